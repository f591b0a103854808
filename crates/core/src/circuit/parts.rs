//! The physical parts a circuit's equations are made of, written once over [`Scalar`] so every
//! circuit builds its right-hand side from the same pieces (docs/model.md, docs/emulator.md):
//! the piston ([`Piston`]), a chamber ([`Chamber`]) filled with a fluid ([`Fluid`]), a pump
//! ([`Pump`]) and a drive ([`Drive`], or the first-order motor [`FirstOrderMotor`]).
//!
//! [`Effects`] are the switches of these parts beyond the linear model. With every effect off
//! each part is the ideal one the linear model of the article §2.3.1 (Figure 4) is made of, so
//! the exact Jacobian of a circuit's equations is that model.

use super::stops::Stops;
use super::{Role, Scalar, Signal};
use crate::bulk::models::BulkModel;
pub use crate::bulk::models::{effective_beta_of, gas_fraction_of};
use crate::rig::{ARTICLE_COULOMB_FRICTION_N, ARTICLE_PUMP_SLIP_M5_PER_NS, PUMP_DEAD_BAND_RPM};
use crate::units::PA_PER_BAR;

/// Absolute pressure of a gauge pressure of 0 (Pa): the cavitation floor is −1 bar gauge.
pub const ATMOSPHERE_PA: f64 = 1e5;
/// Pure-oil bulk modulus of the article (bar).
pub const BETA_OIL_BAR: f64 = 17_000.0;
/// Velocity scale of the smooth Coulomb friction sign (m/s).
pub const COULOMB_SMOOTHING_M_S: f64 = 1e-3;

/// The speed over which a pump's Coulomb torque loss reverses with the rotation (rad/s): its
/// sign smoothed as tanh(ω / this), as the piston's Coulomb friction's (a tenth of the article
/// rig's 60 rpm dead band).
pub const PUMP_FRICTION_SMOOTHING_RAD_S: f64 = 0.6;

/// The effects beyond the LTI model, each switchable: the switches of the parts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Effects {
    /// Chamber volumes V1 = VL1 + A1 x, V2 = VL2 + A2 (x_max − x) instead of fixed at x0.
    pub varying_volumes: bool,
    /// Gas fraction X of the bulk-modulus model: β_e of both chambers from their mean pressure
    /// (p1 + p2)/2, as docs/bulk-modulus.md#the-constant-gas-fraction-model defines it; `None` keeps β constant.
    pub gas_fraction: Option<f64>,
    /// The model of β_e against pressure the gas fraction belongs to
    /// (docs/bulk-modulus.md#a-family-of-models): the article's unless a rig names another.
    pub bulk_model: BulkModel,
    /// Pure-oil bulk modulus (bar) for the gas-fraction model.
    pub beta_oil_bar: f64,
    /// Motor torque limit as a multiple of the rated torque; `None` = unlimited.
    pub peak_torque_factor: Option<f64>,
    /// Pumps cannot be driven beyond their maximum speed (the rig's `pump_max_speed_rpm`).
    pub pump_speed_limit: bool,
    /// Pump speed below which the delivered flow fades out and the slip leakage sets in
    /// (rad/s); 0 = ideal pumps.
    pub dead_band_rad_s: f64,
    /// Extra internal leakage of a pump turning slower than the dead band, across its ports
    /// (m⁵/(N·s)): full at standstill, none at the dead-band speed.
    pub slip_m5_per_ns: f64,
    /// Coulomb friction force (N); 0 = none.
    pub coulomb_n: f64,
    /// A pump's Coulomb torque loss as a fraction C_f of its ideal torque D·|Δp|; 0 = none.
    pub pump_friction_fraction: f64,
    /// A pump's viscous torque loss b_p·ω (N·m·s/rad); 0 = none.
    pub pump_viscous_nms_per_rad: f64,
    /// The moving mass follows the rig's `mass_by_position` along the stroke ([`MassLaw`]);
    /// off, or a rig without a table, keeps `mass_kg` everywhere.
    pub stroke_mass: bool,
}

/// The emulated drives' torque limit over their rated torque (docs/emulator.md#the-dynamics):
/// a servo drive's short-time peak.
pub const PEAK_TORQUE_FACTOR: f64 = 3.0;

impl Effects {
    /// Everything off: the dynamics linearise to the analytic model.
    pub fn none() -> Effects {
        Effects {
            varying_volumes: false,
            gas_fraction: None,
            bulk_model: BulkModel::ConstantGasFraction,
            beta_oil_bar: BETA_OIL_BAR,
            peak_torque_factor: None,
            pump_speed_limit: false,
            dead_band_rad_s: 0.0,
            slip_m5_per_ns: 0.0,
            coulomb_n: 0.0,
            pump_friction_fraction: 0.0,
            pump_viscous_nms_per_rad: 0.0,
            stroke_mass: false,
        }
    }

