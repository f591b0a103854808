//! `pumpcyl design`: the design method (the article §2.2; docs/design.md) applied to a rig before it is built.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

use crate::emit::{render_both, show, write_atomic};
use crate::RigSource;
use pumpcyl::design::Targets;
use pumpcyl_present::format::json_document;
use pumpcyl_present::request::design::{Design, Robust};
use pumpcyl_present::request::Document;

#[derive(Debug, Args)]
pub struct DesignArgs {
    #[command(flatten)]
    rig: RigSource,
    /// Run even when the masses × pressures would take long (more than 10^5 margin analyses).
    #[arg(long)]
    allow_long_run: bool,
    /// Phase margin target (deg); the default is the article's (its Kp = 25 gives PM 34°).
    #[arg(long, default_value_t = 34.0, allow_negative_numbers = true)]
    target_pm_deg: f64,
    /// Gain margin target (dB).
    #[arg(long, default_value_t = 6.0, allow_negative_numbers = true)]
    target_gm_db: f64,
    /// Stroke excursion checked on each side of x0 (mm).
    #[arg(long, default_value_t = 50.0, allow_negative_numbers = true)]
    stroke_mm: f64,
    /// Mean chamber pressures to check (bar), e.g. --p-mean-bar 1 --p-mean-bar 10; beta
    /// follows the gas-fraction model (docs/bulk-modulus.md) from the rig's beta at --p-beta-bar.
    /// With --robust --experiment and none given: the pressures the records span, beta at the
    /// first record's mean.
    #[arg(long)]
    p_mean_bar: Vec<f64>,
    /// Mean pressure at which the rig's beta_bar was identified (bar). Default: the rig's own
    /// anchor, where its loop rests (docs/bulk-modulus.md#the-anchor; the article's 4.4 bar on
    /// its rig).
    #[arg(long, allow_negative_numbers = true)]
    p_beta_bar: Option<f64>,
    /// Masses to check (kg), e.g. the lightest and heaviest load.
    #[arg(long)]
    mass_kg: Vec<f64>,
    /// Wave to track, FREQ_HZ:AMP_MM (repeatable), e.g. --wave 0.2:35.
    #[arg(long, value_parser = parse_wave)]
    wave: Vec<(f64, f64)>,
    /// Design on the loop as the rig's PLC closes it (plc_rate_hz, plc_delay_samples, a
    /// zero-order hold; docs/analysis.md#sampled-data-margins) instead of the continuous one.
    #[arg(long)]
    sampled: bool,
    /// Print JSON (analysed_loop, kp_max, kp_max_worst_case, worst_case, conditions, tracking, rest_offset_mm, verdict,
    /// reasons; with --robust: kp_max, kp_max_nominal, worst_case, deciding, steps, region).
    #[arg(long)]
    json: bool,
    /// Robust design (docs/design.md#robust-design): the largest Kp whose worst-case margins
    /// over the parameters' uncertainty, the stroke and the pressures meet the targets, and
    /// the article's "lower the leakage estimate and repeat" loop. Without --experiment, over
    /// the stated default uncertainty around the rig's values.
    #[arg(long)]
    robust: bool,
    /// Identification experiment (TOML, as for `identify`) whose records give the
    /// confidence region of beta, b and c12; the experiment's rig is designed.
    #[arg(long, value_name = "EXPERIMENT.toml", requires = "robust", conflicts_with_all = ["rig", "set"])]
    experiment: Option<PathBuf>,
    #[command(flatten)]
    confidence: crate::ConfidenceArg,
    /// Result folder for --robust: result.json and robust-margins.svg/.png (the margins over
    /// the stroke at the deciding parameter point).
    #[arg(long, value_name = "DIR", requires = "robust")]
    out: Option<PathBuf>,
}

/// A wave option, FREQ_HZ:AMP_MM, each part a positive number.
pub(crate) fn parse_wave(s: &str) -> Result<(f64, f64), String> {
    let (f, a) = s
        .split_once(':')
        .ok_or("expected FREQ_HZ:AMP_MM, e.g. 0.2:35")?;
    let f: f64 = f
        .trim()
        .parse()
        .map_err(|_| format!("`{f}` is not a frequency"))?;
    let a: f64 = a
        .trim()
        .parse()
        .map_err(|_| format!("`{a}` is not an amplitude"))?;
    if !(f > 0.0 && f.is_finite() && a > 0.0 && a.is_finite()) {
        return Err(format!("wave {s}: frequency and amplitude must be > 0"));
    }
    Ok((f, a))
}

/// `pumpcyl design`.
pub fn run(args: &DesignArgs) -> Result<String> {
    let load = (args.experiment.as_deref()).map(|p| move || crate::read_files::experiment(p));
    let robust = (args.robust)
        .then(|| Robust::new(args.confidence.confidence, load))
        .transpose()?;
    let request = Design {
        rig: args.rig.input()?,
        targets: Targets {
            pm_deg: args.target_pm_deg,
            gm_db: args.target_gm_db,
            stroke_mm: args.stroke_mm,
            p_mean_bar: args.p_mean_bar.clone(),
            p_beta_bar: args.p_beta_bar,
            mass_kg: args.mass_kg.clone(),
            waves: args.wave.clone(),
            sampled: args.sampled,
            bulk_model: None,
        },
        allow_long_run: args.allow_long_run,
        robust,
    };
    let outcome = crate::emit::run(&request)?;
    if let (Some(dir), Some(chart)) = (&args.out, outcome.robust_chart()) {
        let document = json_document(&outcome.json()?)?;
        let folder = crate::emit::out_dir(dir)?;
        write_atomic(&folder.path().join("result.json"), document.as_bytes())?;
        render_both(&folder.path().join("robust-margins"), &chart)?;
        crate::emit::commit(folder, dir)?;
    }
    show(&outcome, args.json)
}
