//! The paper's figures as data (and plots): Fig. 2 (δ cycles), Fig. 3(a) (mean force vs mean
//! indentation), Fig. 3(b) (exact/approximate pull-off ratio, via [`djkr_core::beta_fit`]) and
//! Figs. 4–8 (pull-off quantities vs a_A at 200, 300, 400 Hz, exact and approximate).
//!
//! The data functions are pure; [`write_figures`] writes each figure as CSV (SI values, headers
//! `name [unit]`: [`crate::output::table`]) plus PNG and SVG, atomically. The tables are
//! [`fig2_table`], [`fig3a_table`], [`fig3b_table`] and [`figs4to8_table`]. Differences from the paper's captions, kept deliberately:
//! - Fig. 3(a): the caption says a_A = 3/10, 3/5, 9/10 mm, the text 250, 500, 750 µm; the text's
//!   values are the default ([`FIG3A_AMPLITUDES`]).
//! - Fig. 7: the caption's F0 = −3/2 π R v0 is a misprint for w0 (docs/MODEL.md).
//! - Figs. 4–8 dashed lines: the closed form with the δ_A derived from eqs. (14)−(15) (docs/MODEL.md);
//!   the CSV also has the printed eq. (23) column.

use crate::output::{Column, OutputError, Table};
use crate::plot::{self, Figure, LegendPosition, PlotError, Series, Style};
use djkr_core::adhesion::GentSchultz;
use djkr_core::beta_fit::{self, BetaFitConfig, RatioPoint};
use djkr_core::closed_form::{self, DeltaAmpForm};
use djkr_core::error::ParamError;
use djkr_core::imposed_area::{self, PullOff};
use djkr_core::material::Material;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Fig. 2: imposed mean radii (m) at a_A = 1 mm, 200 Hz.
pub(crate) const FIG2_MEAN_RADII: [f64; 4] = [33e-6, 500e-6, 1000e-6, 1500e-6];
/// Fig. 3(a): contact-radius amplitudes of the paper's text (m).
pub(crate) const FIG3A_AMPLITUDES: [f64; 3] = [250e-6, 500e-6, 750e-6];
/// Figs. 4–8: frequencies (Hz).
pub const TABLE_FREQUENCIES: [f64; 3] = [200.0, 300.0, 400.0];

/// Figs. 4–8: 61 amplitudes a_A = 0 … 1.5 mm (m).
pub(crate) fn table_amplitudes() -> Vec<f64> {
    (0..61).map(|i| i as f64 * 25e-6).collect()
}

/// Which figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FigureId {
    /// δ(ωt) cycles.
    Fig2,
    /// Mean force vs mean indentation.
    Fig3a,
    /// Exact/approximate pull-off ratio vs v_max/v0.
    Fig3b,
    /// Figs. 4–8 (one table, five plots).
    Figs4to8,
}

impl FigureId {
    /// All figures.
    pub const ALL: [FigureId; 4] = [Self::Fig2, Self::Fig3a, Self::Fig3b, Self::Figs4to8];

    /// Parse `fig2`, `fig3a`, `fig3b`, `fig4-8` (also `4`…`8`).
    pub fn parse(text: &str) -> Option<Self> {
        match text.trim().to_ascii_lowercase().trim_start_matches("fig") {
            "2" => Some(Self::Fig2),
            "3a" => Some(Self::Fig3a),
            "3b" => Some(Self::Fig3b),
            "4-8" | "4" | "5" | "6" | "7" | "8" => Some(Self::Figs4to8),
            _ => None,
        }
    }
}

