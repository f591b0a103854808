//! The frequency-analysis requests: `margins` and `poles` (docs/analysis.md#margins).

use super::{Document, Hooks, Request, RigInput};
use crate::analysis::{loop_margins_text, loop_pole_sets, poles_text, ModesReport};
use crate::documents::{margins_document, poles_document};
use pumpcyl::loops::Loop;
use pumpcyl::lti;
use serde_json::Value;

/// The loop a rig's analysis reads: the position loop with its feedback removed, the
/// sum-pressure loop closed inside it when `sum_pressure_closed` (the article §2.3.3 opens it).
fn loop_of(rig: &RigInput, sum_pressure_closed: bool) -> Loop {
    Loop::of_rig(rig.rig.clone(), &rig.name, sum_pressure_closed)
}

/// `margins`: gain, phase and delay margins of the position loop, every crossing, closed-loop
/// stability and, on a single-pump rig, each mode's.
#[derive(Debug, Clone)]
pub struct Margins {
    /// The rig.
    pub rig: RigInput,
    /// Keep the sum-pressure loop closed inside the analysed loop.
    pub sum_pressure_closed: bool,
}

/// The margins of a loop.
pub struct MarginsOutcome {
    lp: Loop,
    margins: lti::Margins,
}

impl Margins {
    /// The margins of the loop `lp` (a rig's or a state-space model's).
    ///
    /// # Errors
    /// The margins cannot be computed.
    pub fn of_loop(lp: Loop) -> anyhow::Result<MarginsOutcome> {
        let margins = lti::margins(&lp.open_loop)?;
        Ok(MarginsOutcome { lp, margins })
    }
}

impl Request for Margins {
    type Outcome = MarginsOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<MarginsOutcome> {
        Margins::of_loop(loop_of(&self.rig, self.sum_pressure_closed))
    }
}

impl Document for MarginsOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        Ok(margins_document(&self.margins, &self.lp)?)
    }

    fn text(&self) -> anyhow::Result<String> {
        let mut text = loop_margins_text(&self.margins, &self.lp)?;
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
