//! The dual-prime-mover circuit of the article (§2.1, Figure 3; docs/model.md): one cylinder,
//! two chambers, two pumps each on its own motor. Pump 1 runs between the chambers, pump 2
//! between chamber 1 and the reservoir.
//!
//! States, in order (SI): `x` (m), `v` (m/s), `p1`, `p2` (Pa gauge), `w1`, `w2` (rad/s), then
//! for the full motor model `tau1`, `tau2` (N·m, electromagnetic torques) and, with
//! feedforward on, `z1`, `z2` (rad/s, the feedforward filter states). Inputs: the drive speed
//! references `w_ref1`, `w_ref2` (rad/s).
//!
//! The drive feedforward `Kff s/(τff s + 1)·ω_ref` is a torque added after the P gain
//! (docs/model.md#drive-velocity-loops-and-feedforward, docs/choices.md#feedforward-as-a-torque-after-the-p-gain).
//! Written with a filter state z (τff ż = ω_ref − z) it is `(Kff/τff)(ω_ref − z)`, so the
//! torque reference is `τ_ref = Km (ω_ref − ω) + (Kff/τff)(ω_ref − z)`.

use super::parts::{
    cylinder_of_rig, cylinder_rates, Chamber, Drive, Effects, FirstOrderMotor, Fluid, Piston, Pump,
};
use super::energy::{self, Power};
use super::stops::Stops;
use super::{Circuit, CircuitKind, ControlLaw, OperatingState, Role, Scalar, Signal};
use crate::rig::{MotorModel, Rig, RigSi};
use crate::units::{PA_PER_BAR, RAD_S_PER_RPM};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// Why the DPM circuit has no modes to switch between, in one line
/// (docs/circuits.md#will-it-chatter): its pumps hold both chambers, none a valve.
pub const NO_MODES: &str = "pump 1 runs between the chambers and pump 2, on a motor of its own, \
     between chamber 1 and the accumulator (the article §2.1, Figure 3): no valve moves a \
     chamber onto the accumulator";

/// Positions of the states in the state vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layout {
    x: usize,
    v: usize,
    p: [usize; 2],
    w: [usize; 2],
    tau: Option<[usize; 2]>,
    ff: Option<[usize; 2]>,
    n: usize,
}

impl Layout {
    fn for_rig(rig: &Rig) -> Layout {
        let full = rig.motor_model == MotorModel::Full;
        let tau = full.then_some([6, 7]);
        let ff = (full && rig.feedforward).then_some([8, 9]);
        let n = 6 + 2 * usize::from(tau.is_some()) + 2 * usize::from(ff.is_some());
        Layout {
            x: 0,
            v: 1,
            p: [2, 3],
            w: [4, 5],
            tau,
            ff,
            n,
        }
    }
}

/// The motors of the circuit: full drives or first-order motors.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Motors {
    /// The drives and the positions of their torque states.
    Full([Drive; 2], [usize; 2]),
    FirstOrder([FirstOrderMotor; 2]),
}

impl Motors {
    /// The same motors without their torque and speed limits (what a Newton step at rest may
    /// cross).
    fn without_limits(&self) -> Motors {
        match self {
            Motors::Full(drives, at) => Motors::Full(
                drives.map(|d| Drive {
                    torque_limit: None,
                    speed_limit: None,
                    ..d
                }),
                *at,
            ),
            m => *m,
        }
    }
}

/// The DPM circuit of a rig: its parts with their effects switched as asked.
#[derive(Debug, Clone, PartialEq)]
pub struct Dpm {
    si: RigSi,
    layout: Layout,
    piston: Piston,
    chambers: [Chamber; 2],
    fluid: Fluid,
    pumps: [Pump; 2],
    motors: Motors,
    /// The drives' electrical side (docs/energy.md#the-drives).
    electrics: energy::Electrics,
    /// The pumps' pressure load acts on the motors.
    coupling: bool,
    /// The sum-pressure loop is part of the control law.
    sum_pressure: bool,
}

impl Dpm {
    /// The circuit the linear model is the Jacobian of: every effect off, no end stops, the
    /// rig's variant switches (motor model, feedforward, motor coupling) as set.
    pub fn linear(rig: &Rig) -> Dpm {
        Dpm::build(rig, Effects::none(), None, rig.motor_coupling)
    }

    /// The circuit the emulator integrates: the chosen effects, the end stops, the pumps'
    /// load always on the motors (docs/emulator.md).
    pub fn emulated(rig: &Rig, effects: Effects) -> Dpm {
        let si = rig.si();
        let stops = Stops::new(rig.stroke_mm * 1e-3, si.mass);
        Dpm::build(rig, effects, Some(stops), true)
    }

