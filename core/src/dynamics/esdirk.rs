//! The implicit stepper: Kennedy & Carpenter's `ESDIRK4(3)6L[2]SA` (the implicit half of
//! `ARK4(3)6L[2]SA`, coefficients as SUNDIALS ARKODE ships them), applied to the whole state
//! (x_s, v_s, a), with the quadrature states integrated by the same weights.
//!
//! Each implicit stage reduces to one scalar monotone root: at fixed a the mechanical stage
//! equations are linear in (x_s, v_s) (F is linear in δ at fixed a), so they are eliminated in
//! closed form ([`Model::position`]); what remains is the contact-radius equation in its forward
//! form G_s(a_i, δ_i(a_i)) = w(ȧ_i) with ȧ_i = (a_i − c_i)/(hγ), which has no infinite speeds
//! anywhere (a compressive edge, G ≤ 0, and a constant w, where it becomes the algebraic
//! G = w0, are all harmless). The root is the *upward* crossing of
//! ρ(a) = (G_s − w)/w0 nearest the predictor, bracketed by geometric expansion and refined by
//! Brent (`roots::find_root_brent` with [`RelativeConvergency`]). No root with a > 0 means the
//! contact collapses within the stage: the step fails ([`StepFail::NoRoot`]) and the driver
//! shrinks it; when it cannot be shrunk further the contact is lost.
//!
//! The method is stiffly accurate (y_{n+1} is the last stage, so ȧ at the step end is the
//! exact rate of the new state and is reused as the first, explicit stage of the next step) and
//! L-stable: the healing stiffness ∂ȧ/∂a ≈ −4aȧ/(nRu) costs no stability restriction.

use super::model::{Drive, Kinematics, Mechanics, Model, NQ};
use super::state::{State, StepFail, StepOut, Tol};
use super::stepper::{Capabilities, Reach, Stepper};
use crate::adhesion::Law;
use crate::jkr;
use crate::numerics::RelativeConvergency;

/// Number of stages.
pub const S: usize = 6;
/// Diagonal coefficient γ.
pub const GAMMA: f64 = 0.25;

/// Butcher coefficients A (lower triangular, diagonal γ from the second stage on).
pub const A: [[f64; S]; S] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.25, 0.25, 0.0, 0.0, 0.0, 0.0],
    [8611.0 / 62500.0, -1743.0 / 31250.0, 0.25, 0.0, 0.0, 0.0],
    [
        5012029.0 / 34652500.0,
        -654441.0 / 2922500.0,
        174375.0 / 388108.0,
        0.25,
        0.0,
        0.0,
    ],
    [
        15267082809.0 / 155376265600.0,
        -71443401.0 / 120774400.0,
        730878875.0 / 902184768.0,
        2285395.0 / 8070912.0,
        0.25,
        0.0,
    ],
    [
        82889.0 / 524892.0,
        0.0,
        15625.0 / 83664.0,
        69875.0 / 102672.0,
        -2260.0 / 8211.0,
        0.25,
    ],
];
/// Weights of the 4th-order solution (= the last row of A: stiffly accurate).
pub const B: [f64; S] = A[5];
/// Weights of the embedded 3rd-order solution.
pub const BHAT: [f64; S] = [
    4586570599.0 / 29645900160.0,
    0.0,
    178811875.0 / 945068544.0,
    814220225.0 / 1159782912.0,
    -3700637.0 / 11593932.0,
    61727.0 / 225920.0,
];
/// Nodes.
pub const C: [f64; S] = [0.0, 0.5, 83.0 / 250.0, 31.0 / 50.0, 17.0 / 20.0, 1.0];

