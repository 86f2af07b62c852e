//! Small numerical helpers shared by the physics modules.

/// Convergence test for the `roots` crate that is relative in x (the crate's own `f64` test is
/// absolute, which fails for roots far from 1 in magnitude) and absolute in a *scaled* residual.
#[derive(Debug, Clone, Copy)]
pub struct RelativeConvergency {
    /// Relative tolerance on x.
    pub x_rel: f64,
    /// Absolute tolerance on x (for roots at or near 0).
    pub x_abs: f64,
    /// Tolerance on |f| (scale f so that this is meaningful).
    pub f_abs: f64,
    /// Iteration limit.
    pub max_iter: usize,
}

impl Default for RelativeConvergency {
    fn default() -> Self {
        Self {
            x_rel: 4.0 * f64::EPSILON,
            x_abs: 1e-300,
            f_abs: 0.0,
            max_iter: 200,
        }
    }
}

impl roots::Convergency<f64> for RelativeConvergency {
    fn is_root_found(&mut self, y: f64) -> bool {
        y.abs() <= self.f_abs
    }
    fn is_converged(&mut self, x1: f64, x2: f64) -> bool {
        (x1 - x2).abs() <= self.x_abs + self.x_rel * x1.abs().max(x2.abs())
    }
    fn is_iteration_limit_reached(&mut self, iter: usize) -> bool {
        iter >= self.max_iter
    }
}
