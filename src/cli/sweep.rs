//! `djkr sweep FILE --set KEY=SPEC ... --out DIR` and `djkr sweep merge DIR... --out DIR`: thin
//! over [`crate::sweep`].

use super::common::fmt_force;
use super::signals::{self, Signal};
use crate::cli::slurm::{default_shards, SlurmScript};
use crate::scenario::parse::ScenarioSource;
use crate::sweep::files::{self, Manifest, Shard};
use crate::sweep::{run_sweep, Axis, Ensemble, Grid, Row, RunOptions, Sweep};
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Flags of `djkr sweep`.
#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    command: Option<SweepCommand>,
    #[command(flatten)]
    run: SweepRunArgs,
}

#[derive(Subcommand, Debug)]
enum SweepCommand {
    /// Merge the shard folders of one sweep (--shard K/N) into the files of the unsharded sweep.
    Merge(MergeArgs),
}

/// Flags of `djkr sweep merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The shard folders (each written by `djkr sweep ... --shard K/N --out DIR`).
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Folder for the merged sweep.csv, sweep.h5, points.csv and plots: not one of the shard
    /// folders, nor inside one (their parent is fine).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Overwrite files in --out that djkr did not write under the names the merge publishes.
    #[arg(long)]
    force: bool,
}

/// Flags of a sweep.
#[derive(Args, Debug)]
pub struct SweepRunArgs {
    /// Scenario file (TOML; see docs/guide/scenarios.md).
    #[arg(required = true)]
    file: Option<PathBuf>,
    /// A swept key and its values (repeatable; several make the Cartesian grid, first key
    /// slowest): KEY=A,B,C (a list, units welcome: base.amplitude=10um,30um,60um),
    /// KEY=START:STOP:N (linear, ends included) or KEY=START:STOP:Nlog (log-spaced). KEY is any
    /// `--set` key (base.frequency, stage[3].speed, adhesion.n, solver.method, ...).
    #[arg(long = "set", value_name = "KEY=SPEC")]
    set: Vec<String>,
    /// Pair the keys' values (the i-th point takes the i-th value of each) instead of the grid.
    #[arg(long)]
    zip: bool,
    /// Run N members per point, each with the base phase at shaker-on ([base] phase) drawn
    /// uniformly in [0, 2π) from (seed, point, member).
    #[arg(long, value_name = "N")]
    ensemble: Option<usize>,
    /// Seed of the ensemble's phases [default: 0].
    #[arg(long, value_name = "S")]
    seed: Option<u64>,
    /// Output folder [default: out/<scenario name>-sweep].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Runs at a time [default: one per core]; capped, with a warning, at the available
    /// parallelism (cores the process may use), so that each run's solver.max_wall_s stays
    /// wall time. With --slurm: the CPUs per array task.
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    /// Continue the sweep in --out: runs not yet done, and again those whose row is `stopped`
    /// (a budget stopped them) or `error` (they failed), unless --no-retry (a folder without a
    /// sweep starts one).
    #[arg(long)]
    resume: bool,
    /// With --resume: keep the `stopped` and `error` rows as they are and run only the runs not
    /// yet done.
    #[arg(long, requires = "resume")]
    no_retry: bool,
    /// Also keep each run's own folder (DIR/runs/pPPPP-mMM: run.h5, summary.json).
    #[arg(long)]
    keep_runs: bool,
    /// Overwrite files in --out that djkr did not write under the names the sweep publishes
    /// (sweep.json, progress.csv, sweep.csv, sweep.h5, points.csv, the plots); without it such
    /// a file stops the sweep before it starts. Nothing else in the folder is touched.
    #[arg(long)]
    force: bool,
    /// Run only the K-th of N disjoint slices of the runs (K from 1), or `slurm` to take them
    /// from SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT; merge with `djkr sweep merge`.
    #[arg(long, value_name = "K/N")]
    shard: Option<String>,
    /// Run nothing: write DIR/sweep.sbatch, a Slurm array job (one task per shard) with a
    /// dependent merge step, and say how to submit it.
    #[arg(long)]
    slurm: bool,
    /// With --slurm: array tasks [default: one per 64 runs, at most 1000].
    #[arg(long, value_name = "N", requires = "slurm")]
    shards: Option<usize>,
    /// With --slurm: the tasks' time limit (#SBATCH --time), in a format sbatch accepts:
    /// MINUTES, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS or UNLIMITED, e.g. 2:00:00.
    #[arg(long, value_name = "TIME", requires = "slurm")]
    slurm_time: Option<String>,
    /// With --slurm: the partition (#SBATCH --partition): a name of letters, digits, '_', '-'
    /// and '.', or a comma-separated list of them; anything else is refused.
    #[arg(long, value_name = "NAME", requires = "slurm")]
    slurm_partition: Option<String>,
}

