//! The result documents the command line prints with `--json` and the Python package returns,
//! where a run's signals or warnings join a presentation module's document: one function each,
//! so both front ends give the same keys (python/tests/test_documents.py runs the command line
//! and compares).

use crate::analysis::{loop_margins_json, loop_pole_sets, merged, poles_json, ModesReport};
use crate::robustness::{disk_json, gang_of_four_json, sampled_json};
use crate::time::{rating_warnings, step_json, Runs, StepSetup};
use pumpcyl::loops::Loop;
use pumpcyl::lti::{LtiError, Margins};
use pumpcyl::response::{OverRating, Signals, StepMetrics};
use serde_json::{json, Value};

/// The signals of a run as one JSON object, each column by its name (`time_s`, `x_mm`, ...,
/// units in the names), one value per sample.
pub fn signals_json(s: &Signals) -> Value {
    let columns: serde_json::Map<String, Value> = s
        .named()
        .into_iter()
        .map(|(name, v)| (name.to_string(), json!(v)))
        .collect();
    Value::Object(columns)
}

/// The document of a position step (`pumpcyl step --json`, Python's `step`): the metrics of
/// each run ([`step_json`]), the nominal run's `signals` and the `warnings`.
pub fn step_document(setup: &StepSetup, runs: &Runs<StepMetrics>, warnings: &[String]) -> Value {
    let mut v = step_json(setup, runs);
    v["signals"] = signals_json(&runs.done[0].signals);
    with_warnings(v, warnings)
}

/// The document `doc` with `warnings` added to its `warnings` list, made (empty if need be)
/// when absent, so the key is always there.
pub fn with_warnings(mut doc: Value, warnings: &[String]) -> Value {
    if let Some(obj) = doc.as_object_mut() {
        let list = obj
            .entry("warnings")
            .or_insert_with(|| Value::Array(Vec::new()));
        if let Some(list) = list.as_array_mut() {
            list.extend(warnings.iter().cloned().map(Value::String));
        }
    }
    doc
}

/// The document `doc` with `rig_defaulted_keys`, the keys its rig file left out (they took the
/// documented defaults, docs/formats.md#rig-toml), where the document has a `rig` block and its
/// rig was read from a file (`defaulted` given); any other document as it is. A rig made from
/// the embedded default has no file and so no list.
///
/// ```
/// use pumpcyl_present::documents::with_rig_defaulted_keys;
/// let doc = serde_json::json!({"rig": "my.toml", "step_mm": 5.0});
/// let v = with_rig_defaulted_keys(doc.clone(), Some(&["beta_bar"]));
/// assert_eq!(v["rig_defaulted_keys"], serde_json::json!(["beta_bar"]));
/// assert_eq!(with_rig_defaulted_keys(doc, None).get("rig_defaulted_keys"), None);
/// let other = serde_json::json!({"gain_margin_db": 6.0});
/// assert_eq!(with_rig_defaulted_keys(other.clone(), Some(&["beta_bar"])), other);
/// ```
pub fn with_rig_defaulted_keys(mut doc: Value, defaulted: Option<&[&str]>) -> Value {
    if let (Some(keys), Some(obj)) = (defaulted, doc.as_object_mut()) {
        if obj.contains_key("rig") {
            obj.insert("rig_defaulted_keys".into(), json!(keys));
        }
    }
    doc
}

/// The drive ratings the run `what` exceeds ([`rating_warnings`]), one line each without the
/// terminal's `warning: ` prefix, as a document lists its warnings.
pub fn rating_warning_lines(what: &str, over: &[OverRating]) -> Vec<String> {
    rating_warnings(what, over)
        .lines()
        .map(|l| l.trim_start_matches("warning: ").to_string())
        .collect()
}

/// The margins document (`pumpcyl margins --json`, Python's `margins`): the analysed loop's
/// margins ([`loop_margins_json`]), its disk margin of skew `skew` and sensitivity peaks
/// ([`disk_json`]), the loop as its PLC samples it ([`sampled_json`]) and, on a single-pump rig, its two modes beside the
/// switching force ([`ModesReport::margins_json`]: `modes`, `switching_force_n`, ...).
///
/// # Errors
/// The margins cannot be computed.
pub fn margins_document(m: &Margins, lp: &Loop, skew: f64) -> Result<Value, LtiError> {
    let disk = pumpcyl::lti::disk_margins(&lp.open_loop, skew);
    let doc = merged(loop_margins_json(m, lp)?, disk_json(&disk));
    let doc = merged(doc, sampled_json(lp, m, skew));
    let doc = merged(doc, gang_of_four_json(lp, &disk));
    Ok(match ModesReport::of_loop(lp)? {
        Some(modes) => merged(doc, modes.margins_json()?),
        None => doc,
    })
}

/// The poles document (`pumpcyl poles --json`, Python's `poles`): the pole sets of the
/// analysed loop ([`loop_pole_sets`], [`poles_json`]) and, on a single-pump rig, its two modes
/// beside the switching force ([`ModesReport::poles_json`]).
///
/// # Errors
/// The poles cannot be computed.
pub fn poles_document(lp: &Loop) -> Result<Value, LtiError> {
    let doc = poles_json(&lp.description, &loop_pole_sets(lp)?);
    Ok(match ModesReport::of_loop(lp)? {
        Some(modes) => merged(doc, modes.poles_json()?),
        None => doc,
    })
}
