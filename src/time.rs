//! The time-domain commands: `step`, `track`, `simulate` (docs/simulation.md).

use anyhow::{Context, Result};
use clap::Args;
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::emit::{fmt_opt, format_of, shown_name, write_atomic, Format};
use crate::export;
use crate::RigSource;
use pumpcyl::record::Record;
use pumpcyl::response::{self, Baseline, Signals, StepMetrics, TrackMetrics, ARTICLE_SINE_CASES};
use pumpcyl::rig::Rig;
use pumpcyl_present::figures::{trace, Chart};
use pumpcyl_present::plot::{LineStyle, Panel};

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
    /// Number of periods simulated; metrics skip the first.
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

/// The runs of a time-domain command: the nominal rig's and each `--compare` variant's, and
/// the variants set aside because their closed loop is unstable.
struct Runs<T> {
    /// Label and result, the nominal rig first.
    done: Vec<(String, T)>,
    /// Label and reason of each unstable variant.
    unstable: Vec<(String, String)>,
}

impl<T> Runs<T> {
    /// Run `f` on the nominal rig and on each variant. An unstable nominal rig is an error; an
    /// unstable variant is set aside with its reason (its response would only grow).
    fn of(
        source: &RigSource,
        rig: &Rig,
        compare: &[String],
        mut f: impl FnMut(&Rig) -> Result<T>,
    ) -> Result<Runs<T>> {
        let mut runs = Runs {
            done: Vec::new(),
            unstable: Vec::new(),
        };
        for (label, r) in variants(rig, compare)? {
            match f(&r) {
                Ok(t) => runs.done.push((label, t)),
                Err(e) if label != "nominal" && is_unstable(&e) => {
                    runs.unstable.push((label, e.to_string()))
                }
                Err(e) => return Err(crate::emit::hinted(e).context(which(source, &label))),
            }
        }
        Ok(runs)
    }
}

/// Add the unstable variants (label, reason) to a JSON report as `unstable`, if there are any.
fn add_unstable(v: &mut serde_json::Value, unstable: &[(String, String)]) {
    if !unstable.is_empty() {
        v["unstable"] = unstable
            .iter()
            .map(|(l, why)| json!({"label": l, "unstable": why}))
            .collect();
    }
}

/// Unstable variants as lines for the terminal (empty when there are none).
fn unstable_lines(unstable: &[(String, String)]) -> String {
    unstable
        .iter()
        .map(|(l, why)| format!("--compare {l}: not simulated: {why}\n"))
        .collect()
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
    let all = Runs::of(&args.rig, &rig, &args.opts.compare, |r| {
        let s = response::step(r, args.step_mm, args.duration_s, args.rate_hz)?;
        let m = response::step_metrics_of(r, &s, args.step_mm);
        Ok((s, m))
    })?;
    let runs: Vec<_> = all
        .done
        .iter()
        .map(|(l, (s, m))| (l.clone(), s, *m))
        .collect();
    if let Some(path) = &args.opts.out {
        let series: Vec<(String, &Signals)> =
            runs.iter().map(|(l, s, _)| (l.clone(), *s)).collect();
        let title = format!(
            "Step {:+} mm from x0 = {} mm ({})",
            args.step_mm,
            rig.x0_mm,
            args.rig.origin()
        );
        let subtitle = step_subtitle(&runs[0].2);
        if export::has_ext(path, "mat") {
            let m: Vec<&StepMetrics> = runs.iter().map(|r| &r.2).collect();
            let col = |f: fn(&StepMetrics) -> Option<f64>| m.iter().map(|m| f(m)).collect();
            let scalars = [
                ("step_mm", col(|m| Some(m.step_mm))),
                ("rise_time_s", col(|m| m.rise_time_s)),
                ("overshoot_mm", col(|m| Some(m.overshoot_mm))),
                ("overshoot_pct", col(|m| Some(m.overshoot_pct))),
                ("peak_time_s", col(|m| Some(m.peak_time_s))),
                ("settling_time_s", col(|m| m.settling_time_s)),
                (
                    "steady_state_error_mm",
                    col(|m| Some(m.steady_state_error_mm)),
                ),
                ("final_error_mm", col(|m| Some(m.final_error_mm))),
            ];
            export::write_signals_mat(path, &title, &series, None, &scalars)?;
        } else {
            write_figure(path, &title, Some(&subtitle), &series, None)?;
        }
    }
    if args.opts.json {
        let mut v =
            json!({"rig": args.rig.origin(), "step_mm": args.step_mm, "metrics": runs[0].2});
        if runs.len() > 1 {
            v["compare"] = runs[1..]
                .iter()
                .map(|(l, _, m)| json!({"label": l, "metrics": m}))
                .collect();
        }
        add_unstable(&mut v, &all.unstable);
        return Ok(serde_json::to_string_pretty(&v)? + "\n");
    }
    Ok(step_table(args, &runs) + &unstable_lines(&all.unstable))
}

