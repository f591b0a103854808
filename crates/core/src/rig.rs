//! The rig description: every parameter of a dual-prime-mover (DPM) pump-controlled cylinder,
//! read from and written to TOML (the article §2.3.4; docs/formats.md#rig-toml).
//!
//! User-facing keys carry their unit in the name (`beta_bar`, `mass_kg`, `x0_mm`). Inside the
//! code everything is SI: [`Rig::si`] converts once and the model uses only [`RigSi`].
//! The embedded default ([`Rig::default`]) is the article's rig.
//!
//! Build a rig: the article's, or your own from TOML text. A key the text leaves out takes its
//! documented default ([`Rig::file_default`]): the article's value, except `mass_by_position`,
//! which is `[]` (one mass over the stroke), since the article's seesaw table belongs to the
//! article's rig alone. [`Rig::from_toml_str_with_defaults`] also says which keys were left out,
//! so a front end can print them where they are used (docs/formats.md#rig-toml):
//!
//! ```
//! use pumpcyl::rig::Rig;
//!
//! let article = Rig::default();
//! assert_eq!((article.beta_bar, article.mass_kg, article.kp), (165.0, 10593.0, 25.0));
//! assert_eq!(article.mass_by_position.len(), 3);
//!
//! let mine = Rig::from_toml_str("mass_kg = 4898.0\nkp = 40.0\n", "my-rig.toml")?;
//! assert_eq!((mine.mass_kg, mine.kp, mine.beta_bar), (4898.0, 40.0, 165.0));
//! assert!(mine.mass_by_position.is_empty());
//!
//! let file = Rig::from_toml_str_with_defaults("mass_kg = 4898.0\nkp = 40.0\n", "my-rig.toml")?;
//! assert!(file.defaulted.contains(&"beta_bar") && !file.defaulted.contains(&"kp"));
//!
//! // the commented TOML that `pumpcyl rig --print-default` prints reads back to the same rig
//! assert_eq!(Rig::from_toml_str(&article.to_commented_toml(), "default.toml")?, article);
//!
//! // a non-physical value is an error naming the file, the line and the key
//! let err = Rig::from_toml_str("mass_kg = -1.0\n", "my-rig.toml").unwrap_err();
//! assert_eq!(err.to_string(), "my-rig.toml: line 1, key `mass_kg` = -1: must be > 0");
//! # Ok::<(), pumpcyl::rig::RigError>(())
//! ```
//!
//! Change parameters with `KEY=VALUE` overrides, as `--set` does on the command line:
//!
//! ```
//! use pumpcyl::rig::{MotorModel, Rig};
//!
//! let rig = Rig::default().with_overrides(&[
//!     "beta_bar=37.8".to_string(),
//!     "motor_model=first_order".to_string(),
//! ])?;
//! assert_eq!(rig.beta_bar, 37.8);
//! assert_eq!(rig.motor_model, MotorModel::FirstOrder);
//!
//! // an unknown key is refused, with a suggestion
//! let err = rig.with_overrides(&["beta_barr=1".to_string()]).unwrap_err();
//! assert!(err.to_string().contains("did you mean `beta_bar`?"));
//! # Ok::<(), pumpcyl::rig::RigError>(())
//! ```

use crate::circuit::dual_pump::balance::Balance;
use crate::circuit::CircuitKind;
use crate::source_files;
use crate::units::{readable, PA_PER_BAR};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::Path;

/// Errors reading, overriding or validating a rig description.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// TOML syntax, unknown key or wrong type; the message names line, column and key.
    #[error("{file}: {message}")]
    Parse {
        /// The file (or `--set`).
        file: String,
        /// The parser's message, naming line and key.
        message: String,
    },
    /// A rig file without a single key: probably not the rig the user meant (the article's rig
    /// is the default, and its printed form a start for one's own).
    #[error("{file}: line 1: no keys: the file is empty, so it is probably not the rig you meant")]
    Empty {
        /// The file.
        file: String,
    },
    /// A position reference that leaves the stroke.
    #[error(
        "the reference spans {lo_mm} … {hi_mm} mm, outside the stroke (0 … {stroke_mm} mm, \
         `stroke_mm` of the rig, about x0_mm = {x0_mm} mm)"
    )]
    OutsideStroke {
        /// Lowest reference (mm).
        lo_mm: f64,
        /// Highest reference (mm).
        hi_mm: f64,
        /// The rig's stroke (mm).
        stroke_mm: f64,
        /// The rig's operating point (mm).
        x0_mm: f64,
    },
    /// A position beyond the `mass_by_position` table: pumpcyl does not extrapolate a mass.
    #[error(
        "key `mass_by_position` gives the mass from {lo_mm} to {hi_mm} mm only; the position {x_mm} mm \
         needs a point beyond (pumpcyl does not extrapolate a mass; `mass_by_position = []` keeps it constant)"
    )]
    MassOutsideTable {
        /// The position asked for (mm).
        x_mm: f64,
        /// The table's first position (mm).
        lo_mm: f64,
        /// The table's last position (mm).
        hi_mm: f64,
    },
    /// A `KEY=VALUE` override that does not fit.
    #[error("{source_name} {assignment}: {message}")]
    Set {
        /// Where the overrides come from, in the caller's words (`--set`, `[set]`, `override`).
        source_name: String,
        /// The assignment as given.
        assignment: String,
        /// What is wrong.
        message: String,
    },
    /// A key the rig's circuit does not have, set explicitly (docs/circuits.md).
    #[error("{source_name}: {}key `{key}`: the {} circuit has no such key (it belongs to the {}; docs/circuits.md)", line.map_or(String::new(), |l| format!("line {l}, ")), circuit.name(), circuits_text(owners))]
    NotInCircuit {
        /// Where the rig came from (file name, `--set`).
        source_name: String,
        /// The line of the key in the file, when it is written there.
        line: Option<usize>,
        /// The key.
        key: &'static str,
        /// The rig's circuit.
        circuit: CircuitKind,
        /// The circuits the key belongs to.
        owners: Vec<CircuitKind>,
    },
    /// A key no circuit has, or a value of the wrong type for a key a circuit's module
    /// declares ([`crate::circuit::Key`]).
    #[error("{source_name}: {}{message}", at.map_or(String::new(), |(l, c)| format!("line {l}, column {c}: ")))]
    BadKey {
        /// Where the rig came from (file name, `--set`).
        source_name: String,
        /// The line and column of the key in the file, when it is written there.
        at: Option<(usize, usize)>,
        /// The key as written.
        key: String,
        /// What is wrong, naming the key.
        message: String,
    },
    /// A value outside its physical range.
    #[error("{source_name}: {}key `{key}` = {}: {rule}", line.map_or(String::new(), |l| format!("line {l}, ")), readable(*value))]
    Invalid {
        /// Where the rig came from (file name, `--set` or `default`).
        source_name: String,
        /// The line of the key in the file, when it is written there.
        line: Option<usize>,
        /// The key.
        key: &'static str,
        /// The offending value.
        value: f64,
        /// The rule it breaks.
        rule: String,
    },
}

/// Motor (servo drive) model used in the LTI model (docs/model.md#variants).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotorModel {
    /// Full model: rotor + pump inertia, P velocity loop, first-order current loop, filtered
    /// velocity feedforward, load torque from the pressures (docs/model.md#drive-velocity-loops-and-feedforward).
    Full,
    /// First-order approximation common in the literature: ω/ω_ref = 1/(τ s + 1), no load
    /// torque, no feedforward. τ is `motor_time_constant_s`, or, when absent, J_i/Km_i — the
    /// velocity loop's time constant on the motor-plus-pump inertia with feedforward off
    /// **\[choice\]** (docs/choices.md).
    FirstOrder,
}

/// The mass the cylinder moves at one stroke position, where the geometry ties the two (the
/// seesaw's I/r² changes with the lever arm; the article §3.3: 9958 kg at x0 − 50 mm, 10 593 kg
/// at x0, 12 373 kg at x0 + 50 mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MassPoint {
    /// Piston position (mm).
    pub x_mm: f64,
    /// Effective moving mass there (kg).
    pub mass_kg: f64,
}

/// The article's rig: its masses at x0 − 50 mm, x0 and x0 + 50 mm (the article §3.3).
pub const ARTICLE_MASS_BY_POSITION: [MassPoint; 3] = [
    MassPoint {
        x_mm: 295.0,
        mass_kg: 9958.0,
    },
    MassPoint {
        x_mm: 345.0,
        mass_kg: 10593.0,
    },
    MassPoint {
        x_mm: 395.0,
        mass_kg: 12373.0,
    },
];

/// The article-valued rig's accumulator pre-charge (bar gauge): with it the dual-pump circuit
/// on the article's values rests at the DPM's rest pressures, p1 + p2 = 10 bar split by the force
/// balance (docs/circuits.md#the-default-pre-charge).
pub const ACCUMULATOR_PRECHARGE_BAR: f64 = 6.91;

/// The article's rig's cross-port leakage c12 (m⁵/(N·s), the article §2.3.4).
pub const ARTICLE_C12_M5_PER_NS: f64 = 1.2e-10;

/// The emulator's pump dead band (rpm): pumpcyl's value for the article's pumps
/// **\[choice\]**, every rig's default (docs/emulator.md#what-a-user-rig-gets).
pub const PUMP_DEAD_BAND_RPM: f64 = 60.0;

/// The emulator's pump slip leakage on the article's rig (m⁵/(N·s)): pumpcyl's value
/// **\[choice\]**, a third of the rig's c12; another rig's default keeps that ratio to its own
/// c12 ([`Rig::pump_slip`]).
pub const ARTICLE_PUMP_SLIP_M5_PER_NS: f64 = 4e-11;

/// The emulator's Coulomb friction on the article's 63/36 mm cylinder (N): pumpcyl's value
/// **\[choice\]**; another rig's default scales it by its seals' diameters
/// ([`Rig::coulomb_friction`]).
pub const ARTICLE_COULOMB_FRICTION_N: f64 = 15.0;

/// The article's piston and rod diameters added (mm), 63 + 36: the seals' sizes the
/// emulator's 15 N Coulomb friction belongs to.
const ARTICLE_SEAL_DIAMETERS_MM: f64 = 99.0;

/// The one-motor circuits' cylinder rating (bar) where a rig states none: 250 bar, the
/// nominal pressure of the ISO 6022 series of industrial cylinders **\[choice\]**; the relief
/// valves' setting is checked against it (docs/circuits.md#valves).
pub const CYLINDER_RATED_PRESSURE_BAR: f64 = 250.0;

/// The keys a rig may leave out without taking a value of the article's: absent, each is
/// derived from the rig itself (docs/formats.md#rig-toml), each with its allowed range.
const OPTIONAL_KEYS: [(&str, Range); 6] = [
    ("motor_time_constant_s", Range::Positive(1e-6, 1000.0)),
    ("polytropic_index", Range::Positive(1.0, 2.0)),
    ("air_dissolution_pressure_bar", Range::Positive(1e-3, 1e4)),
    ("pump_slip_m5_per_ns", Range::NonNegative(1e-6)),
    ("coulomb_friction_n", Range::NonNegative(1e9)),
    ("relief_setting_bar", Range::Positive(0.001, 1e5)),
];

/// Whether `key` is one of the rig's optional keys (`OPTIONAL_KEYS`), absent unless set.
pub fn is_optional_key(key: &str) -> bool {
    OPTIONAL_KEYS.iter().any(|(k, _)| *k == key)
}

