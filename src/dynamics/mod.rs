//! The time-domain simulator: eqs. (30)–(32) with a rate-dependent JKR contact.
//!
//! [`types`] holds what a run produces and the observer interface; the driver and the models live
//! beside it.

pub mod driver;
pub mod esdirk;
pub mod explicit;
pub mod model;
pub mod types;

pub use driver::{simulate, SimError};
pub use types::*;
