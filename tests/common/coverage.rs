//! Coverage of 95 % intervals over record sets with known truths: what the step and the
//! frequency method's measurements (tests/coverage.rs, tests/frf_coverage.rs) count and print.

/// One record set: per parameter (β, b, c12) whether its interval is closed and whether it
/// holds the truth.
#[derive(Debug, Clone, Copy)]
pub struct Outcome {
    pub bounded: [bool; 3],
    pub inside: [bool; 3],
}

impl Outcome {
    /// The outcome of the intervals `(identifiable, [lo, hi])` for the truth `value`.
    pub fn of(intervals: [(bool, [f64; 2]); 3], value: [f64; 3]) -> Outcome {
        Outcome {
            bounded: intervals.map(|(b, _)| b),
            inside: std::array::from_fn(|i| {
                let [lo, hi] = intervals[i].1;
                lo <= value[i] && value[i] <= hi
            }),
        }
    }
}

/// Coverage per parameter: (share inside, sets counted), a set counted for parameter `i` where
/// `counted(outcome, i)`; with none counted, nothing is missed (share 1).
pub fn coverage(
    outcomes: &[Outcome],
    counted: impl Fn(&Outcome, usize) -> bool,
) -> [(f64, usize); 3] {
    std::array::from_fn(|i| {
        let sets: Vec<&Outcome> = outcomes.iter().filter(|o| counted(o, i)).collect();
        let inside = sets.iter().filter(|o| o.inside[i]).count();
        let share = if sets.is_empty() {
            1.0
        } else {
            inside as f64 / sets.len() as f64
        };
        (share, sets.len())
    })
}

/// Print the coverage of `what` over `sets` record sets and assert each parameter's at least
/// 90 %.
pub fn check(what: &str, sets: u64, c: &[(f64, usize); 3]) {
    eprintln!(
        "coverage of the 95 % intervals over {sets} {what}: beta {:.1} % ({}), b {:.1} % ({} \
         counted), c12 {:.1} % ({})",
        100.0 * c[0].0,
        c[0].1,
        100.0 * c[1].0,
        c[1].1,
        100.0 * c[2].0,
        c[2].1
    );
    for (name, (share, _)) in ["beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"]
        .iter()
        .zip(c)
    {
        assert!(*share >= 0.9, "coverage of {name}: {share}");
    }
}

/// The record sets of a full measurement: `PUMPCYL_COVERAGE_SETS`, else `default`.
pub fn sets(default: u64) -> u64 {
    std::env::var("PUMPCYL_COVERAGE_SETS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}
