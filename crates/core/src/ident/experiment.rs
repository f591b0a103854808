//! The experiment file of `pumpcyl identify`: rig, overrides, standstill point, datasets and
//! optional grids, in TOML. Paths are relative to the experiment file.

use super::grid::Grid;
use super::leakage::Standstill;
use super::problem::{DatasetSpec, Prepared, Problem};
use super::IdentError;
use crate::input::{self, Key, Key::Index, Key::Name};
use crate::record::Record;
use crate::rig::Rig;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

fn default_threshold() -> f64 {
    0.25
}

fn yes() -> bool {
    true
}

/// The experiment file as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentFile {
    /// Rig description file; absent = the embedded article rig.
    pub rig: Option<String>,
    /// Rig key overrides (same keys as the rig TOML).
    #[serde(default)]
    pub set: toml::Table,
    /// Standstill point for c1, c2 (the article §2.3.2, §2.4; docs/identification.md#leakage-from-standstill).
    pub standstill: StandstillSpec,
    /// The records to fit, at least one.
    pub dataset: Vec<DatasetSpec>,
    /// First grid; absent = the article's (3264 candidates).
    pub grid: Option<Grid>,
    /// Second grid; absent = the article's refined grid (3553), unless auto-refined.
    pub refined_grid: Option<Grid>,
    /// Threshold of the threshold set (mm²).
    #[serde(default = "default_threshold")]
    pub threshold_mm2: f64,
    /// Derive the second grid from the first grid's threshold set.
    #[serde(default)]
    pub auto_refine: bool,
    /// Nelder–Mead refinement from the best grid point.
    #[serde(default = "yes")]
    pub local_refinement: bool,
}

/// The standstill point as written: its three values, or a record to average.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StandstillSpec {
    /// A standstill record (docs/formats.md#record-csv with `w1_rpm`, `w2_rpm`, `p1_bar`), averaged.
    pub record: Option<String>,
    /// Motor/pump 1 speed (rpm).
    pub w1_rpm: Option<f64>,
    /// Motor/pump 2 speed (rpm).
    pub w2_rpm: Option<f64>,
    /// Chamber 1 pressure (bar gauge).
    pub p1_bar: Option<f64>,
}

/// Errors of an experiment file, located by key path.
struct Locate<'a> {
    /// The file name.
    name: &'a str,
    /// Its text.
    text: &'a str,
}

impl Locate<'_> {
    /// `FILE: line L, message`, the line being that of the key at `path` (or of the deepest
    /// table on it that is written).
    fn error(&self, path: &[Key], message: impl std::fmt::Display) -> IdentError {
        let line =
            input::toml_line(self.text, path).map_or(String::new(), |l| format!("line {l}, "));
        IdentError::Input(format!("{}: {line}{message}", self.name))
    }
}

impl ExperimentFile {
    /// The rig: the named file or the embedded default, with `[set]` applied.
    fn rig(&self, files: &dyn input::Files, dir: &Path, at: &Locate) -> Result<Rig, IdentError> {
        let base = match &self.rig {
            Some(r) => {
                Rig::from_file_in(files, &dir.join(r)).map_err(|e| at.error(&[Name("rig")], e))?
            }
            None => Rig::default(),
        };
        let assignment = |(k, v): (&String, &toml::Value)| format!("{k}={v}");
        // each key alone first, so an unknown key or a wrong type is found on its own line
        for (k, v) in &self.set {
            if let Err(e @ crate::rig::RigError::Set { .. }) =
                base.with_overrides_from("[set]", &[assignment((k, v))])
            {
                return Err(at.error(&[Name("set"), Name(k)], e));
            }
        }
        let all: Vec<String> = self.set.iter().map(assignment).collect();
        base.with_overrides_from("[set]", &all).map_err(|e| {
            let key = match &e {
                crate::rig::RigError::Invalid { key, .. } => key,
                _ => "",
            };
            at.error(&[Name("set"), Name(key)], e)
        })
    }

