//! Every output names the circuit it used: `step`, `track` and `simulate` on a dual-pump rig
//! (tests/user-rig.toml, `--set circuit=dual-pump`, the article's Figure 1b) carry `circuit`
//! in their JSON and say it in their text heading, as `margins` and `poles` do; the article's
//! rig says `dpm`.

use serde_json::Value;
use std::path::Path;
use std::process::Command;

const USER_RIG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/user-rig.toml");

/// Standard output of a run that must succeed.
fn run(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?} failed: {err}");
    String::from_utf8(out.stdout).unwrap()
}

/// `command` with `args` on the dual-pump user rig: its JSON document and its text.
fn both(command: &str, args: &[&str]) -> (Value, String) {
    let mut all = vec![command, "--rig", USER_RIG, "--set", "circuit=dual-pump"];
    all.extend_from_slice(args);
    let text = run(&all);
    all.push("--json");
    (serde_json::from_str(&run(&all)).unwrap(), text)
}

#[test]
fn step_names_the_dual_pump_circuit() {
    let (doc, text) = both("step", &["--step-mm", "5", "--duration-s", "1"]);
    assert_eq!(doc["circuit"], "dual-pump");
    let heading = text.lines().next().unwrap();
    assert!(heading.contains("circuit dual-pump"), "{heading}");
    // the article's rig names its own circuit
    let dpm: Value = serde_json::from_str(&run(&["step", "--duration-s", "1", "--json"])).unwrap();
    assert_eq!(dpm["circuit"], "dpm");
}

#[test]
fn track_names_the_dual_pump_circuit() {
    let sine = ["--freq-hz", "0.5", "--amp-mm", "10", "--periods", "1"];
    let (doc, text) = both("track", &sine);
    assert_eq!(doc["circuit"], "dual-pump");
    let heading = text.lines().next().unwrap();
    assert!(heading.contains("circuit dual-pump"), "{heading}");
}

/// A record about the user rig's x0 = 400 mm: a 5 mm step at 0.5 s, 2 s at 100 Hz.
fn step_record(dir: &Path) -> String {
    let mut csv = String::from("time_s,x_ref_mm,x_mm\n");
    for k in 0..200 {
        let t = f64::from(k) * 0.01;
        let x_ref = if t < 0.5 { 400.0 } else { 405.0 };
        csv += &format!("{t:.2},{x_ref},{x_ref}\n");
    }
    let path = dir.join("step.csv");
    std::fs::write(&path, csv).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn simulate_names_the_dual_pump_circuit() {
    let dir = tempfile::tempdir().unwrap();
    let data = step_record(dir.path());
    let (doc, text) = both("simulate", &["--data", &data]);
    assert_eq!(doc["circuit"], "dual-pump");
    let heading = text.lines().next().unwrap();
    assert!(heading.contains("(circuit dual-pump)"), "{heading}");
}
