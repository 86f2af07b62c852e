//! Refit of the corrective factor β of eq. (24) against the exact imposed-area pull-off (Sec. 2.2,
//! Fig. 3(b)).
//!
//! For a fixed material and frequency, a grid of Gent–Schultz exponents n and speed ratios
//! v_max/v0 (v_max = a_A ω, the peak contact-radius speed, so a_A = v_max/ω) is mapped to exact
//! pull-off amplifications by [`crate::imposed_area::pull_off`], once per grid point (they do not
//! depend on β) and in parallel. The closed-form amplification at β is
//! A(β) = ¼(√(1 + (v_max/(β v0))^n) + 1)² (eqs. 21, 24); it is cheap, so the error curve over β
//! costs nothing once the exact values are known.
//!
//! Error metric: the RMS over the grid of ln(A_exact / A_approx(β)). A logarithmic ratio because
//! the amplifications span orders of magnitude across the grid and an over- and an under-prediction
//! by the same factor should weigh the same; it is also what Fig. 3(b) shows (the ratio). β is
//! minimised by a scan of the error on a log-spaced β grid (which is also the reported error
//! curve) followed by Brent's method on the bracket around the best scan point.
//!
//! # Findings
//!
//! (`cargo test --release --test it closed_form::beta_study -- --ignored --nocapture`, paper material,
//! v0 = 0.0445 mm/s.) Over the paper's range (n = 0.1 … 0.9, v_max/v0 = 10⁻² … 10², 200 Hz) the
//! best β is ≈ 4.2 (RMS ln ratio 0.156, against 0.188 at β = 2.5); at β = 2.5 the ratio
//! exact/approximate spans 0.73 … 1.04. The optimum depends strongly on n (≈ 3.0 for n = 0.9,
//! 7.6 for n = 0.531, > 60 for n ≤ 0.3) and on the speed range (≈ 10 up to v_max/v0 = 10, 3.2 up
//! to 10³, 2.8 up to 10⁴), because eq. (19) keeps the peeling peak but ignores the healing half
//! cycle, where w < w0 (see [`crate::closed_form::small_amplitude_amplification`], the exact
//! small-amplitude limit the exact points follow). In the setting of Figs. 4–7 (n = 0.531,
//! a_A = 10 µm … 1 mm at 200–400 Hz, i.e. v_max/v0 ≈ 300 … 56 000) the best β is 3.0–3.2 with
//! ratios 0.91 … 1.07 (0.82 … 0.98 at β = 2.5).
//!
//! Note that at a fixed frequency a_A = (v_max/v0) v0/ω is tiny at the paper's constants
//! (v0/ω ≈ 35 nm at 200 Hz), so the refit probes the small-amplitude limit a_A ≪ a_m in which the
//! closed form was derived; a lower frequency moves a_A towards a_m at the same v_max/v0.

use crate::adhesion::GentSchultz;
use crate::closed_form;
use crate::error::{positive, ParamError};
use crate::imposed_area;
use crate::material::Material;
use crate::numerics::brent_minimize;
use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::PI;

/// `count` points spaced evenly in log between `lo` and `hi` (both > 0); `[lo]` when count is 1.
pub fn log_space(lo: f64, hi: f64, count: usize) -> Vec<f64> {
    match count {
        0 => Vec::new(),
        1 => vec![lo],
        _ => (0..count)
            .map(|i| lo * (hi / lo).powf(i as f64 / (count - 1) as f64))
            .collect(),
    }
}

/// The grid and ranges of a β refit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BetaFitConfig {
    /// Material (K, R, w0); the law's w0 is the material's.
    pub material: Material,
    /// Gent–Schultz reference speed v0 (m/s).
    pub v0: f64,
    /// Vibration frequency (Hz): a_A = v_max / (2π f).
    pub frequency_hz: f64,
    /// Gent–Schultz exponents n of the grid (each > 0).
    pub n_values: Vec<f64>,
    /// Speed ratios v_max/v0 of the grid (each > 0).
    pub speed_ratios: Vec<f64>,
    /// Smallest β searched (> 0).
    pub beta_min: f64,
    /// Largest β searched (> beta_min).
    pub beta_max: f64,
    /// Number of β values of the reported error curve (≥ 3), log-spaced.
    pub beta_points: usize,
}

