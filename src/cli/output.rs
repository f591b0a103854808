//! Output helpers: atomic file writes and number formatting.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// Write `bytes` to `path` atomically: a temporary file in the same folder, then a rename, so a
/// failure never leaves a half-written output behind.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir).with_context(|| {
        format!(
            "{}: cannot create a file in {}",
            path.display(),
            dir.display()
        )
    })?;
    tmp.write_all(bytes)
        .and_then(|_| tmp.as_file().sync_all())
        .with_context(|| format!("{}: write failed", path.display()))?;
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(())
}

/// The output format chosen by a file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Comma-separated values.
    Csv,
    /// Scalable vector graphics.
    Svg,
    /// Portable network graphics.
    Png,
    /// MAT-file, level 5 (MATLAB, GNU Octave; docs/matlab.md).
    Mat,
}

/// Format from the extension of `path`, among `allowed`.
pub fn format_of(path: &Path, allowed: &[Format]) -> Result<Format> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let format = match ext.as_deref() {
        Some("csv") => Some(Format::Csv),
        Some("svg") => Some(Format::Svg),
        Some("png") => Some(Format::Png),
        Some("mat") => Some(Format::Mat),
        _ => None,
    };
    match format {
        Some(f) if allowed.contains(&f) => Ok(f),
        _ => {
            let names: Vec<String> = allowed
                .iter()
                .map(|f| format!(".{}", format!("{f:?}").to_lowercase()))
                .collect();
            anyhow::bail!(
                "{}: unknown output format; use one of {}",
                path.display(),
                names.join(", ")
            )
        }
    }
}

/// A finite value with `digits` decimals, or "inf".
pub fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "inf".to_string(), |x| format!("{x:.digits$}"))
}

/// Print to standard output; a closed pipe (`pumpcyl ... | head`) is not an error.
pub fn emit(text: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other.context("cannot write to standard output")?),
    }
}
