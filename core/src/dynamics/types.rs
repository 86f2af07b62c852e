//! What a time-domain run produces, and how observers (writers, progress bars, steady-state
//! detectors) watch it. These types are the contract between the driver and the output writers.

use super::model::{Drive, Model};
use super::state::{Knot, State};
use crate::jkr;
use serde::Serialize;
use thiserror::Error;

/// One sample of the time series (SI).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sample {
    /// Time t (s).
    pub t: f64,
    /// Sphere position x_s (m, down +).
    pub x_s: f64,
    /// Sphere velocity v_s (m/s, down +).
    pub v_s: f64,
    /// Base displacement x_b (m, up +).
    pub x_b: f64,
    /// Spring far-end position x_k (m, down +).
    pub x_k: f64,
    /// Indentation δ = x_s + x_b (m; negative: gap or tensile contact).
    pub delta: f64,
    /// Contact radius a (m; 0 out of contact).
    pub a: f64,
    /// Contact-radius rate ȧ (m/s; > 0 healing; 0 out of contact).
    pub a_dot: f64,
    /// Contact force F (N, compressive +).
    pub force: f64,
    /// Energy release rate G (J/m², signed: negative for a compressive edge; 0 out of contact).
    pub g: f64,
    /// Work of adhesion w(ȧ) (J/m²; w0 out of contact).
    pub w: f64,
    /// Index of the protocol stage (0-based).
    pub stage: usize,
}

/// A gap in the time series: envelope following jumped over whole base periods between two
/// consecutive samples, so nothing was computed between them and a line drawn from one to the
/// other would invent a motion that did not happen. `t_start` and `t_end` are the times of the
/// two samples (the last before the jump, the first after it); `periods` is the number of base
/// periods skipped between them (those of every jump between the two samples).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gap {
    /// Time of the last sample before the gap (s).
    pub t_start: f64,
    /// Time of the first sample after the gap (s).
    pub t_end: f64,
    /// Base periods skipped (not integrated) between the two samples.
    pub periods: u64,
}

/// Kinds of events the driver locates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EventKind {
    /// Contact radius reached 0.
    ContactLoss,
    /// The gap closed; contact formed.
    Impact,
    /// Final detachment (contact lost for good during an `until = "pull-off"` stage).
    PullOff,
    /// The compressive preload of an approach stage was reached.
    PreloadReached,
    /// A stage's duration elapsed.
    DurationElapsed,
    /// A stage started (the shaker may have switched).
    StageStart,
}

/// A located event.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Event {
    /// What happened.
    pub kind: EventKind,
    /// When (s).
    pub time: f64,
    /// Stage index.
    pub stage: usize,
    /// State at the event.
    pub state: Sample,
}

/// Solver statistics.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Stats {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps.
    pub rejected: u64,
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// Wall-clock time (s).
    pub wall_s: f64,
}

/// Pull-off summary.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PullOffSummary {
    /// Most tensile cycle-averaged contact force before detachment (N); without base motion, the
    /// most tensile contact force. Tensile is negative: a force ≥ 0 means none was tensile (a
    /// sphere that bounced off, or a contact never pulled), and then it is no pull-off force
    /// ([`PullOffSummary::is_tensile`]).
    pub force: f64,
    /// force / (−3/2 π R w0) for a tensile `force`; NaN otherwise (a compressive or zero force
    /// over the static pull-off force would read as a negative or zero amplification).
    pub amplification: f64,
    /// Time at which that force was reached (s; the end of the averaging cycle).
    pub time: f64,
}

impl PullOffSummary {
    /// The summary of a most tensile force `force` reached at `time`, against the static
    /// pull-off force `f0` (negative): the amplification only where `force` is tensile.
    pub fn new(force: f64, time: f64, f0: f64) -> Self {
        let tensile = force < 0.0;
        Self {
            force,
            amplification: if tensile { force / f0 } else { f64::NAN },
            time,
        }
    }

    /// Whether `force` is tensile (< 0): a pull-off force. False when every cycle mean (or
    /// contact force) stayed compressive or zero.
    pub fn is_tensile(&self) -> bool {
        self.force < 0.0
    }
}

