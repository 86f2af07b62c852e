//! Envelope following: under a steady vibration the state at the start of each base period
//! (the stroboscopic state) drifts slowly — the dwell settles, the spring end creeps at a few
//! µm/s, the mean contact radius ratchets — while the state within each period repeats. Instead
//! of integrating every period, the envelope method integrates single periods exactly and
//! advances the stroboscopic state over many periods at once with a step-size-controlled
//! method in slow time, as circuit simulators do for oscillators (Petzold, SIAM J. Sci. Stat.
//! Comput. 2 (1981) 85; Kundert, White & Sangiovanni-Vincentelli, 1990).
//!
//! # The envelope equation
//! With P_k the one-period map from the start of period k (the spring end and the base phase
//! are those of period k), the stroboscopic states satisfy y_{k+1} − y_k = P_k(y_k) − y_k. The
//! envelope z(τ) is the smooth curve through them (τ in periods). One evaluation of
//! g(z, τ) = P_τ(z) − z is one period integrated exactly ([`Simulator::trial_period`]), and g is
//! the envelope's forward difference over a period, not its derivative:
//! z(τ + 1) − z(τ) = z′(τ + ½) + z‴/24 + …, so dz/dτ at τ + ½ is g(z(τ), τ) to second order.
//! Read as the derivative at τ itself (dz/dτ = g(z), as this module did before) it is first
//! order: that solution misses the map's orbit by z″/2 per period, and along the creeping
//! radius, which forgets an error only over 1/(1 − μ) periods, by about z″/(2 (1 − μ)).
//!
//! # The integrator in slow time
//! Variable-step BDF2 on (x_s, v_s, a), its derivative taken where g gives it: from the envelope
//! points z_n, z_{n−1} (τ_n, τ_{n−1}), the new point z at τ_n + m (m whole periods) solves
//! ℓ₀′ z + ℓ₁′ z_n + ℓ₂′ z_{n−1} = P(z) − z, with ℓⱼ′ the derivatives at τ_n + m + ½ of the
//! Lagrange basis on (τ_n + m, τ_n, τ_{n−1}): the quadratic through the three points has the
//! slope g(z) half a period after the new point. Measured on the 300 Hz paper protocol's unload
//! at a step of two periods from directly integrated boundaries (scaled): the predictor missed
//! the map's orbit (the trial periods iterated) by 4e-10, the plain BDF2 corrector (ℓⱼ′ at
//! τ_n + m) by 2.4e-8 — 0.6 times the second difference of the boundaries, 4.6e-8, as above —
//! and this one by 1.6e-10. On a map whose orbit is known in closed form it misses by 10–370
//! times less for steps of 16 down to 2 periods (the module's tests). The fast mechanical
//! modes (the sphere's ring-down, multipliers ~0.9 e^{±i ω_r T} per period) are stiff in slow
//! time: an explicit step over many periods would blow them up; the corrector damps them as
//! BDF2 does (tested for every multiplier in the disc of radius 0.99, steps of 2–128 periods).
//! Consecutive steps may grow at most 2× (variable-step BDF2 is zero-stable below 1 + √2).
//! The envelope points are the exact boundaries while the run integrates directly and the jump
//! targets while it jumps (the boundary one period after a jump target, integrated for the
//! output, is not one: its spacing would make the steps too uneven). Newton on the corrector
//! with J = ∂P/∂y by forward differences (one trial period per unknown), kept for four jumps or
//! while Newton converges in ≤ 2 iterations. Predictor: the quadratic through the last three
//! envelope points. Trial periods run at 1/100 of the run's tolerances: an error of one trial
//! period enters a jump m times, and it is systematic (every trial starts alike).
//!
//! # Error control
//! The local error of the corrector is estimated from its distance to the predictor (Milne's
//! device for variable steps: both miss by multiples of the envelope's third derivative, and the
//! corrector's share of the distance is [`milne_ratio`], 1/3 for a step of two periods from
//! boundaries one apart, 0.20 for one of 8 from boundaries 8 apart), in the
//! scales of the steady-state module (x_s by the indentation amplitude, v_s by ω times it, a by
//! the mean radius). A jump of m periods may use m (1 − μ) of the tolerance (at most all of it),
//! μ the largest Floquet multiplier of the map (the eigenvalues of J): the creeping contact
//! radius forgets an error only over 1/(1 − μ) periods, so the jumps within that memory add up
//! their errors (measured on the 10 µm paper protocols, μ ≈ 0.997: without this share the
//! contact radius drifted 1e-4 from direct integration by the pull-off, whatever the local
//! tolerance; with it 2e-7). The next skip is m (tol/err)^(1/3) within [m/5, 4m]. A step whose
//! trial period loses or regains contact, whose Newton iteration fails, or whose error is too
//! large is retried with a smaller m (the first step of a run of attempts is not: below); below
//! two periods the run integrates directly for a while and tries again. No step is tried while
//! the newest two envelope points differ by more than a tenth of the scales (`FAST_DRIFT`):
//! that is no slow drift (the ring-up after the shaker starts), and its trial periods are the
//! most expensive of the run.
//!
//! # What it costs
//! A trial period at 1/100 of the tolerances costs 1.3–2 times a direct one, and a step takes a
//! Newton period or two, a Jacobian (three more) every few steps: a jump of two periods costs
//! more than integrating them. So each run of attempts keeps its account — the RHS evaluations
//! of its trial periods against those of the periods it jumped over, at the measured cost of a
//! direct period — and when it ends (the skip fell below two periods) the run integrates
//! directly for 16 periods if it paid, otherwise for twice as long as after the last one that
//! did not (16, 32, 64, …): where the error share leaves only skips of two periods, the
//! attempts cost a logarithm of the stage's length instead of a share of it. On the unloads of
//! the bundled 10 µm paper protocols (μ = 0.995–0.999), with the plain BDF2 corrector, the
//! attempts every 17 periods had spent 823 trial periods to jump over 230 periods at 300 Hz;
//! with this account 52, and the run took 13 % fewer evaluations (1.48 M → 1.29 M; 200 Hz
//! 1.01 M → 0.87 M, 400 Hz 1.90 M → 1.72 M). A run of attempts also ends once its jumps stop
//! paying: when the error test proposes a skip shorter than 1 + what its trial periods cost per
//! jump so far, in direct periods ([`Envelope::break_even`]; the period after a jump target is
//! integrated directly). Towards pull-off the error grows and the skips shrink: at
//! `envelope_tol = 1e-8` on the 400 Hz protocol one run of attempts went on to the end of the
//! unload in jumps of three periods that cost 2.7 trial periods each.
//!
//! No run of attempts starts from directly integrated boundaries where a skip long enough to
//! pay ([`SCREEN_SKIP`], 8 periods) could not pass the error test, and that is predicted without
//! a trial period ([`Envelope::predicted_error`]): the third difference of the last 25 boundaries
//! taken 8 apart is the predictor's error on such a step, Milne's device takes 0.20 of it, and
//! the step's share of the tolerance uses the stage's last multiplier (its 0.999 limit before the
//! stage's first Jacobian). It keeps the trial periods out of the ring-down that follows a
//! stage's start (on the 300 Hz protocol at `envelope_tol = 1e-6`, the four attempts of the
//! vibrating dwell, errors 10²–10⁵ times the tolerance, and those of the unload's first 1 000
//! periods), out of the last periods before pull-off, and out of a run whose tolerance no skip
//! can meet (`envelope_tol = 1e-8` on the 200 and 300 Hz protocols: no trial period, the run is
//! `off`'s to the bit). The run of attempts then starts from the boundaries the screen read,
//! 8 apart, so that its first step is the one predicted (of 7–16 periods, by the predicted
//! error), not one of two periods from boundaries one apart followed by steps of 4 and 8, each
//! a Newton solve. Where the first step is refused all the same, the run of attempts ends there
//! instead of trying shorter ones: the screen errs where the trial periods' own error nears
//! the step's share (`envelope_tol = 1e-8` on the 400 Hz protocol without samples: four runs of
//! attempts, 11 trial periods, +0.26 % against `off`) and at the end of the unload, where a
//! shorter step that passes does not pay.
//!
//! With the plain BDF2 corrector (above) a step of two periods from directly integrated
//! boundaries passed with 0.5–0.85 of its share at `envelope_tol = 1e-6`, its miss being the
//! corrector's own, z″/2 per period (not the difference between the maps of the direct and of
//! the trial periods: measured, 1.5e-11 per period on the 300 Hz unload, 1/300 of the miss);
//! the next could not be longer, and `auto` cost more than
//! `off` (300 Hz: 1.274 M evaluations with samples, 22 trial periods to skip 16, against
//! 1.271 M; 200 Hz +0.4 %, 400 Hz +0.6 %). Now, with samples as `djkr run` writes them, `auto`
//! takes 72 %, 62 % and 53 % of `off`'s evaluations on the 200, 300 and 400 Hz protocols
//! (0.615 M, 0.792 M and 0.900 M against 0.853 M, 1.271 M and 1.689 M; 60–79 % without
//! samples), jumping over 1 900–5 000 periods in steps of up to 100, and pulls off within
//! 0.6–1.8e-7 (relative) of `off`. At `envelope_tol = 1e-5`: 33–46 % (0.390 M, 0.474 M,
//! 0.550 M, against 0.399 M, 0.495 M, 0.595 M before), within 2.5–3.1e-6 of `off` (1.0–3.4e-5
//! before: the plain corrector's miss, which its Milne estimate understated 3–5 times, went
//! into every jump). At 1e-7, 82–97 % of `off` (89–99.5 % without samples); at 1e-4,
//! 24–28 % (as before, within 1 %).
//!
//! # Where it stops
//! Where the largest multiplier μ reaches 0.999, perturbations no longer decay and the
//! envelope's errors would grow. In a stage that ends at pull-off this is the approach to the
//! loss of stability (pull-off under vibration, a fold of the periodic orbit): the stage is
//! integrated directly to its end. In any other stage it is a transient — the ring-down and the
//! ratcheting contact radius after the shaker starts (1 s at 400 Hz on the light rig: μ = 1.11
//! three periods in, 0.997 at 20, 0.90 from 100 on) — so jumps pause as after an unprofitable
//! run of attempts (16 periods, then 32, 64, …) and are tried again. Where the drift is slow
//! and strongly damped (the strong vibration of the paper's regime) the skips grow to hundreds
//! of periods; where the radius barely forgets (μ within 0.3 % of 1) the error share leaves
//! little to skip, and `auto` integrates most periods directly, as it should.
//!
//! # A periodic steady state
//! In a hold under a steady shaker the map is the same every period (P_k = P), and once the
//! run has settled onto the periodic orbit, z* = P(z*), every later boundary of the stage is z*.
//! The BDF would still walk there in steps growing at most 2× each, a Newton solve of trial
//! periods per step, and its error estimate, fed by directly integrated boundaries whose
//! integration errors the predictor amplifies, refuses short jumps near the orbit (on the
//! compiled peer's benchmark scene, 1 s at 400 Hz: refused at periods 104, 121 and 138, where
//! the map contracts by μ = 0.90 per period). So where the drift per period, over 1 − r, puts
//! the run within 1e-3 (scaled) of a fixed point — r the factor the drift shrank by per period
//! over the last 16 periods, the slowest multiplier the approach shows (not the last Jacobian's
//! μ: Jacobians are rare once unprofitable attempts back off, and one taken during the ring-up
//! says nothing of the approach) — the envelope looks for it by Newton on P(z) = z (shooting)
//! with a fresh Jacobian, and jumps to the stage's end when the last correction is below 1/100
//! of the tolerance, the run's state within 1e-3 of z* (the map is linear on the way), and the
//! transient left after the jump, μ^M |y − z*| over its M periods, below 1/100 of the
//! tolerance. The fixed point is looked for at every boundary, also while the BDF cools down
//! after a refused step (the drift test is its own guard); a failed search waits 16, 32, 64, …
//! periods before the next. On that scene it jumps from period 95 to 398 at rtol 1e-7: a(1 s)
//! within 5e-14 of the jump from period 96 screened by the last Jacobian's μ (25 k
//! evaluations), and within 5e-9 of direct integration of every period (90 k); 22.6 k
//! evaluations, where walking to the orbit with the BDF took 41 k and 73 k with trial periods
//! in the ring-up (above).
//!
//! # What is not produced for skipped periods
//! The periods jumped over have no time-series samples and no period records; the record
//! indices in the output show which periods were integrated. Events cannot happen in them
//! (the trial periods at both ends are smooth). The quadrature states are carried across a jump
//! unchanged (only their differences within a period are used).

