//! djkr's own explicit stepper: Dormand & Prince's 8(5,3) pair (Hairer's `DOP853`: 12 stages,
//! the 8th-order solution propagated, error from the combined 5th- and 3rd-order estimates,
//! first-same-as-last), taking one step at a time inside the driver's loop like the implicit
//! stepper.
//!
//! Why not only `ode_solvers`' Dop853: that crate's tableau has c₁₂ = 0 where the row sum (and
//! Hairer's value) is 1, so on a time-dependent right-hand side (the base motion, the moving
//! spring end) its 12th stage is evaluated at the wrong time and the step control collapses
//! (srenevey/ode-solvers PR #42, open). Its integrator also cannot reject a step whose trial
//! stage leaves the domain of the law (G ≤ 0: infinite healing speed), and every macro step is a
//! restart. Here:
//!
//! - a trial stage with G ≤ 0 in contact fails the *step* ([`StepFail::Singular`]), which the
//!   driver rejects and shortens (or, under `auto`, takes with the implicit method); a stage
//!   with a ≤ 0 reports a collapsing contact ([`StepFail::NoRoot`]), as the implicit stages do;
//! - only (x_s, v_s, a) feed the right-hand side, so the stage sums run over three components;
//!   the quadrature states are integrated with the 8th-order weights but kept out of the error
//!   norm (as in the implicit stepper: they are smooth functionals of the state);
//! - the last evaluation f(t + h, y₁) is returned for reuse as the first stage of the next step.
//!
//! Coefficients: Hairer's `dop853.f` (the same values as scipy's `DOP853`), with the order
//! conditions and the observed order checked in the tests below.

use super::model::{Drive, Kinematics, Mechanics, Model, NQ};
use super::state::{State, StepFail, StepOut, Tol};
use super::stepper::{Capabilities, Reach, Stepper};

/// Stage coefficients a_ij (row i = stage i + 1 of Hairer's numbering; 12 stages).
const A: [[f64; 12]; 12] = [
    [0.0; 12],
    [
        0.05260015195876773,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.0197250569845379,
        0.0591751709536137,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.02958758547680685,
        0.0,
        0.08876275643042054,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.2413651341592667,
        0.0,
        -0.8845494793282861,
        0.924834003261792,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.037037037037037035,
        0.0,
        0.0,
        0.17082860872947386,
        0.12546768756682242,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.037109375,
        0.0,
        0.0,
        0.17025221101954405,
        0.06021653898045596,
        -0.017578125,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.03709200011850479,
        0.0,
        0.0,
        0.17038392571223998,
        0.10726203044637328,
        -0.015319437748624402,
        0.008273789163814023,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.6241109587160757,
        0.0,
        0.0,
        -3.3608926294469414,
        -0.868219346841726,
        27.59209969944671,
        20.154067550477894,
        -43.48988418106996,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.47766253643826434,
        0.0,
        0.0,
        -2.4881146199716677,
        -0.590290826836843,
        21.230051448181193,
        15.279233632882423,
        -33.28821096898486,
        -0.020331201708508627,
        0.0,
        0.0,
        0.0,
    ],
    [
        -0.9371424300859873,
        0.0,
        0.0,
        5.186372428844064,
        1.0914373489967295,
        -8.149787010746927,
        -18.52006565999696,
        22.739487099350505,
        2.4936055526796523,
        -3.0467644718982196,
        0.0,
        0.0,
    ],
    [
        2.273310147516538,
        0.0,
        0.0,
        -10.53449546673725,
        -2.0008720582248625,
        -17.9589318631188,
        27.94888452941996,
        -2.8589982771350235,
        -8.87285693353063,
        12.360567175794303,
        0.6433927460157636,
        0.0,
    ],
];
/// 8th-order weights.
const B: [f64; 12] = [
    0.054293734116568765,
    0.0,
    0.0,
    0.0,
    0.0,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    0.3111643669578199,
    -0.1521609496625161,
    0.20136540080403034,
    0.04471061572777259,
];
/// Weights of the 3rd-order estimate (on stages 1, 9, 12).
const BHH: [f64; 3] = [0.2440944881889764, 0.7338466882816118, 0.022058823529411766];
/// Nodes (c_12 = 1: the row sum; see the module docs).
const C: [f64; 12] = [
    0.0,
    0.05260015195876773,
    0.0789002279381516,
    0.1183503419072274,
    0.2816496580927726,
    0.3333333333333333,
    0.25,
    0.3076923076923077,
    0.6512820512820513,
    0.6,
    0.8571428571428571,
    1.0,
];
/// b − b̂ of the embedded 5th-order estimate.
const E5: [f64; 12] = [
    0.01312004499419488,
    0.0,
    0.0,
    0.0,
    0.0,
    -1.2251564463762044,
    -0.4957589496572502,
    1.6643771824549864,
    -0.35032884874997366,
    0.3341791187130175,
    0.08192320648511571,
    -0.022355307863886294,
];