    /// Every effect on with the gas fraction `x` (docs/emulator.md#the-dynamics): volumes
    /// following the piston, β_e(p) of the constant gas-fraction model, a 3× peak torque, the
    /// pump speed limit, the article rig's 60 rpm pump dead band with its 4e-11 m⁵/(N·s) slip
    /// leakage and 15 N Coulomb friction, and the moving mass following the rig's
    /// `mass_by_position`. [`Effects::with_rig`] puts another rig's own dead band, slip and
    /// friction in (docs/emulator.md#what-a-user-rig-gets).
    pub fn all(x: f64) -> Effects {
        Effects {
            varying_volumes: true,
            gas_fraction: Some(x),
            bulk_model: BulkModel::ConstantGasFraction,
            beta_oil_bar: BETA_OIL_BAR,
            peak_torque_factor: Some(PEAK_TORQUE_FACTOR),
            pump_speed_limit: true,
            dead_band_rad_s: PUMP_DEAD_BAND_RPM * crate::units::RAD_S_PER_RPM,
            slip_m5_per_ns: ARTICLE_PUMP_SLIP_M5_PER_NS,
            coulomb_n: ARTICLE_COULOMB_FRICTION_N,
            pump_friction_fraction: 0.0,
            pump_viscous_nms_per_rad: 0.0,
            stroke_mass: true,
        }
    }

    /// The pumps' speed limit (rad/s) these effects put on `rig`: its `pump_max_speed_rpm`
    /// where the limit is on.
    pub fn pump_speed_limit_rad_s(&self, rig: &crate::rig::Rig) -> Option<f64> {
        (self.pump_speed_limit).then_some(rig.pump_max_speed_rpm * crate::units::RAD_S_PER_RPM)
    }

    /// These effects with `rig`'s own pump dead band, slip leakage and Coulomb friction (its
    /// keys `pump_dead_band_rpm`, `pump_slip_m5_per_ns`, `coulomb_friction_n`, or the defaults
    /// [`crate::rig::Rig::pump_slip`] and [`crate::rig::Rig::coulomb_friction`] derive) and its
    /// pumps' torque losses (`pump_friction_torque_fraction`, `pump_viscous_torque_nms_per_rad`;
    /// docs/energy.md#the-pumps): on the article's rig exactly [`Effects::all`]'s
    /// (docs/emulator.md#what-a-user-rig-gets).
    pub fn with_rig(self, rig: &crate::rig::Rig) -> Effects {
        Effects {
            dead_band_rad_s: rig.pump_dead_band_rpm * crate::units::RAD_S_PER_RPM,
            slip_m5_per_ns: rig.pump_slip(),
            coulomb_n: rig.coulomb_friction(),
            pump_friction_fraction: rig.circuit_key("pump_friction_torque_fraction"),
            pump_viscous_nms_per_rad: rig.circuit_key("pump_viscous_torque_nms_per_rad"),
            ..self
        }
    }
}

/// `a` where its value is at least `b`, `b` otherwise (and where `a` is not a number), as
/// `f64::max` does.
fn at_least<T: Scalar>(a: T, b: f64) -> T {
    if a.re() >= b {
        a
    } else {
        T::from(b)
    }
}

/// The piston and the mass it moves: Newton with viscous and smooth Coulomb friction, the
/// end stops and the mass law along the stroke (docs/model.md#newton, docs/emulator.md).
#[derive(Debug, Clone, PartialEq)]
pub struct Piston {
    /// The areas the two chambers' pressures push on, A1 (extending) and A2 (retracting) (m²).
    pub areas_m2: [f64; 2],
    /// Viscous friction (N·s/m).
    pub viscous_ns_per_m: f64,
    /// Moving mass at x0 (kg).
    pub mass_kg: f64,
    /// External force against extension (N).
    pub force_ext_n: f64,
    /// Coulomb friction force (N).
    pub coulomb_n: f64,
    /// The mass along the stroke.
    pub mass_law: MassLaw,
    /// The ends of the stroke, if they act (docs/emulator.md#end-stops).
    pub stops: Option<Stops>,
}

impl Piston {
    /// The acceleration (m/s²) at position `x` (m), velocity `v` (m/s) and the gauge pressures
    /// `p` (Pa) on A1 and A2.
    pub fn acceleration<T: Scalar>(&self, x: T, v: T, p: [T; 2]) -> T {
        let coulomb = (v / COULOMB_SMOOTHING_M_S).tanh() * self.coulomb_n;
        let stop = self.stops.map_or(T::from(0.0), |s| s.force_n(x, v));
        let force = p[0] * self.areas_m2[0]
            - p[1] * self.areas_m2[1]
            - self.force_ext_n
            - v * self.viscous_ns_per_m
            - coulomb
            + stop;
        // a constant mass divides as a number: the derivatives are then exactly the linear
        // model's quotients
        if self.mass_law.is_constant() {
            force / self.mass_kg
        } else {
            force / (self.mass_law.ratio_of(x) * self.mass_kg)
        }
    }
}

