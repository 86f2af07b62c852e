//! `djkr fit`: recovery of known constants from data djkr made itself (with Gaussian noise), the
//! fitted scenario reproducing the fitted values, and the one-line refusals of bad input.

use djkr::fit::{FitData, ForwardModel};
use djkr::scenario::overrides::{Override, SetKey};
use djkr::scenario::parse::ScenarioSource;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

pub(crate) const HEAVY: &str = "scenarios/paper-protocol-300hz.toml";

fn djkr(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .output()
        .expect("djkr runs")
}

/// A standard normal deviate for (seed, i), by Box–Muller on the ensemble's counter-based
/// uniform numbers (reproducible, no dependency).
pub(crate) fn gauss(seed: u64, i: u64) -> f64 {
    use djkr::sweep::uniform;
    let u1 = uniform(seed, i, 0).max(1e-300);
    let u2 = uniform(seed, i, 1);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Header of the two-condition data files (and of [`cells2`]'s cells).
const COND2: &str = "base.frequency [Hz],base.amplitude [um]";
/// Header of the three-condition data files (and of [`cells3`]'s cells).
const COND3: &str = "base.frequency [Hz],base.amplitude [um],stage[3].speed [um/s]";

fn cells2(conditions: &[(f64, f64)]) -> Vec<String> {
    conditions.iter().map(|(f, a)| format!("{f},{a}")).collect()
}

fn cells3(rows: &[(f64, f64, f64)]) -> Vec<String> {
    rows.iter()
        .map(|(f, a, v)| format!("{f},{a},{v}"))
        .collect()
}

/// The pull-off amplification djkr predicts for rows of conditions (`cells`, under the CSV
/// header `header`) on `scenario` with `sets` (`KEY=VALUE`) applied.
pub(crate) fn truth(scenario: &str, header: &str, cells: &[String], sets: &[&str]) -> Vec<f64> {
    let mut csv = format!("{header},pull_off_amplification [1]\n");
    for c in cells {
        csv.push_str(&format!("{c},0\n"));
    }
    let data = FitData::parse(&csv, "truth.csv", None).unwrap();
    let source = ScenarioSource::read(Path::new(scenario)).unwrap();
    let fixed: Vec<Override> = sets.iter().map(|s| Override::parse(s).unwrap()).collect();
    let model = ForwardModel::new(source, data, Vec::<SetKey>::new(), fixed, None, 0).unwrap();
    model.predict(&[vec![]], None, &mut || {}).unwrap()[0]
        .values
        .clone()
}

/// Write a data file of `values` at the rows of conditions `cells` (under `header`) with `rel`
/// relative Gaussian noise (seed `seed`) and sigma.
pub(crate) fn write_data(
    path: &Path,
    header: &str,
    cells: &[String],
    values: &[f64],
    rel: f64,
    seed: u64,
) {
    let mut csv = format!("{header},pull_off_amplification [1],sigma [1]\n");
    for (i, (c, v)) in cells.iter().zip(values).enumerate() {
        let s = rel * v;
        let obs = v + s * gauss(seed, i as u64);
        csv.push_str(&format!("{c},{obs:e},{s:e}\n"));
    }
    std::fs::write(path, csv).unwrap();
}

fn fit_json(out: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("fit.json")).unwrap()).unwrap()
}

fn param<'a>(j: &'a Value, key: &str) -> &'a Value {
    j["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["key"] == key)
        .unwrap_or_else(|| panic!("{key} in {j}"))
}

/// The two estimates and their sigma (NaN where none) of fit.json `j` for the keys of `truth`,
/// and whether both lie within 3 sigma of their true values.
fn estimates(j: &Value, truth: [(&str, f64); 2]) -> ([f64; 2], [f64; 2], bool) {
    let mut e = [0.0; 2];
    let mut s = [0.0; 2];
    let mut ok = true;
    for (i, (key, t)) in truth.iter().enumerate() {
        let p = param(j, key);
        e[i] = p["value"].as_f64().unwrap();
        s[i] = p["sigma"].as_f64().unwrap_or(f64::NAN);
        ok &= (e[i] - t).abs() < 3.0 * s[i];
    }
    (e, s, ok)
}

/// Per parameter of a coverage study: the mean reported sigma over the spread (sample standard
/// deviation) of the estimates, printed with both.
fn sigma_over_spread(est: &[[f64; 2]], sig: &[[f64; 2]]) -> [f64; 2] {
    let count = est.len() as f64;
    let mut ratios = [0.0; 2];
    for (i, r) in ratios.iter_mut().enumerate() {
        let m = est.iter().map(|e| e[i]).sum::<f64>() / count;
        let spread = (est.iter().map(|e| (e[i] - m).powi(2)).sum::<f64>() / (count - 1.0)).sqrt();
        let mean_sigma = sig.iter().map(|s| s[i]).sum::<f64>() / count;
        *r = mean_sigma / spread;
        eprintln!(
            "param {i}: mean estimate {m:.4e}, spread {spread:.4e}, mean sigma {mean_sigma:.4e}, \
             ratio {r:.3}"
        );
    }
    ratios
}

