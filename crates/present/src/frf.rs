//! A frequency-response estimate (docs/identification.md#frequency-response-from-a-sweep) as
//! text, JSON, CSV and a Bode figure with its 95 % band and the rig's model for comparison
//! (docs/formats.md#frf-outputs).

use crate::plot::{bode_svg, BodeSeries, ReportError};
use crate::table::Table;
use pumpcyl::frf::{Complex64, Design, Estimate, Point, Response};
use pumpcyl::ident::{Candidate, Experiment, FrequencyFit, FrequencyProblem, FrequencyUncertainty};
use serde::Serialize;
use serde_json::json;
use std::fmt::Write;

/// The model's response beside an estimate: its name and H at the estimate's frequencies.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelCurve {
    /// What the model is (the rig and the loop).
    pub label: String,
    /// |H| (dB) at each estimated frequency.
    pub magnitude_db: Vec<f64>,
    /// arg H (deg), unwrapped, at each estimated frequency.
    pub phase_deg: Vec<f64>,
}

/// The JSON document of `pumpcyl frf --json`.
#[derive(Debug, Serialize)]
struct Document<'a> {
    #[serde(flatten)]
    estimate: &'a Estimate,
    confidence: f64,
    band_reference: &'static str,
    model: Option<&'a ModelCurve>,
}

/// Where the band's formula comes from, as the outputs cite it.
pub const BAND_REFERENCE: &str = "Bendat & Piersol, Random Data, 4th ed., Wiley 2010, Table 9.6: \
     eps = sqrt(1 - coherence)/(sqrt(coherence) sqrt(2 n_d)); 95 %: |H|(1 +/- 1.96 eps), phase \
     +/- asin(1.96 eps)";

/// The estimate (and the model beside the closed loop) as a JSON value.
pub fn frf_json(est: &Estimate, model: Option<&ModelCurve>) -> serde_json::Value {
    serde_json::to_value(Document {
        estimate: est,
        confidence: 0.95,
        band_reference: BAND_REFERENCE,
        model,
    })
    .unwrap_or(serde_json::Value::Null)
}

/// The estimate as text: what was estimated and how, one table per response, the warnings.
pub fn frf_text(est: &Estimate) -> String {
    let mut out = format!(
        "{}: {} at {} Hz, {} segments of {} samples ({:.1} independent averages){}\n",
        est.file,
        method_name(est),
        crate::plot::sig(est.rate_hz, 6),
        est.segments,
        est.segment_samples,
        est.averages,
        discarded_text(est)
    );
    let _ = writeln!(
        out,
        "lowest frequency {:.4} Hz: {}",
        est.lowest_frequency_hz, est.lowest_frequency_reason
    );
    for r in std::iter::once(&est.closed_loop).chain(&est.plant) {
        out.push_str(&response_table(r).text());
    }
    for w in &est.warnings {
        let _ = writeln!(out, "warning: {w}");
    }
    out
}

/// The leading periods left out of a periodic sweep, as the text's first line ends.
fn discarded_text(est: &Estimate) -> String {
    match est.method {
        pumpcyl::frf::Method::Periods => {
            let mut text = format!(
                ", {} leading periods left out as not in periodic steady state",
                est.periods_discarded
            );
            if est.pooled_lines > 0 {
                let _ = write!(
                    text,
                    "; each line's noise from its own and {} neighbouring lines' scatter",
                    2 * est.pooled_lines
                );
            }
            text
        }
        _ => String::new(),
    }
}

fn method_name(est: &Estimate) -> &'static str {
    match est.method {
        pumpcyl::frf::Method::WelchHann => "Welch H1, Hann window, half overlap",
        pumpcyl::frf::Method::Periods => "H1 over whole periods, no window",
        pumpcyl::frf::Method::SineFit => "least-squares sine fit per level",
    }
}

/// One response as a table: frequency, |H|, phase, coherence, the band.
fn response_table(r: &Response) -> Table {
    let mut t = Table::new(
        &format!("{} ({}), 95 % band", r.name, r.unit),
        &[
            "freq_hz",
            "magnitude_db",
            "phase_deg",
            "coherence",
            "band_db",
            "band_deg",
        ],
    );
    for p in &r.points {
        t.push(vec![
            format!("{:.4}", p.freq_hz),
            format!("{:.3}", p.magnitude_db),
            format!("{:.2}", p.phase_deg),
            format!("{:.4}", p.coherence),
            format!("±{:.3}", p.band_db),
            format!("±{:.2}", p.band_deg),
        ]);
    }
    t
}

