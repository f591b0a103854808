//! The single-pump circuit of the article's Figure 1a (docs/circuits.md#single-pump): one servo
//! motor and its drive turn one pump D1 between the chambers (positive speed moves oil from
//! chamber 2 into chamber 1), and two pilot-operated check valves connect the chambers to the
//! low-pressure accumulator at p_acc: the valve on chamber i feeds it when it falls below the
//! accumulator, and the other chamber's pressure holds it open in both directions
//! ([`PilotCheck`]). The piston's area difference goes to or comes from the accumulator through
//! the open valve. The article (§2.1) names this circuit's "non-linear switching dynamics under
//! low-force conditions" as the reason its rig was not built so: [`modes`] gives the two modes
//! the valves switch between, the force at which they switch, and the closed-loop check whether
//! a step makes them switch.
//!
//! States (SI): `x` (m), `v` (m/s), `p1`, `p2` (Pa gauge), `w` (rad/s), then with the full motor
//! model `tau` (N·m) and, with feedforward on, `z` (rad/s); the input is the drive's speed
//! command `w_ref` (rad/s). Equations (docs/circuits.md#single-pump-equations):
//!
//! - m v̇ = p1 A1 − p2 A2 − F_ext − b v
//! - V1/β ṗ1 = D1 ω − A1 v − c1 (p1 − p_acc) − c12 (p1 − p2) + Q_v1(p1, p2)
//! - V2/β ṗ2 = −D1 ω + A2 v − c2 (p2 − p_acc) + c12 (p1 − p2) + Q_v2(p2, p1)
//! - J ω̇ = τ − D1 (p1 − p2),  J = Jm1 + Jp1
//! - τ̇ = ωI (Km1 (ω_ref − ω) + (Kff/τff)(ω_ref − z) − τ),  τff ż = ω_ref − z
//!
//! with Q_vi the pilot-operated check valve's flow into chamber i, piloted by the other chamber,
//! and the control law ω_ref = K_scale Kp (x_ref − x). [`SinglePump::new`] is these equations
//! over the circuit's parts with every effect off; [`SinglePump::emulated`] adds the parts'
//! effects, the end stops and the relief valves. Its linear models are those of its two modes
//! ([`modes::Mode`]), not of these equations: at rest one valve is open, where its flow law is
//! steep and one-sided.
//!
//! ```
//! use pumpcyl::circuit::single_pump::{modes::{switching, Mode}, SinglePump};
//! use pumpcyl::circuit::{linearise, Circuit};
//! use pumpcyl::rig::Rig;
//!
//! let rig = Rig::default().with_overrides(&["circuit=single-pump".into()])?;
//! // no load: below the switching force p_acc (A1 − A2), chamber 1 sits at the accumulator
//! let s = switching(&rig);
//! assert_eq!(s.mode_at_rest, 2);
//! assert!((s.switching_force_n - 6.91e5 * std::f64::consts::PI / 4.0 * 0.036f64.powi(2)).abs() < 1e-9);
//! let mode = Mode::new(&rig, 2);
//! let op = mode.operating_point();
//! let (a, b) = linearise(&mode, &op.state, &op.inputs);
//! assert_eq!((a.nrows(), b.ncols()), (6, 1)); // x, v, p2, w, tau, z
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod modes;

/// The single-pump circuit's pilot ratio: 3:1, the smallest of Sun Hydraulics' pilot-to-open
/// check cartridges (its series 0; series 1, 3 and 4 are 4:1), as Sun's "Frequently asked
/// questions: pilot-to-open check cartridge valves" (2001) gives them (docs/circuits.md#the-pilot-operated-check-valves).
pub const PILOT_RATIO: f64 = 3.0;

/// The single-pump circuit's check-valve cracking pressure (bar): the anti-cavitation check
/// valve's 0.5 bar, a light spring of a size-10 check valve **\[choice\]**: the same poppet and
/// spring, piloted (docs/circuits.md#valves).
pub const CHECK_VALVE_CRACK_BAR: f64 = 0.5;

use super::parts::{
    cylinder_of_rig, cylinder_rates, one_motor_inputs, one_motor_states, Chamber, Effects, Fluid,
    Motor, Piston, Pump,
};
use super::energy::{self, Power};
use super::stops::Stops;
use super::valves::{PilotCheck, Valve};
use super::{Circuit, CircuitKind, ControlLaw, OperatingState, Scalar, Signal};
use crate::rig::Rig;
use crate::units::PA_PER_BAR;

