//! Duty cycles (docs/energy.md#duty-cycles): a position reference and, where it changes, the
//! external force over time — the article's three sines, a step sequence or an engineer's own
//! profile — run on the emulated rig with its power account, and what the drives go through:
//! the RMS and peak torque and speed of each motor against its ratings.

use super::integrate::drive_states;
use super::{emulate_profile, Dynamics, Emulation, Plc, Profile, RunError};
use crate::circuit::parts::PEAK_TORQUE_FACTOR;
use crate::limits::Work;
use crate::record::{RecordError, Table};
use crate::rig::Rig;
use crate::source_files::Files;
use crate::units::RAD_S_PER_RPM;
use serde::Serialize;
use std::f64::consts::PI;
use std::path::Path;

/// The article's three tracking sines (its Figures 8–10): frequency (Hz) and amplitude (mm).
pub const ARTICLE_SINES: [(f64, f64); 3] = [(0.1, 50.0), (0.2, 35.0), (0.25, 20.0)];

/// Whole periods of each sine in [`Cycle::article_sines`].
pub const SINE_PERIODS: u32 = 2;

/// How long a cycle of sines holds the centre after its last sine (s), so it ends at rest.
pub const SINES_REST_S: f64 = 2.0;

/// The largest external force a profile may ask for (N): far beyond any pump-controlled
/// cylinder, so a column in the wrong unit is refused instead of run.
pub const MAX_FORCE_N: f64 = 1e8;

/// A duty cycle: the position reference over time and, where given, the external force.
#[derive(Debug, Clone, PartialEq)]
pub enum Cycle {
    /// Sines about `centre_mm`, one after another, each `periods` whole periods from phase 0,
    /// then the centre held [`SINES_REST_S`].
    Sines {
        /// The centre (mm).
        centre_mm: f64,
        /// Each sine's frequency (Hz) and amplitude (mm).
        sines: Vec<(f64, f64)>,
        /// Whole periods of each.
        periods: u32,
    },
    /// `centre`, `centre + a`, `centre`, `centre − a`, `centre`, each held `hold_s`.
    Steps {
        /// The centre (mm).
        centre_mm: f64,
        /// The step's size a (mm).
        amplitude_mm: f64,
        /// How long each level is held (s).
        hold_s: f64,
    },
    /// An engineer's own profile: the reference (and the force) at the given times, linear
    /// between them, the first time taken as the cycle's start.
    Table {
        /// Times (s), strictly increasing.
        time_s: Vec<f64>,
        /// The position reference (mm).
        x_ref_mm: Vec<f64>,
        /// The external force (N), if the profile gives it.
        force_n: Option<Vec<f64>>,
    },
}

/// Linear interpolation of `ys` at times `ts` (strictly increasing) at `t`, held at the ends.
fn interpolate(ts: &[f64], ys: &[f64], t: f64) -> f64 {
    let k = ts.partition_point(|&s| s <= t);
    match k {
        0 => ys[0],
        k if k >= ts.len() => ys[ts.len() - 1],
        k => {
            let w = (t - ts[k - 1]) / (ts[k] - ts[k - 1]);
            ys[k - 1] + w * (ys[k] - ys[k - 1])
        }
    }
}

impl Cycle {
    /// The article's three sines ([`ARTICLE_SINES`]) about `centre_mm`, [`SINE_PERIODS`] each.
    pub fn article_sines(centre_mm: f64) -> Cycle {
        Cycle::Sines {
            centre_mm,
            sines: ARTICLE_SINES.to_vec(),
            periods: SINE_PERIODS,
        }
    }

