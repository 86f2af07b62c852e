//! Pseudo-arclength continuation of the zero set of an underdetermined system G(u) = 0,
//! G: R^N → R^(N−1): a curve, followed by a tangent predictor and Keller's bordered corrector,
//! with step control, location of the zeros of test functions along the curve, and the edges of
//! a parameter window. Used for the periodic orbits ([`super::branch`]) and for the fold curves
//! ([`super::folds`]).
//!
//! **Tangent.** t solves [J; t_prev^T] t = e_N and is normalised (‖t‖₂ = 1): it lies in the null
//! space of the Jacobian J = ∂G/∂u and keeps the orientation of the previous tangent
//! (t·t_prev > 0), so the curve is followed through its turning points without changing
//! direction.
//!
//! **Corrector.** From u_k with tangent t_k and step h: predictor u⁰ = u_k + h t_k, then Newton on
//! G(u) = 0, t_k·(u − u_k) = h (Keller), each correction solving the bordered system
//! [J; t_kᵀ] Δ = −[G(u); t_k·(u − u_k) − h]. The first iterations reuse u_k's Jacobian (a chord
//! iteration, one period of the map each); when the corrections contract by less than half, the
//! Jacobian is recomputed at the iterate (Newton). Converged when every |Δ_i| < `tol` +
//! floor_i, the floor being the precision the integration leaves the unknown
//! ([`System::floor`]); the Jacobian and tangent are then computed at the converged point (for
//! the next predictor, the multipliers and the test functions).
//!
//! **Step control.** A step is refused and halved when the corrector fails (no convergence in
//! `max_iterations`, a first correction larger than half the step, i.e. a predictor too far
//! from the curve, a failed period of the map), or when the tangent turns by more than
//! `max_angle`. After an accepted step h grows by a factor from the number of corrector
//! iterations (2 for ≤ 2, 1.5 for 3, 1 for 4, 0.7 beyond) and is kept such that the tangent turns
//! by about half `max_angle`; h stays in [`h_min`, `h_max`]. Below `h_min` the continuation
//! stops and says why.
//!
//! **Test functions.** After each accepted step every test function is evaluated at the new
//! point; a sign change against the previous point is located by the Illinois variant of
//! regula falsi on the arclength s ∈ (0, h) of that step, each trial a corrected point on the
//! hyperplane t_k·(u − u_k) = s, to `locate_tol` in s (a zero of the test in between). The window
//! is a test function too (positive inside): the curve ends on its edge, located the same way.

use nalgebra::{DMatrix, DVector};

use super::map::MapFail;

/// A system whose zero set is followed: N unknowns, N − 1 equations.
pub trait System {
    /// An evaluation at a point (whatever the system needs to reuse).
    type Eval: Clone;
    /// Number of unknowns N.
    fn dim(&self) -> usize;
    /// Evaluate at `u`; `near` is an evaluation nearby (carries what `u` does not hold).
    fn evaluate(&self, u: &DVector<f64>, near: &Self::Eval) -> Result<Self::Eval, MapFail>;
    /// The point u of an evaluation.
    fn point<'a>(&self, e: &'a Self::Eval) -> &'a DVector<f64>;
    /// The residual G(u) (N − 1) of an evaluation.
    fn residual<'a>(&self, e: &'a Self::Eval) -> &'a DVector<f64>;
    /// The Jacobian ∂G/∂u ((N − 1) × N) at an evaluation.
    fn jacobian(&self, e: &Self::Eval) -> Result<DMatrix<f64>, MapFail>;
    /// How precisely each unknown can be known at `u` (absolute, in u's units): the floor the
    /// integration's own error puts under a converged correction. Zero by default.
    fn floor(&self, u: &DVector<f64>) -> DVector<f64> {
        DVector::zeros(u.len())
    }
}

/// Settings of the continuation (all lengths in the scaled unknowns).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Corrector tolerance on ‖Δ‖∞.
    pub tol: f64,
    /// Corrector iterations before a step is refused.
    pub max_iterations: usize,
    /// First step.
    pub h_start: f64,
    /// Smallest step.
    pub h_min: f64,
    /// Largest step.
    pub h_max: f64,
    /// Largest turn of the tangent per step (rad).
    pub max_angle: f64,
    /// Tolerance in arclength of a located test-function zero or window edge.
    pub locate_tol: f64,
    /// Most points on one curve.
    pub max_points: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            tol: 1e-9,
            max_iterations: 12,
            h_start: 1e-2,
            h_min: 1e-9,
            h_max: 0.1,
            max_angle: 0.12,
            locate_tol: 1e-10,
            max_points: 5000,
        }
    }
}

