//! Output folders (issue 24, defects 4, 5, 7 and 14): djkr never opens a path a user planted,
//! never replaces or deletes a file it did not write, and one process at a time writes a
//! folder. Every case runs the binary as a user would.

use std::os::unix::fs::symlink;
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const TINY: &str = "tests/sweep/tiny.toml";

fn djkr(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .output()
        .expect("djkr runs")
}

fn spawn(cwd: &Path, args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("djkr runs")
}

fn ok(cwd: &Path, args: &[&str]) -> Output {
    let o = djkr(cwd, args);
    assert!(
        o.status.success(),
        "djkr {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Exit status 2 and its message.
fn refused(cwd: &Path, args: &[&str]) -> String {
    let o = djkr(cwd, args);
    let msg = String::from_utf8_lossy(&o.stderr).trim().to_string();
    assert_eq!(o.status.code(), Some(2), "djkr {args:?}: {msg}");
    msg
}

fn tiny() -> String {
    format!("{}/{TINY}", env!("CARGO_MANIFEST_DIR"))
}

fn is_regular(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_file())
}

fn wait_for(what: &str, limit: Duration, mut cond: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !cond() {
        assert!(t0.elapsed() < limit, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Symbolic links planted at every partial name djkr used before (`.NAME.partial`) point at a
/// victim file; `djkr run`, `djkr plot` and a sweep write through none of them, and publish
/// regular files.
#[test]
fn planted_symlinks_at_partial_names_are_never_followed() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let victim = t.join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    let (run, sweep) = (t.join("D"), t.join("S"));
    std::fs::create_dir_all(&run).unwrap();
    std::fs::create_dir_all(&sweep).unwrap();
    let run_names = [
        "run.h5",
        "summary.json",
        "timeseries.csv",
        "events.csv",
        "cycles.csv",
        "run.png",
        "run.svg",
    ];
    for n in run_names {
        symlink(&victim, run.join(format!(".{n}.partial"))).unwrap();
    }
    let sweep_names = [
        "sweep.json",
        "progress.csv",
        "sweep.csv",
        "sweep.h5",
        "points.csv",
        "amplification.png",
        "amplification.svg",
    ];
    for n in sweep_names {
        symlink(&victim, sweep.join(format!(".{n}.partial"))).unwrap();
    }
    // A run long enough to stream its files while it runs (the streaming writer's partials).
    ok(
        t,
        &[
            "run",
            &tiny(),
            "--out",
            "D",
            "--csv",
            "--plot",
            "--set",
            "output.sample_rate=1e6",
        ],
    );
    ok(t, &["plot", "D"]);
    ok(
        t,
        &[
            "sweep",
            &tiny(),
            "--set",
            "base.frequency=280,300",
            "--out",
            "S",
        ],
    );
    ok(t, &["plot", "S"]);
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    for n in run_names {
        assert!(is_regular(&run.join(n)), "{n} is not a regular file");
    }
    for n in &sweep_names[2..] {
        assert!(is_regular(&sweep.join(n)), "{n} is not a regular file");
    }
    assert!(is_regular(&sweep.join("sweep.json")));
    // The planted links are the user's: left as they were.
    assert!(std::fs::read_link(run.join(".run.png.partial")).is_ok());
}

/// A user's files under the names a run publishes stop it before any work (exit 2, naming
/// them); `--force` overwrites those names and nothing else; djkr's own folder is rerun
/// without `--force`, and `--out .` works in a folder full of other files.
#[test]
fn user_files_under_published_names_are_refused_unless_force() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let d = t.join("D");
    std::fs::create_dir_all(&d).unwrap();
    for n in ["summary.json", "timeseries.csv", "run.png", "notes.txt"] {
        std::fs::write(d.join(n), format!("mine: {n}")).unwrap();
    }
    let args = ["run", &tiny(), "--out", "D", "--csv", "--plot"];
    let msg = refused(t, &args);
    for n in ["summary.json", "timeseries.csv", "run.png"] {
        assert!(msg.contains(n), "{msg}");
    }
    assert!(
        msg.contains("--force") && !msg.contains("notes.txt"),
        "{msg}"
    );
    assert!(!d.join("run.h5").exists(), "the run started");
    for n in ["summary.json", "timeseries.csv", "run.png"] {
        assert_eq!(
            std::fs::read_to_string(d.join(n)).unwrap(),
            format!("mine: {n}")
        );
    }
    let mut forced = args.to_vec();
    forced.push("--force");
    ok(t, &forced);
    assert!(std::fs::read_to_string(d.join("summary.json"))
        .unwrap()
        .contains("run_id"));
    assert_eq!(
        std::fs::read_to_string(d.join("notes.txt")).unwrap(),
        "mine: notes.txt"
    );
    // djkr's own folder: again and again without --force, and `djkr plot` into it.
    ok(t, &args);
    ok(t, &["run", &tiny(), "--out", "D"]);
    ok(t, &["plot", "D"]);
    // A file of the user's replacing one djkr wrote is the user's again.
    std::fs::remove_file(d.join("run.svg")).unwrap();
    std::fs::write(d.join("run.svg"), b"my drawing").unwrap();
    let msg = refused(t, &["plot", "D"]);
    assert!(
        msg.contains("run.svg") && !msg.contains("run.png,"),
        "{msg}"
    );
    assert_eq!(std::fs::read(d.join("run.svg")).unwrap(), b"my drawing");
    // `--out .` in a folder of other files.
    let here = t.join("here");
    std::fs::create_dir_all(&here).unwrap();
    std::fs::write(here.join("data.csv"), b"mine").unwrap();
    ok(&here, &["run", &tiny(), "--out", ".", "--csv"]);
    ok(&here, &["run", &tiny(), "--out", "."]);
    assert_eq!(std::fs::read(here.join("data.csv")).unwrap(), b"mine");
}

/// A sweep leaves a user's progress.csv, sweep.csv and points.csv alone (refused before it
/// starts, exit 2), overwrites them with `--force`, and resumes its own folder without it.
#[test]
fn a_sweep_refuses_a_users_tables_and_resumes_its_own_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let s = t.join("S");
    std::fs::create_dir_all(&s).unwrap();
    for n in ["progress.csv", "sweep.csv", "points.csv"] {
        std::fs::write(s.join(n), format!("mine: {n}")).unwrap();
    }
    let args = [
        "sweep",
        &tiny(),
        "--set",
        "base.frequency=280,300",
        "--out",
        "S",
    ];
    let msg = refused(t, &args);
    for n in ["progress.csv", "sweep.csv", "points.csv"] {
        assert!(msg.contains(n), "{msg}");
        assert_eq!(
            std::fs::read_to_string(s.join(n)).unwrap(),
            format!("mine: {n}")
        );
    }
    assert!(!s.join("sweep.json").exists());
    let mut forced = args.to_vec();
    forced.push("--force");
    ok(t, &forced);
    // Complete: djkr's own progress.csv is gone, its tables are in place.
    assert!(!s.join("progress.csv").exists());
    assert!(std::fs::read_to_string(s.join("sweep.csv"))
        .unwrap()
        .starts_with("point"));
    let mut resume = args.to_vec();
    resume.push("--resume");
    ok(t, &resume);
    ok(t, &["sweep", "merge", "S", "--out", "M"]);
    ok(t, &["sweep", "merge", "S", "--out", "M"]);
    // A progress.csv of the user's after a complete sweep is not djkr's to delete.
    std::fs::write(s.join("progress.csv"), b"mine again").unwrap();
    let msg = refused(t, &resume);
    assert!(msg.contains("progress.csv"), "{msg}");
    assert_eq!(
        std::fs::read(s.join("progress.csv")).unwrap(),
        b"mine again"
    );
}

/// Files named like djkr's partials that djkr did not record are never deleted; those a killed
/// run recorded in its lock are, by the next run into the folder.
#[test]
fn only_partials_djkr_recorded_are_deleted() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let d = t.join("D");
    std::fs::create_dir_all(&d).unwrap();
    let planted = [".run.h5.1764-99.partial", ".summary.json.partial"];
    for n in planted {
        std::fs::write(d.join(n), b"mine").unwrap();
    }
    // A long streamed run, killed once its partials are on disk.
    let mut child = spawn(
        t,
        &[
            "run",
            &tiny(),
            "--out",
            "D",
            "--csv",
            "--set",
            "stage[0].duration=20",
            "--set",
            "output.sample_rate=2e5",
        ],
    );
    let partials = |d: &Path| -> Vec<String> {
        std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".partial") && !planted.contains(&n.as_str()))
            .collect()
    };
    // The writer records each partial in the lock right after creating it.
    let recorded = || {
        std::fs::read_to_string(d.join(".djkr.lock"))
            .unwrap_or_default()
            .matches("\npartial ")
            .count()
    };
    wait_for("the streamed partials", Duration::from_secs(60), || {
        partials(&d).len() == 4 && recorded() >= 4
    });
    child.kill().unwrap();
    child.wait().unwrap();
    let left = partials(&d);
    assert_eq!(left.len(), 4, "{left:?}");
    let lock = std::fs::read_to_string(d.join(".djkr.lock")).unwrap();
    for n in &left {
        assert!(lock.contains(n.as_str()), "{n} not recorded in {lock}");
    }
    ok(t, &["run", &tiny(), "--out", "D"]);
    assert!(partials(&d).is_empty(), "{:?}", partials(&d));
    for n in planted {
        assert_eq!(std::fs::read(d.join(n)).unwrap(), b"mine", "{n}");
    }
}

