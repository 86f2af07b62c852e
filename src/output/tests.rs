//! Output writers: a synthetic run (samples and events made up here, no simulator) written by
//! `RunWriter`, read back with hdf5-pure's reader, with h5py (`tests/h5read.py`) and with h5dump
//! when installed, and compared bit-exactly; summary.json and CSV parsed back; atomic behaviour.
//!
//! h5py and h5dump: the system's when present; otherwise, only with `DJKR_TEST_INSTALL=1`, h5py
//! from the package index into a venv under the target directory and h5dump from Debian's
//! `hdf5-tools` (module `tools`). Without them the cross-checks are skipped with one line each.

use crate::output::test_tools as tools;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use super::folder::MANIFEST_NAME;
use super::hdf5_file::{hdf5_bytes, read_descriptions, RunTables};
use super::names::{FLUSH_ROWS, LOCK_NAME, SPILL_ROWS};
use super::timeseries::{events_table, gaps_table, SERIES};
use super::{cycles::cycle_table, OutputError, RunWriter, TimeSeriesWriter};
use crate::scenario::parse::parse_scenario;
use crate::scenario::Scenario;
use djkr_core::dynamics::{
    CycleRecord, Event, EventCounts, EventKind, Gap, Observer, PullOffSummary, RunResult, Sample,
    Stats,
};
use serde_json::Value;

const SCENARIO: &str = r#"# a scenario for the writer tests
version = 1
[material]
K = 9.33e6
R = 0.051
w0 = 0.240
[sphere]
mass = 3e-3
[spring]
stiffness = 200.0
[base]
amplitude = 10e-6
frequency = 300.0
[initial]
preload = 0.02
[[stage]]
kind = "hold"
duration = 0.1
vibration = true
[[stage]]
kind = "unload"
speed = 5e-6
until = "pull-off"
"#;

fn scenario() -> Scenario {
    parse_scenario(SCENARIO, "tests/synthetic \"run\".toml", None).unwrap()
}

/// Deterministic values with awkward bit patterns: irrationals, tiny and huge magnitudes, -0.0
/// and subnormals.
fn value(i: usize, col: usize) -> f64 {
    let x = (i as f64 * 0.618_033_988_749_894_9 + col as f64 * 0.414_213_562_373_095_1).sin();
    match (i + col) % 97 {
        0 => -0.0,
        1 => 5e-324,
        2 => 1e-300 * x,
        3 => 1.7e300 * x,
        _ => x * 10f64.powi((col as i32 % 7) - 6),
    }
}

fn sample(i: usize) -> Sample {
    Sample {
        t: i as f64 * 1.234_567_890_123e-5,
        x_s: value(i, 1),
        v_s: value(i, 2),
        x_b: value(i, 3),
        x_k: value(i, 4),
        delta: value(i, 5),
        a: value(i, 6).abs(),
        a_dot: value(i, 7),
        force: value(i, 8),
        g: value(i, 9),
        w: value(i, 10).abs() + 0.24,
        stage: if i < 1000 { 0 } else { 1 },
    }
}

/// Six events spread over a run of `n` samples.
fn events(n: usize) -> Vec<Event> {
    let kinds = [
        EventKind::StageStart,
        EventKind::ContactLoss,
        EventKind::Impact,
        EventKind::DurationElapsed,
        EventKind::StageStart,
        EventKind::PullOff,
    ];
    kinds
        .iter()
        .enumerate()
        .map(|(j, &kind)| {
            let s = sample(j * (n / 6).max(1) + 7);
            Event {
                kind,
                time: s.t,
                stage: s.stage,
                state: s,
            }
        })
        .collect()
}

fn result(events: Vec<Event>, final_state: Sample) -> RunResult {
    RunResult {
        pull_off: PullOffSummary {
            force: -0.098_765_432_1,
            amplification: 1.712_345_678_9,
            time: 12.345_678_901,
        },
        detached: true,
        stats: Stats {
            steps: 123_456,
            rejected: 789,
            rhs_evals: 987_654,
            wall_s: 1.25,
        },
        method: "dopri5 (auto: \"no stiffness\")".to_string(),
        final_state,
        event_counts: {
            let mut c = EventCounts::default();
            for e in &events {
                c.add(e.kind);
            }
            c
        },
        events,
        cycle_count: 3,
        last_cycle: Some(cycle(2)),
        max_contact_radius: final_state.a,
        envelope: Default::default(),
        detachment_time: 13.579_246_8,
        approach_roughness: 2.5e-6,
        approach_zero_means: 0,
    }
}

/// The three period records of the synthetic run.
fn cycles() -> Vec<CycleRecord> {
    (0..3).map(cycle).collect()
}

fn cycle(i: u64) -> CycleRecord {
    let v = |c: usize| value(i as usize + 11, c);
    CycleRecord {
        index: i,
        stage: 1,
        t_start: i as f64 / 300.0,
        t_end: (i + 1) as f64 / 300.0,
        force_mean: v(1),
        force_sin: v(2),
        force_cos: v(3),
        delta_mean: v(4),
        delta_sin: v(5),
        delta_cos: v(6),
        a_mean: v(7),
        a_sin: v(8),
        a_cos: v(9),
        x_s_mean: v(10),
        x_k_mean: v(11),
        spring_mean: v(12),
        spring_sin: v(13),
        spring_cos: v(14),
        work_base: v(15),
        work_holder: v(16),
        dissipation_damping: v(17),
        dissipation_adhesion: v(18),
        energy_start: v(19),
        energy_end: v(20),
    }
}

// Several 32768-element chunks, the last one partial; 65536 and more is where hdf5-pure 0.47 once
// wrote chunk dimensions libhdf5 could not read. Below SPILL_ROWS: written at the end.
const N: usize = 70_000;
// Long enough to be streamed: the first spill, two appends and a partial last batch.
const N_STREAMED: usize = SPILL_ROWS + 2 * FLUSH_ROWS + 12_345;

/// Write the synthetic run of `n` samples into `dir`; returns the samples and the result.
fn write_run(dir: &Path, csv: bool, n: usize) -> (Vec<Sample>, RunResult) {
    let (samples, res, _) = write_run_with_id(dir, csv, n);
    (samples, res)
}

