//! A rig file describes the whole rig: what it leaves out takes a documented default, named
//! where it is used (docs/formats.md#rig-toml). The article's seesaw mass table stays with the
//! embedded article rig; a user rig without `mass_by_position` has one mass over its stroke.
//! Also: tiny and huge floats printed in exponent form and read back equal, a plain integrator
//! called one by `poles` (docs/analysis.md#poles-and-damping), a duplicate TOML key named.

use pumpcyl::rig::Rig;
use pumpcyl::select::Application;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

/// A user rig sharing no value with the article's (80/45 mm, 2500 kg, 800 mm stroke, x0 at
/// 400 mm, beyond the article's mass table of 295 … 395 mm): tests/user-rig.toml without its
/// `mass_by_position` line, 13 keys.
fn my_rig() -> String {
    include_str!("user-rig.toml")
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("mass_by_position"))
        .map(|l| {
            format!(
                "{l}
"
            )
        })
        .collect()
}

fn pumpcyl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Standard output and standard error of a run that must succeed.
fn run(args: &[&str]) -> (String, String) {
    let out = pumpcyl(args);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.success(), "{args:?} failed: {err}");
    (String::from_utf8(out.stdout).unwrap(), err)
}

fn json(args: &[&str]) -> Value {
    serde_json::from_str(&run(args).0).unwrap()
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// The keys `pumpcyl rig --print-default` writes, in order (the independent list of every key).
fn printed_keys() -> Vec<String> {
    let (text, _) = run(&["rig", "--print-default"]);
    let table: toml::Table = text.parse().unwrap();
    let mut keys: Vec<(usize, String)> = table
        .keys()
        .map(|k| (text.find(&format!("\n{k} = ")).unwrap(), k.clone()))
        .collect();
    keys.sort();
    keys.into_iter().map(|(_, k)| k).collect()
}

#[test]
fn a_user_rig_without_a_mass_table_keeps_one_mass_over_its_stroke() {
    let dir = tempfile::tempdir().unwrap();
    let mine = write(dir.path(), "my.toml", &my_rig());
    // x0 ± 50 mm = 350 … 450 mm: beyond the article's table, which this rig does not have
    let d = json(&["design", "--rig", &mine, "--json"]);
    let conditions = d["conditions"].as_array().unwrap();
    // the checked positions (the searched ones follow them, with the same one mass)
    let at: Vec<(f64, f64)> = (conditions.iter())
        .filter(|c| c["searched"].is_null())
        .map(|c| (c["x_mm"].as_f64().unwrap(), c["mass_kg"].as_f64().unwrap()))
        .collect();
    assert_eq!(at, [(350.0, 2500.0), (400.0, 2500.0), (450.0, 2500.0)]);
    assert!(conditions.iter().all(|c| c["mass_kg"] == 2500.0));
    // the printed rig says so
    let (text, _) = run(&["rig", "--rig", &mine]);
    assert!(text.contains("\nmass_by_position = []  # "), "{text}");
    // the embedded article rig keeps the seesaw's masses (the article §3.3)
    let d = json(&["design", "--json"]);
    let masses: Vec<f64> = d["conditions"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["searched"].is_null())
        .map(|c| c["mass_kg"].as_f64().unwrap())
        .collect();
    assert_eq!(masses, [9958.0, 10593.0, 12373.0]);
}

#[test]
fn the_keys_a_rig_file_leaves_out_are_named_with_the_values_they_take() {
    let dir = tempfile::tempdir().unwrap();
    let rig_text = my_rig();
    let mine = write(dir.path(), "my.toml", &rig_text);
    let written: Vec<&str> = rig_text
        .lines()
        .map(|l| l.split(" = ").next().unwrap())
        .collect();
    let expected: Vec<String> = printed_keys()
        .into_iter()
        .filter(|k| !written.contains(&k.as_str()))
        .collect();
    assert_eq!(expected.len(), 35, "{expected:?}");
    let (_, err) = run(&["margins", "--rig", &mine]);
    let notes: Vec<&str> = err.lines().collect();
    assert_eq!(notes.len(), 1, "{err}");
    let note = notes[0];
    assert!(
        note.starts_with(&format!("note: {mine} does not set 35 keys; ")),
        "{note}"
    );
    assert!(note.contains("mass_by_position = [] (one mass over the stroke"));
    assert!(note.contains("the others take the article rig's values: "));
    for (key, value) in [
        ("motor_inertia_1_kg_mm2", "1600.0"),
        ("c1_m5_per_ns", "5.49e-11"),
        ("k_pres_per_bar", "0.22"),
        ("motor_model", "\"full\""),
    ] {
        assert!(note.contains(&format!("{key} = {value}")), "{key}: {note}");
    }
    assert!(note.ends_with("(docs/formats.md#rig-toml)"), "{note}");
    // a JSON result with a rig block lists them; a key set by --set is not among them
    let step = json(&["step", "--rig", &mine, "--json", "--set", "k_beta=1.2"]);
    let listed: Vec<&str> = step["rig_defaulted_keys"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| k.as_str().unwrap())
        .collect();
    let without_k_beta: Vec<&str> = expected
        .iter()
        .map(String::as_str)
        .filter(|k| *k != "k_beta")
        .collect();
    assert_eq!(listed, without_k_beta);
    // a file that sets every key: no note, an empty list
    let (full, _) = run(&["rig", "--print-default"]);
    let full = write(dir.path(), "full.toml", &full);
    let (_, err) = run(&["margins", "--rig", &full]);
    assert_eq!(err, "");
    let step = json(&["step", "--rig", &full, "--json"]);
    assert_eq!(step["rig_defaulted_keys"], serde_json::json!([]));
    // the embedded default: nothing to note, no list
    let (_, err) = run(&["margins"]);
    assert_eq!(err, "");
    assert!(json(&["step", "--json"])
        .get("rig_defaulted_keys")
        .is_none());
}

#[test]
fn a_rig_table_of_an_application_without_a_mass_table_has_one_mass() {
    let app = Application::from_toml_str("[rig]\nkp = 20.0\n", "app.toml").unwrap();
    assert!(app.rig.mass_by_position.is_empty());
    assert_eq!(app.rig.kp, 20.0);
    // without a [rig] table the application's rig is the article's, table and all
    let app = Application::from_toml_str("stroke_mm = 40.0\n", "app.toml").unwrap();
    assert_eq!(app.rig, Rig::default());
    // the printed article application reads back to the article's rig, table and all
    let text = Application::default().to_commented_toml();
    let back = Application::from_toml_str(&text, "printed.toml").unwrap();
    assert_eq!(back.rig, Rig::default());
}

#[test]
fn tiny_and_huge_floats_print_in_exponent_form_and_read_back_equal() {
    let (text, _) = run(&["rig", "--print-default"]);
    assert!(text.contains("\nc12_m5_per_ns = 1.2e-10  # "), "{text}");
    assert!(text.contains("\nc2_m5_per_ns = -1.19e-11  # "), "{text}");
    // no value written with a run of zeros
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let value = line.split("  # ").next().unwrap();
        assert!(!value.contains("0000"), "{line}");
    }
    let dir = tempfile::tempdir().unwrap();
    let sets = [
        "external_force_n=-2.5e-5",
        "motor_inertia_1_kg_mm2=1.25e9",
        "c1_m5_per_ns=3e-17",
        "mass_kg=12345678.9",
        "kff_kg_m2=0.0001",
    ];
    let mut args = vec!["rig"];
    for s in &sets {
        args.extend(["--set", s]);
    }
    let (text, _) = run(&args);
    for line in [
        "external_force_n = -2.5e-5",
        "motor_inertia_1_kg_mm2 = 1.25e9",
        "c1_m5_per_ns = 3e-17",
        "mass_kg = 1.23456789e7",
        "kff_kg_m2 = 1e-4",
    ] {
        assert!(text.contains(&format!("\n{line}  # ")), "{line}: {text}");
    }
    // read back: the same rig, value for value
    let path = write(dir.path(), "printed.toml", &text);
    let printed = Rig::from_file(Path::new(&path)).unwrap();
    let expected = Rig::default()
        .with_overrides(&sets.map(String::from))
        .unwrap();
    assert_eq!(printed, expected);
    let (again, _) = run(&["rig", "--rig", &path]);
    assert_eq!(again, text);
}

