//! The circuit selection (docs/select.md) as text: one line a candidate, then the answer.

use crate::figures::{trace, Chart, Plot};
use crate::format::fmt_short;
use crate::plot::{LineStyle, Panel};
use crate::records::{csv_number, csv_text};
use pumpcyl::select::{
    Application, Candidate, Circuit, GasFractionFrom, Selection, Verdict, REFINE_TOLERANCE_BAR,
    RISE_STEP_MM,
};
use std::fmt::Write;

/// The verdict in the article's words (its §4).
pub fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::LowPressureSuitable => "LOW-PRESSURE CIRCUIT SUITABLE WITH HIGH CERTAINTY",
        Verdict::UsePressurisedCircuit => {
            "UNCERTAIN WITH THE LOW-PRESSURE CIRCUIT: USE THE PRESSURISED CIRCUIT"
        }
        Verdict::LowPressureInsufficient => {
            "THE LOW-PRESSURE CIRCUIT FAILS EVEN IN THE BEST CASE: USE THE PRESSURISED CIRCUIT"
        }
        Verdict::ValveSuitable => "VALVE-CONTROLLED CYLINDER SUITABLE WITH HIGH CERTAINTY",
        Verdict::Uncertain => {
            "UNCERTAIN: MET ONLY IN THE BEST CASE, AT NO LEVEL OVER THE WHOLE RANGE"
        }
        Verdict::NotAchievable => "NOT ACHIEVABLE WITH THESE CIRCUITS, EVEN IN THE BEST CASE",
    }
}

fn circuit_text(c: Circuit) -> &'static str {
    c.name()
}

/// Where the gas-fraction range came from, in words.
pub fn gas_fraction_text(s: &Selection) -> String {
    let [lo, x, hi] = s.gas_fraction;
    let from = match &s.gas_fraction_from {
        GasFractionFrom::Identification(e) => format!(
            "from the identified β {:.1} bar ({:.1} … {:.1} bar, {:.0} % confidence) at the records' mean pressure {:.2} bar",
            e.beta_nominal_bar,
            e.beta_bar[0],
            e.beta_bar[1],
            100.0 * e.confidence,
            e.p_mean_bar
        ),
        GasFractionFrom::Article(r) => format!(
            "from the article's identification, beta {} bar at its records' mean chamber pressure {} bar (a factor 2 either way unless stated)",
            fmt_short(r.beta_bar, 1),
            fmt_short(r.p_mean_bar, 2)
        ),
        GasFractionFrom::Rig(r) => format!(
            "from the rig's beta {} bar at its anchor {} bar, where its loop rests (docs/bulk-modulus.md#the-anchor; a factor 2 either way unless stated)",
            fmt_short(r.beta_bar, 1),
            fmt_short(r.p_mean_bar, 2)
        ),
        GasFractionFrom::Application => "as stated in the application".to_string(),
    };
    format!("gas fraction {x:.4} ({lo:.4} … {hi:.4}), {from}")
}