/// A point on the curve with its Jacobian and tangent.
#[derive(Debug, Clone)]
pub struct Node<E> {
    /// The evaluation at the point.
    pub eval: E,
    /// ∂G/∂u at the point.
    pub jac: DMatrix<f64>,
    /// Unit tangent, oriented along the direction of travel.
    pub tangent: DVector<f64>,
    /// Pseudo-arclength from the start of the curve.
    pub s: f64,
    /// Corrector iterations that produced it.
    pub iterations: usize,
}

/// Work done, for reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Work {
    /// Accepted steps.
    pub steps: usize,
    /// Refused steps.
    pub rejected: usize,
    /// Corrected points computed while locating test-function zeros and window edges.
    pub located: usize,
}

/// Why a corrector failed.
#[derive(Debug, Clone, PartialEq)]
pub enum CorrectFail {
    /// An evaluation of the map failed.
    Map(MapFail),
    /// The bordered system is singular.
    Singular,
    /// No convergence within the iteration limit, or the corrections grew.
    NoConvergence,
    /// The first correction was larger than half the step.
    FarPredictor,
}

/// The unit tangent in the null space of `jac`, oriented along `prev`.
pub fn tangent(jac: &DMatrix<f64>, prev: &DVector<f64>) -> Option<DVector<f64>> {
    let n = jac.ncols();
    let b = bordered(jac, prev);
    let mut rhs = DVector::zeros(n);
    rhs[n - 1] = 1.0;
    let t = b.lu().solve(&rhs)?;
    let norm = t.norm();
    (norm.is_finite() && norm > 0.0).then(|| t / norm)
}

/// [J; tᵀ].
fn bordered(jac: &DMatrix<f64>, t: &DVector<f64>) -> DMatrix<f64> {
    let n = jac.ncols();
    let mut b = DMatrix::zeros(n, n);
    b.view_mut((0, 0), (n - 1, n)).copy_from(jac);
    for j in 0..n {
        b[(n - 1, j)] = t[j];
    }
    b
}

/// The corrected point at arclength `h` from `from` along its tangent (module doc).
pub fn correct<S: System>(
    sys: &S,
    from: &Node<S::Eval>,
    h: f64,
    set: &Settings,
) -> Result<Node<S::Eval>, CorrectFail> {
    let n = sys.dim();
    let u0 = sys.point(&from.eval).clone();
    let t = &from.tangent;
    let mut u = &u0 + t * h;
    let mut jac = from.jac.clone();
    let mut fresh = false;
    let mut near = from.eval.clone();
    let mut last_norm = f64::INFINITY;
    // Corrections are measured against the tolerance plus each unknown's precision floor:
    // converged when every |Δ_i| < tol + floor_i.
    let weights = sys.floor(&u).add_scalar(set.tol);
    let wnorm = |d: &DVector<f64>| {
        d.iter()
            .zip(weights.iter())
            .fold(0.0f64, |m, (x, w)| m.max(x.abs() / w))
    };
    for it in 0..set.max_iterations {
        let e = sys.evaluate(&u, &near).map_err(CorrectFail::Map)?;
        let g = sys.residual(&e);
        let mut rhs = DVector::zeros(n);
        for i in 0..n - 1 {
            rhs[i] = -g[i];
        }
        rhs[n - 1] = -(t.dot(&(&u - &u0)) - h);
        let mut delta = bordered(&jac, t)
            .lu()
            .solve(&rhs)
            .ok_or(CorrectFail::Singular)?;
        let mut dn = wnorm(&delta);
        if it > 0 && dn > 0.5 * last_norm && !fresh {
            // Slow chord contraction: Newton from here on.
            jac = sys.jacobian(&e).map_err(CorrectFail::Map)?;
            fresh = true;
            delta = bordered(&jac, t)
                .lu()
                .solve(&rhs)
                .ok_or(CorrectFail::Singular)?;
            dn = wnorm(&delta);
        } else if it > 0 && dn > last_norm && dn >= 1.0 {
            return Err(CorrectFail::NoConvergence);
        }
        if !dn.is_finite() {
            return Err(CorrectFail::NoConvergence);
        }
        if it == 0 && h != 0.0 && delta.amax() > 0.5 * h.abs() && dn > 10.0 {
            return Err(CorrectFail::FarPredictor);
        }
        u += &delta;
        near = e;
        last_norm = dn;
        if dn < 1.0 {
            let e = sys.evaluate(&u, &near).map_err(CorrectFail::Map)?;
            let jac = sys.jacobian(&e).map_err(CorrectFail::Map)?;
            let tangent = tangent(&jac, t).ok_or(CorrectFail::Singular)?;
            return Ok(Node {
                eval: e,
                jac,
                tangent,
                s: from.s + h,
                iterations: it + 1,
            });
        }
    }
    Err(CorrectFail::NoConvergence)
}

