//! The methods a scene may ask for (`[solver] method`, `--methods`), named in one registry
//! table ([`METHODS`]), the `auto` rule, and the solver settings of a scenario.
//!
//! Adding an integrator is one file that implements [`Stepper`] beside the method (saying what
//! it provides by its [`super::stepper::Capabilities`]) and one line in [`METHODS`]: the
//! scenario parser, `djkr accuracy --methods`, error messages and reports read the names from
//! the table, and no other code needs to name the method.

use super::dp8::Dp8;
use super::esdirk::Implicit;
use super::ode_adapter::{OdeMethod, OdeSolvers};
use super::rescue::Rescued;
use super::stepper::Stepper;
use crate::adhesion::AdhesionLaw;
use crate::cancel::Cancel;
use crate::rig::{ContactFormation, Rig};
use std::fmt;

/// One integration method a scene may ask for: its name and how to build its stepper.
#[derive(Clone, Copy)]
pub struct MethodEntry {
    /// The name in scenario files (`[solver] method`), flags (`--methods`) and reports.
    pub name: &'static str,
    /// The stepper for a rig (fresh: nothing carried over).
    pub build: fn(&Rig) -> Box<dyn Stepper>,
}

/// Every method, in the order files, flags and error messages list them: the one table that
/// names them.
pub const METHODS: &[MethodEntry] = &[
    MethodEntry {
        name: "auto",
        build: build_auto,
    },
    MethodEntry {
        name: "dp8",
        build: |_| Box::new(Dp8::default()),
    },
    MethodEntry {
        name: "dopri5",
        build: |_| Box::new(OdeSolvers::new(OdeMethod::Dopri5)),
    },
    MethodEntry {
        name: "dop853",
        build: |_| Box::new(OdeSolvers::new(OdeMethod::Dop853)),
    },
    MethodEntry {
        name: "implicit",
        build: |_| Box::new(Implicit),
    },
];

/// An integration method: a name in [`METHODS`]. A value comes from the table
/// ([`method_from_name`], [`methods`]) or from one of the constants, which exist for the
/// methods that code names (the `auto` rule and its choices, tests and studies comparing
/// methods); a new method needs none. `Display` prints the name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Method(&'static str);

/// Named like the enum variants they replaced, so that `Method::Dp8` reads (and matches) as
/// it did.
#[allow(non_upper_case_globals)]
impl Method {
    /// Let djkr choose ([`auto_method`]) and report the choice.
    pub const Auto: Method = Method::registered("auto");
    /// Explicit Dormand–Prince 8(5,3), djkr's own stepper (`dynamics/dp8.rs`; steps rejected at
    /// the healing singularity, no restarts).
    pub const Dp8: Method = Method::registered("dp8");
    /// Explicit Dormand–Prince 5(4) (`ode_solvers`, `dynamics/ode_adapter.rs`).
    pub const Dopri5: Method = Method::registered("dopri5");
    /// Explicit Dormand–Prince 8(5,3) (`ode_solvers`, `dynamics/ode_adapter.rs`).
    pub const Dop853: Method = Method::registered("dop853");
    /// Implicit, root-solved update of the contact radius (`dynamics/esdirk.rs`; robust at the
    /// healing singularity).
    pub const Implicit: Method = Method::registered("implicit");

    /// The method of `name`, checked when the constant is compiled: a name not in [`METHODS`]
    /// fails the build.
    const fn registered(name: &'static str) -> Method {
        let mut i = 0;
        while i < METHODS.len() {
            if const_str_eq(METHODS[i].name, name) {
                return Method(METHODS[i].name);
            }
            i += 1;
        }
        panic!("a Method constant names a method missing from METHODS")
    }

    /// Its entry in [`METHODS`]. Every `Method` names one (values are made from the table, or
    /// are the constants above, checked against it at compile time), so the fallback to the
    /// first entry is never taken.
    fn entry(self) -> &'static MethodEntry {
        METHODS
            .iter()
            .find(|e| e.name == self.0)
            .unwrap_or(&METHODS[0])
    }
}

/// `a == b` at compile time (`str`'s `==` is not `const`).
const fn const_str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

/// Every method, in the order of [`METHODS`].
pub fn methods() -> impl Iterator<Item = Method> {
    METHODS.iter().map(|e| Method(e.name))
}

/// The names of [`METHODS`], in order: what `[solver] method` and `--methods` accept (a
/// constant, made from the registry when the code compiles, for tables of keys that need a
/// `'static` list).
pub const METHOD_NAMES: [&str; METHODS.len()] = {
    let mut names = [""; METHODS.len()];
    let mut i = 0;
    while i < METHODS.len() {
        names[i] = METHODS[i].name;
        i += 1;
    }
    names
};

