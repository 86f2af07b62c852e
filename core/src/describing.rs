//! Describing-function (harmonic-balance) predictor of the small and moderate oscillations of the
//! sphere, built on the imposed-area cycle and solved self-consistently with eq. (30).
//!
//! ## Ansatz
//! In periodic steady state the contact radius is taken as a(t) = a_m + a_A sin(ωt + ψ), the
//! imposed-area ansatz with a phase. With θ = ωt + ψ, [`imposed_area::cycle`] gives δ(θ) and F(θ)
//! over the cycle: their means δ_m, F_m and first harmonics δ_s sin θ + δ_c cos θ,
//! F_s sin θ + F_c cos θ.
//!
//! ## Phasors
//! A first harmonic x(t) = x_s sin ωt + x_c cos ωt is written as the complex number
//! X = x_s + i x_c. Then ẋ = ω(x_s cos ωt − x_c sin ωt) has phasor ω(−x_c + i x_s) = iωX, so d/dt
//! is iω (and d²/dt² is −ω²). The base x_b = X_b sin ωt has phasor X_b (real). A shift of the
//! time origin by ψ/ω rotates phasors: with sin θ = sin ωt cos ψ + cos ωt sin ψ and
//! cos θ = cos ωt cos ψ − sin ωt sin ψ, the t-phasor of δ_s sin θ + δ_c cos θ is
//! (δ_s cos ψ − δ_c sin ψ) + i(δ_s sin ψ + δ_c cos ψ) = e^{iψ}(δ_s + i δ_c). So
//! δ1 = e^{iψ}(δ_s + i δ_c) and F1 = e^{iψ}(F_s + i F_c).
//!
//! ## Harmonic balance of eq. (30)
//! m ẍ_s + c ẋ_s + k(x_s − x_k) = −F + m g with x_s = δ − x_b, x_b = X_b sin ωt.
//! - Mean (⟨ẍ_s⟩ = ⟨ẋ_s⟩ = ⟨x_b⟩ = 0, so ⟨x_s⟩ = δ_m): F_m = m g − k(δ_m − x_k).
//! - First harmonic, damping on the sphere (c ẋ_s): with A = k − mω², D = cω, Z = A + iD and
//!   X_s = δ1 − X_b: Z(δ1 − X_b) = −F1.
//! - Damping on the contact (c δ̇): A(δ1 − X_b) + iD δ1 = −F1.
//!
//! Check: with a linear contact F1 = k_c δ1 the sphere case gives δ1/X_b = (A + iD)/(B + iD),
//! B = A + k_c, i.e. δ_s/X_b = (AB + D²)/(B² + D²), δ_c/X_b = D(B − A)/(B² + D²), which is
//! [`crate::transfer::linear`]; the contact case gives A(B − iD)/(B² + D²), also as there.
//!
//! Unknowns (a_m, a_A, ψ), three real equations (the mean and the real and imaginary parts of
//! the first harmonic). They are solved by damped Newton in the variables (a_m, ln a_A, ψ): the
//! logarithm keeps the Jacobian well scaled when a_A is tiny, as it is under a Gent–Schultz law
//! (δ1 grows like a_A^n there, see below). The ψ column of the Jacobian is exact
//! (∂δ1/∂ψ = iδ1, ∂F1/∂ψ = iF1), the other two are central finite differences. The start is a
//! describing-function fixed point: the linear transfer with a complex contact stiffness κ
//! (initially k_c = (3/2) K a_0), a_A matched to its |δ1|, κ updated to F1/δ1, a few times.
//! [`continuation`] walks an increasing list of base amplitudes with adaptive substeps.
//!
//! ## Effective contact (describing function)
//! F1 = (k_eff + iω c_eff) δ1 ([`effective_contact`]), independent of ψ (both phasors rotate
//! together). c_eff > 0 means the contact absorbs energy: the work done on it per cycle is
//! ∮ F dδ = π ω c_eff |δ1|². This is how adhesion hysteresis (peeling at w > w0, healing at
//! w < w0) shows up as damping.
//!
//! ## Small-amplitude limits (a real finding about eq. (37))
//! - Rate-independent law (constant w): the contact moves along the JKR equilibrium curve, so
//!   δ1 = δ_eq'(a_m) α and F1 = F_eq'(a_m) α to first order, and F1/δ1 → the JKR tangent stiffness
//!   k_t = F_eq'/δ_eq' = k_c (2a/R − 3s)/(2a/R − s), s = √(2πw/(3K a)) ([`tangent_stiffness`]),
//!   with no damping. k_t < k_c always; k_t = 0 at the load-controlled pull-off radius. Eq. (37)'s
//!   k_c = (3/2) K a_m (∂F/∂δ at fixed a) is not the small-signal stiffness of this model.
//! - Gent–Schultz law with n < 1: w − w0 ∝ |ȧ|^n, so δ1 ∝ a_A^n ≫ a_A and a_A → 0 faster than X_b:
//!   the contact line is effectively pinned and F1/δ1 → k_c (eq. (37) is then right), with
//!   c_eff ∝ a_A^{1−n} → 0.
//!
//! ## Limitations
//! When a_A > a_m the imposed cycle loses contact; the imposed-area method then sets δ = 0 out of
//! contact, which is not the free flight of the sphere. [`solve`] and [`solutions`] never return
//! such cycles ([`DescribingError::ContactLost`]); [`at_contact_amplitude`] does, flagged by
//! `contact_fraction < 1`, and they should not be trusted.
//! Near a nonlinear resonance one X_b can have three solutions (a fold): [`solutions`] returns
//! them all, [`solve`] one of them. A sinusoidal a(t) is an ansatz: the time-domain
//! a(t) has higher harmonics, which this predictor ignores. With damping on the contact, δ1 = 0 at
//! ω² = k/m (an anti-resonance of this model), where ln a_A → −∞: no solution is found there.

use crate::adhesion::AdhesionLaw;
use crate::dynamics::protocol::Initial;
use crate::error::ParamError;
use crate::imposed_area::{self, Cycle, Harmonics};
use crate::jkr;
use crate::material::Material;
use crate::rig::{DampingOn, Holder, Rig, StaticError};
pub use crate::rig::{StaticState, Support};
use crate::transfer::Transfer;
use nalgebra::Complex;
use serde::Serialize;
use std::f64::consts::PI;
use thiserror::Error;

