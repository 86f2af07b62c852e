//! `djkr run FILE` and `djkr check FILE`: the time-domain simulator on a scenario file.

use super::common::{default_out, law_name, load_scenario, SetArgs};
use super::signals;
use crate::api::{close_run_folder, open_run_folder, FolderOptions};
use crate::output::RunWriter;
use crate::scenario::checks;
use crate::scenario::parse::{ScenarioError, ScenarioSource};
use crate::sensitivity::Sensitivity;
use anyhow::{Context, Result};
use clap::Args;
use djkr_core::cancel::Cancel;
use djkr_core::dynamics::{
    self, Ending, Event, Model, Observer, Outcome, Reason, RunResult, Sample, SimError, Status,
    StepSamples,
};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Flags of `djkr run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Scenario file (TOML; see docs/guide/scenarios.md).
    file: PathBuf,
    /// Output directory for summary.json and run.h5 (created if needed) [default: out/<scenario name>].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also write timeseries.csv, events.csv, cycles.csv and gaps.csv.
    #[arg(long)]
    csv: bool,
    /// Print the summary as JSON (SI values) instead of a table.
    #[arg(long)]
    json: bool,
    /// Also draw run.png and run.svg: F(t), a(t), δ(t), per-cycle means, the last F–δ loops
    /// (same as `[output] plot = true`).
    #[arg(long)]
    plot: bool,
    /// Also run N twins (default 4) whose base amplitude (without a base: initial preload or
    /// gap) differs by k·1e-12 relative, in parallel, and report how far the pull-off moves:
    /// under vibration the approach to pull-off can be chaotic, and then only a distribution
    /// converges (docs/guide/numerics.md, "How reproducible is a pull-off?"). Adds `sensitivity` to summary.json.
    #[arg(long, value_name = "N", num_args = 0..=1, default_missing_value = "4",
          value_parser = clap::value_parser!(u16).range(1..=256))]
    sensitivity: Option<u16>,
    /// Overwrite files in --out that djkr did not write under the names this run publishes
    /// (summary.json, run.h5, the CSV files, run.png/svg); without it such a file stops the run
    /// before it starts. Nothing else in the folder is touched.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    set: SetArgs,
}

/// Flags of `djkr check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// Scenario file(s) to validate without running (--set applies to each).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    #[command(flatten)]
    set: SetArgs,
}

/// Shows progress on a terminal (indicatif hides itself otherwise) and forwards to the writer.
struct Progress<'a> {
    inner: &'a mut RunWriter,
    bar: ProgressBar,
    last: Instant,
    samples: u64,
    events: usize,
    stages: usize,
}

impl Observer for Progress<'_> {
    fn sample(&mut self, s: &Sample) -> bool {
        self.samples += 1;
        // Reading the clock at every sample cost 6 % of a run sampled at 12 kHz.
        if self.samples.is_multiple_of(256) {
            self.show(s);
        }
        self.inner.sample(s)
    }
    fn step_samples(&mut self, model: &Model, step: &StepSamples) -> bool {
        let before = self.samples / 256;
        self.samples += step.n as u64;
        if self.samples / 256 != before {
            self.show(&step.end(model));
        }
        self.inner.step_samples(model, step)
    }
    fn event(&mut self, e: &Event) {
        self.events += 1;
        self.inner.event(e);
    }
    fn cycle(&mut self, c: &dynamics::CycleRecord) {
        self.inner.cycle(c);
    }
    fn gap(&mut self, g: &dynamics::Gap) {
        self.inner.gap(g);
    }
    fn stop_reason(&self) -> Option<Reason> {
        self.inner.stop_reason()
    }
}

impl Progress<'_> {
    /// Show where the run is, at most every 100 ms.
    fn show(&mut self, s: &Sample) {
        if self.last.elapsed() < Duration::from_millis(100) {
            return;
        }
        self.last = Instant::now();
        self.bar.set_message(format!(
            "t = {:.6} s  stage {}/{}  a = {:.4} mm  F = {:.4} mN  events {}",
            s.t,
            s.stage + 1,
            self.stages,
            s.a * 1e3,
            s.force * 1e3,
            self.events
        ));
    }
}

