//! The experiment file of `pumpcyl identify`: rig, overrides, standstill point, datasets and
//! optional grids, in TOML. Paths are relative to the experiment file.

use super::frequency::{FrequencyProblem, Loaded, SweepSet};
use super::grid::{short, Grid, SecondGrid, FIRST_AXES};
use super::leakage::Standstill;
use super::problem::{DatasetSpec, Prepared, Problem};
use super::IdentError;
use crate::record::Record;
use crate::rig::Rig;
use crate::source_files::{self, Key, Key::Index, Key::Name};
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
    /// `"time"` (the article's fit of step records, the default) or `"frequency"` (sweep
    /// records fitted by their frequency response, with any step records beside them;
    /// docs/identification.md#grey-box-fit-to-a-frequency-response).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// The records to fit, at least one.
    pub dataset: Vec<DatasetEntry>,
    /// First grid; absent = one over `ranges`, each axis without a range centred on the rig's
    /// value ([`FIRST_AXES`]), or the article's with `grids = "article"`.
    pub grid: Option<Grid>,
    /// Second grid; absent = one centred on the first stage's best ([`Grid::around`]), or the
    /// article's refined grid with `grids = "article"`, unless auto-refined.
    pub refined_grid: Option<Grid>,
    /// `"article"`: the article's two grids (§2.4), for the article's records.
    #[serde(default)]
    pub grids: Option<String>,
    /// Ranges [lo, hi] of the first grid's axes (β bar, b N·s/m, c12 m⁵/(N·s)).
    #[serde(default)]
    pub ranges: Ranges,
    /// Threshold of the threshold set (mm²).
    #[serde(default = "default_threshold")]
    pub threshold_mm2: f64,
    /// Derive the second grid from the first grid's threshold set.
    #[serde(default)]
    pub auto_refine: bool,
    /// Nelder–Mead refinement from the best grid point.
    #[serde(default = "yes")]
    pub local_refinement: bool,
    /// Whether the records join the nonlinear refinement of a fit at several pressure levels
    /// (docs/identification.md#nonlinear-refinement); absent: where it pays, when two levels
    /// or more are fitted together.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nonlinear_refinement: Option<bool>,
}

/// One `[[dataset]]` as written: a [`DatasetSpec`] whose `fit_end_s` only a step record needs,
/// and what kind of record it is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetEntry {
    /// Record file (docs/formats.md#record-csv), relative to the experiment file.
    pub file: String,
    /// Position gain used in the experiment (normalised command per metre).
    pub kp: f64,
    /// Effective mass during the experiment (kg).
    pub mass_kg: f64,
    /// End of the fit window of a step record (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit_end_s: Option<f64>,
    /// `"step"` or `"sweep"`; absent, the frequency method tells them by the reference (a
    /// sweep crosses its mean many times), the time method fits every record as a step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<String>,
    /// The sweep that made a sweep record (`[dataset.sweep]`, the keys of
    /// docs/formats.md#sweep-records-and-their-description): its reference is checked against
    /// it and the record estimated as that sweep. Implies `kind = "sweep"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<crate::frf::SweepSpec>,
}

/// How an experiment's records are fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The step records' position errors over time (the article §2.4).
    Time,
    /// The sweep records' frequency responses, with any step records' position errors.
    Frequency,
}

impl Method {
    /// The method named `name` in an experiment file.
    pub fn named(name: &str) -> Option<Method> {
        match name {
            "time" => Some(Method::Time),
            "frequency" => Some(Method::Frequency),
            _ => None,
        }
    }
}

