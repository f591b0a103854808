//! The nonlinear rig emulator (docs/emulator.md): the continuous dynamics of the DPM rig
//! with what the LTI model leaves out — chamber volumes that follow the piston, a
//! pressure-dependent bulk modulus (docs/bulk-modulus.md), cavitation, motor torque and speed limits, pump
//! low-speed flow loss, Coulomb friction and a stroke-dependent mass. Each effect can be
//! switched off; with all of them off the right-hand side linearises to the analytic model of
//! `model` (a test checks every entry of A and B).
//!
//! `plc` closes the loop at the PLC's rate and integrates these dynamics between samples.

pub mod article;
mod experiment;
mod plc;

pub use experiment::{
    DriveSignals, DriveStep, Experiment, DRIVE_RATE_HZ, DRIVE_RECORD_S, PLC_RATE_HZ, RECORD_S,
    SETTLE_S, SINE_PERIODS, STEP_MM,
};
pub use plc::{emulate, equilibrium, hold_speeds, Plc, PlcLoop};

use crate::bulk::effective_beta;

/// Why the emulator cannot run: a rig or experiment it does not model (a first-order motor, a
/// drive that does not exist, a bulk modulus beyond the oil's own), a loop that cannot rest at
/// its start, or the ODE solver failing.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct EmulatorError(pub String);

impl From<&str> for EmulatorError {
    fn from(message: &str) -> Self {
        EmulatorError(message.to_string())
    }
}
use crate::model::{Layout, Plant};
use crate::rig::{MotorModel, Rig, RigSi};
use crate::units::PA_PER_BAR;

/// The effects beyond the LTI model, each switchable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Effects {
    /// Chamber volumes V1 = VL1 + A1 x, V2 = VL2 + A2 (x_max − x) instead of fixed at x0.
    pub varying_volumes: bool,
    /// Gas fraction X of the bulk-modulus model: β_e of both chambers from their mean pressure
    /// (p1 + p2)/2, as docs/bulk-modulus.md#the-constant-gas-fraction-model defines it; `None` keeps β constant.
    pub gas_fraction: Option<f64>,
    /// Pure-oil bulk modulus (bar) for the gas-fraction model.
    pub beta_oil_bar: f64,
    /// Motor torque limit as a multiple of the rated torque; `None` = unlimited.
    pub peak_torque_factor: Option<f64>,
    /// Pumps cannot be driven beyond their maximum speed (the rig's `pump_max_speed_rpm`).
    pub pump_speed_limit: bool,
    /// Pump speed below which the delivered flow fades out and the slip leakage sets in
    /// (rad/s); 0 = ideal pumps.
    pub dead_band_rad_s: f64,
    /// Extra internal leakage of a pump turning slower than the dead band, across its ports
    /// (m⁵/(N·s)): full at standstill, none at the dead-band speed.
    pub slip_m5_per_ns: f64,
    /// Coulomb friction force (N); 0 = none.
    pub coulomb_n: f64,
    /// Relative change of the effective mass per metre of stroke away from x0 (1/m).
    pub mass_slope_per_m: f64,
    /// Relative curvature of the effective mass against stroke (1/m²):
    /// m(x) = m (1 + slope d + curvature d²), d = x − x0.
    pub mass_curvature_per_m2: f64,
}

impl Effects {
    /// Everything off: the dynamics linearise to the analytic model.
    pub fn none() -> Effects {
        Effects {
            varying_volumes: false,
            gas_fraction: None,
            beta_oil_bar: crate::bulk::BETA_OIL_BAR,
            peak_torque_factor: None,
            pump_speed_limit: false,
            dead_band_rad_s: 0.0,
            slip_m5_per_ns: 0.0,
            coulomb_n: 0.0,
            mass_slope_per_m: 0.0,
            mass_curvature_per_m2: 0.0,
        }
    }

