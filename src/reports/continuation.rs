//! What `djkr continue` writes and prints: the branch table (`branch.csv`, `branch.h5`, whose
//! column names are a contract), the special points, the sweeps and the fold curves as tables
//! ([`crate::output::table`]), and the `--json` summary ([`ContinuationReport`]).
//!
//! JSON has no NaN: a number that may be missing is left out.

use serde::ser::{Serialize, SerializeMap, Serializer};

use crate::output::{Column, Table};
use crate::reports::steady::{orbit_column, Orbit, OrbitQuantity as Q};
use djkr_core::continuation::branch::{Branch, BranchEnd, BranchPoint, PointKind};
use djkr_core::continuation::folds::{FoldCurve, FoldPoint, FoldPointKind};
use djkr_core::continuation::sweep::SweepPoint;
use djkr_core::dynamics::CycleRecord;
use djkr_core::steady::Steady;

impl Orbit for BranchPoint {
    fn record(&self) -> &CycleRecord {
        &self.cycle
    }

    fn delta_amp_over_xb(&self) -> f64 {
        BranchPoint::delta_amp_over_xb(self)
    }
}

impl Orbit for FoldPoint {
    fn record(&self) -> &CycleRecord {
        &self.cycle
    }

    fn delta_amp_over_xb(&self) -> f64 {
        FoldPoint::delta_amp_over_xb(self)
    }
}

/// The branch table: one row per point (special points included, in order of arclength).
pub fn branch_table(b: &Branch) -> Table {
    let p = &b.points;
    let f = |g: &dyn Fn(&BranchPoint) -> f64| p.iter().map(g).collect::<Vec<f64>>();
    let orb = |q: Q, description: &str| orbit_column(q, description, p.iter().map(Some));
    let info = b.parameter.info;
    Table::from_fixed(vec![
        Column::f64(
            "arclength",
            "1",
            "pseudo-arclength along the branch in the scaled unknowns (state by L, omega L, a_m; parameter by the range's width)",
            f(&|x| x.arclength),
        ),
        Column::f64(info.key, info.unit, info.what, f(&|x| x.value)),
        orb(
            Q::DeltaAmpOverXb,
            "first-harmonic indentation amplitude |delta_1| / X_b",
        ),
        orb(
            Q::Phase,
            "phase phi of delta_1, delta - delta_m ~ |delta_1| sin(wt + phi)",
        ),
        orb(Q::DeltaMean, "cycle-mean indentation"),
        orb(Q::ForceMean, "cycle-mean contact force (compressive +)"),
        orb(Q::AMean, "cycle-mean contact radius"),
        orb(Q::AAmp, "first-harmonic contact-radius amplitude a_A"),
        Column::i64(
            "stable",
            "1",
            "1: every Floquet multiplier inside the unit circle; 0: not",
            p.iter().map(|x| i64::from(x.stable())).collect(),
        ),
        Column::f64(
            "multiplier_1_abs",
            "1",
            "largest |Floquet multiplier|",
            f(&|x| x.multiplier_abs(0)),
        ),
        Column::f64(
            "multiplier_2_abs",
            "1",
            "second largest |Floquet multiplier| (NaN: fewer unknowns)",
            f(&|x| x.multiplier_abs(1)),
        ),
        Column::f64(
            "multiplier_3_abs",
            "1",
            "third largest |Floquet multiplier| (NaN: fewer unknowns)",
            f(&|x| x.multiplier_abs(2)),
        ),
    ])
}

