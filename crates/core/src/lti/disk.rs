//! Disk margins and sensitivity peaks of a SISO loop L(s) (docs/analysis.md#disk-margins).
//!
//! The disk margin with skew σ is α = 1 / max_ω |S(jω) + (σ − 1)/2|, S = 1/(1 + L) (Seiler,
//! Packard & Gahinet, "An introduction to disk margins", IEEE Control Systems Magazine 40(5),
//! 2020, §"Disk margin"; python-control's `disk_margins`, MATLAB's `diskmargin`): the loop stays
//! stable for every simultaneous gain and phase change f in the disk whose real-axis intercepts
//! are γ_min = (1 − α(1 − σ)/2)/(1 + α(1 + σ)/2) and γ_max = (1 + α(1 − σ)/2)/(1 − α(1 + σ)/2).
//! σ = 0 is the balanced disk (|S − T|/2), σ = 1 the sensitivity S (α = 1/M_s), σ = −1 the
//! complementary sensitivity T (α = 1/M_t). As for python-control, the margins presume the
//! nominal closed loop stable; [`super::Margins::closed_loop_stable`] says whether it is.
//!
//! The peak is found on a log grid over the loop's poles' span and refined by golden-section
//! search around the grid's largest value (a bounded number of steps).

use super::freqresp::LoopResponse;
use super::{eigenvalues, log_grid, FreqEvaluator, LtiError, SampledLoop, StateSpace};
use num_complex::Complex64;
use serde::Serialize;

/// Grid points per decade before the refinement.
const POINTS_PER_DECADE: f64 = 200.0;
/// Golden-section steps of the refinement: the bracket of two grid intervals shrinks by 0.618
/// per step, to 10⁻¹³ of a decade in 60.
const REFINE_STEPS: usize = 60;

/// A disk margin and the margins it guarantees.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiskMargin {
    /// The skew σ: 0 balanced, 1 the sensitivity S, −1 the complementary sensitivity T.
    pub skew: f64,
    /// The disk margin α.
    pub disk_margin: f64,
    /// The disk-based gain margin (dB): 20 log10 min(1/γ_min, γ_max); `None` infinite.
    pub gain_margin_db: Option<f64>,
    /// The disk-based phase margin (deg); `None` infinite.
    pub phase_margin_deg: Option<f64>,
    /// Where |S + (σ − 1)/2| peaks (Hz); `None` at infinite frequency.
    pub frequency_hz: Option<f64>,
}

/// The peak of |S| or |T| and where it lies.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Peak {
    /// The peak's value (absolute, not dB).
    pub value: f64,
    /// Its frequency (Hz); `None` at infinite frequency.
    pub frequency_hz: Option<f64>,
}

/// A loop's disk margin and its sensitivity peaks, from one frequency response.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiskMargins {
    /// The disk margin of the skew asked for.
    pub disk: DiskMargin,
    /// M_s = max |S| (the disk margin of skew 1 is 1/M_s).
    pub sensitivity_peak: Peak,
    /// M_t = max |T| (the disk margin of skew −1 is 1/M_t).
    pub complementary_sensitivity_peak: Peak,
}

/// The disk margin of the loop `sys` with skew `skew` (in [−1, 1]), and its sensitivity peaks
/// M_s = max |S| and M_t = max |T|.
///
/// # Errors
/// A model the frequency response cannot be evaluated for, or a skew outside [−1, 1].
pub fn disk_margins(sys: &StateSpace, skew: f64) -> Result<DiskMargins, LtiError> {
    check_skew(skew)?;
    disk_of(&Response::continuous(sys)?, skew)
}

/// [`disk_margins`] of the loop `sys` as a PLC closes it, sampled every `h` seconds with a
/// zero-order hold and `delay` samples of computation delay ([`super::sampled_margins`]): the
/// peaks over 0 < ω ≤ π/h of the sampled loop's frequency response.
///
/// # Errors
/// As [`disk_margins`] and [`SampledLoop::new`].
pub fn sampled_disk_margins(
    sys: &StateSpace,
    h: f64,
    delay: usize,
    skew: f64,
) -> Result<DiskMargins, LtiError> {
    check_skew(skew)?;
    disk_of(&Response::sampled(sys, h, delay)?, skew)
}

/// Refuse a skew outside [−1, 1].
fn check_skew(skew: f64) -> Result<(), LtiError> {
    if !(-1.0..=1.0).contains(&skew) {
        return Err(LtiError::NonFiniteResult {
            what: "the disk margin",
            at: format!("skew {skew}: it must lie in [-1, 1]"),
        });
    }
    Ok(())
}

