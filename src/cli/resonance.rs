//! `djkr resonance`: the frequency response by continuation (up and down sweeps of the periodic
//! steady state), with the linear transfer and harmonic balance alongside; writes
//! `resonance.csv`, `resonance.h5` and plots, prints a summary.

use super::common::default_out;
use super::common::{
    limits, load_scenario, positive_quantity, print_json, write_atomic, BudgetStopped,
    CommandBudget,
};
use super::steady::{progress_bar, range, stem, SteadyArgs};
use crate::api;
use crate::output::hdf5_file::{hdf5_tables, Attr};
use crate::plot::{self, Figure, LegendPosition, Series, Style};
use crate::reports::steady::{self as report, NoPeak, ResonanceReport};
use crate::scenario::Scenario;
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use djkr_core::steady::sweep::{self, Direction, Linearisation, Sweep, SweepPoint};
use djkr_core::steady::{Options, Problem};
use djkr_core::units::Dimension;
use std::path::{Path, PathBuf};

/// Sweep direction(s).
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepArg {
    /// Increasing frequency.
    Up,
    /// Decreasing frequency.
    Down,
    /// Both, in parallel.
    Both,
}

/// Flags of `djkr resonance`.
#[derive(Args, Debug)]
#[command(after_help = super::common::STEADY_UNUSED_KEYS)]
pub struct ResonanceArgs {
    /// Scenario file (mechanics, contact, mean load, base amplitude; see `djkr validate`).
    file: PathBuf,
    /// Frequencies START:STOP:COUNT, evenly spaced, e.g. 300:500:101 or 300Hz:0.5kHz:41.
    #[arg(long, value_name = "START:STOP:N", allow_hyphen_values = true)]
    freq: String,
    /// Sweep direction.
    #[arg(long, value_enum, default_value = "both")]
    sweep: SweepArg,
    /// Base amplitude X_b [default: the scenario's]. Units: m, mm, um, nm.
    #[arg(long, value_name = "X_B", allow_hyphen_values = true)]
    amp: Option<String>,
    /// Output directory for resonance.csv, resonance.h5 and the plots [default:
    /// out/<scenario name>-resonance].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Overwrite files in --out that djkr did not write under the names this command writes;
    /// without it such a file stops the command before any work. Nothing else is touched.
    #[arg(long)]
    force: bool,
    /// Skip the harmonic-balance predictor.
    #[arg(long)]
    no_harmonic_balance: bool,
    /// Print a JSON summary (SI values) instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    steady: SteadyArgs,
}

/// Run `djkr resonance`.
pub fn resonance(a: &ResonanceArgs) -> Result<()> {
    let opts = a.steady.options()?;
    let (lo, hi, n) = range(
        "--freq",
        &a.freq,
        Dimension::Frequency,
        limits::RESONANCE_FREQUENCIES,
    )?;
    let mut scn = load_scenario(&a.file, &a.steady.set)?;
    let mut replaced = vec![("solver.rtol", "--rtol"), ("base.frequency", "--freq")];
    if a.amp.is_some() {
        replaced.push(("base.amplitude", "--amp alone"));
    }
    a.steady.set.refuse_replaced("resonance", &replaced)?;
    // solver.max_wall_s bounds the whole command, not each frequency (401 frequencies with 1 s
    // took 62 s): every steady state polls the budget's flag.
    let budget = CommandBudget::start(scn.solver.max_wall_s);
    scn.solver.cancel = budget.token();
    let (mut problem, start) =
        Problem::from_plan(&scn.plan()).with_context(|| format!("{}", a.file.display()))?;
    if let Some(t) = &a.amp {
        let xb = positive_quantity("--amp", t, Dimension::Length)?;
        problem = problem.at(problem.frequency, xb)?;
    }
    let which = match a.sweep {
        SweepArg::Up => api::Sweeps::Up,
        SweepArg::Down => api::Sweeps::Down,
        SweepArg::Both => api::Sweeps::Both,
    };
    let dirs = if which == api::Sweeps::Both { 2 } else { 1 };
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| default_out(&a.file, "-resonance"));
    let names = [
        "resonance.csv",
        "resonance.h5",
        "resonance.png",
        "resonance.svg",
    ];
    let phase = ["resonance-phase.png", "resonance-phase.svg"];
    super::common::claim_out(&out, &[&names[..], &phase[..]].concat(), a.force)?;
    let bar = progress_bar((n * dirs) as u64, "sweep");
    let progress = |d: Direction, p: &SweepPoint| {
        bar.inc(1);
        bar.set_message(format!("{} {:.2} Hz", d.name(), p.frequency));
    };
    let res = api::resonance(
        &problem,
        &start,
        (lo, hi, n),
        which,
        &opts,
        !a.no_harmonic_balance,
        &progress,
    );
    bar.finish_and_clear();
    let (sweeps, lin, wall) = (&res.sweeps, &res.linearisation, res.wall_s);

    let mut report = ResonanceReport::new(
        sweeps,
        (lo, hi, n),
        lin.as_ref().map_err(String::as_str),
        wall,
    );
    let mut files = write_tables(&out, &scn, &res, &opts)?;
    let (fig, phase) = figures(
        &a.file,
        sweeps,
        res.harmonic_balance,
        lin.as_ref().ok(),
        (lo, hi),
        edge_of(&report),
    );
    let (png, svg) = plot::render(&fig, &out.join("resonance"))?;
    let (ppng, psvg) = plot::render(&phase, &out.join("resonance-phase"))?;
    files.extend([png, svg, ppng, psvg]);

    report.files = files.iter().map(|p| p.display().to_string()).collect();
    if a.json {
        print_json(&report)?;
    } else {
        print_report(&a.file, &report)?;
    }
    if budget.exhausted() {
        let done: Vec<String> = sweeps
            .iter()
            .map(|s| {
                let solved = s.points.iter().filter(|p| p.steady.is_some()).count();
                format!("{solved} of {n} {}", s.direction.name())
            })
            .collect();
        return Err(BudgetStopped(format!(
            "solver.max_wall_s = {} s, the budget of the whole resonance command, ran out: \
             steady states for {} frequencies; {} holds them",
            budget.seconds,
            done.join(", "),
            out.display()
        ))
        .into());
    }
    Ok(())
}

