//! The stage protocol: where a run starts, and what the spring end and the shaker do, stage by
//! stage (the paper's Sec. 3: approach, dwell, shaker on, dwell, unload to pull-off), above the
//! [`Simulator`]: stage ends, the pull-off proof, the most tensile force and cycle records, and
//! the samples handed to the observer.

use super::envelope::{Envelope, EnvelopeSettings};
use super::methods::{self, EnvelopeMode, Method, Solver};
use super::model::{self, Drive, Mechanics, Model, NQ};
use super::simulator::{Segment, Settings, Simulator, Stop};
use super::state::{hermite, Knot, State};
use super::types::*;
use crate::jkr;
use crate::numerics;
use crate::rig::{Rig, Support};
use std::f64::consts::PI;

/// The state the run starts from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Initial {
    /// Static JKR equilibrium (w0) under this compressive contact force (N); the spring end is
    /// placed so that spring and weight balance it.
    Preload(f64),
    /// Out of contact, at rest, with this gap (m, > 0) between sphere and substrate; the spring
    /// end is placed so the sphere is in equilibrium in free space.
    Gap(f64),
    /// An explicit state, e.g. the end of an earlier run (shooting, frequency sweeps): the sphere
    /// at `x_s` (m) moving at `v_s` (m/s), contact radius `a` (m; 0 = out of contact) growing at
    /// `a_dot` (m/s; the rate consistent with the state, as a [`crate::dynamics::Sample`]
    /// reports it), spring end at `x_k` (m). The base is at rest at phase 0 (x_b = 0).
    State {
        /// Sphere position (m, down +).
        x_s: f64,
        /// Sphere velocity (m/s, down +).
        v_s: f64,
        /// Contact radius (m).
        a: f64,
        /// Contact-radius rate (m/s).
        a_dot: f64,
        /// Spring-end position (m, down +).
        x_k: f64,
    },
}

/// When a stage ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Until {
    /// After this duration (s).
    Duration(f64),
    /// When the compressive contact force first reaches this value (N).
    Preload(f64),
    /// At final detachment: contact lost and the sphere moving away for good.
    PullOff,
}

/// What a stage does to the spring end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageKind {
    /// Move the spring end towards the substrate (x_k increasing).
    Approach,
    /// Keep the spring end still.
    Hold,
    /// Move the spring end away from the substrate (x_k decreasing).
    Unload,
}

/// One stage of the protocol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    /// What the spring end does.
    pub kind: StageKind,
    /// Spring-end speed (m/s, ≥ 0; 0 for a hold).
    pub speed: f64,
    /// End condition.
    pub until: Until,
    /// Shaker state during the stage; `None` keeps the previous stage's state (initially off).
    pub vibration: Option<bool>,
    /// Safety limit (s): a stage whose `until` is not a duration errors out after this long.
    pub max_duration: f64,
}

impl Stage {
    /// The longest this stage can last (s): its duration, or its `max_duration`.
    pub fn longest_duration(&self) -> f64 {
        match self.until {
            Until::Duration(d) => d,
            _ => self.max_duration,
        }
    }
}

/// The scales a protocol adds to a rig's model: an initial gap and the fastest spring-end speed.
pub fn run_scales(initial: &Initial, stages: &[Stage]) -> model::RunScales {
    model::RunScales {
        gap: match initial {
            Initial::Gap(g) => Some(*g),
            _ => None,
        },
        max_speed: stages
            .iter()
            .map(|st| st.speed)
            .filter(|v| *v > 0.0)
            .fold(0.0_f64, f64::max),
    }
}

/// Everything a protocol run needs: the rig, where it starts, the stages, the solver and the
/// output cadence (borrowed from a scenario, or built by hand).
#[derive(Debug, Clone, Copy)]
pub struct Plan<'a> {
    /// The physical rig.
    pub rig: &'a Rig,
    /// Where the run starts.
    pub initial: Initial,
    /// The stages, in order.
    pub stages: &'a [Stage],
    /// Method, tolerances and budgets.
    pub solver: Solver,
    /// Time-series samples per second of simulated time (0: every accepted step).
    pub sample_rate: f64,
    /// Windows `[t0, t1]` of time (s; sorted, disjoint) that must be recorded densely:
    /// envelope following never jumps into or across them (`[output] dense`).
    pub dense: &'a [[f64; 2]],
}

