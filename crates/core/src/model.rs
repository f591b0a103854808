//! The linear DPM cylinder model (the article §2.3.1, Figure 4; docs/model.md) and its variants (docs/model.md#variants).
//!
//! States, in order (SI): `x` (m), `v` (m/s), `p1`, `p2` (Pa), `w1`, `w2` (rad/s), then for the
//! full motor model `tau1`, `tau2` (N·m, electromagnetic torques) and, with feedforward on,
//! `z1`, `z2` (rad/s, the feedforward filter states). The model is linear in deviations from a
//! steady operating point; the plant's inputs are the drive speed references ω_ref1, ω_ref2
//! (rad/s).
//!
//! The drive feedforward `Kff s/(τff s + 1)·ω_ref` is a torque added after the P gain
//! (docs/model.md#drive-velocity-loops-and-feedforward, docs/choices.md#feedforward-as-a-torque-after-the-p-gain). Written with a filter state z (τff ż = ω_ref − z) it is
//! `(Kff/τff)(ω_ref − z)`, so the torque reference is
//! `τ_ref = Km (ω_ref − ω) + (Kff/τff)(ω_ref − z)`.

use crate::lti::{StateInfo, StateSpace};
use crate::rig::{MotorModel, Rig, RigSi};
use nalgebra::DMatrix;

/// Names and SI units of the outputs of [`Plant::closed_loop_outputs`], in order.
pub const SIM_OUTPUTS: [(&str, &str); 6] = [
    ("x", "m"),
    ("p1", "Pa"),
    ("p2", "Pa"),
    ("w1", "rad/s"),
    ("w2", "rad/s"),
    ("e", "m"),
];

/// The steady operating point (SI; pressures gauge).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OperatingPoint {
    /// Position (m).
    pub x: f64,
    /// Chamber 1 pressure (Pa).
    pub p1: f64,
    /// Chamber 2 pressure (Pa).
    pub p2: f64,
    /// Motor 1 speed (rad/s).
    pub w1: f64,
    /// Motor 2 speed (rad/s).
    pub w2: f64,
}

/// Positions of the states in the state vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Piston position.
    pub x: usize,
    /// Piston velocity.
    pub v: usize,
    /// Chamber pressures p1, p2.
    pub p: [usize; 2],
    /// Motor speeds ω1, ω2.
    pub w: [usize; 2],
    /// Electromagnetic torques (full motor model only).
    pub tau: Option<[usize; 2]>,
    /// Feedforward filter states (full motor model with feedforward only).
    pub ff: Option<[usize; 2]>,
    /// Number of states.
    pub n: usize,
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

    /// Names and SI units of the states, in order.
    pub fn states(&self) -> Vec<StateInfo> {
        let s = |name: &str, unit: &str| StateInfo {
            name: name.into(),
            unit: unit.into(),
        };
        let mut out = vec![
            s("x", "m"),
            s("v", "m/s"),
            s("p1", "Pa"),
            s("p2", "Pa"),
            s("w1", "rad/s"),
            s("w2", "rad/s"),
        ];
        if self.tau.is_some() {
            out.extend([s("tau1", "N*m"), s("tau2", "N*m")]);
        }
        if self.ff.is_some() {
            out.extend([s("z1", "rad/s"), s("z2", "rad/s")]);
        }
        out
    }
}

/// The DPM plant: ẋ = A x + B ω_ref, with ω_ref = (ω_ref1, ω_ref2) in rad/s.
#[derive(Debug, Clone)]
pub struct Plant {
    /// State positions.
    pub layout: Layout,
    /// State matrix (SI).
    pub a: DMatrix<f64>,
    /// Input matrix, n × 2 (inputs ω_ref1, ω_ref2 in rad/s).
    pub b: DMatrix<f64>,
    /// The rig in SI units.
    pub si: RigSi,
}

impl Plant {
    /// Assemble the plant of the article §2.3.1, Figure 4; docs/model.md for a rig (its variant switches included).
    pub fn new(rig: &Rig) -> Plant {
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
        Plant { layout, a, b, si }
    }

    /// Controller law ω_ref = Kx·x + Kr·x_ref (rad/s) of docs/model.md#the-dpm-control-law with the position error
    /// e = x_ref − x and, optionally, the sum-pressure loop on −(Δp1 + Δp2):
    /// u1 = Kp e + K_pres (Δp1 + Δp2), u2 = Kp α e − K_pres Kβ (Δp1 + Δp2), ω_ref = K_scale u.
    /// Returns (Kx: 2 × n, Kr: 2 × 1).
    pub fn controller(&self, sum_pressure: bool) -> (DMatrix<f64>, DMatrix<f64>) {
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
        (kx, kr)
    }

