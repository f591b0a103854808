//! The valve-controlled cylinder the article measures the pump-controlled one against (its
//! introduction and §4; docs/circuits.md#valve): a four-way servo-proportional valve between a
//! constant-pressure supply, the tank and the cylinder's chambers, written from its nonlinear
//! equations (Merritt, *Hydraulic Control Systems*, 1967, §5.2 and §6.2; Jelali & Kroll,
//! *Hydraulic Servo-systems*, 2003, §4.2).
//!
//! States (SI): `x` (m), `v` (m/s), `p1`, `p2` (Pa gauge), the spool opening `s` (normalised to
//! ±1 at full opening) and its rate `s_dot` (1/s); the input is the opening command `s_ref`.
//! Equations:
//!
//! - m v̇ = p1 A1 − p2 A2 − F_ext − b v
//! - V1/β ṗ1 = Q_PA − Q_AT − A1 v − c_L (p1 − p2)
//! - V2/β ṗ2 = r (Q_PB − Q_BT) + A2 v + c_L (p1 − p2)
//! - s̈ = ω_v² (s_ref − s) − 2 ζ_v ω_v ṡ
//!
//! with the turbulent orifice law on every land, Q = K_v · max(0, opening) · √Δp: lands P→A and
//! B→T open with u₀ + s, A→T and P→B with u₀ − s (a matched, symmetric underlap u₀), K_v = Q_N/√Δp_N
//! per land from the datasheet's rated flow at its rated drop per land, port B's lands scaled by
//! r, and the opening held to ±1 (the spool's stops). The underlap comes from the datasheet's null
//! leakage Q_L (ports blocked, at supply pressure, tank at 0 bar): Q_L = 2 K_v u₀ √(p_s/2). The
//! control law is the article's P law on the spool, s_ref = K_p (x_ref − x), K_p in full
//! openings per metre.
//!
//! ```
//! use pumpcyl::circuit::{valve::Valve, linearise, Circuit};
//! use pumpcyl::rig::Rig;
//!
//! let rig = Rig::default().with_overrides(&["circuit=valve".into()])?;
//! let c = Valve::new(&rig)?;
//! let op = c.operating_point();
//! let (a, b) = linearise(&c, &op.state, &op.inputs);
//! assert_eq!((a.nrows(), b.ncols()), (6, 1));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::parts::{cylinder_of_rig, cylinder_rates, one_motor_states, Chamber, Effects, Fluid};
use super::parts::Piston;
use super::energy::{self, Power};
use super::stops::Stops;
use super::{Circuit, CircuitKind, ControlLaw, Key, OperatingState, Role, Scalar, Signal};
use crate::rig::{Range, Rig};
use crate::units::PA_PER_BAR;

/// State positions: position, velocity, the chamber pressures, the spool's opening and rate.
const X: usize = 0;
const V: usize = 1;
const P1: usize = 2;
const P2: usize = 3;
const S: usize = 4;
const SD: usize = 5;
/// Number of states.
const N: usize = 6;

/// The pressure difference (Pa) below which the orifice law's square root is rounded off, so
/// that its derivative stays finite where a land's pressure drop passes zero: the flow is
/// Δp/(Δp² + δ²)^¼ instead of sign(Δp)√|Δp|, which differs by less than 1e-8 relative beyond
/// 100 × δ (1 bar) **\[choice\]**.
const ROUNDING_PA: f64 = 1e2;

/// Most Newton steps to the rest with the cylinder's leakage.
const MAX_REST_STEPS: usize = 100;

