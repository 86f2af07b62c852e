//! Fitting a rig's unknowns to measured data (`djkr fit`): weighted least squares of a sweep
//! observable over the full dynamic model, with uncertainties and information criteria to
//! compare laws.
//!
//! - `data` ([`FitData`]): the data file (conditions named by scenario keys, one observable named as in
//!   `sweep.csv`, optional `sigma`), units honoured.
//! - `free` ([`FreeKey`]): the free keys (`KEY[=LO:HI]`), log space for positive scales, bounds by
//!   transformation.
//! - `model` ([`ForwardModel`]): the forward model, every row a run of the sweep engine (with an ensemble, the
//!   mean over members whose phases are fixed by the seed).
//! - `driver` (`fit()`): the fit's steps, over
//!   - `problem`: the model's evaluation at points of the fit coordinates, finite-difference
//!     Jacobians checked against the model's error;
//!   - `lm`: the optimiser, Levenberg–Marquardt with Nielsen's damping;
//!   - `starts`: multi-start (Latin hypercube) and the distinct minima;
//!   - `tolerance`: the forward runs' tolerances from the data's sigma;
//!   - `uncertainty`: covariance per direction, the linear model's check, profile likelihood;
//!   - `report` ([`FitReport`] is `fit.json`).
//!
//! - `fitted`: the starting values from the scenario and the fitted scenario (`fitted.toml`);
//! - `residuals`: the residual table (`residuals.csv`, and as columns for Python);
//! - `predict` ([`FitFolder`], [`PredictRequest`], [`PredictReport`]): a fit read back, and the
//!   model's predictions with their uncertainty from it (`djkr predict`);
//! - `design` ([`DesignRequest`], [`Sigma`], [`Target`], [`DesignReport`]): the new measurements
//!   that would pin the free keys down best (`djkr design`).

pub(crate) mod analysis;
pub(crate) mod data;
pub(crate) mod design;
pub(crate) mod driver;
pub(crate) mod figure;
pub(crate) mod files;
pub(crate) mod fitted;
pub(crate) mod free;
pub(crate) mod lm;
pub(crate) mod model;
pub(crate) mod optimiser;
pub(crate) mod predict;
pub(crate) mod problem;
pub(crate) mod report;
pub(crate) mod residuals;
pub(crate) mod starts;
pub(crate) mod stencil;
pub(crate) mod tolerance;
pub(crate) mod uncertainty;

pub use data::{FitData, Observable};
pub use design::{DesignReport, DesignRequest, Sigma, Target};
pub(crate) use driver::{check_start, fit};
pub(crate) use free::fittable_keys;
pub use free::FreeKey;
pub(crate) use model::expected_runs;
pub use model::ForwardModel;
pub use predict::{FitFolder, PredictReport, PredictRequest};
pub(crate) use report::{FitEvent, FitOptions};
pub use report::{FitReport, Parameter, StartReport, Tolerances};
pub use residuals::Column;
