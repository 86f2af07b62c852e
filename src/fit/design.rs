//! The choice of new measurements (`djkr design`, issue 34): which K candidates, added to a
//! fit's data, minimise the expected covariance of the free keys (/work/shared/STATS.md, "Design
//! of experiments").
//!
//! - **The current information** `F0 = C_y⁻¹`: the inverse of the fit's covariance in the fit
//!   coordinates (`ln x` for a key in log space), as `fit.json` holds it. It is the `JᵀWJ` of
//!   the data the fit computed at its estimate, scaled as the fit scaled its covariance (by the
//!   reduced χ² where the data carry no σ), with no forward run spent to compute it again; the
//!   current σ are then the fit's own.
//! - **A candidate** `c` (a point of the grid of conditions one could measure): the model's
//!   sensitivity to each free key over that key's current uncertainty, the central secant
//!   `(m(y + σ_j e_j) − m(y − σ_j e_j)) / 2σ_j` in the fit coordinates (σ_j from the fit's
//!   covariance, the interval clipped to the key's bounds; [`secant_ends`], [`secants`]),
//!   divided by the new measurement's expected σ_c (absolute, or relative to the prediction; by
//!   default the data's median relative σ): `g_c`. Not the fit's Jacobian at the estimate
//!   (forward differences of a tiny step): where the model jumps (a pull-off that moves by one
//!   shaker period as a key changes) the local slope is a tooth of a sawtooth, and the design
//!   would pick the candidate whose tooth happens to be steepest; the secant is the change a
//!   new measurement can resolve over the keys' uncertainty, and a secant of a model linear in
//!   its keys is its slope, so the closed forms hold. Measuring it adds `g_c g_cᵀ` to `F`. Its
//!   *information* is `g_cᵀ F0⁻¹ g_c`, the prediction's variance from the parameters over the
//!   measurement's (one measurement there raises `ln det F` by `ln(1 + information)`).
//! - **The criteria**, each minimised: D-optimal `−ln det F`, A-optimal `trace F⁻¹`, or one key's
//!   variance `(F⁻¹)_jj`. The algorithm is the classic one: a greedy choice (each addition the
//!   best given those before), then exchange passes (Fedorov): each chosen measurement is
//!   replaced by the candidate that improves the criterion most, until a pass changes nothing
//!   (at most [`MAX_PASSES`]).
//! - **The comparison**: the same K spread uniformly over the candidates, the i-th (from 0) at
//!   candidate `⌊(i + ½) N / K⌋` of the N in the grid's order.
//! - **Expected covariance** `F⁻¹` after the additions, in the keys' units `D F⁻¹ D` (D the
//!   diagonal of `∂x/∂y`): linear, exact for a model linear in the keys.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use serde::Serialize;

use crate::error::Error;
use crate::sweep::grid::Axis;
use crate::words::{input, input_value};

use super::data::CondValue;
use super::free::Transform;
use super::predict::{
    at_estimate, forward_model, grid_data, refuse_free_axes, Cell, ConditionColumn, FitFolder,
};

use nalgebra::{DMatrix, DVector};

/// Most exchange passes after the greedy choice.
pub const MAX_PASSES: usize = 50;

/// What a design minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Criterion {
    /// `−ln det F` (D-optimal: the volume of the confidence ellipsoid).
    D,
    /// `trace F⁻¹` (A-optimal: the sum of the keys' variances).
    A,
    /// `(F⁻¹)_jj`: the variance of key `j`.
    Key(usize),
}

/// The criterion's value at information `f` (+∞ where `f` is singular).
pub(crate) fn criterion_value(f: &DMatrix<f64>, c: Criterion) -> f64 {
    let Some(ch) = f.clone().cholesky() else {
        return f64::INFINITY;
    };
    match c {
        Criterion::D => -2.0 * ch.l().diagonal().iter().map(|d| d.ln()).sum::<f64>(),
        Criterion::A => ch.inverse().trace(),
        Criterion::Key(j) => ch.inverse()[(j, j)],
    }
}

/// `f0` plus `g gᵀ` for each chosen candidate.
pub(crate) fn information(f0: &DMatrix<f64>, g: &[DVector<f64>], chosen: &[usize]) -> DMatrix<f64> {
    let mut f = f0.clone();
    for &c in chosen {
        f += &g[c] * g[c].transpose();
    }
    f
}

