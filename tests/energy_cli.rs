//! `emulate --energy` (docs/energy.md#over-a-run): the power account integrated over the
//! record, on rigs that are not the article's, closing to rounding, with the record the same as
//! without it.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;
use serde_json::Value;
use std::path::Path;

/// The `energy` object of `pumpcyl emulate ARGS --energy --json` in `dir`, and the record's
/// bytes, beside the record's bytes without `--energy`.
fn emulated(dir: &Path, args: &[&str]) -> (Value, Vec<u8>, Vec<u8>) {
    let with: Vec<&str> = [
        &["emulate"][..],
        args,
        &["--out", "e.csv", "--energy", "--json"],
    ]
    .concat();
    let doc: Value = run::json(dir, &with);
    let counted = std::fs::read(dir.join("e.csv")).unwrap();
    let without: Vec<&str> = [&["emulate"][..], args, &["--out", "f.csv"]].concat();
    let out = run::pumpcyl(dir, &without);
    assert!(out.status.success(), "{out:?}");
    (
        doc["energy"].clone(),
        counted,
        std::fs::read(dir.join("f.csv")).unwrap(),
    )
}

fn sum(v: &Value) -> f64 {
    v.as_object()
        .unwrap()
        .values()
        .map(|j| j.as_f64().unwrap())
        .sum()
}

#[test]
fn the_energy_of_a_record_closes_and_leaves_the_record_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let user = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/user-rig.toml");
    for (name, args) in [
        ("dpm step", vec!["--experiment", "step", "--rig", user]),
        (
            "dual-pump sine",
            vec![
                "--experiment",
                "sine",
                "--rig",
                user,
                "--set",
                "circuit=dual-pump",
                "--duration-s",
                "4",
            ],
        ),
        (
            "valve step",
            vec![
                "--experiment",
                "step",
                "--set",
                "circuit=valve",
                "--set",
                "kp=1",
                "--set",
                "beta_bar=6000",
            ],
        ),
    ] {
        let (e, counted, plain) = emulated(dir.path(), &args);
        assert_eq!(counted, plain, "{name}: the record changed with --energy");
        let delivered = e["energy_in_j"].as_f64().unwrap();
        assert!(delivered > 0.0, "{name}: {e}");
        assert_eq!(delivered, sum(&e["sources_j"]), "{name}");
        let balance = delivered
            - e["work_out_j"].as_f64().unwrap()
            - sum(&e["losses_j"])
            - sum(&e["stored_j"]);
        assert!(
            balance.abs() <= 1e-9 * delivered,
            "{name}: {balance} J of {delivered} J: {e}"
        );
        assert!((e["imbalance_j"].as_f64().unwrap() - balance).abs() <= 1e-9 * delivered);
        // every loss takes energy; the leakage's share is positive
        for (kind, j) in e["losses_j"].as_object().unwrap() {
            assert!(
                j.as_f64().unwrap() >= -1e-9 * delivered,
                "{name}: {kind} = {j}"
            );
        }
        assert!(
            e["losses_j"]["leakage"].as_f64().unwrap() >= 0.0,
            "{name}: {e}"
        );
    }
}
