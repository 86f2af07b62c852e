//! Small-oscillation transfer from base motion to indentation (paper Sec. 4, eqs. 36–39), with
//! the contact linearised as a spring k_c = (3/2) K a_m (∂F/∂δ at fixed a).
//!
//! Derivation (docs/MODEL.md, "Resonance transfer"). With δ = x_s + x_b, x_b = X_b sin ωt, and F ≈ F_m +
//! k_c (δ − δ_m), the oscillating part of eq. (30) with damping on the sphere is
//! m δ̈ + c δ̇ + (k + k_c) δ = m ẍ_b + c ẋ_b + k x_b = X_b [(k − mω²) sin ωt + cω cos ωt].
//! Writing A = k − mω², B = k + k_c − mω², D = cω and δ = δ_s sin ωt + δ_c cos ωt, the sine and
//! cosine balances B δ_s − D δ_c = A X_b and D δ_s + B δ_c = D X_b give
//! δ_s/X_b = (AB + D²)/(B² + D²), δ_c/X_b = D(B − A)/(B² + D²).
//! With damping on the contact (c δ̇, eq. 3) the forcing loses its c ẋ_b term and
//! δ_s/X_b = AB/(B² + D²), δ_c/X_b = −AD/(B² + D²).
//! The paper's printed eqs. (36)–(38) carry sign typos ((37) has −(ωc)² in the numerator, (36) the
//! wrong sign on X_b); [`paper_printed`] evaluates them as printed, for comparison only. The
//! far-from-resonance limit (39), δ_s/X_b = A/B, is right.

use crate::rig::{DampingOn, Rig};
use serde::Serialize;

/// Indentation response to a unit base amplitude: δ − δ_m = X_b (s sin ωt + c cos ωt).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Transfer {
    /// δ_s / X_b.
    pub sin: f64,
    /// δ_c / X_b.
    pub cos: f64,
}

impl Transfer {
    /// |δ_A / X_b|.
    pub fn magnitude(&self) -> f64 {
        self.sin.hypot(self.cos)
    }
    /// Phase φ (rad) with δ − δ_m = |δ_A| sin(ωt + φ).
    pub fn phase(&self) -> f64 {
        self.cos.atan2(self.sin)
    }
}

/// A = k − mω² and D = cω of the rig at ω.
fn coefficients(rig: &Rig, omega: f64) -> (f64, f64) {
    (
        rig.spring_stiffness() - rig.mass() * omega * omega,
        rig.damping_coefficient() * omega,
    )
}

/// The corrected linear transfer of the rig at angular frequency ω (rad/s), with the contact
/// linearised as a spring of stiffness `kc` (N/m; (3/2) K a_m).
pub fn linear(rig: &Rig, kc: f64, omega: f64) -> Transfer {
    let (a, d) = coefficients(rig, omega);
    let b = a + kc;
    let den = b * b + d * d;
    match rig.damping_on() {
        DampingOn::Sphere => Transfer {
            sin: (a * b + d * d) / den,
            cos: d * (b - a) / den,
        },
        DampingOn::Contact => Transfer {
            sin: a * b / den,
            cos: -a * d / den,
        },
    }
}

/// The paper's eqs. (37) and (36) as printed (sign typos included), for comparison: δ_s/X_b =
/// (AB − D²)/(B² + D²) and δ_c/X_b = −(D + D δ_s/X_b)/B.
pub fn paper_printed(rig: &Rig, kc: f64, omega: f64) -> Transfer {
    let (a, d) = coefficients(rig, omega);
    let b = a + kc;
    let s = (a * b - d * d) / (b * b + d * d);
    Transfer {
        sin: s,
        cos: -(d + d * s) / b,
    }
}

/// Eq. (39), the far-from-resonance limit δ_s/X_b = A/B (no damping).
pub fn far_from_resonance(rig: &Rig, kc: f64, omega: f64) -> f64 {
    let (a, _) = coefficients(rig, omega);
    a / (a + kc)
}

