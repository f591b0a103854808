//! The experiment file of `pumpcyl identify`: rig, overrides, standstill point, datasets and
//! optional grids, in TOML. Paths are relative to the experiment file.

use super::grid::Grid;
use super::leakage::Standstill;
use super::problem::{DatasetSpec, Prepared, Problem};
use super::IdentError;
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
    /// Standstill point for c1, c2 (SPEC §6.2).
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
    /// A standstill record (SPEC §9 CSV with `w1_rpm`, `w2_rpm`, `p1_bar`), averaged.
    pub record: Option<String>,
    /// Motor/pump 1 speed (rpm).
    pub w1_rpm: Option<f64>,
    /// Motor/pump 2 speed (rpm).
    pub w2_rpm: Option<f64>,
    /// Chamber 1 pressure (bar gauge).
    pub p1_bar: Option<f64>,
}

impl StandstillSpec {
    /// The standstill point: the record's means, or the three values.
    fn resolve(&self, dir: &Path) -> Result<Standstill, IdentError> {
        let values = [self.w1_rpm, self.w2_rpm, self.p1_bar];
        match (&self.record, values) {
            (Some(file), [None, None, None]) => {
                Standstill::of_record(&Record::read(&dir.join(file))?)
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
    /// Read, check and prepare an experiment; errors name the file, and the line and key where
    /// the TOML parser knows them.
    pub fn load(path: &Path) -> Result<Experiment, IdentError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| IdentError::Input(format!("{name}: cannot read: {e}")))?;
        let file: ExperimentFile = toml::from_str(&text)
            .map_err(|e| IdentError::Input(format!("{name}: {}", e.to_string().trim_end())))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let in_file = |m: String| IdentError::Input(format!("{name}: {m}"));
        let base = match &file.rig {
            Some(r) => Rig::from_file(&dir.join(r))?,
            None => Rig::default(),
        };
        let overrides: Vec<String> = file.set.iter().map(|(k, v)| format!("{k}={v}")).collect();
        let rig = base
            .with_overrides(&overrides)
            .map_err(|e| in_file(format!("[set]: {e}")))?;
        let standstill = file
            .standstill
            .resolve(dir)
            .map_err(|e| in_file(e.to_string()))?;
        standstill.validate().map_err(|e| in_file(e.to_string()))?;
        if file.dataset.is_empty() {
            return Err(in_file("needs at least one [[dataset]]".into()));
        }
        for (key, g) in [("grid", &file.grid), ("refined_grid", &file.refined_grid)] {
            if let Some(g) = g {
                g.validate(key).map_err(in_file)?;
            }
        }
        if !(file.threshold_mm2.is_finite() && file.threshold_mm2 > 0.0) {
            return Err(in_file(format!(
                "threshold_mm2 = {}: must be > 0",
                file.threshold_mm2
            )));
        }
        let mut datasets = Vec::new();
        for (i, spec) in file.dataset.iter().enumerate() {
            let record = Record::read(&dir.join(&spec.file))?;
            for (key, v) in [("kp", spec.kp), ("mass_kg", spec.mass_kg)] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(in_file(format!(
                        "dataset {} (`{}`): {key} = {v}: must be > 0",
                        i + 1,
                        spec.file
                    )));
                }
            }
            datasets.push(Prepared::new(spec, record, &rig).map_err(|e| in_file(e.to_string()))?);
        }
        let problem = Problem {
            datasets,
            standstill,
        };
        Ok(Experiment {
            path: path.to_path_buf(),
            file,
            rig,
            problem,
        })
    }

    /// The two grids: the file's, else the article's (SPEC §6.3).
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
}
