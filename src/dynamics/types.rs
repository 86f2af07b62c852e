//! What a time-domain run produces, and how observers (writers, progress bars, steady-state
//! detectors) watch it. These types are the contract between the driver and the output writers.

use serde::Serialize;

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
    /// most tensile contact force.
    pub force: f64,
    /// force / (−3/2 π R w0).
    pub amplification: f64,
    /// Time at which that force was reached (s; the end of the averaging cycle).
    pub time: f64,
}

/// Everything a run returns (the time series goes to observers, not here).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunResult {
    /// Pull-off summary.
    pub pull_off: PullOffSummary,
    /// True when final detachment happened.
    pub detached: bool,
    /// Event log.
    pub events: Vec<Event>,
    /// Solver statistics.
    pub stats: Stats,
    /// The method actually used, and why when `auto` chose it.
    pub method: String,
    /// Final state.
    pub final_state: Sample,
}

/// Watches a run. The driver calls `sample` at the output cadence and `event` for each located
/// event; an observer may ask the run to stop by returning `false` from `sample`.
pub trait Observer {
    /// A time-series sample. Return `false` to stop the run.
    fn sample(&mut self, s: &Sample) -> bool {
        let _ = s;
        true
    }
    /// A located event.
    fn event(&mut self, e: &Event) {
        let _ = e;
    }
}

/// An observer that ignores everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NoObserver;
impl Observer for NoObserver {}

/// An observer that keeps every sample and event in memory.
#[derive(Debug, Default, Clone)]
pub struct Recorder {
    /// Samples, in time order.
    pub samples: Vec<Sample>,
    /// Events, in time order.
    pub events: Vec<Event>,
}

impl Observer for Recorder {
    fn sample(&mut self, s: &Sample) -> bool {
        self.samples.push(*s);
        true
    }
    fn event(&mut self, e: &Event) {
        self.events.push(*e);
    }
}
