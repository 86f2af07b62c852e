//! Continuation of periodic orbits through their folds, with Floquet stability, bifurcations,
//! and the fold curves in two parameters (`djkr continue`).
//!
//! A frequency sweep ([`crate::steady::sweep`]) follows a stable orbit from one frequency to
//! the next and jumps when it ends: it cannot show the unstable middle branch of a bent
//! resonance, locate its folds precisely, tell a fold from another bifurcation, or map where the
//! response is bistable. This module follows the branch itself.
//!
//! # The problem ([`family`], `map`)
//! A *family* is a model ([`family::Scene`]; in djkr a scenario file and its fixed `--set`
//! overrides) and one key left free (two for the fold curves): any constant of the periodic
//! problem (base frequency and amplitude, preload, damping, stiffness, mass, the material and
//! law constants; stages, solver and output keys are refused with that list). The orbit at value p is the
//! periodic steady state of the scenario with `KEY = p` written in it, as `djkr validate --set
//! KEY=p` would find it. Unknowns u = (ŷ, p̂): the state at phase 0 over the components the
//! problem integrates (x_s, v_s, a for the Gent–Schultz scenes; x_s, v_s under a constant law,
//! where a is algebraic; a alone without inertia), each divided by a scale fixed for the whole
//! branch (L, ωL, a_m of the first orbit, as shooting scales them), and the parameter divided by
//! the width of its range. Residual F(u) = (P(y; p) − y)/scale, P the one-period map integrated
//! adaptively at rtol 1e-10 (as shooting).
//!
//! # Continuation ([`engine`], [`branch`])
//! Pseudo-arclength: tangent predictor u_k + h t_k, Keller's bordered corrector
//! [J; t_kᵀ] Δ = −[F; t_k·(u − u_k) − h] (a chord iteration on u_k's Jacobian, one period per
//! iteration; Newton when it contracts poorly), converged when every |Δ_i| < 1e-9 plus the
//! precision floor 10·rtol·|u_i| the integration leaves that unknown. Step control: a step is
//! halved when the corrector fails or the tangent turns by more than 0.12 rad; it grows by up to
//! 2× when the corrector took few iterations, keeping the turn near 0.06 rad; h ≤ 0.1. The
//! branch starts at START from the steady state shooting finds there (from the scene's own
//! start) and ends where it leaves [START, STOP] at either end, the last point put exactly on
//! the edge.
//!
//! # Derivatives and multipliers (`map`, `floquet`)
//! The Jacobian (monodromy matrix M = ∂P/∂y and ∂P/∂p) is by central differences with step 1e-5
//! (scaled) on the *frozen step sequence* of the adaptive period: each perturbed start is
//! integrated again with exactly the accepted steps of the base period (stretched by T(p′)/T(p)
//! when the period changes), so every difference is that of one smooth discrete map and never
//! straddles a change of the step sequence (measured on the bundled scene: the adaptive map is
//! smooth to its rounding, ~1e-14, between such changes, with isolated jumps of ~3e-11 where
//! they happen; see `map`). Rounding in the replays is ~1e-14, so the entries of M carry ~1e-9 (1e-14/ε plus the ε² truncation);
//! central differences at 1e-5 and 1e-4 agree to 2e-8 on the creep multiplier at 400 Hz. Not
//! variational equations with saltation: there are no events inside a smooth period, and the
//! core simulator's steppers are reused as they are. The Floquet multipliers are the
//! eigenvalues of M (Schur), largest modulus first; the orbit is stable when all |μ| < 1. Under
//! a constant law at X_b = 3 nm they match e^{λT} of the damped oscillator with the JKR tangent
//! stiffness to 1e-5, the remaining difference being the amplitude's nonlinearity
//! (tests/it/continuation.rs).
//!
//! # Folds, the creeping radius, and the other bifurcations
//! One multiplier sits close to 1: the mean contact radius creeps (the Gent–Schultz law is flat
//! near G = w0), a nearly neutral direction of the map (on the bundled scene at 1.5 µm, 1 − μ is
//! 5e-4 at 340 Hz, 4e-2 at 420 Hz, 2e-4 at 600 Hz; near the peak the creep mode joins the
//! oscillator's pair, |μ| ≥ 0.90; 1 − μ → 0 as X_b → 0). On the bent resonance that mode *is*
//! the fold's: it crosses +1 at the folds and is just above 1 on the middle branch. A fold test
//! that looks for a multiplier "near 1", or counts the multipliers above 1 from noisy finite
//! differences, would fire all along the branch or
//! miss where the margin is below the noise. The fold is decided instead by the **sign of the
//! tangent's parameter component**, which comes from a bordered linear solve, not from
//! eigenvalues: it changes sign exactly where the branch turns back. That zero is located by
//! regula falsi on the arclength (to 1e-10), and there the largest real multiplier is +1
//! (checked: within 1e-9 on the bundled scene). det(M − I)·t_p changes sign where a real
//! multiplier crosses +1 *without* the branch turning (a branch point, reported as such);
//! det(M + I) at a period doubling (a real μ through −1); Π_{i<j}(μ_iμ_j − 1) at a
//! Neimark–Sacker point (a complex pair through |μ| = 1; a real pair with product 1 is refused).
//! Because the parameter is extremal at a fold, an arclength error δs moves it by O(δs²): the
//! folds of the bundled scene at 1.5 µm agree to 5e-11 (upper) and 1e-9 (lower) relative
//! between rtol 1e-10 and 1e-13, and lie between the frequencies where fine up and down sweeps
//! jump.
//!
//! **Grazing.** A period that loses or forms contact is not a smooth map. When the corrector
//! meets one (an event in the adaptive period, or a replayed step whose stage finds no contact
//! radius), the step is halved down to 1e-6 in arclength and the branch ends there, reported as
//! a grazing with the event kind: a change of the event sequence, not a fold, even when the
//! branch would seem to turn. (On `scenarios/impacts.toml` the in-contact branch in X_b folds at
//! 380 µm and its unstable continuation grazes just after.)
//!
//! # Two parameters ([`folds`])
//! Each fold is followed in a second key on F = 0, det(M − I) = 0 by the same engine; through a
//! cusp the curve of upper folds turns into the curve of lower folds, and the cusp is where the
//! second key is extremal along it (refined by a parabola). Inside the fold curves the system is
//! bistable.
//!
//! # Cost
//! One adaptive period per corrector iteration, 2n + 2 replays per Jacobian: `djkr continue`
//! prints the points and periods of a branch. Its wall time is measured by `cargo bench --bench
//! continuation` and quoted once, in docs/guide/benchmarks.md.