use super::simulator::Simulator;
use super::state::State;
use super::types::{CycleRecord, EnvelopeStats, SimError};
use crate::jkr;

/// Settings of envelope following.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvelopeSettings {
    /// Local error tolerance per envelope step, in the scaled norm (dimensionless).
    pub tol: f64,
    /// Largest skip (periods).
    pub max_skip: u64,
    /// Envelope following stops for the rest of the stage once the largest Floquet multiplier of
    /// the one-period map reaches this: perturbations (and the envelope's errors) no longer decay.
    pub max_multiplier: f64,
}

impl Default for EnvelopeSettings {
    fn default() -> Self {
        Self {
            tol: 1e-6,
            max_skip: 100_000,
            max_multiplier: 0.999,
        }
    }
}

/// What [`Envelope::fresh_jacobian`] found.
enum Fresh {
    /// The Jacobian (scaled), the envelope's now, and g(z) = P(z) − z from its first trial
    /// period.
    Map([f64; 3], [[f64; 3]; 3]),
    /// A trial period was not smooth (contact lost or regained, or not integrable).
    NotSmooth,
    /// The largest multiplier reached its limit.
    AtLimit,
}

/// An exact envelope point: the stroboscopic state (x_s, v_s, a) at the start of period τ.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Point {
    tau: f64,
    y: [f64; 3],
}

/// The cost and the gain of a run of envelope attempts (from the end of one pause to the start
/// of the next).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Venture {
    /// RHS evaluations of its trial periods.
    spent: u64,
    /// Periods it jumped over.
    skipped: u64,
    /// Jumps it made.
    jumps: u64,
}

/// One BDF step in slow time, set up from the history.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BdfStep {
    /// The new point's τ (τ_n + m).
    tau: f64,
    /// The step (periods).
    m: u64,
    /// The index of the period the new point starts.
    k: u64,
    /// The share of the distance between corrector and predictor that is the corrector's
    /// error (Milne's device, [`milne_ratio`]).
    milne: f64,
    /// The predictor: the quadratic through the history, at `tau`.
    predicted: [f64; 3],
    /// ℓ₀′, the corrector's coefficient of the new point.
    l0: f64,
    /// Σ_{j≥1} ℓⱼ′ yⱼ over the newest ORDER history points.
    known: [f64; 3],
}

