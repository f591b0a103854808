//! The frequency analyses as every front end shows them (docs/analysis.md): margins as a JSON
//! document and as text.
//!
//! One convention for margins everywhere (command line, summary.json, Python): a margin is a
//! number, or `null` (Python `None`) when it is infinite because there is no crossing of that
//! kind; a crossover frequency is `null` where there is no crossing. A NaN is never written.

use crate::format::fmt_opt;
use pumpcyl::lti::{CrossingKind, Margins};
use serde::Serialize;
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
}

/// The margins of the loop `description` as a JSON document (the command line's
/// `margins --json`, Python's `margins`).
pub fn margins_json(m: &Margins, description: &str) -> serde_json::Value {
    serde_json::to_value(MarginsReport {
        description,
        margins: m,
    })
    .expect("margins serialise")
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
    let verdict = if m.closed_loop_stable {
        "stable"
    } else {
        "UNSTABLE"
    };
    let _ = writeln!(
        s,
        "  closed loop   {verdict} (from the closed-loop eigenvalues)"
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
        let _ = writeln!(
            s,
            "  {kind:<6} {:>9.4} {:>9.2} {:>11.2}  {margin}",
            c.frequency_hz, c.magnitude_db, c.phase_deg
        );
    }
    s
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
}
