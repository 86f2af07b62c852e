//! The simulator: one integrator stepping the model under a drive, with step-size control,
//! event location, contact formation and loss, base-period records and budgets. Each
//! [`Simulator::step`] returns why it stopped — an accepted step, an event, a base period ended,
//! the stop time reached — in the manner of diffsol's `step()`; the caller (the stage
//! [`protocol`](super::protocol), shooting, continuation) decides what to do next and may
//! [`reset`](Simulator::reset) the state or move the stop time ([`Simulator::advance_to`])
//! without building a scenario.

use super::control::StepControl;
use super::events::{self, Watch};
use super::methods::Solver;
use super::model::{self, q, Drive, Kinematics, Mechanics, Model, NQ};
use super::state::{State, StepFail, StepOut, Tol};
use super::stepper::Stepper;
use super::types::{make_sample, CycleRecord, EventKind, Sample, SimError, Stats};
use crate::adhesion::AdhesionLaw;
use crate::cancel::Cancel;
use crate::jkr;
use crate::rig::ContactFormation;
use std::f64::consts::PI;
use std::time::Instant;

/// Budgets and tolerances of a simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Error-norm tolerances.
    pub tol: Tol,
    /// Event location tolerance in time (s).
    pub event_tol: f64,
    /// Accepted-step budget.
    pub max_steps: u64,
    /// Wall-clock budget (s).
    pub max_wall_s: f64,
    /// Event budget (contact losses, impacts, preloads reached).
    pub max_events: u64,
    /// Samples are interpolated on a time grid between step ends (DP8 then keeps its steps to
    /// 1/16 of a base period).
    pub interpolated_samples: bool,
    /// Polled with the wall-clock budget: a raised flag stops the run with
    /// [`SimError::Cancelled`].
    pub cancel: Cancel,
}

impl From<&Solver> for Settings {
    /// The simulator's settings from a scenario's `[solver]` section: its tolerances and
    /// budgets as given (a negative `event_tol` taken as 0), samples at step ends
    /// (`interpolated_samples` false: a caller that interpolates on a time grid sets it).
    fn from(s: &Solver) -> Self {
        Self {
            tol: Tol {
                rtol: s.rtol,
                atol: s.atol,
            },
            event_tol: s.event_tol.max(0.0),
            max_steps: s.max_steps,
            max_wall_s: s.max_wall_s,
            max_events: s.max_events,
            interpolated_samples: false,
            cancel: s.cancel,
        }
    }
}

/// A stretch of the solution between two states of one step, under the drive that held over
/// it (a period record at its end may switch the shaker off afterwards).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Start.
    pub y0: State,
    /// End.
    pub y1: State,
    /// The prescribed motions over it.
    pub drive: Drive,
}

/// One base period integrated on a scratch simulator ([`Simulator::trial_period`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrialPeriod {
    /// The state at the end of the period.
    pub end: State,
    /// The period's record.
    pub record: CycleRecord,
    /// A contact loss or an impact happened within it.
    pub rough: bool,
}

/// Why [`Simulator::step`] returned. The period record and the event state are boxed: every
/// step returns a `Stop` through three calls, and carried inline (216 bytes) their copies were
/// 1.8 % of the integration on the compiled peer's scene; a period ends every few steps and an
/// event rarely.
#[derive(Debug, Clone, PartialEq)]
pub enum Stop {
    /// An accepted step; [`Simulator::segment`] is its start and end. `period` is the record of
    /// a base period that ended with it; `reached` says the stop time was reached.
    Step {
        /// The record of the base period ending at this step's end.
        period: Option<Box<CycleRecord>>,
        /// The step ended at the stop time.
        reached: bool,
    },
    /// The short backward-Euler step that gives a newly formed contact its healing rate
    /// (taken right after an [`EventKind::Impact`]); [`Simulator::segment`] spans it.
    Kick,
    /// A located event (contact loss, impact, preload reached) with the state at the event; the
    /// step leading up to it, if any, is [`Simulator::segment`]. After a contact loss the
    /// simulator's state is already out of contact; after an impact it is the formed contact.
    Event(EventKind, Box<State>),
    /// A base period ended at the current time (without a step: a boundary met by rounding).
    Period(Box<CycleRecord>),
    /// The stop time was reached (without a step).
    Reached,
}

/// The base-period clock: where the current period started, and the quadratures and energy
/// there.
#[derive(Debug, Clone, Copy)]
struct Cycles {
    index: u64,
    t0: f64,
    q0: [f64; NQ],
    e0: f64,
    /// The shaker switches off at the next period boundary (x_b stays continuous).
    off_pending: bool,
    /// The shaker starts at this time (a base phase delays it after the switching stage starts).
    armed_at: Option<f64>,
}