    /// Every effect on, as the emulated article rig has them (docs/emulator.md#the-dynamics):
    /// volumes following the piston, β_e(p) with the gas fraction that gives `beta_bar` at
    /// `p_mean_bar`, a 3× peak torque, the pump speed limit, a 60 rpm pump dead band with slip
    /// leakage, 15 N Coulomb friction, and the seesaw's effective mass against stroke
    /// (9958 kg at −50 mm, 12 373 kg at +50 mm for 10 593 kg at x0: the article §2.1).
    pub fn article(beta_bar: f64, p_mean_bar: f64) -> Result<Effects, EmulatorError> {
        let oil = crate::bulk::BETA_OIL_BAR;
        let x = crate::bulk::gas_fraction(beta_bar, p_mean_bar, oil)
            .map_err(|e| EmulatorError(e.to_string()))?;
        let (m0, m_minus, m_plus, d) = (10_593.0, 9_958.0, 12_373.0, 0.05);
        Ok(Effects {
            varying_volumes: true,
            gas_fraction: Some(x),
            beta_oil_bar: oil,
            peak_torque_factor: Some(3.0),
            pump_speed_limit: true,
            dead_band_rad_s: 60.0 * crate::units::RAD_S_PER_RPM,
            slip_m5_per_ns: 4e-11,
            coulomb_n: 15.0,
            mass_slope_per_m: (m_plus - m_minus) / (2.0 * d) / m0,
            mass_curvature_per_m2: ((m_plus + m_minus) / 2.0 - m0) / (d * d) / m0,
        })
    }
}

/// Absolute pressure of a gauge pressure of 0 (Pa): cavitation floor is −1 bar gauge.
const ATMOSPHERE_PA: f64 = 1e5;
/// Velocity scale of the smooth Coulomb friction sign (m/s).
const COULOMB_SMOOTHING_M_S: f64 = 1e-3;

/// The continuous dynamics of the rig, states as in [`Layout`] (absolute position, gauge
/// pressures), inputs the drive speed references ω_ref1, ω_ref2 (rad/s).
#[derive(Debug, Clone)]
pub struct Dynamics {
    si: RigSi,
    pub(crate) layout: Layout,
    x_max: f64,
    vl: [f64; 2],
    rated_torque: f64,
    max_pump_speed: f64,
    effects: Effects,
}

impl Dynamics {
    /// The dynamics of a rig (full motor model only) with the chosen effects.
    pub fn new(rig: &Rig, effects: Effects) -> Result<Dynamics, EmulatorError> {
        if rig.motor_model != MotorModel::Full {
            return Err("the emulator needs motor_model = \"full\"".into());
        }
        let plant = Plant::new(rig);
        Ok(Dynamics {
            si: plant.si,
            layout: plant.layout,
            x_max: rig.stroke_mm * 1e-3,
            vl: [rig.line_volume_1_dm3 * 1e-3, rig.line_volume_2_dm3 * 1e-3],
            rated_torque: rig.motor_rated_torque_nm,
            max_pump_speed: rig.pump_max_speed_rpm * crate::units::RAD_S_PER_RPM,
            effects,
        })
    }

    /// Change the external force on the piston (N).
    pub fn set_external_force_n(&mut self, f_n: f64) {
        self.si.f_ext = f_n;
    }

    /// The state positions.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Number of states.
    pub fn order(&self) -> usize {
        self.layout.n
    }

    /// Bulk modulus (Pa) at a mean chamber gauge pressure (Pa).
    fn beta(&self, p_gauge: f64) -> f64 {
        match self.effects.gas_fraction {
            None => self.si.beta,
            Some(x) => {
                let p_bar = (p_gauge / PA_PER_BAR).max(1e-3);
                effective_beta(x, p_bar, self.effects.beta_oil_bar) * PA_PER_BAR
            }
        }
    }

    /// Pump flow factor at speed ω: 1 above the dead band, fading smoothly to 0 at standstill.
    fn pump_factor(&self, w: f64) -> f64 {
        let db = self.effects.dead_band_rad_s;
        if db <= 0.0 {
            1.0
        } else {
            let r = (w / db).abs();
            if r >= 1.0 {
                1.0
            } else {
                r * r * (3.0 - 2.0 * r)
            }
        }
    }

