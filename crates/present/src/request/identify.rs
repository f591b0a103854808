//! The identification request: β, b and c12 from records by the two-stage grid search (the
//! article §2.4) or the frequency-domain fit, with their intervals when asked, from an
//! experiment file or from records given on a rig (docs/identification.md).

use super::{Document, FieldError, Given, Hooks, Request, RigInput};
use crate::frf::{fitted_curves, frequency_json, frequency_text, frf_svg, FitOrigin};
use crate::identification::{self as outputs, Found, Origin};
use crate::uncertainty::{profile_files, uncertainty_text};
use pumpcyl::ident::shards::{self, Partial};
use pumpcyl::ident::{
    self, analyze, finish, Candidate, Experiment, FrequencyFit, FrequencyProblem,
    FrequencyUncertainty, Grid, Identifiability, Identification, Method, Options, Problem,
    SecondGrid, Standstill, Uncertainty, UncertaintyOptions,
};
use pumpcyl::rig::Rig;
use pumpcyl::source_files::Files;
use serde_json::Value;
use std::time::Instant;

/// Where the records come from.
pub enum Source {
    /// An experiment file, loaded: its rig, records, grids, options and method.
    Experiment(Box<Experiment>),
    /// Records given on a rig at a standstill point (Python's datasets).
    Datasets(Box<Datasets>),
}

/// Records given on a rig, each loaded for its method.
pub struct Datasets {
    /// The rig they were taken on.
    pub rig: RigInput,
    /// The records.
    pub sets: Vec<ident::Loaded>,
    /// The standstill point the leakages are read at.
    pub standstill: Standstill,
    /// How they are fitted.
    pub method: Method,
}

/// The search over what the source gives: the grids, the options and the top list.
#[derive(Debug, Clone, Default)]
pub struct Search {
    /// The article's two grids (§2.4) instead of the source's.
    pub article_grids: bool,
    /// The first grid, over the source's.
    pub grid: Option<Grid>,
    /// The second stage over the source's: `Some(None)` for none.
    pub refined_grid: Option<Option<SecondGrid>>,
    /// Derive the second grid from the first stage's best.
    pub auto_refine: Option<bool>,
    /// Polish the best candidate locally.
    pub local_refinement: Option<bool>,
    /// The position MSE threshold of a plausible candidate (mm²).
    pub threshold_mm2: Option<f64>,
    /// The length of the top list.
    pub top: usize,
}

/// `identify`: the identification of the records of `source`.
pub struct Identify {
    /// The records.
    pub source: Source,
    /// The search.
    pub search: Search,
    /// The slice `I/N` of the grid search to run (an experiment file's only), merged later.
    pub shard: Option<(usize, usize)>,
    /// The confidence of the intervals, when they are analysed.
    pub uncertainty: Option<f64>,
    /// Whether a search beyond its limit may run.
    pub allow_long_run: bool,
    /// Where a shard's experiment file is read again.
    pub files: &'static dyn Files,
}

/// A time-domain problem with what its source gives.
struct Posed {
    problem: Problem,
    rig: Rig,
    origin: Origin,
    grids: (Grid, Option<SecondGrid>),
    options: Options,
    defaulted: Option<Vec<&'static str>>,
}

/// An identification.
pub enum IdentifyOutcome {
    /// The grid search's answer.
    Time(Box<TimeAnswer>),
    /// The frequency-domain fit.
    Frequency(Box<FrequencyAnswer>),
    /// A shard's partial result.
    Shard(Box<Partial>),
}

/// The grid search's answer with its document.
pub struct TimeAnswer {
    experiment: Option<Experiment>,
    id: Identification,
    seconds: f64,
    uncertainty: Option<(Uncertainty, f64)>,
    document: Value,
    verdicts: Option<[Identifiability; 3]>,
    warnings: Vec<String>,
}

/// The frequency-domain fit with its document.
pub struct FrequencyAnswer {
    experiment: Option<Experiment>,
    problem: FrequencyProblem,
    fit: FrequencyFit,
    seconds: f64,
    uncertainty: Option<(FrequencyUncertainty, f64)>,
    document: Value,
}

/// The rig's own values, the centre of a grid on it.
fn centre(rig: &Rig) -> Candidate {
    Candidate {
        beta_bar: rig.beta_bar,
        viscous_friction_ns_per_m: rig.viscous_friction_ns_per_m,
        c12_m5_per_ns: rig.c12_m5_per_ns,
    }
}

