//! Overrides of scenario values (`djkr run FILE --set base.amplitude=30um`): one value changed
//! without editing the file.
//!
//! An override is applied to the file's generic TOML table *before* the section walk of
//! [`parse`](super::parse), so every range check and every message of a file is reused, and
//! `djkr run FILE --set K=V` is exactly `djkr run EDITED` where EDITED is FILE with `K = V`
//! written in it.
//!
//! **Keys** are the dotted keys that error messages print:
//!
//! | form | example |
//! |---|---|
//! | `KEY` (top level) | `version` |
//! | `SECTION.KEY` | `base.amplitude`, `adhesion.n`, `solver.rtol` |
//! | `stage[N].KEY` (N from 0, as messages count) | `stage[3].speed`, `stage[0].until` |
//!
//! The keys each section takes come from [`super::keys::KEYS`], the table
//! the parser's unknown-key checks use, so a key added there is at once settable. An absent
//! section is created (`base.amplitude` on a file without `[base]`: validation then asks for
//! `base.frequency`); a stage is not: `stage[N]` must exist in the file.
//!
//! **Values** are read as a TOML literal (number, boolean, quoted string) when they are one, and
//! as a bare string otherwise, so `30um`, `"30um"`, `gent-schultz`, `pull-off` and `true` all mean
//! what they would mean in the file. From a program, a value may also be a number or a boolean
//! ([`SetValue`]).
//!
//! **End conditions.** Setting one of a stage's end conditions (`duration`, `preload`, `until`)
//! *replaces* the end condition the file gives that stage, as "end this stage after 2 s instead"
//! means; setting `duration` also drops the file's `max_duration` of that stage (a safety limit
//! for preload and pull-off ends only). Two overrides that conflict with each other are an
//! error, as they would be in a file.
//!
//! **Errors.** A malformed override or an unknown key is an [`OverrideError`]; an override that
//! does not fit the file (a stage that does not exist) or whose value validation rejects is a
//! [`ScenarioError::Override`] naming the override instead of the file's key and value:
//! `--set base.amplitude=-1um: must be a finite number >= 0 (m)`. Each key may be set once.

use std::fmt;

use toml::{Table, Value};

use super::error::{show, show_float, ScenarioError};
use super::keys::{self, section_keys, STAGE_END_KEYS, STAGE_SECTION};
use crate::words::{input, render, set_item, Plain, Source, Words};
use djkr_core::text::excerpt;

/// A malformed override, or one naming a key no scenario file takes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OverrideError {
    /// The override as given (`KEY=VALUE`, or what was given instead).
    pub set: String,
    /// What is wrong, and what is allowed.
    pub message: String,
}

impl OverrideError {
    /// The message in the words of a front end.
    pub fn in_words(&self, w: &dyn Words) -> String {
        render(
            &format!(
                "{}: {}",
                w.malformed_override(&excerpt(&self.set)),
                self.message
            ),
            w,
        )
    }
}

impl fmt::Display for OverrideError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.in_words(&Plain))
    }
}

impl std::error::Error for OverrideError {}

/// A key of a scenario file, as error messages print it: `version`, `base.amplitude`,
/// `stage[3].speed`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SetKey {
    section: Option<&'static str>,
    index: Option<usize>,
    name: &'static str,
}

impl SetKey {
    /// Parse a dotted key, checking that a scenario file takes it (the section and key exist,
    /// `stage` has an index and no other section has one).
    pub fn parse(text: &str) -> Result<SetKey, OverrideError> {
        parse_key(text.trim()).map_err(|message| OverrideError {
            set: text.to_string(),
            message,
        })
    }

    /// The section (`None`: a top-level key such as `version`).
    pub fn section(&self) -> Option<&'static str> {
        self.section
    }

    /// The stage index (0-based) of a `stage[N].KEY`.
    pub fn index(&self) -> Option<usize> {
        self.index
    }

    /// The key within its section.
    pub fn name(&self) -> &'static str {
        self.name
    }
}

impl fmt::Display for SetKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.section, self.index) {
            (None, _) => write!(f, "{}", self.name),
            (Some(s), None) => write!(f, "{s}.{}", self.name),
            (Some(s), Some(i)) => write!(f, "{s}[{i}].{}", self.name),
        }
    }
}

