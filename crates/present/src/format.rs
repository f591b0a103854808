//! Numbers, names and JSON documents as the outputs show them.

use serde::Serialize;
use std::path::Path;

/// A JSON document as every output prints and writes it: pretty-printed (two-space indent)
/// with a final newline.
///
/// # Errors
/// When `v` does not serialise to JSON (a map with keys that are not strings).
pub fn json_document(v: &impl Serialize) -> serde_json::Result<String> {
    Ok(serde_json::to_string_pretty(v)? + "\n")
}

/// A finite value with `digits` decimals, or "inf" for `None` (an infinite margin).
pub fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "inf".to_string(), |x| format!("{x:.digits$}"))
}

/// The last component of a file path, for figure titles: a title names the record, not the
/// folder it happens to be read from.
pub fn shown_name(path: &str) -> String {
    Path::new(path)
        .file_name()
        .map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned())
}

/// `v` with at most `digits` decimals, trailing zeros dropped (4.4 → "4.4", 4.8173 → "4.82" at
/// two): a value read off a rig or a model, shown as a reader quotes it.
pub fn fmt_short(v: f64, digits: usize) -> String {
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}
