//! The time-domain commands: `step`, `track`, `simulate` (docs/simulation.md).

use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

use crate::emit::{format_of, run, show, write_atomic, Format};
use crate::RigSource;
use pumpcyl::record::Record;
use pumpcyl_present::figures::Chart;
use pumpcyl_present::request::time::{Replay, Step, Track};
use pumpcyl_present::request::RigInput;

/// Options shared by the time-domain commands.
#[derive(Debug, Args)]
pub struct TimeOptions {
    /// Output file: .csv (signals), .svg or .png (four-panel figure), .mat (signals and
    /// metrics for MATLAB/Octave, named as the CSV columns).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Print the metrics as JSON.
    #[arg(long)]
    json: bool,
    /// Overlay a variant: KEY=VALUE[,KEY=VALUE...] on top of the rig (repeatable), e.g.
    /// --compare feedforward=false --compare sum_pressure=false.
    #[arg(long, value_name = "KEY=VALUE[,...]")]
    compare: Vec<String>,
}

#[derive(Debug, Args)]
pub struct StepArgs {
    #[command(flatten)]
    rig: RigSource,
    /// Step size (mm), from the operating point x0.
    #[arg(long, default_value_t = 5.0, allow_negative_numbers = true)]
    step_mm: f64,
    /// Simulated duration (s).
    #[arg(long, default_value_t = 4.0, allow_negative_numbers = true)]
    duration_s: f64,
    /// Sample rate (Hz) of the reference and the output.
    #[arg(long, default_value_t = 100.0, allow_negative_numbers = true)]
    rate_hz: f64,
    #[command(flatten)]
    opts: TimeOptions,
}

#[derive(Debug, Args)]
pub struct TrackArgs {
    #[command(flatten)]
    rig: RigSource,
    /// Sine frequency (Hz).
    #[arg(
        long,
        required_unless_present = "article_cases",
        allow_negative_numbers = true
    )]
    freq_hz: Option<f64>,
    /// Sine amplitude (mm) about x0.
    #[arg(
        long,
        required_unless_present = "article_cases",
        allow_negative_numbers = true
    )]
    amp_mm: Option<f64>,
    /// Number of whole periods simulated, drawn and written (1 or more). The metrics are the
    /// periodic steady state: the loop starts from its own periodic solution, so every period
    /// is alike and no start-up transient enters them.
    #[arg(long, default_value_t = 3.0, allow_negative_numbers = true)]
    periods: f64,
    /// Sample rate (Hz).
    #[arg(long, default_value_t = 100.0, allow_negative_numbers = true)]
    rate_hz: f64,
    /// Run the article's three cases (0.1 Hz ±50 mm, 0.2 Hz ±35 mm, 0.25 Hz ±20 mm).
    #[arg(long, conflicts_with_all = ["freq_hz", "amp_mm"])]
    article_cases: bool,
    #[command(flatten)]
    opts: TimeOptions,
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    rig: RigSource,
    /// Record to replay (CSV, docs/formats.md#record-csv: time_s, x_ref_mm, x_mm; optional p1_bar, p2_bar,
    /// w1_rpm, w2_rpm).
    #[arg(
        long,
        value_name = "RECORD.csv",
        required_unless_present = "experiment"
    )]
    data: Option<PathBuf>,
    /// Replay a dataset of an `identify` experiment file with its own conditions: the file's
    /// rig and [set], the dataset's Kp, mass and fit window (--set applies on top).
    #[arg(long, value_name = "EXPERIMENT.toml", conflicts_with_all = ["data", "rig"], requires = "dataset")]
    experiment: Option<PathBuf>,
    /// Which [[dataset]] of --experiment to replay (1 = the first).
    #[arg(long, value_name = "N", requires = "experiment")]
    dataset: Option<usize>,
    /// End of the fit window on the record's time axis (s); default: the whole record (with
    /// --experiment: the dataset's fit_end_s).
    #[arg(long, allow_negative_numbers = true)]
    fit_end_s: Option<f64>,
    #[command(flatten)]
    opts: TimeOptions,
}

