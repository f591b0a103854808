//! Frequency response C(sI − A)⁻¹B + D of a SISO model, by a solve (docs/analysis.md#frequency-response).
//!
//! Setup once: balance A (Parlett–Reinsch) and take its real Schur form T = Qᵀ A Q (orthogonal
//! Q, so no conditioning is lost). Each frequency then costs one complex back-substitution
//! through the quasi-triangular T (1×1 and 2×2 blocks): O(n²/2), no transfer-function
//! polynomial, no inverse. The poles come with the factorisation.

use super::poles::BalancedSchur;
use super::{LtiError, StateSpace};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Pre-factored SISO model for fast evaluation at many complex frequencies.
#[derive(Debug, Clone)]
pub struct FreqEvaluator {
    /// Order n.
    n: usize,
    /// Quasi-triangular Schur factor of the balanced A, row-major n × n.
    t: Vec<f64>,
    /// Qᵀ D⁻¹ B.
    b: Vec<f64>,
    /// Qᵀ D Cᵀ.
    c: Vec<f64>,
    /// Feedthrough.
    d: f64,
    /// Eigenvalues of A, sorted by modulus.
    poles: Vec<Complex64>,
    /// Poles at the origin (integrators), decided against rounding.
    integrators: usize,
}

/// Largest order solved in a stack buffer (larger models use the heap).
const STACK_ORDER: usize = 16;
/// Frequencies evaluated side by side by [`FreqEvaluator::at_many`].
const LANES: usize = 4;

impl FreqEvaluator {
    /// Prepare a SISO model for evaluation.
    pub fn new(sys: &StateSpace) -> Result<Self, LtiError> {
        sys.require_siso()?;
        let schur = BalancedSchur::new(&sys.a)?;
        let n = schur.t.nrows();
        Ok(FreqEvaluator {
            n,
            t: (0..n * n).map(|k| schur.t[(k / n, k % n)]).collect(),
            b: schur.input(&sys.b.column(0).into_owned()),
            c: schur.output(&sys.c.row(0).transpose()),
            d: sys.d[(0, 0)],
            integrators: schur.integrators(),
            poles: schur.eigenvalues,
        })
    }

    /// Eigenvalues of A (the open-loop poles), sorted by modulus.
    pub fn poles(&self) -> &[Complex64] {
        &self.poles
    }

    /// The number of poles at the origin (integrators): the smallest eigenvalues that are zero
    /// within rounding (docs/analysis.md#margins).
    pub fn integrators(&self) -> usize {
        self.integrators
    }

    /// G(s) at a complex frequency s (rad/s). At an eigenvalue of A the result is infinite.
    pub fn eval(&self, s: Complex64) -> Complex64 {
        self.eval_lanes([s])[0]
    }

    /// G(jω) at many angular frequencies ω (rad/s), the same values as [`at`](Self::at) bit
    /// for bit, several frequencies at a time: their back-substitutions are independent, so
    /// interleaving them hides the latency of each one's chain of dependent operations.
    pub fn at_many(&self, omega: &[f64]) -> Vec<Complex64> {
        let mut out = Vec::with_capacity(omega.len());
        for chunk in omega.chunks(LANES) {
            let mut s = [Complex64::new(0.0, chunk[chunk.len() - 1]); LANES];
            for (s, &w) in s.iter_mut().zip(chunk) {
                s.im = w;
            }
            out.extend_from_slice(&self.eval_lanes(s)[..chunk.len()]);
        }
        out
    }

    /// G at `L` complex frequencies, each by the operations of a single evaluation.
    fn eval_lanes<const L: usize>(&self, s: [Complex64; L]) -> [Complex64; L] {
        let zero = [Complex64::new(0.0, 0.0); L];
        if self.n <= STACK_ORDER {
            let mut z = [zero; STACK_ORDER];
            self.solve(s, &mut z[..self.n])
        } else {
            self.solve(s, &mut vec![zero; self.n])
        }
    }

