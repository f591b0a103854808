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
    mode_of, Mode, SwitchCounter, Switching, MAX_SETTLING_S, SETTLED_FRACTION,
};
use crate::circuit::CircuitKind;
use crate::rig::Rig;
use crate::source_files::FieldError;

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

/// Refuse a rig of a circuit without modes to switch between.
fn require_single_pump(rig: &Rig) -> Result<(), EmulatorError> {
    crate::circuit::require(rig, "the chatter prediction", CircuitKind::has_modes)
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
    let (settled_at_s, seconds) = step_times_s(rig)?;
    let (x0, to) = (rig.x0_mm * 1e-3, (rig.x0_mm + STEP_MM) * 1e-3);
    let reference = move |t: f64| if t < HOLD_S { x0 } else { to };
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

/// When [`step`] on `rig` counts as settled and how long it runs (s from the run's start):
/// [`HOLD_S`] plus the 2 % settling time of the mode at rest's slowest closed-loop pole (at most
/// [`MAX_SETTLING_S`]), then [`TAIL_S`] more.
///
/// # Errors
/// A mode whose model cannot be analysed.
fn step_times_s(rig: &Rig) -> Result<(f64, f64), EmulatorError> {
    let at_rest = crate::circuit::single_pump::modes::switching(rig).mode_at_rest;
    let settle = Mode::new(rig, 3 - at_rest)
        .settling_time_s()
        .map_err(|e| EmulatorError(e.to_string()))?
        .min(MAX_SETTLING_S);
    let settled_at_s = HOLD_S + settle;
    Ok((settled_at_s, settled_at_s + TAIL_S))
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

/// A wave a chatter scan runs at each force ([`sine`]): the article's sine records' timing
/// (1 s at rest, the start-up transient, [`WATCHED_PERIODS`] whole periods watched) at
/// `freq_hz` and `amplitude_mm` about x0.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Wave {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Amplitude about x0 (mm).
    pub amplitude_mm: f64,
}

/// The external forces a chatter scan runs (N).
#[derive(Debug, Clone, PartialEq)]
pub enum Forces {
    /// `points` forces about the switching force: the switching force itself, then half the
    /// rest evenly below it down to [`DEFAULT_SPAN`] times the valve band's reach below it, the
    /// other half evenly above it up to as many times its reach above
    /// (docs/circuits.md#a-scan-of-the-load).
    AboutSwitching {
        /// How many forces.
        points: usize,
    },
    /// `points` forces evenly from `from_n` to `to_n`, both included.
    Range {
        /// The lowest force (N).
        from_n: f64,
        /// The highest force (N).
        to_n: f64,
        /// How many forces.
        points: usize,
    },
    /// These forces (N).
    Given(Vec<f64>),
}

/// The forces a scan runs when none are asked for ([`Forces::AboutSwitching`]): 13, the
/// switching force and six each side of it, so that the valve band's edges are two of them
/// **\[choice\]**.
pub const DEFAULT_POINTS: usize = 13;

/// How far the default scan reaches either side of the switching force, in the valve band's
/// own reach on that side (A1 Δp_crack below, A2 Δp_crack above): three times, so that the
/// forces a step's transient acceleration carries across the band are in it too
/// (docs/circuits.md#a-scan-of-the-load) **\[choice\]**.
pub const DEFAULT_SPAN: f64 = 3.0;

impl Forces {
    /// The forces (N) for a circuit switching as `s` says: increasing, each once.
    ///
    /// # Errors
    /// A range of fewer than two points or whose ends do not increase; a force that is not a
    /// rig's `external_force_n` (finite, within its range); no force given; more forces than
    /// one array holds ([`crate::limits::MAX_POINTS`]).
    pub fn values(&self, s: &Switching) -> Result<Vec<f64>, FieldError> {
        let force = |field: &'static str, f: f64| match Rig::check_key("external_force_n", f) {
            Some(why) => Err(FieldError::new(
                field,
                format!("{field} = {f}: as an external_force_n, {why}"),
            )),
            None => Ok(f),
        };
        let check_points = |points: usize| -> Result<(), FieldError> {
            if points < 2 {
                return Err(FieldError::new(
                    "points",
                    format!("points = {points}: a range needs at least 2"),
                ));
            }
            crate::limits::check_size("points", points as f64)
                .map_err(|e| FieldError::new("points", e.to_string()))?;
            Ok(())
        };
        let even = |from: f64, to: f64, points: usize| -> Result<Vec<f64>, FieldError> {
            check_points(points)?;
            let step = (to - from) / (points - 1) as f64;
            Ok((0..points).map(|k| from + step * k as f64).collect())
        };
        let mut forces = match self {
            Forces::AboutSwitching { points } => {
                check_points(*points)?;
                let f_s = s.switching_force_n;
                let floor = f64::EPSILON * f_s.abs().max(1.0);
                let below = DEFAULT_SPAN * (f_s - s.valve_band_n[0]).max(floor);
                let above = DEFAULT_SPAN * (s.valve_band_n[1] - f_s).max(floor);
                let (n_below, n_above) = ((points - 1) / 2, points - 1 - (points - 1) / 2);
                let lower = (0..n_below).map(|k| f_s - below * (1.0 - k as f64 / n_below as f64));
                let upper = (1..=n_above).map(|k| f_s + above * k as f64 / n_above as f64);
                lower.chain([f_s]).chain(upper).collect()
            }
            Forces::Range {
                from_n,
                to_n,
                points,
            } => {
                let (from, to) = (force("from_n", *from_n)?, force("to_n", *to_n)?);
                if from >= to {
                    return Err(FieldError::new(
                        "to_n",
                        format!("to_n = {to}: must be above from_n = {from}"),
                    ));
                }
                even(from, to, *points)?
            }
            Forces::Given(given) => {
                crate::limits::check_size("forces_n", given.len() as f64)
                    .map_err(|e| FieldError::new("forces_n", e.to_string()))?;
                if given.is_empty() {
                    return Err(FieldError::new(
                        "forces_n",
                        "forces_n: give at least one force",
                    ));
                }
                (given.iter())
                    .map(|&f| force("forces_n", f))
                    .collect::<Result<Vec<_>, _>>()?
            }
        };
        forces.sort_by(f64::total_cmp);
        forces.dedup();
        Ok(forces)
    }
}

