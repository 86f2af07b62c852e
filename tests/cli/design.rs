//! `djkr design` end to end (issue 34): a real fit of two keys on a cheap rig, then a design of
//! six new measurements over a 5 × 5 grid of candidates; its files, its numbers' consistency
//! (repeats summing to K, expected σ no larger than now, the design's covariance determinant no
//! larger than the uniform spread's), its sensitivities (secants over ±σ, checked by
//! independent runs of `djkr sweep`), `--json`, and its refusals. About 5 s.

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

/// The cheap rig: the paper's protocol with 50 ms of preload and 100 ms of vibration.
const SCENARIO: &str = "scenarios/paper-protocol-300hz.toml";
const SHORT: [&str; 4] = [
    "--set",
    "stage[1].duration=0.05",
    "--set",
    "stage[2].duration=0.1",
];

/// Data of the cheap rig: its pull-off amplification with adhesion.v0 = 60 µm/s and
/// adhesion.n = 0.5 (djkr sweep), each with 2 % noise (a fixed draw) and that σ: the bundled
/// example data, which docs/guide/planning.md starts from (examples/data/README.md).
const CHEAP_DATA: &str = "examples/data/pull-off-300hz.csv";

fn djkr(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .expect("djkr runs")
}

/// A fit of adhesion.v0 and adhesion.n to [`CHEAP_DATA`] in `dir/fit`.
pub(crate) fn cheap_fit(dir: &Path) -> std::path::PathBuf {
    let fit = dir.join("fit");
    let mut args = vec![
        "fit",
        CHEAP_DATA,
        "--scenario",
        SCENARIO,
        "--free",
        "adhesion.v0",
        "--free",
        "adhesion.n",
        "--out",
        fit.to_str().unwrap(),
    ];
    args.extend(SHORT);
    let o = djkr(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    fit
}

/// The determinant of a covariance given as σ per key and the correlation matrix (2 × 2).
fn det2(sigma: &[f64], corr: &Value) -> f64 {
    let r = corr[0][1].as_f64().unwrap();
    assert_eq!(corr[1][0].as_f64().unwrap(), r, "symmetric");
    sigma[0].powi(2) * sigma[1].powi(2) * (1.0 - r * r)
}

#[test]
fn design_writes_its_files_and_beats_the_uniform_spread() {
    let dir = tempfile::tempdir().unwrap();
    let fit = cheap_fit(dir.path());
    let fit_json: Value =
        serde_json::from_str(&std::fs::read_to_string(fit.join("fit.json")).unwrap()).unwrap();
    let out = dir.path().join("design");
    let k = 6;
    let o = djkr(&[
        "design",
        "--fit",
        fit.to_str().unwrap(),
        "--candidates",
        "base.amplitude=0um:20um:5",
        "stage[3].speed=30um/s:3000um/s:5log",
        "--add",
        "6",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    for f in ["design.csv", "design.json", "design.png", "design.svg"] {
        assert!(out.join(f).is_file(), "{f} not written");
    }
    let printed: Value = serde_json::from_slice(&o.stdout).unwrap();
    let j: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("design.json")).unwrap()).unwrap();
    assert_eq!(printed, j, "--json prints design.json");
    assert_eq!(j["criterion"], "D");
    assert_eq!(j["sigma_measurement_from"], "data");
    // The data's median relative σ: 2 % to the rounding of the file's four digits.
    let rel = j["sigma_measurement"]["relative"].as_f64().unwrap();
    assert!((rel - 0.02).abs() < 2e-4, "{rel}");

    // The chosen rows: their repeats sum to K, and they are the rows of design.csv with repeats.
    let chosen = j["chosen"].as_array().unwrap();
    let total: u64 = chosen.iter().map(|c| c["repeats"].as_u64().unwrap()).sum();
    assert_eq!(total, k);
    let csv = std::fs::read_to_string(out.join("design.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "base.amplitude [m],stage[3].speed [m/s],value [1],sigma_measurement [1],\
         sigma_prediction [1],information [1],repeats [1],uniform_repeats [1]"
    );
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    assert_eq!(rows.len(), 25);
    let repeats: Vec<u64> = rows.iter().map(|r| r[6].parse().unwrap()).collect();
    let uniform: Vec<u64> = rows.iter().map(|r| r[7].parse().unwrap()).collect();
    assert_eq!(repeats.iter().sum::<u64>(), k);
    assert_eq!(uniform.iter().sum::<u64>(), k);
    for c in chosen {
        let row = c["row"].as_u64().unwrap() as usize;
        assert_eq!(repeats[row - 1], c["repeats"].as_u64().unwrap());
        let a: f64 = rows[row - 1][0].parse().unwrap();
        assert_eq!(c["conditions"]["base.amplitude"].as_f64().unwrap(), a);
    }

    // σ now is the fit's; after the design no larger, and the covariance's determinant (the D
    // criterion) no larger than after K uniform measurements.
    let keys = ["adhesion.v0", "adhesion.n"];
    let sig =
        |name: &str| -> Vec<f64> { keys.iter().map(|k| j[name][k].as_f64().unwrap()).collect() };
    let (now, expected, uni) = (
        sig("current_sigma"),
        sig("expected_sigma"),
        sig("uniform_sigma"),
    );
    for (i, p) in fit_json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
    {
        assert_eq!(p["key"], keys[i]);
        let s = p["sigma"].as_f64().unwrap();
        assert!(
            (now[i] - s).abs() <= 1e-9 * s,
            "{}: {} vs {s}",
            keys[i],
            now[i]
        );
        assert!(
            expected[i] <= now[i],
            "{}: {} > {}",
            keys[i],
            expected[i],
            now[i]
        );
        assert!(uni[i] <= now[i]);
    }
    let d_design = det2(&expected, &j["expected_correlation"]);
    let d_uniform = det2(&uni, &j["uniform_correlation"]);
    assert!(d_design <= d_uniform, "{d_design} > {d_uniform}");
    let cv = &j["criterion_value"];
    assert!(cv["expected"].as_f64().unwrap() <= cv["uniform"].as_f64().unwrap());

    // The sensitivities are each key's secant over ±σ (docs/guide/design.md): the value once
    // and two runs per free key at each candidate.
    assert_eq!(j["forward_runs"].as_u64().unwrap(), 25 * (1 + 2 * 2));
    // At 20 µm and 3 mm/s (row 25, where the amplification's local slope in n jumps), the
    // prediction's σ from the secants, by independent runs of `djkr sweep` on fitted.toml at
    // the fit's tolerances: with the model's changes Δv (v0 from v0·e^(−σ/v0) to v0·e^(σ/v0),
    // ±σ of ln v0) and Δn (n ± σ_n), σ² = (Δv/2)² + 2ρ (Δv/2)(Δn/2) + (Δn/2)², whatever the
    // coordinates (a secant over ±σ times σ is half the change). The same runs as design's, up
    // to the rounding of the points' coordinates and of the files' numbers.
    let params = fit_json["parameters"].as_array().unwrap();
    let (v0, sv) = (
        params[0]["value"].as_f64().unwrap(),
        params[0]["sigma"].as_f64().unwrap(),
    );
    let (n, sn) = (
        params[1]["value"].as_f64().unwrap(),
        params[1]["sigma"].as_f64().unwrap(),
    );
    let rho = fit_json["correlation"][0][1].as_f64().unwrap();
    let tol = &fit_json["tolerances"];
    let (rtol, etol) = (
        tol["rtol"].as_f64().unwrap(),
        tol["envelope_tol"].as_f64().unwrap(),
    );
    let change = |set: String, name: &str| -> f64 {
        let sweep = dir.path().join(name);
        let o = djkr(&[
            "sweep",
            fit.join("fitted.toml").to_str().unwrap(),
            "--set",
            "base.amplitude=20um",
            "--set",
            "stage[3].speed=3mm/s",
            "--set",
            &format!("solver.rtol={rtol:e}"),
            "--set",
            &format!("solver.envelope_tol={etol:e}"),
            "--set",
            &set,
            "--out",
            sweep.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let csv = std::fs::read_to_string(sweep.join("sweep.csv")).unwrap();
        let mut lines = csv.lines();
        let col = lines
            .next()
            .unwrap()
            .split(',')
            .position(|h| h == "pull_off_amplification [1]")
            .unwrap();
        let v: Vec<f64> = lines
            .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
            .collect();
        assert_eq!(v.len(), 2);
        v[1] - v[0]
    };
    let dv = change(
        format!(
            "adhesion.v0={:e},{:e}",
            v0 * (-sv / v0).exp(),
            v0 * (sv / v0).exp()
        ),
        "sweep-v0",
    );
    let dn = change(format!("adhesion.n={:e},{:e}", n - sn, n + sn), "sweep-n");
    let want = ((dv / 2.0).powi(2) + rho * dv * dn / 2.0 + (dn / 2.0).powi(2)).sqrt();
    let got: f64 = rows[24][4].parse().unwrap();
    assert_eq!(rows[24][0].parse::<f64>().unwrap(), 2e-5);
    assert!(
        (got - want).abs() <= 1e-9 * want,
        "sigma_prediction at 20 um, 3 mm/s: {got} from design, {want} from the secants"
    );
}

/// Bad input: one line each, exit status 2, nothing written.
#[test]
fn design_refuses_bad_input_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let fit = cheap_fit(dir.path());
    let f = fit.to_str().unwrap();
    let bad = dir.path().join("bad");
    let grid = "base.amplitude=0um:20um:5";
    for (args, words) in [
        (vec!["--candidates", grid, "--add", "0"], "--add 0: must be"),
        (
            vec!["--candidates", "foo.bar=1,2", "--add", "2"],
            "--candidates foo.bar=1,2: unknown section 'foo'",
        ),
        (
            vec!["--candidates", "adhesion.n=0.4,0.5", "--add", "2"],
            "adhesion.n is a key the fit estimated, not a condition",
        ),
        (
            vec![
                "--candidates",
                grid,
                "--add",
                "2",
                "--criterion",
                "adhesion.w0",
            ],
            "--criterion adhesion.w0: must be D, A or a free key of the fit (adhesion.v0, \
             adhesion.n)",
        ),
        (
            vec!["--candidates", grid, "--add", "6", "--no-repeats"],
            "--add 6: with --no-repeats at most the 5 candidates",
        ),
        (
            vec!["--candidates", "base.amplitude=10um", "--add", "2"],
            "the candidates are one point",
        ),
        (
            vec!["--candidates", grid, "--add", "2", "--sigma=0%"],
            "--sigma 0%: a relative sigma must be",
        ),
    ] {
        let mut all = vec!["design", "--fit", f];
        all.extend(args);
        all.extend(["--out", bad.to_str().unwrap()]);
        let o = djkr(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{all:?}: {err}");
        assert!(err.contains(words), "{all:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!bad.exists(), "{all:?}: --out made");
    }
    // A folder without a fit.
    let o = djkr(&[
        "design",
        "--fit",
        dir.path().to_str().unwrap(),
        "--candidates",
        grid,
        "--add",
        "2",
        "--out",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("holds no fit (no fit.json)"));
}
