//! Sharded identification (docs/identification.md#sharding): the partial result each shard
//! writes, its fingerprint, and the merge that checks the shards belong together and were not
//! edited before it gives the answer of one run.

use super::IdentError;
use super::{finish, Experiment, Identification, Options, Stage};
use super::{Grid, SecondGrid, MEMBERS_KEPT};

type Result<T> = std::result::Result<T, IdentError>;

/// Refuse with the message when the condition does not hold.
macro_rules! ensure {
    ($cond:expr, $($message:tt)+) => {
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !$cond {
            return Err(IdentError::Input(format!($($message)+)));
        }
    };
}
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

/// A partial result of a sharded run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Partial {
    /// The experiment file, by its canonical path.
    pub experiment: PathBuf,
    /// [`digest`] of the experiment and options the shard ran with.
    pub digest: String,
    /// Which shard: (I, N), I from 1.
    pub shard: (usize, usize),
    /// Whether the merged result is refined by Nelder–Mead.
    pub local_refinement: bool,
    /// The threshold of the threshold sets (mm²).
    pub threshold_mm2: f64,
    /// Length of the top list.
    pub top: usize,
    /// The shard's search time (s).
    pub seconds: f64,
    /// The shard's stages.
    pub stages: Vec<Stage>,
}

impl Partial {
    /// The partial result of shard `shard` of the experiment file at `path` (read from
    /// `source`), searched with `opts`: its `stages`, found in `seconds`. The file is named by
    /// its canonical path and fingerprinted as the merge will load it ([`digest`]); what
    /// `pumpcyl identify --shard` writes and Python's `identify(shard=...)` returns.
    pub fn of_search(
        source: &dyn crate::source_files::Files,
        path: &std::path::Path,
        opts: &Options,
        shard: (usize, usize),
        seconds: f64,
        stages: Vec<Stage>,
    ) -> Result<Partial> {
        let canonical = std::fs::canonicalize(path)
            .map_err(|e| IdentError::Input(format!("{}: {e}", path.display())))?;
        let exp = Experiment::load_in(source, &canonical)?;
        Ok(Partial {
            digest: digest(&exp, opts, shard)?,
            experiment: canonical,
            shard,
            local_refinement: opts.local_refinement,
            threshold_mm2: opts.threshold_mm2,
            top: opts.top_n,
            seconds,
            stages,
        })
    }
}

/// A fingerprint of everything a shard's result depends on: the experiment file, the rig it
/// names with its overrides, the standstill point, every dataset's record and settings, the
/// grids (so the number of stages), the options (threshold, top length, refinement) and which
/// slice of the grid the shard is, (I, N).
pub fn digest(exp: &Experiment, opts: &Options, shard: (usize, usize)) -> Result<String> {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    crate::source_files::read_bounded(&crate::source_files::Disk, &exp.path)
        .map_err(|e| IdentError::Input(format!("{}: {e}", exp.path.display())))?
        .hash(&mut h);
    // Debug prints every f64 exactly (shortest round-trip form)
    format!("{:?}", exp.rig).hash(&mut h);
    format!("{:?}", exp.problem).hash(&mut h);
    format!("{:?}", exp.grids()).hash(&mut h);
    format!(
        "{:?} {} {}",
        opts.threshold_mm2.to_bits(),
        opts.top_n,
        opts.local_refinement
    )
    .hash(&mut h);
    shard.hash(&mut h);
    Ok(format!("{:016x}", h.finish()))
}