/// A sweep stopped by a signal: exit status 130 after Ctrl-C, 3 after SIGTERM.
#[derive(Debug)]
pub struct Interrupted(pub Option<Signal>);

impl Interrupted {
    /// 130 after Ctrl-C (the shell's code for SIGINT), 3 after SIGTERM (a stop, as a budget's).
    pub fn exit_status(&self) -> u8 {
        self.0.map_or(130, Signal::exit_status)
    }
}

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self.0 {
            Some(Signal::Terminate) => "terminated (SIGTERM)",
            _ => "interrupted",
        })
    }
}

impl std::error::Error for Interrupted {}

/// Run `djkr sweep`.
pub fn sweep(a: &SweepArgs) -> Result<()> {
    match &a.command {
        Some(SweepCommand::Merge(m)) => merge(m),
        None => run(&a.run),
    }
}

fn build(a: &SweepRunArgs, file: &Path) -> Result<Sweep> {
    let axes = a
        .set
        .iter()
        .map(|s| Axis::parse(s))
        .collect::<Result<Vec<_>, _>>()?;
    let grid = Grid::new(axes, a.zip)?;
    if a.zip && grid.axes().len() < 2 {
        bail!("--zip pairs the values of two or more --set keys; give at least two");
    }
    let ensemble = match (a.ensemble, a.seed) {
        (Some(members), seed) => {
            if members == 0 {
                bail!("--ensemble 0: must be a whole number >= 1 (members per point)");
            }
            Some(Ensemble {
                members,
                seed: seed.unwrap_or(0),
            })
        }
        (None, Some(s)) => bail!("--seed {s}: seeds the ensemble's phases; add --ensemble N"),
        (None, None) => None,
    };
    let source = ScenarioSource::read(file)?;
    Ok(Sweep::new(source, grid, ensemble)?)
}

/// Raised by Ctrl-C or SIGTERM (or a progress file that cannot be written): no new run starts,
/// running ones are abandoned.
fn stop_flag() -> &'static AtomicBool {
    signals::flag()
}

fn run(a: &SweepRunArgs) -> Result<()> {
    let Some(file) = a.file.as_deref() else {
        bail!("give a scenario FILE (or `djkr sweep merge DIR... --out DIR`)");
    };
    if a.jobs == Some(0) {
        bail!("--jobs 0: must be a whole number >= 1 (runs at a time)");
    }
    let sweep = build(a, file)?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| super::common::default_out(file, "-sweep"));
    if a.slurm {
        return slurm(a, file, &sweep, &out);
    }
    let shard = parse_shard(a.shard.as_deref())?;
    let manifest = Manifest::of(&sweep, shard);
    // The lock in `opened` is held to the end of the sweep: a second sweep is refused at once.
    let opened = files::open(&out, manifest, a.resume, a.force).context("--out")?;
    let runs_dir = out.join(files::RUNS_DIR);
    if a.keep_runs && std::fs::symlink_metadata(&runs_dir).is_ok_and(|m| !m.is_dir()) {
        bail!(
            "--keep-runs: {} is not a folder: move it away (djkr keeps the runs' folders there)",
            runs_dir.display()
        );
    }
    let _lock = opened.lock;
    let manifest = opened.manifest;
    let mut progress = opened.progress;
    let mut rows: Vec<Row> = opened.done;
    let retried = if a.no_retry {
        0
    } else {
        // Stopped and failed runs run again; their new rows replace the old ones (a row file
        // read back keeps the last row of each run).
        let before = rows.len();
        rows.retain(|r| r.result.is_ok());
        before - rows.len()
    };
    let todo = files::remaining(&sweep, &manifest, &rows);
    let owned = rows.len() + todo.len();
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let (jobs, warning) = capped_jobs(a.jobs, cores);
    if let Some(w) = warning {
        eprintln!("warning: {w}");
    }
    install_stop_handler();
    if !rows.is_empty() || retried > 0 {
        eprintln!(
            "resuming {}: {} of {owned} runs already done{}",
            out.display(),
            rows.len(),
            if retried > 0 {
                format!("; {retried} stopped or failed run(s) run again (--no-retry keeps them)")
            } else {
                String::new()
            }
        );
    }
    let keep_runs = a.keep_runs.then(|| out.join(files::RUNS_DIR));
    let executed = execute(&sweep, &todo, jobs, keep_runs, &mut progress, &mut rows);
    finish(&sweep, &manifest, &out, &mut rows, owned, jobs, executed)
}

