//! Two-parameter continuation of folds: the curves in the (KEY, KEY2) plane along which the
//! branch of periodic orbits turns back, the region of bistability between them, and the cusp
//! where that region is born.
//!
//! **System.** Unknowns z = (ŷ, p̂, q̂) (the scaled state at phase 0 and the two parameters);
//! equations F(z) = P(y; p, q) − y = 0 (scaled, n) and g(z) = det(M(z) − I) = 0, the fold
//! condition: a multiplier +1. A curve in R^(n+2), followed by the same pseudo-arclength engine
//! as the branches ([`super::engine`]). With n ≤ 3 state unknowns the determinant is as well
//! conditioned as a bordered (minimally augmented) test function and needs no bordering vectors
//! to update. g comes from a Richardson-extrapolated monodromy matrix (central differences at
//! 1e-3 and 5e-4 on the frozen step sequence, error O(ε⁴)); its gradient, needed only by the
//! corrector, from central differences of g with step 1e-4.
//!
//! **Precision.** The fold multiplier is the creeping radius's, within ~1e-3 of 1 along the
//! whole branch, so g changes slowly along the branch (|∇g| ~ 1e-4 in scaled units on the
//! bundled scene) and its noise (~1e-11) leaves the state of a fold point uncertain at ~1e-7 in
//! the branch's direction; the corrector does not resolve the state below 1e-6 or the
//! parameters below 1e-7 (scaled; [`System::floor`]). Along that direction the parameters are
//! extremal at a fold, so they are not affected to first order; what remains is how g depends
//! on KEY2 itself, which near the cusp is weak: the cusp's KEY2 is known to ~1e-5 relative
//! (the bundled scene: 1.038292 µm from the fold curve at rtol 1e-10, 1.038281 µm at 1e-12,
//! 1.038285 µm from the fold separation Δf ∝ (X_b − X_c)^{3/2} of branches just above it;
//! its frequency to 1e-6).
//!
//! **Cusp.** Near a cusp the fold curve in (y, p, q) is smooth while its projection on the
//! (p, q) plane has a cusp: in the normal form ẋ = p + q x − x³ the folds are
//! (p, q) = (−2x³, 3x²), so along the curve q has an extremum where the two folds meet and
//! p only an inflection. The cusp is located as the zero of the q-component of the fold curve's
//! tangent, then refined as the vertex of a parabola through q at ±0.01 in arclength
//! ([`engine::extremum`]: q is extremal there, so the tangent's error matters only through
//! the parabola). It is called a cusp when the tangent's p-component is also small there
//! (below 5 % of its state part); a smooth turn of the fold curve in q is reported as a turn.
//!
//! **Start.** The branch is computed at KEY2 = START of `--fold-range`; each fold on it starts a
//! fold curve, followed into the window until it leaves it (either parameter's range). A curve
//! that passes through a cusp comes back as the other fold of the pair and ends near it, so
//! that fold is not followed again.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::branch::{Branch, BranchEnd, PointKind};
use super::engine::{self, Curve, End, Node, System, Test};
use super::family::Family;
use super::map::{Evaluation, MapFail, ScaledMap};
use super::ContinuationError;
use crate::dynamics::CycleRecord;

/// Precision of the state of a fold point (scaled): the fold multiplier is the creeping
/// radius's, within ~1e-3 of 1 along the whole branch, so g changes slowly with the state
/// (|∇g| ~ 1e-4 on the bundled scene) and its ~1e-10 noise leaves the state uncertain at
/// ~1e-7..1e-6 along the branch. The parameters are not: at a fold they are extremal along
/// that direction.
const STATE_FLOOR: f64 = 1e-6;

/// Precision of the parameters of a fold point (scaled).
const PARAMETER_FLOOR: f64 = 1e-7;

/// Step of the Richardson-extrapolated monodromy matrix behind g (scaled units).
const MONODROMY_STEP: f64 = 1e-3;

/// Step of the central differences of g (scaled units).
const G_STEP: f64 = 1e-4;

/// The fold system (module doc): the scaled map with two free parameters.
#[derive(Debug, Clone)]
pub struct FoldSystem {
    /// The map with parameters (KEY, KEY2).
    pub map: ScaledMap,
}

