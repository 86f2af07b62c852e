//! The files of a fit, written in its output folder (claimed and locked by the caller before
//! the fit starts): `fit.json`, `residuals.csv`, `fitted.toml`, `fit.png` and `fit.svg`, each
//! atomically. Shared by `djkr fit` and Python's `djkr.fit(out=...)`.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use crate::output::table::format_f64;
use crate::scenario::overrides::Override;
use crate::scenario::parse::ScenarioSource;

use super::free::FreeKey;
use super::model::ForwardModel;
use super::report::FitOutcome;

/// The files a fit writes.
pub const FILES: [&str; 5] = [
    "fit.json",
    "residuals.csv",
    "fitted.toml",
    "fit.png",
    "fit.svg",
];

/// The header of `fitted.toml`.
fn header(
    source: &ScenarioSource,
    fixed: &[Override],
    model: &ForwardModel,
    outcome: &FitOutcome,
) -> String {
    format!(
        "Written by djkr fit: {} with the estimates of {}\nfrom {} (fit.json beside this file). \
         Each value written in says so in a comment.\n{}",
        source.name(),
        outcome
            .report
            .parameters
            .iter()
            .map(|p| format!("{} = {} {}", p.key, format_f64(p.value), p.unit))
            .collect::<Vec<_>>()
            .join(", "),
        model.data().name,
        if fixed.is_empty() {
            String::new()
        } else {
            format!(
                "With the overrides {}.",
                fixed
                    .iter()
                    .map(|o| o.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }
    )
}

/// The texts of `fit.json`, `residuals.csv` and `fitted.toml`, in that order: what [`write`]
/// writes, and what `predict` reads of a fit made without a folder.
pub(crate) fn texts(
    source: &ScenarioSource,
    fixed: &[Override],
    free: &[FreeKey],
    model: &ForwardModel,
    outcome: &FitOutcome,
) -> Result<[String; 3], String> {
    let toml = super::fitted::fitted_toml(
        source,
        fixed,
        free,
        &outcome.values,
        &header(source, fixed, model, outcome),
    )?;
    let json = serde_json::to_string_pretty(&outcome.report).map_err(|e| e.to_string())?;
    Ok([
        format!("{json}\n"),
        super::residuals::residuals_csv(model, outcome),
        toml,
    ])
}

/// Write the fit's files in `out`: `fit.json`, `residuals.csv`, `fitted.toml`, then the figure
/// (whose model grid runs with `stop` and reports each run to `on_run`). Returns `fit.json`'s
/// text.
#[allow(clippy::too_many_arguments)]
pub fn write(
    out: &Path,
    source: &ScenarioSource,
    fixed: &[Override],
    free: &[FreeKey],
    model: &ForwardModel,
    outcome: &FitOutcome,
    stop: Option<&AtomicBool>,
    on_run: &mut dyn FnMut(),
) -> Result<String, String> {
    let put = |name: &str, bytes: &[u8]| {
        crate::output::write_atomic(&out.join(name), bytes).map_err(|e| format!("{name}: {e}"))
    };
    let [json, residuals, toml] = texts(source, fixed, free, model, outcome)?;
    put("fit.json", json.as_bytes())?;
    put("residuals.csv", residuals.as_bytes())?;
    put("fitted.toml", toml.as_bytes())?;
    super::figure::draw(model, outcome, &out.join("fit"), stop, on_run)
        .map_err(|e| format!("fit.png/fit.svg: {e}"))?;
    Ok(json.trim_end().to_string())
}
