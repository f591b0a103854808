//! Frequency response C(sI − A)⁻¹B + D of a SISO model, by a solve (SPEC §4).
//!
//! Setup once: balance A (Parlett–Reinsch), reduce it to upper Hessenberg form H = Qᵀ A Q.
//! Then each frequency costs one O(n²) complex Hessenberg solve with partial pivoting — no
//! transfer-function polynomial, no inverse.

use super::{LtiError, StateSpace};
use nalgebra::linalg::balancing::balance_parlett_reinsch;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Pre-factored SISO model for fast evaluation at many complex frequencies.
#[derive(Debug, Clone)]
pub struct FreqEvaluator {
    /// Upper Hessenberg form of the balanced A.
    h: DMatrix<f64>,
    /// Qᵀ D⁻¹ B.
    b: DVector<f64>,
    /// C D Q.
    c: DVector<f64>,
    /// Feedthrough.
    d: f64,
}

impl FreqEvaluator {
    /// Prepare a SISO model for evaluation.
    pub fn new(sys: &StateSpace) -> Result<Self, LtiError> {
        sys.require_siso()?;
        let mut a = sys.a.clone();
        let scale = balance_parlett_reinsch(&mut a);
        let b = sys.b.column(0).component_div(&scale);
        let c = sys.c.row(0).transpose().component_mul(&scale);
        let (q, h) = a.hessenberg().unpack();
        Ok(FreqEvaluator {
            b: q.tr_mul(&b),
            c: q.tr_mul(&c),
            h,
            d: sys.d[(0, 0)],
        })
    }

    /// G(s) at a complex frequency s (rad/s). At an eigenvalue of A the result is infinite.
    pub fn eval(&self, s: Complex64) -> Complex64 {
        let n = self.h.nrows();
        // M = sI − H, row-major, upper Hessenberg.
        let mut m: Vec<Complex64> = Vec::with_capacity(n * n);
        for i in 0..n {
            for j in 0..n {
                let diag = if i == j { s } else { Complex64::new(0.0, 0.0) };
                m.push(diag - self.h[(i, j)]);
            }
        }
        let mut x: Vec<Complex64> = self.b.iter().map(|&v| Complex64::new(v, 0.0)).collect();
        for k in 0..n.saturating_sub(1) {
            // pivot between rows k and k+1 (the only non-zeros in column k below the diagonal)
            if m[(k + 1) * n + k].norm_sqr() > m[k * n + k].norm_sqr() {
                for j in k..n {
                    m.swap(k * n + j, (k + 1) * n + j);
                }
                x.swap(k, k + 1);
            }
            let pivot = m[k * n + k];
            if pivot == Complex64::new(0.0, 0.0) {
                continue;
            }
            let l = m[(k + 1) * n + k] / pivot;
            for j in k + 1..n {
                let mkj = m[k * n + j];
                m[(k + 1) * n + j] -= l * mkj;
            }
            let xk = x[k];
            x[k + 1] -= l * xk;
        }
        for k in (0..n).rev() {
            let mut acc = x[k];
            for j in k + 1..n {
                acc -= m[k * n + j] * x[j];
            }
            x[k] = acc / m[k * n + k];
        }
        let y: Complex64 = self.c.iter().zip(&x).map(|(&c, &xi)| xi * c).sum();
        y + self.d
    }

    /// G(jω) at an angular frequency ω (rad/s).
    pub fn at(&self, omega: f64) -> Complex64 {
        self.eval(Complex64::new(0.0, omega))
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
    let integrators = super::margins::count_integrators(&super::eigenvalues(&sys.a)?);
    let values: Vec<Complex64> = freq_hz.iter().map(|f| ev.at(2.0 * PI * f)).collect();
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
    let mut out = Vec::with_capacity(values.len());
    let Some(first) = values.first() else {
        return out;
    };
    // sign of the low-frequency gain from the real-axis value G(σ)·σ^k
    let real_gain = ev.eval(Complex64::new(omega0, 0.0)).re;
    let asymptote = -90.0 * integrators as f64 - if real_gain < 0.0 { 180.0 } else { 0.0 };
    let mut prev = nearest_branch(first.arg().to_degrees(), asymptote);
    out.push(prev);
    for g in &values[1..] {
        prev = nearest_branch(g.arg().to_degrees(), prev);
        out.push(prev);
    }
    out
}

/// The angle `raw + 360 k` (deg) nearest to `reference`.
pub(crate) fn nearest_branch(raw: f64, reference: f64) -> f64 {
    raw + 360.0 * ((reference - raw) / 360.0).round()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn siso(a: &[f64], b: &[f64], c: &[f64], d: f64) -> StateSpace {
        let n = b.len();
        StateSpace::new(
            DMatrix::from_row_slice(n, n, a),
            DMatrix::from_row_slice(n, 1, b),
            DMatrix::from_row_slice(1, n, c),
            DMatrix::from_element(1, 1, d),
        )
        .unwrap()
    }

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
