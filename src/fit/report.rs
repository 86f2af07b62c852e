//! What a fit reports: `fit.json` ([`FitReport`]), the outcome the files are written from
//! ([`FitOutcome`]), the options ([`FitOptions`]), the progress events ([`FitEvent`]) and the
//! error of a fit that has no estimate ([`FitError`]).

use std::sync::atomic::AtomicBool;

use serde::Serialize;

use super::model::{ParamSet, Prediction};

/// What a fit reports as it goes.
#[derive(Debug, Clone, PartialEq)]
pub enum FitEvent {
    /// A forward run ended.
    Run,
    /// An iteration (a Jacobian) ended, or the first evaluation (`iteration` 0).
    Iteration {
        /// Iterations so far (all starts, profiles and refits).
        iteration: usize,
        /// χ² at the iteration's point.
        chi2: f64,
        /// The best χ² met.
        best: f64,
        /// Forward runs so far.
        runs: usize,
    },
    /// A new stage of the fit begins (a start, the check of the tolerances, the uncertainty
    /// analysis, a profile), with the forward runs it is expected to take in all from now on.
    Stage {
        /// What, in words.
        what: String,
        /// Forward runs expected from now on (an estimate).
        runs_expected: usize,
    },
}

/// How to fit.
#[derive(Debug, Clone, Copy)]
pub struct FitOptions<'a> {
    /// Most Jacobians (iterations) of each optimisation.
    pub max_iterations: usize,
    /// Starting points: the given one and `starts − 1` drawn by Latin hypercube.
    pub starts: usize,
    /// Profile-likelihood intervals for every key (otherwise only where the linear model fails).
    pub profile: bool,
    /// Raised (Ctrl-C): stop and keep the best estimate.
    pub stop: Option<&'a AtomicBool>,
}

impl Default for FitOptions<'_> {
    fn default() -> Self {
        FitOptions {
            max_iterations: 30,
            starts: 1,
            profile: false,
            stop: None,
        }
    }
}

/// One parameter of `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// The key.
    pub key: String,
    /// The estimate (in `unit`).
    pub value: f64,
    /// Its standard deviation from the curvature (in `unit`), or null where the curvature does
    /// not support one (a fit that did not converge, a bound hit, a key the data cannot fix, a
    /// model that is not linear over one σ).
    pub sigma: Option<f64>,
    /// The 68 % interval `[lo, hi]` (in `unit`): the profile likelihood's where
    /// `interval_from` is `"profile"`, else the curvature's (the estimate ± σ in the fit
    /// coordinate: `value · exp(∓σ/value)` for a key in log space); null without either.
    pub interval: Option<[f64; 2]>,
    /// `"profile"` or `"curvature"` (null without an interval).
    pub interval_from: Option<&'static str>,
    /// The key's SI unit.
    pub unit: String,
    /// The starting value (the scenario's, in `unit`).
    pub initial: f64,
}

/// One start of a multi-start fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StartReport {
    /// The starting values (in the keys' units).
    pub start: Vec<f64>,
    /// Where the optimiser ended (in the keys' units).
    pub estimate: Vec<f64>,
    /// χ² there (at the fit's tolerances; null where the start could not be evaluated).
    pub chi2: Option<f64>,
    /// Whether it met a convergence criterion.
    pub converged: bool,
    /// Which distinct minimum it reached: 0 the best, 1 the next, …
    pub minimum: usize,
    /// Iterations.
    pub iterations: usize,
    /// Why it ended, or why it could not start.
    pub termination: String,
}

