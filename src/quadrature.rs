//! Quadrature for integrands with algebraic endpoint singularities.
//!
//! The imposed-area cycle (Sec. 2.1) is split at its kinks, so every piece has its singular
//! behaviour at the ends only: |cos θ|^n from the Gent–Schultz law where ȧ = 0 (n from 0.05 to 1.5,
//! and the transition 1 + C|ȧ|^n sits at distances as small as 1e-25 from the end for small n),
//! and √a where the contact is lost. The default rule is tanh-sinh (double exponential, Takahasi &
//! Mori 1974): the substitution x = ½(1 + tanh(π/2 sinh t)) crowds the nodes doubly exponentially
//! towards both ends, which turns any integrable algebraic endpoint singularity into a function
//! of t that decays doubly exponentially; the trapezoidal rule in t then converges like
//! exp(−c N / ln N) whatever the exponent.
//!
//! Why hand-written rather than a crate (e.g. `quadrature`): the hot path (one imposed-area cycle,
//! called ~10⁵ times for a pull-off table) must not allocate or recompute hyperbolic functions,
//! so the nodes and weights are precomputed once (per size, [`QuadratureRule::tanh_sinh`];
//! the default in a [`std::sync::OnceLock`]); and the integrand must receive each abscissa also as
//! its *distance from either end*, computed without cancellation (1 − x for x → 1 is exact here,
//! e^{−2u}/(1 + e^{−2u})), so that cos θ near π/2 or a(θ) near a contact-loss point keep full
//! relative accuracy. The `quadrature` crate neither precomputes its nodes nor exposes those
//! distances.
//!
//! [`QuadratureRule::graded_gauss_legendre`] is an independent reference rule (composite
//! Gauss–Legendre on a mesh graded geometrically towards both ends) for convergence studies.

use std::f64::consts::PI;
use std::sync::OnceLock;

/// One node of a rule on the unit interval [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Node {
    /// Distance from the left end, s ∈ (0, 1).
    pub from_left: f64,
    /// Distance from the right end, 1 − s, computed without cancellation.
    pub from_right: f64,
    /// Weight (the weights of a rule sum to 1 on [0, 1]).
    pub weight: f64,
}

/// A fixed quadrature rule on [0, 1], mapped affinely to any [a, b].
#[derive(Debug, Clone, PartialEq)]
pub struct QuadratureRule {
    nodes: Vec<Node>,
}

/// Number of nodes of the default rule. On the imposed-area cycle (two law evaluations per node,
/// so 162 per cycle) its worst relative error in F_m over n = 0.05…1.5, peeling speeds a_A ω/v0
/// from 3e-3 to 2e5, truncated and untruncated cycles, was 5e-12 against the graded
/// Gauss–Legendre reference (`study_worst_case` in `tests/imposed_area.rs`); 61 nodes gave 2e-10,
/// 41 nodes 2e-8.
pub const DEFAULT_NODES: usize = 81;

