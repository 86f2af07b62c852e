//! The one table of scenario keys: every key a scenario file takes, with its unit, default,
//! allowed range, a one-line meaning, and (for numeric keys) how to read and write it on a parsed
//! [`Scenario`].
//!
//! Everything that names a scenario key reads this table: the parser's unknown-key checks
//! ([`section_keys`]), `--set` and sweeps (which keys exist, what their values are), continuation
//! (which keys are constants of a periodic orbit, [`KeyInfo::param`](KeyInfo#structfield.param)), typed setting of a value
//! on a parsed scenario ([`Scenario::set`](super::Scenario::set)), and `djkr keys [--json]`, the generated reference. A
//! key added here is at once accepted in files, settable, and documented; a test checks that the
//! parser accepts exactly these keys (tests/scenario_files.rs).
//!
//! Stage keys are spelled `stage[].speed` here (as `djkr keys` prints them); a key of one stage
//! is `stage[N].speed` in messages and `--set`.

use super::Scenario;
use djkr_core::dynamics::protocol::{Initial, StageKind, Until};
use djkr_core::rig::{BaseMotion, ContactFormation, Damping, DampingOn, Holder};
use djkr_core::units::Dimension;

/// Default gravitational acceleration (m/s²) when `sphere.gravity` is absent.
pub const DEFAULT_GRAVITY: f64 = 9.807;
/// Default safety limit (s) of a stage that ends on a preload or at pull-off.
pub const DEFAULT_MAX_DURATION: f64 = 1e4;
/// Relative agreement required between a tabulated law's w(0) and `material.w0`.
pub const TABLE_W0_RTOL: f64 = 1e-6;
/// The end conditions of a stage, of which exactly one is given.
pub const STAGE_END_KEYS: &[&str] = &["duration", "preload", "until"];

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

/// Reads a numeric key of a parsed scenario (`usize`: the stage index of a stage key); `None`
/// when the scenario does not have it (no `[base]`, a law without `v0`).
pub type Get = fn(&Scenario, usize) -> Option<f64>;

/// Writes a numeric key on a parsed scenario, as the parser would have read the value had the
/// file given it (the law rebuilt for `material.w0`, a stage's end condition replaced); the
/// range checks come after ([`Scenario::set`](super::Scenario::set)). `Err`: the scenario's structure does not take the
/// key (a key of a section the file does not have, a key of another law), as the parser's
/// message for the file with the key written in it.
pub type Put = fn(&mut Scenario, usize, f64) -> Result<(), Refused>;

/// Why a key cannot be written on a scenario: the key the parser would name, and its message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refused {
    /// The dotted key (or section, `[spring]`) the message is about.
    pub key: String,
    /// What is wrong and what is expected.
    pub message: String,
    /// A value error (the value shown before the message) rather than a key error.
    pub value: Option<String>,
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
    /// [`super::checks::UPPER_BOUNDS`] and [`super::checks::LOWER_BOUNDS`] are added by
    /// [`KeyInfo::range`]).
    pub allowed: &'static str,
    /// What it is, in one line.
    pub description: &'static str,
    /// As a continuation parameter (a constant of the periodic orbit): its name in tables and
    /// plots; `None` when the key cannot be continued.
    pub param: Option<&'static str>,
    /// Read it on a parsed scenario (numeric keys).
    pub get: Option<Get>,
    /// Write it on a parsed scenario (numeric keys).
    pub put: Option<Put>,
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
pub const STAGE_SECTION: &str = "stage";
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
        get: None,
        put: None,
    }
}

