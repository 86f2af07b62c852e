//! `djkr fit DATA.csv --scenario FILE --free KEY[=LO:HI]... --out DIR`: thin over [`crate::fit`].

use super::signals;
use super::sweep::Interrupted;
use crate::fit::{self, FitData, FitEvent, FitOptions, ForwardModel, FreeKey};
use crate::scenario::overrides::Override;
use crate::scenario::parse::ScenarioSource;
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Flags of `djkr fit`.
#[derive(Args, Debug)]
#[command(after_help = fit_help())]
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
    /// Most iterations (Jacobians) of each run of Levenberg–Marquardt (each start, each refit).
    #[arg(long, value_name = "N", default_value_t = 30)]
    max_iterations: usize,
    /// Fit from N starting points: the given one and N - 1 drawn by Latin hypercube (between
    /// a key's bounds, or a factor 10 either side of the start in log space, +-50 % for a linear
    /// key); fit.json lists every start and the minimum it reached, and the best is the estimate.
    #[arg(long, value_name = "N", default_value_t = 1)]
    starts: usize,
    /// Give every key its profile-likelihood interval (chi2 + 1, the other keys refitted);
    /// without it only where the model is not linear over one sigma.
    #[arg(long)]
    profile: bool,
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

/// At most this many starts (each a whole fit).
const MAX_STARTS: usize = 1000;

const FIT_HELP: &str = "Example (the law comparison of docs/guide/fit.md):
  djkr fit data.csv --scenario scenarios/paper-protocol-300hz.toml \\
      --free adhesion.v0 --free adhesion.n --out out/fit-gs
The optimiser is Levenberg-Marquardt with Nielsen's damping: a failed step raises the damping and
tries again; it stops when the Gauss-Newton step would lower chi2 by less than 1e-3 (converged),
when two steps lowered chi2 by less than 1e-6 of it, when no step changes the parameters by more
than 1e-6, or after --max-iterations. A fit that did not converge gets no sigma. At the estimate
the linear model is checked at +-1 sigma; where it fails (a jump of the model) the key's interval
is its profile likelihood's (--profile: for every key). The forward runs' tolerances follow from
the data's sigma (a model error of at most 1 % of it, checked at the estimate; --set
solver.rtol=... or solver.envelope_tol=... wins).
Exit status: 0 fitted (fit.json says whether it converged), 2 bad input, 130 Ctrl-C (the best
estimate so far is written).";

/// The help after the flags: [`FIT_HELP`] and the keys that can be freed.
fn fit_help() -> String {
    format!(
        "{FIT_HELP}\n\nKeys that can be freed (the rig's and its protocol's physical constants; \
         solver.*, output.*, stage durations and limits are refused): {}",
        fit::fittable_keys().join(", ")
    )
}

