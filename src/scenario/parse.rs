//! TOML parsing and validation of scenario files.
//!
//! The file is first parsed into a generic TOML table (syntax errors carry the line and column
//! TOML reports), then walked section by section. Overrides (`--set KEY=VALUE`,
//! [`super::overrides`]) are written into that table between the two steps, so they meet the
//! same checks; [`ScenarioSource`] keeps the parsed table for many override sets. Walking the table by hand, rather than through
//! `#[serde(deny_unknown_fields)]` structs, is what lets every error name the file, the dotted key
//! (`stage[2].speed`, `material.K`), the value as written and the allowed range with its unit:
//! serde's messages know the field name but not the section path or the range.
//!
//! "> 0" means a finite, normal (not subnormal) positive number throughout.
//!
//! Physical quantities are bare numbers in SI, or strings with a unit (`R = "51mm"`,
//! `frequency = "0.3kHz"`) parsed by [`djkr_core::units::parse_quantity`]. Integers are accepted
//! wherever a number is (`stiffness = 200`).
//!
//! The key names are a contract (docs/guide/scenarios.md and the generated
//! docs/guide/scenario-reference.md). Every key, with its unit, default,
//! allowed range and meaning, is in the one table of keys, [`keys::KEYS`], which the parser's
//! unknown-key checks read and `djkr keys [--json]` prints (this module's doc no longer copies
//! it, so it cannot fall behind).

use std::fmt::Display;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use toml::{Table, Value};

use super::checks;
pub use super::error::ScenarioError;
pub(crate) use super::error::{show, show_float};
use super::keys::{self, STAGE_END_KEYS, STAGE_SECTION};
pub(crate) use super::keys::{DEFAULT_GRAVITY, DEFAULT_MAX_DURATION, TABLE_W0_RTOL};
use super::overrides::{self, Override, SetKey};
use super::{
    BaseMotion, ContactFormation, Damping, DampingOn, Holder, Initial, Method, Output, Rig,
    Scenario, Solver, Sphere, Stage, StageKind, Until,
};
use crate::input::{self, InputKind};
use crate::words::Source;
use djkr_core::adhesion::LAW_NAMES;
use djkr_core::adhesion::{
    AdhesionLaw, ConstantW, GentSchultz, Law, SaturatedGentSchultz, TabulatedLaw,
};
use djkr_core::dynamics::methods::{method_from_name, method_names, EnvelopeMode};
use djkr_core::error::ParamError;
use djkr_core::jkr;
use djkr_core::material::Material;
use djkr_core::units::{parse_quantity, Dimension};

/// The scenario-file format version this parser reads.
pub(crate) const SCENARIO_VERSION: i64 = 1;
/// Largest allowed relative tolerance `solver.rtol`.
pub(crate) const MAX_RTOL: f64 = 1e-2;
/// Smallest allowed relative tolerance `solver.rtol` (a few ulps: tighter is rounding noise).
pub(crate) const MIN_RTOL: f64 = 1e-14;

type Result<T> = std::result::Result<T, ScenarioError>;

/// Parse and validate a scenario from its text. `source_name` names it in errors (usually the
/// path); `base_dir` is where a tabulated law's `file` is looked up when relative (`None`: the
/// current directory).
pub fn parse_scenario(text: &str, source_name: &str, base_dir: Option<&Path>) -> Result<Scenario> {
    ScenarioSource::parse(text, source_name, base_dir)?.scenario(&[])
}

/// Read, parse and validate a scenario file. A tabulated law's `file` is resolved relative to
/// the scenario file's directory.
pub fn load_scenario(path: &Path) -> Result<Scenario> {
    ScenarioSource::read(path)?.scenario(&[])
}

/// [`load_scenario`] with overrides applied (`djkr run FILE --set KEY=VALUE`): the result is that
/// of the file with the overridden keys edited in it.
pub fn load_scenario_with(path: &Path, overrides: &[Override]) -> Result<Scenario> {
    ScenarioSource::read(path)?.scenario(overrides)
}

/// A scenario file read and parsed (TOML syntax only) once, to be validated with any number of
/// override sets: each [`scenario`](Self::scenario) call works on the parsed table, not the file
/// (a sweep applies thousands of override sets to one file), and one that sets the same keys as
/// the call before re-reads only the sections whose values changed.
#[derive(Debug, Clone)]
pub struct ScenarioSource {
    /// Shared with every scenario built (a continuation builds one per period).
    text: Arc<str>,
    name: String,
    base_dir: Option<PathBuf>,
    table: Table,
    tables: LawTables,
    memo: Arc<Mutex<Option<Memo>>>,
}

/// The last scenario built with overrides from a [`ScenarioSource`] (and its clones): the
/// overrides, the table they were applied to, and the parsed sections. When the next build sets
/// the same keys (a continuation sets its free keys every period, a sweep its axes every point),
/// the overrides are applied to this table instead of a fresh copy of the file's (the same
/// keys, so the same table but for their values), and a section none of whose keys changed
/// value is taken from here instead of parsed again: each section's parse is a function of its
/// own table and of the sections [`build`] passes it. The checks across sections run every
/// time. Building the whole scenario each period had become a third of a continuation's time.
#[derive(Debug)]
struct Memo {
    set: Vec<(SetKey, Value)>,
    table: Table,
    parts: Parts,
}

/// A scenario's parsed sections.
#[derive(Debug)]
struct Parts {
    rig: Rig,
    initial: Initial,
    stages: Vec<Stage>,
    solver: Solver,
    output: Output,
}

/// The sections of the last build ([`Memo`]), with the sections whose keys changed value since.
struct Last {
    parts: Parts,
    changed: Vec<&'static str>,
}

impl Last {
    /// The last build's sections, if none of the sections `names` changed.
    fn unless(&self, names: &[&str]) -> Option<&Parts> {
        (!names.iter().any(|n| self.changed.contains(n))).then_some(&self.parts)
    }
}

/// `a == b`, but numbers compared bit for bit (`-0.0` is not `0.0`, a NaN is itself).
fn same_value(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Float(x), Value::Float(y)) => x.to_bits() == y.to_bits(),
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(a, b)| same_value(a, b))
        }
        (Value::Table(x), Value::Table(y)) => {
            x.len() == y.len()
                && x.iter()
                    .zip(y)
                    .all(|((ka, a), (kb, b))| ka == kb && same_value(a, b))
        }
        _ => a == b,
    }
}

impl ScenarioSource {
    /// Read a scenario file and parse its TOML. A tabulated law's `file` is resolved relative to
    /// the scenario file's directory.
    pub fn read(path: &Path) -> Result<Self> {
        let name = path.display().to_string();
        let text = read_text(path, &name)?;
        Self::parse(&text, &name, Some(&parent_dir(path)))
    }

    /// Parse a scenario's TOML from its text (`source_name` and `base_dir` as in
    /// [`parse_scenario`]). Only the syntax is checked here.
    pub fn parse(text: &str, source_name: &str, base_dir: Option<&Path>) -> Result<Self> {
        let table = Parser {
            source: &Source::file(source_name),
            tables: None,
        }
        .parse_toml(text)?;
        Ok(Self {
            text: text.into(),
            name: source_name.to_string(),
            base_dir: base_dir.map(Path::to_path_buf),
            table,
            tables: LawTables::default(),
            memo: Arc::default(),
        })
    }

    /// A scenario given as a tree of values (a Python dict, a parsed JSON document) with the
    /// structure of a scenario file, validated as the file's table would be. `source_name` names
    /// it in errors (`<dict>`); `base_dir` as in [`parse_scenario`]. Its [`text`](Self::text),
    /// the record runs and sweeps keep, is the tree written as a scenario file, held to the size
    /// limit of one ([`InputKind::Scenario`]). A key given twice in a table is refused.
    pub fn from_tree(
        top: Vec<(String, Tree)>,
        source_name: &str,
        base_dir: Option<&Path>,
    ) -> Result<Self> {
        let source = Source::file(source_name);
        let table = tree_table(top, "", 0, &source)?;
        let text = toml::to_string(&table).map_err(|e| ScenarioError::Syntax {
            source: source.clone(),
            line: 1,
            column: 1,
            message: format!("cannot be written as a scenario file: {e}"),
        })?;
        if text.len() as u64 > InputKind::Scenario.limit() {
            return Err(ScenarioError::Io {
                source,
                cause: input::InputError::too_large(InputKind::Scenario),
            });
        }
        Ok(Self {
            text: text.into(),
            name: source_name.to_string(),
            base_dir: base_dir.map(Path::to_path_buf),
            table,
            tables: LawTables::default(),
            memo: Arc::default(),
        })
    }

    /// Only the `[material]` and `[adhesion]` sections, as [`material_and_law`] reads them.
    pub fn material_and_law(&self) -> Result<(Material, Law)> {
        let source = Source::file(&self.name);
        let p = Parser {
            source: &source,
            tables: None,
        };
        p.material_and_law(&self.table, self.base_dir.as_deref())
    }

    /// The name errors give the file (usually its path).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The file's text.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Where a tabulated law's relative `file` is looked up (the scenario file's folder; `None`
    /// for a text without a file: the working directory).
    pub fn base_dir(&self) -> Option<&Path> {
        self.base_dir.as_deref()
    }