/// Envelope following along one run.
#[derive(Debug, Clone)]
pub struct Envelope {
    settings: EnvelopeSettings,
    /// The last exact envelope points, oldest first (at most 3).
    history: Vec<Point>,
    /// ∂P/∂y in scaled units, and the period index it was taken at.
    jac: Option<[[f64; 3]; 3]>,
    /// The next skip to try (periods).
    skip: f64,
    /// Periods of direct integration left before the next attempt.
    cooldown: u64,
    /// Residual scales (L, ωL, a).
    scales: [f64; 3],
    /// The map lost its stability margin: no more jumps in this stage.
    stop: bool,
    /// The stage ends at pull-off: a multiplier reaching the limit there is the approach to the
    /// loss of stability, and stops the jumps for good; elsewhere (a transient, a slow creep) it
    /// only pauses them for [`Envelope::backoff`] periods.
    towards_pull_off: bool,
    /// Periods of direct integration after the next pause that follows an unprofitable run of
    /// attempts, or the multiplier reaching its limit outside a pull-off stage (doubles each
    /// time; back to [`FIRST_BACKOFF`] after a run of attempts that paid).
    backoff: u64,
    /// What the current run of attempts (since the last pause) cost and gained.
    venture: Venture,
    /// The current pause ([`Envelope::cooldown`]) is a back-off: its periods count in
    /// [`EnvelopeStats::backoff_periods`].
    backing_off: bool,
    /// RHS evaluations the run's jumps saved: the periods jumped over, each at the running
    /// mean cost of a direct period when it was jumped ([`Envelope::affordable`]).
    saved: f64,
    /// The drift per period at the newest boundaries since the history was last forgotten
    /// (period index, [`Envelope::drift`]), oldest first, spanning at most [`DECAY_WINDOW`]
    /// periods.
    drifts: std::collections::VecDeque<(u64, f64)>,
    /// RHS evaluations of a directly integrated period, a running mean (0: none measured yet).
    direct_cost: f64,
    /// The run's RHS evaluations when the last boundary was left (the period since then was
    /// integrated directly); `None` after [`Envelope::forget`].
    evals_left_at: Option<u64>,
    /// The stroboscopic states at the last directly integrated boundaries, each one period after
    /// the one before, oldest first (at most 3 [`SCREEN_SKIP`] + 1): what
    /// [`Envelope::predicted_error`] reads.
    direct: std::collections::VecDeque<[f64; 3]>,
    /// Jumps taken with the current Jacobian.
    jac_age: u32,
    /// The largest Floquet multiplier at the stage's last Jacobian (`None` before it has one).
    multiplier: Option<f64>,
    /// The last boundary was a jump target (the next one is not an envelope point).
    jumped: bool,
    /// The stage repeats the same one-period map every period (a hold under a steady shaker):
    /// a periodic steady state, once reached, holds to the stage's end.
    periodic: bool,
    /// Periods to wait before the next search for a periodic steady state.
    steady_wait: u64,
    /// Multiples of [`COOLDOWN`] periods to wait after the next failed search (doubles with each
    /// failure).
    steady_backoff: u64,
    stats: EnvelopeStats,
}

/// How many direct periods follow a run of attempts that paid, or a drift too fast to follow.
const COOLDOWN: u64 = 16;
/// Direct periods after the first run of attempts that did not pay, or the multiplier first
/// reaching its limit outside a pull-off stage (then twice as many each time).
const FIRST_BACKOFF: u64 = 16;
/// The trial periods' net cost (their RHS evaluations minus those the jumps saved) may reach
/// this share of the run's other evaluations, plus [`BUDGET_ALLOWANCE`] direct periods, before
/// no more are spent ([`Envelope::affordable`]).
const BUDGET_SHARE: f64 = 0.01;
/// Direct periods' worth of trial periods a run may spend beyond [`BUDGET_SHARE`]: what finding
/// out costs before envelope following pays. Measured on the bundled scenes (the paper
/// protocols at `envelope_tol` 1e-6 to 1e-4 and X_b = 10–150 µm, the peer's scene, the gentle
/// and the resonance rig), the net cost beyond 1 % of the run's work peaked at 29–66 periods'
/// worth, 94 on the gentle rig's 3 s ring-up: twice that never binds where following pays.
const BUDGET_ALLOWANCE: f64 = 128.0;
/// The shortest skip that pays for its trial periods: a step takes a Newton period or two and
/// a share of a Jacobian's three, each 1.3–2 direct periods' work, and the period after each jump
/// is integrated directly.
const SCREEN_SKIP: u64 = 8;
/// Trial periods run at this fraction of the run's tolerances. An integration error e of one
/// trial period enters a jump of m periods m times over, and it is systematic (every trial
/// starts the same way), so it accumulates along the unload like m e per jump instead of
/// averaging out like the errors of directly integrated periods: measured on the 400 Hz paper
/// protocol at the run's own tolerance, the contact radius drifted by 1e-7 per jump of 5
/// periods, 1e-4 over the unload, whatever the envelope tolerance.
const TRIAL_TOLERANCE: f64 = 1e-2;
/// A state that moves by more than this fraction of its scales in one period has no slow
/// envelope to follow: no jump is tried (measured on the light rig at 400 Hz / 10 µm: 0.5–0.9
/// per period in the ring-up after the shaker starts, where a trial period at the envelope's
/// tolerance took 3 833 evaluations and the map expanded, μ = 1.11; 0.06 and less from period
/// 20 on).
const FAST_DRIFT: f64 = 0.1;
/// Largest scaled distance from a periodic steady state at which envelope following looks for
/// it (and the largest Newton correction of that search): close enough that the map is linear.
const STEADY_NEAR: f64 = 1e-3;
/// Periods over which the decay of the drift estimates how fast the run approaches a periodic
/// steady state.
const DECAY_WINDOW: u64 = 16;
/// Order of the BDF in slow time (its predictor uses one point more).
const ORDER: usize = 2;
/// Jumps a Jacobian serves before it is recomputed.
const MAX_JAC_AGE: u32 = 4;
/// Largest ratio of consecutive envelope steps (variable-step BDF2 is zero-stable below 1 + √2).
const MAX_RATIO: f64 = 2.0;
/// Newton iterations per corrector solve.
const MAX_NEWTON: usize = 4;
/// A Newton iterate whose error estimate is this many times what the step may have ends the
/// iteration: the step will be refused whatever the remaining corrections, which shrink
/// quadratically (measured on the paper protocols: by 10⁻²–10⁻⁴ per iteration).
const HOPELESS: f64 = 100.0;
/// Largest Newton correction, in the scaled norm (the orbit's amplitudes).
const MAX_NEWTON_STEP: f64 = 1.0;

impl Envelope {
    /// Envelope following with `settings`.
    pub fn new(settings: EnvelopeSettings) -> Self {
        Self {
            settings,
            history: Vec::new(),
            jac: None,
            skip: 4.0,
            cooldown: 0,
            scales: [f64::NAN; 3],
            stop: false,
            towards_pull_off: false,
            backoff: FIRST_BACKOFF,
            venture: Venture::default(),
            backing_off: false,
            saved: 0.0,
            drifts: std::collections::VecDeque::new(),
            direct_cost: 0.0,
            evals_left_at: None,
            direct: std::collections::VecDeque::new(),
            jac_age: 0,
            multiplier: None,
            jumped: false,
            periodic: false,
            steady_wait: 0,
            steady_backoff: 1,
            stats: EnvelopeStats::default(),
        }
    }

    /// What it did so far.
    pub fn stats(&self) -> EnvelopeStats {
        self.stats
    }

    /// Forget the history (an event happened, the drive changed).
    pub fn forget(&mut self) {
        self.jumped = false;
        self.evals_left_at = None;
        self.direct.clear();
        self.drifts.clear();
        self.history.clear();
        self.jac = None;
        self.skip = 4.0;
    }

    /// A new stage (`towards_pull_off` when it ends at pull-off; `periodic` when its one-period
    /// map is the same every period: the spring end held, the shaker steady): forget the history
    /// and allow jumps again.
    pub fn new_stage(&mut self, towards_pull_off: bool, periodic: bool) {
        self.forget();
        self.stop = false;
        self.towards_pull_off = towards_pull_off;
        self.periodic = periodic && !towards_pull_off;
        self.backoff = FIRST_BACKOFF;
        self.venture = Venture::default();
        self.steady_wait = 0;
        self.steady_backoff = 1;
        self.multiplier = None;
    }

