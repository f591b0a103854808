//! Step 11, "The article's Figure 1 circuits on its own application": pumpcyl's own study,
//! answering the article's §2.1 (why the dual-prime-mover circuit and not the single-pump or the
//! dual-pump circuit of its Figure 1) and §4 (predict before building) on emulated records.
//! The three circuits of docs/circuits.md side by side on the article's rig and seesaw (zero
//! external force), Kp 25: margins (per mode for the single pump), the emulated 5 mm step, the
//! article's three sinusoids and the single pump's chatter prediction
//! (docs/circuits.md#will-it-chatter).
//!
//! Every number comes from the commands a user would run on the same rig: each circuit's rig is
//! the default rig with the `--set` assignments listed in summary.json (`set`), its margins are
//! `pumpcyl margins --json`'s and its records `pumpcyl emulate --no-noise`'s
//! (tests/reproduce_figure1.rs runs them).

use super::{Run, Source, STEP_MM};
use crate::figures::{trace, Chart};
use crate::format::fmt_opt;
use crate::plot::{LineStyle, Panel};
use anyhow::{anyhow, Context, Result};
use pumpcyl::circuit::single_pump::modes::{linear_models, switching};
use pumpcyl::circuit::Level;
use pumpcyl::emulator::article::{sine_periods, SINE_START_S};
use pumpcyl::emulator::chatter::{self, ModeRun, ARTICLE_SINES};
use pumpcyl::emulator::{Effects, Experiment, Plc, PLC_RATE_HZ};
use pumpcyl::lti::{self, Margins};
use pumpcyl::model::Plant;
use pumpcyl::response::{step_metrics, track_metrics, Signals, StepMetrics, TrackWindow};
use pumpcyl::rig::Rig;
use rayon::prelude::*;
use serde::Serialize;

/// When the emulated step happens (s): `pumpcyl emulate --experiment step`'s default `--at-s`.
pub const STEP_AT_S: f64 = 0.5;
/// The emulated step record's length (s): long enough for the single pump's slowest mode to
/// settle (about 11 s at zero load, docs/circuits.md#will-it-chatter) **\[choice\]**.
pub const STEP_RECORD_S: f64 = 15.5;
/// The external forces of the quiet-range scan (N): −200 to 1200 N in 100 N steps, across the
/// single pump's switching force and its valve band at the chosen pre-charge **\[choice\]**.
pub fn scan_forces_n() -> Vec<f64> {
    (0..15).map(|k| -200.0 + 100.0 * f64::from(k)).collect()
}

/// One circuit of the comparison on the article's rig.
#[derive(Debug, Clone, Serialize)]
pub struct CircuitRun {
    /// The circuit in words, e.g. `dual pump, D2 matched (2.909 cm³/rev)`.
    pub label: String,
    /// Its circuit key (`dpm`, `dual-pump`, `single-pump`).
    pub circuit: String,
    /// The `--set` assignments that make its rig from the default rig (the article's Table 1).
    pub set: Vec<String>,
    /// The accumulator pre-charge of a one-motor circuit (bar); `None` for the DPM.
    pub accumulator_precharge_bar: Option<f64>,
    /// The chamber pressures p1, p2 at rest before the emulated step (bar).
    pub rest_pressures_bar: [f64; 2],
    /// The control error x_ref − x at rest before the emulated step (mm): a one-motor circuit's
    /// P law commands the shaft speed that feeds the leakage through a standing error.
    pub rest_error_mm: f64,
    /// The margins of the analysed loop (`pumpcyl margins`): the mode at rest for the single
    /// pump, the sum-pressure loop open for the DPM (the article §2.3.3).
    pub margins: Margins,
    /// The single pump's modes, mode 1 first; empty for the other circuits.
    pub modes: Vec<ModeMargins>,
    /// The emulated 5 mm step's metrics, from the rest before the step.
    pub step: StepMetrics,
    /// Mode switches in the emulated step record (changes of its `mode` column); `None` for a
    /// circuit without modes.
    pub step_mode_changes: Option<usize>,
    /// The article's three sinusoids, emulated.
    pub tracking: Vec<Wave>,
}

