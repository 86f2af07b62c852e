//! Reference problems: one catalogue for the tests, the benchmarks and the studies.
//!
//! Every scene the test suite proves something about, every scene a benchmark times and every
//! scene a study in `examples/` measures is built here, so that a benchmark measures exactly
//! what the tests prove correct, and the numbers quoted in the docs come from the same scenes.
//! Where a scene has a known answer (a closed form, a JKR limit, a balance law), the catalogue
//! says which and, when it is a formula, provides it ([`RampOscillator`]).
//!
//! - Imposed-area operating points: [`CYCLE_400HZ`], [`CYCLE_400HZ_TRUNCATED`],
//!   [`PULL_OFF_400HZ`], and the Figs. 4–8 grid [`figs_4_to_8_grid`].
//! - Elastic JKR limits: [`soft_spring_jkr`], [`load_controlled_unload`],
//!   [`displacement_controlled_unload`], [`massless_unload`], [`quasi_static_jkr`].
//! - Free flight and impact against a closed form: [`free_flight`] with [`RampOscillator`].
//! - Gent–Schultz unloads without vibration: [`gs_rigid_unload`], [`gs_massless_unload`],
//!   [`gs_soft_spring_unload`].
//! - Vibration: [`vibrating_hold`] (the 3 g sphere the simulator's tests and benches use),
//!   [`hold_400hz_1s`] (the 1 s / 400 Hz speed target), [`resonance_hold`], [`impacts`],
//!   [`seeded_impact_with_contact_damping`], [`light_protocol`].
//! - Synthetic experimental records for the Gent–Schultz fit: [`synthetic_unloading_record`],
//!   [`paper_unloading_record`], [`add_noise`].
//! - Per-cycle balances: [`cycle_balance_scenes`], the scenes on which the tests assert the
//!   energy and momentum balance and `examples/study_checks.rs` measures it, and the checks
//!   themselves ([`cycle_balances`], [`summarise_balances`], [`contact_energy`]).
//! - The bundled scenario files in `scenarios/`, compiled in: [`Bundled`].
//!
//! All scenes use the paper's material ([`Material::PAPER`]) and, unless they say otherwise, its
//! Gent–Schultz law ([`GentSchultz::PAPER`]). The builders only construct values; a test or
//! study changes the solver settings or the stages of its copy as it needs.
//!
//! It is compiled into each test, benchmark and study that uses it (`#[path]`), not into the
//! library: no user of djkr needs it. Each uses a part, hence `allow(dead_code)`.
#![allow(dead_code)]

use djkr::scenario::parse::{parse_scenario, ScenarioError};
use djkr::scenario::*;
use djkr_core::adhesion::{ConstantW, GentSchultz, Law};
use djkr_core::dynamics::protocol::*;
use djkr_core::dynamics::Solver;
use djkr_core::material::Material;
use djkr_core::rig::{BaseMotion, ContactFormation, Damping, DampingOn, Holder, Rig, Sphere};
use std::f64::consts::PI;

/// A stage with a generous safety limit (10⁷ s).
pub fn stage(kind: StageKind, speed: f64, until: Until, vibration: Option<bool>) -> Stage {
    Stage {
        kind,
        speed,
        until,
        vibration,
        max_duration: 1e7,
    }
}

fn scene(rig: Rig, initial: Initial, stages: Vec<Stage>, solver: Solver) -> Scenario {
    Scenario {
        rig,
        initial,
        stages,
        solver,
        output: Output::default(),
        source_text: "".into(),
        source_name: "<catalogue>".into(),
        overrides: Vec::new(),
    }
}

fn paper_gs() -> Law {
    Law::GentSchultz(GentSchultz::PAPER)
}

fn constant_w0() -> Law {
    Law::Constant(ConstantW {
        w0: Material::PAPER.w0,
    })
}

// ------------------------------------------------------------------------------------------
// Imposed-area operating points
// ------------------------------------------------------------------------------------------

/// An imposed-area cycle a(θ) = a_m + a_A sin θ at a base frequency.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImposedCycle {
    /// Frequency f (Hz).
    pub frequency: f64,
    /// Mean contact radius a_m (m).
    pub a_mean: f64,
    /// Contact-radius amplitude a_A (m).
    pub a_amp: f64,
}

impl ImposedCycle {
    /// Angular frequency ω = 2π f (rad/s).
    pub fn omega(&self) -> f64 {
        2.0 * PI * self.frequency
    }
}

