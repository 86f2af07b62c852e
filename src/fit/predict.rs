//! Predictions from a fit, with their uncertainty (`djkr predict`, issue 34): the model at the
//! fit's estimate over a grid of conditions, and the standard deviation that the parameters'
//! covariance gives it.
//!
//! - **The fit**: a fit's folder ([`FitFolder::read`]): `fit.json` (the estimates, their
//!   covariance in the keys' units, the fit coordinates, the tolerances, the ensemble),
//!   `fitted.toml` (the scenario with the estimates and the fit's fixed overrides written in)
//!   and `residuals.csv` (the data's conditions); or the same texts from a fit just made
//!   (`api::FitResult::fitted`, what Python's `djkr.predict` takes from a `djkr.Fit`).
//! - **The observable**: the fit's, or another that djkr produces (the fitted keys' covariance
//!   carried into that quantity; the fit's data are then not drawn).
//! - **The grid**: the axes of a sweep ([`crate::sweep::Axis`], `KEY=SPEC` as `djkr sweep --set`
//!   takes it; the Cartesian grid), or without axes the data's own conditions.
//! - **Linear propagation** (the delta method, /work/shared/STATS.md): with `g` the gradient of
//!   the prediction in the fit coordinates `y` (`ln x` for a key fitted in log space) and `C_y`
//!   the covariance there, `σ_parameters² = g C_y gᵀ`. The gradient is the fit's own Jacobian
//!   ([`super::problem::Evaluator::jacobian_y`]): forward differences of step `√ε` (ε the error
//!   level of the fit's tolerances), widened where a column does not stand above the model's
//!   error, at the fit's tolerances; the value itself runs at the scenario's (`fitted.toml`'s),
//!   as the fit's residuals do.
//! - **Samples**: with `samples = N`, N draws `y⁽ˢ⁾ ~ N(ŷ, C_y)` (so a key in log space stays
//!   positive), the model run at each; `sigma_samples` is their standard deviation. Where it
//!   and `sigma_parameters` differ by more than [`DISAGREEMENT`] (either way) the model is not
//!   linear over the parameters' uncertainty, and a note says the samples are the ones to trust.
//! - **Ensemble** (chaotic rigs): the request's `(members, seed)`, else the fit's (so that at the
//!   data's own conditions the values are the fit's, the same phases): each value is the mean
//!   over the members, `sigma_ensemble` its standard error, and the Jacobian the fit's central
//!   differences whose steps widen above that noise ([`super::stencil`]). Each draw of the
//!   samples is an ensemble mean too, so their spread holds the members' noise: it is compared
//!   with the combined `sigma`.
//! - **Bands**: `sigma = √(σ_parameters² + σ_ensemble²)`; `lo68, hi68 = value ∓ sigma`, `lo95,
//!   hi95 = value ∓ 1.96 sigma` (normal quantiles).
//!
//! [`propagate`], [`draws`] and [`spread`] are the pure parts, tested against closed forms; the
//! forward model is the fit's.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::Error;
use crate::input::{read_text, InputKind};
use crate::scenario::overrides::{Override, SetKey};
use crate::scenario::parse::ScenarioSource;
use crate::sweep::grid::{Axis, Grid};
use crate::sweep::spec::KeyCell;
use crate::words::{input, input_value};

use super::data::{CondValue, Condition, DataRow, FitData, Observable};
use super::free::{FreeKey, Transform};
use super::model::{EvalError, ForwardModel};
use super::problem::{fd_step, Evaluator};
use super::report::FitEvent;

/// The factor beyond which `sigma_samples` and `sigma_parameters` are said to disagree (a
/// ratio above it or below its inverse): a model that is not linear over the parameters'
/// uncertainty. With N samples the ratio's own sampling error is about `1/√(2N)` (7 % at 100), so
/// a factor 1.5 is not reached by chance.
pub const DISAGREEMENT: f64 = 1.5;

/// At most this many parameter draws.
pub const MAX_SAMPLES: usize = 100_000;

/// The normal quantile of a two-sided 95 % band.
pub const Z95: f64 = 1.959_963_984_540_054;

/// What to predict from a fit ([`FitFolder`]).
#[derive(Debug, Clone, Default)]
pub struct PredictRequest {
    /// The grid's axes (the Cartesian grid, first key slowest); empty: the data's own
    /// conditions.
    pub grid: Vec<Axis>,
    /// The observable to predict, as named in sweep.csv (`None`: the fit's).
    pub observable: Option<String>,
    /// An ensemble per point `(members, seed)` (`None`: the fit's, if it had one).
    pub ensemble: Option<(usize, u64)>,
    /// Parameter draws for `sigma_samples` (0: none).
    pub samples: usize,
    /// The draws' seed (`None`: 0); refused without draws or an ensemble of the request's, as
    /// it would seed nothing.
    pub seed: Option<u64>,
    /// Threads (0: one per core).
    pub jobs: usize,
}

/// A condition's value in a row: a number (SI) or text.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Cell {
    /// SI number.
    Num(f64),
    /// Text as given.
    Text(String),
}

/// A condition column of the prediction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConditionColumn {
    /// The scenario key.
    pub key: String,
    /// Its SI unit (null: text).
    pub unit: Option<&'static str>,
}

/// One grid point's prediction (in the observable's SI unit).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PredictRow {
    /// The conditions, in the order of [`PredictReport::conditions`].
    pub conditions: Vec<Cell>,
    /// The model at the estimate.
    pub value: f64,
    /// Its σ from the parameters' covariance (linear propagation); null where no key has a σ.
    pub sigma_parameters: Option<f64>,
    /// The ensemble's standard error (0 without an ensemble).
    pub sigma_ensemble: f64,
    /// `√(sigma_parameters² + sigma_ensemble²)`.
    pub sigma: Option<f64>,
    /// `value − sigma`.
    pub lo68: Option<f64>,
    /// `value + sigma`.
    pub hi68: Option<f64>,
    /// `value − 1.96 sigma`.
    pub lo95: Option<f64>,
    /// `value + 1.96 sigma`.
    pub hi95: Option<f64>,
    /// The standard deviation of the model over the parameter draws (null without samples).
    pub sigma_samples: Option<f64>,
}

