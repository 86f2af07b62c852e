//! Scenario files: the whole description of an experiment (material, adhesion law, sphere,
//! spring, damping, base motion, initial state, a protocol of stages, solver and output settings).
//!
//! This module holds the *validated* model that the simulator consumes. Parsing of the TOML file
//! (with unknown keys rejected and every out-of-range value reported with file, key, value and the
//! allowed range) lives in [`parse`].
//!
//! Coordinates (docs/MODEL.md): x_s sphere position (down +), x_b base displacement (up +), x_k the far
//! end of the holding spring (down +), δ = x_s + x_b the indentation (> 0 compresses).

pub(crate) mod checks;
pub(crate) mod error;
pub mod family;
pub mod keys;
pub mod overrides;
pub mod parse;

pub(crate) use djkr_core::dynamics::protocol::{Initial, Stage, StageKind, Until};
pub(crate) use djkr_core::dynamics::{Method, Solver};
pub(crate) use djkr_core::rig::{
    BaseMotion, ContactFormation, Damping, DampingOn, Holder, Rig, Sphere,
};

/// Output settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Output {
    /// Time-series samples per second of simulated time; 0 = every accepted step.
    pub sample_rate: f64,
    /// Also write CSV.
    pub csv: bool,
    /// Shuffle + deflate the HDF5 datasets (smaller files, slower writes).
    pub compress: bool,
    /// `fsync` every file and the directory before the run counts as written (survives a power
    /// loss, not only a killed process; docs/guide/output.md, "Crash safety").
    pub fsync: bool,
    /// Also draw the run's figure (`run.png`, `run.svg`; same as `run --plot`).
    pub plot: bool,
    /// Windows `[t0, t1]` (s; sorted, disjoint) recorded densely: envelope following never
    /// jumps into or across them, so the time series has no gap there.
    pub dense: Vec<[f64; 2]>,
}

impl Default for Output {
    fn default() -> Self {
        Self {
            sample_rate: 0.0,
            csv: false,
            compress: false,
            fsync: false,
            plot: false,
            dense: Vec::new(),
        }
    }
}

/// A validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// The physical rig: material, law, sphere, holder, damping, base, contact formation.
    pub rig: Rig,
    /// Starting state.
    pub initial: Initial,
    /// Protocol.
    pub stages: Vec<Stage>,
    /// Solver settings.
    pub solver: Solver,
    /// Output settings.
    pub output: Output,
    /// The scenario file's text, stored with the results (as in the file: without the
    /// overrides, which `overrides` lists).
    pub source_text: std::sync::Arc<str>,
    /// Where it came from (path, or `<string>`), followed by its overrides as on the command
    /// line: `scenarios/impacts.toml --set base.amplitude=30um`.
    pub source_name: String,
    /// The overrides applied to the file's values (`KEY=VALUE`, as given to `--set`), in order;
    /// empty when the file is used as written.
    pub overrides: Vec<String>,
}

impl Scenario {
    /// The runnable protocol: rig, initial state, stages, solver and the output cadence.
    pub fn plan(&self) -> djkr_core::dynamics::Plan<'_> {
        djkr_core::dynamics::Plan {
            rig: &self.rig,
            initial: self.initial,
            stages: &self.stages,
            solver: self.solver,
            sample_rate: self.output.sample_rate,
            dense: &self.output.dense,
        }
    }

    /// Simulate the scenario ([`djkr_core::dynamics::run`]), feeding `obs` with samples, events and
    /// cycle records.
    pub fn simulate(
        &self,
        obs: &mut dyn djkr_core::dynamics::Observer,
    ) -> Result<djkr_core::dynamics::RunResult, djkr_core::dynamics::SimError> {
        djkr_core::dynamics::run(&self.plan(), obs)
    }

    /// [`Scenario::simulate`], keeping what a run that ends early computed
    /// ([`djkr_core::dynamics::run_partial`]).
    pub fn simulate_partial(
        &self,
        obs: &mut dyn djkr_core::dynamics::Observer,
    ) -> Result<djkr_core::dynamics::Outcome, djkr_core::dynamics::SimError> {
        djkr_core::dynamics::run_partial(&self.plan(), obs)
    }

    /// The scales the protocol adds to the rig's model (initial gap, fastest spring-end speed).
    pub fn run_scales(&self) -> djkr_core::dynamics::model::RunScales {
        djkr_core::dynamics::protocol::run_scales(&self.initial, &self.stages)
    }
}

impl Scenario {
    /// Where the scenario came from: its file and the overrides applied to it.
    pub fn source(&self) -> crate::words::Source {
        crate::words::Source {
            file: self.file_name().to_string(),
            set: self.overrides.clone().into(),
        }
    }

    /// The scenario file's name: `source_name` without its overrides.
    fn file_name(&self) -> &str {
        let suffix: String = self
            .overrides
            .iter()
            .map(|o| format!(" --set {o}"))
            .collect();
        self.source_name
            .strip_suffix(&suffix)
            .unwrap_or(&self.source_name)
    }
}