/// State positions: position, velocity, the chamber pressures, the shaft speed, then the
/// motor's torque and feedforward filter (full motor model only).
const X: usize = 0;
const V: usize = 1;
const P1: usize = 2;
const W: usize = 4;

/// The single-pump circuit of a rig (the article's Figure 1a).
#[derive(Debug, Clone, PartialEq)]
pub struct SinglePump {
    piston: Piston,
    chambers: [Chamber; 2],
    fluid: Fluid,
    pump: Pump,
    motor: Motor,
    /// The drive's electrical side (docs/energy.md#the-drives).
    electrics: energy::Electrics,
    /// Leakages c1, c2 (to the accumulator line) and c12 (across) (m⁵/(N·s)).
    leakage: [f64; 3],
    /// The pump's pressure load acts on the shaft.
    coupling: bool,
    /// The pilot-operated check valves into chamber 1 (piloted by p2) and chamber 2 (by p1).
    checks: [PilotCheck; 2],
    /// The relief valves chamber → accumulator (the emulated circuit only).
    relief: Option<Valve>,
    /// The check valves are part of the equations; off, a mode pins a chamber at p_acc instead.
    valves_on: bool,
    /// Accumulator pressure p_acc (Pa gauge).
    p_acc: f64,
    /// Position gain times command scale, K_scale Kp (rad/s per m).
    gain: f64,
    /// Operating-point position x0 (m).
    x0: f64,
    /// Number of states.
    n: usize,
}

/// How the circuit is assembled: with or without the parts' effects, stops and relief valves.
struct Build {
    effects: Effects,
    stops: Option<Stops>,
    emulated: bool,
}

impl SinglePump {
    /// The circuit's own equations: both chambers compressible, the pilot-operated check valves
    /// in, every effect off, no end stops and no relief valves; the rig's variant switches
    /// (motor model, feedforward, motor coupling) as set.
    pub fn new(rig: &Rig) -> SinglePump {
        SinglePump::build(
            rig,
            Build {
                effects: Effects::none(),
                stops: None,
                emulated: false,
            },
        )
    }

    /// The circuit the emulator integrates: the chosen effects, the end stops, the
    /// pilot-operated check valves and the relief valves, the pump's load always on the shaft.
    pub fn emulated(rig: &Rig, effects: Effects) -> SinglePump {
        SinglePump::build(
            rig,
            Build {
                effects,
                stops: Some(Stops::new(rig.stroke_mm * 1e-3, rig.mass_kg)),
                emulated: true,
            },
        )
    }

    fn build(rig: &Rig, b: Build) -> SinglePump {
        let si = rig.si();
        let (piston, chambers) = cylinder_of_rig(rig, &b.effects, b.stops);
        let motor = Motor::of_rig(rig, si.j[0], &b.effects);
        let check = PilotCheck {
            valve: Valve {
                crack_pa: rig.circuit_key("check_valve_crack_bar") * PA_PER_BAR,
                ..Valve::ANTI_CAVITATION
            },
            pilot_ratio: rig.circuit_key("pilot_ratio"),
        };
        SinglePump {
            piston,
            chambers,
            fluid: Fluid::of(si.beta, &b.effects),
            pump: Pump::of(si.d[0], &b.effects),
            leakage: [si.c1, si.c2, si.c12],
            coupling: b.emulated || rig.motor_coupling,
            checks: [check; 2],
            relief: b
                .emulated
                .then(|| Valve::relief(rig.relief_setting_pa(CircuitKind::SinglePump))),
            valves_on: true,
            p_acc: rig.accumulator_precharge_bar * PA_PER_BAR,
            gain: si.k_scale * si.kp,
            x0: si.x0,
            n: 4 + motor.n_states(),
            motor,
            electrics: energy::Electrics::of(rig),
        }
    }

    /// Number of states: 7 (full motor model with feedforward), 6 (without), 5 (first order).
    pub fn n_states(&self) -> usize {
        self.n
    }

    /// The accumulator pressure p_acc (Pa gauge).
    pub fn accumulator_pa(&self) -> f64 {
        self.p_acc
    }

    /// The pilot-operated check valves into chamber 1 and chamber 2.
    pub fn checks(&self) -> [PilotCheck; 2] {
        self.checks
    }

    /// The piston and annulus areas A1, A2 (m²).
    pub fn areas_m2(&self) -> [f64; 2] {
        self.piston.areas_m2
    }

    /// The external force against extension (N).
    pub fn external_force_n(&self) -> f64 {
        self.piston.force_ext_n
    }

