//! The design results in words (docs/design.md): the verdict's one spelling, the deciding
//! margin, the nominal design as text, the robust design as JSON and text, and its leakage loop
//! as a table. Gains are in 1/m, gain margins in dB, phase margins in deg, delay margins in s;
//! an infinite margin is `inf` in text and `null` in JSON.

use crate::format::fmt_opt;
use crate::table::Table;
use pumpcyl::design::robust::{Binding, Region, RegionSource, RobustOptions, Worst};
use pumpcyl::design::{
    robust_design, Design, DesignError, RobustDesign, Searched, Targets, Verdict,
};
use pumpcyl::ident::Experiment;
use pumpcyl::rig::Rig;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::time::Instant;

/// The verdict as every text output writes it.
pub fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::Adequate => "ADEQUATE",
        Verdict::Marginal => "MARGINAL",
        Verdict::UseHigherPressure => "USE A CIRCUIT WITH HIGHER PRESSURE",
    }
}

/// The margin that decides a robust gain, in words.
pub fn binding_text(b: Binding) -> &'static str {
    match b {
        Binding::PhaseMargin => "phase margin",
        Binding::GainMargin => "gain margin",
        Binding::Stability => "stability",
    }
}

/// The article's loop done automatically (docs/design.md#robust-design): each step's leakage
/// estimate, the largest Kp there, the margin that binds it, the worst margins over the region
/// and whether the gain holds over the whole region.
pub fn leakage_loop_table(d: &RobustDesign) -> Table {
    let mut t = Table::new(
        "The article's loop done automatically: lower the leakage estimate, design again, and \
         check the gain over the whole region",
        &[
            "step",
            "c12 (m⁵/(N·s))",
            "Kp max",
            "binds",
            "worst GM (dB)",
            "worst PM (deg)",
            "holds over the region",
        ],
    );
    for (i, st) in d.steps.iter().enumerate() {
        let holds = if st.worst_case.meets_targets {
            "yes"
        } else {
            "no"
        };
        t.push(vec![
            format!("{}", i + 1),
            format!("{:.4e}", st.c12_m5_per_ns),
            format!("{:.2}", st.kp_max),
            binding_text(st.deciding.binding).to_string(),
            fmt_opt(st.worst_case.gain_margin_db.value, 2),
            fmt_opt(st.worst_case.phase_margin_deg.value, 1),
            holds.to_string(),
        ]);
    }
    t
}

/// Where the rig's β holds for a design over pressures, in words: `beta_bar holds at 5.81 bar
/// (docs/bulk-modulus.md#the-anchor)`.
fn anchor_text(t: &Targets) -> String {
    t.p_beta_bar.map_or_else(
        || "beta_bar at the rig's anchor".to_string(),
        |p| {
            let model = t.bulk_model.map_or("gas-fraction".to_string(), |m| m.described());
            format!("beta_bar holds at {p:.2} bar mean pressure, the {model} model's anchor (docs/bulk-modulus.md#the-anchor)")
        },
    )
}

/// A velocity-loop gain beside its K_p, or nothing where the loop has none.
fn kv_text(kv: Option<f64>) -> String {
    kv.map_or(String::new(), |kv| {
        format!(", Kv {kv:.3} 1/s (docs/analysis.md#the-velocity-loop-gain)")
    })
}

/// ", the searched worst PM position" after a searched condition's position.
fn searched_text(searched: Option<Searched>) -> &'static str {
    match searched {
        None => "",
        Some(Searched::PhaseMargin) => " (searched: the least phase margin over the stroke)",
        Some(Searched::GainMargin) => " (searched: the least gain margin over the stroke)",
    }
}

