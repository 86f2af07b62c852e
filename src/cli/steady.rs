//! Flags and helpers shared by the periodic-steady-state commands: `djkr validate`
//! ([`super::validate`]), `djkr resonance` ([`super::resonance`]) and `djkr shortcut-map`
//! ([`super::shortcut_map`]).

use super::common::{positive_quantity, SetArgs};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use djkr_core::steady::{Options, Strategy};
use djkr_core::units::Dimension;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;
use std::time::Duration;

/// How to find the steady state.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum MethodArg {
    /// Shooting, falling back to time-stepping.
    Auto,
    /// Shooting only (Newton on the one-cycle map).
    Shooting,
    /// Time-stepping with stroboscopic detection only.
    TimeStepping,
}

/// Settings shared by the three commands.
#[derive(Args, Debug, Clone)]
pub struct SteadyArgs {
    /// Steady-state method.
    #[arg(long, value_enum, default_value = "auto")]
    method: MethodArg,
    /// Tolerance on the scaled once-per-cycle residual (x_s by the indentation amplitude, v_s by
    /// ω times it, a by the mean radius).
    #[arg(
        long,
        default_value = "1e-8",
        value_name = "TOL",
        allow_hyphen_values = true
    )]
    tol: String,
    /// Relative tolerance of the time integration (overrides the scenario's).
    #[arg(
        long,
        default_value = "1e-10",
        value_name = "RTOL",
        allow_hyphen_values = true
    )]
    rtol: String,
    /// Cycle budget of time-stepping.
    #[arg(long, default_value = "20000", value_name = "N")]
    max_cycles: u64,
    #[command(flatten)]
    pub set: SetArgs,
}

impl SteadyArgs {
    pub fn options(&self) -> Result<Options> {
        let tol = positive_quantity("--tol", &self.tol, Dimension::Dimensionless)?;
        let rtol = positive_quantity("--rtol", &self.rtol, Dimension::Dimensionless)?;
        if tol >= 1.0 {
            bail!("--tol = {}: must be in (0, 1)", self.tol);
        }
        if rtol >= 1e-3 {
            bail!("--rtol = {}: must be in (0, 1e-3)", self.rtol);
        }
        if self.max_cycles == 0 {
            bail!("--max-cycles = 0: must be >= 1");
        }
        Ok(Options {
            tol,
            rtol,
            max_cycles: self.max_cycles,
            strategy: match self.method {
                MethodArg::Auto => Strategy::Auto,
                MethodArg::Shooting => Strategy::Shooting,
                MethodArg::TimeStepping => Strategy::TimeStepping,
            },
            ..Options::default()
        })
    }
}

/// Parse START:STOP:COUNT with units ([`crate::api::range`]).
pub fn range(flag: &str, text: &str, dim: Dimension, max: usize) -> Result<(f64, f64, usize)> {
    Ok(crate::api::range(flag, text, dim, max)?)
}

/// The scenario file's name without extension.
pub fn stem(file: &Path) -> String {
    file.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scenario".into())
}

/// A progress bar (hidden when stderr is not a terminal).
pub fn progress_bar(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} [{{elapsed}}] {what} {{bar:30}} {{pos}}/{{len}} {{msg}}"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}
