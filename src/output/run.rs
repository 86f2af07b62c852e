//! The writer of `djkr run`'s folder ([`RunWriter`]): it buffers the rows a run streams into it,
//! switches to streaming once the run is long (module `stream`), and publishes the run's files,
//! `summary.json` last (memory, atomicity and disk space: the module doc of `output`).

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::atomic::{self, AtomicFile};
use super::error::{human_bytes, io_err, OutputError};
use super::names::{
    CSV_NAMES, CYCLES_CSV_NAME, EVENTS_CSV_NAME, FLUSH_ROWS, GAPS_CSV_NAME, HDF5_NAME, SPILL_ROWS,
    SUMMARY_NAME, TIMESERIES_CSV_NAME,
};
use super::stream::{Background, Pending, Rows, Streaming};
use super::summary::{self, SummaryFiles};
use super::{cycles, disk, folder, hdf5_file, timeseries};
use crate::scenario::Scenario;
use djkr_core::dynamics::model::Model;
use djkr_core::dynamics::StepSamples;
use djkr_core::dynamics::{
    CycleRecord, Ending, Event, EventKind, Gap, Observer, Reason, RunResult, Sample,
};

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
    /// `DIR/gaps.csv`, when CSV was requested.
    pub gaps_csv: Option<PathBuf>,
    /// The text written into `summary.json`.
    pub summary_text: String,
}

impl OutputPaths {
    /// Every file written, in the order written.
    pub fn all(&self) -> Vec<&Path> {
        let mut v: Vec<&Path> = vec![self.hdf5.as_path()];
        v.extend(
            [
                &self.timeseries_csv,
                &self.events_csv,
                &self.cycles_csv,
                &self.gaps_csv,
            ]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path),
        );
        v.push(self.summary.as_path());
        v
    }
}

/// How a run's files are written (`[output]` keys and `--csv`).
#[derive(Debug, Clone, Copy)]
struct Options {
    csv: bool,
    compress: bool,
    fsync: bool,
}

/// Writes one run into an output directory: buffered, then streamed once long (memory and
/// atomicity: the module doc).
#[derive(Debug)]
pub struct RunWriter {
    dir: PathBuf,
    scenario: Scenario,
    options: Options,
    run_id: String,
    rows: Rows,
    kinds: Vec<EventKind>,
    samples: u64,
    cycles: u64,
    /// The gaps of the time series (24 bytes each, at most one per envelope jump).
    gaps: Vec<Gap>,
    stream: Option<Background>,
    /// The run's model (a copy, and where it lives) until streaming starts and the writer
    /// thread takes it to build the samples.
    model: Option<(usize, Model)>,
    error: Option<OutputError>,
    sections: Vec<(String, serde_json::Value)>,
    /// What the run's rows take on disk.
    sizes: disk::Sizes,
    /// The free space of the folder's file system, looked at while the run streams.
    disk: disk::FolderWatch,
    /// Bytes (estimated: [`disk::Sizes`]) handed to the writer thread so far.
    sent: u64,
    /// The free space was too low to go on: the run stops, reason `disk`.
    disk_low: Option<disk::Low>,
    // Last: released after the partials are gone.
    lock: Option<folder::DirLock>,
}

impl RunWriter {
    /// Prepare to write a run of `scenario` into `dir` (created if missing), with CSV files when
    /// `csv` is true (compression and syncing from `[output]`). Fails early, before the run,
    /// when `dir` cannot be created or written, when another run holds it, when a file the run
    /// would publish exists and djkr did not write it ([`OutputError::Clash`]: see
    /// [`RunWriter::create_with`] for `--force`), or when the samples the scenario asks for
    /// would not fit on its disk. Partials that killed runs recorded in the lock are removed.
    pub fn create(dir: &Path, scenario: &Scenario, csv: bool) -> Result<Self, OutputError> {
        Self::create_with(dir, scenario, csv, &[], false)
    }

