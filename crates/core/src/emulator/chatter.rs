//! The chatter prediction of the single-pump circuit from the emulator
//! (docs/circuits.md#will-it-chatter): the article's 5 mm step (§3.3) and its three sinusoids
//! (§3.3, Figures 11–13) emulated with the valves switching, and the mode switches counted
//! after the loop has settled — the article's §2.1 warning ("non-linear switching dynamics
//! under low-force conditions") answered for a rig before it is built. The continuous-law check
//! of [`crate::circuit::single_pump::modes::StepCheck`] answers the same question without the
//! PLC and the emulator's effects; [`predict`] gives the emulator's answer beside it.

use super::article::{sine_periods, SINE_START_S};
use super::{Dynamics, Effects, EmulatorError, Plc, PlcLoop, PLC_RATE_HZ, STEP_MM};
use crate::circuit::single_pump::modes::{
    mode_of, Mode, SwitchCounter, MAX_SETTLING_S, SETTLED_FRACTION,
};
use crate::circuit::CircuitKind;
use crate::rig::Rig;

/// Time the step check watches after the step has settled (s), as the continuous-law check
/// ([`crate::circuit::single_pump::modes::StepCheck::ARTICLE`]) **\[choice\]**.
pub const TAIL_S: f64 = 10.0;

/// Time held at the start before the step (s): the record opens at rest.
pub const HOLD_S: f64 = 1.0;

/// What one emulated run of the single-pump circuit did with its modes.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModeRun {
    /// The experiment in words, e.g. `5 mm step` or `sine 0.10 Hz, 50 mm`.
    pub experiment: String,
    /// The external force (N).
    pub external_force_n: f64,
    /// The mode at rest before the run (1: chamber 2 on the accumulator, 2: chamber 1;
    /// `None`: both valves shut).
    pub mode_at_start: Option<usize>,
    /// Mode switches over the whole run, counted at the PLC's samples.
    pub switches: usize,
    /// When the loop counts as settled (s from the run's start): the step's settling time of
    /// the mode at rest's linear model after the step; the sine's start-up transient.
    pub settled_at_s: f64,
    /// Mode switches after `settled_at_s`.
    pub switches_after_settling: usize,
    /// Of those, the switches the reference itself explains (a sine: the times the force its
    /// motion needs crosses the switching force in the watched periods, [`reference_crossings`];
    /// a step: none).
    pub switches_explained: usize,
    /// Length of the watched window after `settled_at_s` (s).
    pub watched_s: f64,
    /// Half the peak-to-peak control error x_ref − x after `settled_at_s` (m): for the step
    /// the amplitude of any sustained oscillation; for a sine the tracking error.
    pub error_amplitude_m: f64,
    /// The run chatters: after settling, the step switches at all or keeps oscillating by more
    /// than [`SETTLED_FRACTION`] of the step; a sine switches in its watched periods more often
    /// than the reference explains (`switches_explained`).
    pub chatters: bool,
}

/// The emulator's chatter prediction on one rig: the step and the three sines.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Prediction {
    /// The 5 mm step from x0.
    pub step: ModeRun,
    /// The article's three sinusoids about x0.
    pub sines: Vec<ModeRun>,
}

impl Prediction {
    /// Any of the runs chatters.
    pub fn chatters(&self) -> bool {
        self.step.chatters || self.sines.iter().any(|s| s.chatters)
    }
}

/// Refuse a rig that is not a single-pump circuit.
fn require_single_pump(rig: &Rig) -> Result<(), EmulatorError> {
    crate::circuit::require(rig, "the chatter prediction", &[CircuitKind::SinglePump])
        .map_err(EmulatorError)
}

/// The emulated run of `rig` (the emulator's effects `effects`, a noise-free PLC at 100 Hz)
/// from rest at `reference(0)` for `seconds`, switches counted at each PLC sample
/// ([`SwitchCounter`] on [`mode_of`]) and the error watched from `settled_at_s` on.
fn watch(
    rig: &Rig,
    effects: Effects,
    reference: &dyn Fn(f64) -> f64,
    (seconds, settled_at_s): (f64, f64),
) -> Result<(Option<usize>, usize, usize, f64), EmulatorError> {
    let d = Dynamics::new(rig, effects)?;
    let c = d
        .circuit()
        .single_pump()
        .cloned()
        .ok_or("not a single-pump circuit")?;
    let plc = Plc::ideal(PLC_RATE_HZ);
    let mut run = PlcLoop::settled(rig, &d, &plc, reference(0.0) * 1e3, 0.0)?;
    let start = mode_of(&c, run.state());
    let mut counter = SwitchCounter::starting_in(start);
    let (mut before, mut lo, mut hi) = (None, f64::INFINITY, f64::NEG_INFINITY);
    let ts = run.period_s();
    for k in 0..(seconds / ts).round() as usize {
        let t = k as f64 * ts;
        let u = run.commands(reference(t) * 1e3);
        run.hold(u, t, t + ts)?;
        counter.observe(mode_of(&c, run.state()));
        if t + ts >= settled_at_s {
            before.get_or_insert(counter.switches);
            let e = reference(t + ts) - run.state()[d.at.position];
            (lo, hi) = (lo.min(e), hi.max(e));
        }
    }
    let after = counter.switches - before.unwrap_or(counter.switches);
    Ok((start, counter.switches, after, 0.5 * (hi - lo)))
}

