//! A family of periodic-orbit problems: a model (a [`Scene`]) with one or two scalar parameters
//! whose values the continuation chooses.
//!
//! Continuation knows no file format: the scene hands it the steady-state problem at given
//! parameter values. The root crate's scene (`djkr::scenario::family`) is a scenario file with
//! its fixed overrides, parsed once; each value is one more override, validated as the file
//! with it written in would be, and its steady-state problem taken as
//! [`Problem::from_plan`] takes it. There, the spring end x_k is where that plan holds it: the
//! static JKR equilibrium under `initial.preload`, at every value, for a scene that vibrates
//! from its first stage (the bundled resonance scene); for a scene whose vibration starts after
//! earlier stages (approach, dwell), where those stages leave it, run once at the first value
//! (START) and kept. Rerunning them for every value would tie the mean load to the approach's
//! dynamics, which jump: on `scenarios/paper-protocol-400hz.toml` the spring end left by the
//! approach jumps by 2.1 µm at damping.c = 3.1019 N s/m (the approach's preload crossing moves
//! to another oscillation), and no branch can cross that.
//!
//! Only constants of the periodic problem are parameters (the scene says which: the material,
//! the law's constants, the mechanics, the base motion and the mean load); the protocol's
//! stages, the solver and the output do not change a periodic orbit.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::dynamics::protocol::Initial;
use crate::steady::{OrbitState, Problem};
use crate::units::Dimension;

use super::ContinuationError;

/// A continuation parameter's key, SI unit (as table headers write it) and the dimension its
/// values are parsed with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParameterInfo {
    /// The dotted key (`base.frequency`).
    pub key: &'static str,
    /// SI unit, `1` when dimensionless (`Hz`).
    pub unit: &'static str,
    /// Dimension for parsing values with units (`--range 340Hz:0.6kHz`).
    pub dimension: Dimension,
    /// What it is, in a few words.
    pub what: &'static str,
}

/// A continuation parameter: which key, and its unit and meaning (the keys that may be one, and
/// how a value reaches the problem, are the [`Scene`]'s).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Parameter {
    /// Its unit, dimension and description.
    pub info: ParameterInfo,
}

impl Parameter {
    /// The key as written (`base.frequency`).
    pub fn name(&self) -> &'static str {
        self.info.key
    }
}

/// The problem at one parameter point: the steady-state problem, where the spring end is held,
/// and where the scene's own start is (for the first orbit).
#[derive(Debug, Clone)]
pub struct Setup {
    /// The steady-state problem (rig, base motion, solver).
    pub problem: Problem,
    /// The spring end x_k (m).
    pub x_k: f64,
    /// The scene's start at this point: its initial state, or where its earlier stages end.
    pub start: Initial,
}

impl Setup {
    /// The base period T = 1/f (s).
    pub fn period(&self) -> f64 {
        1.0 / self.problem.frequency
    }

    /// A consistent state at phase 0 from (x_s, v_s, a) (ȧ from the law; see
    /// [`Problem::consistent`]).
    pub fn state(&self, y: [f64; 3]) -> Option<OrbitState> {
        self.problem.consistent(y[0], y[1], y[2], self.x_k)
    }
}

/// What the continuation needs from the model it continues: the periodic problem at given
/// parameter values. Implemented above the physics (the root crate builds it from a scenario
/// file and its `--set` overrides, `djkr::scenario::family`), so that continuation knows no file
/// format.
pub trait Scene: Send + Sync + std::fmt::Debug {
    /// The problem at parameter values `values` (one per free key, SI, finite).
    fn setup(&self, values: &[f64]) -> Result<Setup, ContinuationError>;
}

/// A family of periodic-orbit problems: a [`Scene`] with one or two parameters left free (module
/// doc).
#[derive(Debug, Clone)]
pub struct Family {
    scene: Arc<dyn Scene>,
    params: Vec<Parameter>,
    /// Periods integrated through this family and its clones (adaptive and replayed).
    periods: Arc<AtomicU64>,
}

impl Family {
    /// The scene `scene` with the free parameters `params` (one or two, different).
    pub fn new(scene: Arc<dyn Scene>, params: Vec<Parameter>) -> Result<Family, ContinuationError> {
        if params.len() == 2 && params[0] == params[1] {
            return Err(ContinuationError::SameParameter {
                input: "fold_param",
                name: params[1].name().to_string(),
                other: "param",
            });
        }
        Ok(Family {
            scene,
            params,
            periods: Arc::new(AtomicU64::new(0)),
        })
    }

    /// Periods of the map integrated so far through this family and its clones.
    pub fn periods(&self) -> u64 {
        self.periods.load(Ordering::Relaxed)
    }

    /// Count `k` periods integrated.
    pub fn count(&self, k: u64) {
        self.periods.fetch_add(k, Ordering::Relaxed);
    }

    /// The free keys.
    pub fn params(&self) -> &[Parameter] {
        &self.params
    }

    /// The problem at parameter values `values` (one per free key, SI).
    pub fn setup(&self, values: &[f64]) -> Result<Arc<Setup>, ContinuationError> {
        for (p, &v) in self.params.iter().zip(values) {
            if !v.is_finite() {
                return Err(ContinuationError::Input(format!(
                    "{} = {v}: must be a finite number ({})",
                    p.name(),
                    p.info.unit
                )));
            }
        }
        Ok(Arc::new(self.scene.setup(values)?))
    }
}
