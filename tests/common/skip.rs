//! Skipping a test whose tool (GNU Octave, Chromium) this machine lacks, visibly.
//!
//! The test harness has no "skipped" outcome and hides what a passing test prints, so a
//! skipped test would read `ok` like one that ran. [`skip`] therefore writes its line straight
//! to the terminal (past the harness's capture) and appends it to the skip log that `./test.sh`
//! sums up in its last line (`skipped: 5 tests — 4 need …`). Under CI it fails instead: there
//! every tool is installed (`.ci/run`) and a test that did not run is an error.

use std::io::Write;
use std::path::PathBuf;

/// The skip log: `PUMPCYL_SKIP_LOG` (`./test.sh` sets it), else `target/skipped-tests.txt`.
/// One line per skipped test: `test<TAB>tool<TAB>install command`.
pub fn log_path() -> PathBuf {
    match std::env::var_os("PUMPCYL_SKIP_LOG") {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ => PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
            .parent()
            .expect("CARGO_TARGET_TMPDIR is inside the target folder")
            .join("skipped-tests.txt"),
    }
}

/// Whether this is CI (`CI` set and not empty), where no test may skip.
pub fn under_ci() -> bool {
    std::env::var_os("CI").is_some_and(|v| !v.is_empty())
}

/// Skip `test` because `tool` is missing, `install` being the command that installs it
/// (`apt-get install chromium`): say so on the terminal and in the skip log. Under CI, panic
/// instead. The caller returns right after.
pub fn skip(test: &str, tool: &str, install: &str) {
    assert!(
        !under_ci(),
        "{test}: needs {tool}, and under CI no test may skip ({install}; .ci/run installs it)"
    );
    // `eprintln!` would be captured and hidden by the harness; the stderr handle is not.
    let _ = writeln!(
        std::io::stderr().lock(),
        "SKIPPED: {test}: needs {tool} ({install})"
    );
    let field = |s: &str| s.replace(['\t', '\n', '\r'], " ");
    let line = format!("{}\t{}\t{}\n", field(test), field(tool), field(install));
    let path = log_path();
    // append mode and one write per line: tests skipping in parallel do not interleave
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .and_then(|mut f| f.write_all(line.as_bytes()));
    if let Err(e) = written {
        panic!(
            "{test}: skipped ({tool} missing) but the skip log {} could not be written: {e}",
            path.display()
        );
    }
}
