//! The HDF5 run file, written with `hdf5-pure`.
//!
//! Why `hdf5-pure`: it is pure Rust, so `cargo build` on a fresh machine needs no libhdf5, no
//! cmake and no C toolchain (the bindings to the C library either link a system libhdf5, which
//! then must exist at run time, or build it from source with cmake ≥ 3.26). Its files are read
//! bit-exactly by h5py and by h5dump (tests/output.rs checks with both when they are installed).
//! It is young and has one maintainer; the file layout below uses only its well-trodden parts
//! (1-D f64/i64 datasets, contiguous or chunked, optionally with shuffle + deflate, appends to
//! chunked datasets, variable-length string attributes and variable-length string datasets).
//! Every group of datasets is a [`super::table::Table`] written by
//! [`super::table::Table::write_hdf5_with`], the writer of every djkr table.
//!
//! Storage: a run written at the end ([`hdf5_bytes`]) has contiguous datasets, or chunked and
//! deflated ones with `[output] compress = true`; a streamed run ([`H5Stream`]) has extendable
//! datasets chunked by [`HDF5_CHUNK`] (time series) and [`RECORD_CHUNK`] (events, periods)
//! elements. Readers see the same content either way (tests/output.rs checks with h5py).
//!
//! Layout:
//!
//! ```text
//! /                 attrs: layout_version (i64), djkr_version, run_id (as in summary.json),
//!                          source, scenario (the file's text), harmonics (the convention of
//!                          the cycles' mean/sin/cos fields: `output::cycles::HARMONIC_CONVENTION`),
//!                          method, detached (i64 0/1), pull_off_force (N),
//!                          pull_off_amplification (1), pull_off_time (s),
//!                          steps, rejected, rhs_evals (u64), wall_s (s)
//! /t, /x_s, /v_s, /x_b, /x_k, /delta, /a, /a_dot, /F, /G, /w    f64[n]   attrs: units
//! /stage, /segment                                               i64[n]   attrs: units
//!                   (segment: 0 from the start, +1 after each gap of the time series)
//! /events/kind      variable-length strings (impact, contact-loss, pull-off, ...)
//! /events/time      f64[m] (s)     /events/stage   i64[m]
//! /events/x_s ... /events/w        f64[m]: the state at each event (same names as above)
//! /cycles           attrs: count; one dataset per CycleRecord field (index, stage: i64; the rest
//!                   f64), attrs units (`output::cycles::CYCLE_FIELDS`); no datasets when the
//!                   run recorded no cycle
//! /gaps             attrs: count; t_start, t_end f64[g] (s), periods i64[g]: the spans envelope
//!                   following skipped, each between two consecutive samples (empty datasets
//!                   when the time series has no gap)
//! /descriptions/path, /descriptions/text   strings: the description of every dataset and group
//!                   above, one row each (`/cycles/a_cos` → its definition), [`run_descriptions`]
//! ```
//!
//! All strings are variable-length UTF-8 (`AttrValue::VarLenString`): fixed-length ones come back
//! as `bytes` in h5py. Descriptions are a table rather than attributes because hdf5-pure 0.47 as
//! released gives each variable-length string attribute a 4 KiB global-heap collection of its own:
//! with a `description` next to every `units`, a 1 s run's file held 448 kB that were not dataset
//! storage. The vendored hdf5-pure (`vendor/hdf5-pure/README-djkr.md`) packs the attributes into
//! shared collections: 30 kB of that file are not dataset storage (tests/output.rs checks
//! ≤ 200 kB).

use std::ops::Range;
use std::path::{Path, PathBuf};

use hdf5_pure::{AttrValue, File, FileAccessProperties, FileBuilder, SyncPolicy};

use super::cycles::{cycle_schema, HARMONIC_CONVENTION};
use super::table::{text_attr as vstr, Descriptions, Storage, Table, HDF5_CHUNK};
use super::timeseries::{events_table, gaps_table, TimeSeriesWriter, GAPS_DESCRIPTION};
use super::OutputError;
use crate::dynamics::RunResult;
use crate::scenario::Scenario;

/// Version of the layout above, stored as the root attribute `layout_version`. 2: the
/// descriptions moved from a `description` attribute per dataset and group to the table
/// `/descriptions`, and the root attribute `harmonics` was added.
pub const LAYOUT_VERSION: i64 = 2;

/// Elements per chunk of the extendable event and cycle datasets of a streamed file (the time
/// series uses [`HDF5_CHUNK`]).
pub const RECORD_CHUNK: usize = 1024;

const EVENTS_DESCRIPTION: &str = "located events: kind, time, stage and the state at the event";
const CYCLES_DESCRIPTION: &str =
    "exact averages and first harmonics over each base period while the shaker is on";

