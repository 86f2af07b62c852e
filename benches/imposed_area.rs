//! Imposed-area benchmarks: one cycle at the default accuracy, one pull-off point, and the whole
//! Figs. 4–8 table (3 frequencies × 61 amplitudes), at the catalogue's operating points
//! (`crate::catalogue::{CYCLE_400HZ, CYCLE_400HZ_TRUNCATED, PULL_OFF_400HZ, figs_4_to_8_grid}`).
//! Targets on the 2-core reference machine, release build: cycle ≤ 20 µs, pull-off point
//! ≤ 2 ms, table ≤ 0.3 s.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
use crate::catalogue::{
    figs_4_to_8_grid, ImposedCycle, CYCLE_400HZ, CYCLE_400HZ_TRUNCATED, PULL_OFF_400HZ,
};
use criterion::{criterion_group, criterion_main, Criterion};
use djkr_core::adhesion::GentSchultz;
use djkr_core::imposed_area::{cycle, pull_off, pull_off_table};
use djkr_core::material::Material;
use std::hint::black_box;

fn bench_cycle(c: &mut Criterion) {
    let m = Material::PAPER;
    let law = GentSchultz::PAPER;
    let point = |p: ImposedCycle| (p.omega(), p.a_mean, p.a_amp);
    let (omega, a_m, a_a) = point(CYCLE_400HZ);
    c.bench_function("cycle 400 Hz a_m 2 mm a_A 0.5 mm", |b| {
        b.iter(|| cycle(&m, &law, black_box(omega), black_box(a_m), black_box(a_a)))
    });
    let (omega, a_m, a_a) = point(CYCLE_400HZ_TRUNCATED);
    c.bench_function("cycle truncated 400 Hz a_m 0.3 mm a_A 0.5 mm", |b| {
        b.iter(|| cycle(&m, &law, black_box(omega), black_box(a_m), black_box(a_a)))
    });
}

fn bench_pull_off(c: &mut Criterion) {
    let m = Material::PAPER;
    let law = GentSchultz::PAPER;
    let p = PULL_OFF_400HZ;
    c.bench_function("pull-off 400 Hz a_A 0.5 mm", |b| {
        b.iter(|| pull_off(&m, &law, black_box(p.omega()), black_box(p.a_amp)))
    });
}

fn bench_table(c: &mut Criterion) {
    let m = Material::PAPER;
    let law = GentSchultz::PAPER;
    let (freqs, amps) = figs_4_to_8_grid();
    let mut g = c.benchmark_group("figs 4-8");
    g.sample_size(10);
    g.bench_function("pull-off table 3 x 61", |b| {
        b.iter(|| pull_off_table(&m, &law, black_box(&freqs), black_box(&amps)))
    });
    g.finish();
}

criterion_group!(benches, bench_cycle, bench_pull_off, bench_table);
criterion_main!(benches);
