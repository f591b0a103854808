//! The loop as a PLC runs it: sampled-data margins (docs/analysis.md#sampled-data-margins).
//!
//! The PLC reads the position every h seconds, computes its command and applies it d samples
//! later, held until the next (a zero-order hold). Between samples the plant is exact: its
//! zero-order-hold equivalent Φ = e^{Ah}, Γ = ∫₀ʰ e^{As} ds B ([`super::Zoh`]; Franklin, Powell
//! & Workman, *Digital Control of Dynamic Systems*, 3rd ed., 1998, §4.3.3), so the loop the PLC
//! closes is L(z) = (C (zI − Φ)⁻¹ Γ + D) z^{−d}, with the frequency response L(e^{jωh}) for
//! 0 < ω ≤ π/h. Its gain, phase, delay and disk margins are read as the continuous loop's are
//! (the same refined grid and crossing search, [`super::margins`]), up to the Nyquist
//! frequency π/h; the closed loop's stability from the eigenvalues of the sampled closed loop,
//! the delay's d states included, against the unit circle.

use super::freqresp::{low_frequency_asymptote, FreqEvaluator, LoopResponse};
use super::margins::{frequency_range, seeds, summarise, velocity_gain, Grid};
use super::{eigenvalues, CrossingKind, LtiError, Margins, Stability, StateSpace, Zoh};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Largest computation delay (samples) a sampled loop may have: each is a state of its model.
pub const MAX_DELAY_SAMPLES: usize = 100;

/// A SISO loop sampled with a zero-order hold every `h` seconds and delayed `d` samples.
#[derive(Debug, Clone)]
pub struct SampledLoop {
    /// Sample period h (s).
    h: f64,
    /// Computation delay d (samples).
    delay: usize,
    /// Φ = e^{Ah}.
    phi: DMatrix<f64>,
    /// Γ = ∫₀ʰ e^{As} ds B.
    gamma: DVector<f64>,
    /// Cᵀ.
    c: DVector<f64>,
    /// D.
    d: f64,
}

impl SampledLoop {
    /// The loop `sys` sampled every `h` seconds (> 0) with `delay` samples of computation delay.
    ///
    /// # Errors
    /// A model that is not SISO, a step that is not finite and positive, or a delay above
    /// [`MAX_DELAY_SAMPLES`].
    pub fn new(sys: &StateSpace, h: f64, delay: usize) -> Result<SampledLoop, LtiError> {
        sys.require_siso()?;
        if delay > MAX_DELAY_SAMPLES {
            return Err(LtiError::Dimension(format!(
                "a computation delay of {delay} samples: pumpcyl models at most {MAX_DELAY_SAMPLES}"
            )));
        }
        let zoh = Zoh::new(&sys.a, &sys.b, h)?;
        Ok(SampledLoop {
            h,
            delay,
            gamma: zoh.gamma.column(0).into_owned(),
            phi: zoh.phi,
            c: sys.c.row(0).transpose(),
            d: sys.d[(0, 0)],
        })
    }

    /// The Nyquist frequency π/h (rad/s): the response above it repeats the one below.
    pub fn nyquist_rad_per_s(&self) -> f64 {
        PI / self.h
    }

    /// (zI − Φ) at z = e^{jωh}, and z.
    fn resolvent(&self, omega: f64) -> (DMatrix<Complex64>, Complex64) {
        let z = Complex64::from_polar(1.0, omega * self.h);
        let n = self.phi.nrows();
        let m = DMatrix::from_fn(n, n, |i, j| {
            let diag = if i == j { z } else { Complex64::new(0.0, 0.0) };
            diag - self.phi[(i, j)]
        });
        (m, z)
    }

    /// z^{−d} at z = e^{jωh}.
    fn delay_factor(&self, omega: f64) -> Complex64 {
        Complex64::from_polar(1.0, -omega * self.h * self.delay as f64)
    }

    /// The closed loop's state matrix under unity negative feedback, u = r − y, sampled: the
    /// plant's n states and the delay line's d (the commands computed and not yet applied).
    pub fn closed_loop_matrix(&self) -> Result<DMatrix<f64>, LtiError> {
        let (n, d) = (self.phi.nrows(), self.delay);
        if d == 0 {
            let den = 1.0 + self.d;
            if den.abs() < f64::EPSILON {
                return Err(LtiError::IllPosedFeedback);
            }
            return Ok(&self.phi - &self.gamma * self.c.transpose() / den);
        }
        let mut a = DMatrix::zeros(n + d, n + d);
        a.view_mut((0, 0), (n, n)).copy_from(&self.phi);
        // the applied command is the delay line's last entry v_d: x⁺ = Φ x + Γ v_d; the PLC's
        // new command u = −(Cx + D v_d) enters v_1; v_{i+1}⁺ = v_i
        a.view_mut((0, n + d - 1), (n, 1)).copy_from(&self.gamma);
        for j in 0..n {
            a[(n, j)] = -self.c[j];
        }
        a[(n, n + d - 1)] -= self.d;
        for i in 1..d {
            a[(n + i, n + i - 1)] = 1.0;
        }
        Ok(a)
    }

