//! Fitting a rig's unknowns to measured data (`djkr fit`): weighted least squares of a sweep
//! observable over the full dynamic model, with uncertainties and information criteria to
//! compare laws.
//!
//! - `data` ([`FitData`]): the data file (conditions named by scenario keys, one observable named as in
//!   `sweep.csv`, optional `sigma`), units honoured.
//! - `free` ([`FreeKey`]): the free keys (`KEY[=LO:HI]`), log space for positive scales, bounds by
//!   transformation.
//! - `model` ([`ForwardModel`]): the forward model, every row a run of the sweep engine (with an ensemble, the
//!   mean over members whose phases are fixed by the seed).
//! - `driver` ([`fit()`]): Levenberg–Marquardt with finite-difference Jacobians, covariance, correlation,
//!   χ², AIC and BIC ([`FitReport`] is `fit.json`).
//!
//! This module also gives the starting values ([`initial_value`]), the fitted scenario
//! ([`fitted_toml`]) and the residual table ([`residuals_csv`]).

pub(crate) mod data;
pub(crate) mod driver;
pub(crate) mod figure;
pub(crate) mod free;
pub(crate) mod model;
pub(crate) mod stencil;

pub use data::{FitData, Observable};
pub use driver::{
    check_start, fd_step, fit, FitEvent, FitOptions, FitOutcome, FitReport, Parameter,
};
pub use figure::fit_figure;
pub use free::FreeKey;
pub use model::ForwardModel;

use crate::output::table::format_f64;
use crate::scenario::overrides::{Override, SetKey};
use crate::scenario::parse::ScenarioSource;
use crate::units::{parse_quantity, Dimension};

/// A number from a TOML value as a scenario file holds it: a number (SI) or a string with
/// units.
fn toml_number(v: &toml::Value, key: &SetKey, dim: Dimension) -> Result<f64, String> {
    match v {
        toml::Value::Float(x) => Ok(*x),
        toml::Value::Integer(i) => Ok(*i as f64),
        toml::Value::String(s) => parse_quantity(&key.to_string(), s, dim)
            .map_err(|e| format!("{key} = '{s}': {}", e.allowed)),
        other => Err(format!("{key} = {other}: not a number")),
    }
}

/// The starting value (SI) of a free key: the `--set` override's if one sets it, else the
/// scenario file's. A key the file does not give has no starting value (the parser's default is
/// not a measured value): the message says to give one with `--set`.
pub fn initial_value(
    source: &ScenarioSource,
    fixed: &[Override],
    free: &FreeKey,
) -> Result<f64, String> {
    let key = free.key;
    if let Some(o) = fixed.iter().find(|o| o.key() == key) {
        return toml_number(o.value(), &key, free.dim);
    }
    let table: toml::Table = source
        .text()
        .parse()
        .map_err(|e| format!("{}: {e}", source.name()))?;
    let section = match (key.section(), key.index()) {
        (None, _) => Some(&table),
        (Some(s), None) => table.get(s).and_then(toml::Value::as_table),
        (Some(s), Some(i)) => table
            .get(s)
            .and_then(toml::Value::as_array)
            .and_then(|a| a.get(i))
            .and_then(toml::Value::as_table),
    };
    let missing = || {
        format!(
            "--free {}: {} does not give {key}: give its starting value with --set {key}=VALUE",
            free.given,
            source.name()
        )
    };
    let v = section
        .and_then(|t| t.get(key.name()))
        .ok_or_else(missing)?;
    toml_number(v, &key, free.dim).map_err(|m| format!("{}: {m}", source.name()))
}

/// The scenario with the estimates: the file's table with the fixed `--set` overrides and the
/// free keys at `values` written in, as TOML, headed by a comment saying where it came from.
/// `djkr run` of it with a data row's conditions as `--set` reproduces that row's fitted value
/// (the numbers are written in shortest round-trip form). The file's comments are not kept.
pub fn fitted_toml(
    source: &ScenarioSource,
    fixed: &[Override],
    free: &[FreeKey],
    values: &[f64],
    header: &str,
) -> Result<String, String> {
    let mut table: toml::Table = source
        .text()
        .parse()
        .map_err(|e| format!("{}: {e}", source.name()))?;
    let mut all: Vec<Override> = fixed.to_vec();
    for (f, &x) in free.iter().zip(values) {
        all.push(Override::from_key(f.key, x).map_err(|e| e.to_string())?);
    }
    crate::scenario::overrides::apply(&mut table, &all, source.name())
        .map_err(|e| e.to_string())?;
    let body = toml::to_string(&table).map_err(|e| e.to_string())?;
    let mut out = String::new();
    for line in header.lines() {
        out.push_str("# ");
        out.push_str(line);
        out.push('\n');
    }
    out.push('\n');
    out.push_str(&body);
    Ok(out)
}

/// `residuals.csv`: per data row its conditions (SI, in the columns' units), `observed`,
/// `sigma` (the file's; empty without), with an ensemble `ensemble_se` (the standard error of
/// the members' mean at the estimate), `fitted`, `residual` (= observed − fitted) and
/// `normalized_residual` (residual over the σ the row was weighted with).
pub fn residuals_csv(model: &ForwardModel, outcome: &FitOutcome) -> String {
    let data = model.data();
    let u = data.observable.unit();
    let mut head: Vec<String> = data
        .conditions
        .iter()
        .map(|c| match c.unit {
            Some(unit) => format!("{} [{unit}]", c.key),
            None => c.key.to_string(),
        })
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

/// A text cell, quoted when it needs to be.
fn csv_text(t: &str) -> String {
    if t.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", t.replace('"', "\"\""))
    } else {
        t.to_string()
    }
}