/// A second sweep into a folder a sweep is writing is refused at once, naming the holder's
/// pid, with or without --resume; the first sweep completes without a spurious error row.
#[test]
fn a_second_sweep_into_a_busy_folder_is_refused_naming_the_holder() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let args = [
        "sweep",
        &tiny(),
        "--set",
        "base.frequency=250:350:12",
        "--keep-runs",
        "--jobs",
        "1",
        "--out",
        "S",
    ];
    let mut first = spawn(t, &args);
    let lock = t.join("S/.djkr.lock");
    wait_for("the first sweep's lock", Duration::from_secs(30), || {
        std::fs::read_to_string(&lock).is_ok_and(|s| s.contains("pid"))
    });
    let pid = format!("pid {}", first.id());
    let mut resume = args.to_vec();
    resume.push("--resume");
    for second in [&args[..], &resume[..]] {
        let t0 = Instant::now();
        let msg = refused(t, second);
        assert!(t0.elapsed() < Duration::from_secs(5));
        assert!(msg.contains(&pid) && msg.contains("S"), "{msg}");
    }
    let msg = refused(t, &["run", &tiny(), "--out", "S"]);
    assert!(msg.contains(&pid), "{msg}");
    let status = first.wait().unwrap();
    assert!(status.success());
    let rows = std::fs::read_to_string(t.join("S/sweep.csv")).unwrap();
    assert_eq!(rows.lines().count(), 13, "{rows}");
    assert!(rows.lines().skip(1).all(|l| l.contains(",ok,")), "{rows}");
}

