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

mod tools;

use tools::{have, is_root};

/// Skip with one line (or fail when installing was allowed: then CI must run the test).
fn skip(why: &str) {
    tools::skip_or_fail("the Slurm test (tests/slurm.rs)", why);
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
    let sweep = dir.join("sweep");
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
