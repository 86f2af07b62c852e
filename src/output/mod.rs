//! Output: the one table writer (`table`: CSV and HDF5) and the one atomic writer (`AtomicFile`)
//! every command uses, and the writers of `djkr run`: the HDF5 run file, `summary.json` and, on
//! request, CSV.
//!
//! [`RunWriter`] (module `run`) is an [`Observer`]: hand it to the driver, which streams samples,
//! events and period records into it, then call [`RunWriter::finish`] with the [`RunResult`].
//!
//! **Memory independent of run length.** The writer buffers rows in memory up to
//! [`SPILL_ROWS`] samples (≈ 3 MB). A run that stays below is written at the end in one piece.
//! A longer one switches to streaming (module `stream`): the HDF5 file is created with
//! extendable chunked datasets, and a writer thread builds the samples of each step and appends
//! them, the events and the period records to it (and to the CSV files) a whole chunk at a time,
//! so memory stays bounded however long the run, and the integration goes on meanwhile. The
//! event kinds (one byte per event; `solver.max_events` bounds them) are written when the run
//! ends, as are the results. Both ways give files of the same content (`hdf5_file` has the
//! layout).
//!
//! **Atomic output.** Every file is written under a hidden partial name of its own, created new
//! and never through a symbolic link (`DIR/.run.h5.<run_id>.XXXXXX.partial`, ...: `AtomicFile`),
//! and renamed into place only when the run has ended, `summary.json` last: its presence marks
//! complete files, and it records the size of every other file of the run (`file_bytes`) and
//! how the run ended (`status`: a run stopped by a budget or failed mid-way is published by
//! [`RunWriter::finish_with`]). A run that is killed, or whose writer is dropped without
//! finishing, leaves no `run.h5`/`summary.json` of its own, and files of an earlier complete run
//! in the directory stay untouched. A writer holds an exclusive lock on
//! `DIR/.djkr.lock` from [`RunWriter::create`] to its end, so a second run into the same
//! directory fails at once, naming the directory and the holder's process id, instead of
//! interleaving; the lock file records the partials the holder created, and the next holder
//! removes those a killed run left behind. Files djkr did not write are never removed or
//! replaced (`folder`: a name the run would publish that holds a file of the user's is refused
//! before the run, unless `--force`); an earlier run's CSV files stay when this run writes none
//! (`files` in summary.json lists this run's).
//!
//! **Disk space** (`disk`). A run whose certain samples (the stages with a fixed duration)
//! would not fit on the folder's disk is refused before it starts; while a run streams, the
//! writer watches the free space and stops the run (`status` `stopped`, `reason` `disk`) while
//! what it must still write fits, so that it publishes complete files of what it computed.
//!
//! **What is flushed when.** By default nothing is `fsync`ed: a rename makes each file appear
//! whole or not at all to every process, so a killed or crashed djkr (time limit, out of memory,
//! Ctrl-C, a panic) never leaves a file that looks complete but is not. Only a crash of the
//! machine itself (kernel, power) within the kernel's write-back delay (~30 s) can lose data that
//! a rename already published; a reader detects that from `summary.json` (missing, not valid
//! JSON, or `file_bytes` disagreeing with the files). `[output] fsync = true` syncs every file
//! and the directory before the run counts as written (about 3.5 ms per file on the reference
//! machine) for runs whose output must survive a power loss.
//!
//! File layouts: `hdf5_file` (HDF5), `SummaryFiles` (JSON and its non-finite rule); the four CSV
//! files are the tables of the HDF5 file ([`timeseries`], `timeseries::events_table`,
//! `cycles`, `timeseries::gaps_table`) written by `table`, which writes every table of djkr (runs, resonance sweeps,
//! shortcut maps, accuracy studies, figures), and every file goes to disk through `AtomicFile`.
//!
//! [`Observer`]: djkr_core::dynamics::Observer
//! [`RunResult`]: djkr_core::dynamics::RunResult
//! `AtomicFile`: atomic::AtomicFile
//! `SummaryFiles`: summary::SummaryFiles

pub(crate) mod atomic;
pub(crate) mod cycles;
pub(crate) mod disk;
mod error;
pub(crate) mod folder;
pub(crate) mod hdf5_file;
mod names;
mod run;
mod stream;
pub(crate) mod summary;
pub(crate) mod table;
pub mod timeseries;

pub use error::OutputError;
pub(crate) use folder::write_atomic;
pub(crate) use names::HDF5_NAME;
pub use names::SPILL_ROWS;
pub(crate) use run::{gaps_section, new_run_id};
pub use run::{OutputPaths, RunWriter};
pub use table::{Column, Data, Field, Table};
pub use timeseries::TimeSeriesWriter;

/// The tests' tools (installing h5py and Python packages, reading descriptions back, the
/// generated chapters of the docs), shared with the integration tests.
#[cfg(test)]
#[path = "../../tests/tools/mod.rs"]
pub(crate) mod test_tools;

#[cfg(test)]
mod tests;