/// The estimate as CSV: one row per frequency, the closed loop's columns and, where estimated,
/// the plant's (`plant_` prefix), then the model's closed loop where given, then the leading
/// periods left out of a periodic sweep (the same on every row).
pub fn frf_csv(est: &Estimate, model: Option<&ModelCurve>) -> String {
    const COLUMNS: [&str; 8] = [
        "magnitude_db",
        "phase_deg",
        "re",
        "im",
        "coherence",
        "relative_error",
        "band_db",
        "band_deg",
    ];
    let mut header = vec!["freq_hz".to_string()];
    header.extend(COLUMNS.iter().map(|c| c.to_string()));
    if est.plant.is_some() {
        header.extend(COLUMNS.iter().map(|c| format!("plant_{c}")));
    }
    if model.is_some() {
        header.extend(["model_magnitude_db".into(), "model_phase_deg".into()]);
    }
    header.push("periods_discarded".into());
    let mut out = header.join(",");
    out.push('\n');
    let cells = |p: &Point| {
        [
            p.magnitude_db,
            p.phase_deg,
            p.re,
            p.im,
            p.coherence,
            p.relative_error,
            p.band_db,
            p.band_deg,
        ]
        .map(|v| format!("{v:.9e}"))
        .join(",")
    };
    for (k, p) in est.closed_loop.points.iter().enumerate() {
        let mut row = format!("{:.9e},{}", p.freq_hz, cells(p));
        if let Some(plant) = &est.plant {
            let _ = write!(row, ",{}", cells(&plant.points[k]));
        }
        if let Some(m) = model {
            let _ = write!(row, ",{:.9e},{:.9e}", m.magnitude_db[k], m.phase_deg[k]);
        }
        let _ = write!(row, ",{}", est.periods_discarded);
        let _ = writeln!(out, "{row}");
    }
    out
}

/// The Bode figure of the closed-loop estimate with its 95 % band (dashed above and below)
/// and the model's response.
pub fn frf_svg(est: &Estimate, model: Option<&ModelCurve>) -> Result<String, ReportError> {
    let points = &est.closed_loop.points;
    let freq_hz: Vec<f64> = points.iter().map(|p| p.freq_hz).collect();
    let curve = |label: &str, sign: f64| BodeSeries {
        label: label.to_string(),
        freq_hz: freq_hz.clone(),
        mag_db: points
            .iter()
            .map(|p| p.magnitude_db + band_db(p, sign))
            .collect(),
        phase_deg: points
            .iter()
            .map(|p| p.phase_deg + sign * p.band_deg)
            .collect(),
    };
    let mut series = vec![curve("estimate x/x_ref", 0.0)];
    if let Some(m) = model {
        series.push(BodeSeries {
            label: m.label.clone(),
            freq_hz: freq_hz.clone(),
            mag_db: m.magnitude_db.clone(),
            phase_deg: m.phase_deg.clone(),
        });
    }
    series.push(curve("95 % band, upper", 1.0));
    series.push(curve("95 % band, lower", -1.0));
    let title = format!(
        "Closed-loop frequency response of {} ({})",
        crate::format::shown_name(&est.file),
        method_name(est)
    );
    bode_svg(&title, &series, &[])
}

/// The magnitude band's edge (dB) on the `sign` side: 20 log10(1 ± 1.96 ε), the lower edge
/// open (−∞ shown as a gap) where 1.96 ε ≥ 1.
fn band_db(p: &Point, sign: f64) -> f64 {
    if sign == 0.0 {
        return 0.0;
    }
    let z = pumpcyl::frf::Z95 * p.relative_error;
    let edge = 1.0 + sign * z;
    if edge > 0.0 {
        20.0 * edge.log10()
    } else {
        f64::NAN
    }
}

/// What the motors' dead band asks of the amplitude, in words: the least amplitude that clears
/// it, or, where the limits allow less (the design then takes the limit), that it needs more.
fn dead_band_text(d: &Design) -> String {
    if d.min_amplitude_mm < d.max_amplitude_mm {
        format!("dead band needs ≥ {:.2}", d.min_amplitude_mm)
    } else {
        "the dead band needs more than the limits allow, see the note below".to_string()
    }
}