/// A starting point for Newton: the imposed cycle a = a_m + a_A sin(ωt + ψ).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Guess {
    /// a_m (m).
    pub a_mean: f64,
    /// a_A (m), > 0.
    pub a_amp: f64,
    /// ψ (rad).
    pub phase: f64,
}

/// A harmonic-balance solution: a(t) = a_mean + a_amp sin(ωt + phase), and the indentation and
/// force it implies, δ(t) ≈ δ_m + δ_s sin ωt + δ_c cos ωt (time origin of the base motion
/// x_b = X_b sin ωt), F(t) likewise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HarmonicBalance {
    /// Imposed mean contact radius a_m (m).
    pub a_mean: f64,
    /// Contact-radius amplitude a_A (m).
    pub a_amp: f64,
    /// Phase ψ of the contact radius relative to the base motion (rad).
    pub phase: f64,
    /// Mean δ_m = ⟨x_s⟩ and the coefficients of sin ωt and cos ωt in δ, and the same of the
    /// contact force F (time origin of the base motion; their fields sit at this level in
    /// JSON).
    #[serde(flatten)]
    pub harmonics: Harmonics,
    /// Fraction of the period in contact (< 1: the solution is outside the method's validity).
    pub contact_fraction: f64,
    /// Spring end x_k used (m).
    pub x_k: f64,
    /// Base amplitude X_b (m).
    pub base_amplitude: f64,
    /// Angular frequency ω (rad/s).
    pub omega: f64,
    /// Newton iterations spent (summed over continuation substeps when [`solve`] needed them;
    /// 0 from [`at_contact_amplitude`], whose X_b and ψ are closed forms).
    pub iterations: usize,
    /// Relative residual at the solution: the largest of the mean and first-harmonic equation
    /// residuals, each divided by the sum of the magnitudes of its terms. ≤ [`ACCEPT`] except at
    /// base amplitudes so small that the first harmonic sits at the quadrature's rounding floor
    /// ([`ROUNDING_FLOOR`]).
    pub residual: f64,
}

impl HarmonicBalance {
    /// δ1 / X_b as a [`Transfer`], comparable with [`crate::transfer::linear`].
    pub fn transfer(&self) -> Transfer {
        Transfer {
            sin: self.harmonics.delta_sin / self.base_amplitude,
            cos: self.harmonics.delta_cos / self.base_amplitude,
        }
    }

    /// The solution as a starting point for a neighbouring problem.
    pub fn guess(&self) -> Guess {
        Guess {
            a_mean: self.a_mean,
            a_amp: self.a_amp,
            phase: self.phase,
        }
    }

    /// Effective contact stiffness and damping F1/δ1 = k_eff + iω c_eff of this solution
    /// (N/m, N s/m); `None` at zero amplitude.
    pub fn effective_contact(&self) -> Option<EffectiveContact> {
        effective_from_phasors(
            self.harmonics.delta_sin,
            self.harmonics.delta_cos,
            self.harmonics.force_sin,
            self.harmonics.force_cos,
            self.omega,
        )
    }
}

/// Describing-function contact: F1 = (stiffness + iω damping) δ1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EffectiveContact {
    /// k_eff = Re(F1/δ1) (N/m).
    pub stiffness: f64,
    /// c_eff = Im(F1/δ1)/ω (N s/m); > 0 when the contact dissipates energy.
    pub damping: f64,
}

/// Why the predictor has no answer.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DescribingError {
    /// An input out of range.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// No static contact equilibrium to start from.
    #[error("no static contact: {0}")]
    NoStaticState(String),
    /// Newton (with continuation) did not converge.
    #[error(
        "harmonic balance did not converge at omega = {omega} rad/s, X_b = {base_amplitude} m \
         after {iterations} iterations (relative residual {residual:e})"
    )]
    NotConverged {
        /// ω (rad/s).
        omega: f64,
        /// X_b (m).
        base_amplitude: f64,
        /// Iterations spent.
        iterations: usize,
        /// Best relative residual reached (may be infinite when no cycle could be evaluated).
        residual: f64,
    },
    /// The only harmonic-balance solution found loses contact for part of the cycle (a_A > a_m),
    /// where the imposed-area method sets δ = 0 instead of following the sphere's flight: the
    /// regime of impacts, outside this predictor.
    #[error(
        "at omega = {omega} rad/s, X_b = {base_amplitude} m the contact is lost for part of the \
         cycle (contact fraction {contact_fraction}): impacts, outside the predictor"
    )]
    ContactLost {
        /// ω (rad/s).
        omega: f64,
        /// X_b (m).
        base_amplitude: f64,
        /// Fraction of the period in contact of the truncated solution.
        contact_fraction: f64,
    },
    /// The scenario cannot be mapped onto this predictor.
    #[error("scenario not supported: {0}")]
    Unsupported(String),
}

/// Relative residual at which Newton stops.
const TARGET: f64 = 1e-12;
/// Relative residual a solution must reach to be returned.
pub const ACCEPT: f64 = 1e-10;
const MAX_NEWTON: usize = 60;
/// Absolute rounding floor of the first-harmonic equation, as a fraction of the Hertz force
/// K (a_m + a_A)³/R: F1 is a small difference of node values of that size (summed over the
/// cycle), so at tiny base amplitudes |F1| ~ 1e-8 N the relative residual cannot reach
/// [`ACCEPT`]. A solution whose mean equation is within [`ACCEPT`] and whose first-harmonic
/// residual (N) is below this floor is accepted; its `residual` then reports the larger
/// relative value honestly.
pub const ROUNDING_FLOOR: f64 = 1e-13;

