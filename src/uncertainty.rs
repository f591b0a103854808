//! `pumpcyl identify --uncertainty`: the noise level, profile-likelihood intervals of β, b and
//! c12 and their profiles, formatted (docs/identification.md, "Uncertainty").

use anyhow::Result;
use serde_json::json;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use crate::ident::{identification_json, identification_text, write_result_folder};
use crate::time::render_both;
use pumpcyl::ident::{analyze, Experiment, Identification, Uncertainty, UncertaintyOptions};
use pumpcyl_present::figures::{
    parameter_index as index, parameter_value as value, Chart, PARAMETER_UNITS as UNITS,
};

/// Lag-1 autocorrelation of the residuals above which the text warns that they are not white
/// (white noise stays within about 2/√N of 0, below 0.1 for a few hundred samples).
const CORRELATED: f64 = 0.3;

/// Analyse the uncertainty of an identification and report it with the identification:
/// JSON (the identification's fields plus `intervals`, `confidence`, `noise_std_mm`,
/// `identifiable`, `profiles`) or text; with `out`, the identification's files plus one profile
/// figure per parameter.
pub(super) fn report(
    exp: &Experiment,
    id: &Identification,
    seconds: f64,
    confidence: f64,
    json_out: bool,
    out: Option<&Path>,
) -> Result<String> {
    let start = Instant::now();
    let opts = UncertaintyOptions {
        confidence,
        ..UncertaintyOptions::default()
    };
    let u = analyze(&exp.problem, &id.best().candidate, &opts)?;
    let unc_seconds = start.elapsed().as_secs_f64();
    let mut v = identification_json(exp, id, seconds)?;
    add_json(&mut v, &u, unc_seconds);
    if let Some(dir) = out {
        write_result_folder(dir, exp, id, &v, |folder| write_profiles(folder, &u))?;
    }
    if json_out {
        return Ok(serde_json::to_string_pretty(&v)? + "\n");
    }
    Ok(identification_text(exp, id, seconds) + &text(&u, unc_seconds))
}

/// Add the uncertainty's fields to the identification's JSON.
fn add_json(v: &mut serde_json::Value, u: &Uncertainty, seconds: f64) {
    let mut intervals = serde_json::Map::new();
    let mut identifiable = serde_json::Map::new();
    let mut profiles = serde_json::Map::new();
    for p in &u.profiles {
        intervals.insert(p.parameter.into(), json!(p.interval));
        identifiable.insert(p.parameter.into(), json!(p.identifiable));
        let points: Vec<_> = p
            .points
            .iter()
            .map(|q| json!({"value": q.value, "statistic": q.statistic, "sse_mm2": q.sse_mm2}))
            .collect();
        profiles.insert(p.parameter.into(), json!(points));
    }
    v["intervals"] = intervals.into();
    v["identifiable"] = identifiable.into();
    v["confidence"] = json!(u.confidence);
    v["noise_std_mm"] = json!(u.noise_std_mm);
    v["chi2_threshold"] = json!(u.threshold);
    v["samples"] = json!(u.samples);
    v["residual_autocorrelation"] = json!(u.residual_autocorrelation);
    v["variance_inflation"] = json!(u.variance_inflation);
    v["sse_offset_free_mm2"] = json!(u.sse_mm2);
    v["profiles"] = profiles.into();
    v["uncertainty_seconds"] = json!(seconds);
}

/// The text lines of the uncertainty.
fn text(u: &Uncertainty, seconds: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "uncertainty: {:.0} % profile-likelihood intervals (Delta SSE / sigma^2 <= {:.3}), \
         noise sigma {:.4} mm from {} samples, in {seconds:.2} s",
        u.confidence * 100.0,
        u.threshold,
        u.noise_std_mm,
        u.samples
    );
    if u.residual_autocorrelation > CORRELATED {
        let _ = writeln!(
            s,
            "  note: the residuals are correlated (lag-1 autocorrelation {:.2}): they are \
             mostly model error, not white noise; sigma^2 is inflated {:.0}-fold for it \
             (docs/identification.md, \"Uncertainty\")",
            u.residual_autocorrelation, u.variance_inflation
        );
    }
    for p in &u.profiles {
        let i = index(p.parameter);
        let verdict = if p.identifiable {
            String::from("identifiable")
        } else {
            let sides: Vec<&str> = [("below", p.crossed[0]), ("above", p.crossed[1])]
                .iter()
                .filter(|(_, c)| !c)
                .map(|(side, _)| *side)
                .collect();
            format!(
                "NOT identifiable from these records: the profile stays under the threshold \
                 {} the estimate up to the search bound",
                sides.join(" and ")
            )
        };
        let _ = writeln!(
            s,
            "  {:<26} {} .. {} {}  {verdict}",
            p.parameter,
            value(i, p.interval[0]),
            value(i, p.interval[1]),
            UNITS[i]
        );
    }
    s
}

/// One figure per profile: `profile-NAME.svg` and `.png`.
fn write_profiles(dir: &Path, u: &Uncertainty) -> Result<()> {
    for p in &u.profiles {
        render_both(
            &dir.join(format!("profile-{}", p.parameter)),
            &Chart::profile(u, p),
        )?;
    }
    Ok(())
}