/// Check that a shard's stages are what its slice of the grids gives: each stage on the grid
/// the experiment names, as many candidates evaluated as the slice holds, the outcome counts
/// adding up, a top list as long as the candidates allow and every listed candidate the grid
/// point of its index, inside the slice; a time that is a time. Only a re-run could tell an
/// honest cost from an edited one; the merge simulates again what it reports
/// ([`verify_costs`]).
fn check_part(exp: &Experiment, p: &Partial, opts: &Options) -> std::result::Result<(), String> {
    let fail = |what: String| Err(what + "; a partial result was edited or is damaged");
    if !(p.seconds.is_finite() && p.seconds >= 0.0) {
        return fail(format!("a search time of {} s", p.seconds));
    }
    let (i, n) = p.shard;
    for (k, (stage, grid)) in p.stages.iter().zip(fixed_grids(exp)?).enumerate() {
        let at = |what: String| format!("stage {}: {what}", k + 1);
        let grid = grid.unwrap_or_else(|| stage.grid.clone());
        if stage.grid != grid {
            return fail(at("its grid is not the experiment's".into()));
        }
        let s = &stage.summary;
        let slice = super::shard_len(grid.len(), Some(p.shard)) as u64;
        if s.evaluated != slice {
            return fail(at(format!(
                "{} candidates evaluated, the slice {i}/{n} holds {slice}",
                s.evaluated
            )));
        }
        let rejected = s.non_finite + s.unstable + s.pruned;
        let eligible = s.evaluated.checked_sub(rejected);
        let top_ok = s.top.len() <= opts.top_n
            && (s.top.len() == opts.top_n || eligible == Some(s.top.len() as u64));
        if !top_ok || eligible.is_none() {
            return fail(at(format!(
                "a top list of {} from {} candidates ({} non-finite, {} unstable, {} pruned)",
                s.top.len(),
                s.evaluated,
                s.non_finite,
                s.unstable,
                s.pruned
            )));
        }
        let members = &s.threshold_members;
        let bounded = |e: &super::Scored| {
            s.threshold_bounds.is_some_and(|b| {
                let v = [
                    e.candidate.beta_bar,
                    e.candidate.viscous_friction_ns_per_m,
                    e.candidate.c12_m5_per_ns,
                ];
                (0..3).all(|a| b[a][0] <= v[a] && v[a] <= b[a][1])
            })
        };
        let set_ok = s.threshold_mm2 == opts.threshold_mm2
            && s.threshold_count >= members.len() as u64
            && s.threshold_count <= eligible.unwrap_or(0)
            && (s.threshold_count == 0) == s.threshold_bounds.is_none()
            && members
                .iter()
                .all(|e| e.cost_mm2 < opts.threshold_mm2 && bounded(e));
        if !set_ok {
            return fail(at(format!(
                "a threshold set of {} candidates that does not match its members and bounds",
                s.threshold_count
            )));
        }
        for e in s.top.iter().chain(&s.threshold_members) {
            let index = usize::try_from(e.index).unwrap_or(usize::MAX);
            let inside = index < grid.len() && index % n == i - 1;
            if !(inside && usize::from(e.stage) == k + 1 && grid.candidate(index) == e.candidate) {
                return fail(at(format!(
                    "candidate {} is not the grid point of its slice",
                    e.index
                )));
            }
        }
        if !s.top.windows(2).all(|w| w[0].cost_mm2 <= w[1].cost_mm2) {
            return fail(at("the top list is not in order of cost".into()));
        }
        check_members(s).map_err(|e| at(e) + "; a partial result was edited or is damaged")?;
    }
    Ok(())
}

/// Check that a stage's top list and threshold set tell the same story: the set keeps its
/// best [`MEMBERS_KEPT`] members (all of them when fewer), their bounds are the members' own
/// when all are kept, and the top list begins with the set's best, the same candidates at the
/// same costs in the same order (both are the lowest costs of the slice), the rest of it at or
/// above the threshold. A best candidate dropped from the top list, or a cost raised there, is
/// still in the member list.
fn check_members(s: &super::Summary) -> std::result::Result<(), String> {
    let members = &s.threshold_members;
    let count = usize::try_from(s.threshold_count).unwrap_or(usize::MAX);
    if members.len() != count.min(MEMBERS_KEPT) {
        return Err(format!(
            "threshold_count {} with {} threshold_members (all are kept up to {MEMBERS_KEPT})",
            s.threshold_count,
            members.len()
        ));
    }
    if members.len() == count && s.threshold_bounds != bounds_of(members) {
        return Err("threshold_bounds are not the bounds of the threshold_members".into());
    }
    let below = s.top.len().min(count);
    let shared = below.min(members.len());
    if let Some(k) = (0..shared).find(|&k| s.top[k] != members[k]) {
        return Err(format!(
            "top[{k}] (candidate {} at {} mm²) is not the threshold set's best at that place \
             (threshold_members[{k}]: candidate {} at {} mm²)",
            s.top[k].index, s.top[k].cost_mm2, members[k].index, members[k].cost_mm2
        ));
    }
    if let Some(k) = (below..s.top.len()).find(|&k| s.top[k].cost_mm2 < s.threshold_mm2) {
        return Err(format!(
            "top[{k}] costs {} mm², below the threshold, but is not among the threshold_count \
             {}",
            s.top[k].cost_mm2, s.threshold_count
        ));
    }
    Ok(())
}

