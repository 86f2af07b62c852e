//! The disk space a run's files need: refused before the run where it is certain, watched while
//! the run streams where it is not.
//!
//! **Before the run** (`check_up_front`) djkr counts only the samples a run is certain to take:
//! `[output] sample_rate` over the stages with a fixed `duration` (the count of
//! [`crate::memory::Estimate`]), at [`HDF5_ROW_BYTES`] a sample (and [`CSV_ROW_BYTES`] more with
//! CSV). A stage that ends at a preload or at pull-off may end long before its `max_duration`
//! (the bundled paper protocol's unload may take 200 s and takes 21), so it counts for nothing
//! there: counting its `max_duration` refused that protocol on a 200 MB file system ("about
//! 263 MB") although it writes 28 MB.
//!
//! **While the run streams** ([`DiskWatch`]) the run writer asks the file system for its free
//! space (one `statvfs`) after each batch it hands to its writer thread, at most once per
//! [`CHECK_BYTES`] of output or [`CHECK_EVERY`], and stops the run (`status` `stopped`, `reason`
//! `disk`) as soon as the free space would no longer hold what must still be written: the
//! batches queued and not yet written, the next batch, the writer's partial chunks, and the
//! closing writes (the event kinds, the last records, summary.json): [`Sizes::reserve`]. The run
//! then publishes what it computed, complete files, as every stopped run does. A run that never
//! streams writes at most [`super::names::SPILL_ROWS`] samples (a few MB), all at its end.
//!
//! What this cannot see: another process filling the disk faster than one check to the next
//! (then the write fails, `No space left on device`, and the run's partial files are removed as
//! for any failed write), and a file system whose free space is not what `statvfs` reports
//! (some network and FUSE file systems).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::error::OutputError;
use super::hdf5_file::RECORD_CHUNK;
use super::names::FLUSH_ROWS;
use crate::scenario::Scenario;

/// Bytes per sample in the HDF5 file (13 columns of 8 bytes, uncompressed).
pub(super) const HDF5_ROW_BYTES: u64 = 104;
/// Bytes per sample in timeseries.csv (13 shortest round-trip numbers and commas, generous).
pub(super) const CSV_ROW_BYTES: u64 = 300;
/// Bytes per event or period record in the HDF5 file (24 columns of 8 bytes).
const HDF5_RECORD_BYTES: u64 = 192;
/// Bytes per event or period record in CSV (24 numbers, generous).
const CSV_RECORD_BYTES: u64 = 600;
/// Bytes per event kind, written when the run ends (a variable-length string and its index).
const KIND_BYTES: u64 = 40;
/// The closing writes that do not grow with the run: the root's attributes, the descriptions,
/// the gaps, summary.json (at most 10 000 events listed, a few MB), CSV's gaps.csv.
const CLOSING_BYTES: u64 = 8 << 20;

/// Output between two looks at the free space, at most.
pub const CHECK_BYTES: u64 = 8 << 20;
/// Time between two looks at the free space, at most (when output comes slowly).
pub const CHECK_EVERY: Duration = Duration::from_secs(2);

/// What a run's rows take on disk, by its options.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Sizes {
    /// Bytes per time-series sample.
    pub sample: u64,
    /// Bytes per event or period record.
    pub record: u64,
}

impl Sizes {
    /// The sizes of a run's rows with or without CSV files.
    pub fn of(csv: bool) -> Sizes {
        Sizes {
            sample: HDF5_ROW_BYTES + if csv { CSV_ROW_BYTES } else { 0 },
            record: HDF5_RECORD_BYTES + if csv { CSV_RECORD_BYTES } else { 0 },
        }
    }

    /// Bytes of `samples` samples and `records` events and period records.
    pub fn rows(self, samples: usize, records: usize) -> u64 {
        (samples as u64)
            .saturating_mul(self.sample)
            .saturating_add((records as u64).saturating_mul(self.record))
    }

    /// Bytes the run must still be able to write beyond what is queued, when it stops after
    /// `events` events: the next batch and the writer thread's partial chunks (a chunk of
    /// samples each, a chunk of events and of records), the event kinds and the closing writes.
    pub fn reserve(self, events: u64) -> u64 {
        self.rows(2 * FLUSH_ROWS, 2 * RECORD_CHUNK)
            .saturating_add(events.saturating_mul(KIND_BYTES))
            .saturating_add(CLOSING_BYTES)
    }
}

/// The free space was too low to go on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Low {
    /// Bytes free.
    pub free: u64,
    /// Bytes the run still had to write.
    pub need: u64,
}

/// Whether a run that must still write `need` bytes may go on with `free` bytes free.
pub fn room_for(free: u64, need: u64) -> bool {
    free >= need
}

/// Watches the free space of an output folder's file system while a run streams into it (see
/// the module documentation). `free` says how many bytes are free (`None`: unknown, which never
/// stops a run); it is called at most once per [`CHECK_BYTES`] of output or [`CHECK_EVERY`].
pub struct DiskWatch<F> {
    free: F,
    checked_bytes: u64,
    checked_at: Option<Instant>,
}

