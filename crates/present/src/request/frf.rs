//! The frequency-response request: the closed loop's and the plant's response estimated from a
//! sweep record, with coherence and a 95 % band, beside the rig's model
//! (docs/identification.md#frequency-response-from-a-sweep).

use super::{Document, Hooks, Request, RigInput};
use crate::frf::{
    frf_csv, frf_json, frf_svg, frf_text, model_warning, rig_model_curve, ModelCurve,
};
use pumpcyl::frf::{estimate, Estimate, Excitation, Options};
use pumpcyl::record::Record;
use serde_json::Value;

/// `frf`: the estimate of a sweep record on the rig it was taken on.
#[derive(Debug, Clone)]
pub struct Frf {
    /// The rig, whose model is drawn beside the estimate.
    pub rig: RigInput,
    /// The record.
    pub record: Record,
    /// The sweep the record holds, when described (else found in the record, or Welch's
    /// method).
    pub excitation: Option<Excitation>,
    /// Welch's segment length (s), for a record that is not a periodic sweep.
    pub segment_s: Option<f64>,
}

/// An estimate beside the rig's model.
pub struct FrfOutcome {
    estimate: Estimate,
    model: ModelCurve,
}

impl Request for Frf {
    type Outcome = FrfOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<FrfOutcome> {
        let rig = &self.rig.rig;
        self.record.check_units(rig.stroke_mm)?;
        let opts = Options {
            excitation: self.excitation,
            rig: Some(rig),
            segment_s: self.segment_s,
        };
        let mut estimate = estimate(&self.record, &opts)?;
        estimate.warnings.extend(model_warning(rig));
        let model = rig_model_curve(rig, &estimate, &self.rig.name)?;
        Ok(FrfOutcome { estimate, model })
    }
}

impl FrfOutcome {
    /// The estimate and the model as CSV (docs/formats.md#frf-outputs).
    pub fn csv(&self) -> String {
        frf_csv(&self.estimate, Some(&self.model))
    }

    /// The Bode figure of the estimate with its band and the model (SVG).
    ///
    /// # Errors
    /// The figure cannot be drawn.
    pub fn svg(&self) -> anyhow::Result<String> {
        frf_svg(&self.estimate, Some(&self.model)).map_err(|e| anyhow::anyhow!(e))
    }
}

impl Document for FrfOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(frf_json(&self.estimate, Some(&self.model)))
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(frf_text(&self.estimate))
    }

    fn warnings(&self) -> &[String] {
        &self.estimate.warnings
    }
}
