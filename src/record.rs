//! A run kept in memory ([`RunRecord`]): what [`crate::api::run`] returns and what an error of a
//! run that ended early carries ([`crate::error::Error::Ended`]).

use std::path::PathBuf;

use djkr_core::dynamics::{Event, RunResult};

use crate::output::table::Table;
use crate::output::OutputPaths;

/// A run kept in memory: the tables of its `run.h5` (time series, events, period records), its
/// result and its `summary.json`.
#[derive(Debug)]
pub struct RunRecord {
    /// The time series: the `SERIES` columns of [`crate::output::timeseries`], then `stage`.
    pub series: Table,
    /// Every event, in time order.
    pub events: Vec<Event>,
    /// The period records (the HDF5 `cycles/` group's columns).
    pub cycles: Table,
    /// The gaps of the time series (the HDF5 `gaps/` group's columns,
    /// `crate::output::timeseries::gaps_table`).
    pub gaps: Table,
    /// The run's result.
    pub result: RunResult,
    /// The text of `summary.json`: the file written into the run folder, or without one the
    /// same text with empty `files` and `file_bytes`.
    pub summary: String,
    /// The files written, when a run folder was asked for.
    pub files: Option<OutputPaths>,
    /// The run's figure (`run.png`, `run.svg`), when `[output] plot = true`.
    pub plots: Vec<PathBuf>,
}