/// One mode's margins (docs/circuits.md#modes-in-margins-and-poles).
#[derive(Debug, Clone, Serialize)]
pub struct ModeMargins {
    /// 1: chamber 2 on the accumulator; 2: chamber 1.
    pub mode: usize,
    /// The mode of the rest at zero external force.
    pub at_rest: bool,
    /// Its loop's margins.
    pub margins: Margins,
}

/// One emulated sinusoid of the article (its §3.3): the maximum control error over the
/// record's last two whole periods (docs/simulation.md#tracking-metrics).
#[derive(Debug, Clone, Serialize)]
pub struct Wave {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Amplitude (mm).
    pub amplitude_mm: f64,
    /// Record length (s); the wave starts at 1 s.
    pub record_s: f64,
    /// Maximum |x_ref − x| over the last two periods (mm).
    pub max_error_mm: f64,
    /// Changes of the record's `mode` column over the whole record (single pump only).
    pub mode_changes: Option<usize>,
    /// The same over the last two periods.
    pub mode_changes_last_two_periods: Option<usize>,
}

/// The single pump's chatter verdict (docs/circuits.md#will-it-chatter): the emulator's step
/// check at zero external force and the scan of the external force.
#[derive(Debug, Clone, Serialize)]
pub struct Chatter {
    /// The step check at zero external force ([`chatter::step`]).
    pub step: ModeRun,
    /// The article's three sines at zero external force ([`chatter::sine`]).
    pub sines: Vec<ModeRun>,
    /// The step check at each scanned external force, −200 to 1200 N in 100 N steps.
    pub scan: Vec<ModeRun>,
    /// The runs of consecutive scanned forces whose step settles without switching (N).
    pub quiet_ranges_n: Vec<(f64, f64)>,
    /// The switching force p_acc (A1 − A2) (N).
    pub switching_force_n: f64,
    /// Whether the step or any of the article's sines chatters.
    pub chatters: bool,
}

/// Step 11's numbers (summary.json `figure1_circuits`).
#[derive(Debug, Clone, Serialize)]
pub struct Figure1Circuits {
    /// Why the one-motor circuits run at their pre-charges.
    pub pressure_level: String,
    /// DPM, dual pump with D2 matched, dual pump with the article's D2, single pump.
    pub circuits: Vec<CircuitRun>,
    /// The single pump's chatter verdict.
    pub single_pump_chatter: Chatter,
}

/// The matched pump 2 of the dual-pump circuit (cm³/rev): D2/D1 = A1/A2 − 1
/// (docs/circuits.md#matching).
fn matched_d2_cm3_per_rev(rig: &Rig) -> f64 {
    let si = rig.si();
    rig.displacement_1_cm3_per_rev * (si.a1 / si.a2 - 1.0)
}

/// The DPM's chamber 1 pressure at rest with no load (bar): its sum-pressure set-point split
/// by the force balance p1 A1 = p2 A2.
fn dpm_rest_p1_bar(rig: &Rig) -> f64 {
    let si = rig.si();
    rig.p_sum_ref_bar * si.a2 / (si.a1 + si.a2)
}

/// The four circuits: label and the `--set` assignments from the default rig.
pub(super) fn circuits(base: &Rig) -> Vec<(String, Vec<String>)> {
    let d2 = matched_d2_cm3_per_rev(base);
    let p_acc = dpm_rest_p1_bar(base);
    vec![
        (
            format!("DPM (sum-pressure set-point {} bar)", base.p_sum_ref_bar),
            vec![],
        ),
        (
            format!("dual pump, D2 matched ({d2:.3} cm³/rev)"),
            vec![
                "circuit=dual-pump".into(),
                format!("displacement_2_cm3_per_rev={d2}"),
            ],
        ),
        (
            format!(
                "dual pump, the article's D2 ({} cm³/rev)",
                base.displacement_2_cm3_per_rev
            ),
            vec!["circuit=dual-pump".into()],
        ),
        (
            format!("single pump (pre-charge {p_acc:.2} bar)"),
            vec![
                "circuit=single-pump".into(),
                format!("accumulator_precharge_bar={p_acc}"),
            ],
        ),
    ]
}

