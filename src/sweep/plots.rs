//! A sweep's figures (PNG + SVG, through [`crate::plot`]):
//! - `amplification`: the pull-off amplification against the swept numeric key with the most
//!   values (the first given on a tie), one line per value of the other swept keys; with an ensemble the
//!   point's mean with bars of ± one standard deviation of the members;
//! - `amplification-map`: with exactly two swept keys, both numeric, a heat map of the (mean)
//!   amplification;
//! - `phase`: with an ensemble, each member's amplification against its base phase, one look
//!   (colour, then marker shape) per point, named in the legend; more points than there are
//!   distinct looks ([`MAX_KEYED_POINTS`]) are drawn alike, and the legend says so.
//!
//! Axes are in the unit that suits the swept values (µm, kHz, ...: [`plot::axis_label`]);
//! dimensionless ones say `(–)`. The legends are placed by the plot layer where they cover no
//! data.
//!
//! A log range (`START:STOP:Nlog`) gets a log axis. Points whose runs all failed are gaps.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::output::table::format_f64;
use crate::plot::{self, Figure, Heatmap, LegendPosition, Series, Style};

use super::row::{KeyInfo, Row};
use super::spec::KeyCell;
use super::stats::PointStats;

/// The stem names of the figures.
pub const AMPLIFICATION: &str = "amplification";
/// The heat map's stem.
pub const AMPLIFICATION_MAP: &str = "amplification-map";
/// The phase figure's stem.
pub const PHASE: &str = "phase";

/// The axis label of key `k` in the display unit `unit` ([`plot::display_unit`]; "–" for a
/// dimensionless key).
fn label(k: &KeyInfo, unit: &str) -> String {
    match k.unit.as_deref() {
        Some(_) => format!("{} ({})", k.name, plot::unit_text(unit)),
        None => k.name.clone(),
    }
}

/// Points of a phase figure that can each have a look of their own (7 colours × 5 markers).
pub const MAX_KEYED_POINTS: usize = 35;

/// The display unit of key `j` over the sweep's points, and its factor from SI.
fn key_display(keys: &[KeyInfo], points: &[PointStats], j: usize) -> (f64, String) {
    let values: Vec<f64> = points.iter().filter_map(|p| p.keys[j].num()).collect();
    match keys[j].unit.as_deref() {
        Some(u) if u != "1" => plot::display_unit(u, &values),
        _ => (1.0, String::new()),
    }
}

/// Error bars smaller than this fraction of the mean are not drawn: at a plot's resolution
/// (about 1 part in 1000) they are invisible, and drawn they suggest a spread that is rounding
/// (a deterministic rig's members differ by ~1e-7).
const MIN_BAR: f64 = 1e-3;

fn value_text(k: &KeyInfo, c: &KeyCell) -> String {
    match (c, k.unit.as_deref()) {
        (KeyCell::Num(x), Some(u)) if u != "1" => {
            let (f, unit) = plot::display_unit(u, &[*x]);
            format!("{} = {} {unit}", k.name, short(*x * f))
        }
        _ => format!("{} = {c}", k.name),
    }
}

/// A number with at most 4 significant digits.
fn short(x: f64) -> String {
    let s = format!("{x:.4e}");
    match s.parse::<f64>() {
        Ok(y) => format_f64(y),
        Err(_) => s,
    }
}

/// Keys whose value changes between points.
fn varying(points: &[PointStats], nkeys: usize) -> Vec<usize> {
    (0..nkeys)
        .filter(|&j| {
            let first = points.first().and_then(|p| p.keys.get(j));
            points.iter().any(|p| p.keys.get(j) != first)
        })
        .collect()
}

/// The files [`sweep_plots`] may write for a sweep (the phase figure only for an `ensemble`;
/// which of the others depends on the rows), claimed before a sweep or `djkr plot` writes into
/// a folder.
pub fn plot_file_names(ensemble: bool) -> Vec<String> {
    let mut stems = vec![AMPLIFICATION, AMPLIFICATION_MAP];
    if ensemble {
        stems.push(PHASE);
    }
    stems
        .iter()
        .flat_map(|s| [format!("{s}.png"), format!("{s}.svg")])
        .collect()
}

/// Draw the figures that fit a sweep over `keys` (paired by `--zip` when `zip`, with members
/// when `ensemble`); returns the files written.
pub fn sweep_plots(
    dir: &Path,
    keys: &[KeyInfo],
    zip: bool,
    ensemble: bool,
    points: &[PointStats],
    rows: &[Row],
) -> Result<Vec<PathBuf>, plot::PlotError> {
    let vary = varying(points, keys.len());
    let mut files = Vec::new();
    let numeric = |j: usize| keys[j].unit.is_some();
    if let Some(xj) = x_key(keys, points, &vary) {
        let fig = amplification_figure(keys, points, &vary, xj, ensemble);
        let (png, svg) = plot::render(&fig, &dir.join(AMPLIFICATION))?;
        files.extend([png, svg]);
    }
    if vary.len() == 2 && !zip && vary.iter().all(|&j| numeric(j)) {
        if let Some(map) = amplification_map(keys, points, (vary[0], vary[1]), ensemble) {
            let (png, svg) = plot::render_heatmap(&map, &dir.join(AMPLIFICATION_MAP))?;
            files.extend([png, svg]);
        }
    }
    if ensemble {
        let fig = phase_figure(keys, points, rows, &vary);
        let (png, svg) = plot::render(&fig, &dir.join(PHASE))?;
        files.extend([png, svg]);
    }
    Ok(files)
}

