//! Hostile and careless input at the command line (issue 15): special and huge files, unbounded
//! grids, a closed stdout, values outside the model's range, flags that do nothing. Every case
//! ends with a clear message (exit 2) or a result with a warning, never a panic or a hang; each
//! child process runs under a deadline.

use crate::tools;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a djkr run left: exit code (`None`: killed by a signal or by the deadline), stdout,
/// stderr.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Run djkr with `args` in `cwd`, killed after `limit`.
fn djkr_in(cwd: &Path, args: &[&str], limit: Duration) -> Run {
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("djkr binary runs");
    let (status, stdout, stderr) = tools::finish_within(child, limit);
    assert!(
        status.is_some(),
        "djkr {args:?} did not finish within {limit:?} (hang); stderr: {stderr}"
    );
    Run {
        code: status.and_then(|s| s.code()),
        stdout,
        stderr,
    }
}

fn djkr(args: &[&str]) -> Run {
    djkr_in(
        Path::new(env!("CARGO_MANIFEST_DIR")),
        args,
        Duration::from_secs(60),
    )
}

/// Exit status 2, no panic, and every needle in stderr.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let r = djkr(args);
    assert!(
        !r.stderr.contains("panicked"),
        "djkr {args:?}: {}",
        r.stderr
    );
    assert_eq!(r.code, Some(2), "djkr {args:?}: {}", r.stderr);
    for n in needles {
        assert!(
            r.stderr.contains(n),
            "djkr {args:?}: '{n}' missing from: {}",
            r.stderr
        );
    }
    r.stderr
}

fn manifest(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

// ---------------------------------------------------------------------------------------------
// Item 3: input files are read with a size limit; special files are refused up front.

#[cfg(unix)]
fn fifo(dir: &Path) -> PathBuf {
    let p = dir.join("fifo.toml");
    let ok = Command::new("mkfifo").arg(&p).status().unwrap().success();
    assert!(ok, "mkfifo");
    p
}

#[cfg(unix)]
#[test]
fn special_files_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let f = fifo(dir.path());
    let d = dir.path().to_path_buf();
    for (path, what) in [
        ("/dev/zero", "character device"),
        ("/dev/urandom", "character device"),
        (s(&f), "FIFO"),
        (s(&d), "directory"),
    ] {
        refused(&["check", path], &[path, what, "not a regular file"]);
        refused(&["run", path], &[path, what]);
        refused(
            &[
                "cycle",
                "--freq",
                "200",
                "--a-mean",
                "1mm",
                "--a-amp",
                "1mm",
                "--material",
                path,
            ],
            &["--material", path, what],
        );
        refused(&["gs-fit", path], &[path, what]);
    }
    // A tabulated law's file.
    let scn = dir.path().join("tab.toml");
    let text = std::fs::read_to_string(manifest("tests/scenarios/good/tabulated.toml"))
        .unwrap()
        .replace("law-table.csv", s(&f));
    std::fs::write(&scn, text).unwrap();
    refused(&["check", s(&scn)], &["adhesion.file", "FIFO"]);
}

#[test]
fn oversized_files_are_refused_with_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.toml");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(3 << 20).unwrap(); // sparse: no disk used
    refused(&["check", s(&big)], &[s(&big), "1 MiB", "scenario file"]);
    refused(
        &[
            "pulloff",
            "--freq",
            "200",
            "--a-amp",
            "1mm",
            "--material",
            s(&big),
        ],
        &["1 MiB"],
    );
    let csv = dir.path().join("big.csv");
    std::fs::File::create(&csv)
        .unwrap()
        .set_len(600 << 20)
        .unwrap();
    refused(&["gs-fit", s(&csv)], &[s(&csv), "512 MiB", "record"]);
    let law = dir.path().join("law.csv");
    std::fs::File::create(&law)
        .unwrap()
        .set_len(20 << 20)
        .unwrap();
    let scn = dir.path().join("tab.toml");
    let text = std::fs::read_to_string(manifest("tests/scenarios/good/tabulated.toml"))
        .unwrap()
        .replace("law-table.csv", s(&law));
    std::fs::write(&scn, text).unwrap();
    refused(&["check", s(&scn)], &["adhesion.file", "16 MiB"]);
}

