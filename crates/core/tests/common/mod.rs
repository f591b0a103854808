//! Plant builders shared by the margin tests.

use nalgebra::DMatrix;
use num_complex::Complex64;
use pumpcyl::lti::StateSpace;

/// SISO model num(s)/den(s) in controllable canonical form; `den` highest power first (any
/// leading coefficient), `num` of lower degree, highest power first.
pub fn tf(num: &[f64], den: &[f64]) -> StateSpace {
    let n = den.len() - 1;
    let monic: Vec<f64> = den.iter().map(|c| c / den[0]).collect();
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n - 1 {
        a[(i, i + 1)] = 1.0;
    }
    for j in 0..n {
        a[(n - 1, j)] = -monic[n - j];
    }
    let mut b = DMatrix::zeros(n, 1);
    b[(n - 1, 0)] = 1.0;
    let mut padded = vec![0.0; n - num.len()];
    padded.extend(num.iter().map(|c| c / den[0]));
    let c = DMatrix::from_fn(1, n, |_, j| padded[n - 1 - j]);
    StateSpace::new(a, b, c, DMatrix::zeros(1, 1)).unwrap()
}

/// p(s) for coefficients highest power first.
pub fn poly(c: &[f64], s: Complex64) -> Complex64 {
    c.iter()
        .fold(Complex64::new(0.0, 0.0), |acc, &k| acc * s + k)
}