    /// At an exact period boundary of `sim` (`rec` the period that just ended): record the
    /// envelope point and, when the history and the error estimate allow, jump over whole
    /// periods. `room` is how many periods may be jumped before the stop time must be
    /// approached directly. Returns the number of periods jumped (0: integrate directly).
    pub fn at_boundary(
        &mut self,
        sim: &mut Simulator,
        rec: &CycleRecord,
        room: u64,
    ) -> Result<u64, SimError> {
        let evals = sim.stats().rhs_evals;
        if let Some(before) = self.evals_left_at {
            // The period that just ended was integrated directly: what a jump saves per period.
            let cost = evals.saturating_sub(before) as f64;
            self.direct_cost = if self.direct_cost > 0.0 {
                0.75 * self.direct_cost + 0.25 * cost
            } else {
                cost
            };
        }
        let jumped = self.follow(sim, rec, room);
        self.evals_left_at = Some(sim.stats().rhs_evals);
        jumped
    }

    /// [`Envelope::at_boundary`] without its bookkeeping of direct periods' cost.
    fn follow(
        &mut self,
        sim: &mut Simulator,
        rec: &CycleRecord,
        room: u64,
    ) -> Result<u64, SimError> {
        let y = *sim.state();
        let k = sim.period_index();
        if !y.contact {
            self.forget();
            return Ok(0);
        }
        if self.stop {
            return Ok(0);
        }
        self.scales = scales(sim, rec);
        // The envelope points are the exact boundaries while integrating directly, and the jump
        // targets while jumping: the boundary one period after a jump target is not one (its
        // spacing of one period after a long jump would make the BDF's steps too uneven).
        if std::mem::take(&mut self.jumped) {
            if self.history.last().is_none_or(|p| p.tau as u64 + 1 != k) {
                self.forget();
            }
        } else {
            if self.history.last().is_some_and(|p| p.tau as u64 + 1 != k) {
                // Not one period after the last boundary (a jump lies between).
                self.direct.clear();
            }
            self.direct.push_back([y.x, y.v, y.a]);
            if self.direct.len() > 3 * SCREEN_SKIP as usize + 1 {
                self.direct.pop_front();
            }
            self.push(Point {
                tau: k as f64,
                y: [y.x, y.v, y.a],
            });
            if let Some(d) = self.drift() {
                self.drifts.push_back((k, d));
                while self
                    .drifts
                    .front()
                    .is_some_and(|&(k0, _)| k0 + DECAY_WINDOW < k)
                {
                    self.drifts.pop_front();
                }
            }
        }
        // The farthest target: the stop time's margin, the largest skip.
        let far = k + room.min(self.settings.max_skip);
        // Looked for at every boundary, also while the BDF cools down after a refused step: the
        // search has its own guard (the drift against the multiplier) and its own wait.
        if let Some(z) = self.steady_state(sim, &y, k, far)? {
            // The history before the periodic steady state is no envelope of what follows.
            self.forget();
            self.stats.steady_jumps += 1;
            // A jump that pays for the attempts before it: no back-off carries past it.
            self.venture = Venture::default();
            self.cooldown = 0;
            self.backoff = FIRST_BACKOFF;
            self.backing_off = false;
            return Ok(self.land(sim, z, far, k));
        }
        if self.cooldown > 0 {
            self.cooldown -= 1;
            if self.backing_off {
                self.stats.backoff_periods += 1;
            }
            return Ok(0);
        }
        if self.history.len() < ORDER + 1 {
            return Ok(0);
        }
        if self.drift().is_none_or(|d| d > FAST_DRIFT) {
            // No slow drift to follow yet: spend no trial periods on it.
            self.cooldown = COOLDOWN;
            self.backing_off = false;
            return Ok(0);
        }
        let n = self.history.len();
        let base = self.history[n - 1].tau as u64;
        if base == k {
            // A run of attempts would start from directly integrated boundaries: only where a
            // skip that pays would pass the error test.
            let Some(pred) = self.predicted_error().filter(|&e| e <= 1.0) else {
                self.stats.backoff_periods += 1;
                return Ok(0);
            };
            // And from the boundaries the screen read, SCREEN_SKIP apart: its first step is
            // the one the screen predicted, not two periods from boundaries one apart (the
            // integration error of the direct periods, which the screen's differences barely
            // see, would decide that step, and steps of 2, 4, 8 cost a Newton solve each).
            let s = SCREEN_SKIP as usize;
            let last = self.direct.len() - 1;
            self.history = (0..=ORDER)
                .rev()
                .map(|j| Point {
                    tau: (k - (j * s) as u64) as f64,
                    y: self.direct[last - j * s],
                })
                .collect();
            self.skip = SCREEN_SKIP as f64 * growth(pred);
        }
        let n = self.history.len();
        let h_prev = self.history[n - 1].tau - self.history[n - 2].tau;
        loop {
            if self.stop || self.cooldown > 0 {
                return Ok(0);
            }
            if !self.affordable(sim) {
                // Over budget: integrate on, and look again at the next boundary.
                self.stats.backoff_periods += 1;
                return Ok(0);
            }
            // The BDF step from the newest envelope point, its growth bounded for stability.
            let m = self.skip.min(MAX_RATIO * h_prev).floor() as u64;
            let target = (base + m).min(far);
            if target < k + 2 || self.skip < self.break_even() {
                self.pause();
                self.skip = 4.0;
                return Ok(0);
            }
            let before = sim.stats().rhs_evals;
            let tried = self.attempt(sim, &y, target - base);
            self.venture.spent += sim.stats().rhs_evals.saturating_sub(before);
            match tried? {
                Some((z, err)) => {
                    self.skip = (target - base) as f64 * growth(err);
                    self.venture.skipped += target - k;
                    self.venture.jumps += 1;
                    return Ok(self.land(sim, z, target, k));
                }
                None => {
                    self.stats.rejected += 1;
                    if self.venture.jumps == 0 {
                        // The screen predicted this step to pass: where it errs (the trial
                        // periods' own error near the tolerance, the end of the unload), the
                        // smaller steps the loop would try next rarely pay for their Newton
                        // solves.
                        self.pause();
                        self.skip = 4.0;
                        return Ok(0);
                    }
                }
            }
        }
    }

