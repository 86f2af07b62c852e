//! The time-domain steady state side by side with the predictors (`djkr validate`).
//!
//! - **time domain**: the periodic steady state ([`super::Problem::solve`]), cycle means and first
//!   harmonics from the quadratures.
//! - **imposed area** (paper Sec. 2.1) at (ω, a_m, a_A) with a_m the simulated ⟨a⟩ and a_A =
//!   hypot(a_s, a_c) the amplitude of the simulated a(t)'s first harmonic. The imposed cycle has
//!   a = a_m + a_A sin θ; the simulated one a_m + a_A sin(ωt + φ_a) with φ_a = atan2(a_c, a_s), so
//!   θ = ωt + φ_a and the imposed δ_s, δ_c are rotated into the base's time frame:
//!   δ1 = e^{iφ_a}(δ_s + iδ_c) (phasor X = x_s + i x_c; [`crate::describing`], "Phasors").
//!   Means and δ_A need no rotation.
//! - **linear transfer** (docs/MODEL.md, eqs. 36–39 derived correctly) with k_c = (3/2) K a_0 at the
//!   static contact (w0) under the scene's mean load; its a_m, δ_m and F_m are the static values.
//! - **paper transfer**: eqs. (36)–(37) as printed ([`crate::transfer::paper_printed`]), and the
//!   far-from-resonance eq. (39), δ_s/X_b = A/B, reported separately.
//! - **harmonic balance** ([`crate::describing`]), the "beyond the paper" predictor.
//! - **force balance**: over a periodic cycle inertia and damping average out, so
//!   ⟨F⟩ = m g − k(⟨x_s⟩ − x_k) = m g + ⟨spring force⟩ must hold to integration accuracy. A
//!   violation is an internal inconsistency (the only failure `djkr validate` reports through
//!   its exit code); a disagreement between the models is a result.

use super::sweep::Linearisation;
use super::{Options, Problem, Steady, SteadyError};
use crate::dynamics::protocol::{Initial, Plan};
use crate::imposed_area;
use crate::rig::{Holder, Rig};
use serde::Serialize;

/// One method's predictions (SI; `None` where the method does not give the quantity).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Prediction {
    /// Mean contact radius a_m (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub a_mean: Option<f64>,
    /// First-harmonic amplitude of the contact radius a_A (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub a_amp: Option<f64>,
    /// Mean indentation δ_m (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delta_mean: Option<f64>,
    /// Coefficient of sin ωt in δ (m), base time frame x_b = X_b sin ωt.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delta_sin: Option<f64>,
    /// Coefficient of cos ωt in δ (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delta_cos: Option<f64>,
    /// First-harmonic amplitude δ_A = hypot(δ_s, δ_c) (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delta_amp: Option<f64>,
    /// Mean contact force F_m (N, compressive +).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_mean: Option<f64>,
}