/// As [`write_run`], also returning the run id.
fn write_run_with_id(dir: &Path, csv: bool, n: usize) -> (Vec<Sample>, RunResult, String) {
    let scn = scenario();
    let mut w = RunWriter::create(dir, &scn, csv).unwrap();
    let run_id = w.run_id().to_string();
    let samples: Vec<Sample> = (0..n).map(sample).collect();
    let evs = events(n);
    let cyc = cycles();
    // A streamed run gets its first period record after the first spill (the period datasets
    // are created then) and the next ones in later batches.
    let cycle_at = if n >= SPILL_ROWS {
        [n - 2 * FLUSH_ROWS - 10, n - FLUSH_ROWS - 10, n - 1]
    } else {
        [
            n.saturating_sub(3),
            n.saturating_sub(2),
            n.saturating_sub(1),
        ]
    };
    let mut next_event = 0;
    for (i, s) in samples.iter().enumerate() {
        if let Some(g) = gap_before(&samples, i) {
            w.gap(&g);
        }
        while next_event < evs.len() && evs[next_event].time <= s.t {
            w.event(&evs[next_event]);
            next_event += 1;
        }
        if let Some(k) = cycle_at.iter().position(|&j| j == i) {
            w.cycle(&cyc[k]);
        }
        assert!(w.sample(s));
    }
    assert_eq!(w.is_streaming(), n >= SPILL_ROWS);
    let final_state = samples.last().copied().unwrap_or(sample(0));
    let res = result(evs, final_state);
    let paths = w.finish(&res).unwrap();
    assert_eq!(paths.hdf5, dir.join("run.h5"));
    assert_eq!(paths.summary, dir.join("summary.json"));
    assert_eq!(paths.timeseries_csv.is_some(), csv);
    (samples, res, run_id)
}

/// The gap the synthetic runs of [`write_run`] have before sample `i`: before the samples at
/// a third and at two thirds of a run of 3 or more (in different batches of a streamed one).
fn gap_before(samples: &[Sample], i: usize) -> Option<Gap> {
    let n = samples.len();
    (n >= 3 && (i == n / 3 || i == 2 * n / 3)).then(|| Gap {
        t_start: samples[i - 1].t,
        t_end: samples[i].t,
        periods: 7 + i as u64,
    })
}

/// The files in `dir`, but the lock file and the record of its files every run writer leaves.
fn names_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != LOCK_NAME && n != MANIFEST_NAME)
        .collect();
    v.sort();
    v
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn expected_column(samples: &[Sample], name: &str) -> Vec<f64> {
    let def = SERIES.iter().find(|c| c.name == name).unwrap();
    samples.iter().map(|s| def.value(s)).collect()
}

#[test]
fn hdf5_reads_back_bit_exactly_with_hdf5_pure() {
    check_with_hdf5_pure(N);
}

#[test]
fn streamed_hdf5_reads_back_bit_exactly_with_hdf5_pure() {
    check_with_hdf5_pure(N_STREAMED);
}

fn check_with_hdf5_pure(n: usize) {
    let dir = tempfile::tempdir().unwrap();
    let (samples, res) = write_run(dir.path(), false, n);
    assert_eq!(names_in(dir.path()), vec!["run.h5", "summary.json"]);

    let f = hdf5_pure::File::open(dir.path().join("run.h5")).unwrap();
    let expected_units = [
        ("t", "s"),
        ("x_s", "m"),
        ("v_s", "m/s"),
        ("x_b", "m"),
        ("x_k", "m"),
        ("delta", "m"),
        ("a", "m"),
        ("a_dot", "m/s"),
        ("F", "N"),
        ("G", "J/m^2"),
        ("w", "J/m^2"),
    ];
    for (name, unit) in expected_units {
        let ds = f.dataset(name).unwrap();
        assert_eq!(ds.shape().unwrap(), vec![n as u64], "{name}");
        let got = ds.read_f64().unwrap();
        assert_eq!(bits(&got), bits(&expected_column(&samples, name)), "{name}");
        let attrs = ds.attrs().unwrap();
        assert_eq!(attrs["units"].as_str(), Some(unit), "{name}");
    }
    // Every dataset and group has its row in /descriptions; a period record is defined, not
    // named (it used to repeat its name: `a_cos` → 'a_cos').
    let d = read_descriptions(&f).unwrap();
    for name in f.root().datasets().unwrap() {
        assert!(
            d.get(&format!("/{name}")).is_some_and(|t| !t.is_empty()),
            "{name}"
        );
    }
    for g in f.root().groups().unwrap() {
        assert!(d.get(&format!("/{g}")).is_some(), "/{g}");
        for name in f.group(&g).unwrap().datasets().unwrap() {
            let text = d.get(&format!("/{g}/{name}")).unwrap_or_default();
            assert!(text.len() > name.len() + 10, "/{g}/{name}: {text:?}");
        }
    }
    assert!(d.get("/cycles/a_cos").unwrap().contains("cos theta"));
    let harmonics = f.root().attrs().unwrap()["harmonics"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(harmonics.contains("x_b = X_b sin theta"), "{harmonics}");
    let stage = f.dataset("stage").unwrap().read_i64().unwrap();
    let want: Vec<i64> = samples.iter().map(|s| s.stage as i64).collect();
    assert_eq!(stage, want);

    let root = f.root().attrs().unwrap();
    assert_eq!(root["scenario"].as_str(), Some(SCENARIO));
    assert_eq!(
        root["source"].as_str(),
        Some("tests/synthetic \"run\".toml")
    );
    assert_eq!(
        root["djkr_version"].as_str(),
        Some(env!("CARGO_PKG_VERSION"))
    );
    assert_eq!(root["method"].as_str(), Some(res.method.as_str()));
    assert_eq!(root["detached"].as_i64(), Some(1));
    assert_eq!(
        root["pull_off_force"].as_f64().map(f64::to_bits),
        Some(res.pull_off.force.to_bits())
    );
    assert_eq!(root["steps"].as_u64(), Some(123_456));

    let ev = res.events;
    let kinds = f.dataset("events/kind").unwrap().read_string().unwrap();
    assert_eq!(
        kinds,
        vec![
            "stage-start",
            "contact-loss",
            "impact",
            "duration-elapsed",
            "stage-start",
            "pull-off"
        ]
    );
    let times = f.dataset("events/time").unwrap().read_f64().unwrap();
    assert_eq!(
        bits(&times),
        bits(&ev.iter().map(|e| e.time).collect::<Vec<_>>())
    );
    let forces = f.dataset("events/F").unwrap().read_f64().unwrap();
    assert_eq!(
        bits(&forces),
        bits(&ev.iter().map(|e| e.state.force).collect::<Vec<_>>())
    );
    let st = f.dataset("events/stage").unwrap().read_i64().unwrap();
    assert_eq!(st, ev.iter().map(|e| e.stage as i64).collect::<Vec<_>>());

    let fm = f.dataset("cycles/force_mean").unwrap();
    assert_eq!(
        bits(&fm.read_f64().unwrap()),
        bits(&cycles().iter().map(|c| c.force_mean).collect::<Vec<_>>())
    );
    assert_eq!(fm.attrs().unwrap()["units"].as_str(), Some("N"));
    let idx = f.dataset("cycles/index").unwrap().read_i64().unwrap();
    assert_eq!(idx, vec![0, 1, 2]);
    let e_end = f.dataset("cycles/energy_end").unwrap();
    assert_eq!(e_end.attrs().unwrap()["units"].as_str(), Some("J"));
}

/// A Python interpreter that can import h5py: the system `python3` if it can; otherwise a venv
/// under the target directory (module `tools`: made from the package index only with
/// `DJKR_TEST_INSTALL=1`). `None` when there is none: the h5py cross-checks are skipped, with one
/// line saying so (a failure when installing was allowed).
fn h5py_python() -> Option<PathBuf> {
    static PYTHON: OnceLock<Option<PathBuf>> = OnceLock::new();
    PYTHON
        .get_or_init(|| {
            let system = PathBuf::from("python3");
            if tools::runs(&system, "import h5py, numpy") {
                return Some(system);
            }
            match tools::venv("h5py-venv", &["h5py", "numpy"], &["h5py", "numpy"]) {
                Ok(py) => Some(py),
                Err(why) => {
                    tools::skip_or_fail("the h5py cross-checks of src/output/tests.rs", &why);
                    None
                }
            }
        })
        .clone()
}

/// Runs tests/h5read.py with an h5py-capable Python; `None` when none could be provided outside CI.
fn h5py_dump(path: &Path) -> Option<Value> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/h5read.py");
    let py = h5py_python()?;
    let o = Command::new(&py)
        .arg(&script)
        .arg(path)
        .output()
        .unwrap_or_else(|e| panic!("{} not runnable: {e}", py.display()));
    assert!(
        o.status.success(),
        "h5read.py failed ({}): {}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    Some(serde_json::from_slice(&o.stdout).unwrap())
}

fn json_bits(v: &Value) -> Vec<u64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect()
}

