//! Errors of the library's commands ([`Error`]), and how each front end words them ([`Words`]).
//!
//! An error says what happened and where: the input of the request it is about (named as the
//! request's field is: `a_amp`, `freq`, `out`, `ensemble`), the scenario's file and the overrides
//! applied to it ([`Source`]), the key, the value and what is allowed. It does not say how a user
//! typed that input: the command line words an input as a flag (`--a-amp`), Python as a keyword
//! argument (`a_amp`), and overrides as `--set K=V` or `set={'K': V}`. Each front end implements
//! [`Words`] and renders an error with [`Error::in_words`]; `Display` uses [`Plain`], the library's
//! own words (field names, `set K=V`), for Rust callers.
//!
//! Where a message names another input than the one it is about (`a_mean = …: with a_amp = …`),
//! the text holds it as `«a_amp»`, which [`render`] replaces with the front end's word.

use std::fmt;
use std::path::PathBuf;

use djkr_core::dynamics::{Ending, SimError};
use djkr_core::error::ParamError;
use djkr_core::steady::SteadyError;
use djkr_core::text::excerpt;

use crate::output::OutputError;
use crate::run_plot::RunPlotError;
use crate::scenario::overrides::OverrideError;
use crate::scenario::parse::ScenarioError;
use crate::sweep::{SpecError, SweepError};

/// How a front end names what its user gave it.
pub trait Words {
    /// `name`, an input of a request (its field name: `a_amp`, `freq`, `out`), as this front end
    /// spells it: `--a-amp` on the command line, `a_amp` in Python.
    fn input(&self, name: &str) -> String;
    /// Overrides of scenario keys (`KEY=VALUE` each, in order) as this front end takes them:
    /// `--set K=V --set K2=V2` on the command line, `set={'K': V, 'K2': V2}` in Python.
    fn overrides(&self, items: &[String]) -> String;
    /// An override that did not parse or names no key (`KEY=VALUE`, or whatever was given), as
    /// this front end shows it: `--set K=V` on the command line, `set={'K': ...}` in Python (its
    /// value plays no part).
    fn malformed_override(&self, set: &str) -> String;
    /// An axis of a sweep (`KEY=SPEC`: a list or a range of values) that did not parse: `--set
    /// K=SPEC` on the command line, `grid={'K': ...}` in Python.
    fn axis(&self, spec: &str) -> String;
    /// An input with its value, where a message names both: `--ensemble 5`, `ensemble = 5`.
    fn input_value(&self, name: &str, value: &str) -> String;
}

/// The library's own words, for Rust callers: inputs by their field names, overrides as
/// `set K=V, K2=V2`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Plain;

impl Words for Plain {
    fn input(&self, name: &str) -> String {
        name.to_string()
    }
    fn overrides(&self, items: &[String]) -> String {
        format!("set {}", items.join(", "))
    }
    fn malformed_override(&self, set: &str) -> String {
        format!("set {set}")
    }
    fn axis(&self, spec: &str) -> String {
        format!("axis {spec}")
    }
    fn input_value(&self, name: &str, value: &str) -> String {
        format!("{name} = {value}")
    }
}

/// `text` with every `«name»` (an input named inside a message) and `«set:KEY=VALUE»` (an
/// override) in the words of `w`.
pub fn render(text: &str, w: &dyn Words) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find('«') {
        let after = &rest[i + '«'.len_utf8()..];
        match after.find('»') {
            Some(j) => {
                out.push_str(&rest[..i]);
                let inner = &after[..j];
                match inner.strip_prefix("set:") {
                    Some(item) => out.push_str(&w.overrides(&[item.to_string()])),
                    None => out.push_str(&w.input(inner)),
                }
                rest = &after[j + '»'.len_utf8()..];
            }
            None => break,
        }
    }
    out.push_str(rest);
    out
}

/// `«name»`: the input `name` inside a message, for [`render`] to word.
pub fn input(name: &str) -> String {
    format!("«{name}»")
}

/// `«set:KEY=VALUE»`: an override inside a message, for [`render`] to word.
pub fn set_item(item: &str) -> String {
    format!("«set:{item}»")
}

/// Where a scenario came from: its file (a path, `<string>`, `<dict>`) and the overrides applied
/// to the file's values (`KEY=VALUE`, in order).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Source {
    /// The file's name as messages give it (usually its path).
    pub file: String,
    /// The overrides, `KEY=VALUE` each.
    pub set: Box<[String]>,
}

