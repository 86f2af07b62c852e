//! The one table of scenario keys: every key a scenario file takes, with its unit, default,
//! allowed range and a one-line meaning.
//!
//! Everything that names a scenario key reads this table: the parser's unknown-key checks
//! (`section_keys`), `--set` and sweeps (which keys exist, what their values are), continuation
//! (which keys are constants of a periodic orbit, [`KeyInfo::param`](KeyInfo#structfield.param)),
//! and `djkr keys [--json]`, the generated reference. A key added here is at once accepted in
//! files, settable, and documented; a test checks that the
//! parser accepts exactly these keys (tests/it/scenario_files.rs).
//!
//! Stage keys are spelled `stage[].speed` here (as `djkr keys` prints them); a key of one stage
//! is `stage[N].speed` in messages and `--set`.

use std::sync::OnceLock;

use djkr_core::units::Dimension;

/// Default gravitational acceleration (m/s²) when `sphere.gravity` is absent.
pub(crate) const DEFAULT_GRAVITY: f64 = 9.807;
/// Default safety limit (s) of a stage that ends on a preload or at pull-off.
pub(crate) const DEFAULT_MAX_DURATION: f64 = 1e4;
/// Relative agreement required between a tabulated law's w(0) and `material.w0`.
pub(crate) const TABLE_W0_RTOL: f64 = 1e-6;
/// The end conditions of a stage, of which exactly one is given.
pub(crate) const STAGE_END_KEYS: &[&str] = &["duration", "preload", "until"];

/// What the values of a key are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A number: SI, or a string with a unit of the dimension (`None`: bare numbers only).
    Number(Option<Dimension>),
    /// A whole number (`version`, `solver.max_steps`).
    Whole,
    /// `true` or `false`.
    Bool,
    /// One of a list of names.
    Choice(&'static [&'static str]),
    /// Free text (a file name).
    Text,
    /// A list of `[t0, t1]` windows (s).
    Windows,
}

/// One key of the scenario format.
#[derive(Clone, Copy)]
pub struct KeyInfo {
    /// The section (`""` for the top level, `"stage"` for `[[stage]]`).
    pub section: &'static str,
    /// The key within its section.
    pub name: &'static str,
    /// SI unit as tables write it, `""` when dimensionless or not a number.
    pub unit: &'static str,
    /// What its values are.
    pub kind: Kind,
    /// The value taken when the key is absent, as a TOML literal; `None` when it is required
    /// or derived from other keys (see the description).
    pub default: Option<&'static str>,
    /// The allowed values, as error messages write them (bounds of
    /// `super::checks::UPPER_BOUNDS` and `super::checks::LOWER_BOUNDS` are added by
    /// [`KeyInfo::range`]).
    pub allowed: &'static str,
    /// What it is, in one line.
    pub description: &'static str,
    /// As a continuation parameter (a constant of the periodic orbit): its name in tables and
    /// plots; `None` when the key cannot be continued.
    pub param: Option<&'static str>,
}

impl std::fmt::Debug for KeyInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.key())
    }
}

impl KeyInfo {
    /// The key as `djkr keys` prints it: `version`, `base.amplitude`, `stage[].speed`.
    pub fn key(&self) -> String {
        match self.section {
            "" => self.name.to_string(),
            STAGE => format!("{STAGE}[].{}", self.name),
            s => format!("{s}.{}", self.name),
        }
    }

    /// The allowed range as the error messages write it, with the bounds the model carries.
    pub fn range(&self) -> String {
        let key = if self.section.is_empty() {
            self.name.to_string()
        } else {
            format!("{}.{}", self.section, self.name)
        };
        let lower = super::checks::lower_bound(&key).map(|b| b.0);
        let upper = super::checks::upper_bound(&key).map(|b| b.0);
        match (self.allowed, lower, upper) {
            ("> 0", Some(lo), Some(hi)) => format!("[{lo:e}, {hi:e}]"),
            ("> 0", Some(lo), None) => format!(">= {lo:e}"),
            ("> 0", None, Some(hi)) => format!("(0, {hi:e}]"),
            (">= 0", Some(lo), Some(hi)) => format!("0 or [{lo:e}, {hi:e}]"),
            (">= 0", Some(lo), None) => format!("0 or >= {lo:e}"),
            (">= 0", None, Some(hi)) => format!("[0, {hi:e}]"),
            (r, _, _) => r.to_string(),
        }
    }

    /// Whether the values are numbers (of a dimension, or bare).
    pub fn is_number(&self) -> bool {
        matches!(self.kind, Kind::Number(_) | Kind::Whole)
    }
}

