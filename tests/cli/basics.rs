//! The command line as a contract: JSON keys of `cycle` and `pulloff`, errors that name the flag,
//! the value and what is allowed (exit status 2, never a panic), and every bundled scenario running
//! through `djkr run` with complete output.

use serde_json::Value;
use std::path::{Path, PathBuf};
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
        // Shui et al.'s eq. (5) sets a_m itself: --a-amp has no effect there (and is refused).
        let mut args = vec!["pulloff", "--freq", "400", "--json"];
        if method[1] == "yi" {
            args.extend_from_slice(&["--a-amp", "0.5mm"]);
        }
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
        // A detached run's pull-off force; a run that never detached (impacts.toml) had no
        // pull-off, only a most tensile force.
        let force = if s["detached"] == true {
            assert!(s.get("most_tensile").is_none(), "{name}");
            &s["pull_off"]["force"]
        } else {
            assert_eq!(s["pull_off"], serde_json::json!({}), "{name}");
            &s["most_tensile"]["force"]
        };
        assert!(force.as_f64().unwrap().is_finite(), "{name}");
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
    let law = djkr_core::adhesion::ConstantW { w0: 0.240 };
    let m = djkr_core::material::Material::PAPER;
    let exact =
        djkr_core::imposed_area::pull_off(&m, &law, 2.0 * std::f64::consts::PI * 300.0, 0.5e-3)
            .unwrap();
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
    use djkr_core::adhesion::SaturatedGentSchultz;
    use djkr_core::closed_form::{pull_off_approx, DeltaAmpForm};
    let good = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenarios/good");
    let sat_file = good.join("saturated.toml");
    let sat = SaturatedGentSchultz::new(0.240, 4.45e-5, 0.531, 0.1).unwrap();
    let m = djkr_core::material::Material::PAPER;
    let omega = 2.0 * std::f64::consts::PI * 300.0;
    let base = ["pulloff", "--freq", "300", "--a-amp", "0.5mm", "--json"];
    let mut a = base.to_vec();
    a.extend(["--material", sat_file.to_str().unwrap()]);
    let exact = djkr_core::imposed_area::pull_off(&m, &sat, omega, 0.5e-3).unwrap();
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

// ---------------------------------------------------------------------------------------------
// `--set KEY=VALUE`: on every command that reads a scenario, equal to the edited file; bad
// overrides named as such.

fn scenario(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name)
}

