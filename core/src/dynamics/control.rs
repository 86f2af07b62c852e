//! Step-size control: the proposal for the next attempt, its growth after an accepted step and
//! its shrinking after a rejected one, the turning points of the contact line that some methods'
//! steps must end on, and what the last base period's attempts teach the next one. What applies
//! to a method is what its [`Capabilities`] say (DP8 has them all), never its name.
//!
//! # The last period as a guide
//! Under a steady shaker the solution repeats from one base period to the next, and so does the
//! difficulty of each stretch of the period. The elementary controller only extrapolates the
//! last step's error, and where the difficulty rises steeply along the period it overshoots
//! every period anew: on the compiled peer's benchmark scene (1 s at 400 Hz, rtol 1e-7, every
//! period integrated) the stretch of fast healing after each turning point of the contact line
//! took four rejected attempts per period, their errors 3–18 times the tolerance, the error at
//! one step length growing 40-fold from one step to the next (1 347 rejected attempts of
//! 7 388, 18 % of the evaluations). So the controller of a method with
//! [`Capabilities::period_memory`] (DP8) remembers, by their start within the
//! period, the attempts of the last period that were rejected or whose length the memory itself
//! held down (guards), with their lengths and errors; ℓ_g, the length a guard's error scales to
//! 0.7 of the tolerance by err ∝ h⁸, is what it allows from its start s_g. An attempt into
//! which a guard's start falls (or that starts within ℓ_g/4 after it) ends no later than
//! s_g + ℓ_g, shortened at most 5×. Only guards count: a cap from every attempt of the last
//! period was measured to pin each step to its last length and cost 4 % more steps on the
//! bundled paper protocols, where rejections are rare. Guards persist as long as they hold a
//! step down and relax as its error falls. The memory only shortens proposals (the error test
//! still decides every step), so it costs accuracy nothing; attempts of a rescuing implicit
//! method are not remembered (where it takes over, the steps collapse for reasons the next
//! period need not share), and the trial periods of envelope following start from the run's
//! memory, its errors rescaled to their tolerances. Measured (evaluations): that scene
//! 90 491 → 73 737 (rejected attempts 1 735 → 444), with envelope following 22 618 → 21 464;
//! the 300 Hz paper protocol at X_b = 100 / 150 µm 1 648 105 → 1 580 064 and
//! 3 028 451 → 2 927 141; `scenarios/impacts.toml` 1 092 339 → 966 596; the bundled 10 µm
//! protocols within 0.05 % and the resonance scene unchanged (few rejections to prevent). Not
//! every rejection goes: an attempt that starts beyond a guard's reach and ends before the next
//! guard's start is not held (the unit test's model keeps about a quarter of them).

use super::stepper::{Capabilities, Reach};

/// The step-size state carried from one attempt to the next.
#[derive(Debug, Clone, PartialEq)]
pub struct StepControl {
    /// The proposed length of the next step (s).
    pub h: f64,
    /// The last attempt was rejected (the next accepted step may not grow).
    rejected_last: bool,
    /// The current attempt was already shortened to end at a turning point of the contact line.
    kink_cut: bool,
    /// Predicted time of the next turning point of the contact line (a method with
    /// [`Capabilities::turning_points`]), to end a step there.
    kink_ahead: Option<f64>,
    /// The next attempt's length when the last one was cut back to a turning point (the step
    /// proposal `h` is kept for the step after it).
    h_cut: Option<f64>,
    /// The last base period's attempts (a method with [`Capabilities::period_memory`] under a
    /// steady shaker).
    memory: PeriodMemory,
    /// The current attempt's start within its base period (s), when the memory applies.
    offset: Option<f64>,
    /// The current attempt's length was held down by the memory.
    guarded: bool,
}

/// The error (as a fraction of the tolerance) a remembered attempt's length is scaled to: the
/// memory only keeps the controller from overshooting, it does not tighten it (the controller
/// itself aims at 0.9⁸ ≈ 0.43).
const MEMORY_TARGET: f64 = 0.7;

/// The memory shortens a proposal at most this many times (the overshoots it corrects were 3–4
/// times the step).
const MEMORY_SHRINK: f64 = 5.0;

/// Most guards a period's memory holds; a period that makes more (deep healing, impacts) is not
/// remembered.
const MEMORY_ATTEMPTS: usize = 512;

/// One remembered attempt that guards the next period: its start within the period (s), length
/// (s), error estimate (as a fraction of the tolerance) and the exponent of its controller.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Guard {
    s: f64,
    h: f64,
    err: f64,
    e: f64,
    /// The longest attempt from `s` whose error the rule err ∝ h^(1/e) puts at
    /// [`MEMORY_TARGET`] of the tolerance (at most 5 h).
    allows: f64,
}

