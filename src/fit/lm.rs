//! The optimiser: Levenberg–Marquardt with Nielsen's update of the damping (Nielsen 1999;
//! Madsen, Nielsen & Tingleff, *Methods for non-linear least squares problems*, 2004,
//! algorithm 3.16), over any [`LeastSquares`] problem.
//!
//! Notation: `r(u)` the weighted residuals, `χ² = rᵀr`, `J = ∂r/∂u`, `A = JᵀJ`, `g = Jᵀr`.
//! From `u` the step `h` solves `(A + μI) h = −g`; the linear model predicts that χ² falls by
//! `hᵀ(μh − g)`. The step is taken when χ² falls (`ρ`, actual over predicted fall, above 0):
//! then a new Jacobian is computed and `μ` is multiplied by `max(1/3, 1 − (2ρ − 1)³)`; a step
//! that does not lower χ² (or whose point cannot be evaluated: a failed run, a χ² that is not
//! finite) is *rejected*: `μ` is multiplied by `ν` and `ν` doubled, and the smaller step tried
//! again. So the optimiser never gives up after a failed step: it keeps shrinking the step
//! until one lowers χ² or a criterion below ends it.
//!
//! Why not the `levenberg-marquardt` crate (MINPACK's trust region): it decides on its own when
//! to compute a Jacobian, counts no iterations, hides rejected steps and ends on a trust region
//! shrunk below `xtol` of the parameters' norm after a few rejections — from `adhesion.n = 0.3`
//! on the paper protocol it stopped after one trial step (issue 36). Here each iteration is one
//! Jacobian, every trial is seen (progress, the best point kept), and the ends are these,
//! checked in this order after each Jacobian and each trial:
//!
//! - **gradient** (converged): the Gauss–Newton step from the current point, `h = −A⁺g`, would
//!   lower χ² by `gᵀA⁺g ≤ gtol · s²`, where `s² = 1` for data with sigma (`χ²/dof` without):
//!   with `gtol = 1e-3` the estimate lies within `√gtol ≈ 0.03` σ of the minimum of the
//!   linearised model;
//! - **relative χ² change** (converged): two successive accepted steps each lowered χ² by less
//!   than `ftol = 1e-6` of it;
//! - **step size** (converged, at the resolution of the step): the step is shorter than
//!   `xtol (‖u‖ + xtol)`, `xtol = 1e-6`: no step the damping allows changes the parameters by more
//!   than the model resolves (a minimum, or a kink of χ² that [`super::uncertainty`] then
//!   recognises);
//! - **iterations** (not converged): `max_iterations` Jacobians computed;
//! - **halt** (not converged): the problem stopped it (Ctrl-C, a failed run of a Jacobian).
//!
//! The last Jacobian is always the one at the returned point (it is computed after each
//! accepted step, before the criteria), so the uncertainty analysis never recomputes it.

use nalgebra::{DMatrix, DVector};

/// Why the problem stopped the optimiser.
#[derive(Debug, Clone, PartialEq)]
pub enum Halt {
    /// Stopped from outside (Ctrl-C).
    Stopped,
    /// A computation the optimiser needs failed (a run of a Jacobian), with the message.
    Failed(String),
}

/// A weighted least-squares problem in the optimiser's coordinates `u`.
pub trait LeastSquares {
    /// The weighted residuals at `u`; `Ok(None)` where the point cannot be evaluated (a trial
    /// step is then rejected).
    fn residuals(&mut self, u: &[f64]) -> Result<Option<DVector<f64>>, Halt>;
    /// `∂r/∂u` at `u`, where the residuals are `r`.
    fn jacobian(&mut self, u: &[f64], r: &DVector<f64>) -> Result<DMatrix<f64>, Halt>;
    /// An iteration (a Jacobian) ended at `u` with `chi2`: for progress.
    fn iteration(&mut self, _iterations: usize, _chi2: f64) {}
}

