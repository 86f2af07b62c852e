//! The figure of one run (`run.png`, `run.svg`), drawn from its folder's `run.h5`
//! (`djkr run --plot`, `[output] plot = true`, `djkr plot DIR`):
//!
//! | | |
//! |---|---|
//! | F(t) | per-cycle mean force ⟨F⟩ |
//! | a(t) | F–δ loop of the last cycles before pull-off |
//! | δ(t) | per-cycle ⟨δ⟩ and δ_A |
//!
//! The time panels mark the stage starts (dashed) and the events (impact, contact loss, the
//! detachment: the `pull-off` event, when the contact was lost for good). The pull-off itself,
//! the most tensile (cycle-mean) force, is marked at its force and time in F(t) and ⟨F⟩, and only
//! when the run detached with a tensile force (the file's `detached` and `pull_off_force`); a
//! title names a pull-off only then. Long series are thinned for reading by keeping the extremes
//! of buckets much narrower than a pixel column (never averaged); the plot layer then draws a
//! series denser than the pixels as the min–max band of each pixel column, so a vibration is
//! drawn as the band it fills, without the moiré of a line through some of its samples. Where
//! envelope following skipped base periods (the file's `/gaps`), every line breaks and the time
//! panels shade the skipped spans ("envelope: N periods skipped"): a line across a gap would draw
//! a motion nothing computed. Axes are in the SI prefix that suits the run (mN or N, µm or mm,
//! ms or s).

use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::input::{self, InputError, InputKind};
use crate::output::timeseries;
use crate::plot::{self, Figure, LegendPosition, PlotError, Series, Style, GREY};

/// The figure's file stem in a run folder.
pub const RUN_PLOT_STEM: &str = "run";
/// The files of the run's figure in its folder.
pub const RUN_PLOT_FILES: [&str; 2] = ["run.png", "run.svg"];
/// Image size (width, height) in pixels.
pub const RUN_PLOT_SIZE: (u32, u32) = (1600, 1500);
/// Points per series handed to the plot layer at most: the extremes of 10 000 buckets, more
/// than ten per pixel column, so that the plot layer's min–max band of each column is that of
/// the samples.
const MAX_POINTS: usize = 20_000;
/// Cycles in the F–δ loop.
const LOOP_CYCLES: usize = 3;
/// Points of the F–δ loop at most (its abscissa goes back and forth: a line, not a band).
const LOOP_POINTS: usize = 3000;
/// Markers per event kind at most (impacts can happen every cycle).
const MAX_EVENT_MARKERS: usize = 300;

