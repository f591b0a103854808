//! Limits are checked before memory is taken (docs/formats.md#limits): an input that never ends
//! is stopped at its documented size while it is read, and sizes derived from arguments are
//! computed and refused, naming the option, before anything is allocated.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;
use run::refused;

#[test]
fn inputs_that_never_end_are_stopped_at_their_limit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.mat")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.csv")).unwrap();
    // a MAT-file's header is checked first: no endian indicator in its 128 bytes
    refused(
        d,
        &["simulate", "--data", "zero.mat"],
        &["zero.mat", "not a level-5 MAT-file"],
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

#[test]
fn long_runs_and_large_models_are_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 2·10⁶ table rows took minutes, 300 × 300 design conditions most of an hour
    refused(
        d,
        &["bulk-modulus", "--points", "2000000"],
        &["--points", "--allow-long-run"],
    );
    let mut design = vec!["design".to_string()];
    for i in 0..300 {
        design.extend(["--mass-kg".into(), format!("{}", 1000 + i)]);
        design.extend(["--p-mean-bar".into(), format!("{}", 1.0 + i as f64 / 100.0)]);
    }
    let design: Vec<&str> = design.iter().map(String::as_str).collect();
    refused(d, &design, &["mass_kg × p_mean_bar", "--allow-long-run"]);
    // a state-space model of 501 states
    let n = 501;
    let row = |k: usize| format!("[{}]", (0..k).map(|_| "0").collect::<Vec<_>>().join(","));
    let a: Vec<String> = (0..n).map(|_| row(n)).collect();
    let b: Vec<String> = (0..n).map(|_| "[1]".to_string()).collect();
    let json = format!(
        "{{\"A\":[{}],\"B\":[{}],\"C\":[{}],\"D\":[[0]]}}",
        a.join(","),
        b.join(","),
        row(n)
    );
    std::fs::write(d.join("big.json"), json).unwrap();
    refused(
        d,
        &["margins", "--ss", "big.json"],
        &["big.json", "501 states", "limit of 500"],
    );
    // a Bode diagram of 4.8·10⁷ points (3 GB): refused from its arguments
    let bode = [
        "bode",
        "--from-hz",
        "1e-6",
        "--to-hz",
        "1e6",
        "--points-per-decade",
        "4000000",
    ];
    refused(d, &bode, &["--points-per-decade", "limit of 5e7 values"]);
}
