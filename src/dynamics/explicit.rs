//! Explicit methods (`ode_solvers` Dopri5 / Dop853) on y = (x_s, v_s, a) with ȧ = law.crack_speed(G).

use super::driver::SimError;
use super::model::Model;
use super::types::{Observer, RunResult};
use crate::scenario::Scenario;
use std::time::Instant;

/// Run a scenario with an explicit method.
pub fn simulate_explicit(
    s: &Scenario,
    obs: &mut dyn Observer,
    model: &Model,
    start: Instant,
) -> Result<RunResult, SimError> {
    let _ = (s, obs, model, start);
    Err(SimError::Setup(
        "explicit methods are not available yet: use method = \"implicit\" or \"auto\"".into(),
    ))
}