/// A designed sweep in words.
pub fn design_text(d: &Design) -> String {
    let mut out = format!(
        "sweep design: crossover {:.3} Hz, resonance {}; band {:.3} … {:.3} Hz; amplitude \
         {:.2} mm ({}, the limits allow ≤ {:.2}, set by {}); a multisine \
         of {} lines on the harmonics of its {:.3} s period; {} averages: {} periods, {:.1} s\n",
        d.crossover_hz,
        d.resonance_hz
            .map_or("none found".to_string(), |f| format!("{f:.3} Hz")),
        d.from_hz,
        d.to_hz,
        d.amplitude_mm,
        dead_band_text(d),
        d.max_amplitude_mm,
        d.amplitude_bound,
        d.lines_held,
        d.period_s,
        d.averages,
        d.periods,
        d.duration_s
    );
    for n in &d.notes {
        let _ = writeln!(out, "note: {n}");
    }
    out
}

/// The model's curve beside `est`: `label`, |H| (dB) and arg H (deg), the phase unwrapped
/// beside the estimate's, from the model's H at each of the estimate's frequencies.
pub fn model_curve(label: String, est: &Estimate, h: &[Complex64]) -> ModelCurve {
    let points = &est.closed_loop.points;
    ModelCurve {
        label,
        magnitude_db: h.iter().map(|h| 20.0 * h.norm().log10()).collect(),
        phase_deg: points
            .iter()
            .zip(h)
            .map(|(p, h)| p.phase_deg + (h / p.h()).arg().to_degrees())
            .collect(),
    }
}

/// The rig's closed loop beside `est` (labelled with the rig's `origin`), its controller
/// sampled at the record's rate as a PLC runs it ([`pumpcyl::frf::sampled_loop_response`],
/// docs/identification.md#grey-box-fit-to-a-frequency-response), linearised about the rest the
/// rig holds ([`rest_plant`]).
pub fn rig_model_curve(
    rig: &pumpcyl::rig::Rig,
    est: &Estimate,
    origin: &str,
) -> Result<ModelCurve, pumpcyl::lti::LtiError> {
    let (plant, about) = rest_plant(rig);
    let freqs: Vec<f64> = est.closed_loop.points.iter().map(|p| p.freq_hz).collect();
    let h = pumpcyl::frf::sampled_loop_response(&plant, rig.sum_pressure, &freqs, est.rate_hz)?;
    let label = format!("model x/x_ref ({origin}; {about})");
    Ok(model_curve(label, est, &h))
}

/// The linear plant about the rest `rig` holds, and what it is in words: its linear model
/// ([`pumpcyl::model::Plant::new`]; the single-pump circuit's in the mode it rests in); for a
/// dual-pump rig whose valves-shut rest opens a check valve ([`model_warning`]), the Jacobian
/// of its emulated equations, every effect off and the valves in, at the rest its loop holds
/// with that valve open ([`pumpcyl::emulator::equilibrium`]); the valves-shut model where that
/// rest cannot be found.
pub fn rest_plant(rig: &pumpcyl::rig::Rig) -> (pumpcyl::model::Plant, String) {
    let plant = pumpcyl::model::Plant::new(rig);
    let about = plant.circuit().describe();
    if model_warning(rig).is_none() {
        return (plant, about);
    }
    match valve_open_jacobian(rig) {
        Some((a, b)) => (
            pumpcyl::model::Plant { a, b, ..plant },
            format!("{about}, linearised at its rest with a check valve open"),
        ),
        None => (plant, format!("{about}, every valve shut")),
    }
}

/// ∂f/∂x, ∂f/∂u of `rig`'s emulated equations (every effect off, valves in) at the rest its
/// loop holds at x0; `None` where it finds none.
fn valve_open_jacobian(
    rig: &pumpcyl::rig::Rig,
) -> Option<(nalgebra::DMatrix<f64>, nalgebra::DMatrix<f64>)> {
    use pumpcyl::circuit::{Circuit, Role};
    let d = pumpcyl::emulator::Dynamics::new(rig, pumpcyl::emulator::Effects::none()).ok()?;
    let x = pumpcyl::emulator::equilibrium(rig, &d, rig.x0_mm).ok()?;
    let c = d.circuit();
    let x_mm = x[c.state_of(Role::Position)?] * 1e3;
    let p_bar: Vec<f64> = (c.states_of(Role::Pressure).iter())
        .map(|&i| x[i] / 1e5)
        .collect();
    let u = c.plc_commands(rig, rig.x0_mm, x_mm, &p_bar);
    Some(pumpcyl::circuit::linearise(c, &x, &u[..c.commands()]))
}

