//! `pumpcyl fmu`: the rig emulator or the linear model as an FMU (FMI 2.0 Co-Simulation,
//! Linux x86-64; docs/fmu.md).

use crate::emit::write_atomic;
use crate::RigSource;
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use pumpcyl::fmu::{Config, Controller, ModelKind};
use std::path::PathBuf;

/// The model inside the FMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FmuModel {
    /// The nonlinear rig emulator (docs/emulator.md).
    Emulator,
    /// The linear model (docs/model.md).
    Linear,
}

/// The linear model's position loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LoopKind {
    /// Closed by the article's controller: the input is the position reference.
    Closed,
    /// Open: the motor speed commands are the inputs.
    Open,
}

/// The emulator's controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ControllerKind {
    /// The article's, at the PLC's 100 Hz: the input is the position reference.
    Article,
    /// None: the motor speed commands are the inputs, for a controller of your own.
    External,
}

#[derive(Debug, Args)]
pub struct FmuArgs {
    /// The FMU file to write (FMI 2.0 Co-Simulation, Linux x86-64).
    #[arg(long, value_name = "FILE.fmu")]
    out: PathBuf,
    /// The model inside.
    #[arg(long, value_enum, default_value_t = FmuModel::Emulator)]
    model: FmuModel,
    /// Emulator: the article's controller, or the circuit's commands as inputs (motor speeds, a spool opening).
    #[arg(long, value_enum, default_value_t = ControllerKind::Article)]
    controller: ControllerKind,
    /// Linear model: the position loop closed, or open (the circuit's commands as inputs).
    #[arg(long = "loop", value_enum, default_value_t = LoopKind::Closed)]
    loop_kind: LoopKind,
    /// Emulator: every effect of docs/emulator.md off (the nonlinear model then linearises to
    /// the linear one).
    #[arg(long)]
    no_effects: bool,
    /// Emulator: integrate the power account with the states and add its energies since the
    /// start as outputs, energy_in_j, work_out_j, losses_j, stored_change_j
    /// (docs/fmu.md#energy; the steps take several times longer).
    #[arg(long)]
    energy: bool,
    /// Rig (TOML). Default: the emulated article rig for the emulator (as `pumpcyl emulate`),
    /// the article's rig for the linear model (as `pumpcyl step`).
    #[command(flatten)]
    source: RigSource,
}

/// `pumpcyl fmu`.
pub fn run(args: &FmuArgs) -> Result<String> {
    if args.out.extension().and_then(|e| e.to_str()) != Some("fmu") {
        bail!(
            "--out {}: an FMU file name ends in .fmu",
            args.out.display()
        );
    }
    let config = config(args)?;
    let bytes = pumpcyl_present::fmu::archive(&config)?;
    write_atomic(&args.out, &bytes)?;
    let vars = pumpcyl::fmu::variables(&config);
    let count = |c| vars.iter().filter(|v| v.causality == c).count();
    use pumpcyl::fmu::Causality::*;
    Ok(format!(
        "{}: FMI 2.0 Co-Simulation FMU ({}), {} inputs, {} outputs, {} parameters, {} bytes\n{}\n",
        args.out.display(),
        pumpcyl_present::fmu::description_of(&config),
        count(Input),
        count(Output),
        count(Parameter),
        bytes.len(),
        pumpcyl_present::fmu::emulator_basis(&config)?
    ))
}

/// The FMU's configuration from the options.
fn config(args: &FmuArgs) -> Result<Config> {
    let (model, controller, effects) = match args.model {
        FmuModel::Emulator => {
            if args.loop_kind == LoopKind::Open {
                bail!("--loop is the linear model's; the emulator takes --controller external");
            }
            let controller = match args.controller {
                ControllerKind::Article => Controller::Article,
                ControllerKind::External => Controller::External,
            };
            (ModelKind::Emulator, controller, !args.no_effects)
        }
        FmuModel::Linear => {
            if args.controller == ControllerKind::External || args.no_effects {
                bail!("--controller and --no-effects are the emulator's; the linear model takes --loop open");
            }
            let controller = match args.loop_kind {
                LoopKind::Closed => Controller::Article,
                LoopKind::Open => Controller::External,
            };
            (ModelKind::Linear, controller, false)
        }
    };
    let rig = match model {
        ModelKind::Emulator => crate::emulate::load_rig(&args.source, effects)?,
        ModelKind::Linear => args.source.load()?,
    };
    if args.energy && model == ModelKind::Linear {
        bail!("--energy is the emulator's: the linear model has no power account");
    }
    let config = pumpcyl::fmu::checked_config((model, controller), effects, args.energy, rig)?;
    Ok(config)
}