/// Another name a rig file or `--set` may give a key, and the key's own name: the article
/// speaks of the accumulator's pressure, which for a gas accumulator at rest is its pre-charge
/// (docs/circuits.md#single-pump).
const KEY_ALIASES: [(&str, &str); 1] = [("accumulator_pressure_bar", "accumulator_precharge_bar")];

/// The key's own name for `key`, which may be an alias ([`KEY_ALIASES`]).
fn canonical_key(key: &str) -> &str {
    KEY_ALIASES
        .iter()
        .find(|(alias, _)| *alias == key)
        .map_or(key, |(_, own)| own)
}

/// `key` (by its own name) and the circuits it belongs to when `circuit` does not have it;
/// `None` for a key of `circuit` (or of every circuit).
/// The keys not every circuit has are those a circuit's description lists as its own
/// ([`crate::circuit::Description::own_keys`], docs/circuits.md) and the drives' keys
/// ([`crate::circuit::DRIVE_KEYS`]), which every circuit with drives has.
fn foreign_key(circuit: CircuitKind, key: &str) -> Option<(&'static str, Vec<CircuitKind>)> {
    let key = canonical_key(key);
    if let Some((declared, owners)) = declared_key(key) {
        return (!owners.contains(&circuit)).then_some((declared.name, owners));
    }
    if let Some(own) = crate::circuit::DRIVE_KEYS.iter().find(|k| **k == key) {
        let owners: Vec<CircuitKind> = (CircuitKind::ALL.into_iter())
            .filter(|k| k.description().drives > 0)
            .collect();
        return (!owners.contains(&circuit)).then_some((own, owners));
    }
    let owners: Vec<CircuitKind> = (CircuitKind::ALL.into_iter())
        .filter(|k| k.description().own_keys.contains(&key))
        .collect();
    let own = *(owners.first()?.description().own_keys.iter()).find(|k| **k == key)?;
    (!owners.contains(&circuit)).then_some((own, owners))
}

/// The key `name` as a circuit's module declares it, and the circuits that declare it.
fn declared_key(name: &str) -> Option<(crate::circuit::Key, Vec<CircuitKind>)> {
    let declares = |k: &CircuitKind| k.description().keys.iter().any(|d| d.name == name);
    let owners: Vec<CircuitKind> = CircuitKind::ALL.into_iter().filter(declares).collect();
    let key = *(owners.first()?.description().keys.iter()).find(|d| d.name == name)?;
    Some((key, owners))
}

/// Every key that circuits' modules declare, each once, in the order of the list of circuits.
fn declared_keys() -> Vec<crate::circuit::Key> {
    let mut keys: Vec<crate::circuit::Key> = Vec::new();
    for key in CircuitKind::ALL
        .into_iter()
        .flat_map(|k| k.description().keys)
    {
        if !keys.iter().any(|k| k.name == key.name) {
            keys.push(*key);
        }
    }
    keys
}

/// The column (from 1) where `key` starts on line `line` (from 1) of `text`; 1 where it is
/// not found there (a quoted or dotted key).
fn key_column(text: &str, line: usize, key: &str) -> usize {
    let on = text.lines().nth(line.saturating_sub(1)).unwrap_or("");
    on.find(key).map_or(1, |c| on[..c].chars().count() + 1)
}

/// A TOML number as a float.
fn number(value: &toml::Value) -> Option<f64> {
    match value {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// "dpm circuit", "dpm and dual-pump circuits".
fn circuits_text(circuits: &[CircuitKind]) -> String {
    let names: Vec<&str> = circuits.iter().map(|c| c.name()).collect();
    match names.len() {
        1 => format!("{} circuit", names[0]),
        _ => format!("{} circuits", names.join(" and ")),
    }
}

/// Most points a `mass_by_position` table may hold.
pub const MAX_MASS_POINTS: usize = 1000;

/// A DPM rig. Field names are the TOML keys; units are in the names. Absent keys in a file or a
/// `[rig]` table take [`Rig::file_default`]: the article's rig (the article §2.3.4) with one mass
/// over the stroke (docs/formats.md#rig-toml).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
// unknown keys land in `circuit_keys` (serde's flatten), where `validate` refuses them
#[serde(default = "Rig::file_default")]
pub struct Rig {
    /// The hydraulic circuit: the article's dual-prime-mover circuit (`dpm`, the default), one
    /// motor turning two pumps (`dual-pump`, the article's Figure 1b) or one pump with
    /// pilot-operated check valves (`single-pump`, Figure 1a; docs/circuits.md).
    pub circuit: CircuitKind,
    /// Piston diameter d1 (mm).
    pub piston_diameter_mm: f64,
    /// Rod diameter d2 (mm).
    pub rod_diameter_mm: f64,
    /// Line volume between pump and chamber 1, VL1 (dm³).
    pub line_volume_1_dm3: f64,
    /// Line volume between pump and chamber 2, VL2 (dm³).
    pub line_volume_2_dm3: f64,
    /// Cylinder stroke x_max (mm).
    pub stroke_mm: f64,
    /// Operating-point position x0 used for the chamber volumes (mm).
    pub x0_mm: f64,
    /// Motor 1 rotor inertia Jm1 (kg·mm²).
    pub motor_inertia_1_kg_mm2: f64,
    /// Motor 2 rotor inertia Jm2 (kg·mm²).
    pub motor_inertia_2_kg_mm2: f64,
    /// Pump 1 inertia Jp1 (kg·mm²).
    pub pump_inertia_1_kg_mm2: f64,
    /// Pump 2 inertia Jp2 (kg·mm²).
    pub pump_inertia_2_kg_mm2: f64,
    /// Pump 1 displacement D1 (cm³/rev), between chamber 2 and chamber 1.
    pub displacement_1_cm3_per_rev: f64,
    /// Pump 2 displacement D2 (cm³/rev), between reservoir and chamber 1.
    pub displacement_2_cm3_per_rev: f64,
    /// Current-loop bandwidth ωI (rad/s).
    pub current_loop_bandwidth_rad_per_s: f64,
    /// Drive 1 velocity-loop P gain Km1 (N·m·s/rad).
    pub km1_nms_per_rad: f64,
    /// Drive 2 velocity-loop P gain Km2 (N·m·s/rad).
    pub km2_nms_per_rad: f64,
    /// Drive velocity feedforward gain Kff (kg·m²), a torque per angular acceleration.
    pub kff_kg_m2: f64,
    /// Feedforward filter time constant τff (s).
    pub tau_ff_s: f64,
    /// Normalised command to motor speed, K_scale (rad/s per unit command).
    pub k_scale_rad_per_s: f64,
    /// First-order motor time constant (s); absent = J_i/Km_i per motor. Only for
    /// `motor_model = "first_order"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motor_time_constant_s: Option<f64>,
    /// Effective moving mass m (kg) at x0.
    pub mass_kg: f64,
    /// The mass at each stroke position where the geometry ties them, increasing in `x_mm`
    /// (docs/formats.md#rig-toml). Between points the mass is interpolated linearly; a load
    /// case of another mass scales the same way, by its ratio to the table's mass at x0. Empty:
    /// the mass is `mass_kg` over the whole stroke.
    pub mass_by_position: Vec<MassPoint>,
    /// External force F_ext (N); zero at the horizontal position.
    pub external_force_n: f64,
    /// Effective bulk modulus β (bar): the linear model's, and where β_e varies with pressure
    /// (the emulator, `design --p-mean-bar`, `select`) its value at the rig's anchor
    /// (docs/bulk-modulus.md#the-anchor).
    pub beta_bar: f64,
    /// The model of β_e against pressure through `beta_bar` at the anchor
    /// (docs/bulk-modulus.md#a-family-of-models): `constant-gas-fraction` (the article's §3.1,
    /// the default), `constant-gas-fraction-absolute`, `entrained-air` or
    /// `entrained-air-dissolving`.
    pub bulk_modulus_model: crate::bulk::models::Form,
    /// The entrained-air models' polytropic index n (1 isothermal … 1.4 adiabatic); absent = 1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub polytropic_index: Option<f64>,
    /// The dissolving model's critical pressure (bar gauge) above which no free air is left;
    /// absent = 30 bar.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub air_dissolution_pressure_bar: Option<f64>,
    /// Viscous friction b (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// Cross-port leakage c12 (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// Accumulator pre-charge p_acc (bar gauge): the pressure of the accumulator line, which sets
    /// the pressure level of the dual- and single-pump circuits (docs/circuits.md#operating-point);
    /// `accumulator_pressure_bar` is another name for it. Not a key of the DPM, whose
    /// sum-pressure loop sets its level.
    #[serde(alias = "accumulator_pressure_bar")]
    pub accumulator_precharge_bar: f64,
    /// Chamber 1 leakage c1 (m⁵/(N·s)); may be negative (absorbs a pump null shift).
    pub c1_m5_per_ns: f64,
    /// Chamber 2 leakage c2 (m⁵/(N·s)); may be negative (absorbs a pump null shift).
    pub c2_m5_per_ns: f64,
    /// Position P gain Kp (normalised command per metre of error).
    pub kp: f64,
    /// Sum-pressure set-point p1 + p2 (bar).
    pub p_sum_ref_bar: f64,
    /// Sum-pressure gain K_pres (normalised command per bar of sum-pressure error): 0.22 by
    /// default (0.15 for the article's lighter 4898 kg load), the article's "22 (15)" (§2.3.4)
    /// read as percent of full command per bar (docs/choices.md#the-sum-pressure-gain-022-per-bar).
    /// Any other value, 22 included, is a valid setting.
    pub k_pres_per_bar: f64,
    /// Sum-pressure split factor Kβ (dimensionless).
    pub k_beta: f64,
    /// The PLC's sample rate (Hz) as the sampled-data margins read the loop
    /// (docs/analysis.md#sampled-data-margins): the article's 100 Hz PLC (§2.3.4).
    pub plc_rate_hz: f64,
    /// The PLC's computation delay (whole samples) between reading the position and applying
    /// the command, as the sampled-data margins read the loop (docs/analysis.md#sampled-data-margins):
    /// 1 by default, a command computed in one cycle and written out in the next
    /// **\[choice\]** (docs/choices.md).
    pub plc_delay_samples: f64,
    /// Motor rated torque (N·m).
    pub motor_rated_torque_nm: f64,
    /// Motor rated speed (rpm).
    pub motor_rated_speed_rpm: f64,
    /// Pump maximum speed (rpm).
    pub pump_max_speed_rpm: f64,
    /// The emulator's pump dead band (rpm): below it a pump's flow fades out and its slip
    /// leakage sets in (docs/emulator.md#the-dynamics); 0 = ideal pumps.
    pub pump_dead_band_rpm: f64,
    /// The emulator's pump slip leakage at standstill (m⁵/(N·s)); absent = [`Rig::pump_slip`]'s
    /// default, the article rig's 4e-11 in proportion to the rig's c12.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pump_slip_m5_per_ns: Option<f64>,
    /// The emulator's Coulomb friction on the piston (N); absent = [`Rig::coulomb_friction`]'s
    /// default, the article rig's 15 N in proportion to the seals' diameters d1 + d2.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coulomb_friction_n: Option<f64>,
    /// The dual- and single-pump circuits' relief valves' setting (bar above the accumulator
    /// line); absent = [`Rig::relief_setting_pa`]'s τ_rated / D (docs/circuits.md#valves).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relief_setting_bar: Option<f64>,
    /// The dual- and single-pump circuits' cylinder rating (bar gauge): a relief setting that
    /// lets a chamber go above it is warned about (docs/circuits.md#valves).
    pub cylinder_rated_pressure_bar: f64,
    /// Drive velocity feedforward on (docs/choices.md#feedforward-as-a-torque-after-the-p-gain) or off.
    pub feedforward: bool,
    /// Motor–hydraulics coupling: the D1(p1 − p2) and D2 p1 load torques on the motors.
    pub motor_coupling: bool,
    /// Sum-pressure loop closed in closed-loop simulations. The frequency analysis of the article §2.3.3
    /// opens it regardless (see `model::LoopOptions`).
    pub sum_pressure: bool,
    /// Motor model: "full" or "first_order".
    pub motor_model: MotorModel,
    /// The values of the keys that circuits' modules declare ([`crate::circuit::Key`]), as
    /// written; a key of the rig's circuit left out takes its declared default
    /// ([`Rig::circuit_key`]). A key here that no circuit declares, or that another circuit
    /// declares, is refused by [`Rig::validate`].
    #[serde(flatten)]
    pub circuit_keys: CircuitKeys,
}

/// The values a rig gives the keys circuits' modules declare, by key (see [`Rig::circuit_keys`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct CircuitKeys(pub std::collections::BTreeMap<String, toml::Value>);

impl Default for Rig {
    /// The article's rig (the article §2.3.4; docs/formats.md#rig-toml).
    fn default() -> Self {
        Rig {
            circuit: crate::circuit::ARTICLE,
            piston_diameter_mm: 63.0,
            rod_diameter_mm: 36.0,
            line_volume_1_dm3: 0.1272,
            line_volume_2_dm3: 0.1272,
            stroke_mm: 500.0,
            x0_mm: 345.0,
            motor_inertia_1_kg_mm2: 1600.0,
            motor_inertia_2_kg_mm2: 1600.0,
            pump_inertia_1_kg_mm2: 600.0,
            pump_inertia_2_kg_mm2: 34.0,
            displacement_1_cm3_per_rev: 6.0,
            displacement_2_cm3_per_rev: 3.6,
            current_loop_bandwidth_rad_per_s: 1256.6,
            km1_nms_per_rad: 0.026,
            km2_nms_per_rad: 0.026,
            kff_kg_m2: 0.0016,
            tau_ff_s: 0.0012,
            k_scale_rad_per_s: 314.1593,
            motor_time_constant_s: None,
            mass_kg: 10593.0,
            mass_by_position: ARTICLE_MASS_BY_POSITION.to_vec(),
            external_force_n: 0.0,
            beta_bar: 165.0,
            bulk_modulus_model: crate::bulk::models::Form::ConstantGasFraction,
            polytropic_index: None,
            air_dissolution_pressure_bar: None,
            viscous_friction_ns_per_m: 100.0,
            c12_m5_per_ns: ARTICLE_C12_M5_PER_NS,
            accumulator_precharge_bar: ACCUMULATOR_PRECHARGE_BAR,
            c1_m5_per_ns: 5.49e-11,
            c2_m5_per_ns: -1.19e-11,
            kp: 25.0,
            p_sum_ref_bar: 10.0,
            k_pres_per_bar: 0.22,
            k_beta: 1.4,
            plc_rate_hz: 100.0,
            plc_delay_samples: 1.0,
            motor_rated_torque_nm: 12.5,
            motor_rated_speed_rpm: 3000.0,
            pump_max_speed_rpm: 3600.0,
            pump_dead_band_rpm: PUMP_DEAD_BAND_RPM,
            pump_slip_m5_per_ns: None,
            coulomb_friction_n: None,
            relief_setting_bar: None,
            cylinder_rated_pressure_bar: CYLINDER_RATED_PRESSURE_BAR,
            feedforward: true,
            motor_coupling: true,
            sum_pressure: true,
            motor_model: MotorModel::Full,
            circuit_keys: CircuitKeys::default(),
        }
    }
}

/// The rig in SI units, with the derived quantities of the article §2.3.1 (docs/model.md#geometry).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigSi {
    /// Piston area A1 (m²).
    pub a1: f64,
    /// Annulus area A2 (m²).
    pub a2: f64,
    /// Chamber 1 volume at x0, V1 = VL1 + A1 x0 (m³).
    pub v1: f64,
    /// Chamber 2 volume at x0, V2 = VL2 + A2 (x_max − x0) (m³).
    pub v2: f64,
    /// Motor-plus-pump inertias J1, J2 (kg·m²).
    pub j: [f64; 2],
    /// Motor rotor inertias Jm1, Jm2 (kg·m²).
    pub jm: [f64; 2],
    /// Pump displacements D1, D2 (m³/rad).
    pub d: [f64; 2],
    /// Current-loop bandwidth ωI (1/s).
    pub omega_i: f64,
    /// Velocity-loop gains Km1, Km2 (N·m·s/rad).
    pub km: [f64; 2],
    /// Feedforward gain Kff (kg·m²), zero when feedforward is off.
    pub kff: f64,
    /// Feedforward filter time constant (s).
    pub tau_ff: f64,
    /// Command scale (rad/s per unit).
    pub k_scale: f64,
    /// First-order motor time constants (s).
    pub tau_motor: [f64; 2],
    /// Mass (kg).
    pub mass: f64,
    /// Bulk modulus (Pa).
    pub beta: f64,
    /// Viscous friction (N·s/m).
    pub b: f64,
    /// Leakages c1, c2, c12 (m⁵/(N·s)).
    pub c1: f64,
    /// Chamber 2 leakage (m⁵/(N·s)).
    pub c2: f64,
    /// Cross-port leakage (m⁵/(N·s)).
    pub c12: f64,
    /// Position gain (1/m).
    pub kp: f64,
    /// Sum-pressure gain (1/Pa).
    pub k_pres: f64,
    /// Sum-pressure split factor.
    pub k_beta: f64,
    /// Flow-matching ratio α = (D1/D2)(A1/A2 − 1).
    pub alpha: f64,
    /// Operating-point position x0 (m).
    pub x0: f64,
    /// Sum-pressure set-point (Pa).
    pub p_sum_ref: f64,
    /// External force (N).
    pub f_ext: f64,
}

impl RigSi {
    /// The chamber pressures at rest (Pa gauge): the sum-pressure set-point split by the force
    /// balance p1 A1 − p2 A2 = F_ext (docs/model.md#newton).
    pub fn rest_pressures_pa(&self) -> [f64; 2] {
        let p1 = (self.p_sum_ref * self.a2 + self.f_ext) / (self.a1 + self.a2);
        [p1, self.p_sum_ref - p1]
    }
}

/// A rig read from TOML text, with the keys the text left out (docs/formats.md#rig-toml).
#[derive(Debug, Clone, PartialEq)]
pub struct RigFile {
    /// The rig.
    pub rig: Rig,
    /// The keys the text does not set, in the order of the commented TOML; each took its
    /// value in [`Rig::file_default`]. The optional keys (`motor_time_constant_s`, the emulator's
    /// slip and Coulomb friction, the relief setting) are never listed: absent, each is derived
    /// from the rig itself, not a value of the article's.
    pub defaulted: Vec<&'static str>,
}

/// The keys of `rig`'s circuit a file did not write (`written` says which it did), in the order
/// of the commented TOML; the keys of another circuit take no part in this one.
fn defaulted_keys(rig: &Rig, written: impl Fn(&str) -> bool) -> Vec<&'static str> {
    Rig::key_docs()
        .map(|(key, _)| key)
        .filter(|key| !is_optional_key(key))
        .filter(|key| foreign_key(rig.circuit, key).is_none() && !written(key))
        .collect()
}

