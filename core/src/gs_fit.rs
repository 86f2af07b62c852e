//! Gent–Schultz constants (w0, v0, n) from a quasi-static unloading record (Sec. 3).
//!
//! # Method
//!
//! 1. Input: rows (t, a, F) of time (s), contact radius (m) and contact force (N, compressive
//!    positive), e.g. from [`parse_csv`]; the material gives K and R.
//! 2. Work of adhesion at every row from eq. (28), w = (F_H − F)²/(6π R F_H), F_H = K a³/R
//!    ([`jkr::work_of_adhesion_from_force`]).
//! 3. Crack speed v = −ȧ by local polynomial regression (Savitzky–Golay-like, for any spacing):
//!    at row i, a least-squares polynomial of degree 1 or 3 (`degree`) in t − t_i through the
//!    2h + 1 rows i − h … i + h (h = `half_window`); its linear coefficient is ȧ(t_i). A straight
//!    line has a truncation error ≈ (a⃛/6)(Σk⁴/Σk²)Δt², which is large here: a peel that starts
//!    from rest accelerates as ȧ ∝ t^(1/n) and ends in a runaway, and on the synthetic records of
//!    `tests/it/gent_schultz_fitting.rs` it biases n by ~1% at 250 Hz. A cubic removes that term (error
//!    O(Δt⁴ a⁽⁵⁾)) at the price of ~2–3× more noise for the same window; it is the default.
//!    The slope's noise gain √((XᵀX)⁻¹)₁₁/T (T the window's half span) gives σ_v. Rows without a
//!    full window (the first and last h) get no speed.
//! 4. Noise levels σ_a and σ_F (stationary white noise assumed) are given in the options or
//!    estimated as the square root of the median, over all windows, of the residual variance of
//!    the local polynomials through a(t) and F(t). The median keeps windows where the record
//!    curves fast (the end of the peel) from inflating the estimate. Each row then has a speed
//!    error σ_v and a work-of-adhesion error σ_w from first-order propagation of σ_a
//!    and σ_F through eq. (28): with D = F_H − F,
//!    ∂w/∂F = −2D/(6πR F_H), ∂w/∂a = 3D(F_H + F)/(6πR F_H a). The latter matters: w is
//!    very sensitive to F where F_H ∝ a³ is small, so the errors are strongly heteroscedastic.
//! 5. Keep the peeling rows: v > `min_speed` and v > `min_speed_over_noise` · σ_v (rows whose
//!    speed is not resolved above the noise are dropped).
//! 6. Fit w = w0 (1 + (v/v0)^n) by weighted least squares with effective variances
//!    s_j² = σ_w,j² + (∂w/∂v)_j² σ_v,j² (the regressor's noise enters to first order through the
//!    model's slope, evaluated at the previous iterate; 6 iterations, the first without it), by
//!    variable projection: for fixed n the model w = A + B vⁿ is linear in (A, B), solved in closed
//!    form; the weighted residual χ²(n) is minimised over n ∈ [n_min, n_max] (log scan, then
//!    Brent). Then w0 = A and v0 = (A/B)^(1/n).
//! 7. Uncertainties: Gauss–Newton covariance (Jᵀ W J)⁻¹ · χ²/(N − 3), W = diag(1/s_j²), J the
//!    Jacobian in (w0, ln v0, n) at the optimum (columns scaled to unit norm before the inverse,
//!    nalgebra), mapped to (w0, v0, n) by σ_v0 = v0 σ_ln v0. At the optimum this equals the
//!    covariance propagated from (A, B, n). The χ²/(N − 3) factor makes the errors follow the
//!    actual scatter if the noise levels were misjudged; it is reported (≈ 1 when they are right).
//!
//! Calibration on synthetic records (`tests/it/gent_schultz_fitting.rs`, `gs_fit_seeds`, 20 noise seeds, 250 Hz,
//! cubic over 21 rows): the pulls (fit − truth)/σ have means +0.1 … +0.7 and standard deviations
//! 0.5 … 0.7, so the reported errors are conservative by about 1.5–2×. Not investigated further;
//! the overlapping windows make neighbouring speed errors correlated, which the independent-error
//! covariance does not model. Noise in v that is large against the slowest speeds kept biases
//! the fit (errors-in-variables beyond first order): keep `min_speed_over_noise` ≥ 3.

use crate::adhesion::GentSchultz;
use crate::error::{non_negative, positive, ParamError};
use crate::jkr;
use crate::material::Material;
use crate::numerics::brent_minimize;
use crate::units::Dimension;
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};
use serde::Serialize;

