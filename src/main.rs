//! The `pumpcyl` command line (`pumpcyl --help`): argument parsing, progress, signal handling
//! and showing results; the numerics are in the core crate (`pumpcyl`) and every document and
//! figure in `pumpcyl-present` (docs/architecture.md).

// The doc comments of the argument structs are the `--help` text clap prints, written for a
// terminal (`[[step]]`, `[A,B,C,D]`), not rustdoc links.
#![allow(rustdoc::broken_intra_doc_links)]

mod advise;
mod analysis;
mod bulk;
mod chatter;
mod cycle;
mod design;
mod emit;
mod emulate;
mod export;
mod fmu;
mod frf;
mod ident;
mod interrupt;
mod read_files;
mod reproduce;
mod select;
mod serve;
mod sweep;
mod time;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

use pumpcyl::loops::Loop;
use pumpcyl::rig::Rig;
use pumpcyl_present::request::{FieldError, RigInput};

/// pumpcyl — model, analyse, identify and design pump-controlled hydraulic cylinders.
///
/// The default rig is the dual-prime-mover cylinder of Gøytil, Hansen & Tvilde, Actuators 2025,
/// 14(8), 366. Units are part of every key and column name (SI inside).
#[derive(Debug, Parser)]
#[command(name = "pumpcyl", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Write over what pumpcyl otherwise leaves alone: a read-only output file, a file of
    /// yours at a path of a result folder, a non-empty folder that holds no earlier result
    /// (its other files are kept either way; docs/formats.md#result-folders). Inputs are never
    /// written over.
    #[arg(long, global = true)]
    force: bool,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Print a rig description as commented TOML (the embedded default, or a file with --set
    /// overrides applied), ready to copy and edit.
    Rig(RigArgs),
    /// Gain, phase and delay margins of the position loop (docs/analysis.md#margins), every crossing, and
    /// closed-loop stability from the closed-loop eigenvalues.
    Margins(analysis::MarginsArgs),
    /// Bode diagram (magnitude dB, unwrapped phase deg) of the position open loop, as CSV or SVG,
    /// optionally overlaying variants.
    Bode(analysis::BodeArgs),
    /// Open- and closed-loop poles with natural frequency (Hz) and damping ratio.
    Poles(analysis::PolesArgs),
    /// The open- or closed-loop state-space model (A, B, C, D and state names, SI), also as a
    /// MATLAB/Octave function, MAT-file or grey-box model function.
    Model(analysis::ModelCmdArgs),
    /// Closed-loop response to a position step (docs/simulation.md#step-metrics): rise, overshoot, settling, with
    /// position, error, pressures and motor speeds.
    Step(time::StepArgs),
    /// Sinusoidal tracking (docs/simulation.md#tracking-metrics): maximum and RMS error and wave reduction.
    Track(time::TrackArgs),
    /// Replay a recorded reference (docs/formats.md#record-csv) through the model and compare with the
    /// measured response (position MSE in mm²).
    Simulate(time::SimulateArgs),
    /// Chamber leakages c1, c2 from a standstill point for a given c12 (the article §2.4).
    Leakage(ident::LeakageArgs),
    /// Drive velocity-loop gain Km from a motor velocity step (the article §2.4.1).
    IdentifyDrive(ident::DriveArgs),
    /// Two-stage grid identification of beta, b and c12 from records (the article §2.4).
    Identify(ident::IdentifyArgs),
    /// Which further record (a step, a sinusoid, a gain) would narrow the intervals of beta,
    /// b and c12 most, from the linearised model (docs/identification.md, "Experiment advice").
    Advise(advise::AdviseArgs),
    /// Merge the partial results of `identify --shard I/N` into the answer of one run.
    IdentifyMerge(ident::MergeArgs),
    /// Gas fraction from an identified bulk modulus, beta_e against mean pressure, and the
    /// margins at each pressure (docs/bulk-modulus.md).
    BulkModulus(bulk::BulkArgs),
    /// The design method (the article §2.2) for a rig before it is built: the largest Kp meeting margin targets, margins
    /// across stroke, mass and pressure, predicted tracking, and a verdict.
    Design(design::DesignArgs),
    /// Which circuit, at which pressure level (the article §4): for an application, each
    /// candidate circuit and pressure level over the undissolved air's range — largest Kp,
    /// tracking error, standing cost — and the lowest pressure that meets the requirement.
    Select(select::SelectArgs),
    /// Will it chatter (docs/circuits.md#a-scan-of-the-load): a single-pump rig's emulated 5 mm
    /// step, and any --wave, at each of a range of external forces; the mode switches at each,
    /// those its step's transient and its waves' references explain, the quiet force ranges,
    /// the switching force and its valve band, and a verdict. Other circuits have no modes.
    Chatter(chatter::ChatterArgs),
    /// A duty cycle on the emulated rig (docs/energy.md#duty-cycles): the article's three
    /// sines, a step sequence or a profile's file (position and force over time); the energy
    /// drawn, returned and lost by kind, the load's work and the efficiency, and each motor's
    /// RMS and peak torque and speed against its ratings, a motor too small named.
    Cycle(cycle::CycleArgs),
    /// Records from the nonlinear rig emulator (docs/formats.md#record-csv): a step, a sinusoid, a standstill
    /// or a drive step, or every embedded article record with --article-records.
    Emulate(emulate::EmulateArgs),
    /// Frequency response of a sweep record (docs/identification.md#frequency-response-from-a-sweep):
    /// x/x_ref and the plant with coherence and a 95 % band, as a table, JSON, CSV or a Bode
    /// figure; or the sweep to record on a rig (--design).
    Frf(frf::FrfArgs),
    /// The rig emulator or the linear model as an FMU (FMI 2.0 Co-Simulation, Linux x86-64)
    /// for Simulink, Dymola, OpenModelica, Hopsan or any FMI tool (docs/fmu.md).
    Fmu(fmu::FmuArgs),
    /// The article's whole workflow on the embedded rig and emulated records: figures, a
    /// summary.json and a self-contained report.html in one folder.
    Reproduce(reproduce::ReproduceArgs),
    /// The designer: a local page where the rig's fields and sliders move the margins, the
    /// Bode diagram, the step, the poles and β_e against pressure live, every number the
    /// command line's own (docs/serve.md); on 127.0.0.1 unless asked otherwise.
    Serve(serve::ServeArgs),
}

