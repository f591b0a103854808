//! Stability margins of a SISO loop transfer L(s) under unity negative feedback (docs/analysis.md#margins).
//!
//! Method: evaluate L(jω) by a solve on a logarithmic grid that covers every pole's frequency
//! ±2 decades, with extra points at lightly damped poles, refined wherever the phase moves more
//! than 20° or the magnitude more than 10 dB between neighbours; unwrap the phase from the
//! low-frequency asymptote (−90° per integrator); find every sign change of |L| − 1 (gain
//! crossings) and of the phase through −180° + k·360° (phase crossings), and refine each with
//! Brent's method in log ω. A grid-local peak of |L| just below 0 dB (or dip just above) is
//! searched for its true extremum, so a pair of crossings between two grid points is not
//! missed. A phase that only touches −180° through rounding (a double
//! integrator) does not cross it, and phase crossings below −200 dB (where the phase is rounding
//! noise) are not reported. Stability is decided from the closed-loop eigenvalues, never from
//! the margins, so open-loop unstable plants are not misjudged.

use super::freqresp::{
    low_frequency_asymptote, nearest_branch, unwrap_from, FreqEvaluator, LoopResponse,
};
use super::{roots, LtiError, Stability, StateSpace};
use num_complex::Complex64;
use serde::Serialize;
use std::f64::consts::PI;

/// Initial grid density (points per decade).
const POINTS_PER_DECADE: f64 = 20.0;
/// Largest phase step (deg) allowed between neighbouring grid points.
const MAX_PHASE_STEP_DEG: f64 = 20.0;
/// Largest magnitude step (dB) allowed between neighbouring grid points: a 10 dB step in a
/// twentieth of a decade is a 200 dB/decade slope, only seen near sharp resonances (whose
/// frequencies are seeded into the grid as well).
const MAX_MAG_STEP_DB: f64 = 10.0;
/// A phase that stays within this distance (deg) of −180° + k·360° on both sides of a sign
/// change only touches the level through rounding (a double integrator sits on −180°
/// everywhere): that is not a phase crossing.
const PHASE_TOUCH_DEG: f64 = 1e-6;
/// A magnitude that stays within this distance (dB) of 0 dB on both sides of a sign change
/// only touches it through rounding (|L(0)| = 1 with |L| < 1 above: 1/(s + 1) is −4e−16 dB at
/// 10⁻⁸ rad/s): that is not a gain crossing, and it has no delay margin.
const GAIN_TOUCH_DB: f64 = 1e-9;
/// 20/ln 10: dB per neper (a relative change η of |L| is 20 log10(1 + η) ≈ 8.69 η dB).
const DB_PER_NEPER: f64 = 8.685_889_638_065_035;
/// Phase crossings where |L| is below this level (dB) are not reported: there the phase is
/// rounding noise, and a gain margin above 200 dB says nothing about stability.
const PHASE_CROSSING_FLOOR_DB: f64 = -200.0;
/// Bisection depth limit of the grid refinement (a factor 2¹² finer at most).
const MAX_REFINE_DEPTH: u32 = 12;

/// Whether a crossing is of the magnitude (|L| = 1) or of the phase (∠L = −180° + k·360°).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CrossingKind {
    /// |L(jω)| = 1: gives a phase margin.
    Gain,
    /// ∠L(jω) = −180° mod 360°: gives a gain margin.
    Phase,
}

/// One crossing of the open-loop frequency response.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Crossing {
    /// Gain or phase crossing.
    pub kind: CrossingKind,
    /// Frequency (Hz).
    pub frequency_hz: f64,
    /// |L| there (dB).
    pub magnitude_db: f64,
    /// Unwrapped phase there (deg).
    pub phase_deg: f64,
    /// Phase margin (deg, in (−180, 180]) at a gain crossing; gain margin (dB) at a phase
    /// crossing.
    pub margin: f64,
    /// Delay margin (s) at a gain crossing: the smallest pure delay that brings this crossing to
    /// −180°.
    pub delay_margin_s: Option<f64>,
    /// First-order bound on the error of `margin` (its unit: deg at a gain crossing, dB at a
    /// phase crossing) that the conditioning of the model allows in double precision
    /// (docs/analysis.md#conditioning).
    pub margin_error_bound: f64,
}

