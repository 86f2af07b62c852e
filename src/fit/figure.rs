//! `fit.png`/`fit.svg`: the data with their error bars and the fitted values, one curve per
//! group of the other conditions.
//!
//! The horizontal axis is the numeric condition with the most distinct values (the row number
//! without one); the rows that share the values of every other condition are one group, drawn
//! in one colour: markers for the data, a vertical bar of ±σ (the σ each row was weighted with,
//! when the file gives sigma), and a line through the model's values at the same conditions.

use crate::output::table::format_f64;
use crate::plot::{display_unit, unit_text, Figure, LegendPosition, Series, Style, GREY};

use super::data::CondValue;
use super::model::ForwardModel;
use super::FitOutcome;

/// The figure of a fit.
pub fn fit_figure(model: &ForwardModel, outcome: &FitOutcome) -> Figure {
    let data = model.data();
    let n = data.rows.len();
    // The x condition: numeric, most distinct values.
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
    let (xf, xunit) = match xj.and_then(|j| data.conditions[j].unit) {
        Some(u) => display_unit(u, &xs),
        None => (1.0, String::new()),
    };
    let x_label = match xj {
        Some(j) => format!("{} [{}]", data.conditions[j].key, unit_text(&xunit)),
        None => "row [–]".to_string(),
    };
    let obs: Vec<f64> = data.rows.iter().map(|r| r.observed).collect();
    let (yf, yunit) = display_unit(data.observable.unit(), &obs);
    // Groups: the other conditions' values.
    let label_of = |i: usize| -> String {
        data.conditions
            .iter()
            .enumerate()
            .filter(|(j, _)| Some(*j) != xj)
            .map(|(j, c)| {
                let v = match &data.rows[i].conditions[j] {
                    CondValue::Num(x) => format_f64(*x),
                    CondValue::Text(t) => t.clone(),
                };
                format!(
                    "{} = {v}{}",
                    c.key,
                    c.unit.map(|u| format!(" {u}")).unwrap_or_default()
                )
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
    let mut fig = Figure::new(
        format!(
            "djkr fit: {} of {} ({} rows)",
            data.observable.name(),
            data.name,
            n
        ),
        x_label,
        format!("{} [{}]", data.observable.name(), unit_text(&yunit)),
    );
    fig.legend = LegendPosition::default();
    // The key to the lines: a legend entry with no data of its own.
    fig.series.push(
        Series::new(
            "lines: the fitted values",
            Vec::new(),
            Vec::new(),
            Style::Line,
        )
        .with_color(GREY),
    );
    for (g, (label, idx)) in groups.iter().enumerate() {
        let mut idx = idx.clone();
        idx.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
        let name = if label.is_empty() {
            "data".to_string()
        } else {
            label.clone()
        };
        fig.series.push(
            Series::new(
                name,
                idx.iter().map(|&i| xs[i] * xf).collect(),
                idx.iter().map(|&i| obs[i] * yf).collect(),
                Style::Markers,
            )
            .with_color(g),
        );
        if data.has_sigma {
            let mut bx = Vec::new();
            let mut by = Vec::new();
            for &i in &idx {
                let s = outcome.weights[i];
                bx.extend([xs[i] * xf, xs[i] * xf, f64::NAN]);
                by.extend([(obs[i] - s) * yf, (obs[i] + s) * yf, f64::NAN]);
            }
            fig.series
                .push(Series::new("", bx, by, Style::Line).with_color(g));
        }
        fig.series.push(
            Series::new(
                "",
                idx.iter().map(|&i| xs[i] * xf).collect(),
                idx.iter()
                    .map(|&i| outcome.prediction.values[i] * yf)
                    .collect(),
                Style::Line,
            )
            .with_color(g),
        );
    }
    fig
}