/// 400 Hz, a_m = 2 mm, a_A = 0.5 mm: in contact throughout the cycle (near the paper's pull-off
/// radii). The cycle `benches/imposed_area.rs` times at the default accuracy.
pub const CYCLE_400HZ: ImposedCycle = ImposedCycle {
    frequency: 400.0,
    a_mean: 2e-3,
    a_amp: 0.5e-3,
};

/// 400 Hz, a_m = 0.3 mm, a_A = 0.5 mm: truncated (contact lost for part of the cycle).
pub const CYCLE_400HZ_TRUNCATED: ImposedCycle = ImposedCycle {
    frequency: 400.0,
    a_mean: 0.3e-3,
    a_amp: 0.5e-3,
};

/// A pull-off search at a base frequency and contact-radius amplitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PullOffPoint {
    /// Frequency f (Hz).
    pub frequency: f64,
    /// Contact-radius amplitude a_A (m).
    pub a_amp: f64,
}

impl PullOffPoint {
    /// Angular frequency ω = 2π f (rad/s).
    pub fn omega(&self) -> f64 {
        2.0 * PI * self.frequency
    }
}

/// The exact pull-off at 400 Hz, a_A = 0.5 mm (paper material and law).
pub const PULL_OFF_400HZ: PullOffPoint = PullOffPoint {
    frequency: 400.0,
    a_amp: 0.5e-3,
};

/// The grid of the paper's Figs. 4–8: frequencies 200, 300, 400 Hz (Hz) and amplitudes
/// a_A = 0, 25 µm, …, 1.5 mm (m), 3 × 61 pull-offs (the grid `djkr figures` draws).
pub fn figs_4_to_8_grid() -> (Vec<f64>, Vec<f64>) {
    (
        vec![200.0, 300.0, 400.0],
        (0..61).map(|i| i as f64 * 25e-6).collect(),
    )
}

// ------------------------------------------------------------------------------------------
// Elastic JKR limits (constant w0)
// ------------------------------------------------------------------------------------------

/// Elastic JKR (constant w0) on a 1 g sphere held by a soft 10 N/m spring, without gravity,
/// starting in JKR equilibrium under a 10 mN preload; no damping, no base; rtol 1e-9, atol 1e-10;
/// **no stages** (add them). The base of the JKR-limit and free-flight scenes.
pub fn soft_spring_jkr() -> Scenario {
    scene(
        Rig {
            material: Material::PAPER,
            law: constant_w0(),
            sphere: Sphere {
                mass: 1e-3,
                gravity: 0.0,
            },
            holder: Holder::Spring { stiffness: 10.0 },
            damping: None,
            base: None,
            formation: ContactFormation::JumpIn,
        },
        Initial::Preload(0.01),
        vec![],
        Solver {
            rtol: 1e-9,
            atol: 1e-10,
            ..Solver::default()
        },
    )
}

/// [`soft_spring_jkr`] unloaded at 1 mm/s to pull-off: **load control**. Known answer: the most
/// tensile force is the load-controlled pull-off force −3/2 πRw0
/// ([`djkr_core::jkr::load_controlled_pull_off_force`]), detachment follows right after it.
pub fn load_controlled_unload() -> Scenario {
    let mut s = soft_spring_jkr();
    s.stages = vec![stage(StageKind::Unload, 1e-3, Until::PullOff, None)];
    s
}

/// [`soft_spring_jkr`] through a rigid link unloaded at 0.1 mm/s: **displacement control**.
/// Known answer: the contact follows the JKR curve past −3/2 πRw0 and is lost at
/// a³ = πwR²/(6K), F = −5/6 πRw ([`djkr_core::jkr::displacement_controlled_pull_off_radius`],
/// [`djkr_core::jkr::displacement_controlled_pull_off_force`]).
pub fn displacement_controlled_unload() -> Scenario {
    let mut s = soft_spring_jkr();
    s.rig.holder = Holder::Rigid;
    s.stages = vec![stage(StageKind::Unload, 1e-4, Until::PullOff, None)];
    s
}

/// [`soft_spring_jkr`] with a massless sphere (quasi-static force balance) on a spring of
/// `stiffness` (N/m), unloaded at 0.1 mm/s. Known answer: load control (−3/2 πRw0, lost at the
/// force minimum) on a soft spring (10 N/m), displacement control (lost at −5/6 πRw) on a stiff
/// one (10⁷ N/m).
pub fn massless_unload(stiffness: f64) -> Scenario {
    let mut s = soft_spring_jkr();
    s.rig.sphere.mass = 0.0;
    s.rig.holder = Holder::Spring { stiffness };
    s.stages = vec![stage(StageKind::Unload, 1e-4, Until::PullOff, None)];
    s
}

