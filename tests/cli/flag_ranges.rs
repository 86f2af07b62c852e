//! Issue 24 (hardening, round 3), the command-line part: a full stdout, ranges of every
//! command's flags, `solver.event_tol`, quoting in errors, the Slurm script's values,
//! validation gaps, `--jobs` and the whole-command budget of `resonance` and `shortcut-map`.
//! Every child process runs under a deadline; none may panic.

use crate::tools;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a djkr run left: exit code (`None`: killed by a signal), stdout, stderr.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Run djkr with `args` in `cwd` with `stdout` as its standard output (piped when `None`),
/// killed after `limit`.
fn djkr_with(cwd: &Path, args: &[&str], stdout: Option<Stdio>, limit: Duration) -> Run {
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(stdout.unwrap_or_else(Stdio::piped))
        .stderr(Stdio::piped())
        .spawn()
        .expect("djkr binary runs");
    let (status, stdout, stderr) = tools::finish_within(child, limit);
    assert!(
        status.is_some(),
        "djkr {args:?} did not finish within {limit:?}; stderr: {stderr}"
    );
    let r = Run {
        code: status.and_then(|s| s.code()),
        stdout,
        stderr,
    };
    assert!(
        !r.stderr.contains("panicked"),
        "djkr {args:?} panicked: {}",
        r.stderr
    );
    r
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn djkr(args: &[&str]) -> Run {
    djkr_with(root(), args, None, Duration::from_secs(120))
}

/// Exit status 2 and every needle in stderr; returns stderr.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let r = djkr(args);
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

/// Exit status 0; returns the run.
fn ok(args: &[&str]) -> Run {
    let r = djkr(args);
    assert_eq!(r.code, Some(0), "djkr {args:?}: {}", r.stderr);
    r
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

// ---------------------------------------------------------------------------------------------
// Defect 8: a full stdout is a clean error with exit status 1, never a panic (exit 101).

#[cfg(target_os = "linux")]
#[test]
fn a_full_stdout_is_a_clean_error_with_exit_status_1() {
    let dir = tempfile::tempdir().unwrap();
    let run_out = dir.path().join("run");
    let fig_out = dir.path().join("figs");
    let cases: Vec<Vec<&str>> = vec![
        vec![
            "cycle", "--freq", "400", "--a-mean", "1mm", "--a-amp", "1mm",
        ],
        vec![
            "cycle", "--freq", "400", "--a-mean", "1mm", "--a-amp", "1mm", "--json",
        ],
        vec![
            "pulloff", "--freq", "400", "--a-amp", "0.5mm", "--method", "approx",
        ],
        vec!["required-speed", "--amplification", "3"],
        vec!["check", "tests/sweep/tiny.toml"],
        vec!["run", "tests/sweep/tiny.toml", "--out", s(&run_out)],
        vec!["figures", "--out", s(&fig_out)],
    ];
    for args in &cases {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let r = djkr_with(root(), args, Some(full.into()), Duration::from_secs(120));
        assert_eq!(r.code, Some(1), "djkr {args:?}: {}", r.stderr);
        assert!(
            r.stderr.contains("writing to standard output")
                && r.stderr.contains("No space left on device"),
            "djkr {args:?}: {}",
            r.stderr
        );
    }
    // The run's files were written before the listing failed.
    assert!(run_out.join("summary.json").is_file());
}

// ---------------------------------------------------------------------------------------------
// Defect 12: values written into sweep.sbatch follow Slurm's grammar; nothing is written else.

#[test]
fn slurm_values_that_could_inject_a_command_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("job");
    let base = [
        "sweep",
        "tests/sweep/tiny.toml",
        "--set",
        "base.amplitude=1um,2um",
        "--slurm",
        "--out",
        s(&out),
    ];
    for (flag, value) in [
        ("--slurm-partition", "batch\necho pwned"),
        ("--slurm-partition", "batch;id"),
        ("--slurm-partition", "a b"),
        ("--slurm-partition", "$(id)"),
        ("--slurm-time", "1:00:00\necho pwned"),
        ("--slurm-time", "1h"),
        ("--slurm-time", "1:2:3:4"),
    ] {
        let mut args = base.to_vec();
        args.extend([flag, value]);
        let e = refused(&args, &[flag]);
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
        assert!(!out.exists(), "{flag} {value:?}: wrote {}", out.display());
    }
    // A newline in --out would end the #SBATCH --output line.
    let bad_out = dir.path().join("x\necho pwned");
    let mut args = base.to_vec();
    args[6] = s(&bad_out);
    refused(&args, &["--out", "control character"]);
    // Every format sbatch documents is accepted, and lands in the script as given.
    for t in ["90", "30:00", "2:00:00", "1-12", "1-12:30", "1-12:30:00"] {
        let mut args = base.to_vec();
        args.extend(["--slurm-time", t, "--slurm-partition", "gpu-a100,long_q"]);
        ok(&args);
        let script = std::fs::read_to_string(out.join("sweep.sbatch")).unwrap();
        assert!(
            script.contains(&format!("#SBATCH --time={t}\n")),
            "{script}"
        );
        assert!(script.contains("#SBATCH --partition=gpu-a100,long_q\n"));
    }
}

// ---------------------------------------------------------------------------------------------
// Defect 6 (the cap): --jobs beyond the available parallelism is capped, with a warning.

#[test]
fn jobs_beyond_the_cores_are_capped_with_a_warning() {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sw");
    let r = ok(&[
        "sweep",
        "tests/sweep/tiny.toml",
        "--set",
        "base.amplitude=1um,2um",
        "--jobs",
        "100000000",
        "--out",
        s(&out),
    ]);
    let want = format!("--jobs 100000000: capped at {cores}, the available parallelism");
    assert!(r.stderr.contains(&want), "{}", r.stderr);
    assert!(
        r.stdout.contains(&format!("on {cores} thread(s)")),
        "{}",
        r.stdout
    );
    // Within the cores: no warning.
    let out1 = dir.path().join("sw1");
    let r = ok(&[
        "sweep",
        "tests/sweep/tiny.toml",
        "--set",
        "base.amplitude=1um,2um",
        "--jobs",
        "1",
        "--out",
        s(&out1),
    ]);
    assert!(!r.stderr.contains("capped"), "{}", r.stderr);
}

// ---------------------------------------------------------------------------------------------
// Defect 10: solver.event_tol is bounded where the answer stops converging (measured).

#[test]
fn a_coarse_event_tol_is_refused_and_a_loose_one_warned_about() {
    // 1e-3 s gave amplification 2.12 instead of 9.57, exit 0.
    for v in ["1e-3", "3e-5", "1.1e-6"] {
        let set = format!("solver.event_tol={v}");
        refused(
            &["run", "tests/sweep/tiny.toml", "--set", &set],
            &["solver.event_tol", "must not exceed 1e-6 (s)"],
        );
        refused(
            &["check", "tests/sweep/tiny.toml", "--set", &set],
            &["solver.event_tol"],
        );
    }
    // Within the bound but above 1e-9 s: runs, with a warning in the summary.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let r = ok(&[
        "run",
        "tests/sweep/tiny.toml",
        "--set",
        "solver.event_tol=1e-6",
        "--out",
        s(&out),
    ]);
    assert!(r
        .stderr
        .contains("solver.event_tol = 1e-6 s is above 1e-9 s"));
    assert!(r.stdout.contains("amplification 9.570"), "{}", r.stdout);
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("solver.event_tol = 1e-6 s is above 1e-9 s"));
    // The default and tight values: no warning.
    let r = ok(&[
        "check",
        "tests/sweep/tiny.toml",
        "--set",
        "solver.event_tol=1e-9",
    ]);
    assert!(!r.stderr.contains("event_tol"), "{}", r.stderr);
}