/// The runs at a time: `requested` (`--jobs`), at most `cores` (the available parallelism),
/// and a warning when capped. More threads than cores share them, so each run's
/// `solver.max_wall_s` would be spent partly waiting (`--jobs 64` on 2 cores failed 62 of 64
/// runs on a 1 s budget that every run met with `--jobs 2`).
fn capped_jobs(requested: Option<usize>, cores: usize) -> (usize, Option<String>) {
    match requested {
        Some(j) if j > cores => (
            cores,
            Some(format!(
                "--jobs {j}: capped at {cores}, the available parallelism of this machine \
                 (more runs at a time would share the cores, and solver.max_wall_s is wall time)"
            )),
        ),
        Some(j) => (j, None),
        None => (cores, None),
    }
}

/// `--shard K/N` or `--shard slurm` (from the array task's environment).
fn parse_shard(text: Option<&str>) -> Result<Option<Shard>> {
    Ok(match text {
        None => None,
        Some("slurm") => {
            Some(Shard::from_slurm(|k| std::env::var(k).ok()).map_err(anyhow::Error::msg)?)
        }
        Some(t) => Some(Shard::parse(t).map_err(anyhow::Error::msg)?),
    })
}

/// Ctrl-C or SIGTERM raises the stop flag; a second one ends the process at once (the progress
/// file is intact line by line). A handler that cannot be installed is a warning.
fn install_stop_handler() {
    signals::install(
        "stopping: no new runs start, running ones are abandoned (Ctrl-C again to quit at once)",
    );
}

/// What [`execute`] did.
struct Executed {
    /// Runs finished in this call (those of the list less the ones a stop left unstarted).
    ran: usize,
    /// Wall time of the call (s).
    wall: f64,
    /// The first failure to append to the progress file (it stopped the sweep).
    write_error: Option<anyhow::Error>,
}

/// Run `todo` on `jobs` threads under a progress bar, appending each row to the progress file
/// and to `rows` as it arrives.
fn execute(
    sweep: &Sweep,
    todo: &[usize],
    jobs: usize,
    keep_runs: Option<PathBuf>,
    progress: &mut files::Progress,
    rows: &mut Vec<Row>,
) -> Executed {
    let bar = ProgressBar::new(todo.len() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed}] {bar:30} {pos}/{len} runs, ETA {eta} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let t0 = Instant::now();
    let mut failed = 0usize;
    let mut write_error: Option<anyhow::Error> = None;
    let opts = RunOptions {
        jobs,
        stop: Some(stop_flag()),
        keep_runs,
    };
    let not_run = run_sweep(sweep, todo, &opts, |row| {
        if row.result.is_err() {
            failed += 1;
            bar.set_message(format!("({failed} failed or stopped)"));
        }
        if write_error.is_none() {
            if let Err(e) = progress.append(&row) {
                write_error = Some(e.into());
                stop_flag().store(true, Ordering::SeqCst);
            }
        }
        rows.push(row);
        bar.inc(1);
    });
    bar.finish_and_clear();
    Executed {
        ran: todo.len() - not_run,
        wall: t0.elapsed().as_secs_f64(),
        write_error,
    }
}

