//! The other models the paper discusses (Sec. 1; docs/MODEL.md, "Other models"): Shui et al. (2020),
//! eqs. (5)–(7), and Yi et al. (2024), eq. (8). Sign convention as everywhere in the crate: the
//! force F > 0 is compressive, so pull-off forces are negative.
//!
//! # Shui et al., eqs. (5)–(7), and the corrections made here
//!
//! Eq. (5) as printed reads F_m = K a_m³/R − √(6π ω0 K a_m²) − (3/2) m ω² X_b K a_m /
//! √((3K a_m/2 − m ω²)² + c² ω²). Its second term has units √(N/m · N/m² · m²) = N/m^{1/2}…
//! only with a_m³ (and the work of adhesion w0 in place of the misprinted "ω0") is it a force: it
//! is then the JKR adhesive term √(6π w0 K a_m³) of eq. (13). [`shui_mean_force`] implements
//! F_m = K a_m³/R − √(6π w0 K a_m³) − (3/2) m ω² X_b K a_m / √((3K a_m/2 − m ω²)² + c² ω²).
//!
//! Shui's pull-off, eq. (6), F_po = −m ω² X_b √(1 + m ω²/c²), is not dimensionally consistent
//! either (m ω²/c² has units 1/kg). The evident correction is (m ω/c)²:
//! F_po = −m ω² X_b √(1 + (m ω/c)²) ([`shui_pull_off_eq6`]). It is exactly the extremum of the
//! dynamic (third) term of eq. (5) alone: with s = 3K a_m/2, M = m ω², D = c ω, the term is
//! −X_b M s/√((s − M)² + D²), whose magnitude peaks at s* = M + D²/M with the value
//! M X_b √(1 + M²/D²) = m ω² X_b √(1 + (m ω/c)²). Its c → ∞ limit is eq. (7), F = −m ω² X_b
//! ([`shui_pull_off_eq7`]); that limit is reached at s* → ∞, i.e. a_m → ∞.
//!
//! Neither (6) nor (7) depends on the Gent–Schultz constants (nor even on w0, K or R): that is the
//! paper's point against this model. Note also that (6) is not the minimum of eq. (5): that
//! minimum ([`shui_pull_off`]) includes the JKR terms, and for c → ∞ at fixed a_m the dynamic term
//! vanishes like 1/c, so the minimum of (5) tends to the static JKR pull-off −(3/2)π R w0, not to
//! eq. (7).
//!
//! # Yi et al., eq. (8)
//!
//! Hertz force plus an adhesive force w(ȧ) dπa²/dδ, with the Hertz relation a = √(Rδ) (so
//! dπa²/dδ = πR) and an imposed indentation δ = δ_m + δ_A sin ωt with δ_m = δ_A:
//! F(t) = K √R δ^{3/2} − π R w(ȧ) (the adhesive term pulls), and ȧ = (√R/2) δ_A ω cos ωt /
//! √(δ_m + δ_A sin ωt). The mean force over a cycle is the model's pull-off; there is no search.
//!
//! The apparent singularity of ȧ at ωt = 3π/2 (δ → 0) is not one: since
//! cos²θ = (1 − sin θ)(1 + sin θ), ȧ = (√(R δ_A) ω/2) sgn(cos θ) √(1 − sin θ), bounded by
//! ω √(R δ_A/2), with a jump from peeling to healing at θ = 3π/2 where the contact vanishes.
//! Substituting φ = θ/2 − π/4 (so 1 − sin θ = 2 sin²φ, 1 + sin θ = 2 cos²φ, dθ = 2 dφ):
//!
//! - ⟨K √R δ^{3/2}⟩ = K √R δ_A^{3/2} (1/π)∫_{−π/2}^{π/2} 2√2 cos³φ dφ = K √R δ_A^{3/2} · 8√2/(3π);
//! - ⟨w⟩ = (1/π)∫_0^{π/2} [w(−v̂ sin φ) + w(+v̂ sin φ)] dφ with v̂ = ω √(R δ_A/2) the peak speed:
//!   peeling for φ > 0, healing for φ < 0 (folded onto (0, π/2)). The integrand is smooth inside
//!   and has the |sin φ|^n kink at the end φ = 0, so a tanh-sinh rule converges fast.
//!
//! Area amplitude to indentation amplitude (for a CLI that speaks in a_A like the other models):
//! a = √(Rδ) runs from 0 to √(2Rδ_A), so a_A ≡ (a_max − a_min)/2 = √(2Rδ_A)/2, i.e.
//! δ_A = 2 a_A²/R ([`yi_indentation_amplitude_from_area_amplitude`]). Then the peak speed
//! v̂ = ω √(R δ_A/2) = a_A ω, the same v_max as in the imposed-area method.

