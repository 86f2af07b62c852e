//! Frequency response by continuation: the periodic steady state at each frequency of a list,
//! each started from the previous frequency's steady state, so that an up sweep and a down sweep
//! follow the branch they are on and reveal hysteresis or jumps near a nonlinear resonance.
//!
//! Alongside, the two predictors that need no time integration: the corrected linear transfer
//! (docs/MODEL.md, eqs. 36–39, with k_c = (3/2) K a_0 at the static radius a_0 of the scene's mean
//! load) and the harmonic-balance predictor ([`crate::describing`]), itself continued along the
//! sweep (each frequency's Newton started from the previous solution).
//!
//! The continuation within a sweep is sequential; the up and down sweeps are independent and
//! run in parallel ([`sweep_both`], rayon).

use super::{Options, Problem, Steady, SteadyError};
use crate::describing::{self, HarmonicBalance, Setup, StaticState};
use crate::dynamics::protocol::Initial;
use crate::rig::Rig;
use crate::transfer::{self, Transfer};
use serde::Serialize;

/// Sweep direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Direction {
    /// Increasing frequency.
    Up,
    /// Decreasing frequency.
    Down,
}

impl Direction {
    /// "up" or "down".
    pub fn name(self) -> &'static str {
        match self {
            Direction::Up => "up",
            Direction::Down => "down",
        }
    }
}

/// The static contact and the linear oscillator of a scene (the predictors' common ground).
#[derive(Debug, Clone, PartialEq)]
pub struct Linearisation {
    /// Harmonic-balance setup (the rig and its mean load).
    pub setup: Setup,
    /// The static contact under the scene's mean load (w0, no vibration).
    pub static_state: StaticState,
    /// The linearised contact stiffness k_c = (3/2) K a_0 (N/m).
    pub contact_stiffness: f64,
}

impl Linearisation {
    /// From a rig and a run's initial state, which sets the mean load (see
    /// [`describing::Setup::new`]: a preload, or an explicit state's spring end).
    pub fn new(rig: &Rig, initial: &Initial) -> Result<Self, SteadyError> {
        let setup =
            Setup::new(rig, initial).map_err(|e| SteadyError::Setup(format!("predictors: {e}")))?;
        let st = describing::static_state(&setup.rig, setup.support)
            .map_err(|e| SteadyError::Setup(format!("predictors: {e}")))?;
        Ok(Self {
            contact_stiffness: 1.5 * setup.rig.material.k * st.a,
            setup,
            static_state: st,
        })
    }

    /// For a steady-state problem started from `start` (the scene's initial state, or the state
    /// its pre-vibration stages reached).
    pub fn for_problem(problem: &Problem, start: &Initial) -> Result<Self, SteadyError> {
        Self::new(problem.rig(), start)
    }

    /// The corrected linear transfer δ1/X_b at frequency f (Hz).
    pub fn linear(&self, frequency: f64) -> Transfer {
        transfer::linear(
            &self.setup.rig,
            self.contact_stiffness,
            2.0 * std::f64::consts::PI * frequency,
        )
    }

    /// The paper's eqs. (36)–(37) as printed, at frequency f (Hz).
    pub fn paper(&self, frequency: f64) -> Transfer {
        transfer::paper_printed(
            &self.setup.rig,
            self.contact_stiffness,
            2.0 * std::f64::consts::PI * frequency,
        )
    }

    /// Eq. (39), the far-from-resonance limit δ_s/X_b = A/B, at frequency f (Hz).
    pub fn far_from_resonance(&self, frequency: f64) -> f64 {
        transfer::far_from_resonance(
            &self.setup.rig,
            self.contact_stiffness,
            2.0 * std::f64::consts::PI * frequency,
        )
    }

    /// Undamped linear resonance f_r = √((k + k_c)/m)/2π (Hz).
    pub fn resonance_frequency(&self) -> f64 {
        transfer::resonance_frequency(&self.setup.rig, self.contact_stiffness)
    }
}

/// One frequency of a sweep.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepPoint {
    /// Frequency f (Hz).
    pub frequency: f64,
    /// The time-domain steady state (`None` when it could not be found; see `error`).
    pub steady: Option<Steady>,
    /// Why the steady state is missing.
    pub error: Option<String>,
    /// Corrected linear transfer δ1/X_b.
    pub linear: Option<Transfer>,
    /// Harmonic-balance solution (continued along the sweep).
    pub harmonic: Option<HarmonicBalance>,
}