/// Locate the zero of `test` between `from` (arclength 0, value `f0`) and the point at arclength
/// `h` (value `f1`, opposite sign) by Illinois regula falsi; the corrected point nearest the
/// zero. `work` counts the points computed.
pub fn locate<S: System>(
    sys: &S,
    from: &Node<S::Eval>,
    h: f64,
    (f0, f1): (f64, f64),
    test: &dyn Fn(&Node<S::Eval>) -> f64,
    set: &Settings,
    work: &mut Work,
) -> Result<Node<S::Eval>, CorrectFail> {
    let (mut a, mut fa, mut b, mut fb) = (0.0f64, f0, h, f1);
    let mut best: Option<(f64, Node<S::Eval>)> = None;
    for _ in 0..60 {
        let (lo, hi) = (a.min(b), a.max(b));
        let mut s = b - fb * (b - a) / (fb - fa);
        if !(s.is_finite() && s > lo && s < hi) {
            s = 0.5 * (lo + hi);
        }
        let node = correct(sys, from, s, set)?;
        work.located += 1;
        let f = test(&node);
        if !f.is_finite() {
            break;
        }
        let done = f == 0.0;
        if best.as_ref().is_none_or(|(g, _)| f.abs() < g.abs()) {
            best = Some((f, node));
        }
        if done {
            break;
        }
        if (f > 0.0) != (fb > 0.0) {
            // The zero lies between b and s.
            a = b;
            fa = fb;
        } else {
            // Between a and s: keep a, halve its value (Illinois).
            fa *= 0.5;
        }
        b = s;
        fb = f;
        if (b - a).abs() < set.locate_tol {
            break;
        }
    }
    best.map(|(_, n)| n).ok_or(CorrectFail::NoConvergence)
}

/// The point of the curve near `node` whose unknown `k` equals `target` exactly (the edge of a
/// window, located to `locate_tol` by [`trace`], made exact): a corrector on the hyperplane
/// u_k = target, the tangent oriented as `node`'s.
pub fn snap<S: System>(
    sys: &S,
    node: &Node<S::Eval>,
    k: usize,
    target: f64,
    set: &Settings,
) -> Result<Node<S::Eval>, CorrectFail> {
    let d = target - sys.point(&node.eval)[k];
    if d == 0.0 {
        return Ok(node.clone());
    }
    let mut e = DVector::zeros(sys.dim());
    e[k] = d.signum();
    let fake = Node {
        tangent: e,
        ..node.clone()
    };
    let mut n = correct(sys, &fake, d.abs(), set)?;
    n.tangent = tangent(&n.jac, &node.tangent).ok_or(CorrectFail::Singular)?;
    n.s = node.s;
    Ok(n)
}

/// The point near `node` where unknown `k` is extremal along the curve, from the vertex of the
/// parabola through u_k at arclengths −d, 0, +d from `node` (corrected points), then corrected
/// there. Where u_k is extremal its value depends on the arclength only quadratically, so a
/// zero of the tangent's k-component located with an error δs leaves an error ∝ δs² in u_k,
/// which this refinement removes; `None` when the vertex is not within ±d.
pub fn extremum<S: System>(
    sys: &S,
    node: &Node<S::Eval>,
    k: usize,
    d: f64,
    set: &Settings,
) -> Option<Node<S::Eval>> {
    let q = |n: &Node<S::Eval>| sys.point(&n.eval)[k];
    let a = correct(sys, node, -d, set).ok()?;
    let b = correct(sys, node, d, set).ok()?;
    let (qa, q0, qb) = (q(&a), q(node), q(&b));
    let curvature = qa - 2.0 * q0 + qb;
    let u = 0.5 * d * (qa - qb) / curvature;
    if !(u.is_finite() && u.abs() < d) {
        return None;
    }
    let mut c = correct(sys, node, u, set).ok()?;
    c.tangent = tangent(&c.jac, &node.tangent)?;
    c.s = node.s + u;
    Some(c)
}

