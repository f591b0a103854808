//! Margins and stability at the edges of double precision (docs/analysis.md#margins): slow
//! poles beside fast ones, integrators built in series, very slow stable poles, undamped loops
//! and zeros far above the poles. References are closed forms or a direct dense complex solve
//! of C (jωI − A)⁻¹ B, independent of the Schur path under test.

use nalgebra::DMatrix;
use num_complex::Complex64;
use pumpcyl::lti::{margins, stability, CrossingKind, Stability, StateSpace};
use std::f64::consts::PI;

fn ss(a: &[&[f64]], b: &[f64], c: &[f64]) -> StateSpace {
    let n = b.len();
    StateSpace::new(
        DMatrix::from_fn(n, n, |i, j| a[i][j]),
        DMatrix::from_column_slice(n, 1, b),
        DMatrix::from_row_slice(1, n, c),
        DMatrix::zeros(1, 1),
    )
    .unwrap()
}

/// L(jω) by a dense complex LU solve.
fn direct(sys: &StateSpace, w: f64) -> Complex64 {
    let n = sys.a.nrows();
    let m = DMatrix::from_fn(n, n, |i, j| {
        let d = if i == j {
            Complex64::new(0.0, w)
        } else {
            Complex64::new(0.0, 0.0)
        };
        d - sys.a[(i, j)]
    });
    let b = sys.b.map(|v| Complex64::new(v, 0.0));
    let x = m.lu().solve(&b).unwrap();
    (0..n).map(|i| x[(i, 0)] * sys.c[(0, i)]).sum::<Complex64>() + sys.d[(0, 0)]
}

/// A root of f in [a, b] (rad/s) by bisection in log ω.
fn bisect(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    for _ in 0..200 {
        let m = (a * b).sqrt();
        if (f(a) > 0.0) == (f(m) > 0.0) {
            a = m;
        } else {
            b = m;
        }
    }
    (a * b).sqrt()
}

#[test]
fn a_slow_pole_beside_a_fast_one_is_not_an_integrator() {
    // L(0) = −0.5: a phase crossing at 0 Hz with GM = 20 log10 2 = 6.02 dB (python-control
    // agrees); the fast pole at −1e9 once made the pole at −0.5 count as an integrator.
    let sys = ss(&[&[-0.5, 1.0], &[0.0, -1e9]], &[0.0, 1e9], &[-0.25, 0.0]);
    let m = margins(&sys).unwrap();
    assert_eq!(m.integrators, 0);
    let gm = 20.0 * 2f64.log10();
    assert!((m.gain_margin_db.unwrap() - gm).abs() < 1e-9, "{m:?}");
    assert_eq!(m.phase_crossover_hz, Some(0.0));
    // without the fast pole the answer is the same
    let m1 = margins(&ss(&[&[-0.5]], &[1.0], &[-0.25])).unwrap();
    assert!((m1.gain_margin_db.unwrap() - gm).abs() < 1e-9, "{m1:?}");
}

#[test]
fn a_double_integrator_built_in_series_has_no_made_up_dc_margin() {
    let sys = ss(
        &[
            &[0.0, 0.0, 0.0, 0.0],
            &[1.0, 0.0, 0.0, 0.0],
            &[0.0, 1.0, -1.6115, 0.0],
            &[0.0, 41.614, -65.449, -8.1232],
        ],
        &[0.0010965, 0.0, 0.0, 0.0],
        &[0.0, 554.58, -872.24, -100.13],
    );
    let m = margins(&sys).unwrap();
    assert_eq!(m.integrators, 2);
    assert_eq!(m.gain_margin_db, None, "no phase crossover: {m:?}");
    // the gain crossover and PM from a direct solve
    let wc = bisect(|w| direct(&sys, w).norm() - 1.0, 1e-3, 1.0);
    let pm = 180.0 + direct(&sys, wc).arg().to_degrees().rem_euclid(360.0) - 360.0;
    assert!((pm - 47.92).abs() < 0.01, "reference PM {pm}");
    assert!(
        (m.phase_margin_deg.unwrap() - pm).abs() < 1e-6,
        "{m:?} vs {pm}"
    );
    assert!((m.gain_crossover_hz.unwrap() - wc / (2.0 * PI)).abs() < 1e-9);
    assert!(m.closed_loop_stable);
}