    /// Validate the scenario with `overrides` applied to the file's table before the section
    /// walk, so each override is range-checked as the file's own value would be. An error about
    /// an overridden key names the override ([`ScenarioError::Override`]); other errors name
    /// the file and its overrides (`FILE --set K=V: key: ...`), which is also the scenario's
    /// `source_name`.
    pub fn scenario(&self, overrides: &[Override]) -> Result<Scenario> {
        let base_dir = self.base_dir.as_deref();
        let file = Source::file(&self.name);
        if overrides.is_empty() {
            return build(&self.table, &self.text, file, base_dir, &self.tables, None);
        }
        // Another thread building from the same source meanwhile builds without the memo.
        let mut slot = self.memo.try_lock().ok();
        let same_keys = |m: &mut Memo| {
            m.set.len() == overrides.len()
                && m.set.iter().zip(overrides).all(|((k, _), o)| *k == o.key())
        };
        let memo = slot
            .as_deref_mut()
            .and_then(|m| m.take_if(|m| same_keys(m)));
        let (mut table, last) = match memo {
            Some(Memo { set, table, parts }) => {
                let changed = set
                    .iter()
                    .zip(overrides)
                    .filter(|((_, was), o)| !same_value(was, o.value()))
                    .map(|((key, _), _)| key.section().unwrap_or(""))
                    .collect();
                (table, Some(Last { parts, changed }))
            }
            None => (self.table.clone(), None),
        };
        overrides::apply(&mut table, overrides, &file)?;
        let source = Source {
            file: self.name.clone(),
            set: overrides.iter().map(ToString::to_string).collect(),
        };
        let scn = build(
            &table,
            &self.text,
            source,
            base_dir,
            &self.tables,
            last.as_ref(),
        )
        .map_err(|e| overrides::attribute(e, overrides, &file))?;
        if let Some(m) = slot.as_deref_mut() {
            *m = Some(Memo {
                set: overrides
                    .iter()
                    .map(|o| (o.key(), o.value().clone()))
                    .collect(),
                table,
                parts: Parts {
                    rig: scn.rig.clone(),
                    initial: scn.initial,
                    stages: scn.stages.clone(),
                    solver: scn.solver,
                    output: scn.output.clone(),
                },
            });
        }
        Ok(scn)
    }
}

/// The section walk: validate a parsed table into a scenario. A section that neither it nor the
/// sections its parse reads besides changed since `last` (the last build from the same source
/// with the same keys set) is taken from there ([`Memo`]); the checks across sections run every
/// time.
fn build(
    root: &Table,
    text: &Arc<str>,
    source: Source,
    base_dir: Option<&Path>,
    tables: &LawTables,
    last: Option<&Last>,
) -> Result<Scenario> {
    let p = Parser {
        source: &source,
        tables: Some(tables),
    };
    let top = Section::root(root);
    p.check_top_level(&top)?;
    p.version(&top, true)?;
    let same = |names: &[&str]| last.and_then(|l| l.unless(names));
    let material = match same(&["material"]) {
        Some(m) => m.rig.material,
        None => p.material(&top)?,
    };
    let law = match same(&["material", "adhesion"]) {
        Some(m) => m.rig.law.clone(),
        None => p.law(&top, &material, base_dir)?,
    };
    let holder = match same(&["spring"]) {
        Some(m) => m.rig.holder,
        None => p.holder(&top)?,
    };
    let sphere = match same(&["spring", "sphere"]) {
        Some(m) => m.rig.sphere,
        None => p.sphere(&top, holder)?,
    };
    let damping = match same(&["damping"]) {
        Some(m) => m.rig.damping,
        None => p.damping(&top)?,
    };
    let base = match same(&["base"]) {
        Some(m) => m.rig.base,
        None => p.base(&top)?,
    };
    let formation = match same(&["material", "contact"]) {
        Some(m) => m.rig.formation,
        None => p.formation(&top, &material)?,
    };
    let initial = match same(&["spring", "sphere", "initial"]) {
        Some(m) => m.initial,
        None => p.initial(&top, holder, sphere)?,
    };
    // The stages read whether there is a base motion, not its values.
    let stages = match same(&["spring", "stage"]) {
        Some(m) if m.rig.base.is_some() == base.is_some() => m.stages.clone(),
        _ => p.stages(&top, holder, base.is_some())?,
    };
    let solver = match same(&["solver"]) {
        Some(m) => m.solver,
        None => p.solver(&top)?,
    };
    let output = match same(&["output"]) {
        Some(m) => m.output.clone(),
        None => p.output(&top)?,
    };
    p.physics(&top, &material, holder, sphere, &initial, &stages)?;
    let scenario = Scenario {
        rig: Rig {
            material,
            law,
            sphere,
            holder,
            damping,
            base,
            formation,
        },
        initial,
        stages,
        solver,
        output,
        source_text: Arc::clone(text),
        source_name: overrides::describe(&source.file, &source.set),
        overrides: source.set.into_vec(),
    };
    // What the simulator would refuse when it sets the run up is refused here, so `check` and
    // every command agree with `run`.
    checks::setup_check(&scenario).map_err(|e| ScenarioError::Setup {
        source: Source {
            file: source.file,
            set: scenario.overrides.clone().into(),
        },
        message: e.to_string(),
    })?;
    Ok(scenario)
}

/// Only the `[material]` and `[adhesion]` sections of a file, for commands that need nothing else
/// (`--material FILE`). The file may be a full scenario (its other known sections are ignored, not
/// validated) or hold just these two sections; `version`, when present, must be 1; unknown
/// top-level keys are still rejected.
pub fn material_and_law(path: &Path) -> Result<(Material, Law)> {
    let name = path.display().to_string();
    let text = read_text(path, &name)?;
    parse_material_and_law(&text, &name, Some(&parent_dir(path)))
}

/// [`material_and_law`] on a text already in memory (`source_name` and `base_dir` as in
/// [`parse_scenario`]).
pub fn parse_material_and_law(
    text: &str,
    source_name: &str,
    base_dir: Option<&Path>,
) -> Result<(Material, Law)> {
    let source = Source::file(source_name);
    let p = Parser {
        source: &source,
        tables: None,
    };
    let root = p.parse_toml(text)?;
    p.material_and_law(&root, base_dir)
}

/// A scenario's value, format-neutral: what a scenario file, a Python dict or a JSON document
/// holds once parsed. [`ScenarioSource::from_tree`] validates a table of them.
#[derive(Debug, Clone, PartialEq)]
pub enum Tree {
    /// `true` or `false`.
    Bool(bool),
    /// A whole number.
    Int(i64),
    /// A number.
    Float(f64),
    /// Text (a key's value with a unit, `"30um"`, or a name).
    Text(String),
    /// A list (the stages, dense windows, a tabulated law's points).
    List(Vec<Tree>),
    /// A table (a section): its keys in order.
    Table(Vec<(String, Tree)>),
}

/// Why `v` (SI) lies outside the range of the numeric key `key`, or `None`: the checks of a
/// value alone that the parser runs (finite, its sign, not subnormal, the bounds of
/// [`checks::UPPER_BOUNDS`] and [`checks::LOWER_BOUNDS`], a frequency's, phase's or tolerance's
/// interval), worded as the parser words them (`must be a finite number > 0 (dimensionless)`).
/// What depends on the rest of the scenario (a speed on a hold stage, the physics across keys)
/// is not checked here; nor are whole-number keys, which their writer checks. `djkr fit` holds
/// the bounds of `--free` to this.
pub(crate) fn range_error(key: SetKey, v: f64) -> Option<String> {
    let info = keys::find(key.section().unwrap_or(""), key.name())?;
    let unit = if info.unit.is_empty() {
        "dimensionless"
    } else {
        info.unit
    };
    let k = key.to_string();
    match (key.section().unwrap_or(""), key.name()) {
        ("base", "frequency") => positive_error(&k, v, unit).or_else(|| frequency_error(v)),
        ("base", "phase") => phase_error(v),
        ("solver", "rtol") => rtol_error(v),
        ("solver", "atol") => atol_error(v),
        ("solver", "envelope_tol") => envelope_tol_error(v),
        ("solver", "max_steps" | "max_events" | "max_memory") => None, // whole numbers, checked as such
        ("output", "sample_rate") => {
            non_negative_error(&k, v, "samples per second; 0 = every step")
        }
        _ => {
            if info.allowed.starts_with(">= 0") {
                non_negative_error(&k, v, unit)
            } else {
                positive_error(&k, v, unit)
            }
        }
    }
}

/// The deepest nesting of tables and lists a [`Tree`] may have: the TOML parser's own limit
/// (toml 0.9 refuses tables, arrays and dotted keys nested 80 deep), so a tree is refused where
/// the same scenario as a file would be.
pub const MAX_TREE_DEPTH: usize = 80;

/// The parser's table of `items`, `depth` levels down (`key` the dotted path so far, for
/// messages).
fn tree_table(
    items: Vec<(String, Tree)>,
    key: &str,
    depth: usize,
    source: &Source,
) -> Result<Table> {
    if depth > MAX_TREE_DEPTH {
        return Err(too_deep(key, source));
    }
    let mut t = Table::new();
    for (k, v) in items {
        let path = if key.is_empty() {
            k.clone()
        } else {
            format!("{key}.{k}")
        };
        let value = tree_value(v, &path, depth + 1, source)?;
        if t.insert(k, value).is_some() {
            return Err(ScenarioError::Key {
                source: source.clone(),
                key: path,
                message: "given twice".into(),
            });
        }
    }
    Ok(t)
}

