//! Loop transfers that have tripped up other control libraries, each against an answer derived
//! independently of `pumpcyl` (closed form, or a bisection on a closed-form expression), with
//! the derivation in a comment. tests/margins_analytic.rs covers the textbook cases (integrator
//! with one or two lags, a ζ = 0.01 resonance with three gain crossings, 2/(s − 1), no gain
//! crossing); these are the awkward ones.

use nalgebra::DMatrix;
use num_complex::Complex64;
use pumpcyl::lti::{margins, Crossing, CrossingKind, Margins, StateSpace};
use std::f64::consts::PI;

mod common;
use common::{poly, tf};

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

fn poly_mul(p: &[f64], q: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; p.len() + q.len() - 1];
    for (i, a) in p.iter().enumerate() {
        for (j, b) in q.iter().enumerate() {
            out[i + j] += a * b;
        }
    }
    out
}

/// p + q, aligned at the constant term.
fn poly_add(p: &[f64], q: &[f64]) -> Vec<f64> {
    let n = p.len().max(q.len());
    let at = |c: &[f64], k: usize| if k < c.len() { c[c.len() - 1 - k] } else { 0.0 };
    (0..n).rev().map(|k| at(p, k) + at(q, k)).collect()
}

/// Routh–Hurwitz: every root of `p` (highest power first, leading coefficient > 0) in the open
/// left half-plane. A zero in the first column (marginal or degenerate case) counts as not
/// stable.
fn hurwitz(p: &[f64]) -> bool {
    let mut rows: Vec<Vec<f64>> = vec![
        p.iter().step_by(2).copied().collect(),
        p.iter().skip(1).step_by(2).copied().collect(),
    ];
    for _ in 2..p.len() {
        let (r0, r1) = (&rows[rows.len() - 2], &rows[rows.len() - 1]);
        let at = |r: &Vec<f64>, k: usize| r.get(k).copied().unwrap_or(0.0);
        let next = (0..r0.len().saturating_sub(1))
            .map(|k| (at(r1, 0) * at(r0, k + 1) - at(r0, 0) * at(r1, k + 1)) / at(r1, 0))
            .collect();
        rows.push(next);
    }
    rows.iter().all(|r| r.first().is_none_or(|&v| v > 0.0))
}

/// Root of a continuous `f` on [lo, hi] (f(lo), f(hi) of opposite signs) by bisection in
/// ln ω, to the last bit.
fn bisect_log(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    let (mut a, mut b) = (lo.ln(), hi.ln());
    let fa_negative = f(lo) < 0.0;
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if (f(m.exp()) < 0.0) == fa_negative {
            a = m;
        } else {
            b = m;
        }
    }
    (0.5 * (a + b)).exp()
}

/// Series connection of SISO models, signal flowing from the first to the last.
fn cascade(blocks: &[StateSpace]) -> StateSpace {
    let series = |g1: &StateSpace, g2: &StateSpace| {
        let (n1, n2) = (g1.order(), g2.order());
        let mut a = DMatrix::zeros(n1 + n2, n1 + n2);
        a.view_mut((0, 0), (n1, n1)).copy_from(&g1.a);
        a.view_mut((n1, 0), (n2, n1)).copy_from(&(&g2.b * &g1.c));
        a.view_mut((n1, n1), (n2, n2)).copy_from(&g2.a);
        let b = DMatrix::from_fn(n1 + n2, 1, |i, _| {
            if i < n1 {
                g1.b[(i, 0)]
            } else {
                (&g2.b * &g1.d)[(i - n1, 0)]
            }
        });
        let c = DMatrix::from_fn(1, n1 + n2, |_, j| {
            if j < n1 {
                (&g2.d * &g1.c)[(0, j)]
            } else {
                g2.c[(0, j - n1)]
            }
        });
        StateSpace::new(a, b, c, &g2.d * &g1.d).unwrap()
    };
    let (first, rest) = blocks.split_first().unwrap();
    rest.iter().fold(first.clone(), |acc, g| series(&acc, g))
}

fn hz(w: f64) -> f64 {
    w / (2.0 * PI)
}

fn of_kind(m: &Margins, kind: CrossingKind) -> Vec<Crossing> {
    m.crossings
        .iter()
        .filter(|c| c.kind == kind)
        .copied()
        .collect()
}

/// |got − want| ≤ tol, with a message naming the quantity.
fn assert_near(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got}, want {want} (error {:e} > {tol:e})",
        (got - want).abs()
    );
}

/// A crossing at ω (rad/s) with the given margin (dB or deg): frequency to 1e-9 relative,
/// margin to `tol`.
fn assert_crossing(c: &Crossing, kind: CrossingKind, w: f64, margin: f64, tol: f64) {
    assert_eq!(c.kind, kind, "{c:?}");
    assert_near(
        c.frequency_hz,
        hz(w),
        1e-9 * hz(w),
        "crossing frequency (Hz)",
    );
    assert_near(c.margin, margin, tol, "crossing margin");
}

/// Headline values of a loop without any phase crossing.
fn assert_no_phase_crossing(m: &Margins) {
    assert!(of_kind(m, CrossingKind::Phase).is_empty(), "{m:#?}");
    assert_eq!(m.gain_margin_db, None, "GM must be infinite: {m:#?}");
    assert_eq!(m.phase_crossover_hz, None);
}

/// Closed-loop characteristic polynomial den + num of L = num/den under unity feedback.
fn closed_loop(num: &[f64], den: &[f64]) -> Vec<f64> {
    poly_add(den, num)
}

// ---------------------------------------------------------------------------------------------
// Resonances and multiple crossings
// ---------------------------------------------------------------------------------------------

