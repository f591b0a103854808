//! Hydraulic circuits behind one interface (docs/circuits.md).
//!
//! A circuit owns its state vector (names, units, meaning), its nonlinear equations, its
//! operating point and its control law. Its linear model is the exact Jacobian of those same
//! equations at the operating point, computed by forward-mode automatic differentiation
//! ([`linearise`], dual numbers of the `num-dual` crate), never a second hand-written copy of
//! the equations. Everything outside a circuit module works through the circuit's named
//! signals ([`Signal`]) and never names a circuit's state by index.
//!
//! The circuits are those of the article's Figure 1 and its Figure 3:
//! - [`CircuitKind::Dpm`] — the dual-prime-mover circuit the article builds (§2.1, Figure 3);
//! - [`CircuitKind::DualPump`] — two pumps on one motor (Figure 1b);
//! - [`CircuitKind::SinglePump`] — one pump, pilot-operated check valves (Figure 1a).

/// `impl Circuit` for an enum whose every variant holds one circuit ([`AnyCircuit`],
/// [`Emulated`]): each method is the variant's own. One list of the trait's methods serves
/// every such enum.
macro_rules! delegate_circuit {
    ($ty:ident { $($variant:ident),+ $(,)? }) => {
        impl $crate::circuit::Circuit for $ty {
            fn kind(&self) -> $crate::circuit::CircuitKind {
                match self { $($ty::$variant(c) => c.kind()),+ }
            }
            fn states(&self) -> Vec<$crate::circuit::Signal> {
                match self { $($ty::$variant(c) => c.states()),+ }
            }
            fn inputs(&self) -> Vec<$crate::circuit::Signal> {
                match self { $($ty::$variant(c) => c.inputs()),+ }
            }
            fn rhs<T: $crate::circuit::Scalar>(&self, x: &[T], u: &[T], dx: &mut [T]) {
                match self { $($ty::$variant(c) => c.rhs(x, u, dx)),+ }
            }
            fn operating_point(&self) -> $crate::circuit::OperatingState {
                match self { $($ty::$variant(c) => c.operating_point()),+ }
            }
            fn control_law(&self) -> $crate::circuit::ControlLaw {
                match self { $($ty::$variant(c) => c.control_law()),+ }
            }
            fn drive_regime(&self, x: &[f64], u: &[f64]) -> Option<u64> {
                match self { $($ty::$variant(c) => c.drive_regime(x, u)),+ }
            }
        }
    };
}

/// The calls every circuit answers from the parts it holds — its `piston` (load, end stops),
/// its `fluid` and its drives where it has them (the field named, whose type has
/// `without_limits`) — written once as inherent methods of each circuit, so that callers need
/// no trait in scope. The circuit's module has `Stops` in scope.
macro_rules! cylinder_calls {
    ($circuit:ty $(, $drives:ident)?) => {
        /// Change the external force on the piston (N) in the equations; the operating point
        /// stays the rig's.
        pub fn set_external_force_n(&mut self, f_n: f64) {
            self.piston.force_ext_n = f_n;
        }

        /// The end stops, if they act.
        pub fn stops(&self) -> Option<Stops> {
            self.piston.stops
        }

        /// The same circuit without the limits a Newton step at rest may cross: no torque or
        /// speed limit on the drives, no end stops.
        pub fn without_limits(&self) -> $circuit {
            let mut free = self.clone();
            free.piston.stops = None;
            $(free.$drives = self.$drives.without_limits();)?
            free
        }

        /// Bulk modulus (Pa) of the chambers at a mean gauge pressure (Pa).
        pub fn beta_pa(&self, p_gauge: f64) -> f64 {
            self.fluid.beta(p_gauge).value()
        }
    };
}

