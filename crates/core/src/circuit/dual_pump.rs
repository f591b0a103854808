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
//! - V1(x)/β ṗ1 = (D1 + D2) ω − A1 v − c1 (p1 − p_acc) − c12 (p1 − p2),  V1 = VL1 + A1 x
//! - V2(x)/β ṗ2 = −D1 ω + A2 v − c2 (p2 − p_acc) + c12 (p1 − p2),  V2 = VL2 + A2 (x_max − x)
//! - J ω̇ = τ − D1 (p1 − p2) − D2 (p1 − p_acc),  J = Jm1 + Jp1 + Jp2
//! - τ̇ = ωI (Km1 (ω_ref − ω) + (Kff/τff)(ω_ref − z) − τ),  τff ż = ω_ref − z
//!
//! and the control law ω_ref = K_scale Kp (x_ref − x).
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

use super::valves::Valves;
use super::{Circuit, CircuitKind, ControlLaw, OperatingState, Role, Scalar, Signal};
use crate::bulk;
use crate::rig::{MotorModel, Rig, RigSi};
use crate::units::PA_PER_BAR;
use nalgebra::DMatrix;

/// State positions: position, velocity, the chamber pressures, the shaft speed, the torque and
/// the feedforward filter (the last two with the full motor model only).
const X: usize = 0;
const V: usize = 1;
const P1: usize = 2;
const P2: usize = 3;
const W: usize = 4;
const TAU: usize = 5;
const Z: usize = 6;

/// A rig whose leakage leaves the dual-pump circuit's pressures at rest undetermined.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the leakages c1, c2, c12 leave the dual-pump circuit's pressures at rest undetermined \
     (its steady flow balance is singular; docs/circuits.md#operating-point)"
)]
pub struct Undetermined;

/// The single-motor dual-pump circuit of a rig (the article's Figure 1b).
#[derive(Debug, Clone)]
pub struct DualPump {
    si: RigSi,
    /// Accumulator pressure p_acc (Pa gauge).
    p_acc: f64,
    /// Shaft inertia Jm1 + Jp1 + Jp2 (kg·m²).
    j: f64,
    /// Line volumes VL1, VL2 (m³) and stroke (m).
    vl: [f64; 2],
    x_max: f64,
    /// First-order motor time constant (s).
    tau_motor: f64,
    full: bool,
    feedforward: bool,
    coupling: bool,
    /// The gas fraction's anchor: the rig's β (bar).
    beta_bar: f64,
    /// The emulator's valves (docs/circuits.md#valves).
    pub valves: Valves,
}

/// A steady state of the circuit at constant piston speed (SI, gauge pressures).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SteadyMotion {
    /// Piston speed (m/s).
    pub v_m_per_s: f64,
    /// Chamber 1 pressure (Pa gauge).
    pub p1_pa: f64,
    /// Chamber 2 pressure (Pa gauge).
    pub p2_pa: f64,
    /// Shaft speed (rad/s).
    pub omega_rad_per_s: f64,
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
    /// Net flow the valves would pass into chambers 1 and 2 there (m³/s): zero while every
    /// valve is shut, as the linear model assumes.
    pub valve_flow_m3_per_s: [f64; 2],
}

impl DualPump {
    /// The circuit of `rig` (its drive 1, both pumps, its leakage and pre-charge).
    ///
    /// # Errors
    /// [`Undetermined`] when the leakage does not fix the pressures at rest (no leakage at
    /// all, for one).
    pub fn new(rig: &Rig) -> Result<DualPump, Undetermined> {
        let si = rig.si();
        let j = si.j[0] + rig.pump_inertia_2_kg_mm2 * 1e-6;
        let full = rig.motor_model == MotorModel::Full;
        let c = DualPump {
            si,
            p_acc: rig.accumulator_precharge_bar * PA_PER_BAR,
            j,
            vl: [rig.line_volume_1_dm3 * 1e-3, rig.line_volume_2_dm3 * 1e-3],
            x_max: rig.stroke_mm * 1e-3,
            tau_motor: rig.motor_time_constant_s.unwrap_or(j / si.km[0]),
            full,
            feedforward: full && rig.feedforward,
            coupling: rig.motor_coupling,
            beta_bar: rig.beta_bar,
            valves: Valves::new(relief_setting_pa(&si, rig.motor_rated_torque_nm)),
        };
        c.steady_motion(0.0)?;
        Ok(c)
    }

    /// Number of states: 7 (full motor model with feedforward), 6 (without), 5 (first order).
    pub fn n_states(&self) -> usize {
        if !self.full {
            5
        } else if self.feedforward {
            7
        } else {
            6
        }
    }

