//! The integrators behind one interface, and the method a scene asks for.

/// Integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Let djkr choose (and report the choice).
    Auto,
    /// Explicit Dormand–Prince 5(4) (`ode_solvers`).
    Dopri5,
    /// Explicit Dormand–Prince 8(5,3) (`ode_solvers`).
    Dop853,
    /// Explicit Dormand–Prince 8(5,3), djkr's own stepper (steps rejected at the healing
    /// singularity, no restarts).
    Dp8,
    /// Implicit, root-solved update of the contact radius (robust at the healing singularity).
    Implicit,
}

/// Whether envelope following may skip periods ([`super::envelope`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvelopeMode {
    /// Where the shaker runs steadily and the error estimate allows.
    Auto,
    /// Never: every period is integrated (a complete time series).
    Off,
}

/// Default of `solver.max_memory`: 2 GiB.
pub const DEFAULT_MAX_MEMORY: u64 = 2 << 30;
/// Smallest `solver.max_memory` accepted: 1 MiB.
pub const MIN_MAX_MEMORY: u64 = 1 << 20;

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solver {
    /// Method.
    pub method: Method,
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance, relative to the natural scale of each state component (dimensionless).
    pub atol: f64,
    /// Maximum number of steps for the whole run.
    pub max_steps: u64,
    /// Wall-clock budget for the whole run (s).
    pub max_wall_s: f64,
    /// Contact events (losses, impacts) for the whole run.
    pub max_events: u64,
    /// Memory a run may hold in samples, events and period records kept in memory (bytes;
    /// `solver.max_memory`, default [`DEFAULT_MAX_MEMORY`]). A run whose sample count is known
    /// up front is refused when its estimate exceeds it; otherwise a run that reaches it stops
    /// with reason `memory`.
    pub max_memory: u64,
    /// Event location tolerance in time (s).
    pub event_tol: f64,
    /// Envelope following.
    pub envelope: EnvelopeMode,
    /// Local error tolerance of an envelope step (scaled, dimensionless).
    pub envelope_tol: f64,
    /// Cancellation from another thread ([`crate::cancel`]); none unless a caller sets one. Not
    /// a scenario key.
    pub cancel: Cancel,
}

impl Default for Solver {
    fn default() -> Self {
        Self {
            method: Method::Auto,
            rtol: 1e-8,
            atol: 1e-10,
            max_steps: 50_000_000,
            max_wall_s: 600.0,
            max_events: 10_000_000,
            max_memory: DEFAULT_MAX_MEMORY,
            event_tol: 1e-12,
            envelope: EnvelopeMode::Auto,
            envelope_tol: 1e-6,
            cancel: Cancel::NONE,
        }
    }
}

use super::dp8;
use super::esdirk;
use super::model::{Drive, Model, NQ};
use super::ode_adapter::{self, OdeMethod};
use super::state::{State, StepFail, StepOut, Tol};
use crate::adhesion::AdhesionLaw;
use crate::cancel::Cancel;
use crate::rig::{ContactFormation, Rig};

/// How the simulator drives a stepper.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepperKind {
    /// One step of an embedded pair, sized by its error estimate (the implicit ESDIRK).
    Embedded,
    /// An explicit high-order method whose accuracy needs its steps to end on the turning points
    /// of the contact line (ȧ ∝ |G − w0|^(1/n) is not smooth there): the simulator ends steps at
    /// the turning points the stepper reports (DP8).
    TurningPoints,
    /// A macro step of an integrator with its own inner step control (`ode_solvers`): kept to
    /// 1/16 of a base period so that events can be located and samples interpolated on it.
    Macro,
}

/// One integration method behind the simulator: a step attempt from a state, and what the
/// simulator needs to know about it. Adding an integrator is one implementation of this trait
/// plus one [`Method`] entry (and its line in [`build`]).
pub trait Stepper: Send {
    /// What ran, for the run's report.
    fn name(&self) -> &'static str;
    /// How the simulator sizes its steps.
    fn kind(&self) -> StepperKind;
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
    /// The step size is collapsing: hand the next attempts to a more robust method, if there is
    /// one (`false` otherwise, and the run fails with a step-size underflow).
    fn fallback(&mut self) -> bool {
        false
    }
}

