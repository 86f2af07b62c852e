//! The paper's imposed-area method (Sec. 2.1), with kink-aware quadrature, and the pull-off search.
//!
//! Impose a(θ) = a_m + a_A sin θ, θ = ωt, truncated at a ≥ 0. The crack speed is ȧ = a_A ω cos θ,
//! the work of adhesion w(θ) = w(ȧ) from the law, the indentation δ(θ) from eq. (13) (JKR
//! equilibrium at w), the force F(θ) = (K a/2)(3δ − a²/R). While a ≤ 0 there is no contact:
//! δ = 0 and F = 0, as in the paper.
//!
//! ## Folding the cycle
//! a(θ) is symmetric about θ = π/2 and ȧ antisymmetric. Writing θ = π/2 ∓ φ, φ ∈ [0, Φ]:
//! a = a_m + a_A cos φ on both sides, healing (ȧ = +a_A ω sin φ) at θ = π/2 − φ and peeling
//! (ȧ = −a_A ω sin φ) at θ = π/2 + φ. Φ = π when a_m ≥ a_A (contact throughout), otherwise the
//! contact is lost at cos Φ = −a_m/a_A. So one integral over [0, Φ] with two evaluations of w per
//! node covers the cycle; the kinks (ȧ = 0 at θ = π/2, 3π/2, i.e. φ = 0, π) and the contact-loss
//! points (φ = Φ) are exactly the ends of that interval, where tanh-sinh puts its nodes densely.
//! With sin θ = cos φ and cos θ = ±sin φ:
//! - δ_m = (1/2π) ∫₀^Φ (δ_h + δ_p) dφ, F_m = (1/2π) ∫₀^Φ (F_h + F_p) dφ;
//! - δ_s = (1/π) ∫₀^Φ (δ_h + δ_p) cos φ dφ, δ_c = (1/π) ∫₀^Φ (δ_h − δ_p) sin φ dφ (eqs. 25–27);
//! - likewise for the force, F_s = (1/π) ∫₀^{2π} F sin θ dθ = (1/π) ∫₀^Φ (F_h + F_p) cos φ dφ and
//!   F_c = (1/π) ∫₀^{2π} F cos θ dθ = (1/π) ∫₀^Φ (F_h − F_p) sin φ dφ: the even part (about
//!   θ = π/2) pairs with sin θ = cos φ, the odd part with cos θ = ±sin φ (used by
//!   [`crate::describing`]);
//! - mean of the truncated radius (closed form): ā = (a_m Φ + a_A sin Φ)/π; contact fraction Φ/π.
//!
//! With g = √(8π a/(3K)) and S = √w_p + √w_h, D = √w_p − √w_h:
//! δ_h + δ_p = 2a²/R − g S, δ_h − δ_p = g D, F_h + F_p = 2K a³/R − (3/2) K a g S,
//! F_h − F_p = (3/2) K a g D.
//!
//! Near the right end the radius is evaluated from the distance d = Φ − φ without cancellation:
//! a = (a_m + a_A cos Φ) + 2 a_A (−cos Φ) sin²(d/2) + a_A sin Φ sin d, where the first bracket is 0
//! for a truncated cycle and a_m − a_A otherwise.
//!
//! ## Slope of the mean force
//! Since F = 0 where the contact is lost, the moving ends contribute nothing (Leibniz), and
//! dF_m/da_m = (1/2π) ∫ ∂F_eq/∂a dθ at fixed w, with ∂F_eq/∂a = 3K a²/R − (9/4) K g √w. It is
//! computed in the same pass and used by the pull-off search (root of the slope, see
//! [`pull_off`]).

use crate::adhesion::AdhesionLaw;
use crate::error::ParamError;
use crate::jkr;
use crate::material::Material;
use crate::quadrature::QuadratureRule;
use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::PI;

