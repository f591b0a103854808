//! The frequency-analysis requests: `margins` and `poles` (docs/analysis.md#margins).

use super::{check_field, Document, FieldError, Given, Hooks, Request, RigInput};
use crate::analysis::{
    bode_csv, loop_margins_text, loop_pole_sets, model_text, poles_text, ModesReport,
};
use crate::documents::{margins_document, poles_document};
use crate::figures::{bode_markers, Chart};
use crate::matlab::bode_mat;
use crate::plot::BodeSeries;
use pumpcyl::loops::{Loop, ModelView};
use pumpcyl::lti;
use serde_json::{json, Value};

/// The loop a rig's analysis reads: the position loop with its feedback removed, the
/// sum-pressure loop closed inside it when `sum_pressure_closed` (the article §2.3.3 opens it).
fn loop_of(rig: &RigInput, sum_pressure_closed: bool) -> Loop {
    Loop::of_rig(rig.rig.clone(), &rig.name, sum_pressure_closed)
}

/// `margins`: gain, phase and delay margins of the position loop, every crossing, closed-loop
/// stability, the disk margin and sensitivity peaks, the same of the loop as its PLC samples it
/// and, on a single-pump rig, each mode's.
#[derive(Debug, Clone)]
pub struct Margins {
    /// The rig.
    pub rig: RigInput,
    /// Keep the sum-pressure loop closed inside the analysed loop.
    pub sum_pressure_closed: bool,
    /// The disk margin's skew σ in [−1, 1] (0: balanced; docs/analysis.md#disk-margins).
    pub skew: f64,
}

/// The margins of a loop.
pub struct MarginsOutcome {
    lp: Loop,
    margins: lti::Margins,
    skew: f64,
}

impl Margins {
    /// The margins of the loop `lp` (a rig's or a state-space model's), the disk margin's skew
    /// `skew`.
    ///
    /// # Errors
    /// The margins cannot be computed, or the skew lies outside [−1, 1].
    pub fn of_loop(lp: Loop, skew: f64) -> anyhow::Result<MarginsOutcome> {
        check_field(
            "skew",
            skew,
            (-1.0..=1.0).contains(&skew),
            "must lie in [-1, 1]",
        )?;
        let margins = lti::margins(&lp.open_loop)?;
        Ok(MarginsOutcome { lp, margins, skew })
    }
}

impl Request for Margins {
    type Outcome = MarginsOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<MarginsOutcome> {
        let lp = loop_of(&self.rig, self.sum_pressure_closed);
        Margins::of_loop(lp, self.skew)
    }
}

impl Document for MarginsOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(margins_document(&self.margins, &self.lp, self.skew)?)
    }

    fn text(&self) -> anyhow::Result<String> {
        let mut text = loop_margins_text(&self.margins, &self.lp)?;
        let disk = lti::disk_margins(&self.lp.open_loop, self.skew);
        text += &crate::robustness::disk_text(&disk);
        text += &crate::robustness::gang_of_four_text(&self.lp, &disk);
        text += &crate::robustness::sampled_text(&self.lp, &self.margins, self.skew);
        if let Some(modes) = ModesReport::of_loop(&self.lp)? {
            text += &modes.margins_text()?;
        }
        Ok(text)
    }
}

/// `poles`: the open- and closed-loop poles with natural frequency and damping and, on a
/// single-pump rig, each mode's.
#[derive(Debug, Clone)]
pub struct Poles {
    /// The rig.
    pub rig: RigInput,
    /// Keep the sum-pressure loop closed inside the analysed loop.
    pub sum_pressure_closed: bool,
}

/// The poles of a loop.
pub struct PolesOutcome {
    lp: Loop,
}

impl Poles {
    /// The poles of the loop `lp` (a rig's or a state-space model's).
    pub fn of_loop(lp: Loop) -> PolesOutcome {
        PolesOutcome { lp }
    }
}

impl Request for Poles {
    type Outcome = PolesOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<PolesOutcome> {
        Ok(Poles::of_loop(loop_of(&self.rig, self.sum_pressure_closed)))
    }
}

impl Document for PolesOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(poles_document(&self.lp)?)
    }

    fn text(&self) -> anyhow::Result<String> {
        let mut text = poles_text(&self.lp.description, &loop_pole_sets(&self.lp)?);
        if let Some(modes) = ModesReport::of_loop(&self.lp)? {
            text += &modes.poles_text()?;
        }
        Ok(text)
    }
}

