//! The identification commands: `leakage`, `identify-drive`, `identify`, `identify-merge`
//! (the article §2.4; docs/identification.md).

use anyhow::Result;
use clap::Args;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::emit::{ensure_folder, format_of, write_atomic, Format};
use crate::RigSource;
use pumpcyl::ident::shards::{self, Partial};
use pumpcyl::ident::{
    analyze, finish, identify_drive, DriveRecord, Experiment, Identification, Method, Options,
    Request, Standstill, Uncertainty, UncertaintyOptions,
};
use pumpcyl_present::figures::Chart;
use pumpcyl_present::frf as frf_outputs;
use pumpcyl_present::identification as outputs;
use pumpcyl_present::uncertainty::{profile_files, uncertainty_text};

#[derive(Debug, Args)]
pub struct LeakageArgs {
    #[command(flatten)]
    rig: RigSource,
    /// A standstill record (docs/formats.md#record-csv with w1_rpm, w2_rpm, p1_bar): its means are used.
    #[arg(long, value_name = "RECORD.csv", conflicts_with_all = ["w1_rpm", "w2_rpm", "p1_bar"])]
    record: Option<PathBuf>,
    /// Motor/pump 1 speed at standstill (rpm).
    #[arg(
        long,
        allow_negative_numbers = true,
        required_unless_present = "record"
    )]
    w1_rpm: Option<f64>,
    /// Motor/pump 2 speed at standstill (rpm).
    #[arg(
        long,
        allow_negative_numbers = true,
        required_unless_present = "record"
    )]
    w2_rpm: Option<f64>,
    /// Chamber 1 pressure at standstill (bar gauge).
    #[arg(
        long,
        required_unless_present = "record",
        allow_negative_numbers = true
    )]
    p1_bar: Option<f64>,
    /// Cross-port leakage c12 (m⁵/(N·s)).
    #[arg(long, allow_negative_numbers = true)]
    c12: f64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct DriveArgs {
    #[command(flatten)]
    rig: RigSource,
    /// Drive step record: CSV with time_s, w_ref_rpm, w_rpm.
    record: PathBuf,
    /// Which motor's rotor inertia to use (1 or 2).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    motor: u8,
    /// Overlay of measured and simulated speed: .svg, .png or .csv.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct IdentifyArgs {
    /// Experiment description (TOML): rig, [set], [standstill], [[dataset]], optional grids.
    experiment: PathBuf,
    /// Print JSON (beta_bar, viscous_friction_ns_per_m, c12_m5_per_ns, c1_m5_per_ns,
    /// c2_m5_per_ns, cost_mm2, candidates_evaluated, seconds, refined, grid_best, ...).
    #[arg(long)]
    json: bool,
    /// Folder for result.json, the cost landscape (CSV and heat map) and the fit overlays.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Derive the second grid from the first grid's candidates below the threshold.
    #[arg(long)]
    auto_refine: bool,
    /// Skip the local (Nelder–Mead) refinement.
    #[arg(long)]
    no_refine: bool,
    /// Threshold of the threshold set (mm²); default: the experiment's, else 0.25.
    #[arg(long, allow_negative_numbers = true)]
    threshold_mm2: Option<f64>,
    /// Length of the top list.
    #[arg(long, default_value_t = 20)]
    top: usize,
    /// Evaluate only slice I of N of the grids (1-based; N at most 1000 and at most the
    /// candidates of the smallest grid) and write a partial result into --out for
    /// `pumpcyl identify-merge`.
    #[arg(long, value_name = "I/N", value_parser = parse_shard)]
    shard: Option<(usize, usize)>,
    /// Run even when the grids times the records would take hours (more than
    /// 10^9 candidate-samples).
    #[arg(long)]
    allow_long_run: bool,
    /// Also give the noise level and profile-likelihood intervals of beta, b and c12, saying
    /// which the records do not bound (docs/identification.md, "Uncertainty"); with --out, the
    /// profile figures too.
    #[arg(long, conflicts_with = "shard")]
    uncertainty: bool,
    /// Confidence level of the --uncertainty intervals, in (0, 1).
    #[arg(long, default_value_t = 0.95, requires = "uncertainty")]
    confidence: f64,
    /// Fit the sweep records by their frequency response (with any step records beside them),
    /// as the experiment's `method = "frequency"` does
    /// (docs/identification.md#grey-box-fit-to-a-frequency-response).
    #[arg(long, conflicts_with = "shard")]
    frequency: bool,
}