/// Run a protocol from its initial state, feeding `obs` with samples, events and cycle records.
/// See the module documentation of [`crate::dynamics`]. A run that ends early (a budget, a
/// failure) returns its error and drops what it computed; [`run_partial`] keeps it.
pub fn run(plan: &Plan, obs: &mut dyn Observer) -> Result<RunResult, SimError> {
    run_partial(plan, obs)?.into_result()
}

/// [`run`], keeping what a run that ends early computed: once the run has started, a budget
/// (`max_steps`, `max_wall_s`, `max_events`), a cancellation or a failure of the integration
/// ends it with its [`Outcome`]: the result up to there (final state, events, cycles, pull-off
/// so far) and the error. An error here means the run could not start (the scenario cannot be
/// simulated: a [`SimError::Setup`] or an explicit method on a rate-independent law).
pub fn run_partial(plan: &Plan, obs: &mut dyn Observer) -> Result<Outcome, SimError> {
    let model = model::resolve(plan.rig, run_scales(&plan.initial, plan.stages))
        .map_err(SimError::Setup)?;
    let (y, drive) = initial_state(plan.rig, &plan.initial, &model)?;
    let stepper = methods::build(plan.solver.method, plan.rig);
    if !stepper.capabilities().algebraic_radius && model.rate_independent {
        return Err(SimError::Explicit {
            method: stepper.name().into(),
            t: 0.0,
            reason: "the adhesion law is rate-independent: the contact radius is algebraic \
                     (G = w0) and has no explicit rate"
                .into(),
            state: Box::new(make_sample(&model, &drive, &y, 0)),
        });
    }
    let sample_dt = if plan.sample_rate > 0.0 {
        1.0 / plan.sample_rate
    } else {
        0.0
    };
    let wants_samples = obs.wants_samples();
    let settings = Settings {
        interpolated_samples: wants_samples && sample_dt > 0.0,
        ..Settings::from(&plan.solver)
    };
    let formation = plan.rig.formation;
    let sim = Simulator::new(model, stepper, formation, settings, y, drive);
    let mut run = Protocol {
        sim,
        obs,
        stage: 0,
        events: Vec::new(),
        event_counts: EventCounts::default(),
        last_event: None,
        cycle_count: 0,
        max_radius: 0.0,
        last_cycle: None,
        sample_dt,
        next_sample: 0.0,
        wants_samples,
        last_sample_t: None,
        pending_gap: None,
        dense: plan.dense,
        stopped: false,
        min_force: None,
        min_cycle: None,
        roughness: ApproachRoughness::new(),
        shaker_at_detach: None,
        detachment_time: None,
        pending_loss: None,
        detached: false,
        in_pulloff: false,
        envelope: (plan.solver.envelope == EnvelopeMode::Auto).then(|| {
            Envelope::new(EnvelopeSettings {
                tol: plan.solver.envelope_tol,
                ..EnvelopeSettings::default()
            })
        }),
    };
    let y0 = *run.sim.state();
    run.output(&Segment {
        y0,
        y1: y0,
        drive: *run.sim.drive(),
    });
    if run.sample_dt > 0.0 {
        run.next_sample = run.sample_dt;
    }
    let mut error = None;
    for (i, st) in plan.stages.iter().enumerate() {
        if run.stopped {
            break;
        }
        if let Err(e) = run.run_stage(i, st) {
            error = Some(e);
            break;
        }
    }
    let observer_reason = if run.stopped {
        run.obs.stop_reason()
    } else {
        None
    };
    Ok(Outcome {
        result: run.finish(plan.solver.method),
        error,
        observer_reason,
    })
}