    /// Back-substitution of (sI − T) z = b through the 1×1 and 2×2 diagonal blocks of T, then
    /// c·z + d, for `L` frequencies side by side (lane l of every array belongs to `s[l]`; no
    /// operation mixes lanes). `z` (length n) is the work buffer.
    fn solve<const L: usize>(&self, s: [Complex64; L], z: &mut [[Complex64; L]]) -> [Complex64; L] {
        let n = self.n;
        let t = |i: usize, j: usize| self.t[i * n + j];
        // b_i + Σ_{j ≥ from} T_ij z_j, summed by increasing j
        let rhs = |z: &[[Complex64; L]], i: usize, from: usize| {
            let row = &self.t[i * n + from..(i + 1) * n];
            let mut acc = [Complex64::new(self.b[i], 0.0); L];
            for (&tij, zj) in row.iter().zip(&z[from..]) {
                for (a, &zjl) in acc.iter_mut().zip(zj) {
                    *a += zjl * tij;
                }
            }
            acc
        };
        let mut k = n;
        while k > 0 {
            let i = k - 1;
            if i > 0 && t(i, i - 1) != 0.0 {
                // 2×2 block on rows i−1, i
                let (r1, r2) = (rhs(z, i - 1, k), rhs(z, i, k));
                let (t12, t21) = (t(i - 1, i), t(i, i - 1));
                for l in 0..L {
                    let (a11, a22) = (s[l] - t(i - 1, i - 1), s[l] - t(i, i));
                    let inv_det = (a11 * a22 - t12 * t21).inv();
                    z[i - 1][l] = (a22 * r1[l] + r2[l] * t12) * inv_det;
                    z[i][l] = (r1[l] * t21 + a11 * r2[l]) * inv_det;
                }
                k -= 2;
            } else {
                let r = rhs(z, i, k);
                for l in 0..L {
                    z[i][l] = r[l] / (s[l] - t(i, i));
                }
                k -= 1;
            }
        }
        let mut y = [Complex64::new(0.0, 0.0); L];
        for (&c, zi) in self.c.iter().zip(z.iter()) {
            for (y, &zil) in y.iter_mut().zip(zi) {
                *y += zil * c;
            }
        }
        y.map(|y| y + self.d)
    }

    /// G(jω) at an angular frequency ω (rad/s).
    pub fn at(&self, omega: f64) -> Complex64 {
        self.eval(Complex64::new(0.0, omega))
    }

    /// A first-order bound η on the relative error of G(jω) as evaluated in double precision,
    /// and the logarithmic slope d ln G/dω there (docs/analysis.md#conditioning).
    ///
    /// G − d = cᵀ M⁻¹ b with M = jωI − T is a bilinear form: a perturbation δM changes it by
    /// −wᵀ δM z (z = M⁻¹ b, wᵀ = cᵀ M⁻¹), so its normwise condition is ‖w‖ ‖z‖ ‖M‖ / |G|
    /// (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., 2002, §7.1, applied to
    /// a bilinear form). The Schur factorisation of the balanced A and the back-substitution are
    /// backward stable with ‖δM‖ ≲ n ε (‖T‖_F + ω) (Golub & Van Loan, *Matrix Computations*,
    /// 4th ed., §7.5.6), and the rotation of b and c adds n ε ‖b‖ and n ε ‖c‖:
    /// η = n ε (‖w‖ ‖z‖ (‖T‖_F + ω) + ‖w‖ ‖b‖ + ‖c‖ ‖z‖) / |G|. Infinite on a pole.
    pub fn relative_error_and_log_slope(&self, omega: f64) -> (f64, Complex64) {
        let n = self.n;
        let s = Complex64::new(0.0, omega);
        let m = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            let diag = if i == j { s } else { Complex64::new(0.0, 0.0) };
            diag - self.t[i * n + j]
        });
        let col = |v: &[f64]| nalgebra::DVector::from_iterator(n, v.iter().map(|&x| x.into()));
        let (b, c) = (col(&self.b), col(&self.c));
        let (Some(z), Some(w)) = (m.clone().lu().solve(&b), m.transpose().lu().solve(&c)) else {
            return (f64::INFINITY, Complex64::new(f64::NAN, f64::NAN));
        };
        let g = c.dot(&z) + self.d;
        // dG/dω = j dG/ds, dG/ds = −wᵀ z
        let slope = -Complex64::i() * w.dot(&z) / g;
        let t_norm = self.t.iter().map(|x| x * x).sum::<f64>().sqrt();
        let (nw, nz) = (w.norm(), z.norm());
        let cond = nw * nz * (t_norm + omega) + nw * b.norm() + c.norm() * nz;
        let eta = n as f64 * f64::EPSILON * cond / g.norm();
        (eta, slope)
    }

    /// The first-order bound on the relative error of G(jω)
    /// ([`relative_error_and_log_slope`](Self::relative_error_and_log_slope)).
    pub fn relative_error_bound(&self, omega: f64) -> f64 {
        self.relative_error_and_log_slope(omega).0
    }
}

