//! `djkr fit DATA.csv --scenario FILE --free KEY[=LO:HI]... --out DIR`: thin over [`djkr::fit`].

use super::signals;
use super::sweep::Interrupted;
use anyhow::{bail, Context, Result};
use clap::Args;
use djkr::fit::{self, FitData, FitEvent, FitOptions, ForwardModel, FreeKey};
use djkr::scenario::overrides::Override;
use djkr::scenario::parse::ScenarioSource;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Flags of `djkr fit`.
#[derive(Args, Debug)]
#[command(after_help = FIT_HELP)]
pub struct FitArgs {
    /// Data CSV: one column per condition named by its scenario key with its unit
    /// (`base.amplitude [um]`), one observable named as in sweep.csv
    /// (`pull_off_amplification [1]`), optionally `sigma [unit of the observable]`.
    data: PathBuf,
    /// Scenario file (TOML): each data row is it with the row's conditions set.
    #[arg(long, value_name = "FILE")]
    scenario: PathBuf,
    /// A key to fit (repeatable), optionally bounded: adhesion.n, adhesion.v_sat=0.01:100 (units
    /// welcome; either bound may be left empty). Starts from the scenario's value (or --set's).
    #[arg(long = "free", value_name = "KEY[=LO:HI]", required = true)]
    free: Vec<String>,
    /// The observable column to fit, when the file has several.
    #[arg(long, value_name = "NAME")]
    observable: Option<String>,
    /// A value for every row (repeatable), as `djkr run --set` takes it.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Predict each row as the mean over N runs with base phases drawn from --seed (the same at
    /// every evaluation); the ensemble's standard error joins sigma.
    #[arg(long, value_name = "N")]
    ensemble: Option<usize>,
    /// Seed of the ensemble's phases [default: 0].
    #[arg(long, value_name = "S")]
    seed: Option<u64>,
    /// Runs at a time [default: one per core].
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    /// Most iterations (Jacobians) of Levenberg–Marquardt.
    #[arg(long, value_name = "N", default_value_t = 30)]
    max_iterations: usize,
    /// Print fit.json on stdout.
    #[arg(long)]
    json: bool,
    /// Output folder for fit.json, residuals.csv, fitted.toml, fit.png, fit.svg
    /// [default: out/<data name>-fit].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Overwrite files of those names in --out that djkr did not write.
    #[arg(long)]
    force: bool,
}

const FIT_HELP: &str = "Example (the law comparison of docs/guide/fit.md):
  djkr fit data.csv --scenario scenarios/paper-protocol-300hz.toml \\
      --free adhesion.v0 --free adhesion.n --out out/fit-gs
Exit status: 0 fitted (fit.json says whether it converged), 2 bad input, 130 Ctrl-C (the best
estimate so far is written).";

/// The files a fit writes.
const FILES: [&str; 5] = [
    "fit.json",
    "residuals.csv",
    "fitted.toml",
    "fit.png",
    "fit.svg",
];