/// A table or list at `key` nested deeper than [`MAX_TREE_DEPTH`].
fn too_deep(key: &str, source: &Source) -> ScenarioError {
    ScenarioError::Key {
        source: source.clone(),
        key: key.to_string(),
        message: format!("nested more than {MAX_TREE_DEPTH} deep, the limit of a scenario file"),
    }
}

fn tree_value(v: Tree, key: &str, depth: usize, source: &Source) -> Result<Value> {
    if matches!(v, Tree::List(_)) && depth > MAX_TREE_DEPTH {
        return Err(too_deep(key, source));
    }
    Ok(match v {
        Tree::Bool(b) => Value::Boolean(b),
        Tree::Int(i) => Value::Integer(i),
        Tree::Float(x) => Value::Float(x),
        Tree::Text(s) => Value::String(s),
        Tree::List(items) => Value::Array(
            items
                .into_iter()
                .enumerate()
                .map(|(i, x)| tree_value(x, &format!("{key}[{i}]"), depth + 1, source))
                .collect::<Result<_>>()?,
        ),
        Tree::Table(items) => Value::Table(tree_table(items, key, depth, source)?),
    })
}

fn read_text(path: &Path, name: &str) -> Result<String> {
    input::read_text(path, InputKind::Scenario).map_err(|cause| ScenarioError::Io {
        source: Source::file(name),
        cause,
    })
}

fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Keys of `[adhesion]` with `law = "constant"`.
const CONSTANT_LAW_KEYS: &[&str] = &["law"];
/// Keys of `[adhesion]` with `law = "gent-schultz"`.
const GS_LAW_KEYS: &[&str] = &["law", "v0", "n"];
/// Keys of `[adhesion]` with `law = "gent-schultz-saturated"`.
const SATURATED_LAW_KEYS: &[&str] = &["law", "v0", "n", "v_sat"];
/// Keys of `[adhesion]` with `law = "tabulated"`.
const TABULATED_LAW_KEYS: &[&str] = &["law", "file"];

/// The most windows `[output] dense` may list (each is checked at every period boundary that
/// envelope following considers; far more than a protocol has stages).
pub(crate) const MAX_DENSE_WINDOWS: usize = 10_000;

/// The keys of section `name` ([`keys::section_keys`], the one table of keys; `""` for the top
/// level).
fn keys_of(name: &str) -> &'static [&'static str] {
    keys::section_keys(name).unwrap_or_default()
}

/// The sections as a file writes them: `[material], ..., [[stage]], ...`.
fn section_list() -> String {
    keys::SECTIONS
        .iter()
        .map(|s| {
            if *s == STAGE_SECTION {
                format!("[[{s}]]")
            } else {
                format!("[{s}]")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A physical quantity kind: the units a string may carry and the SI unit shown in errors.
#[derive(Clone, Copy)]
struct Quantity {
    /// `None`: bare numbers only.
    dim: Option<Dimension>,
    /// Unit label for messages.
    unit: &'static str,
}

const PRESSURE: Quantity = q(Some(Dimension::Pressure), "Pa");
const LENGTH: Quantity = q(Some(Dimension::Length), "m");
const ENERGY_PER_AREA: Quantity = q(Some(Dimension::EnergyPerArea), "J/m^2");
const SPEED: Quantity = q(Some(Dimension::Speed), "m/s");
const FREQUENCY: Quantity = q(Some(Dimension::Frequency), "Hz");
const TIME: Quantity = q(Some(Dimension::Time), "s");
const MASS: Quantity = q(Some(Dimension::Mass), "kg");
const FORCE: Quantity = q(Some(Dimension::Force), "N");
const STIFFNESS: Quantity = q(Some(Dimension::Stiffness), "N/m");
const DAMPING: Quantity = q(Some(Dimension::Damping), "N s/m");
const ACCELERATION: Quantity = q(Some(Dimension::Acceleration), "m/s^2");
const DIMENSIONLESS: Quantity = q(None, "dimensionless");
const ANGLE: Quantity = q(Some(Dimension::Angle), "rad");
const RATE: Quantity = q(Some(Dimension::Frequency), "samples per second");

const fn q(dim: Option<Dimension>, unit: &'static str) -> Quantity {
    Quantity { dim, unit }
}

/// A number read from the file, with its text as written (for messages).
struct Num {
    v: f64,
    shown: Shown,
}

/// How a number was written in the file, formatted only for a message (formatting every number
/// of every scenario built, most of which never fail, was about 5 % of a continuation branch's
/// time, which builds one scenario per period).
enum Shown {
    Integer(i64),
    Float(f64),
    /// A string with a unit, as TOML writes it (quoted).
    Text(String),
}

impl Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Shown::Integer(i) => write!(f, "{i}"),
            Shown::Float(x) => f.write_str(&show_float(*x)),
            Shown::Text(t) => write!(f, "{}", Value::String(t.clone())),
        }
    }
}

/// One TOML table and its dotted path (`""` for the root, `"stage[2]"`, `"material"`).
struct Section<'a> {
    path: String,
    table: &'a Table,
}

impl<'a> Section<'a> {
    fn root(table: &'a Table) -> Self {
        Self {
            path: String::new(),
            table,
        }
    }

    fn key(&self, k: &str) -> String {
        if self.path.is_empty() {
            k.to_string()
        } else {
            format!("{}.{}", self.path, k)
        }
    }

    fn has(&self, k: &str) -> bool {
        self.table.contains_key(k)
    }
}

/// Why `v` is out of the range of a key > 0 (`key` dotted, `unit` for the message), or `None`:
/// a finite, normal positive number within the bounds the model carries
/// ([`checks::key_range_error`]). Shared by the parser and by [`range_error`] (the bounds of
/// `djkr fit`'s free keys), so both word it the same.
pub(crate) fn positive_error(key: &str, v: f64, unit: &str) -> Option<String> {
    if v.is_finite() && v >= f64::MIN_POSITIVE {
        bound_error(key, v, unit)
    } else if let Some(e) =
        djkr_core::error::subnormal_error(v, &format!("a normal finite number > 0 ({unit})"))
    {
        Some(e)
    } else {
        Some(format!("must be a finite number > 0 ({unit})"))
    }
}

/// As [`positive_error`] for a key >= 0.
pub(crate) fn non_negative_error(key: &str, v: f64, unit: &str) -> Option<String> {
    if let Some(e) = v
        .is_subnormal()
        .then(|| {
            djkr_core::error::subnormal_error(
                v,
                &format!("0 or a normal finite number > 0 ({unit})"),
            )
        })
        .flatten()
    {
        // As for the keys > 0: a subnormal has lost digits, and its reciprocal overflows.
        Some(e)
    } else if v.is_finite() && v >= 0.0 {
        bound_error(key, v, unit)
    } else {
        Some(format!("must be a finite number >= 0 ({unit})"))
    }
}

/// The bounds the model carries for the key ([`checks::key_range_error`]); `base.frequency`'s
/// range is checked (with its own message) by [`frequency_error`].
fn bound_error(key: &str, v: f64, unit: &str) -> Option<String> {
    if key == "base.frequency" {
        return None;
    }
    checks::key_range_error(key, v, unit)
}

/// Why a base frequency (Hz, already > 0) is out of range.
pub(crate) fn frequency_error(f: f64) -> Option<String> {
    (!(checks::MIN_FREQUENCY..=checks::MAX_FREQUENCY).contains(&f)).then(|| {
        format!(
            "must lie in [{:e}, {:e}] (Hz): a period longer than 1e6 s outlasts any run, \
             one shorter than 1 us is below the time resolution of a long run",
            checks::MIN_FREQUENCY,
            checks::MAX_FREQUENCY
        )
    })
}

/// Why a base phase (rad) is out of range.
pub(crate) fn phase_error(phase: f64) -> Option<String> {
    (!(phase.is_finite() && (0.0..2.0 * std::f64::consts::PI).contains(&phase))).then(|| {
        "must lie in [0, 2 pi) (rad; the shaker starts phase/omega after its stage begins)"
            .to_string()
    })
}

/// Why a seed radius (m, > 0) does not fit the material.
pub(crate) fn seed_error(r: f64, m: &Material) -> Option<String> {
    let a_jump = jkr::jump_in_radius(m, m.w0);
    (r > a_jump).then(|| {
        format!(
            "must not exceed the JKR jump-in radius (8 pi w0 R^2 / 3K)^(1/3) = {a_jump:.4e} m of this material"
        )
    })
}

/// Why a static preload `p` cannot start a sphere that no spring holds (weight `weight`).
pub(crate) fn resting_preload_error(p: f64, weight: f64) -> Option<String> {
    ((p - weight).abs() > 1e-9 * weight.max(f64::MIN_POSITIVE)).then(|| {
        format!(
            "without a spring force the sphere rests on its own weight, so a static start needs preload = m g = {weight:.6e} N (or leave out [initial])"
        )
    })
}

/// The relative tolerance's range.
pub(crate) fn rtol_error(v: f64) -> Option<String> {
    (!(v.is_finite() && (MIN_RTOL..=MAX_RTOL).contains(&v))).then(|| {
        format!("must lie in [{MIN_RTOL:e}, {MAX_RTOL:e}] (relative tolerance, dimensionless; below {MIN_RTOL:e} the error estimate is rounding noise)")
    })
}