/// Steps a [`Rescued`] stepper's rescue took, by cause.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Rescues {
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

/// The implicit `ESDIRK4(3)6L[2]SA` with the root-solved contact radius ([`esdirk`]).
#[derive(Debug, Default, Clone, Copy)]
pub struct Implicit;

impl Stepper for Implicit {
    fn fresh(&self) -> Box<dyn Stepper> {
        Box::new(Implicit)
    }
    fn name(&self) -> &'static str {
        "implicit ESDIRK4(3)6L[2]SA (root-solved contact radius)"
    }
    fn kind(&self) -> StepperKind {
        StepperKind::Embedded
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
        *out = esdirk::step(model, drive, y, h, tol)?;
        Ok(())
    }
}

/// djkr's explicit DOP853 ([`dp8`]), with its first-same-as-last evaluation carried from one
/// step to the next.
#[derive(Debug, Default, Clone)]
pub struct Dp8 {
    /// Two slots for the rates at a step's ends and the states they belong to: a step reads its
    /// start from one and writes its end into the other, so they are never moved.
    fsal: [Fsal; 2],
    /// The slot holding the rates at the current state, if any.
    cur: Option<usize>,
    /// Refuse steps in deep healing ([`StepFail::Stiff`]) for a rescue method to take.
    stiffness_switch: bool,
}

/// |∂ȧ/∂a| h beyond which DP8 hands a healing step to the implicit method. DOP853's stability
/// interval on the negative real axis reaches about −6; at the switch the explicit steps are
/// stability-limited, not accuracy-limited, and in deep healing (G ≈ 1e-6 w0, ∂ȧ/∂a ≈ −1e13/s)
/// they would fall below what the time resolves late in a long run (h < 8 ε t).
pub const DP8_STIFFNESS_LIMIT: f64 = 3.0;

/// The rates and quadrature integrands at the end of DP8's last step, with what identifies the
/// state they belong to (kept small: the cache is written on every step).
#[derive(Debug, Clone, Default)]
struct Fsal {
    t: f64,
    x: f64,
    v: f64,
    a: f64,
    contact: bool,
    rates: dp8::Rates,
    fq: [f64; NQ],
}

impl Fsal {
    /// Label the rates held as those at `y`.
    fn label(&mut self, y: &State) {
        self.t = y.t;
        self.x = y.x;
        self.v = y.v;
        self.a = y.a;
        self.contact = y.contact;
    }

    /// True for the very state the rates belong to (an identity test, hence bitwise; the time
    /// to a few ulp, as a step's end time is recomputed).
    fn belongs_to(&self, y: &State) -> bool {
        let same = |p: f64, q: f64| p.to_bits() == q.to_bits();
        (self.t - y.t).abs() <= 8.0 * f64::EPSILON * y.t.abs()
            && same(self.x, y.x)
            && same(self.v, y.v)
            && same(self.a, y.a)
            && self.contact == y.contact
    }
}

impl Dp8 {
    /// DP8 that refuses deep-healing steps (for [`Rescued`]): `attempt` fails with
    /// [`StepFail::Stiff`] where |∂ȧ/∂a| h > [`DP8_STIFFNESS_LIMIT`] at the step's start.
    pub fn with_stiffness_switch() -> Self {
        Self {
            stiffness_switch: true,
            ..Self::default()
        }
    }
}

