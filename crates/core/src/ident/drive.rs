//! Drive velocity-loop gain from a motor velocity step (the article §2.4.1; docs/identification.md#drive-gain): the motor alone, decoupled
//! from the pump, feedforward off: Jm ω̇ = τem, τem = τref/(s/ωI + 1), τref = Km (ωref − ω).

use super::IdentError;
use crate::lti::{Simulator, StateSpace};
use crate::record::Table;
use nalgebra::DMatrix;
use std::path::Path;

/// A drive step record: `time_s`, `w_ref_rpm`, `w_rpm`.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveRecord {
    /// File name for messages.
    pub file: String,
    /// Time (s).
    pub time_s: Vec<f64>,
    /// Speed reference (rpm).
    pub w_ref_rpm: Vec<f64>,
    /// Measured speed (rpm).
    pub w_rpm: Vec<f64>,
}

impl DriveRecord {
    /// Read a drive record (CSV with a header; extra columns ignored).
    pub fn read(path: &Path) -> Result<DriveRecord, IdentError> {
        Self::read_in(&crate::source_files::Disk, path)
    }

    /// [`DriveRecord::read`] from `files`.
    pub fn read_in(
        files: &dyn crate::source_files::Files,
        path: &Path,
    ) -> Result<DriveRecord, IdentError> {
        let mut t = Table::read_in(files, path, &["time_s", "w_ref_rpm", "w_rpm"], &[])?;
        Ok(DriveRecord {
            file: path.display().to_string(),
            time_s: t.take("time_s").unwrap_or_default(),
            w_ref_rpm: t.take("w_ref_rpm").unwrap_or_default(),
            w_rpm: t.take("w_rpm").unwrap_or_default(),
        })
    }
}

/// The identified drive gain and its fit.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DriveFit {
    /// Velocity-loop P gain Km (N·m·s/rad).
    pub km_nms_per_rad: f64,
    /// Mean squared speed error of the fit (rpm²).
    pub mse_rpm2: f64,
    /// Simulated speed with the identified gain (rpm), one per sample.
    pub w_sim_rpm: Vec<f64>,
}

/// The drive model ω/ωref for rotor inertia `jm` (kg·m²), current-loop bandwidth `omega_i`
/// (1/s) and gain `km`: states ω, τem.
fn drive_model(jm: f64, omega_i: f64, km: f64) -> StateSpace {
    StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.0, 1.0 / jm, -omega_i * km, -omega_i]),
        DMatrix::from_row_slice(2, 1, &[0.0, omega_i * km]),
        DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
        DMatrix::zeros(1, 1),
    )
    .expect("a 2-state model is consistent")
}

/// Simulated speed (rpm) from the record's initial steady state.
fn simulate(rec: &DriveRecord, jm: f64, omega_i: f64, km: f64) -> Result<Vec<f64>, IdentError> {
    let k = first_change(&rec.w_ref_rpm).max(1);
    let mean = |v: &[f64]| v[..k].iter().sum::<f64>() / k as f64;
    let (r0, w0) = (mean(&rec.w_ref_rpm), mean(&rec.w_rpm));
    let u: Vec<f64> = rec.w_ref_rpm.iter().map(|r| r - r0).collect();
    let sys = drive_model(jm, omega_i, km);
    let r = Simulator::new(&sys).run(&rec.time_s, &u, &[0.0, 0.0])?;
    Ok(r.output(0).iter().map(|w| w + w0).collect())
}

fn first_change(v: &[f64]) -> usize {
    v.iter().position(|&x| x != v[0]).unwrap_or(v.len())
}

fn mse(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64
}

/// The range of Km scanned (N·m·s/rad).
const KM_MIN: f64 = 1e-5;
const KM_MAX: f64 = 10.0;

/// Samples after the step below which a record cannot show the motor's response.
const MIN_STEP_SAMPLES: usize = 10;