/// The next step after an accepted one of length `h` that took `iterations` corrector
/// iterations and turned the tangent by `angle` (rad).
pub fn next_step(h: f64, iterations: usize, angle: f64, set: &Settings) -> f64 {
    // Chord iterations contract linearly, at a rate that grows with the step: a handful is
    // normal, many mean the Jacobian changed too much over the step.
    let by_iterations: f64 = match iterations {
        0..=3 => 2.0,
        4..=5 => 1.5,
        6..=7 => 1.0,
        _ => 0.7,
    };
    let by_angle = if angle > 0.0 {
        (0.5 * set.max_angle / angle).clamp(0.25, 2.0)
    } else {
        2.0
    };
    (h * by_iterations.min(by_angle)).clamp(set.h_min, set.h_max)
}

/// The angle (rad) between two unit vectors.
pub fn angle(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    a.dot(b).clamp(-1.0, 1.0).acos()
}

/// Why a curve ended.
#[derive(Debug, Clone, PartialEq)]
pub enum End {
    /// It reached the edge of the window (the located edge point is the last node).
    Window,
    /// The map stops being smooth: a period ahead loses or forms contact (grazing); the last
    /// node is within [`GRAZE_TOL`] in arclength of the change.
    Rough(Vec<crate::dynamics::EventKind>),
    /// The step fell below `h_min`; why the last step failed.
    Underflow(String),
    /// `max_points` reached.
    MaxPoints,
}

/// Arclength to which a change of the event sequence (grazing) is located.
pub const GRAZE_TOL: f64 = 1e-6;

/// A followed curve: its nodes (special points included, in order), which nodes are zeros of
/// which test function, and why it ended.
#[derive(Debug, Clone)]
pub struct Curve<E> {
    /// The nodes in order of arclength.
    pub nodes: Vec<Node<E>>,
    /// (test index, node index) of each located zero.
    pub specials: Vec<(usize, usize)>,
    /// (test index, arclength before, after) of sign changes that could not be located.
    pub unlocated: Vec<(usize, f64, f64)>,
    /// Why it ended.
    pub end: End,
    /// Work done.
    pub work: Work,
}

/// A test function of a node.
pub type Test<'a, E> = &'a dyn Fn(&Node<E>) -> f64;

