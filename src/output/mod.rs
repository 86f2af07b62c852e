//! Output: the one table writer ([`table`]: CSV and HDF5) and the one atomic writer ([`atomic`])
//! every command uses, and the writers of `djkr run`: the HDF5 run file, `summary.json` and, on
//! request, CSV.
//!
//! [`RunWriter`] is an [`Observer`]: hand it to the driver, which streams samples and events into
//! it, then call [`RunWriter::finish`] with the [`RunResult`]. It buffers the run in memory
//! ([`TimeSeriesWriter`]; why, and the memory it takes, in [`timeseries`]) and writes the files
//! only at the end.
//!
//! **Atomic output.** Every file is first written in full to a hidden partial name in the output
//! directory (`.run.h5.partial`, `.summary.json.partial`, ...), flushed to disk, and only then
//! renamed into place, `summary.json` last. A run that fails, is interrupted, or whose writer is
//! dropped without [`RunWriter::finish`] (or given up with [`RunWriter::abort`]) leaves no
//! `run.h5`/`summary.json` of its own: partials are removed, and files of an earlier complete run
//! in the same directory stay untouched. A successful finish replaces the earlier run's files and,
//! when this run writes no CSV, removes an earlier run's `timeseries.csv`/`events.csv`/
//! `cycles.csv`, so the directory always describes one run. Two runs writing to the same directory at the same time are
//! not supported.
//!
//! The event lists in all files come from [`RunResult::events`], the driver's complete log (events
//! streamed to the observer are also buffered, see [`TimeSeriesWriter::events`]); the per-cycle
//! records from [`RunResult::cycles`] ([`cycles`]).
//!
//! File layouts: [`hdf5_file`] (HDF5), [`summary`] (JSON and its non-finite rule); the three CSV
//! files are the tables of the HDF5 file ([`timeseries`], [`timeseries::events_table`],
//! [`cycles`]) written by [`table`], which writes every table of djkr (runs, resonance sweeps,
//! shortcut maps, accuracy studies, figures), and every file goes to disk through [`atomic`].

pub mod atomic;
pub mod cycles;
pub mod hdf5_file;
pub mod summary;
pub mod table;
pub mod timeseries;

use std::fs::{self, File};
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::dynamics::types::{Event, Observer, RunResult, Sample};
use crate::scenario::Scenario;
pub use atomic::{write_atomic, AtomicFile};
pub use summary::SummaryFiles;
pub use table::{Column, Field, Table};
pub use timeseries::TimeSeriesWriter;

/// File name of the HDF5 run file.
pub const HDF5_NAME: &str = "run.h5";
/// File name of the JSON summary.
pub const SUMMARY_NAME: &str = "summary.json";
/// File name of the time-series CSV.
pub const TIMESERIES_CSV_NAME: &str = "timeseries.csv";
/// File name of the events CSV.
pub const EVENTS_CSV_NAME: &str = "events.csv";
/// File name of the per-cycle CSV.
pub const CYCLES_CSV_NAME: &str = "cycles.csv";

/// The CSV files, written together on request.
const CSV_NAMES: [&str; 3] = [TIMESERIES_CSV_NAME, EVENTS_CSV_NAME, CYCLES_CSV_NAME];

