//! One branch of periodic orbits continued in one parameter, with its stability and
//! bifurcations ([`super`] has the method).

use std::time::Instant;

use nalgebra::{Complex, DMatrix, DVector};
use serde::Serialize;

use crate::dynamics::{CycleRecord, EventKind};
use crate::steady::{Options, Steady};

use super::engine::{self, Curve, End, Node, System, Test};
use super::family::{Family, Parameter};
use super::floquet;
use super::map::{Evaluation, MapFail, ScaledMap};
use super::ContinuationError;

impl System for ScaledMap {
    type Eval = Evaluation;
    fn dim(&self) -> usize {
        self.n() + self.m()
    }
    fn evaluate(&self, u: &DVector<f64>, near: &Evaluation) -> Result<Evaluation, MapFail> {
        ScaledMap::evaluate(self, u, &near.y)
    }
    fn point<'a>(&self, e: &'a Evaluation) -> &'a DVector<f64> {
        &e.u
    }
    fn residual<'a>(&self, e: &'a Evaluation) -> &'a DVector<f64> {
        &e.residual
    }
    fn jacobian(&self, e: &Evaluation) -> Result<DMatrix<f64>, MapFail> {
        ScaledMap::jacobian(self, e)
    }
    fn floor(&self, u: &DVector<f64>) -> DVector<f64> {
        self.floor(u)
    }
}

/// Settings of a branch continuation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// The continuation's step control and tolerances (scaled units; see [`engine::Settings`]).
    pub engine: engine::Settings,
    /// Relative tolerance of the time integration (default 1e-10, as shooting).
    pub rtol: f64,
    /// Finite-difference step of the derivatives, scaled (default 1e-5, central differences).
    pub fd_step: f64,
    /// How the first orbit is found (shooting, time-stepping as the fallback).
    pub steady: Options,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            engine: engine::Settings::default(),
            rtol: 1e-10,
            fd_step: super::map::FD_STEP,
            steady: Options::default(),
        }
    }
}

/// What a point of a branch is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PointKind {
    /// An ordinary point.
    Regular,
    /// The first point (at the start of the range).
    Start,
    /// A fold (limit point): the branch turns back, a real multiplier is +1.
    Fold,
    /// A period doubling: a real multiplier is −1.
    PeriodDoubling,
    /// A Neimark–Sacker point: a complex pair on the unit circle.
    NeimarkSacker,
    /// A real multiplier through +1 without a turn of the branch (a branch point).
    BranchPoint,
    /// The last smooth point before a period loses or forms contact.
    Grazing,
    /// The last point (at an edge of the range, or where the continuation stopped).
    End,
}

impl PointKind {
    /// The name used in tables: `regular`, `fold`, `period-doubling`, ...
    pub fn name(self) -> &'static str {
        match self {
            PointKind::Regular => "regular",
            PointKind::Start => "start",
            PointKind::Fold => "fold",
            PointKind::PeriodDoubling => "period-doubling",
            PointKind::NeimarkSacker => "neimark-sacker",
            PointKind::BranchPoint => "branch-point",
            PointKind::Grazing => "grazing",
            PointKind::End => "end",
        }
    }
}

/// One periodic orbit of a branch (SI).
#[derive(Debug, Clone, PartialEq)]
pub struct BranchPoint {
    /// Pseudo-arclength from the start, in the scaled unknowns (dimensionless).
    pub arclength: f64,
    /// The parameter value (SI).
    pub value: f64,
    /// Base frequency f (Hz) at this point.
    pub frequency: f64,
    /// Base amplitude X_b (m) at this point.
    pub amplitude: f64,
    /// State at phase 0: (x_s m, v_s m/s, a m).
    pub state: [f64; 3],
    /// Means and first harmonics of the orbit.
    pub cycle: CycleRecord,
    /// Floquet multipliers, largest modulus first.
    pub multipliers: Vec<Complex<f64>>,
    /// The parameter component of the unit tangent (scaled), along the direction of travel.
    pub tangent_parameter: f64,
    /// Scaled residual ‖P(y) − y‖∞ at the point.
    pub residual: f64,
    /// What the point is.
    pub kind: PointKind,
}