/// The initial state and drive (see the module documentation of [`crate::dynamics`]).
pub fn initial_state(rig: &Rig, initial: &Initial, m: &Model) -> Result<(State, Drive), SimError> {
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
    match *initial {
        Initial::Preload(p) => {
            let st = rig
                .static_state(Support::StaticLoad(p))
                .map_err(|e| SimError::Setup(format!("initial preload {p} N: {e}")))?;
            y.x = st.delta;
            y.a = st.a;
            y.contact = true;
            xk = st.x_k;
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
                Mechanics::Dynamic if !m.free_holder => y.x - m.mass * m.gravity / m.spring,
                Mechanics::Dynamic => 0.0,
                _ => y.x,
            };
        }
    }
    Ok((y, Drive::held(xk, false)))
}

/// The samples of `seg` for (y0.t, y1.t]: on the grid `next_sample` + k `sample_dt` (advanced
/// past them), or the step's end alone without a grid (`sample_dt` = 0); and the time of the
/// last of them.
fn step_samples(
    seg: &Segment,
    stage: usize,
    next_sample: &mut f64,
    sample_dt: f64,
) -> (StepSamples, f64) {
    let mut step = StepSamples {
        k0: Knot::from(&seg.y0),
        k1: Knot::from(&seg.y1),
        drive: seg.drive,
        stage,
        t_first: *next_sample,
        dt: sample_dt.max(0.0),
        n: 0,
    };
    // The last sample's time, accumulated as `StepSamples::each` accumulates it.
    let mut last = seg.y1.t;
    if step.dt == 0.0 {
        step.n = 1;
    } else {
        while *next_sample <= seg.y1.t {
            step.n += 1;
            last = *next_sample;
            *next_sample += sample_dt;
        }
    }
    (step, last)
}

/// A protocol run in progress.
struct Protocol<'a> {
    sim: Simulator,
    obs: &'a mut dyn Observer,
    stage: usize,
    /// The first [`EVENT_LOG_LIMIT`] events.
    events: Vec<Event>,
    event_counts: EventCounts,
    /// The last event (the pending contact loss refers to it).
    last_event: Option<Event>,
    cycle_count: u64,
    /// The largest contact radius at the end of an accepted step (m).
    max_radius: f64,
    last_cycle: Option<CycleRecord>,
    sample_dt: f64,
    next_sample: f64,
    /// The observer uses samples (`Observer::wants_samples`).
    wants_samples: bool,
    /// Time of the last sample handed to the observer.
    last_sample_t: Option<f64>,
    /// A gap whose first sample after is still to come: its start (the last sample's time)
    /// and the periods skipped so far.
    pending_gap: Option<(f64, u64)>,
    /// `[output] dense`: windows envelope following keeps out of.
    dense: &'a [[f64; 2]],
    /// The observer asked to stop.
    stopped: bool,
    /// Most tensile force candidate (force, time).
    min_force: Option<(f64, f64)>,
    /// Most tensile cycle-mean force (force, cycle end time).
    min_cycle: Option<(f64, f64)>,
    /// How rough the cycle means were before `min_cycle`.
    roughness: ApproachRoughness,
    /// Shaker state when detachment was declared.
    shaker_at_detach: Option<bool>,
    /// Time of the final detachment (the pull-off event).
    detachment_time: Option<f64>,
    /// Contact loss that may turn out to be the final detachment.
    pending_loss: Option<Event>,
    detached: bool,
    /// The current stage ends at pull-off.
    in_pulloff: bool,
    /// Envelope following, when the solver allows it.
    envelope: Option<Envelope>,
}