    /// ẋ = f(x, u) into `dx`.
    pub fn rhs(&self, x: &[f64], u: &[f64; 2], dx: &mut [f64]) {
        let (si, l, e) = (&self.si, &self.layout, &self.effects);
        let (pos, v) = (x[l.x], x[l.v]);
        let (p1, p2) = (x[l.p[0]], x[l.p[1]]);
        let (w1, w2) = (x[l.w[0]], x[l.w[1]]);
        // mechanics
        let dev = pos - si.x0;
        let mass = si.mass * (1.0 + e.mass_slope_per_m * dev + e.mass_curvature_per_m2 * dev * dev);
        let coulomb = e.coulomb_n * (v / COULOMB_SMOOTHING_M_S).tanh();
        dx[l.x] = v;
        dx[l.v] = (p1 * si.a1 - p2 * si.a2 - si.f_ext - si.b * v - coulomb) / mass;
        // hydraulics
        let (v1, v2) = if e.varying_volumes {
            (
                self.vl[0] + si.a1 * pos,
                self.vl[1] + si.a2 * (self.x_max - pos),
            )
        } else {
            (si.v1, si.v2)
        };
        let (f1, f2) = (self.pump_factor(w1), self.pump_factor(w2));
        // pump 1 slips from chamber 1 to 2, pump 2 from chamber 1 to the reservoir
        let q1 = si.d[0] * w1 * f1 - e.slip_m5_per_ns * (1.0 - f1) * (p1 - p2);
        let q2 = si.d[1] * w2 * f2 - e.slip_m5_per_ns * (1.0 - f2) * p1;
        let cross = si.c12 * (p1 - p2);
        let beta = self.beta(0.5 * (p1 + p2));
        let dp1 = beta / v1 * (q1 + q2 - si.a1 * v - si.c1 * p1 - cross);
        let dp2 = beta / v2 * (-q1 + si.a2 * v - si.c2 * p2 + cross);
        // cavitation: gauge pressure cannot fall below −1 bar
        let floor = -ATMOSPHERE_PA;
        dx[l.p[0]] = if p1 <= floor && dp1 < 0.0 { 0.0 } else { dp1 };
        dx[l.p[1]] = if p2 <= floor && dp2 < 0.0 { 0.0 } else { dp2 };
        // motors, drives (the full model's layout always has tau)
        let tau = l.tau.expect("full motor model");
        let load = [si.d[0] * (p1 - p2), si.d[1] * p1];
        let limit = e.peak_torque_factor.map(|f| f * self.rated_torque);
        for i in 0..2 {
            let w = x[l.w[i]];
            let mut t_ref = si.km[i] * (u[i] - w);
            if let Some(ff) = l.ff {
                t_ref += si.kff / si.tau_ff * (u[i] - x[ff[i]]);
                dx[ff[i]] = (u[i] - x[ff[i]]) / si.tau_ff;
            }
            if let Some(lim) = limit {
                t_ref = t_ref.clamp(-lim, lim);
            }
            dx[tau[i]] = si.omega_i * (t_ref - x[tau[i]]);
            let mut acc = (x[tau[i]] - load[i]) / si.j[i];
            if e.pump_speed_limit && w.abs() >= self.max_pump_speed && acc * w > 0.0 {
                acc = 0.0;
            }
            dx[l.w[i]] = acc;
        }
    }

