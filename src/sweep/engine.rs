//! Running a sweep: every point validated before anything runs, runs in parallel on a pool of
//! worker threads, each row handed back as its run ends.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::Instant;

use crate::output::RunWriter;
use crate::scenario::overrides::{Override, SetKey};
use crate::scenario::parse::{ScenarioError, ScenarioSource};
use crate::scenario::Scenario;
use djkr_core::dynamics::{CycleRecord, Event, Model, Observer, Sample, Status, StepSamples};

use super::grid::{Grid, MAX_RUNS};
use super::phase::ensemble_phase;
use super::row::{KeyColumn, Row, RunNumbers};

/// Why a sweep cannot start.
#[derive(Debug)]
pub enum SweepError {
    /// A point the scenario's rules reject: `--set base.amplitude=-1um (point 3): must be ...`.
    Override {
        /// The point (from 0).
        point: usize,
        /// The override at fault, `KEY=VALUE`.
        set: String,
        /// What is wrong.
        message: String,
    },
    /// A point whose scenario is invalid for a reason that is not one override's.
    Point {
        /// The point (from 0).
        point: usize,
        /// The scenario's error.
        source: Box<ScenarioError>,
    },
    /// The ensemble cannot be drawn.
    Ensemble {
        /// The members asked for.
        members: usize,
        /// What is wrong.
        message: String,
    },
}

/// An ensemble: `members` runs per point, each with its base phase drawn from `seed`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ensemble {
    /// Members per point (≥ 1).
    pub members: usize,
    /// Seed of the phases.
    pub seed: u64,
}

impl SweepError {
    /// The message in the words of a front end.
    pub fn in_words(&self, w: &dyn crate::words::Words) -> String {
        let text = match self {
            SweepError::Override {
                point,
                set,
                message,
            } => format!(
                "{} (point {point}): {message}",
                w.overrides(std::slice::from_ref(set))
            ),
            SweepError::Point { point, source } => {
                format!("point {point}: {}", source.in_words(w))
            }
            SweepError::Ensemble { members, message } => {
                format!(
                    "{}: {message}",
                    w.input_value("ensemble", &members.to_string())
                )
            }
        };
        crate::words::render(&text, w)
    }
}

impl std::fmt::Display for SweepError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.in_words(&crate::words::Plain))
    }
}

impl std::error::Error for SweepError {}

/// The runs of a study, the product of `factors` (each a count and what it counts:
/// `(12, "points")`, `(8, "members")`), refused past [`MAX_RUNS`] with the product as given:
/// `12 points x 8 members is more than 10000000 runs`. The one bound on the runs a study holds
/// at once: a sweep's points times its ensemble's members (its rows are held in memory until
/// the tables are written), and a fit's rows times members times the parameter sets of one
/// iteration (one grid of runs, built in memory before any runs).
pub(crate) fn check_runs(factors: &[(usize, &str)]) -> Result<usize, String> {
    factors
        .iter()
        .try_fold(1usize, |n, (k, _)| n.checked_mul(*k))
        .filter(|n| *n <= MAX_RUNS)
        .ok_or_else(|| {
            let product = factors
                .iter()
                .map(|(k, what)| format!("{k} {what}"))
                .collect::<Vec<_>>()
                .join(" x ");
            format!("{product} is more than {MAX_RUNS} runs")
        })
}

/// A run of a sweep: its point and member.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) struct RunId {
    /// Point (from 0).
    pub point: usize,
    /// Member (from 0).
    pub member: usize,
}

/// A scenario file, the points of a grid and an optional ensemble: every run validated.
#[derive(Debug, Clone)]
pub(crate) struct Sweep {
    source: ScenarioSource,
    grid: Grid,
    ensemble: Option<Ensemble>,
    phase_key: SetKey,
}

