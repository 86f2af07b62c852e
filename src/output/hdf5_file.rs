//! Every HDF5 file djkr writes is assembled here, the one module that writes with `hdf5-pure`:
//! the run file (below), the files of tables ([`hdf5_tables`]: `sweep.h5`, `resonance.h5`,
//! `branch.h5`, the shortcut maps) and the table writer they share ([`TableHdf5`]).
//! Callers give tables ([`super::table::Table`]) and root attributes ([`Attr`]); none of them
//! names an `hdf5-pure` type.
//!
//! A table is one dataset per column in a group (or the root), with a variable-length UTF-8
//! string attribute `units` (fixed-length strings come back as `bytes` in h5py). The
//! descriptions of every dataset and group of a file are rows of one table, the group
//! `/descriptions` ([`Descriptions`]: datasets `path` and `text`), not attributes: hdf5-pure 0.47
//! as released gives each variable-length string attribute a global-heap collection of its own,
//! 4 KiB at least, while a string dataset packs its strings into shared ones (with one
//! `description` attribute per dataset a 1 s run file held ~200 kB of them; the vendored copy,
//! `vendor/hdf5-pure`, shares them for attributes too). Numeric columns are chunked by
//! one rule, [`HDF5_CHUNK`] elements (a shorter column is one chunk of its length), shuffled
//! and deflated at [`DEFLATE_LEVEL`]; an empty numeric column is an empty dataset of its type;
//! text columns are variable-length string datasets.
//!
//! The run file:
//!
//! Why `hdf5-pure`: it is pure Rust, so `cargo build` on a fresh machine needs no libhdf5, no
//! cmake and no C toolchain (the bindings to the C library either link a system libhdf5, which
//! then must exist at run time, or build it from source with cmake ≥ 3.26). Its files are read
//! bit-exactly by h5py and by h5dump (src/output/tests.rs checks with both when they are installed).
//! It is young and has one maintainer; the file layout below uses only its well-trodden parts
//! (1-D f64/i64 datasets, contiguous or chunked, optionally with shuffle + deflate, appends to
//! chunked datasets, variable-length string attributes and variable-length string datasets).
//! Every group of datasets is a [`super::table::Table`] written by
//! [`TableHdf5::write_hdf5_with`], the writer of every djkr table.
//!
//! Storage: a run written at the end ([`hdf5_bytes`]) has contiguous datasets, or chunked and
//! deflated ones with `[output] compress = true`; a streamed run ([`H5Stream`]) has extendable
//! datasets chunked by [`HDF5_CHUNK`] (time series) and [`RECORD_CHUNK`] (events, periods)
//! elements. Readers see the same content either way (src/output/tests.rs checks with h5py).
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
//! shared collections: 30 kB of that file are not dataset storage (src/output/tests.rs checks
//! ≤ 200 kB).

use std::ops::Range;
use std::path::{Path, PathBuf};

use hdf5_pure::{
    make_f64_type, make_i64_type, AttrValue, DatasetBuilder, File, FileAccessProperties,
    FileBuilder, GroupBuilder, SyncPolicy,
};

use super::cycles::{cycle_schema, HARMONIC_CONVENTION};
use super::error::OutputError;
use super::table::{Column, Data, Descriptions, Kind, Table, DESCRIPTIONS_GROUP};
use super::timeseries::{events_table, gaps_table, TimeSeriesWriter, GAPS_DESCRIPTION};
use crate::scenario::Scenario;
use djkr_core::dynamics::RunResult;

/// Version of the layout above, stored as the root attribute `layout_version`. 2: the
/// descriptions moved from a `description` attribute per dataset and group to the table
/// `/descriptions`, and the root attribute `harmonics` was added.
pub const LAYOUT_VERSION: i64 = 2;

/// Elements per chunk of a numeric HDF5 dataset (32 Ki f64 = 256 KiB). Must stay below 65536:
/// hdf5-pure 0.47 encodes a chunk dimension of 65536 or more in a form libhdf5 rejects ("stored
/// chunk dimension encoding length does not match"), while its own reader accepts it.
pub const HDF5_CHUNK: usize = 1 << 15;

/// Deflate level of numeric HDF5 datasets (after the shuffle filter). Measured on a synthetic
/// 10⁶-sample run (96 MB raw, release build): level 1 gives 47.9 MB in 0.8 s, level 4 gives
/// 46.5 MB in 3.3 s; shuffled doubles gain little from harder compression.
pub const DEFLATE_LEVEL: u32 = 1;

