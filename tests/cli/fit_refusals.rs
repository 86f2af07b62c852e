//! `djkr fit` attacked as a hostile or careless user would (issue 35, items 1, 3, 4, 6, 11, 12):
//! an ensemble too large to hold, a FIFO or a device as the data file, a file that is not data at
//! all, cells of megabytes, data whose chi2 cannot be finite, CRLF files and blank lines, bounds
//! of ±1e308. Each case ends with one clear message and exit status 2 (or, for a valid fit of
//! extreme data, a result whose numbers are all finite), never a hang, an abort or an echo of the
//! file; each child process runs under a deadline. The fits use tests/sweep/tiny.toml (a run of
//! a few milliseconds), so the whole file runs in a few seconds.

use crate::tools;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const TINY: &str = "tests/sweep/tiny.toml";
const HEADER: &str = "base.amplitude [um],pull_off_amplification [1]";
const HEADER_OBS: &str = "pull_off_amplification [1]";

/// What a djkr run left: exit code (`None`: killed by a signal), stdout, stderr, wall time.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    seconds: f64,
}

/// `djkr fit DATA --scenario tiny.toml --out OUT ARGS...` from the repository's root, killed after
/// 60 s (a hang fails the test).
fn fit(data: &Path, out: &Path, args: &[&str]) -> Run {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = vec![
        "fit",
        data.to_str().unwrap(),
        "--scenario",
        TINY,
        "--out",
        out.to_str().unwrap(),
    ];
    all.extend_from_slice(args);
    let t0 = Instant::now();
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(&all)
        .current_dir(root)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("djkr runs");
    let (status, stdout, stderr) = tools::finish_within(child, Duration::from_secs(60));
    let status = status.unwrap_or_else(|| panic!("djkr {all:?} hung; stderr: {stderr}"));
    Run {
        code: status.code(),
        stdout,
        stderr,
        seconds: t0.elapsed().as_secs_f64(),
    }
}

/// Exit status 2 with one line on stderr holding every needle, no panic, nothing written in
/// `out`. Returns the line.
fn refused(data: &Path, out: &Path, args: &[&str], needles: &[&str]) -> String {
    let r = fit(data, out, args);
    let e = r.stderr.trim_end().to_string();
    assert_eq!(r.code, Some(2), "{args:?}: {e}");
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(e.lines().count(), 1, "{args:?}: {e}");
    for n in needles {
        assert!(e.contains(n), "'{n}' missing from: {e}");
    }
    assert!(
        !out.join("fit.json").exists(),
        "a refused fit wrote fit.json"
    );
    e
}

fn data(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn good(dir: &Path) -> PathBuf {
    data(dir, "good.csv", &format!("{HEADER}\n5,2\n10,3\n20,4\n"))
}

/// Item 1: an ensemble whose runs or memory pass a sweep's bounds is refused at once, before
/// any work: the reproducers aborted on a 28.8 TB allocation, or allocated 2.9 GB.
#[test]
fn an_ensemble_too_large_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = good(dir.path());
    let out = dir.path().join("o");
    for n in ["99999999999", "10000000"] {
        let e = refused(
            &d,
            &out,
            &["--free", "adhesion.n", "--ensemble", n],
            &[
                &format!("--ensemble {n}: 3 rows x {n} members x 3 parameter sets"),
                "more than 10000000 runs",
            ],
        );
        eprintln!("{e}");
        assert!(!out.exists(), "--out was created before the refusal");
    }
    // Within the count of runs, but not within the memory the scenario allows.
    let e = refused(
        &d,
        &out,
        &[
            "--free",
            "adhesion.n",
            "--ensemble",
            "100000",
            "--set",
            "solver.max_memory=1048576",
        ],
        &[
            "--ensemble 100000: a batch of 900000 runs",
            "more than solver.max_memory = 1048576 bytes (1.0 MiB)",
        ],
    );
    eprintln!("{e}");
}