impl KeyInfo {
    const fn access(mut self, get: Get, put: Put) -> Self {
        self.get = Some(get);
        self.put = Some(put);
        self
    }

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

fn refused(key: &str, message: impl Into<String>) -> Refused {
    Refused {
        key: key.to_string(),
        message: message.into(),
        value: None,
    }
}

/// The law rebuilt with the material's `w0` (a law carries its own copy).
fn rebuild_law(s: &mut Scenario) -> Result<(), Refused> {
    use djkr_core::adhesion::{ConstantW, GentSchultz, Law, SaturatedGentSchultz};
    let w0 = s.rig.material.w0;
    let param = |e: djkr_core::error::ParamError| Refused {
        key: format!("adhesion.{}", e.name),
        message: e.allowed,
        value: Some(e.value),
    };
    s.rig.law = match &s.rig.law {
        Law::Constant(_) => Law::Constant(ConstantW { w0 }),
        Law::GentSchultz(g) => Law::GentSchultz(GentSchultz::new(w0, g.v0, g.n).map_err(param)?),
        Law::Saturated(g) => Law::Saturated(
            SaturatedGentSchultz::new(w0, g.base.v0, g.base.n, g.v_sat).map_err(param)?,
        ),
        Law::Tabulated(t) => {
            let w_table = djkr_core::adhesion::AdhesionLaw::w0(t);
            let rtol = TABLE_W0_RTOL;
            if (w_table - w0).abs() > rtol * w0 {
                return Err(Refused {
                    key: "adhesion.file".into(),
                    message: format!(
                        "the table gives w(0) = {w_table} J/m^2 but material.w0 = {w0}; they must agree (to {rtol:e} relative)"
                    ),
                    value: Some("(the table)".into()),
                });
            }
            Law::Tabulated(t.clone())
        }
    };
    Ok(())
}

/// Write a Gent–Schultz constant (`v0`, `n`, `v_sat`) of the scenario's law, refusing a law
/// that does not take it as the parser does.
fn put_law(s: &mut Scenario, name: &str, v: f64) -> Result<(), Refused> {
    use djkr_core::adhesion::{GentSchultz, Law, SaturatedGentSchultz};
    let param = |e: djkr_core::error::ParamError| Refused {
        key: format!("adhesion.{}", e.name),
        message: e.allowed,
        value: Some(e.value),
    };
    let w0 = s.rig.material.w0;
    let (law_name, allowed) = match &s.rig.law {
        Law::GentSchultz(g) if name != "v_sat" => {
            let (v0, n) = if name == "v0" { (v, g.n) } else { (g.v0, v) };
            s.rig.law = Law::GentSchultz(GentSchultz::new(w0, v0, n).map_err(param)?);
            return Ok(());
        }
        Law::Saturated(g) => {
            let (mut v0, mut n, mut v_sat) = (g.base.v0, g.base.n, g.v_sat);
            match name {
                "v0" => v0 = v,
                "n" => n = v,
                _ => v_sat = v,
            }
            s.rig.law = Law::Saturated(SaturatedGentSchultz::new(w0, v0, n, v_sat).map_err(param)?);
            return Ok(());
        }
        Law::GentSchultz(_) => ("gent-schultz", "law, v0, n"),
        Law::Constant(_) => ("constant", "law"),
        Law::Tabulated(_) => ("tabulated", "law, file"),
    };
    Err(refused(
        &format!("adhesion.{name}"),
        format!("unknown key for law = \"{law_name}\"; allowed here: {allowed}"),
    ))
}

fn base<'s>(s: &'s mut Scenario, name: &str) -> Result<&'s mut BaseMotion, Refused> {
    let missing = if name == "frequency" {
        ("base.amplitude", "missing: base amplitude X_b (m, >= 0)")
    } else if name == "amplitude" {
        ("base.frequency", "missing: base frequency f (Hz, > 0)")
    } else {
        ("base.amplitude", "missing: base amplitude X_b (m, >= 0)")
    };
    s.rig
        .base
        .as_mut()
        .ok_or_else(|| refused(missing.0, missing.1))
}

fn has_spring_force(h: Holder) -> bool {
    match h {
        Holder::None => false,
        Holder::Spring { stiffness } => stiffness > 0.0,
        Holder::Rigid => true,
    }
}

/// The sphere's weight carries the start when no spring can: keep the derived preload.
fn put_sphere(s: &mut Scenario, mass: Option<f64>, gravity: Option<f64>) {
    let old = s.rig.sphere.mass * s.rig.sphere.gravity;
    if let Some(m) = mass {
        s.rig.sphere.mass = m;
    }
    if let Some(g) = gravity {
        s.rig.sphere.gravity = g;
    }
    if !has_spring_force(s.rig.holder) && s.initial == Initial::Preload(old) {
        s.initial = Initial::Preload(s.rig.sphere.mass * s.rig.sphere.gravity);
    }
}

fn kind_name(k: StageKind) -> &'static str {
    match k {
        StageKind::Approach => "approach",
        StageKind::Hold => "hold",
        StageKind::Unload => "unload",
    }
}