/// Why a run's figure could not be made.
#[derive(Debug, Error)]
pub enum RunPlotError {
    /// The run file could not be read.
    #[error("{}: {message}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Drawing failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// What the figure shows, read from a run's `run.h5`.
#[derive(Debug, Clone, Default)]
pub struct RunSeries {
    /// Time (s).
    pub t: Vec<f64>,
    /// Contact force (N).
    pub force: Vec<f64>,
    /// Contact radius (m).
    pub a: Vec<f64>,
    /// Indentation (m).
    pub delta: Vec<f64>,
    /// Events: kind, time (s), F (N), a (m), δ (m).
    pub events: Vec<(String, f64, f64, f64, f64)>,
    /// Per cycle: t_start, t_end (s), ⟨F⟩ (N), ⟨δ⟩ (m), δ_A (m).
    pub cycles: Vec<[f64; 5]>,
    /// The segment index of each sample (`/segment`; empty in files written before it).
    pub segment: Vec<i64>,
    /// Gaps of the time series: t_start, t_end (s), periods skipped (`/gaps`).
    pub gaps: Vec<(f64, f64, i64)>,
    /// The pull-off, (time (s), force (N)): the most tensile (cycle-mean) contact force, present
    /// only for a run that detached with a tensile force (root attributes `detached`,
    /// `pull_off_time`, `pull_off_force`).
    pub pull_off: Option<(f64, f64)>,
}

/// Open a run file for reading: through the one reader of input files
/// ([`crate::input::open`]: a regular file of at most [`InputKind::RunFile`]'s limit, opened
/// without blocking, so a FIFO or a link to `/dev/zero` is refused at once), then parsed by
/// `hdf5-pure` from that open file, never from the path again. It reads what it needs on demand
/// ([`hdf5_pure::ReadSeekSource`]) within the length measured once at the open, a length held
/// to the same limit: a file that grows meanwhile is not read past it, and memory holds the
/// series read, not the file.
fn open_run_file(path: &Path) -> Result<hdf5_pure::File, String> {
    let kind = InputKind::RunFile;
    let file = input::open(path, kind).map_err(|e| e.to_string())?;
    let source = hdf5_pure::ReadSeekSource::new(file)
        .map_err(|e| format!("not a readable HDF5 file: {e}"))?;
    if hdf5_pure::Source::len(&source) > kind.limit() {
        return Err(InputError::too_large(kind).to_string());
    }
    hdf5_pure::File::from_source(source).map_err(|e| format!("not a readable HDF5 file: {e}"))
}

/// Read the series of a run file.
pub fn read_run(path: &Path) -> Result<RunSeries, RunPlotError> {
    let err = |message: String| RunPlotError::Read {
        path: path.to_path_buf(),
        message,
    };
    let f = open_run_file(path).map_err(err)?;
    let f64s = |name: &str| -> Result<Vec<f64>, RunPlotError> {
        f.dataset(name)
            .and_then(|d| d.read_f64())
            .map_err(|e| err(format!("dataset {name}: {e}")))
    };
    let attrs = f.root().attrs().unwrap_or_default();
    let number = |name: &str| attrs.get(name).and_then(|v| v.as_f64());
    let detached = attrs.get("detached").and_then(|v| v.as_i64()) == Some(1);
    let pull_off = match (number("pull_off_time"), number("pull_off_force")) {
        (Some(t), Some(force)) if detached && t.is_finite() && force < 0.0 => Some((t, force)),
        _ => None,
    };
    let mut s = RunSeries {
        t: f64s("t")?,
        force: f64s("F")?,
        a: f64s("a")?,
        delta: f64s("delta")?,
        pull_off,
        ..RunSeries::default()
    };
    let kinds = f
        .dataset("events/kind")
        .and_then(|d| d.read_string())
        .map_err(|e| err(format!("dataset events/kind: {e}")))?;
    let (et, ef, ea, ed) = (
        f64s("events/time")?,
        f64s("events/F")?,
        f64s("events/a")?,
        f64s("events/delta")?,
    );
    s.events = kinds
        .into_iter()
        .enumerate()
        .filter_map(|(i, k)| Some((k, *et.get(i)?, *ef.get(i)?, *ea.get(i)?, *ed.get(i)?)))
        .collect();
    if let Ok(d) = f.dataset("segment") {
        s.segment = d
            .read_i64()
            .map_err(|e| err(format!("dataset segment: {e}")))?;
    }
    if f.dataset("gaps/t_start").is_ok() {
        let (t0, t1) = (f64s("gaps/t_start")?, f64s("gaps/t_end")?);
        let periods = f
            .dataset("gaps/periods")
            .and_then(|d| d.read_i64())
            .map_err(|e| err(format!("dataset gaps/periods: {e}")))?;
        s.gaps = t0
            .into_iter()
            .zip(t1)
            .zip(periods)
            .map(|((a, b), p)| (a, b, p))
            .collect();
    }
    if f.dataset("cycles/t_end").is_ok() {
        let (t0, t1, fm, dm, ds, dc) = (
            f64s("cycles/t_start")?,
            f64s("cycles/t_end")?,
            f64s("cycles/force_mean")?,
            f64s("cycles/delta_mean")?,
            f64s("cycles/delta_sin")?,
            f64s("cycles/delta_cos")?,
        );
        s.cycles = (0..t1.len().min(t0.len()).min(fm.len()))
            .filter_map(|i| {
                Some([
                    t0[i],
                    t1[i],
                    fm[i],
                    *dm.get(i)?,
                    ds.get(i)?.hypot(*dc.get(i)?),
                ])
            })
            .collect();
    }
    Ok(s)
}

/// [`thin_to`] within each stretch of `ranges` (about `MAX_POINTS` in all, each stretch its share
/// and at least its two ends), the stretches separated by a NaN so that no line joins them.
fn thin_broken(x: &[f64], y: &[f64], ranges: &[std::ops::Range<usize>]) -> (Vec<f64>, Vec<f64>) {
    let n = x.len().min(y.len()).max(1);
    let (mut xo, mut yo) = (Vec::new(), Vec::new());
    for (k, r) in ranges.iter().enumerate() {
        let r = r.start.min(x.len().min(y.len()))..r.end.min(x.len().min(y.len()));
        if k > 0 {
            xo.push(f64::NAN);
            yo.push(f64::NAN);
        }
        let share = (MAX_POINTS * r.len() / n).max(4);
        let (a, b) = thin_to(&x[r.clone()], &y[r], share);
        xo.extend(a);
        yo.extend(b);
    }
    (xo, yo)
}

/// Per-cycle values `(t_end, value)` with a NaN between two records that are not contiguous
/// (envelope following skipped periods between them), so that no line joins them.
fn broken_cycles(cycles: &[[f64; 5]], value: impl Fn(&[f64; 5]) -> f64) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for (i, c) in cycles.iter().enumerate() {
        if let Some(p) = i.checked_sub(1).map(|j| &cycles[j]) {
            // Contiguous records share a boundary; half a period apart is a skip.
            if c[0] - p[1] > 0.5 * (p[1] - p[0]) {
                x.push(f64::NAN);
                y.push(f64::NAN);
            }
        }
        x.push(c[1]);
        y.push(value(c));
    }
    (x, y)
}