/// Root attributes known when the run starts.
fn start_attrs(scenario: &Scenario, run_id: &str) -> Vec<(&'static str, AttrValue)> {
    vec![
        ("layout_version", AttrValue::I64(LAYOUT_VERSION)),
        ("djkr_version", vstr(env!("CARGO_PKG_VERSION"))),
        ("run_id", vstr(run_id)),
        ("source", vstr(&scenario.source_name)),
        ("scenario", vstr(&scenario.source_text)),
        ("harmonics", vstr(HARMONIC_CONVENTION)),
    ]
}

/// The descriptions of every dataset and group of a run file (the group `/descriptions`): those
/// of the time series, the events and the period records, from their schemas, whether or not the
/// run recorded a period (the streamed file knows them before the first period arrives).
///
/// A dataset added to the run file gets its row here: from its table's schema
/// (`d.table("/group", &schema)`) or by hand (`d.add("/group/name", "text")`).
pub fn run_descriptions() -> Descriptions {
    let mut d = Descriptions::new();
    d.table("/", &TimeSeriesWriter::new().table().schema())
        .add("/events", EVENTS_DESCRIPTION)
        .table("/events", &events_table(&[]).schema())
        .add("/cycles", CYCLES_DESCRIPTION)
        .table("/cycles", &cycle_schema())
        .add("/gaps", GAPS_DESCRIPTION)
        .table("/gaps", &gaps_table(&[]).schema());
    d
}

/// Root attributes of the finished run.
fn result_attrs(result: &RunResult) -> Vec<(&'static str, AttrValue)> {
    vec![
        ("method", vstr(&result.method)),
        ("detached", AttrValue::I64(i64::from(result.detached))),
        ("pull_off_force", AttrValue::F64(result.pull_off.force)),
        (
            "pull_off_amplification",
            AttrValue::F64(result.pull_off.amplification),
        ),
        ("pull_off_time", AttrValue::F64(result.pull_off.time)),
        ("steps", AttrValue::U64(result.stats.steps)),
        ("rejected", AttrValue::U64(result.stats.rejected)),
        ("rhs_evals", AttrValue::U64(result.stats.rhs_evals)),
        ("wall_s", AttrValue::F64(result.stats.wall_s)),
    ]
}

/// The tables of a run: the time series, the events (with their `kind` text column) and the
/// period records.
#[derive(Debug, Clone, Copy)]
pub struct RunTables<'a> {
    /// Samples.
    pub series: &'a Table,
    /// Events.
    pub events: &'a Table,
    /// Period records.
    pub cycles: &'a Table,
    /// Gaps of the time series ([`super::timeseries::gaps_table`]).
    pub gaps: &'a Table,
}

/// Serialise a whole run at once (layout in the module doc).
pub fn hdf5_bytes(
    tables: RunTables,
    scenario: &Scenario,
    run_id: &str,
    result: &RunResult,
    compress: bool,
) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    write_hdf5(tables, scenario, run_id, result, compress, &mut bytes)
        .map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// [`hdf5_bytes`] written into `w` front to back as it is laid out, without the file's image in
/// memory (hdf5-pure's `finish_to`: the same bytes). An error of the HDF5 encoder comes back as
/// an I/O error whose text says so.
pub fn write_hdf5(
    tables: RunTables,
    scenario: &Scenario,
    run_id: &str,
    result: &RunResult,
    compress: bool,
    w: impl std::io::Write,
) -> std::io::Result<()> {
    let mut b = FileBuilder::new();
    for (k, v) in start_attrs(scenario, run_id)
        .into_iter()
        .chain(result_attrs(result))
    {
        b.set_attr(k, v);
    }
    let storage = Storage {
        compress,
        extendable: None,
    };
    tables.series.write_hdf5_with(&mut b, storage);
    let mut g = b.create_group("events");
    tables.events.write_hdf5_with(&mut g, storage);
    b.add_group(g.finish());
    let mut g = b.create_group("cycles");
    g.set_attr("count", AttrValue::I64(tables.cycles.rows() as i64));
    if !tables.cycles.is_empty() {
        tables.cycles.write_hdf5_with(&mut g, storage);
    }
    b.add_group(g.finish());
    let mut g = b.create_group("gaps");
    g.set_attr("count", AttrValue::I64(tables.gaps.rows() as i64));
    tables.gaps.write_hdf5_with(&mut g, storage);
    b.add_group(g.finish());
    run_descriptions().write(&mut b);
    b.finish_to(w).map_err(|e| match e {
        hdf5_pure::Error::Io(io) => io,
        other => std::io::Error::other(format!("HDF5 writer: {other}")),
    })
}

/// A run file written while the run goes on: created with empty extendable datasets, then
/// appended to, and finished with the event kinds and the results. Its content is
/// that of [`hdf5_bytes`] for the same rows (the period datasets appear with the first period,
/// the event kinds at the end).
pub struct H5Stream {
    file: File,
    path: PathBuf,
    compress: bool,
    cycles_created: bool,
}

impl std::fmt::Debug for H5Stream {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("H5Stream")
            .field("path", &self.path)
            .finish()
    }
}

