//! The HDF5 run file, written with `hdf5-pure`.
//!
//! Why `hdf5-pure`: it is pure Rust, so `cargo build` on a fresh machine needs no libhdf5, no
//! cmake and no C toolchain (the bindings to the C library either link a system libhdf5, which
//! then must exist at run time, or build it from source with cmake ≥ 3.26). Its files are read
//! bit-exactly by h5py and by h5dump (tests/output.rs checks with both when they are installed).
//! It is young and has one maintainer; the file layout below uses only its well-trodden parts
//! (1-D f64/i64 datasets, chunked with shuffle + deflate, variable-length string attributes and one
//! variable-length string dataset).
//!
//! Layout:
//!
//! ```text
//! /                 attrs: layout_version (i64), djkr_version, source, scenario (the file's text),
//!                          method, detached (i64 0/1), pull_off_force (N),
//!                          pull_off_amplification (1), pull_off_time (s),
//!                          steps, rejected, rhs_evals (u64), wall_s (s)
//! /t, /x_s, /v_s, /x_b, /x_k, /delta, /a, /a_dot, /F, /G, /w    f64[n]   attrs: units, description
//! /stage                                                         i64[n]   attrs: units, description
//! /events/kind      variable-length strings (impact, contact-loss, pull-off, ...)
//! /events/time      f64[m] (s)     /events/stage   i64[m]
//! /events/x_s ... /events/w        f64[m]: the state at each event (same names as above)
//! /cycles           attrs: count; one dataset per CycleRecord field (index, stage: i64; the rest
//!                   f64), attrs units, description (see `output::cycles`); no datasets when the
//!                   run recorded no cycle
//! ```
//!
//! All strings are variable-length UTF-8 (`AttrValue::VarLenString`): fixed-length ones come back
//! as `bytes` in h5py.

use std::path::Path;

use hdf5_pure::{make_f64_type, make_i64_type, AttrValue, DatasetBuilder, FileBuilder};

use super::cycles::{cycle_table, cycle_unit, CycleColumn};
use super::timeseries::{
    stage_index, TimeSeriesWriter, SERIES, STAGE, STAGE_DESCRIPTION, STAGE_UNIT,
};
use super::{write_file_synced, OutputError};
use crate::dynamics::types::RunResult;
use crate::scenario::Scenario;

/// Version of the layout above, stored as the root attribute `layout_version`.
pub const LAYOUT_VERSION: i64 = 1;

/// Elements per chunk of a time-series dataset (32 Ki f64 = 256 KiB). Must stay below 65536:
/// hdf5-pure 0.47 encodes a chunk dimension of 65536 or more in a form libhdf5 rejects ("stored
/// chunk dimension encoding length does not match"), while its own reader accepts it.
const CHUNK: usize = 1 << 15;
/// Deflate level. Measured on a synthetic 10⁶-sample run (96 MB raw, release build): level 1
/// gives 47.9 MB in 0.8 s, level 4 gives 46.5 MB in 3.3 s; shuffled doubles gain little from
/// harder compression.
const DEFLATE_LEVEL: u32 = 1;

fn vstr(s: &str) -> AttrValue {
    AttrValue::VarLenString(s.to_string())
}

fn label(ds: &mut DatasetBuilder, unit: &str, description: &str) {
    ds.set_attr("units", vstr(unit));
    ds.set_attr("description", vstr(description));
}

fn f64_data(ds: &mut DatasetBuilder, data: &[f64]) {
    if data.is_empty() {
        ds.with_dtype(make_f64_type()).with_shape(&[0]);
    } else {
        ds.with_f64_data(data);
        compress(ds, data.len());
    }
}

fn i64_data(ds: &mut DatasetBuilder, data: &[i64]) {
    if data.is_empty() {
        ds.with_dtype(make_i64_type()).with_shape(&[0]);
    } else {
        ds.with_i64_data(data);
        compress(ds, data.len());
    }
}

fn compress(ds: &mut DatasetBuilder, len: usize) {
    let chunk = len.min(CHUNK) as u64;
    ds.with_chunks(&[chunk])
        .with_shuffle()
        .with_deflate(DEFLATE_LEVEL);
}

