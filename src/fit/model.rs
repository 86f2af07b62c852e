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
use crate::sweep::{run_sweep, RunOptions, Sweep};

use super::data::{CondValue, FitData};

/// The model's prediction for every data row, at one parameter set.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// The observable per row (SI): the run's, or the members' mean.
    pub values: Vec<f64>,
    /// The standard error of the members' mean per row (0 without an ensemble).
    pub se: Vec<f64>,
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
            .chain(free.iter().map(|k| (*k, format!("--free {k}"))))
            .chain(fixed.iter().map(|o| (o.key(), format!("--set {o}"))))
            .chain(ensemble.map(|_| (phase, "--ensemble (it draws base.phase)".to_string())));
        for (k, what) in keys {
            if let Some((_, first)) = seen.iter().find(|(s, _)| *s == k) {
                return Err(format!("{k} is both {first} and {what}: give it once"));
            }
            seen.push((k, what));
        }
        if let Some((m, _)) = ensemble {
            if m == 0 {
                return Err("--ensemble 0: must be a whole number >= 1 (members per row)".into());
            }
        }
        Ok(ForwardModel {
            source,
            data,
            free,
            fixed,
            ensemble,
            jobs,
        })
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
        for o in &self.fixed {
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
                Prediction { values: mean, se }
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
            .map(|o| format!("--set {o}"))
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
        match point {
            Some(p) => {
                let i = (p / self.members()) % self.data.rows.len();
                format!("{} line {}: {text}", self.data.name, self.data.rows[i].line)
            }
            None => text.to_string(),
        }
    }
}