/// The mean and first harmonic of the indentation δ and the contact force F over one period,
/// δ(θ) ≈ δ_m + δ_s sin θ + δ_c cos θ and F likewise: the numbers every periodic solution of the
/// contact reports, whether it comes from an imposed contact radius ([`Cycle`], θ the phase of
/// a(θ)) or from harmonic balance ([`crate::describing::HarmonicBalance`], θ = ωt of the base
/// motion). One type so that the two are compared and printed field by field.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Harmonics {
    /// Mean indentation δ_m (m), with δ = 0 out of contact.
    pub delta_mean: f64,
    /// First harmonic sine coefficient δ_s = (1/π) ∫ δ sin θ dθ, eq. (26) (m).
    pub delta_sin: f64,
    /// First harmonic cosine coefficient δ_c = (1/π) ∫ δ cos θ dθ, eq. (25) (m).
    pub delta_cos: f64,
    /// First harmonic amplitude δ_A = |δ1| = hypot(δ_s, δ_c), eq. (27) (m).
    pub delta_amp: f64,
    /// Mean contact force F_m (N, positive compressive), with F = 0 out of contact.
    pub force_mean: f64,
    /// First harmonic sine coefficient of the force F_s = (1/π) ∫ F sin θ dθ (N).
    pub force_sin: f64,
    /// First harmonic cosine coefficient of the force F_c = (1/π) ∫ F cos θ dθ (N).
    pub force_cos: f64,
}

/// Cycle averages of one imposed-area cycle (SI).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Cycle {
    /// Imposed mean contact radius a_m of a(θ) = a_m + a_A sin θ (m); may be < a_A or negative.
    pub a_mean_imposed: f64,
    /// Imposed amplitude a_A (m).
    pub a_amp: f64,
    /// Mean of the truncated radius max(a, 0) over the cycle, the paper's a posteriori a_m (m).
    pub a_mean: f64,
    /// Means and first harmonics of δ and F over θ (their fields sit at this level in JSON).
    #[serde(flatten)]
    pub harmonics: Harmonics,
    /// dF_m/da_m at fixed ω and a_A (N/m): zero at pull-off.
    pub force_slope: f64,
    /// Fraction of the period in contact (a > 0).
    pub contact_fraction: f64,
    /// Number of evaluations of the adhesion law w(ȧ) spent on this cycle.
    pub evaluations: usize,
}

/// Pull-off at fixed (ω, a_A): the minimum of F_m over the imposed a_m.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PullOff {
    /// The cycle at the global minimum.
    pub cycle: Cycle,
    /// Pull-off force F_m,po (N, negative: tensile).
    pub force: f64,
    /// F_m,po / F0 with F0 = −(3/2) π R w0 ([`Material::static_pull_off_force`]).
    pub amplification: f64,
    /// (a_mean_imposed, F_m) of every local minimum found, in increasing a_m (m, N).
    pub local_minima: Vec<(f64, f64)>,
    /// True when the minimum is certified global: the scan covered the whole range where a
    /// minimum can lie (see [`pull_off`]) and `cycle` is the lowest of `local_minima`. When
    /// `local_minima` has several entries, the others are local minima above the global one.
    pub global: bool,
}

fn check_inputs(omega: f64, a_mean: f64, a_amp: f64) -> Result<(), ParamError> {
    if !(omega.is_finite() && omega > 0.0) {
        return Err(ParamError::new(
            "omega",
            omega,
            "must be a finite angular frequency > 0 rad/s",
        ));
    }
    if !(a_amp.is_finite() && a_amp >= 0.0) {
        return Err(ParamError::new(
            "a_amp",
            a_amp,
            "must be a finite contact-radius amplitude >= 0 m",
        ));
    }
    if !(a_mean.is_finite() && a_mean >= -a_amp) {
        return Err(ParamError::new(
            "a_mean",
            a_mean,
            format!(
                "must be a finite mean contact radius >= -a_amp = {} m",
                -a_amp
            ),
        ));
    }
    Ok(())
}

fn check_material(m: &Material) -> Result<(), ParamError> {
    m.validate()
}

