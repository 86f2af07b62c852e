//! `summary.json`: the run's headline numbers, machine-readable.
//!
//! ```json
//! {
//!   "format_version": 1,
//!   "djkr_version": "0.1.0",
//!   "run_id": "1795500000.123456-41234",
//!   "scenario": "scenarios/paper-protocol-300hz.toml --set base.amplitude=30um",
//!   "overrides": ["base.amplitude=30um"],
//!   "status": "stopped",
//!   "reason": "max_wall_s",
//!   "message": "wall-clock budget of solver.max_wall_s = 45 s exhausted at t = ... (the run got to t = 3.2e0 s in stage 1)",
//!   "method": "dopri5 (auto: ...)",
//!   "detached": true,
//!   "pull_off": {"amplification": 1.7, "approach_roughness": 1.2e-6, "force": -0.098, "time": 12.3},
//!   "detachment": {"time": 13.1},
//!   "stats": {"rejected": 12, "rhs_evals": 7000, "steps": 1000, "wall_s": 0.4, "write_s": 0.02},
//!   "samples": 1000,
//!   "envelope": {"jumps": 12, "periods_skipped": 3400, "trial_periods": 40, "rejected": 2,
//!                "steady_jumps": 0},
//!   "events_listed": 12,
//!   "file_bytes": {"hdf5": 183424, "timeseries_csv": 91233},
//!   "sensitivity": {"key": "base.amplitude", "epsilon": 1e-12, "force_spread": 3.1e-2, "digits": 1, "sensitive": true, "runs": [...], ...},
//!   "final_state": {"F": 0.0, "G": 0.0, "a": 0.0, ..., "stage": 3, "t": 12.4, ...},
//!   "cycles": {"count": 3600, "last": {"force_mean": -0.05, "index": 3599, ...}},
//!   "event_counts": {"impact": 3, "pull-off": 1, ...},
//!   "units": {"F": "N", "pull_off.force": "N", "t": "s", ...},
//!   "files": {"hdf5": "run.h5", "timeseries_csv": "timeseries.csv", ...},
//!   "warnings": ["outside the model: the contact reaches a = ..."],
//!   "non_finite": {"pull_off.force": "NaN"},
//!   "events": [
//!     {"kind": "stage-start", "stage": 0, "state": {...}, "time": 0.0},
//!     ...
//!   ]
//! }
//! ```
//!
//! `status` is `ok` (the run went through its stages), `stopped` (a budget, low disk space or a
//! signal stopped it) or `failed` (the integration failed mid-way); `reason` names why
//! (`max_steps`, `max_wall_s`, `max_events`, `memory`, `disk`, `SIGINT`, `SIGTERM`, `non-finite`,
//! `step-underflow`, `no-progress`, `stage-timeout`, `method-failed`, `setup`:
//! [`djkr_core::dynamics::Reason`]) and
//! `message` says what happened, when and in which stage; both are absent when ok (the file
//! has no `null`: see the non-finite rule below). A stopped
//! or failed run's numbers (`final_state`, `pull_off`, `cycles`, `events`, ...) and files
//! describe the run up to where it ended.
//!
//! `pull_off.force` is the pull-off force: under vibration the most tensile cycle-averaged
//! contact force of the pull-off stage, otherwise the most tensile contact force;
//! `pull_off.time` is when it was reached (the end of that period). `detachment.time` is when
//! the contact was lost for good (the `pull-off` event: the last contact loss, after which the
//! sphere never touched again), later than `pull_off.time` (on the paper protocol at 300 Hz
//! 21.59 s against 20.83 s); absent without detachment. A run that never detached had no
//! pull-off: `pull_off` is then empty and `most_tensile` (`force`, `time`, `tensile`, and the
//! approach keys below; no amplification) holds the most tensile force it saw, present only then.
//! `pull_off.tensile` says whether that
//! force is tensile (negative): false when no cycle mean (no contact force) was, as for a sphere
//! that bounced off; `pull_off.amplification` is then left out (`non_finite`: NaN), and a
//! detached run says so in `warnings` ([`checks::no_tensile_pull_off`]). `pull_off.approach_roughness` is the
//! largest relative second difference of the cycle-mean force over the 16 periods before the
//! pull-off (`dynamics::ApproachRoughness`): above 1e-3 the approach fluctuated and the pull-off
//! is likely sensitive to tiny input changes (`djkr run --sensitivity` measures it); absent
//! when not measured (no vibration, or no three consecutive periods before the pull-off) or not
//! defined: `pull_off.approach_zero_means`, present only then, counts the periods among those 16
//! whose mean force was zero (the sphere off the substrate for a whole period), where a relative
//! difference would divide by zero.
//!
//! `stats.wall_s` is the wall-clock time of the integration, what `solver.max_wall_s` bounds;
//! `stats.write_s` the wall-clock time spent after it writing the run's files (the samples
//! still queued for the writer thread, closing `run.h5`, the CSV files; not summary.json
//! itself, nor a figure drawn after): not bounded by the budget, and growing with what was left
//! to write (2 s for 450 MB of run.h5 and CSV on the reference machine). Absent for a run kept
//! in memory without a folder.
//!
//! `warnings` lists what leaves the model's range ([`checks::result_warnings`]: a contact
//! beyond 0.2 R, no pull-off recorded; always present, empty without).
//!
//! `scenario` names the file and its `--set` overrides; `overrides` lists them (`KEY=VALUE` as
//! given; always present, empty when the file ran as written). `run_id` (Unix seconds.microseconds at
//! the start of the run, then the process id) is the same string as the root attribute `run_id`
//! of `run.h5`: files of one run carry one id. `event_counts` counts
//! every event of the run; `events` lists the first `events_listed` of them (at most 10 000; the
//! HDF5 file has them all). `envelope` says how many periods envelope following jumped over
//! (they have no samples and no records).
//!
//! Top-level keys come one per line in this order, and events one per line, so the file diffs
//! and greps well even with thousands of impacts.
//!
//! **Non-finite rule.** JSON has no NaN or infinity (serde_json would write `null`, which then fails
//! to read back as a number). A non-finite number is therefore *omitted* from its object and its
//! dotted path recorded in `non_finite` with its value spelled `"NaN"`, `"inf"` or `"-inf"` —
//! e.g. a run that never detached may have no `pull_off.time` and
//! `"non_finite": {"pull_off.time": "NaN"}`. Readers treat a number field as optional and look in
//! `non_finite` when it is missing. `non_finite` is always present (empty when all is finite).