impl DatasetEntry {
    /// This dataset's `record`, taken on `rig`, prepared for `method`: a sweep (by `kind`, or
    /// with the frequency method by its reference) as its frequency response, anything else as
    /// a step record, which needs `fit_end_s`. The error names the key at fault (`None`: the
    /// dataset as a whole) and says why, without the dataset's name.
    pub fn load(
        &self,
        record: Record,
        method: Method,
        rig: &Rig,
    ) -> Result<Loaded, (Option<&'static str>, String)> {
        for (k, v) in [("kp", self.kp), ("mass_kg", self.mass_kg)] {
            if !(v.is_finite() && v > 0.0) {
                return Err((Some(k), format!("{k} = {v}: must be > 0")));
            }
            if let Some(rule) = Rig::check_key(k, v) {
                let v = crate::units::readable(v);
                return Err((Some(k), format!("{k} = {v}: {rule}")));
            }
        }
        let sweep = match (method, self.kind.as_deref()) {
            (_, Some("step")) if self.sweep.is_some() => {
                let m = "kind = \"step\" with a [dataset.sweep] table: a step record has no sweep";
                return Err((Some("kind"), m.to_string()));
            }
            (_, None) if self.sweep.is_some() => true,
            (_, Some("step")) | (Method::Time, None) => false,
            (_, Some("sweep")) => true,
            (Method::Frequency, None) => crate::frf::check_sweep(&record).is_ok(),
            (_, Some(other)) => {
                let m = format!("kind = \"{other}\": give \"step\" or \"sweep\"");
                return Err((Some("kind"), m));
            }
        };
        if sweep && method == Method::Frequency {
            let rig = Rig {
                kp: self.kp,
                mass_kg: self.mass_kg,
                ..rig.clone()
            };
            let excitation = match &self.sweep {
                Some(spec) => {
                    let t = &record.time_s;
                    let rate_hz = (t.len() - 1) as f64 / (t[t.len() - 1] - t[0]);
                    let e = spec.excitation(&rig, rate_hz);
                    Some(e.map_err(|e| (Some("sweep"), format!("[dataset.sweep] {e}")))?)
                }
                None => None,
            };
            return SweepSet::described(&self.file, &record, rig, excitation)
                .map(|s| Loaded::Sweep(Box::new(s)))
                .map_err(|e| (Some("file"), e.to_string()));
        }
        let Some(fit_end_s) = self.fit_end_s else {
            let why = match crate::frf::check_sweep(&record) {
                Err(e) if method == Method::Frequency => format!(
                    "{}; as a step record it needs fit_end_s",
                    e.to_string().replace(&format!("{}: ", record.file), "")
                ),
                _ => "a step record needs fit_end_s, the end of its fit window (s); a sweep \
                      record is fitted with method = \"frequency\""
                    .to_string(),
            };
            return Err((None, why));
        };
        let spec = DatasetSpec {
            file: self.file.clone(),
            kp: self.kp,
            mass_kg: self.mass_kg,
            fit_end_s,
        };
        Prepared::new(&spec, record, rig)
            .map(|p| Loaded::Step(Box::new(p)))
            .map_err(|e| (Some("fit_end_s"), e.to_string()))
    }
}

/// The ranges [lo, hi] of the first grid's axes, each optional.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ranges {
    /// Bulk modulus (bar).
    pub beta_bar: Option<[f64; 2]>,
    /// Viscous friction (N·s/m).
    pub viscous_friction_ns_per_m: Option<[f64; 2]>,
    /// Cross-port leakage (m⁵/(N·s)).
    pub c12_m5_per_ns: Option<[f64; 2]>,
}

impl Ranges {
    /// The three ranges in the order (β, b, c12).
    fn axes(&self) -> [(&'static str, Option<[f64; 2]>); 3] {
        [
            ("beta_bar", self.beta_bar),
            ("viscous_friction_ns_per_m", self.viscous_friction_ns_per_m),
            ("c12_m5_per_ns", self.c12_m5_per_ns),
        ]
    }

    /// Whether no range is given.
    fn is_empty(&self) -> bool {
        self.axes().iter().all(|(_, r)| r.is_none())
    }
}

/// The first grid of an experiment and where it comes from, in words (printed with the
/// answer).
fn first_grid(file: &ExperimentFile, rig: &Rig, at: &Locate) -> Result<(Grid, String), IdentError> {
    if let Some(g) = &file.grid {
        return Ok((g.clone(), "the experiment's [grid]".into()));
    }
    if file.grids.is_some() {
        return Ok((
            Grid::article_first(),
            "the article's (grids = \"article\")".into(),
        ));
    }
    let centre = [
        rig.beta_bar,
        rig.viscous_friction_ns_per_m,
        rig.c12_m5_per_ns,
    ];
    let mut ranges = [[0.0; 2]; 3];
    let mut said = Vec::new();
    for (k, (key, given)) in file.ranges.axes().into_iter().enumerate() {
        let (count, factor) = FIRST_AXES[k];
        let c = centre[k];
        ranges[k] = match given {
            Some([lo, hi]) => {
                if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi >= lo) {
                    let m = format!("ranges.{key} = [{lo}, {hi}]: needs 0 < lo <= hi");
                    return Err(at.error(&[Name("ranges"), Name(key)], m));
                }
                said.push(format!("{key} {}…{} ([ranges])", short(lo), short(hi)));
                [lo, hi]
            }
            None if c.is_finite() && c > 0.0 => {
                said.push(format!("{key} {} ({count} values ÷/× {factor})", short(c)));
                [c / factor, c * factor]
            }
            None => {
                let m = format!(
                    "the rig's {key} is {c}: the first grid is centred on the rig's value, \
                     which must be > 0; give [ranges] {key} = [lo, hi] or a [grid]"
                );
                return Err(at.error(&[Name("ranges")], m));
            }
        };
    }
    let grid = Grid::over(&ranges);
    if let Err(e) = grid.validate("ranges") {
        return Err(at.error(&[Name("ranges"), Name(e.field)], e.message));
    }
    let text = format!("centred on the rig's values: {}", said.join(", "));
    Ok((grid, text))
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
        let line = source_files::toml_line(self.text, path)
            .map_or(String::new(), |l| format!("line {l}, "));
        IdentError::Input(format!("{}: {line}{message}", self.name))
    }
}