#[derive(Debug, Args)]
pub struct MergeArgs {
    /// Partial results written by `identify --shard I/N --out DIR`.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// Folder for the merged result, as `identify --out`.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let (i, n) = s.split_once('/').ok_or("expected I/N, e.g. 3/8")?;
    let i: usize = i
        .trim()
        .parse()
        .map_err(|_| format!("`{i}` is not a shard number"))?;
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| format!("`{n}` is not a shard count"))?;
    if n == 0 || i == 0 || i > n {
        return Err(format!("shard {i}/{n}: need 1 <= I <= N"));
    }
    Ok((i, n))
}

/// `pumpcyl leakage`.
pub fn leakage(args: &LeakageArgs) -> Result<String> {
    anyhow::ensure!(
        args.c12.is_finite() && args.c12 >= 0.0,
        "--c12 must be >= 0 (got {})",
        args.c12
    );
    let rig = args.rig.load()?;
    let s = match (&args.record, args.w1_rpm, args.w2_rpm, args.p1_bar) {
        (Some(path), ..) => {
            let rec = pumpcyl::record::Record::read_in(crate::read_files::files(), path)?;
            warn(&pumpcyl::ident::standstill_warnings(&rec));
            Standstill::of_record(&rec)?
        }
        (None, Some(w1_rpm), Some(w2_rpm), Some(p1_bar)) => Standstill {
            w1_rpm,
            w2_rpm,
            p1_bar,
        },
        _ => anyhow::bail!("give --record or all of --w1-rpm, --w2-rpm, --p1-bar"),
    };

    let l = s.leakage(&rig, args.c12)?;
    if args.json {
        return Ok(serde_json::to_string_pretty(&l)? + "\n");
    }
    Ok(outputs::leakage_text(&s, &l))
}

/// `pumpcyl identify-drive`.
pub fn drive(args: &DriveArgs) -> Result<String> {
    let rig = args.rig.load()?;
    let rec = DriveRecord::read_in(crate::read_files::files(), &args.record)?;
    let jm = if args.motor == 1 {
        rig.motor_inertia_1_kg_mm2
    } else {
        rig.motor_inertia_2_kg_mm2
    } * 1e-6;
    let fit = identify_drive(&rec, jm, rig.current_loop_bandwidth_rad_per_s)?;
    if let Some(path) = &args.out {
        write_drive_overlay(path, &rec, &fit)?;
    }
    if args.json {
        let v = outputs::drive_json(&rec, args.motor, &fit, jm);
        return Ok(serde_json::to_string_pretty(&v)? + "\n");
    }
    Ok(outputs::drive_text(
        &rec,
        args.motor,
        &fit,
        jm,
        rig.current_loop_bandwidth_rad_per_s,
    ))
}

pub(super) fn write_drive_overlay(
    path: &Path,
    rec: &DriveRecord,
    fit: &pumpcyl::ident::DriveFit,
) -> Result<()> {
    let format = format_of(path, &[Format::Csv, Format::Svg, Format::Png])?;
    if format == Format::Csv {
        return write_atomic(path, outputs::drive_csv(rec, fit).as_bytes());
    }
    let chart = Chart::drive_step(rec, fit);
    crate::emit::render(path, &chart)
}

/// The experiment file's options with this command's flags on top.
fn options(args: &IdentifyArgs, exp: &Experiment) -> Options {
    let file = exp.options();
    Options {
        auto_refine: args.auto_refine || file.auto_refine,
        local_refinement: !args.no_refine && file.local_refinement,
        threshold_mm2: args.threshold_mm2.unwrap_or(file.threshold_mm2),
        top_n: args.top,
    }
}

