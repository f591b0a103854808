//! What the emulated rig is asked to do (docs/emulator.md): a position step, a sinusoid or a standstill
//! of the closed loop, or a velocity step of one drive with its motor decoupled from the pump
//! (the article §2.4.1; docs/identification.md#drive-gain).

use super::integrate::integrate;
use super::plc::Noise;
use super::EmulatorError;
use super::{emulate_reporting, Dynamics, Effects, Emulation, Plc, RunError};
use crate::limits::Work;
use crate::response::Signals;
use crate::rig::Rig;
use crate::source_files::FieldError;
use crate::units::RAD_S_PER_RPM;
use std::f64::consts::PI;

/// A closed-loop experiment: the position reference against time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Experiment {
    /// The reference jumps from `from_mm` to `to_mm` at `at_s`.
    Step {
        /// Reference before the step (mm).
        from_mm: f64,
        /// Reference after the step (mm).
        to_mm: f64,
        /// Time of the step (s).
        at_s: f64,
        /// Length of the record (s).
        duration_s: f64,
    },
    /// x_ref = centre + amplitude sin(2π f (t − start)) from `start_s` on (docs/simulation.md#tracking-metrics).
    Sine {
        /// Centre of the sinusoid, and the reference before `start_s` (mm).
        centre_mm: f64,
        /// Amplitude (mm).
        amplitude_mm: f64,
        /// Frequency (Hz).
        freq_hz: f64,
        /// Time the sinusoid starts (s).
        start_s: f64,
        /// Length of the record (s).
        duration_s: f64,
    },
    /// The reference held at `x_mm`: the pumps only feed the leakage (the article §2.3.2, §2.4; docs/identification.md#leakage-from-standstill).
    Standstill {
        /// Reference position held (mm).
        x_mm: f64,
        /// Length of the record (s).
        duration_s: f64,
    },
    /// A sweep about the operating point: chirp, multisine or stepped sine
    /// (docs/identification.md#frequency-response-from-a-sweep); the record ends with it.
    Sweep(crate::frf::Excitation),
}

/// The closed-loop records' sample rate when none is asked for (Hz): the PLC's.
pub const PLC_RATE_HZ: f64 = 100.0;
/// A drive record's sample rate when none is asked for (Hz): the drive's scope.
pub const DRIVE_RATE_HZ: f64 = 1000.0;
/// A step or standstill record's length when none is asked for (s).
pub const RECORD_S: f64 = 6.0;
/// A drive step record's length when none is asked for (s).
pub const DRIVE_RECORD_S: f64 = 1.0;
/// A step's size when its ends are not given (mm): the article's 5 mm, ending at x0.
pub const STEP_MM: f64 = 5.0;
/// The periods a sine record holds after its start when no length is asked for.
pub const SINE_PERIODS: f64 = 2.0;

/// `v` if it is a finite number > 0, else the complaint about `field`.
fn positive(field: &'static str, v: f64) -> Result<(), FieldError> {
    if v.is_finite() && v > 0.0 {
        return Ok(());
    }
    Err(FieldError::new(
        field,
        format!("{field} = {v}: must be > 0"),
    ))
}

/// `t` if it is a finite time >= 0, else the complaint about `field`.
fn not_negative(field: &'static str, t: f64) -> Result<(), FieldError> {
    if t.is_finite() && t >= 0.0 {
        return Ok(());
    }
    Err(FieldError::new(
        field,
        format!("{field} = {t}: must be >= 0"),
    ))
}

impl Experiment {
    /// A step of [`STEP_MM`] ending at the rig's operating point x0, at `at_s`, [`RECORD_S`]
    /// long: the article's step experiment, ends and length given or not.
    pub fn step(
        rig: &Rig,
        from_mm: Option<f64>,
        to_mm: Option<f64>,
        at_s: f64,
        duration_s: Option<f64>,
    ) -> Experiment {
        Experiment::Step {
            from_mm: from_mm.unwrap_or(rig.x0_mm - STEP_MM),
            to_mm: to_mm.unwrap_or(rig.x0_mm),
            at_s,
            duration_s: duration_s.unwrap_or(RECORD_S),
        }
    }

    /// A sinusoid about the rig's operating point x0 from `start_s`, [`SINE_PERIODS`] periods
    /// after its start when no length is given.
    pub fn sine(
        rig: &Rig,
        amplitude_mm: f64,
        freq_hz: f64,
        start_s: f64,
        duration_s: Option<f64>,
    ) -> Experiment {
        Experiment::Sine {
            centre_mm: rig.x0_mm,
            amplitude_mm,
            freq_hz,
            start_s,
            duration_s: duration_s.unwrap_or(start_s + SINE_PERIODS / freq_hz),
        }
    }