/// What `predict` reports (`prediction.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PredictReport {
    /// The observable (as named in sweep.csv).
    pub observable: String,
    /// Its SI unit.
    pub unit: String,
    /// The condition columns.
    pub conditions: Vec<ConditionColumn>,
    /// The free keys whose covariance is propagated (those with a σ).
    pub keys: Vec<String>,
    /// The ensemble each value is the mean of (null without): the request's, else the fit's.
    pub ensemble: Option<super::report::Ensemble>,
    /// One row per grid point.
    pub rows: Vec<PredictRow>,
    /// Parameter draws made.
    pub samples: usize,
    /// The seed of the draws (and of the request's ensemble's phases).
    pub seed: u64,
    /// Forward runs made.
    pub forward_runs: usize,
    /// What the numbers need said.
    pub notes: Vec<String>,
}

impl PredictReport {
    /// The columns of `prediction.csv` (its header's names, `name [unit]`): a condition with
    /// a unit as numbers (SI), one without as text, the value, σ and bands as numbers (NaN where
    /// null).
    pub fn columns(&self) -> Vec<(String, super::residuals::Column)> {
        use super::residuals::Column;
        let conditions = self.conditions.len();
        csv_header(self)
            .into_iter()
            .enumerate()
            .map(|(j, name)| {
                let column = if j >= conditions {
                    Column::Num(
                        self.rows
                            .iter()
                            .map(|row| row_numbers(self, row)[j - conditions].unwrap_or(f64::NAN))
                            .collect(),
                    )
                } else if self.conditions[j].unit.is_some() {
                    Column::Num(
                        self.rows
                            .iter()
                            .map(|row| match &row.conditions[j] {
                                Cell::Num(x) => *x,
                                Cell::Text(_) => f64::NAN,
                            })
                            .collect(),
                    )
                } else {
                    Column::Text(
                        self.rows
                            .iter()
                            .map(|row| match &row.conditions[j] {
                                Cell::Text(t) => t.clone(),
                                Cell::Num(x) => x.to_string(),
                            })
                            .collect(),
                    )
                };
                (name, column)
            })
            .collect()
    }
}

/// One parameter of `fit.json`, as read back.
#[derive(Debug, Clone, Deserialize)]
struct FitParameter {
    key: String,
    value: f64,
    initial: f64,
    #[serde(default)]
    coordinate: Option<String>,
    #[serde(default)]
    bounds: Option<[Option<f64>; 2]>,
}

/// The tolerances of `fit.json`, as read back.
#[derive(Debug, Clone, Deserialize)]
struct FitTolerances {
    rtol: f64,
    envelope_tol: f64,
    chosen: bool,
}

/// What `predict` reads of `fit.json`.
#[derive(Debug, Clone, Deserialize)]
struct FitJson {
    parameters: Vec<FitParameter>,
    covariance: Vec<Vec<Option<f64>>>,
    observable: String,
    converged: bool,
    tolerances: FitTolerances,
    /// Absent from a fit written before `fit.json` recorded its ensemble (and null without one).
    #[serde(default)]
    ensemble: Option<super::report::Ensemble>,
}

/// A fit, read from its folder ([`FitFolder::read`]) or from the texts of its files.
#[derive(Debug, Clone)]
pub struct FitFolder {
    /// How messages name the fit: its folder's path, or `(the fit's result)`.
    pub(crate) shown: String,
    /// `fitted.toml`.
    pub(crate) source: ScenarioSource,
    /// The free keys (bounds as fitted).
    pub(crate) free: Vec<FreeKey>,
    /// Their transforms to the fit coordinates.
    pub(crate) tr: Vec<Transform>,
    /// The estimates (SI).
    pub(crate) values: Vec<f64>,
    /// The covariance in the fit coordinates (NaN where a key has no σ).
    pub(crate) cov_y: DMatrix<f64>,
    /// The observable fitted.
    pub(crate) observable: Observable,
    /// The data (from `residuals.csv`: the conditions, observed values and sigma).
    pub(crate) data: FitData,
    /// The fit's solver tolerances, when it chose its own: `(rtol, envelope_tol)`.
    pub(crate) tolerances: Option<(f64, f64)>,
    /// The fit's ensemble `(members, seed)`, if it had one.
    pub(crate) ensemble: Option<(usize, u64)>,
    /// Whether the fit converged.
    pub(crate) converged: bool,
}

impl FitFolder {
    /// The estimate in the fit coordinates `y`.
    pub(crate) fn y_estimate(&self) -> Vec<f64> {
        self.tr
            .iter()
            .zip(&self.values)
            .map(|(t, &x)| t.y(x))
            .collect()
    }

    /// Read the fit in `dir`. A folder without `fit.json` (no fit) is refused in one line.
    pub fn read(dir: &Path) -> Result<FitFolder, Error> {
        let shown = dir.display().to_string();
        let bad = |m: String| Error::Invalid(format!("{}: {m}", input_value("fit", &shown)));
        if !dir.is_dir() {
            return Err(bad("not a folder: give the folder a fit wrote".into()));
        }
        let json_path = dir.join("fit.json");
        if !json_path.exists() {
            return Err(bad(format!(
                "holds no fit (no fit.json): give the folder a fit wrote (its {})",
                input("out")
            )));
        }
        let json =
            read_text(&json_path, InputKind::FitData).map_err(|e| bad(format!("fit.json: {e}")))?;
        let source = ScenarioSource::read(&dir.join("fitted.toml"))
            .map_err(|e| bad(format!("fitted.toml: {e}")))?;
        let residuals = read_text(&dir.join("residuals.csv"), InputKind::FitData)
            .map_err(|e| bad(format!("residuals.csv: {e}")))?;
        Self::parse(&shown, &json, source, &residuals)
    }

