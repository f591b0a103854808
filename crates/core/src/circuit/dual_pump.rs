//! The single-motor dual-pump circuit of the article's Figure 1b (docs/circuits.md#dual-pump):
//! one servo motor and its drive turn both pumps on one shaft. Pump 1 (D1) moves oil from
//! chamber 2 into chamber 1 for positive speed, pump 2 (D2) from the accumulator into chamber 1.
//! The accumulator's pre-charge p_acc sets the pressure level; no loop controls it (the
//! article §2.1 names the "unpredictable pressure phenomena" of this circuit as the reason the
//! DPM was built instead: [`DualPump::steady_motion`] predicts them).
//!
//! States (SI): `x` (m), `v` (m/s), `p1`, `p2` (Pa gauge), `w` (rad/s, the shaft), then for the
//! full motor model `tau` (N·m) and, with feedforward on, `z` (rad/s); the input is the drive's
//! speed command `w_ref` (rad/s). Equations (docs/circuits.md#equations):
//!
//! - m v̇ = p1 A1 − p2 A2 − F_ext − b v
//! - V1/β ṗ1 = (D1 + D2) ω − A1 v − c1 (p1 − p_acc) − c12 (p1 − p2)
//! - V2/β ṗ2 = −D1 ω + A2 v − c2 (p2 − p_acc) + c12 (p1 − p2)
//! - J ω̇ = τ − D1 (p1 − p2) − D2 (p1 − p_acc),  J = Jm1 + Jp1 + Jp2
//! - τ̇ = ωI (Km1 (ω_ref − ω) + (Kff/τff)(ω_ref − z) − τ),  τff ż = ω_ref − z
//!
//! and the control law ω_ref = K_scale Kp (x_ref − x). The equations are built from the parts
//! every circuit shares ([`super::parts`]): [`DualPump::new`] is the ideal circuit whose
//! Jacobian is the linear model (volumes at x0, constant β), [`DualPump::emulated`] the one the
//! emulator integrates (the parts' effects, the end stops, and the check and relief valves of
//! [`super::valves`]).
//!
//! ```
//! use pumpcyl::circuit::{dual_pump::DualPump, linearise, Circuit};
//! use pumpcyl::rig::Rig;
//!
//! let rig = Rig::default().with_overrides(&["circuit=dual-pump".into()])?;
//! let c = DualPump::new(&rig)?;
//! let op = c.operating_point();
//! let (a, b) = linearise(&c, &op.state, &op.inputs);
//! assert_eq!((a.nrows(), b.ncols()), (7, 1));
//! // the article-valued rig rests at the DPM's rest pressures (p1 + p2 = 10 bar)
//! let rest = c.rest();
//! assert!(((rest.p1_pa + rest.p2_pa) / 1e6 - 1.0).abs() < 1e-3);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod balance;

/// Why the dual-pump circuit has no modes to switch between, in one line
/// (docs/circuits.md#will-it-chatter): pump 2 feeds the area difference, its valves only
/// protect the chambers (docs/circuits.md#valves).
pub const NO_MODES: &str = "pump 2, on the shaft of pump 1, feeds chamber 1 from the \
     accumulator (the article's Figure 1b): no valve moves a chamber onto the accumulator; its \
     check valves only refill a chamber that falls below it";

pub use balance::{SteadyMotion, Undetermined};

use super::parts::{
    cylinder_of_rig, cylinder_rates, effective_beta_of, gas_fraction_of, one_motor_inputs,
    one_motor_states, Chamber, Effects, Fluid, Motor, Piston, Pump, BETA_OIL_BAR,
};
use super::energy::{self, Power};
use super::stops::Stops;
use super::valves::Valves;
use super::{Circuit, CircuitKind, ControlLaw, OperatingState, Scalar, Signal};
use crate::rig::Rig;
use crate::units::PA_PER_BAR;
use balance::Balance;

/// State positions: position, velocity, the chamber pressures, the shaft speed, then the
/// motor's torque and feedforward filter (with the full motor model only; tests name them).
const X: usize = 0;
const V: usize = 1;
const P1: usize = 2;
const P2: usize = 3;
const W: usize = 4;
#[cfg(test)]
const TAU: usize = 5;

