//! `pumpcyl bulk-modulus`: gas fraction, β_e against pressure and the margins there (docs/bulk-modulus.md).

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

use crate::emit::{format_of, render, write_atomic, Format};
use crate::RigSource;
use pumpcyl::bulk::{BetaReading, BulkModel, BETA_OIL_BAR};
use pumpcyl_present::request::bulk::BulkModulus;

#[derive(Debug, Args)]
pub struct BulkArgs {
    #[command(flatten)]
    rig: RigSource,
    /// Identified effective bulk modulus (bar). Default: the rig's beta_bar (the article's
    /// 165 bar on its rig).
    #[arg(long, allow_negative_numbers = true)]
    beta_bar: Option<f64>,
    /// Mean chamber pressure during the identification (bar). Default: the rig's anchor, where
    /// its loop rests (docs/bulk-modulus.md#the-anchor: the article's records' 4.4 bar on its
    /// rig, its accumulator_precharge_bar on a one-motor circuit).
    #[arg(long, allow_negative_numbers = true)]
    p_mean_bar: Option<f64>,
    /// Pure-oil bulk modulus (bar).
    #[arg(long, default_value_t = BETA_OIL_BAR, allow_negative_numbers = true)]
    beta_oil_bar: f64,
    /// Lowest mean pressure of the table (bar).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    from_bar: f64,
    /// Highest mean pressure of the table (bar).
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
    to_bar: f64,
    /// Table rows, evenly spaced.
    #[arg(long, default_value_t = 10)]
    points: usize,
    /// Print JSON: gas_fraction and table rows (p_bar, beta_bar, gain_margin_db,
    /// phase_margin_deg, closed_loop_stable).
    #[arg(long)]
    json: bool,
    /// Output: .csv (a fine table) or .svg / .png (β_e, GM and PM against pressure).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Run even when the table would take long (more than 10^5 margin analyses: --points), or
    /// the nonlinear refinement of the --level records (more than 5·10^4 record samples × models,
    /// docs/identification.md#nonlinear-refinement).
    #[arg(long)]
    allow_long_run: bool,
    /// The model of beta against pressure (docs/bulk-modulus.md#a-family-of-models):
    /// constant-gas-fraction (the article's), constant-gas-fraction-absolute, entrained-air or
    /// entrained-air-dissolving; every model's beta is tabled beside it either way. Default:
    /// the rig's bulk_modulus_model.
    #[arg(long)]
    model: Option<String>,
    /// The entrained air's polytropic index n (1 isothermal ... 1.4 adiabatic). Default: the
    /// rig's polytropic_index, else 1.
    #[arg(long)]
    polytropic_index: Option<f64>,
    /// The pressure (bar gauge) at which the dissolving model's air is all dissolved.
    /// Default: the rig's air_dissolution_pressure_bar, else 30.
    #[arg(long)]
    air_dissolution_pressure_bar: Option<f64>,
    /// An identification experiment at one pressure level (repeatable, up to 20): each
    /// identifies beta with its interval at its records' mean chamber pressure, and the family
    /// is fitted to them all (docs/bulk-modulus.md#several-pressure-levels).
    #[arg(long, value_name = "EXPERIMENT.toml")]
    level: Vec<PathBuf>,
    /// Confidence level of the levels' intervals and of the models' tests, in (0, 1).
    #[arg(
        long,
        default_value_t = 0.95,
        requires = "level",
        allow_negative_numbers = true
    )]
    confidence: f64,
}

/// The model `--model` names with its parameters, the rig's model and parameters where they
/// are not given.
fn model_of(args: &BulkArgs, rig: &pumpcyl::rig::Rig) -> Result<BulkModel> {
    let form = match &args.model {
        Some(name) => BulkModel::named(name)?.form(),
        None => rig.bulk_modulus_model,
    };
    let same = form == rig.bulk_modulus_model;
    let n = args
        .polytropic_index
        .or(rig.polytropic_index.filter(|_| same));
    let pc =
        (args.air_dissolution_pressure_bar).or(rig.air_dissolution_pressure_bar.filter(|_| same));
    BulkModel::of(form, n, pc).map_err(|e| anyhow::anyhow!("bulk-modulus model: {e}"))
}

/// `pumpcyl bulk-modulus`.
pub fn bulk(args: &BulkArgs) -> Result<String> {
    let rig = args.rig.input()?;
    let (reading, from) = reading(args, &rig.rig);
    let model = model_of(args, &rig.rig)?;
    let request = BulkModulus {
        rig,
        reading,
        from,
        beta_oil_bar: args.beta_oil_bar,
        from_bar: args.from_bar,
        to_bar: args.to_bar,
        points: args.points,
        allow_long_run: args.allow_long_run,
        model,
        levels: (args.level.iter())
            .map(|p| crate::read_files::experiment(p))
            .collect::<Result<Vec<_>>>()?,
        confidence: args.confidence,
    };
    let outcome = crate::emit::run(&request)?;
    if let Some(path) = &args.out {
        match format_of(path, &[Format::Csv, Format::Svg, Format::Png])? {
            Format::Csv => write_atomic(path, outcome.csv()?.as_bytes())?,
            _ => render(path, &outcome.chart()?)?,
        }
    }
    crate::emit::show(&outcome, args.json)
}

/// The β and mean pressure the gas fraction is read off, and where they came from in words:
/// each of --beta-bar and --p-mean-bar as given, else the rig's reading
/// ([`BetaReading::for_rig`]: the article's identification on the article's rig).
fn reading(args: &BulkArgs, rig: &pumpcyl::rig::Rig) -> (BetaReading, String) {
    let own = BetaReading::for_rig(rig, args.rig.rig.is_none());
    let reading = BetaReading {
        beta_bar: args.beta_bar.unwrap_or(own.beta_bar),
        p_mean_bar: args.p_mean_bar.unwrap_or(own.p_mean_bar),
    };
    let article = own == pumpcyl::bulk::ARTICLE_READING;
    let (beta_words, p_words) = if article {
        (
            "the article's identification",
            "its records' mean chamber pressure",
        )
    } else {
        (
            "the rig's beta_bar",
            if rig.circuit.description().level.at_emulated_rest {
                "the rig's anchor, the mean chamber pressure of its loop at rest (docs/bulk-modulus.md#the-anchor)"
            } else {
                "the rig's mean chamber pressure at rest, its accumulator_precharge_bar"
            },
        )
    };
    let from = match (args.beta_bar, args.p_mean_bar) {
        (Some(_), Some(_)) => "--beta-bar at --p-mean-bar".to_string(),
        (Some(_), None) => format!("--beta-bar at {p_words}"),
        (None, Some(_)) => format!("{beta_words} at --p-mean-bar"),
        (None, None) => format!("{beta_words} at {p_words}"),
    };
    let from = if article {
        from
    } else {
        format!("{from}; rig: {}", args.rig.origin())
    };
    (reading, from)
}