/// The derivatives at one point: ẋ_s, v̇_s, ȧ, G, and (for the reduced mechanics, where x_s and
/// v_s follow from a) the positions. The quadrature integrands are accumulated by [`rates`]
/// directly into the caller's weighted sum, so the stages stay small.
#[derive(Debug, Clone, Copy, Default)]
pub struct Rates {
    /// ẋ_s (m/s).
    pub fx: f64,
    /// v̇_s (m/s²).
    pub fv: f64,
    /// ȧ (m/s).
    pub fa: f64,
    /// x_s at the point (m): the argument for the full mechanics, derived for the reduced ones.
    pub x: f64,
    /// v_s at the point (m/s), likewise.
    pub v: f64,
    /// Signed energy release rate G (J/m²; w0 out of contact).
    pub g: f64,
    /// dG/dt along the solution (J/m²/s; evaluated only at step ends, else 0).
    pub gdot: f64,
}

/// Evaluate the explicit right-hand side at (t, x, v, a): ȧ = law⁻¹(G) in closed form (or by the
/// law's inverse), adding `wq` × the quadrature integrands to `qacc` (skipped for `wq` = 0), and
/// with `ends` (a step's first or last point) also dG/dt. In
/// contact, a ≤ 0 is a collapsing contact ([`StepFail::NoRoot`]) and G ≤ 0 or an undefined rate
/// is the healing singularity ([`StepFail::Singular`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn rates(
    model: &Model,
    kin: &Kinematics,
    x: f64,
    v: f64,
    a: f64,
    contact: bool,
    wq: f64,
    qacc: &mut [f64; NQ],
    ends: bool,
) -> Result<Rates, StepFail> {
    let reduced = model.mech != Mechanics::Dynamic;
    let (x, v, adot, w, gdot) = if contact {
        if a.is_nan() || a <= 0.0 {
            return Err(StepFail::NoRoot);
        }
        if model.rate_independent {
            return Err(StepFail::Singular);
        }
        let xq = if reduced {
            model.position(kin, a, 0.0, true, x, v, 0.0).0
        } else {
            x
        };
        let g = model.signed_g(a, xq + kin.xb);
        if g.is_nan() || g <= 0.0 {
            return Err(StepFail::Singular);
        }
        let adot = model.crack_speed(g);
        if !adot.is_finite() {
            return Err(StepFail::Singular);
        }
        let (x, v) = if reduced {
            model.position(kin, a, adot, true, x, v, 0.0)
        } else {
            (x, v)
        };
        // Ġ from G = (3K/8π) u|u|/a with u = a²/R − δ: the turning points ȧ = 0 (G = w0) are
        // located on its cubic Hermite interpolant.
        let gdot = if ends {
            model.signed_g_rate(a, x + kin.xb, adot, v + kin.vb)
        } else {
            0.0
        };
        // On the law, w(ȧ) = G exactly.
        (x, v, adot, g, gdot)
    } else {
        let (x, v) = if reduced {
            model.position(kin, 0.0, 0.0, false, x, v, 0.0)
        } else {
            (x, v)
        };
        (x, v, 0.0, model.w0, 0.0)
    };
    let acc = if reduced {
        0.0
    } else {
        model.accel(kin, x, v, a, contact)
    };
    if !(acc.is_finite() && x.is_finite() && v.is_finite()) {
        return Err(StepFail::NonFinite);
    }
    if wq != 0.0 {
        let fq = model.integrands(kin, x, v, a, adot, w, contact);
        for (q, f) in qacc.iter_mut().zip(fq.iter()) {
            *q += wq * f;
        }
    }
    Ok(Rates {
        fx: v,
        fv: acc,
        fa: adot,
        x,
        v,
        g: w,
        gdot,
    })
}