/// Margins of a loop, with every crossing. `None` headline values are infinite margins (no
/// crossing of that kind).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Margins {
    /// Headline gain margin (dB): the phase crossing with the smallest |GM|, as MATLAB `margin`.
    pub gain_margin_db: Option<f64>,
    /// Headline phase margin (deg): the gain crossing with the smallest |PM|.
    pub phase_margin_deg: Option<f64>,
    /// Frequency of the headline gain margin (Hz).
    pub phase_crossover_hz: Option<f64>,
    /// Frequency of the headline phase margin (Hz).
    pub gain_crossover_hz: Option<f64>,
    /// Smallest delay margin over the gain crossings (s); 0 when the closed loop is already
    /// unstable **\[choice\]** (docs/choices.md); `None` (infinite) without a gain crossing.
    pub delay_margin_s: Option<f64>,
    /// Closed-loop asymptotic stability proven from the closed-loop eigenvalues: true only when
    /// [`closed_loop_stability`](Margins::closed_loop_stability) is `Stable`.
    pub closed_loop_stable: bool,
    /// Closed-loop stability from the closed-loop eigenvalues, decided against rounding:
    /// `stable`, `unstable`, or `undecided` when a pole lies within rounding of the imaginary axis.
    pub closed_loop_stability: Stability,
    /// Every crossing, by increasing frequency.
    pub crossings: Vec<Crossing>,
    /// Poles at the origin counted for the phase anchor.
    pub integrators: usize,
    /// The velocity-loop gain K_v (1/s): lim s·L(s) as s → 0, the steady rate of the output per
    /// unit of error, the velocity error constant of a type-1 loop (Ogata, *Modern Control
    /// Engineering*, 5th ed., §5-8). For a position loop it is the piston's steady velocity per
    /// metre of error, comparable across circuits whatever unit their K_p has
    /// (docs/analysis.md#the-velocity-loop-gain). `None` unless the loop has exactly one
    /// integrator.
    pub velocity_gain_per_s: Option<f64>,
    /// The conditioning of the model does not allow the headline gain or phase margin to
    /// [`RELIABLE_DB`] dB / [`RELIABLE_DEG`]°: its crossing's `margin_error_bound` is larger
    /// (docs/analysis.md#conditioning).
    pub ill_conditioned: bool,
}

/// Largest error bound (dB) of a gain margin stated without an ill-conditioning warning.
pub const RELIABLE_DB: f64 = 0.01;
/// Largest error bound (deg) of a phase margin stated without an ill-conditioning warning.
pub const RELIABLE_DEG: f64 = 0.01;

/// Margins of the SISO loop transfer `sys` (see the module documentation for the method).
///
/// The margins of the article's rig: the open loop x_ref → x with the position feedback
/// removed and the sum-pressure loop open ([`Plant::open_loop`](crate::model::Plant::open_loop)),
/// the article's GM ≈ 6.45 dB and PM ≈ 33.5° (docs/analysis.md#margins):
///
/// ```
/// use pumpcyl::{lti::margins, model::Plant, rig::Rig};
///
/// let m = margins(&Plant::new(&Rig::default()).open_loop(false))?;
/// let (gm_db, pm_deg) = (m.gain_margin_db.unwrap(), m.phase_margin_deg.unwrap());
/// assert!((6.4..6.5).contains(&gm_db), "GM {gm_db} dB");
/// assert!((33.0..34.0).contains(&pm_deg), "PM {pm_deg} deg");
/// assert!(m.closed_loop_stable);
/// // the gain crossing lies below the phase crossing, as it must for a stable loop
/// assert!(m.gain_crossover_hz.unwrap() < m.phase_crossover_hz.unwrap());
///
/// // at 37.8 bar (the gas-laden oil at 1 bar) both margins are negative: unstable
/// let soft = Rig::default().with_overrides(&["beta_bar=37.8".to_string()])?;
/// let m = margins(&Plant::new(&soft).open_loop(false))?;
/// assert!(m.gain_margin_db.unwrap() < 0.0 && m.phase_margin_deg.unwrap() < 0.0);
/// assert!(!m.closed_loop_stable);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn margins(sys: &StateSpace) -> Result<Margins, LtiError> {
    let ev = FreqEvaluator::new(sys)?;
    sys.require_transfer()?;
    let poles = ev.poles();
    let integrators = ev.integrators();
    let stability = sys.closed_loop_stability()?;
    let (lo, hi) = frequency_range(&ev, poles, integrators, sys.d[(0, 0)]);
    let asymptote = low_frequency_asymptote(&ev, lo, integrators);
    let grid = Grid::build(&ev, seeds(poles, lo, hi), asymptote);
    let mut crossings = grid.crossings(&ev);
    if integrators == 0 {
        crossings.splice(0..0, dc_phase_crossing(&ev));
    }
    let mut m = summarise(crossings, stability, integrators);
    m.velocity_gain_per_s = (integrators == 1).then(|| velocity_gain(&ev));
    if let Some(c) = m
        .crossings
        .iter()
        .find(|c| !(c.margin.is_finite() && c.phase_deg.is_finite()))
    {
        return Err(LtiError::NonFiniteResult {
            what: "the margins",
            at: format!("{} Hz", crate::units::readable(c.frequency_hz)),
        });
    }
    Ok(m)
}

