//! The names and sizes of a run's files: the file names `djkr run` publishes in its folder, the
//! lock it holds there, and the row counts at which its writer streams and appends.

/// File name of the HDF5 run file.
pub(crate) const HDF5_NAME: &str = "run.h5";
/// File name of the JSON summary.
pub(crate) const SUMMARY_NAME: &str = "summary.json";
/// File name of the time-series CSV.
pub(crate) const TIMESERIES_CSV_NAME: &str = "timeseries.csv";
/// File name of the events CSV.
pub(crate) const EVENTS_CSV_NAME: &str = "events.csv";
/// File name of the per-cycle CSV.
pub(crate) const CYCLES_CSV_NAME: &str = "cycles.csv";
/// File name of the gaps CSV (the HDF5 `/gaps` group).
pub(crate) const GAPS_CSV_NAME: &str = "gaps.csv";
/// The lock file a run writer holds in its output directory.
pub(crate) const LOCK_NAME: &str = ".djkr.lock";

/// The CSV files, written together on request.
pub(super) const CSV_NAMES: [&str; 3] = [TIMESERIES_CSV_NAME, EVENTS_CSV_NAME, CYCLES_CSV_NAME];

/// Samples buffered before a run switches to streaming (13 columns × 8 bytes: ≈ 3.4 MB): a run
/// longer than one chunk streams, so that its writer thread starts early.
pub const SPILL_ROWS: usize = 1 << 15;
/// Samples per append once streaming (one chunk of every time-series dataset).
pub(crate) const FLUSH_ROWS: usize = 1 << 15;