/// The solver tolerances of the forward runs and their check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tolerances {
    /// `solver.rtol` of the fit's runs.
    pub rtol: f64,
    /// `solver.envelope_tol` of the fit's runs.
    pub envelope_tol: f64,
    /// The scenario's (with `--set`): those of the check, and of `fitted.toml`.
    pub scenario_rtol: f64,
    /// The scenario's `solver.envelope_tol`.
    pub scenario_envelope_tol: f64,
    /// Whether the fit chose its tolerances (false: the scenario's, kept: `--set`, no sigma
    /// column, an ensemble, or data more precise than the scenario's tolerances resolve).
    pub chosen: bool,
    /// The largest model error allowed, as a fraction of a row's sigma.
    pub limit: f64,
    /// The model error at the estimate: the largest over the rows of |prediction at the fit's
    /// tolerances − at the scenario's| / sigma (null when not checked).
    pub model_error: Option<f64>,
    /// Why the fit's tolerances are what they are, in words.
    pub why: String,
}

/// The content of `fit.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    /// The estimates.
    pub parameters: Vec<Parameter>,
    /// Covariance matrix in the keys' units (`unit_i · unit_j`), in the order of `parameters`
    /// (null where a key has no σ).
    pub covariance: Vec<Vec<Option<f64>>>,
    /// Correlation matrix, in the order of `parameters` (null where undefined).
    pub correlation: Vec<Vec<Option<f64>>>,
    /// Σ ((obs − fit)/σ)² at the estimate (σ = 1 in the observable's unit without a sigma column).
    pub chi2: f64,
    /// Rows − free keys.
    pub dof: usize,
    /// χ² / dof.
    pub reduced_chi2: f64,
    /// χ² + 2k.
    pub aic: f64,
    /// χ² + k ln n.
    pub bic: f64,
    /// Whether the optimiser met a convergence criterion (false when stopped, out of
    /// iterations or ended by a failed run).
    pub converged: bool,
    /// The criterion that ended the optimiser of the best start, in words.
    pub termination: String,
    /// Jacobians computed (all starts, refits and profiles).
    pub iterations: usize,
    /// Forward runs made.
    pub forward_runs: usize,
    /// Right-hand-side evaluations of those runs (the integration's work).
    pub rhs_evals: u64,
    /// The observable fitted (as named in sweep.csv).
    pub observable: String,
    /// What the numbers need said.
    pub notes: Vec<String>,
    /// Every start (one without `--starts`).
    pub starts: Vec<StartReport>,
    /// The forward runs' tolerances.
    pub tolerances: Tolerances,
    /// Data rows.
    pub rows: usize,
    /// Wall time of the fit (s).
    pub wall_s: f64,
    /// Whether a stop (Ctrl-C) ended the fit (the estimate is the best so far).
    pub interrupted: bool,
}

/// A fit's result: the report and what the files need.
#[derive(Debug, Clone)]
pub struct FitOutcome {
    /// `fit.json`.
    pub report: FitReport,
    /// The estimates (SI), in the order of the free keys.
    pub values: ParamSet,
    /// The prediction at the estimates (at the scenario's tolerances when they were checked).
    pub prediction: Prediction,
    /// The σ each row was weighted with (SI; 1 without a sigma column).
    pub weights: Vec<f64>,
    /// The covariance of the keys in their fit coordinates (k × k, NaN where none), and the
    /// derivative dx/dy of each key at the estimate: what a ±1σ band of the model needs.
    pub cov_y: Vec<Vec<f64>>,
    /// The estimates in the fit coordinates.
    pub y: Vec<f64>,
    /// Each key's forward-difference step in the fit coordinate at the end.
    pub steps: Vec<f64>,
    /// The parameter sets (SI) of the estimate with each key stepped by its step in `steps`.
    pub stepped: Vec<ParamSet>,
}

/// A fit that could not start, whose first evaluation failed, or that was stopped (Ctrl-C)
/// before its first evaluation ended, so that no estimate exists to report.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct FitError {
    /// What went wrong, as one line.
    pub message: String,
    /// The stop flag ended the first evaluation: not an error of the input, and nothing to write.
    pub stopped: bool,
}

impl FitError {
    /// An error of the input or of a forward run.
    pub fn new(message: impl Into<String>) -> Self {
        FitError {
            message: message.into(),
            stopped: false,
        }
    }
}