/// JKR tangent stiffness dF/dδ along the equilibrium curve at work of adhesion w (N/m):
/// k_t = F_eq'(a)/δ_eq'(a) = (3/2) K a (2a/R − 3s)/(2a/R − s), s = √(2πw/(3K a)). Infinite at the
/// displacement-controlled pull-off radius (δ_eq' = 0), negative between it and the
/// load-controlled one. The small-amplitude stiffness of a rate-independent contact.
pub fn tangent_stiffness(m: &Material, a: f64, w: f64) -> f64 {
    let s = (2.0 * PI * w / (3.0 * m.k * a)).sqrt();
    let t = 2.0 * a / m.r;
    jkr::contact_stiffness(m, a) * (t - 3.0 * s) / (t - s)
}

fn effective_from_phasors(
    ds: f64,
    dc: f64,
    fs: f64,
    fc: f64,
    omega: f64,
) -> Option<EffectiveContact> {
    let den = ds * ds + dc * dc;
    if !(den > 0.0 && den.is_finite() && omega > 0.0) {
        return None;
    }
    // F1/δ1 = (fs + i fc)(ds − i dc)/|δ1|².
    let re = (fs * ds + fc * dc) / den;
    let im = (fc * ds - fs * dc) / den;
    (re.is_finite() && im.is_finite()).then_some(EffectiveContact {
        stiffness: re,
        damping: im / omega,
    })
}

/// Effective (describing-function) contact stiffness and damping of the imposed cycle
/// a = a_m + a_A sin θ at ω: F1/δ1 = k_eff + iω c_eff (N/m, N s/m). Independent of the phase.
/// Errors on invalid inputs and on a_A = 0 or a cycle without indentation harmonic.
pub fn effective_contact<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_mean: f64,
    a_amp: f64,
) -> Result<EffectiveContact, ParamError> {
    let c = imposed_area::cycle(m, law, omega, a_mean, a_amp)?;
    effective_from_phasors(
        c.harmonics.delta_sin,
        c.harmonics.delta_cos,
        c.harmonics.force_sin,
        c.harmonics.force_cos,
        omega,
    )
    .ok_or_else(|| {
        ParamError::new(
            "a_amp",
            a_amp,
            "must give a nonzero indentation harmonic (a_A > 0)",
        )
    })
}

/// Harmonic balance needs a rig whose indentation is not prescribed.
fn check_rig(rig: &Rig) -> Result<(), DescribingError> {
    if rig.holder == Holder::Rigid {
        return Err(DescribingError::Unsupported(
            "rigid holder: the indentation is prescribed, nothing to balance".into(),
        ));
    }
    Ok(())
}

impl From<StaticError> for DescribingError {
    fn from(e: StaticError) -> Self {
        match e {
            StaticError::Param(p) => DescribingError::Param(p),
            StaticError::NoContact(s) => DescribingError::NoStaticState(s),
        }
    }
}

/// The static contact under `support` at w0 (no vibration): [`Rig::static_state`], for a rig
/// harmonic balance can describe (not a rigid link).
pub fn static_state(rig: &Rig, support: Support) -> Result<StaticState, DescribingError> {
    check_rig(rig)?;
    Ok(rig.static_state(support)?)
}

/// Phasors (re = sine part, im = cosine part; see the module doc).
type C = Complex<f64>;

/// The phasor rotated by e^{iψ}.
fn rot(z: C, psi: f64) -> C {
    let (s, c) = psi.sin_cos();
    z * C::new(c, s)
}

/// One problem: everything but the unknowns.
struct Balance<'a> {
    rig: &'a Rig,
    x_k: f64,
    xb: f64,
    omega: f64,
}

/// The residual at (a_m, ln a_A, ψ), with what is needed to report it.
#[derive(Clone, Copy)]
struct Eval {
    cycle: Cycle,
    /// δ1, F1 in the time frame.
    d1: C,
    f1: C,
    /// [mean, Re first harmonic, Im first harmonic] (N).
    r: [f64; 3],
    /// Relative residual (see [`HarmonicBalance::residual`]).
    rel: f64,
    /// The mean equation is within [`ACCEPT`] and the first-harmonic residual is below the
    /// rounding floor of the quadrature (see [`ROUNDING_FLOOR`]).
    at_floor: bool,
}