/// One imposed-area cycle with the default rule ([`QuadratureRule::default_rule`]).
///
/// `omega` in rad/s, `a_mean` and `a_amp` in m. Errors when ω ≤ 0, a_A < 0, a_m < −a_A or any is
/// not finite, or the material is invalid.
///
/// Accuracy: ~1e-11 relative in F_m or better for laws that are smooth in ȧ except at ȧ = 0
/// (Gent–Schultz, saturated Gent–Schultz, constant; the worst case over a wide box is in
/// `docs/studies/imposed-area.md`, regenerated by `cargo run --release --example
/// study_imposed_area`). A law with kinks at other speeds is
/// integrated across them: [`crate::adhesion::TabulatedLaw`] (piecewise linear in asinh ȧ) gives
/// ~2e-5 relative for a 61-point table of the paper's law at 400 Hz; [`cycle_with_kinks`] splits
/// at given kink speeds and restores full accuracy ([`AdhesionLaw`] does not expose a law's kinks,
/// so the caller passes them).
pub fn cycle<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_mean: f64,
    a_amp: f64,
) -> Result<Cycle, ParamError> {
    cycle_with(m, law, omega, a_mean, a_amp, QuadratureRule::default_rule())
}

/// One imposed-area cycle with a chosen quadrature rule (for convergence studies).
pub fn cycle_with<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_mean: f64,
    a_amp: f64,
    rule: &QuadratureRule,
) -> Result<Cycle, ParamError> {
    check_material(m)?;
    check_inputs(omega, a_mean, a_amp)?;
    Ok(cycle_unchecked(m, law, omega, a_mean, a_amp, rule))
}

/// The cycle without input checks (inputs validated by the caller).
fn cycle_unchecked<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_m: f64,
    a_a: f64,
    rule: &QuadratureRule,
) -> Cycle {
    cycle_pieces(m, law, omega, a_m, a_a, rule, &[])
}

/// One imposed-area cycle with the cycle also split where |ȧ| equals one of `kink_speeds` (m/s,
/// sign ignored): for laws with kinks away from ȧ = 0, e.g. a [`crate::adhesion::TabulatedLaw`]
/// (pass its table speeds). Each speed v < a_A ω adds the break points φ = asin(v/(a_A ω)) and
/// π − φ, so each piece is smooth inside and tanh-sinh keeps its accuracy. Same checks as
/// [`cycle`], plus finite kink speeds.
pub fn cycle_with_kinks<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_mean: f64,
    a_amp: f64,
    rule: &QuadratureRule,
    kink_speeds: &[f64],
) -> Result<Cycle, ParamError> {
    check_material(m)?;
    check_inputs(omega, a_mean, a_amp)?;
    if let Some(v) = kink_speeds.iter().find(|v| !v.is_finite()) {
        return Err(ParamError::new(
            "kink_speeds",
            v,
            "must be finite speeds (m/s)",
        ));
    }
    Ok(cycle_pieces(
        m,
        law,
        omega,
        a_mean,
        a_amp,
        rule,
        kink_speeds,
    ))
}