/// The selection of `app` (from `origin`) as a table and the answer.
pub fn selection_text(origin: &str, app: &Application, s: &Selection) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "circuit selection (docs/select.md) for {origin}: targets PM >= {} deg, GM >= {} dB over x0 ± {} mm",
        app.target_pm_deg, app.target_gm_db, app.stroke_mm
    );
    let _ = writeln!(out, "rig: {}", s.rig.describe());
    let loads: Vec<String> = app.mass_kg.iter().map(|m| format!("{m} kg")).collect();
    let _ = writeln!(
        out,
        "loads: {}",
        if loads.is_empty() {
            format!("the rig's {} kg", app.rig.mass_kg)
        } else {
            loads.join(", ")
        }
    );
    let model = app.rig.bulk_model().unless_the_articles();
    let _ = writeln!(out, "{}{model}", gas_fraction_text(s));
    let mut needs: Vec<String> = app
        .wave
        .iter()
        .map(|w| {
            format!(
                "{} Hz ±{} mm within {} mm",
                w.freq_hz, w.amp_mm, w.max_error_mm
            )
        })
        .collect();
    needs.extend(
        app.max_rise_time_s
            .map(|t| format!("rise time of a {RISE_STEP_MM} mm step within {t} s")),
    );
    let _ = writeln!(out, "requirement: {}", needs.join("; "));
    let _ = writeln!(
        out,
        "  {:<13} {:>8} {:>17} {:>8} {:>9} {:>22} {:>12} {:>10} {:>22}  {:<5} {:<9} reason",
        "circuit",
        "p (bar)",
        "beta_e (bar)",
        "Kp max",
        "Kv (1/s)",
        "max |e| (mm)",
        "rise (s)",
        "loss (W)",
        "switches (settled, mm)",
        "meets",
        "best case"
    );
    for c in &s.options {
        let worst: Vec<String> = c
            .tracking_max_error_mm
            .iter()
            .map(|[lo, hi]| format!("{lo:.1}…{hi:.1}"))
            .collect();
        let rise = c
            .rise_time_s
            .map_or("-".to_string(), |[lo, hi]| format!("{lo:.2}…{hi:.2}"));
        let _ = writeln!(
            out,
            "  {:<13} {:>8.1} {:>17} {:>8} {:>9} {:>22} {:>12} {:>10} {:>22}  {:<5} {:<9} {}",
            circuit_text(c.circuit),
            c.mean_pressure_bar,
            format!("{:.0} … {:.0}", c.beta_e_bar[0], c.beta_e_bar[1]),
            // no gain meets the targets: no number (the reason says so)
            if c.kp_max > 0.0 {
                format!("{:.2}", c.kp_max)
            } else {
                "-".to_string()
            },
            c.kv_max_per_s
                .map_or("-".to_string(), |kv| format!("{kv:.3}")),
            if worst.is_empty() {
                "-".to_string()
            } else {
                worst.join(", ")
            },
            rise,
            c.standing_loss_w
                .map_or("-".to_string(), |w| format!("{w:.1}")),
            mode_check_text(c),
            if c.meets { "yes" } else { "no" },
            if c.meets_best_case { "yes" } else { "no" },
            c.reason
        );
    }
    out += &rest_offset_text(s);
    let _ = writeln!(
        out,
        "lowest level (mean chamber pressure, pre-charge or supply) meeting the requirement over the whole uncertainty: {}",
        lowest_text(s)
    );
    if let Some(c) = &s.at_min_mean_pressure {
        let (name, kind) = (c.circuit.name(), c.circuit.kind.name());
        let kind = if name == kind {
            String::new()
        } else {
            format!(" ({kind})")
        };
        let _ = writeln!(
            out,
            "answer: the {name} circuit{kind} at {:.2} bar",
            c.mean_pressure_bar
        );
    }
    if s.options.iter().any(|c| c.circuit.kind.has_modes()) {
        let _ = writeln!(
            out,
            "single-pump mode check: {} (switches over its runs; after the step settled and beyond a wave's reference; the step's oscillation amplitude; docs/select.md#the-single-pump-circuit)",
            s.mode_check
        );
    }
    let _ = writeln!(out, "verdict: {}", verdict_text(s.verdict));
    for r in &s.reasons {
        let _ = writeln!(out, "  - {r}");
    }
    out
}