/// The special points of a branch (start, folds, bifurcations, grazing, end): `bifurcations.csv`.
pub fn special_table(b: &Branch) -> Table {
    let p: Vec<&BranchPoint> = b
        .points
        .iter()
        .filter(|x| x.kind != PointKind::Regular)
        .collect();
    let f = |g: &dyn Fn(&BranchPoint) -> f64| p.iter().map(|x| g(x)).collect::<Vec<f64>>();
    let info = b.parameter.info;
    let mu = |k: usize, part: &'static str| {
        Column::f64(
            format!("multiplier_{}_{part}", k + 1),
            "1",
            format!(
                "{} part of the Floquet multiplier {} (largest modulus first)",
                if part == "re" { "real" } else { "imaginary" },
                k + 1
            ),
            p.iter()
                .map(|x| {
                    x.multipliers
                        .get(k)
                        .map_or(f64::NAN, |z| if part == "re" { z.re } else { z.im })
                })
                .collect(),
        )
    };
    let mut cols = vec![
        Column::text(
            "kind",
            "start, fold, period-doubling, neimark-sacker, branch-point, grazing, end",
            p.iter().map(|x| x.kind.name().to_string()).collect(),
        ),
        Column::f64("arclength", "1", "pseudo-arclength", f(&|x| x.arclength)),
        Column::f64(info.key, info.unit, info.what, f(&|x| x.value)),
        orbit_column(
            Q::DeltaAmpOverXb,
            "|delta_1| / X_b",
            p.iter().copied().map(Some),
        ),
        orbit_column(
            Q::AMean,
            "cycle-mean contact radius",
            p.iter().copied().map(Some),
        ),
    ];
    for k in 0..3 {
        cols.push(mu(k, "re"));
        cols.push(mu(k, "im"));
    }
    Table::from_fixed(cols)
}

/// A sweep's table (`sweep.csv` holds both directions).
pub fn sweep_table(key: &str, unit: &str, direction: &str, p: &[SweepPoint]) -> Table {
    let st =
        |q: Q, description: &str| orbit_column(q, description, p.iter().map(|x| x.steady.as_ref()));
    Table::from_fixed(vec![
        Column::text(
            "direction",
            "sweep direction",
            p.iter().map(|_| direction.to_string()).collect(),
        ),
        Column::f64(
            key,
            unit,
            "parameter value",
            p.iter().map(|x| x.value).collect(),
        ),
        st(Q::DeltaAmpOverXb, "|delta_1| / X_b"),
        st(Q::Phase, "phase of delta_1"),
        st(Q::DeltaMean, "cycle-mean indentation"),
        st(Q::ForceMean, "cycle-mean contact force"),
        st(Q::AMean, "cycle-mean contact radius"),
        st(Q::AAmp, "contact-radius amplitude"),
        Column::text(
            "error",
            "why the steady state is missing (empty when found)",
            p.iter()
                .map(|x| x.error.clone().unwrap_or_default())
                .collect(),
        ),
    ])
}

/// The fold curves' table (`fold_curves.csv`): one row per point, `curve` numbering them.
pub fn fold_table(keys: [(&str, &str); 2], curves: &[FoldCurve]) -> Table {
    let rows: Vec<(usize, &FoldPoint)> = curves
        .iter()
        .enumerate()
        .flat_map(|(i, c)| c.points.iter().map(move |p| (i, p)))
        .collect();
    let f = |g: &dyn Fn(&FoldPoint) -> f64| rows.iter().map(|(_, p)| g(p)).collect::<Vec<f64>>();
    let orb =
        |q: Q, description: &str| orbit_column(q, description, rows.iter().map(|(_, p)| Some(*p)));
    Table::from_fixed(vec![
        Column::i64(
            "curve",
            "1",
            "fold curve number (from 0)",
            rows.iter().map(|(i, _)| *i as i64).collect(),
        ),
        Column::text(
            "kind",
            "start, regular, cusp, turn, end",
            rows.iter()
                .map(|(_, p)| fold_kind_name(p.kind).to_string())
                .collect(),
        ),
        Column::f64(
            "arclength",
            "1",
            "pseudo-arclength along the fold curve (scaled)",
            f(&|p| p.arclength),
        ),
        Column::f64(keys[0].0, keys[0].1, "first parameter", f(&|p| p.values[0])),
        Column::f64(
            keys[1].0,
            keys[1].1,
            "second parameter",
            f(&|p| p.values[1]),
        ),
        orb(
            Q::DeltaAmpOverXb,
            "|delta_1| / X_b of the orbit at the fold",
        ),
        orb(Q::AMean, "cycle-mean contact radius at the fold"),
    ])
}

fn fold_kind_name(k: FoldPointKind) -> &'static str {
    match k {
        FoldPointKind::Regular => "regular",
        FoldPointKind::Start => "start",
        FoldPointKind::Cusp => "cusp",
        FoldPointKind::Turn => "turn",
        FoldPointKind::End => "end",
    }
}

// ---------------------------------------------------------------------------------------------
// JSON