fn whole(v: f64, min: u64, key: &str, allowed: &str) -> Result<u64, Refused> {
    if v.is_finite() && v >= min as f64 && v.fract() == 0.0 && v <= 9.0e15 {
        Ok(v as u64)
    } else {
        Err(Refused {
            key: key.to_string(),
            message: allowed.to_string(),
            value: Some(super::error::show_float(v)),
        })
    }
}

const MAX_STEPS_ALLOWED: &str = "must be a whole number >= 1 (steps)";
const MAX_EVENTS_ALLOWED: &str = "must be a whole number >= 1 (contact events)";
const MAX_MEMORY_ALLOWED: &str =
    "must be a whole number of bytes >= 1048576 (1 MiB; default 2147483648 = 2 GiB)";

/// Every key of the scenario format, section by section in the order the README lists them.
pub const KEYS: &[KeyInfo] = &[
    k("", "version", "", Kind::Whole, None, "= 1", "scenario format version (required)"),
    k("material", "K", "Pa", num(D::Pressure), None, "> 0", "JKR elastic constant K = 4E*/3 (required)")
        .continued("JKR elastic constant K")
        .access(|s, _| Some(s.rig.material.k), |s, _, v| {
            s.rig.material.k = v;
            Ok(())
        }),
    k("material", "R", "m", num(D::Length), None, "> 0", "sphere radius R (required)")
        .continued("sphere radius R")
        .access(|s, _| Some(s.rig.material.r), |s, _, v| {
            s.rig.material.r = v;
            Ok(())
        }),
    k("material", "w0", "J/m^2", num(D::EnergyPerArea), None, "> 0", "quasi-static work of adhesion w0 (required)")
        .continued("work of adhesion w0")
        .access(|s, _| Some(s.rig.material.w0), |s, _, v| {
            s.rig.material.w0 = v;
            rebuild_law(s)
        }),
    k("adhesion", "law", "", Kind::Choice(&djkr_core::adhesion::LAW_NAMES), Some("\"constant\""),
        "\"constant\", \"gent-schultz\", \"gent-schultz-saturated\", \"tabulated\"",
        "rate dependence of the work of adhesion w(v) (required in [adhesion]; absent section: constant w0)"),
    k("adhesion", "v0", "m/s", num(D::Speed), None, "> 0", "Gent-Schultz reference speed v0, C = v0^-n (required by the gent-schultz laws)")
        .continued("Gent-Schultz speed v0")
        .access(|s, _| law_constant(s, "v0"), |s, _, v| put_law(s, "v0", v)),
    k("adhesion", "n", "", BARE, None, "> 0", "Gent-Schultz exponent n (required by the gent-schultz laws)")
        .continued("Gent-Schultz exponent n")
        .access(|s, _| law_constant(s, "n"), |s, _, v| put_law(s, "n", v)),
    k("adhesion", "v_sat", "m/s", num(D::Speed), None, "> 0", "saturation speed v_sat (required by gent-schultz-saturated)")
        .continued("saturation speed v_sat")
        .access(|s, _| law_constant(s, "v_sat"), |s, _, v| put_law(s, "v_sat", v)),
    k("adhesion", "file", "", Kind::Text, None, "a CSV file of two columns, speed (m/s) and w (J/m^2)",
        "table of w(v) for law = \"tabulated\", relative to the scenario file (required by it)"),
    k("sphere", "mass", "kg", num(D::Mass), None, ">= 0", "sphere mass m, 0 = quasi-static force balance (required unless spring.rigid)")
        .continued("sphere mass m")
        .access(|s, _| Some(s.rig.sphere.mass), |s, _, v| {
            put_sphere(s, Some(v), None);
            Ok(())
        }),
    k("sphere", "gravity", "m/s^2", num(D::Acceleration), Some("9.807"), ">= 0", "gravitational acceleration g")
        .continued("gravity g")
        .access(|s, _| Some(s.rig.sphere.gravity), |s, _, v| {
            put_sphere(s, None, Some(v));
            Ok(())
        }),
    k("spring", "stiffness", "N/m", num(D::Stiffness), None, ">= 0", "stiffness k of the holding spring (or rigid = true; absent [spring]: none)")
        .continued("spring stiffness k")
        .access(|s, _| match s.rig.holder {
            Holder::Spring { stiffness } => Some(stiffness),
            _ => None,
        }, |s, _, v| match s.rig.holder {
            Holder::Rigid => Err(refused("[spring]", "give either stiffness (N/m) or rigid = true, not both")),
            _ => {
                s.rig.holder = Holder::Spring { stiffness: v };
                Ok(())
            }
        }),
    k("spring", "rigid", "", Kind::Bool, Some("false"), "true or false", "a rigid link instead of a spring"),
    k("damping", "c", "N s/m", num(D::Damping), None, ">= 0", "viscous damping coefficient c (required in [damping]; absent section: none)")
        .continued("damping coefficient c")
        .access(|s, _| s.rig.damping.map(|d| d.c), |s, _, v| {
            let on = s.rig.damping.map_or(DampingOn::Sphere, |d| d.on);
            s.rig.damping = Some(Damping { c: v, on });
            Ok(())
        }),
    k("damping", "on", "", Kind::Choice(&["sphere", "contact"]), Some("\"sphere\""), "\"sphere\", \"contact\"",
        "what the damper acts on: the sphere's speed or the indentation rate"),
    k("base", "amplitude", "m", num(D::Length), None, ">= 0", "base vibration amplitude X_b (required in [base]; absent section: no vibration)")
        .continued("base amplitude X_b")
        .access(|s, _| s.rig.base.map(|b| b.amplitude), |s, _, v| {
            base(s, "amplitude")?.amplitude = v;
            Ok(())
        }),
    k("base", "frequency", "Hz", num(D::Frequency), None, "[1e-6, 1e6]", "base vibration frequency f (required in [base])")
        .continued("base frequency f")
        .access(|s, _| s.rig.base.map(|b| b.frequency), |s, _, v| {
            base(s, "frequency")?.frequency = v;
            Ok(())
        }),
    k("base", "phase", "rad", num(D::Angle), Some("0.0"), "[0, 2 pi)", "phase of the base motion when the shaker starts")
        .access(|s, _| s.rig.base.map(|b| b.phase), |s, _, v| {
            base(s, "phase")?.phase = v;
            Ok(())
        }),
    k("contact", "formation", "", Kind::Choice(&["jump-in", "seed"]), Some("\"jump-in\""), "\"jump-in\", \"seed\"",
        "how the contact forms: at the JKR jump-in radius, or at seed_radius"),
    k("contact", "seed_radius", "m", num(D::Length), None, "> 0, <= the JKR jump-in radius", "contact radius at formation (required by formation = \"seed\")")
        .access(|s, _| match s.rig.formation {
            ContactFormation::Seed(r) => Some(r),
            ContactFormation::JumpIn => None,
        }, |s, _, v| match s.rig.formation {
            ContactFormation::Seed(_) => {
                s.rig.formation = ContactFormation::Seed(v);
                Ok(())
            }
            ContactFormation::JumpIn => Err(refused("contact.seed_radius",
                "only used with formation = \"seed\" (the default \"jump-in\" forms the contact at the JKR jump-in radius)")),
        }),
    k("initial", "preload", "N", num(D::Force), None, "> 0", "static preload at the start, JKR equilibrium under it (or gap; without a spring: the weight)")
        .continued("mean load (static preload)")
        .access(|s, _| match s.initial {
            Initial::Preload(p) => Some(p),
            _ => None,
        }, |s, _, v| match s.initial {
            Initial::Preload(_) => {
                s.initial = Initial::Preload(v);
                Ok(())
            }
            _ => Err(refused("[initial]", "give either preload (N) or gap (m), not both")),
        }),
    k("initial", "gap", "m", num(D::Length), None, "> 0", "initial gap between sphere and substrate (or preload)")
        .access(|s, _| match s.initial {
            Initial::Gap(g) => Some(g),
            _ => None,
        }, |s, _, v| match s.initial {
            Initial::Gap(_) => {
                s.initial = Initial::Gap(v);
                Ok(())
            }
            _ => Err(refused("[initial]", "give either preload (N) or gap (m), not both")),
        }),
    k(STAGE, "kind", "", Kind::Choice(&["approach", "hold", "unload"]), None, "\"approach\", \"hold\", \"unload\"",
        "what the spring end does in this stage (required)"),
    k(STAGE, "speed", "m/s", num(D::Speed), None, "> 0", "spring-end speed (required unless hold: 0)")
        .access(|s, i| Some(s.stages[i].speed), |s, i, v| {
            s.stages[i].speed = v;
            Ok(())
        }),
    k(STAGE, "duration", "s", num(D::Time), None, "> 0", "end the stage after this time (one of duration, preload, until)")
        .access(|s, i| match s.stages[i].until {
            Until::Duration(d) => Some(d),
            _ => None,
        }, |s, i, v| {
            let st = &mut s.stages[i];
            st.until = Until::Duration(v);
            st.max_duration = v;
            Ok(())
        }),
    k(STAGE, "preload", "N", num(D::Force), None, "> 0", "end the stage at this compressive load (approach only)")
        .access(|s, i| match s.stages[i].until {
            Until::Preload(p) => Some(p),
            _ => None,
        }, |s, i, v| {
            let st = &mut s.stages[i];
            if st.kind != StageKind::Approach {
                return Err(refused(&format!("stage[{i}].preload"), format!(
                    "a preload end is for approach stages only (this is kind = \"{}\"); use duration or until = \"pull-off\"",
                    kind_name(st.kind)
                )));
            }
            if let Until::Duration(_) = st.until {
                st.max_duration = DEFAULT_MAX_DURATION;
            }
            st.until = Until::Preload(v);
            Ok(())
        }),
    k(STAGE, "until", "", Kind::Choice(&["pull-off"]), None, "\"pull-off\"", "end the stage at pull-off (unload only)"),
    k(STAGE, "vibration", "", Kind::Bool, None, "true or false", "base vibration on in this stage (absent: as the stage before; off in the first)"),
    k(STAGE, "max_duration", "s", num(D::Time), Some("1e4"), "> 0", "safety limit of a stage that ends on a preload or at pull-off")
        .access(|s, i| Some(s.stages[i].max_duration), |s, i, v| {
            let st = &mut s.stages[i];
            if let Until::Duration(_) = st.until {
                return Err(refused(&format!("stage[{i}].max_duration"),
                    "only for stages that end on a preload or at pull-off (a duration end is its own limit)"));
            }
            st.max_duration = v;
            Ok(())
        }),
    k("solver", "method", "", Kind::Choice(&djkr_core::dynamics::methods::METHOD_NAMES), Some("\"auto\""),
        "\"auto\", \"dp8\", \"dopri5\", \"dop853\", \"implicit\"", "integrator (auto: embedded while it can, implicit where stiff)"),
    k("solver", "rtol", "", BARE, Some("1e-8"), "[1e-14, 1e-2]", "relative tolerance")
        .access(|s, _| Some(s.solver.rtol), |s, _, v| {
            s.solver.rtol = v;
            Ok(())
        }),
    k("solver", "atol", "", BARE, Some("1e-10"), "(0, 1]", "absolute tolerance, relative to each state component's natural scale")
        .access(|s, _| Some(s.solver.atol), |s, _, v| {
            s.solver.atol = v;
            Ok(())
        }),
    k("solver", "max_steps", "", Kind::Whole, Some("50000000"), ">= 1", "budget of integration steps (the run stops, status stopped)")
        .access(|s, _| Some(s.solver.max_steps as f64), |s, _, v| {
            s.solver.max_steps = whole(v, 1, "solver.max_steps", MAX_STEPS_ALLOWED)?;
            Ok(())
        }),
    k("solver", "max_events", "", Kind::Whole, Some("10000000"), ">= 1", "budget of contact events (the run stops, status stopped)")
        .access(|s, _| Some(s.solver.max_events as f64), |s, _, v| {
            s.solver.max_events = whole(v, 1, "solver.max_events", MAX_EVENTS_ALLOWED)?;
            Ok(())
        }),
    k("solver", "max_wall_s", "s", num(D::Time), Some("600.0"), "> 0", "budget of wall-clock time of the integration (the run stops, status stopped; writing the files after it is not counted: summary.json stats.write_s)")
        .access(|s, _| Some(s.solver.max_wall_s), |s, _, v| {
            s.solver.max_wall_s = v;
            Ok(())
        }),
    k("solver", "max_memory", "B", Kind::Whole, Some("2147483648"), ">= 1048576", "budget of memory for the run's records (bytes)")
        .access(|s, _| Some(s.solver.max_memory as f64), |s, _, v| {
            s.solver.max_memory = whole(v, djkr_core::dynamics::methods::MIN_MAX_MEMORY, "solver.max_memory", MAX_MEMORY_ALLOWED)?;
            Ok(())
        }),
    k("solver", "event_tol", "s", num(D::Time), Some("1e-12"), "> 0", "time tolerance of contact events (a warning above 1e-9)")
        .access(|s, _| Some(s.solver.event_tol), |s, _, v| {
            s.solver.event_tol = v;
            Ok(())
        }),
    k("solver", "envelope", "", Kind::Choice(&["auto", "off"]), Some("\"auto\""), "\"auto\", \"off\"",
        "envelope following: jump over base periods where the vibration drifts slowly (auto) or never (off)"),
    k("solver", "envelope_tol", "", BARE, Some("1e-6"), "[1e-12, 1e-2]", "local error of an envelope step in the scaled norm")
        .access(|s, _| Some(s.solver.envelope_tol), |s, _, v| {
            s.solver.envelope_tol = v;
            Ok(())
        }),
    k("output", "sample_rate", "1/s", num(D::Frequency), Some("0"), ">= 0", "time-series samples per second of simulated time (0 = every step)")
        .access(|s, _| Some(s.output.sample_rate), |s, _, v| {
            s.output.sample_rate = v;
            Ok(())
        }),
    k("output", "csv", "", Kind::Bool, Some("false"), "true or false", "also write the time series as CSV"),
    k("output", "compress", "", Kind::Bool, Some("false"), "true or false", "shuffle + deflate the HDF5 datasets (smaller files, slower writes)"),
    k("output", "fsync", "", Kind::Bool, Some("false"), "true or false", "fsync every file and the folder before the run counts as written"),
    k("output", "plot", "", Kind::Bool, Some("false"), "true or false", "also draw the run's figure (run.png, run.svg)"),
    k("output", "dense", "s", Kind::Windows, Some("[]"), "a list of [t0, t1] windows with t0 < t1",
        "time windows recorded densely (no envelope jump into or across them)"),
];

