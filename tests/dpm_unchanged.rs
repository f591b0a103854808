//! The DPM's numbers did not move when its equations moved behind the circuit interface
//! (docs/architecture.md): `pumpcyl reproduce`'s summary.json holds every number of
//! `tests/data/dpm-summary-before-circuits.json` (written before the move, its run time left
//! out) at the same JSON path, to 1e-12 of its size. New keys are allowed; a missing one is a
//! failure. Its numbers were moved on purpose once since: when the loop's rest offset
//! (docs/simulation.md#the-rest-under-load) entered the step and tracking errors and the rig's
//! one bulk-modulus anchor (docs/bulk-modulus.md#the-anchor) the gas fractions: the steps'
//! steady-state and final errors, the design's reasons and the circuit study's errors and
//! lowest pressures, nothing else.

use serde_json::Value;
use std::path::Path;
use std::process::Command;

/// Relative tolerance of every number.
const REL: f64 = 1e-12;
/// The floor under which two numbers are equal regardless (zeros).
const ABS: f64 = 1e-300;

/// Every difference between `want` and `got` below the path `at`, one line each.
fn differences(want: &Value, got: &Value, at: &str, out: &mut Vec<String>) {
    match (want, got) {
        (Value::Object(w), Value::Object(g)) => {
            for (k, v) in w {
                match g.get(k) {
                    Some(gv) => differences(v, gv, &format!("{at}.{k}"), out),
                    None => out.push(format!("{at}.{k}: missing")),
                }
            }
        }
        (Value::Array(w), Value::Array(g)) if w.len() == g.len() => {
            for (i, (v, gv)) in w.iter().zip(g).enumerate() {
                differences(v, gv, &format!("{at}[{i}]"), out);
            }
        }
        (Value::Number(w), Value::Number(g)) => {
            let (w, g) = (w.as_f64().unwrap(), g.as_f64().unwrap());
            if (w - g).abs() > (REL * w.abs().max(g.abs())).max(ABS) {
                out.push(format!("{at}: {w:e} became {g:e}"));
            }
        }
        (w, g) if w == g => {}
        (w, g) => out.push(format!("{at}: {w} became {g}")),
    }
}

#[test]
fn the_comparison_sees_a_moved_number_and_a_missing_key() {
    let want: Value = serde_json::from_str(r#"{"a": [1.0, 5e-301], "b": {"c": 3.0}}"#).unwrap();
    let same: Value =
        serde_json::from_str(r#"{"a": [1.0000000000001, 0.0], "b": {"c": 3.0, "new": 1}}"#)
            .unwrap();
    let mut out = Vec::new();
    differences(&want, &same, "", &mut out);
    assert!(out.is_empty(), "{out:?}");
    let moved: Value = serde_json::from_str(r#"{"a": [1.00000000001, 0.0], "b": {}}"#).unwrap();
    differences(&want, &moved, "", &mut out);
    assert_eq!(out.len(), 2, "{out:?}");
    assert!(
        out[0].starts_with(".a[0]") && out[1] == ".b.c: missing",
        "{out:?}"
    );
}

#[test]
fn reproduce_gives_the_dpm_numbers_of_before_the_circuits() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("dpm-unchanged");
    let _ = std::fs::remove_dir_all(&dir);
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["reproduce", "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read =
        |p: &Path| -> Value { serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap() };
    let golden =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/dpm-summary-before-circuits.json");
    let mut out = Vec::new();
    differences(
        &read(&golden),
        &read(&dir.join("summary.json")),
        "",
        &mut out,
    );
    assert!(
        out.is_empty(),
        "{} numbers moved:\n{}",
        out.len(),
        out.join("\n")
    );
}