/// `scenarios/quasi-static-jkr.toml` built in code: elastic JKR through a rigid link, massless,
/// from equilibrium under 20 mN, unloaded at 1 µm/s to pull-off, rtol 1e-10. Known answer: it
/// passes −3/2 πRw0 and is lost at −5/6 πRw0.
pub fn quasi_static_jkr() -> Scenario {
    scene(
        Rig {
            material: Material::PAPER,
            law: constant_w0(),
            sphere: Sphere {
                mass: 0.0,
                gravity: 9.807,
            },
            holder: Holder::Rigid,
            damping: None,
            base: None,
            formation: ContactFormation::JumpIn,
        },
        Initial::Preload(0.02),
        vec![Stage {
            max_duration: 100.0,
            ..stage(StageKind::Unload, 1e-6, Until::PullOff, None)
        }],
        Solver {
            rtol: 1e-10,
            ..Solver::default()
        },
    )
}

// ------------------------------------------------------------------------------------------
// Free flight against a closed form
// ------------------------------------------------------------------------------------------

/// The ramp-driven free oscillator of [`free_flight`]: the sphere (m = 1 g on k = 10 N/m,
/// ω = 100 rad/s) starts at rest a `gap` (m) above the substrate, in equilibrium, and the spring
/// end moves towards the substrate at `speed` (m/s). Its position, down +, is
/// x(t) = −gap + V t − (V/ω) sin ωt.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RampOscillator {
    /// Initial gap (m).
    pub gap: f64,
    /// Spring-end speed V (m/s).
    pub speed: f64,
    /// Natural angular frequency ω = √(k/m) (rad/s).
    pub omega: f64,
}

impl RampOscillator {
    /// Sphere position x(t) (m, down +; the substrate is at 0).
    pub fn position(&self, t: f64) -> f64 {
        -self.gap + self.speed * t - self.speed / self.omega * (self.omega * t).sin()
    }

    /// The first time the sphere reaches the substrate, x(t) = 0 (s): a scan by 10⁻⁴ s, then
    /// 200 bisections (to rounding). x(t) is non-decreasing (ẋ = V(1 − cos ωt) ≥ 0), so the first
    /// sign change is the impact.
    pub fn impact_time(&self) -> f64 {
        let dt = 1e-4;
        let mut t = 0.0;
        while self.position(t) < 0.0 {
            t += dt;
        }
        let (mut lo, mut hi) = ((t - dt).max(0.0), t);
        for _ in 0..200 {
            let m = 0.5 * (lo + hi);
            if self.position(m) < 0.0 {
                lo = m
            } else {
                hi = m
            }
        }
        0.5 * (lo + hi)
    }
}

/// Free flight: [`soft_spring_jkr`] with gravity, starting out of contact at rest a `gap` (m)
/// above the substrate, the spring end approaching at `speed` (m/s) for `duration` (s). Known
/// answer: [`RampOscillator`] (returned alongside) until the impact, which it also times.
pub fn free_flight(gap: f64, speed: f64, duration: f64) -> (Scenario, RampOscillator) {
    let mut s = soft_spring_jkr();
    s.rig.sphere.gravity = 9.81;
    s.initial = Initial::Gap(gap);
    s.stages = vec![stage(
        StageKind::Approach,
        speed,
        Until::Duration(duration),
        None,
    )];
    let omega = (s.rig.spring_stiffness() / s.rig.sphere.mass).sqrt();
    (s, RampOscillator { gap, speed, omega })
}

// ------------------------------------------------------------------------------------------
// Gent–Schultz unloads without vibration
// ------------------------------------------------------------------------------------------

/// The paper's Gent–Schultz law through a rigid link (no inertia: only a is integrated), from
/// equilibrium under 10 mN, unloaded at `speed` (m/s) to pull-off; rtol 1e-9. Known answer: the
/// pull-off amplification exceeds 1 and tends to the static 1 as the speed → 0.
pub fn gs_rigid_unload(speed: f64) -> Scenario {
    let mut s = soft_spring_jkr();
    s.rig.law = paper_gs();
    s.rig.holder = Holder::Rigid;
    s.stages = vec![stage(StageKind::Unload, speed, Until::PullOff, None)];
    s
}

/// The Gent–Schultz law on a massless sphere held by the soft 10 N/m spring (quasi-static
/// balance), unloaded at `speed` (m/s) to pull-off.
pub fn gs_massless_unload(speed: f64) -> Scenario {
    let mut s = soft_spring_jkr();
    s.rig.law = paper_gs();
    s.rig.sphere.mass = 0.0;
    s.stages = vec![stage(StageKind::Unload, speed, Until::PullOff, None)];
    s
}

