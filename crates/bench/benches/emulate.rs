//! Emulating the article's 4 s identification step on the nonlinear rig (target: < 1 s).

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::emulator::article;
use pumpcyl::emulator::Experiment;

fn bench(c: &mut Criterion) {
    let rec = &article::records().unwrap()[0];
    let step = Experiment::Step {
        from_mm: 340.0,
        to_mm: 345.0,
        at_s: 0.5,
        duration_s: 4.0,
    };
    c.bench_function("emulate 4 s step (100 Hz PLC, all effects)", |b| {
        b.iter(|| {
            step.run(&rec.truth.rig, rec.truth.effects, &rec.truth.plc)
                .unwrap()
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
