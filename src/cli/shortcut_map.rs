//! `djkr shortcut-map`: where the imposed-area shortcut holds, as its error against the
//! time-domain steady state over frequency × base amplitude; writes `shortcut-map.csv`,
//! `shortcut-map.h5` and colour maps, prints a summary.

use super::common::default_out;
use super::common::{
    limits, load_scenario, print_json, write_atomic, BudgetStopped, CommandBudget,
};
use super::steady::{progress_bar, range, SteadyArgs};
use crate::output::hdf5_file::{hdf5_tables, Attr};
use crate::plot::{self, Heatmap};
use crate::reports::steady::{self as report, ShortcutMapReport};
use crate::scenario::Scenario;
use anyhow::{Context, Result};
use clap::Args;
use djkr_core::steady::map::{self as smap, MapCell, ShortcutMap};
use djkr_core::steady::{sweep, Problem};
use djkr_core::units::Dimension;
use std::path::{Path, PathBuf};

/// Flags of `djkr shortcut-map`.
#[derive(Args, Debug)]
#[command(after_help = super::common::STEADY_UNUSED_KEYS)]
pub struct ShortcutMapArgs {
    /// Scenario file (mechanics, contact, mean load; see `djkr validate`).
    file: PathBuf,
    /// Frequencies START:STOP:COUNT, evenly spaced.
    #[arg(long, value_name = "START:STOP:N", allow_hyphen_values = true)]
    freq: String,
    /// Base amplitudes START:STOP:COUNT, log-spaced, e.g. 0.05um:2um:9.
    #[arg(long, value_name = "START:STOP:N", allow_hyphen_values = true)]
    amp: String,
    /// Output directory for shortcut-map.csv, .h5 and the maps [default:
    /// out/<scenario name>-shortcut-map].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Overwrite files in --out that djkr did not write under the names this command writes;
    /// without it such a file stops the command before any work. Nothing else is touched.
    #[arg(long)]
    force: bool,
    /// Print a JSON summary (SI values) instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    steady: SteadyArgs,
}

fn log_space(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![lo];
    }
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

/// Run `djkr shortcut-map`.
pub fn shortcut_map(a: &ShortcutMapArgs) -> Result<()> {
    let opts = a.steady.options()?;
    let (flo, fhi, nf) = range("--freq", &a.freq, Dimension::Frequency, limits::MAP_AXIS)?;
    let (alo, ahi, na) = range("--amp", &a.amp, Dimension::Length, limits::MAP_AXIS)?;
    if nf * na > limits::MAP_CELLS {
        anyhow::bail!(
            "--freq {} --amp {}: {nf} x {na} = {} cells, more than the limit of {} (steady states per map)",
            a.freq,
            a.amp,
            nf * na,
            limits::MAP_CELLS
        );
    }
    let mut scn = load_scenario(&a.file, &a.steady.set)?;
    a.steady.set.refuse_replaced(
        "shortcut-map",
        &[
            ("solver.rtol", "--rtol"),
            ("base.frequency", "--freq"),
            ("base.amplitude", "--amp"),
        ],
    )?;
    // solver.max_wall_s bounds the whole command, not each cell.
    let budget = CommandBudget::start(scn.solver.max_wall_s);
    scn.solver.cancel = budget.token();
    let (problem, start) =
        Problem::from_plan(&scn.plan()).with_context(|| format!("{}", a.file.display()))?;
    let freqs = sweep::frequencies(flo, fhi, nf);
    let amps = log_space(alo, ahi, na);
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| default_out(&a.file, "-shortcut-map"));
    let maps = ["shortcut-map-force", "shortcut-map-delta"];
    let mut names = vec![
        "shortcut-map.csv".to_string(),
        "shortcut-map.h5".to_string(),
    ];
    names.extend(
        maps.iter()
            .flat_map(|m| [format!("{m}.png"), format!("{m}.svg")]),
    );
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    super::common::claim_out(&out, &names, a.force)?;
    let bar = progress_bar((nf * na) as u64, "map");
    let progress = |c: &MapCell| {
        bar.inc(1);
        bar.set_message(format!(
            "{:.1} Hz, {:.3} µm",
            c.frequency,
            c.amplitude * 1e6
        ));
    };
    let m = smap::shortcut_map(&problem, &start, &freqs, &amps, &opts, &progress);
    bar.finish_and_clear();
    let mut files = write_tables(&out, &scn, &m)?;
    files.extend(write_maps(
        &out,
        &a.file,
        &scn,
        &m,
        na > 1 && ahi / alo > 4.0,
    )?);
    let mut report = ShortcutMapReport::new(&m);
    report.files = files.iter().map(|p| p.display().to_string()).collect();
    if a.json {
        print_json(&report)?;
    } else {
        print_report(&a.file, &report)?;
    }
    if budget.exhausted() {
        let solved = m.cells.iter().filter(|c| c.error.is_none()).count();
        return Err(BudgetStopped(format!(
            "solver.max_wall_s = {} s, the budget of the whole shortcut-map command, ran out: \
             {solved} of {} cells computed; {} holds them (the others carry their error)",
            budget.seconds,
            m.cells.len(),
            out.display()
        ))
        .into());
    }
    Ok(())
}