impl RigFile {
    /// The same file's record for `rig`, the rig after overrides that may switch its circuit
    /// (`--set circuit=dual-pump`): the keys of that circuit the file left out, so a key of the
    /// new circuit the file could not write (the accumulator's pre-charge of a DPM file) is
    /// named with the value it takes, and the old circuit's own keys are not. A key the file
    /// wrote that the new circuit does not have is refused, naming the file (`file`): it would
    /// be silently ignored.
    pub fn with_rig(&self, rig: Rig, file: &str) -> Result<RigFile, RigError> {
        let old = self.rig.circuit;
        let written = |key: &str| foreign_key(old, key).is_none() && !self.defaulted.contains(&key);
        let wrote: Vec<&str> = (Rig::key_docs().map(|(key, _)| key))
            .filter(|key| written(key))
            .collect();
        rig.check_circuit_keys(file, &wrote)?;
        Ok(RigFile {
            defaulted: defaulted_keys(&rig, written),
            rig,
        })
    }

    /// One line saying which keys `file` leaves out and the values they take, or `None` when it
    /// sets them all; keys in `except` (set another way, such as `--set`) are not named.
    ///
    /// ```
    /// use pumpcyl::rig::Rig;
    ///
    /// let file = Rig::from_toml_str_with_defaults(&Rig::default().to_commented_toml(), "a.toml")?;
    /// assert_eq!(file.note("a.toml", &[]), None);
    /// let file = Rig::from_toml_str_with_defaults("kp = 15.0\nmass_by_position = []\n", "b.toml")?;
    /// let note = file.note("b.toml", &["beta_bar"]).unwrap();
    /// assert!(note.starts_with("b.toml does not set 45 keys; they take the article rig's values: "));
    /// assert!(note.contains("piston_diameter_mm = 63.0, ") && note.contains("c12_m5_per_ns = 1.2e-10"));
    /// assert!(!note.contains("beta_bar"));
    /// # Ok::<(), pumpcyl::rig::RigError>(())
    /// ```
    pub fn note(&self, file: &str, except: &[&str]) -> Option<String> {
        let keys: Vec<&str> = self
            .defaulted
            .iter()
            .copied()
            .filter(|k| !except.contains(k))
            .collect();
        let table = self.rig.table();
        let value = |k: &str| table.get(k).map_or_else(String::new, toml_text);
        let d = self.rig.circuit.description();
        let declared = |k: &&str| d.keys.iter().any(|key| key.name == *k);
        let assigned = |own: bool| -> Vec<String> {
            (keys.iter())
                .filter(|k| **k != "mass_by_position" && declared(k) == own)
                .map(|k| format!("{k} = {}", value(k)))
                .collect()
        };
        let (article, own) = (assigned(false), assigned(true));
        let mut parts = Vec::new();
        if keys.contains(&"mass_by_position") {
            parts.push(
                "mass_by_position = [] (one mass over the stroke, not the article's seesaw table)"
                    .to_string(),
            );
        }
        if !article.is_empty() {
            let they = if parts.is_empty() {
                "they"
            } else {
                "the others"
            };
            parts.push(format!(
                "{they} take the article rig's values: {}",
                article.join(", ")
            ));
        }
        if !own.is_empty() {
            parts.push(format!(
                "the {} circuit's own keys take its module's defaults: {}",
                d.name,
                own.join(", ")
            ));
        }
        let n = keys.len();
        let plural = if n == 1 { "" } else { "s" };
        (n > 0).then(|| {
            format!(
                "{file} does not set {n} key{plural}; {} (docs/formats.md#rig-toml)",
                parts.join("; ")
            )
        })
    }
}

