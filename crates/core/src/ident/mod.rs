//! Parameter identification from measured data (the article §2.4; docs/identification.md): drive gain from a velocity step,
//! chamber leakages from a standstill record, and the two-stage grid search for β, b and c12
//! with a local refinement.
//!
//! Identify β, b and c12 from the emulated article records (whose truth is β_e ≈ 165 bar,
//! c12 = 1.2e-10 m⁵/(N·s)) on a small grid of your own (docs/identification.md):
//!
//! ```
//! use pumpcyl::ident::{finish, run_stages, Experiment, Grid, Options};
//! use std::path::Path;
//!
//! let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/article/identify.toml");
//! let exp = Experiment::load(&file)?; // the records, the standstill point, the rig
//! let grid = Grid {
//!     beta_bar: vec![100.0, 165.0, 250.0],
//!     viscous_friction_ns_per_m: vec![100.0, 300.0],
//!     c12_m5_per_ns: vec![1.2e-10],
//! };
//! let opts = Options {
//!     auto_refine: false,
//!     local_refinement: false,
//!     threshold_mm2: 0.25,
//!     top_n: 3,
//! };
//! let stages = run_stages(&exp.problem, (grid, None), &opts, None, &|_| {})?;
//! let id = finish(&exp.problem, stages, &opts)?;
//! assert_eq!(id.evaluated(), 6);
//! assert_eq!(id.best().candidate.beta_bar, 165.0);
//! // c1 from the standstill record for that c12: the emulator's 5.49e-11 within 1 %
//! assert!((id.leakage.c1_m5_per_ns / 5.49e-11 - 1.0).abs() < 0.01);
//! # Ok::<(), pumpcyl::ident::IdentError>(())
//! ```

mod advice;
mod drive;
mod experiment;
mod frequency;
mod grid;
mod leakage;
mod level;
mod nonlinear;
mod problem;
mod refine;
mod search;
pub mod shards;
mod uncertainty;

pub use advice::{
    advise, advise_experiment, default_designs, designs_for, designs_from_toml, gram,
    sweep_information, widths, Advice, AdviceOptions, Assessment, Design, Width,
    DEFAULT_DURATION_S, DEFAULT_FREQS_HZ, DEFAULT_KP_FACTORS, DEFAULT_MAX_AMP_MM, DEFAULT_STEPS_MM,
    LOG_STEP, MAX_CANDIDATES, MIN_DAMPING, MIN_SAMPLES_PER_PERIOD, REST_S,
};
pub use drive::{identify_drive, DriveFit, DriveRecord};
pub use experiment::{DatasetEntry, Experiment, ExperimentFile, Method, RigDefaults};
pub use frequency::Loaded;
pub use frequency::{
    FrequencyFit, FrequencyProblem, FrequencyUncertainty, Scales, SweepSet, SweepSummary,
    MODEL_ERROR_SCALE,
};
pub use grid::{
    candidate_values, spaced, stepped, Candidate, Grid, SecondGrid, FIRST_AXES, SECOND_COUNTS,
};
pub use leakage::{standstill_warnings, Leakage, Standstill, STANDSTILL_SPREAD_MM};
pub use level::{identify_level, LevelReading};
pub use nonlinear::{refine_nonlinear, LevelBeta, NonlinearFit, Refined, Source};
pub use problem::{DatasetSpec, Prepared, Problem};
pub use refine::refine;
pub use search::{search, shard_len, Scored, SearchOptions, Summary, MEMBERS_KEPT};
pub use uncertainty::{
    analyze, at_bound_reason, check_confidence, chi2_1_quantile, identifiability, normal_quantile,
    search_bound_at, Identifiability, Profile, ProfilePoint, Uncertainty, UncertaintyOptions,
    AT_BOUND, BOUNDS, FLAT_FACTOR, PARAMETERS,
};

use serde::{Deserialize, Serialize};

