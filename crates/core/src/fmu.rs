//! The rig as a co-simulation slave, for an FMU (FMI 2.0 Co-Simulation; docs/fmu.md): the
//! nonlinear emulator (docs/emulator.md) with the article's PLC around it or with the motor
//! speed commands as inputs, or the linear model of the article §2.3 (docs/model.md) with its
//! position loop closed or open. Inputs are held over each communication step.
//!
//! This module is the FMU's behaviour in plain Rust: the variables ([`variables`]), their
//! values and the stepping ([`Instance`]). The C functions of the FMI standard are a thin shell
//! over it (crates/fmu), and the files of the FMU (modelDescription.xml, the archive) are
//! written by the presentation layer from the same [`variables`].
//!
//! Every call is bounded and checked before it works: a step of at most [`MAX_STEP_S`] from
//! the instance's own time (whole PLC periods counted from the start), a start time within
//! ±[`MAX_START_S`], and each call only in the [`Phase`] that allows it (docs/fmu.md#limits).
//!
//! ```
//! use pumpcyl::fmu::{Config, Controller, Instance, ModelKind};
//! use pumpcyl::rig::Rig;
//!
//! // the linear closed loop of the article's rig, a 5 mm step of the reference
//! let config = Config::new(ModelKind::Linear, Controller::Article, false, Rig::default());
//! let mut fmu = Instance::new(config)?;
//! fmu.initialize(0.0)?;
//! let x_ref = fmu.value_reference("x_ref_m").unwrap();
//! let x = fmu.value_reference("x_m").unwrap();
//! let x0 = fmu.get_real(x)?;
//! fmu.set_real(x_ref, x0 + 5e-3)?;
//! let mut peak = x0;
//! for k in 0..200 {
//!     fmu.do_step(k as f64 * 0.01, 0.01)?;
//!     peak = peak.max(fmu.get_real(x)?);
//! }
//! // the article's rig overshoots a 5 mm step by half (docs/simulation.md#step-metrics)
//! assert!((peak - x0 - 7.5e-3).abs() < 0.1e-3);
//! # Ok::<(), pumpcyl::fmu::FmuError>(())
//! ```

use crate::circuit::energy::Energy;
use crate::circuit::{Circuit, Effects, Role, Signal};
use crate::emulator::{self, article, Dynamics, Plc, PlcLoop, PLC_RATE_HZ, SETTLE_S};
use crate::lti::Zoh;
use crate::model::Plant;
use crate::rig::{MotorModel, Rig};
use crate::units::{PA_PER_BAR, RAD_S_PER_RPM};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Why the FMU cannot do what it was asked, in one line naming the variable or parameter.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct FmuError(pub String);

impl From<emulator::EmulatorError> for FmuError {
    fn from(e: emulator::EmulatorError) -> Self {
        FmuError(format!("emulator: {e}"))
    }
}

impl From<crate::lti::LtiError> for FmuError {
    fn from(e: crate::lti::LtiError) -> Self {
        FmuError(format!("linear model: {e}"))
    }
}

/// Which model the FMU carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelKind {
    /// The nonlinear rig emulator (docs/emulator.md).
    Emulator,
    /// The 10-state linear model (docs/model.md).
    Linear,
}

/// What drives the motors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Controller {
    /// The article's DPM control law (position P gain and sum-pressure loop,
    /// docs/model.md#the-dpm-control-law): the input is the position reference. In the emulator
    /// it runs at the PLC's sample rate, as in `pumpcyl emulate`.
    Article,
    /// None: the motor speed commands are the inputs (the plant alone, the linear model's open
    /// loop), for a controller of the user's own.
    External,
}

/// What an FMU is: the model, its controller, whether the emulator's effects are on, the rig
/// (the parameters' start values) and the GUID its modelDescription.xml carries. Written into
/// the FMU's resources as TOML and read back by the FMU when it is instantiated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// The model.
    pub model: ModelKind,
    /// The controller.
    pub controller: Controller,
    /// Emulator only: every effect of docs/emulator.md on (as `pumpcyl emulate`), or none.
    pub effects: bool,
    /// Emulator only: the power account integrated with the states, its energies as outputs
    /// (docs/fmu.md#energy).
    #[serde(default)]
    pub energy: bool,
    /// The fingerprint of the variables (modelDescription.xml's `guid`).
    pub guid: String,
    /// The rig.
    pub rig: Rig,
}

/// File name of the configuration in the FMU's `resources/` folder.
pub const CONFIG_FILE: &str = "pumpcyl-fmu.toml";

/// The FMU's model identifier: the shared library is `binaries/linux64/pumpcyl.so`.
pub const MODEL_IDENTIFIER: &str = "pumpcyl";

impl Config {
    /// A configuration with its GUID computed from the variables.
    pub fn new(model: ModelKind, controller: Controller, effects: bool, rig: Rig) -> Config {
        let mut c = Config {
            model,
            controller,
            effects,
            energy: false,
            guid: String::new(),
            rig,
        };
        c.guid = c.fingerprint();
        c
    }

    /// This configuration with the energy outputs (docs/fmu.md#energy) where `on`, for the
    /// emulator only: the linear model has no power account.
    pub fn with_energy(mut self, on: bool) -> Config {
        self.energy = on && self.model == ModelKind::Emulator;
        self.guid = self.fingerprint();
        self
    }

    /// The configuration as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a configuration always serialises")
    }

    /// Read a configuration written by [`Config::to_toml`].
    pub fn from_toml(text: &str) -> Result<Config, FmuError> {
        let c: Config =
            toml::from_str(text).map_err(|e| FmuError(format!("{CONFIG_FILE}: {e}")))?;
        Rig::from_toml_str(&c.rig.to_toml(), CONFIG_FILE).map_err(|e| FmuError(e.to_string()))?;
        Ok(c)
    }

    /// A fingerprint of the model, the controller and every variable (name, reference, start
    /// value): FNV-1a, written as a GUID-shaped hex string.
    fn fingerprint(&self) -> String {
        let mut text = format!("{:?} {:?} {}", self.model, self.controller, self.effects);
        for v in variables(self) {
            text.push_str(&format!("|{} {} {:?}", v.name, v.value_reference, v.start));
        }
        let mut h: u128 = 0x6c62_272e_07bb_0142_62b8_2175_6295_c58d;
        for b in text.bytes() {
            h ^= u128::from(b);
            h = h.wrapping_mul(0x0000_0000_0100_0000_0000_0000_0000_013B);
        }
        let x = format!("{h:032x}");
        format!(
            "{{{}-{}-{}-{}-{}}}",
            &x[0..8],
            &x[8..12],
            &x[12..16],
            &x[16..20],
            &x[20..32]
        )
    }
}

/// The rig an FMU of `model` carries when none is given: the emulator's own (the article's
/// rig with the set-point of its emulated records, as `pumpcyl emulate`) when its effects are
/// on, the article's rig otherwise (as `pumpcyl step`).
pub fn default_rig(model: ModelKind, effects: bool) -> Result<Rig, FmuError> {
    Ok(match model {
        ModelKind::Emulator if effects => article::default_rig()?,
        _ => Rig::default(),
    })
}

/// A configuration that starts: [`Config::new`], then an instance initialised once, so an
/// FMU that could not start is refused when it is written, not in the user's simulator.
pub fn checked_config(
    (model, controller): (ModelKind, Controller),
    effects: bool,
    energy: bool,
    rig: Rig,
) -> Result<Config, FmuError> {
    let config = Config::new(
        model,
        controller,
        effects && model == ModelKind::Emulator,
        rig,
    )
    .with_energy(energy);
    Instance::new(config.clone())?
        .initialize(0.0)
        .map_err(|e| FmuError(format!("the FMU would not start: {e}")))?;
    Ok(config)
}

/// A variable's role (FMI's causality).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Set before initialisation, fixed after.
    Parameter,
    /// Set by the master before each step.
    Input,
    /// Computed by the FMU.
    Output,
}

/// A variable's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// A real number in the variable's unit.
    Real(f64),
    /// A Boolean.
    Boolean(bool),
}

/// One variable of the FMU.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Name (a rig key for a parameter; the unit is part of every name).
    pub name: String,
    /// FMI value reference.
    pub value_reference: u32,
    /// Role.
    pub causality: Causality,
    /// Unit (the FMI unit name; `None` for Booleans and dimensionless values).
    pub unit: Option<&'static str>,
    /// What it is.
    pub description: String,
    /// Start value (parameters and inputs; outputs at the start of the run are computed).
    pub start: Option<Value>,
}

/// How many commands the rig's circuit takes: the DPM's two drives, the single-motor
/// circuits' one, the valve-controlled cylinder's spool (docs/fmu.md#every-circuit).
fn command_count(rig: &Rig) -> usize {
    rig.circuit.description().commands()
}

