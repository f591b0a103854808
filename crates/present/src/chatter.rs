//! "Will it chatter?" as every front end asks it and shows it (`pumpcyl chatter`, Python's
//! `chatter`; docs/circuits.md#a-scan-of-the-load): the request, its one run, and its
//! document, text, CSV and figure. The single-pump circuit's defining question (the article
//! §2.1: "non-linear switching dynamics under low-force conditions") answered over a range of
//! loads by the emulator's scan ([`pumpcyl::emulator::chatter::scan`]); a circuit without modes
//! gets its own one-line reason ([`pumpcyl::circuit::mode_switching`]).

use crate::figures::{trace, Chart, Plot};
use crate::plot::{LineStyle, Panel};
use crate::records::{csv_number, csv_text};
use pumpcyl::circuit::{mode_switching, CircuitKind};
use pumpcyl::emulator::chatter::{
    self, ForceScan, ForceVerdict, Forces, ModeRun, ScanError, ScanRequest, Wave,
};
use pumpcyl::emulator::{Effects, PLC_RATE_HZ, STEP_MM};
use pumpcyl::limits::Work;
use pumpcyl::rig::Rig;
use serde::Serialize;
use std::fmt::Write;

/// A chatter scan asked for: the forces (`None`: the default about the switching force,
/// [`Forces::AboutSwitching`] with [`chatter::DEFAULT_POINTS`]) and the waves run beside the
/// 5 mm step at each.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Request {
    /// The external forces (N).
    pub forces: Option<Forces>,
    /// The waves (Hz, mm about x0).
    pub waves: Vec<Wave>,
}

/// The answer in one word.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Some scanned force chatters.
    Chatters,
    /// No scanned force chatters.
    Quiet,
    /// The circuit has no modes to switch between.
    NoModes,
}

impl Verdict {
    /// The verdict as the text and the CSV write it (the JSON's snake_case).
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Chatters => "chatters",
            Verdict::Quiet => "quiet",
            Verdict::NoModes => "no_modes",
        }
    }
}

/// The document of a chatter scan (`pumpcyl chatter --json`, Python's `chatter`): every key
/// present for every circuit, `null` (or empty) where a circuit without modes has no value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Chatter {
    /// The rig in words (its file, or Python's repr).
    pub rig: String,
    /// Its circuit (`dpm`, `dual-pump`, `single-pump`).
    pub circuit: CircuitKind,
    /// `chatters`, `quiet` or `no_modes`.
    pub verdict: Verdict,
    /// The answer in one line.
    pub answer: String,
    /// The switching force p_acc (A1 − A2) (N).
    pub switching_force_n: Option<f64>,
    /// The band the check valves' cracking pressure widens it to (N).
    pub valve_band_n: Option<[f64; 2]>,
    /// The rig's own external force (N).
    pub external_force_n: f64,
    /// The mode the rig's own load rests in (1: chamber 2 on the accumulator, 2: chamber 1).
    pub mode_at_rest: Option<usize>,
    /// The step run at every force.
    pub step_mm: f64,
    /// The waves run at every force beside the step.
    pub waves: Vec<Wave>,
    /// Each scanned force, increasing.
    pub forces: Vec<ForceScan>,
    /// The runs of consecutive scanned forces where nothing switched (N).
    pub quiet_ranges_n: Vec<(f64, f64)>,
    /// The runs of consecutive scanned forces that chatter (N).
    pub chattering_ranges_n: Vec<(f64, f64)>,
    /// What the emulator used, in words (docs/emulator.md#what-a-user-rig-gets); `null` for a
    /// circuit without modes, which runs nothing.
    pub basis: Option<String>,
}