/// Write signals by the extension of `path`: the CSV `csv` makes, the MAT-file `mat` makes or
/// the figure `chart` makes (SVG or PNG).
fn write_signals(
    path: &Path,
    csv: impl FnOnce() -> String,
    mat: impl FnOnce() -> Vec<u8>,
    chart: impl FnOnce() -> Chart,
) -> Result<()> {
    match format_of(path, &[Format::Csv, Format::Svg, Format::Png, Format::Mat])? {
        Format::Csv => write_atomic(path, csv().as_bytes()),
        Format::Mat => write_atomic(path, &mat()),
        _ => crate::emit::render(path, &chart()),
    }
}

/// `pumpcyl step`.
pub fn step(args: &StepArgs) -> Result<String> {
    let request = Step {
        rig: args.rig.input()?,
        step_mm: args.step_mm,
        duration_s: args.duration_s,
        rate_hz: args.rate_hz,
        compare: args.opts.compare.clone(),
    };
    let outcome = run(&request)?;
    if let Some(path) = &args.opts.out {
        write_signals(path, || outcome.csv(), || outcome.mat(), || outcome.chart())?;
    }
    show(&outcome, args.opts.json)
}

/// `pumpcyl track`.
pub fn track(args: &TrackArgs) -> Result<String> {
    let waves = match (args.article_cases, args.freq_hz, args.amp_mm) {
        (false, Some(f), Some(a)) => vec![(f, a)],
        _ => Vec::new(),
    };
    let request = Track {
        rig: args.rig.input()?,
        waves,
        periods: args.periods,
        rate_hz: args.rate_hz,
        compare: args.opts.compare.clone(),
    };
    let outcome = run(&request)?;
    if let Some(path) = &args.opts.out {
        write_signals(path, || outcome.csv(), || outcome.mat(), || outcome.chart())?;
    }
    show(&outcome, args.opts.json)
}

/// `pumpcyl simulate`.
pub fn simulate(args: &SimulateArgs) -> Result<String> {
    let (record, rig, dataset_end) = replayed(args)?;
    let request = Replay {
        rig,
        record,
        fit_end_s: args.fit_end_s.or(dataset_end),
        own_conditions: args.experiment.is_some(),
        compare: args.opts.compare.clone(),
    };
    let outcome = run(&request)?;
    if let Some(path) = &args.opts.out {
        write_signals(path, || outcome.csv(), || outcome.mat(), || outcome.chart())?;
    }
    show(&outcome, args.opts.json)
}

/// The record to replay, the rig to replay it on and the dataset's fit window end (s): from
/// --data and the rig options, or from a dataset of --experiment with its own conditions.
fn replayed(args: &SimulateArgs) -> Result<(Record, RigInput, Option<f64>)> {
    let (Some(path), Some(n)) = (&args.experiment, args.dataset) else {
        let data = args
            .data
            .as_ref()
            .context("--data or --experiment is needed")?;
        return Ok((
            Record::read_in(crate::read_files::files(), data)?,
            args.rig.input()?,
            None,
        ));
    };
    let exp = crate::read_files::experiment(path)?;
    let count = exp.problem.datasets.len();
    anyhow::ensure!(
        (1..=count).contains(&n),
        "{}: --dataset {n}: the file has {count} dataset(s), numbered from 1",
        path.display()
    );
    let ds = &exp.problem.datasets[n - 1];
    let rig = ds.rig.with_overrides_from("--set", &args.rig.set)?;
    let name = format!(
        "{} dataset {n}: Kp {}, m {} kg, K_pres {} per bar",
        path.display(),
        rig.kp,
        rig.mass_kg,
        rig.k_pres_per_bar
    );
    let defaulted = exp.rig_defaulted_keys().map(<[_]>::to_vec);
    let rig = RigInput {
        rig,
        name,
        defaulted,
    };
    Ok((ds.record.clone(), rig, Some(ds.fit_end_s)))
}
