//! The nonlinear rig emulator (docs/emulator.md): the continuous dynamics of the DPM rig
//! with what the LTI model leaves out — chamber volumes that follow the piston, a
//! pressure-dependent bulk modulus (docs/bulk-modulus.md), cavitation, motor torque and speed limits, pump
//! low-speed flow loss, Coulomb friction and a stroke-dependent mass. Each effect can be
//! switched off; with all of them off the right-hand side linearises to the analytic model of
//! `model` (a test checks every entry of A and B).
//!
//! `plc` closes the loop at the PLC's rate and integrates these dynamics between samples.

pub mod article;
pub mod chatter;
pub mod cycle;
mod experiment;
mod integrate;
mod phi;
mod steps;
pub use integrate::with_bdf_integrator;
mod plc;

pub use crate::circuit::stops::{End, EndStopHit, Stops, CONTACT_DAMPING, CONTACT_RAD_S};
pub use experiment::{
    DriveSignals, DriveStep, Experiment, DRIVE_RATE_HZ, DRIVE_RECORD_S, PLC_RATE_HZ, RECORD_S,
    SETTLE_S, SINE_PERIODS, STEP_MM,
};
pub use plc::{
    emulate, emulate_profile, emulate_reporting, equilibrium, hold_speeds, hold_speeds_accounting,
    Emulation, Plc, PlcLoop, Profile, PROGRESS_STEPS,
};

/// Why an emulation under a work limit stopped: the emulator could not run, or its
/// integrator's work went beyond the limit (docs/emulator.md#the-work-limit).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RunError {
    /// The emulator's own error.
    #[error(transparent)]
    Emulator(#[from] EmulatorError),
    /// The integrator's work beyond [`crate::limits::MAX_EMULATOR_WORK`], not allowed.
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
}

impl RunError {
    /// The emulator's error of a run that allows a long run (where no limit stops it).
    pub(crate) fn into_emulator(self) -> EmulatorError {
        match self {
            RunError::Emulator(e) => e,
            RunError::Limit(e) => EmulatorError(e.to_string()),
        }
    }
}

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
use crate::circuit::{Circuit, Emulated, Role};
use crate::rig::{MotorModel, Rig};
use crate::units::PA_PER_BAR;

pub use crate::circuit::parts::{Effects, MassLaw};

impl Effects {
    /// Every effect on ([`Effects::all`]) with the gas fraction that gives `beta_bar` at
    /// `p_mean_bar`: the emulated article records' (the article §2.1: 165 bar at 4.4 bar).
    pub fn article(beta_bar: f64, p_mean_bar: f64) -> Result<Effects, EmulatorError> {
        let x = crate::bulk::gas_fraction(beta_bar, p_mean_bar, crate::bulk::BETA_OIL_BAR)
            .map_err(|e| EmulatorError(e.to_string()))?;
        Ok(Effects::all(x))
    }

    /// Every effect on for `rig` ([`Effects::all`] with the rig's own dead band, slip and
    /// Coulomb friction, [`Effects::with_rig`]), the bulk modulus anchored at the rig
    /// itself: the gas fraction that gives the rig's `beta_bar` at the pressure
    /// [`beta_anchor_bar`] names — the DPM's mean chamber pressure at rest
    /// ([`rest_mean_pressure_bar`]), so the emulated β_e at its operating point *is*
    /// `beta_bar`; a single-motor circuit's accumulator pre-charge, the level its chambers
    /// rest near (docs/emulator.md#every-circuit); the mass following the rig's own `mass_by_position` (constant without one).
    /// What `pumpcyl emulate` and the emulator FMU run (docs/emulator.md#what-a-user-rig-gets).
    ///
    /// # Errors
    /// A rig whose loop cannot rest, whose rest needs a chamber below the vapour pressure
    /// (docs/model.md#cavitation), or whose mean pressure at rest is not above 0 bar gauge (the
    /// gas-fraction model needs a positive pressure), or a `beta_bar` beyond the oil's own.
    pub fn for_rig(rig: &Rig) -> Result<Effects, EmulatorError> {
        let p_mean = beta_anchor_bar(rig)?;
        if p_mean.is_nan() || p_mean <= 0.0 {
            // the DPM's message as it always was; a single-motor circuit's names its pre-charge
            let level = rig.circuit.description().level;
            let (what, raise) = (level.words, level.key);
            return Err(EmulatorError(format!(
                "{what} is {p_mean:.3} bar gauge: the emulator's bulk modulus (the {} \
                 model, docs/bulk-modulus.md) needs it above 0 bar; raise {raise}",
                rig.bulk_model().name()
            )));
        }
        Effects::of_gas(rig, p_mean)
            .map_err(|e| EmulatorError(format!("beta_bar = {}: {e}", rig.beta_bar)))
    }