/// Everything a run returns, in memory that does not grow with the run's length: the time
/// series, every period record and every event go to observers (a writer streams them to
/// disk; [`Recorder`] keeps them in memory when that is wanted).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunResult {
    /// Pull-off summary.
    pub pull_off: PullOffSummary,
    /// True when final detachment happened.
    pub detached: bool,
    /// The event log, its first [`EVENT_LOG_LIMIT`] events (observers see them all).
    pub events: Vec<Event>,
    /// Events in the whole run, by kind (complete even when the log is cut).
    pub event_counts: EventCounts,
    /// Solver statistics.
    pub stats: Stats,
    /// The method actually used, and why when `auto` chose it.
    pub method: String,
    /// Final state.
    pub final_state: Sample,
    /// Base periods recorded (integrated exactly; envelope following skips others).
    pub cycle_count: u64,
    /// The last period record.
    pub last_cycle: Option<CycleRecord>,
    /// The largest contact radius at the end of any accepted step (m).
    pub max_contact_radius: f64,
    /// What envelope following did.
    pub envelope: EnvelopeStats,
    /// Time of the final detachment (s): the contact loss after which the sphere never touched
    /// again (the `pull-off` event); NaN without detachment. Later than `pull_off.time`, the
    /// most tensile force, by the last periods of the unloading.
    pub detachment_time: f64,
    /// [`ApproachRoughness`] at the pull-off (NaN when not measured: no three consecutive
    /// period records before the most tensile cycle mean, or not defined: see
    /// `approach_zero_means`).
    pub approach_roughness: f64,
    /// Periods among those [`ApproachRoughness`] looks at whose cycle-mean force was zero (the
    /// sphere off the substrate for the whole period): the relative fluctuation divides by that
    /// mean, so it is not defined there, and `approach_roughness` is then NaN. 0 when every
    /// mean was non-zero or none was measured.
    pub approach_zero_means: usize,
}

impl RunResult {
    /// The pull-off happened under vibration and [`ApproachRoughness`] says its approach was
    /// rough: the pull-off is likely sensitive to tiny input changes (check with `--sensitivity`).
    pub fn pull_off_likely_sensitive(&self) -> bool {
        self.detached && self.approach_roughness > ROUGH_APPROACH
    }

    /// The pull-off happened under vibration and some of the periods before it had a zero mean
    /// force (`approach_zero_means`): the sphere left the substrate for whole periods on its way
    /// to the pull-off, where [`ApproachRoughness`] is not defined.
    pub fn pull_off_approach_left_contact(&self) -> bool {
        self.detached && self.approach_zero_means > 0
    }
}

/// What envelope following did in a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct EnvelopeStats {
    /// Accepted envelope steps (jumps).
    pub jumps: u64,
    /// Base periods jumped over (not integrated).
    pub periods_skipped: u64,
    /// Trial periods integrated (Newton iterations and Jacobians).
    pub trial_periods: u64,
    /// Rejected envelope steps.
    pub rejected: u64,
    /// Jumps to the end of a stage from its periodic steady state (counted in `jumps` too).
    pub steady_jumps: u64,
    /// Right-hand-side evaluations of the trial periods (counted in `Stats::rhs_evals` too).
    pub trial_rhs_evals: u64,
    /// Base periods integrated directly because the back-off held envelope steps back: after
    /// runs of attempts that did not pay, or the multiplier reaching its limit in a transient,
    /// while the trial periods' net cost was over its budget, or where no skip long enough to
    /// pay could pass the error test (predicted from the directly integrated boundaries).
    pub backoff_periods: u64,
}

/// Periods before the pull-off over which [`ApproachRoughness`] looks for fluctuating cycle means.
pub const ROUGHNESS_PERIODS: usize = 16;

/// Roughness of the approach above which a vibrating pull-off is reported as likely sensitive
/// (chaotic). Measured (`djkr run`, default settings): the heavy rig of
/// `scenarios/paper-protocol-300hz.toml`, deterministic to 4.5e-12 between twins, has 1.2e-6;
/// the light rig of `tests/sweep/light-protocol-300hz.toml`, whose pull-off spreads by 3 % over
/// an ensemble, has 0.27. The threshold sits near their geometric mean, a factor of ~500 from
/// each.
pub const ROUGH_APPROACH: f64 = 1e-3;