/// The emulated record of `experiment` on `rig`, every effect on, noise-free sensors at the
/// PLC's 100 Hz: `pumpcyl emulate --no-noise`.
fn emulate(rig: &Rig, experiment: &Experiment) -> Result<Signals> {
    let effects = Effects::for_rig(rig).map_err(|e| anyhow!("{e}"))?;
    experiment
        .run(rig, effects, &Plc::ideal(PLC_RATE_HZ))
        .map_err(|e| anyhow!("{e}"))
}

/// The step's metrics from the rest before it: the position about its value at the step; the
/// steady-state error from the DC solution of `rig`'s linear closed loop (the mode at rest for
/// the single pump), as `pumpcyl step` gives it.
fn step_of(rig: &Rig, s: &Signals) -> StepMetrics {
    let sys = Plant::new(rig).closed_loop_outputs(rig.sum_pressure);
    let dc_mm = lti::dc_output(&sys, &[STEP_MM * 1e-3]).map_or(f64::NAN, |y| y[0] * 1e3);
    let k0 = s.time_s.iter().position(|&t| t >= STEP_AT_S).unwrap_or(0);
    let x0 = s.x_mm[k0.saturating_sub(1)];
    let t = &s.time_s[k0..];
    let y: Vec<f64> = s.x_mm[k0..].iter().map(|x| x - x0).collect();
    step_metrics(t, &y, STEP_MM, dc_mm)
}

/// Changes of a record's `mode` column from sample `from` on; `None` without the column.
fn mode_changes(s: &Signals, from: usize) -> Option<usize> {
    let m = s.mode.get(from..).filter(|m| !m.is_empty())?;
    Some(m.windows(2).filter(|w| w[0] != w[1]).count())
}

/// The emulated sinusoid `(freq_hz, amplitude_mm)` of `rig`, as the article's records run it
/// (at rest for 1 s, the wave's whole periods after a 20 s start-up, two more measured).
fn wave(rig: &Rig, (freq_hz, amplitude_mm): (f64, f64)) -> Result<Wave> {
    let n = sine_periods(freq_hz);
    let record_s = SINE_START_S + f64::from(n) / freq_hz;
    let e = Experiment::sine(rig, amplitude_mm, freq_hz, SINE_START_S, Some(record_s));
    let s = emulate(rig, &e)?;
    let window = TrackWindow::periods(SINE_START_S, freq_hz, n - 1, n, false);
    let m = track_metrics(&s.time_s, &s.e_mm, freq_hz, amplitude_mm, window);
    let from = (s.time_s.iter())
        .position(|&t| t >= window.from_s - 1e-9)
        .unwrap_or(0);
    Ok(Wave {
        freq_hz,
        amplitude_mm,
        record_s,
        max_error_mm: m.max_error_mm,
        mode_changes: mode_changes(&s, 0),
        mode_changes_last_two_periods: mode_changes(&s, from),
    })
}

/// The margins of `rig`'s analysed loop, and per mode for the single pump.
fn margins(rig: &Rig) -> Result<(Margins, Vec<ModeMargins>)> {
    let m = lti::margins(&Plant::new(rig).open_loop(false))?;
    if !rig.circuit.has_modes() {
        return Ok((m, Vec::new()));
    }
    let modes = (linear_models(rig)?.iter())
        .map(|mm| {
            Ok(ModeMargins {
                mode: mm.mode,
                at_rest: mm.at_rest,
                margins: lti::margins(&mm.open_loop)?,
            })
        })
        .collect::<Result<Vec<_>, lti::LtiError>>()?;
    Ok((m, modes))
}

/// One circuit run: its margins, emulated step and waves; the step record for the figure.
fn run_circuit(base: &Rig, label: &str, set: &[String]) -> Result<(CircuitRun, Signals)> {
    let rig = base
        .with_overrides_from("the Figure 1 study", set)
        .with_context(|| label.to_string())?;
    let (m, modes) = margins(&rig)?;
    let step = Experiment::step(&rig, None, None, STEP_AT_S, Some(STEP_RECORD_S));
    let s = emulate(&rig, &step)?;
    let tracking = (ARTICLE_SINES.par_iter())
        .map(|&w| wave(&rig, w))
        .collect::<Result<Vec<_>>>()?;
    let run = CircuitRun {
        label: label.to_string(),
        circuit: rig.circuit.name().to_string(),
        set: set.to_vec(),
        accumulator_precharge_bar: (rig.circuit.description().level == Level::ACCUMULATOR)
            .then_some(rig.accumulator_precharge_bar),
        rest_pressures_bar: [s.p1_bar[0], s.p2_bar[0]],
        rest_error_mm: s.e_mm[0],
        margins: m,
        modes,
        step: step_of(&rig, &s),
        step_mode_changes: mode_changes(&s, 0),
        tracking,
    };
    Ok((run, s))
}

