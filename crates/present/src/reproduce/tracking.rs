//! The sinusoidal tracking of the article's §3.4 (Figures 16–18): the emulated records against
//! the model (docs/simulation.md#tracking-metrics).

use super::{agrees, printed, summary, Run, Source};
use crate::figures::Chart;
use anyhow::Result;
use pumpcyl::emulator::article;
use pumpcyl::record::Record;
use pumpcyl::response::{simulate, track_metrics, Baseline, Signals, ARTICLE_SINE_CASES};
use pumpcyl::rig::Rig;

/// Step 8: the three sinusoids of the article (docs/simulation.md#tracking-metrics), emulated records against the model.
pub(super) fn tracking(run: &mut Run, nominal: &Rig) -> Result<Vec<summary::Tracking>> {
    run.step("Sinusoidal tracking (docs/simulation.md#tracking-metrics)");
    let files = [
        "sine_0.10hz_50mm.csv",
        "sine_0.20hz_35mm.csv",
        "sine_0.25hz_20mm.csv",
    ];
    let mut out = Vec::new();
    let mut rows = Vec::new();
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
        let measured = Signals::of_record(&rec);
        let sim = simulate(
            nominal,
            &rec.time_s,
            &rec.x_ref_mm,
            &Baseline::of_record(&rec, nominal),
        )?;
        // skip the rest before the wave starts (1 s) and its first period
        let start = rec.first_change();
        let tm = |s: &Signals| track_metrics(&s.time_s[start..], &s.e_mm[start..], *f, *a);
        let (m, s) = (tm(&measured), tm(&sim));
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
            article_measured_max_error_mm: article_e,
            article_measured_wave_reduction: article_r,
        });
        let why = if agrees(s.max_error_mm, article_e, 0.01) {
            String::new()
        } else {
            format!(
                "the article's is measured on the real rig; LTI model {:.2} mm, emulated rig {:.2} mm",
                s.max_error_mm, m.max_error_mm
            )
        };
        run.compare_why(
            &format!("max control error {f} Hz, ±{a} mm (mm)"),
            format!("{:.2} (LTI model)", s.max_error_mm),
            &format!("{article_e} (real rig)"),
            &format!("{:.2} (emulated rig)", m.max_error_mm),
            &why,
        );
        run.compare_why(
            &format!("wave reduction {f} Hz, ±{a} mm"),
            format!("{:.1} % (LTI model)", 100.0 * s.wave_reduction),
            &format!("{:.0} % (real rig)", 100.0 * article_r),
            &format!("{:.1} % (emulated rig)", 100.0 * m.wave_reduction),
            if agrees(100.0 * s.wave_reduction, 100.0 * article_r, 1.0) {
                ""
            } else {
                "1 − max |e| / amplitude: follows the max error row above"
            },
        );
        let title = format!("Sinusoid {f} Hz, ±{a} mm: emulated record against the model");
        let subtitle = format!(
            "max |e|: {:.2} mm emulated, {:.2} mm model; wave reduction {:.1} % / {:.1} %",
            m.max_error_mm,
            s.max_error_mm,
            100.0 * m.wave_reduction,
            100.0 * s.wave_reduction
        );
        let series = [("model".to_string(), &sim)];
        let stem = format!("sine_{}hz", format!("{f:.2}").replace('.', "p"));
        let chart = Chart::signals_of(
            &title,
            Some(&subtitle),
            &series,
            Some(("emulated", &measured)),
            None,
        );
        run.figure(&stem, Source::Article(number), &title, &chart)?;
    }
    run.table(
        "Tracking (after the first period)",
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
