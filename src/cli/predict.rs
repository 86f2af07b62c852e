//! `djkr predict --fit DIR [--set KEY=SPEC]... [--observable NAME] [--samples N]
//! [--ensemble N] [--seed S] --out DIR`: thin over [`crate::fit::predict`].

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
    /// The quantity to predict, as named in sweep.csv: pull_off_force, pull_off_amplification,
    /// pull_off_time, force_mean, delta_mean, delta_amp [default: the fit's].
    #[arg(long, value_name = "NAME")]
    observable: Option<String>,
    /// Also propagate by N parameter draws from the fit's distribution (in the fit
    /// coordinates): the column sigma_samples.
    #[arg(long, value_name = "N", default_value_t = 0)]
    samples: usize,
    /// Each value the mean of N runs of base phases drawn from --seed (chaotic rigs):
    /// sigma_ensemble is its standard error [default: the fit's ensemble, if it had one].
    #[arg(long, value_name = "N")]
    ensemble: Option<usize>,
    /// Seed of the draws of --samples and of the phases of --ensemble [default: 0].
    #[arg(long, value_name = "S")]
    seed: Option<u64>,
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
(sigma_parameters), with an ensemble the standard error of its mean (sigma_ensemble; a fit
made with --ensemble lends its own), sigma = sqrt(sigma_parameters^2 + sigma_ensemble^2), the
68 % and 95 % bands (value -+ sigma, -+ 1.96 sigma), and with --samples the standard deviation
over N parameter draws (sigma_samples; a note where it differs from sigma by more than a
factor 1.5: the model is not linear there, trust the samples). Forward runs: points x
(2 + free keys) + points x samples, each times the members with an ensemble (whose Jacobian is
central: 1 + 2 x free keys, more where a step widens).
Exit status: 0 predicted, 2 bad input, 130 Ctrl-C (nothing written).";

/// Run `djkr predict`.
pub fn predict(a: &PredictArgs) -> Result<()> {
    if a.jobs == Some(0) {
        bail!("--jobs 0: must be a whole number >= 1 (runs at a time)");
    }
    let grid = a
        .set
        .iter()
        .map(|s| Axis::parse(s))
        .collect::<Result<Vec<_>, _>>()?;
    let req = PredictRequest {
        grid,
        observable: a.observable.clone(),
        ensemble: a.ensemble.map(|m| (m, a.seed.unwrap_or(0))),
        samples: a.samples,
        seed: a.seed,
        jobs: a.jobs.unwrap_or(0),
    };
    // The fit is read (and a folder without one refused), and the request checked, before the
    // output folder is claimed.
    let fit = predict::FitFolder::read(&a.fit)?;
    predict::check(&fit, &req)?;
    signals::install("stopping: forward runs in progress are abandoned; nothing is written");
    super::common::claim_out(&a.out, &predict::FILES, a.force).context("--out")?;
    let _lock = crate::output::folder::DirLock::acquire(&a.out)?;
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed}] predict: {pos} forward runs")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let report = predict::predict(&fit, &req, Some(signals::flag()), &mut || bar.inc(1));
    bar.finish_and_clear();
    let report = match report {
        Err(crate::error::Error::Cancelled) => {
            eprintln!("stopped: nothing written in {}", a.out.display());
            return Err(Interrupted(signals::received()).into());
        }
        r => r?,
    };
    let (json, figure) = predict::write(&a.out, &report, &fit)
        .map_err(anyhow::Error::msg)
        .context("--out")?;
    if !figure {
        eprintln!(
            "note: no figure: no numeric condition takes two values in the grid (give --set \
             KEY=SPEC with several values)"
        );
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
