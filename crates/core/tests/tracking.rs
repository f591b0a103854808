//! Sinusoidal tracking in the periodic steady state (docs/simulation.md#tracking-metrics)
//! against an independent reference: the continuous closed-loop frequency response from the
//! reference to the position, by a complex solve of (jωI − A), with the zero-order hold of the
//! sampled reference, e^{−jωh/2}·sin(ωh/2)/(ωh/2): max |e| = a·|1 − T(jω)·ZOH(jω)|.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use pumpcyl::model::Plant;
use pumpcyl::response::{self, Baseline, ARTICLE_SINE_CASES};
use pumpcyl::rig::Rig;
use std::f64::consts::PI;

/// The rig `pumpcyl reproduce` identifies on the embedded records (summary.json `identified`,
/// `leakage`): the default rig with β, b, c12 and c1, c2 from standstill.
fn identified() -> Rig {
    Rig {
        beta_bar: 166.2012691219017,
        viscous_friction_ns_per_m: 142.91168356834623,
        c12_m5_per_ns: 1.2609713416007314e-10,
        c1_m5_per_ns: 5.784886765967618e-11,
        c2_m5_per_ns: -1.3889052500812698e-11,
        ..Rig::default()
    }
}

/// A rig that is not the article's: a larger bore, a lighter load, stiffer oil, another gain.
fn other() -> Rig {
    Rig::from_toml_str(
        "piston_diameter_mm = 80.0\nrod_diameter_mm = 45.0\nmass_kg = 4000.0\n\
         beta_bar = 400.0\nkp = 15.0\nk_pres_per_bar = 0.15\n",
        "other.toml",
    )
    .unwrap()
}

/// a·|1 − T(jω)·ZOH(jω)| (mm): T from x_ref to x of the closed loop as simulated (sum-pressure
/// loop as the rig says), solved directly on its matrices.
fn reference_max_error_mm(rig: &Rig, freq_hz: f64, amp_mm: f64, rate_hz: f64) -> f64 {
    let sys = Plant::new(rig).closed_loop_outputs(rig.sum_pressure);
    let (w, h) = (2.0 * PI * freq_hz, 1.0 / rate_hz);
    let n = sys.order();
    let lhs = DMatrix::from_fn(n, n, |i, j| {
        let s = if i == j {
            Complex64::new(0.0, w)
        } else {
            Complex64::new(0.0, 0.0)
        };
        s - sys.a[(i, j)]
    });
    let b = DVector::from_fn(n, |i, _| Complex64::new(sys.b[(i, 0)], 0.0));
    let x = lhs.lu().solve(&b).unwrap();
    let t: Complex64 = (0..n).map(|j| x[j] * sys.c[(0, j)]).sum();
    let zoh = Complex64::from_polar((w * h / 2.0).sin() / (w * h / 2.0), -w * h / 2.0);
    amp_mm * (Complex64::new(1.0, 0.0) - t * zoh).norm()
}

