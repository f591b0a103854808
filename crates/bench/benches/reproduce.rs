//! Criterion benchmark of the article's whole workflow (`pumpcyl reproduce` without writing its
//! files): every step of `pumpcyl_present::reproduce::reproduce`, figures rendered to SVG and
//! PNG in memory, on all cores and on one thread.

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl_present::reproduce::{reproduce, ReproduceOptions};
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("reproduce");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(15));
    group.bench_function("whole_workflow_all_cores", |b| {
        b.iter(|| reproduce(&ReproduceOptions::default()).unwrap())
    });
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    group.bench_function("whole_workflow_one_thread", |b| {
        b.iter(|| one.install(|| reproduce(&ReproduceOptions::default()).unwrap()))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