/// The optimiser's criteria (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Most Jacobians.
    pub max_iterations: usize,
    /// The Gauss–Newton fall of χ², in units of `scale`, below which the point is a minimum.
    pub gtol: f64,
    /// The relative fall of χ² of two successive accepted steps below which the point is a
    /// minimum.
    pub ftol: f64,
    /// The relative step below which the point is a minimum at the step's resolution.
    pub xtol: f64,
    /// `s²`: 1 with sigma, `χ²/dof` without (then updated with χ²); see [`Self::dof`].
    pub dof: Option<usize>,
    /// The first damping over the largest diagonal element of `A`.
    pub tau: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            max_iterations: 30,
            gtol: 1e-3,
            ftol: 1e-6,
            xtol: 1e-6,
            dof: None,
            tau: 1e-3,
        }
    }
}

/// How the optimiser ended.
#[derive(Debug, Clone, PartialEq)]
pub enum End {
    /// The Gauss–Newton step would lower χ² by less than `gtol`.
    Gradient,
    /// Two successive steps lowered χ² by less than `ftol` of it.
    Chi2Change,
    /// The step shrank below `xtol`.
    StepSize,
    /// `max_iterations` Jacobians without meeting a criterion.
    Iterations,
    /// The problem stopped it.
    Halted(Halt),
}

impl End {
    /// Whether a convergence criterion ended the optimiser.
    pub fn converged(&self) -> bool {
        matches!(self, End::Gradient | End::Chi2Change | End::StepSize)
    }

    /// The criterion in words (`fit.json`'s `termination`).
    pub fn words(&self) -> String {
        match self {
            End::Gradient => "gradient: the Gauss-Newton step would lower chi2 by less than \
                              the tolerance"
                .into(),
            End::Chi2Change => {
                "chi2 change: two successive steps lowered chi2 by less than 1e-6 of it".into()
            }
            End::StepSize => "step size: no step the damping allows changed the parameters by \
                              more than 1e-6"
                .into(),
            End::Iterations => "iterations: the most iterations allowed ran out".into(),
            End::Halted(Halt::Stopped) => "interrupted".into(),
            End::Halted(Halt::Failed(m)) => format!("a forward run failed: {m}"),
        }
    }
}

/// The optimiser's result.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The best point (the last accepted).
    pub u: Vec<f64>,
    /// Its residuals.
    pub r: DVector<f64>,
    /// χ² there.
    pub chi2: f64,
    /// The Jacobian there (`∂r/∂u`), if one was computed there (none when halted before).
    pub jacobian: Option<DMatrix<f64>>,
    /// How it ended.
    pub end: End,
    /// Jacobians computed.
    pub iterations: usize,
    /// Trial steps rejected.
    pub rejected: usize,
    /// The last accepted step (from the point before to `u`): its predicted and actual fall of
    /// χ², for the check of the linear model along it. None before any.
    pub last_step: Option<Step>,
    /// The Gauss–Newton fall of χ² at `u` (`gᵀA⁺g`; NaN without a Jacobian there).
    pub gn_fall: f64,
}

/// An accepted step.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The step in `u`.
    pub h: Vec<f64>,
    /// The fall of χ² the linear model predicted.
    pub predicted: f64,
    /// The fall of χ² met.
    pub actual: f64,
}

/// `gᵀA⁺g`: the fall of χ² the Gauss–Newton step predicts (the pseudo-inverse ignores the
/// directions `A` does not see, at 1e-12 of its largest eigenvalue).
pub fn gauss_newton_fall(a: &DMatrix<f64>, g: &DVector<f64>) -> f64 {
    let eig = a.clone().symmetric_eigen();
    let top = eig.eigenvalues.iter().fold(0.0f64, |m, &e| m.max(e));
    let mut fall = 0.0;
    for (l, &e) in eig.eigenvalues.iter().enumerate() {
        if e > 1e-12 * top && e > 0.0 {
            let c = eig.eigenvectors.column(l).dot(g);
            fall += c * c / e;
        }
    }
    fall
}

