//! The model's response to compare an estimate with: the continuous response H(jω), or the
//! response of the model with its input held between samples, which is what a record sampled
//! at `rate_hz` shows of a linear loop driven by a sampled reference.

use crate::lti::{FreqEvaluator, LtiError, StateSpace, Zoh};
use crate::model::Plant;
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
    let c: Vec<f64> = (0..sys.order()).map(|i| sys.c[(0, i)]).collect();
    Ok(discrete(
        &zoh.phi,
        zoh.gamma.column(0).as_slice(),
        &c,
        sys.d[(0, 0)],
        freq_hz,
        h,
    ))
}

/// x/x_ref at each of `freq_hz` of `plant`'s loop with its controller (the sum-pressure loop
/// where `sum_pressure`) sampled at `rate_hz`: the position and pressures read at each sample,
/// the speed commands held until the next, as a PLC runs it. With Φ, Γ the zero-order-hold
/// discretisation of the plant over h = 1/`rate_hz` and u = Kx·x + Kr·x_ref the control law,
/// x_{k+1} = (Φ + Γ Kx) x_k + Γ Kr x_ref,k, so T(z) = e_xᵀ (zI − Φ − Γ Kx)⁻¹ Γ Kr at
/// z = e^{jωh} (docs/identification.md#grey-box-fit-to-a-frequency-response).
pub fn sampled_loop_response(
    plant: &Plant,
    sum_pressure: bool,
    freq_hz: &[f64],
    rate_hz: f64,
) -> Result<Vec<Complex64>, LtiError> {
    let h = 1.0 / rate_hz;
    let zoh = Zoh::new(&plant.a, &plant.b, h)?;
    let (kx, kr) = plant.controller(sum_pressure);
    let phi = &zoh.phi + &zoh.gamma * kx;
    let gamma = &zoh.gamma * kr;
    let mut c = vec![0.0; plant.n()];
    c[plant.position()] = 1.0;
    Ok(discrete(
        &phi,
        gamma.column(0).as_slice(),
        &c,
        0.0,
        freq_hz,
        h,
    ))
}

/// c (zI − Φ)⁻¹ γ + d at z = e^{jωh} for each of `freq_hz`.
fn discrete(
    phi: &DMatrix<f64>,
    gamma: &[f64],
    c: &[f64],
    d: f64,
    freq_hz: &[f64],
    h: f64,
) -> Vec<Complex64> {
    let n = c.len();
    let cplx = |v: f64| Complex64::new(v, 0.0);
    let gamma = DVector::from_fn(n, |i, _| cplx(gamma[i]));
    freq_hz
        .iter()
        .map(|f| {
            let z = Complex64::from_polar(1.0, 2.0 * std::f64::consts::PI * f * h);
            let m = DMatrix::from_fn(n, n, |i, j| {
                let eye = if i == j { z } else { cplx(0.0) };
                eye - cplx(phi[(i, j)])
            });
            let x = m.lu().solve(&gamma).unwrap_or_else(|| DVector::zeros(n));
            (0..n).map(|i| x[i] * c[i]).sum::<Complex64>() + d
        })
        .collect()
}