/// What a chatter scan runs: the 5 mm step (always) and `waves` at each of `forces`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanRequest {
    /// The external forces.
    pub forces: Forces,
    /// The waves run at each force beside the step.
    pub waves: Vec<Wave>,
}

impl Default for ScanRequest {
    /// The step alone at the default forces about the switching force.
    fn default() -> Self {
        ScanRequest {
            forces: Forces::AboutSwitching {
                points: DEFAULT_POINTS,
            },
            waves: Vec::new(),
        }
    }
}

/// How one force of a scan came out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ForceVerdict {
    /// No run switched modes, and the step settled.
    Quiet,
    /// Some run switched, but only as a step's transient or a wave's reference explains: the
    /// normal mode changes of a load whose needed force crosses the switching force.
    Switches,
    /// A run chatters ([`ModeRun::chatters`]): the step switches (or swings) after it has
    /// settled, or a wave switches in its watched periods more often than its reference
    /// explains.
    Chatters,
}

/// One force of a chatter scan: its step, its waves and what they add up to.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ForceScan {
    /// The external force (N).
    pub external_force_n: f64,
    /// The mode at rest before the step (1: chamber 2 on the accumulator, 2: chamber 1;
    /// `None`: both valves shut, the cylinder locked between the two).
    pub mode_at_start: Option<usize>,
    /// The verdict at this force.
    pub verdict: ForceVerdict,
    /// Mode switches over every run (the step's and the waves').
    pub switches: usize,
    /// Of those, the switches after the step settled and in the waves' watched periods.
    pub switches_after_settling: usize,
    /// Of those, the ones the waves' references explain ([`reference_crossings`]).
    pub switches_explained: usize,
    /// The switches after settling beyond those explained, summed over the runs (a wave that
    /// switches less often than its reference explains adds none): the loop switching on its own.
    pub extra_switches: usize,
    /// The 5 mm step ([`step`]).
    pub step: ModeRun,
    /// Each wave of the request ([`sine`]), in order.
    pub waves: Vec<ModeRun>,
}