    fn build(rig: &Rig, e: Effects, stops: Option<Stops>, coupling: bool) -> Dpm {
        let si = rig.si();
        let layout = Layout::for_rig(rig);
        let (piston, chambers) = cylinder_of_rig(rig, &e, stops);
        let pumps = si.d.map(|d| Pump::of(d, &e));
        let motors = match layout.tau {
            Some(tau) => Motors::Full(
                [0, 1].map(|i| Drive {
                    inertia: si.j[i],
                    km: si.km[i],
                    omega_i: si.omega_i,
                    feedforward: layout.ff.map(|_| si.kff / si.tau_ff),
                    tau_ff_s: si.tau_ff,
                    torque_limit: e.peak_torque_factor.map(|f| f * rig.motor_rated_torque_nm),
                    speed_limit: e.pump_speed_limit_rad_s(rig),
                }),
                tau,
            ),
            None => Motors::FirstOrder(si.tau_motor.map(|tau_s| FirstOrderMotor { tau_s })),
        };
        Dpm {
            piston,
            chambers,
            fluid: Fluid::of(si.beta, &e),
            pumps,
            motors,
            si,
            layout,
            coupling,
            sum_pressure: rig.sum_pressure,
            electrics: energy::Electrics::of(rig),
        }
    }

    /// The rig in SI units.
    pub fn si(&self) -> &RigSi {
        &self.si
    }

    /// Number of states.
    pub fn order(&self) -> usize {
        self.layout.n
    }

    cylinder_calls!(Dpm, motors);

    /// The pressures at rest (Pa gauge) and the pump speeds (rad/s) that feed the leakage at
    /// standstill: the sum-pressure set-point split by the force balance p1 A1 − p2 A2 = F_ext,
    /// and docs/identification.md#leakage-from-standstill solved for ω.
    fn rest(&self) -> ([f64; 2], [f64; 2]) {
        let si = &self.si;
        let [p1, p2] = si.rest_pressures_pa();
        let cross = si.c12 * (p1 - p2);
        let w1 = (cross - si.c2 * p2) / si.d[0];
        let w2 = (si.c1 * p1 + cross - si.d[0] * w1) / si.d[1];
        ([p1, p2], [w1, w2])
    }

    /// The operating point as a state (absolute x0, gauge pressures, the leakage speeds; with
    /// the full motor model the torques that carry the pumps' load where `loaded`, none
    /// otherwise, and the feedforward filters settled) and the speed commands (rad/s) that
    /// hold it.
    pub fn rest_state(&self, loaded: bool) -> (Vec<f64>, [f64; 2]) {
        let (p, w) = self.rest();
        let (l, si) = (&self.layout, &self.si);
        let mut x = vec![0.0; l.n];
        x[l.x] = si.x0;
        x[l.p[0]] = p[0];
        x[l.p[1]] = p[1];
        x[l.w[0]] = w[0];
        x[l.w[1]] = w[1];
        // first-order motors: the speed settles at its command
        let Some(tau) = l.tau else { return (x, w) };
        let load = if loaded {
            [si.d[0] * (p[0] - p[1]), si.d[1] * p[0]]
        } else {
            [0.0; 2]
        };
        let mut u = [0.0; 2];
        for i in 0..2 {
            x[tau[i]] = load[i];
            // τ = Km (u − ω) at rest (the feedforward filter has settled: z = u)
            u[i] = w[i] + load[i] / si.km[i];
            if let Some(ff) = l.ff {
                x[ff[i]] = u[i];
            }
        }
        (x, u)
    }

    /// The control law of docs/model.md#the-dpm-control-law with the position error
    /// e = x_ref − x and, with `sum_pressure`, the sum-pressure loop on −(Δp1 + Δp2):
    /// u1 = Kp e + K_pres (Δp1 + Δp2), u2 = Kp α e − K_pres Kβ (Δp1 + Δp2), ω_ref = K_scale u.
    pub fn law(&self, sum_pressure: bool) -> ControlLaw {
        let si = &self.si;
        let l = &self.layout;
        let direction = [1.0, si.alpha];
        let kr = DMatrix::from_fn(2, 1, |i, _| si.k_scale * si.kp * direction[i]);
        let mut kx = DMatrix::zeros(2, l.n);
        for i in 0..2 {
            kx[(i, l.x)] = -kr[(i, 0)];
        }
        if sum_pressure {
            let split = [1.0, -si.k_beta];
            for i in 0..2 {
                for &p in &l.p {
                    kx[(i, p)] = si.k_scale * si.k_pres * split[i];
                }
            }
        }
        ControlLaw { kx, kr }
    }

    /// The same law on what a PLC measures, in absolute terms (docs/model.md#the-dpm-control-law):
    /// the speed commands (rad/s) for the reference `r_mm`, the position `x_mm` (mm) and the
    /// pressures `p_bar` (bar gauge, in the order of the pressure states). The sum-pressure
    /// set-point matters here.
    pub fn plc_commands(&self, rig: &Rig, r_mm: f64, x_mm: f64, p_bar: &[f64]) -> [f64; 2] {
        let si = &self.si;
        let e = (r_mm - x_mm) * 1e-3;
        let e_p = rig.p_sum_ref_bar - (p_bar[0] + p_bar[1]);
        let k_pres = if rig.sum_pressure {
            rig.k_pres_per_bar
        } else {
            0.0
        };
        let u1 = si.kp * e - k_pres * e_p;
        let u2 = si.kp * si.alpha * e + k_pres * si.k_beta * e_p;
        [si.k_scale * u1, si.k_scale * u2]
    }
}