/// The forces on a piston besides its pressures, the external force and its inertia (N,
/// positive extending): what [`Piston::acceleration`] subtracts or adds, for the power account
/// (docs/energy.md#the-cylinder).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PistonForces {
    /// Viscous friction b·v, against the motion.
    pub viscous_n: f64,
    /// Coulomb friction (smoothed), against the motion.
    pub coulomb_n: f64,
    /// The end stops' push back into the stroke.
    pub stop_n: f64,
}

impl Piston {
    /// The friction and stop forces at position `x` (m) and velocity `v` (m/s), as
    /// [`Piston::acceleration`] takes them.
    pub fn forces(&self, x: f64, v: f64) -> PistonForces {
        PistonForces {
            viscous_n: v * self.viscous_ns_per_m,
            coulomb_n: (v / COULOMB_SMOOTHING_M_S).tanh() * self.coulomb_n,
            stop_n: self.stops.map_or(0.0, |s| s.force_n(x, v)),
        }
    }

    /// The moving mass at position `x` (kg), as [`Piston::acceleration`] divides by it.
    pub fn mass_at(&self, x: f64) -> f64 {
        match self.mass_law.is_constant() {
            true => self.mass_kg,
            false => self.mass_law.ratio_of(x) * self.mass_kg,
        }
    }
}

/// The oil's bulk modulus: constant, or the gas-fraction law β_e(p)
/// (docs/bulk-modulus.md#the-constant-gas-fraction-model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fluid {
    /// The constant bulk modulus (Pa), without a gas fraction.
    pub beta_pa: f64,
    /// The gas fraction of the β_e(p) law, if it acts.
    pub gas_fraction: Option<f64>,
    /// The model of the law (docs/bulk-modulus.md#a-family-of-models).
    pub bulk_model: BulkModel,
    /// Pure-oil bulk modulus (bar) of the law.
    pub beta_oil_bar: f64,
}

/// A bulk modulus (Pa): constant, or a function of the pressure.
#[derive(Debug, Clone, Copy)]
pub enum Beta<T> {
    /// The same at every pressure.
    Constant(f64),
    /// Its value at the pressure asked.
    Varying(T),
}

impl<T: Scalar> Beta<T> {
    /// Its value (Pa).
    pub fn value(self) -> T {
        match self {
            Beta::Constant(b) => T::from(b),
            Beta::Varying(b) => b,
        }
    }
}

impl Fluid {
    /// The fluid of a circuit: the rig's constant bulk modulus `beta_pa` (Pa), with the
    /// gas-fraction law where the effects `e` turn it on.
    pub fn of(beta_pa: f64, e: &Effects) -> Fluid {
        Fluid {
            beta_pa,
            gas_fraction: e.gas_fraction,
            bulk_model: e.bulk_model,
            beta_oil_bar: e.beta_oil_bar,
        }
    }

    /// Bulk modulus (Pa) at a gauge pressure (Pa).
    pub fn beta<T: Scalar>(&self, p_gauge: T) -> Beta<T> {
        match self.gas_fraction {
            None => Beta::Constant(self.beta_pa),
            Some(x) => {
                let p_bar = at_least(p_gauge / PA_PER_BAR, self.bulk_model.floor_bar());
                Beta::Varying(self.bulk_model.beta(x, p_bar, self.beta_oil_bar) * PA_PER_BAR)
            }
        }
    }
}

/// A chamber's volume: fixed, or following the piston.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Volume {
    /// Fixed (m³).
    Fixed(f64),
    /// The cap side: the dead volume (m³) plus the area (m²) times the position.
    Cap {
        /// Dead (line) volume (m³).
        dead_m3: f64,
        /// Piston area (m²).
        area_m2: f64,
    },
    /// The rod side: the dead volume (m³) plus the area (m²) times the stroke left.
    Rod {
        /// Dead (line) volume (m³).
        dead_m3: f64,
        /// Annulus area (m²).
        area_m2: f64,
        /// Stroke (m).
        stroke_m: f64,
    },
}

/// A chamber: continuity with the fluid's bulk modulus, its volume and the cavitation floor
/// (docs/model.md#continuity, docs/model.md#cavitation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chamber {
    /// Its volume.
    pub volume: Volume,
}

impl Chamber {
    /// The volume (m³) at piston position `x` (m).
    pub fn volume_m3<T: Scalar>(&self, x: T) -> T {
        match self.volume {
            Volume::Fixed(v) => T::from(v),
            Volume::Cap { dead_m3, area_m2 } => x * area_m2 + dead_m3,
            Volume::Rod {
                dead_m3,
                area_m2,
                stroke_m,
            } => (T::from(stroke_m) - x) * area_m2 + dead_m3,
        }
    }