/// [`thin_broken`] of a series whose stretches are separated by NaN abscissae.
fn thin_nan(x: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut ranges = Vec::new();
    let mut start = 0;
    for (i, v) in x.iter().enumerate() {
        if v.is_nan() {
            if i > start {
                ranges.push(start..i);
            }
            start = i + 1;
        }
    }
    if x.len() > start {
        ranges.push(start..x.len());
    }
    thin_broken(x, y, &ranges)
}

/// The points of a NaN-separated series that stand alone between two breaks (a record between
/// two skips), which a line does not show: drawn as markers (`None`: there are none).
fn isolated(x: &[f64], y: &[f64]) -> Option<(Vec<f64>, Vec<f64>)> {
    let gap = |i: Option<usize>| i.and_then(|i| x.get(i)).is_none_or(|v| v.is_nan());
    let (lx, ly): (Vec<f64>, Vec<f64>) = (0..x.len().min(y.len()))
        .filter(|&i| !x[i].is_nan() && gap(i.checked_sub(1)) && gap(Some(i + 1)))
        .map(|i| (x[i], y[i]))
        .unzip();
    // A run without breaks drawn as one line needs none.
    (!lx.is_empty() && x.iter().any(|v| v.is_nan())).then_some((lx, ly))
}

/// Keep at most `max` of (x, y): the extremes of y in each of `max / 2` buckets, in order.
fn thin_to(x: &[f64], y: &[f64], max: usize) -> (Vec<f64>, Vec<f64>) {
    let n = x.len().min(y.len());
    if n <= max {
        return (x[..n].to_vec(), y[..n].to_vec());
    }
    let buckets = max / 2;
    let (mut xo, mut yo) = (Vec::with_capacity(max), Vec::with_capacity(max));
    for b in 0..buckets {
        let (lo, hi) = (
            b * n / buckets,
            ((b + 1) * n / buckets).max(b * n / buckets + 1),
        );
        let (mut imin, mut imax) = (lo, lo);
        for i in lo..hi.min(n) {
            if y[i] < y[imin] {
                imin = i;
            }
            if y[i] > y[imax] {
                imax = i;
            }
        }
        for i in if imin <= imax {
            [imin, imax]
        } else {
            [imax, imin]
        } {
            xo.push(x[i]);
            yo.push(y[i]);
        }
    }
    (xo, yo)
}

/// Palette indices of the marks, the same in every panel: the pull-off an orange square (the
/// orange of the palette, in its second cycle), the detachment a blue ring (so that a contact
/// loss at the same point stays visible inside), impacts green, contact losses vermillion.
const PULL_OFF_COLOR: usize = plot::COLOR_COUNT + 5;
const DETACHMENT_COLOR: usize = 1;
const IMPACT_COLOR: usize = 3;
const CONTACT_LOSS_COLOR: usize = 2;