/// Pitfall: a frequency grid that does not resolve a sharp peak. With ζ = 0.002 the peak of
/// |L| is 0.2% wide; scaled to exceed 0 dB by 9e-6 dB, its two gain crossings lie 5.7e-6
/// apart (relative): a fixed logarithmic grid — python-control's and ControlSystems.jl's
/// default frequency vectors (JuliaControl/ControlSystems.jl#771: a default frequency axis made
/// `margin` miss a crossing) — steps straight over them, and so does a 12-fold bisection of a
/// 20-per-decade grid (2.8e-5); `margins` seeds ω_d of lightly damped poles into its grid
/// (here 2e-6 above the peak at ω_r = ωn√(1 − 2ζ²), inside the pair).
///
/// L = K ωn²/(s² + 2ζωn s + ωn²). With x = (ω/ωn)², |L| = 1 ⇔ (1 − x)² + 4ζ²x = K², i.e.
/// x = 1 − 2ζ² ± √(K² − 4ζ²(1 − ζ²)); the peak is K/(2ζ√(1 − ζ²)), so with K = P·2ζ√(1 − ζ²)
/// the root is √(4ζ²(1 − ζ²)(P² − 1)). There ∠L = −atan2(2ζ√x, 1 − x) and PM = 180° + ∠L.
/// The phase only tends to −180°: no phase crossing. Closed loop s² + 2ζωn s + ωn²(1 + K):
/// stable.
#[test]
fn very_lightly_damped_resonance_peaking_just_above_0_db() {
    let (wn, zeta, peak) = (50.0, 0.002f64, 1.000001);
    let k = peak * 2.0 * zeta * (1.0 - zeta * zeta).sqrt();
    let den = [1.0, 2.0 * zeta * wn, wn * wn];
    let m = margins(&tf(&[k * wn * wn], &den)).unwrap();
    let root = (4.0 * zeta * zeta * (1.0 - zeta * zeta) * (peak * peak - 1.0)).sqrt();
    let gains = of_kind(&m, CrossingKind::Gain);
    assert_eq!(gains.len(), 2, "{m:#?}");
    let mut pms = Vec::new();
    for (c, x) in gains.iter().zip([
        1.0 - 2.0 * zeta * zeta - root,
        1.0 - 2.0 * zeta * zeta + root,
    ]) {
        let pm = 180.0 - (2.0 * zeta * x.sqrt()).atan2(1.0 - x).to_degrees();
        assert_crossing(c, CrossingKind::Gain, wn * x.sqrt(), pm, 1e-6);
        pms.push((pm, wn * x.sqrt()));
    }
    // the headline PM is the smaller one, its delay margin the smaller of the two
    let (pm, wc) = pms
        .iter()
        .copied()
        .min_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
        .unwrap();
    assert_near(m.phase_margin_deg.unwrap(), pm, 1e-6, "PM");
    assert_near(
        m.gain_crossover_hz.unwrap(),
        hz(wc),
        1e-9 * hz(wc),
        "gain crossover",
    );
    let dm = pms
        .iter()
        .map(|(pm, w)| pm.to_radians() / w)
        .fold(f64::INFINITY, f64::min);
    assert_near(m.delay_margin_s.unwrap(), dm, 1e-9 * dm, "delay margin");
    assert_no_phase_crossing(&m);
    assert!(hurwitz(&closed_loop(&[k * wn * wn], &den)) && m.closed_loop_stable);
    // 9e-6 dB *below* 0 dB instead: no crossing at all
    let m = margins(&tf(&[k * wn * wn / peak / peak], &den)).unwrap();
    assert!(m.crossings.is_empty(), "{m:#?}");
    assert_eq!((m.phase_margin_deg, m.delay_margin_s), (None, None));
}

/// Pitfall: several phase crossings. The headline GM is the one of smallest |GM| (as MATLAB
/// `margin`), here a *negative* one in the middle of three, not the first or the last;
/// libraries that take the first crossing of −180° or only interpolate one
/// (JuliaControl/ControlSystems.jl#524: phase crossings found one grid index off) get another.
///
/// L = K (s + a)² / (s (s + b)² (s + c)²), a = 10, b = 1, c = 100, K = 1e5. ∠L = −180° ⇔
/// atan(ω/a) − atan(ω/b) − atan(ω/c) = −45°; with tan(atan(ω/b) + atan(ω/c)) =
/// ω(b + c)/(bc − ω²) this is ω³ + (a − b − c)ω² + (a(b + c) − bc)ω − abc = 0, i.e.
/// ω³ − 91ω² + 910ω − 1000 = (ω − 10)(ω² − 81ω + 100): ω = 10 and (81 ± √6161)/2. The phase
/// falls through −180° at 1.254, rises through it at 10 and falls again at 79.75 rad/s.
/// ln|L| has slope 2ω²/(a² + ω²) − 1 − 2ω²/(b² + ω²) − 2ω²/(c² + ω²) < 0: one gain crossing,
/// found by bisection. Closed loop s(s + 1)²(s + 100)² + K(s + 10)²: Routh–Hurwitz stable.
#[test]
fn three_phase_crossings_headline_is_the_smallest_gm() {
    let k = 1e5;
    let num: Vec<f64> = poly_mul(&[1.0, 10.0], &[1.0, 10.0])
        .iter()
        .map(|c| c * k)
        .collect();
    let lags = poly_mul(
        &poly_mul(&[1.0, 1.0], &[1.0, 1.0]),
        &poly_mul(&[1.0, 100.0], &[1.0, 100.0]),
    );
    let den = poly_mul(&[1.0, 0.0], &lags);
    let m = margins(&tf(&num, &den)).unwrap();
    let l = |w: f64| poly(&num, Complex64::new(0.0, w)) / poly(&den, Complex64::new(0.0, w));
    let gm = |w: f64| -20.0 * l(w).norm().log10();
    let d = 6161f64.sqrt();
    let phase_w = [(81.0 - d) / 2.0, 10.0, (81.0 + d) / 2.0];
    let wc = bisect_log(|w| l(w).norm() - 1.0, 10.0, 100.0);
    let phase = |w: f64| {
        (2.0 * (w / 10.0).atan() - 2.0 * w.atan() - 2.0 * (w / 100.0).atan()).to_degrees() - 90.0
    };
    let kinds = [
        CrossingKind::Phase,
        CrossingKind::Phase,
        CrossingKind::Gain,
        CrossingKind::Phase,
    ];
    let expected = [
        (phase_w[0], gm(phase_w[0])),
        (phase_w[1], gm(phase_w[1])),
        (wc, 180.0 + phase(wc)),
        (phase_w[2], gm(phase_w[2])),
    ];
    assert_eq!(m.crossings.len(), 4, "{m:#?}");
    for ((c, kind), (w, margin)) in m.crossings.iter().zip(kinds).zip(expected) {
        assert_crossing(c, kind, w, margin, 1e-6);
        assert_near(
            c.phase_deg,
            if kind == CrossingKind::Phase {
                -180.0
            } else {
                phase(w)
            },
            1e-6,
            "phase",
        );
    }
    // GMs −49.96, −5.85, +22.18 dB: the headline is the middle, negative one
    assert_near(m.gain_margin_db.unwrap(), gm(10.0), 1e-6, "GM");
    assert!(m.gain_margin_db.unwrap() < -5.0);
    assert_near(
        m.phase_crossover_hz.unwrap(),
        hz(10.0),
        1e-9 * hz(10.0),
        "phase crossover",
    );
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
}

