//! The frequency analyses as every front end shows them (docs/analysis.md): margins as a JSON
//! document and as text, poles as JSON and text, Bode data as CSV, the model as text.
//!
//! One convention for margins everywhere (command line, summary.json, Python): a margin is a
//! number, or `null` (Python `None`) when it is infinite because there is no crossing of that
//! kind; a crossover frequency is `null` where there is no crossing. A NaN is never written.

use crate::format::fmt_opt;
use crate::plot::BodeSeries;
use crate::records::{csv_number, csv_text};
use nalgebra::DMatrix;
use pumpcyl::circuit::single_pump::modes::{linear_models, switching, ModeModel, Switching};
use pumpcyl::loops::{Loop, ModelView, Port, SimulatedLoop};
use pumpcyl::lti::{
    poles_and_stability, CrossingKind, LtiError, Margins, PoleInfo, Stability, RELIABLE_DB,
    RELIABLE_DEG,
};
use serde::Serialize;
use serde_json::{json, Value};
use std::fmt::Write as _;

/// The margins of a loop with what the loop is: the core's [`Margins`], every field of it, and
/// `loop`, the loop in words.
#[derive(Debug, Clone, Serialize)]
pub struct MarginsReport<'a> {
    /// What was analysed, in words.
    #[serde(rename = "loop")]
    pub description: &'a str,
    /// The margins, every crossing, stability.
    #[serde(flatten)]
    pub margins: &'a Margins,
    /// The closed loop as simulated (sum-pressure loop closed as well), where it differs from
    /// the one `closed_loop_stability` is read on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub simulated_closed_loop: Option<SimulatedLoop>,
}

/// The margins of the loop `description` as a JSON document (the command line's
/// `margins --json`, Python's `margins`).
pub fn margins_json(m: &Margins, description: &str) -> serde_json::Value {
    report_json(m, description, None)
}

/// The margins of the analysed loop `lp` as a JSON document, with the stability of the loop as
/// simulated where it differs (`simulated_closed_loop`).
pub fn loop_margins_json(m: &Margins, lp: &Loop) -> Result<serde_json::Value, LtiError> {
    Ok(report_json(m, &lp.description, lp.simulated()?))
}

fn report_json(m: &Margins, description: &str, simulated: Option<SimulatedLoop>) -> Value {
    serde_json::to_value(MarginsReport {
        description,
        margins: m,
        simulated_closed_loop: simulated,
    })
    .expect("margins serialise")
}

/// The margins of the analysed loop `lp` as text, with a line on the loop as simulated where it
/// differs ([`margins_text`]).
pub fn loop_margins_text(m: &Margins, lp: &Loop) -> Result<String, LtiError> {
    let mut s = margins_text(m, &lp.description);
    if let Some(sim) = lp.simulated()? {
        let line = simulated_line(&sim);
        let at = s.find("crossings (").unwrap_or(s.len());
        s.insert_str(at, &line);
    }
    Ok(s)
}

/// The stability of the loop as simulated, in one line: which loop, and the rightmost pole when
/// it is not stable.
fn simulated_line(sim: &SimulatedLoop) -> String {
    let [re, im] = sim.rightmost_pole;
    let pole = format!(
        "a pole at {re:+.4} ±{im:.4}j rad/s, {:.3} Hz",
        sim.rightmost_pole_hz
    );
    let verdict = match sim.stability {
        Stability::Stable => "stable".to_string(),
        Stability::Unstable => format!("UNSTABLE: {pole}"),
        Stability::Integrator => "INTEGRATOR: a pole at the origin, the others stable".to_string(),
        Stability::Undecided => format!("UNDECIDED: {pole}, within rounding of the imaginary axis"),
    };
    format!(
        "  as simulated  {verdict} (sum-pressure loop closed as well, as `pumpcyl step` runs it)\n"
    )
}

