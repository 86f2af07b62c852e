//! Studies: sweeps and ensembles over any scenario key (`djkr sweep`).
//!
//! A sweep is a scenario file, a grid of override sets and optionally an ensemble; from outside
//! the crate it runs through [`crate::api::sweep`] (or `djkr sweep`, which writes a folder).
//!
//! - `spec`: `KEY=SPEC` (a list `10um,30um`, `START:STOP:N`, `START:STOP:Nlog`) and the unit of
//!   every key; `grid` (`Grid`): the points (Cartesian in the order given, or `zip`).
//! - `engine`: `Sweep::new` validates every point before anything runs (a bad one is named:
//!   `--set base.amplitude=-1um (point 3): ...`); `run_sweep` runs on a pool of threads and
//!   hands each [`Row`] back as it ends. A run is exactly `djkr run FILE --set KEY=VALUE ...`:
//!   the same override list on the same parsed file, the same `Scenario::simulate` with an
//!   observer of the same kind as the run writer's (the step control depends on whether samples
//!   are wanted), the same `RunResult` fields. A run that fails is a row with its error.
//! - `phase`: an ensemble member's base phase at shaker-on ([`crate::scenario::BaseMotion`]
//!   `phase`, applied as `--set base.phase=PHI`) is a hash of (seed, point, member), so rows do
//!   not depend on thread count, order, resume or sharding.
//! - `row`, `stats`: the tables `sweep.csv`/`sweep.h5` (one row per run) and `points.csv`
//!   (one row per point, the members' statistics); `plots`: the figures.
//! - `files`: the sweep folder (`sweep.json`, the `progress.csv` journal read by `--resume`,
//!   the final files written atomically), Slurm shards (`Shard`: run i belongs to shard
//!   (i mod N) + 1) and their merge.
//!
//! Memory: a run's time series is never kept (the observer drops samples; with `--keep-runs`
//! the run writer holds one run's series until it is written); what grows with the sweep is one
//! row per run (~0.3 kB).

pub(crate) mod engine;
pub(crate) mod files;
pub(crate) mod grid;
pub(crate) mod phase;
pub(crate) mod plots;
pub(crate) mod row;
pub(crate) mod spec;
pub(crate) mod stats;

pub(crate) use engine::{check_runs, run_all, run_sweep, RunOptions, Sweep};
pub use engine::{Ensemble, SweepError};
pub use grid::Axis;
pub(crate) use grid::Grid;
pub use phase::uniform;
pub(crate) use row::rows_table;
pub use row::{KeyColumn, Row, RunNumbers};
pub use spec::{KeyCell, SpecError};
pub use stats::{point_stats, points_table, PointStats, Summary};
