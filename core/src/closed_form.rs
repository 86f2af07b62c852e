//! The paper's closed-form approximation of the imposed-area problem, eqs. (16)–(24), and its
//! inversion eq. (29) (docs/MODEL.md, "Imposed-area method").
//!
//! # The estimate (Sec. 2.2)
//!
//! For a(t) = a_m + a_A sin ωt with a_A ≪ a_m, the paper samples the indentation of eq. (13) at
//! two instants: at ωt = π/2 (a = a_m + a_A, ȧ = 0, so w = w0) and at ωt = π (a = a_m, peeling at
//! the peak speed a_A ω, so w = w0 (1 + C (a_A ω)^n)). With S = 8π a_m w0 / (3K) and
//! X = C (a_A ω)^n:
//!
//! - δ_{π/2} = (a_m + a_A)²/R − √S (eq. 14 with the root evaluated at a_m, as the paper does);
//! - δ_π = a_m²/R − √(S (1 + X)) (eq. 15).
//!
//! The mean δ_m = (δ_{π/2} + δ_π)/2 is, keeping eq. (16) as printed (it drops
//! a_m a_A/R + a_A²/(2R), and eqs. (18)–(22) are built on it),
//! δ_m = a_m²/R − ½(√(S(1+X)) + √S) = a_m²/R − √(8π a_m w_eff / (3K)) (eq. 22), with
//! w_eff = (w0/4)(√(1 + X) + 1)² (eq. 19). Put in eq. (10), it gives the JKR curve with w → w_eff,
//! eq. (18), whose minimum is eqs. (20)–(21).
//!
//! # The amplitude δ_A: derived and printed forms
//!
//! (δ_{π/2} − δ_π)/2 gives the **derived** amplitude
//! δ_A = a_m a_A/R + a_A²/(2R) + ½(√(S(1+X)) − √S), which vanishes at a_A = 0 as it must.
//! The paper prints (17), and hence (23), as δ_A = a_m a_A/R + ½(√(S(1+X)) + √S)
//! = a_m a_A/R + √(8π a_m w_eff/(3K)): a sign slip ("+ √S") and a dropped a_A²/(2R), so the
//! **printed** δ_A does not vanish at a_A = 0 (it equals √S there, the JKR edge opening). Both are
//! available through [`DeltaAmpForm`]; the derived one is the default. Against the exact
//! first-harmonic amplitude of the imposed-area method at pull-off (200 Hz, paper constants,
//! β = 2.5) both forms are low: for a_A = 0.05, 0.3, 1 mm the exact δ_A is 70, 133, 202 µm, the
//! derived form gives 42, 91, 180 µm and the printed one 59, 111, 193 µm (its spurious √S happens
//! to compensate part of the deficit). See `beta_study` in `tests/it/closed_form.rs`.
//!
//! # The β correction and which speed enters δ_A
//!
//! The paper corrects the speed in the effective work of adhesion, eq. (24): X → C (a_A ω/β)^n,
//! β ≈ 2.5 (β = 1 is the uncorrected eq. 19). For Figs. 5–6 it uses "(23) with (20) with corrected
//! effective work of adhesion (24)": δ_A is evaluated at a_m = a_m,po of eq. (20) with w_eff of
//! eq. (24). Here the corrected speed a_A ω/β enters **every** rate term, consistently for both
//! forms: printed δ_A = a_m a_A/R + √(8π a_m w_eff(β)/(3K)), derived
//! δ_A = a_m a_A/R + a_A²/(2R) + √(8π a_m w_eff(β)/(3K)) − √S. The geometric terms a_m a_A/R and
//! a_A²/(2R) carry no speed and are not corrected.
//!
//! All functions are pure, allocation-free and SI. The low-level ones assume validated inputs
//! (finite, a ≥ 0, β > 0); [`pull_off_approx`] and [`vibration_speed_for_amplification`] validate.

use crate::adhesion::AdhesionLaw;
use crate::error::{non_negative, positive, ParamError};
use crate::jkr;
use crate::material::Material;
use serde::Serialize;

/// The paper's corrective factor on the speed in eq. (24).
pub const BETA_PAPER: f64 = 2.5;