    cylinder_calls!(SinglePump, motor);

    /// The position loop's gain K_scale Kp (rad/s per m): ω_ref = K_scale Kp (x_ref − x).
    pub fn position_gain(&self) -> f64 {
        self.gain
    }

    /// The chamber (1 or 2) at the accumulator at rest under the external force: 2 (mode 1)
    /// from the switching force p_acc (A1 − A2) up, 1 (mode 2) below it.
    pub fn accumulator_chamber_at_rest(&self) -> usize {
        let [a1, a2] = self.piston.areas_m2;
        if self.piston.force_ext_n >= self.p_acc * (a1 - a2) {
            2
        } else {
            1
        }
    }

    /// The opening signals (Pa) of the check valves into chamber 1 and chamber 2 at the state
    /// `s` ([`PilotCheck::signal`]): a valve passes flow while its signal is above its cracking
    /// pressure.
    pub fn valve_signals_pa(&self, s: &[f64]) -> [f64; 2] {
        let (p1, p2) = (s[P1], s[P1 + 1]);
        [
            self.checks[0].signal(p1, p2, self.p_acc),
            self.checks[1].signal(p2, p1, self.p_acc),
        ]
    }

    /// The net flows into chambers 1 and 2 that compress their oil (m³/s): the pump, the
    /// piston, the leakage and the valves.
    fn chamber_flows<T: Scalar>(&self, s: &[T]) -> [T; 2] {
        let (v, p1, p2, w) = (s[V], s[P1], s[P1 + 1], s[W]);
        let p_acc = self.p_acc;
        let [a1, a2] = self.piston.areas_m2;
        let [c1, c2, c12] = self.leakage;
        // the pump from chamber 2 into chamber 1
        let q = self.pump.flow(w, p1 - p2);
        let cross = (p1 - p2) * c12;
        let mut flows = [
            q - v * a1 - (p1 - p_acc) * c1 - cross,
            -q + v * a2 - (p2 - p_acc) * c2 + cross,
        ];
        if self.valves_on {
            flows[0] += self.checks[0].into_chamber(p1, p2, p_acc);
            flows[1] += self.checks[1].into_chamber(p2, p1, p_acc);
        }
        if let Some(relief) = self.relief {
            flows[0] -= relief.flow(p1 - p_acc);
            flows[1] -= relief.flow(p2 - p_acc);
        }
        flows
    }

    /// The pump's load torque on the motor (N·m) at chamber pressures `p_pa` (Pa gauge),
    /// D1 (p1 − p2): what the drive's rating is checked against.
    pub fn load_torque_nm(&self, [p1, p2]: [f64; 2]) -> f64 {
        (p1 - p2) * self.pump.displacement_m3
    }

    /// The pump's load torque D1 (p1 − p2) (N·m); zero without the motor–hydraulics coupling.
    fn load_torque<T: Scalar>(&self, s: &[T]) -> T {
        if !self.coupling {
            return T::from(0.0);
        }
        let dp = s[P1] - s[P1 + 1];
        dp * self.pump.displacement_m3 + self.pump.friction_torque(s[W], dp)
    }

    /// The rest at x0 with chamber `acc` (0 or 1) at the accumulator pressure: the other
    /// chamber's pressure from the force balance, the shaft speed that feeds its leakage, and
    /// the motor holding the pump's load ([`Motor::hold`]). It is a steady state of the mode that
    /// pins chamber `acc` ([`modes::Mode`]); of the full equations to the open valve's pressure
    /// drop under the leakage it passes.
    fn rest_in(&self, acc: usize) -> OperatingState {
        let [a1, a2] = self.piston.areas_m2;
        let f = self.piston.force_ext_n;
        let mut state = vec![0.0; self.n];
        state[X] = self.x0;
        state[P1 + acc] = self.p_acc;
        state[P1 + 1 - acc] = match acc {
            // p1 A1 − p_acc A2 = F_ext
            1 => (f + self.p_acc * a2) / a1,
            // p_acc A1 − p2 A2 = F_ext
            _ => (self.p_acc * a1 - f) / a2,
        };
        // the other chamber's balance: its flow at standstill, less the pump's ±D1 ω
        let other = 1 - acc;
        let still = self.without_check_valves().chamber_flows(&state)[other];
        let pump_sign = if other == 0 { 1.0 } else { -1.0 };
        state[W] = -still / (pump_sign * self.pump.displacement_m3);
        let load = self.load_torque(&state);
        let w_ref = self.motor.hold(&mut state, W, load);
        OperatingState {
            state,
            inputs: vec![w_ref],
        }
    }