/// Run the chatter scan `request` on `rig` (named `origin`): the scan's document, or for a
/// circuit without modes the document that says why, running nothing. `work` follows the
/// emulated runs (one unit each) and allows a long run.
///
/// # Errors
/// A request field that is wrong ([`ScanError::Request`]), a scan beyond its work limit, or a
/// run the emulator cannot do.
pub fn run(rig: &Rig, origin: &str, request: &Request, work: &Work) -> Result<Chatter, ScanError> {
    let mut doc = Chatter {
        rig: origin.to_string(),
        circuit: rig.circuit,
        verdict: Verdict::NoModes,
        answer: String::new(),
        switching_force_n: None,
        valve_band_n: None,
        external_force_n: rig.external_force_n,
        mode_at_rest: None,
        step_mm: STEP_MM,
        waves: request.waves.clone(),
        forces: Vec::new(),
        quiet_ranges_n: Vec::new(),
        chattering_ranges_n: Vec::new(),
        basis: None,
    };
    if let Err(why) = mode_switching(rig) {
        doc.answer = format!(
            "no modes to switch between, so it cannot chatter: {why} (docs/circuits.md#will-it-chatter)"
        );
        return Ok(doc);
    }
    let scan_request = ScanRequest {
        forces: (request.forces.clone()).unwrap_or(Forces::AboutSwitching {
            points: chatter::DEFAULT_POINTS,
        }),
        waves: request.waves.clone(),
    };
    let scan = chatter::scan(rig, &scan_request, work)?;
    let effects = Effects::for_rig(rig).map_err(|e| ScanError::Run(e.to_string()))?;
    doc.basis =
        Some(crate::emulated::basis(rig, &effects).map_err(|e| ScanError::Run(e.to_string()))?);
    doc.verdict = if scan.chatters {
        Verdict::Chatters
    } else {
        Verdict::Quiet
    };
    doc.switching_force_n = Some(scan.switching.switching_force_n);
    doc.valve_band_n = Some(scan.switching.valve_band_n);
    doc.mode_at_rest = Some(scan.switching.mode_at_rest);
    doc.forces = scan.forces;
    doc.quiet_ranges_n = scan.quiet_ranges_n;
    doc.chattering_ranges_n = scan.chattering_ranges_n;
    doc.answer = answer(&doc);
    Ok(doc)
}

/// The emulated runs a request makes, the units `work` counts in [`run`]: the step and each
/// wave at each force (a list of forces given twice counts twice here, once in the scan).
pub fn runs(request: &Request) -> u64 {
    let forces = match &request.forces {
        None => chatter::DEFAULT_POINTS,
        Some(Forces::AboutSwitching { points } | Forces::Range { points, .. }) => *points,
        Some(Forces::Given(f)) => f.len(),
    };
    (forces as u64).saturating_mul(1 + request.waves.len() as u64)
}

/// Forces as text: `a … b N` for a range, `a N` for one force.
fn range_text((lo, hi): (f64, f64)) -> String {
    if lo == hi {
        format!("{lo:.1} N")
    } else {
        format!("{lo:.1} … {hi:.1} N")
    }
}

/// Ranges as text, comma-separated; `none` when there are none.
fn ranges_text(ranges: &[(f64, f64)]) -> String {
    if ranges.is_empty() {
        return "none".into();
    }
    let parts: Vec<String> = ranges.iter().map(|r| range_text(*r)).collect();
    parts.join(", ")
}

/// What the runs at each force are, in words: `the 5 mm step` and each wave.
fn runs_text(doc: &Chatter) -> String {
    let mut s = format!("the emulated {} mm step", doc.step_mm);
    for w in &doc.waves {
        let _ = write!(s, ", the sine {} Hz ±{} mm", w.freq_hz, w.amplitude_mm);
    }
    s
}

/// The one-line answer of a scanned rig: the verdict, where it chatters and why, where it is
/// quiet.
fn answer(doc: &Chatter) -> String {
    let (first, last) = match (doc.forces.first(), doc.forces.last()) {
        (Some(a), Some(b)) => (a.external_force_n, b.external_force_n),
        _ => return "no force scanned".into(),
    };
    let quiet = match doc.quiet_ranges_n.as_slice() {
        [] => "every scanned force switches".to_string(),
        ranges => format!("no switch at all at {}", ranges_text(ranges)),
    };
    match doc.verdict {
        Verdict::Chatters => {
            let extra: usize = doc.forces.iter().map(|f| f.extra_switches).sum();
            let swinging = (doc.forces.iter())
                .filter(|f| f.step.chatters && f.step.switches_after_settling == 0)
                .count();
            let mut why = Vec::new();
            if extra > 0 {
                why.push(format!(
                    "{extra} mode switches in all beyond what the step's transient and the \
                     waves' references explain"
                ));
            }
            if swinging > 0 {
                why.push(format!(
                    "at {swinging} of the forces the settled step still swings by more than \
                     {} % of the step",
                    100.0 * pumpcyl::circuit::single_pump::modes::SETTLED_FRACTION
                ));
            }
            format!(
                "chatters at {}: {}; {quiet}",
                ranges_text(&doc.chattering_ranges_n),
                why.join(", and ")
            )
        }
        _ => {
            let switching: Vec<&ForceScan> = (doc.forces.iter())
                .filter(|f| f.verdict == ForceVerdict::Switches)
                .collect();
            let normal = match (switching.first(), switching.last()) {
                (Some(a), Some(b)) => format!(
                    "; from {} the modes switch, but only during the step's transient or as the \
                     waves' references explain",
                    range_text((a.external_force_n, b.external_force_n))
                ),
                _ => String::new(),
            };
            format!(
                "quiet: no force of {} chatters; {quiet}{normal}",
                range_text((first, last))
            )
        }
    }
}

