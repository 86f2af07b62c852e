//! The time-domain simulator: eqs. (30)–(32) with a rate-dependent JKR contact, events and a
//! stage protocol.
//!
//! ```text
//! m ẍ_s + c ẋ_s + k (x_s − x_k(t)) = −F + m g        (30)   (or c δ̇ in contact: damping "contact")
//! x_b = X_b sin ω(t − t_on) while the shaker is on    (31)
//! δ = x_s + x_b,  F = (K a/2)(3δ − a²/R) in contact   (32)
//! contact radius:  G_s(a, δ) = w(ȧ),  G_s = 3K u|u|/(8πa),  u = a²/R − δ
//! ```
//!
//! Entry points: [`run`]`(&Plan, &mut dyn Observer) -> Result<RunResult, SimError>` for
//! a whole protocol (the `djkr` crate's `Scenario::simulate` builds the [`Plan`]), and
//! [`Simulator`], whose `step()` advances one accepted step (or to the next event,
//! period boundary or target) for callers that drive the time loop themselves (steady-state
//! shooting, continuation, envelope following).
//!
//! What a user composes is re-exported here: the plan and its stages ([`Plan`], [`Initial`],
//! [`Stage`], [`StageKind`], [`Until`]), the solver settings ([`Solver`], [`Method`]), the
//! results and the observer interface ([`RunResult`], [`Sample`], [`Event`], [`CycleRecord`],
//! [`Observer`]), the simulator ([`Simulator`], [`Stop`]), and the one interface of the
//! integrators with the state it steps ([`Stepper`], [`Capabilities`], [`State`], [`StepOut`],
//! [`Tol`]). Three namespaces are public: [`model`], the pure physics of one instant;
//! [`protocol`], the stages and the run; [`methods`], the registry of method names, `auto`'s
//! choice and the solver settings. [`kernels`] exposes single steps for tests and benches.
//! The rest is internal (files under `core/src/dynamics/`): `esdirk` the implicit stepper,
//! `dp8` the explicit DP8 stepper, `ode_adapter` the `ode_solvers` methods, `rescue` a method
//! rescued by another, `control` step-size control, `events` event location, `envelope`
//! envelope following, `simulator`, `state`, `stepper` and `types` (re-exported above). The
//! reference scenes shared by tests and benchmarks are the `djkr` crate's `catalogue`.
//!
//! # Methods
//!
//! **Implicit.** Kennedy & Carpenter's `ESDIRK4(3)6L[2]SA` (the implicit
//! table of `ARK4(3)6L[2]SA`; order conditions checked in a unit test) applied to the whole state
//! (x_s, v_s, a). Why not an IMEX split: the explicit half of an ARK pair needs ȧ at the start of
//! each step from the state, which is the singular evaluation this method exists to avoid; a
//! fully implicit *stiffly accurate* ESDIRK instead ends each step on a solved stage, whose ȧ is
//! the exact rate of the new state and is reused as the next step's explicit first stage. The
//! cost of treating the mechanics implicitly is nil: at fixed a, F is linear in δ, so each
//! stage's (x_s, v_s) follow in closed form from a, and every stage is **one scalar root** in a:
//! ρ(a) = (G_s(a, δ(a)) − w((a − c_i)/(hγ)))/w0. It is bounded everywhere (no infinite speeds:
//! a compressive edge, G → 0 and a constant w, where it is the algebraic G = w0, are harmless)
//! and increasing through the wanted root (the stable branch). L-stability removes the healing
//! stiffness ∂ȧ/∂a ≈ −4aȧ/(nRu).
//!
//! *Stage solve* (`esdirk`): safeguarded Newton with the analytic dρ/da (closed forms of
//! ∂x/∂a of the stage's linear mechanics, ∂G_s/∂a, dw/dȧ). For Gent–Schultz with n < 1 the
//! unknown is the law variable z = sign(ȧ)(|ȧ|/v0)^n instead of a: w(z) is C¹ with slope −w0
//! and a(z) = c_i + hγ v0 sign(z)|z|^(1/n) is C¹, so the residual is regular through the turning
//! points ȧ = 0 where ρ(a) has an infinite slope (Newton in a failed there on 3 % of stages;
//! in z never). The predictor extrapolates z linearly over the previous stages (z is linear in
//! time through a turning point, ȧ is not). Stop: Newton step below 10⁻² rtol, or the measured
//! quadratic contraction K = |Δ_k|/|Δ_{k−1}|² predicting K Δ_k² below it; on a stage's first
//! step, K is the one measured on the previous stage of the same step (× 4), so a good
//! predictor is accepted after one residual. |z|^(1/n) as exp(ln|z|/n). (Accepting the first
//! Newton step unconditionally made the 1 s / 400 Hz outputs 100× less accurate; the measured-K
//! test leaves them unchanged to < 1 %.) Fall-back for the other laws, a
//! non-monotone residual or no convergence in 12 iterations: the derivative-free secant /
//! bracketing + Brent search (`roots`, `numerics::RelativeConvergency`), which keeps
//! every former guarantee (a root with a > 0 or [`StepFail::NoRoot`]).
//!
//! Error norm: x_s, v_s, a (RMS of err/(atol·scale + rtol·|y|), scales: the larger of the jump-in
//! indentation a_J²/R, X_b and the initial gap; that length × 2π/t_char; a_J); elementary step
//! control 0.9 err^(−1/4) (a PI controller, β = 0.04…0.12, was measured: fewer rejections, as many
//! more accepted steps, the same error per rhs evaluation). Quadrature states are accumulated
//! stage by stage with the weights b (stage 2 has b = 0 and is skipped) and **excluded** from the
//! error norm (they do not feed back; the steps the state needs resolve them: the per-cycle
//! momentum and energy balances they carry hold to integration accuracy, `docs/studies/checks.md`).
//!
//! **DP8** (`dp8`): Dormand & Prince's explicit 8(5,3) pair (Hairer's `DOP853` coefficients;
//! order conditions and the fixed-step order 8 are tested), djkr's own stepper, taking
//! one step at a time in the simulator's loop like the implicit one, with ȧ = law⁻¹(G) in closed
//! form. What makes an explicit method work on this problem:
//! - *The healing singularity fails a step, not the run.* A trial stage with G ≤ 0 (ȧ = +∞)
//!   rejects the step ([`state::StepFail::Singular`]); the simulator shortens it, or under `auto`
//!   takes that one step with the implicit method. A stage with a ≤ 0 reports a collapsing
//!   contact, as an implicit stage does.
//! - *Steps end on the turning points of the contact line.* ȧ ∝ |G − w0|^(1/n) is singular where
//!   ȧ changes sign (a − a_k ∝ |t − t_k|^(1+1/n)). The DOP853 weights integrate |τ|^1.88 with an
//!   error up to 8.6e-3 of the integral when the turning point lies inside the step, and 1.4e-5
//!   from one side. The turning point is located on the cubic Hermite interpolant of G (G and Ġ
//!   at both step ends, exact to the step's order), predicted from it for the next step, and a
//!   step that still straddles one is redone up to it.
//! - *An error estimate that sees the contact radius.* Hairer's combination of the 5th- and
//!   3rd-order estimates, over x_s, v_s, a with the implicit stepper's scales, and in addition the
//!   contact radius's own 5th-order estimate. The combination alone understated a's local error
//!   up to 70× at turning points and in deep healing (measured against 64-substep references),
//!   and the global error then stalled near 1e-5 whatever the tolerance.
//! - Cost: first same as last (the end evaluation starts the next step); the quadrature
//!   integrands go straight into the stage sum (only x_s, v_s, a form stages); one `sin_cos` per
//!   step, the stages advancing the base phase by series ([`model::Drive::at_advanced`]).
//!   Control 0.9 err^(−1/8) in [0.2, 5], no growth right after a rejection.
//!
//! **Dopri5 and Dop853 from `ode_solvers`**, on (x_s, v_s, a, quadratures, time), scaled so the
//! crate's scalar tolerances act per component (quadratures kept with a loose weight, 1e-6). The
//! crate has no event location and its Dense output is unreliable, so it is used as a macro-step
//! engine: the adapter picks spans that never cross stage ends or base-period boundaries, scans
//! each for events and locates them by re-integrating from the span's start. The time is a state
//! component because the crate's Dop853 tableau has c₁₂ = 0 instead of 1 (its 12th stage ran at
//! the wrong time; srenevey/ode-solvers PR #42): as an autonomous system it is exact. Neither
//! can reject a step whose stage meets G ≤ 0: an explicitly requested one then fails with
//! [`SimError::Explicit`] naming time and state; a finite-time collapse a → 0 (step-size
//! underflow in contact) is handed to the simulator like a failed implicit stage.
//!
//! **Auto** ([`methods::auto_method`]): the implicit method for a rate-independent law (a is
//! algebraic: no explicit rate), for seeded contact formation (healing from G ≈ 0 after every
//! impact) and without inertia (rigid link, m = 0: there neither method wins everywhere); DP8
//! otherwise, taking single steps implicitly where a DP8 stage meets G ≤ 0 (counted in
//! `RunResult::method`).
//!
//! **Which method when** (measured per scene in `docs/studies/methods.md`, regenerated by
//! `cargo run --release --example study_methods -- --full`; error against cost per bundled scene
//! in `docs/accuracy/`, regenerated by `djkr accuracy`):
//! - the Gent–Schultz law with inertia, with or without vibration, up to healing to
//!   G/w0 ≈ 0.01 each cycle and impacts: DP8 (`auto`), several times faster than the implicit
//!   method at equal accuracy (at equal rtol faster and far more accurate; with impacts every
//!   cycle about as fast and far more accurate);
//! - without inertia (rigid link, m = 0) the two trade places: DP8 is faster on a slow GS unload,
//!   slower under a 400 Hz base (its reduced right-hand side solves the position twice); `auto`
//!   takes the implicit method ([`methods::auto_method`] quotes the measured ratios);
//! - constant w, seeded contact: the implicit method (`auto`);
//! - Dopri5, Dop853: only for comparison (a trial stage meeting G ≤ 0 ends the run; per-span
//!   restarts).