#[test]
fn hdf5_reads_back_bit_exactly_with_h5py() {
    check_with_h5py(N);
}

#[test]
fn streamed_hdf5_reads_back_bit_exactly_with_h5py() {
    check_with_h5py(N_STREAMED);
}

/// A run stopped by a budget publishes files that h5py opens (issue 24, defect 3): written whole
/// (a short run) and streamed (past [`SPILL_ROWS`] samples), every dataset read whole, the time
/// series as long as summary.json's `samples`, and `"status": "stopped"`.
#[test]
fn a_stopped_run_opens_in_h5py() {
    let Some(py) = h5py_python() else {
        eprintln!("skipped a_stopped_run_opens_in_h5py: no Python with h5py");
        return;
    };
    for max_steps in [2_000u64, (SPILL_ROWS + FLUSH_ROWS / 2) as u64] {
        let dir = tempfile::tempdir().unwrap();
        let mut scn = scenario();
        scn.stages[0].until = djkr_core::dynamics::protocol::Until::Duration(1e3);
        scn.solver.max_steps = max_steps;
        scn.solver.envelope = djkr_core::dynamics::EnvelopeMode::Off;
        scn.output.sample_rate = 0.0;
        let mut w = RunWriter::create(dir.path(), &scn, true).unwrap();
        let outcome = scn.simulate_partial(&mut w).unwrap();
        let ending = outcome.ending();
        assert_eq!(ending.reason, Some(djkr_core::dynamics::Reason::MaxSteps));
        assert_eq!(w.is_streaming(), max_steps as usize > SPILL_ROWS);
        let paths = w.finish_with(&outcome.result, &ending).unwrap();
        let summary: Value = serde_json::from_str(&paths.summary_text).unwrap();
        assert_eq!(summary["status"], "stopped");
        assert_eq!(summary["reason"], "max_steps");
        let script = "import h5py, json, sys\n\
                      n = {}\n\
                      with h5py.File(sys.argv[1], 'r') as f:\n\
                      \tf.visititems(lambda k, v: n.__setitem__(k, len(v[()])) \
                      if isinstance(v, h5py.Dataset) and v.shape else None)\n\
                      print(json.dumps(n))";
        let o = Command::new(&py)
            .args(["-c", script])
            .arg(dir.path().join("run.h5"))
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "h5py cannot read the stopped run's file: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let lens: Value = serde_json::from_slice(&o.stdout).unwrap();
        let samples = summary["samples"].as_u64().unwrap();
        assert!(samples > 1000, "{samples}");
        assert_eq!(lens["t"].as_u64(), Some(samples), "{lens}");
        assert_eq!(lens["stage"].as_u64(), Some(samples), "{lens}");
    }
}

/// The bytes of a file that are not dataset storage: its size less h5py's `get_storage_size()`
/// of every dataset (headers, chunk indices, global heaps, free space), and the number of
/// `units` attributes in it, each of which must read as `str` (h5py gives `bytes` for a
/// fixed-length string). `None` when h5py is not available (skipped).
fn overhead_and_units(path: &Path) -> Option<(u64, usize)> {
    let dump = h5py_dump(path)?;
    let size = std::fs::metadata(path).unwrap().len();
    let mut storage = 0;
    let mut units = 0;
    let mut attr_sets: Vec<(String, &Value)> = vec![("/".into(), &dump["attrs"])];
    for (name, a) in dump["group_attrs"].as_object().into_iter().flatten() {
        attr_sets.push((name.clone(), a));
    }
    for (name, d) in dump["datasets"].as_object().unwrap() {
        storage += d["storage_size"].as_u64().unwrap();
        attr_sets.push((name.clone(), &d["attrs"]));
    }
    for (name, attrs) in attr_sets {
        if let Some(u) = attrs.get("units") {
            assert!(u["str"].is_string(), "{name}: units read as {u}, not str");
            units += 1;
        }
    }
    assert!(storage > 0 && storage < size, "{storage} of {size} bytes");
    Some((size - storage, units))
}