/// The runs of one force in order: the step, then the waves.
fn runs_of(f: &ForceScan) -> impl Iterator<Item = &ModeRun> {
    std::iter::once(&f.step).chain(&f.waves)
}

/// A mode as text: `1`, `2`, or `-` (both valves shut).
fn mode_text(m: Option<usize>) -> String {
    m.map_or("-".into(), |m| m.to_string())
}

/// The chatter scan as text (`pumpcyl chatter`): the rig and what ran, the switching force and
/// its band, a table of the forces (each run's switches, after settling, explained by the
/// reference), the quiet and chattering ranges and the answer.
pub fn chatter_text(doc: &Chatter) -> String {
    let mut s = String::new();
    let head = format!("{} (circuit {})", doc.rig, doc.circuit.name());
    let (Some(f_s), Some(band)) = (doc.switching_force_n, doc.valve_band_n) else {
        let _ = writeln!(s, "{head}: {}", doc.answer);
        return s;
    };
    let _ = writeln!(
        s,
        "{head}: will it chatter? {} at {} external forces, noise-free PLC at {PLC_RATE_HZ} Hz, \
         every emulator effect on (emulated, not measured)",
        runs_text(doc),
        doc.forces.len()
    );
    let _ = writeln!(
        s,
        "  switching force p_acc (A1 - A2)  {f_s:.1} N; valve band {:.1} … {:.1} N \
         (docs/circuits.md#the-switching-force)",
        band[0], band[1]
    );
    if let Some(m) = doc.mode_at_rest {
        let _ = writeln!(
            s,
            "  the rig's own load               {:.1} N rests in mode {m} (chamber {} on the accumulator)",
            doc.external_force_n,
            3 - m
        );
    }
    if let Some(b) = &doc.basis {
        let _ = writeln!(s, "  {b}");
    }
    let mut header = format!("{:>12} {:>5}  {:>13}", "force_n", "mode", "step sw/after");
    for w in &doc.waves {
        let label = format!("{} Hz ±{} mm sw/watched/expl", w.freq_hz, w.amplitude_mm);
        let _ = write!(header, "  {label:>30}");
    }
    let _ = writeln!(header, "  {:>5}  verdict", "extra");
    s.push_str(&header);
    for f in &doc.forces {
        let _ = write!(
            s,
            "{:>12.1} {:>5}  {:>13}",
            f.external_force_n,
            mode_text(f.mode_at_start),
            format!("{}/{}", f.step.switches, f.step.switches_after_settling)
        );
        for w in &f.waves {
            let cell = format!(
                "{}/{}/{}",
                w.switches, w.switches_after_settling, w.switches_explained
            );
            let _ = write!(s, "  {cell:>30}");
        }
        let verdict = match f.verdict {
            ForceVerdict::Quiet => "quiet",
            ForceVerdict::Switches => "switches, none extra",
            ForceVerdict::Chatters => "CHATTERS",
        };
        let _ = writeln!(s, "  {:>5}  {verdict}", f.extra_switches);
    }
    let _ = writeln!(
        s,
        "  (sw: mode switches in the run; after: after the step settled; watched: in the wave's \
         last {} periods; expl: of those, the reference's own crossings of the switching force; \
         extra: switches after settling beyond those explained; docs/circuits.md#will-it-chatter)",
        chatter::WATCHED_PERIODS
    );
    let _ = writeln!(s, "quiet (no switch): {}", ranges_text(&doc.quiet_ranges_n));
    let _ = writeln!(
        s,
        "chatters:          {}",
        ranges_text(&doc.chattering_ranges_n)
    );
    let _ = writeln!(s, "verdict: {}", doc.answer);
    s
}