/// The rigs checked: the article's, another, and the identified one.
fn rigs() -> [(&'static str, Rig); 3] {
    [
        ("default", Rig::default()),
        ("other", other()),
        ("identified", identified()),
    ]
}

#[test]
fn steady_state_errors_match_the_frequency_response() {
    for (name, rig) in rigs() {
        for (f, a) in ARTICLE_SINE_CASES {
            let rate = 100.0;
            let (s, m) = response::track(&rig, f, a, 2, rate).unwrap();
            let wave = reference_max_error_mm(&rig, f, a, rate);
            // the error is the wave's about the loop's standing error at rest
            // (docs/simulation.md#the-rest-under-load; tests/rest_offset.rs checks it against
            // the emulator): e(t) = offset + E·sin(ωt + φ)
            let offset = m.rest_offset_mm.unwrap();
            assert!(offset.abs() < 0.1 * wave, "{name}: offset {offset} mm");
            let want = offset.abs() + wave;
            // the samples catch the peak of |e| to within half a sample of phase: cos(π f/rate)
            let lo = offset.abs() + wave * (PI * f / rate).cos();
            assert!(
                m.max_error_mm <= want * (1.0 + 1e-6) && m.max_error_mm >= lo * (1.0 - 1e-6),
                "{name} {f} Hz: {} mm, reference {want} mm",
                m.max_error_mm
            );
            // a whole number of periods of a sine about a constant: the RMS of both
            let rms = (offset * offset + wave * wave / 2.0).sqrt();
            assert!(
                (m.rms_error_mm - rms).abs() <= 1e-5 * rms,
                "{name} {f} Hz: RMS {} mm, reference {rms} mm",
                m.rms_error_mm
            );
            assert!((m.wave_reduction - (1.0 - m.max_error_mm / a)).abs() < 1e-15);
            assert!(m.window.steady_state && m.window.periods == [1, 2]);
            assert_eq!(s.time_s.len(), (2.0 * rate / f).round() as usize + 1);
        }
    }
}

#[test]
fn the_article_waves_on_the_identified_rig() {
    // the numbers reproduce's model column shows (mm; the wave's error about the 0.060 mm rest
    // offset), and the frequency response's
    let rig = identified();
    for ((f, a), want) in ARTICLE_SINE_CASES
        .into_iter()
        .zip([9.1146, 13.1467, 9.7062])
    {
        let (_, m) = response::track(&rig, f, a, 1, 100.0).unwrap();
        assert!(
            (m.max_error_mm - want).abs() < 1e-4,
            "{f} Hz: {}",
            m.max_error_mm
        );
        let reference = reference_max_error_mm(&rig, f, a, 100.0) + m.rest_offset_mm.unwrap().abs();
        assert!((m.max_error_mm - reference).abs() < 1e-4 * reference);
    }
}

#[test]
fn every_steady_period_is_alike_and_the_response_from_rest_converges_to_it() {
    let rig = identified();
    let (f, a, rate) = (0.25, 20.0, 100.0);
    let per = (rate / f) as usize;
    let (s, _) = response::track(&rig, f, a, 3, rate).unwrap();
    for k in 0..2 * per {
        assert!((s.e_mm[k] - s.e_mm[k + per]).abs() < 1e-9, "sample {k}");
        assert!((s.p1_bar[k] - s.p1_bar[k + per]).abs() < 1e-9, "sample {k}");
    }
    // from rest, the same wave: the difference is the start-up transient, and it has decayed
    // below 1 % of its largest by the decay time ln(100)/|Re λ| of the slowest pole
    let decay = response::transient_decay_s(&rig).unwrap();
    let periods = (2.0 * decay * f).ceil() as u32;
    let (steady, _) = response::track(&rig, f, a, periods, rate).unwrap();
    let base = Baseline::of_rig(&rig);
    let rest = response::simulate(&rig, &steady.time_s, &steady.x_ref_mm, &base).unwrap();
    let gap: Vec<f64> = rest
        .e_mm
        .iter()
        .zip(&steady.e_mm)
        .map(|(r, s)| (r - s).abs())
        .collect();
    let largest = gap.iter().fold(0.0f64, |m, g| m.max(*g));
    let after = steady
        .time_s
        .iter()
        .zip(&gap)
        .filter(|(t, _)| **t >= decay)
        .fold(0.0f64, |m, (_, g)| m.max(*g));
    assert!(
        largest > 1.0,
        "the start-up transient is millimetres: {largest}"
    );
    assert!(
        after < 0.01 * largest,
        "{after} of {largest} mm after {decay} s"
    );
    // and it was still above 1 % a period earlier: the decay time is not a loose bound
    let before = steady
        .time_s
        .iter()
        .zip(&gap)
        .filter(|(t, _)| **t >= decay - 1.0 / f)
        .fold(0.0f64, |m, (_, g)| m.max(*g));
    assert!(before > 0.01 * largest, "{before} of {largest} mm");
}

#[test]
fn the_slowest_pole_sets_the_decay_time() {
    // the article's rig: its dominant closed-loop pair near −0.41 ± 3.99j rad/s (ζ ≈ 0.10)
    let rig = Rig::default();
    let sys = Plant::new(&rig).closed_loop_outputs(rig.sum_pressure);
    let slowest = pumpcyl::lti::eigenvalues(&sys.a)
        .unwrap()
        .into_iter()
        .max_by(|a, b| a.re.total_cmp(&b.re))
        .unwrap();
    assert!(
        (slowest.re + 0.41).abs() < 0.01 && (slowest.im.abs() - 3.99).abs() < 0.02,
        "{slowest}"
    );
    let decay = response::transient_decay_s(&rig).unwrap();
    assert!((decay - 100f64.ln() / -slowest.re).abs() < 1e-12);
    assert!((11.0..11.5).contains(&decay), "{decay}");
    // an unstable loop has no decay time and no steady state
    let unstable = Rig {
        kp: 400.0,
        ..Rig::default()
    };
    assert!(response::transient_decay_s(&unstable).is_err());
    assert!(response::track(&unstable, 0.2, 35.0, 1, 100.0).is_err());
}

#[test]
fn a_steady_state_on_a_record_clock_is_the_same_wave_shifted() {
    // the wave starting at 1 s, seen on the samples 21–41 s of a record's clock: the same
    // steady state as from its own start, two periods on
    let rig = identified();
    let (f, a) = (0.1, 50.0);
    let (own, _) = response::track(&rig, f, a, 4, 100.0).unwrap();
    let clock: Vec<f64> = (2100..=4100).map(|k| k as f64 / 100.0).collect();
    let base = Baseline::of_rig(&rig);
    let shifted = response::steady_sine(&rig, f, a, 1.0, &clock, &base).unwrap();
    for (k, e) in shifted.e_mm.iter().enumerate() {
        assert!((e - own.e_mm[2000 + k]).abs() < 1e-9, "sample {k}");
    }
    // uneven sample times have no single sampled loop: refused
    let mut uneven = clock.clone();
    uneven[5] += 0.003;
    assert!(response::steady_sine(&rig, f, a, 1.0, &uneven, &base).is_err());
    assert!(response::track(&rig, f, a, 0, 100.0).is_err());
    assert!(
        response::track(&rig, 60.0, a, 1, 100.0).is_err(),
        "above Nyquist"
    );
}