use crate::adhesion::AdhesionLaw;
use crate::error::{non_negative, positive, ParamError};
use crate::jkr;
use crate::material::Material;
use serde::Serialize;
use std::f64::consts::{FRAC_PI_2, PI};

// ---------------------------------------------------------------------------------------------
// Shui et al.
// ---------------------------------------------------------------------------------------------

/// The oscillator of Shui et al.'s model: sphere mass, damping, base amplitude and frequency.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ShuiSystem {
    /// Sphere mass m (kg).
    pub mass: f64,
    /// Damping coefficient c (N·s/m).
    pub damping: f64,
    /// Base vibration amplitude X_b (m).
    pub base_amplitude: f64,
    /// Angular frequency ω (rad/s).
    pub omega: f64,
}

impl ShuiSystem {
    /// Check m > 0, c > 0 (c = 0 makes the resonance of eq. (5) unbounded), X_b ≥ 0, ω ≥ 0.
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("m", self.mass, "kg")?;
        positive(
            "c",
            self.damping,
            "N s/m (c = 0 makes the resonance of eq. (5) unbounded)",
        )?;
        non_negative("X_b", self.base_amplitude, "m")?;
        non_negative("omega", self.omega, "rad/s")?;
        Ok(())
    }
}

/// The dynamic (third) term of the corrected eq. (5) (N, ≤ 0 for X_b ≥ 0):
/// −(3/2) m ω² X_b K a_m / √((3K a_m/2 − m ω²)² + c² ω²).
#[inline]
pub fn shui_dynamic_term(m: &Material, s: &ShuiSystem, a_mean: f64) -> f64 {
    let mw2 = s.mass * s.omega * s.omega;
    let kc = 1.5 * m.k * a_mean;
    let cw = s.damping * s.omega;
    -mw2 * s.base_amplitude * kc / ((kc - mw2).hypot(cw))
}

/// Shui et al.'s mean force against mean contact radius, eq. (5) corrected (module docs):
/// F_m = K a_m³/R − √(6π w0 K a_m³) − (3/2) m ω² X_b K a_m / √((3K a_m/2 − m ω²)² + c² ω²) (N).
/// With X_b = 0 it is the JKR curve at w0.
#[inline]
pub fn shui_mean_force(m: &Material, s: &ShuiSystem, a_mean: f64) -> f64 {
    jkr::equilibrium_force(m, a_mean, m.w0) + shui_dynamic_term(m, s, a_mean)
}

/// Shui et al.'s pull-off, eq. (6) with the dimensional correction m ω²/c² → (m ω/c)²:
/// F_po = −m ω² X_b √(1 + (m ω/c)²) (N). The extremum of the dynamic term of eq. (5) alone; it
/// does not depend on the Gent–Schultz constants.
pub fn shui_pull_off_eq6(s: &ShuiSystem) -> f64 {
    let mw2 = s.mass * s.omega * s.omega;
    let ratio = s.mass * s.omega / s.damping;
    -mw2 * s.base_amplitude * (1.0 + ratio * ratio).sqrt()
}

/// Eq. (7), the c → ∞ limit of eq. (6): F_po = −m ω² X_b (N). Independent of c, w0 and the
/// Gent–Schultz constants.
pub fn shui_pull_off_eq7(s: &ShuiSystem) -> f64 {
    -s.mass * s.omega * s.omega * s.base_amplitude
}

/// Radius at which the dynamic term of eq. (5) peaks: 3K a*/2 = m ω² + (c ω)²/(m ω²)
/// = m ω² + c²/m (m); finite at ω = 0 too.
pub fn shui_peak_radius(m: &Material, s: &ShuiSystem) -> f64 {
    (s.mass * s.omega * s.omega + s.damping * s.damping / s.mass) / (1.5 * m.k)
}