    /// The flow area (m²) by which pump 2 over-supplies chamber 1 per unit piston speed,
    /// (1 + D2/D1) A2 − A1: zero for a matched circuit, D2/D1 = A1/A2 − 1
    /// (docs/circuits.md#matching).
    pub fn mismatch_m2(&self) -> f64 {
        let si = &self.si;
        (1.0 + si.d[1] / si.d[0]) * si.a2 - si.a1
    }

    /// The steady state at rest ([`DualPump::steady_motion`] at v = 0).
    pub fn rest(&self) -> SteadyMotion {
        self.steady_motion(0.0)
            .expect("checked when the circuit was built")
    }

    /// The steady state at constant piston speed `v` (m/s): the force balance
    /// A1 q1 − A2 q2 = F_ext − p_acc (A1 − A2) + b v with qi = pi − p_acc, and both chambers'
    /// flow balances with leakage, solved in closed form (docs/circuits.md#steady-motion).
    ///
    /// # Errors
    /// [`Undetermined`] when the balance is singular.
    pub fn steady_motion(&self, v: f64) -> Result<SteadyMotion, Undetermined> {
        let si = &self.si;
        let r = si.d[1] / si.d[0];
        // chamber 1 minus (1 + r) × chamber 2 eliminates ω: ka q1 − kb q2 = −m v
        let ka = r * si.c12 - si.c1;
        let kb = r * si.c12 + (1.0 + r) * si.c2;
        let m = self.mismatch_m2();
        let g = si.f_ext - self.p_acc * (si.a1 - si.a2) + si.b * v;
        let det = kb * si.a1 - ka * si.a2;
        let scale = kb.abs() * si.a1 + ka.abs() * si.a2;
        if det.is_nan() || det.abs() <= 1e-9 * scale {
            return Err(Undetermined);
        }
        let q1 = (m * v * si.a2 + kb * g) / det;
        let q2 = (m * v * si.a1 + ka * g) / det;
        let omega = (si.a2 * v - si.c2 * q2 + si.c12 * (q1 - q2)) / si.d[0];
        Ok(SteadyMotion {
            v_m_per_s: v,
            p1_pa: self.p_acc + q1,
            p2_pa: self.p_acc + q2,
            omega_rad_per_s: omega,
        })
    }

    /// [`DualPump::steady_motion`] with its effective bulk modulus: the constant gas-fraction
    /// model (docs/bulk-modulus.md) anchored at the rig's `beta_bar` at the mean pressure at
    /// rest, read at the steady mean pressure; and the flow the valves would pass there.
    ///
    /// # Errors
    /// A mean pressure at rest or in motion not above 0 bar gauge, or a `beta_bar` beyond the
    /// oil's own (the gas-fraction model's range).
    pub fn steady_bulk(&self, v: f64) -> Result<SteadyBulk, bulk::BulkError> {
        let undetermined = |e: Undetermined| bulk::BulkError::Input(e.to_string());
        let mean_bar = |s: &SteadyMotion| 0.5 * (s.p1_pa + s.p2_pa) / PA_PER_BAR;
        let rest = self.steady_motion(0.0).map_err(undetermined)?;
        let x = bulk::gas_fraction(self.beta_bar, mean_bar(&rest), bulk::BETA_OIL_BAR)?;
        let state = self.steady_motion(v).map_err(undetermined)?;
        let p_mean_bar = mean_bar(&state);
        if p_mean_bar.is_nan() || p_mean_bar <= 0.0 {
            return Err(bulk::BulkError::Input(format!(
                "the mean chamber pressure at {v} m/s is {p_mean_bar:.3} bar gauge: the gas-fraction \
                 model needs it above 0 bar"
            )));
        }
        let flow = |i, p| self.valves.into_chamber(i, p, self.p_acc);
        Ok(SteadyBulk {
            state,
            p_mean_bar,
            beta_e_bar: bulk::effective_beta(x, p_mean_bar, bulk::BETA_OIL_BAR),
            valve_flow_m3_per_s: [flow(0, state.p1_pa), flow(1, state.p2_pa)],
        })
    }

    /// The emulator's equations: [`Circuit::rhs`] with the check and relief valves' flows
    /// ([`Valves`], docs/circuits.md#valves) added to the chambers.
    pub fn rhs_with_valves<T: Scalar>(&self, x: &[T], u: &[T], dx: &mut [T]) {
        self.rhs(x, u, dx);
        let [v1, v2] = self.volumes(x[X]);
        for (i, p) in [P1, P2].into_iter().enumerate() {
            let q = self.valves.into_chamber(i, x[p], self.p_acc);
            dx[p] += q * self.si.beta / [v1, v2][i];
        }
    }

    /// The chamber volumes V1 = VL1 + A1 x, V2 = VL2 + A2 (x_max − x) (m³).
    fn volumes<T: Scalar>(&self, x: T) -> [T; 2] {
        let si = &self.si;
        [
            x * si.a1 + self.vl[0],
            (-x + self.x_max) * si.a2 + self.vl[1],
        ]
    }

