//! The integration's overhead over its RHS work, measured in pairs: the compiled peer's
//! benchmark scene (`benches/scenes/vib400.toml`, 1 s at 400 Hz) at djkr's equal-accuracy
//! tolerance (rtol 1e-7) in process (no start-up, no files), and right after it as many DP8
//! right-hand sides as the run evaluated, called in a plain loop (`common::OneRhs`, the unit of
//! `one_rhs_dp8` in `benches/dynamics.rs`). Alternating the two keeps a noisy machine's
//! slow spells out of their ratio (criterion times the two benchmarks minutes apart).
//!
//! `cargo bench --bench overhead [-- ROUNDS]` (default 300): the medians and minima of both
//! and the median of the per-round ratios.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use djkr_core::dynamics::NoObserver;
use std::hint::black_box;
use std::time::Instant;

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(300)
        .max(1);
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/scenes/vib400.toml");
    let mut s = match djkr::scenario::parse::load_scenario(&file) {
        Ok(s) => s,
        Err(e) => panic!("cannot load {}: {e}", file.display()),
    };
    s.solver.rtol = 1e-7;
    let evals = match s.simulate(&mut NoObserver) {
        Ok(r) => r.stats.rhs_evals,
        Err(e) => panic!("vib400 does not run: {e}"),
    };
    let mut one = common::OneRhs::new();
    let (mut run, mut rhs, mut ratio) = (vec![], vec![], vec![]);
    for _ in 0..rounds {
        let t = Instant::now();
        let _ = black_box(
            black_box(&s)
                .simulate(&mut NoObserver)
                .map(|r| r.stats.steps),
        );
        let tr = t.elapsed().as_secs_f64();
        let t = Instant::now();
        for _ in 0..evals {
            let _ = black_box(one.call());
        }
        let tf = t.elapsed().as_secs_f64();
        run.push(tr);
        rhs.push(tf);
        ratio.push(tr / tf);
    }
    for v in [&mut run, &mut rhs, &mut ratio] {
        v.sort_by(f64::total_cmp);
    }
    let mid = rounds / 2;
    println!(
        "vib400 at rtol 1e-7 in process: median {:.3} ms, fastest {:.3} ms ({evals} RHS evaluations)",
        run[mid] * 1e3,
        run[0] * 1e3
    );
    println!(
        "{evals} DP8 right-hand sides in a loop: median {:.3} ms ({:.1} ns each), fastest {:.3} ms",
        rhs[mid] * 1e3,
        rhs[mid] / evals as f64 * 1e9,
        rhs[0] * 1e3
    );
    println!(
        "overhead (run / its RHS work): median of {rounds} paired ratios {:.2} (quartiles {:.2}, {:.2}); ratio of the fastest {:.2}",
        ratio[mid],
        ratio[rounds / 4],
        ratio[3 * rounds / 4],
        run[0] / rhs[0]
    );
}
