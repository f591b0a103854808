//! The dual-pump circuit's steady state at constant piston speed in closed form: the force
//! balance and both chambers' flow balances with leakage (docs/circuits.md#operating-point).
//! It needs only numbers, not the rig, so the rig's own validation can ask it for the rest.

/// A rig whose leakage leaves the dual-pump circuit's pressures at rest undetermined.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the leakages c1, c2, c12 leave the dual-pump circuit's pressures at rest undetermined \
     (its steady flow balance is singular; docs/circuits.md#operating-point)"
)]
pub struct Undetermined;

/// A steady state of the circuit at constant piston speed (SI, gauge pressures).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SteadyMotion {
    /// Piston speed (m/s).
    pub v_m_per_s: f64,
    /// Chamber 1 pressure (Pa gauge).
    pub p1_pa: f64,
    /// Chamber 2 pressure (Pa gauge).
    pub p2_pa: f64,
    /// Shaft speed (rad/s).
    pub omega_rad_per_s: f64,
}

/// What the balance depends on (SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Balance {
    /// Piston and annulus areas A1, A2 (m²).
    pub areas_m2: [f64; 2],
    /// Pump displacements D1, D2 (m³/rad).
    pub displacements_m3: [f64; 2],
    /// Leakages c1, c2 (to the accumulator line) and c12 (across) (m⁵/(N·s)).
    pub leakage_m5_per_ns: [f64; 3],
    /// Viscous friction b (N·s/m).
    pub viscous_ns_per_m: f64,
    /// External force against extension (N).
    pub force_ext_n: f64,
    /// Accumulator pressure p_acc (Pa gauge).
    pub p_acc_pa: f64,
}

impl Balance {
    /// The flow area (m²) by which pump 2 over-supplies chamber 1 per unit piston speed,
    /// (1 + D2/D1) A2 − A1: zero for a matched circuit, D2/D1 = A1/A2 − 1
    /// (docs/circuits.md#matching).
    pub fn mismatch_m2(&self) -> f64 {
        let ([a1, a2], [d1, d2]) = (self.areas_m2, self.displacements_m3);
        (1.0 + d2 / d1) * a2 - a1
    }

    /// The steady state at piston speed `v` (m/s). With qi = pi − p_acc and r = D2/D1,
    /// chamber 1's balance less (1 + r) times chamber 2's removes ω:
    /// (r c12 − c1) q1 − (r c12 + (1 + r) c2) q2 = −M v, M the mismatch area; with the force
    /// balance A1 q1 − A2 q2 = F_ext − p_acc (A1 − A2) + b v it fixes q1, q2, and chamber 2's
    /// balance then ω.
    ///
    /// # Errors
    /// [`Undetermined`] when the two equations are singular (no leakage at all, for one).
    pub fn steady(&self, v: f64) -> Result<SteadyMotion, Undetermined> {
        let ([a1, a2], [d1, d2]) = (self.areas_m2, self.displacements_m3);
        let [c1, c2, c12] = self.leakage_m5_per_ns;
        let r = d2 / d1;
        let ka = r * c12 - c1;
        let kb = r * c12 + (1.0 + r) * c2;
        let m = self.mismatch_m2();
        let g = self.force_ext_n - self.p_acc_pa * (a1 - a2) + self.viscous_ns_per_m * v;
        let det = kb * a1 - ka * a2;
        let scale = kb.abs() * a1 + ka.abs() * a2;
        if det.is_nan() || det.abs() <= 1e-9 * scale {
            return Err(Undetermined);
        }
        let q1 = (m * v * a2 + kb * g) / det;
        let q2 = (m * v * a1 + ka * g) / det;
        Ok(SteadyMotion {
            v_m_per_s: v,
            p1_pa: self.p_acc_pa + q1,
            p2_pa: self.p_acc_pa + q2,
            omega_rad_per_s: (a2 * v - c2 * q2 + c12 * (q1 - q2)) / d1,
        })
    }
}
