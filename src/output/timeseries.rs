//! The time-series columns (names, units, descriptions: one schema shared by the HDF5, CSV and JSON
//! writers), [`TimeSeriesWriter`], the observer that buffers a run's samples and events as a
//! [`Table`], and the events as a table (`events_table`).
//!
//! The run writer buffers samples here column by column and, once a run is long, appends them
//! to the HDF5 file in batches ([`super::run::RunWriter`]: memory independent of run length).

use super::table::{Cell, Column, Data, Field, Table};
use djkr_core::dynamics::{Event, EventKind, Gap, Observer, Sample};

/// One f64 time-series column: the same name in HDF5 (dataset), JSON (key) and, with its unit,
/// in the CSV header (`F [N]`).
#[derive(Debug, Clone, Copy)]
pub struct SeriesColumn {
    /// Dataset / JSON key name (`t`, `x_s`, `F`, ...).
    pub name: &'static str,
    /// SI unit, as stored in the HDF5 `units` attribute (`1` for dimensionless).
    pub unit: &'static str,
    /// One-line description (HDF5 `description` attribute).
    pub description: &'static str,
    get: fn(&Sample) -> f64,
}

impl SeriesColumn {
    /// This column's value in a sample.
    pub fn value(&self, s: &Sample) -> f64 {
        (self.get)(s)
    }
}

const fn col(
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    get: fn(&Sample) -> f64,
) -> SeriesColumn {
    SeriesColumn {
        name,
        unit,
        description,
        get,
    }
}

/// The f64 columns of the time series, in file order. The stage index ([`STAGE`]) and the segment
/// index ([`SEGMENT`]) follow them.
pub const SERIES: [SeriesColumn; 11] = [
    col("t", "s", "time from the start of the protocol (s)", |s| s.t),
    col("x_s", "m", "sphere position (down positive)", |s| s.x_s),
    col("v_s", "m/s", "sphere velocity (down positive)", |s| s.v_s),
    col("x_b", "m", "base displacement (up positive)", |s| s.x_b),
    col(
        "x_k",
        "m",
        "far end of the holding spring (down positive)",
        |s| s.x_k,
    ),
    col(
        "delta",
        "m",
        "indentation x_s + x_b (positive compresses; negative: gap or tensile contact)",
        |s| s.delta,
    ),
    col("a", "m", "contact radius (0 out of contact)", |s| s.a),
    col(
        "a_dot",
        "m/s",
        "contact-radius rate (positive healing, 0 out of contact)",
        |s| s.a_dot,
    ),
    col(
        "F",
        "N",
        "contact force on the sphere (compressive positive)",
        |s| s.force,
    ),
    col(
        "G",
        "J/m^2",
        "energy release rate (signed: negative for a compressive edge; 0 out of contact)",
        |s| s.g,
    ),
    col(
        "w",
        "J/m^2",
        "work of adhesion w(a_dot) (w0 out of contact)",
        |s| s.w,
    ),
];

/// Name of the stage-index column (int64 in HDF5).
pub const STAGE: &str = "stage";
/// Unit of the stage index (dimensionless).
pub(crate) const STAGE_UNIT: &str = "1";
/// Description of the stage index.
pub(crate) const STAGE_DESCRIPTION: &str =
    "index of the protocol stage ([[stage]] in the scenario, 0-based)";

/// Name of the segment-index column (int64 in HDF5).
pub const SEGMENT: &str = "segment";
/// The index ranges of the gap-free stretches ("pieces") of a time series of `n` samples whose
/// segment indices are `segment`: a new piece wherever the index changes. One piece when there
/// are no indices (a file written before them). What `run.png` draws as separate lines and the
/// Python binding's `Run.pieces()` gives.
pub fn pieces(segment: &[i64], n: usize) -> Vec<std::ops::Range<usize>> {
    if segment.len() != n {
        return std::iter::once(0..n).collect();
    }
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..n {
        if segment[i] != segment[i - 1] {
            out.push(start..i);
            start = i;
        }
    }
    out.push(start..n);
    out
}

/// Description of the segment index.
pub(crate) const SEGMENT_DESCRIPTION: &str =
    "index of the gap-free stretch of the time series the sample belongs to: 0 from the start, \
     +1 after each gap (a span envelope following skipped, listed in /gaps); never draw a line \
     between samples of different segments";

/// Description of the `/gaps` group.
pub(crate) const GAPS_DESCRIPTION: &str =
    "spans of the time series that envelope following jumped over (no sample inside): each gap \
     lies between two consecutive samples, where /segment steps by one";

impl SeriesColumn {
    /// This column's schema.
    pub fn field(&self) -> Field {
        Field::f64(self.name, self.unit, self.description)
    }
}

