//! The ends of the stroke (docs/emulator.md#end-stops): the piston cannot leave its cylinder.
//! At x = 0 and at x = `stroke_mm` a stiff, critically damped contact pushes it back, with the
//! force the stop takes; it only pushes, never pulls, so the piston leaves a stop freely. Inside
//! the stroke the contact is idle and the dynamics are exactly those of docs/emulator.md.

use std::fmt;

/// Natural frequency of the piston's mass on a stop's stiffness (rad/s): 100 Hz, stiff beside
/// the hydraulic resonance (a few Hz, the article §3.3) yet below the drives' current loop
/// (1257 1/s), so BDF integrates through a contact without a stiffer problem than it already has.
pub const CONTACT_RAD_S: f64 = 2.0 * std::f64::consts::PI * 100.0;

/// Damping ratio of the contact: critical, so the piston settles on a stop without bouncing.
pub const CONTACT_DAMPING: f64 = 1.0;

/// Which end of the stroke.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// x = 0, the piston fully retracted.
    Retracted,
    /// x = stroke, the piston fully extended.
    Extended,
}

/// The first time an emulated run met an end of its stroke.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EndStopHit {
    /// The end it met.
    pub end: End,
    /// That end's position (mm).
    pub end_mm: f64,
    /// Time of the first PLC sample (or communication point) in contact (s).
    pub at_s: f64,
}

impl fmt::Display for EndStopHit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let which = match self.end {
            End::Retracted => "retracted",
            End::Extended => "extended",
        };
        write!(
            f,
            "the piston hit its {which} end stop (x = {} mm) at t = {:.2} s; the stop holds it while \
             the loop pushes into it (docs/emulator.md#end-stops)",
            self.end_mm, self.at_s
        )
    }
}

/// The stops of a piston of moving mass `mass_kg` on a stroke of `stroke_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stops {
    stroke_m: f64,
    stiffness_n_per_m: f64,
    damping_ns_per_m: f64,
}

impl Stops {
    pub(crate) fn new(stroke_m: f64, mass_kg: f64) -> Stops {
        Stops {
            stroke_m,
            stiffness_n_per_m: mass_kg * CONTACT_RAD_S * CONTACT_RAD_S,
            damping_ns_per_m: 2.0 * CONTACT_DAMPING * mass_kg * CONTACT_RAD_S,
        }
    }

    /// The force of the stops on the piston at `x_m`, `v_m_s` (N, positive extending): zero
    /// inside the stroke, a push back into it beyond an end.
    pub fn force_n<T: super::Scalar>(&self, x_m: T, v_m_s: T) -> T {
        let (k, c) = (self.stiffness_n_per_m, self.damping_ns_per_m);
        let push = |f: T| if f.re() >= 0.0 { f } else { T::from(0.0) };
        if x_m < 0.0 {
            push(-x_m * k - v_m_s * c)
        } else if x_m > self.stroke_m {
            -push((x_m - self.stroke_m) * k + v_m_s * c)
        } else {
            T::from(0.0)
        }
    }

    /// The end the piston is at or beyond at `x_m`, if any.
    pub(crate) fn end_at(&self, x_m: f64) -> Option<(End, f64)> {
        if x_m <= 0.0 {
            Some((End::Retracted, 0.0))
        } else if x_m >= self.stroke_m {
            Some((End::Extended, self.stroke_m * 1e3))
        } else {
            None
        }
    }

    /// Refuse a rest at `x_m` outside the stroke, for the reference `r_mm`.
    pub(crate) fn check_rest(&self, x_m: f64, r_mm: f64) -> Result<(), String> {
        if x_m > 0.0 && x_m < self.stroke_m {
            return Ok(());
        }
        Err(format!(
            "the emulated loop cannot rest at x_ref = {r_mm} mm: its rest is at x = {:.0} mm, \
             outside the stroke 0…{} mm (the position gain kp is too small to feed the leakage \
             from a position error inside the stroke)",
            x_m * 1e3,
            self.stroke_m * 1e3
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stops_push_only_beyond_an_end_and_never_pull() {
        let s = Stops::new(0.5, 1000.0);
        let k = 1000.0 * CONTACT_RAD_S * CONTACT_RAD_S;
        assert_eq!(s.force_n(0.25, 3.0), 0.0);
        assert_eq!(s.force_n(0.0, -1.0), 0.0);
        // 1 mm beyond x = 0, at rest: the spring alone, pushing out
        assert!((s.force_n(-1e-3, 0.0) - k * 1e-3).abs() < 1e-6 * k);
        // leaving the stop faster than the spring pushes: no pull
        assert_eq!(s.force_n(-1e-6, 10.0), 0.0);
        assert!((s.force_n(0.501, 0.0) + k * 1e-3).abs() < 1e-6 * k);
        assert_eq!(s.force_n(0.500_001, -10.0), 0.0);
        assert_eq!(s.end_at(-1e-9), Some((End::Retracted, 0.0)));
        assert_eq!(s.end_at(0.5), Some((End::Extended, 500.0)));
        assert_eq!(s.end_at(0.3), None);
    }
}
