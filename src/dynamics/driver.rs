//! The driver: owns the time loop, runs the stage protocol, locates events, records cycles, feeds
//! the observer. See the module documentation of [`crate::dynamics`] for the design.

use super::erk;
use super::esdirk::{self, State, StepFail, Tol};
use super::explicit::{self, ExplicitKind};
use super::model::{self, q, Drive, Mechanics, Model, NQ};
use super::types::*;
use crate::adhesion::AdhesionLaw;
use crate::jkr;
use crate::numerics;
use crate::scenario::{ContactFormation, Holder, Initial, Method, Scenario, StageKind, Until};
use std::f64::consts::PI;
use std::time::Instant;
use thiserror::Error;

/// Why a run failed: what, when, and the state at that time.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SimError {
    /// The scenario combines settings the simulator cannot run.
    #[error("scenario cannot be simulated: {0}")]
    Setup(String),
    /// The step size fell below what the time resolves.
    #[error("step size underflow at t = {t:e} s (h = {h:e} s); {}", describe(.state))]
    StepSizeUnderflow {
        /// Time (s).
        t: f64,
        /// Last attempted step (s).
        h: f64,
        /// State.
        state: Box<Sample>,
    },
    /// `solver.max_steps` exhausted.
    #[error("step budget of {max_steps} steps exhausted at t = {t:e} s; {}", describe(.state))]
    StepBudget {
        /// Time (s).
        t: f64,
        /// The budget.
        max_steps: u64,
        /// State.
        state: Box<Sample>,
    },
    /// `solver.max_wall_s` exhausted.
    #[error("wall-clock budget of {max_wall_s} s exhausted at t = {t:e} s; {}", describe(.state))]
    WallBudget {
        /// Time (s).
        t: f64,
        /// The budget (s).
        max_wall_s: f64,
        /// State.
        state: Box<Sample>,
    },
    /// A stage ran for its `max_duration` without meeting its end condition.
    #[error("stage {stage} ({until}) did not end within max_duration = {max_duration} s (t = {t:e} s); {}", describe(.state))]
    StageTimeout {
        /// Stage index (0-based).
        stage: usize,
        /// The end condition, in words.
        until: String,
        /// The stage's limit (s).
        max_duration: f64,
        /// Time (s).
        t: f64,
        /// State.
        state: Box<Sample>,
    },
    /// The state became non-finite and no smaller step cured it.
    #[error("non-finite state at t = {t:e} s; {}", describe(.state))]
    NonFinite {
        /// Time (s).
        t: f64,
        /// Last finite state.
        state: Box<Sample>,
    },
    /// An explicitly requested explicit method met a state it cannot integrate.
    #[error("{method} failed at t = {t:e} s: {reason}; {}; use method = \"implicit\" (or \"auto\")", describe(.state))]
    Explicit {
        /// The method.
        method: String,
        /// Time (s).
        t: f64,
        /// What happened.
        reason: String,
        /// State.
        state: Box<Sample>,
    },
}

fn describe(s: &Sample) -> String {
    format!(
        "state: stage {}, x_s = {:e} m, v_s = {:e} m/s, delta = {:e} m, a = {:e} m, a_dot = {:e} m/s, F = {:e} N, G = {:e} J/m^2",
        s.stage, s.x_s, s.v_s, s.delta, s.a, s.a_dot, s.force, s.g
    )
}

/// Build the time-series sample of a state.
pub fn make_sample(m: &Model, drive: &Drive, y: &State, stage: usize) -> Sample {
    let kin = drive.at(m, y.t);
    let delta = y.x + kin.xb;
    let (a, adot, f, g, w) = if y.contact {
        (
            y.a,
            y.adot,
            jkr::contact_force(&m.mat, y.a, delta),
            jkr::signed_energy_release_rate(&m.mat, y.a, delta),
            m.work_of_adhesion(y.adot),
        )
    } else {
        (0.0, 0.0, 0.0, 0.0, m.w0)
    };
    Sample {
        t: y.t,
        x_s: y.x,
        v_s: y.v,
        x_b: kin.xb,
        x_k: kin.xk,
        delta,
        a,
        a_dot: adot,
        force: f,
        g,
        w,
        stage,
    }
}

/// Cubic Hermite interpolation of (x, v, a) between two states (ȧ linear).
fn hermite(y0: &State, y1: &State, t: f64) -> State {
    let h = y1.t - y0.t;
    if h <= 0.0 {
        return *y1;
    }
    let s = ((t - y0.t) / h).clamp(0.0, 1.0);
    let h00 = (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s);
    let h10 = s * (1.0 - s) * (1.0 - s);
    let h01 = s * s * (3.0 - 2.0 * s);
    let h11 = s * s * (s - 1.0);
    let p = |p0: f64, d0: f64, p1: f64, d1: f64| h00 * p0 + h10 * h * d0 + h01 * p1 + h11 * h * d1;
    let mut y = *y1;
    y.t = t;
    y.x = p(y0.x, y0.v, y1.x, y1.v);
    y.v = p(y0.v, y0.acc, y1.v, y1.acc);
    y.a = p(y0.a, y0.adot, y1.a, y1.adot);
    y.adot = y0.adot + s * (y1.adot - y0.adot);
    y.acc = y0.acc + s * (y1.acc - y0.acc);
    y
}

/// The integration engine in use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Engine {
    /// `ESDIRK4(3)6L[2]SA` with the root-solved contact radius.
    Implicit,
    /// djkr's own explicit DOP853 stepper ([`erk`]).
    Dp8,
    /// An `ode_solvers` explicit method.
    Explicit(ExplicitKind),
}

