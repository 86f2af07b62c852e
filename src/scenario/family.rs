//! The scenario side of continuation: a scenario file with its fixed `--set` overrides, as the
//! [`Scene`] whose periodic orbits `djkr continue` follows, and which keys may be parameters.
//!
//! The file is read and parsed once; each parameter value is an override of the file's table,
//! validated as the file with the value written in it would be ([`ScenarioSource::scenario`],
//! the one way a scenario is built), and the steady-state problem taken from it. A tabulated
//! law's table, read once with the file, is shared by every scenario built.

use std::sync::{Arc, Mutex, OnceLock};

use super::keys::{Kind, KEYS};
use super::overrides::{Override, SetKey};
use super::parse::{ScenarioError, ScenarioSource};
use djkr_core::continuation::family::{Family, Parameter, ParameterInfo, Scene, Setup};
use djkr_core::continuation::ContinuationError;
use djkr_core::dynamics::protocol::Initial;
use djkr_core::steady::Problem;
use djkr_core::text::excerpt;
use djkr_core::units::Dimension;

/// The keys a periodic orbit can be continued in: those of the table of keys with a parameter
/// name ([`KeyInfo::param`](super::keys::KeyInfo#structfield.param)), in table order.
pub(crate) fn parameters() -> &'static [ParameterInfo] {
    static TABLE: OnceLock<Vec<ParameterInfo>> = OnceLock::new();
    TABLE.get_or_init(|| {
        KEYS.iter()
            .filter_map(|k| {
                let what = k.param?;
                let dimension = match k.kind {
                    Kind::Number(Some(d)) => d,
                    _ => Dimension::Dimensionless,
                };
                Some(ParameterInfo {
                    // Built once per process: the table's keys live as long as it.
                    key: Box::leak(k.key().into_boxed_str()),
                    unit: if k.unit.is_empty() { "1" } else { k.unit },
                    dimension,
                    what,
                })
            })
            .collect()
    })
}

/// The allowed keys, comma separated (for messages).
pub(crate) fn allowed_keys() -> String {
    parameters()
        .iter()
        .map(|p| p.key)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Parse a continuation parameter given as `flag` (for messages), refusing a key that is not a
/// constant of the periodic problem with the list of those that are.
pub fn parameter(flag: &str, text: &str) -> Result<Parameter, ContinuationError> {
    let key = SetKey::parse(text).map_err(|e| {
        ContinuationError::Input(format!(
            "{flag} {}: {}; a continuation parameter is one of {}",
            excerpt(text),
            e.message,
            allowed_keys()
        ))
    })?;
    let shown = key.to_string();
    let info = *parameters()
        .iter()
        .find(|p| p.key == shown)
        .ok_or_else(|| {
            ContinuationError::Input(format!(
                "{flag} {}: not a constant of the periodic orbit (stages, solver, output and \
             text keys do not change it); a continuation parameter is one of {}",
                excerpt(text),
                allowed_keys()
            ))
        })?;
    Ok(Parameter { info })
}

/// A scenario with one or two keys left free: the [`Scene`] of `djkr continue`.
#[derive(Debug)]
pub(crate) struct ScenarioScene {
    source: ScenarioSource,
    fixed: Vec<Override>,
    keys: Vec<SetKey>,
    rtol: f64,
    /// The scene's start at the first value built, and whether earlier stages made it.
    start: Mutex<Option<(Initial, bool)>>,
}

/// The family of `source` with the overrides `fixed` and the free keys `params` (one or two).
/// An override of a free key is refused (its values come from the continuation). `rtol` is the
/// integration tolerance used when earlier stages must run to find the start.
pub fn family(
    source: &ScenarioSource,
    fixed: &[Override],
    params: Vec<Parameter>,
    rtol: f64,
) -> Result<Family, ContinuationError> {
    for o in fixed {
        if let Some(p) = params.iter().find(|p| p.name() == o.key().to_string()) {
            return Err(ContinuationError::Input(format!(
                "{}: {} is the continuation parameter, whose values come from its \
                 range; drop the {}",
                crate::words::set_item(&excerpt(&o.to_string())),
                p.name(),
                crate::words::input("set")
            )));
        }
    }
    let keys = params
        .iter()
        .map(|p| SetKey::parse(p.name()).map_err(|e| ContinuationError::Input(e.to_string())))
        .collect::<Result<Vec<_>, _>>()?;
    // The file with its fixed overrides must be a scenario on its own.
    source
        .scenario(fixed)
        .map_err(|e| ContinuationError::Scene(Box::new(e)))?;
    let scene = ScenarioScene {
        source: source.clone(),
        fixed: fixed.to_vec(),
        keys,
        rtol,
        start: Mutex::new(None),
    };
    Family::new(Arc::new(scene), params)
}

impl Scene for ScenarioScene {
    fn setup(&self, values: &[f64]) -> Result<Setup, ContinuationError> {
        let mut all = self.fixed.clone();
        for (&key, &v) in self.keys.iter().zip(values) {
            all.push(
                Override::from_key(key, v).map_err(|e| ContinuationError::Input(e.to_string()))?,
            );
        }
        let scn = self.source.scenario(&all).map_err(|e| match &e {
            // A value of a free key the file's rules refuse: name the key, not an override.
            ScenarioError::Override { key, message, .. } => {
                match self
                    .keys
                    .iter()
                    .zip(values)
                    .find(|(k, _)| k.to_string() == *key)
                {
                    Some((_, v)) => ContinuationError::Input(format!("{key} = {v:e}: {message}")),
                    None => ContinuationError::Scene(Box::new(e)),
                }
            }
            _ => ContinuationError::Scene(Box::new(e)),
        })?;
        let err = |e: String| ContinuationError::Input(format!("{}: {e}", scn.source_name));
        // Where the vibration starts: the scene's initial state, or where its earlier stages
        // leave it. Earlier stages are run once, at the first value (module doc of
        // `continuation::family`).
        let known = self.start.lock().ok().and_then(|g| *g);
        let base_only = self.keys.iter().all(|k| k.section() == Some("base"));
        let (problem, start) = match (known, scn.rig.base) {
            (Some((start, staged)), Some(b)) if staged || base_only => (
                Problem::new(&scn.rig, scn.solver, b.frequency, b.amplitude)
                    .map_err(|e| err(e.to_string()))?,
                start,
            ),
            _ => {
                let (problem, start) =
                    Problem::from_plan(&scn.plan()).map_err(|e| err(e.to_string()))?;
                if let Ok(mut g) = self.start.lock() {
                    if g.is_none() {
                        *g = Some((start, start != scn.initial));
                    }
                }
                (problem, start)
            }
        };
        let sim = problem
            .simulator(&start, self.rtol)
            .map_err(|e| ContinuationError::Input(format!("{}: {e}", scn.source_name)))?;
        let x_k = sim.drive().xk0;
        Ok(Setup {
            problem,
            x_k,
            start,
        })
    }
}