/// Bode data: frequency (Hz), magnitude (dB) and unwrapped phase (deg).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Bode {
    /// Frequencies (Hz).
    pub freq_hz: Vec<f64>,
    /// Magnitude 20 log10 |G| (dB).
    pub mag_db: Vec<f64>,
    /// Unwrapped phase (deg), anchored at the low-frequency asymptote.
    pub phase_deg: Vec<f64>,
}

/// `points` frequencies spaced logarithmically from `from` to `to` inclusive.
pub fn log_grid(from: f64, to: f64, points: usize) -> Vec<f64> {
    let points = points.max(2);
    let (l0, l1) = (from.ln(), to.ln());
    (0..points)
        .map(|i| (l0 + (l1 - l0) * i as f64 / (points - 1) as f64).exp())
        .collect()
}

/// Bode data of a SISO model at the given frequencies (Hz, increasing). The phase is unwrapped
/// along the grid and anchored at the low-frequency asymptote: −90° per integrator, −180° more
/// for a negative low-frequency gain. The grid must be fine enough that the phase moves less
/// than 180° between neighbours (use `margins` for a self-refining grid).
pub fn bode(sys: &StateSpace, freq_hz: &[f64]) -> Result<Bode, LtiError> {
    let ev = FreqEvaluator::new(sys)?;
    sys.require_transfer()?;
    let integrators = ev.integrators();
    let omega: Vec<f64> = freq_hz.iter().map(|f| 2.0 * PI * f).collect();
    let values = ev.at_many(&omega);
    if let Some((f, _)) = freq_hz
        .iter()
        .zip(&values)
        .find(|(_, v)| !(v.re.is_finite() && v.im.is_finite()))
    {
        return Err(LtiError::NonFiniteResult {
            what: "the frequency response (dB)",
            at: format!("{} Hz", crate::units::readable(*f)),
        });
    }
    let phase = match freq_hz.first() {
        Some(&f0) => unwrap_anchored(&ev, &values, 2.0 * PI * f0, integrators),
        None => Vec::new(),
    };
    Ok(Bode {
        freq_hz: freq_hz.to_vec(),
        mag_db: values.iter().map(|g| 20.0 * g.norm().log10()).collect(),
        phase_deg: phase,
    })
}

/// Unwrapped phase (deg) of successive values, anchored at the first point (angular frequency
/// `omega0`) to the asymptote of a system with `integrators` poles at the origin.
pub(crate) fn unwrap_anchored(
    ev: &FreqEvaluator,
    values: &[Complex64],
    omega0: f64,
    integrators: usize,
) -> Vec<f64> {
    unwrap_from(values, low_frequency_asymptote(ev, omega0, integrators))
}

/// The phase (deg) a loop with `integrators` poles at the origin approaches at low frequency:
/// −90° per integrator, −180° more for a negative low-frequency gain, its sign read from the
/// real-axis value G(σ)·σ^k at σ = `omega0`.
pub(crate) fn low_frequency_asymptote(ev: &FreqEvaluator, omega0: f64, integrators: usize) -> f64 {
    let real_gain = ev.eval(Complex64::new(omega0, 0.0)).re;
    -90.0 * integrators as f64 - if real_gain < 0.0 { 180.0 } else { 0.0 }
}

/// Unwrapped phase (deg) of successive values, the first on the branch nearest `asymptote`.
pub fn unwrap_from(values: &[Complex64], asymptote: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(values.len());
    let Some(first) = values.first() else {
        return out;
    };
    let mut prev = nearest_branch(first.arg().to_degrees(), asymptote);
    out.push(prev);
    for g in &values[1..] {
        prev = nearest_branch(g.arg().to_degrees(), prev);
        out.push(prev);
    }
    out
}

/// A loop's frequency response L(jω) as the margin and disk analyses read it: a continuous
/// model's ([`FreqEvaluator`]) or a sampled loop's ([`super::SampledLoop`]).
pub(crate) trait LoopResponse {
    /// L at the angular frequency ω (rad/s).
    fn at(&self, omega: f64) -> Complex64;
    /// L at many angular frequencies (rad/s).
    fn at_many(&self, omega: &[f64]) -> Vec<Complex64> {
        omega.iter().map(|&w| self.at(w)).collect()
    }
    /// A first-order bound on the relative error of L(ω) as evaluated, and d ln L/dω
    /// (docs/analysis.md#conditioning).
    fn relative_error_and_log_slope(&self, omega: f64) -> (f64, Complex64);
}

impl LoopResponse for FreqEvaluator {
    fn at(&self, omega: f64) -> Complex64 {
        FreqEvaluator::at(self, omega)
    }
    fn at_many(&self, omega: &[f64]) -> Vec<Complex64> {
        FreqEvaluator::at_many(self, omega)
    }
    fn relative_error_and_log_slope(&self, omega: f64) -> (f64, Complex64) {
        FreqEvaluator::relative_error_and_log_slope(self, omega)
    }
}