/// `resonance.csv` (all sweeps in one table) and `resonance.h5` (one group per direction).
fn write_tables(
    out: &Path,
    scn: &Scenario,
    res: &api::Resonance,
    opts: &Options,
) -> Result<Vec<PathBuf>> {
    let sweeps = &res.sweeps;
    let csv_path = out.join("resonance.csv");
    res.table().save_csv(&csv_path)?;
    let tables: Vec<_> = sweeps.iter().map(report::sweep_table).collect();
    let groups: Vec<(&str, &str, &crate::output::Table)> = sweeps
        .iter()
        .zip(&tables)
        .map(|(sw, t)| {
            (
                sw.direction.name(),
                "frequency sweep: time-domain steady state per frequency, started from the previous one",
                t,
            )
        })
        .collect();
    let attrs = [
        ("missing", Attr::text(report::MISSING)),
        ("source", Attr::text(&scn.source_name)),
        ("scenario", Attr::text(&scn.source_text)),
        (
            "base_amplitude",
            Attr::F64(sweeps.first().map_or(f64::NAN, |s| s.amplitude)),
        ),
        ("tolerance", Attr::F64(opts.tol)),
        ("rtol", Attr::F64(opts.rtol)),
    ];
    let h5_path = out.join("resonance.h5");
    let bytes = hdf5_tables(&attrs, None, &groups).map_err(|e| anyhow::anyhow!("HDF5: {e}"))?;
    write_atomic(&h5_path, &bytes)?;
    Ok(vec![csv_path, h5_path])
}

/// The magnitude and phase plots.
fn figures(
    file: &Path,
    sweeps: &[Sweep],
    harmonic: bool,
    lin: Option<&Linearisation>,
    (lo, hi): (f64, f64),
    edge: Option<&str>,
) -> (Figure, Figure) {
    let amplitude = sweeps.first().map_or(f64::NAN, |s| s.amplitude);
    // The frequency axis in Hz or kHz, as its range suits.
    let (ff, f_label) = plot::axis_label("frequency f", "Hz", &[lo, hi]);
    // A maximum at an end of the range is not a resonance peak: the title says so.
    let what = edge.map_or("frequency response".to_string(), |e| {
        format!("no peak in range (largest at the {e} end)")
    });
    let mut fig = Figure::new(
        format!("{what}, X_b = {:.3} µm ({})", amplitude * 1e6, stem(file)),
        f_label.clone(),
        "|δ_A / X_b| (–)",
    )
    .with_legend(LegendPosition::UpperRight);
    let mut phase = Figure::new(
        format!(
            "phase φ of δ_1, δ − δ_m ≈ |δ_1| sin(ωt + φ) ({})",
            stem(file)
        ),
        f_label,
        "phase φ (rad)",
    )
    .with_legend(LegendPosition::UpperRight);
    let in_unit = |x: Vec<f64>| -> Vec<f64> { x.iter().map(|f| f * ff).collect() };
    for (i, sw) in sweeps.iter().enumerate() {
        // The second sweep as rings over the first's dots: both visible where they agree.
        let style = if i == 0 {
            Style::LineMarkers
        } else {
            Style::Rings
        };
        let label = format!("time domain, sweep {}", sw.direction.name());
        let series = |f: &dyn Fn(&SweepPoint) -> Option<f64>| {
            let (x, y) = report::sorted_by_frequency(&sw.points, f);
            Series::new(label.clone(), in_unit(x), y, style).with_color(i)
        };
        fig = fig.with_series(series(&|p| {
            p.steady.as_ref().map(|s| s.transfer_magnitude())
        }));
        phase = phase.with_series(series(&|p| p.steady.as_ref().map(|s| s.transfer_phase())));
        if harmonic {
            let (x, y) = report::sorted_by_frequency(&sw.points, |p| {
                p.harmonic.map(|h| h.harmonics.delta_amp / amplitude)
            });
            let name = format!("harmonic balance, {}", sw.direction.name());
            fig =
                fig.with_series(Series::new(name, in_unit(x), y, Style::Dashed).with_color(3 + i));
        }
    }
    if let Some(l) = lin {
        let fd = sweep::frequencies(lo, hi, 801);
        let y: Vec<f64> = fd.iter().map(|&f| l.linear(f).magnitude()).collect();
        let yp: Vec<f64> = fd.iter().map(|&f| l.linear(f).phase()).collect();
        let name = "linear transfer, k_c = 3/2 K a_0";
        let fd = in_unit(fd);
        fig = fig.with_series(Series::new(name, fd.clone(), y, Style::Line).with_color(2));
        phase =
            phase.with_series(Series::new("linear transfer", fd, yp, Style::Line).with_color(2));
    }
    (fig, phase)
}