impl Balance<'_> {
    fn a_coef(&self) -> f64 {
        self.rig.spring_stiffness() - self.rig.mass() * self.omega * self.omega
    }
    fn d_coef(&self) -> f64 {
        self.rig.damping_coefficient() * self.omega
    }

    /// First-harmonic residual and the sum of its term magnitudes, from δ1, F1 (time frame).
    fn harmonic(&self, d1: C, f1: C) -> (C, f64) {
        let (a, d) = (self.a_coef(), self.d_coef());
        let xs = d1 - C::new(self.xb, 0.0);
        match self.rig.damping_on() {
            DampingOn::Sphere => {
                let z = C::new(a, d) * xs;
                (f1 + z, f1.norm() + z.norm())
            }
            DampingOn::Contact => {
                let z1 = xs * a;
                let z2 = C::new(0.0, d) * d1;
                (f1 + z1 + z2, f1.norm() + z1.norm() + z2.norm())
            }
        }
    }

    fn eval(&self, x: [f64; 3]) -> Option<Eval> {
        let a_amp = x[1].exp();
        let cycle =
            imposed_area::cycle(&self.rig.material, &self.rig.law, self.omega, x[0], a_amp).ok()?;
        let d1 = rot(
            C::new(cycle.harmonics.delta_sin, cycle.harmonics.delta_cos),
            x[2],
        );
        let f1 = rot(
            C::new(cycle.harmonics.force_sin, cycle.harmonics.force_cos),
            x[2],
        );
        let k = self.rig.spring_stiffness();
        let weight = self.rig.weight();
        let spring = k * (cycle.harmonics.delta_mean - self.x_k);
        let r0 = cycle.harmonics.force_mean + spring - weight;
        let s0 = cycle.harmonics.force_mean.abs() + spring.abs() + weight.abs();
        let (r1, s1) = self.harmonic(d1, f1);
        let rel0 = r0.abs() / s0.max(f64::MIN_POSITIVE);
        let rel = rel0.max(r1.norm() / s1.max(f64::MIN_POSITIVE));
        let floor = ROUNDING_FLOOR * jkr::hertz_force(&self.rig.material, x[0].abs() + a_amp);
        let at_floor = rel0 <= ACCEPT && r1.norm() <= floor;
        let r = [r0, r1.re, r1.im];
        (r.iter().all(|v| v.is_finite()) && rel.is_finite()).then_some(Eval {
            cycle,
            d1,
            f1,
            r,
            rel,
            at_floor,
        })
    }

    /// Damped Newton from x. Returns the solution and the iterations, or the best residual.
    fn newton(
        &self,
        mut x: [f64; 3],
        scale: [f64; 2],
    ) -> Result<(Eval, [f64; 3], usize), (f64, usize)> {
        let norm = |e: &Eval| {
            let a = e.r[0] / scale[0];
            let b = e.r[1] / scale[1];
            let c = e.r[2] / scale[1];
            (a * a + b * b + c * c).sqrt()
        };
        let Some(mut cur) = self.eval(x) else {
            return Err((f64::INFINITY, 0));
        };
        let mut stalls = 0;
        for it in 0..MAX_NEWTON {
            if cur.rel <= TARGET {
                return Ok((cur, x, it));
            }
            // Jacobian: central differences in a_m and ln a_A, exact in ψ.
            let a_amp = x[1].exp();
            let h0 = 1e-7 * x[0].abs().max(a_amp);
            let h1 = 1e-6;
            let mut jac = [[0.0; 3]; 3];
            for (col, h) in [(0usize, h0), (1, h1)] {
                let mut xp = x;
                let mut xm = x;
                xp[col] += h;
                xm[col] -= h;
                let (Some(ep), Some(em)) = (self.eval(xp), self.eval(xm)) else {
                    return Err((cur.rel, it));
                };
                for (row, (p, q)) in jac.iter_mut().zip(ep.r.iter().zip(&em.r)) {
                    row[col] = (p - q) / (2.0 * h);
                }
            }
            let (dr, _) = self.harmonic(cur.d1 * C::new(0.0, 1.0), cur.f1 * C::new(0.0, 1.0));
            // ∂R1/∂ψ: the X_b term does not rotate, so remove its contribution from harmonic().
            let (r_xb, _) = self.harmonic(C::new(0.0, 0.0), C::new(0.0, 0.0));
            let dpsi = dr - r_xb;
            jac[0][2] = 0.0;
            jac[1][2] = dpsi.re;
            jac[2][2] = dpsi.im;
            let rhs = [-cur.r[0], -cur.r[1], -cur.r[2]];
            let Some(mut dx) = solve3(jac, rhs) else {
                return Err((cur.rel, it));
            };
            // Trust limits: ln a_A by at most 2, a_m by at most half of max(a_m, a_A), ψ by 1 rad.
            let lim = [0.5 * x[0].abs().max(a_amp), 2.0, 1.0];
            let mut shrink: f64 = 1.0;
            for i in 0..3 {
                if dx[i].abs() > lim[i] {
                    shrink = shrink.min(lim[i] / dx[i].abs());
                }
            }
            for v in &mut dx {
                *v *= shrink;
            }
            let n0 = norm(&cur);
            let mut lambda = 1.0;
            let mut accepted = None;
            for _ in 0..30 {
                let xt = [
                    x[0] + lambda * dx[0],
                    x[1] + lambda * dx[1],
                    x[2] + lambda * dx[2],
                ];
                if let Some(e) = self.eval(xt) {
                    if norm(&e) < (1.0 - 1e-4 * lambda) * n0 {
                        accepted = Some((e, xt));
                        break;
                    }
                }
                lambda *= 0.5;
            }
            match accepted {
                Some((e, xt)) => {
                    cur = e;
                    x = xt;
                    stalls = 0;
                }
                None => {
                    // At the rounding floor no step decreases the norm: accept if good enough.
                    stalls += 1;
                    if cur.rel <= ACCEPT || cur.at_floor {
                        return Ok((cur, x, it + 1));
                    }
                    return Err((cur.rel, it + 1 + stalls));
                }
            }
        }
        if cur.rel <= ACCEPT || cur.at_floor {
            Ok((cur, x, MAX_NEWTON))
        } else {
            Err((cur.rel, MAX_NEWTON))
        }
    }

    /// Force scales of the mean and first-harmonic equations, for the Newton line search.
    fn scales(&self, a0: f64) -> [f64; 2] {
        let f0 = 1.5 * PI * self.rig.material.r * self.rig.w0();
        let weight = self.rig.weight().abs();
        let kc = jkr::contact_stiffness(&self.rig.material, a0);
        let z = self.a_coef().hypot(self.d_coef());
        [
            (f0 + weight + kc * a0 * a0 / self.rig.material.r).max(f64::MIN_POSITIVE),
            ((z + kc) * self.xb).max(f64::MIN_POSITIVE),
        ]
    }

    /// Linear transfer with complex contact stiffness κ: δ1.
    fn linear_d1(&self, kappa: C) -> Option<C> {
        let (a, d) = (self.a_coef(), self.d_coef());
        let xb = C::new(self.xb, 0.0);
        let out = match self.rig.damping_on() {
            DampingOn::Sphere => {
                let z = C::new(a, d);
                z * xb / (z + kappa)
            }
            DampingOn::Contact => xb * a / (C::new(a, d) + kappa),
        };
        (out.re.is_finite() && out.im.is_finite() && out.norm() > 0.0).then_some(out)
    }

    /// a_A at which the cycle's |δ1| equals `target` (safeguarded secant in log-log).
    fn match_amplitude(&self, a_m: f64, target: f64) -> Option<(f64, Cycle)> {
        let amp = |la: f64| {
            imposed_area::cycle(&self.rig.material, &self.rig.law, self.omega, a_m, la.exp())
                .ok()
                .filter(|c| c.harmonics.delta_amp > 0.0 && c.harmonics.delta_amp.is_finite())
        };
        let lt = target.ln();
        // Hertz-like start: δ_A ≈ 2 a_m a_A / R.
        let mut x = (target * self.rig.material.r / (2.0 * a_m))
            .min(0.5 * a_m)
            .ln();
        let mut c = amp(x)?;
        let mut y = c.harmonics.delta_amp.ln();
        let mut p = 1.0;
        for _ in 0..40 {
            if (y - lt).abs() < 1e-4 {
                break;
            }
            let step = ((lt - y) / p).clamp(-5.0, 5.0);
            let xn = (x + step).min((0.95 * a_m).ln());
            let cn = amp(xn)?;
            let yn = cn.harmonics.delta_amp.ln();
            if (xn - x).abs() > 1e-12 {
                p = ((yn - y) / (xn - x)).clamp(0.05, 3.0);
            }
            x = xn;
            y = yn;
            c = cn;
            if xn >= (0.95 * a_m).ln() && yn < lt {
                break;
            }
        }
        Some((x.exp(), c))
    }

    /// Describing-function fixed point as a starting guess.
    fn initial_guess(&self, a0: f64) -> Option<[f64; 3]> {
        let mut kappa = C::new(jkr::contact_stiffness(&self.rig.material, a0), 0.0);
        let mut x = None;
        for _ in 0..4 {
            let d1 = self.linear_d1(kappa)?;
            let (a_amp, c) = self.match_amplitude(a0, d1.norm())?;
            let d_theta = C::new(c.harmonics.delta_sin, c.harmonics.delta_cos);
            let psi = d1.im.atan2(d1.re) - d_theta.im.atan2(d_theta.re);
            x = Some([a0, a_amp.ln(), psi]);
            let k_new = C::new(c.harmonics.force_sin, c.harmonics.force_cos) / d_theta;
            if !(k_new.re.is_finite() && k_new.im.is_finite()) {
                break;
            }
            kappa = k_new;
        }
        x
    }

    fn finish(&self, e: &Eval, x: [f64; 3], iterations: usize) -> HarmonicBalance {
        let psi = x[2].rem_euclid(2.0 * PI);
        HarmonicBalance {
            a_mean: x[0],
            a_amp: x[1].exp(),
            phase: psi,
            harmonics: Harmonics {
                delta_mean: e.cycle.harmonics.delta_mean,
                delta_sin: e.d1.re,
                delta_cos: e.d1.im,
                delta_amp: e.d1.norm(),
                force_mean: e.cycle.harmonics.force_mean,
                force_sin: e.f1.re,
                force_cos: e.f1.im,
            },
            contact_fraction: e.cycle.contact_fraction,
            x_k: self.x_k,
            base_amplitude: self.xb,
            omega: self.omega,
            iterations,
            residual: e.rel,
        }
    }
}