/// A loop without integrators whose DC gain L(0) is negative sits on −180° at ω = 0: that is a
/// phase crossing at 0 Hz (as MATLAB `allmargin` reports), with GM = −20 log10 |L(0)|.
fn dc_phase_crossing(ev: &FreqEvaluator) -> Option<Crossing> {
    let l0 = ev.eval(Complex64::new(0.0, 0.0));
    (l0.re < 0.0 && l0.re.is_finite()).then(|| {
        let magnitude_db = 20.0 * l0.re.abs().log10();
        Crossing {
            kind: CrossingKind::Phase,
            frequency_hz: 0.0,
            magnitude_db,
            phase_deg: -180.0,
            margin: -magnitude_db,
            delay_margin_s: None,
            margin_error_bound: DB_PER_NEPER * ev.relative_error_bound(0.0),
        }
    })
}

/// Pick the headline margins from the crossings.
pub(super) fn summarise(
    crossings: Vec<Crossing>,
    stability: Stability,
    integrators: usize,
) -> Margins {
    let closed_loop_stable = stability == Stability::Stable;
    let smallest = |kind| {
        crossings
            .iter()
            .filter(|c| c.kind == kind)
            .min_by(|a, b| a.margin.abs().total_cmp(&b.margin.abs()))
    };
    let gm = smallest(CrossingKind::Phase);
    let pm = smallest(CrossingKind::Gain);
    let delay = crossings
        .iter()
        .filter_map(|c| c.delay_margin_s)
        .min_by(f64::total_cmp)
        .map(|d| if closed_loop_stable { d } else { 0.0 });
    let ill_conditioned = gm.is_some_and(|c| c.margin_error_bound > RELIABLE_DB)
        || pm.is_some_and(|c| c.margin_error_bound > RELIABLE_DEG);
    Margins {
        ill_conditioned,
        gain_margin_db: gm.map(|c| c.margin),
        phase_margin_deg: pm.map(|c| c.margin),
        phase_crossover_hz: gm.map(|c| c.frequency_hz),
        gain_crossover_hz: pm.map(|c| c.frequency_hz),
        delay_margin_s: delay,
        closed_loop_stable,
        closed_loop_stability: stability,
        crossings,
        integrators,
        velocity_gain_per_s: None,
    }
}

/// lim s·L(s) as s → 0 of a loop with one integrator: s·L(s) = K_v + O(s) at real s below the
/// slowest other pole, so two values at ε and 2ε, ε ten-thousandths of that pole, give K_v by
/// Richardson extrapolation to O(ε²), a relative 10⁻⁸ of the pole's own term.
pub(super) fn velocity_gain(ev: &FreqEvaluator) -> f64 {
    let slowest = (ev.poles().iter().skip(1))
        .map(|p| p.norm())
        .find(|r| *r > 0.0)
        .unwrap_or(1.0);
    let at = |s: f64| s * ev.eval(Complex64::new(s, 0.0)).re;
    let eps = 1e-4 * slowest;
    2.0 * at(eps) - at(2.0 * eps)
}

/// The grid's first points over [`lo`, `hi`] (rad/s): [`POINTS_PER_DECADE`] and the points
/// around the lightly damped `poles` ([`pole_points`]).
pub(super) fn seeds(poles: &[Complex64], lo: f64, hi: f64) -> Vec<f64> {
    let mut seeds = super::log_grid(lo, hi, ((hi / lo).log10() * POINTS_PER_DECADE) as usize + 2);
    seeds.extend(
        pole_points(poles)
            .into_iter()
            .filter(|w| *w > lo && *w < hi),
    );
    seeds
}