/// The single pump's chatter verdict on `rig` (zero external force): the emulator's
/// prediction ([`chatter::predict`]: the step and the article's three sines, switches counted
/// as docs/circuits.md#will-it-chatter says) and the scan of the external force.
fn chatter_of(rig: &Rig) -> Result<Chatter> {
    let effects = Effects::for_rig(rig).map_err(|e| anyhow!("{e}"))?;
    let prediction = chatter::predict(rig, effects).map_err(|e| anyhow!("{e}"))?;
    let scan = (scan_forces_n().par_iter())
        .map(|&f| chatter::scan_forces(rig, &[f]).map_err(|e| anyhow!("{e}")))
        .collect::<Result<Vec<_>>>()?
        .concat();
    Ok(Chatter {
        chatters: prediction.chatters(),
        quiet_ranges_n: chatter::quiet_ranges_n(&scan),
        switching_force_n: switching(rig).switching_force_n,
        step: prediction.step,
        sines: prediction.sines,
        scan,
    })
}

/// Step 11: the three Figure 1 circuits side by side on the article's rig at Kp 25.
pub(super) fn figure1_circuits(run: &mut Run) -> Result<Figure1Circuits> {
    run.step("The article's Figure 1 circuits on its own application (pumpcyl's own study, answering the article §2.1 and §4; docs/circuits.md)");
    let base = Rig::default();
    let runs = (circuits(&base).par_iter())
        .map(|(label, set)| run_circuit(&base, label, set))
        .collect::<Result<Vec<_>>>()?;
    let single = runs.last().ok_or_else(|| anyhow!("no single pump"))?;
    let single_rig = base.with_overrides_from("the Figure 1 study", &single.0.set)?;
    let chatter = chatter_of(&single_rig)?;
    let level = pressure_level(&base);
    run.text(&explanation(&level, &runs, &chatter));
    run.table(
        "The article's Figure 1 circuits on its rig (Kp 25, 10 593 kg, zero external force): margins, the emulated 5 mm step and the article's three sinusoids",
        &HEADER,
        runs.iter().flat_map(|(r, _)| rows(r)).collect(),
    );
    run.table(
        "The single pump's emulated 5 mm step against the external force (docs/circuits.md#will-it-chatter)",
        &SCAN_HEADER,
        chatter.scan.iter().map(scan_row).collect(),
    );
    let chart = steps_chart(&runs);
    run.figure(
        "figure1_circuits_step",
        Source::Own,
        "The article's Figure 1 circuits on its own application (answering its §2.1 and §4): the emulated 5 mm step of each circuit at Kp 25 with zero external force, and the single pump's mode",
        &chart,
    )?;
    run.compare_why(
        "§2.1: the single pump's switching under low force (seesaw, zero external force, Kp 25): mode switches during / after settling of the emulated 5 mm step and the three sines, chatters?",
        format!(
            "step {} / {}; sines {}; chatters: {}",
            chatter.step.switches,
            chatter.step.switches_after_settling,
            (chatter.sines.iter())
                .map(|w| format!("{} / {}", w.switches, w.switches_after_settling))
                .collect::<Vec<_>>()
                .join(", "),
            if chatter.chatters { "yes" } else { "no" }
        ),
        "\"non-linear switching dynamics under low-force conditions\", \"may often lead to instability\"",
        "-",
        "pumpcyl's own prediction on emulated records (docs/circuits.md#will-it-chatter); the article gives no number",
    );
    Ok(Figure1Circuits {
        pressure_level: level,
        circuits: runs.into_iter().map(|(r, _)| r).collect(),
        single_pump_chatter: chatter,
    })
}

