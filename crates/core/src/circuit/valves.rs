//! The valves a single-motor circuit adds to its emulated equations (docs/circuits.md#valves):
//! anti-cavitation check valves from the accumulator into each chamber and a pressure-relief
//! valve from a chamber to the accumulator, as the circuits of the article's Figure 1 carry them;
//! the single-pump circuit's check valves are pilot-operated ([`PilotCheck`]).
//!
//! Every valve is one sharp-edged orifice whose opening follows its pressure drop:
//!
//! Q = Cd · A(Δp) · √(2/ρ) · Δp / (Δp² + Δp_lam²)^¼,
//! A(Δp) = A_max · s((Δp − Δp_crack) / Δp_open), s(t) = 3t² − 2t³ on [0, 1],
//!
//! which is the turbulent orifice law Cd A √(2|Δp|/ρ) sign(Δp) for |Δp| ≫ Δp_lam, linear
//! (laminar) near Δp = 0 so that it is differentiable there (the smoothing of Simscape Fluids'
//! Check Valve (IL) block), and an opening that rises
//! smoothly (C¹) from zero at the cracking pressure to full over the opening range. A valve
//! below its cracking pressure passes no flow and has zero derivative: at an operating point
//! where every valve is shut the valves do not enter the linear model.
//!
//! ```
//! use pumpcyl::circuit::valves::Valve;
//!
//! let check = Valve::ANTI_CAVITATION;
//! assert_eq!(check.flow(0.4e5), 0.0); // below its 0.5 bar cracking pressure
//! let open = check.flow(5e5); // fully open: the orifice law
//! let orifice = 0.61 * check.area_m2 * (2.0 * 5e5 / 870.0f64).sqrt();
//! assert!((open / orifice - 1.0).abs() < 1e-4); // the laminar term: (0.05/5)²/4
//! ```

use super::Scalar;

/// Density of the mineral oil (kg/m³): 0.87 kg/dm³, an ISO VG 46 mineral hydraulic oil at
/// 15 °C as its makers' data sheets give it (mineral hydraulic oils lie at 0.85–0.89 kg/dm³)
/// **\[choice\]**: the orifice flow goes with 1/√ρ, so the spread moves it by ±1 %.
pub const OIL_DENSITY_KG_PER_M3: f64 = 870.0;

/// Discharge coefficient of a sharp-edged orifice in turbulent flow, 0.61: the contraction
/// coefficient π/(π + 2) = 0.611 of a sharp-edged orifice small against its bore (Merritt,
/// *Hydraulic Control Systems*, Wiley 1967).
pub const DISCHARGE_COEFFICIENT: f64 = 0.61;

/// One valve: a sharp-edged orifice that opens with its pressure drop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Valve {
    /// Pressure drop (Pa) at which the valve starts to open.
    pub crack_pa: f64,
    /// Pressure rise above the cracking pressure (Pa) over which it opens fully.
    pub open_range_pa: f64,
    /// Fully open flow area (m²).
    pub area_m2: f64,
    /// Pressure drop (Pa) below which the flow turns laminar (linear in Δp).
    pub laminar_pa: f64,
}

impl Valve {
    /// The anti-cavitation check valve: a size-10 screw-in check valve with a light spring,
    /// 0.5 bar cracking pressure **\[choice\]** (the kind makers sell with a choice of springs:
    /// Bosch Rexroth's check valve type S, sizes 6 to 30, data sheet RE 20375); its 10 mm bore
    /// fully open, π (10 mm)²/4 = 78.5 mm², 1 bar above cracking **\[choice\]**, the order of
    /// the rise from cracking to the straight (turbulent) part of makers' Δp–Q curves; laminar
    /// below 0.05 bar **\[choice\]**, a tenth of the cracking pressure.
    pub const ANTI_CAVITATION: Valve = Valve {
        crack_pa: 0.5e5,
        open_range_pa: 1.0e5,
        area_m2: 7.853_981_633_974_483e-5,
        laminar_pa: 0.05e5,
    };

    /// A pressure-relief valve set at `setting_pa` above the accumulator: the same size-10
    /// bore, fully open 10 % above its setting **\[choice\]** (the order of a direct-operated
    /// relief valve's pressure override in makers' Δp–Q curves) and laminar below 0.05 bar.
    pub fn relief(setting_pa: f64) -> Valve {
        Valve {
            crack_pa: setting_pa,
            open_range_pa: 0.1 * setting_pa,
            ..Valve::ANTI_CAVITATION
        }
    }