/// Item 3: a FIFO, a device or a directory as the data file is refused at once (the FIFO hung,
/// /dev/zero was read without end), naming the path and what it is; so is a file beyond the
/// 16 MiB limit of a fit data file.
#[cfg(unix)]
#[test]
fn special_and_huge_data_files_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("data.csv");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let out = dir.path().join("o");
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    for (path, what) in [
        (fifo.clone(), "is a FIFO (named pipe), not a regular file"),
        (PathBuf::from("/dev/zero"), "is a character device"),
        (sub, "is a directory"),
    ] {
        let t0 = Instant::now();
        refused(
            &path,
            &out,
            &["--free", "adhesion.n"],
            &[&format!("{}: {what}", path.display())],
        );
        assert!(t0.elapsed() < Duration::from_secs(10), "{path:?}");
    }
    let big = dir.path().join("big.csv");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(17 << 20).unwrap(); // sparse: no disk used
    refused(
        &big,
        &out,
        &["--free", "adhesion.n"],
        &["big.csv: larger than 16777216 bytes (16 MiB), the limit for a fit data file"],
    );
}

/// Item 4: a file that is not data at all is refused without showing its content, and a cell
/// of megabytes is quoted cut to 80 characters (the whole 100 MB cell was echoed on one line).
#[test]
fn the_content_of_a_bad_file_is_not_echoed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let shadow = data(
        dir.path(),
        "shadow",
        "root:$6$s3cr3tHash$abcdefghijkl:19000:0:99999:7:::\ndaemon:*:19000:0:99999:7:::\n",
    );
    let e = refused(
        &shadow,
        &out,
        &["--free", "adhesion.n"],
        &["line 1, column 1 (a header cell of", "not shown"],
    );
    for secret in ["root", "s3cr3t", "19000", "daemon"] {
        assert!(!e.contains(secret), "{e}");
    }
    let long = "x".repeat(5 << 20);
    let cell = data(
        dir.path(),
        "cell.csv",
        &format!("{HEADER}\n5,2\n10,{long}\n20,4\n"),
    );
    let e = refused(
        &cell,
        &out,
        &["--free", "adhesion.n"],
        &["line 3, column 2", "bytes in all)", "is not a number"],
    );
    assert!(e.len() < 600, "{} bytes: {e}", e.len());
    let digits = data(
        dir.path(),
        "digits.csv",
        &format!("{HEADER}\n5,2\n10,{}\n20,4\n", "9".repeat(5 << 20)),
    );
    let e = refused(
        &digits,
        &out,
        &["--free", "adhesion.n"],
        &["line 3, column 2", "is not a finite number"],
    );
    assert!(e.len() < 600, "{} bytes: {e}", e.len());
    // A text key's cell is taken as typed and refused by the scenario: quoted cut too.
    let method = data(
        dir.path(),
        "method.csv",
        &format!(
            "base.amplitude [um],solver.method,{HEADER_OBS}\n5,auto,2\n10,{long},3\n20,auto,4\n"
        ),
    );
    let e = refused(
        &method,
        &out,
        &["--free", "adhesion.n"],
        &[
            "method.csv line 3: --set solver.method=xxx",
            "bytes in all): must be one of",
        ],
    );
    assert!(e.len() < 600, "{} bytes: {e}", e.len());
    let unit = data(
        dir.path(),
        "unit.csv",
        &format!("base.amplitude [{long}],pull_off_amplification [1]\n5,2\n"),
    );
    let e = refused(
        &unit,
        &out,
        &["--free", "adhesion.n"],
        &["line 1, column 1"],
    );
    assert!(e.len() < 800, "{} bytes: {e}", e.len());
}