impl ExperimentFile {
    /// The rig: the named file or the embedded default, with `[set]` applied.
    fn rig(
        &self,
        files: &dyn source_files::Files,
        dir: &Path,
        at: &Locate,
    ) -> Result<(Rig, RigDefaults), IdentError> {
        let (base, defaults) = match &self.rig {
            Some(r) => {
                let path = dir.join(r);
                let read = Rig::from_file_with_defaults_in(files, &path)
                    .map_err(|e| at.error(&[Name("rig")], e))?;
                let set: Vec<&str> = self.set.keys().map(String::as_str).collect();
                let defaults = RigDefaults {
                    note: read.note(&path.display().to_string(), &set),
                    keys: read
                        .defaulted
                        .iter()
                        .copied()
                        .filter(|k| !set.contains(k))
                        .collect(),
                };
                (read.rig, defaults)
            }
            None => (Rig::default(), RigDefaults::default()),
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
        let rig = base.with_overrides_from("[set]", &all).map_err(|e| {
            let key = match &e {
                crate::rig::RigError::Invalid { key, .. } => key,
                _ => "",
            };
            at.error(&[Name("set"), Name(key)], e)
        })?;
        Ok((rig, defaults))
    }

    /// Dataset `i`, its record read and prepared for `method`.
    fn dataset(
        &self,
        files: &dyn source_files::Files,
        (i, method): (usize, Method),
        dir: &Path,
        rig: &Rig,
        at: &Locate,
    ) -> Result<Loaded, IdentError> {
        let spec = &self.dataset[i];
        let key = |k| [Name("dataset"), Index(i), Name(k)];
        let what = format!("dataset {} (`{}`)", i + 1, spec.file);
        let record = Record::read_in(files, &dir.join(&spec.file))
            .map_err(|e| at.error(&key("file"), format!("{what}: {e}")))?;
        spec.load(record, method, rig).map_err(|(k, m)| match k {
            // the step record's own check names its dataset
            Some("fit_end_s") => at.error(&key("fit_end_s"), m),
            Some(k) => at.error(&key(k), format!("{what}: {m}")),
            None => at.error(&[Name("dataset"), Index(i)], format!("{what}: {m}")),
        })
    }
}

impl StandstillSpec {
    /// The standstill point: the record's means, or the three values.
    fn resolve(
        &self,
        files: &dyn source_files::Files,
        dir: &Path,
    ) -> Result<Standstill, IdentError> {
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

/// The keys a rig file leaves out, which take the article rig's values (docs/formats.md#rig-toml),
/// but those its reader sets another way; none for the embedded rig.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RigDefaults {
    /// One line naming the keys and their values, when the file leaves any out.
    pub note: Option<String>,
    /// The keys.
    pub keys: Vec<&'static str>,
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
    /// What the experiment's rig file leaves out (docs/formats.md#rig-toml).
    pub rig_defaults: RigDefaults,
    /// How the records are fitted: the file's `method`, or the caller's.
    pub method: Method,
    /// The step records ready to fit (every record with the time method).
    pub problem: Problem,
    /// The sweep records' estimates (the frequency method only).
    pub sweeps: Vec<SweepSet>,
    /// The first grid (the file's, the article's, or over the ranges / the rig's values).
    pub first_grid: Grid,
    /// The second stage: given, centred on the first stage's best, or none.
    pub second_grid: Option<SecondGrid>,
    /// Where the grids come from, in words.
    pub grids_origin: String,
}

impl Experiment {
    /// The keys the experiment's rig file leaves out (`rig_defaulted_keys` of a result with a
    /// `rig` block, docs/formats.md#rig-toml); `None` when it names no rig file.
    pub fn rig_defaulted_keys(&self) -> Option<&[&'static str]> {
        self.file
            .rig
            .is_some()
            .then_some(self.rig_defaults.keys.as_slice())
    }

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
        Self::load_in(&source_files::Disk, path)
    }

    /// [`Experiment::load`], the experiment and every file it names read from `files`.
    pub fn load_in(files: &dyn source_files::Files, path: &Path) -> Result<Experiment, IdentError> {
        Self::load_as(files, path, None)
    }

    /// [`Experiment::load_in`] with `method` instead of the file's (`identify --frequency`).
    pub fn load_as(
        files: &dyn source_files::Files,
        path: &Path,
        method: Option<Method>,
    ) -> Result<Experiment, IdentError> {
        let name = path.display().to_string();
        let text = source_files::read_text(files, path)
            .map_err(|m| IdentError::Input(format!("{name}: {m}")))?;
        Self::parse(files, &text, path, method)
    }