impl Default for BetaFitConfig {
    /// The paper's range: n = 0.1, 0.3, 0.5, 0.7, 0.9; v_max/v0 from 10⁻² to 10² (25 points);
    /// paper material and v0; 200 Hz; β from 0.5 to 10.
    fn default() -> Self {
        Self {
            material: Material::PAPER,
            v0: GentSchultz::PAPER.v0,
            frequency_hz: 200.0,
            n_values: vec![0.1, 0.3, 0.5, 0.7, 0.9],
            speed_ratios: log_space(1e-2, 1e2, 25),
            beta_min: 0.5,
            beta_max: 10.0,
            beta_points: 60,
        }
    }
}

impl BetaFitConfig {
    /// Check every range; errors name the field.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.material.validate()?;
        positive("v0", self.v0, "m/s")?;
        positive("frequency", self.frequency_hz, "Hz")?;
        if self.n_values.is_empty() || self.speed_ratios.is_empty() {
            return Err(ParamError::new(
                "grid",
                format!(
                    "{} n values x {} speed ratios",
                    self.n_values.len(),
                    self.speed_ratios.len()
                ),
                "needs at least one n and one v_max/v0",
            ));
        }
        for &n in &self.n_values {
            positive("n", n, "(dimensionless)")?;
        }
        for &r in &self.speed_ratios {
            positive("v_max/v0", r, "(dimensionless)")?;
        }
        positive("beta_min", self.beta_min, "(dimensionless)")?;
        if !(self.beta_max.is_finite() && self.beta_max > self.beta_min) {
            return Err(ParamError::new(
                "beta_max",
                self.beta_max,
                format!("must be finite and > beta_min = {}", self.beta_min),
            ));
        }
        if self.beta_points < 3 {
            return Err(ParamError::new(
                "beta_points",
                self.beta_points,
                "must be >= 3",
            ));
        }
        Ok(())
    }
}

/// One grid point with its exact pull-off amplification.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ExactPoint {
    /// Gent–Schultz exponent n.
    pub n: f64,
    /// v_max/v0.
    pub speed_ratio: f64,
    /// Contact-radius amplitude a_A = v_max/ω (m).
    pub a_amp: f64,
    /// Exact mean contact radius at pull-off (a posteriori mean, m).
    pub a_mean_exact: f64,
    /// Exact amplification F_m,po/F0.
    pub amp_exact: f64,
}

/// Exact over approximate amplification at one grid point and one β (Fig. 3(b)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RatioPoint {
    /// Gent–Schultz exponent n.
    pub n: f64,
    /// v_max/v0.
    pub speed_ratio: f64,
    /// Exact amplification.
    pub amp_exact: f64,
    /// Closed-form amplification at this β.
    pub amp_approx: f64,
    /// amp_exact / amp_approx.
    pub ratio: f64,
}

/// Result of a β refit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BetaFit {
    /// β minimising the error.
    pub best_beta: f64,
    /// RMS of ln(A_exact/A_approx) at the best β.
    pub best_error: f64,
    /// True when the best β lies at an end of [beta_min, beta_max]: widen the range.
    pub at_bound: bool,
    /// The error at the paper's β = 2.5.
    pub error_at_paper_beta: f64,
    /// The error curve (β, RMS ln ratio) on the log-spaced β grid.
    pub error_curve: Vec<(f64, f64)>,
    /// Per-point ratios at the best β.
    pub ratios_best: Vec<RatioPoint>,
    /// Per-point ratios at β = 2.5 (Fig. 3(b)).
    pub ratios_paper: Vec<RatioPoint>,
    /// The exact grid the fit used.
    pub exact: Vec<ExactPoint>,
}

/// Exact amplifications over the grid (parallel; rayon). Errors from the exact solver are passed
/// on with the grid point in the name.
pub fn exact_grid(config: &BetaFitConfig) -> Result<Vec<ExactPoint>, ParamError> {
    config.validate()?;
    let omega = 2.0 * PI * config.frequency_hz;
    let m = config.material;
    let pairs: Vec<(f64, f64)> = config
        .n_values
        .iter()
        .flat_map(|&n| config.speed_ratios.iter().map(move |&r| (n, r)))
        .collect();
    pairs
        .par_iter()
        .map(|&(n, ratio)| {
            let law = GentSchultz::new(m.w0, config.v0, n)?;
            let a_amp = ratio * config.v0 / omega;
            let po = imposed_area::pull_off(&m, &law, omega, a_amp)
                .map_err(|e| e.renamed(format!("exact pull-off at n = {n}, v_max/v0 = {ratio}")))?;
            Ok(ExactPoint {
                n,
                speed_ratio: ratio,
                a_amp,
                a_mean_exact: po.cycle.a_mean,
                amp_exact: po.amplification,
            })
        })
        .collect()
}