/// The time-series schema: [`SERIES`], then the stage index and the segment index (int64).
pub(crate) fn series_schema() -> Vec<Field> {
    let mut s: Vec<Field> = SERIES.iter().map(SeriesColumn::field).collect();
    s.push(Field::i64(STAGE, STAGE_UNIT, STAGE_DESCRIPTION));
    s.push(Field::i64(SEGMENT, "1", SEGMENT_DESCRIPTION));
    s
}

/// The gaps as a table: `t_start`, `t_end` (s) and `periods` (int64). The HDF5 `/gaps` group and
/// `gaps.csv`.
pub(crate) fn gaps_table(gaps: &[Gap]) -> Table {
    Table::from_fixed(vec![
        Column::f64(
            "t_start",
            "s",
            "time of the last sample before the gap",
            gaps.iter().map(|g| g.t_start).collect(),
        ),
        Column::f64(
            "t_end",
            "s",
            "time of the first sample after the gap",
            gaps.iter().map(|g| g.t_end).collect(),
        ),
        Column::i64(
            "periods",
            "1",
            "base periods envelope following skipped (did not integrate) between the two samples",
            gaps.iter()
                .map(|g| i64::try_from(g.periods).unwrap_or(i64::MAX))
                .collect(),
        ),
    ])
}

/// Buffers a run's samples (as a table of `series_schema`) and events; the writers read them
/// at the end.
#[derive(Debug, Clone)]
pub struct TimeSeriesWriter {
    table: Table,
    events: Vec<Event>,
    /// The segment index of the samples pushed next.
    segment: i64,
    /// The gaps seen, in time order.
    gaps: Vec<Gap>,
}

impl Default for TimeSeriesWriter {
    fn default() -> Self {
        Self {
            table: Table::from_fixed(
                series_schema()
                    .into_iter()
                    .map(|f| {
                        let data = Data::empty(f.kind);
                        Column::of(f, data)
                    })
                    .collect(),
            ),
            events: Vec::new(),
            segment: 0,
            gaps: Vec::new(),
        }
    }
}

impl TimeSeriesWriter {
    /// An empty buffer.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of samples buffered.
    pub fn len(&self) -> usize {
        self.table.rows()
    }

    /// True when no sample has been buffered.
    pub fn is_empty(&self) -> bool {
        self.table.is_empty()
    }

    /// The values of f64 column `name` (one of [`SERIES`]), or `None` for an unknown name.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.table.column(name).and_then(|c| c.data.as_f64())
    }

    /// The samples as a table: the columns of [`SERIES`], then [`STAGE`].
    pub fn table(&self) -> &Table {
        &self.table
    }

    /// The stage index of each sample.
    pub fn stages(&self) -> &[i64] {
        self.table
            .column(STAGE)
            .and_then(|c| c.data.as_i64())
            .unwrap_or_default()
    }

    /// The events seen, in the order they arrived.
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// The gaps seen, in time order.
    pub fn gaps(&self) -> &[Gap] {
        &self.gaps
    }

    /// The segment index the next sample gets.
    pub fn segment(&self) -> i64 {
        self.segment
    }

    /// Set the segment index of the samples pushed from here on (a writer whose samples arrive
    /// with their segment, not through [`Observer::gap`]).
    pub fn set_segment(&mut self, segment: i64) {
        self.segment = segment;
    }

    /// The samples as a table and the events, by value (a run kept in memory).
    pub fn into_parts(self) -> (Table, Vec<Event>) {
        (self.table, self.events)
    }

    /// Forget the buffered samples and events (they went to disk).
    pub fn clear(&mut self) {
        self.table.clear();
        self.events.clear();
    }

    /// Buffer the rows of `other`, a table of this schema.
    pub fn extend(&mut self, other: &Table) -> Result<(), super::table::TableError> {
        self.table.append_rows(other)
    }

    /// Forget the first `n` samples (they went to disk).
    pub fn remove_first(&mut self, n: usize) {
        self.table.remove_first_rows(n);
    }

    /// Buffer one sample.
    pub fn push(&mut self, s: &Sample) {
        let mut row = [0.0; SERIES.len()];
        for (x, def) in row.iter_mut().zip(SERIES.iter()) {
            *x = def.value(s);
        }
        // The schema is SERIES then the stage: the row always fits.
        let pushed = self
            .table
            .push_numeric_row(&row, &[stage_index(s.stage), self.segment]);
        debug_assert!(pushed.is_ok(), "{pushed:?}");
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
    fn gap(&mut self, g: &Gap) {
        self.gaps.push(*g);
        self.segment += 1;
    }
}

/// A stage index as stored in files (int64; indices never come near 2^63).
pub fn stage_index(stage: usize) -> i64 {
    i64::try_from(stage).unwrap_or(i64::MAX)
}