    /// The reference held at the rig's operating point x0, [`RECORD_S`] long when no length is
    /// given.
    pub fn standstill(rig: &Rig, duration_s: Option<f64>) -> Experiment {
        Experiment::Standstill {
            x_mm: rig.x0_mm,
            duration_s: duration_s.unwrap_or(RECORD_S),
        }
    }

    /// Refuse what the rig cannot do or the record cannot show: a length or a sine that is not
    /// positive, a time before 0, a reference that leaves the stroke
    /// ([`Rig::check_reference`]), a sine at or above the Nyquist frequency of `rate_hz`
    /// ([`check_nyquist`](crate::response::check_nyquist)), or a record of fewer than two
    /// samples, which no reader accepts. The error names the field.
    pub fn check(&self, rig: &Rig, rate_hz: f64) -> Result<(), FieldError> {
        record_length(self.duration_s(), rate_hz)?;
        let reach = |field: &'static str, value: f64, lo: f64, hi: f64| {
            rig.check_reference(lo, hi)
                .map_err(|e| FieldError::new(field, format!("{field} = {value}: {e}")))
        };
        match *self {
            Experiment::Step {
                from_mm,
                to_mm,
                at_s,
                ..
            } => {
                not_negative("at_s", at_s)?;
                reach("from_mm", from_mm, from_mm, from_mm)?;
                reach("to_mm", to_mm, to_mm, to_mm)
            }
            Experiment::Sine {
                centre_mm,
                amplitude_mm,
                freq_hz,
                start_s,
                ..
            } => {
                not_negative("start_s", start_s)?;
                positive("freq_hz", freq_hz)?;
                positive("amplitude_mm", amplitude_mm)?;
                reach(
                    "amplitude_mm",
                    amplitude_mm,
                    centre_mm - amplitude_mm,
                    centre_mm + amplitude_mm,
                )?;
                crate::response::check_nyquist(freq_hz, rate_hz)
                    .map_err(|e| FieldError::new("freq_hz", format!("freq_hz = {freq_hz}: {e}")))
            }
            Experiment::Standstill { x_mm, .. } => reach("x_mm", x_mm, x_mm, x_mm),
            Experiment::Sweep(e) => e.check(rate_hz, rig),
        }
    }

    /// Recorded length (s).
    pub fn duration_s(&self) -> f64 {
        match *self {
            Experiment::Step { duration_s, .. }
            | Experiment::Sine { duration_s, .. }
            | Experiment::Standstill { duration_s, .. } => duration_s,
            Experiment::Sweep(e) => e.duration_s(),
        }
    }

    /// The position reference (mm) at time `t` (s).
    pub fn reference_mm(&self, t: f64) -> f64 {
        match *self {
            Experiment::Step {
                from_mm,
                to_mm,
                at_s,
                ..
            } => {
                if t < at_s {
                    from_mm
                } else {
                    to_mm
                }
            }
            Experiment::Sine {
                centre_mm,
                amplitude_mm,
                freq_hz,
                start_s,
                ..
            } => {
                let phase = 2.0 * PI * freq_hz * (t - start_s).max(0.0);
                centre_mm + amplitude_mm * phase.sin()
            }
            Experiment::Standstill { x_mm, .. } => x_mm,
            Experiment::Sweep(e) => e.reference_mm(t),
        }
    }

    /// Run it on the emulated rig: the PLC's record from t = 0.
    pub fn run(&self, rig: &Rig, effects: Effects, plc: &Plc) -> Result<Signals, EmulatorError> {
        Ok(self.run_noted(rig, effects, plc)?.signals)
    }

    /// [`Experiment::run`] with the first end stop the piston met, if it did
    /// (docs/emulator.md#end-stops).
    pub fn run_noted(
        &self,
        rig: &Rig,
        effects: Effects,
        plc: &Plc,
    ) -> Result<Emulation, EmulatorError> {
        let unlimited = Work {
            allow_long_run: true,
            ..Work::QUIET
        };
        self.run_reporting(rig, effects, plc, &unlimited)
            .map_err(RunError::into_emulator)
    }

    /// [`Experiment::run_noted`], calling `work.progress(n)` as `n` more controller steps are
    /// done ([`super::plc::emulate_reporting`]), [`Experiment::steps`] in all, and stopped
    /// when the integrator's work goes beyond its limit unless `work` allows a long run
    /// (docs/emulator.md#the-work-limit).
    pub fn run_reporting(
        &self,
        rig: &Rig,
        effects: Effects,
        plc: &Plc,
        work: &Work,
    ) -> Result<Emulation, RunError> {
        let dynamics = Dynamics::new(rig, effects)?;
        let span = (SETTLE_S, self.duration_s());
        emulate_reporting(rig, &dynamics, plc, span, |t| self.reference_mm(t), work)
    }

    /// The controller steps of the record at `rate_hz` (its samples).
    pub fn steps(&self, rate_hz: f64) -> u64 {
        (self.duration_s() * rate_hz).round() as u64 + 1
    }
}

