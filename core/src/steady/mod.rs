//! Periodic steady state of the vibrating contact, found fast, and what it is compared with.
//!
//! # The one-cycle map
//! With the shaker on at frequency f and the spring end held still, the time-domain model
//! (eqs. 30–32, [`crate::dynamics`]) is periodic in time with period T = 1/f. Its stroboscopic
//! (once-per-cycle) map P takes the state at phase 0 to the state one period later:
//! P(y0) = end state of a hold stage of exactly T started from `Initial::State` y0 with the
//! vibration on (the shaker starts at phase 0 at the stage start, so every call starts at phase
//! 0). A periodic steady state is a fixed point y* = P(y*). The state y = (x_s, v_s, a) carries
//! the spring end x_k along unchanged; ȧ is not an unknown: it is the rate the law gives for the
//! state, ȧ = w⁻¹(G(a, δ)) with δ = x_s at phase 0 (x_b = 0), recomputed for every start so that
//! every call of P sees a consistent state (the implicit integrator uses it as its first stage).
//! Reduced models drop unknowns: with a rate-independent law a is algebraic (the JKR radius at
//! w0 for δ = x_s, stable branch) and ȧ = δ̇/δ_eq'(a); with m = 0 or a rigid link x_s is not a
//! state (the driver recomputes it), only a is.
//!
//! # Shooting ([`Problem::shoot`])
//! Newton on P(y) − y = 0 in scaled unknowns: x_s by a length L, v_s by ωL, a by a_m, where L is
//! the larger of X_b and the first harmonic |δ1| of the first cycle computed (fixed for the
//! solve). The Jacobian of P is by forward finite differences (one extra period per unknown,
//! step `fd_step` in scaled units), the periods integrated at a tight tolerance (`rtol`, default
//! 1e-10) so the differences are meaningful.
//!
//! The creeping contact radius makes P − I nearly singular (its slow eigenvalue 1 − ρ is ~1e-3
//! on the bundled resonance scene, and → 0 at the fold of a nonlinear resonance): the fixed
//! point can be far along that direction while the residual is small, and a full Newton step
//! along it raises the residual through the curvature of P. Hence:
//! - the step is damped (λ = 1, ½, ¼, …) by Deuflhard's *natural monotonicity* test, which is
//!   affine invariant: accept when the simplified correction at the trial point,
//!   ‖(J − I)⁻¹ r(y + λΔ)‖ with the same Jacobian, is ≤ (1 − λ/4)‖Δ‖. A residual test refuses
//!   exactly the long steps along the slow direction that are needed (measured when this test
//!   was chosen, against the residual test that no longer exists: 40 iterations instead of 8
//!   past the fold at 427 Hz, X_b = 1 µm);
//! - converged when the residual ‖P(y) − y‖∞ < `tol` **and** the Newton correction (the
//!   estimated distance to the fixed point, reported as [`Steady::distance`]) < `tol`.
//!
//! Shooting gives up when a period contains a contact loss or an impact (P is then not smooth),
//! the contact is open at phase 0, the damped step finds no acceptable λ, or `max_newton`
//! iterations pass.
//!
//! # Auto: shooting, then time-stepping chunks ([`Problem::solve`])
//! When shooting fails, time-stepping runs a chunk of 64 periods (then 128, … up to 4096),
//! after which shooting is tried again from the chunk's end, until one of them converges or
//! `max_cycles` periods are spent. A sweep that jumps off the end of a branch thus integrates
//! the transient only until Newton can take over.
//!
//! # Time-stepping with stroboscopic detection ([`Problem::time_step`])
//! One long hold (at most `max_cycles` periods, same tolerance), watched by an observer that
//! takes the end state of every period. The successive differences d_k = ‖y_k − y_{k−1}‖∞
//! (scaled as above) decay like ρ^k near a stable orbit; ρ is estimated over the last ten
//! cycles, ρ = (d_k/d_{k−10})^{1/10} (a geometric mean, robust to the rotation of a lightly
//! damped ring-down), and the distance to the orbit is estimated as d_k ρ/(1 − ρ) (the tail of
//! the geometric series). Converged when that estimate (or d_k itself, when it is already below
//! tol/100, the integration-noise regime where ρ is meaningless) stays below `tol` for
//! `consecutive` periods in a row. A plain "d_k < tol" is not enough here: the Gent–Schultz law
//! is flat near G = w0, so the mean contact radius creeps with ρ very close to 1 and a small d_k
//! can sit far from the orbit.
//!
//! # Cycle averages
//! Means and first harmonics of δ, a, F and the spring force of the steady cycle come from the
//! quadratures integrated with the solution ([`crate::dynamics::CycleRecord`]), not from output
//! samples.
//!
//! Submodules: [`crosscheck`] (the time-domain steady state side by side with the imposed-area
//! method, the linear transfer, the paper's printed eqs. (37)–(39) and harmonic balance),
//! [`sweep`] (frequency response with continuation, up and down), [`map`] (where the
//! imposed-area shortcut holds, over a frequency × amplitude grid).

pub mod crosscheck;
pub mod map;

pub mod sweep;