/// The angle `raw + 360 k` (deg) nearest to `reference`.
pub(crate) fn nearest_branch(raw: f64, reference: f64) -> f64 {
    raw + 360.0 * ((reference - raw) / 360.0).round()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lti::siso;

    #[test]
    fn matches_direct_complex_evaluation() {
        // G(s) = (s + 3) / (s³ + 2 s² + 5 s + 1) in controllable canonical form, plus D = 0.5
        let sys = siso(
            &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, -1.0, -5.0, -2.0],
            &[0.0, 0.0, 1.0],
            &[3.0, 1.0, 0.0],
            0.5,
        );
        let ev = FreqEvaluator::new(&sys).unwrap();
        for &w in &[1e-3, 0.1, 1.0, 2.2, 10.0, 1e3] {
            let s = Complex64::new(0.0, w);
            let direct = (s + 3.0) / (s * s * s + 2.0 * s * s + 5.0 * s + 1.0) + 0.5;
            let g = ev.at(w);
            assert!(
                (g - direct).norm() < 1e-12 * direct.norm().max(1.0),
                "w={w}: {g} vs {direct}"
            );
        }
    }

    /// Side by side or one at a time, every frequency gets the same value to the last bit, for
    /// any count (partial last chunk included) and through 1×1 and 2×2 Schur blocks.
    #[test]
    fn many_frequencies_equal_one_at_a_time_bit_for_bit() {
        // (s + 3) / ((s + 0.5)(s² + 0.2 s + 4)(s + 7)) + 1/4 in companion form (the
        // denominator s⁴ + 7.7 s³ + 9 s² + 30.7 s + 14): two real poles and a complex pair
        let sys = siso(
            &[
                0.0, 1.0, 0.0, 0.0, //
                0.0, 0.0, 1.0, 0.0, //
                0.0, 0.0, 0.0, 1.0, //
                -14.0, -30.7, -9.0, -7.7,
            ],
            &[0.0, 0.0, 0.0, 1.0],
            &[3.0, 1.0, 0.0, 0.0],
            0.25,
        );
        let ev = FreqEvaluator::new(&sys).unwrap();
        for count in [2, 3, 4, 5, 9, 17] {
            let omega = log_grid(1e-3, 1e3, count);
            let many = ev.at_many(&omega);
            assert_eq!(many.len(), omega.len());
            for (g, &w) in many.iter().zip(&omega) {
                let one = ev.at(w);
                assert_eq!(
                    (g.re.to_bits(), g.im.to_bits()),
                    (one.re.to_bits(), one.im.to_bits())
                );
            }
        }
        // and the value is the transfer function's
        let s = Complex64::new(0.0, 2.0);
        let direct = (s + 3.0) / ((s + 0.5) * (s * s + 0.2 * s + 4.0) * (s + 7.0)) + 0.25;
        assert!((ev.at_many(&[2.0])[0] - direct).norm() < 1e-12 * direct.norm());
    }

    #[test]
    fn integrator_phase_anchored_at_minus_90() {
        // G = 2 / (s (s + 1))
        let sys = siso(&[0.0, 1.0, 0.0, -1.0], &[0.0, 1.0], &[2.0, 0.0], 0.0);
        let f = log_grid(1e-4, 1e3, 200);
        let b = bode(&sys, &f).unwrap();
        assert!((b.phase_deg[0] + 90.0).abs() < 0.1, "{}", b.phase_deg[0]);
        assert!((b.phase_deg.last().unwrap() + 180.0).abs() < 0.1);
        // magnitude at w = 1 rad/s: 2/√2
        let w1 = bode(&sys, &[1.0 / (2.0 * PI)]).unwrap();
        assert!((w1.mag_db[0] - 20.0 * (2f64 / 2f64.sqrt()).log10()).abs() < 1e-10);
        assert!((w1.phase_deg[0] + 135.0).abs() < 1e-10);
    }

    #[test]
    fn negative_gain_anchored_at_minus_180() {
        let sys = siso(&[-1.0], &[1.0], &[-1.0], 0.0);
        let b = bode(&sys, &log_grid(1e-5, 1e3, 100)).unwrap();
        assert!(
            (b.phase_deg[0] + 180.0).abs() < 0.1,
            "{:?}",
            &b.phase_deg[..3]
        );
        assert!((b.phase_deg.last().unwrap() + 270.0).abs() < 0.1);
    }
}
