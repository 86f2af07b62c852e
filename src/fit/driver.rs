//! The fit itself: weighted least squares by Levenberg–Marquardt (the `levenberg-marquardt`
//! crate, MINPACK's trust-region algorithm over nalgebra) in the optimiser's coordinates `u`
//! (see [`super::free`]), with finite-difference Jacobians, then the covariance, correlation and
//! information criteria at the best estimate.
//!
//! **Finite-difference step.** The forward model is a numerical integration: its output carries
//! an error that does not vary smoothly with the parameters, of relative size about the solver's
//! `rtol` times the error amplification of event location and cycle averaging (taken as 100).
//! A forward difference with step `h` has truncation error ∝ `h` and noise error ∝ `ε/h`, so the
//! step that balances them is `h = √ε`: `h = √(100 · rtol)` in the fit coordinate `y` (a relative
//! step for a key fitted in log space), kept within [1e-6, 1e-2]. With the paper protocol's
//! `rtol = 1e-8` this is `h = 1e-3`. A step that would leave the bounds is taken backwards.
//! With an ensemble (a chaotic rig, where each member jumps under any change of the parameters),
//! the Jacobian is a central difference whose step widens until the change of the prediction
//! stands well above the ensemble's noise: see [`super::stencil`].
//!
//! **Weights with an ensemble.** A row's σ joins the file's sigma and the standard error of its
//! ensemble mean. One mean's standard error is itself noisy (a chaotic pull-off has a skewed,
//! clustered distribution: 16 members give standard errors from 0.1 to 1.5 % at neighbouring
//! parameter values), so it is pooled (root mean square) over the parameter sets of the first
//! Jacobian for the weights, and over every set evaluated for the covariance, which is then the
//! sandwich `A⁻¹ B A⁻¹` of the weighted normal matrix `A` and the same with the pooled variances
//! (`A⁻¹` when they equal the weights).
//!
//! **Interruption.** The best parameter set met so far (lowest χ²) is kept at every evaluation;
//! a stop (Ctrl-C) ends the optimiser and that set is the result, said so in `notes`.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::sync::atomic::AtomicBool;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};
use serde::Serialize;

use super::free::{FreeKey, Transform};
use super::model::{EvalError, ForwardModel, ParamSet, Prediction};
use super::stencil::{max_step, pooled_se, snr, stencil, widen, INITIAL_HALF_STEP, MAX_WIDENINGS};

/// Predictions kept for reuse (a stencil point met again): a few Jacobians' worth.
const CACHE: usize = 64;

/// What a fit reports as it goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FitEvent {
    /// A forward run ended.
    Run,
    /// A new best χ² (after `iteration` Jacobians).
    Best {
        /// Jacobians computed so far.
        iteration: usize,
        /// The χ².
        chi2: f64,
    },
}

/// How to fit.
#[derive(Debug, Clone, Copy)]
pub struct FitOptions<'a> {
    /// Most Jacobians (outer iterations) before giving up.
    pub max_iterations: usize,
    /// Raised (Ctrl-C): stop and keep the best estimate.
    pub stop: Option<&'a AtomicBool>,
}

impl Default for FitOptions<'_> {
    fn default() -> Self {
        FitOptions {
            max_iterations: 30,
            stop: None,
        }
    }
}

/// One parameter of `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// The key.
    pub key: String,
    /// The estimate (in `unit`).
    pub value: f64,
    /// Its standard deviation (in `unit`), or null where the curvature does not support one (a
    /// bound hit, a parameter that is not identifiable).
    pub sigma: Option<f64>,
    /// The key's SI unit.
    pub unit: String,
    /// The starting value (the scenario's, in `unit`).
    pub initial: f64,
}

/// The content of `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    /// The estimates.
    pub parameters: Vec<Parameter>,
    /// Correlation matrix, in the order of `parameters` (null where undefined).
    pub correlation: Vec<Vec<Option<f64>>>,
    /// Σ ((obs − fit)/σ)² at the estimate (σ = 1 in the observable's unit without a sigma column).
    pub chi2: f64,
    /// Rows − free keys.
    pub dof: usize,
    /// χ² / dof.
    pub reduced_chi2: f64,
    /// χ² + 2k.
    pub aic: f64,
    /// χ² + k ln n.
    pub bic: f64,
    /// Whether the optimiser met its convergence criteria (false when stopped or out of
    /// iterations).
    pub converged: bool,
    /// Jacobians computed (outer iterations).
    pub iterations: usize,
    /// Forward runs made.
    pub forward_runs: usize,
    /// Right-hand-side evaluations of those runs (the integration's work).
    pub rhs_evals: u64,
    /// The observable fitted (as named in sweep.csv).
    pub observable: String,
    /// What the numbers need said: bounds hit, parameters not identifiable, no sigma column,
    /// no convergence, an interruption.
    pub notes: Vec<String>,
    /// Data rows.
    pub rows: usize,
    /// Wall time of the fit (s).
    pub wall_s: f64,
    /// Whether a stop (Ctrl-C) ended the fit (the estimate is the best so far).
    pub interrupted: bool,
}

