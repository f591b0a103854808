//! Emulating the article's rig on the nonlinear emulator (docs/emulator.md): the article's 4 s
//! identification step (target: < 1 s), and 600 s of the emulated article rig with every effect
//! and the PLC's noise, as `pumpcyl emulate --experiment step --duration-s 600` runs it
//! (target: ≤ 0.3 s, 2000× real time, so a chatter check fits inside a selection), and the
//! same on the article's rig as each of the other circuits of its Figure 1; and 600 s of the
//! article's 0.2 Hz ±35 mm sine, in motion throughout (`pumpcyl emulate --experiment sine
//! --freq-hz 0.2 --amplitude-mm 35 --duration-s 600`), with the PLC's noise and without.

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::circuit::CircuitKind;
use pumpcyl::emulator::{article, Effects, Experiment, Plc};
use std::time::Duration;

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
    let rig = article::default_rig().unwrap();
    let effects = Effects::for_rig(&rig).unwrap();
    let plc = article::plc(1);
    let long = Experiment::step(&rig, None, None, 0.5, Some(600.0));
    let mut group = c.benchmark_group("emulator");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));
    group.bench_function("emulator_600s", |b| {
        b.iter(|| long.run(&rig, effects, &plc).unwrap())
    });
    let sine = Experiment::sine(&rig, 35.0, 0.2, 0.5, Some(600.0));
    group.bench_function("emulator_600s_sine", |b| {
        b.iter(|| sine.run(&rig, effects, &plc).unwrap())
    });
    let quiet = Plc::ideal(plc.rate_hz);
    group.bench_function("emulator_600s_sine_no_noise", |b| {
        b.iter(|| sine.run(&rig, effects, &quiet).unwrap())
    });
    for kind in [CircuitKind::DualPump, CircuitKind::SinglePump] {
        let rig = rig
            .with_overrides(&[format!("circuit={}", kind.name())])
            .unwrap();
        let effects = Effects::for_rig(&rig).unwrap();
        let name = format!("emulator_600s_{}", kind.name().replace('-', "_"));
        group.bench_function(name, |b| b.iter(|| long.run(&rig, effects, &plc).unwrap()));
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