/// `bode`: magnitude and unwrapped phase of the position open loop on a logarithmic grid, the
/// nominal loop and each variant overlaid, each with its margin markers.
pub struct Bode {
    /// The loops: the nominal first, then each variant, labelled.
    pub loops: Vec<(String, Loop)>,
    /// Lowest frequency (Hz).
    pub from_hz: f64,
    /// Highest frequency (Hz).
    pub to_hz: f64,
    /// Points per decade.
    pub points_per_decade: usize,
}

/// The Bode series of every loop.
pub struct BodeOutcome {
    title: String,
    series: Vec<BodeSeries>,
    markers: Vec<Option<crate::plot::BodeMarkers>>,
}

impl Bode {
    /// The frequency grid, checked.
    pub fn grid(&self) -> anyhow::Result<Vec<f64>> {
        let (from, to) = (self.from_hz, self.to_hz);
        let ok = from > 0.0 && to > from && to.is_finite();
        if !ok {
            let problem = "must satisfy 0 < from < to";
            let e = FieldError::new("from_hz", Given::Number(from), problem);
            return Err(e.and("to_hz", Given::Number(to)).into());
        }
        let n = self.points_per_decade;
        check_field("points_per_decade", n as f64, n >= 2, "must be at least 2")?;
        let decades = to.log10() - from.log10();
        // each point holds its frequency and a magnitude and a phase per series
        let points = pumpcyl::limits::check_table(
            "the grid",
            (decades * n as f64).floor() + 1.0,
            1 + 2 * self.loops.len(),
        )
        .map_err(|e| {
            FieldError::new("from_hz", Given::Number(from), e.to_string())
                .and("to_hz", Given::Number(to))
                .and("points_per_decade", Given::Number(n as f64))
        })?;
        Ok(lti::log_grid(from, to, points))
    }
}

impl Request for Bode {
    type Outcome = BodeOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<BodeOutcome> {
        let freqs = self.grid()?;
        let mut series = Vec::new();
        let mut markers = Vec::new();
        for (label, lp) in &self.loops {
            let b = lti::bode(&lp.open_loop, &freqs)?;
            series.push(BodeSeries {
                label: label.clone(),
                freq_hz: b.freq_hz,
                mag_db: b.mag_db,
                phase_deg: b.phase_deg,
            });
            markers.push(Some(bode_markers(&lti::margins(&lp.open_loop)?)));
        }
        let title = format!("Bode: {}", self.loops[0].1.description);
        Ok(BodeOutcome {
            title,
            series,
            markers,
        })
    }
}

impl BodeOutcome {
    /// The series as a MAT-file.
    pub fn mat(&self) -> Vec<u8> {
        bode_mat(&self.series)
    }

    /// The Bode figure, every series with its margin markers in its own colour.
    pub fn chart(&self) -> Chart {
        Chart::bode(&self.title, self.series.clone(), self.markers.clone())
    }

    /// How many series it holds.
    pub fn count(&self) -> usize {
        self.series.len()
    }
}

impl Document for BodeOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let series: Vec<Value> = (self.series.iter())
            .map(|s| json!({"label": s.label, "freq_hz": s.freq_hz, "mag_db": s.mag_db, "phase_deg": s.phase_deg}))
            .collect();
        Ok(json!({ "title": self.title, "series": series }))
    }

    /// The series as CSV (freq_hz, then mag_db and phase_deg per series).
    fn text(&self) -> anyhow::Result<String> {
        Ok(bode_csv(&self.series))
    }
}

/// `model`: the open or closed loop's state-space model, its states, inputs and outputs named.
pub struct Model {
    /// The loop.
    pub lp: Loop,
    /// The closed loop as `step` simulates it, instead of the open loop.
    pub closed_loop: bool,
}

/// A loop as shown or exported.
pub struct ModelOutcome {
    view: ModelView,
}

impl Request for Model {
    type Outcome = ModelOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<ModelOutcome> {
        let view = self
            .lp
            .view(self.closed_loop, self.lp.sum_pressure_closed)?;
        Ok(ModelOutcome { view })
    }
}

impl ModelOutcome {
    /// The loop as exported (MATLAB/Octave files, MAT-files).
    pub fn view(&self) -> &ModelView {
        &self.view
    }
}

impl Document for ModelOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let json = lti::ModelJson::from_model(&self.view.sys, self.view.states.clone());
        Ok(serde_json::to_value(json)?)
    }

    fn text(&self) -> anyhow::Result<String> {
        Ok(model_text(&self.view))
    }
}
