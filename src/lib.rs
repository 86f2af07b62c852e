//! djkr: dynamic JKR adhesion of a rigid sphere on a vibrating viscoelastic substrate.
//!
//! The physics lives in pure functions: [`jkr`] (contact relations), [`adhesion`] (rate-dependent
//! work of adhesion), [`imposed_area`] (the paper's Sec. 2.1 method), [`closed_form`] (eqs. 16–24,
//! 29), [`comparators`] (Shui et al., Yi et al.), [`dynamics`] (the time-domain simulator).
//! I/O lives at the edges: [`scenario::parse`], [`output`], [`plot`], and the CLI.
#![deny(clippy::float_cmp)]
#![warn(missing_docs)]

pub mod accuracy;
pub mod api;
pub mod catalogue;
pub mod continuation;
pub mod figures;
pub mod input;
pub mod memory;
pub mod output;
pub mod plot;
pub mod reports;
pub mod run_plot;
pub mod scenario;
pub mod sensitivity;
pub mod sweep;

pub use djkr_core::{
    adhesion, beta_fit, cancel, closed_form, comparators, describing, dynamics, error, gs_fit,
    imposed_area, jkr, material, numerics, quadrature, rig, steady, text, transfer, units,
};