/// The [`EmulatedForm`] calls every circuit answers from [`cylinder_calls`]' inherent
/// methods; `order` is the circuit's number of states. For a one-motor circuit
/// (`one_motor`), also its rest (its operating point, the command of its one drive) and its
/// PLC law ω_ref = K_scale Kp (x_ref − x) with 0 for the drive it does not have.
macro_rules! emulated_form_calls {
    ($circuit:ty, $order:ident) => {
        fn order(&self) -> usize {
            self.$order()
        }
        fn set_force_n(&mut self, f_n: f64) {
            self.set_external_force_n(f_n);
        }
        fn end_stops(&self) -> Option<Stops> {
            self.stops()
        }
        fn free(&self) -> $circuit {
            self.without_limits()
        }
        fn beta_at_pa(&self, p_gauge: f64) -> f64 {
            self.beta_pa(p_gauge)
        }
    };
    ($circuit:ty, $order:ident, one_motor) => {
        emulated_form_calls!($circuit, $order);
        fn rest_with_commands(&self) -> (Vec<f64>, [f64; 2]) {
            let op = self.operating_point();
            (op.state, [op.inputs[0], 0.0])
        }
        fn commands(&self, _rig: &Rig, r_mm: f64, x_mm: f64, _p_bar: &[f64]) -> [f64; 2] {
            let e = (r_mm - x_mm) * 1e-3;
            [self.position_gain() * e, 0.0]
        }
    };
}

#[macro_use]
mod description;
mod any;
pub mod emulated;
pub mod energy;
pub mod parts;
pub mod stops;
pub mod switching;
pub mod valves;

pub use any::{mode_switching, pressure_level_bar, require, require_dpm};
pub use description::{
    Description, EmulatedForm, Key, Level, LinearForm, Module, OneMotorRest, PressureLevel,
    SupplyRest, Variant, DRIVE_KEYS,
};
pub use dpm::Dpm;
pub use parts::Effects;

use nalgebra::DMatrix;
use num_dual::Dual64;
use serde::{Deserialize, Serialize};
use stops::Stops;
use switching::Switching;

// The list of circuits: the one place that names them all (docs/architecture.md#circuits).
circuits! {
    /// The dual-prime-mover circuit of the article (§2.1, Figure 3): two motors, two pumps.
    Dpm: dpm,
    /// One motor turning two pumps on one shaft (the article's Figure 1b).
    DualPump: dual_pump,
    /// One motor, one pump between the chambers, pilot-operated check valves to the
    /// accumulator (the article's Figure 1a).
    SinglePump: single_pump,
    /// A four-way servo valve between a supply and the cylinder (the article's introduction, §4).
    Valve: valve,
}

/// The article's circuit (§2.1, Figure 3), the default rig's.
pub const ARTICLE: CircuitKind = CircuitKind::Dpm;

/// The scalar a circuit's equations are written over: `f64` when the emulator integrates
/// them, a dual number when [`linearise`] differentiates them. Declared with the bulk-modulus
/// models (a leaf module, which the circuits' fluid evaluates over the same scalar).
pub use crate::bulk::models::Scalar;

impl Default for CircuitKind {
    /// The article's circuit ([`ARTICLE`]).
    fn default() -> CircuitKind {
        ARTICLE
    }
}

impl CircuitKind {
    /// The name used in rig files and every output (`circuit = "dpm"`).
    pub fn name(self) -> &'static str {
        self.description().name
    }

    /// The controller's loops closed in the simulated loop, in words: the DPM's sum-pressure
    /// loop beside the position loop (the article §2.3.3); a one-motor circuit has the
    /// position loop alone (docs/circuits.md).
    pub fn closed_loops(self) -> &'static str {
        if self.has_sum_pressure_loop() {
            "the position and sum-pressure loops closed"
        } else {
            "the position loop closed"
        }
    }

    /// Whether the circuit's controller has a sum-pressure loop (the DPM's, the article
    /// §2.3.3): the one-motor circuits' pressure level is their accumulator's
    /// (docs/circuits.md), whatever the rig's `sum_pressure` says.
    pub fn has_sum_pressure_loop(self) -> bool {
        self.description().sum_pressure_loop
    }

    /// The circuit of a name used in rig files, if any.
    pub fn from_name(name: &str) -> Option<CircuitKind> {
        CircuitKind::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// What a signal of a circuit is: the role that code outside the circuit may ask for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// The piston position (m), the controlled output.
    Position,
    /// The piston velocity (m/s).
    Velocity,
    /// A chamber pressure (Pa gauge).
    Pressure,
    /// A motor (shaft) speed (rad/s).
    MotorSpeed,
    /// A drive's electromagnetic torque (N·m).
    Torque,
    /// A drive's feedforward filter state (rad/s).
    Feedforward,
    /// A speed command to a drive (rad/s), an input.
    SpeedCommand,
    /// A servo valve's spool opening, normalised to ±1 at full opening.
    SpoolOpening,
    /// A servo valve's spool velocity (normalised openings per second).
    SpoolVelocity,
    /// An opening command to a servo valve's spool (normalised, ±1), an input.
    SpoolCommand,
}