/// The cycle, integrated piecewise over [0, Φ] split at the φ where |ȧ| hits a kink speed.
fn cycle_pieces<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_m: f64,
    a_a: f64,
    rule: &QuadratureRule,
    kink_speeds: &[f64],
) -> Cycle {
    let k = m.k;
    let r = m.r;
    let g_coef = 8.0 * PI / (3.0 * k);
    let mut out = Cycle {
        a_mean_imposed: a_m,
        a_amp: a_a,
        a_mean: 0.0,
        harmonics: Harmonics::default(),
        force_slope: 0.0,
        contact_fraction: 0.0,
        evaluations: 0,
    };
    if a_m + a_a <= 0.0 {
        // No contact at any time.
        return out;
    }
    let speed = a_a * omega;
    if a_a <= 0.0 || speed <= 0.0 {
        return static_cycle(out, m, law, a_m);
    }
    // Half-width Φ of the contact interval in φ; atan2 keeps it accurate where acos would be
    // ill-conditioned (a_m → ±a_A).
    let truncated = a_m < a_a;
    let (phi_end, sin_end, cos_end) = if truncated {
        let c = -a_m / a_a;
        let s = ((a_a - a_m) * (a_a + a_m)).max(0.0).sqrt() / a_a;
        (s.atan2(c), s, c)
    } else {
        (PI, 0.0, -1.0)
    };
    let base = if truncated { 0.0 } else { a_m - a_a };
    let two_r = 2.0 / r;
    // Integrand at distances d0 = φ and d1 = Φ − φ, each accurate near its own end:
    // [(δh+δp), (δh+δp)cosφ, (δh−δp)sinφ, (Fh+Fp), slope, (Fh+Fp)cosφ, (Fh−Fp)sinφ].
    let node = |d0: f64, d1: f64| -> [f64; 7] {
        // sin φ, cos φ from the nearer end.
        let (sin_phi, cos_phi) = if d0 <= d1 {
            d0.sin_cos()
        } else {
            let (sd, cd) = d1.sin_cos();
            // φ = Φ − d1.
            (sin_end * cd - cos_end * sd, cos_end * cd + sin_end * sd)
        };
        let half = (0.5 * d1).sin();
        let a = (base + a_a * (-cos_end) * 2.0 * half * half + a_a * sin_end * d1.sin()).max(0.0);
        let adot = speed * sin_phi;
        let wp = law.work_of_adhesion(-adot).max(0.0);
        let wh = law.work_of_adhesion(adot).max(0.0);
        let (sp, sh) = (wp.sqrt(), wh.sqrt());
        let s = sp + sh;
        let dd = sp - sh;
        let g = (g_coef * a).sqrt();
        let a2r = a * a * two_r;
        let dsum = a2r - g * s;
        let fsum = k * a * (a2r - 1.5 * g * s);
        let slope = 6.0 * k * a * a / r - 2.25 * k * g * s;
        let fdiff = 1.5 * k * a * g * dd;
        [
            dsum,
            dsum * cos_phi,
            g * dd * sin_phi,
            fsum,
            slope,
            fsum * cos_phi,
            fdiff * sin_phi,
        ]
    };
    let (sums, pieces) = integrate_pieces(rule, phi_end, speed, kink_speeds, &node);
    let inv2pi = 0.5 / PI;
    out.a_mean = (a_m * phi_end + a_a * sin_end) / PI;
    out.harmonics.delta_mean = sums[0] * inv2pi;
    out.harmonics.delta_sin = sums[1] / PI;
    out.harmonics.delta_cos = sums[2] / PI;
    out.harmonics.delta_amp = out.harmonics.delta_sin.hypot(out.harmonics.delta_cos);
    out.harmonics.force_mean = sums[3] * inv2pi;
    out.force_slope = sums[4] * inv2pi;
    out.harmonics.force_sin = sums[5] / PI;
    out.harmonics.force_cos = sums[6] / PI;
    out.contact_fraction = phi_end / PI;
    out.evaluations = 2 * rule.len() * pieces;
    out
}

/// The cycle of a static contact (no oscillation of the radius) at w(0): no kinks, closed form.
fn static_cycle<L: AdhesionLaw + ?Sized>(mut out: Cycle, m: &Material, law: &L, a_m: f64) -> Cycle {
    let (k, r) = (m.k, m.r);
    let g_coef = 8.0 * PI / (3.0 * k);
    let w = law.work_of_adhesion(0.0).max(0.0);
    let g = (g_coef * a_m).sqrt();
    let sw = w.sqrt();
    out.a_mean = a_m;
    out.harmonics.delta_mean = jkr::equilibrium_indentation(m, a_m, w);
    out.harmonics.force_mean = jkr::equilibrium_force(m, a_m, w);
    out.force_slope = 3.0 * k * a_m * a_m / r - 2.25 * k * g * sw;
    out.contact_fraction = 1.0;
    out.evaluations = 1;
    out
}