    /// Check and prepare the experiment `text` of the file at `path` (which names it in
    /// messages; the files it lists are relative to its folder).
    pub fn from_text(text: &str, path: &Path) -> Result<Experiment, IdentError> {
        Self::from_text_in(&source_files::Disk, text, path)
    }

    /// [`Experiment::from_text`], the files it names read from `files`.
    pub fn from_text_in(
        files: &dyn source_files::Files,
        text: &str,
        path: &Path,
    ) -> Result<Experiment, IdentError> {
        Self::parse(files, text, path, None)
    }

    /// [`Experiment::from_text_in`], `method` (when given) instead of the file's.
    fn parse(
        files: &dyn source_files::Files,
        text: &str,
        path: &Path,
        method: Option<Method>,
    ) -> Result<Experiment, IdentError> {
        let name = path.display().to_string();
        let file: ExperimentFile = toml::from_str(text).map_err(|e| {
            IdentError::Input(format!("{name}: {}", source_files::toml_error(&e, text)))
        })?;
        let at = Locate { name: &name, text };
        let dir = path.parent().unwrap_or(Path::new("."));
        let (rig, rig_defaults) = file.rig(files, dir, &at)?;
        if !rig.has_key("c12_m5_per_ns") {
            let m = format!(
                "circuit = \"{}\": identification fits beta, b and c12, the pumps' cross-port \
                 leakage, which this circuit has none of: it models the circuits with drives only \
                 (docs/circuits.md#what-works-on-which-circuit)",
                rig.circuit.name()
            );
            return Err(IdentError::Input(format!("{name}: {m}")));
        }
        let standstill = file
            .standstill
            .resolve(files, dir)
            .and_then(|s| s.validate_for(&rig).map(|_| s))
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
        match file.grids.as_deref() {
            None | Some("article") => {}
            Some(other) => {
                let m = format!("grids = \"{other}\": the only named grids are \"article\"");
                return Err(at.error(&[Name("grids")], m));
            }
        }
        if file.grids.is_some() && !file.ranges.is_empty() {
            let m = "give either grids = \"article\" or [ranges], not both";
            return Err(at.error(&[Name("ranges")], m));
        }
        let (first_grid, first_origin) = first_grid(&file, &rig, &at)?;
        let (second_grid, second_origin) = match (&file.refined_grid, &file.grids) {
            (Some(g), _) => (g.clone().into(), "the experiment's [refined_grid]"),
            (None, Some(_)) => (Grid::article_refined().into(), "the article's refined grid"),
            (None, None) => (SecondGrid::Centred, "centred on the first stage's best"),
        };
        let method = match (method, file.method.as_deref()) {
            (Some(m), _) => m,
            (None, None) => Method::Time,
            (None, Some(m)) => Method::named(m).ok_or_else(|| {
                let m = format!("method = \"{m}\": give \"time\" or \"frequency\"");
                at.error(&[Name("method")], m)
            })?,
        };
        let (mut datasets, mut sweeps) = (Vec::new(), Vec::new());
        for i in 0..file.dataset.len() {
            match file.dataset(files, (i, method), dir, &rig, &at)? {
                Loaded::Step(p) => datasets.push(*p),
                Loaded::Sweep(s) => sweeps.push(*s),
            }
        }
        if method == Method::Frequency && sweeps.is_empty() {
            let m = "the frequency method needs at least one sweep record (a chirp, multisine \
                     or stepped sine: pumpcyl emulate --experiment multisine); every dataset's \
                     reference is a step or a hold";
            return Err(at.error(&[Name("dataset")], m));
        }
        Ok(Experiment {
            path: path.to_path_buf(),
            grids_origin: format!("first {first_origin}; second {second_origin}"),
            first_grid,
            second_grid: Some(second_grid),
            file,
            rig,
            rig_defaults,
            method,
            problem: Problem {
                datasets,
                standstill,
            },
            sweeps,
        })
    }

    /// The records of a frequency-domain fit: the sweeps, with the step records beside them
    /// when there are any, their controller sampled as the sweeps'; `None` with the time
    /// method.
    pub fn frequency_problem(&self) -> Option<FrequencyProblem> {
        (self.method == Method::Frequency).then(|| FrequencyProblem {
            sweeps: self.sweeps.clone(),
            steps: (!self.problem.datasets.is_empty())
                .then(|| self.problem.clone().with_sampled_controller()),
            standstill: self.problem.standstill,
        })
    }

    /// The two grids: the file's; else the first over its ranges or centred on the rig's
    /// values and the second centred on the first stage's best; the article's with
    /// `grids = "article"` (docs/identification.md#the-two-grids).
    pub fn grids(&self) -> (Grid, Option<SecondGrid>) {
        (self.first_grid.clone(), self.second_grid.clone())
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