impl Guard {
    fn new(s: f64, h: f64, err: f64, e: f64) -> Self {
        let allows = if err > 0.0 {
            h * (MEMORY_TARGET / err).powf(e).min(5.0)
        } else {
            5.0 * h
        };
        Self {
            s,
            h,
            err,
            e,
            allows,
        }
    }
}

/// The guards of the last complete base period and of the current one, in the order they were
/// made (so by their start within the period).
#[derive(Debug, Clone, Default, PartialEq)]
struct PeriodMemory {
    last: Vec<Guard>,
    current: Vec<Guard>,
    /// The current period made more than [`MEMORY_ATTEMPTS`] guards.
    overflow: bool,
}

impl PeriodMemory {
    fn remember(&mut self, g: Guard) {
        if self.current.len() >= MEMORY_ATTEMPTS {
            self.overflow = true;
        } else {
            self.current.push(g);
        }
    }

    /// The longest attempt from offset `s`, proposed `h` long, the last period's guards allow:
    /// it may not end beyond s_g + ℓ_g for a guard that starts within it (or a quarter of ℓ_g
    /// before it), ℓ_g the length the guard allows from its start s_g (∞ without such a guard).
    /// No attempt is longer than `h_max`, so no ℓ_g exceeds 5 `h_max`.
    fn cap(&self, s: f64, h: f64, h_max: f64) -> f64 {
        let from = self.last.partition_point(|g| g.s < s - 1.25 * h_max);
        self.last[from..]
            .iter()
            .take_while(|g| g.s < s + h)
            .filter(|g| g.s >= s - 0.25 * g.allows)
            .map(|g| g.s + g.allows - s)
            .fold(f64::INFINITY, f64::min)
    }

    /// A new period starts: the current one becomes the last.
    fn next_period(&mut self) {
        if self.overflow {
            self.current.clear();
        }
        self.overflow = false;
        std::mem::swap(&mut self.last, &mut self.current);
        self.current.clear();
    }