/// The refined frequency grid with values and unwrapped phase.
pub(super) struct Grid {
    omega: Vec<f64>,
    mag_db: Vec<f64>,
    phase_deg: Vec<f64>,
}

impl Grid {
    /// The response on `seeds` (rad/s), refined where it moves too much between neighbours, the
    /// phase unwrapped from the branch nearest `asymptote` (deg).
    pub(super) fn build(ev: &impl LoopResponse, mut seeds: Vec<f64>, asymptote: f64) -> Grid {
        seeds.sort_by(f64::total_cmp);
        seeds.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * *b);
        let seeded = ev.at_many(&seeds).into_iter().zip(&seeds).map(|(g, &w)| {
            if finite(g) {
                (w, g)
            } else {
                off_pole(ev, w)
            }
        });
        let mut omega = Vec::with_capacity(seeds.len() * 2);
        let mut values = Vec::with_capacity(seeds.len() * 2);
        let mut prev = None;
        for next in seeded {
            match prev {
                None => {
                    omega.push(next.0);
                    values.push(next.1);
                }
                Some(p) => refine(ev, p, next, 0, &mut omega, &mut values),
            }
            prev = Some(next);
        }
        let (omega, values) = with_hidden_extrema(ev, omega, values);
        let phase_deg = unwrap_from(&values, asymptote);
        let mag_db = values.iter().map(|g| 20.0 * g.norm().log10()).collect();
        Grid {
            omega,
            mag_db,
            phase_deg,
        }
    }

    /// Every gain and phase crossing, refined, by increasing frequency.
    pub(super) fn crossings(&self, ev: &impl LoopResponse) -> Vec<Crossing> {
        let mut out = Vec::new();
        for i in 1..self.omega.len() {
            let (w0, w1) = (self.omega[i - 1], self.omega[i]);
            let touch = self.mag_db[i - 1].abs().max(self.mag_db[i].abs()) <= GAIN_TOUCH_DB;
            if (self.mag_db[i - 1] >= 0.0) != (self.mag_db[i] >= 0.0) && !touch {
                let mag = |u: f64| 20.0 * ev.at(u.exp()).norm().log10();
                let w = brent_log(mag, w0, w1);
                out.push(self.crossing_at(ev, CrossingKind::Gain, w, i));
            }
            let k0 = ((self.phase_deg[i - 1] + 180.0) / 360.0).floor();
            let k1 = ((self.phase_deg[i] + 180.0) / 360.0).floor();
            let level = -180.0 + 360.0 * k0.max(k1);
            let away = (self.phase_deg[i - 1] - level)
                .abs()
                .max((self.phase_deg[i] - level).abs());
            if k0 != k1 && away > PHASE_TOUCH_DEG {
                let phase = |u: f64| self.phase_near(ev, u.exp(), i) - level;
                let w = brent_log(phase, w0, w1);
                let c = self.crossing_at(ev, CrossingKind::Phase, w, i);
                if c.magnitude_db > PHASE_CROSSING_FLOOR_DB {
                    out.push(c);
                }
            }
        }
        out.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
        out
    }

    /// A phase crossing at the grid's last point, where the phase sits on −180° + k·360° (within
    /// [`PHASE_TOUCH_DEG`] · 10³) without crossing it inside the grid: the Nyquist frequency of a
    /// sampled loop, where its response is real. `None` elsewhere.
    pub(super) fn crossing_at_end(&self, ev: &impl LoopResponse) -> Option<Crossing> {
        let i = self.omega.len() - 1;
        let phase = self.phase_deg[i];
        let level = -180.0 + 360.0 * ((phase + 180.0) / 360.0).round();
        let on = (phase - level).abs() <= 1e3 * PHASE_TOUCH_DEG;
        let c = self.crossing_at(ev, CrossingKind::Phase, self.omega[i], i);
        (on && c.magnitude_db > PHASE_CROSSING_FLOOR_DB).then_some(Crossing {
            phase_deg: level,
            ..c
        })
    }

    /// Unwrapped phase at ω inside grid interval `i` (between points i−1 and i).
    fn phase_near(&self, ev: &impl LoopResponse, omega: f64, i: usize) -> f64 {
        let (w0, w1) = (self.omega[i - 1], self.omega[i]);
        let t = (omega / w0).ln() / (w1 / w0).ln();
        let interp = self.phase_deg[i - 1] + t * (self.phase_deg[i] - self.phase_deg[i - 1]);
        nearest_branch(ev.at(omega).arg().to_degrees(), interp)
    }

    fn crossing_at(
        &self,
        ev: &impl LoopResponse,
        kind: CrossingKind,
        omega: f64,
        i: usize,
    ) -> Crossing {
        let g = ev.at(omega);
        let magnitude_db = 20.0 * g.norm().log10();
        let phase_deg = self.phase_near(ev, omega, i);
        let (margin, delay_margin_s) = match kind {
            CrossingKind::Gain => {
                let pm = wrap_half_open(phase_deg + 180.0);
                let delay = pm.rem_euclid(360.0).to_radians() / omega;
                (pm, delay.is_finite().then_some(delay))
            }
            CrossingKind::Phase => (-magnitude_db, None),
        };
        Crossing {
            kind,
            frequency_hz: omega / (2.0 * PI),
            magnitude_db,
            phase_deg,
            margin,
            delay_margin_s,
            margin_error_bound: margin_error_bound(ev, kind, omega),
        }
    }
}