/// The absolute tolerance's range.
pub(crate) fn atol_error(v: f64) -> Option<String> {
    (!(v.is_finite() && (f64::MIN_POSITIVE..=1.0).contains(&v))).then(|| {
        "must lie in (0, 1] (absolute tolerance relative to each state component's natural scale, dimensionless)".to_string()
    })
}

/// The envelope tolerance's range.
pub(crate) fn envelope_tol_error(v: f64) -> Option<String> {
    (!(v.is_finite() && (1e-12..=1e-2).contains(&v))).then(|| {
        "must lie in [1e-12, 1e-2] (local error of an envelope step in the scaled \
         norm, dimensionless)"
            .to_string()
    })
}

/// Combinations of valid values that JKR or the simulator cannot carry ([`checks`]: a sphere
/// too small for its jump-in radius, a static load whose contact exceeds R, a weight lost to
/// rounding): `(key, value shown or None for a key error, message)`. `initial_given`: whether
/// the file has `[initial]` (else the start is the sphere resting on its weight).
pub(crate) fn physics_error(
    m: &Material,
    holder: Holder,
    sphere: Sphere,
    initial: &Initial,
    stages: &[Stage],
    initial_given: bool,
) -> Option<(String, Option<String>, String)> {
    if let Some(e) = checks::material_error(m) {
        return Some(("[material]".into(), None, e));
    }
    let weight = sphere.mass * sphere.gravity;
    if checks::spring_carries_weight(holder) {
        if let Some(e) = checks::weight_error(m, weight) {
            return Some((
                "[sphere]".into(),
                None,
                format!(
                    "mass = {} kg, gravity = {} m/s^2: {e}",
                    sphere.mass, sphere.gravity
                ),
            ));
        }
    }
    if let Initial::Preload(p) = *initial {
        if let Some(e) = checks::load_error(m, p) {
            return Some(if initial_given {
                ("initial.preload".into(), Some(show_float(p)), e)
            } else {
                (
                    "[sphere]".into(),
                    None,
                    format!("the sphere rests on its weight m g = {p:e} N: {e}"),
                )
            });
        }
    }
    for (i, st) in stages.iter().enumerate() {
        if let Until::Preload(p) = st.until {
            if let Some(e) = checks::load_error(m, p) {
                return Some((format!("stage[{i}].preload"), Some(show_float(p)), e));
            }
        }
    }
    None
}

struct Parser<'a> {
    source: &'a Source,
    /// The law tables read for this file so far (`None`: read each one).
    tables: Option<&'a LawTables>,
}

/// The tabulated laws a scenario file's validations have read, by path: each table is read and
/// parsed once per [`ScenarioSource`], and every scenario built from it shares its rows (a
/// 55 000-row table took 5 ms to parse, 99 % of a tabulated continuation).
type LawTables = Arc<Mutex<Vec<(PathBuf, TabulatedLaw)>>>;

