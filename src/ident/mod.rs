//! Parameter identification from measured data (SPEC §6): drive gain from a velocity step,
//! chamber leakages from a standstill record, and the two-stage grid search for β, b and c12
//! with a local refinement.

mod drive;
mod experiment;
mod grid;
mod leakage;
mod problem;
mod refine;
mod search;
mod uncertainty;

pub use drive::{identify_drive, DriveFit, DriveRecord};
pub use experiment::{Experiment, ExperimentFile};
pub use grid::{spaced, stepped, Candidate, Grid};
pub use leakage::{Leakage, Standstill};
pub use problem::{DatasetSpec, Prepared, Problem};
pub use refine::refine;
pub use search::{search, shard_len, Scored, SearchOptions, Summary, MEMBERS_KEPT};
pub use uncertainty::{
    analyze, chi2_1_quantile, Profile, ProfilePoint, Uncertainty, UncertaintyOptions, BOUNDS,
    PARAMETERS,
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
}

/// Run the search stages (both grids; the second derived from the first with `auto_refine`).
pub fn run_stages(
    problem: &Problem,
    grids: (Grid, Option<Grid>),
    opts: &Options,
    shard: Option<(usize, usize)>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<Stage>, IdentError> {
    let search_opts = SearchOptions {
        top_n: opts.top_n,
        threshold_mm2: opts.threshold_mm2,
        shard,
    };
    let (first, second) = grids;
    let s1 = search(problem, &first, 1, search_opts, progress);
    let second = match (opts.auto_refine, second) {
        (true, _) => {
            let bounds = s1.threshold_bounds.ok_or_else(|| {
                IdentError::Input(format!(
                    "--auto-refine: no stable candidate of the first grid costs less than {} mm²; \
                     raise threshold_mm2 or give a refined grid",
                    opts.threshold_mm2
                ))
            })?;
            Some(Grid::refined_from(&first, &bounds))
        }
        (false, g) => g,
    };
    let mut stages = vec![Stage {
        grid: first,
        summary: s1,
    }];
    if let Some(grid) = second {
        let summary = search(problem, &grid, 2, search_opts, progress);
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
