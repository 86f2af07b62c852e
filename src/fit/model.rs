//! The forward model of a fit: each data row is the scenario with that row's conditions and the
//! free keys' current values set, run by the sweep engine (the same runs as `djkr run` and
//! `djkr sweep`, the observable read as `sweep.csv` holds it), all rows and all parameter sets of
//! a batch in parallel.
//!
//! With an ensemble, a row's prediction is the mean over its members, whose base phases are
//! [`crate::sweep::phase::ensemble_phase`]`(seed, row, member)`: the same phases at every
//! evaluation, so that a finite-difference Jacobian sees the parameters and not new noise.

use std::sync::atomic::{AtomicBool, Ordering};

use crate::scenario::overrides::{Override, SetKey, SetValue};
use crate::scenario::parse::ScenarioSource;
use crate::sweep::grid::{Axis, Grid};
use crate::sweep::phase::ensemble_phase;
use crate::sweep::spec::{KeyCell, SpecForm, SpecValue};
use crate::sweep::{check_runs, run_sweep, RunOptions, Sweep};
use crate::words::{input, input_value, set_item};

use super::data::{CondValue, FitData};
use djkr_core::text::excerpt;

/// The model's prediction for every data row, at one parameter set.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// The observable per row (SI): the run's, or the members' mean.
    pub values: Vec<f64>,
    /// The standard error of the members' mean per row (0 without an ensemble).
    pub se: Vec<f64>,
    /// Right-hand-side evaluations of the runs that made it (all rows and members).
    pub rhs_evals: u64,
}

/// Why an evaluation gave no prediction.
#[derive(Debug, Clone, PartialEq)]
pub enum EvalError {
    /// Stopped (Ctrl-C) before every run ended.
    Stopped,
    /// A run failed or a scenario was refused: the message names the row and the values.
    Failed(String),
}

/// One value of each free key.
pub type ParamSet = Vec<f64>;

/// A scenario file, data, the free keys and fixed overrides: predictions for parameter sets.
#[derive(Debug, Clone)]
pub struct ForwardModel {
    source: ScenarioSource,
    data: FitData,
    free: Vec<SetKey>,
    fixed: Vec<Override>,
    /// The fit's own solver settings (tolerances chosen from the data), set after `fixed` on
    /// every run; none unless [`Self::with_solver`] gave some.
    solver: Vec<Override>,
    ensemble: Option<(usize, u64)>,
    jobs: usize,
}

impl ForwardModel {
    /// The model of `data` on `source`, with `free` keys (values given per evaluation), `fixed`
    /// overrides for every row (`--set`), an optional ensemble `(members, seed)` and `jobs`
    /// threads (0: one per core). A key given twice (a condition also free or also `--set`) is
    /// refused.
    pub fn new(
        source: ScenarioSource,
        data: FitData,
        free: Vec<SetKey>,
        fixed: Vec<Override>,
        ensemble: Option<(usize, u64)>,
        jobs: usize,
    ) -> Result<ForwardModel, String> {
        let phase = SetKey::parse("base.phase").map_err(|e| e.to_string())?;
        let mut seen: Vec<(SetKey, String)> = Vec::new();
        let keys = data
            .conditions
            .iter()
            .map(|c| (c.key, format!("a column of {}", data.name)))
            .chain(
                free.iter()
                    .map(|k| (*k, input_value("free", &k.to_string()))),
            )
            .chain(fixed.iter().map(|o| (o.key(), set_item(&o.to_string()))))
            .chain(ensemble.map(|_| {
                (
                    phase,
                    format!("{} (it draws base.phase)", input("ensemble")),
                )
            }));
        for (k, what) in keys {
            if let Some((_, first)) = seen.iter().find(|(s, _)| *s == k) {
                return Err(format!("{k} is both {first} and {what}: give it once"));
            }
            seen.push((k, what));
        }
        if let Some((m, _)) = ensemble {
            if m == 0 {
                return Err(format!(
                    "{}: must be a whole number >= 1 (members per row)",
                    input_value("ensemble", "0")
                ));
            }
        }
        let model = ForwardModel {
            source,
            data,
            free,
            fixed,
            solver: Vec::new(),
            ensemble,
            jobs,
        };
        model.check_batch_size()?;
        Ok(model)
    }