/// One integrator stepping the model of a rig.
pub struct Simulator {
    model: Model,
    drive: Drive,
    stepper: Box<dyn Stepper>,
    control: StepControl,
    settings: Settings,
    formation: ContactFormation,
    y: State,
    stats: Stats,
    start: Instant,
    /// The stop time (s).
    t_end: f64,
    /// The preload whose crossing ends the current stretch (approach stages).
    preload: Option<f64>,
    /// The base-period clock and what a period record starts from.
    cycles: Cycles,
    /// A time at which a stage solve found no root (the contact collapses before it).
    collapse_at: Option<f64>,
    /// A contact just formed and awaits its backward-Euler kick.
    kick_pending: bool,
    segment: Option<Segment>,
    /// The last step attempt, written in place by the stepper.
    out: StepOut,
    /// Stage index reported in samples, records and errors.
    stage: usize,
    /// Units of work done (attempts and events), for the wall-clock cadence.
    work: u64,
    /// Contact events so far (losses, impacts, preloads).
    events: u64,
    /// Time of the last contact event and how many happened at it (no-progress guard).
    event_time: (f64, u64),
}

/// Contact events at one time (within what it resolves) after which a run is declared stuck.
const EVENT_LOOP_LIMIT: u64 = 64;

impl Simulator {
    /// A simulator for `model` with `stepper`, starting at `y` under `drive` (the shaker's
    /// period records start now if it is on). The stop time is +∞ until
    /// [`advance_to`](Self::advance_to) sets one.
    pub fn new(
        model: Model,
        stepper: Box<dyn Stepper>,
        formation: ContactFormation,
        settings: Settings,
        y: State,
        drive: Drive,
    ) -> Self {
        let mut sim = Self {
            control: StepControl::new(1e-3 * model.t_char),
            model,
            drive,
            stepper,
            settings,
            formation,
            y,
            stats: Stats::default(),
            start: Instant::now(),
            t_end: f64::INFINITY,
            preload: None,
            cycles: Cycles {
                index: 0,
                t0: y.t,
                q0: y.q,
                e0: 0.0,
                off_pending: false,
                armed_at: None,
            },
            collapse_at: None,
            kick_pending: false,
            segment: None,
            out: StepOut::default(),
            stage: 0,
            work: 0,
            events: 0,
            event_time: (f64::NAN, 0),
        };
        sim.refresh();
        if sim.drive.shaker {
            sim.start_cycles();
        }
        sim
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The prescribed motions.
    pub fn drive(&self) -> &Drive {
        &self.drive
    }

    /// The current state.
    pub fn state(&self) -> &State {
        &self.y
    }

    /// Solver statistics so far (wall time filled in by [`Simulator::finish_stats`]).
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// The statistics with the wall time since the simulator was made.
    pub fn finish_stats(&mut self) -> Stats {
        self.stats.wall_s = self.start.elapsed().as_secs_f64();
        self.stats
    }

    /// Budgets and tolerances.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The stepper (its name and rescue count are reported with the run).
    pub fn stepper(&self) -> &dyn Stepper {
        self.stepper.as_ref()
    }

    /// The step behind the last [`Stop::Step`], [`Stop::Kick`] or [`Stop::Event`].
    pub fn segment(&self) -> Option<&Segment> {
        self.segment.as_ref()
    }

    /// Label what follows with stage index `stage` (samples in errors, period records).
    pub fn set_stage(&mut self, stage: usize) {
        self.stage = stage;
    }

    /// Index of the current base period since the shaker switched on.
    pub fn period_index(&self) -> u64 {
        self.cycles.index
    }

    /// The base period T = 2π/ω (s; +∞ without base motion).
    pub fn period(&self) -> f64 {
        if self.model.omega > 0.0 {
            2.0 * PI / self.model.omega
        } else {
            f64::INFINITY
        }
    }

    /// The time (s) at which base period `k` (since the shaker switched on) starts.
    pub fn boundary_time(&self, k: u64) -> f64 {
        self.drive.t_on + k as f64 * 2.0 * PI / self.model.omega
    }

    /// The stop time (s).
    pub fn stop_time(&self) -> f64 {
        self.t_end
    }

    /// True while the shaker runs periods and will not switch off at the next boundary.
    pub fn vibrating_steadily(&self) -> bool {
        self.drive.shaker
            && self.model.omega > 0.0
            && !self.cycles.off_pending
            && self.cycles.armed_at.is_none()
    }

    /// A state at the start of base period `k` with sphere position `x`, velocity `v` and
    /// contact radius `a` (in contact), its rate ȧ from the law: the start of a trial period or
    /// of a jump. `q` (the quadratures, whose differences make period records) is carried over.
    pub fn state_at_boundary(&self, k: u64, x: f64, v: f64, a: f64, q: [f64; NQ]) -> State {
        let t = self.boundary_time(k);
        let kin = self.kin(t);
        let g = self.model.signed_g(a, x + kin.xb);
        let adot = self.model.crack_speed(g);
        State {
            t,
            x,
            v,
            acc: self.model.accel(&kin, x, v, a, true),
            a,
            adot,
            contact: true,
            q,
        }
    }

    /// Jump to `z`, the state at the start of base period `period_index() + periods` (envelope
    /// following: the periods between are not integrated). Period records resume from there.
    pub fn jump(&mut self, z: State, periods: u64) {
        self.y = z;
        self.collapse_at = None;
        self.kick_pending = false;
        self.refresh();
        let kin = self.kin(z.t);
        self.cycles.index += periods;
        self.cycles.t0 = z.t;
        self.cycles.q0 = z.q;
        self.cycles.e0 = model::total_energy(&self.model, &kin, z.x, z.v, z.a, z.contact);
    }

    /// Integrate one whole base period from `z` (at the start of period `k`) on a scratch copy
    /// of this simulator (same model, drive, method and settings; nothing carried over): the end
    /// state, the period's record, and whether a contact loss or impact happened within it. Its
    /// work is added to this simulator's statistics and budgets.
    /// `tol_factor` scales the tolerances of the trial (envelope following integrates its trial
    /// periods more tightly than the run: an integration error in one period is multiplied by
    /// the number of periods a jump covers).
    pub fn trial_period(
        &mut self,
        z: State,
        k: u64,
        tol_factor: f64,
    ) -> Result<TrialPeriod, SimError> {
        let mut settings = self.settings;
        settings.tol.rtol = (settings.tol.rtol * tol_factor).max(1e-14);
        settings.tol.atol = (settings.tol.atol * tol_factor).max(1e-300);
        settings.max_steps = settings.max_steps.saturating_sub(self.stats.steps).max(1);
        let wall_left = settings.max_wall_s - self.start.elapsed().as_secs_f64();
        if wall_left <= 0.0 {
            return Err(SimError::WallBudget {
                t: self.y.t,
                max_wall_s: self.settings.max_wall_s,
                state: self.err_state(),
            });
        }
        settings.max_wall_s = wall_left;
        let mut trial = Simulator {
            control: self.control.for_trial(tol_factor),
            model: self.model.clone(),
            drive: self.drive,
            stepper: self.stepper.fresh(),
            settings,
            formation: self.formation,
            y: z,
            stats: Stats::default(),
            start: Instant::now(),
            t_end: f64::INFINITY,
            preload: None,
            cycles: Cycles {
                index: k,
                t0: z.t,
                q0: z.q,
                e0: 0.0,
                off_pending: false,
                armed_at: None,
            },
            collapse_at: None,
            kick_pending: false,
            segment: None,
            out: StepOut::default(),
            stage: self.stage,
            work: 0,
            events: 0,
            event_time: (f64::NAN, 0),
        };
        trial.refresh();
        let kin = trial.kin(z.t);
        trial.cycles.e0 = model::total_energy(&trial.model, &kin, z.x, z.v, z.a, z.contact);
        trial.advance_to(trial.boundary_time(k + 1), None);
        let mut rough = false;
        let out = loop {
            match trial.step() {
                Ok(Stop::Step {
                    period: Some(rec), ..
                })
                | Ok(Stop::Period(rec)) => break Ok((rec, trial.y)),
                Ok(Stop::Event(..)) => rough = true,
                Ok(Stop::Reached) => {
                    break Err(SimError::Setup(
                        "a trial period ended without its period record".into(),
                    ))
                }
                Ok(_) => {}
                Err(e) => break Err(e),
            }
        };
        self.stats.steps += trial.stats.steps;
        self.stats.rejected += trial.stats.rejected;
        self.stats.rhs_evals += trial.stats.rhs_evals;
        // The trial ran on what was left of the run's budgets: an exhausted one is the run's,
        // reported with the run's own budget, steps and time (the trial's would name what was
        // left, e.g. "734 steps", and a time ahead of the run's last accepted state).
        let out = out.map_err(|e| match e {
            SimError::StepBudget { .. } => SimError::StepBudget {
                t: self.y.t,
                max_steps: self.settings.max_steps,
                steps: self.stats.steps,
                state: self.err_state(),
            },
            SimError::WallBudget { .. } => SimError::WallBudget {
                t: self.y.t,
                max_wall_s: self.settings.max_wall_s,
                state: self.err_state(),
            },
            e => e,
        });
        let (record, end) = out?;
        Ok(TrialPeriod {
            end,
            record: *record,
            rough,
        })
    }

    /// Stop at time `t_end` (s): [`Stop::Reached`] (or a step with `reached`) when it is hit.
    /// `preload`: also end at the first crossing of the contact force up through it (N).
    pub fn advance_to(&mut self, t_end: f64, preload: Option<f64>) {
        self.t_end = t_end;
        self.preload = preload;
    }

    /// Restart from `y` under `drive` (the state need not follow from the current one): cached
    /// evaluations are dropped, and the period records restart if the shaker is on.
    pub fn reset(&mut self, y: State, drive: Drive) {
        self.y = y;
        self.drive = drive;
        self.control.forget_periods();
        self.collapse_at = None;
        self.kick_pending = false;
        self.cycles.off_pending = false;
        self.cycles.armed_at = None;
        self.refresh();
        if self.drive.shaker {
            self.start_cycles();
        }
    }

    /// Move the spring end at `speed` (m/s, + towards the substrate) from where it is now.
    pub fn set_spring_end_speed(&mut self, speed: f64) {
        let t0 = self.y.t;
        self.drive.xk0 = self.drive.x_k(t0);
        self.drive.tk0 = t0;
        self.drive.xk_speed = speed;
    }

    /// Switch the shaker on now (at phase 0, so x_b is continuous), or off at the next base
    /// period boundary (same reason). Call [`Simulator::refresh`] after changing the drive.
    /// With a base phase φ the shaker starts φ/ω later, at phase 0 of its own motion.
    pub fn set_shaker(&mut self, on: bool) {
        if on {
            self.cycles.off_pending = false;
            if self.model.omega > 0.0 && !self.drive.shaker && self.cycles.armed_at.is_none() {
                if self.model.shaker_delay > 0.0 {
                    self.cycles.armed_at = Some(self.y.t + self.model.shaker_delay);
                } else {
                    self.switch_on();
                }
            }
        } else if self.drive.shaker {
            self.cycles.off_pending = true;
        } else {
            self.cycles.armed_at = None;
        }
    }

    /// The longest step: 1/8 of the period of the fastest motion the scene has now (the base
    /// while the shaker is on, else the free oscillation of sphere and spring on the contact),
    /// and at most 10 characteristic times. With the shaker off, a base-period cap would make a
    /// quiet dwell cost as many steps as a vibrating one (measured: 292k steps for the paper's
    /// 60 s dwell at 300 Hz, 21k without).
    fn h_max(&self) -> f64 {
        let m = &self.model;
        let fastest = if self.drive.shaker && m.omega > 0.0 {
            2.0 * PI / m.omega
        } else {
            m.t_free
        };
        (fastest / 8.0).min(10.0 * m.t_char)
    }

    /// The shaker starts now, at phase 0.
    fn switch_on(&mut self) {
        self.drive.shaker = true;
        self.drive.t_on = self.y.t;
        self.control.forget_periods();
        self.start_cycles();
    }

    /// A boundary at the current time was reached: the armed shaker starts, or a base period
    /// ends (its record).
    fn at_boundary(&mut self) -> Option<CycleRecord> {
        if self.cycles.armed_at.take().is_some() {
            self.switch_on();
            self.refresh();
            return None;
        }
        self.control.next_period();
        Some(self.record_cycle())
    }

    /// Refresh the derived parts of the state (acceleration; x, v for the reduced mechanics)
    /// after the drive changed, and forget what the stepper carried over.
    pub fn refresh(&mut self) {
        self.stepper.reset();
        self.control.reset();
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

    /// The prescribed quantities at time t.
    pub fn kin(&self, t: f64) -> Kinematics {
        self.drive.at(&self.model, t)
    }

    /// The time-series sample of a state (stage index `stage`).
    pub fn sample_of(&self, y: &State, stage: usize) -> Sample {
        make_sample(&self.model, &self.drive, y, stage)
    }

    /// Contact force of a state (N; 0 out of contact).
    pub fn force_of(&self, y: &State) -> f64 {
        if !y.contact {
            return 0.0;
        }
        let kin = self.kin(y.t);
        jkr::contact_force(&self.model.mat, y.a, y.x + kin.xb)
    }

    /// dF/dt of a state (N/s; 0 out of contact).
    pub fn force_rate(&self, y: &State) -> f64 {
        if !y.contact {
            return 0.0;
        }
        let kin = self.kin(y.t);
        let (k, r) = (self.model.mat.k, self.model.mat.r);
        let d = y.x + kin.xb;
        0.5 * k * (3.0 * d - 3.0 * y.a * y.a / r) * y.adot + 1.5 * k * y.a * (y.v + kin.vb)
    }

    /// A fresh step of length `h` from `y` (exact re-stepping for searches within a step); `None`
    /// when it fails.
    pub fn trial(&mut self, y: &State, h: f64) -> Option<State> {
        match self.try_step(y, h) {
            Ok(true) => Some(self.out.y),
            _ => None,
        }
    }

    /// Smallest step (s) the time resolves.
    pub fn h_min(&self) -> f64 {
        8.0 * f64::EPSILON * self.y.t.abs().max(self.model.t_char)
    }

    /// Take the next step, or handle what is due: the kick of a new contact, a contact formed at
    /// rest, a period boundary or the stop time. Rejected attempts are retried inside, each
    /// under the budgets.
    pub fn step(&mut self) -> Result<Stop, SimError> {
        self.segment = None;
        let stop = if self.kick_pending {
            self.kick_pending = false;
            self.budget()?;
            self.kick()?
        } else {
            loop {
                if let Some(stop) = self.attempt()? {
                    break stop;
                }
            }
        };
        if let Stop::Event(_, ye) = &stop {
            self.count_event(ye.t)?;
        }
        Ok(stop)
    }

    /// Count a contact event at time `t`; error when they repeat without time advancing.
    fn count_event(&mut self, t: f64) -> Result<(), SimError> {
        self.events += 1;
        let (t0, n) = self.event_time;
        if (t - t0).abs() <= 4.0 * self.h_min() {
            self.event_time.1 = n + 1;
            if n + 1 >= EVENT_LOOP_LIMIT {
                return Err(SimError::EventLoop {
                    t,
                    count: n + 1,
                    state: self.err_state(),
                });
            }
        } else {
            self.event_time = (t, 1);
        }
        Ok(())
    }

    fn err_state(&self) -> Box<Sample> {
        Box::new(self.sample_of(&self.y, self.stage))
    }

    /// The step size fell below what the time resolves at `t`: the stepper's more robust
    /// method, if it has one, takes the next attempts from a fresh proposal; otherwise the run
    /// fails.
    fn fall_back(&mut self, t: f64, h: f64) -> Result<Option<Stop>, SimError> {
        if self.stepper.fallback() {
            self.control.h = 1e-3 * self.model.t_char;
            return Ok(None);
        }
        Err(self.underflow(t, h))
    }

    /// The step size fell below what the time resolves at `t`.
    fn underflow(&self, t: f64, h: f64) -> SimError {
        SimError::StepSizeUnderflow {
            t,
            h,
            state: self.err_state(),
        }
    }

    /// Check the budgets; every unit of work (a step attempt, an event) passes here, so they
    /// hold in every loop.
    fn budget(&mut self) -> Result<(), SimError> {
        self.work += 1;
        if self.stats.steps >= self.settings.max_steps {
            return Err(SimError::StepBudget {
                t: self.y.t,
                max_steps: self.settings.max_steps,
                steps: self.stats.steps,
                state: self.err_state(),
            });
        }
        if self.events >= self.settings.max_events {
            return Err(SimError::EventBudget {
                t: self.y.t,
                max_events: self.settings.max_events,
                state: self.err_state(),
            });
        }
        // The clock costs ~20 ns; a unit of work ~1 µs.
        if self.work.is_multiple_of(64) {
            if self.settings.cancel.is_cancelled() {
                return Err(SimError::Cancelled { t: self.y.t });
            }
            let wall = self.start.elapsed().as_secs_f64();
            if wall > self.settings.max_wall_s {
                return Err(SimError::WallBudget {
                    t: self.y.t,
                    max_wall_s: self.settings.max_wall_s,
                    state: self.err_state(),
                });
            }
        }
        Ok(())
    }

    /// The time since the start of the current base period at `t` (s), while the shaker runs
    /// steadily (`None` otherwise): where step control looks up the last period's attempts.
    fn period_offset(&self, t: f64) -> Option<f64> {
        if !self.vibrating_steadily() {
            return None;
        }
        Some(t - self.boundary_time(self.cycles.index))
    }

    fn next_boundary(&self) -> f64 {
        if let Some(t) = self.cycles.armed_at {
            t
        } else if self.drive.shaker && self.model.omega > 0.0 {
            self.boundary_time(self.cycles.index + 1)
        } else {
            f64::INFINITY
        }
    }

    fn start_cycles(&mut self) {
        let y = self.y;
        let kin = self.kin(y.t);
        self.cycles = Cycles {
            index: 0,
            t0: y.t,
            q0: y.q,
            e0: model::total_energy(&self.model, &kin, y.x, y.v, y.a, y.contact),
            off_pending: self.cycles.off_pending,
            armed_at: None,
        };
    }

    fn record_cycle(&mut self) -> CycleRecord {
        let y = self.y;
        let c = self.cycles;
        let tt = y.t - c.t0;
        let d: [f64; NQ] = std::array::from_fn(|i| y.q[i] - c.q0[i]);
        let kin = self.kin(y.t);
        let e1 = model::total_energy(&self.model, &kin, y.x, y.v, y.a, y.contact);
        let m = |i: usize| d[i] / tt;
        let hh = |i: usize| 2.0 * d[i] / tt;
        let rec = CycleRecord {
            index: c.index,
            stage: self.stage,
            t_start: c.t0,
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
            energy_start: c.e0,
            energy_end: e1,
        };
        self.cycles.index += 1;
        self.cycles.t0 = y.t;
        self.cycles.q0 = y.q;
        self.cycles.e0 = e1;
        if self.cycles.off_pending {
            self.cycles.off_pending = false;
            self.drive.shaker = false;
            self.refresh();
        }
        rec
    }

    /// Try a step into `self.out`; `Ok(false)` for a failed stage solve (counted as 12
    /// evaluations).
    fn try_step(&mut self, y: &State, h: f64) -> Result<bool, StepFail> {
        let mut extra = 0;
        let r = self.stepper.attempt(
            &self.model,
            &self.drive,
            y,
            h,
            self.settings.tol,
            &mut extra,
            &mut self.out,
        );
        self.stats.rhs_evals += extra;
        match r {
            Ok(()) => {
                self.stats.rhs_evals += self.out.evals;
                Ok(true)
            }
            Err(StepFail::NoRoot) => {
                self.stats.rhs_evals += 12;
                Ok(false)
            }
            Err(e) => Err(e),
        }
    }

    fn watch_value(&self, w: Watch, y: &State) -> f64 {
        match w {
            Watch::Loss => y.a - self.model.a_floor,
            Watch::Impact => y.x + self.kin(y.t).xb,
            Watch::Preload(p) => self.force_of(y) - p,
        }
    }

    /// Locate the crossing of `w` within the step y0 → y1 (length h).
    fn locate(&mut self, w: Watch, y0: &State, y1: Option<State>, h: f64) -> State {
        let t_tol = self.settings.event_tol.max(4.0 * f64::EPSILON * y0.t.abs());
        let a_floor = self.model.a_floor;
        // The simulator is borrowed by both closures: the values are read through a copy of
        // what they need.
        let model = self.model.clone();
        let drive = self.drive;
        let g = move |y: Option<&State>| match y {
            Some(y) => match w {
                Watch::Loss => y.a - a_floor,
                Watch::Impact => y.x + drive.at(&model, y.t).xb,
                Watch::Preload(p) => {
                    let f = if y.contact {
                        jkr::contact_force(&model.mat, y.a, y.x + drive.at(&model, y.t).xb)
                    } else {
                        0.0
                    };
                    f - p
                }
            },
            // A failed stage solve: the contact has collapsed.
            None => -a_floor,
        };
        events::locate(w, y0, y1, h, t_tol, g, |th| self.trial(y0, th))
    }

    /// The contact forms now (impact): at the jump-in radius or the seed; the backward-Euler
    /// kick that gives it its healing rate follows at the next [`Simulator::step`].
    fn form_contact(&mut self) -> Stop {
        let a0 = match self.formation {
            ContactFormation::JumpIn => self.model.a_jump,
            ContactFormation::Seed(r) => r,
        };
        self.y.contact = true;
        self.y.a = a0;
        self.y.adot = 0.0;
        self.collapse_at = None;
        self.refresh();
        self.kick_pending = true;
        Stop::Event(EventKind::Impact, Box::new(self.y))
    }

    /// The kick of a newly formed contact: one backward-Euler step of 10⁻⁷ t_char, whose end
    /// rate is the (possibly enormous, but finite) healing rate of the new state.
    fn kick(&mut self) -> Result<Stop, SimError> {
        let hk = 1e-7 * self.model.t_char;
        match super::esdirk::backward_euler(&self.model, &self.drive, &self.y, hk) {
            Ok(o) => {
                self.stats.rhs_evals += o.evals;
                self.segment = Some(Segment {
                    y0: self.y,
                    y1: o.y,
                    drive: self.drive,
                });
                self.y = o.y;
                Ok(Stop::Kick)
            }
            Err(StepFail::NoRoot) => {
                let y = self.y;
                Ok(self.lose_contact(&y))
            }
            Err(
                StepFail::NonFinite | StepFail::Explicit(_) | StepFail::Singular | StepFail::Stiff,
            ) => Err(SimError::NonFinite {
                t: self.y.t,
                state: self.err_state(),
            }),
        }
    }

    /// The contact is lost at `y`: the event carries `y`; the state goes out of contact.
    fn lose_contact(&mut self, y: &State) -> Stop {
        self.y = *y;
        self.y.contact = false;
        self.y.a = 0.0;
        self.y.adot = 0.0;
        self.collapse_at = None;
        self.refresh();
        Stop::Event(EventKind::ContactLoss, Box::new(*y))
    }

    /// One pass of the stepping loop: `None` when an attempt was rejected (try again).
    fn attempt(&mut self) -> Result<Option<Stop>, SimError> {
        self.budget()?;
        let y0 = self.y;
        if !y0.contact && self.watch_value(Watch::Impact, &y0) >= 0.0 {
            // Out of contact with no gap (e.g. the spring end driven into the substrate at a
            // stage start): contact forms now.
            return Ok(Some(self.form_contact()));
        }
        let t_bound = self.next_boundary();
        let t_lim = self.t_end.min(t_bound);
        let snap = 16.0 * f64::EPSILON * y0.t.abs().max(self.model.t_char);
        if t_lim - y0.t <= snap {
            return Ok(self.absorb_sliver(y0.t, t_bound, t_lim, snap));
        }
        let caps = self.stepper.capabilities();
        let offset = self.period_offset(y0.t);
        let prop = self.control.propose(
            y0.t,
            self.h_max(),
            caps,
            self.settings.interpolated_samples,
            offset,
        );
        let mut h = prop.h;
        if y0.contact {
            if let Some(tc) = self.collapse_at {
                if tc - y0.t <= self.settings.event_tol.max(self.h_min()) {
                    return Ok(Some(self.lose_contact(&y0)));
                }
                h = h.min(0.5 * (tc - y0.t));
            }
        }
        let mut hits = false;
        if h >= t_lim - y0.t || t_lim - y0.t - h < 1e-3 * h {
            h = t_lim - y0.t;
            hits = true;
        }
        match self.try_step(&y0, h) {
            Ok(true) => {}
            Ok(false) => return self.no_root(&y0, h),
            Err(e) => return self.failed(&y0, h, e),
        }
        if self.stepper.rescued_last() {
            self.control.not_remembered();
        }
        // The attempt is read where the stepper wrote it (the state with its quadratures is
        // 192 bytes).
        let StepOut {
            err,
            err_exp,
            kink,
            kink_ahead,
            ..
        } = self.out;
        if self.control.redo_at_turning_point(kink, h, self.h_min()) {
            self.stats.rejected += 1;
            return Ok(None);
        }
        if err > 1.0 {
            return self.reject_step(&y0, err, err_exp, h);
        }
        self.control
            .accept(err, err_exp, h, hits || prop.shortened, kink_ahead);
        if hits {
            self.out.y.t = t_lim;
        }
        self.stats.steps += 1;
        if let Some(stop) = self.event_in_step(&y0, h) {
            return Ok(Some(stop));
        }
        let y1 = &self.out.y;
        if !(y1.x.is_finite() && y1.v.is_finite() && y1.a.is_finite() && y1.a >= 0.0) {
            return Err(SimError::NonFinite {
                t: y0.t,
                state: self.err_state(),
            });
        }
        let heals = y1.adot >= 0.0;
        self.y = self.out.y;
        self.segment = Some(Segment {
            y0,
            y1: self.out.y,
            drive: self.drive,
        });
        if heals {
            // The contact heals: a collapse predicted while it shrank did not happen. (A DP8
            // stage leaving the domain across a turning point of the contact line looks like a
            // collapse; kept, the prediction halved every later step until the step size
            // underflowed: the failures at X_b = 100 µm of the 200 and 300 Hz protocols.)
            self.collapse_at = None;
        }
        // A period boundary a rounding sliver after the stage end (a stage of whole periods)
        // still closes its cycle.
        let period = if hits && t_bound - t_lim <= snap {
            self.at_boundary().map(Box::new)
        } else {
            None
        };
        Ok(Some(Stop::Step {
            period,
            reached: hits && self.t_end <= t_lim,
        }))
    }

    /// Boundaries are hit exactly; a rounding sliver between two of them (a stage end and a
    /// period boundary computed differently, e.g. a stage of exactly one base period) is absorbed
    /// here: from `t0`, within `snap` of the limit `t_lim`, the state moves to it, and a period
    /// boundary `t_bound` within the sliver is recorded.
    fn absorb_sliver(&mut self, t0: f64, t_bound: f64, t_lim: f64, snap: f64) -> Option<Stop> {
        if t_bound - t0 <= snap {
            self.y.t = self.y.t.max(t_bound);
            return self.at_boundary().map(|r| Stop::Period(Box::new(r)));
        }
        self.y.t = self.y.t.max(t_lim);
        Some(Stop::Reached)
    }

    /// The step y0 → y0 + `h` failed its error test (`err` > 1, the controller's exponent
    /// `err_exp`): shrink the step, or lose the contact or fall back when it would become too
    /// small.
    fn reject_step(
        &mut self,
        y0: &State,
        err: f64,
        err_exp: f64,
        h: f64,
    ) -> Result<Option<Stop>, SimError> {
        self.stats.rejected += 1;
        let h_new = self.control.reject(err, err_exp, h);
        if y0.contact && y0.adot < 0.0 && h_new <= self.settings.event_tol.max(self.h_min()) {
            // The radius runs into a turning point or a → 0 with unbounded speed faster
            // than the event tolerance resolves: the contact is lost here.
            return Ok(Some(self.lose_contact(y0)));
        }
        if h_new <= self.h_min() {
            if self.heal_to_floor(y0) {
                return Ok(None);
            }
            return self.fall_back(y0.t, h_new);
        }
        Ok(None)
    }

    /// A contact whose G is below its law's healing floor (a saturated law's w at the
    /// saturation speed, a table's smallest w; [`AdhesionLaw::healing_floor`]) heals without
    /// bound: the law has no finite speed there, and the steps collapse on the jump it implies
    /// (measured: a table held flat beyond its last row, the implicit method's error 3.1 at
    /// every step length down to 1e-14 s; tests/scenarios/fuzz-found). The edge moves as fast
    /// as it must, so the radius jumps to where G is back above the floor: a root of
    /// G(a, δ) = floor (1 + 1e-9) at the current δ, nearest to the current radius. True when the
    /// state moved (the attempt is then retried from it); a state already on or above the floor
    /// is left alone, so a collapse there still ends the run with its error, never in a loop.
    fn heal_to_floor(&mut self, y0: &State) -> bool {
        let floor = self.model.law.healing_floor();
        if !y0.contact || floor <= 0.0 {
            return false;
        }
        let kin = self.kin(y0.t);
        let delta = y0.x + kin.xb;
        let target = floor * (1.0 + 1e-9);
        if self.model.signed_g(y0.a, delta) >= floor {
            return false;
        }
        let f = |a: f64| self.model.signed_g(a, delta) - target;
        // The nearest sign change in either direction, widening geometrically.
        let bracket = (0..64).find_map(|k| {
            let d = 1e-12 * 2f64.powi(k);
            [y0.a * (1.0 + d), y0.a * (1.0 - d)]
                .into_iter()
                .find(|&a| a > 0.0 && f(a) > 0.0)
        });
        let Some(good) = bracket else {
            return false;
        };
        // The root's side where G is on the floor or above.
        let good = if good > y0.a {
            crate::numerics::bisect(y0.a, good, 0.0, |a| f(a) <= 0.0).1
        } else {
            crate::numerics::bisect(good, y0.a, 0.0, |a| f(a) > 0.0).0
        };
        self.y.a = good;
        self.refresh();
        true
    }

    /// The earliest event within the accepted step y0 → y1 (`self.out`), located; the state
    /// moves to it.
    fn event_in_step(&mut self, y0: &State, h: f64) -> Option<Stop> {
        let watches: [Option<Watch>; 2] = if y0.contact {
            [Some(Watch::Loss), self.preload.map(Watch::Preload)]
        } else {
            [Some(Watch::Impact), None]
        };
        // Every crossing is judged on the step's end before locating one (its trial steps
        // overwrite `self.out`).
        let crossed = watches.map(|w| {
            w.filter(|&w| w.crossed(self.watch_value(w, y0), self.watch_value(w, &self.out.y)))
        });
        if crossed.iter().all(Option::is_none) {
            return None;
        }
        let y1 = self.out.y;
        let mut first: Option<(Watch, State)> = None;
        for w in crossed.into_iter().flatten() {
            let ye = self.locate(w, y0, Some(y1), h);
            if first.as_ref().is_none_or(|(_, f)| ye.t < f.t) {
                first = Some((w, ye));
            }
        }
        let (w, ye) = first?;
        self.segment = Some(Segment {
            y0: *y0,
            y1: ye,
            drive: self.drive,
        });
        self.y = ye;
        let stop = match w {
            Watch::Loss => self.lose_contact(&ye),
            Watch::Impact => self.form_contact(),
            Watch::Preload(_) => Stop::Event(EventKind::PreloadReached, Box::new(ye)),
        };
        Some(stop)
    }

    /// A stage solve found no root with a > 0 for the attempt y0 + h.
    fn no_root(&mut self, y0: &State, h: f64) -> Result<Option<Stop>, SimError> {
        self.stats.rejected += 1;
        if y0.contact && y0.adot < 0.0 {
            // A shrinking contact with no stage root: it collapses before t + h (a → 0, or the
            // end of the equilibrium branch: the displacement-controlled jump-off). The
            // prediction is dropped when an accepted step shows the contact healing.
            let tc = y0.t + h;
            self.collapse_at = Some(self.collapse_at.map_or(tc, |c| c.min(tc)));
            self.control.shrink(h, 0.5);
            return Ok(None);
        }
        // Healing (e.g. right after a seeded impact, ȧ huge): the step is too long for the stage
        // rates; shorten it.
        let h_new = self.control.shrink(h, 0.25);
        if h_new <= self.h_min() {
            return self.fall_back(y0.t, h_new);
        }
        Ok(None)
    }

    /// An attempt failed otherwise: an explicit method's limits, the healing singularity, a
    /// non-finite stage.
    fn failed(&mut self, y0: &State, h: f64, e: StepFail) -> Result<Option<Stop>, SimError> {
        match e {
            StepFail::Explicit(reason) => {
                // Only an explicitly requested `ode_solvers` method gets here (`auto` runs DP8
                // or the implicit method).
                Err(SimError::Explicit {
                    method: self.stepper.name().into(),
                    t: y0.t,
                    reason: reason.into(),
                    state: self.err_state(),
                })
            }
            StepFail::Singular | StepFail::Stiff => {
                // A DP8 trial stage met G ≤ 0 (or, unrescued, deep healing): the step is too
                // long for the healing rate.
                self.stats.rejected += 1;
                if self.control.shrink(h, 0.25) <= self.h_min() {
                    return Err(SimError::Explicit {
                        method: self.stepper.name().into(),
                        t: y0.t,
                        reason: "the contact edge is compressive or G <= 0 (infinite healing \
                                 speed) at every step size"
                            .into(),
                        state: self.err_state(),
                    });
                }
                Ok(None)
            }
            StepFail::NonFinite | StepFail::NoRoot => {
                self.stats.rejected += 1;
                if h <= self.h_min() {
                    return Err(SimError::NonFinite {
                        t: y0.t,
                        state: self.err_state(),
                    });
                }
                self.control.shrink(h, 0.25);
                Ok(None)
            }
        }
    }
}