/// Refuse a record that cannot show a response: a reference that never steps, too few samples
/// after the step, or a motor speed that never moves (its span below 0.1 % of the step).
fn check_response(rec: &DriveRecord) -> Result<(), IdentError> {
    let start = first_change(&rec.w_ref_rpm);
    if start >= rec.time_s.len() {
        return Err(IdentError::Input(format!(
            "{}: lines 2-{}, column `w_ref_rpm`: the speed reference never changes: no step \
             to identify from",
            rec.file,
            rec.time_s.len() + 1
        )));
    }
    let after = rec.time_s.len() - start;
    if after < MIN_STEP_SAMPLES {
        return Err(IdentError::Input(format!(
            "{}: {after} samples after the step at line {}: need at least {MIN_STEP_SAMPLES} to \
             see the motor respond",
            rec.file,
            start + 2
        )));
    }
    let span = |v: &[f64]| {
        let (lo, hi) = crate::record::range(v);
        hi - lo
    };
    let (moved, step) = (span(&rec.w_rpm), span(&rec.w_ref_rpm));
    if moved <= 1e-3 * step {
        return Err(IdentError::Input(format!(
            "{}: column `w_rpm`: the motor speed spans {} rpm for a step of {} rpm: the motor \
             does not move, so Km cannot be identified",
            rec.file,
            crate::units::readable(moved),
            crate::units::readable(step)
        )));
    }
    Ok(())
}

/// Identify Km: a log-spaced scan over 1e-5 … 10 N·m·s/rad, then golden-section search in the
/// bracket around the best scan point (the cost is smooth in log Km). A record that shows no
/// response, or whose best fit lies on the edge of the scan, is refused: an answer there is the
/// scan's bound, not a measurement.
pub fn identify_drive(rec: &DriveRecord, jm: f64, omega_i: f64) -> Result<DriveFit, IdentError> {
    check_response(rec)?;
    let cost = |log_km: f64| -> f64 {
        simulate(rec, jm, omega_i, log_km.exp()).map_or(f64::INFINITY, |w| mse(&w, &rec.w_rpm))
    };
    let scan = super::spaced(KM_MIN.ln(), KM_MAX.ln(), 61, false);
    let costs: Vec<f64> = scan.iter().map(|&l| cost(l)).collect();
    let best = (0..scan.len())
        .min_by(|&a, &b| costs[a].total_cmp(&costs[b]))
        .unwrap_or(0);
    if best == 0 || best == scan.len() - 1 {
        return Err(IdentError::Input(format!(
            "{}: column `w_rpm`: the best fit lies on the edge of the range scanned, Km = {:.3e} \
             N·m·s/rad ({KM_MIN:e} … {KM_MAX}): this record does not determine Km",
            rec.file,
            scan[best].exp()
        )));
    }
    let (mut lo, mut hi) = (
        scan[best.saturating_sub(1)],
        scan[(best + 1).min(scan.len() - 1)],
    );
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..80 {
        let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if cost(a) < cost(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let km = (0.5 * (lo + hi)).exp();
    let w_sim_rpm = simulate(rec, jm, omega_i, km)?;
    Ok(DriveFit {
        km_nms_per_rad: km,
        mse_rpm2: mse(&w_sim_rpm, &rec.w_rpm),
        w_sim_rpm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_the_gain_of_a_simulated_step() {
        let (jm, wi, km) = (1.6e-3, 1256.6, 0.026);
        let time_s: Vec<f64> = (0..200).map(|k| k as f64 * 0.005).collect();
        let w_ref_rpm: Vec<f64> = time_s
            .iter()
            .map(|&t| if t < 0.1 { 0.0 } else { 500.0 })
            .collect();
        let n = time_s.len();
        let mut rec = DriveRecord {
            file: "d.csv".into(),
            time_s,
            w_ref_rpm,
            w_rpm: vec![0.0; n],
        };
        let mut w = simulate(&rec, jm, wi, km).unwrap();
        // deterministic ±1 rpm "noise"
        for (k, v) in w.iter_mut().enumerate() {
            *v += if k % 2 == 0 { 1.0 } else { -1.0 };
        }
        rec.w_rpm = w;
        let fit = identify_drive(&rec, jm, wi).unwrap();
        assert!((fit.km_nms_per_rad / km - 1.0).abs() < 0.01, "{fit:?}");
        assert!((fit.mse_rpm2 - 1.0).abs() < 0.05);
    }
}
