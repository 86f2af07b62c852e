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
//! Submodules: [`compare`] (the time-domain steady state side by side with the imposed-area
//! method, the linear transfer, the paper's printed eqs. (37)–(39) and harmonic balance),
//! [`sweep`] (frequency response with continuation, up and down), [`map`] (where the
//! imposed-area shortcut holds, over a frequency × amplitude grid).

pub mod compare;
pub mod map;
pub mod sweep;

use crate::adhesion::AdhesionLaw;
use crate::dynamics::{simulate, CycleRecord, EventKind, Observer, RunResult, Sample, SimError};
use crate::jkr;
use crate::material::Material;
use crate::scenario::{BaseMotion, Holder, Initial, Scenario, Stage, StageKind, Until};
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

/// A steady-state problem: a scenario's contact, sphere, holder and law, shaken at one frequency
/// and amplitude with the spring end held still.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// The one-period template: the scenario with one vibrating hold stage of one period.
    scenario: Scenario,
    /// Base frequency f (Hz).
    pub frequency: f64,
    /// Base amplitude X_b (m).
    pub amplitude: f64,
    unknowns: Unknowns,
}

impl Problem {
    /// The scenario's mechanics shaken at `frequency` (Hz, > 0) with amplitude `amplitude`
    /// (m, ≥ 0), the spring end held still. The scenario's stages and base section are ignored.
    pub fn new(scn: &Scenario, frequency: f64, amplitude: f64) -> Result<Problem, SteadyError> {
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
        let mut s = scn.clone();
        s.rig.base = Some(BaseMotion {
            amplitude,
            frequency,
        });
        s.stages = vec![Stage {
            kind: StageKind::Hold,
            speed: 0.0,
            until: Until::Duration(1.0 / frequency),
            vibration: Some(true),
            max_duration: f64::INFINITY,
        }];
        s.output.sample_rate = 0.0;
        s.output.csv = false;
        let mechanics = s.rig.sphere.mass > 0.0 && !matches!(s.rig.holder, Holder::Rigid);
        let radius = !s.rig.law.is_rate_independent();
        Ok(Problem {
            scenario: s,
            frequency,
            amplitude,
            unknowns: Unknowns { mechanics, radius },
        })
    }

    /// The steady-state problem a scenario file describes, and where to start: the scene's first
    /// stage with the vibration on, at the scene's base amplitude and frequency, with the spring
    /// end held where that stage starts. The stages before it (shaker off: approach, dwell) are
    /// run first with the scene's own solver settings, and their end state is the start;
    /// without such stages the start is the scene's initial state. A moving spring end during
    /// the vibrating stage (approach, unload) has no periodic steady state: it is held at its
    /// position at the stage start.
    pub fn from_scenario(scn: &Scenario) -> Result<(Problem, Initial), SteadyError> {
        let base = scn.rig.base.ok_or_else(|| {
            SteadyError::Setup(format!(
                "{}: no [base] section: nothing vibrates, no periodic steady state",
                scn.source_name
            ))
        })?;
        let mut on = false;
        let mut first = None;
        for (i, st) in scn.stages.iter().enumerate() {
            if let Some(v) = st.vibration {
                on = v;
            }
            if on {
                first = Some(i);
                break;
            }
        }
        let i = first.ok_or_else(|| {
            SteadyError::Setup(format!(
                "{}: no stage switches the shaker on (vibration = true)",
                scn.source_name
            ))
        })?;
        let problem = Problem::new(scn, base.frequency, base.amplitude)?;
        if i == 0 {
            return Ok((problem, scn.initial));
        }
        let mut pre = scn.clone();
        pre.stages.truncate(i);
        pre.output.sample_rate = 0.0;
        let r = simulate(&pre, &mut crate::dynamics::NoObserver)?;
        if r.detached {
            return Err(SteadyError::Setup(format!(
                "{}: the sphere detached before the first vibrating stage (stage {})",
                scn.source_name,
                i + 1
            )));
        }
        Ok((problem, OrbitState::from_sample(&r.final_state).initial()))
    }

    /// The same mechanics at another frequency (Hz) and base amplitude (m).
    pub fn at(&self, frequency: f64, amplitude: f64) -> Result<Problem, SteadyError> {
        Problem::new(&self.scenario, frequency, amplitude)
    }

