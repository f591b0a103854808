//! Parallel grid search in bounded memory: candidates are generated from their index, costed,
//! and folded into a top-N list and threshold statistics per chunk; nothing per candidate is
//! stored (docs/identification.md#pruning). Unstable candidates are caught by their closed-loop eigenvalues before
//! they can enter any reported result.

use super::grid::{Candidate, Grid};
use super::problem::Problem;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Candidates per parallel work item (and per progress update).
const CHUNK: usize = 64;
/// Threshold-set members kept for the report (the count and bounds cover all of them).
pub const MEMBERS_KEPT: usize = 1000;

/// A costed candidate with its place in the search (stage, index) for a deterministic order.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scored {
    /// Parameters.
    #[serde(flatten)]
    pub candidate: Candidate,
    /// Cost (mm²).
    pub cost_mm2: f64,
    /// Search stage (1 or 2; 0 for a local refinement).
    pub stage: u8,
    /// Flat grid index within the stage.
    pub index: u64,
}

impl Scored {
    fn key(&self) -> (f64, u8, u64) {
        (self.cost_mm2, self.stage, self.index)
    }

    fn before(&self, other: &Scored) -> bool {
        let (a, b) = (self.key(), other.key());
        a.0.total_cmp(&b.0)
            .then(a.1.cmp(&b.1))
            .then(a.2.cmp(&b.2))
            .is_lt()
    }
}

/// What a search (or a shard of it) found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Candidates evaluated.
    pub evaluated: u64,
    /// Candidates whose cost was not finite.
    pub non_finite: u64,
    /// Candidates rejected as closed-loop unstable.
    pub unstable: u64,
    /// Candidates whose simulation stopped early, proven unable to enter any result.
    pub pruned: u64,
    /// The best candidates, best first.
    pub top: Vec<Scored>,
    /// Cost threshold of the threshold set (mm²).
    pub threshold_mm2: f64,
    /// Stable candidates below the threshold.
    pub threshold_count: u64,
    /// The best of them (at most [`MEMBERS_KEPT`]), best first.
    pub threshold_members: Vec<Scored>,
    /// Bounds [lo, hi] of β, b and c12 over the whole threshold set.
    pub threshold_bounds: Option<[[f64; 2]; 3]>,
}

impl Summary {
    fn empty(threshold_mm2: f64) -> Summary {
        Summary {
            evaluated: 0,
            non_finite: 0,
            unstable: 0,
            pruned: 0,
            top: Vec::new(),
            threshold_mm2,
            threshold_count: 0,
            threshold_members: Vec::new(),
            threshold_bounds: None,
        }
    }

    /// The worst cost of a full top list: no candidate above it can enter the final top list
    /// (∞ while the list is not full).
    fn top_bound(&self, top_n: usize) -> f64 {
        match self.top.last() {
            Some(worst) if self.top.len() >= top_n => worst.cost_mm2,
            _ => f64::INFINITY,
        }
    }

    /// Fold one costed candidate in; `top_bound` is a cost no final top-list member exceeds;
    /// `stable` is asked only when the candidate would enter a result.
    fn push(
        &mut self,
        s: Scored,
        top_n: usize,
        top_bound: f64,
        stable: impl Fn(&Candidate) -> bool,
    ) {
        self.evaluated += 1;
        if !s.cost_mm2.is_finite() {
            self.non_finite += 1;
            return;
        }
        let enters_top = s.cost_mm2 <= top_bound
            && (self.top.len() < top_n || self.top.last().is_some_and(|w| s.before(w)));
        let below = s.cost_mm2 < self.threshold_mm2;
        if !(enters_top || below) {
            return;
        }
        if !stable(&s.candidate) {
            self.unstable += 1;
            return;
        }
        if enters_top {
            insert_sorted(&mut self.top, s, top_n);
        }
        if below {
            self.threshold_count += 1;
            insert_sorted(&mut self.threshold_members, s, MEMBERS_KEPT);
            let c = s.candidate;
            let point = [
                [c.beta_bar; 2],
                [c.viscous_friction_ns_per_m; 2],
                [c.c12_m5_per_ns; 2],
            ];
            self.threshold_bounds = Some(union(self.threshold_bounds, point));
        }
    }

