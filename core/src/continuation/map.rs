//! The one-period map of a [`Family`] and its derivatives, in scaled unknowns.
//!
//! The unknowns are u = (ŷ, p̂): the state components of (x_s, v_s, a) that the problem
//! integrates ([`Problem::unknown_indices`](crate::steady::Problem::unknown_indices)), each divided by its scale (L, ωL, a_m, fixed for
//! the whole branch), and the free parameters, each divided by its scale (the width of its
//! range). The residual is F(u) = (P(y; p) − y)/scale over the state unknowns.
//!
//! # Derivatives: finite differences on a frozen step sequence
//! The map is integrated adaptively (DP8 at rtol 1e-10 by default). Its derivatives are taken
//! on the *discrete* map instead: the accepted steps of the adaptive period from y are recorded,
//! and every perturbed start is integrated again with exactly that step sequence
//! ([`Simulator::trial`](crate::dynamics::Simulator::trial), one fresh step at a time,
//! stretched by T(p′)/T(p) when the perturbed parameter changes the period). The differences are
//! then those of one smooth map (Bock's *internal numerical differentiation*). Measured on the
//! bundled resonance scene at 1.5 µm: over spans of 1e-6 and 1e-4 (scaled) both the adaptive
//! and the replayed map deviate from a quadratic by ~1e-14, their rounding; over a span of 1e-2
//! the adaptive map's second differences are ~1e-13 except isolated ones of ~3e-11, where its
//! step sequence changes. The replayed map has no such places. With rounding ~1e-14, central differences at
//! ε = 1e-5 ([`FD_STEP`]) carry ~1e-9 (1e-14/ε, plus ε² times the third derivative); central
//! differences at 1e-5 and 1e-4 agree to 2e-8 on the slowest multiplier, forward ones at 1e-6
//! are off by ~1e-7. A Jacobian costs 2n + 2m replays (n state unknowns, m parameters), each
//! cheaper than an adaptive period (no rejected steps).
//!
//! A period that loses or forms contact is not smooth: it is reported (the event kinds), and the
//! continuation treats it as the end of the smooth branch (grazing).

use nalgebra::{DMatrix, DVector};

use crate::dynamics::{CycleRecord, EventKind, Stop};
use crate::steady::OrbitState;

use super::family::{Family, Setup};

/// Default finite-difference step in scaled units.
pub const FD_STEP: f64 = 1e-5;

/// Multiple of rtol × |u_i| below which a corrector need not resolve unknown i
/// ([`ScaledMap::floor`]).
pub const FLOOR: f64 = 10.0;

/// One adaptive period of the map.
#[derive(Debug, Clone)]
pub struct Period {
    /// The start (consistent) state.
    pub start: OrbitState,
    /// The state one period later: (x_s, v_s, a).
    pub end: [f64; 3],
    /// The cycle record of the period.
    pub record: CycleRecord,
    /// Contact losses and impacts within the period.
    pub events: Vec<EventKind>,
    /// The base period T (s) the steps span.
    pub length: f64,
    /// The accepted step lengths (s), in order.
    steps: Vec<f64>,
}

impl Period {
    /// The period loses or forms contact, or the contact is open at its end: not smooth.
    pub fn rough(&self) -> bool {
        !self.events.is_empty() || self.end[2] <= 0.0 || self.start.a <= 0.0
    }
}

/// Why one evaluation of the map failed (the continuation shortens its step or stops).
#[derive(Debug, Clone, PartialEq)]
pub enum MapFail {
    /// The state is not consistent with the law (e.g. a compressive edge under a Gent–Schultz
    /// law, or a ≤ 0).
    Inconsistent,
    /// The period contains these events (the map is not smooth there).
    Rough(Vec<EventKind>),
    /// The time integration failed.
    Sim(String),
    /// A parameter value the scenario refuses.
    Setup(String),
}