use std::collections::BTreeMap;

use serde_json::{Map, Value};

use super::cycles::cycle_table;
use super::table::Data;
use super::timeseries::{kind_name, stage_index, SERIES, STAGE, STAGE_UNIT};
use crate::scenario::{checks, Scenario};
use djkr_core::dynamics::{CycleRecord, Ending, RunResult, Sample};

/// Version of the summary layout, stored as `format_version`.
pub const SUMMARY_VERSION: i64 = 1;

/// File names (relative to the output directory) listed under `files`. The default lists none
/// (a run kept in memory, without a run folder: `files` and `file_bytes` are empty).
#[derive(Debug, Clone, Default)]
pub(crate) struct SummaryFiles {
    /// The HDF5 file (empty: none written).
    pub hdf5: String,
    /// The time-series CSV, when written.
    pub timeseries_csv: Option<String>,
    /// The events CSV, when written.
    pub events_csv: Option<String>,
    /// The cycles CSV, when written.
    pub cycles_csv: Option<String>,
    /// The gaps CSV, when written.
    pub gaps_csv: Option<String>,
    /// The size in bytes of each file above (`file_bytes`): a reader can tell a file that a
    /// machine crash truncated after the run from a complete one.
    pub bytes: Vec<(String, u64)>,
    /// Wall-clock seconds spent writing the files after the integration ended (`stats.write_s`;
    /// `None`: nothing written, a run kept in memory only).
    pub write_s: Option<f64>,
}

/// Further top-level sections of summary.json, written after the standard ones (e.g.
/// `sensitivity`, from `djkr run --sensitivity`).
pub type Sections = [(String, Value)];

/// Builds JSON objects while applying the non-finite rule.
#[derive(Default)]
struct Builder {
    non_finite: BTreeMap<String, Value>,
}

