//! The memory a run kept in memory ([`crate::api::run`], Python's `djkr.run`) will hold,
//! estimated before it starts, so that a run which cannot fit is refused at once with the keys
//! that drive it instead of aborting the process (and a user's Python session) on a failed
//! allocation hours later.
//!
//! The estimate covers what grows with the run's length: the time-series samples. A sample is
//! known to be taken every `1 / [output] sample_rate` seconds of simulated time, so a scenario
//! with a sample rate holds `sample_rate × Σ duration + 1` samples over its stages with a fixed
//! `duration` (the `+ 1` is the sample at t = 0; no other samples are taken). A stage that ends
//! at a preload or at pull-off may end long before its `max_duration`, so it adds nothing to the
//! estimate: refusing on its `max_duration` would refuse ordinary scenarios (a pull-off at 2 s
//! under the default `max_duration` of 10⁴ s); such stages, and runs sampled at every step
//! (`sample_rate = 0`), are bounded while running instead. Each known sample is counted at the
//! most it can cost ([`SAMPLE_BYTES`]), since an allocation that fails at the peak aborts the
//! process as surely as one at the end.
//!
//! The command line's `djkr run` streams its samples to disk and holds a bounded buffer, and a
//! sweep's runs do not build their samples at all (`sweep::engine`'s observer), so neither is
//! checked here.

use thiserror::Error;

use crate::scenario::Scenario;
use djkr_core::dynamics::protocol::Until;

/// Bytes a time-series sample held in memory takes at the peak: 11 `f64` columns and two `i64`
/// columns, stage and segment (104 bytes a row), each column a `Vec` that doubles its capacity
/// when full, so that a run of n samples holds between 104 n and 208 n bytes depending on where
/// n falls between two powers of two, and while one column is copied into its doubled buffer
/// the old buffer is still live (8 bytes a sample more): 216 bytes. Measured, not assumed:
/// `tests/memory_estimate.rs` counts every byte the heap holds (a counting global allocator) at
/// its peak during `api::run` for sample counts on both sides of a doubling, and checks that the
/// peak per sample (less the peak of the same run with 2 samples) never exceeds this figure and
/// comes within 5 % of it (2¹⁷ samples: 107.8 bytes a sample; 2¹⁷ + 1: 215.8).
pub const SAMPLE_BYTES: f64 = 216.0;

/// How many samples a run of `scn` is known to take, and the keys that say so.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Samples known to be taken (`sample_rate × Σ duration + 1`).
    pub samples: f64,
    /// Bytes they will hold in memory ([`SAMPLE_BYTES`] each).
    pub bytes: f64,
    /// `[output] sample_rate` (1/s).
    pub sample_rate: f64,
    /// The stages with a fixed duration: (index, duration in s), longest first.
    pub durations: Vec<(usize, f64)>,
}

impl Estimate {
    /// The estimate for `scn`, or `None` when its sample count is not known up front (sampled
    /// at every step).
    pub fn of(scn: &Scenario) -> Option<Estimate> {
        let rate = scn.output.sample_rate;
        if !(rate > 0.0 && rate.is_finite()) {
            return None;
        }
        let mut durations: Vec<(usize, f64)> = scn
            .stages
            .iter()
            .enumerate()
            .filter_map(|(i, st)| match st.until {
                Until::Duration(d) => Some((i, d)),
                _ => None,
            })
            .collect();
        durations.sort_by(|a, b| b.1.total_cmp(&a.1));
        let span: f64 = durations.iter().map(|(_, d)| d).sum();
        let samples = (rate * span).floor() + 1.0;
        Some(Estimate {
            samples,
            bytes: samples * SAMPLE_BYTES,
            sample_rate: rate,
            durations,
        })
    }

    /// The keys that drive the estimate, in words: `output.sample_rate = 1e7 1/s over
    /// stage[0].duration = 1000 s`, the three longest stages named and the rest counted.
    fn keys(&self) -> String {
        const NAMED: usize = 3;
        let mut stages: Vec<String> = self
            .durations
            .iter()
            .take(NAMED)
            .map(|(i, d)| format!("stage[{i}].duration = {d} s"))
            .collect();
        if self.durations.len() > NAMED {
            let rest: f64 = self.durations[NAMED..].iter().map(|(_, d)| d).sum();
            stages.push(format!(
                "{} more stages of {rest} s",
                self.durations.len() - NAMED
            ));
        }
        format!(
            "output.sample_rate = {} 1/s over {}",
            self.sample_rate,
            stages.join(" + ")
        )
    }
}

/// A run refused because its samples would not fit in `solver.max_memory`.
#[derive(Debug, Clone, PartialEq, Error)]
#[error(
    "{source_name}: the run would hold about {samples:.3e} samples in memory ({keys}), about {} \
     ({bytes:.3e} bytes at {SAMPLE_BYTES} bytes a sample), more than solver.max_memory = \
     {budget} bytes ({}); lower output.sample_rate or those durations, or raise \
     solver.max_memory",
    human_bytes(*bytes),
    human_bytes(*budget as f64)
)]
pub struct MemoryError {
    /// The scenario's name (with its overrides).
    pub source_name: String,
    /// Samples known to be taken.
    pub samples: f64,
    /// Bytes they would hold.
    pub bytes: f64,
    /// The keys that drive the estimate, in words.
    pub keys: String,
    /// `solver.max_memory` (bytes).
    pub budget: u64,
}

/// Refuse a run kept in memory whose known samples would exceed `solver.max_memory`.
pub(crate) fn check_in_memory(scn: &Scenario) -> Result<(), MemoryError> {
    let Some(e) = Estimate::of(scn) else {
        return Ok(());
    };
    let budget = scn.solver.max_memory;
    if e.bytes <= budget as f64 {
        return Ok(());
    }
    Err(MemoryError {
        source_name: scn.source_name.clone(),
        samples: e.samples,
        bytes: e.bytes,
        keys: e.keys(),
        budget,
    })
}

/// Bytes in binary units: `2.0 GiB`, `894.1 TiB`, `512 B`.
pub(crate) fn human_bytes(b: f64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut x = b;
    let mut i = 0;
    while x >= 1024.0 && i + 1 < units.len() {
        x /= 1024.0;
        i += 1;
    }
    if i == 0 {
        format!("{x:.0} B")
    } else {
        format!("{x:.1} {}", units[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binary_units() {
        assert_eq!(human_bytes(512.0), "512 B");
        assert_eq!(human_bytes((2u64 << 30) as f64), "2.0 GiB");
        assert_eq!(human_bytes(1.5 * 1024.0 * 1024.0), "1.5 MiB");
    }
}