use crate::adhesion::AdhesionLaw;
use crate::dynamics::model::{self, Model, RunScales};
use crate::dynamics::protocol::{self, Initial, Plan};
use crate::dynamics::{
    methods, CycleRecord, EventKind, Sample, Settings, SimError, Simulator, Solver, Stop,
};
use crate::jkr;
use crate::rig::{BaseMotion, Rig};
use serde::Serialize;
use std::f64::consts::PI;
use std::time::Instant;
use thiserror::Error;

/// Why no steady state could be computed.
#[derive(Debug, Error)]
pub enum SteadyError {
    /// The scenario or an argument cannot describe a periodic steady state.
    #[error("steady state: {0}")]
    Setup(String),
    /// A time-domain run failed.
    #[error("steady state: time-domain run failed: {0}")]
    Sim(#[from] SimError),
    /// Time-stepping reached its cycle budget before the stroboscopic test passed.
    #[error(
        "steady state: not reached within {cycles} cycles (last stroboscopic change {residual:e}, \
         estimated distance to the orbit {estimate:e}, tolerance {tol:e}){reason}"
    )]
    NotConverged {
        /// Periods integrated.
        cycles: u64,
        /// Last scaled change of the once-per-cycle state.
        residual: f64,
        /// Last estimated scaled distance to the periodic orbit.
        estimate: f64,
        /// The tolerance asked for.
        tol: f64,
        /// Why shooting was not used, when it was tried first (starts with "; ").
        reason: String,
    },
}

/// How the steady state was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SteadyMethod {
    /// Newton on the one-cycle map.
    Shooting,
    /// Plain time-stepping with stroboscopic detection.
    TimeStepping,
}

impl SteadyMethod {
    /// The name used in JSON and tables: "shooting" or "time-stepping".
    pub fn name(self) -> &'static str {
        match self {
            SteadyMethod::Shooting => "shooting",
            SteadyMethod::TimeStepping => "time-stepping",
        }
    }
}

/// Which methods [`Problem::solve`] may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Shooting; when it fails, chunks of time-stepping, each followed by a new shooting attempt.
    #[default]
    Auto,
    /// Shooting only (an error when it fails).
    Shooting,
    /// Time-stepping only.
    TimeStepping,
}

/// Settings of the steady-state search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Tolerance on the scaled once-per-cycle residual (dimensionless; default 1e-8).
    pub tol: f64,
    /// Relative tolerance of the time integration (overrides the scenario's; default 1e-10).
    pub rtol: f64,
    /// Finite-difference step of the shooting Jacobian, in scaled units (default 1e-6).
    pub fd_step: f64,
    /// Newton iterations before shooting gives up (default 20).
    pub max_newton: usize,
    /// Periods of time-stepping before giving up (default 20 000).
    pub max_cycles: u64,
    /// Consecutive periods the stroboscopic test must pass (default 3).
    pub consecutive: usize,
    /// Which methods to use.
    pub strategy: Strategy,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            tol: 1e-8,
            rtol: 1e-10,
            fd_step: 1e-6,
            max_newton: 20,
            max_cycles: 20_000,
            consecutive: 3,
            strategy: Strategy::Auto,
        }
    }
}

impl Options {
    fn validate(&self) -> Result<(), SteadyError> {
        let bad = |what: &str, v: String, allowed: &str| {
            Err(SteadyError::Setup(format!("{what} = {v}: {allowed}")))
        };
        if !(self.tol.is_finite() && self.tol > 0.0 && self.tol < 1.0) {
            return bad("tol", self.tol.to_string(), "must be in (0, 1)");
        }
        if !(self.rtol.is_finite() && self.rtol > 0.0 && self.rtol < 1.0) {
            return bad("rtol", self.rtol.to_string(), "must be in (0, 1)");
        }
        if !(self.fd_step.is_finite() && self.fd_step > 0.0 && self.fd_step < 1.0) {
            return bad("fd_step", self.fd_step.to_string(), "must be in (0, 1)");
        }
        if self.max_cycles == 0 {
            return bad("max_cycles", "0".into(), "must be >= 1");
        }
        if self.consecutive == 0 {
            return bad("consecutive", "0".into(), "must be >= 1");
        }
        Ok(())
    }
}

/// The state at phase 0 of the base motion (the start of a cycle), SI.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OrbitState {
    /// Sphere position x_s (m, down +).
    pub x_s: f64,
    /// Sphere velocity v_s (m/s, down +).
    pub v_s: f64,
    /// Contact radius a (m; 0 out of contact).
    pub a: f64,
    /// Contact-radius rate ȧ (m/s), consistent with the state.
    pub a_dot: f64,
    /// Spring-end position x_k (m, down +).
    pub x_k: f64,
}

impl OrbitState {
    /// From a simulator sample.
    pub fn from_sample(s: &Sample) -> Self {
        Self {
            x_s: s.x_s,
            v_s: s.v_s,
            a: s.a,
            a_dot: s.a_dot,
            x_k: s.x_k,
        }
    }

    /// As a scenario's initial state.
    pub fn initial(&self) -> Initial {
        Initial::State {
            x_s: self.x_s,
            v_s: self.v_s,
            a: self.a,
            a_dot: self.a_dot,
            x_k: self.x_k,
        }
    }

    fn vector(&self) -> [f64; 3] {
        [self.x_s, self.v_s, self.a]
    }
}