    /// A profile from a CSV or MAT file (docs/formats.md#duty-cycle-csv): `time_s` and
    /// `x_ref_mm`, and `external_force_n` if the force changes; every position within the
    /// rig's stroke and every force within [`MAX_FORCE_N`].
    ///
    /// # Errors
    /// The file cannot be read, or a column is missing or holds a value out of range, named
    /// with its line.
    pub fn read(files: &dyn Files, path: &Path, rig: &Rig) -> Result<Cycle, RecordError> {
        let columns = (&["time_s", "x_ref_mm"][..], &["external_force_n"][..]);
        let mut t = Table::read_in(files, path, columns.0, columns.1)?;
        let time_s = t.take("time_s").unwrap_or_default();
        let x_ref_mm = t.take("x_ref_mm").unwrap_or_default();
        let force_n = t.take("external_force_n");
        let out = |column: &str, k: usize, message: String| RecordError::Value {
            file: path.display().to_string(),
            line: k as u64 + 2,
            column: column.to_string(),
            message,
        };
        if let Some(k) = x_ref_mm
            .iter()
            .position(|x| !(0.0..=rig.stroke_mm).contains(x))
        {
            let message = format!(
                "{} mm is outside the rig's stroke, 0 to {} mm (stroke_mm)",
                x_ref_mm[k], rig.stroke_mm
            );
            return Err(out("x_ref_mm", k, message));
        }
        if let Some(f) = &force_n {
            if let Some(k) = f.iter().position(|f| f.abs() > MAX_FORCE_N) {
                let message = format!("{} N is beyond {MAX_FORCE_N:e} N: is it in N?", f[k]);
                return Err(out("external_force_n", k, message));
            }
        }
        let t0 = time_s[0];
        Ok(Cycle::Table {
            time_s: time_s.iter().map(|t| t - t0).collect(),
            x_ref_mm,
            force_n,
        })
    }

    /// How long it lasts (s).
    pub fn duration_s(&self) -> f64 {
        match self {
            Cycle::Sines { sines, periods, .. } => {
                sines
                    .iter()
                    .map(|(f, _)| f64::from(*periods) / f)
                    .sum::<f64>()
                    + SINES_REST_S
            }
            Cycle::Steps { hold_s, .. } => 5.0 * hold_s,
            Cycle::Table { time_s, .. } => time_s[time_s.len() - 1],
        }
    }

    /// The position reference at `t` (s from the cycle's start; mm).
    pub fn reference_mm(&self, t: f64) -> f64 {
        match self {
            Cycle::Sines {
                centre_mm,
                sines,
                periods,
            } => {
                let mut start = 0.0;
                for &(f, a) in sines {
                    let end = start + f64::from(*periods) / f;
                    if t < end {
                        return centre_mm + a * (2.0 * PI * f * (t - start)).sin();
                    }
                    start = end;
                }
                *centre_mm
            }
            Cycle::Steps {
                centre_mm,
                amplitude_mm,
                hold_s,
            } => {
                let level = [0.0, 1.0, 0.0, -1.0, 0.0];
                let k = ((t / hold_s).floor().max(0.0) as usize).min(4);
                centre_mm + level[k] * amplitude_mm
            }
            Cycle::Table {
                time_s, x_ref_mm, ..
            } => interpolate(time_s, x_ref_mm, t),
        }
    }

    /// The external force at `t` (N), where the cycle gives one.
    pub fn force_n(&self, t: f64) -> Option<f64> {
        match self {
            Cycle::Table {
                time_s,
                force_n: Some(f),
                ..
            } => Some(interpolate(time_s, f, t)),
            _ => None,
        }
    }
}

/// What one motor goes through over a cycle and whether it is big enough
/// (docs/energy.md#drive-sizing): the RMS torque against the rated (continuous) torque, the
/// peak torque against the drive's limit, and the peak speed against the motor's rated speed
/// and the pump's maximum.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriveDuty {
    /// Motor 1 or 2.
    pub motor: usize,
    /// The RMS of the electromagnetic torque over the cycle (N·m).
    pub rms_torque_nm: f64,
    /// The largest |torque| (N·m).
    pub peak_torque_nm: f64,
    /// The RMS of the speed (rpm).
    pub rms_speed_rpm: f64,
    /// The largest |speed| (rpm).
    pub peak_speed_rpm: f64,
    /// The rated (continuous) torque, `motor_rated_torque_nm` (N·m).
    pub rated_torque_nm: f64,
    /// The torque the drive can give for a moment: the emulator's limit, 3 × rated (N·m).
    pub peak_torque_limit_nm: f64,
    /// The rated speed, `motor_rated_speed_rpm`.
    pub rated_speed_rpm: f64,
    /// The pump's maximum speed, `pump_max_speed_rpm`.
    pub pump_max_speed_rpm: f64,
    /// What it exceeds: `rms_torque`, `peak_torque`, `speed` (rated), `pump_speed`; empty
    /// when it fits the cycle.
    pub exceeds: Vec<&'static str>,
}