/// An FMU variable: name, FMI unit (empty: none) and what it is.
type Named = (String, &'static str, String);

/// The FMU variable of a state or command by its role, the `i`-th (from 1) of that role, as
/// an output (`output`: a command the article's controller sends) or an external controller's
/// input: the names the FMU gives the drives and the spool (docs/fmu.md#variables); `None` for
/// a role the FMU does not show this way.
fn by_role(role: Role, i: usize, output: bool) -> Option<Named> {
    let spool = "(normalised: ±1 fully open)";
    Some(match role {
        Role::MotorSpeed => (
            format!("omega{i}_rad_per_s"),
            "rad/s",
            format!("speed of motor {i}"),
        ),
        Role::Torque => (
            format!("tau{i}_nm"),
            "N.m",
            format!("electromagnetic torque of motor {i}"),
        ),
        Role::SpoolOpening => (
            "spool_opening".into(),
            "1",
            format!("spool opening {spool}"),
        ),
        Role::SpeedCommand => (
            format!("omega_ref{i}_rad_per_s"),
            "rad/s",
            if output {
                format!("the controller's speed command to motor {i}")
            } else {
                format!("speed command of motor {i}")
            },
        ),
        Role::SpoolCommand => (
            "spool_opening_ref".into(),
            "1",
            format!(
                "{}spool opening command {spool}",
                if output { "the controller's " } else { "" }
            ),
        ),
        _ => return None,
    })
}

/// The FMU variables of `signals` whose roles it shows, role by role in the order of `roles`,
/// numbered within each role.
fn by_roles(signals: &[Signal], roles: &[Role], output: bool) -> Vec<Named> {
    (roles.iter())
        .flat_map(|role| {
            let of_role = signals.iter().filter(move |s| s.role == *role);
            of_role
                .enumerate()
                .filter_map(move |(k, s)| by_role(s.role, k + 1, output))
        })
        .collect()
}

/// The roles of the commands the FMU shows, in order.
const COMMANDS: [Role; 2] = [Role::SpeedCommand, Role::SpoolCommand];

/// The roles of the states the FMU outputs after the position, velocity and pressures, in
/// order ([`Fmu::outputs`] follows them).
const STATE_OUTPUTS: [Role; 3] = [Role::MotorSpeed, Role::Torque, Role::SpoolOpening];

/// The inputs: the position reference or the circuit's commands (a speed per drive, a spool
/// opening), then the external force added to the parameter `external_force_n`
/// (docs/fmu.md#variables).
fn input_names(c: &Config) -> Vec<Named> {
    let mut out = match c.controller {
        Controller::Article => vec![(
            "x_ref_m".into(),
            "m",
            "position reference (absolute, as the rig's x0)".into(),
        )],
        Controller::External => commands(c, false),
    };
    out.push((
        "f_ext_n".into(),
        "N",
        "external force on the piston added to the parameter external_force_n (positive \
         against the extension); 0 at the start"
            .into(),
    ));
    out
}

/// The circuit's commands as FMU variables, as outputs (the article's controller's) or inputs.
fn commands(c: &Config, output: bool) -> Vec<Named> {
    by_roles(&Plant::new(&c.rig).circuit().inputs(), &COMMANDS, output)
}

/// The outputs: the position, velocity and pressures, each drive's speed and torque or the
/// spool's opening, the article's controller's commands; the single-pump emulator's mode.
fn output_names(c: &Config) -> Vec<Named> {
    let plain = |n: &str, unit: &'static str, doc: &str| (n.to_string(), unit, doc.to_string());
    let mut out = vec![
        plain("x_m", "m", "piston position (absolute)"),
        plain("v_m_per_s", "m/s", "piston velocity"),
        plain("p1_pa", "Pa", "chamber 1 (piston side) pressure, gauge"),
        plain("p2_pa", "Pa", "chamber 2 (rod side) pressure, gauge"),
        plain("p_sum_pa", "Pa", "sum pressure p1 + p2"),
    ];
    out.extend(by_roles(
        &Plant::new(&c.rig).signals(),
        &STATE_OUTPUTS,
        true,
    ));
    if c.controller == Controller::Article {
        out.extend(commands(c, true));
    }
    if has_mode(c) {
        out.push(plain(
            "mode",
            "",
            "the single-pump circuit's mode: 1 with chamber 2 on the accumulator, 2 with \
             chamber 1 (docs/emulator.md#the-mode-signal)",
        ));
    }
    if c.energy {
        out.extend(ENERGY_OUTPUTS.map(|(n, doc)| plain(n, "J", doc)));
    }
    out
}

/// The energy outputs (docs/fmu.md#energy): the power account integrated from the start.
const ENERGY_OUTPUTS: [(&str, &str); 4] = [
    (
        "energy_in_j",
        "what the sources delivered since the start, net (the drives' supply, a valve's supply)",
    ),
    (
        "work_out_j",
        "the work against the external force since the start",
    ),
    (
        "losses_j",
        "every loss since the start (docs/energy.md#the-account)",
    ),
    (
        "stored_change_j",
        "the change of every stored energy since the start",
    ),
];

/// The FMU has the mode output: the emulator of a single-pump rig.
fn has_mode(c: &Config) -> bool {
    c.model == ModelKind::Emulator && c.rig.circuit.has_modes()
}

/// Value references start here for the outputs and the parameters.
const OUTPUT_VR: u32 = 100;
const PARAMETER_VR: u32 = 1000;

/// Every variable of an FMU of `c`: the inputs (value references from 0), the outputs (from
/// 100) and every scalar rig key as a parameter (from 1000) with its unit and description.
pub fn variables(c: &Config) -> Vec<Variable> {
    let start_inputs = input_start(c);
    let mut out: Vec<Variable> = input_names(c)
        .into_iter()
        .zip(start_inputs)
        .enumerate()
        .map(|(k, ((name, unit, doc), start))| Variable {
            name,
            value_reference: k as u32,
            causality: Causality::Input,
            unit: Some(unit),
            description: doc,
            start: Some(Value::Real(start)),
        })
        .collect();
    out.extend(
        output_names(c)
            .into_iter()
            .enumerate()
            .map(|(k, (name, unit, doc))| Variable {
                name,
                value_reference: OUTPUT_VR + k as u32,
                causality: Causality::Output,
                // the mode is a number without a unit
                unit: (!unit.is_empty()).then_some(unit),
                description: doc,
                start: None,
            }),
    );
    out.extend(
        parameters(&c.rig)
            .into_iter()
            .enumerate()
            .map(|(k, mut v)| {
                v.value_reference = PARAMETER_VR + k as u32;
                v
            }),
    );
    out
}

/// Every scalar rig key (numbers and switches) as a parameter; the tables and the motor model
/// are fixed when the FMU is written.
fn parameters(rig: &Rig) -> Vec<Variable> {
    let table = rig.table();
    Rig::key_docs()
        .filter(|(key, _)| rig.has_key(key))
        .filter_map(|(key, doc)| {
            let start = match table.get(key)? {
                toml::Value::Float(v) => Value::Real(*v),
                toml::Value::Integer(v) => Value::Real(*v as f64),
                toml::Value::Boolean(b) => Value::Boolean(*b),
                _ => return None,
            };
            let unit = match start {
                Value::Real(_) => Some(unit_of(doc)),
                Value::Boolean(_) => None,
            };
            Some(Variable {
                name: key.into(),
                value_reference: 0,
                causality: Causality::Parameter,
                unit,
                description: doc.into(),
                start: Some(start),
            })
        })
        .collect()
}

/// The FMI unit of a rig key from its documentation ("mm, piston diameter d1" → "mm").
fn unit_of(doc: &str) -> &'static str {
    let head = doc.split(',').next().unwrap_or("").trim();
    UNITS.iter().find(|u| u.doc == head).map_or("1", |u| u.name)
}

/// A unit as the rig's keys write it, its FMI name, its SI base-unit exponents
/// (kg, m, s, rad, A) and the factor to SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    /// As the rig's key documentation writes it.
    pub doc: &'static str,
    /// The FMI unit name.
    pub name: &'static str,
    /// Exponents of kg, m, s, rad, A.
    pub base: [i32; 5],
    /// SI value of one unit.
    pub factor: f64,
}