/// Exponent of DP8's step-size controller: 1/8, as in Hairer's DOP853, whose combination of
/// the 5th- and 3rd-order estimates behaves as an O(h⁸) local error.
pub const ERR_EXP: f64 = 0.125;

/// Stage indices in increasing order of their nodes C.
const BY_NODE: [usize; 12] = [0, 1, 2, 3, 6, 4, 7, 5, 9, 8, 10, 11];

/// Where within the step (as a fraction of h) the contact line turns (ȧ = 0, i.e. G = w0): the
/// first sign change of G − w0 along the stages in node order, placed by linear interpolation of
/// G (smooth in time, unlike ȧ ∝ |G − w0|^(1/n)). `None` without a sign change.
fn turning_point(k: &[Rates; 12], w0: f64) -> Option<f64> {
    for pair in BY_NODE.windows(2) {
        let (i, j) = (pair[0], pair[1]);
        let (si, sj) = (k[i].g - w0, k[j].g - w0);
        if (si > 0.0) != (sj > 0.0) {
            // Opposite signs: si − sj ≠ 0.
            return Some(C[i] + (C[j] - C[i]) * (si / (si - sj)).clamp(0.0, 1.0));
        }
    }
    None
}

/// Cubic Hermite interpolant of G − w0 over a step, in s = (t − t0)/h.
struct GCubic {
    c: [f64; 4],
}

impl GCubic {
    /// From the values g0, g1 and the scaled slopes d0 = h Ġ0, d1 = h Ġ1 at s = 0 and 1.
    fn new(g0: f64, d0: f64, g1: f64, d1: f64) -> Self {
        let dg = g1 - g0;
        GCubic {
            c: [g0, d0, 3.0 * dg - 2.0 * d0 - d1, -2.0 * dg + d0 + d1],
        }
    }

    fn at(&self, s: f64) -> f64 {
        let c = &self.c;
        c[0] + s * (c[1] + s * (c[2] + s * c[3]))
    }

    /// The first zero crossing in (lo, hi], scanned on `n` intervals and refined by bisection.
    fn root(&self, lo: f64, hi: f64, n: usize) -> Option<f64> {
        let mut a = lo;
        let mut fa = self.at(a);
        for i in 1..=n {
            let b = lo + (hi - lo) * i as f64 / n as f64;
            let fb = self.at(b);
            if (fa > 0.0) != (fb > 0.0) {
                // Bisection with selects rather than branches: which half holds the root is a
                // coin toss the branch predictor loses half the time (measured on the peer's
                // scene: the cubic's roots took 5 % of the integration; this form takes 1.7 %
                // off the whole, the same roots bit for bit).
                let (mut l, mut r, positive) = (a, b, fa > 0.0);
                for _ in 0..32 {
                    let m = 0.5 * (l + r);
                    let same = (self.at(m) > 0.0) == positive;
                    l = if same { m } else { l };
                    r = if same { r } else { m };
                }
                return Some(0.5 * (l + r));
            }
            a = b;
            fa = fb;
        }
        None
    }
}