/// Errors of the identification.
#[derive(Debug, thiserror::Error)]
pub enum IdentError {
    /// Bad experiment description or values.
    #[error("{0}")]
    Input(String),
    /// A record that cannot be used.
    #[error(transparent)]
    Record(#[from] crate::record::RecordError),
    /// A rig that cannot be used.
    #[error(transparent)]
    Rig(#[from] crate::rig::RigError),
    /// A numerical failure.
    #[error(transparent)]
    Lti(#[from] crate::lti::LtiError),
    /// A size or an amount of work beyond its limit.
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
    /// The caller stopped the search (see [`run_stages_while`]).
    #[error("identification interrupted")]
    Interrupted,
}

/// Options of the two-stage search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Derive the second grid from the first grid's threshold set.
    pub auto_refine: bool,
    /// Nelder–Mead from the best grid point.
    pub local_refinement: bool,
    /// Threshold of the threshold set (mm²).
    pub threshold_mm2: f64,
    /// Length of the reported top list.
    pub top_n: usize,
}

impl Options {
    /// Refuse options that cannot run: a threshold that is not a positive number, an empty top
    /// list.
    pub fn validate(&self) -> Result<(), IdentError> {
        if !(self.threshold_mm2.is_finite() && self.threshold_mm2 > 0.0) {
            return Err(IdentError::Input(format!(
                "threshold_mm2 = {}: must be > 0",
                self.threshold_mm2
            )));
        }
        if self.top_n < 1 {
            return Err(IdentError::Input("top: must be at least 1".into()));
        }
        Ok(())
    }
}

impl Default for Options {
    /// The article's search: the two given grids, threshold 0.25 mm², Nelder–Mead after them,
    /// a top list of 20 (docs/identification.md#the-two-grids).
    fn default() -> Self {
        Options {
            auto_refine: false,
            local_refinement: true,
            threshold_mm2: 0.25,
            top_n: 20,
        }
    }
}

/// One stage of the search: its grid and what it found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stage {
    /// The grid.
    pub grid: Grid,
    /// The result (over the whole grid, or over one shard).
    pub summary: Summary,
}

/// The answer of an identification.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Identification {
    /// The stages.
    pub stages: Vec<Stage>,
    /// Best grid point.
    pub grid_best: Scored,
    /// Result of the local refinement, when it improved on the grid.
    pub refined: Option<Scored>,
    /// The leakages of the final answer.
    pub leakage: Leakage,
    /// Top list over all stages, best first.
    pub top: Vec<Scored>,
}

impl Identification {
    /// The final answer: the refined point if there is one, else the best grid point.
    pub fn best(&self) -> &Scored {
        self.refined.as_ref().unwrap_or(&self.grid_best)
    }

    /// Candidates evaluated over all stages (the local refinement not counted).
    pub fn evaluated(&self) -> u64 {
        self.stages.iter().map(|s| s.summary.evaluated).sum()
    }

    /// For each parameter (in the order of [`PARAMETERS`]), the range of its axis in the grid
    /// of the best grid point's stage when that point lies on the axis's lowest or highest
    /// value (the optimum may lie outside the grid), else `None`.
    pub fn grid_best_edges(&self) -> [Option<(f64, f64)>; 3] {
        let best = &self.grid_best;
        match self.stages.get(usize::from(best.stage.max(1)) - 1) {
            Some(stage) => stage.grid.edges_at(&best.candidate),
            None => [None; 3],
        }
    }

    /// Whether the local refinement's answer has parameter `i` strictly inside (lo, hi).
    fn polished_inside(&self, i: usize, (lo, hi): (f64, f64)) -> bool {
        (self.refined.as_ref())
            .map(|r| grid::candidate_values(&r.candidate)[i])
            .is_some_and(|v| lo < v && v < hi)
    }

    /// What a user should know before trusting the answer: each stage's best on an edge of
    /// that stage's grid (the optimum may lie outside it; a later stage centred on it reaches
    /// beyond; not said of the last stage where the local refinement's answer lies inside its
    /// range), and a search where every candidate of the top list costs the same (the
    /// records carry no excitation: the reference never moves the loop, so the cost cannot
    /// tell the parameters apart).
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let [first, .., last] = self.top.as_slice() {
            if (last.cost_mm2 - first.cost_mm2).abs() <= 1e-12 * first.cost_mm2.abs().max(1e-300) {
                out.push(format!(
                    "every candidate of the top {} costs the same ({:.4e} mm²): the records carry no excitation \
                     (does the reference step?), so the answer means nothing",
                    self.top.len(),
                    first.cost_mm2
                ));
                return out;
            }
        }
        for (k, stage) in self.stages.iter().enumerate() {
            let Some(best) = stage.summary.top.first() else {
                continue;
            };
            let values = grid::candidate_values(&best.candidate);
            let later = self.stages.get(k + 1).map(|s| &s.grid);
            for (i, range) in stage.grid.edges_at(&best.candidate).into_iter().enumerate() {
                let Some((lo, hi)) = range else { continue };
                let beyond = later.is_some_and(|g| g.straddles(i, values[i]));
                if later.is_none() && self.polished_inside(i, (lo, hi)) {
                    // the local refinement found the optimum inside the last grid's range
                    continue;
                }
                let what = if beyond {
                    format!("the grid of stage {} reaches beyond it", k + 2)
                } else {
                    "the optimum may lie outside it; widen that axis ([ranges] or the grids of \
                     the experiment)"
                        .to_string()
                };
                out.push(format!(
                    "the best grid point has {} = {} on the edge of the stage {} grid ({} … {}): \
                     {what}",
                    PARAMETERS[i],
                    grid::short(values[i]),
                    k + 1,
                    grid::short(lo),
                    grid::short(hi)
                ));
            }
        }
        out
    }
}