/// The event kinds marked in the time panels: the file's kind, its legend text, colour, style.
const MARKED_EVENTS: [(&str, &str, usize, Style); 3] = [
    ("pull-off", "detachment", DETACHMENT_COLOR, Style::Rings),
    ("impact", "impact", IMPACT_COLOR, Style::Markers),
    (
        "contact-loss",
        "contact loss",
        CONTACT_LOSS_COLOR,
        Style::Markers,
    ),
];

/// What a time panel shows: the quantity's name and SI unit, its samples, and its value at an
/// event.
struct Quantity<'a> {
    title: &'a str,
    name: &'a str,
    unit: &'a str,
    values: &'a [f64],
    at_event: fn(&(String, f64, f64, f64, f64)) -> f64,
}

/// The pull-off marker of a panel in display units (`None`: the run has no pull-off).
fn pull_off_marker(s: &RunSeries, t_scale: f64, f_scale: f64) -> Option<Series> {
    let (t, force) = s.pull_off?;
    // Under vibration the pull-off force is a cycle mean, reached at the end of its cycle.
    let mean = s
        .cycles
        .iter()
        .any(|c| (c[1] - t).abs() <= 1e-9 * t.abs().max(f64::MIN_POSITIVE));
    let label = if mean {
        "pull-off: most tensile ⟨F⟩"
    } else {
        "pull-off: most tensile F"
    };
    Some(
        Series::new(
            label,
            vec![t * t_scale],
            vec![force * f_scale],
            Style::Markers,
        )
        .with_color(PULL_OFF_COLOR),
    )
}

/// The display unit of the run's time axis.
fn time_axis(s: &RunSeries) -> (f64, String) {
    let ends: Vec<f64> = s.t.first().into_iter().chain(s.t.last()).copied().collect();
    plot::axis_label("t", "s", &ends)
}

/// One time panel: the series, the stage starts and the events; F(t) also the pull-off.
fn time_panel(s: &RunSeries, q: &Quantity, force: bool) -> Figure {
    let (ts, t_label) = time_axis(s);
    let (ys, y_label) = plot::axis_label(q.name, q.unit, q.values);
    let (tx, ty) = thin_broken(&s.t, q.values, &timeseries::pieces(&s.segment, s.t.len()));
    let tx: Vec<f64> = tx.iter().map(|v| v * ts).collect();
    let ty: Vec<f64> = ty.iter().map(|v| v * ys).collect();
    let (lo, hi) = ty
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let mut fig = Figure::new(q.title, t_label, y_label).with_legend(LegendPosition::UpperRight);
    if let Some(band) = gap_band(s, ts) {
        fig.series.push(band);
    }
    let trace = q.title.split_whitespace().last().unwrap_or_default();
    fig.series
        .push(Series::new(trace, tx, ty, Style::Line).with_color(0));
    if lo.is_finite() && hi.is_finite() {
        let (mut bx, mut by) = (Vec::new(), Vec::new());
        for e in s
            .events
            .iter()
            .filter(|e| e.0 == "stage-start" && e.1 > 0.0)
        {
            bx.extend([e.1 * ts, e.1 * ts, f64::NAN]);
            by.extend([lo, hi, f64::NAN]);
        }
        if !bx.is_empty() {
            fig.series
                .push(Series::new("stage start", bx, by, Style::Dashed).with_color(GREY));
        }
    }
    if force {
        fig.series.extend(pull_off_marker(s, ts, ys));
    }
    // The detachment as a ring, first: the contact loss it often coincides with stays visible
    // inside.
    for (kind, label, color, style) in MARKED_EVENTS {
        let (ex, ey): (Vec<f64>, Vec<f64>) = s
            .events
            .iter()
            .filter(|e| e.0 == kind)
            .take(MAX_EVENT_MARKERS)
            .map(|e| (e.1 * ts, (q.at_event)(e) * ys))
            .unzip();
        if !ex.is_empty() {
            fig.series
                .push(Series::new(label, ex, ey, style).with_color(color));
        }
    }
    fig
}

/// The shaded spans of the gaps (times scaled by `ts`), labelled with the periods skipped in
/// them (`None`: no gap).
fn gap_band(s: &RunSeries, ts: f64) -> Option<Series> {
    if s.gaps.is_empty() {
        return None;
    }
    let x: Vec<f64> = s.gaps.iter().flat_map(|g| [g.0 * ts, g.1 * ts]).collect();
    let periods: i64 = s.gaps.iter().map(|g| g.2).sum();
    let y = vec![f64::NAN; x.len()];
    Some(
        Series::new(
            format!("envelope: {periods} periods skipped"),
            x,
            y,
            Style::Band,
        )
        .with_color(GREY),
    )
}

