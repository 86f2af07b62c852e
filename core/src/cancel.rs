//! Cancelling a long computation from another thread.
//!
//! A [`Cancel`] token travels with the solver settings ([`crate::dynamics::Solver::cancel`]) into
//! every simulator a computation builds (a run, the shooting and time-stepping of `validate`, each
//! frequency of a resonance sweep). The simulator polls it with its wall-clock budget (about every
//! 64 units of work, tens of microseconds) and stops with [`crate::dynamics::SimError::Cancelled`].
//! The command line raises it on SIGINT or SIGTERM (`djkr run` then publishes what the run
//! computed); the Python binding raises the flag when the interpreter reports a
//! KeyboardInterrupt while the work runs on another thread.
//!
//! The token is a `Copy` reference to a flag with a `'static` lifetime, so that the solver
//! settings stay `Copy`. [`CancelFlag::acquire`] lends one of a fixed pool of flags and returns it
//! to the pool when dropped; a caller must not keep a token past its flag's guard.

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};

/// A cancellation token: none (the default), or a flag another thread may raise.
#[derive(Clone, Copy, Default)]
pub struct Cancel(Option<&'static AtomicBool>);

impl Cancel {
    /// No cancellation: the computation runs to its end or its budgets.
    pub const NONE: Cancel = Cancel(None);

    /// A token on a flag of the caller's own (e.g. the command line's signal flag, raised by
    /// SIGINT or SIGTERM).
    pub const fn from_static(flag: &'static AtomicBool) -> Cancel {
        Cancel(Some(flag))
    }

    /// True once the flag has been raised.
    #[inline]
    pub fn is_cancelled(&self) -> bool {
        self.0.is_some_and(|f| f.load(Ordering::Relaxed))
    }
}

/// A token is not part of what a computation computes: any two compare equal, so scenarios and
/// solver settings compare by their values alone.
impl PartialEq for Cancel {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl fmt::Debug for Cancel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            None => f.write_str("Cancel(none)"),
            Some(flag) => write!(f, "Cancel(raised: {})", flag.load(Ordering::Relaxed)),
        }
    }
}

/// Flags in the pool: concurrent cancellable computations before the pool falls back to a
/// leaked flag (one byte each).
const POOL: usize = 64;

#[allow(clippy::declare_interior_mutable_const)]
const LOWERED: AtomicBool = AtomicBool::new(false);
static FLAGS: [AtomicBool; POOL] = [LOWERED; POOL];
static IN_USE: [AtomicBool; POOL] = [LOWERED; POOL];

/// A cancellation flag lent from a fixed pool: [`token`](Self::token) for the computation,
/// [`cancel`](Self::cancel) from any thread; returned to the pool on drop.
#[derive(Debug)]
pub struct CancelFlag {
    flag: &'static AtomicBool,
    slot: Option<usize>,
}

impl CancelFlag {
    /// A lowered flag.
    pub fn acquire() -> Self {
        for (i, used) in IN_USE.iter().enumerate() {
            if used
                .compare_exchange(false, true, Ordering::AcqRel, Ordering::Relaxed)
                .is_ok()
            {
                FLAGS[i].store(false, Ordering::SeqCst);
                return Self {
                    flag: &FLAGS[i],
                    slot: Some(i),
                };
            }
        }
        // More than POOL computations at once: a flag of its own, never freed.
        Self {
            flag: Box::leak(Box::new(AtomicBool::new(false))),
            slot: None,
        }
    }

    /// The token to hand to the computation.
    pub fn token(&self) -> Cancel {
        Cancel(Some(self.flag))
    }

    /// The flag itself (for APIs that take an `AtomicBool`, such as a sweep's stop request).
    pub fn flag(&self) -> &'static AtomicBool {
        self.flag
    }

    /// Raise the flag: the computation stops at its next poll.
    pub fn cancel(&self) {
        self.flag.store(true, Ordering::SeqCst);
    }

    /// True once raised.
    pub fn is_cancelled(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
    }
}

impl Drop for CancelFlag {
    fn drop(&mut self) {
        if let Some(i) = self.slot {
            IN_USE[i].store(false, Ordering::Release);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_raised_flag_cancels_its_token_only() {
        let a = CancelFlag::acquire();
        let b = CancelFlag::acquire();
        assert!(!a.token().is_cancelled() && !b.token().is_cancelled());
        a.cancel();
        assert!(a.token().is_cancelled());
        assert!(!b.token().is_cancelled());
        assert!(!Cancel::NONE.is_cancelled());
        assert_eq!(a.token(), Cancel::NONE);
    }

    #[test]
    fn a_returned_flag_comes_back_lowered() {
        let held: Vec<CancelFlag> = (0..POOL + 3).map(|_| CancelFlag::acquire()).collect();
        for f in &held {
            f.cancel();
        }
        drop(held);
        let again = CancelFlag::acquire();
        assert!(!again.is_cancelled());
    }
}