/// The bounds [lo, hi] of β, b and c12 over `members` (None when empty).
fn bounds_of(members: &[super::Scored]) -> Option<[[f64; 2]; 3]> {
    let axes = |e: &super::Scored| {
        let c = e.candidate;
        [c.beta_bar, c.viscous_friction_ns_per_m, c.c12_m5_per_ns]
    };
    let first = axes(members.first()?);
    Some(std::array::from_fn(|a| {
        members
            .iter()
            .map(|e| axes(e)[a])
            .fold([first[a]; 2], |b, v| [b[0].min(v), b[1].max(v)])
    }))
}

/// Refuse a shard label (I, N) outside 1 ≤ I ≤ N ≤ the fewest candidates of the experiment's
/// grids (so every shard has a candidate of each stage) and N ≤
/// [`MAX_SHARDS`](crate::limits::MAX_SHARDS) (docs/identification.md#sharding).
pub fn check_label(exp: &Experiment, (i, n): (usize, usize)) -> Result<()> {
    check_count((i, n))?;
    let (first, second) = exp.grids();
    let candidates = match second {
        Some(SecondGrid::Given(g)) => first.len().min(g.len()),
        _ => first.len(),
    };
    ensure!(
        n <= candidates,
        "shard {i}/{n}: more shards than the {candidates} candidates of the experiment's \
         smallest grid; give N <= {candidates}"
    );
    Ok(())
}

/// Refuse a shard label outside 1 ≤ I ≤ N ≤ [`MAX_SHARDS`](crate::limits::MAX_SHARDS).
fn check_count((i, n): (usize, usize)) -> Result<()> {
    let max = crate::limits::MAX_SHARDS;
    ensure!(
        (1..=n).contains(&i) && n <= max,
        "shard {i}/{n}: need 1 <= I <= N <= {max} (the most shards a run is split into)"
    );
    Ok(())
}

/// The experiment's grids as a sharded run evaluates them, both fixed in advance; an error
/// when the second is centred on the first stage's best (no shard can have run it).
fn fixed_grids(exp: &Experiment) -> std::result::Result<[Option<Grid>; 2], String> {
    match exp.grids() {
        (_, Some(SecondGrid::Centred)) => Err(
            "the experiment's second grid is centred on the first stage's best, so it cannot \
             be sharded: give `refined_grid` in the experiment"
                .into(),
        ),
        (first, Some(SecondGrid::Given(g))) => Ok([Some(first), Some(g)]),
        (first, None) => Ok([Some(first), None]),
    }
}

/// The top lists of each shard's stages, with the file the shard was read from: what
/// [`verify_costs`] simulates again.
type Tops = Vec<(PathBuf, Vec<Vec<super::Scored>>)>;

/// Simulate again every candidate the merged result reports (each stage's merged top list)
/// and each shard's best of each stage, and compare with the costs the shards wrote: a shard
/// whose costs do not reproduce is refused, naming its file, the stage and the place in its
/// top list. The grid point of every listed index was checked by [`check_part`].
fn verify_costs(exp: &Experiment, tops: &Tops, merged: &[Stage]) -> Result<()> {
    use rayon::prelude::*;
    let reported =
        |k: usize, e: &super::Scored| merged[k].summary.top.iter().any(|m| m.index == e.index);
    let mut jobs = Vec::new();
    for (file, stages) in tops {
        for (k, top) in stages.iter().enumerate() {
            for (j, e) in top.iter().enumerate() {
                if j == 0 || reported(k, e) {
                    jobs.push((file, k, j, e));
                }
            }
        }
    }
    let costs: Vec<f64> = jobs
        .par_iter()
        .map(|(_, _, _, e)| exp.problem.cost(&e.candidate))
        .collect();
    for ((file, k, j, e), cost) in jobs.iter().zip(costs) {
        ensure!(
            (cost - e.cost_mm2).abs() <= 1e-9 * cost.abs().max(1e-12),
            "{}: stage {}: top[{j}] (beta_bar {}) has cost_mm2 {} in the partial result but \
             costs {cost} mm² when simulated again; a partial result was edited or made by \
             another pumpcyl",
            file.display(),
            k + 1,
            e.candidate.beta_bar,
            e.cost_mm2
        );
    }
    Ok(())
}