impl Role {
    /// The typical size of a signal of this role (SI): the scale of finite-difference steps
    /// and of solver tolerances.
    pub fn typical_size(self) -> f64 {
        match self {
            Role::Position => 1e-3,
            Role::Velocity => 1e-2,
            Role::Pressure => 1e5,
            Role::Torque => 0.1,
            Role::MotorSpeed | Role::Feedforward | Role::SpeedCommand => 10.0,
            Role::SpoolOpening | Role::SpoolCommand => 1e-2,
            Role::SpoolVelocity => 1.0,
        }
    }
}

/// A named signal of a circuit: a state or an input, with its SI unit and its meaning.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Signal {
    /// Name, e.g. `p1`.
    pub name: String,
    /// SI unit, e.g. `Pa`.
    pub unit: String,
    /// What it is, e.g. `chamber 1 pressure (gauge)`.
    pub meaning: String,
    /// Its role, for code that must find e.g. the position without naming it.
    pub role: Role,
}

impl Signal {
    /// A signal from its parts.
    pub fn new(name: &str, unit: &str, meaning: &str, role: Role) -> Signal {
        Signal {
            name: name.into(),
            unit: unit.into(),
            meaning: meaning.into(),
            role,
        }
    }
}

/// The steady state a circuit is linearised about and the speed commands that hold it.
#[derive(Debug, Clone, PartialEq)]
pub struct OperatingState {
    /// The state (absolute position, gauge pressures, SI), in the order of [`Circuit::states`].
    pub state: Vec<f64>,
    /// The speed commands (rad/s), in the order of [`Circuit::inputs`].
    pub inputs: Vec<f64>,
}

/// A linear control law in deviations from the operating point: u = Kx Δx + Kr Δx_ref, with
/// u the speed commands (rad/s) and x_ref the position reference (m).
#[derive(Debug, Clone, PartialEq)]
pub struct ControlLaw {
    /// Feedback on the state, inputs × states.
    pub kx: DMatrix<f64>,
    /// Feedforward of the position reference, inputs × 1.
    pub kr: DMatrix<f64>,
}

impl ControlLaw {
    /// The article's P law on one input alone, u = gain (x_ref − x), for a circuit of `n`
    /// states whose position is state `x`.
    pub fn position(n: usize, x: usize, gain: f64) -> ControlLaw {
        let mut kx = DMatrix::zeros(1, n);
        kx[(0, x)] = -gain;
        ControlLaw {
            kx,
            kr: DMatrix::from_element(1, 1, gain),
        }
    }
}

/// A hydraulic circuit: its signals, its nonlinear equations, its operating point and its
/// control law. Implemented once per circuit module.
pub trait Circuit {
    /// Which circuit this is.
    fn kind(&self) -> CircuitKind;

    /// The states, in order.
    fn states(&self) -> Vec<Signal>;

    /// The inputs (speed commands), in order.
    fn inputs(&self) -> Vec<Signal>;

    /// The nonlinear equations ẋ = f(x, u) into `dx` (SI, absolute position, gauge
    /// pressures), over `f64` or a dual number.
    fn rhs<T: Scalar>(&self, x: &[T], u: &[T], dx: &mut [T]);

    /// The steady state at rest and the commands that hold it.
    fn operating_point(&self) -> OperatingState;

    /// The control law at the operating point (the article's P law, and what the circuit adds).
    fn control_law(&self) -> ControlLaw;

    /// Which side of their limits the circuit's drives are on at (x, u) ([`parts::Drive::regime`]),
    /// where its torque and feedforward states and its commands enter its equations only
    /// through its drives: then ∂f/∂x depends on them through this alone, and the emulator's
    /// integrator takes one linear part for all of them (docs/emulator.md#the-integration).
    /// `None` (the default): the circuit does not say so, and every state counts.
    fn drive_regime(&self, _x: &[f64], _u: &[f64]) -> Option<u64> {
        None
    }

    /// The position of the first state with `role`, if any.
    fn state_of(&self, role: Role) -> Option<usize> {
        self.states().iter().position(|s| s.role == role)
    }

    /// The positions of every state with `role`, in order.
    fn states_of(&self, role: Role) -> Vec<usize> {
        (self.states().iter().enumerate())
            .filter(|(_, s)| s.role == role)
            .map(|(i, _)| i)
            .collect()
    }
}

