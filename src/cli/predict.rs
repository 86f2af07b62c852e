//! `djkr predict --fit DIR [--set KEY=SPEC]... [--samples N] --out DIR`: thin over
//! [`crate::fit::predict`].

use super::signals;
use super::sweep::Interrupted;
use crate::fit::predict::{self, PredictRequest};
use crate::sweep::Axis;
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Duration;

/// Flags of `djkr predict`.
#[derive(Args, Debug)]
#[command(after_help = PREDICT_HELP)]
pub struct PredictArgs {
    /// The folder a `djkr fit` wrote (fit.json, fitted.toml, residuals.csv).
    #[arg(long, value_name = "DIR")]
    fit: PathBuf,
    /// A condition and its values (repeatable; several make the Cartesian grid, first key
    /// slowest), as `djkr sweep --set` takes it: base.frequency=200:500:7,
    /// base.amplitude=10um,30um. Without it: the fit's data's own conditions.
    #[arg(long = "set", value_name = "KEY=SPEC")]
    set: Vec<String>,
    /// Also propagate by N parameter draws from the fit's distribution (in the fit
    /// coordinates): the column sigma_samples.
    #[arg(long, value_name = "N", default_value_t = 0)]
    samples: usize,
    /// Seed of the draws.
    #[arg(long, value_name = "S", default_value_t = 0)]
    seed: u64,
    /// Runs at a time [default: one per core].
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    /// Print prediction.json on stdout.
    #[arg(long)]
    json: bool,
    /// Output folder for prediction.csv, prediction.json, prediction.png and prediction.svg.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Overwrite files of those names in --out that djkr did not write.
    #[arg(long)]
    force: bool,
}

const PREDICT_HELP: &str = "Example (after `djkr fit ... --out out/fit`):
  djkr predict --fit out/fit --set base.frequency=250 --set base.amplitude=10um:60um:6 \\
      --samples 100 --out out/predict
For each grid point: the model at the fit's estimate (value), its standard deviation from the
parameters' covariance by linear propagation through the fit's own finite-difference Jacobian
(sigma_parameters), the 68 % and 95 % bands (value -+ sigma, -+ 1.96 sigma), and with
--samples the standard deviation over N parameter draws (sigma_samples; a note where it differs
from sigma_parameters by more than a factor 1.5: the model is not linear there, trust the
samples). Forward runs: points x (2 + free keys) + points x samples.
Exit status: 0 predicted, 2 bad input, 130 Ctrl-C (nothing written).";

/// At most this many draws.
const MAX_SAMPLES: usize = 100_000;

/// Run `djkr predict`.
pub fn predict(a: &PredictArgs) -> Result<()> {
    if a.jobs == Some(0) {
        bail!("--jobs 0: must be a whole number >= 1 (runs at a time)");
    }
    if a.samples == 1 || a.samples > MAX_SAMPLES {
        bail!(
            "--samples {}: must be 0 (none) or from 2 to {MAX_SAMPLES} (a spread needs two)",
            a.samples
        );
    }
    let grid = a
        .set
        .iter()
        .map(|s| Axis::parse(s))
        .collect::<Result<Vec<_>, _>>()?;
    let req = PredictRequest {
        fit: a.fit.clone(),
        grid,
        samples: a.samples,
        seed: a.seed,
        jobs: a.jobs.unwrap_or(0),
    };
    // The fit is read (and a folder without one refused) before the output folder is claimed.
    let fit = predict::FitFolder::read(&req.fit)?;
    signals::install("stopping: forward runs in progress are abandoned; nothing is written");
    super::common::claim_out(&a.out, &predict::FILES, a.force).context("--out")?;
    let _lock = crate::output::folder::DirLock::acquire(&a.out)?;
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed}] predict: {pos} forward runs")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let report = predict::predict(&req, Some(signals::flag()), &mut || bar.inc(1));
    bar.finish_and_clear();
    let report = match report {
        Err(crate::error::Error::Cancelled) => {
            eprintln!("stopped: nothing written in {}", a.out.display());
            return Err(Interrupted(signals::received()).into());
        }
        r => r?,
    };
    let json = serde_json::to_string_pretty(&report)?;
    let put = |name: &str, bytes: &[u8]| -> Result<()> {
        crate::output::write_atomic(&a.out.join(name), bytes).with_context(|| name.to_string())
    };
    put(
        "prediction.csv",
        predict::prediction_csv(&report).as_bytes(),
    )?;
    put("prediction.json", format!("{json}\n").as_bytes())?;
    match predict::prediction_figure(&report, &fit.data) {
        Some(fig) => {
            crate::plot::render(&fig, &a.out.join("prediction"))
                .map_err(|e| anyhow::anyhow!("prediction.png/prediction.svg: {e}"))?;
        }
        None => eprintln!(
            "note: no figure: no numeric condition takes two values in the grid (give --set \
             KEY=SPEC with several values)"
        ),
    }
    if a.json {
        println!("{json}");
    } else {
        for n in &report.notes {
            eprintln!("note: {n}");
        }
        eprintln!(
            "predict: {} points, {} forward runs: {}",
            report.rows.len(),
            report.forward_runs,
            a.out.join("prediction.csv").display()
        );
    }
    Ok(())
}