impl BranchPoint {
    /// |δ1| / X_b (NaN when X_b = 0).
    pub fn delta_amp_over_xb(&self) -> f64 {
        if self.amplitude > 0.0 {
            self.delta_amp() / self.amplitude
        } else {
            f64::NAN
        }
    }
    /// |δ1| (m).
    pub fn delta_amp(&self) -> f64 {
        self.cycle.delta_sin.hypot(self.cycle.delta_cos)
    }
    /// Phase φ (rad) of δ1, δ − δ_m ≈ |δ1| sin(ωt + φ).
    pub fn phase(&self) -> f64 {
        self.cycle.delta_cos.atan2(self.cycle.delta_sin)
    }
    /// a_A = |a1| (m).
    pub fn a_amp(&self) -> f64 {
        self.cycle.a_sin.hypot(self.cycle.a_cos)
    }
    /// Every |μ| < 1.
    pub fn stable(&self) -> bool {
        floquet::stable(&self.multipliers)
    }
    /// |μ_k| (k from 0, largest first), NaN when the problem has fewer unknowns.
    pub fn multiplier_abs(&self, k: usize) -> f64 {
        self.multipliers.get(k).map_or(f64::NAN, |z| z.norm())
    }
}

/// Why a branch ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case", tag = "reason", content = "detail")]
pub enum BranchEnd {
    /// It reached an edge of the range.
    Range,
    /// A period ahead loses or forms contact (the events named): the smooth branch ends.
    Grazing(String),
    /// The step size underflowed (why the last step failed).
    StepUnderflow(String),
    /// The point limit was reached.
    MaxPoints,
}

/// A branch of periodic orbits.
#[derive(Debug, Clone)]
pub struct Branch {
    /// The parameter.
    pub parameter: Parameter,
    /// The range asked for (start, stop), SI.
    pub range: (f64, f64),
    /// The points in order of arclength, special points included.
    pub points: Vec<BranchPoint>,
    /// Why it ended.
    pub end: BranchEnd,
    /// Accepted steps, refused steps, points computed to locate special points.
    pub work: engine::Work,
    /// Periods of the map integrated (adaptive and replayed).
    pub periods: u64,
    /// Wall-clock time (s).
    pub wall_s: f64,
    /// Observations worth a line each.
    pub notes: Vec<String>,
    /// The scaled map (scales, unknowns) the branch was computed with.
    pub map: ScaledMap,
}

impl Branch {
    /// The points of one kind.
    pub fn of_kind(&self, kind: PointKind) -> impl Iterator<Item = &BranchPoint> {
        self.points.iter().filter(move |p| p.kind == kind)
    }
}

/// The monodromy matrix of a node of the branch.
fn monodromy(map: &ScaledMap, jac: &DMatrix<f64>) -> DMatrix<f64> {
    map.monodromy(jac)
}

fn multipliers_of(map: &ScaledMap, node: &Node<Evaluation>) -> Vec<Complex<f64>> {
    floquet::multipliers(&monodromy(map, &node.jac)).unwrap_or_default()
}

/// The first orbit: the steady state at `value` found as `djkr validate` finds it, then
/// polished by Newton at fixed parameter with the continuation's own Jacobian; its tangent
/// points towards increasing (`direction` > 0) or decreasing parameter.
pub fn first_node(
    map: &ScaledMap,
    steady: &Steady,
    value: f64,
    direction: f64,
    set: &engine::Settings,
) -> Result<Node<Evaluation>, ContinuationError> {
    let y = [steady.state.x_s, steady.state.v_s, steady.state.a];
    let u = map.scale(&y, &[value]);
    let fail = |e: String| {
        ContinuationError::Start(format!(
            "at {} = {value}: {e}",
            map.family.params()[0].name()
        ))
    };
    let e = map.evaluate(&u, &y).map_err(|e| fail(e.to_string()))?;
    let jac = map.jacobian(&e).map_err(|e| fail(e.to_string()))?;
    let n = map.dim();
    let mut t = DVector::zeros(n);
    t[n - 1] = direction.signum();
    let fake = Node {
        eval: e,
        jac,
        tangent: t,
        s: 0.0,
        iterations: 0,
    };
    engine::correct(map, &fake, 0.0, set).map_err(|e| fail(format!("{e:?}")))
}