#[derive(Debug, Args)]
struct RigArgs {
    /// Print the embedded default rig (the article's, §2.1).
    #[arg(long, conflicts_with_all = ["rig", "set"])]
    print_default: bool,
    /// Rig description to read and print back (validated, with --set applied).
    #[arg(long, value_name = "FILE.toml")]
    rig: Option<PathBuf>,
    /// Override a rig key: --set beta_bar=37.8 (repeatable; same keys as the TOML).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
}

/// The confidence level of what `--experiment`'s records give (an interval or a region),
/// checked in (0, 1) before any work.
#[derive(Debug, Clone, Copy, Args)]
pub struct ConfidenceArg {
    /// Confidence level of the interval or region read off the --experiment records, in (0, 1).
    #[arg(
        long,
        default_value_t = 0.95,
        requires = "experiment",
        allow_negative_numbers = true
    )]
    pub(crate) confidence: f64,
}

/// A rig: the embedded default or a file, with `--set` overrides.
#[derive(Debug, Clone, Args)]
pub struct RigSource {
    /// Rig description (TOML). Default: the embedded article rig.
    #[arg(long, value_name = "FILE.toml")]
    pub(crate) rig: Option<PathBuf>,
    /// Override a rig key: --set beta_bar=37.8 (repeatable; same keys as the TOML).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub(crate) set: Vec<String>,
}

impl RigSource {
    /// The rig: file or default, with --set applied. The keys a file leaves out are noted on
    /// standard error (docs/formats.md#rig-toml) and in a JSON result's `rig_defaulted_keys`.
    pub fn load(&self) -> Result<Rig> {
        Ok(self.input()?.rig)
    }

    /// The rig as a request runs on it: file or default with --set applied, named by where it
    /// came from ([`RigSource::origin`]), with the keys its file left out (noted on standard
    /// error, docs/formats.md#rig-toml).
    pub fn input(&self) -> Result<RigInput> {
        let Some(path) = &self.rig else {
            let rig = Rig::default().with_overrides_from("--set", &self.set)?;
            return Ok(RigInput {
                rig,
                name: self.origin(),
                defaulted: None,
            });
        };
        let file = Rig::from_file_with_defaults_in(crate::read_files::files(), path)
            .map_err(|e| crate::emit::hinted(e.into()))?;
        let rig = file.rig.with_overrides_from("--set", &self.set)?;
        let set: Vec<&str> = (self.set.iter())
            .filter_map(|a| a.split_once('=').map(|(k, _)| k.trim()))
            .collect();
        let name = path.display().to_string();
        let file = file.with_rig(rig.clone(), &name)?;
        crate::read_files::note_rig_defaults(&file, &name, &set);
        let defaulted = (file.defaulted.iter().copied())
            .filter(|k| !set.contains(k))
            .collect();
        Ok(RigInput {
            rig,
            name: self.origin(),
            defaulted: Some(defaulted),
        })
    }

    /// Where the rig came from, in words.
    pub fn origin(&self) -> String {
        self.origin_or("default rig")
    }

    /// Where the rig came from, `default` naming the rig used without --rig.
    pub fn origin_or(&self, default: &str) -> String {
        let file = self
            .rig
            .as_ref()
            .map_or(default.to_string(), |p| p.display().to_string());
        if self.set.is_empty() {
            file
        } else {
            format!("{file}, {}", self.set.join(" "))
        }
    }
}