    /// dp/dt (Pa/s) of the chamber at pressure `p` (Pa gauge) with bulk modulus `beta` (Pa),
    /// piston at `x`, and the net inflow `q` (m³/s); a pressure at the cavitation floor
    /// (−1 bar gauge) does not fall further.
    pub fn pressure_rate<T: Scalar>(&self, beta: Beta<T>, x: T, p: T, q: T) -> T {
        let dp = match (beta, self.volume) {
            // a constant stiffness β/V multiplies as a number: the derivatives are then
            // exactly the linear model's products
            (Beta::Constant(b), Volume::Fixed(v)) => q * (b / v),
            (beta, _) => beta.value() / self.volume_m3(x) * q,
        };
        if p <= -ATMOSPHERE_PA && dp < 0.0 {
            T::from(0.0)
        } else {
            dp
        }
    }
}

/// A fixed-displacement pump with the low-speed dead band and slip leakage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pump {
    /// Displacement (m³/rad).
    pub displacement_m3: f64,
    /// Speed below which the flow fades out (rad/s); 0 = ideal.
    pub dead_band_rad_s: f64,
    /// Slip leakage across the ports at standstill (m⁵/(N·s)).
    pub slip_m5_per_ns: f64,
    /// Coulomb torque loss as a fraction of D·|Δp|.
    pub friction_fraction: f64,
    /// Viscous torque loss (N·m·s/rad).
    pub viscous_nms_per_rad: f64,
}

impl Pump {
    /// A pump of displacement `d` (m³/rad) with the dead band, slip and torque losses of `e`.
    pub fn of(d: f64, e: &Effects) -> Pump {
        Pump {
            displacement_m3: d,
            dead_band_rad_s: e.dead_band_rad_s,
            slip_m5_per_ns: e.slip_m5_per_ns,
            friction_fraction: e.pump_friction_fraction,
            viscous_nms_per_rad: e.pump_viscous_nms_per_rad,
        }
    }

    /// The torque its friction takes from the shaft at speed `w` (rad/s) against `dp` (Pa)
    /// (docs/energy.md#the-pumps): a Coulomb part C_f·D·|Δp| against the rotation (its sign
    /// smoothed over [`PUMP_FRICTION_SMOOTHING_RAD_S`]) and a viscous part b_p·ω, after
    /// Wilson's pump model; exactly 0 without them.
    pub fn friction_torque<T: Scalar>(&self, w: T, dp: T) -> T {
        if self.friction_fraction == 0.0 && self.viscous_nms_per_rad == 0.0 {
            return T::from(0.0);
        }
        let coulomb = dp.abs() * (self.friction_fraction * self.displacement_m3);
        (w / PUMP_FRICTION_SMOOTHING_RAD_S).tanh() * coulomb + w * self.viscous_nms_per_rad
    }
    /// The flow factor at speed `w`: 1 above the dead band, fading smoothly to 0 at standstill.
    pub fn factor<T: Scalar>(&self, w: T) -> T {
        let db = self.dead_band_rad_s;
        if db <= 0.0 {
            return T::from(1.0);
        }
        let r = (w / db).abs();
        if r >= 1.0 {
            T::from(1.0)
        } else {
            r * r * (T::from(3.0) - r * 2.0)
        }
    }

    /// The delivered flow (m³/s) at speed `w` (rad/s) against the pressure difference `dp`
    /// (Pa) across its ports, outlet minus inlet.
    pub fn flow<T: Scalar>(&self, w: T, dp: T) -> T {
        let f = self.factor(w);
        w * self.displacement_m3 * f - (T::from(1.0) - f) * self.slip_m5_per_ns * dp
    }
}

/// An electric drive: a first-order current loop, a P velocity loop with the filtered
/// feedforward torque after the P gain, a torque limit and the pump's speed limit
/// (docs/model.md#drive-velocity-loops-and-feedforward).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// Motor-plus-pump inertia (kg·m²).
    pub inertia: f64,
    /// Velocity-loop gain (N·m·s/rad).
    pub km: f64,
    /// Current-loop bandwidth (1/s).
    pub omega_i: f64,
    /// Feedforward gain over its filter time constant Kff/τff (N·m·s/rad), if on.
    pub feedforward: Option<f64>,
    /// Feedforward filter time constant (s).
    pub tau_ff_s: f64,
    /// Torque limit (N·m), if any.
    pub torque_limit: Option<f64>,
    /// Speed limit (rad/s), if any.
    pub speed_limit: Option<f64>,
}

/// The rates of a drive's states.
#[derive(Debug, Clone, Copy)]
pub struct DriveRates<T> {
    /// Speed (rad/s²).
    pub speed: T,
    /// Electromagnetic torque (N·m/s).
    pub torque: T,
    /// Feedforward filter (rad/s²), if on.
    pub feedforward: Option<T>,
}

