//! `djkr required-speed` (eq. 29) and `djkr beta-fit` (Fig. 3(b) and β ≈ 2.5, checked).

use super::common::{
    beta_from, key_positive_quantity, limit_count, limits, positive_quantity, print_json,
    print_table, reject_unused, MaterialArgs,
};
use anyhow::{bail, Context, Result};
use clap::Args;
use djkr_core::beta_fit::{self, BetaFitConfig};
use djkr_core::closed_form;
use djkr_core::units::Dimension;
use serde_json::json;
use std::path::PathBuf;

/// Flags of `djkr required-speed`.
#[derive(Args, Debug)]
pub struct RequiredSpeedArgs {
    /// Target pull-off amplification F_m,po/F0 (≥ 1).
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    amplification: String,
    /// Speed correction β of eq. (24), in [0.01, 100].
    #[arg(long, default_value = "2.5", allow_hyphen_values = true)]
    beta: String,
    /// Print one JSON object of SI values.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    material: MaterialArgs,
}

/// Run `djkr required-speed`.
pub fn required_speed(a: &RequiredSpeedArgs) -> Result<()> {
    reject_unused(
        &[
            ("--modulus", a.material.k.is_some()),
            ("--radius", a.material.radius.is_some()),
        ],
        "in required-speed (eq. 29 depends on the adhesion law only)",
    )?;
    let (_, law) = a.material.resolve()?;
    let target = positive_quantity(
        "--amplification",
        &a.amplification,
        Dimension::Dimensionless,
    )?;
    let beta = beta_from("--beta", &a.beta)?;
    let v = closed_form::vibration_speed_for_amplification(&law, target, beta).map_err(|e| {
        djkr_core::error::ParamError {
            value: djkr_core::text::excerpt(&a.amplification),
            ..e.renamed("--amplification")
        }
    })?;
    let printed = closed_form::vibration_speed_as_printed(&law, target, beta).ok();
    if a.json {
        let mut o = json!({ "speed": v, "amplification": target, "beta": beta });
        if let Some(p) = printed {
            o["speed_as_printed"] = json!(p);
        }
        return print_json(&o);
    }
    let mut rows = vec![(
        "v = a_A ω from eqs. (21), (24)",
        format!("{:.6} mm/s", v * 1e3),
    )];
    if let Some(p) = printed {
        rows.push((
            "eq. (29) as printed (drops the 1/4 of eq. 21)",
            format!("{:.6} mm/s", p * 1e3),
        ));
    }
    print_table(
        &format!("Vibration speed for amplification {target} (β = {beta})"),
        &rows,
    )?;
    Ok(())
}

/// Flags of `djkr beta-fit`.
#[derive(Args, Debug)]
pub struct BetaFitArgs {
    /// Gent–Schultz exponents n, comma-separated (each > 0).
    #[arg(long, default_value = "0.1,0.3,0.5,0.7,0.9")]
    n_values: String,
    /// Speed ratios v_max/v0 as MIN:MAX:COUNT, log-spaced (v_max = a_A ω).
    #[arg(long, default_value = "1e-2:1e2:25")]
    speed_ratio: String,
    /// β search range MIN:MAX:COUNT (the error curve is reported on this log grid).
    #[arg(long, default_value = "0.5:10:60")]
    beta: String,
    /// Vibration frequency (Hz), which sets a_A = v_max/ω.
    #[arg(long, default_value = "200", value_name = "HZ")]
    freq: String,
    /// Write the error curve and the ratio table as CSV (and plots) into this directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Overwrite files in --out that djkr did not write under the names this command writes;
    /// without it such a file stops the command before any work. Nothing else is touched.
    #[arg(long)]
    force: bool,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    material: MaterialArgs,
}

/// Parse `MIN:MAX:COUNT`.
fn range(flag: &str, text: &str) -> Result<(f64, f64, usize)> {
    let parts: Vec<&str> = text.split(':').collect();
    let bad = || {
        anyhow::anyhow!(
            "{flag} = {shown_text}: expected MIN:MAX:COUNT with 0 < MIN < MAX and COUNT >= 1",
            shown_text = djkr_core::text::excerpt(text)
        )
    };
    if parts.len() != 3 {
        return Err(bad());
    }
    let lo: f64 = parts[0].trim().parse().map_err(|_| bad())?;
    let hi: f64 = parts[1].trim().parse().map_err(|_| bad())?;
    let n: usize = parts[2].trim().parse().map_err(|_| bad())?;
    if !(lo > 0.0 && hi >= lo && hi.is_finite() && n >= 1) {
        return Err(bad());
    }
    Ok((lo, hi, n))
}

