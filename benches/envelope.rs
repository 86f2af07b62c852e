//! Envelope following against integrating every period, on the paper protocol
//! (`scenarios/paper-protocol-300hz.toml`, `catalogue::Bundled::PaperProtocol300`, a forward
//! run of `djkr fit`): `solver.envelope = "auto"` must cost no more than `"off"` at the
//! default `envelope_tol = 1e-6`, where the radius barely forgets (μ ≈ 0.997) and the error
//! share leaves skips of tens of periods (RHS evaluations 62 % of `off`'s with samples, 69 %
//! without; above `off`'s while the corrector read P(z) − z as the derivative at the new point
//! and got no further than jumps of two periods), and save more at `envelope_tol = 1e-5` (shown
//! for comparison).
//!
//! - `run/{off,auto}`: the scenario as shipped, at the default tolerances, integrated as `djkr
//!   run` integrates it (an observer that takes the 12 kHz time-series samples, here to drop
//!   them: the samples bound the step, so this is the run's own work without its file output).
//! - `run/auto_tol1e-5`: the same at `envelope_tol = 1e-5`.
//! - `no_samples/{off,auto}`: without an observer of samples (the steps are longer), as a
//!   forward run of a fit or a sweep that keeps no time series integrates it.
//!
//! Before criterion's estimates, the default `off` and `auto` runs are timed alternately
//! (`PAIRS` rounds each way): the median of the per-round ratios auto/off keeps a noisy
//! machine's slow spells out of the comparison (criterion times the benchmarks seconds apart).
//! Each run's deterministic counts (RHS evaluations, the envelope's statistics) are printed once.
//!
//! `cargo bench --bench envelope`
#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
use crate::catalogue::Bundled;
use criterion::{criterion_group, criterion_main, Criterion};
use djkr::scenario::Scenario;
use djkr_core::dynamics::{EnvelopeMode, NoObserver, Observer};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Alternating rounds of auto and off before criterion's estimates.
const PAIRS: usize = 20;

/// Takes the time-series samples as `djkr run`'s writer does, and drops them.
struct Samples;

impl Observer for Samples {}

/// One run, with the samples taken or not.
fn simulate(
    s: &Scenario,
    samples: bool,
) -> Result<djkr_core::dynamics::RunResult, djkr_core::dynamics::SimError> {
    if samples {
        s.simulate(&mut Samples)
    } else {
        s.simulate(&mut NoObserver)
    }
}

/// Run once and print what the benchmark will measure.
fn announce(name: &str, s: &Scenario, samples: bool) -> u64 {
    let t = Instant::now();
    match simulate(s, samples) {
        Ok(r) => {
            eprintln!(
                "{name}: {:.1} ms once; rhs {} steps {}; envelope {:?}; amplification {:.12}",
                t.elapsed().as_secs_f64() * 1e3,
                r.stats.rhs_evals,
                r.stats.steps,
                r.envelope,
                r.pull_off.amplification
            );
            r.stats.rhs_evals
        }
        Err(e) => panic!("{name}: {e}"),
    }
}

fn time_once(s: &Scenario, samples: bool) -> f64 {
    let t = Instant::now();
    let _ = black_box(simulate(black_box(s), samples).map(|r| r.stats.steps));
    t.elapsed().as_secs_f64()
}

/// `PAIRS` alternating rounds of `off` and `auto`: the medians and the median paired ratio.
fn pairs(what: &str, off: &Scenario, auto: &Scenario, samples: bool) {
    let (mut o, mut a, mut ratio) = (vec![], vec![], vec![]);
    for _ in 0..PAIRS {
        let to = time_once(off, samples);
        let ta = time_once(auto, samples);
        o.push(to);
        a.push(ta);
        ratio.push(ta / to);
    }
    for v in [&mut o, &mut a, &mut ratio] {
        v.sort_by(f64::total_cmp);
    }
    let mid = PAIRS / 2;
    eprintln!(
        "{what}: {PAIRS} alternating pairs: off median {:.2} ms, auto median {:.2} ms; \
         auto/off median of the paired ratios {:.4} (quartiles {:.4}, {:.4})",
        o[mid] * 1e3,
        a[mid] * 1e3,
        ratio[mid],
        ratio[PAIRS / 4],
        ratio[3 * PAIRS / 4]
    );
}

fn bench(c: &mut Criterion) {
    let p = match Bundled::PaperProtocol300.scenario() {
        Ok(p) => p,
        Err(e) => panic!("paper_protocol_300hz: cannot load the scenario: {e}"),
    };
    let with = |mode: EnvelopeMode, tol: Option<f64>| {
        let mut s = p.clone();
        s.solver.envelope = mode;
        if let Some(t) = tol {
            s.solver.envelope_tol = t;
        }
        s
    };
    let runs = [
        ("run/off", with(EnvelopeMode::Off, None), true),
        ("run/auto", with(EnvelopeMode::Auto, None), true),
        (
            "run/auto_tol1e-5",
            with(EnvelopeMode::Auto, Some(1e-5)),
            true,
        ),
        ("no_samples/off", with(EnvelopeMode::Off, None), false),
        ("no_samples/auto", with(EnvelopeMode::Auto, None), false),
    ];
    let rhs: Vec<u64> = runs.iter().map(|(n, s, w)| announce(n, s, *w)).collect();
    eprintln!(
        "rhs auto/off {:.5} (run), {:.5} (no_samples); auto_tol1e-5/off {:.5} (run)",
        rhs[1] as f64 / rhs[0] as f64,
        rhs[4] as f64 / rhs[3] as f64,
        rhs[2] as f64 / rhs[0] as f64
    );
    pairs("run", &runs[0].1, &runs[1].1, true);
    pairs("no_samples", &runs[3].1, &runs[4].1, false);

    let mut g = c.benchmark_group("envelope/paper_protocol_300hz");
    g.sample_size(20).measurement_time(Duration::from_secs(10));
    for (name, s, samples) in &runs {
        g.bench_function(*name, |b| {
            b.iter(|| simulate(black_box(s), *samples).map(|r| r.stats.steps))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