// ---------------------------------------------------------------------------------------------
// Open-loop unstable loops: the sign of the GM is not the verdict
// ---------------------------------------------------------------------------------------------

/// Pitfall: an open-loop unstable loop is stabilised by *enough* gain, so its GM is negative
/// (the gain may only be reduced, by |GM|) when it is stable, and positive when it is not; a
/// verdict read off the sign of the margins is wrong both ways
/// (python-control/python-control#784 discusses exactly this for an open-loop unstable loop).
///
/// L = K (s + 1)/(s (s − 1)). ∠L = −90° + atan ω − (180° − atan ω) = 2 atan ω − 270°, from
/// −270° (the real-axis value K(σ + 1)/(σ(σ − 1)) < 0 for small σ > 0) up to −90°: −180° at
/// ω = 1, where |L| = K → GM = −20 log10 K. |L| = 1 ⇔ K²(1 + ω²) = ω²(1 + ω²) ⇔ ω = K, where
/// PM = 2 atan K − 90°; delay margin PM(rad)/K. Closed loop s² + (K − 1)s + K: stable iff K > 1.
#[test]
fn open_loop_unstable_loop_is_stable_with_a_negative_gain_margin() {
    for k in [2.0f64, 0.5] {
        let (num, den) = ([k, k], [1.0, -1.0, 0.0]);
        let m = margins(&tf(&num, &den)).unwrap();
        let pm = 2.0 * k.atan().to_degrees() - 90.0;
        assert_eq!(m.crossings.len(), 2, "{m:#?}");
        let (phase, gain) = if k > 1.0 { (0, 1) } else { (1, 0) };
        assert_crossing(
            &m.crossings[phase],
            CrossingKind::Phase,
            1.0,
            -20.0 * k.log10(),
            1e-9,
        );
        assert_near(
            m.crossings[phase].phase_deg,
            -180.0,
            1e-9,
            "phase at the phase crossing",
        );
        assert_crossing(&m.crossings[gain], CrossingKind::Gain, k, pm, 1e-9);
        assert_near(m.gain_margin_db.unwrap(), -20.0 * k.log10(), 1e-9, "GM");
        assert_near(m.phase_margin_deg.unwrap(), pm, 1e-9, "PM");
        let stable = hurwitz(&closed_loop(&num, &den));
        assert_eq!((m.closed_loop_stable, stable), (k > 1.0, k > 1.0), "{m:#?}");
        // stable: GM −6.02 dB, PM +36.87°; unstable: GM +6.02 dB, PM −36.87°, delay margin 0
        let dm = if stable { pm.to_radians() / k } else { 0.0 };
        assert_near(m.delay_margin_s.unwrap(), dm, 1e-12, "delay margin");
        assert_eq!(m.integrators, 1);
    }
}

/// Pitfall: an open-loop unstable loop with both a lower and an upper gain margin; a
/// `margin` that reports one of them hides the other (JuliaControl/ControlSystems.jl#1045:
/// `allMargins = true` returned only the upper one).
///
/// L = 100/((s − 1)(s + 4)(s + 6)), den = s³ + 9s² + 14s − 24. Closed loop
/// s³ + 9s² + 14s + (K − 24): Routh–Hurwitz stable for 24 < K < 126 + 24 = 150. L(0) =
/// −100/24 sits on −180° at 0 Hz → GM = 20 log10(24/100) = −12.40 dB (as MATLAB `allmargin`);
/// Im den(jω) = 14ω − ω³ = 0 at ω = √14 where den = −9·14 − 24 = −150 → GM = 20 log10 1.5 =
/// +3.52 dB, the headline. |L| = 1 ⇔ (ω² + 1)(ω² + 16)(ω² + 36) = 1e4 (increasing: one root,
/// by bisection), PM = atan ω − atan(ω/4) − atan(ω/6) there.
#[test]
fn open_loop_unstable_loop_lists_lower_and_upper_gain_margins() {
    let (num, den) = ([100.0], [1.0, 9.0, 14.0, -24.0]);
    let m = margins(&tf(&num, &den)).unwrap();
    let wc = bisect_log(
        |w| (w * w + 1.0) * (w * w + 16.0) * (w * w + 36.0) - 1e4,
        1.0,
        10.0,
    );
    let pm = (wc.atan() - (wc / 4.0).atan() - (wc / 6.0).atan()).to_degrees();
    let (gm_low, gm_high) = (20.0 * 0.24f64.log10(), 20.0 * 1.5f64.log10());
    assert_eq!(m.crossings.len(), 3, "{m:#?}");
    assert_eq!(m.crossings[0].frequency_hz, 0.0);
    assert_near(m.crossings[0].margin, gm_low, 1e-9, "GM at 0 Hz");
    assert_crossing(&m.crossings[1], CrossingKind::Gain, wc, pm, 1e-9);
    assert_crossing(
        &m.crossings[2],
        CrossingKind::Phase,
        14f64.sqrt(),
        gm_high,
        1e-9,
    );
    assert_near(
        m.crossings[2].phase_deg,
        -180.0,
        1e-9,
        "phase (from −180° at DC)",
    );
    assert_near(m.gain_margin_db.unwrap(), gm_high, 1e-9, "headline GM");
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
}

