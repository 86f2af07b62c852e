//! `djkr design --fit DIR --candidates KEY=SPEC... --add K --out DIR`: thin over
//! [`crate::api::design`] (the call Python's `djkr.design` makes).

use super::signals;
use super::sweep::Interrupted;
use crate::fit::design::{self, DesignRequest, Sigma, Target};
use crate::fit::predict::{Cell, FitFolder};
use crate::sweep::Axis;
use anyhow::{anyhow, bail, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Duration;

/// Flags of `djkr design`.
#[derive(Args, Debug)]
#[command(after_help = DESIGN_HELP)]
pub struct DesignArgs {
    /// The folder a `djkr fit` wrote (fit.json, fitted.toml, residuals.csv).
    #[arg(long, value_name = "DIR")]
    fit: PathBuf,
    /// The conditions one could measure, as `djkr sweep --set` takes them (several make the
    /// Cartesian grid, first key slowest): --candidates base.frequency=200:500:7
    /// base.amplitude=5um:100um:20. Not a key the fit estimated.
    #[arg(long, value_name = "KEY=SPEC", num_args = 1.., required = true)]
    candidates: Vec<String>,
    /// New measurements to choose (K >= 1); a candidate may be chosen more than once (repeats)
    /// unless --no-repeats.
    #[arg(long, value_name = "K")]
    add: usize,
    /// Expected sigma of a new measurement: a percentage of the prediction (2%) or a value in
    /// the observable's unit (units allowed) [default: the fit's data's median relative sigma].
    #[arg(long, value_name = "VALUE|REL%")]
    sigma: Option<String>,
    /// What the design minimises: D (the determinant of the keys' covariance), A (the sum of
    /// their variances, in the fit coordinates) or a free key (its variance).
    #[arg(long, value_name = "D|A|KEY", default_value = "D")]
    criterion: String,
    /// Measure each candidate at most once.
    #[arg(long)]
    no_repeats: bool,
    /// Runs at a time [default: one per core].
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    /// Print design.json on stdout.
    #[arg(long)]
    json: bool,
    /// Output folder for design.csv, design.json, design.png and design.svg.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Overwrite files of those names in --out that djkr did not write.
    #[arg(long)]
    force: bool,
}

const DESIGN_HELP: &str = "Example (after `djkr fit ... --out out/fit`):
  djkr design --fit out/fit --candidates base.frequency=200:500:4 base.amplitude=10um:60um:6 \\
      --add 6 --out out/design
The current information is the inverse of the fit's covariance (in its coordinates: log for a
positive scale). For each candidate: the model's change from -1 to +1 sigma of each free key
(a secant in the fit's coordinates, not a local slope), divided by the expected sigma of a
measurement there. K measurements are chosen greedily, then exchanged one at a time (Fedorov)
while that improves the criterion. Reported, for them and for K spread uniformly over the
candidates: each key's expected sigma and the correlations (design.json); which candidates to
measure how many times (design.csv: repeats). The expected sigma are linear predictions: a fit
of the new data confirms them. Forward runs: candidates x (1 + 2 x free keys).
Exit status: 0 designed, 2 bad input, 130 Ctrl-C (nothing written).";

/// `KEY=SPEC` of `--candidates`, refused in the flag's own words.
fn axis(text: &str) -> Result<Axis> {
    Axis::parse(text).map_err(|e| {
        anyhow!(
            "--candidates {}: {}",
            e.set,
            crate::error::render(&e.message, &super::words::Flags)
        )
    })
}

/// Run `djkr design`.
pub fn design(a: &DesignArgs) -> Result<()> {
    if a.jobs == Some(0) {
        bail!("--jobs 0: must be a whole number >= 1 (runs at a time)");
    }
    let candidates = a
        .candidates
        .iter()
        .map(|s| axis(s))
        .collect::<Result<Vec<_>>>()?;
    let mut req = DesignRequest::new(candidates, a.add);
    req.criterion = Target::parse(&a.criterion);
    req.repeats = !a.no_repeats;
    req.jobs = a.jobs.unwrap_or(0);
    // Everything that can be refused is, before the output folder is claimed, in this order:
    // K and the candidates, the folder, what the fit refuses, the σ (read for the fit's
    // observable).
    design::check_request(&req)?;
    let fit = FitFolder::read(&a.fit)?;
    if let Some(text) = &a.sigma {
        design::check_before_sigma(&fit, &req)?;
        req.sigma = Some(Sigma::parse(text, &fit)?);
    }
    design::check(&fit, &req)?;
    signals::install("stopping: forward runs in progress are abandoned; nothing is written");
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed}] design: {pos} forward runs")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let report = crate::api::design_with_progress(
        &fit,
        &req,
        Some((a.out.clone(), a.force)),
        Some(signals::flag()),
        &mut || bar.inc(1),
    );
    bar.finish_and_clear();
    let report = match report {
        Err(crate::error::Error::Cancelled) => {
            eprintln!("stopped: nothing written in {}", a.out.display());
            return Err(Interrupted(signals::received()).into());
        }
        r => r?,
    };
    let json = serde_json::to_string_pretty(&report)?;
    if a.json {
        println!("{json}");
    } else {
        for n in &report.notes {
            eprintln!("note: {n}");
        }
        // Three digits: the expected sigma are linear predictions, not measurements.
        let sig = |m: &std::collections::BTreeMap<String, f64>, k: &str| {
            m.get(k)
                .map_or("?".into(), |&v| djkr_core::text::format_sig(v, 3))
        };
        for (k, u) in report.keys.iter().zip(&report.key_units) {
            let u = if u == "1" {
                String::new()
            } else {
                format!(" {u}")
            };
            eprintln!(
                "{k}: sigma now {}{u}, after the design {}{u}, after {} uniform {}{u}",
                sig(&report.current_sigma, k),
                sig(&report.expected_sigma, k),
                report.add,
                sig(&report.uniform_sigma, k),
            );
        }
        let units: std::collections::BTreeMap<&str, Option<&str>> = report
            .conditions
            .iter()
            .map(|c| (c.key.as_str(), c.unit))
            .collect();
        for c in &report.chosen {
            let at: Vec<String> = c
                .conditions
                .iter()
                .map(
                    |(k, v)| match (v, units.get(k.as_str()).copied().flatten()) {
                        (Cell::Num(x), Some(u)) => {
                            let (f, unit) = crate::plot::display_unit(u, &[*x]);
                            format!(
                                "{k} = {} {}",
                                crate::plot::tick_label(x * f),
                                crate::plot::unit_text(&unit)
                            )
                        }
                        (Cell::Num(x), None) => format!("{k} = {x}"),
                        (Cell::Text(t), _) => format!("{k} = {t}"),
                    },
                )
                .collect();
            eprintln!(
                "measure {} x (row {} of design.csv): {}",
                c.repeats,
                c.row,
                at.join(", ")
            );
        }
        eprintln!(
            "design: {} candidates, {} forward runs: {}",
            report.candidates.len(),
            report.forward_runs,
            a.out.join("design.csv").display()
        );
    }
    Ok(())
}