fn step_subtitle(m: &StepMetrics) -> String {
    format!(
        "rise {} s, overshoot {:.2} mm ({:.1} %), settling (2 %) {}",
        fmt_opt(m.rise_time_s, 3),
        m.overshoot_mm,
        m.overshoot_pct,
        m.settling_time_s
            .map_or("not within the run".into(), |t| format!("{t:.2} s"))
    )
}

fn step_table(args: &StepArgs, runs: &[(String, &Signals, StepMetrics)]) -> String {
    let mut s = format!(
        "step {:+} mm, {} Hz, {} s ({}; sum-pressure loop as the rig says)\n",
        args.step_mm,
        args.rate_hz,
        args.duration_s,
        args.rig.origin()
    );
    let _ = write!(s, "{:<24}", "");
    for (label, _, _) in runs {
        let _ = write!(s, " {label:>22}");
    }
    s.push('\n');
    type Row = (&'static str, fn(&StepMetrics) -> String);
    let rows: [Row; 7] = [
        ("rise time 10-90 % (s)", |m| fmt_opt(m.rise_time_s, 3)),
        ("overshoot (mm)", |m| format!("{:.3}", m.overshoot_mm)),
        ("overshoot (%)", |m| format!("{:.2}", m.overshoot_pct)),
        ("peak time (s)", |m| format!("{:.2}", m.peak_time_s)),
        ("settling time 2 % (s)", |m| {
            m.settling_time_s
                .map_or("not settled".into(), |t| format!("{t:.2}"))
        }),
        ("steady-state error (mm)", |m| {
            format!("{:.4}", m.steady_state_error_mm)
        }),
        ("error at end (mm)", |m| format!("{:.4}", m.final_error_mm)),
    ];
    for (name, f) in rows {
        let _ = write!(s, "{name:<24}");
        for (_, _, m) in runs {
            let _ = write!(s, " {:>22}", f(m));
        }
        s.push('\n');
    }
    s
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
    for &(f, a) in &cases {
        anyhow::ensure!(f > 0.0 && f.is_finite(), "--freq-hz must be > 0 (got {f})");
        anyhow::ensure!(a > 0.0 && a.is_finite(), "--amp-mm must be > 0 (got {a})");
        check_timing(args.periods / f, "--periods / --freq-hz", args.rate_hz)?;
    }
    anyhow::ensure!(
        args.periods > 1.0,
        "--periods must exceed 1 (metrics skip the first period)"
    );
    let rig = args.rig.load()?;
    for &(_, a) in &cases {
        let what = format!("--amp-mm {a}");
        check_in_stroke(&rig, &what, rig.x0_mm - a, rig.x0_mm + a)?;
    }
    let mut runs = Vec::new();
    let mut unstable = Vec::new();
    for &(f, a) in &cases {
        let all = Runs::of(&args.rig, &rig, &args.opts.compare, |r| {
            let s = response::sine(r, f, a, args.periods, args.rate_hz)?;
            let m = response::track_metrics(&s.time_s, &s.e_mm, f, a);
            Ok((s, m))
        })?;
        runs.extend(all.done.into_iter().map(|(l, (s, m))| (l, s, m)));
        unstable = all.unstable;
    }
    if let Some(path) = &args.opts.out {
        write_track_output(path, &runs)?;
    }
    if args.opts.json {
        let cases: Vec<_> = runs
            .iter()
            .map(|(l, _, m)| json!({"label": l, "metrics": m}))
            .collect();
        let mut v = json!({"rig": args.rig.origin(), "cases": cases});
        add_unstable(&mut v, &unstable);
        return Ok(serde_json::to_string_pretty(&v)? + "\n");
    }
    let mut s = format!(
        "sinusoidal tracking ({}), metrics after the first period\n",
        args.rig.origin()
    );
    let _ = writeln!(
        s,
        "{:<22} {:>8} {:>8} {:>12} {:>12} {:>15}",
        "variant", "freq_hz", "amp_mm", "max_err_mm", "rms_err_mm", "wave_reduction"
    );
    for (label, _, m) in &runs {
        let _ = writeln!(
            s,
            "{label:<22} {:>8.3} {:>8.1} {:>12.3} {:>12.3} {:>15.3}",
            m.freq_hz, m.amp_mm, m.max_error_mm, m.rms_error_mm, m.wave_reduction
        );
    }
    Ok(s + &unstable_lines(&unstable))
}

fn write_track_output(path: &Path, runs: &[(String, Signals, TrackMetrics)]) -> Result<()> {
    let labelled: Vec<(String, &Signals)> = runs
        .iter()
        .map(|(l, s, m)| (format!("{} Hz ±{} mm {l}", m.freq_hz, m.amp_mm), s))
        .collect();
    match format_of(path, &[Format::Csv, Format::Svg, Format::Png, Format::Mat])? {
        Format::Csv => return write_atomic(path, signals_csv(&labelled, None).as_bytes()),
        Format::Mat => {
            let col = |f: fn(&TrackMetrics) -> f64| runs.iter().map(|r| Some(f(&r.2))).collect();
            let scalars = [
                ("freq_hz", col(|m| m.freq_hz)),
                ("amp_mm", col(|m| m.amp_mm)),
                ("max_error_mm", col(|m| m.max_error_mm)),
                ("rms_error_mm", col(|m| m.rms_error_mm)),
                ("wave_reduction", col(|m| m.wave_reduction)),
            ];
            let title = "Sinusoidal tracking";
            return export::write_signals_mat(path, title, &labelled, None, &scalars);
        }
        _ => {}
    }
    // one position panel per case, then all errors together
    let mut panels = Vec::new();
    let mut errors = Panel {
        y_label: "Control error (mm)".into(),
        traces: Vec::new(),
    };
    for (i, (label, s)) in labelled.iter().enumerate() {
        let (_, _, m) = &runs[i];
        panels.push(Panel {
            y_label: format!("Position (mm), {} Hz", m.freq_hz),
            traces: vec![
                trace("x_ref", &s.time_s, &s.x_ref_mm, LineStyle::Dashed, Some(6)),
                trace(
                    &format!("x {label}"),
                    &s.time_s,
                    &s.x_mm,
                    LineStyle::Solid,
                    Some(i),
                ),
            ],
        });
        errors
            .traces
            .push(trace(label, &s.time_s, &s.e_mm, LineStyle::Solid, Some(i)));
    }
    panels.push(errors);
    let title = "Sinusoidal tracking (the article)";
    let list = |f: fn(&TrackMetrics) -> String| -> String {
        runs.iter()
            .map(|(_, _, m)| f(m))
            .collect::<Vec<_>>()
            .join(" / ")
    };
    let subtitle = format!(
        "max|e| {} mm; wave reduction {}",
        list(|m| format!("{:.1}", m.max_error_mm)),
        list(|m| format!("{:.2}", m.wave_reduction))
    );
    render(path, &Chart::time(title, Some(&subtitle), panels))
}

/// `pumpcyl simulate`.
pub fn simulate(args: &SimulateArgs) -> Result<String> {
    let (rec, rig, dataset_end) = replayed(args)?;
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
    let all = Runs::of(&args.rig, &rig, &args.opts.compare, |r| {
        let base = Baseline::of_record(&rec, r);
        let s = response::simulate(r, &rec.time_s, &rec.x_ref_mm, &base)?;
        let mse = response::position_mse_until(&rec.time_s, &s.x_mm, &rec.x_mm, window_end);
        Ok((s, mse))
    })?;
    let runs: Vec<_> = all.done.iter().map(|(l, (s, m))| (l, s, *m)).collect();
    let in_window = rec.time_s.iter().filter(|&&t| t <= window_end).count();
    if let Some(path) = &args.opts.out {
        let series: Vec<(String, &Signals)> = runs
            .iter()
            .map(|(l, s, _)| (format!("sim {l}"), *s))
            .collect();
        let title = format!("{} against the model ({})", shown_name(&rec.file), origin);
        let subtitle = format!(
            "position MSE {:.4} mm² up to t = {} s",
            runs[0].2, window_end
        );
        if export::has_ext(path, "mat") {
            let scalars = [
                ("mse_mm2", runs.iter().map(|r| Some(r.2)).collect()),
                ("fit_end_s", vec![Some(window_end)]),
            ];
            export::write_signals_mat(path, &title, &series, Some(&measured), &scalars)?;
        } else {
            let mark = args.fit_end_s.or(dataset_end);
            write_fit_figure(
                path,
                &title,
                Some(&subtitle),
                &series,
                Some(&measured),
                mark,
            )?;
        }
    }
    if args.opts.json {
        let mut v = json!({
            "file": rec.file, "rig": origin, "mse_mm2": runs[0].2,
            "fit_end_s": window_end, "samples_in_window": in_window,
        });
        if runs.len() > 1 {
            v["compare"] = runs[1..]
                .iter()
                .map(|(l, _, m)| json!({"label": l, "mse_mm2": m}))
                .collect();
        }
        add_unstable(&mut v, &all.unstable);
        return Ok(serde_json::to_string_pretty(&v)? + "\n");
    }
    let conditions = match args.experiment {
        Some(_) => format!(" ({origin})"),
        None => String::new(),
    };
    let mut s = format!(
        "{}{conditions}: {} samples, fit window up to {} s ({in_window} samples)\n",
        rec.file,
        rec.len(),
        window_end
    );
    for (label, _, mse) in &runs {
        let _ = writeln!(s, "  {label:<24} position MSE {mse:.5} mm²");
    }
    Ok(s + &unstable_lines(&all.unstable))
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
            Record::read_in(crate::inputs::files(), data)?,
            args.rig.load()?,
            None,
        ));
    };
    let exp = pumpcyl::ident::Experiment::load_in(crate::inputs::files(), path)?;
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