/// Find the contact radius of an implicit stage: the upward zero crossing of `rho` (a function of
/// a, increasing through its root) nearest to the predictor `a_p`, to `xtol_rel` relative in a
/// on the secant fast path (the driver uses 10⁻⁴ rtol: well inside the step's error budget).
/// Returns `None` when no crossing exists with a > 0.
pub fn solve_radius<F: FnMut(f64) -> f64>(
    mut rho: F,
    a_p: f64,
    step0: f64,
    xtol_rel: f64,
    evals: &mut u64,
) -> Option<f64> {
    let mut eval = |a: f64| {
        *evals += 1;
        rho(a)
    };
    let r_p = eval(a_p);
    if !r_p.is_finite() {
        return None;
    }
    if r_p == 0.0 {
        return Some(a_p);
    }
    if let Some(a) = secant_radius(&mut eval, a_p, r_p, step0, xtol_rel) {
        return Some(a);
    }
    let (lo, hi, rhi) = bracket_radius(&mut eval, a_p, r_p, step0)?;
    if rhi == 0.0 {
        return Some(hi);
    }
    let mut conv = RelativeConvergency {
        x_rel: 8.0 * f64::EPSILON,
        x_abs: 1e-300,
        f_abs: 0.0,
        max_iter: 100,
    };
    match roots::find_root_brent(lo, hi, &mut eval, &mut conv) {
        Ok(a) if a > 0.0 => Some(a),
        Ok(_) => None,
        // The bracket is valid, so only the iteration limit can fail: take its midpoint.
        Err(_) => Some(0.5 * (lo + hi)),
    }
}

/// The fast path of [`solve_radius`]: secant iteration from the predictor `a_p` (where ρ is
/// `r_p`), accepted only if it converges onto an upward crossing (positive slope); otherwise
/// `None` and the bracketing search decides.
fn secant_radius(
    eval: &mut impl FnMut(f64) -> f64,
    a_p: f64,
    r_p: f64,
    step0: f64,
    xtol_rel: f64,
) -> Option<f64> {
    let (mut a0, mut r0) = (a_p, r_p);
    let dir = if r_p < 0.0 { 1.0 } else { -1.0 };
    let mut a1 = a_p + dir * step0.max(1e-9 * a_p);
    if a1 > 0.0 {
        let mut r1 = eval(a1);
        for _ in 0..12 {
            if !r1.is_finite() || (r1 - r0).abs() <= 0.0 {
                break;
            }
            let slope = (r1 - r0) / (a1 - a0);
            if slope <= 0.0 {
                break;
            }
            let a2 = a1 - r1 / slope;
            if a2.is_nan() || a2 <= 0.0 {
                break;
            }
            if (a2 - a1).abs() <= xtol_rel * a2 {
                return Some(a2);
            }
            (a0, r0) = (a1, r1);
            a1 = a2;
            r1 = eval(a1);
            if r1 == 0.0 {
                return Some(a1);
            }
        }
    }
    None
}

/// A bracket (lo, hi, ρ(hi)) of the upward crossing nearest to the predictor `a_p` (where ρ is
/// `r_p`), searched outwards in steps growing 4× from `step0`; `None` when there is none with
/// a > 0.
fn bracket_radius(
    eval: &mut impl FnMut(f64) -> f64,
    a_p: f64,
    r_p: f64,
    step0: f64,
) -> Option<(f64, f64, f64)> {
    let mut d = step0.max(4.0 * f64::EPSILON * a_p);
    if r_p < 0.0 {
        let mut l = a_p;
        loop {
            let h = a_p + d;
            let r = eval(h);
            if !r.is_finite() {
                return None;
            }
            if r >= 0.0 {
                return Some((l, h, r));
            }
            l = h;
            d *= 4.0;
            if d > 1e12 * a_p.max(step0) {
                return None;
            }
        }
    } else {
        let mut h = a_p;
        let mut rh = r_p;
        let mut last = false;
        loop {
            let mut l = a_p - d;
            if l <= 0.0 {
                l = a_p * 1e-12;
                last = true;
            }
            let r = eval(l);
            if r.is_finite() && r < 0.0 {
                return Some((l, h, rh));
            }
            if last {
                return None;
            }
            h = l;
            rh = if r.is_finite() { r } else { f64::INFINITY };
            d *= 4.0;
        }
    }
}

