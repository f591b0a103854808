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
    // an undamped pair ±j: on the axis within rounding, not provably either side
    let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -1.0, 0.0]);
    assert_eq!(stability(&a).unwrap(), Stability::Undecided);
    // 1e-9 beside 1e10: within the integrator tolerance (100 n·ε·‖A‖₁ = 4.4e-4) of the origin,
    // an integrator (docs/analysis.md#poles-and-damping)
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![-1e-9, -1e10]));
    assert_eq!(stability(&a).unwrap(), Stability::Integrator);
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

/// A first-order SISO block (a, b, c, d).
type Block = (f64, f64, f64, f64);

/// The series connection of blocks (the signal passes the first block first).
fn series(blocks: &[Block]) -> StateSpace {
    let n = blocks.iter().filter(|b| b.1 != 0.0).count();
    let (mut a, mut b) = (DMatrix::zeros(n, n), DMatrix::zeros(n, 1));
    let (mut c, mut d) = (DMatrix::zeros(1, n), 1.0);
    let mut k = 0;
    for &(ba, bb, bc, bd) in blocks {
        if bb == 0.0 {
            // a pure gain
            c *= bd;
            d *= bd;
            continue;
        }
        // new state: x' = ba x + bb (c_prev x_prev + d_prev u); y = bc x + bd (c_prev x_prev + d_prev u)
        for j in 0..k {
            a[(k, j)] = bb * c[(0, j)];
        }
        a[(k, k)] = ba;
        b[(k, 0)] = bb * d;
        for j in 0..k {
            c[(0, j)] *= bd;
        }
        c[(0, k)] = bc;
        d *= bd;
        k += 1;
    }
    StateSpace::new(a, b, c, DMatrix::from_element(1, 1, d)).unwrap()
}

/// L(jω) as the product of the blocks' transfer functions c b/(s − a) + d: exact, independent
/// of any realisation.
fn analytic(blocks: &[Block], w: f64) -> Complex64 {
    let s = Complex64::new(0.0, w);
    blocks
        .iter()
        .map(|&(a, b, c, d)| {
            if b == 0.0 {
                Complex64::new(d, 0.0)
            } else {
                c * b / (s - a) + d
            }
        })
        .product()
}

/// Every crossing of L(jω) on a dense grid of evaluations of `l`: gain crossings where |L| passes 1,
/// phase crossings where Im L changes sign with Re L < 0 (the phase passes −180° + k·360°),
/// each located by bisection; (frequency in rad/s, kind, margin).
fn reference_crossings(
    l_of: impl Fn(f64) -> Complex64,
    lo: f64,
    hi: f64,
) -> Vec<(f64, CrossingKind, f64)> {
    let per_decade = 400.0;
    let n = ((hi / lo).log10() * per_decade) as usize + 1;
    let w: Vec<f64> = (0..=n)
        .map(|i| lo * (hi / lo).powf(i as f64 / n as f64))
        .collect();
    let l: Vec<Complex64> = w.iter().map(|&w| l_of(w)).collect();
    let mut out = Vec::new();
    for i in 1..w.len() {
        if (l[i - 1].norm() >= 1.0) != (l[i].norm() >= 1.0) {
            let wc = bisect(|u| l_of(u).norm() - 1.0, w[i - 1], w[i]);
            let pm = l_of(wc).arg().to_degrees() + 180.0;
            let pm = if pm > 180.0 { pm - 360.0 } else { pm };
            out.push((wc, CrossingKind::Gain, pm));
        }
        let left = l[i - 1].re < 0.0 && l[i].re < 0.0;
        if left && (l[i - 1].im >= 0.0) != (l[i].im >= 0.0) {
            let wp = bisect(|u| l_of(u).im, w[i - 1], w[i]);
            out.push((wp, CrossingKind::Phase, -20.0 * l_of(wp).norm().log10()));
        }
    }
    out
}