/// The integrals of `node` (a function of the distances to both ends of [0, Φ]) over
/// [0, `phi_end`], split where |ȧ| = `speed` |sin φ| hits a kink speed; and the number of pieces.
fn integrate_pieces(
    rule: &QuadratureRule,
    phi_end: f64,
    speed: f64,
    kink_speeds: &[f64],
    node: &impl Fn(f64, f64) -> [f64; 7],
) -> ([f64; 7], usize) {
    if kink_speeds.is_empty() {
        return (rule.integrate_n(0.0, phi_end, |_, d0, d1| node(d0, d1)), 1);
    }
    let mut cuts: Vec<f64> = kink_speeds
        .iter()
        .map(|v| v.abs() / speed)
        .filter(|&x| x > 0.0 && x <= 1.0)
        .flat_map(|x| {
            let p = x.asin();
            [p, PI - p]
        })
        .filter(|&p| p > 0.0 && p < phi_end)
        .collect();
    cuts.push(0.0);
    cuts.push(phi_end);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|x, y| (*x - *y).abs() <= 4.0 * f64::EPSILON * PI);
    let mut sums = [0.0; 7];
    for win in cuts.windows(2) {
        let (p0, p1) = (win[0], win[1]);
        // Distances to the cycle's own ends stay exact in the first and last piece.
        let tail = phi_end - p1;
        let part = rule.integrate_n(p0, p1, |_, dl, dr| node(p0 + dl, tail + dr));
        for (s, v) in sums.iter_mut().zip(part) {
            *s += v;
        }
    }
    (sums, cuts.len() - 1)
}

/// Indentation δ(θ) of the imposed cycle at phase θ = ωt (m); 0 where a ≤ 0 (no contact).
/// For plotting the paper's Fig. 2. Inputs are expected validated as by [`cycle`]; a non-finite
/// result is returned as 0.
pub fn indentation_at<L: AdhesionLaw + ?Sized>(
    m: &Material,
    law: &L,
    omega: f64,
    a_mean: f64,
    a_amp: f64,
    theta: f64,
) -> f64 {
    let (s, c) = theta.sin_cos();
    let a = a_mean + a_amp * s;
    if a.is_nan() || a <= 0.0 {
        return 0.0;
    }
    let w = law.work_of_adhesion(a_amp * omega * c).max(0.0);
    let d = jkr::equilibrium_indentation(m, a, w);
    if d.is_finite() {
        d
    } else {
        0.0
    }
}

/// Number of grid points of the pull-off scan.
const SCAN_POINTS: usize = 48;

