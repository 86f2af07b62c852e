//! The generated chapters of the user guide (issue 27) match what the code generates now.
//!
//! - `docs/guide/cli-reference.md`: `djkr help` and `djkr help COMMAND` for every command (clap).
//! - `docs/guide/output.md`, between its `GENERATED` markers: the column tables of the writers
//!   (name, unit, description), taken from the library's own table builders.
//! - `docs/guide/scenario-reference.md`: `djkr keys --json`, the key table of the scenario parser.
//!
//! `DJKR_BLESS=1 cargo test --release --test docs_reference` rewrites them; without `DJKR_BLESS`
//! a difference fails the test, naming the file, the first differing line and that command.

use djkr::output::table::Field;
use djkr::output::{cycles, timeseries};
use djkr::sweep::KeyColumn;
use std::path::PathBuf;
use std::process::Command;

/// The command that regenerates the generated chapters.
const BLESS: &str = "DJKR_BLESS=1 cargo test --release --test docs_reference";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// One line on the terminal, past the test harness's output capture.
fn say(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

fn bless() -> bool {
    std::env::var_os("DJKR_BLESS").is_some_and(|v| v == "1")
}

/// Compare `generated` with the committed file `rel` (or write it under `DJKR_BLESS=1`).
fn check(rel: &str, generated: &str) {
    let path = root().join(rel);
    if bless() {
        std::fs::write(&path, generated).unwrap_or_else(|e| panic!("{rel}: {e}"));
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed == generated {
        return;
    }
    let (n, old, new) = committed
        .lines()
        .map(Some)
        .chain(std::iter::repeat(None))
        .zip(generated.lines().map(Some).chain(std::iter::repeat(None)))
        .enumerate()
        .find(|(_, (a, b))| a != b)
        .map(|(n, (a, b))| {
            (
                n + 1,
                a.unwrap_or("<end of file>"),
                b.unwrap_or("<end of file>"),
            )
        })
        .unwrap_or((0, "", ""));
    panic!(
        "{rel} is out of date with the code (line {n}):\n  committed: {old}\n  generated: {new}\n\
         Regenerate the generated chapters with `{BLESS}` and commit them."
    );
}

/// `djkr ARGS`, its stdout; `Err` with its stderr when it fails.
fn djkr(args: &[&str]) -> Result<String, String> {
    let out = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .env_remove("COLUMNS")
        .output()
        .expect("djkr runs");
    if out.status.success() {
        Ok(String::from_utf8(out.stdout).expect("UTF-8 help"))
    } else {
        Err(String::from_utf8_lossy(&out.stderr).into_owned())
    }
}

/// The subcommands listed in a clap help text's `Commands:` section (without `help`).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| l.trim() != "Commands:")
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

/// A GitHub-style anchor of a heading.
fn anchor(heading: &str) -> String {
    heading
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The command reference: the help of `djkr` and of every (nested) command.
fn cli_reference() -> String {
    let mut sections = Vec::new();
    let mut todo = vec![Vec::<String>::new()];
    while let Some(path) = todo.pop() {
        let mut args = vec!["help".to_string()];
        args.extend(path.iter().cloned());
        let argv: Vec<&str> = args.iter().map(String::as_str).collect();
        let help = djkr(&argv).unwrap_or_else(|e| panic!("djkr {}: {e}", argv.join(" ")));
        for sub in subcommands(&help).into_iter().rev() {
            let mut p = path.clone();
            p.push(sub);
            todo.push(p);
        }
        sections.push((path, help));
    }
    let mut s = String::from(
        "# Command reference\n\n\
         <!-- GENERATED from `djkr help COMMAND` by `DJKR_BLESS=1 cargo test --release --test \
         docs_reference`; do not edit by hand. -->\n\n\
         Every command's help, as `djkr help COMMAND` prints it. What the commands share (units, \
         the default material, errors, limits, warnings) is in [the command line](commands.md).\n\n",
    );
    for (path, _) in &sections {
        let name = std::iter::once("djkr")
            .chain(path.iter().map(String::as_str))
            .collect::<Vec<_>>()
            .join(" ");
        s.push_str(&format!("- [`{name}`](#{})\n", anchor(&name)));
    }
    for (path, help) in &sections {
        let name = std::iter::once("djkr")
            .chain(path.iter().map(String::as_str))
            .collect::<Vec<_>>()
            .join(" ");
        s.push_str(&format!(
            "\n## {name}\n\n```text\n{}\n```\n",
            help.trim_end()
        ));
    }
    s
}

/// One Markdown table of columns: name, unit, type, description.
fn columns_table(title: &str, intro: &str, fields: &[Field]) -> String {
    let mut s = format!(
        "### {title}\n\n{intro}\n\n| column | unit | type | description |\n|---|---|---|---|\n"
    );
    for f in fields {
        let unit = if f.unit.is_empty() {
            "text".to_string()
        } else {
            format!("`{}`", f.unit)
        };
        s.push_str(&format!(
            "| `{}` | {} | {} | {} |\n",
            f.name,
            unit,
            format!("{:?}", f.kind).to_lowercase(),
            f.description.replace('|', "\\|")
        ));
    }
    s
}

/// The output reference's column tables, from the writers' own table builders.
fn output_columns() -> String {
    let amp = [KeyColumn {
        name: "base.amplitude".into(),
        unit: Some("m".into()),
    }];
    let map = djkr_core::steady::map::ShortcutMap {
        frequencies: Vec::new(),
        amplitudes: Vec::new(),
        cells: Vec::new(),
        cycles: 0,
        wall_s: 0.0,
    };
    let tables = [
        (
            "`run.h5` root datasets, `timeseries.csv`",
            "One row per sample (`djkr run`; `--csv` for the CSV). Header cells are `name [unit]`.",
            timeseries::series_schema(),
        ),
        (
            "`run.h5` `events/`, `events.csv`",
            "One row per event; the state at the event follows the time-series names.",
            timeseries::events_table(&[]).schema(),
        ),
        (
            "`run.h5` `cycles/`, `cycles.csv`",
            "One row per base period under vibration; the harmonic convention is above.",
            cycles::cycle_schema(),
        ),
        (
            "`run.h5` `gaps/`, `gaps.csv`",
            "One row per gap that envelope following left in the time series (see \"Gaps\").",
            timeseries::gaps_table(&[]).schema(),
        ),
        (
            "`sweep.csv`, `sweep.h5`",
            "One row per run of `djkr sweep`; one column per swept key (here `base.amplitude`) \
             after `point` and `member`.",
            djkr::sweep::row::row_schema(&amp),
        ),
        (
            "`points.csv`",
            "One row per point of a sweep: statistics over its ensemble members (here a sweep of \
             `base.amplitude`).",
            djkr::sweep::stats::points_table(&amp, &[]).schema(),
        ),
        (
            "`resonance.csv`, `resonance.h5`",
            "One row per frequency and direction of `djkr resonance`.",
            djkr::reports::steady::sweeps_table(&[]).schema(),
        ),
        (
            "`shortcut-map.csv`, `shortcut-map.h5` `cells/`",
            "One row per cell of `djkr shortcut-map`, row-major in amplitude; NaN where missing.",
            djkr::reports::steady::map_table(&map).schema(),
        ),
        (
            "`continue`: `sweep.csv`",
            "The up and down sweeps overlaid on a branch (here continued in `base.frequency`).",
            djkr::reports::continuation::sweep_table("base.frequency", "Hz", "up", &[]).schema(),
        ),
        (
            "`continue --fold-param`: `fold_curves.csv`",
            "One row per point of a fold curve (here in `base.frequency` and `base.amplitude`).",
            djkr::reports::continuation::fold_table(
                [("base.frequency", "Hz"), ("base.amplitude", "m")],
                &[],
            )
            .schema(),
        ),
    ];
    let branch = example_branch();
    let tables = tables.into_iter().chain([
        (
            "`continue`: `branch.csv`, `branch.h5`",
            "One row per point of the branch of periodic orbits (here continued in \
             `base.frequency`).",
            djkr::reports::continuation::branch_table(&branch).schema(),
        ),
        (
            "`continue`: `bifurcations.csv`",
            "One row per special point of the branch (folds, period doublings, Neimark–Sacker \
             points, ends).",
            djkr::reports::continuation::special_table(&branch).schema(),
        ),
    ]);
    let mut s = String::new();
    for (title, intro, fields) in tables {
        s.push('\n');
        s.push_str(&columns_table(title, intro, &fields));
    }
    s
}

/// A short branch of `scenarios/resonance-400hz.toml` in `base.frequency` (a fraction of a
/// second): the branch tables' columns depend on the parameter, so they come from a real one.
fn example_branch() -> djkr_core::continuation::branch::Branch {
    use djkr::scenario::family::{family, parameter};
    use djkr_core::continuation::branch;
    let source =
        djkr::scenario::parse::ScenarioSource::read(&root().join("scenarios/resonance-400hz.toml"))
            .expect("bundled scenario");
    let param = parameter("--param", "base.frequency").expect("parameter");
    let family = family(&source, &[], vec![param], 1e-10).expect("family");
    branch::continue_branch(
        &family,
        (380.0, 390.0),
        &branch::Settings::default(),
        &mut |_| {},
    )
    .expect("a short branch")
}

/// Replace the text between the `BEGIN GENERATED: name` and `END GENERATED` markers of `doc`.
fn splice(doc: &str, name: &str, generated: &str) -> String {
    let begin = format!("<!-- BEGIN GENERATED: {name} ");
    let start = doc
        .find(&begin)
        .unwrap_or_else(|| panic!("no `{begin}...-->` marker"));
    let after = start + doc[start..].find("-->").expect("marker closes") + 3;
    let end = after
        + doc[after..]
            .find("<!-- END GENERATED -->")
            .expect("END GENERATED marker");
    format!("{}\n{}\n{}", &doc[..after], generated.trim(), &doc[end..])
}

/// The scenario reference from the JSON of `djkr keys --json` (a list of objects with `key`,
/// `unit`, `default`, `range`, `description`), grouped by section.
fn scenario_reference(json: &str) -> String {
    let keys: Vec<serde_json::Value> =
        serde_json::from_str(json).expect("djkr keys --json: a JSON list");
    let mut s = String::from(
        "# Scenario reference\n\n\
         <!-- GENERATED from `djkr keys --json` by `DJKR_BLESS=1 cargo test --release --test \
         docs_reference`; do not edit by hand. -->\n\n\
         Every key the scenario parser and `--set` accept, from the table they use. Units are \
         SI (a value may be written with units, `\"51mm\"`); `—` as default: required, or derived \
         from other keys. How to write a scenario: [writing scenarios](scenarios.md).\n",
    );
    let mut section = String::new();
    for k in &keys {
        let text = |f: &str| {
            k.get(f)
                .and_then(serde_json::Value::as_str)
                .unwrap_or_else(|| panic!("djkr keys --json: {k}: `{f}` is not a string"))
                .replace('|', "\\|")
        };
        let key = text("key");
        let sec = match key.split_once('.') {
            Some((sec, _)) => sec.to_string(),
            None => "top level".to_string(),
        };
        if sec != section {
            section = sec;
            let title = if section == "top level" {
                section.clone()
            } else if section.starts_with("stage") {
                "`[[stage]]`".to_string()
            } else {
                format!("`[{section}]`")
            };
            s.push_str(&format!(
                "\n## {title}\n\n| key | unit | default | range | description |\n|---|---|---|---|---|\n"
            ));
        }
        let unit = text("unit");
        let default = match k.get("default") {
            None | Some(serde_json::Value::Null) => "—".to_string(),
            Some(v) => format!("`{v}`"),
        };
        s.push_str(&format!(
            "| `{key}` | {} | {default} | {} | {} |\n",
            if unit.is_empty() {
                "1".to_string()
            } else {
                format!("`{unit}`")
            },
            text("range"),
            text("description")
        ));
    }
    s
}

#[test]
fn command_reference_is_generated_from_clap() {
    check("docs/guide/cli-reference.md", &cli_reference());
}

#[test]
fn output_column_tables_are_generated_from_the_writers() {
    let rel = "docs/guide/output.md";
    let doc = std::fs::read_to_string(root().join(rel)).expect("output.md");
    check(rel, &splice(&doc, "output columns", &output_columns()));
}

#[test]
fn scenario_reference_is_generated_from_djkr_keys() {
    match djkr(&["keys", "--json"]) {
        Ok(json) => check(
            "docs/guide/scenario-reference.md",
            &scenario_reference(&json),
        ),
        Err(e) if e.contains("unrecognized subcommand") => say(
            "SKIPPED docs/guide/scenario-reference.md (tests/docs_reference.rs): this djkr has no \
             `keys` command yet, so the scenario reference is neither checked nor regenerated",
        ),
        Err(e) => panic!("djkr keys --json failed: {e}"),
    }
}

/// The scenario reference generator on a sample of the `djkr keys --json` contract.
#[test]
fn scenario_reference_renders_the_keys_contract() {
    let json = r#"[
        {"key": "version", "unit": "", "default": null, "range": "1", "description": "format version"},
        {"key": "material.K", "unit": "Pa", "default": null, "range": "> 0", "description": "JKR elastic constant 4E*/3"},
        {"key": "stage[].speed", "unit": "m/s", "default": null, "range": "> 0", "description": "spring-end speed"},
        {"key": "solver.method", "unit": "", "default": "auto", "range": "auto, dp8, implicit, dopri5, dop853", "description": "integrator"},
        {"key": "solver.rtol", "unit": "", "default": 1e-8, "range": "[1e-14, 1e-2]", "description": "relative tolerance"}
    ]"#;
    let s = scenario_reference(json);
    assert!(s.contains("\n## top level\n"), "{s}");
    assert!(
        s.contains("| `material.K` | `Pa` | — | > 0 | JKR elastic constant 4E*/3 |"),
        "{s}"
    );
    assert!(s.contains("\n## `[[stage]]`\n"), "{s}");
    assert!(
        s.contains("| `solver.method` | 1 | `\"auto\"` | auto, dp8, implicit, dopri5, dop853 |"),
        "{s}"
    );
    assert!(s.contains("| `solver.rtol` | 1 | `1e-8` |"), "{s}");
    assert_eq!(s.matches("\n## `[solver]`").count(), 1, "{s}");
}

/// The key paths of a `summary.json` object: top-level keys and the keys of their objects,
/// except the objects keyed by data (quantity names, file roles, event kinds) or listed whole.
fn summary_keys(v: &serde_json::Value) -> Vec<String> {
    const WHOLE: [&str; 7] = [
        "final_state",
        "units",
        "files",
        "file_bytes",
        "event_counts",
        "non_finite",
        "sensitivity",
    ];
    let mut out = Vec::new();
    for (k, v) in v.as_object().expect("summary.json is an object") {
        out.push(k.clone());
        if let (false, Some(o)) = (WHOLE.contains(&k.as_str()), v.as_object()) {
            out.extend(o.keys().map(|c| format!("{k}.{c}")));
        }
    }
    out
}

/// Every key of `summary.json` (of a run that went through and of one stopped by a budget) is
/// named in the output reference, so a key added to the writer without the docs fails here.
#[test]
fn summary_json_keys_are_documented() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("docs-summary-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scenario = root().join("scenarios/paper-protocol-300hz.toml");
    let mut keys = Vec::new();
    for (name, extra) in [("ok", None), ("stopped", Some("solver.max_steps=1000"))] {
        let out = dir.join(name);
        let mut c = Command::new(env!("CARGO_BIN_EXE_djkr"));
        c.arg("run").arg(&scenario).arg("--out").arg(&out);
        if let Some(set) = extra {
            c.args(["--set", set]);
        }
        let status = c.output().expect("djkr runs").status;
        assert!(status.code().is_some(), "djkr run {name}: {status}");
        let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
        let v: serde_json::Value = serde_json::from_str(&text).expect("JSON");
        keys.extend(summary_keys(&v));
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        keys.iter().any(|k| k == "reason"),
        "the stopped run has a reason: {keys:?}"
    );
    let doc = std::fs::read_to_string(root().join("docs/guide/output.md")).expect("output.md");
    let missing: Vec<&String> = keys
        .iter()
        .filter(|k| !doc.contains(&format!("`{k}`")))
        .collect();
    assert!(
        missing.is_empty(),
        "summary.json keys not named in docs/guide/output.md (\"summary.json, key by key\"): \
         {missing:?}"
    );
}
