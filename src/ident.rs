//! The identification commands: `leakage`, `identify-drive`, `identify`, `identify-merge`
//! (the article §2.4; docs/identification.md).

use anyhow::Result;
use clap::Args;
use std::path::{Path, PathBuf};

use crate::emit::{ensure_folder, format_of, show, write_atomic, Format};
use crate::RigSource;
use pumpcyl::ident::shards::Partial;
use pumpcyl::ident::{DriveRecord, Method, Standstill};
use pumpcyl_present::request::identify::{Identify, Merge, Search, Source};
use pumpcyl_present::request::standstill::{DriveRequest, LeakageRequest, Point};

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
    let point = match (&args.record, args.w1_rpm, args.w2_rpm, args.p1_bar) {
        (Some(path), ..) => Point::Record(Box::new(pumpcyl::record::Record::read_in(
            crate::read_files::files(),
            path,
        )?)),
        (None, Some(w1_rpm), Some(w2_rpm), Some(p1_bar)) => Point::Given(Standstill {
            w1_rpm,
            w2_rpm,
            p1_bar,
        }),
        _ => anyhow::bail!("give --record or all of --w1-rpm, --w2-rpm, --p1-bar"),
    };
    let request = LeakageRequest {
        rig: args.rig.input()?,
        point,
        c12: args.c12,
    };
    show(&crate::emit::run(&request)?, args.json)
}

/// `pumpcyl identify-drive`.
pub fn drive(args: &DriveArgs) -> Result<String> {
    let request = DriveRequest {
        rig: args.rig.input()?,
        record: DriveRecord::read_in(crate::read_files::files(), &args.record)?,
        motor: args.motor,
    };
    let outcome = crate::emit::run(&request)?;
    if let Some(path) = &args.out {
        match format_of(path, &[Format::Csv, Format::Svg, Format::Png])? {
            Format::Csv => write_atomic(path, outcome.csv().as_bytes())?,
            _ => crate::emit::render(path, &outcome.chart())?,
        }
    }
    show(&outcome, args.json)
}

/// `pumpcyl identify`.
pub fn identify(args: &IdentifyArgs) -> Result<String> {
    anyhow::ensure!(
        args.shard.is_none() || args.out.is_some(),
        "--shard writes a partial result: give --out DIR"
    );
    let uncertainty = args.uncertainty.then_some(args.confidence);
    if let Some(confidence) = uncertainty {
        pumpcyl_present::request::check_confidence(confidence)?;
    }
    let method = args.frequency.then_some(Method::Frequency);
    let exp = crate::read_files::experiment_as(&args.experiment, method)?;
    let request = Identify {
        source: Source::Experiment(Box::new(exp)),
        search: Search {
            auto_refine: args.auto_refine.then_some(true),
            local_refinement: args.no_refine.then_some(false),
            threshold_mm2: args.threshold_mm2,
            top: args.top,
            ..Search::default()
        },
        shard: args.shard,
        uncertainty,
        allow_long_run: args.allow_long_run,
        files: crate::read_files::files(),
    };
    let outcome = crate::emit::run(&request)?;
    if let (Some(part), Some(dir)) = (outcome.partial(), &args.out) {
        ensure_folder(dir)?;
        let (i, n) = part.shard;
        let path = dir.join(format!("part-{i}-of-{n}.json"));
        write_atomic(&path, serde_json::to_string(part)?.as_bytes())?;
        let seconds = part.seconds;
        return Ok(format!(
            "wrote {} (shard {i}/{n}, {seconds:.2} s)\n",
            path.display()
        ));
    }
    if let Some(dir) = &args.out {
        write_folder(dir, outcome.files()?)?;
    }
    show(&outcome, args.json)
}

/// The result folder `dir` of `files` (name, bytes), built aside and swapped in whole.
fn write_folder(dir: &Path, files: Vec<(String, Vec<u8>)>) -> Result<()> {
    let folder = crate::emit::out_dir(dir)?;
    for (name, bytes) in files {
        write_atomic(&folder.path().join(name), &bytes)?;
    }
    crate::emit::commit(folder, dir)
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
    let request = Merge {
        parts,
        files: crate::read_files::files(),
    };
    let outcome = crate::emit::run(&request)?;
    if let Some(dir) = &args.out {
        write_folder(dir, outcome.files()?)?;
    }
    show(&outcome, args.json)
}
