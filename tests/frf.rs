//! Frequency response from sweep records (docs/identification.md#frequency-response-from-a-sweep):
//! the estimate of noise-free sweeps of the linear model against the model's own response, the
//! stepped sine's least squares against the exact response, and the records it refuses.

use pumpcyl::frf::{self, Excitation, FrfError, Options};
use pumpcyl::model::Plant;
use pumpcyl::record::Record;
use pumpcyl::response::{simulate, Baseline};
use pumpcyl::rig::Rig;

/// The article's rig with the sum-pressure loop open (the P law of the plant estimate).
fn rig() -> Rig {
    Rig::default()
        .with_overrides(&["sum_pressure=false".to_string()])
        .unwrap()
}

/// A noise-free record of the linear closed loop driven by `e`, sampled at `rate_hz`.
fn linear_record(rig: &Rig, e: &Excitation, rate_hz: f64) -> Record {
    let t = pumpcyl::response::sample_times(e.duration_s(), rate_hz).unwrap();
    let r: Vec<f64> = t.iter().map(|&t| e.reference_mm(t)).collect();
    let s = simulate(rig, &t, &r, &Baseline::of_rig(rig)).unwrap();
    let mut rec = Record::from_arrays("linear.csv", &s.time_s, &s.x_ref_mm, &s.x_mm).unwrap();
    rec.w1_rpm = Some(s.w1_rpm.clone());
    rec
}

#[test]
fn print_design() {
    let rig = rig();
    let d = frf::design(&rig, &frf::DesignGoal::default()).unwrap();
    eprintln!("{d:#?}");
}

/// The largest |ΔdB| and |Δdeg| between an estimate's points of coherence above 0.99 and the
/// model's closed loop (sampled at `rate_hz`, or continuous), and how many points were compared.
fn worst_against_model(rig: &Rig, est: &frf::Estimate, rate_hz: Option<f64>) -> (f64, f64, usize) {
    let sys = Plant::new(rig).closed_loop(rig.sum_pressure);
    let good: Vec<_> = est
        .closed_loop
        .points
        .iter()
        .filter(|p| p.coherence > 0.99)
        .collect();
    let f: Vec<f64> = good.iter().map(|p| p.freq_hz).collect();
    let model = frf::model_response(&sys, &f, rate_hz).unwrap();
    let mut worst = (0.0f64, 0.0f64, good.len());
    for (p, h) in good.iter().zip(&model) {
        let ratio = p.h() / h;
        worst.0 = worst.0.max((20.0 * ratio.norm().log10()).abs());
        worst.1 = worst.1.max(ratio.arg().to_degrees().abs());
    }
    worst
}

#[test]
fn chirp_of_the_linear_model_gives_its_closed_loop_response() {
    let rig = rig();
    for (rate_hz, sampled) in [(100.0, true), (1000.0, false)] {
        let e = Excitation::chirp(&rig, 5.0, (0.05, 3.0), 100.0, 3);
        let rec = linear_record(&rig, &e, rate_hz);
        let est = frf::estimate(
            &rec,
            &Options {
                excitation: Some(e),
                rig: Some(&rig),
                segment_s: None,
            },
        )
        .unwrap();
        let (db, deg, n) = worst_against_model(&rig, &est, sampled.then_some(rate_hz));
        eprintln!(
            "chirp at {rate_hz} Hz: {n} of {} points, worst {db:.4} dB {deg:.4} deg",
            est.closed_loop.points.len()
        );
        assert!(n >= 20, "{n} points above 0.99");
        assert!(db < 0.1 && deg < 1.0, "{db} dB, {deg} deg");
    }
}

#[test]
fn multisine_of_the_linear_model_gives_its_sampled_response() {
    let rig = rig();
    let e = Excitation::multisine(&rig, 5.0, 0.05, 3.0, 40, 4);
    let rec = linear_record(&rig, &e, 100.0);
    let est = frf::estimate(
        &rec,
        &Options {
            excitation: Some(e),
            rig: Some(&rig),
            segment_s: None,
        },
    )
    .unwrap();
    assert_eq!(est.method, frf::Method::Periods);
    let (db, deg, n) = worst_against_model(&rig, &est, Some(100.0));
    eprintln!(
        "multisine: {n} of {} points, worst {db:.2e} dB {deg:.2e} deg",
        est.closed_loop.points.len()
    );
    assert!(n >= 20 && db < 1e-3 && deg < 1e-2, "{n} {db} {deg}");
}

#[test]
fn stepped_sine_least_squares_gives_the_exact_response_at_its_frequencies() {
    let rig = rig();
    let decay_s = pumpcyl::response::transient_decay_s(&rig).unwrap();
    let e = Excitation::stepped_sine(&rig, 5.0, (0.1, 3.0), (12, 4), (2, 2.0 * decay_s));
    let rec = linear_record(&rig, &e, 100.0);
    let opts = Options {
        excitation: Some(e),
        rig: Some(&rig),
        segment_s: None,
    };
    let est = frf::estimate(&rec, &opts).unwrap();
    assert_eq!(est.method, frf::Method::SineFit);
    assert_eq!(est.closed_loop.points.len(), 12);
    let (db, deg, n) = worst_against_model(&rig, &est, Some(100.0));
    eprintln!("stepped: {n} points, worst {db:.2e} dB {deg:.2e} deg");
    assert!(n == 12 && db < 0.01 && deg < 0.1, "{n} {db} {deg}");
}

#[test]
fn debug_chirp() {
    let rig = rig();
    eprintln!(
        "decay {}",
        pumpcyl::response::transient_decay_s(&rig).unwrap()
    );
    let e = Excitation::chirp(&rig, 5.0, (0.05, 3.0), 100.0, 3);
    let rec = linear_record(&rig, &e, 1000.0);
    let est = frf::estimate(
        &rec,
        &Options {
            excitation: Some(e),
            rig: Some(&rig),
            segment_s: None,
        },
    )
    .unwrap();
    let sys = Plant::new(&rig).closed_loop(rig.sum_pressure);
    let f: Vec<f64> = est.closed_loop.points.iter().map(|p| p.freq_hz).collect();
    let model = frf::model_response(&sys, &f, None).unwrap();
    for (p, h) in est.closed_loop.points.iter().zip(&model).step_by(16) {
        let ratio = p.h() / h;
        eprintln!(
            "{:.4} coh {:.5} dB {:.3} deg {:.3} eps {:.2e}",
            p.freq_hz,
            p.coherence,
            20.0 * ratio.norm().log10(),
            ratio.arg().to_degrees(),
            p.relative_error
        );
    }
}