/// A point in the JSON report: `{"KEY": value, "delta_amp_over_xb": ..., "a_mean": ...}` (a
/// second key's value with `--fold-param`), plus what else is known about it. Keys are the
/// scenario keys themselves, so the object is built by hand.
#[derive(Debug, Clone, PartialEq)]
pub struct Marked {
    /// (key, value) of the parameters.
    pub values: Vec<(String, f64)>,
    /// |δ1|/X_b (left out when not finite).
    pub delta_amp_over_xb: f64,
    /// ⟨a⟩ (m).
    pub a_mean: f64,
    /// Other numbers (name, value), left out when not finite.
    pub extra: Vec<(&'static str, f64)>,
    /// |μ| largest first (branch points only).
    pub multipliers_abs: Vec<f64>,
}

impl Serialize for Marked {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        for (k, v) in &self.values {
            if v.is_finite() {
                m.serialize_entry(k, v)?;
            }
        }
        if self.delta_amp_over_xb.is_finite() {
            m.serialize_entry("delta_amp_over_xb", &self.delta_amp_over_xb)?;
        }
        if self.a_mean.is_finite() {
            m.serialize_entry("a_mean", &self.a_mean)?;
        }
        for (k, v) in &self.extra {
            if v.is_finite() {
                m.serialize_entry(k, v)?;
            }
        }
        let mu: Vec<f64> = self
            .multipliers_abs
            .iter()
            .copied()
            .filter(|x| x.is_finite())
            .collect();
        if !mu.is_empty() {
            m.serialize_entry("multipliers_abs", &mu)?;
        }
        m.end()
    }
}

impl Marked {
    /// A point of a branch.
    pub fn of_point(key: &str, p: &BranchPoint) -> Self {
        Self {
            values: vec![(key.to_string(), p.value)],
            delta_amp_over_xb: p.delta_amp_over_xb(),
            a_mean: p.cycle.a_mean,
            extra: vec![("arclength", p.arclength)],
            multipliers_abs: p.multipliers.iter().map(|z| z.norm()).collect(),
        }
    }

    /// A point of a fold curve.
    pub fn of_fold(keys: [&str; 2], p: &FoldPoint) -> Self {
        Self {
            values: vec![
                (keys[0].to_string(), p.values[0]),
                (keys[1].to_string(), p.values[1]),
            ],
            delta_amp_over_xb: p.delta_amp_over_xb(),
            a_mean: p.cycle.a_mean,
            extra: Vec::new(),
            multipliers_abs: Vec::new(),
        }
    }
}

/// A jump of a sweep: the last value on the branch it leaves and the next value swept.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Jump {
    /// Sweep direction, `up` or `down`.
    pub direction: &'static str,
    /// Last value before the jump.
    pub from: f64,
    /// Next value swept.
    pub to: f64,
    /// |δ1|/X_b before.
    pub delta_amp_over_xb_before: f64,
    /// |δ1|/X_b after (left out when that steady state is missing).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delta_amp_over_xb_after: Option<f64>,
}

/// A fold curve in the JSON report.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FoldCurveReport {
    /// Why it ended.
    pub end: BranchEnd,
    /// Its points.
    pub points: Vec<Marked>,
}

/// The `--json` summary of `djkr continue`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ContinuationReport {
    /// The scenario (with its overrides).
    pub scenario: String,
    /// The continuation parameter (KEY).
    pub parameter: String,
    /// Its SI unit.
    pub unit: String,
    /// The range (START, STOP), SI.
    pub range: [f64; 2],
    /// Points on the branch (special points included).
    pub points: usize,
    /// Why the branch ended.
    pub end: BranchEnd,
    /// Folds (limit points): the branch turns back, a multiplier is +1.
    pub folds: Vec<Marked>,
    /// Period doublings: a multiplier is −1.
    pub period_doublings: Vec<Marked>,
    /// Neimark–Sacker points: a complex pair on the unit circle.
    pub neimark_sacker: Vec<Marked>,
    /// Branch points (a real multiplier through +1 without a turn).
    pub branch_points: Vec<Marked>,
    /// The last smooth point before a period loses or forms contact.
    pub grazing: Vec<Marked>,
    /// Where the sweeps jump (with `--sweep` > 0).
    pub sweep_jumps: Vec<Jump>,
    /// Accepted steps.
    pub steps: usize,
    /// Refused steps.
    pub rejected: usize,
    /// Periods of the map integrated for the branch (adaptive and replayed).
    pub periods: u64,
    /// Wall-clock time of the branch (s).
    pub wall_s: f64,
    /// The second parameter (KEY2) with `--fold-param`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fold_parameter: Option<String>,
    /// Its range.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fold_range: Option<[f64; 2]>,
    /// The fold curves (with `--fold-param`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fold_curves: Option<Vec<FoldCurveReport>>,
    /// The cusp where the folds are born (with `--fold-param`, when one was found).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cusp: Option<Marked>,
    /// Wall-clock time of the fold curves (s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fold_wall_s: Option<f64>,
    /// Observations.
    pub notes: Vec<String>,
    /// Files written.
    pub files: Vec<String>,
}

