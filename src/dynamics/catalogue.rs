//! The reference scenes moved to [`crate::catalogue`] (they build whole scenarios and serve the
//! imposed-area, steady-state and time-domain tests alike). This re-export keeps the old path
//! `djkr::dynamics::catalogue` working.

pub use crate::catalogue::*;