impl Drive {
    /// The rates at speed command `u`, speed `w` (rad/s), torque `tau` (N·m), feedforward
    /// filter `z` (rad/s, if on) and load torque `load` (N·m).
    pub fn rates<T: Scalar>(&self, u: T, w: T, tau: T, z: Option<T>, load: T) -> DriveRates<T> {
        let feedforward = z.and_then(|z| Some((z, self.feedforward?)));
        let torque = match self.torque_limit {
            // unlimited: ωI (τ_ref − τ) term by term, so its derivatives are the linear
            // model's ωI Km and ωI Kff/τff exactly (docs/model.md#drive-velocity-loops-and-feedforward)
            None => {
                let w_i = self.omega_i;
                let mut rate = (u - w) * self.km * w_i;
                if let Some((z, kf)) = feedforward {
                    rate += (u - z) * kf * w_i;
                }
                rate - tau * w_i
            }
            Some(lim) => {
                let mut t_ref = self.torque_reference(u, w, feedforward);
                if t_ref < -lim {
                    t_ref = T::from(-lim);
                } else if t_ref > lim {
                    t_ref = T::from(lim);
                }
                (t_ref - tau) * self.omega_i
            }
        };
        let mut acc = (tau - load) / self.inertia;
        if self.speed_held(w, acc) {
            acc = T::from(0.0);
        }
        DriveRates {
            speed: acc,
            torque,
            feedforward: feedforward.map(|(z, _)| (u - z) / self.tau_ff_s),
        }
    }
}

impl Drive {
    /// The torque reference before its limit, Km (u − ω) + (Kff/τff)(u − z), with `feedforward`
    /// the filter state and Kff/τff where the feedforward is on.
    fn torque_reference<T: Scalar>(&self, u: T, w: T, feedforward: Option<(T, f64)>) -> T {
        let mut t_ref = (u - w) * self.km;
        if let Some((z, kf)) = feedforward {
            t_ref += (u - z) * kf;
        }
        t_ref
    }

    /// Whether the speed limit holds the acceleration `acc` at zero at speed `w`: at the limit,
    /// accelerating further.
    fn speed_held<T: Scalar>(&self, w: T, acc: T) -> bool {
        self.speed_limit
            .is_some_and(|max| w.abs() >= max && (acc * w) > 0.0)
    }

    /// Which side of its limits the drive is on at speed command `u`, speed `w`, torque `tau`,
    /// feedforward filter `z` and load torque `load`, as [`Drive::rates`] decides it: 0, 1 or 2
    /// with the torque reference within its limit, clamped at −limit or at +limit, plus 3
    /// where the speed limit holds the acceleration at zero. Within one regime the rates are
    /// linear in `u`, `tau` and `z` with coefficients that do not depend on them, so the
    /// Jacobian of the rates depends on these three through the regime alone.
    pub fn regime(&self, u: f64, w: f64, tau: f64, z: Option<f64>, load: f64) -> u64 {
        let feedforward = z.and_then(|z| Some((z, self.feedforward?)));
        let clamp = self.torque_limit.map_or(0, |lim| {
            let t_ref = self.torque_reference(u, w, feedforward);
            if t_ref < -lim {
                1
            } else if t_ref > lim {
                2
            } else {
                0
            }
        });
        let held = self.speed_held(w, (tau - load) / self.inertia);
        clamp + if held { 3 } else { 0 }
    }
}

/// A motor whose speed follows its command with one time constant, ω/ω_ref = 1/(τ s + 1): no
/// load torque, no feedforward (docs/model.md#variants).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FirstOrderMotor {
    /// Time constant (s).
    pub tau_s: f64,
}

impl FirstOrderMotor {
    /// The acceleration (rad/s²) at command `u` and speed `w` (rad/s).
    pub fn acceleration<T: Scalar>(&self, u: T, w: T) -> T {
        (u - w) / self.tau_s
    }
}

/// The one motor of a single-motor circuit (the article's Figure 1a and 1b): drive 1's loops
/// on the shaft's inertia, or the first-order approximation (docs/model.md#variants).
#[derive(Debug, Clone, PartialEq)]
pub enum Motor {
    /// Drive 1's loops (states w, tau and, with the feedforward on, z).
    Full(Drive),
    /// ω/ω_ref = 1/(τ s + 1) (state w).
    FirstOrder(FirstOrderMotor),
}

impl Motor {
    /// The motor of `rig` turning a shaft of inertia `inertia` (kg·m²), with the torque and
    /// speed limits of `e`.
    pub fn of_rig(rig: &crate::rig::Rig, inertia: f64, e: &Effects) -> Motor {
        let si = rig.si();
        if rig.motor_model != crate::rig::MotorModel::Full {
            return Motor::FirstOrder(FirstOrderMotor {
                tau_s: rig.motor_time_constant_s.unwrap_or(inertia / si.km[0]),
            });
        }
        Motor::Full(Drive {
            inertia,
            km: si.km[0],
            omega_i: si.omega_i,
            feedforward: rig.feedforward.then_some(si.kff / si.tau_ff),
            tau_ff_s: si.tau_ff,
            torque_limit: e.peak_torque_factor.map(|f| f * rig.motor_rated_torque_nm),
            speed_limit: e.pump_speed_limit_rad_s(rig),
        })
    }