/// The Gent–Schultz law on the 1 g sphere held by the soft 10 N/m spring (with inertia),
/// unloaded at `speed` (m/s) to pull-off.
pub fn gs_soft_spring_unload(speed: f64) -> Scenario {
    let mut s = soft_spring_jkr();
    s.rig.law = paper_gs();
    s.stages = vec![stage(StageKind::Unload, speed, Until::PullOff, None)];
    s
}

// ------------------------------------------------------------------------------------------
// Vibration
// ------------------------------------------------------------------------------------------

pub use djkr_core::rig::light_rig;

/// [`light_rig`] with the paper's Gent–Schultz law and a base shaking at `frequency` (Hz) with
/// amplitude `xb` (m), starting in JKR equilibrium under a 20 mN preload; one hold stage of
/// `duration` (s) with the shaker on; rtol 1e-8.
pub fn vibrating_hold(xb: f64, frequency: f64, duration: f64) -> Scenario {
    let mut rig = light_rig(paper_gs());
    rig.base = Some(BaseMotion {
        amplitude: xb,
        frequency,
        phase: 0.0,
    });
    scene(
        rig,
        Initial::Preload(0.02),
        vec![stage(
            StageKind::Hold,
            0.0,
            Until::Duration(duration),
            Some(true),
        )],
        Solver {
            rtol: 1e-8,
            ..Solver::default()
        },
    )
}

/// The speed target: 1 s of [`vibrating_hold`] at 400 Hz with a 5 µm base (the contact heals to
/// G/w0 ≈ 0.01 every cycle). `docs/accuracy/hold-400hz-1s.toml` is this scene as a file (a test
/// checks that they agree).
pub fn hold_400hz_1s() -> Scenario {
    vibrating_hold(5e-6, 400.0, 1.0)
}

/// `scenarios/resonance-400hz.toml`'s vibrating hold alone (0.5 s, 200 cycles at 400 Hz on the
/// 2.71 g sphere whose linearised resonance is at 400 Hz), without its unload, sampled at every
/// step.
pub(crate) fn resonance_hold() -> Result<Scenario, ScenarioError> {
    let mut s = Bundled::Resonance400.scenario()?;
    s.stages.truncate(1);
    s.output = Output::default();
    Ok(s)
}

/// Impacts every cycle: the rig of `scenarios/impacts.toml` (m = 0.25 kg, k = 2000 N/m,
/// c = 10 N s/m, 300 Hz) with `law`, `formation` and base amplitude `xb` (m), from equilibrium
/// under 50 mN, shaker on for `duration` (s); rtol 1e-8. X_b = 400 µm loses and regains the
/// contact every cycle with the Gent–Schultz law, 40 µm with a constant w.
pub fn impacts(xb: f64, law: Law, formation: ContactFormation, duration: f64) -> Scenario {
    scene(
        Rig {
            material: Material::PAPER,
            law,
            sphere: Sphere {
                mass: 0.25,
                gravity: 9.807,
            },
            holder: Holder::Spring { stiffness: 2000.0 },
            damping: Some(Damping {
                c: 10.0,
                on: DampingOn::Sphere,
            }),
            base: Some(BaseMotion {
                amplitude: xb,
                frequency: 300.0,
                phase: 0.0,
            }),
            formation,
        },
        Initial::Preload(0.05),
        vec![stage(
            StageKind::Hold,
            0.0,
            Until::Duration(duration),
            Some(true),
        )],
        Solver::default(),
    )
}

/// A Gent–Schultz contact formed from a 1 µm seed at impact (rate-limited healing through the
/// compressive-edge state), with contact damping c δ̇ (eq. 3, c = 0.05 N s/m): the 1 g sphere on
/// the soft spring approaches from a 5 µm gap at 1 mm/s to a 10 mN preload, then holds 50 ms
/// with a 1 µm, 200 Hz base; rtol 1e-9, at most 10⁵ steps.
pub fn seeded_impact_with_contact_damping() -> Scenario {
    let mut s = soft_spring_jkr();
    s.rig.law = paper_gs();
    s.rig.formation = ContactFormation::Seed(1e-6);
    s.rig.damping = Some(Damping {
        c: 0.05,
        on: DampingOn::Contact,
    });
    s.rig.base = Some(BaseMotion {
        amplitude: 1e-6,
        frequency: 200.0,
        phase: 0.0,
    });
    s.initial = Initial::Gap(5e-6);
    s.stages = vec![
        stage(StageKind::Approach, 1e-3, Until::Preload(0.01), Some(false)),
        stage(StageKind::Hold, 0.0, Until::Duration(0.05), Some(true)),
    ];
    s.solver.max_steps = 100_000;
    s
}

