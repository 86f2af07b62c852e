//! Issue 35 (hardening, round 4), the files and folders part: every file djkr reads goes through
//! one reader (a regular file within a size limit, anything else refused at once naming it),
//! `sweep merge` never writes into one of its inputs, the folder lock is never written through a
//! file djkr did not create, a full disk stops a run and keeps what it wrote, and summary.json
//! reports the time spent writing. Every child process runs under a deadline: a read that blocks
//! on a FIFO fails the test instead of hanging it.

use crate::tools;

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

// ---------------------------------------------------------------- item 15: disk space

/// Say on the terminal, past the harness's capture, that `what` was skipped and why (one line).
fn skipped(what: &str, why: &str) {
    use std::io::Write;
    use std::os::fd::FromRawFd;
    // SAFETY: fd 2 is the process's standard error, open for the whole test run; ManuallyDrop
    // keeps it from being closed here.
    let mut stderr = std::mem::ManuallyDrop::new(unsafe { std::fs::File::from_raw_fd(2) });
    let _ = writeln!(stderr, "SKIPPED {what}: {why}");
}

/// The `unshare` arguments that give a mount namespace in which a tmpfs can be mounted on
/// `probe` (as root, as in CI; or as a user where unprivileged user namespaces are allowed), or
/// why there are none. The mount lives and dies with that namespace: nothing on the machine
/// changes.
fn mount_namespace(probe: &Path) -> Result<Vec<&'static str>, String> {
    if !tools::have("unshare") {
        return Err("no unshare command".into());
    }
    for prefix in [
        vec!["--mount"],
        vec!["--user", "--map-root-user", "--mount"],
    ] {
        let ok = Command::new("unshare")
            .args(&prefix)
            .args(["sh", "-c", "mount -t tmpfs -o size=1m tmpfs \"$1\"", "sh"])
            .arg(probe)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            return Ok(prefix);
        }
    }
    Err("cannot mount a tmpfs in a mount namespace (neither root nor user namespaces)".into())
}

