//! The evaluation layer of a fit: the forward model's predictions at points of the fit
//! coordinates `y` (cached, counted, the best point met kept), the weighted residuals, and the
//! finite-difference Jacobians; [`View`] presents a subset of the keys to the optimiser
//! ([`super::lm`]) in its unbounded coordinates `u` (all keys for a fit, all but one for a
//! profile).
//!
//! **Finite-difference steps.** The forward model is a numerical integration: its output
//! carries an error that does not vary smoothly with the parameters, of size `εᵢ` per row (the
//! level the fit's tolerances are chosen for, see [`super::tolerance`]). A forward difference of
//! step `h` has a truncation error ∝ `h` and a noise error ∝ `ε/h`: the step that balances them
//! is `h = √ε_rel` in the fit coordinate `y` ([`fd_step`]). Each column is then checked against
//! that noise as the ensemble stencil does ([`super::stencil`]): the change of the prediction
//! across the step must stand [`super::stencil::TARGET_SNR`] times above `√2 εᵢ`, or the step
//! widens (at most [`MAX_WIDENINGS`] rounds, to [`max_step`]); a key keeps its step from one
//! Jacobian to the next. So an envelope jump or an event located a little differently cannot
//! make a column ragged. A step that would leave the bounds is taken backwards.
//!
//! With an ensemble (a chaotic rig, where each member jumps under any change of the
//! parameters), the Jacobian is a central difference whose step widens until the change stands
//! well above the ensemble's noise: see [`super::stencil`].

use std::cell::RefCell;
use std::collections::VecDeque;
use std::sync::atomic::AtomicBool;

use nalgebra::{DMatrix, DVector};

use super::free::Transform;
use super::lm::{Halt, LeastSquares};
use super::model::{EvalError, ForwardModel, ParamSet, Prediction};
use super::report::FitEvent;
use super::stencil::{max_step, snr, stencil, widen, MAX_WIDENINGS};

/// Predictions kept for reuse (a stencil point met again): a few Jacobians' worth.
const CACHE: usize = 64;

/// The forward-difference step in `y` for a model whose relative error is `eps_rel`: `√eps_rel`,
/// kept within [1e-6, 0.1].
pub(crate) fn fd_step(eps_rel: f64) -> f64 {
    eps_rel.sqrt().clamp(1e-6, 0.1)
}

/// What has been run, and the best point met.
#[derive(Debug, Clone, Default)]
pub struct Counters {
    /// Forward runs made.
    pub runs: usize,
    /// Their RHS evaluations.
    pub rhs_evals: u64,
    /// The best point met (lowest finite χ²): χ², y, prediction.
    pub best: Option<(f64, Vec<f64>, Prediction)>,
    /// Σ over the parameter sets evaluated of each row's squared standard error, and their
    /// count (the pooled ensemble noise).
    pub se2: Vec<f64>,
    /// Parameter sets pooled in `se2`.
    pub se2_sets: usize,
    /// Each column's signal-to-noise ratio in the last Jacobian.
    pub snr: Vec<f64>,
    /// Iterations (Jacobians) of every optimisation so far, for progress.
    pub iterations: usize,
}

/// A Jacobian kept: its point (y), the matrix, and its columns' signal-to-noise ratios.
type LastJacobian = (Vec<f64>, DMatrix<f64>, Vec<f64>);

/// The evaluation of a fit's model at points of the fit coordinates.
pub struct Evaluator<'a, 'b> {
    model: ForwardModel,
    /// The keys' transforms.
    pub tr: Vec<Transform>,
    /// The observations (SI).
    pub obs: Vec<f64>,
    /// The σ each row is weighted with (SI).
    pub w: Vec<f64>,
    /// Each row's model error (SI) that a forward-difference column must stand above.
    pub err: Vec<f64>,
    /// Each key's forward-difference step in `y` (widened against `err`, kept).
    h: RefCell<Vec<f64>>,
    /// With an ensemble: the model's noise per row (the pooled standard error of the members'
    /// mean, SI); the Jacobians are then central differences of widening steps.
    noise: Option<Vec<f64>>,
    /// With an ensemble: each key's half-step in y, kept from one Jacobian to the next.
    steps: RefCell<Vec<f64>>,
    cache: RefCell<VecDeque<(ParamSet, Prediction)>>,
    /// The last Jacobian (∂(pred/w)/∂y at a point, all keys), its point and its columns'
    /// signal-to-noise ratios.
    jac: RefCell<Option<LastJacobian>>,
    /// The base forward-difference step (from the model's error).
    h0: RefCell<f64>,
    stop: Option<&'a AtomicBool>,
    /// Counters and the best point.
    pub st: RefCell<Counters>,
    progress: RefCell<&'b mut dyn FnMut(FitEvent)>,
}

