//! Reference scenes shared by the tests and the benchmarks (one catalogue, so the benchmark
//! measures what the tests prove correct).

use crate::adhesion::{GentSchultz, Law};
use crate::material::Material;
use crate::scenario::*;

/// A stage with a generous safety limit.
pub fn stage(kind: StageKind, speed: f64, until: Until, vibration: Option<bool>) -> Stage {
    Stage {
        kind,
        speed,
        until,
        vibration,
        max_duration: 1e7,
    }
}

/// The paper's material and Gent–Schultz law on a 3 g sphere held by a 200 N/m spring with light
/// sphere damping (c = 0.02 N s/m), a base shaking at `frequency` (Hz) with amplitude `xb` (m),
/// starting in JKR equilibrium under a 20 mN preload; one hold stage of `duration` (s) with the
/// shaker on; rtol 1e-8.
pub fn vibrating_hold(xb: f64, frequency: f64, duration: f64) -> Scenario {
    Scenario {
        rig: Rig {
            material: Material::PAPER,
            law: Law::GentSchultz(GentSchultz::PAPER),
            sphere: Sphere {
                mass: 3e-3,
                gravity: 9.81,
            },
            holder: Holder::Spring { stiffness: 200.0 },
            damping: Some(Damping {
                c: 0.02,
                on: DampingOn::Sphere,
            }),
            base: Some(BaseMotion {
                amplitude: xb,
                frequency,
                phase: 0.0,
            }),
            formation: ContactFormation::JumpIn,
        },
        initial: Initial::Preload(0.02),
        stages: vec![stage(
            StageKind::Hold,
            0.0,
            Until::Duration(duration),
            Some(true),
        )],
        solver: Solver {
            rtol: 1e-8,
            ..Solver::default()
        },
        output: Output::default(),
        source_text: String::new(),
        source_name: "<catalogue>".into(),
        overrides: Vec::new(),
    }
}

/// The paper's protocol (Sec. 3) with shortened dwells: from a 20 µm gap, approach at 100 µm/s
/// to a 50 mN preload, dwell 0.5 s, switch a 300 Hz, 10 µm shaker on, dwell 0.5 s, unload at
/// `unload_speed` (m/s; the paper's is 5 µm/s) to pull-off. m = 3 g, k = 200 N/m, c = 0.05 N s/m.
pub fn paper_protocol(unload_speed: f64) -> Scenario {
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