/// One row of an unloading record (SI).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct UnloadingRow {
    /// Time (s).
    pub t: f64,
    /// Contact radius (m).
    pub a: f64,
    /// Contact force (N, compressive positive).
    pub force: f64,
}

/// Parse a CSV text of rows (t, a, F). The first non-comment line must be a header. If it names
/// the columns (`t`/`time`, `a`/`radius`/`contact_radius`/`contact`, `F`/`force`/`load`, any
/// case) they may come in any order among other columns, which are ignored, so a run's own
/// `timeseries.csv` is a record. A unit in the header is honoured and converted to SI: in
/// brackets or parentheses (`t [ms]`, `a (um)`, the style of djkr's CSV files), or as an
/// underscore suffix that is a unit of the column (`t_s`, `a_mm`, `F_mN`; `a_dot` is not `a`).
/// Without units the values are SI. A header naming none of the columns means the order
/// t (s), a (m), F (N). Separators: `,` `;` tab or spaces; `#` starts a comment. Errors name
/// `source` and the line.
pub fn parse_csv(text: &str, source: &str) -> Result<Vec<UnloadingRow>, ParamError> {
    // Split on `,` `;` or tab when the line has one (so a header like "t [s], a [m]" keeps its
    // units with its names), otherwise on whitespace.
    let split = |line: &str| -> Vec<String> {
        let parts: Vec<&str> = if line.contains([',', ';', '\t']) {
            line.split([',', ';', '\t']).collect()
        } else {
            line.split_whitespace().collect()
        };
        parts
            .into_iter()
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::to_string)
            .collect()
    };
    let mut columns: Option<[RecordColumn; 3]> = None;
    let mut rows = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let where_ = || format!("{source}: line {}", i + 1);
        let cols = split(line);
        let Some(idx) = &columns else {
            let nums: Vec<Option<f64>> = cols.iter().map(|c| c.parse().ok()).collect();
            if nums.iter().all(Option::is_some) {
                return Err(ParamError::new(
                    where_(),
                    crate::text::unquoted_line(line),
                    "expected a header line naming the columns t, a, F before the data",
                ));
            }
            columns = Some(
                header_columns(&cols)
                    .map_err(|m| ParamError::new(where_(), crate::text::unquoted_line(line), m))?,
            );
            continue;
        };
        let value = |c: &RecordColumn| -> Option<f64> {
            let x: f64 = cols.get(c.index)?.parse().ok()?;
            Some(x * c.to_si).filter(|v| v.is_finite())
        };
        match (value(&idx[0]), value(&idx[1]), value(&idx[2])) {
            (Some(t), Some(a), Some(force)) => rows.push(UnloadingRow { t, a, force }),
            _ => {
                return Err(ParamError::new(
                    where_(),
                    crate::text::unquoted_line(line),
                    "expected finite numbers in the columns t, a and F",
                ))
            }
        }
    }
    Ok(rows)
}

/// Where a record's quantity is, and the factor to SI of its unit.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RecordColumn {
    index: usize,
    to_si: f64,
}

/// Name and unit of a header cell: `name [unit]`, `name (unit)`, or the bare name.
fn name_and_unit(cell: &str) -> (String, Option<String>) {
    let c = cell.trim().trim_matches('"').trim();
    match c.find(['[', '(']) {
        Some(open) => {
            let unit = c[open + 1..].trim_end_matches([']', ')']).trim();
            (
                c[..open].trim().to_ascii_lowercase(),
                Some(unit.to_string()),
            )
        }
        None => (c.to_ascii_lowercase(), None),
    }
}