// ---------------------------------------------------------------------------------------------
// Integrators
// ---------------------------------------------------------------------------------------------

/// Pitfall: the double integrator K/s² has ∠L = −180° at *every* frequency. MATLAB `margin`
/// gives Gm = Inf, Pm = 0; phase-crossing detectors working on sign changes of ∠L + 180° see
/// rounding noise. The sane answer, pinned here: no phase crossing (GM infinite), one gain
/// crossing at ω = √K with PM = 0 and the phase exactly −180°, delay margin 0, closed loop
/// s² + K with poles ±j√K on the axis: not stable.
#[test]
fn double_integrator_has_zero_phase_margin_and_no_phase_crossing() {
    let k = 4.0;
    let m = margins(&tf(&[k], &[1.0, 0.0, 0.0])).unwrap();
    assert_eq!(m.crossings.len(), 1, "{m:#?}");
    assert_crossing(&m.crossings[0], CrossingKind::Gain, k.sqrt(), 0.0, 1e-12);
    assert_near(m.crossings[0].phase_deg, -180.0, 1e-12, "phase");
    assert_no_phase_crossing(&m);
    assert_eq!(
        (m.phase_margin_deg, m.delay_margin_s),
        (Some(0.0), Some(0.0))
    );
    assert!(!m.closed_loop_stable && !hurwitz(&[1.0, 0.0, k]));
    assert_eq!(m.integrators, 2);
}

/// Pitfall (the python-control/python-control#947 loop): three integrators and two zeros,
/// L = (s² + 0.5 s + 0.05)/s³, conditionally stable. The phase starts at −270° (a library
/// wrapping it into (−180°, 180°] starts at +90°) and rises through −180°; the GM is −20 dB
/// (python-control's 0.1 in absolute units, which its user read as wrong).
///
/// L(jω) = −0.5/ω² + j(0.05 − ω²)/ω³: real at ω = √0.05 where L = −10 → GM = −20 dB. |L| = 1
/// ⇔ (0.05 − u)² + 0.25u = u³ (u = ω²) ⇔ u³ − u² − 0.15u − 0.0025 = 0: one sign change, one
/// positive root (bisection). There Re, Im < 0 and PM = atan(2(ω² − 0.05)/ω) = 63.84°.
/// Closed loop s³ + s² + 0.5 s + 0.05: Routh 1·0.5 > 0.05, stable.
#[test]
fn triple_integrator_with_two_zeros_is_conditionally_stable() {
    let (num, den) = ([1.0, 0.5, 0.05], [1.0, 0.0, 0.0, 0.0]);
    let m = margins(&tf(&num, &den)).unwrap();
    let wc = bisect_log(|w| w.powi(6) - w.powi(4) - 0.15 * w * w - 0.0025, 0.5, 2.0);
    let pm = (2.0 * (wc * wc - 0.05) / wc).atan().to_degrees();
    let wp = 0.05f64.sqrt();
    assert_eq!(m.crossings.len(), 2, "{m:#?}");
    assert_crossing(&m.crossings[0], CrossingKind::Phase, wp, -20.0, 1e-9);
    assert_near(
        m.crossings[0].phase_deg,
        -180.0,
        1e-9,
        "unwrapped phase (from −270°)",
    );
    assert_crossing(&m.crossings[1], CrossingKind::Gain, wc, pm, 1e-9);
    assert_near(m.phase_margin_deg.unwrap(), pm, 1e-9, "PM");
    assert_near(m.gain_margin_db.unwrap(), -20.0, 1e-9, "GM");
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
    assert_eq!(m.integrators, 3);
}

// ---------------------------------------------------------------------------------------------
// No crossing, or a phase that only tends to −180°
// ---------------------------------------------------------------------------------------------

/// Pitfall: nothing to find. L = 0.9/((s + 1)(0.1 s + 1)): |L| ≤ 0.9 (DC) and
/// ∠L = −atan ω − atan(0.1 ω) > −180° at every finite ω. Both margins infinite, no crossing,
/// no delay margin; closed loop 0.1 s² + 1.1 s + 1.9: stable.
#[test]
fn no_crossing_at_all_gives_infinite_margins() {
    let (num, den) = ([0.9], [0.1, 1.1, 1.0]);
    let m = margins(&tf(&num, &den)).unwrap();
    assert!(m.crossings.is_empty(), "{m:#?}");
    assert_eq!(m.gain_margin_db, None);
    assert_eq!(m.phase_margin_deg, None);
    assert_eq!((m.phase_crossover_hz, m.gain_crossover_hz), (None, None));
    assert_eq!(m.delay_margin_s, None);
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
}