    /// A periodic steady state reached in a periodic stage: the fixed point z* = P(z*) of the
    /// one-period map, found by Newton (shooting) from the state `y` at the boundary of period
    /// `k`, as the state at boundary `far` (`None`: not there yet, integrate on).
    ///
    /// Tried only where the drift per period, divided by 1 − r (r the factor it shrinks by per
    /// period, [`Envelope::drift_decay`]: the distance to the fixed point of a linear
    /// contraction), is below [`STEADY_NEAR`]. Accepted when the last Newton correction is
    /// below 1/100 of the tolerance (z is then z* to the trial periods' accuracy), y is within
    /// [`STEADY_NEAR`] of z* (the linearisation, and the multiplier μ of the fresh Jacobian at
    /// y, hold on the way), and the transient μ^M |y − z*| left over the M = far − k periods of
    /// the jump is below 1/100 of the tolerance: every later boundary of the stage is z* within
    /// the tolerance, so none of them needs integrating. It is looked for at every boundary (also while the BDF cools down); a failed
    /// search waits 16, 32, 64, … periods before the next.
    fn steady_state(
        &mut self,
        sim: &mut Simulator,
        y: &State,
        k: u64,
        far: u64,
    ) -> Result<Option<State>, SimError> {
        if !self.periodic || far < k + 2 {
            return Ok(None);
        }
        if self.steady_wait > 0 {
            self.steady_wait -= 1;
            return Ok(None);
        }
        let Some(drift) = self.drift() else {
            return Ok(None);
        };
        if !self.affordable(sim) {
            return Ok(None);
        }
        // How near: the drift over the rate it decays at (the search takes a fresh multiplier
        // before it accepts anything). A drift that does not decay is no approach to a fixed
        // point; a NaN fails the test too.
        let Some(rate) = self.drift_decay() else {
            return Ok(None);
        };
        let near = drift < STEADY_NEAR * (1.0 - rate);
        if !near {
            return Ok(None);
        }
        let found = self.shoot(sim, y, k)?;
        let tol = self.settings.tol;
        let accepted = found.and_then(|(z, dist)| {
            // The fresh Jacobian's (shoot takes one before it returns a point).
            let mu = self.multiplier.unwrap_or(1.0);
            let periods = (far - k) as f64;
            let transient = dist * mu.powf(periods);
            (dist <= STEADY_NEAR && transient <= 0.01 * tol).then_some(z)
        });
        match accepted {
            Some(z) => Ok(Some(sim.state_at_boundary(far, z[0], z[1], z[2], y.q))),
            None => {
                self.steady_wait = COOLDOWN.saturating_mul(self.steady_backoff);
                self.steady_backoff = self.steady_backoff.saturating_mul(2);
                Ok(None)
            }
        }
    }

    /// Newton on P(z) = z from the boundary state `y` at period `k`, with a fresh Jacobian at
    /// `y` (kept for the BDF): the fixed point and its scaled distance from `y`, or `None` when
    /// the iteration does not converge or the multiplier is at its limit.
    fn shoot(
        &mut self,
        sim: &mut Simulator,
        y: &State,
        k: u64,
    ) -> Result<Option<([f64; 3], f64)>, SimError> {
        let sc = self.scales;
        let start = [y.x, y.v, y.a];
        let mut z = start;
        // A fresh Jacobian at y: the multiplier bounds the transient the jump leaves out, so
        // it must be the one here, not one from an earlier stretch of the run.
        let (g0, jac) = match self.fresh_jacobian(sim, &z, k, y)? {
            Fresh::Map(g0, jac) => (g0, jac),
            Fresh::NotSmooth => {
                self.jac = None;
                return Ok(None);
            }
            Fresh::AtLimit => return Ok(None),
        };
        let mut g_known = Some(g0);
        for _ in 0..MAX_NEWTON {
            let g = match g_known.take() {
                Some(g) => g,
                None => match self.map(sim, &z, k, y)? {
                    Some(g) => g,
                    None => return Ok(None),
                },
            };
            // (I − J) dz = P(z) − z, scaled.
            let f: [f64; 3] = std::array::from_fn(|i| g[i] / sc[i]);
            let Some(dz) = crate::numerics::solve_dense(
                3,
                |i, j| if i == j { 1.0 } else { 0.0 } - jac[i][j],
                &f,
            ) else {
                return Ok(None);
            };
            let step = dz.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            if step.is_nan() || step > STEADY_NEAR {
                return Ok(None);
            }
            for i in 0..3 {
                z[i] += dz[i] * sc[i];
            }
            if step <= 0.01 * self.settings.tol {
                let dist = (0..3)
                    .map(|i| ((z[i] - start[i]) / sc[i]).abs())
                    .fold(0.0f64, f64::max);
                return Ok(Some((z, dist)));
            }
        }
        Ok(None)
    }

    /// The largest change per period of the newest two envelope points, in the scales (`None`
    /// before there are two, or when it is not finite).
    fn drift(&self) -> Option<f64> {
        let n = self.history.len();
        if n < 2 {
            return None;
        }
        let (p0, p1) = (self.history[n - 2], self.history[n - 1]);
        let d = (0..3)
            .map(|i| ((p1.y[i] - p0.y[i]) / self.scales[i] / (p1.tau - p0.tau)).abs())
            .fold(0.0f64, f64::max);
        d.is_finite().then_some(d)
    }

    /// The factor by which the drift shrank per period over the last [`DECAY_WINDOW`] periods
    /// (`None` before the history spans them): the slowest multiplier the run's approach to a
    /// fixed point shows.
    fn drift_decay(&self) -> Option<f64> {
        let (&(k0, d0), &(k1, d1)) = (self.drifts.front()?, self.drifts.back()?);
        (k1 >= k0 + DECAY_WINDOW).then(|| (d1 / d0).powf(1.0 / (k1 - k0) as f64))
    }

    /// Jump from the boundary of period `k` to the state `z` at the start of period `target`:
    /// the new envelope point, the run moved there; returns the periods skipped.
    fn land(&mut self, sim: &mut Simulator, z: State, target: u64, k: u64) -> u64 {
        let skipped = target - k;
        self.saved += skipped as f64 * self.direct_cost;
        self.stats.jumps += 1;
        self.stats.periods_skipped += skipped;
        self.push(Point {
            tau: target as f64,
            y: [z.x, z.v, z.a],
        });
        self.jumped = true;
        sim.jump(z, skipped);
        skipped
    }

    fn push(&mut self, p: Point) {
        if self.history.last().is_some_and(|l| l.tau >= p.tau) {
            self.history.clear();
        }
        self.history.push(p);
        if self.history.len() > ORDER + 1 {
            self.history.remove(0);
        }
    }

    /// One envelope step of `m` periods from the current boundary state `y`: the corrected
    /// state and its scaled error estimate, or `None` (the skip was reduced) when the step is
    /// refused.
    fn attempt(
        &mut self,
        sim: &mut Simulator,
        y: &State,
        m: u64,
    ) -> Result<Option<(State, f64)>, SimError> {
        let bdf = self.bdf_step(m);
        let Some((z, iterations)) = self.newton(sim, y, &bdf)? else {
            return Ok(None);
        };
        self.jac_age += 1;
        if iterations > 2 || self.jac_age >= MAX_JAC_AGE {
            // A fresh Jacobian next time: also a fresh look at the multipliers, which move as
            // the run drifts towards a loss of stability.
            self.jac = None;
        }
        let err = self.milne_error(&bdf, &z, m);
        if !(err.is_finite() && err <= 1.0) {
            let shrink = if err.is_finite() {
                (0.9 * err.powf(-1.0 / (ORDER as f64 + 1.0))).clamp(0.2, 0.9)
            } else {
                0.25
            };
            self.skip = m as f64 * shrink;
            return Ok(None);
        }
        if z[2].is_nan() || z[2] <= 0.0 {
            return Ok(self.refuse());
        }
        Ok(Some((
            sim.state_at_boundary(bdf.k, z[0], z[1], z[2], y.q),
            err,
        )))
    }

    /// The BDF step of `m` periods from the history: the new point's τ, the predictor and the
    /// corrector's coefficients.
    fn bdf_step(&self, m: u64) -> BdfStep {
        // History, newest last: the predictor uses all ORDER + 1 points, the corrector the newest
        // ORDER of them and the new point.
        let hist = &self.history;
        let newest = hist[hist.len() - 1];
        let tau = newest.tau + m as f64;
        let taus: Vec<f64> = hist.iter().map(|p| p.tau).collect();
        let ys: Vec<[f64; 3]> = hist.iter().map(|p| p.y).collect();
        let predicted = lagrange(&taus, &ys, tau);
        // BDF of order ORDER on (tau, the newest ORDER points): Σ ℓⱼ' yⱼ = g(z).
        let mut nodes = vec![tau];
        nodes.extend(taus.iter().rev().take(ORDER));
        let l = lagrange_derivatives(&nodes, tau + 0.5);
        let known: [f64; 3] = std::array::from_fn(|c| {
            (1..=ORDER)
                .map(|j| l[j] * hist[hist.len() - j].y[c])
                .sum::<f64>()
        });
        BdfStep {
            tau,
            m,
            k: newest.tau as u64 + m,
            milne: milne_ratio(&nodes, &taus),
            predicted,
            l0: l[0],
            known,
        }
    }