    /// The fit whose files `fit.json` and `residuals.csv` have the texts `json` and `residuals`
    /// and whose `fitted.toml` is `source`; `shown` names it in messages.
    pub(crate) fn parse(
        shown: &str,
        json: &str,
        source: ScenarioSource,
        residuals: &str,
    ) -> Result<FitFolder, Error> {
        let bad = |m: String| Error::Invalid(format!("{}: {m}", input_value("fit", shown)));
        let json: FitJson = serde_json::from_str(json)
            .map_err(|e| bad(format!("fit.json is not a fit's report: {e}")))?;
        let observable = Observable::parse(&json.observable).ok_or_else(|| {
            bad(format!(
                "fit.json: observable '{}' is not one djkr produces",
                djkr_core::text::excerpt(&json.observable)
            ))
        })?;
        let k = json.parameters.len();
        if json.covariance.len() != k || json.covariance.iter().any(|r| r.len() != k) {
            return Err(bad(format!(
                "fit.json: the covariance is not {k} x {k} (the parameters')"
            )));
        }
        let mut free = Vec::with_capacity(k);
        let mut tr = Vec::with_capacity(k);
        for p in &json.parameters {
            let mut f = FreeKey::parse(&p.key).map_err(|m| bad(format!("fit.json: {m}")))?;
            if let Some([lo, hi]) = p.bounds {
                f.lo = lo;
                f.hi = hi;
            }
            let t = Transform::new(&f, p.initial);
            if let Some(c) = &p.coordinate {
                let want = c == "log";
                if want != t.log {
                    return Err(bad(format!(
                        "fit.json: {} has coordinate '{}', which its start and bounds do not \
                         give",
                        p.key,
                        djkr_core::text::excerpt(c)
                    )));
                }
            }
            free.push(f);
            tr.push(t);
        }
        if json.ensemble.is_some_and(|e| e.members == 0) {
            return Err(bad("fit.json: an ensemble of 0 members".into()));
        }
        let values: Vec<f64> = json.parameters.iter().map(|p| p.value).collect();
        let dx: Vec<f64> = tr
            .iter()
            .zip(&values)
            .map(|(t, &x)| t.dx_dy(t.y(x)))
            .collect();
        let cov_y = DMatrix::from_fn(k, k, |a, b| match json.covariance[a][b] {
            Some(c) => c / (dx[a] * dx[b]),
            None => f64::NAN,
        });
        let data = parse_residuals(residuals, observable)
            .map_err(|m| bad(format!("residuals.csv: {m}")))?;
        Ok(FitFolder {
            shown: shown.to_string(),
            source,
            free,
            tr,
            values,
            cov_y,
            observable,
            data,
            tolerances: json
                .tolerances
                .chosen
                .then_some((json.tolerances.rtol, json.tolerances.envelope_tol)),
            ensemble: json.ensemble.map(|e| (e.members, e.seed)),
            converged: json.converged,
        })
    }
}

/// The data of a fit from its `residuals.csv`'s text: the condition columns (those before
/// `observed`), `observed` as the observable and `sigma` where given.
fn parse_residuals(text: &str, observable: Observable) -> Result<FitData, String> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(text.as_bytes());
    let head: Vec<String> = reader
        .headers()
        .map_err(|e| e.to_string())?
        .iter()
        .map(str::to_string)
        .collect();
    let obs = head
        .iter()
        .position(|h| h.starts_with("observed"))
        .ok_or("no 'observed' column")?;
    let sigma = head.iter().position(|h| h.starts_with("sigma"));
    let mut rows: Vec<Vec<String>> = Vec::new();
    for r in reader.records() {
        let r = r.map_err(|e| e.to_string())?;
        rows.push(r.iter().map(str::to_string).collect());
    }
    let with_sigma =
        sigma.filter(|&s| rows.iter().all(|r| r.get(s).is_some_and(|c| !c.is_empty())));
    let unit = observable.unit();
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    let mut h: Vec<String> = head[..obs].to_vec();
    h.push(format!("{} [{unit}]", observable.name()));
    if with_sigma.is_some() {
        h.push(format!("sigma [{unit}]"));
    }
    w.write_record(&h).map_err(|e| e.to_string())?;
    for r in &rows {
        let mut cells: Vec<&str> = r[..obs.min(r.len())].iter().map(String::as_str).collect();
        cells.push(r.get(obs).map_or("", String::as_str));
        if let Some(s) = with_sigma {
            cells.push(r.get(s).map_or("", String::as_str));
        }
        w.write_record(&cells).map_err(|e| e.to_string())?;
    }
    let bytes = w.into_inner().map_err(|e| e.to_string())?;
    let csv_text = String::from_utf8(bytes).map_err(|e| e.to_string())?;
    FitData::parse(&csv_text, "residuals.csv", Some(observable.name())).map_err(|e| e.0)
}

/// `σ` of each row from the Jacobian `jac` (rows × keys, ∂prediction/∂y) and the covariance
/// `cov` in the same coordinates: `√(g C gᵀ)` per row. Keys whose variance is not finite are
/// left out (held at the estimate).
pub fn propagate(jac: &DMatrix<f64>, cov: &DMatrix<f64>) -> Vec<f64> {
    let k = cov.nrows();
    let keep: Vec<usize> = (0..k).filter(|&j| cov[(j, j)].is_finite()).collect();
    (0..jac.nrows())
        .map(|i| {
            let mut v = 0.0;
            for &a in &keep {
                for &b in &keep {
                    v += jac[(i, a)] * cov[(a, b)] * jac[(i, b)];
                }
            }
            v.max(0.0).sqrt()
        })
        .collect()
}

/// A deterministic stream of standard normal numbers (SplitMix64 and Box–Muller).
struct Normal {
    state: u64,
    spare: Option<f64>,
}