/// Run `djkr fit`.
pub fn fit(a: &FitArgs) -> Result<()> {
    if a.jobs == Some(0) {
        bail!("--jobs 0: must be a whole number >= 1 (runs at a time)");
    }
    let ensemble = match (a.ensemble, a.seed) {
        (Some(0), _) => bail!("--ensemble 0: must be a whole number >= 1 (members per row)"),
        (Some(m), s) => Some((m, s.unwrap_or(0))),
        (None, Some(s)) => bail!("--seed {s}: seeds the ensemble's phases; add --ensemble N"),
        (None, None) => None,
    };
    let free = FreeKey::parse_all(&a.free).map_err(anyhow::Error::msg)?;
    let all_set = a
        .set
        .iter()
        .map(|s| Override::parse(s))
        .collect::<Result<Vec<_>, _>>()?;
    // A --set of a free key gives its starting value; the others hold for every row.
    let (starts, fixed): (Vec<Override>, Vec<Override>) = all_set
        .into_iter()
        .partition(|o| free.iter().any(|f| f.key == o.key()));
    let data = FitData::read(&a.data, a.observable.as_deref())?;
    let source = ScenarioSource::read(&a.scenario)?;
    let with_starts: Vec<Override> = fixed.iter().chain(&starts).cloned().collect();
    let scn = source.scenario(&with_starts)?;
    let x0 = free
        .iter()
        .map(|f| fit::initial_value(&source, &starts, f).map_err(anyhow::Error::msg))
        .collect::<Result<Vec<_>>>()?;
    fit::check_start(&free, &x0)?;
    let model = ForwardModel::new(
        source.clone(),
        data,
        free.iter().map(|f| f.key).collect(),
        fixed.clone(),
        ensemble,
        a.jobs.unwrap_or(0),
    )
    .map_err(anyhow::Error::msg)?;
    let out = a.out.clone().unwrap_or_else(|| default_out(&a.data));
    // Installed before the folder is claimed and locked, so that a Ctrl-C from then on (even
    // while the first evaluation runs) ends the fit through the stop flag, never half-way.
    signals::install(
        "stopping: forward runs in progress are abandoned and the best estimate so far is \
         written (none before the first evaluation has ended); Ctrl-C again to quit at once",
    );
    super::common::claim_out(&out, &FILES, a.force).context("--out")?;
    let _lock = djkr::output::folder::DirLock::acquire(&out)?;
    let per_iteration = model.runs_per_set() * fit::sets_per_iteration(model.members(), free.len());
    let bar = ProgressBar::new((model.runs_per_set() + 6 * per_iteration) as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed}] {bar:30} {pos}/{len} runs (length grows if the fit needs \
             more), ETA {eta} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let opts = FitOptions {
        max_iterations: a.max_iterations,
        stop: Some(signals::flag()),
    };
    let mut progress = |e: FitEvent| match e {
        FitEvent::Run => {
            if bar.position() + 1 >= bar.length().unwrap_or(0) {
                bar.inc_length(per_iteration as u64);
            }
            bar.inc(1);
        }
        FitEvent::Best { iteration, chi2 } => {
            let line = format!("iteration {iteration}, best chi2 {chi2:.6e}");
            // Without a terminal (a log, a pipe) the bar is hidden: each new best is a line.
            if bar.is_hidden() {
                eprintln!("fit: {line} after {} forward runs", bar.position());
            }
            bar.set_message(line);
        }
    };
    let outcome = fit::fit(&model, &free, &x0, scn.solver.rtol, opts, &mut progress);
    bar.finish_and_clear();
    let outcome = match outcome {
        Err(e) if e.stopped => {
            eprintln!("stopped: {e}; nothing written in {}", out.display());
            return Err(Interrupted(signals::received()).into());
        }
        o => o?,
    };
    let header = format!(
        "Written by djkr fit: {} with the estimates of {}\nfrom {} (fit.json beside this file). \
         Each value written in says so in a comment.\n{}",
        source.name(),
        outcome
            .report
            .parameters
            .iter()
            .map(|p| format!(
                "{} = {} {}",
                p.key,
                djkr::output::table::format_f64(p.value),
                p.unit
            ))
            .collect::<Vec<_>>()
            .join(", "),
        model.data().name,
        if fixed.is_empty() {
            String::new()
        } else {
            format!(
                "With {}.",
                fixed
                    .iter()
                    .map(|o| format!("--set {o}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            )
        }
    );
    let toml = fit::fitted_toml(&source, &fixed, &free, &outcome.values, &header)
        .map_err(anyhow::Error::msg)?;
    let json = serde_json::to_string_pretty(&outcome.report)?;
    write(&out, "fit.json", format!("{json}\n").as_bytes())?;
    write(
        &out,
        "residuals.csv",
        fit::residuals_csv(&model, &outcome).as_bytes(),
    )?;
    write(&out, "fitted.toml", toml.as_bytes())?;
    let fig = fit::fit_figure(&model, &outcome);
    djkr::plot::render(&fig, &out.join("fit")).context("fit.png/fit.svg")?;
    for n in &outcome.report.notes {
        eprintln!("note: {n}");
    }
    if a.json {
        outln!("{json}")?;
    } else {
        report(&outcome.report, &out)?;
    }
    if outcome.report.interrupted {
        eprintln!(
            "stopped: the files in {} hold the best estimate so far",
            out.display()
        );
        return Err(Interrupted(signals::received()).into());
    }
    Ok(())
}

/// Write one of the fit's files atomically.
fn write(out: &Path, name: &str, bytes: &[u8]) -> Result<()> {
    djkr::output::write_atomic(&out.join(name), bytes).with_context(|| format!("--out {name}"))
}

/// `--out` left out: out/<data name>-fit.
fn default_out(data: &Path) -> PathBuf {
    super::common::default_out(data, "-fit")
}

/// A fit statistic to `decimals` decimals, or in e-notation from 1e9 (a poor fit's chi2 of
/// 3e306 printed its 307 digits).
fn statistic(x: f64, decimals: usize) -> String {
    if x.abs() < 1e9 {
        format!("{x:.decimals$}")
    } else {
        format!("{x:.decimals$e}")
    }
}

/// The readable report.
fn report(r: &djkr::fit::FitReport, out: &Path) -> Result<()> {
    outln!(
        "fit of {} to {} rows: chi2 {}, dof {}, reduced chi2 {}, AIC {}, BIC {}",
        r.observable,
        r.rows,
        statistic(r.chi2, 4),
        r.dof,
        statistic(r.reduced_chi2, 4),
        statistic(r.aic, 3),
        statistic(r.bic, 3)
    )?;
    outln!(
        "  {} in {} iteration(s), {} forward runs, {:.1} s",
        match (
            r.converged,
            r.notes.iter().any(|n| n.starts_with("poor fit"))
        ) {
            (true, false) => "converged",
            (true, true) => "converged to a poor fit (see the note)",
            (false, _) => "NOT converged",
        },
        r.iterations,
        r.forward_runs,
        r.wall_s
    )?;
    for p in &r.parameters {
        let unit = if p.unit == "1" {
            String::new()
        } else {
            format!(" {}", p.unit)
        };
        let no_sigma = if p.sigma.is_some() {
            ""
        } else {
            " (no sigma: see the notes)"
        };
        outln!(
            "  {} = {}{unit}{no_sigma}  (from {})",
            p.key,
            djkr::output::table::format_pm(p.value, p.sigma),
            djkr::output::table::format_f64(p.initial)
        )?;
    }
    outln!(
        "wrote fit.json, residuals.csv, fitted.toml, fit.png, fit.svg in {}",
        out.display()
    )?;
    Ok(())
}
