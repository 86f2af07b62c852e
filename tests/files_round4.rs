//! Issue 35 (hardening, round 4), the files and folders part: every file djkr reads goes through
//! one reader (a regular file within a size limit, anything else refused at once naming it),
//! `sweep merge` never writes into one of its inputs, the folder lock is never written through a
//! file djkr did not create, a full disk stops a run and keeps what it wrote, and summary.json
//! reports the time spent writing. Every child process runs under a deadline: a read that blocks
//! on a FIFO fails the test instead of hanging it.

#![cfg(unix)]

mod tools;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

const TINY: &str = "tests/sweep/tiny.toml";

/// What a djkr run left: exit code (`None`: killed by a signal) and stderr.
struct Run {
    code: Option<i32>,
    stderr: String,
}

/// Run djkr with `args` in the crate's folder, killed after `limit` (the test then fails).
fn djkr_within(args: &[&str], limit: Duration) -> Run {
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("djkr binary runs");
    let (status, _stdout, stderr) = tools::finish_within(child, limit);
    assert!(
        status.is_some(),
        "djkr {args:?} did not finish within {limit:?} (a blocking read?); stderr: {stderr}"
    );
    let r = Run {
        code: status.and_then(|s| s.code()),
        stderr,
    };
    assert!(
        !r.stderr.contains("panicked"),
        "djkr {args:?} panicked: {}",
        r.stderr
    );
    r
}

fn djkr(args: &[&str]) -> Run {
    djkr_within(args, Duration::from_secs(60))
}

/// Exit status 2 within 10 s (a refusal is immediate) and every needle in stderr.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let r = djkr_within(args, Duration::from_secs(10));
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

fn ok(args: &[&str]) -> Run {
    let r = djkr(args);
    assert_eq!(r.code, Some(0), "djkr {args:?}: {}", r.stderr);
    r
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn mkfifo(p: &Path) {
    let c = std::ffi::CString::new(s(p)).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(
        unsafe { libc::mkfifo(c.as_ptr(), 0o600) },
        0,
        "mkfifo {p:?}"
    );
}

/// A sparse file of `len` bytes (no disk used): larger than a limit at no cost.
fn sparse(p: &Path, len: u64) {
    std::fs::File::create(p).unwrap().set_len(len).unwrap();
}

/// A complete sweep of two runs of the tiny scene in `dir`, optionally one shard of two.
fn tiny_sweep(dir: &Path, shard: Option<&str>) {
    let mut args = vec![
        "sweep",
        TINY,
        "--set",
        "base.amplitude=1um,2um",
        "--out",
        s(dir),
    ];
    if let Some(k) = shard {
        args.extend(["--shard", k]);
    }
    ok(&args);
}

// ---------------------------------------------------------------- item 3: one reader

#[test]
fn plot_refuses_a_run_file_that_is_a_fifo_or_a_device_at_once() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("D");
    std::fs::create_dir(&d).unwrap();
    let h5 = d.join("run.h5");
    // Before: `djkr plot D` hung on the FIFO (no writer ever opens it here).
    mkfifo(&h5);
    refused(
        &["plot", s(&d)],
        &[s(&h5), "is a FIFO (named pipe), not a regular file"],
    );
    // Before: read 2.1 GB of zeros, then failed.
    std::fs::remove_file(&h5).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &h5).unwrap();
    refused(&["plot", s(&d)], &[s(&h5), "is a character device"]);
    // A run file larger than its limit (4 GiB) is refused before a byte is read.
    std::fs::remove_file(&h5).unwrap();
    sparse(&h5, (4 << 30) + 1);
    refused(
        &["plot", s(&d)],
        &[
            s(&h5),
            "larger than 4294967296 bytes (4 GiB), the limit for a run file",
        ],
    );
    // Nothing was drawn.
    assert!(!d.join("run.png").exists());
}

#[test]
fn plot_merge_and_resume_refuse_a_sweep_description_that_is_a_fifo() {
    let tmp = tempfile::tempdir().unwrap();
    let sdir = tmp.path().join("S");
    std::fs::create_dir(&sdir).unwrap();
    let json = sdir.join("sweep.json");
    mkfifo(&json);
    let what = "is a FIFO (named pipe), not a regular file";
    refused(&["plot", s(&sdir)], &[s(&json), what]);
    let m = tmp.path().join("M");
    refused(
        &["sweep", "merge", s(&sdir), "--out", s(&m)],
        &[s(&json), what],
    );
    refused(
        &[
            "sweep",
            TINY,
            "--set",
            "base.amplitude=1um,2um",
            "--resume",
            "--out",
            s(&sdir),
        ],
        &[s(&json), "a FIFO"],
    );
    // Larger than a sweep description's limit (64 MiB).
    std::fs::remove_file(&json).unwrap();
    sparse(&json, (64 << 20) + 1);
    refused(
        &["plot", s(&sdir)],
        &[s(&json), "(64 MiB), the limit for a sweep description"],
    );
}