    /// Every effect on for `rig` ([`Effects::with_rig`]) with its bulk-modulus model
    /// ([`Rig::bulk_model`]) through its `beta_bar` at the gauge pressure `p_anchor_bar`.
    fn of_gas(rig: &Rig, p_anchor_bar: f64) -> Result<Effects, crate::bulk::BulkError> {
        let model = rig.bulk_model();
        let x = model.fit(rig.beta_bar, p_anchor_bar, crate::bulk::BETA_OIL_BAR)?;
        Ok(Effects {
            bulk_model: model,
            ..Effects::all(x).with_rig(rig)
        })
    }

    /// [`Effects::for_rig`] when `on`, [`Effects::none`] otherwise: the choice of
    /// `pumpcyl emulate --no-effects` and of the emulator FMU.
    pub fn switched(rig: &Rig, on: bool) -> Result<Effects, EmulatorError> {
        if on {
            Effects::for_rig(rig)
        } else {
            Ok(Effects::none())
        }
    }
}

/// The pressure (bar gauge) at which the emulator's bulk modulus is the rig's `beta_bar`
/// ([`Effects::for_rig`]): the DPM's mean chamber pressure at rest
/// ([`rest_mean_pressure_bar`]); the accumulator's pre-charge for the single-motor circuits,
/// whose pressure level it sets (docs/emulator.md#every-circuit).
///
/// # Errors
/// A DPM loop that cannot rest at x0, or whose rest needs cavitation.
pub fn beta_anchor_bar(rig: &Rig) -> Result<f64, EmulatorError> {
    if rig.circuit.description().level.at_emulated_rest {
        rest_mean_pressure_bar(rig)
    } else {
        Ok(crate::circuit::pressure_level_bar(rig))
    }
}

/// The mean chamber pressure (p1 + p2)/2 (bar gauge) of `rig`'s emulated loop at rest at x0,
/// every effect on: the pressure at which its `beta_bar` holds ([`Effects::for_rig`]). At rest
/// no oil is compressed, so the bulk modulus does not change this state. Where Newton's method
/// cannot bring the loop to rest, the LTI model's operating point (the set-point's sum split
/// by the force balance) stands in.
///
/// # Errors
/// A loop that cannot rest there, or a rest that needs cavitation (docs/model.md#cavitation).
pub fn rest_mean_pressure_bar(rig: &Rig) -> Result<f64, EmulatorError> {
    // Newton runs with β_e(p) anchored at the set-point's mean (the rest does not depend on
    // it, the path to it does: this is the path the emulator's own start takes)
    let effects = match Effects::of_gas(rig, 0.5 * rig.p_sum_ref_bar) {
        Ok(effects) => effects,
        Err(_) => Effects {
            gas_fraction: None,
            ..Effects::all(0.0).with_rig(rig)
        },
    };
    let d = Dynamics::new(rig, effects)?;
    // a loop Newton cannot bring to rest (one that rings at its limits, such as a sum-pressure
    // gain of 22 per bar) rests, if at all, at the LTI model's operating point
    let x = equilibrium(rig, &d, rig.x0_mm).unwrap_or_else(|_| d.operating_point().0);
    let p: Vec<f64> = d.at.pressures.iter().map(|&i| x[i] / PA_PER_BAR).collect();
    crate::cavitation::check_chambers(&p)
        .map_err(|e| EmulatorError(format!("the emulated loop at rest at x0: {e}")))?;
    Ok(0.5 * (p[0] + p[1]))
}

