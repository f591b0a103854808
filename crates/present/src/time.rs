//! The time-domain results as every front end shows them (docs/simulation.md): the documents of
//! a position step (docs/simulation.md#step-metrics), sinusoidal tracking
//! (docs/simulation.md#tracking-metrics) and a replayed record, each over the nominal rig and
//! its variants, as JSON, text, CSV of the signals and MAT-files (docs/matlab.md).
//!
//! Positions and errors are in mm, times in s, pressures in bar gauge, speeds in rpm, as in the
//! core's [`Signals`] and metrics.

use crate::figures::{trace, Chart};
use crate::format::{fmt_opt, shown_name};
use crate::matlab::signals_mat;
use crate::plot::{LineStyle, Panel};
use crate::records::{csv_number, csv_text};
use pumpcyl::circuit::CircuitKind;
use pumpcyl::record::Record;
use pumpcyl::response::{
    OverRating, Ringing, Signals, StepMetrics, TrackMetrics, TrackWindow, RINGING_GM_DB,
};
use serde::Serialize;
use serde_json::{json, Value};
use std::fmt::Write as _;

/// One simulated run: which rig it is, its signals and its metrics (`M`: [`StepMetrics`],
/// [`TrackMetrics`], or the position MSE in mm² of a replay).
#[derive(Debug, Clone)]
pub struct Run<M> {
    /// `nominal`, or the variant's overrides (`KEY=VALUE[,...]`).
    pub label: String,
    /// The simulated signals.
    pub signals: Signals,
    /// The metrics of the run.
    pub metrics: M,
    /// The drive ratings its signals exceed ([`pumpcyl::response::signals_over_ratings`]).
    pub over_ratings: Vec<OverRating>,
}

/// A variant that was not simulated because its closed loop is unstable (its response would
/// only grow).
#[derive(Debug, Clone)]
pub struct Unstable {
    /// The variant's overrides (`KEY=VALUE[,...]`).
    pub label: String,
    /// Why it is unstable, in words.
    pub reason: String,
}

/// The runs of one time-domain result: the nominal rig's first, then each variant's, and the
/// variants set aside as unstable. The documents below expect at least the nominal run.
#[derive(Debug, Clone)]
pub struct Runs<M> {
    /// The simulated runs, the nominal rig first.
    pub done: Vec<Run<M>>,
    /// The variants not simulated.
    pub unstable: Vec<Unstable>,
}

/// What a step simulation was asked for.
#[derive(Debug, Clone, Copy)]
pub struct StepSetup<'a> {
    /// Where the rig comes from, in words.
    pub rig: &'a str,
    /// The rig's circuit, which every output names.
    pub circuit: CircuitKind,
    /// The step (mm) from the operating point x0.
    pub step_mm: f64,
    /// The simulated duration (s).
    pub duration_s: f64,
    /// The sample rate (Hz).
    pub rate_hz: f64,
}

/// A record replayed through the model.
#[derive(Debug, Clone, Copy)]
pub struct Replay<'a> {
    /// The record.
    pub record: &'a Record,
    /// The rig it was replayed on, in words.
    pub rig: &'a str,
    /// The rig's circuit, which every output names.
    pub circuit: CircuitKind,
    /// Whether the rig is a dataset's own conditions, which the text then names.
    pub own_conditions: bool,
    /// The end of the fit window (s) on the record's time axis.
    pub fit_end_s: f64,
}

impl Replay<'_> {
    /// The samples at or before the end of the fit window.
    pub fn samples_in_window(&self) -> usize {
        let end = self.fit_end_s;
        self.record.time_s.iter().filter(|&&t| t <= end).count()
    }
}

/// `[{"label": …, key: metrics, "over_ratings": […]}, …]` for `runs`.
fn labelled<M: Serialize>(runs: &[Run<M>], key: &str) -> Value {
    runs.iter()
        .map(|r| json!({"label": r.label, key: r.metrics, "over_ratings": r.over_ratings}))
        .collect()
}

