//! The experiment designer (docs/identification.md#designing-the-sweep): from the rig's linear
//! model, the band that covers the position loop's crossover and the hydraulic resonance, the
//! amplitude that keeps the pumps out of their dead band without driving the motors beyond
//! their rated speed, the piston out of its stroke or a chamber out of its pressure band, the
//! multisine's period that puts its lines densely about the resonance, and the length that
//! gives a stated random error at a stated coherence.

use super::excitation::{Excitation, DEFAULT_LINES, MAX_LINES, MIN_SAMPLES_PER_PERIOD, START_S};
use crate::circuit::Role;
use crate::lti::{bode, eigenvalues, log_grid, margins, resonance, LtiError, StateSpace};
use crate::model::Plant;
use crate::rig::Rig;
use crate::units::{PA_PER_BAR, RAD_S_PER_RPM};
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
    /// The largest within the motors' rated speed, 90 % of the room to the stroke's ends and
    /// [`PRESSURE_SHARE`] of each chamber's room to the edges of its pressure band.
    pub max_amplitude_mm: f64,
    /// The limit that set `max_amplitude_mm`, in words.
    pub amplitude_bound: String,
    /// The multisine's period (s), in whole samples at the goal's rate: 1/`from_hz`, or a whole
    /// multiple of it where the lines must lie closer than 1/`from_hz` to resolve the
    /// least-damped resonance in the band.
    pub period_s: f64,
    /// The lines asked of the multisine (its `lines` key): [`DEFAULT_LINES`], or as many as
    /// put two log-spaced lines within the resonance's half-power band.
    pub lines: usize,
    /// The lines it holds: `lines` log-spaced harmonics of its period, repeats dropped, so
    /// fewer where the band holds fewer harmonics.
    pub lines_held: usize,
    /// Independent averages n_d = (1 − γ²)/(2 γ² ε²) for the goal's ε at its γ².
    pub averages: usize,
    /// Periods of the multisine of `period_s`: the averages and one to settle.
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

/// The share of a chamber's room to the edges of its pressure band
/// ([`crate::circuit::valves::pressure_band_bar`]) the linear model's pressure excursion may
/// take at the designed amplitude's upper limit: the rest is the margin for the multisine's
/// lines adding up beyond a single sine's peak and for the model's error.
pub const PRESSURE_SHARE: f64 = 2.0 / 3.0;

/// The largest amplitude (mm) one limit allows and the limit in words.
type Limit = (f64, String);

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
    let sys = plant.closed_loop_outputs(rig.sum_pressure);
    let grid = log_grid(from_hz / 10.0, to_hz, 200);
    let (speed, peak) = motor_speeds(&plant, &sys, &grid)?;
    let (max_mm, bound) = motion_limit(rig, &plant, peak);
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
    let (period_s, lines) = resolving_grid(&plant, (from_hz, to_hz))?;
    let unit = Excitation::multisine(rig, 1.0, (from_hz, to_hz), (lines, periods), goal.rate_hz)
        .with_period(period_s, goal.rate_hz);
    let by_pressure = least_of(pressure_limits(rig, &plant, &sys, &unit, &mut notes)?);
    let ((max_mm, bound), min_mm) =
        bound_by_pressures((max_mm, bound), min_mm, by_pressure, goal, &mut notes);
    let amplitude_mm = (min_mm * max_mm).sqrt();
    // the period as the record holds it, in whole samples
    let period_s = unit.period_s().unwrap_or(period_s);
    Ok(Design {
        crossover_hz: fc,
        resonance_hz: res,
        from_hz,
        to_hz,
        amplitude_mm,
        min_amplitude_mm: min_mm,
        max_amplitude_mm: max_mm,
        amplitude_bound: bound,
        period_s,
        lines,
        lines_held: unit.harmonics().len(),
        averages,
        periods,
        duration_s: START_S + periods as f64 * period_s,
        notes,
    })
}

/// The least of the motors' rated speed (less the standstill speed) at `peak` rpm per mm of
/// reference and 90 % of the room to the nearer end of the stroke.
fn motion_limit(rig: &Rig, plant: &Plant, peak: f64) -> Limit {
    let op = plant.operating_point();
    let idle_rpm = (plant.states_of(Role::MotorSpeed).into_iter())
        .map(|i| op.state[i].abs())
        .fold(0.0, f64::max)
        / RAD_S_PER_RPM;
    let room = rig.x0_mm.min(rig.stroke_mm - rig.x0_mm);
    let limits: Vec<Limit> = vec![
        (
            (rig.motor_rated_speed_rpm - idle_rpm) / peak,
            "the motors' rated speed".into(),
        ),
        (0.9 * room, "90 % of the room to the stroke's ends".into()),
    ];
    least_of(limits).unwrap_or((f64::NAN, String::new()))
}