impl Prediction {
    /// The fields as (name, value) pairs, in the order of the JSON keys.
    pub fn fields(&self) -> [(&'static str, Option<f64>); 7] {
        [
            ("a_mean", self.a_mean),
            ("a_amp", self.a_amp),
            ("delta_mean", self.delta_mean),
            ("delta_sin", self.delta_sin),
            ("delta_cos", self.delta_cos),
            ("delta_amp", self.delta_amp),
            ("force_mean", self.force_mean),
        ]
    }

    /// Relative differences from `reference` (same field order): δ_s and δ_c relative to the
    /// reference δ_A, the others relative to their own reference value; `None` where either
    /// side lacks the field or the reference scale is 0.
    pub fn relative_to(&self, reference: &Prediction) -> [(&'static str, Option<f64>); 7] {
        let amp = reference.delta_amp;
        let mut out = self.fields();
        for ((name, v), (_, r)) in out.iter_mut().zip(reference.fields()) {
            let scale = match *name {
                "delta_sin" | "delta_cos" => amp,
                _ => r.map(f64::abs),
            };
            *v = match (*v, r, scale) {
                (Some(x), Some(y), Some(s)) if s > 0.0 => Some((x - y) / s),
                _ => None,
            };
        }
        out
    }
}

/// The force-balance identity over the steady cycle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ForceBalance {
    /// ⟨F⟩ (N).
    pub force_mean: f64,
    /// m g − k(⟨x_s⟩ − ⟨x_k⟩) = m g + ⟨holder force⟩ (N).
    pub predicted: f64,
    /// |⟨F⟩ − predicted| / scale, scale = max(|⟨F⟩|, m g, |⟨holder force⟩|, |F1|).
    pub relative_error: f64,
    /// Largest relative error accepted as integration accuracy.
    pub tolerance: f64,
    /// relative_error ≤ tolerance.
    pub holds: bool,
}

/// Relative tolerance of the force-balance check. At a converged orbit the imbalance is
/// (m Δv + c Δx)/T with Δ the state's change over the cycle, which the steady-state tolerance
/// bounds by ~tol·(k + k_c)L: far below this; the quadratures themselves balance momentum to
/// rounding (measured in `docs/studies/checks.md`).
pub const FORCE_BALANCE_TOLERANCE: f64 = 1e-6;

/// Everything `djkr validate` reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// Base frequency f (Hz).
    pub frequency: f64,
    /// Base amplitude X_b (m).
    pub amplitude: f64,
    /// The steady state found.
    pub steady: Steady,
    /// Time-domain values.
    pub time_domain: Prediction,
    /// Imposed-area method at the simulated (ω, a_m, a_A).
    pub imposed_area: Option<Prediction>,
    /// Why the imposed-area cycle is missing.
    pub imposed_area_error: Option<String>,
    /// Corrected linear transfer (static a_m, δ_m, F_m).
    pub linear_transfer: Option<Prediction>,
    /// The paper's eqs. (36)–(37) as printed (static a_m, δ_m, F_m).
    pub paper_transfer: Option<Prediction>,
    /// Eq. (39): δ_s/X_b = A/B, δ_c = 0.
    pub paper_far_from_resonance: Option<Prediction>,
    /// Harmonic balance.
    pub harmonic_balance: Option<Prediction>,
    /// Why the predictors needing a static contact or harmonic balance are missing.
    pub predictor_error: Option<String>,
    /// Linear resonance f_r = √((k + k_c)/m)/2π (Hz), k_c = (3/2) K a_0.
    pub linear_resonance: Option<f64>,
    /// The force-balance identity.
    pub force_balance: ForceBalance,
}

/// Time-domain values of a steady state.
pub fn time_domain(s: &Steady) -> Prediction {
    let c = &s.cycle;
    Prediction {
        a_mean: Some(c.a_mean),
        a_amp: Some(s.a_amp()),
        delta_mean: Some(c.delta_mean),
        delta_sin: Some(c.delta_sin),
        delta_cos: Some(c.delta_cos),
        delta_amp: Some(s.delta_amp()),
        force_mean: Some(c.force_mean),
    }
}

/// The imposed-area cycle at the steady state's (ω, a_m, a_A), rotated into the base's frame.
pub fn imposed(rig: &Rig, s: &Steady) -> Result<Prediction, String> {
    let c = &s.cycle;
    let a_amp = s.a_amp();
    let omega = 2.0 * std::f64::consts::PI * s.frequency;
    let ic = imposed_area::cycle(&rig.material, &rig.law, omega, c.a_mean, a_amp)
        .map_err(|e| e.to_string())?;
    let phi = if a_amp > 0.0 {
        c.a_cos.atan2(c.a_sin)
    } else {
        0.0
    };
    let (sn, cs) = phi.sin_cos();
    Ok(Prediction {
        a_mean: Some(ic.a_mean),
        a_amp: Some(a_amp),
        delta_mean: Some(ic.harmonics.delta_mean),
        delta_sin: Some(ic.harmonics.delta_sin * cs - ic.harmonics.delta_cos * sn),
        delta_cos: Some(ic.harmonics.delta_sin * sn + ic.harmonics.delta_cos * cs),
        delta_amp: Some(ic.harmonics.delta_amp),
        force_mean: Some(ic.harmonics.force_mean),
    })
}

