//! `fit.png`/`fit.svg`: the data and the model above, the normalised residuals below.
//!
//! The horizontal axis is the numeric condition with the most distinct values (the row number
//! without one); the rows that share the values of every other condition are one group, drawn
//! in one colour. Above: the data as markers with a vertical bar of ±σ (the σ each row was
//! weighted with, when the file gives sigma), and the model as a line computed on a grid of
//! [`GRID`] points of the plotted condition across the group's range (not segments between the
//! data points), with dashed lines at ±1σ of the model from the parameters' covariance (the
//! delta method: `σ_m² = gᵀ C g`, `g` the forward difference of the model at each grid point
//! with the fit's last steps). Its title holds the estimates. Below: each row's
//! `(observed − fitted)/σ`, with lines at 0 and ±1, under a title with the data file and
//! χ²/dof. Without a numeric condition, or when the
//! grid's runs cannot be made (a stop, a failed run), the model is drawn as rings at the data
//! points.

use std::sync::atomic::AtomicBool;

use crate::output::table::format_pm;
use crate::plot::{display_unit, unit_text, Figure, LegendPosition, Series, Style};
use djkr_core::text::format_sig;

use super::data::{CondValue, DataRow, FitData};
use super::model::{EvalError, ForwardModel};
use super::report::FitOutcome;

/// Points of the model's grid per group.
pub const GRID: usize = 16;

/// The model on a grid of the plotted condition, per group (in the order of the groups).
#[derive(Debug, Clone, PartialEq)]
pub struct Curves {
    /// Per group: the condition's values (SI), the model, and its ±1σ (NaN without one).
    pub groups: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)>,
}

/// The plotted condition and the groups of rows.
struct Layout {
    /// The condition on the horizontal axis (index into the data's conditions).
    xj: Option<usize>,
    /// Each row's abscissa (SI, or the row number).
    xs: Vec<f64>,
    /// The groups: label and rows, sorted by abscissa.
    groups: Vec<(String, Vec<usize>)>,
}

