//! The tables of `djkr beta-fit` (`beta_error_curve.csv`, `beta_ratios.csv`).

use crate::output::{Column, Table};
use djkr_core::beta_fit::{BetaFit, RatioPoint};

/// The error curve as a table (`beta_error_curve.csv`): β, RMS of ln(A_exact/A_approx).
pub fn error_curve_table(fit: &BetaFit) -> Table {
    let c = &fit.error_curve;
    Table::from_fixed(vec![
        Column::f64(
            "beta",
            "1",
            "speed correction β of eq. (24)",
            c.iter().map(|p| p.0).collect(),
        ),
        Column::f64(
            "error_rms_ln_ratio",
            "1",
            "RMS over the grid of ln(A_exact / A_approx)",
            c.iter().map(|p| p.1).collect(),
        ),
    ])
}

/// The per-point ratios as a table (`beta_ratios.csv`): at the best β and at β = 2.5.
pub fn ratios_table(fit: &BetaFit) -> Table {
    let (b, p) = (&fit.ratios_best, &fit.ratios_paper);
    let col = |name: &str, description: &str, v: &[RatioPoint], f: fn(&RatioPoint) -> f64| {
        Column::f64(name, "1", description, v.iter().map(f).collect())
    };
    Table::from_fixed(vec![
        col("n", "Gent–Schultz exponent", b, |x| x.n),
        col("v_max_over_v0", "peak contact-line speed over v0", b, |x| {
            x.speed_ratio
        }),
        col("amp_exact", "exact pull-off amplification", b, |x| {
            x.amp_exact
        }),
        col(
            "amp_approx_best_beta",
            "closed-form amplification at the best β",
            b,
            |x| x.amp_approx,
        ),
        col(
            "ratio_best_beta",
            "amp_exact / amp_approx at the best β",
            b,
            |x| x.ratio,
        ),
        col(
            "ratio_beta_2_5",
            "amp_exact / amp_approx at β = 2.5",
            p,
            |x| x.ratio,
        ),
    ])
}