/// The margins of the loop `description` as text: the headline margins, stability and every
/// crossing.
pub fn margins_text(m: &Margins, description: &str) -> String {
    let at = |f: Option<f64>, what: &str| {
        f.map_or(format!("(no {what})"), |f| format!("at {f:.4} Hz ({what})"))
    };
    let mut s = String::new();
    let _ = writeln!(s, "{description}");
    let _ = writeln!(
        s,
        "  gain margin   {:>9} dB  {}",
        fmt_opt(m.gain_margin_db, 2),
        at(m.phase_crossover_hz, "phase crossover")
    );
    let _ = writeln!(
        s,
        "  phase margin  {:>9} deg {}",
        fmt_opt(m.phase_margin_deg, 2),
        at(m.gain_crossover_hz, "gain crossover")
    );
    let _ = writeln!(s, "  delay margin  {:>9} s", fmt_opt(m.delay_margin_s, 4));
    if let Some(kv) = m.velocity_gain_per_s {
        let _ = writeln!(
            s,
            "  velocity gain {kv:>9.4} 1/s Kv: steady piston velocity per metre of error"
        );
    }
    if m.ill_conditioned {
        let _ = writeln!(
            s,
            "  WARNING       ill-conditioned model: double precision does not resolve the margins \
             to 0.01 (error bounds below; docs/analysis.md#conditioning)"
        );
    }
    let verdict = match m.closed_loop_stability {
        Stability::Stable => "stable",
        Stability::Unstable => "UNSTABLE",
        Stability::Integrator => "INTEGRATOR: a pole at the origin, the others stable",
        Stability::Undecided => "UNDECIDED: a pole lies within rounding of the imaginary axis",
    };
    let _ = writeln!(
        s,
        "  closed loop   {verdict} (position feedback around the analysed loop; from its eigenvalues)"
    );
    let _ = writeln!(s, "crossings ({}):", m.crossings.len());
    let _ = writeln!(s, "  kind    freq_hz    |L|_db   phase_deg  margin");
    for c in &m.crossings {
        let (kind, margin) = match c.kind {
            CrossingKind::Gain => (
                "gain",
                format!(
                    "PM {:.2} deg, delay margin {} s",
                    c.margin,
                    fmt_opt(c.delay_margin_s, 4)
                ),
            ),
            CrossingKind::Phase => ("phase", format!("GM {:.2} dB", c.margin)),
        };
        let limit = match c.kind {
            CrossingKind::Gain => RELIABLE_DEG,
            CrossingKind::Phase => RELIABLE_DB,
        };
        let margin = if c.margin_error_bound > limit {
            format!("{margin} (ill-conditioned: ±{:.3e})", c.margin_error_bound)
        } else {
            margin
        };
        let _ = writeln!(
            s,
            "  {kind:<6} {:>9.4} {:>9.2} {:>11.2}  {margin}",
            c.frequency_hz, c.magnitude_db, c.phase_deg
        );
    }
    s
}

/// Which poles of a loop a [`PoleSet`] holds (docs/analysis.md#poles-and-damping).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoleSetKind {
    /// The eigenvalues of the analysed loop transfer L(s).
    OpenLoop,
    /// The poles of unity position feedback around L(s).
    ClosedLoop,
    /// The closed loop with the sum-pressure loop closed as well: the controller as simulated.
    ClosedLoopWithSumPressure,
}

impl PoleSetKind {
    /// The set's key in the poles document (`open_loop`, `closed_loop`,
    /// `closed_loop_with_sum_pressure`).
    pub fn key(self) -> &'static str {
        match self {
            PoleSetKind::OpenLoop => "open_loop",
            PoleSetKind::ClosedLoop => "closed_loop",
            PoleSetKind::ClosedLoopWithSumPressure => "closed_loop_with_sum_pressure",
        }
    }

    /// What the set is, in words.
    pub fn description(self) -> &'static str {
        match self {
            PoleSetKind::OpenLoop => "open loop (the analysed L(s))",
            PoleSetKind::ClosedLoop => "closed loop (unity position feedback around L(s))",
            PoleSetKind::ClosedLoopWithSumPressure => {
                "closed loop with the sum-pressure loop as well (the controller as simulated)"
            }
        }
    }
}

/// A set of poles with their natural frequencies (Hz) and damping ratios, and their stability
/// decided against rounding (docs/analysis.md#poles-and-damping).
#[derive(Debug, Clone, PartialEq)]
pub struct PoleSet {
    /// Which poles.
    pub kind: PoleSetKind,
    /// The poles (real part 1/s, imaginary part rad/s).
    pub poles: Vec<PoleInfo>,
    /// Stable, unstable, an integrator (poles at the origin, the others stable), or undecided
    /// (another pole within rounding of the imaginary axis).
    pub stability: Stability,
}

impl PoleSet {
    /// The set `kind`: the eigenvalues of the system matrix `a` and their stability.
    pub fn of(kind: PoleSetKind, a: &DMatrix<f64>) -> Result<PoleSet, LtiError> {
        let (poles, stability) = poles_and_stability(a)?;
        Ok(PoleSet {
            kind,
            poles: poles.into_iter().map(PoleInfo::from).collect(),
            stability,
        })
    }
}