/// Safeguarded Newton iteration for the stage radius: `rho_d(a)` returns (ρ, dρ/da) with the
/// analytic derivative. A Newton step that leaves the bracket of the upward crossing found so
/// far, or that does not halve |ρ|, is replaced by bisection of that bracket. Converged (step
/// below `xtol_rel` relative) only onto an upward crossing (dρ/da > 0); `None` hands the stage to
/// the derivative-free [`solve_radius`] (non-monotone ρ, a kink exactly at the predictor, no
/// convergence in 12 iterations), which keeps every old guarantee.
fn newton_radius<F: FnMut(f64) -> (f64, f64, f64, f64)>(
    mut rho_d: F,
    p0: f64,
    p_floor: f64,
    xtol_rel: f64,
    evals: &mut u64,
    k_hint: &mut f64,
) -> Option<(f64, f64)> {
    let mut p = p0;
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    let mut r_prev = f64::INFINITY;
    let mut step_prev = f64::INFINITY;
    for _ in 0..12 {
        let (r, d, a, dadp) = rho_d(p);
        *evals += 1;
        if !r.is_finite() || d.is_nan() || d <= 0.0 || !d.is_finite() {
            return None;
        }
        if r == 0.0 {
            return Some((p, a));
        }
        if r < 0.0 {
            lo = lo.max(p);
        } else {
            hi = hi.min(p);
        }
        let mut pn = p - r / d;
        if lo.is_finite() && hi.is_finite() && (!(pn > lo && pn < hi) || r.abs() > 0.5 * r_prev) {
            pn = 0.5 * (lo + hi);
        }
        r_prev = r.abs();
        let step = (pn - p).abs();
        let tol = xtol_rel * pn.abs().max(p_floor);
        // Converged when this step is below tolerance, or when the measured quadratic
        // contraction K = |Δ_k|/|Δ_{k−1}|² says the error left after it, K Δ_k², is.
        let contraction = if step_prev.is_finite() {
            let k = step / (step_prev * step_prev);
            *k_hint = k;
            k
        } else if k_hint.is_finite() {
            // First step: the contraction measured on the previous stage of this step, with a
            // safety factor of 4.
            4.0 * *k_hint
        } else {
            f64::INFINITY
        };
        step_prev = step;
        if step <= tol || contraction * step * step <= tol {
            // The last Newton correction, carried to a to first order (its error is of the
            // order of the square of an already negligible step).
            return Some((pn, a + dadp * (pn - p)));
        }
        p = pn;
    }
    None
}

/// Values at one stage.
#[derive(Debug, Clone, Copy)]
struct Stage {
    x: f64,
    v: f64,
    a: f64,
    fx: f64,
    fv: f64,
    fa: f64,
    /// Law variable z = sign(ȧ)(|ȧ|/v0)^n of the Gent–Schultz (n < 1) stage solve (else 0).
    z: f64,
}

/// Evaluate the explicit derivatives at a state (used for the first stage and after resets).
pub fn derivatives(model: &Model, kin: &Kinematics, y: &State) -> (f64, [f64; NQ]) {
    let acc = match model.mech {
        Mechanics::Dynamic => model.accel(kin, y.x, y.v, y.a, y.contact),
        _ => 0.0,
    };
    let w = if y.contact {
        model.work_of_adhesion(y.adot)
    } else {
        model.w0
    };
    let fq = model.integrands(kin, y.x, y.v, y.a, y.adot, w, y.contact);
    (acc, fq)
}