impl ContinuationReport {
    /// The report of a branch (`files`, the sweeps' jumps and the fold curves are added by the
    /// caller).
    pub fn new(scenario: &str, b: &Branch) -> Self {
        let key = b.parameter.name();
        let of = |k: PointKind| -> Vec<Marked> {
            b.of_kind(k).map(|p| Marked::of_point(key, p)).collect()
        };
        Self {
            scenario: scenario.to_string(),
            parameter: key.to_string(),
            unit: b.parameter.info.unit.to_string(),
            range: [b.range.0, b.range.1],
            points: b.points.len(),
            end: b.end.clone(),
            folds: of(PointKind::Fold),
            period_doublings: of(PointKind::PeriodDoubling),
            neimark_sacker: of(PointKind::NeimarkSacker),
            branch_points: of(PointKind::BranchPoint),
            grazing: of(PointKind::Grazing),
            sweep_jumps: Vec::new(),
            steps: b.work.steps,
            rejected: b.work.rejected,
            periods: b.periods,
            wall_s: b.wall_s,
            fold_parameter: None,
            fold_range: None,
            fold_curves: None,
            cusp: None,
            fold_wall_s: None,
            notes: b.notes.clone(),
            files: Vec::new(),
        }
    }

    /// Add the fold curves of `--fold-param KEY2` over `range`.
    pub fn with_folds(
        mut self,
        key2: &str,
        range: (f64, f64),
        curves: &[FoldCurve],
        wall_s: f64,
    ) -> Self {
        let keys = [self.parameter.clone(), key2.to_string()];
        let k = [keys[0].as_str(), keys[1].as_str()];
        self.fold_curves = Some(
            curves
                .iter()
                .map(|c| FoldCurveReport {
                    end: c.end.clone(),
                    points: c.points.iter().map(|p| Marked::of_fold(k, p)).collect(),
                })
                .collect(),
        );
        self.cusp = curves
            .iter()
            .flat_map(FoldCurve::cusps)
            .next()
            .map(|p| Marked::of_fold(k, p));
        if self.cusp.is_none() {
            self.notes.push(format!(
                "no cusp within {key2} = {}..{}: the folds persist over the whole range",
                range.0, range.1
            ));
        }
        for (i, c) in curves.iter().enumerate() {
            if let BranchEnd::StepUnderflow(why) | BranchEnd::Grazing(why) = &c.end {
                self.notes
                    .push(format!("fold curve {i} stopped early: {why}"));
            }
        }
        self.fold_parameter = Some(key2.to_string());
        self.fold_range = Some([range.0, range.1]);
        self.fold_wall_s = Some(wall_s);
        self
    }
}

/// The runs of a branch: maximal stretches of consecutive points of equal stability, each as
/// (stable, [(parameter value, |δ1|/X_b)]) in order.
fn runs(b: &Branch) -> Vec<(bool, Vec<(f64, f64)>)> {
    let mut runs: Vec<(bool, Vec<(f64, f64)>)> = Vec::new();
    for p in &b.points {
        let xy = (p.value, p.delta_amp_over_xb());
        match runs.last_mut() {
            Some((st, v)) if *st == p.stable() => v.push(xy),
            _ => runs.push((p.stable(), vec![xy])),
        }
    }
    runs
}

