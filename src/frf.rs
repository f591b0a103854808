//! `pumpcyl frf`: the frequency response of a sweep record with its coherence and 95 % band
//! (docs/identification.md#frequency-response-from-a-sweep), and the sweep options `pumpcyl
//! emulate` shares to make such a record.

use crate::emit::write_atomic;
use crate::RigSource;
use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
use pumpcyl::frf::{self, Design, DesignGoal, Estimate, Excitation, Options};
use pumpcyl::model::Plant;
use pumpcyl::record::Record;
use pumpcyl::rig::Rig;
use pumpcyl_present::frf::{design_text, frf_csv, frf_json, frf_svg, frf_text, ModelCurve};
use std::path::PathBuf;

/// The sweeps pumpcyl can emulate and describe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SweepKind {
    /// Logarithmic chirp, faded in and out, played --periods times.
    Chirp,
    /// Multisine with Schroeder phases on the grid of its period (1/--from-hz).
    Multisine,
    /// One sine after another, log-spaced, settling then --periods whole periods each.
    SteppedSine,
}

/// How a sweep is shaped (`emulate --experiment chirp|multisine|stepped-sine`, `frf --sweep`).
/// Absent band limits come from the sweep designer (`pumpcyl frf --design`).
#[derive(Debug, Clone, Args)]
pub struct SweepArgs {
    /// Sweep: lowest frequency (Hz). Default: the designer's (a tenth of the loop's crossover).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    from_hz: Option<f64>,
    /// Sweep: highest frequency (Hz). Default: the designer's (past the hydraulic resonance).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    to_hz: Option<f64>,
    /// Chirp: the length of one sweep (s). Default: 10 periods of --from-hz.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    sweep_s: Option<f64>,
    /// Sweeps of a chirp, periods of a multisine (the first settles) or periods fitted per
    /// frequency of a stepped sine. Default: 3, 24 (for ε = 5 % at coherence 0.9), 4.
    #[arg(long)]
    periods: Option<usize>,
    /// Multisine: its lines.
    #[arg(long, default_value_t = 30)]
    lines: usize,
    /// Stepped sine: its frequencies.
    #[arg(long, default_value_t = 12)]
    levels: usize,
    /// Stepped sine: periods discarded at each frequency (at least the loop's transient decay
    /// is discarded in any case).
    #[arg(long, default_value_t = 2)]
    settle_periods: usize,
}

/// The sweep asked for on `rig`, starting at `at_s`, for a record at `rate_hz`, checked.
pub(crate) fn excitation(
    kind: SweepKind,
    amplitude_mm: Option<f64>,
    at_s: f64,
    args: &SweepArgs,
    (rig, rate_hz): (&Rig, f64),
) -> Result<Excitation> {
    let (band, amplitude_mm) = match (args.from_hz, args.to_hz, amplitude_mm) {
        (Some(lo), Some(hi), Some(a)) => ((lo, hi), a),
        _ => {
            let d = design_for(rig, rate_hz)?;
            (
                (
                    args.from_hz.unwrap_or(d.from_hz),
                    args.to_hz.unwrap_or(d.to_hz),
                ),
                amplitude_mm.unwrap_or(d.amplitude_mm),
            )
        }
    };
    let e = match kind {
        SweepKind::Chirp => Excitation::chirp(
            rig,
            amplitude_mm,
            band,
            (
                args.sweep_s.unwrap_or(10.0 / band.0),
                args.periods.unwrap_or(3),
            ),
            rate_hz,
        ),
        SweepKind::Multisine => Excitation::multisine(
            rig,
            amplitude_mm,
            band,
            (
                args.lines,
                args.periods
                    .unwrap_or(frf::design::averages_for(0.9, 0.05) + 1),
            ),
            rate_hz,
        ),
        SweepKind::SteppedSine => {
            let decay_s = pumpcyl::response::transient_decay_s(rig).unwrap_or(0.0);
            Excitation::stepped_sine(
                rig,
                amplitude_mm,
                band,
                (args.levels, args.periods.unwrap_or(4)),
                (args.settle_periods, decay_s),
            )
        }
    }
    .starting_at(at_s);
    e.check(rate_hz, rig)
        .map_err(|err| crate::emit::as_option(err, option_of))?;
    Ok(e)
}

/// The option that sets a sweep's field.
pub(crate) fn option_of(field: &str) -> &str {
    match field {
        "from_hz" => "from-hz",
        "to_hz" => "to-hz",
        "amplitude_mm" => "amplitude-mm",
        "duration_s" => "sweep-s",
        "sweeps" | "periods" => "periods",
        "settle_periods" => "settle-periods",
        "start_s" => "at-s",
        "rate_hz" => "rate-hz",
        other => other,
    }
}

/// The designer's sweep for `rig` at `rate_hz`.
fn design_for(rig: &Rig, rate_hz: f64) -> Result<Design> {
    let goal = DesignGoal {
        rate_hz,
        ..DesignGoal::default()
    };
    frf::design(rig, &goal).map_err(|e| anyhow!("designing the sweep: {e}"))
}

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
    let rec = Record::read(path)?;
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
    let model = model_curve(&rig, &est, &args.source.origin())?;
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

/// The rig's closed loop at the estimate's frequencies, its reference held between samples as
/// the record's is, its phase unwrapped beside the estimate's.
fn model_curve(rig: &Rig, est: &Estimate, origin: &str) -> Result<ModelCurve> {
    let sys = Plant::new(rig).closed_loop(rig.sum_pressure);
    let points = &est.closed_loop.points;
    let freqs: Vec<f64> = points.iter().map(|p| p.freq_hz).collect();
    let h = frf::model_response(&sys, &freqs, Some(est.rate_hz))?;
    Ok(ModelCurve {
        label: format!("model x/x_ref ({origin})"),
        magnitude_db: h.iter().map(|h| 20.0 * h.norm().log10()).collect(),
        phase_deg: points
            .iter()
            .zip(&h)
            .map(|(p, h)| p.phase_deg + (h / p.h()).arg().to_degrees())
            .collect(),
    })
}