    /// The flow (m³/s) through the valve at pressure drop `dp` (Pa) across it, inlet minus
    /// outlet; zero below the cracking pressure.
    pub fn flow<T: Scalar>(&self, dp: T) -> T {
        self.flow_opened_by(dp, dp)
    }

    /// The flow (m³/s) at pressure drop `dp` (Pa, inlet minus outlet) through the valve opened
    /// by the signal `signal` (Pa): shut while the signal is below the cracking pressure, fully
    /// open from the cracking pressure plus the opening range. A plain valve's signal is its
    /// pressure drop ([`Valve::flow`]); a pilot-operated one adds its pilot ([`PilotCheck`]).
    pub fn flow_opened_by<T: Scalar>(&self, signal: T, dp: T) -> T {
        let t = (signal - self.crack_pa) / self.open_range_pa;
        if t <= 0.0 {
            return T::from(0.0);
        }
        let s = if t >= 1.0 {
            T::from(1.0)
        } else {
            t * t * (T::from(3.0) - t * 2.0)
        };
        let lam2 = self.laminar_pa * self.laminar_pa;
        let root = (dp * dp + lam2).sqrt().sqrt();
        s * (DISCHARGE_COEFFICIENT * self.area_m2 * (2.0 / OIL_DENSITY_KG_PER_M3).sqrt()) * dp
            / root
    }
}

/// A pilot-operated check valve from the accumulator into a chamber (the single-pump circuit of
/// the article's Figure 1a, docs/circuits.md#the-pilot-operated-check-valves): a check valve
/// whose poppet the other chamber's pressure, on a pilot piston `pilot_ratio` times the seat's
/// area, pushes open. Its opening signal is
///
/// s = (p_acc − p) + k (p_pilot − p_acc),
///
/// the seat's pressure drop plus the pilot's push, both measured from the accumulator line (the
/// pilot piston's spring side drains there **\[choice\]**); the valve follows [`Valve`]'s law on
/// this signal: shut below the cracking pressure, fully open from the cracking pressure plus
/// the opening range, and the orifice flow in either direction by the seat's pressure drop
/// p_acc − p once open (the control pressure of Simscape Fluids' Pilot-Operated Check Valve (IL)
/// and of Hopsan's `HydraulicPilotControlledCheckValve`: seat drop plus pilot ratio times pilot).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PilotCheck {
    /// The check valve: cracking pressure, opening range, area, laminar range.
    pub valve: Valve,
    /// Pilot piston area over the seat's area, k.
    pub pilot_ratio: f64,
}

impl PilotCheck {
    /// The opening signal (Pa) at chamber pressure `p`, pilot pressure `p_pilot` and
    /// accumulator pressure `p_acc` (Pa).
    pub fn signal<T: Scalar>(&self, p: T, p_pilot: T, p_acc: f64) -> T {
        (T::from(p_acc) - p) + (p_pilot - p_acc) * self.pilot_ratio
    }

    /// The flow (m³/s) into the chamber at pressure `p` with pilot pressure `p_pilot` and
    /// accumulator pressure `p_acc` (Pa); negative when the pilot holds the valve open and the
    /// chamber is above the accumulator.
    pub fn into_chamber<T: Scalar>(&self, p: T, p_pilot: T, p_acc: f64) -> T {
        let dp = T::from(p_acc) - p;
        (self.valve).flow_opened_by(self.signal(p, p_pilot, p_acc), dp)
    }

    /// The pilot pressure above the accumulator (Pa) that holds the valve fully open with its
    /// chamber at the accumulator pressure: (Δp_crack + Δp_open)/k.
    pub fn held_open_above_pa(&self) -> f64 {
        (self.valve.crack_pa + self.valve.open_range_pa) / self.pilot_ratio
    }

    /// The pilot pressure above the accumulator (Pa) below which the valve shuts with its
    /// chamber at the accumulator pressure: Δp_crack/k.
    pub fn shut_below_pa(&self) -> f64 {
        self.valve.crack_pa / self.pilot_ratio
    }
}

