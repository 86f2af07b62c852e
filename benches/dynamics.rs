//! Time-domain simulator benchmarks (criterion medians are what the module docs quote).
//!
//! - `one_rhs`: one implicit-stage residual with its derivative (mechanical closed form, signed
//!   G, GS law in the z variable): the unit of `Stats::rhs_evals` for the implicit method.
//! - `one_rhs_dp8`: one explicit right-hand side as a DP8 stage evaluates it (G, ȧ = law⁻¹(G),
//!   acceleration, the 17 quadrature integrands into the stage sum; the base phase advanced from
//!   the step start): the unit of `Stats::rhs_evals` for DP8.
//! - `one_cycle_400Hz/{implicit,dp8}`: one base period of `catalogue::vibrating_hold(5 µm,
//!   400 Hz)`.
//! - `vibration_1s_400Hz/{method}`: 1 s of that hold at rtol 1e-8, `catalogue::hold_400hz_1s`
//!   (issue 3 target: ≤ 20 ms).
//!   Dopri5 and Dop853 (`ode_solvers`) cannot integrate this scene (the contact heals to
//!   G/w0 ≈ 0.01 every cycle and a trial stage meets G ≤ 0); they are benchmarked on the same
//!   hold at 1 µm (`vibration_1um_1s_400Hz/…`), where every method runs.
//! - `paper_protocol_300hz/{method}`: the shipped `scenarios/paper-protocol-300hz.toml`
//!   (`catalogue::Bundled::PaperProtocol300`; issue 3 target: ≤ 2 s).
//! - `peer_vib400_rtol1e-7/auto`: the compiled peer's benchmark scene
//!   (`benches/scenes/vib400.toml`) at rtol 1e-7, where djkr's error is below the peer's at
//!   1e-8; with `one_rhs_dp8` it gives the integration's overhead over its RHS work (measured
//!   in pairs, robust to a noisy machine, by `benches/overhead.rs`).
//!
//! Every scene but the peer's comes from `crate::catalogue`, the scenes the tests prove correct.
//!
//! `cargo bench --bench dynamics`; each benchmark prints its `Stats` once (steps, rhs), so
//! wall / (rhs × one_rhs) can be formed.
#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use crate::catalogue::{vibrating_hold, Bundled};
use criterion::{criterion_group, criterion_main, Criterion};
use djkr::scenario::Scenario;
use djkr_core::dynamics::Method;
use djkr_core::dynamics::NoObserver;
use std::hint::black_box;
use std::time::{Duration, Instant};

const METHODS: [(&str, Method); 5] = [
    ("implicit", Method::Implicit),
    ("dp8", Method::Dp8),
    ("dopri5", Method::Dopri5),
    ("dop853", Method::Dop853),
    ("auto", Method::Auto),
];

/// Run once and print what the benchmark will measure; `false` when the method fails there.
fn announce(name: &str, s: &Scenario) -> bool {
    let t = Instant::now();
    match s.simulate(&mut NoObserver) {
        Ok(r) => {
            eprintln!(
                "{name}: {:.1} ms once; steps {} rejected {} rhs {}; {}",
                t.elapsed().as_secs_f64() * 1e3,
                r.stats.steps,
                r.stats.rejected,
                r.stats.rhs_evals,
                r.method
            );
            true
        }
        Err(e) => {
            let e = e.to_string();
            eprintln!("{name}: fails ({})", &e[..e.len().min(160)]);
            false
        }
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("dynamics");
    g.sample_size(10).measurement_time(Duration::from_secs(5));

    // One implicit-stage residual with its derivative, as the Newton iteration evaluates it.
    let (model, drive) = common::hold_model_and_drive();
    let kin = drive.at(&model, 1e-4);
    let (ck, hg) = (1.1e-3, 1e-6);
    g.bench_function("one_rhs", |b| {
        let mut z = 0.3;
        b.iter(|| {
            z += 1e-9;
            let za: f64 = black_box(z);
            let pw = (za.ln() / 0.531).exp();
            let a = ck + hg * 4.45e-5 * pw;
            let (x, dx) = model.position_slope(&kin, a, 1e-5, 0.0, hg);
            let u = a * a / model.mat.r - (x + kin.xb);
            let g = 3.0 * model.mat.k * u * u.abs() / (8.0 * std::f64::consts::PI * a);
            black_box((g - model.w0 / (1.0 + za), dx))
        })
    });

    // One DP8 stage evaluation, in contact and healing (G < w0), with its quadrature sum.
    let mut one = common::OneRhs::new();
    g.bench_function("one_rhs_dp8", |b| b.iter(|| black_box(one.call())));

    // One base period (400 Hz) of the 5 µm hold.
    for (name, m) in [("implicit", Method::Implicit), ("dp8", Method::Dp8)] {
        let mut one = vibrating_hold(5e-6, 400.0, 1.0 / 400.0);
        one.solver.method = m;
        let id = format!("one_cycle_400Hz/{name}");
        if announce(&id, &one) {
            g.bench_function(id, |b| {
                b.iter(|| {
                    black_box(&one)
                        .simulate(&mut NoObserver)
                        .map(|r| r.stats.steps)
                })
            });
        }
    }

    for (xb, tag) in [
        (5e-6, "vibration_1s_400Hz"),
        (1e-6, "vibration_1um_1s_400Hz"),
    ] {
        for (name, m) in METHODS {
            let mut s = vibrating_hold(xb, 400.0, 1.0);
            s.solver.method = m;
            let id = format!("{tag}/{name}");
            if announce(&id, &s) {
                g.bench_function(id, |b| {
                    b.iter(|| {
                        black_box(&s)
                            .simulate(&mut NoObserver)
                            .map(|r| r.stats.steps)
                    })
                });
            }
        }
    }

    match Bundled::PaperProtocol300.scenario() {
        Ok(p) => {
            for (name, m) in METHODS {
                let mut s = p.clone();
                s.solver.method = m;
                let id = format!("paper_protocol_300hz/{name}");
                if announce(&id, &s) {
                    g.bench_function(id, |b| {
                        b.iter(|| {
                            black_box(&s)
                                .simulate(&mut NoObserver)
                                .map(|r| r.stats.steps)
                        })
                    });
                }
            }
        }
        Err(e) => eprintln!("paper_protocol_300hz: cannot load the scenario: {e}"),
    }

    // The compiled peer's benchmark scene at djkr's equal-accuracy tolerance, in process (no
    // start-up, no files): its time over rhs × one_rhs_dp8 is the integration's overhead.
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/scenes/vib400.toml");
    match djkr::scenario::parse::load_scenario(&file) {
        Ok(mut s) => {
            s.solver.rtol = 1e-7;
            let id = "peer_vib400_rtol1e-7/auto";
            if announce(id, &s) {
                g.bench_function(id, |b| {
                    b.iter(|| {
                        black_box(&s)
                            .simulate(&mut NoObserver)
                            .map(|r| r.stats.steps)
                    })
                });
            }
        }
        Err(e) => eprintln!("peer_vib400: cannot load {}: {e}", file.display()),
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
