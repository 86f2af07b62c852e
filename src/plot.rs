//! A thin plotting layer over `plotters`: line/marker figures and heat maps, written as PNG and SVG.
//!
//! Text is drawn with DejaVu Sans embedded in the binary (the `dejavu` crate), registered with
//! plotters' `ab_glyph` font table once per process, so no system font or fontconfig is needed.
//! The SVG output names the family `sans-serif` in its `<text>` elements (a viewer substitutes its
//! own sans font; layout was computed with DejaVu Sans metrics).
//!
//! Robustness rules: non-finite points (and, on a log axis, non-positive ones) are skipped and
//! split a line into separate pieces — they never panic and never reach the drawing; a series whose
//! x and y lengths differ is an error, not a silent truncation. Files are written atomically: each
//! is drawn and encoded in memory, then written by [`crate::output::write_atomic`] (partial name,
//! renamed into place), so an interrupted run leaves no `stem.png` / `stem.svg` that looks
//! complete but is not.
//!
//! What a reader sees: the legend lists every labelled series and sits where it covers no data
//! (the emptiest corner of the plotting area, else outside it on the right:
//! `src/plot/layout.rs`); the colours are colour-blind safe and series that share a colour
//! differ in marker and dash (`src/plot/look.rs`); a line denser than the pixels is drawn as
//! the min–max band of each pixel column, never as a line through some of its samples; axis
//! values are in the SI prefix that suits them ([`display_unit`], [`axis_label`]).

use plotters::coord::combinators::{IntoLogRange, LogCoord};
use plotters::coord::ranged1d::{
    AsRangedCoord, DefaultFormatting, KeyPointHint, Ranged, ValueFormatter,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use thiserror::Error;

mod layout;
mod look;

use layout::{column_band, dashes, place_legend, Corner, Placement, Prim, Px};
use look::{look, Look};
pub use look::{Shape, COLOR_COUNT, GREY};

/// The unit a reader expects for values `values` of SI unit `si`, and the factor from SI to it:
/// µm rather than `1e-5` m, mN rather than `0.02` N, kHz rather than `1500` Hz (the largest
/// |value| picks the prefix that puts it in [1, 1000)). Units without prefixed forms here
/// (J/m^2, rad, dimensionless) stay as given.
pub fn display_unit(si: &str, values: &[f64]) -> (f64, String) {
    let top = values
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let pick = |steps: &[(f64, &str)]| -> (f64, String) {
        // `steps`: (factor, unit) from the largest unit down; the first that makes top ≥ 1.
        for &(f, u) in steps {
            if top * f >= 1.0 {
                return (f, u.to_string());
            }
        }
        let (f, u) = steps[steps.len() - 1];
        (f, u.to_string())
    };
    match si {
        "m" if top > 0.0 => pick(&[(1.0, "m"), (1e3, "mm"), (1e6, "µm"), (1e9, "nm")]),
        "N" if top > 0.0 => pick(&[(1.0, "N"), (1e3, "mN"), (1e6, "µN")]),
        "m/s" if top > 0.0 => pick(&[(1.0, "m/s"), (1e3, "mm/s"), (1e6, "µm/s")]),
        "s" if top > 0.0 => pick(&[(1.0, "s"), (1e3, "ms"), (1e6, "µs")]),
        "kg" if top > 0.0 => pick(&[(1.0, "kg"), (1e3, "g"), (1e6, "mg")]),
        "Hz" if top > 0.0 => pick(&[(1e-6, "MHz"), (1e-3, "kHz"), (1.0, "Hz")]),
        "Pa" if top > 0.0 => pick(&[(1e-9, "GPa"), (1e-6, "MPa"), (1e-3, "kPa"), (1.0, "Pa")]),
        "N/m" if top > 0.0 => pick(&[(1e-3, "kN/m"), (1.0, "N/m")]),
        _ => (1.0, si.to_string()),
    }
}

/// The unit written in an axis label for SI unit `si`: "–" for a dimensionless quantity (`""`
/// or `"1"`), else `si` itself.
pub fn unit_text(si: &str) -> &str {
    match si {
        "" | "1" | "-" => "–",
        u => u,
    }
}

/// An axis label for `quantity` of SI unit `si` over `values`, in the unit a reader expects
/// ([`display_unit`]), and the factor from SI to that unit: `("base.amplitude", "m", [3e-6])`
/// gives `(1e6, "base.amplitude (µm)")`; a dimensionless quantity is labelled `(–)`.
pub fn axis_label(quantity: &str, si: &str, values: &[f64]) -> (f64, String) {
    let (f, unit) = display_unit(si, values);
    (f, format!("{quantity} ({})", unit_text(&unit)))
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Line through the points in order (solid, or the dash pattern of its palette index);
    /// denser than the pixels, a band from the smallest to the largest value of each pixel
    /// column.
    Line,
    /// Dashed line through the points in order.
    Dashed,
    /// One filled marker per point (a circle, or the shape of its palette index), no line.
    Markers,
    /// [`Style::Line`] plus a marker at every point.
    LineMarkers,
    /// One ring (a hollow marker, larger than a filled one) per point, no line: drawn over or
    /// under the filled markers of another series at the same points, both stay visible.
    Rings,
    /// Light vertical bands over the whole height of the plot, drawn under every other series:
    /// `x` holds their edges in pairs (`[a0, b0, a1, b1, ...]`, one band from each `a` to its
    /// `b`) and `y` is not used (NaN, so that it leaves the axis range alone). Shades spans of
    /// time, e.g. those envelope following skipped.
    Band,
}

/// One data series of a [`Figure`].
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text; an empty label gives no legend entry.
    pub label: String,
    /// Abscissae (same length as `y`).
    pub x: Vec<f64>,
    /// Ordinates (same length as `x`).
    pub y: Vec<f64>,
    /// Line or marker style.
    pub style: Style,
    /// Index into the palette ([`palette_color`]; [`GREY`] for reference lines and marks); `None`
    /// uses the series' position in the figure. Indices from [`COLOR_COUNT`] on repeat the
    /// colours with another marker shape and dash pattern, so that series with different
    /// indices never look alike.
    pub color: Option<usize>,
}

impl Series {
    /// A series with the palette colour chosen by position.
    pub fn new(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>, style: Style) -> Self {
        Self {
            label: label.into(),
            x,
            y,
            style,
            color: None,
        }
    }

    /// Same series with palette colour `index`.
    pub fn with_color(mut self, index: usize) -> Self {
        self.color = Some(index);
        self
    }
}

/// The corner a figure's legend box prefers. The legend goes into the first corner, this one
/// first, where it covers no data, and outside the plotting area when every corner covers data
/// (the plotting area then narrows to make room on its right).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendPosition {
    /// Upper left corner (default).
    #[default]
    UpperLeft,
    /// Upper right corner.
    UpperRight,
    /// Lower right corner.
    LowerRight,
}

/// A 2-D figure: axes, labels and series.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Caption above the plot.
    pub title: String,
    /// Horizontal axis label (with units).
    pub x_label: String,
    /// Vertical axis label (with units).
    pub y_label: String,
    /// Logarithmic horizontal axis (non-positive x are skipped).
    pub x_log: bool,
    /// Logarithmic vertical axis (non-positive y are skipped).
    pub y_log: bool,
    /// Fixed horizontal range; `None` fits the finite data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed vertical range; `None` fits the finite data.
    pub y_range: Option<(f64, f64)>,
    /// The data, drawn in order (later series on top).
    pub series: Vec<Series>,
    /// The corner the legend prefers (it moves where it covers no data).
    pub legend: LegendPosition,
    /// Image size in pixels (width, height), for both PNG and SVG.
    pub size: (u32, u32),
}

