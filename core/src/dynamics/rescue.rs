//! A fast method paired with a robust one for the steps it cannot take ([`Rescued`]): how
//! `auto` runs DP8 with the implicit method beside it.

use super::model::{Drive, Model};
use super::state::{State, StepFail, StepOut, Tol};
use super::stepper::{Capabilities, Rescues, Stepper};

/// A fast method with a robust one for the steps it cannot take: where the primary refuses a
/// step in deep healing ([`StepFail::Stiff`]) or a trial stage meets the healing singularity
/// (G ≤ 0: ȧ = +∞, [`StepFail::Singular`]), that one step is taken by the rescue; the next step
/// tries the primary again. After [`Stepper::fallback`] the rescue takes every attempt for a
/// while. `auto` runs DP8 rescued by the implicit method.
#[derive(Debug, Default, Clone)]
pub struct Rescued<P, R> {
    primary: P,
    rescue: R,
    /// Steps the primary refused as too stiff.
    stiff: u64,
    /// Steps where a trial stage of the primary met G ≤ 0.
    singular: u64,
    /// Attempts still to be taken by the rescue after a fallback.
    forced: u32,
    /// Attempts taken by the rescue after fallbacks.
    fallbacks: u64,
    /// The last successful attempt was the rescue's.
    rescued_last: bool,
}

/// Attempts the rescue takes after a [`Stepper::fallback`].
const FALLBACK_ATTEMPTS: u32 = 64;

impl<P: Stepper, R: Stepper> Rescued<P, R> {
    /// `primary`, falling back to `rescue`.
    pub fn new(primary: P, rescue: R) -> Self {
        Self {
            primary,
            rescue,
            stiff: 0,
            singular: 0,
            forced: 0,
            fallbacks: 0,
            rescued_last: false,
        }
    }
}

impl<P: Stepper + Clone + 'static, R: Stepper + Clone + 'static> Stepper for Rescued<P, R> {
    fn fresh(&self) -> Box<dyn Stepper> {
        let mut p = self.primary.clone();
        let mut r = self.rescue.clone();
        p.reset();
        r.reset();
        Box::new(Rescued::new(p, r))
    }
    fn name(&self) -> &'static str {
        self.primary.name()
    }
    fn short_name(&self) -> &'static str {
        self.primary.short_name()
    }
    /// The primary's: the rescue takes single steps, which the primary's capabilities need not
    /// serve (a rescued step reports no turning point, and [`Stepper::rescued_last`] keeps it
    /// out of the period memory).
    fn capabilities(&self) -> Capabilities {
        self.primary.capabilities()
    }
    fn attempt(
        &mut self,
        model: &Model,
        drive: &Drive,
        y: &State,
        h: f64,
        tol: Tol,
        evals: &mut u64,
        out: &mut StepOut,
    ) -> Result<(), StepFail> {
        self.rescued_last = true;
        if self.forced > 0 {
            self.forced -= 1;
            self.fallbacks += 1;
            return self.rescue.attempt(model, drive, y, h, tol, evals, out);
        }
        match self.primary.attempt(model, drive, y, h, tol, evals, out) {
            Err(StepFail::Singular) => {
                self.singular += 1;
                self.rescue.attempt(model, drive, y, h, tol, evals, out)
            }
            Err(StepFail::Stiff) => {
                self.stiff += 1;
                self.rescue.attempt(model, drive, y, h, tol, evals, out)
            }
            r => {
                self.rescued_last = false;
                r
            }
        }
    }
    fn reset(&mut self) {
        self.primary.reset();
        self.rescue.reset();
    }
    fn rescued_last(&self) -> bool {
        self.rescued_last
    }
    fn rescues(&self) -> Rescues {
        Rescues {
            by: self.rescue.short_name(),
            stiff: self.stiff,
            singular: self.singular,
            fallback: self.fallbacks,
        }
    }
    fn fallback(&mut self) -> bool {
        if self.forced > 0 {
            // Already on the rescue: it failed too.
            return false;
        }
        self.forced = FALLBACK_ATTEMPTS;
        true
    }
}