/// The nominal design (docs/design.md#what-pumpcyl-design-does) for the rig `rig` (in words)
/// as text: the targets, the largest gains and the binding condition, the margins at every
/// condition, the predicted tracking at the gain it names, the verdict and its reasons.
pub fn design_text(rig: &str, d: &Design) -> String {
    let mut s = format!(
        "design (the article §2.2) for {rig} ({}): PM >= {} deg, GM >= {} dB\n  Kp max at the design point   {:.2} (1/m){}\n  Kp max over all conditions   {:.2}\n",
        d.analysed_loop, d.targets.pm_deg, d.targets.gm_db, d.kp_max,
        kv_text(d.kv_max_per_s), d.kp_max_worst_case
    );
    if !d.targets.p_mean_bar.is_empty() {
        let _ = writeln!(s, "  {}", anchor_text(&d.targets));
    }
    let w = &d.worst_case;
    let _ = writeln!(
        s,
        "  binding condition            x {:.1} mm{}{}, m {:.0} kg{}: its Kp max {:.2} sets the gain (GM {} dB, PM {} deg at Kp = {:.2})",
        w.x_mm,
        searched_text(w.searched),
        w.mode.map_or(String::new(), |m| format!(", mode {m}")),
        w.mass_kg,
        w.p_mean_bar.map_or(String::new(), |p| format!(", p {p} bar")),
        w.kp_max,
        fmt_opt(w.gain_margin_db, 2),
        fmt_opt(w.phase_margin_deg, 1),
        d.kp_max
    );
    let _ = writeln!(s, "conditions at Kp = {:.2}:", d.kp_max);
    let modes = d.conditions.iter().any(|c| c.mode.is_some());
    let _ = writeln!(
        s,
        "  {:>7}{} {:>9} {:>7} {:>9} {:>8} {:>8}  {:>8}  position",
        "x_mm",
        if modes { "  mode" } else { "" },
        "mass_kg",
        "p_bar",
        "beta_bar",
        "GM_dB",
        "PM_deg",
        "kp_max"
    );
    for c in &d.conditions {
        let p = c.p_mean_bar.map_or("-".into(), |p| format!("{p}"));
        let stable = if c.closed_loop_stable {
            ""
        } else {
            "  UNSTABLE"
        };
        let _ = writeln!(
            s,
            "  {:>7.1}{} {:>9.0} {:>7} {:>9.1} {:>8} {:>8}  {:>8.2}  {}{stable}",
            c.x_mm,
            c.mode.map_or(String::new(), |m| format!("{m:>6}")),
            c.mass_kg,
            p,
            c.beta_bar,
            fmt_opt(c.gain_margin_db, 2),
            fmt_opt(c.phase_margin_deg, 1),
            c.kp_max,
            match c.searched {
                None => "checked",
                Some(Searched::PhaseMargin) => "searched: least PM",
                Some(Searched::GainMargin) => "searched: least GM",
            }
        );
    }
    let gain = match d.kp_recommended {
        Some(_) => "the recommended gain",
        None => "Kp max at the design point: no gain meets the targets everywhere",
    };
    for t in &d.tracking {
        let _ = writeln!(
            s,
            "tracking {} Hz ±{} mm at Kp = {:.2} ({gain}): max error {:.2} mm, RMS {:.2} mm, wave reduction {:.2}",
            t.freq_hz, t.amp_mm, d.tracking_kp, t.max_error_mm, t.rms_error_mm, t.wave_reduction
        );
    }
    s + &verdict_lines(d.verdict, &d.reasons)
}

/// `verdict: …` and one line per reason.
fn verdict_lines(verdict: Verdict, reasons: &[String]) -> String {
    let mut s = format!("verdict: {}\n", verdict_text(verdict));
    for r in reasons {
        let _ = writeln!(s, "  - {r}");
    }
    s
}

/// A robust design request (docs/design.md#robust-design): the parameter region of an
/// experiment's records at `confidence` (its rig and its records' pressures), else the stated
/// default region around `rig`; masses × pressures beyond the design's limit only with
/// `allow_long_run`.
pub struct RobustRequest<'a> {
    /// The rig, used when there is no experiment.
    pub rig: &'a Rig,
    /// The experiment whose records give the region, if any, loaded.
    pub experiment: Option<&'a Experiment>,
    /// The confidence of the region.
    pub confidence: f64,
    /// Whether work beyond the design's limit may run.
    pub allow_long_run: bool,
}

/// A robust design with its times: the whole design's and the parameter region's (s).
pub struct RobustRun {
    /// The design.
    pub design: RobustDesign,
    /// The time of the whole design (s).
    pub seconds: f64,
    /// The time the parameter region took (s).
    pub identification_seconds: f64,
}

impl RobustRun {
    /// Its document ([`robust_json`]).
    pub fn document(&self) -> Value {
        robust_json(&self.design, self.seconds, self.identification_seconds)
    }
}