/// The paper's protocol (Sec. 3) on the light rig, with shortened dwells: from a 20 µm gap,
/// approach at 100 µm/s to a 50 mN preload, dwell 0.5 s, switch a 300 Hz, 10 µm shaker on, dwell
/// 0.5 s, unload at `unload_speed` (m/s; the paper's is 5 µm/s) to pull-off. m = 3 g,
/// k = 200 N/m, c = 0.05 N s/m. (The bundled `scenarios/paper-protocol-*.toml` use the heavy
/// rig of the experiment instead: [`Bundled`].)
pub fn light_protocol(unload_speed: f64) -> Scenario {
    let mut s = vibrating_hold(10e-6, 300.0, 0.5);
    s.rig.damping = Some(Damping {
        c: 0.05,
        on: DampingOn::Sphere,
    });
    s.initial = Initial::Gap(20e-6);
    s.stages = vec![
        stage(
            StageKind::Approach,
            100e-6,
            Until::Preload(0.05),
            Some(false),
        ),
        stage(StageKind::Hold, 0.0, Until::Duration(0.5), None),
        stage(StageKind::Hold, 0.0, Until::Duration(0.5), Some(true)),
        stage(StageKind::Unload, unload_speed, Until::PullOff, None),
    ];
    s
}

// ------------------------------------------------------------------------------------------
// Synthetic experimental records
// ------------------------------------------------------------------------------------------

/// A synthetic unloading record from the model itself, for the Gent–Schultz fit: a rigid-link
/// unloading δ(t) = δ0 − V t from JKR equilibrium at w0 and radius `a0` (m), at `speed` V (m/s),
/// the contact radius following the inverse law ȧ = `law.crack_speed`(G(a, δ)), integrated by
/// classical RK4 with `substeps` steps per sample, sampled every `dt` (s) until a < `a_end` (m)
/// (at most 10⁶ rows); the force from the JKR relation. Known answer: the law's constants.
pub fn synthetic_unloading_record(
    law: &GentSchultz,
    a0: f64,
    speed: f64,
    dt: f64,
    substeps: usize,
    a_end: f64,
) -> Vec<djkr_core::gs_fit::UnloadingRow> {
    use djkr_core::adhesion::AdhesionLaw;
    use djkr_core::gs_fit::UnloadingRow;
    use djkr_core::jkr;
    let m = Material::PAPER;
    let delta0 = jkr::equilibrium_indentation(&m, a0, law.w0);
    let delta = |t: f64| delta0 - speed * t;
    let rate = |t: f64, a: f64| law.crack_speed(jkr::energy_release_rate(&m, a, delta(t)));
    let h = dt / substeps.max(1) as f64;
    let (mut t, mut a) = (0.0f64, a0);
    let mut rows = vec![UnloadingRow {
        t,
        a,
        force: jkr::contact_force(&m, a, delta(t)),
    }];
    while a > a_end && rows.len() < 1_000_000 {
        for _ in 0..substeps.max(1) {
            let k1 = rate(t, a);
            let k2 = rate(t + 0.5 * h, a + 0.5 * h * k1);
            let k3 = rate(t + 0.5 * h, a + 0.5 * h * k2);
            let k4 = rate(t + h, a + h * k3);
            a += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            t += h;
        }
        rows.push(UnloadingRow {
            t,
            a,
            force: jkr::contact_force(&m, a, delta(t)),
        });
    }
    rows
}

/// The reference record of the fit tests and study: [`synthetic_unloading_record`] of the
/// paper's law, a 2 mm contact unloaded at 10 µm/s, sampled at 250 Hz (a camera), 20 RK4
/// substeps per sample, down to a = 0.3 mm: crack speeds from ~0 to ~30 v0.
pub fn paper_unloading_record() -> Vec<djkr_core::gs_fit::UnloadingRow> {
    synthetic_unloading_record(&GentSchultz::PAPER, 2e-3, 10e-6, 0.004, 20, 0.3e-3)
}

