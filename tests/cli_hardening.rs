//! Hostile and careless input at the command line (issue 15): special and huge files, unbounded
//! grids, a closed stdout, values outside the model's range, flags that do nothing. Every case
//! ends with a clear message (exit 2) or a result with a warning, never a panic or a hang; each
//! child process runs under a deadline.

use std::io::Read;
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
    let mut child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("djkr binary runs");
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let t_out = std::thread::spawn(move || {
        let mut s = String::new();
        out.read_to_string(&mut s).ok();
        s
    });
    let t_err = std::thread::spawn(move || {
        let mut s = String::new();
        err.read_to_string(&mut s).ok();
        s
    });
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if t0.elapsed() > limit {
            child.kill().ok();
            child.wait().ok();
            break None;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let stdout = t_out.join().unwrap();
    let stderr = t_err.join().unwrap();
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