/// A cycle run on the emulated rig: the record with its power columns and energies, and each
/// motor's duty.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleRun {
    /// The record and its energies ([`Plc::energy`] on).
    pub emulation: Emulation,
    /// Each motor's duty, in order; none for the valve circuit.
    pub drives: Vec<DriveDuty>,
}

/// Each drive's RMS and peak (speed, torque) over the run (rad/s, N·m), integrated with the
/// account: its squares over the record's length, its largest values at the integrator's steps.
fn rms_of(emulation: &Emulation) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let t = &emulation.signals.time_s;
    let seconds = t.last().zip(t.first()).map_or(0.0, |(b, a)| b - a);
    let energy = emulation.energy.as_ref();
    let rms = (energy.iter().flat_map(|e| &e.drive_squares))
        .map(|sq| sq.map(|s| (s.max(0.0) / seconds).sqrt()))
        .collect();
    (rms, energy.map_or(Vec::new(), |e| e.drive_peaks.clone()))
}

/// The duty of each drive from its RMS and peak (speed, torque) over the run and its (speed,
/// torque) at each sample (rad/s, N·m).
fn duties(
    rig: &Rig,
    samples: &[Vec<[f64; 2]>],
    (rms, peaks): &(Vec<[f64; 2]>, Vec<[f64; 2]>),
) -> Vec<DriveDuty> {
    let drives = samples.first().map_or(0, Vec::len);
    (0..drives)
        .map(|i| {
            let of = |j: usize| samples.iter().map(move |s| s[i][j]);
            let rms = |j: usize| rms.get(i).map_or(f64::NAN, |r| r[j]);
            let integrated = |j: usize| peaks.get(i).map_or(0.0, |p| p[j]);
            let peak = |j: usize| of(j).fold(integrated(j), |m: f64, v| m.max(v.abs()));
            let mut duty = DriveDuty {
                motor: i + 1,
                rms_torque_nm: rms(1),
                peak_torque_nm: peak(1),
                rms_speed_rpm: rms(0) / RAD_S_PER_RPM,
                peak_speed_rpm: peak(0) / RAD_S_PER_RPM,
                rated_torque_nm: rig.motor_rated_torque_nm,
                peak_torque_limit_nm: PEAK_TORQUE_FACTOR * rig.motor_rated_torque_nm,
                rated_speed_rpm: rig.motor_rated_speed_rpm,
                pump_max_speed_rpm: rig.pump_max_speed_rpm,
                exceeds: Vec::new(),
            };
            duty.exceeds = exceeded(&duty);
            duty
        })
        .collect()
}

/// The ratings `d` exceeds, by name ([`DriveDuty::exceeds`]); a peak at the limit itself (the
/// drive saturating) counts as exceeding it.
fn exceeded(d: &DriveDuty) -> Vec<&'static str> {
    [
        ("rms_torque", d.rms_torque_nm > d.rated_torque_nm),
        (
            "peak_torque",
            d.peak_torque_nm >= d.peak_torque_limit_nm * (1.0 - 1e-6),
        ),
        ("speed", d.peak_speed_rpm > d.rated_speed_rpm),
        ("pump_speed", d.peak_speed_rpm > d.pump_max_speed_rpm),
    ]
    .into_iter()
    .filter(|(_, over)| *over)
    .map(|(name, _)| name)
    .collect()
}

