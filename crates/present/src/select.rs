//! The circuit selection (docs/select.md) as text: one line a candidate, then the answer.

use pumpcyl::select::{Application, Circuit, Selection, Verdict};
use std::fmt::Write;

/// The verdict in the article's words (its §4).
pub fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::LowPressureSuitable => "LOW-PRESSURE CIRCUIT SUITABLE WITH HIGH CERTAINTY",
        Verdict::UsePressurisedCircuit => {
            "UNCERTAIN WITH THE LOW-PRESSURE CIRCUIT: USE THE PRESSURISED CIRCUIT"
        }
        Verdict::NotAchievable => "NOT ACHIEVABLE WITH THESE CIRCUITS",
    }
}

fn circuit_text(c: Circuit) -> &'static str {
    match c {
        Circuit::LowPressure => "low-pressure",
        Circuit::Pressurised => "pressurised",
    }
}

/// The selection of `app` (from `origin`) as a table and the answer.
pub fn selection_text(origin: &str, app: &Application, s: &Selection) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "circuit selection (docs/select.md) for {origin}: gas fraction {:.4} ({:.4} … {:.4}), targets PM >= {} deg, GM >= {} dB over x0 ± {} mm",
        app.gas_fraction, app.gas_fraction_min, app.gas_fraction_max, app.target_pm_deg, app.target_gm_db, app.stroke_mm
    );
    let waves: Vec<String> = app
        .wave
        .iter()
        .map(|w| {
            format!(
                "{} Hz ±{} mm within {} mm",
                w.freq_hz, w.amp_mm, w.max_error_mm
            )
        })
        .collect();
    let _ = writeln!(out, "requirement: {}", waves.join("; "));
    let _ = writeln!(
        out,
        "  {:<13} {:>8} {:>17} {:>8} {:>22} {:>10}  {:<5} reason",
        "circuit", "p (bar)", "beta_e (bar)", "Kp max", "max |e| (mm), worst", "loss (W)", "meets"
    );
    for c in &s.options {
        let worst: Vec<String> = c
            .tracking_max_error_mm
            .iter()
            .map(|[lo, hi]| format!("{lo:.1}…{hi:.1}"))
            .collect();
        let _ = writeln!(
            out,
            "  {:<13} {:>8.1} {:>17} {:>8.2} {:>22} {:>10.1}  {:<5} {}",
            circuit_text(c.circuit),
            c.mean_pressure_bar,
            format!("{:.0} … {:.0}", c.beta_e_bar[0], c.beta_e_bar[1]),
            c.kp_max,
            if worst.is_empty() {
                "-".to_string()
            } else {
                worst.join(", ")
            },
            c.standing_loss_w,
            if c.meets { "yes" } else { "no" },
            c.reason
        );
    }
    let _ = writeln!(
        out,
        "lowest mean pressure meeting the requirement over the whole uncertainty: {}",
        s.min_mean_pressure_bar
            .map_or("none".to_string(), |p| format!("{p} bar"))
    );
    let _ = writeln!(out, "verdict: {}", verdict_text(s.verdict));
    for r in &s.reasons {
        let _ = writeln!(out, "  - {r}");
    }
    out
}