/// A note beside `rig`'s model curve where a dual-pump circuit's valves-shut rest opens a
/// check valve (docs/circuits.md#valves): that model is not the loop the rig runs about its
/// rest, so the curve drawn is the linearisation at the rest with the valve open
/// ([`rest_plant`]). The single-pump circuit's model is already the mode it rests in
/// ([`pumpcyl::circuit::AnyCircuit::describe`]).
pub fn model_warning(rig: &pumpcyl::rig::Rig) -> Option<String> {
    rig.circuit.validate_rest(rig).ok()?;
    let c = pumpcyl::circuit::AnyCircuit::linear(rig);
    let (chamber, p_bar, p_acc_bar, q) = c.valve_open_at_rest()?;
    Some(format!(
        "a check valve is open at rest: the valves-shut linear model rests with chamber \
         {chamber} at {p_bar:.2} bar, below the {p_acc_bar:.2} bar accumulator by more than the \
         valve's cracking pressure ({q:.3e} m³/s through it), so the model drawn is the \
         linearisation at the rest the loop holds with the valve open, which ties the chamber \
         to the accumulator; it holds for small excursions only (load the piston so that both \
         chambers sit within the valves' settings; \
         docs/circuits.md#identification-where-a-valve-is-open)"
    ))
}

/// The fitted model of each sweep of a frequency-domain fit, at the sweep's frequencies; a
/// sweep whose fitted loop cannot be evaluated gets none.
pub fn fitted_curves(problem: &FrequencyProblem, fit: &FrequencyFit) -> Vec<Option<ModelCurve>> {
    problem
        .sweeps
        .iter()
        .map(|s| {
            let freqs: Vec<f64> = s
                .estimate
                .closed_loop
                .points
                .iter()
                .map(|p| p.freq_hz)
                .collect();
            let rig = problem.rig_for(&fit.best, s).ok()?;
            let h = s.model_at(&rig, &freqs)?;
            Some(model_curve(
                format!(
                    "fitted model (beta {:.1} bar, b {:.0} N·s/m, c12 {:.3e} m⁵/(N·s))",
                    fit.best.beta_bar, fit.best.viscous_friction_ns_per_m, fit.best.c12_m5_per_ns
                ),
                &s.estimate,
                &h,
            ))
        })
        .collect()
}

/// The one document of a frequency-domain (or combined) fit, whoever asked for it (`pumpcyl
/// identify --frequency --json`, result.json, Python's `identify(..., method="frequency")`):
/// the answer with its leakages as the step identification's (`beta_bar`,
/// `viscous_friction_ns_per_m`, `c12_m5_per_ns`, `c1_m5_per_ns`, `c2_m5_per_ns`), the best
/// grid point, the costs and their weights, each sweep's part, the warnings, and with the
/// intervals `intervals`, `identifiable`, `profiles`, `confidence`, `chi2_threshold`.
pub fn frequency_document(
    exp: &Experiment,
    fit: &FrequencyFit,
    seconds: f64,
    uncertainty: Option<(&FrequencyUncertainty, f64)>,
) -> serde_json::Value {
    let origin = FitOrigin {
        experiment: exp.path.display().to_string(),
        grids: exp.grids_origin.clone(),
        step_datasets: exp
            .problem
            .datasets
            .iter()
            .map(|d| d.name.clone())
            .collect(),
    };
    frequency_json(&origin, fit, seconds, uncertainty)
}

/// Where a frequency-domain fit's records and grid came from: the experiment file (or what
/// stands for it, e.g. Python's datasets), the grids' description, the step records' names.
#[derive(Debug, Clone)]
pub struct FitOrigin {
    /// The experiment file, or a description of the records given instead.
    pub experiment: String,
    /// How the grids were chosen.
    pub grids: String,
    /// The step records fitted beside the sweeps.
    pub step_datasets: Vec<String>,
}

