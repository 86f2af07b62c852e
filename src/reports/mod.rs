//! Tables of results (CSV and HDF5 through [`crate::output::table`]) built from the physics
//! crate's results.

pub mod beta_fit;
pub mod continuation;
pub mod steady;
