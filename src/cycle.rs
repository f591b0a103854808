//! `pumpcyl cycle`: a duty cycle on the emulated rig — its energy drawn, returned and lost by
//! kind, the load's work and the efficiency, and each motor against its ratings
//! (docs/energy.md#duty-cycles).

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

use crate::emit::{format_of, show, write_atomic, Format};
use crate::RigSource;
use pumpcyl_present::request::cycle::{CycleKind, CycleRequest};

#[derive(Debug, Args)]
pub struct CycleArgs {
    #[command(flatten)]
    rig: RigSource,
    /// The cycle: `article-sines` (the article's 0.10 Hz 50 mm, 0.20 Hz 35 mm and 0.25 Hz 20 mm
    /// sines about x0, two periods each), `steps` (x0, x0 + a, x0, x0 − a, x0, each held
    /// --hold-s) or a profile's file (CSV or MAT: `time_s`, `x_ref_mm` and, if the force
    /// changes, `external_force_n`; docs/formats.md#duty-cycle-csv).
    #[arg(long, value_name = "CYCLE", default_value = "article-sines")]
    cycle: String,
    /// The steps' size a (mm).
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 20.0,
        allow_negative_numbers = true
    )]
    step_mm: f64,
    /// How long `steps` holds each level (s).
    #[arg(long, value_name = "S", default_value_t = 2.0)]
    hold_s: f64,
    /// Seed of the PLC's sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Noise-free, unquantised sensors.
    #[arg(long)]
    no_noise: bool,
    /// Switch every emulator effect off.
    #[arg(long)]
    no_effects: bool,
    /// Run even beyond the emulator's work limit.
    #[arg(long)]
    allow_long_run: bool,
    /// Print JSON (rig, circuit, cycle, summary: drawn_j, regenerated_j, net_j, work_out_j,
    /// load_work_j, losses_j, stored_change_j, efficiency, mean_power_w, peak_power_w;
    /// energy: the account by kind; drives: rms/peak torque and speed against the ratings,
    /// exceeds; defaults_assumed; warnings).
    #[arg(long)]
    json: bool,
    /// The cycle's record with its power columns (CSV; docs/formats.md#power-columns).
    #[arg(long, value_name = "RECORD.csv")]
    out: Option<PathBuf>,
}

/// `pumpcyl cycle`.
pub fn run(args: &CycleArgs) -> Result<String> {
    if let Some(path) = &args.out {
        format_of(path, &[Format::Csv])?;
    }
    let cycle = CycleKind::named(&args.cycle, args.step_mm, args.hold_s);
    let request = CycleRequest {
        rig: crate::emulate::load_input(&args.rig, !args.no_effects)?,
        cycle,
        effects: !args.no_effects,
        noise: !args.no_noise,
        seed: args.seed,
        allow_long_run: args.allow_long_run,
        files: crate::read_files::files(),
    };
    let outcome = crate::emit::run(&request)?;
    if let Some(path) = &args.out {
        write_atomic(path, outcome.csv().as_bytes())?;
    }
    show(&outcome, args.json)
}