/// The pole sets of the analysed loop `lp`: its open loop, unity position feedback around it,
/// and, where the rig's controller closes the sum-pressure loop that `lp` leaves open, the
/// closed loop as simulated.
///
/// # Errors
/// The eigenvalues cannot be computed.
pub fn loop_pole_sets(lp: &Loop) -> Result<Vec<PoleSet>, LtiError> {
    let mut sets = vec![
        PoleSet::of(PoleSetKind::OpenLoop, &lp.open_loop.a)?,
        PoleSet::of(PoleSetKind::ClosedLoop, &lp.open_loop.unity_feedback()?.a)?,
    ];
    if let Some(rig) = lp.simulated_rig() {
        let full = pumpcyl::model::Plant::new(rig).closed_loop(true);
        sets.push(PoleSet::of(
            PoleSetKind::ClosedLoopWithSumPressure,
            &full.a,
        )?);
    }
    Ok(sets)
}

/// The poles document (`poles --json`): `loop`, the loop in words, and per set its key (the
/// core's [`PoleInfo`] of every pole), `<key>_stable` (true only when provably asymptotically
/// stable) and `<key>_stability` (`stable`, `unstable`, `integrator` or `undecided`).
pub fn poles_json(description: &str, sets: &[PoleSet]) -> Value {
    let mut v = json!({"loop": description});
    for set in sets {
        let key = set.kind.key();
        v[key] = json!(set.poles);
        v[format!("{key}_stable")] = json!(set.stability == Stability::Stable);
        v[format!("{key}_stability")] = json!(set.stability);
    }
    v
}

/// The poles as text: the loop, then per set its stability and a table of the poles (real part
/// 1/s, imaginary part rad/s, natural frequency Hz, damping ratio; `-` for a pole at the origin).
pub fn poles_text(description: &str, sets: &[PoleSet]) -> String {
    let mut s = format!("{description}\n");
    for set in sets {
        let verdict = match set.stability {
            Stability::Stable => "asymptotically stable",
            Stability::Unstable => "not asymptotically stable (a pole right of the imaginary axis)",
            Stability::Integrator => {
                "an integrator: a pole at the origin (exactly 0 or within 100 rounding radii of \
                 it), every other pole asymptotically stable"
            }
            Stability::Undecided => {
                "undecided: a pole lies within rounding of the imaginary axis (an undamped mode; \
                 not provably asymptotically stable)"
            }
        };
        let _ = writeln!(s, "\n{}: {verdict}", set.kind.description());
        let _ = writeln!(
            s,
            "  {:>14} {:>14} {:>12} {:>9}",
            "re_1_per_s", "im_rad_per_s", "f_n_hz", "damping"
        );
        for q in &set.poles {
            let damping = q.damping.map_or("-".to_string(), |z| format!("{z:.4}"));
            let _ = writeln!(
                s,
                "  {:>14.6} {:>14.6} {:>12.5} {:>9}",
                q.re, q.im, q.natural_freq_hz, damping
            );
        }
    }
    s
}

/// The single-pump circuit's two modes as `margins` and `poles` report them
/// (docs/circuits.md#modes-in-margins-and-poles): where the circuit switches, where the rig's
/// load puts it, and each mode's own loop e → x at its operating point.
#[derive(Debug, Clone)]
pub struct ModesReport {
    /// The switching force, the mode at rest and how far the load's force is from switching.
    pub switching: Switching,
    /// Both modes, mode 1 first.
    pub modes: Vec<ModeModel>,
}

impl ModesReport {
    /// The modes of the loop `lp` when it is a single-pump rig's; `None` for another circuit or
    /// a model read from JSON.
    ///
    /// # Errors
    /// A mode's model [`pumpcyl::lti::StateSpace::new`] refuses.
    pub fn of_loop(lp: &Loop) -> Result<Option<ModesReport>, LtiError> {
        let Some(rig) = (lp.rig.as_ref()).filter(|r| r.circuit.has_modes()) else {
            return Ok(None);
        };
        Ok(Some(ModesReport {
            switching: switching(rig),
            modes: linear_models(rig)?.to_vec(),
        }))
    }

    /// A mode in words: `mode 2 (chamber 1 at the accumulator pressure), the mode at rest`.
    fn describe(m: &ModeModel) -> String {
        format!(
            "mode {} (chamber {} at the accumulator pressure){}",
            m.mode,
            m.accumulator_chamber,
            if m.at_rest { ", the mode at rest" } else { "" }
        )
    }