/// A root attribute as djkr writes it (what callers give [`hdf5_tables`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Attr {
    /// Text, stored as a variable-length UTF-8 string (h5py reads it as `str`).
    Text(String),
    /// A 64-bit float.
    F64(f64),
    /// A 64-bit integer (counts, flags 0/1).
    I64(i64),
}

impl Attr {
    /// A text attribute.
    pub fn text(s: &str) -> Attr {
        Attr::Text(s.to_string())
    }

    fn value(&self) -> AttrValue {
        match self {
            Attr::Text(s) => text_attr(s),
            Attr::F64(x) => AttrValue::F64(*x),
            Attr::I64(x) => AttrValue::I64(*x),
        }
    }
}

/// Elements per chunk of the extendable event and cycle datasets of a streamed file (the time
/// series uses [`HDF5_CHUNK`]).
pub const RECORD_CHUNK: usize = 1024;

const EVENTS_DESCRIPTION: &str = "located events: kind, time, stage and the state at the event";
const CYCLES_DESCRIPTION: &str =
    "exact averages and first harmonics over each base period while the shaker is on";

/// The HDF5 form of a table (layout in the module doc): the writer's methods on [`Table`],
/// kept here rather than in `output::table` so that the table stays free of any file format.
pub trait TableHdf5 {
    /// Write every column as a dataset of `group` (a file's root or a group), with a `units`
    /// attribute (chunking and compression in the module doc).
    fn write_hdf5(&self, group: &mut impl Hdf5Group);

    /// As [`TableHdf5::write_hdf5`], with a storage choice: compressed or not, and extendable
    /// (every numeric dataset chunked, unlimited, so that rows can be appended:
    /// [`TableHdf5::append_hdf5_rows`]; text columns are then left out, to be written whole at
    /// the end).
    fn write_hdf5_with(&self, group: &mut impl Hdf5Group, storage: Storage);

    /// As [`TableHdf5::write_hdf5_with`], into a group of a file open for editing (a table
    /// whose first rows arrive after the file was created).
    fn create_hdf5_in(&self, group: &hdf5_pure::Group, storage: Storage) -> Result<(), String>;

    /// Append the rows in `rows` to the extendable datasets of the open file `file` under
    /// `prefix` (`""` for the root, `"events/"`, ...), one dataset per numeric column (text
    /// columns are skipped).
    fn append_hdf5_rows(
        &self,
        file: &hdf5_pure::File,
        prefix: &str,
        rows: Range<usize>,
    ) -> Result<(), String>;
}

/// The columns a table writes under `storage` (text columns are left out of extendable
/// datasets).
fn stored_columns(t: &Table, storage: Storage) -> impl Iterator<Item = &Column> {
    t.columns()
        .iter()
        .filter(move |c| storage.extendable.is_none() || c.data.kind() != Kind::Text)
}

impl TableHdf5 for Table {
    fn write_hdf5(&self, group: &mut impl Hdf5Group) {
        self.write_hdf5_with(group, Storage::default());
    }

    fn write_hdf5_with(&self, group: &mut impl Hdf5Group, storage: Storage) {
        for c in stored_columns(self, storage) {
            configure_dataset(group.create_dataset(&c.name), c, storage);
        }
    }

    fn create_hdf5_in(&self, group: &hdf5_pure::Group, storage: Storage) -> Result<(), String> {
        for c in stored_columns(self, storage) {
            group
                .create_dataset(&c.name, |ds| configure_dataset(ds, c, storage))
                .map_err(|e| format!("creating {}: {e}", c.name))?;
        }
        Ok(())
    }

    fn append_hdf5_rows(
        &self,
        file: &hdf5_pure::File,
        prefix: &str,
        rows: Range<usize>,
    ) -> Result<(), String> {
        if rows.is_empty() {
            return Ok(());
        }
        for c in self.columns() {
            let name = format!("{prefix}{}", c.name);
            let result = match &c.data {
                Data::F64(v) => file
                    .dataset(&name)
                    .and_then(|mut d| d.append(&v[rows.clone()])),
                Data::I64(v) => file
                    .dataset(&name)
                    .and_then(|mut d| d.append(&v[rows.clone()])),
                _ => Ok(()),
            };
            result.map_err(|e| format!("appending to {name}: {e}"))?;
        }
        Ok(())
    }
}

/// How a table's numeric columns are stored in HDF5.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Storage {
    /// Shuffle + deflate ([`DEFLATE_LEVEL`]).
    pub compress: bool,
    /// Extendable (unlimited, chunked with this many elements per chunk) so that rows can be
    /// appended during a run; `None`: written once.
    pub extendable: Option<usize>,
}