/// Choose `k` candidates (indices into `g`, sorted; an index more than once is a repeat) that
/// minimise `criterion` of `f0 + Σ g_c g_cᵀ`. Without `repeats`, each candidate at most once
/// (then `k` may not exceed the candidates). Ties go to the lower index, so the choice is
/// reproducible.
pub(crate) fn choose(
    f0: &DMatrix<f64>,
    g: &[DVector<f64>],
    k: usize,
    repeats: bool,
    criterion: Criterion,
) -> Vec<usize> {
    let allowed = |chosen: &[usize], c: usize| repeats || !chosen.contains(&c);
    let outer: Vec<DMatrix<f64>> = g.iter().map(|v| v * v.transpose()).collect();
    let mut chosen: Vec<usize> = Vec::with_capacity(k);
    let mut f = f0.clone();
    for _ in 0..k {
        let mut best: Option<(f64, usize)> = None;
        for (c, o) in outer.iter().enumerate() {
            if !allowed(&chosen, c) {
                continue;
            }
            let v = criterion_value(&(&f + o), criterion);
            if best.is_none_or(|(b, _)| v < b) {
                best = Some((v, c));
            }
        }
        match best {
            Some((_, c)) => {
                chosen.push(c);
                f += &outer[c];
            }
            None => break,
        }
    }
    // Exchange passes. The information without a slot's measurement is recomputed from `f0`
    // after each exchange, so that rounding does not accumulate.
    let mut current = criterion_value(&f, criterion);
    for _ in 0..MAX_PASSES {
        let mut changed = false;
        for slot in 0..chosen.len() {
            let mut others = chosen.clone();
            others.remove(slot);
            let without = information(f0, g, &others);
            let mut best: Option<(f64, usize)> = None;
            for (c, o) in outer.iter().enumerate() {
                if c == chosen[slot] || !allowed(&others, c) {
                    continue;
                }
                let v = criterion_value(&(&without + o), criterion);
                // A relative margin, so that rounding cannot swap back and forth.
                if v < current - 1e-12 * current.abs().max(1.0) && best.is_none_or(|(b, _)| v < b) {
                    best = Some((v, c));
                }
            }
            if let Some((v, c)) = best {
                chosen[slot] = c;
                current = v;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    chosen.sort_unstable();
    chosen
}

/// The interval of each key's fit coordinate over which its secant is taken: `y_j ± σ_j`,
/// clipped to the key's bounds (`tr`), as `(lower, upper)`.
pub(crate) fn secant_ends(tr: &[Transform], y: &[f64], sigma: &[f64]) -> Vec<(f64, f64)> {
    tr.iter()
        .zip(y.iter().zip(sigma))
        .map(|(t, (&y, &s))| {
            let lo = t.lo.map_or(y - s, |l| (y - s).max(l));
            let hi = t.hi.map_or(y + s, |h| (y + s).min(h));
            (lo, hi)
        })
        .collect()
}

/// The points of the fit coordinates at which the secants' model runs: for each key `j` in
/// turn, `y` with key `j` at the lower end of its interval (`ends`), then at the upper end.
pub(crate) fn secant_points(y: &[f64], ends: &[(f64, f64)]) -> Vec<Vec<f64>> {
    ends.iter()
        .enumerate()
        .flat_map(|(j, &(lo, hi))| {
            [lo, hi].map(|v| {
                let mut p = y.to_vec();
                p[j] = v;
                p
            })
        })
        .collect()
}

/// The secants `∂m/∂y` (rows the candidates, columns the keys) from the model's values at
/// [`secant_points`] (in their order): column `j` is `(m(upper) − m(lower)) / (upper − lower)`;
/// 0 for an interval of no width.
pub(crate) fn secants(values: &[Vec<f64>], ends: &[(f64, f64)]) -> DMatrix<f64> {
    let n = values.first().map_or(0, Vec::len);
    DMatrix::from_fn(n, ends.len(), |i, j| {
        let (lo, hi) = ends[j];
        if hi > lo {
            (values[2 * j + 1][i] - values[2 * j][i]) / (hi - lo)
        } else {
            0.0
        }
    })
}

/// Each candidate's sensitivities per unit of its measurement's σ, `g_c = (∂m/∂y)_c / σ_c`, from
/// the sensitivities `jac` (rows the candidates) and the σ `sigma`; a candidate whose σ is not
/// positive and finite, or whose sensitivities are not finite, tells nothing (zeros), and is
/// counted (the second value).
pub(crate) fn weighted(jac: &DMatrix<f64>, sigma: &[f64]) -> (Vec<DVector<f64>>, usize) {
    let k = jac.ncols();
    let mut silent = 0;
    let g = sigma
        .iter()
        .enumerate()
        .map(|(i, &s)| {
            if s > 0.0 && s.is_finite() && (0..k).all(|j| jac[(i, j)].is_finite()) {
                DVector::from_fn(k, |j, _| jac[(i, j)] / s)
            } else {
                silent += 1;
                DVector::zeros(k)
            }
        })
        .collect();
    (g, silent)
}

/// `k` measurements spread uniformly over `n` candidates: the i-th (from 0) at candidate
/// `⌊(i + ½) n / k⌋`, as counts per candidate (each candidate `k / n` times when `n` divides
/// `k`; for `k < n`, the middles of `k` equal runs of the candidates in order).
pub fn uniform(n: usize, k: usize) -> Vec<usize> {
    let mut counts = vec![0; n];
    if n == 0 {
        return counts;
    }
    for i in 0..k {
        let c = ((2 * i + 1) * n) / (2 * k);
        counts[c.min(n - 1)] += 1;
    }
    counts
}

/// Counts per candidate of a list of chosen indices.
fn counts(n: usize, chosen: &[usize]) -> Vec<usize> {
    let mut c = vec![0; n];
    for &i in chosen {
        c[i] += 1;
    }
    c
}

/// Indices with their repeats from counts.
fn indices(counts: &[usize]) -> Vec<usize> {
    counts
        .iter()
        .enumerate()
        .flat_map(|(i, &c)| std::iter::repeat_n(i, c))
        .collect()
}

/// The inverse of an information matrix (NaN where it is singular).
fn covariance(f: &DMatrix<f64>) -> DMatrix<f64> {
    match f.clone().cholesky() {
        Some(ch) => ch.inverse(),
        None => DMatrix::from_element(f.nrows(), f.ncols(), f64::NAN),
    }
}

/// A design's numbers in the fit coordinates ([`plan`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Per candidate, how many times the design measures it (summing to K).
    pub chosen: Vec<usize>,
    /// Per candidate, how many times K uniform measurements measure it.
    pub uniform: Vec<usize>,
    /// The covariance now, `F0⁻¹`.
    pub current: DMatrix<f64>,
    /// The covariance expected after the design's measurements.
    pub expected: DMatrix<f64>,
    /// The covariance expected after the uniform ones.
    pub uniform_cov: DMatrix<f64>,
    /// The criterion's value now, after the design and after the uniform measurements.
    pub criterion: [f64; 3],
    /// Each candidate's information `g_cᵀ F0⁻¹ g_c`.
    pub information: Vec<f64>,
}

/// The design of `k` new measurements over the candidates `g` (sensitivities per unit σ, in the
/// fit coordinates) given the current information `f0`, with the uniform spread beside it.
pub fn plan(
    f0: &DMatrix<f64>,
    g: &[DVector<f64>],
    k: usize,
    repeats: bool,
    criterion: Criterion,
) -> Plan {
    let n = g.len();
    let chosen = counts(n, &choose(f0, g, k, repeats, criterion));
    let uni = uniform(n, k);
    let f_design = information(f0, g, &indices(&chosen));
    let f_uniform = information(f0, g, &indices(&uni));
    let current = covariance(f0);
    let information = g
        .iter()
        .map(|v| (v.transpose() * &current * v)[(0, 0)])
        .collect();
    Plan {
        criterion: [
            criterion_value(f0, criterion),
            criterion_value(&f_design, criterion),
            criterion_value(&f_uniform, criterion),
        ],
        chosen,
        uniform: uni,
        current,
        expected: covariance(&f_design),
        uniform_cov: covariance(&f_uniform),
        information,
    }
}

/// Most measurements a design adds.
pub(crate) const MAX_ADD: usize = 10_000;

/// Most candidates (each costs 1 + 2 × free keys forward runs).
pub(crate) const MAX_CANDIDATES: usize = 10_000;

/// What a design minimises, as asked for.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Target {
    /// The determinant of the covariance (D-optimal).
    #[default]
    D,
    /// The sum of the variances in the fit coordinates (A-optimal).
    A,
    /// The variance of one free key (the key).
    Key(String),
}

impl Target {
    /// `D`, `A` or a key, as typed.
    pub fn parse(text: &str) -> Target {
        match text.trim() {
            "D" | "d" => Target::D,
            "A" | "a" => Target::A,
            k => Target::Key(k.to_string()),
        }
    }

    fn shown(&self) -> String {
        match self {
            Target::D => "D".into(),
            Target::A => "A".into(),
            Target::Key(k) => k.clone(),
        }
    }
}

/// The expected σ of a new measurement, typed: a fraction of the prediction at the candidate
/// (`Relative(0.02)` is 2 %) or a value in the observable's SI unit. A front end reads the text
/// `2%` or `0.05` (units welcome) with [`Sigma::parse`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sigma {
    /// A fraction of the prediction, above 0 and at most 10 (1000 %).
    Relative(f64),
    /// A value in the observable's SI unit, finite and above 0.
    Absolute(f64),
}