/// Continue the branch of `family` (one free key) from `start` to `stop` (SI): the first orbit
/// by shooting, then pseudo-arclength continuation until the branch leaves the range (at either
/// end), a period ahead loses contact, or the step underflows. `progress` sees each accepted
/// point's parameter value.
pub fn continue_branch(
    family: &Family,
    (start, stop): (f64, f64),
    set: &Settings,
    progress: &mut dyn FnMut(f64),
) -> Result<Branch, ContinuationError> {
    let t0 = Instant::now();
    let param = *family
        .params()
        .first()
        .ok_or_else(|| ContinuationError::Input("no continuation parameter".into()))?;
    let width = (stop - start).abs();
    if !(width.is_finite() && width > 0.0) {
        return Err(ContinuationError::EmptyRange {
            input: "range",
            start,
            stop,
            unit: param.info.unit,
        });
    }
    let setup = family.setup(&[start])?;
    let steady = setup
        .problem
        .solve(&setup.start, &set.steady)
        .map_err(|e| ContinuationError::Start(format!("at {} = {start}: {e}", param.name())))?;
    let map = ScaledMap {
        family: family.clone(),
        idx: setup.problem.unknown_indices(),
        sc: steady.scales,
        ps: vec![width],
        rtol: set.rtol,
        fd_step: set.fd_step,
        central: true,
    };
    let first = first_node(&map, &steady, start, stop - start, &set.engine)?;
    let mut curve = trace_branch(&map, first, (start, stop), &set.engine, progress);
    snap_to_range(&map, &mut curve, (start, stop), &set.engine);
    let mut b = to_branch(&map, param, (start, stop), curve);
    b.periods = map.family.periods();
    b.wall_s = t0.elapsed().as_secs_f64();
    Ok(b)
}

/// Put the last point of a curve that ended at the edge of the range exactly on it (the located
/// edge is within `locate_tol` in arclength).
pub fn snap_to_range(
    map: &ScaledMap,
    curve: &mut Curve<Evaluation>,
    (start, stop): (f64, f64),
    set: &engine::Settings,
) {
    if curve.end != End::Window {
        return;
    }
    let n = map.n();
    let Some(last) = curve.nodes.last_mut() else {
        return;
    };
    let p = last.eval.values[0];
    let bound = if (p - start).abs() < (p - stop).abs() {
        start
    } else {
        stop
    };
    if let Ok(s) = engine::snap(map, last, n, bound / map.ps[0], set) {
        if (s.eval.values[0] - bound).abs() <= (p - bound).abs() {
            *last = s;
        }
    }
}

/// The test functions of a branch: fold (tangent's parameter component), period doubling,
/// Neimark–Sacker, a real multiplier through +1 (det(M − I)).
const TESTS: [PointKind; 4] = [
    PointKind::Fold,
    PointKind::PeriodDoubling,
    PointKind::NeimarkSacker,
    PointKind::BranchPoint,
];