impl Dpm {
    /// The standstill of the circuit's own operating point: the pump speeds that feed exactly
    /// its leakages at its rest pressures, so its c1 and c2 come back from it.
    pub fn standstill(&self) -> Standstill {
        let (p, w) = self.rest();
        Standstill {
            w1_rpm: w[0] / RAD_S_PER_RPM,
            w2_rpm: w[1] / RAD_S_PER_RPM,
            p1_bar: p[0] / PA_PER_BAR,
        }
    }

    /// c1 and c2 from the standstill continuity equations (the article §2.3.2, §2.4;
    /// docs/identification.md#leakage-from-standstill) for a given c12:
    /// c1 = (D1 ω1 + D2 ω2 − c12 (p1 − p2))/p1, c2 = (−D1 ω1 + c12 (p1 − p2))/p2, with p2
    /// from Newton's force balance at rest, p1 A1 − p2 A2 = F_ext (the sign convention of
    /// docs/model.md#newton).
    pub fn standstill_leakage(
        &self,
        rig: &Rig,
        s: &Standstill,
        c12: f64,
    ) -> Result<Leakage, String> {
        let si = &self.si;
        let p1 = s.p1_bar * PA_PER_BAR;
        let p2 = rig.p2_at_rest_bar(s.p1_bar) * PA_PER_BAR;
        // the steady state must be one the circuit can hold (docs/model.md#cavitation)
        crate::cavitation::check_chambers(&[s.p1_bar, p2 / PA_PER_BAR]).map_err(|e| {
            format!(
                "standstill p1_bar = {} with external force {} N: the force balance puts {e}",
                s.p1_bar, si.f_ext
            )
        })?;
        if p2 <= 0.0 {
            return Err(format!(
                "standstill p1_bar = {} with external force {} N gives p2 = {:.3} bar <= 0",
                s.p1_bar,
                si.f_ext,
                p2 / PA_PER_BAR
            ));
        }
        let (w1, w2) = (s.w1_rpm * RAD_S_PER_RPM, s.w2_rpm * RAD_S_PER_RPM);
        let cross = c12 * (p1 - p2);
        Ok(Leakage {
            p2_bar: p2 / PA_PER_BAR,
            c12_m5_per_ns: c12,
            c1_m5_per_ns: (si.d[0] * w1 + si.d[1] * w2 - cross) / p1,
            c2_m5_per_ns: (-si.d[0] * w1 + cross) / p2,
        })
    }
}

/// A standstill operating point held under feedback: pump speeds feeding the leakage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Standstill {
    /// Motor/pump 1 speed (rpm); negative: turning backwards.
    pub w1_rpm: f64,
    /// Motor/pump 2 speed (rpm).
    pub w2_rpm: f64,
    /// Chamber 1 pressure (bar gauge).
    pub p1_bar: f64,
}

/// The leakages that hold a standstill point for a given cross-port leakage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Leakage {
    /// Chamber 2 pressure from the force balance p1 A1 − p2 A2 = F_ext (bar gauge).
    pub p2_bar: f64,
    /// Cross-port leakage used (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// Chamber 1 leakage (m⁵/(N·s)).
    pub c1_m5_per_ns: f64,
    /// Chamber 2 leakage (m⁵/(N·s)); negative values absorb a pump null shift.
    pub c2_m5_per_ns: f64,
}

/// The standstill balance at one pressure pair: the flows the pumps deliver to feed the
/// leakage, the power that leakage loses and the torques that hold the pressures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Balance {
    /// Pump flows, pumps 1 and 2 (m³/s).
    pub flow_m3_s: [f64; 2],
    /// Hydraulic power lost to leakage, Σ p × Q (W).
    pub power_w: f64,
    /// Motor torques that hold the pressures, motors 1 and 2 (N·m).
    pub torque_nm: [f64; 2],
}

impl Dpm {
    /// The load torques of the pumps on motors 1 and 2 (N·m) at the chamber pressures `p_pa`
    /// (Pa gauge): pump 1 moves oil from chamber 2 to chamber 1, D1 (p1 − p2); pump 2 from the
    /// reservoir to chamber 1, D2 p1 (docs/model.md).
    pub fn load_torques_nm(&self, p_pa: [f64; 2]) -> [f64; 2] {
        let (d, [p1, p2]) = (self.si.d, p_pa);
        [d[0] * (p1 - p2), d[1] * p1]
    }

    /// The standstill balance at the chamber pressures `p_pa` (Pa gauge; docs/select.md#cost):
    /// pump 1 moves oil from chamber 2 to chamber 1 against p1 − p2, pump 2 from the reservoir
    /// to chamber 1 against p1; at rest they deliver exactly the leakage,
    /// D1 ω1 = c12 (p1 − p2) − c2 p2 and D1 ω1 + D2 ω2 = c1 p1 + c12 (p1 − p2),
    /// and the power lost is c1 p1² + c2 p2² + c12 (p1 − p2)², which equals the pumps'
    /// hydraulic power (p1 − p2) D1 ω1 + p1 D2 ω2.
    pub fn standstill_balance(&self, p_pa: [f64; 2]) -> Balance {
        let (si, [p1, p2]) = (&self.si, p_pa);
        let q1 = si.c12 * (p1 - p2) - si.c2 * p2;
        let q2 = si.c1 * p1 + si.c12 * (p1 - p2) - q1;
        Balance {
            flow_m3_s: [q1, q2],
            power_w: si.c1 * p1 * p1 + si.c2 * p2 * p2 + si.c12 * (p1 - p2) * (p1 - p2),
            torque_nm: self.load_torques_nm(p_pa),
        }
    }
}