/// Which expression of the indentation amplitude δ_A to use (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum DeltaAmpForm {
    /// (δ_{π/2} − δ_π)/2 from eqs. (14)–(15):
    /// a_m a_A/R + a_A²/(2R) + ½(√(S(1+X)) − √S); zero at a_A = 0.
    #[default]
    Derived,
    /// Eq. (17)/(23) as printed: a_m a_A/R + ½(√(S(1+X)) + √S); equal to √S ≠ 0 at a_A = 0.
    Printed,
}

/// The rate factor C (a_A ω/β)^n = (a_A ω/(β v0))^n of eq. (24) (dimensionless). For any law,
/// w(−a_A ω/β)/w0 − 1 ([`AdhesionLaw::peel_rate_factor`]): 0 for a constant w.
#[inline]
pub fn rate_factor<L: AdhesionLaw + ?Sized>(law: &L, omega: f64, a_amp: f64, beta: f64) -> f64 {
    law.peel_rate_factor(a_amp * omega / beta)
}

/// Effective work of adhesion, eq. (24) (eq. 19 at β = 1):
/// w_eff = (w0/4)(√(1 + C (a_A ω/β)^n) + 1)² (J/m²), with w0 = `law.w0()`.
#[inline]
pub fn effective_work_of_adhesion<L: AdhesionLaw + ?Sized>(
    law: &L,
    omega: f64,
    a_amp: f64,
    beta: f64,
) -> f64 {
    let x = rate_factor(law, omega, a_amp, beta);
    0.25 * law.w0() * ((1.0 + x).sqrt() + 1.0).powi(2)
}

/// Mean force against mean contact radius, eq. (18): F_m = K a_m (a_m²/R − 3√(2π w_eff a_m/(3K)))
/// = K a_m³/R − √(6π w_eff K a_m³) (N, compressive positive): the JKR curve with w → w_eff.
#[inline]
pub fn mean_force(m: &Material, a_mean: f64, w_eff: f64) -> f64 {
    jkr::equilibrium_force(m, a_mean, w_eff)
}

/// Mean indentation, eq. (16) = eq. (22): δ_m = a_m²/R − √(8π a_m w_eff/(3K)) (m).
#[inline]
pub fn mean_indentation(m: &Material, a_mean: f64, w_eff: f64) -> f64 {
    jkr::equilibrium_indentation(m, a_mean, w_eff)
}

/// Mean contact radius at pull-off, eq. (20): a_m,po = (3π R² w_eff/(2K))^(1/3) (m).
#[inline]
pub fn pull_off_radius(m: &Material, w_eff: f64) -> f64 {
    jkr::load_controlled_pull_off_radius(m, w_eff)
}

/// Mean force at pull-off, eq. (21): F_m,po = −(3/2) π R w_eff (N).
#[inline]
pub fn pull_off_force(m: &Material, w_eff: f64) -> f64 {
    jkr::load_controlled_pull_off_force(m, w_eff)
}

/// Amplitude of the indentation oscillation δ_A (m) at mean radius `a_mean`, in the chosen form,
/// with the β-corrected speed a_A ω/β in the rate term (module documentation):
///
/// - [`DeltaAmpForm::Derived`]: a_m a_A/R + a_A²/(2R) + ½(√(S(1+X_β)) − √S);
/// - [`DeltaAmpForm::Printed`] (eqs. 17, 23): a_m a_A/R + ½(√(S(1+X_β)) + √S);
///
/// with S = 8π a_m w0/(3K), w0 = `law.w0()`, X_β = C (a_A ω/β)^n.
pub fn indentation_amplitude<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_mean: f64,
    a_amp: f64,
    beta: f64,
    form: DeltaAmpForm,
) -> f64 {
    let s = 8.0 * std::f64::consts::PI * a_mean * law.w0() / (3.0 * m.k);
    let root_s = s.sqrt();
    let x = rate_factor(law, omega, a_amp, beta);
    let root_peel = (s * (1.0 + x)).sqrt();
    let geometric = a_mean * a_amp / m.r;
    match form {
        DeltaAmpForm::Derived => geometric + 0.5 * a_amp * a_amp / m.r + 0.5 * (root_peel - root_s),
        DeltaAmpForm::Printed => geometric + 0.5 * (root_peel + root_s),
    }
}