/// A fit's result: the report and what the files need.
#[derive(Debug, Clone)]
pub struct FitOutcome {
    /// `fit.json`.
    pub report: FitReport,
    /// The estimates (SI), in the order of the free keys.
    pub values: ParamSet,
    /// The prediction at the estimates (None if the fit was stopped before the first one).
    pub prediction: Prediction,
    /// The σ each row was weighted with (SI; 1 without a sigma column).
    pub weights: Vec<f64>,
}

/// A fit that could not start, whose first evaluation failed, or that was stopped (Ctrl-C)
/// before its first evaluation ended, so that no estimate exists to report.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct FitError {
    /// What went wrong, as one line.
    pub message: String,
    /// The stop flag ended the first evaluation: not an error of the input, and nothing to write.
    pub stopped: bool,
}

impl FitError {
    /// An error of the input or of a forward run.
    pub fn new(message: impl Into<String>) -> Self {
        FitError {
            message: message.into(),
            stopped: false,
        }
    }
}

/// Degrees of freedom: rows − free keys.
fn dof_of(n: usize, k: usize) -> usize {
    n.saturating_sub(k)
}

/// The finite-difference step in `y` for a scenario solved at relative tolerance `rtol`.
pub fn fd_step(rtol: f64) -> f64 {
    (100.0 * rtol).sqrt().clamp(1e-6, 1e-2)
}

struct State {
    /// The last evaluation: u and its prediction.
    last: Option<(Vec<f64>, Prediction)>,
    /// The best: χ², u, prediction.
    best: Option<(f64, Vec<f64>, Prediction)>,
    /// The Jacobian with respect to y (weighted, of the prediction: ∂(pred/w)/∂y) and its u.
    jac_y: Option<(Vec<f64>, DMatrix<f64>)>,
    iterations: usize,
    runs: usize,
    rhs_evals: u64,
    stopped: bool,
    failure: Option<String>,
    out_of_iterations: bool,
    /// Σ over the parameter sets evaluated of each row's squared standard error, and their
    /// count (the pooled ensemble noise).
    se2: Vec<f64>,
    se2_sets: usize,
    /// With an ensemble: each column's signal-to-noise ratio in the last Jacobian.
    snr: Vec<f64>,
}

struct Problem<'a, 'b> {
    model: &'a ForwardModel,
    tr: Vec<Transform>,
    obs: Vec<f64>,
    w: Vec<f64>,
    /// The forward-difference step in y (the solver's noise alone).
    h: f64,
    /// With an ensemble: the model's noise per row (the pooled standard error of the members'
    /// mean, SI); the Jacobians are then central differences of widening steps.
    noise: Option<Vec<f64>>,
    /// With an ensemble: each key's half-step in y, kept from one Jacobian to the next.
    steps: RefCell<Vec<f64>>,
    /// The last predictions, so that a parameter set met again is not run again.
    cache: RefCell<VecDeque<(ParamSet, Prediction)>>,
    u: DVector<f64>,
    opts: FitOptions<'a>,
    state: RefCell<State>,
    progress: RefCell<&'b mut dyn FnMut(FitEvent)>,
}

impl Problem<'_, '_> {
    fn x_of_u(&self, u: &[f64]) -> ParamSet {
        u.iter()
            .zip(&self.tr)
            .map(|(&u, t)| t.x(t.y_of_u(u)))
            .collect()
    }

    fn chi2(&self, p: &Prediction) -> f64 {
        (0..self.obs.len())
            .map(|i| ((self.obs[i] - p.values[i]) / self.w[i]).powi(2))
            .sum()
    }

    /// Run a batch (the sets not met before), counting runs and reporting them.
    fn predict(&self, sets: &[ParamSet]) -> Result<Vec<Prediction>, EvalError> {
        let mut out: Vec<Option<Prediction>> = sets
            .iter()
            .map(|s| {
                self.cache
                    .borrow()
                    .iter()
                    .find(|(c, _)| c == s)
                    .map(|(_, p)| p.clone())
            })
            .collect();
        let missing: Vec<ParamSet> = sets
            .iter()
            .zip(&out)
            .filter(|(_, o)| o.is_none())
            .map(|(s, _)| s.clone())
            .collect();
        if missing.is_empty() {
            return Ok(out.into_iter().flatten().collect());
        }
        let mut runs = 0;
        let r = {
            let mut progress = self.progress.borrow_mut();
            self.model.predict(&missing, self.opts.stop, &mut || {
                runs += 1;
                (*progress)(FitEvent::Run);
            })
        };
        self.state.borrow_mut().runs += runs;
        let r = r?;
        self.state.borrow_mut().rhs_evals += r.iter().map(|p| p.rhs_evals).sum::<u64>();
        let mut fresh = r.into_iter();
        for (set, o) in sets.iter().zip(out.iter_mut()) {
            if o.is_none() {
                let p = fresh.next().ok_or(EvalError::Stopped)?;
                self.keep(set, &p);
                *o = Some(p);
            }
        }
        Ok(out.into_iter().flatten().collect())
    }