// ---------------------------------------------------------------------------------------------
// Item 4 (part): the default output folder of `run` is always a proper subfolder of out/.

#[test]
fn default_out_folder_is_a_subfolder_of_out_for_any_file_name() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(manifest("tests/scenarios/good/rigid-link.toml")).unwrap();
    std::fs::write(dir.path().join("...toml"), &text).unwrap();
    let r = djkr_in(dir.path(), &["run", "...toml"], Duration::from_secs(60));
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(!dir.path().join("summary.json").exists());
    assert!(!dir.path().join("run.h5").exists());
    assert!(
        dir.path().join("out/scenario/summary.json").exists(),
        "{}",
        r.stdout
    );
}

// ---------------------------------------------------------------------------------------------
// Item 6: every accepted input gives a valid result, a clear error, or a warning.

fn scenario(rel: &str) -> String {
    s(&manifest(rel)).to_string()
}

#[test]
fn impossible_scenes_are_refused_at_validation() {
    let minimal = scenario("tests/scenarios/good/minimal.toml");
    let resting = scenario("tests/scenarios/good/resting-on-weight.toml");
    let paper = scenario("scenarios/paper-protocol-300hz.toml");
    // R = 1e-9: the jump-in radius alone is 6 R.
    refused(
        &["check", &minimal, "--set", "material.R=1e-9"],
        &["[material]", "jump-in radius", "exceeds R"],
    );
    // gravity = 1e20 is beyond any rig; a weight within the bounds but beyond 1e6 x the
    // adhesive force is lost to rounding on a spring; resting on it, the contact exceeds R.
    refused(
        &["check", &paper, "--set", "sphere.gravity=1e20"],
        &["--set sphere.gravity=1e20", "must not exceed 1e4 (m/s^2)"],
    );
    refused(
        &["check", &paper, "--set", "sphere.mass=1e4"],
        &["[sphere]", "mass = 10000 kg", "the weight m g"],
    );
    refused(
        &["run", &resting, "--set", "sphere.mass=1e4"],
        &["[sphere]", "rests on its weight", "> R"],
    );
    // Values far beyond any rig (found by the fuzz test: they ran without end).
    refused(
        &["check", &resting, "--set", "material.K=9.33e47"],
        &["--set material.K=9.33e47", "must not exceed 1e13 (Pa)"],
    );
    refused(
        &["check", &paper, "--set", "stage[0].speed=1e125"],
        &["--set stage[0].speed=1e125", "must not exceed 1e2 (m/s)"],
    );
    // frequency = 1e-300: a period longer than any run.
    refused(
        &["check", &paper, "--set", "base.frequency=1e-300"],
        &["--set base.frequency=1e-300", "[1e-6, 1e6] (Hz)"],
    );
    // What run refuses at setup, check refuses too (mass 0 with damping).
    refused(
        &[
            "check",
            &scenario("tests/scenarios/good/quasi-static-mass-zero.toml"),
            "--set",
            "damping.c=0.5",
        ],
        &["mass = 0 with damping"],
    );
    refused(
        &["check", &minimal, "--set", "solver.method=dp8"],
        &["solver.method", "rate-independent"],
    );
}