#[test]
fn the_tables_of_a_sweep_folder_are_read_through_the_same_reader() {
    let tmp = tempfile::tempdir().unwrap();
    let sdir = tmp.path().join("S");
    tiny_sweep(&sdir, None);
    // The folder as djkr left it plots.
    ok(&["plot", s(&sdir)]);
    let rows = sdir.join("sweep.csv");
    std::fs::remove_file(&rows).unwrap();
    mkfifo(&rows);
    refused(&["plot", s(&sdir)], &[s(&rows), "a FIFO"]);
    let m = tmp.path().join("M");
    refused(
        &["sweep", "merge", s(&sdir), "--out", s(&m)],
        &[s(&rows), "a FIFO"],
    );
    std::fs::remove_file(&rows).unwrap();
    std::os::unix::fs::symlink("/dev/urandom", &rows).unwrap();
    refused(&["plot", s(&sdir)], &[s(&rows), "a character device"]);
}

// ---------------------------------------------------------------- item 9: merge into a shard

#[test]
fn merge_into_one_of_its_own_shard_folders_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let sm = tmp.path().join("SM");
    let (s1, s2) = (sm.join("s1"), sm.join("s2"));
    tiny_sweep(&s1, Some("1/2"));
    tiny_sweep(&s2, Some("2/2"));
    let before = std::fs::read(s1.join("sweep.json")).unwrap();
    let rows_before = std::fs::read(s1.join("sweep.csv")).unwrap();
    std::os::unix::fs::symlink(&s1, tmp.path().join("link")).unwrap();
    // The reproducer, then the same folder by other names, then a folder inside a shard.
    let same = [
        s1.clone(),
        sm.join("s2/../s1"),
        tmp.path().join("link"),
        s2.join("merged"),
        sm.join("s1/new/deeper"),
    ];
    for out in &same {
        let msg = refused(
            &["sweep", "merge", s(&s1), s(&s2), "--out", s(out)],
            &["shard folder", "would overwrite the shard's own files"],
        );
        assert!(msg.contains(s(out)), "{msg}");
    }
    // Even with --force.
    refused(
        &["sweep", "merge", s(&s1), s(&s2), "--out", s(&s1), "--force"],
        &["is the shard folder"],
    );
    // The shard is untouched, nothing was created inside the shards, and the shards still merge
    // (into their parent, as --slurm lays them out, and elsewhere).
    assert_eq!(std::fs::read(s1.join("sweep.json")).unwrap(), before);
    assert_eq!(std::fs::read(s1.join("sweep.csv")).unwrap(), rows_before);
    assert!(!s2.join("merged").exists() && !s1.join("new").exists());
    ok(&["sweep", "merge", s(&s1), s(&s2), "--out", s(&sm)]);
    ok(&[
        "sweep",
        "merge",
        s(&s1),
        s(&s2),
        "--out",
        s(&tmp.path().join("M")),
    ]);
    let merged = std::fs::read_to_string(sm.join("sweep.csv")).unwrap();
    assert_eq!(merged.lines().count(), 3, "{merged}");
}

// ---------------------------------------------------------------- item 14: the folder lock

#[test]
fn the_folder_lock_is_never_written_through_a_file_of_the_users() {
    let tmp = tempfile::tempdir().unwrap();
    let (v, d) = (tmp.path().join("v"), tmp.path().join("D"));
    // The reproducer: `: > v; mkdir D; ln v D/.djkr.lock; djkr run tiny --out D`.
    std::fs::write(&v, b"").unwrap();
    std::fs::create_dir(&d).unwrap();
    let lock = d.join(".djkr.lock");
    std::fs::hard_link(&v, &lock).unwrap();
    refused(
        &["run", TINY, "--out", s(&d)],
        &[s(&lock), "a file with 2 hard links, not djkr's lock file"],
    );
    assert_eq!(std::fs::read(&v).unwrap(), b"", "v was written");
    assert!(!d.join("run.h5").exists());
    // A sweep and a merge into it are refused the same way.
    refused(
        &[
            "sweep",
            TINY,
            "--set",
            "base.amplitude=1um,2um",
            "--out",
            s(&d),
        ],
        &["2 hard links"],
    );
    assert_eq!(std::fs::read(&v).unwrap(), b"");
    // An empty file of a single link is not djkr's either.
    std::fs::remove_file(&lock).unwrap();
    std::fs::write(&lock, b"").unwrap();
    refused(&["run", TINY, "--out", s(&d)], &[s(&lock), "an empty file"]);
    assert_eq!(std::fs::read(&lock).unwrap(), b"");
    // Removed, the folder takes runs again, and the lock file a run leaves is reused by the next.
    std::fs::remove_file(&lock).unwrap();
    ok(&["run", TINY, "--out", s(&d)]);
    let left = std::fs::read_to_string(&lock).unwrap();
    assert!(left.starts_with("djkr lock\npid "), "{left}");
    ok(&["run", TINY, "--out", s(&d)]);
    assert_eq!(std::fs::read(&v).unwrap(), b"");
}