/// The valve's own rig keys (docs/circuits.md#valve-keys): a valve of the size of the
/// article's pump drive's flow (20 L/min at 35 bar per land, a size-6 servo-proportional
/// valve), at 100 bar supply, the pressure the article's introduction gives a valve-controlled
/// cylinder's 6300 bar bulk modulus at **\[choice\]**.
const KEYS: &[Key] = &[
    Key {
        name: "supply_pressure_bar",
        doc: "bar, the valve's supply pressure p_s (a constant-pressure source)",
        default: 100.0,
        range: Range::Positive(0.1, 1e4),
    },
    Key {
        name: "tank_pressure_bar",
        doc: "bar, the tank's pressure p_t",
        default: 0.0,
        range: Range::NonNegative(1e3),
    },
    Key {
        name: "valve_rated_flow_lpm",
        doc: "L/min, the valve's rated flow per land at valve_rated_drop_bar, fully open",
        default: 20.0,
        range: Range::Positive(1e-3, 1e5),
    },
    Key {
        name: "valve_rated_drop_bar",
        doc: "bar, the pressure drop per land its rated flow is given at",
        default: 35.0,
        range: Range::Positive(0.1, 1e4),
    },
    Key {
        name: "valve_flow_ratio_b_to_a",
        doc: "port B's lands' flow over port A's at the same opening and drop",
        default: 1.0,
        range: Range::Positive(0.01, 100.0),
    },
    Key {
        name: "valve_null_leakage_lpm",
        doc: "L/min, the valve's null leakage (total, ports blocked, at the supply pressure): sets its underlap",
        default: 0.3,
        range: Range::Positive(1e-6, 1e4),
    },
    Key {
        name: "valve_natural_frequency_hz",
        doc: "Hz, the spool's natural frequency (its -90 degree frequency)",
        default: 60.0,
        range: Range::Positive(0.1, 1e4),
    },
    Key {
        name: "valve_damping",
        doc: "the spool's damping ratio",
        default: 0.7,
        range: Range::Positive(1e-3, 100.0),
    },
    Key {
        name: "supply_flow_lpm",
        doc: "L/min, a fixed-displacement supply pump's flow at the supply pressure, its excess over what the valve draws spilled through the relief valve; 0 = a pressure-compensated supply, which delivers what the valve draws",
        default: 0.0,
        range: Range::NonNegative(1e5),
    },
    Key {
        name: "cylinder_leakage_m5_per_ns",
        doc: "m⁵/(N·s), the cylinder's internal leakage, chamber 1 to chamber 2",
        default: 0.0,
        range: Range::NonNegative(1e-6),
    },
];

/// The servo valve: its lands and its spool.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ServoValve {
    /// Flow coefficient of one fully open land, K_v = Q_N/√Δp_N (m³/s per √Pa).
    kv: f64,
    /// Port B's lands over port A's.
    ratio_b: f64,
    /// The matched underlap u₀ (normalised opening).
    underlap: f64,
    /// Supply and tank pressures (Pa gauge).
    supply_pa: f64,
    tank_pa: f64,
    /// A fixed-displacement supply's flow (m³/s); 0 for a pressure-compensated one.
    fixed_supply_m3_s: f64,
    /// The spool's natural frequency (rad/s) and damping ratio.
    omega: f64,
    zeta: f64,
}

impl ServoValve {
    fn of_rig(rig: &Rig) -> ServoValve {
        let k = |name| rig.circuit_key(name);
        let lpm = 1e-3 / 60.0;
        let kv = k("valve_rated_flow_lpm") * lpm / (k("valve_rated_drop_bar") * PA_PER_BAR).sqrt();
        let supply_pa = k("supply_pressure_bar") * PA_PER_BAR;
        ServoValve {
            kv,
            ratio_b: k("valve_flow_ratio_b_to_a"),
            underlap: k("valve_null_leakage_lpm") * lpm / (2.0 * kv * (supply_pa / 2.0).sqrt()),
            supply_pa,
            tank_pa: k("tank_pressure_bar") * PA_PER_BAR,
            fixed_supply_m3_s: k("supply_flow_lpm") * lpm,
            omega: 2.0 * std::f64::consts::PI * k("valve_natural_frequency_hz"),
            zeta: k("valve_damping"),
        }
    }

    /// The flow (m³/s) of one land of port A at opening `o` (normalised) and drop `dp` (Pa).
    fn land<T: Scalar>(&self, o: T, dp: T) -> T {
        if o <= 0.0 {
            return T::from(0.0);
        }
        let root = (dp * dp + ROUNDING_PA * ROUNDING_PA).sqrt().sqrt();
        o * self.kv * dp / root
    }

    /// The flow (m³/s) the supply delivers through the lands P→A and P→B at the spool opening
    /// `s` and the chamber pressures `p1`, `p2` (Pa gauge).
    fn supply_flow(&self, s: f64, p1: f64, p2: f64) -> f64 {
        let s = s.clamp(-1.0, 1.0);
        let (ps, u0) = (self.supply_pa, self.underlap);
        self.land(s + u0, ps - p1) + self.land(-s + u0, ps - p2) * self.ratio_b
    }

