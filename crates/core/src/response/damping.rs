//! Whether a step response rings (docs/simulation.md#ringing): a loop whose gain margin is
//! under [`RINGING_GM_DB`] is stable but barely damped, and its step rings on long after the
//! overshoot its metrics report.

use crate::lti::{eigenvalues, margins, LtiError, PoleInfo};
use crate::model::Plant;
use crate::rig::Rig;
use serde::Serialize;

/// Gain margin (dB) below which a step gets a damping warning: the loop gain may rise by less
/// than 12 % before the loop is unstable, and its least-damped poles lie close to the
/// imaginary axis (sustained ringing).
pub const RINGING_GM_DB: f64 = 1.0;

/// The damping warning of a step: the gain margin of the loop and its least-damped
/// closed-loop pole.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ringing {
    /// Gain margin of the loop as simulated, opened at the position feedback (dB).
    pub gain_margin_db: f64,
    /// Natural frequency |λ|/(2π) of the least-damped closed-loop pole (Hz).
    pub natural_freq_hz: f64,
    /// Its damping ratio −Re λ/|λ|.
    pub damping_ratio: f64,
}

/// The damping warning for a step of `rig`, `None` when its loop (the sum-pressure loop as the
/// rig says, opened at the position feedback) has a gain margin of [`RINGING_GM_DB`] or more,
/// or an infinite one.
///
/// The article's rig at Kp = 25, simulated with its sum-pressure loop closed, has 3.3 dB: no
/// warning. At Kp = 34 the loop gain has risen by 2.7 dB, and 0.66 dB is left: the step rings
/// with a damping ratio of 0.019 at 0.69 Hz.
///
/// ```
/// use pumpcyl::{response, rig::Rig};
///
/// assert_eq!(response::ringing(&Rig::default())?, None);
/// let rig = Rig { kp: 34.0, ..Rig::default() };
/// let r = response::ringing(&rig)?.expect("under 1 dB");
/// assert!((r.gain_margin_db - 0.66).abs() < 0.01, "{r:?}");
/// assert!((r.damping_ratio - 0.019).abs() < 0.001 && (r.natural_freq_hz - 0.69).abs() < 0.01);
/// # Ok::<(), pumpcyl::lti::LtiError>(())
/// ```
pub fn ringing(rig: &Rig) -> Result<Option<Ringing>, LtiError> {
    let plant = Plant::new(rig);
    let gm = margins(&plant.open_loop(rig.sum_pressure))?.gain_margin_db;
    let Some(gain_margin_db) = gm.filter(|gm| *gm < RINGING_GM_DB) else {
        return Ok(None);
    };
    let least = eigenvalues(&plant.closed_loop(rig.sum_pressure).a)?
        .into_iter()
        .filter(|p| p.im > 0.0)
        .map(PoleInfo::from)
        .filter_map(|p| Some((p.natural_freq_hz, p.damping?)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    Ok(least.map(|(natural_freq_hz, damping_ratio)| Ringing {
        gain_margin_db,
        natural_freq_hz,
        damping_ratio,
    }))
}