    /// The keys a mode's object starts with: `mode`, `accumulator_chamber`, `at_rest`, `loop`.
    fn head(m: &ModeModel) -> Value {
        json!({
            "mode": m.mode,
            "accumulator_chamber": m.accumulator_chamber,
            "at_rest": m.at_rest,
            "loop": Self::describe(m),
        })
    }

    /// The switching fields ([`Switching`], `switching_force_n` and the distance of the load's
    /// force from it) and `modes`, one object per mode made by `fields` from its loop.
    fn document(
        &self,
        fields: impl Fn(&ModeModel) -> Result<Value, LtiError>,
    ) -> Result<Value, LtiError> {
        let mut doc = serde_json::to_value(self.switching).expect("the switching serialises");
        let modes = (self.modes.iter())
            .map(|m| Ok(merged(Self::head(m), fields(m)?)))
            .collect::<Result<Vec<Value>, LtiError>>()?;
        doc["modes"] = Value::Array(modes);
        Ok(doc)
    }

    /// The margins document's modes part: per mode `accumulator_chamber`, `at_rest` and every
    /// margin field of `margins --json` ([`Margins`]) of its own loop.
    ///
    /// # Errors
    /// A mode's margins cannot be computed.
    pub fn margins_json(&self) -> Result<Value, LtiError> {
        self.document(|m| {
            Ok(serde_json::to_value(pumpcyl::lti::margins(&m.open_loop)?)
                .expect("margins serialise"))
        })
    }

    /// The poles document's modes part: per mode its open-loop and closed-loop poles as
    /// [`poles_json`] gives them.
    ///
    /// # Errors
    /// A mode's poles cannot be computed.
    pub fn poles_json(&self) -> Result<Value, LtiError> {
        self.document(|m| Ok(poles_json(&Self::describe(m), &mode_pole_sets(m)?)))
    }

    /// The switching force and where the load is, in words (the text outputs' header of the
    /// modes).
    fn switching_text(&self) -> String {
        let s = &self.switching;
        let side = if s.force_from_switching_n >= 0.0 {
            "above"
        } else {
            "below"
        };
        format!(
            "\nsingle-pump modes (docs/circuits.md#modes-in-margins-and-poles): switching force \
             p_acc (A1 - A2) = {:.2} N; the external force {:.2} N lies {:.2} N {side} it \
             (mode {} at rest); a load acceleration of {:+.4} m/s^2 brings the pressures' force \
             to it{}\n",
            s.switching_force_n,
            s.external_force_n,
            s.force_from_switching_n.abs(),
            s.mode_at_rest,
            s.acceleration_to_switch_m_per_s2,
            if s.within_valve_band {
                "; inside the check valves' band, the mode at rest depends on the way there"
            } else {
                ""
            }
        )
    }

    /// Both modes' margins as text ([`margins_text`] of each mode's loop).
    ///
    /// # Errors
    /// A mode's margins cannot be computed.
    pub fn margins_text(&self) -> Result<String, LtiError> {
        let mut s = self.switching_text();
        for m in &self.modes {
            let margins = pumpcyl::lti::margins(&m.open_loop)?;
            s += &margins_text(&margins, &Self::describe(m));
        }
        Ok(s)
    }

    /// Both modes' poles as text ([`poles_text`] of each mode's sets).
    ///
    /// # Errors
    /// A mode's poles cannot be computed.
    pub fn poles_text(&self) -> Result<String, LtiError> {
        let mut s = self.switching_text();
        for m in &self.modes {
            s += &poles_text(&Self::describe(m), &mode_pole_sets(m)?);
        }
        Ok(s)
    }
}

/// A mode's open-loop poles and the poles of unity position feedback around its loop.
fn mode_pole_sets(m: &ModeModel) -> Result<[PoleSet; 2], LtiError> {
    Ok([
        PoleSet::of(PoleSetKind::OpenLoop, &m.open_loop.a)?,
        PoleSet::of(PoleSetKind::ClosedLoop, &m.open_loop.unity_feedback()?.a)?,
    ])
}

/// The object `a` with the keys of the object `b` added (b's win).
pub fn merged(mut a: Value, b: Value) -> Value {
    if let (Some(a), Value::Object(b)) = (a.as_object_mut(), b) {
        a.extend(b);
    }
    a
}