/// Solve the 3×3 Newton system.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let x = crate::numerics::solve_dense(3, |i, j| a[i][j], &b)?;
    Some([x[0], x[1], x[2]])
}

fn check_drive(omega: f64, xb: f64) -> Result<(), ParamError> {
    if !(omega.is_finite() && omega > 0.0) {
        return Err(ParamError::new(
            "omega",
            omega,
            "must be finite and > 0 rad/s",
        ));
    }
    if !(xb.is_finite() && xb >= 0.0) {
        return Err(ParamError::new(
            "base amplitude",
            xb,
            "must be finite and >= 0 m",
        ));
    }
    Ok(())
}

fn static_solution(st: &StaticState, xb: f64, omega: f64) -> HarmonicBalance {
    HarmonicBalance {
        a_mean: st.a,
        a_amp: 0.0,
        phase: 0.0,
        harmonics: Harmonics {
            delta_mean: st.delta,
            force_mean: st.force,
            ..Harmonics::default()
        },
        contact_fraction: 1.0,
        x_k: st.x_k,
        base_amplitude: xb,
        omega,
        iterations: 0,
        residual: 0.0,
    }
}

/// Harmonic-balance solution at base amplitude X_b (m) and angular frequency ω (rad/s).
///
/// Tries, in order: Newton from `guess`; Newton from the describing-function fixed point
/// (module doc); continuation in X_b from X_b/1000 ([`continuation`]); the first solution of a
/// scan along a_A ([`solutions`], which passes folds of the response). Where several solutions
/// exist, which one is returned depends on the start; use [`solutions`] to get them all.
/// X_b = 0 returns the static contact (a_A = 0). Errors, never NaN, on invalid inputs, no static
/// contact, no convergence to a relative residual of [`ACCEPT`], or when the only solution found
/// loses contact ([`DescribingError::ContactLost`]).
#[allow(clippy::too_many_arguments)]
pub fn solve(
    rig: &Rig,
    support: Support,
    base_amplitude: f64,
    omega: f64,
    guess: Option<Guess>,
) -> Result<HarmonicBalance, DescribingError> {
    let h = solve_any(rig, support, base_amplitude, omega, guess)?;
    if h.contact_fraction >= 1.0 {
        return Ok(h);
    }
    // Converged to a truncated cycle: look for an in-contact solution elsewhere on the branch.
    match solutions(rig, support, base_amplitude, omega)?.first() {
        Some(g) => Ok(*g),
        None => Err(DescribingError::ContactLost {
            omega,
            base_amplitude,
            contact_fraction: h.contact_fraction,
        }),
    }
}

/// [`solve`] without the contact-loss check.
#[allow(clippy::too_many_arguments)]
fn solve_any(
    rig: &Rig,
    support: Support,
    base_amplitude: f64,
    omega: f64,
    guess: Option<Guess>,
) -> Result<HarmonicBalance, DescribingError> {
    check_drive(omega, base_amplitude)?;
    let st = static_state(rig, support)?;
    if base_amplitude <= 0.0 {
        return Ok(static_solution(&st, base_amplitude, omega));
    }
    let pb = Balance {
        rig,
        x_k: st.x_k,
        xb: base_amplitude,
        omega,
    };
    let scale = pb.scales(st.a);
    let mut spent = 0;
    let mut best = f64::INFINITY;
    if let Some(g) = guess {
        if g.a_amp > 0.0 && g.a_amp.is_finite() && g.a_mean.is_finite() && g.phase.is_finite() {
            match pb.newton([g.a_mean, g.a_amp.ln(), g.phase], scale) {
                Ok((e, x, it)) => return Ok(pb.finish(&e, x, it)),
                Err((r, it)) => {
                    spent += it;
                    best = best.min(r);
                }
            }
        }
    }
    if let Some(x0) = pb.initial_guess(st.a) {
        match pb.newton(x0, scale) {
            Ok((e, x, it)) => return Ok(pb.finish(&e, x, it + spent)),
            Err((r, it)) => {
                spent += it;
                best = best.min(r);
            }
        }
    }
    let ramp: Vec<f64> = (0..=6)
        .map(|i| base_amplitude * 10f64.powf(-3.0 + 0.5 * i as f64))
        .collect();
    match continuation_from(rig, &st, omega, &ramp) {
        Ok(v) => match v.last() {
            Some(h) => {
                let mut h = *h;
                h.iterations += spent;
                Ok(h)
            }
            None => Err(DescribingError::NotConverged {
                omega,
                base_amplitude,
                iterations: spent,
                residual: best,
            }),
        },
        Err(DescribingError::NotConverged {
            iterations,
            residual,
            ..
        }) => {
            // Last resort: scan the branch in a_A (passes folds in X_b).
            let found = solutions(rig, support, base_amplitude, omega)?;
            match found.first() {
                Some(h) => Ok(*h),
                None => Err(DescribingError::NotConverged {
                    omega,
                    base_amplitude,
                    iterations: iterations + spent,
                    residual: residual.min(best),
                }),
            }
        }
        Err(e) => Err(e),
    }
}

