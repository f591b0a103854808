//! The time-domain commands: `step`, `track`, `simulate` (docs/simulation.md).

use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

use crate::emit::{format_of, write_atomic, Format};
use crate::RigSource;
use pumpcyl::record::Record;
use pumpcyl::response::{self, Baseline, Signals, ARTICLE_SINE_CASES};
use pumpcyl::rig::Rig;
use pumpcyl_present::documents;
use pumpcyl_present::figures::Chart;
use pumpcyl_present::format::json_document;
use pumpcyl_present::time::{
    series, signals_csv, simulate_json, simulate_mat, simulate_series, simulate_subtitle,
    simulate_text, simulate_title, step_mat, step_subtitle, step_text, step_title, track_chart,
    track_json, track_mat, track_series, track_text, Replay, Run, Runs, StepSetup, Unstable,
};

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

/// The nominal rig and each `--compare` variant, labelled.
fn variants(rig: &Rig, compare: &[String]) -> Result<Vec<(String, Rig)>> {
    let mut out = vec![("nominal".to_string(), rig.clone())];
    for c in compare {
        let overrides: Vec<String> = c.split(',').map(|s| s.trim().to_string()).collect();
        let v = rig
            .with_overrides_from("--set", &overrides)
            .with_context(|| format!("--compare {c}"))?;
        out.push((c.clone(), v));
    }
    Ok(out)
}

/// Run `f` (signals and metrics) on the nominal rig and on each `--compare` variant, each
/// run's signals checked against its rig's drive ratings
/// ([`response::signals_over_ratings`]). An unstable nominal rig is an error; an unstable
/// variant is set aside with its reason (its response would only grow).
fn run_variants<M>(
    source: &RigSource,
    rig: &Rig,
    compare: &[String],
    mut f: impl FnMut(&Rig) -> Result<(Signals, M)>,
) -> Result<Runs<M>> {
    let mut runs = Runs {
        done: Vec::new(),
        unstable: Vec::new(),
    };
    for (label, r) in variants(rig, compare)? {
        match f(&r) {
            Ok((signals, metrics)) => runs.done.push(Run {
                label,
                over_ratings: response::signals_over_ratings(&r, &signals),
                signals,
                metrics,
            }),
            Err(e) if label != "nominal" && is_unstable(&e) => runs.unstable.push(Unstable {
                label,
                reason: e.to_string(),
            }),
            Err(e) => return Err(crate::emit::hinted(e).context(which(source, &label))),
        }
    }
    Ok(runs)
}

fn is_unstable(e: &anyhow::Error) -> bool {
    matches!(
        e.downcast_ref::<pumpcyl::lti::LtiError>(),
        Some(pumpcyl::lti::LtiError::Unstable { .. })
    )
}

/// The rig and variant a run belongs to, for messages.
fn which(rig: &RigSource, label: &str) -> String {
    match label {
        "nominal" => rig.origin(),
        variant => format!("{} with --compare {variant}", rig.origin()),
    }
}

/// Check a run of `duration_s` (set by the options `duration_from`) sampled at `rate_hz` before
/// any work, as the core checks every record ([`pumpcyl::limits::check_samples`]), blaming the
/// options that set it.
fn check_timing(duration_s: f64, duration_from: &str, rate_hz: f64) -> Result<()> {
    pumpcyl::limits::check_samples(duration_s, rate_hz)
        .map_err(|e| anyhow::anyhow!("{duration_from} and --rate-hz: {e}"))?;
    Ok(())
}

/// Refuse a reference from `lo_mm` to `hi_mm` that leaves the rig's stroke
/// ([`Rig::check_reference`]), naming the options `what` that set it.
fn check_in_stroke(rig: &Rig, what: &str, lo_mm: f64, hi_mm: f64) -> Result<()> {
    rig.check_reference(lo_mm, hi_mm)
        .map_err(|e| anyhow::anyhow!("{what}: {e}"))
}