/// The disk margin of skew `skew` and the sensitivity peaks of a loop's response.
fn disk_of(response: &Response<impl LoopResponse>, skew: f64) -> Result<DiskMargins, LtiError> {
    let (g, w) = response.peak(&|l: Complex64| (1.0 / (1.0 + l) + (skew - 1.0) / 2.0).norm())?;
    let peak_of = |f: &dyn Fn(Complex64) -> f64| -> Result<Peak, LtiError> {
        let (value, w) = response.peak(f)?;
        Ok(Peak {
            value,
            frequency_hz: w.map(|w| w / std::f64::consts::TAU),
        })
    };
    Ok(DiskMargins {
        disk: margins_of(1.0 / g, skew, w),
        sensitivity_peak: peak_of(&|l| (1.0 / (1.0 + l)).norm())?,
        complementary_sensitivity_peak: peak_of(&|l| (l / (1.0 + l)).norm())?,
    })
}

impl DiskMargin {
    /// The real-axis intercepts (γ_min, γ_max) of the disk of gain-and-phase changes the loop
    /// tolerates (see the module documentation); γ_max is negative or infinite where the disk
    /// holds every gain above γ_min.
    pub fn gains(&self) -> (f64, f64) {
        gains(self.disk_margin, self.skew)
    }
}

/// (γ_min, γ_max) of the disk of skew `skew` and size `alpha`.
fn gains(alpha: f64, skew: f64) -> (f64, f64) {
    let g_min = (1.0 - 0.5 * alpha * (1.0 - skew)) / (1.0 + 0.5 * alpha * (1.0 + skew));
    let g_max = (1.0 + 0.5 * alpha * (1.0 - skew)) / (1.0 - 0.5 * alpha * (1.0 + skew));
    (g_min, g_max)
}

/// The disk's margins for α, as python-control's `disk_margins` states them.
fn margins_of(alpha: f64, skew: f64, omega: Option<f64>) -> DiskMargin {
    let (g_min, g_max) = gains(alpha, skew);
    let gm = 20.0 * (1.0 / g_min).min(g_max).log10();
    let gain_margin_db = (gm.is_finite() && g_max > 0.0).then_some(gm);
    let cos = (1.0 + g_min * g_max) / (g_min + g_max);
    let phase_margin_deg = match (g_max.is_finite() && g_max > 0.0, cos.abs() < 1.0) {
        (false, _) => Some(90.0),
        (true, true) => Some(cos.acos().to_degrees()),
        (true, false) => None,
    };
    DiskMargin {
        skew,
        disk_margin: alpha,
        gain_margin_db,
        phase_margin_deg,
        frequency_hz: omega.map(|w| w / std::f64::consts::TAU),
    }
}

/// A loop's frequency response on the peak search's grid.
struct Response<R> {
    ev: R,
    /// The grid (rad/s) and L(jω) there.
    grid: Vec<f64>,
    values: Vec<Complex64>,
    /// L at infinite frequency (the feedthrough D of a continuous loop); `None` for a sampled
    /// loop, whose grid ends at the Nyquist frequency.
    at_infinity: Option<Complex64>,
}

impl Response<SampledLoop> {
    /// The sampled loop's L(e^{jωh}) on a log grid from a thousandth of the slowest pole (or a
    /// ten-thousandth of the Nyquist frequency) to the Nyquist frequency π/h, with the sampled
    /// closed loop's poles' frequencies |arg z|/h added.
    fn sampled(sys: &StateSpace, h: f64, delay: usize) -> Result<Self, LtiError> {
        let ev = FreqEvaluator::new(sys)?;
        let sampled = SampledLoop::new(sys, h, delay)?;
        let nyquist = sampled.nyquist_rad_per_s();
        let slowest = (ev.poles().iter().map(|p| p.norm()))
            .filter(|w| *w > 0.0)
            .fold(f64::INFINITY, f64::min);
        let lo = (slowest.min(1.0) / 1e3).min(nyquist * 1e-4);
        let points = ((nyquist / lo).log10() * POINTS_PER_DECADE) as usize + 2;
        let mut grid = log_grid(lo, nyquist, points);
        let closed = eigenvalues(&sampled.closed_loop_matrix()?)?;
        grid.extend(
            (closed.iter())
                .map(|z| z.arg().abs() / h)
                .filter(|w| *w > lo && *w < nyquist),
        );
        Ok(Response::on_grid(sampled, grid, None))
    }
}

impl<R: LoopResponse> Response<R> {
    /// `ev` evaluated on `grid` (rad/s, sorted here).
    fn on_grid(ev: R, mut grid: Vec<f64>, at_infinity: Option<Complex64>) -> Self {
        grid.sort_by(f64::total_cmp);
        grid.dedup();
        let values = ev.at_many(&grid);
        Response {
            ev,
            grid,
            values,
            at_infinity,
        }
    }
}