    /// Refuse a fit whose largest batch of runs (every run of one iteration: rows × members ×
    /// [`sets_per_iteration`], one grid built in memory before any of them runs) would
    /// pass the bounds of a sweep: [`crate::sweep::check_runs`]'s count of runs, and the memory
    /// the batch's grid holds ([`Self::batch_bytes`]) against the scenario's
    /// `solver.max_memory`, the budget of issue 24 (the parser's default when the scenario with
    /// the fixed overrides does not parse: that error is the caller's to report). Without this
    /// `--ensemble 99999999999` aborted the process (and a Python session) on an allocation of
    /// 28.8 TB, and `--ensemble 10000000` allocated 2.9 GB at once.
    fn check_batch_size(&self) -> Result<(), String> {
        let rows = self.data.rows.len();
        let members = self.members();
        let sets = sets_per_iteration(members, self.free.len());
        let what = match self.ensemble {
            Some((m, _)) => input_value("ensemble", &m.to_string()),
            None => self.data.name.clone(),
        };
        let mut factors = vec![(rows, "rows")];
        if self.ensemble.is_some() {
            factors.push((members, "members"));
        }
        factors.push((sets, "parameter sets of one iteration"));
        let runs = check_runs(&factors).map_err(|m| {
            format!(
                "{what}: {m} (a fit runs an iteration's parameter sets as one batch){}",
                if self.ensemble.is_some() {
                    "; use fewer members"
                } else {
                    ""
                }
            )
        })?;
        let budget = self
            .source
            .scenario(&self.fixed)
            .map_or(djkr_core::dynamics::methods::DEFAULT_MAX_MEMORY, |s| {
                s.solver.max_memory
            });
        let bytes = self.batch_bytes(runs);
        if bytes > budget as f64 {
            return Err(format!(
                "{what}: a batch of {runs} runs ({}) would hold about {} ({bytes:.3e} bytes: \
                 {:.0} bytes a run for its {} keys and result) in memory, more than \
                 solver.max_memory = {budget} bytes ({}){}",
                factors
                    .iter()
                    .map(|(k, what)| format!("{k} {what}"))
                    .collect::<Vec<_>>()
                    .join(" x "),
                crate::memory::human_bytes(bytes),
                bytes / runs as f64,
                self.batch_axes(),
                crate::memory::human_bytes(budget as f64),
                if self.ensemble.is_some() {
                    "; use fewer members, or raise solver.max_memory"
                } else {
                    "; raise solver.max_memory"
                }
            ));
        }
        Ok(())
    }

    /// The keys a batch's grid sets: one axis each ([`Self::batch_grid`]).
    fn batch_axes(&self) -> usize {
        self.data.conditions.len()
            + self.free.len()
            + self.fixed.len()
            + self.solver.len()
            + usize::from(self.ensemble.is_some())
    }

    /// The bytes a batch of `runs` runs holds before and while it runs: per run, a value of
    /// each of its axes ([`SpecValue`], with the text of a text value twice: the override's and
    /// the table's), its index in the list of runs to do (one `usize`) and its result (one
    /// `f64`). What the sweep engine holds per running job is bounded by the jobs, not counted.
    /// Measured: a batch of 9e6 runs of two axes, counted 144 bytes a run (1.30e9 bytes), peaked
    /// at 1.45e9 bytes resident, the executable and the threads' stacks included.
    fn batch_bytes(&self, runs: usize) -> f64 {
        let value = std::mem::size_of::<SpecValue>();
        let text_conditions: usize = self
            .data
            .conditions
            .iter()
            .enumerate()
            .map(|(j, _)| {
                self.data
                    .rows
                    .iter()
                    .map(|r| match &r.conditions[j] {
                        CondValue::Text(t) => 2 * t.len(),
                        CondValue::Num(_) => 0,
                    })
                    .max()
                    .unwrap_or(0)
            })
            .sum();
        let text_fixed: usize = self
            .fixed
            .iter()
            .chain(&self.solver)
            .map(|o| 2 * o.to_string().len())
            .sum();
        let per_run = std::mem::size_of::<f64>()
            + std::mem::size_of::<usize>()
            + self.batch_axes() * value
            + text_conditions
            + text_fixed;
        runs as f64 * per_run as f64
    }