/// An evaluation of the fold system.
#[derive(Debug, Clone)]
pub struct FoldEval {
    /// The map's evaluation (residual F, the period).
    pub map: Evaluation,
    /// The monodromy matrix (scaled).
    pub mono: DMatrix<f64>,
    /// [F; g].
    pub residual: DVector<f64>,
}

impl FoldSystem {
    /// The monodromy matrix for g: Richardson's extrapolation of central differences at
    /// steps ε and ε/2 ((4 M(ε/2) − M(ε))/3, error O(ε⁴)), ε = [`MONODROMY_STEP`].
    fn monodromy(
        &self,
        y: [f64; 3],
        values: &[f64],
        steps: &[f64],
        t0: f64,
    ) -> Result<DMatrix<f64>, MapFail> {
        let m = &self.map;
        let coarse = m.monodromy_with(y, values, steps, t0, MONODROMY_STEP, true)?;
        let fine = m.monodromy_with(y, values, steps, t0, 0.5 * MONODROMY_STEP, true)?;
        Ok((fine * 4.0 - coarse) / 3.0)
    }

    fn g(&self, mono: &DMatrix<f64>) -> f64 {
        let n = mono.nrows();
        (mono - DMatrix::identity(n, n)).determinant()
    }
}

impl System for FoldSystem {
    type Eval = FoldEval;
    fn dim(&self) -> usize {
        self.map.n() + 2
    }
    fn evaluate(&self, u: &DVector<f64>, near: &FoldEval) -> Result<FoldEval, MapFail> {
        let e = self.map.evaluate(u, &near.map.y)?;
        let t0 = e.period.length;
        let mono = self.monodromy(e.y, &e.values, self.map.steps(&e), t0)?;
        let n = self.map.n();
        let mut residual = DVector::zeros(n + 1);
        residual.rows_mut(0, n).copy_from(&e.residual);
        residual[n] = self.g(&mono);
        Ok(FoldEval {
            map: e,
            mono,
            residual,
        })
    }
    fn point<'a>(&self, e: &'a FoldEval) -> &'a DVector<f64> {
        &e.map.u
    }
    fn residual<'a>(&self, e: &'a FoldEval) -> &'a DVector<f64> {
        &e.residual
    }
    fn floor(&self, u: &DVector<f64>) -> DVector<f64> {
        let n = self.map.n();
        let mut f = self.map.floor(u);
        for i in 0..n {
            f[i] += STATE_FLOOR;
        }
        f[n] += PARAMETER_FLOOR;
        f[n + 1] += PARAMETER_FLOOR;
        f
    }
    fn jacobian(&self, e: &FoldEval) -> Result<DMatrix<f64>, MapFail> {
        let n = self.map.n();
        let d = n + 2;
        let me = &e.map;
        let steps = self.map.steps(me);
        let t0 = me.period.length;
        let mut jac = DMatrix::zeros(n + 1, d);
        jac.view_mut((0, 0), (n, n))
            .copy_from(&(&e.mono - DMatrix::identity(n, n)));
        for k in 0..2 {
            let c = self.map.parameter_column(me.y, &me.values, k, steps, t0)?;
            jac.view_mut((0, n + k), (n, 1)).copy_from(&c);
        }
        for j in 0..d {
            let g = |sign: f64| -> Result<f64, MapFail> {
                let mut y = me.y;
                let mut values = me.values.clone();
                if j < n {
                    let i = self.map.idx[j];
                    y[i] += sign * G_STEP * self.map.sc[i];
                } else {
                    values[j - n] += sign * G_STEP * self.map.ps[j - n];
                }
                Ok(self.g(&self.map.monodromy_at(y, &values, steps, t0)?))
            };
            jac[(n, j)] = (g(1.0)? - g(-1.0)?) / (2.0 * G_STEP);
        }
        Ok(jac)
    }
}

/// A point of a fold curve (SI).
#[derive(Debug, Clone, PartialEq)]
pub struct FoldPoint {
    /// Pseudo-arclength along the fold curve (scaled, dimensionless).
    pub arclength: f64,
    /// (KEY, KEY2) values.
    pub values: [f64; 2],
    /// Base amplitude X_b (m) at this point.
    pub amplitude: f64,
    /// The orbit's cycle record.
    pub cycle: CycleRecord,
    /// Tangent components along (KEY, KEY2), scaled.
    pub tangent: [f64; 2],
    /// What the point is.
    pub kind: FoldPointKind,
}