    /// Dataset `i`, its record read and prepared.
    fn dataset(
        &self,
        files: &dyn input::Files,
        i: usize,
        dir: &Path,
        rig: &Rig,
        at: &Locate,
    ) -> Result<Prepared, IdentError> {
        let spec = &self.dataset[i];
        let key = |k| [Name("dataset"), Index(i), Name(k)];
        let what = format!("dataset {} (`{}`)", i + 1, spec.file);
        let record = Record::read_in(files, &dir.join(&spec.file))
            .map_err(|e| at.error(&key("file"), format!("{what}: {e}")))?;
        for (k, v) in [("kp", spec.kp), ("mass_kg", spec.mass_kg)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(at.error(&key(k), format!("{what}: {k} = {v}: must be > 0")));
            }
            if let Some(rule) = Rig::check_key(k, v) {
                let v = crate::units::readable(v);
                return Err(at.error(&key(k), format!("{what}: {k} = {v}: {rule}")));
            }
        }
        Prepared::new(spec, record, rig).map_err(|e| at.error(&key("fit_end_s"), e))
    }
}

impl StandstillSpec {
    /// The standstill point: the record's means, or the three values.
    fn resolve(&self, files: &dyn input::Files, dir: &Path) -> Result<Standstill, IdentError> {
        let values = [self.w1_rpm, self.w2_rpm, self.p1_bar];
        match (&self.record, values) {
            (Some(file), [None, None, None]) => {
                Standstill::of_record(&Record::read_in(files, &dir.join(file))?)
            }
            (Some(_), _) => Err(IdentError::Input(
                "[standstill]: give either `record` or `w1_rpm`, `w2_rpm`, `p1_bar`, not both"
                    .into(),
            )),
            (None, [Some(w1_rpm), Some(w2_rpm), Some(p1_bar)]) => Ok(Standstill {
                w1_rpm,
                w2_rpm,
                p1_bar,
            }),
            (None, _) => Err(IdentError::Input(
                "[standstill]: needs `record = \"FILE.csv\"` or all of `w1_rpm`, `w2_rpm`, `p1_bar`"
                    .into(),
            )),
        }
    }
}

/// A loaded experiment: the file, where it lives, the rig and the prepared problem.
#[derive(Debug, Clone)]
pub struct Experiment {
    /// The experiment file path.
    pub path: PathBuf,
    /// Its contents.
    pub file: ExperimentFile,
    /// The rig with the overrides applied.
    pub rig: Rig,
    /// Datasets ready to fit.
    pub problem: Problem,
}

impl Experiment {
    /// The mean chamber pressure (bar gauge) of the first dataset's record, averaged over its
    /// samples: the pressure its identified β holds at (docs/bulk-modulus.md#fitting-the-gas-fraction);
    /// `None` when that record has no chamber pressures.
    pub fn mean_chamber_pressure_bar(&self) -> Option<f64> {
        let p = self
            .problem
            .datasets
            .first()?
            .record
            .mean_chamber_pressure_bar()?;
        Some(p.iter().sum::<f64>() / p.len() as f64)
    }

    /// The mean chamber pressures (p1 + p2)/2 (bar gauge) the records span: the lowest sample
    /// over every dataset, [`Experiment::mean_chamber_pressure_bar`], the highest sample;
    /// `None` when the first record has no chamber pressures.
    pub fn chamber_pressure_span_bar(&self) -> Option<[f64; 3]> {
        let mean = self.mean_chamber_pressure_bar()?;
        let (lo, hi) = self
            .problem
            .datasets
            .iter()
            .filter_map(|d| d.record.mean_chamber_pressure_bar())
            .flatten()
            .filter(|p| p.is_finite() && *p > 0.0)
            .fold((mean, mean), |(l, h), p| (l.min(p), h.max(p)));
        Some([lo, mean, hi])
    }