impl Engine {
    fn name(self) -> &'static str {
        match self {
            Engine::Implicit => "implicit ESDIRK4(3)6L[2]SA (root-solved contact radius)",
            Engine::Dp8 => "explicit DP8: Dormand-Prince 8(5,3), djkr's stepper",
            Engine::Explicit(ExplicitKind::Dopri5) => "explicit Dopri5 (ode_solvers)",
            Engine::Explicit(ExplicitKind::Dop853) => "explicit Dop853 (ode_solvers)",
        }
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
/// - **DP8** otherwise, taking single steps implicitly where a DP8 stage meets G ≤ 0: several
///   times faster than the implicit method at equal accuracy on the scenes with inertia.
pub fn auto_engine(s: &Scenario) -> Engine {
    let no_inertia = matches!(s.rig.holder, Holder::Rigid) || s.rig.sphere.mass == 0.0;
    if s.rig.law.is_rate_independent()
        || matches!(s.rig.formation, ContactFormation::Seed(_))
        || no_inertia
    {
        Engine::Implicit
    } else {
        Engine::Dp8
    }
}

/// Which state function an event watches.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Watch {
    /// a − a_floor, falling through 0.
    Loss,
    /// δ, rising through 0 (out of contact).
    Impact,
    /// F − P, rising through 0.
    Preload(f64),
}

struct Run<'a> {
    model: Model,
    tol: Tol,
    max_steps: u64,
    max_wall_s: f64,
    event_tol: f64,
    formation: ContactFormation,
    obs: &'a mut dyn Observer,
    y: State,
    drive: Drive,
    stage: usize,
    h: f64,
    events: Vec<Event>,
    cycles: Vec<CycleRecord>,
    stats: Stats,
    start: Instant,
    cycle_index: u64,
    cycle_t0: f64,
    cycle_q0: [f64; NQ],
    cycle_e0: f64,
    off_pending: bool,
    sample_dt: f64,
    next_sample: f64,
    stopped: bool,
    /// Most tensile force candidate (force, time).
    min_force: Option<(f64, f64)>,
    /// Most tensile cycle-mean force (force, cycle end time).
    min_cycle: Option<(f64, f64)>,
    /// Shaker state when detachment was declared.
    shaker_at_detach: Option<bool>,
    /// Contact loss that may turn out to be the final detachment.
    pending_loss: Option<Event>,
    detached: bool,
    /// A time at which a stage solve found no root (the contact collapses before it).
    collapse_at: Option<f64>,
    /// The current stage ends at pull-off.
    in_pulloff: bool,
    /// Engine in use.
    engine: Engine,
    /// `method = auto`.
    auto: bool,
    /// Last inner step of the explicit engine (s).
    h_inner: f64,
    /// The observer uses samples (`Observer::wants_samples`).
    wants_samples: bool,
    /// The DP8 stepper's last evaluation: the rates at the end of its last step (first same as
    /// last), reused when the next step starts from that state under the same drive.
    fsal: Option<(State, erk::Rates, [f64; NQ])>,
    /// Steps that `auto` took with the implicit method after a DP8 stage met G ≤ 0.
    implicit_rescues: u64,
    /// The current attempt was already shortened to end at a turning point of the contact line.
    kink_cut: bool,
    /// The last attempt was rejected (the next accepted step may not grow).
    rejected_last: bool,
    /// Predicted time of the next turning point of the contact line (DP8), to end a step there.
    kink_ahead: Option<f64>,
    /// The next attempt's length when the last one was cut back to a turning point (the step
    /// proposal `h` is kept for the step after it).
    h_cut: Option<f64>,
}