impl FoldPoint {
    /// |δ1| / X_b (NaN when X_b = 0).
    pub fn delta_amp_over_xb(&self) -> f64 {
        if self.amplitude > 0.0 {
            self.cycle.delta_sin.hypot(self.cycle.delta_cos) / self.amplitude
        } else {
            f64::NAN
        }
    }
}

/// What a point of a fold curve is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FoldPointKind {
    /// An ordinary point.
    Regular,
    /// The start: a fold of the branch.
    Start,
    /// A cusp: the two folds meet (KEY2 extremal, KEY's tangent ≈ 0).
    Cusp,
    /// KEY2 extremal along the curve without a cusp (the fold curve turns in KEY2).
    Turn,
    /// The last point.
    End,
}

/// A followed fold curve.
#[derive(Debug, Clone)]
pub struct FoldCurve {
    /// Its points in order.
    pub points: Vec<FoldPoint>,
    /// Why it ended.
    pub end: BranchEnd,
    /// Work done.
    pub work: engine::Work,
}

impl FoldCurve {
    /// The cusps on the curve.
    pub fn cusps(&self) -> impl Iterator<Item = &FoldPoint> {
        self.points.iter().filter(|p| p.kind == FoldPointKind::Cusp)
    }
}

/// |t_p| below this fraction of the tangent's state part at a zero of t_q: a cusp.
const CUSP_RATIO: f64 = 0.05;