    /// The same motor without its torque and speed limits (what a Newton step at rest may
    /// cross).
    pub fn without_limits(&self) -> Motor {
        match self {
            Motor::Full(d) => Motor::Full(Drive {
                torque_limit: None,
                speed_limit: None,
                ..*d
            }),
            m => m.clone(),
        }
    }

    /// How many states it has: 1 (first order), 2 (full), 3 (full with feedforward).
    pub fn n_states(&self) -> usize {
        match self {
            Motor::FirstOrder(_) => 1,
            Motor::Full(d) => 2 + usize::from(d.feedforward.is_some()),
        }
    }

    /// Writes the rates of its states, which start at `at` in `s` (speed, torque, feedforward),
    /// into `dx`, at speed command `u` and load torque `load` (N·m).
    pub fn write_rates<T: Scalar>(&self, u: T, s: &[T], load: T, dx: &mut [T], at: usize) {
        match self {
            Motor::FirstOrder(m) => dx[at] = m.acceleration(u, s[at]),
            Motor::Full(drive) => {
                let z = drive.feedforward.map(|_| s[at + 2]);
                let rates = drive.rates(u, s[at], s[at + 1], z, load);
                dx[at] = rates.speed;
                dx[at + 1] = rates.torque;
                if let Some(rate) = rates.feedforward {
                    dx[at + 2] = rate;
                }
            }
        }
    }

    /// Which side of its limits the motor is on ([`Drive::regime`]) at speed command `u` and
    /// load torque `load` (N·m), its states starting at `at` in `s`; a first-order motor has
    /// no limits: 0.
    pub fn regime(&self, u: f64, s: &[f64], load: f64, at: usize) -> u64 {
        match self {
            Motor::FirstOrder(_) => 0,
            Motor::Full(drive) => {
                let z = drive.feedforward.map(|_| s[at + 2]);
                drive.regime(u, s[at], s[at + 1], z, load)
            }
        }
    }

    /// At steady speed (already in `state[at]`) against the load torque `load` (N·m): the
    /// torque that carries it, the feedforward filter settled, and the speed command that holds
    /// it through the P loop (τ = Km (ω_ref − ω)), which it returns.
    pub fn hold(&self, state: &mut [f64], at: usize, load: f64) -> f64 {
        let mut w_ref = state[at];
        if let Motor::Full(drive) = self {
            state[at + 1] = load;
            w_ref += load / drive.km;
            if drive.feedforward.is_some() {
                state[at + 2] = w_ref;
            }
        }
        w_ref
    }
}

/// The rates of a cylinder's states into `dx`, at the state positions `[x, v, p1, p2]` of `s`:
/// Newton on the piston, and continuity in each chamber with the net flows `flows` into it
/// (pumps, piston displacement, leakage, valves) and the bulk modulus of the chambers' mean
/// pressure (docs/model.md#newton, docs/model.md#continuity). Every circuit's equations start
/// with it.
pub fn cylinder_rates<T: Scalar>(
    (piston, chambers, fluid): (&Piston, &[Chamber; 2], &Fluid),
    [x, v, p1, p2]: [usize; 4],
    s: &[T],
    flows: [T; 2],
    dx: &mut [T],
) {
    let (pos, p) = (s[x], [s[p1], s[p2]]);
    dx[x] = s[v];
    dx[v] = piston.acceleration(pos, s[v], p);
    let beta = fluid.beta((p[0] + p[1]) * 0.5);
    dx[p1] = chambers[0].pressure_rate(beta, pos, p[0], flows[0]);
    dx[p2] = chambers[1].pressure_rate(beta, pos, p[1], flows[1]);
}

/// The first `n` states of a one-motor circuit (the article's Figure 1 circuits): x, v, p1, p2,
/// the shaft speed (`shaft` says what turns), then the full drive's torque and feedforward
/// filter state.
pub fn one_motor_states(shaft: &str, n: usize) -> Vec<Signal> {
    let all = [
        Signal::new("x", "m", "piston position", Role::Position),
        Signal::new("v", "m/s", "piston velocity", Role::Velocity),
        Signal::new(
            "p1",
            "Pa",
            "chamber 1 (piston side) pressure, gauge",
            Role::Pressure,
        ),
        Signal::new(
            "p2",
            "Pa",
            "chamber 2 (rod side) pressure, gauge",
            Role::Pressure,
        ),
        Signal::new("w", "rad/s", shaft, Role::MotorSpeed),
        Signal::new("tau", "N*m", "motor electromagnetic torque", Role::Torque),
        Signal::new(
            "z",
            "rad/s",
            "drive feedforward filter state",
            Role::Feedforward,
        ),
    ];
    all.into_iter().take(n).collect()
}

/// The input of a one-motor circuit: its drive's speed command.
pub fn one_motor_inputs() -> Vec<Signal> {
    vec![Signal::new(
        "w_ref",
        "rad/s",
        "drive speed command",
        Role::SpeedCommand,
    )]
}

