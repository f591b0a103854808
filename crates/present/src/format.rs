//! Numbers and names as the text outputs show them.

use std::path::Path;

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