/// A periodic steady state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Steady {
    /// How it was found.
    pub method: SteadyMethod,
    /// Base frequency f (Hz).
    pub frequency: f64,
    /// Base amplitude X_b (m).
    pub amplitude: f64,
    /// The state at the start of the steady cycle (phase 0).
    pub state: OrbitState,
    /// Exact averages and first harmonics over the steady cycle.
    pub cycle: CycleRecord,
    /// Scaled once-per-cycle residual at the end: ‖P(y) − y‖∞ for shooting, the last successive
    /// change for time-stepping.
    pub residual: f64,
    /// Estimated scaled distance to the periodic orbit: the residual for shooting (Newton
    /// converges quadratically), d ρ/(1 − ρ) for time-stepping.
    pub distance: f64,
    /// Base periods integrated in total (shooting: trial and finite-difference periods included;
    /// a failed shooting attempt before a fallback included).
    pub cycles: u64,
    /// Newton iterations (0 for time-stepping).
    pub newton_iterations: usize,
    /// The steady cycle contains a contact loss or impact.
    pub contact_lost: bool,
    /// Wall-clock time (s).
    pub wall_s: f64,
    /// Scales used for the residual: length L (m), speed ωL (m/s), radius (m).
    pub scales: [f64; 3],
}

impl Steady {
    /// First-harmonic amplitude of the indentation |δ1| = hypot(δ_s, δ_c) (m).
    pub fn delta_amp(&self) -> f64 {
        self.cycle.delta_sin.hypot(self.cycle.delta_cos)
    }
    /// First-harmonic amplitude of the contact radius a_A = hypot(a_s, a_c) (m).
    pub fn a_amp(&self) -> f64 {
        self.cycle.a_sin.hypot(self.cycle.a_cos)
    }
    /// |δ1| / X_b (0 when X_b = 0).
    pub fn transfer_magnitude(&self) -> f64 {
        if self.amplitude > 0.0 {
            self.delta_amp() / self.amplitude
        } else {
            0.0
        }
    }
    /// Phase φ (rad) of δ1 with δ − δ_m ≈ |δ1| sin(ωt + φ).
    pub fn transfer_phase(&self) -> f64 {
        self.cycle.delta_cos.atan2(self.cycle.delta_sin)
    }
}

/// Which components of (x_s, v_s, a) are unknowns of the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Unknowns {
    /// x_s and v_s are states (m > 0 with a spring or no holder).
    mechanics: bool,
    /// a is a state (rate-dependent law).
    radius: bool,
}

impl Unknowns {
    fn indices(&self) -> Vec<usize> {
        let mut v = Vec::with_capacity(3);
        if self.mechanics {
            v.extend([0, 1]);
        }
        if self.radius {
            v.push(2);
        }
        v
    }
}

/// A steady-state problem: a rig shaken at one frequency and amplitude with the spring end held
/// still, and the solver that integrates its one-period map.
#[derive(Debug, Clone)]
pub struct Problem {
    /// The rig, its base at this problem's frequency and amplitude.
    rig: Rig,
    /// The rig's model, resolved once.
    model: Model,
    /// Method, tolerances and budgets of the time integration (the tolerance `rtol` is set per
    /// call by [`Options::rtol`]).
    solver: Solver,
    /// Base frequency f (Hz).
    pub frequency: f64,
    /// Base amplitude X_b (m).
    pub amplitude: f64,
    unknowns: Unknowns,
}

/// Whole base periods run from a state ([`Problem::run_periods`]).
#[derive(Debug, Clone)]
pub struct PeriodRun {
    /// The state at the end.
    pub end: Sample,
    /// The record of every period completed, in order (only the last one is kept when the
    /// watcher keeps nothing: see [`Problem::run_periods`]).
    pub last: Option<CycleRecord>,
    /// Periods completed.
    pub periods: u64,
    /// Contact losses and impacts (kind, time).
    pub events: Vec<(EventKind, f64)>,
}

impl PeriodRun {
    /// Why these periods are not a smooth map: contact lost or formed within them, or the
    /// contact open at the end.
    pub fn rough(&self) -> Option<String> {
        if let Some((kind, t)) = self.events.first() {
            return Some(format!("{kind:?} at t = {t:.6e} s within the period"));
        }
        if self.end.a <= 0.0 {
            return Some("contact open at phase 0".into());
        }
        None
    }
}

impl Problem {
    /// The rig shaken at `frequency` (Hz, > 0) with amplitude `amplitude` (m, ≥ 0), the spring
    /// end held still, integrated with `solver` (its `rtol` is replaced per call). The rig's own
    /// base section is ignored.
    pub fn new(
        rig: &Rig,
        solver: Solver,
        frequency: f64,
        amplitude: f64,
    ) -> Result<Problem, SteadyError> {
        if !(frequency.is_finite() && frequency > 0.0) {
            return Err(SteadyError::Setup(format!(
                "frequency = {frequency} Hz: must be finite and > 0"
            )));
        }
        if !(amplitude.is_finite() && amplitude >= 0.0) {
            return Err(SteadyError::Setup(format!(
                "base amplitude = {amplitude} m: must be finite and >= 0"
            )));
        }
        let mut rig = rig.clone();
        rig.base = Some(BaseMotion {
            amplitude,
            frequency,
            phase: 0.0,
        });
        let model = model::resolve(&rig, RunScales::default()).map_err(SteadyError::Setup)?;
        let unknowns = Unknowns {
            mechanics: rig.has_inertia(),
            radius: !rig.law.is_rate_independent(),
        };
        Ok(Problem {
            rig,
            model,
            solver,
            frequency,
            amplitude,
            unknowns,
        })
    }

