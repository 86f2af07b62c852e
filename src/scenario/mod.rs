//! Scenario files: the whole description of an experiment (material, adhesion law, sphere,
//! spring, damping, base motion, initial state, a protocol of stages, solver and output settings).
//!
//! This module holds the *validated* model that the simulator consumes. Parsing of the TOML file
//! (with unknown keys rejected and every out-of-range value reported with file, key, value and the
//! allowed range) lives in [`parse`].
//!
//! Coordinates (MODEL.md): x_s sphere position (down +), x_b base displacement (up +), x_k the far
//! end of the holding spring (down +), δ = x_s + x_b the indentation (> 0 compresses).

pub mod parse;

use crate::adhesion::Law;
use crate::material::Material;

/// The sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Mass m (kg). Zero selects the quasi-static force balance (no inertia).
    pub mass: f64,
    /// Gravitational acceleration g (m/s²), acting downward (towards the substrate).
    pub gravity: f64,
}

/// How the sphere is held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Holder {
    /// No spring: the sphere rests on its own weight (k = 0, x_k unused).
    None,
    /// A linear spring of stiffness k (N/m) whose far end x_k(t) the protocol moves.
    Spring {
        /// Stiffness k (N/m).
        stiffness: f64,
    },
    /// A rigid link: the sphere follows x_k(t) exactly; only a(t) is integrated (the paper's
    /// quasi-static test). δ(t) = x_k(t) + x_b(t) is prescribed.
    Rigid,
}

/// Where viscous damping acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DampingOn {
    /// On the sphere's absolute velocity, eq. (30): c ẋ_s.
    Sphere,
    /// On the indentation rate, eq. (3) (Shui et al.): c δ̇, only while in contact.
    Contact,
}

/// Viscous damping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Damping {
    /// Coefficient c (N s/m).
    pub c: f64,
    /// Where it acts.
    pub on: DampingOn,
}

/// Harmonic base motion x_b = X_b sin(2π f (t − t_on)) while the shaker is on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseMotion {
    /// Amplitude X_b (m).
    pub amplitude: f64,
    /// Frequency f (Hz).
    pub frequency: f64,
}

/// How contact forms when the gap closes (impact).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactFormation {
    /// Instantly at the JKR jump-in radius a³ = 8πw0R²/(3K).
    JumpIn,
    /// From a small seed radius (m), then rate-limited by the healing law.
    Seed(f64),
}

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
    /// Event location tolerance in time (s).
    pub event_tol: f64,
}

impl Default for Solver {
    fn default() -> Self {
        Self {
            method: Method::Auto,
            rtol: 1e-8,
            atol: 1e-10,
            max_steps: 50_000_000,
            max_wall_s: 600.0,
            event_tol: 1e-12,
        }
    }
}

/// Output settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output {
    /// Time-series samples per second of simulated time; 0 = every accepted step.
    pub sample_rate: f64,
    /// Also write CSV.
    pub csv: bool,
}

impl Default for Output {
    fn default() -> Self {
        Self {
            sample_rate: 0.0,
            csv: false,
        }
    }
}

/// A validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Contact pair.
    pub material: Material,
    /// Adhesion law (absent section: constant w0).
    pub law: Law,
    /// Sphere.
    pub sphere: Sphere,
    /// Spring, rigid link or none.
    pub holder: Holder,
    /// Damping (absent: none).
    pub damping: Option<Damping>,
    /// Base motion (absent: no vibration).
    pub base: Option<BaseMotion>,
    /// How contact forms at impact.
    pub formation: ContactFormation,
    /// Starting state.
    pub initial: Initial,
    /// Protocol.
    pub stages: Vec<Stage>,
    /// Solver settings.
    pub solver: Solver,
    /// Output settings.
    pub output: Output,
    /// The scenario file's text, stored with the results.
    pub source_text: String,
    /// Where it came from (path, or `<string>`).
    pub source_name: String,
}