/// The chatter scan as CSV (`pumpcyl chatter --out FILE.csv`): one row a run at a force,
/// `external_force_n,run,mode_at_start,switches,switches_after_settling,switches_explained,
/// extra_switches,error_amplitude_mm,chatters,verdict` (`run`: `step` or the wave; the mode
/// empty while both valves are shut; `verdict` the force's).
pub fn chatter_csv(doc: &Chatter) -> String {
    let header = [
        "external_force_n",
        "run",
        "mode_at_start",
        "switches",
        "switches_after_settling",
        "switches_explained",
        "extra_switches",
        "error_amplitude_mm",
        "chatters",
        "verdict",
    ];
    let rows = doc.forces.iter().flat_map(|f| {
        runs_of(f).map(move |r| {
            vec![
                csv_number(f.external_force_n),
                r.experiment.clone(),
                r.mode_at_start.map_or(String::new(), |m| m.to_string()),
                r.switches.to_string(),
                r.switches_after_settling.to_string(),
                r.switches_explained.to_string(),
                (r.switches_after_settling)
                    .saturating_sub(r.switches_explained)
                    .to_string(),
                csv_number(r.error_amplitude_m * 1e3),
                r.chatters.to_string(),
                verdict_name(f.verdict).to_string(),
            ]
        })
    });
    csv_text(&header.map(String::from), rows)
}

/// A force's verdict as the CSV writes it (the JSON's snake_case).
fn verdict_name(v: ForceVerdict) -> &'static str {
    match v {
        ForceVerdict::Quiet => "quiet",
        ForceVerdict::Switches => "switches",
        ForceVerdict::Chatters => "chatters",
    }
}

/// The chatter scan as a figure (`pumpcyl chatter --out FILE.svg|png`): the mode switches of
/// every run and those beyond what the step's transient and the references explain, against
/// the external force, with the switching force (dash-dot) and the valve band's edges (dashed)
/// as vertical lines.
///
/// # Errors
/// A circuit without modes, which has nothing to draw.
pub fn chatter_chart(doc: &Chatter) -> Result<Chart, String> {
    let (Some(f_s), Some(band)) = (doc.switching_force_n, doc.valve_band_n) else {
        return Err(format!(
            "circuit = \"{}\": no modes, no figure: {}",
            doc.circuit.name(),
            doc.answer
        ));
    };
    let f: Vec<f64> = doc.forces.iter().map(|f| f.external_force_n).collect();
    let count = |g: &dyn Fn(&ForceScan) -> usize| -> Vec<f64> {
        doc.forces.iter().map(|f| g(f) as f64).collect()
    };
    let all = count(&|f| f.switches);
    let extra = count(&|f| f.extra_switches);
    // two points at one force from -inf to +inf: a vertical line over the panel's height
    let vertical = |x: f64| ([x, x], [f64::NEG_INFINITY, f64::INFINITY]);
    let (xs, ys) = vertical(f_s);
    let (lo_x, lo_y) = vertical(band[0]);
    let (hi_x, hi_y) = vertical(band[1]);
    let panel = Panel {
        y_label: "Mode switches".into(),
        traces: vec![
            trace("every switch", &f, &all, LineStyle::Solid, Some(0)),
            trace(
                "beyond the step's transient and the references (chatter)",
                &f,
                &extra,
                LineStyle::Solid,
                Some(1),
            ),
            trace("switching force", &xs, &ys, LineStyle::DashDot, Some(6)),
            trace("valve band", &lo_x, &lo_y, LineStyle::Dashed, Some(7)),
            trace("", &hi_x, &hi_y, LineStyle::Dashed, Some(7)),
        ],
        ..Default::default()
    };
    Ok(Chart {
        title: format!("Will it chatter? {}: {}", doc.rig, doc.verdict.name()),
        subtitle: Some(format!(
            "{} at each force (emulated); switching force {f_s:.1} N, valve band {:.1} … {:.1} N",
            runs_text(doc),
            band[0],
            band[1]
        )),
        plot: Plot::Xy {
            x_label: "External force (N)".into(),
            panels: vec![panel],
        },
    })
}