    /// [`RunWriter::create`], also claiming `extra` names the caller will write into `dir`
    /// after the run (`run.png`, `run.svg`), and with `force` overwriting files of these names
    /// that djkr did not write (`--force`; nothing else in the folder is touched).
    pub fn create_with(
        dir: &Path,
        scenario: &Scenario,
        csv: bool,
        extra: &[&str],
        force: bool,
    ) -> Result<Self, OutputError> {
        folder::prepare(dir)?;
        let lock = folder::DirLock::acquire(dir)?;
        let mut names = vec![HDF5_NAME, SUMMARY_NAME];
        if csv {
            names.extend(CSV_NAMES);
            names.push(GAPS_CSV_NAME);
        }
        names.extend(extra);
        folder::check_names(dir, &names, force)?;
        let options = Options {
            csv,
            compress: scenario.output.compress,
            fsync: scenario.output.fsync,
        };
        disk::check_up_front(dir, scenario, csv)?;
        Ok(Self {
            dir: dir.to_path_buf(),
            scenario: scenario.clone(),
            options,
            run_id: new_run_id(),
            rows: Rows::new(),
            kinds: Vec::new(),
            samples: 0,
            cycles: 0,
            gaps: Vec::new(),
            stream: None,
            model: None,
            error: None,
            sections: Vec::new(),
            sizes: disk::Sizes::of(csv),
            disk: disk::watch(dir),
            sent: 0,
            disk_low: None,
            lock,
        })
    }

    /// Record a partial this writer created in the directory's lock (see [`folder::DirLock`]).
    fn note_partial(&self, file: &AtomicFile) {
        if let Some(l) = &self.lock {
            l.note_partial(file.partial());
        }
    }

    /// The output directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// This run's identity, shared by its `run.h5` and `summary.json` (`run_id`).
    pub fn run_id(&self) -> &str {
        &self.run_id
    }

    /// Add a top-level section `key` to summary.json (after the standard ones).
    pub(crate) fn add_summary_section(&mut self, key: &str, value: serde_json::Value) {
        self.sections.push((key.to_string(), value));
    }

    /// True once the run is long enough that its rows are streamed to disk.
    pub fn is_streaming(&self) -> bool {
        self.stream.is_some()
    }