impl Sweep {
    /// Validate every point of `grid` on `source` (and, with an ensemble, that every point has
    /// a `[base]` whose phase to draw) before anything runs.
    pub fn new(
        source: ScenarioSource,
        grid: Grid,
        ensemble: Option<Ensemble>,
    ) -> Result<Sweep, SweepError> {
        let phase_key = SetKey::parse("base.phase").map_err(|e| SweepError::Ensemble {
            members: 0,
            message: e.to_string(),
        })?;
        if let Some(e) = ensemble {
            let err = |message: String| SweepError::Ensemble {
                members: e.members,
                message,
            };
            if e.members == 0 {
                return Err(err("must be a whole number >= 1 (members per point)".into()));
            }
            if let Some(a) = grid.axes().iter().find(|a| a.key == phase_key) {
                return Err(err(format!(
                    "the ensemble draws base.phase, which {} also sets: drop one",
                    crate::words::set_item(&a.shown())
                )));
            }
            check_runs(&[(grid.points(), "points"), (e.members, "members")]).map_err(err)?;
        }
        let sweep = Sweep {
            source,
            grid,
            ensemble,
            phase_key,
        };
        for p in 0..sweep.grid.points() {
            let scn = sweep
                .source
                .scenario(&sweep.grid.overrides(p))
                .map_err(|e| point_error(p, e))?;
            if let Some(e) = ensemble {
                if scn.rig.base.is_none() {
                    return Err(SweepError::Ensemble {
                        members: e.members,
                        message: format!(
                            "{} has no [base] section (point {p}): the ensemble draws the base \
                             phase at shaker-on ([base] phase); add [base] or drop «ensemble»",
                            scn.source_name
                        ),
                    });
                }
            }
        }
        Ok(sweep)
    }

