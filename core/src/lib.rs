//! djkr-core: the physics of dynamic JKR adhesion — a rigid sphere, hung on a spring, in adhesive
//! contact with a viscoelastic substrate that may vibrate — with no file format and no terminal.
//!
//! What computes lives here; what reads scenario files, writes HDF5/CSV/plots and talks to a user
//! lives in the `djkr` crate above it. SI units throughout; compressive forces are positive and
//! the sphere's position is measured downwards (the sign conventions of `docs/guide/concepts.md`).
//!
//! The pieces a user composes are re-exported at the crate root:
//!
//! - the material and the laws: [`Material`], [`Law`] (Gent–Schultz [`GentSchultz`], its
//!   saturated and tabulated variants [`SaturatedGentSchultz`] and [`TabulatedLaw`], a constant
//!   work of adhesion [`ConstantW`]) and the interface they share, [`AdhesionLaw`]; the contact
//!   relations are in [`jkr`];
//! - the rig: [`Rig`] and its parts ([`Sphere`], [`Holder`], [`Damping`], [`DampingOn`],
//!   [`BaseMotion`], [`ContactFormation`]);
//! - the time-domain simulator: a [`Plan`] (rig, [`Initial`] state, [`Stage`]s of a
//!   [`StageKind`] each ending [`Until`] a condition, a [`Solver`] naming a [`Method`]) run by
//!   [`run`] into an [`Observer`] (or [`NoObserver`]), giving a [`RunResult`] (its [`Event`]s,
//!   [`Sample`]s and [`CycleRecord`]s through the observer) or a [`SimError`]; the [`Simulator`]
//!   for callers that drive the time loop themselves;
//! - periodic steady states: a [`SteadyProblem`] solved with [`SteadyOptions`] into a
//!   [`Steady`] orbit or a [`SteadyError`] (frequency sweeps in [`steady::sweep`]);
//! - continuation of periodic orbits through their folds, with Floquet multipliers and
//!   bifurcations: [`continuation`] (a [`continuation::family::Scene`] gives the periodic problem
//!   at each parameter value; the `djkr` crate's is a scenario file);
//! - harmonic balance: [`harmonic_balance`] gives a [`HarmonicBalance`] (more in [`describing`]);
//! - the paper's shortcut and closed forms: [`imposed_area`], [`closed_form`], [`comparators`],
//!   [`transfer`]; fits of measured records: [`gs_fit`], [`beta_fit`];
//! - what the layers above share: [`units`] (names and scales of quantities), [`text`] (number
//!   formatting), [`error`] (range checks), [`cancel`] (cooperative cancellation),
//!   [`quadrature`] (the rules the imposed-area method integrates with).
//!
//! The modules hold the rest of each subject; the integrators' internals (step-size control,
//! event location, envelope following, the steppers) are private to [`dynamics`].
//!
//! # Example: a quasi-static pull-off is JKR's
//!
//! A 3 g sphere on a soft 200 N/m spring, pressed with 20 mN and unloaded slowly with a constant
//! work of adhesion, leaves the surface at the load-controlled JKR pull-off force −3/2 π R w:
//!
//! ```
//! use djkr_core::jkr::load_controlled_pull_off_force;
//! use djkr_core::rig::light_rig;
//! use djkr_core::{run, ConstantW, Initial, Law, NoObserver, Plan, Solver, Stage, StageKind, Until};
//!
//! let w = 0.24; // J/m²
//! let rig = light_rig(Law::Constant(ConstantW { w0: w }));
//! let unload = Stage {
//!     kind: StageKind::Unload,
//!     speed: 1e-5, // m/s at the spring end
//!     until: Until::PullOff,
//!     vibration: None,
//!     max_duration: 100.0, // s
//! };
//! let plan = Plan {
//!     rig: &rig,
//!     initial: Initial::Preload(0.02), // N
//!     stages: &[unload],
//!     solver: Solver::default(),
//!     sample_rate: 0.0,
//!     dense: &[],
//! };
//! let result = run(&plan, &mut NoObserver).expect("the run ends at pull-off");
//! let jkr = load_controlled_pull_off_force(&rig.material, w);
//! assert!(result.detached);
//! assert!((result.pull_off.force / jkr - 1.0).abs() < 0.01);
//! ```
#![deny(clippy::float_cmp)]
#![deny(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links, rustdoc::private_intra_doc_links)]

pub mod adhesion;
pub mod beta_fit;
pub mod cancel;
pub mod closed_form;
pub mod comparators;
pub mod continuation;
pub mod describing;
pub mod dynamics;
pub mod error;
pub mod gs_fit;
pub mod imposed_area;
pub mod jkr;
pub mod material;
pub(crate) mod numerics;
pub mod quadrature;
pub mod rig;
pub mod steady;
pub mod text;
pub mod transfer;
pub mod units;

pub use adhesion::{AdhesionLaw, ConstantW, GentSchultz, Law, SaturatedGentSchultz, TabulatedLaw};
pub use describing::{solve as harmonic_balance, HarmonicBalance};
pub use dynamics::{
    run, CycleRecord, Event, Initial, Method, NoObserver, Observer, Plan, RunResult, Sample,
    SimError, Simulator, Solver, Stage, StageKind, Until,
};
pub use material::Material;
pub use rig::{BaseMotion, ContactFormation, Damping, DampingOn, Holder, Rig, Sphere};
pub use steady::{Options as SteadyOptions, Problem as SteadyProblem, Steady, SteadyError};