    /// The steady-state problem a protocol describes, and where to start: the first stage with
    /// the vibration on, at the rig's base amplitude and frequency, with the spring end held
    /// where that stage starts. The stages before it (shaker off: approach, dwell) are run first,
    /// and their end state is the start; without such stages the start is the initial state. A
    /// moving spring end during the vibrating stage (approach, unload) has no periodic steady
    /// state: it is held at its position at the stage start.
    pub fn from_plan(plan: &Plan) -> Result<(Problem, Initial), SteadyError> {
        let base = plan.rig.base.ok_or_else(|| {
            SteadyError::Setup(
                "no [base] section: nothing vibrates, no periodic steady state".into(),
            )
        })?;
        let mut on = false;
        let mut first = None;
        for (i, st) in plan.stages.iter().enumerate() {
            if let Some(v) = st.vibration {
                on = v;
            }
            if on {
                first = Some(i);
                break;
            }
        }
        let i = first.ok_or_else(|| {
            SteadyError::Setup("no stage switches the shaker on (vibration = true)".into())
        })?;
        let problem = Problem::new(plan.rig, plan.solver, base.frequency, base.amplitude)?;
        if i == 0 {
            return Ok((problem, plan.initial));
        }
        let pre = Plan {
            stages: &plan.stages[..i],
            sample_rate: 0.0,
            ..*plan
        };
        let r = crate::dynamics::run(&pre, &mut crate::dynamics::NoObserver)?;
        if r.detached {
            return Err(SteadyError::Setup(format!(
                "the sphere detached before the first vibrating stage (stage {})",
                i + 1
            )));
        }
        Ok((problem, OrbitState::from_sample(&r.final_state).initial()))
    }

    /// The same rig at another frequency (Hz) and base amplitude (m).
    pub fn at(&self, frequency: f64, amplitude: f64) -> Result<Problem, SteadyError> {
        Problem::new(&self.rig, self.solver, frequency, amplitude)
    }

    /// The cancellation token of its solver settings ([`crate::cancel`]).
    pub fn cancel(&self) -> crate::cancel::Cancel {
        self.solver.cancel
    }

    /// The rig (its base at this problem's frequency and amplitude).
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// Which of (x_s, v_s, a) (indices 0, 1, 2) are unknowns of the one-period map: x_s and v_s
    /// when the sphere has inertia, a when the law is rate-dependent (module doc).
    pub fn unknown_indices(&self) -> Vec<usize> {
        self.unknowns.indices()
    }

    /// Angular frequency ω = 2πf (rad/s).
    pub fn omega(&self) -> f64 {
        2.0 * PI * self.frequency
    }

    /// A simulator at `start` (phase 0, the shaker on from now, the spring end held still),
    /// integrating at tolerance `rtol` with this problem's method and budgets: what
    /// [`run_periods`](Self::run_periods) steps, for callers that drive the steps themselves
    /// (continuation replays a period's step sequence from perturbed starts).
    pub fn simulator(&self, start: &Initial, rtol: f64) -> Result<Simulator, SimError> {
        let (y, mut drive) = protocol::initial_state(&self.rig, start, &self.model)?;
        drive.shaker = true;
        drive.t_on = y.t;
        let mut settings = Settings::from(&self.solver);
        settings.tol.rtol = rtol;
        let stepper = methods::build(self.solver.method, &self.rig);
        Ok(Simulator::new(
            self.model.clone(),
            stepper,
            self.rig.formation,
            settings,
            y,
            drive,
        ))
    }

    /// Run `periods` base periods from `start` (at phase 0) with integration tolerance `rtol`.
    /// `watch` sees the end state and record of every completed period and may stop the run
    /// early by returning `false`.
    pub fn run_periods(
        &self,
        start: &Initial,
        periods: u64,
        rtol: f64,
        mut watch: impl FnMut(&Sample, &CycleRecord) -> bool,
    ) -> Result<PeriodRun, SimError> {
        let mut sim = self.simulator(start, rtol)?;
        let y = *sim.state();
        // The simulator records the last base-period boundary (k·2π/ω) even when rounding puts
        // it a sliver after the stop time (periods / f).
        sim.advance_to(y.t + periods as f64 / self.frequency, None);
        let mut run = PeriodRun {
            end: sim.sample_of(&y, 0),
            last: None,
            periods: 0,
            events: Vec::new(),
        };
        loop {
            let (period, reached) = match sim.step()? {
                Stop::Step { period, reached } => (period, reached),
                Stop::Event(kind, ye) => {
                    if matches!(kind, EventKind::ContactLoss | EventKind::Impact) {
                        run.events.push((kind, ye.t));
                    }
                    (None, false)
                }
                Stop::Kick => (None, false),
                Stop::Period(rec) => (Some(rec), false),
                Stop::Reached => (None, true),
            };
            if let Some(rec) = period {
                run.periods += 1;
                run.last = Some(*rec);
                let end = sim.sample_of(sim.state(), 0);
                if !watch(&end, &rec) {
                    run.end = end;
                    return Ok(run);
                }
            }
            if reached {
                run.end = sim.sample_of(sim.state(), 0);
                return Ok(run);
            }
        }
    }

