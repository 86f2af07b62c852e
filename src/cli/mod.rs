//! Command-line front end. Each subcommand parses its flags, calls the library and reports
//! (a readable table with units, or `--json` with SI values).

#[macro_use]
mod out;

mod accuracy;
mod closed;
mod common;
mod continuation;
mod design;
mod figures;
mod fit;
mod fit_data;
mod imposed;
mod keys;
mod plot;
mod predict;
mod resonance;
mod run;
mod shortcut_map;
mod signals;
mod slurm;
mod steady;
mod sweep;
mod validate;
mod words;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

/// djkr — dynamic JKR adhesion of a sphere on a vibrating viscoelastic substrate.
///
/// Bare numbers are SI; values with units are welcome (51mm, 9.33MPa, 240mJ/m^2, 0.0445mm/s,
/// 1.5kHz). The default material is the paper's Fig. 2 set (K 9.33 MPa, R 51 mm, w0 240 mJ/m²,
/// v0 0.0445 mm/s, n 0.531).
#[derive(Parser, Debug)]
#[command(name = "djkr", version, about, long_about = None, after_help = EXAMPLES)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

const EXAMPLES: &str = "Examples:
  djkr cycle --freq 200 --a-mean 1mm --a-amp 1mm
  djkr pulloff --freq 400Hz --a-amp 0.5mm
  djkr pulloff --freq 400 --a-amp 0.5mm --method approx --beta 2.5 --json
  djkr figures --out out/figures
  djkr run scenarios/paper-protocol-300hz.toml --out out/paper-300hz --plot
  djkr sweep scenarios/paper-protocol-300hz.toml --set base.frequency=200,300,400 --set base.amplitude=10um:60um:6 --out out/study
  djkr sweep scenarios/paper-protocol-300hz.toml --ensemble 32 --seed 1 --out out/phase-spread
  djkr check scenarios/*.toml
  djkr validate scenarios/resonance-400hz.toml
  djkr resonance scenarios/resonance-400hz.toml --freq 300:500:101 --out out/resonance
  djkr continue scenarios/resonance-400hz.toml --param base.frequency --range 340:600 --set base.amplitude=1.5um
  djkr accuracy scenarios/paper-protocol-300hz.toml --methods implicit,auto --out out/accuracy
  djkr fit data.csv --scenario scenarios/paper-protocol-300hz.toml --free adhesion.v0 --free adhesion.n --out out/fit

Bare numbers are SI; values with units are welcome (51mm, 9.33MPa, 240mJ/m^2, 0.0445mm/s, 1.5kHz).
Default material: the paper's Fig. 2 set (K 9.33 MPa, R 51 mm, w0 240 mJ/m^2, v0 0.0445 mm/s, n 0.531).
Scenario-file keys, every command and every result are documented in the user guide, docs/guide/.";

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scenario file with the time-domain simulator (eqs. 30-32): writes summary.json and
    /// run.h5 (and CSV with --csv) into --out, atomically.
    ///
    /// A run stopped by a budget (solver.max_steps, max_wall_s, max_events), by low disk space
    /// (reason "disk"), Ctrl-C or SIGTERM, or failed mid-way, still writes what it computed up
    /// to there, with "status" ("stopped" or "failed"), "reason" and "message" in summary.json.
    /// Exit status: 0 ok, 1 the run failed, 2 bad input (or files that cannot be written), 3
    /// stopped by a budget, low disk space or SIGTERM, 130 Ctrl-C (docs/guide/unattended.md).
    ///
    /// Two times: summary.json "pull_off.time" is when the pull-off force (the most tensile
    /// cycle-averaged force under vibration) was reached; "detachment.time" is when the contact
    /// was lost for good (later). run.h5's cycles/ hold per-period means and first harmonics:
    /// over the base period from t_start, s(t) ~ s_mean + s_sin sin theta + s_cos cos theta with
    /// theta = omega (t - t_on), x_b = X_b sin theta (root attribute "harmonics"); every
    /// dataset is defined in descriptions/ (docs/guide/output.md).
    ///
    /// Gaps: envelope following (solver.envelope = "auto") jumps over base periods where the
    /// vibration drifts slowly, so the time series has gaps (no sample inside; 2 to thousands
    /// of periods). run.h5 lists them in /gaps (t_start, t_end: the samples either side;
    /// periods: periods skipped), /segment numbers the gap-free stretches (0, +1 after each
    /// gap), summary.json "gaps" counts them, --csv writes gaps.csv. Never draw a line across
    /// a gap: run.png breaks its lines there and shades the skipped spans. To record an
    /// interval densely, list it in [output] dense = [[t0, t1], ...] (s); solver.envelope =
    /// "off" gives no gap at all.
    Run(run::RunArgs),
    /// Validate scenario files without running them.
    Check(run::CheckArgs),
    /// Every key a scenario file takes: unit, default, allowed range and meaning (--json: a
    /// list of objects with the fields key, unit, default, range, description). Stage keys are
    /// written stage[].KEY; set one with --set stage[N].KEY=VALUE.
    Keys(keys::KeysArgs),
    /// Sweeps and ensembles over any scenario key (--set KEY=SPEC), in parallel and resumable:
    /// sweep.csv, sweep.h5 (one row per run), points.csv (statistics per point) and plots;
    /// --shard K/N, `djkr sweep merge` and --slurm for clusters.
    ///
    /// A run stopped by a budget is a row with status "stopped", one that failed "error";
    /// --resume runs both again unless --no-retry. Exit status: 0 the sweep ran (whatever its
    /// rows' status), 2 bad input, 3 stopped by SIGTERM, 130 Ctrl-C (resume with --resume).
    Sweep(sweep::SweepArgs),
    /// Draw the figures of an existing run folder (run.png/.svg) or sweep folder.
    Plot(plot::PlotArgs),
    /// One imposed-area cycle (paper Sec. 2.1): a(t) = a_m + a_A sin ωt → δ(t), its mean and
    /// first harmonics (eqs. 25–27), the mean force and the contact fraction.
    Cycle(imposed::CycleArgs),
    /// Pull-off for a given vibration (ω, a_A): the minimum over a_m of the mean force, by the
    /// exact imposed-area method, the closed form (eqs. 20–24), Shui et al. or Yi et al.
    Pulloff(imposed::PulloffArgs),
    /// Eq. (29): the contact-radius speed a_A ω the closed form needs for a target amplification.
    RequiredSpeed(closed::RequiredSpeedArgs),
    /// Refit the speed correction β of eq. (24) against the exact pull-off over a range of n and
    /// v_max/v0 (checks the paper's Fig. 3(b) and β ≈ 2.5), reporting the error curve.
    BetaFit(closed::BetaFitArgs),
    /// Fit the Gent–Schultz constants w0, v0, n (with uncertainties) to a quasi-static unloading
    /// record (CSV: t, a, F), using eq. (28) for w and −ȧ for the crack speed.
    GsFit(fit::GsFitArgs),
    /// Fit free scenario keys (adhesion.v0, adhesion.n, adhesion.v_sat, damping.c, ...) to
    /// measured data (a CSV of conditions and a sweep.csv observable) by weighted least squares
    /// over the full dynamic model (Levenberg-Marquardt): fit.json (estimates, sigma,
    /// correlation, chi2, AIC, BIC), residuals.csv, fitted.toml, fit.png/.svg.
    ///
    /// Exit status: 0 fitted (fit.json says whether it converged), 2 bad input, 130 Ctrl-C
    /// (the best estimate so far is written), 3 SIGTERM.
    Fit(fit_data::FitArgs),
    /// Predict with uncertainty from a fit: the model at the fit's estimate over a grid of
    /// conditions (as `djkr sweep --set`), with sigma from the parameters' covariance (linear
    /// propagation, and with --samples parameter draws) and 68/95 % bands: prediction.csv,
    /// prediction.json. Exit status: 0 predicted, 2 bad input, 130 Ctrl-C
    Predict(predict::PredictArgs),
    /// Choose the next measurements from a fit: K new measurements among candidate conditions
    /// (a grid as `djkr sweep --set`) that minimise the free keys' expected covariance
    /// (D-optimal, A-optimal or one key's variance; greedy, then exchange), against K spread
    /// uniformly: design.csv, design.json, design.png. Exit status: 0 designed, 2 bad input,
    /// 130 Ctrl-C
    Design(design::DesignArgs),
    /// Reproduce the paper's figures (Figs. 2, 3(a), 3(b), 4–8) as CSV + PNG + SVG.
    Figures(figures::FiguresArgs),
    /// Run a scenario to its periodic steady state (shooting, time-stepping as the fallback) and
    /// compare it with the imposed-area method, the linear transfer, the paper's printed
    /// eqs. (37)-(39) and harmonic balance; checks the force balance (exit code 2 if violated).
    Validate(validate::ValidateArgs),
    /// Frequency response by continuation (up and down sweeps): |δ_A/X_b|, phase, F_m, a_m, a_A
    /// per frequency with the linear transfer and harmonic balance; CSV, HDF5 and plots.
    /// solver.max_wall_s (--set, or the scenario's; default 600 s) bounds the whole command: when
    /// it runs out, the files hold the frequencies computed so far and djkr exits with status 3.
    Resonance(resonance::ResonanceArgs),
    /// Continue the periodic orbit in one scenario key (pseudo-arclength, through folds):
    /// stable and unstable branches, Floquet multipliers, folds, period doublings,
    /// Neimark-Sacker points, sweeps overlaid; with --fold-param the fold curves in two keys
    /// (bistability region, cusp). CSV, HDF5 and plots.
    Continue(continuation::ContinueArgs),
    /// Map the error of the imposed-area shortcut against the time-domain steady state over a
    /// grid of frequency and base amplitude (mean force, δ_A); CSV, HDF5 and colour maps.
    /// solver.max_wall_s (--set, or the scenario's; default 600 s) bounds the whole command: when
    /// it runs out, the cells not computed are marked so in the files and djkr exits with
    /// status 3.
    ShortcutMap(shortcut_map::ShortcutMapArgs),
    /// Speed vs accuracy: a work-precision study of the integrators on a scenario FILE (errors
    /// against a converged reference, median wall time, steps, RHS evaluations; CSV, table,
    /// plot), or with --imposed-area, quadrature nodes vs error and the closed form's error map.
    Accuracy(accuracy::AccuracyArgs),
}

/// Entry point: run the command, print errors as one readable message, map to an exit code.
pub fn main() -> ExitCode {
    restore_sigpipe();
    tune_allocator();
    let cli = match parse_args() {
        Ok(cli) => cli,
        Err(e) => {
            eprintln!("error: {}", error_text(&e));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Run(a) => run::run(&a),
        Command::Check(a) => run::check(&a),
        Command::Keys(a) => keys::keys(&a),
        Command::Sweep(a) => sweep::sweep(&a),
        Command::Plot(a) => plot::plot(&a),
        Command::Cycle(a) => imposed::cycle(&a),
        Command::Pulloff(a) => imposed::pulloff(&a),
        Command::RequiredSpeed(a) => closed::required_speed(&a),
        Command::BetaFit(a) => closed::beta_fit(&a),
        Command::GsFit(a) => fit::gs_fit(&a),
        Command::Fit(a) => fit_data::fit(&a),
        Command::Predict(a) => predict::predict(&a),
        Command::Design(a) => design::design(&a),
        Command::Figures(a) => figures::figures(&a),
        Command::Validate(a) => validate::validate(&a),
        Command::Resonance(a) => resonance::resonance(&a),
        Command::Continue(a) => continuation::continuation(&a),
        Command::ShortcutMap(a) => shortcut_map::shortcut_map(&a),
        Command::Accuracy(a) => accuracy::accuracy(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A sweep stopped by a signal has said how to resume: 130 (the shell's code for SIGINT)
        // after Ctrl-C, 3 after SIGTERM.
        Err(e) if e.is::<sweep::Interrupted>() => ExitCode::from(
            e.downcast_ref::<sweep::Interrupted>()
                .map_or(130, |i| i.exit_status()),
        ),
        // A run that ended early has published its files: 1 failed, 3 stopped, 130 Ctrl-C.
        Err(e) if e.is::<run::RunEnded>() => {
            let code = e
                .downcast_ref::<run::RunEnded>()
                .map_or(1, |r| r.exit_status());
            eprintln!(
                "{}: {}",
                if code == 1 { "error" } else { "stopped" },
                error_text(&e)
            );
            ExitCode::from(code)
        }
        // Stopped by a budget after writing what it computed (resonance, shortcut-map).
        Err(e) if e.is::<common::BudgetStopped>() => {
            eprintln!("stopped: {}", error_text(&e));
            ExitCode::from(3)
        }
        // A full disk under `> file` is not bad input: the command ran, its listing was lost.
        Err(e) if e.chain().any(|c| c.is::<out::StdoutError>()) => {
            eprintln!("error: {}", error_text(&e));
            ExitCode::from(1)
        }
        Err(e) => {
            eprintln!("error: {}", error_text(&e));
            ExitCode::from(2)
        }
    }
}

/// Parse the command line. clap's own messages (an invalid value, an unknown argument) quote
/// what was typed through [`djkr_core::text::excerpt`], as every djkr message does; they end djkr
/// here, as `Cli::parse` would (exit status 2, or 0 for `--help` and `--version`). A path
/// argument longer than the system allows is refused (`Err`) before it reaches any message.
fn parse_args() -> anyhow::Result<Cli> {
    let matches = Cli::command()
        .try_get_matches()
        .unwrap_or_else(|e| short_values(e).exit());
    check_path_lengths(&Cli::command(), &matches)?;
    Ok(Cli::from_arg_matches(&matches).unwrap_or_else(|e| short_values(e).exit()))
}

/// `e` with each value it quotes cut to an excerpt (a 100 kB `--method` was echoed whole).
fn short_values(mut e: clap::Error) -> clap::Error {
    use clap::error::ContextValue;
    use djkr_core::text::{excerpt, EXCERPT_CHARS};
    let long = |s: &str| s.chars().count() > EXCERPT_CHARS;
    let cut: Vec<_> = e
        .context()
        .filter_map(|(kind, value)| {
            let short = match value {
                ContextValue::String(s) if long(s) => ContextValue::String(excerpt(s)),
                ContextValue::Strings(v) if v.iter().any(|s| long(s)) => {
                    ContextValue::Strings(v.iter().map(|s| excerpt(s)).collect())
                }
                // A tip quotes the value inside a sentence ("to pass '--x…' as a value, use
                // '-- --x…'"): kept when short, else the sentence is cut.
                ContextValue::StyledStr(s) if long(&s.to_string()) => {
                    ContextValue::String(excerpt(&s.to_string()))
                }
                ContextValue::StyledStrs(v) if v.iter().any(|s| long(&s.to_string())) => {
                    ContextValue::Strings(v.iter().map(|s| excerpt(&s.to_string())).collect())
                }
                _ => return None,
            };
            Some((kind, short))
        })
        .collect();
    for (kind, value) in cut {
        e.insert(kind, value);
    }
    e
}

/// Refuse a path argument that no system call would take ([`crate::api::path_length_error`]),
/// quoting its beginning: every later message names the file by its path, whole, which for
/// such a path would be the 100 kB the user pasted.
fn check_path_lengths(cmd: &clap::Command, m: &clap::ArgMatches) -> anyhow::Result<()> {
    use std::any::TypeId;
    for arg in cmd.get_arguments() {
        if arg.get_value_parser().type_id() != TypeId::of::<std::path::PathBuf>() {
            continue;
        }
        let Some(raw) = m.get_raw(arg.get_id().as_str()) else {
            continue;
        };
        for value in raw {
            if let Some(e) = crate::api::path_length_error(std::path::Path::new(value)) {
                let name = match arg.get_long() {
                    Some(l) => format!("--{l}"),
                    None => arg
                        .get_value_names()
                        .and_then(<[_]>::first)
                        .map_or_else(|| arg.get_id().to_string(), ToString::to_string),
                };
                anyhow::bail!("{name} {e}");
            }
        }
    }
    if let Some((name, sub)) = m.subcommand() {
        if let Some(c) = cmd.find_subcommand(name) {
            check_path_lengths(c, sub)?;
        }
    }
    Ok(())
}

/// Let a closed stdout end djkr quietly, as it does any Unix filter (`djkr figures | head -1`).
/// Rust ignores SIGPIPE, so every `println!` after the reader has gone would panic on EPIPE
/// (exit 101); with the default disposition restored, the kernel ends the process at the first
/// such write instead. The commands print their results after writing their files, so a closed
/// stdout cuts only the listing short.
fn restore_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread exists; SIG_DFL is a valid
    // disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Keep large blocks in the heap. glibc's malloc serves a block above its mmap threshold with a
/// fresh mapping, unmapped again when freed, and raises the threshold only to the largest block
/// freed so far: a streamed run's writer thread, whose HDF5 appends allocate and free 256 KiB
/// buffers for every chunk, then paid a page fault per 4 KiB of them (its time 0.29 → 0.45 s on
/// the full-length paper protocol, when a run started streaming before it had freed a larger
/// block). Fixed thresholds (32 MiB mapping, 64 MiB trimming) reuse the heap's blocks instead;
/// memory stays bounded by the run's own (bounded) peak.
fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: called first thing in main, before any thread exists or any allocation depends on
    // the thresholds; both are documented mallopt parameters with values in range.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 64 << 20);
    }
}

/// An error and its causes on one line, `outer: inner: ...`, leaving out a cause whose text the
/// line already holds: library errors that show their I/O cause in their own message and also
/// chain it as their `source` printed the OS message twice.
fn error_text(e: &anyhow::Error) -> String {
    words::text(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cause_already_shown_is_not_repeated() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file (os error 2)");
        #[derive(Debug, thiserror::Error)]
        #[error("x: {0}")]
        struct Shows(#[source] std::io::Error);
        let e = anyhow::Error::new(Shows(io)).context("--out x");
        assert_eq!(error_text(&e), "--out x: x: No such file (os error 2)");
        let e = anyhow::anyhow!("inner").context("outer");
        assert_eq!(error_text(&e), "outer: inner");
    }
}