    /// The flows (m³/s) of the four lands at the spool opening `s` and the chamber pressures
    /// `p1`, `p2`, as [`ServoValve::flows`] takes them: P→A, A→T, P→B, B→T.
    fn land_flows(&self, s: f64, p1: f64, p2: f64) -> [f64; 4] {
        let s = s.clamp(-1.0, 1.0);
        let (ps, pt, u0, r) = (self.supply_pa, self.tank_pa, self.underlap, self.ratio_b);
        let (open, shut) = (s + u0, -s + u0);
        [
            self.land(open, -p1 + ps),
            self.land(shut, p1 - pt),
            self.land(shut, -p2 + ps) * r,
            self.land(open, p2 - pt) * r,
        ]
    }

    /// The flows (m³/s) the valve passes into chambers 1 and 2 at the spool opening `s` and
    /// the chamber pressures `p1`, `p2`; the opening held to ±1.
    fn flows<T: Scalar>(&self, s: T, p1: T, p2: T) -> [T; 2] {
        let s = if s > 1.0 {
            T::from(1.0)
        } else if s < -1.0 {
            T::from(-1.0)
        } else {
            s
        };
        let (ps, pt, u0) = (self.supply_pa, self.tank_pa, self.underlap);
        let (open, shut) = (s + u0, -s + u0);
        [
            self.land(open, -p1 + ps) - self.land(shut, p1 - pt),
            (self.land(shut, -p2 + ps) - self.land(open, p2 - pt)) * self.ratio_b,
        ]
    }
}

/// The rated flow (L/min per land at `valve_rated_drop_bar`) of the valve that drives `rig`'s
/// cylinder, unloaded and fully open, at `velocity_m_per_s` in its slower direction: the
/// datasheet sizing of Merritt (1967, §5) and Jelali & Kroll (2003, §4) for an asymmetric
/// cylinder (docs/circuits.md#sizing-the-valve). With the chamber pressures balanced,
/// p₁A₁ = p₂A₂, and the lands' law Q = K_v·√Δp, v² = K_v²·y with
/// y = (p_s − p_t/φ)/(A₁² + A₂²/(r²φ)) extending and r²(p_s − φp_t)/(A₂² + r²φA₁²) retracting
/// (φ = A₁/A₂, r the B port's ratio): the smaller y sizes K_v, and Q_N = K_v·√Δp_N.
pub fn rated_flow_for_velocity_lpm(rig: &Rig, velocity_m_per_s: f64) -> f64 {
    let v = ServoValve::of_rig(rig);
    let si = rig.si();
    let (a1, a2, r) = (si.a1, si.a2, v.ratio_b);
    let phi = a1 / a2;
    let extending = (v.supply_pa - v.tank_pa / phi) / (a1 * a1 + a2 * a2 / (r * r * phi));
    let retracting = r * r * (v.supply_pa - phi * v.tank_pa) / (a2 * a2 + r * r * phi * a1 * a1);
    let kv = velocity_m_per_s / extending.min(retracting).sqrt();
    let drop_pa = rig.circuit_key("valve_rated_drop_bar") * PA_PER_BAR;
    kv * drop_pa.sqrt() * 60e3
}

/// The valve-controlled cylinder of a rig.
#[derive(Debug, Clone, PartialEq)]
pub struct Valve {
    valve: ServoValve,
    piston: Piston,
    chambers: [Chamber; 2],
    fluid: Fluid,
    /// The cylinder's internal leakage c_L (m⁵/(N·s)).
    leakage: f64,
    /// Position gain K_p (normalised opening per m).
    gain: f64,
    /// Operating-point position x0 (m).
    x0: f64,
    /// The rest: spool opening and chamber pressures (Pa gauge).
    rest: [f64; 3],
}

/// Why a valve-controlled cylinder has no rest: the force it must hold, or the leakage's
/// balance the Newton steps did not find.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct NoRest(String);

impl Valve {
    /// The ideal circuit of `rig`, whose Jacobian at rest is the linear model: volumes at x0,
    /// constant β, no friction but the viscous, no end stops.
    ///
    /// # Errors
    /// [`NoRest`] when the valve cannot hold the rig's external force.
    pub fn new(rig: &Rig) -> Result<Valve, NoRest> {
        Valve::build(rig, Effects::none(), None)
    }