    fn target(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Write the buffered rows to disk when there are enough of them; `false` after an error
    /// (kept for [`RunWriter::finish`]) or once the free disk space is too low to go on
    /// ([`disk::DiskWatch`]; the run then stops with reason `disk`), which stops the run.
    fn maybe_flush(&mut self) -> bool {
        if self.error.is_some() || self.disk_low.is_some() {
            return false;
        }
        let limit = if self.stream.is_some() {
            FLUSH_ROWS
        } else {
            SPILL_ROWS
        };
        if self.rows.most() >= limit {
            if let Err(e) = self.flush() {
                self.error = Some(e);
                return false;
            }
        }
        self.disk_low.is_none()
    }

    fn flush(&mut self) -> Result<(), OutputError> {
        if self.stream.is_none() {
            // The model moves to the thread, which builds the samples from here on.
            let (addr, model) = match self.model.take() {
                Some((addr, m)) => (addr, Some(m)),
                None => (0, None),
            };
            let st = Streaming::create(
                &self.dir,
                &self.scenario,
                &self.run_id,
                (self.options.csv, self.options.compress),
                model,
            )?;
            self.note_partial(&st.h5_file);
            for (file, _) in &st.csv {
                self.note_partial(file);
            }
            self.stream = Some(Background::spawn(st, addr)?);
        }
        let mut full = std::mem::replace(&mut self.rows, Rows::new());
        full.bytes = self.sizes.rows(
            full.series.len() + full.pending_samples,
            full.events.rows() + full.cycles.rows(),
        );
        self.sent = self.sent.saturating_add(full.bytes);
        if let Some(bg) = &mut self.stream {
            self.rows = bg.send(full)?;
            // What is queued and not yet written, and what the run must still write if it
            // stops here, must fit in what is free.
            let queued = self.sent.saturating_sub(bg.written());
            let need = queued.saturating_add(self.sizes.reserve(self.kinds.len() as u64));
            if let Some(low) = self.disk.check(self.sent, need, std::time::Instant::now()) {
                self.disk_low = Some(low);
            }
        }
        Ok(())
    }

    /// `ending` (how the run ended) with what this writer saw added to its message: for a run
    /// it stopped for disk space (reason `disk`), the free space and what the rest of the run
    /// would have needed.
    pub fn explain(&self, mut ending: Ending) -> Ending {
        if let (Some(Reason::Disk), Some(low), Some(m)) =
            (ending.reason, self.disk_low, ending.message.as_mut())
        {
            m.push_str(&format!(
                "; {}: {} free, {} needed to go on and finish the run's files",
                self.dir.display(),
                human_bytes(low.free as f64),
                human_bytes(low.need as f64)
            ));
        }
        ending
    }

    /// The segment index of the samples arriving now (the gaps seen so far).
    fn segment(&self) -> i64 {
        i64::try_from(self.gaps.len()).unwrap_or(i64::MAX)
    }

    /// Buffer one built sample.
    fn push_sample(&mut self, s: &Sample) -> bool {
        self.samples += 1;
        let segment = self.segment();
        if self.stream.is_some() {
            self.rows.pending.push(Pending::One(*s, segment));
            self.rows.pending_samples += 1;
        } else {
            self.rows.series.set_segment(segment);
            self.rows.series.push(s);
        }
        self.maybe_flush()
    }

    /// Write every file of the finished run and move them into place, `summary.json` last. On
    /// error nothing of this run is left in the directory (partials are removed) and the error
    /// names the file. The run went to its end (`"status": "ok"`); [`RunWriter::finish_with`]
    /// publishes a run that ended early.
    pub fn finish(self, result: &RunResult) -> Result<OutputPaths, OutputError> {
        self.finish_with(result, &Ending::ok())
    }

    /// [`RunWriter::finish`] for a run that ended as `ending` says: a run stopped by a budget or
    /// a signal, or failed mid-way, publishes what it computed up to there (its time series,
    /// events and period records, complete files) with `status`, `reason` and `message` in
    /// summary.json.
    pub fn finish_with(
        mut self,
        result: &RunResult,
        ending: &Ending,
    ) -> Result<OutputPaths, OutputError> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        // The time spent writing after the integration (`stats.write_s`): solver.max_wall_s
        // bounds the integration, not this.
        let t_write = std::time::Instant::now();
        let fsync = self.options.fsync;
        let mut staged: Vec<AtomicFile> = Vec::new();
        match self.stream.take() {
            None => self.stage_whole(result, &mut staged)?,
            Some(mut bg) => {
                let last = std::mem::replace(&mut self.rows, Rows::new());
                bg.send(last)?;
                let mut st = bg.finish()?;
                st.write(true)?;
                let kinds: Vec<String> = self
                    .kinds
                    .iter()
                    .map(|k| timeseries::kind_name(*k))
                    .collect();
                let kinds: Vec<&str> = kinds.iter().map(String::as_str).collect();
                let gaps = timeseries::gaps_table(&self.gaps);
                st.h5.finish(&kinds, self.cycles, &gaps, result)?;
                staged.push(st.h5_file);
                for (file, w) in st.csv {
                    let p = file.partial().to_path_buf();
                    let f = w
                        .into_inner()
                        .into_inner()
                        .map_err(|e| io_err(&p)(e.into_error()))?;
                    if fsync {
                        f.sync_all().map_err(io_err(&p))?;
                    }
                    staged.push(file);
                }
                if self.options.csv {
                    staged.push(self.stage_gaps_csv()?);
                }
            }
        }
        let mut files = SummaryFiles {
            hdf5: HDF5_NAME.to_string(),
            ..SummaryFiles::default()
        };
        if self.options.csv {
            files.timeseries_csv = Some(TIMESERIES_CSV_NAME.to_string());
            files.events_csv = Some(EVENTS_CSV_NAME.to_string());
            files.cycles_csv = Some(CYCLES_CSV_NAME.to_string());
            files.gaps_csv = Some(GAPS_CSV_NAME.to_string());
        }
        for f in &staged {
            let p = f.partial();
            let len = fs::metadata(p).map_err(io_err(p))?.len();
            let name = f
                .target()
                .file_name()
                .map(|n| n.to_string_lossy().into_owned());
            files.bytes.push((name.unwrap_or_default(), len));
        }
        files.write_s = Some(t_write.elapsed().as_secs_f64());
        let json = summary::summary_json(
            &self.scenario,
            result,
            ending,
            self.samples,
            &files,
            &self.run_id,
            &gaps_section(&self.sections, self.gaps.len()),
        );
        // Last: its presence marks a complete run.
        staged.push(AtomicFile::write_tagged(
            &self.target(SUMMARY_NAME),
            &self.run_id,
            fsync,
            |w| w.write_all(json.as_bytes()),
        )?);
        for f in &staged {
            self.note_partial(f);
        }
        folder::commit_all(&self.dir, staged)?;
        if fsync {
            atomic::sync_dir(&self.dir);
        }
        let csv = |name: &str| self.options.csv.then(|| self.dir.join(name));
        Ok(OutputPaths {
            hdf5: self.dir.join(HDF5_NAME),
            summary: self.dir.join(SUMMARY_NAME),
            timeseries_csv: csv(TIMESERIES_CSV_NAME),
            events_csv: csv(EVENTS_CSV_NAME),
            cycles_csv: csv(CYCLES_CSV_NAME),
            gaps_csv: csv(GAPS_CSV_NAME),
            summary_text: json,
        })
    }