/// One identification to run (docs/identification.md): the problem, its grids, the options,
/// and how it may run. Every front end runs an identification through this: [`Request::check`]
/// refuses options that cannot run and work that would take hours unless allowed,
/// [`Request::search`] runs the stages and [`Request::run`] adds [`finish`].
#[derive(Debug, Clone)]
pub struct Request<'a> {
    /// The records and the standstill point.
    pub problem: &'a Problem,
    /// The first grid and the second (derived from the first with `auto_refine`).
    pub grids: (Grid, Option<SecondGrid>),
    /// The search options.
    pub options: Options,
    /// Evaluate only slice I of N (1-based) of the grids, for a partial result.
    pub shard: Option<(usize, usize)>,
    /// Run even when the grids times the records exceed
    /// [`MAX_CANDIDATE_SAMPLES`](crate::limits::MAX_CANDIDATE_SAMPLES).
    pub allow_long_run: bool,
}

/// The candidates a search on `grids` with `options` evaluates (of the shard `shard`, if
/// any): the total a progress report counts, known before the problem is posed.
pub fn candidates(
    grids: &(Grid, Option<SecondGrid>),
    options: &Options,
    shard: Option<(usize, usize)>,
) -> u64 {
    let second = match &grids.1 {
        Some(SecondGrid::Given(g)) if !options.auto_refine => g.len(),
        Some(_) => SecondGrid::centred_len(),
        None => 0,
    };
    shard_len(grids.0.len() + second, shard) as u64
}

impl<'a> Request<'a> {
    /// The identification of `problem` on `grids` with `options`, whole, within the work limit.
    pub fn new(problem: &'a Problem, grids: (Grid, Option<SecondGrid>), options: Options) -> Self {
        Request {
            problem,
            grids,
            options,
            shard: None,
            allow_long_run: false,
        }
    }

    /// The candidates the search evaluates (of this shard): the total for a progress report.
    pub fn candidates(&self) -> u64 {
        candidates(&self.grids, &self.options, self.shard)
    }

    /// The samples of the records, all of them (each candidate simulates every record).
    fn record_samples(&self) -> usize {
        self.problem.datasets.iter().map(|d| d.record.len()).sum()
    }

    /// Refuse options that cannot run, a shard with a derived second grid, and work beyond the
    /// limit unless a long run is allowed.
    pub fn check(&self) -> Result<(), IdentError> {
        self.options.validate()?;
        if self.problem.datasets.is_empty() {
            return Err(IdentError::Input(
                "no step record to fit in the time domain: the records are sweeps, fitted \
                 with the frequency method (identify --frequency)"
                    .into(),
            ));
        }
        if self.shard.is_some() && self.options.auto_refine {
            return Err(IdentError::Input(
                "a shard needs fixed grids: auto-refine derives the second grid from the \
                 first, so run that stage unsharded"
                    .into(),
            ));
        }
        if self.shard.is_some() && self.grids.1 == Some(SecondGrid::Centred) {
            return Err(IdentError::Input(
                "a shard needs fixed grids: the second grid is centred on the first stage's \
                 best, so give `refined_grid` in the experiment or run unsharded"
                    .into(),
            ));
        }
        crate::limits::check_work(
            "identify: the grids' candidates times the records' samples",
            self.candidates() as f64 * self.record_samples() as f64,
            crate::limits::MAX_CANDIDATE_SAMPLES,
            self.allow_long_run,
        )?;
        Ok(())
    }

    /// [`Request::check`], then the search stages; `progress(n)` after each chunk of n
    /// candidates, the search stopping soon after it returns `false`
    /// ([`IdentError::Interrupted`]).
    pub fn search(
        &self,
        progress: &(dyn Fn(u64) -> bool + Sync),
    ) -> Result<Vec<Stage>, IdentError> {
        self.check()?;
        run_stages_while(
            self.problem,
            self.grids.clone(),
            &self.options,
            self.shard,
            progress,
        )
    }