impl Source {
    /// A file used as written.
    pub fn file(file: impl Into<String>) -> Self {
        Self {
            file: file.into(),
            set: Box::default(),
        }
    }

    /// The file and its overrides in the words of `w`: `FILE --set K=V`.
    pub fn words(&self, w: &dyn Words) -> String {
        if self.set.is_empty() {
            self.file.clone()
        } else {
            format!("{} {}", self.file, w.overrides(&self.set))
        }
    }
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.words(&Plain))
    }
}

/// Why a command of the library failed. [`Error::is_input`] tells bad input (the caller's to fix:
/// exit status 2 on the command line, `ScenarioError` in Python) from a computation that failed
/// or was cancelled. [`Error::in_words`] words it for a front end; `Display` in [`Plain`] words.
#[derive(Debug)]
pub enum Error {
    /// An input of the request out of range or malformed: `name` is the input's field name.
    Param(ParamError),
    /// A scenario that does not parse or validate (also a bad override value).
    Scenario(Box<ScenarioError>),
    /// A `KEY=VALUE` override that does not parse.
    Override(OverrideError),
    /// A sweep's `KEY=SPEC` that does not parse.
    Spec(SpecError),
    /// A sweep whose points or ensemble do not validate.
    Sweep(SweepError),
    /// Other bad input, with its message (inputs in it as `«name»`, [`render`]).
    Invalid(String),
    /// A run kept in memory whose known samples exceed `solver.max_memory` ([`crate::memory`]).
    Memory(crate::memory::MemoryError),
    /// The scenario cannot describe a periodic steady state (no `[base]`, ...).
    SteadySetup {
        /// The scenario.
        source: Source,
        /// Why.
        error: SteadyError,
    },
    /// The steady-state search failed.
    Steady {
        /// The scenario.
        source: Source,
        /// Why.
        error: SteadyError,
    },
    /// The run could not start (the scenario cannot be simulated; nothing written).
    Run {
        /// The scenario.
        source: Source,
        /// Why.
        error: SimError,
    },
    /// The run started and ended early: stopped by a budget (`solver.max_steps`, `max_wall_s`,
    /// `max_events`, `max_memory`), by low disk space, or failed mid-way. What it computed is
    /// kept in `record` (and, with a run folder, published there with its status).
    Ended {
        /// The scenario.
        source: Source,
        /// Its status, reason and message.
        ending: Ending,
        /// The run up to where it ended.
        record: Box<crate::api::RunRecord>,
    },
    /// Writing into an output folder failed, or the folder refused the command before it
    /// started.
    Output {
        /// The input that named the folder (`out`), when the failure is the folder's to fix.
        input: Option<&'static str>,
        /// What was being written, when not the folder as a whole (`writing results into DIR`).
        context: Option<String>,
        /// Why.
        error: OutputError,
    },
    /// Drawing the run's figure failed.
    Plot {
        /// The run folder.
        dir: PathBuf,
        /// Why.
        error: RunPlotError,
    },
    /// A report held a non-finite number where JSON has none (an internal error).
    NonFinite(String),
    /// Stopped from another thread ([`djkr_core::cancel`]).
    Cancelled,
}

impl Error {
    /// True for bad input: an argument, a scenario, an override, a sweep's grid, an output folder
    /// that refuses the command before it starts.
    pub fn is_input(&self) -> bool {
        matches!(
            self,
            Error::Param(_)
                | Error::Scenario(_)
                | Error::Override(_)
                | Error::Spec(_)
                | Error::Sweep(_)
                | Error::Invalid(_)
                | Error::Memory(_)
                | Error::SteadySetup { .. }
        ) || self.is_output_refusal()
    }

    /// True when an output folder refused the command before it started: a file djkr did not
    /// write at a name it publishes (without `force`), a name there that is not a regular file, a
    /// path that is not a folder, another run holding the folder, or output that would not fit
    /// the free disk space. A failure to write once the command has started is not one.
    pub fn is_output_refusal(&self) -> bool {
        matches!(
            self,
            Error::Output {
                error: OutputError::Clash { .. }
                    | OutputError::NotRegular { .. }
                    | OutputError::NotAFolder { .. }
                    | OutputError::Busy { .. }
                    | OutputError::DiskSpace { .. },
                ..
            }
        )
    }

