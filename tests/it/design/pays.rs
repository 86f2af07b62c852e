//! `djkr design` (issue 34), opt-in study "design pays": K new measurements chosen by the design
//! shrink σ of adhesion.n, against K spread uniformly, by the factor the design predicted. The
//! design's closed forms are unit tests (`src/fit/design_tests.rs`) and the command's files and
//! refusals `tests/cli/design.rs`.

use djkr::api::{self, FitRequest};
use djkr::fit::{FitData, FreeKey};
use djkr::scenario::overrides::Override;
use djkr::scenario::parse::ScenarioSource;
use djkr::sweep::Axis;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

use crate::fit::{gauss, HEAVY, SHORT};

/// The bundled data: six pull-off amplifications of the cheap rig (`HEAVY` with `SHORT`) made
/// with adhesion.v0 = 60 µm/s and adhesion.n = 0.5 and 2 % noise.
const DATA: &str = "examples/data/pull-off-300hz.csv";
/// The truth the data were made from.
const TRUTH: [&str; 2] = ["adhesion.v0=6e-5", "adhesion.n=0.5"];
/// The candidates, as docs/guide/design.md gives them.
const CANDIDATES: [&str; 2] = [
    "base.amplitude=0um:20um:5",
    "stage[3].speed=30um/s:3000um/s:5log",
];
/// The measurements added.
const K: usize = 6;
/// The relative noise of every measurement.
const REL: f64 = 0.02;

/// The conditions (base amplitude [m], unloading speed [m/s]) of the rows of [`DATA`].
fn data_conditions() -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(DATA).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "base.amplitude [um],stage[3].speed [um/s],pull_off_amplification [1],sigma [1]"
    );
    lines
        .map(|l| {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (c[0] * 1e-6, c[1] * 1e-6)
        })
        .collect()
}

/// The noise-free pull-off amplification at each of `conditions` (SI), from the truth: one
/// [`api::sweep`] of the cheap rig per condition (independent of the fit's forward model).
fn truth(conditions: &[(f64, f64)]) -> Vec<f64> {
    let source = ScenarioSource::read(Path::new(HEAVY)).unwrap();
    conditions
        .iter()
        .map(|(a, v)| {
            let axes: Vec<Axis> = SHORT
                .iter()
                .chain(&TRUTH)
                .map(|s| s.to_string())
                .chain([
                    format!("base.amplitude={a:e}"),
                    format!("stage[3].speed={v:e}"),
                ])
                .map(|s| Axis::parse(&s).unwrap())
                .collect();
            let table = api::sweep(source.clone(), axes, None, 0, None).unwrap();
            let column = table.column("pull_off_amplification").unwrap();
            let values = column.data.as_f64().unwrap();
            assert_eq!(values.len(), 1);
            values[0]
        })
        .collect()
}

/// A fit of adhesion.v0 and adhesion.n on the cheap rig through the library ([`api::fit`]).
fn fit(data: FitData, out: Option<&Path>) -> djkr::fit::FitReport {
    let mut req = FitRequest::new(
        ScenarioSource::read(Path::new(HEAVY)).unwrap(),
        data,
        FreeKey::parse_all(&["adhesion.v0", "adhesion.n"]).unwrap(),
    );
    req.set = Override::parse_all(&SHORT).unwrap();
    req.out = out.map(|d| (d.to_path_buf(), false));
    api::fit(&req, None).unwrap().report
}

/// Data at `conditions` (SI) from `values` with [`REL`] relative Gaussian noise (seed `seed`,
/// row `i` drawing deviate `i`) and that σ.
fn noisy(conditions: &[(f64, f64)], values: &[f64], seed: u64) -> FitData {
    let mut csv = String::from(
        "base.amplitude [m],stage[3].speed [m/s],pull_off_amplification [1],sigma [1]\n",
    );
    for (i, ((a, v), y)) in conditions.iter().zip(values).enumerate() {
        let s = REL * y;
        let obs = y + s * gauss(seed, i as u64);
        csv.push_str(&format!("{a:e},{v:e},{obs:e},{s:e}\n"));
    }
    FitData::parse(&csv, "study.csv", None).unwrap()
}