/// Run djkr's `args` (`OUT` standing for a folder on the small file system) with its output
/// folder on a fresh tmpfs of `size`, in a mount namespace of its own, then copy the folder to
/// `keep`. Returns djkr's exit code and stderr, or `None` (after one line saying so) when no
/// tmpfs can be mounted here.
fn run_on_small_fs(size: &str, args: &[&str], keep: &Path) -> Option<(Option<i32>, String)> {
    let tmp = tempfile::tempdir().unwrap();
    let mnt = tmp.path().join("mnt");
    std::fs::create_dir(&mnt).unwrap();
    let prefix = match mount_namespace(&mnt) {
        Ok(p) => p,
        Err(why) => {
            skipped("the disk-space tests on a small file system", &why);
            return None;
        }
    };
    // $1 the mount point, $2 where to copy the output folder, $3 djkr, then djkr's arguments.
    let script = "mnt=$1; keep=$2; djkr=$3; shift 3
        mount -t tmpfs -o size=$SIZE tmpfs \"$mnt\" || exit 97
        for a in \"$@\"; do
            if [ \"$a\" = OUT ]; then set -- \"$@\" \"$mnt/o\"; else set -- \"$@\" \"$a\"; fi
            shift
        done
        \"$djkr\" \"$@\" >/dev/null
        rc=$?
        cp -r \"$mnt/o\" \"$keep\" || exit 98
        exit $rc";
    let child = Command::new("unshare")
        .args(&prefix)
        .args(["sh", "-c", script, "sh"])
        .arg(&mnt)
        .arg(keep)
        .arg(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .env("SIZE", size)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("unshare runs");
    let (status, _, stderr) = tools::finish_within(child, Duration::from_secs(120));
    let code = status
        .expect("djkr on a small file system finished in time")
        .code();
    assert!(
        !matches!(code, Some(97 | 98)),
        "mounting or copying failed: {stderr}"
    );
    Some((code, stderr))
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// Before: "the run's output would take about 263.3 MB ... more than the 209.7 MB free", exit 2,
/// although the run wrote 28 MB (its pull-off stage's max_duration was counted). It writes
/// 14 MB now that envelope following skips 3 379 of the unload's periods (16 before), and
/// run.h5 holds every sample summary.json counts, up to the detachment (within 1 ms).
#[test]
fn the_paper_protocol_runs_on_a_200_mb_file_system() {
    let keep = tempfile::tempdir().unwrap();
    let kept = keep.path().join("o");
    let args = ["run", "scenarios/paper-protocol-300hz.toml", "--out", "OUT"];
    let Some((code, stderr)) = run_on_small_fs("200m", &args, &kept) else {
        return;
    };
    assert_eq!(code, Some(0), "{stderr}");
    let j = summary(&kept);
    assert_eq!(j["status"], "ok");
    assert_eq!(j["detached"], true);
    let h5 = std::fs::metadata(kept.join("run.h5")).unwrap().len();
    assert_eq!(j["file_bytes"]["run.h5"], h5);
    assert!(h5 > 10_000_000 && h5 < 200_000_000, "{h5}");
    let t = sample_times(&kept.join("run.h5"));
    assert_eq!(t.len() as u64, j["samples"].as_u64().unwrap());
    // The last sample is the last of the 12 kHz grid before the run ends at the detachment.
    let (detached, t_end) = (
        j["detachment"]["time"].as_f64().unwrap(),
        j["final_state"]["t"].as_f64().unwrap(),
    );
    let last = *t.last().unwrap();
    assert!(
        last > detached - 1e-3 && last <= t_end,
        "{last} vs {detached}, {t_end}"
    );
}

/// A run whose pull-off stage writes more than the disk holds stops for disk space, exit 3,
/// and keeps complete files of what it computed.
#[test]
fn a_run_that_fills_the_disk_stops_and_keeps_what_it_wrote() {
    let keep = tempfile::tempdir().unwrap();
    let kept = keep.path().join("o");
    let args = ["run", "scenarios/paper-protocol-300hz.toml", "--out", "OUT"];
    let Some((code, stderr)) = run_on_small_fs("24m", &args, &kept) else {
        return;
    };
    assert_eq!(code, Some(3), "{stderr}");
    assert!(stderr.contains("stopped: run stopped (disk)"), "{stderr}");
    let j = summary(&kept);
    assert_eq!(j["status"], "stopped");
    assert_eq!(j["reason"], "disk");
    let msg = j["message"].as_str().unwrap();
    assert!(
        msg.starts_with("disk space low") && msg.contains("MB free") && msg.contains("in stage 3"),
        "{msg}"
    );
    // The files are complete: their sizes as recorded, and run.h5 reads to the stop (read here
    // with hdf5-pure; `djkr plot` draws it below).
    let h5 = kept.join("run.h5");
    assert_eq!(
        j["file_bytes"]["run.h5"],
        std::fs::metadata(&h5).unwrap().len()
    );
    let t = sample_times(&h5);
    assert_eq!(t.len() as u64, j["samples"].as_u64().unwrap());
    let t_end = j["final_state"]["t"].as_f64().unwrap();
    let last = *t.last().unwrap();
    assert!(last > 5.0 && last <= t_end, "{last} vs {t_end}");
    assert!(t.windows(2).all(|w| w[1] > w[0]));
    ok(&["plot", s(&kept)]);
}

// ---------------------------------------------------------------- item 16: the time spent writing

/// `solver.max_wall_s` bounds the integration; the files are written after it, and summary.json
/// says how long that took (`stats.write_s`), which the command's own time bears out.
#[test]
fn summary_reports_the_time_spent_writing_after_the_budget() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().join("D");
    let t0 = std::time::Instant::now();
    let r = djkr(&[
        "run",
        "scenarios/paper-protocol-300hz.toml",
        "--set",
        "solver.max_wall_s=0.05",
        "--set",
        "output.sample_rate=200000",
        "--out",
        s(&d),
    ]);
    let elapsed = t0.elapsed().as_secs_f64();
    assert_eq!(r.code, Some(3), "{}", r.stderr);
    let j = summary(&d);
    assert_eq!(j["reason"], "max_wall_s");
    let (wall, write) = (
        j["stats"]["wall_s"].as_f64().unwrap(),
        j["stats"]["write_s"].as_f64().unwrap(),
    );
    assert_eq!(j["units"]["stats.write_s"], "s");
    // Both happened within the command's lifetime, one after the other.
    assert!(
        write > 0.0 && wall + write < elapsed,
        "{wall} + {write} vs {elapsed}"
    );
    // A run that went to its end reports it too.
    let ok_dir = tmp.path().join("ok");
    ok(&["run", TINY, "--out", s(&ok_dir)]);
    let j = summary(&ok_dir);
    assert_eq!(j["status"], "ok");
    assert!(j["stats"]["write_s"].as_f64().unwrap() >= 0.0);
}

/// The sample times (`t`, s) of a run's `run.h5`.
fn sample_times(h5: &Path) -> Vec<f64> {
    hdf5_pure::File::open(h5)
        .unwrap()
        .dataset("t")
        .unwrap()
        .read_f64()
        .unwrap()
}