/// The x axis of the amplification figure: of the varying keys `vary`, the numeric one with the
/// most distinct values (the first given on a tie).
fn x_key(keys: &[KeyInfo], points: &[PointStats], vary: &[usize]) -> Option<usize> {
    let numeric = |j: usize| keys[j].unit.is_some();
    let distinct = |j: usize| {
        let mut v: Vec<u64> = points
            .iter()
            .filter_map(|p| p.keys[j].num().map(f64::to_bits))
            .collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    vary.iter()
        .copied()
        .filter(|&j| numeric(j))
        .fold(None, |best: Option<(usize, usize)>, j| {
            let n = distinct(j);
            match best {
                Some((_, m)) if m >= n => best,
                _ => Some((j, n)),
            }
        })
        .map(|(j, _)| j)
}

/// `amplification`: the amplification against key `xj`, one line per value of the other
/// varying keys; with an `ensemble`, bars of ± one standard deviation of the members.
fn amplification_figure(
    keys: &[KeyInfo],
    points: &[PointStats],
    vary: &[usize],
    xj: usize,
    ensemble: bool,
) -> Figure {
    let others: Vec<usize> = vary.iter().copied().filter(|&j| j != xj).collect();
    let mut groups: Vec<(String, Vec<&PointStats>)> = Vec::new();
    for p in points {
        let name = others
            .iter()
            .map(|&j| value_text(&keys[j], &p.keys[j]))
            .collect::<Vec<_>>()
            .join(", ");
        match groups.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => v.push(p),
            None => groups.push((name, vec![p])),
        }
    }
    let (xf, xu) = key_display(keys, points, xj);
    let mut fig = Figure::new(
        if ensemble {
            format!(
                "pull-off amplification against {} (bars < 0.1 % not drawn)",
                keys[xj].name
            )
        } else {
            format!("pull-off amplification against {}", keys[xj].name)
        },
        label(&keys[xj], &xu),
        if ensemble {
            "pull-off amplification, mean ± std of members (–)"
        } else {
            "pull-off amplification (–)"
        },
    )
    .with_log(keys[xj].log, false)
    .with_legend(LegendPosition::UpperLeft);
    for (g, (name, mut pts)) in groups.into_iter().enumerate() {
        pts.sort_by(|a, b| {
            let x = |p: &PointStats| p.keys[xj].num().unwrap_or(f64::NAN);
            x(a).total_cmp(&x(b))
        });
        let xs: Vec<f64> = pts
            .iter()
            .map(|p| p.keys[xj].num().unwrap_or(f64::NAN) * xf)
            .collect();
        let ys: Vec<f64> = pts.iter().map(|p| p.amplification.mean).collect();
        fig.series
            .push(Series::new(name, xs.clone(), ys.clone(), Style::LineMarkers).with_color(g));
        if pts.iter().any(|p| p.amplification.n >= 2) {
            let (mut bx, mut by) = (Vec::new(), Vec::new());
            for (p, x) in pts.iter().zip(&xs) {
                let s = p.amplification;
                if s.std.is_finite() && s.std >= MIN_BAR * s.mean.abs() {
                    bx.extend([*x, *x, f64::NAN]);
                    by.extend([s.mean - s.std, s.mean + s.std, f64::NAN]);
                }
            }
            fig.series
                .push(Series::new("", bx, by, Style::Line).with_color(g));
        }
    }
    fig
}