/// Pull-off at fixed ω (rad/s) and a_A (m): the minimum over a_m of the mean force F_m.
///
/// ## Search range, from physics
/// The law is decreasing in ȧ, so over the cycle w ≤ w_max = w(−a_A ω), the work of adhesion at
/// the largest peeling speed. The slope dF_m/da_m = ⟨3K a²/R − (9/4) K g(a) √w⟩ (module doc) is then
/// bounded below by ⟨∂F_eq(a, w_max)/∂a⟩, and ∂F_eq(a, w_max)/∂a > 0 for every a above the JKR
/// load-controlled pull-off radius a_po(w_max). Hence F_m strictly increases once
/// a_m − a_A > a_po(w_max): every minimum lies in [−a_A, a_A + a_po(w_max)], and the scan covers
/// [−a_A, a_A + 1.05 a_po(w_max)].
///
/// ## Scan and refinement
/// F_m and its slope are evaluated on a uniform grid of 48 points (the first one a hair above
/// −a_A, where the contact is empty and the slope exactly 0); every sign change of the slope from −
/// to + brackets a local minimum, which is refined by Brent's root finder on the slope
/// (hand-written zeroin, `slope_root`; about 6 cycles per minimum). Why a root of the slope
/// rather than argmin's BrentOpt on F_m: the slope is computed analytically in the same
/// quadrature pass at no extra cost, and a root of it locates a_m,po to ~1e-12 relative, whereas
/// minimising values locates it only to ~√(quadrature error), i.e. ~1e-5 relative at 1e-10
/// accuracy in F_m (F_m itself is insensitive to that, being flat at its minimum).
///
/// Two minima closer than one grid cell (~1/47 of the range) would be seen as one; dense
/// brute-force scans found a single minimum for Gent–Schultz laws with n = 0.05…1.5 over six
/// decades of peeling speed (`docs/studies/imposed-area.md`, "Several local minima"; the tests
/// certify a few cases by dense scan). Cost: ~54 cycles (the time per pull-off is a benchmark:
/// `cargo bench --bench imposed_area`).
pub fn pull_off<L: AdhesionLaw + ?Sized + Sync>(
    m: &Material,
    law: &L,
    omega: f64,
    a_amp: f64,
) -> Result<PullOff, ParamError> {
    check_material(m)?;
    check_inputs(omega, 0.0, a_amp)?;
    let rule = QuadratureRule::default_rule();
    let w_max = law.work_of_adhesion(-a_amp * omega).max(law.w0());
    if !(w_max.is_finite() && w_max > 0.0) {
        return Err(ParamError::new(
            "law",
            w_max,
            "the work of adhesion at the largest peeling speed must be finite and > 0 J/m^2",
        ));
    }
    let lo = -a_amp;
    let hi = a_amp + 1.05 * jkr::load_controlled_pull_off_radius(m, w_max);
    let eval = |a: f64| cycle_unchecked(m, law, omega, a, a_amp, rule);
    let span = hi - lo;
    let mut prev = eval(lo + 1e-9 * span);
    let mut minima: Vec<Cycle> = Vec::new();
    let mut best_grid = prev;
    for i in 1..SCAN_POINTS {
        let a1 = lo + span * i as f64 / (SCAN_POINTS - 1) as f64;
        let next = eval(a1);
        if next.harmonics.force_mean < best_grid.harmonics.force_mean {
            best_grid = next;
        }
        if prev.force_slope < 0.0 && next.force_slope >= 0.0 {
            minima.push(slope_root(&eval, prev, next, 1e-12));
        }
        prev = next;
    }
    // The slope is positive at the end of the range by construction; if rounding made it
    // otherwise, the lowest grid point stands in, and the result is not certified global.
    let certified = prev.force_slope > 0.0 && !minima.is_empty();
    if minima.is_empty() {
        minima.push(best_grid);
    }
    let best = minima.iter().copied().fold(minima[0], |b, c| {
        if c.harmonics.force_mean < b.harmonics.force_mean {
            c
        } else {
            b
        }
    });
    let f0 = m.static_pull_off_force();
    Ok(PullOff {
        cycle: best,
        force: best.harmonics.force_mean,
        amplification: best.harmonics.force_mean / f0,
        local_minima: minima
            .iter()
            .map(|c| (c.a_mean_imposed, c.harmonics.force_mean))
            .collect(),
        global: certified,
    })
}