/// A cheap indicator of a chaotic approach to pull-off, from what a run records anyway: the
/// largest relative second difference of the cycle-mean force,
/// |⟨F⟩ₖ₊₁ − 2⟨F⟩ₖ + ⟨F⟩ₖ₋₁| / |⟨F⟩ₖ|, over the [`ROUGHNESS_PERIODS`] periods before the most tensile
/// cycle mean (the pull-off force). A period-1 orbit under the slow unloading ramp changes its
/// means smoothly (second differences ~1e-6 of the force); once it loses stability the means
/// fluctuate from period to period by a sizeable fraction of the force, and twins whose input
/// differs by one ulp separate (`docs/studies/sensitivity.md`). Only consecutive periods count
/// (envelope following leaves gaps between records). A period whose mean force is zero (no
/// contact for the whole period) has no relative second difference: it is counted instead, and
/// the indicator is then not defined ([`ApproachRoughness::zero_means`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ApproachRoughness {
    /// The last two periods: (end time, cycle-mean force).
    last: [Option<(f64, f64)>; 2],
    /// Start time of the newest of them (consecutive periods share their end and start time
    /// bit for bit: a period starts where the last ended).
    last_start: f64,
    /// Second differences centred on the recent periods, newest last.
    window: std::collections::VecDeque<Second>,
    /// The indicator at the most tensile cycle mean so far (NaN before the first).
    at_min: f64,
    /// Zero means among the periods of the window at the most tensile cycle mean so far.
    zero_at_min: usize,
}

/// A relative second difference of the cycle means, centred on one period.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Second {
    /// The three periods are not consecutive (a gap between records): none taken.
    Gap,
    /// |⟨F⟩ₖ₊₁ − 2⟨F⟩ₖ + ⟨F⟩ₖ₋₁| / |⟨F⟩ₖ|.
    Relative(f64),
    /// ⟨F⟩ₖ = 0: the relative difference is not defined.
    ZeroMean,
}

impl ApproachRoughness {
    /// No period yet.
    pub fn new() -> Self {
        Self {
            at_min: f64::NAN,
            ..Self::default()
        }
    }

    /// Take the period `rec`; `new_min` says whether its mean is the most tensile so far (the
    /// indicator is then taken over the periods before it).
    pub fn record(&mut self, rec: &CycleRecord, new_min: bool) {
        if new_min {
            self.at_min = self
                .window
                .iter()
                .filter_map(|s| match s {
                    Second::Relative(r) => Some(*r),
                    _ => None,
                })
                .fold(f64::NAN, f64::max);
            self.zero_at_min = self
                .window
                .iter()
                .filter(|s| **s == Second::ZeroMean)
                .count();
        }
        let r = match self.last {
            [Some((t0, f0)), Some((t1, f1))]
                if t0.to_bits() == self.last_start.to_bits()
                    && t1.to_bits() == rec.t_start.to_bits() =>
            {
                if f1 == 0.0 {
                    Second::ZeroMean
                } else {
                    Second::Relative((rec.force_mean - 2.0 * f1 + f0).abs() / f1.abs())
                }
            }
            _ => Second::Gap,
        };
        if self.last[1].is_some() {
            if self.window.len() == ROUGHNESS_PERIODS {
                self.window.pop_front();
            }
            self.window.push_back(r);
        }
        self.last = [self.last[1], Some((rec.t_end, rec.force_mean))];
        self.last_start = rec.t_start;
    }

    /// Forget the periods so far (a new pull-off stage starts its own summary).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// The indicator at the pull-off: NaN when no three consecutive periods preceded it, or
    /// when it is not defined there ([`ApproachRoughness::zero_means`] > 0).
    pub fn value(&self) -> f64 {
        if self.zero_at_min > 0 {
            f64::NAN
        } else {
            self.at_min
        }
    }

    /// How many of the periods the indicator looks at before the pull-off had a zero mean
    /// force: where the relative second difference divides by zero.
    pub fn zero_means(&self) -> usize {
        self.zero_at_min
    }
}

/// Events kept in [`RunResult::events`].
pub const EVENT_LOG_LIMIT: usize = 10_000;

/// How many events of each kind a run had.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct EventCounts {
    /// Contact losses.
    pub contact_loss: u64,
    /// Impacts.
    pub impact: u64,
    /// Final detachments.
    pub pull_off: u64,
    /// Preloads reached.
    pub preload_reached: u64,
    /// Stage durations elapsed.
    pub duration_elapsed: u64,
    /// Stage starts.
    pub stage_start: u64,
}

impl EventCounts {
    /// Count one event.
    pub fn add(&mut self, kind: EventKind) {
        match kind {
            EventKind::ContactLoss => self.contact_loss += 1,
            EventKind::Impact => self.impact += 1,
            EventKind::PullOff => self.pull_off += 1,
            EventKind::PreloadReached => self.preload_reached += 1,
            EventKind::DurationElapsed => self.duration_elapsed += 1,
            EventKind::StageStart => self.stage_start += 1,
        }
    }

    /// All events.
    pub fn total(&self) -> u64 {
        self.contact_loss
            + self.impact
            + self.pull_off
            + self.preload_reached
            + self.duration_elapsed
            + self.stage_start
    }