/// Why figures could not be produced.
#[derive(Debug, Error)]
pub enum FiguresError {
    /// A parameter was out of range.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// Writing a CSV failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Rendering a plot failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// The output directory could not be created.
    #[error("{path}: cannot create directory: {source}")]
    Dir {
        /// The directory.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// One Fig. 2 curve: δ(θ) over a cycle for one imposed a_m.
#[derive(Debug, Clone, PartialEq)]
pub struct Fig2Curve {
    /// Imposed mean radius (m).
    pub a_mean: f64,
    /// Phase θ = ωt (rad), 0 … 2π.
    pub theta: Vec<f64>,
    /// Indentation δ(θ) (m); 0 where a(θ) ≤ 0.
    pub delta: Vec<f64>,
}

/// Fig. 2 data: δ(θ) at 200 Hz, a_A = 1 mm, for [`FIG2_MEAN_RADII`], `points` samples per cycle.
pub fn fig2(m: &Material, law: &GentSchultz, points: usize) -> Vec<Fig2Curve> {
    let omega = 2.0 * PI * 200.0;
    let n = points.max(2);
    FIG2_MEAN_RADII
        .iter()
        .map(|&a_mean| {
            let theta: Vec<f64> = (0..n)
                .map(|i| 2.0 * PI * i as f64 / (n - 1) as f64)
                .collect();
            let delta = theta
                .iter()
                .map(|&t| imposed_area::indentation_at(m, law, omega, a_mean, 1e-3, t))
                .collect();
            Fig2Curve {
                a_mean,
                theta,
                delta,
            }
        })
        .collect()
}

/// One Fig. 3(a) curve: (δ_m, F_m) along a sweep of a_m at fixed a_A.
#[derive(Debug, Clone, PartialEq)]
pub struct Fig3aCurve {
    /// Contact-radius amplitude (m).
    pub a_amp: f64,
    /// Mean radius (a posteriori, m) of each point.
    pub a_mean: Vec<f64>,
    /// Exact mean indentation (m).
    pub delta_mean: Vec<f64>,
    /// Exact mean force (N).
    pub force_mean: Vec<f64>,
    /// Closed-form mean indentation, eq. (22) with eq. (24) (m).
    pub approx_delta_mean: Vec<f64>,
    /// Closed-form mean force, eq. (18) with eq. (24) (N).
    pub approx_force_mean: Vec<f64>,
}

/// Fig. 3(a) data at 400 Hz: for each a_A, a_m swept over `points` values up to 4 mm.
pub fn fig3a(
    m: &Material,
    law: &GentSchultz,
    amplitudes: &[f64],
    beta: f64,
    points: usize,
) -> Result<Vec<Fig3aCurve>, ParamError> {
    let omega = 2.0 * PI * 400.0;
    let n = points.max(2);
    amplitudes
        .iter()
        .map(|&a_amp| {
            let w_eff = closed_form::effective_work_of_adhesion(law, omega, a_amp, beta);
            let mut c = Fig3aCurve {
                a_amp,
                a_mean: Vec::with_capacity(n),
                delta_mean: Vec::with_capacity(n),
                force_mean: Vec::with_capacity(n),
                approx_delta_mean: Vec::with_capacity(n),
                approx_force_mean: Vec::with_capacity(n),
            };
            for i in 0..n {
                let a_m = 0.1e-3 + (4e-3 - 0.1e-3) * i as f64 / (n - 1) as f64;
                let cyc = imposed_area::cycle(m, law, omega, a_m, a_amp)?;
                c.a_mean.push(cyc.a_mean);
                c.delta_mean.push(cyc.harmonics.delta_mean);
                c.force_mean.push(cyc.harmonics.force_mean);
                c.approx_delta_mean
                    .push(closed_form::mean_indentation(m, a_m, w_eff));
                c.approx_force_mean
                    .push(closed_form::mean_force(m, a_m, w_eff));
            }
            Ok(c)
        })
        .collect()
}

/// One row of the Figs. 4–8 table.
#[derive(Debug, Clone, PartialEq)]
pub struct TableRow {
    /// Frequency (Hz).
    pub frequency: f64,
    /// Contact-radius amplitude a_A (m).
    pub a_amp: f64,
    /// Exact pull-off.
    pub exact: PullOff,
    /// Closed form with the derived δ_A.
    pub approx: closed_form::ApproxPullOff,
    /// Closed-form δ_A as printed in eq. (23) (m).
    pub approx_delta_amp_printed: f64,
}

/// Figs. 4–8 data: exact and approximate pull-off for each frequency and amplitude (the exact
/// points in parallel).
pub fn table(
    m: &Material,
    law: &GentSchultz,
    frequencies: &[f64],
    amplitudes: &[f64],
    beta: f64,
) -> Result<Vec<TableRow>, ParamError> {
    let exact = imposed_area::pull_off_table(m, law, frequencies, amplitudes)?;
    let mut rows = Vec::with_capacity(exact.len());
    for (i, e) in exact.into_iter().enumerate() {
        let f = frequencies[i / amplitudes.len()];
        let a_amp = amplitudes[i % amplitudes.len()];
        let omega = 2.0 * PI * f;
        let approx =
            closed_form::pull_off_approx(m, law, omega, a_amp, beta, DeltaAmpForm::Derived)?;
        let printed =
            closed_form::pull_off_approx(m, law, omega, a_amp, beta, DeltaAmpForm::Printed)?;
        rows.push(TableRow {
            frequency: f,
            a_amp,
            exact: e,
            approx,
            approx_delta_amp_printed: printed.delta_amp,
        });
    }
    Ok(rows)
}

/// Fig. 3(b) data at `beta` over the paper's grid (n = 0.1 … 0.9, v_max/v0 = 1e-2 … 1e2, 200 Hz).
pub fn fig3b(m: &Material, law: &GentSchultz, beta: f64) -> Result<Vec<RatioPoint>, ParamError> {
    let cfg = BetaFitConfig {
        material: *m,
        v0: law.v0,
        ..BetaFitConfig::default()
    };
    beta_fit::figure_3b(&cfg, beta)
}

fn mkdir(dir: &Path) -> Result<(), FiguresError> {
    std::fs::create_dir_all(dir).map_err(|source| FiguresError::Dir {
        path: dir.to_path_buf(),
        source,
    })
}

fn table_of(columns: Vec<Column>) -> Table {
    Table::from_fixed(columns)
}

/// Fig. 2 as a table: `theta [rad]`, then δ for each imposed a_m (`delta_at_a_m_33um [m]`, …).
pub(crate) fn fig2_table(curves: &[Fig2Curve]) -> Table {
    let mut cols = vec![Column::f64(
        "theta",
        "rad",
        "phase ωt over one cycle",
        curves.first().map(|c| c.theta.clone()).unwrap_or_default(),
    )];
    for c in curves {
        let label = format!("{:.0}um", c.a_mean * 1e6);
        cols.push(Column::f64(
            format!("delta_at_a_m_{label}"),
            "m",
            format!("indentation δ at imposed a_m = {label}, a_A = 1 mm, 200 Hz"),
            c.delta.clone(),
        ));
    }
    table_of(cols)
}

/// Fig. 3(a) as a table: one row per (a_A, a_m) point, exact and closed-form means.
pub(crate) fn fig3a_table(curves: &[Fig3aCurve]) -> Table {
    let all = |f: &dyn Fn(&Fig3aCurve) -> &Vec<f64>| -> Vec<f64> {
        curves.iter().flat_map(|c| f(c).iter().copied()).collect()
    };
    table_of(vec![
        Column::f64(
            "a_amp",
            "m",
            "contact-radius amplitude a_A",
            curves
                .iter()
                .flat_map(|c| std::iter::repeat_n(c.a_amp, c.a_mean.len()))
                .collect(),
        ),
        Column::f64(
            "a_mean",
            "m",
            "mean contact radius a_m",
            all(&|c| &c.a_mean),
        ),
        Column::f64(
            "delta_mean",
            "m",
            "exact mean indentation δ_m",
            all(&|c| &c.delta_mean),
        ),
        Column::f64(
            "force_mean",
            "N",
            "exact mean force F_m",
            all(&|c| &c.force_mean),
        ),
        Column::f64(
            "approx_delta_mean",
            "m",
            "closed-form mean indentation, eq. (22) with eq. (24)",
            all(&|c| &c.approx_delta_mean),
        ),
        Column::f64(
            "approx_force_mean",
            "N",
            "closed-form mean force, eq. (18) with eq. (24)",
            all(&|c| &c.approx_force_mean),
        ),
    ])
}

/// Fig. 3(b) as a table: exact / approximate amplification per (n, v_max/v0).
pub(crate) fn fig3b_table(points: &[RatioPoint]) -> Table {
    let col = |name: &str, description: &str, f: fn(&RatioPoint) -> f64| {
        Column::f64(name, "1", description, points.iter().map(f).collect())
    };
    table_of(vec![
        col("n", "Gent–Schultz exponent", |p| p.n),
        col(
            "v_max_over_v0",
            "peak contact-line speed a_A ω / v0",
            |p| p.speed_ratio,
        ),
        col("amp_exact", "exact pull-off amplification", |p| p.amp_exact),
        col("amp_approx", "closed-form pull-off amplification", |p| {
            p.amp_approx
        }),
        col("ratio", "amp_exact / amp_approx", |p| p.ratio),
    ])
}

/// Figs. 4–8 as a table: exact and closed-form pull-off per (frequency, a_A).
pub(crate) fn figs4to8_table(rows: &[TableRow]) -> Table {
    let col = |name: &str, unit: &str, description: &str, f: fn(&TableRow) -> f64| {
        Column::f64(name, unit, description, rows.iter().map(f).collect())
    };
    table_of(vec![
        col("frequency", "Hz", "vibration frequency", |r| r.frequency),
        col("a_amp", "m", "contact-radius amplitude a_A", |r| r.a_amp),
        col("exact_a_mean", "m", "exact: mean radius at pull-off", |r| {
            r.exact.cycle.a_mean
        }),
        col(
            "exact_delta_mean",
            "m",
            "exact: mean indentation at pull-off",
            |r| r.exact.cycle.harmonics.delta_mean,
        ),
        col(
            "exact_delta_amp",
            "m",
            "exact: indentation amplitude at pull-off",
            |r| r.exact.cycle.harmonics.delta_amp,
        ),
        col("exact_force", "N", "exact: pull-off force", |r| {
            r.exact.force
        }),
        col(
            "exact_amplification",
            "1",
            "exact: pull-off amplification over -3/2 pi R w0",
            |r| r.exact.amplification,
        ),
        col(
            "exact_contact_fraction",
            "1",
            "exact: fraction of the cycle in contact",
            |r| r.exact.cycle.contact_fraction,
        ),
        col(
            "exact_local_minima",
            "1",
            "exact: local minima of F_m(a_m)",
            |r| r.exact.local_minima.len() as f64,
        ),
        col("approx_a_mean", "m", "closed form: mean radius", |r| {
            r.approx.a_mean
        }),
        col(
            "approx_delta_mean",
            "m",
            "closed form: mean indentation",
            |r| r.approx.delta_mean,
        ),
        col(
            "approx_delta_amp",
            "m",
            "closed form: indentation amplitude (derived from eqs. 14-15)",
            |r| r.approx.delta_amp,
        ),
        col(
            "approx_delta_amp_printed",
            "m",
            "closed form: indentation amplitude, eq. (23) as printed",
            |r| r.approx_delta_amp_printed,
        ),
        col("approx_force", "N", "closed form: pull-off force", |r| {
            r.approx.force
        }),
        col(
            "approx_amplification",
            "1",
            "closed form: pull-off amplification",
            |r| r.approx.amplification,
        ),
    ])
}

/// Write the chosen figures into `out_dir` as CSV + PNG + SVG; returns the files written.
pub fn write_figures(
    out_dir: &Path,
    which: &[FigureId],
    m: &Material,
    law: &GentSchultz,
    beta: f64,
) -> Result<Vec<PathBuf>, FiguresError> {
    mkdir(out_dir)?;
    let mut files = Vec::new();
    let push_plot = |files: &mut Vec<PathBuf>, fig: &Figure, stem: &str| {
        plot::render(fig, &out_dir.join(stem)).map(|(a, b)| {
            files.push(a);
            files.push(b);
        })
    };
    for id in which {
        match id {
            FigureId::Fig2 => {
                let curves = fig2(m, law, 721);
                let p = out_dir.join("fig2.csv");
                fig2_table(&curves).save_csv(&p)?;
                files.push(p);
                push_plot(&mut files, &fig2_figure(&curves), "fig2")?;
            }
            FigureId::Fig3a => {
                let curves = fig3a(m, law, &FIG3A_AMPLITUDES, beta, 200)?;
                let p = out_dir.join("fig3a.csv");
                fig3a_table(&curves).save_csv(&p)?;
                files.push(p);
                push_plot(&mut files, &fig3a_figure(&curves, beta), "fig3a")?;
            }
            FigureId::Fig3b => {
                let pts = fig3b(m, law, beta)?;
                let p = out_dir.join("fig3b.csv");
                fig3b_table(&pts).save_csv(&p)?;
                files.push(p);
                push_plot(&mut files, &fig3b_figure(&pts, beta), "fig3b")?;
            }
            FigureId::Figs4to8 => {
                let amps = table_amplitudes();
                let rows = table(m, law, &TABLE_FREQUENCIES, &amps, beta)?;
                let p = out_dir.join("figs4-8.csv");
                figs4to8_table(&rows).save_csv(&p)?;
                files.push(p);
                for (stem, fig) in figs4to8_figures(&rows, beta) {
                    push_plot(&mut files, &fig, stem)?;
                }
            }
        }
    }
    Ok(files)
}

/// `values` times `k`.
fn scaled(values: &[f64], k: f64) -> Vec<f64> {
    values.iter().map(|v| v * k).collect()
}

/// Fig. 2: the indentation over one cycle, one line per mean contact radius.
fn fig2_figure(curves: &[Fig2Curve]) -> Figure {
    let all: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.delta.iter().copied())
        .collect();
    let (ds, d_label) = plot::axis_label("δ", "m", &all);
    let mut fig = Figure::new(
        "Fig. 2: indentation over one cycle (200 Hz, a_A = 1 mm)",
        "ωt (rad)",
        d_label,
    );
    for (k, c) in curves.iter().enumerate() {
        fig = fig.with_series(
            Series::new(
                format!("a_m = {:.0} µm", c.a_mean * 1e6),
                c.theta.clone(),
                scaled(&c.delta, ds),
                Style::Line,
            )
            .with_color(k),
        );
    }
    fig
}

/// Fig. 3(a): the mean force against the mean indentation, exact and (dashed) closed form with
/// speed correction `beta`, one colour per amplitude.
fn fig3a_figure(curves: &[Fig3aCurve], beta: f64) -> Figure {
    let deltas: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.delta_mean.iter().chain(&c.approx_delta_mean).copied())
        .collect();
    let forces: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.force_mean.iter().chain(&c.approx_force_mean).copied())
        .collect();
    let (ds, d_label) = plot::axis_label("δ_m", "m", &deltas);
    let (fs, f_label) = plot::axis_label("F_m", "N", &forces);
    let mut fig = Figure::new(
        format!("Fig. 3(a): F_m vs δ_m at 400 Hz (dashed: eq. 18, β = {beta})"),
        d_label,
        f_label,
    )
    .with_legend(LegendPosition::LowerRight);
    for (k, c) in curves.iter().enumerate() {
        fig = fig
            .with_series(
                Series::new(
                    format!("exact, a_A = {:.0} µm", c.a_amp * 1e6),
                    scaled(&c.delta_mean, ds),
                    scaled(&c.force_mean, fs),
                    Style::Line,
                )
                .with_color(k),
            )
            .with_series(
                Series::new(
                    format!("approx, a_A = {:.0} µm", c.a_amp * 1e6),
                    scaled(&c.approx_delta_mean, ds),
                    scaled(&c.approx_force_mean, fs),
                    Style::Dashed,
                )
                .with_color(k),
            );
    }
    fig
}

