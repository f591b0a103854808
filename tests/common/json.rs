//! JSON helpers of the tests that read pumpcyl's documents.

use serde_json::Value;

/// A matrix of a JSON document (rows of numbers), as rows.
pub fn matrix(v: &Value) -> Vec<Vec<f64>> {
    (v.as_array().unwrap().iter())
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect()
}
