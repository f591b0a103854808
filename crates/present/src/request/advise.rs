//! The advice request: which further record would narrow the intervals of β, b and c12 most,
//! from the linearised model (docs/identification.md, "Experiment advice").

use super::{Document, Hooks, Request};
use crate::advise::{advice_json, advice_text};
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
}

/// The advice.
pub struct AdviseOutcome {
    name: String,
    advice: Advice,
    seconds: f64,
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
            seconds: start.elapsed().as_secs_f64(),
        })
    }
}

impl Document for AdviseOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(advice_json(&self.advice, &self.name, self.seconds))
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(advice_text(&self.name, &self.advice, self.seconds))
    }
}
