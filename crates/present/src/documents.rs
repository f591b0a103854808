//! The result documents the command line prints with `--json` and the Python package returns,
//! where a run's signals or warnings join a presentation module's document: one function each,
//! so both front ends give the same keys (python/tests/test_documents.py runs the command line
//! and compares).

use crate::time::{rating_warnings, step_json, Runs, StepSetup};
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

/// The drive ratings the run `what` exceeds ([`rating_warnings`]), one line each without the
/// terminal's `warning: ` prefix, as a document lists its warnings.
pub fn rating_warning_lines(what: &str, over: &[OverRating]) -> Vec<String> {
    rating_warnings(what, over)
        .lines()
        .map(|l| l.trim_start_matches("warning: ").to_string())
        .collect()
}
