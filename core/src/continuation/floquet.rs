//! Floquet multipliers of a periodic orbit and the test functions of its bifurcations.
//!
//! The multipliers are the eigenvalues of the monodromy matrix M = ∂P/∂y, the derivative of the
//! one-period map at the orbit's state at phase 0 ([`super::map`]: finite differences on the
//! frozen step sequence). The system is forced, so there is no trivial multiplier 1: the orbit is
//! asymptotically stable when every |μ| < 1. Scaling the state (M ↦ S⁻¹MS) leaves them unchanged.
//!
//! Test functions, each changing sign at one kind of bifurcation (Kuznetsov, *Elements of
//! Applied Bifurcation Theory*, Sec. 10.2, for maps):
//! - fold (a real μ through +1): the parameter component of the branch's tangent, which changes
//!   sign where the branch turns back (not read off the multipliers: see [`super`]);
//! - period doubling (a real μ through −1): ψ_PD = det(M + I) = Π (1 + μ_i);
//! - Neimark–Sacker (a complex pair through |μ| = 1): ψ_NS = Π_{i<j} (μ_i μ_j − 1), the
//!   determinant of the bialternate product M ⊙ M − I; it also vanishes for a real pair with
//!   μ_i μ_j = 1 (a neutral saddle, no bifurcation), which the classification refuses.

use nalgebra::{Complex, DMatrix};

/// The eigenvalues of `m`, largest modulus first; `None` when `m` is not finite or the Schur
/// iteration does not converge.
pub fn multipliers(m: &DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    if m.nrows() == 0 {
        return Some(Vec::new());
    }
    if m.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let schur = nalgebra::linalg::Schur::try_new(m.clone(), f64::EPSILON, 10_000)?;
    let mut v: Vec<Complex<f64>> = schur.complex_eigenvalues().iter().copied().collect();
    v.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    Some(v)
}

/// Asymptotically stable: every |μ| < 1.
pub fn stable(mu: &[Complex<f64>]) -> bool {
    mu.iter().all(|z| z.norm() < 1.0)
}

/// ψ_PD = Π (1 + μ_i) (real for a real matrix).
pub fn period_doubling_test(mu: &[Complex<f64>]) -> f64 {
    mu.iter()
        .fold(Complex::new(1.0, 0.0), |acc, z| acc * (z + 1.0))
        .re
}

/// ψ_NS = Π_{i<j} (μ_i μ_j − 1) (real for a real matrix); 1 with fewer than two multipliers.
pub fn neimark_sacker_test(mu: &[Complex<f64>]) -> f64 {
    let mut acc = Complex::new(1.0, 0.0);
    for i in 0..mu.len() {
        for j in i + 1..mu.len() {
            acc *= mu[i] * mu[j] - 1.0;
        }
    }
    acc.re
}

/// The multiplier nearest the unit circle whose imaginary part is significant (|Im μ| > `tol`):
/// the pair of a Neimark–Sacker point.
pub fn complex_nearest_circle(mu: &[Complex<f64>], tol: f64) -> Option<Complex<f64>> {
    mu.iter()
        .filter(|z| z.im.abs() > tol)
        .min_by(|a, b| (a.norm() - 1.0).abs().total_cmp(&(b.norm() - 1.0).abs()))
        .copied()
}

/// The real multiplier nearest `target` (±1).
pub fn real_nearest(mu: &[Complex<f64>], target: f64, tol: f64) -> Option<Complex<f64>> {
    mu.iter()
        .filter(|z| z.im.abs() <= tol)
        .min_by(|a, b| (a.re - target).abs().total_cmp(&(b.re - target).abs()))
        .copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn damped_oscillator_monodromy_has_exp_lambda_t() {
        // m x'' + c x' + k x = 0: the one-period map of (x, v) is exp(A T).
        let (m, c, k, t) = (2.71e-3, 0.5, 17_115.0, 1.0 / 400.0);
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -k / m, -c / m]);
        // exp(A T) by scaling and squaring of a Taylor series.
        let s = 2f64.powi(20);
        let b = &a * (t / s);
        let mut e = DMatrix::<f64>::identity(2, 2);
        let mut term = DMatrix::<f64>::identity(2, 2);
        for i in 1..20 {
            term = &term * &b / i as f64;
            e += &term;
        }
        for _ in 0..20 {
            e = &e * &e;
        }
        let mu = multipliers(&e).unwrap_or_default();
        let disc = Complex::new(c * c - 4.0 * m * k, 0.0).sqrt();
        let lam = (Complex::new(-c, 0.0) + disc) / (2.0 * m);
        let exact = (lam * t).exp();
        assert_eq!(mu.len(), 2);
        assert!(
            (mu[0].norm() - exact.norm()).abs() < 1e-9,
            "{mu:?} vs {exact}"
        );
        let hit = mu.iter().any(|z| (z - exact).norm() < 1e-8);
        assert!(hit, "{mu:?} vs {exact}");
        assert!(stable(&mu));
    }

    #[test]
    fn test_functions_change_sign_at_their_crossings() {
        let pd = |r: f64| period_doubling_test(&[Complex::new(r, 0.0), Complex::new(0.5, 0.0)]);
        assert!(pd(-0.9) > 0.0 && pd(-1.1) < 0.0);
        let ns = |r: f64| {
            let z = Complex::from_polar(r, 0.7);
            neimark_sacker_test(&[z, z.conj(), Complex::new(0.3, 0.0)])
        };
        assert!(ns(0.95) * ns(1.05) < 0.0);
        let mu = [
            Complex::new(0.1, 0.9),
            Complex::new(0.1, -0.9),
            Complex::new(-0.8, 0.0),
        ];
        assert!(complex_nearest_circle(&mu, 1e-9).is_some());
        assert!(real_nearest(&mu, -1.0, 1e-9).is_some_and(|z| z.re < -0.7));
        assert!(multipliers(&DMatrix::from_element(2, 2, f64::NAN)).is_none());
    }
}