impl Rig {
    /// What a rig file or `[rig]` table gets for a key it leaves out: the article's value
    /// ([`Rig::default`]), except `mass_by_position`, which is `[]`: one mass, `mass_kg`, over
    /// the whole stroke (the article's table is its seesaw's, docs/formats.md#rig-toml).
    pub fn file_default() -> Rig {
        Rig {
            mass_by_position: Vec::new(),
            ..Rig::default()
        }
    }

    /// Parse a rig from TOML text; `name` is used in messages (usually the file name). Absent
    /// keys take [`Rig::file_default`]; [`Rig::from_toml_str_with_defaults`] also lists them.
    pub fn from_toml_str(text: &str, name: &str) -> Result<Rig, RigError> {
        Ok(Self::from_toml_str_with_defaults(text, name)?.rig)
    }

    /// [`Rig::from_toml_str`], with the keys the text leaves out.
    pub fn from_toml_str_with_defaults(text: &str, name: &str) -> Result<RigFile, RigError> {
        let rig: Rig = toml::from_str(text).map_err(|e| RigError::Parse {
            file: name.to_string(),
            message: source_files::toml_error(&e, text),
        })?;
        let written = toml::from_str::<toml::Table>(text).unwrap_or_default();
        let set: Vec<&str> = written.keys().map(String::as_str).collect();
        rig.check_circuit_keys(name, &set)
            .and_then(|()| rig.validate(name))
            .map_err(|mut e| {
                let at = |key: &str| {
                    let alias = KEY_ALIASES.iter().find(|(_, own)| *own == key);
                    source_files::toml_line(text, &[source_files::Key::Name(key)]).or_else(|| {
                        source_files::toml_line(text, &[source_files::Key::Name(alias?.0)])
                    })
                };
                match &mut e {
                    RigError::Invalid { line, key, .. }
                    | RigError::NotInCircuit { line, key, .. } => *line = at(key),
                    RigError::BadKey { at: place, key, .. } => {
                        *place = at(key).map(|l| (l, key_column(text, l, key)));
                    }
                    _ => {}
                }
                e
            })?;
        let defaulted = defaulted_keys(&rig, |key| written.keys().any(|k| canonical_key(k) == key));
        Ok(RigFile {
            rig: rig.with_circuit_keys(),
            defaulted,
        })
    }

    /// Read and validate a rig file.
    pub fn from_file(path: &Path) -> Result<Rig, RigError> {
        Self::from_file_in(&source_files::Disk, path)
    }

    /// [`Rig::from_file`] from `files`.
    pub fn from_file_in(files: &dyn source_files::Files, path: &Path) -> Result<Rig, RigError> {
        Ok(Self::from_file_with_defaults_in(files, path)?.rig)
    }

    /// [`Rig::from_file_in`], with the keys the file leaves out.
    pub fn from_file_with_defaults_in(
        files: &dyn source_files::Files,
        path: &Path,
    ) -> Result<RigFile, RigError> {
        let name = path.display().to_string();
        let parse_err = |message| RigError::Parse {
            file: name.clone(),
            message,
        };
        let text = source_files::read_text(files, path).map_err(|e| parse_err(e.to_string()))?;
        if toml::from_str::<toml::Table>(&text).is_ok_and(|t| t.is_empty()) {
            return Err(RigError::Empty { file: name });
        }
        Self::from_toml_str_with_defaults(&text, &name)
    }

    /// Apply `KEY=VALUE` overrides (same keys and types as the TOML), then validate.
    /// A bare word value (`motor_model=first_order`) is taken as a string. Errors name the
    /// overrides as `override`; see [`Rig::with_overrides_from`].
    pub fn with_overrides(&self, assignments: &[String]) -> Result<Rig, RigError> {
        self.with_overrides_from("override", assignments)
    }

    /// [`Rig::with_overrides`], errors naming the overrides' source in the caller's words (the
    /// command line's `--set`, an experiment file's `[set]`).
    pub fn with_overrides_from(
        &self,
        source_name: &str,
        assignments: &[String],
    ) -> Result<Rig, RigError> {
        if assignments.is_empty() {
            return Ok(self.clone());
        }
        let mut table = toml::Table::try_from(self).expect("a rig always serialises");
        let mut set = Vec::new();
        let mut named: Vec<(String, &str)> = Vec::new();
        for assignment in assignments {
            let (key, value) = parse_assignment(source_name, assignment, &table)?;
            // one key under two names (an alias and its own name) is refused, as in a rig file
            let given = assignment.split_once('=').map_or("", |(k, _)| k.trim());
            if let Some((_, other)) = named.iter().find(|(k, n)| *k == key && *n != given) {
                return Err(RigError::Set {
                    source_name: source_name.to_string(),
                    assignment: source_files::shown_text(assignment, source_files::MAX_VALUE_CHARS)
                        .into_owned(),
                    message: format!("`{given}` and `{other}` name the same key: give one"),
                });
            }
            named.push((key.clone(), given));
            table.insert(key.clone(), value);
            set.push(key);
        }
        let rig: Rig = table
            .try_into()
            .map_err(|e: toml::de::Error| RigError::Set {
                source_name: source_name.to_string(),
                assignment: source_files::shown_text(
                    &assignments.join(" "),
                    source_files::MAX_VALUE_CHARS,
                )
                .into_owned(),
                // serde's "…\nin `key`" kept on one line
                message: (e.to_string().lines().map(str::trim))
                    .filter(|l| !l.is_empty())
                    .collect::<Vec<_>>()
                    .join("; "),
            })?;
        let set: Vec<&str> = set.iter().map(String::as_str).collect();
        rig.check_circuit_keys(source_name, &set)?;
        rig.validate(source_name)?;
        Ok(rig.with_circuit_keys())
    }

    /// The rig holding exactly those of its circuit's declared keys ([`Rig::circuit_keys`])
    /// that differ from their defaults: two rigs that give every key the same value are equal
    /// however they were written (a key written at its default is the key left out), and
    /// another circuit's keys, left from before a change of circuit, are gone (as a file may
    /// not write them).
    pub fn with_circuit_keys(mut self) -> Rig {
        let values: Vec<(String, toml::Value)> = (self.circuit.description().keys.iter())
            .filter(|k| self.circuit_key(k.name) != k.default)
            .map(|k| (k.name.to_string(), self.circuit_key(k.name).into()))
            .collect();
        self.circuit_keys = CircuitKeys(values.into_iter().collect());
        self
    }

    /// Whether the rig's circuit has `key` (every key but those of the other circuits,
    /// docs/circuits.md).
    pub fn has_key(&self, key: &str) -> bool {
        foreign_key(self.circuit, key).is_none()
    }

    /// Refuse a key of `set` (the keys a file or the overrides write) that the rig's circuit
    /// does not have: it would be silently ignored otherwise (docs/circuits.md).
    fn check_circuit_keys(&self, source_name: &str, set: &[&str]) -> Result<(), RigError> {
        match set.iter().find_map(|k| foreign_key(self.circuit, k)) {
            None => Ok(()),
            Some((key, owners)) => Err(RigError::NotInCircuit {
                source_name: source_name.to_string(),
                line: None,
                key,
                circuit: self.circuit,
                owners,
            }),
        }
    }

    /// Check every value against its physical range (the article §2.3.4; docs/formats.md#rig-toml); the error names the key.
    pub fn validate(&self, source_name: &str) -> Result<(), RigError> {
        let invalid = |key, value, rule| RigError::Invalid {
            source_name: source_name.to_string(),
            line: None,
            key,
            value,
            rule,
        };
        self.validate_circuit_keys(source_name)?;
        for (key, value, rule) in self.numeric_fields() {
            if !value.is_finite() {
                return Err(invalid(key, value, "must be a finite number".into()));
            }
            if let Some(rule) = rule.violated(value) {
                return Err(invalid(key, value, rule));
            }
        }
        if self.rod_diameter_mm >= self.piston_diameter_mm {
            return Err(invalid(
                "rod_diameter_mm",
                self.rod_diameter_mm,
                "must be smaller than piston_diameter_mm".into(),
            ));
        }
        if self.x0_mm <= 0.0 || self.x0_mm >= self.stroke_mm {
            return Err(invalid(
                "x0_mm",
                self.x0_mm,
                "must lie strictly inside the stroke (0, stroke_mm)".into(),
            ));
        }
        self.validate_mass_table()
            .map_err(|(value, rule)| invalid("mass_by_position", value, rule))?;
        self.validate_bulk_model()
            .map_err(|(key, value, rule)| invalid(key, value, rule))?;
        (self.circuit.validate_rest(self)).map_err(|(key, value, rule)| invalid(key, value, rule))
    }

    /// The dual-pump circuit's rest (docs/circuits.md#operating-point): its leakage must fix
    /// the chamber pressures, and they must lie above the vapour pressure
    /// (docs/model.md#cavitation).
    pub(crate) fn validate_dual_pump_rest(&self) -> Result<(), (&'static str, f64, String)> {
        let op = (self.dual_pump_balance().steady(0.0))
            .map_err(|e| ("c12_m5_per_ns", self.c12_m5_per_ns, e.to_string()))?;
        crate::cavitation::check_chambers(&[op.p1_pa / PA_PER_BAR, op.p2_pa / PA_PER_BAR]).map_err(
            |e| {
                (
                    "accumulator_precharge_bar",
                    self.accumulator_precharge_bar,
                    format!("the dual-pump circuit's rest needs {e}"),
                )
            },
        )
    }

    /// The operating point at rest must be a state the circuit can hold: the sum-pressure
    /// set-point split by the force balance (docs/model.md#newton) leaves no chamber below the
    /// vapour pressure (docs/model.md#cavitation).
    pub(crate) fn validate_rest(&self) -> Result<(), String> {
        let [p1, p2] = self.si().rest_pressures_pa();
        crate::cavitation::check_chambers(&[p1 / PA_PER_BAR, p2 / PA_PER_BAR]).map_err(|e| {
            format!(
                "with p_sum_ref_bar = {} the rest needs {e}",
                readable(self.p_sum_ref_bar)
            )
        })
    }

    /// What the dual-pump circuit's steady flow and force balance depends on
    /// (docs/circuits.md#operating-point).
    pub fn dual_pump_balance(&self) -> Balance {
        let si = self.si();
        Balance {
            areas_m2: [si.a1, si.a2],
            displacements_m3: si.d,
            leakage_m5_per_ns: [si.c1, si.c2, si.c12],
            viscous_ns_per_m: si.b,
            force_ext_n: si.f_ext,
            p_acc_pa: self.accumulator_precharge_bar * PA_PER_BAR,
        }
    }

    /// The `mass_by_position` rules: at most [`MAX_MASS_POINTS`] points, none or at least two,
    /// positions finite, inside the stroke and increasing, masses in the range of `mass_kg`.
    fn validate_mass_table(&self) -> Result<(), (f64, String)> {
        let t = &self.mass_by_position;
        if t.len() > MAX_MASS_POINTS {
            return Err((
                t.len() as f64,
                format!("more than {MAX_MASS_POINTS} points"),
            ));
        }
        if t.len() == 1 {
            return Err((1.0, "needs no point (constant mass) or at least two".into()));
        }
        for (k, p) in t.iter().enumerate() {
            if !(p.x_mm.is_finite() && p.x_mm > 0.0 && p.x_mm < self.stroke_mm) {
                return Err((
                    p.x_mm,
                    format!(
                        "point {}: x_mm must lie strictly inside the stroke (0, stroke_mm)",
                        k + 1
                    ),
                ));
            }
            if k > 0 && p.x_mm <= t[k - 1].x_mm {
                return Err((
                    p.x_mm,
                    format!("point {}: x_mm must increase from point to point", k + 1),
                ));
            }
            if let Some(rule) = Rig::check_key("mass_kg", p.mass_kg) {
                return Err((p.mass_kg, format!("point {}: mass_kg {rule}", k + 1)));
            }
        }
        Ok(())
    }