    /// (kind, count) for every kind, in a fixed order.
    pub fn by_kind(&self) -> [(EventKind, u64); 6] {
        [
            (EventKind::ContactLoss, self.contact_loss),
            (EventKind::DurationElapsed, self.duration_elapsed),
            (EventKind::Impact, self.impact),
            (EventKind::PreloadReached, self.preload_reached),
            (EventKind::PullOff, self.pull_off),
            (EventKind::StageStart, self.stage_start),
        ]
    }
}

/// Exact averages over one base period, from quadrature states integrated with the solution
/// (not from decimated output). Harmonics use θ = ω (t − t_on): a signal s(t) over the cycle is
/// `mean + sin · sin θ + cos · cos θ + …` with `sin = (2/T) ∫ s sin θ dt`, `cos = (2/T) ∫ s cos θ dt`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CycleRecord {
    /// Cycle index since the shaker last switched on (0-based).
    pub index: u64,
    /// Stage index at the end of the cycle.
    pub stage: usize,
    /// Start time (s).
    pub t_start: f64,
    /// End time (s).
    pub t_end: f64,
    /// Cycle-mean contact force ⟨F⟩ (N).
    pub force_mean: f64,
    /// First harmonic of F, sine part (N).
    pub force_sin: f64,
    /// First harmonic of F, cosine part (N).
    pub force_cos: f64,
    /// ⟨δ⟩ (m).
    pub delta_mean: f64,
    /// First harmonic of δ, sine part (m).
    pub delta_sin: f64,
    /// First harmonic of δ, cosine part (m).
    pub delta_cos: f64,
    /// ⟨a⟩ (m).
    pub a_mean: f64,
    /// First harmonic of a, sine part (m).
    pub a_sin: f64,
    /// First harmonic of a, cosine part (m).
    pub a_cos: f64,
    /// ⟨x_s⟩ (m).
    pub x_s_mean: f64,
    /// ⟨x_k⟩ (m).
    pub x_k_mean: f64,
    /// Mean force of the holder on the sphere, down + (N): k (⟨x_k⟩ − ⟨x_s⟩) for a spring, F − m g
    /// for a rigid link (its reaction), 0 without a holder.
    pub spring_mean: f64,
    /// First harmonic of the holder force, sine part (N).
    pub spring_sin: f64,
    /// First harmonic of the holder force, cosine part (N).
    pub spring_cos: f64,
    /// Work done by the base on the sphere–contact system over the cycle (J).
    pub work_base: f64,
    /// Work done by the moving spring end over the cycle (J).
    pub work_holder: f64,
    /// Energy dissipated by viscous damping over the cycle (J).
    pub dissipation_damping: f64,
    /// Energy dissipated by the rate-dependent adhesion, ∫ (w0 − w) 2πa ȧ dt (J).
    pub dissipation_adhesion: f64,
    /// Total mechanical energy at the start of the cycle (J; see `dynamics::model::total_energy`).
    pub energy_start: f64,
    /// Total mechanical energy at the end of the cycle (J).
    pub energy_end: f64,
}

/// Watches a run. The driver calls `sample` at the output cadence and `event` for each located
/// event; an observer may ask the run to stop by returning `false` from `sample`.
pub trait Observer {
    /// A time-series sample. Return `false` to stop the run.
    fn sample(&mut self, s: &Sample) -> bool {
        let _ = s;
        true
    }
    /// The time-series samples of one step (the driver's way of handing them over): by default
    /// each is built and handed to [`Observer::sample`]; an observer may keep the step and build
    /// them later, elsewhere, from `model` (the run writer's thread does). Return `false` to stop
    /// the run.
    fn step_samples(&mut self, model: &Model, step: &StepSamples) -> bool {
        step.each(model, |s| self.sample(s))
    }
    /// Whether this observer uses time-series samples at all. The driver skips building them
    /// (a sin/cos, G and w per sample) when it returns `false`; events and cycles still arrive.
    fn wants_samples(&self) -> bool {
        true
    }
    /// A located event.
    fn event(&mut self, e: &Event) {
        let _ = e;
    }
    /// A completed base-period record (only while the shaker is on).
    fn cycle(&mut self, c: &CycleRecord) {
        let _ = c;
    }
    /// A gap in the time series: the samples handed over next start a new segment. Called
    /// before the first sample after the gap, so that an observer counting gaps knows the
    /// segment of every sample as it arrives.
    fn gap(&mut self, g: &Gap) {
        let _ = g;
    }
    /// Why this observer asked the run to stop, when it did for a reason of its own that the
    /// run's status should carry (an in-memory observer over its memory budget:
    /// [`Reason::Memory`]). `None` (the default): a stop that is not the run's to report (e.g.
    /// a sweep abandoning its runs, or a writer whose own error is reported when it finishes).
    fn stop_reason(&self) -> Option<Reason> {
        None
    }
}

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoObserver;
impl Observer for NoObserver {
    fn wants_samples(&self) -> bool {
        false
    }
}

