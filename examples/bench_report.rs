//! The criterion results as a document: every benchmark's median (with its 95 % interval) and
//! the time it was measured, read from `target/criterion/*/new/estimates.json`. Run the benches
//! first, on an idle machine (the medians move with load), then the report:
//!
//!   cargo bench --bench imposed_area   # and dynamics, methods, steady
//!   cargo run --release --example bench_report
//!
//! Writes `docs/studies/benchmarks.md`. The scenes are those of `crate::catalogue`.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use common::{Args, Table};
use std::path::{Path, PathBuf};
use std::time::UNIX_EPOCH;

/// Every `new/benchmark.json` under `dir`.
fn find(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            find(&p, out);
        } else if p.ends_with("new/benchmark.json") {
            out.push(p);
        }
    }
}

fn time(seconds: f64) -> String {
    let (v, unit) = if seconds >= 1.0 {
        (seconds, "s")
    } else if seconds >= 1e-3 {
        (seconds * 1e3, "ms")
    } else if seconds >= 1e-6 {
        (seconds * 1e6, "µs")
    } else {
        (seconds * 1e9, "ns")
    };
    if v >= 100.0 {
        format!("{v:.0} {unit}")
    } else if v >= 10.0 {
        format!("{v:.1} {unit}")
    } else {
        format!("{v:.2} {unit}")
    }
}

/// yyyy-mm-dd hh:mm (UTC) of a file's modification time.
fn stamp(p: &Path) -> String {
    let Some(secs) = std::fs::metadata(p)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
        .map(|d| d.as_secs())
    else {
        return "?".into();
    };
    let date = common::date_of(secs);
    format!("{date} {:02}:{:02}", secs % 86_400 / 3600, secs % 3600 / 60)
}

fn main() {
    let args = Args::parse(
        "bench_report",
        "docs/studies",
        "Criterion medians of every benchmark run so far, as markdown. Writes benchmarks.md.",
    );
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target"));
    let mut files = Vec::new();
    find(&target.join("criterion"), &mut files);
    let mut rows = Vec::new();
    for f in &files {
        let (Ok(b), Ok(e)) = (
            std::fs::read_to_string(f),
            std::fs::read_to_string(f.with_file_name("estimates.json")),
        ) else {
            continue;
        };
        let (Ok(b), Ok(e)) = (
            serde_json::from_str::<serde_json::Value>(&b),
            serde_json::from_str::<serde_json::Value>(&e),
        ) else {
            continue;
        };
        let id = b["full_id"].as_str().unwrap_or("?").to_string();
        let m = &e["median"];
        let ns = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN) * 1e-9;
        rows.push((
            id,
            ns(&m["point_estimate"]),
            ns(&m["confidence_interval"]["lower_bound"]),
            ns(&m["confidence_interval"]["upper_bound"]),
            stamp(&f.with_file_name("estimates.json")),
        ));
    }
    rows.sort_by(|a, b| a.0.cmp(&b.0));
    let mut doc = args.header("Benchmarks: criterion medians");
    doc +=
        "Criterion's median per benchmark with its 95 % interval, and when it was measured (UTC). \
            The load average above is the report's, not the benches': run them on an idle \
            machine. Benches: `benches/*.rs`, timing the scenes of `tests/catalogue/mod.rs`.\n\n";
    let mut t = Table::new(&["benchmark", "median", "95 % interval", "measured"]);
    for (id, med, lo, hi, when) in &rows {
        t.row([
            format!("`{id}`"),
            time(*med),
            format!("{} – {}", time(*lo), time(*hi)),
            when.clone(),
        ]);
    }
    if rows.is_empty() {
        doc += "No results: run `cargo bench` first.\n";
    } else {
        doc += &t.markdown();
    }
    print!("{doc}");
    args.write("benchmarks.md", &doc);
}