/// The approximate pull-off state of eqs. (20)–(24) for one (ω, a_A, β), reported like the exact
/// imposed-area pull-off.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ApproxPullOff {
    /// Effective work of adhesion w_eff, eq. (24) (J/m²).
    pub w_eff: f64,
    /// Mean contact radius at pull-off a_m,po, eq. (20) (m).
    pub a_mean: f64,
    /// Mean indentation at pull-off δ_m,po, eq. (22) at a_m,po (m).
    pub delta_mean: f64,
    /// Indentation amplitude at pull-off δ_A,po, eq. (23) or its derived form at a_m,po (m).
    pub delta_amp: f64,
    /// Mean force at pull-off F_m,po, eq. (21) (N, negative: tensile).
    pub force: f64,
    /// Amplification F_m,po / F0 with F0 = [`Material::static_pull_off_force`] (uses the
    /// material's w0).
    pub amplification: f64,
    /// True when a_A < a_m,po, the regime in which the estimate was derived (no contact loss).
    pub small_amplitude: bool,
    /// Which δ_A form was used.
    pub form: DeltaAmpForm,
}

/// The closed-form pull-off for vibration at angular frequency `omega` (rad/s, ≥ 0) with
/// contact-radius amplitude `a_amp` (m, ≥ 0), corrective factor `beta` (> 0; the paper's value
/// is [`BETA_PAPER`]) and δ_A form `form`. Errors name the offending parameter. Any law: the
/// rate enters through w(−a_A ω/β) ([`rate_factor`]); a constant w gives amplification 1.
pub fn pull_off_approx<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_amp: f64,
    beta: f64,
    form: DeltaAmpForm,
) -> Result<ApproxPullOff, ParamError> {
    m.validate()?;
    positive("w0", law.w0(), "J/m^2")?;
    non_negative("omega", omega, "rad/s")?;
    non_negative("a_A", a_amp, "m")?;
    positive("beta", beta, "(dimensionless)")?;
    let w_eff = effective_work_of_adhesion(law, omega, a_amp, beta);
    if !w_eff.is_finite() {
        return Err(ParamError::new(
            "a_A*omega",
            a_amp * omega,
            "the rate factor w(-a_A omega/beta)/w0 - 1 overflows: reduce the vibration speed",
        ));
    }
    let a_mean = pull_off_radius(m, w_eff);
    let force = pull_off_force(m, w_eff);
    Ok(ApproxPullOff {
        w_eff,
        a_mean,
        delta_mean: mean_indentation(m, a_mean, w_eff),
        delta_amp: indentation_amplitude(m, law, omega, a_mean, a_amp, beta, form),
        force,
        amplification: force / m.static_pull_off_force(),
        small_amplitude: a_amp < a_mean,
        form,
    })
}

/// Amplification of the approximate pull-off, eq. (21)/(24) over the static one:
/// A = w_eff/w0 = ¼(√(1 + (v/(β v0))^n) + 1)² with v = a_A ω (dimensionless).
#[inline]
pub fn amplification<L: AdhesionLaw + ?Sized>(law: &L, speed: f64, beta: f64) -> f64 {
    let x = law.peel_rate_factor(speed / beta);
    0.25 * ((1.0 + x).sqrt() + 1.0).powi(2)
}

/// Eq. (29), derived exactly from eqs. (21) and (24): the vibration speed v = a_A ω (m/s) for
/// which the closed form predicts amplification `target` = A ≥ 1:
/// A = ¼(√(1 + (v/(β v0))^n) + 1)²  ⇒  v = β v0 ((2√A − 1)² − 1)^(1/n).
///
/// The paper prints v = β ((A^½ − 1)² − 1)/C)^(1/n) and evaluates it to 86 mm/s for A = 48,
/// β = 2.5, n = 0.531, v0 = 0.0445 mm/s. That arithmetic drops the ¼ of eq. (21): (A^½ − 1)² − 1
/// inverts A = (√(1+X) + 1)², i.e. an amplification of 48/4 = 12 in eq. (21). The exact inversion
/// for A = 48 gives ≈ 1.66 m/s; see [`vibration_speed_as_printed`].
///
/// Any law: v = β × [`AdhesionLaw::peel_speed_for_rate_factor`]; a law that never reaches the
/// rate factor (a constant w for A > 1, a saturated law beyond its plateau) is an error.
pub fn vibration_speed_for_amplification<L: AdhesionLaw + ?Sized>(
    law: &L,
    target: f64,
    beta: f64,
) -> Result<f64, ParamError> {
    positive("w0", law.w0(), "J/m^2")?;
    positive("beta", beta, "(dimensionless)")?;
    if !(target.is_finite() && target >= 1.0) {
        return Err(ParamError::new(
            "amplification",
            target,
            "must be a finite number >= 1 (the closed form never reduces pull-off)",
        ));
    }
    let x = (2.0 * target.sqrt() - 1.0).powi(2) - 1.0;
    required_speed(law, x, beta, target)
}