/// The columns of (t, a, F) from a header with units (see [`parse_csv`]). A header that names
/// none of them gives t, a, F in that order, SI; one that names only some is an error, as is a
/// unit that is not one of the quantity's.
fn header_columns(cells: &[String]) -> Result<[RecordColumn; 3], String> {
    const QUANTITIES: [(&str, &[&str], Dimension); 3] = [
        ("t", &["t", "time"], Dimension::Time),
        (
            "a",
            &["a", "radius", "contact_radius", "contact"],
            Dimension::Length,
        ),
        ("F", &["f", "force", "load"], Dimension::Force),
    ];
    let factor = |dim: Dimension, unit: &str| {
        dim.units()
            .iter()
            .find(|(u, _)| *u == unit)
            .map(|(_, f)| *f)
    };
    let mut found = [None; 3];
    for (q, (label, names, dim)) in QUANTITIES.iter().enumerate() {
        for (index, cell) in cells.iter().enumerate() {
            let (name, unit) = name_and_unit(cell);
            let unit = match unit {
                Some(u) if names.contains(&name.as_str()) => u,
                Some(_) => continue,
                None if names.contains(&name.as_str()) => dim.si().to_string(),
                None => match (cell.rsplit_once('_'), name.rsplit_once('_')) {
                    (Some((_, u)), Some((head, _)))
                        if names.contains(&head) && factor(*dim, u).is_some() =>
                    {
                        u.to_string()
                    }
                    _ => continue,
                },
            };
            let to_si = factor(*dim, &unit).ok_or_else(|| {
                let allowed: Vec<&str> = dim.units().iter().map(|(u, _)| *u).collect();
                format!(
                    "column '{}': unknown unit '{}' for {label}: expected one of {}",
                    crate::text::excerpt(cell),
                    crate::text::excerpt(&unit),
                    allowed.join(", ")
                )
            })?;
            found[q] = Some(RecordColumn { index, to_si });
            break;
        }
    }
    match found {
        [Some(t), Some(a), Some(f)] => Ok([t, a, f]),
        [None, None, None] => Ok([0, 1, 2].map(|index| RecordColumn { index, to_si: 1.0 })),
        _ => {
            let missing: Vec<&str> = QUANTITIES
                .iter()
                .zip(found)
                .filter(|(_, f)| f.is_none())
                .map(|((label, _, _), _)| *label)
                .collect();
            Err(format!(
                "the header names some of the columns t, a, F but not {}",
                missing.join(", ")
            ))
        }
    }
}

/// The rows of a record to fit: the last unbroken stretch with a > 0, as `start..end`. A run's
/// `timeseries.csv` goes on after pull-off with a = 0 (and may start out of contact); those rows
/// are no unloading record. `None` when no row is in contact.
pub fn contact_span(rows: &[UnloadingRow]) -> Option<std::ops::Range<usize>> {
    let end = rows.iter().rposition(|r| r.a > 0.0)? + 1;
    let start = rows[..end]
        .iter()
        .rposition(|r| r.a <= 0.0 || r.a.is_nan())
        .map_or(0, |i| i + 1);
    Some(start..end)
}

/// Options of the fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GsFitOptions {
    /// Half width h of the local regression window (rows); ≥ 1.
    pub half_window: usize,
    /// Degree of the local polynomial for ȧ: 1 (straight line, truncation O(Δt² ä⃛)) or 3
    /// (cubic, truncation O(Δt⁴ a⁽⁵⁾), about 2–3× more noise for the same window).
    pub degree: usize,
    /// Smallest peeling speed kept (m/s, ≥ 0).
    pub min_speed: f64,
    /// Keep only rows with v > this × σ_v (the speed's standard error); ≥ 0.
    pub min_speed_over_noise: f64,
    /// Smallest exponent n searched (> 0).
    pub n_min: f64,
    /// Largest exponent n searched (> n_min).
    pub n_max: f64,
    /// Standard deviation of the noise on a (m, ≥ 0); `None`: estimated from the record.
    pub noise_a: Option<f64>,
    /// Standard deviation of the noise on F (N, ≥ 0); `None`: estimated from the record.
    pub noise_force: Option<f64>,
}

impl Default for GsFitOptions {
    fn default() -> Self {
        Self {
            half_window: 10,
            degree: 3,
            min_speed: 0.0,
            min_speed_over_noise: 3.0,
            n_min: 0.02,
            n_max: 3.0,
            noise_a: None,
            noise_force: None,
        }
    }
}

impl GsFitOptions {
    /// Check the options; errors name the field.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.half_window < 1 {
            return Err(ParamError::new(
                "half_window",
                self.half_window,
                "must be >= 1",
            ));
        }
        if !(self.degree == 1 || self.degree == 3) {
            return Err(ParamError::new("degree", self.degree, "must be 1 or 3"));
        }
        if 2 * self.half_window + 1 < self.degree + 3 {
            return Err(ParamError::new(
                "half_window",
                self.half_window,
                format!(
                    "must leave 2 rows of residual for degree {}: >= {}",
                    self.degree,
                    (self.degree + 2) / 2
                ),
            ));
        }
        non_negative("min_speed", self.min_speed, "m/s")?;
        non_negative("min_speed_over_noise", self.min_speed_over_noise, "")?;
        positive("n_min", self.n_min, "")?;
        if !(self.n_max.is_finite() && self.n_max > self.n_min) {
            return Err(ParamError::new(
                "n_max",
                self.n_max,
                format!("must be finite and > n_min = {}", self.n_min),
            ));
        }
        if let Some(x) = self.noise_a {
            non_negative("noise_a", x, "m")?;
        }
        if let Some(x) = self.noise_force {
            non_negative("noise_force", x, "N")?;
        }
        Ok(())
    }
}