/// The single-motor dual-pump circuit of a rig (the article's Figure 1b).
#[derive(Debug, Clone, PartialEq)]
pub struct DualPump {
    balance: Balance,
    piston: Piston,
    chambers: [Chamber; 2],
    fluid: Fluid,
    /// Pump 1 (chamber 2 → chamber 1) and pump 2 (accumulator → chamber 1).
    pumps: [Pump; 2],
    motor: Motor,
    /// The drive's electrical side (docs/energy.md#the-drives).
    electrics: energy::Electrics,
    /// Leakages c1, c2, c12 (m⁵/(N·s)).
    leakage: [f64; 3],
    /// The pumps' pressure load acts on the shaft.
    coupling: bool,
    /// The emulator's valves (docs/circuits.md#valves).
    valves: Valves,
    /// The valves are part of the equations (the emulated circuit, not the ideal one).
    valves_on: bool,
    /// Position gain times command scale, K_scale Kp (rad/s per m).
    gain: f64,
    /// Operating-point position x0 (m).
    x0: f64,
    /// The gas fraction's anchor: the rig's β (bar).
    beta_bar: f64,
    /// Number of states.
    n: usize,
}

/// [`SteadyMotion`] with the effective bulk modulus it gives (docs/circuits.md#steady-motion).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SteadyBulk {
    /// The steady state.
    pub state: SteadyMotion,
    /// Mean chamber pressure (p1 + p2)/2 (bar gauge).
    pub p_mean_bar: f64,
    /// Effective bulk modulus there (bar), of the gas fraction that gives the rig's `beta_bar`
    /// at its mean pressure at rest.
    pub beta_e_bar: f64,
    /// Net flow the emulator's valves would pass into chambers 1 and 2 there (m³/s): zero
    /// while every valve is shut, as the linear model assumes.
    pub valve_flow_m3_per_s: [f64; 2],
}

impl DualPump {
    /// The ideal circuit of `rig`, whose Jacobian at rest is the linear model: no effect, no
    /// end stops, no valves, the rig's variant switches (motor model, feedforward, motor
    /// coupling) as set.
    ///
    /// # Errors
    /// [`Undetermined`] when the leakage does not fix the pressures at rest.
    pub fn new(rig: &Rig) -> Result<DualPump, Undetermined> {
        DualPump::build(rig, Effects::none(), None, false)
    }

    /// The circuit the emulator integrates: the chosen effects, the end stops, the check and
    /// relief valves, the pumps' load always on the shaft (docs/circuits.md#valves).
    ///
    /// # Errors
    /// [`Undetermined`] when the leakage does not fix the pressures at rest.
    pub fn emulated(rig: &Rig, effects: Effects) -> Result<DualPump, Undetermined> {
        let stops = Stops::new(rig.stroke_mm * 1e-3, rig.mass_kg);
        DualPump::build(rig, effects, Some(stops), true)
    }

    fn build(
        rig: &Rig,
        e: Effects,
        stops: Option<Stops>,
        emulated: bool,
    ) -> Result<DualPump, Undetermined> {
        let si = rig.si();
        let balance = rig.dual_pump_balance();
        balance.steady(0.0)?;
        let (piston, chambers) = cylinder_of_rig(rig, &e, stops);
        let motor = Motor::of_rig(rig, si.j[0] + rig.pump_inertia_2_kg_mm2 * 1e-6, &e);
        Ok(DualPump {
            balance,
            piston,
            chambers,
            fluid: Fluid::of(si.beta, &e),
            pumps: si.d.map(|d| Pump::of(d, &e)),
            leakage: [si.c1, si.c2, si.c12],
            coupling: emulated || rig.motor_coupling,
            valves: Valves::new(rig.relief_setting_pa(CircuitKind::DualPump)),
            valves_on: emulated,
            gain: si.k_scale * si.kp,
            x0: si.x0,
            beta_bar: rig.beta_bar,
            n: 4 + motor.n_states(),
            motor,
            electrics: energy::Electrics::of(rig),
        })
    }

    /// Number of states: 7 (full motor model with feedforward), 6 (without), 5 (first order).
    pub fn n_states(&self) -> usize {
        self.n
    }

    cylinder_calls!(DualPump, motor);

    /// The accumulator pressure p_acc (Pa gauge).
    pub fn accumulator_pa(&self) -> f64 {
        self.balance.p_acc_pa
    }

    /// The position loop's gain K_scale Kp (rad/s per m): ω_ref = K_scale Kp (x_ref − x).
    pub fn position_gain(&self) -> f64 {
        self.gain
    }