/// Why the one-motor circuits run at their pre-charges.
fn pressure_level(base: &Rig) -> String {
    format!(
        "The DPM holds p1 + p2 at its set-point, {} bar; the one-motor circuits have no such loop and \
         their accumulator's pre-charge sets the level. Each runs at the pre-charge whose linear \
         model rests at the DPM's own rest pressures, p1 {:.2} bar and p2 {:.2} bar with no load: \
         the dual pump at its default {} bar (docs/circuits.md#the-default-pre-charge), the single \
         pump at {:.2} bar, the DPM's p1, since at rest it holds chamber 1 on the accumulator and \
         chamber 2 at the force balance's p1 A1/A2. All three models take the same β, {} bar, so \
         their margins compare the circuits, not two pressure levels; the emulator anchors its \
         β_e(p) at the DPM's mean pressure and at each one-motor circuit's pre-charge \
         (docs/emulator.md#every-circuit). Emulated, the dual pump rests higher than its linear \
         model, where check valve 1 just feeds chamber 1 (docs/circuits.md#valves).",
        base.p_sum_ref_bar,
        dpm_rest_p1_bar(base),
        base.p_sum_ref_bar - dpm_rest_p1_bar(base),
        base.accumulator_precharge_bar,
        dpm_rest_p1_bar(base),
        base.beta_bar
    )
}

const HEADER: [&str; 9] = [
    "circuit",
    "loop",
    "GM (dB)",
    "PM (deg)",
    "rest p1, p2 (bar)",
    "step rise (s)",
    "overshoot (%)",
    "2 % settling (s)",
    "sines 0.10/0.20/0.25 Hz: max |e| (mm)",
];

/// The rows of one circuit: its analysed loop, then each mode of the single pump.
fn rows(r: &CircuitRun) -> Vec<Vec<String>> {
    let errors: Vec<String> = (r.tracking.iter())
        .map(|w| format!("{:.2}", w.max_error_mm))
        .collect();
    let mut out = vec![vec![
        r.label.clone(),
        if r.modes.is_empty() {
            "as analysed".into()
        } else {
            "the mode at rest".into()
        },
        fmt_opt(r.margins.gain_margin_db, 2),
        fmt_opt(r.margins.phase_margin_deg, 1),
        format!(
            "{:.2}, {:.2}",
            r.rest_pressures_bar[0], r.rest_pressures_bar[1]
        ),
        fmt_opt(r.step.rise_time_s, 3),
        format!("{:.1}", r.step.overshoot_pct),
        fmt_opt(r.step.settling_time_s, 2),
        errors.join(" / "),
    ]];
    for m in &r.modes {
        out.push(vec![
            String::new(),
            format!(
                "mode {} (chamber {} on the accumulator){}",
                m.mode,
                3 - m.mode,
                if m.at_rest { ", at rest" } else { "" }
            ),
            fmt_opt(m.margins.gain_margin_db, 2),
            fmt_opt(m.margins.phase_margin_deg, 1),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
        ]);
    }
    out
}

const SCAN_HEADER: [&str; 6] = [
    "external force (N)",
    "mode at rest",
    "switches",
    "after settling",
    "error amplitude after settling (mm)",
    "chatters",
];

fn scan_row(r: &ModeRun) -> Vec<String> {
    vec![
        format!("{:.0}", r.external_force_n),
        r.mode_at_start
            .map_or("both valves shut".into(), |m| m.to_string()),
        r.switches.to_string(),
        r.switches_after_settling.to_string(),
        format!("{:.4}", r.error_amplitude_m * 1e3),
        if r.chatters { "yes" } else { "no" }.into(),
    ]
}