impl ForceScan {
    /// The runs at `force_n` summed up.
    fn of(force_n: f64, step: ModeRun, waves: Vec<ModeRun>) -> ForceScan {
        let runs = || std::iter::once(&step).chain(&waves);
        let sum = |f: &dyn Fn(&ModeRun) -> usize| runs().map(f).sum::<usize>();
        let switches = sum(&|r| r.switches);
        let chatters = runs().any(|r| r.chatters);
        ForceScan {
            external_force_n: force_n,
            mode_at_start: step.mode_at_start,
            verdict: match (chatters, switches) {
                (true, _) => ForceVerdict::Chatters,
                (false, 0) => ForceVerdict::Quiet,
                _ => ForceVerdict::Switches,
            },
            switches,
            switches_after_settling: sum(&|r| r.switches_after_settling),
            switches_explained: sum(&|r| r.switches_explained),
            extra_switches: sum(&|r| {
                (r.switches_after_settling).saturating_sub(r.switches_explained)
            }),
            step,
            waves,
        }
    }
}

/// A chatter scan of a single-pump rig (docs/circuits.md#a-scan-of-the-load): where it
/// switches, what happened at each force, and the verdict.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Scan {
    /// The switching force, its valve band and where the rig's own load rests.
    #[serde(flatten)]
    pub switching: Switching,
    /// The waves run at each force beside the step.
    pub waves: Vec<Wave>,
    /// Each force, increasing.
    pub forces: Vec<ForceScan>,
    /// The runs of consecutive scanned forces where nothing switched (N, lowest and highest).
    pub quiet_ranges_n: Vec<(f64, f64)>,
    /// The runs of consecutive scanned forces that chatter (N, lowest and highest).
    pub chattering_ranges_n: Vec<(f64, f64)>,
    /// Some force chatters.
    pub chatters: bool,
}

/// Why a chatter scan cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScanError {
    /// A field of the request is wrong.
    #[error("{0}")]
    Request(FieldError),
    /// The scan is beyond its work limit.
    #[error("{0}")]
    Limit(#[from] crate::limits::LimitError),
    /// A run cannot be emulated (the rig or the force named).
    #[error("{0}")]
    Run(String),
}

/// The runs of consecutive `forces` whose verdict `keep` holds, as (lowest, highest) force (N).
fn ranges_n(forces: &[ForceScan], keep: impl Fn(&ForceScan) -> bool) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut open = false;
    for f in forces {
        let kept = keep(f);
        match (kept, open, out.last_mut()) {
            (true, true, Some(last)) => last.1 = f.external_force_n,
            (true, _, _) => out.push((f.external_force_n, f.external_force_n)),
            _ => {}
        }
        open = kept;
    }
    out
}

/// Check the waves of a request on `rig`: each frequency and amplitude finite and positive,
/// below the PLC's Nyquist frequency, and the wave inside the stroke.
fn check_waves(rig: &Rig, waves: &[Wave]) -> Result<(), FieldError> {
    for w in waves {
        let named = |why: String| {
            FieldError::new(
                "waves",
                format!("waves = {}:{}: {why}", w.freq_hz, w.amplitude_mm),
            )
        };
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !(positive(w.freq_hz) && positive(w.amplitude_mm)) {
            return Err(named("the frequency and the amplitude must be > 0".into()));
        }
        if w.freq_hz >= 0.5 * PLC_RATE_HZ {
            return Err(named(format!(
                "at or above the PLC's Nyquist frequency, {} Hz",
                0.5 * PLC_RATE_HZ
            )));
        }
        rig.check_reference(rig.x0_mm - w.amplitude_mm, rig.x0_mm + w.amplitude_mm)
            .map_err(|e| named(e.to_string()))?;
    }
    Ok(())
}

