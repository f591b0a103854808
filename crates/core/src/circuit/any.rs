//! The circuit a rig is, whichever its kind: what the linear model holds ([`AnyCircuit`], made
//! from the list of circuits in `circuit/mod.rs`), and the calls every part of pumpcyl asks of
//! a rig's circuit.

use super::switching::Switching;
use super::{AnyCircuit, CircuitKind};
use crate::rig::Rig;

/// Refuse, in one line, a rig of another circuit than the DPM for `what`, a part of pumpcyl
/// that models the DPM only so far (docs/circuits.md#what-works-on-which-circuit).
pub fn require_dpm(rig: &Rig, what: &str) -> Result<(), String> {
    require(rig, what, |k| k == CircuitKind::Dpm)
}

/// Refuse, in one line, a rig of a circuit that `modelled` does not hold for `what`, naming
/// the circuits it holds for.
pub fn require(
    rig: &Rig,
    what: &str,
    modelled: impl Fn(CircuitKind) -> bool,
) -> Result<(), String> {
    if modelled(rig.circuit) {
        return Ok(());
    }
    let names: Vec<&str> = (CircuitKind::ALL.into_iter())
        .filter(|&k| modelled(k))
        .map(CircuitKind::name)
        .collect();
    Err(format!(
        "circuit = \"{}\": {what} models the {} circuit only so far; margins, poles, bode and \
         model analyse every circuit (docs/circuits.md#what-works-on-which-circuit)",
        rig.circuit.name(),
        names.join(" and ")
    ))
}

/// Where the circuit of `rig` switches between modes, the single-pump circuit's
/// [`Switching`] (docs/circuits.md#the-switching-force); for a circuit without modes, why it
/// has none, in the circuit's own one line ([`super::Description::no_modes`]): what "will it
/// chatter?" answers for it (docs/circuits.md#will-it-chatter).
pub fn mode_switching(rig: &Rig) -> Result<Switching, &'static str> {
    rig.circuit.mode_switching(rig)
}

impl AnyCircuit {
    /// The circuit of `rig` its linear model is the Jacobian of: every effect off, no end
    /// stops, the rig's variant switches as set; the single-pump circuit in the mode of its
    /// operating point at rest (docs/circuits.md#its-two-modes).
    pub fn linear(rig: &Rig) -> AnyCircuit {
        rig.circuit.linear(rig)
    }

    /// Every linear model the loop of `rig` runs in, the one at rest first
    /// ([`AnyCircuit::linear`]): the single-pump circuit's two modes (its other mode where a
    /// load crosses the switching force, docs/circuits.md#its-two-modes), the one model of a
    /// circuit without modes. What a design checks its gains in.
    pub fn linear_modes(rig: &Rig) -> Vec<AnyCircuit> {
        rig.circuit.linear_modes(rig)
    }
}

/// The mean chamber pressure (bar gauge) a rig's circuit holds at rest, the level its
/// `beta_bar` is read at: the DPM's sum-pressure set-point split evenly (its loop holds
/// p1 + p2 there; docs/model.md#the-dpm-control-law), the one-motor circuits' accumulator
/// pre-charge (docs/circuits.md).
pub fn pressure_level_bar(rig: &Rig) -> f64 {
    rig.circuit.pressure_level_bar(rig)
}
