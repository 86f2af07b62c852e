//! Explicit methods: `ode_solvers` Dopri5 and Dop853 on the scaled state
//! (x_s, v_s, a, quadratures) with ȧ = law.crack_speed(G) in closed form (or by the law's own
//! inverse).
//!
//! `ode_solvers` has no event location, and its Dense output hands mismatched (x, y) pairs to
//! `solout`, so it is used here only as a *macro-step* engine: [`macro_step`] integrates from a
//! state over [t, t + H] with the crate's own adaptive control (Sparse output; the last point is
//! the end state). The driver chooses H (never across a stage end, a base-period boundary or a
//! known event), scans each macro step for events and locates them by re-integrating from its
//! start over shorter spans — the same bracketing search as for the implicit method.
//!
//! Scaling: the components are divided by their natural scales (length, velocity, jump-in radius)
//! so that the crate's scalar atol/rtol act like the implicit method's per-component norm. The
//! quadrature states are divided by 1e6 × their natural scale, which keeps them in the error norm
//! with a loose weight (their relative error is still controlled by rtol).
//!
//! Dop853 caveat (measured): on our scenes its inner step settles at a tolerance-independent
//! size (1/108 of the macro step on the free oscillator) and its accuracy stalls near 1e-8 m,
//! while the crate's Dop853 alone on y'' = −y converges normally (`probe_*` tests); on GS contacts
//! it also crawls through the non-smooth points where ȧ changes sign and reports stiffness. The
//! cause was not found; `auto` never chooses it.
//!
//! Failure modes (reported to the driver as [`StepFail::Explicit`]): a compressive edge or G ≤ 0
//! (ȧ = +∞: the explicit form cannot pass it), a rate-independent law (ȧ undefined), stiffness
//! detected by `ode_solvers`, or its step budget exhausted.

use super::model::{Drive, Mechanics, Model, NQ};
use super::state::{State, StepFail, StepOut, Tol};
use super::stepper::{Capabilities, Reach, Stepper};
use crate::adhesion::AdhesionLaw;
use crate::jkr;
use ode_solvers::dop_shared::{IntegrationError, OutputType};
use ode_solvers::{Dop853, Dopri5, SVector, System};
use std::cell::Cell;

/// Which explicit method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OdeMethod {
    /// Dormand–Prince 5(4).
    Dopri5,
    /// Dormand–Prince 8(5,3).
    Dop853,
}

/// The last component is the time elapsed in the span (/ t_char): the right-hand side reads the
/// time from it rather than from the crate's argument, because `ode_solvers` 0.6.2 evaluates
/// Dop853's 12th stage at t instead of t + h (its node c₁₂ is 0 where the row sum and Hairer's
/// value are 1; srenevey/ode-solvers PR #42). On our time-dependent right-hand side (base
/// motion, moving spring end) that made its steps collapse; as an autonomous system it is
/// exact. Dopri5 gets the same treatment (the component is integrated exactly by both).
const TI: usize = 3 + NQ;
const N: usize = 4 + NQ;
type Y = SVector<f64, N>;

struct Rhs<'a> {
    model: &'a Model,
    drive: Drive,
    contact: bool,
    scale: [f64; N],
    t0: f64,
    singular: &'a Cell<bool>,
    collapse: &'a Cell<bool>,
    evals: &'a Cell<u64>,
}

/// Instantaneous derivatives of the explicit formulation at (t, x, v, a); returns
/// (x, v, acc, ȧ, w, integrands). `None` when ȧ is infinite (G ≤ 0) or undefined.
#[allow(clippy::type_complexity)]
fn explicit_rates(
    model: &Model,
    drive: &Drive,
    t: f64,
    x: f64,
    v: f64,
    a: f64,
    contact: bool,
) -> Option<(f64, f64, f64, f64, [f64; NQ])> {
    let kin = drive.at(model, t);
    let (x, v, adot, w) = if contact {
        if a.is_nan() || a <= 0.0 || model.rate_independent {
            return None;
        }
        let (xq, _) = match model.mech {
            Mechanics::Dynamic => (x, v),
            _ => model.position(&kin, a, 0.0, true, x, v, 0.0),
        };
        let g = jkr::signed_energy_release_rate(&model.mat, a, xq + kin.xb);
        let adot = model.law.crack_speed(g);
        if !adot.is_finite() {
            return None;
        }
        let (x, v) = match model.mech {
            Mechanics::Dynamic => (x, v),
            _ => model.position(&kin, a, adot, true, x, v, 0.0),
        };
        // On the law, w(ȧ) = G exactly.
        (x, v, adot, g)
    } else {
        let (x, v) = match model.mech {
            Mechanics::Dynamic => (x, v),
            _ => model.position(&kin, 0.0, 0.0, false, x, v, 0.0),
        };
        (x, v, 0.0, model.w0)
    };
    let acc = match model.mech {
        Mechanics::Dynamic => model.accel(&kin, x, v, a, contact),
        _ => 0.0,
    };
    let fq = model.integrands(&kin, x, v, a, adot, w, contact);
    Some((x, v, acc, adot, fq))
}