/// An observer that keeps every sample and event in memory.
#[derive(Debug, Default, Clone)]
pub struct Recorder {
    /// Samples, in time order.
    pub samples: Vec<Sample>,
    /// Events, in time order.
    pub events: Vec<Event>,
    /// Cycle records, in time order.
    pub cycles: Vec<CycleRecord>,
    /// Gaps in the time series, in time order.
    pub gaps: Vec<Gap>,
}

impl Observer for Recorder {
    fn sample(&mut self, s: &Sample) -> bool {
        self.samples.push(*s);
        true
    }
    fn event(&mut self, e: &Event) {
        self.events.push(*e);
    }
    fn cycle(&mut self, c: &CycleRecord) {
        self.cycles.push(*c);
    }
    fn gap(&mut self, g: &Gap) {
        self.gaps.push(*g);
    }
}

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
    #[error(
        "step budget exhausted: {steps} steps taken of solver.max_steps = {max_steps}, at t = \
         {t:e} s; {}",
        describe(.state)
    )]
    StepBudget {
        /// Time (s).
        t: f64,
        /// The budget, as the scenario set it.
        max_steps: u64,
        /// Accepted steps taken when the budget ran out (those of envelope following's trial
        /// periods included).
        steps: u64,
        /// State.
        state: Box<Sample>,
    },
    /// `solver.max_events` exhausted.
    #[error("event budget of solver.max_events = {max_events} events exhausted at t = {t:e} s; {}", describe(.state))]
    EventBudget {
        /// Time (s).
        t: f64,
        /// The budget.
        max_events: u64,
        /// State.
        state: Box<Sample>,
    },
    /// Events repeat without time advancing: the run cannot make progress.
    #[error(
        "no progress: {count} contact events at t = {t:e} s without time advancing (the contact \
         forms and is lost again at once; e.g. a work of adhesion too small for the contact to \
         form at the jump-in radius); {}",
        describe(.state)
    )]
    EventLoop {
        /// Time (s).
        t: f64,
        /// Events at that time.
        count: u64,
        /// State.
        state: Box<Sample>,
    },
    /// `solver.max_wall_s` exhausted.
    #[error("wall-clock budget of solver.max_wall_s = {max_wall_s} s exhausted at t = {t:e} s; {}", describe(.state))]
    WallBudget {
        /// Time (s).
        t: f64,
        /// The budget (s).
        max_wall_s: f64,
        /// State.
        state: Box<Sample>,
    },
    /// Cancelled from another thread ([`crate::cancel`]; e.g. Ctrl-C in Python).
    #[error("cancelled at t = {t:e} s")]
    Cancelled {
        /// Time (s).
        t: f64,
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

impl SimError {
    /// Why this error ended a run, as summary.json's `reason` names it (with its `status`:
    /// [`Reason::status`]). [`SimError::Cancelled`] is [`Reason::Sigint`] (an interrupt: Ctrl-C
    /// on the command line, KeyboardInterrupt in Python); the command line, which knows the
    /// signal, makes it [`Reason::Sigterm`] when that was the signal.
    pub fn reason(&self) -> Reason {
        match self {
            SimError::Setup(_) => Reason::Setup,
            SimError::StepSizeUnderflow { .. } => Reason::StepUnderflow,
            SimError::StepBudget { .. } => Reason::MaxSteps,
            SimError::EventBudget { .. } => Reason::MaxEvents,
            SimError::EventLoop { .. } => Reason::NoProgress,
            SimError::WallBudget { .. } => Reason::MaxWallS,
            SimError::Cancelled { .. } => Reason::Sigint,
            SimError::StageTimeout { .. } => Reason::StageTimeout,
            SimError::NonFinite { .. } => Reason::NonFinite,
            SimError::Explicit { .. } => Reason::MethodFailed,
        }
    }
}

/// How a run ended: summary.json's `status`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// The run went through its stages to their end.
    Ok,
    /// A budget stopped it (`solver.max_steps`, `max_wall_s`, `max_events`, `max_memory`) or a
    /// signal (SIGINT, SIGTERM): what it computed up to there is kept.
    Stopped,
    /// The integration failed (a non-finite state, a step-size underflow, ...): what it
    /// computed up to there is kept.
    Failed,
}