    /// The open loop of the article §2.3.3; docs/analysis.md#the-loop-that-is-analysed, x_ref → x with the position feedback branch removed (SISO):
    /// input is the position error e (m), output x (m). With `sum_pressure` the sum-pressure
    /// loop stays closed inside; docs/analysis.md#the-loop-that-is-analysed analyses it open.
    pub fn open_loop(&self, sum_pressure: bool) -> StateSpace {
        let (kx, kr) = self.controller(sum_pressure);
        let mut kx_inner = kx;
        kx_inner.column_mut(self.layout.x).fill(0.0);
        let a = &self.a + &self.b * kx_inner;
        let b = &self.b * kr;
        self.siso(a, b)
    }

    /// The closed loop x_ref → x (SISO) with the position loop and, optionally, the sum-pressure
    /// loop closed.
    pub fn closed_loop(&self, sum_pressure: bool) -> StateSpace {
        let (a, b) = self.closed_ab(sum_pressure);
        self.siso(a, b)
    }

    /// The closed loop for simulation (the article §2.3.3; docs/simulation.md#exact-zero-order-hold): input x_ref (m, deviation); outputs
    /// [`SIM_OUTPUTS`]: x (m), p1, p2 (Pa), ω1, ω2 (rad/s) and the control error e = x_ref − x (m).
    pub fn closed_loop_outputs(&self, sum_pressure: bool) -> StateSpace {
        let (a, b) = self.closed_ab(sum_pressure);
        let l = &self.layout;
        let mut c = DMatrix::zeros(SIM_OUTPUTS.len(), l.n);
        for (row, state) in [l.x, l.p[0], l.p[1], l.w[0], l.w[1]]
            .into_iter()
            .enumerate()
        {
            c[(row, state)] = 1.0;
        }
        c[(5, l.x)] = -1.0;
        let mut d = DMatrix::zeros(SIM_OUTPUTS.len(), 1);
        d[(5, 0)] = 1.0;
        StateSpace::new(a, b, c, d).expect("the assembled model is consistent")
    }

    /// A and B of the closed loop with input x_ref.
    fn closed_ab(&self, sum_pressure: bool) -> (DMatrix<f64>, DMatrix<f64>) {
        let (kx, kr) = self.controller(sum_pressure);
        (&self.a + &self.b * kx, &self.b * kr)
    }

    /// The steady operating point the model is linearised about (SI, gauge pressures): x0, the
    /// pressures from the sum-pressure set-point and the force balance p1 A1 − p2 A2 = F_ext, and
    /// the pump speeds that feed the leakage at standstill (docs/identification.md#leakage-from-standstill solved for ω).
    pub fn operating_point(&self) -> OperatingPoint {
        let si = &self.si;
        let [p1, p2] = si.rest_pressures_pa();
        let cross = si.c12 * (p1 - p2);
        let w1 = (cross - si.c2 * p2) / si.d[0];
        let w2 = (si.c1 * p1 + cross - si.d[0] * w1) / si.d[1];
        OperatingPoint {
            x: si.x0,
            p1,
            p2,
            w1,
            w2,
        }
    }

