//! Runs that end early keep what they computed (issue 24, defect 3): a run stopped by a budget
//! (`max_steps`, `max_wall_s`, `max_events`, `max_memory`) or a signal (SIGINT, SIGTERM), or
//! failed mid-way, publishes its files with `status`, `reason` and `message` in summary.json and
//! exits 3 (stopped), 1 (failed) or 130 (Ctrl-C); a sweep's row stopped by a budget is
//! `stopped`, and `--resume` runs stopped and failed rows again unless `--no-retry`. Also the
//! step budget's message (defect 14): the budget the user set and the steps taken.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use djkr::api::{self, SAMPLE_BYTES};
use djkr::error::Error as ApiError;
use djkr::scenario::parse::parse_scenario;
use djkr_core::dynamics::{Reason, SimError, Status};
use serde_json::Value;

const TINY: &str = "tests/sweep/tiny.toml";
const VIB400: &str = "benches/scenes/vib400.toml";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn djkr(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .current_dir(root())
        .args(args)
        .output()
        .expect("djkr binary runs")
}

fn summary(dir: &Path) -> Value {
    let text = std::fs::read_to_string(dir.join("summary.json"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    serde_json::from_str(&text).unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `djkr run FILE --set ... --out DIR --csv`: the output, and the folder.
fn run_cli(tmp: &Path, name: &str, file: &str, sets: &[&str]) -> (Output, PathBuf) {
    let out = tmp.join(name);
    let mut args = vec!["run", file, "--csv", "--out", out.to_str().unwrap()];
    for s in sets {
        args.push("--set");
        args.push(s);
    }
    (djkr(&args), out)
}

/// The scene of defect 14: the paper's material with w0 = 1e-9, no mass, a 200 N/m spring from
/// a 0.02 N preload, the base at 10 µm and 1e5 Hz for 1 s, then unloading at 1 mm/s to pull-off.
const DEFECT_14: &str = r#"
version = 1
[material]
K = 9.33e6
R = 0.051
w0 = 1e-9
[adhesion]
law = "gent-schultz"
v0 = 4.45e-5
n = 0.531
[sphere]
mass = 0
[spring]
stiffness = 200.0
[base]
amplitude = 10e-6
frequency = 1e5
[initial]
preload = 0.02
[[stage]]
kind = "hold"
duration = 1.0
vibration = true
[[stage]]
kind = "unload"
speed = 1e-3
until = "pull-off"
[solver]
max_steps = 200000
max_wall_s = 3
"#;

/// Defect 14: `max_steps = 200000` was reported as "step budget of 734 steps exhausted" (what
/// was left for an envelope-following trial period when it ran out). The message now gives the
/// budget the scenario set and the steps taken, and the run's own time.
#[test]
fn the_step_budget_message_states_the_budget_set_and_the_steps_taken() {
    let s = parse_scenario(DEFECT_14, "defect14.toml", None).unwrap();
    let o = s
        .simulate_partial(&mut djkr_core::dynamics::NoObserver)
        .unwrap();
    let e = o.error.as_ref().expect("the step budget stops this run");
    match e {
        SimError::StepBudget {
            max_steps,
            steps,
            t,
            ..
        } => {
            assert_eq!(*max_steps, 200_000);
            assert_eq!(*steps, 200_000);
            assert_eq!(o.result.stats.steps, 200_000);
            // The run's last accepted state, not the trial's.
            assert_eq!(*t, o.result.final_state.t);
        }
        e => panic!("expected the step budget, got {e}"),
    }
    let m = e.to_string();
    assert!(
        m.contains("200000 steps taken of solver.max_steps = 200000"),
        "{m}"
    );
    let ending = o.ending();
    assert_eq!(ending.status(), Status::Stopped);
    assert_eq!(ending.reason, Some(Reason::MaxSteps));
}

/// Each budget stops `djkr run` with exit status 3 and publishes the run up to the stop: every
/// file, summary.json with status, reason and a message naming the time and stage.
#[test]
fn a_run_stopped_by_a_budget_publishes_what_it_computed() {
    let tmp = tempfile::tempdir().unwrap();
    let cases: [(&str, &str, &[&str], &str); 3] = [
        (
            "steps",
            TINY,
            &["solver.max_steps=3000", "output.sample_rate=0"],
            "max_steps",
        ),
        (
            "events",
            "scenarios/impacts.toml",
            &["solver.max_events=5"],
            "max_events",
        ),
        (
            "wall",
            TINY,
            &[
                "solver.max_wall_s=0.3",
                "stage[0].duration=1000",
                "solver.envelope=off",
            ],
            "max_wall_s",
        ),
    ];
    for (name, file, sets, reason) in cases {
        let (o, out) = run_cli(tmp.path(), name, file, sets);
        assert_eq!(o.status.code(), Some(3), "{name}: {}", text(&o));
        let s = summary(&out);
        assert_eq!(s["status"], "stopped", "{name}");
        assert_eq!(s["reason"], reason, "{name}");
        let message = s["message"].as_str().unwrap();
        assert!(message.contains("the run got to t = "), "{message}");
        assert!(message.contains(" in stage "), "{message}");
        let t_end = s["final_state"]["t"].as_f64().unwrap();
        assert!(t_end > 0.0, "{name}: the run got somewhere");
        for f in [
            "run.h5",
            "timeseries.csv",
            "events.csv",
            "cycles.csv",
            "summary.json",
        ] {
            assert!(out.join(f).is_file(), "{name}: {f} published");
        }
        // The time series runs up to the stop.
        let csv = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
        let last_t: f64 = csv
            .lines()
            .last()
            .unwrap()
            .split(',')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        // A grid sample's time is computed on the grid (k / rate), the final state's by the
        // integration: where the run stops right at a sample, they may differ by an ulp.
        assert!(
            last_t > 0.0 && last_t <= t_end * (1.0 + 4.0 * f64::EPSILON),
            "{name}: {last_t} vs {t_end}"
        );
        assert_eq!(
            s["samples"].as_u64().unwrap() as usize,
            csv.lines().count() - 1,
            "{name}"
        );
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(stderr.contains("stopped: "), "{stderr}");
        assert!(stderr.contains(out.to_str().unwrap()), "{stderr}");
    }
    // A run that goes to its end says so.
    let (o, out) = run_cli(tmp.path(), "ok", TINY, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let s = summary(&out);
    assert_eq!(s["status"], "ok");
    assert!(
        s.get("reason").is_none() && s.get("message").is_none(),
        "{s}"
    );
}

/// A failure that is not a budget (here a stage that ends at pull-off running out of its
/// max_duration first): status failed, exit status 1, the files published.
#[test]
fn a_run_that_fails_mid_way_publishes_what_it_computed() {
    let tmp = tempfile::tempdir().unwrap();
    let (o, out) = run_cli(
        tmp.path(),
        "failed",
        TINY,
        &["stage[1].max_duration=0.01", "output.sample_rate=0"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let s = summary(&out);
    assert_eq!(s["status"], "failed");
    assert_eq!(s["reason"], "stage-timeout");
    assert!(s["message"].as_str().unwrap().contains("max_duration"));
    assert!(out.join("run.h5").is_file());
    assert!(String::from_utf8_lossy(&o.stderr).starts_with("error: "));
}

/// Every reason a `SimError` gives, with its status (the documented names).
#[test]
fn every_error_has_a_documented_reason() {
    let state = Box::new(djkr_core::dynamics::Sample {
        t: 1.0,
        x_s: 0.0,
        v_s: 0.0,
        x_b: 0.0,
        x_k: 0.0,
        delta: 0.0,
        a: 0.0,
        a_dot: 0.0,
        force: 0.0,
        g: 0.0,
        w: 0.0,
        stage: 2,
    });
    let cases = [
        (
            SimError::NonFinite {
                t: 1.0,
                state: state.clone(),
            },
            "non-finite",
            Status::Failed,
        ),
        (
            SimError::StepSizeUnderflow {
                t: 1.0,
                h: 1e-20,
                state: state.clone(),
            },
            "step-underflow",
            Status::Failed,
        ),
        (
            SimError::EventLoop {
                t: 1.0,
                count: 9,
                state: state.clone(),
            },
            "no-progress",
            Status::Failed,
        ),
        (
            SimError::Explicit {
                method: "dp8".into(),
                t: 1.0,
                reason: "x".into(),
                state: state.clone(),
            },
            "method-failed",
            Status::Failed,
        ),
        (
            SimError::WallBudget {
                t: 1.0,
                max_wall_s: 2.0,
                state: state.clone(),
            },
            "max_wall_s",
            Status::Stopped,
        ),
        (
            SimError::EventBudget {
                t: 1.0,
                max_events: 2,
                state: state.clone(),
            },
            "max_events",
            Status::Stopped,
        ),
        (SimError::Cancelled { t: 1.0 }, "SIGINT", Status::Stopped),
    ];
    for (e, name, status) in cases {
        assert_eq!(e.reason().name(), name, "{e}");
        assert_eq!(e.reason().status(), status, "{e}");
    }
    assert_eq!(Reason::Memory.name(), "memory");
    assert_eq!(Reason::Sigterm.name(), "SIGTERM");
    assert_eq!(Reason::Sigterm.status(), Status::Stopped);
}

/// A long run sent SIGTERM (exit status 3) or SIGINT (130) publishes what it computed, with the
/// signal as its reason.
#[cfg(unix)]
#[test]
fn a_signal_stops_a_run_and_keeps_what_it_computed() {
    let tmp = tempfile::tempdir().unwrap();
    for (signal, code, reason) in [("-TERM", 3, "SIGTERM"), ("-INT", 130, "SIGINT")] {
        let out = tmp.path().join(reason);
        let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
            .current_dir(root())
            .args([
                "run",
                VIB400,
                "--set",
                "stage[0].duration=1000",
                "--set",
                "solver.envelope=off",
                "--set",
                "output.sample_rate=100",
                "--out",
                out.to_str().unwrap(),
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(1000));
        let t0 = Instant::now();
        let kill = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(kill.success());
        let o = child.wait_with_output().unwrap();
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "{reason}: took {:?}",
            t0.elapsed()
        );
        assert_eq!(o.status.code(), Some(code), "{reason}: {}", text(&o));
        let s = summary(&out);
        assert_eq!(s["status"], "stopped");
        assert_eq!(s["reason"], reason);
        assert!(s["message"].as_str().unwrap().contains(reason));
        assert!(s["final_state"]["t"].as_f64().unwrap() > 0.0);
        assert!(out.join("run.h5").is_file());
    }
}

/// `solver.max_memory` caps what a run kept in memory holds: with 1 MiB and a sample at every
/// step, the run stops with reason `memory`, its samples within the budget, and keeps them.
#[test]
fn the_memory_budget_stops_a_run_kept_in_memory() {
    let tmp = tempfile::tempdir().unwrap();
    let src = djkr::scenario::parse::ScenarioSource::read(&root().join(TINY)).unwrap();
    let sets = djkr::scenario::overrides::Override::parse_all(&[
        "solver.max_memory=1048576".to_string(),
        "output.sample_rate=0".to_string(),
        "stage[0].duration=5".to_string(),
        "solver.envelope=off".to_string(),
    ])
    .unwrap();
    let scn = src.scenario(&sets).unwrap();
    let out = tmp.path().join("memory");
    let e = api::run(&scn, Some(&out)).unwrap_err();
    let ApiError::Ended { ending, record, .. } = &e else {
        panic!("expected a stopped run, got {e}");
    };
    assert_eq!(ending.status(), Status::Stopped);
    assert_eq!(ending.reason, Some(Reason::Memory));
    assert!(e.to_string().contains("max_memory"), "{e}");
    let samples = record.series.rows() as u64;
    assert!(samples > 1000, "{samples}");
    // What it holds (samples, events, period records) is within the budget, and one more
    // sample would have passed it.
    let held = samples * SAMPLE_BYTES
        + record.events.len() as u64 * api::EVENT_BYTES
        + record.cycles.rows() as u64 * api::CYCLE_BYTES;
    assert!(held <= 1 << 20, "{held} bytes held");
    assert!(held + SAMPLE_BYTES > 1 << 20, "{held} bytes held");
    let s: Value = serde_json::from_str(&record.summary).unwrap();
    assert_eq!(s["status"], "stopped");
    assert_eq!(s["reason"], "memory");
    assert_eq!(s["samples"].as_u64().unwrap(), samples);
    let on_disk = summary(&out);
    assert_eq!(on_disk["reason"], "memory");
    assert_eq!(on_disk["samples"].as_u64().unwrap(), samples);
    // The same scene with the default budget goes on past it.
    let sets = djkr::scenario::overrides::Override::parse_all(&[
        "output.sample_rate=0".to_string(),
        "stage[0].duration=0.2".to_string(),
        "solver.max_memory=1048576".to_string(),
    ])
    .unwrap();
    let short = src.scenario(&sets).unwrap();
    assert!(api::run(&short, None).is_ok());
}

/// A sweep's row stopped by a budget has status `stopped`; `--resume` runs it again unless
/// `--no-retry`.
#[test]
fn a_sweep_row_stopped_by_a_budget_is_stopped_and_resume_retries_it() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let o_str = out.to_str().unwrap();
    let o = djkr(&[
        "sweep",
        TINY,
        "--set",
        "solver.max_steps=50,1000000",
        "--jobs",
        "1",
        "--out",
        o_str,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let status = |out: &Path| -> Vec<String> {
        let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = header.iter().position(|h| *h == "status").unwrap();
        lines
            .map(|l| l.split(',').nth(col).unwrap().to_string())
            .collect()
    };
    assert_eq!(status(&out), ["stopped", "ok"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("1 stopped by a budget"), "{stdout}");
    // --no-retry: nothing to do.
    let o = djkr(&[
        "sweep",
        TINY,
        "--set",
        "solver.max_steps=50,1000000",
        "--jobs",
        "1",
        "--out",
        o_str,
        "--resume",
        "--no-retry",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(!String::from_utf8_lossy(&o.stdout).contains("  ran "));
    assert_eq!(status(&out), ["stopped", "ok"]);
    // --resume: the stopped row runs again (and stops again: the budget is the same).
    let o = djkr(&[
        "sweep",
        TINY,
        "--set",
        "solver.max_steps=50,1000000",
        "--jobs",
        "1",
        "--out",
        o_str,
        "--resume",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("1 stopped or failed run(s) run again"),
        "{stderr}"
    );
    assert!(String::from_utf8_lossy(&o.stdout).contains("  ran 1 "));
    assert_eq!(status(&out), ["stopped", "ok"]);
}

/// The sizes docs/guide/unattended.md ("Memory") gives for what a run holds in memory.
#[test]
fn the_documented_sizes_are_the_counted_ones() {
    assert_eq!(SAMPLE_BYTES, 104);
    // The estimate before a run counts a sample's peak, at most twice its data (a column's
    // buffer doubles when full) plus a little.
    assert!(djkr::memory::SAMPLE_BYTES >= 2.0 * SAMPLE_BYTES as f64);
    assert_eq!(api::EVENT_BYTES, 120);
    assert_eq!(api::CYCLE_BYTES, 192);
}

/// SIGTERM stops a sweep as Ctrl-C does (what is done is written, the message says how to
/// resume) but with exit status 3, a stop rather than an interrupt.
#[cfg(unix)]
#[test]
fn sigterm_stops_a_sweep_with_exit_status_3() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("term");
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .current_dir(root())
        .args([
            "sweep",
            TINY,
            "--set",
            "base.amplitude=4um:16um:300",
            "--jobs",
            "2",
            "--out",
            out.to_str().unwrap(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let progress = out.join("progress.csv");
    let t0 = Instant::now();
    while std::fs::read_to_string(&progress).map_or(0, |t| t.lines().count()) < 3
        && t0.elapsed() < Duration::from_secs(60)
    {
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let o = child.wait_with_output().unwrap();
    if o.status.success() {
        // The sweep finished before the signal arrived: nothing to check.
        return;
    }
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("--resume --out"), "{stderr}");
    assert!(out.join("sweep.csv").is_file());
}