/// Write the sweep's files from all `rows` (of the `owned` runs of this folder), report, and
/// for a sweep stopped early say how to resume it ([`Interrupted`]).
fn finish(
    sweep: &Sweep,
    manifest: &Manifest,
    out: &Path,
    rows: &mut [Row],
    owned: usize,
    jobs: usize,
    executed: Executed,
) -> Result<()> {
    let new_wall: f64 = rows.iter().rev().take(executed.ran).map(|r| r.wall_s).sum();
    let complete = rows.len() == owned;
    let written = files::write_results(out, manifest, rows, complete)
        .with_context(|| format!("writing the sweep's files into {}", out.display()))?;
    if let Some(e) = executed.write_error {
        return Err(e.context(format!(
            "{}: the progress file could not be written; the sweep stopped",
            out.display()
        )));
    }
    report(
        sweep,
        manifest,
        rows,
        executed.ran,
        executed.wall,
        new_wall,
        jobs,
    )?;
    outln!("\nwrote:")?;
    for p in &written {
        outln!("  {}", p.display())?;
    }
    if !complete {
        let shard = manifest
            .shard
            .map(|s| format!(" --shard {}/{}", s.index, s.count))
            .unwrap_or_default();
        eprintln!(
            "\nstopped: {} of {owned} runs done (the tables hold those). Continue with:\n  {}{shard} --resume --out {}",
            rows.len(),
            manifest.command(),
            files::shell_quote(&out.display().to_string())
        );
        return Err(Interrupted(signals::received()).into());
    }
    Ok(())
}

/// Print what ran and the points' amplifications.
fn report(
    sweep: &Sweep,
    manifest: &Manifest,
    rows: &[Row],
    ran: usize,
    wall: f64,
    runs_wall: f64,
    jobs: usize,
) -> anyhow::Result<()> {
    let stopped = rows.iter().filter(|r| r.stopped).count();
    let failed = rows.iter().filter(|r| r.result.is_err()).count() - stopped;
    outln!(
        "{}: {} point(s) x {} member(s){}; {} run(s) in this folder, {failed} failed, {stopped} \
         stopped by a budget",
        manifest.scenario,
        sweep.grid().points(),
        sweep.members(),
        manifest
            .shard
            .map(|s| format!(", shard {}/{}", s.index, s.count))
            .unwrap_or_default(),
        rows.len()
    )?;
    if ran > 0 {
        outln!(
            "  ran {ran} in {wall:.3} s on {jobs} thread(s); the runs' own wall time adds up to \
             {runs_wall:.3} s ({:.2} runs' seconds per second)",
            runs_wall / wall.max(1e-9)
        )?;
    }
    let points = crate::sweep::stats::point_stats(rows);
    if points.len() <= 40 {
        let names: Vec<String> = manifest.keys.iter().map(|k| k.name.clone()).collect();
        outln!(
            "  point  {}  amplification  pull-off force",
            names.join("  ")
        )?;
        for p in &points {
            let keys: Vec<String> = p.keys.iter().map(ToString::to_string).collect();
            let amp = if p.amplification.n >= 2 {
                format!(
                    "{:.4} ± {:.4} (std, n = {})",
                    p.amplification.mean, p.amplification.std, p.amplification.n
                )
            } else {
                format!("{:.4}", p.amplification.mean)
            };
            outln!(
                "  {:>5}  {}  {amp}  {}{}",
                p.point,
                keys.join("  "),
                fmt_force(p.force.mean),
                if p.failed > 0 {
                    format!("  ({} failed)", p.failed)
                } else {
                    String::new()
                }
            )?;
        }
    }
    if let Some(r) = rows.iter().find(|r| r.result.is_err()) {
        if let Err(e) = &r.result {
            outln!(
                "  first {}: point {} member {}: {e}",
                if r.stopped { "stop" } else { "failure" },
                r.point,
                r.member
            )?;
        }
    }
    Ok(())
}

fn absolute(p: &Path) -> Result<PathBuf> {
    std::path::absolute(p)
        .with_context(|| format!("{}: cannot make the path absolute", p.display()))
}

/// Refuse a value that `sweep.sbatch` would quote but that does not fit Slurm's grammar
/// (`--slurm-partition`, `--slurm-time`) or holds a control character (a path, a `--set`):
/// written into an `#SBATCH` or comment line, a newline would start a command of its own.
fn check_script_values(a: &SweepRunArgs, file: &Path, out: &Path, exe: &Path) -> Result<()> {
    use crate::cli::slurm::{check_partition, check_script_text, check_sweep_folder, check_time};
    use djkr_core::text::excerpt;
    if let Some(p) = &a.slurm_partition {
        check_partition(p)
            .map_err(|e| anyhow::anyhow!("--slurm-partition = {}: {e}", excerpt(p)))?;
    }
    if let Some(t) = &a.slurm_time {
        check_time(t).map_err(|e| anyhow::anyhow!("--slurm-time = {}: {e}", excerpt(t)))?;
    }
    // The script holds the paths as text: one that is not UTF-8 would be written as another.
    fn text_of<'a>(what: &str, p: &'a Path) -> Result<&'a str> {
        p.to_str().ok_or_else(|| {
            anyhow::anyhow!(
                "{what} {}: is not valid UTF-8 text, so it cannot go into a Slurm script",
                excerpt(&p.to_string_lossy())
            )
        })
    }
    let out_text = text_of("--out", out)?;
    check_sweep_folder(out_text)
        .map_err(|e| anyhow::anyhow!("--out {}: {e}", excerpt(out_text)))?;
    for (what, p) in [("the scenario file", file), ("the djkr binary", exe)] {
        let text = text_of(what, p)?;
        check_script_text(text).map_err(|e| anyhow::anyhow!("{what} {}: {e}", excerpt(text)))?;
    }
    for set in &a.set {
        check_script_text(set).map_err(|e| anyhow::anyhow!("--set {}: {e}", excerpt(set)))?;
    }
    Ok(())
}