/// The steps about the rest before the step (mm), the control error (mm) and the single
/// pump's mode (a category axis, 1 or 2), over the step record.
fn steps_chart(runs: &[(CircuitRun, Signals)]) -> Chart {
    let mut position = vec![];
    let mut error = vec![];
    let mut mode = vec![];
    for (k, (r, s)) in runs.iter().enumerate() {
        let k0 = s.time_s.iter().position(|&t| t >= STEP_AT_S).unwrap_or(0);
        let x0 = s.x_mm[k0.saturating_sub(1)];
        let y: Vec<f64> = s.x_mm.iter().map(|x| x - x0).collect();
        position.push(trace(&r.label, &s.time_s, &y, LineStyle::Solid, Some(k)));
        error.push(trace("", &s.time_s, &s.e_mm, LineStyle::Solid, Some(k)));
        if !s.mode.is_empty() {
            mode.push(trace(
                &r.label,
                &s.time_s,
                &s.mode,
                LineStyle::Solid,
                Some(k),
            ));
        }
    }
    if let Some((_, s)) = runs.first() {
        let r: Vec<f64> = s
            .time_s
            .iter()
            .map(|&t| if t < STEP_AT_S { 0.0 } else { STEP_MM })
            .collect();
        position.insert(
            0,
            trace("reference", &s.time_s, &r, LineStyle::Dashed, Some(6)),
        );
    }
    Chart::time(
        "The article's Figure 1 circuits: emulated 5 mm step at Kp 25, zero external force",
        Some("emulated data, not a measurement; position about the rest before the step"),
        vec![
            Panel {
                y_label: "Position, x − x(step) (mm)".into(),
                traces: position,
                ..Default::default()
            },
            Panel {
                y_label: "Control error x_ref − x (mm)".into(),
                traces: error,
                ..Default::default()
            },
            Panel {
                y_label: "Single-pump mode".into(),
                traces: mode,
                // the record's mode column (docs/emulator.md#the-mode-signal): 1 or 2
                categories: vec!["1".into(), "2".into()],
            },
        ],
    )
}

/// The section's answer in words.
fn explanation(level: &str, runs: &[(CircuitRun, Signals)], c: &Chatter) -> String {
    let quiet: Vec<String> = (c.quiet_ranges_n.iter())
        .map(|(lo, hi)| format!("{lo:.0} to {hi:.0} N"))
        .collect();
    let single = runs.last().map(|(r, _)| r);
    let modes = single.map_or(String::new(), |r| {
        (r.modes.iter())
            .map(|m| {
                format!(
                    "mode {}: GM {} dB, PM {}°",
                    m.mode,
                    fmt_opt(m.margins.gain_margin_db, 2),
                    fmt_opt(m.margins.phase_margin_deg, 1)
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    });
    format!(
        "pumpcyl's own study, on emulated records, not in the article: the article (§2.1) built the \
         dual-prime-mover circuit rather than the single-pump circuit of its Figure 1a (\"non-linear \
         switching dynamics under low-force conditions\") or the dual-pump circuit of its Figure 1b \
         (\"unpredictable pressure phenomena\"), and advises (§4) to predict before building. Here the \
         three circuits run the article's application, its rig and seesaw at zero external force, \
         Kp 25 (docs/circuits.md). {level} The single pump's modes: {modes}. Its chatter prediction \
         (docs/circuits.md#will-it-chatter): the emulated 5 mm step switches {} times, {} after it has \
         settled (at {:.1} s), and its error swings by ±{:.3} µm after settling; the article's three \
         sinusoids switch {} times in their two watched periods (twice a period is the wave's own \
         reversal of the force the load needs). Verdict: {}. Scanning the external \
         force from {:.0} to {:.0} N, the step settles without switching for {} (switching force \
         {:.0} N). The one-motor circuits' tracking errors include their standing error at rest \
         (x_ref − x in the order of the table: {} mm): the P law commands the shaft speed that feeds the leakage only through an error. \
         The records are `pumpcyl emulate --no-noise` on each circuit's rig, the margins \
         `pumpcyl margins`'s.",
        c.step.switches,
        c.step.switches_after_settling,
        c.step.settled_at_s,
        c.step.error_amplitude_m * 1e6,
        (c.sines.iter())
            .map(|w| w.switches_after_settling.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        if c.chatters {
            "it chatters at Kp 25 on the article's application"
        } else {
            "no chatter at Kp 25 on the article's application: the switches die out with the transient"
        },
        scan_forces_n().first().copied().unwrap_or(f64::NAN),
        scan_forces_n().last().copied().unwrap_or(f64::NAN),
        if quiet.is_empty() {
            "no scanned force".to_string()
        } else {
            quiet.join(" and ")
        },
        c.switching_force_n,
        (runs.iter())
            .map(|(r, _)| format!("{:.2}", r.rest_error_mm))
            .collect::<Vec<_>>()
            .join(" / "),
    )
}