/// Brent's zeroin (Brent 1973, ch. 4) on the slope dF_m/da_m, from a bracket (c0, c1) of cycles
/// with slope(c0) < 0 ≤ slope(c1); returns the cycle at the root, to `rel_tol` relative in a_m.
/// Hand-written rather than `roots::find_root_brent`, which re-evaluates an end of its bracket at
/// every iteration (two cycles per step) and cannot hand back the cycle it last evaluated: here
/// a refinement costs 6–10 cycles.
fn slope_root<F: Fn(f64) -> Cycle>(eval: &F, c0: Cycle, c1: Cycle, rel_tol: f64) -> Cycle {
    // Points carry their cycles: a (previous iterate), b (best), c (opposite sign to b).
    let x = |c: &Cycle| c.a_mean_imposed;
    let y = |c: &Cycle| c.force_slope;
    let (mut pa, mut pb) = (c0, c1);
    let abs_tol = rel_tol * (x(&c1) - x(&c0)).abs();
    let mut pc = pa;
    let mut d = x(&pb) - x(&pa);
    let mut e = d;
    for _ in 0..200 {
        let mut c_is_a = false;
        if (y(&pb) > 0.0) == (y(&pc) > 0.0) {
            pc = pa;
            d = x(&pb) - x(&pa);
            e = d;
            c_is_a = true;
        }
        if y(&pc).abs() < y(&pb).abs() {
            pa = pb;
            pb = pc;
            pc = pa;
            c_is_a = true;
        }
        let (a, b, c) = (x(&pa), x(&pb), x(&pc));
        let (fa, fb, fc) = (y(&pa), y(&pb), y(&pc));
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * (rel_tol * b.abs()).max(abs_tol);
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            return pb;
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            // Inverse quadratic interpolation, or secant when only two points are distinct.
            let s = fb / fa;
            let (mut p, mut q) = if c_is_a {
                (2.0 * xm * s, 1.0 - s)
            } else {
                let q = fa / fc;
                let r = fb / fc;
                (
                    s * (2.0 * xm * q * (q - r) - (b - a) * (r - 1.0)),
                    (q - 1.0) * (r - 1.0) * (s - 1.0),
                )
            };
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * xm * q - (tol1 * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        pa = pb;
        pb = eval(b + if d.abs() > tol1 { d } else { tol1.copysign(xm) });
    }
    pb
}

/// Pull-off for every (frequency, amplitude) pair, in parallel (rayon). `freqs_hz` in Hz,
/// `a_amps` in m. The result is row-major: index = i_freq · a_amps.len() + i_amp.
pub fn pull_off_table<L: AdhesionLaw + ?Sized + Sync>(
    m: &Material,
    law: &L,
    freqs_hz: &[f64],
    a_amps: &[f64],
) -> Result<Vec<PullOff>, ParamError> {
    for &f in freqs_hz {
        if !(f.is_finite() && f > 0.0) {
            return Err(ParamError::new(
                "frequency",
                f,
                "must be a finite frequency > 0 Hz",
            ));
        }
    }
    let n = a_amps.len();
    (0..freqs_hz.len() * n)
        .into_par_iter()
        .map(|idx| {
            let f = freqs_hz[idx / n];
            let a = a_amps[idx % n];
            pull_off(m, law, 2.0 * PI * f, a)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adhesion::GentSchultz;

    const M: Material = Material::PAPER;

    #[test]
    fn slope_matches_finite_difference() {
        let law = GentSchultz::PAPER;
        let omega = 2.0 * PI * 300.0;
        for &(a_m, a_a) in &[
            (2e-3, 0.5e-3),
            (0.3e-3, 0.5e-3),
            (-0.2e-3, 0.5e-3),
            (1e-3, 0.0),
        ] {
            let c = cycle(&M, &law, omega, a_m, a_a).unwrap();
            let h = 1e-6 * (a_m.abs() + a_a);
            let fp = cycle(&M, &law, omega, a_m + h, a_a)
                .unwrap()
                .harmonics
                .force_mean;
            let fm = cycle(&M, &law, omega, a_m - h, a_a)
                .unwrap()
                .harmonics
                .force_mean;
            let fd = (fp - fm) / (2.0 * h);
            assert!(
                (fd - c.force_slope).abs() <= 1e-6 * c.force_slope.abs().max(1.0),
                "a_m {a_m}: fd {fd} vs {}",
                c.force_slope
            );
        }
    }

    #[test]
    fn zeroin_converges_fast_on_smooth_and_kinked_slopes() {
        use std::cell::Cell;
        let template = cycle(&M, &GentSchultz::PAPER, 1.0, 1e-3, 0.0).unwrap();
        for (name, f, root) in [
            (
                "cubic",
                (|x: f64| x * x * x - 2.0) as fn(f64) -> f64,
                2f64.cbrt(),
            ),
            (
                "kinked",
                |x: f64| if x < 0.3 { x - 0.3 } else { 5.0 * (x - 0.3) },
                0.3,
            ),
            ("flat", |x: f64| (x - 0.7).powi(3), 0.7),
        ] {
            let calls = Cell::new(0);
            let eval = |x: f64| {
                calls.set(calls.get() + 1);
                Cycle {
                    a_mean_imposed: x,
                    force_slope: f(x),
                    ..template
                }
            };
            let c = slope_root(&eval, eval(0.0), eval(2.0), 1e-12);
            let tol = if name == "flat" { 1e-4 } else { 1e-11 };
            assert!(
                (c.a_mean_imposed - root).abs() < tol,
                "{name}: {}",
                c.a_mean_imposed
            );
            // Superlinear where the slope has a simple root; at worst a few times bisection
            // (41 halvings of the bracket) for a degenerate, triple root.
            let max_calls = if name == "flat" { 150 } else { 20 };
            assert!(calls.get() < max_calls, "{name}: {} calls", calls.get());
        }
    }

    #[test]
    fn harmonics_are_flat_in_json_in_field_order() {
        // The shared Harmonics type sits inside Cycle, flattened: the JSON a user reads keeps
        // the keys and order it had when they were fields of Cycle itself.
        let c = cycle(&M, &GentSchultz::PAPER, 100.0, 0.5e-3, 0.2e-3).unwrap();
        let v = serde_json::to_value(c).unwrap();
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        let text = serde_json::to_string(&c).unwrap();
        let mut in_text = keys.clone();
        in_text.sort_by_key(|k| text.find(&format!("\"{k}\"")).unwrap());
        assert_eq!(
            in_text,
            [
                "a_mean_imposed",
                "a_amp",
                "a_mean",
                "delta_mean",
                "delta_sin",
                "delta_cos",
                "delta_amp",
                "force_mean",
                "force_sin",
                "force_cos",
                "force_slope",
                "contact_fraction",
                "evaluations"
            ]
        );
        assert_eq!(v["delta_amp"].as_f64(), Some(c.harmonics.delta_amp));
        assert_eq!(v["force_cos"].as_f64(), Some(c.harmonics.force_cos));
    }

    #[test]
    fn mean_truncated_radius_and_contact_fraction() {
        let law = GentSchultz::PAPER;
        let a_a = 1e-3;
        for &a_m in &[-0.5e-3, 0.0, 0.5e-3, 1e-3, 2e-3] {
            let c = cycle(&M, &law, 100.0, a_m, a_a).unwrap();
            // Brute force: midpoint rule on max(a, 0), whose kinks cost O(N^-2).
            let n = 200_000;
            let (mut s, mut t) = (0.0, 0.0);
            for i in 0..n {
                let th = 2.0 * PI * (i as f64 + 0.5) / n as f64;
                let a = a_m + a_a * th.sin();
                s += a.max(0.0);
                t += if a > 0.0 { 1.0 } else { 0.0 };
            }
            assert!((c.a_mean - s / n as f64).abs() < 1e-12, "{a_m}");
            assert!((c.contact_fraction - t / n as f64).abs() < 1e-4, "{a_m}");
        }
    }

    #[test]
    fn rejects_bad_inputs_naming_the_parameter() {
        let law = GentSchultz::PAPER;
        let e = cycle(&M, &law, 0.0, 1e-3, 1e-4).unwrap_err();
        assert_eq!(e.name, "omega");
        let e = cycle(&M, &law, 1.0, 1e-3, -1e-4).unwrap_err();
        assert_eq!(e.name, "a_amp");
        let e = cycle(&M, &law, 1.0, -2e-4, 1e-4).unwrap_err();
        assert_eq!(e.name, "a_mean");
        let e = cycle(&M, &law, 1.0, f64::NAN, 1e-4).unwrap_err();
        assert_eq!(e.name, "a_mean");
        let e = pull_off(&M, &law, f64::INFINITY, 1e-4).unwrap_err();
        assert_eq!(e.name, "omega");
        let e = pull_off_table(&M, &law, &[200.0, -1.0], &[1e-4]).unwrap_err();
        assert_eq!(e.name, "frequency");
        let bad = Material { k: -1.0, ..M };
        assert!(cycle(&bad, &law, 1.0, 1e-3, 1e-4).is_err());
    }

    #[test]
    fn empty_contact_is_all_zero() {
        let law = GentSchultz::PAPER;
        let c = cycle(&M, &law, 100.0, -1e-3, 1e-3).unwrap();
        // Exactly zero, not merely small.
        for v in [
            c.harmonics.force_mean,
            c.harmonics.delta_mean,
            c.harmonics.delta_amp,
            c.contact_fraction,
            c.a_mean,
        ] {
            assert!(v.abs() < f64::MIN_POSITIVE, "{c:?}");
        }
        let d = indentation_at(&M, &law, 100.0, 0.2e-3, 1e-3, 1.5 * PI);
        assert!(d.abs() < f64::MIN_POSITIVE);
    }
}