impl Figure {
    /// An empty linear-axes figure of the default size (1000 × 700 px).
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_log: false,
            y_log: false,
            x_range: None,
            y_range: None,
            series: Vec::new(),
            legend: LegendPosition::default(),
            size: DEFAULT_SIZE,
        }
    }

    /// Append a series.
    pub fn with_series(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }

    /// Set logarithmic axes.
    pub fn with_log(mut self, x_log: bool, y_log: bool) -> Self {
        self.x_log = x_log;
        self.y_log = y_log;
        self
    }

    /// Fix the horizontal range.
    pub fn with_x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x_range = Some((lo, hi));
        self
    }

    /// Prefer a corner for the legend.
    pub fn with_legend(mut self, pos: LegendPosition) -> Self {
        self.legend = pos;
        self
    }
}

/// A 2-D colour map over a rectilinear grid of cell centres, with a colour bar.
#[derive(Debug, Clone, PartialEq)]
pub struct Heatmap {
    /// Caption above the map.
    pub title: String,
    /// Horizontal axis label (with units).
    pub x_label: String,
    /// Vertical axis label (with units).
    pub y_label: String,
    /// Colour-bar label (with units).
    pub z_label: String,
    /// Cell centres along x, strictly increasing, finite (and > 0 when `x_log`).
    pub x: Vec<f64>,
    /// Cell centres along y, strictly increasing, finite (and > 0 when `y_log`).
    pub y: Vec<f64>,
    /// Values, row-major: `z[iy * x.len() + ix]`. Non-finite cells (and non-positive ones when
    /// `z_log`) are drawn grey.
    pub z: Vec<f64>,
    /// Logarithmic x axis.
    pub x_log: bool,
    /// Logarithmic y axis.
    pub y_log: bool,
    /// Logarithmic colour scale.
    pub z_log: bool,
    /// Fixed colour range; `None` spans the valid data.
    pub z_range: Option<(f64, f64)>,
    /// Image size in pixels (width, height).
    pub size: (u32, u32),
}

/// Why a figure could not be written.
#[derive(Debug, Error)]
pub enum PlotError {
    /// A file could not be written, renamed or its directory read.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// plotters failed while drawing.
    #[error("{path}: drawing failed: {message}")]
    Draw {
        /// The file being drawn.
        path: PathBuf,
        /// plotters' message.
        message: String,
    },
    /// The figure description is inconsistent (lengths, ranges, grid).
    #[error("figure '{title}': {message}")]
    Invalid {
        /// The figure's title.
        title: String,
        /// What is wrong.
        message: String,
    },
    /// The embedded font could not be registered.
    #[error("embedded font could not be registered: {0}")]
    Font(String),
}

/// Default image size (width, height) in pixels.
pub const DEFAULT_SIZE: (u32, u32) = (1000, 700);

const FONT_FAMILY: &str = "sans-serif";

/// Register DejaVu Sans (regular and bold) as plotters' `sans-serif` family, once per process.
fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "DejaVu Sans regular".to_string())?;
            plotters::style::register_font(FONT_FAMILY, FontStyle::Bold, dejavu::sans::bold())
                .map_err(|_| "DejaVu Sans bold".to_string())?;
            Ok(())
        })
        .clone()
        .map_err(PlotError::Font)
}

/// Render `fig` to `stem.png` and `stem.svg` (the stem's extension, if any, is replaced). Creates
/// the parent directory if needed. Returns the two paths (PNG, SVG).
pub fn render(fig: &Figure, path_stem: &Path) -> Result<(PathBuf, PathBuf), PlotError> {
    validate_figure(fig)?;
    ensure_font()?;
    let (png, svg) = output_paths(path_stem)?;
    write_png(&png, fig.size, |area| draw_figure(area, fig))?;
    write_svg(&svg, fig.size, |area| draw_figure(area, fig))?;
    Ok((png, svg))
}

/// Render `map` to `stem.png` and `stem.svg`, a colour map with a colour bar on the right.
pub fn render_heatmap(map: &Heatmap, path_stem: &Path) -> Result<(PathBuf, PathBuf), PlotError> {
    validate_heatmap(map)?;
    ensure_font()?;
    let (png, svg) = output_paths(path_stem)?;
    write_png(&png, map.size, |area| draw_heatmap(area, map))?;
    write_svg(&svg, map.size, |area| draw_heatmap(area, map))?;
    Ok((png, svg))
}

/// Render `panels` side by side in `columns` columns (as many rows as needed) on one image of
/// `size` pixels, to `stem.png` and `stem.svg`; each panel is a [`Figure`] drawn in its cell
/// (its own `size` is replaced by the cell's).
pub fn render_panels(
    panels: &[Figure],
    columns: usize,
    size: (u32, u32),
    path_stem: &Path,
) -> Result<(PathBuf, PathBuf), PlotError> {
    let cols = columns.max(1);
    let rows = panels.len().div_ceil(cols).max(1);
    let cell = (size.0 / cols as u32, size.1 / rows as u32);
    let panels: Vec<Figure> = panels
        .iter()
        .map(|f| Figure {
            size: cell,
            ..f.clone()
        })
        .collect();
    for f in &panels {
        validate_figure(f)?;
    }
    ensure_font()?;
    let (png, svg) = output_paths(path_stem)?;
    write_png(&png, size, |area| draw_panels(area, &panels, (rows, cols)))?;
    write_svg(&svg, size, |area| draw_panels(area, &panels, (rows, cols)))?;
    Ok((png, svg))
}

fn draw_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[Figure],
    grid: (usize, usize),
) -> DrawResult {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    for (area, fig) in root.split_evenly(grid).iter().zip(panels) {
        draw_figure(area, fig)?;
    }
    Ok(())
}

fn output_paths(stem: &Path) -> Result<(PathBuf, PathBuf), PlotError> {
    if stem.file_name().is_none() {
        return Err(PlotError::Io {
            path: stem.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "no file name"),
        });
    }
    if let Some(dir) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir).map_err(|source| PlotError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    Ok((stem.with_extension("png"), stem.with_extension("svg")))
}

type DrawResult = Result<(), String>;

/// Write `bytes` to `path` with the project's atomic writer ([`crate::output::write_atomic`]).
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    crate::output::write_atomic(path, bytes).map_err(|e| match e {
        crate::output::OutputError::Io { path, source } => PlotError::Io { path, source },
        other => PlotError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::other(other.to_string()),
        },
    })
}