    /// The flow area (m²) by which pump 2 over-supplies chamber 1 per unit piston speed
    /// ([`Balance::mismatch_m2`]).
    pub fn mismatch_m2(&self) -> f64 {
        self.balance.mismatch_m2()
    }

    /// The steady state at rest ([`DualPump::steady_motion`] at v = 0).
    pub fn rest(&self) -> SteadyMotion {
        (self.balance.steady(0.0)).expect("checked when the circuit was built")
    }

    /// Where a check valve is open at the rest the linear model is taken at
    /// ([`DualPump::rest`], every valve shut; docs/circuits.md#valves): the chamber (1 or 2),
    /// its pressure and the accumulator's (bar gauge), and the flow the valve would pass there
    /// (m³/s). `None` while both stay shut.
    pub fn valve_open_at_rest(&self) -> Option<(usize, f64, f64, f64)> {
        let rest = self.rest();
        let p_acc = self.balance.p_acc_pa;
        [rest.p1_pa, rest.p2_pa]
            .iter()
            .enumerate()
            .map(|(i, &p)| (i, p, self.valves.into_chamber(i, p, p_acc)))
            .find(|(_, _, q)| *q != 0.0)
            .map(|(i, p, q)| (i + 1, p / PA_PER_BAR, p_acc / PA_PER_BAR, q))
    }

    /// The steady state at constant piston speed `v` (m/s): the force balance and both
    /// chambers' flow balances with leakage, solved in closed form ([`Balance::steady`],
    /// docs/circuits.md#steady-motion).
    pub fn steady_motion(&self, v: f64) -> SteadyMotion {
        (self.balance.steady(v)).expect("the balance's matrix does not depend on v")
    }

    /// [`DualPump::steady_motion`] with its effective bulk modulus: the constant gas-fraction
    /// model (docs/bulk-modulus.md) anchored at the rig's `beta_bar` at the mean pressure at
    /// rest, read at the steady mean pressure; and the flow the emulator's valves would pass
    /// there.
    ///
    /// # Errors
    /// A mean pressure at rest or in motion not above 0 bar gauge, or a `beta_bar` beyond the
    /// oil's own (the gas-fraction model's range).
    pub fn steady_bulk(&self, v: f64) -> Result<SteadyBulk, String> {
        let mean_bar = |s: &SteadyMotion| 0.5 * (s.p1_pa + s.p2_pa) / PA_PER_BAR;
        let x = gas_fraction_of(self.beta_bar, mean_bar(&self.rest()), BETA_OIL_BAR)?;
        let state = self.steady_motion(v);
        let p_mean_bar = mean_bar(&state);
        if p_mean_bar.is_nan() || p_mean_bar <= 0.0 {
            return Err(format!(
                "the mean chamber pressure at {v} m/s is {p_mean_bar:.3} bar gauge: the gas-fraction \
                 model needs it above 0 bar"
            ));
        }
        let flow = |i, p| self.valves.into_chamber(i, p, self.balance.p_acc_pa);
        Ok(SteadyBulk {
            state,
            p_mean_bar,
            beta_e_bar: effective_beta_of(x, p_mean_bar, BETA_OIL_BAR),
            valve_flow_m3_per_s: [flow(0, state.p1_pa), flow(1, state.p2_pa)],
        })
    }

