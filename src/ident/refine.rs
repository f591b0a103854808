//! Local refinement of the best grid point by Nelder–Mead (argmin) on the logarithms of β, b
//! and c12, so the parameters stay positive without bounds (docs/identification.md#neldermead-refinement).

use super::grid::Candidate;
use super::problem::Problem;
use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;

/// Iteration limit of the simplex search.
const MAX_ITERS: u64 = 400;
/// Initial simplex: each parameter 10 % away from the start.
const STEP: f64 = 0.1;

struct LogCost<'a> {
    problem: &'a Problem,
}

fn candidate_of(p: &[f64]) -> Candidate {
    Candidate {
        beta_bar: p[0].exp(),
        viscous_friction_ns_per_m: p[1].exp(),
        c12_m5_per_ns: p[2].exp(),
    }
}

impl CostFunction for LogCost<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
        Ok(self.problem.cost(&candidate_of(p)))
    }
}

/// Refine from `start`; returns the refined candidate and its cost, or `None` when the result
/// is not better or not stable.
pub fn refine(problem: &Problem, start: &Candidate) -> Option<(Candidate, f64)> {
    // friction may be 0 on a grid: start the log search from a small positive value
    let x0 = vec![
        start.beta_bar.ln(),
        start.viscous_friction_ns_per_m.max(1.0).ln(),
        start.c12_m5_per_ns.max(1e-16).ln(),
    ];
    let mut simplex = vec![x0.clone()];
    for i in 0..3 {
        let mut v = x0.clone();
        v[i] += STEP;
        simplex.push(v);
    }
    let solver = NelderMead::new(simplex).with_sd_tolerance(1e-10).ok()?;
    let res = Executor::new(LogCost { problem }, solver)
        .configure(|s| s.max_iters(MAX_ITERS))
        .run()
        .ok()?;
    let best = res.state().get_best_param()?.clone();
    let c = candidate_of(&best);
    let cost = problem.cost(&c);
    let start_cost = problem.cost(start);
    (cost.is_finite() && cost <= start_cost && problem.is_stable(&c)).then_some((c, cost))
}
