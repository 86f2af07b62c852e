//! The fit benchmark of issue 28: the heavy rig (the paper protocol, `scenarios/paper-protocol-300hz.toml`)
//! at 3 frequencies × 6 amplitudes (200/300/400 Hz, 10–60 µm), data made by djkr with
//! `adhesion.v0 = 60 µm/s`, `adhesion.n = 0.5` and 2 % Gaussian noise (seed 100, as the first
//! seed of `tests/it/fit.rs::coverage_study_heavy_rig`), fitted for v0 and n from the file's values
//! on all cores: the whole `djkr fit` minus its files. Forward runs, iterations and the estimates
//! are printed once. The target is ≤ 60 s on a 2-core machine.
//!
//! `cargo bench --bench fit` (10 samples of one fit each: a few minutes).
use criterion::{criterion_group, criterion_main, Criterion};
use djkr::api;
use djkr::fit::{FitData, ForwardModel};
use djkr::scenario::overrides::Override;
use djkr::scenario::parse::ScenarioSource;
use djkr::sweep::uniform;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

/// A standard normal deviate for (seed, i) (Box–Muller, as `tests/it/fit.rs`).
fn gauss(seed: u64, i: u64) -> f64 {
    let u1 = uniform(seed, i, 0).max(1e-300);
    let u2 = uniform(seed, i, 1);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The data file's text: the truth at each row plus 2 % noise, with sigma.
fn data(source: &ScenarioSource) -> Result<String, String> {
    let rows: Vec<(f64, f64)> = [200.0, 300.0, 400.0]
        .iter()
        .flat_map(|&f| [10.0, 20.0, 30.0, 40.0, 50.0, 60.0].map(|a| (f, a)))
        .collect();
    let head = "base.frequency [Hz],base.amplitude [um],pull_off_amplification [1]";
    let mut csv = format!("{head}\n");
    for (f, a) in &rows {
        csv.push_str(&format!("{f},{a},0\n"));
    }
    let truth = FitData::parse(&csv, "truth.csv", None).map_err(|e| e.to_string())?;
    let fixed = ["adhesion.v0=6e-5", "adhesion.n=0.5"]
        .iter()
        .map(|s| Override::parse(s).map_err(|e| e.to_string()))
        .collect::<Result<Vec<_>, _>>()?;
    let model = ForwardModel::new(source.clone(), truth, Vec::new(), fixed, None, 0)?;
    let values = model
        .predict(&[vec![]], None, &mut || {})
        .map_err(|e| format!("{e:?}"))?
        .remove(0)
        .values;
    let mut out = format!("{head},sigma [1]\n");
    for (i, ((f, a), v)) in rows.iter().zip(&values).enumerate() {
        let s = 0.02 * v;
        let obs = v + s * gauss(100, i as u64);
        out.push_str(&format!("{f},{a},{obs:e},{s:e}\n"));
    }
    Ok(out)
}

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-protocol-300hz.toml");
    let setup = || -> Result<(ScenarioSource, String), String> {
        let source = ScenarioSource::read(&path).map_err(|e| e.to_string())?;
        let text = data(&source)?;
        Ok((source, text))
    };
    let (source, text) = match setup() {
        Ok(s) => s,
        Err(e) => {
            eprintln!("fit bench: {e}");
            return;
        }
    };
    let request = match (
        djkr::fit::FitData::parse(&text, "data.csv", None),
        djkr::fit::FreeKey::parse_all(&["adhesion.v0", "adhesion.n"]),
    ) {
        (Ok(data), Ok(free)) => api::FitRequest::new(source, data, free),
        (Err(e), _) => return eprintln!("fit bench: {e}"),
        (_, Err(e)) => return eprintln!("fit bench: {e}"),
    };
    let fit = || api::fit(&request, None);
    match fit() {
        Ok(r) => {
            let r = &r.report;
            eprintln!(
                "fit: {} forward runs, {} RHS evaluations, {} iterations, converged {}, chi2 \
                 {:.2}, parameters {:?}",
                r.forward_runs,
                r.rhs_evals,
                r.iterations,
                r.converged,
                r.chi2,
                r.parameters
                    .iter()
                    .map(|p| (p.key.clone(), p.value, p.sigma))
                    .collect::<Vec<_>>()
            )
        }
        Err(e) => {
            eprintln!("fit bench: {e}");
            return;
        }
    }
    let mut g = c.benchmark_group("fit");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(90));
    g.bench_function("heavy_rig_3x6_v0_n", |b| b.iter(|| black_box(fit())));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