/// Run `cycle` on the rig with its power account on (`plc.energy` is set), from the loop at
/// rest at the cycle's start, settled `settle_s` with the PLC's noise; each drive's speed and
/// torque are taken at every PLC sample.
///
/// # Errors
/// As [`emulate_profile`].
pub fn run(
    rig: &Rig,
    dynamics: &Dynamics,
    plc: &Plc,
    (settle_s, cycle): (f64, &Cycle),
    work: &Work,
) -> Result<CycleRun, RunError> {
    let drives = drive_states(dynamics);
    let mut samples: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut observe = |_t: f64, x: &[f64]| {
        samples.push(drives.iter().map(|&[w, tau]| [x[w], x[tau]]).collect());
    };
    let force = |t: f64| cycle.force_n(t).unwrap_or(rig.external_force_n);
    let profile = Profile {
        force_n: cycle
            .force_n(0.0)
            .is_some()
            .then_some(&force as &dyn Fn(f64) -> f64),
        observe: Some(&mut observe),
    };
    let plc = Plc {
        energy: true,
        ..*plc
    };
    let reference = |t: f64| cycle.reference_mm(t);
    let times = (settle_s, cycle.duration_s());
    let emulation = emulate_profile(rig, dynamics, &plc, times, (&reference, profile), work)?;
    let rms = rms_of(&emulation);
    Ok(CycleRun {
        drives: duties(rig, &samples, &rms),
        emulation,
    })
}

/// A cycle's energy in the figures an engineer compares circuits by (docs/energy.md#duty-cycles).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CycleEnergy {
    /// The cycle's length (s).
    pub duration_s: f64,
    /// What the sources drew: the drives' DC bus from the supply (`electrical`), or a valve's
    /// supply (J).
    pub drawn_j: f64,
    /// What the drives returned to the supply (J, ≥ 0; `regenerated`).
    pub regenerated_j: f64,
    /// Drawn less returned: the cycle's net energy (J).
    pub net_j: f64,
    /// The work against the external force over the cycle (J).
    pub work_out_j: f64,
    /// The work the piston did on the load where it drove it (J): the positive part of the
    /// load's power, F_ext·v + m·v·v̇, from the record's power columns.
    pub load_work_j: f64,
    /// Every loss together (J).
    pub losses_j: f64,
    /// The change of every stored energy together (J).
    pub stored_change_j: f64,
    /// The load's work over what the sources drew, `load_work_j / drawn_j`.
    pub efficiency: f64,
    /// The net energy over the cycle's length (W).
    pub mean_power_w: f64,
    /// The largest power the sources drew over one PLC interval (W).
    pub peak_power_w: f64,
}

impl CycleRun {
    /// Its energy in figures ([`CycleEnergy`]); `None` without the account.
    pub fn energy(&self) -> Option<CycleEnergy> {
        let e = self.emulation.energy.as_ref()?;
        let s = &self.emulation.signals;
        let rows = s.time_s.len();
        let period_s = s.time_s.get(1).map_or(0.0, |t1| t1 - s.time_s[0]);
        // each sample's sum of the power columns `keep` names
        let summed = |keep: &dyn Fn(&str) -> bool| -> Vec<f64> {
            let mut sum = vec![0.0; rows];
            for (_, column) in s.power_w.iter().filter(|(n, _)| keep(n)) {
                sum.iter_mut().zip(column).for_each(|(t, w)| *t += w);
            }
            sum
        };
        let drawn_w = summed(&|n| n.starts_with("source_"));
        let load_w = summed(&|n| n == "work_out_w" || n == "stored_load_motion_w");
        let net_j: f64 = e.sources_j.iter().map(|(_, j)| j).sum();
        let regenerated_j = 0.0 - e.of("regenerated");
        let drawn_j: f64 = (e.sources_j.iter())
            .filter(|(k, _)| *k != "regenerated")
            .map(|(_, j)| j)
            .sum();
        let load_work_j = load_w.iter().map(|w| w.max(0.0)).sum::<f64>() * period_s;
        let duration_s = period_s * rows.saturating_sub(1) as f64;
        Some(CycleEnergy {
            duration_s,
            drawn_j,
            regenerated_j,
            net_j,
            work_out_j: e.work_out_j,
            load_work_j,
            losses_j: e.losses_j.iter().map(|(_, j)| j).sum(),
            stored_change_j: e.stored_j.iter().map(|(_, j)| j).sum(),
            efficiency: load_work_j / drawn_j,
            mean_power_w: net_j / duration_s,
            peak_power_w: drawn_w.into_iter().fold(f64::NEG_INFINITY, f64::max),
        })
    }
}