// ---------------------------------------------------------------------------------------------
// Defect 13: check refuses what run cannot start, naming the key; units everywhere; both mus.

#[test]
fn check_refuses_what_run_cannot_start_naming_the_key() {
    for (set, key, why) in [
        ("spring.stiffness=5e-324", "spring.stiffness", "subnormal"),
        (
            "sphere.mass=1e-300",
            "sphere.mass",
            "must be at least 1e-20 (kg)",
        ),
        (
            "sphere.mass=1e-100",
            "sphere.mass",
            "must be at least 1e-20 (kg)",
        ),
        ("sphere.gravity=1e-310", "sphere.gravity", "subnormal"),
        ("damping.c=1e-310", "damping.c", "subnormal"),
        ("base.amplitude=1e-310", "base.amplitude", "subnormal"),
        (
            "output.sample_rate=1e-310",
            "output.sample_rate",
            "subnormal",
        ),
    ] {
        refused(
            &["check", "tests/sweep/tiny.toml", "--set", set],
            &[key, why],
        );
        refused(&["run", "tests/sweep/tiny.toml", "--set", set], &[key, why]);
    }
    // 0 stays what it was: a massless sphere is the quasi-static balance (refused here only
    // because this scenario has damping, as before).
    refused(
        &["check", "tests/sweep/tiny.toml", "--set", "sphere.mass=0"],
        &["mass = 0 with damping"],
    );
    ok(&[
        "check",
        "tests/sweep/tiny.toml",
        "--set",
        "sphere.mass=0",
        "--set",
        "damping.c=0",
    ]);
}