/// The name of the one section that is a list of tables (`[[stage]]`, keys `stage[N].KEY`).
pub(crate) const STAGE_SECTION: &str = "stage";
const STAGE: &str = STAGE_SECTION;

const fn k(
    section: &'static str,
    name: &'static str,
    unit: &'static str,
    kind: Kind,
    default: Option<&'static str>,
    allowed: &'static str,
    description: &'static str,
) -> KeyInfo {
    KeyInfo {
        section,
        name,
        unit,
        kind,
        default,
        allowed,
        description,
        param: None,
    }
}

impl KeyInfo {
    const fn continued(mut self, what: &'static str) -> Self {
        self.param = Some(what);
        self
    }
}

use Dimension as D;

const fn num(d: Dimension) -> Kind {
    Kind::Number(Some(d))
}

const BARE: Kind = Kind::Number(None);

/// Every key of the scenario format, section by section in the order the README lists them.
pub const KEYS: &[KeyInfo] = &[
    k("", "version", "", Kind::Whole, None, "= 1", "scenario format version (required)"),
    k("material", "K", "Pa", num(D::Pressure), None, "> 0", "JKR elastic constant K = 4E*/3 (required)")
        .continued("JKR elastic constant K"),
    k("material", "R", "m", num(D::Length), None, "> 0", "sphere radius R (required)")
        .continued("sphere radius R"),
    k("material", "w0", "J/m^2", num(D::EnergyPerArea), None, "> 0", "quasi-static work of adhesion w0 (required)")
        .continued("work of adhesion w0"),
    k("adhesion", "law", "", Kind::Choice(&djkr_core::adhesion::LAW_NAMES), Some("\"constant\""),
        "\"constant\", \"gent-schultz\", \"gent-schultz-saturated\", \"tabulated\"",
        "rate dependence of the work of adhesion w(v) (required in [adhesion]; absent section: constant w0)"),
    k("adhesion", "v0", "m/s", num(D::Speed), None, "> 0", "Gent-Schultz reference speed v0, C = v0^-n (required by the gent-schultz laws)")
        .continued("Gent-Schultz speed v0"),
    k("adhesion", "n", "", BARE, None, "> 0", "Gent-Schultz exponent n (required by the gent-schultz laws)")
        .continued("Gent-Schultz exponent n"),
    k("adhesion", "v_sat", "m/s", num(D::Speed), None, "> 0", "saturation speed v_sat (required by gent-schultz-saturated)")
        .continued("saturation speed v_sat"),
    k("adhesion", "file", "", Kind::Text, None, "a CSV file of two columns, speed (m/s) and w (J/m^2)",
        "table of w(v) for law = \"tabulated\", relative to the scenario file (required by it)"),
    k("sphere", "mass", "kg", num(D::Mass), None, ">= 0", "sphere mass m, 0 = quasi-static force balance (required unless spring.rigid)")
        .continued("sphere mass m"),
    k("sphere", "gravity", "m/s^2", num(D::Acceleration), Some("9.807"), ">= 0", "gravitational acceleration g")
        .continued("gravity g"),
    k("spring", "stiffness", "N/m", num(D::Stiffness), None, ">= 0", "stiffness k of the holding spring (or rigid = true; absent [spring]: none)")
        .continued("spring stiffness k"),
    k("spring", "rigid", "", Kind::Bool, Some("false"), "true or false", "a rigid link instead of a spring"),
    k("damping", "c", "N s/m", num(D::Damping), None, ">= 0", "viscous damping coefficient c (required in [damping]; absent section: none)")
        .continued("damping coefficient c"),
    k("damping", "on", "", Kind::Choice(&["sphere", "contact"]), Some("\"sphere\""), "\"sphere\", \"contact\"",
        "what the damper acts on: the sphere's speed or the indentation rate"),
    k("base", "amplitude", "m", num(D::Length), None, ">= 0", "base vibration amplitude X_b (required in [base]; absent section: no vibration)")
        .continued("base amplitude X_b"),
    k("base", "frequency", "Hz", num(D::Frequency), None, "[1e-6, 1e6]", "base vibration frequency f (required in [base])")
        .continued("base frequency f"),
    k("base", "phase", "rad", num(D::Angle), Some("0.0"), "[0, 2 pi)", "phase of the base motion when the shaker starts"),
    k("contact", "formation", "", Kind::Choice(&["jump-in", "seed"]), Some("\"jump-in\""), "\"jump-in\", \"seed\"",
        "how the contact forms: at the JKR jump-in radius, or at seed_radius"),
    k("contact", "seed_radius", "m", num(D::Length), None, "> 0, <= the JKR jump-in radius", "contact radius at formation (required by formation = \"seed\")"),
    k("initial", "preload", "N", num(D::Force), None, "> 0", "static preload at the start, JKR equilibrium under it (or gap; without a spring: the weight)")
        .continued("mean load (static preload)"),
    k("initial", "gap", "m", num(D::Length), None, "> 0", "initial gap between sphere and substrate (or preload)"),
    k(STAGE, "kind", "", Kind::Choice(&["approach", "hold", "unload"]), None, "\"approach\", \"hold\", \"unload\"",
        "what the spring end does in this stage (required)"),
    k(STAGE, "speed", "m/s", num(D::Speed), None, "> 0", "spring-end speed (required unless hold: 0)"),
    k(STAGE, "duration", "s", num(D::Time), None, "> 0", "end the stage after this time (one of duration, preload, until)"),
    k(STAGE, "preload", "N", num(D::Force), None, "> 0", "end the stage at this compressive load (approach only)"),
    k(STAGE, "until", "", Kind::Choice(&["pull-off"]), None, "\"pull-off\"", "end the stage at pull-off (unload only)"),
    k(STAGE, "vibration", "", Kind::Bool, None, "true or false", "base vibration on in this stage (absent: as the stage before; off in the first)"),
    k(STAGE, "max_duration", "s", num(D::Time), Some("1e4"), "> 0", "safety limit of a stage that ends on a preload or at pull-off"),
    k("solver", "method", "", Kind::Choice(&djkr_core::dynamics::methods::METHOD_NAMES), Some("\"auto\""),
        "\"auto\", \"dp8\", \"dopri5\", \"dop853\", \"implicit\"", "integrator (auto: embedded while it can, implicit where stiff)"),
    k("solver", "rtol", "", BARE, Some("1e-8"), "[1e-14, 1e-2]", "relative tolerance"),
    k("solver", "atol", "", BARE, Some("1e-10"), "(0, 1]", "absolute tolerance, relative to each state component's natural scale"),
    k("solver", "max_steps", "", Kind::Whole, Some("50000000"), ">= 1", "budget of integration steps (the run stops, status stopped)"),
    k("solver", "max_events", "", Kind::Whole, Some("10000000"), ">= 1", "budget of contact events (the run stops, status stopped)"),
    k("solver", "max_wall_s", "s", num(D::Time), Some("600.0"), "> 0", "budget of wall-clock time of the integration (the run stops, status stopped; writing the files after it is not counted: summary.json stats.write_s)"),
    k("solver", "max_memory", "B", Kind::Whole, Some("2147483648"), ">= 1048576", "budget of memory for the run's records (bytes)"),
    k("solver", "event_tol", "s", num(D::Time), Some("1e-12"), "> 0", "time tolerance of contact events (a warning above 1e-9)"),
    k("solver", "envelope", "", Kind::Choice(&["auto", "off"]), Some("\"auto\""), "\"auto\", \"off\"",
        "envelope following: jump over base periods where the vibration drifts slowly (auto) or never (off)"),
    k("solver", "envelope_tol", "", BARE, Some("1e-6"), "[1e-12, 1e-2]", "local error of an envelope step in the scaled norm"),
    k("output", "sample_rate", "1/s", num(D::Frequency), Some("0"), ">= 0", "time-series samples per second of simulated time (0 = every step)"),
    k("output", "csv", "", Kind::Bool, Some("false"), "true or false", "also write the time series as CSV"),
    k("output", "compress", "", Kind::Bool, Some("false"), "true or false", "shuffle + deflate the HDF5 datasets (smaller files, slower writes)"),
    k("output", "fsync", "", Kind::Bool, Some("false"), "true or false", "fsync every file and the folder before the run counts as written"),
    k("output", "plot", "", Kind::Bool, Some("false"), "true or false", "also draw the run's figure (run.png, run.svg)"),
    k("output", "dense", "s", Kind::Windows, Some("[]"), "a list of [t0, t1] windows with t0 < t1",
        "time windows recorded densely (no envelope jump into or across them)"),
];

