//! Streaming a long run to disk: the rows buffered between two writes ([`Rows`]), the files of
//! a streamed run ([`Streaming`]) and the thread that writes them ([`Background`]).
//!
//! Once a run is long enough to stream ([`super::names::SPILL_ROWS`] samples), its files are created
//! (empty) and everything after is written on a thread of its own while the integration goes
//! on: the samples of each step travel as the step ([`StepSamples`]: its two end points and the
//! output grid) and the thread builds them (interpolation, force, G, w), buffers them and appends
//! them to the HDF5 file (and CSV) a whole chunk ([`super::names::FLUSH_ROWS`] rows) at a time. On the
//! full-length paper protocol (1 M samples) building and appending the samples was half of the
//! run's time on one thread; appending is mostly copying (hdf5-pure copies a batch twice on its
//! way to the file), and whole chunks keep it from rewriting a partial one at every append.
//!
//! Memory stays bounded: a batch is at most [`super::names::FLUSH_ROWS`] samples or 2048 steps, the
//! channel holds at most `QUEUE` (32) of them, the thread works on one and the run fills one;
//! written batches come back emptied (keeping their capacity) for the run to refill. The
//! thread owns the partial files: when the run is dropped without finishing, the channel closes,
//! the thread ends and the partials are removed, and the drop waits for that, so the directory's
//! lock is released only after. An error of the thread (a full disk) reaches the run at its next
//! batch, which then stops.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;

use super::atomic::AtomicFile;
use super::cycles;
use super::error::{io_err, OutputError};
use super::hdf5_file::{H5Stream, RunTables, RECORD_CHUNK};
use super::names::{CSV_NAMES, FLUSH_ROWS, HDF5_NAME};
use super::table::{CsvWriter, Table};
use super::timeseries::{self, TimeSeriesWriter};
use crate::scenario::Scenario;
use djkr_core::dynamics::model::Model;
use djkr_core::dynamics::Sample;
use djkr_core::dynamics::StepSamples;

/// A sample not built yet, or built already, with its segment index (the `segment` column).
#[derive(Debug, Clone, Copy)]
pub(super) enum Pending {
    /// A sample handed over as it is.
    One(Sample, i64),
    /// The samples of one step, built by the writer thread.
    Step(StepSamples, i64),
}

/// The rows buffered since the last write to disk.
#[derive(Debug)]
pub(super) struct Rows {
    /// Samples (built).
    pub series: TimeSeriesWriter,
    /// Events.
    pub events: Table,
    /// Period records.
    pub cycles: Table,
    /// Samples after `series`, still to be built (streaming only).
    pub pending: Vec<Pending>,
    /// How many samples `pending` holds.
    pub pending_samples: usize,
    /// What the batch takes on disk (estimated by the run writer when it hands it over).
    pub bytes: u64,
}

impl Rows {
    pub fn new() -> Self {
        Self {
            series: TimeSeriesWriter::new(),
            events: timeseries::events_table(&[]),
            cycles: cycles::cycle_table(&[]),
            pending: Vec::new(),
            pending_samples: 0,
            bytes: 0,
        }
    }

    /// The buffered tables, with the run's `gaps` (kept by the run writer).
    pub fn tables<'a>(&'a self, gaps: &'a Table) -> RunTables<'a> {
        RunTables {
            series: self.series.table(),
            events: &self.events,
            cycles: &self.cycles,
            gaps,
        }
    }

    /// The longest table, counting pending samples, and a pending item as 16 rows (a batch
    /// holds at most 2048 of them, about 0.4 MB).
    pub fn most(&self) -> usize {
        (self.series.len() + self.pending_samples)
            .max(16 * self.pending.len())
            .max(self.events.rows())
            .max(self.cycles.rows())
    }

    pub fn clear(&mut self) {
        self.series.clear();
        self.events.clear();
        self.cycles.clear();
        self.pending.clear();
        self.pending_samples = 0;
        self.bytes = 0;
    }
}

/// The files of a run that switched to streaming, and the samples built but not yet written
/// (less than a chunk).
#[derive(Debug)]
pub(super) struct Streaming {
    // Field order matters on drop: the HDF5 handle closes before its partial is removed.
    pub h5: H5Stream,
    pub h5_file: AtomicFile,
    pub csv: Vec<(AtomicFile, CsvWriter<BufWriter<File>>)>,
    /// Samples not yet written.
    buf: TimeSeriesWriter,
    /// Events not yet written.
    events: Table,
    /// Period records not yet written.
    cycles: Table,
    /// The run's model, to build the samples of steps.
    model: Option<Model>,
}