/// Draw into an RGB buffer and encode it as PNG in memory, then write it atomically.
fn write_png<F>(path: &Path, size: (u32, u32), draw: F) -> Result<(), PlotError>
where
    F: for<'a> Fn(&DrawingArea<BitMapBackend<'a>, Shift>) -> DrawResult,
{
    let draw_err = |message: String| PlotError::Draw {
        path: path.to_path_buf(),
        message,
    };
    let (w, h) = size;
    let mut rgb = vec![0u8; 3 * w as usize * h as usize];
    {
        let backend = BitMapBackend::with_buffer_and_format(&mut rgb, size)
            .map_err(|e| draw_err(e.to_string()))?;
        let root = backend.into_drawing_area();
        draw(&root).map_err(draw_err)?;
        root.present().map_err(|e| draw_err(e.to_string()))?;
    }
    let mut png = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(
        &mut png,
        &rgb,
        w,
        h,
        image::ColorType::Rgb8,
        image::ImageOutputFormat::Png,
    )
    .map_err(|e| draw_err(format!("PNG encoding: {e}")))?;
    write_file(path, png.get_ref())
}

fn write_svg<F>(path: &Path, size: (u32, u32), draw: F) -> Result<(), PlotError>
where
    F: for<'a> Fn(&DrawingArea<SVGBackend<'a>, Shift>) -> DrawResult,
{
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        let drawn = draw(&root).and_then(|_| root.present().map_err(|e| e.to_string()));
        drawn.map_err(|message| PlotError::Draw {
            path: path.to_path_buf(),
            message,
        })?;
    }
    write_file(path, text.as_bytes())
}

fn validate_figure(fig: &Figure) -> Result<(), PlotError> {
    let invalid = |message: String| PlotError::Invalid {
        title: fig.title.clone(),
        message,
    };
    if fig.size.0 < 100 || fig.size.1 < 100 {
        return Err(invalid(format!(
            "image size {}x{} px is too small (at least 100x100)",
            fig.size.0, fig.size.1
        )));
    }
    for s in &fig.series {
        if s.x.len() != s.y.len() {
            return Err(invalid(format!(
                "series '{}' has {} x values and {} y values",
                s.label,
                s.x.len(),
                s.y.len()
            )));
        }
    }
    for (name, range, log) in [("x", fig.x_range, fig.x_log), ("y", fig.y_range, fig.y_log)] {
        if let Some((lo, hi)) = range {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) || (log && lo <= 0.0) {
                return Err(invalid(format!(
                    "{name} range ({lo}, {hi}) must be finite, increasing{}",
                    if log { " and > 0 on a log axis" } else { "" }
                )));
            }
        }
    }
    Ok(())
}

fn validate_heatmap(map: &Heatmap) -> Result<(), PlotError> {
    let invalid = |message: String| PlotError::Invalid {
        title: map.title.clone(),
        message,
    };
    if map.size.0 < 200 || map.size.1 < 100 {
        return Err(invalid(format!(
            "image size {}x{} px is too small (at least 200x100)",
            map.size.0, map.size.1
        )));
    }
    for (name, v, log) in [("x", &map.x, map.x_log), ("y", &map.y, map.y_log)] {
        if v.is_empty() {
            return Err(invalid(format!("no {name} cell centres")));
        }
        let ok_values = v.iter().all(|t| t.is_finite() && (!log || *t > 0.0));
        let increasing = v.windows(2).all(|w| w[0] < w[1]);
        if !ok_values || !increasing {
            return Err(invalid(format!(
                "{name} cell centres must be finite, strictly increasing{}",
                if log { " and > 0 on a log axis" } else { "" }
            )));
        }
    }
    if map.z.len() != map.x.len() * map.y.len() {
        return Err(invalid(format!(
            "z has {} values, expected {} x {} = {}",
            map.z.len(),
            map.x.len(),
            map.y.len(),
            map.x.len() * map.y.len()
        )));
    }
    if let Some((lo, hi)) = map.z_range {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) || (map.z_log && lo <= 0.0) {
            return Err(invalid(format!(
                "colour range ({lo}, {hi}) must be finite, increasing{}",
                if map.z_log {
                    " and > 0 on a log scale"
                } else {
                    ""
                }
            )));
        }
    }
    Ok(())
}

/// True when `v` can be placed on an axis (finite, and > 0 on a log axis).
fn plottable(v: f64, log: bool) -> bool {
    v.is_finite() && (!log || v > 0.0)
}

/// Data range of the plottable values, padded (5 % linear, a fraction of a decade log); a fixed
/// range wins. Degenerate or empty data get a unit-sized range around the value (or [0, 1]).
fn axis_range(
    values: impl Iterator<Item = f64>,
    log: bool,
    fixed: Option<(f64, f64)>,
) -> (f64, f64) {
    if let Some(r) = fixed {
        return r;
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| plottable(*v, log)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (llo, lhi) = (lo.log10(), hi.log10());
        let pad = if lhi > llo { 0.03 * (lhi - llo) } else { 0.5 };
        (10f64.powf(llo - pad), 10f64.powf(lhi + pad))
    } else if hi > lo {
        let pad = 0.04 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let half = if lo == 0.0 { 1.0 } else { 0.5 * lo.abs() };
        (lo - half, hi + half)
    }
}

/// Tick label: up to 5 significant digits, no float noise, scientific outside [1e-3, 1e5).
pub fn tick_label(v: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    if v == 0.0 || v.abs() < 1e-300 {
        return "0".to_string();
    }
    let mag = v.abs().log10().floor();
    if (-3.0..5.0).contains(&mag) {
        let decimals = (4.0 - mag).clamp(0.0, 8.0) as usize;
        let s = format!("{v:.decimals$}");
        let s = if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
        if s == "-0" {
            "0".to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.3e}");
        match s.split_once('e') {
            Some((m, e)) => {
                let m = if m.contains('.') {
                    m.trim_end_matches('0').trim_end_matches('.')
                } else {
                    m
                };
                format!("{m}e{e}")
            }
            None => s,
        }
    }
}

/// Tick formatter for one axis over [lo, hi]. Linear: values within 1e-9 of the span of zero
/// print as "0" (tick positions carry float noise). Log: only 10^k are labelled when the axis
/// spans two decades or more, else only 1, 2 and 5 × 10^k (plotters proposes every light tick,
/// whose labels would overlap); on an axis without a power of ten, every tick (round values:
/// [`round_ticks`]).
fn axis_formatter(log: bool, lo: f64, hi: f64) -> impl Fn(&f64) -> String {
    let span = (hi - lo).abs();
    let decades = if log && lo > 0.0 && hi > 0.0 {
        (hi / lo).log10().abs()
    } else {
        0.0
    };
    let spans = !log || spans_power_of_ten(lo, hi);
    move |v: &f64| {
        let v = *v;
        if !log {
            return if v.abs() <= 1e-9 * span {
                "0".to_string()
            } else {
                tick_label(v)
            };
        }
        if !(v > 0.0 && v.is_finite()) {
            return String::new();
        }
        let e = v.log10().floor();
        let mantissa = v / 10f64.powf(e);
        let near = |m: f64| (mantissa - m).abs() < 1e-6 * m || (mantissa - 10.0 * m).abs() < 1e-5;
        let keep = if decades >= 2.0 {
            near(1.0)
        } else if !spans {
            true
        } else {
            near(1.0) || near(2.0) || near(5.0)
        };
        if keep {
            tick_label(v)
        } else {
            String::new()
        }
    }
}

/// A logarithmic axis whose key points are sorted and free of duplicates: plotters 0.3.7's
/// `LogCoord` repeats the decade boundary (0.01 … 0.09, 0.1, 0.1 over [0.0035, 0.12]), which
/// drew its tick label twice.
struct LogAxis(LogCoord<f64>);