/// A warning line per drive rating a run exceeds, the run named by `label` (empty when every
/// run stays within the ratings, docs/simulation.md#drive-ratings).
fn over_rating_lines<M>(runs: &[Run<M>], label: impl Fn(&Run<M>) -> String) -> String {
    runs.iter()
        .map(|r| rating_warnings(&label(r), &r.over_ratings))
        .collect()
}

/// A `warning:` line per drive rating in `over` that the response named `what` exceeds
/// ([`pumpcyl::response::signals_over_ratings`]; docs/simulation.md#drive-ratings).
pub fn rating_warnings(what: &str, over: &[OverRating]) -> String {
    over.iter()
        .map(|o| {
            format!(
                "warning: {what}: {o}: beyond its rating the drive saturates, and the rig does not follow this response\n"
            )
        })
        .collect()
}

/// `v` with the unstable variants as `unstable: [{"label", "unstable": reason}]`, if any.
fn with_unstable(mut v: Value, unstable: &[Unstable]) -> Value {
    if !unstable.is_empty() {
        v["unstable"] = unstable
            .iter()
            .map(|u| json!({"label": u.label, "unstable": u.reason}))
            .collect();
    }
    v
}

/// `v` with the variants after the nominal run as `compare: [{"label", key: metrics}]`, if any.
fn with_compare<M: Serialize>(mut v: Value, runs: &[Run<M>], key: &str) -> Value {
    if runs.len() > 1 {
        v["compare"] = labelled(&runs[1..], key);
    }
    v
}

/// The unstable variants as lines for a terminal, one each (empty when there are none).
fn unstable_lines(unstable: &[Unstable]) -> String {
    unstable
        .iter()
        .map(|u| format!("--compare {}: not simulated: {}\n", u.label, u.reason))
        .collect()
}

/// The runs' signals with their labels, as the figures and [`signals_csv`] take them.
pub fn series<M>(runs: &[Run<M>]) -> Vec<(String, &Signals)> {
    series_labelled(runs, |r| r.label.clone())
}

fn series_labelled<M>(
    runs: &[Run<M>],
    label: impl Fn(&Run<M>) -> String,
) -> Vec<(String, &Signals)> {
    runs.iter().map(|r| (label(r), &r.signals)).collect()
}

/// A MAT column per metric: `f` of each run's metrics.
fn column<M>(runs: &[Run<M>], f: impl Fn(&M) -> Option<f64>) -> Vec<Option<f64>> {
    runs.iter().map(|r| f(&r.metrics)).collect()
}

/// The step document (`step --json`): `rig`, its `circuit` ([`CircuitKind::name`]), `step_mm`, the nominal `metrics` (the core's
/// [`StepMetrics`], with `ringing` when the loop barely damps) and `over_ratings` (the drive
/// ratings exceeded, [`OverRating`]), and `compare` and `unstable` for the variants.
pub fn step_json(setup: &StepSetup, runs: &Runs<StepMetrics>) -> Value {
    let nominal = &runs.done[0];
    let v = json!({
        "rig": setup.rig, "circuit": setup.circuit.name(), "step_mm": setup.step_mm,
        "metrics": nominal.metrics,
        "over_ratings": nominal.over_ratings,
    });
    with_unstable(with_compare(v, &runs.done, "metrics"), &runs.unstable)
}

