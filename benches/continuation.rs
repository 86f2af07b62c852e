//! Continuation benchmarks on the bundled `scenarios/resonance-400hz.toml` at X_b = 1.5 µm, the
//! hysteretic resonance the tests check:
//!
//! - `continuation/branch_340-600Hz`: the whole branch of periodic orbits over 340–600 Hz,
//!   unstable middle part, both folds (located) and Floquet multipliers included, from the
//!   scene's start (issue 14 target: ≤ 1 s). The points, periods and folds are printed once.
//! - `continuation/fold_curves_1.5-0.5um`: the folds of that branch followed in X_b down to
//!   0.5 µm, through the cusp.
//!
//! `cargo bench --bench continuation`.
use criterion::{criterion_group, criterion_main, Criterion};
use djkr::scenario::family::{family, parameter};
use djkr::scenario::overrides::Override;
use djkr::scenario::parse::ScenarioSource;
use djkr_core::continuation::branch::{self, PointKind, Settings};
use djkr_core::continuation::family::Family;
use djkr_core::continuation::folds;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/resonance-400hz.toml");
    let setup = || -> Result<(Family, Family), String> {
        let src = ScenarioSource::read(&path).map_err(|e| e.to_string())?;
        let f = parameter("--param", "base.frequency").map_err(|e| e.to_string())?;
        let x = parameter("--fold-param", "base.amplitude").map_err(|e| e.to_string())?;
        let amp = Override::parse("base.amplitude=1.5um").map_err(|e| e.to_string())?;
        let one = family(&src, &[amp], vec![f], 1e-10).map_err(|e| e.to_string())?;
        let two = family(&src, &[], vec![f, x], 1e-10).map_err(|e| e.to_string())?;
        Ok((one, two))
    };
    let (one, two) = match setup() {
        Ok(f) => f,
        Err(e) => {
            eprintln!("{e}");
            return;
        }
    };
    let set = Settings::default();
    let run = || branch::continue_branch(&one, (340.0, 600.0), &set, &mut |_| {});
    let b = match run() {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{e}");
            return;
        }
    };
    let folds: Vec<f64> = b.of_kind(PointKind::Fold).map(|p| p.value).collect();
    eprintln!(
        "branch 340-600 Hz: {} points, {} steps ({} refused, {} located), {} periods, {:.3} s once; folds {folds:?}",
        b.points.len(),
        b.work.steps,
        b.work.rejected,
        b.work.located,
        b.periods,
        b.wall_s
    );
    let mut g = c.benchmark_group("continuation");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("branch_340-600Hz", |bch| {
        bch.iter(|| black_box(run().is_ok()))
    });
    g.bench_function("fold_curves_1.5-0.5um", |bch| {
        bch.iter(|| {
            black_box(
                folds::continue_folds(&two, &b, (1.5e-6, 0.5e-6), &set.engine, &mut |_, _| {})
                    .is_ok(),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