    /// c1 and c2 from a standstill held under feedback (docs/identification.md#leakage-from-standstill)
    /// for a given c12: the shaft speed ω feeding both chambers' leakage at rest,
    /// c1 = ((D1 + D2) ω − c12 (p1 − p2))/(p1 − p_acc), c2 = (−D1 ω + c12 (p1 − p2))/(p2 − p_acc),
    /// with p2 from the force balance at rest. The circuit's leakages run to the accumulator
    /// line, so a chamber at the accumulator pressure leaves its own undetermined.
    ///
    /// # Errors
    /// A standstill whose chamber pressure is within 1 Pa of the accumulator's, or that puts a
    /// chamber below the vapour pressure (docs/model.md#cavitation).
    pub fn standstill_leakage(
        &self,
        rig: &Rig,
        s: &crate::circuit::dpm::Standstill,
        c12: f64,
    ) -> Result<crate::circuit::dpm::Leakage, String> {
        let p2_bar = rig.p2_at_rest_bar(s.p1_bar);
        crate::cavitation::check_chambers(&[s.p1_bar, p2_bar]).map_err(|e| {
            format!(
                "standstill p1_bar = {}: the force balance puts {e}",
                s.p1_bar
            )
        })?;
        let (p1, p2) = (s.p1_bar * PA_PER_BAR, p2_bar * PA_PER_BAR);
        let p_acc = self.balance.p_acc_pa;
        if (p1 - p_acc).abs() < 1.0 || (p2 - p_acc).abs() < 1.0 {
            return Err(format!(
                "standstill p1_bar = {}: a chamber at the accumulator pressure leaves its leakage \
                 c1 or c2 undetermined (docs/identification.md#leakage-from-standstill)",
                s.p1_bar
            ));
        }
        self.valves_shut_at([p1, p2])
            .map_err(|e| format!("standstill p1_bar = {}: {e}", s.p1_bar))?;
        let [d1, d2] = self.balance.displacements_m3;
        let w = s.w1_rpm * crate::units::RAD_S_PER_RPM;
        let cross = c12 * (p1 - p2);
        let (c1, c2) = (
            ((d1 + d2) * w - cross) / (p1 - p_acc),
            (-d1 * w + cross) / (p2 - p_acc),
        );
        // near the accumulator pressure the leakages grow without bound, and some c12 then
        // gives a circuit with no determined rest: refused here, not when its model is built
        let with = Balance {
            leakage_m5_per_ns: [c1, c2, c12],
            ..self.balance
        };
        with.steady(0.0).map_err(|e| {
            format!(
                "standstill p1_bar = {} with c12 = {c12:e}: the leakages c1 = {c1:e}, c2 = {c2:e} \
                 it gives: {e}",
                s.p1_bar
            )
        })?;
        Ok(crate::circuit::dpm::Leakage {
            p2_bar,
            c12_m5_per_ns: c12,
            c1_m5_per_ns: c1,
            c2_m5_per_ns: c2,
        })
    }

    /// Whether every valve is shut at the chamber pressures `p_pa` (Pa gauge), as the linear
    /// model assumes; if not, which chamber's valve passes how much. At a standstill with a
    /// valve open the pump speed feeds the valve rather than the leakage, and the open valve
    /// ties its chamber to the accumulator, which the linear model (every valve shut) cannot
    /// hold: identified from such records, β reads about 30 % low
    /// (docs/circuits.md#identification-where-a-valve-is-open).
    pub(crate) fn valves_shut_at(&self, p_pa: [f64; 2]) -> Result<(), String> {
        let p_acc = self.balance.p_acc_pa;
        for (i, p) in p_pa.into_iter().enumerate() {
            let q = self.valves.into_chamber(i, p, p_acc);
            if q != 0.0 {
                let kind = if q > 0.0 { "check" } else { "relief" };
                return Err(format!(
                    "chamber {} at {:.3} bar against the {:.3} bar accumulator opens its {kind} \
                     valve ({:.2} cm³/s): the pump speed feeds the valve, not the leakage, and the \
                     linear model has every valve shut; load the piston so that both chambers \
                     sit within the valves' settings (docs/circuits.md#identification-where-a-valve-is-open)",
                    i + 1,
                    p / PA_PER_BAR,
                    p_acc / PA_PER_BAR,
                    q.abs() * 1e6
                ));
            }
        }
        Ok(())
    }

    /// The net flows into chambers 1 and 2 that compress their oil (m³/s): the pumps, the
    /// piston, the leakage and the valves.
    fn chamber_flows<T: Scalar>(&self, s: &[T]) -> [T; 2] {
        let (v, p1, p2, w) = (s[V], s[P1], s[P2], s[W]);
        let p_acc = self.balance.p_acc_pa;
        let [a1, a2] = self.piston.areas_m2;
        let [c1, c2, c12] = self.leakage;
        // pump 1 from chamber 2 into chamber 1, pump 2 from the accumulator into chamber 1
        let q1 = self.pumps[0].flow(w, p1 - p2);
        let q2 = self.pumps[1].flow(w, p1 - p_acc);
        let cross = (p1 - p2) * c12;
        let mut flows = [
            q1 + q2 - v * a1 - (p1 - p_acc) * c1 - cross,
            -q1 + v * a2 - (p2 - p_acc) * c2 + cross,
        ];
        if self.valves_on {
            flows[0] += self.valves.into_chamber(0, p1, p_acc);
            flows[1] += self.valves.into_chamber(1, p2, p_acc);
        }
        flows
    }

