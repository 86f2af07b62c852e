//! djkr: dynamic JKR adhesion of a rigid sphere on a vibrating viscoelastic substrate.
//!
//! The physics lives in pure functions: [`jkr`] (contact relations), [`adhesion`] (rate-dependent
//! work of adhesion), [`imposed_area`] (the paper's Sec. 2.1 method), [`closed_form`] (eqs. 16–24,
//! 29), [`comparators`] (Shui et al., Yi et al.), [`dynamics`] (the time-domain simulator).
//! I/O lives at the edges: [`scenario::parse`], [`output`], [`plot`], and the CLI.
#![deny(clippy::float_cmp)]
#![warn(missing_docs)]

pub mod accuracy;
pub mod adhesion;
pub mod api;
pub mod beta_fit;
pub mod cancel;
pub mod catalogue;
pub mod closed_form;
pub mod comparators;
pub mod continuation;
pub mod describing;
pub mod dynamics;
pub mod error;
pub mod figures;
pub mod fit;
pub mod gs_fit;
pub mod imposed_area;
pub mod input;
pub mod jkr;
pub mod material;
pub mod memory;
pub mod numerics;
pub mod output;
pub mod plot;
pub mod quadrature;
pub mod rig;
pub mod run_plot;
pub mod scenario;
pub mod sensitivity;
pub mod steady;
pub mod sweep;
pub mod text;
pub mod transfer;
pub mod units;