    /// The net flows into chambers 1 and 2 that compress their oil (m³/s): the pumps, the
    /// piston and the leakage, each sum [`net`] of its terms.
    fn chamber_flows<T: Scalar>(&self, s: &[T]) -> [T; 2] {
        let si = &self.si;
        let (v, p1, p2, w) = (s[V], s[P1], s[P2], s[W]);
        let cross = (p1 - p2) * si.c12;
        [
            net([
                w * (si.d[0] + si.d[1]),
                -v * si.a1,
                -(p1 - self.p_acc) * si.c1,
                -cross,
            ]),
            net([-w * si.d[0], v * si.a2, -(p2 - self.p_acc) * si.c2, cross]),
        ]
    }

    /// The load torque of both pumps on the shaft, D1 (p1 − p2) + D2 (p1 − p_acc) (N·m); zero
    /// without the motor–hydraulics coupling.
    fn load_torque<T: Scalar>(&self, s: &[T]) -> T {
        if !self.coupling {
            return T::from(0.0);
        }
        (s[P1] - s[P2]) * self.si.d[0] + (s[P1] - self.p_acc) * self.si.d[1]
    }

    /// The shaft and its drive into `dx` (docs/model.md#drive-velocity-loops-and-feedforward).
    fn drive<T: Scalar>(&self, s: &[T], w_ref: T, dx: &mut [T]) {
        let si = &self.si;
        if !self.full {
            dx[W] = (w_ref - s[W]) / self.tau_motor;
            return;
        }
        dx[W] = (s[TAU] - self.load_torque(s)) / self.j;
        let mut torque_ref = (w_ref - s[W]) * si.km[0];
        if self.feedforward {
            torque_ref += (w_ref - s[Z]) * (si.kff / si.tau_ff);
            dx[Z] = (w_ref - s[Z]) / si.tau_ff;
        }
        dx[TAU] = (torque_ref - s[TAU]) * si.omega_i;
    }
}

/// The sum of a chamber's flow terms, its value zero where it lies within the rounding of the
/// terms (8 ulp of their magnitudes): at rest the flows cancel exactly, and the rounding left
/// over would otherwise enter the Jacobian through the volume's dependence on the position
/// (∂(β q/V)/∂x = −q β V'/V², zero at rest) as a spurious pole near zero in place of the
/// piston's integrator. The derivatives are kept; the equations' values move by rounding only.
fn net<T: Scalar>(terms: [T; 4]) -> T {
    let scale: f64 = terms.iter().map(|t| t.re().abs()).sum();
    let q = terms.into_iter().fold(T::from(0.0), |a, t| a + t);
    if q.re().abs() <= 8.0 * f64::EPSILON * scale {
        q - q.re()
    } else {
        q
    }
}

/// The relief valves' setting (Pa above the accumulator): the pressure at which the pumps'
/// load torque reaches the motor's rated torque with the other chamber at the accumulator,
/// τ_rated / (D1 + D2) **\[choice\]**: the valve protects the motor (docs/circuits.md#valves).
fn relief_setting_pa(si: &RigSi, rated_torque_nm: f64) -> f64 {
    rated_torque_nm / (si.d[0] + si.d[1])
}

impl Circuit for DualPump {
    fn kind(&self) -> CircuitKind {
        CircuitKind::DualPump
    }

    fn states(&self) -> Vec<Signal> {
        let all = [
            Signal::new("x", "m", "piston position", Role::Position),
            Signal::new("v", "m/s", "piston velocity", Role::Velocity),
            Signal::new(
                "p1",
                "Pa",
                "chamber 1 (piston side) pressure, gauge",
                Role::Pressure,
            ),
            Signal::new(
                "p2",
                "Pa",
                "chamber 2 (rod side) pressure, gauge",
                Role::Pressure,
            ),
            Signal::new(
                "w",
                "rad/s",
                "shaft speed (motor and both pumps)",
                Role::MotorSpeed,
            ),
            Signal::new("tau", "N*m", "motor electromagnetic torque", Role::Torque),
            Signal::new(
                "z",
                "rad/s",
                "drive feedforward filter state",
                Role::Feedforward,
            ),
        ];
        all.into_iter().take(self.n_states()).collect()
    }

    fn inputs(&self) -> Vec<Signal> {
        vec![Signal::new(
            "w_ref",
            "rad/s",
            "drive speed command",
            Role::SpeedCommand,
        )]
    }

    fn rhs<T: Scalar>(&self, s: &[T], u: &[T], dx: &mut [T]) {
        let si = &self.si;
        dx[X] = s[V];
        dx[V] = (s[P1] * si.a1 - s[P2] * si.a2 - s[V] * si.b - si.f_ext) / si.mass;
        let q = self.chamber_flows(s);
        let vol = self.volumes(s[X]);
        dx[P1] = q[0] * si.beta / vol[0];
        dx[P2] = q[1] * si.beta / vol[1];
        self.drive(s, u[0], dx);
    }