impl Streaming {
    /// Create the HDF5 file (and, with `csv`, the CSV files) of a run under their partial
    /// names in `dir`, with no rows yet; `model` builds the samples of steps.
    pub fn create(
        dir: &Path,
        scenario: &Scenario,
        run_id: &str,
        (csv, compress): (bool, bool),
        model: Option<Model>,
    ) -> Result<Self, OutputError> {
        let (h5_file, handle) = AtomicFile::create(&dir.join(HDF5_NAME), run_id)?;
        let h5 = H5Stream::create(h5_file.partial(), handle, scenario, run_id, compress)?;
        let mut st = Streaming {
            h5,
            h5_file,
            csv: Vec::new(),
            buf: TimeSeriesWriter::new(),
            events: timeseries::events_table(&[]),
            cycles: cycles::cycle_table(&[]),
            model,
        };
        if csv {
            // The schemas of the stream's own (empty) tables.
            let schemas = [
                st.buf.table().schema(),
                st.events.schema(),
                st.cycles.schema(),
            ];
            for (name, schema) in CSV_NAMES.into_iter().zip(schemas) {
                let (file, out) = AtomicFile::create(&dir.join(name), run_id)?;
                let p = file.partial().to_path_buf();
                let w = CsvWriter::new(BufWriter::with_capacity(1 << 16, out), &schema)
                    .map_err(io_err(&p))?;
                st.csv.push((file, w));
            }
        }
        Ok(st)
    }

    /// Take in a batch: its samples (built ones, then pending ones, in order), events and period
    /// records into the buffers, and write their whole chunks.
    pub fn absorb(&mut self, rows: &Rows) -> Result<(), OutputError> {
        self.buf
            .extend(rows.series.table())
            .map_err(|e| self.h5_error(e.to_string()))?;
        self.write_series(self.buf.len() - self.buf.len() % FLUSH_ROWS)?;
        for p in &rows.pending {
            match p {
                Pending::One(s, segment) => {
                    self.buf.set_segment(*segment);
                    self.push(s)?;
                }
                Pending::Step(step, segment) => {
                    self.buf.set_segment(*segment);
                    let Some(m) = self.model.take() else {
                        return Err(self.h5_error("a step's samples without a model".into()));
                    };
                    let mut res = Ok(());
                    step.each(&m, |s| {
                        res = self.push(s);
                        res.is_ok()
                    });
                    self.model = Some(m);
                    res?;
                }
            }
        }
        let added = (self.events.append_rows(&rows.events))
            .and_then(|()| self.cycles.append_rows(&rows.cycles));
        added.map_err(|e| self.h5_error(e.to_string()))?;
        self.write(false)
    }

    /// Buffer one sample, and write the buffer when it holds a chunk.
    fn push(&mut self, s: &Sample) -> Result<(), OutputError> {
        self.buf.push(s);
        if self.buf.len() >= FLUSH_ROWS {
            self.write_series(self.buf.len())?;
        }
        Ok(())
    }

    /// Write the first `n` buffered samples and drop them from the buffer.
    fn write_series(&mut self, n: usize) -> Result<(), OutputError> {
        if n == 0 {
            return Ok(());
        }
        let series = self.buf.table();
        self.h5.append_series(series, 0..n)?;
        if let Some((file, w)) = self.csv.first_mut() {
            w.write_row_range(series, 0..n)
                .map_err(io_err(file.partial()))?;
        }
        self.buf.remove_first(n);
        Ok(())
    }

    /// Write the buffered rows: all of them (`all`), or the whole chunks of each table only (a
    /// chunk written whole is never rewritten; growing a partial one would copy it).
    pub fn write(&mut self, all: bool) -> Result<(), OutputError> {
        let whole = |n: usize, chunk: usize| if all { n } else { n - n % chunk };
        self.write_series(whole(self.buf.len(), FLUSH_ROWS))?;
        let ne = whole(self.events.rows(), RECORD_CHUNK);
        let nc = whole(self.cycles.rows(), RECORD_CHUNK);
        self.h5
            .append_records((&self.events, 0..ne), (&self.cycles, 0..nc))?;
        for ((file, w), (t, k)) in self
            .csv
            .iter_mut()
            .skip(1)
            .zip([(&self.events, ne), (&self.cycles, nc)])
        {
            w.write_row_range(t, 0..k).map_err(io_err(file.partial()))?;
        }
        self.events.remove_first_rows(ne);
        self.cycles.remove_first_rows(nc);
        Ok(())
    }