impl Normal {
    fn new(seed: u64) -> Normal {
        Normal {
            state: seed ^ 0x5DEE_CE66_D1CE_4E5B,
            spare: None,
        }
    }

    fn uniform(&mut self) -> f64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        // In (0, 1): never 0, so that the logarithm below is finite.
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn next(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let (u, v) = (self.uniform(), self.uniform());
        let r = (-2.0 * u.ln()).sqrt();
        let t = std::f64::consts::TAU * v;
        self.spare = Some(r * t.sin());
        r * t.cos()
    }
}

/// `n` draws from `N(y, cov)` (seeded): the keys whose variance is not finite stay at `y`. The
/// square root of the covariance is its symmetric eigen-decomposition's (`V √Λ`, negative
/// eigenvalues of rounding taken as 0), so a singular covariance draws too.
pub fn draws(y: &[f64], cov: &DMatrix<f64>, n: usize, seed: u64) -> Vec<Vec<f64>> {
    let keep: Vec<usize> = (0..y.len()).filter(|&j| cov[(j, j)].is_finite()).collect();
    let m = keep.len();
    let sub = DMatrix::from_fn(m, m, |a, b| {
        0.5 * (cov[(keep[a], keep[b])] + cov[(keep[b], keep[a])])
    });
    let eig = nalgebra::SymmetricEigen::new(sub);
    let root = DMatrix::from_fn(m, m, |a, b| {
        eig.eigenvectors[(a, b)] * eig.eigenvalues[b].max(0.0).sqrt()
    });
    let mut rng = Normal::new(seed);
    (0..n)
        .map(|_| {
            let z: Vec<f64> = (0..m).map(|_| rng.next()).collect();
            let mut out = y.to_vec();
            for (a, &ja) in keep.iter().enumerate() {
                out[ja] += (0..m).map(|b| root[(a, b)] * z[b]).sum::<f64>();
            }
            out
        })
        .collect()
}

/// The standard deviation (with `n − 1`) of each row over the samples `values` (one vector of
/// rows per sample); null with fewer than 2 samples.
pub fn spread(values: &[Vec<f64>], rows: usize) -> Vec<Option<f64>> {
    let n = values.len();
    (0..rows)
        .map(|i| {
            (n >= 2).then(|| {
                let mean = values.iter().map(|v| v[i]).sum::<f64>() / n as f64;
                let ss: f64 = values.iter().map(|v| (v[i] - mean).powi(2)).sum();
                (ss / (n - 1) as f64).sqrt()
            })
        })
        .collect()
}

/// A prediction's row from its value and its σ parts.
pub fn row(
    conditions: Vec<Cell>,
    value: f64,
    sigma_parameters: Option<f64>,
    sigma_ensemble: f64,
    sigma_samples: Option<f64>,
) -> PredictRow {
    let sigma = sigma_parameters.map(|s| s.hypot(sigma_ensemble));
    PredictRow {
        conditions,
        value,
        sigma_parameters,
        sigma_ensemble,
        sigma,
        lo68: sigma.map(|s| value - s),
        hi68: sigma.map(|s| value + s),
        lo95: sigma.map(|s| value - Z95 * s),
        hi95: sigma.map(|s| value + Z95 * s),
        sigma_samples,
    }
}

/// The grid's data: one row per grid point, the axes as conditions (observed 0, no sigma).
pub(crate) fn grid_data(axes: &[Axis], observable: Observable) -> Result<FitData, Error> {
    let grid = Grid::new(axes.to_vec(), false).map_err(Error::Spec)?;
    let conditions: Vec<Condition> = grid
        .axes()
        .iter()
        .map(|a| Condition {
            key: a.key,
            unit: a.unit(),
        })
        .collect();
    let rows = (0..grid.points())
        .map(|p| DataRow {
            line: p as u64 + 2,
            conditions: grid
                .cells(p)
                .into_iter()
                .map(|c| match c {
                    KeyCell::Num(x) => CondValue::Num(x),
                    KeyCell::Text(t) => CondValue::Text(t),
                })
                .collect(),
            observed: 0.0,
            sigma: None,
        })
        .collect();
    Ok(FitData {
        name: input("set"),
        conditions,
        observable,
        has_sigma: false,
        observable_column: (0, String::new()),
        sigma_column: None,
        rows,
    })
}

/// The observable `name` asks for (`None`: the fit's), or the refusal that lists them.
fn observable_of(name: Option<&str>, fit: &FitFolder) -> Result<Observable, Error> {
    let Some(name) = name else {
        return Ok(fit.observable);
    };
    Observable::parse(name).ok_or_else(|| {
        Error::Invalid(format!(
            "{}: not an observable djkr produces; one of {} (the fit's: {})",
            input_value("observable", &djkr_core::text::excerpt(name)),
            Observable::list(),
            fit.observable.name()
        ))
    })
}

/// What a request makes of a fit before anything runs: the observable and the model over the
/// grid's data (with the ensemble, the request's or the fit's).
struct Prepared {
    observable: Observable,
    model: ForwardModel,
}

/// Refuse a request that [`predict`] would refuse, before anything runs (so that a front end can
/// check it before it claims an output folder).
pub fn check(fit: &FitFolder, req: &PredictRequest) -> Result<(), Error> {
    prepare(fit, req).map(|_| ())
}

