//! `pumpcyl bulk-modulus`: gas fraction, β_e against pressure and the margins there (docs/bulk-modulus.md).

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

use crate::emit::{format_of, render, write_atomic, Format};
use crate::RigSource;
use pumpcyl::bulk::{gas_fraction, table, BetaReading, Row, BETA_OIL_BAR};
use pumpcyl_present::bulk::{bulk_csv, bulk_json, bulk_text};
use pumpcyl_present::figures::Chart;
use pumpcyl_present::format::json_document;

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
    /// Run even when the table would take long (more than 10^5 margin analyses: --points).
    #[arg(long)]
    allow_long_run: bool,
}

/// `pumpcyl bulk-modulus`.
pub fn bulk(args: &BulkArgs) -> Result<String> {
    anyhow::ensure!(
        args.from_bar > 0.0 && args.to_bar > args.from_bar && args.to_bar.is_finite(),
        "--from-bar and --to-bar must satisfy 0 < from < to (got {} and {})",
        args.from_bar,
        args.to_bar
    );
    anyhow::ensure!(args.points >= 2, "--points must be at least 2");
    pumpcyl::limits::check_size("--points", args.points as f64)?;
    pumpcyl::limits::check_work(
        "--points",
        args.points as f64,
        pumpcyl::limits::MAX_MARGIN_ANALYSES,
        args.allow_long_run,
    )
    .map_err(|e| crate::emit::hinted(e.into()))?;
    let rig = args.rig.load()?;
    let (reading, from) = reading(args, &rig);
    let x = gas_fraction(reading.beta_bar, reading.p_mean_bar, args.beta_oil_bar)?;
    let pressures = pumpcyl::ident::spaced(args.from_bar, args.to_bar, args.points, false);
    let rows = table(&rig, x, args.beta_oil_bar, &pressures)?;
    let fit = (reading.beta_bar, reading.p_mean_bar, args.beta_oil_bar);
    if let Some(path) = &args.out {
        let fine = pumpcyl::ident::spaced(args.from_bar, args.to_bar, 91, false);
        let fine_rows = table(&rig, x, args.beta_oil_bar, &fine)?;
        write_output(path, fit, x, &fine_rows)?;
    }
    if args.json {
        return Ok(json_document(&bulk_json(
            x,
            args.beta_oil_bar,
            (reading, &from),
            &rows,
        ))?);
    }
    Ok(bulk_text(fit, &from, x, &rows))
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

/// The β_e table as CSV or as a figure (β_e, GM, PM against pressure), by extension; `fit` is
/// (β bar, at mean pressure bar, β_oil bar) the gas fraction came from.
fn write_output(path: &std::path::Path, fit: (f64, f64, f64), x: f64, rows: &[Row]) -> Result<()> {
    if format_of(path, &[Format::Csv, Format::Svg, Format::Png])? == Format::Csv {
        return write_atomic(path, bulk_csv(rows).as_bytes());
    }
    render(path, &Chart::bulk_modulus(fit, x, rows))
}