    /// Combine two summaries of disjoint candidate sets.
    pub fn merge(mut self, other: Summary, top_n: usize) -> Summary {
        self.evaluated += other.evaluated;
        self.non_finite += other.non_finite;
        self.unstable += other.unstable;
        self.pruned += other.pruned;
        self.threshold_count += other.threshold_count;
        for s in other.top {
            insert_sorted(&mut self.top, s, top_n);
        }
        for s in other.threshold_members {
            insert_sorted(&mut self.threshold_members, s, MEMBERS_KEPT);
        }
        if let Some(b) = other.threshold_bounds {
            self.threshold_bounds = Some(union(self.threshold_bounds, b));
        }
        self
    }
}

/// Union of two sets of axis bounds.
fn union(a: Option<[[f64; 2]; 3]>, b: [[f64; 2]; 3]) -> [[f64; 2]; 3] {
    let Some(a) = a else { return b };
    std::array::from_fn(|i| [a[i][0].min(b[i][0]), a[i][1].max(b[i][1])])
}

/// Insert keeping the list sorted (best first) and at most `cap` long.
fn insert_sorted(list: &mut Vec<Scored>, s: Scored, cap: usize) {
    let pos = list.partition_point(|x| x.before(&s));
    if pos < cap {
        list.insert(pos, s);
        list.truncate(cap);
    }
}

/// Search options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchOptions {
    /// Length of the top list.
    pub top_n: usize,
    /// Threshold of the threshold set (mm²).
    pub threshold_mm2: f64,
    /// Evaluate only the candidates with index % count == shard − 1 (1-based `shard`).
    pub shard: Option<(usize, usize)>,
}

/// Evaluate every candidate of `grid` (or of the shard) in parallel. `progress(n)` is called
/// after each chunk of n candidates; once it returns `false` the remaining chunks are skipped
/// (the summary then covers only the chunks evaluated: the caller that stops discards it).
pub fn search(
    problem: &Problem,
    grid: &Grid,
    stage: u8,
    opts: SearchOptions,
    progress: &(dyn Fn(u64) -> bool + Sync),
) -> Summary {
    let stopped = AtomicBool::new(false);
    let (shard, shards) = opts.shard.map_or((0, 1), |(i, n)| (i - 1, n));
    let mine = shard_len(grid.len(), opts.shard);
    // One accumulator per rayon split; the best full-top bound any of them has reached is
    // shared (positive f64 bits order like the floats), so a fresh split prunes at once too.
    let shared = AtomicU64::new(f64::INFINITY.to_bits());
    (0..mine.div_ceil(CHUNK))
        .into_par_iter()
        .with_min_len(4)
        .fold(
            || Summary::empty(opts.threshold_mm2),
            |mut acc, c| {
                if stopped.load(Ordering::Relaxed) {
                    return acc;
                }
                let positions = c * CHUNK..((c + 1) * CHUNK).min(mine);
                let count = positions.len();
                for index in positions.map(|p| shard + p * shards) {
                    let local = acc.top_bound(opts.top_n);
                    shared.fetch_min(local.to_bits(), Ordering::Relaxed);
                    let top = f64::from_bits(shared.load(Ordering::Relaxed)).min(local);
                    let bound = top.max(opts.threshold_mm2);
                    let candidate = grid.candidate(index);
                    let Some(cost_mm2) = problem.cost_below(&candidate, bound) else {
                        acc.evaluated += 1;
                        acc.pruned += 1;
                        continue;
                    };
                    let s = Scored {
                        candidate,
                        cost_mm2,
                        stage,
                        index: index as u64,
                    };
                    acc.push(s, opts.top_n, top, |c| problem.is_stable(c));
                }
                if !progress(count as u64) {
                    stopped.store(true, Ordering::Relaxed);
                }
                acc
            },
        )
        .reduce(
            || Summary::empty(opts.threshold_mm2),
            |a, b| a.merge(b, opts.top_n),
        )
}

/// The number of candidates a shard holds.
pub fn shard_len(total: usize, shard: Option<(usize, usize)>) -> usize {
    shard.map_or(total, |(i, n)| (i - 1..total).step_by(n).count())
}