/// The Jacobians ∂f/∂x (n × n) and ∂f/∂u (n × m) of a circuit's equations at (x0, u0), exact
/// to rounding: one forward pass with a dual number per column.
pub fn linearise<C: Circuit>(c: &C, x0: &[f64], u0: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (x0.len(), u0.len());
    let column = |j: usize| -> Vec<f64> {
        let seed = |i: usize, v: f64| Dual64::new(v, if i == j { 1.0 } else { 0.0 });
        let x: Vec<Dual64> = x0.iter().enumerate().map(|(i, &v)| seed(i, v)).collect();
        let u: Vec<Dual64> = u0
            .iter()
            .enumerate()
            .map(|(i, &v)| seed(n + i, v))
            .collect();
        let mut dx = vec![Dual64::from(0.0); n];
        c.rhs(&x, &u, &mut dx);
        dx.iter().map(|d| d.eps).collect()
    };
    let mut a = DMatrix::zeros(n, n);
    let mut b = DMatrix::zeros(n, m);
    for j in 0..n + m {
        let col = column(j);
        for (i, v) in col.into_iter().enumerate() {
            if j < n {
                a[(i, j)] = v;
            } else {
                b[(i, j - n)] = v;
            }
        }
    }
    (a, b)
}

/// ∂f/∂x alone of a circuit's equations at (x0, u0) into `out` (row-major n × n): the first
/// matrix [`linearise`] gives, bit for bit, by the same forward pass per column, without
/// ∂f/∂u and without a matrix of its own (the emulator's integrator takes one per new linear
/// part, docs/emulator.md#the-integration).
pub fn state_jacobian<C: Circuit>(c: &C, x0: &[f64], u0: &[f64], out: &mut [f64]) {
    let n = x0.len();
    let mut x: Vec<Dual64> = x0.iter().map(|&v| Dual64::new(v, 0.0)).collect();
    let u: Vec<Dual64> = u0.iter().map(|&v| Dual64::new(v, 0.0)).collect();
    let mut dx = vec![Dual64::from(0.0); n];
    for j in 0..n {
        x[j].eps = 1.0;
        dx.fill(Dual64::from(0.0));
        c.rhs(&x, &u, &mut dx);
        x[j].eps = 0.0;
        for (i, d) in dx.iter().enumerate() {
            out[i * n + j] = d.eps;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillator with a nonlinear spring, ẍ = u − x³ − ẋ, to check the dual-number
    /// Jacobian against its analytic value.
    struct Toy;

    impl Circuit for Toy {
        fn kind(&self) -> CircuitKind {
            CircuitKind::Dpm
        }
        fn states(&self) -> Vec<Signal> {
            vec![
                Signal::new("x", "m", "position", Role::Position),
                Signal::new("v", "m/s", "velocity", Role::Velocity),
            ]
        }
        fn inputs(&self) -> Vec<Signal> {
            vec![Signal::new("u", "rad/s", "command", Role::SpeedCommand)]
        }
        fn rhs<T: Scalar>(&self, x: &[T], u: &[T], dx: &mut [T]) {
            dx[0] = x[1];
            dx[1] = u[0] - x[0] * x[0] * x[0] - x[1];
        }
        fn operating_point(&self) -> OperatingState {
            OperatingState {
                state: vec![2.0, 0.0],
                inputs: vec![8.0],
            }
        }
        fn control_law(&self) -> ControlLaw {
            ControlLaw {
                kx: DMatrix::from_row_slice(1, 2, &[-1.0, 0.0]),
                kr: DMatrix::from_element(1, 1, 1.0),
            }
        }
    }

    #[test]
    fn dual_numbers_give_the_analytic_jacobian() {
        let op = Toy.operating_point();
        let (a, b) = linearise(&Toy, &op.state, &op.inputs);
        assert_eq!(a, DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -12.0, -1.0]));
        assert_eq!(b, DMatrix::from_row_slice(2, 1, &[0.0, 1.0]));
        assert_eq!(Toy.state_of(Role::Velocity), Some(1));
        assert_eq!(Toy.states_of(Role::Pressure), Vec::<usize>::new());
    }

    #[test]
    fn names_round_trip() {
        for k in CircuitKind::ALL {
            assert_eq!(CircuitKind::from_name(k.name()), Some(k));
        }
        assert_eq!(CircuitKind::from_name("DPM"), None);
    }
}
