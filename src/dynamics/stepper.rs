//! The integrators behind one interface, and the method a scene asks for.

/// Integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Let djkr choose (and report the choice).
    Auto,
    /// Explicit Dormand–Prince 5(4) (`ode_solvers`).
    Dopri5,
    /// Explicit Dormand–Prince 8(5,3) (`ode_solvers`).
    Dop853,
    /// Explicit Dormand–Prince 8(5,3), djkr's own stepper (steps rejected at the healing
    /// singularity, no restarts).
    Dp8,
    /// Implicit, root-solved update of the contact radius (robust at the healing singularity).
    Implicit,
}

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solver {
    /// Method.
    pub method: Method,
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance, relative to the natural scale of each state component (dimensionless).
    pub atol: f64,
    /// Maximum number of steps for the whole run.
    pub max_steps: u64,
    /// Wall-clock budget for the whole run (s).
    pub max_wall_s: f64,
    /// Event location tolerance in time (s).
    pub event_tol: f64,
}

impl Default for Solver {
    fn default() -> Self {
        Self {
            method: Method::Auto,
            rtol: 1e-8,
            atol: 1e-10,
            max_steps: 50_000_000,
            max_wall_s: 600.0,
            event_tol: 1e-12,
        }
    }
}