impl QuadratureRule {
    /// The default tanh-sinh rule with [`DEFAULT_NODES`] nodes, built once per process.
    pub fn default_rule() -> &'static QuadratureRule {
        static RULE: OnceLock<QuadratureRule> = OnceLock::new();
        RULE.get_or_init(|| QuadratureRule::tanh_sinh(DEFAULT_NODES))
    }

    /// Tanh-sinh rule with `n` nodes (n is rounded up to odd, minimum 3).
    ///
    /// Nodes t_k = k h, |k| ≤ N, n = 2N + 1. The range t_max = N h balances the discretisation
    /// error exp(−π²/h) (strip of analyticity of half-width π/2) against the truncation error
    /// exp(−(π/2) e^{t_max}) of a bounded integrand: t_max e^{t_max} = 2πN, solved by Newton.
    /// An unbounded end x^{−β} has truncation error ~exp(−(1 − β)(π/2) e^{t_max}): fine for
    /// β = ½ (81 nodes: 2e-16 on ∫₀¹ x^{−½}) but not near 1 (β = 0.9: 4e-5); use
    /// [`QuadratureRule::tanh_sinh_with`] with a larger t_max there. Integrands must use the
    /// distances they are given, not x − a, near a singular end.
    pub fn tanh_sinh(n: usize) -> Self {
        let half = (n.max(3) - 1).div_ceil(2);
        let target = 2.0 * PI * half as f64;
        // Solve t e^t = target for t > 0.
        let mut t = target.ln().max(1.0);
        for _ in 0..50 {
            let g = t * t.exp() - target;
            let dg = (t + 1.0) * t.exp();
            let step = g / dg;
            t -= step;
            if step.abs() < 1e-15 * t {
                break;
            }
        }
        Self::tanh_sinh_with(half, t / half as f64)
    }

    /// Tanh-sinh rule with nodes t_k = k h, |k| ≤ `half`, step `h` in t (for studies).
    pub fn tanh_sinh_with(half: usize, h: f64) -> Self {
        let mut nodes = Vec::with_capacity(2 * half + 1);
        for k in -(half as i64)..=(half as i64) {
            let t = k as f64 * h;
            let u = 0.5 * PI * t.sinh();
            // s = 1/(1 + e^{-2u}), 1 - s = 1/(1 + e^{2u}), both without cancellation.
            let e = (-2.0 * u.abs()).exp();
            let small = e / (1.0 + e);
            let big = 1.0 / (1.0 + e);
            let (s, r) = if u >= 0.0 { (big, small) } else { (small, big) };
            let weight = h * PI * t.cosh() * s * r;
            if weight > 0.0 && s > 0.0 && r > 0.0 {
                nodes.push(Node {
                    from_left: s,
                    from_right: r,
                    weight,
                });
            }
        }
        Self { nodes }
    }

    /// Reference rule: composite `p`-point Gauss–Legendre on a mesh graded geometrically towards
    /// both ends: [0, ½] is cut at ½σ^j, j = 1..levels (and mirrored), so the smallest element has
    /// size ½σ^levels. Converges for any integrable algebraic endpoint singularity as the levels
    /// grow (error ≈ σ^{levels(1+α)} from the last element), independently of tanh-sinh.
    pub fn graded_gauss_legendre(p: usize, levels: usize, sigma: f64) -> Self {
        let (x, w) = gauss_legendre(p.max(1));
        // Element boundaries on [0, 1/2] as distances from 0: 0, ½σ^L, …, ½σ, ½.
        let mut cuts = vec![0.0];
        for j in (1..=levels).rev() {
            cuts.push(0.5 * sigma.powi(j as i32));
        }
        cuts.push(0.5);
        let mut nodes = Vec::with_capacity(2 * p * (cuts.len() - 1));
        for win in cuts.windows(2) {
            let (lo, hi) = (win[0], win[1]);
            let half = 0.5 * (hi - lo);
            for (xi, wi) in x.iter().zip(&w) {
                let d = lo + half * (1.0 + xi);
                let weight = half * wi;
                nodes.push(Node {
                    from_left: d,
                    from_right: 1.0 - d,
                    weight,
                });
                nodes.push(Node {
                    from_left: 1.0 - d,
                    from_right: d,
                    weight,
                });
            }
        }
        Self { nodes }
    }

    /// The nodes on [0, 1].
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Number of nodes (integrand evaluations per interval).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True for a rule without nodes (never built by the constructors here).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// ∫_a^b f. The integrand receives (x, x − a, b − x), the two distances computed without
    /// cancellation.
    #[inline]
    pub fn integrate<F: FnMut(f64, f64, f64) -> f64>(&self, a: f64, b: f64, mut f: F) -> f64 {
        let l = b - a;
        let mut sum = 0.0;
        for nd in &self.nodes {
            let dl = l * nd.from_left;
            let dr = l * nd.from_right;
            let x = if dl <= dr { a + dl } else { b - dr };
            sum += nd.weight * f(x, dl, dr);
        }
        sum * l
    }

    /// ∫_a^b of a vector of `N` integrands evaluated together (shared work per node).
    #[inline]
    pub fn integrate_n<const N: usize, F: FnMut(f64, f64, f64) -> [f64; N]>(
        &self,
        a: f64,
        b: f64,
        mut f: F,
    ) -> [f64; N] {
        let l = b - a;
        let mut sum = [0.0; N];
        for nd in &self.nodes {
            let dl = l * nd.from_left;
            let dr = l * nd.from_right;
            let x = if dl <= dr { a + dl } else { b - dr };
            let v = f(x, dl, dr);
            for (s, vi) in sum.iter_mut().zip(v) {
                *s += nd.weight * vi;
            }
        }
        sum.map(|s| s * l)
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on P_p from Chebyshev guesses).
pub fn gauss_legendre(p: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; p];
    let mut w = vec![0.0; p];
    let pf = p as f64;
    for i in 0..p.div_ceil(2) {
        let mut z = (PI * (i as f64 + 0.75) / (pf + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // Legendre recurrence.
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=p {
                let kf = k as f64;
                let p2 = ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
            }
            let pp = if p == 1 { 1.0 } else { p1 };
            let pm = if p == 1 { 0.0 } else { p0 };
            let val = if p == 1 { z } else { pp };
            dp = if p == 1 {
                1.0
            } else {
                pf * (z * pp - pm) / (z * z - 1.0)
            };
            let dz = val / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        x[i] = -z;
        x[p - 1 - i] = z;
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        w[i] = wi;
        w[p - 1 - i] = wi;
    }
    (x, w)
}

/// Adaptive tanh-sinh (double-exponential) quadrature of `f` over [a, b], refined level by level until two
/// successive estimates agree to `rel_tol` (or 10 levels). Handles integrable end-point
/// singularities and kinks at the ends; never evaluates f at a or b. Allocation-free. For the
/// imposed-area hot path use the precomputed [`QuadratureRule`] instead (fixed nodes, endpoint
/// distances); this one is for one-off integrals whose accuracy must be reached adaptively.
pub fn integrate_adaptive<F: FnMut(f64) -> f64>(mut f: F, a: f64, b: f64, rel_tol: f64) -> f64 {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    if h == 0.0 {
        return 0.0;
    }
    // At |t| = 4.5, π/2 sinh t ≈ 71 and the distance to the end is ~1e−61 (b − a): enough for
    // an x^(−1/2) end singularity, whose tail beyond the last node is ~√distance. Nodes that round
    // onto an end are skipped (the integrand may be infinite there).
    let t_max = 4.5_f64;
    // Contribution of the node pair ±t (or the single node t = 0).
    let mut pair = |t: f64| -> f64 {
        let u = std::f64::consts::FRAC_PI_2 * t.sinh();
        let cu = u.cosh();
        let weight = std::f64::consts::FRAC_PI_2 * t.cosh() / (cu * cu);
        // Distance of the node from the nearer end, without cancellation: h (1 − tanh|u|).
        let dist = h * 2.0 / (1.0 + (2.0 * u.abs()).exp());
        if t == 0.0 {
            weight * f(c)
        } else {
            let (xl, xr) = (a + dist, b - dist);
            let left = if xl > a { f(xl) } else { 0.0 };
            let right = if xr < b { f(xr) } else { 0.0 };
            weight * (left + right)
        }
    };
    let mut step = 0.5_f64;
    let mut sum = pair(0.0);
    let mut k = 1;
    while (k as f64) * step <= t_max {
        sum += pair(k as f64 * step);
        k += 1;
    }
    let mut estimate = h * step * sum;
    for level in 1..=10 {
        step *= 0.5;
        // New nodes: odd multiples of the halved step.
        let mut k = 1;
        while (k as f64) * step <= t_max {
            sum += pair(k as f64 * step);
            k += 2;
        }
        let next = h * step * sum;
        let converged = (next - estimate).abs() <= rel_tol * next.abs();
        estimate = next;
        if converged && level >= 3 {
            break;
        }
    }
    estimate
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for p in 1..12 {
            let (x, w) = gauss_legendre(p);
            for deg in 0..(2 * p) {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
                let exact = if deg % 2 == 1 {
                    0.0
                } else {
                    2.0 / (deg as f64 + 1.0)
                };
                assert!((q - exact).abs() < 1e-13, "p {p} deg {deg}: {q} vs {exact}");
            }
        }
    }

    #[test]
    fn weights_sum_to_one() {
        for rule in [
            QuadratureRule::tanh_sinh(41),
            QuadratureRule::tanh_sinh(DEFAULT_NODES),
            QuadratureRule::graded_gauss_legendre(8, 20, 0.2),
        ] {
            let s: f64 = rule.nodes().iter().map(|n| n.weight).sum();
            assert!((s - 1.0).abs() < 1e-14, "{s}");
            for n in rule.nodes() {
                assert!(n.from_left > 0.0 && n.from_right > 0.0);
                assert!((n.from_left + n.from_right - 1.0).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn tanh_sinh_on_algebraic_endpoint_singularities() {
        // ∫_0^1 x^α (1 − x)^β dx = B(α+1, β+1); here with β = 0 and β = α: closed forms.
        let rule = QuadratureRule::default_rule();
        for &alpha in &[0.05, 0.1, 0.2655, 0.5, 0.75, 1.5] {
            let q = rule.integrate(0.0, 1.0, |_, dl, _| dl.powf(alpha));
            let exact = 1.0 / (alpha + 1.0);
            assert!(
                (q / exact - 1.0).abs() < 1e-12,
                "alpha {alpha}: {q} vs {exact}"
            );
            // Symmetric: sqrt-type at the other end, using the distance from the right.
            let q = rule.integrate(0.0, 2.0, |_, dl, dr| dl.powf(alpha) * dr.sqrt());
            // ∫_0^2 x^α (2−x)^½ = 2^{α+3/2} B(α+1, 3/2)
            let b = beta(alpha + 1.0, 1.5);
            let exact = 2f64.powf(alpha + 1.5) * b;
            assert!(
                (q / exact - 1.0).abs() < 1e-11,
                "alpha {alpha}: {q} vs {exact}"
            );
        }
    }

    #[test]
    fn graded_reference_converges_on_singular_integrand() {
        let rule = QuadratureRule::graded_gauss_legendre(12, 60, 0.5);
        let q = rule.integrate(0.0, 1.0, |_, dl, _| dl.powf(0.05));
        assert!((q * 1.05 - 1.0).abs() < 1e-13, "{q}");
    }

    /// Beta function by the reference rule's own closed form check: B(x, y) = Γ(x)Γ(y)/Γ(x+y)
    /// with a Lanczos Γ.
    fn beta(x: f64, y: f64) -> f64 {
        (ln_gamma(x) + ln_gamma(y) - ln_gamma(x + y)).exp()
    }

    fn ln_gamma(x: f64) -> f64 {
        // Lanczos (g = 7, n = 9), ~1e-15 relative for x > 0.5.
        const G: [f64; 9] = [
            0.999_999_999_999_809_9,
            676.520_368_121_885_1,
            -1_259.139_216_722_402_8,
            771.323_428_777_653_1,
            -176.615_029_162_140_6,
            12.507_343_278_686_905,
            -0.138_571_095_265_720_12,
            9.984_369_578_019_572e-6,
            1.505_632_735_149_311_6e-7,
        ];
        let x = x - 1.0;
        let mut a = G[0];
        let t = x + 7.5;
        for (i, g) in G.iter().enumerate().skip(1) {
            a += g / (x + i as f64);
        }
        0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
    }
}
