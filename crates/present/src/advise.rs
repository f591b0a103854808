//! Experiment advice as every front end shows it (docs/identification.md#experiment-advice):
//! which further record would narrow the intervals of β (bar), b (N·s/m) and c12 (m⁵/(N·s))
//! most, as JSON and as text. Widths are relative to the estimate.

use pumpcyl::ident::{Advice, Assessment, Width};
use serde_json::{json, Value};
use std::fmt::Write as _;

/// The advice document (`advise --json`): every field of the core's [`Advice`], `experiment`,
/// the experiment file, `seconds`, the time the advice took (s), and `ranking_by_parameter`,
/// each parameter's ranking of the candidates keyed by its name.
pub fn advice_json(advice: &Advice, experiment: &str, seconds: f64) -> Value {
    let mut v = serde_json::to_value(advice).expect("advice serialises");
    v["experiment"] = json!(experiment);
    v["seconds"] = json!(seconds);
    let ranked = advice
        .current
        .iter()
        .enumerate()
        .map(|(i, w)| (w.parameter.to_string(), ranking(advice, i)));
    v["ranking_by_parameter"] = Value::Object(ranked.collect());
    v
}

/// The candidates ranked for the parameter `i` on its own, best (least expected log-std)
/// first: `[{label, log_std, interval, width, relative_width}, ...]`.
fn ranking(advice: &Advice, i: usize) -> Value {
    let mut ranked: Vec<&Assessment> = advice.candidates.iter().collect();
    ranked.sort_by(|a, b| a.widths[i].log_std.total_cmp(&b.widths[i].log_std));
    let entry = |c: &Assessment| {
        let w = &c.widths[i];
        json!({
            "label": c.label, "log_std": w.log_std, "interval": w.interval,
            "width": w.width, "relative_width": w.relative_width,
        })
    };
    ranked.into_iter().map(entry).collect()
}

/// A relative width as the tables show it: `12.3 %`, or `unbounded` when the interval reaches
/// a search bound.
pub fn width_text(w: &Width) -> String {
    w.relative_width
        .map_or("unbounded".into(), |r| format!("{:.1} %", 100.0 * r))
}

/// The advice for the experiment `name` as text: the linearisation point and noise, the
/// current widths and each candidate's (ranked), the skipped candidates, the one that helps b
/// most and the best for β and c12; `seconds` the time it took (s).
pub fn advice_text(name: &str, a: &Advice, seconds: f64) -> String {
    let mut s = String::new();
    let p = &a.point;
    let i = &a.identified;
    let _ = writeln!(
        s,
        "experiment advice for {name} (noise sigma {:.4} mm, variance inflated {:.1}-fold, \
         model error of the records' disagreement x{:.2} / x{:.2} / x{:.2} on the variances of \
         beta / b / c12; {:.0} % intervals, widths relative to the estimate), in {seconds:.1} s",
        a.noise_std_mm,
        a.variance_inflation,
        a.model_error_factor[0],
        a.model_error_factor[1],
        a.model_error_factor[2],
        a.confidence * 100.0
    );
    let _ = writeln!(
        s,
        "linearised at beta {:.1} bar, b {:.1} N·s/m, c12 {:.4e} m⁵/(N·s): the least-SSE point \
         with each record's initial position fitted (docs/identification.md#uncertainty), \
         polished from identify's answer beta {:.1} bar, b {:.1} N·s/m, c12 {:.4e} m⁵/(N·s), \
         whose cost takes the initial position from the samples at rest; where the two differ \
         most, the records bound that parameter least",
        p.beta_bar,
        p.viscous_friction_ns_per_m,
        p.c12_m5_per_ns,
        i.beta_bar,
        i.viscous_friction_ns_per_m,
        i.c12_m5_per_ns
    );
    if !a.point_from_rig.is_empty() {
        let names: Vec<&str> = (a.point_from_rig.iter())
            .map(|p| crate::identification::short_name(p))
            .collect();
        let _ = writeln!(
            s,
            "{}: identify's estimate sits at its search bound (the records do not bound it), so \
             the model is linearised at the rig file's value instead, and the current width is \
             unbounded (docs/identification.md#experiment-advice)",
            names.join(", ")
        );
    }
    let _ = match a.budget_s {
        Some(b) => writeln!(
            s,
            "each candidate weighed at {b} s of recording: its record counted {b} s over its \
             length times (docs/identification.md#experiment-advice)"
        ),
        None => writeln!(
            s,
            "each candidate is one record, whatever its length (the last figure of its label; \
             --budget-s weighs them at the same recording time)"
        ),
    };
    // the label column as wide as the longest label (a sweep's is longer than a step's)
    let w = a
        .candidates
        .iter()
        .map(|c| c.label.chars().count())
        .fold(36, usize::max);
    let _ = writeln!(
        s,
        "{:>4}  {:<w$} {:>10} {:>10} {:>10}   {:>7} {:>7} {:>7}",
        "rank", "record added", "beta", "b", "c12", "x beta", "x b", "x c12"
    );
    let _ = writeln!(
        s,
        "{:>4}  {:<w$} {:>10} {:>10} {:>10}",
        "-",
        "none (the current records)",
        width_text(&a.current[0]),
        width_text(&a.current[1]),
        width_text(&a.current[2])
    );
    for (k, c) in a.candidates.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:>4}  {:<w$} {:>10} {:>10} {:>10}   {:>7} {:>7} {:>7}",
            k + 1,
            c.label,
            width_text(&c.widths[0]),
            width_text(&c.widths[1]),
            width_text(&c.widths[2]),
            ratio_text(a, c, 0),
            ratio_text(a, c, 1),
            ratio_text(a, c, 2)
        );
    }
    for line in &a.skipped {
        let _ = writeln!(s, "skipped: {line}");
    }
    if let Some(b) = a.candidates.iter().find(|c| c.label == a.best_for[1]) {
        let _ = writeln!(s, "{}", helps_b(a, b));
    }
    let _ = writeln!(
        s,
        "best for beta: {}; best for c12: {}",
        a.best_for[0], a.best_for[2]
    );
    s
}