/// Follow the folds of `branch` in the second parameter of `family` (its keys: the branch's,
/// then KEY2) from `q_range.0` (where the branch was computed) towards `q_range.1`, within the
/// branch's range of KEY. One curve per fold not already reached by an earlier curve.
pub fn continue_folds(
    family: &Family,
    branch: &Branch,
    q_range: (f64, f64),
    set: &engine::Settings,
    progress: &mut dyn FnMut(f64, f64),
) -> Result<Vec<FoldCurve>, ContinuationError> {
    let (q0, q1) = q_range;
    let qw = (q1 - q0).abs();
    if !(qw.is_finite() && qw > 0.0) {
        return Err(ContinuationError::EmptyRange {
            input: "fold_range",
            start: q0,
            stop: q1,
            unit: "",
        });
    }
    let bm = &branch.map;
    let map = ScaledMap {
        family: family.clone(),
        ps: vec![bm.ps[0], qw],
        ..bm.clone()
    };
    let sys = FoldSystem { map };
    let (p0, p1) = branch.range;
    let (plo, phi, pw) = (p0.min(p1), p0.max(p1), bm.ps[0]);
    let (qlo, qhi) = (q0.min(q1), q0.max(q1));
    let n = sys.map.n();
    let mut curves: Vec<FoldCurve> = Vec::new();
    for fold in branch.of_kind(PointKind::Fold) {
        let reached = curves.iter().any(|c| {
            c.points.last().is_some_and(|e| {
                (e.values[0] - fold.value).abs() < 1e-6 * pw && (e.values[1] - q0).abs() < 1e-6 * qw
            })
        });
        if reached {
            continue;
        }
        let start = first_fold_node(&sys, fold.state, fold.value, q0, q1 - q0, set)?;
        let tq = |node: &Node<FoldEval>| node.tangent[n + 1];
        let window = |node: &Node<FoldEval>| {
            let v = &node.eval.map.values;
            ((v[0] - plo) / pw)
                .min((phi - v[0]) / pw)
                .min((v[1] - qlo) / qw)
                .min((qhi - v[1]) / qw)
        };
        let tests: [Test<'_, FoldEval>; 1] = [&tq];
        let mut watch = |node: &Node<FoldEval>| {
            let v = &node.eval.map.values;
            progress(v[0], v[1]);
        };
        let mut curve = engine::trace(&sys, start, set, &tests, &window, &mut watch);
        if curve.end == End::Window {
            // Put the last point exactly on the edge it reached.
            if let Some(last) = curve.nodes.last_mut() {
                let v = &last.eval.map.values;
                let edges = [
                    (n, plo, v[0], pw),
                    (n, phi, v[0], pw),
                    (n + 1, qlo, v[1], qw),
                    (n + 1, qhi, v[1], qw),
                ];
                if let Some(&(k, bound, _, w)) = edges.iter().min_by(|a, b| {
                    ((a.2 - a.1) / a.3)
                        .abs()
                        .total_cmp(&((b.2 - b.1) / b.3).abs())
                }) {
                    if let Ok(snapped) = engine::snap(&sys, last, k, bound / w, set) {
                        *last = snapped;
                    }
                }
            }
        }
        // A cusp: KEY2's value is extremal there; refine it by a parabola (engine::extremum).
        for &(_, i) in &curve.specials {
            if let Some(better) = engine::extremum(&sys, &curve.nodes[i], n + 1, 1e-2, set) {
                curve.nodes[i] = better;
            }
        }
        curves.push(to_curve(&sys, curve));
    }
    Ok(curves)
}

/// The first node of a fold curve: the branch's fold (state `y`, KEY = `p`) at KEY2 = `q`,
/// corrected on the fold system at fixed KEY2, its tangent towards KEY2's `direction`.
fn first_fold_node(
    sys: &FoldSystem,
    y: [f64; 3],
    p: f64,
    q: f64,
    direction: f64,
    set: &engine::Settings,
) -> Result<Node<FoldEval>, ContinuationError> {
    let fail = |e: String| ContinuationError::Start(format!("fold curve from {p}: {e}"));
    let u = sys.map.scale(&y, &[p, q]);
    let e0 = sys.map.evaluate(&u, &y).map_err(|e| fail(e.to_string()))?;
    let t0 = e0.period.length;
    let mono = sys
        .monodromy(e0.y, &e0.values, sys.map.steps(&e0), t0)
        .map_err(|e| fail(e.to_string()))?;
    let n = sys.map.n();
    let mut residual = DVector::zeros(n + 1);
    residual.rows_mut(0, n).copy_from(&e0.residual);
    residual[n] = sys.g(&mono);
    let e = FoldEval {
        map: e0,
        mono,
        residual,
    };
    let jac = sys.jacobian(&e).map_err(|e| fail(e.to_string()))?;
    let mut t = DVector::zeros(n + 2);
    t[n + 1] = direction.signum();
    let fake = Node {
        eval: e,
        jac,
        tangent: t,
        s: 0.0,
        iterations: 0,
    };
    engine::correct(sys, &fake, 0.0, set).map_err(|e| fail(format!("{e:?}")))
}

fn to_curve(sys: &FoldSystem, curve: Curve<FoldEval>) -> FoldCurve {
    let n = sys.map.n();
    let mut points: Vec<FoldPoint> = curve
        .nodes
        .iter()
        .map(|node| {
            let e = &node.eval.map;
            let amplitude = sys
                .map
                .family
                .setup(&e.values)
                .map_or(f64::NAN, |s| s.problem.amplitude);
            FoldPoint {
                arclength: node.s,
                values: [e.values[0], e.values[1]],
                amplitude,
                cycle: e.period.record,
                tangent: [node.tangent[n], node.tangent[n + 1]],
                kind: FoldPointKind::Regular,
            }
        })
        .collect();
    for &(_, i) in &curve.specials {
        let node = &curve.nodes[i];
        let ty = node.tangent.rows(0, n).norm();
        let tp = node.tangent[n].abs();
        points[i].kind = if tp < CUSP_RATIO * ty {
            FoldPointKind::Cusp
        } else {
            FoldPointKind::Turn
        };
    }
    if let Some(p) = points.first_mut() {
        p.kind = FoldPointKind::Start;
    }
    if let Some(p) = points.last_mut() {
        if p.kind == FoldPointKind::Regular {
            p.kind = FoldPointKind::End;
        }
    }
    let end = match curve.end {
        End::Window => BranchEnd::Range,
        End::Rough(k) => BranchEnd::Grazing(format!("{k:?}")),
        End::Underflow(why) => BranchEnd::StepUnderflow(why),
        End::MaxPoints => BranchEnd::MaxPoints,
    };
    FoldCurve {
        points,
        end,
        work: curve.work,
    }
}