/// The error bound of the margin at a crossing at ω (docs/analysis.md#conditioning): the
/// relative error η of L(jω) moves the quantity read there directly and, through the shift of
/// the crossing along the other quantity's slope, indirectly. With g = d ln L/dω, a phase
/// crossing's GM moves by 8.69 η (1 + |Re g / Im g|) dB, a gain crossing's PM by
/// η (1 + |Im g / Re g|) rad.
fn margin_error_bound(ev: &impl LoopResponse, kind: CrossingKind, omega: f64) -> f64 {
    let (eta, g) = ev.relative_error_and_log_slope(omega);
    match kind {
        CrossingKind::Phase => DB_PER_NEPER * eta * (1.0 + (g.re / g.im).abs()),
        CrossingKind::Gain => (eta * (1.0 + (g.im / g.re).abs())).to_degrees(),
    }
}

/// Bisect (in log ω) between two evaluated points while the response moves too much.
fn refine(
    ev: &impl LoopResponse,
    a: (f64, Complex64),
    b: (f64, Complex64),
    depth: u32,
    omega: &mut Vec<f64>,
    values: &mut Vec<Complex64>,
) {
    let dphase = nearest_branch((b.1 / a.1).arg().to_degrees(), 0.0).abs();
    let dmag = 20.0 * (b.1.norm() / a.1.norm()).log10().abs();
    let too_coarse = !(dphase <= MAX_PHASE_STEP_DEG && dmag <= MAX_MAG_STEP_DB);
    if too_coarse && depth < MAX_REFINE_DEPTH {
        let wm = (a.0 * b.0).sqrt();
        let mid = (wm, ev.at(wm));
        refine(ev, a, mid, depth + 1, omega, values);
        refine(ev, mid, b, depth + 1, omega, values);
    } else {
        omega.push(b.0);
        values.push(b.1);
    }
}

/// Width (dB) of the band below 0 dB (above, for minima) in which a local extremum of |L| on
/// the grid is searched for its true extremum: a peak grazing 0 dB between two grid points hides
/// a pair of gain crossings.
const HIDDEN_PAIR_BAND_DB: f64 = 6.0;

/// The grid with the true extremum of |L| added inside every grid-local maximum lying just
/// below 0 dB (or minimum just above), found by golden-section search in log ω over the two
/// neighbouring intervals: where it reaches across 0 dB the crossing pair becomes visible.
fn with_hidden_extrema(
    ev: &impl LoopResponse,
    omega: Vec<f64>,
    values: Vec<Complex64>,
) -> (Vec<f64>, Vec<Complex64>) {
    let db: Vec<f64> = values.iter().map(|g| 20.0 * g.norm().log10()).collect();
    let mut points: Vec<(f64, Complex64)> = omega.iter().copied().zip(values).collect();
    for i in 1..db.len().saturating_sub(1) {
        let peak = db[i] >= db[i - 1] && db[i] >= db[i + 1] && db[i] > -HIDDEN_PAIR_BAND_DB;
        let dip = db[i] <= db[i - 1] && db[i] <= db[i + 1] && db[i] < HIDDEN_PAIR_BAND_DB;
        if (peak && db[i] < 0.0) || (dip && db[i] >= 0.0) {
            let sign = if peak { -1.0 } else { 1.0 };
            let f = |u: f64| sign * ev.at(u.exp()).norm();
            let u = golden_min(f, omega[i - 1].ln(), omega[i + 1].ln());
            points.push((u.exp(), ev.at(u.exp())));
        }
    }
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    points.dedup_by(|a, b| (a.0 - b.0).abs() <= 1e-12 * b.0);
    points.into_iter().unzip()
}

