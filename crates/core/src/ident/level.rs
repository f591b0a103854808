//! β_e identified at one pressure level: an experiment's identification and the profile
//! interval of its β, at the records' mean chamber pressure
//! (docs/bulk-modulus.md#several-pressure-levels).

use super::{analyze, Candidate, Experiment, IdentError, UncertaintyOptions};
use crate::bulk::levels::Level;

/// β_e at one level and what it was read off.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelReading {
    /// β_e, its interval and the mean chamber pressure.
    pub level: Level,
    /// The linear identification's answer (β, b, c12), polished on the SSE.
    pub best: Candidate,
    /// Whether the records bound β on both sides.
    pub identifiable: bool,
    /// Where the mean pressure came from: the records' chamber pressures, or the rig's anchor
    /// where the records have none.
    pub pressure_from_records: bool,
}

/// Identify `exp` (its grids and options), profile its β at `confidence`, and read the mean
/// chamber pressure off its records (the rig's anchor, [`crate::anchor::anchor_bar`], where
/// they hold no chamber pressures).
///
/// # Errors
/// The identification's or the analysis' own.
pub fn identify_level(exp: &Experiment, confidence: f64) -> Result<LevelReading, IdentError> {
    let id = exp.identify(&exp.options())?;
    let opts = UncertaintyOptions {
        confidence,
        profile: [true, false, false],
    };
    let u = analyze(&exp.problem, &id.best().candidate, &opts)?;
    let beta = u
        .profile("beta_bar")
        .ok_or_else(|| IdentError::Input("the analysis profiled no beta_bar".into()))?;
    let from_records = exp.mean_chamber_pressure_bar();
    let reading = LevelReading {
        level: Level {
            p_mean_bar: from_records.unwrap_or_else(|| crate::anchor::anchor_bar(&exp.rig)),
            beta_bar: u.best.beta_bar,
            interval_bar: beta.interval,
            profile: (beta.points.iter())
                .map(|pt| [pt.value, pt.statistic])
                .collect(),
        },
        best: u.best,
        identifiable: beta.identifiable,
        pressure_from_records: from_records.is_some(),
    };
    Ok(reading)
}