/// Pitfall (the python-control/python-control#87 loop, a feedback amplifier): two poles, so the
/// phase only tends to −180°, yet python-control's `stability_margins` on Bode data reported a
/// phase crossover. L = 1e15/(10 s² + 1.01e7 s + 1e11) = 1e14/((s + 1e4)(s + 1e6)).
/// GM infinite. |L| = 1 ⇔ (u + 1e8)(u + 1e12) = 1e28 (u = ω²), u = 2c/(b + √(b² + 4c)) with
/// b = 1e8 + 1e12, c = 1e28 − 1e20 (no cancellation); PM = 180° − atan(ω/1e4) − atan(ω/1e6).
#[test]
fn two_pole_amplifier_has_no_phase_crossing() {
    let (num, den) = ([1e15], [10.0, 1.01e7, 1e11]);
    let m = margins(&tf(&num, &den)).unwrap();
    let (b, c) = (1e8f64 + 1e12, 1e28 - 1e20);
    let wc = (2.0 * c / (b + (b * b + 4.0 * c).sqrt())).sqrt();
    let pm = 180.0 - ((wc / 1e4).atan() + (wc / 1e6).atan()).to_degrees();
    assert_eq!(m.crossings.len(), 1, "{m:#?}");
    assert_crossing(&m.crossings[0], CrossingKind::Gain, wc, pm, 1e-9);
    assert_near(
        m.delay_margin_s.unwrap(),
        pm.to_radians() / wc,
        1e-9 * pm.to_radians() / wc,
        "delay margin",
    );
    assert_no_phase_crossing(&m);
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
}

/// Pitfall: a crossing set by a zero far below every pole. An analysis range derived from the
/// poles alone (here 1…1e5 rad/s) misses it — `pumpcyl` did, until its range was extended
/// while |L| at the low end and |L(0)| lie on different sides of 1.
/// L = 0.5 (10 s + 1)/((0.01 s + 1)(0.001 s + 1)). |L| = 1 ⇔ 0.25 (1 + 100u) =
/// (1 + 1e-4 u)(1 + 1e-6 u) ⇔ 1e-10 u² − β u + 0.75 = 0 (u = ω², β = 25 − 1.01e-4), two positive
/// roots u₁ = 1.5/(β + √(β² − 3e-10)) (no cancellation) and u₂ = 0.75/(1e-10 u₁).
/// ∠L = atan 10ω − atan 0.01ω − atan 0.001ω: +60° at ω₁ = 0.173 → PM = −120° (wrapped into
/// (−180°, 180°]), and −89.9° at ω₂ ≈ 5e5 → PM = +90.1°, the headline. No phase crossing;
/// closed loop 1e-5 s² + 5.011 s + 1.5: stable.
#[test]
fn zero_far_below_the_poles_lifts_a_crossing_below_their_range() {
    let (num, den) = ([5.0, 0.5], [1e-5, 0.011, 1.0]);
    let m = margins(&tf(&num, &den)).unwrap();
    let beta = 25.0f64 - 1.01e-4;
    let u1 = 1.5 / (beta + (beta * beta - 3e-10).sqrt());
    let u2 = 0.75 / (1e-10 * u1);
    let phase = |w: f64| ((10.0 * w).atan() - (0.01 * w).atan() - (0.001 * w).atan()).to_degrees();
    let gains = of_kind(&m, CrossingKind::Gain);
    assert_eq!(gains.len(), 2, "{m:#?}");
    let (w1, w2) = (u1.sqrt(), u2.sqrt());
    assert_crossing(&gains[0], CrossingKind::Gain, w1, phase(w1) - 180.0, 1e-9);
    assert_crossing(&gains[1], CrossingKind::Gain, w2, phase(w2) + 180.0, 1e-9);
    assert_near(
        m.phase_margin_deg.unwrap(),
        phase(w2) + 180.0,
        1e-9,
        "headline PM",
    );
    // delay margins (PM taken in [0°, 360°)): 239.9° at ω₁, 90.1° at ω₂
    let d1 = (phase(w1) + 180.0).to_radians() / w1;
    assert_near(
        gains[0].delay_margin_s.unwrap(),
        d1,
        1e-9 * d1,
        "delay margin at ω₁",
    );
    assert_no_phase_crossing(&m);
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
}

// ---------------------------------------------------------------------------------------------
// Non-minimum phase and time delay
// ---------------------------------------------------------------------------------------------

/// Pitfall: a right-half-plane zero adds phase *lag* while it raises the gain, and its
/// numerator (1 − s/z) has a negative leading coefficient; the phase must still be anchored at
/// −90° (positive DC gain), not −270°.
/// L = K (1 − s/z)/(s (1 + s/p)), K = 1, z = 2, p = 10: ∠L = −90° − atan(ω/z) − atan(ω/p) =
/// −180° at ω = √(zp), where |L| = K/z → GM = 20 log10(z/K) = 6.02 dB. |L| = 1 ⇔
/// u²/p² + (1 − K²/z²) u − K² = 0 (u = ω²), PM = 90° − atan(ω/z) − atan(ω/p). Closed loop
/// s² + p(1 − K/z) s + Kp: stable iff K < z, consistent with GM > 0.
#[test]
fn right_half_plane_zero_adds_lag() {
    let (k, z, p) = (1.0f64, 2.0, 10.0);
    let (num, den) = ([-k * p / z, k * p], [1.0, p, 0.0]);
    let m = margins(&tf(&num, &den)).unwrap();
    let q = 1.0 - k * k / (z * z);
    let wc = (p * p * (-q + (q * q + 4.0 * k * k / (p * p)).sqrt()) / 2.0).sqrt();
    let pm = 90.0 - ((wc / z).atan() + (wc / p).atan()).to_degrees();
    assert_eq!(m.crossings.len(), 2, "{m:#?}");
    assert_crossing(&m.crossings[0], CrossingKind::Gain, wc, pm, 1e-9);
    assert_crossing(
        &m.crossings[1],
        CrossingKind::Phase,
        (z * p).sqrt(),
        20.0 * (z / k).log10(),
        1e-9,
    );
    assert_near(
        m.crossings[1].phase_deg,
        -180.0,
        1e-9,
        "anchored at −90°, not −270°",
    );
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
}

