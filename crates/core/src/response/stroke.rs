//! Whether a predicted response stays inside the cylinder (docs/emulator.md#end-stops): the
//! linear model of the article §2.3 has no end stops, so a large step or wave can predict a
//! piston beyond x = 0 or the stroke, which the real cylinder cannot follow (the emulator's end
//! stops hold it, docs/emulator.md#end-stops). One check, used by `step`, `track`, `simulate`
//! and Python's `simulate`, says so.

use super::Signals;
use crate::rig::Rig;
use serde::Serialize;
use std::fmt;

/// A predicted position outside the stroke 0 … `stroke_mm`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StrokeExcursion {
    /// The stroke (mm).
    pub stroke_mm: f64,
    /// The lowest predicted position (mm).
    pub min_x_mm: f64,
    /// The highest predicted position (mm).
    pub max_x_mm: f64,
    /// The first time the prediction is outside the stroke (s).
    pub first_s: f64,
}

impl fmt::Display for StrokeExcursion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (min, max) = (self.min_x_mm, self.max_x_mm);
        let reach = if max >= self.stroke_mm && min <= 0.0 {
            format!("{min:.1} mm and {max:.1} mm")
        } else if max >= self.stroke_mm {
            format!("{max:.1} mm")
        } else {
            format!("{min:.1} mm")
        };
        write!(
            f,
            "the predicted position reaches {reach}, outside the stroke 0…{} mm, from t = {:.3} s: \
             the cylinder would hit its end stop there, which the linear model does not \
             (docs/emulator.md#end-stops)",
            self.stroke_mm, self.first_s
        )
    }
}

/// Where the predicted position of `s` leaves the stroke of `rig` (at or beyond 0 or
/// `stroke_mm`), if it does.
pub fn stroke_excursion(rig: &Rig, s: &Signals) -> Option<StrokeExcursion> {
    let outside = |x: f64| x <= 0.0 || x >= rig.stroke_mm;
    let first = s.x_mm.iter().position(|x| outside(*x))?;
    let (min, max) = s
        .x_mm
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(*x), hi.max(*x))
        });
    Some(StrokeExcursion {
        stroke_mm: rig.stroke_mm,
        min_x_mm: min,
        max_x_mm: max,
        first_s: s.time_s[first],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_that_overshoots_the_end_is_an_excursion_and_a_small_one_is_not() {
        let rig = Rig::default();
        // the article's 5 mm step from x0 = 345 mm: inside the 500 mm stroke
        let small = super::super::step(&rig, 5.0, 3.0, 100.0).unwrap();
        assert_eq!(stroke_excursion(&rig, &small), None);
        // 154 mm to 499 mm: the linear model overshoots by half the step (docs/simulation.md)
        let big = super::super::step(&rig, 154.0, 3.0, 100.0).unwrap();
        let e = stroke_excursion(&rig, &big).unwrap();
        let peak = big.x_mm.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(e.max_x_mm, peak);
        assert!(peak > 570.0 && peak < 585.0, "{peak}");
        // the first sample at or beyond 500 mm, and none before it
        let k = big.time_s.iter().position(|t| *t == e.first_s).unwrap();
        assert!(big.x_mm[k] >= 500.0 && big.x_mm[..k].iter().all(|x| *x < 500.0));
        assert!(e.to_string().contains("reaches 5"), "{e}");
        // and downwards, past x = 0
        let down = super::super::step(&rig, -340.0, 3.0, 100.0).unwrap();
        let e = stroke_excursion(&rig, &down).unwrap();
        assert!(e.min_x_mm < 0.0 && e.max_x_mm <= 345.0 + 1e-9, "{e:?}");
    }
}
