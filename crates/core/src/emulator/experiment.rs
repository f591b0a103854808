//! What the emulated rig is asked to do (docs/emulator.md): a position step, a sinusoid or a standstill
//! of the closed loop, or a velocity step of one drive with its motor decoupled from the pump
//! (the article §2.4.1; docs/identification.md#drive-gain).

use super::plc::{integrate, Noise};
use super::EmulatorError;
use super::{emulate, Dynamics, Effects, Plc};
use crate::response::Signals;
use crate::rig::{Rig, RAD_S_PER_RPM};
use std::f64::consts::PI;
use std::fmt::Write;

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
}

impl Experiment {
    /// Recorded length (s).
    pub fn duration_s(&self) -> f64 {
        match *self {
            Experiment::Step { duration_s, .. }
            | Experiment::Sine { duration_s, .. }
            | Experiment::Standstill { duration_s, .. } => duration_s,
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
        }
    }

    /// Run it on the emulated rig: the PLC's record from t = 0.
    pub fn run(&self, rig: &Rig, effects: Effects, plc: &Plc) -> Result<Signals, EmulatorError> {
        let dynamics = Dynamics::new(rig, effects)?;
        emulate(rig, &dynamics, plc, SETTLE_S, self.duration_s(), |t| {
            self.reference_mm(t)
        })
    }
}

/// Noisy run-in before a record starts (s), so its first samples carry the PLC's jitter.
const SETTLE_S: f64 = 0.5;

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

impl DriveSignals {
    /// The record as CSV with a header row.
    pub fn csv(&self) -> String {
        let mut out = String::from("time_s,w_ref_rpm,w_rpm\n");
        for k in 0..self.time_s.len() {
            let _ = writeln!(
                out,
                "{:.6},{:.6},{:.6}",
                self.time_s[k], self.w_ref_rpm[k], self.w_rpm[k]
            );
        }
        out
    }
}

impl DriveStep {
    /// Emulate the step, sampled at `plc.rate_hz` with `plc.noise_w_rpm` on the speed.
    pub fn run(
        &self,
        rig: &Rig,
        effects: Effects,
        plc: &Plc,
    ) -> Result<DriveSignals, EmulatorError> {
        if self.motor != 1 && self.motor != 2 {
            return Err(EmulatorError(format!(
                "drive {} does not exist: 1 or 2",
                self.motor
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