/// The upper limit `max` lowered to the chambers' `by_pressure` where that is lower, and the
/// lower limit `min_mm` lowered to it where it exceeds it (the pressures win over the dead
/// band, with a note).
fn bound_by_pressures(
    max: Limit,
    min_mm: f64,
    by_pressure: Option<Limit>,
    goal: &DesignGoal,
    notes: &mut Vec<String>,
) -> (Limit, f64) {
    let max = match by_pressure {
        Some(p) if p.0 < max.0 => p,
        _ => max,
    };
    if min_mm <= max.0 {
        return (max, min_mm);
    }
    notes.push(format!(
        "the chambers' pressures allow {:.2} mm, below the {min_mm:.2} mm that drives the \
         motors {} dead bands: the pumps spend part of the sweep in their dead band",
        max.0, goal.dead_band_factor
    ));
    let low = max.0;
    (max, low)
}

/// The least of `limits`, `None` if there is none.
fn least_of(limits: Vec<Limit>) -> Option<Limit> {
    limits.into_iter().min_by(|a, b| a.0.total_cmp(&b.0))
}

/// The motor speeds (rpm) per mm of reference at each of `grid`, the least of the drives at
/// each frequency, and the largest over every drive and frequency.
fn motor_speeds(
    plant: &Plant,
    sys: &StateSpace,
    grid: &[f64],
) -> Result<(Vec<f64>, f64), LtiError> {
    let mut speed = vec![f64::INFINITY; grid.len()];
    let mut peak: f64 = 0.0;
    for row in rows_of(plant, Role::MotorSpeed) {
        let b = bode(&output(sys, row)?, grid)?;
        for (k, db) in b.mag_db.iter().enumerate() {
            let rpm_per_mm = 10f64.powf(db / 20.0) * 1e-3 / RAD_S_PER_RPM;
            speed[k] = speed[k].min(rpm_per_mm);
            peak = peak.max(rpm_per_mm);
        }
    }
    Ok((speed, peak))
}

/// The rows of [`Plant::closed_loop_outputs`] whose state has `role`.
fn rows_of(plant: &Plant, role: Role) -> Vec<usize> {
    (plant.outputs().iter().enumerate())
        .filter(|(_, o)| o.role == Some(role))
        .map(|(row, _)| row)
        .collect()
}

/// The largest amplitude each chamber's pressure allows: the lowest and highest pressure of
/// the linear loop's periodic response to the multisine `unit` (of 1 mm) within
/// [`PRESSURE_SHARE`] of its room at rest ([`Plant::rest`]) to each edge of its band
/// ([`crate::circuit::valves::pressure_band_bar`]). A chamber that rests outside its band (a
/// valve open at rest) gets a note and no limit.
fn pressure_limits(
    rig: &Rig,
    plant: &Plant,
    sys: &StateSpace,
    unit: &Excitation,
    notes: &mut Vec<String>,
) -> Result<Vec<Limit>, LtiError> {
    let freqs = unit.frequencies_hz();
    let rest =
        (plant.rest(rig.sum_pressure)).map_or_else(|| plant.operating_point().state, |r| r.state);
    let band = crate::circuit::valves::pressure_band_bar(rig);
    let outputs = plant.outputs();
    let mut limits = Vec::new();
    for row in rows_of(plant, Role::Pressure) {
        let (Some(state), name) = (outputs[row].state, &outputs[row].name) else {
            continue;
        };
        let p_bar = rest[state] / PA_PER_BAR;
        // Pa per m of reference → bar per mm
        let h: Vec<_> = (super::model_response(&output(sys, row)?, &freqs, None)?.into_iter())
            .map(|h| h * 1e-8)
            .collect();
        let (down, up) = unit.response_range(&h);
        let rooms = [
            (p_bar - band[0].0, -down, band[0].1),
            (band[1].0 - p_bar, up, band[1].1),
        ];
        for (room, per_mm, edge) in rooms {
            if room <= 0.0 {
                notes.push(format!(
                    "{name} rests at {p_bar:.2} bar, outside its band ({edge}): no pressure \
                     limit from it"
                ));
            } else if per_mm > 0.0 {
                limits.push((
                    PRESSURE_SHARE * room / per_mm,
                    format!(
                        "{name}: {:.0} % of its {room:.2} bar from {p_bar:.2} bar at rest to {edge}",
                        100.0 * PRESSURE_SHARE
                    ),
                ));
            }
        }
    }
    Ok(limits)
}