    /// The same model with the solver settings `solver` (`solver.rtol`, `solver.envelope_tol`)
    /// set on every run after the fixed overrides; a key the fixed overrides set is left to
    /// them (`--set` wins).
    pub fn with_solver(&self, solver: Vec<Override>) -> ForwardModel {
        let solver = solver
            .into_iter()
            .filter(|o| !self.fixed.iter().any(|f| f.key() == o.key()))
            .collect();
        ForwardModel {
            solver,
            ..self.clone()
        }
    }

    /// The fit's own solver settings ([`Self::with_solver`]).
    pub fn solver(&self) -> &[Override] {
        &self.solver
    }

    /// The data.
    pub fn data(&self) -> &FitData {
        &self.data
    }

    /// The scenario file.
    pub fn source(&self) -> &ScenarioSource {
        &self.source
    }

    /// The free keys.
    pub fn free(&self) -> &[SetKey] {
        &self.free
    }

    /// The fixed overrides.
    pub fn fixed(&self) -> &[Override] {
        &self.fixed
    }

    /// The ensemble `(members, seed)`, if any.
    pub fn ensemble(&self) -> Option<(usize, u64)> {
        self.ensemble
    }

    /// Threads (0: one per core).
    pub fn jobs(&self) -> usize {
        self.jobs
    }

    /// Members per row (1 without an ensemble).
    pub fn members(&self) -> usize {
        self.ensemble.map_or(1, |e| e.0)
    }

    /// Forward runs per parameter set.
    pub fn runs_per_set(&self) -> usize {
        self.data.rows.len() * self.members()
    }

    /// The one place where a fit sets scenario keys: the grid of a batch, a zip of one axis per
    /// key, whose point `(s · rows + i) · members + m` is parameter set `s` on data row `i`,
    /// member `m`: the row's conditions, the set's free values, the fixed `--set` overrides and,
    /// with an ensemble, the member's base phase. Every value goes in as `--set KEY=VALUE` would
    /// (SI numbers as numbers, text as typed), so a point is `djkr run FILE --set ...`.
    fn batch_grid(&self, sets: &[ParamSet]) -> Result<Grid, String> {
        let rows = self.data.rows.len();
        let members = self.members();
        let points = sets.len() * rows * members;
        let mut axes = Vec::new();
        let mut axis = |key: SetKey, value: &dyn Fn(usize, usize, usize) -> SpecValue| {
            let mut values = Vec::with_capacity(points);
            for s in 0..sets.len() {
                for i in 0..rows {
                    for m in 0..members {
                        values.push(value(s, i, m));
                    }
                }
            }
            axes.push(Axis {
                key,
                spec: String::new(),
                form: SpecForm::List,
                values,
            });
        };
        let num = |x: f64| SpecValue {
            set: SetValue::Float(x),
            cell: KeyCell::Num(x),
        };
        for (j, c) in self.data.conditions.iter().enumerate() {
            axis(c.key, &|_, i, _| match &self.data.rows[i].conditions[j] {
                CondValue::Num(x) => num(*x),
                CondValue::Text(t) => SpecValue {
                    set: SetValue::Text(t.clone()),
                    cell: KeyCell::Text(t.clone()),
                },
            });
        }
        for (j, k) in self.free.iter().enumerate() {
            axis(*k, &|s, _, _| num(sets[s][j]));
        }
        for o in self.fixed.iter().chain(&self.solver) {
            let text = o.to_string();
            let value = text.split_once('=').map_or("", |p| p.1).to_string();
            axis(o.key(), &|_, _, _| SpecValue {
                set: SetValue::Text(value.clone()),
                cell: KeyCell::Text(value.clone()),
            });
        }
        if let Some((_, seed)) = self.ensemble {
            let phase = SetKey::parse("base.phase").map_err(|e| e.to_string())?;
            axis(phase, &|_, i, m| {
                num(ensemble_phase(seed, i as u64, m as u64))
            });
        }
        Grid::new(axes, true).map_err(|e| e.to_string())
    }

    /// The overrides that reproduce row `i` at parameter set `x` (member 0): what
    /// `djkr run FILE --set ...` needs, for messages and for the residuals' reproduction.
    pub fn row_overrides(&self, x: &[f64], i: usize) -> Result<Vec<Override>, String> {
        let grid = self.batch_grid(&[x.to_vec()])?;
        Ok(grid.overrides(i * self.members()))
    }