/// The value of an override: text as a user types it (read as a TOML literal when it is one,
/// otherwise as a bare string: `30um`, `pull-off`), or a number or boolean from a program.
#[derive(Debug, Clone, PartialEq)]
pub enum SetValue {
    /// As typed on the command line.
    Text(String),
    /// A number (SI, as a bare number in the file).
    Float(f64),
    /// An integer (for keys that need one, such as `version`).
    Integer(i64),
    /// A boolean.
    Bool(bool),
}

impl From<&str> for SetValue {
    fn from(t: &str) -> Self {
        SetValue::Text(t.to_string())
    }
}

impl From<String> for SetValue {
    fn from(t: String) -> Self {
        SetValue::Text(t)
    }
}

impl From<f64> for SetValue {
    fn from(x: f64) -> Self {
        SetValue::Float(x)
    }
}

impl From<i64> for SetValue {
    fn from(i: i64) -> Self {
        SetValue::Integer(i)
    }
}

impl From<bool> for SetValue {
    fn from(b: bool) -> Self {
        SetValue::Bool(b)
    }
}

impl SetValue {
    /// The TOML value the file would hold, and the value as shown in messages.
    fn to_toml(&self) -> Result<(Value, String), String> {
        Ok(match self {
            SetValue::Text(t) => {
                let t = t.trim();
                if t.is_empty() {
                    return Err("empty value: expected KEY=VALUE, e.g. base.amplitude=30um".into());
                }
                let v = match t.parse::<Value>() {
                    Ok(
                        v @ (Value::Integer(_)
                        | Value::Float(_)
                        | Value::Boolean(_)
                        | Value::String(_)),
                    ) => v,
                    _ => Value::String(t.to_string()),
                };
                (v, t.to_string())
            }
            SetValue::Float(x) => (Value::Float(*x), show_float(*x)),
            SetValue::Integer(i) => (Value::Integer(*i), i.to_string()),
            SetValue::Bool(b) => (Value::Boolean(*b), b.to_string()),
        })
    }
}

/// One override: a key of the file and the value to give it.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    key: SetKey,
    value: Value,
    shown: String,
}

impl Override {
    /// Each of `sets` (`KEY=VALUE`) by [`Override::parse`], in order; the first error stops.
    pub fn parse_all<S: AsRef<str>>(sets: &[S]) -> Result<Vec<Override>, OverrideError> {
        sets.iter().map(|t| Override::parse(t.as_ref())).collect()
    }

    /// Parse `KEY=VALUE` as typed after `--set` (split at the first `=`; spaces around either
    /// side are ignored).
    pub fn parse(arg: &str) -> Result<Override, OverrideError> {
        let err = |message: String| OverrideError {
            set: arg.to_string(),
            message,
        };
        let Some((key, value)) = arg.split_once('=') else {
            return Err(err(
                "expected KEY=VALUE, e.g. base.amplitude=30um or stage[0].speed=1mm/s".into(),
            ));
        };
        let key = parse_key(key.trim()).map_err(err)?;
        Self::from_key(key, value).map_err(|e| OverrideError {
            set: arg.into(),
            ..e
        })
    }

    /// An override from a key (dotted, as in [`SetKey::parse`]) and a value: text with units as
    /// typed, or a number or boolean.
    pub fn new(key: &str, value: impl Into<SetValue>) -> Result<Override, OverrideError> {
        let value = value.into();
        let key = parse_key(key.trim()).map_err(|message| OverrideError {
            set: format!("{}={}", key.trim(), shown_raw(&value)),
            message,
        })?;
        Self::from_key(key, value)
    }

    /// An override of an already parsed key (a sweep parses its keys once).
    pub fn from_key(key: SetKey, value: impl Into<SetValue>) -> Result<Override, OverrideError> {
        let value = value.into();
        let (value, shown) = value.to_toml().map_err(|message| OverrideError {
            set: format!("{key}={}", shown_raw(&value)),
            message,
        })?;
        Ok(Override { key, value, shown })
    }

