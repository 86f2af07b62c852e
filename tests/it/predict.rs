//! `djkr predict` (issue 34): predictions from a fit's folder with their uncertainty, on the
//! cheap rig of `fit.rs` (a fit of adhesion.v0 and adhesion.n to six rows).

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn djkr(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .output()
        .expect("djkr runs")
}

fn column(csv: &str, name: &str) -> Vec<f64> {
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let j = head
        .iter()
        .position(|h| h.split(" [").next() == Some(name))
        .unwrap_or_else(|| panic!("no column {name} in {head:?}"));
    lines
        .map(|l| l.split(',').nth(j).unwrap().parse().unwrap())
        .collect()
}

fn predict(fit: &Path, out: &Path, extra: &[&str]) -> Value {
    let mut args = vec![
        "predict",
        "--fit",
        fit.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ];
    args.extend(extra);
    let o = djkr(&args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let printed: Value = serde_json::from_slice(&o.stdout).unwrap();
    let file: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("prediction.json")).unwrap())
            .unwrap();
    assert_eq!(printed, file, "--json prints prediction.json");
    file
}

/// At the data's own conditions the prediction is the fit's: `value` equals residuals.csv's
/// `fitted` to the bit (the same runs, at the scenario's tolerances). sigma_parameters is
/// positive and finite, the bands are value -+ sigma and -+ 1.96 sigma, and the samples' spread
/// agrees with the linear propagation within the documented factor 1.5 (with 40 draws the
/// spread's own error is about 11 %). A grid given with `--set` gives one row per point, its
/// conditions in SI. About 10 s.
#[test]
fn predictions_at_the_data_reproduce_the_fit_and_carry_its_covariance() {
    let dir = tempfile::tempdir().unwrap();
    let data = crate::fit::cheap_data(dir.path());
    let fit = dir.path().join("fit");
    let (j, _) = crate::fit::fit_cheap(
        &data,
        &fit,
        &["--free", "adhesion.v0", "--free", "adhesion.n"],
    );
    assert_eq!(j["converged"], true);
    let p = j["parameters"].as_array().unwrap();
    assert_eq!(p[0]["coordinate"], "log");
    assert_eq!(p[1]["coordinate"], "linear");

    let out = dir.path().join("pred");
    let r = predict(&fit, &out, &["--samples", "40", "--seed", "5"]);
    let residuals = std::fs::read_to_string(fit.join("residuals.csv")).unwrap();
    let fitted = column(&residuals, "fitted");
    let csv = std::fs::read_to_string(out.join("prediction.csv")).unwrap();
    assert_eq!(
        csv.lines().next().unwrap(),
        "base.amplitude [m],stage[3].speed [m/s],value [1],sigma_parameters [1],\
         sigma_ensemble [1],sigma [1],lo68 [1],hi68 [1],lo95 [1],hi95 [1],sigma_samples [1]"
    );
    let value = column(&csv, "value");
    assert_eq!(value, fitted, "the fit's own predictions, to the bit");
    // The numbers from the CSV (shortest round-trip digits, parsed exactly; serde_json's
    // default parser may be an ulp off).
    assert_eq!(r["rows"].as_array().unwrap().len(), 6);
    let (sp, ss, s) = (
        column(&csv, "sigma_parameters"),
        column(&csv, "sigma_samples"),
        column(&csv, "sigma"),
    );
    let (lo68, hi95) = (column(&csv, "lo68"), column(&csv, "hi95"));
    for i in 0..6 {
        let v = value[i];
        assert!(sp[i] > 0.0 && sp[i] < 0.5 * v.abs(), "row {i}: {}", sp[i]);
        assert_eq!(s[i], sp[i], "no ensemble: sigma is sigma_parameters");
        assert_eq!(lo68[i], v - s[i]);
        assert_eq!(hi95[i], v + 1.959963984540054 * s[i]);
        assert!(
            ss[i] < 1.5 * sp[i] && sp[i] < 1.5 * ss[i],
            "row {i}: samples {}, linear {}",
            ss[i],
            sp[i]
        );
    }

    let out2 = dir.path().join("grid");
    let g = predict(
        &fit,
        &out2,
        &[
            "--set",
            "base.amplitude=5um,15um",
            "--set",
            "stage[3].speed=100um/s",
        ],
    );
    let rows = g["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1]["conditions"][0].as_f64().unwrap(), 15e-6);
    assert_eq!(rows[1]["conditions"][1].as_f64().unwrap(), 1e-4);
    assert!(rows[1]["sigma_parameters"].as_f64().unwrap() > 0.0);
    // 5 um at 100 um/s is a data row: the same value as the fit's.
    let grid_csv = std::fs::read_to_string(out2.join("prediction.csv")).unwrap();
    assert_eq!(column(&grid_csv, "value")[0], fitted[0]);

    // Bad input: one line each, exit status 2.
    let bad = dir.path().join("bad");
    for (args, words) in [
        (
            vec!["--fit", dir.path().to_str().unwrap()],
            "holds no fit (no fit.json)",
        ),
        (
            vec![
                "--fit",
                fit.to_str().unwrap(),
                "--set",
                "adhesion.n=0.4,0.5",
            ],
            "a key the fit estimated, not a condition",
        ),
        (
            vec!["--fit", fit.to_str().unwrap(), "--samples", "1"],
            "--samples 1",
        ),
    ] {
        let mut all = vec!["predict"];
        all.extend(args);
        all.extend(["--out", bad.to_str().unwrap()]);
        let o = djkr(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{all:?}: {err}");
        assert!(err.contains(words), "{all:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
}