/// Follow the branch from `first` within the parameter window [min, max] of `range`.
pub fn trace_branch(
    map: &ScaledMap,
    first: Node<Evaluation>,
    (start, stop): (f64, f64),
    set: &engine::Settings,
    progress: &mut dyn FnMut(f64),
) -> Curve<Evaluation> {
    let n = map.n();
    let ps = map.ps[0];
    let (lo, hi) = (start.min(stop), start.max(stop));
    let fold = |node: &Node<Evaluation>| node.tangent[n];
    let pd = |node: &Node<Evaluation>| floquet::period_doubling_test(&multipliers_of(map, node));
    let ns = |node: &Node<Evaluation>| floquet::neimark_sacker_test(&multipliers_of(map, node));
    // det(M − I) changes sign where a real multiplier crosses +1, at a fold as at a branch
    // point; det(M − I)/t_p is det of the bordered Jacobian [J; tᵀ], which changes sign only at
    // a branch point. Its product with t_p has the same sign and no pole.
    let bp = |node: &Node<Evaluation>| {
        let m = monodromy(map, &node.jac) - DMatrix::identity(n, n);
        m.determinant() * node.tangent[n]
    };
    let window = |node: &Node<Evaluation>| {
        let p = node.eval.values[0];
        ((p - lo) / ps).min((hi - p) / ps)
    };
    let tests: [Test<'_, Evaluation>; 4] = [&fold, &pd, &ns, &bp];
    let mut watch = |node: &Node<Evaluation>| progress(node.eval.values[0]);
    engine::trace(map, first, set, &tests, &window, &mut watch)
}

/// The branch's points from a traced curve: multipliers, kinds, and the checks that turn test
/// zeros into bifurcations (module doc of [`super`]).
pub fn to_branch(
    map: &ScaledMap,
    parameter: Parameter,
    range: (f64, f64),
    curve: Curve<Evaluation>,
) -> Branch {
    let mut notes = Vec::new();
    let mut points = branch_points(map, &curve);
    classify_specials(&mut points, &curve, &parameter, &mut notes);
    for &(t, s0, s1) in &curve.unlocated {
        let at = |s: f64| {
            curve
                .nodes
                .iter()
                .find(|n| n.s.to_bits() == s.to_bits())
                .map_or(f64::NAN, |n| n.eval.values[0])
        };
        notes.push(format!(
            "a {} lies between {} = {:.9e} and {:.9e} but could not be located",
            TESTS[t].name(),
            parameter.name(),
            at(s0),
            at(s1)
        ));
    }
    let end = branch_end(&curve.end);
    mark_ends(&mut points, &end);
    match &end {
        BranchEnd::Grazing(k) => notes.push(format!(
            "the branch ends at a grazing: past the last point a period contains {k}, the map is not smooth there (not a fold)"
        )),
        BranchEnd::StepUnderflow(why) => notes.push(format!(
            "the continuation stopped: the step size fell below its minimum ({why})"
        )),
        BranchEnd::MaxPoints => notes.push("the continuation stopped at its point limit".into()),
        BranchEnd::Range => {}
    }
    Branch {
        parameter,
        range,
        points,
        end,
        work: curve.work,
        periods: 0,
        wall_s: 0.0,
        notes,
        map: map.clone(),
    }
}

/// One regular point per node of the curve, with its multipliers.
fn branch_points(map: &ScaledMap, curve: &Curve<Evaluation>) -> Vec<BranchPoint> {
    let n = map.n();
    curve
        .nodes
        .iter()
        .map(|node| {
            let e = &node.eval;
            let (frequency, amplitude) = map
                .family
                .setup(&e.values)
                .map(|s| (s.problem.frequency, s.problem.amplitude))
                .unwrap_or((f64::NAN, f64::NAN));
            BranchPoint {
                arclength: node.s,
                value: e.values[0],
                frequency,
                amplitude,
                state: e.y,
                cycle: e.period.record,
                multipliers: multipliers_of(map, node),
                tangent_parameter: node.tangent[n],
                residual: e.residual.amax(),
                kind: PointKind::Regular,
            }
        })
        .collect()
}

/// Mark the test zeros of the curve that the multipliers confirm as bifurcations; a note for
/// each zero that is something else (a neutral saddle, a branch point).
fn classify_specials(
    points: &mut [BranchPoint],
    curve: &Curve<Evaluation>,
    parameter: &Parameter,
    notes: &mut Vec<String>,
) {
    let folds: Vec<f64> = curve
        .specials
        .iter()
        .filter(|(t, _)| TESTS[*t] == PointKind::Fold)
        .map(|&(_, i)| curve.nodes[i].s)
        .collect();
    for &(t, i) in &curve.specials {
        let p = &mut points[i];
        let kind = TESTS[t];
        let tol = 1e-6;
        let keep = match kind {
            PointKind::Fold => true,
            PointKind::PeriodDoubling => floquet::real_nearest(&p.multipliers, -1.0, tol)
                .is_some_and(|z| (z.re + 1.0).abs() < 1e-3),
            PointKind::NeimarkSacker => {
                let z = floquet::complex_nearest_circle(&p.multipliers, tol);
                let ok = z.is_some_and(|z| (z.norm() - 1.0).abs() < 1e-3);
                if !ok {
                    notes.push(format!(
                        "{} = {:.9e}: two real multipliers with product 1 (a neutral saddle, not a Neimark-Sacker point)",
                        parameter.name(),
                        p.value
                    ));
                }
                ok
            }
            PointKind::BranchPoint => {
                // At a fold det(M − I) vanishes too: only a zero away from every fold is a
                // branch point.
                let near_fold = folds.iter().any(|s| (s - p.arclength).abs() < 1e-6);
                if !near_fold {
                    notes.push(format!(
                        "{} = {:.9e}: a real multiplier crosses +1 without the branch turning back (a branch point; the other branch is not followed)",
                        parameter.name(),
                        p.value
                    ));
                }
                !near_fold
            }
            _ => false,
        };
        if keep {
            p.kind = kind;
        }
    }
}

/// Why the traced curve ended.
fn branch_end(end: &End) -> BranchEnd {
    match end {
        End::Window => BranchEnd::Range,
        End::Rough(kinds) => {
            let k: Vec<&str> = kinds.iter().map(|k| event_name(*k)).collect();
            BranchEnd::Grazing(k.join(", "))
        }
        End::Underflow(why) => BranchEnd::StepUnderflow(why.clone()),
        End::MaxPoints => BranchEnd::MaxPoints,
    }
}

/// The first point is the start; the last, unless special, the end (a grazing where the branch
/// ends at one).
fn mark_ends(points: &mut [BranchPoint], end: &BranchEnd) {
    if let Some(p) = points.first_mut() {
        p.kind = PointKind::Start;
    }
    if let Some(p) = points.last_mut() {
        if p.kind == PointKind::Regular {
            p.kind = match end {
                BranchEnd::Grazing(_) => PointKind::Grazing,
                _ => PointKind::End,
            };
        }
    }
}

fn event_name(k: EventKind) -> &'static str {
    match k {
        EventKind::ContactLoss => "a contact loss",
        EventKind::Impact => "an impact",
        _ => "an event",
    }
}
