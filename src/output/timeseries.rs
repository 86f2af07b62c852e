//! The time-series columns (names, units, descriptions: one table shared by the HDF5, CSV and JSON
//! writers) and [`TimeSeriesWriter`], the observer that buffers a run's samples and events.
//!
//! Buffering in memory, column by column, and writing once at the end is a deliberate choice over
//! hdf5-pure's extendable datasets: a run of 10⁶ samples is 12 columns × 8 bytes × 10⁶ ≈ 96 MB, far
//! below the machine's memory; writing once yields plain chunked datasets every HDF5 reader
//! handles; and nothing reaches the disk before the run has succeeded, which is what makes the
//! output atomic (see [`super::RunWriter`]). A run sampled at every step of a very long
//! integration (`output.sample_rate = 0`, 10⁸ steps) would need ~10 GB: set a sample rate.

use crate::dynamics::types::{Event, Observer, Sample};

/// One f64 time-series column: the same name in HDF5 (dataset), JSON (key) and, with its unit,
/// in the CSV header.
#[derive(Debug, Clone, Copy)]
pub struct Column {
    /// Dataset / JSON key name (`t`, `x_s`, `F`, ...).
    pub name: &'static str,
    /// SI unit, as stored in the HDF5 `units` attribute (`1` for dimensionless).
    pub unit: &'static str,
    /// CSV header: name and unit (`F_N`, `v_s_m_per_s`).
    pub csv_header: &'static str,
    /// One-line description (HDF5 `description` attribute).
    pub description: &'static str,
    get: fn(&Sample) -> f64,
}

impl Column {
    /// This column's value in a sample.
    pub fn value(&self, s: &Sample) -> f64 {
        (self.get)(s)
    }
}

const fn col(
    name: &'static str,
    unit: &'static str,
    csv_header: &'static str,
    description: &'static str,
    get: fn(&Sample) -> f64,
) -> Column {
    Column {
        name,
        unit,
        csv_header,
        description,
        get,
    }
}

/// The f64 columns of the time series, in file order. The stage index ([`STAGE`]) follows them.
pub const SERIES: [Column; 11] = [
    col("t", "s", "t_s", "time", |s| s.t),
    col(
        "x_s",
        "m",
        "x_s_m",
        "sphere position (down positive)",
        |s| s.x_s,
    ),
    col(
        "v_s",
        "m/s",
        "v_s_m_per_s",
        "sphere velocity (down positive)",
        |s| s.v_s,
    ),
    col(
        "x_b",
        "m",
        "x_b_m",
        "base displacement (up positive)",
        |s| s.x_b,
    ),
    col(
        "x_k",
        "m",
        "x_k_m",
        "far end of the holding spring (down positive)",
        |s| s.x_k,
    ),
    col(
        "delta",
        "m",
        "delta_m",
        "indentation x_s + x_b (positive compresses; negative: gap or tensile contact)",
        |s| s.delta,
    ),
    col("a", "m", "a_m", "contact radius (0 out of contact)", |s| {
        s.a
    }),
    col(
        "a_dot",
        "m/s",
        "a_dot_m_per_s",
        "contact-radius rate (positive healing, 0 out of contact)",
        |s| s.a_dot,
    ),
    col(
        "F",
        "N",
        "F_N",
        "contact force on the sphere (compressive positive)",
        |s| s.force,
    ),
    col(
        "G",
        "J/m^2",
        "G_J_per_m2",
        "energy release rate (signed: negative for a compressive edge; 0 out of contact)",
        |s| s.g,
    ),
    col(
        "w",
        "J/m^2",
        "w_J_per_m2",
        "work of adhesion w(a_dot) (w0 out of contact)",
        |s| s.w,
    ),
];

/// Name of the stage-index column (int64 in HDF5).
pub const STAGE: &str = "stage";
/// Unit of the stage index (dimensionless).
pub const STAGE_UNIT: &str = "1";
/// Description of the stage index.
pub const STAGE_DESCRIPTION: &str =
    "index of the protocol stage ([[stage]] in the scenario, 0-based)";

/// Buffers a run's samples (column-wise) and events; the writers read them at the end.
#[derive(Debug, Clone, Default)]
pub struct TimeSeriesWriter {
    columns: [Vec<f64>; 11],
    stage: Vec<i64>,
    events: Vec<Event>,
}

impl TimeSeriesWriter {
    /// An empty buffer.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of samples buffered.
    pub fn len(&self) -> usize {
        self.stage.len()
    }

    /// True when no sample has been buffered.
    pub fn is_empty(&self) -> bool {
        self.stage.is_empty()
    }

    /// The values of f64 column `name` (one of [`SERIES`]), or `None` for an unknown name.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        SERIES
            .iter()
            .position(|c| c.name == name)
            .map(|i| self.columns[i].as_slice())
    }

    /// The f64 columns, in the order of [`SERIES`].
    pub fn columns(&self) -> &[Vec<f64>; 11] {
        &self.columns
    }

    /// The stage index of each sample.
    pub fn stages(&self) -> &[i64] {
        &self.stage
    }

    /// The events seen, in the order they arrived.
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// Buffer one sample.
    pub fn push(&mut self, s: &Sample) {
        for (col, def) in self.columns.iter_mut().zip(SERIES.iter()) {
            col.push(def.value(s));
        }
        self.stage.push(stage_index(s.stage));
    }
}

impl Observer for TimeSeriesWriter {
    fn sample(&mut self, s: &Sample) -> bool {
        self.push(s);
        true
    }
    fn event(&mut self, e: &Event) {
        self.events.push(*e);
    }
}

/// A stage index as stored in files (int64; indices never come near 2^63).
pub(crate) fn stage_index(stage: usize) -> i64 {
    i64::try_from(stage).unwrap_or(i64::MAX)
}
