//! The fit's residuals: `residuals.csv` ([`residuals_csv`]) and the same columns as data
//! ([`residual_columns`], for Python's DataFrame).

use super::data;
use super::model::ForwardModel;
use super::report::FitOutcome;
use crate::output::table::format_f64;

/// A column of a table of the fit's results (residuals, predictions, designs): numbers, counts,
/// or the text of a text condition.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    /// Numbers (SI, in the column's unit).
    Num(Vec<f64>),
    /// Whole numbers (a design's repeats).
    Whole(Vec<u64>),
    /// Text as the data file gave it.
    Text(Vec<String>),
}

/// `residuals.csv`: per data row its conditions (SI, in the columns' units), `observed`,
/// `sigma` (the file's; empty without), with an ensemble `ensemble_se` (the standard error of
/// the members' mean at the estimate), `fitted`, `residual` (= observed − fitted) and
/// `normalized_residual` (residual over the σ the row was weighted with).
pub(crate) fn residuals_csv(model: &ForwardModel, outcome: &FitOutcome) -> String {
    let data = model.data();
    let u = data.observable.unit();
    let mut head: Vec<String> = data
        .conditions
        .iter()
        .map(|c| column_name(c.key, c.unit))
        .collect();
    head.push(format!("observed [{u}]"));
    head.push(format!("sigma [{u}]"));
    let ens = model.members() > 1;
    if ens {
        head.push(format!("ensemble_se [{u}]"));
    }
    head.push(format!("fitted [{u}]"));
    head.push(format!("residual [{u}]"));
    head.push("normalized_residual [1]".into());
    let mut out = head.join(",");
    out.push('\n');
    for (i, r) in data.rows.iter().enumerate() {
        let mut cells: Vec<String> = r
            .conditions
            .iter()
            .map(|c| match c {
                data::CondValue::Num(x) => format_f64(*x),
                data::CondValue::Text(t) => csv_text(t),
            })
            .collect();
        let fit = outcome.prediction.values[i];
        cells.push(format_f64(r.observed));
        cells.push(r.sigma.map(format_f64).unwrap_or_default());
        if ens {
            cells.push(format_f64(outcome.prediction.se[i]));
        }
        cells.push(format_f64(fit));
        cells.push(format_f64(r.observed - fit));
        cells.push(format_f64((r.observed - fit) / outcome.weights[i]));
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// The columns of `residuals.csv` (named as its header), for Python's DataFrame.
pub(crate) fn residual_columns(
    model: &ForwardModel,
    outcome: &FitOutcome,
) -> Vec<(String, Column)> {
    let data = model.data();
    let u = data.observable.unit();
    let mut out = Vec::new();
    for (j, c) in data.conditions.iter().enumerate() {
        let name = column_name(c.key, c.unit);
        let col = match c.unit {
            Some(_) => Column::Num(
                data.rows
                    .iter()
                    .map(|r| match &r.conditions[j] {
                        data::CondValue::Num(x) => *x,
                        data::CondValue::Text(_) => f64::NAN,
                    })
                    .collect(),
            ),
            None => Column::Text(
                data.rows
                    .iter()
                    .map(|r| match &r.conditions[j] {
                        data::CondValue::Num(x) => format_f64(*x),
                        data::CondValue::Text(t) => t.clone(),
                    })
                    .collect(),
            ),
        };
        out.push((name, col));
    }
    let obs: Vec<f64> = data.rows.iter().map(|r| r.observed).collect();
    let fit = &outcome.prediction.values;
    let num = |name: String, v: Vec<f64>| (name, Column::Num(v));
    out.push(num(format!("observed [{u}]"), obs.clone()));
    out.push(num(
        format!("sigma [{u}]"),
        data.rows
            .iter()
            .map(|r| r.sigma.unwrap_or(f64::NAN))
            .collect(),
    ));
    if model.members() > 1 {
        out.push(num(
            format!("ensemble_se [{u}]"),
            outcome.prediction.se.clone(),
        ));
    }
    out.push(num(format!("fitted [{u}]"), fit.clone()));
    out.push(num(
        format!("residual [{u}]"),
        obs.iter().zip(fit).map(|(o, f)| o - f).collect(),
    ));
    out.push(num(
        "normalized_residual [1]".into(),
        (0..obs.len())
            .map(|i| (obs[i] - fit[i]) / outcome.weights[i])
            .collect(),
    ));
    out
}

/// A condition's column name: `key [unit]`, or the bare key for a text condition. Shared by
/// residuals.csv, prediction.csv and design.csv.
pub(crate) fn column_name(key: impl std::fmt::Display, unit: Option<&str>) -> String {
    match unit {
        Some(unit) => format!("{key} [{unit}]"),
        None => key.to_string(),
    }
}

/// A text cell, quoted where it holds a comma, a quote or a line end (RFC 4180).
pub(crate) fn csv_text(t: &str) -> String {
    if t.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", t.replace('"', "\"\""))
    } else {
        t.to_string()
    }
}