/// One entry of A that depends on the grey-box parameters: position (0-based), its value at
/// given parameters, and the MATLAB expression that computes it (docs/matlab.md).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamEntry {
    /// Row (0-based).
    pub row: usize,
    /// Column (0-based).
    pub col: usize,
    /// Value at the parameters given (SI).
    pub value: f64,
    /// The same in MATLAB, from the variables of the grey-box function.
    pub expr: &'static str,
}

impl Dpm {
    /// The entries of the linear model's A that depend on β, b and the leakages (the piston's
    /// viscous friction and the two continuity equations, the article's model;
    /// docs/matlab.md), each with its value at (`beta` Pa, `b` N·s/m, `c1`, `c2`, `c12`
    /// m⁵/(N·s)) and its MATLAB expression. The controller and the motors add nothing to these
    /// rows (their inputs are the motors).
    pub fn param_entries(&self, beta: f64, b: f64, [c1, c2, c12]: [f64; 3]) -> Vec<ParamEntry> {
        let (l, si) = (&self.layout, &self.si);
        let (k1, k2) = (beta / si.v1, beta / si.v2);
        let e = |row, col, value, expr| ParamEntry {
            row,
            col,
            value,
            expr,
        };
        let (v, [p1, p2], [w1, w2]) = (l.v, l.p, l.w);
        vec![
            e(v, v, -b / si.mass, "-b/m"),
            e(p1, w1, k1 * si.d[0], "k1*D1"),
            e(p1, w2, k1 * si.d[1], "k1*D2"),
            e(p1, v, -k1 * si.a1, "-k1*A1"),
            e(p1, p1, -k1 * (c1 + c12), "-k1*(c1 + c12)"),
            e(p1, p2, k1 * c12, "k1*c12"),
            e(p2, w1, -k2 * si.d[0], "-k2*D1"),
            e(p2, v, k2 * si.a2, "k2*A2"),
            e(p2, p2, -k2 * (c2 + c12), "-k2*(c2 + c12)"),
            e(p2, p1, k2 * c12, "k2*c12"),
        ]
    }
}

impl Dpm {
    /// The net flows (m³/s) into chambers 1 and 2 at state `x`: the pumps, the piston's
    /// displacement and the leakages.
    fn chamber_flows<T: Scalar>(&self, x: &[T]) -> [T; 2] {
        let (l, si) = (&self.layout, &self.si);
        let v = x[l.v];
        let (p1, p2) = (x[l.p[0]], x[l.p[1]]);
        let (w1, w2) = (x[l.w[0]], x[l.w[1]]);
        // pump 1 slips from chamber 1 to 2, pump 2 from chamber 1 to the reservoir
        let q1 = self.pumps[0].flow(w1, p1 - p2);
        let q2 = self.pumps[1].flow(w2, p1);
        let cross = (p1 - p2) * si.c12;
        let in1 = q1 + q2 - v * si.a1 - p1 * si.c1 - cross;
        let in2 = -q1 + v * si.a2 - p2 * si.c2 + cross;
        [in1, in2]
    }

    /// Where the power goes at state `x` under commands `u` (docs/energy.md): the drives'
    /// shaft power, the pumps' slip and dead band, the leakages, the cylinder.
    fn power_at(&self, x: &[f64], u: &[f64]) -> Power {
        let (l, si) = (&self.layout, &self.si);
        let mut dx = vec![0.0; x.len()];
        self.rhs(x, u, &mut dx);
        let mut power = Power::default();
        let s = [x[l.x], x[l.v], x[l.p[0]], x[l.p[1]]];
        energy::cylinder(&self.piston, s, self.chamber_flows(x), dx[l.v], &mut power);
        let [_, _, p1, p2] = s;
        let coupled = self.coupling;
        energy::pump(&self.pumps[0], x[l.w[0]], p1 - p2, coupled, &mut power);
        energy::pump(&self.pumps[1], x[l.w[1]], p1, coupled, &mut power);
        let leaks = energy::leak(si.c1, p1, 0.0)
            + energy::leak(si.c2, p2, 0.0)
            + energy::leak(si.c12, p1, p2);
        power.loss("leakage", leaks);
        if let Motors::Full(drives, tau) = &self.motors {
            let load = self.loads(x);
            let at = [0, 1].map(|i| energy::DriveAt {
                drive: &drives[i],
                state: [x[l.w[i]], x[tau[i]]],
                dw: dx[l.w[i]],
                load: load[i],
            });
            energy::drives(&self.electrics, &at, &mut power);
        }
        power
    }