    /// The scenario file.
    pub fn source(&self) -> &ScenarioSource {
        &self.source
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The ensemble, if any.
    pub fn ensemble(&self) -> Option<Ensemble> {
        self.ensemble
    }

    /// Members per point (1 without an ensemble).
    pub fn members(&self) -> usize {
        self.ensemble.map_or(1, |e| e.members)
    }

    /// Number of runs: points × members.
    pub fn runs(&self) -> usize {
        self.grid.points() * self.members()
    }

    /// Run `index` (from 0) in (point, member) order.
    pub fn run_id(&self, index: usize) -> RunId {
        RunId {
            point: index / self.members(),
            member: index % self.members(),
        }
    }

    /// The index of a run in (point, member) order.
    pub fn run_index(&self, id: RunId) -> usize {
        id.point * self.members() + id.member
    }

    /// The key columns of the tables.
    pub fn key_columns(&self) -> Vec<KeyColumn> {
        self.grid
            .axes()
            .iter()
            .map(|a| KeyColumn {
                name: a.key.to_string(),
                unit: a.unit().map(str::to_string),
            })
            .collect()
    }

    /// The drawn phase of a run (rad), with an ensemble.
    pub fn drawn_phase(&self, id: RunId) -> Option<f64> {
        self.ensemble
            .map(|e| ensemble_phase(e.seed, id.point as u64, id.member as u64))
    }

    /// The overrides of a run: the point's, then `base.phase` with an ensemble (as
    /// `djkr run FILE --set ... --set base.phase=PHI` would give them).
    pub fn overrides(&self, id: RunId) -> Vec<Override> {
        let mut o = self.grid.overrides(id.point);
        if let Some(phi) = self.drawn_phase(id) {
            if let Ok(p) = Override::from_key(self.phase_key, phi) {
                o.push(p);
            }
        }
        o
    }

    /// The scenario of a run: the file with the run's overrides, as `djkr run FILE --set ...`
    /// gives it ([`ScenarioSource::scenario`], the one way a scenario is built: each value
    /// validated as the edited file's would be).
    pub fn scenario(&self, id: RunId) -> Result<Scenario, ScenarioError> {
        self.source.scenario(&self.overrides(id))
    }

    /// Run one member. `None` when `stop` was raised and the run abandoned (it is not a row).
    /// With `keep`, the run's own folder is written there (`run.h5`, `summary.json`, CSV and plot
    /// as the scenario's `[output]` asks).
    pub fn run(&self, id: RunId, stop: Option<&AtomicBool>, keep: Option<&Path>) -> Option<Row> {
        let t0 = Instant::now();
        let keys = self.grid.cells(id.point);
        let scn = match self.scenario(id) {
            Ok(s) => s,
            Err(e) => {
                let phase = self.drawn_phase(id).unwrap_or(f64::NAN);
                let wall = t0.elapsed().as_secs_f64();
                return Some(Row::failed(
                    id.point,
                    id.member,
                    keys,
                    phase,
                    &e.to_string(),
                    wall,
                ));
            }
        };
        let phase = self
            .drawn_phase(id)
            .unwrap_or_else(|| scn.rig.base.map_or(0.0, |b| b.phase));
        let failed = |message: &str| {
            Some(Row::failed(
                id.point,
                id.member,
                keys.clone(),
                phase,
                message,
                t0.elapsed().as_secs_f64(),
            ))
        };
        let mut writer = match keep {
            Some(dir) => match RunWriter::create(dir, &scn, scn.output.csv) {
                Ok(w) => Some(w),
                Err(e) => return failed(&format!("run folder: {e}")),
            },
            None => None,
        };
        let mut obs = SweepObserver {
            stop,
            stopped: false,
            inner: writer.as_mut(),
        };
        let outcome = scn.simulate_partial(&mut obs);
        if obs.stopped {
            return None;
        }
        let outcome = match outcome {
            Ok(o) => o,
            Err(e) => return failed(&e.to_string()),
        };
        // A run that a budget stopped or that failed mid-way keeps its run folder, with its
        // status, like `djkr run`'s.
        let ending = match &writer {
            Some(w) => w.explain(outcome.ending()),
            None => outcome.ending(),
        };
        let result = outcome.result;
        if let Some(w) = writer {
            let dir = w.dir().to_path_buf();
            if let Err(e) = w.finish_with(&result, &ending) {
                return failed(&format!("run folder: {e}"));
            }
            if scn.output.plot && ending.status() == Status::Ok {
                if let Err(e) = crate::run_plot::plot_run_dir(&dir) {
                    return failed(&format!("run plot: {e}"));
                }
            }
        }
        let message = ending.message.as_deref().unwrap_or_default();
        match ending.status() {
            Status::Ok => Some(Row {
                point: id.point,
                member: id.member,
                keys,
                phase,
                result: Ok(RunNumbers::of(&result)),
                stopped: false,
                wall_s: result.stats.wall_s,
            }),
            Status::Stopped => Some(Row::stopped(
                id.point,
                id.member,
                keys,
                phase,
                message,
                result.stats.wall_s,
            )),
            Status::Failed => failed(message),
        }
    }
}

/// A point's validation error, named by its override when one is at fault.
fn point_error(point: usize, e: ScenarioError) -> SweepError {
    match e {
        ScenarioError::Override { set, message, .. } => SweepError::Override {
            point,
            set,
            message,
        },
        source => SweepError::Point {
            point,
            source: Box::new(source),
        },
    }
}

/// What a sweep's run watches: nothing but the stop request (and, with `--keep-runs`, the run
/// writer). It takes samples like `djkr run`'s writer does, because the driver's step control
/// depends on whether samples are wanted (`[output] sample_rate > 0` keeps DP8's steps within
/// 1/16 of a base period): the same observer contract gives the same numbers. Samples are
/// not built (without `--keep-runs`), so memory per run does not grow with its length.
struct SweepObserver<'a> {
    stop: Option<&'a AtomicBool>,
    stopped: bool,
    inner: Option<&'a mut RunWriter>,
}

impl SweepObserver<'_> {
    /// True (and remembered) once a stop was requested.
    fn stop_requested(&mut self) -> bool {
        if self.stop.is_some_and(|f| f.load(Ordering::Relaxed)) {
            self.stopped = true;
        }
        self.stopped
    }
}

