//! Criterion benchmark of the frequency analysis on the default rig (issue target: `margins`
//! < 200 µs per call, model assembly included).

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::lti::{eigenvalues, margins, FreqEvaluator};
use pumpcyl::model::Plant;
use pumpcyl::rig::Rig;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let rig = Rig::default();
    c.bench_function("margins_default_rig", |b| {
        b.iter(|| margins(&Plant::new(black_box(&rig)).open_loop(false)).unwrap())
    });
    let ol = Plant::new(&rig).open_loop(false);
    c.bench_function("poles_default_rig", |b| {
        b.iter(|| eigenvalues(black_box(&ol.a)).unwrap())
    });
    let ev = FreqEvaluator::new(&ol).unwrap();
    c.bench_function("freqresp_one_point", |b| b.iter(|| ev.at(black_box(3.0))));
}

criterion_group!(benches, bench);
criterion_main!(benches);