impl Builder {
    fn put(&mut self, map: &mut Map<String, Value>, prefix: &str, key: &str, x: f64) {
        match serde_json::Number::from_f64(x) {
            Some(n) if x.is_finite() => {
                map.insert(key.to_string(), Value::Number(n));
            }
            _ => {
                let text = if x.is_nan() {
                    "NaN"
                } else if x > 0.0 {
                    "inf"
                } else {
                    "-inf"
                };
                self.non_finite
                    .insert(format!("{prefix}{key}"), Value::String(text.to_string()));
            }
        }
    }

    /// `cycles`: the count and the last record (as in the cycle table), with the units of the
    /// latter (`cycles.last.<field>`).
    fn cycles(
        &mut self,
        count: u64,
        last: Option<&CycleRecord>,
    ) -> (Value, BTreeMap<String, String>) {
        let mut cycles = Map::new();
        cycles.insert("count".into(), Value::from(count));
        let mut units = BTreeMap::new();
        let Some(last) = last else {
            return (Value::Object(cycles), units);
        };
        let mut m = Map::new();
        for col in cycle_table(std::slice::from_ref(last)).columns() {
            let name = &col.name;
            match &col.data {
                Data::F64(v) => v
                    .iter()
                    .for_each(|&x| self.put(&mut m, "cycles.last.", name, x)),
                Data::I64(v) => v.iter().for_each(|&x| {
                    m.insert(name.clone(), Value::from(x));
                }),
                Data::Text(v) => v.iter().for_each(|x| {
                    m.insert(name.clone(), Value::from(x.as_str()));
                }),
            }
            units.insert(format!("cycles.last.{name}"), col.unit.clone());
        }
        cycles.insert("last".into(), Value::Object(m));
        (Value::Object(cycles), units)
    }

    fn state(&mut self, prefix: &str, s: &Sample) -> Value {
        let mut m = Map::new();
        for def in SERIES.iter() {
            self.put(&mut m, prefix, def.name, def.value(s));
        }
        m.insert(STAGE.to_string(), Value::from(stage_index(s.stage)));
        Value::Object(m)
    }
}

/// The units of every number in the summary (keys as in the file; state keys as in the HDF5
/// datasets).
pub fn units() -> BTreeMap<String, String> {
    let mut u: BTreeMap<String, String> = SERIES
        .iter()
        .map(|c| (c.name.to_string(), c.unit.to_string()))
        .collect();
    u.insert(STAGE.into(), STAGE_UNIT.into());
    for (k, v) in [
        ("pull_off.force", "N"),
        ("pull_off.amplification", "1"),
        ("pull_off.time", "s"),
        ("pull_off.approach_roughness", "1"),
        ("pull_off.approach_zero_means", "1"),
        ("most_tensile.force", "N"),
        ("most_tensile.time", "s"),
        ("most_tensile.approach_roughness", "1"),
        ("most_tensile.approach_zero_means", "1"),
        ("detachment.time", "s"),
        ("events.time", "s"),
        ("stats.wall_s", "s"),
        ("stats.write_s", "s"),
        ("stats.steps", "1"),
        ("stats.rejected", "1"),
        ("stats.rhs_evals", "1"),
    ] {
        u.insert(k.into(), v.into());
    }
    u
}