impl System<f64, Y> for Rhs<'_> {
    fn system(&self, _t: f64, y: &Y, dy: &mut Y) {
        self.evals.set(self.evals.get() + 1);
        let s = &self.scale;
        let t = self.t0 + y[TI] * s[TI];
        dy[TI] = 1.0 / s[TI];
        let (x, v, a) = (y[0] * s[0], y[1] * s[1], y[2] * s[2]);
        match explicit_rates(self.model, &self.drive, t, x, v, a, self.contact) {
            Some((_, v, acc, adot, fq)) => {
                dy[0] = v / s[0];
                dy[1] = acc / s[1];
                dy[2] = adot / s[2];
                for k in 0..NQ {
                    dy[3 + k] = fq[k] / s[3 + k];
                }
            }
            None => {
                if self.contact && (a.is_nan() || a <= 0.0) {
                    self.collapse.set(true);
                } else {
                    self.singular.set(true);
                }
                for k in 0..TI {
                    dy[k] = 0.0;
                }
            }
        }
    }
}

fn scales(model: &Model) -> [f64; N] {
    let mut s = [1.0; N];
    s[0] = model.len_scale;
    s[1] = model.vel_scale;
    s[2] = model.a_jump;
    let f = jkr::hertz_force(&model.mat, model.a_jump).max(1e-300);
    let t = model.t_char;
    let qs: [f64; NQ] = {
        let l = model.len_scale;
        let a = model.a_jump;
        let e = f * l;
        [
            f * t,
            f * t,
            f * t,
            l * t,
            l * t,
            a * t,
            a * t,
            a * t,
            l * t,
            l * t,
            f * t,
            f * t,
            f * t,
            e,
            e,
            e,
            e,
        ]
    };
    for k in 0..NQ {
        s[3 + k] = 1e6 * qs[k];
    }
    s[TI] = t;
    s
}

/// What the crate's integration outcome and the right-hand side's flags mean for the macro
/// step: a trial stage that pushed a through 0 is a collapsing contact; one that met G ≤ 0 the
/// limit of the explicit form.
fn check_outcome<E>(
    res: Result<E, IntegrationError>,
    collapse: bool,
    singular: bool,
    contact: bool,
) -> Result<(), StepFail> {
    if collapse && !singular {
        // A trial stage pushed a through 0: the contact collapses within the macro step.
        return Err(StepFail::NoRoot);
    }
    if singular {
        return Err(StepFail::Explicit(
            "the contact edge became compressive or G <= 0 (infinite healing speed)",
        ));
    }
    match res {
        Ok(_) => Ok(()),
        Err(IntegrationError::StiffnessDetected { .. }) => {
            Err(StepFail::Explicit("stiffness detected"))
        }
        Err(IntegrationError::MaxNumStepReached { .. }) => Err(StepFail::Explicit(
            "step budget of the explicit method exhausted",
        )),
        Err(IntegrationError::StepSizeUnderflow { .. }) => {
            // In contact this is the finite-time collapse a → 0 (ȧ → −∞) inside the macro
            // step: report it like a failed implicit stage so that the driver closes in on it.
            Err(if contact {
                StepFail::NoRoot
            } else {
                StepFail::Explicit("step size underflow")
            })
        }
    }
}

