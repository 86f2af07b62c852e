//! State events within a step: which functions of the state are watched, when they have
//! crossed, and where (located by Illinois regula falsi on the step length, every trial a fresh
//! step from the step's start, so a located state is as accurate as any step).

use super::state::State;

/// A state function whose zero crossing is an event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Watch {
    /// a − a_floor, falling through 0: the contact is lost.
    Loss,
    /// δ, rising through 0 out of contact: impact.
    Impact,
    /// F − P, rising through 0: the preload P of an approach stage is reached.
    Preload(f64),
}

impl Watch {
    /// True when the watched function has crossed between the pre-event value `g0` and `g1`.
    pub fn crossed(self, g0: f64, g1: f64) -> bool {
        match self {
            Watch::Loss => g0 > 0.0 && g1 <= 0.0,
            Watch::Impact | Watch::Preload(_) => g0 < 0.0 && g1 >= 0.0,
        }
    }
}

/// Locate the crossing of a watched function `g` within the step `y0` → `y1` (length `h`) to
/// `t_tol` in time. `trial(dt)` takes a fresh step of length dt from `y0` (`None` when its stage
/// solve fails: the contact has collapsed before, and `g(None)` values that side); returns the
/// post-event state, or the pre-event one when the post side has no state.
pub fn locate(
    w: Watch,
    y0: &State,
    y1: Option<State>,
    h: f64,
    t_tol: f64,
    g: impl Fn(Option<&State>) -> f64,
    mut trial: impl FnMut(f64) -> Option<State>,
) -> State {
    let (mut lo, mut glo, mut ylo) = (0.0, g(Some(y0)), *y0);
    let (mut hi, mut ghi, mut yhi) = (h, g(y1.as_ref()), y1);
    let mut side = 0i32;
    for _ in 0..200 {
        if hi - lo <= t_tol {
            break;
        }
        let mut th = (lo * ghi - hi * glo) / (ghi - glo);
        if !th.is_finite() || th <= lo || th >= hi {
            th = 0.5 * (lo + hi);
        }
        // Keep trial points away from the ends so the bracket always shrinks.
        let span = hi - lo;
        th = th.clamp(lo + 1e-3 * span, hi - 1e-3 * span);
        let yt = trial(th);
        let gt = g(yt.as_ref());
        if w.crossed(glo, gt) {
            hi = th;
            ghi = gt;
            yhi = yt;
            if side == 1 {
                glo *= 0.5;
            }
            side = 1;
        } else {
            lo = th;
            glo = gt;
            if let Some(y) = yt {
                ylo = y;
            }
            if side == -1 {
                ghi *= 0.5;
            }
            side = -1;
        }
    }
    match yhi {
        Some(y) => y,
        None => ylo,
    }
}
