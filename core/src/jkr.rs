//! JKR contact relations of a rigid sphere on an elastic half-space (docs/MODEL.md, "Contact
//! relations"). Sign conventions: the indentation δ > 0 compresses, the force F > 0 is
//! compressive, the contact radius a ≥ 0. All functions are pure and SI.
//!
//! For any contact radius a > 0 and indentation δ (not only at equilibrium):
//! - force, the static part of eq. (3): F(a, δ) = (K a / 2)(3δ − a²/R);
//! - signed edge opening u = a²/R − δ (u > 0: tensile edge, a crack that can peel);
//! - energy release rate, left side of eq. (4): G = 3 K u² / (8 π a), meaningful for u ≥ 0.
//!   For u < 0 the edge is compressive and the contact must advance: use
//!   [`signed_energy_release_rate`] (u·|u|) or [`stress_intensity`], never the bare square.

use crate::material::Material;
use std::f64::consts::PI;

/// Contact force F(a, δ) = (K a/2)(3δ − a²/R) (N, positive compressive). Zero at a = 0.
#[inline]
pub fn contact_force(m: &Material, a: f64, delta: f64) -> f64 {
    0.5 * m.k * a * (3.0 * delta - a * a / m.r)
}

/// Signed edge opening u = a²/R − δ (m). Positive: tensile (crack-like) edge.
#[inline]
pub fn edge_opening(m: &Material, a: f64, delta: f64) -> f64 {
    a * a / m.r - delta
}

/// Energy release rate G = 3 K u² / (8 π a) (J/m²) with u the edge opening. Only a crack-driving
/// quantity for u ≥ 0; see [`signed_energy_release_rate`].
#[inline]
pub fn energy_release_rate(m: &Material, a: f64, delta: f64) -> f64 {
    let u = edge_opening(m, a, delta);
    3.0 * m.k * u * u / (8.0 * PI * a)
}

/// Signed energy release rate 3 K u|u| / (8 π a) (J/m²): equal to G for a tensile edge and
/// negative for a compressive one, so that "G < w" (heal) stays true when the edge is compressed.
#[inline]
pub fn signed_energy_release_rate(m: &Material, a: f64, delta: f64) -> f64 {
    let u = edge_opening(m, a, delta);
    3.0 * m.k * u * u.abs() / (8.0 * PI * a)
}

/// Mode-I stress intensity at the contact edge K_I = 3 K u / (4 √(π a)) (Pa √m), signed.
/// G = K_I² / (2 E*) with E* = 3K/4.
#[inline]
pub fn stress_intensity(m: &Material, a: f64, delta: f64) -> f64 {
    3.0 * m.k * edge_opening(m, a, delta) / (4.0 * (PI * a).sqrt())
}

/// Edge opening at which G = w: u = √(8 π a w / (3K)) (m).
#[inline]
pub fn equilibrium_edge_opening(m: &Material, a: f64, w: f64) -> f64 {
    (8.0 * PI * a * w / (3.0 * m.k)).sqrt()
}

/// Indentation in equilibrium at work of adhesion w, eq. (13): δ = a²/R − √(8 π a w / (3K)) (m).
#[inline]
pub fn equilibrium_indentation(m: &Material, a: f64, w: f64) -> f64 {
    a * a / m.r - equilibrium_edge_opening(m, a, w)
}

/// Force in equilibrium at work of adhesion w: F = K a³/R − √(6 π w K a³) (N).
#[inline]
pub fn equilibrium_force(m: &Material, a: f64, w: f64) -> f64 {
    let a3 = a * a * a;
    m.k * a3 / m.r - (6.0 * PI * w * m.k * a3).sqrt()
}

/// Hertz force K a³/R (N), and the Hertz indentation a²/R.
#[inline]
pub fn hertz_force(m: &Material, a: f64) -> f64 {
    m.k * a * a * a / m.r
}

/// Hertz contact radius for indentation δ ≥ 0: a = √(R δ) (m); 0 for δ ≤ 0.
#[inline]
pub fn hertz_radius(m: &Material, delta: f64) -> f64 {
    (m.r * delta.max(0.0)).sqrt()
}