/// The rates at a state (the first stage of a step) and its quadrature integrands.
pub fn rates_at(model: &Model, drive: &Drive, y: &State) -> Result<(Rates, [f64; NQ]), StepFail> {
    let mut fq = [0.0; NQ];
    let kin = drive.at(model, y.t);
    let r = rates(model, &kin, y.x, y.v, y.a, y.contact, 1.0, &mut fq, true)?;
    Ok((r, fq))
}

/// One DOP853 step of size h from y. `k1`, `fq1` are the rates and quadrature integrands at y
/// (from the previous step's last evaluation, or [`rates_at`]). The step goes to `out` and the
/// rates and integrands at its end to `k_end`, `fq_end` (written in place: returned, the three
/// were 440 bytes to move through every attempt); on an error their contents are unspecified.
#[allow(clippy::too_many_arguments)]
pub fn step(
    model: &Model,
    drive: &Drive,
    y: &State,
    k1: &Rates,
    fq1: &[f64; NQ],
    h: f64,
    tol: Tol,
    out: &mut StepOut,
    k_end: &mut Rates,
    fq_end: &mut [f64; NQ],
) -> Result<(), StepFail> {
    let mut k = [*k1; 12];
    let mut evals = 0u64;
    let mut qacc: [f64; NQ] = std::array::from_fn(|i| B[0] * fq1[i]);
    // One sin_cos per step: the stages advance the base phase from the step's start.
    let phase0 = drive.phase(model, y.t);
    for i in 1..12 {
        let (mut x, mut v, mut a) = (0.0, 0.0, 0.0);
        for (kj, &c) in k.iter().zip(&A[i]).take(i) {
            x += c * kj.fx;
            v += c * kj.fv;
            a += c * kj.fa;
        }
        let a_i = if y.contact { y.a + h * a } else { 0.0 };
        evals += 1;
        let kin = drive.at_advanced(model, y.t + C[i] * h, phase0, C[i] * h);
        k[i] = rates(
            model,
            &kin,
            y.x + h * x,
            y.v + h * v,
            a_i,
            y.contact,
            B[i],
            &mut qacc,
            false,
        )?;
    }
    // The 8th-order increments and the two error estimates, over (x, v, a).
    let mut inc = [0.0f64; 3];
    let mut e5 = [0.0f64; 3];
    for (j, kj) in k.iter().enumerate() {
        let f = [kj.fx, kj.fv, kj.fa];
        for c in 0..3 {
            inc[c] += B[j] * f[c];
            e5[c] += E5[j] * f[c];
        }
    }
    let q: [f64; NQ] = std::array::from_fn(|i| y.q[i] + h * qacc[i]);
    let f3 = |kj: &Rates| [kj.fx, kj.fv, kj.fa];
    let (f1, f9, f12) = (f3(&k[0]), f3(&k[8]), f3(&k[11]));
    let e3: [f64; 3] =
        std::array::from_fn(|c| inc[c] - BHH[0] * f1[c] - BHH[1] * f9[c] - BHH[2] * f12[c]);
    let (x1, v1) = (y.x + h * inc[0], y.v + h * inc[1]);
    let a1 = if y.contact { y.a + h * inc[2] } else { 0.0 };
    let err = error_norm(model, tol, y, [x1, v1, a1], &e5, &e3, h);
    if !err.is_finite() || q.iter().any(|v| !v.is_finite()) {
        return Err(StepFail::NonFinite);
    }
    // First same as last: the rates at the end state.
    evals += 1;
    *fq_end = [0.0; NQ];
    let kin = drive.at_advanced(model, y.t + h, phase0, h);
    *k_end = rates(model, &kin, x1, v1, a1, y.contact, 1.0, fq_end, true)?;
    let (kink, kink_ahead) = turning_points(model, y, h, k1, k_end, &k);
    *out = StepOut {
        y: State {
            t: y.t + h,
            x: k_end.x,
            v: k_end.v,
            acc: k_end.fv,
            a: a1,
            adot: k_end.fa,
            contact: y.contact,
            q,
        },
        err,
        evals,
        err_exp: ERR_EXP,
        kink,
        kink_ahead,
    };
    Ok(())
}