/// The piston and the two chambers of `rig`'s cylinder with the effects `e` and the end
/// stops `stops`: volumes fixed at x0, or following the piston.
pub fn cylinder_of_rig(
    rig: &crate::rig::Rig,
    e: &Effects,
    stops: Option<Stops>,
) -> (Piston, [Chamber; 2]) {
    let si = rig.si();
    let vl = [rig.line_volume_1_dm3 * 1e-3, rig.line_volume_2_dm3 * 1e-3];
    let volumes = if e.varying_volumes {
        [
            Volume::Cap {
                dead_m3: vl[0],
                area_m2: si.a1,
            },
            Volume::Rod {
                dead_m3: vl[1],
                area_m2: si.a2,
                stroke_m: rig.stroke_mm * 1e-3,
            },
        ]
    } else {
        [Volume::Fixed(si.v1), Volume::Fixed(si.v2)]
    };
    let piston = Piston {
        areas_m2: [si.a1, si.a2],
        viscous_ns_per_m: si.b,
        mass_kg: si.mass,
        force_ext_n: si.f_ext,
        coulomb_n: e.coulomb_n,
        mass_law: if e.stroke_mass {
            MassLaw::of_rig(rig)
        } else {
            MassLaw::constant()
        },
        stops,
    };
    (piston, volumes.map(|volume| Chamber { volume }))
}

/// The moving mass along the stroke, relative to its value at x0: the rig's
/// `mass_by_position` table, interpolated by the quadratic through the three neighbouring table
/// points nearest the position (the line through two for a two-point table), so a three-point table
/// such as the article's seesaw (§3.3) is followed by one smooth parabola, and a position
/// beyond the table extrapolates its end's. The ratio never falls below half the table's
/// smallest mass over its mass at x0, a guard for a wild extrapolation (docs/emulator.md).
#[derive(Debug, Clone, PartialEq)]
pub struct MassLaw {
    /// Table positions (m).
    x_m: Vec<f64>,
    /// Table masses over the table's mass at x0.
    ratio: Vec<f64>,
    /// The smallest ratio the law gives.
    floor: f64,
}

impl MassLaw {
    /// The mass is the same everywhere.
    pub fn constant() -> MassLaw {
        MassLaw {
            x_m: vec![],
            ratio: vec![],
            floor: 0.0,
        }
    }

    /// The law of `rig`'s `mass_by_position` (constant without a table).
    pub fn of_rig(rig: &crate::rig::Rig) -> MassLaw {
        let t = &rig.mass_by_position;
        if t.len() < 2 {
            return MassLaw::constant();
        }
        let mut law = MassLaw {
            x_m: t.iter().map(|p| p.x_mm * 1e-3).collect(),
            ratio: t.iter().map(|p| p.mass_kg).collect(),
            floor: 0.0,
        };
        let at_x0 = law.raw(rig.x0_mm * 1e-3);
        law.ratio.iter_mut().for_each(|r| *r /= at_x0);
        law.floor = 0.5 * law.ratio.iter().cloned().fold(f64::INFINITY, f64::min);
        law
    }

    /// The mass is the same everywhere.
    pub fn is_constant(&self) -> bool {
        self.x_m.is_empty()
    }

    /// The mass at `x_m` (m) over the mass at x0.
    pub fn ratio(&self, x_m: f64) -> f64 {
        self.ratio_of(x_m)
    }

    /// [`MassLaw::ratio`] over `f64` or a dual number (a circuit's equations).
    pub fn ratio_of<T: Scalar>(&self, x_m: T) -> T {
        if self.x_m.is_empty() {
            return T::from(1.0);
        }
        at_least(self.raw(x_m), self.floor)
    }

