//! Finite differences of an ensemble mean on a chaotic rig.
//!
//! With fixed phases, each member of an ensemble still jumps under any change of the parameters
//! (one ulp of input moves a chaotic pull-off by percent), so the mean of N members is a smooth
//! trend plus a noise that is white in the parameters, of about the mean's standard error. A
//! difference quotient over a step `2h` carries that noise divided by `2h`: with a step of the
//! size that suits the solver's error alone, the Jacobian is mostly noise, `JᵀWJ` is inflated by
//! the noise's square, and the parameters' σ come out too small (by about 1/√2 on the light rig
//! with 16 members at a step of 0.1, measured).
//!
//! So a column is taken as a central difference whose step is widened until the change of the
//! prediction across it stands [`TARGET_SNR`] times above the noise of that change, which makes
//! the noise's share of `JᵀWJ` about 1/[`TARGET_SNR`]² (1 %). The truncation error of a central
//! difference is second order in the step: at the widest step allowed ([`max_step`]) it is a
//! few percent of the slope for the power-law responses of the Gent–Schultz keys.

use super::free::Transform;
use super::model::Prediction;

/// The ratio of the signal (the change of the prediction across the stencil) to its noise that
/// a column must reach before its step stops widening.
pub const TARGET_SNR: f64 = 10.0;

/// The first half-step in the fit coordinate `y` (a relative step of 10 % for a key fitted in
/// log space); each column keeps the step it ends with for the next Jacobian.
pub const INITIAL_HALF_STEP: f64 = 0.1;

/// How many times a column's step may be widened in one Jacobian.
pub const MAX_WIDENINGS: usize = 3;

/// The largest widening factor of one round.
const MAX_FACTOR: f64 = 4.0;

/// The widest half-step in the fit coordinate `y` at `y`: 0.5 for a key fitted in log space (a
/// factor 1.65 either side), half the key's own size for a linear one (so that a stencil never
/// crosses zero; at least 0.1, as `y` is of order one at the start).
pub fn max_step(t: &Transform, y: f64) -> f64 {
    if t.log {
        0.5
    } else {
        0.5 * y.abs().max(0.2)
    }
}

/// The two points `(a, b)` of a central difference of half-step `h` about `y`, moved inside the
/// bounds (and narrowed to their span) where `y ± h` would leave them.
pub fn stencil(t: &Transform, y: f64, h: f64) -> (f64, f64) {
    let lo = t.lo.unwrap_or(f64::NEG_INFINITY);
    let hi = t.hi.unwrap_or(f64::INFINITY);
    let h = h.min(0.5 * (hi - lo));
    let (mut a, mut b) = (y - h, y + h);
    if b > hi {
        a -= b - hi;
        b = hi;
    }
    if a < lo {
        b = (b + (lo - a)).min(hi);
        a = lo;
    }
    (a, b)
}

/// The signal-to-noise ratio of one column: `signal2` is Σ (Δᵢ/wᵢ)², the weighted squared change
/// of the prediction across the stencil, and `noise2` is Σ 2 (sᵢ/wᵢ)², its expectation from the
/// noise alone (two independent means of standard error `sᵢ`). The noise's share is removed, so
/// that a change that is all noise has a ratio of 0.
pub fn snr(signal2: f64, noise2: f64) -> f64 {
    if noise2 <= 0.0 {
        return f64::INFINITY;
    }
    (signal2 / noise2 - 1.0).max(0.0).sqrt()
}

/// The next half-step of a column whose ratio `snr` is below [`TARGET_SNR`] at half-step `h`
/// (widened by at most [`MAX_FACTOR`] per round, to at most `h_max`), or `None` when it is good
/// enough or cannot widen.
pub fn widen(h: f64, snr: f64, h_max: f64) -> Option<f64> {
    if snr >= TARGET_SNR || h >= h_max {
        return None;
    }
    let factor = if snr > 0.0 {
        (TARGET_SNR / snr).min(MAX_FACTOR)
    } else {
        MAX_FACTOR
    };
    Some((h * factor).min(h_max))
}

/// Each row's standard error pooled over predictions: the root mean square (0 without any).
pub fn pooled_se(preds: &[Prediction]) -> Vec<f64> {
    let rows = preds.first().map_or(0, |p| p.se.len());
    (0..rows)
        .map(|i| (preds.iter().map(|p| p.se[i] * p.se[i]).sum::<f64>() / preds.len() as f64).sqrt())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::free::FreeKey;

    #[test]
    fn a_stencil_stays_inside_the_bounds_with_its_width() {
        let f = FreeKey::parse("adhesion.n=0.1:0.9").unwrap();
        let t = Transform::new(&f, 0.5);
        // y = x / 0.5: bounds 0.2 .. 1.8.
        let (a, b) = stencil(&t, 1.0, 0.3);
        assert!((a - 0.7).abs() < 1e-12 && (b - 1.3).abs() < 1e-12);
        let (a, b) = stencil(&t, 1.7, 0.3);
        assert!((b - 1.8).abs() < 1e-12 && (a - 1.2).abs() < 1e-12);
        let (a, b) = stencil(&t, 0.25, 0.3);
        assert!((a - 0.2).abs() < 1e-12 && (b - 0.8).abs() < 1e-12);
        // Wider than the span: the span.
        let (a, b) = stencil(&t, 1.0, 5.0);
        assert!((a - 0.2).abs() < 1e-12 && (b - 1.8).abs() < 1e-12);
        let free = Transform::new(&FreeKey::parse("adhesion.v0").unwrap(), 1e-4);
        assert_eq!(stencil(&free, -9.0, 0.5), (-9.5, -8.5));
    }

    /// A change that is all noise has ratio 0 and widens by the largest factor; a good one stops;
    /// a step at its limit stops.
    #[test]
    fn the_step_widens_until_the_signal_stands_above_the_noise() {
        assert!(snr(2.0, 2.0).abs() < 1e-15);
        assert!((snr(202.0, 2.0) - 10.0).abs() < 1e-12);
        assert!(snr(1.0, 0.0).is_infinite());
        assert_eq!(widen(0.1, 0.0, 0.5), Some(0.4));
        assert!((widen(0.1, 5.0, 0.5).unwrap() - 0.2).abs() < 1e-15);
        assert_eq!(widen(0.2, 5.0, 0.3), Some(0.3));
        assert_eq!(widen(0.1, 10.0, 0.5), None);
        assert_eq!(widen(0.5, 1.0, 0.5), None);
    }
}
