//! The frequency-analysis commands: `margins`, `bode`, `poles`, `model` (docs/analysis.md#margins).

use anyhow::{Context, Result};
use clap::Args;
use serde_json::json;
use std::fmt::Write as _;
use std::path::PathBuf;

use crate::emit::{format_of, write_atomic, Format};
use crate::export;
use crate::{Loop, ModelArgs};
use pumpcyl::lti::{self, PoleInfo};
use pumpcyl::model::Plant;
use pumpcyl_present::analysis::{margins_json, margins_text};
use pumpcyl_present::figures::bode_markers;
use pumpcyl_present::plot::{self, BodeSeries};

#[derive(Debug, Args)]
pub struct MarginsArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Print JSON (keys loop, gain_margin_db, phase_margin_deg, phase_crossover_hz,
    /// gain_crossover_hz, delay_margin_s, closed_loop_stable, crossings, integrators; a null
    /// margin is infinite: no crossing of that kind).
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct BodeArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Lowest frequency (Hz).
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    from_hz: f64,
    /// Highest frequency (Hz).
    #[arg(long, default_value_t = 100.0, allow_negative_numbers = true)]
    to_hz: f64,
    /// Grid density (points per decade, logarithmic).
    #[arg(long, default_value_t = 200)]
    points_per_decade: usize,
    /// Output file: .csv (freq_hz, mag_db, phase_deg per series), .svg / .png (Bode plot) or
    /// .mat (MATLAB/Octave). Without it the CSV goes to standard output.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Overlay a variant: KEY=VALUE[,KEY=VALUE...] applied on top of the rig (repeatable),
    /// e.g. --compare beta_bar=37.8 --compare beta_bar=370.
    #[arg(long, value_name = "KEY=VALUE[,...]")]
    compare: Vec<String>,
}

#[derive(Debug, Args)]
pub struct PolesArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
pub struct ModelCmdArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Print JSON: {"A","B","C","D","states"} (row-major, SI).
    #[arg(long)]
    json: bool,
    /// The closed loop as `step` simulates it (input x_ref; outputs x, p1, p2, w1, w2, e)
    /// instead of the open loop.
    #[arg(long)]
    closed_loop: bool,
    /// Write the model for MATLAB/Octave: NAME.m (a function returning an `ss` object with
    /// named states, inputs and outputs) or NAME.mat (A, B, C, D, names, operating point).
    #[arg(long, value_name = "FILE.m|FILE.mat")]
    out: Option<PathBuf>,
    /// Write a grey-box model function [A,B,C,D] = NAME(beta_bar, b, c12, Ts) for idgrey
    /// (System Identification Toolbox), c1 and c2 from the standstill equations.
    #[arg(long, value_name = "NAME.m", conflicts_with = "ss")]
    greybox: Option<PathBuf>,
    /// Standstill of the grey-box function (with --w2-rpm, --p1-bar): motor/pump 1 speed
    /// (rpm). Default: the rig's own operating point, which gives back the rig's c1 and c2.
    #[arg(long, requires_all = ["w2_rpm", "p1_bar", "greybox"], allow_negative_numbers = true)]
    w1_rpm: Option<f64>,
    /// Standstill motor/pump 2 speed (rpm), with --w1-rpm.
    #[arg(long, requires = "w1_rpm", allow_negative_numbers = true)]
    w2_rpm: Option<f64>,
    /// Standstill chamber 1 pressure (bar gauge), with --w1-rpm.
    #[arg(long, requires = "w1_rpm", allow_negative_numbers = true)]
    p1_bar: Option<f64>,
}

/// `pumpcyl margins`.
pub fn margins(args: &MarginsArgs) -> Result<String> {
    let lp = args.model.build(&[])?;
    let m = lti::margins(&lp.open_loop)?;
    if args.json {
        Ok(serde_json::to_string_pretty(&margins_json(&m, &lp.description))? + "\n")
    } else {
        Ok(margins_text(&m, &lp.description))
    }
}