/// Q(x) of the [n/n] Padé approximant e^{−x} ≈ Q(−x)/Q(x): coefficients of x^k, k = 0…n,
/// c_k = (2n − k)! n! / ((2n)! k! (n − k)!).
fn pade_q(n: usize) -> Vec<f64> {
    let fact = |m: usize| (1..=m).map(|i| i as f64).product::<f64>();
    (0..=n)
        .map(|k| fact(2 * n - k) * fact(n) / (fact(2 * n) * fact(k) * fact(n - k)))
        .collect()
}

/// Pitfall: a time delay (5th-order Padé, T = 0.5 s) behind an integrator, L = K e^{−sT}/s:
/// the all-pass turns the phase down to −90° − 5·180° = −990°, crossing −180° three times
/// (−180°, −540°, −900°); a phase wrapped into (−180°, 180°] loses the branches
/// (JuliaControl/ControlSystems.jl#969 "handle phase wrapping in margin").
/// |Q(−jx)| = |Q(jx)|, so |L| = K/ω exactly: ω_c = K and GM = 20 log10(ω/K) at each phase
/// crossing. ∠L = −90° − 2 arg Q(jωT), so PM = 90° − 2 arg Q(jKT), delay margin PM(rad)/K —
/// and, the Padé phase error at ωT = 0.5 being ~(n!)²/((2n)!(2n+1)!)·x^{2n+1} ≈ 1e-13 rad,
/// also the exact-delay values 90° − KT (rad→deg) and π/(2K) − T. The phase crossings are
/// where arg Q(jx) = 45° + k·180°, i.e. the positive roots of Re Q(jx) − Im Q(jx), a quintic
/// with three sign changes (Descartes: at most three positive roots), bracketed on a fine grid
/// and bisected. Closed loop s Q(sT) + K Q(−sT): Routh–Hurwitz stable.
#[test]
fn pade_delay_behind_an_integrator() {
    let (k, t) = (1.0f64, 0.5);
    let q = pade_q(5);
    let q_of = |sign: f64| -> Vec<f64> {
        (0..q.len())
            .rev()
            .map(|i| q[i] * (sign * t).powi(i as i32))
            .collect()
    };
    let num: Vec<f64> = q_of(-1.0).iter().map(|c| c * k).collect();
    let den = poly_mul(&q_of(1.0), &[1.0, 0.0]);
    let m = margins(&tf(&num, &den)).unwrap();
    let qj = |x: f64| {
        q.iter().rev().fold(Complex64::new(0.0, 0.0), |acc, &c| {
            acc * Complex64::new(0.0, x) + c
        })
    };
    let pm = 90.0 - 2.0 * qj(k * t).arg().to_degrees();
    assert_near(
        pm,
        90.0 - (k * t).to_degrees(),
        1e-10,
        "Padé PM against the exact delay",
    );
    let f = |x: f64| qj(x).re - qj(x).im;
    let grid = pumpcyl::lti::log_grid(1e-2, 1e3, 5001);
    let roots: Vec<f64> = grid
        .windows(2)
        .filter(|g| (f(g[0]) < 0.0) != (f(g[1]) < 0.0))
        .map(|g| bisect_log(f, g[0], g[1]))
        .collect();
    assert_eq!(roots.len(), 3);
    assert_eq!(m.crossings.len(), 4, "{m:#?}");
    assert_crossing(&m.crossings[0], CrossingKind::Gain, k, pm, 1e-9);
    assert_near(
        m.delay_margin_s.unwrap(),
        pm.to_radians() / k,
        1e-9,
        "delay margin",
    );
    assert_near(
        m.delay_margin_s.unwrap(),
        PI / (2.0 * k) - t,
        1e-9,
        "exact-delay margin",
    );
    for (i, (c, x)) in m.crossings[1..].iter().zip(&roots).enumerate() {
        let w = x / t;
        assert_crossing(c, CrossingKind::Phase, w, 20.0 * (w / k).log10(), 1e-9);
        assert_near(
            c.phase_deg,
            -180.0 - 360.0 * i as f64,
            1e-9,
            "unwrapped branch",
        );
    }
    assert_near(
        m.gain_margin_db.unwrap(),
        20.0 * (roots[0] / t / k).log10(),
        1e-9,
        "GM",
    );
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
}

// ---------------------------------------------------------------------------------------------
// Near pole-zero cancellations
// ---------------------------------------------------------------------------------------------

/// Pitfall: a stable pole-zero pair 1e-4 apart right at the crossover. A transfer-function
/// library either cancels it (`minreal` tolerances) or loses it in the polynomial roots; the
/// dipole's phase dip, δ/2 rad for z = p(1 + δ), is what sets the PM below 90°.
/// L = (K/s)(s + z)/(s + p), K = p: |L| = 1 ⇔ u² + (p² − K²)u − K²z² = 0 ⇔ u = pz (u = ω²),
/// and PM = 90° + atan √(p/z) − atan √(z/p) = 90° − 0.00286°. No phase crossing; closed loop
/// s² + (p + K)s + Kz: stable.
#[test]
fn stable_dipole_at_the_crossover_keeps_its_phase_dip() {
    let (p, delta) = (10.0f64, 1e-4);
    let (z, k) = (p * (1.0 + delta), p);
    let (num, den) = ([k, k * z], [1.0, p, 0.0]);
    let m = margins(&tf(&num, &den)).unwrap();
    let pm = 90.0 + ((p / z).sqrt().atan() - (z / p).sqrt().atan()).to_degrees();
    assert!(90.0 - pm > 0.0028, "the dip is resolved: {pm}");
    assert_eq!(m.crossings.len(), 1, "{m:#?}");
    assert_crossing(
        &m.crossings[0],
        CrossingKind::Gain,
        (p * z).sqrt(),
        pm,
        1e-9,
    );
    assert_no_phase_crossing(&m);
    assert!(hurwitz(&closed_loop(&num, &den)) && m.closed_loop_stable);
}

