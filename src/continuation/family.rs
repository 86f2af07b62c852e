//! A family of periodic-orbit problems: one scenario file, its fixed `--set` overrides, and one or
//! two scalar keys whose values the continuation chooses.
//!
//! The orbit at parameter value p is the periodic steady state of the scenario with `KEY = p`
//! written in it (`djkr validate FILE --set KEY=p` finds one of them): the scenario is rebuilt
//! from the parsed file with the override ([`ScenarioSource::scenario`], cheap), and its
//! steady-state problem taken as [`Problem::from_plan`] takes it. The spring end x_k is where that
//! plan holds it: the static JKR equilibrium under `initial.preload`, at every value, for a
//! scene that vibrates from its first stage (the bundled resonance scene); for a scene whose
//! vibration starts after earlier stages (approach, dwell), where those stages leave it, run
//! once at the first value (START) and kept. Rerunning them for every value would tie the mean
//! load to the approach's dynamics, which jump: on `scenarios/paper-protocol-400hz.toml` the
//! spring end left by the approach jumps by 2.1 µm at damping.c = 3.1019 N s/m (the approach's
//! preload crossing moves to another oscillation), and no branch can cross that.
//!
//! Only keys that are constants of the periodic problem are parameters ([`PARAMETERS`]): the
//! material, the law's constants, the mechanics, the base motion and the mean load. The others
//! (the protocol's stages, the solver, the output, the version, text and boolean keys) do not
//! change a periodic orbit, and are refused with the list of what is allowed.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use crate::dynamics::protocol::Initial;
use crate::scenario::overrides::{Override, SetKey};
use crate::scenario::parse::{ScenarioError, ScenarioSource};
use crate::steady::{OrbitState, Problem};
use crate::units::Dimension;

use super::ContinuationError;

/// A scenario key that may be a continuation parameter: its key, SI unit (as table headers write
/// it) and the dimension its values are parsed with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParameterInfo {
    /// The dotted key (`base.frequency`).
    pub key: &'static str,
    /// SI unit, `1` when dimensionless (`Hz`).
    pub unit: &'static str,
    /// Dimension for parsing values with units (`--range 340Hz:0.6kHz`).
    pub dimension: Dimension,
    /// What it is, in a few words.
    pub what: &'static str,
}

/// The keys a periodic orbit can be continued in.
pub const PARAMETERS: &[ParameterInfo] = &[
    p(
        "base.frequency",
        "Hz",
        Dimension::Frequency,
        "base frequency f",
    ),
    p(
        "base.amplitude",
        "m",
        Dimension::Length,
        "base amplitude X_b",
    ),
    p(
        "initial.preload",
        "N",
        Dimension::Force,
        "mean load (static preload)",
    ),
    p(
        "damping.c",
        "N s/m",
        Dimension::Damping,
        "damping coefficient c",
    ),
    p(
        "spring.stiffness",
        "N/m",
        Dimension::Stiffness,
        "spring stiffness k",
    ),
    p("sphere.mass", "kg", Dimension::Mass, "sphere mass m"),
    p(
        "sphere.gravity",
        "m/s^2",
        Dimension::Dimensionless,
        "gravity g",
    ),
    p(
        "material.K",
        "Pa",
        Dimension::Pressure,
        "JKR elastic constant K",
    ),
    p("material.R", "m", Dimension::Length, "sphere radius R"),
    p(
        "material.w0",
        "J/m^2",
        Dimension::EnergyPerArea,
        "work of adhesion w0",
    ),
    p(
        "adhesion.v0",
        "m/s",
        Dimension::Speed,
        "Gent-Schultz speed v0",
    ),
    p(
        "adhesion.n",
        "1",
        Dimension::Dimensionless,
        "Gent-Schultz exponent n",
    ),
    p(
        "adhesion.v_sat",
        "m/s",
        Dimension::Speed,
        "saturation speed v_sat",
    ),
];

const fn p(
    key: &'static str,
    unit: &'static str,
    dimension: Dimension,
    what: &'static str,
) -> ParameterInfo {
    ParameterInfo {
        key,
        unit,
        dimension,
        what,
    }
}

/// The allowed keys, comma separated (for messages).
pub fn allowed_keys() -> String {
    PARAMETERS
        .iter()
        .map(|p| p.key)
        .collect::<Vec<_>>()
        .join(", ")
}

/// A continuation parameter: a checked key and what it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Parameter {
    /// The parsed key.
    pub key: SetKey,
    /// Its unit, dimension and description.
    pub info: ParameterInfo,
}

impl Parameter {
    /// Parse a key given as `flag` (for messages), refusing a key that is not a constant of the
    /// periodic problem with the list of those that are.
    pub fn parse(flag: &str, text: &str) -> Result<Parameter, ContinuationError> {
        let key = SetKey::parse(text).map_err(|e| {
            ContinuationError::Input(format!(
                "{flag} {text}: {}; a continuation parameter is one of {}",
                e.message,
                allowed_keys()
            ))
        })?;
        let shown = key.to_string();
        let info = PARAMETERS.iter().find(|p| p.key == shown).ok_or_else(|| {
            ContinuationError::Input(format!(
                "{flag} {text}: not a constant of the periodic orbit (stages, solver, output and \
                 text keys do not change it); a continuation parameter is one of {}",
                allowed_keys()
            ))
        })?;
        Ok(Parameter { key, info: *info })
    }

    /// The key as written (`base.frequency`).
    pub fn name(&self) -> &'static str {
        self.info.key
    }
}

