//! Criterion benchmark of the identification grid search (target: the article's two grids,
//! 6817 candidates × 2 records of 3.2 s at 100 Hz, under 0.1 s wall on 2 cores). Uses the
//! records of bench/peer (model-generated, see bench/peer/README.md).

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::ident::{run_stages, Experiment, Options};
use std::path::Path;

fn bench(c: &mut Criterion) {
    let exp = Experiment::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/peer/experiment.toml"),
    )
    .expect("bench/peer/experiment.toml loads");
    let opts = Options {
        auto_refine: false,
        local_refinement: false,
        threshold_mm2: 0.25,
        top_n: 20,
    };
    let mut group = c.benchmark_group("identify");
    group.sample_size(10);
    group.bench_function("article_grids_6817_candidates_all_cores", |b| {
        b.iter(|| run_stages(&exp.problem, exp.grids(), &opts, None, &|_| {}).unwrap())
    });
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    group.bench_function("article_grids_6817_candidates_one_thread", |b| {
        b.iter(|| {
            one.install(|| run_stages(&exp.problem, exp.grids(), &opts, None, &|_| {}).unwrap())
        })
    });
    let cand = exp.grids().0.candidate(0);
    group.bench_function("one_candidate_cost_2_records", |b| {
        b.iter(|| exp.problem.cost(&cand))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