/// Bode data as CSV (docs/analysis.md#bode-diagrams): `freq_hz` (Hz), then `mag_db` (dB) and
/// `phase_deg` (deg) of the first series and `mag_db[label],phase_deg[label]` of each further
/// one (a label with a comma quoted, as any CSV cell); every series on the first one's
/// frequencies, values in the records' number format ([`csv_number`]).
pub fn bode_csv(series: &[BodeSeries]) -> String {
    let mut header = vec!["freq_hz".to_string()];
    for (i, ser) in series.iter().enumerate() {
        if i == 0 {
            header.extend(["mag_db".into(), "phase_deg".into()]);
        } else {
            let label = &ser.label;
            header.extend([format!("mag_db[{label}]"), format!("phase_deg[{label}]")]);
        }
    }
    let rows = series[0].freq_hz.iter().enumerate().map(|(k, f)| {
        let values = series
            .iter()
            .flat_map(|ser| [ser.mag_db[k], ser.phase_deg[k]]);
        std::iter::once(*f)
            .chain(values)
            .map(csv_number)
            .collect::<Vec<_>>()
    });
    csv_text(&header, rows)
}

/// The model as text: what it is, its inputs and outputs with their units, the states, and the
/// matrices A, B, C, D (SI) row by row.
pub fn model_text(view: &ModelView) -> String {
    let plural = |p: &[Port]| if p.len() > 1 { "s" } else { "" };
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
    let sys = &view.sys;
    for (name, m) in [("A", &sys.a), ("B", &sys.b), ("C", &sys.c), ("D", &sys.d)] {
        let _ = writeln!(s, "{name} =");
        s += &matrix_rows(m);
    }
    s
}

/// The rows of a matrix, one a line: `  [v v v]`, each value as `{:>11.4e}`.
fn matrix_rows(m: &DMatrix<f64>) -> String {
    m.row_iter()
        .map(|r| {
            let cells: Vec<String> = r.iter().map(|v| format!("{v:>11.4e}")).collect();
            format!("  [{}]\n", cells.join(" "))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::{model::Plant, rig::Rig};

    #[test]
    fn the_json_holds_every_field_of_the_core_margins_and_the_loop() {
        let m = pumpcyl::lti::margins(&Plant::new(&Rig::default()).open_loop(false)).unwrap();
        let v = margins_json(&m, "default rig");
        let core = serde_json::to_value(&m).unwrap();
        let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(|k| k.as_str()).collect();
        let mut want: Vec<&str> = core
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        want.push("loop");
        keys.sort_unstable();
        want.sort_unstable();
        assert_eq!(keys, want);
        assert_eq!(v["loop"], "default rig");
        assert_eq!(v["gain_margin_db"], core["gain_margin_db"]);
        assert!(margins_text(&m, "default rig").contains("closed loop   stable"));
    }

    #[test]
    fn the_poles_documents_list_every_pole_of_every_set() {
        let plant = Plant::new(&Rig::default());
        let open = plant.open_loop(false);
        let sets = [
            PoleSet::of(PoleSetKind::OpenLoop, &open.a).unwrap(),
            PoleSet::of(PoleSetKind::ClosedLoop, &open.unity_feedback().unwrap().a).unwrap(),
        ];
        // the article's loop has an integrator (a pole at the origin, the others stable), a
        // stable closed loop
        assert_eq!(sets[0].stability, Stability::Integrator);
        assert_eq!(sets[1].stability, Stability::Stable);
        let v = poles_json("default rig", &sets);
        assert_eq!(v.as_object().unwrap().len(), 7);
        assert_eq!(v["open_loop_stability"], "integrator");
        assert_eq!(v["open_loop"].as_array().unwrap().len(), open.a.nrows());
        assert_eq!(v["closed_loop_stable"], true);
        let text = poles_text("default rig", &sets);
        // the loop, then per set a blank line, the verdict, the column names and the poles
        assert_eq!(text.lines().count(), 1 + 2 * 3 + 2 * open.a.nrows());
    }

    #[test]
    fn the_bode_csv_has_two_columns_per_series_and_a_row_per_frequency() {
        let series = |label: &str| BodeSeries {
            label: label.into(),
            freq_hz: vec![0.1, 1.0, 10.0],
            mag_db: vec![20.0, 0.0, -20.0],
            phase_deg: vec![-90.0, -135.0, -180.0],
        };
        let csv = bode_csv(&[series("nominal"), series("kp=30,beta_bar=50")]);
        let mut lines = csv.lines();
        assert_eq!(
            lines.next(),
            Some("freq_hz,mag_db,phase_deg,\"mag_db[kp=30,beta_bar=50]\",\"phase_deg[kp=30,beta_bar=50]\"")
        );
        assert_eq!(
            lines.next(),
            Some("0.100000,20.000000,-90.000000,20.000000,-90.000000")
        );
        assert_eq!(lines.count(), 2);
    }
}