/// Merge the partial results `parts` (each with the file it was read from, for messages) into
/// the identification of one unsharded run, with the time it took: the shards' search times
/// added up, plus the merge's own (s). Refused when a shard is missing or given twice, the
/// shards come from different runs, options or experiment contents, or a partial result was
/// edited (every candidate it reports and each shard's best are simulated again).
pub fn merge(
    source: &dyn crate::source_files::Files,
    parts: Vec<(PathBuf, Partial)>,
) -> Result<(Experiment, Identification, f64)> {
    let (files, parts): (Vec<PathBuf>, Vec<Partial>) = parts.into_iter().unzip();
    ensure!(!parts.is_empty(), "no partial results given");
    let first = &parts[0];
    let n = first.shard.1;
    for (p, file) in parts.iter().zip(&files) {
        check_count(p.shard).map_err(|e| IdentError::Input(format!("{}: {e}", file.display())))?;
    }
    ensure!(
        n == parts.len(),
        "missing shards: {} claims {n} shards, {} partial results given; give all N",
        files[0].display(),
        parts.len()
    );
    let mut seen = vec![false; n];
    for (p, file) in parts.iter().zip(&files) {
        ensure!(
            (1..=n).contains(&p.shard.0),
            "{}: shard {}/{}: need 1 <= I <= N",
            file.display(),
            p.shard.0,
            p.shard.1
        );
        ensure!(
            p.shard.1 == n && p.experiment == first.experiment,
            "partial results come from different runs ({} shard {}/{} vs {} shard {}/{})",
            first.experiment.display(),
            first.shard.0,
            n,
            p.experiment.display(),
            p.shard.0,
            p.shard.1
        );
        ensure!(!seen[p.shard.0 - 1], "shard {}/{n} given twice", p.shard.0);
        seen[p.shard.0 - 1] = true;
    }
    let missing: Vec<String> = (1..=n)
        .filter(|i| !seen[i - 1])
        .map(|i| i.to_string())
        .collect();
    ensure!(
        missing.is_empty(),
        "missing shards {} of {n}",
        missing.join(", ")
    );
    let exp = Experiment::load_in(source, &first.experiment)?;
    check_label(&exp, first.shard)
        .map_err(|e| IdentError::Input(format!("{}: {e}", files[0].display())))?;
    let opts = Options {
        auto_refine: false,
        local_refinement: first.local_refinement,
        threshold_mm2: first.threshold_mm2,
        top_n: first.top,
    };
    let stage_count = 1 + usize::from(exp.grids().1.is_some());
    for (p, file) in parts.iter().zip(&files) {
        ensure!(
            p.stages.len() == stage_count,
            "{}: {} stage(s), the experiment has {stage_count}",
            file.display(),
            p.stages.len()
        );
        ensure!(
            p.threshold_mm2 == opts.threshold_mm2
                && p.top == opts.top_n
                && p.local_refinement == opts.local_refinement,
            "{}: made with another threshold_mm2, top or local_refinement than {}",
            file.display(),
            files[0].display()
        );
        ensure!(
            digest(&exp, &opts, p.shard)? == p.digest,
            "{}: the experiment, its rig, its records, the options or the shard's label {}/{} \
             changed since this shard ran",
            file.display(),
            p.shard.0,
            p.shard.1
        );
        check_part(&exp, p, &opts)
            .map_err(|e| IdentError::Input(format!("{}: {e}", file.display())))?;
    }
    let start = Instant::now();
    // the time reported is the shards' search time added up, plus the merge's own
    let shard_seconds: f64 = parts.iter().map(|p| p.seconds).sum();
    let tops: Tops = files
        .iter()
        .zip(&parts)
        .map(|(f, p)| {
            (
                f.clone(),
                p.stages.iter().map(|s| s.summary.top.clone()).collect(),
            )
        })
        .collect();
    let mut stages: Vec<Stage> = Vec::new();
    for part in parts {
        for (i, stage) in part.stages.into_iter().enumerate() {
            match stages.get_mut(i) {
                Some(s) => s.summary = s.summary.clone().merge(stage.summary, opts.top_n),
                None => stages.push(stage),
            }
        }
    }
    verify_costs(&exp, &tops, &stages)?;
    let id = finish(&exp.problem, stages, &opts)?;
    Ok((exp, id, shard_seconds + start.elapsed().as_secs_f64()))
}

#[cfg(test)]
mod tests {
    use super::super::{Candidate, Grid};

    #[test]
    fn every_article_grid_point_survives_the_json_of_a_partial_result_exactly() {
        // the merge checks each winner against the grid point its index names, bit for bit:
        // JSON must give back the very same f64 (serde_json's float_roundtrip)
        for grid in [Grid::article_first(), Grid::article_refined()] {
            for index in 0..grid.len() {
                let c = grid.candidate(index);
                let back: Candidate =
                    serde_json::from_str(&serde_json::to_string(&c).unwrap()).unwrap();
                assert_eq!(back, c, "grid point {index}");
            }
        }
    }
}