    /// The circuit the emulator integrates: the chosen effects and the end stops.
    ///
    /// # Errors
    /// [`NoRest`] when the valve cannot hold the rig's external force.
    pub fn emulated(rig: &Rig, effects: Effects) -> Result<Valve, NoRest> {
        let stops = Stops::new(rig.stroke_mm * 1e-3, rig.mass_kg);
        Valve::build(rig, effects, Some(stops))
    }

    fn build(rig: &Rig, e: Effects, stops: Option<Stops>) -> Result<Valve, NoRest> {
        let si = rig.si();
        let (piston, chambers) = cylinder_of_rig(rig, &e, stops);
        let mut c = Valve {
            valve: ServoValve::of_rig(rig),
            piston,
            chambers,
            fluid: Fluid::of(si.beta, &e),
            leakage: rig.circuit_key("cylinder_leakage_m5_per_ns"),
            gain: si.kp,
            x0: si.x0,
            rest: [0.0; 3],
        };
        c.rest = c.solve_rest()?;
        Ok(c)
    }

    /// The spool opening and the chamber pressures (Pa gauge) at rest: each chamber's flows
    /// balance the cylinder's leakage and the pressures hold the external force. Without leakage
    /// in closed form, k = ((u₀ + s)/(u₀ − s))² = (F + A2 p_s − A1 p_t)/(A1 p_s − A2 p_t − F),
    /// p1 = (k p_s + p_t)/(k + 1), p2 = (p_s + k p_t)/(k + 1); with it, Newton's method from there.
    fn solve_rest(&self) -> Result<[f64; 3], NoRest> {
        let [a1, a2] = self.piston.areas_m2;
        let (ps, pt, u0, f) = (
            self.valve.supply_pa,
            self.valve.tank_pa,
            self.valve.underlap,
            self.piston.force_ext_n,
        );
        let (num, den) = (f + a2 * ps - a1 * pt, a1 * ps - a2 * pt - f);
        if num <= 0.0 || den <= 0.0 || pt >= ps {
            return Err(NoRest(format!(
                "the valve cannot hold the external force {f} N at rest: with {:.1} bar supply and \
                 {:.1} bar tank it holds {:.0} N to {:.0} N (docs/circuits.md#valve)",
                ps / PA_PER_BAR,
                pt / PA_PER_BAR,
                a1 * pt - a2 * ps,
                a1 * ps - a2 * pt
            )));
        }
        let k = num / den;
        let r = k.sqrt();
        let closed = [
            u0 * (r - 1.0) / (r + 1.0),
            (k * ps + pt) / (k + 1.0),
            (ps + k * pt) / (k + 1.0),
        ];
        if self.leakage == 0.0 {
            return Ok(closed);
        }
        self.newton_rest(closed)
    }

    /// The rest's residuals: chamber 1's and 2's net flows (m³/s) and the force balance (N).
    fn rest_residual(&self, [s, p1, p2]: [f64; 3]) -> [f64; 3] {
        let [q1, q2] = self.valve.flows(s, p1, p2);
        let cross = self.leakage * (p1 - p2);
        let [a1, a2] = self.piston.areas_m2;
        [q1 - cross, q2 + cross, p1 * a1 - p2 * a2 - self.piston.force_ext_n]
    }

    /// Newton's method on [`Valve::rest_residual`] from `start`, the Jacobian by central
    /// differences, each step halved until the residual falls.
    fn newton_rest(&self, start: [f64; 3]) -> Result<[f64; 3], NoRest> {
        let scale = [self.valve.underlap * 1e-6, 1.0, 1.0];
        let weigh = |r: [f64; 3]| {
            let q = self.valve.kv * self.valve.supply_pa.sqrt();
            (r[0] / q).powi(2) + (r[1] / q).powi(2) + (r[2] / (self.piston.areas_m2[0] * 1e5)).powi(2)
        };
        let mut y = start;
        for _ in 0..MAX_REST_STEPS {
            let r = self.rest_residual(y);
            if weigh(r) < 1e-26 {
                return Ok(y);
            }
            let mut j = nalgebra::Matrix3::zeros();
            for c in 0..3 {
                let (mut up, mut down) = (y, y);
                up[c] += scale[c];
                down[c] -= scale[c];
                let (ru, rd) = (self.rest_residual(up), self.rest_residual(down));
                for row in 0..3 {
                    j[(row, c)] = (ru[row] - rd[row]) / (2.0 * scale[c]);
                }
            }
            let step = j
                .lu()
                .solve(&nalgebra::Vector3::new(-r[0], -r[1], -r[2]))
                .ok_or_else(|| NoRest("the rest's Jacobian is singular".into()))?;
            let mut t = 1.0;
            while t > 1e-6 {
                let next = [y[0] + t * step[0], y[1] + t * step[1], y[2] + t * step[2]];
                if weigh(self.rest_residual(next)) < weigh(r) {
                    y = next;
                    break;
                }
                t *= 0.5;
            }
            if t <= 1e-6 {
                break;
            }
        }
        Err(NoRest(format!(
            "no rest found with the cylinder's leakage {:e} m⁵/(N·s) (docs/circuits.md#valve)",
            self.leakage
        )))
    }