/// `rows` with independent Gaussian noise of standard deviations `sigma_a` (m) on the radius and
/// `sigma_f` (N) on the force, deterministic for a `seed` (xorshift64* uniforms, Box–Muller).
pub fn add_noise(
    rows: &[djkr_core::gs_fit::UnloadingRow],
    sigma_a: f64,
    sigma_f: f64,
    seed: u64,
) -> Vec<djkr_core::gs_fit::UnloadingRow> {
    let mut state = seed.max(1);
    let mut uniform = || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        let x = state.wrapping_mul(0x2545_F491_4F6C_DD1D);
        ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let mut gauss = move || {
        let (u1, u2) = (uniform(), uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    };
    rows.iter()
        .map(|r| djkr_core::gs_fit::UnloadingRow {
            t: r.t,
            a: r.a + sigma_a * gauss(),
            force: r.force + sigma_f * gauss(),
        })
        .collect()
}

// ------------------------------------------------------------------------------------------
// Per-cycle balance laws
// ------------------------------------------------------------------------------------------

/// The scenes on which the per-cycle energy and momentum balances are asserted
/// (`tests/it/dynamics.rs`) and measured (`examples/study_checks.rs`), each at its own tolerances,
/// with samples at every accepted step (the cycle boundaries are steps):
/// - the light rig's 300 Hz hold (X_b = 2 µm, 0.05 s);
/// - [`resonance_hold`] (200 cycles at resonance);
/// - [`seeded_impact_with_contact_damping`] (contact damping, eq. 3);
/// - the first 0.1 s of [`impacts`] at X_b = 400 µm, with jump-in and with seeded formation
///   (contact lost and regained every cycle);
/// - [`light_protocol`] unloading at 1 mm/s (the spring end moves; pull-off under vibration).
pub fn cycle_balance_scenes() -> Result<Vec<(&'static str, Scenario)>, ScenarioError> {
    Ok(vec![
        (
            "light rig, 300 Hz, X_b 2 µm",
            vibrating_hold(2e-6, 300.0, 0.05),
        ),
        ("resonance-400hz hold", resonance_hold()?),
        (
            "seeded impact, contact damping",
            seeded_impact_with_contact_damping(),
        ),
        (
            "impacts, jump-in",
            impacts(400e-6, paper_gs(), ContactFormation::JumpIn, 0.1),
        ),
        (
            "impacts, seed 10 µm",
            impacts(400e-6, paper_gs(), ContactFormation::Seed(1e-5), 0.1),
        ),
        ("light protocol, unload 1 mm/s", light_protocol(1e-3)),
    ])
}

/// Energy of a contact of radius a (m) at indentation δ (m), elastic minus surface (J):
/// U(a, δ) − w0 π a² with U = (3K/4) a δ² − (K/2) a³ δ/R + (3K/20) a⁵/R² (so that ∂U/∂δ = F and
/// ∂U/∂a = 2πa G). At the JKR jump-in state (δ = 0, a³ = 8πw0R²/(3K)) it is −0.6 π w0 a².
pub fn contact_energy(m: &Material, a: f64, delta: f64) -> f64 {
    let (k, r) = (m.k, m.r);
    0.75 * k * a * delta * delta - 0.5 * k * a.powi(3) * delta / r + 0.15 * k * a.powi(5) / (r * r)
        - m.w0 * PI * a * a
}

/// The balance laws over one base period: each residual with the scale it is measured against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleBalance {
    /// Start of the cycle (s).
    pub t_start: f64,
    /// Momentum, eq. (30) averaged over the period: the residual
    /// |⟨F⟩ − m g − ⟨F_holder⟩ + (m Δv + c Δx_s)/T| (N) and the first harmonic |F1| of the contact
    /// force (N); `None` where eq. (30) has no inertia (rigid link, m = 0) or contact damping acts
    /// on a contact that opens within the cycle.
    pub momentum: Option<(f64, f64)>,
    /// Energy: the residual |ΔE − (W_base + W_holder − D_damping − D_adhesion) − Σ E_jump| (J)
    /// and the cycle's largest work or dissipation term (J). E_jump is the step of the contact
    /// energy ([`contact_energy`]) at each impact and contact loss within the cycle, which no
    /// rate integrates: a jump-in releases 0.6 π w0 a_J²; a contact lost by its final collapse
    /// (faster than any step, at a of a few µm while δ ≪ 0) takes the elastic energy still in it,
    /// which the adhesion would dissipate in that last instant.
    pub energy: (f64, f64),
}

