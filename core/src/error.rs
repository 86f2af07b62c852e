//! Library error types. Every error names where it came from (a flag, a key, a time and state) and,
//! for an out-of-range value, what is allowed.

use thiserror::Error;

/// A parameter outside its allowed range, or malformed. Its message quotes the value (and the
/// name, which may hold a file's path) through [`crate::text::excerpt`]: at most 80 characters.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{} = {}: {allowed}", crate::text::excerpt(.name), crate::text::excerpt(.value))]
pub struct ParamError {
    /// Name of the parameter as the user spells it (flag, scenario key, or symbol).
    pub name: String,
    /// The offending value, as given.
    pub value: String,
    /// What is allowed, in words, with units.
    pub allowed: String,
}

impl ParamError {
    /// Build an error for parameter `name` with value `value` and an `allowed` description.
    pub fn new(name: impl Into<String>, value: impl ToString, allowed: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            value: value.to_string(),
            allowed: allowed.into(),
        }
    }

    /// Same error, renamed (e.g. from the symbol `R` to the flag `--radius`).
    pub fn renamed(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }
}

/// Require `value` to be finite and strictly positive.
pub fn positive(name: &str, value: f64, unit: &str) -> Result<f64, ParamError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ParamError::new(
            name,
            value,
            format!("must be a finite number > 0{}", unit_suffix(unit)),
        ))
    }
}

/// Require `value` to be finite and ≥ 0.
pub fn non_negative(name: &str, value: f64, unit: &str) -> Result<f64, ParamError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(ParamError::new(
            name,
            value,
            format!("must be a finite number >= 0{}", unit_suffix(unit)),
        ))
    }
}

/// Require `lo <= value <= hi` (finite).
pub fn in_range(name: &str, value: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, ParamError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(value)
    } else {
        Err(ParamError::new(
            name,
            value,
            format!("must lie in [{lo}, {hi}]{}", unit_suffix(unit)),
        ))
    }
}

/// Why `value` is refused as subnormal (not 0, of magnitude below `f64::MIN_POSITIVE`), or
/// `None`: a subnormal input has lost digits and its reciprocal overflows. Every value djkr
/// reads, a scenario key or a flag, is held to this one rule; `allowed` completes the sentence
/// (`must be {allowed}`), e.g. `a normal finite number > 0 (m)`.
pub fn subnormal_error(value: f64, allowed: &str) -> Option<String> {
    (value != 0.0 && value.abs() < f64::MIN_POSITIVE).then(|| {
        format!(
            "is subnormal (below {:e}): must be {allowed}",
            f64::MIN_POSITIVE
        )
    })
}

fn unit_suffix(unit: &str) -> String {
    if unit.is_empty() {
        String::new()
    } else {
        format!(" ({unit})")
    }
}
