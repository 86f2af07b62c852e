//! `djkr run FILE` and `djkr check FILE`: the time-domain simulator on a scenario file.

use super::common::{default_out, law_name, load_scenario, SetArgs};
use anyhow::{Context, Result};
use clap::Args;
use djkr::dynamics::{self, Event, Observer, RunResult, Sample};
use djkr::output::RunWriter;
use djkr::scenario::checks;
use djkr::scenario::parse::{ScenarioError, ScenarioSource};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Flags of `djkr run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Scenario file (TOML; see README, "Scenario files").
    file: PathBuf,
    /// Output directory for summary.json and run.h5 (created if needed) [default: out/<scenario name>].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also write timeseries.csv and events.csv.
    #[arg(long)]
    csv: bool,
    /// Print the summary as JSON (SI values) instead of a table.
    #[arg(long)]
    json: bool,
    /// Also draw run.png and run.svg: F(t), a(t), δ(t), per-cycle means, the last F–δ loops
    /// (same as `[output] plot = true`).
    #[arg(long)]
    plot: bool,
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
        if self.samples.is_multiple_of(256) && self.last.elapsed() >= Duration::from_millis(100) {
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
        self.inner.sample(s)
    }
    fn event(&mut self, e: &Event) {
        self.events += 1;
        self.inner.event(e);
    }
    fn cycle(&mut self, c: &dynamics::CycleRecord) {
        self.inner.cycle(c);
    }
}

/// Run `djkr run`.
pub fn run(a: &RunArgs) -> Result<()> {
    let scn = load_scenario(&a.file, &a.set)?;
    let out = a.out.clone().unwrap_or_else(|| default_out(&a.file, ""));
    let mut writer = RunWriter::create(&out, &scn, a.csv || scn.output.csv)
        .with_context(|| format!("--out {}", out.display()))?;
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
    let result = scn.simulate(&mut obs);
    bar.finish_and_clear();
    let result = match result {
        Ok(r) => r,
        Err(e) => {
            writer.abort();
            return Err(anyhow::Error::new(e).context(format!(
                "{}: run failed (no output written)",
                scn.source_name
            )));
        }
    };
    let paths = writer
        .finish(&result)
        .with_context(|| format!("writing results into {}", out.display()))?;
    let plots = if a.plot || scn.output.plot {
        let (png, svg) = djkr::run_plot::plot_run_dir(&out)
            .with_context(|| format!("drawing the run's figure into {}", out.display()))?;
        vec![png, svg]
    } else {
        Vec::new()
    };
    let warnings = checks::result_warnings(&scn, &result);
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    if a.json {
        // Exactly the summary.json just written (its non-finite rule included).
        let text = std::fs::read_to_string(&paths.summary)
            .with_context(|| format!("reading back {}", paths.summary.display()))?;
        println!("{}", text.trim_end());
        return Ok(());
    }
    print_summary(&scn, &result, &warnings);
    println!("\nwrote:");
    for p in paths
        .all()
        .into_iter()
        .chain(plots.iter().map(PathBuf::as_path))
    {
        println!("  {}", p.display());
    }
    Ok(())
}

fn print_summary(scn: &djkr::scenario::Scenario, r: &RunResult, warnings: &[String]) {
    // Every line without a `-0.0`.
    macro_rules! line {
        ($($t:tt)*) => {
            println!("{}", super::common::no_negative_zero(&format!($($t)*)))
        };
    }
    line!(
        "{}: {} stage(s), method {}",
        scn.source_name,
        scn.stages.len(),
        r.method
    );
    if !checks::pull_off_recorded(r) {
        line!(
            "  no pull-off        no pull-off force recorded (see the warning){}",
            if r.detached { " (detached)" } else { "" }
        );
    } else if r.detached {
        line!(
            "  pull-off force     {:.6} mN  (amplification {:.4} over −3/2 π R w0 = {:.6} mN)",
            r.pull_off.force * 1e3,
            r.pull_off.amplification,
            scn.rig.material.static_pull_off_force() * 1e3
        );
        line!("  reached at         t = {:.6} s", r.pull_off.time);
    } else {
        line!(
            "  no detachment; most tensile {} force {:.6} mN at t = {:.6} s",
            if scn.rig.base.is_some() {
                "cycle-averaged"
            } else {
                "contact"
            },
            r.pull_off.force * 1e3,
            r.pull_off.time
        );
    }
    let mut counts = std::collections::BTreeMap::new();
    for e in &r.events {
        // The names summary.json and events.csv use (contact-loss, pull-off, ...).
        let name = match serde_json::to_value(e.kind) {
            Ok(serde_json::Value::String(s)) => s,
            _ => "event".to_string(),
        };
        *counts.entry(name).or_insert(0usize) += 1;
    }
    let list: Vec<String> = counts.iter().map(|(k, n)| format!("{k} ×{n}")).collect();
    line!("  events             {}", list.join(", "));
    line!(
        "  solver             {} steps, {} rejected, {} rhs evaluations, {:.3} s wall",
        r.stats.steps,
        r.stats.rejected,
        r.stats.rhs_evals,
        r.stats.wall_s
    );
    let f = &r.final_state;
    line!(
        "  final state        t = {:.6} s, a = {:.6} mm, δ = {:.6} µm, F = {:.6} mN",
        f.t,
        f.a * 1e3,
        f.delta * 1e6,
        f.force * 1e3
    );
    for w in warnings {
        line!("  warning            {w}");
    }
}

/// Run `djkr check`.
pub fn check(a: &CheckArgs) -> Result<()> {
    let overrides = a.set.overrides()?;
    let mut failed = 0;
    for f in &a.files {
        match ScenarioSource::read(f).and_then(|src| src.scenario(&overrides)) {
            Ok(s) => {
                println!(
                    "{}: ok ({} stage(s), law {}, {})",
                    s.source_name,
                    s.stages.len(),
                    law_name(&s.rig.law),
                    if s.rig.base.is_some() {
                        "vibrating base"
                    } else {
                        "no base motion"
                    }
                );
                for w in checks::scenario_warnings(&s) {
                    eprintln!("warning: {}: {w}", s.source_name);
                }
            }
            Err(e) => {
                failed += 1;
                match e {
                    // An override's error names the override, not the file: say which file.
                    ScenarioError::Override { .. } => eprintln!("error: {}: {e}", f.display()),
                    _ => eprintln!("error: {e}"),
                }
            }
        }
    }
    if failed > 0 {
        anyhow::bail!("{failed} of {} scenario file(s) invalid", a.files.len());
    }
    Ok(())
}