/// The checks of a request, and what it makes of the fit ([`Prepared`]).
fn prepare(fit: &FitFolder, req: &PredictRequest) -> Result<Prepared, Error> {
    if req.samples == 1 || req.samples > MAX_SAMPLES {
        return Err(Error::Invalid(format!(
            "{}: must be 0 (none) or from 2 to {MAX_SAMPLES} (a spread needs two)",
            input_value("samples", &req.samples.to_string())
        )));
    }
    let observable = observable_of(req.observable.as_deref(), fit)?;
    if let Some((m, _)) = req.ensemble {
        if m < 2 {
            return Err(Error::Invalid(format!(
                "{}: must be a whole number >= 2 (members per point: a standard error needs two)",
                input_value("ensemble", &m.to_string())
            )));
        }
    }
    refuse_free_axes(fit, &req.grid, &crate::words::axis_item)?;
    if let (Some(s), 0, None) = (req.seed, req.samples, req.ensemble) {
        return Err(Error::Invalid(format!(
            "{}: seeds the draws of {} and the phases of {}; give one of them",
            input_value("seed", &s.to_string()),
            input("samples"),
            input("ensemble")
        )));
    }
    let mut data = if req.grid.is_empty() {
        fit.data.clone()
    } else {
        grid_data(&req.grid, observable)?
    };
    data.observable = observable;
    let model = forward_model(fit, data, req.ensemble.or(fit.ensemble), req.jobs)?;
    Ok(Prepared { observable, model })
}

/// The model of a fit's estimate over the rows of `data`, and what else [`at_estimate`] was
/// asked for.
pub(crate) struct AtEstimate {
    /// The model at the estimate per row (SI), at the scenario's tolerances (`fitted.toml`'s),
    /// as the fit's residuals are: the members' mean with an ensemble.
    pub values: Vec<f64>,
    /// The standard error of each value over the ensemble's members (0 without an ensemble).
    pub se: Vec<f64>,
    /// With `jacobian`: ∂prediction/∂y per row and free key (rows × keys), in the fit
    /// coordinates, the fit's own Jacobian at the fit's tolerances.
    pub jac: Option<DMatrix<f64>>,
    /// The model at each of the `extra` points of the fit coordinates (rows each).
    pub extra: Vec<Vec<f64>>,
    /// Forward runs made.
    pub forward_runs: usize,
}

/// Refuse a grid axis that sets a key the fit estimated; `item` words the axis in the message
/// (the input it came from).
pub(crate) fn refuse_free_axes(
    fit: &FitFolder,
    axes: &[Axis],
    item: &dyn Fn(&str) -> String,
) -> Result<(), Error> {
    for a in axes {
        if fit.free.iter().any(|f| f.key == a.key) {
            return Err(Error::Invalid(format!(
                "{}: {} is a key the fit estimated, not a condition: its value is the fit's \
                 estimate",
                item(&a.shown()),
                a.key
            )));
        }
    }
    Ok(())
}

/// The forward model of the fit in `fit` over the rows of `data` (their conditions set on
/// `fitted.toml`, the fit's free keys), each value the mean of an ensemble `(members, seed)` if
/// given; `jobs` threads (0: one per core).
pub(crate) fn forward_model(
    fit: &FitFolder,
    data: FitData,
    ensemble: Option<(usize, u64)>,
    jobs: usize,
) -> Result<ForwardModel, Error> {
    let keys: Vec<SetKey> = fit.free.iter().map(|f| f.key).collect();
    ForwardModel::new(fit.source.clone(), data, keys, Vec::new(), ensemble, jobs)
        .map_err(Error::Invalid)
}

/// The model `model` of the fit in `fit` ([`forward_model`]) at its estimate, with `jacobian`
/// its gradient against the free keys as the fit computes it ([`Evaluator::jacobian_y`]:
/// forward differences of step `√ε`, ε the error level of the fit's tolerances, widened where a
/// column does not stand above the model's error; with an ensemble of two members or more, the
/// fit's central differences whose steps widen above the members' noise,
/// [`super::stencil`]), and the model at the points `extra` of the fit coordinates (at the
/// fit's tolerances). Shared by `predict` (the Jacobian, and its samples at `extra`) and
/// `design` (no Jacobian: its secants' points at `extra`); `stop` abandons the runs
/// ([`Error::Cancelled`]), `on_run` is called as each forward run ends.
pub(crate) fn at_estimate(
    fit: &FitFolder,
    model: &ForwardModel,
    jacobian: bool,
    extra: &[Vec<f64>],
    stop: Option<&AtomicBool>,
    on_run: &mut dyn FnMut(),
) -> Result<AtEstimate, Error> {
    let n = model.data().rows.len();
    let members = model.ensemble().map_or(1, |e| e.0);
    let scn = fit
        .source
        .scenario(&[])
        .map_err(|e| Error::Invalid(e.to_string()))?;
    let envelope = scn.solver.envelope == djkr_core::dynamics::methods::EnvelopeMode::Auto;
    let (rtol, env) = fit
        .tolerances
        .unwrap_or((scn.solver.rtol, scn.solver.envelope_tol));
    let fit_model = match fit.tolerances {
        Some((r, e)) => model.with_solver(vec![
            Override::from_key(SetKey::parse("solver.rtol").map_err(Error::Override)?, r)
                .map_err(Error::Override)?,
            Override::from_key(
                SetKey::parse("solver.envelope_tol").map_err(Error::Override)?,
                e,
            )
            .map_err(Error::Override)?,
        ]),
        None => model.clone(),
    };
    let eps_rel = super::tolerance::RTOL_GAIN * rtol
        + if envelope {
            super::tolerance::ENVELOPE_GAIN * env
        } else {
            0.0
        };
    let y_hat = fit.y_estimate();
    let mut progress = |e: FitEvent| {
        if e == FitEvent::Run {
            on_run();
        }
    };
    let mut ev = Evaluator::new(
        fit_model,
        fit.tr.clone(),
        vec![1.0; n],
        vec![0.0; n],
        fd_step(eps_rel),
        // With an ensemble, central differences whose steps widen above its noise, as the fit's.
        (members > 1).then(|| (vec![0.0; n], super::stencil::INITIAL_HALF_STEP)),
        stop,
        &mut progress,
    );
    let failed = |e: EvalError| match e {
        EvalError::Stopped => Error::Cancelled,
        EvalError::Failed(m) => Error::Invalid(m),
    };
    let value = ev
        .predict_on(model, std::slice::from_ref(&fit.values))
        .map_err(failed)?
        .pop()
        .ok_or(Error::Cancelled)?;
    ev.set_error(
        value.values.iter().map(|v| eps_rel * v.abs()).collect(),
        fd_step(eps_rel),
    );
    if members > 1 {
        ev.set_noise(value.se.clone());
    }
    let jac = if jacobian {
        Some(ev.jacobian_y(&y_hat).map_err(failed)?)
    } else {
        None
    };
    let extra = if extra.is_empty() {
        Vec::new()
    } else {
        ev.predict_y(extra)
            .map_err(failed)?
            .into_iter()
            .map(|p| p.values)
            .collect()
    };
    let forward_runs = ev.st.borrow().runs;
    Ok(AtEstimate {
        values: value.values,
        se: value.se,
        jac,
        extra,
        forward_runs,
    })
}