/// "the last cycle" or "the last k cycles".
fn last_cycles(k: usize) -> String {
    if k == 1 {
        "the last cycle".to_string()
    } else {
        format!("the last {k} cycles")
    }
}

/// The six panels of a run's figure.
pub fn run_panels(s: &RunSeries) -> Vec<Figure> {
    let f = time_panel(
        s,
        &Quantity {
            title: "contact force F(t)",
            name: "F, compressive +",
            unit: "N",
            values: &s.force,
            at_event: |e| e.2,
        },
        true,
    );
    let a = time_panel(
        s,
        &Quantity {
            title: "contact radius a(t)",
            name: "a",
            unit: "m",
            values: &s.a,
            at_event: |e| e.3,
        },
        false,
    );
    let d = time_panel(
        s,
        &Quantity {
            title: "indentation δ(t)",
            name: "δ, compressive +",
            unit: "m",
            values: &s.delta,
            at_event: |e| e.4,
        },
        false,
    );
    let cycle_ends: Vec<f64> = s.cycles.iter().map(|c| c[1]).collect();
    let (cts, ct_label) = plot::axis_label("t at the cycle's end", "s", &cycle_ends);
    let mean_forces: Vec<f64> = s
        .cycles
        .iter()
        .map(|c| c[2])
        .chain(s.pull_off.map(|p| p.1))
        .collect();
    let (fs, f_label) = plot::axis_label("⟨F⟩", "N", &mean_forces);
    let mut fm = Figure::new(
        if s.cycles.is_empty() {
            "per-cycle mean force: no cycles (the shaker never ran)"
        } else {
            "per-cycle mean force ⟨F⟩"
        },
        ct_label.clone(),
        f_label,
    )
    .with_legend(LegendPosition::UpperRight);
    let (cx, cy) = broken_cycles(&s.cycles, |c| c[2]);
    let (cx, cy) = thin_nan(&cx, &cy);
    let lone = isolated(&cx, &cy);
    let scale = |v: Vec<f64>, k: f64| -> Vec<f64> { v.iter().map(|x| x * k).collect() };
    fm.series
        .push(Series::new("", scale(cx, cts), scale(cy, fs), Style::Line).with_color(1));
    if let Some((x, y)) = lone {
        fm.series
            .push(Series::new("", scale(x, cts), scale(y, fs), Style::Markers).with_color(1));
    }
    if let Some(po) = pull_off_marker(s, cts, fs) {
        fm.series[0].label = "⟨F⟩ of each cycle".into();
        fm.series.push(po);
    }
    // The F–δ loop: the last cycles that end before the detachment, else the last of the run;
    // without cycles, the whole run. The title says which.
    let (end, until) = match s.events.iter().find(|e| e.0 == "pull-off") {
        Some(e) => (e.1, " before the detachment"),
        None => (f64::INFINITY, " of the run"),
    };
    let before: Vec<&[f64; 5]> = s.cycles.iter().filter(|c| c[1] <= end).collect();
    let (t0, t1, loop_title) = match before.len() {
        0 => (
            f64::NEG_INFINITY,
            f64::INFINITY,
            "F–δ over the whole run".to_string(),
        ),
        n => {
            let first = before[n.saturating_sub(LOOP_CYCLES)];
            let k = n.min(LOOP_CYCLES);
            (
                first[0],
                before[n - 1][1],
                format!("F–δ loop: {}{until}", last_cycles(k)),
            )
        }
    };
    let inside: Vec<usize> = (0..s.t.len().min(s.delta.len()).min(s.force.len()))
        .filter(|&i| s.t[i] >= t0 && s.t[i] <= t1)
        .collect();
    let stride = inside.len().div_ceil(LOOP_POINTS).max(1);
    let seg = |i: usize| s.segment.get(i).copied().unwrap_or(0);
    let (mut lx, mut ly) = (Vec::new(), Vec::new());
    let mut prev: Option<usize> = None;
    for (k, &i) in inside.iter().enumerate() {
        let ends_stretch = inside.get(k + 1).is_none_or(|&j| seg(j) != seg(i));
        if k % stride != 0 && !ends_stretch && prev.is_none_or(|p| seg(p) == seg(i)) {
            continue;
        }
        if prev.is_some_and(|p| seg(p) != seg(i)) {
            // A gap between the two: the loop's line breaks there.
            lx.push(f64::NAN);
            ly.push(f64::NAN);
        }
        lx.push(s.delta[i]);
        ly.push(s.force[i]);
        prev = Some(i);
    }
    let (lxs, lx_label) = plot::axis_label("δ", "m", &lx);
    let (lys, ly_label) = plot::axis_label("F", "N", &ly);
    let mut lp = Figure::new(loop_title, lx_label, ly_label);
    lp.series
        .push(Series::new("", scale(lx, lxs), scale(ly, lys), Style::Line).with_color(4));
    let deltas: Vec<f64> = s.cycles.iter().flat_map(|c| [c[3], c[4]]).collect();
    let (ds, d_label) = plot::axis_label("⟨δ⟩, δ_A", "m", &deltas);
    let mut dp = Figure::new("per-cycle ⟨δ⟩ and δ_A", ct_label, d_label)
        .with_legend(LegendPosition::UpperRight);
    for (name, idx, color) in [("⟨δ⟩", 3, 0), ("δ_A", 4, 2)] {
        let (x, y) = broken_cycles(&s.cycles, |c| c[idx]);
        let (x, y) = thin_nan(&x, &y);
        let lone = isolated(&x, &y);
        dp.series
            .push(Series::new(name, scale(x, cts), scale(y, ds), Style::Line).with_color(color));
        if let Some((x, y)) = lone {
            dp.series.push(
                Series::new("", scale(x, cts), scale(y, ds), Style::Markers).with_color(color),
            );
        }
    }
    vec![f, fm, a, lp, d, dp]
}