/// The chatter scan of `rig` (a single-pump circuit, [`crate::circuit::mode_switching`]):
/// at each force of `request` the emulated 5 mm step ([`step`]) and each wave ([`sine`]) on the
/// rig loaded with it, the emulator's effects for that rig ([`Effects::for_rig`], as
/// [`scan_forces`]), the forces in parallel. `work` follows the runs (one unit each); the
/// controller steps of the whole scan are held to [`crate::limits::MAX_EMULATED_STEPS`]
/// unless it allows a long run.
///
/// # Errors
/// A circuit without modes (its reason in one line), a request field that is wrong, a scan
/// beyond its work limit, or a run the emulator cannot do (the force named).
pub fn scan(
    rig: &Rig,
    request: &ScanRequest,
    work: &crate::limits::Work,
) -> Result<Scan, ScanError> {
    use rayon::prelude::*;
    let switching = crate::circuit::mode_switching(rig).map_err(|why| {
        ScanError::Run(format!(
            "circuit = \"{}\": no modes to switch between: {why}",
            rig.circuit.name()
        ))
    })?;
    let forces = request
        .forces
        .values(&switching)
        .map_err(ScanError::Request)?;
    check_waves(rig, &request.waves).map_err(ScanError::Request)?;
    rig.check_reference(rig.x0_mm, rig.x0_mm + STEP_MM)
        .map_err(|e| ScanError::Run(format!("the {STEP_MM} mm step: {e}")))?;
    let loaded = |f: f64| Rig {
        external_force_n: f,
        ..rig.clone()
    };
    let at = |f: f64, e: EmulatorError| ScanError::Run(format!("external force {f} N: {e}"));
    if !work.allow_long_run {
        let waves_s: f64 = request.waves.iter().map(|w| sine_seconds(w.freq_hz)).sum();
        let mut seconds = 0.0;
        for &f in &forces {
            seconds += step_times_s(&loaded(f)).map_err(|e| at(f, e))?.1 + waves_s;
        }
        crate::limits::check_work(
            "forces × runs (emulated controller steps)",
            seconds * PLC_RATE_HZ,
            crate::limits::MAX_EMULATED_STEPS,
            false,
        )?;
    }
    let scanned = (forces.par_iter())
        .map(|&f| {
            let r = loaded(f);
            let effects = Effects::for_rig(&r).map_err(|e| at(f, e))?;
            let step = step(&r, effects).map_err(|e| at(f, e))?;
            work.advance(1)?;
            let waves = (request.waves.iter())
                .map(|w| {
                    let run = sine(&r, effects, w.freq_hz, w.amplitude_mm).map_err(|e| at(f, e));
                    work.advance(1)?;
                    run
                })
                .collect::<Result<Vec<_>, _>>()?;
            Ok(ForceScan::of(f, step, waves))
        })
        .collect::<Result<Vec<_>, ScanError>>()?;
    Ok(Scan {
        switching,
        waves: request.waves.clone(),
        quiet_ranges_n: ranges_n(&scanned, |f| f.verdict == ForceVerdict::Quiet),
        chattering_ranges_n: ranges_n(&scanned, |f| f.verdict == ForceVerdict::Chatters),
        chatters: scanned.iter().any(|f| f.verdict == ForceVerdict::Chatters),
        forces: scanned,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scan's forces: by default the switching force and as many each side, out to three
    /// times the valve band's reach on that side; given forces sorted, each once; a range of
    /// one point, a range that does not increase and a force no rig takes are refused, each
    /// naming its field.
    #[test]
    fn a_scans_forces_lie_about_the_switching_force_and_are_checked() {
        let rig = Rig {
            circuit: CircuitKind::SinglePump,
            ..Rig::default()
        };
        let s = crate::circuit::single_pump::modes::switching(&rig);
        let f_s = s.switching_force_n;
        let (below, above) = (f_s - s.valve_band_n[0], s.valve_band_n[1] - f_s);
        let got = Forces::AboutSwitching { points: 5 }.values(&s).unwrap();
        let want = [
            f_s - 3.0 * below,
            f_s - 1.5 * below,
            f_s,
            f_s + 1.5 * above,
            f_s + 3.0 * above,
        ];
        assert_eq!(got.len(), 5);
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-9 * f_s, "{got:?} vs {want:?}");
        }
        assert_eq!(got[2], f_s);
        let given = Forces::Given(vec![300.0, -20.0, 300.0]).values(&s).unwrap();
        assert_eq!(given, [-20.0, 300.0]);
        let refused = |f: Forces| f.values(&s).unwrap_err().field;
        let range = |from_n, to_n, points| Forces::Range {
            from_n,
            to_n,
            points,
        };
        assert_eq!(refused(range(0.0, 10.0, 1)), "points");
        assert_eq!(refused(range(10.0, 0.0, 3)), "to_n");
        assert_eq!(refused(range(-2e9, 0.0, 3)), "from_n");
        assert_eq!(refused(Forces::Given(Vec::new())), "forces_n");
        assert_eq!(refused(Forces::Given(vec![f64::NAN])), "forces_n");
        assert_eq!(refused(Forces::AboutSwitching { points: 1 }), "points");
    }

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