fn log_axis(lo: f64, hi: f64) -> LogAxis {
    LogAxis((lo..hi).log_scale().into())
}

impl Ranged for LogAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;
    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.0.map(value, limit)
    }
    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        let r = self.0.range();
        if !spans_power_of_ten(r.start, r.end) {
            // plotters starts at the next power of ten, past the end of such an axis: it would
            // have no tick at all. Round values instead.
            return round_ticks(r.start, r.end);
        }
        let mut k = self.0.key_points(hint);
        k.sort_by(f64::total_cmp);
        k.dedup();
        k
    }
    fn range(&self) -> std::ops::Range<f64> {
        self.0.range()
    }
}

/// True when [lo, hi] (> 0) holds a power of ten.
fn spans_power_of_ten(lo: f64, hi: f64) -> bool {
    let (lo, hi) = (lo.min(hi), lo.max(hi));
    lo > 0.0 && 10f64.powf(lo.log10().ceil()) <= hi * (1.0 + 1e-12)
}

/// Four to ten round values (1, 2 or 5 × 10^k apart) in [lo, hi].
fn round_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let (lo, hi) = (lo.min(hi), lo.max(hi));
    if !(hi > lo && lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let raw = (hi - lo) / 5.0;
    let e = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * e)
        .find(|s| (hi - lo) / s <= 10.0)
        .unwrap_or(10.0 * e);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// Pixel sizes for a figure of `size`, from a design at 700 px on its short side.
fn px_scale(size: (u32, u32)) -> impl Fn(f64) -> u32 {
    let scale = f64::from(size.0.min(size.1)) / 700.0;
    move |v| (v * scale).round().max(1.0) as u32
}

/// A Cartesian chart over the coordinates `XS` × `YS`.
type Chart<'a, DB, XS, YS> = ChartContext<
    'a,
    DB,
    Cartesian2d<<XS as AsRangedCoord>::CoordDescType, <YS as AsRangedCoord>::CoordDescType>,
>;

/// The Cartesian chart shared by line figures and heat maps, drawn below their title (which
/// spans the whole width: legend or colour bar included), `extra_right` px of room on its right.
fn chart_below_title<'a, DB, XS, YS>(
    area: &'a DrawingArea<DB, Shift>,
    px: &impl Fn(f64) -> u32,
    xs: XS,
    ys: YS,
    extra_right: u32,
) -> Result<Chart<'a, DB, XS, YS>, String>
where
    DB: DrawingBackend,
    XS: AsRangedCoord<Value = f64>,
    YS: AsRangedCoord<Value = f64>,
{
    ChartBuilder::on(area)
        .margin(px(18.0))
        .margin_right(px(18.0) + extra_right)
        .x_label_area_size(px(60.0))
        .y_label_area_size(px(95.0))
        .build_cartesian_2d(xs, ys)
        .map_err(|e| e.to_string())
}

/// Axis descriptions and clean tick labels; `grid` draws the light mesh of line figures (heat
/// maps have none).
fn draw_axes<DB, X, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    (x_label, y_label): (&str, &str),
    (x_log, y_log): (bool, bool),
    px: &impl Fn(f64) -> u32,
    grid: bool,
) -> DrawResult
where
    DB: DrawingBackend,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let (xr, yr) = (chart.x_range(), chart.y_range());
    let x_fmt = axis_formatter(x_log, xr.start, xr.end);
    let y_fmt = axis_formatter(y_log, yr.start, yr.end);
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style((FONT_FAMILY, px(17.0)))
        .axis_desc_style((FONT_FAMILY, px(20.0)));
    if grid {
        mesh.light_line_style(RGBColor(235, 235, 235))
            .bold_line_style(RGBColor(205, 205, 205));
    } else {
        mesh.disable_mesh();
    }
    mesh.draw().map_err(|e| e.to_string())
}

fn draw_figure<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, fig: &Figure) -> DrawResult {
    let xs = fig.series.iter().flat_map(|s| s.x.iter().copied());
    let ys = fig.series.iter().flat_map(|s| s.y.iter().copied());
    let (x0, x1) = axis_range(xs, fig.x_log, fig.x_range);
    let (y0, y1) = axis_range(ys, fig.y_log, fig.y_range);
    match (fig.x_log, fig.y_log) {
        (false, false) => draw_xy(root, fig, || x0..x1, || y0..y1),
        (true, false) => draw_xy(root, fig, || log_axis(x0, x1), || y0..y1),
        (false, true) => draw_xy(root, fig, || x0..x1, || log_axis(y0, y1)),
        (true, true) => draw_xy(root, fig, || log_axis(x0, x1), || log_axis(y0, y1)),
    }
}

