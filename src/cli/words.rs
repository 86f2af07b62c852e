//! The command line's words for the library's errors ([`crate::error::Words`]): an input is the
//! flag that gives it (`a_amp` is `--a-amp`), overrides are `--set K=V`, a sweep's axis is
//! `--set K=SPEC`.

use crate::error::Words;

/// The command line's [`Words`].
pub struct Flags;

/// Request fields whose flag is not the field's name with `-` for `_`.
const RENAMED: &[(&str, &str)] = &[("modulus", "--modulus")];

impl Words for Flags {
    fn input(&self, name: &str) -> String {
        if name.starts_with('-') || name.contains('.') || name.contains(' ') {
            // Already a flag, or a scenario key (`material.K`), or words.
            return name.to_string();
        }
        match RENAMED.iter().find(|(n, _)| *n == name) {
            Some((_, flag)) => flag.to_string(),
            None => format!("--{}", name.replace('_', "-")),
        }
    }
    fn overrides(&self, items: &[String]) -> String {
        items
            .iter()
            .map(|i| format!("--set {i}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
    fn malformed_override(&self, set: &str) -> String {
        format!("--set {set}")
    }
    fn axis(&self, spec: &str) -> String {
        format!("--set {spec}")
    }
    fn input_value(&self, name: &str, value: &str) -> String {
        format!("{} {value}", self.input(name))
    }
}

/// One error of a chain in the command line's words: the library's errors worded by [`Flags`],
/// any other as it displays itself.
pub fn cause_text(cause: &(dyn std::error::Error + 'static)) -> String {
    use crate::error::Error;
    use crate::scenario::overrides::OverrideError;
    use crate::scenario::parse::ScenarioError;
    use crate::sweep::{SpecError, SweepError};
    if let Some(e) = cause.downcast_ref::<Error>() {
        e.in_words(&Flags)
    } else if let Some(e) = cause.downcast_ref::<ScenarioError>() {
        e.in_words(&Flags)
    } else if let Some(e) = cause.downcast_ref::<OverrideError>() {
        e.in_words(&Flags)
    } else if let Some(e) = cause.downcast_ref::<SpecError>() {
        e.in_words(&Flags)
    } else if let Some(e) = cause.downcast_ref::<SweepError>() {
        e.in_words(&Flags)
    } else if let Some(e) = cause.downcast_ref::<djkr_core::continuation::ContinuationError>() {
        crate::error::continuation_in_words(e, &Flags)
    } else {
        crate::error::render(&cause.to_string(), &Flags)
    }
}

/// An error and its causes in the command line's words, joined by `: ` (a cause whose text the
/// message already holds is left out).
pub fn text(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let t = cause_text(cause);
        if t.is_empty() || out.contains(&t) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&t);
    }
    out
}