#[test]
fn contacts_beyond_the_small_contact_range_are_warned_everywhere() {
    // cycle: text and JSON (a_m + a_A = 31 mm: beyond 0.2 R, within R; a contact wider than R
    // is refused since issue 24).
    let r = djkr(&[
        "cycle", "--freq", "200", "--a-mean", "1mm", "--a-amp", "30mm", "--json",
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    let notes = v["notes"].as_array().unwrap();
    assert!(
        notes[0].as_str().unwrap().contains("outside the model"),
        "{v}"
    );
    assert!(
        r.stderr.contains("warning: outside the model"),
        "{}",
        r.stderr
    );
    let r = djkr(&[
        "cycle", "--freq", "200", "--a-mean", "1mm", "--a-amp", "30mm",
    ]);
    assert!(r.stdout.contains("note: outside the model"), "{}", r.stdout);
    let r = djkr(&[
        "cycle", "--freq", "200", "--a-mean", "1mm", "--a-amp", "1mm", "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    assert!(v["notes"].as_array().unwrap().is_empty(), "{v}");
    // run: stderr, text and summary.json (also through --json).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("small");
    let rigid = scenario("tests/scenarios/good/rigid-link.toml");
    let r = djkr(&["run", &rigid, "--set", "material.R=2e-4", "--out", s(&out)]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(
        r.stderr.contains("warning: outside the model"),
        "{}",
        r.stderr
    );
    assert!(
        r.stdout.contains("warning            outside the model"),
        "{}",
        r.stdout
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let w = summary["warnings"].as_array().unwrap();
    assert!(w[0].as_str().unwrap().contains("0.405 R"), "{summary}");
    // check says so before the run.
    let r = djkr(&["check", &rigid, "--set", "material.R=2e-4"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(
        r.stderr.contains("warning: ") && r.stderr.contains("0.405 R"),
        "{}",
        r.stderr
    );
    let r = djkr(&["run", &rigid, "--out", s(&dir.path().join("ok")), "--json"]);
    let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    assert_eq!(v["warnings"], serde_json::json!([]), "{v}");
}

#[test]
fn a_pull_off_never_recorded_is_reported_missing() {
    // A base period of 1000 s: no cycle completes, so there is no cycle-averaged force; the
    // summary used to print pull_off.force = 0.0 at t = 0.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("slow");
    let r = djkr(&[
        "run",
        &scenario("scenarios/resonance-400hz.toml"),
        "--set",
        "base.frequency=1e-3",
        "--out",
        s(&out),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.stdout.contains("no pull-off"), "{}", r.stdout);
    assert!(!r.stdout.contains("amplification"), "{}", r.stdout);
    assert!(
        r.stderr.contains("warning: no pull-off force recorded"),
        "{}",
        r.stderr
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(v["pull_off"].get("force").is_none(), "{v}");
    assert_eq!(v["non_finite"]["pull_off.force"], "NaN");
}

// ---------------------------------------------------------------------------------------------
// Item 8: every grid and list is bounded; the message names the flag and the limit.

#[test]
fn grids_are_bounded_naming_the_flag_and_the_limit() {
    let res = scenario("scenarios/resonance-400hz.toml");
    let tol21 = vec!["1e-6"; 21].join(",");
    let nodes33 = vec!["11"; 33].join(",");
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec!["shortcut-map", &res, "--freq", "300:500:100000", "--amp", "0.05um:2um:100000"],
            vec!["--freq = 300:500:100000", "1..=1001"],
        ),
        (
            vec!["shortcut-map", &res, "--freq", "300:500:1001", "--amp", "0.05um:2um:1001"],
            vec!["--freq 300:500:1001 --amp 0.05um:2um:1001", "1002001 cells", "limit of 10000"],
        ),
        (
            vec!["resonance", &res, "--freq", "300:500:100000"],
            vec!["--freq = 300:500:100000", "1..=2001"],
        ),
        (
            vec!["beta-fit", "--speed-ratio", "1e-2:1e2:100000"],
            vec!["--speed-ratio", "100000 speed ratios", "limit of 1000"],
        ),
        (
            vec!["beta-fit", "--speed-ratio", "1e-2:1e2:1000", "--n-values", "0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1.0,1.1,1.2,1.3,1.4,1.5,1.6,1.7,1.8,1.9,2.0,2.1"],
            vec!["21000 exact pull-offs", "limit of 20000"],
        ),
        (
            vec!["beta-fit", "--beta", "0.5:10:100000"],
            vec!["--beta", "limit of 10000"],
        ),
        (
            vec!["accuracy", &res, "--repeats", "1000"],
            vec!["--repeats", "1..=100"],
        ),
        (
            vec!["accuracy", &res, "--tolerances", &tol21],
            vec!["--tolerances", "21 tolerances", "limit of 20"],
        ),
        (
            vec!["accuracy", "--imposed-area", "--nodes", &nodes33],
            vec!["--nodes", "33 node counts", "limit of 32"],
        ),
    ];
    for (args, needles) in cases {
        let t = Instant::now();
        refused(&args, &needles);
        assert!(
            t.elapsed() < Duration::from_secs(10),
            "{args:?} took {:?}",
            t.elapsed()
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Item 9: a closed stdout ends djkr quietly (SIGPIPE restored), never with a panic.

#[cfg(unix)]
#[test]
fn a_closed_stdout_ends_djkr_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    let figs = dir.path().join("figs");
    for args in [
        vec!["figures", "--only", "fig2", "--out", s(&figs)],
        vec![
            "cycle", "--freq", "200", "--a-mean", "1mm", "--a-amp", "1mm",
        ],
        vec!["help"],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_djkr"))
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take()); // the reader goes away at once, as `| head -0` would
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_ne!(out.status.code(), Some(101), "{args:?}: {err}");
        assert!(
            out.status.success() || out.status.signal() == Some(libc::SIGPIPE),
            "{args:?}: {:?} {err}",
            out.status
        );
    }
}

/// `validate scenarios/impacts.toml` printed `346.30626-1379.26544`: columns ran together.
#[test]
fn validate_table_columns_never_run_together() {
    let r = djkr(&["validate", &scenario("scenarios/impacts.toml")]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let mut rows = 0;
    for line in r.stdout.lines() {
        for label in [
            "time domain",
            "imposed area",
            "linear transfer",
            "paper (39)",
        ] {
            if let Some(rest) = line.strip_prefix(label) {
                rows += 1;
                for cell in rest.split_whitespace() {
                    assert!(
                        cell == "—" || cell.parse::<f64>().is_ok(),
                        "cell '{cell}' in: {line}\n{}",
                        r.stdout
                    );
                }
            }
        }
    }
    assert!(rows >= 6, "{}", r.stdout);
}

/// `accuracy scenarios/quasi-static-jkr.toml`, the --help example, ran 12 cases that could only
/// fail (explicit methods on a constant-w law): they are skipped up front, saying so.
#[test]
fn accuracy_skips_methods_that_cannot_run_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let r = djkr(&[
        "accuracy",
        &scenario("scenarios/quasi-static-jkr.toml"),
        "--tolerances",
        "1e-4",
        "--repeats",
        "1",
        "--out",
        s(dir.path()),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(
        r.stderr.contains("skipping dp8, dopri5, dop853"),
        "{}",
        r.stderr
    );
    assert!(r.stderr.contains("rate-independent"), "{}", r.stderr);
    assert!(
        !r.stdout
            .lines()
            .any(|l| l.starts_with("| dp8") || l.starts_with("| dop")),
        "{}",
        r.stdout
    );
    assert!(r.stdout.contains("| implicit | 1e-4 |"), "{}", r.stdout);
    let r = djkr(&[
        "accuracy",
        &scenario("scenarios/quasi-static-jkr.toml"),
        "--methods",
        "dp8",
        "--out",
        s(dir.path()),
    ]);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(
        r.stderr.contains("--methods = dp8: none of them can run"),
        "{}",
        r.stderr
    );
    let help = djkr(&["--help"]).stdout;
    assert!(
        !help.contains("accuracy scenarios/quasi-static-jkr"),
        "{help}"
    );
}

// ---------------------------------------------------------------------------------------------
// Item 9: flags that have no effect are refused, naming them; flag values and event names as
// the user writes them.

#[test]
fn flags_without_effect_are_refused_naming_them() {
    let pulloff = ["pulloff", "--freq", "400", "--a-amp", "0.5mm"];
    let with = |extra: &[&'static str]| {
        let mut v: Vec<&str> = pulloff.to_vec();
        v.extend_from_slice(extra);
        v
    };
    refused(
        &with(&["--beta", "3"]),
        &["--beta has no effect with --method exact"],
    );
    refused(
        &with(&["--method", "approx", "--mass", "3g"]),
        &["--mass has no effect with --method approx"],
    );
    refused(
        &with(&[
            "--method",
            "exact",
            "--delta-form",
            "printed",
            "--damping",
            "1",
        ]),
        &["--delta-form, --damping have no effect with --method exact"],
    );
    refused(
        &[
            "pulloff",
            "--freq",
            "400",
            "--a-amp",
            "1mm",
            "--method",
            "shui",
            "--mass",
            "3g",
            "--damping",
            "0.5",
            "--base-amp",
            "10um",
        ],
        &["--a-amp has no effect with --method shui"],
    );
    refused(
        &["gs-fit", "docs/gs-fit/unload-record.csv", "--n", "0.5"],
        &["--n has no effect in gs-fit"],
    );
    refused(
        &["required-speed", "--amplification", "10", "--radius", "1mm"],
        &["--radius has no effect in required-speed"],
    );
    refused(
        &["accuracy", "--imposed-area", "--tolerances", "1e-6"],
        &["--tolerances has no effect with --imposed-area"],
    );
    refused(
        &[
            "accuracy",
            "scenarios/quasi-static-jkr.toml",
            "--nodes",
            "11",
        ],
        &["--nodes has no effect without --imposed-area"],
    );
    // The approx method still takes its own flags; its note names the form as a user would.
    let r = djkr(&with(&[
        "--method",
        "approx",
        "--beta",
        "3",
        "--delta-form",
        "printed",
        "--json",
    ]));
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.stdout.contains("as printed in eq. (23)"), "{}", r.stdout);
    assert!(!r.stdout.contains("Printed"), "{}", r.stdout);
}

#[test]
fn messages_use_the_names_users_write() {
    // --method exact (not `Exact`) in the message.
    let e = refused(
        &["pulloff", "--freq", "400"],
        &["--a-amp is required for --method exact"],
    );
    assert!(!e.contains("Exact"), "{e}");
    // Event kinds as summary.json spells them, not Rust's (ContactLoss).
    let dir = tempfile::tempdir().unwrap();
    let r = djkr(&[
        "run",
        &scenario("tests/scenarios/good/rigid-link.toml"),
        "--out",
        s(dir.path()),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(
        r.stdout
            .contains("contact-loss ×1, pull-off ×1, stage-start ×1"),
        "{}",
        r.stdout
    );
    assert!(!r.stdout.contains("ContactLoss"), "{}", r.stdout);
    // A short method line.
    let first = r.stdout.lines().next().unwrap();
    assert!(first.ends_with("method implicit (auto)"), "{first}");
}

/// I/O errors printed the OS message twice (`...: Not a directory (os error 20): Not a
/// directory (os error 20)`).
#[test]
fn io_errors_print_the_os_message_once() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let under = |n: &str| s(&file.join(n)).to_string();
    let rigid = scenario("tests/scenarios/good/rigid-link.toml");
    for args in [
        vec!["run".to_string(), rigid.clone(), "--out".into(), under("x")],
        vec![
            "figures".into(),
            "--only".into(),
            "fig2".into(),
            "--out".into(),
            under("f"),
        ],
        vec!["gs-fit".into(), under("none.csv")],
        vec!["check".into(), under("none.toml")],
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let e = refused(&args, &[]);
        assert_eq!(e.matches("os error").count(), 1, "{args:?}: {e}");
    }
}

/// `-0.00000` was printed for values that round to zero (validate at X_b = 0).
#[test]
fn no_negative_zero_is_printed() {
    let r = djkr(&[
        "validate",
        &scenario("scenarios/resonance-400hz.toml"),
        "--set",
        "base.amplitude=0",
    ]);
    for cell in r.stdout.split_whitespace() {
        let digits = cell.trim_start_matches('-');
        let zero = !digits.is_empty() && digits.chars().all(|c| c == '0' || c == '.');
        assert!(
            !(cell.starts_with('-') && zero),
            "'{cell}' in:\n{}",
            r.stdout
        );
    }
    assert!(r.stdout.contains("0.00000"), "{}", r.stdout);
}
