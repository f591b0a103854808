//! `pumpcyl select`: which circuit, at which pressure level (docs/select.md; the article §4).

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

use crate::emit::{render_both, show, write_atomic};
use pumpcyl::rig::Rig;
use pumpcyl::select::{Application, RigFrom};
use pumpcyl_present::format::json_document;
use pumpcyl_present::request::select::{Evidence, Select};
use pumpcyl_present::request::Document;

#[derive(Debug, Args)]
pub struct SelectArgs {
    /// Application description (TOML, docs/formats.md#application-toml). Default: the
    /// embedded article application.
    #[arg(value_name = "APPLICATION.toml")]
    application: Option<PathBuf>,
    /// Rig description (TOML): the rig to select for, replacing the application's own (its
    /// [rig] table or `rig` file, with a note). Absent keys of the application that follow the
    /// rig (the gas fraction, from its beta at its mean chamber pressure, and the loads) follow
    /// this one. Default: the application's rig, else the article's.
    #[arg(long, value_name = "FILE.toml")]
    rig: Option<PathBuf>,
    /// Override an application key, or a rig key as rig.KEY: --set gas_fraction_max=0.1
    /// --set rig.kp=20 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// The circuits to try, comma-separated: dpm (at the low and the pressurised levels),
    /// dual-pump and single-pump (at each accumulator pre-charge, precharge_bar), valve (at each
    /// supply pressure, supply_bar). Default: the
    /// application's `circuits`, else every circuit the rig's components allow
    /// (docs/select.md#circuits).
    #[arg(long, value_delimiter = ',', value_name = "CIRCUIT,...")]
    circuits: Vec<String>,
    /// The single-pump candidates' mode check (docs/select.md#the-single-pump-circuit):
    /// emulator (the emulated 5 mm step and the application's waves, a noise-free PLC at
    /// 100 Hz; fails where the step switches after it settled or a wave switches more often
    /// than its reference's needed force explains) or equations (the circuit's equations under
    /// the continuous P law, a 5 mm step; fails on any switch).
    #[arg(long, value_name = "CHECK", default_value = "emulator")]
    mode_check: String,
    /// Fix the position gain (1/m) instead of designing the largest one at each candidate.
    #[arg(long, value_name = "KP")]
    kp: Option<f64>,
    /// Identification experiment (TOML, as for `identify`): its records' interval of beta,
    /// read at their mean chamber pressure, gives the gas-fraction range instead of the
    /// application's gas_fraction keys (docs/select.md#from-an-identification).
    #[arg(long, value_name = "EXPERIMENT.toml")]
    experiment: Option<PathBuf>,
    #[command(flatten)]
    confidence: crate::ConfidenceArg,
    /// Run even when the loads × pressure levels exceed 400 cases (each [[wave]] beyond the
    /// first adding 1/30 of a case), or the single-pump mode checks' emulated runs exceed the
    /// work of 10^7 calm controller steps (docs/select.md#work; a progress bar shows the cases
    /// on a terminal).
    #[arg(long)]
    allow_long_run: bool,
    /// Run each circuit that meets (its lowest meeting level, its largest gain) through the
    /// application's waves, two periods each, on the emulated rig: the cycle's energy, losses
    /// by kind and peak power per circuit, the cheapest, and what the chosen circuit costs
    /// against it and saves against the valve (docs/select.md#energy). Seconds per circuit.
    #[arg(long)]
    energy: bool,
    /// Print the application as commented TOML (with --set applied) and stop.
    #[arg(long)]
    print_default: bool,
    /// Result folder: result.json (as --json prints), options.csv (one row a candidate: its
    /// circuit, level, gain and velocity-loop gain, loss, mode-check numbers, verdict and reason) and select.svg/.png
    /// (the largest Kp and the tracking-error band against the pressure level, the
    /// requirement, the chosen level).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Print JSON (min_mean_pressure_bar, bisected between the levels, min_level_bar,
    /// chosen_circuit, verdict, reasons, rig, gas_fraction_from, options: circuit,
    /// circuit_kind, pressure_level, mean_pressure_bar,
    /// beta_e_bar, kp_max, kv_max_per_s, tracking_max_error_mm, standing_loss_w, meets, meets_best_case,
    /// margins_hold_at_reference_gas_fraction, mode_switches, switches_after_settling,
    /// oscillation_amplitude_mm, reason; mode_check).
    #[arg(long)]
    json: bool,
}

/// `pumpcyl select`.
pub fn run(args: &SelectArgs) -> Result<String> {
    let base = match &args.application {
        Some(path) => Application::from_file_in(crate::read_files::files(), path)?,
        None => Application::default(),
    };
    let base = match &args.rig {
        Some(path) => with_rig_file(&base, path)?,
        None => base,
    };
    let confidence = args.confidence.confidence;
    let evidence = (args.experiment.as_deref())
        .map(|p| Evidence::new(confidence, || crate::read_files::experiment(p)))
        .transpose()?;
    let request = Select {
        application: base.with_overrides("--set", &args.set)?,
        origin: (args.application.as_ref()).map_or("the article's application".into(), |p| {
            p.display().to_string()
        }),
        circuits: args.circuits.clone(),
        mode_check: args.mode_check.clone(),
        kp: args.kp,
        evidence,
        allow_long_run: args.allow_long_run,
        energy: args.energy,
    };
    if args.print_default {
        return Ok(request.application()?.to_commented_toml());
    }
    let outcome = crate::emit::run(&request)?;
    if let Some(dir) = &args.out {
        let document = json_document(&outcome.json()?)?;
        let folder = crate::emit::out_dir(dir)?;
        write_atomic(&folder.path().join("result.json"), document.as_bytes())?;
        render_both(&folder.path().join("select"), &outcome.chart())?;
        write_atomic(&folder.path().join("options.csv"), outcome.csv().as_bytes())?;
        crate::emit::commit(folder, dir)?;
    }
    show(&outcome, args.json)
}

/// `app` on the rig of the file `path` (`--rig`), naming the application's own rig it replaces.
fn with_rig_file(app: &Application, path: &std::path::Path) -> Result<Application> {
    let rig = Rig::from_file_in(crate::read_files::files(), path)
        .map_err(|e| crate::emit::hinted(e.into()))?;
    let replaces = match app.rig_from {
        RigFrom::Article => None,
        ref own => Some(own.describe()),
    };
    let from = RigFrom::Given {
        name: format!("{} (--rig)", path.display()),
        replaces,
    };
    app.with_rig(rig, from)
        .map_err(|e| anyhow::anyhow!("--rig {}: {e}", path.display()))
}
