//! djkr: dynamic JKR adhesion of a rigid sphere on a vibrating viscoelastic substrate.
//!
//! The physics lives in pure functions: [`jkr`] (contact relations), [`adhesion`] (rate-dependent
//! work of adhesion), [`imposed_area`] (the paper's Sec. 2.1 method), [`closed_form`] (eqs. 16–24,
//! 29), [`comparators`] (Shui et al., Yi et al.). I/O lives at the edges (the CLI, output writers).
#![deny(clippy::float_cmp)]
#![warn(missing_docs)]

pub mod adhesion;
pub mod error;
pub mod jkr;
pub mod material;
pub mod numerics;
pub mod units;