#[test]
fn every_quantity_takes_its_units_and_both_micro_signs() {
    let dir = tempfile::tempdir().unwrap();
    let run = |sets: &[&str], name: &str| -> String {
        let out = dir.path().join(name);
        let mut args = vec!["run", "tests/sweep/tiny.toml", "--out", s(&out)];
        for set in sets {
            args.extend(["--set", set]);
        }
        ok(&args);
        let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
        let v: serde_json::Value = serde_json::from_str(&summary).unwrap();
        v["pull_off"]["amplification"].to_string()
    };
    // The same run, spelled with and without units: gravity in m/s^2 (a factor of 1, so the
    // same number as 9.81), the base amplitude with u, the micro sign and the Greek mu (the
    // same factor 1e-6 each).
    let si = run(&["sphere.gravity=9.81", "base.amplitude=\"10um\""], "si");
    for (i, (g, xb)) in [
        ("\"9.81m/s^2\"", "\"10um\""),
        ("\"9.81 m/s2\"", "\"10\u{b5}m\""),
        ("9.81", "\"10\u{3bc}m\""),
    ]
    .iter()
    .enumerate()
    {
        let g = format!("sphere.gravity={g}");
        let xb = format!("base.amplitude={xb}");
        assert_eq!(run(&[&g, &xb], &format!("u{i}")), si, "{g} {xb}");
    }
    refused(
        &[
            "check",
            "tests/sweep/tiny.toml",
            "--set",
            "sphere.gravity=9.81m/s",
        ],
        &["sphere.gravity", "unknown unit"],
    );
    // And in a flag: --radius 51μm is 51 µm.
    let a = ok(&[
        "pulloff",
        "--freq",
        "400",
        "--a-amp",
        "5um",
        "--radius",
        "51\u{3bc}m",
        "--json",
    ]);
    let b = ok(&[
        "pulloff", "--freq", "400", "--a-amp", "5um", "--radius", "51um", "--json",
    ]);
    assert_eq!(a.stdout, b.stdout);
}

// ---------------------------------------------------------------------------------------------
// Defect 9: the ranges of the scenario keys apply to every command's flags.