    /// The operating point as a state of this plant's layout (absolute x0, gauge pressures,
    /// the leakage speeds; with the full motor model the torques that carry the pumps' load
    /// where `loaded`, none otherwise, and the feedforward filters settled) and the speed
    /// commands ω_ref (rad/s) that hold it.
    pub fn rest_state(&self, loaded: bool) -> (Vec<f64>, [f64; 2]) {
        let op = self.operating_point();
        let (l, si) = (&self.layout, &self.si);
        let mut x = vec![0.0; l.n];
        x[l.x] = op.x;
        x[l.p[0]] = op.p1;
        x[l.p[1]] = op.p2;
        x[l.w[0]] = op.w1;
        x[l.w[1]] = op.w2;
        let w = [op.w1, op.w2];
        // first-order motors: the speed settles at its command
        let Some(tau) = l.tau else { return (x, w) };
        let load = if loaded {
            [si.d[0] * (op.p1 - op.p2), si.d[1] * op.p1]
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

    /// Wrap A, B with output x and no feedthrough.
    fn siso(&self, a: DMatrix<f64>, b: DMatrix<f64>) -> StateSpace {
        let mut c = DMatrix::zeros(1, self.layout.n);
        c[(0, self.layout.x)] = 1.0;
        StateSpace::new(a, b, c, DMatrix::zeros(1, 1)).expect("the assembled model is consistent")
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lti::{eigenvalues, margins};

    #[test]
    fn default_rig_margins_match_the_article() {
        let m = margins(&Plant::new(&Rig::default()).open_loop(false)).unwrap();
        let gm = m.gain_margin_db.unwrap();
        let pm = m.phase_margin_deg.unwrap();
        assert!((gm - 6.5).abs() <= 0.1, "GM {gm}");
        assert!((pm - 33.5).abs() <= 0.5, "PM {pm}");
        assert!(m.closed_loop_stable);
        assert_eq!(m.integrators, 1);
    }

    #[test]
    fn flow_matching_gives_velocity_gain_d1_over_a2() {
        // With α flow matching, the steady open-loop velocity per unit error is
        // Kp K_scale D1 / A2 (pump 1 alone feeds the annulus): check the low-frequency
        // asymptote |L(jω)| ω → Kv (leakage makes it approximate: 2 %).
        let plant = Plant::new(&Rig::default());
        let si = plant.si;
        let kv = si.kp * si.k_scale * si.d[0] / si.a2;
        let ev = crate::lti::FreqEvaluator::new(&plant.open_loop(false)).unwrap();
        let w = 1e-4;
        let kv_measured = ev.at(w).norm() * w;
        assert!(
            (kv_measured / kv - 1.0).abs() < 0.02,
            "{kv_measured} vs {kv}"
        );
    }

    #[test]
    fn variants_change_the_state_count() {
        let full = Plant::new(&Rig::default());
        assert_eq!(full.layout.n, 10);
        assert_eq!(full.layout.states().len(), 10);
        let no_ff = Plant::new(&Rig {
            feedforward: false,
            ..Rig::default()
        });
        assert_eq!(no_ff.layout.n, 8);
        let first = Plant::new(&Rig {
            motor_model: MotorModel::FirstOrder,
            ..Rig::default()
        });
        assert_eq!(first.layout.n, 6);
        // first-order motor pole at −Km/J
        let p = eigenvalues(&first.a).unwrap();
        let want = -first.si.km[0] / first.si.j[0];
        assert!(
            p.iter().any(|z| (z.re - want).abs() < 1e-9 && z.im == 0.0),
            "{p:?}"
        );
    }

    #[test]
    fn decoupled_motor_speeds_ignore_pressure() {
        let rig = Rig {
            motor_coupling: false,
            ..Rig::default()
        };
        let plant = Plant::new(&rig);
        let l = plant.layout;
        for w in l.w {
            for p in l.p {
                assert_eq!(plant.a[(w, p)], 0.0);
            }
        }
    }

    #[test]
    fn operating_point_reproduces_the_article_standstill() {
        // docs/identification.md#leakage-from-standstill: ω1 ≈ −160 rpm, ω2 ≈ 245 rpm at p1 ≈ 3.95 bar, p2 ≈ 5.86 bar; the model's
        // point (p1 + p2 = 10 bar exactly) is close: within 5 %.
        let op = Plant::new(&Rig::default()).operating_point();
        let rpm = 60.0 / (2.0 * std::f64::consts::PI);
        assert!((op.w1 * rpm / -160.0 - 1.0).abs() < 0.05, "{}", op.w1 * rpm);
        assert!((op.w2 * rpm / 245.0 - 1.0).abs() < 0.05, "{}", op.w2 * rpm);
        assert!((op.p1 + op.p2 - 10e5).abs() < 1e-6);
        let si = Rig::default().si();
        assert!((op.p1 * si.a1 - op.p2 * si.a2).abs() < 1e-9);
    }

    #[test]
    fn closed_loop_with_sum_pressure_is_stable_with_unit_dc_gain() {
        let plant = Plant::new(&Rig::default());
        for sp in [false, true] {
            let cl = plant.closed_loop(sp);
            let p = eigenvalues(&cl.a).unwrap();
            assert!(crate::lti::is_stable(&p), "sum_pressure={sp}: {p:?}");
            // type-1 loop: DC gain x/x_ref = 1, from the solve A x = −B
            let x = cl.a.clone().lu().solve(&(-&cl.b)).unwrap();
            let dc = (&cl.c * x)[(0, 0)];
            assert!((dc - 1.0).abs() < 1e-9, "dc {dc}");
        }
    }
}
