//! Margins, poles and Bode of small plants against closed-form results (docs/analysis.md#margins).

use nalgebra::DMatrix;
use num_complex::Complex64;
use pumpcyl::lti::{bode, margins, CrossingKind, FreqEvaluator};
use std::f64::consts::PI;

mod common;
use common::{poly, tf};

fn hz(w: f64) -> f64 {
    w / (2.0 * PI)
}

#[test]
fn integrator_with_lag_closed_form_pm_infinite_gm() {
    // L = K / (s (τ s + 1)), K = 10, τ = 0.5  →  den = s² + 2 s, num = 20
    let (k, tau) = (10.0, 0.5);
    let m = margins(&tf(&[k / tau], &[1.0, 1.0 / tau, 0.0])).unwrap();
    let wc = ((-1.0 + (1.0 + 4.0 * tau * tau * k * k).sqrt()) / (2.0 * tau * tau)).sqrt();
    let pm = 90.0 - (tau * wc).atan().to_degrees();
    assert!((m.phase_margin_deg.unwrap() - pm).abs() < 1e-8, "{m:?}");
    assert!((m.gain_crossover_hz.unwrap() - hz(wc)).abs() < 1e-9 * hz(wc));
    assert_eq!(m.gain_margin_db, None, "GM must be infinite");
    assert_eq!(m.phase_crossover_hz, None);
    let dm = pm.to_radians() / wc;
    assert!((m.delay_margin_s.unwrap() - dm).abs() < 1e-9);
    assert!(m.closed_loop_stable);
    assert_eq!(m.integrators, 1);
}

#[test]
fn integrator_with_two_lags_closed_form_gm() {
    // L = K / (s (τ1 s + 1)(τ2 s + 1)): ωp = 1/√(τ1 τ2), GM = (τ1 + τ2)/(K τ1 τ2)
    let (k, t1, t2) = (2.0, 1.0, 0.1);
    let den = [t1 * t2, t1 + t2, 1.0, 0.0];
    let monic: Vec<f64> = den.iter().map(|c| c / den[0]).collect();
    let m = margins(&tf(&[k / den[0]], &monic)).unwrap();
    let wp = 1.0 / (t1 * t2).sqrt();
    let gm_db = 20.0 * ((t1 + t2) / (k * t1 * t2)).log10();
    assert!((m.gain_margin_db.unwrap() - gm_db).abs() < 1e-8, "{m:?}");
    assert!((m.phase_crossover_hz.unwrap() - hz(wp)).abs() < 1e-9 * hz(wp));
    assert!(m.closed_loop_stable);
    // PM from the independent closed form |L(jωc)| = 1
    let l = |w: f64| k / poly(&den, Complex64::new(0.0, w));
    let wc = m.gain_crossover_hz.unwrap() * 2.0 * PI;
    assert!((l(wc).norm() - 1.0).abs() < 1e-9);
    let pm = 180.0 + l(wc).arg().to_degrees();
    assert!((m.phase_margin_deg.unwrap() - pm).abs() < 1e-8);
}

#[test]
fn lightly_damped_resonance_gives_three_gain_crossings_and_unstable_loop() {
    // L = K ωn² / (s (s² + 2ζωn s + ωn²)), K = 0.5, ωn = 10, ζ = 0.01: the resonance peak
    // K/(2ζωn) = 2.5 lifts |L| above 1 again around ωn; the phase is −180° exactly at ωn.
    let (k, wn, z) = (0.5, 10.0, 0.01);
    let den = [1.0, 2.0 * z * wn, wn * wn, 0.0];
    let m = margins(&tf(&[k * wn * wn], &den)).unwrap();
    let gains: Vec<_> = m
        .crossings
        .iter()
        .filter(|c| c.kind == CrossingKind::Gain)
        .collect();
    assert_eq!(gains.len(), 3, "{m:?}");
    let l = |w: f64| k * wn * wn / poly(&den, Complex64::new(0.0, w));
    for c in &gains {
        assert!(
            (l(c.frequency_hz * 2.0 * PI).norm() - 1.0).abs() < 1e-8,
            "{c:?}"
        );
    }
    let phase: Vec<_> = m
        .crossings
        .iter()
        .filter(|c| c.kind == CrossingKind::Phase)
        .collect();
    assert_eq!(phase.len(), 1, "{m:?}");
    assert!((phase[0].frequency_hz - hz(wn)).abs() < 1e-9 * hz(wn));
    let gm = -20.0 * (k / (2.0 * z * wn)).log10();
    assert!((m.gain_margin_db.unwrap() - gm).abs() < 1e-7, "{m:?}");
    // s³ + 0.2 s² + 100 s + 50: Routh 0.2·100 < 50 → unstable; delay margin 0
    assert!(!m.closed_loop_stable);
    assert_eq!(m.delay_margin_s, Some(0.0));
}