/// A row kept for the fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PeelingPoint {
    /// Row index in the record.
    pub row: usize,
    /// Time (s).
    pub t: f64,
    /// Contact radius (m).
    pub a: f64,
    /// Crack speed v = −ȧ (m/s, > 0).
    pub speed: f64,
    /// Standard error of the speed, σ_a × the local fit's slope gain (m/s).
    pub speed_error: f64,
    /// Work of adhesion from eq. (28) (J/m²).
    pub w: f64,
    /// Standard error of w from the noise on a and F (J/m²).
    pub w_error: f64,
}

/// Local polynomial fit at one row.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LocalFit {
    /// Slope of a(t) at the row (m/s).
    pub slope: f64,
    /// Factor g such that the slope's standard error is σ_a · g (1/s): √((XᵀX)⁻¹)₁₁ / T.
    pub slope_gain: f64,
    /// Residual variance of a about its local polynomial (m²).
    pub var_a: f64,
    /// Residual variance of F about its local polynomial (N²).
    pub var_force: f64,
}

/// Least-squares polynomial of degree `deg` (1 or 3) through (τ, y), τ scaled to [−1, 1]:
/// coefficient c1 (slope in τ), (XᵀX)⁻¹₁₁ and the residual variance. `None` if singular.
fn local_poly(taus: &[f64], ys: &[f64], deg: usize) -> Option<(f64, f64, f64)> {
    let p = deg + 1;
    let mut xtx = Matrix4::<f64>::zeros();
    let mut xty = Vector4::<f64>::zeros();
    for (&tau, &y) in taus.iter().zip(ys) {
        let mut pw = [1.0; 4];
        for k in 1..p {
            pw[k] = pw[k - 1] * tau;
        }
        for r in 0..p {
            xty[r] += pw[r] * y;
            for c in 0..p {
                xtx[(r, c)] += pw[r] * pw[c];
            }
        }
    }
    for r in p..4 {
        xtx[(r, r)] = 1.0;
    }
    let inv = xtx.try_inverse()?;
    let coef = inv * xty;
    let ssr: f64 = taus
        .iter()
        .zip(ys)
        .map(|(&tau, &y)| {
            let mut fit = 0.0;
            let mut pw = 1.0;
            for k in 0..p {
                fit += coef[k] * pw;
                pw *= tau;
            }
            (y - fit).powi(2)
        })
        .sum();
    let dof = (taus.len() as f64 - p as f64).max(1.0);
    Some((coef[1], inv[(1, 1)], ssr / dof))
}