    /// The pumps' load torques on the drives (N·m) at state `x`: pump 1's D1 (p1 − p2), pump
    /// 2's D2 p1, each with its friction ([`Pump::friction_torque`]); none without the
    /// motor–hydraulics coupling.
    fn loads<T: Scalar>(&self, x: &[T]) -> [T; 2] {
        let (l, si) = (&self.layout, &self.si);
        let (p1, p2) = (x[l.p[0]], x[l.p[1]]);
        if self.coupling {
            let dp = [p1 - p2, p1];
            [0, 1].map(|i| dp[i] * si.d[i] + self.pumps[i].friction_torque(x[l.w[i]], dp[i]))
        } else {
            [T::from(0.0); 2]
        }
    }
}

impl Circuit for Dpm {
    fn kind(&self) -> CircuitKind {
        CircuitKind::Dpm
    }

    fn states(&self) -> Vec<Signal> {
        let s = Signal::new;
        let mut out = vec![
            s("x", "m", "piston position", Role::Position),
            s("v", "m/s", "piston velocity", Role::Velocity),
            s("p1", "Pa", "chamber 1 pressure", Role::Pressure),
            s("p2", "Pa", "chamber 2 pressure", Role::Pressure),
            s("w1", "rad/s", "motor/pump 1 speed", Role::MotorSpeed),
            s("w2", "rad/s", "motor/pump 2 speed", Role::MotorSpeed),
        ];
        if self.layout.tau.is_some() {
            out.extend([
                s(
                    "tau1",
                    "N*m",
                    "motor 1 electromagnetic torque",
                    Role::Torque,
                ),
                s(
                    "tau2",
                    "N*m",
                    "motor 2 electromagnetic torque",
                    Role::Torque,
                ),
            ]);
        }
        if self.layout.ff.is_some() {
            out.extend([
                s(
                    "z1",
                    "rad/s",
                    "drive 1 feedforward filter",
                    Role::Feedforward,
                ),
                s(
                    "z2",
                    "rad/s",
                    "drive 2 feedforward filter",
                    Role::Feedforward,
                ),
            ]);
        }
        out
    }

    fn inputs(&self) -> Vec<Signal> {
        vec![
            Signal::new(
                "w_ref1",
                "rad/s",
                "motor 1 speed command",
                Role::SpeedCommand,
            ),
            Signal::new(
                "w_ref2",
                "rad/s",
                "motor 2 speed command",
                Role::SpeedCommand,
            ),
        ]
    }

    fn rhs<T: Scalar>(&self, x: &[T], u: &[T], dx: &mut [T]) {
        let l = &self.layout;
        let cylinder = (&self.piston, &self.chambers, &self.fluid);
        let at = [l.x, l.v, l.p[0], l.p[1]];
        cylinder_rates(cylinder, at, x, self.chamber_flows(x), dx);
        match &self.motors {
            Motors::Full(drives, tau) => {
                let load = self.loads(x);
                for i in 0..2 {
                    let z = l.ff.map(|ff| x[ff[i]]);
                    let r = drives[i].rates(u[i], x[l.w[i]], x[tau[i]], z, load[i]);
                    dx[l.w[i]] = r.speed;
                    dx[tau[i]] = r.torque;
                    if let (Some(ff), Some(dz)) = (l.ff, r.feedforward) {
                        dx[ff[i]] = dz;
                    }
                }
            }
            Motors::FirstOrder(motors) => {
                for (i, m) in motors.iter().enumerate() {
                    dx[l.w[i]] = m.acceleration(u[i], x[l.w[i]]);
                }
            }
        }
    }

    /// The regimes of the two drives ([`Drive::regime`]), drive 1's plus 6 times drive 2's;
    /// first-order motors have none.
    fn drive_regime(&self, x: &[f64], u: &[f64]) -> Option<u64> {
        let Motors::Full(drives, tau) = &self.motors else {
            return Some(0);
        };
        let l = &self.layout;
        let load = self.loads(x);
        let regime = |i: usize| {
            let z = l.ff.map(|ff| x[ff[i]]);
            drives[i].regime(u[i], x[l.w[i]], x[tau[i]], z, load[i])
        };
        Some(regime(0) + 6 * regime(1))
    }

    fn operating_point(&self) -> OperatingState {
        let (state, u) = self.rest_state(self.coupling);
        OperatingState {
            state,
            inputs: u.to_vec(),
        }
    }

    fn control_law(&self) -> ControlLaw {
        self.law(self.sum_pressure)
    }
}

/// The DPM circuit as the list of circuits knows it (docs/architecture.md#circuits).
pub struct Module;

impl super::Module for Module {
    const DESCRIPTION: super::Description = super::Description {
        name: "dpm",
        fmu_words: "dual-prime-mover",
        controller_words: "with the article's position and sum-pressure controller",
        drives: 2,
        servo_valves: 0,
        pumps: 2,
        variants: &[
            super::Variant {
                level: super::PressureLevel::LowPressure,
                name: "low-pressure",
                key: "low_pressure",
            },
            super::Variant {
                level: super::PressureLevel::Pressurised,
                name: "pressurised",
                key: "pressurised",
            },
        ],
        sum_pressure_loop: true,
        level: super::Level {
            key: "p_sum_ref_bar",
            words: "the rig's mean chamber pressure at rest",
            at_emulated_rest: true,
        },
        valves: None,
        own_keys: &[
            "motor_inertia_2_kg_mm2",
            "km2_nms_per_rad",
            "p_sum_ref_bar",
            "k_pres_per_bar",
            "k_beta",
            "sum_pressure",
            "pump_inertia_2_kg_mm2",
            "displacement_2_cm3_per_rev",
        ],
        keys: &energy::LOSS_KEYS,
        no_modes: Some(NO_MODES),
    };
    type Linear = Dpm;
    type Emulated = Dpm;

