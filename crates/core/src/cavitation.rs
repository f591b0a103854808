//! The lowest pressure a chamber can hold: one check for every steady state pumpcyl computes
//! (leakage, design, select, the emulator's initial state; docs/model.md#cavitation).
//!
//! Mineral oil's vapour pressure is a few kPa absolute, and the air dissolved in it comes out of
//! solution well above that, so no chamber holds a steady pressure below 0 bar absolute. With
//! the atmosphere taken as 1 bar, that is −1 bar gauge: the floor the emulator's cavitation
//! model also uses (docs/emulator.md). A steady state that needs a chamber below it is not a
//! state the circuit can reach.
//!
//! ```
//! use pumpcyl::cavitation::{check_chambers, VAPOUR_PRESSURE_BAR_GAUGE};
//!
//! assert_eq!(VAPOUR_PRESSURE_BAR_GAUGE, -1.0);
//! assert!(check_chambers(&[6.72, 1.2]).is_ok());
//! let err = check_chambers(&[6.72, -4.72]).unwrap_err();
//! assert_eq!(err.chamber, 2);
//! assert_eq!(
//!     err.to_string(),
//!     "chamber 2 at -4.72 bar gauge, below the oil's vapour pressure (-1 bar gauge): \
//!      cavitation, a state the circuit cannot hold"
//! );
//! ```

use crate::units::readable;

/// The vapour pressure of the oil as pumpcyl takes it (bar gauge): 0 bar absolute with a 1 bar
/// atmosphere (the oil's own vapour pressure, a few kPa absolute, is below the resolution of
/// any chamber pressure pumpcyl computes).
pub const VAPOUR_PRESSURE_BAR_GAUGE: f64 = -1.0;

/// A chamber pressure below [`VAPOUR_PRESSURE_BAR_GAUGE`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "chamber {chamber} at {:.2} bar gauge, below the oil's vapour pressure ({} bar gauge): \
     cavitation, a state the circuit cannot hold",
    p_bar,
    readable(VAPOUR_PRESSURE_BAR_GAUGE)
)]
pub struct Cavitation {
    /// The chamber (1-based, as the article numbers them).
    pub chamber: usize,
    /// Its pressure (bar gauge).
    pub p_bar: f64,
}

/// Refuse chamber pressures (bar gauge, chamber 1 first) of which one lies below the vapour
/// pressure, or is not a number: the first such chamber is named.
pub fn check_chambers(p_bar: &[f64]) -> Result<(), Cavitation> {
    match p_bar
        .iter()
        .position(|p| p.is_nan() || *p < VAPOUR_PRESSURE_BAR_GAUGE)
    {
        None => Ok(()),
        Some(i) => Err(Cavitation {
            chamber: i + 1,
            p_bar: p_bar[i],
        }),
    }
}

/// How near the floor (bar) a chamber of an emulated run counts as at it: the emulator holds a
/// chamber there (its pressure does not fall below [`VAPOUR_PRESSURE_BAR_GAUGE`]), so one that
/// reaches it sits within the integrator's step of it.
pub const AT_FLOOR_BAR: f64 = 1e-3;

/// The first time a chamber of an emulated run reached the cavitation floor
/// (docs/emulator.md#cavitation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorHit {
    /// The chamber (1-based, as the article numbers them).
    pub chamber: usize,
    /// Time of the first PLC sample at the floor (s).
    pub at_s: f64,
}

impl FloorHit {
    /// The first chamber of `p_bar` (bar gauge, chamber 1 first) within [`AT_FLOOR_BAR`] of the
    /// floor or below it, at `at_s`.
    pub fn of_chambers(p_bar: &[f64], at_s: f64) -> Option<FloorHit> {
        let i = p_bar
            .iter()
            .position(|p| *p <= VAPOUR_PRESSURE_BAR_GAUGE + AT_FLOOR_BAR)?;
        Some(FloorHit {
            chamber: i + 1,
            at_s,
        })
    }
}

impl std::fmt::Display for FloorHit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "chamber {} reached the cavitation floor ({} bar gauge) at t = {:.2} s: the oil \
             cavitates and the emulator holds the chamber there, so from then on the record is \
             not what the linear model describes (a smaller or slower reference, or a higher \
             sum-pressure set-point, keeps the chambers above it; docs/emulator.md#cavitation)",
            self.chamber,
            readable(VAPOUR_PRESSURE_BAR_GAUGE),
            self.at_s
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chamber_within_a_millibar_of_the_floor_is_at_it() {
        assert_eq!(FloorHit::of_chambers(&[4.0, 5.0], 1.0), None);
        assert_eq!(FloorHit::of_chambers(&[4.0, -0.998], 1.0), None);
        let hit = FloorHit::of_chambers(&[-0.9995, -1.0], 0.6).unwrap();
        assert_eq!((hit.chamber, hit.at_s), (1, 0.6));
        assert!(hit
            .to_string()
            .starts_with("chamber 1 reached the cavitation floor (-1 bar gauge) at t = 0.60 s"));
    }
}