/// Run `djkr fit` and return fit.json (panics with stderr on failure).
fn run_fit(data: &Path, out: &Path, scenario: &str, extra: &[&str]) -> Value {
    let mut args = vec![
        "fit",
        data.to_str().unwrap(),
        "--scenario",
        scenario,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = djkr(&args);
    assert!(
        o.status.success(),
        "{:?}: {}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    fit_json(out)
}

/// The heavy rig (paper protocol) with v0 and n moved from the paper's values (4.45e-5 m/s,
/// 0.531) and 2 % noise: the fit from the paper's values recovers both within 3 sigma, says it
/// converged, and `djkr run fitted.toml` with a row's conditions gives that row's fitted value
/// to the bit. Six rows (two frequencies, three amplitudes) keep it short; the full 3 x 6 study
/// over 20 seeds is `coverage_study_heavy_rig` (--ignored).
#[test]
fn fit_recovers_v0_and_n_on_the_heavy_rig() {
    let dir = tempfile::tempdir().unwrap();
    let (v0, n) = (6e-5, 0.5);
    let cond: Vec<(f64, f64)> = [300.0, 400.0]
        .iter()
        .flat_map(|&f| [10.0, 30.0, 60.0].map(|a| (f, a)))
        .collect();
    let sets = [format!("adhesion.v0={v0}"), format!("adhesion.n={n}")];
    let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
    let values = truth(HEAVY, COND2, &cells2(&cond), &sets);
    let data = dir.path().join("data.csv");
    write_data(&data, COND2, &cells2(&cond), &values, 0.02, 7);
    let out = dir.path().join("fit");
    let t0 = std::time::Instant::now();
    let j = run_fit(
        &data,
        &out,
        HEAVY,
        &["--free", "adhesion.v0", "--free", "adhesion.n"],
    );
    eprintln!(
        "fit: {} forward runs, {:.1} s wall: {j}",
        j["forward_runs"],
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(j["converged"], true, "{j}");
    for (key, t) in [("adhesion.v0", v0), ("adhesion.n", n)] {
        let p = param(&j, key);
        let (v, s) = (p["value"].as_f64().unwrap(), p["sigma"].as_f64().unwrap());
        assert!(s > 0.0 && s < 0.5 * t, "{key}: sigma {s}");
        assert!((v - t).abs() < 3.0 * s, "{key}: {v} ± {s}, truth {t}");
    }
    assert_eq!(param(&j, "adhesion.v0")["unit"], "m/s");
    assert_eq!(param(&j, "adhesion.v0")["initial"].as_f64(), Some(4.45e-5));
    let k = 2.0;
    let chi2 = j["chi2"].as_f64().unwrap();
    assert_eq!(j["dof"], 4);
    assert!((j["aic"].as_f64().unwrap() - (chi2 + 2.0 * k)).abs() < 1e-12);
    assert!((j["bic"].as_f64().unwrap() - (chi2 + k * 6f64.ln())).abs() < 1e-12);
    assert_eq!(j["observable"], "pull_off_amplification");
    for f in ["residuals.csv", "fitted.toml", "fit.png", "fit.svg"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // fitted.toml reproduces a row's fitted value (row 4: 400 Hz, 30 um).
    let res = std::fs::read_to_string(out.join("residuals.csv")).unwrap();
    let row: Vec<&str> = res.lines().nth(5).unwrap().split(',').collect();
    let run_out = dir.path().join("run");
    let o = djkr(&[
        "run",
        out.join("fitted.toml").to_str().unwrap(),
        "--set",
        &format!("base.frequency={}", row[0]),
        "--set",
        &format!("base.amplitude={}", row[1]),
        "--out",
        run_out.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: Value = serde_json::from_slice(&o.stdout).unwrap();
    let fitted: f64 = row[4].parse().unwrap();
    assert_eq!(
        s["pull_off"]["amplification"].as_f64().unwrap().to_bits(),
        fitted.to_bits(),
        "{row:?}"
    );
}

/// Bad input is refused with one line and exit status 2, before any run.
#[test]
fn bad_input_is_refused_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.csv");
    std::fs::write(
        &good,
        "base.amplitude [um],pull_off_amplification [1]\n10,1.7\n20,2.1\n30,3\n",
    )
    .unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "base.amplitude [um],pull_off_amplification [1]\n10,1.7\n20,abc\n",
    )
    .unwrap();
    let unknown = dir.path().join("unknown.csv");
    std::fs::write(
        &unknown,
        "base.wobble [um],pull_off_amplification [1]\n10,1.7\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    let g = good.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![bad.to_str().unwrap(), "--free", "adhesion.n"],
            "line 3, column 2",
        ),
        (
            vec![unknown.to_str().unwrap(), "--free", "adhesion.n"],
            "neither a scenario key",
        ),
        (vec![g, "--free", "adhesion.wobble"], "adhesion.wobble"),
        (vec![g, "--free", "adhesion.law"], "not a numeric key"),
        (
            vec![g, "--free", "adhesion.n", "--observable", "wall_s"],
            "does not produce",
        ),
        (
            vec![g, "--free", "adhesion.n", "--observable", "delta_amp"],
            "no delta_amp column",
        ),
        (vec![g, "--free", "base.amplitude"], "both"),
        (vec![g, "--free", "adhesion.v_sat"], "--set adhesion.v_sat"),
        (
            vec![g, "--free", "adhesion.n=0.6:0.9"],
            "outside the bounds",
        ),
    ];
    for (args, want) in cases {
        let mut all = vec!["fit"];
        all.extend(args.iter().copied());
        all.extend(["--scenario", HEAVY, "--out", o]);
        let r = djkr(&all);
        let e = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{all:?}: {e}");
        assert_eq!(e.trim_end().lines().count(), 1, "{all:?}: {e}");
        assert!(e.contains(want), "{all:?}: {e}");
    }
    assert!(!out.exists(), "a refused fit wrote nothing");
}

/// Opt-in: the 3 x 6 heavy-rig study over 20 seeds: every estimate within 3 sigma in >= 18 of
/// 20, and the reported sigma within a factor 1.5 of the estimates' spread.
#[test]
#[ignore = "about 20 fits of 18 rows: minutes"]
fn coverage_study_heavy_rig() {
    let dir = tempfile::tempdir().unwrap();
    let (v0, n) = (6e-5, 0.5);
    let cond: Vec<(f64, f64)> = [200.0, 300.0, 400.0]
        .iter()
        .flat_map(|&f| [10.0, 20.0, 30.0, 40.0, 50.0, 60.0].map(|a| (f, a)))
        .collect();
    let sets = [format!("adhesion.v0={v0}"), format!("adhesion.n={n}")];
    let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
    let values = truth(HEAVY, COND2, &cells2(&cond), &sets);
    let mut inside = 0;
    let mut est: Vec<[f64; 2]> = Vec::new();
    let mut sig: Vec<[f64; 2]> = Vec::new();
    let seeds = 20;
    for seed in 0..seeds {
        let data = dir.path().join(format!("data{seed}.csv"));
        write_data(&data, COND2, &cells2(&cond), &values, 0.02, 100 + seed);
        let out = dir.path().join(format!("fit{seed}"));
        let t0 = std::time::Instant::now();
        let j = run_fit(
            &data,
            &out,
            HEAVY,
            &["--free", "adhesion.v0", "--free", "adhesion.n"],
        );
        let (e, s, ok) = estimates(&j, [("adhesion.v0", v0), ("adhesion.n", n)]);
        eprintln!(
            "seed {seed}: v0 {:.4e} ± {:.2e}, n {:.4} ± {:.4}, {} runs, {:.1} s, converged {}",
            e[0],
            s[0],
            e[1],
            s[1],
            j["forward_runs"],
            t0.elapsed().as_secs_f64(),
            j["converged"]
        );
        inside += usize::from(ok);
        est.push(e);
        sig.push(s);
    }
    eprintln!("heavy rig, {seeds} seeds: {inside} with both estimates within 3 sigma");
    assert!(inside >= 18, "{inside} of {seeds} within 3 sigma");
    for (i, ratio) in sigma_over_spread(&est, &sig).iter().enumerate() {
        assert!((1.0 / 1.5..=1.5).contains(ratio), "param {i}: {ratio}");
    }
}

/// The rows of the law comparison (docs/guide/fit.md, "Comparing laws"), on the paper protocol
/// with short dwells (0.1 s, 0.2 s): two vibrating rows (300 Hz, 5 and 10 um, unloading at
/// 100 um/s; the saturated law's values fall > 10 % below the plain law's) and five rows without
/// vibration unloading at 30 um/s to 3 mm/s, which pin the law at crack speeds below and above
/// v_sat. (With vibrating rows alone, 200 and 400 Hz at 1 to 10 um, a plain law with n about 0.2
/// mimicked the saturated data: AIC 6.0 against 7.8.)
struct LawComparison {
    dir: tempfile::TempDir,
    rows: Vec<(f64, f64, f64)>,
}

impl LawComparison {
    const SHORT: [&'static str; 2] = ["stage[1].duration=0.1", "stage[2].duration=0.2"];

    fn new() -> Self {
        let mut rows: Vec<(f64, f64, f64)> = vec![(300.0, 5.0, 100.0), (300.0, 10.0, 100.0)];
        rows.extend([30.0, 100.0, 300.0, 1000.0, 3000.0].map(|v| (300.0, 0.0, v)));
        LawComparison {
            dir: tempfile::tempdir().unwrap(),
            rows,
        }
    }

    /// The noise-free values of the rows by the plain law, or by the saturated law with
    /// v_sat = 1 mm/s.
    fn truth(&self, saturated: bool) -> Vec<f64> {
        let law = ["adhesion.law=gent-schultz-saturated", "adhesion.v_sat=1e-3"];
        let extra: &[&str] = if saturated { &law } else { &[] };
        let sets: Vec<&str> = Self::SHORT.iter().chain(extra).copied().collect();
        truth(HEAVY, COND3, &cells3(&self.rows), &sets)
    }

    /// The data `values` with 2 % noise (seed 11), fitted by the plain law (v0, n free) and by the
    /// saturated law (v0, n, v_sat free, v_sat from 3 mm/s within 10 um/s to 1 m/s).
    fn fit_both(&self, name: &str, values: &[f64]) -> (Value, Value) {
        let data = self.dir.path().join(format!("{name}.csv"));
        write_data(&data, COND3, &cells3(&self.rows), values, 0.02, 11);
        let args = |extra: &[&str], free: &[&str]| -> Vec<String> {
            let sets = Self::SHORT.iter().chain(extra);
            let sets = sets.flat_map(|s| ["--set".to_string(), s.to_string()]);
            let free = free
                .iter()
                .flat_map(|k| ["--free".to_string(), k.to_string()]);
            sets.chain(free).collect()
        };
        let fit = |what: &str, a: Vec<String>| -> Value {
            let a: Vec<&str> = a.iter().map(String::as_str).collect();
            let t0 = std::time::Instant::now();
            let out = self.dir.path().join(format!("{name}-{what}"));
            let j = run_fit(&data, &out, HEAVY, &a);
            eprintln!("{name}, {what} ({:.1} s): {j}", t0.elapsed().as_secs_f64());
            j
        };
        let p = fit("plain", args(&[], &["adhesion.v0", "adhesion.n"]));
        let s = fit(
            "saturated",
            args(
                &["adhesion.law=gent-schultz-saturated", "adhesion.v_sat=3e-3"],
                &["adhesion.v0", "adhesion.n", "adhesion.v_sat=1e-5:1"],
            ),
        );
        (p, s)
    }
}

fn aic(j: &Value) -> f64 {
    j["aic"].as_f64().unwrap()
}

/// Data from the plain law, fitted by both laws: the saturated fit's v_sat runs to its bound or
/// its AIC is not lower by more than 2 (the extra key buys nothing). About 5 s (two-core release
/// build).
#[test]
fn a_saturated_law_gains_nothing_on_plain_data() {
    let case = LawComparison::new();
    let (p, s) = case.fit_both("plain-data", &case.truth(false));
    let v_sat = param(&s, "adhesion.v_sat");
    let at_bound = v_sat["sigma"].is_null()
        && s["notes"].as_array().unwrap().iter().any(|n| {
            n.as_str()
                .unwrap()
                .contains("adhesion.v_sat ran to its bound")
        });
    assert!(
        at_bound || aic(&p) - aic(&s) <= 2.0,
        "AIC plain {} saturated {}: {s}",
        aic(&p),
        aic(&s)
    );
}

/// An estimate for the law comparison's table: the value and its sigma (`a ± s`), or, where the
/// fit gives no sigma, its profile-likelihood interval (`a (lo to hi)`), in `unit` (`scale` SI
/// units per unit) to two significant digits of the uncertainty.
fn estimate_cell(p: &Value, name: &str, unit: &str, scale: f64) -> String {
    let v = p["value"].as_f64().unwrap() / scale;
    let sig = |x: f64| {
        let digits = (1 - x.abs().log10().floor() as i32).max(0) as usize;
        format!("{x:.digits$}")
    };
    match p["sigma"].as_f64() {
        Some(s) => {
            let s = s / scale;
            let digits = (1 - s.log10().floor() as i32).max(0) as usize;
            format!("{name} = {v:.digits$} ± {s:.digits$}{unit}")
        }
        None => {
            let i = p["interval"].as_array().unwrap();
            let (lo, hi) = (
                i[0].as_f64().unwrap() / scale,
                i[1].as_f64().unwrap() / scale,
            );
            format!("{name} = {} ({} to {}){unit}", sig(v), sig(lo), sig(hi))
        }
    }
}

/// The law comparison (the paper's open question) of docs/guide/fit.md, whose table and verdict
/// this test writes (`DJKR_BLESS=1`) or checks: data from a saturated law (v_sat = 1 mm/s) with
/// 2 % noise, fitted by both laws; the saturated law's AIC is lower by more than 10, and its
/// intervals (sigma, or the profile likelihood's where the model is not linear over one sigma)
/// hold the truth. Opt-in: the saturated fit computes three profile likelihoods (about 4 000
/// forward runs, a minute on two cores):
/// `cargo test --release --test it fit::aic -- --ignored --nocapture`.
#[test]
#[ignore = "three profile likelihoods of the saturated law: about a minute"]
fn aic_tells_a_saturated_law_from_the_plain_one() {
    let case = LawComparison::new();
    let (sat, plain) = (case.truth(true), case.truth(false));
    assert!(
        sat[1] < 0.9 * plain[1],
        "saturation must lower the largest amplitude's value by 10 %: {sat:?} {plain:?}"
    );
    let (p, s) = case.fit_both("saturated-data", &sat);
    assert!(
        aic(&p) - aic(&s) > 10.0,
        "AIC plain {} saturated {}",
        aic(&p),
        aic(&s)
    );
    let truth = [
        ("adhesion.v0", 4.45e-5),
        ("adhesion.n", 0.531),
        ("adhesion.v_sat", 1e-3),
    ];
    for (key, t) in truth {
        let i = param(&s, key)["interval"].as_array().unwrap().clone();
        let (lo, hi) = (i[0].as_f64().unwrap(), i[1].as_f64().unwrap());
        assert!((lo..=hi).contains(&t), "{key}: {t} outside [{lo}, {hi}]");
    }
    let cells = |j: &Value, keys: &[(&str, &str, &str, f64)]| -> String {
        keys.iter()
            .map(|(k, name, unit, scale)| estimate_cell(param(j, k), name, unit, *scale))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let v0 = ("adhesion.v0", "v0", " µm/s", 1e-6);
    let n = ("adhesion.n", "n", "", 1.0);
    let v_sat = ("adhesion.v_sat", "v_sat", " mm/s", 1e-3);
    let row = |law: &str, keys: &str, j: &Value, est: String| -> String {
        format!(
            "| {law} | {keys} | {:.3} | {:.1} | {est} | {} |",
            j["chi2"].as_f64().unwrap(),
            aic(j),
            j["forward_runs"]
        )
    };
    let table = [
        "| law | free keys | χ² | AIC | estimates | forward runs |".to_string(),
        "|---|---|---|---|---|---|".to_string(),
        row("Gent–Schultz", "v0, n", &p, cells(&p, &[v0, n])),
        row("saturated", "v0, n, v_sat", &s, cells(&s, &[v0, n, v_sat])),
    ];
    let went_on = s["notes"]
        .as_array()
        .unwrap()
        .iter()
        .any(|n| n.as_str().unwrap().contains("the fit went on from there"));
    let went_on = if went_on {
        format!(
            " In the saturated fit a profile met a lower χ² than the optimiser's estimate \
             ({:.3}), and the fit went on from there.",
            s["starts"][0]["chi2"].as_f64().unwrap()
        )
    } else {
        String::new()
    };
    let generated = format!(
        "{}\n\nThe saturated law is preferred by ΔAIC = {:.1}. The plain law only fits by \
         distorting n to {:.3}, with a reduced χ² of {:.1}.{went_on}\n",
        table.join("\n"),
        aic(&p) - aic(&s),
        param(&p, "adhesion.n")["value"].as_f64().unwrap(),
        p["reduced_chi2"].as_f64().unwrap()
    );
    crate::tools::check(
        "docs/guide/fit.md",
        &crate::tools::splice(
            &std::fs::read_to_string(crate::tools::root().join("docs/guide/fit.md")).unwrap(),
            "law comparison",
            &generated,
        ),
    );
}

/// With an ensemble, a row's prediction is the mean of the members `djkr sweep --ensemble N
/// --seed S` runs for the same point (the same phases, drawn from (seed, row, member)), and its
/// standard error is the members' standard deviation over √N: checked against a sweep of the
/// tiny scenario, to the bit for the mean.
#[test]
fn ensemble_rows_are_the_sweeps_members_mean() {
    let tiny = "tests/sweep/tiny.toml";
    let source = ScenarioSource::read(Path::new(tiny)).unwrap();
    let (members, seed) = (3, 5);
    let table = djkr::api::sweep(
        source.clone(),
        vec![djkr::sweep::Axis::parse("base.amplitude=5e-6,1e-5").unwrap()],
        Some(djkr::sweep::Ensemble { members, seed }),
        0,
        None,
    )
    .unwrap();
    let column = |name: &str| table.column(name).unwrap().data.clone();
    let points = column("point");
    let amplifications = column("pull_off_amplification");
    let (points, amplifications) = (points.as_i64().unwrap(), amplifications.as_f64().unwrap());
    let data = FitData::parse(
        "base.amplitude [m],pull_off_amplification [1]\n5e-6,0\n1e-5,0\n",
        "d.csv",
        None,
    )
    .unwrap();
    let model = ForwardModel::new(
        source,
        data,
        Vec::<SetKey>::new(),
        vec![],
        Some((members, seed)),
        0,
    )
    .unwrap();
    let p = model
        .predict(&[vec![]], None, &mut || {})
        .unwrap()
        .remove(0);
    for point in 0..2 {
        let v: Vec<f64> = points
            .iter()
            .zip(amplifications)
            .filter(|(p, _)| **p == point as i64)
            .map(|(_, a)| *a)
            .collect();
        assert_eq!(v.len(), members);
        let mean = v.iter().sum::<f64>() / members as f64;
        assert_eq!(p.values[point].to_bits(), mean.to_bits(), "{v:?}");
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (members - 1) as f64).sqrt();
        assert!((p.se[point] - sd / (members as f64).sqrt()).abs() <= 1e-12 * sd.max(1.0));
        assert!(
            p.se[point] > 0.0,
            "the phases differ, so the members do: {v:?}"
        );
    }
}

/// Start `djkr fit` on the heavy rig (paper protocol) as a child with its stderr piped, on
/// three rows of data made with v0 and n moved from the scenario's values (so that the fit has
/// iterations to go after its first evaluation).
#[cfg(unix)]
fn spawn_fit(dir: &Path, extra: &[&str]) -> (std::process::Child, std::path::PathBuf) {
    use std::process::Stdio;
    let cond = [(300.0, 10.0), (300.0, 40.0), (400.0, 20.0)];
    let values = truth(
        HEAVY,
        COND2,
        &cells2(&cond),
        &["adhesion.v0=8e-5", "adhesion.n=0.45"],
    );
    let data = dir.join("data.csv");
    write_data(&data, COND2, &cells2(&cond), &values, 0.02, 3);
    let out = dir.join("fit");
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args([
            "fit",
            data.to_str().unwrap(),
            "--scenario",
            HEAVY,
            "--free",
            "adhesion.v0",
            "--free",
            "adhesion.n",
            "--out",
            out.to_str().unwrap(),
        ])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("djkr runs");
    (child, out)
}

/// Send SIGINT to a child.
#[cfg(unix)]
fn interrupt(child: &std::process::Child) {
    let pid = libc::pid_t::try_from(child.id()).unwrap();
    // SAFETY: kill(2) with a valid pid and signal has no memory effects.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
}

/// Ctrl-C after the first evaluation ends the fit with exit status 130 and writes the best
/// estimate met so far: fit.json (with `"interrupted": true`, not converged, and a note saying
/// so), residuals.csv and fitted.toml. The signal is sent when stderr (not a terminal, so one
/// line per new best instead of a bar) reports the starting values' chi2, which is after the
/// first evaluation and long before a 3-row, 2-key fit from moved values can end.
#[cfg(unix)]
#[test]
fn ctrl_c_after_the_first_evaluation_writes_the_best_estimate() {
    use std::io::{BufRead, BufReader, Read};
    let dir = tempfile::tempdir().unwrap();
    // A 4-member ensemble per row, one run at a time: the Jacobian after the first evaluation
    // alone is 24 runs, so the fit cannot end before the signal arrives.
    let (mut child, out) = spawn_fit(dir.path(), &["--ensemble", "4", "--jobs", "1"]);
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    loop {
        let mut line = String::new();
        if err.read_line(&mut line).unwrap() == 0 {
            panic!("djkr fit ended before its first evaluation was reported: {seen}");
        }
        seen.push_str(&line);
        if line.starts_with("fit: iteration 0, best chi2") {
            break;
        }
    }
    interrupt(&child);
    err.read_to_string(&mut seen).unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{seen}");
    for f in ["fit.json", "residuals.csv", "fitted.toml"] {
        assert!(out.join(f).is_file(), "{f} missing: {seen}");
    }
    let j = fit_json(&out);
    assert_eq!(j["interrupted"], true, "{j}");
    assert_eq!(j["converged"], false, "{j}");
    assert!(
        j["notes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|n| n.as_str().unwrap().starts_with("interrupted:")),
        "{j}"
    );
    assert!(seen.contains("hold the best estimate so far"), "{seen}");
    // The written scenario carries the estimates (the best met, finite).
    for key in ["adhesion.v0", "adhesion.n"] {
        assert!(param(&j, key)["value"].as_f64().unwrap().is_finite(), "{j}");
    }
}

/// Ctrl-C during the first evaluation (a 32-member ensemble per row, one run at a time, makes
/// it 96 runs long): no estimate
/// exists, so djkr exits 130 with one line saying so and writes none of the fit's files. The
/// signal is sent once the output folder's lock exists (the handlers are installed before it
/// is taken) and before any progress line reports the starting values.
#[cfg(unix)]
#[test]
fn ctrl_c_during_the_first_evaluation_writes_nothing() {
    use std::io::Read;
    let dir = tempfile::tempdir().unwrap();
    let (mut child, out) = spawn_fit(dir.path(), &["--ensemble", "32", "--jobs", "1"]);
    let t0 = std::time::Instant::now();
    while !out.join(".djkr.lock").exists() {
        assert!(
            t0.elapsed() < std::time::Duration::from_secs(60),
            "no lock file in {}",
            out.display()
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(200));
    interrupt(&child);
    let mut seen = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut seen)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(
        !seen.contains("fit: iteration 0"),
        "the first evaluation ended before the signal (96 runs in 200 ms?): {seen}"
    );
    assert_eq!(status.code(), Some(130), "{seen}");
    assert!(
        seen.lines().any(|l| l.starts_with("stopped: ")
            && l.contains("no estimate was computed yet")
            && l.contains("nothing written")),
        "{seen}"
    );
    for f in [
        "fit.json",
        "residuals.csv",
        "fitted.toml",
        "fit.png",
        "fit.svg",
    ] {
        assert!(!out.join(f).exists(), "{f} written: {seen}");
    }
}

/// Opt-in study of the light, chaotic rig (`tests/sweep/tiny.toml`: the 3 g sphere on 200 N/m,
/// 50 ms of vibration at 300 Hz, unloaded at 2 mm/s, where one ulp of input moves a single
/// run's pull-off by percent and the ensemble mean is the observable). For each of 20 seeds:
/// data are the 16-member ensemble means (seed 1000 + s) at five amplitudes made with v0 and n
/// moved from the file's values, plus 1 % Gaussian measurement noise, with
/// sigma = √(se² + (1 %)²); `djkr fit --ensemble 16 --seed s` (other phases than the data's)
/// fits v0 and n from the file's values. Reported: converged count, count with both estimates
/// within 3σ of the truth, and the mean σ against the spread of the estimates. Asserted as for
/// the heavy rig: converged and within 3σ in >= 18 of 20, mean σ within a factor 1.5 of the
/// spread.
#[test]
#[ignore = "20 ensemble fits on the light rig: about 2 minutes"]
fn coverage_study_light_rig_ensemble() {
    let tiny = "tests/sweep/tiny.toml";
    let (v0, n) = (6e-5, 0.48);
    let (members, seeds) = (16usize, 20u64);
    let amps = [2.0, 4.0, 7.0, 12.0, 20.0];
    let header = "base.amplitude [um],pull_off_amplification [1],sigma [1]\n";
    let mut rows = String::from("base.amplitude [um],pull_off_amplification [1]\n");
    for a in amps {
        rows.push_str(&format!("{a},0\n"));
    }
    let source = ScenarioSource::read(Path::new(tiny)).unwrap();
    let fixed: Vec<Override> = [format!("adhesion.v0={v0}"), format!("adhesion.n={n}")]
        .iter()
        .map(|s| Override::parse(s).unwrap())
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let (mut converged, mut inside) = (0, 0);
    let mut est: Vec<[f64; 2]> = Vec::new();
    let mut sig: Vec<[f64; 2]> = Vec::new();
    let t_all = std::time::Instant::now();
    for seed in 0..seeds {
        let data = FitData::parse(&rows, "truth.csv", None).unwrap();
        let model = ForwardModel::new(
            source.clone(),
            data,
            Vec::<SetKey>::new(),
            fixed.clone(),
            Some((members, 1000 + seed)),
            0,
        )
        .unwrap();
        let p = model
            .predict(&[vec![]], None, &mut || {})
            .unwrap()
            .remove(0);
        let mut csv = String::from(header);
        for (i, a) in amps.iter().enumerate() {
            let m = 0.01 * p.values[i];
            let obs = p.values[i] + m * gauss(seed, i as u64);
            let s = (p.se[i].powi(2) + m * m).sqrt();
            csv.push_str(&format!("{a},{obs:e},{s:e}\n"));
        }
        let path = dir.path().join(format!("data{seed}.csv"));
        std::fs::write(&path, csv).unwrap();
        let out = dir.path().join(format!("fit{seed}"));
        let t0 = std::time::Instant::now();
        let fit_seed = seed.to_string();
        let ens = members.to_string();
        let j = run_fit(
            &path,
            &out,
            tiny,
            &[
                "--free",
                "adhesion.v0",
                "--free",
                "adhesion.n",
                "--ensemble",
                &ens,
                "--seed",
                &fit_seed,
            ],
        );
        let (e, s, ok) = estimates(&j, [("adhesion.v0", v0), ("adhesion.n", n)]);
        let conv = j["converged"] == true;
        eprintln!(
            "seed {seed}: v0 {:.4e} ± {:.2e}, n {:.4} ± {:.4}, chi2 {:.3}, {} iterations, {} \
             runs, {:.1} s, converged {conv}, within 3 sigma {ok}; notes {}",
            e[0],
            s[0],
            e[1],
            s[1],
            j["chi2"].as_f64().unwrap(),
            j["iterations"],
            j["forward_runs"],
            t0.elapsed().as_secs_f64(),
            j["notes"]
        );
        converged += usize::from(conv);
        inside += usize::from(ok);
        est.push(e);
        sig.push(s);
    }
    let ratios = sigma_over_spread(&est, &sig);
    eprintln!(
        "light rig, {seeds} seeds: {converged} converged, {inside} within 3 sigma, {:.0} s",
        t_all.elapsed().as_secs_f64()
    );
    assert!(converged >= 18, "{converged} of {seeds} converged");
    assert!(inside >= 18, "{inside} of {seeds} within 3 sigma");
    for (i, r) in ratios.iter().enumerate() {
        assert!(
            (1.0 / 1.5..=1.5).contains(r),
            "param {i}: mean sigma / spread {r}"
        );
    }
}

/// The library's fit raised to stop before it starts: no estimate exists, and that is a
/// cancellation (Python's KeyboardInterrupt), not invalid input; the same call unraised fits.
#[test]
fn api_fit_stopped_before_the_first_evaluation_is_cancelled() {
    use djkr::api;
    use djkr::error::Error as ApiError;
    use std::sync::atomic::AtomicBool;
    let source = ScenarioSource::read(Path::new("tests/sweep/tiny.toml")).unwrap();
    let data = "base.amplitude [um],pull_off_amplification [1]\n2,6.5\n5,8.0\n10,10.0\n";
    let request = api::FitRequest {
        jobs: 1,
        ..api::FitRequest::new(
            source,
            djkr::fit::FitData::parse(data, "d.csv", None).unwrap(),
            djkr::fit::FreeKey::parse_all(&["adhesion.n"]).unwrap(),
        )
    };
    let call = |stop: &AtomicBool| api::fit(&request, Some(stop));
    let e = call(&AtomicBool::new(true)).unwrap_err();
    assert!(matches!(e, ApiError::Cancelled), "{e}");
    let r = call(&AtomicBool::new(false)).unwrap();
    assert!(r.report.parameters[0].value.is_finite(), "{r:?}");
}

// Issue 36: the seven cases of `djkr fit` off the happy path, each on a cheap rig that shows the
// same behaviour (the paper protocol with short dwells, 0.05 s and 0.1 s, unloading at 30 um/s
// to 3 mm/s: a run takes about 0.03 s) unless said otherwise. The paper protocol's 18 rows of
// the issue are `issue36_cases_on_the_paper_protocol` (--ignored).

/// The cheap rig's fixed overrides.
pub(crate) const SHORT: [&str; 2] = ["stage[1].duration=0.05", "stage[2].duration=0.1"];
/// The cheap rig's conditions: amplitude, unloading speed.
pub(crate) const COND_CHEAP: &str = "base.amplitude [um],stage[3].speed [um/s]";

pub(crate) fn cheap_cells() -> Vec<String> {
    [
        (5.0, 100.0),
        (10.0, 100.0),
        (20.0, 100.0),
        (0.0, 30.0),
        (0.0, 300.0),
        (0.0, 3000.0),
    ]
    .iter()
    .map(|(a, v)| format!("{a},{v}"))
    .collect()
}

/// Data of the cheap rig made with v0 = 60 um/s and n = 0.5, with 2 % noise (seed 3).
pub(crate) fn cheap_data(dir: &Path) -> std::path::PathBuf {
    let mut sets: Vec<&str> = SHORT.to_vec();
    sets.extend(["adhesion.v0=6e-5", "adhesion.n=0.5"]);
    let values = truth(HEAVY, COND_CHEAP, &cheap_cells(), &sets);
    let data = dir.join("cheap.csv");
    write_data(&data, COND_CHEAP, &cheap_cells(), &values, 0.02, 3);
    data
}

/// `djkr fit` on the cheap rig with `extra` flags: fit.json and stderr.
pub(crate) fn fit_cheap(data: &Path, out: &Path, extra: &[&str]) -> (Value, String) {
    let mut args: Vec<String> = vec![
        "fit".into(),
        data.to_str().unwrap().into(),
        "--scenario".into(),
        HEAVY.into(),
        "--out".into(),
        out.to_str().unwrap().into(),
    ];
    for s in SHORT {
        args.extend(["--set".into(), s.into()]);
    }
    args.extend(extra.iter().map(|s| s.to_string()));
    let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(&args)
        .output()
        .expect("djkr runs");
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?}: {err}");
    (fit_json(out), err)
}

fn notes(j: &Value) -> Vec<String> {
    j["notes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap().to_string())
        .collect()
}

/// Cases 1 and 7. From adhesion.n = 0.3 (far from the data's 0.5) the fit keeps trying after
/// rejected steps and ends where the fit from the scenario's values ends (chi2 within 0.05,
/// estimates within 0.1 sigma), converged, with sigma. Its progress without a terminal is one
/// line per iteration, each with the best chi2, the runs done and expected, the elapsed time
/// and an ETA. A fit cut short by --max-iterations 1 says it did not converge and gives no
/// sigma, no covariance, and no hint about ensembles. About 6 s.
#[test]
fn issue36_a_far_start_converges_and_an_unconverged_fit_has_no_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let data = cheap_data(dir.path());
    let free = ["--free", "adhesion.v0", "--free", "adhesion.n"];
    let (near, _) = fit_cheap(&data, &dir.path().join("near"), &free);
    let mut far_args = free.to_vec();
    far_args.extend(["--set", "adhesion.n=0.3"]);
    let (far, err) = fit_cheap(&data, &dir.path().join("far"), &far_args);
    eprintln!("near: {near}\nfar: {far}\n{err}");
    for j in [&near, &far] {
        assert_eq!(j["converged"], true, "{j}");
        assert!(!j["termination"].as_str().unwrap().starts_with("iterations"));
    }
    let chi2 = |j: &Value| j["chi2"].as_f64().unwrap();
    assert!((chi2(&near) - chi2(&far)).abs() < 0.05, "{near} {far}");
    assert!(far["iterations"].as_u64().unwrap() > 1);
    for key in ["adhesion.v0", "adhesion.n"] {
        let (a, b) = (param(&near, key), param(&far, key));
        let s = a["sigma"].as_f64().unwrap();
        assert!(b["sigma"].as_f64().unwrap() > 0.0);
        let d = (a["value"].as_f64().unwrap() - b["value"].as_f64().unwrap()).abs();
        assert!(d < 0.1 * s, "{key}: {a} {b}");
    }
    // Progress: a line per iteration (0 is the start).
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("fit: iteration "))
        .collect();
    assert_eq!(
        lines.len() as u64,
        far["iterations"].as_u64().unwrap() + 1,
        "{err}"
    );
    for l in &lines {
        assert!(
            l.contains("best chi2")
                && l.contains(" of about ")
                && l.contains("forward runs")
                && l.contains("s elapsed")
                && l.contains("ETA"),
            "{l}"
        );
    }
    // Cut short: not converged, no sigma, no covariance, no misleading hint.
    let mut short = far_args.clone();
    short.extend(["--max-iterations", "1"]);
    let (cut, _) = fit_cheap(&data, &dir.path().join("cut"), &short);
    assert_eq!(cut["converged"], false, "{cut}");
    for p in cut["parameters"].as_array().unwrap() {
        assert!(p["sigma"].is_null() && p["interval"].is_null(), "{cut}");
    }
    assert!(cut["covariance"].as_array().unwrap().iter().all(|r| r
        .as_array()
        .unwrap()
        .iter()
        .all(Value::is_null)));
    let n = notes(&cut);
    assert!(
        n.iter()
            .any(|n| n.starts_with("not converged (iterations") && n.contains("no sigma is given")),
        "{n:?}"
    );
    assert!(!n.iter().any(|n| n.contains("ensemble")), "{n:?}");
}

/// Case 3. A key without effect on the data (initial.gap: the approach's start, forgotten
/// after the dwell) freed beside v0 and n: the note names the direction the data cannot fix
/// (initial.gap alone), initial.gap has no sigma, and v0 and n keep theirs, within 5 % of the
/// fit without the useless key. About 9 s.
#[test]
fn issue36_a_useless_key_removes_only_its_own_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let data = cheap_data(dir.path());
    let two = ["--free", "adhesion.v0", "--free", "adhesion.n"];
    let (a, _) = fit_cheap(&data, &dir.path().join("two"), &two);
    let mut three = two.to_vec();
    three.extend(["--free", "initial.gap"]);
    let (b, _) = fit_cheap(&data, &dir.path().join("three"), &three);
    eprintln!("{b}");
    assert_eq!(b["converged"], true, "{b}");
    for key in ["adhesion.v0", "adhesion.n"] {
        let (sa, sb) = (
            param(&a, key)["sigma"].as_f64().unwrap(),
            param(&b, key)["sigma"].as_f64().unwrap(),
        );
        assert!((sb / sa - 1.0).abs() < 0.05, "{key}: {sa} {sb}");
    }
    assert!(param(&b, "initial.gap")["sigma"].is_null());
    let n = notes(&b);
    let unfixed: Vec<&String> = n
        .iter()
        .filter(|n| n.starts_with("not identifiable"))
        .collect();
    assert_eq!(unfixed.len(), 1, "{n:?}");
    assert!(
        unfixed[0].contains("combination initial.gap (")
            && !unfixed[0].contains("adhesion.v0")
            && !unfixed[0].contains("adhesion.n"),
        "{unfixed:?}"
    );
}

/// Data without a sigma column weigh every row the same and scale the parameters' σ by the
/// reduced χ² s²; the check of the linear model at ±1σ, the profiles and the other minima must
/// measure Δχ² in the same unit (s², not 1). The reference: the same rows with a sigma column
/// of s for every row, whose reduced χ² is 1. With the same forward model, both fits give the
/// same estimates and σ (the objectives differ by the constant s²; measured: the same to
/// 1e-15), and neither says the model is not linear over one σ. Before, the fit without sigma
/// took Δχ² = 1 in raw units, 200 times its s², called every key non-linear and walked its
/// profiles silently for minutes. About 3 s.
#[test]
fn a_fit_without_sigma_measures_delta_chi2_in_its_reduced_chi2() {
    let dir = tempfile::tempdir().unwrap();
    let data = cheap_data(dir.path());
    let text = std::fs::read_to_string(&data).unwrap();
    let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split(',').collect()).collect();
    let bare: String = rows.iter().map(|r| r[..3].join(",") + "\n").collect();
    let no_sigma = dir.path().join("no-sigma.csv");
    std::fs::write(&no_sigma, bare).unwrap();
    // The same forward model for both: a fit chooses its runs' tolerances from the data's σ,
    // and keeps the scenario's without; given, they hold for both.
    let two = [
        "--free",
        "adhesion.v0",
        "--free",
        "adhesion.n",
        "--set",
        "solver.rtol=1e-8",
        "--set",
        "solver.envelope_tol=1e-6",
    ];
    let (a, _) = fit_cheap(&no_sigma, &dir.path().join("a"), &two);
    assert_eq!(a["converged"], true, "{a}");
    let s = a["reduced_chi2"].as_f64().unwrap().sqrt();
    let weighted: String = std::iter::once(format!("{},sigma [1]\n", rows[0][..3].join(",")))
        .chain(
            rows[1..]
                .iter()
                .map(|r| format!("{},{s:e}\n", r[..3].join(","))),
        )
        .collect();
    let with_sigma = dir.path().join("with-sigma.csv");
    std::fs::write(&with_sigma, weighted).unwrap();
    let (b, _) = fit_cheap(&with_sigma, &dir.path().join("b"), &two);
    assert_eq!(b["converged"], true, "{b}");
    assert!(
        (b["reduced_chi2"].as_f64().unwrap() - 1.0).abs() < 1e-3,
        "{b}"
    );
    for key in ["adhesion.v0", "adhesion.n"] {
        let (pa, pb) = (param(&a, key), param(&b, key));
        let (va, vb) = (pa["value"].as_f64().unwrap(), pb["value"].as_f64().unwrap());
        let (sa, sb) = (pa["sigma"].as_f64().unwrap(), pb["sigma"].as_f64().unwrap());
        eprintln!("{key}: without sigma {va:e} ± {sa:e}, with sigma s {vb:e} ± {sb:e}");
        assert!((va - vb).abs() <= 1e-9 * va.abs(), "{key}: {va} {vb}");
        assert!((sa / sb - 1.0).abs() <= 1e-9, "{key}: sigma {sa} {sb}");
    }
    for j in [&a, &b] {
        let n = notes(j);
        assert!(
            !n.iter().any(|n| n.contains("not linear over one sigma")),
            "{n:?}"
        );
    }
}

/// Case 4. Numerical settings are refused as fit parameters (exit status 2, one line, the keys
/// that can be freed listed), and `djkr help fit` lists them.
#[test]
fn issue36_numerical_settings_are_not_fit_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d.csv");
    std::fs::write(
        &data,
        "base.amplitude [um],pull_off_amplification [1]\n10,1.7\n20,2.1\n30,3\n",
    )
    .unwrap();
    for key in ["solver.rtol", "output.sample_rate", "stage[3].max_duration"] {
        let o = djkr(&[
            "fit",
            data.to_str().unwrap(),
            "--scenario",
            HEAVY,
            "--free",
            key,
            "--out",
            dir.path().join("out").to_str().unwrap(),
        ]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{key}: {e}");
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
        assert!(
            e.contains(&format!("--free {key}: {key} is a numerical setting"))
                && e.contains("Keys that can be freed: material.K")
                && e.contains("adhesion.v0")
                && e.contains("damping.c"),
            "{e}"
        );
    }
    assert!(!dir.path().join("out").exists());
    let o = djkr(&["help", "fit"]);
    let h = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    assert!(
        h.contains("Keys that can be freed")
            && h.contains("adhesion.n")
            && h.contains("stage[N].speed"),
        "{h}"
    );
    let list = h.split("Keys that can be freed").nth(1).unwrap();
    assert!(
        !list.contains("solver.rtol") && !list.contains("max_duration"),
        "{list}"
    );
}

/// Case 5 on the cheap rig: `--starts 3` from n = 3 reports every start (its start, estimate,
/// chi2, convergence and the minimum it reached), the drawn starts lie in the documented range
/// (a factor 10 either side of v0's start, +-50 % of n's), and the estimate is the best start's.
/// About 8 s.
#[test]
fn issue36_starts_are_reported_and_the_best_is_the_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let data = cheap_data(dir.path());
    let (j, _) = fit_cheap(
        &data,
        &dir.path().join("starts"),
        &[
            "--free",
            "adhesion.v0",
            "--free",
            "adhesion.n",
            "--set",
            "adhesion.n=3",
            "--starts",
            "3",
        ],
    );
    let starts = j["starts"].as_array().unwrap();
    assert_eq!(starts.len(), 3, "{j}");
    let chi2s: Vec<f64> = starts.iter().map(|s| s["chi2"].as_f64().unwrap()).collect();
    let best = chi2s.iter().copied().fold(f64::INFINITY, f64::min);
    // The estimate is the best start's (its chi2 at the scenario's tolerances is within the
    // model's error of the fit's).
    assert!((j["chi2"].as_f64().unwrap() - best).abs() < 0.05, "{j}");
    let start = |s: &Value, i: usize| s["start"][i].as_f64().unwrap();
    assert_eq!(start(&starts[0], 1), 3.0);
    for s in &starts[1..] {
        assert!(
            (4.45e-6..=4.45e-4).contains(&start(s, 0)) && (1.5..=4.5).contains(&start(s, 1)),
            "{s}"
        );
        assert!(s["estimate"].as_array().unwrap().len() == 2);
    }
    for (s, c) in starts.iter().zip(&chi2s) {
        // Every start converged to the one minimum of this rig (numbered 0).
        assert_eq!(s["converged"], true, "{s}");
        assert_eq!(s["minimum"], 0, "{s}: chi2 {c} against {best}");
    }
}