/// The contact radius of an implicit stage in contact: (a, ȧ, w(ȧ) when known, the law
/// variable z of the Gent–Schultz Newton path or NaN). The root is found by [`newton_radius`]
/// with the analytic dρ/da for the laws with a closed-form slope (Gent–Schultz, constant),
/// falling back to [`solve_radius`]; arguments as [`implicit_stage`]'s.
#[allow(clippy::too_many_arguments)]
#[inline]
fn stage_radius(
    model: &Model,
    kin: &Kinematics,
    xk: f64,
    vk: f64,
    ck: f64,
    hg: f64,
    adot_guess: f64,
    z_guess: Option<f64>,
    xtol_rel: f64,
    evals: &mut u64,
    k_hint: &mut f64,
) -> Result<(f64, f64, Option<f64>, f64), StepFail> {
    let mat = &model.mat;
    let w0 = model.w0;
    let mut a_p = ck + hg * adot_guess;
    if !(a_p > 0.0 && a_p.is_finite()) {
        a_p = if ck > 0.0 { ck } else { model.a_floor };
    }
    let inv_hg = 1.0 / hg;
    let c3 = 3.0 * mat.k / (8.0 * std::f64::consts::PI);
    let inv_r = 1.0 / mat.r;
    // G_s(a, δ(a)) and its total derivative in a.
    let g_d = |a: f64| {
        let (x, dx) = model.position_slope(kin, a, xk, vk, hg);
        let u = a * a * inv_r - (x + kin.xb);
        let du = 2.0 * a * inv_r - dx;
        let inv_a = 1.0 / a;
        (
            c3 * u * u.abs() * inv_a,
            c3 * u.abs() * inv_a * (2.0 * du - u * inv_a),
        )
    };
    let newton = match &model.law {
        Law::GentSchultz(gs) if gs.n < 1.0 => {
            // Gent–Schultz with n < 1: Newton in z = sign(ȧ)(|ȧ|/v0)^n, in which w(z) =
            // w0(1 + |z|) (peeling) or w0/(1 + z) (healing) is C¹ with slope −w0 at z = 0
            // and a(z) = c + hγ v0 sign(z)|z|^(1/n) is C¹: ρ(z) is regular through the kink
            // ȧ = 0 where ρ(a) has an infinite slope. |z|^(1/n) as exp(ln|z|/n): one exp
            // and one ln per evaluation instead of the slower `pow`.
            let inv_n = 1.0 / gs.n;
            let v0h = hg * gs.v0;
            let rho_z = |z: f64| {
                let za = z.abs();
                let (pw, da) = if za > 0.0 {
                    let pw = (za.ln() * inv_n).exp();
                    (pw, v0h * inv_n * pw / za)
                } else {
                    (0.0, 0.0)
                };
                let a = ck + v0h * pw.copysign(z);
                if a.is_nan() || a <= 0.0 {
                    return (f64::NAN, f64::NAN, a, da);
                }
                let (g, dg) = g_d(a);
                let (w, dw) = if z < 0.0 {
                    (gs.w0 * (1.0 - z), -gs.w0)
                } else {
                    let d = 1.0 + z;
                    (gs.w0 / d, -gs.w0 / (d * d))
                };
                ((g - w) / w0, (dg * da - dw) / w0, a, da)
            };
            let z_p = match z_guess {
                Some(z) if z.is_finite() => z,
                _ => {
                    let ad_p = (a_p - ck) * inv_hg;
                    (ad_p.abs() / gs.v0).powf(gs.n).copysign(ad_p)
                }
            };
            newton_radius(rho_z, z_p, 1.0, xtol_rel, evals, k_hint)
        }
        _ if model.has_law_slope() => {
            let rho_d = |a: f64| {
                if a.is_nan() || a <= 0.0 {
                    return (f64::NAN, f64::NAN, a, 1.0);
                }
                let ad = (a - ck) * inv_hg;
                let (g, dg) = g_d(a);
                let (w, dw) = model.work_and_slope(ad).unwrap_or((w0, 0.0));
                ((g - w) / w0, (dg - dw * inv_hg) / w0, a, 1.0)
            };
            newton_radius(rho_d, a_p, 0.0, xtol_rel, evals, k_hint).map(|(_, a)| (f64::NAN, a))
        }
        _ => None,
    };
    match newton {
        Some((z, a)) => Ok((a, (a - ck) * inv_hg, None, z)),
        None => {
            let rho = |a: f64| {
                if a <= 0.0 {
                    return f64::NAN;
                }
                let ad = (a - ck) / hg;
                let (x, _) = model.position(kin, a, ad, true, xk, vk, hg);
                let g = jkr::signed_energy_release_rate(mat, a, x + kin.xb);
                (g - model.work_of_adhesion(ad)) / w0
            };
            let step0 = (1e-3 * (a_p - ck).abs()).max(1e-10 * a_p);
            let a = solve_radius(rho, a_p, step0, xtol_rel, evals).ok_or(StepFail::NoRoot)?;
            let ad = (a - ck) / hg;
            Ok((a, ad, Some(model.work_of_adhesion(ad)), f64::NAN))
        }
    }
}