/// Local polynomial regressions (degree `degree`, 1 or 3) of a(t) and F(t) over the 2h + 1 rows
/// around every row with a full window, centred on the row; `None` at the first and last
/// `half_window` rows or for a window too short for the degree.
pub fn local_fits(
    rows: &[UnloadingRow],
    half_window: usize,
    degree: usize,
) -> Vec<Option<LocalFit>> {
    let h = half_window;
    let deg = if degree >= 3 { 3 } else { 1 };
    let mut taus = Vec::with_capacity(2 * h + 1);
    let mut a_s = Vec::with_capacity(2 * h + 1);
    let mut f_s = Vec::with_capacity(2 * h + 1);
    (0..rows.len())
        .map(|i| {
            if i < h || i + h >= rows.len() || 2 * h + 1 < deg + 2 {
                return None;
            }
            let win = &rows[i - h..=i + h];
            let t_c = rows[i].t;
            let span = (win[2 * h].t - t_c).max(t_c - win[0].t);
            if span <= 0.0 {
                return None;
            }
            taus.clear();
            a_s.clear();
            f_s.clear();
            for r in win {
                taus.push((r.t - t_c) / span);
                a_s.push(r.a - rows[i].a);
                f_s.push(r.force - rows[i].force);
            }
            let (c1, g11, var_a) = local_poly(&taus, &a_s, deg)?;
            let (_, _, var_force) = local_poly(&taus, &f_s, deg)?;
            Some(LocalFit {
                slope: c1 / span,
                slope_gain: g11.sqrt() / span,
                var_a,
                var_force,
            })
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let k = v.len();
    if k % 2 == 1 {
        v[k / 2]
    } else {
        0.5 * (v[k / 2 - 1] + v[k / 2])
    }
}

/// Noise levels (σ_a m, σ_F N): the options' values, or the square roots of the median residual
/// variances of the local fits.
pub fn noise_levels(fits: &[Option<LocalFit>], opts: &GsFitOptions) -> (f64, f64) {
    let sa = opts
        .noise_a
        .unwrap_or_else(|| median(fits.iter().flatten().map(|f| f.var_a).collect()).sqrt());
    let sf = opts
        .noise_force
        .unwrap_or_else(|| median(fits.iter().flatten().map(|f| f.var_force).collect()).sqrt());
    (sa, sf)
}

/// Standard error of w from eq. (28) for errors σ_a on a and σ_F on F (first order, J/m²).
pub fn work_of_adhesion_error(m: &Material, a: f64, force: f64, sigma_a: f64, sigma_f: f64) -> f64 {
    let fh = jkr::hertz_force(m, a);
    let d = fh - force;
    let den = 6.0 * std::f64::consts::PI * m.r * fh;
    let dw_df = -2.0 * d / den;
    let dw_da = 3.0 * d * (fh + force) / (den * a);
    (dw_df * sigma_f).hypot(dw_da * sigma_a)
}

/// Validate a record and extract the peeling points (steps 2–5 of the module documentation).
pub fn peeling_points(
    m: &Material,
    rows: &[UnloadingRow],
    opts: &GsFitOptions,
) -> Result<Vec<PeelingPoint>, ParamError> {
    m.validate()?;
    opts.validate()?;
    let need = 2 * opts.half_window + 1;
    if rows.len() < need {
        return Err(ParamError::new(
            "record",
            format!("{} rows", rows.len()),
            format!("needs at least 2 half_window + 1 = {need} rows"),
        ));
    }
    for (i, r) in rows.iter().enumerate() {
        if !(r.t.is_finite() && r.a.is_finite() && r.force.is_finite()) || r.a <= 0.0 {
            return Err(ParamError::new(
                format!("record row {}", i + 1),
                format!("(t {}, a {}, F {})", r.t, r.a, r.force),
                "t, a, F must be finite and a > 0",
            ));
        }
        if i > 0 && r.t <= rows[i - 1].t {
            return Err(ParamError::new(
                format!("record row {}", i + 1),
                r.t,
                format!("time must increase strictly (previous {})", rows[i - 1].t),
            ));
        }
    }
    let fits = local_fits(rows, opts.half_window, opts.degree);
    let (sa, sf) = noise_levels(&fits, opts);
    Ok(rows
        .iter()
        .zip(fits)
        .enumerate()
        .filter_map(|(i, (r, fit))| {
            let fit = fit?;
            let v = -fit.slope;
            let speed_error = sa * fit.slope_gain;
            let keep = v > opts.min_speed && v > opts.min_speed_over_noise * speed_error;
            keep.then(|| PeelingPoint {
                row: i,
                t: r.t,
                a: r.a,
                speed: v,
                speed_error,
                w: jkr::work_of_adhesion_from_force(m, r.a, r.force),
                w_error: work_of_adhesion_error(m, r.a, r.force, sa, sf),
            })
        })
        .filter(|p| p.w.is_finite() && p.w_error.is_finite())
        .collect())
}

/// Result of a Gent–Schultz fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GsFit {
    /// Quasi-static work of adhesion w0 (J/m²).
    pub w0: f64,
    /// Reference speed v0 (m/s).
    pub v0: f64,
    /// Exponent n.
    pub n: f64,
    /// Standard errors of (w0, v0, n).
    pub sigma: [f64; 3],
    /// Covariance of (w0, v0, n) (row-major, SI).
    pub covariance: [[f64; 3]; 3],
    /// Number of points used in the fit.
    pub points_used: usize,
    /// Number of rows in the record.
    pub rows: usize,
    /// RMS of the residuals w − w_fit (J/m²), unweighted.
    pub residual_rms: f64,
    /// χ²/(N − 3) with the effective variances: ≈ 1 when the noise model is right.
    pub chi2_reduced: f64,
    /// Smallest and largest speed used (m/s).
    pub speed_range: (f64, f64),
    /// True when n lies at an end of [n_min, n_max]: widen the range or question the data.
    pub n_at_bound: bool,
    /// The points used.
    pub points: Vec<PeelingPoint>,
}

/// Standard errors of the fitted constants, by name.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sigma {
    /// σ of w0 (J/m²).
    pub w0: f64,
    /// σ of v0 (m/s).
    pub v0: f64,
    /// σ of n.
    pub n: f64,
}