/// Case 6. The report shows the fit: fit.json's covariance (in the keys' units) is symmetric
/// with sigma squared on its diagonal and the correlation off it; each key's interval is the
/// curvature's (log space for v0: value times exp(-+sigma/value)); fit.svg has a data and a model
/// entry in its legend, the model's +-1 sigma, the estimates and chi2/dof, and a residual panel.
/// About 3 s.
#[test]
fn issue36_the_report_shows_the_fit() {
    let dir = tempfile::tempdir().unwrap();
    let data = cheap_data(dir.path());
    let out = dir.path().join("fit");
    let (j, _) = fit_cheap(
        &data,
        &out,
        &["--free", "adhesion.v0", "--free", "adhesion.n"],
    );
    let cov = &j["covariance"];
    let keys = ["adhesion.v0", "adhesion.n"];
    for (a, ka) in keys.iter().enumerate() {
        let pa = param(&j, ka);
        let sa = pa["sigma"].as_f64().unwrap();
        let c = cov[a][a].as_f64().unwrap();
        assert!((c.sqrt() / sa - 1.0).abs() < 1e-9, "{j}");
        for (b, kb) in keys.iter().enumerate() {
            let sb = param(&j, kb)["sigma"].as_f64().unwrap();
            let cab = cov[a][b].as_f64().unwrap();
            assert_eq!(cab.to_bits(), cov[b][a].as_f64().unwrap().to_bits());
            let r = j["correlation"][a][b].as_f64().unwrap();
            assert!((cab / (sa * sb) - r).abs() < 1e-9, "{j}");
        }
        assert_eq!(pa["interval_from"], "curvature");
    }
    let v0 = param(&j, "adhesion.v0");
    let (x, s) = (v0["value"].as_f64().unwrap(), v0["sigma"].as_f64().unwrap());
    let iv = v0["interval"].as_array().unwrap();
    assert!((iv[0].as_f64().unwrap() / (x * (-s / x).exp()) - 1.0).abs() < 1e-12);
    assert!((iv[1].as_f64().unwrap() / (x * (s / x).exp()) - 1.0).abs() < 1e-12);
    let n = param(&j, "adhesion.n");
    let (x, s) = (n["value"].as_f64().unwrap(), n["sigma"].as_f64().unwrap());
    let iv = n["interval"].as_array().unwrap();
    assert!((iv[0].as_f64().unwrap() - (x - s)).abs() < 1e-12);
    let svg = std::fs::read_to_string(out.join("fit.svg")).unwrap();
    for want in [
        "data +- sigma, base.amplitude = 0 µm",
        "data +- sigma, base.amplitude = 5 µm",
        "model, base.amplitude = 0 µm",
        "model +- 1 sigma (parameters)",
        "adhesion.v0 = (",
        "adhesion.n = 0.",
        "chi2/dof = ",
        "residuals (observed - fitted)/sigma",
    ] {
        assert!(svg.contains(want), "{want} not in fit.svg");
    }
    assert!(out.join("fit.png").is_file());
}