/// CSV of signals: one block of columns per series (suffixed `[label]` beyond the first), and
/// the measured columns first when given.
fn signals_csv(series: &[(String, &Signals)], measured: Option<&Signals>) -> String {
    let names = [
        "x_ref_mm", "x_mm", "e_mm", "p1_bar", "p2_bar", "w1_rpm", "w2_rpm",
    ];
    let mut blocks: Vec<(String, &Signals)> = Vec::new();
    if let Some(m) = measured {
        blocks.push(("measured".into(), m));
    }
    blocks.extend(series.iter().map(|(l, s)| (l.clone(), *s)));
    let mut out = String::from("time_s");
    for (i, (label, _)) in blocks.iter().enumerate() {
        for n in names {
            if i == 0 {
                let _ = write!(out, ",{n}");
            } else {
                let _ = write!(out, ",{n}[{}]", label.replace(',', ";"));
            }
        }
    }
    out.push('\n');
    let len = blocks
        .iter()
        .map(|(_, s)| s.time_s.len())
        .max()
        .unwrap_or(0);
    for k in 0..len {
        let t = blocks
            .iter()
            .find_map(|(_, s)| s.time_s.get(k))
            .copied()
            .unwrap_or(f64::NAN);
        let _ = write!(out, "{t:.6}");
        for (_, s) in &blocks {
            for v in [
                &s.x_ref_mm,
                &s.x_mm,
                &s.e_mm,
                &s.p1_bar,
                &s.p2_bar,
                &s.w1_rpm,
                &s.w2_rpm,
            ] {
                match v.get(k) {
                    Some(x) => {
                        let _ = write!(out, ",{x:.6}");
                    }
                    None => out.push(','),
                }
            }
        }
        out.push('\n');
    }
    out
}

