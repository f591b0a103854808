//! Criterion benchmark of the circuit selection (docs/select.md): the article's application
//! with two circuits and ten pressure levels (the low-pressure circuit at 1, 2, 4, 6, 8 and
//! 10 bar, the pressurised one at 20, 30, 40 and 50 bar), the default uncertainty of the
//! undissolved air. Target: a full selection in under 1 s on a 2-core machine.

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::select::Application;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let app = Application {
        low_pressure_bar: vec![1.0, 2.0, 4.0, 6.0, 8.0, 10.0],
        pressurised_bar: vec![20.0, 30.0, 40.0, 50.0],
        ..Application::default()
    };
    let mut group = c.benchmark_group("select");
    group.sample_size(10);
    group.bench_function("article_application_two_circuits_ten_levels", |b| {
        b.iter(|| black_box(&app).select(None).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
