//! `djkr fit`: recovery of known constants from data djkr made itself (with Gaussian noise), the
//! fitted scenario reproducing the fitted values, and the one-line refusals of bad input.

use djkr::fit::{FitData, ForwardModel};
use djkr::scenario::overrides::{Override, SetKey};
use djkr::scenario::parse::ScenarioSource;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

const HEAVY: &str = "scenarios/paper-protocol-300hz.toml";

fn djkr(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .output()
        .expect("djkr runs")
}

/// A standard normal deviate for (seed, i), by Box–Muller on the ensemble's counter-based
/// uniform numbers (reproducible, no dependency).
fn gauss(seed: u64, i: u64) -> f64 {
    use djkr::sweep::phase::uniform;
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
fn truth(scenario: &str, header: &str, cells: &[String], sets: &[&str]) -> Vec<f64> {
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
fn write_data(path: &Path, header: &str, cells: &[String], values: &[f64], rel: f64, seed: u64) {
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

/// The law comparison (the paper's open question). Data from a saturated law (v_sat = 1 mm/s)
/// with 2 % noise, on the paper protocol with short dwells (0.1 s, 0.2 s): two vibrating rows
/// (300 Hz, 5 and 10 um, unloading at 100 um/s; the saturated values fall > 10 % below the
/// plain law's) and five rows without vibration unloading at 30 um/s to 3 mm/s, which pin the
/// law at crack speeds below and above v_sat. (With vibrating rows alone, 200 and 400 Hz at 1 to
/// 10 um, a plain law with n about 0.2 mimicked the saturated data: AIC 6.0 against 7.8.)
/// Fitted by both laws, the saturated law's AIC is lower by more than 10. Data from the plain
/// law: the saturated fit's v_sat runs to its bound or its AIC is not lower by more than 2.
/// About 4 s (two-core release build).
#[test]
fn aic_tells_a_saturated_law_from_the_plain_one() {
    let dir = tempfile::tempdir().unwrap();
    let short = ["stage[1].duration=0.1", "stage[2].duration=0.2"];
    let mut rows: Vec<(f64, f64, f64)> = vec![(300.0, 5.0, 100.0), (300.0, 10.0, 100.0)];
    rows.extend([30.0, 100.0, 300.0, 1000.0, 3000.0].map(|v| (300.0, 0.0, v)));
    let sat_law = ["adhesion.law=gent-schultz-saturated", "adhesion.v_sat=1e-3"];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        short.iter().chain(extra).copied().collect::<Vec<_>>()
    };
    let sat = truth(HEAVY, COND3, &cells3(&rows), &with(&sat_law));
    let plain = truth(HEAVY, COND3, &cells3(&rows), &with(&[]));
    assert!(
        sat[1] < 0.9 * plain[1],
        "saturation must lower the largest amplitude's value by 10 %: {sat:?} {plain:?}"
    );
    let sets = |extra: &[&str]| -> Vec<String> {
        short
            .iter()
            .chain(extra)
            .flat_map(|s| ["--set".to_string(), s.to_string()])
            .collect()
    };
    let fit_both = |name: &str, values: &[f64]| -> (Value, Value) {
        let data = dir.path().join(format!("{name}.csv"));
        write_data(&data, COND3, &cells3(&rows), values, 0.02, 11);
        let mut a = sets(&[]);
        a.extend(["--free", "adhesion.v0", "--free", "adhesion.n"].map(String::from));
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let t0 = std::time::Instant::now();
        let p = run_fit(&data, &dir.path().join(format!("{name}-plain")), HEAVY, &a);
        let t1 = t0.elapsed().as_secs_f64();
        let mut a = sets(&["adhesion.law=gent-schultz-saturated", "adhesion.v_sat=3e-3"]);
        a.extend(
            [
                "--free",
                "adhesion.v0",
                "--free",
                "adhesion.n",
                "--free",
                "adhesion.v_sat=1e-5:1",
            ]
            .map(String::from),
        );
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let s = run_fit(&data, &dir.path().join(format!("{name}-sat")), HEAVY, &a);
        eprintln!(
            "{name}: plain ({t1:.1} s) {p}\nsaturated ({:.1} s) {s}",
            t0.elapsed().as_secs_f64() - t1
        );
        (p, s)
    };
    let aic = |j: &Value| j["aic"].as_f64().unwrap();
    let (p, s) = fit_both("saturated-data", &sat);
    assert!(
        aic(&p) - aic(&s) > 10.0,
        "AIC plain {} saturated {}",
        aic(&p),
        aic(&s)
    );
    let (p, s) = fit_both("plain-data", &plain);
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

/// With an ensemble, a row's prediction is the mean of the members `djkr sweep --ensemble N
/// --seed S` runs for the same point (the same phases, drawn from (seed, row, member)), and its
/// standard error is the members' standard deviation over √N: checked against a sweep of the
/// tiny scenario, to the bit for the mean.
#[test]
fn ensemble_rows_are_the_sweeps_members_mean() {
    use djkr::sweep::{run_all, Axis, Ensemble, Grid, RunOptions, Sweep};
    let tiny = "tests/sweep/tiny.toml";
    let source = ScenarioSource::read(Path::new(tiny)).unwrap();
    let (members, seed) = (3, 5);
    let grid = Grid::new(
        vec![Axis::parse("base.amplitude=5e-6,1e-5").unwrap()],
        false,
    )
    .unwrap();
    let sweep = Sweep::new(source.clone(), grid, Some(Ensemble { members, seed })).unwrap();
    let rows = run_all(&sweep, &RunOptions::default());
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
        let v: Vec<f64> = rows
            .iter()
            .filter(|r| r.point == point)
            .map(|r| r.amplification().unwrap())
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
    let call = |stop: &AtomicBool| {
        api::fit(
            source.clone(),
            data,
            "d.csv",
            &["adhesion.n"],
            None,
            &[] as &[&str],
            None,
            1,
            Some(stop),
        )
    };
    let e = call(&AtomicBool::new(true)).unwrap_err();
    assert!(matches!(e, ApiError::Cancelled), "{e}");
    let j = call(&AtomicBool::new(false)).unwrap();
    assert!(
        j["parameters"][0]["value"].as_f64().unwrap().is_finite(),
        "{j}"
    );
}