/// Run `djkr beta-fit`.
pub fn beta_fit(a: &BetaFitArgs) -> Result<()> {
    let (m, law) = a.material.resolve_gent_schultz("djkr beta-fit")?;
    let n_values = a
        .n_values
        .split(',')
        .map(|t| positive_quantity("--n-values", t.trim(), Dimension::Dimensionless))
        .collect::<Result<Vec<_>, _>>()?;
    limit_count(
        "--n-values",
        &a.n_values,
        n_values.len(),
        limits::BETA_FIT_N_VALUES,
        "exponents",
    )?;
    let (slo, shi, sn) = range("--speed-ratio", &a.speed_ratio)?;
    limit_count(
        "--speed-ratio",
        &a.speed_ratio,
        sn,
        limits::BETA_FIT_SPEED_RATIOS,
        "speed ratios",
    )?;
    if n_values.len() * sn > limits::BETA_FIT_PULL_OFFS {
        bail!(
            "--n-values {} --speed-ratio {}: {} x {sn} = {} exact pull-offs, more than the limit of {}",
            a.n_values,
            a.speed_ratio,
            n_values.len(),
            n_values.len() * sn,
            limits::BETA_FIT_PULL_OFFS
        );
    }
    let (blo, bhi, bn) = range("--beta", &a.beta)?;
    limit_count("--beta", &a.beta, bn, limits::BETA_FIT_BETAS, "beta values")?;
    if bn < 3 || bhi <= blo {
        bail!("--beta = {}: needs MIN < MAX and COUNT >= 3", a.beta);
    }
    let cfg = BetaFitConfig {
        material: m,
        v0: law.v0,
        frequency_hz: key_positive_quantity(
            "--freq",
            &a.freq,
            Dimension::Frequency,
            "base.frequency",
        )?,
        n_values,
        speed_ratios: beta_fit::log_space(slo, shi, sn),
        beta_min: blo,
        beta_max: bhi,
        beta_points: bn,
    };
    if let Some(dir) = &a.out {
        let names = ["beta_error_curve.csv", "beta_ratios.csv"];
        let plots = ["beta_error_curve.png", "beta_error_curve.svg"];
        super::common::claim_out(dir, &[&names[..], &plots[..]].concat(), a.force)?;
    }
    eprintln!(
        "computing {} exact pull-offs ({} n x {} speed ratios)...",
        cfg.n_values.len() * cfg.speed_ratios.len(),
        cfg.n_values.len(),
        cfg.speed_ratios.len()
    );
    let fit = beta_fit::fit_beta(&cfg)?;
    if let Some(dir) = &a.out {
        write_beta_outputs(dir, &fit).with_context(|| format!("--out {}", dir.display()))?;
    }
    if a.json {
        return print_json(&serde_json::to_value(&fit)?);
    }
    let worst = |r: &[beta_fit::RatioPoint]| {
        r.iter()
            .map(|p| p.ratio)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            })
    };
    let (blo_r, bhi_r) = worst(&fit.ratios_best);
    let (plo_r, phi_r) = worst(&fit.ratios_paper);
    print_table(
        "β refit: exact / approximate pull-off amplification (error = RMS of ln ratio)",
        &[
            ("best β", format!("{:.4}", fit.best_beta)),
            ("error at best β", format!("{:.4e}", fit.best_error)),
            ("ratio range at best β", format!("{blo_r:.4} .. {bhi_r:.4}")),
            (
                "error at β = 2.5 (paper)",
                format!("{:.4e}", fit.error_at_paper_beta),
            ),
            (
                "ratio range at β = 2.5",
                format!("{plo_r:.4} .. {phi_r:.4}"),
            ),
        ],
    )?;
    outln!("\n  error curve (β, error):")?;
    for (b, e) in fit
        .error_curve
        .iter()
        .step_by((fit.error_curve.len() / 15).max(1))
    {
        outln!("    {b:8.4}  {e:.4e}")?;
    }
    Ok(())
}

fn write_beta_outputs(dir: &std::path::Path, fit: &beta_fit::BetaFit) -> Result<()> {
    use crate::plot::{render, Figure, Series, Style};
    std::fs::create_dir_all(dir)?;
    crate::reports::beta_fit::error_curve_table(fit).save_csv(&dir.join("beta_error_curve.csv"))?;
    crate::reports::beta_fit::ratios_table(fit).save_csv(&dir.join("beta_ratios.csv"))?;
    let fig = Figure::new(
        "β refit: error of the closed form",
        "β (–)",
        "RMS ln(A_exact / A_approx) (–)",
    )
    .with_series(Series::new(
        "error",
        fit.error_curve.iter().map(|p| p.0).collect(),
        fit.error_curve.iter().map(|p| p.1).collect(),
        Style::Line,
    ))
    .with_log(true, false);
    render(&fig, &dir.join("beta_error_curve"))?;
    Ok(())
}