impl std::fmt::Display for MapFail {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MapFail::Inconsistent => write!(f, "no state consistent with the adhesion law"),
            MapFail::Rough(k) => {
                let names: Vec<&str> = k
                    .iter()
                    .map(|e| match e {
                        EventKind::ContactLoss => "a contact loss",
                        EventKind::Impact => "an impact",
                        _ => "an event",
                    })
                    .collect();
                write!(
                    f,
                    "the period contains {} (the one-period map is smooth only while the contact \
                     holds all period)",
                    if names.is_empty() {
                        "an open contact".to_string()
                    } else {
                        names.join(" and ")
                    }
                )
            }
            MapFail::Sim(e) => write!(f, "time integration failed: {e}"),
            MapFail::Setup(e) => write!(f, "{e}"),
        }
    }
}

/// Run one adaptive period from `y` (x_s, v_s, a) at `setup`, recording its steps.
pub fn period(setup: &Setup, y: [f64; 3], rtol: f64) -> Result<Period, MapFail> {
    let start = setup.state(y).ok_or(MapFail::Inconsistent)?;
    let mut sim = setup
        .problem
        .simulator(&start.initial(), rtol)
        .map_err(|e| MapFail::Sim(e.to_string()))?;
    let t0 = sim.state().t;
    sim.advance_to(t0 + setup.period(), None);
    let mut steps = Vec::with_capacity(64);
    let mut events = Vec::new();
    loop {
        let stop = sim.step().map_err(|e| MapFail::Sim(e.to_string()))?;
        if let Some(seg) = sim.segment() {
            if matches!(stop, Stop::Step { .. }) {
                steps.push(seg.y1.t - seg.y0.t);
            }
        }
        let (record, reached) = match stop {
            Stop::Step { period, reached } => (period, reached),
            Stop::Event(kind, _) => {
                if matches!(kind, EventKind::ContactLoss | EventKind::Impact) {
                    events.push(kind);
                }
                (None, false)
            }
            Stop::Kick => (None, false),
            Stop::Period(rec) => (Some(rec), false),
            Stop::Reached => (None, true),
        };
        if let Some(record) = record {
            let s = sim.sample_of(sim.state(), 0);
            return Ok(Period {
                start,
                end: [s.x_s, s.v_s, s.a],
                record: *record,
                events,
                length: setup.period(),
                steps,
            });
        }
        if reached {
            return Err(MapFail::Sim(
                "the period ended without a cycle record".into(),
            ));
        }
    }
}

/// Integrate from `y` at `setup` with the step sequence `steps` stretched by `stretch` (no step
/// control, no events): the discrete map whose differences are the derivatives (module doc).
pub fn replay(
    setup: &Setup,
    y: [f64; 3],
    steps: &[f64],
    stretch: f64,
    rtol: f64,
) -> Result<[f64; 3], MapFail> {
    let start = setup.state(y).ok_or(MapFail::Inconsistent)?;
    let mut sim = setup
        .problem
        .simulator(&start.initial(), rtol)
        .map_err(|e| MapFail::Sim(e.to_string()))?;
    let mut s = *sim.state();
    for &h in steps {
        // A replayed step fails when a stage finds no contact radius (the contact collapses
        // within it): the perturbed orbit loses contact where the recorded one did not, so the
        // map is at the edge of its smooth part (grazing).
        s = sim
            .trial(&s, h * stretch)
            .ok_or_else(|| MapFail::Rough(vec![EventKind::ContactLoss]))?;
    }
    let e = sim.sample_of(&s, 0);
    Ok([e.x_s, e.v_s, e.a])
}

/// The scaled map of a family: which state components are unknowns and the scales.
#[derive(Debug, Clone)]
pub struct ScaledMap {
    /// The family.
    pub family: Family,
    /// Indices into (x_s, v_s, a) of the state unknowns.
    pub idx: Vec<usize>,
    /// Scales of (x_s, v_s, a): L (m), ωL (m/s), a_m (m).
    pub sc: [f64; 3],
    /// Scales of the free parameters (SI units of each).
    pub ps: Vec<f64>,
    /// Integration tolerance.
    pub rtol: f64,
    /// Finite-difference step (scaled).
    pub fd_step: f64,
    /// Take the state derivatives by central differences (twice the cost).
    pub central: bool,
}