#[test]
fn margins_agree_with_a_dense_direct_reference_on_adversarial_loops() {
    // integrators in series (0 to 3), lags and lead-lags spanning twelve decades, zeros in the
    // right half-plane, negative gains: every crossing the reference resolves is found, at the
    // same frequency with the same margin, and no other
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut checked = 0;
    for case in 0..300 {
        let mut blocks: Vec<Block> = Vec::new();
        let mut corners = vec![1.0];
        let integrators = (uniform() * 4.0) as usize;
        for _ in 0..integrators {
            blocks.push((0.0, 1.0, 1.0, 0.0));
        }
        for _ in 0..1 + (uniform() * 3.0) as usize {
            let p = 10f64.powf(uniform() * 12.0 - 6.0);
            corners.push(p);
            blocks.push((-p, 1.0, p, 0.0));
        }
        for _ in 0..(uniform() * 3.0) as usize {
            let z = 10f64.powf(uniform() * 12.0 - 6.0) * if uniform() < 0.3 { -1.0 } else { 1.0 };
            let p = 10f64.powf(uniform() * 12.0 - 6.0);
            corners.extend([z.abs(), p]);
            blocks.push((-p, 1.0, p / z * (z - p), p / z));
        }
        let sign = if uniform() < 0.2 { -1.0 } else { 1.0 };
        blocks.push((0.0, 0.0, 0.0, sign * 10f64.powf(uniform() * 6.0 - 3.0)));
        let sys = series(&blocks);
        let Ok(m) = margins(&sys) else { continue };
        let lo = corners.iter().copied().fold(f64::INFINITY, f64::min) * 1e-4;
        let hi = corners.iter().copied().fold(0.0, f64::max) * 1e4;
        let exact = |w: f64| analytic(&blocks, w);
        let reference = reference_crossings(exact, lo, hi);
        // only crossings the reference resolves cleanly: apart from each other and from the
        // −200 dB floor, inside the reference grid's span
        // a phase crossing is clean when the phase stands clearly on either side of −180°
        // a little below and above it (not a flat phase on −180° that rounding flips)
        let crosses = |w: f64| {
            let side = |u: f64| {
                let l = exact(u);
                (l.im / l.norm()).asin().to_degrees()
            };
            let (a, b) = (side(w / 1.02), side(w * 1.02));
            a.abs() > 1e-3 && b.abs() > 1e-3 && (a > 0.0) != (b > 0.0)
        };
        let clean = |w: f64, kind: CrossingKind, margin: f64| {
            let apart = reference
                .iter()
                .all(|r| r.0 == w || (r.0 / w).ln().abs() > 1e-2);
            // the realisation carries L there to 1e-6 (else no method on it could)
            let carried = (direct(&sys, w) / exact(w) - 1.0).norm() < 1e-6;
            let floor = kind == CrossingKind::Gain || (margin < 190.0 && crosses(w));
            apart && carried && floor && w > lo * 10.0 && w < hi / 10.0
        };
        for &(w, kind, margin) in reference.iter().filter(|r| clean(r.0, r.1, r.2)) {
            let found = m
                .crossings
                .iter()
                .find(|c| c.kind == kind && (c.frequency_hz * 2.0 * PI / w).ln().abs() < 1e-6);
            let c = found.unwrap_or_else(|| {
                panic!(
                    "case {case}: {kind:?} at {w} rad/s missing: {blocks:?} {reference:?} {:?}",
                    m.crossings
                )
            });
            assert!(
                (c.margin - margin).abs() < 1e-4 * margin.abs().max(1.0),
                "case {case}: {c:?} vs {margin}"
            );
            checked += 1;
        }
        for c in m.crossings.iter().filter(|c| c.frequency_hz > 0.0) {
            let w = c.frequency_hz * 2.0 * PI;
            if clean(w, c.kind, c.margin) && w > lo * 10.0 && w < hi / 10.0 {
                let known = reference
                    .iter()
                    .any(|r| r.1 == c.kind && (r.0 / w).ln().abs() < 1e-3);
                assert!(
                    known,
                    "case {case}: {c:?} not in the reference {reference:?}"
                );
            }
        }
    }
    eprintln!("{checked} crossings compared");
    assert!(checked > 300, "only {checked} crossings compared");
}