/// Solve one implicit stage (also used alone as a backward-Euler step with `hg` = h).
/// `xk`, `vk`, `ck` are the known parts of x, v, a; returns the stage values and adds
/// `wq` × (the quadrature integrands) to `qacc` (skipped for a zero weight).
///
/// The root is found by [`newton_radius`] with the analytic dρ/da for the laws with a closed-form
/// slope (Gent–Schultz, constant), falling back to [`solve_radius`]. On the Newton path w(ȧ) at
/// the root is taken as G_s (they agree to the root's residual), which saves the law's `powf`.
#[allow(clippy::too_many_arguments)]
fn implicit_stage(
    model: &Model,
    kin: &Kinematics,
    contact: bool,
    xk: f64,
    vk: f64,
    ck: f64,
    hg: f64,
    adot_guess: f64,
    z_guess: Option<f64>,
    xtol_rel: f64,
    evals: &mut u64,
    wq: f64,
    qacc: &mut [f64; NQ],
    k_hint: &mut f64,
) -> Result<Stage, StepFail> {
    let (a, adot, w_known, z_out) = if contact {
        stage_radius(
            model, kin, xk, vk, ck, hg, adot_guess, z_guess, xtol_rel, evals, k_hint,
        )?
    } else {
        (0.0, 0.0, Some(model.w0), f64::NAN)
    };
    let (x, v) = model.position(kin, a, adot, contact, xk, vk, hg);
    let fv = match model.mech {
        Mechanics::Dynamic => model.accel(kin, x, v, a, contact),
        _ => 0.0,
    };
    *evals += 1;
    if !(x.is_finite() && v.is_finite() && a.is_finite() && adot.is_finite() && fv.is_finite()) {
        return Err(StepFail::NonFinite);
    }
    if wq != 0.0 {
        let w = match w_known {
            Some(w) => w,
            None if model.rate_independent => model.w0,
            None => jkr::signed_energy_release_rate(&model.mat, a, x + kin.xb),
        };
        let fq = model.integrands(kin, x, v, a, adot, w, contact);
        for (q, f) in qacc.iter_mut().zip(fq.iter()) {
            *q += wq * f;
        }
    }
    Ok(Stage {
        x,
        v,
        a,
        fx: v,
        fv,
        fa: adot,
        z: z_out,
    })
}

/// Predictors for stage `i`'s rate and law variable: linear extrapolation in time through the
/// two previous stages (the first implicit stage uses the step's initial values). In the law
/// variable z the extrapolation is linear in time through a turning point ȧ = 0, where ȧ
/// itself is not.
#[inline]
fn predict(st: &[Stage; S], i: usize) -> (f64, f64) {
    if i < 2 {
        return (st[0].fa, st[0].z);
    }
    let (c1, c2) = (C[i - 1], C[i - 2]);
    let slope = (st[i - 1].fa - st[i - 2].fa) / (c1 - c2);
    let guess = st[i - 1].fa + slope * (C[i] - c1);
    let slope = (st[i - 1].z - st[i - 2].z) / (c1 - c2);
    (guess, st[i - 1].z + slope * (C[i] - c1))
}