/// The step's error: the implicit stepper's per-component scales, with Hairer's combination
/// err = h E5² / sqrt(n (E5² + 0.01 E3²)) of the weighted sums of squares over (x, v, a). The
/// contact radius must in addition pass its own 5th-order estimate: the Gent–Schultz rate is not
/// smooth where ȧ changes sign (a − a_k ∝ |t − t_k|^(1 + 1/n)) and varies steeply in deep
/// healing, and there the combined estimate alone was measured to understate the local error in
/// a by up to 70× (1 s at 400 Hz, 5 µm: the global error then stalls near 1e-5 instead of
/// following rtol). `end` is (x, v, a) at the step's end.
#[inline(always)]
fn error_norm(
    model: &Model,
    tol: Tol,
    y: &State,
    end: [f64; 3],
    e5: &[f64; 3],
    e3: &[f64; 3],
    h: f64,
) -> f64 {
    let [x1, v1, a1] = end;
    let (mut s5, mut s3, mut n) = (0.0, 0.0, 0usize);
    let sa = tol.atol * model.a_jump + tol.rtol * y.a.abs().max(a1.abs());
    if model.mech == Mechanics::Dynamic {
        let sx = tol.atol * model.len_scale + tol.rtol * y.x.abs().max(x1.abs());
        let sv = tol.atol * model.vel_scale + tol.rtol * y.v.abs().max(v1.abs());
        s5 += (e5[0] / sx).powi(2) + (e5[1] / sv).powi(2);
        s3 += (e3[0] / sx).powi(2) + (e3[1] / sv).powi(2);
        n += 2;
    }
    if y.contact {
        s5 += (e5[2] / sa).powi(2);
        s3 += (e3[2] / sa).powi(2);
        n += 1;
    }
    if n > 0 {
        let mut deno = s5 + 0.01 * s3;
        if deno <= 0.0 {
            deno = 1.0;
        }
        let combined = h.abs() * s5 * (1.0 / (deno * n as f64)).sqrt();
        let ea = if y.contact {
            h.abs() * (e5[2] / sa).abs()
        } else {
            0.0
        };
        combined.max(ea)
    } else {
        0.0
    }
}

/// Turning points of the contact line (G = w0) inside the step (as a fraction of h) and just
/// beyond it (as a time), on the cubic Hermite interpolant of G (both ends exact to the step's
/// order); a turning point that the end values miss (G touching w0 and returning) is found from
/// the stages `k`.
#[inline(always)]
fn turning_points(
    model: &Model,
    y: &State,
    h: f64,
    k1: &Rates,
    k_end: &Rates,
    k: &[Rates; 12],
) -> (Option<f64>, Option<f64>) {
    if !y.contact || model.rate_independent {
        return (None, None);
    }
    let g = GCubic::new(
        k1.g - model.w0,
        h * k1.gdot,
        k_end.g - model.w0,
        h * k_end.gdot,
    );
    let kink = if (k1.g > model.w0) != (k_end.g > model.w0) {
        g.root(0.0, 1.0, 1)
    } else {
        turning_point(k, model.w0)
    };
    (kink, g.root(1.0, 2.5, 3).map(|s| y.t + s * h))
}

/// djkr's explicit DOP853 ([`step`]) as a [`Stepper`], with its first-same-as-last evaluation carried from one
/// step to the next.
#[derive(Debug, Default, Clone)]
pub struct Dp8 {
    /// Two slots for the rates at a step's ends and the states they belong to: a step reads its
    /// start from one and writes its end into the other, so they are never moved.
    fsal: [Fsal; 2],
    /// The slot holding the rates at the current state, if any.
    cur: Option<usize>,
    /// Refuse steps in deep healing ([`StepFail::Stiff`]) for a rescue method to take.
    stiffness_switch: bool,
}