/// Pitfall: an *unstable* pole almost cancelled by a zero (a = 1, a' = 1 + 1e-6). The
/// frequency response is that of K/s to 1e-6 — PM ≈ 90°, no phase crossing, the picture of a
/// healthy loop — but the pole is still there and the loop is unstable; a margin routine that
/// cancels the pair (`minreal`) or judges stability from the margins says "stable". `margins`
/// takes the verdict from the closed-loop eigenvalues (and reports a delay margin of 0).
/// L = K (s − a')/(s (s − a)), K = 2: ∠L = −90° − atan(ω/a') + atan(ω/a) (real-axis value
/// K(σ − a')/(σ(σ − a)) > 0: anchored at −90°); |L| = 1 ⇔ u² + (a² − K²)u − K²a'² = 0;
/// closed loop s² + (K − a)s − Ka': a negative constant term, unstable.
#[test]
fn nearly_cancelled_unstable_pole_is_still_unstable() {
    let (a, k) = (1.0f64, 2.0);
    let a2 = a * (1.0 + 1e-6);
    let (num, den) = ([k, -k * a2], [1.0, -a, 0.0]);
    let m = margins(&tf(&num, &den)).unwrap();
    let q = a * a - k * k;
    let wc = ((-q + (q * q + 4.0 * k * k * a2 * a2).sqrt()) / 2.0).sqrt();
    let pm = 90.0 + ((wc / a).atan() - (wc / a2).atan()).to_degrees();
    assert_eq!(m.crossings.len(), 1, "{m:#?}");
    assert_crossing(&m.crossings[0], CrossingKind::Gain, wc, pm, 1e-9);
    assert_no_phase_crossing(&m);
    assert!(!hurwitz(&closed_loop(&num, &den)));
    assert!(!m.closed_loop_stable, "{m:#?}");
    assert_eq!(m.delay_margin_s, Some(0.0));
}

// ---------------------------------------------------------------------------------------------
// High order
// ---------------------------------------------------------------------------------------------

/// ζ of the second-order sections of an n-th order Butterworth filter (n even).
fn butterworth_zetas(n: usize) -> Vec<f64> {
    (1..=n / 2)
        .map(|k| ((2 * k - 1) as f64 * PI / (2 * n) as f64).sin())
        .collect()
}

/// Pitfall: a 49-state loop. As a transfer function its filter denominator has coefficients
/// from 1 to 1.5e11, and the roots of the rounded coefficients are off by up to 0.34 — five
/// times the spacing of the true poles (checked with numpy) — so any analysis through the
/// polynomial is meaningless (JuliaControl/ControlSystems.jl#800 warns against high-order
/// `tf`); `margins` works on the state space.
/// L = (K/s)·B₄₈(s/ωc), B₄₈ the 48th-order Butterworth low-pass as 24 second-order sections in
/// cascade, ωc = 1, K = 0.02. Closed forms: |B(jω)|² = 1/(1 + ω⁹⁶), ∠L = −90° −
/// Σ atan2(2ζ_k ω, 1 − ω²) (continuous, decreasing). |L| = 1 and ∠L = −180° − k·360° are
/// solved by bisection on these expressions. At ω = K, |B| = 1 − 0.02⁹⁶/2: the gain crossover
/// is K to the last bit, PM = 55.0°; the phase then turns by 48·90° in all, through twelve
/// phase crossings, the first (GM 8.2 dB) the headline. All of them have |L| < 1 and the loop
/// is open-loop stable apart from the integrator, so the Nyquist plot does not encircle −1:
/// stable. Only the crossings where |L| is above −120 dB are compared: further out L is below
/// the rounding level of its evaluation (down to −830 dB at the twelfth crossing).
#[test]
fn butterworth_48_behind_an_integrator() {
    let (n, k) = (48, 0.02);
    let zetas = butterworth_zetas(n);
    let section = |z: f64| {
        let m = |r, c, v: &[f64]| DMatrix::from_row_slice(r, c, v);
        let (a, b) = (m(2, 2, &[0.0, 1.0, -1.0, -2.0 * z]), m(2, 1, &[0.0, 1.0]));
        StateSpace::new(a, b, m(1, 2, &[1.0, 0.0]), m(1, 1, &[0.0])).unwrap()
    };
    let mut blocks = vec![tf(&[k], &[1.0, 0.0])];
    blocks.extend(zetas.iter().map(|&z| section(z)));
    let sys = cascade(&blocks);
    assert_eq!(sys.order(), 49);
    let m = margins(&sys).unwrap();
    let mag = |w: f64| k / w / (1.0 + w.powi(2 * n as i32)).sqrt();
    let phase = |w: f64| {
        -90.0
            - zetas
                .iter()
                .map(|z| (2.0 * z * w).atan2(1.0 - w * w).to_degrees())
                .sum::<f64>()
    };
    let wc = bisect_log(|w| mag(w) - 1.0, 1e-4, 1.0);
    let pm = 180.0 + phase(wc);
    let phase_w: Vec<f64> = (0..12)
        .map(|i| bisect_log(|w| phase(w) + 180.0 + 360.0 * i as f64, 1e-3, 1e3))
        .collect();
    let resolved: Vec<&Crossing> = m
        .crossings
        .iter()
        .filter(|c| c.magnitude_db > -120.0)
        .collect();
    let mut expected = vec![(CrossingKind::Gain, wc, pm)];
    expected.extend(
        phase_w
            .iter()
            .filter(|&&w| mag(w) > 1e-6)
            .map(|&w| (CrossingKind::Phase, w, -20.0 * mag(w).log10())),
    );
    assert_eq!(resolved.len(), expected.len(), "{m:#?}");
    assert_eq!(expected.len(), 9);
    for (c, (kind, w, margin)) in resolved.iter().zip(expected) {
        assert_crossing(c, kind, w, margin, 1e-6);
    }
    assert_near(m.phase_margin_deg.unwrap(), pm, 1e-6, "PM");
    assert_near(
        m.gain_margin_db.unwrap(),
        -20.0 * mag(phase_w[0]).log10(),
        1e-6,
        "GM",
    );
    assert_near(
        m.delay_margin_s.unwrap(),
        pm.to_radians() / wc,
        1e-6,
        "delay margin",
    );
    // Nyquist: every crossing of the negative real axis has |L| < 1
    assert!(phase_w.iter().all(|&w| mag(w) < 1.0));
    assert!(m.closed_loop_stable);
}