/// The step's error: h Σ (b − b̂) f for the integrated components, as the RMS of
/// err/(atol·scale + rtol·|y|).
#[inline]
fn error_norm(model: &Model, tol: Tol, y: &State, st: &[Stage; S], h: f64) -> f64 {
    let last = st[S - 1];
    let (mut ex, mut ev, mut ea) = (0.0, 0.0, 0.0);
    for (j, stj) in st.iter().enumerate() {
        let e = B[j] - BHAT[j];
        ex += e * stj.fx;
        ev += e * stj.fv;
        ea += e * stj.fa;
    }
    let (ex, ev, ea) = (h * ex, h * ev, h * ea);
    let mut sum = 0.0;
    let mut n = 0;
    if model.mech == Mechanics::Dynamic {
        let sx = tol.atol * model.len_scale + tol.rtol * y.x.abs().max(last.x.abs());
        let sv = tol.atol * model.vel_scale + tol.rtol * y.v.abs().max(last.v.abs());
        sum += (ex / sx).powi(2) + (ev / sv).powi(2);
        n += 2;
    }
    if y.contact {
        let sa = tol.atol * model.a_jump + tol.rtol * y.a.abs().max(last.a.abs());
        sum += (ea / sa).powi(2);
        n += 1;
    }
    if n > 0 {
        (sum / n as f64).sqrt()
    } else {
        0.0
    }
}

/// One ESDIRK step of size h from y (the drive must not change within the step).
pub fn step(
    model: &Model,
    drive: &Drive,
    y: &State,
    h: f64,
    tol: Tol,
) -> Result<StepOut, StepFail> {
    let mut evals = 0u64;
    let kin0 = drive.at(model, y.t);
    let (acc0, fq0) = derivatives(model, &kin0, y);
    evals += 1;
    let mut qacc = [0.0; NQ];
    for (q, f) in qacc.iter_mut().zip(fq0.iter()) {
        *q = B[0] * f;
    }
    let mut st = [Stage {
        x: y.x,
        v: y.v,
        a: y.a,
        fx: y.v,
        fv: acc0,
        fa: if y.contact { y.adot } else { 0.0 },
        z: match &model.law {
            Law::GentSchultz(gs) if gs.n < 1.0 && y.contact => {
                (y.adot.abs() / gs.v0).powf(gs.n).copysign(y.adot)
            }
            _ => f64::NAN,
        },
    }; S];
    let hg = h * GAMMA;
    let xtol = (1e-2 * tol.rtol).max(1e-14);
    let mut k_hint = f64::NAN;
    for i in 1..S {
        let t = y.t + C[i] * h;
        let kin = drive.at(model, t);
        let (mut xk, mut vk, mut ck) = (y.x, y.v, y.a);
        for j in 0..i {
            let aij = A[i][j];
            if aij != 0.0 {
                xk += h * aij * st[j].fx;
                vk += h * aij * st[j].fv;
                ck += h * aij * st[j].fa;
            }
        }
        let (guess, z_guess) = predict(&st, i);
        st[i] = implicit_stage(
            model,
            &kin,
            y.contact,
            xk,
            vk,
            ck,
            hg,
            guess,
            Some(z_guess),
            xtol,
            &mut evals,
            B[i],
            &mut qacc,
            &mut k_hint,
        )?;
    }
    let last = st[S - 1];
    let mut qn = y.q;
    for (qk, s) in qn.iter_mut().zip(qacc.iter()) {
        *qk += h * s;
    }
    let err = error_norm(model, tol, y, &st, h);
    if !err.is_finite() || qn.iter().any(|v| !v.is_finite()) {
        return Err(StepFail::NonFinite);
    }
    Ok(StepOut {
        y: State {
            t: y.t + h,
            x: last.x,
            v: last.v,
            acc: last.fv,
            a: last.a,
            adot: last.fa,
            contact: y.contact,
            q: qn,
        },
        err,
        evals,
        err_exp: 0.25,
        kink: None,
        kink_ahead: None,
    })
}