impl<F: FnMut() -> Option<u64>> DiskWatch<F> {
    /// A watch asking `free` for the free bytes.
    pub fn new(free: F) -> Self {
        Self {
            free,
            checked_bytes: 0,
            checked_at: None,
        }
    }

    /// After `sent` bytes in all were handed to the writer, when it is `now` and the run would
    /// still have to write `need` bytes if it stopped here: `Some` to stop the run.
    pub fn check(&mut self, sent: u64, need: u64, now: Instant) -> Option<Low> {
        let due = sent.saturating_sub(self.checked_bytes) >= CHECK_BYTES
            || self
                .checked_at
                .is_none_or(|t| now.saturating_duration_since(t) >= CHECK_EVERY);
        if !due {
            return None;
        }
        self.checked_bytes = sent;
        self.checked_at = Some(now);
        let free = (self.free)()?;
        (!room_for(free, need)).then_some(Low { free, need })
    }
}

impl<F> std::fmt::Debug for DiskWatch<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DiskWatch")
            .field("checked_bytes", &self.checked_bytes)
            .finish_non_exhaustive()
    }
}

/// The watch of a run writing into `dir`.
pub(super) type FolderWatch = DiskWatch<Box<dyn FnMut() -> Option<u64> + Send>>;

/// A watch of the file system of `dir`.
pub(super) fn watch(dir: &Path) -> FolderWatch {
    let dir: PathBuf = dir.to_path_buf();
    DiskWatch::new(Box::new(move || free_bytes(&dir)))
}

/// Bytes available to this user on the file system of `dir` (`None`: unknown).
pub(super) fn free_bytes(dir: &Path) -> Option<u64> {
    fs4::available_space(dir).ok()
}

/// Refuse before the run a run whose certain samples (see the module documentation) would not
/// fit on the disk of `dir`. Runs sampled at every step cannot be estimated and are not checked.
pub(super) fn check_up_front(
    dir: &Path,
    scenario: &Scenario,
    csv: bool,
) -> Result<(), OutputError> {
    let Some(estimate) = crate::memory::Estimate::of(scenario) else {
        return Ok(());
    };
    let samples = estimate.samples;
    let need = samples * Sizes::of(csv).sample as f64;
    match free_bytes(dir) {
        Some(free) if need > free as f64 => Err(OutputError::DiskSpace {
            dir: dir.to_path_buf(),
            need,
            free: free as f64,
            samples,
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reserve_covers_the_next_batch_the_partial_chunks_and_the_closing() {
        let s = Sizes::of(false);
        assert_eq!(s.sample, 104);
        assert_eq!(
            s.reserve(10),
            2 * 32768 * 104 + 2 * 1024 * 192 + 10 * 40 + (8 << 20)
        );
        let c = Sizes::of(true);
        assert_eq!((c.sample, c.record), (404, 792));
        assert_eq!(c.rows(3, 2), 3 * 404 + 2 * 792);
        assert!(room_for(100, 100) && !room_for(99, 100));
    }

    /// The watch with an injected file system: free space falling as the run writes.
    #[test]
    fn the_watch_stops_the_run_once_the_rest_would_not_fit_and_looks_only_now_and_then() {
        let t0 = Instant::now();
        let looks = std::cell::Cell::new(0);
        let disk = std::cell::Cell::new(100u64 << 20);
        let mut w = DiskWatch::new(|| {
            looks.set(looks.get() + 1);
            Some(disk.get())
        });
        let mib = 1u64 << 20;
        // The first batch is looked at.
        assert_eq!(w.check(mib, 20 * mib, t0), None);
        assert_eq!(looks.get(), 1);
        // Small batches soon after are not.
        for k in 2..8 {
            assert_eq!(w.check(k * mib, 20 * mib, t0), None);
        }
        assert_eq!(looks.get(), 1);
        // 8 MiB more output: looked at again.
        assert_eq!(w.check(9 * mib, 20 * mib, t0), None);
        assert_eq!(looks.get(), 2);
        // Slow output: looked at again after CHECK_EVERY.
        let later = t0 + CHECK_EVERY;
        assert_eq!(w.check(9 * mib + 1, 20 * mib, later), None);
        assert_eq!(looks.get(), 3);
        // The disk fills up (another writer, or this run): the first look that finds less free
        // than the rest needs stops the run, saying both.
        disk.set(30 * mib);
        assert_eq!(w.check(17 * mib, 20 * mib, later), None);
        disk.set(20 * mib - 1);
        assert_eq!(
            w.check(25 * mib + 1, 20 * mib, later),
            Some(Low {
                free: 20 * mib - 1,
                need: 20 * mib
            })
        );
    }

    #[test]
    fn an_unknown_free_space_never_stops_a_run() {
        let mut w = DiskWatch::new(|| None);
        let t0 = Instant::now();
        for k in 0..100u64 {
            assert_eq!(w.check(k << 24, u64::MAX, t0), None);
        }
    }
}
