//! Criterion benchmark of the frequency-response estimate (docs/identification.md#frequency-response-from-a-sweep)
//! of a 600 s record at 100 Hz (target: under 1 s): Welch's estimate of a chirp described by
//! nothing but its record, and the periodic estimate of a multisine checked against its
//! description, both with the rig's crossover check and the plant's response.

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::frf::{estimate, Excitation, Options};
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
}

criterion_group!(benches, bench);
criterion_main!(benches);
