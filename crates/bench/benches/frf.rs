//! Criterion benchmark of the frequency-response estimate (docs/identification.md#frequency-response-from-a-sweep)
//! of a 600 s record at 100 Hz (target: under 1 s): Welch's estimate of a chirp described by
//! nothing but its record, and the periodic estimate of a multisine checked against its
//! description, both with the rig's crossover check and the plant's response; and the
//! frequency-domain grid fit of β, b and c12 (docs/identification.md#grey-box-fit-to-a-frequency-response)
//! to that multisine on a grid of the article's size (3264 candidates) with its polish.

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::frf::{estimate, Excitation, Options};
use pumpcyl::ident::{Experiment, FrequencyProblem, Grid, SweepSet};
use pumpcyl::record::Record;
use pumpcyl::response::{sample_times, simulate, Baseline};
use pumpcyl::rig::Rig;
use std::hint::black_box;

/// The linear closed loop's record of `e` at 100 Hz.
fn record(rig: &Rig, e: &Excitation) -> Record {
    let t = sample_times(e.duration_s(), 100.0).unwrap();
    let r: Vec<f64> = t.iter().map(|&t| e.reference_mm(t)).collect();
    let s = simulate(rig, &t, &r, &Baseline::of_rig(rig)).unwrap();
    Record::from_arrays("bench.csv", &s.time_s, &s.x_ref_mm, &s.x_mm).unwrap()
}

fn bench(c: &mut Criterion) {
    let rig = Rig::default()
        .with_overrides(&["sum_pressure=false".to_string()])
        .unwrap();
    let chirp = Excitation::chirp(&rig, 5.0, (0.05, 3.0), (599.0, 1), 100.0);
    let rec = record(&rig, &chirp);
    assert_eq!(rec.len(), 60_001);
    let welch = Options {
        excitation: None,
        rig: Some(&rig),
        segment_s: None,
    };
    c.bench_function("frf_welch_600s_100hz", |b| {
        b.iter(|| estimate(black_box(&rec), &welch).unwrap())
    });
    let multisine = Excitation::multisine(&rig, 5.0, (0.05, 3.0), (30, 29), 100.0);
    let rec = record(&rig, &multisine);
    let periodic = Options {
        excitation: Some(multisine),
        rig: Some(&rig),
        segment_s: None,
    };
    c.bench_function("frf_multisine_600s_100hz", |b| {
        b.iter(|| estimate(black_box(&rec), &periodic).unwrap())
    });
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/article/identify.toml"
    );
    let exp = Experiment::load(std::path::Path::new(file)).unwrap();
    let problem = FrequencyProblem {
        sweeps: vec![SweepSet::new("bench.csv", &rec, rig.clone()).unwrap()],
        steps: None,
        standstill: exp.problem.standstill,
    };
    let grid = Grid::article_first();
    assert_eq!(grid.len(), 3264);
    let mut group = c.benchmark_group("frf_fit");
    group.sample_size(10);
    group.bench_function("grid_fit_article_grid", |b| {
        b.iter(|| problem.fit(black_box(&grid)).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