#[test]
fn command_flags_meet_the_ranges_of_the_scenario_keys() {
    let c = |extra: &[&'static str]| {
        let mut v = vec![
            "cycle", "--freq", "400", "--a-mean", "1mm", "--a-amp", "1mm",
        ];
        v.extend_from_slice(extra);
        v
    };
    // The reproducer: NaN with exit 0 (and an internal error with --json).
    for json in [false, true] {
        let mut args = vec![
            "cycle", "--freq", "1e300", "--a-mean", "1e300", "--a-amp", "1e300",
        ];
        if json {
            args.push("--json");
        }
        let e = refused(&args, &["--freq = 1e300", "[1e-6, 1e6]", "base.frequency"]);
        assert!(!e.contains("NaN") && !e.contains("internal"), "{e}");
    }
    refused(
        &[
            "cycle", "--freq", "1e15", "--a-mean", "1mm", "--a-amp", "1mm",
        ],
        &["--freq = 1e15"],
    );
    refused(
        &[
            "cycle", "--freq", "400", "--a-mean", "1e300", "--a-amp", "1mm",
        ],
        &["--a-mean = 1e300", "exceed the sphere's radius"],
    );
    refused(
        &[
            "cycle", "--freq", "400", "--a-mean", "1mm", "--a-amp", "1e300", "--json",
        ],
        &["--a-amp = 1e300", "exceed the sphere's radius"],
    );
    for (flag, value, key) in [
        ("--modulus", "1e20", "material.K"),
        ("--modulus", "0.5", "material.K"),
        ("--radius", "100", "material.R"),
        ("--w0", "1e-12", "material.w0"),
        ("--v0", "1e6", "adhesion.v0"),
        ("--n", "50", "adhesion.n"),
    ] {
        refused(&c(&[flag, value]), &[flag, key]);
        let r = refused(
            &["pulloff", "--freq", "400", "--a-amp", "0.5mm", flag, value],
            &[flag, key],
        );
        assert!(!r.contains("NaN"));
    }
    refused(&c(&["--radius", "1e-310"]), &["--radius", "subnormal"]);
    refused(
        &["pulloff", "--freq", "1e300", "--a-amp", "1e300"],
        &["--freq = 1e300"],
    );
    refused(
        &["pulloff", "--freq", "400", "--a-amp", "1e300"],
        &["--a-amp = 1e300"],
    );
    refused(
        &[
            "pulloff", "--freq", "400", "--a-amp", "1mm", "--method", "approx", "--beta", "1e300",
        ],
        &["--beta = 1e300", "[1e-2, 1e2]"],
    );
    refused(
        &["required-speed", "--amplification", "3", "--beta", "1e300"],
        &["--beta = 1e300"],
    );
    // An error quotes the value as typed, not a 300-digit rendering of it.
    let e = refused(
        &["required-speed", "--amplification", "1e300"],
        &["--amplification = 1e300:"],
    );
    assert!(e.len() < 300, "{e}");
    refused(
        &[
            "pulloff",
            "--freq",
            "400",
            "--method",
            "shui",
            "--mass",
            "1e-300",
            "--damping",
            "1",
            "--base-amp",
            "1um",
        ],
        &["--mass", "sphere.mass"],
    );
    refused(
        &[
            "resonance",
            "scenarios/resonance-400hz.toml",
            "--freq",
            "1e300:1e301:2",
        ],
        &["--freq = 1e300", "base.frequency"],
    );
    refused(
        &[
            "shortcut-map",
            "scenarios/resonance-400hz.toml",
            "--freq",
            "300:400:2",
            "--amp",
            "1um:5:2",
        ],
        &["--amp = 5", "base.amplitude"],
    );
    // Within the ranges, the answers are as before.
    let r = ok(&c(&["--json"]));
    assert!(r.stdout.contains("\"force_mean\""));
}

// ---------------------------------------------------------------------------------------------
// Defect 11: errors quote at most ~80 characters, and no line of a file that failed to parse.