    /// A start state consistent with the model: ȧ from the law for (a, δ = x_s) (x_b = 0 at phase
    /// 0); with a rate-independent law a itself is the JKR radius at w0 for δ. `None` when the
    /// law gives no finite rate (a compressive edge under a Gent–Schultz law heals at an
    /// unbounded rate).
    pub fn consistent(&self, x_s: f64, v_s: f64, a: f64, x_k: f64) -> Option<OrbitState> {
        let m = &self.rig.material;
        let law = &self.rig.law;
        if !(x_s.is_finite() && v_s.is_finite() && a.is_finite() && x_k.is_finite()) {
            return None;
        }
        if a <= 0.0 {
            return Some(OrbitState {
                x_s,
                v_s,
                a: 0.0,
                a_dot: 0.0,
                x_k,
            });
        }
        let (a, a_dot) = if law.is_rate_independent() {
            let w = law.w0();
            let ae = jkr::equilibrium_radius_for_indentation(m, x_s, w)?;
            let ddelta = v_s + self.amplitude * self.omega();
            let slope = 2.0 * ae / m.r - 0.5 * jkr::equilibrium_edge_opening(m, ae, w) / ae;
            (ae, ddelta / slope)
        } else {
            let g = jkr::signed_energy_release_rate(m, a, x_s);
            (a, law.crack_speed(g))
        };
        (a.is_finite() && a_dot.is_finite()).then_some(OrbitState {
            x_s,
            v_s,
            a,
            a_dot,
            x_k,
        })
    }

    /// The residual scales (L, ωL, a) from a cycle record.
    pub fn scales(&self, c: &CycleRecord) -> [f64; 3] {
        let m = &self.rig.material;
        let a_j = jkr::jump_in_radius(m, self.rig.law.w0());
        let floor = 1e-6 * a_j * a_j / m.r;
        let l = c
            .delta_sin
            .hypot(c.delta_cos)
            .max(self.amplitude)
            .max(floor);
        [l, self.omega() * l, c.a_mean.max(1e-3 * a_j)]
    }

    /// Find the periodic steady state from `start` (any initial state) by the configured
    /// strategy: shooting first, then time-stepping when shooting fails (the reason is kept in
    /// the error if time-stepping fails too).
    pub fn solve(&self, start: &Initial, opts: &Options) -> Result<Steady, SteadyError> {
        opts.validate()?;
        match opts.strategy {
            Strategy::TimeStepping => self.time_step(start, opts, 0, ""),
            Strategy::Shooting => self.shoot(start, opts).map_err(|f| match f.error {
                Some(e) => e,
                None => SteadyError::Setup(format!("shooting failed: {}", f.reason)),
            }),
            Strategy::Auto => self.hybrid(start, opts),
        }
    }

    /// Shooting, and when it fails, time-stepping in chunks of 64, 128, … (at most 4096)
    /// periods, each followed by a new shooting attempt from where the chunk ended, until one of
    /// them converges or `max_cycles` periods are spent. A transient far from the orbit (a jump
    /// off the end of a branch in a sweep) is thus integrated only until Newton can take over,
    /// instead of through the slow creep of the mean contact radius.
    fn hybrid(&self, start: &Initial, opts: &Options) -> Result<Steady, SteadyError> {
        let t0 = Instant::now();
        let mut spent = 0u64;
        let mut from = *start;
        let mut chunk = 64u64;
        let mut reason;
        let (mut d, mut est) = (f64::NAN, f64::NAN);
        loop {
            match self.shoot(&from, opts) {
                Ok(mut s) => {
                    s.cycles += spent;
                    s.wall_s = t0.elapsed().as_secs_f64();
                    return Ok(s);
                }
                Err(f) => {
                    if let Some(e @ SteadyError::Setup(_)) = f.error {
                        return Err(e);
                    }
                    spent += f.cycles;
                    reason = f.reason;
                    if let Some(l) = f.last {
                        from = l.initial();
                    }
                }
            }
            if spent >= opts.max_cycles {
                break;
            }
            let n = chunk.min(opts.max_cycles - spent);
            let run = self.stroboscopic(&from, opts, n)?;
            spent += run.cycles;
            if let Some(mut s) = run.steady {
                s.cycles = spent;
                s.wall_s = t0.elapsed().as_secs_f64();
                return Ok(s);
            }
            if let Some(l) = run.last {
                from = l.initial();
            }
            (d, est) = (run.residual, run.estimate);
            if spent >= opts.max_cycles {
                break;
            }
            chunk = (2 * chunk).min(4096);
        }
        Err(SteadyError::NotConverged {
            cycles: spent,
            residual: d,
            estimate: est,
            tol: opts.tol,
            reason: format!("; shooting failed last with: {reason}"),
        })
    }

    /// One period of the map from `start`.
    fn map_once(&self, start: &Initial, rtol: f64) -> Result<PeriodRun, SimError> {
        self.run_periods(start, 1, rtol, |_, _| true)
    }

