//! Why a scenario was rejected ([`ScenarioError`]), and how values are shown in its messages:
//! shared by the parser, `--set` and typed setting, none of which owns the others.

use std::fmt;

use toml::Value;

use crate::input::InputError;
use crate::words::{render, Plain, Source, Words};
use djkr_core::text::excerpt;

/// Why a scenario file was rejected. Every variant names where the scenario came from (its file
/// and the overrides applied to it, [`Source`]); value errors also name the dotted key, the value
/// as written and what is allowed. The overrides are worded by each front end
/// ([`ScenarioError::in_words`]); `Display` uses the library's own words ([`Plain`]).
#[derive(Debug)]
pub enum ScenarioError {
    /// The file could not be read: missing, unreadable, not a regular file, too large or not
    /// text ([`crate::input::read_text`]).
    Io {
        /// The file.
        source: Source,
        /// Why (shown in the message, so not also chained as a `source`, which made the command
        /// line print it twice).
        cause: InputError,
    },
    /// TOML syntax error.
    Syntax {
        /// The file.
        source: Source,
        /// 1-based line.
        line: usize,
        /// 1-based column (in characters).
        column: usize,
        /// What the TOML parser said.
        message: String,
    },
    /// A value of the wrong type or out of range.
    Value {
        /// The file and its overrides.
        source: Source,
        /// Dotted key, e.g. `stage[1].speed`.
        key: String,
        /// The value as written.
        value: String,
        /// What is allowed (with units), or what is wrong with the value.
        allowed: String,
    },
    /// A key or section that is missing, unknown, or in conflict with another.
    Key {
        /// The file and its overrides.
        source: Source,
        /// Dotted key or section, e.g. `material.K`, `[foo]`, `stage[0]`.
        key: String,
        /// What is wrong and what is expected.
        message: String,
    },
    /// Valid values that the simulator cannot run together (a massless sphere with damping, an
    /// explicit method on a rate-independent law): what it would refuse when setting the run up.
    Setup {
        /// The file and its overrides.
        source: Source,
        /// What cannot be simulated, and what to change.
        message: String,
    },
    /// An override that does not fit the file (a stage it does not have), or whose value the
    /// file's rules reject: named by the override rather than by the file's key and value.
    Override {
        /// The file the override was applied to.
        source: Source,
        /// The override, `KEY=VALUE`.
        set: String,
        /// Its dotted key.
        key: String,
        /// What is wrong, and what is allowed.
        message: String,
    },
}

impl ScenarioError {
    /// Where the scenario came from.
    pub fn source(&self) -> &Source {
        match self {
            ScenarioError::Io { source, .. }
            | ScenarioError::Syntax { source, .. }
            | ScenarioError::Value { source, .. }
            | ScenarioError::Key { source, .. }
            | ScenarioError::Setup { source, .. }
            | ScenarioError::Override { source, .. } => source,
        }
    }

    /// The file the error is about.
    pub fn file(&self) -> &str {
        &self.source().file
    }

    /// The dotted key the error is about, when there is one.
    pub fn key(&self) -> Option<&str> {
        match self {
            ScenarioError::Value { key, .. }
            | ScenarioError::Key { key, .. }
            | ScenarioError::Override { key, .. } => Some(key),
            _ => None,
        }
    }

    /// The message in the words of a front end (`w`): the overrides as it takes them.
    pub fn in_words(&self, w: &dyn Words) -> String {
        let at = |s: &Source| s.words(w);
        let text = match self {
            ScenarioError::Io { source, cause } => format!("{}: {cause}", at(source)),
            ScenarioError::Syntax {
                source,
                line,
                column,
                message,
            } => format!(
                "{}: TOML syntax error at line {line}, column {column}: {message}",
                at(source)
            ),
            ScenarioError::Value {
                source,
                key,
                value,
                allowed,
            } => format!(
                "{}: {} = {}: {allowed}",
                at(source),
                excerpt(key),
                excerpt(value)
            ),
            ScenarioError::Key {
                source,
                key,
                message,
            } => format!("{}: {}: {message}", at(source), excerpt(key)),
            ScenarioError::Setup { source, message } => format!("{}: {message}", at(source)),
            ScenarioError::Override { set, message, .. } => {
                format!("{}: {message}", w.overrides(&[excerpt(set)]))
            }
        };
        render(&text, w)
    }
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.in_words(&Plain))
    }
}

impl std::error::Error for ScenarioError {}

/// Shows a float as a user would write it: shortest round-trip digits, exponent form outside
/// [1e-3, 1e9), TOML's spelling of non-finite values.
pub fn show_float(x: f64) -> String {
    if x.is_nan() {
        "nan".to_string()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.to_string()
    } else if x == 0.0 || (1e-3..1e9).contains(&x.abs()) {
        // As TOML writes it (`Value::Float(x).to_string()`, which goes through a document
        // writer: a continuation formats a value per period): a whole number gets `.0`.
        if x.fract() == 0.0 {
            format!("{x:.1}")
        } else {
            format!("{x}")
        }
    } else {
        format!("{x:e}")
    }
}

/// Shows a TOML value as it would be written (strings quoted).
pub fn show(v: &Value) -> String {
    match v {
        Value::Table(_) => "(a table)".to_string(),
        Value::Float(f) => show_float(*f),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `show_float` writes a number between 1e-3 and 1e9 (and a zero) as TOML does, without
    /// TOML's writer: checked against it on whole numbers, zeros of both signs, the ends of the
    /// range and 200 000 values of random bits.
    #[test]
    fn show_float_writes_what_toml_writes() {
        let mut xs = vec![
            0.0,
            -0.0,
            1e-3,
            -1e-3,
            0.1,
            1.5,
            300.0,
            -300.0,
            999_999_999.0,
        ];
        xs.extend([
            123_456_789.0,
            1e9 - 0.5,
            2.0f64.powi(29),
            1.0 / 3.0,
            0.000_999_999,
        ]);
        let mut state = 0x9E37_79B9_7F4A_7C15_u64;
        while xs.len() < 200_000 {
            // xorshift64*: random bits; a third of them rounded to a whole number.
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            let bits = state.wrapping_mul(0x2545_F491_4F6C_DD1D);
            let x = f64::from_bits(bits);
            if x.is_finite() && (1e-3..1e9).contains(&x.abs()) {
                xs.push(if bits.is_multiple_of(3) { x.round() } else { x });
            }
        }
        for x in xs {
            if x == 0.0 || (1e-3..1e9).contains(&x.abs()) {
                assert_eq!(show_float(x), Value::Float(x).to_string(), "{x:e}");
            }
        }
    }
}
