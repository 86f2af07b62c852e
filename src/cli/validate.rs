//! `djkr validate`: the periodic steady state of a scenario (shooting, with time-stepping as the
//! fallback) compared with the imposed-area method, the linear transfer, the paper's printed
//! equations and harmonic balance, and the force-balance check.

use super::common::load_scenario;
use super::common::print_json;
use super::steady::SteadyArgs;
use crate::reports::steady::ValidateReport;
use anyhow::{bail, Context, Result};
use clap::Args;
use djkr_core::steady::crosscheck::Prediction;
use indicatif::ProgressBar;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Flags of `djkr validate`.
#[derive(Args, Debug)]
#[command(after_help = super::common::STEADY_UNUSED_KEYS)]
pub struct ValidateArgs {
    /// Scenario file: its first stage with the vibration on, at its base amplitude and frequency,
    /// with the spring end held where that stage starts.
    file: PathBuf,
    /// Print one JSON object (SI values).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    steady: SteadyArgs,
}

/// Run `djkr validate`.
pub fn validate(a: &ValidateArgs) -> Result<()> {
    let opts = a.steady.options()?;
    let scn = load_scenario(&a.file, &a.steady.set)?;
    a.steady
        .set
        .refuse_replaced("validate", &[("solver.rtol", "--rtol")])?;
    let bar = ProgressBar::new_spinner();
    bar.set_message("finding the periodic steady state");
    bar.enable_steady_tick(Duration::from_millis(200));
    let report = crate::api::validate(&scn, &opts);
    bar.finish_and_clear();
    let report = report.with_context(|| format!("{}", a.file.display()))?;
    if a.json {
        print_json(&report)?;
    } else {
        print_report(&a.file, &report)?;
    }
    if let Some(e) = crate::api::force_balance_violation(&report) {
        bail!(e);
    }
    Ok(())
}

fn cell(v: Option<f64>, scale: f64) -> String {
    match v {
        Some(x) if x.is_finite() && (x * scale).abs() < 1e4 => format!("{:.5}", x * scale),
        Some(x) if x.is_finite() => format!("{:.3e}", x * scale),
        _ => "—".to_string(),
    }
}

fn row(label: &str, p: &Prediction, scales: [f64; 7]) -> Vec<String> {
    let mut line = vec![label.to_string()];
    for ((_, v), sc) in p.fields().iter().zip(scales) {
        line.push(cell(*v, sc));
    }
    line
}

/// Lay out rows of cells: the first column left-aligned, the others right-aligned, each column
/// as wide as its widest cell and separated by two spaces, so columns never run together
/// (`346.30626-1379.26544` was one cell too wide for a fixed width).
fn layout(rows: &[Vec<String>]) -> String {
    let cols = rows.iter().map(Vec::len).max().unwrap_or(0);
    let width: Vec<usize> = (0..cols)
        .map(|j| {
            rows.iter()
                .filter_map(|r| r.get(j))
                .map(|c| c.chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for r in rows {
        let mut line = String::new();
        for (j, c) in r.iter().enumerate() {
            let w = width[j];
            if j == 0 {
                line.push_str(&format!("{c:<w$}"));
            } else {
                line.push_str(&format!("  {c:>w$}"));
            }
        }
        out.push_str(&super::common::no_negative_zero(line.trim_end()));
        out.push('\n');
    }
    out
}

fn print_report(file: &Path, r: &ValidateReport) -> anyhow::Result<()> {
    let s = &r.steady;
    outln!(
        "{}: periodic steady state at f = {} Hz, X_b = {:.6} µm",
        file.display(),
        r.frequency,
        r.amplitude * 1e6
    )?;
    outln!(
        "  found by {}: {} Newton iterations, {} periods integrated, residual {:.2e}, {:.1} ms{}",
        s.method.name(),
        s.newton_iterations,
        s.cycles,
        s.residual,
        s.wall_s * 1e3,
        if s.contact_lost {
            "; the cycle loses contact"
        } else {
            ""
        }
    )?;
    if let Some(f) = r.linear_resonance {
        outln!("  linear resonance √((k + k_c)/m)/2π = {f:.3} Hz (k_c = 3/2 K a_0)")?;
    }
    outln!()?;
    let header = |names: [&str; 7]| {
        std::iter::once(String::new())
            .chain(names.iter().map(|n| n.to_string()))
            .collect::<Vec<_>>()
    };
    let scales = [1e3, 1e6, 1e6, 1e6, 1e6, 1e6, 1e3];
    let mut rows = vec![
        header([
            "a_m mm", "a_A µm", "δ_m µm", "δ_s µm", "δ_c µm", "δ_A µm", "F_m mN",
        ]),
        row("time domain", &r.time_domain, scales),
    ];
    for (_, label, p) in r.predictors.labelled() {
        if let Some(p) = p {
            rows.push(row(label, p, scales));
        }
    }
    out!("{}", layout(&rows))?;
    outln!("\nrelative difference from the time domain, % (δ_s, δ_c relative to δ_A):")?;
    let mut rows = vec![header(["a_m", "a_A", "δ_m", "δ_s", "δ_c", "δ_A", "F_m"])];
    for (_, label, p) in r.relative_difference.labelled() {
        if let Some(p) = p {
            rows.push(row(label, p, [100.0; 7]));
        }
    }
    out!("{}", layout(&rows))?;
    for note in &r.notes {
        outln!("  {note}")?;
    }
    let fb = &r.force_balance;
    outln!(
        "\nforce balance  <F> = {:.9} mN,  m g - k(<x_s> - x_k) = {:.9} mN,  relative error {:.2e}  ({})",
        fb.force_mean * 1e3,
        fb.predicted * 1e3,
        fb.relative_error,
        if fb.holds {
            "holds"
        } else {
            "VIOLATED: internal inconsistency"
        }
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_never_run_together() {
        let rows = vec![
            vec!["".to_string(), "δ_A µm".into(), "F_m mN".into()],
            vec![
                "imposed area".to_string(),
                "346.30626".into(),
                "-1379.26544".into(),
            ],
            vec!["x".to_string(), "—".into(), "1.000e5".into()],
        ];
        let t = layout(&rows);
        assert!(t.contains("346.30626  -1379.26544"), "{t}");
        for line in t.lines() {
            assert!(!line.contains("6-1"), "{t}");
        }
        // Right-aligned under their headers.
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines[0].chars().count(), lines[1].chars().count(), "{t}");
    }
}
