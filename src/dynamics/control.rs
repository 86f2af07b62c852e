//! Step-size control: the proposal for the next attempt, its growth after an accepted step and
//! its shrinking after a rejected one, and the turning points of the contact line that DP8's
//! steps must end on.

use super::stepper::StepperKind;

/// The step-size state carried from one attempt to the next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepControl {
    /// The proposed length of the next step (s).
    pub h: f64,
    /// The last attempt was rejected (the next accepted step may not grow).
    rejected_last: bool,
    /// The current attempt was already shortened to end at a turning point of the contact line.
    kink_cut: bool,
    /// Predicted time of the next turning point of the contact line (DP8), to end a step there.
    kink_ahead: Option<f64>,
    /// The next attempt's length when the last one was cut back to a turning point (the step
    /// proposal `h` is kept for the step after it).
    h_cut: Option<f64>,
}

/// A step length to attempt.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proposal {
    /// Length (s).
    pub h: f64,
    /// Shortened to end on a turning point: the proposal for the step after it is kept.
    pub shortened: bool,
}

impl StepControl {
    /// Start with a first step of `h` (s).
    pub fn new(h: f64) -> Self {
        Self {
            h,
            rejected_last: false,
            kink_cut: false,
            kink_ahead: None,
            h_cut: None,
        }
    }

    /// Forget the predicted turning point (the drive or the state changed).
    pub fn reset(&mut self) {
        self.kink_ahead = None;
    }

    /// The next attempt from time `t`, at most `h_max` long: the proposal, cut back to a
    /// turning point of the contact line where the last attempt straddled one, or ended on the
    /// predicted one (DP8). Macro steps, and DP8's long steps when samples are interpolated on a
    /// time grid, are kept to half of `h_max` (1/16 of a base period: cubic Hermite error
    /// ≈ (ωh)⁴/384 ≈ 6e-5 of the amplitude, against 1e-3 at 1/8).
    pub fn propose(
        &mut self,
        t: f64,
        h_max: f64,
        kind: StepperKind,
        interpolated_samples: bool,
    ) -> Proposal {
        let mut h = self.h.min(h_max);
        if kind == StepperKind::Macro
            || (kind == StepperKind::TurningPoints && interpolated_samples)
        {
            h = h.min(0.5 * h_max);
        }
        let mut shortened = false;
        if let Some(hc) = self.h_cut.take() {
            h = h.min(hc);
            shortened = true;
        } else if let (StepperKind::TurningPoints, Some(tk)) = (kind, self.kink_ahead) {
            // End the step at the predicted turning point rather than cut it afterwards.
            let d = tk - t;
            if d > 0.05 * h && d < h {
                h = d;
                shortened = true;
            }
        }
        Proposal { h, shortened }
    }

    /// Set the proposal to `factor` × `h` after a failed attempt of length `h`; returns it.
    pub fn shrink(&mut self, h: f64, factor: f64) -> f64 {
        self.h = factor * h;
        self.h
    }

    /// A step of length `h` whose contact line turns at `fraction` of it is redone to end there,
    /// once: ȧ ∝ |G − w0|^(1/n) is not smooth at the turning point, and the 8th-order weights
    /// integrate that singular part ~600× better from one side (DOP853 weights on τ^1.88:
    /// 1.4e-5 of the integral, against up to 8.6e-3 when it lies inside). True when the attempt
    /// is to be redone.
    pub fn redo_at_turning_point(&mut self, fraction: Option<f64>, h: f64, h_min: f64) -> bool {
        if let Some(f) = fraction {
            if !self.kink_cut && f > 0.02 && f < 0.98 && h * f > h_min {
                self.kink_cut = true;
                self.h_cut = Some(h * f);
                return true;
            }
        }
        self.kink_cut = false;
        false
    }

    /// The error estimate `err` > 1 of an attempt of length `h` rejects it: the proposal shrinks
    /// by 0.9 err^(−e) within [0.1, 0.9]; returns it.
    pub fn reject(&mut self, err: f64, e: f64, h: f64) -> f64 {
        self.rejected_last = true;
        let fac = (0.9 * err.powf(-e)).clamp(0.1, 0.9);
        self.h = h * fac;
        self.h
    }

    /// An accepted step of length `h` with error estimate `err` (exponent `e`). Elementary
    /// control 0.9 err^(−e) within [0.2, 5], with no growth right after a rejection (Hairer's
    /// rule); a step clipped to a boundary (`keep`: it hit a stage end or a period boundary, or
    /// was shortened to a turning point) keeps the larger of the old proposal and the new one.
    /// `kink_ahead` is the stepper's prediction of the next turning point. A PI controller
    /// (Gustafsson, h err^(−α) err_prev^β with α = 1/4 − 0.75 β) was measured on 1 s at 400 Hz
    /// with the implicit method: β = 0.04…0.12 cut rejections 1.4–100× but added as many
    /// accepted steps, at an unchanged error per evaluation, so the simpler rule stays.
    pub fn accept(&mut self, err: f64, e: f64, h: f64, keep: bool, kink_ahead: Option<f64>) {
        let mut fac = if err > 0.0 {
            (0.9 * err.powf(-e)).clamp(0.2, 5.0)
        } else {
            5.0
        };
        if self.rejected_last {
            fac = fac.min(1.0);
            self.rejected_last = false;
        }
        let h_next = h * fac;
        self.h = if keep { self.h.max(h_next) } else { h_next };
        self.kink_ahead = kink_ahead;
    }
}