    /// The spool opening and chamber pressures (Pa gauge) at rest.
    pub fn rest(&self) -> [f64; 3] {
        self.rest
    }

    /// The position loop's gain K_p (normalised opening per m).
    pub fn position_gain(&self) -> f64 {
        self.gain
    }

    /// The underlap u₀ the null leakage gives (normalised opening).
    pub fn underlap(&self) -> f64 {
        self.valve.underlap
    }

    /// Number of states.
    pub fn n_states(&self) -> usize {
        N
    }

    cylinder_calls!(Valve);
}

impl Circuit for Valve {
    fn kind(&self) -> CircuitKind {
        CircuitKind::Valve
    }

    fn states(&self) -> Vec<Signal> {
        let mut states = one_motor_states("", 4);
        states.push(Signal::new(
            "s",
            "1",
            "spool opening (normalised, 1 = fully open P to A)",
            Role::SpoolOpening,
        ));
        states.push(Signal::new("s_dot", "1/s", "spool velocity", Role::SpoolVelocity));
        states
    }

    fn inputs(&self) -> Vec<Signal> {
        vec![Signal::new(
            "s_ref",
            "1",
            "spool opening command",
            Role::SpoolCommand,
        )]
    }

    fn rhs<T: Scalar>(&self, s: &[T], u: &[T], dx: &mut [T]) {
        let [q1, q2] = self.valve.flows(s[S], s[P1], s[P2]);
        let [a1, a2] = self.piston.areas_m2;
        let cross = (s[P1] - s[P2]) * self.leakage;
        let flows = [q1 - s[V] * a1 - cross, q2 + s[V] * a2 + cross];
        let cylinder = (&self.piston, &self.chambers, &self.fluid);
        cylinder_rates(cylinder, [X, V, P1, P2], s, flows, dx);
        let w = self.valve.omega;
        dx[S] = s[SD];
        dx[SD] = (u[0] - s[S]) * (w * w) - s[SD] * (2.0 * self.valve.zeta * w);
    }

    /// At rest at x0: the spool at the opening that balances the flows and holds the force,
    /// commanded there.
    fn operating_point(&self) -> OperatingState {
        let [s, p1, p2] = self.rest;
        let mut state = vec![0.0; N];
        state[X] = self.x0;
        state[P1] = p1;
        state[P2] = p2;
        state[S] = s;
        OperatingState {
            state,
            inputs: vec![s],
        }
    }

    /// s_ref = K_p (x_ref − x): the article's P law on the spool.
    fn control_law(&self) -> ControlLaw {
        ControlLaw::position(N, X, self.gain)
    }
}

/// The valve-controlled cylinder as the list of circuits knows it
/// (docs/architecture.md#circuits).
pub struct Module;

impl super::Module for Module {
    const DESCRIPTION: super::Description = super::Description {
        name: "valve",
        fmu_words: "valve-controlled cylinder (circuit valve, four-way servo-proportional valve)",
        controller_words: "with the article's position controller on its spool",
        drives: 0,
        servo_valves: 1,
        pumps: 0,
        variants: &[super::Variant {
            level: super::PressureLevel::Supply,
            name: "valve",
            key: "valve",
        }],
        sum_pressure_loop: false,
        level: super::Level {
            key: "supply_pressure_bar",
            words: "the mean chamber pressure its valve holds at rest from its supply",
            at_emulated_rest: true,
        },
        valves: None,
        own_keys: &[],
        keys: KEYS,
        no_modes: Some("a valve-controlled cylinder has no valves that switch its chambers"),
    };
    type Linear = Valve;
    type Emulated = Valve;

    fn linear(rig: &Rig) -> Valve {
        Valve::new(rig).expect("Rig::validate refuses a valve rig with no rest")
    }