/// |δ1|/X_b of a run at `v`, linearly interpolated (`None` outside it).
fn run_at(run: &[(f64, f64)], v: f64) -> Option<f64> {
    if let [(p, y)] = run {
        return ((v - p).abs() <= 1e-12 * p.abs()).then_some(*y);
    }
    run.windows(2).find_map(|w| {
        let ((p0, y0), (p1, y1)) = (w[0], w[1]);
        let (lo, hi) = (p0.min(p1), p0.max(p1));
        (v >= lo && v <= hi).then(|| {
            if hi > lo {
                y0 + (y1 - y0) * (v - p0) / (p1 - p0)
            } else {
                y0
            }
        })
    })
}

/// Which run of the branch a sweep's steady state lies on: the run whose value at the same
/// parameter is nearest, if within 2 % (`None`: on none of them).
fn run_of(runs: &[(bool, Vec<(f64, f64)>)], v: f64, y: f64) -> Option<usize> {
    runs.iter()
        .enumerate()
        .filter_map(|(i, (_, r))| run_at(r, v).map(|z| (i, (z - y).abs() / y.abs().max(z.abs()))))
        .filter(|(_, d)| *d < 0.02)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// The relative change of |δ_A/X_b| between neighbouring sweep values, either of them on no
/// run of the branch, that counts as a jump (the plot shows it as one; a smooth curve sampled
/// by a sweep changes far less between neighbours).
pub const OFF_BRANCH_JUMP: f64 = 0.25;

/// Whether a sweep jumps between neighbouring values with |δ_A/X_b| `a` and `b` (`None`: no
/// steady state found), on runs `ra` and `rb` of the branch (`None`: on none): a steady state
/// lost, two different runs, or, where either lies on no run (off the computed branch, e.g.
/// past a Neimark–Sacker point), a change the plot shows as a jump.
fn is_jump(a: f64, b: Option<f64>, ra: Option<usize>, rb: Option<usize>) -> bool {
    match (ra, b, rb) {
        (_, None, _) => true,
        (Some(x), Some(_), Some(y)) => x != y,
        (_, Some(b), _) => (b - a).abs() > OFF_BRANCH_JUMP * a.abs().max(b.abs()),
    }
}

/// What the sweeps did against the branch: where they jump (consecutive values on different
/// runs of the branch, a steady state missing after one found, or, off the branch, a change of
/// more than [`OFF_BRANCH_JUMP`]), and which values they
/// found on an unstable run (shooting converges to any orbit near its start, stable or not).
pub fn jumps(direction: &'static str, p: &[SweepPoint], branch: &Branch) -> (Vec<Jump>, Vec<f64>) {
    let runs = runs(branch);
    let run = |x: &SweepPoint| {
        x.steady
            .as_ref()
            .and_then(|s| run_of(&runs, x.value, s.transfer_magnitude()))
    };
    let unstable: Vec<f64> = p
        .iter()
        .filter(|x| run(x).is_some_and(|r| !runs[r].0))
        .map(|x| x.value)
        .collect();
    let mut out = Vec::new();
    for w in p.windows(2) {
        let Some(a) = w[0].steady.as_ref().map(Steady::transfer_magnitude) else {
            continue;
        };
        let b = w[1].steady.as_ref().map(Steady::transfer_magnitude);
        if is_jump(a, b, run(&w[0]), run(&w[1])) {
            out.push(Jump {
                direction,
                from: w[0].value,
                to: w[1].value,
                delta_amp_over_xb_before: a,
                delta_amp_over_xb_after: b,
            });
        }
    }
    (out, unstable)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sweep_jump_off_the_branch_is_reported_like_the_plot_shows_it() {
        // Issue 25: a down sweep drawn jumping 2.82 → 9.76 with both values on no run of the
        // computed branch was not reported.
        assert!(is_jump(2.82, Some(9.76), None, None));
        assert!(is_jump(2.82, Some(9.76), Some(0), None));
        assert!(is_jump(2.82, Some(9.76), None, Some(1)));
        // Neighbours of a smooth curve off the branch are not jumps.
        assert!(!is_jump(2.82, Some(3.0), None, None));
        // On the branch: different runs jump, one run does not, however steep.
        assert!(is_jump(2.82, Some(2.9), Some(0), Some(1)));
        assert!(!is_jump(2.82, Some(9.76), Some(1), Some(1)));
        // A steady state lost is a jump.
        assert!(is_jump(2.82, None, Some(0), None));
    }
}