#[test]
fn open_loop_unstable_plant_is_judged_by_closed_loop_poles() {
    // L = 2 / (s − 1): closed loop s + 1 (stable) although the open loop is unstable.
    // |L| = 1 at ω = √3, ∠L = −120° → PM = 60°; DC gain −2 → phase crossing at 0 Hz,
    // GM = −6.02 dB (lowering the gain below 1/2 destabilises).
    let m = margins(&tf(&[2.0], &[1.0, -1.0])).unwrap();
    assert!(m.closed_loop_stable);
    assert!((m.phase_margin_deg.unwrap() - 60.0).abs() < 1e-8, "{m:?}");
    assert!((m.gain_crossover_hz.unwrap() - hz(3f64.sqrt())).abs() < 1e-9);
    assert!((m.gain_margin_db.unwrap() + 20.0 * 2f64.log10()).abs() < 1e-9);
    assert_eq!(m.phase_crossover_hz, Some(0.0));
    // and with gain 0.5 the same plant is closed-loop unstable: s − 1 + 0.5
    let m = margins(&tf(&[0.5], &[1.0, -1.0])).unwrap();
    assert!(!m.closed_loop_stable);
}

#[test]
fn no_gain_crossing_means_infinite_pm_and_finite_gm() {
    // L = 0.5 / ((s+1)(s+2)(s+3)): |L| < 1 everywhere; phase −180° at ω = √11 where
    // L = 0.5/(−60) → GM = 20 log10(120).
    let m = margins(&tf(&[0.5], &[1.0, 6.0, 11.0, 6.0])).unwrap();
    assert_eq!(m.phase_margin_deg, None);
    assert_eq!(m.gain_crossover_hz, None);
    assert_eq!(m.delay_margin_s, None);
    assert!(
        (m.gain_margin_db.unwrap() - 20.0 * 120f64.log10()).abs() < 1e-8,
        "{m:?}"
    );
    assert!((m.phase_crossover_hz.unwrap() - hz(11f64.sqrt())).abs() < 1e-9);
    assert!(m.closed_loop_stable);
}

#[test]
fn bode_equals_direct_complex_evaluation() {
    // fifth-order plant with a lightly damped pair and a zero
    let num = [3.0, 0.5, 40.0];
    let den = [1.0, 4.2, 110.0, 300.0, 250.0, 0.0];
    let sys = tf(&num, &den);
    let freqs = pumpcyl::lti::log_grid(1e-3, 1e3, 500);
    let b = bode(&sys, &freqs).unwrap();
    for (i, f) in freqs.iter().enumerate() {
        let s = Complex64::new(0.0, 2.0 * PI * f);
        let g = poly(&num, s) / poly(&den, s);
        let err_db = (b.mag_db[i] - 20.0 * g.norm().log10()).abs();
        assert!(err_db < 1e-7, "f={f}: {err_db} dB");
        let dphase = (b.phase_deg[i] - g.arg().to_degrees()).rem_euclid(360.0);
        assert!(dphase.min(360.0 - dphase) < 1e-8, "f={f}");
    }
    // unwrapped and anchored: −90° at low frequency (one integrator), −270° at high
    // frequency (relative degree 3), never a 360° jump between neighbours
    assert!((b.phase_deg[0] + 90.0).abs() < 1.0);
    assert!(
        (b.phase_deg.last().unwrap() + 270.0).abs() < 1.0,
        "{}",
        b.phase_deg.last().unwrap()
    );
    assert!(b.phase_deg.windows(2).all(|w| (w[1] - w[0]).abs() < 180.0));
}

#[test]
fn default_rig_frequency_response_equals_dense_complex_solve() {
    use pumpcyl::model::Plant;
    use pumpcyl::rig::Rig;
    let ol = Plant::new(&Rig::default()).open_loop(false);
    let ev = FreqEvaluator::new(&ol).unwrap();
    let n = ol.order();
    for &w in &[0.01, 1.0, 5.0, 30.0, 1000.0] {
        let m = DMatrix::from_fn(n, n, |i, j| {
            let diag = if i == j {
                Complex64::new(0.0, w)
            } else {
                Complex64::new(0.0, 0.0)
            };
            diag - ol.a[(i, j)]
        });
        let rhs = ol.b.map(|v| Complex64::new(v, 0.0));
        let x = m.lu().solve(&rhs).unwrap();
        let direct = (ol.c.map(|v| Complex64::new(v, 0.0)) * x)[(0, 0)];
        let g = ev.at(w);
        assert!(
            (g - direct).norm() < 1e-8 * direct.norm(),
            "w={w}: {g} vs {direct}"
        );
    }
}