/// Issue 25, "Compact files": the `run.h5` of the 1 s hold at 400 Hz
/// (`docs/accuracy/hold-400hz-1s.toml`, 6319 samples, 400 period records) has at most 200 kB
/// that are not dataset storage (275 kB with hdf5-pure 0.47 as released, which gave each
/// variable-length string attribute a 4 KiB heap collection of its own; 28 kB when libhdf5
/// writes the same content), and each of its datasets has a `units` attribute that h5py reads
/// as `str`.
#[test]
fn a_one_second_run_file_is_compact_and_its_units_read_as_str() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("hold");
    let scn = crate::load_scenario(&root.join("docs/accuracy/hold-400hz-1s.toml")).unwrap();
    crate::api::run(&scn, Some(&out)).unwrap();
    let Some((overhead, units)) = overhead_and_units(&out.join("run.h5")) else {
        return;
    };
    // Every dataset carries units (the description table's two columns the empty ones).
    let dump = h5py_dump(&out.join("run.h5")).unwrap();
    let datasets = dump["datasets"].as_object().unwrap().len();
    assert!(datasets > 50, "{datasets} datasets");
    assert_eq!(units, datasets);
    eprintln!("run.h5 of the 1 s hold: {overhead} bytes are not dataset storage");
    assert!(
        overhead <= 200_000,
        "{overhead} bytes of run.h5 are not dataset storage"
    );
}

/// A text attribute longer than a shared 4 KiB heap collection (the scenario's text, here with a
/// 12 kB comment of two- and three-byte characters) gets a collection of its own and reads back
/// whole in h5py, next to the `units` packed in the shared ones.
#[test]
fn a_scenario_text_longer_than_a_heap_collection_reads_back_whole() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root.join("docs/accuracy/hold-400hz-1s.toml")).unwrap();
    let long = format!("# {}\n{text}", "é 中 ".repeat(2000));
    assert!(long.len() > 12_000);
    let file = dir.path().join("long.toml");
    std::fs::write(&file, &long).unwrap();
    let out = dir.path().join("long");
    let scn = crate::load_scenario(&file).unwrap();
    crate::api::run(&scn, Some(&out)).unwrap();
    let Some((_, units)) = overhead_and_units(&out.join("run.h5")) else {
        return;
    };
    assert!(units > 50, "{units}");
    let dump = h5py_dump(&out.join("run.h5")).unwrap();
    assert_eq!(dump["attrs"]["scenario"]["str"], long.as_str());
}

/// The same bound for a streamed file (datasets created empty and extended, the period records
/// and gaps added to the open file): its bytes that are not dataset storage stay under 200 kB,
/// and every `units` attribute reads as `str`.
#[test]
fn a_streamed_run_file_is_compact() {
    let dir = tempfile::tempdir().unwrap();
    write_run(dir.path(), false, N_STREAMED);
    let Some((overhead, units)) = overhead_and_units(&dir.path().join("run.h5")) else {
        return;
    };
    assert!(units > 40, "{units} units attributes");
    eprintln!("streamed run.h5: {overhead} bytes are not dataset storage");
    assert!(
        overhead <= 200_000,
        "{overhead} bytes of the streamed run.h5 are not dataset storage"
    );
}

fn check_with_h5py(n: usize) {
    let dir = tempfile::tempdir().unwrap();
    let (samples, res) = write_run(dir.path(), false, n);
    let Some(dump) = h5py_dump(&dir.path().join("run.h5")) else {
        return;
    };
    let ds = &dump["datasets"];
    for def in SERIES.iter() {
        let d = &ds[format!("/{}", def.name)];
        assert_eq!(d["dtype"], "float64", "{}", def.name);
        assert_eq!(d["shape"], serde_json::json!([n]));
        assert_eq!(
            json_bits(&d["f64_bits"]),
            bits(&expected_column(&samples, def.name)),
            "{}",
            def.name
        );
        // Units must come back as str (variable-length UTF-8), not bytes.
        assert_eq!(d["attrs"]["units"]["str"], def.unit, "{}", def.name);
    }
    let stage: Vec<i64> = ds["/stage"]["int"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_i64().unwrap())
        .collect();
    assert_eq!(
        stage,
        samples.iter().map(|s| s.stage as i64).collect::<Vec<_>>()
    );
    assert_eq!(dump["attrs"]["scenario"]["str"], SCENARIO);
    assert_eq!(
        dump["attrs"]["source"]["str"],
        "tests/synthetic \"run\".toml"
    );
    assert_eq!(
        dump["attrs"]["pull_off_amplification"]["f64_bits"].as_u64(),
        Some(res.pull_off.amplification.to_bits())
    );
    assert_eq!(
        dump["groups"],
        serde_json::json!(["/cycles", "/descriptions", "/events", "/gaps"])
    );
    // Every `units` attribute reads as str (h5py gives bytes for a fixed-length string), and
    // every dataset is described in /descriptions (h5py needs `.asstr()` on string datasets).
    let described: Vec<&str> = ds["/descriptions/path"]["str"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap())
        .collect();
    for (path, d) in ds.as_object().unwrap() {
        assert!(d["attrs"]["units"]["str"].is_string(), "{path}: {d:?}");
        assert!(described.contains(&path.as_str()), "{path} not described");
    }
    // The gaps: their datasets with units as str, and the segment stepping after each.
    let gaps: Vec<Gap> = (0..n).filter_map(|i| gap_before(&samples, i)).collect();
    assert_eq!(
        json_bits(&ds["/gaps/t_end"]["f64_bits"]),
        bits(&gaps.iter().map(|g| g.t_end).collect::<Vec<_>>())
    );
    assert_eq!(ds["/gaps/t_start"]["attrs"]["units"]["str"], "s");
    assert_eq!(ds["/gaps/periods"]["attrs"]["units"]["str"], "1");
    assert_eq!(ds["/segment"]["attrs"]["units"]["str"], "1");
    let segment = ds["/segment"]["int"].as_array().unwrap();
    assert_eq!(segment.len(), n);
    assert_eq!(segment[n - 1].as_i64(), Some(gaps.len() as i64));
    assert_eq!(
        json_bits(&ds["/cycles/a_sin"]["f64_bits"]),
        bits(&cycles().iter().map(|c| c.a_sin).collect::<Vec<_>>())
    );
    assert_eq!(ds["/cycles/a_sin"]["attrs"]["units"]["str"], "m");
    assert_eq!(ds["/cycles/stage"]["int"], serde_json::json!([1, 1, 1]));
    let kinds: Vec<&str> = ds["/events/kind"]["str"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| k.as_str().unwrap())
        .collect();
    assert_eq!(kinds[2], "impact");
    assert_eq!(kinds.len(), res.events.len());
    assert_eq!(
        json_bits(&ds["/events/delta"]["f64_bits"]),
        bits(&res.events.iter().map(|e| e.state.delta).collect::<Vec<_>>())
    );
}

