//! `pumpcyl frf`: the frequency response of a sweep record with its coherence and 95 % band
//! (docs/identification.md#frequency-response-from-a-sweep), or the sweep to record (--design).

use crate::emit::write_atomic;
use crate::sweep::{design_for, excitation, SweepArgs, SweepKind};
use crate::RigSource;
use anyhow::{anyhow, Result};
use clap::Args;
use pumpcyl::frf::{self, Options};
use pumpcyl::record::Record;
use pumpcyl_present::frf::design_text;
use pumpcyl_present::request::frf::Frf;
use pumpcyl_present::request::RigInput;
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
    /// Print the sweep the designer proposes for the rig (band, amplitude, length) instead;
    /// with a RECORD.csv of a sweep on the rig, its averages follow from the record's coherence.
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
        let d = match &args.record {
            Some(path) => design_for_pilot(&rig, args.rate_hz, path)?,
            None => design_for(&rig, args.rate_hz)?,
        };
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
    if let Some(e) = &excitation {
        frf::check_matches(&rec, e)
            .map_err(|err| anyhow!("{err}{}", defaults_hint(args, e, &rec)))?;
    }
    let request = Frf {
        rig: RigInput {
            rig,
            name: args.source.origin(),
            defaulted: None,
        },
        record: rec,
        excitation,
        segment_s: args.segment_s,
    };
    let outcome = crate::emit::run(&request)?;
    if let Some(out) = &args.out {
        write_atomic(out, outcome.csv().as_bytes())?;
    }
    if let Some(figure) = &args.figure {
        write_atomic(figure, outcome.svg()?.as_bytes())?;
    }
    crate::emit::show(&outcome, args.json)
}

/// Where the described sweep `e` took the designer's values for absent options and the record
/// is not that sweep: the values taken, and the period and peak deviation the record's own
/// reference shows, so that the options it was emulated with can be given.
fn defaults_hint(args: &FrfArgs, e: &frf::Excitation, rec: &Record) -> String {
    let defaulted = args.amplitude_mm.is_none() || args.shape.band_defaulted();
    if !defaulted {
        return String::new();
    }
    let (from_hz, to_hz) = e.band_hz();
    let period = match e {
        frf::Excitation::Multisine { period_s, .. } => format!(" --period-s {period_s}"),
        _ => String::new(),
    };
    let shown = frf::find_period(rec).map_or(String::new(), |(_, len)| {
        let rate_hz = (rec.len() - 1) as f64 / (rec.time_s[rec.len() - 1] - rec.time_s[0]);
        let r0 = rec.x_ref_mm[0];
        let dev = rec
            .x_ref_mm
            .iter()
            .map(|r| (r - r0).abs())
            .fold(0.0, f64::max);
        format!(
            "; the record's reference repeats every {} s with a peak deviation of {dev:.3} mm",
            len as f64 / rate_hz
        )
    });
    format!(
        "; absent options took the designer's values for this rig: --from-hz {from_hz} --to-hz \
         {to_hz} --amplitude-mm {}{period}{shown}: give the options the record was emulated \
         with (a record emulated with --no-effects, another --rig or --set had another rig's \
         design)",
        e.amplitude_mm()
    )
}

/// The design for `rig` at `rate_hz` whose averages follow from the coherence of the sweep
/// record at `path` ([`frf::design_from_pilot`]): estimated as `frf` estimates an undescribed
/// record, its median coherence over the usable frequencies at its own peak deviation.
fn design_for_pilot(
    rig: &pumpcyl::rig::Rig,
    rate_hz: f64,
    path: &std::path::Path,
) -> Result<frf::Design> {
    let rec = Record::read_in(crate::read_files::files(), path)?;
    rec.check_units(rig.stroke_mm)?;
    let opts = Options {
        excitation: None,
        rig: Some(rig),
        segment_s: None,
    };
    let est = frf::estimate(&rec, &opts)?;
    let mut usable: Vec<f64> = (est.closed_loop.points.iter())
        .map(|p| p.coherence)
        .filter(|&c| c >= est.usable_coherence)
        .collect();
    usable.sort_by(f64::total_cmp);
    let r0 = rec.x_ref_mm[0];
    let pilot = frf::Pilot {
        coherence: usable[usable.len() / 2],
        amplitude_mm: rec
            .x_ref_mm
            .iter()
            .map(|r| (r - r0).abs())
            .fold(0.0, f64::max),
        settling_s: (est.periods_discarded * est.segment_samples) as f64 / est.rate_hz,
    };
    frf::design_from_pilot(rig, &crate::sweep::goal_at(rate_hz), &pilot)
        .map_err(|e| anyhow!("designing the sweep: {e}"))
}
