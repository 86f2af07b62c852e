//! The figure of one run (`run.png`, `run.svg`), drawn from its folder's `run.h5`
//! (`djkr run --plot`, `[output] plot = true`, `djkr plot DIR`):
//!
//! | | |
//! |---|---|
//! | F(t) | per-cycle mean force ⟨F⟩ |
//! | a(t) | F–δ loop of the last cycles before pull-off |
//! | δ(t) | per-cycle ⟨δ⟩ and δ_A |
//!
//! The time panels mark the stage starts (dashed) and the events (impact, contact loss,
//! pull-off). Long series are thinned for drawing by keeping each pixel column's extremes (so
//! the envelope of a vibration is drawn as it is), never averaged. Where envelope following
//! skipped base periods (the file's `/gaps`), every line breaks and the time panels shade the
//! skipped spans ("envelope: N periods skipped"): a line across a gap would draw a motion
//! nothing computed.

use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::input::{self, InputError, InputKind};
use crate::plot::{self, Figure, LegendPosition, PlotError, Series, Style};

/// The figure's file stem in a run folder.
pub const RUN_PLOT_STEM: &str = "run";
/// The files of the run's figure in its folder.
pub const RUN_PLOT_FILES: [&str; 2] = ["run.png", "run.svg"];
/// Image size (width, height) in pixels.
pub const RUN_PLOT_SIZE: (u32, u32) = (1600, 1500);
/// Points per drawn series at most (about two per pixel column).
const MAX_POINTS: usize = 3000;
/// Cycles in the F–δ loop.
const LOOP_CYCLES: usize = 3;
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
    /// Where the run came from (the `source` attribute).
    pub source: String,
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
    let source = f
        .root()
        .attrs()
        .ok()
        .and_then(|a| a.get("source").and_then(|v| v.as_str().map(str::to_string)))
        .unwrap_or_default();
    let mut s = RunSeries {
        source,
        t: f64s("t")?,
        force: f64s("F")?,
        a: f64s("a")?,
        delta: f64s("delta")?,
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

/// The index ranges of the gap-free stretches of a time series of `n` samples whose segment
/// indices are `segment` (one stretch when there are none: a file written before them).
fn stretches(segment: &[i64], n: usize) -> Vec<std::ops::Range<usize>> {
    if segment.len() != n {
        return std::iter::once(0..n).collect();
    }
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..n {
        if segment[i] != segment[i - 1] {
            out.push(start..i);
            start = i;
        }
    }
    out.push(start..n);
    out
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

/// One time panel: the series, the stage starts and the events.
fn time_panel(
    s: &RunSeries,
    title: &str,
    y_label: &str,
    y: &[f64],
    scale: f64,
    event_value: fn(&(String, f64, f64, f64, f64)) -> f64,
) -> Figure {
    let (tx, ty) = thin_broken(&s.t, y, &stretches(&s.segment, s.t.len()));
    let ty: Vec<f64> = ty.iter().map(|v| v * scale).collect();
    let (lo, hi) = ty
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let mut fig = Figure::new(title, "t (s)", y_label).with_legend(LegendPosition::LowerLeft);
    if let Some(band) = gap_band(s) {
        fig.series.push(band);
    }
    fig.series
        .push(Series::new("", tx, ty, Style::Line).with_color(0));
    if lo.is_finite() && hi.is_finite() {
        let (mut bx, mut by) = (Vec::new(), Vec::new());
        for e in s
            .events
            .iter()
            .filter(|e| e.0 == "stage-start" && e.1 > 0.0)
        {
            bx.extend([e.1, e.1, f64::NAN]);
            by.extend([lo, hi, f64::NAN]);
        }
        if !bx.is_empty() {
            fig.series
                .push(Series::new("stage start", bx, by, Style::Dashed).with_color(9));
        }
    }
    // Pull-off as a ring, first: the contact loss it often coincides with stays visible inside.
    for (kind, color, style) in [
        ("pull-off", 1, Style::Rings),
        ("impact", 3, Style::Markers),
        ("contact-loss", 2, Style::Markers),
    ] {
        let (ex, ey): (Vec<f64>, Vec<f64>) = s
            .events
            .iter()
            .filter(|e| e.0 == kind)
            .take(MAX_EVENT_MARKERS)
            .map(|e| (e.1, event_value(e) * scale))
            .unzip();
        if !ex.is_empty() {
            fig.series
                .push(Series::new(kind, ex, ey, style).with_color(color));
        }
    }
    fig
}

/// The shaded spans of the gaps, labelled with the periods skipped in them (`None`: no gap).
fn gap_band(s: &RunSeries) -> Option<Series> {
    if s.gaps.is_empty() {
        return None;
    }
    let x: Vec<f64> = s.gaps.iter().flat_map(|g| [g.0, g.1]).collect();
    let periods: i64 = s.gaps.iter().map(|g| g.2).sum();
    let y = vec![f64::NAN; x.len()];
    Some(
        Series::new(
            format!("envelope: {periods} periods skipped"),
            x,
            y,
            Style::Band,
        )
        .with_color(7),
    )
}

/// The six panels of a run's figure.
pub fn run_panels(s: &RunSeries) -> Vec<Figure> {
    let f = time_panel(
        s,
        "contact force F(t)",
        "F (mN, compressive +)",
        &s.force,
        1e3,
        |e| e.2,
    );
    let a = time_panel(s, "contact radius a(t)", "a (mm)", &s.a, 1e3, |e| e.3);
    let d = time_panel(
        s,
        "indentation δ(t)",
        "δ (µm, compressive +)",
        &s.delta,
        1e6,
        |e| e.4,
    );
    let mut fm = Figure::new(
        if s.cycles.is_empty() {
            "per-cycle mean force: no cycles (the shaker never ran)"
        } else {
            "per-cycle mean force ⟨F⟩"
        },
        "t at the cycle's end (s)",
        "⟨F⟩ (mN)",
    );
    let (cx, cy) = broken_cycles(&s.cycles, |c| c[2] * 1e3);
    let (cx, cy) = thin_nan(&cx, &cy);
    let lone = isolated(&cx, &cy);
    fm.series
        .push(Series::new("", cx, cy, Style::Line).with_color(1));
    if let Some((x, y)) = lone {
        fm.series
            .push(Series::new("", x, y, Style::Markers).with_color(1));
    }
    if let Some(po) = s.events.iter().find(|e| e.0 == "pull-off") {
        if let Some(best) = s
            .cycles
            .iter()
            .filter(|c| c[1] <= po.1)
            .min_by(|a, b| a[2].total_cmp(&b[2]))
        {
            fm.series.push(
                Series::new(
                    "pull-off force",
                    vec![best[1]],
                    vec![best[2] * 1e3],
                    Style::Markers,
                )
                .with_color(2),
            );
        }
    }
    // The F–δ loop: the last cycles that end before pull-off (or the run's end); without
    // cycles, the whole run.
    let end = s
        .events
        .iter()
        .find(|e| e.0 == "pull-off")
        .map_or(f64::INFINITY, |e| e.1);
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
                format!("F–δ loop: the last {k} cycle(s) before pull-off"),
            )
        }
    };
    let inside: Vec<usize> = (0..s.t.len().min(s.delta.len()).min(s.force.len()))
        .filter(|&i| s.t[i] >= t0 && s.t[i] <= t1)
        .collect();
    let stride = inside.len().div_ceil(MAX_POINTS).max(1);
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
        lx.push(s.delta[i] * 1e6);
        ly.push(s.force[i] * 1e3);
        prev = Some(i);
    }
    let mut lp = Figure::new(loop_title, "δ (µm)", "F (mN)");
    lp.series
        .push(Series::new("", lx, ly, Style::Line).with_color(4));
    let mut dp = Figure::new("per-cycle ⟨δ⟩ and δ_A", "t at the cycle's end (s)", "µm")
        .with_legend(LegendPosition::UpperRight);
    for (name, idx, color) in [("⟨δ⟩", 3, 0), ("δ_A", 4, 2)] {
        let (x, y) = broken_cycles(&s.cycles, |c| c[idx] * 1e6);
        let (x, y) = thin_nan(&x, &y);
        let lone = isolated(&x, &y);
        dp.series
            .push(Series::new(name, x, y, Style::Line).with_color(color));
        if let Some((x, y)) = lone {
            dp.series
                .push(Series::new("", x, y, Style::Markers).with_color(color));
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

    #[test]
    fn a_contact_loss_at_the_pull_off_stays_visible() {
        // Issue 25: the contact-loss marker was drawn under the pull-off marker at the same
        // point. The pull-off is a ring drawn first; the dots of the other events come after it.
        let ev = |kind: &str| (kind.to_string(), 1.0, -0.01, 1e-4, -1e-6);
        let s = RunSeries {
            source: "x".into(),
            t: vec![0.0, 1.0, 2.0],
            force: vec![0.0, -0.01, 0.0],
            a: vec![1e-3, 1e-4, 0.0],
            delta: vec![1e-6, -1e-6, -2e-6],
            events: vec![ev("contact-loss"), ev("pull-off")],
            cycles: Vec::new(),
            segment: Vec::new(),
            gaps: Vec::new(),
        };
        let panels = run_panels(&s);
        // The time panels: F, a and δ (positions 0, 2, 4).
        for fig in [&panels[0], &panels[2], &panels[4]] {
            let pos = |label: &str| fig.series.iter().position(|x| x.label == label).unwrap();
            let (po, cl) = (pos("pull-off"), pos("contact-loss"));
            assert_eq!(fig.series[po].style, Style::Rings, "{}", fig.title);
            assert_eq!(fig.series[cl].style, Style::Markers, "{}", fig.title);
            assert!(
                po < cl,
                "{}: the pull-off ring must be drawn first",
                fig.title
            );
        }
    }
}
