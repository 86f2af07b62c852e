//! What every stepper shares: the integrated state, a step attempt's outcome and why it failed,
//! the tolerances, and the dense output between step ends.

use super::model::NQ;

/// The integrated state at one time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct State {
    /// Time (s).
    pub t: f64,
    /// Sphere position x_s (m).
    pub x: f64,
    /// Sphere velocity (m/s).
    pub v: f64,
    /// Sphere acceleration (m/s²; derived, kept for dense output).
    pub acc: f64,
    /// Contact radius (m; 0 out of contact).
    pub a: f64,
    /// ȧ (m/s): the exact rate of this state (first stage of the next step).
    pub adot: f64,
    /// In contact.
    pub contact: bool,
    /// Quadrature states.
    pub q: [f64; NQ],
}

/// Why a step attempt failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepFail {
    /// A stage found no contact radius a > 0: the contact collapses within the step.
    NoRoot,
    /// A stage produced a non-finite value.
    NonFinite,
    /// An explicit stage met the healing singularity (G ≤ 0 in contact: ȧ = +∞).
    Singular,
    /// The step lies in deep healing, where the contact-radius equation is too stiff for an
    /// explicit method at this step length (|∂ȧ/∂a| h beyond its stability interval).
    Stiff,
    /// The explicit formulation cannot continue (reason).
    Explicit(&'static str),
}

/// A completed step attempt.
#[derive(Debug, Clone, Copy, Default)]
pub struct StepOut {
    /// The state at t + h.
    pub y: State,
    /// Weighted RMS error estimate (accept when ≤ 1).
    pub err: f64,
    /// Residual / right-hand-side evaluations spent.
    pub evals: u64,
    /// Exponent of the step-size controller, 1/(p̂ + 1) for an embedded estimate of order p̂
    /// (0 when `err` is not an estimate).
    pub err_exp: f64,
    /// Where within the step the contact line turns (ȧ = 0), as a fraction of h, for a stepper
    /// whose accuracy needs the step to end there (the explicit DP8); `None` otherwise.
    pub kink: Option<f64>,
    /// The predicted time (s) of the next turning point after the step, within two more step
    /// lengths (same steppers; `None` otherwise).
    pub kink_ahead: Option<f64>,
}

/// Tolerances of the error norm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tol {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance relative to each component's natural scale.
    pub atol: f64,
}

/// What dense output and samples need of a state: (t, x, v, a), their rates and the contact
/// flag, without the quadratures (a step's samples travel as two knots).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knot {
    /// Time (s).
    pub t: f64,
    /// Sphere position x_s (m).
    pub x: f64,
    /// Sphere velocity (m/s).
    pub v: f64,
    /// Sphere acceleration (m/s²).
    pub acc: f64,
    /// Contact radius (m; 0 out of contact).
    pub a: f64,
    /// ȧ (m/s).
    pub adot: f64,
    /// In contact.
    pub contact: bool,
}

impl From<&State> for Knot {
    fn from(y: &State) -> Self {
        Self {
            t: y.t,
            x: y.x,
            v: y.v,
            acc: y.acc,
            a: y.a,
            adot: y.adot,
            contact: y.contact,
        }
    }
}

impl Knot {
    /// Cubic Hermite interpolation of (x, v, a) between two knots of one step (ȧ and the
    /// acceleration linear); the contact flag and, outside the step, the values of `k1`.
    pub fn hermite(k0: &Knot, k1: &Knot, t: f64) -> Knot {
        let h = k1.t - k0.t;
        if h <= 0.0 {
            return *k1;
        }
        let s = ((t - k0.t) / h).clamp(0.0, 1.0);
        let h00 = (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s);
        let h10 = s * (1.0 - s) * (1.0 - s);
        let h01 = s * s * (3.0 - 2.0 * s);
        let h11 = s * s * (s - 1.0);
        let p =
            |p0: f64, d0: f64, p1: f64, d1: f64| h00 * p0 + h10 * h * d0 + h01 * p1 + h11 * h * d1;
        Knot {
            t,
            x: p(k0.x, k0.v, k1.x, k1.v),
            v: p(k0.v, k0.acc, k1.v, k1.acc),
            a: p(k0.a, k0.adot, k1.a, k1.adot),
            adot: k0.adot + s * (k1.adot - k0.adot),
            acc: k0.acc + s * (k1.acc - k0.acc),
            contact: k1.contact,
        }
    }
}

/// Cubic Hermite interpolation of (x, v, a) between two states of one step ([`Knot::hermite`];
/// the quadratures and the contact flag of `y1`): the dense output for interpolated searches.
pub fn hermite(y0: &State, y1: &State, t: f64) -> State {
    if y1.t - y0.t <= 0.0 {
        return *y1;
    }
    let k = Knot::hermite(&Knot::from(y0), &Knot::from(y1), t);
    State {
        t: k.t,
        x: k.x,
        v: k.v,
        acc: k.acc,
        a: k.a,
        adot: k.adot,
        ..*y1
    }
}