/// What `djkr gs-fit --json` prints: the fit's headline numbers (SI) and the record's rows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GsFitReport {
    /// Quasi-static work of adhesion w0 (J/m²).
    pub w0: f64,
    /// Reference speed v0 (m/s).
    pub v0: f64,
    /// Exponent n.
    pub n: f64,
    /// Standard errors.
    pub sigma: Sigma,
    /// Points used in the fit.
    pub points_used: usize,
    /// Rows given to the fit (the record's last stretch in contact).
    pub rows: usize,
    /// Rows of the record left out, out of contact ([`contact_span`]).
    pub rows_out_of_contact: usize,
    /// RMS of the residuals (J/m²).
    pub residual_rms: f64,
    /// Reduced χ².
    pub chi2_reduced: f64,
    /// Smallest and largest crack speed used (m/s).
    pub speed_range: [f64; 2],
    /// n at an end of its search range.
    pub n_at_bound: bool,
}

impl GsFitReport {
    /// The report of `fit`, which left out `rows_out_of_contact` rows of the record.
    pub fn new(fit: &GsFit, rows_out_of_contact: usize) -> Self {
        Self {
            w0: fit.w0,
            v0: fit.v0,
            n: fit.n,
            sigma: Sigma {
                w0: fit.sigma[0],
                v0: fit.sigma[1],
                n: fit.sigma[2],
            },
            points_used: fit.points_used,
            rows: fit.rows,
            rows_out_of_contact,
            residual_rms: fit.residual_rms,
            chi2_reduced: fit.chi2_reduced,
            speed_range: [fit.speed_range.0, fit.speed_range.1],
            n_at_bound: fit.n_at_bound,
        }
    }
}

impl GsFit {
    /// The fitted law.
    pub fn law(&self) -> Result<GentSchultz, ParamError> {
        GentSchultz::new(self.w0, self.v0, self.n)
    }
}

/// Weighted linear least squares w = A + B uⁿ for fixed n over (u, w, weight): (A, B, χ²).
fn linear_for_n(pts: &[(f64, f64, f64)], n: f64) -> (f64, f64, f64) {
    let sw: f64 = pts.iter().map(|p| p.2).sum();
    let xm = pts.iter().map(|p| p.2 * p.0.powf(n)).sum::<f64>() / sw;
    let wm = pts.iter().map(|p| p.2 * p.1).sum::<f64>() / sw;
    let (mut sxx, mut sxw) = (0.0, 0.0);
    for p in pts {
        let dx = p.0.powf(n) - xm;
        sxx += p.2 * dx * dx;
        sxw += p.2 * dx * (p.1 - wm);
    }
    let b = if sxx > 0.0 { sxw / sxx } else { 0.0 };
    let a = wm - b * xm;
    let chi2: f64 = pts
        .iter()
        .map(|p| p.2 * (p.1 - a - b * p.0.powf(n)).powi(2))
        .sum();
    (a, b, chi2)
}

/// Minimise χ²(n) of [`linear_for_n`] over [n_min, n_max]: (n, A, B, χ², at_bound).
fn project_n(pts: &[(f64, f64, f64)], opts: &GsFitOptions) -> (f64, f64, f64, f64, bool) {
    let chi2 = |n: f64| linear_for_n(pts, n).2;
    let scan = 80usize;
    let (ln_lo, ln_hi) = (opts.n_min.ln(), opts.n_max.ln());
    let n_at = |i: usize| (ln_lo + (ln_hi - ln_lo) * i as f64 / (scan - 1) as f64).exp();
    let (mut i_best, mut c_best) = (0, f64::INFINITY);
    for i in 0..scan {
        let c = chi2(n_at(i));
        if c < c_best {
            c_best = c;
            i_best = i;
        }
    }
    let lo = n_at(i_best.saturating_sub(1));
    let hi = n_at((i_best + 1).min(scan - 1));
    let (n_b, c_b) = brent_minimize(chi2, lo, hi, 1e-13, 0.0, 300);
    let n = if c_b <= c_best { n_b } else { n_at(i_best) };
    let at_bound = n <= opts.n_min * (1.0 + 1e-6) || n >= opts.n_max * (1.0 - 1e-6);
    let (a, b, c) = linear_for_n(pts, n);
    (n, a, b, c, at_bound)
}