/// Contiguous runs of plottable points, inside the axis ranges' validity.
fn segments(s: &Series, x_log: bool, y_log: bool) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur = Vec::new();
    for (&x, &y) in s.x.iter().zip(&s.y) {
        if plottable(x, x_log) && plottable(y, y_log) {
            cur.push((x, y));
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// The look of series `i` of a figure.
fn series_look(i: usize, s: &Series) -> Look {
    look(s.color.unwrap_or(i), s.style == Style::Dashed)
}

/// Line widths and marker sizes of a figure of `size`, in px.
#[derive(Debug, Clone, Copy)]
struct Strokes {
    /// Pixels per design pixel (700 px on the short side).
    scale: f64,
    line: u32,
    radius: i32,
    ring: i32,
}

impl Strokes {
    fn of(size: (u32, u32)) -> Self {
        let px = px_scale(size);
        Self {
            scale: f64::from(size.0.min(size.1)) / 700.0,
            line: px(2.0),
            radius: px(4.0) as i32,
            ring: px(7.0) as i32,
        }
    }

    fn dash(&self, pattern: &[f64]) -> Vec<f64> {
        pattern.iter().map(|v| (v * self.scale).max(1.0)).collect()
    }
}

/// The primitives of every series but the shaded spans, in drawing order, each with its series'
/// index; `map` takes data to pixels of the plotting area.
fn primitives(fig: &Figure, st: Strokes, map: &impl Fn(f64, f64) -> Px) -> Vec<(usize, Prim)> {
    let mut out = Vec::new();
    for (i, s) in fig.series.iter().enumerate() {
        if s.style == Style::Band {
            continue;
        }
        let lk = series_look(i, s);
        for seg in segments(s, fig.x_log, fig.y_log) {
            let pts: Vec<Px> = seg.iter().map(|&(x, y)| map(x, y)).collect();
            if matches!(s.style, Style::Line | Style::LineMarkers | Style::Dashed) {
                let solid = lk.dash.is_empty();
                match column_band(&pts, (st.line as i32 / 2).max(1)) {
                    Some(band) if solid => out.push((i, Prim::Fill { points: band })),
                    _ => {
                        for d in dashes(&pts, &st.dash(lk.dash)) {
                            out.push((
                                i,
                                Prim::Path {
                                    points: d,
                                    width: st.line,
                                },
                            ));
                        }
                    }
                }
            }
            let marker = |at: Px, ring: bool| Prim::Marker {
                at,
                shape: lk.shape,
                size: if ring { st.ring } else { st.radius },
                filled: !ring,
                width: st.line,
            };
            match s.style {
                Style::Markers | Style::LineMarkers => {
                    out.extend(pts.iter().map(|&p| (i, marker(p, false))));
                }
                Style::Rings => out.extend(pts.iter().map(|&p| (i, marker(p, true)))),
                _ => {}
            }
        }
    }
    out
}

/// The shaded spans of the `Band` series, each with its series' index: pixel columns x0..x1.
fn shaded_spans(fig: &Figure, map_x: &impl Fn(f64) -> i32) -> Vec<(usize, (i32, i32))> {
    let mut out = Vec::new();
    for (i, s) in fig.series.iter().enumerate() {
        if s.style != Style::Band {
            continue;
        }
        for b in s.x.chunks_exact(2) {
            if plottable(b[0], fig.x_log) && plottable(b[1], fig.x_log) {
                let (a, c) = (map_x(b[0]), map_x(b[1]));
                out.push((i, (a.min(c), a.max(c))));
            }
        }
    }
    out
}

/// The vertices of a marker of `shape` and half-width `size` centred at `at` (circles are drawn
/// as circles, not from vertices).
fn shape_vertices(shape: Shape, at: Px, size: i32) -> Vec<Px> {
    let s = f64::from(size);
    let rel: Vec<(f64, f64)> = match shape {
        Shape::Circle => Vec::new(),
        Shape::Square => vec![(-0.9, -0.9), (0.9, -0.9), (0.9, 0.9), (-0.9, 0.9)],
        Shape::TriangleUp => vec![(0.0, -1.2), (1.1, 0.8), (-1.1, 0.8)],
        Shape::Diamond => vec![(0.0, -1.25), (1.25, 0.0), (0.0, 1.25), (-1.25, 0.0)],
        Shape::TriangleDown => vec![(0.0, 1.2), (1.1, -0.8), (-1.1, -0.8)],
    };
    rel.iter()
        .map(|(dx, dy)| {
            (
                at.0 + (dx * s).round() as i32,
                at.1 + (dy * s).round() as i32,
            )
        })
        .collect()
}

/// Draw one primitive in `color` on `area` (pixels of the plotting area).
fn draw_prim<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    prim: &Prim,
    color: RGBColor,
) -> DrawResult {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    match prim {
        Prim::Path { points, width } => area
            .draw(&PathElement::new(
                points.clone(),
                color.stroke_width(*width),
            ))
            .map_err(|e| err(&e)),
        Prim::Fill { points } => area
            .draw(&Polygon::new(points.clone(), color.filled()))
            .map_err(|e| err(&e)),
        Prim::Marker {
            at,
            shape,
            size,
            filled,
            width,
        } => {
            let style = if *filled {
                color.filled()
            } else {
                color.stroke_width(*width)
            };
            if *shape == Shape::Circle {
                return area
                    .draw(&Circle::new(*at, *size, style))
                    .map_err(|e| err(&e));
            }
            let mut v = shape_vertices(*shape, *at, *size);
            if *filled {
                area.draw(&Polygon::new(v, style)).map_err(|e| err(&e))
            } else {
                v.push(v[0]);
                area.draw(&PathElement::new(v, style)).map_err(|e| err(&e))
            }
        }
    }
}

/// The legend's rows: the labelled series, their text, and the box they need.
struct LegendBox {
    /// Indices of the labelled series, in order.
    entries: Vec<usize>,
    /// Rows per column.
    rows: usize,
    /// One column's width (px).
    col_w: i32,
    /// Box size (px).
    size: (i32, i32),
}

/// Legend metrics at the design size (px): padding, glyph width, row height, font size.
const LEGEND_PAD: f64 = 8.0;
const LEGEND_GLYPH: f64 = 34.0;
const LEGEND_ROW: f64 = 22.0;
const LEGEND_FONT: f64 = 16.0;
/// Gap between the legend box and the edges of the plotting area (design px).
const LEGEND_MARGIN: f64 = 10.0;

/// The legend box of `fig` for a plotting area `max_h` px high (its rows split into columns
/// when they do not fit), `None` when no series is labelled.
fn legend_box<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    fig: &Figure,
    px: &impl Fn(f64) -> u32,
    max_h: i32,
) -> Result<Option<LegendBox>, String> {
    let entries: Vec<usize> = (0..fig.series.len())
        .filter(|&i| !fig.series[i].label.is_empty())
        .collect();
    // A lone series needs no key: the axes name it.
    if entries.is_empty() || fig.series.len() < 2 {
        return Ok(None);
    }
    let font = (FONT_FAMILY, px(LEGEND_FONT)).into_font();
    let style = TextStyle::from(font).color(&BLACK);
    let mut text_w = 0u32;
    for &i in &entries {
        let (w, _) = area
            .estimate_text_size(&fig.series[i].label, &style)
            .map_err(|e| e.to_string())?;
        text_w = text_w.max(w);
    }
    let (pad, glyph, row) = (
        px(LEGEND_PAD) as i32,
        px(LEGEND_GLYPH) as i32,
        px(LEGEND_ROW) as i32,
    );
    let fit = ((max_h - 2 * px(LEGEND_MARGIN) as i32 - pad) / row).max(1) as usize;
    let cols = entries.len().div_ceil(fit);
    let rows = entries.len().div_ceil(cols);
    let col_w = glyph + 2 * pad + text_w as i32 + pad / 2;
    let size = (col_w * cols as i32, row * rows as i32 + pad);
    Ok(Some(LegendBox {
        entries,
        rows,
        col_w,
        size,
    }))
}

/// Draw `title` centred over the whole of `area`, a little below its top edge, and return the
/// area below it.
fn below_title<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    px: &impl Fn(f64) -> u32,
) -> Result<DrawingArea<DB, Shift>, String> {
    area.margin(px(10.0), 0, 0, 0)
        .titled(title, (FONT_FAMILY, px(26.0)))
        .map_err(|e| e.to_string())
}

/// The corners in the order a figure prefers them: its own first.
fn corner_order(pref: LegendPosition) -> [Corner; 4] {
    let first = match pref {
        LegendPosition::UpperLeft => Corner::UpperLeft,
        LegendPosition::UpperRight => Corner::UpperRight,
        LegendPosition::LowerRight => Corner::LowerRight,
    };
    let mut order = [first; 4];
    let mut k = 1;
    for c in [
        Corner::UpperRight,
        Corner::UpperLeft,
        Corner::LowerRight,
        Corner::LowerLeft,
    ] {
        if c != first {
            order[k] = c;
            k += 1;
        }
    }
    order
}