fn layout(data: &FitData) -> Layout {
    let n = data.rows.len();
    let distinct = |j: usize| {
        let mut v: Vec<f64> = data
            .rows
            .iter()
            .filter_map(|r| match r.conditions[j] {
                CondValue::Num(x) => Some(x),
                CondValue::Text(_) => None,
            })
            .collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v.len()
    };
    let xj = (0..data.conditions.len())
        .filter(|&j| data.conditions[j].unit.is_some())
        .max_by_key(|&j| distinct(j));
    let xs: Vec<f64> = (0..n)
        .map(|i| match xj.map(|j| &data.rows[i].conditions[j]) {
            Some(CondValue::Num(x)) => *x,
            _ => i as f64,
        })
        .collect();
    // Each other numeric condition in the unit that reads best over its column (um, not m).
    let shown: Vec<Option<(f64, String)>> = data
        .conditions
        .iter()
        .enumerate()
        .map(|(j, c)| {
            let col: Vec<f64> = data
                .rows
                .iter()
                .filter_map(|r| match r.conditions[j] {
                    CondValue::Num(x) => Some(x),
                    CondValue::Text(_) => None,
                })
                .collect();
            c.unit.map(|u| display_unit(u, &col))
        })
        .collect();
    let label_of = |i: usize| -> String {
        data.conditions
            .iter()
            .enumerate()
            .filter(|(j, _)| Some(*j) != xj)
            .map(|(j, c)| {
                let v = match (&data.rows[i].conditions[j], &shown[j]) {
                    (CondValue::Num(x), Some((f, u))) if u != "1" => {
                        format!("{} {u}", short(x * f))
                    }
                    (CondValue::Num(x), _) => short(*x),
                    (CondValue::Text(t), _) => t.clone(),
                };
                format!("{} = {v}", c.key)
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for i in 0..n {
        let l = label_of(i);
        match groups.iter_mut().find(|(g, _)| *g == l) {
            Some((_, v)) => v.push(i),
            None => groups.push((l, vec![i])),
        }
    }
    for (_, idx) in groups.iter_mut() {
        idx.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
    }
    Layout { xj, xs, groups }
}

/// A condition's value in a legend: 4 significant digits, without trailing zeros (`5 µm`, not
/// `5.000 µm` nor `4.9999999999999996e-6 m`).
fn short(x: f64) -> String {
    let t = format_sig(x, 4);
    match t.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
        }
        None if t.contains('.') => t.trim_end_matches('0').trim_end_matches('.').to_string(),
        _ => t,
    }
}

/// `GRID` values from `a` to `b` (log-spaced when both are positive and span more than a factor
/// 20).
fn grid(a: f64, b: f64) -> Vec<f64> {
    let log = a > 0.0 && b / a > 20.0;
    (0..GRID)
        .map(|i| {
            let t = i as f64 / (GRID - 1) as f64;
            if log {
                (a.ln() + t * (b.ln() - a.ln())).exp()
            } else {
                a + t * (b - a)
            }
        })
        .collect()
}

/// The model of `outcome` on a grid of the plotted condition for each group of `model`'s data,
/// with its ±1σ from the covariance: `1 + k` parameter sets (the estimate and a forward step of
/// each key with a σ) on `groups × GRID` rows, at the fit's tolerances. `None` without a numeric
/// condition to plot against.
pub fn fit_curves(
    model: &ForwardModel,
    outcome: &FitOutcome,
    stop: Option<&AtomicBool>,
    on_run: &mut dyn FnMut(),
) -> Result<Option<Curves>, EvalError> {
    let data = model.data();
    let l = layout(data);
    let Some(xj) = l.xj else {
        return Ok(None);
    };
    let mut rows = Vec::new();
    let mut spans = Vec::new();
    for (_, idx) in &l.groups {
        let lo = idx.iter().map(|&i| l.xs[i]).fold(f64::INFINITY, f64::min);
        let hi = idx
            .iter()
            .map(|&i| l.xs[i])
            .fold(f64::NEG_INFINITY, f64::max);
        let g = if hi > lo { grid(lo, hi) } else { vec![lo] };
        let proto = &data.rows[idx[0]];
        for &x in &g {
            let mut conditions = proto.conditions.clone();
            conditions[xj] = CondValue::Num(x);
            rows.push(DataRow {
                line: proto.line,
                conditions,
                observed: 0.0,
                sigma: None,
            });
        }
        spans.push(g);
    }
    let grid_data = FitData {
        rows,
        has_sigma: false,
        sigma_column: None,
        ..data.clone()
    };
    let t = &outcome.report.tolerances;
    let mut solver = Vec::new();
    for (key, v, s) in [
        ("solver.rtol", t.rtol, t.scenario_rtol),
        (
            "solver.envelope_tol",
            t.envelope_tol,
            t.scenario_envelope_tol,
        ),
    ] {
        if v.to_bits() != s.to_bits() {
            let o = crate::scenario::overrides::SetKey::parse(key)
                .and_then(|k| crate::scenario::overrides::Override::from_key(k, v))
                .map_err(|e| EvalError::Failed(e.to_string()))?;
            solver.push(o);
        }
    }
    let gm = ForwardModel::new(
        model.source().clone(),
        grid_data,
        model.free().to_vec(),
        model.fixed().to_vec(),
        model.ensemble(),
        model.jobs(),
    )
    .map_err(EvalError::Failed)?
    .with_solver(solver);
    let k = outcome.values.len();
    let with_sigma: Vec<usize> = (0..k)
        .filter(|&j| outcome.cov_y[j][j].is_finite())
        .collect();
    let mut sets = vec![outcome.values.clone()];
    let mut steps = Vec::new();
    for &j in &with_sigma {
        sets.push(outcome.stepped[j].clone());
        steps.push(outcome.steps[j]);
    }
    let preds = gm.predict(&sets, stop, on_run)?;
    let m = &preds[0].values;
    let band: Vec<f64> = (0..m.len())
        .map(|i| {
            if with_sigma.is_empty() {
                return f64::NAN;
            }
            let g: Vec<f64> = (0..with_sigma.len())
                .map(|c| (preds[c + 1].values[i] - m[i]) / steps[c])
                .collect();
            let mut v = 0.0;
            for (a, &ja) in with_sigma.iter().enumerate() {
                for (b, &jb) in with_sigma.iter().enumerate() {
                    v += g[a] * outcome.cov_y[ja][jb] * g[b];
                }
            }
            v.max(0.0).sqrt()
        })
        .collect();
    let mut out = Vec::new();
    let mut at = 0;
    for g in spans {
        let len = g.len();
        out.push((g, m[at..at + len].to_vec(), band[at..at + len].to_vec()));
        at += len;
    }
    Ok(Some(Curves { groups: out }))
}

/// The two panels of a fit's figure: data and model above, residuals below (render them with
/// [`crate::plot::render_panels`] in one column).
pub(crate) fn fit_figure(
    model: &ForwardModel,
    outcome: &FitOutcome,
    curves: Option<&Curves>,
) -> Vec<Figure> {
    let data = model.data();
    let l = layout(data);
    let (xs, xj) = (&l.xs, l.xj);
    let (xf, xunit) = match xj.and_then(|j| data.conditions[j].unit) {
        Some(u) => display_unit(u, xs),
        None => (1.0, String::new()),
    };
    let x_label = match xj {
        Some(j) => format!("{} [{}]", data.conditions[j].key, unit_text(&xunit)),
        None => "row [–]".to_string(),
    };
    let obs: Vec<f64> = data.rows.iter().map(|r| r.observed).collect();
    let (yf, yunit) = display_unit(data.observable.unit(), &obs);
    let r = &outcome.report;
    let estimates = r
        .parameters
        .iter()
        .map(|p| {
            let unit = if p.unit == "1" {
                String::new()
            } else {
                format!(" {}", p.unit)
            };
            format!("{} = {}{unit}", p.key, format_pm(p.value, p.sigma))
        })
        .collect::<Vec<_>>()
        .join(", ");
    let mut fig = Figure::new(
        estimates,
        x_label.clone(),
        format!("{} [{}]", data.observable.name(), unit_text(&yunit)),
    );
    fig.legend = LegendPosition::default();
    let mut res = Figure::new(
        format!(
            "{}, {} rows: chi2/dof = {:.2}/{} = {:.3}; residuals (observed - fitted)/sigma",
            std::path::Path::new(&data.name)
                .file_name()
                .map_or(data.name.clone(), |f| f.to_string_lossy().into_owned()),
            r.rows,
            r.chi2,
            r.dof,
            r.reduced_chi2
        ),
        x_label,
        format!("(observed - fitted)/sigma [{}]", unit_text("1")),
    );
    res.legend = LegendPosition::default();
    let single = l.groups.len() == 1;
    for (g, (label, idx)) in l.groups.iter().enumerate() {
        let name = |what: &str| {
            if single || label.is_empty() {
                what.to_string()
            } else {
                format!("{what}, {label}")
            }
        };
        fig.series.push(
            Series::new(
                name(if data.has_sigma {
                    "data +- sigma"
                } else {
                    "data"
                }),
                idx.iter().map(|&i| xs[i] * xf).collect(),
                idx.iter().map(|&i| obs[i] * yf).collect(),
                Style::Markers,
            )
            .with_color(g),
        );
        if data.has_sigma {
            let mut bx = Vec::new();
            let mut by = Vec::new();
            for &i in idx {
                let s = outcome.weights[i];
                bx.extend([xs[i] * xf, xs[i] * xf, f64::NAN]);
                by.extend([(obs[i] - s) * yf, (obs[i] + s) * yf, f64::NAN]);
            }
            fig.series
                .push(Series::new("", bx, by, Style::Line).with_color(g));
        }
        match curves.and_then(|c| c.groups.get(g)) {
            Some((cx, cy, band)) => {
                let x: Vec<f64> = cx.iter().map(|v| v * xf).collect();
                fig.series.push(
                    Series::new(
                        name("model"),
                        x.clone(),
                        cy.iter().map(|v| v * yf).collect(),
                        Style::Line,
                    )
                    .with_color(g),
                );
                if band.iter().all(|b| b.is_finite()) {
                    for sign in [-1.0, 1.0] {
                        let label = if g == 0 && sign > 0.0 {
                            "model +- 1 sigma (parameters)"
                        } else {
                            ""
                        };
                        fig.series.push(
                            Series::new(
                                label,
                                x.clone(),
                                cy.iter()
                                    .zip(band)
                                    .map(|(v, b)| (v + sign * b) * yf)
                                    .collect(),
                                Style::Dashed,
                            )
                            .with_color(g),
                        );
                    }
                }
            }
            None => fig.series.push(
                Series::new(
                    name("model at the data"),
                    idx.iter().map(|&i| xs[i] * xf).collect(),
                    idx.iter()
                        .map(|&i| outcome.prediction.values[i] * yf)
                        .collect(),
                    Style::Rings,
                )
                .with_color(g),
            ),
        }
        res.series.push(
            Series::new(
                if single { String::new() } else { label.clone() },
                idx.iter().map(|&i| xs[i] * xf).collect(),
                idx.iter()
                    .map(|&i| (obs[i] - outcome.prediction.values[i]) / outcome.weights[i])
                    .collect(),
                Style::Markers,
            )
            .with_color(g),
        );
    }
    let (lo, hi) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x * xf), b.max(x * xf))
        });
    for (v, style) in [
        (0.0, Style::Line),
        (-1.0, Style::Dashed),
        (1.0, Style::Dashed),
    ] {
        res.series
            .push(Series::new("", vec![lo, hi], vec![v, v], style).with_color(l.groups.len()));
    }
    vec![fig, res]
}