/// A run that ended early: stopped by a budget or a signal, or failed mid-way. Its files are
/// published; `main` maps it to the exit status (1 failed, 3 stopped, 130 Ctrl-C).
#[derive(Debug)]
pub struct RunEnded {
    /// How it ended.
    pub ending: Ending,
    /// Where its files are.
    pub dir: PathBuf,
}

impl RunEnded {
    /// The exit status: 1 for a failed run, 3 for one stopped by a budget or SIGTERM, 130 for
    /// Ctrl-C.
    pub fn exit_status(&self) -> u8 {
        match (self.ending.status(), self.ending.reason) {
            (Status::Failed, _) => 1,
            (_, Some(Reason::Sigint)) => 130,
            _ => 3,
        }
    }
}

impl std::fmt::Display for RunEnded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "run {} ({}): {}; what it computed is in {} (its summary.json says how it ended)",
            self.ending.status().name(),
            self.ending.reason.map_or("", |r| r.name()),
            self.ending.message.as_deref().unwrap_or(""),
            self.dir.display(),
        )
    }
}

impl std::error::Error for RunEnded {}

/// How the run ended, the signal that stopped it named (SIGINT or SIGTERM; the library knows
/// only that it was cancelled).
fn ending_of(outcome: &Outcome) -> Ending {
    let ending = outcome.ending();
    if !matches!(outcome.error, Some(SimError::Cancelled { .. })) {
        return ending;
    }
    let reason = match signals::received() {
        Some(signals::Signal::Terminate) => Reason::Sigterm,
        _ => Reason::Sigint,
    };
    let f = &outcome.result.final_state;
    Ending::early(
        reason,
        format!(
            "{} received: the run got to t = {:e} s in stage {}",
            reason.name(),
            f.t,
            f.stage
        ),
    )
}