/// The largest relative σ of a new measurement (1000 %).
const MAX_RELATIVE: f64 = 10.0;

impl Sigma {
    /// `text` as the σ of a new measurement for `fit`: a percentage of the prediction (`2%`) or
    /// a value in the unit of the fit's observable (units allowed where it has one), refused as
    /// the input `sigma`.
    pub fn parse(text: &str, fit: &FitFolder) -> Result<Sigma, Error> {
        let t = text.trim();
        if let Some(pc) = t.strip_suffix('%') {
            return match pc.trim().parse::<f64>() {
                Ok(p) if p.is_finite() && p > 0.0 && p <= 100.0 * MAX_RELATIVE => {
                    Ok(Sigma::Relative(p / 100.0))
                }
                _ => Err(bad_relative(text)),
            };
        }
        match djkr_core::units::parse_quantity("sigma", t, fit.observable.dimension()) {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(Sigma::Absolute(v)),
            _ => Err(bad_absolute(text, fit)),
        }
    }
}

/// `«sigma=text»`: a relative σ out of its range.
fn bad_relative(text: &str) -> Error {
    Error::Invalid(format!(
        "{}: a relative sigma must be a percentage above 0 and at most 1000 % (e.g. 2%)",
        input_value("sigma", text)
    ))
}

/// `«sigma=text»`: an absolute σ that is no positive value of the observable.
fn bad_absolute(text: &str, fit: &FitFolder) -> Error {
    Error::Invalid(format!(
        "{}: must be a positive value in the unit of {} ({}, or with its units) or a \
         percentage of the prediction (e.g. 2%)",
        input_value("sigma", text),
        fit.observable.name(),
        fit.observable.unit()
    ))
}

/// What to design, typed (the fit itself is given beside it: [`crate::api::design`]).
#[derive(Debug, Clone)]
pub struct DesignRequest {
    /// The candidates' axes (the Cartesian grid, first key slowest).
    pub candidates: Vec<Axis>,
    /// Measurements to add (K).
    pub add: usize,
    /// The expected σ of a new measurement; `None`: the data's median relative σ.
    pub sigma: Option<Sigma>,
    /// The criterion.
    pub criterion: Target,
    /// Whether a candidate may be measured more than once.
    pub repeats: bool,
    /// Threads (0: one per core).
    pub jobs: usize,
}

impl DesignRequest {
    /// A request with the defaults: D-optimal, repeats allowed, the data's median relative σ.
    pub fn new(candidates: Vec<Axis>, add: usize) -> DesignRequest {
        DesignRequest {
            candidates,
            add,
            sigma: None,
            criterion: Target::D,
            repeats: true,
            jobs: 0,
        }
    }
}