    /// The key.
    pub fn key(&self) -> SetKey {
        self.key
    }

    /// The value, as the file would hold it.
    pub(crate) fn value(&self) -> &Value {
        &self.value
    }
}

/// `KEY=VALUE`, the value as given.
impl fmt::Display for Override {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}={}", self.key, self.shown)
    }
}

fn shown_raw(v: &SetValue) -> String {
    match v {
        SetValue::Text(t) => t.trim().to_string(),
        SetValue::Float(x) => show_float(*x),
        SetValue::Integer(i) => i.to_string(),
        SetValue::Bool(b) => b.to_string(),
    }
}

/// The grammar of keys, with the message a user needs when one is wrong.
fn parse_key(t: &str) -> Result<SetKey, String> {
    if t.is_empty() {
        return Err("empty key: expected KEY=VALUE, e.g. base.amplitude=30um".into());
    }
    let Some((head, name)) = t.split_once('.') else {
        return top_level_key(t);
    };
    if name.contains('.') {
        return Err(format!(
            "malformed key '{}': keys are KEY, SECTION.KEY or stage[N].KEY (one dot), e.g. base.amplitude",
            excerpt(t)
        ));
    }
    let (section, index) = match head.split_once('[') {
        None => (head, None),
        Some((s, rest)) => {
            let Some(digits) = rest.strip_suffix(']') else {
                return Err(format!(
                    "malformed index in '{}': write {}[N].{} with N a whole number >= 0",
                    excerpt(t),
                    excerpt(s),
                    excerpt(name)
                ));
            };
            let i = digits
                .parse::<usize>()
                .ok()
                .filter(|_| digits.bytes().all(|b| b.is_ascii_digit()));
            match i {
                Some(i) => (s, Some(i)),
                None => {
                    return Err(format!(
                        "bad index '{}' in '{}': stages count from 0, write {s}[0].{name}, \
                         {s}[1].{name}, ...",
                        excerpt(digits),
                        excerpt(t),
                        s = excerpt(s),
                        name = excerpt(name)
                    ))
                }
            }
        }
    };
    let Some((section, keys)) = keys::SECTIONS
        .iter()
        .find(|s| **s == section)
        .and_then(|s| Some((*s, section_keys(s)?)))
    else {
        return Err(format!(
            "unknown section '{}'; the sections are {}",
            excerpt(section),
            section_names()
        ));
    };
    match (section == STAGE_SECTION, index) {
        (true, None) => {
            return Err(format!(
                "[[{section}]] is a list: give the stage's index (from 0), e.g. {section}[0].{}",
                excerpt(name)
            ))
        }
        (false, Some(_)) => {
            return Err(format!(
                "[{section}] is a single table, not a list: write {section}.{}",
                excerpt(name)
            ))
        }
        _ => {}
    }
    if name.is_empty() {
        return Err(format!(
            "no key after '{}.'; {} takes {}",
            excerpt(head),
            shown_section(section),
            keys.join(", ")
        ));
    }
    match keys.iter().find(|k| **k == name) {
        Some(&name) => Ok(SetKey {
            section: Some(section),
            index,
            name,
        }),
        None => {
            let hint = keys
                .iter()
                .find(|k| k.eq_ignore_ascii_case(name))
                .map(|k| format!(" (did you mean {}.{k}?)", excerpt(head)))
                .unwrap_or_default();
            Err(format!(
                "unknown key{hint}; {} takes {}",
                shown_section(section),
                keys.join(", ")
            ))
        }
    }
}