/// A frequency sweep in one direction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sweep {
    /// Direction.
    pub direction: Direction,
    /// Base amplitude X_b (m).
    pub amplitude: f64,
    /// Points in the order they were computed.
    pub points: Vec<SweepPoint>,
    /// Base periods integrated in total.
    pub cycles: u64,
    /// Wall-clock time (s).
    pub wall_s: f64,
}

/// `count` frequencies evenly spaced from `lo` to `hi` (Hz), inclusive (`count` = 1: `lo`).
pub fn frequencies(lo: f64, hi: f64, count: usize) -> Vec<f64> {
    match count {
        0 => Vec::new(),
        1 => vec![lo],
        n => (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect(),
    }
}

/// Sweep `freqs` (Hz, any order; sorted ascending for `Up`, descending for `Down`) at the
/// problem's base amplitude, starting from `start` at the first frequency and from the previous
/// steady state after that. `lin` adds the predictors; `progress` is called after each
/// frequency. Cancelled through the problem's solver settings, the sweep ends at the next
/// frequency with the points done.
pub fn sweep(
    problem: &Problem,
    start: &Initial,
    freqs: &[f64],
    direction: Direction,
    opts: &Options,
    lin: Option<&Linearisation>,
    progress: &(dyn Fn(Direction, &SweepPoint) + Sync),
) -> Sweep {
    let t0 = std::time::Instant::now();
    let mut fs: Vec<f64> = freqs.to_vec();
    fs.sort_by(f64::total_cmp);
    if direction == Direction::Down {
        fs.reverse();
    }
    let mut from = *start;
    let mut guess = None;
    let mut cycles = 0;
    let mut points = Vec::with_capacity(fs.len());
    for &f in &fs {
        // Cancelled (crate::cancel): the points left are not computed.
        if problem.cancel().is_cancelled() {
            break;
        }
        let result = problem
            .at(f, problem.amplitude)
            .and_then(|p| p.solve(&from, opts));
        let (steady, error) = match result {
            Ok(s) => {
                cycles += s.cycles;
                from = s.state.initial();
                (Some(s), None)
            }
            Err(e) => {
                if let SteadyError::NotConverged { cycles: c, .. } = e {
                    cycles += c;
                }
                (None, Some(e.to_string()))
            }
        };
        let harmonic = lin.and_then(|l| {
            let h = l.setup.solve(f, problem.amplitude, guess).ok();
            if let Some(h) = &h {
                guess = Some(h.guess());
            }
            h
        });
        let point = SweepPoint {
            frequency: f,
            steady,
            error,
            linear: lin.map(|l| l.linear(f)),
            harmonic,
        };
        progress(direction, &point);
        points.push(point);
    }
    Sweep {
        direction,
        amplitude: problem.amplitude,
        points,
        cycles,
        wall_s: t0.elapsed().as_secs_f64(),
    }
}

/// Up and down sweeps, run in parallel (rayon::join): (up, down).
pub fn sweep_both(
    problem: &Problem,
    start: &Initial,
    freqs: &[f64],
    opts: &Options,
    lin: Option<&Linearisation>,
    progress: &(dyn Fn(Direction, &SweepPoint) + Sync),
) -> (Sweep, Sweep) {
    rayon::join(
        || sweep(problem, start, freqs, Direction::Up, opts, lin, progress),
        || sweep(problem, start, freqs, Direction::Down, opts, lin, progress),
    )
}

/// The peak of a sweep's time-domain |δ1|/X_b: (frequency, height), refined by a parabola
/// through the highest point and its two neighbours (when it is interior). `None` without a
/// steady point.
pub fn peak(points: &[SweepPoint]) -> Option<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|p| {
            p.steady
                .as_ref()
                .map(|s| (p.frequency, s.transfer_magnitude()))
        })
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    peak_of(&v)
}

