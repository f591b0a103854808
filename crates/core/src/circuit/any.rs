//! The circuit a rig is, whichever its kind: what the linear model holds.

use super::dpm::Dpm;
use super::dual_pump::DualPump;
use super::single_pump::modes::{switching, Mode, Switching};
use super::{Circuit, CircuitKind, ControlLaw};
use crate::rig::Rig;

/// A circuit of any kind, the one a rig is: what the linear model holds. A new kind is a new
/// arm; what only the DPM has is asked for through [`AnyCircuit::dpm`].
#[derive(Debug, Clone)]
pub enum AnyCircuit {
    /// The dual-prime-mover circuit (§2.1, Figure 3).
    Dpm(Dpm),
    /// The single-motor dual-pump circuit (Figure 1b).
    DualPump(DualPump),
    /// The single-pump circuit (Figure 1a) in the mode of its operating point at rest
    /// (docs/circuits.md#its-two-modes).
    SinglePumpMode(Mode),
}

/// Refuse, in one line, a rig of another circuit than the DPM for `what`, a part of pumpcyl
/// that models the DPM only so far (docs/circuits.md#what-works-on-which-circuit).
pub fn require_dpm(rig: &Rig, what: &str) -> Result<(), String> {
    require(rig, what, &[CircuitKind::Dpm])
}

/// Refuse, in one line, a rig of a circuit not in `modelled` for `what`.
pub fn require(rig: &Rig, what: &str, modelled: &[CircuitKind]) -> Result<(), String> {
    if modelled.contains(&rig.circuit) {
        return Ok(());
    }
    let names: Vec<&str> = modelled.iter().map(|k| k.name()).collect();
    Err(format!(
        "circuit = \"{}\": {what} models the {} circuit only so far; margins, poles, bode and \
         model analyse every circuit (docs/circuits.md#what-works-on-which-circuit)",
        rig.circuit.name(),
        names.join(" and ")
    ))
}

/// Where the circuit of `rig` switches between modes, the single-pump circuit's
/// [`Switching`] (docs/circuits.md#the-switching-force); for a circuit without modes, why it
/// has none, in the circuit's own one line (its `NO_MODES`): what "will it chatter?" answers
/// for it (docs/circuits.md#will-it-chatter).
pub fn mode_switching(rig: &Rig) -> Result<Switching, &'static str> {
    match rig.circuit {
        CircuitKind::SinglePump => Ok(switching(rig)),
        CircuitKind::Dpm => Err(super::dpm::NO_MODES),
        CircuitKind::DualPump => Err(super::dual_pump::NO_MODES),
    }
}

impl AnyCircuit {
    /// The circuit of `rig` its linear model is the Jacobian of: every effect off, no end
    /// stops, the rig's variant switches as set.
    pub fn linear(rig: &Rig) -> AnyCircuit {
        match rig.circuit {
            CircuitKind::Dpm => AnyCircuit::Dpm(Dpm::linear(rig)),
            CircuitKind::DualPump => AnyCircuit::DualPump(
                DualPump::new(rig).expect("Rig::validate refuses a dual-pump rig with no rest"),
            ),
            CircuitKind::SinglePump => {
                AnyCircuit::SinglePumpMode(Mode::new(rig, 3 - switching(rig).mode_at_rest))
            }
        }
    }

    /// Every linear model the loop of `rig` runs in, the one at rest first
    /// ([`AnyCircuit::linear`]): the single-pump circuit's two modes (its other mode where a
    /// load crosses the switching force, docs/circuits.md#its-two-modes), the one model of a
    /// circuit without modes. What a design checks its gains in.
    pub fn linear_modes(rig: &Rig) -> Vec<AnyCircuit> {
        match rig.circuit {
            CircuitKind::SinglePump => {
                let rest = switching(rig).mode_at_rest;
                [3 - rest, rest]
                    .map(|chamber| AnyCircuit::SinglePumpMode(Mode::new(rig, chamber)))
                    .to_vec()
            }
            _ => vec![AnyCircuit::linear(rig)],
        }
    }

    /// The mode this linear model is (the single-pump circuit's 1 or 2); `None` for a circuit
    /// without modes.
    pub fn mode(&self) -> Option<usize> {
        match self {
            AnyCircuit::SinglePumpMode(m) => Some(m.number()),
            _ => None,
        }
    }

    /// The load torques of the pumps on motors 1 and 2 (N·m) at the chamber pressures `p_pa`
    /// (Pa gauge), what the drives' ratings are checked against; the single motor of a
    /// single-motor circuit is motor 1 (the single-pump circuit's D1 (p1 − p2) in either
    /// mode, what its emulated records are rated by).
    pub fn load_torques_nm(&self, p_pa: [f64; 2]) -> [f64; 2] {
        match self {
            AnyCircuit::Dpm(d) => d.load_torques_nm(p_pa),
            AnyCircuit::DualPump(d) => [d.load_torque_nm(p_pa), 0.0],
            AnyCircuit::SinglePumpMode(m) => [m.load_torque_nm(p_pa), 0.0],
        }
    }

    /// The circuit in words, as every analysis names it: `dpm`, `dual-pump`, or
    /// `single-pump, mode M (chamber K at the accumulator pressure), the mode at rest` (`the
    /// other mode` for the mode the rig does not rest in).
    pub fn describe(&self) -> String {
        match self {
            AnyCircuit::SinglePumpMode(m) => format!(
                "single-pump, mode {} (chamber {} at the accumulator pressure), {}",
                m.number(),
                m.accumulator_chamber(),
                if m.at_rest() {
                    "the mode at rest"
                } else {
                    "the other mode"
                }
            ),
            c => c.kind().name().to_string(),
        }
    }

    /// The DPM circuit, for what only it has (its grey-box entries, its standstill, its two
    /// drives); `None` for another circuit.
    pub fn dpm(&self) -> Option<&Dpm> {
        match self {
            AnyCircuit::Dpm(d) => Some(d),
            _ => None,
        }
    }

    /// The control law at the operating point with the sum-pressure loop where
    /// `sum_pressure` (the article's P law alone otherwise; a circuit without that loop
    /// ignores it).
    pub fn law(&self, sum_pressure: bool) -> ControlLaw {
        match self {
            AnyCircuit::Dpm(d) => d.law(sum_pressure),
            AnyCircuit::DualPump(d) => d.control_law(),
            AnyCircuit::SinglePumpMode(m) => m.control_law(),
        }
    }
}

delegate_circuit!(AnyCircuit {
    Dpm,
    DualPump,
    SinglePumpMode
});

/// The mean chamber pressure (bar gauge) a rig's circuit holds at rest, the level its
/// `beta_bar` is read at: the DPM's sum-pressure set-point split evenly (its loop holds
/// p1 + p2 there; docs/model.md#the-dpm-control-law), the one-motor circuits' accumulator
/// pre-charge (docs/circuits.md).
pub fn pressure_level_bar(rig: &Rig) -> f64 {
    match rig.circuit {
        CircuitKind::Dpm => 0.5 * rig.p_sum_ref_bar,
        CircuitKind::DualPump | CircuitKind::SinglePump => rig.accumulator_precharge_bar,
    }
}