#[test]
fn a_plain_integrator_is_an_integrator_not_undecided() {
    let dir = tempfile::tempdir().unwrap();
    // the article's open loop: the piston position integrates its velocity
    let p = json(&["poles", "--json"]);
    assert_eq!(p["open_loop_stability"], "integrator");
    assert_eq!(p["closed_loop_stability"], "stable");
    let (text, _) = run(&["poles"]);
    assert!(
        text.contains("open loop (the analysed L(s)): an integrator: "),
        "{text}"
    );
    // 1/(s (s + 2)): a pole at exactly 0
    let ss =
        r#"{"A": [[0.0, 1.0], [0.0, -2.0]], "B": [[0.0], [1.0]], "C": [[1.0, 0.0]], "D": [[0.0]]}"#;
    let path = write(dir.path(), "integrator.json", ss);
    let p = json(&["poles", "--json", "--ss", &path]);
    assert_eq!(p["open_loop_stability"], "integrator");
    assert_eq!(p["open_loop_stable"], false);
    assert_eq!(p["closed_loop_stability"], "stable");
    // a pole at -1e-9 beside -1e10: within 100 n·ε·‖A‖₁ = 4.4e-4 of the origin
    let ss = r#"{"A": [[-1e-9, 0.0], [0.0, -1e10]], "B": [[1.0], [1.0]], "C": [[1.0, 1.0]], "D": [[0.0]]}"#;
    let path = write(dir.path(), "slow.json", ss);
    let p = json(&["poles", "--json", "--ss", &path]);
    assert_eq!(p["open_loop_stability"], "integrator");
    // an undamped pair stays undecided; a pole at -1e-3 beside -1e10 is stable
    let ss =
        r#"{"A": [[0.0, 1.0], [-1.0, 0.0]], "B": [[0.0], [1.0]], "C": [[1.0, 0.0]], "D": [[0.0]]}"#;
    let path = write(dir.path(), "undamped.json", ss);
    let p = json(&["poles", "--json", "--ss", &path]);
    assert_eq!(p["open_loop_stability"], "undecided");
    let ss = r#"{"A": [[-1e-3, 0.0], [0.0, -1e10]], "B": [[1.0], [1.0]], "C": [[1.0, 1.0]], "D": [[0.0]]}"#;
    let path = write(dir.path(), "stable.json", ss);
    let p = json(&["poles", "--json", "--ss", &path]);
    assert_eq!(p["open_loop_stability"], "stable");
}

