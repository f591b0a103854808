//! The linear DPM cylinder model (the article §2.3.1, Figure 4; docs/model.md) and its
//! variants (docs/model.md#variants): the exact Jacobian of the DPM circuit's nonlinear
//! equations ([`crate::circuit::dpm`]) at its operating point, every effect off
//! ([`crate::circuit::linearise`]). The model is linear in deviations from that point; its
//! states are the circuit's ([`Plant::signals`]), its inputs the drive speed references
//! (rad/s).

use crate::circuit::{
    linearise, AnyCircuit, Circuit, ControlLaw, Dpm, OperatingState, Role, Signal,
};
use crate::lti::{StateInfo, StateSpace};
use crate::rig::{Rig, RigSi};
use nalgebra::DMatrix;

/// An output of the simulated closed loop ([`Plant::closed_loop_outputs`]): a state of the
/// circuit, or the control error.
#[derive(Debug, Clone, PartialEq)]
pub struct Output {
    /// Name, e.g. `x` or `e`.
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// What it is.
    pub meaning: String,
    /// The state it is, `None` for the control error e = x_ref − x.
    pub state: Option<usize>,
    /// Its role, `None` for the control error.
    pub role: Option<Role>,
}

/// The closed loop at rest with the piston at x0 ([`Plant::rest`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Rest {
    /// The standing control error x_ref − x (m): the reference that holds the piston at x0 is
    /// x0 plus this, and every reference rests this far from the position it reaches.
    pub offset_m: f64,
    /// The state there (absolute position x0, gauge pressures, SI), in the circuit's order.
    pub state: Vec<f64>,
}

/// The plant: ẋ = A x + B u, u the drive speed references (rad/s), of a rig's circuit.
#[derive(Debug, Clone)]
pub struct Plant {
    /// The circuit the model is the Jacobian of.
    pub circuit: AnyCircuit,
    /// State matrix (SI).
    pub a: DMatrix<f64>,
    /// Input matrix, states × inputs (speed references in rad/s).
    pub b: DMatrix<f64>,
    /// The rig in SI units.
    pub si: RigSi,
}

impl Plant {
    /// The plant of the article §2.3.1, Figure 4; docs/model.md for a rig (its variant switches
    /// included): the exact Jacobian of the circuit's equations at its operating point.
    pub fn new(rig: &Rig) -> Plant {
        Plant::of(rig, AnyCircuit::linear(rig))
    }

    /// The plant of `rig` in the linear model `circuit` (one of [`AnyCircuit::linear_modes`]):
    /// its Jacobian at its operating point.
    pub fn of(rig: &Rig, circuit: AnyCircuit) -> Plant {
        let op = circuit.operating_point();
        let (a, b) = linearise(&circuit, &op.state, &op.inputs);
        Plant {
            si: rig.si(),
            circuit,
            a,
            b,
        }
    }

    /// The circuit this is the linear model of.
    pub fn circuit(&self) -> &AnyCircuit {
        &self.circuit
    }

    /// The DPM circuit, for what only it has ([`AnyCircuit::dpm`]); `None` for another circuit.
    pub fn dpm(&self) -> Option<&Dpm> {
        self.circuit.dpm()
    }

    /// Number of states.
    pub fn n(&self) -> usize {
        self.a.nrows()
    }

    /// The circuit's states, in order.
    pub fn signals(&self) -> Vec<Signal> {
        self.circuit.states()
    }

    /// Names and SI units of the states, in order.
    pub fn states(&self) -> Vec<StateInfo> {
        (self.signals().into_iter())
            .map(|s| StateInfo {
                name: s.name,
                unit: s.unit,
            })
            .collect()
    }

    /// The position of the first state with `role` (the position always exists).
    pub fn state_of(&self, role: Role) -> Option<usize> {
        self.circuit.state_of(role)
    }

    /// The positions of every state with `role`, in order.
    pub fn states_of(&self, role: Role) -> Vec<usize> {
        self.circuit.states_of(role)
    }

