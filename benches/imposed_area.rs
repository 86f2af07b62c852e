//! Imposed-area benchmarks: one cycle at the default accuracy, one pull-off point, and the whole
//! Figs. 4–8 table (3 frequencies × 61 amplitudes). Targets on the 2-core reference machine,
//! release build: cycle ≤ 20 µs, pull-off point ≤ 2 ms, table ≤ 0.3 s.

use criterion::{criterion_group, criterion_main, Criterion};
use djkr::adhesion::GentSchultz;
use djkr::imposed_area::{cycle, pull_off, pull_off_table};
use djkr::material::Material;
use std::f64::consts::PI;
use std::hint::black_box;

fn bench_cycle(c: &mut Criterion) {
    let m = Material::PAPER;
    let law = GentSchultz::PAPER;
    let omega = 2.0 * PI * 400.0;
    c.bench_function("cycle 400 Hz a_m 2 mm a_A 0.5 mm", |b| {
        b.iter(|| {
            cycle(
                &m,
                &law,
                black_box(omega),
                black_box(2e-3),
                black_box(0.5e-3),
            )
        })
    });
    c.bench_function("cycle truncated 400 Hz a_m 0.3 mm a_A 0.5 mm", |b| {
        b.iter(|| {
            cycle(
                &m,
                &law,
                black_box(omega),
                black_box(0.3e-3),
                black_box(0.5e-3),
            )
        })
    });
}

fn bench_pull_off(c: &mut Criterion) {
    let m = Material::PAPER;
    let law = GentSchultz::PAPER;
    let omega = 2.0 * PI * 400.0;
    c.bench_function("pull-off 400 Hz a_A 0.5 mm", |b| {
        b.iter(|| pull_off(&m, &law, black_box(omega), black_box(0.5e-3)))
    });
}

fn bench_table(c: &mut Criterion) {
    let m = Material::PAPER;
    let law = GentSchultz::PAPER;
    let freqs = [200.0, 300.0, 400.0];
    let amps: Vec<f64> = (0..=60).map(|i| i as f64 * 25e-6).collect();
    let mut g = c.benchmark_group("figs 4-8");
    g.sample_size(10);
    g.bench_function("pull-off table 3 x 61", |b| {
        b.iter(|| pull_off_table(&m, &law, black_box(&freqs), black_box(&amps)))
    });
    g.finish();
}

criterion_group!(benches, bench_cycle, bench_pull_off, bench_table);
criterion_main!(benches);