/// Contact stiffness ∂F/∂δ at fixed a: (3/2) K a (N/m).
#[inline]
pub fn contact_stiffness(m: &Material, a: f64) -> f64 {
    1.5 * m.k * a
}

/// Load-controlled pull-off radius a³ = 3 π w R² / (2K) (m).
pub fn load_controlled_pull_off_radius(m: &Material, w: f64) -> f64 {
    (3.0 * PI * w * m.r * m.r / (2.0 * m.k)).cbrt()
}

/// Load-controlled pull-off force −(3/2) π R w (N).
pub fn load_controlled_pull_off_force(m: &Material, w: f64) -> f64 {
    -1.5 * PI * m.r * w
}

/// Displacement-controlled pull-off radius a³ = π w R² / (6K) (m), where dδ/da = 0 on the JKR curve.
pub fn displacement_controlled_pull_off_radius(m: &Material, w: f64) -> f64 {
    (PI * w * m.r * m.r / (6.0 * m.k)).cbrt()
}

/// Displacement-controlled pull-off force −(5/6) π R w (N).
pub fn displacement_controlled_pull_off_force(m: &Material, w: f64) -> f64 {
    -5.0 / 6.0 * PI * m.r * w
}

/// Jump-in radius at δ = 0: a³ = 8 π w R² / (3K) (m).
pub fn jump_in_radius(m: &Material, w: f64) -> f64 {
    (8.0 * PI * w * m.r * m.r / (3.0 * m.k)).cbrt()
}

/// Eq. (28): work of adhesion from a measured force F at contact radius a,
/// w = (F_H − F)² / (6 π R F_H) with F_H = K a³/R (J/m²). Same relation as eq. (4).
pub fn work_of_adhesion_from_force(m: &Material, a: f64, force: f64) -> f64 {
    let fh = hertz_force(m, a);
    (fh - force).powi(2) / (6.0 * PI * m.r * fh)
}

/// Contact radius on the stable JKR branch in equilibrium with a compressive or tensile force
/// `force` ≥ −(3/2)πRw (N) at work of adhesion w: the largest root of
/// K a³/R − √(6πwK a³) = F. Solved in closed form in s = a^{3/2}:
/// (K/R) s² − √(6πwK) s − F = 0. Returns `None` below the load-controlled pull-off force.
pub fn equilibrium_radius_for_force(m: &Material, force: f64, w: f64) -> Option<f64> {
    let p = m.k / m.r;
    let q = (6.0 * PI * w * m.k).sqrt();
    let disc = q * q + 4.0 * p * force;
    if disc < 0.0 {
        return None;
    }
    let s = (q + disc.sqrt()) / (2.0 * p);
    Some(s.powf(2.0 / 3.0))
}