/// Candidate `c`'s improvement of parameter `i` in the table: `-` when the interval is
/// unbounded before and after (no width to compare).
fn ratio_text(a: &Advice, c: &Assessment, i: usize) -> String {
    if a.current[i].relative_width.is_none() && c.widths[i].relative_width.is_none() {
        "-".into()
    } else {
        format!("{:.2}", c.improvement[i])
    }
}

/// The line naming the candidate `b` that narrows b most: its width before and after, and
/// the ratio only when both are bounded (an unbounded interval has no width to compare).
fn helps_b(a: &Advice, b: &Assessment) -> String {
    let (now, then) = (&a.current[1], &b.widths[1]);
    match (now.relative_width, then.relative_width) {
        (Some(_), Some(_)) => format!(
            "helps b most: {} (b {} -> {}, {:.1} times narrower in log terms)",
            b.label,
            width_text(now),
            width_text(then),
            b.improvement[1]
        ),
        (None, Some(_)) => format!(
            "helps b most: {} (b unbounded with the current records, {} with it)",
            b.label,
            width_text(then)
        ),
        _ => "helps b most: none; b stays unbounded with the current records and with every \
              candidate (no candidate bounds it)"
            .to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::ident::{Candidate, Design};

    fn width(relative_width: Option<f64>) -> Width {
        Width {
            parameter: "beta_bar",
            log_std: 0.05,
            interval: relative_width.map(|r| [100.0, 100.0 + 100.0 * r]),
            width: relative_width.map(|r| 100.0 * r),
            relative_width,
        }
    }

    fn candidate(label: &str, b_width: f64, b_improvement: f64) -> Assessment {
        Assessment {
            design: Design::Step {
                step_mm: 5.0,
                kp: 25.0,
                duration_s: 4.0,
            },
            label: label.into(),
            duration_s: 4.0,
            repeats: 1.0,
            widths: [width(Some(0.1)), width(Some(b_width)), width(None)],
            improvement: [1.0, b_improvement, 1.0],
            score: -b_improvement.ln(),
        }
    }

    #[test]
    fn the_advice_names_the_candidate_that_narrows_b_most() {
        let a = Advice {
            point: Candidate {
                beta_bar: 165.0,
                viscous_friction_ns_per_m: 2000.0,
                c12_m5_per_ns: 1e-11,
            },
            point_from_rig: vec![],
            identified: Candidate {
                beta_bar: 166.0,
                viscous_friction_ns_per_m: 140.0,
                c12_m5_per_ns: 1e-11,
            },
            noise_std_mm: 0.02,
            variance_inflation: 1.5,
            model_error_factor: [1.0, 1.0, 2.0],
            confidence: 0.95,
            budget_s: None,
            z: 1.96,
            current: [width(Some(0.1)), width(Some(0.8)), width(None)],
            candidates: vec![
                candidate("step 5 mm", 0.2, 4.0),
                candidate("sine", 0.4, 2.0),
            ],
            skipped: vec!["sine 2 Hz: unstable".into()],
            best_for: ["sine".into(), "step 5 mm".into(), "sine".into()],
        };
        let text = advice_text("exp.toml", &a, 1.25);
        // heading, linearisation point, how record length is weighed, column names, current,
        // two candidates, skipped, helps b, best for
        assert_eq!(text.lines().count(), 10, "{text}");
        assert!(text.contains("each candidate is one record"), "{text}");
        assert!(
            text.contains("linearised at beta 165.0 bar, b 2000.0 N·s/m"),
            "{text}"
        );
        assert!(
            text.contains("identify's answer beta 166.0 bar, b 140.0 N·s/m"),
            "{text}"
        );
        assert!(text.contains("helps b most: step 5 mm (b 80.0 % -> 20.0 %, 4.0 times"));
        assert!(text.contains("unbounded"));
        let v = advice_json(&a, "exp.toml", 1.25);
        assert_eq!(v["experiment"], "exp.toml");
        assert_eq!(v["seconds"], 1.25);
        assert_eq!(v["candidates"][1]["label"], "sine");
        assert_eq!(v["current"][2]["relative_width"], Value::Null);
        assert_eq!(v["identified"]["viscous_friction_ns_per_m"], 140.0);
        // b unbounded before and after: said plainly, no ratio
        let mut both = a.clone();
        both.current[1] = width(None);
        for c in &mut both.candidates {
            c.widths[1] = width(None);
            c.improvement[1] = 7.7;
        }
        let text = advice_text("exp.toml", &both, 1.0);
        assert!(
            text.contains("b stays unbounded with the current records and with every candidate"),
            "{text}"
        );
        assert!(
            !text.contains("unbounded -> unbounded") && !text.contains("7.7"),
            "{text}"
        );
        // unbounded before, bounded after: the width after, no ratio
        let mut after = a.clone();
        after.current[1] = width(None);
        let text = advice_text("exp.toml", &after, 1.0);
        assert!(
            text.contains(
                "helps b most: step 5 mm (b unbounded with the current records, 20.0 % with it)"
            ),
            "{text}"
        );
    }
}