/// A progress bar of candidates on stderr when it is a terminal; silent otherwise.
pub(super) fn progress_bar(total: u64) -> indicatif::ProgressBar {
    progress_bar_of(total, "candidates")
}

/// A progress bar of `total` `unit` on stderr when it is a terminal (the size shown from the
/// start); silent otherwise.
pub(super) fn progress_bar_of(total: u64, unit: &str) -> indicatif::ProgressBar {
    if std::io::stderr().is_terminal() {
        let bar = indicatif::ProgressBar::new(total);
        bar.set_style(
            indicatif::ProgressStyle::with_template(&format!(
                "{{bar:40}} {{pos}}/{{len}} {unit} {{per_sec}} eta {{eta}}"
            ))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    } else {
        indicatif::ProgressBar::hidden()
    }
}

/// `pumpcyl identify`.
pub fn identify(args: &IdentifyArgs) -> Result<String> {
    if args.uncertainty {
        crate::emit::check_confidence(args.confidence)?;
    }
    let method = args.frequency.then_some(Method::Frequency);
    let exp = crate::read_files::experiment_as(&args.experiment, method)?;
    if exp.method == Method::Frequency {
        return identify_frequency(args, &exp);
    }
    let opts = options(args, &exp);
    anyhow::ensure!(
        args.shard.is_none() || args.out.is_some(),
        "--shard writes a partial result: give --out DIR"
    );
    if let Some(shard) = args.shard {
        shards::check_label(&exp, shard)?;
    }
    let request = Request {
        shard: args.shard,
        allow_long_run: args.allow_long_run,
        ..exp.request(opts)
    };
    request.check().map_err(|e| crate::emit::hinted(e.into()))?;
    let bar = progress_bar(request.candidates());
    let start = Instant::now();
    let stages = request.search(&|n| {
        bar.inc(n);
        true
    })?;
    let search_seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if let (Some(shard), Some(dir)) = (args.shard, &args.out) {
        let part = Partial::of_search(
            crate::read_files::files(),
            &args.experiment,
            &opts,
            shard,
            search_seconds,
            stages,
        )?;
        ensure_folder(dir)?;
        let path = dir.join(format!("part-{}-of-{}.json", shard.0, shard.1));
        write_atomic(&path, serde_json::to_string(&part)?.as_bytes())?;
        return Ok(format!(
            "wrote {} (shard {}/{}, {:.2} s)\n",
            path.display(),
            shard.0,
            shard.1,
            search_seconds
        ));
    }
    let id = finish(&exp.problem, stages, &opts)?;
    let seconds = start.elapsed().as_secs_f64();
    warn(&id.warnings());
    let uncertainty = if args.uncertainty {
        Some(analyze_uncertainty(&exp, &id, args.confidence)?)
    } else {
        None
    };
    report_identification(
        &exp,
        &id,
        seconds,
        uncertainty.as_ref(),
        args.json,
        args.out.as_deref(),
    )
}

/// `pumpcyl identify` of an experiment fitted in the frequency domain: the grid and the
/// polished answer, the intervals with --uncertainty, with --out the folder of result.json and
/// one fit figure per sweep (`fit-K.svg`: the estimate with its band and the fitted model).
fn identify_frequency(args: &IdentifyArgs, exp: &Experiment) -> Result<String> {
    anyhow::ensure!(
        args.shard.is_none(),
        "--shard: the frequency-domain fit is not sharded (it takes seconds)"
    );
    let problem = exp
        .frequency_problem()
        .ok_or_else(|| anyhow::anyhow!("the experiment is not fitted in the frequency domain"))?;
    let start = Instant::now();
    let fit = problem.fit(&exp.first_grid)?;
    let seconds = start.elapsed().as_secs_f64();
    warn(&fit.warnings);
    let uncertainty = if args.uncertainty {
        let start = Instant::now();
        let u = problem.uncertainty(&fit, args.confidence)?;
        Some((u, start.elapsed().as_secs_f64()))
    } else {
        None
    };
    let u = uncertainty.as_ref().map(|(u, s)| (u, *s));
    let doc = frf_outputs::frequency_document(exp, &fit, seconds, u);
    if let Some(dir) = &args.out {
        let folder = crate::emit::out_dir(dir)?;
        write_atomic(
            &folder.path().join("result.json"),
            (serde_json::to_string_pretty(&doc)? + "\n").as_bytes(),
        )?;
        let curves = frf_outputs::fitted_curves(&problem, &fit);
        for (k, (s, curve)) in problem.sweeps.iter().zip(&curves).enumerate() {
            let svg = frf_outputs::frf_svg(&s.estimate, curve.as_ref())
                .map_err(|e| anyhow::anyhow!(e))?;
            write_atomic(
                &folder.path().join(format!("fit-{}.svg", k + 1)),
                svg.as_bytes(),
            )?;
        }
        crate::emit::commit(folder, dir)?;
    }
    if args.json {
        return Ok(serde_json::to_string_pretty(&doc)? + "\n");
    }
    Ok(frf_outputs::frequency_text(exp, &fit, seconds, u))
}

/// Warnings go to standard error, one line each, so `--json` output stays clean.
fn warn(lines: &[String]) {
    for l in lines {
        eprintln!("warning: {l}");
    }
}

/// `pumpcyl identify-merge`.
pub fn merge(args: &MergeArgs) -> Result<String> {
    let mut parts = Vec::new();
    for p in &args.parts {
        let text = pumpcyl::source_files::read_text(crate::read_files::files(), p)
            .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
        let part: Partial = serde_json::from_str(&text)
            .map_err(|e| anyhow::anyhow!("{}: not a partial result: {e}", p.display()))?;
        parts.push((p.clone(), part));
    }
    let (exp, id, seconds) = shards::merge(crate::read_files::files(), parts)?;
    report_identification(&exp, &id, seconds, None, args.json, args.out.as_deref())
}

/// The profile-likelihood uncertainty of the best candidate (docs/identification.md,
/// "Uncertainty") and the seconds it took.
fn analyze_uncertainty(
    exp: &Experiment,
    id: &Identification,
    confidence: f64,
) -> Result<(Uncertainty, f64)> {
    let start = Instant::now();
    let opts = UncertaintyOptions {
        confidence,
        ..UncertaintyOptions::default()
    };
    let u = analyze(&exp.problem, &id.best().candidate, &opts)?;
    Ok((u, start.elapsed().as_secs_f64()))
}

/// Report an identification (with its uncertainty when analysed): JSON or text; with `out`,
/// its result folder (docs/identification.md), built aside and swapped in whole.
fn report_identification(
    exp: &Experiment,
    id: &Identification,
    seconds: f64,
    uncertainty: Option<&(Uncertainty, f64)>,
    json_out: bool,
    out: Option<&Path>,
) -> Result<String> {
    let origin = outputs::Origin::of_experiment(exp);
    let found = outputs::Found {
        uncertainty,
        ..outputs::Found::of_experiment(exp, &origin, id, seconds)
    };
    let (v, verdicts) = outputs::identification_report(&found)?;
    if let Some(dir) = out {
        let folder = crate::emit::out_dir(dir)?;
        let mut files = outputs::files(exp, id, &v)?;
        if let Some((u, _)) = uncertainty {
            files.extend(profile_files(u)?);
        }
        for (name, bytes) in files {
            write_atomic(&folder.path().join(name), &bytes)?;
        }
        crate::emit::commit(folder, dir)?;
    }
    if json_out {
        return Ok(serde_json::to_string_pretty(&v)? + "\n");
    }
    let mut text = outputs::identification_text(exp, id, seconds, verdicts.as_ref());
    if let Some((u, s)) = uncertainty {
        text += &uncertainty_text(u, *s);
    }
    Ok(text)
}
