//! Limits are checked before memory is taken (docs/formats.md#limits): an input that never ends
//! is stopped at its documented size while it is read, and sizes derived from arguments are
//! computed and refused, naming the option, before anything is allocated.

use std::path::Path;
use std::process::{Command, Output};

fn pumpcyl(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("pumpcyl runs")
}

/// The run fails with exit 1 and one error line holding every word of `words`.
fn refused(dir: &Path, args: &[&str], words: &[&str]) {
    let out = pumpcyl(dir, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    for w in words {
        assert!(err.contains(w), "{args:?}: message lacks `{w}`: {err}");
    }
}

#[test]
fn inputs_that_never_end_are_stopped_at_their_limit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.mat")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.csv")).unwrap();
    refused(
        d,
        &["simulate", "--data", "zero.mat"],
        &["zero.mat", "2048 MiB", "MAT-file"],
    );
    refused(
        d,
        &["identify-merge", "/dev/zero"],
        &["/dev/zero", "64 MiB"],
    );
    refused(d, &["simulate", "--data", "zero.csv"], &["zero.csv"]);
}

#[test]
fn sizes_from_arguments_are_refused_before_any_allocation() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 4.9·10⁷ samples of eight signals once took 9 GB (an allocation abort on smaller machines)
    let step = ["step", "--rate-hz", "1e6", "--duration-s", "49"];
    refused(d, &step, &["--duration-s", "--rate-hz", "limit of 5e6"]);
    let png = [
        "step",
        "--rate-hz",
        "1e6",
        "--duration-s",
        "49",
        "--out",
        "s.png",
    ];
    refused(d, &png, &["--rate-hz", "limit of 5e6"]);
    assert!(!d.join("s.png").exists());
    let track = [
        "track",
        "--freq-hz",
        "0.1",
        "--amp-mm",
        "5",
        "--rate-hz",
        "4e6",
    ];
    refused(d, &track, &["--rate-hz", "limit of 5e6"]);
}
