//! The circuit a rig is, whichever its kind: what the linear model holds.

use super::dpm::Dpm;
use super::{Circuit, CircuitKind, ControlLaw, OperatingState, Scalar, Signal};
use crate::rig::Rig;

/// A circuit of any kind, the one a rig is: what the linear model holds. Only the DPM is wired
/// so far; a new kind is a new arm, and the compiler then names every place that asks a
/// circuit for what only the DPM has ([`AnyCircuit::dpm`]).
#[derive(Debug, Clone, PartialEq)]
pub enum AnyCircuit {
    /// The dual-prime-mover circuit (§2.1, Figure 3).
    Dpm(Dpm),
}

impl AnyCircuit {
    /// The circuit of `rig` its linear model is the Jacobian of: every effect off, no end
    /// stops, the rig's variant switches as set.
    pub fn linear(rig: &Rig) -> AnyCircuit {
        AnyCircuit::Dpm(Dpm::linear(rig))
    }

    /// The DPM circuit, for what only it has (its grey-box entries, its standstill).
    pub fn dpm(&self) -> &Dpm {
        let AnyCircuit::Dpm(d) = self;
        d
    }

    /// The control law at the operating point with the sum-pressure loop where
    /// `sum_pressure` (the article's P law alone otherwise).
    pub fn law(&self, sum_pressure: bool) -> ControlLaw {
        match self {
            AnyCircuit::Dpm(d) => d.law(sum_pressure),
        }
    }

    /// The operating point as a state with the drives carrying the pumps' load where `loaded`,
    /// and the speed commands (rad/s) that hold it.
    pub fn rest_state(&self, loaded: bool) -> (Vec<f64>, [f64; 2]) {
        match self {
            AnyCircuit::Dpm(d) => d.rest_state(loaded),
        }
    }
}

impl Circuit for AnyCircuit {
    fn kind(&self) -> CircuitKind {
        match self {
            AnyCircuit::Dpm(d) => d.kind(),
        }
    }

    fn states(&self) -> Vec<Signal> {
        match self {
            AnyCircuit::Dpm(d) => d.states(),
        }
    }

    fn inputs(&self) -> Vec<Signal> {
        match self {
            AnyCircuit::Dpm(d) => d.inputs(),
        }
    }

    fn rhs<T: Scalar>(&self, x: &[T], u: &[T], dx: &mut [T]) {
        match self {
            AnyCircuit::Dpm(d) => d.rhs(x, u, dx),
        }
    }

    fn operating_point(&self) -> OperatingState {
        match self {
            AnyCircuit::Dpm(d) => d.operating_point(),
        }
    }

    fn control_law(&self) -> ControlLaw {
        match self {
            AnyCircuit::Dpm(d) => d.control_law(),
        }
    }
}