#[test]
fn a_duplicate_key_is_named_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let rig = write(
        dir.path(),
        "dup.toml",
        "kp = 25.0\nbeta_bar = 100.0\nkp = 30.0\n",
    );
    let out = pumpcyl(&["margins", "--rig", &rig]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(
        err.trim_end(),
        format!("error: {rig}: line 3, column 1, key `kp`: duplicate key")
    );
    let app = write(dir.path(), "app.toml", "[rig]\nkp = 20.0\nkp = 30.0\n");
    let out = pumpcyl(&["select", &app]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("line 3, column 1, key `kp`: duplicate key"),
        "{err}"
    );
}

/// A rig file switched to another circuit by `--set circuit=…` is noted for that circuit: its
/// own defaulted keys (the accumulator's pre-charge of the article, which a DPM file cannot
/// write) are named, the DPM's second drive is not; a key the file wrote that the new circuit
/// does not have is refused rather than silently ignored.
#[test]
fn a_circuit_switched_by_set_is_noted_for_that_circuit() {
    let dir = tempfile::tempdir().unwrap();
    let rig = write(dir.path(), "r.toml", "kp = 20.0\nmass_kg = 3000.0\n");
    let (_, err) = run(&["margins", "--rig", &rig, "--set", "circuit=dual-pump"]);
    assert!(err.contains("accumulator_precharge_bar = 6.91"), "{err}");
    assert!(
        !err.contains("km2_nms_per_rad") && !err.contains("p_sum_ref_bar"),
        "{err}"
    );
    let two = write(dir.path(), "two.toml", "km2_nms_per_rad = 0.03\n");
    let out = pumpcyl(&["margins", "--rig", &two, "--set", "circuit=dual-pump"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("key `km2_nms_per_rad`: the dual-pump circuit has no such key"),
        "{err}"
    );
}