/// Item 6: data whose chi2 cannot be finite (an observable of 1e308, a sigma of 1e-308 or one
/// far below what the model predicts) are refused naming the row and the column; extreme data
/// that can be fitted give finite numbers everywhere, a note in words and no sigma of 0.
#[test]
fn data_whose_chi2_cannot_be_finite_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let huge = data(
        dir.path(),
        "huge.csv",
        &format!("{HEADER}\n5,2\n10,1e308\n20,4\n"),
    );
    refused(
        &huge,
        &out,
        &["--free", "adhesion.n"],
        &[
            "huge.csv: line 3, column 2 'pull_off_amplification [1]': '1e308' is too large",
            "chi2 cannot be finite",
        ],
    );
    let sh = format!("{HEADER},sigma [1]");
    let tiny = data(
        dir.path(),
        "tiny.csv",
        &format!("{sh}\n5,2,0.1\n10,3,1e-308\n20,4,0.1\n"),
    );
    refused(
        &tiny,
        &out,
        &["--free", "adhesion.n"],
        &["tiny.csv: line 3, column 3 'sigma [1]': sigma '1e-308' is subnormal"],
    );
    let small = data(
        dir.path(),
        "small.csv",
        &format!("{sh}\n5,0,1e-200\n10,0,1e-200\n20,0,1e-200\n"),
    );
    refused(
        &small,
        &out,
        &["--free", "adhesion.n"],
        &[
            "small.csv: line 2, column 3 'sigma [1]': at the starting values the model predicts",
            "chi2 cannot be",
        ],
    );
    // Fittable, if absurd: every number finite, no Rust Debug text, no sigma of 0.
    let extreme = data(
        dir.path(),
        "extreme.csv",
        &format!("{sh}\n5,0,1e-152\n10,0,1e-152\n20,0,1e-152\n"),
    );
    let r = fit(&extreme, &out, &["--free", "adhesion.n", "--json"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let j: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    for k in ["chi2", "reduced_chi2", "aic", "bic"] {
        assert!(j[k].as_f64().is_some_and(f64::is_finite), "{k}: {j}");
    }
    let p = &j["parameters"][0];
    assert!(
        p["sigma"].is_null() || p["sigma"].as_f64().unwrap() > 0.0,
        "{j}"
    );
    for n in j["notes"].as_array().unwrap() {
        let n = n.as_str().unwrap();
        assert!(!n.contains("Numerical(") && !n.contains("\")"), "{n}");
    }
    let written = std::fs::read_to_string(out.join("fit.json")).unwrap();
    assert!(!written.contains("null,\n  \"dof\""), "{written}");
    // The report prints no number of hundreds of digits.
    let r = fit(&extreme, &out, &["--free", "adhesion.n"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.stdout.lines().all(|l| l.len() < 200), "{}", r.stdout);
}

/// Item 11: the line of an error is the one an editor shows, in CRLF files and across blank
/// and comment lines (a CRLF file reported line 1 for line 2).
#[test]
fn errors_name_the_line_an_editor_shows() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    for (name, text, line) in [
        ("crlf.csv", format!("{HEADER}\r\n5,x\r\n"), 2),
        (
            "crlf5.csv",
            format!("{HEADER}\r\n\r\n5,2\r\n\r\n10,x\r\n"),
            5,
        ),
        (
            "blank.csv",
            format!("# data\n\n{HEADER}\n\n5,2\n# c\n\n10,x\n"),
            8,
        ),
        ("cr.csv", format!("{HEADER}\r5,2\r10,x\r"), 3),
    ] {
        let d = data(dir.path(), name, &text);
        refused(
            &d,
            &out,
            &["--free", "adhesion.n"],
            &[&format!("{name}: line {line}, column 2")],
        );
    }
    let header = data(
        dir.path(),
        "header.csv",
        "# measured 2024\r\n\r\nbase.amplitude [Hz],pull_off_amplification [1]\r\n5,2\r\n",
    );
    refused(
        &header,
        &out,
        &["--free", "adhesion.n"],
        &["header.csv: line 3, column 1 'base.amplitude [Hz]'"],
    );
}

/// Item 12: bounds beyond the key's range are refused naming the bound and the range (they
/// blamed `adhesion.n=nan`, a value nobody gave).
#[test]
fn bounds_beyond_the_keys_range_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = good(dir.path());
    let out = dir.path().join("o");
    let e = refused(
        &d,
        &out,
        &["--free", "adhesion.n=-1e308:1e308"],
        &[
            "--free adhesion.n=-1e308:1e308: LO '-1e308' lies outside the range of adhesion.n: \
             must be a finite number > 0",
        ],
    );
    assert!(!e.contains("nan"), "{e}");
    refused(
        &d,
        &out,
        &["--free", "adhesion.n=0.1:1e308"],
        &["HI '1e308' lies outside the range of adhesion.n: must not exceed 1e1"],
    );
}

/// The refusals are at once, and a valid fit of the same data still runs (and quickly).
#[test]
fn a_valid_fit_of_the_tiny_rig_still_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = good(dir.path());
    let out = dir.path().join("o");
    let r = fit(&d, &out, &["--free", "adhesion.n=0.1:2", "--json"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let j: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    assert!(j["chi2"].as_f64().is_some_and(f64::is_finite), "{j}");
    eprintln!("valid fit: {:.2} s", r.seconds);
}