impl Parser<'_> {
    fn value_err(
        &self,
        key: &str,
        value: impl Display,
        allowed: impl Into<String>,
    ) -> ScenarioError {
        ScenarioError::Value {
            source: self.source.clone(),
            key: key.to_string(),
            value: value.to_string(),
            allowed: allowed.into(),
        }
    }

    fn key_err(&self, key: &str, message: impl Into<String>) -> ScenarioError {
        ScenarioError::Key {
            source: self.source.clone(),
            key: key.to_string(),
            message: message.into(),
        }
    }

    fn material_and_law(&self, root: &Table, base_dir: Option<&Path>) -> Result<(Material, Law)> {
        let top = Section::root(root);
        self.check_top_level(&top)?;
        self.version(&top, false)?;
        let material = self.material(&top)?;
        let law = self.law(&top, &material, base_dir)?;
        Ok((material, law))
    }

    fn parse_toml(&self, text: &str) -> Result<Table> {
        text.parse::<Table>().map_err(|e| {
            let offset = e.span().map(|s| s.start).unwrap_or(0).min(text.len());
            let before = text.get(..offset).unwrap_or(text);
            let line = before.matches('\n').count() + 1;
            let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            ScenarioError::Syntax {
                source: self.source.clone(),
                line,
                column,
                message: e.message().trim().to_string(),
            }
        })
    }

    /// Reject keys of `s` not in `allowed`; `context` is appended to the message
    /// (e.g. ` for law = "constant"`).
    fn check_keys(&self, s: &Section, allowed: &[&str], context: &str) -> Result<()> {
        for k in s.table.keys() {
            if !allowed.contains(&k.as_str()) {
                return Err(self.key_err(
                    &s.key(k),
                    format!("unknown key{context}; allowed here: {}", allowed.join(", ")),
                ));
            }
        }
        Ok(())
    }

    fn check_top_level(&self, top: &Section) -> Result<()> {
        let top_keys = keys_of("");
        for (k, v) in top.table {
            if !top_keys.contains(&k.as_str()) && !keys::SECTIONS.contains(&k.as_str()) {
                return Err(match v {
                    Value::Table(_) => self.key_err(
                        &format!("[{k}]"),
                        format!("unknown section; allowed sections: {}", section_list()),
                    ),
                    _ => self.key_err(
                        k,
                        "unknown top-level key; allowed: version (the sections are tables)",
                    ),
                });
            }
        }
        Ok(())
    }

    /// The sub-table `name` of `parent`, if present.
    fn section<'t>(&self, parent: &Section<'t>, name: &str) -> Result<Option<Section<'t>>> {
        match parent.table.get(name) {
            None => Ok(None),
            Some(Value::Table(t)) => Ok(Some(Section {
                path: parent.key(name),
                table: t,
            })),
            Some(v) => Err(self.value_err(
                &parent.key(name),
                show(v),
                format!("must be a table: write [{name}] and its keys on the lines below"),
            )),
        }
    }

    fn number(&self, s: &Section, k: &str, qty: Quantity) -> Result<Option<Num>> {
        match s.table.get(k) {
            None => Ok(None),
            Some(Value::Integer(i)) => Ok(Some(Num {
                v: *i as f64,
                shown: Shown::Integer(*i),
            })),
            Some(Value::Float(f)) => Ok(Some(Num {
                v: *f,
                shown: Shown::Float(*f),
            })),
            Some(Value::String(text)) if qty.dim.is_some() => {
                let key = s.key(k);
                let dim = qty.dim.unwrap_or(Dimension::Dimensionless);
                let v = parse_quantity(&key, text, dim)
                    .map_err(|e| self.value_err(&key, Value::String(text.clone()), e.allowed))?;
                Ok(Some(Num {
                    v,
                    shown: Shown::Text(text.clone()),
                }))
            }
            Some(v) => {
                let allowed = match qty.dim {
                    Some(dim) => {
                        let units = dim.units();
                        let example = units.get(1).or(units.first()).map_or("", |u| u.0);
                        format!(
                            "must be a number in SI ({}) or a string with a unit such as \"1{example}\"",
                            qty.unit
                        )
                    }
                    None => format!("must be a number ({})", qty.unit),
                };
                Err(self.value_err(&s.key(k), show(v), allowed))
            }
        }
    }

    fn required(&self, s: &Section, k: &str, qty: Quantity, what: &str) -> Result<Num> {
        self.number(s, k, qty)?
            .ok_or_else(|| self.key_err(&s.key(k), format!("missing: {what}")))
    }

    fn string<'t>(&self, s: &Section<'t>, k: &str, choices: &[&str]) -> Result<Option<&'t str>> {
        let key = || s.key(k);
        let list = || {
            choices
                .iter()
                .map(|c| format!("\"{c}\""))
                .collect::<Vec<_>>()
                .join(", ")
        };
        match s.table.get(k) {
            None => Ok(None),
            Some(Value::String(v)) if choices.is_empty() || choices.contains(&v.as_str()) => {
                Ok(Some(v.as_str()))
            }
            Some(v @ Value::String(_)) => {
                Err(self.value_err(&key(), show(v), format!("must be one of {}", list())))
            }
            Some(v) if choices.is_empty() => {
                Err(self.value_err(&key(), show(v), "must be a string (in quotes)"))
            }
            Some(v) => Err(self.value_err(
                &key(),
                show(v),
                format!("must be a string, one of {}", list()),
            )),
        }
    }

    fn boolean(&self, s: &Section, k: &str) -> Result<Option<bool>> {
        match s.table.get(k) {
            None => Ok(None),
            Some(Value::Boolean(b)) => Ok(Some(*b)),
            Some(v) => Err(self.value_err(&s.key(k), show(v), "must be true or false")),
        }
    }

    fn positive(&self, s: &Section, k: &str, n: &Num, unit: &str) -> Result<f64> {
        let key = s.key(k);
        match positive_error(&key, n.v, unit) {
            Some(e) => Err(self.value_err(&key, &n.shown, e)),
            None => Ok(n.v),
        }
    }

    fn non_negative(&self, s: &Section, k: &str, n: &Num, unit: &str) -> Result<f64> {
        let key = s.key(k);
        match non_negative_error(&key, n.v, unit) {
            Some(e) => Err(self.value_err(&key, &n.shown, e)),
            None => Ok(n.v),
        }
    }

    fn req_positive(&self, s: &Section, k: &str, qty: Quantity, what: &str) -> Result<f64> {
        let n = self.required(s, k, qty, what)?;
        self.positive(s, k, &n, qty.unit)
    }

    fn opt_positive(&self, s: &Section, k: &str, qty: Quantity) -> Result<Option<f64>> {
        match self.number(s, k, qty)? {
            Some(n) => self.positive(s, k, &n, qty.unit).map(Some),
            None => Ok(None),
        }
    }

    fn version(&self, top: &Section, required: bool) -> Result<()> {
        match top.table.get("version") {
            None if required => Err(self.key_err(
                "version",
                format!("missing: the first line of a scenario file must be `version = {SCENARIO_VERSION}`"),
            )),
            None => Ok(()),
            Some(Value::Integer(v)) if *v == SCENARIO_VERSION => Ok(()),
            Some(v @ Value::Integer(_)) => Err(self.value_err(
                "version",
                show(v),
                format!("this djkr reads scenario format version {SCENARIO_VERSION} only"),
            )),
            Some(v) => Err(self.value_err(
                "version",
                show(v),
                format!("must be the integer {SCENARIO_VERSION}"),
            )),
        }
    }

    fn material(&self, top: &Section) -> Result<Material> {
        let s = self.section(top, "material")?.ok_or_else(|| {
            self.key_err(
                "[material]",
                "missing section: give [material] with K (Pa), R (m) and w0 (J/m^2)",
            )
        })?;
        self.check_keys(&s, keys_of("material"), "")?;
        let k = self.req_positive(
            &s,
            "K",
            PRESSURE,
            "JKR elastic constant K = 4E*/3 (Pa, > 0)",
        )?;
        let r = self.req_positive(&s, "R", LENGTH, "sphere radius R (m, > 0)")?;
        let w0 = self.req_positive(
            &s,
            "w0",
            ENERGY_PER_AREA,
            "quasi-static work of adhesion w0 (J/m^2, > 0)",
        )?;
        Ok(Material { k, r, w0 })
    }

    fn law(&self, top: &Section, m: &Material, base_dir: Option<&Path>) -> Result<Law> {
        let Some(s) = self.section(top, "adhesion")? else {
            return Ok(Law::Constant(ConstantW { w0: m.w0 }));
        };
        let law = self.string(&s, "law", &LAW_NAMES)?.ok_or_else(|| {
            self.key_err(
                &s.key("law"),
                "missing: one of \"constant\", \"gent-schultz\", \"gent-schultz-saturated\", \"tabulated\"",
            )
        })?;
        let context = format!(" for law = \"{law}\"");
        let param = |e: ParamError| self.value_err(&s.key(&e.name), e.value, e.allowed);
        match law {
            "constant" => {
                self.check_keys(&s, CONSTANT_LAW_KEYS, &context)?;
                Ok(Law::Constant(ConstantW { w0: m.w0 }))
            }
            "gent-schultz" | "gent-schultz-saturated" => {
                let saturated = law == "gent-schultz-saturated";
                let keys = if saturated {
                    SATURATED_LAW_KEYS
                } else {
                    GS_LAW_KEYS
                };
                self.check_keys(&s, keys, &context)?;
                let v0 = self.req_positive(
                    &s,
                    "v0",
                    SPEED,
                    "Gent-Schultz reference speed v0 (m/s, > 0; C = v0^-n)",
                )?;
                let n =
                    self.req_positive(&s, "n", DIMENSIONLESS, "Gent-Schultz exponent n (> 0)")?;
                if saturated {
                    let v_sat =
                        self.req_positive(&s, "v_sat", SPEED, "saturation speed v_sat (m/s, > 0)")?;
                    Ok(Law::Saturated(
                        SaturatedGentSchultz::new(m.w0, v0, n, v_sat).map_err(param)?,
                    ))
                } else {
                    Ok(Law::GentSchultz(
                        GentSchultz::new(m.w0, v0, n).map_err(param)?,
                    ))
                }
            }
            _ => {
                self.check_keys(&s, TABULATED_LAW_KEYS, &context)?;
                let file = self.string(&s, "file", &[])?.ok_or_else(|| {
                    self.key_err(
                        &s.key("file"),
                        "missing: a CSV file of two columns, speed (m/s, > 0 healing) and w (J/m^2), relative to the scenario file",
                    )
                })?;
                let key = s.key("file");
                let shown = Value::String(file.to_string()).to_string();
                let path = match base_dir {
                    Some(d) if Path::new(file).is_relative() => d.join(file),
                    _ => PathBuf::from(file),
                };
                let known = self.tables.and_then(|t| {
                    let list = t.lock().unwrap_or_else(|p| p.into_inner());
                    list.iter()
                        .find(|(p, _)| *p == path)
                        .map(|(_, t)| t.clone())
                });
                let table = match known {
                    Some(t) => t,
                    None => {
                        let text = input::read_text(&path, InputKind::LawTable).map_err(|e| {
                            self.value_err(&key, &shown, format!("{}: {e}", path.display()))
                        })?;
                        let t = TabulatedLaw::from_csv_str(&text, &path.display().to_string())
                            .map_err(|e| self.value_err(&key, &shown, e.to_string()))?;
                        if let Some(tables) = self.tables {
                            let mut list = tables.lock().unwrap_or_else(|p| p.into_inner());
                            list.push((path.clone(), t.clone()));
                        }
                        t
                    }
                };
                let w_table = table.w0();
                if (w_table - m.w0).abs() > TABLE_W0_RTOL * m.w0 {
                    return Err(self.value_err(
                        &key,
                        &shown,
                        format!(
                            "the table gives w(0) = {w_table} J/m^2 but material.w0 = {}; they must agree (to {TABLE_W0_RTOL:e} relative)",
                            m.w0
                        ),
                    ));
                }
                Ok(Law::Tabulated(table))
            }
        }
    }

    fn holder(&self, top: &Section) -> Result<Holder> {
        let Some(s) = self.section(top, "spring")? else {
            return Ok(Holder::None);
        };
        self.check_keys(&s, keys_of("spring"), "")?;
        let rigid = self.boolean(&s, "rigid")?;
        let stiffness = self.number(&s, "stiffness", STIFFNESS)?;
        match (rigid, stiffness) {
            (Some(true), Some(_)) => Err(self.key_err(
                "[spring]",
                "give either stiffness (N/m) or rigid = true, not both",
            )),
            (Some(true), None) => Ok(Holder::Rigid),
            (_, Some(n)) => Ok(Holder::Spring {
                stiffness: self.non_negative(&s, "stiffness", &n, STIFFNESS.unit)?,
            }),
            (_, None) => Err(self.key_err(
                &s.key("stiffness"),
                "missing: give stiffness (N/m, >= 0) or rigid = true (or leave out [spring])",
            )),
        }
    }

    fn sphere(&self, top: &Section, holder: Holder) -> Result<Sphere> {
        let rigid = matches!(holder, Holder::Rigid);
        let Some(s) = self.section(top, "sphere")? else {
            if rigid {
                return Ok(Sphere {
                    mass: 0.0,
                    gravity: DEFAULT_GRAVITY,
                });
            }
            return Err(self.key_err(
                "sphere.mass",
                "missing: give [sphere] with mass (kg, >= 0; 0 = quasi-static force balance); \
                 only a rigid link ([spring] rigid = true) needs no mass",
            ));
        };
        self.check_keys(&s, keys_of("sphere"), "")?;
        let mass = match self.number(&s, "mass", MASS)? {
            Some(n) => self.non_negative(&s, "mass", &n, MASS.unit)?,
            None if rigid => 0.0,
            None => {
                return Err(self.key_err(
                    &s.key("mass"),
                    "missing: sphere mass (kg, >= 0; 0 = quasi-static force balance); required unless spring.rigid = true",
                ))
            }
        };
        let gravity = match self.number(&s, "gravity", ACCELERATION)? {
            Some(n) => self.non_negative(&s, "gravity", &n, ACCELERATION.unit)?,
            None => DEFAULT_GRAVITY,
        };
        Ok(Sphere { mass, gravity })
    }

    fn damping(&self, top: &Section) -> Result<Option<Damping>> {
        let Some(s) = self.section(top, "damping")? else {
            return Ok(None);
        };
        self.check_keys(&s, keys_of("damping"), "")?;
        let n = self.required(&s, "c", DAMPING, "damping coefficient c (N s/m, >= 0)")?;
        let c = self.non_negative(&s, "c", &n, DAMPING.unit)?;
        let on = match self.string(&s, "on", &["sphere", "contact"])? {
            None | Some("sphere") => DampingOn::Sphere,
            Some(_) => DampingOn::Contact,
        };
        Ok(Some(Damping { c, on }))
    }

    fn base(&self, top: &Section) -> Result<Option<BaseMotion>> {
        let Some(s) = self.section(top, "base")? else {
            return Ok(None);
        };
        self.check_keys(&s, keys_of("base"), "")?;
        let na = self.required(&s, "amplitude", LENGTH, "base amplitude X_b (m, >= 0)")?;
        let amplitude = self.non_negative(&s, "amplitude", &na, LENGTH.unit)?;
        let n = self.required(&s, "frequency", FREQUENCY, "base frequency f (Hz, > 0)")?;
        let frequency = self.positive(&s, "frequency", &n, FREQUENCY.unit)?;
        if let Some(e) = frequency_error(frequency) {
            return Err(self.value_err(&s.key("frequency"), &n.shown, e));
        }
        if let Some(e) = checks::base_speed_error(amplitude, frequency) {
            return Err(self.value_err(&s.key("amplitude"), &na.shown, e));
        }
        let mut phase = 0.0;
        if let Some(n) = self.number(&s, "phase", ANGLE)? {
            if let Some(e) = phase_error(n.v) {
                return Err(self.value_err(&s.key("phase"), &n.shown, e));
            }
            phase = n.v;
        }
        Ok(Some(BaseMotion {
            amplitude,
            frequency,
            phase,
        }))
    }

    fn formation(&self, top: &Section, m: &Material) -> Result<ContactFormation> {
        let Some(s) = self.section(top, "contact")? else {
            return Ok(ContactFormation::JumpIn);
        };
        self.check_keys(&s, keys_of("contact"), "")?;
        match self.string(&s, "formation", &["jump-in", "seed"])? {
            Some("seed") => {
                let n = self.required(
                    &s,
                    "seed_radius",
                    LENGTH,
                    "seed radius (m, > 0) for formation = \"seed\"",
                )?;
                let r = self.positive(&s, "seed_radius", &n, LENGTH.unit)?;
                if let Some(e) = seed_error(r, m) {
                    return Err(self.value_err(&s.key("seed_radius"), &n.shown, e));
                }
                Ok(ContactFormation::Seed(r))
            }
            _ => {
                if s.has("seed_radius") {
                    return Err(self.key_err(
                        &s.key("seed_radius"),
                        "only used with formation = \"seed\" (the default \"jump-in\" forms the contact at the JKR jump-in radius)",
                    ));
                }
                Ok(ContactFormation::JumpIn)
            }
        }
    }

    fn initial(&self, top: &Section, holder: Holder, sphere: Sphere) -> Result<Initial> {
        let weight = sphere.mass * sphere.gravity;
        let no_spring_force = !holder.exerts_force();
        let Some(s) = self.section(top, "initial")? else {
            if no_spring_force && weight > 0.0 {
                return Ok(Initial::Preload(weight));
            }
            return Err(self.key_err(
                "[initial]",
                "missing section: give [initial] with preload (N, > 0: static JKR equilibrium under this force) or gap (m, > 0)",
            ));
        };
        self.check_keys(&s, keys_of("initial"), "")?;
        let preload = self.opt_positive(&s, "preload", FORCE)?;
        let gap = self.opt_positive(&s, "gap", LENGTH)?;
        match (preload, gap) {
            (Some(_), Some(_)) => {
                Err(self.key_err("[initial]", "give either preload (N) or gap (m), not both"))
            }
            (Some(p), None) => {
                if no_spring_force {
                    if let Some(e) = resting_preload_error(p, weight) {
                        return Err(self.value_err(&s.key("preload"), p, e));
                    }
                }
                Ok(Initial::Preload(p))
            }
            (None, Some(g)) => Ok(Initial::Gap(g)),
            (None, None) => {
                Err(self.key_err("[initial]", "empty: give preload (N, > 0) or gap (m, > 0)"))
            }
        }
    }

    /// Combinations of valid values that JKR or the simulator cannot carry
    /// ([`checks`]: a sphere too small for its jump-in radius, a static load whose contact
    /// exceeds R, a weight lost to rounding).
    fn physics(
        &self,
        top: &Section,
        m: &Material,
        holder: Holder,
        sphere: Sphere,
        initial: &Initial,
        stages: &[Stage],
    ) -> Result<()> {
        let given = top.table.get("initial").is_some();
        match physics_error(m, holder, sphere, initial, stages, given) {
            None => Ok(()),
            Some((key, None, e)) => Err(self.key_err(&key, e)),
            Some((key, Some(v), e)) => Err(self.value_err(&key, v, e)),
        }
    }

    fn stages(&self, top: &Section, holder: Holder, has_base: bool) -> Result<Vec<Stage>> {
        let list = match top.table.get("stage") {
            None => {
                return Err(self.key_err(
                    "[[stage]]",
                    "missing: the protocol needs at least one [[stage]] (kind = \"approach\", \"hold\" or \"unload\")",
                ))
            }
            Some(Value::Array(a)) => a,
            Some(v @ Value::Table(_)) => {
                return Err(self.value_err(
                    "stage",
                    show(v),
                    "must be an array of tables: write each stage as [[stage]] (two brackets)",
                ))
            }
            Some(v) => {
                return Err(self.value_err(
                    "stage",
                    show(v),
                    "must be an array of tables: write each stage as [[stage]]",
                ))
            }
        };
        if list.is_empty() {
            return Err(self.key_err("stage", "empty: the protocol needs at least one [[stage]]"));
        }
        list.iter()
            .enumerate()
            .map(|(i, v)| {
                let path = format!("stage[{i}]");
                match v {
                    Value::Table(t) => self.stage(&Section { path, table: t }, holder, has_base),
                    other => Err(self.value_err(&path, show(other), "must be a table ([[stage]])")),
                }
            })
            .collect()
    }

    fn stage(&self, s: &Section, holder: Holder, has_base: bool) -> Result<Stage> {
        self.check_keys(s, keys_of(STAGE_SECTION), "")?;
        let kind = match self.string(s, "kind", &["approach", "hold", "unload"])? {
            Some("approach") => StageKind::Approach,
            Some("hold") => StageKind::Hold,
            Some(_) => StageKind::Unload,
            None => {
                return Err(self.key_err(
                    &s.key("kind"),
                    "missing: one of \"approach\", \"hold\", \"unload\"",
                ))
            }
        };
        let kind_name = match kind {
            StageKind::Approach => "approach",
            StageKind::Hold => "hold",
            StageKind::Unload => "unload",
        };
        // Speed.
        let speed = match kind {
            StageKind::Hold => match self.number(s, "speed", SPEED)? {
                Some(n) if n.v == 0.0 => 0.0,
                Some(n) => {
                    return Err(self.value_err(
                        &s.key("speed"),
                        &n.shown,
                        "a hold keeps the spring end still: leave speed out (or set it to 0)",
                    ))
                }
                None => 0.0,
            },
            _ => {
                if !holder.exerts_force() {
                    return Err(self.value_err(
                        &s.key("kind"),
                        format!("\"{kind_name}\""),
                        "moves the spring end, but there is no spring to move: give [spring] with stiffness > 0 (N/m) or rigid = true, or use hold stages only",
                    ));
                }
                self.req_positive(
                    s,
                    "speed",
                    SPEED,
                    &format!("spring-end speed of the {kind_name} stage (m/s, > 0)"),
                )?
            }
        };
        // End condition: exactly one of duration, preload, until.
        let given: Vec<&str> = STAGE_END_KEYS
            .iter()
            .copied()
            .filter(|k| s.has(k))
            .collect();
        if given.len() > 1 {
            return Err(self.key_err(
                &s.path,
                format!(
                    "two end conditions ({}): give exactly one of duration (s), preload (N, approach only) or until = \"pull-off\" (unload only)",
                    given.join(" and ")
                ),
            ));
        }
        let until = match given.first().copied() {
            Some("duration") => {
                Until::Duration(self.req_positive(s, "duration", TIME, "stage duration (s)")?)
            }
            Some("preload") => {
                if kind != StageKind::Approach {
                    return Err(self.key_err(
                        &s.key("preload"),
                        format!("a preload end is for approach stages only (this is kind = \"{kind_name}\"); use duration or until = \"pull-off\""),
                    ));
                }
                Until::Preload(self.req_positive(s, "preload", FORCE, "compressive preload (N)")?)
            }
            Some(_) => {
                self.string(s, "until", &["pull-off"])?;
                if kind != StageKind::Unload {
                    return Err(self.key_err(
                        &s.key("until"),
                        format!("until = \"pull-off\" is for unload stages only (this is kind = \"{kind_name}\")"),
                    ));
                }
                Until::PullOff
            }
            None => {
                return Err(self.key_err(
                    &s.path,
                    "no end condition: give exactly one of duration (s), preload (N, approach only) or until = \"pull-off\" (unload only)",
                ))
            }
        };
        let vibration = self.boolean(s, "vibration")?;
        if vibration == Some(true) && !has_base {
            return Err(self.value_err(
                &s.key("vibration"),
                "true",
                "no [base] section defines the vibration: add [base] with amplitude (m) and frequency (Hz)",
            ));
        }
        let max_duration = match (until, self.opt_positive(s, "max_duration", TIME)?) {
            (Until::Duration(d), None) => d,
            (Until::Duration(_), Some(_)) => {
                return Err(self.key_err(
                    &s.key("max_duration"),
                    "only for stages that end on a preload or at pull-off (a duration end is its own limit)",
                ))
            }
            (_, Some(m)) => m,
            (_, None) => DEFAULT_MAX_DURATION,
        };
        Ok(Stage {
            kind,
            speed,
            until,
            vibration,
            max_duration,
        })
    }

    fn solver(&self, top: &Section) -> Result<Solver> {
        let mut solver = Solver::default();
        let Some(s) = self.section(top, "solver")? else {
            return Ok(solver);
        };
        self.check_keys(&s, keys_of("solver"), "")?;
        if let Some(name) = self.string(&s, "method", &method_names())? {
            solver.method = method_from_name(name).unwrap_or(Method::Auto);
        }
        if let Some(n) = self.number(&s, "rtol", DIMENSIONLESS)? {
            if let Some(e) = rtol_error(n.v) {
                return Err(self.value_err(&s.key("rtol"), &n.shown, e));
            }
            solver.rtol = n.v;
        }
        if let Some(n) = self.number(&s, "atol", DIMENSIONLESS)? {
            if let Some(e) = atol_error(n.v) {
                return Err(self.value_err(&s.key("atol"), &n.shown, e));
            }
            solver.atol = n.v;
        }
        if let Some(n) =
            self.whole_number(&s, "max_steps", 1, "must be a whole number >= 1 (steps)")?
        {
            solver.max_steps = n;
        }
        if let Some(n) = self.whole_number(
            &s,
            "max_events",
            1,
            "must be a whole number >= 1 (contact events)",
        )? {
            solver.max_events = n;
        }
        if let Some(n) = self.whole_number(
            &s,
            "max_memory",
            djkr_core::dynamics::methods::MIN_MAX_MEMORY,
            "must be a whole number of bytes >= 1048576 (1 MiB; default 2147483648 = 2 GiB)",
        )? {
            solver.max_memory = n;
        }
        if let Some(w) = self.opt_positive(&s, "max_wall_s", TIME)? {
            solver.max_wall_s = w;
        }
        if let Some(t) = self.opt_positive(&s, "event_tol", TIME)? {
            solver.event_tol = t;
        }
        match self.string(&s, "envelope", &["auto", "off"])? {
            Some("off") => solver.envelope = EnvelopeMode::Off,
            Some(_) => solver.envelope = EnvelopeMode::Auto,
            None => {}
        }
        if let Some(n) = self.number(&s, "envelope_tol", DIMENSIONLESS)? {
            if let Some(e) = envelope_tol_error(n.v) {
                return Err(self.value_err(&s.key("envelope_tol"), &n.shown, e));
            }
            solver.envelope_tol = n.v;
        }
        Ok(solver)
    }

    /// The whole number `k` of section `s`, at least `min` (an integer, or a float with no
    /// fraction up to 9e15, as TOML writes large numbers); `allowed` is the error's range.
    fn whole_number(&self, s: &Section, k: &str, min: u64, allowed: &str) -> Result<Option<u64>> {
        let Some(v) = s.table.get(k) else {
            return Ok(None);
        };
        let ok = match v {
            Value::Integer(i) if *i >= 0 && *i as u64 >= min => Some(*i as u64),
            Value::Float(f)
                if f.is_finite() && *f >= min as f64 && f.fract() == 0.0 && *f <= 9.0e15 =>
            {
                Some(*f as u64)
            }
            _ => None,
        };
        ok.map(Some)
            .ok_or_else(|| self.value_err(&s.key(k), show(v), allowed))
    }

    fn output(&self, top: &Section) -> Result<Output> {
        let mut out = Output::default();
        let Some(s) = self.section(top, "output")? else {
            return Ok(out);
        };
        self.check_keys(&s, keys_of("output"), "")?;
        if let Some(n) = self.number(&s, "sample_rate", RATE)? {
            out.sample_rate =
                self.non_negative(&s, "sample_rate", &n, "samples per second; 0 = every step")?;
        }
        if let Some(b) = self.boolean(&s, "csv")? {
            out.csv = b;
        }
        if let Some(b) = self.boolean(&s, "compress")? {
            out.compress = b;
        }
        if let Some(b) = self.boolean(&s, "fsync")? {
            out.fsync = b;
        }
        if let Some(b) = self.boolean(&s, "plot")? {
            out.plot = b;
        }
        if let Some(v) = s.table.get("dense") {
            out.dense = self.dense(&s.key("dense"), v)?;
        }
        Ok(out)
    }

    /// `[output] dense`: a list of `[t0, t1]` windows (s, numbers or strings with a time unit),
    /// each finite with t0 < t1; sorted and overlapping or touching windows merged, at most
    /// [`MAX_DENSE_WINDOWS`].
    fn dense(&self, key: &str, v: &Value) -> Result<Vec<[f64; 2]>> {
        const ALLOWED: &str =
            "must be a list of [t0, t1] windows in seconds with t0 < t1, e.g. [[2.0, 2.5], [10, 11]]";
        let list = match v {
            Value::Array(list) => list,
            // `--set` hands its values over as text: a list cannot come that way.
            Value::String(_) => {
                return Err(self.value_err(
                    key,
                    show(v),
                    format!("{ALLOWED}; a list cannot be given with {}: write it in the scenario file's [output]", crate::words::input("set")),
                ))
            }
            other => return Err(self.value_err(key, show(other), ALLOWED)),
        };
        if list.len() > MAX_DENSE_WINDOWS {
            return Err(self.value_err(
                key,
                format!("({} windows)", list.len()),
                format!("at most {MAX_DENSE_WINDOWS} windows"),
            ));
        }
        let mut windows = Vec::with_capacity(list.len());
        for (i, w) in list.iter().enumerate() {
            let wkey = format!("{key}[{i}]");
            let pair = match w {
                Value::Array(p) if p.len() == 2 => p,
                other => return Err(self.value_err(&wkey, show(other), ALLOWED)),
            };
            let mut ts = [0.0; 2];
            for (t, x) in ts.iter_mut().zip(pair) {
                *t = match x {
                    Value::Integer(n) => *n as f64,
                    Value::Float(f) => *f,
                    Value::String(text) => parse_quantity(&wkey, text, Dimension::Time)
                        .map_err(|e| self.value_err(&wkey, show(x), e.allowed))?,
                    other => return Err(self.value_err(&wkey, show(other), ALLOWED)),
                };
            }
            if !(ts[0].is_finite() && ts[1].is_finite() && ts[0] < ts[1]) {
                return Err(self.value_err(
                    &wkey,
                    show(w),
                    "must be a window [t0, t1] of finite times in seconds with t0 < t1",
                ));
            }
            windows.push(ts);
        }
        Ok(merge_windows(windows))
    }
}