    /// A steady-state error about the scenario from `source`: bad input when the scenario
    /// cannot describe a steady state, [`Error::Cancelled`] when cancelled.
    pub fn from_steady(source: Source, error: SteadyError) -> Self {
        match error {
            SteadyError::Sim(SimError::Cancelled { .. }) => Error::Cancelled,
            e @ SteadyError::Setup(_) => Error::SteadySetup { source, error: e },
            e => Error::Steady { source, error: e },
        }
    }

    /// The message in the words of a front end (`w`).
    pub fn in_words(&self, w: &dyn Words) -> String {
        let text = match self {
            Error::Param(p) => format!(
                "{} = {}: {}",
                w.input(&p.name),
                excerpt(&p.value),
                p.allowed
            ),
            Error::Scenario(e) => return e.in_words(w),
            Error::Override(o) => o.in_words(w),
            Error::Spec(e) => e.in_words(w),
            Error::Sweep(e) => e.in_words(w),
            Error::Invalid(m) => m.clone(),
            Error::Memory(e) => e.to_string(),
            Error::SteadySetup { source, error } | Error::Steady { source, error } => {
                format!("{}: {error}", source.words(w))
            }
            Error::Run { source, error } => format!(
                "{}: run could not start (no output written): {error}",
                source.words(w)
            ),
            Error::Ended { source, ending, .. } => format!(
                "{}: run {}: {}",
                source.words(w),
                ending.status().name(),
                ending.message.as_deref().unwrap_or("")
            ),
            Error::Output {
                input,
                context,
                error,
            } => match (input, context) {
                (_, Some(c)) => format!("{c}: {error}"),
                (Some(i), None) => format!("{}: {error}", w.input(i)),
                (None, None) => error.to_string(),
            },
            Error::Plot { dir, error } => {
                format!("drawing the run's figure into {}: {error}", dir.display())
            }
            Error::NonFinite(at) => format!("internal error: non-finite value at {at}"),
            Error::Cancelled => "cancelled".to_string(),
        };
        render(&text, w)
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.in_words(&Plain))
    }
}

impl std::error::Error for Error {}

impl From<ScenarioError> for Error {
    fn from(e: ScenarioError) -> Self {
        Error::Scenario(Box::new(e))
    }
}

macro_rules! from_error {
    ($($t:ty => $v:ident),* $(,)?) => {$(
        impl From<$t> for Error {
            fn from(e: $t) -> Self {
                Error::$v(e)
            }
        }
    )*};
}

from_error!(
    ParamError => Param,
    OverrideError => Override,
    SpecError => Spec,
    SweepError => Sweep,
    crate::memory::MemoryError => Memory,
);

/// The command line's words, for the library's own tests of its messages (the command line's
/// [`Words`] live in the binary).
#[cfg(test)]
pub(crate) struct TestFlags;

#[cfg(test)]
impl Words for TestFlags {
    fn input(&self, name: &str) -> String {
        if name.contains('.') || name.starts_with('-') {
            return name.to_string();
        }
        format!("--{}", name.replace('_', "-"))
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

#[cfg(test)]
mod tests {
    use super::*;

    use TestFlags as Flags;

    #[test]
    fn inputs_inside_a_message_are_worded_by_the_front_end() {
        let text = format!("with {} = 1mm: too wide", input("a_amp"));
        assert_eq!(render(&text, &Flags), "with --a-amp = 1mm: too wide");
        assert_eq!(render(&text, &Plain), "with a_amp = 1mm: too wide");
        // An unclosed marker is left as it is.
        assert_eq!(render("a «b", &Flags), "a «b");
        let t = format!("already set by {}", set_item("adhesion.n=0.5"));
        assert_eq!(render(&t, &Flags), "already set by --set adhesion.n=0.5");
        let s = Source {
            file: "s.toml".into(),
            set: vec!["base.amplitude=30um".into(), "adhesion.n=0.5".into()].into(),
        };
        assert_eq!(
            s.words(&Flags),
            "s.toml --set base.amplitude=30um --set adhesion.n=0.5"
        );
        assert_eq!(
            s.to_string(),
            "s.toml set base.amplitude=30um, adhesion.n=0.5"
        );
    }
}