/// Why output could not be written.
#[derive(Debug, Error)]
pub enum OutputError {
    /// A file-system operation failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The HDF5 encoder refused the data.
    #[error("{}: HDF5 writer: {message}", path.display())]
    Hdf5 {
        /// The file being written.
        path: PathBuf,
        /// What hdf5-pure said.
        message: String,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The files a finished run wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputPaths {
    /// `DIR/run.h5`.
    pub hdf5: PathBuf,
    /// `DIR/summary.json`.
    pub summary: PathBuf,
    /// `DIR/timeseries.csv`, when CSV was requested.
    pub timeseries_csv: Option<PathBuf>,
    /// `DIR/events.csv`, when CSV was requested.
    pub events_csv: Option<PathBuf>,
    /// `DIR/cycles.csv`, when CSV was requested.
    pub cycles_csv: Option<PathBuf>,
}

impl OutputPaths {
    /// Every file written, in the order written.
    pub fn all(&self) -> Vec<&Path> {
        let mut v: Vec<&Path> = vec![self.hdf5.as_path()];
        v.extend(
            [&self.timeseries_csv, &self.events_csv, &self.cycles_csv]
                .into_iter()
                .flatten()
                .map(PathBuf::as_path),
        );
        v.push(self.summary.as_path());
        v
    }
}

/// Writes one run into an output directory (atomic: see the module doc).
#[derive(Debug)]
pub struct RunWriter {
    dir: PathBuf,
    scenario: Scenario,
    csv: bool,
    series: TimeSeriesWriter,
    finished: bool,
}

impl RunWriter {
    /// Prepare to write a run of `scenario` into `dir` (created if missing), with CSV files when
    /// `csv` is true. Fails early, before the run, when `dir` cannot be created or written.
    /// Partial files left there by an earlier, killed run are removed.
    pub fn create(dir: &Path, scenario: &Scenario, csv: bool) -> Result<Self, OutputError> {
        fs::create_dir_all(dir).map_err(io_err(dir))?;
        let writer = Self {
            dir: dir.to_path_buf(),
            scenario: scenario.clone(),
            csv,
            series: TimeSeriesWriter::new(),
            finished: false,
        };
        writer.remove_partials();
        // Probe that the directory is writable now rather than after a long run.
        let probe = writer.partial(HDF5_NAME);
        File::create(&probe).map_err(io_err(&probe))?;
        Ok(writer)
    }

    /// The output directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The buffered time series and events.
    pub fn series(&self) -> &TimeSeriesWriter {
        &self.series
    }

    fn partial(&self, name: &str) -> PathBuf {
        atomic::partial_path(&self.dir.join(name))
    }

    fn remove_partials(&self) {
        for name in [HDF5_NAME, SUMMARY_NAME].into_iter().chain(CSV_NAMES) {
            let p = self.partial(name);
            if p.exists() {
                let _ = fs::remove_file(p);
            }
        }
    }

    /// Write every file of the finished run and move them into place. On error nothing of this
    /// run is left in the directory (partials are removed) and the error names the file.
    pub fn finish(mut self, result: &RunResult) -> Result<OutputPaths, OutputError> {
        let outcome = self.write_all(result);
        if outcome.is_ok() {
            self.finished = true;
        }
        outcome
    }

    fn write_all(&self, result: &RunResult) -> Result<OutputPaths, OutputError> {
        // Every file is staged under its partial name first; an error drops the staged files,
        // which removes their partials.
        let mut staged: Vec<AtomicFile> = Vec::new();
        let target = |name: &str| self.dir.join(name);

        staged.push(hdf5_file::write_hdf5(
            &target(HDF5_NAME),
            &self.series,
            &self.scenario,
            result,
        )?);

        let mut files = SummaryFiles {
            hdf5: HDF5_NAME.to_string(),
            ..SummaryFiles::default()
        };
        if self.csv {
            let tables = [
                self.series.table(),
                &timeseries::events_table(&result.events),
                &cycles::cycle_table(&result.cycles),
            ];
            for (name, table) in CSV_NAMES.into_iter().zip(tables) {
                staged.push(AtomicFile::write_with(&target(name), |w| {
                    table.write_csv(w)
                })?);
            }
            files.timeseries_csv = Some(TIMESERIES_CSV_NAME.to_string());
            files.events_csv = Some(EVENTS_CSV_NAME.to_string());
            files.cycles_csv = Some(CYCLES_CSV_NAME.to_string());
        }

        let json = summary::summary_json(&self.scenario, result, self.series.len(), &files);
        // Last: its presence marks a complete run.
        staged.push(AtomicFile::write(&target(SUMMARY_NAME), json.as_bytes())?);

        for file in staged {
            file.commit()?;
        }
        if !self.csv {
            for name in CSV_NAMES {
                let stale = self.dir.join(name);
                if stale.exists() {
                    fs::remove_file(&stale).map_err(io_err(&stale))?;
                }
            }
        }
        atomic::sync_dir(&self.dir);
        let csv = |name: &str| self.csv.then(|| self.dir.join(name));
        Ok(OutputPaths {
            hdf5: self.dir.join(HDF5_NAME),
            summary: self.dir.join(SUMMARY_NAME),
            timeseries_csv: csv(TIMESERIES_CSV_NAME),
            events_csv: csv(EVENTS_CSV_NAME),
            cycles_csv: csv(CYCLES_CSV_NAME),
        })
    }

    /// Give up: remove this run's partial files (the same as dropping the writer).
    pub fn abort(self) {}
}

impl Drop for RunWriter {
    fn drop(&mut self) {
        if !self.finished {
            self.remove_partials();
        }
    }
}

impl Observer for RunWriter {
    fn sample(&mut self, s: &Sample) -> bool {
        self.series.push(s);
        true
    }
    fn event(&mut self, e: &Event) {
        self.series.event(e);
    }
    // Cycles are written from `RunResult::cycles` at finish; nothing to buffer here.
}