    /// The interpolating polynomial through the nearest (up to) three points at `x`.
    fn raw<T: Scalar>(&self, x: T) -> T {
        let n = self.x_m.len();
        let xr = x.re();
        let k = self.x_m.partition_point(|p| *p < xr);
        // the window k-2..=k or k-1..=k+1, whichever outer point is nearer x
        let after_is_nearer = k + 1 < n && (k < 2 || self.x_m[k + 1] - xr < xr - self.x_m[k - 2]);
        let lo = (k.saturating_sub(if after_is_nearer { 1 } else { 2 })).min(n.saturating_sub(3));
        let hi = (lo + 3).min(n);
        let (xs, ys) = (&self.x_m[lo..hi], &self.ratio[lo..hi]);
        (0..xs.len())
            .map(|i| {
                let w: T = (0..xs.len())
                    .filter(|j| *j != i)
                    .map(|j| (x - xs[j]) / (xs[i] - xs[j]))
                    .product();
                w * ys[i]
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bulk::models::effective_beta_of as effective_beta;
    use num_dual::Dual64;

    /// d/dx of `f` at `x` by a dual number.
    fn derivative(f: impl Fn(Dual64) -> Dual64, x: f64) -> f64 {
        f(Dual64::new(x, 1.0)).eps
    }

    #[test]
    fn ideal_parts_are_the_linear_model() {
        let fluid = Fluid {
            beta_pa: 1.65e7,
            gas_fraction: None,
            bulk_model: BulkModel::ConstantGasFraction,
            beta_oil_bar: 1.6e4,
        };
        assert_eq!(fluid.beta(3e5_f64).value(), 1.65e7);
        let pump = Pump {
            displacement_m3: 2e-6,
            dead_band_rad_s: 0.0,
            slip_m5_per_ns: 4e-11,
            friction_fraction: 0.0,
            viscous_nms_per_rad: 0.0,
        };
        // ideal pump: flow D ω, no slip
        assert_eq!(derivative(|w| pump.flow(w, Dual64::from(1e5)), 3.0), 2e-6);
        assert_eq!(derivative(|p| pump.flow(Dual64::from(3.0), p), 1e5), 0.0);
        let chamber = Chamber {
            volume: Volume::Rod {
                dead_m3: 1e-3,
                area_m2: 2e-3,
                stroke_m: 0.5,
            },
        };
        // V = VL + A (x_max − x): dV/dx = −A
        assert!((derivative(|x| chamber.volume_m3(x), 0.2) + 2e-3).abs() < 1e-18);
        assert!((chamber.volume_m3(0.2_f64) - 1.6e-3).abs() < 1e-18);
    }

    #[test]
    fn the_gas_fraction_law_differentiates_to_its_analytic_slope() {
        // β_e = 1/(X/p + (1 − X)/β_oil): dβ/dp = β² X/p² (per bar)
        let (x, oil) = (0.01, 1.6e4);
        let fluid = Fluid {
            beta_pa: 0.0,
            gas_fraction: Some(x),
            bulk_model: BulkModel::ConstantGasFraction,
            beta_oil_bar: oil,
        };
        let p_bar = 5.0;
        let beta = effective_beta(x, p_bar, oil);
        let want = beta * beta * x / (p_bar * p_bar);
        let got = derivative(|p| fluid.beta(p).value(), p_bar * PA_PER_BAR);
        assert!((got / want - 1.0).abs() < 1e-12, "{got} vs {want}");
    }

    /// Every model of the family differentiates (the emulator's Jacobians) to the central
    /// difference of its own values, on both sides of the dissolving model's kink at p_c.
    #[test]
    fn every_bulk_model_differentiates_to_its_finite_difference() {
        let models = crate::bulk::models::FAMILY
            .into_iter()
            .chain([BulkModel::EntrainedAir {
                polytropic_index: 1.4,
            }]);
        for model in models {
            let fluid = Fluid {
                beta_pa: 0.0,
                gas_fraction: Some(0.02),
                bulk_model: model,
                beta_oil_bar: 1.7e4,
            };
            for p_bar in [0.5, 4.4, 12.0, 29.0, 45.0] {
                let p = p_bar * PA_PER_BAR;
                let h = 1e-4 * PA_PER_BAR;
                let at = |p: f64| fluid.beta(p).value();
                let want = (at(p + h) - at(p - h)) / (2.0 * h);
                let got = derivative(|p| fluid.beta(p).value(), p);
                let scale = want.abs().max(1e-3);
                assert!(
                    (got - want).abs() < 1e-5 * scale,
                    "{} at {p_bar} bar: {got} vs {want}",
                    model.name()
                );
            }
        }
    }

    #[test]
    fn a_pump_in_its_dead_band_slips_and_delivers_less() {
        let pump = Pump {
            displacement_m3: 2e-6,
            dead_band_rad_s: 6.0,
            slip_m5_per_ns: 4e-11,
            friction_fraction: 0.0,
            viscous_nms_per_rad: 0.0,
        };
        // at standstill only the slip: −slip Δp; at half the band the smoothstep 0.5
        assert_eq!(pump.flow(0.0, 1e5), -4e-11 * 1e5);
        assert!((pump.factor(3.0_f64) - 0.5).abs() < 1e-15);
        assert_eq!(pump.factor(-7.0), 1.0);
    }

    #[test]
    fn a_drive_limits_its_torque_and_its_speed() {
        let drive = Drive {
            inertia: 0.01,
            km: 0.026,
            omega_i: 1257.0,
            feedforward: None,
            tau_ff_s: 0.01,
            torque_limit: Some(20.0),
            speed_limit: Some(100.0),
        };
        let r = drive.rates(1e6, 0.0, 0.0, None, 0.0);
        assert_eq!(r.torque, 20.0 * 1257.0);
        // at the speed limit it cannot accelerate further, but it can slow down
        assert_eq!(drive.rates(0.0, 100.0, 5.0, None, 0.0).speed, 0.0);
        assert_eq!(drive.rates(0.0, 100.0, -5.0, None, 0.0).speed, -500.0);
    }
}