/// One candidate of the report (`design.csv`'s row).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CandidateRow {
    /// The conditions, in the order of [`DesignReport::conditions`] (SI).
    pub conditions: Vec<Cell>,
    /// The model at the estimate (the observable's unit).
    pub value: f64,
    /// The expected σ of a measurement there.
    pub sigma_measurement: f64,
    /// The σ of the prediction there from the fit's covariance (linear propagation).
    pub sigma_prediction: f64,
    /// `(sigma_prediction / sigma_measurement)²`.
    pub information: f64,
    /// Times the design measures it.
    pub repeats: usize,
    /// Times K uniform measurements measure it.
    pub uniform_repeats: usize,
}

/// A chosen candidate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Chosen {
    /// Its conditions, `{key: value}` (SI).
    pub conditions: std::collections::BTreeMap<String, Cell>,
    /// Times to measure it.
    pub repeats: usize,
    /// Its row in `design.csv` (from 1, after the header).
    pub row: usize,
}

/// The criterion's value now, after the design and after uniform measurements (in the fit
/// coordinates: `−ln det F`, `trace F⁻¹` or `(F⁻¹)_jj`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CriterionValues {
    /// With the fit's data.
    pub current: f64,
    /// After the design's measurements.
    pub expected: f64,
    /// After K uniform measurements.
    pub uniform: f64,
}

/// What `design` reports (`design.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignReport {
    /// `D`, `A` or the key whose variance is minimised.
    pub criterion: String,
    /// Measurements added (K).
    pub add: usize,
    /// Whether repeats were allowed.
    pub repeats: bool,
    /// The observable (as named in sweep.csv).
    pub observable: String,
    /// Its SI unit.
    pub unit: String,
    /// The expected σ of a new measurement: `{"relative": r}` or `{"absolute": σ}` (the
    /// observable's unit).
    pub sigma_measurement: std::collections::BTreeMap<String, f64>,
    /// Where that σ came from: `sigma` (given) or `data` (the data's median relative σ).
    pub sigma_measurement_from: String,
    /// The free keys, in the fit's order.
    pub keys: Vec<String>,
    /// Their units.
    pub key_units: Vec<String>,
    /// The candidates' condition columns.
    pub conditions: Vec<ConditionColumn>,
    /// The candidates to measure, with how many times.
    pub chosen: Vec<Chosen>,
    /// σ of each key now (the fit's), in its unit.
    pub current_sigma: std::collections::BTreeMap<String, f64>,
    /// σ of each key expected after the design's measurements.
    pub expected_sigma: std::collections::BTreeMap<String, f64>,
    /// σ of each key expected after K measurements spread uniformly over the candidates.
    pub uniform_sigma: std::collections::BTreeMap<String, f64>,
    /// Correlations now (rows and columns in the order of `keys`).
    pub current_correlation: Vec<Vec<f64>>,
    /// Correlations expected after the design.
    pub expected_correlation: Vec<Vec<f64>>,
    /// Correlations expected after the uniform measurements.
    pub uniform_correlation: Vec<Vec<f64>>,
    /// The criterion's values.
    pub criterion_value: CriterionValues,
    /// Every candidate.
    pub candidates: Vec<CandidateRow>,
    /// Forward runs made.
    pub forward_runs: usize,
    /// What the numbers need said.
    pub notes: Vec<String>,
}

/// What [`check`] makes of a request and its fit.
struct Checked {
    criterion: Criterion,
    noise: Sigma,
    from_data: bool,
    points: usize,
}

/// The data's median relative σ (`sigma / |observed|` over the rows with both), if any.
fn median_relative(fit: &FitFolder) -> Option<f64> {
    let mut r: Vec<f64> = fit
        .data
        .rows
        .iter()
        .filter_map(|row| {
            let s = row.sigma?;
            (row.observed != 0.0 && row.observed.is_finite() && s.is_finite() && s > 0.0)
                .then(|| s / row.observed.abs())
        })
        .collect();
    if r.is_empty() {
        return None;
    }
    r.sort_by(f64::total_cmp);
    let m = r.len();
    Some(if m % 2 == 1 {
        r[m / 2]
    } else {
        0.5 * (r[m / 2 - 1] + r[m / 2])
    })
}

/// `«name=value»: m`.
fn bad(name: &str, value: &str, m: String) -> Error {
    Error::Invalid(format!("{}: {m}", input_value(name, value)))
}

/// Refuse what a request cannot be whatever the fit: K out of its range, no candidates. A front
/// end that reads the fit from a folder checks this first, so that these refusals come before
/// those of the folder.
pub fn check_request(req: &DesignRequest) -> Result<(), Error> {
    if req.add < 1 || req.add > MAX_ADD {
        return Err(bad(
            "add",
            &req.add.to_string(),
            format!("must be a whole number from 1 to {MAX_ADD} (new measurements to choose)"),
        ));
    }
    if req.candidates.is_empty() {
        return Err(Error::Invalid(format!(
            "no {} given: give the conditions one could measure as KEY=SPEC (e.g. \
             base.frequency=200:500:7 base.amplitude=5um:100um:20)",
            input("candidates")
        )));
    }
    Ok(())
}