/// The continuous dynamics of the rig: its circuit's emulated equations ([`Emulated`]: the
/// DPM, the dual-pump or the single-pump circuit) with the chosen effects and the end stops,
/// states as in its [`Circuit::states`] (absolute position, gauge pressures), inputs the drive
/// speed references (rad/s): ω_ref1, ω_ref2 for the DPM, the one motor's ω_ref for the
/// single-motor circuits (a second command, where given, is not read).
#[derive(Debug, Clone)]
pub struct Dynamics {
    circuit: Emulated,
    /// Where the position, the pressures and the motor speeds are in the state.
    pub(crate) at: Places,
    /// The pumps' speed limit (rad/s) where the effect is on: the rig's `pump_max_speed_rpm`.
    speed_limit_rad_s: Option<f64>,
    /// The integrator's probe of these equations, once computed ([`Dynamics::probe`]).
    probe: std::sync::OnceLock<Vec<u64>>,
}

/// Where the signals the PLC measures are in a circuit's state.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Places {
    pub(crate) position: usize,
    pub(crate) pressures: Vec<usize>,
    pub(crate) speeds: Vec<usize>,
}

impl Places {
    fn of<C: Circuit>(c: &C) -> Places {
        Places {
            position: c.state_of(Role::Position).unwrap_or(0),
            pressures: c.states_of(Role::Pressure),
            speeds: c.states_of(Role::MotorSpeed),
        }
    }
}

impl Dynamics {
    /// The dynamics of a rig (full motor model only) with the chosen effects, whichever its
    /// circuit.
    pub fn new(rig: &Rig, effects: Effects) -> Result<Dynamics, EmulatorError> {
        if rig.motor_model != MotorModel::Full {
            return Err("the emulator needs motor_model = \"full\"".into());
        }
        let circuit = Emulated::of_rig(rig, effects).map_err(EmulatorError)?;
        let at = Places::of(&circuit);
        Ok(Dynamics {
            circuit,
            at,
            speed_limit_rad_s: effects.pump_speed_limit_rad_s(rig),
            probe: std::sync::OnceLock::new(),
        })
    }

    /// The circuit whose equations these are.
    pub fn circuit(&self) -> &Emulated {
        &self.circuit
    }

    /// The same dynamics without the limits a Newton step may cross at rest (torque and speed
    /// limits, end stops).
    pub(crate) fn without_limits(&self) -> Dynamics {
        Dynamics {
            circuit: self.circuit.without_limits(),
            at: self.at.clone(),
            speed_limit_rad_s: None,
            probe: std::sync::OnceLock::new(),
        }
    }

    /// Refuse a rest `x` whose motors turn faster than the pumps' speed limit, where it is on:
    /// the load's leakage needs a speed the pumps cannot reach, so the loop cannot hold it
    /// (the speed limit only stops acceleration, and a rest has none).
    pub(crate) fn check_rest_speeds(&self, x: &[f64], r_mm: f64) -> Result<(), EmulatorError> {
        let Some(max) = self.speed_limit_rad_s else {
            return Ok(());
        };
        let fastest = (self.at.speeds.iter())
            .map(|&i| x[i].abs())
            .fold(0.0, f64::max);
        if fastest <= max * (1.0 + 1e-9) {
            return Ok(());
        }
        let rpm = |w: f64| w / crate::units::RAD_S_PER_RPM;
        Err(EmulatorError(format!(
            "the emulated loop cannot rest at x_ref = {r_mm} mm: feeding the leakage under the \
             load needs the pumps at {:.0} rpm, beyond pump_max_speed_rpm = {:.0} rpm (a smaller \
             load or leakage, or a larger pump)",
            rpm(fastest),
            rpm(max)
        )))
    }

    /// Change the external force on the piston (N).
    pub fn set_external_force_n(&mut self, f_n: f64) {
        self.circuit.set_external_force_n(f_n);
        self.probe = std::sync::OnceLock::new();
    }

    /// What the integrator probes of these equations to know them again (their rates at two
    /// points, bit for bit), computed by `compute` once: the equations do not change but by
    /// [`Dynamics::set_external_force_n`], which forgets it.
    pub(crate) fn probe(&self, compute: impl FnOnce(&Dynamics) -> Vec<u64>) -> &[u64] {
        self.probe.get_or_init(|| compute(self))
    }

