//! The HDF5 run file, written with `hdf5-pure`.
//!
//! Why `hdf5-pure`: it is pure Rust, so `cargo build` on a fresh machine needs no libhdf5, no
//! cmake and no C toolchain (the bindings to the C library either link a system libhdf5, which
//! then must exist at run time, or build it from source with cmake ≥ 3.26). Its files are read
//! bit-exactly by h5py and by h5dump (tests/output.rs checks with both when they are installed).
//! It is young and has one maintainer; the file layout below uses only its well-trodden parts
//! (1-D f64/i64 datasets, chunked with shuffle + deflate, variable-length string attributes and one
//! variable-length string dataset). Every group of datasets is a [`super::table::Table`] written
//! by [`super::table::Table::write_hdf5`], the writer (and chunking rule) of every djkr table.
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
//!                   f64), attrs units, description (`output::cycles::CYCLE_FIELDS`); no datasets
//!                   when the run recorded no cycle
//! ```
//!
//! All strings are variable-length UTF-8 (`AttrValue::VarLenString`): fixed-length ones come back
//! as `bytes` in h5py.

use std::path::Path;

use hdf5_pure::{AttrValue, FileBuilder};

use super::atomic::AtomicFile;
use super::cycles::cycle_table;
use super::table::text_attr as vstr;
use super::timeseries::{events_table, TimeSeriesWriter};
use super::OutputError;
use crate::dynamics::types::RunResult;
use crate::scenario::Scenario;

/// Version of the layout above, stored as the root attribute `layout_version`.
pub const LAYOUT_VERSION: i64 = 1;

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

    // Datasets at the root: the time series (chunking and compression: `output::table`).
    series.table().write_hdf5(&mut b);

    let mut g = b.create_group("events");
    g.set_attr(
        "description",
        vstr("located events: kind, time, stage and the state at the event"),
    );
    events_table(&result.events).write_hdf5(&mut g);
    b.add_group(g.finish());

    let table = cycle_table(&result.cycles);
    let mut g = b.create_group("cycles");
    g.set_attr(
        "description",
        vstr("exact averages and first harmonics over each base period while the shaker is on"),
    );
    g.set_attr("count", AttrValue::I64(table.rows() as i64));
    if !table.is_empty() {
        table.write_hdf5(&mut g);
    }
    b.add_group(g.finish());
    b.finish().map_err(|e| e.to_string())
}

/// Stage the run's HDF5 file as `path` (written under its partial name; [`super::RunWriter`]
/// commits it with the other files).
pub fn write_hdf5(
    path: &Path,
    series: &TimeSeriesWriter,
    scenario: &Scenario,
    result: &RunResult,
) -> Result<AtomicFile, OutputError> {
    let bytes = hdf5_bytes(series, scenario, result).map_err(|message| OutputError::Hdf5 {
        path: path.to_path_buf(),
        message,
    })?;
    AtomicFile::write(path, &bytes)
}