    /// At rest at x0: the pressures and shaft speed of [`DualPump::rest`]; with the full motor
    /// model the torque that carries the pumps' load, the command that holds it through the P
    /// loop (τ = Km1 (ω_ref − ω)) and the feedforward filter settled (z = ω_ref).
    fn operating_point(&self) -> OperatingState {
        let rest = self.rest();
        let mut state = vec![0.0; self.n_states()];
        state[X] = self.si.x0;
        state[P1] = rest.p1_pa;
        state[P2] = rest.p2_pa;
        state[W] = rest.omega_rad_per_s;
        let mut w_ref = rest.omega_rad_per_s;
        if self.full {
            state[TAU] = self.load_torque(&state);
            w_ref += state[TAU] / self.si.km[0];
            if self.feedforward {
                state[Z] = w_ref;
            }
        }
        OperatingState {
            state,
            inputs: vec![w_ref],
        }
    }

    /// ω_ref = K_scale Kp (x_ref − x): the article's P law on one motor, no sum-pressure loop.
    fn control_law(&self) -> ControlLaw {
        let k = self.si.k_scale * self.si.kp;
        let mut kx = DMatrix::zeros(1, self.n_states());
        kx[(0, X)] = -k;
        ControlLaw {
            kx,
            kr: DMatrix::from_element(1, 1, k),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::circuit::linearise;

    fn dual(sets: &[&str]) -> DualPump {
        let mut all = vec!["circuit=dual-pump".to_string()];
        all.extend(sets.iter().map(|s| s.to_string()));
        DualPump::new(&Rig::default().with_overrides(&all).unwrap()).unwrap()
    }

    /// The operating point is a steady state of the equations: ẋ = 0 to rounding.
    #[test]
    fn the_operating_point_is_at_rest() {
        for sets in [
            &[][..],
            &["feedforward=false"],
            &["motor_model=first_order"],
            &["external_force_n=3000", "motor_coupling=false"],
        ] {
            let c = dual(sets);
            let op = c.operating_point();
            let mut dx = vec![0.0; c.n_states()];
            c.rhs(&op.state, &op.inputs, &mut dx);
            let scale = [1e-3, 1e-3, 1e5, 1e5, 10.0, 1e-2, 10.0];
            for (i, d) in dx.iter().enumerate() {
                assert!(
                    d.abs() < 1e-9 * scale[i] * 1e3,
                    "{sets:?}: state {i} rate {d}"
                );
            }
            assert_eq!(c.states().len(), op.state.len());
        }
    }

    /// The steady flow balance by hand at the article's values with D2 matched: chamber 2 is
    /// fed by the leakage only; with v = 0 the rest is the 3 × 3 balance solved directly.
    #[test]
    fn steady_motion_solves_the_flow_and_force_balance() {
        let c = dual(&["displacement_2_cm3_per_rev=3.2"]);
        let si = c.si;
        for v in [0.0, 0.02, -0.05] {
            let s = c.steady_motion(v).unwrap();
            let (q1, q2) = (s.p1_pa - c.p_acc, s.p2_pa - c.p_acc);
            let w = s.omega_rad_per_s;
            let ch1 = (si.d[0] + si.d[1]) * w - si.a1 * v - si.c1 * q1 - si.c12 * (q1 - q2);
            let ch2 = -si.d[0] * w + si.a2 * v - si.c2 * q2 + si.c12 * (q1 - q2);
            let force = s.p1_pa * si.a1 - s.p2_pa * si.a2 - si.f_ext - si.b * v;
            assert!(ch1.abs() < 1e-18 && ch2.abs() < 1e-18, "{ch1} {ch2}");
            assert!(force.abs() < 1e-9, "{force}");
        }
    }

    /// The linear model has the expected entries where the equations are linear.
    #[test]
    fn linearisation_has_the_hand_entries() {
        let c = dual(&[]);
        let op = c.operating_point();
        let (a, b) = linearise(&c, &op.state, &op.inputs);
        let si = c.si;
        let k1 = si.beta / si.v1;
        assert!((a[(P1, W)] / (k1 * (si.d[0] + si.d[1])) - 1.0).abs() < 1e-12);
        assert!((a[(W, P1)] + (si.d[0] + si.d[1]) / c.j).abs() < 1e-12 * a[(W, P1)].abs());
        // V(x) multiplies a flow that is zero at rest: no position term beyond rounding
        assert!(
            a[(P1, X)].abs() < 1e-12 * a[(P1, V)].abs(),
            "{}",
            a[(P1, X)]
        );
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