/// Predict with uncertainty from the fit `fit` over a grid ([`PredictRequest`]); `stop`
/// abandons the runs (then [`Error::Cancelled`]), `on_run` is called as each forward run ends.
pub fn predict(
    fit: &FitFolder,
    req: &PredictRequest,
    stop: Option<&AtomicBool>,
    on_run: &mut dyn FnMut(),
) -> Result<PredictReport, Error> {
    let Prepared { observable, model } = prepare(fit, req)?;
    let ensemble = model.ensemble();
    let data = model.data();
    let mut notes = Vec::new();
    let seed = req.seed.unwrap_or(0);
    let members = ensemble.map_or(1, |e| e.0);
    let n = data.rows.len();
    if observable != fit.observable {
        notes.push(format!(
            "{} predicted from a fit of {}: the bands carry the uncertainty of the fitted keys \
             only, as far as the model holds for this quantity; the figure draws no data",
            observable.name(),
            fit.observable.name()
        ));
    }
    if members == 1 && ensemble.is_some() {
        notes.push(
            "the fit's ensemble has 1 member: each value is the run at its drawn phase, and \
             sigma_ensemble (0) does not measure the phases' spread: predict with an ensemble \
             of 2 members or more for it"
                .into(),
        );
    }
    let has_sigma: Vec<bool> = (0..fit.free.len())
        .map(|j| fit.cov_y[(j, j)].is_finite())
        .collect();
    let any_sigma = has_sigma.iter().any(|&h| h);
    let ys = if req.samples > 0 {
        draws(&fit.y_estimate(), &fit.cov_y, req.samples, seed)
    } else {
        Vec::new()
    };
    let at = at_estimate(fit, &model, any_sigma, &ys, stop, on_run)?;
    let sigma_p: Vec<Option<f64>> = match &at.jac {
        Some(jac) => propagate(jac, &fit.cov_y).into_iter().map(Some).collect(),
        None => {
            notes.push(
                "no key of the fit has a sigma (see the fit's notes): the prediction has none"
                    .into(),
            );
            vec![None; n]
        }
    };
    for (j, f) in fit.free.iter().enumerate() {
        if !has_sigma[j] && any_sigma {
            notes.push(format!(
                "{}: the fit gave it no sigma; it is held at its estimate in sigma_parameters",
                f.key
            ));
        }
    }
    if !fit.converged {
        notes.push("the fit did not converge: its estimate is the best point it met".into());
    }
    let sigma_s = if req.samples > 0 {
        spread(&at.extra, n)
    } else {
        vec![None; n]
    };
    let mut disagree = 0;
    let rows: Vec<PredictRow> = (0..n)
        .map(|i| {
            // With an ensemble each draw's value carries the members' noise too: the samples'
            // spread is compared with the combined sigma.
            if let (Some(p), Some(s)) = (sigma_p[i].map(|p| p.hypot(at.se[i])), sigma_s[i]) {
                if s > DISAGREEMENT * p || p > DISAGREEMENT * s {
                    disagree += 1;
                }
            }
            let cells = data.rows[i]
                .conditions
                .iter()
                .map(|c| match c {
                    CondValue::Num(x) => Cell::Num(*x),
                    CondValue::Text(t) => Cell::Text(t.clone()),
                })
                .collect();
            row(cells, at.values[i], sigma_p[i], at.se[i], sigma_s[i])
        })
        .collect();
    if disagree > 0 {
        notes.push(format!(
            "at {disagree} of {n} points sigma_samples and {} differ by more than a factor \
             {DISAGREEMENT}: the model is not linear over the parameters' uncertainty there; \
             trust sigma_samples",
            if members > 1 {
                "sigma"
            } else {
                "sigma_parameters"
            }
        ));
    }
    Ok(PredictReport {
        observable: observable.name().to_string(),
        unit: observable.unit().to_string(),
        ensemble: ensemble.map(|(members, seed)| super::report::Ensemble { members, seed }),
        conditions: data
            .conditions
            .iter()
            .map(|c| ConditionColumn {
                key: c.key.to_string(),
                unit: c.unit,
            })
            .collect(),
        keys: fit
            .free
            .iter()
            .zip(&has_sigma)
            .filter(|(_, &h)| h)
            .map(|(f, _)| f.key.to_string())
            .collect(),
        rows,
        samples: req.samples,
        seed,
        forward_runs: at.forward_runs,
        notes,
    })
}

/// The files `predict` writes.
pub const FILES: [&str; 4] = [
    "prediction.csv",
    "prediction.json",
    "prediction.png",
    "prediction.svg",
];

/// Write [`FILES`] in `out` (claimed and locked by the caller), each atomically:
/// `prediction.csv`, `prediction.json` and, where [`prediction_figure`] draws one, the figure.
/// Returns `prediction.json`'s text (without its final newline) and whether a figure was drawn.
pub fn write(out: &Path, r: &PredictReport, fit: &FitFolder) -> Result<(String, bool), String> {
    let put = |name: &str, bytes: &[u8]| {
        crate::output::write_atomic(&out.join(name), bytes).map_err(|e| format!("{name}: {e}"))
    };
    let json = serde_json::to_string_pretty(r).map_err(|e| e.to_string())?;
    put("prediction.csv", prediction_csv(r).as_bytes())?;
    put("prediction.json", format!("{json}\n").as_bytes())?;
    let figure = prediction_figure(r, fit);
    if let Some(fig) = &figure {
        crate::plot::render(fig, &out.join("prediction"))
            .map_err(|e| format!("prediction.png/prediction.svg: {e}"))?;
    }
    Ok((json, figure.is_some()))
}