/// Noisy run-in before a record starts (s), so its first samples carry the PLC's jitter.
pub const SETTLE_S: f64 = 0.5;

/// A velocity step of one drive, its motor decoupled from the pump and the feedforward off
/// (the article §2.4.1; docs/identification.md#drive-gain): Jm ω̇ = τem, τem = τref/(s/ωI + 1), τref = Km (ωref − ω), the torque reference
/// limited to the peak torque.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveStep {
    /// Drive 1 or 2.
    pub motor: usize,
    /// Speed before the step (rpm).
    pub from_rpm: f64,
    /// Speed after the step (rpm).
    pub to_rpm: f64,
    /// Time of the step (s).
    pub at_s: f64,
    /// Recorded length (s).
    pub duration_s: f64,
}

impl DriveStep {
    /// Refuse a drive that does not exist, a time before 0, a length that is not positive or a
    /// record of fewer than two samples at `rate_hz`; the error names the field.
    pub fn check(&self, rate_hz: f64) -> Result<(), FieldError> {
        record_length(self.duration_s, rate_hz)?;
        if !(1..=2).contains(&self.motor) {
            return Err(FieldError::new(
                "motor",
                format!("motor = {}: drive 1 or 2", self.motor),
            ));
        }
        not_negative("at_s", self.at_s)?;
        positive("duration_s", self.duration_s)
    }
}

/// Refuse a record length that is not positive, or that holds fewer than two samples at
/// `rate_hz` (no reader accepts one sample).
fn record_length(duration_s: f64, rate_hz: f64) -> Result<(), FieldError> {
    positive("duration_s", duration_s)?;
    positive("rate_hz", rate_hz)?;
    if crate::limits::sample_count(duration_s, rate_hz) < 2.0 {
        return Err(FieldError::new(
            "rate_hz",
            format!("rate_hz = {rate_hz}: 1 sample in {duration_s} s; a record needs at least 2"),
        ));
    }
    Ok(())
}

/// A drive record: `time_s`, `w_ref_rpm`, `w_rpm` (docs/formats.md#drive-record-csv).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DriveSignals {
    /// Time (s).
    pub time_s: Vec<f64>,
    /// Speed reference (rpm).
    pub w_ref_rpm: Vec<f64>,
    /// Measured speed (rpm).
    pub w_rpm: Vec<f64>,
}

impl DriveStep {
    /// Emulate the step, sampled at `plc.rate_hz` with `plc.noise_w_rpm` on the speed.
    pub fn run(
        &self,
        rig: &Rig,
        effects: Effects,
        plc: &Plc,
    ) -> Result<DriveSignals, EmulatorError> {
        let drives = rig.circuit.description().drives;
        if !(1..=drives).contains(&self.motor) {
            return Err(EmulatorError(format!(
                "drive {} does not exist on the {} circuit: {}",
                self.motor,
                rig.circuit.name(),
                if drives == 2 {
                    "1 or 2"
                } else {
                    "1, its one motor"
                }
            )));
        }
        let si = rig.si();
        let i = self.motor - 1;
        let (jm, km, wi) = (si.jm[i], si.km[i], si.omega_i);
        let limit = effects
            .peak_torque_factor
            .map_or(f64::INFINITY, |f| f * rig.motor_rated_torque_nm);
        let mut noise = Noise::new(plc.seed);
        let ts = 1.0 / plc.rate_hz;
        let steps = (self.duration_s * plc.rate_hz).round() as usize;
        let mut x = vec![self.from_rpm * RAD_S_PER_RPM, 0.0];
        let mut out = DriveSignals::default();
        for k in 0..=steps {
            let t = k as f64 * ts;
            let w_ref = if t < self.at_s {
                self.from_rpm
            } else {
                self.to_rpm
            };
            out.time_s.push(t);
            out.w_ref_rpm.push(w_ref);
            out.w_rpm
                .push(x[0] / RAD_S_PER_RPM + plc.noise_w_rpm * noise.gauss());
            if k < steps {
                let u = w_ref * RAD_S_PER_RPM;
                let f = |x: &[f64], dx: &mut [f64]| {
                    let t_ref = (km * (u - x[0])).clamp(-limit, limit);
                    dx[0] = x[1] / jm;
                    dx[1] = wi * (t_ref - x[1]);
                };
                x = integrate(&f, &[10.0, 0.1], &x, t, t + ts)?;
            }
        }
        Ok(out)
    }
}