/// A linear prediction from a transfer δ1/X_b and the static contact.
fn linear_prediction(lin: &Linearisation, sin: f64, cos: f64, xb: f64) -> Prediction {
    let st = &lin.static_state;
    Prediction {
        a_mean: Some(st.a),
        a_amp: None,
        delta_mean: Some(st.delta),
        delta_sin: Some(sin * xb),
        delta_cos: Some(cos * xb),
        delta_amp: Some(sin.hypot(cos) * xb),
        force_mean: Some(st.force),
    }
}

/// The force-balance identity for a steady cycle of a rig.
pub fn force_balance(rig: &Rig, s: &Steady) -> ForceBalance {
    let c = &s.cycle;
    let weight = rig.weight();
    let holder = match rig.holder {
        Holder::None => 0.0,
        _ => c.spring_mean,
    };
    let predicted = weight + holder;
    let scale = c
        .force_mean
        .abs()
        .max(weight.abs())
        .max(holder.abs())
        .max(c.force_sin.hypot(c.force_cos))
        .max(f64::MIN_POSITIVE);
    let rel = (c.force_mean - predicted).abs() / scale;
    ForceBalance {
        force_mean: c.force_mean,
        predicted,
        relative_error: rel,
        tolerance: FORCE_BALANCE_TOLERANCE,
        holds: rel <= FORCE_BALANCE_TOLERANCE,
    }
}

/// Run the protocol to its steady state ([`Problem::from_plan`]) and compare.
pub fn compare(plan: &Plan, opts: &Options) -> Result<Comparison, SteadyError> {
    let (problem, start) = Problem::from_plan(plan)?;
    let steady = problem.solve(&start, opts)?;
    Ok(compare_steady(&problem, &start, steady))
}

/// Compare a steady state already found for `problem` (started from `start`, which sets the
/// predictors' mean load).
pub fn compare_steady(problem: &Problem, start: &Initial, steady: Steady) -> Comparison {
    let rig = problem.rig();
    let (f, xb) = (steady.frequency, steady.amplitude);
    let (imposed_area, imposed_area_error) = match imposed(rig, &steady) {
        Ok(p) => (Some(p), None),
        Err(e) => (None, Some(e)),
    };
    let lin = Linearisation::for_problem(problem, start);
    let (mut linear_transfer, mut paper_transfer, mut far, mut harmonic_balance) =
        (None, None, None, None);
    let mut predictor_error = None;
    let mut linear_resonance = None;
    match &lin {
        Ok(l) => {
            let t = l.linear(f);
            linear_transfer = Some(linear_prediction(l, t.sin, t.cos, xb));
            let p = l.paper(f);
            paper_transfer = Some(linear_prediction(l, p.sin, p.cos, xb));
            let a39 = l.far_from_resonance(f);
            far = Some(linear_prediction(l, a39, 0.0, xb));
            linear_resonance = Some(l.resonance_frequency()).filter(|x| x.is_finite());
            match l.setup.solve(f, xb, None) {
                Ok(h) => {
                    harmonic_balance = Some(Prediction {
                        a_mean: Some(h.a_mean),
                        a_amp: Some(h.a_amp),
                        delta_mean: Some(h.harmonics.delta_mean),
                        delta_sin: Some(h.harmonics.delta_sin),
                        delta_cos: Some(h.harmonics.delta_cos),
                        delta_amp: Some(h.harmonics.delta_amp),
                        force_mean: Some(h.harmonics.force_mean),
                    })
                }
                Err(e) => predictor_error = Some(format!("harmonic balance: {e}")),
            }
        }
        Err(e) => predictor_error = Some(e.to_string()),
    }
    Comparison {
        frequency: f,
        amplitude: xb,
        time_domain: time_domain(&steady),
        force_balance: force_balance(rig, &steady),
        steady,
        imposed_area,
        imposed_area_error,
        linear_transfer,
        paper_transfer,
        paper_far_from_resonance: far,
        harmonic_balance,
        predictor_error,
        linear_resonance,
    }
}