    fn linear(rig: &Rig) -> Dpm {
        Dpm::linear(rig)
    }

    fn emulated(rig: &Rig, effects: Effects) -> Result<Dpm, String> {
        Ok(Dpm::emulated(rig, effects))
    }

    fn validate_rest(rig: &Rig) -> Result<(), (&'static str, f64, String)> {
        rig.validate_rest()
            .map_err(|rule| ("external_force_n", rig.external_force_n, rule))
    }

    /// The sum-pressure set-point split evenly: its loop holds p1 + p2 there
    /// (docs/model.md#the-dpm-control-law).
    fn pressure_level_bar(rig: &Rig) -> f64 {
        0.5 * rig.p_sum_ref_bar
    }

    /// The cavitation floor and no upper edge: no valve limits its chambers.
    fn pressure_band_bar(_rig: &Rig) -> [(f64, &'static str); 2] {
        use crate::cavitation::VAPOUR_PRESSURE_BAR_GAUGE as FLOOR;
        [(FLOOR, "the cavitation floor"), (f64::INFINITY, "")]
    }
}

impl super::LinearForm for Dpm {
    fn law(&self, sum_pressure: bool) -> ControlLaw {
        Dpm::law(self, sum_pressure)
    }
    fn load_torques_nm(&self, p_pa: [f64; 2]) -> [f64; 2] {
        Dpm::load_torques_nm(self, p_pa)
    }
    fn describe(&self) -> String {
        <Module as super::Module>::DESCRIPTION.name.to_string()
    }
    /// Motor 2's speed is needed: a record without its column `w2_rpm` cannot give it.
    fn standstill_leakage(
        &self,
        rig: &Rig,
        s: &Standstill,
        c12: f64,
    ) -> Option<Result<Leakage, String>> {
        if s.w2_rpm.is_nan() {
            return Some(Err("standstill `w2_rpm` = NaN: the dpm circuit's standstill needs \
                 motor 2's mean speed (a record's column `w2_rpm`)"
                .to_string()));
        }
        Some(Dpm::standstill_leakage(self, rig, s, c12))
    }
}

impl super::EmulatedForm for Dpm {
    emulated_form_calls!(Dpm, order);
    fn rest_with_commands(&self) -> (Vec<f64>, [f64; 2]) {
        self.rest_state(true)
    }
    fn commands(&self, rig: &Rig, r_mm: f64, x_mm: f64, p_bar: &[f64]) -> [f64; 2] {
        self.plc_commands(rig, r_mm, x_mm, p_bar)
    }
    fn power(&self, s: &[f64], u: &[f64]) -> Power {
        self.power_at(s, u)
    }
}

impl super::AnyCircuit {
    /// The DPM circuit, for what only it has (its grey-box entries, its standstill, its two
    /// drives); `None` for another circuit's model.
    pub fn dpm(&self) -> Option<&Dpm> {
        if let super::AnyCircuit::Dpm(dpm) = self {
            return Some(dpm);
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::circuit::linearise;

    // The hand-derived linear model of the article §2.3.1 (Figure 4), as it was written before
    // the circuit's equations were differentiated: the reference the Jacobian must equal.

    /// Newton on the piston and continuity in both chambers (docs/model.md#newton, docs/model.md#continuity).
    fn hydraulics(l: &Layout, si: &RigSi, a: &mut DMatrix<f64>) {
        let (x, v, [p1, p2], [w1, w2]) = (l.x, l.v, l.p, l.w);
        a[(x, v)] = 1.0;
        a[(v, p1)] = si.a1 / si.mass;
        a[(v, p2)] = -si.a2 / si.mass;
        a[(v, v)] = -si.b / si.mass;
        let k1 = si.beta / si.v1;
        a[(p1, w1)] = k1 * si.d[0];
        a[(p1, w2)] = k1 * si.d[1];
        a[(p1, v)] = -k1 * si.a1;
        a[(p1, p1)] = -k1 * (si.c1 + si.c12);
        a[(p1, p2)] = k1 * si.c12;
        let k2 = si.beta / si.v2;
        a[(p2, w1)] = -k2 * si.d[0];
        a[(p2, v)] = k2 * si.a2;
        a[(p2, p2)] = -k2 * (si.c2 + si.c12);
        a[(p2, p1)] = k2 * si.c12;
    }

    /// Full motors: inertia with load torque, first-order current loop, P velocity loop and the
    /// filtered velocity feedforward (docs/model.md#drive-velocity-loops-and-feedforward, docs/choices.md#feedforward-as-a-torque-after-the-p-gain).
    fn full_motors(
        l: &Layout,
        si: &RigSi,
        tau: [usize; 2],
        coupling: bool,
        a: &mut DMatrix<f64>,
        b: &mut DMatrix<f64>,
    ) {
        let [p1, p2] = l.p;
        for i in 0..2 {
            let (w, t) = (l.w[i], tau[i]);
            a[(w, t)] = 1.0 / si.j[i];
            a[(t, t)] = -si.omega_i;
            a[(t, w)] = -si.omega_i * si.km[i];
            b[(t, i)] = si.omega_i * si.km[i];
            if let Some(ff) = l.ff {
                let kf = si.kff / si.tau_ff;
                a[(t, ff[i])] = -si.omega_i * kf;
                b[(t, i)] += si.omega_i * kf;
                a[(ff[i], ff[i])] = -1.0 / si.tau_ff;
                b[(ff[i], i)] = 1.0 / si.tau_ff;
            }
        }
        if coupling {
            // J1 ω̇1 = τ1 − D1 (p1 − p2),  J2 ω̇2 = τ2 − D2 p1
            a[(l.w[0], p1)] = -si.d[0] / si.j[0];
            a[(l.w[0], p2)] = si.d[0] / si.j[0];
            a[(l.w[1], p1)] = -si.d[1] / si.j[1];
        }
    }

    /// First-order motors ω/ω_ref = 1/(τ s + 1): no load torque, no feedforward.
    fn first_order_motors(l: &Layout, si: &RigSi, a: &mut DMatrix<f64>, b: &mut DMatrix<f64>) {
        for i in 0..2 {
            a[(l.w[i], l.w[i])] = -1.0 / si.tau_motor[i];
            b[(l.w[i], i)] = 1.0 / si.tau_motor[i];
        }
    }

    /// The hand-derived (A, B) of a rig.
    fn hand_model(rig: &Rig) -> (DMatrix<f64>, DMatrix<f64>) {
        let layout = Layout::for_rig(rig);
        let si = rig.si();
        let mut a = DMatrix::zeros(layout.n, layout.n);
        let mut b = DMatrix::zeros(layout.n, 2);
        hydraulics(&layout, &si, &mut a);
        match (rig.motor_model, layout.tau) {
            (MotorModel::Full, Some(tau)) => {
                full_motors(&layout, &si, tau, rig.motor_coupling, &mut a, &mut b)
            }
            _ => first_order_motors(&layout, &si, &mut a, &mut b),
        }
        (a, b)
    }

    /// Every variant the rig allows: motor model, feedforward, motor coupling.
    fn variants(base: &Rig) -> Vec<Rig> {
        let mut out = Vec::new();
        for motor_model in [MotorModel::Full, MotorModel::FirstOrder] {
            for feedforward in [true, false] {
                for motor_coupling in [true, false] {
                    out.push(Rig {
                        motor_model,
                        feedforward,
                        motor_coupling,
                        ..base.clone()
                    });
                }
            }
        }
        out
    }

    /// Entries that differ by more than `rel` of their size (or of `floor` for zeros).
    fn differing(got: &DMatrix<f64>, want: &DMatrix<f64>, rel: f64) -> Vec<String> {
        assert_eq!(got.shape(), want.shape());
        (0..got.nrows())
            .flat_map(|i| (0..got.ncols()).map(move |j| (i, j)))
            .filter(|&(i, j)| {
                let (g, w) = (got[(i, j)], want[(i, j)]);
                (g - w).abs() > rel * g.abs().max(w.abs())
            })
            .map(|(i, j)| format!("[{i}][{j}] {} vs {}", got[(i, j)], want[(i, j)]))
            .collect()
    }

    #[test]
    fn the_jacobian_is_the_hand_derived_model_for_every_variant() {
        for rig in variants(&Rig::default()) {
            let c = Dpm::linear(&rig);
            let op = c.operating_point();
            let (a, b) = linearise(&c, &op.state, &op.inputs);
            let (ha, hb) = hand_model(&rig);
            let n = 6 + 2
                * usize::from(rig.motor_model == MotorModel::Full)
                * (1 + usize::from(rig.feedforward));
            assert_eq!((a.nrows(), c.states().len()), (n, n));
            assert_eq!(differing(&a, &ha, 0.0), Vec::<String>::new(), "A");
            assert_eq!(differing(&b, &hb, 0.0), Vec::<String>::new(), "B");
        }
    }

    /// The typical size of each state of `c` (SI), by role.
    fn typical(c: &Dpm) -> Vec<f64> {
        (c.states().iter()).map(|s| s.role.typical_size()).collect()
    }

    /// Central-difference Jacobians of `c`'s equations at (x, u), steps 1e-4 of each state's
    /// typical size (10 rad/s for the commands).
    fn central_differences(c: &Dpm, x: &[f64], u: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
        let (n, m) = (x.len(), u.len());
        let scale = typical(c);
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, m);
        let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
        for j in 0..n + m {
            let h = 1e-4 * if j < n { scale[j] } else { 10.0 };
            let (mut xp, mut xm, mut up, mut um) = (x.to_vec(), x.to_vec(), u.to_vec(), u.to_vec());
            if j < n {
                xp[j] += h;
                xm[j] -= h;
            } else {
                up[j - n] += h;
                um[j - n] -= h;
            }
            c.rhs(&xp, &up, &mut fp);
            c.rhs(&xm, &um, &mut fm);
            for i in 0..n {
                let d = (fp[i] - fm[i]) / (2.0 * h);
                if j < n {
                    a[(i, j)] = d;
                } else {
                    b[(i, j - n)] = d;
                }
            }
        }
        (a, b)
    }

    /// Entries of the Jacobian `exact` the differences `fd` miss by more than 1e-6 of the
    /// entry, with a floor of 1e-9 of the row's typical rate per column size for zeros.
    fn missed(c: &Dpm, fd: &DMatrix<f64>, exact: &DMatrix<f64>, inputs: bool) -> Vec<String> {
        let scale = typical(c);
        let mut out = Vec::new();
        for i in 0..fd.nrows() {
            for j in 0..fd.ncols() {
                let col = if inputs { 10.0 } else { scale[j] };
                let (d, e) = (fd[(i, j)], exact[(i, j)]);
                if (d - e).abs() > 1e-6 * e.abs() + 1e-9 * scale[i] / col {
                    out.push(format!("[{i}][{j}] {d} vs {e}"));
                }
            }
        }
        out
    }

    #[test]
    fn the_jacobian_is_the_central_differences_of_the_nonlinear_equations() {
        // every effect on (the limits are idle here), away from the rest so the flows, the
        // gas-fraction β_e(p), the volumes, the mass law and the friction all have slopes
        let rig = Rig::default();
        let effects = Effects {
            dead_band_rad_s: 300.0 * crate::units::RAD_S_PER_RPM,
            ..Effects::all(0.02)
        };
        for c in [Dpm::linear(&rig), Dpm::emulated(&rig, effects)] {
            let op = c.operating_point();
            let mut x = op.state.clone();
            let deviation = [3e-3, 2e-3, 0.4e5, -0.3e5, 2.0, -3.0, 0.05, -0.02, 1.0, -1.0];
            for (xi, d) in x.iter_mut().zip(deviation) {
                *xi += d;
            }
            let u = [op.inputs[0] + 1.5, op.inputs[1] - 2.5];
            let (a, b) = linearise(&c, &x, &u);
            let (fa, fb) = central_differences(&c, &x, &u);
            assert_eq!(missed(&c, &fa, &a, false), Vec::<String>::new(), "A");
            assert_eq!(missed(&c, &fb, &b, true), Vec::<String>::new(), "B");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 64,
            failure_persistence: None,
            ..Default::default()
        })]

