//! Criterion benchmark of the frequency analysis on the default rig (target: `margins` < 200 µs
//! per call, model assembly included), its frequency responses one at a time and four at a
//! time, and the largest-gain search of the design method (the article §2.2) built on it.

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::design::{kp_max, Targets};
use pumpcyl::lti::{eigenvalues, log_grid, margins, FreqEvaluator};
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
    // about the seed grid of one margins analysis of the default rig
    let omega = log_grid(0.1, 1e6, 148);
    c.bench_function("freqresp_148_points_one_at_a_time", |b| {
        b.iter(|| {
            black_box(&omega)
                .iter()
                .map(|&w| ev.at(w))
                .collect::<Vec<_>>()
        })
    });
    c.bench_function("freqresp_148_points_four_at_a_time", |b| {
        b.iter(|| ev.at_many(black_box(&omega)))
    });
    let targets = Targets::default();
    c.bench_function("kp_max_default_rig_default_targets", |b| {
        b.iter(|| kp_max(black_box(&rig), &targets).unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