    /// The end of the stroke the piston of state `x` is at or beyond, if any, met at `t_s`.
    pub fn end_stop(&self, x: &[f64], t_s: f64) -> Option<EndStopHit> {
        let (end, end_mm) = self.circuit.stops()?.end_at(x[self.at.position])?;
        Some(EndStopHit {
            end,
            end_mm,
            at_s: t_s,
        })
    }

    /// The first chamber of state `x` at the cavitation floor, if any, met at `t_s`.
    pub fn floor_hit(&self, x: &[f64], t_s: f64) -> Option<crate::cavitation::FloorHit> {
        let p = [0, 1].map(|k| x[self.at.pressures[k]] / PA_PER_BAR);
        crate::cavitation::FloorHit::of_chambers(&p, t_s)
    }

    /// Number of states.
    pub fn order(&self) -> usize {
        self.circuit.order()
    }

    /// ẋ = f(x, u) into `dx`, `u` the speed references (at least one per drive).
    pub fn rhs(&self, x: &[f64], u: &[f64], dx: &mut [f64]) {
        self.circuit.rhs(x, u, dx);
    }

    /// The exact Jacobian ∂f/∂x at (x, u), row-major n × n, from the circuit's own equations
    /// by dual numbers ([`crate::circuit::linearise`]): what an implicit integrator needs.
    pub fn jacobian(&self, x: &[f64], u: &[f64]) -> Vec<f64> {
        let (a, _) = crate::circuit::linearise(&self.circuit, x, &u[..self.circuit.commands()]);
        a.transpose().as_slice().to_vec()
    }

    /// [`Dynamics::jacobian`] into `out`, the same numbers bit for bit
    /// ([`crate::circuit::state_jacobian`]).
    pub(crate) fn jacobian_into(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        crate::circuit::state_jacobian(&self.circuit, x, &u[..self.circuit.commands()], out);
    }

    /// The steady operating point of the rig as a state (absolute x0, gauge pressures, leakage
    /// speeds, drive torques equal to the load) and the speed references that hold it (0 for a
    /// drive the circuit does not have).
    pub fn operating_point(&self) -> (Vec<f64>, [f64; 2]) {
        // the emulated motors always carry the pumps' load
        self.circuit.rest_state()
    }

    /// Where the circuit's power goes at state `x` under commands `u` (docs/energy.md): its
    /// sources, the work against the external force, each loss and each stored energy's rate,
    /// closing to rounding.
    pub fn power(&self, x: &[f64], u: &[f64]) -> crate::circuit::energy::Power {
        self.circuit.power(x, &u[..self.circuit.commands()])
    }