impl Default for Storage {
    fn default() -> Self {
        Self {
            compress: true,
            extendable: None,
        }
    }
}

/// One column's dataset: data, layout (written once, or extendable) and attributes.
fn configure_dataset(ds: &mut DatasetBuilder, c: &Column, storage: Storage) {
    match (&c.data, storage.extendable) {
        (Data::F64(v), Some(chunk)) => {
            ds.with_f64_data(v).with_shape(&[v.len() as u64]);
            make_extendable(ds, chunk, storage.compress);
        }
        (Data::I64(v), Some(chunk)) => {
            ds.with_i64_data(v).with_shape(&[v.len() as u64]);
            make_extendable(ds, chunk, storage.compress);
        }
        _ => write_fixed(ds, &c.data, storage.compress),
    }
    ds.set_attr("units", text_attr(&c.unit));
}

fn make_extendable(ds: &mut DatasetBuilder, chunk: usize, compressed: bool) {
    ds.with_maxshape(&[hdf5_pure::MaxExtent::Unlimited])
        .with_chunks(&[chunk as u64]);
    if compressed {
        ds.with_shuffle().with_deflate(DEFLATE_LEVEL);
    }
}

/// A column written once: the module doc's layout.
fn write_fixed(ds: &mut DatasetBuilder, data: &Data, compressed: bool) {
    match data {
        Data::F64(v) if v.is_empty() => {
            ds.with_dtype(make_f64_type()).with_shape(&[0]);
        }
        Data::F64(v) => {
            ds.with_f64_data(v);
            if compressed {
                compress(ds, v.len());
            }
        }
        Data::I64(v) if v.is_empty() => {
            ds.with_dtype(make_i64_type()).with_shape(&[0]);
        }
        Data::I64(v) => {
            ds.with_i64_data(v);
            if compressed {
                compress(ds, v.len());
            }
        }
        Data::Text(v) => {
            let refs: Vec<&str> = v.iter().map(String::as_str).collect();
            ds.with_vlen_strings(&refs);
        }
    }
}

fn compress(ds: &mut DatasetBuilder, len: usize) {
    let chunk = len.min(HDF5_CHUNK) as u64;
    ds.with_chunks(&[chunk])
        .with_shuffle()
        .with_deflate(DEFLATE_LEVEL);
}

/// A variable-length UTF-8 string attribute (h5py reads it as `str`).
fn text_attr(s: &str) -> AttrValue {
    AttrValue::VarLenString(s.to_string())
}

/// Where a table's datasets go: the root of a file, or a group.
pub trait Hdf5Group {
    /// Create dataset `name` here.
    fn create_dataset(&mut self, name: &str) -> &mut DatasetBuilder;
}

impl Hdf5Group for FileBuilder {
    fn create_dataset(&mut self, name: &str) -> &mut DatasetBuilder {
        FileBuilder::create_dataset(self, name)
    }
}

impl Hdf5Group for GroupBuilder {
    fn create_dataset(&mut self, name: &str) -> &mut DatasetBuilder {
        GroupBuilder::create_dataset(self, name)
    }
}

/// Write the group `/descriptions` holding `d` into the file being built.
pub fn write_descriptions(d: &Descriptions, b: &mut FileBuilder) {
    let mut g = b.create_group(DESCRIPTIONS_GROUP);
    d.to_table().write_hdf5(&mut g);
    b.add_group(g.finish());
}

/// The [`Descriptions`] of a file written by djkr (read back, for the tests).
#[cfg(test)]
pub fn read_descriptions(f: &hdf5_pure::File) -> Result<Descriptions, String> {
    let read = |name: &str| {
        f.dataset(&format!("{DESCRIPTIONS_GROUP}/{name}"))
            .and_then(|d| d.read_string())
            .map_err(|e| format!("/{DESCRIPTIONS_GROUP}/{name}: {e}"))
    };
    let (paths, texts) = (read("path")?, read("text")?);
    if paths.len() != texts.len() {
        return Err(format!(
            "/{DESCRIPTIONS_GROUP}: {} paths but {} texts",
            paths.len(),
            texts.len()
        ));
    }
    let mut d = Descriptions::new();
    for (path, text) in paths.iter().zip(&texts) {
        d.add(path, text);
    }
    Ok(d)
}