/// [`check_request`], then what a design of `fit` refuses before its σ: the candidates (no key
/// the fit estimated, two points or more, at most [`MAX_CANDIDATES`]), K without repeats, the
/// criterion and the fit's covariance. Returns the number of candidates and the criterion.
fn checked_before_sigma(fit: &FitFolder, req: &DesignRequest) -> Result<(usize, Criterion), Error> {
    check_request(req)?;
    refuse_free_axes(fit, &req.candidates, &|a| input_value("candidates", a))?;
    let shown: Vec<String> = req.candidates.iter().map(Axis::shown).collect();
    let all = shown.join(" ");
    let points = crate::sweep::grid::Grid::new(req.candidates.clone(), false)
        .map_err(Error::Spec)?
        .points();
    if points < 2 {
        return Err(bad(
            "candidates",
            &all,
            "the candidates are one point: give a key two values or more (a list or a range) \
             to choose among"
                .into(),
        ));
    }
    if points > MAX_CANDIDATES {
        return Err(bad(
            "candidates",
            &all,
            format!(
                "{points} candidates: at most {MAX_CANDIDATES} (each costs {} forward runs)",
                1 + 2 * fit.free.len()
            ),
        ));
    }
    if !req.repeats && req.add > points {
        return Err(bad(
            "add",
            &req.add.to_string(),
            format!(
                "with {} at most the {points} candidates (each measured once); allow repeats or \
                 add candidates",
                input("no_repeats")
            ),
        ));
    }
    let criterion = match &req.criterion {
        Target::D => Criterion::D,
        Target::A => Criterion::A,
        Target::Key(k) => match fit.free.iter().position(|f| f.key.to_string() == *k) {
            Some(j) => Criterion::Key(j),
            None => {
                return Err(bad(
                    "criterion",
                    k,
                    format!(
                        "must be D, A or a free key of the fit ({})",
                        fit.free
                            .iter()
                            .map(|f| f.key.to_string())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ))
            }
        },
    };
    for (j, f) in fit.free.iter().enumerate() {
        if !fit.cov_y[(j, j)].is_finite() {
            return Err(Error::Invalid(format!(
                "{}: the fit gave {} no sigma (see its notes): a design needs the covariance of \
                 every free key; fit again with data that fix it, or with it fixed",
                input_value("fit", &fit.shown),
                f.key
            )));
        }
    }
    Ok((points, criterion))
}

/// Refuse what a design of `fit` refuses before its σ ([`check`] without the σ): a front end
/// that reads the σ as text ([`Sigma::parse`]) checks this first, so that the refusals come in
/// the order [`check`] gives them.
pub fn check_before_sigma(fit: &FitFolder, req: &DesignRequest) -> Result<(), Error> {
    checked_before_sigma(fit, req).map(|_| ())
}

/// Refuse what a design cannot do before a forward run: K, the candidates, the criterion, the
/// fit's covariance and the σ of the new measurements (each named with its value and what is
/// allowed, as `«name=value»`).
fn checked(fit: &FitFolder, req: &DesignRequest) -> Result<Checked, Error> {
    let (points, criterion) = checked_before_sigma(fit, req)?;
    let (noise, from_data) = match req.sigma {
        Some(s @ Sigma::Relative(r)) => {
            if !(r.is_finite() && r > 0.0 && r <= MAX_RELATIVE) {
                return Err(bad_relative(&format!("{}%", 100.0 * r)));
            }
            (s, false)
        }
        Some(s @ Sigma::Absolute(v)) => {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad_absolute(&v.to_string(), fit));
            }
            (s, false)
        }
        None => match median_relative(fit) {
            Some(r) => (Sigma::Relative(r), true),
            None => {
                return Err(Error::Invalid(format!(
                    "{}: the fit's data carry no sigma, so the noise of a new measurement is not \
                     known: give it with {} (e.g. 2% of the prediction, or a value in {})",
                    input_value("fit", &fit.shown),
                    input("sigma"),
                    fit.observable.unit()
                )))
            }
        },
    };
    Ok(Checked {
        criterion,
        noise,
        from_data,
        points,
    })
}

/// Refuse a request that [`design`] would refuse before its first forward run (K, the
/// candidates, the criterion, the fit's covariance, the σ), so that a front end can refuse it
/// before it claims an output folder.
pub fn check(fit: &FitFolder, req: &DesignRequest) -> Result<(), Error> {
    checked(fit, req).map(|_| ())
}

/// σ and correlations in the keys' units from a covariance in the fit coordinates (`dx` the
/// diagonal of ∂x/∂y).
fn in_units(cov: &DMatrix<f64>, dx: &[f64]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let k = dx.len();
    let sigma: Vec<f64> = (0..k).map(|a| dx[a] * cov[(a, a)].sqrt()).collect();
    // Symmetric to the bit (an inverse need not be), 1 on the diagonal.
    let corr = (0..k)
        .map(|a| {
            (0..k)
                .map(|b| {
                    if a == b {
                        1.0
                    } else {
                        0.5 * (cov[(a, b)] + cov[(b, a)]) / (cov[(a, a)] * cov[(b, b)]).sqrt()
                    }
                })
                .collect()
        })
        .collect();
    (sigma, corr)
}