/// Continuation in X_b: solutions at each of `amplitudes` (m, increasing, > 0), each started
/// from the previous one (ln a_A extrapolated linearly in ln X_b), with the step halved (up to
/// 12 times) where Newton fails. Intermediate substeps are not returned.
#[allow(clippy::too_many_arguments)]
pub fn continuation(
    rig: &Rig,
    support: Support,
    omega: f64,
    amplitudes: &[f64],
) -> Result<Vec<HarmonicBalance>, DescribingError> {
    check_drive(omega, 0.0)?;
    let mut prev = 0.0;
    for &xb in amplitudes {
        check_drive(omega, xb)?;
        if xb <= prev {
            return Err(ParamError::new("amplitudes", xb, "must be increasing and > 0 m").into());
        }
        prev = xb;
    }
    let st = static_state(rig, support)?;
    continuation_from(rig, &st, omega, amplitudes)
}

fn continuation_from(
    rig: &Rig,
    st: &StaticState,
    omega: f64,
    amplitudes: &[f64],
) -> Result<Vec<HarmonicBalance>, DescribingError> {
    let mut out = Vec::with_capacity(amplitudes.len());
    // Last two accepted points (ln X_b, x).
    let mut hist: Vec<(f64, [f64; 3])> = Vec::new();
    let mut iterations = 0;
    let fail = |xb: f64, iterations: usize, residual: f64| DescribingError::NotConverged {
        omega,
        base_amplitude: xb,
        iterations,
        residual,
    };
    for &target in amplitudes {
        let mut lo_xb = hist.last().map(|h| h.0.exp());
        let mut step_target = target;
        let mut halvings = 0;
        loop {
            let pb = Balance {
                rig,
                x_k: st.x_k,
                xb: step_target,
                omega,
            };
            let scale = pb.scales(st.a);
            let lx = step_target.ln();
            let x0 = match hist.len() {
                0 => pb.initial_guess(st.a),
                1 => Some(hist[0].1),
                _ => {
                    let (l1, x1) = hist[hist.len() - 2];
                    let (l2, x2) = hist[hist.len() - 1];
                    let t = (lx - l2) / (l2 - l1);
                    Some([
                        x2[0] + t * (x2[0] - x1[0]),
                        x2[1] + t * (x2[1] - x1[1]),
                        x2[2] + t * (x2[2] - x1[2]),
                    ])
                }
            };
            let res = match x0 {
                Some(x0) => pb.newton(x0, scale),
                None => Err((f64::INFINITY, 0)),
            };
            match res {
                Ok((e, x, it)) => {
                    iterations += it;
                    hist.push((lx, x));
                    if hist.len() > 2 {
                        hist.remove(0);
                    }
                    if (step_target - target).abs() <= 0.0 {
                        out.push(pb.finish(&e, x, iterations));
                        break;
                    }
                    lo_xb = Some(step_target);
                    step_target = target;
                }
                Err((r, it)) => {
                    iterations += it;
                    halvings += 1;
                    if halvings > 12 {
                        return Err(fail(step_target, iterations, r));
                    }
                    step_target = match lo_xb {
                        // Geometric midpoint between the last solution and the failed target.
                        Some(lo) => (lo * step_target).sqrt(),
                        // No solution yet: start lower.
                        None => step_target * 0.1,
                    };
                }
            }
        }
    }
    Ok(out)
}