    /// Newton on the one-cycle map (module doc). On failure returns why, the periods spent and
    /// the last state reached (a better start for time-stepping than the original one).
    pub fn shoot(&self, start: &Initial, opts: &Options) -> Result<Steady, Box<ShootFailure>> {
        opts.validate().map_err(ShootFailure::setup)?;
        let mut sh = Shooting {
            problem: self,
            opts,
            t0: Instant::now(),
            spent: 0,
            idx: self.unknowns.indices(),
            sc: [f64::NAN; 3],
        };
        let (mut y, mut py) = sh.first_iterate(start)?;
        // The Jacobian of P − I of the latest Newton iteration (scaled units).
        let mut jac: Option<Vec<Vec<f64>>> = None;
        for iter in 0..=opts.max_newton {
            if let Some(why) = py.rough() {
                return Err(sh.fail(why, Some(y)));
            }
            let r = sh.residual(&y, &py.end);
            let res = norm(&r);
            let Some(cycle) = py.last else {
                return Err(sh.fail("no cycle record".into(), Some(y)));
            };
            if !res.is_finite() {
                return Err(sh.fail("non-finite residual".into(), Some(y)));
            }
            let done = |sh: &Shooting, dist: f64| sh.done(y, cycle, res, dist, iter);
            if sh.idx.is_empty() {
                return Ok(done(&sh, res));
            }
            // Distance to the fixed point: the (simplified) Newton correction −(J − I)⁻¹ r,
            // which near a slow direction of the map (ρ → 1) is much larger than the residual.
            let neg: Vec<f64> = r.iter().map(|x| -x).collect();
            if res < opts.tol {
                if let Some(dist) = jac
                    .clone()
                    .and_then(|m| solve_dense(m, neg.clone()))
                    .map(|d| norm(&d))
                {
                    if dist < opts.tol {
                        return Ok(done(&sh, dist));
                    }
                }
            }
            if iter == opts.max_newton {
                break;
            }
            let m = sh.jacobian(&y, &r)?;
            jac = Some(m.clone());
            let Some(step) = solve_dense(m.clone(), neg) else {
                return Err(sh.fail("singular shooting Jacobian".into(), Some(y)));
            };
            let step_norm = norm(&step);
            if res < opts.tol && step_norm < opts.tol {
                return Ok(done(&sh, step_norm));
            }
            match sh.damped_step(&y, &m, &step)? {
                Some((yn, pn)) => {
                    y = yn;
                    py = pn;
                }
                None => {
                    return Err(sh.fail(format!("Newton stalled at residual {res:.3e}"), Some(y)))
                }
            }
        }
        let res = norm(&sh.residual(&y, &py.end));
        Err(sh.fail(
            format!(
                "no convergence in {} Newton iterations (residual {res:.3e})",
                opts.max_newton
            ),
            Some(y),
        ))
    }

    /// Time-stepping from `start` with stroboscopic detection (module doc). `spent` periods
    /// already used elsewhere are added to the count; `reason` (why shooting was abandoned, if
    /// it was) goes into the error message.
    pub fn time_step(
        &self,
        start: &Initial,
        opts: &Options,
        spent: u64,
        reason: &str,
    ) -> Result<Steady, SteadyError> {
        opts.validate()?;
        let t0 = Instant::now();
        let run = self.stroboscopic(start, opts, opts.max_cycles)?;
        let cycles = spent + run.cycles;
        match run.steady {
            Some(mut s) => {
                s.cycles = cycles;
                s.wall_s = t0.elapsed().as_secs_f64();
                Ok(s)
            }
            None => Err(SteadyError::NotConverged {
                cycles,
                residual: run.residual,
                estimate: run.estimate,
                tol: opts.tol,
                reason: if reason.is_empty() {
                    String::new()
                } else {
                    format!("; shooting was abandoned first: {reason}")
                },
            }),
        }
    }

    /// At most `budget` periods of time-stepping from `start`, stopped as soon as the
    /// stroboscopic test passes.
    fn stroboscopic(
        &self,
        start: &Initial,
        opts: &Options,
        budget: u64,
    ) -> Result<StrobeRun, SteadyError> {
        let t0 = Instant::now();
        let start_state = match *start {
            Initial::State {
                x_s,
                v_s,
                a,
                a_dot,
                x_k,
            } => Some(OrbitState {
                x_s,
                v_s,
                a,
                a_dot,
                x_k,
            }),
            _ => None,
        };
        let mut strobe = Strobe {
            problem: self,
            tol: opts.tol,
            consecutive: opts.consecutive,
            prev: start_state,
            scales: None,
            diffs: Vec::new(),
            passed: 0,
            done: None,
            history: Vec::new(),
        };
        let r = self.run_periods(start, budget.max(1), opts.rtol, |end, c| {
            strobe.period(end, c);
            strobe.done.is_none()
        })?;
        let (d, est) = strobe
            .history
            .last()
            .copied()
            .unwrap_or((f64::NAN, f64::NAN));
        let steady = strobe.done.map(|(state, cycle)| {
            let lost = r
                .events
                .iter()
                .any(|&(_, t)| t > cycle.t_start && t <= cycle.t_end);
            Steady {
                method: SteadyMethod::TimeStepping,
                frequency: self.frequency,
                amplitude: self.amplitude,
                state,
                cycle,
                residual: d,
                distance: est,
                cycles: r.periods,
                newton_iterations: 0,
                contact_lost: lost,
                wall_s: t0.elapsed().as_secs_f64(),
                scales: strobe.scales.unwrap_or([f64::NAN; 3]),
            }
        });
        Ok(StrobeRun {
            steady,
            last: strobe.prev,
            cycles: r.periods,
            residual: d,
            estimate: est,
        })
    }
}

