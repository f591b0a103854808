//! The frequency-analysis commands: `margins`, `bode`, `poles`, `model` (docs/analysis.md#margins).

use anyhow::{Context, Result};
use clap::Args;
use std::fmt::Write as _;
use std::path::PathBuf;

use crate::emit::{format_of, render, show, write_atomic, Format};
use crate::export;
use crate::ModelArgs;
use pumpcyl_present::request::analysis::{Bode, Margins, Model, Poles};
use pumpcyl_present::request::Document;
use pumpcyl_present::robustness::{gang_of_four_chart, nyquist_chart};

#[derive(Debug, Args)]
pub struct MarginsArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Print JSON (keys loop, gain_margin_db, phase_margin_deg, phase_crossover_hz,
    /// gain_crossover_hz, delay_margin_s, closed_loop_stable, crossings, integrators,
    /// ill_conditioned, disk (the balanced disk margin), sensitivity_peak and
    /// complementary_sensitivity_peak (docs/analysis.md#disk-margins), sampled (the same of
    /// the loop as the rig's PLC samples it: plc_rate_hz, plc_delay_samples, the margin
    /// fields, delay_margin_samples, phase_margin_cost_deg, gain_margin_cost_db;
    /// docs/analysis.md#sampled-data-margins); a null margin is
    /// infinite: no crossing of that kind;
    /// docs/analysis.md#conditioning for ill_conditioned and each crossing's margin_error_bound;
    /// on a single-pump rig also modes, one object per mode with accumulator_chamber, at_rest
    /// and the margin fields, beside switching_force_n, force_from_switching_n and
    /// acceleration_to_switch_m_per_s2: docs/circuits.md#modes-in-margins-and-poles).
    #[arg(long)]
    json: bool,
    /// The disk margin's skew sigma in [-1, 1]: 0 balanced, 1 the sensitivity S (1/M_s), -1
    /// the complementary sensitivity T (1/M_t) (docs/analysis.md#disk-margins).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    skew: f64,
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
    /// Also write the nominal loop's Nyquist diagram (.svg or .png): L(jw), the loop as the
    /// rig's PLC samples it, the unit circle, -1 and the balanced disk margin's disk
    /// (docs/analysis.md#the-nyquist-diagram).
    #[arg(long, value_name = "FILE.svg|FILE.png")]
    nyquist: Option<PathBuf>,
    /// Also write the nominal rig loop's gang of four (.svg or .png) over the same grid: S, T,
    /// PS and CS with the rig's Kp as the controller (docs/analysis.md#the-gang-of-four).
    #[arg(long, value_name = "FILE.svg|FILE.png")]
    gang_of_four: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct PolesArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Print JSON (on a single-pump rig with modes, each mode's poles, beside
    /// switching_force_n: docs/circuits.md#modes-in-margins-and-poles).
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
    show(
        &Margins::of_loop(args.model.build(&[])?, args.skew)?,
        args.json,
    )
}

/// `pumpcyl bode`.
pub fn bode(args: &BodeArgs) -> Result<String> {
    anyhow::ensure!(
        args.model.ss.is_none() || args.compare.is_empty(),
        "--compare overlays rig variants; it cannot be used with --ss"
    );
    let mut loops = vec![("nominal".to_string(), args.model.build(&[])?)];
    for variant in &args.compare {
        let overrides: Vec<String> = variant.split(',').map(|s| s.trim().to_string()).collect();
        let lp = args
            .model
            .build(&overrides)
            .with_context(|| format!("--compare {variant}"))?;
        loops.push((variant.clone(), lp));
    }
    let request = Bode {
        loops,
        from_hz: args.from_hz,
        to_hz: args.to_hz,
        points_per_decade: args.points_per_decade,
    };
    let nyquist = match &args.nyquist {
        Some(path) => {
            format_of(path, &[Format::Svg, Format::Png])?;
            Some((path, nyquist_chart(&request.loops[0].1, 0.0)?))
        }
        None => None,
    };
    let gang = match &args.gang_of_four {
        Some(path) => {
            format_of(path, &[Format::Svg, Format::Png])?;
            let grid = request.grid()?;
            Some((path, gang_of_four_chart(&request.loops[0].1, &grid)?))
        }
        None => None,
    };
    let outcome = crate::emit::run(&request)?;
    let extra: Vec<_> = nyquist.iter().chain(&gang).collect();
    for (path, chart) in &extra {
        render(path, chart)?;
    }
    let Some(path) = &args.out else {
        if extra.is_empty() {
            return outcome.text();
        }
        return Ok(extra
            .iter()
            .map(|(p, _)| format!("wrote {}\n", p.display()))
            .collect());
    };
    match format_of(path, &[Format::Csv, Format::Svg, Format::Png, Format::Mat])? {
        Format::Csv => write_atomic(path, outcome.text()?.as_bytes())?,
        Format::Mat => write_atomic(path, &outcome.mat())?,
        _ => render(path, &outcome.chart())?,
    }
    Ok(format!(
        "wrote {} ({} series)\n",
        path.display(),
        outcome.count()
    ))
}

/// `pumpcyl poles`.
pub fn poles(args: &PolesArgs) -> Result<String> {
    show(&Poles::of_loop(args.model.build(&[])?), args.json)
}

/// `pumpcyl model`.
pub fn model(args: &ModelCmdArgs) -> Result<String> {
    let request = Model {
        lp: args.model.build(&[])?,
        closed_loop: args.closed_loop,
    };
    let outcome = crate::emit::run(&request)?;
    let view = outcome.view();
    let mut wrote = String::new();
    if let Some(path) = &args.out {
        export::write_model(path, view)?;
        let _ = writeln!(wrote, "wrote {}", path.display());
    }
    if let Some(path) = &args.greybox {
        let standstill = match (args.w1_rpm, args.w2_rpm, args.p1_bar) {
            (Some(w1_rpm), Some(w2_rpm), Some(p1_bar)) => Some(pumpcyl::ident::Standstill {
                w1_rpm,
                w2_rpm,
                p1_bar,
            }),
            _ => None,
        };
        export::write_greybox(path, view, standstill)?;
        let _ = writeln!(wrote, "wrote {}", path.display());
    }
    if args.json || wrote.is_empty() {
        return show(&outcome, args.json);
    }
    Ok(wrote)
}