/// The balance residuals of every cycle of a run recorded with samples at every step
/// (`samples` must contain the cycle boundaries; a missing boundary gives a NaN momentum
/// residual). The momentum balance is eq. (30) averaged over a period:
/// ⟨F⟩ − m g − ⟨F_holder⟩ = −(m Δv + c Δx_s)/T (for contact damping, Δδ = Δx_s over a period).
pub fn cycle_balances(
    rig: &Rig,
    cycles: &[djkr_core::dynamics::CycleRecord],
    samples: &[djkr_core::dynamics::Sample],
    events: &[djkr_core::dynamics::Event],
) -> Vec<CycleBalance> {
    use djkr_core::dynamics::EventKind;
    let at = |t: f64| {
        let i = samples.partition_point(|s| s.t < t);
        [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|j| samples.get(j))
            .find(|s| (s.t - t).abs() <= 1e-12 * t.abs().max(1e-3))
            .copied()
    };
    let (m, g, c) = (rig.mass(), rig.sphere.gravity, rig.damping_coefficient());
    let inertia = m > 0.0 && !matches!(rig.holder, Holder::Rigid);
    cycles
        .iter()
        .map(|cy| {
            let within = |t: f64| t > cy.t_start && t <= cy.t_end;
            // Contact energy created at impacts, and left in the contact at losses (the state of
            // a loss event is the last one in contact).
            let jumps: f64 = events
                .iter()
                .filter(|e| within(e.time))
                .map(|e| match e.kind {
                    EventKind::Impact => contact_energy(&rig.material, e.state.a, e.state.delta),
                    EventKind::ContactLoss => {
                        -contact_energy(&rig.material, e.state.a, e.state.delta)
                    }
                    _ => 0.0,
                })
                .sum();
            let contact_lost = events
                .iter()
                .any(|e| within(e.time) && e.kind == EventKind::ContactLoss);
            let momentum = if !inertia
                || (contact_lost && rig.damping_on() == DampingOn::Contact && c > 0.0)
            {
                None
            } else {
                let residual = match (at(cy.t_start), at(cy.t_end)) {
                    (Some(s0), Some(s1)) => {
                        let period = cy.t_end - cy.t_start;
                        let lhs = cy.force_mean - m * g - cy.spring_mean;
                        let rhs = -(m * (s1.v_s - s0.v_s) + c * (s1.x_s - s0.x_s)) / period;
                        (lhs - rhs).abs()
                    }
                    _ => f64::NAN,
                };
                Some((residual, cy.force_sin.hypot(cy.force_cos)))
            };
            let budget =
                cy.work_base + cy.work_holder - cy.dissipation_damping - cy.dissipation_adhesion;
            let scale = cy
                .work_base
                .abs()
                .max(cy.work_holder.abs())
                .max(cy.dissipation_damping)
                .max(cy.dissipation_adhesion);
            CycleBalance {
                t_start: cy.t_start,
                momentum,
                energy: (
                    (cy.energy_end - cy.energy_start - budget - jumps).abs(),
                    scale,
                ),
            }
        })
        .collect()
}

/// The worst balance residuals of a run, each relative to the run's own scale: the largest
/// momentum residual over the largest |F1|, the largest energy residual over the largest
/// per-cycle work or dissipation. (Relative to each cycle's own terms, a cycle in which little
/// work is done, such as a ringing dwell, would look bad; the integration error is set by the
/// scale of the motion, not by that cycle's net work.) NaN residuals propagate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BalanceSummary {
    /// Cycles checked.
    pub cycles: usize,
    /// Worst relative momentum residual; `None` when no cycle has a momentum balance.
    pub momentum: Option<f64>,
    /// Worst relative energy residual.
    pub energy: f64,
}

/// Summarise [`cycle_balances`] (see [`BalanceSummary`]).
pub fn summarise_balances(b: &[CycleBalance]) -> BalanceSummary {
    let worst = |v: &mut dyn Iterator<Item = (f64, f64)>| {
        let (mut r, mut s, mut any) = (0.0f64, 0.0f64, false);
        for (ri, si) in v {
            // NaN-propagating maximum: a missing boundary must not pass.
            r = if ri.is_nan() || r.is_nan() {
                f64::NAN
            } else {
                r.max(ri)
            };
            s = s.max(si);
            any = true;
        }
        any.then(|| r / s)
    };
    BalanceSummary {
        cycles: b.len(),
        momentum: worst(&mut b.iter().filter_map(|c| c.momentum)),
        energy: worst(&mut b.iter().map(|c| c.energy)).unwrap_or(0.0),
    }
}

// ------------------------------------------------------------------------------------------
// The bundled scenario files
// ------------------------------------------------------------------------------------------