/// The map at one point: the period, the full state and the residual.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// Scaled unknowns (state, then parameters).
    pub u: DVector<f64>,
    /// Full state (x_s, v_s, a) at phase 0.
    pub y: [f64; 3],
    /// Parameter values (SI).
    pub values: Vec<f64>,
    /// The adaptive period.
    pub period: Period,
    /// Scaled residual (P(y) − y)/scale over the state unknowns.
    pub residual: DVector<f64>,
}

impl ScaledMap {
    /// Number of state unknowns.
    pub fn n(&self) -> usize {
        self.idx.len()
    }

    /// Number of free parameters.
    pub fn m(&self) -> usize {
        self.ps.len()
    }

    /// Scaled unknowns from a full state and parameter values.
    pub fn scale(&self, y: &[f64; 3], values: &[f64]) -> DVector<f64> {
        let n = self.n();
        DVector::from_fn(n + self.m(), |i, _| {
            if i < n {
                let j = self.idx[i];
                y[j] / self.sc[j]
            } else {
                values[i - n] / self.ps[i - n]
            }
        })
    }

    /// Full state and parameter values from scaled unknowns; the components of the state that
    /// are not unknowns are taken from `carry`.
    pub fn unscale(&self, u: &DVector<f64>, carry: &[f64; 3]) -> ([f64; 3], Vec<f64>) {
        let n = self.n();
        let mut y = *carry;
        for (i, &j) in self.idx.iter().enumerate() {
            y[j] = u[i] * self.sc[j];
        }
        let values = (0..self.m()).map(|k| u[n + k] * self.ps[k]).collect();
        (y, values)
    }

    fn setup(&self, values: &[f64]) -> Result<std::sync::Arc<Setup>, MapFail> {
        self.family
            .setup(values)
            .map_err(|e| MapFail::Setup(e.to_string()))
    }

    /// Evaluate the map at scaled unknowns `u` (other state components from `carry`).
    pub fn evaluate(&self, u: &DVector<f64>, carry: &[f64; 3]) -> Result<Evaluation, MapFail> {
        let (y, values) = self.unscale(u, carry);
        let setup = self.setup(&values)?;
        self.family.count(1);
        let period = period(&setup, y, self.rtol)?;
        if period.rough() {
            return Err(MapFail::Rough(period.events.clone()));
        }
        // The start the map actually used (a rate-independent law replaces a by its JKR
        // radius): the residual is that of the consistent state.
        let y = [period.start.x_s, period.start.v_s, period.start.a];
        let residual = DVector::from_fn(self.n(), |i, _| {
            let j = self.idx[i];
            (period.end[j] - y[j]) / self.sc[j]
        });
        Ok(Evaluation {
            u: u.clone(),
            y,
            values,
            period,
            residual,
        })
    }

    /// One replay (counted) of `steps`, recorded over a period `t0`, from `y` at `values`.
    fn replay_at(
        &self,
        y: [f64; 3],
        values: &[f64],
        steps: &[f64],
        t0: f64,
    ) -> Result<[f64; 3], MapFail> {
        let setup = self.setup(values)?;
        self.replay_with(&setup, y, steps, t0)
    }

    /// [`replay_at`](Self::replay_at) with the problem already set up: the replays of one
    /// monodromy matrix share their parameter values, and so one setup.
    fn replay_with(
        &self,
        setup: &Setup,
        y: [f64; 3],
        steps: &[f64],
        t0: f64,
    ) -> Result<[f64; 3], MapFail> {
        self.family.count(1);
        replay(setup, y, steps, setup.period() / t0, self.rtol)
    }

    /// The scaled monodromy matrix ∂P/∂ŷ (n × n) at state `y` and parameters `values`, by
    /// differences of replays of `steps` (recorded over a period `t0`; stretched to the period
    /// at `values`): central with step `fd_step` when [`central`](Self::central), else forward.
    pub fn monodromy_at(
        &self,
        y: [f64; 3],
        values: &[f64],
        steps: &[f64],
        t0: f64,
    ) -> Result<DMatrix<f64>, MapFail> {
        self.monodromy_with(y, values, steps, t0, self.fd_step, self.central)
    }