/// Where the analysed model comes from: a rig (default, file, overrides) or a JSON model.
#[derive(Debug, Clone, Args)]
pub struct ModelArgs {
    #[command(flatten)]
    source: RigSource,
    /// Analyse a SISO continuous state-space model from JSON ({"A","B","C","D"}) instead of a
    /// rig: the model is taken as the loop transfer L(s).
    #[arg(long, value_name = "MODEL.json", conflicts_with_all = ["rig", "set"])]
    ss: Option<PathBuf>,
    /// Keep the sum-pressure loop closed inside the analysed position loop (the article §2.3.3 opens it).
    #[arg(long, conflicts_with = "ss")]
    sum_pressure_closed: bool,
}

impl ModelArgs {
    /// Build the analysed loop, with extra overrides (for --compare).
    fn build(&self, extra: &[String]) -> Result<Loop> {
        if let Some(path) = &self.ss {
            return read_ss(path);
        }
        let rig = self.source.load()?.with_overrides_from("--set", extra)?;
        Ok(Loop::of_rig(
            rig,
            &self.source.origin(),
            self.sum_pressure_closed,
        ))
    }
}

/// Read a `--ss` JSON model; errors name the file, line and key.
fn read_ss(path: &std::path::Path) -> Result<Loop> {
    let name = path.display().to_string();
    pumpcyl::source_files::read_text(crate::read_files::files(), path)
        .and_then(|text| Loop::from_json(&text, &name))
        .map_err(|e| anyhow::anyhow!("{name}: {e}"))
}

/// A message with every control character (from file names, keys or values a user wrote)
/// shown escaped, so an error stays one line and cannot move the terminal's cursor.
pub fn escape_controls(message: &str) -> String {
    message
        .chars()
        .flat_map(|c| {
            let escaped: Vec<char> = if c.is_control() {
                c.escape_default().collect()
            } else {
                vec![c]
            };
            escaped
        })
        .collect()
}

/// Parse the command line and run it.
pub fn run() -> Result<()> {
    interrupt::install();
    let matches = <Cli as clap::CommandFactory>::command().get_matches();
    let cli =
        <Cli as clap::FromArgMatches>::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    emit::set_force(cli.force);
    emit::check_distinct_outputs(&matches)?;
    if let Command::Serve(args) = &cli.command {
        return serve::run(args);
    }
    let text = dispatch(cli.command)?;
    if let Some(note) = read_files::rig_defaults_note() {
        eprintln!("note: {}", escape_controls(&note));
    }
    emit::emit(&text)
}

/// Run one command, its document or text as the command line prints it.
fn dispatch(command: Command) -> Result<String> {
    let text = match command {
        Command::Rig(args) => {
            let rig = if args.print_default {
                Rig::default()
            } else {
                RigSource {
                    rig: args.rig,
                    set: args.set,
                }
                .load()?
            };
            rig.to_commented_toml()
        }
        Command::Margins(args) => analysis::margins(&args)?,
        Command::Bode(args) => analysis::bode(&args)?,
        Command::Poles(args) => analysis::poles(&args)?,
        Command::Model(args) => analysis::model(&args)?,
        Command::Step(args) => time::step(&args)?,
        Command::Track(args) => time::track(&args)?,
        Command::Simulate(args) => time::simulate(&args)?,
        Command::Leakage(args) => ident::leakage(&args)?,
        Command::IdentifyDrive(args) => ident::drive(&args)?,
        Command::Identify(args) => ident::identify(&args)?,
        Command::IdentifyMerge(args) => ident::merge(&args)?,
        Command::Advise(args) => advise::run(&args)?,
        Command::BulkModulus(args) => bulk::bulk(&args)?,
        Command::Design(args) => design::run(&args)?,
        Command::Select(args) => select::run(&args)?,
        Command::Chatter(args) => chatter::run(&args)?,
        Command::Cycle(args) => cycle::run(&args)?,
        Command::Emulate(args) => emulate::run(&args)?,
        Command::Frf(args) => frf::run(&args)?,
        Command::Fmu(args) => fmu::run(&args)?,
        Command::Reproduce(args) => reproduce::run(&args)?,
        Command::Serve(_) => anyhow::bail!("serve runs a server, not a command of the page"),
    };
    // the last line of defence: a result is never printed with a value that is not a number
    anyhow::ensure!(
        !text
            .split(|c: char| !c.is_alphanumeric())
            .any(|w| w == "NaN"),
        "the result holds a value that is not a number (NaN): the inputs take the model beyond \
         what double precision can evaluate"
    );
    Ok(text)
}

/// An error as the command line says it: each cause after the one it explains (as `{:#}`), an
/// option out of range named as the user typed it (`--step-mm 0: ...`).
fn message(e: &anyhow::Error) -> String {
    let parts: Vec<String> = (e.chain())
        .map(|cause| match cause.downcast_ref::<FieldError>() {
            Some(field) => field.on_command_line(),
            None => cause.to_string(),
        })
        .collect();
    parts.join(": ")
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {}", escape_controls(&message(&e)));
        std::process::exit(1);
    }
}