/// β × the peeling speed of rate factor x, or an error naming the amplification when the law
/// never reaches it or the speed overflows.
fn required_speed<L: AdhesionLaw + ?Sized>(
    law: &L,
    x: f64,
    beta: f64,
    target: f64,
) -> Result<f64, ParamError> {
    let v = beta * law.peel_speed_for_rate_factor(x);
    if v.is_finite() {
        Ok(v)
    } else if law.is_rate_independent() {
        Err(ParamError::new(
            "amplification",
            target,
            "a rate-independent (constant w) law never amplifies pull-off: only 1 is reachable",
        ))
    } else {
        Err(ParamError::new(
            "amplification",
            target,
            "no finite peeling speed reaches it with this law (or the speed overflows f64)",
        ))
    }
}

/// Eq. (29) exactly as printed in the paper: v = β v0 ((A^½ − 1)² − 1)^(1/n) (m/s), kept to
/// reproduce its 86 mm/s. It is the inverse of A = (√(1 + (v/(βv0))^n) + 1)², without the ¼ of
/// eq. (21), so it is not the inverse of the closed form (see
/// [`vibration_speed_for_amplification`]). Requires A ≥ 4 (A = 4 is zero speed in this reading).
pub fn vibration_speed_as_printed<L: AdhesionLaw + ?Sized>(
    law: &L,
    target: f64,
    beta: f64,
) -> Result<f64, ParamError> {
    positive("w0", law.w0(), "J/m^2")?;
    positive("beta", beta, "(dimensionless)")?;
    if !(target.is_finite() && target >= 4.0) {
        return Err(ParamError::new(
            "amplification",
            target,
            "eq. (29) as printed needs a finite number >= 4",
        ));
    }
    let x = (target.sqrt() - 1.0).powi(2) - 1.0;
    required_speed(law, x, beta, target)
}

