//! The circuit the emulator integrates, whichever its kind (docs/emulator.md#every-circuit):
//! each circuit's emulated equations (the parts' effects, the end stops and, for the
//! single-motor circuits, their valves), its rest, and what the PLC's control law makes of
//! what the PLC measures. The emulator outside asks for these by role and never names a
//! circuit's state.

use super::dpm::Dpm;
use super::dual_pump::DualPump;
use super::single_pump::{modes, SinglePump};
use super::stops::Stops;
use super::{Circuit, CircuitKind, Effects};
use crate::rig::Rig;

/// The emulated form of a rig's circuit.
#[derive(Debug, Clone)]
pub enum Emulated {
    /// The dual-prime-mover circuit (§2.1, Figure 3): two drives, the sum-pressure loop.
    Dpm(Dpm),
    /// The single-motor dual-pump circuit (Figure 1b) with its check and relief valves.
    DualPump(DualPump),
    /// The single-pump circuit (Figure 1a) with its pilot-operated check valves and relief
    /// valves: both modes and the switching between them.
    SinglePump(SinglePump),
}

/// Dispatch a call to the circuit inside, whichever its kind.
macro_rules! each {
    ($self:expr, $c:ident => $e:expr) => {
        match $self {
            Emulated::Dpm($c) => $e,
            Emulated::DualPump($c) => $e,
            Emulated::SinglePump($c) => $e,
        }
    };
}

impl Emulated {
    /// The emulated circuit of `rig` with the chosen effects.
    ///
    /// # Errors
    /// A dual-pump rig whose leakage leaves its rest undetermined.
    pub fn of_rig(rig: &Rig, effects: Effects) -> Result<Emulated, String> {
        Ok(match rig.circuit {
            CircuitKind::Dpm => Emulated::Dpm(Dpm::emulated(rig, effects)),
            CircuitKind::DualPump => {
                Emulated::DualPump(DualPump::emulated(rig, effects).map_err(|e| e.to_string())?)
            }
            CircuitKind::SinglePump => Emulated::SinglePump(SinglePump::emulated(rig, effects)),
        })
    }

    /// Number of states.
    pub fn order(&self) -> usize {
        match self {
            Emulated::Dpm(c) => c.order(),
            Emulated::DualPump(c) => c.n_states(),
            Emulated::SinglePump(c) => c.n_states(),
        }
    }

    /// How many drives the PLC commands: 2 for the DPM, 1 for the single-motor circuits.
    pub fn drives(&self) -> usize {
        match self {
            Emulated::Dpm(_) => 2,
            _ => 1,
        }
    }

    /// Change the external force on the piston (N); the operating point stays the rig's.
    pub fn set_external_force_n(&mut self, f_n: f64) {
        each!(self, c => c.set_external_force_n(f_n))
    }

    /// The end stops, if they act.
    pub fn stops(&self) -> Option<Stops> {
        each!(self, c => c.stops())
    }

    /// The same circuit without the limits a Newton step at rest may cross (torque and speed
    /// limits, end stops).
    pub fn without_limits(&self) -> Emulated {
        match self {
            Emulated::Dpm(c) => Emulated::Dpm(c.without_limits()),
            Emulated::DualPump(c) => Emulated::DualPump(c.without_limits()),
            Emulated::SinglePump(c) => Emulated::SinglePump(c.without_limits()),
        }
    }

    /// Bulk modulus (Pa) of the chambers at a mean gauge pressure (Pa).
    pub fn beta_pa(&self, p_gauge: f64) -> f64 {
        each!(self, c => c.beta_pa(p_gauge))
    }

    /// The circuit's rest at x0 as a state, with the motors carrying the pumps' load, and the
    /// speed commands that hold it, one per drive ([`Emulated::drives`]) and 0 for a drive the
    /// circuit does not have: where the emulator's search for its loop's rest starts.
    pub fn rest_state(&self) -> (Vec<f64>, [f64; 2]) {
        match self {
            Emulated::Dpm(c) => c.rest_state(true),
            c => {
                let op = c.operating_point();
                (op.state, [op.inputs[0], 0.0])
            }
        }
    }

    /// The speed commands (rad/s) of the circuit's PLC law for the reference `r_mm`, the
    /// measured position `x_mm` (mm) and pressures `p_bar` (bar gauge, in the order of the
    /// pressure states), in absolute terms: the DPM's position and sum-pressure law
    /// (docs/model.md#the-dpm-control-law), the single-motor circuits' ω_ref = K_scale Kp
    /// (x_ref − x) with 0 for the drive they do not have.
    pub fn plc_commands(&self, rig: &Rig, r_mm: f64, x_mm: f64, p_bar: &[f64]) -> [f64; 2] {
        let e = (r_mm - x_mm) * 1e-3;
        match self {
            Emulated::Dpm(c) => c.plc_commands(rig, r_mm, x_mm, p_bar),
            Emulated::DualPump(c) => [c.position_gain() * e, 0.0],
            Emulated::SinglePump(c) => [c.position_gain() * e, 0.0],
        }
    }

    /// The single-pump circuit's mode at state `s` ([`modes::recorded_mode`]: 1 with chamber
    /// 2 on the accumulator, 2 with chamber 1); `None` for a circuit without modes.
    pub fn mode(&self, s: &[f64]) -> Option<usize> {
        match self {
            Emulated::SinglePump(c) => Some(modes::recorded_mode(c, s)),
            _ => None,
        }
    }

    /// The single-pump circuit inside, for what only it has (its modes and valves).
    pub fn single_pump(&self) -> Option<&SinglePump> {
        match self {
            Emulated::SinglePump(c) => Some(c),
            _ => None,
        }
    }
}

delegate_circuit!(Emulated {
    Dpm,
    DualPump,
    SinglePump
});
