//! Continuation of periodic orbits (placeholder doc, rewritten below).

pub mod branch;
pub mod engine;
pub mod family;
pub mod floquet;
pub mod folds;
pub mod map;
pub mod report;
pub mod sweep;

use thiserror::Error;

/// Why a continuation could not run.
#[derive(Debug, Error)]
pub enum ContinuationError {
    /// A key, range or scenario value that cannot describe a family of periodic orbits.
    #[error("{0}")]
    Input(String),
    /// No periodic orbit at the start of the range.
    #[error("continuation: {0}")]
    Start(String),
}