/// One backward-Euler step of size h (first order, L-stable): used right after a contact forms
/// from a seed, where the healing rate of the reset state is practically infinite. The rate ȧ
/// it returns is the exact rate of its end state, so the ESDIRK can continue from there.
pub fn backward_euler(
    model: &Model,
    drive: &Drive,
    y: &State,
    h: f64,
) -> Result<StepOut, StepFail> {
    let mut evals = 0;
    let kin = drive.at(model, y.t + h);
    let kin0 = drive.at(model, y.t);
    let (_, fq0) = derivatives(model, &kin0, y);
    let mut qacc = [0.0; NQ];
    for (q, f) in qacc.iter_mut().zip(fq0.iter()) {
        *q = 0.5 * f;
    }
    let mut no_hint = f64::NAN;
    let st = implicit_stage(
        model,
        &kin,
        y.contact,
        y.x,
        y.v,
        y.a,
        h,
        0.0,
        None,
        1e-14,
        &mut evals,
        0.5,
        &mut qacc,
        &mut no_hint,
    )?;
    let mut qn = y.q;
    for (qk, s) in qn.iter_mut().zip(qacc.iter()) {
        *qk += h * s;
    }
    Ok(StepOut {
        y: State {
            t: y.t + h,
            x: st.x,
            v: st.v,
            acc: st.fv,
            a: st.a,
            adot: st.fa,
            contact: y.contact,
            q: qn,
        },
        err: 0.0,
        evals,
        err_exp: 0.0,
        kink: None,
        kink_ahead: None,
    })
}

/// The implicit `ESDIRK4(3)6L[2]SA` with the root-solved contact radius ([`step`]), as a
/// [`Stepper`].
#[derive(Debug, Default, Clone, Copy)]
pub struct Implicit;