/// The robust design of `request` for `targets` (over the records' pressures when an
/// experiment gives the region), as `design --robust` and Python's `design(robust=True)` run it.
///
/// # Errors
/// A region that cannot be identified, or a design that cannot run.
pub fn robust_run(request: &RobustRequest, targets: &Targets) -> Result<RobustRun, DesignError> {
    let start = Instant::now();
    let (rig, region, targets) = match request.experiment {
        Some(exp) => {
            let (rig, region) = Region::of_records(exp, request.confidence)?;
            (rig, region, targets.clone().over_records(exp))
        }
        None => (
            request.rig.clone(),
            Region::stated_default(request.rig),
            targets.clone(),
        ),
    };
    let identification_seconds = start.elapsed().as_secs_f64();
    let opts = RobustOptions {
        allow_long_run: request.allow_long_run,
        ..RobustOptions::default()
    };
    let design = robust_design(&rig, &region, &targets, &opts)?;
    Ok(RobustRun {
        design,
        seconds: start.elapsed().as_secs_f64(),
        identification_seconds,
    })
}

/// The robust design document (`design --robust --json`, result.json of its folder): every
/// field of the core's [`RobustDesign`], `seconds`, the time of the whole design (s), and
/// `identification_seconds`, the time the parameter region took (s).
pub fn robust_json(d: &RobustDesign, seconds: f64, identification_seconds: f64) -> Value {
    let mut v = serde_json::to_value(d).expect("a robust design serialises");
    v["seconds"] = json!(seconds);
    v["identification_seconds"] = json!(identification_seconds);
    v
}

/// A worst margin as a line of text: `name`, the value with `digits` decimals and its `unit`,
/// `UNSTABLE` if the closed loop is unstable there, and the point where it occurs.
pub fn worst_line(name: &str, unit: &str, w: &Worst, digits: usize) -> String {
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

/// The robust design (docs/design.md#robust-design) as text: the parameter region, the
/// targets, the robust and nominal gains, the worst case at the robust gain, the leakage loop,
/// the verdict and its reasons; `seconds` the time it took (s).
pub fn robust_text(d: &RobustDesign, seconds: f64) -> String {
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
            let p: Vec<String> = t.p_mean_bar.iter().map(|p| format!("{p:.2}")).collect();
            format!(", p {} bar ({})", p.join(", "), anchor_text(t))
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
    s += &verdict_lines(d.verdict, &d.reasons);
    let _ = writeln!(s, "in {seconds:.2} s");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::design::robust::Point;
    use pumpcyl::design::{design, Targets};
    use pumpcyl::rig::Rig;

    #[test]
    fn the_design_text_has_a_row_per_condition_and_ends_with_the_verdict() {
        let d = design(&Rig::default(), &Targets::default()).unwrap();
        let text = design_text("default rig", &d);
        // targets, gains and the binding condition (4), conditions heading and columns (2),
        // conditions, tracking, verdict, reasons
        let want = 6 + d.conditions.len() + d.tracking.len() + 1 + d.reasons.len();
        assert_eq!(text.lines().count(), want, "{text}");
        let verdict = format!("verdict: {}", verdict_text(d.verdict));
        assert_eq!(
            text.lines().nth(want - 1 - d.reasons.len()),
            Some(verdict.as_str())
        );
    }

    #[test]
    fn a_worst_margin_line_says_infinite_and_unstable() {
        let at = Point {
            beta_bar: 165.0,
            viscous_friction_ns_per_m: 2000.0,
            c12_m5_per_ns: 1e-11,
            c1_m5_per_ns: 1e-12,
            c2_m5_per_ns: 1e-12,
            x_mm: -50.0,
            mass_kg: 300.0,
            load_mass_kg: 300.0,
            p_mean_bar: None,
            beta_e_bar: 165.0,
        };
        let w = Worst {
            value: None,
            closed_loop_stable: false,
            at,
        };
        let line = worst_line("GM (dB)", "dB", &w, 2);
        assert!(line.starts_with("  GM (dB)               inf dB UNSTABLE  at beta 165.0 bar"));
        assert!(
            line.ends_with("x -50.0 mm, m 300 kg, beta_e 165.0 bar\n"),
            "{line}"
        );
    }
}
