//! The command line as a contract: JSON keys of `cycle` and `pulloff`, errors that name the flag,
//! the value and what is allowed (exit status 2, never a panic), and every bundled scenario running
//! through `djkr run` with complete output.

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

fn djkr(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .output()
        .expect("djkr binary runs")
}

fn json(args: &[&str]) -> Value {
    let o = djkr(args);
    assert!(
        o.status.success(),
        "djkr {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).expect("valid JSON on stdout")
}

fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("key {key} missing or not a number in {v}"))
}

#[test]
fn cycle_json_has_the_contract_keys_in_si() {
    let v = json(&[
        "cycle", "--freq", "200", "--a-mean", "1mm", "--a-amp", "1mm", "--json",
    ]);
    for k in [
        "a_mean",
        "delta_mean",
        "delta_amp",
        "delta_sin",
        "delta_cos",
        "force_mean",
        "contact_fraction",
    ] {
        assert!(num(&v, k).is_finite(), "{k}");
    }
    // SI: radii in metres, the harmonics combine to the amplitude (eq. 27).
    assert!((num(&v, "a_mean") - 1e-3).abs() < 1e-15);
    let (s, c) = (num(&v, "delta_sin"), num(&v, "delta_cos"));
    assert!((s.hypot(c) - num(&v, "delta_amp")).abs() < 1e-12 * num(&v, "delta_amp"));
    assert!((num(&v, "contact_fraction") - 1.0).abs() < 1e-15);
    // The same cycle with units spelled differently gives the same numbers.
    let w = json(&[
        "cycle", "--freq", "0.2kHz", "--a-mean", "0.001", "--a-amp", "1000um", "--json",
    ]);
    assert!((num(&w, "force_mean") - num(&v, "force_mean")).abs() < 1e-12);
}

#[test]
fn pulloff_json_without_vibration_is_classical_jkr() {
    // a_A = 0: every method must give the static load-controlled JKR pull-off, -3/2 pi R w0, at
    // a^3 = 3 pi w0 R^2 / (2K) (paper material).
    let (k, r, w0) = (9.33e6, 0.051, 0.240);
    let f0 = -1.5 * std::f64::consts::PI * r * w0;
    let a0 = (3.0 * std::f64::consts::PI * w0 * r * r / (2.0 * k)).cbrt();
    for method in ["exact", "approx"] {
        let v = json(&[
            "pulloff", "--freq", "300", "--a-amp", "0", "--method", method, "--json",
        ]);
        for key in [
            "a_mean",
            "delta_mean",
            "delta_amp",
            "force",
            "amplification",
        ] {
            assert!(num(&v, key).is_finite(), "{method}: {key}");
        }
        assert!((num(&v, "force") / f0 - 1.0).abs() < 1e-8, "{method}: {v}");
        assert!(
            (num(&v, "amplification") - 1.0).abs() < 1e-8,
            "{method}: {v}"
        );
        assert!((num(&v, "a_mean") / a0 - 1.0).abs() < 1e-6, "{method}: {v}");
    }
}

#[test]
fn pulloff_with_vibration_amplifies_and_material_flags_apply() {
    let v = json(&["pulloff", "--freq", "400", "--a-amp", "0.5mm", "--json"]);
    assert!(num(&v, "amplification") > 10.0, "{v}");
    // Doubling w0 doubles the static reference; the amplification is relative to the flag's w0.
    let w = json(&[
        "pulloff",
        "--freq",
        "400",
        "--a-amp",
        "0",
        "--w0",
        "480mJ/m^2",
        "--json",
    ]);
    assert!((num(&w, "force") / (-1.5 * std::f64::consts::PI * 0.051 * 0.48) - 1.0).abs() < 1e-8);
    for method in [
        &["--method", "yi"][..],
        &[
            "--method",
            "shui",
            "--mass",
            "3g",
            "--damping",
            "0.5",
            "--base-amp",
            "10um",
        ],
    ] {
        let mut args = vec!["pulloff", "--freq", "400", "--a-amp", "0.5mm", "--json"];
        args.extend_from_slice(method);
        assert!(num(&json(&args), "force").is_finite(), "{args:?}");
    }
}

#[test]
fn bad_input_names_the_flag_value_and_range() {
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["pulloff", "--freq", "0", "--a-amp", "1mm"],
            &["--freq", "0", "> 0"],
        ),
        (
            &["pulloff", "--freq", "200", "--a-amp", "-1mm"],
            &["--a-amp", "-1mm", ">= 0"],
        ),
        (
            &[
                "pulloff", "--freq", "200", "--a-amp", "1mm", "--radius", "-1",
            ],
            &["--radius", "-1", "> 0"],
        ),
        (
            &["pulloff", "--freq", "200", "--a-amp", "1mm", "--n", "0"],
            &["--n", "0", "> 0"],
        ),
        (
            &[
                "cycle", "--freq", "200", "--a-mean", "1mm", "--a-amp", "1furlong",
            ],
            &["--a-amp", "furlong", "unknown unit"],
        ),
        (
            &[
                "cycle", "--freq", "200", "--a-mean", "-2mm", "--a-amp", "1mm",
            ],
            &["--a-mean", "-2mm"],
        ),
        (
            &[
                "pulloff", "--freq", "200", "--a-amp", "1mm", "--method", "shui",
            ],
            &["--mass"],
        ),
        (&["run", "no/such/file.toml"], &["no/such/file.toml"]),
    ];
    for (args, needles) in cases {
        let o = djkr(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "djkr {args:?}: {err}");
        assert!(!err.contains("panicked"), "djkr {args:?} panicked: {err}");
        for n in *needles {
            assert!(err.contains(n), "djkr {args:?}: '{n}' missing from: {err}");
        }
    }
}