/// A streamed run file holds what the file written at once from the same rows holds: every
/// attribute, dataset, unit and value (h5py's view; chunking and compression aside); so do the
/// CSV files.
#[test]
fn streamed_file_has_the_content_of_the_file_written_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let (samples, res, run_id) = write_run_with_id(dir.path(), true, N_STREAMED);
    let mut series = TimeSeriesWriter::new();
    for (i, s) in samples.iter().enumerate() {
        if let Some(g) = gap_before(&samples, i) {
            series.gap(&g);
        }
        series.push(s);
    }
    let gaps = gaps_table(series.gaps());
    assert_eq!(gaps.rows(), 2);
    let tables = RunTables {
        series: series.table(),
        events: &events_table(&res.events),
        cycles: &cycle_table(&cycles()),
        gaps: &gaps,
    };
    // The streamed CSV files are those written at once, byte for byte.
    for (name, table) in [
        ("timeseries.csv", tables.series),
        ("events.csv", tables.events),
        ("cycles.csv", tables.cycles),
        ("gaps.csv", tables.gaps),
    ] {
        let text = std::fs::read_to_string(dir.path().join(name)).unwrap();
        assert!(text == table.to_csv(), "{name} differs");
    }
    let whole = hdf5_bytes(tables, &scenario(), &run_id, &res, false).unwrap();
    let whole_path = dir.path().join("whole.h5");
    std::fs::write(&whole_path, whole).unwrap();
    let layout_free = |mut v: Value| {
        for d in v["datasets"].as_object_mut().unwrap().values_mut() {
            let d = d.as_object_mut().unwrap();
            d.remove("chunks");
            d.remove("compression");
            d.remove("storage_size");
        }
        v
    };
    let Some(streamed) = h5py_dump(&dir.path().join("run.h5")) else {
        return;
    };
    let whole = h5py_dump(&whole_path).unwrap();
    assert_eq!(
        streamed["datasets"]["/t"]["chunks"],
        serde_json::json!([32768])
    );
    assert_eq!(layout_free(streamed), layout_free(whole));
}