    /// This circuit with the check valves out of its equations, which a mode completes by
    /// holding one chamber at the accumulator pressure ([`modes::Mode`]).
    fn without_check_valves(&self) -> SinglePump {
        SinglePump {
            valves_on: false,
            ..self.clone()
        }
    }
}

impl Circuit for SinglePump {
    fn kind(&self) -> CircuitKind {
        CircuitKind::SinglePump
    }

    fn states(&self) -> Vec<Signal> {
        one_motor_states("shaft speed (motor and pump)", self.n)
    }

    fn inputs(&self) -> Vec<Signal> {
        one_motor_inputs()
    }

    fn rhs<T: Scalar>(&self, s: &[T], u: &[T], dx: &mut [T]) {
        let cylinder = (&self.piston, &self.chambers, &self.fluid);
        cylinder_rates(cylinder, [X, V, P1, P1 + 1], s, self.chamber_flows(s), dx);
        (self.motor).write_rates(u[0], s, self.load_torque(s), dx, W);
    }

    /// The regime of the one motor ([`Motor::regime`]).
    fn drive_regime(&self, s: &[f64], u: &[f64]) -> Option<u64> {
        Some(self.motor.regime(u[0], s, self.load_torque(s), W))
    }

    /// At rest at x0 in the mode of the external force ([`modes::switching`]): the open
    /// chamber at p_acc, the other from the force balance (docs/circuits.md#its-two-modes).
    fn operating_point(&self) -> OperatingState {
        self.rest_in(self.accumulator_chamber_at_rest() - 1)
    }

    /// ω_ref = K_scale Kp (x_ref − x): the article's P law on the one motor.
    fn control_law(&self) -> ControlLaw {
        ControlLaw::position(self.n, X, self.gain)
    }
}

/// The single-pump circuit as the list of circuits knows it (docs/architecture.md#circuits):
/// its linear models are its two modes ([`modes::Mode`]), its emulated form [`SinglePump`].
pub struct Module;

impl super::Module for Module {
    const DESCRIPTION: super::Description = super::Description {
        name: "single-pump",
        fmu_words: "single-pump (circuit single-pump, the article's Figure 1a)",
        controller_words: "with the article's position controller on its one motor",
        drives: 1,
        servo_valves: 0,
        pumps: 1,
        variants: &[super::Variant {
            level: super::PressureLevel::Precharge,
            name: "single-pump",
            key: "single_pump",
        }],
        sum_pressure_loop: false,
        level: super::Level::ACCUMULATOR,
        valves: Some("pilot-operated check valves and relief valves"),
        own_keys: &[
            "accumulator_precharge_bar",
            "relief_setting_bar",
            "cylinder_rated_pressure_bar",
        ],
        keys: &super::description::joined::<8>(&energy::LOSS_KEYS, &[
            super::Key {
                name: "pilot_ratio",
                doc: "pilot ratio k of the single-pump circuit's pilot-operated check valves (pilot over seat area)",
                default: PILOT_RATIO,
                range: crate::rig::Range::Positive(0.01, 1000.0),
            },
            super::Key {
                name: "check_valve_crack_bar",
                doc: "bar, cracking pressure of the single-pump circuit's pilot-operated check valves",
                default: CHECK_VALVE_CRACK_BAR,
                range: crate::rig::Range::Positive(0.001, 1000.0),
            },
        ]),
        no_modes: None,
    };
    type Linear = modes::Mode;
    type Emulated = SinglePump;

    /// The mode its rest is in (docs/circuits.md#its-two-modes).
    fn linear(rig: &Rig) -> modes::Mode {
        modes::Mode::new(rig, 3 - modes::switching(rig).mode_at_rest)
    }

    /// The mode at rest, then the other (docs/circuits.md#its-two-modes).
    fn linear_modes(rig: &Rig) -> Vec<modes::Mode> {
        let rest = modes::switching(rig).mode_at_rest;
        [3 - rest, rest]
            .map(|chamber| modes::Mode::new(rig, chamber))
            .to_vec()
    }

    fn emulated(rig: &Rig, effects: Effects) -> Result<SinglePump, String> {
        Ok(SinglePump::emulated(rig, effects))
    }

    /// The full circuit's rest, with the valve of the mode at rest open.
    fn one_motor_rest(rig: &Rig) -> Result<super::OneMotorRest, String> {
        let c = SinglePump::new(rig);
        Ok(super::description::one_motor_rest_of(&c, |p| {
            c.load_torque_nm(p)
        }))
    }