    /// The position of the piston position in the state.
    pub fn position(&self) -> usize {
        self.state_of(Role::Position)
            .expect("every circuit has a piston position")
    }

    /// The controller law u = Kx·x + Kr·x_ref (rad/s) of docs/model.md#the-dpm-control-law,
    /// with the sum-pressure loop where `sum_pressure`. Returns (Kx: inputs × n, Kr: inputs × 1).
    pub fn controller(&self, sum_pressure: bool) -> (DMatrix<f64>, DMatrix<f64>) {
        let ControlLaw { kx, kr } = self.circuit.law(sum_pressure);
        (kx, kr)
    }

    /// The open loop of the article §2.3.3; docs/analysis.md#the-loop-that-is-analysed, x_ref → x with the position feedback branch removed (SISO):
    /// input is the position error e (m), output x (m). With `sum_pressure` the sum-pressure
    /// loop stays closed inside; docs/analysis.md#the-loop-that-is-analysed analyses it open.
    pub fn open_loop(&self, sum_pressure: bool) -> StateSpace {
        let (kx, kr) = self.controller(sum_pressure);
        let mut kx_inner = kx;
        kx_inner.column_mut(self.position()).fill(0.0);
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

    /// The outputs of [`Plant::closed_loop_outputs`], in order: the position, each pressure,
    /// each motor speed (the circuit's names), then the control error e = x_ref − x (m).
    pub fn outputs(&self) -> Vec<Output> {
        let signals = self.signals();
        let mut out: Vec<Output> = [Role::Position, Role::Pressure, Role::MotorSpeed]
            .into_iter()
            .flat_map(|role| self.states_of(role))
            .map(|i| Output {
                name: signals[i].name.clone(),
                unit: signals[i].unit.clone(),
                meaning: signals[i].meaning.clone(),
                state: Some(i),
                role: Some(signals[i].role),
            })
            .collect();
        out.push(Output {
            name: "e".into(),
            unit: "m".into(),
            meaning: "control error x_ref - x".into(),
            state: None,
            role: None,
        });
        out
    }

    /// The closed loop for simulation (the article §2.3.3; docs/simulation.md#exact-zero-order-hold): input x_ref (m, deviation); outputs
    /// [`Plant::outputs`]: the position (m), each pressure (Pa), each motor speed (rad/s) and
    /// the control error e = x_ref − x (m).
    pub fn closed_loop_outputs(&self, sum_pressure: bool) -> StateSpace {
        let (a, b) = self.closed_ab(sum_pressure);
        let outputs = self.outputs();
        let mut c = DMatrix::zeros(outputs.len(), self.n());
        let mut d = DMatrix::zeros(outputs.len(), 1);
        for (row, o) in outputs.iter().enumerate() {
            match o.state {
                Some(i) => c[(row, i)] = 1.0,
                None => {
                    c[(row, self.position())] = -1.0;
                    d[(row, 0)] = 1.0;
                }
            }
        }
        StateSpace::new(a, b, c, d).expect("the assembled model is consistent")
    }

    /// A and B of the closed loop with input x_ref.
    fn closed_ab(&self, sum_pressure: bool) -> (DMatrix<f64>, DMatrix<f64>) {
        let (kx, kr) = self.controller(sum_pressure);
        (&self.a + &self.b * kx, &self.b * kr)
    }

    /// The steady operating point the model is linearised about (SI, absolute position, gauge
    /// pressures) and the speed commands that hold it ([`Circuit::operating_point`]).
    pub fn operating_point(&self) -> OperatingState {
        self.circuit.operating_point()
    }

    /// The operating point as a state with the drives carrying the pumps' load where `loaded`
    /// (none otherwise), and the speed commands (rad/s) that hold it.
    /// `None` for a circuit other than the DPM.
    pub fn rest_state(&self, loaded: bool) -> Option<(Vec<f64>, [f64; 2])> {
        self.dpm().map(|d| d.rest_state(loaded))
    }

    /// The loop at rest with the piston at x0 (docs/simulation.md#the-rest-under-load): the
    /// commands that hold the operating point (the drives' speed error that carries the pumps'
    /// load torque, the speeds that feed the leakage) come from the P law alone, so the
    /// reference that holds the piston at x0 stands off it by [`Rest::offset_m`]. Solved on
    /// this linear model: with A_cl = A + B Kx, the rest deviation under a reference deviation
    /// δr is A_cl⁻¹ B (u₀ − Kr δr), and δr is chosen to bring the position's deviation to 0.
    /// The circuits' rest equations are linear in one valve mode with every emulator effect
    /// off, so this is their exact rest there (tests/rest_offset.rs checks it against the
    /// emulator's Newton rest). `None` where A_cl is singular or the position does not follow
    /// the reference at DC (no rest to hold).
    pub fn rest(&self, sum_pressure: bool) -> Option<Rest> {
        let (kx, kr) = self.controller(sum_pressure);
        let op = self.operating_point();
        let lu = (&self.a + &self.b * kx).lu();
        let u0 = nalgebra::DVector::from_column_slice(&op.inputs);
        let unheld = lu.solve(&(&self.b * u0))?;
        let per_reference = -lu.solve(&(&self.b * kr))?.column(0).into_owned();
        let pos = self.position();
        let gain = per_reference[pos];
        if gain.is_nan() || gain.abs() <= 1e-9 {
            return None;
        }
        let offset_m = -unheld[pos] / gain;
        let deviation = unheld + per_reference * offset_m;
        let state: Vec<f64> = (op.state.iter().zip(deviation.iter()))
            .map(|(x, d)| x + d)
            .collect();
        (offset_m.is_finite() && state.iter().all(|v| v.is_finite()))
            .then_some(Rest { offset_m, state })
    }

    /// Wrap A, B with output x and no feedthrough.
    fn siso(&self, a: DMatrix<f64>, b: DMatrix<f64>) -> StateSpace {
        let mut c = DMatrix::zeros(1, self.n());
        c[(0, self.position())] = 1.0;
        StateSpace::new(a, b, c, DMatrix::zeros(1, 1)).expect("the assembled model is consistent")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lti::{eigenvalues, margins};
    use crate::rig::MotorModel;

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
        assert_eq!(full.n(), 10);
        assert_eq!(full.states().len(), 10);
        let no_ff = Plant::new(&Rig {
            feedforward: false,
            ..Rig::default()
        });
        assert_eq!(no_ff.n(), 8);
        let first = Plant::new(&Rig {
            motor_model: MotorModel::FirstOrder,
            ..Rig::default()
        });
        assert_eq!(first.n(), 6);
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
        for w in plant.states_of(Role::MotorSpeed) {
            for p in plant.states_of(Role::Pressure) {
                assert_eq!(plant.a[(w, p)], 0.0);
            }
        }
    }

    #[test]
    fn operating_point_reproduces_the_article_standstill() {
        // docs/identification.md#leakage-from-standstill: ω1 ≈ −160 rpm, ω2 ≈ 245 rpm at p1 ≈ 3.95 bar, p2 ≈ 5.86 bar; the model's
        // point (p1 + p2 = 10 bar exactly) is close: within 5 %.
        let plant = Plant::new(&Rig::default());
        let x = plant.operating_point().state;
        let [p_cap, p_rod] = [0, 1].map(|k| x[plant.states_of(Role::Pressure)[k]]);
        let [w_1, w_2] = [0, 1].map(|k| x[plant.states_of(Role::MotorSpeed)[k]]);
        let rpm = 60.0 / (2.0 * std::f64::consts::PI);
        assert!((w_1 * rpm / -160.0 - 1.0).abs() < 0.05, "{}", w_1 * rpm);
        assert!((w_2 * rpm / 245.0 - 1.0).abs() < 0.05, "{}", w_2 * rpm);
        assert!((p_cap + p_rod - 10e5).abs() < 1e-6);
        let si = Rig::default().si();
        assert!((p_cap * si.a1 - p_rod * si.a2).abs() < 1e-9);
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