/// Solve `(A + μI) h = −g` (Cholesky; `None` if it fails, which `μ > 0` prevents unless a
/// number is not finite).
fn damped_step(a: &DMatrix<f64>, g: &DVector<f64>, mu: f64) -> Option<DVector<f64>> {
    let mut m = a.clone();
    for i in 0..m.nrows() {
        m[(i, i)] += mu;
    }
    let h = m.cholesky()?.solve(&(-g));
    h.iter().all(|x| x.is_finite()).then_some(h)
}

/// Minimise χ² from `u0`, whose residuals `r0` are known (finite).
pub fn minimise<P: LeastSquares + ?Sized>(
    p: &mut P,
    u0: &[f64],
    r0: DVector<f64>,
    s: &Settings,
) -> Outcome {
    let mut u = DVector::from_column_slice(u0);
    let mut r = r0;
    let mut chi2 = r.norm_squared();
    let mut out = Outcome {
        u: u0.to_vec(),
        r: r.clone(),
        chi2,
        jacobian: None,
        end: End::Iterations,
        iterations: 0,
        rejected: 0,
        last_step: None,
        gn_fall: f64::NAN,
    };
    let scale = |chi2: f64| match s.dof {
        Some(d) if d > 0 => chi2 / d as f64,
        _ => 1.0,
    };
    if s.max_iterations == 0 {
        return out;
    }
    let mut j = match p.jacobian(u.as_slice(), &r) {
        Ok(j) => j,
        Err(h) => {
            out.end = End::Halted(h);
            return out;
        }
    };
    out.iterations = 1;
    p.iteration(out.iterations, chi2);
    let mut a = j.transpose() * &j;
    let mut g = j.transpose() * &r;
    let top = a.diagonal().iter().fold(0.0f64, |m, &x| m.max(x));
    let mut mu = if top > 0.0 && top.is_finite() {
        s.tau * top
    } else {
        s.tau
    };
    let mut nu = 2.0;
    let mut small_falls = 0;
    loop {
        out.gn_fall = gauss_newton_fall(&a, &g);
        out.jacobian = Some(j.clone());
        if out.gn_fall <= s.gtol * scale(chi2) {
            out.end = End::Gradient;
            break;
        }
        if small_falls >= 2 {
            out.end = End::Chi2Change;
            break;
        }
        // Trials from u until one lowers chi2 (then a new Jacobian) or the step is too short.
        let accepted = loop {
            let Some(h) = damped_step(&a, &g, mu) else {
                mu *= nu;
                nu *= 2.0;
                if !mu.is_finite() {
                    break None;
                }
                continue;
            };
            if h.norm() <= s.xtol * (u.norm() + s.xtol) {
                break None;
            }
            let predicted = h.dot(&(mu * &h - &g));
            let trial = &u + &h;
            let rt = match p.residuals(trial.as_slice()) {
                Ok(rt) => rt,
                Err(e) => {
                    out.end = End::Halted(e);
                    return out;
                }
            };
            let chi2t = rt.as_ref().map_or(f64::INFINITY, |r| r.norm_squared());
            let actual = chi2 - chi2t;
            let rho = actual / predicted;
            if chi2t.is_finite() && actual > 0.0 && rho > 0.0 {
                mu *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                nu = 2.0;
                break rt.map(|rt| (trial, rt, chi2t, h, predicted, actual));
            }
            out.rejected += 1;
            mu *= nu;
            nu *= 2.0;
        };
        let Some((trial, rt, chi2t, h, predicted, actual)) = accepted else {
            out.end = End::StepSize;
            break;
        };
        small_falls = if actual < s.ftol * chi2 {
            small_falls + 1
        } else {
            0
        };
        u = trial;
        r = rt;
        chi2 = chi2t;
        out.u = u.as_slice().to_vec();
        out.r = r.clone();
        out.chi2 = chi2;
        out.jacobian = None;
        out.gn_fall = f64::NAN;
        out.last_step = Some(Step {
            h: h.as_slice().to_vec(),
            predicted,
            actual,
        });
        if out.iterations >= s.max_iterations {
            out.end = End::Iterations;
            return out;
        }
        j = match p.jacobian(u.as_slice(), &r) {
            Ok(j) => j,
            Err(h) => {
                out.end = End::Halted(h);
                return out;
            }
        };
        out.iterations += 1;
        p.iteration(out.iterations, chi2);
        a = j.transpose() * &j;
        g = j.transpose() * &r;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A problem of closed form: residuals and Jacobian of `f`, counting calls.
    struct Closed<F: Fn(&[f64]) -> Vec<f64>> {
        f: F,
        calls: usize,
        jacobians: usize,
    }

    impl<F: Fn(&[f64]) -> Vec<f64>> LeastSquares for Closed<F> {
        fn residuals(&mut self, u: &[f64]) -> Result<Option<DVector<f64>>, Halt> {
            self.calls += 1;
            let r = (self.f)(u);
            Ok(r.iter()
                .all(|x| x.is_finite())
                .then(|| DVector::from_vec(r)))
        }
        fn jacobian(&mut self, u: &[f64], _r: &DVector<f64>) -> Result<DMatrix<f64>, Halt> {
            self.jacobians += 1;
            let r0 = (self.f)(u);
            let mut j = DMatrix::zeros(r0.len(), u.len());
            for c in 0..u.len() {
                let h = 1e-7 * u[c].abs().max(1.0);
                let mut a = u.to_vec();
                let mut b = u.to_vec();
                a[c] -= h;
                b[c] += h;
                let (ra, rb) = ((self.f)(&a), (self.f)(&b));
                for i in 0..r0.len() {
                    j[(i, c)] = (rb[i] - ra[i]) / (2.0 * h);
                }
            }
            Ok(j)
        }
    }

    fn run<F: Fn(&[f64]) -> Vec<f64>>(f: F, u0: &[f64], s: &Settings) -> (Outcome, usize) {
        let mut p = Closed {
            f,
            calls: 0,
            jacobians: 0,
        };
        let r0 = DVector::from_vec((p.f)(u0));
        let o = minimise(&mut p, u0, r0, s);
        assert_eq!(o.iterations, p.jacobians);
        (o, p.calls)
    }

    /// Rosenbrock's valley as least squares, r = (10 (u1 − u0²), 1 − u0), from (−1.2, 1): the
    /// minimum (1, 1) with χ² 0, met through many rejected steps; the last Jacobian is the one at
    /// the estimate.
    #[test]
    fn rosenbrock_is_solved() {
        let f = |u: &[f64]| vec![10.0 * (u[1] - u[0] * u[0]), 1.0 - u[0]];
        let s = Settings {
            max_iterations: 200,
            gtol: 1e-20,
            ..Settings::default()
        };
        let (o, _) = run(f, &[-1.2, 1.0], &s);
        assert!(o.end.converged(), "{:?}", o.end);
        assert!(
            (o.u[0] - 1.0).abs() < 1e-6 && (o.u[1] - 1.0).abs() < 1e-6,
            "{:?}",
            o.u
        );
        let j = o.jacobian.expect("the Jacobian at the estimate");
        // At (1, 1): ∂r/∂u = [[−20, 10], [−1, 0]].
        assert!((j[(0, 0)] + 20.0).abs() < 1e-5 && (j[(0, 1)] - 10.0).abs() < 1e-5);
    }

    /// An exponential decay fitted to exact data: the estimates to 1e-8, ending on the gradient
    /// criterion, whose Gauss–Newton fall is then below gtol.
    #[test]
    fn an_exponential_decay_is_recovered() {
        let t: Vec<f64> = (0..12).map(|i| 0.25 * i as f64).collect();
        let obs: Vec<f64> = t.iter().map(|&t| 3.0 * (-1.3 * t).exp() + 0.2).collect();
        let f = move |u: &[f64]| {
            t.iter()
                .zip(&obs)
                .map(|(&t, &o)| (o - (u[0] * (-u[1] * t).exp() + u[2])) / 0.01)
                .collect::<Vec<_>>()
        };
        let (o, _) = run(f, &[1.0, 0.3, 0.0], &Settings::default());
        assert_eq!(o.end, End::Gradient);
        assert!(o.gn_fall <= 1e-3);
        for (got, want) in o.u.iter().zip([3.0, 1.3, 0.2]) {
            assert!((got - want).abs() < 1e-4, "{:?}", o.u);
        }
    }

    /// A start whose first trials fail (the model cannot be evaluated beyond u = 0.5, and the
    /// undamped step from the flat tail of a tanh lands far beyond): the optimiser shrinks the
    /// step and goes on, instead of giving up after one failed step, and reaches the minimum.
    #[test]
    fn failed_trials_shrink_the_step_and_the_fit_goes_on() {
        let f = |u: &[f64]| {
            if u[0] > 0.5 {
                vec![f64::NAN; 2]
            } else {
                vec![10.0 * (u[0] - 0.4).tanh(), 1.0]
            }
        };
        let s = Settings {
            tau: 1e-9,
            ..Settings::default()
        };
        let (o, _) = run(f, &[-2.0], &s);
        assert!(o.end.converged(), "{:?}", o.end);
        assert!(
            o.rejected > 0,
            "no step was rejected: the test does not test"
        );
        assert!((o.u[0] - 0.4).abs() < 1e-3, "{:?}", o.u);
    }

    /// The iteration budget ends the optimiser, not converged, at its best point.
    #[test]
    fn the_iteration_budget_ends_it() {
        let f = |u: &[f64]| vec![10.0 * (u[1] - u[0] * u[0]), 1.0 - u[0]];
        let s = Settings {
            max_iterations: 3,
            gtol: 1e-20,
            ..Settings::default()
        };
        let (o, _) = run(f, &[-1.2, 1.0], &s);
        assert_eq!(o.end, End::Iterations);
        assert!(!o.end.converged());
        assert_eq!(o.iterations, 3);
        // From chi2 = 4.4² + 2.2² = 24.2, lower.
        assert!(o.chi2 < 24.2, "{}", o.chi2);
    }

    /// A function with a jump: χ² has a kink at its minimum. The optimiser ends on the step
    /// size there (not the gradient, which the jump keeps large).
    #[test]
    fn a_kink_ends_on_the_step_size() {
        let f = |u: &[f64]| vec![(u[0] - 1.0).abs().sqrt() * 10.0 + 1.0];
        let (o, _) = run(f, &[3.0], &Settings::default());
        assert_eq!(o.end, End::StepSize, "{o:?}");
        assert!((o.u[0] - 1.0).abs() < 1e-3, "{:?}", o.u);
    }

    /// The Gauss–Newton fall of a linear problem is the whole reducible χ².
    #[test]
    fn the_gauss_newton_fall_is_the_reducible_chi2() {
        let j = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 2.0, 0.0, 0.0]);
        let r = DVector::from_vec(vec![1.0, 4.0, 3.0]);
        let a = j.transpose() * &j;
        let g = j.transpose() * &r;
        // χ² = 26; the best reachable is 9 (the third row): the fall is 17.
        assert!((gauss_newton_fall(&a, &g) - 17.0).abs() < 1e-12);
        // A direction A does not see is left out, not divided by zero.
        let j = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 1.0, 0.0]);
        let a = j.transpose() * &j;
        let g = j.transpose() * DVector::from_vec(vec![1.0, 1.0]);
        assert!((gauss_newton_fall(&a, &g) - 2.0).abs() < 1e-12);
    }
}