/// The largest rest offset in the candidates' errors, in a line (empty when none has one):
/// the standing error the P law needs at rest (docs/simulation.md#the-rest-under-load).
fn rest_offset_text(s: &Selection) -> String {
    let largest = (s.options.iter())
        .filter_map(|c| c.rest_offset_mm.map(|[lo, hi]| (lo.abs().max(hi.abs()), c)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    largest.map_or(String::new(), |(mm, c)| {
        format!(
            "max |e| holds the loop's rest offset, the standing error with which the P law holds the load \
             and feeds the leakage: up to {mm:.2} mm (the {} circuit at {:.2} bar; docs/simulation.md#the-rest-under-load)\n",
            c.circuit.name(),
            c.mean_pressure_bar
        )
    })
}

/// A candidate's mode check in a cell: its switches, those after settling and the step's
/// oscillation amplitude (mm), `12 (0, ±0.243)`; `-` where the check did not run.
fn mode_check_text(c: &Candidate) -> String {
    match (
        c.mode_switches,
        c.switches_after_settling,
        c.oscillation_amplitude_mm,
    ) {
        (Some(n), Some(after), Some(mm)) => format!("{n} ({after}, ±{mm:.3})"),
        _ => "-".to_string(),
    }
}

/// The selection's options as CSV (`options.csv` of `select --out`): one row a candidate,
/// `circuit,mean_pressure_bar,kp_max,kv_max_per_s,standing_loss_w,mode_switches,switches_after_settling,
/// oscillation_amplitude_mm,meets,meets_best_case,reason`, numbers in the records' format
/// ([`csv_number`]); an empty cell where there is no number (no gain, no check).
pub fn selection_csv(s: &Selection) -> String {
    let header = [
        "circuit",
        "mean_pressure_bar",
        "kp_max",
        "kv_max_per_s",
        "standing_loss_w",
        "mode_switches",
        "switches_after_settling",
        "oscillation_amplitude_mm",
        "meets",
        "meets_best_case",
        "reason",
    ]
    .map(String::from);
    let opt = |v: Option<f64>| v.map_or(String::new(), csv_number);
    let count = |v: Option<usize>| v.map_or(String::new(), |n| n.to_string());
    let cells = |c: &Candidate| {
        [
            c.circuit.key().to_string(),
            csv_number(c.mean_pressure_bar),
            opt((c.kp_max > 0.0).then_some(c.kp_max)),
            opt(c.kv_max_per_s),
            opt(c.standing_loss_w),
            count(c.mode_switches),
            count(c.switches_after_settling),
            opt(c.oscillation_amplitude_mm),
            c.meets.to_string(),
            c.meets_best_case.to_string(),
            c.reason.clone(),
        ]
    };
    csv_text(&header, s.options.iter().map(cells))
}

/// The lowest mean pressure in words: the refined answer, its bracket and the level grid's.
pub fn lowest_text(s: &Selection) -> String {
    match (s.min_mean_pressure_bar, s.min_level_bar) {
        (Some(p), Some(level)) => match s.min_mean_pressure_bracket_bar {
            Some([lo, hi]) => format!(
                "{p:.2} bar (bisected between the levels to {REFINE_TOLERANCE_BAR} bar: fails at {lo:.3}, meets at {hi:.3} bar; the lowest level tried that meets: {level} bar)"
            ),
            None => format!("{p} bar (the lowest level tried; none below it to refine against)"),
        },
        _ => "none".to_string(),
    }
}

/// The selection as a figure: the largest Kp (over the whole gas-fraction range, solid, and at
/// the reference gas fraction, dotted), each wave's tracking-error band and, when required, the
/// rise-time band against the mean pressure, one colour a circuit in every panel (solid: the
/// worst case over the uncertainty, dashed: the best, as a legend note says), the requirement as
/// a dash-dot line and the lowest meeting candidate (bisected between the levels) as a black
/// circle on its solid curve in every panel.
/// Within the figure each line style has one meaning: dotted only the reference gas fraction,
/// dashed only the best case, dash-dot only the requirement.
pub fn selection_chart(app: &Application, s: &Selection) -> Chart {
    let chosen_at = s.at_min_mean_pressure.as_ref();
    let mut kp = Panel {
        y_label: "Largest Kp (1/m)".into(),
        traces: Vec::new(),
        ..Default::default()
    };
    for (k, c) in present(s) {
        let (p, o) = of_circuit(s, c);
        let y: Vec<f64> = o.iter().map(|o| o.kp_max).collect();
        kp.traces
            .push(trace(circuit_text(c), &p, &y, LineStyle::Solid, Some(k)));
        let y: Vec<f64> = o.iter().map(|o| o.kp_max_reference).collect();
        kp.traces
            .push(trace("", &p, &y, LineStyle::Dotted, Some(k)));
    }
    kp.traces.push(note(
        "solid: over the gas-fraction range; dotted: at the reference gas fraction",
    ));
    kp.traces
        .extend(chosen_at.and_then(|o| chosen_marker(o.mean_pressure_bar, Some(o.kp_max))));
    let mut panels = vec![kp];
    for (w, wave) in app.wave.iter().enumerate() {
        panels.push(band_panel(
            s,
            format!("max |e| (mm), {} Hz ±{} mm", wave.freq_hz, wave.amp_mm),
            &|o| o.tracking_max_error_mm.get(w).copied(),
            wave.max_error_mm,
        ));
    }
    if let Some(max) = app.max_rise_time_s {
        panels.push(band_panel(
            s,
            format!("Rise time (s), {RISE_STEP_MM} mm step"),
            &|o| o.rise_time_s,
            max,
        ));
    }
    Chart {
        title: "Which circuit: largest Kp and tracking error against the pressure level".into(),
        subtitle: Some(format!(
            "gas fraction {:.4} … {:.4}; {}",
            s.gas_fraction[0],
            s.gas_fraction[2],
            chosen_at.map_or("no level meets the requirement".to_string(), |c| format!(
                "lowest: the {} circuit at {:.2} bar ({})",
                c.circuit.name(),
                c.mean_pressure_bar,
                verdict_text(s.verdict).to_lowercase()
            ))
        )),
        plot: Plot::Xy {
            x_label: "Pressure level (bar): the DPM's mean chamber pressure, a one-motor circuit's pre-charge".into(),
            panels,
        },
    }
}

/// The circuits with a candidate in `s`, each with its colour (its place in
/// [`Circuit::all`], so a circuit keeps its colour whichever others are tried;
/// docs/select.md#circuits).
fn present(s: &Selection) -> impl Iterator<Item = (usize, Circuit)> + '_ {
    (Circuit::all().into_iter().enumerate())
        .filter(|(_, c)| s.options.iter().any(|o| o.circuit == *c))
}

/// The candidates of circuit `c` and their mean pressures (bar).
fn of_circuit(s: &Selection, c: Circuit) -> (Vec<f64>, Vec<&Candidate>) {
    let o: Vec<&Candidate> = s.options.iter().filter(|o| o.circuit == c).collect();
    (o.iter().map(|o| o.mean_pressure_bar).collect(), o)
}

/// A legend line without a curve: what the line styles of a panel mean.
fn note(text: &str) -> crate::plot::Trace {
    trace(text, &[], &[], LineStyle::Solid, None)
}

/// The chosen candidate, at mean pressure `p` (bar) and the value `y` of a panel, as a black
/// circle (none where the candidate has no value there).
fn chosen_marker(p: f64, y: Option<f64>) -> Option<crate::plot::Trace> {
    let y = y.filter(|y| y.is_finite())?;
    Some(trace("chosen", &[p], &[y], LineStyle::Markers, Some(6)))
}

/// A panel of a [least, most] band per candidate (`band`; NaN where absent) against the mean
/// pressure, one colour a circuit, with the requirement `limit` and the chosen candidate's
/// worst case.
fn band_panel(
    s: &Selection,
    y_label: String,
    band: &dyn Fn(&Candidate) -> Option<[f64; 2]>,
    limit: f64,
) -> Panel {
    let mut panel = Panel {
        y_label,
        traces: Vec::new(),
        ..Default::default()
    };
    for (k, c) in present(s) {
        let (p, o) = of_circuit(s, c);
        let end = |i: usize| -> Vec<f64> {
            o.iter()
                .map(|o| band(o).map_or(f64::NAN, |b| b[i]))
                .map(|v| if v.is_finite() { v } else { f64::NAN })
                .collect()
        };
        panel.traces.push(trace(
            circuit_text(c),
            &p,
            &end(1),
            LineStyle::Solid,
            Some(k),
        ));
        panel
            .traces
            .push(trace("", &p, &end(0), LineStyle::Dashed, Some(k)));
    }
    panel.traces.push(note(
        "solid: worst case over the gas fraction and loads; dashed: best case",
    ));
    let (lo, hi) = s
        .options
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), o| {
            (l.min(o.mean_pressure_bar), h.max(o.mean_pressure_bar))
        });
    if lo.is_finite() {
        panel.traces.push(trace(
            "requirement",
            &[lo, hi],
            &[limit; 2],
            LineStyle::DashDot,
            Some(7),
        ));
    }
    let chosen = s.at_min_mean_pressure.as_ref();
    panel
        .traces
        .extend(chosen.and_then(|o| chosen_marker(o.mean_pressure_bar, band(o).map(|b| b[1]))));
    panel
}