/// Peak of sampled (x, y) data sorted by x: the highest sample, refined by a parabola through it
/// and its two neighbours only when those three lie on one smooth branch. That needs a sample
/// beyond each neighbour, and the five points must be concave (the secant slopes decrease): at
/// the jump of a folded resonance curve the step down to the other branch is followed by a
/// flatter one, which concavity refuses, so the parabola is never fitted across a jump (it would
/// invent a peak above the data). Otherwise, and when a value is NaN, the highest sample itself.
pub fn peak_of(v: &[(f64, f64)]) -> Option<(f64, f64)> {
    let i = (0..v.len()).max_by(|&i, &j| v[i].1.total_cmp(&v[j].1))?;
    if i < 2 || i + 2 >= v.len() || !concave(&v[i - 2..=i + 2]) {
        return Some(v[i]);
    }
    let ((x0, y0), (x1, y1), (x2, y2)) = (v[i - 1], v[i], v[i + 1]);
    // y = y1 + p t + q t² in t = x − x1 (local coordinates: no cancellation).
    let (h0, h2) = (x0 - x1, x2 - x1);
    let (d0, d2) = (y0 - y1, y2 - y1);
    let det = h0 * h2 * (h2 - h0);
    let p = (d0 * h2 * h2 - d2 * h0 * h0) / det;
    let q = (d2 * h0 - d0 * h2) / det;
    if q.is_nan() || q >= 0.0 {
        return Some(v[i]);
    }
    let xv = x1 - p / (2.0 * q);
    let yv = y1 - p * p / (4.0 * q);
    if xv.is_finite() && yv.is_finite() && xv > x0 && xv < x2 {
        Some((xv, yv))
    } else {
        Some(v[i])
    }
}

/// True when the secant slopes of the points (sorted by x) never increase: one concave branch,
/// no jump. False for NaN or repeated x.
fn concave(v: &[(f64, f64)]) -> bool {
    let slopes: Vec<f64> = v
        .windows(2)
        .map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0))
        .collect();
    slopes.iter().all(|s| s.is_finite()) && slopes.windows(2).all(|s| s[1] <= s[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parabolic_peak_recovers_a_vertex() {
        let f = |x: f64| 3.0 - 0.01 * (x - 401.3) * (x - 401.3);
        let v: Vec<(f64, f64)> = (0..9)
            .map(|i| 396.0 + 2.0 * i as f64)
            .map(|x| (x, f(x)))
            .collect();
        let (x, y) = peak_of(&v).unwrap_or((0.0, 0.0));
        assert!(
            (x - 401.3).abs() < 1e-9 && (y - 3.0).abs() < 1e-9,
            "{x} {y}"
        );
        assert_eq!(frequencies(300.0, 500.0, 3), vec![300.0, 400.0, 500.0]);
        // A jump right after the maximum: the highest sample.
        let v = [(1.0, 5.0), (2.0, 9.0), (3.0, 10.0), (4.0, 3.0)];
        assert_eq!(peak_of(&v), Some((3.0, 10.0)));
    }

    /// A folded resonance curve sampled across its jump: the upper branch rises steeply to the
    /// fold, the next sample is on the lower branch. The neighbours are both above half the
    /// maximum, so a parabola through the three highest points would put a peak above every
    /// sample (the harmonic-balance "15.18 at 431 Hz" of `resonance --amp 1.5um`); the peak is
    /// the highest sample instead.
    #[test]
    fn no_parabola_across_a_fold_jump() {
        let upper = |f: f64| 15.0 - 2.0 * (434.0 - f).sqrt();
        let mut v: Vec<(f64, f64)> = (0..8)
            .map(|k| 420.0 + 2.0 * k as f64)
            .map(|f| (f, upper(f)))
            .collect();
        v.extend([(436.0, 9.0), (438.0, 8.6), (440.0, 8.2)]);
        let top = v.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let (f, h) = peak_of(&v).unwrap_or((0.0, 0.0));
        assert_eq!((f, h), (434.0, top), "peak {h} at {f}");
        // The old rule (neighbours above half the maximum) would have refined it above the data.
        let (x0, y0, y1, y2) = (432.0, upper(432.0), upper(434.0), 9.0);
        assert!(y0 > 0.5 * y1 && y2 > 0.5 * y1 && x0 < 434.0);
        // A smooth peak on the same grid is still refined between the samples.
        let smooth: Vec<(f64, f64)> = (0..11)
            .map(|k| 420.0 + 2.0 * k as f64)
            .map(|f| (f, 15.0 - 0.02 * (f - 433.1) * (f - 433.1)))
            .collect();
        let (f, h) = peak_of(&smooth).unwrap_or((0.0, 0.0));
        assert!(
            (f - 433.1).abs() < 1e-9 && (h - 15.0).abs() < 1e-9,
            "{f} {h}"
        );
    }
}