impl Run<'_> {
    fn kin(&self, t: f64) -> model::Kinematics {
        self.drive.at(&self.model, t)
    }

    fn sample_of(&self, y: &State) -> Sample {
        make_sample(&self.model, &self.drive, y, self.stage)
    }

    fn force_of(&self, y: &State) -> f64 {
        if !y.contact {
            return 0.0;
        }
        let kin = self.kin(y.t);
        jkr::contact_force(&self.model.mat, y.a, y.x + kin.xb)
    }

    fn force_rate(&self, y: &State) -> f64 {
        if !y.contact {
            return 0.0;
        }
        let kin = self.kin(y.t);
        let (k, r) = (self.model.mat.k, self.model.mat.r);
        let d = y.x + kin.xb;
        0.5 * k * (3.0 * d - 3.0 * y.a * y.a / r) * y.adot + 1.5 * k * y.a * (y.v + kin.vb)
    }

    fn watch_value(&self, w: Watch, y: &State) -> f64 {
        match w {
            Watch::Loss => y.a - self.model.a_floor,
            Watch::Impact => y.x + self.kin(y.t).xb,
            Watch::Preload(p) => self.force_of(y) - p,
        }
    }

    /// True when the watched function has crossed (pre-event value `g0` → `g1`).
    fn crossed(w: Watch, g0: f64, g1: f64) -> bool {
        match w {
            Watch::Loss => g0 > 0.0 && g1 <= 0.0,
            Watch::Impact | Watch::Preload(_) => g0 < 0.0 && g1 >= 0.0,
        }
    }

    fn event(&mut self, kind: EventKind, y: &State) {
        let e = Event {
            kind,
            time: y.t,
            stage: self.stage,
            state: self.sample_of(y),
        };
        self.obs.event(&e);
        self.events.push(e);
    }

    fn err_state(&self) -> Box<Sample> {
        Box::new(self.sample_of(&self.y))
    }

    /// Refresh the derived parts of the state (acceleration; x, v for the reduced mechanics)
    /// after the drive changed.
    fn refresh(&mut self) {
        self.fsal = None;
        self.kink_ahead = None;
        let kin = self.kin(self.y.t);
        let y = &mut self.y;
        match self.model.mech {
            Mechanics::Dynamic => {
                y.acc = self.model.accel(&kin, y.x, y.v, y.a, y.contact);
            }
            _ => {
                let (x, v) = self
                    .model
                    .position(&kin, y.a, y.adot, y.contact, y.x, y.v, 0.0);
                y.x = x;
                y.v = v;
                y.acc = 0.0;
            }
        }
    }

    /// Emit time-series samples for (y0.t, y1.t].
    fn output(&mut self, y0: &State, y1: &State) {
        if self.stopped || !self.wants_samples {
            return;
        }
        if self.sample_dt <= 0.0 {
            let s = self.sample_of(y1);
            if !self.obs.sample(&s) {
                self.stopped = true;
            }
            return;
        }
        while self.next_sample <= y1.t {
            let yi = hermite(y0, y1, self.next_sample);
            let s = self.sample_of(&yi);
            if !self.obs.sample(&s) {
                self.stopped = true;
                return;
            }
            self.next_sample += self.sample_dt;
        }
    }

    /// Track the most tensile instantaneous force while the shaker is off, refining an interior
    /// minimum over the step's interpolant, then (if it may beat the record) by exact re-stepping.
    fn track_force(&mut self, y0: &State, y1: &State) {
        if self.drive.shaker || !y1.contact || !y0.contact {
            return;
        }
        let mut cand = vec![(self.force_of(y1), y1.t)];
        if self.min_force.is_none() {
            cand.push((self.force_of(y0), y0.t));
        }
        if self.force_rate(y0) < 0.0 && self.force_rate(y1) > 0.0 {
            // A cheap search on the step's interpolant first; only a minimum that may beat the
            // record is refined exactly (each trial a fresh step from y0).
            let hermite_f = |run: &mut Self, t: f64| run.force_of(&hermite(y0, y1, t));
            let (fh, th) = self.minimize(y0.t, y1.t, 1e-6 * (y1.t - y0.t), hermite_f);
            let scale = fh.abs().max(1e-300);
            if self.min_force.is_none_or(|(m, _)| fh < m + 1e-3 * scale) {
                let exact = |run: &mut Self, t: f64| match run.try_step(y0, t - y0.t) {
                    Ok(Some(o)) => run.force_of(&o.y),
                    _ => run.force_of(&hermite(y0, y1, t)),
                };
                let tol = self.event_tol.max(1e-15 * y1.t.abs());
                cand.push(self.minimize(y0.t, y1.t, tol, exact));
            } else {
                cand.push((fh, th));
            }
        }
        for (f, t) in cand {
            if self.min_force.is_none_or(|(m, _)| f < m) {
                self.min_force = Some((f, t));
            }
        }
    }

    /// Minimise `f` over [lo, hi] to about `tol` in t with Brent's method: (min, argmin).
    fn minimize(
        &mut self,
        lo: f64,
        hi: f64,
        tol: f64,
        f: impl Fn(&mut Self, f64) -> f64,
    ) -> (f64, f64) {
        // `brent_minimize` converges to ≈ 3 (rel_tol |t| + abs_tol).
        let (t, fmin) =
            numerics::brent_minimize(|t| f(self, t), lo, hi, f64::EPSILON, tol / 3.0, 100);
        (fmin, t)
    }

    fn next_boundary(&self) -> f64 {
        if self.drive.shaker && self.model.omega > 0.0 {
            self.drive.t_on + (self.cycle_index + 1) as f64 * 2.0 * PI / self.model.omega
        } else {
            f64::INFINITY
        }
    }

    fn start_cycles(&mut self) {
        self.cycle_index = 0;
        self.cycle_t0 = self.y.t;
        self.cycle_q0 = self.y.q;
        let kin = self.kin(self.y.t);
        self.cycle_e0 = model::total_energy(
            &self.model,
            &kin,
            self.y.x,
            self.y.v,
            self.y.a,
            self.y.contact,
        );
    }

    fn record_cycle(&mut self) {
        let y = self.y;
        let tt = y.t - self.cycle_t0;
        let d: [f64; NQ] = std::array::from_fn(|i| y.q[i] - self.cycle_q0[i]);
        let kin = self.kin(y.t);
        let e1 = model::total_energy(&self.model, &kin, y.x, y.v, y.a, y.contact);
        let m = |i: usize| d[i] / tt;
        let hh = |i: usize| 2.0 * d[i] / tt;
        let rec = CycleRecord {
            index: self.cycle_index,
            stage: self.stage,
            t_start: self.cycle_t0,
            t_end: y.t,
            force_mean: m(q::F),
            force_sin: hh(q::F_SIN),
            force_cos: hh(q::F_COS),
            // δ = x_s + x_b with x_b = X_b sin θ exactly over this whole base period (see q::XS_SIN).
            delta_mean: m(q::XS),
            delta_sin: hh(q::XS_SIN) + self.model.xb_amp,
            delta_cos: hh(q::XS_COS),
            a_mean: m(q::A),
            a_sin: hh(q::A_SIN),
            a_cos: hh(q::A_COS),
            x_s_mean: m(q::XS),
            x_k_mean: m(q::XK),
            spring_mean: m(q::SPRING),
            spring_sin: hh(q::SPRING_SIN),
            spring_cos: hh(q::SPRING_COS),
            work_base: d[q::W_BASE],
            work_holder: d[q::W_HOLDER],
            dissipation_damping: d[q::D_DAMP],
            dissipation_adhesion: d[q::D_ADH],
            energy_start: self.cycle_e0,
            energy_end: e1,
        };
        if !self.detached && self.min_cycle.is_none_or(|(f, _)| rec.force_mean < f) {
            self.min_cycle = Some((rec.force_mean, rec.t_end));
        }
        self.obs.cycle(&rec);
        self.cycles.push(rec);
        self.cycle_index += 1;
        self.cycle_t0 = y.t;
        self.cycle_q0 = y.q;
        self.cycle_e0 = e1;
        if self.off_pending {
            self.off_pending = false;
            self.drive.shaker = false;
            self.refresh();
        }
    }

    fn h_min(&self) -> f64 {
        8.0 * f64::EPSILON * self.y.t.abs().max(self.model.t_char)
    }

    fn budget(&self) -> Result<(), SimError> {
        if self.stats.steps >= self.max_steps {
            return Err(SimError::StepBudget {
                t: self.y.t,
                max_steps: self.max_steps,
                state: self.err_state(),
            });
        }
        if (self.stats.steps + self.stats.rejected).is_multiple_of(256) {
            let wall = self.start.elapsed().as_secs_f64();
            if wall > self.max_wall_s {
                return Err(SimError::WallBudget {
                    t: self.y.t,
                    max_wall_s: self.max_wall_s,
                    state: self.err_state(),
                });
            }
        }
        Ok(())
    }

    /// Try a step; `Ok(None)` for a failed stage solve.
    fn try_step(&mut self, y: &State, h: f64) -> Result<Option<esdirk::StepOut>, StepFail> {
        let r = match self.engine {
            Engine::Implicit => esdirk::step(&self.model, &self.drive, y, h, self.tol),
            Engine::Dp8 => self.dp8_step(y, h),
            Engine::Explicit(kind) => {
                explicit::macro_step(&self.model, &self.drive, y, h, self.tol, kind, self.h_inner)
                    .map(|(o, hi)| {
                        self.h_inner = hi;
                        o
                    })
            }
        };
        match r {
            Ok(o) => {
                self.stats.rhs_evals += o.evals;
                Ok(Some(o))
            }
            Err(StepFail::NoRoot) => {
                self.stats.rhs_evals += 12;
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }

    /// One DP8 step, reusing the cached first stage when it belongs to `y`. Under `auto`, a step
    /// whose trial stage meets G ≤ 0 (infinite healing speed) is taken by the implicit method
    /// instead; the next step tries DP8 again.
    fn dp8_step(&mut self, y: &State, h: f64) -> Result<esdirk::StepOut, StepFail> {
        let cached = self.fsal.as_ref().and_then(|(ys, r, fq)| {
            let same_t = (ys.t - y.t).abs() <= 8.0 * f64::EPSILON * y.t.abs();
            // The very state the cached rates belong to (an identity test, hence bitwise).
            let same = |p: f64, q: f64| p.to_bits() == q.to_bits();
            (same_t
                && same(ys.x, y.x)
                && same(ys.v, y.v)
                && same(ys.a, y.a)
                && ys.contact == y.contact)
                .then_some((*r, *fq))
        });
        let mut extra = 0;
        let k1 = match cached {
            Some(r) => Ok(r),
            None => {
                extra = 1;
                erk::rates_at(&self.model, &self.drive, y)
            }
        };
        let r =
            k1.and_then(|(k1, fq1)| erk::step(&self.model, &self.drive, y, &k1, &fq1, h, self.tol));
        match r {
            Ok((mut o, k_end, fq_end)) => {
                o.evals += extra;
                self.fsal = Some((o.y, k_end, fq_end));
                Ok(o)
            }
            Err(StepFail::Singular) if self.auto => {
                self.stats.rhs_evals += extra;
                self.implicit_rescues += 1;
                esdirk::step(&self.model, &self.drive, y, h, self.tol)
            }
            Err(e) => {
                self.stats.rhs_evals += extra;
                Err(e)
            }
        }
    }

    /// Locate the earliest crossing of `w` within the step y0 → y1 (length h) by Illinois
    /// regula falsi on the step length, each trial being a fresh step from y0. Returns the
    /// post-event state (or the pre-event one if the post side has no state: collapse).
    fn locate(&mut self, w: Watch, y0: &State, y1: Option<State>, h: f64) -> State {
        let g_of = |run: &Self, y: Option<&State>| match y {
            Some(y) => run.watch_value(w, y),
            None => -run.model.a_floor, // failed stage solve: the contact has collapsed
        };
        let (mut lo, mut glo, mut ylo) = (0.0, self.watch_value(w, y0), *y0);
        let (mut hi, mut ghi, mut yhi) = (h, g_of(self, y1.as_ref()), y1);
        let mut side = 0i32;
        for _ in 0..200 {
            if hi - lo <= self.event_tol.max(4.0 * f64::EPSILON * y0.t.abs()) {
                break;
            }
            let mut th = (lo * ghi - hi * glo) / (ghi - glo);
            if !th.is_finite() || th <= lo || th >= hi {
                th = 0.5 * (lo + hi);
            }
            // Keep trial points away from the ends so the bracket always shrinks.
            let span = hi - lo;
            th = th.clamp(lo + 1e-3 * span, hi - 1e-3 * span);
            let yt = match self.try_step(y0, th) {
                Ok(Some(o)) => Some(o.y),
                _ => None,
            };
            let gt = g_of(self, yt.as_ref());
            if Self::crossed(w, glo, gt) {
                hi = th;
                ghi = gt;
                yhi = yt;
                if side == 1 {
                    glo *= 0.5;
                }
                side = 1;
            } else {
                lo = th;
                glo = gt;
                if let Some(y) = yt {
                    ylo = y;
                }
                if side == -1 {
                    ghi *= 0.5;
                }
                side = -1;
            }
        }
        match yhi {
            Some(y) => y,
            None => ylo,
        }
    }

    /// The contact forms at impact; a backward-Euler kick gives the healing rate of the new state.
    fn form_contact(&mut self) -> Result<(), SimError> {
        let a0 = match self.formation {
            ContactFormation::JumpIn => self.model.a_jump,
            ContactFormation::Seed(r) => r,
        };
        self.y.contact = true;
        self.y.a = a0;
        self.y.adot = 0.0;
        self.collapse_at = None;
        self.refresh();
        self.event(EventKind::Impact, &self.y.clone());
        let hk = 1e-7 * self.model.t_char;
        match esdirk::backward_euler(&self.model, &self.drive, &self.y, hk) {
            Ok(o) => {
                self.stats.rhs_evals += o.evals;
                let y0 = self.y;
                self.y = o.y;
                self.output(&y0, &o.y);
            }
            Err(StepFail::NoRoot) => {
                let y = self.y;
                self.lose_contact(&y);
            }
            Err(StepFail::NonFinite | StepFail::Explicit(_) | StepFail::Singular) => {
                return Err(SimError::NonFinite {
                    t: self.y.t,
                    state: self.err_state(),
                })
            }
        }
        Ok(())
    }

    fn lose_contact(&mut self, y: &State) {
        self.y = *y;
        self.event(EventKind::ContactLoss, y);
        let loss = *self.events.last().unwrap_or(&Event {
            kind: EventKind::ContactLoss,
            time: y.t,
            stage: self.stage,
            state: self.sample_of(y),
        });
        self.y.contact = false;
        self.y.a = 0.0;
        self.y.adot = 0.0;
        self.collapse_at = None;
        self.refresh();
        self.pending_loss = if self.in_pulloff { Some(loss) } else { None };
    }

    /// Can the sphere, now out of contact, never touch the substrate again (in this stage)?
    fn no_return(&self, kind: StageKind, loss_t: f64) -> bool {
        let y = &self.y;
        let m = &self.model;
        let xb_max = if self.drive.shaker { m.xb_amp } else { 0.0 };
        let moving_away = kind != StageKind::Approach;
        let bound = match m.mech {
            Mechanics::Rigid | Mechanics::QuasiStatic => {
                if moving_away {
                    Some(self.drive.x_k(y.t))
                } else {
                    None
                }
            }
            Mechanics::Dynamic => {
                if m.free_holder {
                    if m.g <= 0.0 && y.v < 0.0 {
                        Some(f64::NEG_INFINITY)
                    } else {
                        None
                    }
                } else if moving_away {
                    let cv = if m.contact_damping { 0.0 } else { m.c };
                    let xeq = self.drive.x_k(y.t) + (m.m * m.g - cv * self.drive.xk_speed) / m.k;
                    let xi = y.x - xeq;
                    let vi = y.v - self.drive.xk_speed;
                    Some(xeq + (xi * xi + m.m * vi * vi / m.k).sqrt())
                } else {
                    None
                }
            }
        };
        if let Some(b) = bound {
            if b + xb_max < 0.0 {
                return true;
            }
        }
        // Fallback: a generous time without re-impact.
        let wn = if m.mech == Mechanics::Dynamic && m.k > 0.0 {
            (m.k / m.m).sqrt()
        } else {
            0.0
        };
        let t_osc = if wn > 0.0 { 2.0 * PI / wn } else { 0.0 };
        let t_base = if m.omega > 0.0 {
            2.0 * PI / m.omega
        } else {
            0.0
        };
        let wait = 50.0 * t_osc.max(t_base);
        moving_away && wait > 0.0 && y.t - loss_t > wait
    }

    fn run_stage(&mut self, idx: usize, st: &crate::scenario::Stage) -> Result<(), SimError> {
        self.stage = idx;
        let t0 = self.y.t;
        let speed = match st.kind {
            StageKind::Approach => st.speed,
            StageKind::Hold => 0.0,
            StageKind::Unload => -st.speed,
        };
        self.drive.xk0 = self.drive.x_k(t0);
        self.drive.tk0 = t0;
        self.drive.xk_speed = speed;
        match st.vibration {
            Some(true) => {
                self.off_pending = false;
                if self.model.omega > 0.0 && !self.drive.shaker {
                    self.drive.shaker = true;
                    self.drive.t_on = t0;
                    self.start_cycles();
                }
            }
            Some(false) if self.drive.shaker => self.off_pending = true,
            _ => {}
        }
        self.refresh();
        let y = self.y;
        self.event(EventKind::StageStart, &y);
        let (t_end, is_duration) = match st.until {
            Until::Duration(d) => (t0 + d, true),
            _ => (t0 + st.max_duration, false),
        };
        let preload = match st.until {
            Until::Preload(p) => Some(p),
            _ => None,
        };
        let pulloff = matches!(st.until, Until::PullOff);
        self.in_pulloff = pulloff;
        if pulloff && !self.detached {
            // The pull-off summary describes the pull-off stage.
            self.min_force = None;
            self.min_cycle = None;
        }
        if let (Some(p), true) = (preload, self.y.contact) {
            if self.force_of(&self.y) >= p {
                let y = self.y;
                self.event(EventKind::PreloadReached, &y);
                return Ok(());
            }
        }
        let mut h_max = f64::INFINITY;
        if self.model.omega > 0.0 {
            h_max = 2.0 * PI / self.model.omega / 8.0;
        }
        h_max = h_max.min(self.model.t_char * 10.0);
        loop {
            if self.stopped {
                return Ok(());
            }
            self.budget()?;
            let y0 = self.y;
            if !y0.contact && self.watch_value(Watch::Impact, &y0) >= 0.0 {
                // Out of contact with no gap (e.g. the spring end driven into the substrate at
                // a stage start): contact forms now.
                self.pending_loss = None;
                self.form_contact()?;
                continue;
            }
            let t_bound = self.next_boundary();
            let t_lim = t_end.min(t_bound);
            let snap = 16.0 * f64::EPSILON * y0.t.abs().max(self.model.t_char);
            if t_lim - y0.t <= snap {
                // Boundaries are hit exactly; a rounding sliver between two of them (a stage end
                // and a period boundary computed differently, e.g. a stage of exactly one base
                // period) is absorbed here, and a period boundary within it is recorded.
                if t_bound - y0.t <= snap {
                    self.y.t = self.y.t.max(t_bound);
                    self.record_cycle();
                    continue;
                }
                self.y.t = self.y.t.max(t_lim);
                let y0 = self.y;
                if is_duration {
                    self.event(EventKind::DurationElapsed, &y0);
                    return Ok(());
                }
                return Err(self.timeout(idx, st));
            }
            let mut h = self.h.min(h_max);
            let interpolated_samples = self.wants_samples && self.sample_dt > 0.0;
            if matches!(self.engine, Engine::Explicit(_))
                || (self.engine == Engine::Dp8 && interpolated_samples)
            {
                // Samples between step ends come from a cubic Hermite interpolant: keep the
                // ode_solvers macro steps, and DP8's long steps when samples are on a grid, to
                // 1/16 of a base period (interpolation error ≈ (ωh)⁴/384 ≈ 6e-5 of the amplitude,
                // against 1e-3 at 1/8).
                h = h.min(0.5 * h_max);
            }
            // Steps shortened to end on a turning point keep the step proposal for the next one.
            let mut shortened = false;
            if let Some(hc) = self.h_cut.take() {
                h = h.min(hc);
                shortened = true;
            } else if let (Engine::Dp8, Some(tk)) = (self.engine, self.kink_ahead) {
                // End the step at the predicted turning point rather than cut it afterwards.
                let d = tk - y0.t;
                if d > 0.05 * h && d < h {
                    h = d;
                    shortened = true;
                }
            }
            if y0.contact {
                if let Some(tc) = self.collapse_at {
                    if tc - y0.t <= self.event_tol.max(self.h_min()) {
                        self.lose_contact(&y0);
                        continue;
                    }
                    h = h.min(0.5 * (tc - y0.t));
                }
            }
            let mut hits = false;
            if h >= t_lim - y0.t || t_lim - y0.t - h < 1e-3 * h {
                h = t_lim - y0.t;
                hits = true;
            }
            let out = match self.try_step(&y0, h) {
                Ok(Some(o)) => o,
                Ok(None) => {
                    self.stats.rejected += 1;
                    if y0.contact && y0.adot < 0.0 {
                        // A shrinking contact with no stage root: it collapses before t + h.
                        let tc = y0.t + h;
                        self.collapse_at = Some(self.collapse_at.map_or(tc, |c| c.min(tc)));
                        self.h = 0.5 * h;
                        continue;
                    }
                    // Healing (e.g. right after a seeded impact, ȧ huge): the step is too long
                    // for the stage rates; shorten it.
                    self.h = 0.25 * h;
                    if self.h <= self.h_min() {
                        return Err(SimError::StepSizeUnderflow {
                            t: y0.t,
                            h: self.h,
                            state: self.err_state(),
                        });
                    }
                    continue;
                }
                Err(StepFail::Explicit(reason)) => {
                    // Only an explicitly requested `ode_solvers` method gets here (`auto` runs
                    // DP8 or the implicit method).
                    return Err(SimError::Explicit {
                        method: self.engine.name().into(),
                        t: y0.t,
                        reason: reason.into(),
                        state: self.err_state(),
                    });
                }
                Err(StepFail::Singular) => {
                    // A DP8 trial stage met G ≤ 0: the step is too long for the healing rate.
                    self.stats.rejected += 1;
                    self.h = 0.25 * h;
                    if self.h <= self.h_min() {
                        return Err(SimError::Explicit {
                            method: self.engine.name().into(),
                            t: y0.t,
                            reason: "the contact edge is compressive or G <= 0 (infinite \
                                     healing speed) at every step size"
                                .into(),
                            state: self.err_state(),
                        });
                    }
                    continue;
                }
                Err(_) => {
                    self.stats.rejected += 1;
                    if h <= self.h_min() {
                        return Err(SimError::NonFinite {
                            t: y0.t,
                            state: self.err_state(),
                        });
                    }
                    self.h = 0.25 * h;
                    continue;
                }
            };
            // A DP8 step across a turning point of the contact line (ȧ = 0) is redone to end
            // there: ȧ ∝ |G − w0|^(1/n) is not smooth at the turning point, and the 8th-order
            // weights integrate that singular part ~600× better from one side (DOP853 weights on
            // τ^1.88: 1.4e-5 of the integral, against up to 8.6e-3 when it lies inside).
            if let Some(f) = out.kink {
                if !self.kink_cut && f > 0.02 && f < 0.98 && h * f > self.h_min() {
                    self.stats.rejected += 1;
                    self.kink_cut = true;
                    self.h_cut = Some(h * f);
                    continue;
                }
            }
            self.kink_cut = false;
            let e = out.err_exp;
            if out.err > 1.0 {
                self.stats.rejected += 1;
                self.rejected_last = true;
                let fac = (0.9 * out.err.powf(-e)).clamp(0.1, 0.9);
                self.h = h * fac;
                if y0.contact && y0.adot < 0.0 && self.h <= self.event_tol.max(self.h_min()) {
                    // The radius runs into a turning point or a → 0 with unbounded speed faster
                    // than the event tolerance resolves: the contact is lost here.
                    self.lose_contact(&y0);
                    continue;
                }
                if self.h <= self.h_min() {
                    return Err(SimError::StepSizeUnderflow {
                        t: y0.t,
                        h: self.h,
                        state: self.err_state(),
                    });
                }
                continue;
            }
            // Elementary control, with no growth right after a rejection (Hairer's rule). A PI
            // controller (Gustafsson, h err^(−α) err_prev^β with α = 1/4 − 0.75 β) was measured
            // on 1 s at 400 Hz with the implicit method: β = 0.04…0.12 cuts rejections 1.4–100×
            // but adds as many accepted steps; error per rhs evaluation is unchanged within 10%,
            // so the simpler rule stays.
            let mut fac = if out.err > 0.0 {
                (0.9 * out.err.powf(-e)).clamp(0.2, 5.0)
            } else {
                5.0
            };
            if self.rejected_last {
                fac = fac.min(1.0);
                self.rejected_last = false;
            }
            let h_next = h * fac;
            self.h = if hits || shortened {
                self.h.max(h_next)
            } else {
                h_next
            };
            self.kink_ahead = out.kink_ahead;
            let mut y1 = out.y;
            if hits {
                y1.t = t_lim;
            }
            // Events inside the step.
            let watches: [Option<Watch>; 2] = if y0.contact {
                [Some(Watch::Loss), preload.map(Watch::Preload)]
            } else {
                [Some(Watch::Impact), None]
            };
            let mut first: Option<(Watch, State)> = None;
            for w in watches.into_iter().flatten() {
                let (g0, g1) = (self.watch_value(w, &y0), self.watch_value(w, &y1));
                if Self::crossed(w, g0, g1) {
                    let ye = self.locate(w, &y0, Some(y1), h);
                    if first.as_ref().is_none_or(|(_, f)| ye.t < f.t) {
                        first = Some((w, ye));
                    }
                }
            }
            self.stats.steps += 1;
            if let Some((w, ye)) = first {
                self.output(&y0, &ye);
                self.track_force(&y0, &ye);
                self.y = ye;
                match w {
                    Watch::Loss => {
                        self.lose_contact(&ye);
                    }
                    Watch::Impact => {
                        self.pending_loss = None;
                        self.form_contact()?;
                    }
                    Watch::Preload(_) => {
                        self.event(EventKind::PreloadReached, &ye);
                        return Ok(());
                    }
                }
                continue;
            }
            if !(y1.x.is_finite() && y1.v.is_finite() && y1.a.is_finite() && y1.a >= 0.0) {
                return Err(SimError::NonFinite {
                    t: y0.t,
                    state: self.err_state(),
                });
            }
            self.output(&y0, &y1);
            self.track_force(&y0, &y1);
            self.y = y1;
            // A period boundary a rounding sliver after the stage end (a stage of whole periods)
            // still closes its cycle.
            if hits && t_bound - t_lim <= snap {
                self.record_cycle();
            }
            if pulloff && !self.y.contact {
                if let Some(loss) = self.pending_loss {
                    if self.no_return(st.kind, loss.time) {
                        let e = Event {
                            kind: EventKind::PullOff,
                            ..loss
                        };
                        self.obs.event(&e);
                        self.events.push(e);
                        self.detached = true;
                        self.shaker_at_detach = Some(self.drive.shaker);
                        self.pending_loss = None;
                        return Ok(());
                    }
                }
            }
            if hits && t_end <= t_lim {
                if is_duration {
                    let y = self.y;
                    self.event(EventKind::DurationElapsed, &y);
                    return Ok(());
                }
                return Err(self.timeout(idx, st));
            }
        }
    }

    fn timeout(&self, idx: usize, st: &crate::scenario::Stage) -> SimError {
        SimError::StageTimeout {
            stage: idx,
            until: match st.until {
                Until::Duration(_) => "duration".into(),
                Until::Preload(p) => format!("until preload {p} N"),
                Until::PullOff => "until pull-off".into(),
            },
            max_duration: st.max_duration,
            t: self.y.t,
            state: self.err_state(),
        }
    }
}

/// Simulate a scenario: the stage protocol from its initial state, feeding `obs` with samples,
/// events and cycle records. See the module documentation of [`crate::dynamics`].
pub fn simulate(s: &Scenario, obs: &mut dyn Observer) -> Result<RunResult, SimError> {
    let start = Instant::now();
    let scales = super::protocol::run_scales(&s.initial, &s.stages);
    let model = model::resolve(&s.rig, scales).map_err(SimError::Setup)?;
    let engine = match s.solver.method {
        Method::Auto => auto_engine(s),
        Method::Implicit => Engine::Implicit,
        Method::Dopri5 => Engine::Explicit(ExplicitKind::Dopri5),
        Method::Dop853 => Engine::Explicit(ExplicitKind::Dop853),
        Method::Dp8 => Engine::Dp8,
    };
    let auto = s.solver.method == Method::Auto;
    let (y, drive) = initial_state(s, &model)?;
    let tol = Tol {
        rtol: s.solver.rtol,
        atol: s.solver.atol,
    };
    let sample_dt = if s.output.sample_rate > 0.0 {
        1.0 / s.output.sample_rate
    } else {
        0.0
    };
    let wants_samples = obs.wants_samples();
    let mut run = Run {
        h: 1e-3 * model.t_char,
        model,
        tol,
        max_steps: s.solver.max_steps,
        max_wall_s: s.solver.max_wall_s,
        event_tol: s.solver.event_tol.max(0.0),
        formation: s.rig.formation,
        obs,
        y,
        drive,
        stage: 0,
        events: Vec::new(),
        cycles: Vec::new(),
        stats: Stats::default(),
        start,
        cycle_index: 0,
        cycle_t0: 0.0,
        cycle_q0: [0.0; NQ],
        cycle_e0: 0.0,
        off_pending: false,
        sample_dt,
        next_sample: 0.0,
        stopped: false,
        min_force: None,
        min_cycle: None,
        shaker_at_detach: None,
        pending_loss: None,
        detached: false,
        collapse_at: None,
        in_pulloff: false,
        engine,
        auto,
        h_inner: 0.0,
        wants_samples,
        fsal: None,
        implicit_rescues: 0,
        kink_cut: false,
        rejected_last: false,
        kink_ahead: None,
        h_cut: None,
    };
    if let (Engine::Explicit(_) | Engine::Dp8, true) = (engine, run.model.rate_independent) {
        return Err(SimError::Explicit {
            method: engine.name().into(),
            t: 0.0,
            reason: "the adhesion law is rate-independent: the contact radius is algebraic \
                     (G = w0) and has no explicit rate"
                .into(),
            state: run.err_state(),
        });
    }
    run.refresh();
    let y0 = run.y;
    run.output(&y0, &y0);
    if run.sample_dt > 0.0 {
        run.next_sample = run.sample_dt;
    }
    for (i, st) in s.stages.iter().enumerate() {
        if run.stopped {
            break;
        }
        run.run_stage(i, st)?;
    }
    run.stats.wall_s = run.start.elapsed().as_secs_f64();
    let f0 = jkr::load_controlled_pull_off_force(&run.model.mat, run.model.w0);
    // The shaker state at detachment decides which minimum is the pull-off force: the most
    // tensile cycle mean while vibrating, the most tensile instantaneous force otherwise (each
    // taken over the pull-off stage, or the whole run without one). Without detachment: the
    // cycle means if there are any.
    let vibrating = run.shaker_at_detach.unwrap_or(run.min_cycle.is_some());
    let pick = if vibrating {
        run.min_cycle.or(run.min_force)
    } else {
        run.min_force.or(run.min_cycle)
    };
    let (force, time) = pick.unwrap_or((0.0, 0.0));
    let final_state = run.sample_of(&run.y);
    Ok(RunResult {
        pull_off: PullOffSummary {
            force,
            amplification: force / f0,
            time,
        },
        detached: run.detached,
        events: run.events,
        stats: run.stats,
        method: {
            let mut m = engine.name().to_string();
            if auto {
                m = format!(
                    "{m}; auto: implicit for rate-independent laws, seeded contact formation and \
                     scenes without inertia (rigid link, m = 0), DP8 otherwise, taking a step \
                     implicitly where a DP8 stage meets G <= 0"
                );
            }
            if run.implicit_rescues > 0 {
                m.push_str(&format!(
                    "; {} steps taken implicitly where DP8 met G <= 0",
                    run.implicit_rescues
                ));
            }
            if run.stopped {
                m.push_str("; stopped by the observer");
            }
            m
        },
        final_state,
        cycles: run.cycles,
    })
}

/// The initial state and drive of a scenario (see the module documentation).
pub fn initial_state(s: &Scenario, m: &Model) -> Result<(State, Drive), SimError> {
    let mut y = State {
        t: 0.0,
        x: 0.0,
        v: 0.0,
        acc: 0.0,
        a: 0.0,
        adot: 0.0,
        contact: false,
        q: [0.0; NQ],
    };
    let xk;
    match s.initial {
        Initial::Preload(p) => {
            let a = jkr::equilibrium_radius_for_force(&m.mat, p, m.w0).ok_or_else(|| {
                SimError::Setup(format!(
                    "initial preload {p} N is below the JKR pull-off force {} N",
                    jkr::load_controlled_pull_off_force(&m.mat, m.w0)
                ))
            })?;
            let d = jkr::equilibrium_indentation(&m.mat, a, m.w0);
            y.x = d;
            y.a = a;
            y.contact = true;
            xk = match m.mech {
                Mechanics::Rigid => d,
                _ if m.free_holder => {
                    let wgt = m.m * m.g;
                    if (p - wgt).abs() > 1e-9 * p.abs().max(wgt.abs()) {
                        return Err(SimError::Setup(format!(
                            "holder = none: the preload ({p} N) must equal the weight m g = {wgt} N"
                        )));
                    }
                    0.0
                }
                _ => d + (p - m.m * m.g) / m.k,
            };
        }
        Initial::State {
            x_s,
            v_s,
            a,
            a_dot,
            x_k,
        } => {
            let vals = [x_s, v_s, a, a_dot, x_k];
            if vals.iter().any(|v| !v.is_finite()) || a < 0.0 {
                return Err(SimError::Setup(format!(
                    "initial state must be finite with a >= 0: x_s = {x_s}, v_s = {v_s}, a = {a}, a_dot = {a_dot}, x_k = {x_k}"
                )));
            }
            y.x = x_s;
            y.v = v_s;
            y.a = a;
            y.contact = a > 0.0;
            y.adot = if y.contact { a_dot } else { 0.0 };
            xk = match m.mech {
                Mechanics::Rigid => x_s,
                _ => x_k,
            };
        }
        Initial::Gap(g0) => {
            if !(g0.is_finite() && g0 > 0.0) {
                return Err(SimError::Setup(format!("initial gap {g0} m must be > 0")));
            }
            y.x = -g0;
            xk = match m.mech {
                Mechanics::Dynamic if !m.free_holder => y.x - m.m * m.g / m.k,
                Mechanics::Dynamic => 0.0,
                _ => y.x,
            };
        }
    }
    let drive = Drive {
        xk0: xk,
        tk0: 0.0,
        xk_speed: 0.0,
        shaker: false,
        t_on: 0.0,
    };
    Ok((y, drive))
}