/// Warn of every run whose predicted position leaves the stroke of `rig`
/// ([`response::stroke_excursion`]) on standard error, and return the warnings, each named
/// by its run when there are several.
fn stroke_warnings<M>(rig: &Rig, runs: &Runs<M>) -> Vec<String> {
    let several = runs.done.len() > 1;
    let warnings: Vec<String> = runs
        .done
        .iter()
        .filter_map(|run| {
            let e = response::stroke_excursion(rig, &run.signals)?;
            Some(if several {
                format!("{}: {e}", run.label)
            } else {
                e.to_string()
            })
        })
        .collect();
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    warnings
}

/// The JSON document `doc` with its `warnings` ([`documents::with_warnings`]).
fn with_warnings(doc: serde_json::Value, warnings: &[String]) -> Result<String> {
    Ok(json_document(&documents::with_warnings(doc, warnings))?)
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
    check_timing(args.duration_s, "--duration-s", args.rate_hz)?;
    anyhow::ensure!(
        args.step_mm != 0.0 && args.step_mm.is_finite(),
        "--step-mm must be non-zero"
    );
    let rig = args.rig.load()?;
    let (x0, end) = (rig.x0_mm, rig.x0_mm + args.step_mm);
    check_in_stroke(
        &rig,
        &format!("--step-mm {}", args.step_mm),
        x0.min(end),
        x0.max(end),
    )?;
    let runs = run_variants(&args.rig, &rig, &args.opts.compare, |r| {
        let s = response::step(r, args.step_mm, args.duration_s, args.rate_hz)?;
        let m = response::step_report(r, &s, args.step_mm)?;
        Ok((s, m))
    })?;
    let origin = args.rig.origin();
    let setup = StepSetup {
        rig: &origin,
        circuit: rig.circuit,
        step_mm: args.step_mm,
        duration_s: args.duration_s,
        rate_hz: args.rate_hz,
    };
    if let Some(path) = &args.opts.out {
        let title = step_title(&setup, rig.x0_mm);
        let subtitle = step_subtitle(&runs.done[0].metrics);
        let series = series(&runs.done);
        write_signals(
            path,
            || signals_csv(&series, None),
            || step_mat(&title, &runs.done),
            || Chart::signals(&title, Some(&subtitle), &series, None, None),
        )?;
    }
    let warnings = stroke_warnings(&rig, &runs);
    if args.opts.json {
        return Ok(json_document(&documents::step_document(
            &setup, &runs, &warnings,
        ))?);
    }
    Ok(step_text(&setup, &runs))
}

/// `pumpcyl track`.
pub fn track(args: &TrackArgs) -> Result<String> {
    let cases: Vec<(f64, f64)> = if args.article_cases {
        ARTICLE_SINE_CASES.to_vec()
    } else {
        vec![(
            args.freq_hz.unwrap_or_default(),
            args.amp_mm.unwrap_or_default(),
        )]
    };
    anyhow::ensure!(
        (1.0..=f64::from(u32::MAX)).contains(&args.periods) && args.periods.fract() == 0.0,
        "--periods must be a whole number of periods, 1 or more (got {})",
        args.periods
    );
    for &(f, a) in &cases {
        anyhow::ensure!(f > 0.0 && f.is_finite(), "--freq-hz must be > 0 (got {f})");
        anyhow::ensure!(a > 0.0 && a.is_finite(), "--amp-mm must be > 0 (got {a})");
        check_timing(args.periods / f, "--periods / --freq-hz", args.rate_hz)?;
    }
    let periods = args.periods as u32; // whole and within u32, checked above
    let rig = args.rig.load()?;
    for &(_, a) in &cases {
        let what = format!("--amp-mm {a}");
        check_in_stroke(&rig, &what, rig.x0_mm - a, rig.x0_mm + a)?;
    }
    let mut runs = Runs {
        done: Vec::new(),
        unstable: Vec::new(),
    };
    for &(f, a) in &cases {
        let case = run_variants(&args.rig, &rig, &args.opts.compare, |r| {
            Ok(response::track(r, f, a, periods, args.rate_hz)?)
        })?;
        runs.done.extend(case.done);
        // a variant's closed loop is unstable or not whatever the sine
        runs.unstable = case.unstable;
    }
    if let Some(path) = &args.opts.out {
        write_signals(
            path,
            || signals_csv(&track_series(&runs.done), None),
            || track_mat(&runs.done),
            || track_chart(&runs.done),
        )?;
    }
    let origin = args.rig.origin();
    let warnings = stroke_warnings(&rig, &runs);
    if args.opts.json {
        return with_warnings(track_json(&origin, rig.circuit, &runs), &warnings);
    }
    Ok(track_text(&origin, rig.circuit, &runs))
}