    /// The single-pump circuit's mode at state `x` (1 or 2, docs/emulator.md#the-mode-signal);
    /// `None` for a circuit without modes.
    pub fn mode(&self, x: &[f64]) -> Option<usize> {
        self.circuit.mode(x)
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
        let (x, u) = d.operating_point();
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
        let (x, u) = d.operating_point();
        let typical = [1e-3, 1e-2, 1e5, 1e5, 10.0, 10.0, 0.1, 0.1, 10.0, 10.0];
        let (a, b) = jacobians(&d, &x, &u, &typical);
        let plant = crate::model::Plant::new(&rig);
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

    /// A rig that shares no value with the article's, without a mass table.
    fn user_rig() -> Rig {
        Rig::from_toml_str(
            "piston_diameter_mm = 80.0\nrod_diameter_mm = 45.0\nstroke_mm = 800.0\nx0_mm = 400.0\n\
             mass_kg = 2500.0\nmass_by_position = []\nbeta_bar = 300.0\nkp = 15.0\n",
            "user.toml",
        )
        .unwrap()
    }

    #[test]
    fn the_emulated_bulk_modulus_at_the_rigs_rest_is_its_beta_bar() {
        for beta_bar in [37.8, 165.0, 300.0, 1000.0] {
            let rig = Rig {
                beta_bar,
                ..user_rig()
            };
            let e = Effects::for_rig(&rig).unwrap();
            let d = Dynamics::new(&rig, e).unwrap();
            let x = equilibrium(&rig, &d, rig.x0_mm).unwrap();
            let p_mean = 0.5 * (x[d.at.pressures[0]] + x[d.at.pressures[1]]);
            let beta = d.circuit().beta_pa(p_mean) / PA_PER_BAR;
            assert!(
                (beta - beta_bar).abs() < 1e-9 * beta_bar,
                "{beta} vs {beta_bar}"
            );
        }
        // a bulk modulus above the oil's own has no gas fraction
        let stiff = Rig {
            beta_bar: 2e4,
            ..user_rig()
        };
        assert!(Effects::for_rig(&stiff)
            .unwrap_err()
            .0
            .contains("beta_bar = 20000"));
    }

    #[test]
    fn the_mass_law_follows_the_rigs_table_and_is_constant_without_one() {
        // the article's three points: one parabola through them (§3.3)
        let article = Rig::default();
        let law = MassLaw::of_rig(&article);
        let (m0, mm, mp, d) = (10_593.0, 9_958.0, 12_373.0, 0.05);
        let (k1, k2) = (
            (mp - mm) / (2.0 * d) / m0,
            ((mp + mm) / 2.0 - m0) / (d * d) / m0,
        );
        for dev in [-0.1, -0.05, -0.013, 0.0, 0.021, 0.05, 0.08] {
            let want = 1.0 + k1 * dev + k2 * dev * dev;
            let got = law.ratio(0.345 + dev);
            assert!((got - want).abs() < 1e-12, "at {dev}: {got} vs {want}");
        }
        // a four-point table is met at every point, scaled to the rig's mass at x0
        let table = "mass_by_position = [{x_mm = 100.0, mass_kg = 2000.0}, {x_mm = 300.0, mass_kg = 2400.0}, \
                     {x_mm = 500.0, mass_kg = 2600.0}, {x_mm = 700.0, mass_kg = 3400.0}]\n";
        let rig = Rig::from_toml_str(
            &format!("x0_mm = 500.0\nstroke_mm = 800.0\n{table}"),
            "t.toml",
        )
        .unwrap();
        let law = MassLaw::of_rig(&rig);
        for (x, m) in [(0.1, 2000.0), (0.3, 2400.0), (0.5, 2600.0), (0.7, 3400.0)] {
            assert!((law.ratio(x) - m / 2600.0).abs() < 1e-12, "at {x} m");
        }
        // between points it stays between its neighbours' masses here (a gentle table)
        let mid = law.ratio(0.4) * 2600.0;
        assert!((2400.0..2600.0).contains(&mid), "{mid}");
        // far beyond the table the guard holds it at half the smallest ratio at least
        assert!(law.ratio(-50.0) >= 0.5 * 2000.0 / 2600.0 - 1e-15);
        // no table: constant
        let flat = MassLaw::of_rig(&user_rig());
        assert_eq!((flat.ratio(0.0), flat.ratio(0.8)), (1.0, 1.0));
    }

    #[test]
    fn cavitation_and_torque_limit_act() {
        let rig = Rig::default();
        let effects = Effects {
            peak_torque_factor: Some(3.0),
            ..Effects::none()
        };
        let d = Dynamics::new(&rig, effects).unwrap();
        let (mut x, _) = d.operating_point();
        let c = d.circuit();
        // a huge speed demand: the torque reference saturates at 3 × rated
        let mut dx = vec![0.0; x.len()];
        d.rhs(&x, &[1e4, 1e4], &mut dx);
        let t = c.state_of(Role::Torque).unwrap();
        let want = rig.si().omega_i * (3.0 * rig.motor_rated_torque_nm - x[t]);
        assert!((dx[t] - want).abs() < 1e-9 * want.abs());
        // chamber 1 at −1 bar gauge while the piston runs out of it (v > 0 grows V1): the
        // pressure would fall further, cavitation holds it
        let p_cap = c.state_of(Role::Pressure).unwrap();
        x[p_cap] = -1e5;
        x[c.state_of(Role::Velocity).unwrap()] = 1.0;
        d.rhs(&x, &[0.0, 0.0], &mut dx);
        assert_eq!(dx[p_cap], 0.0);
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
        let em = emulate(&rig, &d, &Plc::ideal(1000.0), 5.0, 2.0, step)
            .unwrap()
            .signals;
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