/// Run `djkr fit`.
pub fn fit(a: &FitArgs) -> Result<()> {
    if a.jobs == Some(0) {
        bail!("--jobs 0: must be a whole number >= 1 (runs at a time)");
    }
    if a.starts == 0 {
        bail!("--starts 0: must be a whole number >= 1 (starting points)");
    }
    if a.starts > MAX_STARTS {
        bail!(
            "--starts {}: at most {MAX_STARTS} starting points",
            a.starts
        );
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
    // The scenario with the overrides must parse (its errors are the user's).
    source.scenario(&with_starts)?;
    let x0 = free
        .iter()
        .map(|f| fit::fitted::initial_value(&source, &starts, f).map_err(anyhow::Error::msg))
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
    super::common::claim_out(&out, &fit::files::FILES, a.force).context("--out")?;
    let _lock = crate::output::folder::DirLock::acquire(&out)?;
    let expected0 = fit::expected_runs(&model, free.len(), a.starts);
    let bar = ProgressBar::new(expected0 as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed}] {prefix} {bar:30} {pos}/{len} runs (expected; grows if the fit needs \
             more), ETA {eta} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let opts = FitOptions {
        max_iterations: a.max_iterations,
        starts: a.starts,
        profile: a.profile,
        stop: Some(signals::flag()),
    };
    let t0 = std::time::Instant::now();
    let mut expected = expected0;
    let mut runs = 0usize;
    let mut started = false;
    let mut progress = |e: FitEvent| match e {
        FitEvent::Run => {
            runs += 1;
            if runs >= expected {
                expected = runs + runs / 4 + 1;
                bar.set_length(expected as u64);
            }
            bar.inc(1);
        }
        FitEvent::Stage {
            what,
            runs_expected,
        } => {
            if runs + runs_expected > expected {
                expected = runs + runs_expected;
                bar.set_length(expected as u64);
            }
            // Without a terminal (a log, a pipe) the bar is hidden: each stage is a line, from
            // the first iteration's on (input refused at the starting values stays one line).
            if bar.is_hidden() && started {
                eprintln!("fit: {what}");
            }
            bar.set_prefix(what);
        }
        FitEvent::Iteration {
            iteration,
            chi2,
            best,
            runs: done,
        } => {
            started = true;
            let line = format!("iteration {iteration}, best chi2 {best:.6e}, chi2 {chi2:.6e}");
            // Without a terminal: one line per iteration, with the runs and the times.
            if bar.is_hidden() {
                let el = t0.elapsed().as_secs_f64();
                let eta = if done > 0 {
                    el / done as f64 * expected.saturating_sub(done) as f64
                } else {
                    f64::NAN
                };
                eprintln!(
                    "fit: {line}, {done} of about {expected} forward runs, {el:.1} s elapsed, \
                     ETA {eta:.0} s"
                );
            }
            bar.set_message(line);
        }
    };
    let outcome = fit::fit(&model, &free, &x0, opts, &mut progress);
    bar.finish_and_clear();
    let outcome = match outcome {
        Err(e) if e.stopped => {
            eprintln!("stopped: {e}; nothing written in {}", out.display());
            return Err(Interrupted(signals::received()).into());
        }
        o => o?,
    };
    // The figure's model on a grid of the plotted condition: more runs, with their own bar.
    let with_sigma = outcome
        .report
        .parameters
        .iter()
        .filter(|p| p.sigma.is_some())
        .count();
    let grid_runs = fit::figure::curve_runs(&model, with_sigma);
    let bar = ProgressBar::new(grid_runs as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed}] fit.png: the model on a grid {bar:30} {pos}/{len} runs, ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    if bar.is_hidden() && grid_runs > 0 && !outcome.report.interrupted {
        eprintln!(
            "fit: fit.png: the model on a grid of the plotted condition ({grid_runs} forward runs)"
        );
    }
    let json = fit::files::write(
        &out,
        &source,
        &fixed,
        &free,
        &model,
        &outcome,
        Some(signals::flag()),
        &mut || bar.inc(1),
    )
    .map_err(anyhow::Error::msg)
    .context("--out")?;
    bar.finish_and_clear();
    for n in &outcome.report.notes {
        eprintln!("note: {n}");
    }
    if a.json {
        outln!("{json}")?;
    } else {
        report(&outcome.report, &out)?;
    }
    if outcome.report.interrupted || signals::flag().load(std::sync::atomic::Ordering::SeqCst) {
        eprintln!(
            "stopped: the files in {} hold the best estimate so far",
            out.display()
        );
        return Err(Interrupted(signals::received()).into());
    }
    Ok(())
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
fn report(r: &crate::fit::FitReport, out: &Path) -> Result<()> {
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
        let interval = match (p.interval, p.interval_from) {
            (Some([lo, hi]), Some("profile")) => format!(
                ", 68 % interval [{}, {}]{unit} (profile likelihood)",
                crate::output::table::format_sig(lo, 4),
                crate::output::table::format_sig(hi, 4)
            ),
            _ => String::new(),
        };
        outln!(
            "  {} = {}{unit}{no_sigma}{interval}  (from {})",
            p.key,
            crate::output::table::format_pm(p.value, p.sigma),
            crate::output::table::format_f64(p.initial)
        )?;
    }
    outln!(
        "wrote fit.json, residuals.csv, fitted.toml, fit.png, fit.svg in {}",
        out.display()
    )?;
    Ok(())
}