/// The names of [`METHODS`], in order: what `[solver] method` and `--methods` accept.
pub fn method_names() -> Vec<&'static str> {
    METHOD_NAMES.to_vec()
}

/// The name of a method, as files and flags spell it.
pub fn method_name(m: Method) -> &'static str {
    m.entry().name
}

/// The method of a name; `None` for a name not in [`METHODS`].
pub fn method_from_name(name: &str) -> Option<Method> {
    METHODS
        .iter()
        .find(|e| e.name == name)
        .map(|e| Method(e.name))
}

/// The stepper for a method on a rig (`auto` resolved by [`auto_method`]).
pub fn build(method: Method, rig: &Rig) -> Box<dyn Stepper> {
    (method.entry().build)(rig)
}

/// The `auto` rule, from measurements per scene type (`docs/studies/methods.md`, regenerated by
/// `cargo run --release --example study_methods -- --full`; `docs/accuracy/`; the extremes
/// matrix, `docs/extremes.md`):
/// - **implicit** for a rate-independent law (a is algebraic: ȧ = law⁻¹(G) does not exist) and
///   for contact formed from a seed (healing from G ≈ 0 at ȧ ≈ ∞ after every impact: DP8 runs
///   it, but no faster);
/// - **implicit** without inertia (rigid link, m = 0: only a is integrated). There the two
///   methods trade places: DP8 is faster on a slow GS unload and slower under a 400 Hz base,
///   its reduced right-hand side solving the position twice (on 2026-11-24: 0.58–0.66 of the
///   implicit wall time on the unloads at 0.1 µm/s, 1.38× under a 2 µm base); all are
///   sub-millisecond and within 1e-6 of the converged result at rtol 1e-8, so the simpler rule
///   stays;
/// - **DP8** otherwise, several times faster than the implicit method at equal accuracy on the
///   scenes with inertia, taking single steps implicitly where a DP8 stage meets G ≤ 0 or the
///   contact heals so deeply that DP8's steps would be stability-limited (`Rescued`).
pub fn auto_method(rig: &Rig) -> Method {
    if rig.law.is_rate_independent()
        || matches!(rig.formation, ContactFormation::Seed(_))
        || !rig.has_inertia()
    {
        Method::Implicit
    } else {
        Method::Dp8
    }
}

/// `auto`'s stepper: the implicit method, or DP8 rescued by it (`Rescued`) for single steps in
/// deep healing or where a DP8 stage meets G ≤ 0, as [`auto_method`] chooses.
fn build_auto(rig: &Rig) -> Box<dyn Stepper> {
    if auto_method(rig) == Method::Dp8 {
        Box::new(Rescued::new(Dp8::with_stiffness_switch(), Implicit))
    } else {
        Box::new(Implicit)
    }
}

/// Whether envelope following may skip periods (`dynamics/envelope.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvelopeMode {
    /// Where the shaker runs steadily and the error estimate allows.
    Auto,
    /// Never: every period is integrated (a complete time series).
    Off,
}

/// Default of `solver.max_memory`: 2 GiB.
pub const DEFAULT_MAX_MEMORY: u64 = 2 << 30;
/// Smallest `solver.max_memory` accepted: 1 MiB.
pub const MIN_MAX_MEMORY: u64 = 1 << 20;

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solver {
    /// Method.
    pub method: Method,
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance, relative to the natural scale of each state component (dimensionless).
    pub atol: f64,
    /// Maximum number of steps for the whole run.
    pub max_steps: u64,
    /// Wall-clock budget for the whole run (s).
    pub max_wall_s: f64,
    /// Contact events (losses, impacts) for the whole run.
    pub max_events: u64,
    /// Memory a run may hold in samples, events and period records kept in memory (bytes;
    /// `solver.max_memory`, default [`DEFAULT_MAX_MEMORY`]). A run whose sample count is known
    /// up front is refused when its estimate exceeds it; otherwise a run that reaches it stops
    /// with reason `memory`.
    pub max_memory: u64,
    /// Event location tolerance in time (s).
    pub event_tol: f64,
    /// Envelope following.
    pub envelope: EnvelopeMode,
    /// Local error tolerance of an envelope step (scaled, dimensionless).
    pub envelope_tol: f64,
    /// Cancellation from another thread ([`crate::cancel`]); none unless a caller sets one. Not
    /// a scenario key.
    pub cancel: Cancel,
}

impl Default for Solver {
    fn default() -> Self {
        Self {
            method: Method::Auto,
            rtol: 1e-8,
            atol: 1e-10,
            max_steps: 50_000_000,
            max_wall_s: 600.0,
            max_events: 10_000_000,
            max_memory: DEFAULT_MAX_MEMORY,
            event_tol: 1e-12,
            envelope: EnvelopeMode::Auto,
            envelope_tol: 1e-6,
            cancel: Cancel::NONE,
        }
    }
}