#[test]
fn h5dump_reads_the_file_when_installed() {
    let dir = tempfile::tempdir().unwrap();
    let (samples, _) = write_run(dir.path(), false, 100);
    let file = dir.path().join("run.h5");
    // Whole-file walk (all groups, attributes and data) must succeed ...
    if !tools::have("h5dump") {
        if let Err(why) = tools::apt_install(&["hdf5-tools"]) {
            tools::skipped(
                "the h5dump check of src/output/tests.rs",
                &format!("h5dump (Debian: hdf5-tools) is not installed; {why}"),
            );
            return;
        }
    }
    let all = Command::new("h5dump")
        .arg(&file)
        .output()
        .expect("h5dump runs");
    assert!(
        all.status.success(),
        "h5dump failed: {}",
        String::from_utf8_lossy(&all.stderr)
    );
    let text = String::from_utf8_lossy(&all.stdout);
    for name in [
        "\"F\"",
        "\"events\"",
        "\"cycles\"",
        "\"units\"",
        "\"scenario\"",
    ] {
        assert!(text.contains(name), "{name} missing from h5dump output");
    }
    // ... and the values, printed with 17 significant digits, are the ones written.
    let out = Command::new("h5dump")
        .args(["-m", "%.17g", "-y", "-w", "0", "-d", "/F"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let data = text
        .split("DATA {")
        .nth(1)
        .unwrap()
        .split('}')
        .next()
        .unwrap();
    let values: Vec<f64> = data.split(',').map(|v| v.trim().parse().unwrap()).collect();
    assert_eq!(bits(&values), bits(&expected_column(&samples, "F")));
}

/// The number that follows `"key":` after `anchor` in `text`, parsed with Rust's correctly
/// rounded `str::parse` (serde_json's default float parser may be off by an ulp, so it cannot
/// check bit-exactness; the file itself is exact: serde_json writes shortest round-trip digits).
fn exact_number(text: &str, anchor: &str, key: &str) -> f64 {
    let start = text.find(anchor).unwrap() + anchor.len();
    let pat = format!("\"{key}\":");
    let at = start + text[start..].find(&pat).unwrap() + pat.len();
    let end = at + text[at..].find([',', '}']).unwrap();
    text[at..end].trim().parse().unwrap()
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn summary_json_has_the_headline_numbers_and_units() {
    let dir = tempfile::tempdir().unwrap();
    let (samples, res) = write_run(dir.path(), true, 2000);
    let text = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    let j: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(j["format_version"], 1);
    assert_eq!(j["scenario"], "tests/synthetic \"run\".toml");
    assert_eq!(j["method"], res.method.as_str());
    assert_eq!(j["detached"], true);
    for (key, want) in [
        ("force", res.pull_off.force),
        ("amplification", res.pull_off.amplification),
        ("time", res.pull_off.time),
        ("approach_roughness", res.approach_roughness),
    ] {
        let got = exact_number(&text, "\"pull_off\":", key);
        assert_eq!(got.to_bits(), want.to_bits(), "pull_off.{key}");
    }
    // The force minimum and the final contact loss are two keys, each with its unit.
    assert_eq!(
        exact_number(&text, "\"detachment\":", "time").to_bits(),
        res.detachment_time.to_bits()
    );
    assert_eq!(j["units"]["detachment.time"], "s");
    assert_eq!(j["units"]["pull_off.time"], "s");
    assert_eq!(j["stats"]["steps"], 123_456);
    assert_eq!(j["stats"]["rejected"], 789);
    assert_eq!(j["stats"]["rhs_evals"], 987_654);
    assert_eq!(j["stats"]["wall_s"].as_f64(), Some(1.25));
    assert_eq!(j["samples"], 2000);
    let last = samples.last().unwrap();
    for def in SERIES.iter() {
        let got = exact_number(&text, "\"final_state\":", def.name);
        assert_eq!(
            got.to_bits(),
            def.value(last).to_bits(),
            "final_state.{}",
            def.name
        );
    }
    assert_eq!(j["final_state"]["stage"], 1);
    assert_eq!(j["units"]["pull_off.force"], "N");
    assert_eq!(j["units"]["F"], "N");
    assert_eq!(j["units"]["t"], "s");
    assert_eq!(j["event_counts"]["stage-start"], 2);
    assert_eq!(j["files"]["hdf5"], "run.h5");
    assert_eq!(j["files"]["timeseries_csv"], "timeseries.csv");
    assert_eq!(j["non_finite"], serde_json::json!({}));
    let ev = j["events"].as_array().unwrap();
    assert_eq!(ev.len(), res.events.len());
    let event_lines: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("  \"events\": ["))
        .skip(1)
        .take(res.events.len())
        .collect();
    for ((e, want), line) in ev.iter().zip(&res.events).zip(&event_lines) {
        assert_eq!(e["stage"].as_u64(), Some(want.stage as u64));
        assert_eq!(
            exact_number(line, "{", "time").to_bits(),
            want.time.to_bits()
        );
        let delta = exact_number(line, "\"state\":", "delta");
        assert_eq!(delta.to_bits(), want.state.delta.to_bits());
    }
    assert_eq!(ev[5]["kind"], "pull-off");
    assert_eq!(j["cycles"]["count"], 3);
    assert_eq!(
        exact_number(&text, "\"cycles\":", "delta_mean").to_bits(),
        cycles()[2].delta_mean.to_bits()
    );
    assert_eq!(j["cycles"]["last"]["index"], 2);
    assert_eq!(j["units"]["cycles.last.delta_mean"], "m");
    assert_eq!(j["units"]["cycles.last.t_end"], "s");
}

#[test]
fn non_finite_numbers_are_omitted_from_json_and_listed() {
    let dir = tempfile::tempdir().unwrap();
    let scn = scenario();
    let mut w = RunWriter::create(dir.path(), &scn, false).unwrap();
    let mut s = sample(3);
    s.g = f64::NAN;
    let event = Event {
        kind: EventKind::Impact,
        time: 0.5,
        stage: 0,
        state: s,
    };
    w.event(&event);
    let mut res = result(vec![event], s);
    res.detached = false;
    res.pull_off.force = f64::NAN;
    res.pull_off.amplification = f64::NAN;
    res.pull_off.time = f64::INFINITY;
    res.approach_roughness = f64::NAN;
    res.final_state.force = f64::NEG_INFINITY;
    w.finish(&res).unwrap();
    let text = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    assert!(!text.contains("null"), "{text}");
    let j: Value = serde_json::from_str(&text).unwrap();
    // Not detached: no pull-off (the most tensile force under `most_tensile`, without an
    // amplification), no detachment time, and no NaN listed for either.
    assert_eq!(j["pull_off"], serde_json::json!({}));
    assert!(j["most_tensile"].get("force").is_none(), "{j}");
    assert!(j["most_tensile"].get("amplification").is_none(), "{j}");
    assert_eq!(j["detachment"], serde_json::json!({}));
    assert!(j["final_state"].get("F").is_none());
    assert!(j["final_state"].get("x_s").is_some());
    assert!(j["events"][0]["state"].get("G").is_none());
    assert_eq!(
        j["non_finite"],
        serde_json::json!({
            "most_tensile.force": "NaN",
            "most_tensile.time": "inf",
            "final_state.F": "-inf",
            "final_state.G": "NaN",
            "events[0].state.G": "NaN",
        })
    );
    // The HDF5 file keeps NaN as NaN.
    let f = hdf5_pure::File::open(dir.path().join("run.h5")).unwrap();
    let g = f.dataset("events/G").unwrap().read_f64().unwrap();
    assert!(g[0].is_nan());
}

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (header, rows)
}

#[test]
fn csv_has_units_in_the_header_and_exact_values() {
    let dir = tempfile::tempdir().unwrap();
    let (samples, res) = write_run(dir.path(), true, 3000);
    assert_eq!(
        names_in(dir.path()),
        vec![
            "cycles.csv",
            "events.csv",
            "gaps.csv",
            "run.h5",
            "summary.json",
            "timeseries.csv"
        ]
    );
    let (header, rows) = read_csv(&dir.path().join("timeseries.csv"));
    assert_eq!(
        header.join(","),
        "t [s],x_s [m],v_s [m/s],x_b [m],x_k [m],delta [m],a [m],a_dot [m/s],F [N],G [J/m^2],w [J/m^2],stage [1],segment [1]"
    );
    // The segment steps by one after each gap (at a third and two thirds of the run).
    let n = samples.len();
    for (i, row) in rows.iter().enumerate() {
        let want = usize::from(i >= n / 3) + usize::from(i >= 2 * n / 3);
        assert_eq!(row[12], want.to_string(), "segment of sample {i}");
    }
    let (header, gap_rows) = read_csv(&dir.path().join("gaps.csv"));
    assert_eq!(header, ["t_start [s]", "t_end [s]", "periods [1]"]);
    assert_eq!(gap_rows.len(), 2);
    assert_eq!(
        gap_rows[0][1].parse::<f64>().unwrap().to_bits(),
        samples[n / 3].t.to_bits()
    );
    assert_eq!(rows.len(), samples.len());
    for (row, s) in rows.iter().zip(&samples) {
        for (k, def) in SERIES.iter().enumerate() {
            let v: f64 = row[k].parse().unwrap();
            assert_eq!(
                v.to_bits(),
                def.value(s).to_bits(),
                "{} {}",
                def.name,
                row[k]
            );
        }
        assert_eq!(row[11], s.stage.to_string());
    }
    let (header, rows) = read_csv(&dir.path().join("events.csv"));
    assert_eq!(&header[..4], &["kind", "time [s]", "stage [1]", "x_s [m]"]);
    assert_eq!(header.len(), 13);
    assert_eq!(rows.len(), res.events.len());
    assert_eq!(rows[1][0], "contact-loss");
    let f_col = header.iter().position(|h| h == "F [N]").unwrap();
    let f: f64 = rows[1][f_col].parse().unwrap();
    assert_eq!(f.to_bits(), res.events[1].state.force.to_bits());

    let (header, rows) = read_csv(&dir.path().join("cycles.csv"));
    assert_eq!(rows.len(), 3);
    let col = header.iter().position(|h| h == "force_sin [N]").unwrap();
    let v: f64 = rows[2][col].parse().unwrap();
    assert_eq!(v.to_bits(), cycles()[2].force_sin.to_bits());
    assert_eq!(
        &header[..4],
        &["index [1]", "stage [1]", "t_start [s]", "t_end [s]"]
    );
    assert!(header.iter().any(|h| h == "work_base [J]"));
}

#[test]
fn a_writer_dropped_or_aborted_leaves_no_output_and_keeps_an_earlier_run() {
    let scn = scenario();
    // Fresh directory: drop without finish.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    {
        let mut w = RunWriter::create(&out, &scn, true).unwrap();
        for i in 0..100 {
            w.sample(&sample(i));
        }
        // A short run is buffered: nothing but the lock while it is in progress ...
        assert!(names_in(&out).is_empty(), "{:?}", names_in(&out));
    }
    // ... and nothing at all once the writer is gone.
    assert!(names_in(&out).is_empty(), "{:?}", names_in(&out));
    assert!(out.join(LOCK_NAME).exists());
    // A streamed run has its partials while in progress, and none after it is dropped.
    {
        let mut w = RunWriter::create(&out, &scn, true).unwrap();
        for i in 0..SPILL_ROWS + 10 {
            w.sample(&sample(i));
        }
        assert!(w.is_streaming());
        let names = names_in(&out);
        assert_eq!(names.len(), 4, "{names:?}");
        assert!(names.iter().all(|n| n.ends_with(".partial")), "{names:?}");
    }
    assert!(names_in(&out).is_empty(), "{:?}", names_in(&out));

    // An earlier complete run survives a later aborted one, byte for byte.
    write_run(&out, true, 500);
    let before: Vec<(String, Vec<u8>)> = names_in(&out)
        .into_iter()
        .map(|n| {
            let b = std::fs::read(out.join(&n)).unwrap();
            (n, b)
        })
        .collect();
    let mut w = RunWriter::create(&out, &scn, false).unwrap();
    for i in 0..50 {
        w.sample(&sample(i + 7));
    }
    w.abort();
    let after: Vec<(String, Vec<u8>)> = names_in(&out)
        .into_iter()
        .map(|n| {
            let b = std::fs::read(out.join(&n)).unwrap();
            (n, b)
        })
        .collect();
    assert_eq!(before, after);
}

