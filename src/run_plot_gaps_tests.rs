//! Gaps as data (issue 25, item 1): where envelope following skips base periods, the time
//! series says so (`/segment`, `/gaps`, `gaps.csv`, `summary.json` `gaps`), the figure breaks its
//! lines there and shades the spans, and `[output] dense` windows keep every jump out.
//!
//! The scene is the issue's own: the paper protocol at 400 Hz with R = 10 mm, m = 1 g and
//! k = 200 N/m, on which envelope following skips tens of thousands of periods.

use std::path::Path;

use crate::api;
use crate::run_plot::{read_run, run_panels};
use crate::scenario::parse::parse_scenario;
use crate::scenario::Scenario;

/// Base frequency of the scene (Hz).
const F_BASE: f64 = 400.0;

/// The issue's scene with `[output]` as given (`output` is the section's body).
fn scene(output: &str) -> Scenario {
    let text = format!(
        r#"
version = 1
[material]
K = 9.33e6
R = 0.010
w0 = 0.240
[adhesion]
law = "gent-schultz"
v0 = 4.45e-5
n = 0.531
[sphere]
mass = 0.001
gravity = 9.807
[spring]
stiffness = 200.0
[damping]
c = 10.0
on = "sphere"
[base]
amplitude = 10e-6
frequency = {F_BASE}
[initial]
gap = 50e-6
[[stage]]
kind = "approach"
speed = 100e-6
preload = 0.05
max_duration = 10.0
[[stage]]
kind = "hold"
duration = 0.5
vibration = false
[[stage]]
kind = "hold"
duration = 0.5
vibration = true
[[stage]]
kind = "unload"
speed = 5e-6
until = "pull-off"
max_duration = 200.0
[solver]
method = "auto"
rtol = 1e-8
[output]
{output}
"#
    );
    parse_scenario(&text, "issue25-gaps.toml", None).unwrap()
}

/// What a run folder holds about its gaps.
struct Read {
    t: Vec<f64>,
    stage: Vec<i64>,
    segment: Vec<i64>,
    t_start: Vec<f64>,
    t_end: Vec<f64>,
    periods: Vec<i64>,
}

fn read(dir: &Path) -> Read {
    let f = hdf5_pure::File::open(dir.join("run.h5")).unwrap();
    let f64s = |n: &str| f.dataset(n).unwrap().read_f64().unwrap();
    let i64s = |n: &str| f.dataset(n).unwrap().read_i64().unwrap();
    // Every new dataset carries units and a description (its row in /descriptions), as the
    // others do.
    let described = crate::output::test_tools::Descriptions::of(&f);
    for name in ["segment", "gaps/t_start", "gaps/t_end", "gaps/periods"] {
        let attrs = f.dataset(name).unwrap().attrs().unwrap();
        assert!(
            attrs.get("units").and_then(|v| v.as_str()).is_some(),
            "{name}: no units"
        );
        let d = described.get(&format!("/{name}"));
        assert!(d.is_some_and(|t| !t.is_empty()), "{name}: no description");
    }
    Read {
        t: f64s("t"),
        stage: i64s("stage"),
        segment: i64s("segment"),
        t_start: f64s("gaps/t_start"),
        t_end: f64s("gaps/t_end"),
        periods: i64s("gaps/periods"),
    }
}