    /// Newton on the corrector of `bdf` from its predictor: the corrected point and the
    /// iterations it took, or `None` when the step is refused (the skip was reduced) or the
    /// largest multiplier reached its limit (jumps stop or pause). An iterate whose error
    /// estimate is already [`HOPELESS`] is returned as it is: the error test refuses it.
    fn newton(
        &mut self,
        sim: &mut Simulator,
        y: &State,
        bdf: &BdfStep,
    ) -> Result<Option<([f64; 3], usize)>, SimError> {
        let (l0, k) = (bdf.l0, bdf.k);
        let sc = self.scales;
        let mut z = bdf.predicted;
        let mut converged = false;
        let mut iterations = 0;
        let mut fresh_jac = false;
        while iterations < MAX_NEWTON {
            let mut g_known = None;
            if self.jac.is_none() {
                match self.fresh_jacobian(sim, &z, k, y)? {
                    Fresh::Map(g0, _) => g_known = Some(g0),
                    Fresh::NotSmooth => return Ok(self.refuse()),
                    Fresh::AtLimit => return Ok(None),
                }
                fresh_jac = true;
            }
            let g = match g_known {
                Some(g) => g,
                None => match self.map(sim, &z, k, y)? {
                    Some(g) => g,
                    None => return Ok(self.refuse()),
                },
            };
            iterations += 1;
            // F(z) = ℓ0' z + ℓ1' y_n + ℓ2' y_{n−1} − g(z), scaled.
            let f: [f64; 3] = std::array::from_fn(|i| (l0 * z[i] + bdf.known[i] - g[i]) / sc[i]);
            let Some(jac) = self.jac else {
                return Ok(self.refuse());
            };
            // J_F = (ℓ0' + 1) I − J_P in scaled units.
            let dz = crate::numerics::solve_dense(
                3,
                |i, j| {
                    let d = if i == j { l0 + 1.0 } else { 0.0 };
                    d - jac[i][j]
                },
                &f,
            );
            let Some(dz) = dz else {
                self.jac = None;
                return Ok(self.refuse());
            };
            let step = dz.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            if step.is_nan() || step > MAX_NEWTON_STEP {
                // Far outside the region the predictor and the Jacobian describe.
                self.jac = None;
                return Ok(self.refuse());
            }
            for i in 0..3 {
                z[i] -= dz[i] * sc[i];
            }
            if step <= 0.01 * self.settings.tol {
                converged = true;
                break;
            }
            if self.milne_error(bdf, &z, bdf.m) > HOPELESS {
                // No more trial periods for a step the error test will refuse: `attempt`
                // refuses it from this iterate.
                converged = true;
                break;
            }
        }
        if !converged {
            if fresh_jac {
                self.jac = None;
                return Ok(self.refuse());
            }
            // A stale Jacobian: take a fresh one next time at a shorter skip.
            self.jac = None;
            return Ok(self.refuse());
        }
        Ok(Some((z, iterations)))
    }

    /// A fresh Jacobian of the map at `z` (period `k`), kept as the envelope's with its largest
    /// multiplier; at the multiplier's limit the jumps stop or pause
    /// ([`Envelope::multiplier_at_limit`]).
    fn fresh_jacobian(
        &mut self,
        sim: &mut Simulator,
        z: &[f64; 3],
        k: u64,
        y: &State,
    ) -> Result<Fresh, SimError> {
        let Some((jac, g0)) = self.jacobian(sim, z, k, y)? else {
            return Ok(Fresh::NotSmooth);
        };
        let mu = slow_multiplier(&jac);
        self.multiplier = Some(mu);
        if mu >= self.settings.max_multiplier {
            self.multiplier_at_limit();
            return Ok(Fresh::AtLimit);
        }
        self.jac = Some(jac);
        self.jac_age = 0;
        Ok(Fresh::Map(g0, jac))
    }

    /// The largest multiplier reached its limit: perturbations stop decaying and the envelope's
    /// errors would grow. Towards pull-off this is the approach to the loss of stability: the
    /// stage is integrated directly from here. Elsewhere it may be a transient (the ring-down
    /// after the shaker starts) or a creep that settles: try again later.
    fn multiplier_at_limit(&mut self) {
        if self.towards_pull_off {
            self.stop = true;
        } else {
            self.forget();
            self.venture = Venture::default();
            self.cooldown = self.backoff;
            self.backoff = self.backoff.saturating_mul(2);
            self.backing_off = true;
        }
    }

    /// The run of attempts ends: integrate directly for a while. A run whose trial periods cost
    /// more evaluations than the periods it jumped over would have (where the error share leaves
    /// only skips of two or three periods, as on the unloads of the 10 µm paper protocols) is
    /// tried again after twice as long each time, so that its cost stays logarithmic in the
    /// stage's length; one that paid is tried again after [`COOLDOWN`].
    fn pause(&mut self) {
        let v = std::mem::take(&mut self.venture);
        if v.skipped as f64 * self.direct_cost > v.spent as f64 {
            self.cooldown = COOLDOWN;
            self.backoff = FIRST_BACKOFF;
            self.backing_off = false;
        } else {
            self.cooldown = self.backoff;
            self.backoff = self.backoff.saturating_mul(2);
            self.backing_off = true;
        }
    }

    /// The shortest step (periods) whose jump pays for its trial periods at what the current
    /// run of attempts spent per jump so far: a step of m periods from the newest envelope
    /// point skips m − 1 (the period after the jump target is integrated directly). 0 before
    /// the run's first jump or the first measured direct period.
    fn break_even(&self) -> f64 {
        let v = self.venture;
        if v.jumps == 0 || self.direct_cost <= 0.0 {
            return 0.0;
        }
        1.0 + v.spent as f64 / v.jumps as f64 / self.direct_cost
    }

    /// Whether the run may spend trial periods now: while their net cost, the RHS evaluations
    /// of every trial period so far minus those the jumps saved, is at most [`BUDGET_SHARE`] of
    /// the run's other evaluations plus [`BUDGET_ALLOWANCE`] direct periods. Each attempt is
    /// checked, so the net cost never exceeds that by more than one attempt (at most seven trial
    /// periods): `auto` never costs materially more than integrating every period, however its
    /// attempts fare and however many stages restart them.
    fn affordable(&self, sim: &Simulator) -> bool {
        let trial = self.stats.trial_rhs_evals as f64;
        let work = (sim.stats().rhs_evals as f64 - trial).max(0.0);
        trial - self.saved <= BUDGET_SHARE * work + BUDGET_ALLOWANCE * self.direct_cost
    }

    /// The error test's verdict, predicted without a trial period, on a BDF step of
    /// [`SCREEN_SKIP`] periods from envelope points [`SCREEN_SKIP`] periods apart: the
    /// predictor's error on such a step is the third difference of the points (exact on
    /// cubics), Milne's device takes 2/11 of it, and the step may use the share
    /// [`Envelope::memory_share`] gives it, with the multiplier at its limit before the stage's
    /// first Jacobian. Read from the directly integrated boundaries; `None` until there are
    /// 3 [`SCREEN_SKIP`] + 1 of them in a row.
    fn predicted_error(&self) -> Option<f64> {
        let d = &self.direct;
        let s = SCREEN_SKIP as usize;
        if d.len() < 3 * s + 1 {
            return None;
        }
        let n = d.len() - 1;
        let (y0, y1, y2, y3) = (d[n], d[n - s], d[n - 2 * s], d[n - 3 * s]);
        let third = (0..3)
            .map(|i| ((y0[i] - 3.0 * y1[i] + 3.0 * y2[i] - y3[i]) / self.scales[i]).abs())
            .fold(0.0f64, f64::max);
        let mu = self.multiplier.unwrap_or(self.settings.max_multiplier);
        let share = (SCREEN_SKIP as f64 * (1.0 - mu)).clamp(1e-3, 1.0);
        let step = SCREEN_SKIP as f64;
        let milne = milne_ratio(&[step, 0.0, -step], &[-2.0 * step, -step, 0.0]);
        let err = milne * third / (self.settings.tol * share);
        err.is_finite().then_some(err)
    }