impl Protocol<'_> {
    fn event(&mut self, kind: EventKind, y: &State) {
        let e = Event {
            kind,
            time: y.t,
            stage: self.stage,
            state: self.sim.sample_of(y, self.stage),
        };
        self.log(e);
    }

    /// Hand an event to the observer and keep it (the first [`EVENT_LOG_LIMIT`] of them).
    fn log(&mut self, e: Event) {
        self.obs.event(&e);
        self.event_counts.add(e.kind);
        self.last_event = Some(e);
        if self.events.len() < EVENT_LOG_LIMIT {
            self.events.push(e);
        }
    }

    /// Emit time-series samples for (y0.t, y1.t] of a segment.
    fn output(&mut self, seg: &Segment) {
        if self.stopped || !self.wants_samples {
            return;
        }
        let (step, last) = step_samples(seg, self.stage, &mut self.next_sample, self.sample_dt);
        self.emit(&step, last);
    }

    /// [`Protocol::output`] of the step just taken, read in place (two states, 470 bytes).
    fn output_step(&mut self) {
        if self.stopped || !self.wants_samples {
            return;
        }
        let Some(seg) = self.sim.segment() else {
            return;
        };
        let (step, last) = step_samples(seg, self.stage, &mut self.next_sample, self.sample_dt);
        self.emit(&step, last);
    }

    /// Hand the samples of a step (the last at `last`) to the observer, after the gap before
    /// them if there is one.
    fn emit(&mut self, step: &StepSamples, last: f64) {
        if step.n == 0 {
            return;
        }
        if let Some((t_start, periods)) = self.pending_gap.take() {
            let t_end = if step.dt > 0.0 {
                step.t_first
            } else {
                step.k1.t
            };
            self.obs.gap(&Gap {
                t_start,
                t_end,
                periods,
            });
        }
        self.last_sample_t = Some(last);
        if !self.obs.step_samples(self.sim.model(), step) {
            self.stopped = true;
        }
    }

    /// What the protocol keeps of the step just taken: the largest radius, its samples and the
    /// most tensile force.
    fn after_step(&mut self) {
        if let Some(seg) = self.sim.segment() {
            self.max_radius = self.max_radius.max(seg.y1.a);
        }
        self.output_step();
        self.track_force();
    }

    fn record_cycle(&mut self, rec: CycleRecord) {
        let new_min = !self.detached && self.min_cycle.is_none_or(|(f, _)| rec.force_mean < f);
        if new_min {
            self.min_cycle = Some((rec.force_mean, rec.t_end));
        }
        if !self.detached {
            self.roughness.record(&rec, new_min);
        }
        self.obs.cycle(&rec);
        self.cycle_count += 1;
        self.last_cycle = Some(rec);
    }

    /// Track the most tensile instantaneous force while the shaker is off, refining an interior
    /// minimum over the step's interpolant, then (if it may beat the record) by exact re-stepping.
    fn track_force(&mut self) {
        let seg = match self.sim.segment() {
            Some(seg) if !seg.drive.shaker && seg.y0.contact && seg.y1.contact => *seg,
            _ => return,
        };
        let (y0, y1) = (&seg.y0, &seg.y1);
        let sim = &mut self.sim;
        let mut cand = vec![(sim.force_of(y1), y1.t)];
        if self.min_force.is_none() {
            cand.push((sim.force_of(y0), y0.t));
        }
        if sim.force_rate(y0) < 0.0 && sim.force_rate(y1) > 0.0 {
            // A cheap search on the step's interpolant first; only a minimum that may beat the
            // record is refined exactly (each trial a fresh step from y0).
            let (fh, th) = minimize(y0.t, y1.t, 1e-6 * (y1.t - y0.t), |t| {
                sim.force_of(&hermite(y0, y1, t))
            });
            let scale = fh.abs().max(1e-300);
            if self.min_force.is_none_or(|(m, _)| fh < m + 1e-3 * scale) {
                let tol = sim.settings().event_tol.max(1e-15 * y1.t.abs());
                cand.push(minimize(y0.t, y1.t, tol, |t| {
                    match sim.trial(y0, t - y0.t) {
                        Some(y) => sim.force_of(&y),
                        None => sim.force_of(&hermite(y0, y1, t)),
                    }
                }));
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

    /// Can the sphere, now out of contact, never touch the substrate again (in this stage)?
    fn no_return(&self, kind: StageKind, loss_t: f64) -> bool {
        let y = self.sim.state();
        let m = self.sim.model();
        let drive = self.sim.drive();
        let xb_max = if drive.shaker { m.xb_amp } else { 0.0 };
        let moving_away = kind != StageKind::Approach;
        let bound = match m.mech {
            Mechanics::Rigid | Mechanics::QuasiStatic => moving_away.then(|| drive.x_k(y.t)),
            Mechanics::Dynamic => {
                if m.free_holder {
                    (m.gravity <= 0.0 && y.v < 0.0).then_some(f64::NEG_INFINITY)
                } else if moving_away {
                    let cv = if m.contact_damping { 0.0 } else { m.damping };
                    let xeq =
                        drive.x_k(y.t) + (m.mass * m.gravity - cv * drive.xk_speed) / m.spring;
                    let xi = y.x - xeq;
                    let vi = y.v - drive.xk_speed;
                    Some(xeq + (xi * xi + m.mass * vi * vi / m.spring).sqrt())
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
        let wn = if m.mech == Mechanics::Dynamic && m.spring > 0.0 {
            (m.spring / m.mass).sqrt()
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

    /// Start stage `idx`: the spring end's speed, the shaker, the stage-start event; `true` when
    /// the stage is already over (an approach whose preload is already reached).
    fn start_stage(&mut self, idx: usize, st: &Stage) -> bool {
        if let Some(e) = self.envelope.as_mut() {
            e.new_stage(
                matches!(st.until, Until::PullOff),
                st.kind == StageKind::Hold,
            );
        }
        self.stage = idx;
        self.sim.set_stage(idx);
        let speed = match st.kind {
            StageKind::Approach => st.speed,
            StageKind::Hold => 0.0,
            StageKind::Unload => -st.speed,
        };
        self.sim.set_spring_end_speed(speed);
        if let Some(on) = st.vibration {
            self.sim.set_shaker(on);
        }
        self.sim.refresh();
        let y = *self.sim.state();
        self.event(EventKind::StageStart, &y);
        let t_end = match st.until {
            Until::Duration(d) => y.t + d,
            _ => y.t + st.max_duration,
        };
        let preload = match st.until {
            Until::Preload(p) => Some(p),
            _ => None,
        };
        self.sim.advance_to(t_end, preload);
        self.in_pulloff = matches!(st.until, Until::PullOff);
        if self.in_pulloff && !self.detached {
            // The pull-off summary describes the pull-off stage.
            self.min_force = None;
            self.min_cycle = None;
            self.roughness.reset();
        }
        if let (Some(p), true) = (preload, y.contact) {
            if self.sim.force_of(&y) >= p {
                self.event(EventKind::PreloadReached, &y);
                return true;
            }
        }
        false
    }

    fn run_stage(&mut self, idx: usize, st: &Stage) -> Result<(), SimError> {
        if self.start_stage(idx, st) {
            return Ok(());
        }
        let is_duration = matches!(st.until, Until::Duration(_));
        loop {
            if self.stopped {
                return Ok(());
            }
            match self.sim.step()? {
                Stop::Step { period, reached } => {
                    self.after_step();
                    if let Some(rec) = period {
                        self.record_cycle(*rec);
                        if !reached {
                            self.follow_envelope(st, &rec)?;
                        }
                    }
                    if self.in_pulloff && self.detach(st.kind) {
                        return Ok(());
                    }
                    if reached {
                        return self.stage_end(idx, st, is_duration);
                    }
                }
                Stop::Kick => self.output_step(),
                Stop::Event(kind, ye) => {
                    if let Some(e) = self.envelope.as_mut() {
                        e.forget();
                    }
                    self.after_step();
                    self.event(kind, &ye);
                    match kind {
                        EventKind::ContactLoss => {
                            self.pending_loss = if self.in_pulloff {
                                self.last_event
                            } else {
                                None
                            };
                        }
                        EventKind::Impact => self.pending_loss = None,
                        EventKind::PreloadReached => return Ok(()),
                        _ => {}
                    }
                }
                Stop::Period(rec) => {
                    self.record_cycle(*rec);
                    self.follow_envelope(st, &rec)?;
                }
                Stop::Reached => return self.stage_end(idx, st, is_duration),
            }
        }
    }

    /// At an exact period boundary: let envelope following jump over periods where the shaker
    /// runs steadily (not in a stage that ends on a preload, which a jump could step over), and
    /// move the sample grid past the jump.
    fn follow_envelope(&mut self, st: &Stage, rec: &CycleRecord) -> Result<(), SimError> {
        let Some(env) = self.envelope.as_mut() else {
            return Ok(());
        };
        if matches!(st.until, Until::Preload(_)) || !self.sim.vibrating_steadily() {
            env.forget();
            return Ok(());
        }
        let t = self.sim.state().t;
        let periods_left = (self.sim.stop_time() - t) / self.sim.period();
        let room = if periods_left.is_finite() && periods_left > 3.0 {
            (periods_left - 2.0).floor() as u64
        } else {
            0
        };
        // A window starts one sample spacing early: the first sample after a jump that lands
        // just before it is still outside it.
        let room = room.min(dense_room(self.dense, t, self.sim.period(), self.sample_dt));
        let jumped = env.at_boundary(&mut self.sim, rec, room)?;
        if jumped == 0 {
            return Ok(());
        }
        let z = *self.sim.state();
        let skips_samples = self.sample_dt <= 0.0 || self.next_sample <= z.t;
        if let Some((_, periods)) = self.pending_gap.as_mut() {
            // No sample since the last jump: one gap holds both.
            *periods += jumped;
        } else if skips_samples && self.wants_samples {
            if let Some(t0) = self.last_sample_t {
                self.pending_gap = Some((t0, jumped));
            }
        }
        if self.sample_dt > 0.0 {
            // The time grid resumes after the jump.
            if self.next_sample <= z.t {
                self.next_sample = ((z.t / self.sample_dt).floor() + 1.0) * self.sample_dt;
            }
        } else {
            // Every step is a sample: so is the state the jump lands on.
            self.output(&Segment {
                y0: z,
                y1: z,
                drive: *self.sim.drive(),
            });
        }
        Ok(())
    }

    /// After an accepted step out of contact in a pull-off stage: declare the final detachment
    /// at the pending contact loss once a re-impact is proven impossible.
    fn detach(&mut self, kind: StageKind) -> bool {
        if self.sim.state().contact {
            return false;
        }
        let Some(loss) = self.pending_loss else {
            return false;
        };
        if !self.no_return(kind, loss.time) {
            return false;
        }
        let e = Event {
            kind: EventKind::PullOff,
            ..loss
        };
        self.log(e);
        self.detached = true;
        self.detachment_time = Some(e.time);
        self.shaker_at_detach = Some(self.sim.drive().shaker);
        self.pending_loss = None;
        true
    }

    /// The stage's time is up: its duration elapsed, or its `max_duration` without its end
    /// condition (an error).
    fn stage_end(&mut self, idx: usize, st: &Stage, is_duration: bool) -> Result<(), SimError> {
        let y = *self.sim.state();
        if is_duration {
            self.event(EventKind::DurationElapsed, &y);
            return Ok(());
        }
        Err(SimError::StageTimeout {
            stage: idx,
            until: match st.until {
                Until::Duration(_) => "duration".into(),
                Until::Preload(p) => format!("until preload {p} N"),
                Until::PullOff => "until pull-off".into(),
            },
            max_duration: st.max_duration,
            t: y.t,
            state: Box::new(self.sim.sample_of(&y, self.stage)),
        })
    }

    fn finish(mut self, method: Method) -> RunResult {
        let stats = self.sim.finish_stats();
        let model = self.sim.model();
        let f0 = jkr::load_controlled_pull_off_force(&model.mat, model.w0);
        // The shaker state at detachment decides which minimum is the pull-off force: the most
        // tensile cycle mean while vibrating, the most tensile instantaneous force otherwise
        // (each taken over the pull-off stage, or the whole run without one). Without
        // detachment: the cycle means if there are any.
        let vibrating = self.shaker_at_detach.unwrap_or(self.min_cycle.is_some());
        let pick = if vibrating {
            self.min_cycle.or(self.min_force)
        } else {
            self.min_force.or(self.min_cycle)
        };
        let (force, time) = pick.unwrap_or((0.0, 0.0));
        // The roughness describes the approach to the most tensile cycle mean: only when that
        // is the pull-off force.
        let (approach_roughness, approach_zero_means) = match pick {
            Some(p) if vibrating && Some(p) == self.min_cycle => {
                (self.roughness.value(), self.roughness.zero_means())
            }
            _ => (f64::NAN, 0),
        };
        let y = *self.sim.state();
        let final_state = self.sim.sample_of(&y, self.stage);
        let stepper = self.sim.stepper();
        // A short name (README, "Methods"): what ran, `(auto)` when auto chose it, and how many
        // steps a rescue method took (DP8 handed to the implicit method).
        let r = stepper.rescues();
        let mut m = if method == Method::Auto {
            let ran = stepper.short_name();
            if r.total() > 0 {
                format!("{ran} (auto; {} steps {})", r.total(), r.by)
            } else {
                format!("{ran} (auto)")
            }
        } else {
            methods::method_name(method).to_string()
        };
        if let Some(e) = self.envelope.as_ref().map(|e| e.stats()) {
            if e.jumps > 0 {
                m.push_str(&format!("; envelope skipped {} periods", e.periods_skipped));
            }
        }
        if self.stopped {
            m.push_str("; stopped by the observer");
        }
        RunResult {
            pull_off: PullOffSummary::new(force, time, f0),
            detached: self.detached,
            events: self.events,
            event_counts: self.event_counts,
            stats,
            method: m,
            final_state,
            cycle_count: self.cycle_count,
            last_cycle: self.last_cycle,
            max_contact_radius: self.max_radius.max(final_state.a),
            envelope: self
                .envelope
                .as_ref()
                .map(|e| e.stats())
                .unwrap_or_default(),
            detachment_time: self.detachment_time.unwrap_or(f64::NAN),
            approach_roughness,
            approach_zero_means,
        }
    }
}

/// How many base periods of length `period` envelope following may jump from time `t` without
/// entering a window of `dense` (sorted, disjoint `[t0, t1]`, each widened by `lead` before
/// its start): none inside a window, the whole periods before the next window's start
/// otherwise (unbounded after the last).
fn dense_room(dense: &[[f64; 2]], t: f64, period: f64, lead: f64) -> u64 {
    for &[t0, t1] in dense {
        if t > t1 {
            continue;
        }
        let t0 = t0 - lead;
        if t >= t0 {
            return 0;
        }
        // A margin of 1e-9 periods keeps a landing point rounded up from entering the window.
        let n = ((t0 - t) / period - 1e-9).floor();
        return if n.is_finite() && n > 0.0 {
            n as u64
        } else {
            0
        };
    }
    u64::MAX
}

/// Minimise `f` over [lo, hi] to about `tol` in t with Brent's method: (min, argmin).
fn minimize(lo: f64, hi: f64, tol: f64, f: impl FnMut(f64) -> f64) -> (f64, f64) {
    // `brent_minimize` converges to ≈ 3 (rel_tol |t| + abs_tol).
    let (t, fmin) = numerics::brent_minimize(f, lo, hi, f64::EPSILON, tol / 3.0, 100);
    (fmin, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_room_stops_jumps_short_of_every_window() {
        let w = [[1.0, 2.0], [3.0, 4.0]];
        let p = 0.1;
        // Before the first window: the whole periods that end at or before its start.
        assert_eq!(dense_room(&w, 0.0, p, 0.0), 9);
        assert_eq!(dense_room(&w, 0.45, p, 0.0), 5);
        // A lead of a sample spacing moves the start earlier.
        assert_eq!(dense_room(&w, 0.0, p, 0.25), 7);
        // Inside a window (its ends included): no jump.
        for t in [1.0, 1.5, 2.0, 3.2] {
            assert_eq!(dense_room(&w, t, p, 0.0), 0, "t = {t}");
        }
        // Between windows: up to the next; after the last: unbounded.
        assert_eq!(dense_room(&w, 2.05, p, 0.0), 9);
        assert_eq!(dense_room(&w, 4.5, p, 0.0), u64::MAX);
        assert_eq!(dense_room(&[], 4.5, p, 0.0), u64::MAX);
        // Closer than a period to the next window: no jump.
        assert_eq!(dense_room(&w, 0.95, p, 0.0), 0);
    }
}
