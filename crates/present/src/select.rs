//! The circuit selection (docs/select.md) as text: one line a candidate, then the answer.

use crate::figures::{trace, Chart, Plot};
use crate::plot::{LineStyle, Panel};
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

/// The selection as a figure: the largest Kp and each wave's tracking-error band against the
/// mean pressure, one colour a circuit (solid: the highest gas fraction, dashed: the lowest),
/// the requirement as a dashed line and the chosen pressure as a dotted vertical.
pub fn selection_chart(app: &Application, s: &Selection) -> Chart {
    let circuits = [Circuit::LowPressure, Circuit::Pressurised];
    let of = |c: Circuit| -> Vec<&pumpcyl::select::Candidate> {
        s.options.iter().filter(|o| o.circuit == c).collect()
    };
    let chosen = s.min_mean_pressure_bar;
    let vertical = |lo: f64, hi: f64| {
        chosen.map(|p| trace("chosen", &[p, p], &[lo, hi], LineStyle::Dotted, Some(6)))
    };
    let mut kp = Panel {
        y_label: "Largest Kp (1/m)".into(),
        traces: Vec::new(),
    };
    for (k, c) in circuits.into_iter().enumerate() {
        let o = of(c);
        let p: Vec<f64> = o.iter().map(|o| o.mean_pressure_bar).collect();
        let y: Vec<f64> = o.iter().map(|o| o.kp_max).collect();
        kp.traces
            .push(trace(circuit_text(c), &p, &y, LineStyle::Solid, Some(k)));
    }
    let top = s.options.iter().map(|o| o.kp_max).fold(0.0, f64::max);
    kp.traces.extend(vertical(0.0, top));
    let mut panels = vec![kp];
    for (w, wave) in app.wave.iter().enumerate() {
        let mut panel = Panel {
            y_label: format!("max |e| (mm), {} Hz ±{} mm", wave.freq_hz, wave.amp_mm),
            traces: Vec::new(),
        };
        let mut all_p = Vec::new();
        for (k, c) in circuits.into_iter().enumerate() {
            let o = of(c);
            let p: Vec<f64> = o.iter().map(|o| o.mean_pressure_bar).collect();
            let band = |i: usize| -> Vec<f64> {
                o.iter()
                    .map(|o| o.tracking_max_error_mm.get(w).map_or(f64::NAN, |e| e[i]))
                    .collect()
            };
            let name = circuit_text(c);
            panel.traces.push(trace(
                &format!("{name}, most air"),
                &p,
                &band(1),
                LineStyle::Solid,
                Some(k),
            ));
            panel.traces.push(trace(
                &format!("{name}, least air"),
                &p,
                &band(0),
                LineStyle::Dashed,
                Some(k),
            ));
            all_p.extend(p);
        }
        let (lo, hi) = all_p
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &p| {
                (l.min(p), h.max(p))
            });
        if lo.is_finite() {
            panel.traces.push(trace(
                "requirement",
                &[lo, hi],
                &[wave.max_error_mm; 2],
                LineStyle::Dashed,
                Some(6),
            ));
        }
        panel.traces.extend(vertical(0.0, 2.0 * wave.max_error_mm));
        panels.push(panel);
    }
    Chart {
        title: "Which circuit: largest Kp and tracking error against the pressure level".into(),
        subtitle: Some(format!(
            "gas fraction {:.4} … {:.4}; {}",
            app.gas_fraction_min,
            app.gas_fraction_max,
            chosen.map_or("no level meets the requirement".to_string(), |p| format!(
                "chosen: {p} bar ({})",
                verdict_text(s.verdict).to_lowercase()
            ))
        )),
        plot: Plot::Xy {
            x_label: "Mean chamber pressure (bar)".into(),
            panels,
        },
    }
}