    /// Chamber 2 pressure (bar gauge) at rest with chamber 1 at `p1_bar`: Newton with no
    /// motion, p1 A1 − p2 A2 = F_ext (docs/model.md#newton).
    pub fn p2_at_rest_bar(&self, p1_bar: f64) -> f64 {
        let si = self.si();
        (p1_bar * PA_PER_BAR * si.a1 - si.f_ext) / si.a2 / PA_PER_BAR
    }

    /// The moving mass (kg) at position `x_mm` of a load whose mass at x0 is `load_mass_kg`:
    /// the load scaled by the `mass_by_position` table, interpolated linearly, at `x_mm` over
    /// its value at `x0_mm` (the load itself without a table; docs/formats.md#rig-toml).
    ///
    /// ```
    /// use pumpcyl::rig::Rig;
    ///
    /// let rig = Rig::default();
    /// // the article's 9958 kg at x0 − 50 mm and 12 373 kg at x0 + 50 mm (§3.3)
    /// assert_eq!(rig.mass_at(rig.mass_kg, 295.0)?, 9958.0);
    /// assert_eq!(rig.mass_at(rig.mass_kg, 395.0)?, 12373.0);
    /// # Ok::<(), pumpcyl::rig::RigError>(())
    /// ```
    ///
    /// # Errors
    /// `x_mm` or `x0_mm` outside the table's positions: pumpcyl does not extrapolate a mass.
    pub fn mass_at(&self, load_mass_kg: f64, x_mm: f64) -> Result<f64, RigError> {
        if self.mass_by_position.is_empty() {
            return Ok(load_mass_kg);
        }
        Ok(load_mass_kg * self.table_mass_at(x_mm)? / self.table_mass_at(self.x0_mm)?)
    }

    /// The `mass_by_position` table interpolated linearly at `x_mm` (kg).
    fn table_mass_at(&self, x_mm: f64) -> Result<f64, RigError> {
        let t = &self.mass_by_position;
        let (first, last) = (t[0], t[t.len() - 1]);
        let k = t.partition_point(|p| p.x_mm < x_mm);
        if !(first.x_mm..=last.x_mm).contains(&x_mm) {
            return Err(RigError::MassOutsideTable {
                x_mm,
                lo_mm: first.x_mm,
                hi_mm: last.x_mm,
            });
        }
        if k == 0 {
            return Ok(first.mass_kg);
        }
        let (a, b) = (t[k - 1], t[k]);
        Ok(a.mass_kg + (b.mass_kg - a.mass_kg) * (x_mm - a.x_mm) / (b.x_mm - a.x_mm))
    }

    /// Refuse a position reference from `lo_mm` to `hi_mm` that leaves the stroke (it must lie
    /// strictly inside 0 … `stroke_mm`): the one rule for every reference pumpcyl simulates,
    /// emulates or proposes as an experiment.
    pub fn check_reference(&self, lo_mm: f64, hi_mm: f64) -> Result<(), RigError> {
        if lo_mm > 0.0 && hi_mm < self.stroke_mm {
            return Ok(());
        }
        Err(RigError::OutsideStroke {
            lo_mm,
            hi_mm,
            stroke_mm: self.stroke_mm,
            x0_mm: self.x0_mm,
        })
    }

    /// What is wrong with `value` for the numeric rig key `key` (its physical range), if anything;
    /// `None` also for a key that is not numeric.
    pub fn check_key(key: &str, value: f64) -> Option<String> {
        let (_, rule) = (Rig::default().numeric_fields().into_iter())
            .map(|(k, _, rule)| (k, rule))
            .chain(OPTIONAL_KEYS)
            .chain(declared_keys().into_iter().map(|k| (k.name, k.range)))
            .find(|(k, _)| *k == key)?;
        if !value.is_finite() {
            return Some("must be a finite number".into());
        }
        rule.violated(value)
    }

    /// The value of the optional key `key` ([`OPTIONAL_KEYS`]) where the rig sets it.
    fn optional(&self, key: &str) -> Option<f64> {
        match key {
            "motor_time_constant_s" => self.motor_time_constant_s,
            "pump_slip_m5_per_ns" => self.pump_slip_m5_per_ns,
            "coulomb_friction_n" => self.coulomb_friction_n,
            "relief_setting_bar" => self.relief_setting_bar,
            "polytropic_index" => self.polytropic_index,
            "air_dissolution_pressure_bar" => self.air_dissolution_pressure_bar,
            _ => None,
        }
    }

    /// What the optional key `key` stands for where the rig leaves it out, in its unit: the
    /// value derived from the rig (0.05 s, an example, for `motor_time_constant_s`, whose
    /// absence is J_i/Km_i per motor).
    fn optional_default(&self, key: &str) -> f64 {
        match key {
            "pump_slip_m5_per_ns" => self.pump_slip(),
            "coulomb_friction_n" => self.coulomb_friction(),
            "relief_setting_bar" => self.relief_setting_pa(self.circuit) / PA_PER_BAR,
            "polytropic_index" => crate::bulk::models::DEFAULT_POLYTROPIC_INDEX,
            "air_dissolution_pressure_bar" => {
                crate::bulk::models::DEFAULT_AIR_DISSOLUTION_PRESSURE_BAR
            }
            _ => 0.05,
        }
    }

    /// The emulator's pump slip leakage at standstill (m⁵/(N·s), docs/emulator.md#the-dynamics):
    /// `pump_slip_m5_per_ns`, or where the rig leaves it out the article rig's 4e-11 in
    /// proportion to the rig's own cross-port leakage, 4e-11 × c12 / 1.2e-10 **\[choice\]**:
    /// the slip is leakage across the pump, of the pump's size as c12 is
    /// (docs/emulator.md#what-a-user-rig-gets).
    ///
    /// ```
    /// use pumpcyl::rig::Rig;
    ///
    /// assert_eq!(Rig::default().pump_slip(), 4e-11);
    /// let small = Rig::default().with_overrides(&["c12_m5_per_ns=2e-12".into()])?;
    /// assert!((small.pump_slip() - 4e-11 / 60.0).abs() < 1e-25);
    /// # Ok::<(), pumpcyl::rig::RigError>(())
    /// ```
    pub fn pump_slip(&self) -> f64 {
        self.pump_slip_m5_per_ns
            .unwrap_or(ARTICLE_PUMP_SLIP_M5_PER_NS * (self.c12_m5_per_ns / ARTICLE_C12_M5_PER_NS))
    }

    /// The emulator's Coulomb friction on the piston (N, docs/emulator.md#the-dynamics):
    /// `coulomb_friction_n`, or where the rig leaves it out the article rig's 15 N in
    /// proportion to the seals' diameters, 15 N × (d1 + d2) / (63 + 36 mm) **\[choice\]**: seal
    /// friction at a pressure grows with the seal's length of contact, the piston seal's
    /// π d1 and the rod seal's π d2 (docs/emulator.md#what-a-user-rig-gets).
    pub fn coulomb_friction(&self) -> f64 {
        self.coulomb_friction_n.unwrap_or(
            ARTICLE_COULOMB_FRICTION_N
                * ((self.piston_diameter_mm + self.rod_diameter_mm) / ARTICLE_SEAL_DIAMETERS_MM),
        )
    }

    /// The relief valves' setting of the one-motor circuit `kind` (Pa above the accumulator
    /// line, docs/circuits.md#valves): `relief_setting_bar`, or where the rig leaves it out
    /// the pressure at which the pumps' load torque reaches the motor's rated torque with the
    /// other chamber at the accumulator **\[choice\]**, τ_rated / (D1 + D2) for the dual-pump
    /// circuit and τ_rated / D1 for the single-pump circuit (and for the DPM, which has none:
    /// its pump 1 alone).
    pub fn relief_setting_pa(&self, kind: CircuitKind) -> f64 {
        let derived = self.motor_rated_torque_nm / kind.relief_displacement_m3_per_rad(self);
        self.relief_setting_bar
            .map_or(derived, |bar| bar * PA_PER_BAR)
    }

    /// Every key with its documentation ("unit, meaning"), in the order of the commented TOML.
    pub fn key_docs() -> impl Iterator<Item = (&'static str, &'static str)> {
        (KEY_DOCS.iter().flat_map(|(_, keys)| keys.iter().copied()))
            .chain(declared_keys().into_iter().map(|k| (k.name, k.doc)))
    }

    /// The value of the key `name` that a circuit's module declares ([`crate::circuit::Key`]):
    /// as the rig writes it, else the declared default.
    ///
    /// # Panics
    /// Where no circuit declares `name`: a module asks only for the keys it declares.
    pub fn circuit_key(&self, name: &str) -> f64 {
        match self.circuit_keys.0.get(name) {
            Some(value) => number(value).unwrap_or(f64::NAN),
            None => {
                declared_key(name)
                    .expect("a module asks for its own keys")
                    .0
                    .default
            }
        }
    }

    /// The rig as a TOML table: every key it serialises, and each key its circuit's module
    /// declares with its value (as written or its default).
    pub fn table(&self) -> toml::Table {
        let mut table = toml::Table::try_from(self).expect("a rig always serialises");
        for key in self.circuit.description().keys {
            table.insert(
                key.name.into(),
                toml::Value::Float(self.circuit_key(key.name)),
            );
        }
        table
    }

    /// Refuse a written key that no circuit declares, and a declared key's value that is not a
    /// number (its range is checked with every other key's).
    fn validate_circuit_keys(&self, source_name: &str) -> Result<(), RigError> {
        let bad = |key: &str, message| RigError::BadKey {
            source_name: source_name.to_string(),
            at: None,
            key: key.to_string(),
            message,
        };
        for (key, value) in &self.circuit_keys.0 {
            if declared_key(key).is_none() {
                let known: Vec<&str> = Rig::key_docs().map(|(k, _)| k).collect();
                return Err(bad(key, source_files::unknown_key_among(key, &known)));
            }
            if number(value).is_none() {
                let shown = source_files::shown_key(key);
                let message = format!("key `{shown}` takes a float, got {}", value.type_str());
                return Err(bad(key, message));
            }
        }
        Ok(())
    }

