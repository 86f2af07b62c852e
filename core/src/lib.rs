//! djkr-core: the physics of dynamic JKR adhesion of a rigid sphere on a vibrating viscoelastic
//! substrate, with no file format and no terminal.
#![deny(clippy::float_cmp)]
#![warn(missing_docs)]

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