/// `pumpcyl simulate`.
pub fn simulate(args: &SimulateArgs) -> Result<String> {
    let (rec, rig, dataset_end) = replayed(args)?;
    rec.check_units(rig.stroke_mm)?;
    let (lo, hi) = rec.reference_range_mm();
    check_in_stroke(&rig, &format!("{}: x_ref_mm", rec.file), lo, hi)?;
    let origin = match (&args.experiment, args.dataset) {
        (Some(p), Some(n)) => format!(
            "{} dataset {n}: Kp {}, m {} kg, K_pres {} per bar",
            p.display(),
            rig.kp,
            rig.mass_kg,
            rig.k_pres_per_bar
        ),
        _ => args.rig.origin(),
    };
    let window_end = match args.fit_end_s.or(dataset_end) {
        Some(t) => {
            let (t0, t1) = (rec.time_s[0], rec.time_s[rec.len() - 1]);
            anyhow::ensure!(
                t.is_finite() && t > t0 && t <= t1,
                "{}: --fit-end-s {t} lies outside the record ({t0} … {t1} s)",
                rec.file
            );
            t
        }
        None => rec.time_s[rec.len() - 1],
    };
    let measured = Signals::of_record(&rec);
    let runs = run_variants(&args.rig, &rig, &args.opts.compare, |r| {
        let base = Baseline::of_record(&rec, r);
        let s = response::simulate(r, &rec.time_s, &rec.x_ref_mm, &base)?;
        let mse = response::position_mse_until(&rec.time_s, &s.x_mm, &rec.x_mm, window_end);
        Ok((s, mse))
    })?;
    let replay = Replay {
        record: &rec,
        rig: &origin,
        circuit: rig.circuit,
        own_conditions: args.experiment.is_some(),
        fit_end_s: window_end,
    };
    if let Some(path) = &args.opts.out {
        let series = simulate_series(&runs.done);
        let title = simulate_title(&replay);
        let subtitle = simulate_subtitle(&replay, runs.done[0].metrics);
        let mark = args.fit_end_s.or(dataset_end);
        write_signals(
            path,
            || signals_csv(&series, Some(&measured)),
            || simulate_mat(&replay, &runs.done, &measured),
            || Chart::signals(&title, Some(&subtitle), &series, Some(&measured), mark),
        )?;
    }
    let warnings = stroke_warnings(&rig, &runs);
    if args.opts.json {
        return with_warnings(simulate_json(&replay, &runs), &warnings);
    }
    Ok(simulate_text(&replay, &runs))
}

/// The record to replay, the rig to replay it on and the dataset's fit window end (s): from
/// --data and the rig options, or from a dataset of --experiment with its own conditions.
fn replayed(args: &SimulateArgs) -> Result<(Record, Rig, Option<f64>)> {
    let (Some(path), Some(n)) = (&args.experiment, args.dataset) else {
        let data = args
            .data
            .as_ref()
            .context("--data or --experiment is needed")?;
        return Ok((
            Record::read_in(crate::read_files::files(), data)?,
            args.rig.load()?,
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
    Ok((ds.record.clone(), rig, Some(ds.fit_end_s)))
}