/// A copy of `src` named `name` in `dir`, with `from` replaced by `to` (which must occur once).
fn edited_copy(src: &Path, dir: &Path, name: &str, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(src).unwrap();
    assert_eq!(text.matches(from).count(), 1, "{from} in {}", src.display());
    let p = dir.join(name);
    std::fs::write(&p, text.replace(from, to)).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `v` without its wall-clock times (`wall_s` at any depth).
fn without_wall_times(mut v: Value) -> Value {
    fn strip(v: &mut Value) {
        match v {
            Value::Object(m) => {
                m.remove("wall_s");
                m.values_mut().for_each(strip);
            }
            Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    strip(&mut v);
    v
}

fn ok(args: &[&str]) -> Output {
    let o = djkr(args);
    assert!(
        o.status.success(),
        "djkr {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Each dataset of an HDF5 file (root, events/, cycles/), bit-exactly: f64 as bits, else i64,
/// else strings.
fn h5_datasets(path: &Path) -> Vec<(String, Vec<String>)> {
    let f = hdf5_pure::File::open(path).unwrap();
    let mut names: Vec<String> = f.root().datasets().unwrap();
    for g in f.root().groups().unwrap() {
        let group = f.group(&g).unwrap();
        names.extend(
            group
                .datasets()
                .unwrap()
                .into_iter()
                .map(|d| format!("{g}/{d}")),
        );
    }
    names.sort();
    names
        .into_iter()
        .map(|n| {
            let ds = f.dataset(&n).unwrap();
            let v: Vec<String> = if let Ok(x) = ds.read_f64() {
                x.iter().map(|x| format!("{:016x}", x.to_bits())).collect()
            } else if let Ok(x) = ds.read_i64() {
                x.iter().map(i64::to_string).collect()
            } else {
                ds.read_string().unwrap()
            };
            (n, v)
        })
        .collect()
}

/// `djkr run FILE --set base.amplitude=30um` is the file with `amplitude = "30um"` in it: the same
/// summary (but for the wall time and the record of the override) and bit-identical HDF5 data.
/// Both run as `x.toml` from their own directory, so the summaries name the same file.
#[test]
fn set_on_run_equals_the_edited_file() {
    let src = scenario("paper-protocol-300hz.toml");
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    std::fs::copy(&src, a.path().join("x.toml")).unwrap();
    edited_copy(
        &src,
        b.path(),
        "x.toml",
        "amplitude = 10e-6 ",
        "amplitude = \"30um\" ",
    );
    let run_in = |dir: &Path, extra: &[&str]| {
        let mut args = vec!["run", "x.toml", "--out", "out", "--json"];
        args.extend_from_slice(extra);
        let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
            .args(&args)
            .current_dir(dir)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let printed: Value = serde_json::from_slice(&o.stdout).unwrap();
        let written: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("out/summary.json")).unwrap())
                .unwrap();
        assert_eq!(printed, written);
        written
    };
    let mut set = run_in(a.path(), &["--set", "base.amplitude=30um"]);
    let mut edited = run_in(b.path(), &[]);
    assert_eq!(set["scenario"], "x.toml --set base.amplitude=30um");
    assert_eq!(set["overrides"], serde_json::json!(["base.amplitude=30um"]));
    assert_eq!(edited["scenario"], "x.toml");
    assert_eq!(edited["overrides"], serde_json::json!([]));
    // The README's amplification at 30 µm.
    let amp = set["pull_off"]["amplification"].as_f64().unwrap();
    assert!((amp - 4.81).abs() < 0.01, "{amp}");
    for v in [&mut set, &mut edited] {
        let m = v.as_object_mut().unwrap();
        m.remove("scenario");
        m.remove("overrides");
        // Each run has its own id, and the run file's size depends on the source name it holds.
        m.remove("run_id");
        m.remove("file_bytes");
        let stats = m["stats"].as_object_mut().unwrap();
        stats.remove("wall_s");
        stats.remove("write_s");
    }
    assert_eq!(set, edited);
    let (hs, he) = (
        h5_datasets(&a.path().join("out/run.h5")),
        h5_datasets(&b.path().join("out/run.h5")),
    );
    assert!(
        hs.len() > 20,
        "{:?}",
        hs.iter().map(|d| &d.0).collect::<Vec<_>>()
    );
    assert!(hs.iter().any(|(n, v)| n == "t" && v.len() > 1000));
    assert!(hs == he, "HDF5 datasets differ");
}

/// `validate` and `resonance` with `--set base.amplitude=0.3um` give the JSON and CSV of the file
/// edited to say so; the override changes the result.
#[test]
fn set_on_validate_and_resonance_equals_the_edited_file() {
    let src = scenario("resonance-400hz.toml");
    let dir = tempfile::tempdir().unwrap();
    let edited = edited_copy(
        &src,
        dir.path(),
        "edited.toml",
        "amplitude = 0.5e-6 ",
        "amplitude = \"0.3um\" ",
    );
    let set = ["--set", "base.amplitude=0.3um"];
    let mut args = vec!["validate", s(&src), "--json"];
    let plain = json(&args);
    args.extend(set);
    let v = without_wall_times(json(&args));
    assert_eq!(
        v,
        without_wall_times(json(&["validate", s(&edited), "--json"]))
    );
    assert_eq!(num(&v, "amplitude"), 3e-7);
    assert_ne!(v, without_wall_times(plain));

    let resonance = |file: &Path, out: &Path, extra: &[&str]| {
        let mut args = vec![
            "resonance",
            s(file),
            "--freq",
            "395:405:3",
            "--sweep",
            "up",
            "--no-harmonic-balance",
            "--out",
            s(out),
            "--json",
        ];
        args.extend_from_slice(extra);
        let v = json(&args);
        assert_eq!(num(&v, "amplitude"), 3e-7);
        std::fs::read_to_string(out.join("resonance.csv")).unwrap()
    };
    let a = resonance(&src, &dir.path().join("set"), &set);
    let b = resonance(&edited, &dir.path().join("edited"), &[]);
    assert_eq!(a, b);
    assert_eq!(a.lines().count(), 4);
}

/// `shortcut-map` (whose amplitudes come from `--amp`) with an override of the damping, and
/// `accuracy` with an override of the unload speed, equal the edited files.
#[test]
fn set_on_shortcut_map_and_accuracy_equals_the_edited_file() {
    let dir = tempfile::tempdir().unwrap();
    let src = scenario("resonance-400hz.toml");
    let edited = edited_copy(
        &src,
        dir.path(),
        "c.toml",
        "\nc = 0.5 ",
        "\nc = \"0.6Ns/m\" ",
    );
    let map = |file: &Path, out: &str, extra: &[&str]| {
        let out = dir.path().join(out);
        let mut args = vec![
            "shortcut-map",
            s(file),
            "--freq",
            "400:400:1",
            "--amp",
            "0.3um:0.3um:1",
            "--out",
            s(&out),
            "--json",
        ];
        args.extend_from_slice(extra);
        json(&args);
        std::fs::read_to_string(out.join("shortcut-map.csv")).unwrap()
    };
    let a = map(&src, "set", &["--set", "damping.c=0.6Ns/m"]);
    assert_eq!(a, map(&edited, "edited", &[]));
    assert_ne!(a, map(&src, "plain", &[]));

    let src = scenario("quasi-static-jkr.toml");
    let edited = edited_copy(
        &src,
        dir.path(),
        "q.toml",
        "speed = 1e-6 ",
        "speed = \"2um/s\" ",
    );
    // The study's errors and counts (not its wall times).
    let study = |file: &Path, out: &str, extra: &[&str]| {
        let out = dir.path().join(out);
        let mut args = vec![
            "accuracy",
            s(file),
            "--methods",
            "implicit",
            "--tolerances",
            "1e-6",
            "--repeats",
            "1",
            "--out",
            s(&out),
        ];
        args.extend_from_slice(extra);
        ok(&args);
        let mut r = csv::Reader::from_path(out.join("work_precision.csv")).unwrap();
        let head = r.headers().unwrap().clone();
        let rows: Vec<Vec<(String, String)>> = r
            .records()
            .map(|rec| {
                head.iter()
                    .zip(rec.unwrap().iter())
                    .filter(|(h, _)| !h.starts_with("wall_"))
                    .map(|(h, v)| (h.to_string(), v.to_string()))
                    .collect()
            })
            .collect();
        assert_eq!(rows.len(), 1);
        rows
    };
    let a = study(&src, "acc-set", &["--set", "stage[0].speed=2um/s"]);
    assert_eq!(a, study(&edited, "acc-edited", &[]));
    assert!(
        a[0].iter().any(|(h, v)| h == "status" && v == "ok"),
        "{a:?}"
    );
}

/// `check FILE... --set` applies the overrides to every file and names the result.
#[test]
fn set_on_check_applies_to_every_file() {
    let (r, q) = (
        scenario("resonance-400hz.toml"),
        scenario("quasi-static-jkr.toml"),
    );
    // The resonance scene's stage[0] is a hold, the quasi-static one's an unload to pull-off:
    // a duration ends either.
    let o = ok(&["check", s(&r), s(&q), "--set", "stage[0].duration=0.2s"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        out.matches("--set stage[0].duration=0.2s: ok").count(),
        2,
        "{out}"
    );
    // A speed: the hold refuses it, the unload refuses it negative; each error names its file.
    let o = djkr(&["check", s(&r), s(&q), "--set", "stage[0].speed=-1"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    for want in [
        format!(
            "error: {}: --set stage[0].speed=-1: a hold keeps the spring end still",
            r.display()
        ),
        format!(
            "error: {}: --set stage[0].speed=-1: must be a finite number > 0 (m/s)",
            q.display()
        ),
        "2 of 2 scenario file(s) invalid".to_string(),
    ] {
        assert!(err.contains(&want), "'{want}' missing from: {err}");
    }
}

/// Bad overrides on every command that takes `--set`: exit 2, one message naming the override
/// (not the file's key), never a panic, nothing written.
#[test]
fn bad_overrides_are_named_on_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let (res, qs) = (
        scenario("resonance-400hz.toml"),
        scenario("quasi-static-jkr.toml"),
    );
    let commands: Vec<Vec<&str>> = vec![
        vec!["run", s(&res), "--out", s(&out)],
        vec!["check", s(&res)],
        vec!["validate", s(&res), "--json"],
        vec![
            "resonance",
            s(&res),
            "--freq",
            "395:405:3",
            "--out",
            s(&out),
        ],
        vec![
            "shortcut-map",
            s(&res),
            "--freq",
            "400:400:1",
            "--amp",
            "0.3um:0.3um:1",
            "--out",
            s(&out),
        ],
        vec![
            "accuracy",
            s(&qs),
            "--methods",
            "implicit",
            "--tolerances",
            "1e-6",
            "--repeats",
            "1",
            "--out",
            s(&out),
        ],
    ];
    let cases: &[(&str, &str)] = &[
        (
            "base.amplitude=-1um",
            "--set base.amplitude=-1um: must be a finite number >= 0 (m)",
        ),
        (
            "base.amplitude=1furlong",
            "--set base.amplitude=1furlong: unknown unit 'furlong'",
        ),
        (
            "base.amplitud=30um",
            "--set base.amplitud=30um: unknown key; [base] takes amplitude, frequency, phase",
        ),
        (
            "bse.amplitude=30um",
            "--set bse.amplitude=30um: unknown section 'bse'; the sections are material, adhesion,",
        ),
        (
            "stage[7].speed=1mm/s",
            "--set stage[7].speed=1mm/s: no such stage:",
        ),
        ("base.amplitude", "--set base.amplitude: expected KEY=VALUE"),
        ("=30um", "--set =30um: empty key"),
        ("stage[x].speed=1", "--set stage[x].speed=1: bad index 'x'"),
        ("stage.speed=1", "--set stage.speed=1: [[stage]] is a list"),
        (
            "solver.rtol=1",
            "--set solver.rtol=1: must lie in [1e-14, 1e-2]",
        ),
    ];
    for cmd in &commands {
        for (set, want) in cases {
            // The quasi-static scene has no [base]: its amplitude cases fail on the override's
            // value first, as the file would, or on the missing frequency.
            let mut args = cmd.clone();
            args.extend(["--set", set]);
            let o = djkr(&args);
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "djkr {args:?}: {err}");
            assert!(!err.contains("panicked"), "djkr {args:?}: {err}");
            // One line; `check` adds its count of invalid files after a file's error.
            assert!(
                err.lines().count() <= 1 + usize::from(cmd[0] == "check"),
                "{err}"
            );
            assert!(
                err.contains(want),
                "djkr {args:?}: '{want}' missing from: {err}"
            );
            assert!(!out.exists(), "djkr {args:?} wrote {}", out.display());
        }
    }
    // A section created by an override is then validated as a whole: the frequency is missing.
    let o = djkr(&[
        "run",
        s(&qs),
        "--out",
        s(&out),
        "--set",
        "base.amplitude=30um",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("quasi-static-jkr.toml --set base.amplitude=30um: base.frequency: missing"),
        "{err}"
    );
    // --set needs a scenario.
    let o = djkr(&["accuracy", "--imposed-area", "--set", "base.amplitude=1um"]);
    assert_eq!(o.status.code(), Some(2));
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

/// `run --sensitivity N`: N twins, a `sensitivity` section in summary.json with the runs and
/// the spread, and a printed verdict; a chaotic pull-off is printed with the digits the twins
/// share, not seven.
#[test]
fn run_sensitivity_reports_the_spread_and_prints_only_shared_digits() {
    let out = tempfile::tempdir().unwrap();
    let gentle = scenario("gentle-unload-300hz.toml");
    let od = out.path().join("g");
    let o = djkr(&[
        "run",
        s(&gentle),
        "--sensitivity",
        "3",
        "--out",
        od.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("SENSITIVE"), "{text}");
    let line = text.lines().find(|l| l.contains("pull-off force")).unwrap();
    // "-700 mN" or "-690 mN": no decimals once the twins disagree in the second digit.
    assert!(
        !line.contains(". mN") && !line.split_whitespace().nth(2).unwrap().contains('.'),
        "{line}"
    );
    let j: Value =
        serde_json::from_str(&std::fs::read_to_string(od.join("summary.json")).unwrap()).unwrap();
    let sens = &j["sensitivity"];
    assert_eq!(sens["runs"].as_array().unwrap().len(), 4);
    assert_eq!(sens["key"], "base.amplitude");
    assert_eq!(sens["sensitive"], true);
    assert_eq!(
        sens["runs"][0]["pull_off_force"].as_f64(),
        j["pull_off"]["force"].as_f64()
    );
    // Without the flag: four digits and a pointer to it.
    let o = djkr(&["run", s(&gentle), "--out", od.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("--sensitivity measures"), "{text}");
    assert!(read_summary(&od).get("sensitivity").is_none());
}

fn read_summary(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn a_set_of_a_key_a_flag_replaces_is_refused_naming_the_flag() {
    // Issue 25: `continue --set solver.rtol=1e-4` gave exactly the default result.
    let scene = "scenarios/resonance-400hz.toml";
    let cases: [(&[&str], &str, &str); 8] = [
        (
            &[
                "continue",
                scene,
                "--param",
                "base.frequency",
                "--range",
                "390:400",
            ],
            "solver.rtol=1e-4",
            "--set solver.rtol has no effect on continue: use --rtol",
        ),
        (
            &[
                "continue",
                scene,
                "--param",
                "base.frequency",
                "--range",
                "390:400",
            ],
            "base.frequency=300",
            "--set base.frequency has no effect on continue: use --param with --range",
        ),
        (
            &["validate", scene],
            "solver.rtol=1e-6",
            "--set solver.rtol has no effect on validate: use --rtol",
        ),
        (
            &["resonance", scene, "--freq", "390:400:3"],
            "solver.rtol=1e-6",
            "--set solver.rtol has no effect on resonance: use --rtol",
        ),
        (
            &["resonance", scene, "--freq", "390:400:3"],
            "base.frequency=300",
            "--set base.frequency has no effect on resonance: use --freq",
        ),
        (
            &[
                "shortcut-map",
                scene,
                "--freq",
                "390:400:3",
                "--amp",
                "0.1um:1um:3",
            ],
            "base.amplitude=1um",
            "--set base.amplitude has no effect on shortcut-map: use --amp",
        ),
        (
            &["accuracy", scene],
            "solver.method=dp8",
            "--set solver.method has no effect on accuracy: use --methods",
        ),
        (
            &["accuracy", scene],
            "solver.rtol=1e-6",
            "--set solver.rtol has no effect on accuracy: use --tolerances",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (args, set, want) in cases {
        let mut a: Vec<&str> = args.to_vec();
        let out = dir.path().join("out");
        a.extend(["--set", set, "--out", out.to_str().unwrap()]);
        if args[0] == "validate" {
            a.truncate(a.len() - 2);
        }
        let o = djkr(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {err}");
        assert!(err.contains(want), "{a:?}: {err}");
    }
    // Without a flag that replaces it, the key is honoured: resonance without --amp reads
    // base.amplitude from the file, so a --set of it is accepted.
    let o = djkr(&[
        "resonance",
        scene,
        "--freq",
        "390:400:2",
        "--sweep",
        "up",
        "--no-harmonic-balance",
        "--set",
        "base.amplitude=0.4um",
        "--json",
        "--out",
        dir.path().join("r").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The chaos note appears only where it applies: on the heavy rig of the paper protocol
/// (deterministic to 4.5e-12 between twins) the cycle means approach the pull-off smoothly and
/// the summary only says how to check; on the light rig near resonance (3 % spread over an
/// ensemble) they fluctuate from period to period and the note is printed. summary.json gives
/// the indicator, and both the pull-off time (the force minimum) and the detachment time
/// (contact lost for good, later).
#[test]
fn chaos_note_only_where_the_approach_to_pull_off_is_rough() {
    let out = tempfile::tempdir().unwrap();
    let light = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/sweep/light-protocol-300hz.toml");
    for (file, chaotic) in [
        (scenario("paper-protocol-300hz.toml"), false),
        (light, true),
    ] {
        let od = out.path().join(if chaotic { "light" } else { "heavy" });
        let o = ok(&["run", s(&file), "--out", od.to_str().unwrap()]);
        let text = String::from_utf8_lossy(&o.stdout);
        assert_eq!(text.contains("chaotic"), chaotic, "{text}");
        assert!(text.contains("--sensitivity measures"), "{text}");
        let j = read_summary(&od);
        let roughness = j["pull_off"]["approach_roughness"].as_f64().unwrap();
        assert_eq!(
            roughness > djkr_core::dynamics::ROUGH_APPROACH,
            chaotic,
            "{roughness}"
        );
        let (pull_off, detachment) = (
            j["pull_off"]["time"].as_f64().unwrap(),
            j["detachment"]["time"].as_f64().unwrap(),
        );
        assert!(pull_off < detachment, "{pull_off} {detachment}");
        assert_eq!(j["units"]["detachment.time"], "s");
    }
}

/// Bytes of an HDF5 file that are not dataset storage: the file's size minus every dataset's
/// stored bytes (contiguous size, or the sum of its chunks), read back with hdf5-pure. What is
/// left is object headers, group indexes and the global heap collections of string attributes
/// and string datasets.
fn non_dataset_bytes(path: &Path) -> u64 {
    let f = hdf5_pure::File::open(path).unwrap();
    let mut names: Vec<String> = f.root().datasets().unwrap();
    for g in f.root().groups().unwrap() {
        let group = f.group(&g).unwrap();
        names.extend(
            group
                .datasets()
                .unwrap()
                .into_iter()
                .map(|d| format!("{g}/{d}")),
        );
    }
    let stored: u64 = names
        .iter()
        .map(|n| {
            let ds = f.dataset(n).unwrap();
            match ds.layout().unwrap() {
                hdf5_pure::Layout::Contiguous { size, .. }
                | hdf5_pure::Layout::Compact { size } => size,
                hdf5_pure::Layout::Chunked { .. } => {
                    ds.chunks().unwrap().iter().map(|c| c.storage_size).sum()
                }
                other => panic!("{n}: unexpected layout {other:?}"),
            }
        })
        .sum();
    std::fs::metadata(path).unwrap().len() - stored
}

/// Descriptions are rows of /descriptions, not one attribute per dataset: hdf5-pure 0.47 as
/// released puts every variable-length string attribute in a 4 KiB global-heap collection of its
/// own. The 1 s run of docs/accuracy/hold-400hz-1s.toml had 448 265 bytes that were not dataset
/// storage (of 1 131 913); with the descriptions in a table 257 441, one collection per `units`
/// attribute (which must stay a variable-length attribute for h5py to read it as str) making
/// most of it. The vendored hdf5-pure shares collections among attributes (30 kB;
/// tests/it/output.rs checks that with h5py); here no dataset may carry any other attribute.
#[test]
fn run_files_spend_no_heap_collection_on_descriptions() {
    let out = tempfile::tempdir().unwrap();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/accuracy/hold-400hz-1s.toml");
    for compress in ["false", "true"] {
        let od = out.path().join(compress);
        let set = format!("output.compress={compress}");
        ok(&[
            "run",
            s(&file),
            "--set",
            &set,
            "--out",
            od.to_str().unwrap(),
        ]);
        let h5 = od.join("run.h5");
        let overhead = non_dataset_bytes(&h5);
        let f = hdf5_pure::File::open(&h5).unwrap();
        // With collections of their own, each string attribute would cost 4 KiB; with the
        // vendored hdf5-pure's shared ones, the attributes, object headers, group indexes and
        // the collections of the string datasets take 30 kB together.
        let is_text = |v: &hdf5_pure::AttrValue| v.as_str().is_some();
        let mut strings = f
            .root()
            .attrs()
            .unwrap()
            .values()
            .filter(|v| is_text(v))
            .count();
        for (path, _) in h5_datasets(&h5) {
            let attrs = f.dataset(&path).unwrap().attrs().unwrap();
            strings += attrs.values().filter(|v| is_text(v)).count();
        }
        assert!(
            overhead <= 4096 * strings as u64 + 40_000 && overhead <= 300_000,
            "{compress}: {overhead} bytes are not dataset storage ({strings} string attributes)"
        );
        let d = crate::tools::Descriptions::of(&f);
        for (path, _) in h5_datasets(&h5) {
            let ds = f.dataset(&path).unwrap();
            let attrs = ds.attrs().unwrap();
            let names: Vec<&String> = attrs.keys().collect();
            assert_eq!(names, ["units"], "/{path}");
            assert!(d.get(&format!("/{path}")).is_some(), "/{path} undescribed");
        }
    }
}

/// `output.dense` is a list of windows, given in the file only (moved from the gaps tests).
#[test]
fn set_refuses_dense_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("s.toml");
    std::fs::write(
        &file,
        "version = 1\n[material]\nK = 1e6\nR = 0.01\nw0 = 0.1\n[sphere]\nmass = 0.001\n\
         [spring]\nstiffness = 100\n[initial]\ngap = 1e-5\n[[stage]]\nkind = \"hold\"\n\
         duration = 1\n",
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_djkr"))
        .arg("check")
        .arg(&file)
        .args(["--set", "output.dense=[[1,2]]"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("output.dense"), "{err}");
    assert!(err.contains("cannot be given with --set"), "{err}");
}