impl Search {
    /// The grids of the search over the source's `source`, `origin` told where they come from.
    fn grids(
        &self,
        source: &(Grid, Option<SecondGrid>),
        origin: &mut Origin,
    ) -> (Grid, Option<SecondGrid>) {
        let source = match self.article_grids {
            false => source.clone(),
            true => {
                origin.grids =
                    "first the article's first grid; second the article's refined grid".into();
                (Grid::article_first(), Some(Grid::article_refined().into()))
            }
        };
        if self.grid.is_some() || self.refined_grid.is_some() {
            origin.grids = format!(
                "{}; the `grid` and `refined_grid` arguments over it",
                origin.grids
            );
        }
        let first = self.grid.clone().unwrap_or(source.0);
        let second = self.refined_grid.clone().unwrap_or(source.1);
        (first, second)
    }

    /// The options of the search over the source's `file`.
    fn options(&self, file: &Options) -> Options {
        Options {
            auto_refine: self.auto_refine.unwrap_or(file.auto_refine),
            local_refinement: self.local_refinement.unwrap_or(file.local_refinement),
            threshold_mm2: self.threshold_mm2.unwrap_or(file.threshold_mm2),
            top_n: self.top,
        }
    }
}

impl Identify {
    fn method(&self) -> Method {
        match &self.source {
            Source::Experiment(exp) => exp.method,
            Source::Datasets(d) => d.method,
        }
    }

    /// Why a shard cannot run with this request, if it cannot: a shard is a slice of the
    /// grids an experiment file names, which the merge loads again
    /// (docs/identification.md#sharding).
    fn check_shard(&self) -> anyhow::Result<()> {
        let Some((i, n)) = self.shard else {
            return Ok(());
        };
        let search = &self.search;
        let problem = match &self.source {
            Source::Datasets(_) => Some("a shard needs an experiment file (the merge loads it again), not datasets"),
            _ if self.method() == Method::Frequency => Some("the frequency-domain fit is not sharded (it takes seconds)"),
            _ if search.article_grids || search.grid.is_some() || search.refined_grid.is_some() => Some(
                "a shard runs the experiment file's own grids: give them in the file, not as grids, grid or refined_grid",
            ),
            _ if search.auto_refine == Some(true) => Some(
                "a shard needs fixed grids: auto-refine derives the second grid from the first, so run that stage unsharded",
            ),
            _ if self.uncertainty.is_some() => Some("the uncertainty is analysed on the merged answer, not on a shard"),
            _ => None,
        };
        if let Some(problem) = problem {
            return Err(FieldError::new("shard", Given::Shard(i, n), problem).into());
        }
        if let Source::Experiment(exp) = &self.source {
            shards::check_label(exp, (i, n))?;
        }
        Ok(())
    }

    /// The grids and options the source gives: an experiment file's, or for records on a rig
    /// the first grid centred on the rig's values and the second on the first stage's best.
    fn source_search(&self) -> anyhow::Result<((Grid, Option<SecondGrid>), Options)> {
        Ok(match &self.source {
            Source::Experiment(exp) => (exp.grids(), exp.options()),
            Source::Datasets(d) => {
                let first = Grid::centred(&centre(&d.rig.rig))?;
                ((first, Some(SecondGrid::Centred)), Options::default())
            }
        })
    }

    /// The time-domain problem of the source.
    fn posed(&self) -> anyhow::Result<Posed> {
        let (grids, options) = self.source_search()?;
        Ok(match &self.source {
            Source::Experiment(exp) => Posed {
                problem: exp.problem.clone(),
                rig: exp.rig.clone(),
                origin: Origin::of_experiment(exp),
                grids,
                options,
                defaulted: exp.rig_defaulted_keys().map(<[_]>::to_vec),
            },
            Source::Datasets(d) => {
                let datasets = (d.sets.iter())
                    .map(|l| match l {
                        ident::Loaded::Step(p) => Ok((**p).clone()),
                        ident::Loaded::Sweep(_) => Err(anyhow::anyhow!(
                            "a sweep is fitted with method=\"frequency\""
                        )),
                    })
                    .collect::<anyhow::Result<_>>()?;
                Posed {
                    problem: Problem {
                        datasets,
                        standstill: d.standstill,
                    },
                    rig: d.rig.rig.clone(),
                    origin: Origin {
                        experiment: None,
                        rig: d.rig.name.clone(),
                        grids: "first centred on the rig's values; second centred on the first stage's best".into(),
                    },
                    grids,
                    options,
                    defaulted: d.rig.defaulted.clone(),
                }
            }
        })
    }

    /// The experiment file of the source, if any.
    fn experiment(&self) -> Option<Experiment> {
        match &self.source {
            Source::Experiment(exp) => Some((**exp).clone()),
            Source::Datasets(_) => None,
        }
    }