/// Closed-form amplification ¼(√(1 + (ratio/β)^n) + 1)² at speed ratio v_max/v0 = `ratio`.
#[inline]
fn approx_amplification(n: f64, ratio: f64, beta: f64) -> f64 {
    let x = (ratio / beta).powf(n);
    0.25 * ((1.0 + x).sqrt() + 1.0).powi(2)
}

/// Ratios exact/approximate at β for every exact point.
pub fn ratios_at(points: &[ExactPoint], beta: f64) -> Vec<RatioPoint> {
    points
        .iter()
        .map(|p| {
            let amp_approx = approx_amplification(p.n, p.speed_ratio, beta);
            RatioPoint {
                n: p.n,
                speed_ratio: p.speed_ratio,
                amp_exact: p.amp_exact,
                amp_approx,
                ratio: p.amp_exact / amp_approx,
            }
        })
        .collect()
}

/// RMS over the points of ln(A_exact / A_approx(β)). Allocation-free. NaN only for an empty slice.
pub fn error_at(points: &[ExactPoint], beta: f64) -> f64 {
    let sum: f64 = points
        .iter()
        .map(|p| {
            (p.amp_exact / approx_amplification(p.n, p.speed_ratio, beta))
                .ln()
                .powi(2)
        })
        .sum();
    (sum / points.len() as f64).sqrt()
}

/// Fit β on precomputed exact points over [beta_min, beta_max] with a `beta_points` error curve.
pub fn fit_beta_on(
    points: &[ExactPoint],
    beta_min: f64,
    beta_max: f64,
    beta_points: usize,
) -> Result<BetaFit, ParamError> {
    if points.is_empty() {
        return Err(ParamError::new("grid", 0, "needs at least one exact point"));
    }
    positive("beta_min", beta_min, "(dimensionless)")?;
    if !(beta_max.is_finite() && beta_max > beta_min) {
        return Err(ParamError::new(
            "beta_max",
            beta_max,
            format!("must be finite and > beta_min = {beta_min}"),
        ));
    }
    if let Some(p) = points
        .iter()
        .find(|p| !(p.amp_exact.is_finite() && p.amp_exact > 0.0))
    {
        return Err(ParamError::new(
            format!(
                "exact amplification at n = {}, v_max/v0 = {}",
                p.n, p.speed_ratio
            ),
            p.amp_exact,
            "must be finite and > 0 for the log-ratio error (a large a_A/a_m can leave no \
             adhesive mean force: shrink the speed range or raise the frequency)",
        ));
    }
    let betas = log_space(beta_min, beta_max, beta_points.max(3));
    let curve: Vec<(f64, f64)> = betas.iter().map(|&b| (b, error_at(points, b))).collect();
    let i_best = curve
        .iter()
        .enumerate()
        .fold(0, |ib, (i, c)| if c.1 < curve[ib].1 { i } else { ib });
    let lo = betas[i_best.saturating_sub(1)];
    let hi = betas[(i_best + 1).min(betas.len() - 1)];
    // Minimise in ln β (the grid is log-spaced).
    let (ln_b, err) = brent_minimize(
        |lb| error_at(points, lb.exp()),
        lo.ln(),
        hi.ln(),
        0.0,
        1e-10,
        200,
    );
    let (best_beta, best_error) = if err <= curve[i_best].1 {
        (ln_b.exp(), err)
    } else {
        curve[i_best]
    };
    let at_bound = best_beta <= beta_min * (1.0 + 1e-4) || best_beta >= beta_max * (1.0 - 1e-4);
    Ok(BetaFit {
        best_beta,
        best_error,
        at_bound,
        error_at_paper_beta: error_at(points, closed_form::BETA_PAPER),
        error_curve: curve,
        ratios_best: ratios_at(points, best_beta),
        ratios_paper: ratios_at(points, closed_form::BETA_PAPER),
        exact: points.to_vec(),
    })
}

/// Full refit: exact grid (parallel), then β. See the module documentation.
pub fn fit_beta(config: &BetaFitConfig) -> Result<BetaFit, ParamError> {
    let points = exact_grid(config)?;
    fit_beta_on(
        &points,
        config.beta_min,
        config.beta_max,
        config.beta_points,
    )
}

/// Fig. 3(b) data at a given β: exact/approximate amplification for every (n, v_max/v0) of the
/// config's grid (row-major in n, then speed ratio).
pub fn figure_3b(config: &BetaFitConfig, beta: f64) -> Result<Vec<RatioPoint>, ParamError> {
    positive("beta", beta, "(dimensionless)")?;
    Ok(ratios_at(&exact_grid(config)?, beta))
}