/// The harmonic-balance solution with the contact-radius amplitude a_A (m) given and the base
/// amplitude X_b an output: the parametrisation that passes folds of the response in X_b (jumps
/// near a nonlinear resonance), where [`solve`] and [`continuation`] in X_b stop.
///
/// The mean equation does not involve ψ, so a_m solves it alone (1-D, bracketed Illinois false
/// position from the static radius). Then the first harmonic gives X_b and ψ in closed form, in
/// the θ frame (δ1 = e^{iψ} δ1θ, F1 = e^{iψ} F1θ):
/// - sphere damping: Z X_b e^{−iψ} = Z δ1θ + F1θ, so X_b = |δ1θ + F1θ/Z|, ψ = −arg(δ1θ + F1θ/Z);
/// - contact damping: A X_b e^{−iψ} = (A + iD) δ1θ + F1θ, so with q = ((A + iD) δ1θ + F1θ)/A,
///   X_b = |q|, ψ = −arg q (A = k − mω² ≠ 0).
///
/// Errors when a_A is not finite and > 0, when the mean equation has no root with a_m ≥ −a_A,
/// or when Z (or A) vanishes.
pub fn at_contact_amplitude(
    rig: &Rig,
    support: Support,
    omega: f64,
    a_amp: f64,
) -> Result<HarmonicBalance, DescribingError> {
    check_drive(omega, 0.0)?;
    if !(a_amp.is_finite() && a_amp > 0.0) {
        return Err(ParamError::new("a_amp", a_amp, "must be finite and > 0 m").into());
    }
    let st = static_state(rig, support)?;
    let weight = rig.weight();
    let k = rig.spring_stiffness();
    let mean = |a_m: f64| -> Option<(f64, Cycle)> {
        let c = imposed_area::cycle(&rig.material, &rig.law, omega, a_m, a_amp).ok()?;
        let r = c.harmonics.force_mean + k * (c.harmonics.delta_mean - st.x_k) - weight;
        r.is_finite().then_some((r, c))
    };
    let no_root = |why: &str| {
        DescribingError::NoStaticState(format!(
            "mean equation at a_A = {a_amp} m, omega = {omega} rad/s: {why}"
        ))
    };
    let ((mut lo, mut rlo, clo), (mut hi, mut rhi, chi)) =
        bracket_mean_root(&mean, &no_root, st.a, a_amp)?;
    // Illinois false position.
    let mut side = 0;
    let mut best = if rlo.abs() < rhi.abs() {
        (lo, clo, rlo)
    } else {
        (hi, chi, rhi)
    };
    for _ in 0..200 {
        let scale = best.1.harmonics.force_mean.abs()
            + weight.abs()
            + (k * (best.1.harmonics.delta_mean - st.x_k)).abs();
        if best.2.abs() <= 1e-14 * scale || (hi - lo) <= 1e-15 * hi.abs().max(a_amp) {
            break;
        }
        let mut x = (lo * rhi - hi * rlo) / (rhi - rlo);
        if !(x > lo && x < hi) {
            x = 0.5 * (lo + hi);
        }
        let (r, c) = mean(x).ok_or_else(|| no_root("cycle failed"))?;
        if r.abs() < best.2.abs() {
            best = (x, c, r);
        }
        if r <= 0.0 {
            lo = x;
            rlo = r;
            if side == -1 {
                rhi *= 0.5;
            }
            side = -1;
        } else {
            hi = x;
            rhi = r;
            if side == 1 {
                rlo *= 0.5;
            }
            side = 1;
        }
    }
    let (a_m, c, _) = best;
    let q = base_phasor(rig, omega, &c)?;
    let xb = q.norm();
    if !(xb.is_finite() && xb > 0.0) {
        return Err(no_root("no first harmonic"));
    }
    let psi = -q.im.atan2(q.re);
    let pb = Balance {
        rig,
        x_k: st.x_k,
        xb,
        omega,
    };
    let e = pb
        .eval([a_m, a_amp.ln(), psi])
        .ok_or_else(|| no_root("cycle failed at the solution"))?;
    Ok(pb.finish(&e, [a_m, a_amp.ln(), psi], 0))
}

/// One end of [`bracket_mean_root`]'s bracket: a_m, the residual there and its cycle.
type BracketEnd = (f64, f64, Cycle);

/// A sign change of the mean equation's residual `mean(a_m)` (increasing with a_m on the branch
/// of the static contact), searched from the static radius `a_static` in steps doubling from a
/// tenth of the larger of it and `a_amp`, not below a_m = −a_A: the ends (a_m, residual, cycle)
/// with the residual ≤ 0 at the lower one and ≥ 0 at the upper one.
fn bracket_mean_root(
    mean: &impl Fn(f64) -> Option<(f64, Cycle)>,
    no_root: &impl Fn(&str) -> DescribingError,
    a_static: f64,
    a_amp: f64,
) -> Result<(BracketEnd, BracketEnd), DescribingError> {
    let lo_limit = -a_amp;
    let (mut lo, mut hi) = (a_static, a_static);
    let (mut rlo, mut clo) = mean(lo).ok_or_else(|| no_root("cycle failed"))?;
    let (mut rhi, mut chi) = (rlo, clo);
    let mut step = 0.1 * a_static.max(a_amp);
    for _ in 0..200 {
        if rlo <= 0.0 && rhi >= 0.0 {
            break;
        }
        if rlo > 0.0 {
            hi = lo;
            rhi = rlo;
            chi = clo;
            lo = (lo - step).max(lo_limit);
            let v = mean(lo).ok_or_else(|| no_root("cycle failed"))?;
            rlo = v.0;
            clo = v.1;
            if rlo > 0.0 && lo <= lo_limit {
                return Err(no_root("positive down to a_m = -a_A"));
            }
        } else {
            lo = hi;
            rlo = rhi;
            clo = chi;
            hi += step;
            let v = mean(hi).ok_or_else(|| no_root("cycle failed"))?;
            rhi = v.0;
            chi = v.1;
        }
        step *= 2.0;
    }
    if !(rlo <= 0.0 && rhi >= 0.0) {
        return Err(no_root("no sign change found"));
    }
    Ok(((lo, rlo, clo), (hi, rhi, chi)))
}

/// The first harmonic's balance for the cycle `c` in the θ frame: q with X_b = |q| and
/// ψ = −arg q (sphere damping: q = δ1θ + F1θ/Z; contact damping: q = ((A + iD) δ1θ + F1θ)/A).
/// Errors when Z (or A) vanishes.
fn base_phasor(rig: &Rig, omega: f64, c: &Cycle) -> Result<C, DescribingError> {
    let a = rig.spring_stiffness() - rig.mass() * omega * omega;
    let d = rig.damping_coefficient() * omega;
    let d1 = C::new(c.harmonics.delta_sin, c.harmonics.delta_cos);
    let f1 = C::new(c.harmonics.force_sin, c.harmonics.force_cos);
    Ok(match rig.damping_on() {
        DampingOn::Sphere => {
            if a.hypot(d) <= 0.0 {
                return Err(ParamError::new(
                    "omega",
                    omega,
                    "must not make k - m omega^2 + i c omega vanish",
                )
                .into());
            }
            d1 + f1 / C::new(a, d)
        }
        DampingOn::Contact => {
            if a.abs() <= 0.0 {
                return Err(ParamError::new(
                    "omega",
                    omega,
                    "must not equal sqrt(k/m) with contact damping",
                )
                .into());
            }
            (C::new(a, d) * d1 + f1) * (1.0 / a)
        }
    })
}

/// Number of points per decade of a_A in [`solutions`]' scan of the branch.
const SCAN_PER_DECADE: f64 = 8.0;