/// Every unit the FMU's variables use.
pub const UNITS: &[Unit] = &[
    Unit {
        doc: "Hz",
        name: "Hz",
        base: [0, 0, -1, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "J",
        name: "J",
        base: [1, 2, -2, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "ohm",
        name: "Ohm",
        base: [1, 2, -3, 0, -2],
        factor: 1.0,
    },
    Unit {
        doc: "N m/A",
        name: "N.m/A",
        base: [1, 2, -2, 0, -1],
        factor: 1.0,
    },
    Unit {
        doc: "-",
        name: "1",
        base: [0, 0, 0, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "m",
        name: "m",
        base: [0, 1, 0, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "m/s",
        name: "m/s",
        base: [0, 1, -1, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "Pa",
        name: "Pa",
        base: [1, -1, -2, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "rad/s",
        name: "rad/s",
        base: [0, 0, -1, 1, 0],
        factor: 1.0,
    },
    Unit {
        doc: "N",
        name: "N",
        base: [1, 1, -2, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "N m",
        name: "N.m",
        base: [1, 2, -2, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "mm",
        name: "mm",
        base: [0, 1, 0, 0, 0],
        factor: 1e-3,
    },
    Unit {
        doc: "dm³",
        name: "dm3",
        base: [0, 3, 0, 0, 0],
        factor: 1e-3,
    },
    Unit {
        doc: "kg·mm²",
        name: "kg.mm2",
        base: [1, 2, 0, 0, 0],
        factor: 1e-6,
    },
    Unit {
        doc: "cm³/rev",
        name: "cm3/rev",
        base: [0, 3, 0, -1, 0],
        factor: 1e-6 / (2.0 * std::f64::consts::PI),
    },
    Unit {
        doc: "N·m·s/rad",
        name: "N.m.s/rad",
        base: [1, 2, -1, -1, 0],
        factor: 1.0,
    },
    Unit {
        doc: "kg·m²",
        name: "kg.m2",
        base: [1, 2, 0, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "s",
        name: "s",
        base: [0, 0, 1, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "rpm",
        name: "rpm",
        base: [0, 0, -1, 1, 0],
        factor: RAD_S_PER_RPM,
    },
    Unit {
        doc: "kg",
        name: "kg",
        base: [1, 0, 0, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "bar",
        name: "bar",
        base: [1, -1, -2, 0, 0],
        factor: PA_PER_BAR,
    },
    Unit {
        doc: "N·s/m",
        name: "N.s/m",
        base: [1, 0, -1, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "m⁵/(N·s)",
        name: "m5/(N.s)",
        base: [-1, 4, 1, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "1/m",
        name: "1/m",
        base: [0, -1, 0, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "1/bar",
        name: "1/bar",
        base: [-1, 1, 2, 0, 0],
        factor: 1.0 / PA_PER_BAR,
    },
    Unit {
        doc: "rad/s per unit normalised command (1 = 3000 rpm)",
        name: "rad/s",
        base: [0, 0, -1, 1, 0],
        factor: 1.0,
    },
];

/// The start values of the inputs: the rig at rest at its operating point. The force input
/// starts at 0: it is added to the parameter `external_force_n`, the one source of the force
/// a master that does not drive the input sets (docs/fmu.md#variables).
fn input_start(c: &Config) -> Vec<f64> {
    match c.controller {
        // the linear loop rests at x0 under the reference that holds it there
        // (docs/simulation.md#the-rest-under-load)
        Controller::Article if c.model == ModelKind::Linear => {
            vec![c.rig.x0_mm * 1e-3 + linear_rest_offset_m(&c.rig), 0.0]
        }
        Controller::Article => vec![c.rig.x0_mm * 1e-3, 0.0],
        Controller::External => {
            let (_, u) = rest(c.model, &c.rig);
            let mut start = u[..command_count(&c.rig)].to_vec();
            start.push(0.0);
            start
        }
    }
}

/// The rest offset of the rig's linear loop under the article's controller (m; 0 where the
/// loop has no rest, which [`Linear::new`] refuses as unstable).
fn linear_rest_offset_m(rig: &Rig) -> f64 {
    Plant::new(rig)
        .rest(rig.sum_pressure)
        .map_or(0.0, |r| r.offset_m)
}

/// The state at rest and the speed commands (rad/s) that hold it (docs/model.md), 0 for a
/// drive the circuit does not have: the emulated motors always carry the pumps' load, the
/// linear ones as the rig's `motor_coupling` says. A single-motor circuit's linear state is
/// that of its linear model (for the single-pump circuit, the mode at rest's).
fn rest(model: ModelKind, rig: &Rig) -> (Vec<f64>, [f64; 2]) {
    let loaded = model == ModelKind::Emulator || rig.motor_coupling;
    let plant = Plant::new(rig);
    if let Some(dpm) = plant.rest_state(loaded) {
        return dpm;
    }
    let op = match model {
        ModelKind::Emulator => crate::circuit::Emulated::of_rig(rig, Effects::none())
            .map(|c| c.operating_point())
            .unwrap_or_else(|_| plant.operating_point()),
        ModelKind::Linear => plant.operating_point(),
    };
    (op.state, [op.inputs[0], 0.0])
}

/// The longest communication step one `do_step` accepts (s): 100 s, 10⁴ PLC periods of the
/// emulator, so no call works for more than seconds (docs/fmu.md#limits).
pub const MAX_STEP_S: f64 = 100.0;

/// The largest start time accepted (s, either sign): 10⁹ s, where a double still resolves
/// 10⁻⁷ s, a hundred-thousandth of the PLC period (docs/fmu.md#limits).
pub const MAX_START_S: f64 = 1e9;

/// Where an instance is in the life of an FMI 2.0 Co-Simulation slave (the FMI 2.0.4
/// standard, section 4.2.4): each call is allowed in some phases only, refused in the others.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Made (or reset): parameters and the start time may be set.
    Instantiated,
    /// Between entering and leaving initialisation mode: parameters and inputs may be set.
    Initialising,
    /// Initialised: steps may be done, inputs set, outputs read.
    Stepping,
    /// Terminated: outputs may be read; only a reset starts it again.
    Terminated,
    /// A step failed part-way: outputs may be read; only a reset starts it again.
    Failed,
}

/// A running FMU: its configuration, the parameters as set, the inputs, and after
/// initialisation the simulation.
pub struct Instance {
    config: Config,
    variables: Vec<Variable>,
    parameters: toml::Table,
    inputs: Vec<f64>,
    sim: Option<Sim>,
    phase: Phase,
    start_s: f64,
    clock: Clock,
    /// What the run has to report once (an end stop met), until [`Instance::take_note`].
    note: Option<String>,
    /// An end stop already reported.
    end_stop_noted: bool,
    /// The parameter `external_force_n` (N) the run was initialised with, to which the input
    /// `f_ext_n` is added.
    force_parameter_n: f64,
}

/// The instance's own time since the start: whole PLC periods counted as an integer and the
/// time into the current one, so a run started at 10⁶ s steps exactly as one started at 0
/// (docs/fmu.md#limits).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Clock {
    period_s: f64,
    periods: u64,
    into_period_s: f64,
}

impl Clock {
    fn new() -> Clock {
        Clock {
            period_s: 1.0 / PLC_RATE_HZ,
            periods: 0,
            into_period_s: 0.0,
        }
    }

    /// Time since the start (s).
    fn elapsed_s(&self) -> f64 {
        self.periods as f64 * self.period_s + self.into_period_s
    }

    /// Advance by `h_s`, calling `piece(period, from, to)` for each part within one period
    /// (`from`, `to` in seconds into that period; `from` = 0 is a PLC sample instant). The end
    /// is found first, as whole periods and a remainder, so no rounding accumulates over the
    /// pieces; an end within 10⁻⁹ of a period of a boundary is the boundary.
    fn advance(
        &mut self,
        h_s: f64,
        mut piece: impl FnMut(u64, f64, f64) -> Result<(), FmuError>,
    ) -> Result<(), FmuError> {
        let (ts, tol) = (self.period_s, 1e-9 * self.period_s);
        let total = self.into_period_s + h_s;
        let mut whole = (total / ts).floor();
        let mut rest = total - whole * ts;
        if rest > ts - tol {
            whole += 1.0;
            rest = 0.0;
        } else if rest < tol {
            rest = 0.0;
        }
        let end = self.periods + whole as u64;
        while self.periods < end || self.into_period_s < rest {
            let to = if self.periods < end { ts } else { rest };
            piece(self.periods, self.into_period_s, to)?;
            if to == ts {
                self.periods += 1;
                self.into_period_s = 0.0;
            } else {
                self.into_period_s = to;
            }
        }
        Ok(())
    }
}

/// The simulation behind an initialised instance.
enum Sim {
    /// The emulator with the article's PLC.
    Plc { run: Box<PlcLoop>, u: [f64; 2] },
    /// The emulator driven by the speed commands.
    Plant {
        dynamics: Box<Dynamics>,
        x: Vec<f64>,
        /// The first end stop the piston met, at the end of a PLC period.
        end_stop: Option<emulator::EndStopHit>,
        /// The energies since the start, where the FMU accounts them.
        energy: Option<Energy>,
    },
    /// The linear model.
    Linear(Box<Linear>),
}

/// The linear model in deviations from the operating point, its inputs [x_ref or ω_ref1,
/// ω_ref2, F_ext] held over each step.
struct Linear {
    /// The circuit's states (for a single-pump mode, the full circuit's).
    signals: Vec<Signal>,
    /// The single-pump circuit's mode at rest, whose model this is.
    mode: Option<crate::circuit::single_pump::modes::Mode>,
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    /// The state deviation.
    z: DVector<f64>,
    /// The state (absolute) the deviations are taken from, and its inputs: the operating
    /// point under outside commands, the loop's rest under the article's controller.
    z_op: Vec<f64>,
    u_op: Vec<f64>,
    /// The controller ω_ref = Kx z + Kr r (deviations), article controller only.
    control: Option<(DMatrix<f64>, DMatrix<f64>)>,
    /// The speed commands (rad/s) at `z_op`.
    rest_commands: [f64; 2],
    zoh: Option<Zoh>,
}

impl Instance {
    /// An instance of `config`, its parameters at their start values.
    pub fn new(config: Config) -> Result<Instance, FmuError> {
        if config.model == ModelKind::Emulator && config.rig.motor_model != MotorModel::Full {
            return Err(FmuError("the emulator needs motor_model = \"full\"".into()));
        }
        let variables = variables(&config);
        let mut parameters =
            toml::Table::try_from(&config.rig).map_err(|e| FmuError(e.to_string()))?;
        parameters.retain(|key, _| config.rig.has_key(key));
        let inputs = input_start(&config);
        Ok(Instance {
            config,
            variables,
            parameters,
            inputs,
            sim: None,
            phase: Phase::Instantiated,
            start_s: 0.0,
            clock: Clock::new(),
            note: None,
            end_stop_noted: false,
            force_parameter_n: 0.0,
        })
    }

    /// Where the instance is in its life.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Refuse `what` unless the instance is in one of `allowed`.
    fn require(&self, what: &str, allowed: &[Phase]) -> Result<(), FmuError> {
        if allowed.contains(&self.phase) {
            return Ok(());
        }
        let why = match self.phase {
            Phase::Instantiated => "the instance is not initialised",
            Phase::Initialising => "the instance is in initialisation mode",
            Phase::Stepping => "the instance is already initialised",
            Phase::Terminated => "the instance is terminated (reset it to run again)",
            Phase::Failed => "a step failed part-way (reset the instance to run again)",
        };
        Err(FmuError(format!("{what}: {why}")))
    }

    /// Set the start time (s; fmi2SetupExperiment), before initialisation. A start time that
    /// is not finite or beyond ±[`MAX_START_S`] is refused.
    pub fn setup_experiment(&mut self, start_s: f64) -> Result<(), FmuError> {
        self.require("setting up the experiment", &[Phase::Instantiated])?;
        self.set_start(start_s)
    }

    /// Take `start_s` as the start time, refused beyond ±[`MAX_START_S`].
    fn set_start(&mut self, start_s: f64) -> Result<(), FmuError> {
        if !(start_s.is_finite() && start_s.abs() <= MAX_START_S) {
            return Err(FmuError(format!(
                "start time {start_s} s: must be a finite number within ±{MAX_START_S:e} s \
                 (docs/fmu.md#limits)"
            )));
        }
        self.start_s = start_s;
        Ok(())
    }

    /// Enter initialisation mode (fmi2EnterInitializationMode).
    pub fn enter_initialization(&mut self) -> Result<(), FmuError> {
        self.require("entering initialisation mode", &[Phase::Instantiated])?;
        self.phase = Phase::Initialising;
        Ok(())
    }

    /// Leave initialisation mode (fmi2ExitInitializationMode): check the parameters and start
    /// the simulation at the start time, the emulator at rest at the reference's start value
    /// (then run for the PLC's settling time, as `pumpcyl emulate` does), the linear model at
    /// its operating point.
    pub fn exit_initialization(&mut self) -> Result<(), FmuError> {
        self.require("leaving initialisation mode", &[Phase::Initialising])?;
        let rig = self.rig()?;
        // one force: the parameter, plus the input as the master has set it (0 unless it has)
        let added = *self.inputs.last().expect("f_ext_n is always an input");
        self.force_parameter_n = rig.external_force_n;
        let rig = Rig {
            external_force_n: rig.external_force_n + added,
            ..rig
        };
        self.sim = Some(match self.config.model {
            ModelKind::Emulator => self.emulator(&rig)?,
            ModelKind::Linear => Sim::Linear(Box::new(Linear::new(&rig, self.config.controller)?)),
        });
        self.clock = Clock::new();
        self.phase = Phase::Stepping;
        Ok(())
    }

    /// End the run (fmi2Terminate): outputs stay readable, steps are refused.
    pub fn terminate(&mut self) -> Result<(), FmuError> {
        self.require("terminating", &[Phase::Stepping, Phase::Failed])?;
        self.phase = Phase::Terminated;
        Ok(())
    }

    /// Back to the instance as made (fmi2Reset): parameters and inputs at their start values.
    pub fn reset(&mut self) -> Result<(), FmuError> {
        *self = Instance::new(self.config.clone())?;
        Ok(())
    }

    /// The instance's own time (s): the start time and the steps done since.
    pub fn time_s(&self) -> f64 {
        self.start_s + self.clock.elapsed_s()
    }

    /// A note the run has for the host, once (the first end stop the emulated piston met,
    /// docs/emulator.md#end-stops).
    pub fn take_note(&mut self) -> Option<String> {
        self.note.take()
    }

    /// The configuration it was made from.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The variables.
    pub fn variables(&self) -> &[Variable] {
        &self.variables
    }

    /// The value reference of the variable `name`.
    pub fn value_reference(&self, name: &str) -> Option<u32> {
        self.variables
            .iter()
            .find(|v| v.name == name)
            .map(|v| v.value_reference)
    }

    fn variable(&self, vr: u32) -> Result<&Variable, FmuError> {
        self.variables
            .iter()
            .find(|v| v.value_reference == vr)
            .ok_or_else(|| FmuError(format!("no variable has the value reference {vr}")))
    }

    /// Set a Real input or (before initialisation) parameter. A parameter's value is checked
    /// when the instance is initialised.
    pub fn set_real(&mut self, vr: u32, value: f64) -> Result<(), FmuError> {
        let v = self.variable(vr)?.clone();
        match (v.causality, v.start) {
            (Causality::Input, _) => {
                self.require(
                    &format!("setting input `{}`", v.name),
                    &[Phase::Instantiated, Phase::Initialising, Phase::Stepping],
                )?;
                if !value.is_finite() {
                    return Err(FmuError(format!(
                        "input `{}` = {value}: must be finite",
                        v.name
                    )));
                }
                self.inputs[vr as usize] = value;
                Ok(())
            }
            (Causality::Parameter, Some(Value::Real(_))) => {
                self.set_parameter(&v.name, toml::Value::Float(value))
            }
            _ => Err(FmuError(format!("`{}` cannot be set as a Real", v.name))),
        }
    }

    /// Set a Boolean parameter (before initialisation).
    pub fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), FmuError> {
        let v = self.variable(vr)?.clone();
        match (v.causality, v.start) {
            (Causality::Parameter, Some(Value::Boolean(_))) => {
                self.set_parameter(&v.name, toml::Value::Boolean(value))
            }
            _ => Err(FmuError(format!("`{}` is not a Boolean parameter", v.name))),
        }
    }

    fn set_parameter(&mut self, key: &str, value: toml::Value) -> Result<(), FmuError> {
        if !matches!(self.phase, Phase::Instantiated | Phase::Initialising) {
            return Err(FmuError(format!(
                "parameter `{key}` is fixed after initialisation"
            )));
        }
        self.parameters.insert(key.to_string(), value);
        Ok(())
    }

    /// A Real variable's value: an input or parameter as set, an output from the simulation
    /// (after initialisation).
    pub fn get_real(&self, vr: u32) -> Result<f64, FmuError> {
        let v = self.variable(vr)?;
        match (v.causality, v.start) {
            (Causality::Input, _) => Ok(self.inputs[vr as usize]),
            (Causality::Parameter, Some(Value::Real(_))) => match self.parameters.get(&v.name) {
                Some(toml::Value::Float(x)) => Ok(*x),
                Some(toml::Value::Integer(x)) => Ok(*x as f64),
                _ => Err(FmuError(format!("parameter `{}` has no value", v.name))),
            },
            (Causality::Output, _) => {
                let k = (vr - OUTPUT_VR) as usize;
                Ok(self.outputs()?[k])
            }
            _ => Err(FmuError(format!("`{}` is not a Real", v.name))),
        }
    }

    /// A Boolean parameter's value.
    pub fn get_boolean(&self, vr: u32) -> Result<bool, FmuError> {
        let v = self.variable(vr)?;
        match self.parameters.get(&v.name) {
            Some(toml::Value::Boolean(b)) => Ok(*b),
            _ => Err(FmuError(format!("`{}` is not a Boolean", v.name))),
        }
    }

    /// The rig the parameters describe, checked (every value named by its key).
    fn rig(&self) -> Result<Rig, FmuError> {
        for (key, value) in &self.parameters {
            if let toml::Value::Float(x) = value {
                if let Some(why) = Rig::check_key(key, *x) {
                    return Err(FmuError(format!("parameter `{key}` = {x}: {why}")));
                }
            }
        }
        let text = toml::to_string(&self.parameters).map_err(|e| FmuError(e.to_string()))?;
        let rig = Rig::from_toml_str(&text, "the FMU's parameters")
            .map_err(|e| FmuError(e.to_string()))?;
        Ok(rig)
    }

    /// Set the start time, enter and leave initialisation mode: the whole of an FMI host's
    /// start ([`Instance::setup_experiment`], [`Instance::exit_initialization`]). After a
    /// start refused for a bad parameter, a second call (the parameter set right) starts it.
    pub fn initialize(&mut self, start_s: f64) -> Result<(), FmuError> {
        if self.phase == Phase::Initialising {
            self.set_start(start_s)?;
        } else {
            self.setup_experiment(start_s)?;
            self.enter_initialization()?;
        }
        self.exit_initialization()
    }

    /// The emulator's effects: those of the rig the run starts on, the parameters' with the
    /// force the run starts under (its `beta_bar` at its own mean pressure at rest, its
    /// `mass_by_position`; docs/emulator.md#what-a-user-rig-gets), as `pumpcyl emulate` takes
    /// them for the same rig; or none.
    fn effects(&self, rig: &Rig) -> Result<crate::emulator::Effects, FmuError> {
        Ok(crate::emulator::Effects::switched(
            rig,
            self.config.effects,
        )?)
    }

    fn emulator(&self, rig: &Rig) -> Result<Sim, FmuError> {
        let dynamics = Dynamics::new(rig, self.effects(rig)?)?;
        Ok(match self.config.controller {
            Controller::Article => {
                let plc = Plc::ideal(PLC_RATE_HZ);
                let mut run =
                    PlcLoop::settled(rig, &dynamics, &plc, self.inputs[0] * 1e3, SETTLE_S)?;
                if self.config.energy {
                    run.account_energy();
                }
                Sim::Plc {
                    run: Box::new(run),
                    u: [0.0; 2],
                }
            }
            Controller::External => {
                let (x, _) = dynamics.operating_point();
                Sim::Plant {
                    dynamics: Box::new(dynamics),
                    x,
                    end_stop: None,
                    energy: self.config.energy.then(Energy::default),
                }
            }
        })
    }

    /// Advance from `t_s` by `h_s` (s), the inputs held. With the article's controller the
    /// emulator's PLC samples at its own rate (docs/fmu.md#sample-rate): a step that does not
    /// divide the PLC period is integrated in pieces, the commands changing only at the PLC's
    /// sample instants, counted as whole periods from the start time.
    ///
    /// # Errors
    /// A step that is not a number in (0, [`MAX_STEP_S`]], a communication point `t_s` that is
    /// not the instance's own time ([`Instance::time_s`], within 10⁻⁶ of the step plus 10⁻⁹ of
    /// the time, at most half the step), a call outside [`Phase::Stepping`], or the simulation failing (the instance
    /// then goes to [`Phase::Failed`]).
    pub fn do_step(&mut self, t_s: f64, h_s: f64) -> Result<(), FmuError> {
        self.require("doing a step", &[Phase::Stepping])?;
        self.check_step(t_s, h_s)?;
        let result = self.advance(h_s);
        if result.is_err() {
            self.phase = Phase::Failed;
        }
        result
    }

    /// Refuse a step length out of (0, [`MAX_STEP_S`]] or a communication point that is not
    /// the instance's own time.
    fn check_step(&self, t_s: f64, h_s: f64) -> Result<(), FmuError> {
        if !(h_s > 0.0 && h_s <= MAX_STEP_S) {
            return Err(FmuError(format!(
                "communication step {h_s} s: must be > 0 and at most {MAX_STEP_S} s, the work \
                 one call may take (docs/fmu.md#limits)"
            )));
        }
        let own = self.time_s();
        // a master's rounding, never as much as half a step (a step skipped or repeated)
        let tol = (1e-6 * h_s + 1e-9 * own.abs().max(1.0)).min(0.5 * h_s);
        let off = (t_s - own).abs();
        if off.is_nan() || off > tol {
            return Err(FmuError(format!(
                "communication point {t_s} s: the instance is at {own} s; each step starts \
                 where the last one ended (docs/fmu.md#limits)"
            )));
        }
        Ok(())
    }

    /// The simulation over `h_s` (s) from the instance's own time.
    fn advance(&mut self, h_s: f64) -> Result<(), FmuError> {
        // the force the rig feels: the parameter plus the input
        let mut inputs = self.inputs.clone();
        *inputs.last_mut().expect("f_ext_n is always an input") += self.force_parameter_n;
        let clock = &mut self.clock;
        match self.sim.as_mut() {
            None => return Err(FmuError("the FMU is not initialised".into())),
            Some(Sim::Plc { run, u }) => plc_step(run, u, &inputs, clock, h_s)?,
            Some(Sim::Plant {
                dynamics,
                x,
                end_stop,
                energy,
            }) => {
                // integrated a PLC period at a time, as the PLC loop is: BDF restarts at each
                // period, so a long step through an end stop or cavitation does not stall it
                let n = dynamics.circuit().commands();
                dynamics.set_external_force_n(inputs[n]);
                let mut u = [0.0; 2];
                u[..n].copy_from_slice(&inputs[..n]);
                let ts = clock.period_s;
                clock.advance(h_s, |k, from, to| {
                    let (t0, t1) = (k as f64 * ts + from, k as f64 * ts + to);
                    *x = match energy.as_mut() {
                        Some(e) => emulator::hold_speeds_accounting(dynamics, x, u, (t0, t1), e)?,
                        None => emulator::hold_speeds(dynamics, x, u, t0, t1)?,
                    };
                    *end_stop = end_stop.or_else(|| dynamics.end_stop(x, t1));
                    Ok(())
                })?;
            }
            Some(Sim::Linear(lin)) => {
                lin.step(&inputs, h_s)?;
                clock.advance(h_s, |_, _, _| Ok(()))?;
            }
        }
        self.note_end_stop();
        Ok(())
    }

    /// Keep a note of the first end stop the emulated piston met (its time the instance's).
    fn note_end_stop(&mut self) {
        if self.end_stop_noted {
            return;
        }
        let hit = match self.sim.as_ref() {
            Some(Sim::Plc { run, .. }) => run.end_stop(),
            Some(Sim::Plant { end_stop, .. }) => *end_stop,
            _ => None,
        };
        if let Some(hit) = hit {
            let hit = emulator::EndStopHit {
                at_s: hit.at_s + self.start_s,
                ..hit
            };
            self.note = Some(hit.to_string());
            self.end_stop_noted = true;
        }
    }

    /// The outputs, in the order of [`variables`].
    fn outputs(&self) -> Result<Vec<f64>, FmuError> {
        let (signals, x, u): (Vec<Signal>, Vec<f64>, Option<[f64; 2]>) = match self.sim.as_ref() {
            None => return Err(FmuError("outputs are known after initialisation".into())),
            Some(Sim::Plc { run, u }) => (
                run.dynamics().circuit().states(),
                run.state().to_vec(),
                Some(*u),
            ),
            Some(Sim::Plant { dynamics, x, .. }) => (dynamics.circuit().states(), x.clone(), None),
            Some(Sim::Linear(lin)) => (
                lin.signals.clone(),
                lin.absolute(),
                lin.commands(&self.inputs),
            ),
        };
        let of = |role: Role| -> Vec<f64> {
            (signals.iter().zip(&x))
                .filter(|(s, _)| s.role == role)
                .map(|(_, v)| *v)
                .collect()
        };
        let pressures = of(Role::Pressure);
        let mut out = of(Role::Position);
        out.extend(of(Role::Velocity));
        out.extend(&pressures);
        out.push(pressures.iter().sum());
        for role in STATE_OUTPUTS {
            out.extend(of(role));
        }
        if self.config.controller == Controller::Article {
            out.extend(&u.unwrap_or([f64::NAN; 2])[..command_count(&self.config.rig)]);
        }
        if has_mode(&self.config) {
            let mode = match self.sim.as_ref() {
                Some(Sim::Plc { run, .. }) => run.dynamics().mode(run.state()),
                Some(Sim::Plant { dynamics, x, .. }) => dynamics.mode(x),
                _ => None,
            };
            out.push(mode.map_or(f64::NAN, |m| m as f64));
        }
        if self.config.energy {
            out.extend(self.energy_outputs());
        }
        Ok(out)
    }

    /// The energy outputs ([`ENERGY_OUTPUTS`]) of the run so far.
    fn energy_outputs(&self) -> [f64; 4] {
        let e = match self.sim.as_ref() {
            Some(Sim::Plc { run, .. }) => run.energy(),
            Some(Sim::Plant { energy, .. }) => energy.as_ref(),
            _ => None,
        };
        let Some(e) = e else {
            return [f64::NAN; 4];
        };
        let sum = |l: &[(&'static str, f64)]| l.iter().map(|(_, j)| j).sum::<f64>();
        [
            sum(&e.sources_j),
            e.work_out_j,
            sum(&e.losses_j),
            sum(&e.stored_j),
        ]
    }
}

/// The emulator with the PLC advanced by `h` (s) on `clock`: at each PLC sample instant the
/// PLC reads the reference and sends new commands `u`, held until the next. The integration
/// runs over the same instants as `pumpcyl emulate` (period k from k·T to k·T + T).
fn plc_step(
    run: &mut PlcLoop,
    u: &mut [f64; 2],
    inputs: &[f64],
    clock: &mut Clock,
    h: f64,
) -> Result<(), FmuError> {
    run.set_external_force_n(inputs[1]);
    let ts = run.period_s();
    clock.advance(h, |k, from, to| {
        if from == 0.0 {
            *u = run.sample(inputs[0] * 1e3).1;
        }
        let base = k as f64 * ts;
        let end = if to == ts { base + ts } else { base + to };
        run.hold(*u, base + from, end)?;
        Ok(())
    })
}

impl Linear {
    /// The linear model of `rig` with the article's controller closed around it, or open.
    fn new(rig: &Rig, controller: Controller) -> Result<Linear, FmuError> {
        let plant = Plant::new(rig);
        let n = plant.n();
        let x_op = plant.operating_point().state[plant.position()];
        let (z_op, u_rest) = rest(ModelKind::Linear, rig);
        // the force enters Newton's law: v̇ = … − F_ext / m
        let mut force = DMatrix::zeros(n, 1);
        let velocity = plant
            .state_of(Role::Velocity)
            .expect("a piston has a velocity");
        force[(velocity, 0)] = -1.0 / plant.si.mass;
        let (a, b_drive, control, u_op, z_op, rest_commands) = match controller {
            // the P law alone holds the load and feeds the leakage: the loop rests with the
            // reference off the piston (docs/simulation.md#the-rest-under-load), its commands
            // there the law's own
            Controller::Article => {
                let (kx, kr) = plant.controller(rig.sum_pressure);
                let a = &plant.a + &plant.b * &kx;
                let b = &plant.b * &kr;
                let (z_rest, offset_m) = plant
                    .rest(rig.sum_pressure)
                    .map_or((z_op.clone(), 0.0), |r| (r.state, r.offset_m));
                let dz = DVector::from_iterator(n, z_rest.iter().zip(&z_op).map(|(r, o)| r - o));
                let at_rest = &kx * dz + &kr * offset_m;
                let mut commands = [0.0; 2];
                for (c, u) in commands.iter_mut().zip(at_rest.iter()) {
                    *c = *u;
                }
                let u_op = vec![x_op + offset_m, rig.external_force_n];
                (a, b, Some((kx, kr)), u_op, z_rest, commands)
            }
            Controller::External => {
                let mut u_op = u_rest[..command_count(rig)].to_vec();
                u_op.push(rig.external_force_n);
                (plant.a.clone(), plant.b.clone(), None, u_op, z_op, u_rest)
            }
        };
        // a single-pump mode pins its accumulator chamber: the outputs show both chambers
        let mode = plant.circuit().single_pump_mode().cloned();
        let signals = match &mode {
            Some(_) => crate::circuit::single_pump::SinglePump::new(rig).states(),
            None => plant.signals(),
        };
        crate::lti::require_stable(&a).or_else(|e| match controller {
            // the open plant has the position integrator; only the closed loop must be stable
            Controller::External => Ok(()),
            Controller::Article => Err(e),
        })?;
        let b = concat_columns(&b_drive, &force);
        Ok(Linear {
            signals,
            mode,
            z: DVector::zeros(n),
            a,
            b,
            z_op,
            u_op,
            control,
            rest_commands,
            zoh: None,
        })
    }

    /// Advance by `h` (s) with the inputs held (exact zero-order hold).
    fn step(&mut self, inputs: &[f64], h: f64) -> Result<(), FmuError> {
        let same = self
            .zoh
            .as_ref()
            .is_some_and(|z| (z.h - h).abs() <= 1e-12 * h);
        if !same {
            self.zoh = Some(Zoh::new(&self.a, &self.b, h)?);
        }
        let zoh = self.zoh.as_ref().expect("set above");
        let du = DVector::from_iterator(
            inputs.len(),
            inputs.iter().zip(&self.u_op).map(|(u, op)| u - op),
        );
        self.z = &zoh.phi * &self.z + &zoh.gamma * du;
        Ok(())
    }

    /// The state, absolute (for a single-pump mode, the full circuit's: the accumulator
    /// chamber at p_acc).
    fn absolute(&self) -> Vec<f64> {
        let s: Vec<f64> = (self.z.iter().zip(&self.z_op))
            .map(|(d, op)| d + op)
            .collect();
        match &self.mode {
            Some(m) => m.full_state(&s),
            None => s,
        }
    }

    /// The controller's speed commands (rad/s, absolute) for the reference in `inputs`.
    fn commands(&self, inputs: &[f64]) -> Option<[f64; 2]> {
        let (kx, kr) = self.control.as_ref()?;
        let r = inputs[0] - self.u_op[0];
        let u = kx * &self.z + kr * r;
        // about the commands at the state the deviations are taken from
        let mut out = self.rest_commands;
        for (o, du) in out.iter_mut().zip(u.iter()) {
            *o += du;
        }
        Some(out)
    }
}

/// [A | B] side by side.
fn concat_columns(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(a.nrows(), a.ncols() + b.ncols());
    out.view_mut((0, 0), (a.nrows(), a.ncols())).copy_from(a);
    out.view_mut((0, a.ncols()), (b.nrows(), b.ncols()))
        .copy_from(b);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::circuit::CircuitKind;
    use crate::emulator::Experiment;

    fn emulated_rig() -> (Rig, crate::emulator::Effects) {
        let rig = article::default_rig().unwrap();
        (
            rig.clone(),
            crate::emulator::Effects::for_rig(&rig).unwrap(),
        )
    }

    /// Run an instance over `n` steps of `h` with the reference `r_mm(t)` set before each, and
    /// return (x, p1) at every communication point from t = 0.
    fn run(fmu: &mut Instance, n: usize, h: f64, r_mm: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
        let (xr, x, p1) = (
            fmu.value_reference("x_ref_m").unwrap(),
            fmu.value_reference("x_m").unwrap(),
            fmu.value_reference("p1_pa").unwrap(),
        );
        fmu.set_real(xr, r_mm(0.0) * 1e-3).unwrap();
        fmu.initialize(0.0).unwrap();
        let mut out = Vec::new();
        for k in 0..=n {
            let t = k as f64 * h;
            out.push((fmu.get_real(x).unwrap(), fmu.get_real(p1).unwrap()));
            if k < n {
                fmu.set_real(xr, r_mm(t) * 1e-3).unwrap();
                fmu.do_step(t, h).unwrap();
            }
        }
        out
    }

    /// A rig that shares no value with the article's: 80/45 mm, 2500 kg, 8/5 cm³/rev, β 300
    /// bar, Kp 15.
    fn user_rig() -> Rig {
        Rig::from_toml_str(
            "piston_diameter_mm = 80.0\nrod_diameter_mm = 45.0\nstroke_mm = 800.0\nx0_mm = 400.0\n\
                 mass_kg = 2500.0\nmass_by_position = []\ndisplacement_1_cm3_per_rev = 8.0\n\
                 displacement_2_cm3_per_rev = 5.0\nbeta_bar = 300.0\nkp = 15.0\n",
            "user.toml",
        )
        .unwrap()
    }

    /// The emulator FMU follows the `beta_bar` a host sets (docs/emulator.md#what-a-user-rig-gets):
    /// on a rig that shares no value with the article's, its step at 100 and 1000 bar equals the
    /// emulator run on the rig with that `beta_bar`, and the two differ.
    #[test]
    fn the_emulator_fmu_follows_the_beta_bar_a_host_sets() {
        let user = user_rig();
        let mut p1_peaks = vec![];
        for beta_bar in [100.0, 1000.0] {
            let rig = Rig {
                beta_bar,
                ..user.clone()
            };
            let effects = crate::emulator::Effects::for_rig(&rig).unwrap();
            let plan = Experiment::step(&rig, None, None, 0.5, Some(1.5));
            let rec = plan.run(&rig, effects, &Plc::ideal(PLC_RATE_HZ)).unwrap();
            let mut fmu = Instance::new(Config::new(
                ModelKind::Emulator,
                Controller::Article,
                true,
                user.clone(),
            ))
            .unwrap();
            let beta = fmu.value_reference("beta_bar").unwrap();
            fmu.set_real(beta, beta_bar).unwrap();
            let got = run(&mut fmu, 150, 0.01, |t| plan.reference_mm(t));
            for (k, (x, p1)) in got.iter().enumerate() {
                assert!(
                    (x * 1e3 - rec.x_mm[k]).abs() < 1e-6,
                    "β {beta_bar}: x at {k}"
                );
                assert!(
                    (p1 - rec.p1_bar[k] * PA_PER_BAR).abs() < 1.0,
                    "β {beta_bar}: p1 at {k}"
                );
            }
            p1_peaks.push(rec.p1_bar.iter().cloned().fold(f64::MIN, f64::max));
        }
        assert!(
            (p1_peaks[0] - p1_peaks[1]).abs() > 1e-3,
            "the two bulk moduli give the same step: {p1_peaks:?}"
        );
    }

    /// One source for the force (docs/fmu.md#variables): on a rig that shares no value with
    /// the article's, written at 0 N, the emulator FMU whose master sets the parameter
    /// `external_force_n` to 500 N gives `emulate`'s 5 mm step of the rig at 500 N, for the
    /// DPM and the single pump; the input `f_ext_n` starts at 0 and adds to the parameter
    /// (300 N set and 200 N on the input: the same run); the linear FMU likewise equals the
    /// one written at 500 N.
    #[test]
    fn the_force_parameter_a_master_sets_is_the_force_the_fmu_runs_at() {
        let user = user_rig();
        for kind in [CircuitKind::Dpm, CircuitKind::SinglePump] {
            let at = |f: f64| Rig {
                circuit: kind,
                external_force_n: f,
                ..user.clone()
            };
            let loaded = at(500.0);
            let effects = crate::emulator::Effects::for_rig(&loaded).unwrap();
            let plan = Experiment::step(&loaded, None, None, 0.5, Some(1.5));
            let rec = plan
                .run(&loaded, effects, &Plc::ideal(PLC_RATE_HZ))
                .unwrap();
            // the same rig unloaded rests elsewhere: the comparison can fail
            let unloaded = Experiment::step(&at(0.0), None, None, 0.5, Some(1.5))
                .run(
                    &at(0.0),
                    crate::emulator::Effects::for_rig(&at(0.0)).unwrap(),
                    &Plc::ideal(PLC_RATE_HZ),
                )
                .unwrap();
            // (far beyond the comparison's 1e-6 mm and 1 Pa)
            let worst = |a: &[f64], b: &[f64]| {
                (a.iter().zip(b)).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()))
            };
            let (dx_mm, dp1_bar) = (
                worst(&rec.x_mm, &unloaded.x_mm),
                worst(&rec.p1_bar, &unloaded.p1_bar),
            );
            assert!(
                dx_mm > 1e-3 || dp1_bar > 1e-3,
                "{kind:?}: x {dx_mm} mm, p1 {dp1_bar} bar apart"
            );
            let config = Config::new(ModelKind::Emulator, Controller::Article, true, at(0.0));
            let force_input = variables(&config)
                .into_iter()
                .find(|v| v.name == "f_ext_n")
                .unwrap();
            assert_eq!(force_input.start, Some(Value::Real(0.0)));
            for (parameter, input) in [(500.0, 0.0), (300.0, 200.0)] {
                let mut fmu = Instance::new(config.clone()).unwrap();
                let p = fmu.value_reference("external_force_n").unwrap();
                fmu.set_real(p, parameter).unwrap();
                let i = fmu.value_reference("f_ext_n").unwrap();
                fmu.set_real(i, input).unwrap();
                let got = run(&mut fmu, 150, 0.01, |t| plan.reference_mm(t));
                for (k, (x, p1)) in got.iter().enumerate() {
                    assert!(
                        (x * 1e3 - rec.x_mm[k]).abs() < 1e-6,
                        "{kind:?} {parameter} + {input} N: x at {k}: {} vs {} mm",
                        x * 1e3,
                        rec.x_mm[k]
                    );
                    assert!(
                        (p1 - rec.p1_bar[k] * PA_PER_BAR).abs() < 1.0,
                        "{kind:?} {parameter} + {input} N: p1 at {k}"
                    );
                }
            }
        }
        let linear = |rig: Rig, parameter: Option<f64>| {
            let config = Config::new(ModelKind::Linear, Controller::Article, false, rig);
            let mut fmu = Instance::new(config).unwrap();
            if let Some(f) = parameter {
                let p = fmu.value_reference("external_force_n").unwrap();
                fmu.set_real(p, f).unwrap();
            }
            let x0 = user.x0_mm;
            run(&mut fmu, 200, 0.01, |t| if t < 0.5 { x0 } else { x0 + 5.0 })
        };
        let written = linear(
            Rig {
                external_force_n: 500.0,
                ..user.clone()
            },
            None,
        );
        let set = linear(user.clone(), Some(500.0));
        let unloaded = linear(user.clone(), None);
        assert!(
            (written[0].1 - unloaded[0].1).abs() > 1e4,
            "p1 at 500 N vs 0 N"
        );
        for (k, (a, b)) in set.iter().zip(&written).enumerate() {
            assert!((a.0 - b.0).abs() < 1e-12, "linear x at {k}");
            assert!((a.1 - b.1).abs() < 1e-6, "linear p1 at {k}");
        }
    }

    #[test]
    fn the_emulator_fmu_gives_the_records_of_emulate() {
        let (rig, effects) = emulated_rig();
        let plan = Experiment::step(&rig, None, None, 0.5, Some(2.0));
        let rec = plan.run(&rig, effects, &Plc::ideal(PLC_RATE_HZ)).unwrap();
        let mut fmu = Instance::new(Config::new(
            ModelKind::Emulator,
            Controller::Article,
            true,
            rig,
        ))
        .unwrap();
        let got = run(&mut fmu, 200, 0.01, |t| plan.reference_mm(t));
        assert_eq!(got.len(), rec.x_mm.len());
        for (k, (x, p1)) in got.iter().enumerate() {
            assert!(
                (x * 1e3 - rec.x_mm[k]).abs() < 1e-6,
                "x at sample {k}: {x} m vs {} mm",
                rec.x_mm[k]
            );
            assert!(
                (p1 - rec.p1_bar[k] * PA_PER_BAR).abs() < 1.0,
                "p1 at sample {k}"
            );
        }
    }

    /// The emulator FMU with its energy outputs (docs/fmu.md#energy) gives `emulate --energy`'s
    /// account of the same run, on a rig that is not the article's: what the sources delivered,
    /// the work out, the losses and the stored change, to 1e-9 of the energy delivered, closing;
    /// the outputs are listed only when asked for.
    #[test]
    fn the_energy_outputs_are_the_emulators_account() {
        let rig = user_rig();
        let effects = Effects::for_rig(&rig).unwrap();
        let plan = Experiment::step(&rig, None, None, 0.5, Some(2.0));
        let plc = Plc {
            energy: true,
            ..Plc::ideal(PLC_RATE_HZ)
        };
        let work = crate::limits::Work::QUIET;
        let e = plan
            .run_reporting(&rig, effects, &plc, &work)
            .unwrap()
            .energy
            .unwrap();
        let config = Config::new(ModelKind::Emulator, Controller::Article, true, rig);
        assert!(Instance::new(config.clone())
            .unwrap()
            .value_reference("losses_j")
            .is_none());
        let mut fmu = Instance::new(config.with_energy(true)).unwrap();
        run(&mut fmu, 200, 0.01, |t| plan.reference_mm(t));
        let out = |name: &str| fmu.get_real(fmu.value_reference(name).unwrap()).unwrap();
        let sum = |l: &[(&'static str, f64)]| l.iter().map(|(_, j)| j).sum::<f64>();
        let delivered = sum(&e.sources_j);
        for (name, want) in [
            ("energy_in_j", delivered),
            ("work_out_j", e.work_out_j),
            ("losses_j", sum(&e.losses_j)),
            ("stored_change_j", sum(&e.stored_j)),
        ] {
            let got = out(name);
            assert!(
                (got - want).abs() <= 1e-9 * delivered,
                "{name}: {got} J, emulate {want} J"
            );
        }
        let closing =
            out("energy_in_j") - out("work_out_j") - out("losses_j") - out("stored_change_j");
        assert!(
            delivered > 1.0 && closing.abs() <= 1e-9 * delivered,
            "{closing}"
        );
    }

    /// The single-motor circuits' emulator FMU gives `emulate`'s records too, with one motor's
    /// variables and, for the single-pump circuit, its mode; their linear FMU steps to the
    /// reference about their rest.
    #[test]
    fn the_single_motor_fmus_give_their_records_and_steps() {
        for kind in [CircuitKind::DualPump, CircuitKind::SinglePump] {
            let rig = article::default_rig()
                .unwrap()
                .with_overrides(&[format!("circuit={}", kind.name())])
                .unwrap();
            let effects = crate::emulator::Effects::for_rig(&rig).unwrap();
            let plan = Experiment::step(&rig, None, None, 0.5, Some(2.0));
            let rec = plan.run(&rig, effects, &Plc::ideal(PLC_RATE_HZ)).unwrap();
            let config = Config::new(ModelKind::Emulator, Controller::Article, true, rig.clone());
            let names: Vec<String> = (variables(&config).into_iter())
                .filter(|v| v.value_reference < PARAMETER_VR)
                .map(|v| v.name)
                .collect();
            assert!(!names
                .iter()
                .any(|n| n.contains('2') && !n.starts_with("p2")));
            assert_eq!(
                names.iter().any(|n| n == "mode"),
                kind == CircuitKind::SinglePump
            );
            let mut fmu = Instance::new(config).unwrap();
            let got = run(&mut fmu, 200, 0.01, |t| plan.reference_mm(t));
            for (k, (x, p1)) in got.iter().enumerate() {
                assert!((x * 1e3 - rec.x_mm[k]).abs() < 1e-6, "{kind:?}: x at {k}");
                assert!(
                    (p1 - rec.p1_bar[k] * PA_PER_BAR).abs() < 1.0,
                    "{kind:?}: p1 at {k}"
                );
            }
            if let Some(vr) = fmu.value_reference("mode") {
                assert_eq!(fmu.get_real(vr).unwrap(), *rec.mode.last().unwrap());
            }
            let linear = Config::new(ModelKind::Linear, Controller::Article, true, rig.clone());
            // the loop rests at x0 under its reference's start value, x0 plus the rest
            // offset (docs/simulation.md#the-rest-under-load), and follows a step on it
            let (x0, x_ref) = (rig.x0_mm, crate::response::Baseline::of_rig(&rig).x_ref_mm);
            let got = run(&mut Instance::new(linear).unwrap(), 3000, 0.01, |t| {
                if t < 0.5 {
                    x_ref
                } else {
                    x_ref + 5.0
                }
            });
            assert!(
                (got[49].0 * 1e3 - x0).abs() < 1e-9,
                "{kind:?}: {:?}",
                got[49]
            );
            let (x_end, _) = got[got.len() - 1];
            assert!((x_end * 1e3 - x0 - 5.0).abs() < 0.01, "{kind:?}: {x_end}");
        }
    }

    #[test]
    fn a_step_that_does_not_divide_the_plc_period_keeps_the_plc_samples() {
        // 4 ms steps: the PLC still acts every 10 ms, so at the common instants (every 20 ms)
        // the run agrees with 10 ms steps to the integrator's tolerance
        let (rig, _) = emulated_rig();
        let config = Config::new(ModelKind::Emulator, Controller::Article, true, rig.clone());
        let step = |t: f64| if t < 0.1 { rig.x0_mm - 5.0 } else { rig.x0_mm };
        let fine = run(
            &mut Instance::new(config.clone()).unwrap(),
            250,
            0.004,
            step,
        );
        let plc = run(&mut Instance::new(config).unwrap(), 100, 0.01, step);
        for k in 0..=50 {
            let (a, b) = (fine[5 * k], plc[2 * k]);
            assert!(
                (a.0 - b.0).abs() < 1e-8,
                "x at {} s: {} vs {}",
                0.02 * k as f64,
                a.0,
                b.0
            );
            assert!((a.1 - b.1).abs() < 10.0, "p1 at {} s", 0.02 * k as f64);
        }
    }

    #[test]
    fn the_linear_fmu_gives_the_step_response() {
        let rig = Rig::default();
        let s = crate::response::step(&rig, 5.0, 3.0, 100.0).unwrap();
        let mut fmu = Instance::new(Config::new(
            ModelKind::Linear,
            Controller::Article,
            false,
            rig.clone(),
        ))
        .unwrap();
        // both rest with the reference off the piston by the loop's rest offset
        // (docs/simulation.md#the-rest-under-load), which the FMU's start value holds
        let base = crate::response::Baseline::of_rig(&rig);
        let x_ref = fmu.value_reference("x_ref_m").unwrap();
        assert!((fmu.get_real(x_ref).unwrap() * 1e3 - base.x_ref_mm).abs() < 1e-12);
        let got = run(&mut fmu, 300, 0.01, |_| base.x_ref_mm + 5.0);
        for (k, (x, p1)) in got.iter().enumerate().skip(1) {
            assert!((x * 1e3 - s.x_mm[k]).abs() < 1e-9 * 1e3, "x at sample {k}");
            assert!(
                (p1 - s.p1_bar[k] * PA_PER_BAR).abs() < 1.0,
                "p1 at sample {k}"
            );
        }
    }

    #[test]
    fn a_bad_parameter_is_named_at_initialisation() {
        let mut fmu = Instance::new(Config::new(
            ModelKind::Linear,
            Controller::Article,
            false,
            Rig::default(),
        ))
        .unwrap();
        let m = fmu.value_reference("mass_kg").unwrap();
        fmu.set_real(m, f64::NAN).unwrap();
        let e = fmu.initialize(0.0).unwrap_err().to_string();
        assert!(e.contains("`mass_kg`") && e.contains("finite"), "{e}");
        fmu.set_real(m, -1.0).unwrap();
        let e = fmu.initialize(0.0).unwrap_err().to_string();
        assert!(e.contains("mass_kg"), "{e}");
    }

    #[test]
    fn instances_share_nothing() {
        let rig = Rig::default();
        let config = Config::new(ModelKind::Linear, Controller::Article, false, rig.clone());
        let alone = run(
            &mut Instance::new(config.clone()).unwrap(),
            100,
            0.01,
            |_| rig.x0_mm + 5.0,
        );
        let (mut a, mut b) = (
            Instance::new(config.clone()).unwrap(),
            Instance::new(config).unwrap(),
        );
        let m = b.value_reference("mass_kg").unwrap();
        b.set_real(m, 4898.0).unwrap();
        let light = run(&mut b, 100, 0.01, |_| rig.x0_mm + 5.0);
        let heavy = run(&mut a, 100, 0.01, |_| rig.x0_mm + 5.0);
        assert_eq!(heavy, alone);
        assert!(light
            .iter()
            .zip(&heavy)
            .any(|(l, h)| (l.0 - h.0).abs() > 1e-5));
    }

    #[test]
    fn the_external_controller_holds_the_rig_at_rest() {
        for model in [ModelKind::Emulator, ModelKind::Linear] {
            let (rig, _) = emulated_rig();
            let mut fmu =
                Instance::new(Config::new(model, Controller::External, false, rig.clone()))
                    .unwrap();
            fmu.initialize(0.0).unwrap();
            for k in 0..50 {
                fmu.do_step(k as f64 * 0.01, 0.01).unwrap();
            }
            let x = fmu.get_real(fmu.value_reference("x_m").unwrap()).unwrap();
            let p = fmu
                .get_real(fmu.value_reference("p_sum_pa").unwrap())
                .unwrap();
            assert!((x - rig.x0_mm * 1e-3).abs() < 1e-7, "{model:?}: x {x}");
            assert!(
                (p - rig.p_sum_ref_bar * PA_PER_BAR).abs() < 10.0,
                "{model:?}: p {p}"
            );
        }
    }

    #[test]
    fn every_parameter_has_a_declared_unit() {
        let c = Config::new(
            ModelKind::Emulator,
            Controller::Article,
            true,
            Rig::default(),
        );
        for v in variables(&c) {
            if let Some(Value::Real(_)) = v.start {
                let unit = v.unit.unwrap();
                assert!(UNITS.iter().any(|u| u.name == unit), "{}: {unit}", v.name);
                if v.causality == Causality::Parameter && !v.description.starts_with("-,") {
                    assert_ne!(unit, "1", "{} has no unit: {}", v.name, v.description);
                }
            }
        }
        // the configuration reads back, with its GUID
        assert_eq!(Config::from_toml(&c.to_toml()).unwrap(), c);
    }

    /// x (m) after each of `n` 10 ms steps of a 5 mm step (at the third step), the instance
    /// started at `start_s` and the master's communication point `t(k)`.
    fn step_from(config: &Config, start_s: f64, t: impl Fn(usize, f64) -> f64) -> Vec<f64> {
        let mut fmu = Instance::new(config.clone()).unwrap();
        let (xr, x) = (
            fmu.value_reference("x_ref_m").unwrap(),
            fmu.value_reference("x_m").unwrap(),
        );
        let x0 = config.rig.x0_mm * 1e-3;
        fmu.initialize(start_s).unwrap();
        let mut now = start_s;
        (0..120)
            .map(|k| {
                fmu.set_real(xr, if k < 3 { x0 } else { x0 + 5e-3 })
                    .unwrap();
                now = t(k, now);
                fmu.do_step(now, 0.01).unwrap();
                fmu.get_real(x).unwrap()
            })
            .collect()
    }

    #[test]
    fn a_run_started_late_steps_as_one_started_at_zero() {
        let (rig, _) = emulated_rig();
        for model in [ModelKind::Emulator, ModelKind::Linear] {
            let config = Config::new(model, Controller::Article, true, rig.clone());
            let at_zero = step_from(&config, 0.0, |k, _| k as f64 * 0.01);
            // a master that adds the step to its time, and one that multiplies it out
            let adding = step_from(&config, 1e6, |k, t| if k == 0 { t } else { t + 0.01 });
            let multiplying = step_from(&config, 1e6, |k, _| 1e6 + k as f64 * 0.01);
            let moved = at_zero
                .iter()
                .fold(0.0_f64, |m, x| m.max((x - at_zero[0]).abs()));
            assert!(moved > 4e-3, "{model:?}: the step moved {moved} m");
            for (name, late) in [("t += h", adding), ("t0 + k h", multiplying)] {
                let worst = late
                    .iter()
                    .zip(&at_zero)
                    .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
                assert!(
                    worst < 1e-9,
                    "{model:?}, {name}: {worst} m from the run at 0"
                );
            }
        }
    }

    /// Every kind of FMU: (model, controller).
    const KINDS: [(ModelKind, Controller); 4] = [
        (ModelKind::Emulator, Controller::Article),
        (ModelKind::Emulator, Controller::External),
        (ModelKind::Linear, Controller::Article),
        (ModelKind::Linear, Controller::External),
    ];

    fn started(model: ModelKind, controller: Controller, start_s: f64) -> Instance {
        let (rig, _) = emulated_rig();
        let mut fmu = Instance::new(Config::new(model, controller, true, rig)).unwrap();
        fmu.initialize(start_s).unwrap();
        fmu
    }

    #[test]
    fn steps_beyond_the_limit_or_not_a_number_are_refused_and_change_nothing() {
        for (model, controller) in KINDS {
            let mut fmu = started(model, controller, 0.0);
            let x = fmu.value_reference("x_m").unwrap();
            fmu.do_step(0.0, 0.01).unwrap();
            let before = fmu.get_real(x).unwrap();
            for h in [
                1e300,
                1e7,
                1e5,
                MAX_STEP_S * 1.001,
                f64::INFINITY,
                f64::NAN,
                -0.01,
                0.0,
            ] {
                let e = fmu.do_step(0.01, h).unwrap_err().to_string();
                assert!(e.contains("communication step"), "{model:?} h = {h}: {e}");
                assert_eq!(fmu.phase(), Phase::Stepping);
                assert_eq!(fmu.get_real(x).unwrap(), before, "h = {h} moved it");
                assert_eq!(fmu.time_s(), 0.01);
            }
            // the refused calls left the instance as it was: the next step goes on
            fmu.do_step(0.01, 0.01).unwrap();
            assert!((fmu.time_s() - 0.02).abs() < 1e-15);
        }
        // the limit itself is a step (the linear model: one exact zero-order hold)
        let mut fmu = started(ModelKind::Linear, Controller::Article, 0.0);
        fmu.do_step(0.0, MAX_STEP_S).unwrap();
        assert_eq!(fmu.time_s(), MAX_STEP_S);
    }

    #[test]
    fn a_communication_point_that_is_not_the_instances_time_is_refused() {
        for (model, controller) in KINDS {
            let mut fmu = started(model, controller, 1e6);
            for t in [-1.0, 0.0, 1e300, f64::NAN, 1e6 + 0.005, 1e6 - 0.01] {
                let e = fmu.do_step(t, 0.01).unwrap_err().to_string();
                assert!(
                    e.contains("the instance is at 1000000 s"),
                    "{model:?} t = {t}: {e}"
                );
            }
            // within the tolerance: a master's rounding
            fmu.do_step(1e6 + 1e-9, 0.01).unwrap();
            fmu.do_step(1e6 + 0.01 - 1e-9, 0.01).unwrap();
            assert!((fmu.time_s() - (1e6 + 0.02)).abs() < 1e-9);
        }
    }

    #[test]
    fn a_start_time_beyond_the_limit_is_refused() {
        let (rig, _) = emulated_rig();
        let config = Config::new(ModelKind::Linear, Controller::Article, false, rig);
        for start in [1e300, -1e300, MAX_START_S * 1.01, f64::NAN, f64::INFINITY] {
            let mut fmu = Instance::new(config.clone()).unwrap();
            let e = fmu.setup_experiment(start).unwrap_err().to_string();
            assert!(e.contains("start time"), "{start}: {e}");
            assert_eq!(fmu.phase(), Phase::Instantiated);
        }
        let mut fmu = Instance::new(config).unwrap();
        fmu.initialize(-MAX_START_S).unwrap();
        fmu.do_step(-MAX_START_S, 0.01).unwrap();
    }

    #[test]
    fn each_call_is_refused_outside_its_phase() {
        for (model, controller) in KINDS {
            let (rig, _) = emulated_rig();
            let mut fmu = Instance::new(Config::new(model, controller, true, rig)).unwrap();
            let x = fmu.value_reference("x_m").unwrap();
            let kp = fmu.value_reference("kp").unwrap();
            let force = fmu.value_reference("f_ext_n").unwrap();
            let refused = |r: Result<(), FmuError>, what: &str| {
                assert!(r.is_err(), "{model:?}/{controller:?}: {what} was accepted");
            };
            refused(fmu.do_step(0.0, 0.01), "a step before initialisation");
            refused(fmu.exit_initialization(), "leaving a mode not entered");
            refused(fmu.terminate(), "terminating before initialisation");
            fmu.setup_experiment(0.0).unwrap();
            fmu.enter_initialization().unwrap();
            refused(
                fmu.setup_experiment(0.0),
                "a start time in initialisation mode",
            );
            refused(fmu.enter_initialization(), "entering twice");
            refused(fmu.do_step(0.0, 0.01), "a step in initialisation mode");
            fmu.exit_initialization().unwrap();
            refused(fmu.set_real(kp, 20.0), "a parameter after initialisation");
            refused(fmu.enter_initialization(), "entering after initialisation");
            fmu.do_step(0.0, 0.01).unwrap();
            fmu.terminate().unwrap();
            let last = fmu.get_real(x).unwrap();
            refused(fmu.do_step(0.01, 0.01), "a step after terminate");
            refused(fmu.set_real(force, 1.0), "an input after terminate");
            refused(fmu.terminate(), "terminating twice");
            // the outputs stay readable; a reset starts over
            assert_eq!(fmu.get_real(x).unwrap(), last);
            fmu.reset().unwrap();
            assert_eq!(fmu.phase(), Phase::Instantiated);
            fmu.initialize(5.0).unwrap();
            fmu.do_step(5.0, 0.01).unwrap();
        }
    }

    #[test]
    fn the_emulator_fmu_stays_inside_its_cylinder_and_says_so() {
        let (rig, _) = emulated_rig();
        // a position gain too small to hold the piston inside the stroke: refused at the start
        let mut weak = Instance::new(Config::new(
            ModelKind::Emulator,
            Controller::Article,
            true,
            rig.clone(),
        ))
        .unwrap();
        let kp = weak.value_reference("kp").unwrap();
        weak.set_real(kp, 1e-6).unwrap();
        let e = weak.initialize(0.0).unwrap_err().to_string();
        assert!(e.contains("outside the stroke 0…500 mm"), "{e}");
        // a step to 1 mm short of the end overshoots into the stop, which holds it
        let mut fmu = started(ModelKind::Emulator, Controller::Article, 0.0);
        let (xr, x) = (
            fmu.value_reference("x_ref_m").unwrap(),
            fmu.value_reference("x_m").unwrap(),
        );
        fmu.set_real(xr, 0.499).unwrap();
        let (mut peak, mut notes) = (0.0_f64, vec![]);
        for k in 0..400 {
            fmu.do_step(k as f64 * 0.01, 0.01).unwrap();
            peak = peak.max(fmu.get_real(x).unwrap());
            notes.extend(fmu.take_note());
        }
        assert!(peak > 0.4999 && peak < 0.5001, "peak {peak} m");
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("extended end stop (x = 500 mm)"),
            "{notes:?}"
        );
    }

    #[test]
    fn the_plant_driven_into_an_end_in_one_long_step_rests_on_its_stop() {
        // speed commands that run the piston into an end and hold it there (or cavitate a
        // chamber trying), in one step of the longest length
        for (w, end_m) in [(-300.0, 0.0), (300.0, 0.5), (1e4, 0.5), (-1e4, 0.0)] {
            let mut fmu = started(ModelKind::Emulator, Controller::External, 0.0);
            for name in ["omega_ref1_rad_per_s", "omega_ref2_rad_per_s"] {
                let vr = fmu.value_reference(name).unwrap();
                fmu.set_real(vr, w).unwrap();
            }
            fmu.do_step(0.0, MAX_STEP_S)
                .unwrap_or_else(|e| panic!("{w} rad/s: {e}"));
            let get = |name: &str| fmu.get_real(fmu.value_reference(name).unwrap()).unwrap();
            let (x, v, p1, p2) = (get("x_m"), get("v_m_per_s"), get("p1_pa"), get("p2_pa"));
            assert!((x - end_m).abs() < 0.5e-3, "{w} rad/s: x {x} m");
            // at rest on the stop, which carries the hydraulic force: the piston sinks into it
            // by that force over the stop's stiffness m ω_s² (docs/emulator.md#end-stops)
            let (rig, _) = emulated_rig();
            let si = rig.si();
            let force = p1 * si.a1 - p2 * si.a2 - rig.external_force_n;
            let k = rig.mass_kg * emulator::CONTACT_RAD_S.powi(2);
            let (sunk, want) = (x - end_m, force / k);
            assert!(v.abs() < 1e-6, "{w} rad/s: still moving at {v} m/s");
            assert!(
                (sunk - want).abs() < 0.01 * want.abs() + 1e-9,
                "{w} rad/s: sank {sunk} m, force {force} N over k: {want} m"
            );
            let note = fmu.take_note().unwrap_or_default();
            assert!(note.contains("end stop"), "{w} rad/s: {note:?}");
            // met within seconds, not at the end of the step
            assert!(!note.contains("t = 100.00 s"), "{w} rad/s: {note:?}");
        }
    }
}