impl Stepper for Dp8 {
    fn fresh(&self) -> Box<dyn Stepper> {
        Box::new(Dp8 {
            stiffness_switch: self.stiffness_switch,
            ..Dp8::default()
        })
    }
    fn name(&self) -> &'static str {
        "explicit DP8: Dormand-Prince 8(5,3), djkr's stepper"
    }
    fn kind(&self) -> StepperKind {
        StepperKind::TurningPoints
    }
    fn attempt(
        &mut self,
        model: &Model,
        drive: &Drive,
        y: &State,
        h: f64,
        tol: Tol,
        evals: &mut u64,
        out: &mut StepOut,
    ) -> Result<(), StepFail> {
        let mut extra = 0;
        let cur = match self.cur {
            Some(c) if self.fsal[c].belongs_to(y) => c,
            _ => {
                extra = 1;
                match dp8::rates_at(model, drive, y) {
                    Ok((rates, fq)) => {
                        let f = &mut self.fsal[0];
                        (f.rates, f.fq) = (rates, fq);
                        f.label(y);
                        self.cur = Some(0);
                        0
                    }
                    Err(e) => {
                        self.cur = None;
                        *evals += extra;
                        return Err(e);
                    }
                }
            }
        };
        // The step's start from slot `cur`, its end into the other.
        let (lo, hi) = self.fsal.split_at_mut(1);
        let (start, end) = if cur == 0 {
            (&lo[0], &mut hi[0])
        } else {
            (&hi[0], &mut lo[0])
        };
        let result = if self.stiffness_switch
            && y.contact
            && model.healing_stiffness(y.a, start.rates.g, start.rates.fa) * h > DP8_STIFFNESS_LIMIT
        {
            Err(StepFail::Stiff)
        } else {
            dp8::step(
                model,
                drive,
                y,
                &start.rates,
                &start.fq,
                h,
                tol,
                out,
                &mut end.rates,
                &mut end.fq,
            )
        };
        match result {
            Ok(()) => {
                out.evals += extra;
                end.label(&out.y);
                self.cur = Some(1 - cur);
                Ok(())
            }
            Err(e) => {
                // A failed attempt is retried from the same state with a shorter step (the
                // rates at y stay in their slot).
                *evals += extra;
                Err(e)
            }
        }
    }
    fn reset(&mut self) {
        self.cur = None;
    }
}

/// A fast method with a robust one for the steps it cannot take: where the primary refuses a
/// step in deep healing ([`StepFail::Stiff`]) or a trial stage meets the healing singularity
/// (G ≤ 0: ȧ = +∞, [`StepFail::Singular`]), that one step is taken by the rescue; the next step
/// tries the primary again. After [`Stepper::fallback`] the rescue takes every attempt for a
/// while. `auto` runs DP8 rescued by the implicit method.
#[derive(Debug, Default, Clone)]
pub struct Rescued<P, R> {
    primary: P,
    rescue: R,
    /// Steps the primary refused as too stiff.
    stiff: u64,
    /// Steps where a trial stage of the primary met G ≤ 0.
    singular: u64,
    /// Attempts still to be taken by the rescue after a fallback.
    forced: u32,
    /// Attempts taken by the rescue after fallbacks.
    fallbacks: u64,
}

/// Attempts the rescue takes after a [`Stepper::fallback`].
const FALLBACK_ATTEMPTS: u32 = 64;

impl<P: Stepper, R: Stepper> Rescued<P, R> {
    /// `primary`, falling back to `rescue`.
    pub fn new(primary: P, rescue: R) -> Self {
        Self {
            primary,
            rescue,
            stiff: 0,
            singular: 0,
            forced: 0,
            fallbacks: 0,
        }
    }
}

impl<P: Stepper + Clone + 'static, R: Stepper + Clone + 'static> Stepper for Rescued<P, R> {
    fn fresh(&self) -> Box<dyn Stepper> {
        let mut p = self.primary.clone();
        let mut r = self.rescue.clone();
        p.reset();
        r.reset();
        Box::new(Rescued::new(p, r))
    }
    fn name(&self) -> &'static str {
        self.primary.name()
    }
    fn kind(&self) -> StepperKind {
        self.primary.kind()
    }
    fn attempt(
        &mut self,
        model: &Model,
        drive: &Drive,
        y: &State,
        h: f64,
        tol: Tol,
        evals: &mut u64,
        out: &mut StepOut,
    ) -> Result<(), StepFail> {
        if self.forced > 0 {
            self.forced -= 1;
            self.fallbacks += 1;
            return self.rescue.attempt(model, drive, y, h, tol, evals, out);
        }
        match self.primary.attempt(model, drive, y, h, tol, evals, out) {
            Err(StepFail::Singular) => {
                self.singular += 1;
                self.rescue.attempt(model, drive, y, h, tol, evals, out)
            }
            Err(StepFail::Stiff) => {
                self.stiff += 1;
                self.rescue.attempt(model, drive, y, h, tol, evals, out)
            }
            r => r,
        }
    }
    fn reset(&mut self) {
        self.primary.reset();
        self.rescue.reset();
    }
    fn rescues(&self) -> Rescues {
        Rescues {
            stiff: self.stiff,
            singular: self.singular,
            fallback: self.fallbacks,
        }
    }
    fn fallback(&mut self) -> bool {
        if self.forced > 0 {
            // Already on the rescue: it failed too.
            return false;
        }
        self.forced = FALLBACK_ATTEMPTS;
        true
    }
}