/// Write signals as CSV, as the four-panel figure or as a MAT-file, by the file's extension.
pub(super) fn write_figure(
    path: &Path,
    title: &str,
    subtitle: Option<&str>,
    series: &[(String, &Signals)],
    measured: Option<&Signals>,
) -> Result<()> {
    write_fit_figure(path, title, subtitle, series, measured, None)
}

/// As [`write_figure`], the figure marking the end of the fit window at `fit_end_s` (s) with a
/// dotted vertical line on every panel (as the article's Figure 6 does).
pub(super) fn write_fit_figure(
    path: &Path,
    title: &str,
    subtitle: Option<&str>,
    series: &[(String, &Signals)],
    measured: Option<&Signals>,
    fit_end_s: Option<f64>,
) -> Result<()> {
    match format_of(path, &[Format::Csv, Format::Svg, Format::Png, Format::Mat])? {
        Format::Csv => write_atomic(path, signals_csv(series, measured).as_bytes()),
        Format::Mat => export::write_signals_mat(path, title, series, measured, &[]),
        _ => render(
            path,
            &Chart::signals(title, subtitle, series, measured, fit_end_s),
        ),
    }
}

/// Render a chart as `stem`.svg and `stem`.png, each atomically.
pub(super) fn render_both(stem: &Path, chart: &Chart) -> Result<()> {
    render(&stem.with_extension("svg"), chart)?;
    render(&stem.with_extension("png"), chart)
}

/// Render a chart to SVG or PNG by extension, atomically.
pub(super) fn render(path: &Path, chart: &Chart) -> Result<()> {
    let bytes = match format_of(path, &[Format::Svg, Format::Png])? {
        Format::Png => chart.png()?,
        _ => chart.svg()?.into_bytes(),
    };
    write_atomic(path, &bytes)
}