/// The pull-off (minimum of eq. (5) over a_m) of Shui et al.'s model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ShuiPullOff {
    /// Mean contact radius at the minimum (m).
    pub a_mean: f64,
    /// Minimum mean force (N, negative).
    pub force: f64,
    /// force / F0 with F0 = −(3/2)π R w0.
    pub amplification: f64,
}

/// Pull-off of the corrected eq. (5): the global minimum of F_m(a_m) over a_m > 0.
///
/// F_m can have two minima, the JKR one near (3πR²w0/(2K))^(1/3) and a resonance dip near
/// 3K a_m/2 ≈ m ω², as narrow as c/(m ω) in relative terms. The search scans log a_m on 600
/// points between 10⁻⁴ of the smaller of the two radii and the radius where the JKR force alone
/// exceeds the largest possible dynamic pull (beyond it F_m > 0 > minimum), refines every scan
/// minimum with Brent, and also refines a bracket of ±10 cω around the dynamic peak a* (so a dip
/// narrower than the scan spacing is not missed). Errors name invalid parameters.
pub fn shui_pull_off(m: &Material, s: &ShuiSystem) -> Result<ShuiPullOff, ParamError> {
    m.validate()?;
    s.validate()?;
    let f = |a: f64| shui_mean_force(m, s, a);
    let a_jkr = jkr::load_controlled_pull_off_radius(m, m.w0);
    let a_peak = shui_peak_radius(m, s);
    let dyn_max = -shui_pull_off_eq6(s);
    let a_hi = jkr::equilibrium_radius_for_force(m, dyn_max.max(0.0), m.w0)
        .unwrap_or(a_jkr)
        .max(2.0 * a_jkr)
        .max(2.0 * a_peak);
    let a_lo = 1e-4 * a_jkr.min(if a_peak > 0.0 { a_peak } else { a_jkr });
    let n_scan = 600usize;
    let ratio = (a_hi / a_lo).ln() / (n_scan - 1) as f64;
    let at = |i: usize| a_lo * (ratio * i as f64).exp();
    let mut best = (a_jkr, f(a_jkr));
    let consider = |x: f64, fx: f64, best: &mut (f64, f64)| {
        if fx.is_finite() && fx < best.1 {
            *best = (x, fx);
        }
    };
    let (mut f_prev, mut f_cur) = (f(at(0)), f(at(1)));
    for i in 1..n_scan - 1 {
        let f_next = f(at(i + 1));
        if f_cur <= f_prev && f_cur <= f_next {
            let (x, fx) = crate::numerics::brent_minimize(f, at(i - 1), at(i + 1), 1e-12, 0.0, 200);
            consider(x, fx, &mut best);
            consider(at(i), f_cur, &mut best);
        }
        f_prev = f_cur;
        f_cur = f_next;
    }
    if a_peak > 0.0 && s.base_amplitude > 0.0 {
        let half = 10.0 * s.damping * s.omega / (1.5 * m.k);
        let lo = (a_peak - half).max(0.5 * a_lo);
        let (x, fx) = crate::numerics::brent_minimize(f, lo, a_peak + half, 1e-12, 0.0, 200);
        consider(x, fx, &mut best);
    }
    let (a_mean, force) = best;
    Ok(ShuiPullOff {
        a_mean,
        force,
        amplification: force / m.static_pull_off_force(),
    })
}

// ---------------------------------------------------------------------------------------------
// Yi et al.
// ---------------------------------------------------------------------------------------------

/// Indentation amplitude δ_A = 2 a_A²/R (m) whose Hertz contact radius a = √(Rδ), with
/// δ = δ_A (1 + sin ωt), oscillates with half-range a_A (module docs).
#[inline]
pub fn yi_indentation_amplitude_from_area_amplitude(m: &Material, a_amp: f64) -> f64 {
    2.0 * a_amp * a_amp / m.r
}