/// Whether two condition cells are the same value (numbers within 1e-9 relative: a grid's range
/// and a data file's decimal need not agree to the bit).
fn same(a: &Cell, b: &Cell) -> bool {
    match (a, b) {
        (Cell::Num(x), Cell::Num(y)) => (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
        (Cell::Text(x), Cell::Text(y)) => x == y,
        _ => false,
    }
}

/// The figure of a prediction: the value over the grid's first condition that varies (numeric),
/// its 68 % band (dashed) and 95 % band (the same colour, another dash), one colour per value of
/// the other conditions, and the fit's data (markers with ±σ where given) where the other
/// conditions match a group's, when the prediction is of the observable the fit was fitted to. `None` without a numeric condition that takes two values.
pub fn prediction_figure(r: &PredictReport, fit: &FitFolder) -> Option<crate::plot::Figure> {
    use crate::plot::{axis_label, Figure, Series, Style, COLOR_COUNT};
    let data = &fit.data;
    // The fit's data are drawn only over a prediction of the quantity they measure.
    let with_data = r.observable == fit.observable.name();
    let varies = |j: usize| {
        let first = &r.rows.first()?.conditions[j];
        Some(r.rows.iter().any(|row| !same(&row.conditions[j], first)))
    };
    let xj = (0..r.conditions.len())
        .find(|&j| r.conditions[j].unit.is_some() && varies(j) == Some(true))?;
    let others: Vec<usize> = (0..r.conditions.len())
        .filter(|&j| j != xj && varies(j) == Some(true))
        .collect();
    // Groups: rows with the same values of the other varying conditions, in order of first
    // appearance.
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, row) in r.rows.iter().enumerate() {
        match groups.iter_mut().find(|g| {
            others
                .iter()
                .all(|&j| same(&r.rows[g[0]].conditions[j], &row.conditions[j]))
        }) {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    let num = |c: &Cell| match c {
        Cell::Num(x) => *x,
        Cell::Text(_) => f64::NAN,
    };
    let xs: Vec<f64> = r.rows.iter().map(|row| num(&row.conditions[xj])).collect();
    let xkey = &r.conditions[xj];
    let (fx, xlabel) = axis_label(&xkey.key, xkey.unit.unwrap_or(""), &xs);
    let all_y: Vec<f64> = r.rows.iter().map(|row| row.value).collect();
    let (fy, ylabel) = axis_label(&r.observable, &r.unit, &all_y);
    let mut fig = Figure::new(
        format!(
            "{} predicted from the fit ({}), with 68 % and 95 % bands",
            r.observable,
            r.keys.join(", ")
        ),
        xlabel,
        ylabel,
    );
    // The data's column of each grid condition, where it has one.
    let data_col: Vec<Option<usize>> = r
        .conditions
        .iter()
        .map(|c| {
            data.conditions
                .iter()
                .position(|d| d.key.to_string() == c.key)
        })
        .collect();
    for (g, rows) in groups.iter().enumerate() {
        let mut idx = rows.clone();
        idx.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
        let name = others
            .iter()
            .map(|&j| {
                let c = &r.rows[idx[0]].conditions[j];
                match (c, r.conditions[j].unit) {
                    (Cell::Num(x), Some(u)) => {
                        let (f, unit) = crate::plot::display_unit(u, &[*x]);
                        format!(
                            "{} = {} {}",
                            r.conditions[j].key,
                            crate::plot::tick_label(x * f),
                            crate::plot::unit_text(&unit)
                        )
                    }
                    (c, _) => format!(
                        "{} = {}",
                        r.conditions[j].key,
                        match c {
                            Cell::Num(x) => crate::output::table::format_f64(*x),
                            Cell::Text(t) => t.clone(),
                        }
                    ),
                }
            })
            .collect::<Vec<_>>()
            .join(", ");
        let x: Vec<f64> = idx.iter().map(|&i| xs[i] * fx).collect();
        let y = |f: &dyn Fn(&PredictRow) -> Option<f64>| -> Vec<f64> {
            idx.iter()
                .map(|&i| f(&r.rows[i]).map_or(f64::NAN, |v| v * fy))
                .collect()
        };
        let label = |what: &str| {
            if name.is_empty() {
                what.to_string()
            } else if what == "prediction" {
                name.clone()
            } else if g == 0 {
                what.to_string()
            } else {
                String::new()
            }
        };
        fig = fig.with_series(
            Series::new(
                label("prediction"),
                x.clone(),
                y(&|r| Some(r.value)),
                Style::Line,
            )
            .with_color(g),
        );
        if r.rows.iter().any(|row| row.sigma.is_some()) {
            for (what, lo, hi, style, colour) in [
                (
                    "68 % band",
                    (|r: &PredictRow| r.lo68) as fn(&PredictRow) -> Option<f64>,
                    (|r: &PredictRow| r.hi68) as fn(&PredictRow) -> Option<f64>,
                    Style::Dashed,
                    g,
                ),
                (
                    "95 % band",
                    |r| r.lo95,
                    |r| r.hi95,
                    Style::Line,
                    g + COLOR_COUNT,
                ),
            ] {
                fig = fig.with_series(
                    Series::new(label(what), x.clone(), y(&lo), style).with_color(colour),
                );
                fig = fig.with_series(Series::new("", x.clone(), y(&hi), style).with_color(colour));
            }
        }
        // The data where the other conditions match this group's.
        if let Some(dx) = data_col[xj].filter(|_| with_data) {
            let (mut px, mut py) = (Vec::new(), Vec::new());
            for d in &data.rows {
                let cell = |k: usize| match &d.conditions[k] {
                    CondValue::Num(x) => Cell::Num(*x),
                    CondValue::Text(t) => Cell::Text(t.clone()),
                };
                let matches = (0..r.conditions.len()).filter(|&j| j != xj).all(|j| {
                    data_col[j].is_none_or(|k| same(&cell(k), &r.rows[idx[0]].conditions[j]))
                });
                if matches {
                    px.push(num(&cell(dx)) * fx);
                    py.push(d.observed * fy);
                }
            }
            if !px.is_empty() {
                fig = fig.with_series(
                    Series::new(
                        if g == 0 { "data (the fit's)" } else { "" },
                        px,
                        py,
                        Style::Markers,
                    )
                    .with_color(g),
                );
            }
        }
    }
    Some(fig)
}

/// A condition's cell as CSV text: a number as the tables write it, text quoted where it holds a
/// comma, a quote or a line end (RFC 4180). Shared by prediction.csv and design.csv.
pub(crate) fn cell_csv(c: &Cell) -> String {
    match c {
        Cell::Num(x) => crate::output::table::format_f64(*x),
        Cell::Text(t) => super::residuals::csv_text(t),
    }
}

/// `prediction.csv`: the conditions, `value`, `sigma_parameters`, `sigma_ensemble`, `sigma`,
/// the 68 % and 95 % bands, and with samples `sigma_samples`, each headed `name [unit]` (SI);
/// an empty cell where a σ is null.
pub fn prediction_csv(r: &PredictReport) -> String {
    use crate::output::table::format_f64;
    let mut out = csv_header(r).join(",");
    out.push('\n');
    let opt = |x: Option<f64>| x.map(format_f64).unwrap_or_default();
    for row in &r.rows {
        let mut cells: Vec<String> = row.conditions.iter().map(cell_csv).collect();
        cells.extend(row_numbers(r, row).iter().map(|&x| opt(x)));
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// A row's numbers in the order of [`csv_header`]'s columns after the conditions: `value`,
/// `sigma_parameters`, `sigma_ensemble`, `sigma`, the bands, and with samples `sigma_samples`.
pub fn row_numbers(r: &PredictReport, row: &PredictRow) -> Vec<Option<f64>> {
    let mut v = vec![
        Some(row.value),
        row.sigma_parameters,
        Some(row.sigma_ensemble),
        row.sigma,
        row.lo68,
        row.hi68,
        row.lo95,
        row.hi95,
    ];
    if r.samples > 0 {
        v.push(row.sigma_samples);
    }
    v
}

/// The names of `prediction.csv`'s columns, `name [unit]` (SI; a text condition without).
pub fn csv_header(r: &PredictReport) -> Vec<String> {
    let u = &r.unit;
    let mut head: Vec<String> = r
        .conditions
        .iter()
        .map(|c| super::residuals::column_name(&c.key, c.unit))
        .collect();
    let mut cols = vec![
        "value",
        "sigma_parameters",
        "sigma_ensemble",
        "sigma",
        "lo68",
        "hi68",
        "lo95",
        "hi95",
    ];
    if r.samples > 0 {
        cols.push("sigma_samples");
    }
    head.extend(cols.iter().map(|c| format!("{c} [{u}]")));
    head
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight line `m(x) = a + b x` in the parameters (a, b): its gradient is (1, x), so
    /// `σ² = C_aa + 2x C_ab + x² C_bb` exactly, and samples of it are normal with that σ.
    #[test]
    fn linear_propagation_is_exact_for_a_line_and_the_samples_agree() {
        let cov = DMatrix::from_row_slice(2, 2, &[0.04, -0.012, -0.012, 0.01]);
        let xs = [-2.0, 0.0, 0.5, 3.0];
        let jac = DMatrix::from_fn(xs.len(), 2, |i, j| if j == 0 { 1.0 } else { xs[i] });
        let s = propagate(&jac, &cov);
        for (i, &x) in xs.iter().enumerate() {
            let exact: f64 = 0.04 + 2.0 * x * -0.012 + x * x * 0.01;
            assert!((s[i] - exact.sqrt()).abs() <= 1e-15 * exact.sqrt().max(1.0));
        }
        let theta = [1.5, -0.7];
        let n = 4000;
        let ds = draws(&theta, &cov, n, 7);
        let values: Vec<Vec<f64>> = ds
            .iter()
            .map(|d| xs.iter().map(|&x| d[0] + d[1] * x).collect())
            .collect();
        let sp = spread(&values, xs.len());
        for i in 0..xs.len() {
            let sd = sp[i].unwrap();
            // The sample standard deviation's own σ is σ/√(2(n − 1)): within 4 of them.
            let tol = 4.0 * s[i] / (2.0 * (n as f64 - 1.0)).sqrt();
            assert!(
                (sd - s[i]).abs() < tol,
                "x = {}: samples {sd}, linear {}, tolerance {tol}",
                xs[i],
                s[i]
            );
        }
    }

    #[test]
    fn a_key_without_variance_is_held_at_its_estimate() {
        let cov = DMatrix::from_row_slice(2, 2, &[0.25, f64::NAN, f64::NAN, f64::NAN]);
        let jac = DMatrix::from_row_slice(1, 2, &[2.0, 100.0]);
        assert_eq!(propagate(&jac, &cov)[0].to_bits(), 1.0f64.to_bits());
        for d in draws(&[1.0, 5.0], &cov, 10, 1) {
            assert_eq!(d[1].to_bits(), 5.0f64.to_bits());
        }
    }

    #[test]
    fn bands_are_normal_quantiles_of_the_combined_sigma() {
        let r = row(vec![], 10.0, Some(3.0), 4.0, None);
        assert_eq!(r.sigma, Some(5.0));
        assert_eq!(r.lo68, Some(5.0));
        assert_eq!(r.hi95, Some(10.0 + Z95 * 5.0));
    }
}