fn law_constant(s: &Scenario, name: &str) -> Option<f64> {
    use djkr_core::adhesion::Law;
    match (&s.rig.law, name) {
        (Law::GentSchultz(g), "v0") => Some(g.v0),
        (Law::GentSchultz(g), "n") => Some(g.n),
        (Law::Saturated(g), "v0") => Some(g.base.v0),
        (Law::Saturated(g), "n") => Some(g.base.n),
        (Law::Saturated(g), "v_sat") => Some(g.v_sat),
        _ => None,
    }
}

/// The sections in the order of [`KEYS`].
pub const SECTIONS: &[&str] = &[
    "material", "adhesion", "sphere", "spring", "damping", "base", "contact", "initial", STAGE,
    "solver", "output",
];

/// The keys section `name` takes (`""`: the top level), in table order; `None`: no such
/// section.
pub fn section_keys(name: &str) -> Option<Vec<&'static str>> {
    if !name.is_empty() && !SECTIONS.contains(&name) {
        return None;
    }
    Some(
        KEYS.iter()
            .filter(|k| k.section == name)
            .map(|k| k.name)
            .collect(),
    )
}

/// The entry of `section.name` (`section` `""` for the top level).
pub fn find(section: &str, name: &str) -> Option<&'static KeyInfo> {
    KEYS.iter().find(|k| k.section == section && k.name == name)
}

/// The table as JSON (`djkr keys --json`): a list of objects with exactly the fields `key`,
/// `unit`, `default` (the TOML value as JSON, `null` when required or derived), `range` and
/// `description`.
pub fn to_json() -> serde_json::Value {
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
pub fn to_text() -> String {
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
    fn numeric_keys_are_readable_and_text_keys_are_not() {
        for key in KEYS {
            let numeric = key.is_number() && key.name != "version";
            assert_eq!(key.get.is_some(), numeric, "{key:?}");
            assert_eq!(key.put.is_some(), numeric, "{key:?}");
            if key.param.is_some() {
                assert!(matches!(key.kind, Kind::Number(_)), "{key:?}");
            }
        }
    }
}