/// Design K new measurements from `fit` ([`DesignRequest`]); `stop` abandons the runs (then
/// [`Error::Cancelled`]), `on_run` is called as each forward run ends.
pub fn design(
    fit: &FitFolder,
    req: &DesignRequest,
    stop: Option<&AtomicBool>,
    on_run: &mut dyn FnMut(),
) -> Result<DesignReport, Error> {
    let Checked {
        criterion,
        noise,
        from_data,
        points,
    } = checked(fit, req)?;
    // No ensemble: the candidates' model at the scenario's own phase.
    let model = forward_model(
        fit,
        grid_data(&req.candidates, fit.observable)?,
        None,
        req.jobs,
    )?;
    let data = model.data();
    let k = fit.free.len();
    // The sensitivities: each key's secant over ±σ in the fit coordinates (see the module
    // documentation), two runs per key and candidate at the fit's tolerances.
    let y_hat = fit.y_estimate();
    let sigma_y: Vec<f64> = (0..k).map(|j| fit.cov_y[(j, j)].sqrt()).collect();
    let ends = secant_ends(&fit.tr, &y_hat, &sigma_y);
    let at = at_estimate(
        fit,
        &model,
        false,
        &secant_points(&y_hat, &ends),
        stop,
        on_run,
    )?;
    let jac = secants(&at.extra, &ends);
    let mut notes = Vec::new();
    let sigma_m: Vec<f64> = at
        .values
        .iter()
        .map(|v| match noise {
            Sigma::Relative(r) => r * v.abs(),
            Sigma::Absolute(s) => s,
        })
        .collect();
    let (g, silent) = weighted(&jac, &sigma_m);
    if silent > 0 {
        notes.push(format!(
            "{silent} of {points} candidates predict 0 (or a number that is not finite), where a \
             relative sigma gives no noise: they are counted as telling nothing and not chosen; \
             give an absolute --sigma to weigh them"
        ));
    }
    let f0 = {
        let c = &fit.cov_y;
        let sym = DMatrix::from_fn(k, k, |a, b| 0.5 * (c[(a, b)] + c[(b, a)]));
        match sym.cholesky() {
            Some(ch) => ch.inverse(),
            None => {
                return Err(Error::Invalid(format!(
                    "{}: the fit's covariance is not positive definite, so its information is \
                     not known",
                    input_value("fit", &fit.shown)
                )))
            }
        }
    };
    let p = plan(&f0, &g, req.add, req.repeats, criterion);
    if !fit.converged {
        notes.push("the fit did not converge: its estimate is the best point it met".into());
    }
    let dx: Vec<f64> = fit
        .tr
        .iter()
        .zip(&y_hat)
        .map(|(t, &y)| t.dx_dy(y))
        .collect();
    let keys: Vec<String> = fit.free.iter().map(|f| f.key.to_string()).collect();
    let (cur_s, cur_c) = in_units(&fit.cov_y, &dx);
    let (exp_s, exp_c) = in_units(&p.expected, &dx);
    let (uni_s, uni_c) = in_units(&p.uniform_cov, &dx);
    let map = |s: &[f64]| -> std::collections::BTreeMap<String, f64> {
        keys.iter().cloned().zip(s.iter().copied()).collect()
    };
    let cells = |i: usize| -> Vec<Cell> {
        data.rows[i]
            .conditions
            .iter()
            .map(|c| match c {
                CondValue::Num(x) => Cell::Num(*x),
                CondValue::Text(t) => Cell::Text(t.clone()),
            })
            .collect()
    };
    let conditions: Vec<ConditionColumn> = data
        .conditions
        .iter()
        .map(|c| ConditionColumn {
            key: c.key.to_string(),
            unit: c.unit,
        })
        .collect();
    let candidates: Vec<CandidateRow> = (0..points)
        .map(|i| CandidateRow {
            conditions: cells(i),
            value: at.values[i],
            sigma_measurement: sigma_m[i],
            sigma_prediction: p.information[i].sqrt() * sigma_m[i],
            information: p.information[i],
            repeats: p.chosen[i],
            uniform_repeats: p.uniform[i],
        })
        .collect();
    let chosen = (0..points)
        .filter(|&i| p.chosen[i] > 0)
        .map(|i| Chosen {
            conditions: conditions
                .iter()
                .map(|c| c.key.clone())
                .zip(cells(i))
                .collect(),
            repeats: p.chosen[i],
            row: i + 1,
        })
        .collect();
    let mut sigma_measurement = std::collections::BTreeMap::new();
    match noise {
        Sigma::Relative(r) => sigma_measurement.insert("relative".to_string(), r),
        Sigma::Absolute(s) => sigma_measurement.insert("absolute".to_string(), s),
    };
    let mut report = DesignReport {
        criterion: req.criterion.shown(),
        add: req.add,
        repeats: req.repeats,
        observable: fit.observable.name().to_string(),
        unit: fit.observable.unit().to_string(),
        sigma_measurement,
        sigma_measurement_from: if from_data { "data" } else { "sigma" }.to_string(),
        keys: keys.clone(),
        key_units: fit.free.iter().map(|f| f.unit.to_string()).collect(),
        conditions,
        chosen,
        current_sigma: map(&cur_s),
        expected_sigma: map(&exp_s),
        uniform_sigma: map(&uni_s),
        current_correlation: cur_c,
        expected_correlation: exp_c,
        uniform_correlation: uni_c,
        criterion_value: CriterionValues {
            current: p.criterion[0],
            expected: p.criterion[1],
            uniform: p.criterion[2],
        },
        candidates,
        forward_runs: at.forward_runs,
        notes,
    };
    // Said whether or not the files are written, so that the report is the same either way.
    if design_figure(&report).is_none() {
        report.notes.push(
            "no figure: no numeric condition takes two values among the candidates".to_string(),
        );
    }
    Ok(report)
}

/// The files `design` writes.
pub const FILES: [&str; 4] = ["design.csv", "design.json", "design.png", "design.svg"];