    /// The corrected point `z`'s local error by Milne's device, as a fraction of the share of
    /// the tolerance a jump of `m` periods may use:
    /// e_c = (1/ℓ0')/(1/ℓ0' + τ − τ_oldest) (z_c − z_p), the corrector's error against the
    /// predictor's, both proportional to the same derivative of the envelope.
    fn milne_error(&self, bdf: &BdfStep, z: &[f64; 3], m: u64) -> f64 {
        let sc = self.scales;
        (0..3)
            .map(|i| (bdf.milne * (z[i] - bdf.predicted[i]) / sc[i]).abs())
            .fold(0.0f64, f64::max)
            / (self.settings.tol * self.memory_share(m))
    }

    /// The share of the envelope tolerance one jump of `m` periods may use. The slowest mode of
    /// the map (the creeping contact radius, multiplier μ close to 1) forgets an error only over
    /// 1/(1 − μ) periods, so the errors of the jumps within that memory add up: a jump may use
    /// m (1 − μ) of the tolerance (at most all of it), which keeps their sum near the tolerance.
    fn memory_share(&self, m: u64) -> f64 {
        // Only after a Jacobian of the stage (the BDF takes one before its first step).
        (m as f64 * (1.0 - self.multiplier.unwrap_or(1.0))).clamp(1e-3, 1.0)
    }

    /// A refused step: try a quarter of the skip.
    fn refuse<T>(&mut self) -> Option<T> {
        self.skip *= 0.25;
        None
    }

    /// g(z) = P(z) − z at period k (unscaled); `None` when the period is not smooth.
    fn map(
        &mut self,
        sim: &mut Simulator,
        z: &[f64; 3],
        k: u64,
        y: &State,
    ) -> Result<Option<[f64; 3]>, SimError> {
        if !(z[2] > 0.0 && z.iter().all(|v| v.is_finite())) {
            return Ok(None);
        }
        let s = sim.state_at_boundary(k, z[0], z[1], z[2], y.q);
        if !s.adot.is_finite() {
            return Ok(None);
        }
        self.stats.trial_periods += 1;
        let before = sim.stats().rhs_evals;
        let t = sim.trial_period(s, k, TRIAL_TOLERANCE);
        self.stats.trial_rhs_evals += sim.stats().rhs_evals.saturating_sub(before);
        let t = match t {
            Ok(t) => t,
            // The run's budgets hold across trial periods too.
            Err(
                e @ (SimError::StepBudget { .. }
                | SimError::WallBudget { .. }
                | SimError::Cancelled { .. }),
            ) => return Err(e),
            // A trial from a poor iterate that cannot be integrated only refuses the step.
            Err(_) => return Ok(None),
        };
        if t.rough || !t.end.contact {
            return Ok(None);
        }
        Ok(Some([t.end.x - z[0], t.end.v - z[1], t.end.a - z[2]]))
    }

    /// ∂P/∂y at z by forward differences, in scaled units, and g(z); `None` when a period is
    /// not smooth.
    #[allow(clippy::type_complexity)]
    fn jacobian(
        &mut self,
        sim: &mut Simulator,
        z: &[f64; 3],
        k: u64,
        y: &State,
    ) -> Result<Option<([[f64; 3]; 3], [f64; 3])>, SimError> {
        let sc = self.scales;
        let Some(g0) = self.map(sim, z, k, y)? else {
            return Ok(None);
        };
        let mut jac = [[0.0; 3]; 3];
        for j in 0..3 {
            let mut zj = *z;
            let h = 1e-6 * sc[j];
            zj[j] += h;
            let Some(gj) = self.map(sim, &zj, k, y)? else {
                return Ok(None);
            };
            for i in 0..3 {
                // P = g + z: ∂P_i/∂z_j = ∂g_i/∂z_j + δ_ij.
                let dg = (gj[i] - g0[i]) / sc[i] / (h / sc[j]);
                jac[i][j] = dg + if i == j { 1.0 } else { 0.0 };
            }
        }
        Ok(Some((jac, g0)))
    }
}

/// The factor by which the next step may grow after one whose error was `err` of what it may
/// have (the local error of the order-2 method goes with the cube of the step).
fn growth(err: f64) -> f64 {
    if err > 0.0 {
        (0.9 * err.powf(-1.0 / (ORDER as f64 + 1.0))).clamp(0.2, 4.0)
    } else {
        4.0
    }
}

/// The largest modulus among the eigenvalues of the one-period map's Jacobian (its Floquet
/// multipliers; the scaling is a similarity transform and does not change them).
fn slow_multiplier(jac: &[[f64; 3]; 3]) -> f64 {
    let m = nalgebra::Matrix3::from_fn(|i, j| jac[i][j]);
    m.complex_eigenvalues()
        .iter()
        .map(|e| e.norm())
        .fold(0.0f64, f64::max)
}

/// The residual scales (L, ωL, a) from a period record: L the larger of the indentation's first
/// harmonic and X_b, a the mean radius (floored at 1e-3 of the jump-in radius).
fn scales(sim: &Simulator, c: &CycleRecord) -> [f64; 3] {
    let m = sim.model();
    let a_j = jkr::jump_in_radius(&m.mat, m.w0);
    let floor = 1e-6 * a_j * a_j / m.mat.r;
    let l = c.delta_sin.hypot(c.delta_cos).max(m.xb_amp).max(floor);
    [l, m.omega * l, c.a_mean.max(1e-3 * a_j)]
}

/// The interpolating polynomial through (tᵢ, yᵢ) evaluated at `at` (Lagrange form).
fn lagrange(t: &[f64], y: &[[f64; 3]], at: f64) -> [f64; 3] {
    let w: Vec<f64> = (0..t.len())
        .map(|i| {
            (0..t.len())
                .filter(|&j| j != i)
                .map(|j| (at - t[j]) / (t[i] - t[j]))
                .product()
        })
        .collect();
    std::array::from_fn(|c| w.iter().zip(y).map(|(wi, yi)| wi * yi[c]).sum())
}

/// Derivatives at `at` of the Lagrange basis on the nodes t₀, t₁, …: ℓᵢ′(at) =
/// Σ_{k≠i} Π_{j≠i,k} (at − tⱼ) / Π_{j≠i} (tᵢ − tⱼ).
fn lagrange_derivatives(t: &[f64], at: f64) -> Vec<f64> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let den: f64 = (0..n).filter(|&j| j != i).map(|j| t[i] - t[j]).product();
            let num: f64 = (0..n)
                .filter(|&k| k != i)
                .map(|k| {
                    (0..n)
                        .filter(|&j| j != i && j != k)
                        .map(|j| at - t[j])
                        .product::<f64>()
                })
                .sum();
            num / den
        })
        .collect()
}