#[test]
fn stale_partials_are_cleared_only_when_recorded_and_other_files_kept() {
    use std::os::unix::fs::MetadataExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_run(d, true, 100);
    // A killed run left two partials it recorded in the lock file (name and inode) ...
    std::fs::write(d.join(".run.h5.1764-99.a1b2c3.partial"), b"half").unwrap();
    std::fs::write(d.join(".timeseries.csv.1764-99.d4e5f6.partial"), b"half").unwrap();
    let ino = |n: &str| std::fs::metadata(d.join(n)).unwrap().ino();
    // ... and one whose name a user has since taken for a file of their own (another inode).
    std::fs::write(d.join(".cycles.csv.1764-99.g7h8i9.partial"), b"mine").unwrap();
    let lock = format!(
        "djkr lock\npid 99\npartial .run.h5.1764-99.a1b2c3.partial {}\n\
         partial .timeseries.csv.1764-99.d4e5f6.partial {}\n\
         partial .cycles.csv.1764-99.g7h8i9.partial {}\n",
        ino(".run.h5.1764-99.a1b2c3.partial"),
        ino(".timeseries.csv.1764-99.d4e5f6.partial"),
        ino(".cycles.csv.1764-99.g7h8i9.partial") + 1
    );
    std::fs::write(d.join(LOCK_NAME), lock).unwrap();
    // Files that look like djkr's partials but that djkr did not record are not its to delete.
    std::fs::write(d.join(".summary.json.partial"), b"mine").unwrap();
    std::fs::write(d.join(".run.h5.1764-98.partial"), b"mine").unwrap();
    std::fs::write(d.join(".notes.partial"), b"mine").unwrap();
    std::fs::write(d.join("run.h5.bak"), b"mine").unwrap();
    write_run(d, false, 100);
    assert_eq!(
        names_in(d),
        vec![
            ".cycles.csv.1764-99.g7h8i9.partial",
            ".notes.partial",
            ".run.h5.1764-98.partial",
            ".summary.json.partial",
            "cycles.csv",
            "events.csv",
            "gaps.csv",
            "run.h5",
            "run.h5.bak",
            "summary.json",
            "timeseries.csv"
        ]
    );
    for n in [
        ".summary.json.partial",
        ".cycles.csv.1764-99.g7h8i9.partial",
    ] {
        assert_eq!(std::fs::read(d.join(n)).unwrap(), b"mine");
    }
    // The earlier run's CSV files stay (djkr never deletes what a user may hold); summary.json
    // lists the files of this run only, with their sizes.
    let j = read_json(&dir.path().join("summary.json"));
    assert!(j["files"].get("timeseries_csv").is_none());
    let size = std::fs::metadata(dir.path().join("run.h5")).unwrap().len();
    assert_eq!(j["file_bytes"], serde_json::json!({ "run.h5": size }));
}

#[test]
fn a_second_writer_into_a_busy_directory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scn = scenario();
    let first = RunWriter::create(dir.path(), &scn, false).unwrap();
    let err = RunWriter::create(dir.path(), &scn, false).unwrap_err();
    assert!(matches!(err, OutputError::Busy { .. }), "{err}");
    let msg = err.to_string();
    assert!(
        msg.contains("another djkr run") && msg.contains(".djkr.lock"),
        "{msg}"
    );
    // The holder is named by its process id (here this test's).
    assert!(
        msg.contains(&format!("pid {}", std::process::id())),
        "{msg}"
    );
    drop(first);
    RunWriter::create(dir.path(), &scn, false).unwrap();
}

