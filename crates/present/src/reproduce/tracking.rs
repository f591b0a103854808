//! The sinusoidal tracking of the article's §3.4 (Figures 16–18): the emulated records against
//! the model (docs/simulation.md#tracking-metrics).
//!
//! The records are measured over whole periods that start once the start-up transient of the
//! identified loop has decayed below 1 %; the model is its periodic steady state, on the same
//! samples.

use super::{agrees, printed, summary, Run, Source};
use crate::figures::Chart;
use crate::time::window_text;
use anyhow::{anyhow, Result};
use pumpcyl::emulator::article;
use pumpcyl::record::Record;
use pumpcyl::response::{
    steady_sine, track_metrics, transient_decay_s, Baseline, Signals, TrackMetrics, TrackWindow,
    ARTICLE_SINE_CASES,
};
use pumpcyl::rig::Rig;

/// One wave measured: the record and the model over the same periods.
struct Measured {
    /// The emulated record over the measured periods.
    record: Signals,
    /// The model's periodic steady state on the same samples.
    model: Signals,
    /// The record's metrics.
    emulated: TrackMetrics,
    /// The model's metrics.
    steady: TrackMetrics,
}

/// The record `rec` of the wave `freq_hz` ± `amp_mm` (starting at [`article::SINE_START_S`])
/// over its whole periods after `decay_s`, and the periodic steady state of `nominal` there.
fn measure(
    rec: &Record,
    nominal: &Rig,
    freq_hz: f64,
    amp_mm: f64,
    decay_s: f64,
) -> Result<Measured> {
    let end_s = rec.time_s[rec.len() - 1];
    let window = TrackWindow::after_decay(article::SINE_START_S, freq_hz, decay_s, end_s)
        .ok_or_else(|| {
            anyhow!(
                "{}: no whole period of the wave after the start-up transient ({decay_s:.1} s) before the record ends at {end_s} s",
                rec.file
            )
        })?;
    let record = Signals::of_record(rec).over(&window);
    // the record's pressures and speeds at rest, the position off the reference by the
    // model's own rest offset (docs/simulation.md#the-rest-under-load): the model's error is
    // its own, the standing error it predicts included, as `track` gives it
    let rest = Baseline::of_record(rec, nominal);
    let own = Baseline::of_rig(nominal);
    let base = Baseline {
        x_mm: rest.x_ref_mm - (own.x_ref_mm - own.x_mm),
        ..rest
    };
    let model = steady_sine(
        nominal,
        freq_hz,
        amp_mm,
        article::SINE_START_S,
        &record.time_s,
        &base,
    )?;
    let metrics = |s: &Signals, window| track_metrics(&s.time_s, &s.e_mm, freq_hz, amp_mm, window);
    let steady = TrackWindow {
        steady_state: true,
        ..window
    };
    Ok(Measured {
        emulated: metrics(&record, window),
        steady: metrics(&model, steady),
        record,
        model,
    })
}