/// Milne's device for the corrector on `nodes` (the new point's τ first, then the newest
/// history points) against the predictor through the history points `taus`: the share of the
/// distance z_c − z_p that is the corrector's error. For a smooth envelope with third
/// derivative y‴, the predictor misses by y‴ W/6, W = Π (τ − τⱼ) over `taus`; the corrector,
/// the quadratic q through the nodes with q′(τ + ½) = g(z), misses by y‴ C with
/// C = (1/24 + ω′(τ + ½)/6)/ℓ₀′(τ + ½), ω(t) = Π (t − tⱼ) over the nodes (1/24: the forward
/// difference's error as a derivative at the midpoint; ω′/6: the quadratic's derivative's).
/// So z_c − z_p = (W/6 + C) y‴, and the corrector's error is C/(W/6 + C) of it.
fn milne_ratio(nodes: &[f64], taus: &[f64]) -> f64 {
    let tau = nodes[0];
    let at = tau + 0.5;
    let l0 = lagrange_derivatives(nodes, at)[0];
    let n = nodes.len();
    let omega_d: f64 = (0..n)
        .map(|k| {
            (0..n)
                .filter(|&j| j != k)
                .map(|j| at - nodes[j])
                .product::<f64>()
        })
        .sum();
    let c = (1.0 / 24.0 + omega_d / 6.0) / l0;
    let w: f64 = taus.iter().map(|t| tau - t).product();
    c / (w / 6.0 + c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The variable-step BDF coefficients differentiate cubics exactly at the new node, for any
    /// spacing, and the Lagrange predictor reproduces them.
    #[test]
    fn bdf_and_predictor_are_exact_on_cubics() {
        let q = |t: f64| 3.0 - 2.0 * t + 0.5 * t * t - 0.01 * t * t * t;
        let dq = |t: f64| -2.0 + t - 0.03 * t * t;
        for nodes in [
            [10.0, 7.0, 6.0, 5.0],
            [5.0, 4.0, 3.0, 2.0],
            [100.0, 3.0, 2.0, 0.5],
        ] {
            for at in [nodes[0], nodes[0] + 0.5, nodes[2]] {
                let l = lagrange_derivatives(&nodes, at);
                let d: f64 = l.iter().zip(nodes).map(|(li, t)| li * q(t)).sum();
                assert!((d - dq(at)).abs() < 1e-9, "{d} vs {}", dq(at));
            }
            let ys: Vec<[f64; 3]> = nodes.iter().map(|&t| [q(t); 3]).collect();
            let p = lagrange(&nodes, &ys, nodes[0] + 7.0);
            assert!((p[0] - q(nodes[0] + 7.0)).abs() < 1e-9);
        }
    }

    /// The corrector on a map whose orbit is known in closed form, y_{k+1} = μ y_k + A sin ωk
    /// (μ = 0.997, the creeping radius's multiplier on the paper protocols; the drive's period
    /// 4 000 periods): its stroboscopic states are y_k = Im(B e^{iωk}), B = A/(e^{iω} − μ).
    /// From history points on the orbit, the quadratic whose derivative at τ + ½ is g(z) =
    /// P(z) − z lands on the orbit to third order, and Milne's device predicts its miss within
    /// 5 % (20 % for a step of 64 periods, where the fourth derivative shows). Set at τ itself
    /// (the plain BDF2, taking g as the derivative where it is only the forward difference),
    /// the corrector misses by 10–370 times as much for steps of 16 down to 2 periods, and by
    /// 3–5 times what its Milne estimate says.
    #[test]
    fn corrector_lands_on_the_maps_orbit() {
        let (mu, amp, om) = (0.997, 1e-3, 2.0 * std::f64::consts::PI / 4000.0);
        type C = nalgebra::Complex<f64>;
        let b = C::new(amp, 0.0) / (C::from_polar(1.0, om) - mu);
        let y = |k: f64| (b * C::from_polar(1.0, om * k)).im;
        let f = |k: f64| amp * (om * k).sin();
        // (history τ, step m, the largest miss of the Milne estimate, the least gain over BDF2)
        for (taus, m, within, gain) in [
            ([998.0, 999.0, 1000.0], 2.0, 0.05, 100.0),
            ([990.0, 998.0, 1000.0], 4.0, 0.05, 50.0),
            ([984.0, 992.0, 1000.0], 8.0, 0.05, 20.0),
            ([984.0, 992.0, 1000.0], 16.0, 0.05, 5.0),
            ([900.0, 950.0, 1000.0], 64.0, 0.2, 1.0),
        ] {
            let tau = taus[2] + m;
            let nodes = [tau, taus[2], taus[1]];
            // ℓ₀ z + ℓ₁ y_n + ℓ₂ y_{n−1} = (μ − 1) z + f(τ): the linear corrector solved.
            let solve = |at: f64| {
                let l = lagrange_derivatives(&nodes, at);
                (f(tau) - l[1] * y(nodes[1]) - l[2] * y(nodes[2])) / (l[0] - mu + 1.0)
            };
            let ys: Vec<[f64; 3]> = taus.iter().map(|&t| [y(t); 3]).collect();
            let predicted = lagrange(&taus, &ys, tau)[0];
            let z = solve(tau + 0.5);
            let miss = z - y(tau);
            let estimate = milne_ratio(&nodes, &taus) * (z - predicted);
            assert!(
                (miss / estimate - 1.0).abs() < within,
                "m {m}: miss {miss:e}, Milne {estimate:e}"
            );
            let bdf2 = solve(tau) - y(tau);
            assert!(
                bdf2.abs() > gain * miss.abs(),
                "m {m}: BDF2 misses by {bdf2:e}, the corrector by {miss:e}"
            );
        }
    }

    /// The corrector, taken half a period after the new point, damps every mode of a map that
    /// contracts: on y_{k+1} = μ y_k (|μ| ≤ 0.99 anywhere in the disc: the creeping radius
    /// near 1, the sphere's ring-down at 0.9 e^{±iθ}) its points never exceed the history's,
    /// over sequences of steps as the envelope takes them (from boundaries one or eight apart,
    /// growing at most 2× per step, shrinking, alternating).
    #[test]
    fn corrector_damps_every_contracting_mode() {
        type C = nalgebra::Complex<f64>;
        let sequences: [&[f64]; 6] = [
            &[2.0; 12],
            &[2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0],
            &[2.0, 3.0, 5.0, 8.0, 13.0, 21.0, 34.0, 55.0],
            &[2.0, 4.0, 2.0, 4.0, 2.0, 4.0, 2.0, 4.0],
            &[8.0, 2.0, 4.0, 8.0, 2.0, 4.0, 8.0, 16.0],
            &[16.0, 32.0, 64.0, 128.0, 30.0, 60.0, 12.0, 24.0, 48.0],
        ];
        for (s, steps) in sequences.iter().enumerate() {
            // History one period apart, or SCREEN_SKIP apart where a run of attempts starts.
            let h = if s == 5 { SCREEN_SKIP as f64 } else { 1.0 };
            for r in [0.0, 0.3, 0.6, 0.9, 0.95, 0.99] {
                for j in 0..72 {
                    let mu = C::from_polar(r, j as f64 * std::f64::consts::PI / 36.0);
                    let (mut taus, mut zs) = (vec![-h, 0.0], vec![C::new(1.0, 0.0); 2]);
                    for &m in steps.iter() {
                        let n = taus.len();
                        let tau = taus[n - 1] + m;
                        let nodes = [tau, taus[n - 1], taus[n - 2]];
                        let l = lagrange_derivatives(&nodes, tau + 0.5);
                        // ℓ₀ z + ℓ₁ z_n + ℓ₂ z_{n−1} = (μ − 1) z.
                        let z = -(zs[n - 1] * l[1] + zs[n - 2] * l[2]) / (l[0] - mu + 1.0);
                        assert!(
                            z.norm() <= 1.0 + 1e-12,
                            "steps {steps:?}, μ = {mu}: |z| = {} at τ = {tau}",
                            z.norm()
                        );
                        taus.push(tau);
                        zs.push(z);
                    }
                }
            }
        }
    }
}