    /// Keep a prediction for reuse and pool its standard errors.
    fn keep(&self, set: &[f64], p: &Prediction) {
        let mut cache = self.cache.borrow_mut();
        if cache.len() == CACHE {
            cache.pop_front();
        }
        cache.push_back((set.to_vec(), p.clone()));
        let mut st = self.state.borrow_mut();
        for (a, s) in st.se2.iter_mut().zip(&p.se) {
            *a += s * s;
        }
        st.se2_sets += 1;
    }

    /// x with key `j` of `y` replaced by `yj`.
    fn x_with(&self, y: &[f64], j: usize, yj: f64) -> ParamSet {
        y.iter()
            .zip(&self.tr)
            .enumerate()
            .map(|(c, (&y, t))| t.x(if c == j { yj } else { y }))
            .collect()
    }

    /// The prediction at u (cached for the last u), remembering the best.
    fn eval(&self, u: &[f64]) -> Result<Prediction, EvalError> {
        if let Some((lu, p)) = &self.state.borrow().last {
            if lu.as_slice() == u {
                return Ok(p.clone());
            }
        }
        let p = self
            .predict(&[self.x_of_u(u)])?
            .pop()
            .ok_or(EvalError::Stopped)?;
        self.remember(u, &p);
        Ok(p)
    }

    /// Keep `p` as the last evaluation, and as the best when its χ² is the lowest met. A χ²
    /// that is not finite is never the best: the start's is checked finite before the
    /// optimiser runs, so the best always exists and is finite.
    fn remember(&self, u: &[f64], p: &Prediction) {
        let chi2 = self.chi2(p);
        let mut st = self.state.borrow_mut();
        st.last = Some((u.to_vec(), p.clone()));
        if chi2.is_finite() && st.best.as_ref().is_none_or(|(b, _, _)| chi2 < *b) {
            st.best = Some((chi2, u.to_vec(), p.clone()));
            let iteration = st.iterations;
            drop(st);
            (*self.progress.borrow_mut())(FitEvent::Best { iteration, chi2 });
        }
    }

    fn note_error(&self, e: EvalError) {
        let mut st = self.state.borrow_mut();
        match e {
            EvalError::Stopped => st.stopped = true,
            EvalError::Failed(m) => {
                if st.failure.is_none() {
                    st.failure = Some(m);
                }
            }
        }
    }

    /// ∂(pred/w)/∂y at u: by forward differences (one batch of k parameter sets), or with an
    /// ensemble by central differences of widening steps ([`Self::central_y`]).
    fn jacobian_y(&self, u: &[f64]) -> Result<DMatrix<f64>, EvalError> {
        if let Some((ju, j)) = &self.state.borrow().jac_y {
            if ju.as_slice() == u {
                return Ok(j.clone());
            }
        }
        let jac = match &self.noise {
            Some(noise) => self.central_y(u, noise)?,
            None => self.forward_y(u)?,
        };
        self.state.borrow_mut().jac_y = Some((u.to_vec(), jac.clone()));
        Ok(jac)
    }