    /// The steady operating point of the rig as a state (absolute x0, gauge pressures, leakage
    /// speeds, drive torques equal to the load) and the speed references that hold it.
    pub fn operating_point(&self, rig: &Rig) -> (Vec<f64>, [f64; 2]) {
        // the emulated motors always carry the pumps' load
        Plant::new(rig).rest_state(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central-difference Jacobians (A, B) of the dynamics at (x, u).
    fn jacobians(d: &Dynamics, x: &[f64], u: &[f64; 2], scale: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = x.len();
        let mut a = vec![0.0; n * n];
        let mut b = vec![0.0; n * 2];
        let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..n {
            let h = 1e-6 * scale[j];
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            xp[j] += h;
            xm[j] -= h;
            d.rhs(&xp, u, &mut fp);
            d.rhs(&xm, u, &mut fm);
            for i in 0..n {
                a[i * n + j] = (fp[i] - fm[i]) / (2.0 * h);
            }
        }
        for j in 0..2 {
            let h = 1e-6 * 10.0;
            let (mut up, mut um) = (*u, *u);
            up[j] += h;
            um[j] -= h;
            d.rhs(x, &up, &mut fp);
            d.rhs(x, &um, &mut fm);
            for i in 0..n {
                b[i * 2 + j] = (fp[i] - fm[i]) / (2.0 * h);
            }
        }
        (a, b)
    }

    #[test]
    fn operating_point_is_an_equilibrium() {
        let rig = Rig::default();
        let d = Dynamics::new(&rig, Effects::none()).unwrap();
        let (x, u) = d.operating_point(&rig);
        let mut dx = vec![0.0; x.len()];
        d.rhs(&x, &u, &mut dx);
        let typical = [1e-3, 1e-2, 1e5, 1e5, 10.0, 10.0, 0.1, 0.1, 10.0, 10.0];
        for (i, v) in dx.iter().enumerate() {
            assert!(v.abs() < 1e-9 * typical[i] * 1e3, "state {i}: {v}");
        }
    }

    #[test]
    fn linearisation_matches_the_analytic_model() {
        // varying volumes on: at the equilibrium the flows vanish, so A and B are unchanged
        let rig = Rig::default();
        let effects = Effects {
            varying_volumes: true,
            ..Effects::none()
        };
        let d = Dynamics::new(&rig, effects).unwrap();
        let (x, u) = d.operating_point(&rig);
        let typical = [1e-3, 1e-2, 1e5, 1e5, 10.0, 10.0, 0.1, 0.1, 10.0, 10.0];
        let (a, b) = jacobians(&d, &x, &u, &typical);
        let plant = Plant::new(&rig);
        let n = d.order();
        for i in 0..n {
            for j in 0..n {
                let (fd, an) = (a[i * n + j], plant.a[(i, j)]);
                // entries the model has as zero must be zero up to rounding of the scaled row
                let floor = 1e-9 * typical[i] / typical[j];
                assert!(
                    (fd - an).abs() <= 1e-4 * an.abs() + floor,
                    "A[{i}][{j}]: {fd} vs {an}"
                );
            }
            for j in 0..2 {
                let (fd, an) = (b[i * 2 + j], plant.b[(i, j)]);
                let floor = 1e-9 * typical[i] / 10.0;
                assert!(
                    (fd - an).abs() <= 1e-4 * an.abs() + floor,
                    "B[{i}][{j}]: {fd} vs {an}"
                );
            }
        }
    }

    #[test]
    fn cavitation_and_torque_limit_act() {
        let rig = Rig::default();
        let effects = Effects {
            peak_torque_factor: Some(3.0),
            ..Effects::none()
        };
        let d = Dynamics::new(&rig, effects).unwrap();
        let (mut x, _) = d.operating_point(&rig);
        let l = Plant::new(&rig).layout;
        // a huge speed demand: the torque reference saturates at 3 × rated
        let mut dx = vec![0.0; x.len()];
        d.rhs(&x, &[1e4, 1e4], &mut dx);
        let t = l.tau.unwrap()[0];
        let want = rig.si().omega_i * (3.0 * rig.motor_rated_torque_nm - x[t]);
        assert!((dx[t] - want).abs() < 1e-9 * want.abs());
        // chamber 1 at −1 bar gauge while the piston runs out of it (v > 0 grows V1): the
        // pressure would fall further, cavitation holds it
        x[l.p[0]] = -1e5;
        x[l.v] = 1.0;
        d.rhs(&x, &[0.0, 0.0], &mut dx);
        assert_eq!(dx[l.p[0]], 0.0);
    }
}

#[cfg(test)]
mod emulate_tests {
    use super::*;
    use crate::response::{simulate, Baseline};

    #[test]
    fn effects_off_and_a_fast_plc_reproduce_the_lti_step() {
        // at 1 kHz the sampled controller is close to the LTI model's continuous one. The
        // sum-pressure loop stays open: the comparison is of the position loop alone.
        let rig = Rig {
            sum_pressure: false,
            ..Rig::default()
        };
        let d = Dynamics::new(&rig, Effects::none()).unwrap();
        let step = |t: f64| if t < 0.2 { 345.0 } else { 350.0 };
        let em = emulate(&rig, &d, &Plc::ideal(1000.0), 5.0, 2.0, step).unwrap();
        // compare deviations from the settled state, as docs/simulation.md#deviations-and-the-baseline does with records
        let mut base = Baseline::of_rig(&rig);
        base.x_mm = em.x_mm[0];
        base.p_bar = [em.p1_bar[0], em.p2_bar[0]];
        let lti = simulate(&rig, &em.time_s, &em.x_ref_mm, &base).unwrap();
        let worst = em
            .x_mm
            .iter()
            .zip(&lti.x_mm)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        // 2 % of the step: the 1 kHz sampling delay and the settled (not LTI) operating point
        assert!(worst < 0.1, "largest difference {worst} mm on a 5 mm step");
        // Pressures are not compared: without the sum-pressure loop nothing holds p1 + p2, and
        // the leakage drains it towards 0.2 bar while the run goes on, a drift the deviation
        // model cannot show.
    }
}