/// A key without a dot: a top-level key, or a section or section key written without it.
fn top_level_key(t: &str) -> Result<SetKey, String> {
    if let Some(name) = top_level_keys().iter().copied().find(|k| *k == t) {
        return Ok(SetKey {
            section: None,
            index: None,
            name,
        });
    }
    let bare = t.split_once('[').map_or(t, |(s, _)| s);
    if let Some(keys) = section_keys(bare) {
        let example = if bare == STAGE_SECTION {
            format!("{bare}[0].{}", keys.first().copied().unwrap_or("kind"))
        } else {
            format!("{bare}.{}", keys.first().copied().unwrap_or("KEY"))
        };
        return Err(format!(
            "{} is a section: set one of its keys, e.g. {example} ({} takes {})",
            shown_section(bare),
            shown_section(bare),
            keys.join(", ")
        ));
    }
    let homes: Vec<String> = keys::KEYS
        .iter()
        .filter(|k| !k.section.is_empty() && k.name == t)
        .map(|k| {
            let s = &k.section;
            if *s == STAGE_SECTION {
                format!("{s}[N].{t}")
            } else {
                format!("{s}.{t}")
            }
        })
        .collect();
    let hint = if homes.is_empty() {
        String::new()
    } else {
        format!(" (did you mean {}?)", homes.join(" or "))
    };
    Err(format!(
        "unknown key{hint}; the top level takes {}, and the sections' keys are written SECTION.KEY \
         (e.g. base.amplitude, stage[0].speed)",
        top_level_keys().join(", ")
    ))
}

/// The keys of the top level that are not sections (`version`).
fn top_level_keys() -> &'static [&'static str] {
    section_keys("").unwrap_or_default()
}

fn shown_section(s: &str) -> String {
    if s == STAGE_SECTION {
        format!("[[{s}]]")
    } else {
        format!("[{s}]")
    }
}

