//! The time-domain simulator: eqs. (30)–(32) with a rate-dependent JKR contact.
//!
//! [`types`] holds what a run produces and the observer interface; the driver and the models live
//! beside it.

pub mod types;

pub use types::*;