/// The issue's checks: `/gaps` lists pairs of consecutive samples, `/segment` starts at 0 and
/// steps by one exactly there, and no other interval in a vibrating stage (2, 3) is longer than
/// `limit`.
fn check_gaps(r: &Read, limit: f64) {
    assert!(!r.t_start.is_empty(), "the scene must skip periods");
    assert_eq!(r.segment.len(), r.t.len());
    assert_eq!(r.segment[0], 0);
    let mut k = 0;
    for i in 1..r.t.len() {
        let step = r.segment[i] - r.segment[i - 1];
        assert!(step == 0 || step == 1, "segment steps by {step} at {i}");
        if step == 1 {
            assert_eq!(
                r.t[i - 1].to_bits(),
                r.t_start[k].to_bits(),
                "gap {k} start"
            );
            assert_eq!(r.t[i].to_bits(), r.t_end[k].to_bits(), "gap {k} end");
            assert!(r.periods[k] >= 1, "gap {k}: {} periods", r.periods[k]);
            k += 1;
        } else if r.stage[i - 1] >= 2 && r.stage[i] >= 2 {
            let dt = r.t[i] - r.t[i - 1];
            assert!(
                dt <= limit,
                "an interval of {dt} s at t = {} s is no listed gap (limit {limit} s)",
                r.t[i - 1]
            );
        }
    }
    assert_eq!(
        k,
        r.t_start.len(),
        "every listed gap is where segment steps"
    );
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// No polyline of a time panel (x = t) joins two samples across a gap, and every time panel
/// shades the gaps with the legend the issue names.
fn check_plot(dir: &Path) {
    let s = read_run(&dir.join("run.h5")).unwrap();
    assert!(!s.gaps.is_empty());
    let periods: i64 = s.gaps.iter().map(|g| g.2).sum();
    let panels = run_panels(&s);
    for (i, fig) in panels.iter().enumerate() {
        let time_panel = i % 2 == 0;
        for series in &fig.series {
            if series.style == crate::plot::Style::Band {
                assert_eq!(series.label, format!("envelope: {periods} periods skipped"));
                assert_eq!(series.x.len(), 2 * s.gaps.len());
                continue;
            }
            if !matches!(series.style, crate::plot::Style::Line) || fig.x_label.contains("δ") {
                continue;
            }
            for w in series.x.windows(2) {
                let (a, b) = (w[0], w[1]);
                if a.is_nan() || b.is_nan() {
                    continue;
                }
                for g in &s.gaps {
                    let crosses = if time_panel {
                        a <= g.0 && b >= g.1
                    } else {
                        a < 0.5 * (g.0 + g.1) && b > 0.5 * (g.0 + g.1)
                    };
                    assert!(
                        !crosses,
                        "{}: a line from t = {a} to {b} s crosses the gap {g:?}",
                        fig.title
                    );
                }
            }
        }
        if time_panel {
            assert!(
                fig.series
                    .iter()
                    .any(|x| x.style == crate::plot::Style::Band),
                "{}: no shaded gaps",
                fig.title
            );
        }
    }
}

#[test]
fn gaps_on_a_sample_grid_are_listed_and_segments_step_there() {
    // 12 kHz: 1 M samples, the streamed writer.
    let scn = scene("sample_rate = 12000\ncsv = true");
    let dir = tempfile::tempdir().unwrap();
    let rec = api::run(&scn, Some(dir.path())).unwrap();
    assert!(rec.result.envelope.periods_skipped > 0);
    let r = read(dir.path());
    check_gaps(&r, 1.5 / 12000.0);
    let total: i64 = r.periods.iter().sum();
    assert!(total as u64 <= rec.result.envelope.periods_skipped);
    // summary.json and gaps.csv say the same.
    assert_eq!(summary(dir.path())["gaps"], r.t_start.len());
    let csv = std::fs::read_to_string(dir.path().join("gaps.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("t_start [s],t_end [s],periods [1]"));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), r.t_start.len());
    let first: Vec<f64> = rows[0].split(',').map(|v| v.parse().unwrap()).collect();
    assert_eq!(first, vec![r.t_start[0], r.t_end[0], r.periods[0] as f64]);
    let header = std::fs::read_to_string(dir.path().join("timeseries.csv")).unwrap();
    assert!(header
        .lines()
        .next()
        .unwrap()
        .ends_with(",stage [1],segment [1]"));
    // The run kept in memory (Python's Run) has the same segments and gaps.
    let seg = rec.series.column("segment").unwrap().data.as_i64().unwrap();
    assert_eq!(seg, &r.segment[..]);
    let t_end = rec.gaps.column("t_end").unwrap().data.as_f64().unwrap();
    assert_eq!(t_end, &r.t_end[..]);
    check_plot(dir.path());
}

#[test]
fn gaps_of_per_step_output_written_whole_or_streamed() {
    // Every step a sample (about 10^5 of them: streamed), and a coarse grid of 200 per second
    // (1.7 10^4 samples: written whole at the end).
    for (output, limit) in [
        ("sample_rate = 0", 2.0 / F_BASE),
        ("sample_rate = 200", 1.5 / 200.0),
    ] {
        let scn = scene(output);
        let dir = tempfile::tempdir().unwrap();
        api::run(&scn, Some(dir.path())).unwrap();
        let r = read(dir.path());
        check_gaps(&r, limit);
        assert_eq!(summary(dir.path())["gaps"], r.t_start.len(), "{output}");
        check_plot(dir.path());
    }
}

#[test]
fn dense_windows_contain_no_gap() {
    let windows = [[4.0, 6.0], [20.0, 21.0]];
    let scn = scene("sample_rate = 12000\ndense = [[20.0, 21.0], [4.0, 5.0], [4.5, \"6s\"]]");
    assert_eq!(scn.output.dense, windows.to_vec(), "sorted and merged");
    let dir = tempfile::tempdir().unwrap();
    api::run(&scn, Some(dir.path())).unwrap();
    let r = read(dir.path());
    check_gaps(&r, 1.5 / 12000.0);
    for (a, b) in r.t_start.iter().zip(&r.t_end) {
        for [t0, t1] in windows {
            assert!(
                *b <= t0 || *a >= t1,
                "the gap ({a}, {b}) s reaches into the dense window [{t0}, {t1}] s"
            );
        }
    }
    // Without the windows, the scene does skip periods inside them.
    let plain = read_gaps_of(&scene("sample_rate = 12000"));
    assert!(plain
        .iter()
        .any(|(a, b)| windows.iter().any(|[t0, t1]| b > t0 && a < t1)));
}

fn read_gaps_of(scn: &Scenario) -> Vec<(f64, f64)> {
    let dir = tempfile::tempdir().unwrap();
    api::run(scn, Some(dir.path())).unwrap();
    let r = read(dir.path());
    r.t_start.into_iter().zip(r.t_end).collect()
}

#[test]
fn dense_windows_are_validated_naming_the_key() {
    for (value, needle) in [
        ("[[2.0, 1.0]]", "output.dense[0]"),
        ("[[1.0, 2.0], [3.0]]", "output.dense[1]"),
        ("[[1.0, nan]]", "output.dense[0]"),
        ("[[1.0, \"2 parsecs\"]]", "output.dense[0]"),
        ("1.0", "output.dense"),
    ] {
        let text = format!(
            "version = 1\n[material]\nK = 1e6\nR = 0.01\nw0 = 0.1\n[sphere]\nmass = 0.001\n\
             [spring]\nstiffness = 100\n[initial]\ngap = 1e-5\n[[stage]]\nkind = \"hold\"\nduration = 1\n\
             [output]\ndense = {value}\n"
        );
        let e = parse_scenario(&text, "x.toml", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{value}: {e}");
        assert!(e.contains("t0 < t1") || e.contains("unit"), "{value}: {e}");
    }
    let many = format!(
        "version = 1\n[material]\nK = 1e6\nR = 0.01\nw0 = 0.1\n[sphere]\nmass = 0.001\n\
         [spring]\nstiffness = 100\n[initial]\ngap = 1e-5\n[[stage]]\nkind = \"hold\"\nduration = 1\n\
         [output]\ndense = [{}]\n",
        (0..10_001)
            .map(|i| format!("[{i}, {}.5]", i))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let e = parse_scenario(&many, "x.toml", None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("at most 10000 windows"), "{e}");
}

#[test]
fn a_run_without_gaps_has_segment_zero_and_an_empty_gaps_group() {
    let mut scn = scene("sample_rate = 2000");
    scn.solver.envelope = djkr_core::dynamics::EnvelopeMode::Off;
    scn.stages[3].max_duration = 2.0;
    scn.stages[3].until = djkr_core::dynamics::protocol::Until::Duration(2.0);
    let dir = tempfile::tempdir().unwrap();
    api::run(&scn, Some(dir.path())).unwrap();
    let f = hdf5_pure::File::open(dir.path().join("run.h5")).unwrap();
    let seg = f.dataset("segment").unwrap().read_i64().unwrap();
    assert!(!seg.is_empty() && seg.iter().all(|s| *s == 0));
    assert!(f
        .dataset("gaps/t_start")
        .unwrap()
        .read_f64()
        .unwrap()
        .is_empty());
    assert_eq!(summary(dir.path())["gaps"], 0);
}
