//! The model's response to compare an estimate with: the continuous response H(jω), or the
//! response of the model with its input held between samples, which is what a record sampled
//! at `rate_hz` shows of a linear loop driven by a sampled reference.

use crate::lti::{FreqEvaluator, LtiError, StateSpace, Zoh};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// H at each of `freq_hz` of the SISO `sys`: continuous (`rate_hz` = `None`) or with its input
/// held over samples of 1/`rate_hz`: C (zI − Φ)⁻¹ Γ + D at z = e^{jωh}, Φ, Γ the zero-order-hold
/// discretisation (docs/simulation.md#exact-zero-order-hold).
pub fn model_response(
    sys: &StateSpace,
    freq_hz: &[f64],
    rate_hz: Option<f64>,
) -> Result<Vec<Complex64>, LtiError> {
    sys.require_siso()?;
    let Some(rate_hz) = rate_hz else {
        let omega: Vec<f64> = freq_hz
            .iter()
            .map(|f| 2.0 * std::f64::consts::PI * f)
            .collect();
        return Ok(FreqEvaluator::new(sys)?.at_many(&omega));
    };
    let h = 1.0 / rate_hz;
    let zoh = Zoh::new(&sys.a, &sys.b, h)?;
    let n = sys.order();
    let cplx = |v: f64| Complex64::new(v, 0.0);
    let gamma = DVector::from_fn(n, |i, _| cplx(zoh.gamma[(i, 0)]));
    Ok(freq_hz
        .iter()
        .map(|f| {
            let z = Complex64::from_polar(1.0, 2.0 * std::f64::consts::PI * f * h);
            let m = DMatrix::from_fn(n, n, |i, j| {
                let eye = if i == j { z } else { cplx(0.0) };
                eye - cplx(zoh.phi[(i, j)])
            });
            let x = m.lu().solve(&gamma).unwrap_or_else(|| DVector::zeros(n));
            (0..n).map(|i| x[i] * sys.c[(0, i)]).sum::<Complex64>() + sys.d[(0, 0)]
        })
        .collect())
}