impl Status {
    /// The name summary.json gives it: `ok`, `stopped`, `failed`.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Stopped => "stopped",
            Status::Failed => "failed",
        }
    }
}

/// Why a run stopped or failed: summary.json's `reason`. The names are a contract
/// (docs/guide/unattended.md); [`Reason::name`] spells them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reason {
    /// `max_steps`: `solver.max_steps` accepted steps taken.
    MaxSteps,
    /// `max_wall_s`: `solver.max_wall_s` of wall-clock time spent.
    MaxWallS,
    /// `max_events`: `solver.max_events` events located.
    MaxEvents,
    /// `memory`: the samples, events and period records held in memory would pass
    /// `solver.max_memory`.
    Memory,
    /// `disk`: the free space left on the file system of the run's output folder would not
    /// hold the rest of its files (a run writer's watch while the run streams).
    Disk,
    /// `SIGINT`: interrupted (Ctrl-C; KeyboardInterrupt in Python).
    Sigint,
    /// `SIGTERM`: asked to terminate (a batch system's time limit, `kill`).
    Sigterm,
    /// `non-finite`: the state became non-finite and no smaller step cured it.
    NonFinite,
    /// `step-underflow`: the step size fell below what the time resolves.
    StepUnderflow,
    /// `no-progress`: contact events repeat without time advancing.
    NoProgress,
    /// `stage-timeout`: a stage ran for its `max_duration` without meeting its end condition.
    StageTimeout,
    /// `method-failed`: an explicitly requested explicit method met a state it cannot
    /// integrate.
    MethodFailed,
    /// `setup`: the simulator could not set up a computation it needed (an internal error;
    /// a scenario that cannot start is refused before the run instead).
    Setup,
}

impl Reason {
    /// Its name in summary.json.
    pub fn name(self) -> &'static str {
        match self {
            Reason::MaxSteps => "max_steps",
            Reason::MaxWallS => "max_wall_s",
            Reason::MaxEvents => "max_events",
            Reason::Memory => "memory",
            Reason::Disk => "disk",
            Reason::Sigint => "SIGINT",
            Reason::Sigterm => "SIGTERM",
            Reason::NonFinite => "non-finite",
            Reason::StepUnderflow => "step-underflow",
            Reason::NoProgress => "no-progress",
            Reason::StageTimeout => "stage-timeout",
            Reason::MethodFailed => "method-failed",
            Reason::Setup => "setup",
        }
    }

    /// `stopped` for a budget or a signal, `failed` otherwise.
    pub fn status(self) -> Status {
        match self {
            Reason::MaxSteps
            | Reason::MaxWallS
            | Reason::MaxEvents
            | Reason::Memory
            | Reason::Disk
            | Reason::Sigint
            | Reason::Sigterm => Status::Stopped,
            _ => Status::Failed,
        }
    }
}

/// How a run ended, as summary.json reports it: `status`, `reason` (none for a run that went to
/// its end) and a `message` saying what stopped it, when and in which stage.
#[derive(Debug, Clone, PartialEq)]
pub struct Ending {
    /// Why it stopped or failed (`None` when ok).
    pub reason: Option<Reason>,
    /// What happened, where (`None` when ok).
    pub message: Option<String>,
}

impl Ending {
    /// A run that went through its stages.
    pub fn ok() -> Self {
        Ending {
            reason: None,
            message: None,
        }
    }

    /// A run ended early for `reason`, with `message` saying what happened.
    pub fn early(reason: Reason, message: String) -> Self {
        Ending {
            reason: Some(reason),
            message: Some(message),
        }
    }

    /// `ok`, `stopped` or `failed`: what its reason implies.
    pub fn status(&self) -> Status {
        self.reason.map_or(Status::Ok, Reason::status)
    }
}

/// A run that started, however it ended: its result up to where it ended, and what ended it
/// early. [`crate::dynamics::protocol::run_partial`] returns it, so that a run stopped by a
/// budget or failed mid-way keeps what it computed (like SciPy's `solve_ivp`: status, message,
/// the solution so far).
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The result up to the end or the stop (`final_state` is where the run got to).
    pub result: RunResult,
    /// The error that ended the run early (`None`: it ran to its end, or its observer stopped
    /// it).
    pub error: Option<SimError>,
    /// The observer's reason, when the observer stopped the run for one
    /// ([`Observer::stop_reason`]).
    pub observer_reason: Option<Reason>,
}