    /// Every numeric key with its value and allowed range.
    fn numeric_fields(&self) -> Vec<(&'static str, f64, Range)> {
        use Range::*;
        let mut fields = vec![
            (
                "piston_diameter_mm",
                self.piston_diameter_mm,
                Positive(1.0, 5000.0),
            ),
            (
                "rod_diameter_mm",
                self.rod_diameter_mm,
                Positive(0.5, 5000.0),
            ),
            (
                "line_volume_1_dm3",
                self.line_volume_1_dm3,
                Positive(1e-6, 1e5),
            ),
            (
                "line_volume_2_dm3",
                self.line_volume_2_dm3,
                Positive(1e-6, 1e5),
            ),
            ("stroke_mm", self.stroke_mm, Positive(1.0, 1e5)),
            ("x0_mm", self.x0_mm, Positive(0.001, 1e5)),
            (
                "motor_inertia_1_kg_mm2",
                self.motor_inertia_1_kg_mm2,
                Positive(0.001, 1e10),
            ),
            (
                "motor_inertia_2_kg_mm2",
                self.motor_inertia_2_kg_mm2,
                Positive(0.001, 1e10),
            ),
            (
                "pump_inertia_1_kg_mm2",
                self.pump_inertia_1_kg_mm2,
                NonNegative(1e10),
            ),
            (
                "pump_inertia_2_kg_mm2",
                self.pump_inertia_2_kg_mm2,
                NonNegative(1e10),
            ),
            (
                "displacement_1_cm3_per_rev",
                self.displacement_1_cm3_per_rev,
                Positive(0.001, 1e5),
            ),
            (
                "displacement_2_cm3_per_rev",
                self.displacement_2_cm3_per_rev,
                Positive(0.001, 1e5),
            ),
            (
                "current_loop_bandwidth_rad_per_s",
                self.current_loop_bandwidth_rad_per_s,
                Positive(0.01, 1e6),
            ),
            ("km1_nms_per_rad", self.km1_nms_per_rad, Positive(1e-6, 1e4)),
            ("km2_nms_per_rad", self.km2_nms_per_rad, Positive(1e-6, 1e4)),
            ("kff_kg_m2", self.kff_kg_m2, NonNegative(1000.0)),
            ("tau_ff_s", self.tau_ff_s, Positive(1e-6, 1000.0)),
            (
                "k_scale_rad_per_s",
                self.k_scale_rad_per_s,
                Positive(0.001, 1e6),
            ),
            ("mass_kg", self.mass_kg, Positive(0.001, 1e8)),
            ("external_force_n", self.external_force_n, Any(1e9)),
            ("beta_bar", self.beta_bar, Positive(0.01, 1e5)),
            (
                "viscous_friction_ns_per_m",
                self.viscous_friction_ns_per_m,
                NonNegative(1e9),
            ),
            ("c12_m5_per_ns", self.c12_m5_per_ns, NonNegative(1e-6)),
            (
                "accumulator_precharge_bar",
                self.accumulator_precharge_bar,
                Positive(0.001, 1e4),
            ),
            ("c1_m5_per_ns", self.c1_m5_per_ns, Any(1e-6)),
            ("c2_m5_per_ns", self.c2_m5_per_ns, Any(1e-6)),
            ("kp", self.kp, Positive(1e-6, 1e6)),
            ("p_sum_ref_bar", self.p_sum_ref_bar, Positive(0.001, 1e4)),
            ("k_pres_per_bar", self.k_pres_per_bar, NonNegative(1e6)),
            ("k_beta", self.k_beta, NonNegative(1000.0)),
            ("plc_rate_hz", self.plc_rate_hz, Positive(0.1, 1e6)),
            (
                "plc_delay_samples",
                self.plc_delay_samples,
                Whole(crate::lti::MAX_DELAY_SAMPLES as f64),
            ),
            (
                "motor_rated_torque_nm",
                self.motor_rated_torque_nm,
                Positive(0.001, 1e6),
            ),
            (
                "motor_rated_speed_rpm",
                self.motor_rated_speed_rpm,
                Positive(0.01, 1e6),
            ),
            (
                "pump_max_speed_rpm",
                self.pump_max_speed_rpm,
                Positive(0.01, 1e6),
            ),
            (
                "pump_dead_band_rpm",
                self.pump_dead_band_rpm,
                NonNegative(1e4),
            ),
            (
                "cylinder_rated_pressure_bar",
                self.cylinder_rated_pressure_bar,
                Positive(0.001, 1e5),
            ),
        ];
        for (key, range) in OPTIONAL_KEYS {
            fields.extend(self.optional(key).map(|v| (key, v, range)));
        }
        for key in self.circuit.description().keys {
            fields.push((key.name, self.circuit_key(key.name), key.range));
        }
        fields
    }

    /// The rig's model of β_e against pressure (`bulk_modulus_model` with its parameters, the
    /// family's defaults where absent; docs/bulk-modulus.md#a-family-of-models).
    pub fn bulk_model(&self) -> crate::bulk::models::BulkModel {
        crate::bulk::models::BulkModel::unchecked(
            self.bulk_modulus_model,
            self.polytropic_index,
            self.air_dissolution_pressure_bar,
        )
    }

    /// The rig under the model `m` of β_e against pressure: its `bulk_modulus_model` and the
    /// parameters that model has, as a rig file names them (the inverse of [`Rig::bulk_model`]).
    pub fn with_bulk_model(&self, m: crate::bulk::models::BulkModel) -> Rig {
        use crate::bulk::models::BulkModel as M;
        let (n, p_crit) = match m {
            M::ConstantGasFraction | M::ConstantGasFractionAbsolute => (None, None),
            M::EntrainedAir { polytropic_index } => (Some(polytropic_index), None),
            M::EntrainedAirDissolving {
                polytropic_index,
                air_dissolution_pressure_bar,
            } => (Some(polytropic_index), Some(air_dissolution_pressure_bar)),
        };
        Rig {
            bulk_modulus_model: m.form(),
            polytropic_index: n,
            air_dissolution_pressure_bar: p_crit,
            ..self.clone()
        }
    }

    /// Refuse a bulk-modulus parameter the rig's `bulk_modulus_model` does not have: it would
    /// be silently ignored otherwise.
    fn validate_bulk_model(&self) -> Result<(), (&'static str, f64, String)> {
        let (n, pc) = (self.polytropic_index, self.air_dissolution_pressure_bar);
        let Some(key) = self.bulk_modulus_model.unused(n, pc) else {
            return Ok(());
        };
        let value = if key == "polytropic_index" { n } else { pc };
        let rule = self.bulk_modulus_model.unused_rule(key);
        Err((key, value.unwrap_or(f64::NAN), rule))
    }

    /// The PLC's sample period (s) and computation delay (samples) as the sampled-data margins
    /// read the loop (docs/analysis.md#sampled-data-margins).
    pub fn plc_sampling(&self) -> (f64, usize) {
        (1.0 / self.plc_rate_hz, self.plc_delay_samples as usize)
    }

    /// Convert to SI and compute the derived quantities (the article §2.3.1; docs/model.md#geometry).
    pub fn si(&self) -> RigSi {
        let mm = 1e-3;
        let d1 = self.piston_diameter_mm * mm;
        let d2 = self.rod_diameter_mm * mm;
        let a1 = PI * d1 * d1 / 4.0;
        let a2 = PI * (d1 * d1 - d2 * d2) / 4.0;
        let x0 = self.x0_mm * mm;
        let x_max = self.stroke_mm * mm;
        let v1 = self.line_volume_1_dm3 * 1e-3 + a1 * x0;
        let v2 = self.line_volume_2_dm3 * 1e-3 + a2 * (x_max - x0);
        let kg_mm2 = 1e-6;
        let jm = [
            self.motor_inertia_1_kg_mm2 * kg_mm2,
            self.motor_inertia_2_kg_mm2 * kg_mm2,
        ];
        let j = [
            jm[0] + self.pump_inertia_1_kg_mm2 * kg_mm2,
            jm[1] + self.pump_inertia_2_kg_mm2 * kg_mm2,
        ];
        let m3_per_rad = 1e-6 / (2.0 * PI);
        let d = [
            self.displacement_1_cm3_per_rev * m3_per_rad,
            self.displacement_2_cm3_per_rev * m3_per_rad,
        ];
        let km = [self.km1_nms_per_rad, self.km2_nms_per_rad];
        let tau_motor = match self.motor_time_constant_s {
            Some(tau) => [tau, tau],
            None => [j[0] / km[0], j[1] / km[1]],
        };
        RigSi {
            a1,
            a2,
            v1,
            v2,
            j,
            jm,
            d,
            omega_i: self.current_loop_bandwidth_rad_per_s,
            km,
            kff: if self.feedforward {
                self.kff_kg_m2
            } else {
                0.0
            },
            tau_ff: self.tau_ff_s,
            k_scale: self.k_scale_rad_per_s,
            tau_motor,
            mass: self.mass_kg,
            beta: self.beta_bar * PA_PER_BAR,
            b: self.viscous_friction_ns_per_m,
            c1: self.c1_m5_per_ns,
            c2: self.c2_m5_per_ns,
            c12: self.c12_m5_per_ns,
            kp: self.kp,
            k_pres: self.k_pres_per_bar / PA_PER_BAR,
            k_beta: self.k_beta,
            alpha: (d[0] / d[1]) * (a1 / a2 - 1.0),
            x0,
            p_sum_ref: self.p_sum_ref_bar * PA_PER_BAR,
            f_ext: self.external_force_n,
        }
    }

    /// The rig as plain TOML, the keys of its circuit only: what [`Rig::from_toml_str`] reads
    /// back to the same rig.
    pub fn to_toml(&self) -> String {
        let mut table = self.table();
        table.retain(|key, _| self.has_key(key));
        toml::to_string(&table).expect("a table always serialises")
    }

    /// The rig as TOML with a comment per key giving unit and meaning, ready to edit.
    pub fn to_commented_toml(&self) -> String {
        let table = self.table();
        let mut out = String::from(
            "# pumpcyl rig description (the article §2.3.4; docs/formats.md#rig-toml). Units are part of every key.\n\
             # Absent keys take the article's value, except mass_by_position: [], one mass over the\n\
             # stroke; the command names them. Unknown keys are errors.\n",
        );
        for (section, keys) in key_sections() {
            out.push_str(&format!("\n# --- {section} ---\n"));
            for (key, doc) in keys {
                // an optional key left out: shown, commented out, with what it stands for; a key
                // another circuit declares, with its default
                let (value, set) = match (table.get(key), declared_key(key)) {
                    (Some(value), _) => (toml_text(value), true),
                    (None, Some((declared, _))) => (toml_text(&declared.default.into()), false),
                    (None, None) => (
                        toml_text(&toml::Value::Float(self.optional_default(key))),
                        false,
                    ),
                };
                match (set, foreign_key(self.circuit, key)) {
                    (true, None) => out.push_str(&format!("{key} = {value}  # {doc}\n")),
                    (false, None) => out.push_str(&format!("# {key} = {value}  # {doc}\n")),
                    // a key of another circuit may not be set: shown, commented out
                    (_, Some((_, owners))) => out.push_str(&format!(
                        "# {key} = {value}  # {doc} ({} only)\n",
                        circuits_text(&owners)
                    )),
                }
            }
        }
        out
    }
}

/// The commented TOML's sections and their keys with their documentation: the rig's own
/// ([`KEY_DOCS`]), then one for the keys circuits' modules declare, each key once, in a
/// section named after the circuits that declare it.
fn key_sections() -> Vec<(String, Vec<(&'static str, &'static str)>)> {
    let own = KEY_DOCS
        .iter()
        .map(|(section, keys)| (section.to_string(), keys.to_vec()));
    let mut declared: Vec<(String, Vec<(&'static str, &'static str)>)> = Vec::new();
    for key in declared_keys() {
        let owners = declared_key(key.name).map(|(_, o)| o).unwrap_or_default();
        let section = circuits_text(&owners);
        match declared.iter_mut().find(|(s, _)| *s == section) {
            Some((_, keys)) => keys.push((key.name, key.doc)),
            None => declared.push((section, vec![(key.name, key.doc)])),
        }
    }
    own.chain(declared).collect()
}