/// The exact imposed-area amplification in the small-amplitude limit a_A/a_m → 0 at fixed peak
/// speed v = a_A ω (dimensionless), for any law: A₀ = ⟨√(w/w0)⟩².
///
/// Derivation: with a ≈ a_m over the cycle, eq. (13) gives δ(θ) = a_m²/R − √(8π a_m w(θ)/(3K)),
/// so δ_m = a_m²/R − √(8π a_m/(3K)) ⟨√w⟩ and, by eq. (10), F_m(a_m) is the JKR curve with
/// √w_eff = ⟨√w⟩: its minimum is −(3/2)π R ⟨√w⟩². With ȧ = v cos θ, folding each half cycle onto
/// φ ∈ (0, π/2): ⟨√w⟩ = (1/π)∫₀^{π/2} [√w(−v sin φ) + √w(v sin φ)] dφ (tanh-sinh, 1e-12).
///
/// The paper's eq. (19) replaces this mean by the two-point value ½(√w(−v) + √w0): it keeps the
/// peeling peak and ignores the healing half, where w < w0. That is why no single β makes
/// eq. (24) match the exact pull-off over all n (see [`crate::beta_fit`]).
pub fn small_amplitude_amplification<L: crate::adhesion::AdhesionLaw + ?Sized>(
    law: &L,
    speed: f64,
) -> f64 {
    let w0 = law.w0();
    if speed == 0.0 {
        return 1.0;
    }
    let mean_root = crate::quadrature::integrate_adaptive(
        |phi| {
            let v = speed * phi.sin();
            (law.work_of_adhesion(-v) / w0).sqrt() + (law.work_of_adhesion(v) / w0).sqrt()
        },
        0.0,
        std::f64::consts::FRAC_PI_2,
        1e-12,
    ) / std::f64::consts::PI;
    mean_root * mean_root
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adhesion::{ConstantW, GentSchultz, SaturatedGentSchultz};

    #[test]
    fn w_eff_at_speed_v0_beta_one() {
        // X = 1 at a_A ω = v0: w_eff = w0 (√2 + 1)²/4.
        let law = GentSchultz::PAPER;
        let w = effective_work_of_adhesion(&law, 1.0, law.v0, 1.0);
        let expect = law.w0 * (2f64.sqrt() + 1.0).powi(2) / 4.0;
        assert!((w / expect - 1.0).abs() < 1e-14);
    }

    #[test]
    fn bad_inputs_are_named() {
        let m = Material::PAPER;
        let law = GentSchultz::PAPER;
        let e = pull_off_approx(&m, &law, 1.0, -1.0, 2.5, DeltaAmpForm::Derived).unwrap_err();
        assert_eq!(e.name, "a_A");
        let e = pull_off_approx(&m, &law, 1.0, 1e-4, 0.0, DeltaAmpForm::Derived).unwrap_err();
        assert_eq!(e.name, "beta");
        let e = vibration_speed_for_amplification(&law, 0.5, 2.5).unwrap_err();
        assert_eq!(e.name, "amplification");
        let e = vibration_speed_for_amplification(&law, f64::NAN, 2.5).unwrap_err();
        assert_eq!(e.name, "amplification");
    }

    /// The closed forms take any law through w(−v): Gent–Schultz through its exact overrides and
    /// through the trait's defaults agree; a constant w gives amplification 1 and no speed for
    /// A > 1; a saturated law has no speed beyond its plateau.
    #[test]
    #[allow(clippy::float_cmp)] // a constant w: rate factor 0 and w_eff = w0 exactly
    fn any_law_through_the_peeling_branch() {
        struct ViaDefaults(GentSchultz);
        impl AdhesionLaw for ViaDefaults {
            fn w0(&self) -> f64 {
                self.0.w0
            }
            fn work_of_adhesion(&self, adot: f64) -> f64 {
                self.0.work_of_adhesion(adot)
            }
            fn speed_scale(&self) -> f64 {
                self.0.v0
            }
        }
        let m = Material::PAPER;
        let gs = GentSchultz::PAPER;
        let generic = ViaDefaults(gs);
        let omega = 2.0 * std::f64::consts::PI * 300.0;
        for a_amp in [1e-6, 1e-4, 1e-3] {
            let a = pull_off_approx(&m, &gs, omega, a_amp, 2.5, DeltaAmpForm::Derived).unwrap();
            let b =
                pull_off_approx(&m, &generic, omega, a_amp, 2.5, DeltaAmpForm::Derived).unwrap();
            assert!((a.force / b.force - 1.0).abs() < 1e-12, "{a:?} {b:?}");
            assert!(
                (a.delta_amp / b.delta_amp - 1.0).abs() < 1e-9,
                "{a:?} {b:?}"
            );
        }
        for target in [1.5, 48.0] {
            let a = vibration_speed_for_amplification(&gs, target, 2.5).unwrap();
            let b = vibration_speed_for_amplification(&generic, target, 2.5).unwrap();
            assert!((a / b - 1.0).abs() < 1e-9, "{a} {b}");
        }
        let cw = ConstantW { w0: 0.24 };
        let c = pull_off_approx(&m, &cw, omega, 1e-3, 2.5, DeltaAmpForm::Derived).unwrap();
        assert_eq!(c.amplification, 1.0);
        assert_eq!(c.w_eff, cw.w0);
        assert_eq!(
            vibration_speed_for_amplification(&cw, 1.0, 2.5).unwrap(),
            0.0
        );
        let e = vibration_speed_for_amplification(&cw, 2.0, 2.5).unwrap_err();
        assert!(e.to_string().contains("rate-independent"), "{e}");
        // Plateau of the saturated law: w0 (1 + (v_sat/v0)^n), amplification < ¼(√(2 + X) + 1)².
        let sat = SaturatedGentSchultz::new(gs.w0, gs.v0, gs.n, 100.0 * gs.v0).unwrap();
        let x_sat = gs.rate_factor(100.0 * gs.v0);
        let a_max = 0.25 * ((1.0 + x_sat).sqrt() + 1.0).powi(2);
        let v = vibration_speed_for_amplification(&sat, 0.5 * (1.0 + a_max), 2.5).unwrap();
        assert!(v.is_finite() && v > 0.0);
        let back = amplification(&sat, v, 2.5);
        assert!((back / (0.5 * (1.0 + a_max)) - 1.0).abs() < 1e-8, "{back}");
        assert!(vibration_speed_for_amplification(&sat, 1.01 * a_max, 2.5).is_err());
    }
}