/// The minimiser of a unimodal `f` on [a, b] by golden-section search (to 1e-12 relative).
fn golden_min(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..200 {
        if (b - a).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs())) {
            break;
        }
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - r * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    (a + b) / 2.0
}

/// Analysis range (rad/s): two decades beyond the slowest and fastest non-zero poles, extended
/// (a decade at a time, twelve at most) while a gain crossing must still lie outside — while |L|
/// at an end of the range is on the other side of 1 from its limit beyond that end (∞ at
/// ω → 0 with integrators, |L(0)| without, |D| at ω → ∞) — or while the phase has not settled
/// to its asymptote there (it still moves more than [`SETTLED_DEG`] over the next decade) and
/// |L| is above the phase-crossing floor. The poles alone do not bound the crossings: a zero far
/// below or above them turns the phase and lifts |L| through 1 outside their range.
pub(super) fn frequency_range(
    ev: &FreqEvaluator,
    poles: &[Complex64],
    integrators: usize,
    d: f64,
) -> (f64, f64) {
    let nonzero = poles[integrators..]
        .iter()
        .map(|p| p.norm())
        .filter(|&w| w > 0.0);
    let (min, max) = nonzero.fold((f64::INFINITY, 0.0f64), |(lo, hi), w| {
        (lo.min(w), hi.max(w))
    });
    let (mut lo, mut hi) = if max > 0.0 {
        (min / 100.0, max * 100.0)
    } else {
        (1e-2, 1e2)
    };
    let dc = if integrators > 0 {
        f64::INFINITY
    } else {
        ev.eval(Complex64::new(0.0, 0.0)).norm()
    };
    let floor = 10f64.powf(PHASE_CROSSING_FLOOR_DB / 20.0);
    let unsettled = |w0: f64, w1: f64| {
        let (g0, g1) = (ev.at(w0), ev.at(w1));
        let turn = nearest_branch((g1 / g0).arg().to_degrees(), 0.0).abs();
        (turn.is_nan() || turn > SETTLED_DEG) && g0.norm().max(g1.norm()) > floor
    };
    for _ in 0..12 {
        let extend_lo = (ev.at(lo).norm() < 1.0) != (dc < 1.0) || unsettled(lo / 10.0, lo);
        if extend_lo {
            lo /= 10.0;
        }
        let extend_hi = (ev.at(hi).norm() < 1.0) != (d.abs() < 1.0) || unsettled(hi, hi * 10.0);
        if extend_hi {
            hi *= 10.0;
        }
        // neither end moved: every further pass would test the same points again
        if !(extend_lo || extend_hi) {
            break;
        }
    }
    (lo, hi)
}

/// The phase (deg) is settled at an end of the range when it turns less than this over the next
/// decade: a pole or zero three decades beyond turns it by about 0.5°, four decades by 0.05°.
const SETTLED_DEG: f64 = 0.1;

/// Extra grid points around lightly damped poles (ζ < 0.5): ω_d (1 ± jζ), j ∈ {0, 1, 2, 4}.
fn pole_points(poles: &[Complex64]) -> Vec<f64> {
    let mut pts = Vec::new();
    for p in poles.iter().filter(|p| p.im > 0.0) {
        let zeta = -p.re / p.norm();
        if zeta.abs() < 0.5 {
            for j in [-4.0, -2.0, -1.0, 0.0, 1.0, 2.0, 4.0] {
                let w = p.im * (1.0 + j * zeta.abs());
                // never on an undamped pole itself, where |L| is infinite
                if w > 0.0 && (j != 0.0 || zeta != 0.0) {
                    pts.push(w);
                }
            }
        }
    }
    pts
}

