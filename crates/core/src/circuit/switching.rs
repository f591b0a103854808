//! Where a circuit with modes switches between them (docs/circuits.md#the-switching-force):
//! what [`super::Module::mode_switching`] answers, apart from the circuit that computes it so
//! that the description of a circuit names no circuit's own types.

/// Where a circuit with modes switches them, and where a rig's load puts it: the single-pump
/// circuit's (docs/circuits.md#the-switching-force), computed by its module.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Switching {
    /// The switching force p_acc (A1 − A2) (N): the external force at rest with both chambers
    /// at the accumulator pressure.
    pub switching_force_n: f64,
    /// The band the check valves' cracking pressure widens it to (N),
    /// [F_s − A1 Δp_crack, F_s + A2 Δp_crack]: leaving mode 1, chamber 1 must fall a cracking
    /// pressure below the accumulator before its valve opens, and leaving mode 2 chamber 2 must;
    /// inside the band the mode at rest depends on where the load came from.
    pub valve_band_n: [f64; 2],
    /// The rig's external force (N).
    pub external_force_n: f64,
    /// The mode at rest (1: chamber 2 at the accumulator, above the switching force; 2:
    /// chamber 1, below it).
    pub mode_at_rest: usize,
    /// The force the pressures carry beyond the switching force at rest, F_ext − F_s (N).
    pub force_from_switching_n: f64,
    /// The load's acceleration (m/s², positive extending) whose inertial force m a brings the
    /// pressures' force to the switching force, (F_s − F_ext)/m: an acceleration beyond it
    /// (in its direction) switches the mode.
    pub acceleration_to_switch_m_per_s2: f64,
    /// The rest lies inside the valves' band.
    pub within_valve_band: bool,
}
