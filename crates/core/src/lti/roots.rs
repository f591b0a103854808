//! Bracketing root refinement (Brent's method from `argmin`) for crossing frequencies.

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::brent::BrentRoot;

/// A scalar function as an argmin cost function.
struct Scalar<F: Fn(f64) -> f64>(F);

impl<F: Fn(f64) -> f64> CostFunction for Scalar<F> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, p: &f64) -> Result<f64, Error> {
        Ok((self.0)(*p))
    }
}

/// Root of `f` in `[lo, hi]` where `f(lo)` and `f(hi)` differ in sign, to absolute tolerance
/// `tol` in the argument. Falls back to the midpoint if the solver fails (it cannot on a valid
/// bracket, but the analysis must never panic).
pub fn brent(f: impl Fn(f64) -> f64, lo: f64, hi: f64, tol: f64) -> f64 {
    let run = Executor::new(Scalar(f), BrentRoot::new(lo, hi, tol))
        .configure(|s| s.max_iters(200))
        .run();
    match run {
        Ok(res) => res
            .state()
            .get_best_param()
            .copied()
            .unwrap_or(0.5 * (lo + hi)),
        Err(_) => 0.5 * (lo + hi),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn finds_sqrt_two() {
        let r = super::brent(|x| x * x - 2.0, 0.0, 3.0, 1e-14);
        assert!((r - 2f64.sqrt()).abs() < 1e-12, "{r}");
    }
}
