//! Issue 35 (hardening, round 4), the values djkr is given and the numbers it reports: long
//! values quoted to an excerpt (item 5), statistics that are not defined (item 7), a detached
//! run with no tensile pull-off (item 8), subnormal radii refused (item 10). Every child process
//! runs under a deadline; none may panic.

mod tools;

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