/// |∂ȧ/∂a| h beyond which DP8 hands a healing step to the implicit method. DOP853's stability
/// interval on the negative real axis reaches about −6; at the switch the explicit steps are
/// stability-limited, not accuracy-limited, and in deep healing (G ≈ 1e-6 w0, ∂ȧ/∂a ≈ −1e13/s)
/// they would fall below what the time resolves late in a long run (h < 8 ε t).
pub const DP8_STIFFNESS_LIMIT: f64 = 3.0;

/// The rates and quadrature integrands at the end of DP8's last step, with what identifies the
/// state they belong to (kept small: the cache is written on every step).
#[derive(Debug, Clone, Default)]
struct Fsal {
    t: f64,
    x: f64,
    v: f64,
    a: f64,
    contact: bool,
    rates: Rates,
    fq: [f64; NQ],
}

impl Fsal {
    /// Label the rates held as those at `y`.
    fn label(&mut self, y: &State) {
        self.t = y.t;
        self.x = y.x;
        self.v = y.v;
        self.a = y.a;
        self.contact = y.contact;
    }

    /// True for the very state the rates belong to (an identity test, hence bitwise; the time
    /// to a few ulp, as a step's end time is recomputed).
    fn belongs_to(&self, y: &State) -> bool {
        let same = |p: f64, q: f64| p.to_bits() == q.to_bits();
        (self.t - y.t).abs() <= 8.0 * f64::EPSILON * y.t.abs()
            && same(self.x, y.x)
            && same(self.v, y.v)
            && same(self.a, y.a)
            && self.contact == y.contact
    }
}

impl Dp8 {
    /// DP8 that refuses deep-healing steps (for [`super::rescue::Rescued`]): `attempt` fails with
    /// [`StepFail::Stiff`] where |∂ȧ/∂a| h > [`DP8_STIFFNESS_LIMIT`] at the step's start.
    pub fn with_stiffness_switch() -> Self {
        Self {
            stiffness_switch: true,
            ..Self::default()
        }
    }
}