/// Case 2, on a rig whose model jumps under any change of its parameters: the light, chaotic
/// rig (`tests/sweep/tiny.toml`) fitted without an ensemble, where one run's pull-off moves by
/// percent for any change of adhesion.n. The curvature's sigma would be as confident as the
/// issue's `c = 221.45 ± 0.061`: instead the check of the linear model at +-1 sigma says that
/// the model is not linear there, the key gets no sigma and its interval is the profile
/// likelihood's (holding the estimate), and the check of the tolerances at the estimate finds
/// the loose tolerances' error far above what the data allow and goes on at the scenario's.
/// (The paper protocol's damping case is in `issue36_cases_on_the_paper_protocol`.) About 2 s.
#[test]
fn issue36_a_model_that_jumps_gets_a_note_and_a_profile_interval() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("tiny.csv");
    std::fs::write(
        &data,
        "base.amplitude [um],pull_off_amplification [1],sigma [1]\n2,6.5,0.1\n5,8.0,0.1\n\
         10,10.0,0.15\n20,12,0.2\n",
    )
    .unwrap();
    let out = dir.path().join("fit");
    let j = run_fit(
        &data,
        &out,
        "tests/sweep/tiny.toml",
        &["--free", "adhesion.n"],
    );
    eprintln!("{j}");
    let n = notes(&j);
    assert!(
        n.iter()
            .any(|n| n.starts_with("adhesion.n: the model is not linear over one sigma")),
        "{n:?}"
    );
    assert!(
        n.iter()
            .any(|n| n.starts_with("at the estimate the model's error was")
                && n.contains("the fit went on at rtol 1e-8, envelope_tol 1e-6")),
        "{n:?}"
    );
    let p = param(&j, "adhesion.n");
    assert!(p["sigma"].is_null(), "{p}");
    assert_eq!(p["interval_from"], "profile");
    let iv = p["interval"].as_array().unwrap();
    let v = p["value"].as_f64().unwrap();
    assert!(
        iv[0].as_f64().unwrap() <= v && v <= iv[1].as_f64().unwrap(),
        "{p}"
    );
    assert!(j["covariance"][0][0].is_null());
}

