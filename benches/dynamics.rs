//! Time-domain simulator benchmarks: 1 s of steady vibration at 400 Hz (rtol 1e-8), and the
//! paper's protocol with a fast unload, each with the implicit method and with `auto`.
use criterion::{criterion_group, criterion_main, Criterion};
use djkr::dynamics::catalogue::{paper_protocol, vibrating_hold};
use djkr::dynamics::{simulate, NoObserver};
use djkr::scenario::Method;
use std::hint::black_box;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("dynamics");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (name, m) in [("implicit", Method::Implicit), ("auto", Method::Auto)] {
        let mut s = vibrating_hold(5e-6, 400.0, 1.0);
        s.solver.method = m;
        let r = simulate(&s, &mut NoObserver).expect("vibration scene runs");
        eprintln!("vibration_1s_400Hz/{name}: {:?}; {}", r.stats, r.method);
        g.bench_function(format!("vibration_1s_400Hz/{name}"), |b| {
            b.iter(|| simulate(black_box(&s), &mut NoObserver).map(|r| r.stats.steps))
        });
        let mut s = paper_protocol(1e-3);
        s.solver.method = m;
        let r = simulate(&s, &mut NoObserver).expect("protocol runs");
        eprintln!(
            "protocol_unload_1mm_s/{name}: pull-off {:?} at t = {}; {:?}; {}",
            r.pull_off.force, r.final_state.t, r.stats, r.method
        );
        g.bench_function(format!("protocol_unload_1mm_s/{name}"), |b| {
            b.iter(|| simulate(black_box(&s), &mut NoObserver).map(|r| r.stats.steps))
        });
    }
    // The cost of one right-hand-side evaluation (one stage residual: mechanical closed form,
    // signed G, w(ȧ) of the GS law), to compare with wall / rhs_evals.
    let s = vibrating_hold(5e-6, 400.0, 1.0);
    let model = djkr::dynamics::model::resolve(&s).expect("scene resolves");
    let drive = djkr::dynamics::model::Drive {
        xk0: 0.0,
        tk0: 0.0,
        xk_speed: 0.0,
        shaker: true,
        t_on: 0.0,
    };
    let kin = drive.at(&model, 1e-4);
    g.bench_function("one_rhs", |b| {
        let mut a = 1.1e-3;
        b.iter(|| {
            a += 1e-12;
            let ad = (a - 1.1e-3) / 1e-6;
            let (x, _) = model.position(&kin, a, ad, true, 1e-5, 0.0, 1e-6);
            let g = djkr::jkr::signed_energy_release_rate(&model.mat, a, x + kin.xb);
            black_box(g - model.work_of_adhesion(black_box(ad)))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
