//! The stage protocol: where a run starts, and what the spring end and the shaker do, stage by
//! stage (the paper's Sec. 3: approach, dwell, shaker on, dwell, unload to pull-off).

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

/// The scales a protocol adds to a rig's model: an initial gap and the fastest spring-end speed.
pub fn run_scales(initial: &Initial, stages: &[Stage]) -> super::model::RunScales {
    super::model::RunScales {
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