/// ω itself, or just above it (by 1e-9 relative, a few times at most) where ω falls on an
/// undamped pole and |L(jω)| is infinite, with L(jω) there (each point evaluated once).
fn off_pole(ev: &impl LoopResponse, omega: f64) -> (f64, Complex64) {
    (0..4)
        .map(|k| omega * (1.0 + 1e-9 * k as f64))
        .map(|w| (w, ev.at(w)))
        .find(|(_, g)| finite(*g))
        .unwrap_or_else(|| (omega, ev.at(omega)))
}

/// Whether both parts of a value are finite.
fn finite(g: Complex64) -> bool {
    g.re.is_finite() && g.im.is_finite()
}

/// Root of `f(ln ω)` between ω0 and ω1 (rad/s), returned as ω.
fn brent_log(f: impl Fn(f64) -> f64, w0: f64, w1: f64) -> f64 {
    roots::brent(f, w0.ln(), w1.ln(), 1e-12).exp()
}

/// Wrap an angle (deg) into (−180, 180].
fn wrap_half_open(deg: f64) -> f64 {
    let w = deg.rem_euclid(360.0);
    if w > 180.0 {
        w - 360.0
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lti::siso;

    /// K_v = lim s·L(s): K of K ω²/(s (s² + 2ζω s + ω²)) over gains, resonances and dampings
    /// from a lightly damped 0.5 Hz to a stiff 500 Hz; none for two integrators or for none.
    #[test]
    fn the_velocity_gain_is_the_velocity_error_constant() {
        for (k, w, zeta) in [(3.7, 3.0, 0.2), (0.05, 3000.0, 0.7), (250.0, 30.0, 0.05)] {
            let a = [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, -w * w, -2.0 * zeta * w];
            let sys = siso(&a, &[0.0, 0.0, 1.0], &[k * w * w, 0.0, 0.0], 0.0);
            let got = margins(&sys).unwrap().velocity_gain_per_s.unwrap();
            assert!((got - k).abs() < 1e-7 * k, "{got} vs {k}");
        }
        let double = siso(&[0.0, 1.0, 0.0, 0.0], &[0.0, 1.0], &[1.0, 0.5], 0.0);
        assert_eq!(margins(&double).unwrap().velocity_gain_per_s, None);
        let none = siso(&[-1.0], &[1.0], &[2.0], 0.0);
        assert_eq!(margins(&none).unwrap().velocity_gain_per_s, None);
    }

    /// |L(0)| = 1 and |L| < 1 at every frequency above: 1/(s + 1), 4/(s² + 3s + 4) (|L|² =
    /// 16/((4 − ω²)² + 9ω²) < 1 for ω > 0) and the same with a gain just below 1. No gain
    /// crossing, so infinite (None) phase and delay margins, never π/ω at a rounding-noise
    /// crossing near 0 Hz (3e8 s before).
    #[test]
    fn a_magnitude_touching_0_db_at_dc_has_no_delay_margin() {
        let loops = [
            siso(&[-1.0], &[1.0], &[1.0], 0.0),
            siso(&[0.0, 1.0, -4.0, -3.0], &[0.0, 1.0], &[4.0, 0.0], 0.0),
            siso(
                &[0.0, 1.0, -4.0, -3.0],
                &[0.0, 1.0],
                &[4.0 - 1e-12, 0.0],
                0.0,
            ),
            siso(&[-2.0], &[1.0], &[2.0], 0.0),
        ];
        for sys in &loops {
            let m = margins(sys).unwrap();
            assert!(m.crossings.is_empty(), "{:?}", m.crossings);
            assert_eq!(
                (m.delay_margin_s, m.phase_margin_deg, m.gain_margin_db),
                (None, None, None)
            );
            assert!(!m.ill_conditioned);
        }
        // just above 1 at DC: a genuine crossing at ω = √(ε(2 + ε)) for 1/(s + 1)·(1 + ε),
        // with its delay margin (π − atan ω)/ω
        let eps = 1e-3;
        let m = margins(&siso(&[-1.0], &[1.0], &[1.0 + eps], 0.0)).unwrap();
        let w = (eps * (2.0 + eps)).sqrt();
        let dm = (PI - w.atan()) / w;
        let got = m.delay_margin_s.unwrap();
        assert!((got - dm).abs() < 1e-9 * dm, "{got} vs {dm}");
    }

    /// A loop whose input reaches no output (B = 0, C = 0, or the input drives a state the
    /// output does not see) has no margins: refused, as by `bode`; D ≠ 0 alone is a transfer.
    #[test]
    fn a_loop_without_transfer_is_refused() {
        let zero = [
            siso(&[-1.0], &[0.0], &[1.0], 0.0),
            siso(&[-1.0], &[1.0], &[0.0], 0.0),
            siso(&[-1.0, 0.0, 0.0, -2.0], &[1.0, 0.0], &[0.0, 1.0], 0.0),
            siso(&[0.0; 4], &[0.0, 0.0], &[0.0, 0.0], 0.0),
        ];
        for sys in &zero {
            assert!(matches!(margins(sys), Err(LtiError::NoTransfer)));
            let freqs = super::super::log_grid(0.01, 100.0, 20);
            let e = super::super::bode(sys, &freqs).unwrap_err();
            assert!(matches!(e, LtiError::NoTransfer));
            assert!(e.to_string().contains("no input reaches the output"), "{e}");
        }
        // D alone, and a chain that reaches the output in its second power of A
        let d_only = siso(&[-1.0], &[0.0], &[1.0], 0.5);
        assert!(super::super::bode(&d_only, &[1.0]).unwrap().mag_db[0].is_finite());
        let chain = siso(&[-1.0, 0.0, 1.0, -2.0], &[1.0, 0.0], &[0.0, 1.0], 0.0);
        assert!(margins(&chain).is_ok());
    }

    /// The error bound follows the conditioning: a well-scaled loop's margins are resolved far
    /// below 0.01, while the bound grows with the relative error η of L(jω) that a companion
    /// form of widely spread poles carries.
    #[test]
    fn the_error_bound_grows_with_the_conditioning() {
        // 2/((s + 1)(s + 2)(s + 3)) ·5: GM 20 log10(60/(2·5)) = 15.56 dB at ω = √11
        let well = siso(
            &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, -6.0, -11.0, -6.0],
            &[0.0, 0.0, 1.0],
            &[10.0, 0.0, 0.0],
            0.0,
        );
        let m = margins(&well).unwrap();
        assert!((m.gain_margin_db.unwrap() - 20.0 * 6f64.log10()).abs() < 1e-9);
        assert!(!m.ill_conditioned);
        assert!(m.crossings.iter().all(|c| c.margin_error_bound < 1e-10));
        let ev = FreqEvaluator::new(&well).unwrap();
        // the poles at 1e−3 … 1e5 rad/s in companion form: coefficients over 27 decades
        let poles = [1e-3, 1e-1, 1e1, 1e3, 1e5];
        let mut den = vec![1.0];
        for p in poles {
            den.push(0.0);
            for k in (1..den.len()).rev() {
                den[k] += p * den[k - 1];
            }
        }
        // den = s⁵ + a4 s⁴ + … + a0 (highest first): companion row −a0 … −a4
        let n = poles.len();
        let mut a = vec![0.0; n * n];
        for i in 0..n - 1 {
            a[i * n + i + 1] = 1.0;
        }
        for j in 0..n {
            a[(n - 1) * n + j] = -den[n - j];
        }
        let mut b = vec![0.0; n];
        b[n - 1] = 1.0;
        let mut c = vec![0.0; n];
        c[0] = den[n];
        let spread = FreqEvaluator::new(&siso(&a, &b, &c, 0.0)).unwrap();
        let (eta_well, eta_spread) = (
            ev.relative_error_bound(3.0),
            spread.relative_error_bound(3.0),
        );
        assert!(eta_well < 1e-13, "{eta_well}");
        assert!(eta_spread > 1e3 * eta_well, "{eta_spread} vs {eta_well}");
        // and it bounds the actual error against the product form Π p / Π (jω + p), or says
        // that no digit is left (η ≥ 1, where a first-order bound ends)
        for w in [1e-4, 1e-2, 1.0, 3.0, 1e2, 1e4, 1e6] {
            let s = Complex64::new(0.0, w);
            let exact = poles
                .iter()
                .fold(Complex64::new(den[n], 0.0), |g, p| g / (s + p));
            let err = (spread.at(w) - exact).norm() / exact.norm();
            let (eta, _) = spread.relative_error_and_log_slope(w);
            assert!(
                err <= eta || eta >= 1.0,
                "ω {w}: error {err:e} above the bound {eta:e}"
            );
        }
    }
}
