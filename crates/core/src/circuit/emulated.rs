//! The circuit the emulator integrates, whichever its kind (docs/emulator.md#every-circuit):
//! [`Emulated`], made from the list of circuits in `circuit/mod.rs`, holds each circuit's
//! emulated equations (the parts' effects, the end stops and, for the single-motor circuits,
//! their valves), its rest, and what the PLC's control law makes of what the PLC measures. The
//! emulator outside asks for these by role and never names a circuit's state.

use super::Effects;
pub use super::Emulated;
use crate::rig::Rig;

impl Emulated {
    /// The emulated circuit of `rig` with the chosen effects.
    ///
    /// # Errors
    /// A dual-pump rig whose leakage leaves its rest undetermined.
    pub fn of_rig(rig: &Rig, effects: Effects) -> Result<Emulated, String> {
        rig.circuit.emulated(rig, effects)
    }
}