/// `amplification-map`: the (mean) amplification over the numeric keys `xj` and `yj`, or `None`
/// when either has fewer than two values or a value that is not finite.
fn amplification_map(
    keys: &[KeyInfo],
    points: &[PointStats],
    (xj, yj): (usize, usize),
    ensemble: bool,
) -> Option<Heatmap> {
    let axis = |j: usize| {
        let mut v: Vec<f64> = points.iter().filter_map(|p| p.keys[j].num()).collect();
        v.sort_by(f64::total_cmp);
        v.dedup_by(|a, b| a.to_bits() == b.to_bits());
        v
    };
    let (xf, xu) = key_display(keys, points, xj);
    let (yf, yu) = key_display(keys, points, yj);
    let (x, y) = (axis(xj), axis(yj));
    let finite = x.iter().chain(&y).all(|v| v.is_finite());
    if !(x.len() >= 2 && y.len() >= 2 && finite) {
        return None;
    }
    let mut cell: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    for p in points {
        let pos = |v: &[f64], j: usize| {
            p.keys[j]
                .num()
                .and_then(|k| v.iter().position(|a| a.to_bits() == k.to_bits()))
        };
        if let (Some(ix), Some(iy)) = (pos(&x, xj), pos(&y, yj)) {
            cell.insert((ix, iy), p.amplification.mean);
        }
    }
    let mut z = vec![f64::NAN; x.len() * y.len()];
    for ((ix, iy), v) in cell {
        z[iy * x.len() + ix] = v;
    }
    Some(Heatmap {
        title: format!(
            "pull-off amplification{}: {} × {}",
            if ensemble { " (mean of members)" } else { "" },
            keys[xj].name,
            keys[yj].name
        ),
        x_label: label(&keys[xj], &xu),
        y_label: label(&keys[yj], &yu),
        z_label: "pull-off amplification (–)".into(),
        x_log: keys[xj].log,
        y_log: keys[yj].log,
        x: x.iter().map(|v| v * xf).collect(),
        y: y.iter().map(|v| v * yf).collect(),
        z,
        z_log: false,
        z_range: None,
        size: plot::DEFAULT_SIZE,
    })
}

/// `phase`: each member's amplification against its base phase, one look per point, named by
/// the varying keys `vary` (by its number when no key varies); more than [`MAX_KEYED_POINTS`]
/// points are drawn alike as one series that says so.
fn phase_figure(keys: &[KeyInfo], points: &[PointStats], rows: &[Row], vary: &[usize]) -> Figure {
    let mut fig = Figure::new(
        "pull-off amplification against the base phase at shaker-on",
        "phase (rad)",
        "pull-off amplification (–)",
    )
    .with_x_range(0.0, std::f64::consts::TAU)
    .with_legend(LegendPosition::UpperRight);
    let mut by_point: BTreeMap<usize, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for r in rows {
        if let Some(a) = r.amplification() {
            let e = by_point.entry(r.point).or_default();
            e.0.push(r.phase);
            e.1.push(a);
        }
    }
    if by_point.len() > MAX_KEYED_POINTS {
        let n = by_point.len();
        let (xs, ys): (Vec<f64>, Vec<f64>) = by_point
            .into_values()
            .flat_map(|(x, y)| x.into_iter().zip(y))
            .unzip();
        fig.series.push(
            Series::new(
                format!("members of all {n} points (too many to tell apart)"),
                xs,
                ys,
                Style::Markers,
            )
            .with_color(1),
        );
        return fig;
    }
    // One point needs no legend; two or more each get a look and a name.
    let labelled = by_point.len() >= 2;
    for (i, (p, (xs, ys))) in by_point.into_iter().enumerate() {
        let name = if labelled {
            points
                .iter()
                .find(|s| s.point == p)
                .map(|s| {
                    let v: Vec<String> = vary
                        .iter()
                        .map(|&j| value_text(&keys[j], &s.keys[j]))
                        .collect();
                    if v.is_empty() {
                        format!("point {p}")
                    } else {
                        v.join(", ")
                    }
                })
                .unwrap_or_default()
        } else {
            String::new()
        };
        fig.series
            .push(Series::new(name, xs, ys, Style::Markers).with_color(i));
    }
    fig
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // values scaled by exact powers of ten, compared exactly
mod tests {
    use super::*;
    use crate::sweep::stats::Summary;

    fn point(i: usize, xb: f64, mean: f64, std: f64) -> PointStats {
        let s = Summary {
            n: 8,
            mean,
            std,
            ..Summary::of([1.0, 2.0])
        };
        PointStats {
            point: i,
            keys: vec![KeyCell::Num(xb)],
            members: 8,
            failed: 0,
            force: s,
            amplification: s,
        }
    }

    #[test]
    fn axes_in_micrometres_and_no_bars_for_rounding_spreads() {
        // Issue 25: the axis in metres (1e-5) and bars drawn for σ ≈ 1e-7.
        let keys = vec![KeyInfo {
            name: "base.amplitude".into(),
            unit: Some("m".into()),
            log: false,
        }];
        let pts = vec![
            point(0, 10e-6, 9.57, 1e-7),
            point(1, 20e-6, 20.0, 0.5),
            point(2, 30e-6, 30.0, 1e-6),
        ];
        let fig = amplification_figure(&keys, &pts, &[0], 0, true);
        assert_eq!(fig.x_label, "base.amplitude (µm)");
        assert_eq!(fig.series[0].x, vec![10.0, 20.0, 30.0]);
        // One bar: the point whose spread is visible.
        let bars = &fig.series[1];
        assert_eq!(bars.x.iter().filter(|x| x.is_finite()).count(), 2);
        assert!(bars.x.iter().all(|x| x.is_nan() || *x == 20.0));
    }
}