/// The kebab-case name of an event kind, as in summary.json (serde's name: a unit test checks).
pub fn kind_name(kind: EventKind) -> String {
    kind_str(kind).to_string()
}

fn kind_str(kind: EventKind) -> &'static str {
    match kind {
        EventKind::ContactLoss => "contact-loss",
        EventKind::Impact => "impact",
        EventKind::PullOff => "pull-off",
        EventKind::PreloadReached => "preload-reached",
        EventKind::DurationElapsed => "duration-elapsed",
        EventKind::StageStart => "stage-start",
    }
}

/// Append one event to a table of the [`events_table`] schema (a run writer's buffer).
pub(crate) fn push_event(table: &mut Table, e: &Event) {
    let mut row = [Cell::F64(0.0); SERIES.len() + 2];
    row[0] = Cell::Text(kind_str(e.kind));
    row[1] = Cell::F64(e.time);
    row[2] = Cell::I64(stage_index(e.stage));
    for (cell, def) in row[3..]
        .iter_mut()
        .zip(SERIES.iter().filter(|c| c.name != "t"))
    {
        *cell = Cell::F64(def.value(&e.state));
    }
    let pushed = table.push_row(&row);
    debug_assert!(pushed.is_ok(), "{pushed:?}");
}

/// Description of the event `kind` column.
pub(crate) const EVENT_KIND_DESCRIPTION: &str =
    "event kind: stage-start, impact, contact-loss, preload-reached, duration-elapsed, pull-off";

/// The events as a table: `kind` (text), `time`, `stage`, then the state at the event (the
/// columns of [`SERIES`] without `t`). The HDF5 `/events` group and `events.csv`.
pub(crate) fn events_table(events: &[Event]) -> Table {
    let mut columns = vec![
        Column::text(
            "kind",
            EVENT_KIND_DESCRIPTION,
            events.iter().map(|e| kind_name(e.kind)).collect(),
        ),
        Column::f64(
            "time",
            "s",
            "time at which the event occurred (s)",
            events.iter().map(|e| e.time).collect(),
        ),
        Column::i64(
            STAGE,
            STAGE_UNIT,
            STAGE_DESCRIPTION,
            events.iter().map(|e| stage_index(e.stage)).collect(),
        ),
    ];
    columns.extend(SERIES.iter().filter(|c| c.name != "t").map(|def| {
        Column::f64(
            def.name,
            def.unit,
            def.description,
            events.iter().map(|e| def.value(&e.state)).collect(),
        )
    }));
    Table::from_fixed(columns)
}

#[cfg(test)]
mod tests {
    use super::pieces;

    /// A new piece wherever the segment index changes; one piece without indices.
    #[test]
    fn pieces_split_where_the_segment_changes() {
        assert_eq!(pieces(&[0, 0, 1, 1, 1, 2], 6), [0..2, 2..5, 5..6]);
        assert_eq!(
            pieces(&[3, 3, 3], 3),
            std::iter::once(0..3).collect::<Vec<_>>()
        );
        assert_eq!(pieces(&[], 4), std::iter::once(0..4).collect::<Vec<_>>());
    }

    use super::*;

    #[test]
    fn schemas_are_valid_tables() {
        assert!(Table::from_schema(&series_schema()).is_ok());
        let t = TimeSeriesWriter::new();
        assert_eq!(t.table().columns().len(), 13);
        assert!(Table::from_schema(&gaps_table(&[]).schema()).is_ok());
        assert_eq!(events_table(&[]).columns().len(), 13);
    }

    #[test]
    fn event_rows_and_kind_names_match_the_table_and_serde() {
        let kinds = [
            EventKind::ContactLoss,
            EventKind::Impact,
            EventKind::PullOff,
            EventKind::PreloadReached,
            EventKind::DurationElapsed,
            EventKind::StageStart,
        ];
        let mut pushed = events_table(&[]);
        let mut events = Vec::new();
        for (i, kind) in kinds.into_iter().enumerate() {
            let serde_name = serde_json::to_value(kind).unwrap();
            assert_eq!(serde_name.as_str(), Some(kind_str(kind)));
            let state = Sample {
                t: i as f64,
                x_s: 1.0,
                v_s: 2.0,
                x_b: 3.0,
                x_k: 4.0,
                delta: 5.0,
                a: 6.0,
                a_dot: 7.0,
                force: -0.5 * i as f64,
                g: 8.0,
                w: 9.0,
                stage: i,
            };
            let e = Event {
                kind,
                time: state.t,
                stage: i,
                state,
            };
            push_event(&mut pushed, &e);
            events.push(e);
        }
        assert_eq!(pushed, events_table(&events));
    }
}