/// Largest magnitude of a vector.
fn norm(r: &[f64]) -> f64 {
    r.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// One shooting solve in progress: the problem, the periods spent, the unknowns and scales.
struct Shooting<'a> {
    problem: &'a Problem,
    opts: &'a Options,
    t0: Instant,
    spent: u64,
    idx: Vec<usize>,
    sc: [f64; 3],
}

impl Shooting<'_> {
    fn fail(&self, reason: String, last: Option<OrbitState>) -> Box<ShootFailure> {
        Box::new(ShootFailure {
            reason,
            cycles: self.spent,
            last,
            error: None,
        })
    }

    /// One period of the map, counted.
    fn map(&mut self, y: &OrbitState) -> Result<PeriodRun, Box<ShootFailure>> {
        let r = self
            .problem
            .map_once(&y.initial(), self.opts.rtol)
            .map_err(|e| ShootFailure::sim(e, self.spent + 1))?;
        self.spent += 1;
        Ok(r)
    }

    /// The first Newton iterate and its image: the start itself when it is a consistent state,
    /// else the end of one period from it; the scales come from the first period's record.
    fn first_iterate(
        &mut self,
        start: &Initial,
    ) -> Result<(OrbitState, PeriodRun), Box<ShootFailure>> {
        let p = self.problem;
        let mut y = match *start {
            Initial::State {
                x_s, v_s, a, x_k, ..
            } => p.consistent(x_s, v_s, a, x_k),
            _ => None,
        };
        if y.is_none() {
            let r = p
                .map_once(start, self.opts.rtol)
                .map_err(|e| ShootFailure::sim(e, self.spent + 1))?;
            self.spent += 1;
            let f = r.end;
            y = p.consistent(f.x_s, f.v_s, f.a, f.x_k);
            if y.is_none() {
                return Err(self.fail(
                    "no consistent start state after one period".into(),
                    Some(OrbitState::from_sample(&f)),
                ));
            }
        }
        let Some(y) = y else {
            return Err(self.fail("no start state".into(), None));
        };
        let py = self.map(&y)?;
        let Some(first) = py.last else {
            return Err(self.fail("the period produced no cycle record".into(), Some(y)));
        };
        self.sc = p.scales(&first);
        Ok((y, py))
    }

    /// The scaled residual P(y) − y over the unknowns.
    fn residual(&self, y: &OrbitState, p: &Sample) -> Vec<f64> {
        let (v, pv) = (y.vector(), [p.x_s, p.v_s, p.a]);
        self.idx
            .iter()
            .map(|&i| (pv[i] - v[i]) / self.sc[i])
            .collect()
    }

    fn done(&self, y: OrbitState, cycle: CycleRecord, res: f64, dist: f64, iter: usize) -> Steady {
        Steady {
            method: SteadyMethod::Shooting,
            frequency: self.problem.frequency,
            amplitude: self.problem.amplitude,
            state: y,
            cycle,
            residual: res,
            distance: dist,
            cycles: self.spent,
            newton_iterations: iter,
            contact_lost: false,
            wall_s: self.t0.elapsed().as_secs_f64(),
            scales: self.sc,
        }
    }

    /// The Jacobian of P − I at `y` (residual `r`) by forward differences, in scaled units.
    fn jacobian(&mut self, y: &OrbitState, r: &[f64]) -> Result<Vec<Vec<f64>>, Box<ShootFailure>> {
        let n = self.idx.len();
        let mut m = vec![vec![0.0; n]; n];
        for (col, j) in self.idx.clone().into_iter().enumerate() {
            let mut v = y.vector();
            v[j] += self.opts.fd_step * self.sc[j];
            let Some(yj) = self.problem.consistent(v[0], v[1], v[2], y.x_k) else {
                return Err(self.fail("perturbed state inconsistent".into(), Some(*y)));
            };
            let pj = self.map(&yj)?;
            if let Some(why) = pj.rough() {
                return Err(self.fail(why, Some(*y)));
            }
            let rj = self.residual(&yj, &pj.end);
            let h = (yj.vector()[j] - y.vector()[j]) / self.sc[j];
            for row in 0..n {
                m[row][col] = (rj[row] - r[row]) / h;
            }
        }
        Ok(m)
    }

    /// Damped step with Deuflhard's natural monotonicity test: accept when the simplified
    /// correction at the trial point, −(J − I)⁻¹ r(y_new) with the same J, is smaller than the
    /// step, ‖Δ̄‖ ≤ (1 − λ/4)‖Δ‖. Unlike a residual test it is affine invariant, so it accepts
    /// the long steps along the map's slow direction (the creeping contact radius) that a
    /// residual test refuses. `None` when no λ ≥ 1/128 passes.
    #[allow(clippy::type_complexity)]
    fn damped_step(
        &mut self,
        y: &OrbitState,
        m: &[Vec<f64>],
        step: &[f64],
    ) -> Result<Option<(OrbitState, PeriodRun)>, Box<ShootFailure>> {
        let step_norm = norm(step);
        let mut lambda = 1.0;
        for _ in 0..8 {
            let mut v = y.vector();
            for (k, &j) in self.idx.iter().enumerate() {
                v[j] += lambda * step[k] * self.sc[j];
            }
            if self.problem.unknowns.radius && v[2] <= 0.5 * y.a {
                lambda *= 0.5;
                continue;
            }
            if let Some(yn) = self.problem.consistent(v[0], v[1], v[2], y.x_k) {
                let pn = self.map(&yn)?;
                let rn = self.residual(&yn, &pn.end);
                let simplified = solve_dense(m.to_vec(), rn.iter().map(|x| -x).collect())
                    .map(|d| norm(&d))
                    .unwrap_or(f64::INFINITY);
                let ok = pn.rough().is_none()
                    && norm(&rn).is_finite()
                    && (simplified <= (1.0 - 0.25 * lambda) * step_norm
                        || norm(&rn) < self.opts.tol);
                if ok {
                    return Ok(Some((yn, pn)));
                }
            }
            lambda *= 0.5;
        }
        Ok(None)
    }
}