/// `design.csv`: one row per candidate: its conditions, `value`, `sigma_measurement`,
/// `sigma_prediction` (the observable's unit), `information`, `repeats` and `uniform_repeats`,
/// each headed `name [unit]` (SI).
fn design_csv(r: &DesignReport) -> String {
    use crate::output::table::format_f64;
    let mut out = csv_header(r).join(",");
    out.push('\n');
    for row in &r.candidates {
        let mut cells: Vec<String> = row
            .conditions
            .iter()
            .map(super::predict::cell_csv)
            .collect();
        cells.push(format_f64(row.value));
        cells.push(format_f64(row.sigma_measurement));
        cells.push(format_f64(row.sigma_prediction));
        cells.push(format_f64(row.information));
        cells.push(row.repeats.to_string());
        cells.push(row.uniform_repeats.to_string());
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// The header of `design.csv`: the conditions, then `value`, `sigma_measurement`,
/// `sigma_prediction`, `information`, `repeats`, `uniform_repeats`, each `name [unit]`.
fn csv_header(r: &DesignReport) -> Vec<String> {
    let u = &r.unit;
    let mut head: Vec<String> = r
        .conditions
        .iter()
        .map(|c| super::residuals::column_name(&c.key, c.unit))
        .collect();
    head.extend([
        format!("value [{u}]"),
        format!("sigma_measurement [{u}]"),
        format!("sigma_prediction [{u}]"),
        "information [1]".into(),
        "repeats [1]".into(),
        "uniform_repeats [1]".into(),
    ]);
    head
}

impl DesignReport {
    /// The columns of `design.csv` (its header's names, `name [unit]`): a condition with a unit
    /// as numbers (SI), one without as text, `value`, the σ and `information` as numbers,
    /// `repeats` and `uniform_repeats` as whole numbers.
    pub fn columns(&self) -> Vec<(String, super::residuals::Column)> {
        use super::residuals::Column;
        let rows = &self.candidates;
        let num = |f: &dyn Fn(&CandidateRow) -> f64| Column::Num(rows.iter().map(f).collect());
        let whole = |f: &dyn Fn(&CandidateRow) -> usize| {
            Column::Whole(rows.iter().map(|r| f(r) as u64).collect())
        };
        let mut columns: Vec<Column> = self
            .conditions
            .iter()
            .enumerate()
            .map(|(j, c)| match c.unit {
                Some(_) => num(&|r| match &r.conditions[j] {
                    Cell::Num(x) => *x,
                    Cell::Text(_) => f64::NAN,
                }),
                None => Column::Text(
                    rows.iter()
                        .map(|r| match &r.conditions[j] {
                            Cell::Text(t) => t.clone(),
                            Cell::Num(x) => x.to_string(),
                        })
                        .collect(),
                ),
            })
            .collect();
        columns.extend([
            num(&|r| r.value),
            num(&|r| r.sigma_measurement),
            num(&|r| r.sigma_prediction),
            num(&|r| r.information),
            whole(&|r| r.repeats),
            whole(&|r| r.uniform_repeats),
        ]);
        csv_header(self).into_iter().zip(columns).collect()
    }
}

/// Classes of information for the figure's colours: four equal steps of `log10` between the
/// smallest positive and the largest information (one class when they are within a factor 2).
fn classes(info: &[f64]) -> (Vec<Option<usize>>, Vec<(f64, f64)>) {
    let pos: Vec<f64> = info
        .iter()
        .copied()
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    let (Some(lo), Some(hi)) = (
        pos.iter().copied().reduce(f64::min),
        pos.iter().copied().reduce(f64::max),
    ) else {
        return (vec![None; info.len()], Vec::new());
    };
    let m = if hi < 2.0 * lo { 1 } else { 4 };
    let (a, b) = (lo.log10(), hi.log10());
    let edges: Vec<f64> = (0..=m)
        .map(|i| 10f64.powf(a + (b - a) * i as f64 / m as f64))
        .collect();
    let class = info
        .iter()
        .map(|&v| {
            (v > 0.0 && v.is_finite()).then(|| {
                // m = 1 also where all are equal (b − a = 0).
                let t = if m == 1 {
                    0.0
                } else {
                    (v.log10() - a) / (b - a) * m as f64
                };
                (t.floor().max(0.0) as usize).min(m - 1)
            })
        })
        .collect();
    let bounds = (0..m).map(|i| (edges[i], edges[i + 1])).collect();
    (class, bounds)
}

/// The figure of a design: the candidates over their first condition that varies (numeric) and,
/// where a second varies too, that one (else the information itself, log scale), each a marker
/// coloured by its class of information; the chosen ones ringed. `None` without a numeric
/// condition that takes two values.
fn design_figure(r: &DesignReport) -> Option<crate::plot::Figure> {
    use crate::plot::{axis_label, Figure, Series, Style};
    use djkr_core::text::format_sig;
    // A condition spread over more than a decade (a log-spaced grid) on a log axis.
    let wide = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        lo > 0.0 && hi > 20.0 * lo
    };
    let num = |c: &Cell| match c {
        Cell::Num(x) => Some(*x),
        Cell::Text(_) => None,
    };
    let varying: Vec<usize> = (0..r.conditions.len())
        .filter(|&j| {
            r.conditions[j].unit.is_some() && {
                let first = r.candidates.first().and_then(|c| num(&c.conditions[j]));
                r.candidates.iter().any(|c| num(&c.conditions[j]) != first)
            }
        })
        .collect();
    let xj = *varying.first()?;
    let yj = varying.get(1).copied();
    let xs: Vec<f64> = r
        .candidates
        .iter()
        .map(|c| num(&c.conditions[xj]).unwrap_or(f64::NAN))
        .collect();
    let xkey = &r.conditions[xj];
    let (fx, xlabel) = axis_label(&xkey.key, xkey.unit.unwrap_or(""), &xs);
    let (ys, fy, ylabel, ylog) = match yj {
        Some(j) => {
            let ys: Vec<f64> = r
                .candidates
                .iter()
                .map(|c| num(&c.conditions[j]).unwrap_or(f64::NAN))
                .collect();
            let key = &r.conditions[j];
            let (f, label) = axis_label(&key.key, key.unit.unwrap_or(""), &ys);
            (ys, f, label, false)
        }
        None => (
            r.candidates.iter().map(|c| c.information).collect(),
            1.0,
            "information of one measurement (1)".to_string(),
            true,
        ),
    };
    let info: Vec<f64> = r.candidates.iter().map(|c| c.information).collect();
    let (class, bounds) = classes(&info);
    let total: usize = r.candidates.iter().map(|c| c.repeats).sum();
    let title = match r.criterion.as_str() {
        "D" | "A" => format!("{total} new measurements ({}-optimal)", r.criterion),
        key => format!("{total} new measurements (least variance of {key})"),
    };
    let mut fig = Figure::new(
        format!("{title}: the candidates by their information"),
        xlabel,
        ylabel,
    )
    .with_log(wide(&xs), ylog || wide(&ys));
    let idx_where = |f: &dyn Fn(usize) -> bool| -> (Vec<f64>, Vec<f64>) {
        (0..r.candidates.len())
            .filter(|&i| f(i))
            .map(|i| (xs[i] * fx, ys[i] * fy))
            .unzip()
    };
    let none: Vec<usize> = (0..info.len()).filter(|&i| class[i].is_none()).collect();
    if !none.is_empty() {
        let (x, y) = idx_where(&|i| class[i].is_none());
        fig = fig.with_series(
            Series::new("information 0", x, y, Style::Markers).with_color(crate::plot::GREY),
        );
    }
    for (c, (lo, hi)) in bounds.iter().enumerate() {
        let (x, y) = idx_where(&|i| class[i] == Some(c));
        if x.is_empty() {
            continue;
        }
        let label = format!("information {}–{}", format_sig(*lo, 2), format_sig(*hi, 2));
        fig = fig.with_series(Series::new(label, x, y, Style::Markers).with_color(c));
    }
    let (x, y) = idx_where(&|i| r.candidates[i].repeats > 0);
    fig = fig.with_series(
        Series::new("chosen (repeats in design.csv)", x, y, Style::Rings)
            .with_color(crate::plot::GREY),
    );
    Some(fig)
}

/// Write `design.csv`, `design.json` and the figure (`design.png`, `design.svg`) into `out`,
/// each atomically; the JSON text is returned (`--json` prints it). Without a numeric condition
/// that varies no figure is drawn (the report's notes say so).
pub fn write(r: &DesignReport, out: &Path) -> Result<String, Error> {
    let fig = design_figure(r);
    let json = serde_json::to_string_pretty(r).map_err(|e| Error::NonFinite(e.to_string()))?;
    let put = |name: &str, bytes: &[u8]| -> Result<(), Error> {
        crate::output::write_atomic(&out.join(name), bytes).map_err(|e| Error::Output {
            input: None,
            context: Some(name.to_string()),
            error: e,
        })
    };
    put("design.csv", design_csv(r).as_bytes())?;
    put("design.json", format!("{json}\n").as_bytes())?;
    if let Some(fig) = fig {
        crate::plot::render(&fig, &out.join("design"))
            .map_err(|e| Error::Invalid(format!("design.png/design.svg: {e}")))?;
    }
    Ok(json)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight line y = a + b x on [0, 1] with equal σ, candidates at 0, 0.1, …, 1: the
    /// D-optimal design puts half the points at each end (the classic result, STATS.md), and so
    /// does the one for the slope's variance (1 / Σ (x − x̄)², largest spread at the ends).
    fn line() -> Vec<DVector<f64>> {
        (0..=10)
            .map(|i| DVector::from_vec(vec![1.0, i as f64 / 10.0]))
            .collect()
    }

    #[test]
    fn d_optimal_for_a_line_is_half_at_each_end() {
        let f0 = DMatrix::identity(2, 2) * 1e-9;
        for k in [2, 4, 6, 10] {
            let c = choose(&f0, &line(), k, true, Criterion::D);
            let at0 = c.iter().filter(|&&i| i == 0).count();
            let at1 = c.iter().filter(|&&i| i == 10).count();
            assert_eq!((at0, at1), (k / 2, k / 2), "K = {k}: {c:?}");
        }
    }

    #[test]
    fn the_slopes_variance_is_least_with_half_at_each_end() {
        let f0 = DMatrix::identity(2, 2) * 1e-9;
        let c = choose(&f0, &line(), 6, true, Criterion::Key(1));
        assert_eq!(c, vec![0, 0, 0, 10, 10, 10]);
        // Its expected variance: 1 / Σ (x − x̄)² = 1 / (6 · 0.25), with the prior's 1e-9
        // negligible.
        let f = information(&f0, &line(), &c);
        let v = criterion_value(&f, Criterion::Key(1));
        assert!((v - 1.0 / 1.5).abs() < 1e-8, "{v}");
    }

    #[test]
    fn without_repeats_each_candidate_once_and_the_ends_first() {
        let f0 = DMatrix::identity(2, 2) * 1e-9;
        let c = choose(&f0, &line(), 4, false, Criterion::D);
        assert_eq!(c, vec![0, 1, 9, 10]);
    }

    #[test]
    fn existing_data_move_the_choice() {
        // Data already pin the intercept at x = 0 (100 measurements there): the slope needs
        // only the far end.
        let g = line();
        let f0 = information(&(DMatrix::identity(2, 2) * 1e-9), &g, &[0; 100]);
        let c = choose(&f0, &g, 3, true, Criterion::D);
        assert_eq!(c, vec![10, 10, 10]);
    }
}

/// The straight line, whose optimal designs and covariances are known in closed form.
#[cfg(test)]
#[path = "design_tests.rs"]
mod closed_form_tests;