#[test]
fn errors_quote_little_and_never_a_line_of_a_foreign_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tiny = std::fs::read_to_string(root().join("tests/sweep/tiny.toml")).unwrap();
    // A tabulated law pointed at a file that is not a table: its lines are not shown.
    let tab = tiny.replace(
        "law = \"gent-schultz\"\nv0 = 4.45e-5\nn = 0.531",
        "law = \"tabulated\"\nfile = \"law.csv\"",
    );
    std::fs::write(d.join("tab.toml"), &tab).unwrap();
    std::fs::write(d.join("law.csv"), "speed,w\n0,0.24\n1e-3,0.2\n").unwrap();
    let secret = "daemon:*:19000:0:99999:7:::secret-line";
    std::fs::write(d.join("secret"), format!("root:x:0:0\n{secret}\n")).unwrap();
    let set = format!("adhesion.file={}", d.join("secret").display());
    let e = refused(
        &["check", s(&d.join("tab.toml")), "--set", &set],
        &["line 2"],
    );
    assert!(!e.contains("daemon") && !e.contains("secret-line"), "{e}");
    // A value of 900 kB is quoted to its first 80 characters.
    let big = tiny.replace("R = 0.051", &format!("R = \"{}mm\"", "1".repeat(900_000)));
    std::fs::write(d.join("big.toml"), big).unwrap();
    let e = refused(
        &["check", s(&d.join("big.toml"))],
        &["material.R", "bytes in all"],
    );
    assert!(e.len() < 400, "{} bytes", e.len());
    // So is a long --set.
    let long = format!("material.R={}", "9".repeat(100_000));
    let e = refused(
        &["check", "tests/sweep/tiny.toml", "--set", &long],
        &["material.R"],
    );
    assert!(e.len() < 600, "{} bytes", e.len());
    // A gs-fit record with one long line: neither echoed nor shown.
    std::fs::write(
        d.join("rec.csv"),
        format!("t,a,F\n{}\n", "x".repeat(1_000_000)),
    )
    .unwrap();
    let e = refused(&["gs-fit", s(&d.join("rec.csv"))], &["line 2", "not shown"]);
    assert!(e.len() < 400 && !e.contains("xxxx"), "{} bytes", e.len());
    std::fs::write(
        d.join("rec2.csv"),
        format!("t [s],a [{}],F [N]\n0,1,2\n", "q".repeat(100_000)),
    )
    .unwrap();
    let e = refused(&["gs-fit", s(&d.join("rec2.csv"))], &["unknown unit"]);
    assert!(e.len() < 600, "{} bytes", e.len());
}

// ---------------------------------------------------------------------------------------------
// Defect 14 (last item): solver.max_wall_s bounds the whole of resonance and shortcut-map.

/// Run djkr with a deadline, timing it.
fn timed(args: &[&str]) -> (Run, Duration) {
    let t0 = Instant::now();
    let r = djkr_with(root(), args, None, Duration::from_secs(120));
    (r, t0.elapsed())
}

#[test]
fn max_wall_s_bounds_the_whole_resonance_and_shortcut_map() {
    let dir = tempfile::tempdir().unwrap();
    let res = dir.path().join("res");
    // impacts.toml: about 0.1 s per frequency on one core, 41 x 2 frequencies.
    let (r, wall) = timed(&[
        "resonance",
        "scenarios/impacts.toml",
        "--freq",
        "200:400:41",
        "--set",
        "solver.max_wall_s=1",
        "--out",
        s(&res),
    ]);
    assert_eq!(r.code, Some(3), "{}", r.stderr);
    assert!(wall < Duration::from_secs(15), "{wall:?}");
    assert!(
        r.stderr.contains("budget of the whole resonance command") && r.stderr.contains("of 41 up"),
        "{}",
        r.stderr
    );
    // What was computed is in the files.
    let csv = std::fs::read_to_string(res.join("resonance.csv")).unwrap();
    assert!(csv.lines().count() >= 2, "{csv}");
    assert!(res.join("resonance.h5").is_file());
    let map = dir.path().join("map");
    let (r, wall) = timed(&[
        "shortcut-map",
        "scenarios/impacts.toml",
        "--freq",
        "200:400:20",
        "--amp",
        "100um:400um:10",
        "--set",
        "solver.max_wall_s=1",
        "--out",
        s(&map),
    ]);
    assert_eq!(r.code, Some(3), "{}", r.stderr);
    assert!(wall < Duration::from_secs(15), "{wall:?}");
    assert!(
        r.stderr
            .contains("budget of the whole shortcut-map command")
            && r.stderr.contains("of 200 cells"),
        "{}",
        r.stderr
    );
    assert!(map.join("shortcut-map.csv").is_file());
    // Within the budget: exit 0, as before.
    let (r, _) = timed(&[
        "resonance",
        "scenarios/resonance-400hz.toml",
        "--freq",
        "390:410:3",
        "--out",
        s(&dir.path().join("ok")),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
}