/// A TOML value as a rig file writes it: a float of magnitude below 1e-3 or from 1e7 in
/// exponent form (`1.2e-10`, not `0.00000000012`), every float shortest so that it reads back
/// equal; arrays and inline tables element by element.
fn toml_text(value: &toml::Value) -> String {
    let join = |items: Vec<String>| items.join(", ");
    match value {
        toml::Value::Float(x) if *x != 0.0 && !(1e-3..1e7).contains(&x.abs()) => format!("{x:e}"),
        toml::Value::Array(a) => format!("[{}]", join(a.iter().map(toml_text).collect())),
        toml::Value::Table(t) => format!(
            "{{ {} }}",
            join(
                t.iter()
                    .map(|(k, v)| format!("{k} = {}", toml_text(v)))
                    .collect()
            )
        ),
        other => other.to_string(),
    }
}

/// Allowed range of a numeric key.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Range {
    /// Strictly positive, at least `.0` and at most `.1` in the key's unit.
    Positive(f64, f64),
    /// Zero or positive, at most `.0`.
    NonNegative(f64),
    /// Either sign, magnitude at most `.0`.
    Any(f64),
    /// A whole number from 0 to `.0` (a count).
    Whole(f64),
}

impl Range {
    /// What is wrong with `value`, if anything. Magnitudes far outside any pump-controlled
    /// cylinder (the limits span several decades around the article's rig, Table 1) are refused
    /// so the numerics downstream never meet them.
    pub fn violated(self, value: f64) -> Option<String> {
        let outside = |lo: f64, hi: f64| {
            format!("outside the physical range {lo:e} to {hi:e} that pumpcyl accepts")
        };
        match self {
            Range::Positive(..) if value <= 0.0 => Some("must be > 0".into()),
            Range::Positive(lo, hi) if value < lo || value > hi => Some(outside(lo, hi)),
            Range::NonNegative(_) if value < 0.0 => Some("must be >= 0".into()),
            Range::NonNegative(hi) if value > hi => Some(outside(0.0, hi)),
            Range::Any(hi) if value.abs() > hi => Some(outside(-hi, hi)),
            Range::Whole(hi) if value.fract() != 0.0 || !(0.0..=hi).contains(&value) => {
                Some(format!("must be a whole number from 0 to {hi}"))
            }
            _ => None,
        }
    }
}

/// Split `KEY=VALUE`, check the key exists and the value's type matches the default's.
fn parse_assignment(
    source_name: &str,
    assignment: &str,
    table: &toml::Table,
) -> Result<(String, toml::Value), RigError> {
    let err = |message: String| RigError::Set {
        source_name: source_name.to_string(),
        assignment: source_files::shown_text(assignment, source_files::MAX_VALUE_CHARS)
            .into_owned(),
        message,
    };
    let (key, raw) = assignment
        .split_once('=')
        .ok_or_else(|| err("expected KEY=VALUE".into()))?;
    let key = canonical_key(key.trim());
    let raw = raw.trim();
    let value = source_files::parse_value(raw);
    // an optional key is absent from the table when unset: its type is float
    let float = toml::Value::Float(0.0);
    let current = match table.get(key) {
        Some(current) => current,
        None if is_optional_key(key) || declared_key(key).is_some() => &float,
        None => {
            let known: Vec<&str> = Rig::key_docs().map(|(k, _)| k).collect();
            return Err(err(source_files::unknown_key_among(key, &known)));
        }
    };
    let value = source_files::typed_like(current, value).map_err(|got| {
        err(format!(
            "key `{key}` takes a {}, got {got} `{}`",
            current.type_str(),
            source_files::shown_text(raw, source_files::MAX_VALUE_CHARS)
        ))
    })?;
    Ok((key.to_string(), value))
}

