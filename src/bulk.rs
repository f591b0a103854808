//! `pumpcyl bulk-modulus`: gas fraction, β_e against pressure and the margins there (docs/bulk-modulus.md).

use anyhow::Result;
use clap::Args;
use serde_json::json;
use std::fmt::Write as _;
use std::path::PathBuf;

use crate::emit::{fmt_opt, format_of, write_atomic, Format};
use crate::RigSource;
use pumpcyl::bulk::{gas_fraction, table, Row, BETA_OIL_BAR};
use pumpcyl_present::figures::Chart;

#[derive(Debug, Args)]
pub struct BulkArgs {
    #[command(flatten)]
    rig: RigSource,
    /// Identified effective bulk modulus (bar).
    #[arg(long, default_value_t = 165.0, allow_negative_numbers = true)]
    beta_bar: f64,
    /// Mean chamber pressure during the identification (bar).
    #[arg(long, default_value_t = 4.4, allow_negative_numbers = true)]
    p_mean_bar: f64,
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
    let rig = args.rig.load()?;
    let x = gas_fraction(args.beta_bar, args.p_mean_bar, args.beta_oil_bar)?;
    let pressures = pumpcyl::ident::spaced(args.from_bar, args.to_bar, args.points, false);
    let rows = table(&rig, x, args.beta_oil_bar, &pressures)?;
    if let Some(path) = &args.out {
        let fine = pumpcyl::ident::spaced(args.from_bar, args.to_bar, 91, false);
        let fine_rows = table(&rig, x, args.beta_oil_bar, &fine)?;
        write_output(
            path,
            (args.beta_bar, args.p_mean_bar, args.beta_oil_bar),
            x,
            &fine_rows,
        )?;
    }
    if args.json {
        return Ok(serde_json::to_string_pretty(
            &json!({"gas_fraction": x, "beta_oil_bar": args.beta_oil_bar, "table": rows}),
        )? + "\n");
    }
    let mut s = format!(
        "gas fraction X = {x:.5} (beta_e = {} bar at {} bar mean pressure, beta_oil = {} bar)\n",
        args.beta_bar, args.p_mean_bar, args.beta_oil_bar
    );
    let _ = writeln!(
        s,
        "{:>8} {:>10} {:>9} {:>9}  closed loop",
        "p_bar", "beta_bar", "GM_dB", "PM_deg"
    );
    for r in &rows {
        let verdict = if r.closed_loop_stable {
            "stable"
        } else {
            "UNSTABLE"
        };
        let _ = writeln!(
            s,
            "{:>8.2} {:>10.1} {:>9} {:>9}  {verdict}",
            r.p_bar,
            r.beta_bar,
            fmt_opt(r.gain_margin_db, 2),
            fmt_opt(r.phase_margin_deg, 1)
        );
    }
    Ok(s)
}

/// The β_e table as CSV or as a figure (β_e, GM, PM against pressure), by extension; `fit` is
/// (β bar, at mean pressure bar, β_oil bar) the gas fraction came from.
pub(super) fn write_output(
    path: &std::path::Path,
    fit: (f64, f64, f64),
    x: f64,
    rows: &[Row],
) -> Result<()> {
    let format = format_of(path, &[Format::Csv, Format::Svg, Format::Png])?;
    if format == Format::Csv {
        let mut s =
            String::from("p_bar,beta_bar,gain_margin_db,phase_margin_deg,closed_loop_stable\n");
        for r in rows {
            let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6}"));
            let _ = writeln!(
                s,
                "{},{:.6},{},{},{}",
                r.p_bar,
                r.beta_bar,
                opt(r.gain_margin_db),
                opt(r.phase_margin_deg),
                r.closed_loop_stable
            );
        }
        return write_atomic(path, s.as_bytes());
    }
    crate::time::render(path, &Chart::bulk_modulus(fit, x, rows))
}