/// The outcome of a stroboscopic run.
struct StrobeRun {
    steady: Option<Steady>,
    /// End state of the last full period.
    last: Option<OrbitState>,
    cycles: u64,
    residual: f64,
    estimate: f64,
}

/// Why shooting gave up.
#[derive(Debug)]
pub struct ShootFailure {
    /// In words.
    pub reason: String,
    /// Periods integrated before giving up.
    pub cycles: u64,
    /// The last iterate (a start for time-stepping).
    pub last: Option<OrbitState>,
    /// A hard error (bad settings, failed run), if that was the cause.
    pub error: Option<SteadyError>,
}

impl ShootFailure {
    fn setup(e: SteadyError) -> Box<Self> {
        Box::new(Self {
            reason: e.to_string(),
            cycles: 0,
            last: None,
            error: Some(e),
        })
    }
    fn sim(e: SimError, cycles: u64) -> Box<Self> {
        Box::new(Self {
            reason: e.to_string(),
            cycles,
            last: None,
            error: Some(SteadyError::Sim(e)),
        })
    }
}

/// Watches a long run: end state of every period and the stroboscopic test.
struct Strobe<'a> {
    problem: &'a Problem,
    tol: f64,
    consecutive: usize,
    prev: Option<OrbitState>,
    scales: Option<[f64; 3]>,
    diffs: Vec<f64>,
    passed: usize,
    done: Option<(OrbitState, CycleRecord)>,
    /// (d_k, estimate) per period.
    history: Vec<(f64, f64)>,
}

impl Strobe<'_> {
    /// A period ended in state `end` with record `c`.
    fn period(&mut self, end: &Sample, c: &CycleRecord) {
        let sc = *self.scales.get_or_insert_with(|| self.problem.scales(c));
        let cur = OrbitState::from_sample(end);
        let Some(prev) = self.prev.replace(cur) else {
            return;
        };
        let (v0, v1) = (prev.vector(), cur.vector());
        let d = (0..3)
            .map(|i| ((v1[i] - v0[i]) / sc[i]).abs())
            .fold(0.0f64, f64::max);
        self.diffs.push(d);
        let k = self.diffs.len();
        let est = if k > 10 {
            let rho = (d / self.diffs[k - 11]).powf(0.1);
            if rho.is_finite() && rho < 1.0 {
                d * (rho / (1.0 - rho)).max(1.0)
            } else {
                f64::INFINITY
            }
        } else {
            f64::INFINITY
        };
        self.history.push((d, est));
        let ok = (d.is_finite() && d < 0.01 * self.tol) || est < self.tol;
        self.passed = if ok { self.passed + 1 } else { 0 };
        if self.passed >= self.consecutive {
            // The steady cycle and the state at its start (as shooting reports it).
            self.done = Some((prev, *c));
        }
    }
}

/// Solve the scaled Newton system M x = b (nalgebra's LU, [`crate::numerics::solve_dense`]).
fn solve_dense(m: Vec<Vec<f64>>, b: Vec<f64>) -> Option<Vec<f64>> {
    crate::numerics::solve_dense(b.len(), |i, j| m[i][j], &b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_solve_matches_known_solution() {
        let a = vec![
            vec![0.0, 2.0, 1.0],
            vec![1.0, 1.0, 0.0],
            vec![3.0, 0.0, 1.0],
        ];
        let x = [1.0, -2.0, 0.5];
        let b: Vec<f64> = a
            .iter()
            .map(|r| r.iter().zip(&x).map(|(p, q)| p * q).sum())
            .collect();
        let s = solve_dense(a, b).unwrap_or_default();
        for i in 0..3 {
            assert!((s[i] - x[i]).abs() < 1e-14);
        }
        assert!(solve_dense(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![1.0, 2.0]).is_none());
    }
}
