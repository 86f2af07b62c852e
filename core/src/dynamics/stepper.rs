//! The one interface of the integrators: a step attempt from a state, and the capabilities the
//! simulator asks a method for. Each method implements [`Stepper`] beside its own code
//! ([`super::esdirk::Implicit`], [`super::dp8::Dp8`], [`super::ode_adapter::OdeSolvers`], the
//! combinator [`super::rescue::Rescued`]); [`super::methods`] names them in one registry table.
//! What is particular to a method (turning points of the contact line, the period memory of
//! the step control, how long an attempt may be, whether it can integrate an algebraic contact
//! radius) is said by its [`Capabilities`], never by its name.

use super::model::{Drive, Model};
use super::state::{State, StepFail, StepOut, Tol};

/// How long the simulator lets one attempt be, within its longest step `h_max` (1/8 of a base
/// period, or of the run's time scale without a base).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reach {
    /// The whole `h_max`: the method's steps are short enough for the samples interpolated on
    /// them (the implicit method's are several times shorter than DP8's).
    Full,
    /// Half of `h_max` when samples are interpolated on a time grid: the method's high order
    /// makes its steps long, and the cubic Hermite interpolant's error, ≈ (ωh)⁴/384 of the
    /// amplitude, is 6e-5 at 1/16 of a period against 1e-3 at 1/8.
    HalfForSamples,
    /// Half of `h_max` always: each attempt is a macro step of an integrator with its own inner
    /// step control, on which events are located and samples interpolated.
    Half,
}

/// What a method provides beyond a step attempt, and so what the simulator and its step
/// control do with it. Every field has one meaning for every method: a new integrator says
/// what it can do here, and no code outside its file names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capabilities {
    /// It integrates a rate-independent adhesion law, whose contact radius is algebraic
    /// (G = w0, no rate ȧ = law⁻¹(G) exists): an explicit method cannot, and a run or `djkr
    /// check` that asks for one on such a law is refused before it starts.
    pub algebraic_radius: bool,
    /// It reports where the contact line turns within a step ([`StepOut::kink`], a fraction of
    /// the step) and predicts the next turning point ([`StepOut::kink_ahead`]); the simulator
    /// redoes a step that straddles one to end on it, and ends the next step on the predicted
    /// one. For a method whose weights lose accuracy on the singular ȧ ∝ |G − w0|^(1/n) inside
    /// a step (DP8: 600× worse than from one side).
    pub turning_points: bool,
    /// Under a steady shaker, the attempts of the last base period that were rejected (or held
    /// down) guide the lengths of the next period's attempts at the same place
    /// (`dynamics/control.rs`). For a method whose difficulty along the period is repeatable and
    /// whose controller would otherwise overshoot it every period anew (DP8's long steps into
    /// the fast healing after a turning point).
    pub period_memory: bool,
    /// How long an attempt may be.
    pub reach: Reach,
}

/// One integration method behind the simulator: a step attempt from a state, and what the
/// simulator needs to know about it ([`Capabilities`]). Adding an integrator is one file that
/// implements this trait beside the method and one line in the registry
/// ([`super::methods::METHODS`]).
pub trait Stepper: Send {
    /// What ran, in full, for the run's report and error messages (e.g. "explicit DP8:
    /// Dormand-Prince 8(5,3), djkr's stepper").
    fn name(&self) -> &'static str;
    /// The name of the method taking the steps as scenario files spell it (a registry name:
    /// "dp8", "implicit", …): what a run's report names when `auto` chose the method.
    fn short_name(&self) -> &'static str;
    /// What the method provides beyond a step attempt.
    fn capabilities(&self) -> Capabilities;
    /// Attempt one step of length `h` from `y` under `drive`, into `out` (the caller's, written
    /// in place: the 248-byte result moved out through every attempt showed as 3 % of the
    /// integration's samples; in place the run is about 1 % faster). `evals` receives the right-hand-side evaluations spent beyond those
    /// [`StepOut::evals`] counts (e.g. a first stage recomputed, or a failed attempt's). On an
    /// error `out` is unspecified.
    #[allow(clippy::too_many_arguments)]
    fn attempt(
        &mut self,
        model: &Model,
        drive: &Drive,
        y: &State,
        h: f64,
        tol: Tol,
        evals: &mut u64,
        out: &mut StepOut,
    ) -> Result<(), StepFail>;
    /// Forget what the stepper carries from one step to the next (the drive or the state changed
    /// discontinuously: stage start, contact formed or lost, shaker switched).
    fn reset(&mut self) {}
    /// A fresh stepper of the same method (nothing carried over), e.g. for trial periods.
    fn fresh(&self) -> Box<dyn Stepper>;
    /// Steps taken by a rescue method where this one could not take them (reported with the
    /// run).
    fn rescues(&self) -> Rescues {
        Rescues::default()
    }
    /// The last successful attempt was taken by a rescue method, not by this stepper's own: its
    /// length and error say nothing of the method's difficulty along the period, so it does not
    /// guide the next period ([`Capabilities::period_memory`]).
    fn rescued_last(&self) -> bool {
        false
    }
    /// The step size is collapsing: hand the next attempts to a more robust method, if there is
    /// one (`false` otherwise, and the run fails with a step-size underflow).
    fn fallback(&mut self) -> bool {
        false
    }
}

/// Steps a [`super::rescue::Rescued`] stepper's rescue took, by cause.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Rescues {
    /// The rescue method's [`Stepper::short_name`] ("" without a rescue).
    pub by: &'static str,
    /// Refused by the primary as too stiff (deep healing).
    pub stiff: u64,
    /// A trial stage of the primary met G ≤ 0.
    pub singular: u64,
    /// Taken after the primary's step size collapsed.
    pub fallback: u64,
}

impl Rescues {
    /// All of them.
    pub fn total(&self) -> u64 {
        self.stiff + self.singular + self.fallback
    }
}