/// The sections in the order of [`KEYS`].
pub(crate) const SECTIONS: &[&str] = &[
    "material", "adhesion", "sphere", "spring", "damping", "base", "contact", "initial", STAGE,
    "solver", "output",
];

/// The keys section `name` takes (`""`: the top level), in table order; `None`: no such
/// section.
pub(crate) fn section_keys(name: &str) -> Option<&'static [&'static str]> {
    // Built once: the parser asks for a section's keys at every build (a continuation builds a
    // scenario per period).
    static BY_SECTION: OnceLock<Vec<(&'static str, Vec<&'static str>)>> = OnceLock::new();
    let table = BY_SECTION.get_or_init(|| {
        std::iter::once("")
            .chain(SECTIONS.iter().copied())
            .map(|s| {
                let keys = KEYS.iter().filter(|k| k.section == s).map(|k| k.name);
                (s, keys.collect())
            })
            .collect()
    });
    table
        .iter()
        .find(|(s, _)| *s == name)
        .map(|(_, keys)| keys.as_slice())
}

/// The entry of `section.name` (`section` `""` for the top level).
pub fn find(section: &str, name: &str) -> Option<&'static KeyInfo> {
    KEYS.iter().find(|k| k.section == section && k.name == name)
}

/// The table as JSON (`djkr keys --json`): a list of objects with exactly the fields `key`,
/// `unit`, `default` (the TOML value as JSON, `null` when required or derived), `range` and
/// `description`.
pub(crate) fn to_json() -> serde_json::Value {
    serde_json::Value::Array(
        KEYS.iter()
            .map(|k| {
                serde_json::json!({
                    "key": k.key(),
                    "unit": k.unit,
                    "default": k.default.map(default_json),
                    "range": k.range(),
                    "description": k.description,
                })
            })
            .collect(),
    )
}

