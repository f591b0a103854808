//! The uncertainty of an identification as JSON fields, text lines and profile figures
//! (docs/identification.md, "Uncertainty").

use crate::figures::{parameter_index as index, parameter_value as value, Chart, PARAMETER_UNITS};
use anyhow::Result;
use pumpcyl::ident::{
    at_bound_reason, candidate_values, search_bound_at, Candidate, Profile, Uncertainty, PARAMETERS,
};
use serde_json::{json, Map, Value};
use std::fmt::Write as _;

/// Lag-1 autocorrelation of the residuals above which the text warns that they are not white
/// (white noise stays within about 2/√N of 0, below 0.1 for a few hundred samples).
const CORRELATED: f64 = 0.3;

/// Add a profile-likelihood analysis's `intervals`, `identifiable` and `profiles` (each point's
/// `value`, `statistic` and its cost under `cost_key`) to a result's JSON, keyed by parameter:
/// one layout for the step and the frequency-domain identification.
pub fn add_profiles_json(v: &mut Value, profiles: &[Profile], cost_key: &str) {
    let mut intervals = Map::new();
    let mut identifiable = Map::new();
    let mut curves = Map::new();
    for p in profiles {
        intervals.insert(p.parameter.into(), json!(p.interval));
        identifiable.insert(p.parameter.into(), json!(p.identifiable));
        let points: Vec<_> = p
            .points
            .iter()
            .map(|q| json!({"value": q.value, "statistic": q.statistic, cost_key: q.sse_mm2}))
            .collect();
        curves.insert(p.parameter.into(), json!(points));
    }
    v["intervals"] = intervals.into();
    v["identifiable"] = identifiable.into();
    v["profiles"] = curves.into();
}

/// Add `at_search_bound` (per parameter, whether the answer `c` sits at a search bound) to a
/// result's JSON, and for each that does, `identifiable` false (where the result has the key)
/// and its reason under `not_identifiable`: that value is the search's limit, not an estimate.
pub fn add_search_bound_json(v: &mut Value, c: &Candidate) {
    let values = candidate_values(c);
    let mut at = Map::new();
    for (i, p) in PARAMETERS.iter().enumerate() {
        let bound = search_bound_at(i, values[i]);
        at.insert(p.to_string(), json!(bound.is_some()));
        let Some(bound) = bound else { continue };
        if v["identifiable"].is_object() {
            v["identifiable"][p] = json!(false);
        }
        if !v["not_identifiable"].is_object() {
            v["not_identifiable"] = json!({});
        }
        v["not_identifiable"][p] = json!(at_bound_reason(i, bound));
    }
    v["at_search_bound"] = at.into();
}

/// Parameter `i`'s `estimate` as text: `shown` (its formatted value with its unit), or where
/// it sits at a search bound, that it does and is not identifiable, never the value.
pub fn estimate_text(i: usize, estimate: f64, shown: String) -> String {
    match search_bound_at(i, estimate) {
        Some(b) => format!(
            "at the search bound {} {} (not identifiable)",
            value(i, b),
            PARAMETER_UNITS[i]
        ),
        None => shown,
    }
}

/// Add the uncertainty's fields to an identification's JSON: `intervals`, `identifiable`,
/// `confidence`, `noise_std_mm`, `chi2_threshold`, `samples`, `residual_autocorrelation`,
/// `variance_inflation`, `inflation_by_parameter`, `sse_offset_free_mm2` (mm²), `profiles` and `uncertainty_seconds`
/// (`seconds`, the time the analysis took).
pub fn add_uncertainty_json(v: &mut Value, u: &Uncertainty, seconds: f64) {
    add_profiles_json(v, &u.profiles, "sse_mm2");
    v["confidence"] = json!(u.confidence);
    v["noise_std_mm"] = json!(u.noise_std_mm);
    v["chi2_threshold"] = json!(u.threshold);
    v["samples"] = json!(u.samples);
    v["residual_autocorrelation"] = json!(u.residual_autocorrelation);
    v["variance_inflation"] = json!(u.variance_inflation);
    let inflation = u.profiles.iter().map(|p| {
        let i = index(p.parameter);
        (p.parameter.to_string(), json!(u.inflation_by_parameter[i]))
    });
    v["inflation_by_parameter"] = Value::Object(inflation.collect());
    v["sse_offset_free_mm2"] = json!(u.sse_mm2);
    v["uncertainty_seconds"] = json!(seconds);
}

/// The text lines of the uncertainty: the noise level, a note when the residuals are
/// correlated, and one interval line per parameter; `seconds` the time the analysis took.
pub fn uncertainty_text(u: &Uncertainty, seconds: f64) -> String {
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
             mostly model error, not white noise; sigma^2 is inflated {:.0}-fold for it, \
             and per parameter by the records' disagreement (docs/identification.md, \
             \"Uncertainty\")",
            u.residual_autocorrelation, u.variance_inflation
        );
    }
    for p in &u.profiles {
        let i = index(p.parameter);
        let _ = writeln!(
            s,
            "  {:<26} {} .. {} {}  {}",
            p.parameter,
            value(i, p.interval[0]),
            value(i, p.interval[1]),
            PARAMETER_UNITS[i],
            verdict(p)
        );
    }
    s
}

/// Whether a profile's interval is closed, in words.
fn verdict(p: &Profile) -> String {
    if p.identifiable {
        return String::from("identifiable");
    }
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
}

/// One figure per profile, in memory: (`profile-NAME.svg` or `.png`, contents).
pub fn profile_files(u: &Uncertainty) -> Result<Vec<(String, Vec<u8>)>> {
    let mut out = Vec::new();
    for p in &u.profiles {
        let chart = Chart::profile(u, p);
        out.push((
            format!("profile-{}.svg", p.parameter),
            chart.svg()?.into_bytes(),
        ));
        out.push((format!("profile-{}.png", p.parameter), chart.png()?));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(crossed: [bool; 2]) -> Profile {
        Profile {
            parameter: "beta_bar",
            points: Vec::new(),
            interval: [1000.0, 2000.0],
            crossed,
            identifiable: crossed[0] && crossed[1],
        }
    }

    #[test]
    fn the_verdict_names_each_open_side_of_the_interval() {
        assert_eq!(verdict(&profile([true, true])), "identifiable");
        let below = verdict(&profile([false, true]));
        assert!(below.contains("threshold below the estimate"), "{below}");
        let both = verdict(&profile([false, false]));
        assert!(both.contains("below and above the estimate"), "{both}");
    }
}