/// [`frequency_document`] for records from `origin`.
pub fn frequency_json(
    origin: &FitOrigin,
    fit: &FrequencyFit,
    seconds: f64,
    uncertainty: Option<(&FrequencyUncertainty, f64)>,
) -> serde_json::Value {
    let c = &fit.best;
    let mut v = json!({
        "method": "frequency",
        "beta_bar": c.beta_bar,
        "viscous_friction_ns_per_m": c.viscous_friction_ns_per_m,
        "c12_m5_per_ns": c.c12_m5_per_ns,
        "c1_m5_per_ns": fit.leakage.c1_m5_per_ns,
        "c2_m5_per_ns": fit.leakage.c2_m5_per_ns,
        "cost": fit.cost,
        "sweep_weighted_cost": fit.sweep_cost,
        "step_sse_mm2": fit.step_sse_mm2,
        "sweep_cost_scale": fit.scales.sweep_scale,
        "step_noise_var_mm2": fit.scales.step_noise_var_mm2,
        "frequencies": fit.frequencies,
        "candidates_evaluated": fit.evaluated,
        "seconds": seconds,
        "grid_best": fit.grid_best,
        "sweeps": fit.sweeps,
        "step_datasets": origin.step_datasets,
        "experiment": origin.experiment,
        "grids": origin.grids,
        "warnings": fit.warnings,
    });
    if let Some((u, s)) = uncertainty {
        crate::uncertainty::add_profiles_json(&mut v, &u.profiles, "cost");
        v["confidence"] = json!(u.confidence);
        v["chi2_threshold"] = json!(u.threshold);
        v["uncertainty_seconds"] = json!(s);
    }
    crate::uncertainty::add_search_bound_json(&mut v, c);
    v
}

/// A frequency-domain fit as text: the records, the answer, the intervals, the warnings.
pub fn frequency_text(
    exp: &Experiment,
    fit: &FrequencyFit,
    seconds: f64,
    uncertainty: Option<(&FrequencyUncertainty, f64)>,
) -> String {
    let mut s = format!(
        "{}: frequency-domain fit of {} sweep{} ({} usable frequencies){}, {} grid candidates \
         in {seconds:.3} s\n",
        exp.path.display(),
        fit.sweeps.len(),
        if fit.sweeps.len() == 1 { "" } else { "s" },
        fit.frequencies,
        match exp.problem.datasets.len() {
            0 => String::new(),
            n => format!(" with {n} step record{}", if n == 1 { "" } else { "s" }),
        },
        fit.evaluated
    );
    let line = |label: &str, c: &Candidate| {
        let v = pumpcyl::ident::candidate_values(c);
        let shown = |i: usize, text: String| crate::uncertainty::estimate_text(i, v[i], text);
        format!(
            "  {label:<16} beta {}  b {}  c12 {}\n",
            shown(0, format!("{:>8.2} bar", v[0])),
            shown(1, format!("{:>8.1} N·s/m", v[1])),
            shown(2, format!("{:.4e} m⁵/(N·s)", v[2]))
        )
    };
    s += &line("best grid point", &fit.grid_best);
    s += &line("fitted", &fit.best);
    let _ = writeln!(
        s,
        "  leakages         c1 {:.4e}, c2 {:.4e} m⁵/(N·s)",
        fit.leakage.c1_m5_per_ns, fit.leakage.c2_m5_per_ns
    );
    for w in &fit.sweeps {
        let _ = writeln!(
            s,
            "  sweep {}: {} of {} frequencies usable (coherence >= {:.3}), weighted cost {:.4}",
            w.file, w.fitted_frequencies, w.frequencies, w.usable_coherence, w.weighted_cost
        );
        let _ = writeln!(
            s,
            "    lowest frequency fitted {:.4} Hz: {}",
            w.lowest_frequency_hz, w.lowest_frequency_reason
        );
    }
    let _ = writeln!(
        s,
        "  weights          sweeps' cost / {:.4e}{}",
        fit.scales.sweep_scale,
        fit.scales
            .step_noise_var_mm2
            .map_or(String::new(), |v| format!(", steps' SSE / {v:.4e} mm²"))
    );
    if let Some((u, secs)) = uncertainty {
        let _ = writeln!(
            s,
            "{:.0} % profile-likelihood intervals (cost rise <= {:.3}, {secs:.2} s):",
            u.confidence * 100.0,
            u.threshold
        );
        for p in &u.profiles {
            let open = if p.identifiable {
                String::new()
            } else {
                "  (unbounded: the records do not bound it on the side(s) at the search bound)"
                    .to_string()
            };
            let _ = writeln!(
                s,
                "  {:<26} {:.4e} … {:.4e}{open}",
                p.parameter, p.interval[0], p.interval[1]
            );
        }
    }
    for w in &fit.warnings {
        let _ = writeln!(s, "  warning: {w}");
    }
    s
}