/// `--slurm`: write the manifest and DIR/sweep.sbatch; run nothing.
fn slurm(a: &SweepRunArgs, file: &Path, sweep: &Sweep, out: &Path) -> Result<()> {
    let exe = std::env::current_exe().context("locating the djkr binary")?;
    check_script_values(a, file, out, &exe)?;
    if a.shard.is_some() {
        bail!("--slurm writes a job whose tasks take --shard K/N themselves: drop --shard");
    }
    let shards = a.shards.unwrap_or_else(|| default_shards(sweep.runs()));
    if shards == 0 || shards > sweep.runs() {
        bail!(
            "--shards {shards}: must lie in [1, {}] (the sweep's runs)",
            sweep.runs()
        );
    }
    crate::output::folder::prepare(out)?;
    let _lock = crate::output::folder::DirLock::acquire(out)?;
    crate::output::folder::check_names(out, &[files::MANIFEST_NAME, "sweep.sbatch"], a.force)?;
    std::fs::create_dir_all(out.join("slurm"))
        .with_context(|| format!("--out {}", out.display()))?;
    let manifest = Manifest::of(sweep, None);
    let path = out.join(files::MANIFEST_NAME);
    if let Some(old) = Manifest::read(out)? {
        if let Some(what) = old.difference(&manifest) {
            bail!(
                "--out {}: already holds another sweep (its {what} differs): choose another --out",
                out.display()
            );
        }
    } else {
        crate::output::write_atomic(
            &path,
            format!("{}\n", serde_json::to_string_pretty(&manifest)?).as_bytes(),
        )?;
    }
    let exe = std::env::current_exe().context("locating the djkr binary")?;
    let script = SlurmScript {
        djkr: exe.display().to_string(),
        scenario: absolute(file)?.display().to_string(),
        set: a.set.iter().map(|s| s.trim().to_string()).collect(),
        zip: a.zip,
        ensemble: sweep.ensemble().map(|e| (e.members, e.seed)),
        keep_runs: a.keep_runs,
        out: absolute(out)?.display().to_string(),
        shards,
        cpus_per_task: a.jobs.unwrap_or(1),
        time: a.slurm_time.clone(),
        partition: a.slurm_partition.clone(),
        runs: sweep.runs(),
    };
    let sbatch = out.join("sweep.sbatch");
    crate::output::write_atomic(&sbatch, script.text().as_bytes())?;
    outln!(
        "{}: {} run(s) in {shards} Slurm array task(s) of about {} run(s), {} thread(s) each.",
        file.display(),
        sweep.runs(),
        sweep.runs().div_ceil(shards),
        script.cpus_per_task
    )?;
    outln!(
        "wrote {}\n\nsubmit it with:\n  sbatch {}",
        sbatch.display(),
        files::shell_quote(&sbatch.display().to_string())
    )?;
    outln!(
        "\nEach task writes {}/shards/K; the first submits the merge step, which runs when every \
         task has succeeded and writes sweep.csv, points.csv, sweep.h5 and the plots into {}.",
        out.display(),
        out.display()
    )?;
    Ok(())
}

/// Run `djkr sweep merge`.
fn merge(m: &MergeArgs) -> Result<()> {
    let merged = files::merge(&m.dirs, &m.out, m.force)?;
    outln!(
        "merged {} folder(s): {} run(s), {} failed",
        m.dirs.len(),
        merged.rows,
        merged.failed
    )?;
    outln!("wrote:")?;
    for p in &merged.files {
        outln!("  {}", p.display())?;
    }
    Ok(())
}