/// Every harmonic-balance solution at base amplitude X_b (m) and ω (rad/s), in increasing a_A.
///
/// Near a nonlinear resonance X_b(a_A) ([`at_contact_amplitude`]) is not monotonic: one X_b can
/// have three solutions (a fold; the time-domain response then depends on its history, with
/// jumps). This scans ln a_A at 8 points per decade, from where X_b(a_A) is below the target up
/// to a_A = 20 a_0 or the first truncated cycle (contact loss: outside the method), brackets each
/// crossing of X_b, refines it by bisection in ln a_A, and polishes it by Newton at the exact
/// X_b. The first entry is the branch connected to X_b = 0, the one continuation from rest
/// follows. An empty list means no in-contact periodic solution of this form (e.g. beyond the
/// largest X_b the contact can follow without loss). Errors on invalid inputs.
pub fn solutions(
    rig: &Rig,
    support: Support,
    base_amplitude: f64,
    omega: f64,
) -> Result<Vec<HarmonicBalance>, DescribingError> {
    check_drive(omega, base_amplitude)?;
    let st = static_state(rig, support)?;
    if base_amplitude <= 0.0 {
        return Ok(vec![static_solution(&st, base_amplitude, omega)]);
    }
    let at = |la: f64| {
        at_contact_amplitude(rig, support, omega, la.exp())
            .ok()
            .filter(|h| h.contact_fraction >= 1.0 && h.base_amplitude.is_finite())
    };
    let target = base_amplitude;
    let step = std::f64::consts::LN_10 / SCAN_PER_DECADE;
    let top = (20.0 * st.a).ln();
    // Lowest a_A: start six decades below a_0 and go down until X_b is below the target.
    let mut lo = (1e-6 * st.a).ln();
    let mut first = None;
    for _ in 0..30 {
        match at(lo) {
            Some(h) if h.base_amplitude < target => {
                first = Some(h);
                break;
            }
            _ => lo -= 3.0 * std::f64::consts::LN_10,
        }
    }
    let Some(mut prev) = first else {
        return Ok(Vec::new());
    };
    let mut la = lo;
    let mut out = Vec::new();
    while la < top {
        let next_la = la + step;
        let Some(next) = at(next_la) else { break };
        let (f0, f1) = (prev.base_amplitude - target, next.base_amplitude - target);
        if (f0 < 0.0) != (f1 < 0.0) {
            // Bisection in ln a_A on X_b(a_A) − X_b.
            let (mut a, mut b, mut fa) = (la, next_la, f0);
            let mut best = if f0.abs() < f1.abs() { prev } else { next };
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                let Some(hm) = at(m) else { break };
                let fm = hm.base_amplitude - target;
                if fm.abs() < (best.base_amplitude - target).abs() {
                    best = hm;
                }
                if (fm < 0.0) == (fa < 0.0) {
                    a = m;
                    fa = fm;
                } else {
                    b = m;
                }
                if (b - a) < 1e-10 {
                    break;
                }
            }
            let pb = Balance {
                rig,
                x_k: st.x_k,
                xb: target,
                omega,
            };
            let x0 = [best.a_mean, best.a_amp.ln(), best.phase];
            if let Ok((e, x, it)) = pb.newton(x0, pb.scales(st.a)) {
                if (x[1] - x0[1]).abs() < 0.1 && e.cycle.contact_fraction >= 1.0 {
                    out.push(pb.finish(&e, x, it));
                }
            }
        }
        prev = next;
        la = next_la;
    }
    Ok(out)
}

/// A rig and its mean load, ready for [`Setup::solve`].
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// The rig (its base section is not used: frequency and amplitude are arguments).
    pub rig: Rig,
    /// Mean load: a run's initial preload (x_k = δ0 + (P − m g)/k, as the simulator places the
    /// spring end), or the spring end of an explicit initial state.
    pub support: Support,
}

impl Setup {
    /// From a rig and the initial state of a run, which sets the mean load. Errors for a rigid
    /// holder (δ is prescribed there: no dynamics to balance), for an initial gap (no contact to
    /// oscillate about) and for mechanical constants out of range.
    pub fn new(rig: &Rig, initial: &Initial) -> Result<Setup, DescribingError> {
        check_rig(rig)?;
        rig.check_mechanics()?;
        let support = match *initial {
            Initial::Preload(p) => Support::StaticLoad(p),
            Initial::State { x_k, .. } => Support::SpringEnd(x_k),
            Initial::Gap(_) => {
                return Err(DescribingError::Unsupported(
                    "initial gap: no static contact to oscillate about".into(),
                ))
            }
        };
        Ok(Setup {
            rig: rig.clone(),
            support,
        })
    }

    /// [`solve`] for this setup at frequency f (Hz) and base amplitude X_b (m).
    pub fn solve(
        &self,
        frequency: f64,
        amplitude: f64,
        guess: Option<Guess>,
    ) -> Result<HarmonicBalance, DescribingError> {
        solve(
            &self.rig,
            self.support,
            amplitude,
            2.0 * PI * frequency,
            guess,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solve3_matches_known_solution() {
        let a = [[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]];
        let x = [1.0, -2.0, 0.5];
        let b = [
            2.0 * x[0] + x[1],
            x[0] + 3.0 * x[1] + x[2],
            x[1] + 4.0 * x[2],
        ];
        let s = solve3(a, b).unwrap_or([0.0; 3]);
        for i in 0..3 {
            assert!((s[i] - x[i]).abs() < 1e-14);
        }
        assert!(solve3([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]], b).is_none());
    }

    #[test]
    fn tangent_stiffness_is_finite_difference_of_the_jkr_curve() {
        let m = Material::PAPER;
        for &a in &[2e-3, 5e-3, 1e-2] {
            let h = 1e-6 * a;
            let df =
                jkr::equilibrium_force(&m, a + h, m.w0) - jkr::equilibrium_force(&m, a - h, m.w0);
            let dd = jkr::equilibrium_indentation(&m, a + h, m.w0)
                - jkr::equilibrium_indentation(&m, a - h, m.w0);
            let kt = tangent_stiffness(&m, a, m.w0);
            assert!(
                (df / dd / kt - 1.0).abs() < 1e-7,
                "{a}: {} vs {kt}",
                df / dd
            );
        }
    }
}
