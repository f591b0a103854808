//! The uncertainty analysis (docs/identification.md, "Uncertainty"): first the coverage of its
//! 95 % intervals, measured once on records simulated by the LTI model with known truth and
//! fresh noise (printed, and checked to lie in 90–99 %); then the time of the whole analysis of
//! the article's emulated records (data/article/identify.toml), and of the rest of "How sure are
//! we" on them: the robust design over the confidence region (docs/design.md#robust-design,
//! identification included) and the experiment advice (docs/identification.md, "Experiment
//! advice").
//!
//! `PUMPCYL_COVERAGE_RUNS` sets the number of simulated records (default 400).

#[path = "../../core/tests/common/synthetic.rs"]
mod synthetic;

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::design::robust::RobustOptions;
use pumpcyl::design::{robust_design, Region, Targets};
use pumpcyl::ident::{
    advise_experiment, analyze, search, spaced, Experiment, Grid, Options, SearchOptions,
    UncertaintyOptions,
};
use rayon::prelude::*;
use std::path::Path;
use synthetic::{problem, TRUTH};

/// Position noise of the simulated records (mm): a few times the article's fit residual
/// floor, so the intervals are a few per cent wide.
const NOISE_MM: f64 = 0.05;

/// A coarse grid that does not hold the truth: the analysis starts from its best point.
fn coarse() -> Grid {
    Grid {
        beta_bar: vec![100.0, 140.0, 190.0, 250.0],
        viscous_friction_ns_per_m: vec![50.0, 200.0, 400.0],
        c12_m5_per_ns: spaced(0.5e-10, 3.2e-10, 5, true),
    }
}

/// Whether the 95 % intervals of β and c12 contain the truth, for one record pair.
fn covers(seed: u64) -> [bool; 2] {
    let p = problem(&TRUTH, NOISE_MM, seed, 2);
    let opts = SearchOptions {
        top_n: 1,
        threshold_mm2: 1e-9,
        shard: None,
    };
    let start = search(&p, &coarse(), 1, opts, &|_| true).top[0].candidate;
    let u = analyze(
        &p,
        &start,
        &UncertaintyOptions {
            confidence: 0.95,
            profile: [true, false, true],
        },
    )
    .expect("analysis of a simulated record");
    let inside = |name: &str, t: f64| {
        let [lo, hi] = u.profile(name).expect("profiled").interval;
        lo <= t && t <= hi
    };
    [
        inside("beta_bar", TRUTH.beta_bar),
        inside("c12_m5_per_ns", TRUTH.c12_m5_per_ns),
    ]
}

fn coverage() {
    let runs: u64 = std::env::var("PUMPCYL_COVERAGE_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(400);
    let start = std::time::Instant::now();
    let hits: Vec<[bool; 2]> = (1..=runs).into_par_iter().map(covers).collect();
    let share = |i: usize| hits.iter().filter(|h| h[i]).count() as f64 / runs as f64;
    let both = hits.iter().filter(|h| h[0] && h[1]).count() as f64 / runs as f64;
    eprintln!(
        "coverage of the 95 % intervals over {runs} simulated record pairs (noise {NOISE_MM} mm): \
         beta {:.1} %, c12 {:.1} %, both {:.1} % ({:.1} s)",
        100.0 * share(0),
        100.0 * share(1),
        100.0 * both,
        start.elapsed().as_secs_f64()
    );
    for (name, c) in [("beta", share(0)), ("c12", share(1))] {
        assert!(
            (0.90..=0.99).contains(&c),
            "coverage of {name}: {c} outside 90–99 %"
        );
    }
}

fn bench(c: &mut Criterion) {
    coverage();
    let exp = Experiment::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/article/identify.toml"),
    )
    .expect("data/article/identify.toml loads");
    let best = exp.identify(&Options::default()).unwrap().best().candidate;
    let mut group = c.benchmark_group("uncertainty");
    group.sample_size(10);
    group.bench_function("article_records_all_three_profiles", |b| {
        b.iter(|| analyze(&exp.problem, &best, &UncertaintyOptions::default()).unwrap())
    });
    group.bench_function("article_records_robust_design_with_identification", |b| {
        b.iter(|| {
            let (rig, region) = Region::of_records(&exp, 0.95).unwrap();
            robust_design(
                &rig,
                &region,
                &Targets::default(),
                &RobustOptions::default(),
            )
            .unwrap()
        })
    });
    group.bench_function(
        "article_records_experiment_advice_with_identification",
        |b| {
            b.iter(|| {
                advise_experiment(&exp, &pumpcyl::source_files::Disk, None, (0.95, None)).unwrap()
            })
        },
    );
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