    /// Read, check and prepare an experiment; every error names the file, and the line and key
    /// it concerns (a record's own errors name the record's line and column as well).
    pub fn load(path: &Path) -> Result<Experiment, IdentError> {
        Self::load_in(&input::Disk, path)
    }

    /// [`Experiment::load`], the experiment and every file it names read from `files`.
    pub fn load_in(files: &dyn input::Files, path: &Path) -> Result<Experiment, IdentError> {
        let name = path.display().to_string();
        let text =
            input::read_text(files, path).map_err(|m| IdentError::Input(format!("{name}: {m}")))?;
        Self::from_text_in(files, &text, path)
    }

    /// Check and prepare the experiment `text` of the file at `path` (which names it in
    /// messages; the files it lists are relative to its folder).
    pub fn from_text(text: &str, path: &Path) -> Result<Experiment, IdentError> {
        Self::from_text_in(&input::Disk, text, path)
    }

    /// [`Experiment::from_text`], the files it names read from `files`.
    pub fn from_text_in(
        files: &dyn input::Files,
        text: &str,
        path: &Path,
    ) -> Result<Experiment, IdentError> {
        let name = path.display().to_string();
        let file: ExperimentFile = toml::from_str(text)
            .map_err(|e| IdentError::Input(format!("{name}: {}", input::toml_error(&e, text))))?;
        let at = Locate { name: &name, text };
        let dir = path.parent().unwrap_or(Path::new("."));
        let rig = file.rig(files, dir, &at)?;
        let standstill = file
            .standstill
            .resolve(files, dir)
            .and_then(|s| s.validate().map(|_| s))
            .map_err(|e| at.error(&[Name("standstill")], e))?;
        if file.dataset.is_empty() {
            return Err(at.error(&[Name("dataset")], "needs at least one [[dataset]]"));
        }
        for (key, g) in [("grid", &file.grid), ("refined_grid", &file.refined_grid)] {
            if let Some(Err(e)) = g.as_ref().map(|g| g.validate(key)) {
                return Err(at.error(&[Name(key), Name(e.field)], e.message));
            }
        }
        if !(file.threshold_mm2.is_finite() && file.threshold_mm2 > 0.0) {
            let m = format!("threshold_mm2 = {}: must be > 0", file.threshold_mm2);
            return Err(at.error(&[Name("threshold_mm2")], m));
        }
        let datasets = (0..file.dataset.len())
            .map(|i| file.dataset(files, i, dir, &rig, &at))
            .collect::<Result<_, _>>()?;
        Ok(Experiment {
            path: path.to_path_buf(),
            file,
            rig,
            problem: Problem {
                datasets,
                standstill,
            },
        })
    }

    /// The two grids: the file's, else the article's (docs/identification.md#the-two-grids).
    pub fn grids(&self) -> (Grid, Option<Grid>) {
        (
            self.file.grid.clone().unwrap_or_else(Grid::article_first),
            Some(
                self.file
                    .refined_grid
                    .clone()
                    .unwrap_or_else(Grid::article_refined),
            ),
        )
    }

    /// The identification options the file gives (its `auto_refine`, `local_refinement` and
    /// `threshold_mm2`; the default top list).
    pub fn options(&self) -> super::Options {
        super::Options {
            auto_refine: self.file.auto_refine,
            local_refinement: self.file.local_refinement,
            threshold_mm2: self.file.threshold_mm2,
            ..super::Options::default()
        }
    }

    /// The identification of this experiment's records on its grids with `options`.
    pub fn request(&self, options: super::Options) -> super::Request<'_> {
        super::Request::new(&self.problem, self.grids(), options)
    }

    /// The whole identification on this experiment's grids, in one call (no progress report,
    /// no sharding, within the work limit): [`Request::run`](super::Request::run).
    pub fn identify(&self, opts: &super::Options) -> Result<super::Identification, IdentError> {
        self.request(*opts).run(&|_| true)
    }
}
