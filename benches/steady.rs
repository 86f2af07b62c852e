//! Steady-state benchmarks on the bundled `scenarios/resonance-400hz.toml`
//! (`catalogue::Bundled::Resonance400`, the scene the tests check):
//!
//! - `steady_400Hz/shooting`, `steady_400Hz/time-stepping`: the periodic steady state at 400 Hz
//!   from the scene's initial state (JKR equilibrium under the 50 mN preload), by Newton on the
//!   one-cycle map and by plain time-stepping with stroboscopic detection, both to the default
//!   tolerance 1e-8 at rtol 1e-10. The periods each integrates are printed once.
//! - `sweep_100/both`: a 100-frequency sweep 300–500 Hz, up and down in parallel (rayon), each
//!   frequency started from the previous steady state, with the harmonic-balance predictor
//!   (issue 4 target: ≤ 10 s on 2 cores); `sweep_100/up`: the up sweep alone, without
//!   harmonic balance (the time-domain part).
//!
//! `cargo bench --bench steady`.
#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
use crate::catalogue::Bundled;
use criterion::{criterion_group, criterion_main, Criterion};
use djkr_core::steady::sweep::{self, Direction, Linearisation};
use djkr_core::steady::{Options, Problem, Strategy};
use std::hint::black_box;
use std::time::{Duration, Instant};

fn bench(c: &mut Criterion) {
    let scn = match Bundled::Resonance400.scenario() {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            return;
        }
    };
    let (problem, start) = match Problem::from_plan(&scn.plan()) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("{e}");
            return;
        }
    };

    let mut g = c.benchmark_group("steady_400Hz");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (name, strategy) in [
        ("shooting", Strategy::Shooting),
        ("time-stepping", Strategy::TimeStepping),
    ] {
        let o = Options {
            strategy,
            ..Options::default()
        };
        let t = Instant::now();
        match problem.solve(&start, &o) {
            Ok(s) => eprintln!(
                "steady_400Hz/{name}: {:.2} ms once; {} periods, {} Newton iterations, residual \
                 {:.2e}, distance {:.2e}; |δ_A/X_b| = {:.6}, F_m = {:.9} N",
                t.elapsed().as_secs_f64() * 1e3,
                s.cycles,
                s.newton_iterations,
                s.residual,
                s.distance,
                s.transfer_magnitude(),
                s.cycle.force_mean
            ),
            Err(e) => {
                eprintln!("steady_400Hz/{name}: fails ({e})");
                continue;
            }
        }
        g.bench_function(name, |b| {
            b.iter(|| black_box(problem.solve(black_box(&start), &o).ok()))
        });
    }
    g.finish();

    let freqs = sweep::frequencies(300.0, 500.0, 100);
    let o = Options::default();
    let lin = Linearisation::for_problem(&problem, &start).ok();
    let mut g = c.benchmark_group("sweep_100");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    let t = Instant::now();
    let (up, down) = sweep::sweep_both(&problem, &start, &freqs, &o, lin.as_ref(), &|_, _| {});
    eprintln!(
        "sweep_100/both: {:.3} s once; periods up {} down {}; peak up {:?}, down {:?}",
        t.elapsed().as_secs_f64(),
        up.cycles,
        down.cycles,
        sweep::peak(&up.points),
        sweep::peak(&down.points)
    );
    g.bench_function("both", |b| {
        b.iter(|| {
            black_box(sweep::sweep_both(
                &problem,
                &start,
                &freqs,
                &o,
                lin.as_ref(),
                &|_, _| {},
            ))
        })
    });
    g.bench_function("up", |b| {
        b.iter(|| {
            black_box(sweep::sweep(
                &problem,
                &start,
                &freqs,
                Direction::Up,
                &o,
                None,
                &|_, _| {},
            ))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