    /// The load torque of both pumps on the motor (N·m) at chamber pressures `p_pa` (Pa gauge),
    /// D1 (p1 − p2) + D2 (p1 − p_acc): what the drive's rating is checked against.
    pub fn load_torque_nm(&self, [p1, p2]: [f64; 2]) -> f64 {
        let d = self.balance.displacements_m3;
        (p1 - p2) * d[0] + (p1 - self.balance.p_acc_pa) * d[1]
    }

    /// The load torque of both pumps on the shaft, D1 (p1 − p2) + D2 (p1 − p_acc) (N·m); zero
    /// without the motor–hydraulics coupling.
    fn load_torque<T: Scalar>(&self, s: &[T]) -> T {
        if !self.coupling {
            return T::from(0.0);
        }
        let d = self.balance.displacements_m3;
        let dp = [s[P1] - s[P2], s[P1] - self.balance.p_acc_pa];
        let friction = self.pumps[0].friction_torque(s[W], dp[0])
            + self.pumps[1].friction_torque(s[W], dp[1]);
        dp[0] * d[0] + dp[1] * d[1] + friction
    }
}

impl Circuit for DualPump {
    fn kind(&self) -> CircuitKind {
        CircuitKind::DualPump
    }

    fn states(&self) -> Vec<Signal> {
        one_motor_states("shaft speed (motor and both pumps)", self.n)
    }

    fn inputs(&self) -> Vec<Signal> {
        one_motor_inputs()
    }

    fn rhs<T: Scalar>(&self, s: &[T], u: &[T], dx: &mut [T]) {
        let cylinder = (&self.piston, &self.chambers, &self.fluid);
        cylinder_rates(cylinder, [X, V, P1, P2], s, self.chamber_flows(s), dx);
        (self.motor).write_rates(u[0], s, self.load_torque(s), dx, W);
    }

    /// The regime of the one motor ([`Motor::regime`]).
    fn drive_regime(&self, s: &[f64], u: &[f64]) -> Option<u64> {
        Some(self.motor.regime(u[0], s, self.load_torque(s), W))
    }

    /// At rest at x0: the pressures and shaft speed of [`DualPump::rest`]; with the full motor
    /// model the torque that carries the pumps' load, the command that holds it through the P
    /// loop (τ = Km1 (ω_ref − ω)) and the feedforward filter settled (z = ω_ref).
    fn operating_point(&self) -> OperatingState {
        let rest = self.rest();
        let mut state = vec![0.0; self.n];
        state[X] = self.x0;
        state[P1] = rest.p1_pa;
        state[P2] = rest.p2_pa;
        state[W] = rest.omega_rad_per_s;
        let load = self.load_torque(&state);
        let w_ref = self.motor.hold(&mut state, W, load);
        OperatingState {
            state,
            inputs: vec![w_ref],
        }
    }

    /// ω_ref = K_scale Kp (x_ref − x): the article's P law on one motor, no sum-pressure loop.
    fn control_law(&self) -> ControlLaw {
        ControlLaw::position(self.n, X, self.gain)
    }
}

/// The dual-pump circuit as the list of circuits knows it (docs/architecture.md#circuits).
pub struct Module;

impl super::Module for Module {
    const DESCRIPTION: super::Description = super::Description {
        name: "dual-pump",
        fmu_words: "single-motor dual-pump (circuit dual-pump, the article's Figure 1b)",
        controller_words: "with the article's position controller on its one motor",
        drives: 1,
        servo_valves: 0,
        pumps: 2,
        variants: &[super::Variant {
            level: super::PressureLevel::Precharge,
            name: "dual-pump",
            key: "dual_pump",
        }],
        sum_pressure_loop: false,
        level: super::Level::ACCUMULATOR,
        valves: Some("anti-cavitation check valves and relief valves"),
        own_keys: &[
            "pump_inertia_2_kg_mm2",
            "displacement_2_cm3_per_rev",
            "accumulator_precharge_bar",
            "relief_setting_bar",
            "cylinder_rated_pressure_bar",
        ],
        keys: &energy::LOSS_KEYS,
        no_modes: Some(NO_MODES),
    };
    type Linear = DualPump;
    type Emulated = DualPump;

    fn linear(rig: &Rig) -> DualPump {
        DualPump::new(rig).expect("Rig::validate refuses a dual-pump rig with no rest")
    }