/// Undamped resonance frequency f_r = √((k + k_c)/m) / 2π (Hz); infinite for m = 0.
pub fn resonance_frequency(rig: &Rig, kc: f64) -> f64 {
    ((rig.spring_stiffness() + kc) / rig.mass()).sqrt() / (2.0 * std::f64::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::rig::{ContactFormation, Damping, Holder, Sphere};

    const KC: f64 = 1.5 * 9.33e6 * 2e-3;

    fn osc(on: DampingOn) -> Rig {
        Rig {
            material: crate::material::Material::PAPER,
            law: crate::adhesion::Law::default(),
            sphere: Sphere {
                mass: 3e-3,
                gravity: 0.0,
            },
            holder: Holder::Spring { stiffness: 200.0 },
            damping: Some(Damping { c: 0.8, on }),
            base: None,
            formation: ContactFormation::JumpIn,
        }
    }

    /// Independent check: integrate the linear oscillator m δ̈ + c δ̇ + (k + k_c) δ = forcing
    /// (sphere damping: m ẍ_b... written in x_s) with RK4 to steady state and project on sin, cos.
    fn simulate(o: &Rig, omega: f64) -> Transfer {
        let (m, k, c, kc) = (o.mass(), o.spring_stiffness(), o.damping_coefficient(), KC);
        // State: x_s, v_s with δ = x_s + x_b; m ẍ_s + c_s ẋ_s + c_c δ̇ + k x_s = −k_c δ.
        let (cs, cc) = match o.damping_on() {
            DampingOn::Sphere => (c, 0.0),
            DampingOn::Contact => (0.0, c),
        };
        let xb = |t: f64| (omega * t).sin();
        let vb = |t: f64| omega * (omega * t).cos();
        let f = |t: f64, x: f64, v: f64| {
            let d = x + xb(t);
            let dd = v + vb(t);
            (v, (-cs * v - cc * dd - k * x - kc * d) / m)
        };
        let period = 2.0 * std::f64::consts::PI / omega;
        let n_per = 2000;
        let h = period / n_per as f64;
        let (mut t, mut x, mut v) = (0.0, 0.0, 0.0);
        let decay = 2.0 * m / (c + 1e-12);
        let cycles = ((20.0 * decay / period).ceil() as usize).max(50);
        let (mut ss, mut sc) = (0.0, 0.0);
        for cyc in 0..=cycles {
            for _ in 0..n_per {
                if cyc == cycles {
                    let d = x + xb(t);
                    ss += d * (omega * t).sin() * h;
                    sc += d * (omega * t).cos() * h;
                }
                let (k1x, k1v) = f(t, x, v);
                let (k2x, k2v) = f(t + h / 2.0, x + h / 2.0 * k1x, v + h / 2.0 * k1v);
                let (k3x, k3v) = f(t + h / 2.0, x + h / 2.0 * k2x, v + h / 2.0 * k2v);
                let (k4x, k4v) = f(t + h, x + h * k3x, v + h * k3v);
                x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
                t += h;
            }
        }
        Transfer {
            sin: 2.0 * ss / period,
            cos: 2.0 * sc / period,
        }
    }

    #[test]
    fn linear_transfer_matches_a_simulated_linear_oscillator() {
        for on in [DampingOn::Sphere, DampingOn::Contact] {
            let o = osc(on);
            for &f in &[100.0, 300.0, 390.0, 500.0, 900.0] {
                let w = 2.0 * std::f64::consts::PI * f;
                let exact = linear(&o, KC, w);
                let sim = simulate(&o, w);
                let scale = exact.magnitude();
                assert!(
                    (exact.sin - sim.sin).abs() < 1e-5 * scale
                        && (exact.cos - sim.cos).abs() < 1e-5 * scale,
                    "{on:?} {f} Hz: closed form {exact:?}, simulated {sim:?}"
                );
            }
        }
    }

    #[test]
    fn printed_equations_differ_but_share_the_undamped_limit() {
        let mut o = osc(DampingOn::Sphere);
        let w = 2.0 * std::f64::consts::PI * 300.0;
        let (l, p) = (linear(&o, KC, w), paper_printed(&o, KC, w));
        assert!((l.sin - p.sin).abs() > 1e-6 * l.magnitude());
        o.damping = None;
        let (l, p) = (linear(&o, KC, w), paper_printed(&o, KC, w));
        assert!((l.sin - far_from_resonance(&o, KC, w)).abs() < 1e-15);
        assert!((p.sin - l.sin).abs() < 1e-15 && l.cos.abs() < 1e-15 && p.cos.abs() < 1e-15);
    }
}