// ---------------------------------------------------------------------------------------------
// Defects these plants found in `margins`, fixed (src/lti/margins.rs: PHASE_TOUCH_DEG and
// PHASE_CROSSING_FLOOR_DB)
// ---------------------------------------------------------------------------------------------

/// Was a defect: phase crossings where L is rounding noise. L = (1/s)·Π p/(s + p), p ∈ {1, 2, 4, 8,
/// 16, 30}, realised as a cascade of its factors (7 states): ∠L = −90° − Σ atan(ω/p), strictly
/// decreasing to −630°, crosses −180° and −540° once each (bisection) and |L| = 1 once. The
/// companion form of the same L gives exactly these three; the cascade adds a fourth phase
/// crossing at 1454 rad/s where |L| = −376 dB, far below the rounding level of its evaluation
/// (in a mildly dense basis, cond(T) = 2.6, the same loop lists 41 such crossings).
#[test]
fn no_phase_crossings_below_the_rounding_level() {
    let poles = [1.0, 2.0, 4.0, 8.0, 16.0, 30.0];
    let mut blocks = vec![tf(&[1.0], &[1.0, 0.0])];
    blocks.extend(poles.map(|p| tf(&[p], &[1.0, p])));
    let m = margins(&cascade(&blocks)).unwrap();
    let phase = |w: f64| {
        -90.0
            - poles
                .iter()
                .map(|p| (w / p).atan().to_degrees())
                .sum::<f64>()
    };
    let mag = |w: f64| {
        poles
            .iter()
            .map(|p| p / (p * p + w * w).sqrt())
            .product::<f64>()
            / w
    };
    let expected = [
        (
            CrossingKind::Gain,
            bisect_log(|w| mag(w) - 1.0, 0.01, 100.0),
        ),
        (
            CrossingKind::Phase,
            bisect_log(|w| phase(w) + 180.0, 0.01, 100.0),
        ),
        (
            CrossingKind::Phase,
            bisect_log(|w| phase(w) + 540.0, 0.01, 1e3),
        ),
    ];
    assert_eq!(m.crossings.len(), 3, "{m:#?}");
    for (c, (kind, w)) in m.crossings.iter().zip(expected) {
        assert_eq!(c.kind, kind);
        assert_near(
            c.frequency_hz,
            hz(w),
            1e-9 * hz(w),
            "crossing frequency (Hz)",
        );
    }
}

/// Was a defect: the double integrator of [`double_integrator_has_zero_phase_margin_and_no_phase_crossing`]
/// in rotated coordinates (A' = Rᵀ A R, a rotation by 2 rad). Its phase is −180° up to
/// rounding, and the sign of that rounding creates phase crossings: 8 of them, headline GM
/// +2.77 dB (other angles give other GMs, e.g. −32.8 dB at 1 rad).
#[test]
fn double_integrator_in_rotated_coordinates_has_no_phase_crossing() {
    let (c, s) = (2f64.cos(), 2f64.sin());
    let r = DMatrix::from_row_slice(2, 2, &[c, -s, s, c]);
    let sys = tf(&[4.0], &[1.0, 0.0, 0.0]);
    let rt = r.transpose();
    let rotated = StateSpace::new(&rt * &sys.a * &r, &rt * &sys.b, &sys.c * &r, sys.d.clone());
    let m = margins(&rotated.unwrap()).unwrap();
    assert_eq!(m.crossings.len(), 1, "{m:#?}");
    assert_no_phase_crossing(&m);
}

/// Was a defect (found by tests/properties.rs): a resonance behind a lag whose |L| peaks only
/// 0.053 dB above 0 dB, between 22.98 and 24.44 rad/s. The grid's seed points sit at the damped
/// frequency, not at the magnitude peak, and both grid neighbours of the peak were below 0 dB:
/// no gain crossing was reported. The two crossings are found by bisection on the closed form
/// |L(jω)| = K ωn² / |ωn² − ω² + 2jζωnω| · p / |jω + p|.
#[test]
fn a_peak_grazing_0_db_between_grid_points_gives_its_crossing_pair() {
    let (wn, zeta, p): (f64, f64, f64) =
        (25.394083724233358, 0.24923106600292969, 158.41758398662677);
    let shape = |w: f64| {
        wn * wn / ((wn * wn - w * w).powi(2) + (2.0 * zeta * wn * w).powi(2)).sqrt() * p
            / (w * w + p * p).sqrt()
    };
    let k = 1.0 / shape(24.443632328185284);
    let mag = |w: f64| k * shape(w);
    let resonance = tf(&[k * wn * wn], &[1.0, 2.0 * zeta * wn, wn * wn]);
    let lag = tf(&[p], &[1.0, p]);
    let m = margins(&cascade(&[resonance, lag])).unwrap();
    let gains: Vec<&Crossing> = m
        .crossings
        .iter()
        .filter(|c| c.kind == CrossingKind::Gain)
        .collect();
    assert_eq!(gains.len(), 2, "{m:#?}");
    let peak = bisect_log(|w| wn * (1.0 - 2.0 * zeta * zeta).sqrt() - w, 1.0, 100.0);
    let expected = [
        bisect_log(|w| mag(w) - 1.0, 10.0, peak),
        bisect_log(|w| 1.0 - mag(w), peak, 100.0),
    ];
    for (c, w) in gains.iter().zip(expected) {
        assert_near(c.frequency_hz, hz(w), 1e-9 * hz(w), "gain crossing (Hz)");
    }
    assert!(m.phase_margin_deg.is_some());
}