impl<'a, 'b> Evaluator<'a, 'b> {
    /// An evaluator of `model` with transforms `tr`, weights `w`, forward-difference step `h`
    /// against the model error `err`, and with an ensemble its noise `noise` and first
    /// half-step `half_step`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        model: ForwardModel,
        tr: Vec<Transform>,
        w: Vec<f64>,
        err: Vec<f64>,
        h: f64,
        noise: Option<(Vec<f64>, f64)>,
        stop: Option<&'a AtomicBool>,
        progress: &'b mut dyn FnMut(FitEvent),
    ) -> Self {
        let k = tr.len();
        let n = w.len();
        let obs = model.data().rows.iter().map(|r| r.observed).collect();
        let (noise, half) = match noise {
            Some((n, h)) => (Some(n), h),
            None => (None, 0.0),
        };
        Evaluator {
            model,
            tr,
            obs,
            w,
            err,
            h: RefCell::new(vec![h; k]),
            h0: RefCell::new(h),
            noise,
            steps: RefCell::new(vec![half; k]),
            cache: RefCell::new(VecDeque::new()),
            jac: RefCell::new(None),
            stop,
            st: RefCell::new(Counters {
                se2: vec![0.0; n],
                ..Counters::default()
            }),
            progress: RefCell::new(progress),
        }
    }

    /// The forward model.
    pub fn model(&self) -> &ForwardModel {
        &self.model
    }

    /// Replace the forward model (other solver settings): predictions met before are forgotten.
    pub fn set_model(&mut self, model: ForwardModel) {
        self.model = model;
        self.cache.borrow_mut().clear();
        *self.jac.borrow_mut() = None;
        self.st.borrow_mut().best = None;
    }

    /// Set the ensemble's noise per row (SI).
    pub fn set_noise(&mut self, noise: Vec<f64>) {
        self.noise = Some(noise);
    }

    /// Set the model error each column must stand above.
    pub fn set_error(&mut self, err: Vec<f64>, h: f64) {
        self.err = err;
        *self.h.borrow_mut() = vec![h; self.tr.len()];
        *self.h0.borrow_mut() = h;
        *self.jac.borrow_mut() = None;
    }

    /// Keys.
    pub fn k(&self) -> usize {
        self.tr.len()
    }

    /// Whether the Jacobians are an ensemble's central differences.
    pub fn ensemble(&self) -> bool {
        self.noise.is_some()
    }

    /// Each key's current step (half-step with an ensemble).
    pub fn steps(&self) -> Vec<f64> {
        if self.ensemble() {
            self.steps.borrow().clone()
        } else {
            self.h.borrow().clone()
        }
    }

    /// Report an event.
    pub fn event(&self, e: FitEvent) {
        (*self.progress.borrow_mut())(e);
    }

    /// The key values (SI) at `y`.
    pub fn x_of_y(&self, y: &[f64]) -> ParamSet {
        y.iter().zip(&self.tr).map(|(&y, t)| t.x(y)).collect()
    }

    /// χ² of a prediction.
    pub fn chi2(&self, p: &Prediction) -> f64 {
        (0..self.obs.len())
            .map(|i| ((self.obs[i] - p.values[i]) / self.w[i]).powi(2))
            .sum()
    }

    /// The weighted residuals of a prediction.
    pub fn residuals_of(&self, p: &Prediction) -> DVector<f64> {
        DVector::from_fn(self.obs.len(), |i, _| {
            (self.obs[i] - p.values[i]) / self.w[i]
        })
    }

    /// Run a batch of points of `y` (the sets not met before), counting runs and reporting
    /// them; each prediction is remembered (the best kept).
    pub fn predict_y(&self, ys: &[Vec<f64>]) -> Result<Vec<Prediction>, EvalError> {
        let sets: Vec<ParamSet> = ys.iter().map(|y| self.x_of_y(y)).collect();
        let preds = self.predict(&sets)?;
        for (y, p) in ys.iter().zip(&preds) {
            self.remember(y, p);
        }
        Ok(preds)
    }

    /// The prediction at `y`.
    pub fn eval_y(&self, y: &[f64]) -> Result<Prediction, EvalError> {
        self.predict_y(&[y.to_vec()])?
            .pop()
            .ok_or(EvalError::Stopped)
    }

    /// Run a batch of parameter sets (SI), those not met before, in chunks of at most the
    /// sets of one iteration (the batch size [`ForwardModel::new`] allowed).
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
        let chunk = super::model::sets_per_iteration(self.model.members(), self.k()).max(1);
        let mut fresh = Vec::with_capacity(missing.len());
        for part in missing.chunks(chunk) {
            let mut runs = 0;
            let r = {
                let mut progress = self.progress.borrow_mut();
                self.model.predict(part, self.stop, &mut || {
                    runs += 1;
                    (*progress)(FitEvent::Run);
                })
            };
            self.st.borrow_mut().runs += runs;
            let r = r?;
            self.st.borrow_mut().rhs_evals += r.iter().map(|p| p.rhs_evals).sum::<u64>();
            for (set, p) in part.iter().zip(&r) {
                self.keep(set, p);
            }
            fresh.extend(r);
        }
        let mut fresh = fresh.into_iter();
        for o in out.iter_mut() {
            if o.is_none() {
                *o = Some(fresh.next().ok_or(EvalError::Stopped)?);
            }
        }
        Ok(out.into_iter().flatten().collect())
    }

    /// Run `sets` (SI) on another model (the scenario's tolerances), counting the runs and
    /// reporting them, nothing kept.
    pub fn predict_on(
        &self,
        model: &ForwardModel,
        sets: &[ParamSet],
    ) -> Result<Vec<Prediction>, EvalError> {
        let mut runs = 0;
        let r = {
            let mut progress = self.progress.borrow_mut();
            model.predict(sets, self.stop, &mut || {
                runs += 1;
                (*progress)(FitEvent::Run);
            })
        };
        self.st.borrow_mut().runs += runs;
        let r = r?;
        self.st.borrow_mut().rhs_evals += r.iter().map(|p| p.rhs_evals).sum::<u64>();
        Ok(r)
    }

    /// Keep a prediction for reuse and pool its standard errors.
    pub fn keep(&self, set: &[f64], p: &Prediction) {
        let mut cache = self.cache.borrow_mut();
        if cache.len() == CACHE {
            cache.pop_front();
        }
        cache.push_back((set.to_vec(), p.clone()));
        let mut st = self.st.borrow_mut();
        for (a, s) in st.se2.iter_mut().zip(&p.se) {
            *a += s * s;
        }
        st.se2_sets += 1;
    }

    /// Keep `p` at `y` as the best when its χ² is the lowest met (a χ² that is not finite never
    /// is).
    pub fn remember(&self, y: &[f64], p: &Prediction) {
        let chi2 = self.chi2(p);
        let mut st = self.st.borrow_mut();
        if chi2.is_finite() && st.best.as_ref().is_none_or(|(b, _, _)| chi2 < *b) {
            st.best = Some((chi2, y.to_vec(), p.clone()));
        }
    }

    /// x with key `j` of `y` replaced by `yj`, as `y`.
    fn y_with(y: &[f64], j: usize, yj: f64) -> Vec<f64> {
        let mut v = y.to_vec();
        v[j] = yj;
        v
    }

    /// ∂(pred/w)/∂y at `y` for all keys (the last one again if it is at `y`): forward
    /// differences checked against the model error, or with an ensemble central differences of
    /// widening steps.
    pub fn jacobian_y(&self, y: &[f64]) -> Result<DMatrix<f64>, EvalError> {
        let all: Vec<usize> = (0..self.k()).collect();
        self.jacobian_cols(y, &all)
    }

    /// [`Self::jacobian_y`] and each column's signal-to-noise ratio at its last step.
    pub fn jacobian_snr(&self, y: &[f64]) -> Result<(DMatrix<f64>, Vec<f64>), EvalError> {
        let j = self.jacobian_y(y)?;
        let snr = match &*self.jac.borrow() {
            Some((jy, _, snr)) if jy.as_slice() == y => snr.clone(),
            _ => self.st.borrow().snr.clone(),
        };
        Ok((j, snr))
    }

    /// The columns `cols` of [`Self::jacobian_y`] (the others 0); kept as the last Jacobian
    /// when they are all.
    pub fn jacobian_cols(&self, y: &[f64], cols: &[usize]) -> Result<DMatrix<f64>, EvalError> {
        if let Some((jy, j, _)) = &*self.jac.borrow() {
            if jy.as_slice() == y {
                return Ok(j.clone());
            }
        }
        let jac = match &self.noise {
            Some(noise) => self.central_y(y, noise, cols)?,
            None => self.forward_y(y, cols)?,
        };
        if cols.len() == self.k() {
            let snr = self.st.borrow().snr.clone();
            *self.jac.borrow_mut() = Some((y.to_vec(), jac.clone(), snr));
        }
        Ok(jac)
    }

    /// Forward differences of each key's step, widened where a column's change does not stand
    /// [`super::stencil::TARGET_SNR`] times above the model error (a batch per round). Each
    /// Jacobian starts from the base step (a step widened far from the estimate, where the
    /// response was flat, would make a secant of the Jacobian at the estimate), except for a
    /// key whose column stood below the error even at its widest step (a key without effect).
    fn forward_y(&self, y: &[f64], cols: &[usize]) -> Result<DMatrix<f64>, EvalError> {
        {
            let h0 = *self.h0.borrow();
            let last = self.st.borrow().snr.clone();
            let mut h = self.h.borrow_mut();
            for &j in cols {
                if last.get(j).is_none_or(|&r| r >= 1.0) {
                    h[j] = h0;
                }
            }
        }
        let base = self.eval_y(y)?;
        let k = y.len();
        let n = self.obs.len();
        let noise2: f64 = (0..n)
            .map(|i| 2.0 * (self.err[i] / self.w[i]).powi(2))
            .sum();
        let mut jac = DMatrix::zeros(n, k);
        let mut ratios = {
            let last = self.st.borrow().snr.clone();
            if last.len() == k {
                last
            } else {
                vec![f64::INFINITY; k]
            }
        };
        let mut todo: Vec<usize> = cols.to_vec();
        for round in 0..=MAX_WIDENINGS {
            let h = self.h.borrow().clone();
            let signed: Vec<f64> = todo
                .iter()
                .map(|&j| {
                    if self.tr[j].inside(y[j] + h[j]) {
                        h[j]
                    } else {
                        -h[j]
                    }
                })
                .collect();
            let ys: Vec<Vec<f64>> = todo
                .iter()
                .zip(&signed)
                .map(|(&j, &s)| Self::y_with(y, j, y[j] + s))
                .collect();
            let sets: Vec<ParamSet> = ys.iter().map(|y| self.x_of_y(y)).collect();
            let preds = match self.predict(&sets) {
                Ok(p) => p,
                // A widened step into a region where a run fails keeps the columns it had.
                Err(EvalError::Failed(_)) if round > 0 => break,
                Err(e) => return Err(e),
            };
            let mut next = Vec::new();
            for (t, &j) in todo.iter().enumerate() {
                let mut signal2 = 0.0;
                for i in 0..n {
                    let d = (preds[t].values[i] - base.values[i]) / self.w[i];
                    jac[(i, j)] = d / signed[t];
                    signal2 += d * d;
                }
                ratios[j] = snr(signal2, noise2);
                if round < MAX_WIDENINGS {
                    if let Some(w) = widen(h[j], ratios[j], max_step(&self.tr[j], y[j])) {
                        self.h.borrow_mut()[j] = w;
                        next.push(j);
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            todo = next;
        }
        self.st.borrow_mut().snr = ratios;
        Ok(jac)
    }

    /// Central differences whose half-steps widen (from the last Jacobian's) until each column's
    /// change stands [`super::stencil::TARGET_SNR`] times above the noise `noise` of the
    /// ensemble mean, or reaches its widest step; a batch per round, at most
    /// [`MAX_WIDENINGS`] rounds after the first.
    fn central_y(
        &self,
        y: &[f64],
        noise: &[f64],
        cols: &[usize],
    ) -> Result<DMatrix<f64>, EvalError> {
        let k = y.len();
        let n = self.obs.len();
        let noise2: f64 = (0..n).map(|i| 2.0 * (noise[i] / self.w[i]).powi(2)).sum();
        let mut jac = DMatrix::zeros(n, k);
        let mut ratios = vec![f64::INFINITY; k];
        let mut todo: Vec<usize> = cols.to_vec();
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
                .flat_map(|(&j, &(a, b))| {
                    [
                        self.x_of_y(&Self::y_with(y, j, a)),
                        self.x_of_y(&Self::y_with(y, j, b)),
                    ]
                })
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
        self.st.borrow_mut().snr = ratios;
        Ok(jac)
    }
}

/// The keys `idx` of an [`Evaluator`]'s point `base` (in `y`), as the optimiser sees them: in
/// their unbounded coordinates `u`, the other keys held at `base`.
pub struct View<'e, 'a, 'b> {
    ev: &'e Evaluator<'a, 'b>,
    base: Vec<f64>,
    idx: Vec<usize>,
    /// A failed run's message, when one ended the optimiser.
    pub failure: Option<String>,
}

impl<'e, 'a, 'b> View<'e, 'a, 'b> {
    /// The keys `idx` about `base` (y).
    pub fn new(ev: &'e Evaluator<'a, 'b>, base: Vec<f64>, idx: Vec<usize>) -> Self {
        View {
            ev,
            base,
            idx,
            failure: None,
        }
    }

    /// The optimiser's coordinates of `y`'s keys.
    pub fn u_of(&self, y: &[f64]) -> Vec<f64> {
        self.idx
            .iter()
            .map(|&j| self.ev.tr[j].u_of_y(y[j]))
            .collect()
    }

    /// The full point (y) of the optimiser's `u`.
    pub fn y_of(&self, u: &[f64]) -> Vec<f64> {
        let mut y = self.base.clone();
        for (c, &j) in self.idx.iter().enumerate() {
            y[j] = self.ev.tr[j].y_of_u(u[c]);
        }
        y
    }

    fn halt(&mut self, e: EvalError) -> Halt {
        match e {
            EvalError::Stopped => Halt::Stopped,
            EvalError::Failed(m) => {
                self.failure = Some(m.clone());
                Halt::Failed(m)
            }
        }
    }
}

impl LeastSquares for View<'_, '_, '_> {
    fn residuals(&mut self, u: &[f64]) -> Result<Option<DVector<f64>>, Halt> {
        let y = self.y_of(u);
        match self.ev.eval_y(&y) {
            Ok(p) if self.ev.chi2(&p).is_finite() => Ok(Some(self.ev.residuals_of(&p))),
            // A trial into a region where a run fails, or where χ² is not finite: rejected.
            Ok(_) | Err(EvalError::Failed(_)) => Ok(None),
            Err(EvalError::Stopped) => Err(Halt::Stopped),
        }
    }

    fn jacobian(&mut self, u: &[f64], _r: &DVector<f64>) -> Result<DMatrix<f64>, Halt> {
        let y = self.y_of(u);
        let jy = self
            .ev
            .jacobian_cols(&y, &self.idx)
            .map_err(|e| self.halt(e))?;
        // r = (obs − pred)/w, so ∂r/∂u = −∂(pred/w)/∂y · dy/du.
        let n = jy.nrows();
        Ok(DMatrix::from_fn(n, self.idx.len(), |i, c| {
            let j = self.idx[c];
            -jy[(i, j)] * self.ev.tr[j].dy_du(u[c])
        }))
    }

    fn iteration(&mut self, _iterations: usize, chi2: f64) {
        let (iteration, runs, best) = {
            let mut st = self.ev.st.borrow_mut();
            st.iterations += 1;
            (
                st.iterations,
                st.runs,
                st.best.as_ref().map_or(chi2, |b| b.0),
            )
        };
        self.ev.event(FitEvent::Iteration {
            iteration,
            chi2,
            best,
            runs,
        });
    }
}