/// Opt-in: the cases of issue 36 on the paper protocol as the issue ran them: 18 rows at
/// 200/300/400 Hz and 10, 20, 30, 40, 60, 80 um made with v0 = 60 um/s, n = 0.5 (damping.c =
/// 10, the file's) plus 2 % noise, fitted for v0 and n:
/// - from the file's values (the reference);
/// - case 1, from n = 0.3: converged to the reference's chi2 (within 0.1), with sigma;
/// - case 2, damping.c freed too: either its chi2 is the reference's (within 0.1: c stayed
///   where the data cannot tell it from 10), or c has no sigma, a note, and an interval
///   holding 10; never a sigma that excludes 10 by 3 of them;
/// - case 3, initial.gap freed too (no effect on the data): v0 and n keep their sigma (within
///   5 %), initial.gap has none;
/// - case 5, from n = 0.8 with --starts 4: the estimate's chi2 is the reference's (within 0.1)
///   and every start is listed.
#[test]
#[ignore = "fits of 18 rows of the paper protocol: many minutes"]
fn issue36_cases_on_the_paper_protocol() {
    let dir = tempfile::tempdir().unwrap();
    let cond: Vec<(f64, f64)> = [200.0, 300.0, 400.0]
        .iter()
        .flat_map(|&f| [10.0, 20.0, 30.0, 40.0, 60.0, 80.0].map(|a| (f, a)))
        .collect();
    let values = truth(
        HEAVY,
        COND2,
        &cells2(&cond),
        &["adhesion.v0=6e-5", "adhesion.n=0.5"],
    );
    let data = dir.path().join("data.csv");
    write_data(&data, COND2, &cells2(&cond), &values, 0.02, 36);
    let fit = |name: &str, extra: &[&str]| -> Value {
        let mut a = vec!["--free", "adhesion.v0", "--free", "adhesion.n"];
        a.extend_from_slice(extra);
        let t0 = std::time::Instant::now();
        let j = run_fit(&data, &dir.path().join(name), HEAVY, &a);
        eprintln!(
            "{name} ({:.0} s, {} runs, {} RHS evaluations): chi2 {}, converged {}, {}\n  notes: {}",
            t0.elapsed().as_secs_f64(),
            j["forward_runs"],
            j["rhs_evals"],
            j["chi2"],
            j["converged"],
            j["parameters"],
            j["notes"]
        );
        j
    };
    let chi2 = |j: &Value| j["chi2"].as_f64().unwrap();
    let r = fit("reference", &[]);
    assert_eq!(r["converged"], true);
    let c1 = fit("case1", &["--set", "adhesion.n=0.3"]);
    assert_eq!(c1["converged"], true, "{c1}");
    assert!((chi2(&c1) - chi2(&r)).abs() < 0.1, "{c1}");
    assert!(param(&c1, "adhesion.n")["sigma"].as_f64().is_some());
    let c2 = fit("case2", &["--free", "damping.c"]);
    let c = param(&c2, "damping.c");
    let cv = c["value"].as_f64().unwrap();
    if let Some(s) = c["sigma"].as_f64() {
        assert!((cv - 10.0).abs() < 3.0 * s, "{c2}");
    } else if chi2(&c2) > chi2(&r) + 0.1 {
        let iv = c["interval"].as_array().unwrap();
        assert!(
            iv[0].as_f64().unwrap() <= 10.0 && 10.0 <= iv[1].as_f64().unwrap(),
            "{c2}"
        );
        assert!(!notes(&c2).is_empty());
    }
    let c3 = fit("case3", &["--free", "initial.gap"]);
    for key in ["adhesion.v0", "adhesion.n"] {
        let (a, b) = (
            param(&r, key)["sigma"].as_f64().unwrap(),
            param(&c3, key)["sigma"].as_f64().unwrap(),
        );
        assert!((b / a - 1.0).abs() < 0.05, "{key}: {a} {b}");
    }
    assert!(param(&c3, "initial.gap")["sigma"].is_null());
    let c5 = fit("case5", &["--set", "adhesion.n=0.8", "--starts", "4"]);
    assert!(chi2(&c5) < chi2(&r) + 0.1, "{c5}");
    assert_eq!(c5["starts"].as_array().unwrap().len(), 4);
}