    /// The stability of the sampled closed loop: every eigenvalue inside the unit circle by more
    /// than its rounding radius ((n + d)·ε·‖A_cl‖₁ · 100) is stable; one outside by more is
    /// unstable; one on it within that radius is undecided (at z = 1, an integrator).
    pub fn closed_loop_stability(&self) -> Result<Stability, LtiError> {
        let a = self.closed_loop_matrix()?;
        let poles = eigenvalues(&a)?;
        let norm1 = (0..a.ncols())
            .map(|j| a.column(j).iter().map(|v| v.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        let radius = 100.0 * a.nrows() as f64 * f64::EPSILON * norm1.max(1.0);
        let on = |p: &Complex64| (p.norm() - 1.0).abs() <= radius;
        Ok(if poles.iter().any(|p| p.norm() > 1.0 + radius) {
            Stability::Unstable
        } else if poles.iter().any(|p| on(p) && (p - 1.0).norm() > radius) {
            Stability::Undecided
        } else if poles.iter().any(on) {
            Stability::Integrator
        } else {
            Stability::Stable
        })
    }
}

impl SampledLoop {
    /// L(e^{jωh}) at the angular frequency ω (rad/s): the sampled loop's frequency response.
    pub fn frequency_response(&self, omega: f64) -> Complex64 {
        let (m, _) = self.resolvent(omega);
        let rhs = self.gamma.map(Complex64::from);
        match m.lu().solve(&rhs) {
            Some(x) => (self.c.map(Complex64::from).dot(&x) + self.d) * self.delay_factor(omega),
            None => Complex64::new(f64::INFINITY, f64::INFINITY),
        }
    }
}

impl LoopResponse for SampledLoop {
    fn at(&self, omega: f64) -> Complex64 {
        self.frequency_response(omega)
    }

    /// As [`FreqEvaluator::relative_error_and_log_slope`] with M = zI − Φ: G = cᵀ M⁻¹ Γ + D,
    /// dG/dz = −wᵀ M⁻¹ Γ (wᵀ = cᵀ M⁻¹), dz/dω = j h z and the delay's −j h d.
    fn relative_error_and_log_slope(&self, omega: f64) -> (f64, Complex64) {
        let (m, z) = self.resolvent(omega);
        let n = self.phi.nrows();
        let (b, c) = (self.gamma.map(Complex64::from), self.c.map(Complex64::from));
        let (Some(x), Some(w)) = (m.clone().lu().solve(&b), m.transpose().lu().solve(&c)) else {
            return (f64::INFINITY, Complex64::new(f64::NAN, f64::NAN));
        };
        let g = c.dot(&x) + self.d;
        let jh = Complex64::new(0.0, self.h);
        let slope = -w.dot(&x) * jh * z / g - jh * self.delay as f64;
        let phi_norm = self.phi.norm();
        let (nw, nx) = (w.norm(), x.norm());
        let cond = nw * nx * (phi_norm + 1.0) + nw * b.norm() + c.norm() * nx;
        (n as f64 * f64::EPSILON * cond / g.norm(), slope)
    }
}

/// The gain, phase and delay margins of the loop `sys` as a PLC closes it, sampled every `h`
/// seconds with a zero-order hold and `delay` samples of computation delay (see the module
/// documentation): crossings up to the Nyquist frequency π/h, stability from the sampled
/// closed loop's eigenvalues. A phase crossing at the Nyquist frequency itself, where the
/// response is real, is reported there.
///
/// # Errors
/// As [`SampledLoop::new`] and [`super::margins`].
pub fn sampled_margins(sys: &StateSpace, h: f64, delay: usize) -> Result<Margins, LtiError> {
    let ev = FreqEvaluator::new(sys)?;
    sys.require_transfer()?;
    let sampled = SampledLoop::new(sys, h, delay)?;
    let (grid, integrators) = sampled_grid(&ev, &sampled, sys.d[(0, 0)]);
    let mut crossings = grid.crossings(&sampled);
    let nyquist = sampled.nyquist_rad_per_s() / (2.0 * PI);
    if !(crossings.iter())
        .any(|c| c.kind == CrossingKind::Phase && c.frequency_hz >= nyquist * (1.0 - 1e-9))
    {
        crossings.extend(grid.crossing_at_end(&sampled));
    }
    let mut m = summarise(crossings, sampled.closed_loop_stability()?, integrators);
    m.velocity_gain_per_s = (integrators == 1).then(|| velocity_gain(&ev));
    if let Some(c) = m.crossings.iter().find(|c| !c.margin.is_finite()) {
        return Err(LtiError::NonFiniteResult {
            what: "the sampled margins",
            at: format!("{} Hz", crate::units::readable(c.frequency_hz)),
        });
    }
    Ok(m)
}

/// The sampled loop's refined grid from the continuous loop's low end (or a ten-thousandth of the
/// Nyquist frequency, the lower) to the Nyquist frequency, seeded at the continuous poles'
/// aliases e^{ph} read back as ln(e^{ph})/h; and the loop's integrator count.
fn sampled_grid(ev: &FreqEvaluator, sampled: &SampledLoop, d: f64) -> (Grid, usize) {
    let (integrators, nyquist) = (ev.integrators(), sampled.nyquist_rad_per_s());
    let (lo, _) = frequency_range(ev, ev.poles(), integrators, d);
    let lo = lo.min(nyquist * 1e-4);
    let aliased: Vec<Complex64> = (ev.poles().iter())
        .map(|p| Complex64::new(p.re, aliased(p.im, sampled.h)))
        .collect();
    let mut points = seeds(&aliased, lo, nyquist);
    points.push(nyquist);
    let asymptote = low_frequency_asymptote(ev, lo, integrators);
    (Grid::build(sampled, points, asymptote), integrators)
}

/// The frequency (rad/s, in [−π/h, π/h]) a continuous frequency `omega` aliases to at step `h`.
fn aliased(omega: f64, h: f64) -> f64 {
    let turn = omega * h;
    (turn - (turn / (2.0 * PI)).round() * 2.0 * PI) / h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lti::siso;

    /// L(s) = k/s sampled with a hold: L(z) = k h/(z − 1) z^{−d}. With d = 0 the closed-loop pole
    /// is 1 − k h, stable for k h < 2, the phase crossing at Nyquist (z = −1, |L| = k h/2): GM =
    /// −20 log10(k h / 2). With d = 1 the characteristic polynomial z² − z + k h is stable for
    /// k h < 1: GM = −20 log10(k h) at the crossing where the phase is −180°, ω h = π/3.
    #[test]
    fn an_integrator_sampled_has_the_analytic_margins() {
        let (k, h) = (10.0, 0.01);
        let sys = siso(&[0.0], &[1.0], &[k], 0.0);
        let m0 = sampled_margins(&sys, h, 0).unwrap();
        let gm0 = m0.gain_margin_db.unwrap();
        let want0 = -20.0 * (k * h / 2.0f64).log10();
        assert!((gm0 - want0).abs() < 1e-9, "{gm0} vs {want0}");
        assert!((m0.phase_crossover_hz.unwrap() - 0.5 / h).abs() < 1e-9);
        assert!(m0.closed_loop_stable);
        let m1 = sampled_margins(&sys, h, 1).unwrap();
        // phase of k h e^{-jωh}/(e^{jωh} − 1) = −ωh − (π/2 + ωh/2) = −π at ωh = π/3
        let gm1 = m1.gain_margin_db.unwrap();
        let w = PI / 3.0 / h;
        let mag = k * h / (2.0 * (w * h / 2.0).sin());
        assert!((gm1 + 20.0 * mag.log10()).abs() < 1e-9, "{gm1}");
        assert!((m1.phase_crossover_hz.unwrap() - w / (2.0 * PI)).abs() < 1e-9);
        // gain crossing: |L| = 1 at 2 sin(ωh/2) = k h; PM = π/2 − 3ωh/2
        let wc = 2.0 * (k * h / 2.0f64).asin() / h;
        let pm = (90.0 - 1.5 * (wc * h).to_degrees()) - 0.0;
        assert!((m1.phase_margin_deg.unwrap() - pm).abs() < 1e-9);
        // the gain that makes it unstable: k h > 1
        let fast = siso(&[0.0], &[1.0], &[150.0], 0.0);
        let m = sampled_margins(&fast, h, 1).unwrap();
        assert!(!m.closed_loop_stable);
        assert!(m.gain_margin_db.unwrap() < 0.0);
    }

    #[test]
    fn the_delay_line_is_bounded() {
        let sys = siso(&[0.0], &[1.0], &[1.0], 0.0);
        assert!(SampledLoop::new(&sys, 0.01, MAX_DELAY_SAMPLES + 1).is_err());
        assert!(SampledLoop::new(&sys, 0.0, 1).is_err());
    }
}