/// The summary as JSON text (layout and non-finite rule in the module doc). `samples` is the
/// number of time-series samples written, `run_id` the identity shared with the run's HDF5 file.
pub fn summary_json(
    scenario: &Scenario,
    result: &RunResult,
    ending: &Ending,
    samples: u64,
    files: &SummaryFiles,
    run_id: &str,
    sections: &Sections,
) -> String {
    // What the scenario's checks say of the result, asked once.
    let recorded = checks::pull_off_recorded(result);
    let warnings = checks::result_warnings(scenario, result);
    let mut b = Builder::default();
    let (pull_off, most_tensile) = b.pull_off(result, recorded);
    // Absent (not NaN) without detachment: that is a run's outcome, not a number gone wrong.
    let mut detachment = Map::new();
    if result.detached {
        b.put(
            &mut detachment,
            "detachment.",
            "time",
            result.detachment_time,
        );
    }
    let mut stats = b.stats(result);
    if let Some(w) = files.write_s {
        b.put(&mut stats, "stats.", "write_s", w);
    }
    let final_state = b.state("final_state.", &result.final_state);
    let counts = event_counts(result);
    let events = b.events(result);
    let (cycles, cycle_units) = b.cycles(result.cycle_count, result.last_cycle.as_ref());

    let top: Vec<(&str, Value)> = vec![
        ("format_version", Value::from(SUMMARY_VERSION)),
        ("djkr_version", Value::from(env!("CARGO_PKG_VERSION"))),
        ("run_id", Value::from(run_id)),
        ("scenario", Value::from(scenario.source_name.as_str())),
        ("overrides", Value::from(scenario.overrides.clone())),
        ("status", Value::from(ending.status().name())),
        ("method", Value::from(result.method.as_str())),
        ("detached", Value::Bool(result.detached)),
        ("pull_off", Value::Object(pull_off)),
        ("detachment", Value::Object(detachment)),
        ("stats", Value::Object(stats)),
        ("samples", Value::from(samples)),
        (
            "envelope",
            serde_json::to_value(result.envelope).unwrap_or(Value::Null),
        ),
        ("events_listed", Value::from(result.events.len() as u64)),
        ("final_state", final_state),
        ("cycles", cycles),
        ("event_counts", counts),
        (
            "units",
            Value::Object(
                units()
                    .into_iter()
                    .chain(cycle_units)
                    .map(|(k, v)| (k, Value::String(v)))
                    .collect(),
            ),
        ),
        ("files", Value::Object(file_map(files))),
        (
            "file_bytes",
            Value::Object(
                files
                    .bytes
                    .iter()
                    .map(|(k, v)| (k.clone(), Value::from(*v)))
                    .collect(),
            ),
        ),
        ("warnings", Value::from(warnings)),
        (
            "non_finite",
            Value::Object(b.non_finite.into_iter().collect()),
        ),
    ];
    let mut top = top;
    // Without detachment: the most tensile force seen, after the empty `pull_off`.
    if let Some(m) = most_tensile {
        let at = top
            .iter()
            .position(|(k, _)| *k == "pull_off")
            .map_or(0, |i| i + 1);
        top.insert(at, ("most_tensile", Value::Object(m)));
    }
    // `reason` and `message` follow `status` when the run ended early (no `null` in the file).
    let at = top
        .iter()
        .position(|(k, _)| *k == "status")
        .map_or(0, |i| i + 1);
    if let Some(m) = &ending.message {
        top.insert(at, ("message", Value::from(m.as_str())));
    }
    if let Some(r) = ending.reason {
        top.insert(at, ("reason", Value::from(r.name())));
    }
    layout(&top, sections, &events)
}

impl Builder {
    /// `pull_off`: force, amplification and time, for a run that detached. No pull-off force
    /// recorded (the simulator's placeholder 0 N at t = 0): left out, as NaN. A run that did not
    /// detach had no pull-off: `pull_off` is empty and the second map, `most_tensile`, holds the
    /// most tensile force it saw and when (no amplification: that is of a pull-off). `recorded`:
    /// [`checks::pull_off_recorded`].
    fn pull_off(
        &mut self,
        result: &RunResult,
        recorded: bool,
    ) -> (Map<String, Value>, Option<Map<String, Value>>) {
        if !result.detached && recorded {
            let po = result.pull_off;
            let p = "most_tensile.";
            let mut m = Map::new();
            self.put(&mut m, p, "force", po.force);
            self.put(&mut m, p, "time", po.time);
            if po.force.is_finite() {
                m.insert("tensile".into(), Value::Bool(po.is_tensile()));
            }
            if !result.approach_roughness.is_nan() {
                self.put(&mut m, p, "approach_roughness", result.approach_roughness);
            }
            if result.approach_zero_means > 0 {
                m.insert(
                    "approach_zero_means".into(),
                    Value::from(result.approach_zero_means),
                );
            }
            return (Map::new(), Some(m));
        }
        (self.detached_pull_off(result, recorded), None)
    }