#[test]
fn check_accepts_bundled_scenarios_and_rejects_bad_ones() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<String> = std::fs::read_dir(dir.join("scenarios"))
        .unwrap()
        .map(|e| e.unwrap().path().display().to_string())
        .filter(|p| p.ends_with(".toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 4);
    let mut args = vec!["check"];
    args.extend(files.iter().map(String::as_str));
    let o = djkr(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bad = dir.join("tests/scenarios/bad");
    let first_bad = std::fs::read_dir(&bad)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "toml"))
        .unwrap();
    let o = djkr(&["check", first_bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr)
        .contains(first_bad.file_name().unwrap().to_str().unwrap()));
}

/// "Every bundled scenario runs from the README's command": each one through `djkr run`, with
/// complete output and physically valid results.
#[test]
fn every_bundled_scenario_runs_with_complete_output() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios");
    let out = tempfile::tempdir().unwrap();
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "toml") {
            continue;
        }
        n += 1;
        let name = p.file_stem().unwrap().to_str().unwrap().to_string();
        let od = out.path().join(&name);
        let o = djkr(&[
            "run",
            p.to_str().unwrap(),
            "--out",
            od.to_str().unwrap(),
            "--csv",
        ]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        for f in ["summary.json", "run.h5", "timeseries.csv", "events.csv"] {
            assert!(od.join(f).is_file(), "{name}: {f} missing");
        }
        let leftovers: Vec<_> = std::fs::read_dir(&od)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|f| f.contains("partial"))
            .collect();
        assert!(
            leftovers.is_empty(),
            "{name}: partial files left: {leftovers:?}"
        );
        let s: Value =
            serde_json::from_str(&std::fs::read_to_string(od.join("summary.json")).unwrap())
                .unwrap();
        assert!(
            s["pull_off"]["force"].as_f64().unwrap().is_finite(),
            "{name}"
        );
        assert!(s["stats"]["steps"].as_u64().unwrap() > 0, "{name}");
        assert_eq!(
            s["non_finite"].as_object().map(|m| m.len()),
            Some(0),
            "{name}"
        );
        // a >= 0 and finite force throughout the written time series.
        let csv = std::fs::read_to_string(od.join("timeseries.csv")).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let ia = header.iter().position(|h| *h == "a [m]").unwrap();
        let iff = header.iter().position(|h| *h == "F [N]").unwrap();
        for l in lines {
            let c: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            assert!(c[ia] >= 0.0 && c[iff].is_finite(), "{name}: {l}");
        }
    }
    assert!(n >= 4);
}