/// `pumpcyl bode`.
pub fn bode(args: &BodeArgs) -> Result<String> {
    anyhow::ensure!(
        args.from_hz > 0.0 && args.to_hz > args.from_hz && args.to_hz.is_finite(),
        "--from-hz and --to-hz must satisfy 0 < from < to (got {} and {})",
        args.from_hz,
        args.to_hz
    );
    anyhow::ensure!(
        args.points_per_decade >= 2,
        "--points-per-decade must be at least 2"
    );
    anyhow::ensure!(
        args.model.ss.is_none() || args.compare.is_empty(),
        "--compare overlays rig variants; it cannot be used with --ss"
    );
    let decades = args.to_hz.log10() - args.from_hz.log10();
    let points = pumpcyl::limits::check_size(
        "--from-hz, --to-hz and --points-per-decade",
        (decades * args.points_per_decade as f64).floor() + 1.0,
    )?;
    let freqs = lti::log_grid(args.from_hz, args.to_hz, points);
    let base = args.model.build(&[])?;
    let mut series = vec![series_of(&base, "nominal", &freqs)?];
    let mut variants = Vec::new();
    for variant in &args.compare {
        let overrides: Vec<String> = variant.split(',').map(|s| s.trim().to_string()).collect();
        let lp = args
            .model
            .build(&overrides)
            .with_context(|| format!("--compare {variant}"))?;
        series.push(series_of(&lp, variant, &freqs)?);
        variants.push(lp);
    }
    let format = match &args.out {
        Some(path) => format_of(path, &[Format::Csv, Format::Svg, Format::Png, Format::Mat])?,
        None => Format::Csv,
    };
    if let (Some(path), Format::Mat) = (&args.out, format) {
        export::write_bode_mat(path, &series)?;
        return Ok(format!(
            "wrote {} ({} series)\n",
            path.display(),
            series.len()
        ));
    }
    let bytes = match format {
        Format::Csv => bode_csv(&series).into_bytes(),
        _ => {
            // Every series keeps its margin markers, drawn in its own colour.
            let markers = std::iter::once(&base)
                .chain(&variants)
                .map(|lp| Ok(Some(bode_markers(&lti::margins(&lp.open_loop)?))))
                .collect::<Result<Vec<_>>>()?;
            let title = format!("Bode: {}", base.description);
            if format == Format::Svg {
                plot::bode_svg(&title, &series, &markers)?.into_bytes()
            } else {
                plot::bode_png(&title, &series, &markers, 1500, 1125)?
            }
        }
    };
    match &args.out {
        Some(path) => {
            write_atomic(path, &bytes)?;
            Ok(format!(
                "wrote {} ({} series)\n",
                path.display(),
                series.len()
            ))
        }
        None => Ok(String::from_utf8(bytes)?),
    }
}

fn series_of(lp: &Loop, label: &str, freqs: &[f64]) -> Result<BodeSeries> {
    let b = lti::bode(&lp.open_loop, freqs)?;
    Ok(BodeSeries {
        label: label.to_string(),
        freq_hz: b.freq_hz,
        mag_db: b.mag_db,
        phase_deg: b.phase_deg,
    })
}

/// CSV: `freq_hz,mag_db,phase_deg`, then `mag_db[variant],phase_deg[variant]` per overlay.
fn bode_csv(series: &[BodeSeries]) -> String {
    let mut s = String::from("freq_hz");
    for (i, ser) in series.iter().enumerate() {
        if i == 0 {
            s.push_str(",mag_db,phase_deg");
        } else {
            let label = ser.label.replace(',', ";");
            let _ = write!(s, ",mag_db[{label}],phase_deg[{label}]");
        }
    }
    s.push('\n');
    for (k, f) in series[0].freq_hz.iter().enumerate() {
        let _ = write!(s, "{f:.6e}");
        for ser in series {
            let _ = write!(s, ",{:.6},{:.6}", ser.mag_db[k], ser.phase_deg[k]);
        }
        s.push('\n');
    }
    s
}

