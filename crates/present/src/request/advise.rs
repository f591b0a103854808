//! The advice request: which further record would narrow the intervals of β, b and c12 most,
//! from the linearised model (docs/identification.md, "Experiment advice").

use super::{Document, Hooks, Request};
use crate::advise::{advice_json, advice_text};
use crate::bulk::{identify_levels, Levels, Refine};
use pumpcyl::ident::{advise_experiment, Advice, Experiment};
use pumpcyl::source_files::Files;
use serde_json::Value;
use std::path::PathBuf;
use std::time::Instant;

/// `advise`: identify the experiment's records, then compare candidate further records by the
/// interval widths expected after adding each.
pub struct Advise {
    /// The experiment, loaded.
    pub experiment: Experiment,
    /// The candidates' file (TOML); `None`: the default steps, sinusoids, gains and sweep.
    pub candidates: Option<PathBuf>,
    /// The confidence of the expected intervals, in (0, 1).
    pub confidence: f64,
    /// Every candidate weighed at this recording time (s).
    pub budget_s: Option<f64>,
    /// Where the candidates' file is read.
    pub files: &'static dyn Files,
    /// Experiments at other pressure levels: with the experiment's own, the family of β(p)
    /// models is fitted to them and the next level to record named
    /// (docs/bulk-modulus.md#several-pressure-levels).
    pub levels: Vec<Experiment>,
}

/// The advice.
pub struct AdviseOutcome {
    name: String,
    advice: Advice,
    seconds: f64,
    pressure_levels: Option<Levels>,
}

impl Request for Advise {
    type Outcome = AdviseOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<AdviseOutcome> {
        let start = Instant::now();
        let candidates = self.candidates.as_deref();
        let options = (self.confidence, self.budget_s);
        let advice = advise_experiment(&self.experiment, self.files, candidates, options)?;
        Ok(AdviseOutcome {
            name: self.experiment.path.display().to_string(),
            advice,
            pressure_levels: self.pressure_levels()?,
            seconds: start.elapsed().as_secs_f64(),
        })
    }
}

impl Advise {
    /// The family of β(p) models fitted to the experiment's level and the others', with the
    /// next level to record; `None` for an experiment fitted in the frequency domain.
    fn pressure_levels(&self) -> anyhow::Result<Option<Levels>> {
        if self.experiment.frequency_problem().is_some() {
            return Ok(None);
        }
        let exps: Vec<Experiment> = std::iter::once(self.experiment.clone())
            .chain(self.levels.iter().cloned())
            .collect();
        let own = self.experiment.rig.bulk_model();
        let fit = (pumpcyl::bulk::BETA_OIL_BAR, self.confidence);
        identify_levels(&exps, own, fit, &[1.0, 10.0], Refine::Off).map(Some)
    }
}

impl Document for AdviseOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let mut v = advice_json(&self.advice, &self.name, self.seconds);
        v["pressure_levels"] = serde_json::to_value(&self.pressure_levels)?;
        Ok(v)
    }

    fn text(&self) -> anyhow::Result<String> {
        let levels = (self.pressure_levels.as_ref()).map_or(String::new(), Levels::next_text);
        Ok(advice_text(&self.name, &self.advice, self.seconds) + &levels)
    }
}