fn draw_xy<DB, XS, YS>(
    root: &DrawingArea<DB, Shift>,
    fig: &Figure,
    xs: impl Fn() -> XS,
    ys: impl Fn() -> YS,
) -> DrawResult
where
    DB: DrawingBackend,
    XS: AsRangedCoord<Value = f64>,
    YS: AsRangedCoord<Value = f64>,
    XS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    YS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| e.to_string();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let px = px_scale(fig.size);
    let st = Strokes::of(fig.size);
    let margin = px(LEGEND_MARGIN) as i32;

    // Where the legend goes, decided on a scratch copy of the chart (same size, same layout):
    // the data's pixels are known only once the chart is laid out, and a legend outside the
    // plotting area changes the layout.
    let (legend, placement) = {
        let mut scratch = String::new();
        let probe_root =
            SVGBackend::with_string(&mut scratch, root.dim_in_pixel()).into_drawing_area();
        let probe_body = below_title(&probe_root, &fig.title, &px)?;
        let probe = chart_below_title(&probe_body, &px, xs(), ys(), 0)?;
        let area = probe.plotting_area();
        let base = area.get_base_pixel();
        let (w, h) = area.dim_in_pixel();
        let map = |x: f64, y: f64| {
            let p = probe.backend_coord(&(x, y));
            (p.0 - base.0, p.1 - base.1)
        };
        let y_any = probe.y_range().start;
        let legend = legend_box(&probe_root, fig, &px, h as i32)?;
        let mut placement = Placement::Outside;
        if let Some(lb) = &legend {
            let prims: Vec<Prim> = primitives(fig, st, &map).into_iter().map(|p| p.1).collect();
            let shades: Vec<(i32, i32)> = shaded_spans(fig, &|x| map(x, y_any).0)
                .into_iter()
                .map(|s| s.1)
                .collect();
            placement = place_legend(
                (w as i32, h as i32),
                lb.size,
                margin,
                &prims,
                &shades,
                &corner_order(fig.legend),
                // Outside, the legend may take up to half the width from the plot.
                w as i32 / 2,
            );
        }
        (legend, placement)
    };
    let outside = legend.is_some() && placement == Placement::Outside;
    let extra = match (&legend, outside) {
        (Some(lb), true) => (lb.size.0 + margin) as u32,
        _ => 0,
    };
    // The title over the whole width, also when the legend takes room on the right.
    let body = below_title(root, &fig.title, &px)?;
    let mut chart = chart_below_title(&body, &px, xs(), ys(), extra)?;
    draw_axes(
        &mut chart,
        (&fig.x_label, &fig.y_label),
        (fig.x_log, fig.y_log),
        &px,
        true,
    )?;
    let plot = chart.plotting_area().strip_coord_spec();
    let base = chart.plotting_area().get_base_pixel();
    let map = |x: f64, y: f64| {
        let p = chart.backend_coord(&(x, y));
        (p.0 - base.0, p.1 - base.1)
    };
    let y_any = chart.y_range().start;
    let (_, h) = plot.dim_in_pixel();
    // Shaded spans first, under the lines and markers.
    for (i, (a, b)) in shaded_spans(fig, &|x| map(x, y_any).0) {
        let color = series_look(i, &fig.series[i]).color;
        plot.draw(&Rectangle::new(
            [(a, 0), (b, h as i32)],
            color.mix(0.18).filled(),
        ))
        .map_err(|e| err(&e))?;
    }
    for (i, prim) in primitives(fig, st, &map) {
        draw_prim(&plot, &prim, series_look(i, &fig.series[i]).color)?;
    }
    let Some(lb) = legend else {
        return Ok(());
    };
    match placement {
        Placement::Inside(at) => draw_legend(&plot, fig, &lb, at, &px, st),
        // Right of the plotting area, level with its top: drawn on the whole area (the plotting
        // area clips what lies outside it).
        Placement::Outside => {
            let (w, _) = plot.dim_in_pixel();
            let r = root.get_base_pixel();
            let at = (base.0 - r.0 + w as i32 + margin, base.1 - r.1);
            draw_legend(root, fig, &lb, at, &px, st)
        }
    }
}

/// Draw the legend box `lb` with its top-left corner at `at` (pixels of the plotting area; to
/// its right when outside it). plotters' own legend needs `DB: 'static` with a generic backend
/// and has fixed corners only. The box is a white fill of opacity 0.88 and a grey frame.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    fig: &Figure,
    lb: &LegendBox,
    (x0, y0): Px,
    px: &impl Fn(f64) -> u32,
    st: Strokes,
) -> DrawResult {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let (bw, bh) = lb.size;
    area.draw(&Rectangle::new(
        [(x0, y0), (x0 + bw, y0 + bh)],
        WHITE.mix(0.88).filled(),
    ))
    .map_err(|e| err(&e))?;
    area.draw(&Rectangle::new(
        [(x0, y0), (x0 + bw, y0 + bh)],
        RGBColor(120, 120, 120).stroke_width(1),
    ))
    .map_err(|e| err(&e))?;
    let font = (FONT_FAMILY, px(LEGEND_FONT)).into_font();
    let text_style =
        TextStyle::from(font)
            .color(&BLACK)
            .pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Left,
                plotters::style::text_anchor::VPos::Center,
            ));
    let (pad, glyph_w, row_h) = (
        px(LEGEND_PAD) as i32,
        px(LEGEND_GLYPH) as i32,
        px(LEGEND_ROW) as i32,
    );
    for (k, &i) in lb.entries.iter().enumerate() {
        let s = &fig.series[i];
        let lk = series_look(i, s);
        let (col, row) = ((k / lb.rows) as i32, (k % lb.rows) as i32);
        let yc = y0 + pad / 2 + row_h * row + row_h / 2;
        let gx = x0 + col * lb.col_w + pad;
        let centre = (gx + glyph_w / 2, yc);
        let mut glyph: Vec<Prim> = Vec::new();
        match s.style {
            Style::Line | Style::LineMarkers | Style::Dashed => {
                for d in dashes(&[(gx, yc), (gx + glyph_w, yc)], &st.dash(lk.dash)) {
                    glyph.push(Prim::Path {
                        points: d,
                        width: st.line,
                    });
                }
            }
            Style::Band => {
                area.draw(&Rectangle::new(
                    [(gx, yc - row_h / 3), (gx + glyph_w, yc + row_h / 3)],
                    lk.color.mix(0.18).filled(),
                ))
                .map_err(|e| err(&e))?;
            }
            Style::Markers | Style::Rings => {}
        }
        if matches!(s.style, Style::Markers | Style::LineMarkers | Style::Rings) {
            let ring = s.style == Style::Rings;
            glyph.push(Prim::Marker {
                at: centre,
                shape: lk.shape,
                size: if ring { st.ring } else { st.radius },
                filled: !ring,
                width: st.line,
            });
        }
        for g in &glyph {
            draw_prim(area, g, lk.color)?;
        }
        area.draw(&Text::new(
            s.label.clone(),
            (gx + glyph_w + pad, yc),
            text_style.clone(),
        ))
        .map_err(|e| err(&e))?;
    }
    Ok(())
}