impl Observer for SweepObserver<'_> {
    fn sample(&mut self, s: &Sample) -> bool {
        if self.stop_requested() {
            return false;
        }
        match self.inner.as_deref_mut() {
            Some(w) => w.sample(s),
            None => true,
        }
    }
    fn step_samples(&mut self, model: &Model, step: &StepSamples) -> bool {
        if self.stop_requested() {
            return false;
        }
        // Without a run folder the samples are not even built.
        match self.inner.as_deref_mut() {
            Some(w) => w.step_samples(model, step),
            None => true,
        }
    }
    fn event(&mut self, e: &Event) {
        if let Some(w) = self.inner.as_deref_mut() {
            w.event(e);
        }
    }
    fn cycle(&mut self, c: &CycleRecord) {
        if let Some(w) = self.inner.as_deref_mut() {
            w.cycle(c);
        }
    }
    fn gap(&mut self, g: &djkr_core::dynamics::Gap) {
        if let Some(w) = self.inner.as_deref_mut() {
            w.gap(g);
        }
    }
    fn stop_reason(&self) -> Option<djkr_core::dynamics::Reason> {
        // The kept run's writer (the free disk space); a stop of the sweep's is no run's reason.
        if self.stopped {
            return None;
        }
        self.inner.as_deref().and_then(Observer::stop_reason)
    }
}

/// How to run a sweep's runs.
#[derive(Debug, Clone, Default)]
pub(crate) struct RunOptions<'a> {
    /// Worker threads (0: one per core).
    pub jobs: usize,
    /// Raised (e.g. by Ctrl-C): no new run starts, running ones are abandoned.
    pub stop: Option<&'a AtomicBool>,
    /// Keep each run's own folder under this directory (`p<point>-m<member>`).
    pub keep_runs: Option<PathBuf>,
}

/// The folder of a kept run: `p000003-m0012` (digits enough for the sweep's largest indices).
pub(crate) fn run_folder_name(sweep: &Sweep, id: RunId) -> String {
    let pw = digits(sweep.grid().points().saturating_sub(1));
    let mw = digits(sweep.members().saturating_sub(1));
    format!(
        "p{:0pw$}-m{:0mw$}",
        id.point,
        id.member,
        pw = pw.max(4),
        mw = mw.max(2)
    )
}

fn digits(mut n: usize) -> usize {
    let mut d = 1;
    while n >= 10 {
        n /= 10;
        d += 1;
    }
    d
}

/// Run `runs` (indices in (point, member) order) on `opts.jobs` threads, in index order as far as
/// threads allow, handing each row to `on_row` on the calling thread as its run ends (completion
/// order). Returns the number of runs that were not started or were abandoned because `stop`
/// was raised (0 when all ran).
pub(crate) fn run_sweep(
    sweep: &Sweep,
    runs: &[usize],
    opts: &RunOptions,
    mut on_row: impl FnMut(Row),
) -> usize {
    let jobs = if opts.jobs == 0 {
        std::thread::available_parallelism().map_or(1, usize::from)
    } else {
        opts.jobs
    }
    .min(runs.len().max(1));
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<Row>();
    let mut done = 0;
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            let tx = tx.clone();
            let next = &next;
            scope.spawn(move || loop {
                if opts.stop.is_some_and(|f| f.load(Ordering::Relaxed)) {
                    return;
                }
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&index) = runs.get(i) else {
                    return;
                };
                let id = sweep.run_id(index);
                let keep = opts
                    .keep_runs
                    .as_ref()
                    .map(|d| d.join(run_folder_name(sweep, id)));
                if let Some(row) = sweep.run(id, opts.stop, keep.as_deref()) {
                    if tx.send(row).is_err() {
                        return;
                    }
                }
            });
        }
        drop(tx);
        for row in rx {
            done += 1;
            on_row(row);
        }
    });
    runs.len() - done
}

/// Run every run of `sweep` and return the rows sorted by (point, member), as `sweep.csv`
/// holds them ([`super::row::rows_table`] makes the table): the whole sweep in one call, for
/// programs (and a Python binding) that want the columns rather than the files. Runs abandoned
/// because `opts.stop` was raised are left out.
pub(crate) fn run_all(sweep: &Sweep, opts: &RunOptions) -> Vec<Row> {
    let runs: Vec<usize> = (0..sweep.runs()).collect();
    let mut rows = Vec::with_capacity(runs.len());
    run_sweep(sweep, &runs, opts, |r| rows.push(r));
    rows.sort_by_key(|r| (r.point, r.member));
    rows
}