        /// For random rigs (every size and gain scaled by 0.3…3, every variant) the Jacobian
        /// is the hand-derived model to 1e-10 of each entry.
        #[test]
        fn the_jacobian_is_the_hand_derived_model_for_random_rigs(
            f in proptest::collection::vec(0.3f64..3.0, 16),
            switches in 0u8..8,
            force in -2e4f64..2e4,
        ) {
            let d = Rig::default();
            let rig = Rig {
                piston_diameter_mm: d.piston_diameter_mm * f[0],
                rod_diameter_mm: d.piston_diameter_mm * f[0] * (0.2 + 0.25 * f[1]),
                line_volume_1_dm3: d.line_volume_1_dm3 * f[2],
                line_volume_2_dm3: d.line_volume_2_dm3 * f[3],
                mass_kg: d.mass_kg * f[4],
                beta_bar: d.beta_bar * f[5],
                viscous_friction_ns_per_m: d.viscous_friction_ns_per_m * f[6],
                c1_m5_per_ns: d.c1_m5_per_ns * f[7],
                c2_m5_per_ns: d.c2_m5_per_ns * f[8],
                c12_m5_per_ns: d.c12_m5_per_ns * f[9],
                km1_nms_per_rad: d.km1_nms_per_rad * f[10],
                km2_nms_per_rad: d.km2_nms_per_rad * f[11],
                kff_kg_m2: d.kff_kg_m2 * f[12],
                tau_ff_s: d.tau_ff_s * f[13],
                displacement_1_cm3_per_rev: d.displacement_1_cm3_per_rev * f[14],
                current_loop_bandwidth_rad_per_s: d.current_loop_bandwidth_rad_per_s * f[15],
                external_force_n: force,
                motor_model: if switches & 1 == 0 { MotorModel::Full } else { MotorModel::FirstOrder },
                feedforward: switches & 2 == 0,
                motor_coupling: switches & 4 == 0,
                ..d
            };
            // a rest below the vapour pressure is no rig (docs/model.md#cavitation)
            let rest = rig.si().rest_pressures_pa();
            proptest::prop_assume!(rest.iter().all(|p| *p > -0.9e5));
            let c = Dpm::linear(&rig);
            let op = c.operating_point();
            let (a, b) = linearise(&c, &op.state, &op.inputs);
            let (ha, hb) = hand_model(&rig);
            proptest::prop_assert_eq!(differing(&a, &ha, 1e-10), Vec::<String>::new());
            proptest::prop_assert_eq!(differing(&b, &hb, 1e-10), Vec::<String>::new());
        }
    }
}