/// The scenario files shipped in `scenarios/`, compiled into the library so that tests, benches
/// and studies load them without a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bundled {
    /// `scenarios/paper-protocol-200hz.toml`.
    PaperProtocol200,
    /// `scenarios/paper-protocol-300hz.toml`.
    PaperProtocol300,
    /// `scenarios/paper-protocol-400hz.toml`.
    PaperProtocol400,
    /// `scenarios/quasi-static-jkr.toml`.
    QuasiStaticJkr,
    /// `scenarios/resonance-400hz.toml`.
    Resonance400,
    /// `scenarios/impacts.toml`.
    Impacts,
    /// `scenarios/gentle-unload-300hz.toml`.
    GentleUnload300,
}

impl Bundled {
    /// Every bundled scenario.
    pub const ALL: [Bundled; 7] = [
        Bundled::PaperProtocol200,
        Bundled::PaperProtocol300,
        Bundled::PaperProtocol400,
        Bundled::QuasiStaticJkr,
        Bundled::Resonance400,
        Bundled::Impacts,
        Bundled::GentleUnload300,
    ];

    /// Path relative to the crate root, e.g. `scenarios/impacts.toml`.
    pub fn path(self) -> &'static str {
        match self {
            Bundled::PaperProtocol200 => "scenarios/paper-protocol-200hz.toml",
            Bundled::PaperProtocol300 => "scenarios/paper-protocol-300hz.toml",
            Bundled::PaperProtocol400 => "scenarios/paper-protocol-400hz.toml",
            Bundled::QuasiStaticJkr => "scenarios/quasi-static-jkr.toml",
            Bundled::Resonance400 => "scenarios/resonance-400hz.toml",
            Bundled::Impacts => "scenarios/impacts.toml",
            Bundled::GentleUnload300 => "scenarios/gentle-unload-300hz.toml",
        }
    }

    /// The file's text, as compiled in.
    pub fn text(self) -> &'static str {
        match self {
            Bundled::PaperProtocol200 => include_str!("../../scenarios/paper-protocol-200hz.toml"),
            Bundled::PaperProtocol300 => include_str!("../../scenarios/paper-protocol-300hz.toml"),
            Bundled::PaperProtocol400 => include_str!("../../scenarios/paper-protocol-400hz.toml"),
            Bundled::QuasiStaticJkr => include_str!("../../scenarios/quasi-static-jkr.toml"),
            Bundled::Resonance400 => include_str!("../../scenarios/resonance-400hz.toml"),
            Bundled::Impacts => include_str!("../../scenarios/impacts.toml"),
            Bundled::GentleUnload300 => include_str!("../../scenarios/gentle-unload-300hz.toml"),
        }
    }

    /// The parsed, validated scenario (named by its path).
    pub fn scenario(self) -> Result<Scenario, ScenarioError> {
        parse_scenario(self.text(), self.path(), None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scenario without its provenance (text and name), to compare scenes built two ways.
    fn bare(mut s: Scenario) -> Scenario {
        s.source_text = "".into();
        s.source_name.clear();
        s
    }

    #[test]
    fn bundled_files_parse() {
        for b in Bundled::ALL {
            let s = b.scenario().unwrap_or_else(|e| panic!("{}: {e}", b.path()));
            assert_eq!(s.source_name, b.path());
            assert!(!s.stages.is_empty());
        }
    }

    /// The scenes that exist both in code and as a file are the same scene.
    #[test]
    fn code_and_file_agree() {
        let file = Bundled::QuasiStaticJkr.scenario().unwrap();
        assert_eq!(bare(quasi_static_jkr()), bare(file));

        let file = Bundled::Impacts.scenario().unwrap();
        let code = impacts(400e-6, paper_gs(), ContactFormation::JumpIn, 0.5);
        assert_eq!(code.rig, file.rig);
        assert_eq!(code.initial, file.initial);
        assert_eq!(code.stages[0].until, file.stages[0].until);

        let text = include_str!("../../docs/accuracy/hold-400hz-1s.toml");
        let file = parse_scenario(text, "docs/accuracy/hold-400hz-1s.toml", None).unwrap();
        let mut code = hold_400hz_1s();
        // The file keeps the parser's safety limit; the catalogue a longer one.
        code.stages[0].max_duration = file.stages[0].max_duration;
        assert_eq!(bare(code), bare(file));
    }

    #[test]
    fn ramp_oscillator_impact_time_is_a_root() {
        let (_, osc) = free_flight(2e-5, 2e-3, 0.1);
        let t = osc.impact_time();
        assert!(osc.position(t).abs() < 1e-18, "{}", osc.position(t));
        assert!(osc.position(0.99 * t) < 0.0);
    }
}