impl Outcome {
    /// The run's status, reason and message. The message is the error's (or the observer's
    /// reason) followed by where the run got to: its time and stage.
    pub fn ending(&self) -> Ending {
        let f = &self.result.final_state;
        let place = format!("the run got to t = {:e} s in stage {}", f.t, f.stage);
        if let Some(e) = &self.error {
            return Ending::early(e.reason(), format!("{e} ({place})"));
        }
        match self.observer_reason {
            Some(Reason::Memory) => Ending::early(
                Reason::Memory,
                format!(
                    "memory budget exhausted: the samples, events and period records held in \
                     memory would pass solver.max_memory ({place})"
                ),
            ),
            Some(Reason::Disk) => Ending::early(
                Reason::Disk,
                format!(
                    "disk space low: the free space left on the file system of the output \
                     folder would not hold the rest of the run's files; the run stopped and \
                     kept what it had written ({place})"
                ),
            ),
            Some(r) => Ending::early(r, format!("stopped: {} ({place})", r.name())),
            None => Ending::ok(),
        }
    }

    /// The result when the run went to its end (or its observer stopped it without a reason),
    /// the error otherwise: what [`crate::dynamics::run`] returns.
    pub fn into_result(self) -> Result<RunResult, SimError> {
        match self.error {
            Some(e) => Err(e),
            None => Ok(self.result),
        }
    }
}

fn describe(s: &Sample) -> String {
    format!(
        "state: stage {}, x_s = {:e} m, v_s = {:e} m/s, delta = {:e} m, a = {:e} m, a_dot = {:e} m/s, F = {:e} N, G = {:e} J/m^2",
        s.stage, s.x_s, s.v_s, s.delta, s.a, s.a_dot, s.force, s.g
    )
}

/// Build the time-series sample of a state.
pub(crate) fn make_sample(m: &Model, drive: &Drive, y: &State, stage: usize) -> Sample {
    knot_sample(m, drive, &Knot::from(y), stage)
}

/// The time-series samples of one step on the output grid: `n` samples at `t_first`,
/// `t_first + dt`, … (the times accumulated by repeated addition, as the driver's grid is),
/// interpolated on the step (`Knot::hermite`); with `dt = 0`, the one sample at its end.
/// The driver hands them to [`Observer::step_samples`] a step at a time, so that
/// an observer may build them elsewhere (the run writer's thread).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepSamples {
    /// The step's start.
    pub k0: Knot,
    /// The step's end.
    pub k1: Knot,
    /// The prescribed motions over it.
    pub drive: Drive,
    /// The stage index.
    pub stage: usize,
    /// The first sample's time (s).
    pub t_first: f64,
    /// The grid spacing (s); 0: the one sample at the step's end.
    pub dt: f64,
    /// Number of samples.
    pub n: usize,
}

impl StepSamples {
    /// Build the samples in time order, handing each to `f`; stops (and returns `false`) when
    /// `f` does.
    pub fn each(&self, m: &Model, mut f: impl FnMut(&Sample) -> bool) -> bool {
        if self.dt <= 0.0 {
            return self.n == 0 || f(&knot_sample(m, &self.drive, &self.k1, self.stage));
        }
        let mut t = self.t_first;
        for _ in 0..self.n {
            let k = Knot::hermite(&self.k0, &self.k1, t);
            if !f(&knot_sample(m, &self.drive, &k, self.stage)) {
                return false;
            }
            t += self.dt;
        }
        true
    }

    /// The sample at the step's end (which need not be on the grid): for progress displays.
    pub fn end(&self, m: &Model) -> Sample {
        knot_sample(m, &self.drive, &self.k1, self.stage)
    }
}