#[test]
fn a_run_that_would_not_fit_the_disk_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let mut scn = scenario();
    // 1e15 samples per second over the 0.1 s hold: 1e14 samples, petabytes (the unload, which
    // ends at pull-off, is not counted: it is watched while the run streams).
    scn.output.sample_rate = 1e15;
    let err = RunWriter::create(dir.path(), &scn, true).unwrap_err();
    assert!(matches!(err, OutputError::DiskSpace { .. }), "{err}");
    let msg = err.to_string();
    assert!(msg.contains("sample_rate") && msg.contains("free"), "{msg}");
    assert!(names_in(dir.path()).is_empty());
}

#[test]
fn an_empty_run_writes_valid_files() {
    let dir = tempfile::tempdir().unwrap();
    let scn = scenario();
    let w = RunWriter::create(dir.path(), &scn, true).unwrap();
    let mut res = result(Vec::new(), sample(0));
    res.cycle_count = 0;
    res.last_cycle = None;
    w.finish(&res).unwrap();
    let f = hdf5_pure::File::open(dir.path().join("run.h5")).unwrap();
    assert_eq!(f.dataset("t").unwrap().shape().unwrap(), vec![0]);
    assert!(f.dataset("t").unwrap().read_f64().unwrap().is_empty());
    assert!(f
        .dataset("events/kind")
        .unwrap()
        .read_string()
        .unwrap()
        .is_empty());
    assert!(f.dataset("stage").unwrap().read_i64().unwrap().is_empty());
    // Without cycles (a scene without vibration) cycles.csv is its header alone.
    let cycles = std::fs::read_to_string(dir.path().join("cycles.csv")).unwrap();
    assert_eq!(cycles.lines().count(), 1, "{cycles}");
    assert!(cycles.starts_with("index [1],stage [1],t_start [s],t_end [s],a_cos [m]"));
    let (header, rows) = read_csv(&dir.path().join("timeseries.csv"));
    assert_eq!((header.len(), rows.len()), (13, 0));
    let j = read_json(&dir.path().join("summary.json"));
    assert_eq!(j["samples"], 0);
    assert_eq!(j["events"], serde_json::json!([]));
    assert_eq!(j["cycles"], serde_json::json!({"count": 0}));
    if let Some(dump) = h5py_dump(&dir.path().join("run.h5")) {
        assert_eq!(dump["datasets"]["/t"]["shape"], serde_json::json!([0]));
        assert_eq!(
            dump["datasets"]["/events/kind"]["str"],
            serde_json::json!([])
        );
    }
}

#[test]
fn create_fails_with_the_path_when_the_directory_cannot_be_made() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("not-a-dir");
    std::fs::write(&file, b"x").unwrap();
    let err: OutputError = RunWriter::create(&file.join("sub"), &scenario(), false).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("not-a-dir"), "{msg}");
    let _: PathBuf = file;
}

/// A simulated run long enough to stream: the writer thread builds the samples of each step
/// (`Observer::step_samples`) where a buffered observer builds them on the run's thread one by
/// one. The files hold the same numbers, bit for bit: every time-series column of run.h5, and
/// the three CSV files byte for byte.
#[test]
fn a_streamed_simulation_holds_the_samples_built_in_memory() {
    // The hold stage only, 2 s at 300 Hz, sampled at 60 kHz (120 000 samples, several a step).
    let hold = &SCENARIO[..SCENARIO.rfind("[[stage]]").unwrap()];
    let text = hold.replace("duration = 0.1", "duration = 2.0")
        + "[solver]\nenvelope = \"off\"\n[output]\nsample_rate = 60000\n";
    let scn = parse_scenario(&text, "tests/streamed.toml", None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut w = RunWriter::create(dir.path(), &scn, true).unwrap();
    let res = scn.simulate(&mut w).unwrap();
    assert!(w.is_streaming());
    w.finish(&res).unwrap();

    struct Both(TimeSeriesWriter, Vec<CycleRecord>);
    impl Observer for Both {
        fn sample(&mut self, s: &Sample) -> bool {
            self.0.sample(s)
        }
        fn cycle(&mut self, c: &CycleRecord) {
            self.1.push(*c);
        }
    }
    let mut mem = Both(TimeSeriesWriter::new(), Vec::new());
    let res_mem = scn.simulate(&mut mem).unwrap();
    let n = mem.0.len();
    assert!(n > SPILL_ROWS + 2 * FLUSH_ROWS, "{n} samples");
    assert_eq!(res.final_state.t.to_bits(), res_mem.final_state.t.to_bits());

    let f = hdf5_pure::File::open(dir.path().join("run.h5")).unwrap();
    for def in SERIES.iter() {
        let got = f.dataset(def.name).unwrap().read_f64().unwrap();
        assert_eq!(
            bits(&got),
            bits(mem.0.column(def.name).unwrap()),
            "{}",
            def.name
        );
    }
    assert_eq!(
        f.dataset("stage").unwrap().read_i64().unwrap(),
        mem.0.stages()
    );
    for (name, table) in [
        ("timeseries.csv", mem.0.table().clone()),
        ("events.csv", events_table(&res_mem.events)),
        ("cycles.csv", cycle_table(&mem.1)),
    ] {
        let written = std::fs::read_to_string(dir.path().join(name)).unwrap();
        assert!(written == table.to_csv(), "{name} differs");
    }
}

/// `djkr run` and `api::run` open their folder through the same step
/// (`api::open_run_folder`): a scenario whose `[output]` asks for the figure claims `run.png`
/// and `run.svg` before the run starts, so a file of the user's under one of those names stops
/// the run at once, before any result is written, and is left as it was.
#[test]
fn api_run_claims_the_figure_before_the_run_like_the_command_line() {
    let text = std::fs::read_to_string("scenarios/quasi-static-jkr.toml").unwrap()
        + "\n[output]\nplot = true\n";
    let scn = parse_scenario(&text, "scenarios/quasi-static-jkr.toml", None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mine = dir.path().join("run.png");
    std::fs::write(&mine, b"the user's own picture").unwrap();
    let err = crate::api::run(&scn, Some(dir.path())).unwrap_err();
    assert!(
        matches!(err, crate::error::Error::Output { .. }),
        "expected the folder to refuse before the run: {err}"
    );
    assert!(err.to_string().contains("run.png"), "{err}");
    assert_eq!(std::fs::read(&mine).unwrap(), b"the user's own picture");
    assert!(!dir.path().join("summary.json").exists());
    assert!(!dir.path().join("run.h5").exists());
}