    /// The time-domain search and its answer (or a shard's partial result).
    fn time(&self, hooks: Hooks<'_>) -> anyhow::Result<IdentifyOutcome> {
        let posed = self.posed()?;
        let mut origin = posed.origin.clone();
        let grids = self.search.grids(&posed.grids, &mut origin);
        let opts = self.search.options(&posed.options);
        let request = ident::Request {
            allow_long_run: self.allow_long_run,
            shard: self.shard,
            ..ident::Request::new(&posed.problem, grids, opts)
        };
        request.check().map_err(|e| match e {
            ident::IdentError::Limit(l) => anyhow::Error::from(l),
            e => e.into(),
        })?;
        let start = Instant::now();
        let stages = request.search(hooks.tick)?;
        if let (Some(label), Source::Experiment(exp)) = (self.shard, &self.source) {
            let seconds = start.elapsed().as_secs_f64();
            let part = Partial::of_search(self.files, &exp.path, &opts, label, seconds, stages)?;
            return Ok(IdentifyOutcome::Shard(Box::new(part)));
        }
        let id = finish(&posed.problem, stages, &opts)?;
        let seconds = start.elapsed().as_secs_f64();
        let uncertainty = (self.uncertainty)
            .map(|confidence| {
                let start = Instant::now();
                let opts = UncertaintyOptions {
                    confidence,
                    ..UncertaintyOptions::default()
                };
                let u = analyze(&posed.problem, &id.best().candidate, &opts)?;
                Ok::<_, ident::IdentError>((u, start.elapsed().as_secs_f64()))
            })
            .transpose()?;
        let found = Found {
            problem: &posed.problem,
            rig: &posed.rig,
            origin: &origin,
            id: &id,
            seconds,
            uncertainty: uncertainty.as_ref(),
            defaulted: posed.defaulted.as_deref(),
        };
        let (document, verdicts) = outputs::identification_report(&found)?;
        Ok(IdentifyOutcome::Time(Box::new(TimeAnswer {
            experiment: self.experiment(),
            warnings: id.warnings(),
            id,
            seconds,
            uncertainty,
            document,
            verdicts,
        })))
    }

    /// The frequency-domain problem, its first grid and where they come from.
    fn frequency_problem(&self) -> anyhow::Result<(FrequencyProblem, Grid, FitOrigin)> {
        let (problem, grid, experiment, grids) = match &self.source {
            Source::Experiment(exp) => {
                let problem = (exp.frequency_problem()).ok_or_else(|| {
                    anyhow::anyhow!("the experiment is not fitted in the frequency domain")
                })?;
                (
                    problem,
                    exp.first_grid.clone(),
                    exp.path.display().to_string(),
                    exp.grids_origin.clone(),
                )
            }
            Source::Datasets(d) => {
                let problem = FrequencyProblem::of_loaded(d.sets.clone(), d.standstill)?;
                let grid = Grid::centred(&centre(&d.rig.rig))?;
                let experiment = format!("datasets on {}", d.rig.name);
                (
                    problem,
                    grid,
                    experiment,
                    "first centred on the rig's values".into(),
                )
            }
        };
        let origin = FitOrigin {
            experiment,
            grids,
            step_datasets: problem.step_names(),
        };
        Ok((problem, self.search.grid.clone().unwrap_or(grid), origin))
    }

    /// The frequency-domain fit and its intervals when asked.
    fn frequency(&self) -> anyhow::Result<IdentifyOutcome> {
        let (problem, grid, origin) = self.frequency_problem()?;
        let start = Instant::now();
        let fit = problem.fit(&grid)?;
        let seconds = start.elapsed().as_secs_f64();
        let uncertainty = (self.uncertainty)
            .map(|confidence| {
                let start = Instant::now();
                let u = problem.uncertainty(&fit, confidence)?;
                Ok::<_, ident::IdentError>((u, start.elapsed().as_secs_f64()))
            })
            .transpose()?;
        let u = uncertainty.as_ref().map(|(u, s)| (u, *s));
        let document = frequency_json(&origin, &fit, seconds, u);
        Ok(IdentifyOutcome::Frequency(Box::new(FrequencyAnswer {
            experiment: self.experiment(),
            problem,
            fit,
            seconds,
            uncertainty,
            document,
        })))
    }
}

impl Request for Identify {
    type Outcome = IdentifyOutcome;

    fn work(&self) -> Option<(u64, &'static str)> {
        if self.method() == Method::Frequency {
            return None;
        }
        // the grids alone count the work: no problem posed, and this shard's share
        let (grids, options) = self.source_search().ok()?;
        let mut words = Origin {
            experiment: None,
            rig: String::new(),
            grids: String::new(),
        };
        let grids = self.search.grids(&grids, &mut words);
        let options = self.search.options(&options);
        Some((
            ident::candidates(&grids, &options, self.shard),
            "candidates",
        ))
    }