    /// `pull_off` of a run that detached (or recorded no force).
    fn detached_pull_off(&mut self, result: &RunResult, recorded: bool) -> Map<String, Value> {
        let po = if recorded {
            result.pull_off
        } else {
            djkr_core::dynamics::PullOffSummary {
                force: f64::NAN,
                amplification: f64::NAN,
                time: f64::NAN,
            }
        };
        let mut pull_off = Map::new();
        self.put(&mut pull_off, "pull_off.", "force", po.force);
        self.put(
            &mut pull_off,
            "pull_off.",
            "amplification",
            po.amplification,
        );
        self.put(&mut pull_off, "pull_off.", "time", po.time);
        if po.force.is_finite() {
            pull_off.insert("tensile".into(), Value::Bool(po.is_tensile()));
        }
        // Absent when not measured (no vibration at the pull-off) or not defined (a zero mean
        // among the periods it looks at, counted instead): not a non-finite number.
        if !result.approach_roughness.is_nan() {
            self.put(
                &mut pull_off,
                "pull_off.",
                "approach_roughness",
                result.approach_roughness,
            );
        }
        if result.approach_zero_means > 0 {
            pull_off.insert(
                "approach_zero_means".into(),
                Value::from(result.approach_zero_means),
            );
        }
        pull_off
    }

    /// `stats`: the solver's work.
    fn stats(&mut self, result: &RunResult) -> Map<String, Value> {
        let mut stats = Map::new();
        stats.insert("steps".into(), Value::from(result.stats.steps));
        stats.insert("rejected".into(), Value::from(result.stats.rejected));
        stats.insert("rhs_evals".into(), Value::from(result.stats.rhs_evals));
        self.put(&mut stats, "stats.", "wall_s", result.stats.wall_s);
        stats
    }

    /// `events`: the listed events, one object each.
    fn events(&mut self, result: &RunResult) -> Vec<Value> {
        result
            .events
            .iter()
            .enumerate()
            .map(|(i, e)| {
                let kind = kind_name(e.kind);
                let prefix = format!("events[{i}].");
                let mut m = Map::new();
                m.insert("kind".into(), Value::String(kind));
                self.put(&mut m, &prefix, "time", e.time);
                m.insert("stage".into(), Value::from(stage_index(e.stage)));
                m.insert(
                    "state".into(),
                    self.state(&format!("{prefix}state."), &e.state),
                );
                Value::Object(m)
            })
            .collect()
    }
}

/// `event_counts`: every kind of event that happened, with its count.
fn event_counts(result: &RunResult) -> Value {
    let counts: BTreeMap<String, u64> = result
        .event_counts
        .by_kind()
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .map(|(k, n)| (kind_name(k), n))
        .collect();
    Value::Object(
        counts
            .into_iter()
            .map(|(k, v)| (k, Value::from(v)))
            .collect(),
    )
}

/// `files`: the files written.
fn file_map(files: &SummaryFiles) -> Map<String, Value> {
    let mut file_map = Map::new();
    // No HDF5 name: nothing was written (a run kept in memory, e.g. from Python without `out`).
    if !files.hdf5.is_empty() {
        file_map.insert("hdf5".into(), Value::String(files.hdf5.clone()));
    }
    if let Some(f) = &files.timeseries_csv {
        file_map.insert("timeseries_csv".into(), Value::String(f.clone()));
    }
    if let Some(f) = &files.events_csv {
        file_map.insert("events_csv".into(), Value::String(f.clone()));
    }
    if let Some(f) = &files.cycles_csv {
        file_map.insert("cycles_csv".into(), Value::String(f.clone()));
    }
    if let Some(f) = &files.gaps_csv {
        file_map.insert("gaps_csv".into(), Value::String(f.clone()));
    }
    file_map
}

/// The text: the `top` keys one per line, then the extra `sections`, then the `events` one per
/// line.
fn layout(top: &[(&str, Value)], sections: &Sections, events: &[Value]) -> String {
    let mut out = String::from("{\n");
    for (k, v) in top {
        out.push_str(&format!("  {}: {},\n", Value::from(*k), v));
    }
    for (k, v) in sections {
        out.push_str(&format!("  {}: {},\n", Value::from(k.as_str()), v));
    }
    out.push_str("  \"events\": [");
    for (i, e) in events.iter().enumerate() {
        out.push_str(if i == 0 { "\n    " } else { ",\n    " });
        out.push_str(&e.to_string());
    }
    out.push_str(if events.is_empty() {
        "]\n}\n"
    } else {
        "\n  ]\n}\n"
    });
    out
}