/// The emulated 5 mm step (the article §3.3) of `rig` from rest at x0, after [`HOLD_S`]:
/// settled at the 2 % settling time 4/|Re s| of the slowest closed-loop pole of the mode at
/// rest's linear model (at most [`MAX_SETTLING_S`]), watched for [`TAIL_S`] more.
///
/// # Errors
/// A rig that is not a single-pump circuit, a mode whose model cannot be analysed, or an
/// emulator error.
pub fn step(rig: &Rig, effects: Effects) -> Result<ModeRun, EmulatorError> {
    require_single_pump(rig)?;
    let at_rest = crate::circuit::single_pump::modes::switching(rig).mode_at_rest;
    let settle = Mode::new(rig, 3 - at_rest)
        .settling_time_s()
        .map_err(|e| EmulatorError(e.to_string()))?
        .min(MAX_SETTLING_S);
    let (x0, to) = (rig.x0_mm * 1e-3, (rig.x0_mm + STEP_MM) * 1e-3);
    let reference = move |t: f64| if t < HOLD_S { x0 } else { to };
    let settled_at_s = HOLD_S + settle;
    let seconds = settled_at_s + TAIL_S;
    let (start, switches, after, amplitude) =
        watch(rig, effects, &reference, (seconds, settled_at_s))?;
    Ok(ModeRun {
        experiment: format!("{STEP_MM} mm step"),
        external_force_n: rig.external_force_n,
        mode_at_start: start,
        switches,
        settled_at_s,
        switches_after_settling: after,
        switches_explained: 0,
        watched_s: TAIL_S,
        error_amplitude_m: amplitude,
        chatters: after > 0 || amplitude > SETTLED_FRACTION * STEP_MM * 1e-3,
    })
}

/// The emulated sinusoid of `amplitude_mm` at `freq_hz` about x0 of `rig`, as the article's
/// sine records run it ([`super::article::records`]): at rest for [`SINE_START_S`], then
/// [`super::article::SINE_SETTLE_S`] of wave for the start-up transient, then
/// [`WATCHED_PERIODS`] whole periods watched. It chatters when it switches in them more often
/// than the force the reference's own motion needs crosses the switching force there
/// ([`reference_crossings`]): those are the normal mode changes of a load whose needed force
/// changes side each half period, at most two a period; any beyond them is the loop switching
/// on its own (docs/circuits.md#will-it-chatter).
///
/// # Errors
/// A rig that is not a single-pump circuit, or an emulator error.
pub fn sine(
    rig: &Rig,
    effects: Effects,
    freq_hz: f64,
    amplitude_mm: f64,
) -> Result<ModeRun, EmulatorError> {
    require_single_pump(rig)?;
    let (x0, a) = (rig.x0_mm * 1e-3, amplitude_mm * 1e-3);
    let reference = move |t: f64| {
        let phase = 2.0 * std::f64::consts::PI * freq_hz * (t - SINE_START_S).max(0.0);
        x0 + a * phase.sin()
    };
    let seconds = sine_seconds(freq_hz);
    let watched_s = f64::from(WATCHED_PERIODS) / freq_hz;
    let settled_at_s = seconds - watched_s;
    let (start, switches, after, amplitude) =
        watch(rig, effects, &reference, (seconds, settled_at_s))?;
    let explained = reference_crossings(
        rig,
        freq_hz,
        a,
        (settled_at_s - SINE_START_S, seconds - SINE_START_S),
    );
    Ok(ModeRun {
        experiment: format!("sine {freq_hz:.2} Hz, {amplitude_mm} mm"),
        external_force_n: rig.external_force_n,
        mode_at_start: start,
        switches,
        settled_at_s,
        switches_after_settling: after,
        switches_explained: explained,
        watched_s,
        error_amplitude_m: amplitude,
        chatters: after > explained,
    })
}

/// The whole periods of a sine watched after its start-up transient.
pub const WATCHED_PERIODS: u32 = 2;

/// How long [`sine`] emulates a wave of `freq_hz` (s): [`SINE_START_S`] at rest, then the
/// whole periods of its start-up transient and the [`WATCHED_PERIODS`].
pub fn sine_seconds(freq_hz: f64) -> f64 {
    SINE_START_S + f64::from(sine_periods(freq_hz)) / freq_hz
}