/// The estimate and σ of adhesion.n in a fit's report, and whether that σ is the curvature's.
/// Where the fit finds the model not linear over one σ it gives no σ but the profile
/// likelihood's 68 % interval: then half its width.
fn n_of(r: &djkr::fit::FitReport) -> (f64, f64, bool) {
    let p = r.parameters.iter().find(|p| p.key == "adhesion.n").unwrap();
    match (p.sigma, p.interval) {
        (Some(s), _) => (p.value, s, true),
        (None, Some([lo, hi])) => (p.value, 0.5 * (hi - lo), false),
        (None, None) => panic!("adhesion.n: neither sigma nor interval"),
    }
}

/// The sample mean and standard deviation.
fn mean_sd(x: &[f64]) -> (f64, f64) {
    let m = x.iter().sum::<f64>() / x.len() as f64;
    let v = x.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64;
    (m, v.sqrt())
}

/// Opt-in study "design pays" (issue 34). The bundled data (six rows of the cheap rig, 2 %
/// noise, v0 = 60 µm/s and n = 0.5) fitted for v0 and n; `djkr design` with `--criterion
/// adhesion.n` chooses K = 6 new measurements among 5 amplitudes × 5 unloading speeds and
/// predicts σ of n after them (`expected_sigma`) and after K spread uniformly over the
/// candidates (`uniform_sigma`). Then for each of `DJKR_STUDY_SEEDS` noise seeds (default 20):
/// fresh 2 % noise on the six base rows and on K new rows at the noise-free truth (one sweep per
/// condition), once at the design's conditions and once at the uniform spread's (the same
/// deviates for both), each refitted with the base rows. The realised factor σ_uniform/σ_design
/// of n, from the refits' σ (their means over the seeds; where a refit finds the model not
/// linear over one σ and gives the profile's interval instead, half its width), must match the
/// predicted one within 25 % (the criterion). Printed beside it: the factor from the
/// spread of the estimates over the seeds (standard deviations of n), whose own relative error
/// with N seeds is about 1/√(N − 1) for independent arms: it must lie within 3 of those of the
/// prediction.
///
/// `cargo test --release --test it design::pays -- --ignored --nocapture`
#[test]
#[ignore = "2 fits per seed on the cheap rig, 20 seeds: minutes"]
fn pays() {
    let seeds: u64 = std::env::var("DJKR_STUDY_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    assert!(seeds >= 10, "the study needs at least 10 seeds");
    let t_all = std::time::Instant::now();
    let dir = tempfile::tempdir().unwrap();

    // The design, from a fit of the bundled data.
    let base_fit = dir.path().join("fit");
    let r0 = fit(
        FitData::read(Path::new(DATA), None).unwrap(),
        Some(&base_fit),
    );
    assert!(r0.converged, "{:?}", r0.termination);
    let out = dir.path().join("design");
    let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .arg("design")
        .arg("--fit")
        .arg(&base_fit)
        .arg("--candidates")
        .args(CANDIDATES)
        .args([
            "--add",
            &K.to_string(),
            "--criterion",
            "adhesion.n",
            "--json",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .expect("djkr runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: Value = serde_json::from_slice(&o.stdout).unwrap();
    let sigma = |name: &str| j[name]["adhesion.n"].as_f64().unwrap();
    let (now, expected, uniform) = (
        sigma("current_sigma"),
        sigma("expected_sigma"),
        sigma("uniform_sigma"),
    );
    let predicted = uniform / expected;

    // The K conditions of each arm (SI), from design.json's chosen rows and design.csv's
    // uniform_repeats, each repeated as often as the arm measures it.
    let mut chosen = Vec::new();
    for c in j["chosen"].as_array().unwrap() {
        let at = (
            c["conditions"]["base.amplitude"].as_f64().unwrap(),
            c["conditions"]["stage[3].speed"].as_f64().unwrap(),
        );
        for _ in 0..c["repeats"].as_u64().unwrap() {
            chosen.push(at);
        }
    }
    let csv = std::fs::read_to_string(out.join("design.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(lines.next().unwrap().starts_with(
        "base.amplitude [m],stage[3].speed [m/s],value [1],sigma_measurement [1],\
         sigma_prediction [1],information [1],repeats [1],uniform_repeats [1]"
    ));
    let mut spread = Vec::new();
    for l in lines {
        let c: Vec<&str> = l.split(',').collect();
        let at = (c[0].parse().unwrap(), c[1].parse().unwrap());
        for _ in 0..c[7].parse::<usize>().unwrap() {
            spread.push(at);
        }
    }
    assert_eq!((chosen.len(), spread.len()), (K, K));
    let show = |v: &[(f64, f64)]| {
        v.iter()
            .map(|(a, s)| format!("({:.3} um, {:.4} um/s)", a * 1e6, s * 1e6))
            .collect::<Vec<_>>()
            .join(" ")
    };
    eprintln!(
        "design (criterion adhesion.n): sigma of n now {now:.4e}, after the design {expected:.4e}, \
         after {K} uniform {uniform:.4e}; predicted factor {predicted:.3}\n  design:  {}\n  \
         uniform: {}",
        show(&chosen),
        show(&spread)
    );

    // The noise-free truth at every row of each arm: base rows first, then the K new ones.
    let base = data_conditions();
    let arms: Vec<Vec<(f64, f64)>> = [&chosen, &spread]
        .iter()
        .map(|new| base.iter().chain(new.iter()).copied().collect())
        .collect();
    let truths: Vec<Vec<f64>> = arms.iter().map(|c| truth(c)).collect();

    // [design, uniform] per seed: the estimate and σ of n.
    let mut est = [Vec::new(), Vec::new()];
    let mut sig = [Vec::new(), Vec::new()];
    let mut profiled = [0, 0];
    for seed in 0..seeds {
        let t0 = std::time::Instant::now();
        for arm in 0..2 {
            let r = fit(noisy(&arms[arm], &truths[arm], 700 + seed), None);
            assert!(r.converged, "seed {seed}, arm {arm}: {:?}", r.termination);
            let (n, s, curvature) = n_of(&r);
            profiled[arm] += usize::from(!curvature);
            est[arm].push(n);
            sig[arm].push(s);
        }
        let i = seed as usize;
        eprintln!(
            "seed {seed}: n design {:.4} ± {:.4e}, uniform {:.4} ± {:.4e}; ratio {:.3}; {:.1} s",
            est[0][i],
            sig[0][i],
            est[1][i],
            sig[1][i],
            sig[1][i] / sig[0][i],
            t0.elapsed().as_secs_f64()
        );
    }
    let (mean_sig_d, mean_sig_u) = (mean_sd(&sig[0]).0, mean_sd(&sig[1]).0);
    let from_sigma = mean_sig_u / mean_sig_d;
    let (mean_d, sd_d) = mean_sd(&est[0]);
    let (mean_u, sd_u) = mean_sd(&est[1]);
    let from_spread = sd_u / sd_d;
    // The relative error of a ratio of two standard deviations of N independent samples each.
    let rel_err = 1.0 / ((seeds - 1) as f64).sqrt();
    eprintln!(
        "design pays over {seeds} seeds: predicted factor {predicted:.3} (sigma of n after 6 \
         uniform {uniform:.4e} / after the design {expected:.4e})\n  from the refits' sigma: \
         {from_sigma:.3} ({:+.1} % of the predicted; mean sigma uniform {mean_sig_u:.4e}, \
         design {mean_sig_d:.4e}; half the profile's interval for {} and {} fits where the \
         model was not linear over one sigma)\n  from the spread of the estimates: \
         {from_spread:.3} ({:+.1} %, its own relative error about {:.0} %; sd uniform \
         {sd_u:.4e}, design {sd_d:.4e}; mean n uniform {mean_u:.4}, design {mean_d:.4})\n  \
         {:.0} s",
        100.0 * (from_sigma / predicted - 1.0),
        profiled[1],
        profiled[0],
        100.0 * (from_spread / predicted - 1.0),
        100.0 * rel_err,
        t_all.elapsed().as_secs_f64()
    );
    assert!(
        (from_sigma / predicted - 1.0).abs() <= 0.25,
        "the refits' sigma give the factor {from_sigma:.3}, design predicted {predicted:.3}"
    );
    assert!(
        (from_spread / predicted).ln().abs() <= 3.0 * rel_err,
        "the estimates' spread gives the factor {from_spread:.3}, design predicted \
         {predicted:.3} (relative error of the spread's factor about {rel_err:.2})"
    );
}