fn extendable(compress: bool, chunk: usize) -> Storage {
    Storage {
        compress,
        extendable: Some(chunk),
    }
}

impl H5Stream {
    /// Write the file at `path`, just created empty and open as `handle` (a partial of a name no
    /// one can plant: [`super::atomic`]), with its datasets empty (the period datasets are
    /// created with the first period record), and open it for appending. hdf5-pure syncs it
    /// once, when it is finished (`SyncPolicy::OnClose`).
    pub fn create(
        path: &Path,
        mut handle: std::fs::File,
        scenario: &Scenario,
        run_id: &str,
        compress: bool,
    ) -> Result<Self, OutputError> {
        let err = |e: hdf5_pure::Error| OutputError::Hdf5 {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let mut b = FileBuilder::new();
        for (k, v) in start_attrs(scenario, run_id) {
            b.set_attr(k, v);
        }
        TimeSeriesWriter::new()
            .table()
            .write_hdf5_with(&mut b, extendable(compress, HDF5_CHUNK));
        let mut g = b.create_group("events");
        events_table(&[]).write_hdf5_with(&mut g, extendable(compress, RECORD_CHUNK));
        b.add_group(g.finish());
        let g = b.create_group("cycles");
        b.add_group(g.finish());
        let g = b.create_group("gaps");
        b.add_group(g.finish());
        run_descriptions().write(&mut b);
        b.finish_to(&mut handle).map_err(err)?;
        drop(handle);
        let file = File::open_rw_with_options(
            path,
            FileAccessProperties::new().with_sync_policy(SyncPolicy::OnClose),
        )
        .map_err(err)?;
        Ok(Self {
            file,
            path: path.to_path_buf(),
            compress,
            cycles_created: false,
        })
    }

    /// Append the samples `rows` of `series`.
    pub fn append_series(&mut self, series: &Table, rows: Range<usize>) -> Result<(), OutputError> {
        series
            .append_hdf5_rows(&self.file, "", rows)
            .map_err(|message| OutputError::Hdf5 {
                path: self.path.clone(),
                message,
            })
    }

    /// Append rows of the events and of the period records (the period datasets are created
    /// with the first).
    pub fn append_records(
        &mut self,
        (events, event_rows): (&Table, Range<usize>),
        (cycles, cycle_rows): (&Table, Range<usize>),
    ) -> Result<(), OutputError> {
        let err = |message: String| OutputError::Hdf5 {
            path: self.path.clone(),
            message,
        };
        events
            .append_hdf5_rows(&self.file, "events/", event_rows)
            .map_err(err)?;
        if cycle_rows.is_empty() {
            return Ok(());
        }
        if self.cycles_created {
            return cycles
                .append_hdf5_rows(&self.file, "cycles/", cycle_rows)
                .map_err(err);
        }
        let group = self.file.group("cycles").map_err(|e| err(e.to_string()))?;
        Table::from_schema(&cycles.schema())
            .map_err(|e| err(e.to_string()))?
            .create_hdf5_in(&group, extendable(self.compress, RECORD_CHUNK))
            .map_err(err)?;
        // Datasets created in an open file are staged until committed; appends need them written.
        self.file.commit().map_err(|e| err(e.to_string()))?;
        self.cycles_created = true;
        cycles
            .append_hdf5_rows(&self.file, "cycles/", cycle_rows)
            .map_err(err)
    }

    /// Write the event kinds (`kinds`, one per event), the period count, the gaps (a
    /// [`super::timeseries::gaps_table`]) and the results, and close the file.
    pub fn finish(
        self,
        kinds: &[&str],
        cycle_count: u64,
        gaps: &Table,
        result: &RunResult,
    ) -> Result<(), OutputError> {
        let err = |e: hdf5_pure::Error| OutputError::Hdf5 {
            path: self.path.clone(),
            message: e.to_string(),
        };
        let events = self.file.group("events").map_err(err)?;
        events
            .create_dataset("kind", |d| {
                d.with_vlen_strings(kinds);
                d.set_attr("units", vstr(""));
            })
            .map_err(err)?;
        let root = self.file.root();
        for (k, v) in result_attrs(result) {
            root.set_attr(k, v).map_err(err)?;
        }
        self.file
            .group("cycles")
            .and_then(|g| g.set_attr("count", AttrValue::I64(cycle_count as i64)))
            .map_err(err)?;
        let group = self.file.group("gaps").map_err(err)?;
        group
            .set_attr("count", AttrValue::I64(gaps.rows() as i64))
            .map_err(err)?;
        gaps.create_hdf5_in(
            &group,
            Storage {
                compress: self.compress,
                extendable: None,
            },
        )
        .map_err(|message| OutputError::Hdf5 {
            path: self.path.clone(),
            message,
        })?;
        self.file.commit().map_err(err)?;
        self.file.close().map_err(err)
    }
}