    fn clear(&mut self) {
        self.last.clear();
        self.current.clear();
        self.overflow = false;
    }
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
            memory: PeriodMemory::default(),
            offset: None,
            guarded: false,
        }
    }

    /// Forget the predicted turning point (the drive or the state changed).
    pub fn reset(&mut self) {
        self.kink_ahead = None;
    }

    /// A base period ends: its attempts become the guide of the next one.
    pub fn next_period(&mut self) {
        self.memory.next_period();
    }

    /// A fresh controller for a trial period at `tol_factor` times the tolerances, starting from
    /// the current proposal and guided by the last period's attempts, their errors measured
    /// against the trial's tolerances.
    pub fn for_trial(&self, tol_factor: f64) -> Self {
        let mut c = Self::new(self.h);
        c.memory.last = self
            .memory
            .last
            .iter()
            .map(|g| Guard::new(g.s, g.h, g.err / tol_factor, g.e))
            .collect();
        c
    }

    /// Forget the remembered periods (the shaker stopped or restarted, the method changed).
    pub fn forget_periods(&mut self) {
        self.memory.clear();
    }

    /// The next attempt from time `t`, at most `h_max` long, for a method that provides `caps`:
    /// the proposal, cut back to a turning point of the contact line where the last attempt
    /// straddled one, or ended on the predicted one ([`Capabilities::turning_points`]); kept to
    /// half of `h_max` as [`Capabilities::reach`] says (1/16 of a base period: cubic Hermite
    /// error ≈ (ωh)⁴/384 ≈ 6e-5 of the amplitude, against 1e-3 at 1/8). `offset`: `t`'s time
    /// since the start of its base period under a steady shaker (`None` otherwise); the
    /// attempts of a method with [`Capabilities::period_memory`] then follow the last period's
    /// (module docs).
    pub fn propose(
        &mut self,
        t: f64,
        h_max: f64,
        caps: Capabilities,
        interpolated_samples: bool,
        offset: Option<f64>,
    ) -> Proposal {
        let mut h = self.h.min(h_max);
        let halved = match caps.reach {
            Reach::Full => false,
            Reach::HalfForSamples => interpolated_samples,
            Reach::Half => true,
        };
        if halved {
            h = h.min(0.5 * h_max);
        }
        self.offset = offset.filter(|_| caps.period_memory);
        if let Some(s) = self.offset {
            let cap = self.memory.cap(s, h, h_max);
            // At most a factor MEMORY_SHRINK: a guard only corrects the controller's overshoot.
            let cap = cap.max(h / MEMORY_SHRINK);
            self.guarded = cap < h;
            h = h.min(cap);
        }
        let mut shortened = false;
        if let Some(hc) = self.h_cut.take() {
            h = h.min(hc);
            shortened = true;
        } else if let (true, Some(tk)) = (caps.turning_points, self.kink_ahead) {
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
        self.remember(err, e, h, true);
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
        self.remember(err, e, h, false);
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

    /// The current attempt is not to guide the next period: a rescue method took it
    /// ([`super::stepper::Stepper::rescued_last`]; where a rescuing implicit method takes over,
    /// in deep healing, the step collapses for reasons the next period need not share).
    pub fn not_remembered(&mut self) {
        self.offset = None;
    }

    /// Keep the attempt of length `h` (error `err`, controller exponent `e`) for the next
    /// period, when the memory applies.
    fn remember(&mut self, err: f64, e: f64, h: f64, rejected: bool) {
        if let Some(s) = self.offset.take() {
            if (rejected || self.guarded) && err.is_finite() {
                self.memory.remember(Guard::new(s, h, err, e));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The capabilities of DP8, whose steps the period memory was made for.
    const DP8: Capabilities = Capabilities {
        algebraic_radius: false,
        turning_points: true,
        period_memory: true,
        reach: Reach::HalfForSamples,
    };

    /// Steps of a model problem over `periods` base periods of length 1 under the controller,
    /// with (`memory`) or without the last period as a guide: an attempt of length h from s
    /// has the error (h/ℓ)⁸, ℓ the smallest local step scale over [s, s + h]; ℓ = 1/8 except
    /// on [0.5, 0.6), where it falls 55-fold (the stretch of fast healing after a turning
    /// point). Returns the rejected and accepted attempts of each period.
    fn model_periods(periods: usize, memory: bool) -> Vec<(usize, usize)> {
        let scale = |s: f64| {
            if (0.5..0.6).contains(&s) {
                0.125 * (-40.0 * (s - 0.5)).exp()
            } else {
                0.125
            }
        };
        let smallest = |s0: f64, s1: f64| {
            (0..=64)
                .map(|i| scale(s0 + (s1 - s0) * i as f64 / 64.0))
                .fold(f64::INFINITY, f64::min)
        };
        let mut c = StepControl::new(0.01);
        let mut out = Vec::new();
        for p in 0..periods {
            let (mut rejected, mut accepted) = (0, 0);
            let mut s = 0.0;
            while s < 1.0 - 1e-12 {
                let t = p as f64 + s;
                let prop = c.propose(t, 0.125, DP8, false, memory.then_some(s));
                let clipped = prop.h >= 1.0 - s;
                let h = prop.h.min(1.0 - s);
                let err = (h / smallest(s, s + h)).powi(8);
                if err > 1.0 {
                    c.reject(err, 0.125, h);
                    rejected += 1;
                } else {
                    c.accept(err, 0.125, h, clipped, None);
                    accepted += 1;
                    s += h;
                }
            }
            c.next_period();
            out.push((rejected, accepted));
        }
        out
    }

    /// Where the difficulty rises steeply at the same place every period, the elementary
    /// controller is rejected there every period; remembering the last period's guards takes
    /// away most of those rejections once the pattern has been seen (not all: an attempt that
    /// starts between two guards' reach is not held), without more accepted steps.
    #[test]
    fn the_last_period_guards_the_next() {
        let plain = model_periods(8, false);
        let guided = model_periods(8, true);
        let steady =
            |v: &[(usize, usize)]| v[4..].iter().fold((0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        let (rej_plain, acc_plain) = steady(&plain);
        let (rej_guided, acc_guided) = steady(&guided);
        assert!(
            rej_plain >= 8,
            "the model should reject every period: {plain:?}"
        );
        assert!(
            rej_guided * 2 <= rej_plain,
            "guided {guided:?} against plain {plain:?}"
        );
        assert!(
            acc_guided as f64 <= 1.1 * acc_plain as f64,
            "guided {guided:?} against plain {plain:?}"
        );
        // The first period has nothing to remember: the same attempts.
        assert_eq!(plain[0], guided[0]);
    }

    /// The memory only shortens: with it a proposal is never longer than without.
    #[test]
    fn the_memory_never_lengthens_a_proposal() {
        let mut c = StepControl::new(0.05);
        let h = c.propose(0.0, 0.125, DP8, false, Some(0.0)).h;
        c.reject(9.0, 0.125, h);
        let h = c.propose(0.0, 0.125, DP8, false, Some(0.0)).h;
        c.accept(1e-6, 0.125, h, false, None);
        c.next_period();
        let mut plain = c.clone();
        plain.forget_periods();
        for s in [0.0, 0.001, 0.0125, 0.5] {
            let with = c.clone().propose(s, 0.125, DP8, false, Some(s));
            let without = plain.clone().propose(s, 0.125, DP8, false, None);
            assert!(with.h <= without.h, "{s}: {} > {}", with.h, without.h);
        }
    }
}