/// Draw `fit.png` and `fit.svg` at `stem`: the model's grid run first ([`fit_curves`], skipped
/// for an interrupted fit; a stop or a failed run leaves the model as rings at the data), then
/// the two panels of [`fit_figure`] one above the other.
pub fn draw(
    model: &ForwardModel,
    outcome: &FitOutcome,
    stem: &std::path::Path,
    stop: Option<&AtomicBool>,
    on_run: &mut dyn FnMut(),
) -> Result<(), crate::plot::PlotError> {
    let curves = if outcome.report.interrupted {
        None
    } else {
        fit_curves(model, outcome, stop, on_run).ok().flatten()
    };
    let panels = fit_figure(model, outcome, curves.as_ref());
    crate::plot::render_panels(&panels, 1, (1000, 1300), stem)?;
    Ok(())
}

/// Forward runs [`fit_curves`] makes for `model`'s data with `k` keys with a σ.
pub fn curve_runs(model: &ForwardModel, k: usize) -> usize {
    let l = layout(model.data());
    if l.xj.is_none() {
        return 0;
    }
    l.groups.len() * GRID * (1 + k) * model.members()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legend_values_are_short() {
        assert_eq!(short(4.999_999_999_999_999_6), "5");
        assert_eq!(short(10.0), "10");
        assert_eq!(short(0.0), "0");
        assert_eq!(short(2.5), "2.5");
        assert_eq!(short(1234.5678), "1235");
        let g = grid(10.0, 80.0);
        assert_eq!(g.len(), GRID);
        assert!((g[0] - 10.0).abs() < 1e-12 && (g[GRID - 1] - 80.0).abs() < 1e-12);
        // Wider than a factor 20: log-spaced.
        let g = grid(30.0, 3000.0);
        assert!((g[1] / g[0] - g[2] / g[1]).abs() < 1e-9);
    }
}
