//! The Rust side of `benches/python_overhead.py`: the library calls the Python binding makes,
//! timed without Python, so that the script can tell the binding's overhead from the work.
//!
//!   cargo run --release --example api_timing -- [SCENE] [RUNS] [CYCLE_BATCHES]
//!
//! - `run`: what `djkr.run(SCENE)` does in Rust: read and validate the scenario file, then
//!   `djkr::api::run` with the time series kept in memory (no folder); RUNS single calls.
//! - `cycle`: what `djkr.cycle(400.0, 0.002, 0.0005)` does: `djkr::api::cycle` on the default
//!   material with the arguments as text, and its JSON object; CYCLE_BATCHES batches of 1000.
//!
//! Prints one JSON object: every run's wall time and every batch's time per call (s).

use djkr::api;
use djkr::scenario::parse::ScenarioSource;
use djkr_core::units::Dimension;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let scene = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "benches/scenes/vib400.toml".into()),
    );
    let runs: usize = args.next().map_or(Ok(30), |a| a.parse())?;
    let batches: usize = args.next().map_or(Ok(15), |a| a.parse())?;

    let mut run_s = Vec::with_capacity(runs);
    let mut samples = 0;
    for _ in 0..runs {
        let t0 = Instant::now();
        let scn = ScenarioSource::read(&scene)?.scenario(&[])?;
        let rec = api::run(&scn, None)?;
        run_s.push(t0.elapsed().as_secs_f64());
        samples = rec.series.rows();
        black_box(rec);
    }

    let (m, law) = api::default_material();
    let mut cycle_s = Vec::with_capacity(batches);
    for _ in 0..batches {
        let t0 = Instant::now();
        for _ in 0..1000 {
            let req = api::CycleRequest {
                freq: api::Quantity::parse("freq", black_box("400.0"), Dimension::Frequency)?,
                a_mean: api::Quantity::parse("a_mean", black_box("0.002"), Dimension::Length)?,
                a_amp: api::Quantity::parse("a_amp", black_box("0.0005"), Dimension::Length)?,
            };
            let r = api::cycle(&m, &law, &req)?;
            api::check_finite(&r)?;
            black_box(serde_json::to_value(&r)?);
        }
        cycle_s.push(t0.elapsed().as_secs_f64() / 1000.0);
    }
    println!(
        "{}",
        serde_json::json!({
            "scene": scene.display().to_string(),
            "samples": samples,
            "run_s": run_s,
            "cycle_s": cycle_s,
        })
    );
    Ok(())
}