    /// The scenario one period of the map runs (one vibrating hold stage of 1/f).
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The rig (shaken at this problem's frequency and amplitude).
    pub fn rig(&self) -> &crate::rig::Rig {
        &self.scenario.rig
    }

    /// Angular frequency ω = 2πf (rad/s).
    pub fn omega(&self) -> f64 {
        2.0 * PI * self.frequency
    }

    /// Run `periods` base periods from `start` with integration tolerance `rtol`, watched by
    /// `obs`.
    pub fn run(
        &self,
        start: &Initial,
        periods: u64,
        rtol: f64,
        obs: &mut dyn Observer,
    ) -> Result<RunResult, SimError> {
        let mut s = self.scenario.clone();
        s.initial = *start;
        s.solver.rtol = rtol;
        // The driver records the last base-period boundary (k·2π/ω) even when rounding puts it
        // a sliver after the stage end (periods / f).
        s.stages[0].until = Until::Duration(periods as f64 / self.frequency);
        simulate(&s, obs)
    }

    /// A start state consistent with the model: ȧ from the law for (a, δ = x_s) (x_b = 0 at phase
    /// 0); with a rate-independent law a itself is the JKR radius at w0 for δ. `None` when the
    /// law gives no finite rate (a compressive edge under a Gent–Schultz law heals at an
    /// unbounded rate).
    fn consistent(&self, x_s: f64, v_s: f64, a: f64, x_k: f64) -> Option<OrbitState> {
        let m = &self.scenario.rig.material;
        let law = &self.scenario.rig.law;
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
            let ae = equilibrium_radius_for_indentation(m, x_s, w)?;
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
    fn scales(&self, c: &CycleRecord) -> [f64; 3] {
        let m = &self.scenario.rig.material;
        let a_j = jkr::jump_in_radius(m, self.scenario.rig.law.w0());
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

    /// Newton on the one-cycle map (module doc). On failure returns why, the periods spent and
    /// the last state reached (a better start for time-stepping than the original one).
    pub fn shoot(&self, start: &Initial, opts: &Options) -> Result<Steady, Box<ShootFailure>> {
        opts.validate().map_err(ShootFailure::setup)?;
        let t0 = Instant::now();
        let mut spent = 0u64;
        let fail = |reason: String, spent: u64, last: Option<OrbitState>| {
            Box::new(ShootFailure {
                reason,
                cycles: spent,
                last,
                error: None,
            })
        };
        // One period from the given start: its end is the first Newton iterate.
        let mut y = match *start {
            Initial::State {
                x_s, v_s, a, x_k, ..
            } => self.consistent(x_s, v_s, a, x_k),
            _ => None,
        };
        if y.is_none() {
            let r = self
                .map_once(start, opts.rtol)
                .map_err(|e| ShootFailure::sim(e, spent + 1))?;
            spent += 1;
            let f = r.final_state;
            y = self.consistent(f.x_s, f.v_s, f.a, f.x_k);
            if y.is_none() {
                return Err(fail(
                    "no consistent start state after one period".into(),
                    spent,
                    Some(OrbitState::from_sample(&f)),
                ));
            }
        }
        let Some(mut y) = y else {
            return Err(fail("no start state".into(), spent, None));
        };
        let idx = self.unknowns.indices();
        let mut py = self
            .map_once(&y.initial(), opts.rtol)
            .map_err(|e| ShootFailure::sim(e, spent + 1))?;
        spent += 1;
        let Some(first) = py.cycles.last().copied() else {
            return Err(fail(
                "the period produced no cycle record".into(),
                spent,
                Some(y),
            ));
        };
        let sc = self.scales(&first);
        let residual = |y: &OrbitState, p: &Sample| -> Vec<f64> {
            let (v, pv) = (y.vector(), [p.x_s, p.v_s, p.a]);
            idx.iter().map(|&i| (pv[i] - v[i]) / sc[i]).collect()
        };
        let norm = |r: &[f64]| r.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        // The Jacobian of P − I of the latest Newton iteration (scaled units).
        let mut jac: Option<Vec<Vec<f64>>> = None;
        for iter in 0..=opts.max_newton {
            if let Some(why) = rough(&py) {
                return Err(fail(why, spent, Some(y)));
            }
            let r = residual(&y, &py.final_state);
            let res = norm(&r);
            let Some(cycle) = py.cycles.last().copied() else {
                return Err(fail("no cycle record".into(), spent, Some(y)));
            };
            if !res.is_finite() {
                return Err(fail("non-finite residual".into(), spent, Some(y)));
            }
            let done = |dist: f64, spent: u64| Steady {
                method: SteadyMethod::Shooting,
                frequency: self.frequency,
                amplitude: self.amplitude,
                state: y,
                cycle,
                residual: res,
                distance: dist,
                cycles: spent,
                newton_iterations: iter,
                contact_lost: false,
                wall_s: t0.elapsed().as_secs_f64(),
                scales: sc,
            };
            if idx.is_empty() {
                return Ok(done(res, spent));
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
                        return Ok(done(dist, spent));
                    }
                }
            }
            if iter == opts.max_newton {
                break;
            }
            // Jacobian of P − I by forward differences, in scaled units.
            let n = idx.len();
            let mut m = vec![vec![0.0; n]; n];
            for (col, &j) in idx.iter().enumerate() {
                let mut v = y.vector();
                v[j] += opts.fd_step * sc[j];
                let Some(yj) = self.consistent(v[0], v[1], v[2], y.x_k) else {
                    return Err(fail("perturbed state inconsistent".into(), spent, Some(y)));
                };
                let pj = self
                    .map_once(&yj.initial(), opts.rtol)
                    .map_err(|e| ShootFailure::sim(e, spent + 1))?;
                spent += 1;
                if let Some(why) = rough(&pj) {
                    return Err(fail(why, spent, Some(y)));
                }
                let rj = residual(&yj, &pj.final_state);
                let h = (yj.vector()[j] - y.vector()[j]) / sc[j];
                for row in 0..n {
                    m[row][col] = (rj[row] - r[row]) / h;
                }
            }
            jac = Some(m.clone());
            let Some(step) = solve_dense(m.clone(), neg) else {
                return Err(fail("singular shooting Jacobian".into(), spent, Some(y)));
            };
            let step_norm = norm(&step);
            if res < opts.tol && step_norm < opts.tol {
                return Ok(done(step_norm, spent));
            }
            // Damped step with Deuflhard's natural monotonicity test: accept when the
            // simplified correction at the trial point, −(J − I)⁻¹ r(y_new) with the same J, is
            // smaller than the step, ‖Δ̄‖ ≤ (1 − λ/4)‖Δ‖. Unlike a residual test it is affine
            // invariant, so it accepts the long steps along the map's slow direction (the
            // creeping contact radius) that a residual test refuses.
            let mut lambda = 1.0;
            let mut accepted = None;
            for _ in 0..8 {
                let mut v = y.vector();
                for (k, &j) in idx.iter().enumerate() {
                    v[j] += lambda * step[k] * sc[j];
                }
                if self.unknowns.radius && v[2] <= 0.5 * y.a {
                    lambda *= 0.5;
                    continue;
                }
                if let Some(yn) = self.consistent(v[0], v[1], v[2], y.x_k) {
                    let pn = self
                        .map_once(&yn.initial(), opts.rtol)
                        .map_err(|e| ShootFailure::sim(e, spent + 1))?;
                    spent += 1;
                    let rn = residual(&yn, &pn.final_state);
                    let simplified = solve_dense(m.clone(), rn.iter().map(|x| -x).collect())
                        .map(|d| norm(&d))
                        .unwrap_or(f64::INFINITY);
                    let ok = rough(&pn).is_none()
                        && norm(&rn).is_finite()
                        && (simplified <= (1.0 - 0.25 * lambda) * step_norm
                            || norm(&rn) < opts.tol);
                    if ok {
                        accepted = Some((yn, pn));
                        break;
                    }
                }
                lambda *= 0.5;
            }
            match accepted {
                Some((yn, pn)) => {
                    y = yn;
                    py = pn;
                }
                None => {
                    return Err(fail(
                        format!("Newton stalled at residual {res:.3e}"),
                        spent,
                        Some(y),
                    ))
                }
            }
        }
        let res = norm(&residual(&y, &py.final_state));
        Err(fail(
            format!(
                "no convergence in {} Newton iterations (residual {res:.3e})",
                opts.max_newton
            ),
            spent,
            Some(y),
        ))
    }

    fn map_once(&self, start: &Initial, rtol: f64) -> Result<RunResult, SimError> {
        self.run(start, 1, rtol, &mut crate::dynamics::NoObserver)
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
            last: None,
            scales: None,
            diffs: Vec::new(),
            passed: 0,
            done: None,
            history: Vec::new(),
        };
        let r = self.run(start, budget.max(1), opts.rtol, &mut strobe)?;
        let cycles = r.cycles.len() as u64;
        let (d, est) = strobe
            .history
            .last()
            .copied()
            .unwrap_or((f64::NAN, f64::NAN));
        let steady = strobe.done.map(|(state, cycle)| {
            let lost = r.events.iter().any(|e| {
                matches!(e.kind, EventKind::ContactLoss | EventKind::Impact)
                    && e.time > cycle.t_start
                    && e.time <= cycle.t_end
            });
            Steady {
                method: SteadyMethod::TimeStepping,
                frequency: self.frequency,
                amplitude: self.amplitude,
                state,
                cycle,
                residual: d,
                distance: est,
                cycles,
                newton_iterations: 0,
                contact_lost: lost,
                wall_s: t0.elapsed().as_secs_f64(),
                scales: strobe.scales.unwrap_or([f64::NAN; 3]),
            }
        });
        Ok(StrobeRun {
            steady,
            last: strobe.prev,
            cycles,
            residual: d,
            estimate: est,
        })
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

/// Why a one-period run is not a smooth map: contact lost or formed within it, or the contact
/// open at its end.
fn rough(r: &RunResult) -> Option<String> {
    if let Some(e) = r
        .events
        .iter()
        .find(|e| matches!(e.kind, EventKind::ContactLoss | EventKind::Impact))
    {
        return Some(format!(
            "{:?} at t = {:.6e} s within the period",
            e.kind, e.time
        ));
    }
    if r.final_state.a <= 0.0 {
        return Some("contact open at phase 0".into());
    }
    None
}

/// Watches a long run: end state of every period, the stroboscopic test, and a stop request.
struct Strobe<'a> {
    problem: &'a Problem,
    tol: f64,
    consecutive: usize,
    prev: Option<OrbitState>,
    last: Option<Sample>,
    scales: Option<[f64; 3]>,
    diffs: Vec<f64>,
    passed: usize,
    done: Option<(OrbitState, CycleRecord)>,
    /// (d_k, estimate) per period.
    history: Vec<(f64, f64)>,
}

impl Observer for Strobe<'_> {
    fn sample(&mut self, s: &Sample) -> bool {
        self.last = Some(*s);
        self.done.is_none()
    }

