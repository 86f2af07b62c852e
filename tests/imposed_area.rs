//! Imposed-area method (Sec. 2.1): limits, independent references, convergence, pull-off.

use djkr::adhesion::GentSchultz;
use djkr::imposed_area::{cycle, pull_off};
use djkr::jkr;
use djkr::material::Material;
use std::f64::consts::PI;

const M: Material = Material::PAPER;

#[test]
fn zero_amplitude_is_classical_jkr() {
    let law = GentSchultz::PAPER;
    let a = 1.5e-3;
    let c = cycle(&M, &law, 2.0 * PI * 400.0, a, 0.0).unwrap();
    assert!((c.delta_mean / jkr::equilibrium_indentation(&M, a, M.w0) - 1.0).abs() < 1e-12);
    assert!((c.force_mean / jkr::equilibrium_force(&M, a, M.w0) - 1.0).abs() < 1e-12);
    let p = pull_off(&M, &law, 2.0 * PI * 400.0, 0.0).unwrap();
    let a_po = jkr::load_controlled_pull_off_radius(&M, M.w0);
    assert!((p.cycle.a_mean_imposed / a_po - 1.0).abs() < 1e-10, "{p:?}");
    assert!((p.amplification - 1.0).abs() < 1e-12);
}
