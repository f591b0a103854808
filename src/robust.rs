//! `pumpcyl design --robust`: the design over the uncertainty of the parameters, the stroke
//! and the pressure range (docs/design.md#robust-design), formatted.

use anyhow::Result;
use serde_json::json;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use crate::emit::{fmt_opt, write_atomic};
use crate::time::render_both;
use pumpcyl::design::robust::{Region, RegionSource, RobustOptions, Worst};
use pumpcyl::design::{robust_design, RobustDesign, Targets};
use pumpcyl::ident::Experiment;
use pumpcyl::rig::Rig;
use pumpcyl_present::design::{leakage_loop_table, verdict_text};
use pumpcyl_present::figures::Chart;

/// Where the rig and the parameter set of a robust design come from.
pub(super) struct Source<'a> {
    /// The rig (used when there is no experiment).
    pub rig: Rig,
    /// The experiment whose records give the region, if any.
    pub experiment: Option<&'a Path>,
    /// Confidence of the region.
    pub confidence: f64,
}

/// Run the robust design and format it: JSON or text; with `out`, a result folder holding
/// result.json and the margins over the stroke at the deciding parameter point.
pub(super) fn run(
    src: &Source,
    targets: &Targets,
    json_out: bool,
    out: Option<&Path>,
) -> Result<String> {
    crate::emit::check_confidence(src.confidence)?;
    let start = Instant::now();
    let (rig, region) = match src.experiment {
        Some(path) => Region::of_records(
            &Experiment::load_in(crate::inputs::files(), path)?,
            src.confidence,
        )?,
        None => (src.rig.clone(), Region::stated_default(&src.rig)),
    };
    let identify_seconds = start.elapsed().as_secs_f64();
    let d = robust_design(&rig, &region, targets, &RobustOptions::default())?;
    let seconds = start.elapsed().as_secs_f64();
    let mut v = serde_json::to_value(&d)?;
    v["seconds"] = json!(seconds);
    v["identification_seconds"] = json!(identify_seconds);
    if let Some(dir) = out {
        let folder = crate::emit::out_dir(dir)?;
        write_atomic(
            &folder.path().join("result.json"),
            (serde_json::to_string_pretty(&v)? + "\n").as_bytes(),
        )?;
        write_figure(folder.path(), &d)?;
        folder.commit()?;
    }
    if json_out {
        return Ok(serde_json::to_string_pretty(&v)? + "\n");
    }
    Ok(text(&d, seconds))
}

/// A worst margin as text: value, unit and where.
fn worst_line(name: &str, unit: &str, w: &Worst, digits: usize) -> String {
    let stable = if w.closed_loop_stable {
        ""
    } else {
        " UNSTABLE"
    };
    format!(
        "  {name:<14} {:>10} {unit}{stable}  at {}\n",
        fmt_opt(w.value, digits),
        w.at.describe()
    )
}

/// The text report.
fn text(d: &RobustDesign, seconds: f64) -> String {
    let r = &d.region;
    let mut s = match r.source {
        RegionSource::Records => format!(
            "robust design (docs/design.md#robust-design) over the {:.0} % confidence region of the records\n",
            r.confidence.unwrap_or(0.0) * 100.0
        ),
        RegionSource::Point => String::from(
            "robust design (docs/design.md#robust-design) at one given parameter point\n",
        ),
        RegionSource::StatedDefault => String::from(
            "robust design (docs/design.md#robust-design) over the STATED DEFAULT uncertainty (no records given: \
             beta ±15 %, b x[0.5, 2], c12 x[0.7, 1.3])\n",
        ),
    };
    let _ = writeln!(
        s,
        "  beta {:.1} .. {:.1} bar, b {:.1} .. {:.1} N·s/m{}, c12 {:.4e} .. {:.4e} m⁵/(N·s); {} ridge points",
        r.beta_bar[0],
        r.beta_bar[1],
        r.viscous_friction_ns_per_m[0],
        r.viscous_friction_ns_per_m[1],
        if r.identifiable[1] { "" } else { " (not identifiable: the reported interval)" },
        r.c12_m5_per_ns[0],
        r.c12_m5_per_ns[1],
        r.ridge.len()
    );
    let t = &d.targets;
    let _ = writeln!(
        s,
        "targets PM >= {} deg, GM >= {} dB over x0 ± {} mm{}",
        t.pm_deg,
        t.gm_db,
        t.stroke_mm,
        if t.p_mean_bar.is_empty() {
            String::new()
        } else {
            format!(", p {:?} bar", t.p_mean_bar)
        }
    );
    let _ = writeln!(s, "  Kp max, robust     {:.2} (1/m)", d.kp_max);
    let _ = writeln!(s, "  Kp max, nominal    {:.2} (1/m)", d.kp_max_nominal);
    let w = &d.worst_case;
    let _ = writeln!(
        s,
        "worst case over {} points at Kp = {:.2}:",
        w.points, w.kp
    );
    s += &worst_line("GM (dB)", "dB", &w.gain_margin_db, 2);
    s += &worst_line("PM (deg)", "deg", &w.phase_margin_deg, 1);
    s += &worst_line("delay margin", "s", &w.delay_margin_s, 4);
    s += &leakage_loop_table(d).text();
    let _ = writeln!(s, "verdict: {}", verdict_text(d.verdict));
    for reason in &d.reasons {
        let _ = writeln!(s, "  - {reason}");
    }
    let _ = writeln!(s, "in {seconds:.2} s");
    s
}

/// `robust-margins.svg` and `.png`: the margins over the stroke at the deciding parameter point.
fn write_figure(dir: &Path, d: &RobustDesign) -> Result<()> {
    render_both(&dir.join("robust-margins"), &Chart::robust_margins(d))
}