pub mod branch;
pub mod engine;
pub mod family;
pub(crate) mod floquet;
pub mod folds;
pub(crate) mod map;

pub mod sweep;

use thiserror::Error;

/// Why a continuation could not run.
#[derive(Debug, Error)]
pub enum ContinuationError {
    /// A key, range or scenario value that cannot describe a family of periodic orbits.
    #[error("{0}")]
    Input(String),
    /// A range whose ends coincide (or are not finite). `input` names the request's range as
    /// its field is named (`range`, `fold_range`); a front end words it (`--range`).
    #[error(
        "{input} {start}:{stop}: START and STOP must differ{}",
        unit_suffix(unit)
    )]
    EmptyRange {
        /// Which range: `range` (the parameter's) or `fold_range` (the second parameter's).
        input: &'static str,
        /// Its start.
        start: f64,
        /// Its end.
        stop: f64,
        /// The parameter's unit, when it has one.
        unit: &'static str,
    },
    /// The second free parameter of a fold continuation is the first one again.
    #[error("{input} {name}: must differ from {other}")]
    SameParameter {
        /// The input that named it again (`fold_param`).
        input: &'static str,
        /// The key.
        name: String,
        /// The input that named it first (`param`).
        other: &'static str,
    },
    /// The scene refused a value (the front end's own error: a scenario's, for `djkr
    /// continue`), kept whole so that the front end can word it.
    #[error("{0}")]
    Scene(Box<dyn std::error::Error + Send + Sync>),
    /// No periodic orbit at the start of the range.
    #[error("continuation: {0}")]
    Start(String),
}

fn unit_suffix(unit: &str) -> String {
    if unit.is_empty() {
        String::new()
    } else {
        format!(" ({unit})")
    }
}
