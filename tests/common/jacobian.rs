//! The central finite-difference Jacobian of a circuit's equations: the independent check of
//! the dual-number linearisation (docs/circuits.md), shared by the circuits' tests.

use nalgebra::DMatrix;
use pumpcyl::circuit::Circuit;

/// Central finite-difference Jacobians of a circuit's equations at (x0, u0), each state
/// perturbed by 1e-6 of its value or of its scale.
pub fn fd_jacobian<C: Circuit>(c: &C, x0: &[f64], u0: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (x0.len(), u0.len());
    let scale = |j: usize| match c.states()[j].unit.as_str() {
        "m" => 0.1,
        "m/s" => 0.01,
        "Pa" => 1e5,
        "rad/s" => 10.0,
        _ => 1.0,
    };
    let f = |x: &[f64], u: &[f64]| {
        let mut dx = vec![0.0; n];
        c.rhs(x, u, &mut dx);
        dx
    };
    let mut a = DMatrix::zeros(n, n);
    let mut b = DMatrix::zeros(n, m);
    for j in 0..n + m {
        let (mut xp, mut up) = (x0.to_vec(), u0.to_vec());
        let (mut xm, mut um) = (x0.to_vec(), u0.to_vec());
        let h = if j < n {
            let h = 1e-6 * x0[j].abs().max(scale(j));
            xp[j] += h;
            xm[j] -= h;
            h
        } else {
            let h = 1e-6 * u0[j - n].abs().max(10.0);
            up[j - n] += h;
            um[j - n] -= h;
            h
        };
        let (fp, fm) = (f(&xp, &up), f(&xm, &um));
        for i in 0..n {
            let d = (fp[i] - fm[i]) / (2.0 * h);
            if j < n {
                a[(i, j)] = d;
            } else {
                b[(i, j - n)] = d;
            }
        }
    }
    (a, b)
}
