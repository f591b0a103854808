//! Running the binary in a folder, for tests of refusals.

use std::path::Path;
use std::process::{Command, Output};

/// Run `pumpcyl ARGS` in `dir`.
pub fn pumpcyl(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("pumpcyl runs")
}

/// The run fails with exit 1 and one error line holding every word of `words`.
pub fn refused(dir: &Path, args: &[&str], words: &[&str]) {
    let out = pumpcyl(dir, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    for w in words {
        assert!(err.contains(w), "{args:?}: message lacks `{w}`: {err}");
    }
}

/// `pumpcyl ARGS` in `dir`, which must succeed, its standard output read as JSON.
pub fn json(dir: &Path, args: &[&str]) -> serde_json::Value {
    let out = pumpcyl(dir, args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{args:?}: {e}"))
}

/// The sum of a JSON object's numbers (an energy account's entries by kind).
pub fn sum(v: &serde_json::Value) -> f64 {
    v.as_object()
        .unwrap()
        .values()
        .map(|j| j.as_f64().unwrap())
        .sum()
}