/// Serialise the run to HDF5 bytes (layout in the module doc).
pub fn hdf5_bytes(
    series: &TimeSeriesWriter,
    scenario: &Scenario,
    result: &RunResult,
) -> Result<Vec<u8>, String> {
    let mut b = FileBuilder::new();
    b.set_attr("layout_version", AttrValue::I64(LAYOUT_VERSION));
    b.set_attr("djkr_version", vstr(env!("CARGO_PKG_VERSION")));
    b.set_attr("source", vstr(&scenario.source_name));
    b.set_attr("scenario", vstr(&scenario.source_text));
    b.set_attr("method", vstr(&result.method));
    b.set_attr("detached", AttrValue::I64(i64::from(result.detached)));
    b.set_attr("pull_off_force", AttrValue::F64(result.pull_off.force));
    b.set_attr(
        "pull_off_amplification",
        AttrValue::F64(result.pull_off.amplification),
    );
    b.set_attr("pull_off_time", AttrValue::F64(result.pull_off.time));
    b.set_attr("steps", AttrValue::U64(result.stats.steps));
    b.set_attr("rejected", AttrValue::U64(result.stats.rejected));
    b.set_attr("rhs_evals", AttrValue::U64(result.stats.rhs_evals));
    b.set_attr("wall_s", AttrValue::F64(result.stats.wall_s));

    for (def, data) in SERIES.iter().zip(series.columns().iter()) {
        let ds = b.create_dataset(def.name);
        f64_data(ds, data);
        label(ds, def.unit, def.description);
    }
    let ds = b.create_dataset(STAGE);
    i64_data(ds, series.stages());
    label(ds, STAGE_UNIT, STAGE_DESCRIPTION);

    let events = &result.events;
    let mut g = b.create_group("events");
    g.set_attr(
        "description",
        vstr("located events: kind, time, stage and the state at the event"),
    );
    let kinds: Vec<String> = events.iter().map(|e| kind_name(e.kind)).collect();
    let kind_refs: Vec<&str> = kinds.iter().map(String::as_str).collect();
    let ds = g.create_dataset("kind");
    ds.with_vlen_strings(&kind_refs);
    label(
        ds,
        "",
        "event kind: stage-start, impact, contact-loss, preload-reached, duration-elapsed, pull-off",
    );
    let times: Vec<f64> = events.iter().map(|e| e.time).collect();
    let ds = g.create_dataset("time");
    f64_data(ds, &times);
    label(ds, "s", "event time");
    let stages: Vec<i64> = events.iter().map(|e| stage_index(e.stage)).collect();
    let ds = g.create_dataset(STAGE);
    i64_data(ds, &stages);
    label(ds, STAGE_UNIT, STAGE_DESCRIPTION);
    for def in SERIES.iter().filter(|c| c.name != "t") {
        let values: Vec<f64> = events.iter().map(|e| def.value(&e.state)).collect();
        let ds = g.create_dataset(def.name);
        f64_data(ds, &values);
        label(ds, def.unit, def.description);
    }
    b.add_group(g.finish());

    let table = cycle_table(&result.cycles);
    let mut g = b.create_group("cycles");
    g.set_attr(
        "description",
        vstr("exact averages and first harmonics over each base period while the shaker is on"),
    );
    g.set_attr("count", AttrValue::I64(table.len() as i64));
    for (name, col) in table.names.iter().zip(&table.columns) {
        let ds = g.create_dataset(name);
        match col {
            CycleColumn::F64(v) => f64_data(ds, v),
            CycleColumn::I64(v) => i64_data(ds, v),
        }
        label(ds, cycle_unit(name), name);
    }
    b.add_group(g.finish());
    b.finish().map_err(|e| e.to_string())
}

/// Write the run's HDF5 file to `path` (not atomically: [`super::RunWriter`] writes to a
/// temporary name and renames).
pub fn write_hdf5(
    path: &Path,
    series: &TimeSeriesWriter,
    scenario: &Scenario,
    result: &RunResult,
) -> Result<(), OutputError> {
    let bytes = hdf5_bytes(series, scenario, result).map_err(|message| OutputError::Hdf5 {
        path: path.to_path_buf(),
        message,
    })?;
    write_file_synced(path, &bytes)
}

/// The kebab-case name of an event kind, as in summary.json.
pub(crate) fn kind_name(kind: crate::dynamics::types::EventKind) -> String {
    match serde_json::to_value(kind) {
        Ok(serde_json::Value::String(s)) => s,
        _ => format!("{kind:?}"),
    }
}