/// Integrate from `y` over [y.t, y.t + h] with an `ode_solvers` method. `h_guess` is the inner
/// step to start with (0: the crate's own initial guess); the last inner step is returned for the
/// next call.
pub fn macro_step(
    model: &Model,
    drive: &Drive,
    y: &State,
    h: f64,
    tol: Tol,
    kind: OdeMethod,
    h_guess: f64,
) -> Result<(StepOut, f64), StepFail> {
    let scale = scales(model);
    let y0 = scaled(y, &scale);
    let singular = Cell::new(false);
    let collapse = Cell::new(false);
    let evals = Cell::new(0u64);
    let rhs = Rhs {
        model,
        drive: *drive,
        contact: y.contact,
        scale,
        t0: y.t,
        singular: &singular,
        collapse: &collapse,
        evals: &evals,
    };
    let (t0, t1) = (y.t, y.t + h);
    let hg = if h_guess > 0.0 { h_guess.min(h) } else { 0.0 };
    let rtol = tol.rtol;
    let atol = tol.atol;
    let n_max = 200_000;
    macro_rules! run {
        ($solver:ident, $beta:expr, $fmin:expr, $fmax:expr) => {{
            let mut s = $solver::from_param(
                rhs,
                t0,
                t1,
                h,
                y0,
                rtol,
                atol,
                0.9,
                $beta,
                $fmin,
                $fmax,
                h,
                hg,
                n_max,
                1000,
                OutputType::Sparse,
            );
            let res = s.integrate();
            let (xs, ys) = s.results().get();
            let out = match (xs.last(), ys.last()) {
                (Some(&t), Some(yv)) => Some((t, *yv)),
                _ => None,
            };
            // The largest inner step (the last one is usually clipped to reach t + h).
            let last_h = xs.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
            let last_h = if last_h > 0.0 { last_h } else { h };
            (res, out, last_h)
        }};
    }
    let (res, out, last_h) = match kind {
        OdeMethod::Dopri5 => run!(Dopri5, 0.04, 0.2, 10.0),
        OdeMethod::Dop853 => run!(Dop853, 0.0, 0.333, 6.0),
    };
    let n_evals = evals.get();
    check_outcome(res, collapse.get(), singular.get(), y.contact)?;
    let Some((t_end, ye)) = out else {
        return Err(StepFail::Explicit("no output"));
    };
    if (t_end - t1).abs() > 1e-9 * h.max(f64::MIN_POSITIVE) + 4.0 * f64::EPSILON * t1.abs() {
        return Err(StepFail::Explicit("integration stopped early"));
    }
    Ok((
        StepOut {
            y: end_state(model, drive, y, t1, &ye, &scale)?,
            err: 0.0,
            evals: n_evals,
            err_exp: 0.0,
            kink: None,
            kink_ahead: None,
        },
        last_h,
    ))
}

/// `y` in the integrator's scaled unknowns.
fn scaled(y: &State, scale: &[f64; N]) -> Y {
    let mut y0 = Y::zeros();
    y0[0] = y.x / scale[0];
    y0[1] = y.v / scale[1];
    y0[2] = y.a / scale[2];
    for k in 0..NQ {
        y0[3 + k] = y.q[k] / scale[3 + k];
    }
    y0
}

/// The state at `t1`, the end of a macro step from `y`, from the integrator's scaled end point
/// `ye`: unscaled, with its rates, checked finite.
fn end_state(
    model: &Model,
    drive: &Drive,
    y: &State,
    t1: f64,
    ye: &Y,
    scale: &[f64; N],
) -> Result<State, StepFail> {
    let (x, v, a) = (ye[0] * scale[0], ye[1] * scale[1], ye[2] * scale[2]);
    let Some((x, v, acc, adot, _)) = explicit_rates(model, drive, t1, x, v, a, y.contact) else {
        return Err(StepFail::Explicit(
            "the contact edge is compressive or G <= 0 (infinite healing speed)",
        ));
    };
    let mut q = [0.0; NQ];
    for k in 0..NQ {
        q[k] = ye[3 + k] * scale[3 + k];
    }
    if !(x.is_finite() && v.is_finite() && a.is_finite() && q.iter().all(|v| v.is_finite())) {
        return Err(StepFail::NonFinite);
    }
    Ok(State {
        t: t1,
        x,
        v,
        acc,
        a: if y.contact { a } else { 0.0 },
        adot,
        contact: y.contact,
        q,
    })
}

/// `ode_solvers`' Dopri5 or Dop853 as a macro-step engine ([`macro_step`]) behind
/// [`Stepper`].
#[derive(Debug, Clone, Copy)]
pub struct OdeSolvers {
    method: OdeMethod,
    /// The last inner step (s), to start the next macro step with.
    h_inner: f64,
}

impl OdeSolvers {
    /// The given `ode_solvers` method.
    pub fn new(method: OdeMethod) -> Self {
        Self {
            method,
            h_inner: 0.0,
        }
    }
}

impl Stepper for OdeSolvers {
    fn fresh(&self) -> Box<dyn Stepper> {
        Box::new(OdeSolvers::new(self.method))
    }
    fn name(&self) -> &'static str {
        match self.method {
            OdeMethod::Dopri5 => "explicit Dopri5 (ode_solvers)",
            OdeMethod::Dop853 => "explicit Dop853 (ode_solvers)",
        }
    }
    fn short_name(&self) -> &'static str {
        match self.method {
            OdeMethod::Dopri5 => "dopri5",
            OdeMethod::Dop853 => "dop853",
        }
    }
    /// Explicit (no algebraic contact radius), and each attempt a macro step with the crate's
    /// own inner control, kept to half the longest step.
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            algebraic_radius: false,
            turning_points: false,
            period_memory: false,
            reach: Reach::Half,
        }
    }
    fn attempt(
        &mut self,
        model: &Model,
        drive: &Drive,
        y: &State,
        h: f64,
        tol: Tol,
        _evals: &mut u64,
        out: &mut StepOut,
    ) -> Result<(), StepFail> {
        let (o, hi) = macro_step(model, drive, y, h, tol, self.method, self.h_inner)?;
        self.h_inner = hi;
        *out = o;
        Ok(())
    }
}