/// A warning when `rig`'s relief valves do not protect its cylinder (docs/circuits.md#valves):
/// the highest chamber pressure they let through, the accumulator's pre-charge plus their
/// setting ([`crate::rig::Rig::relief_setting_pa`], given or derived), above the rig's
/// `cylinder_rated_pressure_bar`. `None` for the DPM, which has no relief valves, and for a
/// setting within the rating.
///
/// ```
/// use pumpcyl::circuit::valves::relief_warning;
/// use pumpcyl::rig::Rig;
///
/// let one = |sets: &[&str]| {
///     let mut all = vec!["circuit=single-pump".to_string()];
///     all.extend(sets.iter().map(|s| s.to_string()));
///     Rig::default().with_overrides(&all)
/// };
/// // the article's 12.5 N m on 6 cm³/rev: 130.9 bar, within ISO 6022's 250 bar
/// assert_eq!(relief_warning(&one(&[])?), None);
/// let w = relief_warning(&one(&["motor_rated_torque_nm=64", "displacement_1_cm3_per_rev=2.5"])?);
/// assert!(w.unwrap().starts_with("relief valves set 1608.5 bar above the accumulator"));
/// assert_eq!(relief_warning(&one(&["motor_rated_torque_nm=64", "relief_setting_bar=200"])?), None);
/// # Ok::<(), pumpcyl::rig::RigError>(())
/// ```
pub fn relief_warning(rig: &crate::rig::Rig) -> Option<String> {
    use crate::units::PA_PER_BAR;
    // a circuit without valves has no relief setting to warn of
    rig.circuit.description().valves?;
    let setting_bar = rig.relief_setting_pa(rig.circuit) / PA_PER_BAR;
    let highest_bar = rig.accumulator_precharge_bar + setting_bar;
    if highest_bar <= rig.cylinder_rated_pressure_bar {
        return None;
    }
    let why = match rig.relief_setting_bar {
        Some(_) => "the rig's relief_setting_bar".to_string(),
        None => format!(
            "derived: motor_rated_torque_nm {} N m over the displacement; set relief_setting_bar",
            crate::units::readable(rig.motor_rated_torque_nm)
        ),
    };
    Some(format!(
        "relief valves set {setting_bar:.1} bar above the accumulator ({why}) let a chamber reach \
         {highest_bar:.1} bar, above cylinder_rated_pressure_bar = {} bar: they do not protect \
         the cylinder (docs/circuits.md#valves)",
        crate::units::readable(rig.cylinder_rated_pressure_bar)
    ))
}