/// `--material FILE` reads the scenario's [material] and [adhesion]: the paper-protocol scene has
/// the paper's constants, so it reproduces the default; the constant-w scene has no rate effect,
/// so the closed form gives exactly 1 and the exact method agrees with a constant-w imposed-area
/// pull-off computed through the library.
#[test]
fn material_file_sets_material_and_law() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios");
    let gs = dir.join("paper-protocol-300hz.toml");
    let cw = dir.join("quasi-static-jkr.toml");
    let base = ["pulloff", "--freq", "300", "--a-amp", "0.5mm", "--json"];
    let default = num(&json(&base), "force");
    let mut a = base.to_vec();
    a.extend(["--material", gs.to_str().unwrap()]);
    assert!((num(&json(&a), "force") - default).abs() < 1e-12 * default.abs());
    let mut a = base.to_vec();
    a.extend(["--material", cw.to_str().unwrap(), "--method", "approx"]);
    assert!((num(&json(&a), "amplification") - 1.0).abs() < 1e-12);
    let mut a = base.to_vec();
    a.extend(["--material", cw.to_str().unwrap()]);
    let law = djkr::adhesion::ConstantW { w0: 0.240 };
    let m = djkr::material::Material::PAPER;
    let exact =
        djkr::imposed_area::pull_off(&m, &law, 2.0 * std::f64::consts::PI * 300.0, 0.5e-3).unwrap();
    assert!((num(&json(&a), "force") - exact.force).abs() < 1e-9 * exact.force.abs());
    let o = djkr(&[
        "pulloff",
        "--freq",
        "300",
        "--a-amp",
        "1mm",
        "--material",
        "no/such.toml",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--material no/such.toml"));
}

/// `--material FILE` takes any law: a saturated Gent–Schultz file gives the library's exact and
/// closed-form pull-off for that law; commands built on the Gent–Schultz constants, and the
/// `--v0`/`--n` flags, refuse a law without them, naming the file and the law (exit 2).
#[test]
fn material_file_with_any_law() {
    use djkr::adhesion::SaturatedGentSchultz;
    use djkr::closed_form::{pull_off_approx, DeltaAmpForm};
    let good = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenarios/good");
    let sat_file = good.join("saturated.toml");
    let sat = SaturatedGentSchultz::new(0.240, 4.45e-5, 0.531, 0.1).unwrap();
    let m = djkr::material::Material::PAPER;
    let omega = 2.0 * std::f64::consts::PI * 300.0;
    let base = ["pulloff", "--freq", "300", "--a-amp", "0.5mm", "--json"];
    let mut a = base.to_vec();
    a.extend(["--material", sat_file.to_str().unwrap()]);
    let exact = djkr::imposed_area::pull_off(&m, &sat, omega, 0.5e-3).unwrap();
    assert!((num(&json(&a), "force") / exact.force - 1.0).abs() < 1e-9);
    a.extend(["--method", "approx"]);
    let approx = pull_off_approx(&m, &sat, omega, 0.5e-3, 2.5, DeltaAmpForm::Derived).unwrap();
    assert!((num(&json(&a), "force") / approx.force - 1.0).abs() < 1e-12);
    // The saturation shows: a less tensile pull-off than the plain Gent–Schultz law's.
    assert!(exact.force > 0.5 * num(&json(&base), "force"));

    let cw = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/quasi-static-jkr.toml");
    let cw = cw.to_str().unwrap();
    for (args, want) in [
        (
            vec![
                "pulloff",
                "--freq",
                "300",
                "--a-amp",
                "1mm",
                "--material",
                cw,
                "--n",
                "0.5",
            ],
            "--v0 and --n set Gent-Schultz constants",
        ),
        (
            vec!["figures", "--out", "target/never", "--material", cw],
            "djkr figures is built on the Gent-Schultz law",
        ),
        (
            vec!["required-speed", "--amplification", "2", "--material", cw],
            "rate-independent",
        ),
    ] {
        let o = djkr(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(
            !args.contains(&"figures") || err.contains("quasi-static-jkr.toml"),
            "{err}"
        );
    }
    assert!(!Path::new("target/never").exists());
}

/// A scenario file that cannot be read: exit 2, the file named, the OS reason said once.
#[test]
fn unreadable_scenario_names_the_file_and_says_why_once() {
    let o = djkr(&["run", "no/such/scenario.toml"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no/such/scenario.toml: cannot read"), "{err}");
    assert_eq!(err.matches("os error").count(), 1, "{err}");
}

/// A pull-off whose contact outgrows the small-contact range of JKR (a ≪ R) is flagged, in the
/// JSON notes and on stderr; the paper's case (a_m + a_A ≈ 4 mm against R = 51 mm) is not.
#[test]
fn pulloff_outside_small_contact_range_is_flagged() {
    let args = [
        "pulloff", "--freq", "400", "--a-amp", "0.5mm", "--n", "1.5", "--json",
    ];
    let o = djkr(&args);
    assert!(o.status.success());
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let notes = v["notes"].as_array().unwrap();
    assert!(
        notes
            .iter()
            .any(|n| n.as_str().unwrap().contains("outside the model")),
        "{v}"
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("warning: outside the model"));
    assert!(num(&v, "a_mean") > 0.2 * 0.051);
    let v = json(&["pulloff", "--freq", "400", "--a-amp", "1.5mm", "--json"]);
    assert!(v["notes"].as_array().unwrap().is_empty(), "{v}");
}

/// `djkr gs-fit` reads a run's own `timeseries.csv` (units in the header, other columns, a row
/// after the contact is lost), end to end; its help names the example record, which fits too.
#[test]
fn gs_fit_reads_a_runs_timeseries() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("unload");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/gs-fit/unload-record.toml");
    let o = djkr(&[
        "run",
        scenario.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let record = out.join("timeseries.csv");
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/gs-fit/unload-record.csv");
    for path in [&record, &example] {
        let v = json(&["gs-fit", path.to_str().unwrap(), "--json"]);
        assert!((num(&v, "w0") / 0.240 - 1.0).abs() < 2e-3, "{v}");
        assert!((num(&v, "n") / 0.531 - 1.0).abs() < 2e-3, "{v}");
        assert!(
            v["rows_out_of_contact"].as_u64().is_some_and(|n| n >= 1),
            "{v}"
        );
    }
    let text = djkr(&["gs-fit", record.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(text.contains("left out 1 row out of contact"), "{text}");
    let help = djkr(&["gs-fit", "--help"]);
    assert!(String::from_utf8_lossy(&help.stdout).contains("docs/gs-fit/unload-record.csv"));
}