    fn h5_error(&self, message: String) -> OutputError {
        OutputError::Hdf5 {
            path: self.h5_file.partial().to_path_buf(),
            message,
        }
    }
}

/// Batches the run may hand over before it waits for the writer thread: the thread is behind
/// where samples are dense and steps cheap (a quiet dwell sampled at 12 kHz: 20 samples a step),
/// the run where steps are many (the unload under vibration), and a deep queue lets the thread
/// catch up there. A batch of steps is about 0.4 MB.
const QUEUE: usize = 32;

/// A writer thread and its two channels.
pub(super) struct Background {
    tx: Option<SyncSender<Rows>>,
    back: Receiver<Rows>,
    handle: Option<JoinHandle<Result<Streaming, OutputError>>>,
    /// The `bytes` of the batches the thread has taken in (written, but for the partial chunks
    /// it keeps until they are whole).
    written: Arc<AtomicU64>,
    /// The address of the model the thread builds samples with (0: none). Compared, never
    /// dereferenced: a run writer serves one run, whose model stays in place.
    model_addr: usize,
}

impl std::fmt::Debug for Background {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Background").finish_non_exhaustive()
    }
}

impl Background {
    /// Start the thread, which takes in every batch sent into the files of `st`; `model_addr`
    /// is where the run's model lives (the one `st` holds a copy of).
    pub fn spawn(mut st: Streaming, model_addr: usize) -> Result<Self, OutputError> {
        let (tx, rx) = sync_channel::<Rows>(QUEUE);
        let (back_tx, back) = sync_channel::<Rows>(QUEUE + 1);
        let model_addr = if st.model.is_some() { model_addr } else { 0 };
        let written = Arc::new(AtomicU64::new(0));
        let taken_in = Arc::clone(&written);
        let handle = std::thread::Builder::new()
            .name("djkr-writer".into())
            .spawn(move || {
                for mut rows in rx {
                    st.absorb(&rows)?;
                    taken_in.fetch_add(rows.bytes, Ordering::Relaxed);
                    rows.clear();
                    let _ = back_tx.try_send(rows);
                }
                Ok(st)
            })
            .map_err(|source| OutputError::Io {
                path: "writer thread".into(),
                source,
            })?;
        Ok(Self {
            tx: Some(tx),
            back,
            handle: Some(handle),
            written,
            model_addr,
        })
    }

    /// The `bytes` of the batches the thread has taken in so far.
    pub fn written(&self) -> u64 {
        self.written.load(Ordering::Relaxed)
    }

    /// True when the thread builds the samples of steps under `model`.
    pub fn builds_with(&self, model: &Model) -> bool {
        self.model_addr != 0 && std::ptr::eq(self.model_addr as *const Model, model)
    }

    /// Hand a full batch to the thread (waiting while `QUEUE` batches wait already) and get an
    /// empty buffer back; the thread's error if it has stopped.
    pub fn send(&mut self, rows: Rows) -> Result<Rows, OutputError> {
        let sent = match &self.tx {
            Some(tx) => tx.send(rows).is_ok(),
            None => false,
        };
        if sent {
            return Ok(self.back.try_recv().unwrap_or_else(|_| Rows::new()));
        }
        Err(match self.join() {
            Err(e) => e,
            Ok(_) => thread_gone(),
        })
    }

    /// Wait until every batch sent is taken in, and take the files back.
    pub fn finish(mut self) -> Result<Streaming, OutputError> {
        self.join()
    }

    fn join(&mut self) -> Result<Streaming, OutputError> {
        self.tx = None;
        match self.handle.take().map(JoinHandle::join) {
            Some(Ok(result)) => result,
            Some(Err(_)) | None => Err(thread_gone()),
        }
    }
}

impl Drop for Background {
    fn drop(&mut self) {
        // Closing the channel ends the thread, which removes its partial files.
        let _ = self.join();
    }
}

fn thread_gone() -> OutputError {
    OutputError::Hdf5 {
        path: HDF5_NAME.into(),
        message: "the writer thread stopped unexpectedly (a panic: please report it)".into(),
    }
}