    fn emulated(rig: &Rig, effects: Effects) -> Result<Valve, String> {
        Valve::emulated(rig, effects).map_err(|e| e.to_string())
    }

    /// The valve on another circuit's cylinder (docs/select.md#the-valve-beside-the-pumps): where
    /// that rig has pumps and no valve of its own, a valve sized for the pumps' top speed, pump
    /// 1 at its speed limit filling the annulus (D₁·ω_max/A₂, the slower direction), at the
    /// rig's supply pressure ([`rated_flow_for_velocity_lpm`]); a valve rig as it is.
    fn built_on(rig: &Rig, kind: CircuitKind) -> Rig {
        let mut out = Rig {
            circuit: kind,
            ..rig.clone()
        };
        if rig.circuit.description().servo_valves > 0 {
            return out;
        }
        let si = rig.si();
        let rpm_to_rad_s = std::f64::consts::PI / 30.0;
        let top = si.d[0] * rig.pump_max_speed_rpm * rpm_to_rad_s / si.a2;
        let flow = rated_flow_for_velocity_lpm(&out, top);
        (out.circuit_keys.0).insert("valve_rated_flow_lpm".into(), toml::Value::Float(flow));
        out
    }

    fn validate_rest(rig: &Rig) -> Result<(), (&'static str, f64, String)> {
        Valve::new(rig)
            .map(|_| ())
            .map_err(|e| ("external_force_n", rig.external_force_n, e.0))
    }

    /// The mean of its chambers' pressures at rest.
    fn pressure_level_bar(rig: &Rig) -> f64 {
        Valve::new(rig).map_or(f64::NAN, |c| 0.5 * (c.rest[1] + c.rest[2]) / PA_PER_BAR)
    }

    fn supply_rest(rig: &Rig) -> Result<super::SupplyRest, String> {
        let c = Valve::new(rig).map_err(|e| e.to_string())?;
        let [s, p1, p2] = c.rest;
        let flow = c.valve.supply_flow(s, p1, p2);
        Ok(super::SupplyRest {
            p_pa: [p1, p2],
            flow_m3_s: flow,
            // a fixed pump's excess is spilled to the tank as well (docs/energy.md#the-valve)
            power_w: (c.valve.supply_pa - c.valve.tank_pa) * flow.max(c.valve.fixed_supply_m3_s),
        })
    }

