//! The experiment designer (docs/identification.md#designing-the-sweep): from the rig's linear
//! model, the band that covers the position loop's crossover and the hydraulic resonance, the
//! amplitude that keeps the pumps out of their dead band without driving the motors beyond
//! their rated speed or the piston out of its stroke, and the length that gives a stated
//! random error at a stated coherence.

use super::excitation::{MIN_SAMPLES_PER_PERIOD, START_S};
use crate::circuit::Role;
use crate::lti::{bode, eigenvalues, log_grid, margins, resonance, LtiError, StateSpace};
use crate::model::Plant;
use crate::rig::Rig;
use crate::units::RAD_S_PER_RPM;
use serde::Serialize;

/// What the sweep is to achieve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignGoal {
    /// The coherence expected where the band is read (0 … 1).
    pub coherence: f64,
    /// The relative random error ε wanted at that coherence.
    pub relative_error: f64,
    /// The pumps' low-speed dead band (rpm): the emulator's default is 60 (docs/emulator.md).
    pub dead_band_rpm: f64,
    /// The motor speed amplitude at the lowest frequency, in dead bands.
    pub dead_band_factor: f64,
    /// The record's sample rate (Hz); by default the PLC's 100 Hz (docs/emulator.md).
    pub rate_hz: f64,
}

impl Default for DesignGoal {
    fn default() -> Self {
        DesignGoal {
            coherence: 0.9,
            relative_error: 0.05,
            dead_band_rpm: 60.0,
            dead_band_factor: 5.0,
            rate_hz: 100.0,
        }
    }
}

/// A sweep designed for a rig.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Design {
    /// Gain crossover of the position loop (Hz), docs/analysis.md#margins.
    pub crossover_hz: f64,
    /// The plant's least-damped resonance above the crossover (Hz), if any.
    pub resonance_hz: Option<f64>,
    /// Lowest frequency (Hz).
    pub from_hz: f64,
    /// Highest frequency (Hz).
    pub to_hz: f64,
    /// Amplitude (mm): the geometric mean of the two limits below.
    pub amplitude_mm: f64,
    /// The smallest amplitude that drives the motors `dead_band_factor` dead bands at `from_hz`.
    pub min_amplitude_mm: f64,
    /// The largest within the motors' rated speed and 90 % of the room to the stroke's ends.
    pub max_amplitude_mm: f64,
    /// Independent averages n_d = (1 − γ²)/(2 γ² ε²) for the goal's ε at its γ².
    pub averages: usize,
    /// Periods of a multisine of period 1/`from_hz`: the averages and one to settle.
    pub periods: usize,
    /// Record length (s): the lead-in and the periods.
    pub duration_s: f64,
    /// What limited the design.
    pub notes: Vec<String>,
}

/// The single-output system of output `row` of `sys`.
fn output(sys: &StateSpace, row: usize) -> Result<StateSpace, LtiError> {
    StateSpace::new(
        sys.a.clone(),
        sys.b.clone(),
        sys.c.rows(row, 1).into_owned(),
        sys.d.rows(row, 1).into_owned(),
    )
}

/// Design a sweep for `rig` (see the module's description).
pub fn design(rig: &Rig, goal: &DesignGoal) -> Result<Design, LtiError> {
    let plant = Plant::new(rig);
    let m = margins(&plant.open_loop(false))?;
    let fc = m.gain_crossover_hz.unwrap_or(1.0);
    let top_hz = goal.rate_hz / (MIN_SAMPLES_PER_PERIOD * 1.25);
    let res = resonance(&eigenvalues(&plant.a)?, fc, top_hz).map(|p| p.natural_freq_hz);
    let mut notes = Vec::new();
    let mut from_hz = fc / 10.0;
    let to_hz = (2.0 * fc).max(res.map_or(0.0, |f| 1.5 * f)).min(top_hz);
    if to_hz < 2.0 * fc {
        notes.push(format!(
            "the band ends at {to_hz:.3} Hz, {} samples per period at {} Hz",
            MIN_SAMPLES_PER_PERIOD * 1.25,
            goal.rate_hz
        ));
    }
    // motor speeds (rpm) per mm of reference, drives 1 and 2, over the band
    let sys = plant.closed_loop_outputs(rig.sum_pressure);
    let grid = log_grid(from_hz / 10.0, to_hz, 200);
    let mut speed = vec![f64::INFINITY; grid.len()];
    let mut peak: f64 = 0.0;
    let motor_rows = (plant.outputs().iter().enumerate())
        .filter(|(_, o)| o.role == Some(Role::MotorSpeed))
        .map(|(row, _)| row)
        .collect::<Vec<_>>();
    for row in motor_rows {
        let b = bode(&output(&sys, row)?, &grid)?;
        for (k, db) in b.mag_db.iter().enumerate() {
            let rpm_per_mm = 10f64.powf(db / 20.0) * 1e-3 / RAD_S_PER_RPM;
            speed[k] = speed[k].min(rpm_per_mm);
            peak = peak.max(rpm_per_mm);
        }
    }
    let op = plant.operating_point();
    let idle_rpm = (plant.states_of(Role::MotorSpeed).into_iter())
        .map(|i| op.state[i].abs())
        .fold(0.0, f64::max)
        / RAD_S_PER_RPM;
    let by_speed = (rig.motor_rated_speed_rpm - idle_rpm) / peak;
    let room = rig.x0_mm.min(rig.stroke_mm - rig.x0_mm);
    let max_mm = by_speed.min(0.9 * room);
    let need = goal.dead_band_factor * goal.dead_band_rpm;
    let at = |f: f64| speed[grid.partition_point(|&g| g < f).min(grid.len() - 1)];
    let mut min_mm = need / at(from_hz);
    if min_mm > max_mm {
        // raise the lowest frequency until the motors clear the dead band within the limits
        if let Some(&f) = grid.iter().find(|&&f| need / at(f) <= max_mm && f <= fc) {
            notes.push(format!(
                "at {from_hz:.3} Hz the motors would need {min_mm:.1} mm to clear the dead \
                 band, beyond the {max_mm:.1} mm allowed: the band starts at {f:.3} Hz"
            ));
            from_hz = f;
            min_mm = need / at(f);
        } else {
            notes.push(format!(
                "no amplitude within {max_mm:.1} mm drives the motors {} dead bands below the \
                 crossover: the pumps spend part of the sweep in their dead band",
                goal.dead_band_factor
            ));
            min_mm = max_mm;
        }
    }
    let averages = averages_for(goal.coherence, goal.relative_error);
    let periods = averages + 1;
    Ok(Design {
        crossover_hz: fc,
        resonance_hz: res,
        from_hz,
        to_hz,
        amplitude_mm: (min_mm * max_mm).sqrt(),
        min_amplitude_mm: min_mm,
        max_amplitude_mm: max_mm,
        averages,
        periods,
        duration_s: START_S + periods as f64 / from_hz,
        notes,
    })
}

/// The independent averages n_d at which an H1 estimate of coherence γ² has the relative
/// random error ε: n_d = (1 − γ²)/(2 γ² ε²) (Bendat & Piersol, *Random Data*, 4th ed., 2010,
/// Table 9.6), at least 2, at most 10⁴.
pub fn averages_for(coherence: f64, relative_error: f64) -> usize {
    let g2 = coherence.clamp(1e-6, 1.0);
    let e = relative_error.max(1e-6);
    let n = ((1.0 - g2) / (2.0 * g2 * e * e)).ceil();
    (n as usize).clamp(2, 10_000)
}
