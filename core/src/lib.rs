//! djkr-core: the physics of dynamic JKR adhesion — a rigid sphere, hung on a spring, in adhesive
//! contact with a viscoelastic substrate that may vibrate — with no file format and no terminal.
//!
//! What computes lives here; what reads scenario files, writes HDF5/CSV/plots and talks to a user
//! lives in the `djkr` crate above it. SI units throughout; compressive forces are positive and
//! the sphere's position is measured downwards (the sign conventions of `docs/MODEL.md`).
//!
//! The pieces a user composes:
//!
//! - the material and the laws: [`material::Material`], [`adhesion::Law`] (Gent–Schultz, its
//!   saturated and tabulated variants, a constant work of adhesion), the contact relations of
//!   [`jkr`];
//! - the rig: [`rig::Rig`] (sphere, spring, damping, base motion, contact formation);
//! - the paper's shortcut and closed forms: [`imposed_area`], [`closed_form`], [`comparators`],
//!   [`transfer`], [`describing`] (harmonic balance);
//! - the time-domain simulator: a [`dynamics::Plan`] (rig, initial state, stages, solver) run by
//!   [`dynamics::run`] into an [`dynamics::Observer`], giving a [`dynamics::RunResult`];
//! - periodic steady states ([`steady`]) and, in the `djkr` crate for now, their continuation;
//! - fits of measured records: [`gs_fit`], [`beta_fit`].
//!
//! # Example: a quasi-static pull-off is JKR's
//!
//! A 3 g sphere on a soft 200 N/m spring, pressed with 20 mN and unloaded slowly with a constant
//! work of adhesion, leaves the surface at the load-controlled JKR pull-off force −3/2 π R w:
//!
//! ```
//! use djkr_core::adhesion::{ConstantW, Law};
//! use djkr_core::dynamics::protocol::{Initial, Stage, StageKind, Until};
//! use djkr_core::dynamics::{run, NoObserver, Plan, Solver};
//! use djkr_core::jkr::load_controlled_pull_off_force;
//! use djkr_core::rig::light_rig;
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

pub mod adhesion;
pub mod beta_fit;
pub mod cancel;
pub mod closed_form;
pub mod comparators;
pub mod describing;
pub mod dynamics;
pub mod error;
pub mod gs_fit;
pub mod imposed_area;
pub mod jkr;
pub mod material;
pub mod numerics;
pub mod quadrature;
pub mod rig;
pub mod steady;
pub mod text;
pub mod transfer;
pub mod units;