//! # Reduced models ("model only what a scene requires")
//!
//! - No base motion: no shaker, no cycles (sin θ = cos θ = 0 in the quadratures).
//! - Rate-independent law (`Law::Constant`, no adhesion section): a is algebraic, G(a, δ) = w0,
//!   solved by the same stage root (the rate no longer enters); always the implicit method.
//! - `Holder::Rigid`: x_s = x_k(t), δ = x_k + x_b prescribed; only a (and the quadratures) is
//!   integrated. The holder force reported is the link's quasi-static reaction F − m g.
//! - m = 0 (with a spring): quasi-static balance k(x_k − x_s) = F(a, x_s + x_b) solved for x_s in
//!   closed form at each a (F is linear in δ), ẋ_s by the chain rule; only a is integrated.
//!   Gravity vanishes with m. With damping the balance would become an ODE in x_s: not
//!   supported (a clear [`SimError::Setup`]); m = 0 without a holder is rejected too.
//! - `Holder::None`: k = 0; a preload must equal the weight m g (else `Setup` error); from a gap
//!   the sphere falls under gravity.
//!
//! # Events (each with time and state, to `Observer::event` and `RunResult::events`)
//!
//! State events are detected by a sign change between step ends and located by Illinois regula
//! falsi on the step length, every trial being a fresh step from the step's start (so the
//! located state is as accurate as any step), to `solver.event_tol` in time; the post-event
//! side is kept. Known times (stage ends, base-period boundaries, the shaker switching) are hit
//! exactly by clipping the step.
//! - **ContactLoss**: a falls to a_floor = min(10⁻³ a_J, seed/10), or the contact collapses
//!   faster than the time resolution: a stage finds no root with a > 0 (the driver then closes in
//!   on the first failing time by halving, and declares the loss when within event_tol), or the
//!   error control needs a step below event_tol while ȧ < 0 (the √ singularity of a(t) at the
//!   displacement-controlled turning point of a constant-w contact). Effect of a_floor: near
//!   a → 0 with δ < 0 the GS law gives a^(1+1/n) ∝ (t_c − t), so the time from 10⁻³ a_J to 0 is
//!   ~10^(−3(1+1/n)) ≈ 10⁻⁸·⁶ of the time from a_J: far below any tolerance. How close the
//!   displacement-controlled loss comes to a³ = πwR²/(6K), and how little a smaller a_floor
//!   moves the loss time and the pull-off force, are measured in `docs/studies/checks.md` and
//!   asserted in `tests/it/dynamics.rs` (`contact_loss_radius_has_negligible_effect`). A loss by
//!   collapse leaves the elastic energy still in the vanishing contact unintegrated (the
//!   adhesion would dissipate it in that last instant), as a jump-in releases 0.6 π w0 a_J²:
//!   the `djkr` crate's `catalogue::cycle_balances` accounts for both steps.
//! - **Impact**: out of contact, δ rises through 0. Contact forms at the jump-in radius
//!   (`JumpIn`) or the seed radius (`Seed`); a backward-Euler kick of 10⁻⁷ t_char then supplies
//!   the (possibly enormous, but finite) healing rate of the new state for the next step.
//! - **PullOff** (stages with `until = PullOff`): after a contact loss the sphere flies freely;
//!   detachment is declared, *at the contact-loss time and state*, once a re-impact is proven
//!   impossible: in an unload or hold stage the free relative motion ξ = x_s − x_eq(t) about the
//!   spring's (non-advancing) equilibrium x_eq = x_k + (m g − c ẋ_k)/k keeps its energy bound
//!   A = √(ξ² + m ξ̇²/k), so the sphere can never reach x_eq + A; if that stays below −X_b (the
//!   highest base position) no contact can form again. Rigid link / m = 0: x_k(t) + X_b < 0.
//!   Fallback: 50 free or base periods without re-impact. An impact before that cancels it.
//! - **PreloadReached** (approach stages): F rises through the preload; the stage ends.
//! - **DurationElapsed**, **StageStart** (the shaker state may change: on at phase 0 so x_b is
//!   continuous; off at the next base-period boundary, for the same reason).
//!
//! Initial states: `Preload(P)`: JKR equilibrium at w0 under compressive force P
//! (a = equilibrium_radius_for_force, δ = equilibrium_indentation), x_s = δ, at rest, ȧ = 0,
//! x_k = x_s + (P − m g)/k. `Gap(g0)`: x_s = −g0 at rest, x_k at the free equilibrium.
//!
//! # Cycle quadratures and the pull-off summary
//!
//! Eighteen quadrature states ([`model::q`]) are integrated with the solution: ∫F, ∫F sin θ,
//! ∫F cos θ, the same for δ and a, ∫x_s, ∫x_k, the holder force and its two harmonics, base work
//! ∫F_b ẋ_b, viscous and adhesive dissipation ∫c ẋ², ∫(w0 − w) 2πa ȧ, and spring-end work. At
//! every base-period boundary (hit exactly) a [`CycleRecord`] gives the exact cycle means and
//! first harmonics and the energy balance. `pull_off.force`: if the shaker is on at detachment
//! (without detachment: if any cycle was recorded), the most tensile cycle-mean force; otherwise
//! the most tensile instantaneous force recorded while the shaker was off (interior minima refined by
//! Brent minimisation with exact re-stepping). Both are taken up to detachment, over the pull-off
//! stage (the whole run if no stage ends at pull-off).
//!
//! # Measurements
//!
//! Measured numbers are not kept here: they live in generated documents that carry their date,
//! commit, machine and the command that regenerates them (index: `docs/studies/README.md`), and
//! the tests assert the claims, with a margin over the measured values, on the scenes of
//! the `djkr` crate's `catalogue` that the benchmarks time:
//! - `docs/studies/checks.md` (`cargo run --release --example study_checks`; asserted in
//!   `tests/it/dynamics.rs`, `tests/it/restart.rs`): the fixed-step orders (4 for the implicit method,
//!   8 for DP8, on the ramp-driven free oscillator, whose drive depends on time so that a wrong
//!   stage time would show), the JKR limits (load- and displacement-controlled pull-off, also
//!   with m = 0), free flight and impact time against the closed form, the per-cycle momentum
//!   and energy balances, the agreement of the implicit method, DP8 and Dopri5 on cycle means
//!   and a GS pull-off, restarts;
//! - `docs/studies/methods.md` (`study_methods`): wall time, steps and error of every method on
//!   the catalogue scenes, the basis of `auto`;
//! - `docs/studies/pull-off-sensitivity.md` (`study_pull_off`): pull-off under strong vibration;
//! - `docs/accuracy/<scene>/work_precision.md` (`djkr accuracy`): error against cost;
//! - criterion medians (`cargo bench --bench dynamics`, `--bench methods`): one right-hand side,
//!   one cycle, 1 s at 400 Hz, the 300 Hz protocol (README, "Benchmarks").
//!
//! What they show, as guidance that does not depend on a day's timings:
//! - Momentum balances to rounding. The energy quadratures are outside the error norm: with DP8
//!   the per-cycle energy residual stays below rtol of the run's energy scale, with the implicit
//!   method (seeded contact) it reaches a few tens of times that.
//! - Errors at one rtol move by ~2× with rounding-level changes (a few-ulp change in the law's
//!   inverse did that to DP8 at 1e-8): quote an rtol with a margin, not the edge. The ⟨F⟩ of a
//!   vibrating hold is a small difference of large excursions, so its relative error is much
//!   larger than that of the state. In long runs the contact radius integrates its local errors
//!   (it has no restoring force: each cycle ratchets it), so the global error grows with the
//!   number of steps; use rtol ≤ 1e-8.
//! - Near pull-off under strong vibration the detachment is extremely sensitive: the cycle means
//!   before it converge as rtol → 0 and agree between methods, the detachment time and the
//!   pull-off force do not (they vary by several per cent with rtol and method): the approach to
//!   dynamic pull-off amplifies perturbations, so pull-off there is reproducible only
//!   statistically. On the shipped protocols the last-cycle errors level off while the pull-off
//!   force converges; stopped before pull-off, the same protocol converges with rtol.
//! - Design choices measured against code that no longer exists (not regenerated): `rates` is
//!   inlined into the stage loop, because reading its stored result back stalled the stepper (a
//!   store-forwarding miss; 11 %); without DP8's own estimate of a and without ending steps on
//!   the turning points, its global error stalled near 1e-5 whatever the tolerance; a PI step
//!   controller (β = 0.04…0.12) traded rejections for more steps at an unchanged error per
//!   right-hand side, and was not adopted; stepping the implicit method onto turning points
//!   saved < 0.3 % (its steps are 6× shorter than DP8's, and the straddle error scales as
//!   h^(2+1/n)); its Newton iteration in z stops after 2 residuals on most stages.

