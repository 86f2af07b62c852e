//! `djkr validate`: the periodic steady state of a scenario (shooting, with time-stepping as the
//! fallback) compared with the imposed-area method, the linear transfer, the paper's printed
//! equations and harmonic balance, and the force-balance check.

use super::common::load_scenario;
use super::common::print_json;
use super::steady::SteadyArgs;
use anyhow::{bail, Context, Result};
use clap::Args;
use djkr::steady::crosscheck::{self, Prediction};
use djkr::steady::report::ValidateReport;
use indicatif::ProgressBar;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Flags of `djkr validate`.
#[derive(Args, Debug)]
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
    let bar = ProgressBar::new_spinner();
    bar.set_message("finding the periodic steady state");
    bar.enable_steady_tick(Duration::from_millis(200));
    let c = crosscheck::compare(&scn.plan(), &opts);
    bar.finish_and_clear();
    let c = c.with_context(|| format!("{}", a.file.display()))?;
    let report = ValidateReport::new(&c);
    if a.json {
        print_json(&report)?;
    } else {
        print_report(&a.file, &report);
    }
    let fb = &report.force_balance;
    if !fb.holds {
        bail!(
            "internal inconsistency: the force balance <F> = m g - k(<x_s> - x_k) fails by {:.3e} (relative), above {:.0e}",
            fb.relative_error,
            fb.tolerance
        );
    }
    Ok(())
}

fn cell(v: Option<f64>, scale: f64) -> String {
    match v {
        Some(x) if x.is_finite() && (x * scale).abs() < 1e4 => format!("{:>11.5}", x * scale),
        Some(x) if x.is_finite() => format!("{:>11.3e}", x * scale),
        _ => format!("{:>11}", "—"),
    }
}

fn row(label: &str, p: &Prediction, scales: [f64; 7]) -> String {
    let mut line = format!("{label:<20}");
    for ((_, v), sc) in p.fields().iter().zip(scales) {
        line.push_str(&cell(*v, sc));
    }
    line
}

fn print_report(file: &Path, r: &ValidateReport) {
    let s = &r.steady;
    println!(
        "{}: periodic steady state at f = {} Hz, X_b = {:.6} µm",
        file.display(),
        r.frequency,
        r.amplitude * 1e6
    );
    println!(
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
    );
    if let Some(f) = r.linear_resonance {
        println!("  linear resonance √((k + k_c)/m)/2π = {f:.3} Hz (k_c = 3/2 K a_0)");
    }
    println!();
    println!(
        "{:<20}{:>11}{:>11}{:>11}{:>11}{:>11}{:>11}{:>11}",
        "", "a_m mm", "a_A µm", "δ_m µm", "δ_s µm", "δ_c µm", "δ_A µm", "F_m mN"
    );
    let scales = [1e3, 1e6, 1e6, 1e6, 1e6, 1e6, 1e3];
    println!("{}", row("time domain", &r.time_domain, scales));
    for (_, label, p) in r.predictors.labelled() {
        if let Some(p) = p {
            println!("{}", row(label, p, scales));
        }
    }
    println!("\nrelative difference from the time domain, % (δ_s, δ_c relative to δ_A):");
    println!(
        "{:<20}{:>11}{:>11}{:>11}{:>11}{:>11}{:>11}{:>11}",
        "", "a_m", "a_A", "δ_m", "δ_s", "δ_c", "δ_A", "F_m"
    );
    for (_, label, p) in r.relative_difference.labelled() {
        if let Some(p) = p {
            println!("{}", row(label, p, [100.0; 7]));
        }
    }
    for note in &r.notes {
        println!("  {note}");
    }
    let fb = &r.force_balance;
    println!(
        "\nforce balance  <F> = {:.9} mN,  m g - k(<x_s> - x_k) = {:.9} mN,  relative error {:.2e}  ({})",
        fb.force_mean * 1e3,
        fb.predicted * 1e3,
        fb.relative_error,
        if fb.holds {
            "holds"
        } else {
            "VIOLATED: internal inconsistency"
        }
    );
}