impl Response<FreqEvaluator> {
    /// L(jω) on a log grid from a thousandth of the slowest pole to a thousand times the fastest,
    /// with the open- and closed-loop poles' frequencies added: S and T peak near a lightly
    /// damped closed-loop pole, narrower than the grid's spacing where the damping is a few
    /// thousandths.
    fn continuous(sys: &StateSpace) -> Result<Self, LtiError> {
        let ev = FreqEvaluator::new(sys)?;
        let spans: Vec<f64> = (ev.poles().iter())
            .map(|p| p.norm())
            .filter(|w| *w > 0.0)
            .collect();
        let lo = spans.iter().copied().fold(f64::INFINITY, f64::min).min(1.0) / 1e3;
        let hi = spans.iter().copied().fold(0.0, f64::max).max(1.0) * 1e3;
        let points = ((hi / lo).log10() * POINTS_PER_DECADE) as usize + 2;
        let closed = sys.closed_loop_poles()?;
        let mut grid = log_grid(lo, hi, points);
        grid.extend(
            (ev.poles().iter().chain(&closed))
                .flat_map(|p| [p.norm(), p.im.abs()])
                .filter(|w| *w > lo && *w < hi),
        );
        let at_infinity = Complex64::new(sys.d[(0, 0)], 0.0);
        Ok(Response::on_grid(ev, grid, Some(at_infinity)))
    }
}

impl<R: LoopResponse> Response<R> {
    /// The largest value of `f(L(jω))` over ω ≥ 0 and where it lies (rad/s; `None` at ω → ∞):
    /// the grid's largest, refined by golden section between its neighbours.
    fn peak(&self, f: &dyn Fn(Complex64) -> f64) -> Result<(f64, Option<f64>), LtiError> {
        let finite = |v: f64| if v.is_finite() { v } else { 0.0 };
        let (k, best) = (self.values.iter().map(|&l| finite(f(l))).enumerate()).fold(
            (0, f64::NEG_INFINITY),
            |b, (k, v)| if v > b.1 { (k, v) } else { b },
        );
        if !best.is_finite() {
            return Err(LtiError::NonFiniteResult {
                what: "the sensitivity",
                at: "every frequency".into(),
            });
        }
        let grid = &self.grid;
        let at = |w: f64| finite(f(self.ev.at(w)));
        let (w, v) = golden(
            &at,
            grid[k.saturating_sub(1)],
            grid[(k + 1).min(grid.len() - 1)],
        );
        let (w, v) = if v >= best { (w, v) } else { (grid[k], best) };
        let at_infinity = self.at_infinity.map_or(f64::NEG_INFINITY, f);
        Ok(if at_infinity > v {
            (at_infinity, None)
        } else {
            (v, Some(w))
        })
    }
}

/// The largest value of `f` on [a, b] by golden-section search in log ω.
fn golden(f: &impl Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (a.ln(), b.ln());
    let g = |x: f64| f(x.exp());
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (g(c), g(d));
    for _ in 0..REFINE_STEPS {
        if fc > fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - r * (b - a);
            fc = g(c);
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + r * (b - a);
            fd = g(d);
        }
    }
    if fc > fd {
        (c.exp(), fc)
    } else {
        (d.exp(), fd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// L(s) = k/(s(s+1)): S = s(s+1)/(s² + s + k); for k = 1, |S(jω)|² = ω²(1+ω²)/((1−ω²)² + ω²).
    fn loop_k(k: f64) -> StateSpace {
        StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, -1.0]),
            DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
            DMatrix::from_row_slice(1, 2, &[k, 0.0]),
            DMatrix::zeros(1, 1),
        )
        .unwrap()
    }

    #[test]
    fn the_sensitivity_peak_is_the_analytic_one() {
        // h(u) = u(1+u)/(u² − u + 1), u = ω², peaks where −2u² + 2u + 1 = 0: u = (1 + √3)/2
        let u = (1.0 + 3f64.sqrt()) / 2.0;
        let want = (u * (1.0 + u) / (u * u - u + 1.0)).sqrt();
        let ms = disk_margins(&loop_k(1.0), 0.0).unwrap().sensitivity_peak;
        assert!(
            (ms.value - want).abs() < 1e-12 * want,
            "{} against {want}",
            ms.value
        );
        let hz = ms.frequency_hz.unwrap();
        assert!(
            (hz * std::f64::consts::TAU - u.sqrt()).abs() < 1e-6,
            "{hz} Hz"
        );
        // skew 1 is the sensitivity: α = 1/M_s
        let d = disk_margins(&loop_k(1.0), 1.0).unwrap().disk;
        assert!((d.disk_margin - 1.0 / ms.value).abs() < 1e-12);
        assert!(disk_margins(&loop_k(1.0), 2.0).is_err());
    }
}