/// An HDF5 file of tables: root attributes (`djkr_version` first, then `root_attrs`), the
/// columns of `root` at the root, then one group per table of `groups` (`name`, description,
/// table: one dataset per column), and the [`Descriptions`] of the groups and their datasets.
/// Returns the file's bytes, or hdf5-pure's message.
pub fn hdf5_tables(
    root_attrs: &[(&str, Attr)],
    root: Option<&Table>,
    groups: &[(&str, &str, &Table)],
) -> Result<Vec<u8>, String> {
    let mut b = FileBuilder::new();
    b.set_attr("djkr_version", text_attr(env!("CARGO_PKG_VERSION")));
    for (k, v) in root_attrs {
        b.set_attr(k, v.value());
    }
    let mut descriptions = Descriptions::new();
    if let Some(table) = root {
        table.write_hdf5(&mut b);
        descriptions.table("/", &table.schema());
    }
    for (name, description, table) in groups {
        let mut g = b.create_group(name);
        table.write_hdf5(&mut g);
        b.add_group(g.finish());
        let path = format!("/{name}");
        descriptions
            .add(&path, description)
            .table(&path, &table.schema());
    }
    write_descriptions(&descriptions, &mut b);
    b.finish().map_err(|e| e.to_string())
}

/// Root attributes known when the run starts.
fn start_attrs(scenario: &Scenario, run_id: &str) -> Vec<(&'static str, AttrValue)> {
    vec![
        ("layout_version", AttrValue::I64(LAYOUT_VERSION)),
        ("djkr_version", text_attr(env!("CARGO_PKG_VERSION"))),
        ("run_id", text_attr(run_id)),
        ("source", text_attr(&scenario.source_name)),
        ("scenario", text_attr(&scenario.source_text)),
        ("harmonics", text_attr(HARMONIC_CONVENTION)),
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
        ("method", text_attr(&result.method)),
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

/// Serialise a whole run at once (layout in the module doc): the tests compare it with the
/// file the streaming writer builds.
#[cfg(test)]
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
    write_descriptions(&run_descriptions(), &mut b);
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
    /// one can plant: [`super::atomic::AtomicFile`]), with its datasets empty (the period datasets are
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
        write_descriptions(&run_descriptions(), &mut b);
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
                d.set_attr("units", text_attr(""));
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

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Table {
        Table::from_columns(vec![
            Column::text("kind", "what", vec!["a,b".into(), "say \"x\"".into()]),
            Column::f64("t", "s", "time", vec![0.5, f64::NAN]),
            Column::i64("stage", "1", "index", vec![0, 3]),
        ])
        .unwrap()
    }

    #[test]
    fn hdf5_round_trip_with_units() {
        let mut t = sample();
        let n = HDF5_CHUNK + 5;
        let mut big = Table::from_columns(vec![Column::f64(
            "x",
            "m",
            "long",
            (0..n).map(|i| i as f64 * 0.1).collect(),
        )])
        .unwrap();
        t.append_rows(&sample()).unwrap();
        let bytes = hdf5_tables(
            &[("source", Attr::text("test"))],
            None,
            &[("g", "group", &t), ("big", "long", &big)],
        )
        .unwrap();
        let f = hdf5_pure::File::from_bytes(bytes).unwrap();
        let ds = f.dataset("g/t").unwrap();
        assert_eq!(ds.attrs().unwrap()["units"].as_str(), Some("s"));
        // Descriptions are rows of /descriptions, not attributes (one heap collection each).
        assert!(!ds.attrs().unwrap().contains_key("description"));
        let d = read_descriptions(&f).unwrap();
        assert_eq!(d.get("/g/t"), Some("time"));
        assert_eq!(d.get("/g/kind"), Some("what"));
        assert_eq!(d.get("/g"), Some("group"));
        assert_eq!(d.get("/big/x"), Some("long"));
        assert!(d.get("/descriptions/text").is_some());
        assert_eq!(ds.read_f64().unwrap()[2].to_bits(), 0.5f64.to_bits());
        assert_eq!(
            f.dataset("g/kind").unwrap().read_string().unwrap()[1],
            "say \"x\""
        );
        assert_eq!(f.dataset("big/x").unwrap().read_f64().unwrap().len(), n);
        big = Table::from_schema(&big.schema()).unwrap();
        let bytes = hdf5_tables(&[], None, &[("e", "empty", &big)]).unwrap();
        let f = hdf5_pure::File::from_bytes(bytes).unwrap();
        assert!(f.dataset("e/x").unwrap().read_f64().unwrap().is_empty());
    }
}