/// Windows sorted by their start, with overlapping or touching ones merged into one.
pub(crate) fn merge_windows(mut windows: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    windows.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let mut merged: Vec<[f64; 2]> = Vec::with_capacity(windows.len());
    for w in windows {
        match merged.last_mut() {
            Some(last) if w[0] <= last[1] => last[1] = last[1].max(w[1]),
            _ => merged.push(w),
        }
    }
    merged
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
version = 1
[material]
K = 9.33e6
R = 0.051
w0 = 0.240
[sphere]
mass = 3e-3
[spring]
stiffness = 200
[initial]
preload = 0.02
[[stage]]
kind = "unload"
speed = 5e-6
until = "pull-off"
"#;

    /// Scenarios built one after another from one source with the same keys set (the memo's
    /// path: the last build's table and unchanged sections reused) are those a fresh source
    /// builds, bit for bit (a sign of zero included), errors included; builds with other keys,
    /// or none, between them change nothing.
    #[test]
    fn builds_with_the_same_keys_are_those_of_a_fresh_source() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-protocol-300hz.toml");
        let text = std::fs::read_to_string(path).unwrap();
        let fresh = || ScenarioSource::parse(&text, "p.toml", None).unwrap();
        let src = fresh();
        // As a continuation sets its keys: typed values.
        let keys = |values: [f64; 4]| -> Vec<Override> {
            [
                "base.frequency",
                "adhesion.n",
                "base.phase",
                "stage[1].duration",
            ]
            .iter()
            .zip(values)
            .map(|(k, v)| Override::from_key(SetKey::parse(k).unwrap(), v).unwrap())
            .collect()
        };
        let sets = [
            keys([300.0, 0.5, 0.0, 0.1]),
            keys([310.0, 0.5, 0.0, 0.1]),
            // Only the sign of a zero changes.
            keys([310.0, 0.5, -0.0, 0.1]),
            keys([310.0, 0.6, -0.0, 0.2]),
            // Refused (n), then refused (the frequency's range): the next build is right.
            keys([310.0, -1.0, 0.0, 0.2]),
            keys([1e9, 0.6, 0.0, 0.2]),
            keys([320.0, 0.6, 0.0, 0.2]),
            Override::parse_all(&["base.frequency=320"]).unwrap(),
            keys([330.0, 0.6, 0.5, 0.3]),
            vec![],
            keys([330.0, 0.6, 0.5, 0.3]),
            keys([330.0, 0.6, 0.5, 0.4]),
        ];
        let show = |r: Result<Scenario>| match r {
            Ok(s) => format!("{s:?}"),
            Err(e) => format!("error {e:?}"),
        };
        let mut refused = 0;
        for o in &sets {
            let got = show(src.scenario(o));
            refused += usize::from(got.starts_with("error"));
            assert_eq!(got, show(fresh().scenario(o)), "{o:?}");
        }
        assert_eq!(refused, 2);
    }

    /// A tabulated law's table is read once per source: scenarios built from it afterwards, with
    /// any overrides, share its rows even when the file has gone.
    #[test]
    fn a_law_table_is_read_once_per_source() {
        let good = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenarios/good");
        let dir = tempfile::tempdir().unwrap();
        for f in ["tabulated.toml", "law-table.csv"] {
            std::fs::copy(good.join(f), dir.path().join(f)).unwrap();
        }
        let src = ScenarioSource::read(&dir.path().join("tabulated.toml")).unwrap();
        let first = src.scenario(&[]).unwrap();
        std::fs::remove_file(dir.path().join("law-table.csv")).unwrap();
        let o = Override::parse("base.amplitude=20um").unwrap();
        let again = src.scenario(&[o]).unwrap();
        assert!(matches!(again.rig.law, Law::Tabulated(_)));
        assert_eq!(again.rig.law, first.rig.law);
        // A new source reads the file again, and says it has gone.
        let e = ScenarioSource::read(&dir.path().join("tabulated.toml"))
            .unwrap()
            .scenario(&[])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("adhesion.file") && e.contains("law-table.csv"),
            "{e}"
        );
    }

    #[test]
    fn the_section_key_lists_agree_with_the_laws() {
        let mut union: Vec<&str> = [
            CONSTANT_LAW_KEYS,
            GS_LAW_KEYS,
            SATURATED_LAW_KEYS,
            TABULATED_LAW_KEYS,
        ]
        .concat();
        union.sort_unstable();
        union.dedup();
        let mut all = keys_of("adhesion").to_vec();
        all.sort_unstable();
        assert_eq!(union, all);
        assert!(STAGE_END_KEYS
            .iter()
            .all(|k| keys_of(STAGE_SECTION).contains(k)));
        assert_eq!(
            keys::section_keys("base"),
            Some(&["amplitude", "frequency", "phase"][..])
        );
        assert_eq!(keys::section_keys("version"), None);
        let e = parse_scenario(&format!("{MINIMAL}[bogus]\nx = 1\n"), "m.toml", None)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("allowed sections: [material], [adhesion], [sphere], [spring], [damping], [base], [contact], [initial], [[stage]], [solver], [output]"),
            "{e}"
        );
    }

    #[test]
    fn minimal_scenario_gets_documented_defaults() {
        let s = parse_scenario(MINIMAL, "min.toml", None).unwrap();
        assert_eq!(s.rig.material, Material::PAPER);
        assert_eq!(s.rig.law, Law::Constant(ConstantW { w0: 0.24 }));
        assert_eq!(
            s.rig.sphere,
            Sphere {
                mass: 3e-3,
                gravity: DEFAULT_GRAVITY
            }
        );
        assert_eq!(s.rig.holder, Holder::Spring { stiffness: 200.0 });
        assert_eq!(s.rig.damping, None);
        assert_eq!(s.rig.base, None);
        assert_eq!(s.rig.formation, ContactFormation::JumpIn);
        assert_eq!(s.initial, Initial::Preload(0.02));
        assert_eq!(s.solver, Solver::default());
        assert_eq!(s.output, Output::default());
        assert_eq!(
            s.stages,
            vec![Stage {
                kind: StageKind::Unload,
                speed: 5e-6,
                until: Until::PullOff,
                vibration: None,
                max_duration: DEFAULT_MAX_DURATION,
            }]
        );
        assert_eq!(&*s.source_text, MINIMAL);
        assert_eq!(s.source_name, "min.toml");
        assert!(s.overrides.is_empty());
    }

    #[test]
    fn quantities_with_units_are_converted_to_si() {
        let text = MINIMAL
            .replace("R = 0.051", "R = \"51mm\"")
            .replace("stiffness = 200", "stiffness = \"0.2N/mm\"")
            .replace("speed = 5e-6", "speed = \"5um/s\"");
        let s = parse_scenario(&text, "u.toml", None).unwrap();
        assert!((s.rig.material.r - 0.051).abs() < 1e-15);
        assert_eq!(s.rig.holder, Holder::Spring { stiffness: 200.0 });
        assert!((s.stages[0].speed - 5e-6).abs() < 1e-20);
        let e = parse_scenario(
            &MINIMAL.replace("R = 0.051", "R = \"51Hz\""),
            "u.toml",
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("u.toml: material.R = \"51Hz\": unknown unit 'Hz'"),
            "{e}"
        );
    }

    #[test]
    fn error_display_names_file_key_value_and_range() {
        let e = parse_scenario(
            &MINIMAL.replace("speed = 5e-6", "speed = -1"),
            "scenarios/x.toml",
            None,
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "scenarios/x.toml: stage[0].speed = -1: must be a finite number > 0 (m/s)"
        );
        assert_eq!(e.key(), Some("stage[0].speed"));
        assert_eq!(e.file(), "scenarios/x.toml");
    }

    #[test]
    fn syntax_error_reports_line_and_column() {
        let text = "version = 1\n[material]\nK = = 3\n";
        let e = parse_scenario(text, "s.toml", None).unwrap_err();
        match e {
            ScenarioError::Syntax { line, column, .. } => {
                assert_eq!(line, 3);
                assert!(column >= 3, "column {column}");
            }
            other => panic!("expected a syntax error, got {other}"),
        }
    }

    #[test]
    fn material_and_law_ignores_the_protocol_but_checks_unknown_sections() {
        let text = "[material]\nK = 1e6\nR = 0.01\nw0 = 0.1\n[adhesion]\nlaw = \"gent-schultz\"\nv0 = 1e-5\nn = 0.5\n";
        let (m, law) = parse_material_and_law(text, "m.toml", None).unwrap();
        assert_eq!(
            m,
            Material {
                k: 1e6,
                r: 0.01,
                w0: 0.1
            }
        );
        assert_eq!(
            law,
            Law::GentSchultz(GentSchultz {
                w0: 0.1,
                v0: 1e-5,
                n: 0.5
            })
        );
        let (_, law) = parse_material_and_law(MINIMAL, "min.toml", None).unwrap();
        assert_eq!(law, Law::Constant(ConstantW { w0: 0.24 }));
        let e = parse_material_and_law(&format!("{text}[bogus]\nx = 1\n"), "m.toml", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("[bogus]"), "{e}");
    }

    #[test]
    fn no_spring_defaults_the_initial_state_to_the_weight() {
        let text = MINIMAL
            .replace("[spring]\nstiffness = 200\n", "")
            .replace("[initial]\npreload = 0.02\n", "")
            .replace(
                "kind = \"unload\"\nspeed = 5e-6\nuntil = \"pull-off\"",
                "kind = \"hold\"\nduration = 1.0",
            );
        let s = parse_scenario(&text, "w.toml", None).unwrap();
        assert_eq!(s.rig.holder, Holder::None);
        assert_eq!(s.initial, Initial::Preload(3e-3 * DEFAULT_GRAVITY));
    }

    /// A TOML value as the format-neutral tree (the test's own conversion, independent of the
    /// library's tree → table one).
    fn to_tree(v: &Value) -> Tree {
        match v {
            Value::Boolean(b) => Tree::Bool(*b),
            Value::Integer(i) => Tree::Int(*i),
            Value::Float(x) => Tree::Float(*x),
            Value::String(t) => Tree::Text(t.clone()),
            Value::Array(a) => Tree::List(a.iter().map(to_tree).collect()),
            Value::Table(t) => {
                Tree::Table(t.iter().map(|(k, v)| (k.clone(), to_tree(v))).collect())
            }
            Value::Datetime(_) => unreachable!("no dates in a scenario"),
        }
    }

    #[test]
    fn a_tree_validates_as_the_file_it_holds() {
        for file in [
            "scenarios/paper-protocol-300hz.toml",
            "scenarios/impacts.toml",
        ] {
            let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
            let from_file = load_scenario(&path).unwrap();
            let text = std::fs::read_to_string(&path).unwrap();
            let Tree::Table(top) = to_tree(&Value::Table(text.parse::<Table>().unwrap())) else {
                unreachable!()
            };
            let src = ScenarioSource::from_tree(top, "<dict>", None).unwrap();
            let mut from_tree = src.scenario(&[]).unwrap();
            assert_eq!(from_tree.source_name, "<dict>");
            // The record is the tree written as a file: it parses back to the same scenario.
            assert_eq!(
                parse_scenario(src.text(), "<dict>", None).unwrap(),
                from_tree
            );
            from_tree.source_name = from_file.source_name.clone();
            from_tree.source_text = from_file.source_text.clone();
            assert_eq!(from_tree, from_file, "{file}");
            assert_eq!(
                src.material_and_law().unwrap(),
                material_and_law(&path).unwrap()
            );
        }
    }

    #[test]
    fn a_tree_is_held_to_a_file_s_limits() {
        let twice = vec![
            ("version".to_string(), Tree::Int(1)),
            ("version".to_string(), Tree::Int(1)),
        ];
        let e = ScenarioSource::from_tree(twice, "<dict>", None).unwrap_err();
        assert_eq!(e.to_string(), "<dict>: version: given twice");
        let mut deep = Tree::Int(1);
        for _ in 0..=MAX_TREE_DEPTH {
            deep = Tree::List(vec![deep]);
        }
        let e = ScenarioSource::from_tree(vec![("x".into(), deep)], "<dict>", None).unwrap_err();
        assert!(e.to_string().contains("nested more than 80 deep"), "{e}");
        let big = Tree::Text("x".repeat(InputKind::Scenario.limit() as usize));
        let e = ScenarioSource::from_tree(vec![("title".into(), big)], "<dict>", None).unwrap_err();
        assert!(e.to_string().contains("larger than 1048576 bytes"), "{e}");
    }
}
