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

use crate::emulator::{self, article, Dynamics, Plc, PlcLoop, PLC_RATE_HZ, SETTLE_S};
use crate::lti::Zoh;
use crate::model::{Layout, Plant};
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
            guid: String::new(),
            rig,
        };
        c.guid = c.fingerprint();
        c
    }

    /// The configuration as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a configuration always serialises")
    }

    /// Read a configuration written by [`Config::to_toml`].
    pub fn from_toml(text: &str) -> Result<Config, FmuError> {
        let c: Config =
            toml::from_str(text).map_err(|e| FmuError(format!("{CONFIG_FILE}: {e}")))?;
        let rig_text = toml::to_string(&c.rig).map_err(|e| FmuError(e.to_string()))?;
        Rig::from_toml_str(&rig_text, CONFIG_FILE).map_err(|e| FmuError(e.to_string()))?;
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
    model: ModelKind,
    controller: Controller,
    effects: bool,
    rig: Rig,
) -> Result<Config, FmuError> {
    let config = Config::new(
        model,
        controller,
        effects && model == ModelKind::Emulator,
        rig,
    );
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

/// The inputs: the position reference or the two speed commands, then the external force.
fn input_names(c: &Config) -> Vec<(&'static str, &'static str, &'static str)> {
    let mut out = match c.controller {
        Controller::Article => vec![(
            "x_ref_m",
            "m",
            "position reference (absolute, as the rig's x0)",
        )],
        Controller::External => vec![
            ("omega_ref1_rad_per_s", "rad/s", "speed command of motor 1"),
            ("omega_ref2_rad_per_s", "rad/s", "speed command of motor 2"),
        ],
    };
    out.push((
        "f_ext_n",
        "N",
        "external force on the piston (positive against the extension)",
    ));
    out
}

/// The outputs.
fn output_names(c: &Config) -> Vec<(&'static str, &'static str, &'static str)> {
    let mut out = vec![
        ("x_m", "m", "piston position (absolute)"),
        ("v_m_per_s", "m/s", "piston velocity"),
        ("p1_pa", "Pa", "chamber 1 (piston side) pressure, gauge"),
        ("p2_pa", "Pa", "chamber 2 (rod side) pressure, gauge"),
        ("p_sum_pa", "Pa", "sum pressure p1 + p2"),
        ("omega1_rad_per_s", "rad/s", "speed of motor 1"),
        ("omega2_rad_per_s", "rad/s", "speed of motor 2"),
    ];
    if c.rig.motor_model == MotorModel::Full {
        out.push(("tau1_nm", "N.m", "electromagnetic torque of motor 1"));
        out.push(("tau2_nm", "N.m", "electromagnetic torque of motor 2"));
    }
    if c.controller == Controller::Article {
        out.push((
            "omega_ref1_rad_per_s",
            "rad/s",
            "the controller's speed command to motor 1",
        ));
        out.push((
            "omega_ref2_rad_per_s",
            "rad/s",
            "the controller's speed command to motor 2",
        ));
    }
    out
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
            name: name.into(),
            value_reference: k as u32,
            causality: Causality::Input,
            unit: Some(unit),
            description: doc.into(),
            start: Some(Value::Real(start)),
        })
        .collect();
    out.extend(
        output_names(c)
            .into_iter()
            .enumerate()
            .map(|(k, (name, unit, doc))| Variable {
                name: name.into(),
                value_reference: OUTPUT_VR + k as u32,
                causality: Causality::Output,
                unit: Some(unit),
                description: doc.into(),
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
    let table = toml::Table::try_from(rig).expect("a rig always serialises");
    Rig::key_docs()
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
/// (kg, m, s, rad) and the factor to SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    /// As the rig's key documentation writes it.
    pub doc: &'static str,
    /// The FMI unit name.
    pub name: &'static str,
    /// Exponents of kg, m, s, rad.
    pub base: [i32; 4],
    /// SI value of one unit.
    pub factor: f64,
}

/// Every unit the FMU's variables use.
pub const UNITS: &[Unit] = &[
    Unit {
        doc: "-",
        name: "1",
        base: [0, 0, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "m",
        name: "m",
        base: [0, 1, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "m/s",
        name: "m/s",
        base: [0, 1, -1, 0],
        factor: 1.0,
    },
    Unit {
        doc: "Pa",
        name: "Pa",
        base: [1, -1, -2, 0],
        factor: 1.0,
    },
    Unit {
        doc: "rad/s",
        name: "rad/s",
        base: [0, 0, -1, 1],
        factor: 1.0,
    },
    Unit {
        doc: "N",
        name: "N",
        base: [1, 1, -2, 0],
        factor: 1.0,
    },
    Unit {
        doc: "N m",
        name: "N.m",
        base: [1, 2, -2, 0],
        factor: 1.0,
    },
    Unit {
        doc: "mm",
        name: "mm",
        base: [0, 1, 0, 0],
        factor: 1e-3,
    },
    Unit {
        doc: "dm³",
        name: "dm3",
        base: [0, 3, 0, 0],
        factor: 1e-3,
    },
    Unit {
        doc: "kg·mm²",
        name: "kg.mm2",
        base: [1, 2, 0, 0],
        factor: 1e-6,
    },
    Unit {
        doc: "cm³/rev",
        name: "cm3/rev",
        base: [0, 3, 0, -1],
        factor: 1e-6 / (2.0 * std::f64::consts::PI),
    },
    Unit {
        doc: "N·m·s/rad",
        name: "N.m.s/rad",
        base: [1, 2, -1, -1],
        factor: 1.0,
    },
    Unit {
        doc: "kg·m²",
        name: "kg.m2",
        base: [1, 2, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "s",
        name: "s",
        base: [0, 0, 1, 0],
        factor: 1.0,
    },
    Unit {
        doc: "rpm",
        name: "rpm",
        base: [0, 0, -1, 1],
        factor: RAD_S_PER_RPM,
    },
    Unit {
        doc: "kg",
        name: "kg",
        base: [1, 0, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "bar",
        name: "bar",
        base: [1, -1, -2, 0],
        factor: PA_PER_BAR,
    },
    Unit {
        doc: "N·s/m",
        name: "N.s/m",
        base: [1, 0, -1, 0],
        factor: 1.0,
    },
    Unit {
        doc: "m⁵/(N·s)",
        name: "m5/(N.s)",
        base: [-1, 4, 1, 0],
        factor: 1.0,
    },
    Unit {
        doc: "1/m",
        name: "1/m",
        base: [0, -1, 0, 0],
        factor: 1.0,
    },
    Unit {
        doc: "1/bar",
        name: "1/bar",
        base: [-1, 1, 2, 0],
        factor: 1.0 / PA_PER_BAR,
    },
    Unit {
        doc: "rad/s per unit normalised command (1 = 3000 rpm)",
        name: "rad/s",
        base: [0, 0, -1, 1],
        factor: 1.0,
    },
];

/// The start values of the inputs: the rig at rest at its operating point.
fn input_start(c: &Config) -> Vec<f64> {
    let f = c.rig.external_force_n;
    match c.controller {
        Controller::Article => vec![c.rig.x0_mm * 1e-3, f],
        Controller::External => {
            let (_, u) = rest(c.model, &c.rig);
            vec![u[0], u[1], f]
        }
    }
}

/// The state at rest and the speed commands (rad/s) that hold it (docs/model.md): the
/// emulated motors always carry the pumps' load, the linear ones as the rig's
/// `motor_coupling` says.
fn rest(model: ModelKind, rig: &Rig) -> (Vec<f64>, [f64; 2]) {
    let loaded = model == ModelKind::Emulator || rig.motor_coupling;
    Plant::new(rig).rest_state(loaded)
}

/// A running FMU: its configuration, the parameters as set, the inputs, and after
/// initialisation the simulation.
pub struct Instance {
    config: Config,
    variables: Vec<Variable>,
    parameters: toml::Table,
    inputs: Vec<f64>,
    sim: Option<Sim>,
    start_s: f64,
}

/// The simulation behind an initialised instance.
enum Sim {
    /// The emulator with the article's PLC.
    Plc { run: Box<PlcLoop>, u: [f64; 2] },
    /// The emulator driven by the speed commands.
    Plant {
        dynamics: Box<Dynamics>,
        x: Vec<f64>,
    },
    /// The linear model.
    Linear(Box<Linear>),
}

/// The linear model in deviations from the operating point, its inputs [x_ref or ω_ref1,
/// ω_ref2, F_ext] held over each step.
struct Linear {
    layout: Layout,
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    /// The state deviation.
    z: DVector<f64>,
    /// The operating point's state (absolute), and its inputs.
    z_op: Vec<f64>,
    u_op: Vec<f64>,
    /// The controller ω_ref = Kx z + Kr r (deviations), article controller only.
    control: Option<(DMatrix<f64>, DMatrix<f64>)>,
    /// The speed commands (rad/s) that hold the operating point.
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
        let parameters = toml::Table::try_from(&config.rig).map_err(|e| FmuError(e.to_string()))?;
        let inputs = input_start(&config);
        Ok(Instance {
            config,
            variables,
            parameters,
            inputs,
            sim: None,
            start_s: 0.0,
        })
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
        if self.sim.is_some() {
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
        Rig::from_toml_str(&text, "the FMU's parameters").map_err(|e| FmuError(e.to_string()))
    }

    /// Check the parameters and start the simulation at `start_s` (s): the emulator at rest at
    /// the reference's start value (then run for the PLC's settling time, as `pumpcyl emulate`
    /// does), the linear model at its operating point.
    pub fn initialize(&mut self, start_s: f64) -> Result<(), FmuError> {
        if !start_s.is_finite() {
            return Err(FmuError(format!("start time {start_s}: must be finite")));
        }
        let rig = self.rig()?;
        let f_ext = *self.inputs.last().expect("f_ext_n is always an input");
        let rig = Rig {
            external_force_n: f_ext,
            ..rig
        };
        self.sim = Some(match self.config.model {
            ModelKind::Emulator => self.emulator(&rig)?,
            ModelKind::Linear => Sim::Linear(Box::new(Linear::new(&rig, self.config.controller)?)),
        });
        self.start_s = start_s;
        Ok(())
    }

    /// The emulator's effects: those of the parameters' rig (its `beta_bar` at its own mean
    /// pressure at rest, its `mass_by_position`; docs/emulator.md#what-a-user-rig-gets), or none.
    fn effects(&self) -> Result<crate::emulator::Effects, FmuError> {
        Ok(crate::emulator::Effects::switched(
            &self.rig()?,
            self.config.effects,
        )?)
    }

    fn emulator(&self, rig: &Rig) -> Result<Sim, FmuError> {
        let dynamics = Dynamics::new(rig, self.effects()?)?;
        Ok(match self.config.controller {
            Controller::Article => {
                let plc = Plc::ideal(PLC_RATE_HZ);
                let run = PlcLoop::settled(rig, &dynamics, &plc, self.inputs[0] * 1e3, SETTLE_S)?;
                Sim::Plc {
                    run: Box::new(run),
                    u: [0.0; 2],
                }
            }
            Controller::External => {
                let (x, _) = dynamics.operating_point(rig);
                Sim::Plant {
                    dynamics: Box::new(dynamics),
                    x,
                }
            }
        })
    }

    /// Advance from `t_s` by `h_s` (s), the inputs held. With the article's controller the
    /// emulator's PLC samples at its own rate (docs/fmu.md#sample-rate): a step that does not
    /// divide the PLC period is integrated in pieces, the commands changing only at the PLC's
    /// sample instants.
    pub fn do_step(&mut self, t_s: f64, h_s: f64) -> Result<(), FmuError> {
        if !(h_s.is_finite() && h_s > 0.0 && t_s.is_finite()) {
            return Err(FmuError(format!(
                "communication step {h_s} s at {t_s} s: must be finite and > 0"
            )));
        }
        let inputs = self.inputs.clone();
        let start = self.start_s;
        match self.sim.as_mut() {
            None => Err(FmuError("the FMU is not initialised".into())),
            Some(Sim::Plc { run, u }) => plc_step(run, u, &inputs, t_s - start, h_s),
            Some(Sim::Plant { dynamics, x }) => {
                dynamics.set_external_force_n(inputs[2]);
                *x = emulator::hold_speeds(dynamics, x, [inputs[0], inputs[1]], t_s, t_s + h_s)?;
                Ok(())
            }
            Some(Sim::Linear(lin)) => lin.step(&inputs, h_s),
        }
    }

    /// The outputs, in the order of [`variables`].
    fn outputs(&self) -> Result<Vec<f64>, FmuError> {
        let (layout, x, u): (&Layout, Vec<f64>, Option<[f64; 2]>) = match self.sim.as_ref() {
            None => return Err(FmuError("outputs are known after initialisation".into())),
            Some(Sim::Plc { run, u }) => (run.dynamics().layout(), run.state().to_vec(), Some(*u)),
            Some(Sim::Plant { dynamics, x }) => (dynamics.layout(), x.clone(), None),
            Some(Sim::Linear(lin)) => (&lin.layout, lin.absolute(), lin.commands(&self.inputs)),
        };
        let mut out = vec![
            x[layout.x],
            x[layout.v],
            x[layout.p[0]],
            x[layout.p[1]],
            x[layout.p[0]] + x[layout.p[1]],
            x[layout.w[0]],
            x[layout.w[1]],
        ];
        if let Some(tau) = layout.tau {
            out.extend([x[tau[0]], x[tau[1]]]);
        }
        if self.config.controller == Controller::Article {
            out.extend(u.unwrap_or([f64::NAN; 2]));
        }
        Ok(out)
    }
}

/// The emulator with the PLC from `t` (relative to the start) by `h` (s): at each PLC sample
/// instant in [t, t + h) the PLC reads the reference and sends new commands `u`.
fn plc_step(
    run: &mut PlcLoop,
    u: &mut [f64; 2],
    inputs: &[f64],
    t: f64,
    h: f64,
) -> Result<(), FmuError> {
    run.set_external_force_n(inputs[1]);
    let ts = run.period_s();
    let tol = 1e-9 * ts;
    let end = t + h;
    let mut now = t;
    while now < end - tol {
        let k = ((now + tol) / ts).floor();
        let sample_t = k * ts;
        let at_sample = (now - sample_t).abs() <= tol;
        if at_sample {
            *u = run.sample(inputs[0] * 1e3).1;
        }
        let next = sample_t + ts;
        let to = if next <= end + tol { next } else { end };
        run.hold(*u, if at_sample { sample_t } else { now }, to)?;
        now = to;
    }
    Ok(())
}

impl Linear {
    /// The linear model of `rig` with the article's controller closed around it, or open.
    fn new(rig: &Rig, controller: Controller) -> Result<Linear, FmuError> {
        let plant = Plant::new(rig);
        let l = plant.layout;
        let op = plant.operating_point();
        let (z_op, u_rest) = rest(ModelKind::Linear, rig);
        // the force enters Newton's law: v̇ = … − F_ext / m
        let mut force = DMatrix::zeros(l.n, 1);
        force[(l.v, 0)] = -1.0 / plant.si.mass;
        let (a, b_drive, control, u_op) = match controller {
            Controller::Article => {
                let (kx, kr) = plant.controller(rig.sum_pressure);
                let a = &plant.a + &plant.b * &kx;
                let b = &plant.b * &kr;
                (a, b, Some((kx, kr)), vec![op.x, rig.external_force_n])
            }
            Controller::External => (
                plant.a.clone(),
                plant.b.clone(),
                None,
                vec![u_rest[0], u_rest[1], rig.external_force_n],
            ),
        };
        crate::lti::require_stable(&a).or_else(|e| match controller {
            // the open plant has the position integrator; only the closed loop must be stable
            Controller::External => Ok(()),
            Controller::Article => Err(e),
        })?;
        let b = concat_columns(&b_drive, &force);
        Ok(Linear {
            layout: l,
            z: DVector::zeros(l.n),
            a,
            b,
            z_op,
            u_op,
            control,
            rest_commands: u_rest,
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

    /// The state, absolute.
    fn absolute(&self) -> Vec<f64> {
        self.z
            .iter()
            .zip(&self.z_op)
            .map(|(d, op)| d + op)
            .collect()
    }

    /// The controller's speed commands (rad/s, absolute) for the reference in `inputs`.
    fn commands(&self, inputs: &[f64]) -> Option<[f64; 2]> {
        let (kx, kr) = self.control.as_ref()?;
        let r = inputs[0] - self.u_op[0];
        let u = kx * &self.z + kr * r;
        // at rest the commands are those that hold the operating point
        Some([u[0] + self.rest_commands[0], u[1] + self.rest_commands[1]])
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

    /// The emulator FMU follows the `beta_bar` a host sets (docs/emulator.md#what-a-user-rig-gets):
    /// on a rig that shares no value with the article's, its step at 100 and 1000 bar equals the
    /// emulator run on the rig with that `beta_bar`, and the two differ.
    #[test]
    fn the_emulator_fmu_follows_the_beta_bar_a_host_sets() {
        let user = Rig::from_toml_str(
            "piston_diameter_mm = 80.0\nrod_diameter_mm = 45.0\nstroke_mm = 800.0\nx0_mm = 400.0\n\
             mass_kg = 2500.0\nmass_by_position = []\ndisplacement_1_cm3_per_rev = 8.0\n\
             displacement_2_cm3_per_rev = 5.0\nbeta_bar = 300.0\nkp = 15.0\n",
            "user.toml",
        )
        .unwrap();
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
        let got = run(&mut fmu, 300, 0.01, |_| rig.x0_mm + 5.0);
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
}
