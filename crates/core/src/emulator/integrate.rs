//! The emulator's time integration (docs/emulator.md): the rig's stiff dynamics (the current
//! loop at 1257 1/s) integrated over one PLC interval with the speed references held, by
//! diffsol's BDF.

use super::{Dynamics, EmulatorError};
use crate::circuit::Circuit;
use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod, VectorCommon};

/// Typical magnitude of each state (SI), for finite-difference steps and tolerances, by its
/// role ([`crate::circuit::Role::typical_size`]).
pub(super) fn typical(d: &Dynamics) -> Vec<f64> {
    (d.circuit().states().iter())
        .map(|s| s.role.typical_size())
        .collect()
}

/// Integrate ẋ = f(x) over [t0, t1] from `x` by BDF; `scale` holds each state's typical size
/// (absolute tolerances and finite-difference steps).
pub(super) fn integrate<F: Fn(&[f64], &mut [f64])>(
    f: &F,
    scale: &[f64],
    x: &[f64],
    t0: f64,
    t1: f64,
) -> Result<Vec<f64>, EmulatorError> {
    let n = x.len();
    let x0 = x.to_vec();
    let err = |e: diffsol::error::DiffsolError| EmulatorError(format!("ODE solver: {e}"));
    let problem = OdeBuilder::<NalgebraMat<f64>>::new()
        .t0(t0)
        .rtol(1e-7)
        .atol(scale.iter().map(|s| s * 1e-7).collect::<Vec<f64>>())
        .rhs_implicit(
            move |x: &[f64], _p: &[f64], _t: f64, y: &mut [f64]| f(x, y),
            move |x: &[f64], _p: &[f64], _t: f64, v: &[f64], y: &mut [f64]| {
                jac_vec(f, x, v, scale, y)
            },
        )
        .init(
            move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&x0),
            n,
        )
        .build()
        .map_err(err)?;
    let mut solver = problem.bdf::<NalgebraLU<f64>>().map_err(err)?;
    solver.solve(t1).map_err(err)?;
    let y = solver.state().y.inner().as_slice().to_vec();
    if y.iter().any(|v| !v.is_finite()) {
        return Err(EmulatorError(format!(
            "ODE solver: the state is not finite at t = {t1} s"
        )));
    }
    Ok(y)
}

/// J(x)·v by a forward difference along v, the step scaled so no state moves by more than
/// 1e-7 of its typical size.
fn jac_vec<F: Fn(&[f64], &mut [f64])>(f: &F, x: &[f64], v: &[f64], scale: &[f64], y: &mut [f64]) {
    let vmax = v
        .iter()
        .zip(scale)
        .map(|(v, s)| (v / s).abs())
        .fold(0.0, f64::max);
    if vmax == 0.0 {
        y.fill(0.0);
        return;
    }
    let eps = 1e-7 / vmax;
    let xp: Vec<f64> = x.iter().zip(v).map(|(x, v)| x + eps * v).collect();
    let mut f0 = vec![0.0; x.len()];
    f(x, &mut f0);
    f(&xp, y);
    for (yi, f) in y.iter_mut().zip(&f0) {
        *yi = (*yi - f) / eps;
    }
}

/// Integrate the rig over one PLC interval with the speed references `u` held.
pub(super) fn hold(
    d: &Dynamics,
    x: &[f64],
    u: [f64; 2],
    t0: f64,
    t1: f64,
) -> Result<Vec<f64>, EmulatorError> {
    integrate(
        &|x: &[f64], y: &mut [f64]| d.rhs(x, &u, y),
        &typical(d),
        x,
        t0,
        t1,
    )
}