    fn emulated(rig: &Rig, effects: Effects) -> Result<DualPump, String> {
        DualPump::emulated(rig, effects).map_err(|e| e.to_string())
    }

    fn validate_rest(rig: &Rig) -> Result<(), (&'static str, f64, String)> {
        rig.validate_dual_pump_rest()
    }

    /// The accumulator's pre-charge (docs/circuits.md).
    fn pressure_level_bar(rig: &Rig) -> f64 {
        rig.accumulator_precharge_bar
    }

    fn one_motor_rest(rig: &Rig) -> Result<super::OneMotorRest, String> {
        let c = DualPump::new(rig).map_err(|e| e.to_string())?;
        Ok(super::description::one_motor_rest_of(&c, |p| {
            c.load_torque_nm(p)
        }))
    }

    /// Both pumps: they share the one motor.
    fn relief_displacement_m3_per_rad(rig: &Rig) -> f64 {
        let d = rig.si().d;
        d[0] + d[1]
    }

    /// From its anti-cavitation check valves' cracking below the accumulator
    /// ([`super::valves::Valve::ANTI_CAVITATION`]) to its relief valves' setting above it.
    fn pressure_band_bar(rig: &Rig) -> [(f64, &'static str); 2] {
        let p_acc = rig.accumulator_precharge_bar;
        super::valves::band_up_to_relief(
            rig,
            p_acc - super::valves::Valve::ANTI_CAVITATION.crack_pa / PA_PER_BAR,
            "its anti-cavitation check valve's cracking",
        )
    }
}

impl super::LinearForm for DualPump {
    fn law(&self, _sum_pressure: bool) -> ControlLaw {
        self.control_law()
    }
    fn load_torques_nm(&self, p_pa: [f64; 2]) -> [f64; 2] {
        [self.load_torque_nm(p_pa), 0.0]
    }
    fn describe(&self) -> String {
        <Module as super::Module>::DESCRIPTION.name.to_string()
    }
    fn standstill_leakage(
        &self,
        rig: &Rig,
        s: &super::dpm::Standstill,
        c12: f64,
    ) -> Option<Result<super::dpm::Leakage, String>> {
        Some(DualPump::standstill_leakage(self, rig, s, c12))
    }
    fn standstill_valves_shut(&self, p_pa: [f64; 2]) -> Result<(), String> {
        self.valves_shut_at(p_pa)
    }
    fn valve_open_at_rest(&self) -> Option<(usize, f64, f64, f64)> {
        DualPump::valve_open_at_rest(self)
    }
}

impl super::EmulatedForm for DualPump {
    emulated_form_calls!(DualPump, n_states, one_motor);
    fn power(&self, s: &[f64], u: &[f64]) -> Power {
        self.power_at(s, u)
    }
}

impl DualPump {
    /// Where the power goes at state `s` under command `u` (docs/energy.md): the drive's shaft
    /// power, the pumps' slip and dead band, the leakages to the accumulator line and across
    /// the piston, the check and relief valves, the accumulator, the cylinder.
    fn power_at(&self, s: &[f64], u: &[f64]) -> Power {
        let mut dx = vec![0.0; s.len()];
        self.rhs(s, u, &mut dx);
        let mut power = Power::default();
        let (p1, p2, w, pa) = (s[P1], s[P2], s[W], self.balance.p_acc_pa);
        energy::cylinder(&self.piston, [s[X], s[V], p1, p2], self.chamber_flows(s), dx[V], &mut power);
        energy::pump(&self.pumps[0], w, p1 - p2, self.coupling, &mut power);
        let q2 = energy::pump(&self.pumps[1], w, p1 - pa, self.coupling, &mut power);
        // what flows into the accumulator line: the leakages, less what pump 2 and the valves
        // take from it
        let leaks = energy::leaks_to_accumulator(self.leakage, [p1, p2], pa, &mut power);
        let mut into_acc = leaks - q2;
        if self.valves_on {
            for (i, p) in [p1, p2].into_iter().enumerate() {
                let q = self.valves.into_chamber(i, p, pa);
                power.loss("valves", energy::throttled(q, pa, p));
                into_acc -= q;
            }
        }
        power.store("accumulator", pa * into_acc);
        let load = self.load_torque(s);
        energy::motor(&self.electrics, &self.motor, (s, &dx, W), load, &mut power);
        power
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::circuit::linearise;

    fn dual_rig(sets: &[&str]) -> Rig {
        let mut all = vec!["circuit=dual-pump".to_string()];
        all.extend(sets.iter().map(|s| s.to_string()));
        Rig::default().with_overrides(&all).unwrap()
    }

    /// The operating point is a steady state of the equations, ideal and emulated with every
    /// effect on: ẋ = 0 to rounding.
    #[test]
    fn the_operating_point_is_at_rest() {
        for sets in [
            &[][..],
            &["feedforward=false"],
            &["motor_model=first_order"],
            &["external_force_n=3000", "motor_coupling=false"],
        ] {
            let rig = dual_rig(sets);
            let ideal = DualPump::new(&rig).unwrap();
            // a load that keeps the valves shut at rest (docs/circuits.md#valves)
            let si = rig.si();
            let balanced = Rig {
                external_force_n: rig.accumulator_precharge_bar * 1e5 * (si.a1 - si.a2),
                ..rig.clone()
            };
            let emulated = DualPump::emulated(&balanced, Effects::all(0.02)).unwrap();
            for c in [ideal, emulated] {
                let op = c.operating_point();
                let mut dx = vec![0.0; c.n_states()];
                c.rhs(&op.state, &op.inputs, &mut dx);
                let scale = [1e-3, 1e-3, 1e5, 1e5, 10.0, 1e-2, 10.0];
                for (i, d) in dx.iter().enumerate() {
                    assert!(d.abs() < 1e-6 * scale[i], "{sets:?}: state {i} rate {d}");
                }
                assert_eq!(c.states().len(), op.state.len());
            }
        }
    }

    /// The closed form solves the 3 × 3 force and flow balance it comes from.
    #[test]
    fn steady_motion_solves_the_flow_and_force_balance() {
        let rig = dual_rig(&["displacement_2_cm3_per_rev=3.2", "external_force_n=-300"]);
        let (c, si) = (DualPump::new(&rig).unwrap(), rig.si());
        let p_acc = rig.accumulator_precharge_bar * 1e5;
        for v in [0.0, 0.02, -0.05] {
            let s = c.steady_motion(v);
            let (q1, q2) = (s.p1_pa - p_acc, s.p2_pa - p_acc);
            let w = s.omega_rad_per_s;
            let ch1 = (si.d[0] + si.d[1]) * w - si.a1 * v - si.c1 * q1 - si.c12 * (q1 - q2);
            let ch2 = -si.d[0] * w + si.a2 * v - si.c2 * q2 + si.c12 * (q1 - q2);
            let force = s.p1_pa * si.a1 - s.p2_pa * si.a2 - si.f_ext - si.b * v;
            assert!(ch1.abs() < 1e-18 && ch2.abs() < 1e-18, "{ch1} {ch2}");
            assert!(force.abs() < 1e-9, "{force}");
        }
    }

    /// The linear model has the hand-derived entries where the equations are linear.
    #[test]
    fn linearisation_has_the_hand_entries() {
        let rig = dual_rig(&[]);
        let (c, si) = (DualPump::new(&rig).unwrap(), rig.si());
        let op = c.operating_point();
        let (a, b) = linearise(&c, &op.state, &op.inputs);
        let k1 = si.beta / si.v1;
        let j = si.j[0] + rig.pump_inertia_2_kg_mm2 * 1e-6;
        assert!((a[(P1, W)] / (k1 * (si.d[0] + si.d[1])) - 1.0).abs() < 1e-12);
        assert!((a[(W, P1)] * j / -(si.d[0] + si.d[1]) - 1.0).abs() < 1e-12);
        // the volumes are those at x0: no position term
        assert_eq!((a[(P1, X)], a[(P2, X)]), (0.0, 0.0));
        let kf = si.kff / si.tau_ff;
        assert!((b[(TAU, 0)] / (si.omega_i * (si.km[0] + kf)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn no_leakage_leaves_the_rest_undetermined() {
        let rig = Rig::default()
            .with_overrides(&[
                "c1_m5_per_ns=0".into(),
                "c2_m5_per_ns=0".into(),
                "c12_m5_per_ns=0".into(),
            ])
            .unwrap();
        let rig = Rig {
            circuit: CircuitKind::DualPump,
            ..rig
        };
        assert_eq!(DualPump::new(&rig).unwrap_err(), Undetermined);
    }
}