    /// Predict every row for each parameter set in `sets`, running all their runs in parallel;
    /// `on_run` is called on this thread as each run ends. A run that fails or a scenario that
    /// is refused makes the whole batch fail (named); `stop` abandons it.
    pub fn predict(
        &self,
        sets: &[ParamSet],
        stop: Option<&AtomicBool>,
        on_run: &mut dyn FnMut(),
    ) -> Result<Vec<Prediction>, EvalError> {
        let grid = self.batch_grid(sets).map_err(EvalError::Failed)?;
        let sweep = Sweep::new(self.source.clone(), grid, None)
            .map_err(|e| EvalError::Failed(self.describe_point_error(sets, &e.to_string(), &e)))?;
        let runs: Vec<usize> = (0..sweep.runs()).collect();
        let mut values = vec![f64::NAN; runs.len()];
        let mut rhs = vec![0u64; runs.len()];
        let mut failure: Option<(usize, String)> = None;
        let opts = RunOptions {
            jobs: self.jobs,
            stop,
            keep_runs: None,
        };
        let not_run = run_sweep(&sweep, &runs, &opts, |row| {
            on_run();
            let p = row.point;
            match &row.result {
                Ok(n) => {
                    rhs[p] = n.rhs_evals;
                    let v = self.data.observable.of(n);
                    if v.is_finite() {
                        values[p] = v;
                    } else if failure.as_ref().is_none_or(|(q, _)| p < *q) {
                        // An amplification is defined for a tensile pull-off force only.
                        let why = if self.data.observable
                            == super::data::Observable::PullOffAmplification
                            && n.pull_off_force >= 0.0
                        {
                            format!(
                                "its pull-off force {} N is not tensile (no cycle mean was: \
                                 the sphere came off without an adhesive pull-off)",
                                crate::output::table::format_f64(n.pull_off_force)
                            )
                        } else {
                            "NaN: no vibration cycle recorded?".to_string()
                        };
                        failure = Some((
                            p,
                            format!("the run gives no {} ({why})", self.data.observable.name()),
                        ));
                    }
                }
                Err(e) => {
                    if failure.as_ref().is_none_or(|(q, _)| p < *q) {
                        failure = Some((p, e.clone()));
                    }
                }
            }
        });
        if not_run > 0 || stop.is_some_and(|f| f.load(Ordering::Relaxed)) {
            return Err(EvalError::Stopped);
        }
        if let Some((p, e)) = failure {
            return Err(EvalError::Failed(format!(
                "{}: {e}",
                self.describe_run(&sweep, p)
            )));
        }
        let rows = self.data.rows.len();
        let members = self.members();
        Ok((0..sets.len())
            .map(|s| {
                let mut mean = Vec::with_capacity(rows);
                let mut se = Vec::with_capacity(rows);
                for i in 0..rows {
                    let base = (s * rows + i) * members;
                    let v = &values[base..base + members];
                    let m = v.iter().sum::<f64>() / members as f64;
                    mean.push(m);
                    se.push(if members > 1 {
                        let var =
                            v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (members - 1) as f64;
                        (var / members as f64).sqrt()
                    } else {
                        0.0
                    });
                }
                let per_set = rows * members;
                let rhs_evals = rhs[s * per_set..(s + 1) * per_set].iter().sum();
                Prediction {
                    values: mean,
                    se,
                    rhs_evals,
                }
            })
            .collect())
    }

    /// Row and overrides of a batch's point, for messages.
    fn describe_run(&self, sweep: &Sweep, point: usize) -> String {
        let rows = self.data.rows.len();
        let members = self.members();
        let i = (point / members) % rows;
        let sets: Vec<String> = sweep
            .grid()
            .overrides(point)
            .iter()
            .map(|o| set_item(&excerpt(&o.to_string())))
            .collect();
        format!(
            "{} line {} ({})",
            self.data.name,
            self.data.rows[i].line,
            sets.join(" ")
        )
    }

