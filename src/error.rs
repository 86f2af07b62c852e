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

pub(crate) use crate::words::input;
#[cfg(test)]
pub(crate) use crate::words::TestFlags;
pub use crate::words::{render, Plain, Source, Words};

use crate::output::OutputError;
use crate::run_plot::RunPlotError;
use crate::scenario::overrides::OverrideError;
use crate::scenario::parse::ScenarioError;
use crate::sweep::{SpecError, SweepError};

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
        record: Box<crate::record::RunRecord>,
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

/// A continuation's error in the words of `w` (its ranges and parameters are inputs of the
/// request: `range`, `fold_range`, `param`, `fold_param`).
pub(crate) fn continuation_in_words(
    e: &djkr_core::continuation::ContinuationError,
    w: &dyn Words,
) -> String {
    use djkr_core::continuation::ContinuationError as C;
    match e {
        C::EmptyRange {
            input,
            start,
            stop,
            unit,
        } => {
            let unit = if unit.is_empty() {
                String::new()
            } else {
                format!(" ({unit})")
            };
            format!(
                "{} {start}:{stop}: START and STOP must differ{unit}",
                w.input(input)
            )
        }
        C::SameParameter { input, name, other } => format!(
            "{} {name}: must differ from {}",
            w.input(input),
            w.input(other)
        ),
        C::Scene(inner) => match inner.downcast_ref::<ScenarioError>() {
            Some(e) => e.in_words(w),
            None => render(&inner.to_string(), w),
        },
        e => render(&e.to_string(), w),
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
        let t = format!(
            "already set by {}",
            crate::words::set_item("adhesion.n=0.5")
        );
        assert_eq!(render(&t, &Flags), "already set by --set adhesion.n=0.5");
        // An input with its value, and a sweep's axis.
        let t = format!("{}: too many", crate::words::input_value("ensemble", "5"));
        assert_eq!(render(&t, &Flags), "--ensemble 5: too many");
        assert_eq!(render(&t, &Plain), "ensemble = 5: too many");
        let t = format!(
            "swept by {}",
            crate::words::axis_item("base.amplitude=1um:2um:3")
        );
        assert_eq!(
            render(&t, &Flags),
            "swept by --set base.amplitude=1um:2um:3"
        );
        assert_eq!(render(&t, &Plain), "swept by axis base.amplitude=1um:2um:3");
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