mod control;
mod dp8;
mod envelope;
mod esdirk;
mod events;
pub mod methods;
pub mod model;
mod ode_adapter;
pub mod protocol;
mod rescue;
mod simulator;
mod state;
mod stepper;
mod types;

pub use methods::{EnvelopeMode, Method, Solver};
pub use model::Model;
pub use protocol::{run, run_partial, Initial, Plan, Stage, StageKind, Until};
pub use simulator::{Segment, Settings, Simulator, Stop};
pub use state::{State, StepFail, StepOut, Tol};
pub use stepper::{Capabilities, Reach, Stepper};
pub use types::*;

/// Single steps and right-hand sides of the two integrators written for djkr, outside a run.
///
/// A simulation never needs these: [`run`] and [`Simulator`] choose and drive the steppers.
/// They are public so that the root crate's observed-order tests (`tests/it/dynamics.rs`, which
/// take their scenes from the `djkr` catalogue) can step the implicit and DP8 methods with
/// fixed steps, and so that the criterion benches (`benches/common`) can time one DP8
/// right-hand side on its own.
pub mod kernels {
    pub use super::dp8::{rates, rates_at, step as dp8_step, Rates};
    pub use super::esdirk::step as esdirk_step;
}

/// The scene the unit tests of the model and the steppers share: the light rig
/// ([`crate::rig::light_rig`]) with `law`, its base shaking at 400 Hz with 5 µm, held for 1 s
/// under a 20 mN preload (the root crate's `catalogue::vibrating_hold(5e-6, 400.0, 1.0)`).
#[cfg(test)]
pub(crate) fn test_hold(law: crate::adhesion::Law) -> (crate::rig::Rig, model::RunScales) {
    use protocol::{Initial, Stage, StageKind, Until};
    let mut rig = crate::rig::light_rig(law);
    rig.base = Some(crate::rig::BaseMotion {
        amplitude: 5e-6,
        frequency: 400.0,
        phase: 0.0,
    });
    let hold = Stage {
        kind: StageKind::Hold,
        speed: 0.0,
        until: Until::Duration(1.0),
        vibration: Some(true),
        max_duration: 1e7,
    };
    (rig, protocol::run_scales(&Initial::Preload(0.02), &[hold]))
}
