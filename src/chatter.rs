//! `pumpcyl chatter`: will a single-pump rig's valves switch between its modes on their own,
//! over a range of loads (docs/circuits.md#a-scan-of-the-load; the article §2.1).

use anyhow::{anyhow, Result};
use clap::Args;
use std::path::PathBuf;

use crate::emit::{format_of, render, show, write_atomic, Format};
use crate::RigSource;
use pumpcyl::emulator::chatter::{Forces, Wave, DEFAULT_POINTS};
use pumpcyl_present::chatter::Request as Scan;
use pumpcyl_present::request::chatter::Chatter;

#[derive(Debug, Args)]
pub struct ChatterArgs {
    #[command(flatten)]
    rig: RigSource,
    /// External force to run (N), repeatable: --force-n 100 --force-n 150. Default: 13 forces,
    /// the switching force and six each side, out to three times the valve band's reach on
    /// that side.
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        conflicts_with_all = ["from_n", "to_n", "points"]
    )]
    force_n: Vec<f64>,
    /// Lowest external force of an evenly spaced scan (N), with --to-n.
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        requires = "to_n"
    )]
    from_n: Option<f64>,
    /// Highest external force of an evenly spaced scan (N), with --from-n.
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        requires = "from_n"
    )]
    to_n: Option<f64>,
    /// Forces of the scan, evenly spaced from --from-n to --to-n (or, without them, over the
    /// default range about the switching force).
    #[arg(long, default_value_t = DEFAULT_POINTS)]
    points: usize,
    /// Wave run beside the 5 mm step at each force, FREQ_HZ:AMP_MM about x0 (repeatable), e.g.
    /// --wave 0.2:35: its switches in its last two periods are set against those its
    /// reference's own needed force explains.
    #[arg(long, value_parser = crate::design::parse_wave)]
    wave: Vec<(f64, f64)>,
    /// Run even when the scan would take more than 10^7 emulated controller steps (forces ×
    /// runs; minutes to hours of work).
    #[arg(long)]
    allow_long_run: bool,
    /// Print JSON (rig, circuit, verdict, answer, switching_force_n, valve_band_n,
    /// external_force_n, mode_at_rest, step_mm, waves, forces: external_force_n, mode_at_start,
    /// verdict, switches, switches_after_settling, switches_explained, extra_switches, step,
    /// waves; quiet_ranges_n, chattering_ranges_n, basis).
    #[arg(long)]
    json: bool,
    /// Output: .csv (one row a run at a force) or .svg / .png (the switches against the force,
    /// the switching force and the valve band marked).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
}

/// `pumpcyl chatter`.
pub fn run(args: &ChatterArgs) -> Result<String> {
    let format = match &args.out {
        Some(path) => Some(format_of(path, &[Format::Csv, Format::Svg, Format::Png])?),
        None => None,
    };
    let forces = match (args.from_n, args.to_n) {
        (Some(from_n), Some(to_n)) => Some(Forces::Range {
            from_n,
            to_n,
            points: args.points,
        }),
        _ if !args.force_n.is_empty() => Some(Forces::Given(args.force_n.clone())),
        _ if args.points != DEFAULT_POINTS => Some(Forces::AboutSwitching {
            points: args.points,
        }),
        _ => None,
    };
    let request = Chatter {
        rig: args.rig.input()?,
        scan: Scan {
            forces,
            waves: (args.wave.iter())
                .map(|&(freq_hz, amplitude_mm)| Wave {
                    freq_hz,
                    amplitude_mm,
                })
                .collect(),
        },
        allow_long_run: args.allow_long_run,
    };
    let outcome = crate::emit::run(&request)?;
    if let (Some(path), Some(format)) = (&args.out, format) {
        match format {
            Format::Csv => write_atomic(path, outcome.csv().as_bytes())?,
            _ => render(
                path,
                &(outcome.chart()).map_err(|e| anyhow!("{}: {e}", path.display()))?,
            )?,
        }
    }
    show(&outcome, args.json)
}
