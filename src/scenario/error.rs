//! Why a scenario was rejected ([`ScenarioError`]), and how values are shown in its messages:
//! shared by the parser, `--set` and typed setting, none of which owns the others.

use thiserror::Error;
use toml::Value;

use crate::input::InputError;
use djkr_core::text::excerpt;

/// Why a scenario file was rejected. Every variant names the file; value errors also name the
/// dotted key, the value as written and what is allowed.
#[derive(Debug, Error)]
pub enum ScenarioError {
    /// The file could not be read: missing, unreadable, not a regular file, too large or not
    /// text ([`crate::input::read_text`]).
    #[error("{file}: {cause}")]
    Io {
        /// The file.
        file: String,
        /// Why (shown in the message, so not also chained as a `source`, which made the command
        /// line print it twice).
        cause: InputError,
    },
    /// TOML syntax error.
    #[error("{file}: TOML syntax error at line {line}, column {column}: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column (in characters).
        column: usize,
        /// What the TOML parser said.
        message: String,
    },
    /// A value of the wrong type or out of range.
    #[error("{file}: {} = {}: {allowed}", excerpt(.key), excerpt(.value))]
    Value {
        /// The file.
        file: String,
        /// Dotted key, e.g. `stage[1].speed`.
        key: String,
        /// The value as written.
        value: String,
        /// What is allowed (with units), or what is wrong with the value.
        allowed: String,
    },
    /// A key or section that is missing, unknown, or in conflict with another.
    #[error("{file}: {}: {message}", excerpt(.key))]
    Key {
        /// The file.
        file: String,
        /// Dotted key or section, e.g. `material.K`, `[foo]`, `stage[0]`.
        key: String,
        /// What is wrong and what is expected.
        message: String,
    },
    /// Valid values that the simulator cannot run together (a massless sphere with damping, an
    /// explicit method on a rate-independent law): what it would refuse when setting the run up.
    #[error("{file}: {message}")]
    Setup {
        /// The file.
        file: String,
        /// What cannot be simulated, and what to change.
        message: String,
    },
    /// A `--set KEY=VALUE` override that does not fit the file (a stage it does not have), or
    /// whose value the file's rules reject: named by the override rather than by the file's key
    /// and value.
    #[error("--set {}: {message}", excerpt(.set))]
    Override {
        /// The file the override was applied to.
        file: String,
        /// The override, `KEY=VALUE`.
        set: String,
        /// Its dotted key.
        key: String,
        /// What is wrong, and what is allowed.
        message: String,
    },
}

impl ScenarioError {
    /// The file the error is about.
    pub fn file(&self) -> &str {
        match self {
            ScenarioError::Io { file, .. }
            | ScenarioError::Syntax { file, .. }
            | ScenarioError::Value { file, .. }
            | ScenarioError::Key { file, .. }
            | ScenarioError::Setup { file, .. }
            | ScenarioError::Override { file, .. } => file,
        }
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
}

/// Shows a float as a user would write it: shortest round-trip digits, exponent form outside
/// [1e-3, 1e9), TOML's spelling of non-finite values.
pub fn show_float(x: f64) -> String {
    if x.is_nan() {
        "nan".to_string()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.to_string()
    } else if x == 0.0 || (1e-3..1e9).contains(&x.abs()) {
        Value::Float(x).to_string()
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
