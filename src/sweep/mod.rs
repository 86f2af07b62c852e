//! Studies: sweeps and ensembles over any scenario key (`djkr sweep`).
//!
//! A sweep is a scenario file, a grid of override sets and optionally an ensemble:
//!
//! ```no_run
//! use djkr::scenario::parse::ScenarioSource;
//! use djkr::sweep::{rows_table, run_all, Axis, Ensemble, Grid, RunOptions, Sweep};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let source = ScenarioSource::read("scenarios/paper-protocol-300hz.toml".as_ref())?;
//! let grid = Grid::new(
//!     vec![Axis::parse("base.frequency=200,300,400")?, Axis::parse("base.amplitude=10um:60um:6")?],
//!     false,
//! )?;
//! let sweep = Sweep::new(source, grid, Some(Ensemble { members: 8, seed: 1 }))?;
//! let rows = run_all(&sweep, &RunOptions { jobs: 2, ..RunOptions::default() });
//! let table = rows_table(&sweep.key_columns(), &rows); // the columns of sweep.csv
//! # let _ = table;
//! # Ok(()) }
//! ```
//!
//! - `spec`: `KEY=SPEC` (a list `10um,30um`, `START:STOP:N`, `START:STOP:Nlog`) and the unit of
//!   every key; `grid` ([`Grid`]): the points (Cartesian in the order given, or `zip`).
//! - `engine`: [`Sweep::new`] validates every point before anything runs (a bad one is named:
//!   `--set base.amplitude=-1um (point 3): ...`); [`run_sweep`] runs on a pool of threads and
//!   hands each [`Row`] back as it ends. A run is exactly `djkr run FILE --set KEY=VALUE ...`:
//!   the same override list on the same parsed file, the same `Scenario::simulate` with an
//!   observer of the same kind as the run writer's (the step control depends on whether samples
//!   are wanted), the same `RunResult` fields. A run that fails is a row with its error.
//! - [`phase`]: an ensemble member's base phase at shaker-on ([`crate::scenario::BaseMotion`]
//!   `phase`, applied as `--set base.phase=PHI`) is a hash of (seed, point, member), so rows do
//!   not depend on thread count, order, resume or sharding.
//! - [`row`], [`stats`]: the tables `sweep.csv`/`sweep.h5` (one row per run) and `points.csv`
//!   (one row per point, the members' statistics); `plots`: the figures.
//! - [`files`]: the sweep folder (`sweep.json`, the `progress.csv` journal read by `--resume`,
//!   the final files written atomically), Slurm shards ([`Shard`]: run i belongs to shard
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