/// "no peak in range: largest |δ_A/X_b| = 1.0205 at 300.000 Hz, the low end".
fn no_peak(n: &NoPeak) -> String {
    format!(
        "no peak in range: largest |δ_A/X_b| = {:.4} at {:.3} Hz, the {} end",
        n.height, n.frequency, n.largest_at
    )
}

/// The end ("low", "high") where a time-domain sweep's response is largest, when no sweep has a
/// peak inside the range.
fn edge_of(r: &ResonanceReport) -> Option<&'static str> {
    if r.sweeps().any(|s| s.peak.is_some()) {
        return None;
    }
    r.sweeps()
        .find_map(|s| s.no_peak_in_range.map(|n| n.largest_at))
}

fn print_report(file: &Path, r: &ResonanceReport) -> anyhow::Result<()> {
    let (lo, hi) = r.range;
    outln!(
        "{}: frequency response {lo}–{hi} Hz ({} frequencies), X_b = {:.4} µm, {:.2} s",
        file.display(),
        r.frequencies,
        r.amplitude * 1e6,
        r.wall_s
    )?;
    if let (Some(k), Some(f)) = (r.contact_stiffness, r.linear_resonance_frequency) {
        outln!(
            "  linear transfer (k_c = 3/2 K a_0 = {k:.1} N/m): f_r = {f:.3} Hz{}",
            match (r.linear_peak, r.linear_no_peak_in_range) {
                (Some(p), _) => format!(
                    ", peak |δ_A/X_b| = {:.4} at {:.3} Hz",
                    p.height, p.frequency
                ),
                (None, Some(n)) => format!(", {}", no_peak(&n)),
                (None, None) => String::new(),
            }
        )?;
    }
    for sw in r.sweeps() {
        out!(
            "  sweep {:<4}: {}/{} steady states ({} by shooting), {} periods, {:.2} s",
            sw.direction,
            sw.found,
            r.frequencies,
            sw.by_shooting,
            sw.cycles,
            sw.wall_s
        )?;
        if let Some(p) = sw.peak {
            out!(
                "; peak |δ_A/X_b| = {:.4} at {:.3} Hz",
                p.height,
                p.frequency
            )?;
            if let (Some(s), Some(h)) = (p.shift_from_linear, p.height_over_linear) {
                out!(" (shift {s:+.3} Hz, height ×{h:.4} of linear)")?;
            }
        }
        if let Some(n) = sw.no_peak_in_range {
            out!("; {}", no_peak(&n))?;
        }
        outln!()?;
        if let Some(p) = sw.harmonic_balance_peak {
            outln!(
                "              harmonic balance peak {:.4} at {:.3} Hz",
                p.height,
                p.frequency
            )?;
        }
        if let Some(n) = sw.harmonic_balance_no_peak_in_range {
            outln!("              harmonic balance: {}", no_peak(&n))?;
        }
    }
    if let Some(d) = r.max_up_down_difference {
        outln!(
            "  largest up/down difference in |δ_A/X_b|: {:.3e} at {:.3} Hz",
            d.delta_amp_over_xb,
            d.frequency
        )?;
    }
    for note in &r.notes {
        outln!("  {note}")?;
    }
    if let Some(end) = edge_of(r) {
        let linear = r
            .linear_resonance_frequency
            .map(|f| format!(" (the linear resonance f_r is at {f:.3} Hz)"))
            .unwrap_or_default();
        outln!(
            "  no peak in {lo}–{hi} Hz: the response is largest at the {end} end{linear}; \
             a --freq range reaching beyond that end finds the resonance"
        )?;
    }
    outln!("\nwrote:")?;
    for p in &r.files {
        outln!("  {p}")?;
    }
    Ok(())
}