/// `ode_solvers`' Dopri5 or Dop853 as a macro-step engine ([`ode_adapter`]).
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
    fn kind(&self) -> StepperKind {
        StepperKind::Macro
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
        let (o, hi) = ode_adapter::macro_step(model, drive, y, h, tol, self.method, self.h_inner)?;
        self.h_inner = hi;
        *out = o;
        Ok(())
    }
}

/// The `auto` rule, from measurements per scene type (`docs/studies/methods.md`, regenerated by
/// `cargo run --release --example study_methods -- --full`; `docs/accuracy/`; the extremes
/// matrix, `docs/extremes.md`):
/// - **implicit** for a rate-independent law (a is algebraic: ȧ = law⁻¹(G) does not exist) and
///   for contact formed from a seed (healing from G ≈ 0 at ȧ ≈ ∞ after every impact: DP8 runs
///   it, but no faster);
/// - **implicit** without inertia (rigid link, m = 0: only a is integrated). There the two
///   methods trade places: DP8 is faster on a slow GS unload and slower under a 400 Hz base,
///   its reduced right-hand side solving the position twice (on 2026-11-24: 0.58–0.66 of the
///   implicit wall time on the unloads at 0.1 µm/s, 1.38× under a 2 µm base); all are
///   sub-millisecond and within 1e-6 of the converged result at rtol 1e-8, so the simpler rule
///   stays;
/// - **DP8** otherwise, several times faster than the implicit method at equal accuracy on the
///   scenes with inertia, taking single steps implicitly where a DP8 stage meets G ≤ 0 or the
///   contact heals so deeply that DP8's steps would be stability-limited ([`Rescued`]).
pub fn auto_method(rig: &Rig) -> Method {
    if rig.law.is_rate_independent()
        || matches!(rig.formation, ContactFormation::Seed(_))
        || !rig.has_inertia()
    {
        Method::Implicit
    } else {
        Method::Dp8
    }
}

/// The stepper for a method on a rig (`auto` resolved by [`auto_method`]).
pub fn build(method: Method, rig: &Rig) -> Box<dyn Stepper> {
    match method {
        Method::Auto => match auto_method(rig) {
            Method::Dp8 => Box::new(Rescued::new(Dp8::with_stiffness_switch(), Implicit)),
            _ => Box::new(Implicit),
        },
        Method::Implicit => Box::new(Implicit),
        Method::Dp8 => Box::new(Dp8::default()),
        Method::Dopri5 => Box::new(OdeSolvers::new(OdeMethod::Dopri5)),
        Method::Dop853 => Box::new(OdeSolvers::new(OdeMethod::Dop853)),
    }
}

/// Every method, in the order files and flags list them.
pub const METHODS: [Method; 5] = [
    Method::Auto,
    Method::Dp8,
    Method::Dopri5,
    Method::Dop853,
    Method::Implicit,
];

/// The names of [`METHODS`] as scenario files (`[solver] method`) and flags (`--methods`)
/// spell them: the one mapping between methods and names.
pub const METHOD_NAMES: [&str; 5] = ["auto", "dp8", "dopri5", "dop853", "implicit"];

/// The name of a method ([`METHOD_NAMES`]).
pub fn method_name(m: Method) -> &'static str {
    let i = METHODS.iter().position(|x| *x == m).unwrap_or(0);
    METHOD_NAMES[i]
}

/// The method of a name; `None` for an unknown name.
pub fn method_from_name(name: &str) -> Option<Method> {
    METHOD_NAMES
        .iter()
        .position(|n| *n == name)
        .map(|i| METHODS[i])
}