/// A TOML literal as JSON (`1e4` → 10000.0, `"auto"` → "auto", `[]` → []).
fn default_json(literal: &str) -> serde_json::Value {
    let table: toml::Table = format!("v = {literal}").parse().unwrap_or_default();
    table
        .get("v")
        .and_then(|v| serde_json::to_value(v).ok())
        .unwrap_or(serde_json::Value::Null)
}

/// The table for a terminal: one key a line, with unit, default, range and meaning.
pub(crate) fn to_text() -> String {
    let rows: Vec<[String; 5]> = KEYS
        .iter()
        .map(|k| {
            [
                k.key(),
                k.unit.to_string(),
                k.default.unwrap_or("-").to_string(),
                k.range(),
                k.description.to_string(),
            ]
        })
        .collect();
    let head = ["key", "unit", "default", "range", "description"];
    let mut w = [0; 4];
    for r in rows
        .iter()
        .map(|r| r.each_ref().map(|c| c.chars().count()))
        .chain([head.map(str::len)])
    {
        for (a, b) in w.iter_mut().zip(r) {
            *a = (*a).max(b);
        }
    }
    let line = |c: [&str; 5]| {
        let mut s = String::new();
        for (i, x) in c.iter().take(4).enumerate() {
            s.push_str(x);
            s.push_str(&" ".repeat(w[i] - x.chars().count() + 2));
        }
        s.push_str(c[4]);
        s.push('\n');
        s
    };
    let mut out = line(head);
    for r in &rows {
        out.push_str(&line(r.each_ref().map(String::as_str)));
    }
    out
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // defaults written exactly, compared exactly
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_values_an_absent_key_takes() {
        let d = |s: &str, n: &str| default_json(find(s, n).and_then(|k| k.default).unwrap());
        let solver = djkr_core::dynamics::Solver::default();
        assert_eq!(d("solver", "rtol"), serde_json::json!(solver.rtol));
        assert_eq!(d("solver", "atol"), serde_json::json!(solver.atol));
        assert_eq!(
            d("solver", "max_steps"),
            serde_json::json!(solver.max_steps)
        );
        assert_eq!(
            d("solver", "max_events"),
            serde_json::json!(solver.max_events)
        );
        assert_eq!(
            d("solver", "max_memory"),
            serde_json::json!(solver.max_memory)
        );
        assert_eq!(
            d("solver", "max_wall_s"),
            serde_json::json!(solver.max_wall_s)
        );
        assert_eq!(
            d("solver", "event_tol"),
            serde_json::json!(solver.event_tol)
        );
        assert_eq!(
            d("solver", "envelope_tol"),
            serde_json::json!(solver.envelope_tol)
        );
        assert_eq!(d("sphere", "gravity"), serde_json::json!(DEFAULT_GRAVITY));
        assert_eq!(
            d("stage", "max_duration"),
            serde_json::json!(super::DEFAULT_MAX_DURATION)
        );
        assert_eq!(d("output", "dense"), serde_json::json!([]));
        assert_eq!(d("adhesion", "law"), serde_json::json!("constant"));
        for key in KEYS {
            if let Some(lit) = key.default {
                assert!(!default_json(lit).is_null(), "{key:?}: {lit}");
            }
        }
    }

    #[test]
    fn continuation_parameters_are_numbers() {
        for key in KEYS {
            if key.param.is_some() {
                assert!(matches!(key.kind, Kind::Number(_)), "{key:?}");
            }
        }
    }
}