/// Viridis, sampled at 9 stops and interpolated linearly; `t` in [0, 1].
fn colormap(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let f = t * (STOPS.len() - 1) as f64;
    let i = (f.floor() as usize).min(STOPS.len() - 2);
    let u = f - i as f64;
    let lerp = |a: u8, b: u8| (f64::from(a) + u * (f64::from(b) - f64::from(a))).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

const MISSING: RGBColor = RGBColor(190, 190, 190);

/// Cell edges from centres: midpoints (geometric on a log axis), outer edges mirrored.
fn cell_edges(c: &[f64], log: bool) -> Vec<f64> {
    let t: Vec<f64> = if log {
        c.iter().map(|v| v.log10()).collect()
    } else {
        c.to_vec()
    };
    let mut e = Vec::with_capacity(t.len() + 1);
    if t.len() == 1 {
        // A single cell: half a decade on a log axis, half the value (or 0.5 at 0) otherwise.
        let half = if log || t[0].abs() < f64::MIN_POSITIVE {
            0.5
        } else {
            0.5 * t[0].abs()
        };
        e.push(t[0] - half);
        e.push(t[0] + half);
    } else {
        e.push(t[0] - 0.5 * (t[1] - t[0]));
        for w in t.windows(2) {
            e.push(0.5 * (w[0] + w[1]));
        }
        let n = t.len();
        e.push(t[n - 1] + 0.5 * (t[n - 1] - t[n - 2]));
    }
    if log {
        e.iter().map(|v| 10f64.powf(*v)).collect()
    } else {
        e
    }
}

/// Colour-scale range and the map value → [0, 1].
fn z_scale(map: &Heatmap) -> (f64, f64) {
    if let Some(r) = map.z_range {
        return r;
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in map.z.iter().filter(|v| plottable(**v, map.z_log)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return if map.z_log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if hi > lo {
        (lo, hi)
    } else if map.z_log {
        (lo / 2.0, hi * 2.0)
    } else {
        let half = if lo == 0.0 { 1.0 } else { 0.5 * lo.abs() };
        (lo - half, hi + half)
    }
}

fn z_fraction(v: f64, (lo, hi): (f64, f64), log: bool) -> Option<f64> {
    if !plottable(v, log) {
        return None;
    }
    let t = if log {
        (v.log10() - lo.log10()) / (hi.log10() - lo.log10())
    } else {
        (v - lo) / (hi - lo)
    };
    Some(t.clamp(0.0, 1.0))
}

fn draw_heatmap<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, map: &Heatmap) -> DrawResult {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    // The title spans the whole width: centred over the map alone, a long one ran off the left.
    let px = px_scale(map.size);
    let body = root
        .titled(&map.title, (FONT_FAMILY, px(26.0)))
        .map_err(|e| err(&e))?;
    let (w, _) = map.size;
    let bar_width = (w / 6).max(80);
    let (main, bar) = body.split_horizontally(w.saturating_sub(bar_width));
    let xe = cell_edges(&map.x, map.x_log);
    let ye = cell_edges(&map.y, map.y_log);
    let (x0, x1) = (xe[0], xe[xe.len() - 1]);
    let (y0, y1) = (ye[0], ye[ye.len() - 1]);
    match (map.x_log, map.y_log) {
        (false, false) => draw_cells(&main, map, &xe, &ye, x0..x1, y0..y1)?,
        (true, false) => draw_cells(&main, map, &xe, &ye, log_axis(x0, x1), y0..y1)?,
        (false, true) => draw_cells(&main, map, &xe, &ye, x0..x1, log_axis(y0, y1))?,
        (true, true) => draw_cells(&main, map, &xe, &ye, log_axis(x0, x1), log_axis(y0, y1))?,
    }
    let (z0, z1) = z_scale(map);
    if map.z_log {
        draw_colorbar(&bar, map, log_axis(z0, z1))
    } else {
        draw_colorbar(&bar, map, z0..z1)
    }
}

fn draw_cells<DB, XS, YS>(
    area: &DrawingArea<DB, Shift>,
    map: &Heatmap,
    xe: &[f64],
    ye: &[f64],
    xs: XS,
    ys: YS,
) -> DrawResult
where
    DB: DrawingBackend,
    XS: AsRangedCoord<Value = f64>,
    YS: AsRangedCoord<Value = f64>,
    XS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    YS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let px = px_scale(map.size);
    let mut chart = chart_below_title(area, &px, xs, ys, 0)?;
    let zr = z_scale(map);
    let nx = map.x.len();
    let cells = (0..map.y.len()).flat_map(|iy| {
        (0..nx).map(move |ix| {
            let color = match z_fraction(map.z[iy * nx + ix], zr, map.z_log) {
                Some(t) => colormap(t),
                None => MISSING,
            };
            Rectangle::new([(xe[ix], ye[iy]), (xe[ix + 1], ye[iy + 1])], color.filled())
        })
    });
    chart.draw_series(cells).map_err(|e| err(&e))?;
    draw_axes(
        &mut chart,
        (&map.x_label, &map.y_label),
        (map.x_log, map.y_log),
        &px,
        false,
    )
}

fn draw_colorbar<DB, ZS>(area: &DrawingArea<DB, Shift>, map: &Heatmap, zs: ZS) -> DrawResult
where
    DB: DrawingBackend,
    ZS: AsRangedCoord<Value = f64>,
    ZS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let px = px_scale(map.size);
    let zr = z_scale(map);
    let mut chart = ChartBuilder::on(area)
        .margin_top(px(18.0))
        .margin_bottom(px(18.0) + px(60.0))
        .margin_right(px(10.0))
        .y_label_area_size(px(80.0))
        .build_cartesian_2d(0.0..1.0, zs)
        .map_err(|e| err(&e))?;
    const STEPS: usize = 128;
    let (l0, l1) = if map.z_log {
        (zr.0.log10(), zr.1.log10())
    } else {
        zr
    };
    let at = |k: usize| {
        let v = l0 + (l1 - l0) * k as f64 / STEPS as f64;
        if map.z_log {
            10f64.powf(v)
        } else {
            v
        }
    };
    chart
        .draw_series((0..STEPS).map(|k| {
            let t = (k as f64 + 0.5) / STEPS as f64;
            Rectangle::new([(0.0, at(k)), (1.0, at(k + 1))], colormap(t).filled())
        }))
        .map_err(|e| err(&e))?;
    let zr_axis = chart.y_range();
    let fmt = axis_formatter(map.z_log, zr_axis.start, zr_axis.end);
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(&map.z_label)
        .y_label_formatter(&fmt)
        .label_style((FONT_FAMILY, px(15.0)))
        .axis_desc_style((FONT_FAMILY, px(18.0)))
        .draw()
        .map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Width and height from a PNG's IHDR chunk (bytes 16..24), after checking the signature.
    fn png_size(bytes: &[u8]) -> Option<(u32, u32)> {
        const SIG: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];
        if bytes.len() < 24 || bytes[..8] != SIG || &bytes[12..16] != b"IHDR" {
            return None;
        }
        let w = u32::from_be_bytes([bytes[16], bytes[17], bytes[18], bytes[19]]);
        let h = u32::from_be_bytes([bytes[20], bytes[21], bytes[22], bytes[23]]);
        Some((w, h))
    }

    fn sample_figure() -> Figure {
        let x: Vec<f64> = (0..50).map(|i| f64::from(i) * 0.1).collect();
        let y: Vec<f64> = x.iter().map(|v| v.sin()).collect();
        let mut y_nan = y.iter().map(|v| v * 0.5).collect::<Vec<_>>();
        y_nan[10] = f64::NAN;
        y_nan[11] = f64::INFINITY;
        Figure::new("Sample", "time t (s)", "signal y (mm)")
            .with_series(Series::new("sin", x.clone(), y, Style::Line))
            .with_series(Series::new(
                "half, with gaps",
                x.clone(),
                y_nan,
                Style::Dashed,
            ))
            .with_series(Series::new(
                "points",
                x.clone(),
                x.iter().map(|v| v.cos()).collect(),
                Style::Markers,
            ))
    }

    #[test]
    fn renders_png_and_svg_with_labels() {
        let dir = tempfile::tempdir().unwrap();
        let mut fig = sample_figure();
        fig.size = (640, 480);
        let (png, svg) = render(&fig, &dir.path().join("sub").join("sample")).unwrap();
        let bytes = fs::read(&png).unwrap();
        assert_eq!(png_size(&bytes), Some((640, 480)));
        let text = fs::read_to_string(&svg).unwrap();
        assert!(text.contains("time t (s)"));
        assert!(text.contains("signal y (mm)"));
        assert!(text.contains("half, with gaps"));
        // No temporary files left behind.
        let leftovers: Vec<_> = fs::read_dir(dir.path().join("sub"))
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("partial"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
    }

    #[test]
    fn log_axes_skip_non_positive_and_all_nan_is_fine() {
        let dir = tempfile::tempdir().unwrap();
        let fig = Figure::new("Log", "v/v0 (-)", "ratio (-)")
            .with_log(true, true)
            .with_series(Series::new(
                "decades",
                vec![-1.0, 0.0, 1e-2, 1.0, 1e2],
                vec![1.0, 2.0, 0.5, 1.0, 3.0],
                Style::LineMarkers,
            ))
            .with_series(Series::new(
                "nothing",
                vec![f64::NAN; 3],
                vec![1.0; 3],
                Style::Line,
            ));
        let (png, svg) = render(&fig, &dir.path().join("log")).unwrap();
        assert_eq!(png_size(&fs::read(png).unwrap()), Some(DEFAULT_SIZE));
        assert!(fs::read_to_string(svg).unwrap().contains("v/v0 (-)"));
        // An empty figure renders too (default ranges).
        let empty = Figure::new("Empty", "x", "y");
        render(&empty, &dir.path().join("empty")).unwrap();
    }

    #[test]
    fn mismatched_lengths_and_bad_ranges_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let fig = Figure::new("Bad", "x", "y").with_series(Series::new(
            "s",
            vec![1.0, 2.0],
            vec![1.0],
            Style::Line,
        ));
        assert!(matches!(
            render(&fig, &dir.path().join("bad")),
            Err(PlotError::Invalid { .. })
        ));
        let fig = Figure::new("Bad", "x", "y")
            .with_log(true, false)
            .with_x_range(0.0, 1.0);
        assert!(matches!(
            render(&fig, &dir.path().join("bad")),
            Err(PlotError::Invalid { .. })
        ));
        assert!(!dir.path().join("bad.png").exists());
    }

    #[test]
    fn heatmap_renders_with_missing_cells() {
        let dir = tempfile::tempdir().unwrap();
        let x = vec![100.0, 200.0, 400.0, 800.0];
        let y = vec![0.1, 0.2, 0.3];
        let mut z: Vec<f64> = (0..12).map(|k| 1e-6 * 10f64.powi(k % 5)).collect();
        z[5] = f64::NAN;
        let map = Heatmap {
            title: "Error map".into(),
            x_label: "frequency f (Hz)".into(),
            y_label: "amplitude a_A (mm)".into(),
            z_label: "relative error (-)".into(),
            x,
            y,
            z,
            x_log: true,
            y_log: false,
            z_log: true,
            z_range: None,
            size: (800, 600),
        };
        let (png, svg) = render_heatmap(&map, &dir.path().join("map")).unwrap();
        assert_eq!(png_size(&fs::read(png).unwrap()), Some((800, 600)));
        let text = fs::read_to_string(svg).unwrap();
        assert!(text.contains("frequency f (Hz)"));
        assert!(text.contains("relative error (-)"));
        let mut bad = map.clone();
        bad.z.pop();
        assert!(render_heatmap(&bad, &dir.path().join("bad")).is_err());
    }

    /// The log axis's key points are strictly increasing (plotters' own repeat the decade
    /// boundary over this range, and misplace one at 100 points).
    #[test]
    fn log_axis_key_points_are_strictly_increasing() {
        let raw: LogCoord<f64> = (0.0035..0.121).log_scale().into();
        assert!(raw.key_points(10).windows(2).any(|w| w[1] <= w[0]));
        let axis = log_axis(0.0035, 0.121);
        for n in [5usize, 10, 30, 100] {
            let k = axis.key_points(n);
            assert!(k.windows(2).all(|w| w[1] > w[0]), "{n}: {k:?}");
            assert!(k.iter().any(|&v| (v - 0.1).abs() < 1e-12), "{n}: {k:?}");
        }
    }

    #[test]
    fn display_units_are_the_ones_a_reader_expects() {
        // Issue 25: sweep axes in metres (1e-5) where the user thinks in µm.
        assert_eq!(display_unit("m", &[1e-5, 5e-5]), (1e6, "µm".into()));
        assert_eq!(display_unit("m", &[0.051]), (1e3, "mm".into()));
        assert_eq!(display_unit("m", &[2.0]), (1.0, "m".into()));
        assert_eq!(display_unit("m", &[3e-9]), (1e9, "nm".into()));
        assert_eq!(display_unit("N", &[0.02, f64::NAN]), (1e3, "mN".into()));
        assert_eq!(display_unit("m/s", &[4.45e-5]), (1e6, "µm/s".into()));
        assert_eq!(display_unit("Hz", &[400.0]), (1.0, "Hz".into()));
        assert_eq!(display_unit("Hz", &[300.0, 1500.0]), (1e-3, "kHz".into()));
        assert_eq!(display_unit("Pa", &[9.33e6]), (1e-6, "MPa".into()));
        assert_eq!(display_unit("m", &[0.0]), (1.0, "m".into()));
        // Issue 33: fold_curves.png had its amplitude axis in metres (1e-6).
        assert_eq!(
            axis_label("base.amplitude", "m", &[1e-6, 4e-6]),
            (1e6, "base.amplitude (µm)".into())
        );
        assert_eq!(axis_label("ratio", "1", &[2.0]), (1.0, "ratio (–)".into()));
    }

    #[test]
    fn tick_labels_are_clean() {
        let lin = axis_formatter(false, -1.0, 1.0);
        assert_eq!(lin(&2.22e-16), "0");
        let log = axis_formatter(true, 50.0, 1500.0);
        assert_eq!(log(&200.0), "200");
        assert_eq!(log(&300.0), "");
        assert_eq!(log(&1000.0), "1000");
        // No power of ten in range: round ticks, each labelled (plotters gave none at all).
        let narrow = axis_formatter(true, 39.0, 68.0);
        assert_eq!(narrow(&45.0), "45");
        assert_eq!(
            log_axis(39.0, 68.0).key_points(10),
            vec![40.0, 45.0, 50.0, 55.0, 60.0, 65.0]
        );
        assert_eq!(
            round_ticks(20.0, 90.0),
            vec![20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0]
        );
        let wide = axis_formatter(true, 1e-2, 1e2);
        assert_eq!(wide(&0.1), "0.1");
        assert_eq!(wide(&0.2), "");
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(-0.0), "0");
        assert_eq!(tick_label(1500.0), "1500");
        assert_eq!(tick_label(0.01), "0.01");
        assert_eq!(tick_label(1e-5), "1e-5");
        assert_eq!(tick_label(2.5e6), "2.5e6");
        assert_eq!(tick_label(-1.25), "-1.25");
    }

    #[test]
    fn cell_edges_bracket_centres() {
        let e = cell_edges(&[1.0, 2.0, 4.0], false);
        assert_eq!(e.len(), 4);
        assert!((e[0] - 0.5).abs() < 1e-12 && (e[3] - 5.0).abs() < 1e-12);
        let e = cell_edges(&[1.0, 100.0], true);
        assert!((e[1] - 10.0).abs() < 1e-9);
    }
}