    fn run(&self, hooks: Hooks<'_>) -> anyhow::Result<IdentifyOutcome> {
        if let Some(confidence) = self.uncertainty {
            super::check_confidence(confidence)?;
        }
        self.check_shard()?;
        match self.method() {
            Method::Frequency => self.frequency(),
            Method::Time => self.time(hooks),
        }
    }
}

/// `identify-merge`: the partial results of every shard of one experiment's grid search,
/// merged into the answer of one run (docs/identification.md#sharding).
pub struct Merge {
    /// Each shard's partial result and where it came from (a file, or Python's `shards[k]`).
    pub parts: Vec<(std::path::PathBuf, Partial)>,
    /// Where the experiment file is read again.
    pub files: &'static dyn Files,
}

impl Request for Merge {
    type Outcome = IdentifyOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<IdentifyOutcome> {
        let (exp, id, seconds) = shards::merge(self.files, self.parts.clone())?;
        let origin = Origin::of_experiment(&exp);
        let (document, verdicts) =
            outputs::identification_report(&Found::of_experiment(&exp, &origin, &id, seconds))?;
        Ok(IdentifyOutcome::Time(Box::new(TimeAnswer {
            experiment: Some(exp),
            warnings: id.warnings(),
            id,
            seconds,
            uncertainty: None,
            document,
            verdicts,
        })))
    }
}

/// The text of an identification names its experiment file.
fn named(experiment: &Option<Experiment>) -> anyhow::Result<&Experiment> {
    (experiment.as_ref()).ok_or_else(|| anyhow::anyhow!("the text of an identification names its experiment file; records given as datasets have only its document"))
}

impl IdentifyOutcome {
    /// The files of its result folder (docs/identification.md#result-folders): result.json and
    /// the figures.
    ///
    /// # Errors
    /// A figure that cannot be drawn, a shard (whose partial result is one file), or records
    /// given as datasets.
    pub fn files(&self) -> anyhow::Result<Vec<(String, Vec<u8>)>> {
        let result = |v: &Value| {
            Ok::<_, anyhow::Error>((
                "result.json".to_string(),
                (serde_json::to_string_pretty(v)? + "\n").into_bytes(),
            ))
        };
        match self {
            IdentifyOutcome::Time(a) => {
                let mut files = outputs::files(named(&a.experiment)?, &a.id, &a.document)?;
                if let Some((u, _)) = &a.uncertainty {
                    files.extend(profile_files(u)?);
                }
                Ok(files)
            }
            IdentifyOutcome::Frequency(a) => {
                let mut files = vec![result(&a.document)?];
                let curves = fitted_curves(&a.problem, &a.fit);
                for (k, (s, curve)) in a.problem.sweeps.iter().zip(&curves).enumerate() {
                    let svg =
                        frf_svg(&s.estimate, curve.as_ref()).map_err(|e| anyhow::anyhow!(e))?;
                    files.push((format!("fit-{}.svg", k + 1), svg.into_bytes()));
                }
                Ok(files)
            }
            IdentifyOutcome::Shard(_) => anyhow::bail!("a shard's partial result is one file"),
        }
    }

    /// A shard's partial result.
    pub fn partial(&self) -> Option<&Partial> {
        match self {
            IdentifyOutcome::Shard(p) => Some(p),
            _ => None,
        }
    }
}

impl Document for IdentifyOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(match self {
            IdentifyOutcome::Time(a) => a.document.clone(),
            IdentifyOutcome::Frequency(a) => a.document.clone(),
            IdentifyOutcome::Shard(p) => serde_json::to_value(p)?,
        })
    }

    fn text(&self) -> anyhow::Result<String> {
        match self {
            IdentifyOutcome::Time(a) => {
                let exp = named(&a.experiment)?;
                let mut text =
                    outputs::identification_text(exp, &a.id, a.seconds, a.verdicts.as_ref());
                if let Some((u, s)) = &a.uncertainty {
                    text += &uncertainty_text(u, *s);
                }
                Ok(text)
            }
            IdentifyOutcome::Frequency(a) => {
                let u = a.uncertainty.as_ref().map(|(u, s)| (u, *s));
                Ok(frequency_text(named(&a.experiment)?, &a.fit, a.seconds, u))
            }
            IdentifyOutcome::Shard(p) => Ok(format!("shard {}/{}\n", p.shard.0, p.shard.1)),
        }
    }

    fn warnings(&self) -> &[String] {
        match self {
            IdentifyOutcome::Time(a) => &a.warnings,
            IdentifyOutcome::Frequency(a) => &a.fit.warnings,
            IdentifyOutcome::Shard(_) => &[],
        }
    }
}
