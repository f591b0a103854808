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

/// A record's CSV text without its power columns (docs/formats.md#power-columns), and those
/// columns by name.
fn split_power(csv: &[u8]) -> (Vec<u8>, Vec<(String, Vec<f64>)>) {
    let text = std::str::from_utf8(csv).unwrap();
    let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split(',').collect()).collect();
    let first = (rows[0].iter())
        .position(|c| c.starts_with("source_"))
        .expect("power columns");
    let mut signals = String::new();
    for row in &rows {
        signals += &row[..first].join(",");
        signals.push('\n');
    }
    let power = (first..rows[0].len())
        .map(|c| {
            let values = rows[1..].iter().map(|r| r[c].parse().unwrap()).collect();
            (rows[0][c].to_string(), values)
        })
        .collect();
    (signals.into_bytes(), power)
}

/// Each power column times the sample period, summed, is the entry of the `energy` object it
/// is named after (`source_electrical_w` is `sources_j.electrical`), to 1e-9 of the energy delivered;
/// the last sample, with no interval after it, holds 0.
fn the_power_columns_add_up_to_the_energies(name: &str, power: &[(String, Vec<f64>)], e: &Value) {
    let delivered = e["energy_in_j"].as_f64().unwrap();
    let period_s = 0.01;
    for (column, values) in power {
        let kind = column.strip_suffix("_w").unwrap();
        let want = match kind.split_once('_').unwrap() {
            ("work", "out") => e["work_out_j"].as_f64().unwrap(),
            ("source", k) => e["sources_j"][k].as_f64().unwrap(),
            ("loss", k) => e["losses_j"][k].as_f64().unwrap(),
            ("stored", k) => e["stored_j"][k].as_f64().unwrap(),
            other => panic!("{name}: column {column}: {other:?}"),
        };
        let got: f64 = values.iter().map(|w| w * period_s).sum();
        assert!(
            (got - want).abs() <= 1e-9 * delivered,
            "{name}: {column}: {got} J from the column, {want} J in the account"
        );
        assert_eq!(values.last(), Some(&0.0), "{name}: {column}");
    }
    assert_eq!(
        power.len(),
        e["sources_j"].as_object().unwrap().len()
            + 1
            + e["losses_j"].as_object().unwrap().len()
            + e["stored_j"].as_object().unwrap().len()
    );
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
        let (signals, power) = split_power(&counted);
        assert_eq!(signals, plain, "{name}: the record changed with --energy");
        the_power_columns_add_up_to_the_energies(name, &power, &e);
        let delivered = e["energy_in_j"].as_f64().unwrap();
        assert!(delivered > 0.0, "{name}: {e}");
        assert_eq!(delivered, run::sum(&e["sources_j"]), "{name}");
        let balance = delivered
            - e["work_out_j"].as_f64().unwrap()
            - run::sum(&e["losses_j"])
            - run::sum(&e["stored_j"]);
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