    fn mode_switching(rig: &Rig) -> Result<modes::Switching, &'static str> {
        Ok(modes::switching(rig))
    }

    /// The accumulator's pre-charge (docs/circuits.md).
    fn pressure_level_bar(rig: &Rig) -> f64 {
        rig.accumulator_precharge_bar
    }

    /// Its compressible chamber (the other one is held at the accumulator): from where its
    /// pilot lets the open check valve shut ([`PilotCheck::shut_below_pa`], the mode
    /// switches) to the relief valves' setting.
    fn pressure_band_bar(rig: &Rig) -> [(f64, &'static str); 2] {
        super::valves::band_up_to_relief(
            rig,
            rig.accumulator_precharge_bar
                + rig.circuit_key("check_valve_crack_bar") / rig.circuit_key("pilot_ratio"),
            "the pressure below which it lets the open pilot-operated check valve shut (the mode switches)",
        )
    }
}

impl super::LinearForm for modes::Mode {
    fn law(&self, _sum_pressure: bool) -> ControlLaw {
        self.control_law()
    }
    fn load_torques_nm(&self, p_pa: [f64; 2]) -> [f64; 2] {
        [self.load_torque_nm(p_pa), 0.0]
    }
    /// `single-pump, mode M (chamber K at the accumulator pressure), the mode at rest` (`the
    /// other mode` for the mode the rig does not rest in).
    fn describe(&self) -> String {
        format!(
            "single-pump, mode {} (chamber {} at the accumulator pressure), {}",
            self.number(),
            self.accumulator_chamber(),
            if self.at_rest() {
                "the mode at rest"
            } else {
                "the other mode"
            }
        )
    }
    fn mode(&self) -> Option<usize> {
        Some(self.number())
    }
}

impl super::EmulatedForm for SinglePump {
    emulated_form_calls!(SinglePump, n_states, one_motor);
    fn mode_at(&self, s: &[f64]) -> Option<usize> {
        Some(modes::recorded_mode(self, s))
    }
    fn power(&self, s: &[f64], u: &[f64]) -> Power {
        self.power_at(s, u)
    }
}

impl SinglePump {
    /// Where the power goes at state `s` under command `u` (docs/energy.md): the drive's shaft
    /// power, the pump's slip and dead band, the leakages to the accumulator line and across
    /// the piston, the pilot-operated check valves and the relief valves, the accumulator, the
    /// cylinder.
    fn power_at(&self, s: &[f64], u: &[f64]) -> Power {
        let mut dx = vec![0.0; s.len()];
        self.rhs(s, u, &mut dx);
        let mut power = Power::default();
        let (p1, p2, w, pa) = (s[P1], s[P1 + 1], s[W], self.p_acc);
        let flows = self.chamber_flows(s);
        energy::cylinder(&self.piston, [s[X], s[V], p1, p2], flows, dx[V], &mut power);
        energy::pump(&self.pump, w, p1 - p2, self.coupling, &mut power);
        let mut into_acc = energy::leaks_to_accumulator(self.leakage, [p1, p2], pa, &mut power);
        if self.valves_on {
            for (check, (p, pilot)) in self.checks.iter().zip([(p1, p2), (p2, p1)]) {
                let q = check.into_chamber(p, pilot, pa);
                power.loss("valves", energy::throttled(q, pa, p));
                into_acc -= q;
            }
        }
        if let Some(relief) = self.relief {
            for p in [p1, p2] {
                let q = relief.flow(p - pa);
                power.loss("valves", energy::throttled(q, p, pa));
                into_acc += q;
            }
        }
        power.store("accumulator", pa * into_acc);
        let load = self.load_torque(s);
        energy::motor(&self.electrics, &self.motor, (s, &dx, W), load, &mut power);
        power
    }
}

impl super::AnyCircuit {
    /// The single-pump circuit's mode this linear model is, for what only it has; `None` for
    /// another circuit's model.
    pub fn single_pump_mode(&self) -> Option<&modes::Mode> {
        if let super::AnyCircuit::SinglePump(mode) = self {
            return Some(mode);
        }
        None
    }
}

impl super::Emulated {
    /// The single-pump circuit inside, for what only it has (its modes and valves); `None` for
    /// another circuit.
    pub fn single_pump(&self) -> Option<&SinglePump> {
        if let super::Emulated::SinglePump(c) = self {
            return Some(c);
        }
        None
    }
}