/// Cycle means of Yi et al.'s eq. (8) force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct YiMeanForce {
    /// Indentation amplitude δ_A = δ_m (m).
    pub delta_amp: f64,
    /// Peak contact-radius speed ω √(R δ_A/2) (m/s).
    pub peak_speed: f64,
    /// Mean Hertz force ⟨K √R δ^{3/2}⟩ = (8√2/(3π)) K √R δ_A^{3/2} (N).
    pub hertz: f64,
    /// Mean work of adhesion over the cycle ⟨w(ȧ)⟩ (J/m²).
    pub mean_work_of_adhesion: f64,
    /// Mean force ⟨F⟩ = hertz − π R ⟨w⟩ (N, compressive positive): the model's pull-off.
    pub force: f64,
    /// force / F0 with F0 = −(3/2)π R w0 of the material.
    pub amplification: f64,
}

/// Mean of the Hertz term over a cycle of δ = δ_A (1 + sin ωt):
/// ⟨K √R δ^{3/2}⟩ = (8√2/(3π)) K √R δ_A^{3/2} (N).
#[inline]
pub fn yi_mean_hertz_force(m: &Material, delta_amp: f64) -> f64 {
    8.0 * 2f64.sqrt() / (3.0 * PI) * m.k * m.r.sqrt() * delta_amp.powf(1.5)
}

/// Cycle mean of w(ȧ) with ȧ = v̂ sgn(cos θ) √((1 − sin θ)/2), v̂ the peak speed (m/s):
/// (1/π)∫_0^{π/2} [w(−v̂ sin φ) + w(v̂ sin φ)] dφ by tanh-sinh to 1e-12 relative (J/m²).
pub fn yi_mean_work_of_adhesion<L: AdhesionLaw + ?Sized>(law: &L, peak_speed: f64) -> f64 {
    if peak_speed == 0.0 {
        return law.w0();
    }
    crate::quadrature::integrate_adaptive(
        |phi| {
            let v = peak_speed * phi.sin();
            law.work_of_adhesion(-v) + law.work_of_adhesion(v)
        },
        0.0,
        FRAC_PI_2,
        1e-12,
    ) / PI
}

/// Yi et al.'s eq. (8) mean force for indentation amplitude `delta_amp` = δ_A = δ_m (m, ≥ 0) at
/// angular frequency `omega` (rad/s, ≥ 0), with any adhesion law. Errors name the parameter.
pub fn yi_mean_force<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    delta_amp: f64,
) -> Result<YiMeanForce, ParamError> {
    m.validate()?;
    non_negative("omega", omega, "rad/s")?;
    non_negative("delta_A", delta_amp, "m")?;
    let peak_speed = omega * (0.5 * m.r * delta_amp).sqrt();
    let hertz = yi_mean_hertz_force(m, delta_amp);
    let mean_w = yi_mean_work_of_adhesion(law, peak_speed);
    if !mean_w.is_finite() {
        return Err(ParamError::new(
            "delta_A",
            delta_amp,
            "the cycle-mean work of adhesion is not finite at this amplitude and frequency",
        ));
    }
    let force = hertz - PI * m.r * mean_w;
    Ok(YiMeanForce {
        delta_amp,
        peak_speed,
        hertz,
        mean_work_of_adhesion: mean_w,
        force,
        amplification: force / m.static_pull_off_force(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brent_finds_a_parabola_minimum() {
        let (x, fx) = crate::numerics::brent_minimize(
            |x| (x - 0.3).powi(2) + 1.0,
            -2.0,
            5.0,
            1e-12,
            1e-15,
            200,
        );
        assert!((x - 0.3).abs() < 1e-7, "{x}");
        assert!((fx - 1.0).abs() < 1e-13);
    }

    #[test]
    fn tanh_sinh_handles_endpoint_singularity() {
        // ∫_0^1 x^{-1/2} dx = 2; ∫_0^{π/2} sin x dx = 1.
        let i = crate::quadrature::integrate_adaptive(|x| 1.0 / x.sqrt(), 0.0, 1.0, 1e-13);
        assert!((i - 2.0).abs() < 1e-10, "{i}");
        let i = crate::quadrature::integrate_adaptive(f64::sin, 0.0, FRAC_PI_2, 1e-13);
        assert!((i - 1.0).abs() < 1e-13, "{i}");
    }
}
