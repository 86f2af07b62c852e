//! Issue 35 (hardening, round 4), the values djkr is given and the numbers it reports: long
//! values quoted to an excerpt (item 5), statistics that are not defined (item 7), a detached
//! run with no tensile pull-off (item 8), subnormal radii refused (item 10). Every child process
//! runs under a deadline; none may panic.

use crate::tools;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// What a djkr run left: exit code (`None`: killed by a signal), stdout, stderr.
struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Run djkr with `args` (from the crate's root), killed after two minutes.
fn djkr(args: &[&str]) -> Run {
    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(root())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("djkr binary runs");
    let (status, stdout, stderr) = tools::finish_within(child, Duration::from_secs(120));
    assert!(status.is_some(), "djkr did not finish: {}", head(&stderr));
    assert!(
        !stderr.contains("panicked"),
        "djkr panicked: {}",
        head(&stderr)
    );
    Run {
        code: status.and_then(|s| s.code()),
        stdout,
        stderr,
    }
}

/// The first 300 characters of `text`.
fn head(text: &str) -> String {
    text.chars().take(300).collect()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

// ---------------------------------------------------------------------------------------------
// Item 5: every message quotes at most ~80 characters of any value.

/// Each command-line entry point that takes text, given a 100 kB value: refused (exit 2) with a
/// message under 1 kB that quotes the value's beginning and says how long it was.
#[test]
fn a_long_value_is_quoted_by_its_beginning_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = d.join("data.csv");
    std::fs::write(&data, "base.frequency,amplification\n300,1\n").unwrap();
    let out = |name: &str| d.join(name).to_str().unwrap().to_string();
    // A word (no number at all), and a number followed by junk (read as an unknown unit).
    let word = "x".repeat(100_000);
    let num = format!("1{word}");
    let tiny = "tests/sweep/tiny.toml";
    let cases: Vec<Vec<String>> = vec![
        // The issue's reproducers.
        vec![
            "pulloff", "--freq", "400", "--a-amp", "1e-3", "--method", &word,
        ],
        vec!["fit", s(&data), "--scenario", tiny, "--free", "adhesion.n"]
            .into_iter()
            .chain(["--observable", &word, "--out", &out("f")])
            .collect(),
        vec![
            "fit",
            s(&data),
            "--scenario",
            tiny,
            "--out",
            &out("f"),
            "--free",
        ]
        .into_iter()
        .chain([format!("adhesion.n={word}:1").as_str()])
        .collect(),
        vec!["continue", tiny, "--param", &word, "--range", "1:2"],
        vec![
            "continue",
            tiny,
            "--param",
            "base.frequency",
            "--range",
            "300:400",
        ]
        .into_iter()
        .chain(["--fold-param", &word, "--fold-range", "1:2"])
        .collect(),
        vec!["sweep", tiny, "--out", &out("s"), "--set"]
            .into_iter()
            .chain([format!("base.amplitude=1um,{word}").as_str()])
            .collect(),
        // Values read by djkr's parsers: numbers, units, keys, indices, ranges.
        vec!["pulloff", "--freq", &num, "--a-amp", "1e-3"],
        vec!["pulloff", "--freq", "400", "--a-amp", "1e-3", "--n", &num],
        vec!["cycle", "--freq", "400", "--a-mean", &num, "--a-amp", "1mm"],
        vec!["required-speed", "--amplification", &num],
        vec!["continue", tiny, "--param", "base.frequency", "--range"]
            .into_iter()
            .chain([format!("1:{num}").as_str()])
            .collect(),
        vec!["sweep", tiny, "--out", &out("s"), "--set"]
            .into_iter()
            .chain([format!("base.amplitude=1um,{num}").as_str()])
            .collect(),
        vec!["sweep", tiny, "--out", &out("s"), "--set"]
            .into_iter()
            .chain([format!("base.amplitude={num}:1:3").as_str()])
            .collect(),
        vec!["sweep", tiny, "--out", &out("s"), "--set"]
            .into_iter()
            .chain([format!("base.amplitude=1:2:{word}").as_str()])
            .collect(),
        vec!["sweep", tiny, "--out", &out("s"), "--set"]
            .into_iter()
            .chain([format!("stage[{word}].speed=1").as_str()])
            .collect(),
        vec!["sweep", tiny, "--out", &out("s"), "--set"]
            .into_iter()
            .chain([format!("{word}.x=1").as_str()])
            .collect(),
        vec!["run", tiny, "--out", &out("r"), "--set"]
            .into_iter()
            .chain([format!("base.amplitude={num}").as_str()])
            .collect(),
        vec![
            "fit",
            s(&data),
            "--scenario",
            tiny,
            "--out",
            &out("f"),
            "--free",
        ]
        .into_iter()
        .chain([format!("adhesion.n=0.1:{num}").as_str()])
        .collect(),
        vec!["resonance", tiny, "--out", &out("res"), "--freq"]
            .into_iter()
            .chain([format!("300:{num}:3").as_str()])
            .collect(),
        vec!["validate", tiny, "--set"]
            .into_iter()
            .chain([format!("base.frequency={num}").as_str()])
            .collect(),
        // Values clap reads: a choice, a whole number, an unknown argument or command.
        vec![
            "pulloff",
            "--freq",
            "400",
            "--a-amp",
            "1e-3",
            "--delta-form",
            &word,
        ],
        vec![
            "sweep",
            tiny,
            "--set",
            "base.amplitude=1um,2um",
            "--jobs",
            &word,
        ],
        vec!["keys", &word],
        vec![&word],
        vec!["run", tiny]
            .into_iter()
            .chain([format!("--{word}").as_str()])
            .collect(),
        // Paths no system call takes.
        vec!["check", &word],
        vec!["gs-fit", &word],
        vec!["plot", &word],
        vec!["run", &word],
        vec!["run", tiny, "--out", &word],
    ]
    .into_iter()
    .map(|c| c.into_iter().map(str::to_string).collect())
    .collect();
    for case in &cases {
        let args: Vec<&str> = case.iter().map(String::as_str).collect();
        let shown: Vec<String> = args
            .iter()
            .map(|a| a.chars().take(24).collect::<String>())
            .collect();
        let r = djkr(&args);
        assert_eq!(r.code, Some(2), "{shown:?}: {}", head(&r.stderr));
        assert!(r.stdout.is_empty(), "{shown:?}: {}", head(&r.stdout));
        assert!(
            r.stderr.len() < 1000,
            "{shown:?}: {} bytes of stderr: {}…",
            r.stderr.len(),
            head(&r.stderr)
        );
        assert!(
            r.stderr.contains("xxxxxxxxxx") && r.stderr.contains("bytes in all"),
            "{shown:?}: the message should quote the value's beginning and its length: {}",
            r.stderr
        );
    }
}

/// Values that come from a file djkr reads back (a sweep folder's sweep.csv, a cell edited to
/// 100 kB), from the environment (`--shard slurm`'s SLURM_ARRAY_TASK_ID) or from a list flag
/// with nothing but commas are quoted by their beginning too.
#[test]
fn long_values_from_files_and_the_environment_are_quoted_by_their_beginning() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = dir.path().join("s");
    let r = djkr(&[
        "sweep",
        "tests/sweep/tiny.toml",
        "--set",
        "base.amplitude=1um,2um",
        "--out",
        s(&sweep),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let csv = sweep.join("sweep.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = header
        .iter()
        .position(|h| h.starts_with("pull_off_force"))
        .unwrap();
    let mut cells: Vec<String> = lines[1].split(',').map(str::to_string).collect();
    cells[col] = "y".repeat(100_000);
    lines[1] = cells.join(",");
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let merged = dir.path().join("m");
    let r = djkr(&["sweep", "merge", s(&sweep), "--out", s(&merged)]);
    assert_eq!(r.code, Some(2), "{}", head(&r.stderr));
    assert!(
        r.stderr.len() < 1000 && r.stderr.contains("yyyyyyyyyy… (100000 bytes in all)"),
        "{}",
        head(&r.stderr)
    );

    let commas = ",".repeat(100_000);
    let r = djkr(&[
        "accuracy",
        "tests/sweep/tiny.toml",
        "--methods",
        &commas,
        "--out",
        s(&dir.path().join("acc")),
    ]);
    assert_eq!(r.code, Some(2), "{}", head(&r.stderr));
    assert!(r.stderr.len() < 1000, "{} bytes", r.stderr.len());

    let child = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args([
            "sweep",
            "tests/sweep/tiny.toml",
            "--set",
            "base.amplitude=1um,2um",
        ])
        .args(["--shard", "slurm", "--out"])
        .arg(dir.path().join("shard"))
        .current_dir(root())
        .env("SLURM_ARRAY_TASK_ID", "7".repeat(100_000))
        .env("SLURM_ARRAY_TASK_COUNT", "2")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (status, _, stderr) = tools::finish_within(child, Duration::from_secs(60));
    assert_eq!(status.and_then(|s| s.code()), Some(2), "{}", head(&stderr));
    assert!(
        stderr.len() < 1000 && stderr.contains("SLURM_ARRAY_TASK_ID = 7777777777"),
        "{}",
        head(&stderr)
    );
}

// ---------------------------------------------------------------------------------------------
// Item 7: a statistic that is not defined is said so, never printed as inf.

/// The light protocol with a constant work of adhesion and damping 0.1 N s/m bounces before the
/// pull-off: periods with no contact at all (mean force exactly 0) among those the roughness
/// looks at. The relative fluctuation divides by those means: it is reported as not defined,
/// with the number of such periods, which cycles.csv confirms.
#[test]
fn a_roughness_over_zero_means_is_not_defined_rather_than_inf() {
    let dir = tempfile::tempdir().unwrap();
    let light = std::fs::read_to_string(root().join("tests/sweep/light-protocol-300hz.toml"))
        .unwrap()
        .replace(
            "law = \"gent-schultz\"\nv0 = 4.45e-5\nn = 0.531",
            "law = \"constant\"",
        );
    assert!(light.contains("law = \"constant\""));
    let file = dir.path().join("light-constant.toml");
    std::fs::write(&file, light).unwrap();
    let out = dir.path().join("run");
    let r = djkr(&[
        "run",
        s(&file),
        "--set",
        "damping.c=0.1",
        "--csv",
        "--out",
        s(&out),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(!r.stdout.contains("inf"), "{}", r.stdout);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let po = &summary["pull_off"];
    assert!(po.get("approach_roughness").is_none(), "{po}");
    assert_eq!(summary["non_finite"], serde_json::json!({}));
    let zeros = po["approach_zero_means"].as_u64().unwrap();
    // The reference: the periods before the one that holds the pull-off force, in cycles.csv.
    // The roughness looks at the second differences centred on the 16 periods that end two
    // periods before it (each needs the period after it).
    let text = std::fs::read_to_string(out.join("cycles.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t_end, mean) = (col("t_end [s]"), col("force_mean [N]"));
    let rows: Vec<(f64, f64)> = lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (c[t_end].parse().unwrap(), c[mean].parse().unwrap())
        })
        .collect();
    let t_po = po["time"].as_f64().unwrap();
    let m = rows
        .iter()
        .position(|(t, _)| t.to_bits() == t_po.to_bits())
        .expect("the pull-off period in cycles.csv");
    let want = rows[m - 17..m - 1]
        .iter()
        .filter(|(_, f)| *f == 0.0)
        .count() as u64;
    assert!(want > 0, "the scene should bounce before its pull-off");
    assert_eq!(zeros, want);
    assert!(
        r.stdout.contains(&format!(
            "{zeros} of the 16 periods before the pull-off had a zero mean"
        )),
        "{}",
        r.stdout
    );
    assert!(r.stdout.contains("not defined"), "{}", r.stdout);
}

// ---------------------------------------------------------------------------------------------
// Item 8: a detached run with no tensile cycle mean reports no pull-off and no amplification.

/// The issue's reproducer: the sphere bounces off the substrate with every cycle mean
/// compressive. No "pull-off force" or amplification is printed, summary.json says
/// `tensile: false` with a warning and leaves the amplification out; cycles.csv confirms that
/// no mean was tensile and that the recorded force is the least compressive one.
#[test]
fn a_detachment_without_a_tensile_mean_is_no_pull_off() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bounce");
    let r = djkr(&[
        "run",
        "tests/sweep/tiny.toml",
        "--set",
        "material.w0=2.929e-5",
        "--set",
        "base.frequency=61.157",
        "--set",
        "initial.preload=2.579e-5",
        "--csv",
        "--out",
        s(&out),
    ]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(!r.stdout.contains("(amplification"), "{}", r.stdout);
    assert!(!r.stdout.contains("  pull-off force   "), "{}", r.stdout);
    assert!(
        r.stdout
            .contains("no pull-off        detached without a tensile cycle mean"),
        "{}",
        r.stdout
    );
    assert!(
        r.stderr.contains("warning: no tensile pull-off"),
        "{}",
        r.stderr
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "ok");
    assert_eq!(summary["detached"], true);
    let po = &summary["pull_off"];
    assert_eq!(po["tensile"], false, "{po}");
    assert!(po.get("amplification").is_none(), "{po}");
    assert_eq!(summary["non_finite"]["pull_off.amplification"], "NaN");
    let warnings = summary["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().starts_with("no tensile pull-off")),
        "{warnings:?}"
    );
    // The reference: every cycle mean in cycles.csv is compressive, and the recorded force is
    // the least compressive of the pull-off stage's.
    let text = std::fs::read_to_string(out.join("cycles.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (stage, mean) = (col("stage [1]"), col("force_mean [N]"));
    let rows: Vec<(u64, f64)> = lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (c[stage].parse().unwrap(), c[mean].parse().unwrap())
        })
        .collect();
    assert!(
        !rows.is_empty() && rows.iter().all(|(_, f)| *f > 0.0),
        "{rows:?}"
    );
    let last_stage = rows.iter().map(|(k, _)| *k).max().unwrap();
    let least = rows
        .iter()
        .filter(|(k, _)| *k == last_stage)
        .map(|(_, f)| *f)
        .fold(f64::INFINITY, f64::min);
    assert_eq!(po["force"].as_f64().unwrap().to_bits(), least.to_bits());

    // A tensile pull-off of the same scene is reported as before.
    let ok_out = dir.path().join("tiny");
    let r = djkr(&["run", "tests/sweep/tiny.toml", "--out", s(&ok_out)]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.stdout.contains("  pull-off force   ") && r.stdout.contains("amplification"));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(ok_out.join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["pull_off"]["tensile"], true);
    assert!(summary["pull_off"]["amplification"].as_f64().unwrap() > 0.0);
    assert_eq!(summary["warnings"], serde_json::json!([]));
}

// ---------------------------------------------------------------------------------------------
// Item 10: subnormal radii refused, as for every key.

/// `pulloff --a-amp`, `cycle --a-mean` and `--a-amp` (and the other quantity flags) take no
/// subnormal, of either sign, with the words a key's refusal uses; 0 and normal values still run.
#[test]
fn subnormal_flags_are_refused_as_keys_are() {
    for (args, flag) in [
        (
            vec!["pulloff", "--freq", "400", "--a-amp", "5e-324"],
            "--a-amp = 5e-324",
        ),
        (
            vec![
                "cycle", "--freq", "200", "--a-mean", "1e-310", "--a-amp", "1mm",
            ],
            "--a-mean = 1e-310",
        ),
        (
            vec![
                "cycle", "--freq", "200", "--a-mean", "-1e-310", "--a-amp", "1mm",
            ],
            "--a-mean = -1e-310",
        ),
        (
            vec![
                "cycle", "--freq", "200", "--a-mean", "1mm", "--a-amp", "1e-310",
            ],
            "--a-amp = 1e-310",
        ),
        (
            vec![
                "pulloff",
                "--freq",
                "400",
                "--method",
                "yi",
                "--delta-amp",
                "1e-310",
            ],
            "--delta-amp = 1e-310",
        ),
        (
            vec!["required-speed", "--amplification", "5e-324"],
            "--amplification = 5e-324",
        ),
    ] {
        let r = djkr(&args);
        assert_eq!(r.code, Some(2), "{args:?}: {}", r.stderr);
        assert!(
            r.stderr.contains(flag)
                && r.stderr
                    .contains("is subnormal (below 2.2250738585072014e-308)"),
            "{args:?}: {}",
            r.stderr
        );
    }
    // A key says it in the same words.
    let r = djkr(&[
        "check",
        "tests/sweep/tiny.toml",
        "--set",
        "base.amplitude=1e-310",
    ]);
    assert_eq!(r.code, Some(2));
    assert!(
        r.stderr
            .contains("is subnormal (below 2.2250738585072014e-308): must be 0 or a normal"),
        "{}",
        r.stderr
    );
    // Zero and normal values run.
    for args in [
        vec!["pulloff", "--freq", "400", "--a-amp", "0"],
        vec!["cycle", "--freq", "200", "--a-mean", "0", "--a-amp", "1mm"],
        vec![
            "cycle", "--freq", "200", "--a-mean", "-0.5mm", "--a-amp", "1mm",
        ],
        vec![
            "cycle", "--freq", "200", "--a-mean", "1mm", "--a-amp", "2.3e-308",
        ],
    ] {
        let r = djkr(&args);
        assert_eq!(r.code, Some(0), "{args:?}: {}", r.stderr);
    }
}

// ---------------------------------------------------------------------------------------------
// Issue 33: a run that never detached reports no pull-off.

/// `scenarios/impacts.toml` loses and regains contact every cycle and never detaches. Its summary
/// quoted a pull-off of −0.65 N with amplification 11.26; that force is only the most tensile
/// cycle mean of the run (the third period, during the start-up). The text now says no
/// pull-off, summary.json leaves `pull_off` empty and gives `most_tensile` (no amplification),
/// and cycles.csv confirms the force and its time (the reference).
#[test]
fn a_run_that_never_detached_reports_no_pull_off() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("impacts");
    let r = djkr(&["run", "scenarios/impacts.toml", "--csv", "--out", s(&out)]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(
        r.stdout.contains(
            "  no pull-off        the sphere never detached; most tensile cycle-averaged force "
        ),
        "{}",
        r.stdout
    );
    assert!(!r.stdout.contains("amplification"), "{}", r.stdout);
    assert!(!r.stdout.contains("pull-off force"), "{}", r.stdout);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["detached"], false);
    assert_eq!(summary["pull_off"], serde_json::json!({}));
    assert_eq!(summary["detachment"], serde_json::json!({}));
    assert_eq!(summary["non_finite"], serde_json::json!({}));
    let most = &summary["most_tensile"];
    assert!(most.get("amplification").is_none(), "{most}");
    assert_eq!(most["tensile"], true, "{most}");
    assert!(
        summary["event_counts"].get("pull-off").is_none(),
        "{summary}"
    );
    // The reference: the most tensile force_mean of cycles.csv, at the end of its period.
    let text = std::fs::read_to_string(out.join("cycles.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t_end, mean) = (col("t_end [s]"), col("force_mean [N]"));
    let (t, f) = lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (
                c[t_end].parse::<f64>().unwrap(),
                c[mean].parse::<f64>().unwrap(),
            )
        })
        .fold(
            (f64::NAN, f64::INFINITY),
            |a, b| if b.1 < a.1 { b } else { a },
        );
    assert!(f < 0.0, "a tensile cycle mean: {f}");
    assert_eq!(
        most["force"].as_f64().unwrap().to_bits(),
        f.to_bits(),
        "{most}"
    );
    assert_eq!(
        most["time"].as_f64().unwrap().to_bits(),
        t.to_bits(),
        "{most}"
    );
    assert!(
        r.stdout.contains(&format!("force {:.1} mN", f * 1e3)),
        "{}",
        r.stdout
    );
}