/// Fit w = w0 (1 + (v/v0)^n) to peeling points (steps 6–7 of the module documentation). `rows`
/// is the record length, reported back.
pub fn fit_points(
    points: &[PeelingPoint],
    opts: &GsFitOptions,
    rows: usize,
) -> Result<GsFit, ParamError> {
    opts.validate()?;
    if points.len() < 4 {
        return Err(ParamError::new(
            "peeling points",
            points.len(),
            "need at least 4 rows with a resolved peeling speed (v = -da/dt > 0) to fit 3 constants",
        ));
    }
    let no_trend = |a: f64, b: f64, n: f64, v_ref: f64| {
        ParamError::new(
            "record",
            format!("w = {a} + {b} (v/{v_ref})^{n}"),
            "the data do not show a positive w0 and a work of adhesion increasing with speed",
        )
    };
    // Scale speeds by their geometric mean so that uⁿ stays O(1) for any n.
    let v_ref = (points.iter().map(|p| p.speed.ln()).sum::<f64>() / points.len() as f64).exp();
    // Variance floor: a noiseless record would otherwise give infinite weights.
    let floor = |p: &PeelingPoint| (1e-9 * p.w.abs()).powi(2).max(f64::MIN_POSITIVE);
    let mut var: Vec<f64> = points
        .iter()
        .map(|p| p.w_error.powi(2) + floor(p))
        .collect();
    let mut sol = (0.0, 0.0, 0.0, 0.0, false);
    for _ in 0..6 {
        let pts: Vec<(f64, f64, f64)> = points
            .iter()
            .zip(&var)
            .map(|(p, v)| (p.speed / v_ref, p.w, 1.0 / v))
            .collect();
        sol = project_n(&pts, opts);
        let (n, a, b, _, _) = sol;
        if !(a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite()) {
            return Err(no_trend(a, b, n, v_ref));
        }
        // Effective variances with the model slope dw/dv = n B uⁿ / v.
        for (p, v) in points.iter().zip(var.iter_mut()) {
            let u = p.speed / v_ref;
            let slope = n * b * u.powf(n) / p.speed;
            *v = p.w_error.powi(2) + (slope * p.speed_error).powi(2) + floor(p);
        }
    }
    let (n, a, b, _, n_at_bound) = sol;
    let w0 = a;
    let v0 = v_ref * (a / b).powf(1.0 / n);
    // Jacobian in (w0, ln v0, n), weighted; χ² with the final variances.
    let mut jtwj = Matrix3::<f64>::zeros();
    let (mut chi2, mut ssr) = (0.0, 0.0);
    for (p, v) in points.iter().zip(&var) {
        let q = (p.speed / v0).powf(n);
        let r = p.w - w0 * (1.0 + q);
        chi2 += r * r / v;
        ssr += r * r;
        let row = Vector3::new(1.0 + q, -w0 * n * q, w0 * q * (p.speed / v0).ln());
        jtwj += row * row.transpose() / *v;
    }
    let singular = || {
        ParamError::new(
            "record",
            format!("{} peeling points", points.len()),
            "the speeds do not span enough of the law to determine w0, v0 and n separately",
        )
    };
    let d = Vector3::new(
        jtwj[(0, 0)].sqrt(),
        jtwj[(1, 1)].sqrt(),
        jtwj[(2, 2)].sqrt(),
    );
    if d.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        return Err(singular());
    }
    let scaled = Matrix3::from_fn(|i, j| jtwj[(i, j)] / (d[i] * d[j]));
    let inv = scaled.try_inverse().ok_or_else(singular)?;
    let chi2_reduced = chi2 / (points.len() - 3) as f64;
    let t = [1.0, v0, 1.0];
    let mut cov = [[0.0; 3]; 3];
    for (i, row) in cov.iter_mut().enumerate() {
        for (j, c) in row.iter_mut().enumerate() {
            *c = chi2_reduced * inv[(i, j)] / (d[i] * d[j]) * t[i] * t[j];
        }
    }
    let sigma = [cov[0][0].sqrt(), cov[1][1].sqrt(), cov[2][2].sqrt()];
    if sigma.iter().any(|s| !s.is_finite()) || !v0.is_finite() {
        return Err(singular());
    }
    let (vmin, vmax) = points.iter().fold((f64::INFINITY, 0.0f64), |(l, h), p| {
        (l.min(p.speed), h.max(p.speed))
    });
    Ok(GsFit {
        w0,
        v0,
        n,
        sigma,
        covariance: cov,
        points_used: points.len(),
        rows,
        residual_rms: (ssr / points.len() as f64).sqrt(),
        chi2_reduced,
        speed_range: (vmin, vmax),
        n_at_bound,
        points: points.to_vec(),
    })
}