/// Sections and per-key documentation used for the commented TOML. Every serialised key must be
/// listed (a test checks it).
const KEY_DOCS: &[(&str, &[(&str, &str)])] = &[
    (
        "circuit",
        &[(
            "circuit",
            "\"dpm\" (the article's dual-prime-mover circuit), \"dual-pump\" (one motor, two pumps: the article's Figure 1b) or \"single-pump\" (one motor, one pump, pilot-operated check valves: Figure 1a); docs/circuits.md",
        )],
    ),
    (
        "geometry",
        &[
            ("piston_diameter_mm", "mm, piston diameter d1"),
            ("rod_diameter_mm", "mm, rod diameter d2"),
            (
                "line_volume_1_dm3",
                "dm³, line volume pump to chamber 1 (piston side), VL1",
            ),
            (
                "line_volume_2_dm3",
                "dm³, line volume pump to chamber 2 (rod side), VL2",
            ),
            ("stroke_mm", "mm, cylinder stroke x_max"),
            (
                "x0_mm",
                "mm, operating-point position used for the chamber volumes",
            ),
        ],
    ),
    (
        "motors, pumps and drives",
        &[
            (
                "motor_inertia_1_kg_mm2",
                "kg·mm², motor 1 rotor inertia Jm1",
            ),
            (
                "motor_inertia_2_kg_mm2",
                "kg·mm², motor 2 rotor inertia Jm2",
            ),
            (
                "pump_inertia_1_kg_mm2",
                "kg·mm², pump 1 (axial piston) inertia Jp1",
            ),
            (
                "pump_inertia_2_kg_mm2",
                "kg·mm², pump 2 (internal gear) inertia Jp2",
            ),
            (
                "displacement_1_cm3_per_rev",
                "cm³/rev, pump 1 displacement D1 (chamber 2 -> chamber 1)",
            ),
            (
                "displacement_2_cm3_per_rev",
                "cm³/rev, pump 2 displacement D2 (reservoir -> chamber 1)",
            ),
            (
                "current_loop_bandwidth_rad_per_s",
                "rad/s, current-loop bandwidth (first order)",
            ),
            ("km1_nms_per_rad", "N·m·s/rad, drive 1 velocity-loop P gain"),
            ("km2_nms_per_rad", "N·m·s/rad, drive 2 velocity-loop P gain"),
            (
                "kff_kg_m2",
                "kg·m², drive velocity feedforward gain (torque per rad/s²)",
            ),
            ("tau_ff_s", "s, feedforward filter time constant"),
            (
                "k_scale_rad_per_s",
                "rad/s per unit normalised command (1 = 3000 rpm)",
            ),
            (
                "motor_time_constant_s",
                "s, first-order motor model only; absent = J_i/Km_i",
            ),
            ("motor_rated_torque_nm", "N m, motor rated torque"),
            ("motor_rated_speed_rpm", "rpm, motor rated speed"),
            ("pump_max_speed_rpm", "rpm, pump speed limit"),
        ],
    ),
    (
        "load and hydraulics",
        &[
            ("mass_kg", "kg, effective moving mass at x0 (I/r² for the seesaw)"),
            (
                "mass_by_position",
                "mass at each stroke position where the geometry ties them: [{ x_mm, mass_kg }, ...], [] for constant",
            ),
            ("external_force_n", "N, external force (0 at horizontal)"),
            ("beta_bar", "bar, effective bulk modulus (at the anchor where it varies with pressure)"),
            (
                "bulk_modulus_model",
                "\"constant-gas-fraction\" (the article's), \"constant-gas-fraction-absolute\", \"entrained-air\" or \"entrained-air-dissolving\": beta against pressure (docs/bulk-modulus.md)",
            ),
            (
                "polytropic_index",
                "-, the entrained-air models' polytropic index n, 1 (isothermal) to 1.4 (adiabatic); absent = 1",
            ),
            (
                "air_dissolution_pressure_bar",
                "bar, the dissolving model's pressure above which no free air is left; absent = 30",
            ),
            ("viscous_friction_ns_per_m", "N·s/m, viscous friction"),
            ("c12_m5_per_ns", "m⁵/(N·s), cross-port leakage"),
            (
                "accumulator_precharge_bar",
                "bar, accumulator pre-charge p_acc (also accumulator_pressure_bar): the dual- and single-pump circuits' pressure level",
            ),
            (
                "c1_m5_per_ns",
                "m⁵/(N·s), chamber 1 leakage (may be negative: pump null shift)",
            ),
            (
                "c2_m5_per_ns",
                "m⁵/(N·s), chamber 2 leakage (may be negative: pump null shift)",
            ),
        ],
    ),
    (
        "emulator effects (docs/emulator.md)",
        &[
            (
                "pump_dead_band_rpm",
                "rpm, pump speed below which its flow fades out and its slip sets in (the article rig's 60)",
            ),
            (
                "pump_slip_m5_per_ns",
                "m⁵/(N·s), pump slip leakage at standstill; absent = 4e-11 × c12 / 1.2e-10 (the article rig's 4e-11)",
            ),
            (
                "coulomb_friction_n",
                "N, Coulomb friction on the piston; absent = 15 N × (d1 + d2) / 99 mm (the article rig's 15 N)",
            ),
            (
                "relief_setting_bar",
                "bar, relief valves' setting above the accumulator line; absent = rated torque / D (docs/circuits.md#valves)",
            ),
            (
                "cylinder_rated_pressure_bar",
                "bar, cylinder rating: a relief setting above it is warned about (ISO 6022's 250 bar)",
            ),
        ],
    ),
    (
        "controller",
        &[
            (
                "kp",
                "1/m, position P gain: normalised command per metre of error",
            ),
            ("p_sum_ref_bar", "bar, sum-pressure set-point p1 + p2"),
            (
                "k_pres_per_bar",
                "1/bar, sum-pressure gain: normalised command per bar (the article's 22 % per bar)",
            ),
            ("k_beta", "-, sum-pressure split factor"),
            (
                "plc_rate_hz",
                "Hz, the PLC's sample rate, as the sampled-data margins read the loop (the article's 100 Hz)",
            ),
            (
                "plc_delay_samples",
                "-, the PLC's computation delay in whole samples, from reading the position to applying the command (sampled-data margins)",
            ),
        ],
    ),
    (
        "model variants",
        &[
            ("feedforward", "bool, drive velocity feedforward on"),
            (
                "motor_coupling",
                "bool, pressure load torques act on the motors",
            ),
            (
                "sum_pressure",
                "bool, sum-pressure loop closed in simulations (frequency analysis opens it)",
            ),
            ("motor_model", "\"full\" or \"first_order\""),
        ],
    ),
];

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The article's masses at the stroke points (§3.3), linear between them, the same shape
    /// for any load, refused outside the table, constant without one.
    #[test]
    fn a_huge_override_gets_a_short_message() {
        // a 100 000-character key or value: the message is one readable line that names it
        for assignment in [
            format!("{}=1", "k".repeat(100_000)),
            format!("kp={}", "1".repeat(100_000)),
            format!("kp=1 {}", "x".repeat(100_000)),
        ] {
            let e = Rig::default()
                .with_overrides(&[assignment])
                .unwrap_err()
                .to_string();
            assert!(e.len() < 2000, "{} bytes: {}", e.len(), &e[..200]);
            assert!(e.contains(" bytes)"), "{e}");
        }
        let e = Rig::default()
            .with_overrides(&["motor_model=foo".into()])
            .unwrap_err()
            .to_string();
        assert!(
            !e.contains('\n') && e.ends_with("; in `motor_model`"),
            "{e}"
        );
        let e = Rig::default()
            .with_overrides(&["kpp=3".into()])
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "override kpp=3: unknown key `kpp`; did you mean `kp`?"
        );
    }

    #[test]
    fn the_mass_follows_the_stroke_where_the_geometry_ties_them() {
        let rig = Rig::default();
        let m = |r: &Rig, x: f64| r.mass_at(r.mass_kg, x).unwrap();
        assert_relative_eq!(m(&rig, 295.0), 9958.0, max_relative = 1e-12);
        assert_relative_eq!(m(&rig, 345.0), 10593.0, max_relative = 1e-12);
        assert_relative_eq!(m(&rig, 395.0), 12373.0, max_relative = 1e-12);
        assert_relative_eq!(
            m(&rig, 370.0),
            0.5 * (10593.0 + 12373.0),
            max_relative = 1e-12
        );
        let light = Rig {
            mass_kg: 4898.0,
            ..rig.clone()
        };
        assert_relative_eq!(
            m(&light, 395.0),
            4898.0 * 12373.0 / 10593.0,
            max_relative = 1e-12
        );
        let err = rig.mass_at(1.0, 400.0).unwrap_err().to_string();
        assert!(
            err.contains("mass_by_position") && err.contains("from 295 to 395 mm"),
            "{err}"
        );
        let flat = rig.with_overrides(&["mass_by_position=[]".into()]).unwrap();
        assert_eq!(flat.mass_at(7.0, 10.0).unwrap(), 7.0);
    }

    #[test]
    fn a_bad_mass_table_is_refused_with_its_key_and_line() {
        let refuse = |table: &str| {
            Rig::from_toml_str(
                &format!("kp = 25.0\nmass_by_position = {table}\n"),
                "r.toml",
            )
            .unwrap_err()
            .to_string()
        };
        let one = refuse("[{ x_mm = 300.0, mass_kg = 1e4 }]");
        assert!(
            one.starts_with("r.toml: line 2, key `mass_by_position`"),
            "{one}"
        );
        assert!(one.contains("at least two"), "{one}");
        let back = refuse("[{ x_mm = 300.0, mass_kg = 1e4 }, { x_mm = 290.0, mass_kg = 1e4 }]");
        assert!(back.contains("point 2: x_mm must increase"), "{back}");
        let outside = refuse("[{ x_mm = 300.0, mass_kg = 1e4 }, { x_mm = 600.0, mass_kg = 1e4 }]");
        assert!(outside.contains("inside the stroke"), "{outside}");
        let negative =
            refuse("[{ x_mm = 300.0, mass_kg = 1e4 }, { x_mm = 400.0, mass_kg = -1.0 }]");
        assert!(
            negative.contains("point 2: mass_kg must be > 0"),
            "{negative}"
        );
        let unknown = refuse("[{ x_mm = 300.0, mass = 1e4 }, { x_mm = 400.0, mass_kg = 1.0 }]");
        assert!(unknown.contains("mass"), "{unknown}");
        let many: Vec<String> = (0..=MAX_MASS_POINTS)
            .map(|k| format!("{{ x_mm = {}, mass_kg = 1e4 }}", 1.0 + 0.4 * k as f64))
            .collect();
        let many = refuse(&format!("[{}]", many.join(", ")));
        assert!(many.contains("more than 1000 points"), "{many}");
    }

    #[test]
    fn commented_toml_round_trips_and_documents_every_key() {
        let rig = Rig::default();
        let text = rig.to_commented_toml();
        assert_eq!(Rig::from_toml_str(&text, "t").unwrap(), rig);
        let table = toml::Table::try_from(&rig).unwrap();
        let documented: Vec<&str> = KEY_DOCS
            .iter()
            .flat_map(|(_, k)| k.iter().map(|(n, _)| *n))
            .collect();
        for key in table.keys() {
            assert!(documented.contains(&key.as_str()), "undocumented key {key}");
        }
        for line in text
            .lines()
            .filter(|l| !l.starts_with('#') && !l.is_empty())
        {
            assert!(line.contains("  # "), "line without comment: {line}");
        }
    }

    #[test]
    fn derived_quantities_match_spec() {
        let si = Rig::default().si();
        assert_relative_eq!(si.a1, 3.117245e-3, max_relative = 1e-6);
        assert_relative_eq!(si.a2, 2.0993693e-3, max_relative = 1e-6);
        assert_relative_eq!(si.v1, 0.1272e-3 + si.a1 * 0.345, max_relative = 1e-12);
        assert_relative_eq!(si.v2, 0.1272e-3 + si.a2 * 0.155, max_relative = 1e-12);
        assert_relative_eq!(si.j[0], 2.2e-3, max_relative = 1e-12);
        assert_relative_eq!(si.j[1], 1.634e-3, max_relative = 1e-12);
        assert_relative_eq!(si.d[0] * 2.0 * PI, 6e-6, max_relative = 1e-12);
        // α = (D1/D2)(A1/A2 − 1) = (6/3.6)(d1²/(d1² − d2²) − 1)
        let r = 63.0f64.powi(2) / (63.0f64.powi(2) - 36.0f64.powi(2));
        assert_relative_eq!(si.alpha, 6.0 / 3.6 * (r - 1.0), max_relative = 1e-12);
        assert_relative_eq!(si.beta, 1.65e7);
    }

    #[test]
    fn overrides_apply_and_name_bad_keys() {
        let rig = Rig::default();
        let set = |s: &str| rig.with_overrides(&[s.to_string()]);
        assert_eq!(set("beta_bar=37.8").unwrap().beta_bar, 37.8);
        assert_eq!(set("mass_kg=4898").unwrap().mass_kg, 4898.0);
        assert!(!set("feedforward=false").unwrap().feedforward);
        assert_eq!(
            set("motor_model=first_order").unwrap().motor_model,
            MotorModel::FirstOrder
        );
        assert_eq!(
            set("motor_time_constant_s=0.05")
                .unwrap()
                .motor_time_constant_s,
            Some(0.05)
        );
        let e = set("bogus=1").unwrap_err().to_string();
        assert!(e.contains("unknown key `bogus`"), "{e}");
        let e = set("beta_bar=abc").unwrap_err().to_string();
        assert!(e.contains("beta_bar") && e.contains("float"), "{e}");
        let e = set("mass_kg=-1").unwrap_err().to_string();
        assert!(e.contains("mass_kg") && e.contains("> 0"), "{e}");
        let e = set("motor_model=second").unwrap_err().to_string();
        assert!(e.contains("motor_model") || e.contains("variant"), "{e}");
        assert!(set("beta_bar").is_err());
    }

    /// An alias and its own name set together are refused, as a rig file refuses the pair;
    /// the same name twice is a later value.
    #[test]
    fn one_key_under_two_names_is_refused() {
        let one_motor = |sets: &[&str]| {
            let mut all = vec!["circuit=single-pump".to_string()];
            all.extend(sets.iter().map(|s| s.to_string()));
            Rig::default().with_overrides_from("--set", &all)
        };
        let e = one_motor(&["accumulator_pressure_bar=3", "accumulator_precharge_bar=4"])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "`accumulator_precharge_bar` and `accumulator_pressure_bar` name the same key"
            ),
            "{e}"
        );
        let r = one_motor(&["accumulator_pressure_bar=3", "accumulator_pressure_bar=4"]).unwrap();
        assert_eq!(r.accumulator_precharge_bar, 4.0);
        let text = "circuit = \"single-pump\"\naccumulator_pressure_bar = 3.0\naccumulator_precharge_bar = 4.0\n";
        assert!(Rig::from_toml_str(text, "pair.toml").is_err());
    }

    #[test]
    fn file_errors_name_line_and_key() {
        let e = Rig::from_toml_str("beta_bar = 165\nmass_kgg = 3\n", "r.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("r.toml") && e.contains("mass_kgg") && e.contains("line 2"),
            "{e}"
        );
        let e = Rig::from_toml_str("beta_bar = \"x\"\n", "r.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1") && e.contains("beta_bar"), "{e}");
        let e = Rig::from_toml_str("beta_bar = 0\n", "r.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("beta_bar") && e.contains("> 0"), "{e}");
        let e = Rig::from_toml_str("x0_mm = 600\n", "r.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("x0_mm"), "{e}");
        let e = Rig::from_toml_str("line_volume_1_dm3 = -0.1\n", "r.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line_volume_1_dm3"), "{e}");
    }

    /// The keys a circuit's module declares (the single-pump circuit's valve keys) are parsed,
    /// checked and written like the rig's own fields.
    #[test]
    fn the_drives_keys_belong_to_the_circuits_with_drives() {
        // a valve rig file that writes a drive's key is refused with its line, and the keys it
        // leaves out name none of the article's motors and pumps
        let valve = "circuit = \"valve\"\n";
        let e = Rig::from_toml_str(&format!("{valve}km1_nms_per_rad = 0.03\n"), "v.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("v.toml: line 2"), "{e}");
        assert!(e.contains("km1_nms_per_rad"), "{e}");
        let file = Rig::from_toml_str_with_defaults(valve, "v.toml").unwrap();
        for key in crate::circuit::DRIVE_KEYS {
            assert!(
                !file.defaulted.contains(key),
                "{key} in {:?}",
                file.defaulted
            );
        }
        assert!(file.defaulted.contains(&"viscous_friction_ns_per_m"));
        // every circuit with drives has them: a DPM or single-pump file writes them
        for circuit in ["dpm", "dual-pump", "single-pump"] {
            let text = format!("circuit = \"{circuit}\"\nkm1_nms_per_rad = 0.03\n");
            let rig = Rig::from_toml_str(&text, "d.toml").unwrap();
            assert_eq!(rig.km1_nms_per_rad, 0.03);
        }
    }

    #[test]
    fn declared_keys_read_check_and_write_like_fields() {
        let single = "circuit = \"single-pump\"\n";
        let read = |extra: &str| Rig::from_toml_str(&format!("{single}{extra}"), "s.toml");
        let e = read("pilot_ratio = \"x\"\n").unwrap_err().to_string();
        assert_eq!(
            e,
            "s.toml: line 2, column 1: key `pilot_ratio` takes a float, got string"
        );
        let e = read("beta_bar = 100\npilot_ratoi = 3\n")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "s.toml: line 3, column 1: unknown key `pilot_ratoi`; did you mean `pilot_ratio`?"
        );
        let e = read("pilot_ratio = 1e9\n").unwrap_err().to_string();
        assert!(
            e.starts_with("s.toml: line 2, key `pilot_ratio` = 1e9: outside"),
            "{e}"
        );
        // written as its default or left out: the same rig; an integer is a float
        let given = read("pilot_ratio = 3\n").unwrap();
        assert_eq!(given, read("").unwrap());
        assert_eq!(given.circuit_key("pilot_ratio"), 3.0);
        assert_eq!(
            read("pilot_ratio = 4\n")
                .unwrap()
                .circuit_key("pilot_ratio"),
            4.0
        );
        // another circuit's declared key: refused in a file, dropped by a change of circuit
        let e = Rig::from_toml_str("pilot_ratio = 4.0\n", "d.toml").unwrap_err();
        assert!(
            matches!(e, RigError::NotInCircuit { line: Some(1), .. }),
            "{e}"
        );
        let back = (given.with_overrides(&["circuit=dpm".into()])).unwrap();
        assert_eq!(back, Rig::file_default());
        assert!(!back.to_toml().contains("pilot_ratio"));
        assert!(given.to_toml().contains("pilot_ratio = 3.0"));
    }

    #[test]
    fn partial_file_takes_defaults() {
        let rig = Rig::from_toml_str("beta_bar = 220\nmass_kg = 4898\n", "p").unwrap();
        assert_eq!(rig.beta_bar, 220.0);
        assert_eq!(rig.kp, 25.0);
    }
}