    /// A batch refused before it ran: the sweep's message names the point; name the data line.
    fn describe_point_error(
        &self,
        _sets: &[ParamSet],
        text: &str,
        e: &crate::sweep::SweepError,
    ) -> String {
        let point = match e {
            crate::sweep::SweepError::Override { point, .. }
            | crate::sweep::SweepError::Point { point, .. } => Some(*point),
            crate::sweep::SweepError::Ensemble { .. } => None,
        };
        // An override's value may be a cell of the data file (a text key's, of any length):
        // quoted cut, and without the sweep's point number, which means nothing to a fit.
        let text = match e {
            crate::sweep::SweepError::Override { set, message, .. } => {
                format!("{}: {message}", set_item(&excerpt(set)))
            }
            _ => text.to_string(),
        };
        match point {
            Some(p) => {
                let i = (p / self.members()) % self.data.rows.len();
                format!("{} line {}: {text}", self.data.name, self.data.rows[i].line)
            }
            None => text,
        }
    }
}

/// Parameter sets a typical iteration evaluates (the trial step and the Jacobian's) with `k`
/// free keys: `k + 1` with forward differences, `2k + 1` with an ensemble's central ones; for a
/// progress bar's length.
pub(crate) fn sets_per_iteration(members: usize, k: usize) -> usize {
    if members > 1 {
        2 * k + 1
    } else {
        k + 1
    }
}

/// Forward runs a fit is expected to take (for progress): the start, and per start about 8
/// iterations of [`sets_per_iteration`], and the check of the uncertainties.
pub(crate) fn expected_runs(model: &ForwardModel, k: usize, starts: usize) -> usize {
    let per_set = model.runs_per_set();
    per_set * (1 + starts.max(1) * 8 * sets_per_iteration(model.members(), k) + 2 * k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(scenario: &str, ensemble: Option<(usize, u64)>) -> Result<ForwardModel, String> {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let source = ScenarioSource::parse(scenario, "tiny.toml", Some(dir)).unwrap();
        let data = FitData::parse(
            "base.amplitude [um],pull_off_amplification [1]\n5,2\n10,3\n20,4\n",
            "d.csv",
            None,
        )
        .unwrap();
        let free = vec![SetKey::parse("adhesion.n").unwrap()];
        ForwardModel::new(source, data, free, Vec::new(), ensemble, 1)
    }

    /// An ensemble is bounded as a sweep's is, counting the runs of one iteration's batch (3
    /// rows x members x 3 parameter sets: the start and the first Jacobian's central
    /// differences), and by the memory of that batch against solver.max_memory.
    #[test]
    fn an_ensemble_is_bounded_by_runs_and_memory() {
        let tiny = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/sweep/tiny.toml"),
        )
        .unwrap();
        let e = model(&tiny, Some((99_999_999_999, 0))).unwrap_err();
        assert_eq!(
            crate::words::render(&e, &crate::words::TestFlags),
            "--ensemble 99999999999: 3 rows x 99999999999 members x 3 parameter sets of one \
             iteration is more than 10000000 runs (a fit runs an iteration's parameter sets as \
             one batch); use fewer members"
        );
        // 10_000_000 / 9 members is the most runs allow.
        assert!(model(&tiny, Some((1_111_112, 0))).is_err());
        let most = model(&tiny, Some((1_111_111, 0))).unwrap();
        // Two axes (the condition and the free key) and the ensemble's phase: three values of
        // 64 bytes, a result and an index, per run.
        let per_run = 8 + 8 + 3 * std::mem::size_of::<SpecValue>();
        assert_eq!(most.batch_bytes(1).to_bits(), (per_run as f64).to_bits());
        let per_run = per_run as f64;
        // With 1 MiB of memory allowed, 1 MiB / per_run / 9 members.
        let small = format!("{tiny}\n[solver]\nmax_memory = 1048576\n");
        let fits = (1_048_576.0 / per_run / 9.0).floor() as usize;
        assert!(model(&small, Some((fits, 0))).is_ok());
        let e = model(&small, Some((fits + 1, 0))).unwrap_err();
        let e = crate::words::render(&e, &crate::words::TestFlags);
        assert!(
            e.starts_with(&format!(
                "--ensemble {}: a batch of {} runs",
                fits + 1,
                9 * (fits + 1)
            )) && e.contains("more than solver.max_memory = 1048576 bytes (1.0 MiB)"),
            "{e}"
        );
        assert!(model(&tiny, None).is_ok());
    }
}