/// The step metrics as text: a heading, one column per run and one row per metric (the
/// least damping next to the overshoot when some run rings), then the warnings and the
/// unstable variants.
pub fn step_text(setup: &StepSetup, runs: &Runs<StepMetrics>) -> String {
    let mut s = format!(
        "step {:+} mm, {} Hz, {} s ({}, circuit {}{})\n",
        setup.step_mm,
        setup.rate_hz,
        setup.duration_s,
        setup.rig,
        setup.circuit.name(),
        if setup.circuit.has_sum_pressure_loop() {
            "; sum-pressure loop as the rig says"
        } else {
            ""
        }
    );
    let _ = write!(s, "{:<24}", "");
    for r in &runs.done {
        let _ = write!(s, " {:>22}", r.label);
    }
    s.push('\n');
    type Row = (&'static str, fn(&StepMetrics) -> String);
    let rows: [Row; 8] = [
        ("rise time 10-90 % (s)", |m| fmt_opt(m.rise_time_s, 3)),
        ("overshoot (mm)", |m| format!("{:.3}", m.overshoot_mm)),
        ("overshoot (%)", |m| format!("{:.2}", m.overshoot_pct)),
        ("peak time (s)", |m| format!("{:.2}", m.peak_time_s)),
        ("settling time 2 % (s)", |m| {
            m.settling_time_s
                .map_or("not settled".into(), |t| format!("{t:.2}"))
        }),
        ("steady-state error (mm)", |m| {
            format!("{:.4}", m.steady_state_error_mm)
        }),
        ("error at end (mm)", |m| format!("{:.4}", m.final_error_mm)),
        ("rest offset (mm)", |m| {
            m.rest_offset_mm.map_or("-".into(), |v| format!("{v:.4}"))
        }),
    ];
    let rings = runs.done.iter().any(|r| r.metrics.ringing.is_some());
    for (k, (name, f)) in rows.into_iter().enumerate() {
        let _ = write!(s, "{name:<24}");
        for r in &runs.done {
            let _ = write!(s, " {:>22}", f(&r.metrics));
        }
        s.push('\n');
        if k == 2 && rings {
            s += &ringing_row(&runs.done);
        }
    }
    s += &ringing_lines(&runs.done);
    s += REST_OFFSET_NOTE;
    s += &over_rating_lines(&runs.done, |r| r.label.clone());
    s + &unstable_lines(&runs.unstable)
}

/// What the rest offset in the errors of `step` and `track` is, in one line.
pub const REST_OFFSET_NOTE: &str = "the errors hold the rest offset: the standing error x_ref - x \
     with which the P law holds the load and feeds the leakage at rest (docs/simulation.md#the-rest-under-load)\n";

/// The row of the least-damped closed-loop pole, `ζ 0.012 at 2.31 Hz` (`-` for a run that
/// does not ring).
fn ringing_row(runs: &[Run<StepMetrics>]) -> String {
    let mut s = format!("{:<24}", "least damping");
    for r in runs {
        let cell = r.metrics.ringing.map_or("-".into(), |g| {
            format!("ζ {:.3} at {:.2} Hz", g.damping_ratio, g.natural_freq_hz)
        });
        let _ = write!(s, " {cell:>22}");
    }
    s + "\n"
}

/// A warning line per run whose loop barely damps its step (docs/simulation.md#ringing).
fn ringing_lines(runs: &[Run<StepMetrics>]) -> String {
    let mut s = String::new();
    for r in runs {
        if let Some(g) = r.metrics.ringing {
            let _ = writeln!(s, "warning: {}: {}", r.label, ringing_text(&g));
        }
    }
    s
}

/// The damping warning in words.
pub fn ringing_text(g: &Ringing) -> String {
    format!(
        "gain margin {:.2} dB, under {RINGING_GM_DB} dB: the step rings on (least-damped \
         closed-loop pole {:.2} Hz, damping ratio {:.3}), more than its overshoot shows",
        g.gain_margin_db, g.natural_freq_hz, g.damping_ratio
    )
}

/// The title of a step figure or MAT-file, `x0_mm` the operating point (mm).
pub fn step_title(setup: &StepSetup, x0_mm: f64) -> String {
    format!(
        "Step {:+} mm from x0 = {} mm ({})",
        setup.step_mm, x0_mm, setup.rig
    )
}

/// The subtitle of a step figure: rise time, overshoot and settling time of `m`.
pub fn step_subtitle(m: &StepMetrics) -> String {
    let ringing = m.ringing.map_or(String::new(), |g| {
        format!(
            "; RINGS: GM {:.2} dB, ζ {:.3} at {:.2} Hz",
            g.gain_margin_db, g.damping_ratio, g.natural_freq_hz
        )
    });
    format!(
        "rise {} s, overshoot {:.2} mm ({:.1} %){ringing}, settling (2 %) {}",
        fmt_opt(m.rise_time_s, 3),
        m.overshoot_mm,
        m.overshoot_pct,
        m.settling_time_s
            .map_or("not within the run".into(), |t| format!("{t:.2} s"))
    )
}

/// The step MAT-file: the signals of every run, as [`signals_mat`], and one column per metric
/// (`step_mm`, `rise_time_s`, …, one value per run; NaN where not reached or not settled).
pub fn step_mat(title: &str, runs: &[Run<StepMetrics>]) -> Vec<u8> {
    let scalars = [
        ("step_mm", column(runs, |m| Some(m.step_mm))),
        ("rise_time_s", column(runs, |m| m.rise_time_s)),
        ("overshoot_mm", column(runs, |m| Some(m.overshoot_mm))),
        ("overshoot_pct", column(runs, |m| Some(m.overshoot_pct))),
        ("peak_time_s", column(runs, |m| Some(m.peak_time_s))),
        ("settling_time_s", column(runs, |m| m.settling_time_s)),
        (
            "steady_state_error_mm",
            column(runs, |m| Some(m.steady_state_error_mm)),
        ),
        ("final_error_mm", column(runs, |m| Some(m.final_error_mm))),
        ("rest_offset_mm", column(runs, |m| m.rest_offset_mm)),
    ];
    signals_mat(title, &series(runs), None, &scalars)
}

/// The tracking document (`track --json`): `rig`, its `circuit` ([`CircuitKind::name`]), `cases` (`label`, the core's
/// [`TrackMetrics`] of every run, whose `window.steady_state` says they are the periodic
/// steady state, and its `over_ratings`) and `unstable`.
pub fn track_json(rig: &str, circuit: CircuitKind, runs: &Runs<TrackMetrics>) -> Value {
    let v = json!({
        "rig": rig, "circuit": circuit.name(), "cases": labelled(&runs.done, "metrics"),
    });
    with_unstable(v, &runs.unstable)
}

/// The tracking metrics as text: a heading naming the rig and its circuit, one row per run, then the warnings and the unstable variants. The metrics are
/// the periodic steady state ([`pumpcyl::response::track`]), as the heading says.
pub fn track_text(rig: &str, circuit: CircuitKind, runs: &Runs<TrackMetrics>) -> String {
    let mut s = format!(
        "sinusoidal tracking ({rig}, circuit {}), metrics of the periodic steady state (every period alike)\n",
        circuit.name()
    );
    let _ = writeln!(
        s,
        "{:<22} {:>8} {:>8} {:>12} {:>12} {:>15} {:>15}",
        "variant",
        "freq_hz",
        "amp_mm",
        "max_err_mm",
        "rms_err_mm",
        "wave_reduction",
        "rest_offset_mm"
    );
    for Run {
        label, metrics: m, ..
    } in &runs.done
    {
        let _ = writeln!(
            s,
            "{label:<22} {:>8.3} {:>8.1} {:>12.3} {:>12.3} {:>15.3} {:>15}",
            m.freq_hz,
            m.amp_mm,
            m.max_error_mm,
            m.rms_error_mm,
            m.wave_reduction,
            m.rest_offset_mm.map_or("-".into(), |v| format!("{v:.3}"))
        );
    }
    s += REST_OFFSET_NOTE;
    s += &over_rating_lines(&runs.done, |r| {
        format!(
            "{} Hz ±{} mm {}",
            r.metrics.freq_hz, r.metrics.amp_mm, r.label
        )
    });
    s + &unstable_lines(&runs.unstable)
}

/// The periods tracking metrics are measured over, in words: `periods 3–4, t = 21–41 s`
/// (`period 3, t = 21–31 s` for one).
pub fn window_text(w: &TrackWindow) -> String {
    let t = |s: f64| (s * 1e3).round() / 1e3;
    let periods = match w.periods {
        [a, b] if a == b => format!("period {a}"),
        [a, b] => format!("periods {a}–{b}"),
    };
    format!("{periods}, t = {}–{} s", t(w.from_s), t(w.to_s))
}

/// The tracking runs' signals, each labelled with its sine (`0.2 Hz ±35 mm nominal`).
pub fn track_series(runs: &[Run<TrackMetrics>]) -> Vec<(String, &Signals)> {
    series_labelled(runs, |r| {
        format!(
            "{} Hz ±{} mm {}",
            r.metrics.freq_hz, r.metrics.amp_mm, r.label
        )
    })
}

/// The tracking MAT-file: the signals of [`track_series`] and one column per metric
/// (`freq_hz`, `amp_mm`, `max_error_mm`, `rms_error_mm`, `wave_reduction`; one value per run).
pub fn track_mat(runs: &[Run<TrackMetrics>]) -> Vec<u8> {
    let scalars = [
        ("freq_hz", column(runs, |m| Some(m.freq_hz))),
        ("amp_mm", column(runs, |m| Some(m.amp_mm))),
        ("max_error_mm", column(runs, |m| Some(m.max_error_mm))),
        ("rms_error_mm", column(runs, |m| Some(m.rms_error_mm))),
        ("wave_reduction", column(runs, |m| Some(m.wave_reduction))),
        ("rest_offset_mm", column(runs, |m| m.rest_offset_mm)),
    ];
    signals_mat("Sinusoidal tracking", &track_series(runs), None, &scalars)
}

/// The tracking figure: one position panel per run (reference dashed), then every run's
/// control error together; the subtitle lists the maximum errors and wave reductions.
pub fn track_chart(runs: &[Run<TrackMetrics>]) -> Chart {
    let mut panels = Vec::new();
    let mut errors = Panel {
        y_label: "Control error (mm)".into(),
        traces: Vec::new(),
        ..Default::default()
    };
    for (i, ((label, s), r)) in track_series(runs).iter().zip(runs).enumerate() {
        panels.push(Panel {
            y_label: format!("Position (mm), {} Hz", r.metrics.freq_hz),
            traces: vec![
                trace("x_ref", &s.time_s, &s.x_ref_mm, LineStyle::Dashed, Some(6)),
                trace(
                    &format!("x {label}"),
                    &s.time_s,
                    &s.x_mm,
                    LineStyle::Solid,
                    Some(i),
                ),
            ],
            ..Default::default()
        });
        errors
            .traces
            .push(trace(label, &s.time_s, &s.e_mm, LineStyle::Solid, Some(i)));
    }
    panels.push(errors);
    let list = |f: fn(&TrackMetrics) -> String| -> String {
        runs.iter()
            .map(|r| f(&r.metrics))
            .collect::<Vec<_>>()
            .join(" / ")
    };
    let subtitle = format!(
        "periodic steady state: max|e| {} mm; wave reduction {}",
        list(|m| format!("{:.1}", m.max_error_mm)),
        list(|m| format!("{:.2}", m.wave_reduction))
    );
    let title = "Sinusoidal tracking (the article)";
    Chart::time(title, Some(&subtitle), panels)
}

/// The replay document (`simulate --json`): `file`, `rig`, its `circuit`
/// ([`CircuitKind::name`]), the nominal run's position MSE
/// `mse_mm2` (mm²) over the fit window up to `fit_end_s` (s), `samples_in_window`,
/// `over_ratings` (the drive ratings the simulated response exceeds, [`OverRating`]), and
/// `compare` (`label`, `mse_mm2`, `over_ratings`) and `unstable` for the variants.
pub fn simulate_json(replay: &Replay, runs: &Runs<f64>) -> Value {
    let nominal = &runs.done[0];
    let v = json!({
        "file": replay.record.file, "rig": replay.rig, "circuit": replay.circuit.name(),
        "mse_mm2": nominal.metrics,
        "fit_end_s": replay.fit_end_s, "samples_in_window": replay.samples_in_window(),
        "over_ratings": nominal.over_ratings,
    });
    with_unstable(with_compare(v, &runs.done, "mse_mm2"), &runs.unstable)
}

/// The replay as text: the record, the circuit, its samples and fit window, each run's position MSE (mm²),
/// then the warnings and the unstable variants.
pub fn simulate_text(replay: &Replay, runs: &Runs<f64>) -> String {
    let conditions = if replay.own_conditions {
        format!(" ({}, circuit {})", replay.rig, replay.circuit.name())
    } else {
        format!(" (circuit {})", replay.circuit.name())
    };
    let mut s = format!(
        "{}{conditions}: {} samples, fit window up to {} s ({} samples)\n",
        replay.record.file,
        replay.record.len(),
        replay.fit_end_s,
        replay.samples_in_window()
    );
    for r in &runs.done {
        let _ = writeln!(s, "  {:<24} position MSE {:.5} mm²", r.label, r.metrics);
    }
    s += &over_rating_lines(&runs.done, |r| format!("sim {}", r.label));
    s + &unstable_lines(&runs.unstable)
}

/// The title of a replay's figure or MAT-file: the record's file name and the rig.
pub fn simulate_title(replay: &Replay) -> String {
    format!(
        "{} against the model ({})",
        shown_name(&replay.record.file),
        replay.rig
    )
}

/// The subtitle of a replay's figure: the nominal run's position MSE (mm²) `mse_mm2`.
pub fn simulate_subtitle(replay: &Replay, mse_mm2: f64) -> String {
    format!(
        "position MSE {mse_mm2:.4} mm² up to t = {} s",
        replay.fit_end_s
    )
}

/// The replayed runs' signals, labelled `sim <label>`.
pub fn simulate_series(runs: &[Run<f64>]) -> Vec<(String, &Signals)> {
    series_labelled(runs, |r| format!("sim {}", r.label))
}

/// The replay MAT-file: the `measured` record first, the runs of [`simulate_series`], the
/// position MSE of each run `mse_mm2` (mm²) and `fit_end_s` (s).
pub fn simulate_mat(replay: &Replay, runs: &[Run<f64>], measured: &Signals) -> Vec<u8> {
    let scalars = [
        ("mse_mm2", column(runs, |m| Some(*m))),
        ("fit_end_s", vec![Some(replay.fit_end_s)]),
    ];
    let series = simulate_series(runs);
    signals_mat(&simulate_title(replay), &series, Some(measured), &scalars)
}

/// CSV of signals: `time_s`, then a block of columns `x_ref_mm, x_mm, e_mm, p1_bar, p2_bar,
/// w1_rpm, w2_rpm` per series, the `measured` record first when given; blocks after the first
/// carry their label as a suffix (`x_mm[label]`; a label with a comma is quoted, as any CSV
/// cell). Values in the records' number format ([`csv_number`]); a series shorter than the
/// longest leaves its cells empty.
pub fn signals_csv(series: &[(String, &Signals)], measured: Option<&Signals>) -> String {
    let mut blocks: Vec<(&str, &Signals)> = Vec::new();
    if let Some(m) = measured {
        blocks.push(("measured", m));
    }
    blocks.extend(series.iter().map(|(l, s)| (l.as_str(), *s)));
    let mut header = vec!["time_s".to_string()];
    for (i, (label, s)) in blocks.iter().enumerate() {
        for (n, _) in &s.named()[1..] {
            header.push(if i == 0 {
                n.to_string()
            } else {
                format!("{n}[{label}]")
            });
        }
    }
    let len = blocks
        .iter()
        .map(|(_, s)| s.time_s.len())
        .max()
        .unwrap_or(0);
    let row = |k: usize| {
        let t = blocks
            .iter()
            .find_map(|(_, s)| s.time_s.get(k))
            .copied()
            .unwrap_or(f64::NAN);
        let cells = blocks.iter().flat_map(move |(_, s)| {
            s.named()[1..]
                .iter()
                .map(move |(_, v)| v.get(k).map_or(String::new(), |x| csv_number(*x)))
                .collect::<Vec<_>>()
        });
        std::iter::once(csv_number(t))
            .chain(cells)
            .collect::<Vec<_>>()
    };
    csv_text(&header, (0..len).map(row))
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::response::{signals_over_ratings, step, step_metrics_of};
    use pumpcyl::rig::Rig;

    fn step_runs(rigs: &[(&str, Rig)]) -> Runs<StepMetrics> {
        let done = rigs
            .iter()
            .map(|(label, rig)| {
                let signals = step(rig, 5.0, 1.0, 100.0).unwrap();
                let metrics = step_metrics_of(rig, &signals, 5.0);
                Run {
                    label: label.to_string(),
                    over_ratings: signals_over_ratings(rig, &signals),
                    signals,
                    metrics,
                }
            })
            .collect();
        Runs {
            done,
            unstable: vec![Unstable {
                label: "kp=400".into(),
                reason: "the closed loop is unstable".into(),
            }],
        }
    }

    #[test]
    fn the_step_documents_hold_every_run() {
        let rig = Rig::default();
        let slow = rig.with_overrides_from("--set", &["kp=10".into()]).unwrap();
        let runs = step_runs(&[("nominal", rig), ("kp=10", slow)]);
        let setup = StepSetup {
            rig: "default rig",
            circuit: pumpcyl::circuit::CircuitKind::Dpm,
            step_mm: 5.0,
            duration_s: 1.0,
            rate_hz: 100.0,
        };
        let v = step_json(&setup, &runs);
        let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort_unstable();
        assert_eq!(
            keys,
            [
                "circuit",
                "compare",
                "metrics",
                "over_ratings",
                "rig",
                "step_mm",
                "unstable"
            ]
        );
        assert_eq!(v["over_ratings"], json!([]));
        assert_eq!(v["compare"][0]["label"], "kp=10");
        assert_eq!(v["metrics"]["step_mm"], 5.0);
        assert_eq!(v["unstable"][0]["label"], "kp=400");
        let text = step_text(&setup, &runs);
        // heading, column labels, eight metrics, the rest offset's note, one unstable variant
        assert_eq!(text.lines().count(), 12, "{text}");
        assert!(text.ends_with("--compare kp=400: not simulated: the closed loop is unstable\n"));
    }

    #[test]
    fn the_signals_csv_has_a_block_per_series_and_a_row_per_sample() {
        let runs = step_runs(&[("nominal", Rig::default())]);
        let s = &runs.done[0].signals;
        let csv = signals_csv(&[("a,b".to_string(), s)], Some(s));
        let mut lines = csv.lines();
        assert!(lines
            .next()
            .unwrap()
            .ends_with(",\"w1_rpm[a,b]\",\"w2_rpm[a,b]\""));
        assert_eq!(lines.count(), s.time_s.len());
        // read back as any CSV reader reads it: the label whole, a value per cell
        let mut reader = csv::Reader::from_reader(csv.as_bytes());
        let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header.len(), 1 + 2 * 7);
        assert_eq!(header[..3], ["time_s", "x_ref_mm", "x_mm"]);
        assert_eq!(header[8], "x_ref_mm[a,b]");
        let last = reader.records().last().unwrap().unwrap();
        let x: f64 = last[9].parse().unwrap();
        assert!((x - s.x_mm.last().unwrap()).abs() <= 5e-7, "{x}");
    }
}