/// The multisine's period (s) and lines for the band `(from_hz, to_hz)`, so that two lines
/// at the least fall within the half-power band 2ζ f_n of the plant's least-damped complex pole
/// pair in the band, its hydraulic resonance: the period 1/`from_hz`, or the least whole
/// multiple of it whose harmonics lie at most ζ f_n apart (at most 100 times 1/`from_hz`), and
/// the lines [`DEFAULT_LINES`], or as many as log-spaced lines need to lie a ratio 1 + ζ/2
/// apart, 1 + ln(to/from)/ln(1 + ζ/2) (at most [`MAX_LINES`]), closer than the harmonics
/// there, so that every harmonic about the resonance is a line.
fn resolving_grid(plant: &Plant, (from_hz, to_hz): (f64, f64)) -> Result<(f64, usize), LtiError> {
    let Some(r) = resonance(&eigenvalues(&plant.a)?, from_hz, to_hz) else {
        return Ok((1.0 / from_hz, DEFAULT_LINES));
    };
    let z = r.damping.unwrap_or(1.0).max(1e-6);
    let k = (from_hz / (z * r.natural_freq_hz)).ceil().clamp(1.0, 100.0);
    let log_lines = 1.0 + (to_hz / from_hz).ln() / (0.5 * z).ln_1p();
    let lines = (log_lines.ceil() as usize).clamp(DEFAULT_LINES, MAX_LINES);
    Ok((k / from_hz, lines))
}

/// What a record of a sweep on the rig tells the design: its coherence and the amplitude it
/// was recorded at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pilot {
    /// The median coherence over the record's usable frequencies.
    pub coherence: f64,
    /// The record's peak deviation of the reference from where it starts (mm).
    pub amplitude_mm: f64,
    /// How long its loop took to reach periodic steady state (s): the leading periods its
    /// estimate left out as transient; 0 where it is not periodic.
    pub settling_s: f64,
}

/// The coherence a sweep of `to_mm` would have where one of `from_mm` had `coherence`: the
/// response's power grows with the amplitude squared, the noise's does not, so the
/// signal-to-noise ratio γ²/(1 − γ²) scales by (to/from)² (Bendat & Piersol 2010, §9.2.3).
pub fn coherence_at(coherence: f64, from_mm: f64, to_mm: f64) -> f64 {
    let g2 = coherence.clamp(0.0, 1.0 - 1e-12);
    let snr = g2 / (1.0 - g2) * (to_mm / from_mm).powi(2);
    if snr.is_finite() {
        snr / (1.0 + snr)
    } else {
        g2
    }
}

/// [`design`] with the coherence read from a pilot record instead of the goal's: the pilot's
/// coherence at the design's amplitude ([`coherence_at`]) sets the averages for the goal's ε,
/// and the pilot's settling the periods left to settle (at least one) before at least 3 and
/// one to spare ([`super::spectra::transient_periods`]), a note says so. The
/// band, amplitude and lines do not depend on it.
pub fn design_from_pilot(rig: &Rig, goal: &DesignGoal, pilot: &Pilot) -> Result<Design, LtiError> {
    let first = design(rig, goal)?;
    let coherence = coherence_at(pilot.coherence, pilot.amplitude_mm, first.amplitude_mm);
    let mut d = design(rig, &DesignGoal { coherence, ..*goal })?;
    let settle = (pilot.settling_s / d.period_s - 1e-6)
        .ceil()
        .clamp(1.0, 1e4) as usize;
    // the transient check (spectra::transient_periods) recognises a settled period only with
    // two more after it to compare, and a record whose last periods still drift by its noise
    // needs one more: at least 3 averaged, and one to spare
    d.periods = settle + d.averages.max(3) + 1;
    d.duration_s = START_S + d.periods as f64 * d.period_s;
    d.notes.push(format!(
        "the record's median coherence {:.4} at {:.2} mm is {coherence:.4} at {:.2} mm: {} \
         averages give ε = {} there; its loop settled in {:.1} s: {settle} periods to settle",
        pilot.coherence,
        pilot.amplitude_mm,
        d.amplitude_mm,
        d.averages,
        goal.relative_error,
        pilot.settling_s
    ));
    Ok(d)
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