    /// [`monodromy_at`](Self::monodromy_at) with step `eps`, central or forward.
    pub fn monodromy_with(
        &self,
        y: [f64; 3],
        values: &[f64],
        steps: &[f64],
        t0: f64,
        eps: f64,
        central: bool,
    ) -> Result<DMatrix<f64>, MapFail> {
        let n = self.n();
        let setup = self.setup(values)?;
        let base = if central {
            None
        } else {
            Some(self.replay_with(&setup, y, steps, t0)?)
        };
        let mut m = DMatrix::zeros(n, n);
        for (col, &j) in self.idx.iter().enumerate() {
            let mut yp = y;
            yp[j] += eps * self.sc[j];
            let plus = self.replay_with(&setup, yp, steps, t0)?;
            let (lo, h) = match base {
                Some(b) => (b, eps),
                None => {
                    let mut ym = y;
                    ym[j] -= eps * self.sc[j];
                    (self.replay_with(&setup, ym, steps, t0)?, 2.0 * eps)
                }
            };
            for (row, &i) in self.idx.iter().enumerate() {
                m[(row, col)] = (plus[i] - lo[i]) / self.sc[i] / h;
            }
        }
        Ok(m)
    }

    /// The scaled derivative ∂P/∂p̂_k (n) at state `y` and parameters `values` (replays as in
    /// [`monodromy_at`](Self::monodromy_at)).
    pub fn parameter_column(
        &self,
        y: [f64; 3],
        values: &[f64],
        k: usize,
        steps: &[f64],
        t0: f64,
    ) -> Result<DVector<f64>, MapFail> {
        let dp = self.fd_step * self.ps[k].abs();
        let mut up = values.to_vec();
        up[k] += dp;
        let plus = self.replay_at(y, &up, steps, t0)?;
        let mut down = values.to_vec();
        if self.central {
            down[k] -= dp;
        }
        let minus = self.replay_at(y, &down, steps, t0)?;
        let h = (up[k] - down[k]) / self.ps[k];
        Ok(DVector::from_fn(self.n(), |row, _| {
            let i = self.idx[row];
            (plus[i] - minus[i]) / self.sc[i] / h
        }))
    }

    /// The Jacobian of the residual at an evaluation, n × (n + m) in scaled units: the columns
    /// of the state unknowns are M − I, M the monodromy matrix (∂P/∂y scaled), then ∂F/∂p̂ per
    /// parameter. Derivatives on the frozen step sequence of `e.period` (module doc).
    pub fn jacobian(&self, e: &Evaluation) -> Result<DMatrix<f64>, MapFail> {
        let (n, m) = (self.n(), self.m());
        let t0 = e.period.length;
        let steps = &e.period.steps;
        let mono = self.monodromy_at(e.y, &e.values, steps, t0)?;
        let mut jac = DMatrix::zeros(n, n + m);
        jac.view_mut((0, 0), (n, n))
            .copy_from(&(mono - DMatrix::identity(n, n)));
        for k in 0..m {
            let c = self.parameter_column(e.y, &e.values, k, steps, t0)?;
            jac.view_mut((0, n + k), (n, 1)).copy_from(&c);
        }
        Ok(jac)
    }

    /// The step sequence of an evaluation's period (for replays at nearby points).
    pub fn steps<'a>(&self, e: &'a Evaluation) -> &'a [f64] {
        &e.period.steps
    }

    /// The precision floor of each scaled unknown: [`FLOOR`] × rtol × |u_i|. A state component
    /// is integrated to about rtol relative to its own size, which its scale (the oscillation
    /// amplitude) may not be: at X_b = 10 nm the mean position x_s is ~1000 L, and a fixed
    /// point is known to ~1e-7 L along the slow (creeping) direction, not to 1e-9.
    pub fn floor(&self, u: &DVector<f64>) -> DVector<f64> {
        u.map(|x| FLOOR * self.rtol * x.abs())
    }

    /// The monodromy matrix M (∂P/∂y over the state unknowns, scaled) from a Jacobian.
    pub fn monodromy(&self, jac: &DMatrix<f64>) -> DMatrix<f64> {
        let n = self.n();
        DMatrix::from_fn(n, n, |i, j| jac[(i, j)] + if i == j { 1.0 } else { 0.0 })
    }
}