#[test]
fn a_triple_integrator_is_analysed_not_refused() {
    // 1/s³: |L| = 1 at 1 rad/s, phase −270° there, PM = −90°, no phase crossover, unstable
    let sys = ss(
        &[&[0.0, 0.0, 0.0], &[1.0, 0.0, 0.0], &[0.0, 1.0, 0.0]],
        &[1.0, 0.0, 0.0],
        &[0.0, 0.0, 1.0],
    );
    let m = margins(&sys).unwrap();
    assert_eq!(m.integrators, 3);
    assert!((m.phase_margin_deg.unwrap() + 90.0).abs() < 1e-9, "{m:?}");
    assert!((m.gain_crossover_hz.unwrap() - 1.0 / (2.0 * PI)).abs() < 1e-12);
    assert_eq!(m.gain_margin_db, None);
    assert_eq!(m.closed_loop_stability, Stability::Unstable);
}

#[test]
fn a_very_slow_stable_pole_is_stable() {
    // closed-loop pole −2e-12: stable, however slow, when the model's own scale is 1e-12
    let sys = ss(&[&[-1e-12]], &[1e-12], &[1.0]);
    let m = margins(&sys).unwrap();
    assert_eq!(m.closed_loop_stability, Stability::Stable);
    assert!(m.closed_loop_stable);
    assert_eq!(m.integrators, 0);
    assert_eq!(
        stability(&DMatrix::from_element(1, 1, 2e-12)).unwrap(),
        Stability::Unstable
    );
}

#[test]
fn a_pole_within_rounding_of_the_axis_is_undecided() {
    // 1e-9 beside 1e10: below the rounding of the fast pole, not provably either side
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![-1e-9, -1e10]));
    assert_eq!(stability(&a).unwrap(), Stability::Undecided);
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![-1e-3, -1e10]));
    assert_eq!(stability(&a).unwrap(), Stability::Stable);
}

#[test]
fn an_undamped_loop_has_a_zero_phase_margin_in_text_and_json_alike() {
    // L = 2/(s² + 1): |L| = 1 at ω = √3 where the phase is −180°: PM 0°; the closed-loop
    // poles ±j√3 lie on the axis: undecided, never a NaN
    let sys = ss(&[&[0.0, 1.0], &[-1.0, 0.0]], &[0.0, 1.0], &[2.0, 0.0]);
    let m = margins(&sys).unwrap();
    let wc = 3f64.sqrt();
    assert!(
        (m.gain_crossover_hz.unwrap() - wc / (2.0 * PI)).abs() < 1e-9,
        "{m:?}"
    );
    assert!(m.phase_margin_deg.unwrap().abs() < 1e-6, "{m:?}");
    assert_eq!(m.closed_loop_stability, Stability::Undecided);
    assert!(m
        .crossings
        .iter()
        .all(|c| c.margin.is_finite() && c.phase_deg.is_finite()));
}

#[test]
fn a_phase_crossing_from_zeros_far_above_the_poles_is_found() {
    // L = 10 (1 + s/1000)² / ((s + 1)(s + 2)(s + 3)): the zeros lift the phase back through
    // −180° near 1000 rad/s, more than two decades above the fastest pole
    let sys = ss(
        &[&[0.0, 1.0, 0.0], &[0.0, 0.0, 1.0], &[-6.0, -11.0, -6.0]],
        &[0.0, 0.0, 1.0],
        &[10.0, 0.02, 1e-5],
    );
    let m = margins(&sys).unwrap();
    let phase = |w: f64| {
        -(w.atan() + (w / 2.0).atan() + (w / 3.0).atan()).to_degrees()
            + 2.0 * (w / 1000.0).atan().to_degrees()
            + 180.0
    };
    let phases: Vec<_> = m
        .crossings
        .iter()
        .filter(|c| c.kind == CrossingKind::Phase)
        .collect();
    assert_eq!(phases.len(), 2, "{m:?}");
    for (c, (lo, hi)) in phases.iter().zip([(1.0, 10.0), (100.0, 1e5)]) {
        let w = bisect(phase, lo, hi);
        assert!(
            (c.frequency_hz - w / (2.0 * PI)).abs() < 1e-9 * w,
            "{c:?} vs {w}"
        );
        let gm = -20.0 * direct(&sys, w).norm().log10();
        assert!((c.margin - gm).abs() < 1e-6, "{c:?} vs {gm}");
    }
}