/// The problem at one parameter point: the steady-state problem, where the spring end is held,
/// and where the scene's own start is (for the first orbit).
#[derive(Debug, Clone)]
pub struct Setup {
    /// The steady-state problem (rig, base motion, solver).
    pub problem: Problem,
    /// The spring end x_k (m).
    pub x_k: f64,
    /// The scene's start at this point: its initial state, or where its earlier stages end.
    pub start: Initial,
}

impl Setup {
    /// The base period T = 1/f (s).
    pub fn period(&self) -> f64 {
        1.0 / self.problem.frequency
    }

    /// A consistent state at phase 0 from (x_s, v_s, a) (ȧ from the law; see
    /// [`Problem::consistent`]).
    pub fn state(&self, y: [f64; 3]) -> Option<OrbitState> {
        self.problem.consistent(y[0], y[1], y[2], self.x_k)
    }
}

/// Entries of the setup cache: the last few parameter points (a Newton iteration and its finite
/// differences revisit the same point several times).
const CACHE: usize = 8;

/// One scenario with one or two keys left free (module doc).
#[derive(Debug)]
pub struct Family {
    source: ScenarioSource,
    fixed: Vec<Override>,
    params: Vec<Parameter>,
    rtol: f64,
    cache: Mutex<VecDeque<(Vec<u64>, Arc<Setup>)>>,
    /// Periods integrated through this family and its clones (adaptive and replayed).
    periods: Arc<AtomicU64>,
    /// The scene's start at the first value built, and whether earlier stages made it.
    start: Arc<Mutex<Option<(Initial, bool)>>>,
}

impl Clone for Family {
    fn clone(&self) -> Self {
        Self {
            source: self.source.clone(),
            fixed: self.fixed.clone(),
            params: self.params.clone(),
            rtol: self.rtol,
            cache: Mutex::new(VecDeque::new()),
            periods: self.periods.clone(),
            start: self.start.clone(),
        }
    }
}

impl Family {
    /// The scenario `source` with the overrides `fixed` and the free keys `params` (one or two).
    /// An override of a free key is refused (its values come from the continuation). `rtol` is
    /// the integration tolerance used when earlier stages must run to find the start.
    pub fn new(
        source: ScenarioSource,
        fixed: Vec<Override>,
        params: Vec<Parameter>,
        rtol: f64,
    ) -> Result<Family, ContinuationError> {
        for o in &fixed {
            if let Some(p) = params.iter().find(|p| p.key == o.key()) {
                return Err(ContinuationError::Input(format!(
                    "--set {o}: {} is the continuation parameter, whose values come from its \
                     range; drop the --set",
                    p.name()
                )));
            }
        }
        if params.len() == 2 && params[0].key == params[1].key {
            return Err(ContinuationError::Input(format!(
                "--fold-param {}: must differ from --param",
                params[1].name()
            )));
        }
        Ok(Family {
            source,
            fixed,
            params,
            rtol,
            cache: Mutex::new(VecDeque::new()),
            periods: Arc::new(AtomicU64::new(0)),
            start: Arc::new(Mutex::new(None)),
        })
    }

    /// Periods of the map integrated so far through this family and its clones.
    pub fn periods(&self) -> u64 {
        self.periods.load(Ordering::Relaxed)
    }

    /// Count `k` periods integrated.
    pub fn count(&self, k: u64) {
        self.periods.fetch_add(k, Ordering::Relaxed);
    }

    /// The free keys.
    pub fn params(&self) -> &[Parameter] {
        &self.params
    }

    /// The scenario file's name.
    pub fn source(&self) -> &ScenarioSource {
        &self.source
    }

    /// The fixed overrides.
    pub fn fixed(&self) -> &[Override] {
        &self.fixed
    }

    /// The problem at parameter values `values` (one per free key, SI).
    pub fn setup(&self, values: &[f64]) -> Result<Arc<Setup>, ContinuationError> {
        let bits: Vec<u64> = values.iter().map(|v| v.to_bits()).collect();
        if let Ok(c) = self.cache.lock() {
            if let Some((_, s)) = c.iter().find(|(b, _)| *b == bits) {
                return Ok(s.clone());
            }
        }
        let s = Arc::new(self.build(values)?);
        if let Ok(mut c) = self.cache.lock() {
            if c.len() == CACHE {
                c.pop_front();
            }
            c.push_back((bits, s.clone()));
        }
        Ok(s)
    }

    fn build(&self, values: &[f64]) -> Result<Setup, ContinuationError> {
        let mut overrides = self.fixed.clone();
        for (p, &v) in self.params.iter().zip(values) {
            if !v.is_finite() {
                return Err(ContinuationError::Input(format!(
                    "{} = {v}: must be a finite number ({})",
                    p.name(),
                    p.info.unit
                )));
            }
            let o = Override::from_key(p.key, v)
                .map_err(|e| ContinuationError::Input(e.to_string()))?;
            overrides.push(o);
        }
        let scn = self.source.scenario(&overrides).map_err(|e| match &e {
            // A value of a free key the file's rules refuse: name the key, not an override.
            ScenarioError::Override { key, message, .. } => {
                match self
                    .params
                    .iter()
                    .zip(values)
                    .find(|(p, _)| p.name() == key)
                {
                    Some((_, v)) => ContinuationError::Input(format!("{key} = {v:e}: {message}")),
                    None => ContinuationError::Input(e.to_string()),
                }
            }
            _ => ContinuationError::Input(e.to_string()),
        })?;
        let err = |e: String| ContinuationError::Input(format!("{}: {e}", scn.source_name));
        // Where the vibration starts: the scene's initial state, or where its earlier stages
        // leave it. Earlier stages are run once, at the first value (module doc).
        let known = self.start.lock().ok().and_then(|g| *g);
        let base_only = self.params.iter().all(|p| p.key.section() == Some("base"));
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