impl Stepper for Dp8 {
    fn fresh(&self) -> Box<dyn Stepper> {
        Box::new(Dp8 {
            stiffness_switch: self.stiffness_switch,
            ..Dp8::default()
        })
    }
    fn name(&self) -> &'static str {
        "explicit DP8: Dormand-Prince 8(5,3), djkr's stepper"
    }
    fn short_name(&self) -> &'static str {
        "dp8"
    }
    /// An explicit method (no algebraic contact radius) whose accuracy needs steps that end on
    /// the turning points of the contact line, whose long steps are halved for interpolated
    /// samples, and whose controller overshoots the same stretch of every period unless the
    /// last period guides it.
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            algebraic_radius: false,
            turning_points: true,
            period_memory: true,
            reach: Reach::HalfForSamples,
        }
    }
    fn attempt(
        &mut self,
        model: &Model,
        drive: &Drive,
        y: &State,
        h: f64,
        tol: Tol,
        evals: &mut u64,
        out: &mut StepOut,
    ) -> Result<(), StepFail> {
        let mut extra = 0;
        let cur = match self.cur {
            Some(c) if self.fsal[c].belongs_to(y) => c,
            _ => {
                extra = 1;
                match rates_at(model, drive, y) {
                    Ok((rates, fq)) => {
                        let f = &mut self.fsal[0];
                        (f.rates, f.fq) = (rates, fq);
                        f.label(y);
                        self.cur = Some(0);
                        0
                    }
                    Err(e) => {
                        self.cur = None;
                        *evals += extra;
                        return Err(e);
                    }
                }
            }
        };
        // The step's start from slot `cur`, its end into the other.
        let (lo, hi) = self.fsal.split_at_mut(1);
        let (start, end) = if cur == 0 {
            (&lo[0], &mut hi[0])
        } else {
            (&hi[0], &mut lo[0])
        };
        let result = if self.stiffness_switch
            && y.contact
            && model.healing_stiffness(y.a, start.rates.g, start.rates.fa) * h > DP8_STIFFNESS_LIMIT
        {
            Err(StepFail::Stiff)
        } else {
            step(
                model,
                drive,
                y,
                &start.rates,
                &start.fq,
                h,
                tol,
                out,
                &mut end.rates,
                &mut end.fq,
            )
        };
        match result {
            Ok(()) => {
                out.evals += extra;
                end.label(&out.y);
                self.cur = Some(1 - cur);
                Ok(())
            }
            Err(e) => {
                // A failed attempt is retried from the same state with a shorter step (the
                // rates at y stay in their slot).
                *evals += extra;
                Err(e)
            }
        }
    }
    fn reset(&mut self) {
        self.cur = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Row sums equal the nodes (the defect of the `ode_solvers` tableau: c₁₂), the 8th-order
    /// weights integrate t^k exactly for k ≤ 7, the embedded 5th-order weights b − E5 for k ≤ 4,
    /// the 3rd-order weights (on stages 1, 9, 12) for k ≤ 2, and the tree conditions
    /// Σ bᵢ aᵢⱼ cⱼ^k = 1/((k+1)(k+2)) hold for k ≤ 6.
    #[test]
    fn order_conditions() {
        for i in 0..12 {
            let s: f64 = A[i].iter().sum();
            assert!((s - C[i]).abs() < 1e-13, "row {i}: {s} vs {}", C[i]);
        }
        let quad = |w: &[f64; 12], k: i32| (0..12).map(|i| w[i] * C[i].powi(k)).sum::<f64>();
        let bhat: [f64; 12] = std::array::from_fn(|i| B[i] - E5[i]);
        for k in 0..8 {
            let want = 1.0 / (k + 1) as f64;
            assert!((quad(&B, k) - want).abs() < 1e-13, "b, k = {k}");
            if k <= 4 {
                assert!((quad(&bhat, k) - want).abs() < 1e-12, "b̂, k = {k}");
            }
        }
        let mut b3 = [0.0; 12];
        (b3[0], b3[8], b3[11]) = (BHH[0], BHH[1], BHH[2]);
        for k in 0..3 {
            assert!(
                (quad(&b3, k) - 1.0 / (k + 1) as f64).abs() < 1e-13,
                "b3, k = {k}"
            );
        }
        for k in 0..7 {
            let s: f64 = (0..12)
                .map(|i| B[i] * (0..12).map(|j| A[i][j] * C[j].powi(k)).sum::<f64>())
                .sum();
            let want = 1.0 / ((k + 1) * (k + 2)) as f64;
            assert!((s - want).abs() < 1e-12, "tree k = {k}: {s} vs {want}");
        }
        let by_node = BY_NODE.map(|i| C[i]);
        assert!(by_node.windows(2).all(|w| w[0] <= w[1]), "{by_node:?}");
        let mut seen = BY_NODE;
        seen.sort_unstable();
        assert_eq!(seen, std::array::from_fn(|i| i));
    }

    /// The Hermite cubic of G − w0 reproduces a cubic exactly, so its root is found to the
    /// bisection's resolution, inside the step and beyond it.
    #[test]
    fn turning_point_on_hermite_cubic() {
        // g(s) = (s − 0.3)(s − 1.7)(s + 2): roots 0.3 (inside) and 1.7 (ahead).
        let g = |s: f64| (s - 0.3) * (s - 1.7) * (s + 2.0);
        let dg = |s: f64| (s - 1.7) * (s + 2.0) + (s - 0.3) * (s + 2.0) + (s - 0.3) * (s - 1.7);
        let c = GCubic::new(g(0.0), dg(0.0), g(1.0), dg(1.0));
        let r = c.root(0.0, 1.0, 1).unwrap();
        assert!((r - 0.3).abs() < 1e-9, "{r}");
        let r = c.root(1.0, 2.5, 3).unwrap();
        assert!((r - 1.7).abs() < 1e-9, "{r}");
        assert!(c.root(0.31, 1.0, 4).is_none());
    }
}