/// `pumpcyl poles`.
pub fn poles(args: &PolesArgs) -> Result<String> {
    let lp = args.model.build(&[])?;
    let mut sets = vec![
        (
            "open_loop",
            "open loop (the analysed L(s))",
            lti::eigenvalues(&lp.open_loop.a)?,
        ),
        (
            "closed_loop",
            "closed loop (unity position feedback around L(s))",
            lp.open_loop.closed_loop_poles()?,
        ),
    ];
    if let Some(rig) = lp
        .rig
        .as_ref()
        .filter(|r| r.sum_pressure && !args.model.sum_pressure_closed)
    {
        let full = Plant::new(rig).closed_loop(true);
        sets.push((
            "closed_loop_with_sum_pressure",
            "closed loop with the sum-pressure loop as well (the controller as simulated)",
            lti::eigenvalues(&full.a)?,
        ));
    }
    let info: Vec<(&str, &str, Vec<PoleInfo>, bool)> = sets
        .into_iter()
        .map(|(k, d, p)| {
            (
                k,
                d,
                p.iter().copied().map(PoleInfo::from).collect(),
                lti::is_stable(&p),
            )
        })
        .collect();
    if args.json {
        let mut obj = serde_json::Map::new();
        obj.insert("loop".into(), json!(lp.description));
        for (key, _, p, stable) in &info {
            obj.insert(key.to_string(), json!(p));
            obj.insert(format!("{key}_stable"), json!(stable));
        }
        return Ok(serde_json::to_string_pretty(&obj)? + "\n");
    }
    let mut s = format!("{}\n", lp.description);
    for (_, desc, p, stable) in &info {
        let verdict = if *stable {
            "asymptotically stable"
        } else {
            "not asymptotically stable (a pole on or right of the imaginary axis)"
        };
        let _ = writeln!(s, "\n{desc}: {verdict}");
        let _ = writeln!(
            s,
            "  {:>14} {:>14} {:>12} {:>9}",
            "re_1_per_s", "im_rad_per_s", "f_n_hz", "damping"
        );
        for q in p {
            let damping = q.damping.map_or("-".to_string(), |z| format!("{z:.4}"));
            let _ = writeln!(
                s,
                "  {:>14.6} {:>14.6} {:>12.5} {:>9}",
                q.re, q.im, q.natural_freq_hz, damping
            );
        }
    }
    Ok(s)
}

/// `pumpcyl model`.
pub fn model(args: &ModelCmdArgs) -> Result<String> {
    let lp = args.model.build(&[])?;
    let view = lp.view(args.closed_loop, args.model.sum_pressure_closed)?;
    let mut wrote = String::new();
    for (path, greybox) in [(&args.out, false), (&args.greybox, true)] {
        if let Some(path) = path {
            if greybox {
                let standstill = match (args.w1_rpm, args.w2_rpm, args.p1_bar) {
                    (Some(w1_rpm), Some(w2_rpm), Some(p1_bar)) => {
                        Some(pumpcyl::ident::Standstill {
                            w1_rpm,
                            w2_rpm,
                            p1_bar,
                        })
                    }
                    _ => None,
                };
                export::write_greybox(path, &view, standstill)?;
            } else {
                export::write_model(path, &view)?;
            }
            let _ = writeln!(wrote, "wrote {}", path.display());
        }
    }
    let json = lti::ModelJson::from_model(&view.sys, view.states.clone());
    if args.json {
        return Ok(serde_json::to_string_pretty(&json)? + "\n");
    }
    if !wrote.is_empty() {
        return Ok(wrote);
    }
    let plural = |p: &[pumpcyl::loops::Port]| if p.len() > 1 { "s" } else { "" };
    let outputs: Vec<String> = view
        .outputs
        .iter()
        .map(|p| format!("{} ({})", p.name, p.unit))
        .collect();
    let inputs: Vec<String> = view
        .inputs
        .iter()
        .map(|p| format!("{} {} ({})", p.meaning, p.name, p.unit))
        .collect();
    let mut s = format!(
        "{}\ninput{}: {}; output{}: {}\nstates:\n",
        view.title,
        plural(&view.inputs),
        inputs.join(", "),
        plural(&view.outputs),
        outputs.join(", ")
    );
    for (i, st) in view.states.iter().enumerate() {
        let _ = writeln!(s, "  {:>2}  {:<6} {}", i + 1, st.name, st.unit);
    }
    for (name, rows) in [
        ("A", &json.a),
        ("B", &json.b),
        ("C", &json.c),
        ("D", &json.d),
    ] {
        let _ = writeln!(s, "{name} =");
        for r in rows {
            let cells: Vec<String> = r.iter().map(|v| format!("{v:>11.4e}")).collect();
            let _ = writeln!(s, "  [{}]", cells.join(" "));
        }
    }
    Ok(s)
}