/// The JKR contact radius at work of adhesion w for indentation δ, on the stable
/// (displacement-controlled) branch a ≥ a_dc, where δ_eq(a) = a²/R − √(8πaw/(3K)) increases;
/// `None` below the branch's minimum δ (no contact). Bracketed by doubling from
/// max(a_dc, √(R|δ|)), then bisected to 1e-15 relative.
pub fn equilibrium_radius_for_indentation(m: &Material, delta: f64, w: f64) -> Option<f64> {
    let a_dc = displacement_controlled_pull_off_radius(m, w);
    let f = |a: f64| equilibrium_indentation(m, a, w) - delta;
    if !(delta.is_finite() && a_dc.is_finite()) || f(a_dc) > 0.0 {
        return None;
    }
    let (mut lo, mut hi) = (a_dc, 2.0 * a_dc.max((m.r * delta.abs()).sqrt()));
    let mut guard = 0;
    while f(hi) < 0.0 {
        lo = hi;
        hi *= 2.0;
        guard += 1;
        if guard > 200 {
            return None;
        }
    }
    // f is monotonic on the branch.
    let (lo, hi) = crate::numerics::bisect(lo, hi, 1e-15, |a| f(a) < 0.0);
    Some(0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    const M: Material = Material::PAPER;

    #[test]
    fn equilibrium_force_is_force_at_equilibrium_indentation() {
        for &a in &[1e-5, 1e-4, 1e-3, 3e-3] {
            let w = 0.3;
            let d = equilibrium_indentation(&M, a, w);
            let f1 = contact_force(&M, a, d);
            let f2 = equilibrium_force(&M, a, w);
            assert!((f1 - f2).abs() <= 1e-12 * f1.abs().max(f2.abs()).max(1e-12));
            // G at equilibrium equals w.
            assert!((energy_release_rate(&M, a, d) - w).abs() < 1e-12 * w);
        }
    }

    #[test]
    fn hertz_limit_w_to_zero() {
        let a = 1e-3;
        let d = equilibrium_indentation(&M, a, 0.0);
        assert!((d - a * a / M.r).abs() < 1e-18);
        assert!((equilibrium_force(&M, a, 0.0) - hertz_force(&M, a)).abs() < 1e-15);
    }

    #[test]
    fn pull_off_points_are_extrema_of_the_jkr_curve() {
        let w = M.w0;
        // Load-controlled: dF/da = 0 at a_po, with F = -3/2 pi R w.
        let a = load_controlled_pull_off_radius(&M, w);
        let h = 1e-7 * a;
        let df = equilibrium_force(&M, a + h, w) - equilibrium_force(&M, a - h, w);
        assert!(df.abs() / (2.0 * h) < 1e-6 * M.k * a);
        let f = equilibrium_force(&M, a, w);
        assert!((f / load_controlled_pull_off_force(&M, w) - 1.0).abs() < 1e-12);
        // Displacement-controlled: dδ/da = 0, F = -5/6 pi R w.
        let a = displacement_controlled_pull_off_radius(&M, w);
        let h = 1e-7 * a;
        let dd = equilibrium_indentation(&M, a + h, w) - equilibrium_indentation(&M, a - h, w);
        assert!((dd / (2.0 * h)).abs() < 1e-6 * a / M.r);
        let f = equilibrium_force(&M, a, w);
        assert!((f / displacement_controlled_pull_off_force(&M, w) - 1.0).abs() < 1e-12);
        // Jump-in: delta = 0.
        let a = jump_in_radius(&M, w);
        assert!(equilibrium_indentation(&M, a, w).abs() < 1e-12 * a * a / M.r);
    }

    #[test]
    fn eq28_inverts_equilibrium() {
        for &a in &[2e-4, 1e-3, 2e-3] {
            let w = 0.5;
            let f = equilibrium_force(&M, a, w);
            assert!((work_of_adhesion_from_force(&M, a, f) - w).abs() < 1e-12);
        }
    }

    #[test]
    fn signed_g_and_stress_intensity() {
        let a = 1e-3;
        let d_tensile = a * a / M.r - 1e-6;
        let d_comp = a * a / M.r + 1e-6;
        assert!(signed_energy_release_rate(&M, a, d_tensile) > 0.0);
        assert!(signed_energy_release_rate(&M, a, d_comp) < 0.0);
        let ki = stress_intensity(&M, a, d_tensile);
        let estar = 0.75 * M.k;
        assert!((ki * ki / (2.0 * estar) - energy_release_rate(&M, a, d_tensile)).abs() < 1e-12);
    }

    #[test]
    fn radius_for_force_roundtrip() {
        let w = M.w0;
        for &f in &[0.05, 0.0, -0.03] {
            let a = equilibrium_radius_for_force(&M, f, w).unwrap();
            assert!((equilibrium_force(&M, a, w) - f).abs() < 1e-12);
        }
        assert!(
            equilibrium_radius_for_force(&M, 1.01 * load_controlled_pull_off_force(&M, w), w)
                .is_none()
        );
    }

    #[test]
    fn equilibrium_radius_inverts_the_jkr_indentation() {
        let m = Material::PAPER;
        for &a in &[0.5e-3, 1.2e-3, 4e-3] {
            let d = equilibrium_indentation(&m, a, m.w0);
            let back = equilibrium_radius_for_indentation(&m, d, m.w0).unwrap_or(0.0);
            assert!((back / a - 1.0).abs() < 1e-12, "{a} -> {back}");
        }
        let a_dc = displacement_controlled_pull_off_radius(&m, m.w0);
        let d_min = equilibrium_indentation(&m, a_dc, m.w0);
        assert!(equilibrium_radius_for_indentation(&m, d_min - 1e-9, m.w0).is_none());
    }
}