/// `shortcut-map.csv` and `shortcut-map.h5` (group `cells`).
fn write_tables(out: &Path, scn: &Scenario, m: &ShortcutMap) -> Result<Vec<PathBuf>> {
    let table = report::map_table(m);
    let csv_path = out.join("shortcut-map.csv");
    table.save_csv(&csv_path)?;
    let attrs = [
        ("missing", Attr::text(report::MISSING)),
        ("source", Attr::text(&scn.source_name)),
        ("scenario", Attr::text(&scn.source_text)),
        ("frequency_count", Attr::I64(m.frequencies.len() as i64)),
        ("amplitude_count", Attr::I64(m.amplitudes.len() as i64)),
        (
            "layout",
            Attr::text(
                "cells row-major in amplitude: index = i_amplitude * frequency_count + i_frequency",
            ),
        ),
    ];
    let groups = [(
        "cells",
        "imposed-area shortcut vs time-domain steady state per (frequency, amplitude)",
        &table,
    )];
    let h5_path = out.join("shortcut-map.h5");
    let bytes = hdf5_tables(&attrs, None, &groups).map_err(|e| anyhow::anyhow!("HDF5: {e}"))?;
    write_atomic(&h5_path, &bytes)?;
    Ok(vec![csv_path, h5_path])
}

fn heatmap(m: &ShortcutMap, title: String, z: Vec<f64>, log_amp: bool) -> Heatmap {
    let z: Vec<f64> = z.iter().map(|v| v.abs()).collect();
    let valid = z.iter().copied().filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = valid.fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v), h.max(v)));
    // A logarithmic colour scale only when the errors span more than a decade.
    let z_log = hi > 10.0 * lo;
    let (ff, f_label) = plot::axis_label("base frequency f", "Hz", &m.frequencies);
    let (af, a_label) = plot::axis_label("base amplitude X_b", "m", &m.amplitudes);
    Heatmap {
        title,
        x_label: f_label,
        y_label: a_label,
        z_label: if z_log {
            "|relative error|, log colour scale (–)".into()
        } else {
            "|relative error| (–)".into()
        },
        x: m.frequencies.iter().map(|f| f * ff).collect(),
        y: m.amplitudes.iter().map(|x| x * af).collect(),
        z,
        x_log: false,
        y_log: log_amp,
        z_log,
        z_range: None,
        size: (1000, 700),
    }
}

/// The two colour maps (mean-force and δ_A errors), PNG and SVG.
fn write_maps(
    out: &Path,
    file: &Path,
    scn: &Scenario,
    m: &ShortcutMap,
    log_amp: bool,
) -> Result<Vec<PathBuf>> {
    let name = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let force = heatmap(
        m,
        format!(
            "{}: imposed-area error in the mean force F_m",
            scn.source_name
        ),
        m.field(|c| c.force_error),
        log_amp,
    );
    let delta = heatmap(
        m,
        format!("imposed-area error in δ_A ({name})"),
        m.field(|c| c.delta_amp_error),
        log_amp,
    );
    let (fp, fs) = plot::render_heatmap(&force, &out.join("shortcut-map-force"))?;
    let (dp, ds) = plot::render_heatmap(&delta, &out.join("shortcut-map-delta"))?;
    Ok(vec![fp, fs, dp, ds])
}

fn print_report(file: &Path, r: &ShortcutMapReport) -> anyhow::Result<()> {
    let (nf, na) = (r.frequencies.len(), r.amplitudes.len());
    outln!(
        "{}: imposed-area shortcut vs time domain over {nf} frequencies × {na} amplitudes, {:.2} s, {} periods",
        file.display(),
        r.wall_s,
        r.cycles
    )?;
    outln!(
        "  steady states found: {}/{} ({} by time-stepping, {} losing contact)",
        r.found,
        r.cells,
        r.by_time_stepping,
        r.contact_lost
    )?;
    let (f, d) = (&r.force_error, &r.delta_amp_error);
    outln!(
        "  |mean-force error|: {:.2e} … {:.2e}; < 1 %: {} cells, < 5 %: {}",
        f.min_abs,
        f.max_abs,
        f.below_1_percent,
        f.below_5_percent
    )?;
    outln!(
        "  |δ_A error|:        {:.2e} … {:.2e}; < 1 %: {} cells, < 5 %: {}",
        d.min_abs,
        d.max_abs,
        d.below_1_percent,
        d.below_5_percent
    )?;
    outln!("\n  force error (%), rows X_b (µm), columns f (Hz):")?;
    out!("  {:>10}", "")?;
    for f in &r.frequencies {
        out!("{f:>9.1}")?;
    }
    outln!()?;
    for (ia, xb) in r.amplitudes.iter().enumerate() {
        out!("  {:>10.4}", xb * 1e6)?;
        for i_f in 0..nf {
            match r.force_error_grid.get(ia * nf + i_f).copied().flatten() {
                Some(e) => out!("{:>9.2}", e * 100.0)?,
                None => out!("{:>9}", "—")?,
            }
        }
        outln!()?;
    }
    outln!("\nwrote:")?;
    for p in &r.files {
        outln!("  {p}")?;
    }
    Ok(())
}