/// The time-series sample at a knot.
fn knot_sample(m: &Model, drive: &Drive, y: &Knot, stage: usize) -> Sample {
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

#[cfg(test)]
mod pull_off_tests {
    use super::*;

    #[test]
    fn only_a_tensile_force_has_an_amplification() {
        let f0 = -0.0577;
        let p = PullOffSummary::new(-0.1154, 2.0, f0);
        assert!(p.is_tensile());
        assert!((p.amplification - 2.0).abs() < 1e-12);
        // A compressive or zero "most tensile" mean: no pull-off, no (negative, -0) ratio.
        for force in [0.0026871761515546567, 0.0, -0.0] {
            let p = PullOffSummary::new(force, 0.065, f0);
            assert!(!p.is_tensile(), "{force}");
            assert!(p.amplification.is_nan(), "{force}");
        }
    }
}

#[cfg(test)]
mod roughness_tests {
    use super::*;

    fn period(k: usize, force_mean: f64) -> CycleRecord {
        let t = k as f64 * 0.01;
        let mut r = CYCLE0;
        r.index = k as u64;
        r.t_start = t;
        // The next period's start, bit for bit (as the simulator's records are).
        r.t_end = (k + 1) as f64 * 0.01;
        r.force_mean = force_mean;
        r
    }

    const CYCLE0: CycleRecord = CycleRecord {
        index: 0,
        stage: 0,
        t_start: 0.0,
        t_end: 0.0,
        force_mean: 0.0,
        force_sin: 0.0,
        force_cos: 0.0,
        delta_mean: 0.0,
        delta_sin: 0.0,
        delta_cos: 0.0,
        a_mean: 0.0,
        a_sin: 0.0,
        a_cos: 0.0,
        x_s_mean: 0.0,
        x_k_mean: 0.0,
        spring_mean: 0.0,
        spring_sin: 0.0,
        spring_cos: 0.0,
        work_base: 0.0,
        work_holder: 0.0,
        dissipation_damping: 0.0,
        dissipation_adhesion: 0.0,
        energy_start: 0.0,
        energy_end: 0.0,
    };

    /// Feed `means` as consecutive periods, the minimum tracked as the protocol does.
    fn roughness(means: &[f64], skip_after: Option<usize>) -> f64 {
        let mut r = ApproachRoughness::new();
        let mut min = f64::INFINITY;
        for (k, &f) in means.iter().enumerate() {
            // A gap (envelope jump) of 100 periods after `skip_after`.
            let k = k + if skip_after.is_some_and(|s| k > s) {
                100
            } else {
                0
            };
            r.record(&period(k, f), f < min);
            min = min.min(f);
        }
        r.value()
    }

    #[test]
    fn a_smooth_approach_is_smooth_and_a_fluctuating_one_rough() {
        // A ramp with a slowly growing curvature: second differences ~1e-6 of the force.
        let smooth: Vec<f64> = (0..40)
            .map(|k| -0.1 - 1e-3 * k as f64 - 1e-7 * (k * k) as f64)
            .collect();
        let r = roughness(&smooth, None);
        assert!(r > 0.0 && r < ROUGH_APPROACH, "{r}");
        // Period-to-period fluctuations of a few % before the minimum.
        let mut rough = smooth.clone();
        rough[30] += 0.005;
        rough[35] -= 0.003;
        let r = roughness(&rough, None);
        assert!(r > ROUGH_APPROACH, "{r}");
        // After the minimum nothing counts: the means rise again while the contact comes apart.
        let mut after = smooth.clone();
        after.extend([-0.1, -0.05, 0.0, -0.02]);
        assert_eq!(
            roughness(&after, None).to_bits(),
            roughness(&smooth, None).to_bits()
        );
        // Across a gap between records (an envelope jump, over which the means moved by a
        // step) no second difference is taken.
        let mut gap = smooth.clone();
        gap[30..].iter_mut().for_each(|f| *f -= 0.01);
        assert!(roughness(&gap, Some(29)) < ROUGH_APPROACH);
        assert!(roughness(&gap, None) > ROUGH_APPROACH);
        // Fewer than three consecutive periods: not measured.
        assert!(roughness(&[-0.1, -0.2], None).is_nan());
    }

    #[test]
    fn a_zero_mean_before_the_pull_off_leaves_the_roughness_undefined() {
        // A bouncing approach: a period without contact (mean force exactly 0) among tensile
        // ones. The relative second difference there would divide by zero.
        let mut means: Vec<f64> = (0..40).map(|k| -0.1 - 1e-3 * k as f64).collect();
        means[33] = 0.0;
        means[36] = 0.0;
        let mut r = ApproachRoughness::new();
        let mut min = f64::INFINITY;
        for (k, &f) in means.iter().enumerate() {
            r.record(&period(k, f), f < min);
            min = min.min(f);
        }
        assert!(r.value().is_nan(), "{}", r.value());
        assert_eq!(r.zero_means(), 2);
        // Once those periods have left the window, the indicator is defined again (and rough:
        // the means jumped).
        let mut later = means.clone();
        later.extend((40..80).map(|k| -0.1 - 1e-3 * k as f64 + if k == 75 { 0.01 } else { 0.0 }));
        let mut r = ApproachRoughness::new();
        let mut min = f64::INFINITY;
        for (k, &f) in later.iter().enumerate() {
            r.record(&period(k, f), f < min);
            min = min.min(f);
        }
        assert_eq!(r.zero_means(), 0);
        assert!(
            r.value().is_finite() && r.value() > ROUGH_APPROACH,
            "{}",
            r.value()
        );
    }
}