impl Stepper for Implicit {
    fn fresh(&self) -> Box<dyn Stepper> {
        Box::new(Implicit)
    }
    fn name(&self) -> &'static str {
        "implicit ESDIRK4(3)6L[2]SA (root-solved contact radius)"
    }
    fn short_name(&self) -> &'static str {
        "implicit"
    }
    /// It solves the contact radius as a root (so it integrates a rate-independent law too);
    /// its steps, several times shorter than DP8's, need no turning points, memory or halving.
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            algebraic_radius: true,
            turning_points: false,
            period_memory: false,
            reach: Reach::Full,
        }
    }
    fn attempt(
        &mut self,
        model: &Model,
        drive: &Drive,
        y: &State,
        h: f64,
        tol: Tol,
        _evals: &mut u64,
        out: &mut StepOut,
    ) -> Result<(), StepFail> {
        *out = step(model, drive, y, h, tol)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Newton stage solve (in z for GS n < 1, in a for GS n ≥ 1 and constant w) lands on the
    /// same root as the derivative-free bracketing solve (Brent to 8 ε) of the plain residual
    /// ρ(a) = (G_s − w(ȧ))/w0, over peeling, healing near G → 0, and stages at the turning point.
    #[test]
    fn newton_stage_matches_bracketing_solve() {
        use crate::adhesion::{ConstantW, GentSchultz};
        use crate::dynamics::model::{resolve, Drive};
        let laws = [
            Law::GentSchultz(GentSchultz::PAPER),
            Law::GentSchultz(GentSchultz {
                n: 1.5,
                ..GentSchultz::PAPER
            }),
            Law::Constant(ConstantW { w0: 0.24 }),
        ];
        let drive = Drive::held(0.0, true);
        let mut checked = 0;
        for law in laws {
            let (rig, scales) = crate::dynamics::test_hold(law);
            let model = match resolve(&rig, scales) {
                Ok(m) => m,
                Err(e) => panic!("{e}"),
            };
            let a0 = 1.2e-3;
            let d_eq = jkr::equilibrium_indentation(&model.mat, a0, model.w0);
            for &t in &[1e-4, 7e-4] {
                let kin = drive.at(&model, t);
                for &dd in &[-3e-7, -1e-8, 0.0, 1e-9, 1e-8, 3e-7, 2e-6] {
                    for &hg in &[2.5e-7, 5e-6] {
                        for &guess in &[0.0, 1e-4, -1e-3] {
                            let xk = d_eq + dd - kin.xb;
                            let mut ev = 0;
                            let mut q = [0.0; NQ];
                            let mut no_hint = f64::NAN;
                            let st = implicit_stage(
                                &model,
                                &kin,
                                true,
                                xk,
                                0.0,
                                a0,
                                hg,
                                guess,
                                None,
                                1e-12,
                                &mut ev,
                                0.0,
                                &mut q,
                                &mut no_hint,
                            );
                            let rho = |a: f64| {
                                if a <= 0.0 {
                                    return f64::NAN;
                                }
                                let ad = (a - a0) / hg;
                                let (x, _) = model.position(&kin, a, ad, true, xk, 0.0, hg);
                                let g = jkr::signed_energy_release_rate(&model.mat, a, x + kin.xb);
                                (g - model.work_of_adhesion(ad)) / model.w0
                            };
                            let a_p = a0 + hg * guess;
                            let reference = solve_radius(rho, a_p, 1e-9 * a_p, 1e-15, &mut ev);
                            match (st, reference) {
                                (Ok(st), Some(ar)) => {
                                    assert!(
                                        (st.a - ar).abs() <= 1e-11 * ar,
                                        "{:?} dd {dd:e} hg {hg:e}: {} vs {ar}",
                                        rig.law,
                                        st.a
                                    );
                                    checked += 1;
                                }
                                (Err(StepFail::NoRoot), None) => {}
                                (a, b) => panic!("dd {dd:e} hg {hg:e}: {a:?} vs {b:?}"),
                            }
                        }
                    }
                }
            }
        }
        assert!(checked > 200, "{checked}");
    }

    #[test]
    fn order_conditions() {
        let c = C;
        for i in 0..S {
            let s: f64 = A[i].iter().sum();
            assert!((s - c[i]).abs() < 1e-14, "row {i}");
        }
        let dot = |u: &[f64; S], v: &[f64; S]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        let ac = |v: &[f64; S]| {
            let mut r = [0.0; S];
            for i in 0..S {
                r[i] = (0..S).map(|j| A[i][j] * v[j]).sum();
            }
            r
        };
        let c2: [f64; S] = c.map(|x| x * x);
        let c3: [f64; S] = c.map(|x| x * x * x);
        let one = [1.0; S];
        for (w, p) in [(B, 4), (BHAT, 3)] {
            let mut conds = vec![
                (dot(&w, &one), 1.0),
                (dot(&w, &c), 0.5),
                (dot(&w, &c2), 1.0 / 3.0),
                (dot(&w, &ac(&c)), 1.0 / 6.0),
            ];
            if p >= 4 {
                let cac: [f64; S] = {
                    let t = ac(&c);
                    let mut r = [0.0; S];
                    for i in 0..S {
                        r[i] = c[i] * t[i];
                    }
                    r
                };
                conds.push((dot(&w, &c3), 0.25));
                conds.push((dot(&w, &cac), 0.125));
                conds.push((dot(&w, &ac(&c2)), 1.0 / 12.0));
                conds.push((dot(&w, &ac(&ac(&c))), 1.0 / 24.0));
            }
            for (k, (got, want)) in conds.iter().enumerate() {
                assert!(
                    (got - want).abs() < 1e-12,
                    "order {p} condition {k}: {got} vs {want}"
                );
            }
        }
    }
}