    /// From the tank's pressure to the supply's: the valve feeds no chamber beyond them.
    fn pressure_band_bar(rig: &Rig) -> [(f64, &'static str); 2] {
        [
            (rig.circuit_key("tank_pressure_bar"), "the tank pressure"),
            (rig.circuit_key("supply_pressure_bar"), "the supply pressure"),
        ]
    }
}

impl super::LinearForm for Valve {
    fn law(&self, _sum_pressure: bool) -> ControlLaw {
        self.control_law()
    }
    fn load_torques_nm(&self, _p_pa: [f64; 2]) -> [f64; 2] {
        [0.0, 0.0]
    }
    fn describe(&self) -> String {
        <Module as super::Module>::DESCRIPTION.name.to_string()
    }
}

impl Valve {
    /// Where the power goes at state `s` under command `u` (docs/energy.md): the supply's
    /// power p_s·(Q_PA + Q_PB), with a fixed pump's excess spilled through its relief valve,
    /// throttled on every land, taken by the tank line at its pressure, lost in the piston's
    /// leakage, and delivered to the cylinder.
    fn power_at(&self, s: &[f64], u: &[f64]) -> Power {
        let mut dx = vec![0.0; s.len()];
        self.rhs(s, u, &mut dx);
        let mut power = Power::default();
        let (p1, p2) = (s[P1], s[P2]);
        let [a1, a2] = self.piston.areas_m2;
        let [pa, at, pb, bt] = self.valve.land_flows(s[S], p1, p2);
        let cross = (p1 - p2) * self.leakage;
        let flows = [pa - at - s[V] * a1 - cross, pb - bt + s[V] * a2 + cross];
        energy::cylinder(&self.piston, [s[X], s[V], p1, p2], flows, dx[V], &mut power);
        let (ps, pt) = (self.valve.supply_pa, self.valve.tank_pa);
        // a fixed pump spills what the lands do not draw through the relief valve to the tank
        let spilled = (self.valve.fixed_supply_m3_s - (pa + pb)).max(0.0);
        power.source("supply", ps * (pa + pb + spilled));
        power.loss("supply_relief", energy::throttled(spilled, ps, pt));
        let throttling = energy::throttled(pa, ps, p1)
            + energy::throttled(at, p1, pt)
            + energy::throttled(pb, ps, p2)
            + energy::throttled(bt, p2, pt);
        power.loss("valve_throttling", throttling);
        // the tank line at its pressure takes what returns, and gives where a chamber is below it
        power.store("tank_line", pt * (at + bt + spilled));
        power.loss("leakage", energy::leak(self.leakage, p1, p2));
        power
    }
}

impl super::EmulatedForm for Valve {
    emulated_form_calls!(Valve, n_states);
    fn power(&self, s: &[f64], u: &[f64]) -> Power {
        self.power_at(s, u)
    }
    fn rest_with_commands(&self) -> (Vec<f64>, [f64; 2]) {
        let op = self.operating_point();
        (op.state, [op.inputs[0], 0.0])
    }
    /// s_ref = K_p (x_ref − x), held to the spool's ±1.
    fn commands(&self, _rig: &Rig, r_mm: f64, x_mm: f64, _p_bar: &[f64]) -> [f64; 2] {
        let e = (r_mm - x_mm) * 1e-3;
        [(self.gain * e).clamp(-1.0, 1.0), 0.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::circuit::linearise;

    fn valve_rig(sets: &[&str]) -> Rig {
        let mut all = vec!["circuit=valve".to_string()];
        all.extend(sets.iter().map(|s| s.to_string()));
        Rig::default().with_overrides(&all).unwrap()
    }

    /// On a pump rig's cylinder the valve is sized for the pumps' top speed, D₁·ω_max/A₂ by
    /// hand (6 cm³/rev at 3600 rpm into the article's 63/36 mm annulus: 0.1715 m/s), at the
    /// rig's supply; a valve rig keeps its own valve.
    #[test]
    fn a_valve_built_on_a_pump_rig_is_sized_for_its_pumps() {
        let mut pump_rig = Rig::default();
        (pump_rig.circuit_keys.0).insert("supply_pressure_bar".into(), toml::Value::Float(70.0));
        let built = CircuitKind::Valve.built_on(&pump_rig);
        assert_eq!(built.circuit, CircuitKind::Valve);
        let annulus = std::f64::consts::PI / 4.0 * (0.063f64.powi(2) - 0.036f64.powi(2));
        let top = 6e-6 * 3600.0 / 60.0 / annulus;
        assert!((top - 0.1715).abs() < 1e-4, "{top}");
        let by_hand = rated_flow_for_velocity_lpm(&built, top);
        let rated = built.circuit_key("valve_rated_flow_lpm");
        assert!((rated - by_hand).abs() <= 1e-12 * by_hand, "{rated} vs {by_hand}");
        assert_eq!(built.circuit_key("supply_pressure_bar"), 70.0);
        let own = valve_rig(&["valve_rated_flow_lpm=12"]);
        assert_eq!(CircuitKind::Valve.built_on(&own), own);
    }

    /// A valve sized for a velocity moves the unloaded piston at it in its slower direction,
    /// fully open (the flows of its lands at the balanced pressures), and faster in the other;
    /// on a symmetric cylinder both ways at the textbook K_v·√(p_s/2)/A.
    #[test]
    fn a_valve_sized_for_a_velocity_reaches_it() {
        for sets in [
            &["valve_null_leakage_lpm=1e-6"][..],
            &["valve_null_leakage_lpm=1e-6", "tank_pressure_bar=3", "valve_flow_ratio_b_to_a=0.6"],
            &["valve_null_leakage_lpm=1e-6", "rod_diameter_mm=20", "supply_pressure_bar=210"],
        ] {
            let rig = valve_rig(sets);
            let q = rated_flow_for_velocity_lpm(&rig, 0.17);
            let rig = rig
                .with_overrides(&[format!("valve_rated_flow_lpm={q}")])
                .unwrap();
            let c = Valve::new(&rig).unwrap();
            let si = rig.si();
            let speed = |s: f64| {
                // the p1 at which the balanced pressures pass equal velocities in and out (the
                // flows fall as p1 rises)
                let v_of = |p1: f64| c.valve.flows(s, p1, p1 * si.a1 / si.a2);
                let (mut lo, mut hi) = (0.0, c.valve.supply_pa);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    let [q1, q2] = v_of(mid);
                    if q1 / si.a1 + q2 / si.a2 > 0.0 {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                (v_of(lo)[0] / si.a1).abs()
            };
            let (out, back) = (speed(1.0), speed(-1.0));
            let slower = out.min(back);
            assert!((slower - 0.17).abs() < 1e-4 * 0.17, "{sets:?}: {out} {back}");
        }
        // a rod of 0.5 mm, the least accepted: areas equal to 6·10⁻⁵
        let symmetric = valve_rig(&["rod_diameter_mm=0.5"]);
        let q = rated_flow_for_velocity_lpm(&symmetric, 0.1);
        let (ps, dpn) = (100e5_f64, 35e5_f64);
        let area = std::f64::consts::PI / 4.0 * 0.063f64.powi(2);
        let kv = 0.1 * area / (ps / 2.0).sqrt();
        assert!((q - kv * dpn.sqrt() * 60e3).abs() < 2e-4 * q, "{q}");
    }

    /// The operating point is a steady state of the equations, with and without the
    /// cylinder's leakage and under a load.
    #[test]
    fn the_operating_point_is_at_rest() {
        for sets in [
            &[][..],
            &["cylinder_leakage_m5_per_ns=1e-12"],
            &["external_force_n=20000", "supply_pressure_bar=210"],
            &["external_force_n=-5000", "tank_pressure_bar=2", "valve_flow_ratio_b_to_a=0.5"],
        ] {
            let rig = valve_rig(sets);
            let c = Valve::new(&rig).unwrap();
            let op = c.operating_point();
            let mut dx = vec![0.0; N];
            c.rhs(&op.state, &op.inputs, &mut dx);
            let scale = [1e-3, 1e-3, 1e5, 1e5, 1e-2, 1.0];
            for (i, d) in dx.iter().enumerate() {
                assert!(d.abs() < 1e-6 * scale[i], "{sets:?}: state {i} rate {d}");
            }
            let [s, p1, p2] = c.rest();
            assert!(s.abs() < c.underlap(), "{sets:?}: {s}");
            assert!(p1 > 0.0 && p2 > 0.0, "{sets:?}: {p1} {p2}");
        }
    }

    /// The underlap gives the datasheet's null leakage: at s = 0 with both ports blocked at
    /// p_s/2, the four lands pass Q_L in all.
    #[test]
    fn the_underlap_gives_the_null_leakage() {
        let rig = valve_rig(&["valve_null_leakage_lpm=0.5", "supply_pressure_bar=140"]);
        let v = ServoValve::of_rig(&rig);
        let half = v.supply_pa / 2.0;
        let through = v.land(v.underlap, half) + v.land(v.underlap, half);
        assert!((through * 60e3 / 0.5 - 1.0).abs() < 1e-9, "{}", through * 60e3);
    }

    /// A load the valve cannot hold is refused, naming the force it can.
    #[test]
    fn a_load_beyond_the_supply_has_no_rest() {
        let rig = Rig::default();
        let e = rig
            .with_overrides(&["circuit=valve".into(), "external_force_n=1e6".into()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("external_force_n") && e.contains("cannot hold"), "{e}");
    }

    /// With a fast spool, no leakage and no friction, the least-damped poles are Merritt's
    /// hydraulic natural frequency ω_h² = (β/m)(A1²/V1 + A2²/V2) (Merritt 1967, §6.2) to 1 %:
    /// the valve's flow-pressure coefficients add damping, not stiffness.
    #[test]
    fn the_hydraulic_natural_frequency_is_merritts() {
        let rig = valve_rig(&[
            "viscous_friction_ns_per_m=0",
            "valve_natural_frequency_hz=2000",
        ]);
        let (c, si) = (Valve::new(&rig).unwrap(), rig.si());
        let op = c.operating_point();
        let (a, _) = linearise(&c, &op.state, &op.inputs);
        let wh = (si.beta / si.mass * (si.a1 * si.a1 / si.v1 + si.a2 * si.a2 / si.v2)).sqrt();
        let poles = a.complex_eigenvalues();
        let slowest = (poles.iter())
            .filter(|p| p.im > 0.0)
            .map(|p| p.norm())
            .fold(f64::INFINITY, f64::min);
        assert!((slowest / wh - 1.0).abs() < 0.01, "{slowest} vs {wh}");
    }
}