/// Follow the curve from `start` (its tangent gives the direction) until it leaves the window
/// (`window` > 0 inside), stops being smooth, the step underflows or `max_points` are reached;
/// zeros of `tests` are located and inserted as nodes (module doc). `progress` sees every
/// accepted node.
pub fn trace<S: System>(
    sys: &S,
    start: Node<S::Eval>,
    set: &Settings,
    tests: &[Test<'_, S::Eval>],
    window: Test<'_, S::Eval>,
    progress: &mut dyn FnMut(&Node<S::Eval>),
) -> Curve<S::Eval> {
    let mut work = Work::default();
    let mut nodes = vec![start];
    let mut specials = Vec::new();
    let mut unlocated = Vec::new();
    let mut h = set.h_start;
    let end = loop {
        if nodes.len() >= set.max_points {
            break End::MaxPoints;
        }
        let Some(cur) = nodes.last().cloned() else {
            break End::MaxPoints;
        };
        let next = match correct(sys, &cur, h, set) {
            Ok(n) => n,
            Err(e) => {
                work.rejected += 1;
                if let CorrectFail::Map(MapFail::Rough(kinds)) = &e {
                    if h < GRAZE_TOL.max(set.h_min) {
                        break End::Rough(kinds.clone());
                    }
                }
                h *= 0.5;
                if h < set.h_min {
                    break End::Underflow(format!("{e:?}"));
                }
                continue;
            }
        };
        let turn = angle(&cur.tangent, &next.tangent);
        if turn > set.max_angle && h > 2.0 * set.h_min {
            work.rejected += 1;
            h *= 0.5;
            continue;
        }
        work.steps += 1;
        let mut found: Vec<(usize, Node<S::Eval>)> = Vec::new();
        for (i, test) in tests.iter().enumerate() {
            let (f0, f1) = (test(&cur), test(&next));
            if f0 * f1 < 0.0 {
                match locate(sys, &cur, h, (f0, f1), *test, set, &mut work) {
                    Ok(n) => found.push((i, n)),
                    Err(_) => unlocated.push((i, cur.s, next.s)),
                }
            }
        }
        let (w0, w1) = (window(&cur), window(&next));
        let edge = if w1 < 0.0 {
            if w0 > 0.0 {
                locate(sys, &cur, h, (w0, w1), window, set, &mut work).ok()
            } else {
                Some(cur.clone())
            }
        } else {
            None
        };
        let stop = edge.as_ref().map_or(f64::INFINITY, |e| e.s);
        found.retain(|(_, n)| n.s < stop);
        found.sort_by(|a, b| a.1.s.total_cmp(&b.1.s));
        for (i, n) in found {
            progress(&n);
            specials.push((i, nodes.len()));
            nodes.push(n);
        }
        if let Some(e) = edge {
            if e.s > nodes.last().map_or(f64::NEG_INFINITY, |n| n.s) {
                progress(&e);
                nodes.push(e);
            }
            break End::Window;
        }
        progress(&next);
        h = next_step(h, next.iterations, turn, set);
        nodes.push(next);
    };
    Curve {
        nodes,
        specials,
        unlocated,
        end,
        work,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit circle y² + x² = 1 as a "branch" in the parameter x (last unknown).
    struct Circle;

    #[derive(Clone, Debug)]
    struct Ev {
        u: DVector<f64>,
        g: DVector<f64>,
    }

    impl System for Circle {
        type Eval = Ev;
        fn dim(&self) -> usize {
            2
        }
        fn evaluate(&self, u: &DVector<f64>, _: &Ev) -> Result<Ev, MapFail> {
            Ok(Ev {
                u: u.clone(),
                g: DVector::from_element(1, u[0] * u[0] + u[1] * u[1] - 1.0),
            })
        }
        fn point<'a>(&self, e: &'a Ev) -> &'a DVector<f64> {
            &e.u
        }
        fn residual<'a>(&self, e: &'a Ev) -> &'a DVector<f64> {
            &e.g
        }
        fn jacobian(&self, e: &Ev) -> Result<DMatrix<f64>, MapFail> {
            Ok(DMatrix::from_row_slice(1, 2, &[2.0 * e.u[0], 2.0 * e.u[1]]))
        }
    }

    #[test]
    fn a_circle_is_followed_around_its_fold_to_the_window_edge() {
        let set = Settings {
            h_max: 0.2,
            h_start: 0.05,
            ..Settings::default()
        };
        let u0 = DVector::from_vec(vec![-(0.75f64.sqrt()), -0.5]);
        let e = Circle
            .evaluate(
                &u0,
                &Ev {
                    u: u0.clone(),
                    g: DVector::zeros(1),
                },
            )
            .unwrap_or_else(|_| unreachable!());
        let jac = Circle.jacobian(&e).unwrap_or_else(|_| unreachable!());
        let t = tangent(&jac, &DVector::from_vec(vec![0.0, 1.0])).unwrap_or_default();
        assert!(t[1] > 0.0);
        let start = Node {
            eval: e,
            jac,
            tangent: t,
            s: 0.0,
            iterations: 0,
        };
        let fold = |n: &Node<Ev>| n.tangent[1];
        let window = |n: &Node<Ev>| (n.eval.u[1] + 0.5).min(2.0 - n.eval.u[1]);
        let curve = trace(&Circle, start, &set, &[&fold], &window, &mut |_| {});
        assert_eq!(curve.end, End::Window);
        assert_eq!(curve.specials.len(), 1);
        let f = &curve.nodes[curve.specials[0].1].eval.u;
        // The fold of x on the circle is (y, x) = (0, 1); x is extremal there, so it is located
        // to second order in the arclength error.
        assert!((f[1] - 1.0).abs() < 1e-14 && f[0].abs() < 1e-6, "{f}");
        let last = curve
            .nodes
            .last()
            .map(|n| n.eval.u.clone())
            .unwrap_or_default();
        assert!(
            (last[1] + 0.5).abs() < 1e-9 && (last[0] - 0.75f64.sqrt()).abs() < 1e-8,
            "{last}"
        );
        // Arclength along the circle from angle −120° round to +120° is 4π/3; the
        // pseudo-arclength, a sum of steps along the tangents, falls short by O(h²κ²) per step.
        let s = curve.nodes.last().map_or(0.0, |n| n.s);
        assert!(
            (s / (4.0 * std::f64::consts::PI / 3.0) - 1.0).abs() < 2e-3,
            "{s}"
        );
        let extremum = extremum(&Circle, &curve.nodes[curve.specials[0].1], 1, 1e-2, &set);
        assert!(
            extremum.is_some_and(|n| (n.eval.u[1] - 1.0).abs() < 1e-15 && n.eval.u[0].abs() < 1e-7)
        );
    }
}
