//! Criterion benchmark of the single-pump candidate's mode check in the circuit selection
//! (docs/select.md#the-single-pump-circuit): the article's application restricted to the
//! single-pump circuit at one pre-charge (6 bar, its two loads, zero external force), with the
//! emulated check (the 5 mm step and the 0.2 Hz wave emulated per load) and with the
//! equations' check (the step on the circuit's own equations), so the difference is the
//! emulated check's cost per candidate.

use criterion::{criterion_group, criterion_main, Criterion};
use pumpcyl::circuit::CircuitKind;
use pumpcyl::limits::Work;
use pumpcyl::select::{Application, ModeCheckKind};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let app = Application {
        precharge_bar: vec![6.0],
        ..Application::default()
    }
    .with_circuits(&[CircuitKind::SinglePump])
    .expect("the article's rig allows the single-pump circuit");
    let mut group = c.benchmark_group("select_single_pump");
    group.sample_size(10);
    for kind in [ModeCheckKind::Emulator, ModeCheckKind::Equations] {
        let name = format!("article_application_one_candidate_{kind:?}").to_lowercase();
        group.bench_function(name, |b| {
            b.iter(|| {
                black_box(&app)
                    .select_checked(None, &Work::QUIET, kind.check())
                    .unwrap()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