/// A directory (or other non-regular file) under a name djkr publishes stops the run before
/// any work; an --out that is a file or a dangling link is named with what it is.
#[test]
fn what_is_in_the_way_is_named_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("E/summary.json")).unwrap();
    let msg = refused(t, &["run", &tiny(), "--out", "E"]);
    assert!(
        msg.contains("summary.json") && msg.contains("is a directory"),
        "{msg}"
    );
    assert!(!t.join("E/run.h5").exists(), "run.h5 was published");
    std::fs::create_dir_all(t.join("P")).unwrap();
    symlink("/etc/hostname", t.join("P/run.h5")).unwrap();
    let msg = refused(t, &["run", &tiny(), "--out", "P", "--force"]);
    assert!(
        msg.contains("run.h5") && msg.contains("symbolic link"),
        "{msg}"
    );

    std::fs::write(t.join("F"), b"a file").unwrap();
    let msg = refused(t, &["run", &tiny(), "--out", "F"]);
    assert!(msg.contains("F: is a file, not a folder"), "{msg}");
    symlink(t.join("nowhere"), t.join("G")).unwrap();
    for cmd in [
        vec!["run", TINY, "--out"],
        vec!["sweep", TINY, "--set", "base.frequency=300", "--out"],
    ] {
        let mut args: Vec<String> = cmd.iter().map(|s| s.to_string()).collect();
        args[1] = tiny();
        args.push("G".into());
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let msg = refused(t, &args);
        assert!(
            msg.contains("G: is a dangling symbolic link") && msg.contains("nowhere"),
            "{msg}"
        );
        assert!(!msg.contains("os error 17"), "{msg}");
    }
}

/// Two `djkr plot` on one folder at once both succeed (each its own partials).
#[test]
fn two_plots_on_one_folder_at_once_both_succeed() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    ok(t, &["run", &tiny(), "--out", "D"]);
    for _ in 0..8 {
        let a = spawn(t, &["plot", "D"]);
        let b = spawn(t, &["plot", "D"]);
        for c in [a, b] {
            let o = c.wait_with_output().unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        }
    }
    assert!(is_regular(&t.join("D/run.png")));
}

/// A run folder written before djkr kept its record (no `.djkr-manifest.json`) is djkr's by its
/// summary.json (`run_id`, `file_bytes`): rerunning into it needs no `--force`, but a file the
/// summary does not list, or one whose size differs from it, is still the user's.
#[test]
fn a_run_folder_of_an_older_djkr_is_recognised_by_its_summary() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let d = t.join("D");
    ok(t, &["run", &tiny(), "--out", "D"]);
    std::fs::remove_file(d.join(".djkr-manifest.json")).unwrap();
    std::fs::write(d.join("timeseries.csv"), b"mine").unwrap();
    let msg = refused(t, &["run", &tiny(), "--out", "D", "--csv"]);
    assert!(
        msg.contains("timeseries.csv") && !msg.contains("run.h5") && !msg.contains("summary"),
        "{msg}"
    );
    std::fs::remove_file(d.join("timeseries.csv")).unwrap();
    ok(t, &["run", &tiny(), "--out", "D", "--csv"]);
    // The record now covers them; an older folder whose run.h5 is not the size its summary says
    // is not recognised.
    std::fs::remove_file(d.join(".djkr-manifest.json")).unwrap();
    std::fs::write(d.join("run.h5"), b"another file").unwrap();
    let msg = refused(t, &["run", &tiny(), "--out", "D"]);
    assert!(msg.contains("run.h5") && !msg.contains("summary"), "{msg}");
    assert_eq!(std::fs::read(d.join("run.h5")).unwrap(), b"another file");
}