    /// The whole identification: [`Request::search`], then [`finish`].
    pub fn run(
        &self,
        progress: &(dyn Fn(u64) -> bool + Sync),
    ) -> Result<Identification, IdentError> {
        let stages = self.search(progress)?;
        finish(self.problem, stages, &self.options)
    }
}

/// Run the search stages (both grids; the second derived from the first with `auto_refine`).
pub fn run_stages(
    problem: &Problem,
    grids: (Grid, Option<SecondGrid>),
    opts: &Options,
    shard: Option<(usize, usize)>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<Stage>, IdentError> {
    run_stages_while(problem, grids, opts, shard, &|n| {
        progress(n);
        true
    })
}

/// [`run_stages`], stoppable: `progress(n)` is called after each chunk of n candidates and the
/// search stops soon after it returns `false`, with [`IdentError::Interrupted`] (for callers
/// that watch for an interrupt, such as the Python package on Ctrl-C).
pub fn run_stages_while(
    problem: &Problem,
    grids: (Grid, Option<SecondGrid>),
    opts: &Options,
    shard: Option<(usize, usize)>,
    progress: &(dyn Fn(u64) -> bool + Sync),
) -> Result<Vec<Stage>, IdentError> {
    let stopped = std::sync::atomic::AtomicBool::new(false);
    let progress = |n: u64| {
        let go_on = progress(n);
        if !go_on {
            stopped.store(true, std::sync::atomic::Ordering::Relaxed);
        }
        go_on
    };
    let check = || {
        if stopped.load(std::sync::atomic::Ordering::Relaxed) {
            Err(IdentError::Interrupted)
        } else {
            Ok(())
        }
    };
    let search_opts = SearchOptions {
        top_n: opts.top_n,
        threshold_mm2: opts.threshold_mm2,
        shard,
    };
    let (first, second) = grids;
    let s1 = search(problem, &first, 1, search_opts, &progress);
    check()?;
    let second = match (opts.auto_refine, second) {
        (false, Some(SecondGrid::Centred)) => {
            let best = s1.top.first().ok_or_else(|| {
                IdentError::Input(
                    "the first grid has no stable candidate with a finite cost to centre the \
                     second grid on: check the records, gains and grids"
                        .into(),
                )
            })?;
            Some(Grid::around(&first, &best.candidate))
        }
        (true, _) => {
            let bounds = s1.threshold_bounds.ok_or_else(|| {
                IdentError::Input(format!(
                    "auto-refine: no stable candidate of the first grid costs less than {} mm²; \
                     raise threshold_mm2 or give a refined grid",
                    opts.threshold_mm2
                ))
            })?;
            Some(Grid::refined_from(&first, &bounds))
        }
        (false, Some(SecondGrid::Given(g))) => Some(g),
        (false, None) => None,
    };
    let mut stages = vec![Stage {
        grid: first,
        summary: s1,
    }];
    if let Some(grid) = second {
        let summary = search(problem, &grid, 2, search_opts, &progress);
        check()?;
        stages.push(Stage { grid, summary });
    }
    Ok(stages)
}

/// Combine the stages into the answer: the best grid point, refined locally if asked.
pub fn finish(
    problem: &Problem,
    stages: Vec<Stage>,
    opts: &Options,
) -> Result<Identification, IdentError> {
    let mut top: Vec<Scored> = stages
        .iter()
        .flat_map(|s| s.summary.top.iter().copied())
        .collect();
    top.sort_by(|a, b| {
        a.cost_mm2
            .total_cmp(&b.cost_mm2)
            .then(a.stage.cmp(&b.stage))
            .then(a.index.cmp(&b.index))
    });
    top.truncate(opts.top_n);
    let grid_best = *top.first().ok_or_else(|| {
        IdentError::Input(
            "no stable candidate with a finite cost: check the records, gains and grids".into(),
        )
    })?;
    let refined = if opts.local_refinement {
        refine(problem, &grid_best.candidate).map(|(candidate, cost_mm2)| Scored {
            candidate,
            cost_mm2,
            stage: 0,
            index: 0,
        })
    } else {
        None
    };
    let best = refined.unwrap_or(grid_best);
    let leakage = problem
        .standstill
        .leakage(&problem.datasets[0].rig, best.candidate.c12_m5_per_ns)?;
    Ok(Identification {
        stages,
        grid_best,
        refined,
        leakage,
        top,
    })
}