/// The sections as keys spell them: `material, ..., stage[N], ...`.
fn section_names() -> String {
    keys::SECTIONS
        .iter()
        .map(|s| {
            if *s == STAGE_SECTION {
                format!("{s}[N]")
            } else {
                (*s).to_string()
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// `file --set K=V --set K2=V2`: what a scenario with overrides is called in messages and
/// records.
pub(crate) fn describe(file: &str, overrides: &[String]) -> String {
    let mut s = file.to_string();
    for o in overrides {
        s.push_str(" --set ");
        s.push_str(o);
    }
    s
}

/// Write the overrides into the file's table (`file` names it in errors).
pub(crate) fn apply(
    table: &mut Table,
    overrides: &[Override],
    file: &Source,
) -> Result<(), ScenarioError> {
    let err = |o: &Override, message: String| ScenarioError::Override {
        source: file.clone(),
        set: o.to_string(),
        key: o.key.to_string(),
        message,
    };
    for (i, o) in overrides.iter().enumerate() {
        if let Some(first) = overrides[..i].iter().find(|p| p.key == o.key) {
            return Err(err(
                o,
                format!(
                    "{} is already set by {}; set each key once",
                    o.key,
                    set_item(&first.to_string())
                ),
            ));
        }
    }
    for o in overrides {
        let key = o.key;
        let target: &mut Table = match (key.section, key.index) {
            (None, _) => &mut *table,
            (Some(s), None) => {
                match table
                    .entry(s.to_string())
                    .or_insert_with(|| Value::Table(Table::new()))
                {
                    Value::Table(t) => t,
                    other => {
                        let shown = show(other);
                        return Err(err(
                        o,
                        format!("{file} gives {s} = {shown}, not a section [{s}]: fix the file first"),
                    ));
                    }
                }
            }
            (Some(s), Some(i)) => {
                let stages = match table.get_mut(s) {
                    Some(Value::Array(a)) => a,
                    None => {
                        return Err(err(
                            o,
                            format!(
                                "{file} has no [[{s}]]; {} changes stages, it does not add them",
                                input("set")
                            ),
                        ))
                    }
                    Some(other) => {
                        let shown = show(other);
                        return Err(err(
                            o,
                            format!("{file} gives {s} = {shown}, not a list of [[{s}]] tables: fix the file first"),
                        ));
                    }
                };
                let n = stages.len();
                match stages.get_mut(i) {
                    Some(Value::Table(t)) => t,
                    Some(other) => {
                        let shown = show(other);
                        return Err(err(
                            o,
                            format!("{file} gives {s}[{i}] = {shown}, not a [[{s}]] table: fix the file first"),
                        ));
                    }
                    None => {
                        let range = match n {
                            0 => "none".to_string(),
                            1 => format!("only {s}[0]"),
                            _ => format!("{s}[0] to {s}[{}]", n - 1),
                        };
                        return Err(err(
                            o,
                            format!(
                                "no such stage: {file} has {n} stage(s) ({range}; stages count from 0); {} does not add stages",
                                input("set")
                            ),
                        ));
                    }
                }
            }
        };
        if key.section == Some(STAGE_SECTION) && STAGE_END_KEYS.contains(&key.name) {
            // The override replaces the file's end condition (and a duration its max_duration),
            // but not one that another override sets: those conflict as they would in a file.
            let set_here = |name: &str| {
                overrides.iter().any(|p| {
                    p.key.section == key.section && p.key.index == key.index && p.key.name == name
                })
            };
            let mut dropped: Vec<&str> = STAGE_END_KEYS
                .iter()
                .copied()
                .filter(|k| *k != key.name)
                .collect();
            if key.name == "duration" {
                dropped.push("max_duration");
            }
            for k in dropped {
                if !set_here(k) {
                    target.remove(k);
                }
            }
        }
        target.insert(key.name.to_string(), o.value.clone());
    }
    Ok(())
}

/// A validation error about a key that an override set, reported as that override's
/// (`--set base.amplitude=-1um: must be ...`) rather than as the file's.
pub(crate) fn attribute(e: ScenarioError, overrides: &[Override], file: &Source) -> ScenarioError {
    let (key, message) = match &e {
        ScenarioError::Value { key, allowed, .. } => (key, allowed),
        ScenarioError::Key { key, message, .. } => (key, message),
        _ => return e,
    };
    match overrides.iter().find(|o| o.key.to_string() == *key) {
        Some(o) => ScenarioError::Override {
            source: file.clone(),
            set: o.to_string(),
            key: key.clone(),
            message: message.clone(),
        },
        None => e,
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // values written exactly, compared exactly
mod tests {
    use super::*;

    fn key(t: &str) -> SetKey {
        SetKey::parse(t).unwrap_or_else(|e| panic!("{e}"))
    }

    fn key_err(t: &str) -> String {
        SetKey::parse(t)
            .unwrap_err()
            .in_words(&crate::words::TestFlags)
    }

    #[test]
    fn keys_parse_as_messages_print_them() {
        for t in [
            "version",
            "base.amplitude",
            "adhesion.n",
            "stage[3].speed",
            "stage[0].until",
            "solver.rtol",
            "material.K",
        ] {
            assert_eq!(key(t).to_string(), t);
        }
        let k = key("stage[12].max_duration");
        assert_eq!(
            (k.section(), k.index(), k.name()),
            (Some("stage"), Some(12), "max_duration")
        );
        assert_eq!(key(" base.amplitude ").to_string(), "base.amplitude");
        assert_eq!(key("stage[007].kind").to_string(), "stage[7].kind");
    }

    #[test]
    fn every_key_of_every_section_is_settable() {
        for section in keys::SECTIONS {
            for k in section_keys(section).unwrap_or_default() {
                let t = if *section == STAGE_SECTION {
                    format!("{section}[0].{k}")
                } else {
                    format!("{section}.{k}")
                };
                assert_eq!(key(&t).to_string(), t);
            }
        }
    }

    #[test]
    fn unknown_keys_list_the_allowed_ones() {
        assert_eq!(
            key_err("base.amplitud"),
            "--set base.amplitud: unknown key; [base] takes amplitude, frequency, phase"
        );
        let e = key_err("bse.amplitude");
        assert!(
            e.starts_with(
                "--set bse.amplitude: unknown section 'bse'; the sections are material, adhesion,"
            ),
            "{e}"
        );
        assert!(e.contains("stage[N]"), "{e}");
        let e = key_err("material.k");
        assert!(e.contains("did you mean material.K?"), "{e}");
        let e = key_err("amplitude");
        assert!(e.contains("did you mean base.amplitude?"), "{e}");
        let e = key_err("preload");
        assert!(
            e.contains("did you mean initial.preload or stage[N].preload?"),
            "{e}"
        );
        let e = key_err("base");
        assert!(e.contains("[base] is a section"), "{e}");
        let e = key_err("stage[1]");
        assert!(
            e.contains("[[stage]] is a section") && e.contains("stage[0].kind"),
            "{e}"
        );
        let e = key_err("stage[0].sped");
        assert!(e.contains("[[stage]] takes kind, speed"), "{e}");
    }

    #[test]
    fn malformed_keys_and_indices_are_named() {
        for (t, want) in [
            ("", "empty key"),
            ("stage.speed", "give the stage's index"),
            ("base[0].amplitude", "[base] is a single table, not a list"),
            ("stage[x].speed", "bad index 'x'"),
            ("stage[-1].speed", "bad index '-1'"),
            ("stage[+1].speed", "bad index '+1'"),
            ("stage[].speed", "bad index ''"),
            ("stage[1.speed", "malformed index"),
            ("base.amplitude.x", "one dot"),
            ("base.", "no key after 'base.'"),
        ] {
            let e = key_err(t);
            assert!(e.contains(want), "{t}: {e}");
        }
    }

    #[test]
    fn values_are_toml_literals_or_bare_strings() {
        let v = |t: &str| Override::parse(t).unwrap().value().clone();
        assert_eq!(v("base.amplitude=30um"), Value::String("30um".into()));
        assert_eq!(v("base.amplitude=\"30um\""), Value::String("30um".into()));
        assert_eq!(v("base.amplitude=3e-5"), Value::Float(3e-5));
        assert_eq!(v("spring.stiffness=200"), Value::Integer(200));
        assert_eq!(v("stage[0].vibration=true"), Value::Boolean(true));
        assert_eq!(
            v("stage[0].until=pull-off"),
            Value::String("pull-off".into())
        );
        assert_eq!(
            v("adhesion.law = gent-schultz"),
            Value::String("gent-schultz".into())
        );
        assert_eq!(v("base.amplitude=-1um"), Value::String("-1um".into()));
        // Not a scalar literal: kept as the text, which validation then rejects by name.
        assert_eq!(v("base.amplitude=[1, 2]"), Value::String("[1, 2]".into()));
        assert_eq!(
            Override::parse("base.amplitude = 30um")
                .unwrap()
                .to_string(),
            "base.amplitude=30um"
        );
    }

    #[test]
    fn program_values_are_numbers_booleans_or_text() {
        let o = Override::new("stage[3].speed", 1e-3).unwrap();
        assert_eq!(o.value(), &Value::Float(1e-3));
        assert_eq!(o.to_string(), "stage[3].speed=0.001");
        assert_eq!(
            Override::new("base.amplitude", "30um").unwrap(),
            Override::parse("base.amplitude=30um").unwrap()
        );
        assert_eq!(
            Override::new("version", 1_i64).unwrap().value(),
            &Value::Integer(1)
        );
        assert_eq!(
            Override::new("output.csv", true).unwrap().value(),
            &Value::Boolean(true)
        );
        let k = SetKey::parse("base.frequency").unwrap();
        assert_eq!(
            Override::from_key(k, 400.0).unwrap().to_string(),
            "base.frequency=400.0"
        );
        let e = Override::new("base.amplitud", 1e-6).unwrap_err();
        assert_eq!(e.set, "base.amplitud=1e-6");
    }

    #[test]
    fn malformed_overrides_are_named() {
        let e = Override::parse("base.amplitude")
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert_eq!(
            e,
            "--set base.amplitude: expected KEY=VALUE, e.g. base.amplitude=30um or stage[0].speed=1mm/s"
        );
        let e = Override::parse("=30um")
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert!(e.starts_with("--set =30um: empty key"), "{e}");
        let e = Override::parse("base.amplitude=")
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert!(e.starts_with("--set base.amplitude=: empty value"), "{e}");
        let e = Override::parse("base.amplitud=30um")
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert_eq!(
            e,
            "--set base.amplitud=30um: unknown key; [base] takes amplitude, frequency, phase"
        );
        // The value may hold '='; the key is what precedes the first one.
        assert_eq!(
            Override::parse("adhesion.file=a=b.csv").unwrap().value(),
            &Value::String("a=b.csv".into())
        );
    }

    // Applying overrides to a scenario.

    use super::super::parse::{parse_scenario, ScenarioSource};
    use super::super::{BaseMotion, StageKind, Until};

    const FILE: &str = r#"
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
kind = "approach"
speed = 1e-4
preload = 0.05
max_duration = 10
[[stage]]
kind = "unload"
speed = 5e-6
until = "pull-off"
"#;

    fn source() -> ScenarioSource {
        ScenarioSource::parse(FILE, "x.toml", None).unwrap()
    }

    fn set(list: &[&str]) -> Vec<Override> {
        list.iter().map(|t| Override::parse(t).unwrap()).collect()
    }

    fn with(list: &[&str]) -> Result<crate::scenario::Scenario, ScenarioError> {
        source().scenario(&set(list))
    }

    fn err(list: &[&str]) -> String {
        with(list).unwrap_err().in_words(&crate::words::TestFlags)
    }

    #[test]
    fn an_override_equals_the_edited_file() {
        let edited = FILE.replace("speed = 5e-6", "speed = \"2um/s\"");
        let want = parse_scenario(&edited, "x.toml", None).unwrap();
        let got = with(&["stage[1].speed=2um/s"]).unwrap();
        assert_eq!(got.stages, want.stages);
        assert_eq!(got.rig, want.rig);
        assert_eq!(got.overrides, vec!["stage[1].speed=2um/s".to_string()]);
        assert_eq!(got.source_name, "x.toml --set stage[1].speed=2um/s");
        assert_eq!(&*got.source_text, FILE);
        // Without overrides: the file as written, nothing recorded.
        let plain = source().scenario(&[]).unwrap();
        assert_eq!(plain.source_name, "x.toml");
        assert!(plain.overrides.is_empty());
    }

    #[test]
    fn an_absent_section_is_created_and_then_validated() {
        let e = err(&["base.amplitude=30um"]);
        assert_eq!(
            e,
            "x.toml --set base.amplitude=30um: base.frequency: missing: base frequency f (Hz, > 0)"
        );
        let s = with(&["base.amplitude=30um", "base.frequency=0.3kHz"]).unwrap();
        assert_eq!(
            s.rig.base,
            Some(BaseMotion {
                amplitude: 30e-6,
                frequency: 300.0,
                phase: 0.0,
            })
        );
    }

    #[test]
    fn validation_errors_name_the_override() {
        let s = |e: &str| e.to_string();
        let mut f = FILE.to_string();
        f.push_str("[base]\namplitude = 1e-5\nfrequency = 300\n");
        let src = ScenarioSource::parse(&f, "x.toml", None).unwrap();
        let e = src.scenario(&set(&["base.amplitude=-1um"])).unwrap_err();
        assert_eq!(
            e.in_words(&crate::words::TestFlags),
            s("--set base.amplitude=-1um: must be a finite number >= 0 (m)")
        );
        assert_eq!(e.file(), "x.toml");
        assert_eq!(e.key(), Some("base.amplitude"));
        assert!(matches!(e, ScenarioError::Override { .. }));
        assert_eq!(
            err(&["stage[1].speed=3Hz"]),
            "--set stage[1].speed=3Hz: unknown unit 'Hz': expected a number in SI (m/s) or with one of the units m/s, mm/s, um/s, µm/s, nm/s"
        );
        assert_eq!(
            err(&["solver.rtol=1"]),
            "--set solver.rtol=1: must lie in [1e-14, 1e-2] (relative tolerance, dimensionless; below 1e-14 the error estimate is rounding noise)"
        );
        assert_eq!(
            err(&["stage[0].vibration=yes"]),
            "--set stage[0].vibration=yes: must be true or false"
        );
        assert_eq!(
            err(&["stage[0].vibration=true"]),
            "--set stage[0].vibration=true: no [base] section defines the vibration: add [base] with amplitude (m) and frequency (Hz)"
        );
        assert!(err(&["adhesion.law=gent-schultz", "adhesion.v_sat=1"])
            .starts_with("--set adhesion.v_sat=1: unknown key for law = \"gent-schultz\""));
        assert!(err(&["adhesion.law=coulomb"])
            .starts_with("--set adhesion.law=coulomb: must be one of"));
    }

    #[test]
    fn stages_must_exist() {
        assert_eq!(
            err(&["stage[2].speed=1e-5"]),
            "--set stage[2].speed=1e-5: no such stage: x.toml has 2 stage(s) (stage[0] to stage[1]; stages count from 0); --set does not add stages"
        );
        let one = FILE.replace(
            "[[stage]]\nkind = \"approach\"\nspeed = 1e-4\npreload = 0.05\nmax_duration = 10\n",
            "",
        );
        let e = ScenarioSource::parse(&one, "y.toml", None)
            .unwrap()
            .scenario(&set(&["stage[1].speed=1e-5"]))
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert!(e.contains("y.toml has 1 stage(s) (only stage[0];"), "{e}");
        let none = FILE.split("[[stage]]").next().unwrap_or_default();
        let e = ScenarioSource::parse(none, "z.toml", None)
            .unwrap()
            .scenario(&set(&["stage[0].speed=1e-5"]))
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert!(e.contains("z.toml has no [[stage]]"), "{e}");
    }

    #[test]
    fn an_end_condition_replaces_the_files() {
        // The approach ends on a preload with a max_duration: a duration replaces both.
        let s = with(&["stage[0].duration=2s"]).unwrap();
        assert_eq!(s.stages[0].until, Until::Duration(2.0));
        assert_eq!(s.stages[0].max_duration, 2.0);
        // The unload ends at pull-off: a duration replaces it.
        let s = with(&["stage[1].duration=0.5"]).unwrap();
        assert_eq!(s.stages[1].until, Until::Duration(0.5));
        // A preload end keeps the file's max_duration.
        let s = with(&["stage[0].preload=0.1N"]).unwrap();
        assert_eq!(s.stages[0].until, Until::Preload(0.1));
        assert_eq!(s.stages[0].max_duration, 10.0);
        // The file's rules still hold: pull-off is for unload stages.
        assert!(err(&["stage[0].until=pull-off"]).starts_with(
            "--set stage[0].until=pull-off: until = \"pull-off\" is for unload stages only"
        ));
        let s = with(&["stage[0].until=pull-off", "stage[0].kind=unload"]).unwrap();
        assert_eq!(
            (s.stages[0].kind, s.stages[0].until),
            (StageKind::Unload, Until::PullOff)
        );
        // Two overrides that conflict are an error, as in a file.
        let e = err(&["stage[1].duration=1", "stage[1].until=pull-off"]);
        assert!(e.contains("two end conditions"), "{e}");
        let e = err(&["stage[0].duration=1", "stage[0].max_duration=5"]);
        assert!(
            e.starts_with("--set stage[0].max_duration=5: only for stages that end on a preload"),
            "{e}"
        );
    }

    #[test]
    fn each_key_is_set_once() {
        assert_eq!(
            err(&["solver.rtol=1e-6", "solver.rtol=1e-7"]),
            "--set solver.rtol=1e-7: solver.rtol is already set by --set solver.rtol=1e-6; set each key once"
        );
    }

    #[test]
    fn a_section_that_is_not_a_table_is_named() {
        let f = FILE.replacen("version = 1\n", "version = 1\nbase = 3\n", 1);
        let e = ScenarioSource::parse(&f, "x.toml", None)
            .unwrap()
            .scenario(&set(&["base.amplitude=1um"]))
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert_eq!(
            e,
            "--set base.amplitude=1um: x.toml gives base = 3, not a section [base]: fix the file first"
        );
    }

    #[test]
    fn one_parsed_file_serves_many_override_sets() {
        let src = source();
        for (i, speed) in [1e-6, 2e-6, 4e-6].into_iter().enumerate() {
            let o = Override::new("stage[1].speed", speed).unwrap();
            let s = src.scenario(std::slice::from_ref(&o)).unwrap();
            assert_eq!(s.stages[1].speed.to_bits(), speed.to_bits(), "{i}");
        }
        // The source is untouched.
        assert_eq!(
            src.scenario(&[]).unwrap().stages[1].speed.to_bits(),
            5e-6_f64.to_bits()
        );
    }
}
