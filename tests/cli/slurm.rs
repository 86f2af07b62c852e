//! `djkr sweep --slurm` for real: a single-node Slurm cluster on the loopback interface (Debian's
//! `slurm-wlm` and `munge`; installed when missing only with `DJKR_TEST_INSTALL=1`), a 2-task array of a small sweep with its
//! dependent merge step, and the merge checked against the unsharded sweep value for value.
//!
//! Needs root (the daemons run as root, as in CI). Without root or without Slurm (and not allowed
//! to install it), the test says why in one line and skips; with `DJKR_TEST_INSTALL=1` that is a
//! failure. Everything lives in a
//! temporary folder: munge's key and socket, Slurm's configuration, state, spool and logs, on
//! ports picked free at start; the daemons run in the foreground as this test's children and are
//! stopped at its end.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::tools;

use tools::{have, is_root};

/// Skip with one line (or fail when installing was allowed: then CI must run the test).
fn skip(why: &str) {
    tools::skip_or_fail("the Slurm test (tests/cli/slurm.rs)", why);
}

/// Slurm's and munge's commands, installed (slurm-wlm, munge) with apt-get only when allowed
/// (`DJKR_TEST_INSTALL=1`); `Err` says why they are not there.
fn ensure_slurm() -> Result<(), String> {
    let needed = ["sbatch", "slurmctld", "slurmd", "munged", "mungekey"];
    if needed.iter().all(|c| have(c)) {
        return Ok(());
    }
    tools::apt_install(&["slurm-wlm", "munge"])
        .map_err(|why| format!("slurm-wlm/munge are not installed; {why}"))?;
    match needed.iter().find(|c| !have(c)) {
        Some(c) => Err(format!("{c} still missing after apt-get install")),
        None => Ok(()),
    }
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// The cluster's daemons; stopped (SIGTERM, then SIGKILL) when dropped.
struct Daemons(Vec<Child>);

impl Drop for Daemons {
    fn drop(&mut self) {
        for c in self.0.iter_mut().rev() {
            let _ = Command::new("kill").arg(c.id().to_string()).status();
            let t0 = Instant::now();
            while t0.elapsed() < Duration::from_secs(5) {
                if matches!(c.try_wait(), Ok(Some(_))) {
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn wait_for(what: &str, timeout: Duration, mut ok: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !ok() {
        assert!(t0.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn logs(dir: &Path) -> String {
    let mut s = String::new();
    for sub in ["log", "sweep/slurm"] {
        if let Ok(rd) = std::fs::read_dir(dir.join(sub)) {
            for e in rd.flatten() {
                let text = std::fs::read_to_string(e.path()).unwrap_or_default();
                let tail: Vec<&str> = text.lines().rev().take(15).collect();
                s.push_str(&format!("--- {}\n", e.path().display()));
                for l in tail.into_iter().rev() {
                    s.push_str(l);
                    s.push('\n');
                }
            }
        }
    }
    s
}

/// Start munged, slurmctld and slurmd on 127.0.0.1 in `dir`; returns the daemons and the
/// path of slurm.conf.
fn start_cluster(dir: &Path) -> (Daemons, PathBuf) {
    let munge = dir.join("munge");
    for d in ["munge", "state", "spool", "log"] {
        std::fs::create_dir_all(dir.join(d)).unwrap();
    }
    let key = munge.join("munge.key");
    let st = Command::new("mungekey")
        .args(["-c", "-k"])
        .arg(&key)
        .status()
        .unwrap();
    assert!(st.success(), "mungekey failed");
    let socket = munge.join("munge.socket");
    let mut daemons = Daemons(Vec::new());
    daemons.0.push(
        Command::new("munged")
            .args(["--foreground", "--force"])
            .arg(format!("--socket={}", socket.display()))
            .arg(format!("--key-file={}", key.display()))
            .arg(format!("--pid-file={}", munge.join("munged.pid").display()))
            .arg(format!(
                "--log-file={}",
                dir.join("log/munged.log").display()
            ))
            .arg(format!(
                "--seed-file={}",
                munge.join("munged.seed").display()
            ))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("munged starts"),
    );
    wait_for("munged's socket", Duration::from_secs(20), || {
        socket.exists()
    });
    let host = Command::new("hostname")
        .arg("-s")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|_| "localhost".into());
    let d = dir.display();
    let conf = dir.join("slurm.conf");
    std::fs::write(
        &conf,
        format!(
            "ClusterName=djkrtest
SlurmctldHost={host}(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort={}
SlurmdPort={}
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={}
StateSaveLocation={d}/state
SlurmdSpoolDir={d}/spool
SlurmctldPidFile={d}/slurmctld.pid
SlurmdPidFile={d}/slurmd.pid
SlurmctldLogFile={d}/log/slurmctld.log
SlurmdLogFile={d}/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
NodeName=djkrnode NodeAddr=127.0.0.1 NodeHostname={host} CPUs=2 State=UNKNOWN
PartitionName=djkr Nodes=djkrnode Default=YES MaxTime=INFINITE State=UP
",
            free_port(),
            free_port(),
            socket.display()
        ),
    )
    .unwrap();
    for (cmd, args) in [
        ("slurmctld", vec!["-D", "-i"]),
        ("slurmd", vec!["-D", "-N", "djkrnode"]),
    ] {
        daemons.0.push(
            Command::new(cmd)
                .args(&args)
                .env("SLURM_CONF", &conf)
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap_or_else(|e| panic!("{cmd}: {e}")),
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    wait_for("the node to be idle", Duration::from_secs(60), || {
        Command::new("sinfo")
            .args(["-h", "-o", "%T"])
            .env("SLURM_CONF", &conf)
            .output()
            .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle")
    });
    (daemons, conf)
}

fn djkr(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "djkr {args:?}: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// sweep.csv's rows without the wall_s column.
fn rows_without_wall(p: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let h: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    let wall = h.iter().position(|c| c == "wall_s [s]").unwrap();
    let mut out = vec![h];
    for rec in r.records() {
        out.push(rec.unwrap().iter().map(str::to_string).collect());
    }
    for row in &mut out {
        row.remove(wall);
    }
    out
}

#[test]
fn slurm_array_and_merge_equal_the_unsharded_sweep() {
    if !is_root() {
        return skip("not root (the Slurm daemons run as root)");
    }
    if let Err(why) = ensure_slurm() {
        return skip(&why);
    }
    let t0 = Instant::now();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let (daemons, conf) = start_cluster(dir);
    // A folder name a shell would expand, with quotes and a `%` (a Slurm file-name pattern):
    // each reader of the script (bash, sbatch's #SBATCH parser, the merge step's sh) must take
    // it as a name.
    let sweep = dir.join("sweep $(touch PWNED) `touch PWNED` \"it's\" 100%j");
    let args = [
        "tests/sweep/tiny.toml",
        "--set",
        "base.amplitude=4um:16um:3",
        "--ensemble",
        "2",
        "--seed",
        "5",
    ];
    let mut a = vec!["sweep"];
    a.extend(args);
    let sw = sweep.to_str().unwrap();
    a.extend(["--slurm", "--shards", "2", "--out", sw]);
    djkr(&a);
    let script = sweep.join("sweep.sbatch");
    let st = Command::new("sbatch")
        .arg("--wait")
        .arg(&script)
        .env("SLURM_CONF", &conf)
        .status()
        .unwrap();
    assert!(st.success(), "array job failed\n{}", logs(dir));
    // The merge step (submitted by the first task, afterok on the array) then writes sweep.csv.
    wait_for("the merge step", Duration::from_secs(120), || {
        sweep.join("sweep.csv").exists() && sweep.join("points.csv").exists()
    });
    let merge_id = std::fs::read_to_string(sweep.join("slurm/merge.jobid")).unwrap_or_default();
    assert!(
        !merge_id.trim().is_empty(),
        "no merge job id\n{}",
        logs(dir)
    );
    // The logs of the tasks and of the merge step landed in OUT/slurm, under Slurm's names.
    let names: Vec<String> = std::fs::read_dir(sweep.join("slurm"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names
            .iter()
            .any(|n| n.starts_with("djkr-sweep-merge-") && n.ends_with(".out"))
            && names
                .iter()
                .filter(|n| n.starts_with("djkr-sweep-") && n.contains('_'))
                .count()
                == 2,
        "{names:?}\n{}",
        logs(dir)
    );
    let pwned = std::process::Command::new("find")
        .arg(dir)
        .args(["-name", "PWNED"])
        .output()
        .unwrap();
    assert!(
        pwned.stdout.is_empty(),
        "a command ran: {}",
        String::from_utf8_lossy(&pwned.stdout)
    );
    assert!(
        !Path::new("/PWNED").exists()
            && !Path::new(env!("CARGO_MANIFEST_DIR")).join("PWNED").exists()
    );
    let shards: Vec<_> = (1..=2).map(|k| sweep.join(format!("shards/{k}"))).collect();
    for s in &shards {
        assert!(
            s.join("sweep.csv").exists(),
            "{}\n{}",
            s.display(),
            logs(dir)
        );
    }
    let local = dir.join("local");
    let mut b = vec!["sweep"];
    b.extend(args);
    b.extend(["--out", local.to_str().unwrap()]);
    djkr(&b);
    assert_eq!(
        rows_without_wall(&sweep.join("sweep.csv")),
        rows_without_wall(&local.join("sweep.csv"))
    );
    assert_eq!(rows_without_wall(&sweep.join("sweep.csv")).len(), 7);
    assert_eq!(
        std::fs::read(sweep.join("points.csv")).unwrap(),
        std::fs::read(local.join("points.csv")).unwrap()
    );

    // A task that fails (its shard's output path is a file): the merge step's dependency can
    // then never be met, and Slurm must cancel it rather than leave it pending for ever.
    let broken = dir.join("broken");
    let mut c = vec!["sweep"];
    c.extend(args);
    c.extend([
        "--slurm",
        "--shards",
        "2",
        "--out",
        broken.to_str().unwrap(),
    ]);
    djkr(&c);
    std::fs::create_dir_all(broken.join("shards")).unwrap();
    std::fs::write(broken.join("shards/2"), "not a directory").unwrap();
    let st = Command::new("sbatch")
        .arg("--wait")
        .arg(broken.join("sweep.sbatch"))
        .env("SLURM_CONF", &conf)
        .status()
        .unwrap();
    assert!(!st.success(), "the array job should fail\n{}", logs(dir));
    let merge_id = std::fs::read_to_string(broken.join("slurm/merge.jobid")).unwrap_or_default();
    let merge_id = merge_id.trim().to_string();
    assert!(!merge_id.is_empty(), "no merge job id\n{}", logs(dir));
    let state = || {
        Command::new("scontrol")
            .args(["show", "job", "-o", &merge_id])
            .env("SLURM_CONF", &conf)
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default()
    };
    wait_for(
        "the merge step to be cancelled",
        Duration::from_secs(60),
        || state().contains("JobState=CANCELLED"),
    );
    assert!(!broken.join("sweep.csv").exists());

    drop(daemons);
    eprintln!(
        "Slurm test: cluster, 2-task array, merge, a failed array's cancelled merge, checks in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
}

// ---------------------------------------------------------------------------------------------
// Without a cluster: sweep.sbatch run as Slurm runs it, with a stand-in `sbatch` first on PATH.

/// A stand-in for Slurm's `sbatch`, for the one call the array tasks make (the merge step's
/// `--wrap` job): like the real one, it turns the `--wrap` text into a `/bin/sh` script and keeps
/// the submitter's environment (`--export=ALL`) for it, to run later (`run_recorded_jobs`). It
/// records its arguments one per line (NUL-separated) and prints a job id. With
/// `FAKE_SBATCH_FAIL=1` it fails, as when the controller is down.
const FAKE_SBATCH: &str = r#"#!/bin/sh
set -eu
if [ "${FAKE_SBATCH_FAIL:-0}" = 1 ]; then echo "sbatch: error: controller down" >&2; exit 1; fi
n=$(ls "$FAKE_SBATCH_JOBS" | wc -l)
job="$FAKE_SBATCH_JOBS/job$n"
mkdir "$job"
printf '%s\0' "$@" > "$job/args"
wrap=
for a in "$@"; do
  case $a in
    --wrap=*) wrap=${a#--wrap=} ;;
  esac
done
[ -n "$wrap" ] || { echo "fake sbatch: only --wrap jobs" >&2; exit 1; }
printf '#!/bin/sh\n# This script was created by sbatch --wrap.\n\n%s\n' "$wrap" > "$job/script"
env -0 > "$job/env"
echo "424$n"
"#;

/// Paths a careless or hostile user may give to `--out`: none of them may run a command.
const HOSTILE: [&str; 7] = [
    "x$(touch PWNED)y",
    "x`touch PWNED`y",
    "a\"b",
    "it's",
    "two words",
    "q'\"$(touch PWNED)\"'`touch PWNED` 100%",
    "%x-%j",
];

/// Every file under `dir`, relative to it.
fn all_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if e.file_type().unwrap().is_dir() {
                todo.push(p.clone());
            }
            out.push(p.strip_prefix(dir).unwrap().to_path_buf());
        }
    }
    out
}

/// Run the array task `k` of `script` as Slurm would (bash, the task's environment), with the
/// stand-in sbatch first on PATH, in `cwd`. Returns its stderr.
fn run_task(script: &Path, k: usize, bin: &Path, jobs: &Path, cwd: &Path, fail: bool) -> String {
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap());
    let o = Command::new("bash")
        .arg(script)
        .current_dir(cwd)
        .env("PATH", path)
        .env("SLURM_ARRAY_JOB_ID", "4241")
        .env("SLURM_ARRAY_TASK_ID", k.to_string())
        .env("SLURM_ARRAY_TASK_MIN", "1")
        .env("SLURM_ARRAY_TASK_MAX", "2")
        .env("SLURM_ARRAY_TASK_COUNT", "2")
        .env("SLURM_CPUS_PER_TASK", "1")
        .env("FAKE_SBATCH_JOBS", jobs)
        .env("FAKE_SBATCH_FAIL", if fail { "1" } else { "0" })
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(
        o.status.success(),
        "task {k} of {}: {stderr}",
        script.display()
    );
    stderr
}

/// The jobs the stand-in recorded: each one's arguments, and the job run as slurmd runs it
/// (`/bin/sh` on the script, with the environment recorded at submission) in `cwd`, and how that
/// went (`Err` with its stderr when it failed).
fn run_recorded_jobs(jobs: &Path, cwd: &Path) -> Vec<(Vec<String>, Result<(), String>)> {
    let mut all = Vec::new();
    let mut names: Vec<_> = std::fs::read_dir(jobs).unwrap().flatten().collect();
    names.sort_by_key(std::fs::DirEntry::file_name);
    for e in names {
        let job = e.path();
        let args = std::fs::read_to_string(job.join("args")).unwrap();
        let env = std::fs::read(job.join("env")).unwrap();
        let mut cmd = Command::new("/bin/sh");
        cmd.arg(job.join("script")).current_dir(cwd).env_clear();
        for kv in env.split(|&b| b == 0).filter(|kv| !kv.is_empty()) {
            let kv = String::from_utf8_lossy(kv);
            let (k, v) = kv.split_once('=').unwrap();
            cmd.env(k, v);
        }
        let o = cmd.output().unwrap();
        let ran = if o.status.success() {
            Ok(())
        } else {
            Err(String::from_utf8_lossy(&o.stderr).into_owned())
        };
        let args = args
            .split('\0')
            .filter(|a| !a.is_empty())
            .map(str::to_string)
            .collect();
        all.push((args, ran));
    }
    all
}

#[test]
fn sweep_sbatch_never_evaluates_a_path_twice() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let bin = root.join("bin");
    std::fs::create_dir(&bin).unwrap();
    let sbatch = bin.join("sbatch");
    std::fs::write(&sbatch, FAKE_SBATCH).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&sbatch, std::fs::Permissions::from_mode(0o755)).unwrap();
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/sweep/tiny.toml");
    let scenario = scenario.to_str().unwrap();
    let reference = root.join("reference");
    djkr(&[
        "sweep",
        scenario,
        "--set",
        "base.amplitude=1um,2um",
        "--out",
        reference.to_str().unwrap(),
    ]);
    for (i, name) in HOSTILE.iter().enumerate() {
        // Everything runs in `cwd`, where an injected `touch PWNED` would land.
        let cwd = root.join(format!("case{i}"));
        let jobs = root.join(format!("jobs{i}"));
        std::fs::create_dir_all(cwd.join("in dir")).unwrap();
        std::fs::create_dir(&jobs).unwrap();
        let out = cwd.join("in dir").join(name);
        let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
            .args(["sweep", scenario, "--set", "base.amplitude=1um,2um"])
            .args(["--slurm", "--shards", "2", "--out"])
            .arg(&out)
            .current_dir(&cwd)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{name}: {stdout}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let script = out.join("sweep.sbatch");
        // The printed `sbatch …` hint, run by sh, submits that very script.
        let hint = stdout
            .lines()
            .skip_while(|l| !l.starts_with("submit it with:"))
            .nth(1)
            .unwrap_or_else(|| panic!("{name}: no sbatch hint in {stdout}"));
        let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap());
        let hint_jobs = root.join(format!("hint{i}"));
        std::fs::create_dir(&hint_jobs).unwrap();
        let o = Command::new("sh")
            .args(["-c", &format!("{} --wrap=:", hint.trim())])
            .current_dir(&cwd)
            .env("PATH", &path)
            .env("FAKE_SBATCH_JOBS", &hint_jobs)
            .output()
            .unwrap();
        assert!(o.status.success(), "{name}: {hint}");
        assert!(!cwd.join("PWNED").exists(), "{name}: {hint}");
        let args = std::fs::read_to_string(hint_jobs.join("job0/args")).unwrap();
        assert_eq!(
            args.split('\0').next(),
            Some(script.to_str().unwrap()),
            "{name}: {hint}"
        );
        // The array's two tasks, the first submitting the merge step; then the merge step.
        for k in 1..=2 {
            run_task(&script, k, &bin, &jobs, &cwd, false);
        }
        let submitted = run_recorded_jobs(&jobs, &cwd);
        // Nothing ran that the user did not ask for: no PWNED, nothing outside OUT.
        assert!(
            !all_files(root).iter().any(|p| p.ends_with("PWNED")),
            "{name}: a command ran"
        );
        let stray: Vec<_> = all_files(&cwd)
            .into_iter()
            .filter(|p| !p.starts_with(Path::new("in dir").join(name)) && p != Path::new("in dir"))
            .collect();
        assert!(stray.is_empty(), "{name}: {stray:?}");
        assert_eq!(submitted.len(), 1, "{name}: one merge step");
        let (args, ran) = &submitted[0];
        assert_eq!(ran, &Ok(()), "{name}: the merge step failed");
        let want_log = format!(
            "--output={}/slurm/%x-%j.out",
            out.to_str().unwrap().replace('%', "%%")
        );
        assert!(args.contains(&want_log), "{name}: {args:?}");
        assert!(args.iter().any(|a| a == "--export=ALL"));
        // The merge wrote the sweep into OUT, equal to the unsharded one.
        assert_eq!(
            rows_without_wall(&out.join("sweep.csv")),
            rows_without_wall(&reference.join("sweep.csv")),
            "{name}"
        );
    }
}

/// When the merge step cannot be submitted, the task says how to merge by hand: that command,
/// run by sh, merges into OUT.
#[test]
fn the_by_hand_merge_hint_runs_as_printed() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let bin = root.join("bin");
    std::fs::create_dir(&bin).unwrap();
    let sbatch = bin.join("sbatch");
    std::fs::write(&sbatch, FAKE_SBATCH).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&sbatch, std::fs::Permissions::from_mode(0o755)).unwrap();
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/sweep/tiny.toml");
    let jobs = root.join("jobs");
    std::fs::create_dir(&jobs).unwrap();
    let out = root.join(HOSTILE[5]);
    djkr(&[
        "sweep",
        scenario.to_str().unwrap(),
        "--set",
        "base.amplitude=1um,2um",
        "--slurm",
        "--shards",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    let script = out.join("sweep.sbatch");
    let stderr = run_task(&script, 1, &bin, &jobs, root, true);
    run_task(&script, 2, &bin, &jobs, root, true);
    let hint = stderr
        .lines()
        .skip_while(|l| !l.contains("could not submit the merge step"))
        .nth(1)
        .unwrap_or_else(|| panic!("no hint in {stderr}"));
    let o = Command::new("sh")
        .args(["-c", hint.trim()])
        .current_dir(root)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{hint}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(rows_without_wall(&out.join("sweep.csv")).len(), 3);
    assert!(!all_files(root).iter().any(|p| p.ends_with("PWNED")));
}

/// A newline in --out (or in the scenario's path, or a --set) is refused by design: it would end
/// the `#SBATCH` line that holds it. Nothing is written.
#[test]
fn a_newline_in_a_slurm_path_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x\n$(touch PWNED)");
    let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args([
            "sweep",
            "tests/sweep/tiny.toml",
            "--set",
            "base.amplitude=1um,2um",
        ])
        .args(["--slurm", "--out"])
        .arg(&out)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("--out") && e.contains("control character"),
        "{e}"
    );
    assert!(!out.exists());
    let back = tmp.path().join("a\\b");
    let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args([
            "sweep",
            "tests/sweep/tiny.toml",
            "--set",
            "base.amplitude=1um,2um",
        ])
        .args(["--slurm", "--out"])
        .arg(&back)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("backslash"));
    assert!(!back.exists());
}