/// Fig. 3(b): the exact over the approximate pull-off amplification against v_max/v0, one line
/// per exponent n.
#[allow(clippy::float_cmp)] // series are selected by grid values copied from the grid, not computed
fn fig3b_figure(pts: &[RatioPoint], beta: f64) -> Figure {
    let mut fig = Figure::new(
        format!("Fig. 3(b): exact / approximate pull-off amplification (β = {beta})"),
        "v_max / v0 (–)",
        "exact / approximate amplification (–)",
    )
    .with_log(true, false);
    let mut ns: Vec<f64> = pts.iter().map(|p| p.n).collect();
    ns.dedup();
    for (k, n) in ns.iter().enumerate() {
        let sel: Vec<&RatioPoint> = pts.iter().filter(|p| p.n == *n).collect();
        fig = fig.with_series(
            Series::new(
                format!("n = {n}"),
                sel.iter().map(|p| p.speed_ratio).collect(),
                sel.iter().map(|p| p.ratio).collect(),
                Style::LineMarkers,
            )
            .with_color(k),
        );
    }
    fig
}

/// Figs. 4–8 from the table `rows`, with their stems: each quantity at pull-off, exact and
/// (dashed) closed form, one colour per frequency; axes in the unit that suits their values.
#[allow(clippy::float_cmp)] // series are selected by grid values copied from the grid, not computed
fn figs4to8_figures(rows: &[TableRow], beta: f64) -> Vec<(&'static str, Figure)> {
    /// One of the five figures: its stem, title, quantities (x, y, y's SI unit), the exact and
    /// closed-form (x, y) of a row in SI, and markers (else a line) for the exact values.
    struct Spec {
        stem: &'static str,
        title: &'static str,
        x: &'static str,
        y: &'static str,
        y_unit: &'static str,
        exact: fn(&TableRow) -> (f64, f64),
        approx: fn(&TableRow) -> (f64, f64),
        markers: bool,
    }
    let specs = [
        Spec {
            stem: "fig4",
            title: "Fig. 4: mean contact radius at pull-off",
            x: "a_A",
            y: "a_m,po",
            y_unit: "m",
            exact: |r| (r.a_amp, r.exact.cycle.a_mean),
            approx: |r| (r.a_amp, r.approx.a_mean),
            markers: false,
        },
        Spec {
            stem: "fig5",
            title: "Fig. 5: mean indentation at pull-off",
            x: "a_A",
            y: "δ_m,po",
            y_unit: "m",
            exact: |r| (r.a_amp, r.exact.cycle.harmonics.delta_mean),
            approx: |r| (r.a_amp, r.approx.delta_mean),
            markers: false,
        },
        Spec {
            stem: "fig6",
            title: "Fig. 6: indentation amplitude at pull-off",
            x: "a_A",
            y: "δ_A,po",
            y_unit: "m",
            exact: |r| (r.a_amp, r.exact.cycle.harmonics.delta_amp),
            approx: |r| (r.a_amp, r.approx.delta_amp),
            markers: false,
        },
        Spec {
            stem: "fig7",
            title: "Fig. 7: pull-off amplification F_m,po / F0",
            x: "a_A",
            y: "F_m,po / F0",
            y_unit: "1",
            exact: |r| (r.a_amp, r.exact.amplification),
            approx: |r| (r.a_amp, r.approx.amplification),
            markers: false,
        },
        Spec {
            stem: "fig8",
            title: "Fig. 8: indentation amplitude vs mean at pull-off",
            x: "δ_m,po",
            y: "δ_A,po",
            y_unit: "m",
            exact: |r| {
                (
                    r.exact.cycle.harmonics.delta_mean,
                    r.exact.cycle.harmonics.delta_amp,
                )
            },
            approx: |r| (r.approx.delta_mean, r.approx.delta_amp),
            markers: true,
        },
    ];
    let mut figs = Vec::new();
    for Spec {
        stem,
        title,
        x: xq,
        y: yq,
        y_unit: yu,
        exact,
        approx,
        markers,
    } in specs
    {
        let (xs, ys): (Vec<f64>, Vec<f64>) =
            rows.iter().flat_map(|r| [exact(r), approx(r)]).unzip();
        let (xf, x_label) = plot::axis_label(xq, "m", &xs);
        let (yf, y_label) = plot::axis_label(yq, yu, &ys);
        let mut fig = Figure::new(format!("{title} (dashed: β = {beta})"), x_label, y_label);
        for (k, &f) in TABLE_FREQUENCIES.iter().enumerate() {
            let sel: Vec<&TableRow> = rows.iter().filter(|r| r.frequency == f).collect();
            let display = |p: (f64, f64)| (p.0 * xf, p.1 * yf);
            let (ex, ey): (Vec<f64>, Vec<f64>) = sel.iter().map(|r| display(exact(r))).unzip();
            let (ax, ay): (Vec<f64>, Vec<f64>) = sel.iter().map(|r| display(approx(r))).unzip();
            let style = if markers { Style::Markers } else { Style::Line };
            fig = fig
                .with_series(Series::new(format!("exact, {f:.0} Hz"), ex, ey, style).with_color(k))
                .with_series(
                    Series::new(format!("approx, {f:.0} Hz"), ax, ay, Style::Dashed).with_color(k),
                );
        }
        figs.push((stem, fig));
    }
    figs
}

#[cfg(test)]
#[path = "figures_tests.rs"]
mod tests;