/// The times the force the reference's own motion needs from the chamber pressures,
/// F(t) = F_ext + m ẍ_ref + b ẋ_ref (Newton, docs/model.md#newton; the rig's mass at x0 and
/// viscous friction, Coulomb friction left out), crosses the switching force p_acc (A1 − A2)
/// (docs/circuits.md#the-switching-force) over the wave's time `(from, to)` (s from its start),
/// counted at the PLC's samples: the mode changes the wave of `amplitude_m` at `freq_hz`
/// explains — none while the needed force stays on one side, two a period once it crosses.
pub fn reference_crossings(
    rig: &Rig,
    freq_hz: f64,
    amplitude_m: f64,
    (from, to): (f64, f64),
) -> usize {
    let f_s = crate::circuit::single_pump::modes::switching(rig).switching_force_n;
    let w = 2.0 * std::f64::consts::PI * freq_hz;
    let force = |t: f64| {
        let (v, a) = (
            amplitude_m * w * (w * t).cos(),
            -amplitude_m * w * w * (w * t).sin(),
        );
        rig.external_force_n + rig.mass_kg * a + rig.viscous_friction_ns_per_m * v - f_s
    };
    let ts = 1.0 / PLC_RATE_HZ;
    let n = ((to - from) / ts).round() as usize;
    (1..=n)
        .filter(|&k| {
            let (t0, t1) = (from + (k - 1) as f64 * ts, from + k as f64 * ts);
            (force(t0) > 0.0) != (force(t1) > 0.0)
        })
        .count()
}

/// The article's three sinusoids (Hz, mm): 0.10 Hz at 50 mm, 0.20 Hz at 35 mm, 0.25 Hz at
/// 20 mm (§3.3; the emulated article records').
pub const ARTICLE_SINES: [(f64, f64); 3] = [(0.1, 50.0), (0.2, 35.0), (0.25, 20.0)];

/// The emulator's chatter prediction on `rig`: the 5 mm step and the article's three sines.
///
/// # Errors
/// As [`step`] and [`sine`].
pub fn predict(rig: &Rig, effects: Effects) -> Result<Prediction, EmulatorError> {
    let sines = (ARTICLE_SINES.iter())
        .map(|&(f, a)| sine(rig, effects, f, a))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Prediction {
        step: step(rig, effects)?,
        sines,
    })
}

/// [`step`] at each external force of `forces_n` (N), the rig's emulator effects
/// ([`Effects::for_rig`]) at each: the scan that gives the range of loads over which the
/// emulated step settles without switching.
///
/// # Errors
/// As [`step`].
pub fn scan_forces(rig: &Rig, forces_n: &[f64]) -> Result<Vec<ModeRun>, EmulatorError> {
    (forces_n.iter())
        .map(|&f| {
            let loaded = Rig {
                external_force_n: f,
                ..rig.clone()
            };
            step(&loaded, Effects::for_rig(&loaded)?)
        })
        .collect()
}

/// The widest runs of consecutive forces in `runs` (in the scan's order) whose step settles
/// without switching (`switches == 0` and not chattering), as (lowest, highest) force (N).
pub fn quiet_ranges_n(runs: &[ModeRun]) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut open = false;
    for r in runs {
        let quiet = r.switches == 0 && !r.chatters;
        match (quiet, open, out.last_mut()) {
            (true, true, Some(last)) => last.1 = r.external_force_n,
            (true, _, _) => out.push((r.external_force_n, r.external_force_n)),
            _ => {}
        }
        open = quiet;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The needed force F_ext + m ẍ + b ẋ of a sine of amplitude A is a sinusoid about F_ext
    /// of amplitude A ω √(m² ω² + b²), by hand: over two whole periods it crosses the
    /// switching force four times when F_ext lies closer to it than that, and never otherwise.
    #[test]
    fn the_reference_crosses_the_switching_force_twice_a_period_when_it_reaches_it() {
        let rig = Rig {
            circuit: CircuitKind::SinglePump,
            ..Rig::default()
        };
        let f_s = crate::circuit::single_pump::modes::switching(&rig).switching_force_n;
        let (freq_hz, a) = (0.2, 0.035);
        let w = 2.0 * std::f64::consts::PI * freq_hz;
        let m2w2 = (rig.mass_kg * w).powi(2);
        let swing = a * w * (m2w2 + rig.viscous_friction_ns_per_m.powi(2)).sqrt();
        let window = (20.0, 30.0);
        for (offset, want) in [(0.0, 4), (0.9, 4), (-0.9, 4), (1.1, 0), (-1.1, 0)] {
            let loaded = Rig {
                external_force_n: f_s + offset * swing,
                ..rig.clone()
            };
            assert_eq!(
                reference_crossings(&loaded, freq_hz, a, window),
                want,
                "F_ext − F_s = {offset} × {swing} N"
            );
        }
    }
}