    fn cycle(&mut self, c: &CycleRecord) {
        let Some(end) = self.last else { return };
        // The driver emits the boundary step's sample before the cycle record.
        if (end.t - c.t_end).abs() > 1e-9 * c.t_end.abs().max(1e-300) {
            return;
        }
        let sc = *self.scales.get_or_insert_with(|| self.problem.scales(c));
        let cur = OrbitState::from_sample(&end);
        let Some(prev) = self.prev.replace(cur) else {
            return;
        };
        let idx = [0usize, 1, 2];
        let (v0, v1) = (prev.vector(), cur.vector());
        let d = idx
            .iter()
            .map(|&i| ((v1[i] - v0[i]) / sc[i]).abs())
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

/// The JKR contact radius at work of adhesion w for indentation δ, on the stable
/// (displacement-controlled) branch a ≥ a_dc, where δ_eq(a) = a²/R − √(8πaw/(3K)) increases;
/// `None` below the branch's minimum δ (no contact).
pub fn equilibrium_radius_for_indentation(m: &Material, delta: f64, w: f64) -> Option<f64> {
    let a_dc = jkr::displacement_controlled_pull_off_radius(m, w);
    let f = |a: f64| jkr::equilibrium_indentation(m, a, w) - delta;
    if !(delta.is_finite() && a_dc.is_finite()) || f(a_dc) > 0.0 {
        return None;
    }
    let (mut lo, mut hi) = (a_dc, 2.0 * a_dc.max((m.r * delta.abs()).sqrt()));
    let mut guard = 0;
    while f(hi) < 0.0 {
        lo = hi;
        hi *= 2.0;
        guard += 1;
        if guard > 200 {
            return None;
        }
    }
    // Bisection to a relative bracket of 1e-15 (f is monotonic on the branch).
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-15 * hi {
            break;
        }
    }
    Some(0.5 * (lo + hi))
}

/// Gaussian elimination with partial pivoting on a small dense system; `None` if singular.
fn solve_dense(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let p = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if !(a[p][col].abs() > 0.0 && a[p][col].is_finite()) {
            return None;
        }
        a.swap(col, p);
        b.swap(col, p);
        let (top, rest) = a.split_at_mut(col + 1);
        let pivot = &top[col];
        for (i, r) in rest.iter_mut().enumerate() {
            let f = r[col] / pivot[col];
            for (x, p) in r[col..].iter_mut().zip(&pivot[col..]) {
                *x -= f * p;
            }
            b[col + 1 + i] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
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

    #[test]
    fn equilibrium_radius_inverts_the_jkr_indentation() {
        let m = Material::PAPER;
        for &a in &[0.5e-3, 1.2e-3, 4e-3] {
            let d = jkr::equilibrium_indentation(&m, a, m.w0);
            let back = equilibrium_radius_for_indentation(&m, d, m.w0).unwrap_or(0.0);
            assert!((back / a - 1.0).abs() < 1e-12, "{a} -> {back}");
        }
        let a_dc = jkr::displacement_controlled_pull_off_radius(&m, m.w0);
        let d_min = jkr::equilibrium_indentation(&m, a_dc, m.w0);
        assert!(equilibrium_radius_for_indentation(&m, d_min - 1e-9, m.w0).is_none());
    }
}