/// Draw `run.png` and `run.svg` into a run folder from its `run.h5`.
pub fn plot_run_dir(dir: &Path) -> Result<(PathBuf, PathBuf), RunPlotError> {
    let h5 = dir.join(crate::output::HDF5_NAME);
    if !h5.exists() {
        return Err(RunPlotError::Read {
            path: h5,
            message: "missing: not a run folder (djkr run writes run.h5 and summary.json)".into(),
        });
    }
    let s = read_run(&h5)?;
    let panels = run_panels(&s);
    Ok(plot::render_panels(
        &panels,
        2,
        RUN_PLOT_SIZE,
        &dir.join(RUN_PLOT_STEM),
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(events: Vec<(String, f64, f64, f64, f64)>) -> RunSeries {
        RunSeries {
            t: vec![0.0, 1.0, 2.0],
            force: vec![0.0, -0.01, 0.0],
            a: vec![1e-3, 1e-4, 0.0],
            delta: vec![1e-6, -1e-6, -2e-6],
            events,
            ..RunSeries::default()
        }
    }

    #[test]
    fn a_contact_loss_at_the_detachment_stays_visible() {
        // Issue 25: the contact-loss marker was drawn under the pull-off marker at the same
        // point. The detachment is a ring drawn first; the dots of the other events come after.
        let ev = |kind: &str| (kind.to_string(), 1.0, -0.01, 1e-4, -1e-6);
        let panels = run_panels(&series(vec![ev("contact-loss"), ev("pull-off")]));
        // The time panels: F, a and δ (positions 0, 2, 4).
        for fig in [&panels[0], &panels[2], &panels[4]] {
            let pos = |label: &str| fig.series.iter().position(|x| x.label == label).unwrap();
            let (po, cl) = (pos("detachment"), pos("contact loss"));
            assert_eq!(fig.series[po].style, Style::Rings, "{}", fig.title);
            assert_eq!(fig.series[cl].style, Style::Markers, "{}", fig.title);
            assert!(
                po < cl,
                "{}: the detachment ring must be drawn first",
                fig.title
            );
        }
    }

    #[test]
    fn the_pull_off_is_marked_at_its_force_and_time_and_only_when_there_was_one() {
        // Issue 33: the "pull-off" marker sat at F = 0 at the detachment (21.59 s) instead of
        // at the most tensile cycle mean (-102.8 mN at 20.83 s).
        let det = ("pull-off".to_string(), 2.0, 0.0, 0.0, -2e-6);
        let mut s = series(vec![det.clone()]);
        s.cycles = vec![[0.0, 0.5, -0.005, 0.0, 1e-6], [0.5, 1.0, -0.009, 0.0, 1e-6]];
        s.pull_off = Some((1.0, -0.009));
        let panels = run_panels(&s);
        for fig in [&panels[0], &panels[1]] {
            let po = fig
                .series
                .iter()
                .find(|x| x.label.starts_with("pull-off"))
                .unwrap_or_else(|| panic!("{}: no pull-off", fig.title));
            assert_eq!(po.label, "pull-off: most tensile ⟨F⟩", "{}", fig.title);
            // Time in s (a 2 s run), force in mN.
            assert!(fig.y_label.ends_with("(mN)"), "{}", fig.y_label);
            assert_eq!((po.x[0], po.y[0]), (1.0, -9.0), "{}", fig.title);
        }
        let det_marker = panels[0]
            .series
            .iter()
            .find(|x| x.label == "detachment")
            .unwrap();
        assert_eq!((det_marker.x[0], det_marker.y[0]), (2.0, 0.0));
        assert_eq!(
            panels[3].title,
            "F–δ loop: the last 2 cycles before the detachment"
        );
        // No pull-off (no detachment, or no tensile force): no marker, no title naming one.
        let mut s = series(Vec::new());
        s.cycles = vec![[0.0, 0.5, 0.005, 0.0, 1e-6], [0.5, 1.0, 0.009, 0.0, 1e-6]];
        let panels = run_panels(&s);
        for fig in &panels {
            assert!(!fig.title.contains("pull-off"), "{}", fig.title);
            assert!(
                fig.series.iter().all(|x| !x.label.contains("pull-off")),
                "{}",
                fig.title
            );
        }
        assert_eq!(panels[3].title, "F–δ loop: the last 2 cycles of the run");
    }

    #[test]
    fn a_dense_oscillation_is_drawn_as_the_band_it_fills() {
        // Issue 33: F(t) of a vibration denser than the pixels showed a moiré that looked like
        // beating (a line through thinned samples). 300 000 samples of a constant-amplitude
        // sine, 3000 periods: several periods per pixel column, so every column of the drawn
        // band must reach from the trough to the crest.
        let n = 300_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-5).collect();
        let force: Vec<f64> = t
            .iter()
            .map(|&t| 0.1 * (std::f64::consts::TAU * 1000.0 * t).sin())
            .collect();
        let s = RunSeries {
            a: vec![1e-3; n],
            delta: vec![1e-6; n],
            t,
            force,
            ..RunSeries::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let panels = run_panels(&s);
        let (_, svg) =
            plot::render_panels(&panels[..1], 1, (800, 500), &dir.path().join("f")).unwrap();
        let svg = std::fs::read_to_string(svg).unwrap();
        let band = svg
            .lines()
            .find(|l| l.starts_with("<polygon") && l.contains("fill=\"#000000\""))
            .expect("the trace is drawn as a band");
        let pts: Vec<(i32, i32)> = band
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap()
            .split_whitespace()
            .map(|p| {
                let (x, y) = p.split_once(',').unwrap();
                (x.parse().unwrap(), y.parse().unwrap())
            })
            .collect();
        let mut extent = std::collections::BTreeMap::<i32, (i32, i32)>::new();
        for (x, y) in pts {
            let e = extent.entry(x).or_insert((y, y));
            *e = (e.0.min(y), e.1.max(y));
        }
        let heights: Vec<i32> = extent.values().map(|e| e.1 - e.0).collect();
        let (lo, hi) = (
            *heights.iter().min().unwrap(),
            *heights.iter().max().unwrap(),
        );
        assert!(heights.len() > 400, "{} columns", heights.len());
        assert!(
            f64::from(lo) >= 0.97 * f64::from(hi),
            "column heights from {lo} to {hi} px: the band beats"
        );
    }
}

/// Gaps as data, from a run to its figure (the run's files and the panels drawn from them).
#[cfg(test)]
#[path = "run_plot_gaps_tests.rs"]
mod gaps_tests;