    /// Central differences whose half-steps widen (from the last Jacobian's) until each column's
    /// change stands [`super::stencil::TARGET_SNR`] times above the noise `noise` of the
    /// ensemble mean, or reaches its widest step; a batch per round, at most
    /// [`MAX_WIDENINGS`] rounds after the first.
    fn central_y(&self, u: &[f64], noise: &[f64]) -> Result<DMatrix<f64>, EvalError> {
        let k = u.len();
        let n = self.obs.len();
        let y: Vec<f64> = u.iter().zip(&self.tr).map(|(&u, t)| t.y_of_u(u)).collect();
        let noise2: f64 = (0..n).map(|i| 2.0 * (noise[i] / self.w[i]).powi(2)).sum();
        let mut jac = DMatrix::zeros(n, k);
        let mut ratios = vec![f64::INFINITY; k];
        let mut todo: Vec<usize> = (0..k).collect();
        let mut ran = self.steps.borrow().clone();
        for round in 0..=MAX_WIDENINGS {
            let steps = self.steps.borrow().clone();
            let pairs: Vec<(f64, f64)> = todo
                .iter()
                .map(|&j| stencil(&self.tr[j], y[j], steps[j]))
                .collect();
            let sets: Vec<ParamSet> = todo
                .iter()
                .zip(&pairs)
                .flat_map(|(&j, &(a, b))| [self.x_with(&y, j, a), self.x_with(&y, j, b)])
                .collect();
            // A run that fails at a widened step (a value the scenario refuses, a run that
            // does not end) keeps the columns of the step before, which did run.
            let preds = match self.predict(&sets) {
                Ok(p) => p,
                Err(EvalError::Failed(_)) if round > 0 => {
                    *self.steps.borrow_mut() = ran;
                    break;
                }
                Err(e) => return Err(e),
            };
            ran = steps.clone();
            let mut next = Vec::new();
            for (t, (&j, &(a, b))) in todo.iter().zip(&pairs).enumerate() {
                let (pa, pb) = (&preds[2 * t], &preds[2 * t + 1]);
                let mut signal2 = 0.0;
                for i in 0..n {
                    let d = (pb.values[i] - pa.values[i]) / self.w[i];
                    jac[(i, j)] = d / (b - a);
                    signal2 += d * d;
                }
                ratios[j] = snr(signal2, noise2);
                if round < MAX_WIDENINGS {
                    if let Some(h) = widen(steps[j], ratios[j], max_step(&self.tr[j], y[j])) {
                        self.steps.borrow_mut()[j] = h;
                        next.push(j);
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            todo = next;
        }
        self.state.borrow_mut().snr = ratios;
        Ok(jac)
    }

    /// Forward differences of step `h` (one batch of k parameter sets).
    fn forward_y(&self, u: &[f64]) -> Result<DMatrix<f64>, EvalError> {
        let base = self.eval(u)?;
        let k = u.len();
        let n = self.obs.len();
        let y: Vec<f64> = u.iter().zip(&self.tr).map(|(&u, t)| t.y_of_u(u)).collect();
        let mut steps = Vec::with_capacity(k);
        let mut sets = Vec::with_capacity(k);
        for j in 0..k {
            let mut yj = y.clone();
            let mut h = self.h;
            if !self.tr[j].inside(y[j] + h) {
                h = -h;
            }
            yj[j] += h;
            steps.push(h);
            sets.push(
                yj.iter()
                    .zip(&self.tr)
                    .map(|(&y, t)| t.x(y))
                    .collect::<Vec<_>>(),
            );
        }
        let preds = self.predict(&sets)?;
        let mut jac = DMatrix::zeros(n, k);
        for j in 0..k {
            for i in 0..n {
                jac[(i, j)] = (preds[j].values[i] - base.values[i]) / (steps[j] * self.w[i]);
            }
        }
        Ok(jac)
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_, '_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, u: &DVector<f64>) {
        self.u.copy_from(u);
    }

    fn params(&self) -> DVector<f64> {
        self.u.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let n = self.obs.len();
        // A trial step into a region where a run fails, or where the model's prediction gives a
        // chi2 that is not finite: a residual larger than any seen, so that the optimiser
        // rejects the step and shrinks its trust region (never an infinite one, which ended the
        // optimiser with a numerical failure).
        let rejected = || {
            let best = self.state.borrow().best.as_ref().map_or(1.0, |b| b.0);
            let r = (100.0 * best.max(1.0) / n as f64).sqrt();
            Some(DVector::from_element(n, r))
        };
        match self.eval(self.u.as_slice()) {
            Ok(p) if self.chi2(&p).is_finite() => Some(DVector::from_fn(n, |i, _| {
                (self.obs[i] - p.values[i]) / self.w[i]
            })),
            Ok(_) => rejected(),
            Err(EvalError::Failed(_)) if self.state.borrow().best.is_some() => rejected(),
            Err(e) => {
                self.note_error(e);
                None
            }
        }
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        {
            let mut st = self.state.borrow_mut();
            if st.iterations >= self.opts.max_iterations {
                st.out_of_iterations = true;
                return None;
            }
            st.iterations += 1;
        }
        let u = self.u.as_slice();
        match self.jacobian_y(u) {
            Ok(jy) => {
                // r = (obs − pred)/w, so ∂r/∂u = −∂(pred/w)/∂y · dy/du.
                let mut j = -jy;
                for (c, t) in self.tr.iter().enumerate() {
                    let d = t.dy_du(u[c]);
                    for i in 0..j.nrows() {
                        j[(i, c)] *= d;
                    }
                }
                Some(j)
            }
            Err(e) => {
                self.note_error(e);
                None
            }
        }
    }
}

/// Refuse data whose χ² at the starting values is not finite, naming the first row at fault
/// and its column (sigma's when the file has one, else the observable's): the rows passed the
/// reader's bound ([`super::data::MAX_WEIGHTED`]), but the model predicts values so far from
/// them, in units of their sigma, that a term overflows (an observed 0 with sigma 1e-200).
fn check_start_chi2(
    data: &super::data::FitData,
    p0: &Prediction,
    w: &[f64],
) -> Result<(), FitError> {
    let bad = (0..data.rows.len()).find(|&i| {
        let r = (data.rows[i].observed - p0.values[i]) / w[i];
        !(r * r).is_finite()
    });
    let Some(i) = bad else {
        let chi2: f64 = (0..data.rows.len())
            .map(|i| ((data.rows[i].observed - p0.values[i]) / w[i]).powi(2))
            .sum();
        return if chi2.is_finite() {
            Ok(())
        } else {
            Err(FitError::new(format!(
                "{}: chi2 at the starting values sums to more than the largest double: the \
                 rows' sigma are too small for what the model predicts",
                data.name
            )))
        };
    };
    let row = &data.rows[i];
    let (col, cell) = data
        .sigma_column
        .as_ref()
        .unwrap_or(&data.observable_column);
    Err(FitError::new(format!(
        "{}: line {}, column {col} '{cell}': at the starting values the model predicts {:.6e}{u} \
         where {:.6e}{u} was observed, with sigma {:.6e}{u}: (observed - predicted) / sigma \
         squared is not finite, so chi2 cannot be; give a sigma of the size of the \
         measurement's error{}",
        data.name,
        row.line,
        p0.values[i],
        row.observed,
        w[i],
        if data.has_sigma {
            ""
        } else {
            " (without a sigma column sigma is 1 in the observable's SI unit)"
        },
        u = match data.observable.unit() {
            "1" => String::new(),
            u => format!(" {u}"),
        }
    )))
}

/// Why the optimiser ended without converging, in words (never its Rust name).
fn termination_words(t: &TerminationReason) -> String {
    match t {
        TerminationReason::Numerical(what) => {
            let what = match *what {
                "residuals norm" => "the norm of the residuals",
                "jacobian" => "the Jacobian",
                "subproblem x" | "subproblem ||Dp||" => "the step it solved for",
                "trust-region reduction" => "the update of its trust region",
                "new x" => "the new parameters",
                _ => "its computation",
            };
            format!(
                "a number in {what} became infinite or NaN, which ended the optimiser (the \
                 model's response is not finite, or not smooth, near the estimate), so no sigma \
                 is given"
            )
        }
        TerminationReason::LostPatience => {
            "the optimiser's budget of evaluations ran out before its criteria were met".into()
        }
        TerminationReason::User(_) => {
            "a forward evaluation ended the optimiser (a failed run or a stop)".into()
        }
        TerminationReason::NoParameters
        | TerminationReason::NoResiduals
        | TerminationReason::WrongDimensions(_) => {
            "the optimiser refused the problem's shape (an internal error: please report it)".into()
        }
        TerminationReason::Converged { .. }
        | TerminationReason::Orthogonal
        | TerminationReason::ResidualsZero
        | TerminationReason::NoImprovementPossible(_) => "the optimiser met its criteria".into(),
    }
}

/// Parameter sets a typical iteration evaluates (the trial step and the Jacobian's) with `k`
/// free keys: `k + 1` with forward differences, `2k + 1` with an ensemble's central ones; for a
/// progress bar's length.
pub fn sets_per_iteration(members: usize, k: usize) -> usize {
    if members > 1 {
        2 * k + 1
    } else {
        k + 1
    }
}

/// Refuse a starting value outside its key's bounds, and bounds too far from it for the fit's
/// coordinate (before anything runs).
pub fn check_start(free: &[FreeKey], x0: &[f64]) -> Result<(), FitError> {
    for (f, &x) in free.iter().zip(x0) {
        let given = crate::text::excerpt(&f.given);
        let t = Transform::new(f, x);
        if !x.is_finite() || !t.inside(t.y(x)) {
            return Err(FitError::new(format!(
                "--free {given}: the starting value {x} {} (the scenario's) lies outside the \
                 bounds; start inside with --set {}=VALUE",
                f.unit, f.key
            )));
        }
        // A linear key moves in units of its starting magnitude: bounds 1e300 times that (a
        // start of 1e-300) would overflow the coordinate or the span between the bounds.
        let span_ok = match (t.lo, t.hi) {
            (Some(l), Some(h)) => (h - l).is_finite(),
            (l, h) => l.is_none_or(f64::is_finite) && h.is_none_or(f64::is_finite),
        };
        if !span_ok {
            return Err(FitError::new(format!(
                "--free {given}: the bounds lie too far from the starting value {x} {} for the \
                 fit's coordinate (the value over its starting magnitude): narrow them, or start \
                 nearer with --set {}=VALUE",
                f.unit, f.key
            )));
        }
    }
    Ok(())
}

/// Fit the free keys `free` (starting at `x0`, SI) of `model` to its data.
pub fn fit(
    model: &ForwardModel,
    free: &[FreeKey],
    x0: &[f64],
    rtol: f64,
    opts: FitOptions,
    progress: &mut dyn FnMut(FitEvent),
) -> Result<FitOutcome, FitError> {
    let t0 = std::time::Instant::now();
    let data = model.data();
    let n = data.rows.len();
    let k = free.len();
    if k == 0 {
        return Err(FitError::new("give at least one --free KEY"));
    }
    if n <= k {
        return Err(FitError::new(format!(
            "{}: {n} row(s) for {k} free key(s): a fit needs more rows than free keys",
            data.name
        )));
    }
    let tr: Vec<Transform> = free
        .iter()
        .zip(x0)
        .map(|(f, &x)| Transform::new(f, x))
        .collect();
    check_start(free, x0)?;
    // Start a little inside a bound: at a bound dy/du = 0 and the key could not move.
    let u0: Vec<f64> = x0
        .iter()
        .zip(&tr)
        .map(|(&x, t)| {
            let mut y = t.y(x);
            let span = match (t.lo, t.hi) {
                (Some(l), Some(h)) => 0.01 * (h - l),
                _ => 0.01,
            };
            if t.lo.is_some_and(|l| y - l < span) {
                y = t.lo.unwrap_or(y) + span;
            }
            if t.hi.is_some_and(|h| h - y < span) {
                y = t.hi.unwrap_or(y) - span;
            }
            t.u_of_y(y)
        })
        .collect();
    let obs: Vec<f64> = data.rows.iter().map(|r| r.observed).collect();
    let mut notes = Vec::new();
    // The first evaluation fixes the weights. With an ensemble it also runs the first
    // Jacobian's stencil (half-step INITIAL_HALF_STEP), and the standard errors of all these sets
    // are pooled into the weights.
    let members = model.members();
    let y0: Vec<f64> = u0.iter().zip(&tr).map(|(&u, t)| t.y_of_u(u)).collect();
    let x_of_y = |y: &[f64]| -> ParamSet { y.iter().zip(&tr).map(|(&y, t)| t.x(y)).collect() };
    let mut sets0 = vec![x_of_y(&y0)];
    if members > 1 {
        for (j, t) in tr.iter().enumerate() {
            let (a, b) = stencil(t, y0[j], INITIAL_HALF_STEP);
            for yj in [a, b] {
                let mut y = y0.clone();
                y[j] = yj;
                sets0.push(x_of_y(&y));
            }
        }
    }
    let mut runs0 = 0;
    let preds0 = model
        .predict(&sets0, opts.stop, &mut || {
            runs0 += 1;
            progress(FitEvent::Run);
        })
        .map_err(|e| match e {
            EvalError::Stopped => FitError {
                message: "during the first evaluation (the model at the starting values): \
                          no estimate was computed yet"
                    .into(),
                stopped: true,
            },
            EvalError::Failed(m) => FitError::new(format!("at the starting values: {m}")),
        })?;
    let p0 = preds0
        .first()
        .cloned()
        .ok_or_else(|| FitError::new("no prediction"))?;
    let pooled = pooled_se(&preds0);
    let w: Vec<f64> = (0..n)
        .map(|i| {
            if data.has_sigma {
                let s = data.rows[i].sigma.unwrap_or(1.0);
                let w2 = s * s + pooled[i] * pooled[i];
                // A sigma of 1e-200 squares to 0: the weight was 0 and every residual infinite.
                if w2.is_normal() {
                    w2.sqrt()
                } else {
                    s.hypot(pooled[i])
                }
            } else {
                1.0
            }
        })
        .collect();
    check_start_chi2(data, &p0, &w)?;
    if !data.has_sigma {
        notes.push(format!(
            "{} has no sigma column: every row weighs the same (sigma = 1 {} in chi2), and the \
             parameters' sigma are scaled by the reduced chi2",
            data.name,
            data.observable.unit()
        ));
    }
    if members > 1 && data.has_sigma {
        notes.push(format!(
            "each row's sigma includes the standard error of its {members}-member ensemble mean \
             (root mean square over the {} parameter sets of the start and the first Jacobian)",
            sets0.len()
        ));
    }
    let problem = Problem {
        model,
        tr: tr.clone(),
        obs: obs.clone(),
        w: w.clone(),
        h: fd_step(rtol),
        noise: (members > 1).then(|| pooled.clone()),
        steps: RefCell::new(vec![INITIAL_HALF_STEP; k]),
        cache: RefCell::new(VecDeque::new()),
        u: DVector::from_vec(u0.clone()),
        opts,
        state: RefCell::new(State {
            last: None,
            best: None,
            jac_y: None,
            iterations: 0,
            runs: runs0,
            rhs_evals: preds0.iter().map(|p| p.rhs_evals).sum(),
            stopped: false,
            failure: None,
            out_of_iterations: false,
            se2: vec![0.0; n],
            se2_sets: 0,
            snr: Vec::new(),
        }),
        progress: RefCell::new(progress),
    };
    for (set, p) in sets0.iter().zip(&preds0) {
        problem.keep(set, p);
    }
    problem.remember(&u0, &p0);
    // Convergence: a relative change of chi2 below 1e-5 (chi2 ~ rows, so an absolute change far
    // below the 1 that moves an estimate by one sigma) or of the scaled parameters below 1e-4;
    // tighter criteria only chase the forward model's numerical noise.
    let lm = LevenbergMarquardt::new()
        .with_ftol(1e-5)
        .with_xtol(1e-4)
        .with_gtol(1e-8)
        .with_patience(100);
    let (problem, report) = lm.minimize(problem);
    let mut st = problem.state.borrow_mut();
    if let Some(m) = st.failure.take() {
        if st.best.is_none() {
            return Err(FitError::new(m));
        }
        notes.push(format!("a forward run failed, which ended the fit: {m}"));
    }
    let (chi2, u_best, pred) = st
        .best
        .clone()
        .ok_or_else(|| FitError::new("no estimate"))?;
    let stopped = st.stopped;
    let mut converged = matches!(
        report.termination,
        TerminationReason::Converged { .. }
            | TerminationReason::Orthogonal
            | TerminationReason::ResidualsZero
            | TerminationReason::NoImprovementPossible(_)
    ) && !stopped;
    // LM computes a new Jacobian after each accepted step: one Jacobian means that no step
    // lowered chi2, and the criteria were met by a trust region shrunk to nothing.
    let stuck = converged && st.iterations <= 1 && chi2 > dof_of(n, k) as f64;
    if stuck {
        converged = false;
        notes.push(
            "not converged: no step from the start lowered chi2 (the trust region shrank to \
             nothing); the response may not be smooth at these step sizes (a chaotic rig: try \
             --ensemble)"
                .into(),
        );
    } else if st.out_of_iterations {
        converged = false;
        notes.push(format!(
            "not converged: {} iterations without meeting the criteria; the estimate is the \
             best met",
            opts.max_iterations
        ));
    } else if stopped {
        notes.push(
            "interrupted: the estimate is the best met so far (lowest chi2), not converged".into(),
        );
    } else if !converged {
        notes.push(format!(
            "not converged: {}; the estimate is the best met",
            termination_words(&report.termination)
        ));
    }
    // After a number of the optimiser became infinite or NaN, the response near the estimate
    // is not one a Jacobian describes: no sigma is claimed.
    let numerical = matches!(report.termination, TerminationReason::Numerical(_));
    drop(st);
    // The Jacobian at the estimate (computed unless it is the last one, or the fit was stopped
    // or ended by a numerical failure).
    let jac = if stopped || numerical {
        None
    } else {
        match problem.jacobian_y(&u_best) {
            Ok(j) => Some(j),
            Err(e) => {
                notes.push(match e {
                    EvalError::Stopped => {
                        "interrupted while computing the uncertainties: no sigma".into()
                    }
                    EvalError::Failed(m) => format!("no sigma: a run of the Jacobian failed: {m}"),
                });
                None
            }
        }
    };
    let st = problem.state.borrow();
    let y_best: Vec<f64> = u_best.iter().zip(&tr).map(|(&u, t)| t.y_of_u(u)).collect();
    let values: Vec<f64> = y_best.iter().zip(&tr).map(|(&y, t)| t.x(y)).collect();
    if !chi2.is_finite() {
        // Unreachable: the best is always finite (see Problem::remember). fit.json never says
        // `chi2: null` for a fit it reports.
        return Err(FitError::new(format!(
            "{}: chi2 is not finite at the estimate: nothing to report",
            data.name
        )));
    }
    let dof = n - k;
    let reduced = chi2 / dof as f64;
    if data.has_sigma && reduced > 10.0 {
        notes.push(format!(
            "poor fit: reduced chi2 = {reduced:.3e}: the model does not describe the data within \
             their sigma, or the optimiser is stuck; the sigma of the parameters are not reliable"
        ));
    }
    let at_bound: Vec<bool> = y_best
        .iter()
        .zip(&tr)
        .map(|(&y, t)| t.at_bound(y))
        .collect();
    for (j, f) in free.iter().enumerate() {
        if at_bound[j] {
            notes.push(format!(
                "{} ran to its bound ({} {}): no sigma for it",
                f.key, values[j], f.unit
            ));
        }
    }
    // With an ensemble (and a sigma column): each row's variance, with the ensemble noise pooled
    // over every parameter set evaluated, over its weight's square.
    let variance_ratio = (members > 1 && data.has_sigma && st.se2_sets > 0).then(|| {
        DVector::from_fn(n, |i, _| {
            let s = data.rows[i].sigma.unwrap_or(1.0);
            (s * s + st.se2[i] / st.se2_sets as f64) / (w[i] * w[i])
        })
    });
    if members > 1 {
        let steps = problem.steps.borrow();
        let list = |f: &dyn Fn(usize) -> String| {
            (0..k)
                .map(|j| format!("{} {}", free[j].key, f(j)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        notes.push(format!(
            "Jacobians by central differences whose steps widen until the change stands 10 times \
             above the ensemble noise; half-steps in the fit coordinates at the estimate: {}; \
             signal-to-noise: {}",
            list(&|j| format!("{:.3}", steps[j])),
            list(&|j| format!("{:.1}", st.snr.get(j).copied().unwrap_or(f64::NAN)))
        ));
        for (j, f) in free.iter().enumerate() {
            if st.snr.get(j).is_some_and(|&r| r < 3.0) {
                notes.push(format!(
                    "{}: the ensemble noise dominates its Jacobian column even at the widest step \
                     (signal-to-noise {:.1} < 3), so its sigma is uncertain: fit with more \
                     --ensemble members",
                    f.key, st.snr[j]
                ));
            }
        }
    }
    // Covariance in y of the keys not at a bound.
    let mut sigma: Vec<Option<f64>> = vec![None; k];
    let mut corr: Vec<Vec<Option<f64>>> = vec![vec![None; k]; k];
    if let Some(jy) = jac {
        let idx: Vec<usize> = (0..k).filter(|&j| !at_bound[j]).collect();
        if !idx.is_empty() {
            let jf = DMatrix::from_fn(n, idx.len(), |i, c| jy[(i, idx[c])]);
            let svd = jf.clone().svd(false, true);
            let smax = svd.singular_values.max();
            let smin = svd.singular_values.min();
            let resolved = smin > 1e-8 * smax && smax.is_finite();
            if !resolved {
                notes.push(format!(
                    "not identifiable: the Jacobian is singular (singular values {smin:.3e} .. \
                     {smax:.3e}): the data do not fix {} separately; no sigma",
                    idx.iter()
                        .map(|&j| free[j].key.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            } else if let Some(vt) = svd.v_t {
                let m = idx.len();
                let scale = if data.has_sigma { 1.0 } else { reduced };
                let mut cov = DMatrix::zeros(m, m);
                for a in 0..m {
                    for b in 0..m {
                        cov[(a, b)] = (0..m)
                            .map(|s| vt[(s, a)] * vt[(s, b)] / svd.singular_values[s].powi(2))
                            .sum::<f64>()
                            * scale;
                    }
                }
                // With an ensemble, the sandwich with the noise pooled over every set evaluated.
                if let Some(ratio) = &variance_ratio {
                    let b = jf.transpose() * DMatrix::from_diagonal(ratio) * &jf;
                    cov = &cov * b * &cov;
                }
                for a in 0..m {
                    let ja = idx[a];
                    let sy = cov[(a, a)].sqrt();
                    sigma[ja] = Some(sy * tr[ja].dx_dy(y_best[ja]));
                    for b in 0..m {
                        let jb = idx[b];
                        let c = cov[(a, b)] / (cov[(a, a)] * cov[(b, b)]).sqrt();
                        corr[ja][jb] = Some(c);
                        if a < b && c.abs() > 0.999 {
                            notes.push(format!(
                                "not identifiable separately: {} and {} are correlated by {c:.4} \
                                 (> 0.999); their sigma are large and mostly shared",
                                free[ja].key, free[jb].key
                            ));
                        }
                    }
                }
            }
        }
    }
    for (j, f) in free.iter().enumerate() {
        if let Some(s) = sigma[j] {
            if !s.is_finite() {
                sigma[j] = None;
                notes.push(format!("{}: sigma is not finite; none given", f.key));
            } else if s <= 0.0 {
                // The covariance underflowed (data sigma of 1e-152 gave sigma = 0, a claim of
                // an exact estimate).
                sigma[j] = None;
                notes.push(format!(
                    "{}: sigma underflowed to 0 (the rows' sigma are far below what the model \
                     resolves); none given",
                    f.key
                ));
            }
        }
    }
    let parameters = free
        .iter()
        .enumerate()
        .map(|(j, f)| Parameter {
            key: f.key.to_string(),
            value: values[j],
            sigma: sigma[j],
            unit: f.unit.to_string(),
            initial: x0[j],
        })
        .collect();
    let report = FitReport {
        parameters,
        correlation: corr,
        chi2,
        dof,
        reduced_chi2: reduced,
        aic: chi2 + 2.0 * k as f64,
        bic: chi2 + k as f64 * (n as f64).ln(),
        converged,
        iterations: st.iterations,
        forward_runs: st.runs,
        rhs_evals: st.rhs_evals,
        observable: data.observable.name().to_string(),
        notes,
        rows: n,
        wall_s: t0.elapsed().as_secs_f64(),
        interrupted: stopped,
    };
    Ok(FitOutcome {
        report,
        values,
        prediction: pred,
        weights: w,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The step balances truncation against the solver's noise: √(100 rtol) (1e-3 at rtol
    /// 1e-8), kept within [1e-6, 1e-2].
    #[test]
    fn the_step_follows_the_solver_tolerance() {
        let close = |a: f64, b: f64| assert!((a - b).abs() <= 1e-15 * b, "{a} vs {b}");
        close(fd_step(1e-8), 1e-3);
        close(fd_step(1e-10), 1e-4);
        close(fd_step(1e-14), 1e-6);
        close(fd_step(1e-3), 1e-2);
    }

    /// Why the optimiser ended is said in words, never its Rust name (`Numerical("residuals
    /// norm")` was a note of fit.json), and a numerical failure says that no sigma is given.
    #[test]
    fn terminations_are_told_in_words() {
        let all = [
            TerminationReason::User("residuals"),
            TerminationReason::Numerical("residuals norm"),
            TerminationReason::Numerical("jacobian"),
            TerminationReason::Numerical("subproblem x"),
            TerminationReason::Numerical("subproblem ||Dp||"),
            TerminationReason::Numerical("trust-region reduction"),
            TerminationReason::Numerical("new x"),
            TerminationReason::ResidualsZero,
            TerminationReason::Orthogonal,
            TerminationReason::Converged {
                ftol: true,
                xtol: false,
            },
            TerminationReason::NoImprovementPossible("ftol"),
            TerminationReason::LostPatience,
            TerminationReason::NoParameters,
            TerminationReason::NoResiduals,
            TerminationReason::WrongDimensions("jacobian"),
        ];
        for t in &all {
            let w = termination_words(t);
            let debug = format!("{t:?}");
            let name = debug.split(['(', ' ', '{']).next().unwrap();
            assert!(!w.contains(name) && !w.contains("||"), "{t:?}: {w}");
            if matches!(t, TerminationReason::Numerical(_)) {
                assert!(
                    w.contains("infinite or NaN") && w.contains("no sigma"),
                    "{w}"
                );
            }
        }
    }
}
