//! Criterion benchmark of the exact ZOH simulation on the default rig (targets:
//! discretisation < 20 µs, a 3.2 s / 100 Hz (320-step) simulation < 10 µs).

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::lti::{Simulator, Zoh};
use pumpcyl::model::Plant;
use pumpcyl::rig::Rig;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let sys = Plant::new(&Rig::default()).closed_loop_outputs(true);
    c.bench_function("discretise_default_rig", |b| {
        b.iter(|| Zoh::new(black_box(&sys.a), black_box(&sys.b), 0.01).unwrap())
    });
    let t: Vec<f64> = (0..=320).map(|k| k as f64 * 0.01).collect();
    let u = vec![5e-3; t.len()];
    let x0 = vec![0.0; sys.order()];
    let mut sim = Simulator::new(&sys);
    sim.run(&t, &u, &x0).unwrap(); // discretise once, as a grid search would
    c.bench_function("simulate_320_steps_default_rig", |b| {
        b.iter(|| sim.run(black_box(&t), black_box(&u), &x0).unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
