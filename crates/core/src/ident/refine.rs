//! Local refinement of the best grid point by Nelder–Mead (argmin) on the logarithms of β, b
//! and c12, so the parameters stay positive without bounds (docs/identification.md#neldermead-refinement).
//! The simplex search itself, [`minimize`], also serves the cost profiles of the uncertainty
//! analysis.

use super::grid::Candidate;
use super::problem::Problem;
use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;

/// Iteration limit of the simplex search.
const MAX_ITERS: u64 = 400;
/// Initial simplex: each parameter 10 % away from the start.
const STEP: f64 = 0.1;

/// A cost over a parameter vector, for argmin.
struct FnCost<'a> {
    f: &'a (dyn Fn(&[f64]) -> f64 + Sync),
}

impl CostFunction for FnCost<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
        Ok((self.f)(p))
    }
}

/// Minimise `f` by Nelder–Mead from `x0`, the initial simplex stepping each coordinate by
/// `step`; at most `max_iters` iterations, stopping when the simplex's cost spread falls below
/// `tol`. Returns the best point and its cost, or `None` when the solver fails.
pub(super) fn minimize(
    f: &(dyn Fn(&[f64]) -> f64 + Sync),
    x0: &[f64],
    step: f64,
    tol: f64,
    max_iters: u64,
) -> Option<(Vec<f64>, f64)> {
    let mut simplex = vec![x0.to_vec()];
    for i in 0..x0.len() {
        let mut v = x0.to_vec();
        v[i] += step;
        simplex.push(v);
    }
    let solver = NelderMead::new(simplex).with_sd_tolerance(tol).ok()?;
    let res = Executor::new(FnCost { f }, solver)
        .configure(|s| s.max_iters(max_iters))
        .run()
        .ok()?;
    let best = res.state().get_best_param()?.clone();
    let cost = f(&best);
    Some((best, cost))
}

/// The candidate of a point in (ln β, ln b, ln c12).
pub(super) fn candidate_of(p: &[f64]) -> Candidate {
    Candidate {
        beta_bar: p[0].exp(),
        viscous_friction_ns_per_m: p[1].exp(),
        c12_m5_per_ns: p[2].exp(),
    }
}

/// The point (ln β, ln b, ln c12) of a candidate; friction and leakage may be 0 on a grid, so
/// the logarithms start from small positive values.
pub(super) fn log_point(c: &Candidate) -> Vec<f64> {
    vec![
        c.beta_bar.ln(),
        c.viscous_friction_ns_per_m.max(1.0).ln(),
        c.c12_m5_per_ns.max(1e-16).ln(),
    ]
}

/// Refine from `start`; returns the refined candidate and its cost, or `None` when the result
/// is not better or not stable.
pub fn refine(problem: &Problem, start: &Candidate) -> Option<(Candidate, f64)> {
    let f = |p: &[f64]| problem.cost(&candidate_of(p));
    let (best, cost) = minimize(&f, &log_point(start), STEP, 1e-10, MAX_ITERS)?;
    let c = candidate_of(&best);
    let start_cost = problem.cost(start);
    (cost.is_finite() && cost <= start_cost && problem.is_stable(&c)).then_some((c, cost))
}