    /// A run that never streamed: its files written whole from the buffered rows.
    fn stage_whole(
        &self,
        result: &RunResult,
        staged: &mut Vec<AtomicFile>,
    ) -> Result<(), OutputError> {
        let target = self.target(HDF5_NAME);
        let gaps = timeseries::gaps_table(&self.gaps);
        staged.push(AtomicFile::write_tagged(
            &target,
            &self.run_id,
            self.options.fsync,
            |w| {
                hdf5_file::write_hdf5(
                    self.rows.tables(&gaps),
                    &self.scenario,
                    &self.run_id,
                    result,
                    self.options.compress,
                    w,
                )
            },
        )?);
        if self.options.csv {
            let t = self.rows.tables(&gaps);
            for (name, table) in CSV_NAMES.into_iter().zip([t.series, t.events, t.cycles]) {
                staged.push(AtomicFile::write_tagged(
                    &self.target(name),
                    &self.run_id,
                    self.options.fsync,
                    |w| table.write_csv(w),
                )?);
            }
            staged.push(self.stage_gaps_csv()?);
        }
        Ok(())
    }

    /// `gaps.csv`, written whole (the gaps are few: at most one per envelope jump).
    fn stage_gaps_csv(&self) -> Result<AtomicFile, OutputError> {
        let gaps = timeseries::gaps_table(&self.gaps);
        AtomicFile::write_tagged(
            &self.target(GAPS_CSV_NAME),
            &self.run_id,
            self.options.fsync,
            |w| gaps.write_csv(w),
        )
    }

    /// Give up: remove this run's partial files (the same as dropping the writer).
    pub fn abort(self) {}
}

impl Observer for RunWriter {
    fn sample(&mut self, s: &Sample) -> bool {
        self.push_sample(s)
    }
    fn step_samples(&mut self, model: &Model, step: &StepSamples) -> bool {
        let segment = self.segment();
        if let Some(bg) = &self.stream {
            if bg.builds_with(model) {
                self.samples += step.n as u64;
                self.rows.pending.push(Pending::Step(*step, segment));
                self.rows.pending_samples += step.n;
                return self.maybe_flush();
            }
        } else if self.model.is_none() {
            self.model = Some((model as *const Model as usize, model.clone()));
        }
        step.each(model, |s| self.push_sample(s))
    }
    fn event(&mut self, e: &Event) {
        timeseries::push_event(&mut self.rows.events, e);
        self.kinds.push(e.kind);
        self.maybe_flush();
    }
    fn cycle(&mut self, c: &CycleRecord) {
        cycles::push_cycle(&mut self.rows.cycles, c);
        self.cycles += 1;
        self.maybe_flush();
    }
    fn gap(&mut self, g: &Gap) {
        self.gaps.push(*g);
    }
    fn stop_reason(&self) -> Option<Reason> {
        self.disk_low.map(|_| Reason::Disk)
    }
}

/// The summary sections `sections` with `gaps` (the number of gaps in the time series) first.
pub(crate) fn gaps_section(
    sections: &summary::Sections,
    gaps: usize,
) -> Vec<(String, serde_json::Value)> {
    let mut v = vec![("gaps".to_string(), serde_json::Value::from(gaps as u64))];
    v.extend(sections.iter().cloned());
    v
}

/// A run id unique on this machine: the start time and the process id.
pub(crate) fn new_run_id() -> String {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    format!(
        "{}.{:06}-{}",
        now.as_secs(),
        now.subsec_micros(),
        std::process::id()
    )
}
