//! Per-method comparison (issue 5): one base cycle, a steady 1 s at 400 Hz, and the paper's
//! protocol at 300 Hz (scenarios/paper-protocol-300hz.toml), for each integrator; the scenes
//! come from `crate::catalogue`. The RHS and the
//! hot path are benchmarked in benches/dynamics.rs; the accuracy of each (method, tolerance) is
//! measured by `djkr accuracy` (src/accuracy.rs) on the same scenes.
//!
//!   cargo bench --bench methods
//!
//! A method that cannot run a scene (an explicit method meeting G ≤ 0) is reported and skipped,
//! not benchmarked; so is one slower than 10 s (its wall-clock budget here). The 1 s / 400 Hz
//! scene is run at rtol 1e-8 (the default), at 5e-9 and at 4e-10: the tolerances whose
//! pull-off-relevant error is near or below 1e-6 with DP8 (1e-8: 2.5e-6; 5e-9: 4.2e-7) and with
//! the implicit method (4e-10: 8.6e-7) in
//! `djkr accuracy docs/accuracy/hold-400hz-1s.toml --tolerances 1e-8,5e-9,1e-9,4e-10`
//! (the target: 1e-6 in ≤ 10 ms).

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
use crate::catalogue::{hold_400hz_1s, vibrating_hold, Bundled};
use criterion::{criterion_group, criterion_main, Criterion};
use djkr::accuracy::{method_label, method_name};
use djkr::scenario::Scenario;
use djkr_core::dynamics::Method;
use djkr_core::dynamics::NoObserver;
use std::hint::black_box;
use std::time::Duration;

const METHODS: [Method; 5] = [
    Method::Implicit,
    Method::Dp8,
    Method::Dopri5,
    Method::Dop853,
    Method::Auto,
];

fn runs(s: &Scenario, label: &str) -> bool {
    match s.simulate(&mut NoObserver) {
        Ok(r) => {
            eprintln!(
                "{label}: {} steps, {} rhs, ran {}",
                r.stats.steps,
                r.stats.rhs_evals,
                method_label(method_name(s.solver.method), &r.method)
            );
            true
        }
        Err(e) => {
            let msg: String = e.to_string().chars().take(160).collect();
            eprintln!("{label}: skipped, the method fails: {msg}");
            false
        }
    }
}

fn bench_scene(c: &mut Criterion, group: &str, base: &Scenario, rtols: &[f64]) {
    let mut g = c.benchmark_group(group);
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for &rtol in rtols {
        for m in METHODS {
            let mut s = base.clone();
            s.solver.method = m;
            s.solver.rtol = rtol;
            s.solver.atol = 0.01 * rtol;
            // A run slower than 10 s (dop853 crawling) is reported and not benchmarked.
            s.solver.max_wall_s = 10.0;
            let id = format!("{}/rtol{rtol:e}", method_name(m));
            if runs(&s, &format!("{group}/{id}")) {
                g.bench_function(id, |b| {
                    b.iter(|| black_box(black_box(&s).simulate(&mut NoObserver)))
                });
            }
        }
    }
    g.finish();
}

fn bench(c: &mut Criterion) {
    bench_scene(
        c,
        "one_cycle_400Hz",
        &vibrating_hold(5e-6, 400.0, 1.0 / 400.0),
        &[1e-8],
    );
    bench_scene(c, "steady_1s_400Hz", &hold_400hz_1s(), &[1e-8, 5e-9, 4e-10]);
    match Bundled::PaperProtocol300.scenario() {
        Ok(s) => {
            let rtol = s.solver.rtol;
            bench_scene(c, "paper_protocol_300Hz", &s, &[rtol]);
        }
        Err(e) => eprintln!("paper protocol: cannot load: {e}"),
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
