//! `pumpcyl frf`: the frequency response of a sweep record with its coherence and 95 % band
//! (docs/identification.md#frequency-response-from-a-sweep), or the sweep to record (--design).

use crate::emit::write_atomic;
use crate::sweep::{design_for, excitation, SweepArgs, SweepKind};
use crate::RigSource;
use anyhow::{anyhow, Result};
use clap::Args;
use pumpcyl::frf::{self, Options};
use pumpcyl::record::Record;
use pumpcyl_present::frf::{design_text, frf_csv, frf_json, frf_svg, frf_text};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct FrfArgs {
    /// Record of a sweep (docs/formats.md#record-csv), sampled uniformly.
    #[arg(value_name = "RECORD.csv", required_unless_present = "design")]
    record: Option<PathBuf>,
    /// Rig (TOML): its loop's crossover is checked, its model is drawn beside the estimate, its
    /// gains give the plant's response. Default: the emulated article rig, as `emulate`'s.
    #[command(flatten)]
    source: RigSource,
    /// The sweep that made the record (checked against its reference): a periodic sweep is
    /// then averaged over its periods, a stepped sine fitted level by level. Without it:
    /// Welch's estimate over the excited band.
    #[arg(long, value_enum)]
    sweep: Option<SweepKind>,
    /// The sweep's amplitude (mm), as emulated. Default: the designer's.
    #[arg(
        long,
        value_name = "MM",
        requires = "sweep",
        allow_negative_numbers = true
    )]
    amplitude_mm: Option<f64>,
    /// The sweep's start (s), as emulated.
    #[arg(long, value_name = "S", default_value_t = 0.5, requires = "sweep")]
    at_s: f64,
    #[command(flatten)]
    shape: SweepArgs,
    /// Welch: segment length (s). Default: an eighth of the record with half overlap, at
    /// least four periods of the sweep's lowest frequency.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    segment_s: Option<f64>,
    /// Print the sweep the designer proposes for the rig (band, amplitude, length) instead.
    #[arg(long, conflicts_with_all = ["sweep", "out", "figure"])]
    design: bool,
    /// The sample rate the designed sweep is recorded at (Hz).
    #[arg(long, value_name = "HZ", default_value_t = 100.0, requires = "design")]
    rate_hz: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    /// Write the estimate as CSV (docs/formats.md#frf-outputs).
    #[arg(long, value_name = "FILE.csv")]
    out: Option<PathBuf>,
    /// Write the Bode figure of the estimate with its band and the model (SVG).
    #[arg(long, value_name = "FILE.svg")]
    figure: Option<PathBuf>,
}

/// `pumpcyl frf`.
pub fn run(args: &FrfArgs) -> Result<String> {
    let rig = crate::emulate::load_rig(&args.source, true)?;
    if args.design {
        let d = design_for(&rig, args.rate_hz)?;
        return Ok(if args.json {
            pumpcyl_present::format::json_document(&d)?
        } else {
            design_text(&d)
        });
    }
    let path = args
        .record
        .as_ref()
        .ok_or_else(|| anyhow!("a RECORD.csv is needed"))?;
    if let (Some(out), Some(figure)) = (&args.out, &args.figure) {
        anyhow::ensure!(
            out != figure,
            "{}: named by --out and --figure; one file cannot hold both outputs, give two paths",
            out.display()
        );
    }
    // read through the command's inputs, so no output is written over the record
    let rec = Record::read_in(crate::read_files::files(), path)?;
    rec.check_units(rig.stroke_mm)?;
    let rate_hz = (rec.len() - 1) as f64 / (rec.time_s[rec.len() - 1] - rec.time_s[0]);
    let excitation = args
        .sweep
        .map(|k| {
            excitation(
                k,
                args.amplitude_mm,
                args.at_s,
                &args.shape,
                (&rig, rate_hz),
            )
        })
        .transpose()?;
    let opts = Options {
        excitation,
        rig: Some(&rig),
        segment_s: args.segment_s,
    };
    let est = frf::estimate(&rec, &opts)?;
    let model = pumpcyl_present::frf::rig_model_curve(&rig, &est, &args.source.origin())?;
    if let Some(out) = &args.out {
        write_atomic(out, frf_csv(&est, Some(&model)).as_bytes())?;
    }
    if let Some(figure) = &args.figure {
        let svg = frf_svg(&est, Some(&model)).map_err(|e| anyhow!(e))?;
        write_atomic(figure, svg.as_bytes())?;
    }
    if args.json {
        return Ok(pumpcyl_present::format::json_document(&frf_json(
            &est,
            Some(&model),
        ))?);
    }
    Ok(frf_text(&est))
}