/// Step 7: the three sinusoids of the article (docs/simulation.md#tracking-metrics), emulated
/// records against the model.
pub(super) fn tracking(run: &mut Run, nominal: &Rig) -> Result<Vec<summary::Tracking>> {
    run.step("Sinusoidal tracking (docs/simulation.md#tracking-metrics)");
    let files = [
        "sine_0.10hz_50mm.csv",
        "sine_0.20hz_35mm.csv",
        "sine_0.25hz_20mm.csv",
    ];
    let decay_s = transient_decay_s(nominal)?;
    run.text(&format!(
        "The identified loop's start-up transient decays below 1 % in {decay_s:.1} s (ln 100 over \
         the decay rate of its slowest pole). Each emulated record is measured over its whole \
         periods that start after that; the model is its periodic steady state on the same samples."
    ));
    let mut out = Vec::new();
    let mut rows = Vec::new();
    let mut spans = Vec::new();
    let stems = [16, 17, 18];
    for ((((f, a), file), (article_e, article_r)), number) in ARTICLE_SINE_CASES
        .iter()
        .zip(files)
        .zip(
            printed::TRACK_MAX_ERROR_MM
                .into_iter()
                .zip(printed::WAVE_REDUCTION),
        )
        .zip(stems)
    {
        let rec = Record::read_in(&article::Embedded, &run.record(file))?;
        let w = measure(&rec, nominal, *f, *a, decay_s)?;
        let (m, s) = (w.emulated, w.steady);
        let over = window_text(&m.window);
        spans.push(format!("{f} Hz {over}"));
        rows.push(vec![
            format!("{f} Hz, ±{a} mm"),
            format!("{article_e}"),
            format!("{:.2}", m.max_error_mm),
            format!("{:.2}", s.max_error_mm),
            format!("{:.1} %", 100.0 * m.wave_reduction),
            format!("{:.1} %", 100.0 * s.wave_reduction),
        ]);
        out.push(summary::Tracking {
            freq_hz: *f,
            amp_mm: *a,
            emulated: m,
            model: s,
            transient_decay_s: decay_s,
            measured_over: over.clone(),
            article_measured_max_error_mm: article_e,
            article_measured_wave_reduction: article_r,
        });
        compare(run, (*f, *a), &m, &s, (article_e, article_r));
        let title = format!("Sinusoid {f} Hz, ±{a} mm: emulated record against the model");
        let subtitle = format!(
            "{over}; max |e|: {:.2} mm emulated, {:.2} mm model (steady state); wave reduction {:.1} % / {:.1} %",
            m.max_error_mm,
            s.max_error_mm,
            100.0 * m.wave_reduction,
            100.0 * s.wave_reduction
        );
        let series = [("model (steady state)".to_string(), &w.model)];
        let stem = format!("sine_{}hz", format!("{f:.2}").replace('.', "p"));
        let chart = Chart::signals_of(
            &title,
            Some(&subtitle),
            &series,
            Some(("emulated", &w.record)),
            None,
        );
        run.figure(&stem, Source::Article(number), &title, &chart)?;
    }
    run.table(
        &format!(
            "Tracking: the emulated records over their whole periods after the start-up \
             transient ({}), the model in its periodic steady state",
            spans.join("; ")
        ),
        &[
            "case",
            "max |e| article, real rig (mm)",
            "max |e| emulated (mm)",
            "max |e| model (mm)",
            "wave reduction emulated",
            "wave reduction model",
        ],
        rows,
    );
    Ok(out)
}

/// The comparison rows of one wave (`f` Hz, ± `a` mm): the model's steady state `s` against
/// the article's measured max error and wave reduction `article`, the emulated record's `m`.
fn compare(
    run: &mut Run,
    (f, a): (f64, f64),
    m: &TrackMetrics,
    s: &TrackMetrics,
    article: (f64, f64),
) {
    let (article_e, article_r) = article;
    let over = window_text(&m.window);
    let why = if agrees(s.max_error_mm, article_e, 0.01) {
        String::new()
    } else {
        format!(
            "the article's is measured on the real rig; LTI model {:.2} mm (steady state), emulated rig {:.2} mm ({over})",
            s.max_error_mm, m.max_error_mm
        )
    };
    run.compare_why(
        &format!("max control error {f} Hz, ±{a} mm (mm)"),
        format!("{:.2} (LTI model, steady state)", s.max_error_mm),
        &format!("{article_e} (real rig)"),
        &format!("{:.2} (emulated rig, {over})", m.max_error_mm),
        &why,
    );
    run.compare_why(
        &format!("wave reduction {f} Hz, ±{a} mm"),
        format!(
            "{:.1} % (LTI model, steady state)",
            100.0 * s.wave_reduction
        ),
        &format!("{:.0} % (real rig)", 100.0 * article_r),
        &format!("{:.1} % (emulated rig, {over})", 100.0 * m.wave_reduction),
        if agrees(100.0 * s.wave_reduction, 100.0 * article_r, 1.0) {
            ""
        } else {
            "1 − max |e| / amplitude: follows the max error row above"
        },
    );
}