/// The band a chamber pressure of `rig`'s circuit keeps to for its linear model to hold
/// (bar gauge), each edge with what sets it (docs/identification.md#designing-the-sweep): the
/// DPM's the cavitation floor ([`crate::cavitation`]) and no upper edge; the dual-pump
/// circuit's from its anti-cavitation check valves' cracking below the accumulator
/// ([`Valve::ANTI_CAVITATION`]) to its relief valves' setting above it; the single-pump
/// circuit's compressible chamber (the other one is held at the accumulator) from where its
/// pilot lets the open check valve shut ([`PilotCheck::shut_below_pa`], the mode switches) to
/// the relief valves' setting. Each edge at least the cavitation floor.
pub fn pressure_band_bar(rig: &crate::rig::Rig) -> [(f64, &'static str); 2] {
    rig.circuit.pressure_band_bar(rig)
}

/// A band from `low` (bar gauge, with what sets it) to the relief valves' setting above the
/// accumulator, the low edge at least the cavitation floor ([`pressure_band_bar`]).
pub(crate) fn band_up_to_relief(
    rig: &crate::rig::Rig,
    low: f64,
    why: &'static str,
) -> [(f64, &'static str); 2] {
    use crate::cavitation::VAPOUR_PRESSURE_BAR_GAUGE as FLOOR;
    use crate::units::PA_PER_BAR;
    let relief = rig.accumulator_precharge_bar + rig.relief_setting_pa(rig.circuit) / PA_PER_BAR;
    [
        (low.max(FLOOR), why),
        (relief, "its relief valve's setting"),
    ]
}

/// The valves of a single-motor circuit: one anti-cavitation check valve from the accumulator
/// into each chamber, and a relief valve from each chamber to the accumulator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Valves {
    /// Check valves accumulator → chamber 1, accumulator → chamber 2.
    pub check: [Valve; 2],
    /// Relief valves chamber 1 → accumulator, chamber 2 → accumulator.
    pub relief: [Valve; 2],
}

impl Valves {
    /// Check valves [`Valve::ANTI_CAVITATION`], relief valves set at `relief_setting_pa` above
    /// the accumulator.
    pub fn new(relief_setting_pa: f64) -> Valves {
        Valves {
            check: [Valve::ANTI_CAVITATION; 2],
            relief: [Valve::relief(relief_setting_pa); 2],
        }
    }

    /// The net flow (m³/s) the valves put into chamber `i` (0 or 1) at chamber pressure `p`
    /// and accumulator pressure `p_acc` (Pa).
    pub fn into_chamber<T: Scalar>(&self, i: usize, p: T, p_acc: f64) -> T {
        let dp = T::from(p_acc) - p;
        self.check[i].flow(dp) - self.relief[i].flow(-dp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    #[test]
    fn the_opening_is_smooth_and_the_flow_turbulent_when_open() {
        let v = Valve::ANTI_CAVITATION;
        // shut below cracking, half open halfway through the range (s(1/2) = 1/2)
        assert_eq!(v.flow(0.0), 0.0);
        assert_eq!(v.flow(-3e5), 0.0);
        let dp = 1.0e5;
        let k = DISCHARGE_COEFFICIENT * v.area_m2 * (2.0 / OIL_DENSITY_KG_PER_M3).sqrt();
        let turbulent = k * dp / (dp * dp + v.laminar_pa * v.laminar_pa).powf(0.25);
        assert!((v.flow(dp) / (0.5 * turbulent) - 1.0).abs() < 1e-12);
        // the derivative is continuous at both ends of the opening range
        let slope = |p: f64| v.flow(Dual64::new(p, 1.0)).eps;
        assert_eq!(slope(v.crack_pa - 1.0), 0.0);
        assert!(slope(v.crack_pa + 1.0).abs() < 1e-12);
        let end = v.crack_pa + v.open_range_pa;
        assert!((slope(end - 1e-3) / slope(end + 1e-3) - 1.0).abs() < 1e-6);
    }

    /// The pilot holds the valve open against a chamber above the accumulator, and the flow
    /// then runs back to the accumulator; without pilot it is the plain check valve.
    #[test]
    fn a_pilot_holds_the_check_valve_open_in_both_directions() {
        let pc = PilotCheck {
            valve: Valve::ANTI_CAVITATION,
            pilot_ratio: 3.0,
        };
        let p_acc = 5e5;
        // no pilot (pilot at the accumulator): the check valve alone
        for p in [3e5, 4.6e5, 6e5] {
            assert_eq!(
                pc.into_chamber(p, p_acc, p_acc),
                Valve::ANTI_CAVITATION.flow(p_acc - p)
            );
        }
        // chamber 0.2 bar above the accumulator: shut until the pilot overcomes the seat's
        // 0.2 bar and the 0.5 bar spring, (0.2 + 0.5)/3 bar above the accumulator
        let p = 5.2e5;
        assert_eq!(pc.into_chamber(p, p_acc + 0.23e5, p_acc), 0.0);
        assert!(pc.into_chamber(p, p_acc + 0.24e5, p_acc) < 0.0);
        let full = pc.into_chamber(p, p_acc + 10e5, p_acc);
        assert_eq!(full, -Valve::ANTI_CAVITATION.flow_opened_by(10.0e5, 0.2e5));
        assert!((pc.held_open_above_pa() - 0.5e5).abs() < 1e-9);
        assert!((pc.shut_below_pa() - 0.5e5 / 3.0).abs() < 1e-9);
    }

    #[test]
    fn relief_vents_above_its_setting_and_check_feeds_below_the_accumulator() {
        let valves = Valves::new(80e5);
        let p_acc = 5e5;
        assert_eq!(valves.into_chamber(0, 4.8e5, p_acc), 0.0);
        assert!(valves.into_chamber(0, 3e5, p_acc) > 0.0);
        assert_eq!(valves.into_chamber(1, 80e5, p_acc), 0.0);
        assert!(valves.into_chamber(1, 95e5, p_acc) < 0.0);
    }
}