/// Gent–Schultz constants from an unloading record: [`peeling_points`] then [`fit_points`].
pub fn fit_gent_schultz(
    m: &Material,
    rows: &[UnloadingRow],
    opts: &GsFitOptions,
) -> Result<GsFit, ParamError> {
    let pts = peeling_points(m, rows, opts)?;
    fit_points(&pts, opts, rows.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_header_and_errors() {
        let text = "# record\nF [N], time_s, a_m\n0.1, 0, 1e-3\n0.09, 1, 0.99e-3\n";
        let rows = parse_csv(text, "rec.csv").unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(
            rows[1],
            UnloadingRow {
                t: 1.0,
                a: 0.99e-3,
                force: 0.09
            }
        );
        let e = parse_csv("t,a,F\n0,1e-3,0.1\n1,x,0.2\n", "rec.csv").unwrap_err();
        assert_eq!(e.name, "rec.csv: line 3");
        let e = parse_csv("0,1e-3,0.1\n", "rec.csv").unwrap_err();
        assert_eq!(e.name, "rec.csv: line 1");
    }

    #[test]
    fn header_units_are_converted_and_other_columns_ignored() {
        // djkr's own timeseries.csv style, with a = 0 after pull-off.
        let text = "t [s],x_s [m],a [m],a_dot [m/s],F [N],stage [1]\n\
                    0.5,1e-6,1e-3,-1e-6,0.01,0\n\
                    1,2e-6,0.9e-3,NaN,0.005,1\n\
                    1.5,3e-6,0,0,0,1\n";
        let rows = parse_csv(text, "ts.csv").unwrap();
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[1].a.to_bits(), 0.9e-3f64.to_bits());
        assert_eq!(rows[1].force.to_bits(), 0.005f64.to_bits());
        assert_eq!(contact_span(&rows), Some(0..2));
        // Units other than SI are converted.
        let rows = parse_csv("a [mm]; time (ms); F_mN\n2; 500; 30\n", "x.csv").unwrap();
        let r = rows[0];
        assert!((r.t - 0.5).abs() < 1e-15 && (r.a - 2e-3).abs() < 1e-18);
        assert!((r.force - 0.03).abs() < 1e-15);
        // Legacy suffixes that are units; `a_dot` is not `a`.
        let rows = parse_csv("t_s,a_dot,a_m,F_N\n1,5,2e-3,0.1\n", "y.csv").unwrap();
        assert_eq!(rows[0].a.to_bits(), 2e-3f64.to_bits());
        // An unknown unit or a missing column is named.
        let e = parse_csv("t [s],a [furlong],F [N]\n1,2,3\n", "z.csv").unwrap_err();
        assert!(
            e.to_string().contains("furlong") && e.name == "z.csv: line 1",
            "{e}"
        );
        let e = parse_csv("t [s],F [N]\n1,2\n", "z.csv").unwrap_err();
        assert!(e.to_string().contains("not a"), "{e}");
    }

    #[test]
    fn contact_span_is_the_last_stretch_in_contact() {
        let row = |a: f64| UnloadingRow {
            t: 0.0,
            a,
            force: 0.0,
        };
        let rows: Vec<UnloadingRow> = [0.0, 1.0, 0.0, 2.0, 3.0, 0.0, 0.0]
            .into_iter()
            .map(row)
            .collect();
        assert_eq!(contact_span(&rows), Some(3..5));
        assert_eq!(contact_span(&rows[..1]), None);
        assert_eq!(contact_span(&rows[3..5]), Some(0..2));
    }

    #[test]
    fn local_slope_is_exact_on_a_line() {
        let rows: Vec<UnloadingRow> = (0..20)
            .map(|i| UnloadingRow {
                t: i as f64 * 0.1,
                a: 2e-3 - 3e-5 * i as f64 * 0.1,
                force: 0.0,
            })
            .collect();
        for deg in [1, 3] {
            let s = local_fits(&rows, 3, deg);
            assert!(s[2].is_none() && s[3].is_some() && s[16].is_some() && s[17].is_none());
            let f = s[10].unwrap();
            assert!((f.slope + 3e-5).abs() < 1e-15);
            assert!(f.var_a < 1e-24);
        }
    }

    #[test]
    fn cubic_local_fit_is_exact_on_a_cubic_with_uneven_steps() {
        let a = |t: f64| 2e-3 - 1e-5 * t + 4e-6 * t * t - 3e-6 * t * t * t;
        let rows: Vec<UnloadingRow> = (0..15)
            .map(|i| {
                let t = 0.1 * i as f64 + 0.013 * ((i * 7) % 5) as f64;
                UnloadingRow {
                    t,
                    a: a(t),
                    force: 0.0,
                }
            })
            .collect();
        let f = local_fits(&rows, 4, 3)[7].unwrap();
        let t = rows[7].t;
        let exact = -1e-5 + 8e-6 * t - 9e-6 * t * t;
        assert!(
            (f.slope - exact).abs() < 1e-12 * 1e-5,
            "{} vs {exact}",
            f.slope
        );
    }
}