/// Run `djkr run`.
pub fn run(a: &RunArgs) -> Result<()> {
    let mut scn = load_scenario(&a.file, &a.set)?;
    let out = a.out.clone().unwrap_or_else(|| default_out(&a.file, ""));
    let folder = FolderOptions {
        csv: a.csv || scn.output.csv,
        plot: a.plot || scn.output.plot,
        force: a.force,
    };
    let mut writer =
        open_run_folder(&scn, &out, folder).with_context(|| format!("--out {}", out.display()))?;
    signals::install(
        "stopping: the run keeps what it computed and writes its files (again to quit at once)",
    );
    scn.solver.cancel = Cancel::from_static(signals::flag());
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    if !bar.is_hidden() {
        bar.enable_steady_tick(Duration::from_millis(200));
    }
    let mut obs = Progress {
        inner: &mut writer,
        bar: bar.clone(),
        last: Instant::now(),
        samples: 0,
        events: 0,
        stages: scn.stages.len(),
    };
    let outcome = scn.simulate_partial(&mut obs);
    bar.finish_and_clear();
    let outcome = match outcome {
        Ok(o) => o,
        Err(e) => {
            writer.abort();
            return Err(anyhow::Error::new(e).context(format!(
                "{}: run could not start (no output written)",
                scn.source_name
            )));
        }
    };
    let ending = writer.explain(ending_of(&outcome));
    let ok = ending.status() == Status::Ok;
    let result = outcome.result;
    let sens = match a.sensitivity {
        Some(n) if ok => match sensitivity(&scn, &result, n.into()) {
            Ok(s) => s,
            // A signal during the twins: the run itself is complete and is written without
            // them (the exit status still says the signal came).
            Err(e) if signals::received().is_some() => {
                eprintln!(
                    "warning: {}: the run's files are written without the sensitivity section",
                    super::words::text(&e)
                );
                None
            }
            Err(e) => return Err(e),
        },
        _ => None,
    };
    if let Some(s) = &sens {
        writer.add_summary_section("sensitivity", serde_json::to_value(s)?);
    }
    let written = close_run_folder(writer, &out, &result, &ending, folder.plot)
        .with_context(|| format!("writing results into {}", out.display()))?;
    let (paths, plots) = (written.paths, written.plots);
    match written.plot_error {
        Some(e) if ok => {
            return Err(anyhow::Error::new(e)
                .context(format!("drawing the run's figure into {}", out.display())))
        }
        // The files of a run that ended early come first: its figure is a bonus.
        Some(e) => eprintln!(
            "warning: drawing the run's figure into {}: {e}",
            out.display()
        ),
        None => {}
    }
    let warnings = checks::result_warnings(&scn, &result);
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let ended = if ok {
        // A signal after the run (during --sensitivity's twins) ends djkr as the signal says.
        signals::received().map(|s| {
            let reason = match s {
                signals::Signal::Terminate => Reason::Sigterm,
                signals::Signal::Interrupt => Reason::Sigint,
            };
            RunEnded {
                ending: Ending::early(
                    reason,
                    format!(
                        "{} received after the run had completed (its files are complete)",
                        reason.name()
                    ),
                ),
                dir: out.clone(),
            }
        })
    } else {
        Some(RunEnded {
            ending: ending.clone(),
            dir: out.clone(),
        })
    };
    if a.json {
        // Exactly the summary.json just written (its non-finite rule included): the text the
        // writer wrote, not the file read back (which anyone could have replaced meanwhile).
        outln!("{}", paths.summary_text.trim_end())?;
    } else {
        print_summary(&scn, &result, &ending, sens.as_ref(), &warnings)?;
        outln!("\nwrote:")?;
        for p in paths
            .all()
            .into_iter()
            .chain(plots.iter().map(PathBuf::as_path))
        {
            outln!("  {}", p.display())?;
        }
    }
    match ended {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

/// The twins of `--sensitivity` (`None` with a note when the scene has nothing to perturb).
fn sensitivity(
    scn: &crate::scenario::Scenario,
    result: &RunResult,
    members: usize,
) -> Result<Option<Sensitivity>> {
    eprintln!(
        "--sensitivity: running {members} twin(s) of {} in parallel ...",
        scn.source_name
    );
    match crate::sensitivity::twins(scn, result, members, crate::sensitivity::EPSILON) {
        None => {
            eprintln!(
                "--sensitivity: nothing to perturb (no base motion and an explicit initial \
                 state); no twins run"
            );
            Ok(None)
        }
        Some(r) => Ok(Some(r.with_context(|| {
            format!("{}: a --sensitivity twin failed", scn.source_name)
        })?)),
    }
}

/// `x` rounded to `digits` significant digits (at least 2), in plain notation (`-684.2`,
/// `-700`).
fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = digits.max(2) as i32;
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = (digits - 1 - magnitude).max(0) as usize;
    let unit = 10f64.powi(magnitude + 1 - digits);
    let rounded = if decimals == 0 {
        (x / unit).round() * unit
    } else {
        x
    };
    format!("{rounded:.decimals$}")
}

/// Print a summary line without a `-0.0`.
macro_rules! summary_line {
    ($($t:tt)*) => {
        outln!("{}", super::common::no_negative_zero(&format!($($t)*)))?
    };
}

fn print_summary(
    scn: &crate::scenario::Scenario,
    r: &RunResult,
    ending: &Ending,
    sens: Option<&Sensitivity>,
    warnings: &[String],
) -> anyhow::Result<()> {
    summary_line!(
        "{}: {} stage(s), method {}",
        scn.source_name,
        scn.stages.len(),
        r.method
    );
    if let (Some(reason), Some(message)) = (ending.reason, ending.message.as_deref()) {
        summary_line!(
            "  {:<18} {message}; what follows is the run up to there",
            format!(
                "{} ({})",
                ending.status().name().to_uppercase(),
                reason.name()
            )
        );
    }
    // Under vibration the approach to pull-off can be chaotic: without a measurement, four
    // significant digits and a pointer to --sensitivity; with one, the digits the twins share.
    let vibrating = scn.rig.base.is_some() && r.cycle_count > 0;
    let digits = match sens {
        Some(s) => s.digits.min(7),
        None if vibrating => 4,
        None => 7,
    };
    print_pull_off(scn, r, digits)?;
    print_sensitivity(
        sens,
        (vibrating && r.detached && r.pull_off.is_tensile()).then_some(r),
    )?;
    print_run_stats(r)?;
    for w in warnings {
        summary_line!("  warning            {w}");
    }
    Ok(())
}

/// The pull-off force and time (to `digits` significant digits), or why there is none.
fn print_pull_off(
    scn: &crate::scenario::Scenario,
    r: &RunResult,
    digits: usize,
) -> anyhow::Result<()> {
    let f0 = scn.rig.material.static_pull_off_force();
    if !checks::pull_off_recorded(r) {
        summary_line!(
            "  no pull-off        no pull-off force recorded (see the warning){}",
            if r.detached { " (detached)" } else { "" }
        );
    } else if r.detached && !r.pull_off.is_tensile() {
        // No tensile mean before the detachment: the sphere came off without a pull-off, and
        // F/F0 (negative or zero) is no amplification (the warning below says so).
        summary_line!(
            "  no pull-off        detached without a tensile {}: the most tensile, {} mN at \
             t = {} s, is {} (see the warning)",
            if scn.rig.base.is_some() && r.cycle_count > 0 {
                "cycle mean"
            } else {
                "contact force"
            },
            significant(r.pull_off.force * 1e3, digits),
            significant(r.pull_off.time, digits.max(3)),
            if r.pull_off.force > 0.0 {
                "compressive"
            } else {
                "zero"
            }
        );
    } else if r.detached {
        summary_line!(
            "  pull-off force     {} mN  (amplification {} over −3/2 π R w0 = {:.6} mN)",
            significant(r.pull_off.force * 1e3, digits),
            significant(r.pull_off.amplification, digits),
            f0 * 1e3
        );
        summary_line!(
            "  reached at         t = {} s",
            significant(r.pull_off.time, digits.max(3))
        );
    } else {
        // Never detached: no pull-off, whatever the most tensile force was (summary.json:
        // `most_tensile`, no amplification).
        summary_line!(
            "  no pull-off        the sphere never detached; most tensile {} force {} mN at \
             t = {} s",
            if scn.rig.base.is_some() && r.cycle_count > 0 {
                "cycle-averaged"
            } else {
                "contact"
            },
            significant(r.pull_off.force * 1e3, digits),
            significant(r.pull_off.time, digits.max(3))
        );
    }
    Ok(())
}

/// What `--sensitivity` measured; without it, for a pull-off under vibration
/// (`vibrating_pull_off`), what the roughness of its approach suggests and how to check it: the
/// chaos note only where the cycle means fluctuated before the pull-off
/// ([`djkr_core::dynamics::ApproachRoughness`]).
fn print_sensitivity(
    sens: Option<&Sensitivity>,
    vibrating_pull_off: Option<&RunResult>,
) -> anyhow::Result<()> {
    match sens {
        Some(s) if s.sensitive => {
            summary_line!(
                "  sensitivity        SENSITIVE: {} runs with {} differing by up to {:.0e} \
                 relative give pull-off forces {} … {} mN (sd {} mN, spread {:.1} %) and \
                 times {:.3} s apart: only the digits shown hold. Report a distribution: \
                 djkr sweep FILE --ensemble N (this sd needs {} members for a standard error \
                 of 1 %)",
                s.runs.len(),
                s.key,
                s.epsilon * (s.runs.len() - 1) as f64,
                significant(s.force_min * 1e3, 4),
                significant(s.force_max * 1e3, 4),
                significant(s.force_std * 1e3, 2),
                100.0 * s.force_spread,
                s.time_spread,
                s.members_for(0.01 * s.force_mean.abs())
            );
        }
        Some(s) => {
            summary_line!(
                "  sensitivity        deterministic: {} runs with {} differing by up to \
                 {:.0e} relative agree to {:.1e} in the pull-off force",
                s.runs.len(),
                s.key,
                s.epsilon * (s.runs.len() - 1) as f64,
                s.force_spread
            );
        }
        None => match vibrating_pull_off {
            // A relative fluctuation divides by the mean: not defined over a period without
            // contact. Said as such, never as an infinite percentage.
            Some(r) if r.pull_off_approach_left_contact() => summary_line!(
                "  note               {} of the {} periods before the pull-off had a zero mean \
                 force (the sphere off the substrate for a whole period), so how much the \
                 cycle means fluctuated is not defined as a fraction of them; an approach that \
                 loses contact is often chaotic: --sensitivity measures how many digits hold",
                r.approach_zero_means,
                djkr_core::dynamics::ROUGHNESS_PERIODS
            ),
            Some(r) if r.pull_off_likely_sensitive() => summary_line!(
                "  note               the cycle means fluctuated by up to {:.1} % from period \
                 to period before the pull-off (a smooth approach stays below {:.0e}): the \
                 approach is likely chaotic and tiny input changes move the pull-off by percent; \
                 --sensitivity measures how many digits hold",
                100.0 * r.approach_roughness,
                djkr_core::dynamics::ROUGH_APPROACH
            ),
            Some(r) if !r.approach_roughness.is_nan() => summary_line!(
                "  check              smooth approach to the pull-off (cycle means rough to \
                 {:.1e}, below {:.0e}): likely deterministic; --sensitivity measures it",
                r.approach_roughness,
                djkr_core::dynamics::ROUGH_APPROACH
            ),
            Some(_) => summary_line!(
                "  check              pull-off under vibration: --sensitivity measures how many \
                 digits hold"
            ),
            None => {}
        },
    }
    Ok(())
}

/// The events by kind, the solver's work and the final state.
fn print_run_stats(r: &RunResult) -> anyhow::Result<()> {
    let counts: Vec<(String, u64)> = r
        .event_counts
        .by_kind()
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .map(|(k, n)| {
            // The names summary.json and events.csv use (contact-loss, pull-off, ...).
            let name = match serde_json::to_value(k) {
                Ok(serde_json::Value::String(s)) => s,
                _ => "event".to_string(),
            };
            (name, n)
        })
        .collect();
    let list: Vec<String> = counts.iter().map(|(k, n)| format!("{k} ×{n}")).collect();
    summary_line!("  events             {}", list.join(", "));
    summary_line!(
        "  solver             {} steps, {} rejected, {} rhs evaluations, {:.3} s wall",
        r.stats.steps,
        r.stats.rejected,
        r.stats.rhs_evals,
        r.stats.wall_s
    );
    let f = &r.final_state;
    summary_line!(
        "  final state        t = {:.6} s, a = {:.6} mm, δ = {:.6} µm, F = {:.6} mN",
        f.t,
        f.a * 1e3,
        f.delta * 1e6,
        f.force * 1e3
    );
    Ok(())
}

/// Run `djkr check`.
pub fn check(a: &CheckArgs) -> Result<()> {
    let overrides = a.set.overrides()?;
    let mut failed = 0;
    for f in &a.files {
        match ScenarioSource::read(f).and_then(|src| src.scenario(&overrides)) {
            Ok(s) => {
                outln!(
                    "{}: ok ({} stage(s), law {}, {})",
                    s.source_name,
                    s.stages.len(),
                    law_name(&s.rig.law),
                    if s.rig.base.is_some() {
                        "vibrating base"
                    } else {
                        "no base motion"
                    }
                )?;
                for w in checks::scenario_warnings(&s) {
                    eprintln!("warning: {}: {w}", s.source_name);
                }
            }
            Err(e) => {
                failed += 1;
                let text = e.in_words(&super::words::Flags);
                match e {
                    // An override's error names the override, not the file: say which file.
                    ScenarioError::Override { .. } => eprintln!("error: {}: {text}", f.display()),
                    _ => eprintln!("error: {text}"),
                }
            }
        }
    }
    if failed > 0 {
        anyhow::bail!("{failed} of {} scenario file(s) invalid", a.files.len());
    }
    Ok(())
}
