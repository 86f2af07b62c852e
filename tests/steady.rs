//! Steady state by shooting and by time-stepping.

use djkr::scenario::parse::load_scenario;
use djkr::steady::{Options, Problem, Strategy};

#[test]
#[ignore]
fn explore() {
    let scn = load_scenario(std::path::Path::new("scenarios/resonance-400hz.toml")).unwrap();
    let (p, start) = Problem::from_scenario(&scn).unwrap();
    for strat in [Strategy::Shooting, Strategy::TimeStepping] {
        let o = Options {
            strategy: strat,
            ..Options::default()
        };
        let t = std::time::Instant::now();
        match p.solve(&start, &o) {
            Ok(s) => println!(
                "{:?}: cycles {} newton {} res {:e} dist {:e} wall {:.3}s |d|/Xb {:.6} a_m {:.9e} a_A {:.3e} F_m {:.9e} state {:?}",
                s.method, s.cycles, s.newton_iterations, s.residual, s.distance, t.elapsed().as_secs_f64(),
                s.transfer_magnitude(), s.cycle.a_mean, s.a_amp(), s.cycle.force_mean, s.state
            ),
            Err(e) => println!("{strat:?}: {e}"),
        }
    }
}

#[test]
#[ignore]
fn explore_compare() {
    for f in [
        "scenarios/resonance-400hz.toml",
        "scenarios/paper-protocol-400hz.toml",
    ] {
        let scn = load_scenario(std::path::Path::new(f)).unwrap();
        let c = djkr::steady::compare::compare(&scn, &Options::default()).unwrap();
        println!("{f}: {}", serde_json::to_string_pretty(&c).unwrap());
    }
}
