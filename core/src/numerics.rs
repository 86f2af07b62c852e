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

/// Bisection of a bracket [lo, hi] on which `below` is true at the low end and false at the
/// high end (a monotone predicate such as f(x) ≤ 0 for an increasing f), down to
/// hi − lo ≤ `rel_tol` |hi| or to adjacent floating-point numbers (`rel_tol` = 0), at most 200
/// halvings. Returns the final bracket (lo, hi). The one bisection of the crate: the static
/// equilibria, the stable JKR branch and the harmonic-balance brackets use it. Hand-written
/// rather than `roots::find_root_brent` because these callers need the bracket itself
/// (the root on a chosen side of a discontinuity) and a predicate, not a value.
pub fn bisect(
    mut lo: f64,
    mut hi: f64,
    rel_tol: f64,
    mut below: impl FnMut(f64) -> bool,
) -> (f64, f64) {
    for _ in 0..200 {
        if hi - lo <= rel_tol * hi.abs() {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if below(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo, hi)
}

/// Solve the dense n × n system A x = b (A given element-wise by `a(i, j)`) by nalgebra's LU
/// with partial pivoting; `None` when A is singular or the solution not finite. The one dense
/// solver of the crate (shooting's Newton, harmonic balance's Newton).
pub fn solve_dense(n: usize, a: impl Fn(usize, usize) -> f64, b: &[f64]) -> Option<Vec<f64>> {
    let m = nalgebra::DMatrix::from_fn(n, n, a);
    let x = m.lu().solve(&nalgebra::DVector::from_column_slice(b))?;
    x.iter()
        .all(|v| v.is_finite())
        .then(|| x.iter().copied().collect())
}

/// Brent's local minimiser (golden section with parabolic steps; Brent 1973, "localmin") of `f`
/// on [a, b]. Returns (x_min, f(x_min)). Converges to |Δx| ≲ 3 (rel_tol |x| + abs_tol). Pure,
/// allocation-free, no clock: used by the pull-off searches, the β refit and the GS fit.
pub fn brent_minimize<F: FnMut(f64) -> f64>(
    mut f: F,
    a: f64,
    b: f64,
    rel_tol: f64,
    abs_tol: f64,
    max_iter: usize,
) -> (f64, f64) {
    let cgold = 0.5 * (3.0 - 5f64.sqrt());
    let (mut a, mut b) = (a.min(b), a.max(b));
    let mut x = a + cgold * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0_f64, 0.0_f64);
    for _ in 0..max_iter {
        let xm = 0.5 * (a + b);
        let tol = rel_tol * x.abs() + abs_tol;
        let tol2 = 2.0 * tol;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let e_old = e;
            e = d;
            if p.abs() < (0.5 * q * e_old).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = if xm >= x { tol } else { -tol };
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { a - x } else { b - x };
            d = cgold * e;
        }
        let u = if d.abs() >= tol {
            x + d
        } else if d > 0.0 {
            x + tol
        } else {
            x - tol
        };
        let fu = f(u);
        // NaN never wins: `fu <= fx` is false for NaN.
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            v = w;
            fv = fw;
            w = x;
            fw = fx;
            x = u;
            fx = fu;
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w.to_bits() == x.to_bits() {
                v = w;
                fv = fw;
                w = u;
                fw = fu;
            } else if fu <= fv || v.to_bits() == x.to_bits() || v.to_bits() == w.to_bits() {
                v = u;
                fv = fu;
            }
        }
    }
    (x, fx)
}
