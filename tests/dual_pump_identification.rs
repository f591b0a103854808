//! `pumpcyl identify` on dual-pump records emulated with every effect on and the PLC's noise
//! (docs/circuits.md#identification-where-a-valve-is-open): where every valve is shut the fitted
//! β is the emulator's own β_e at the records' mean chamber pressure, not the rig's `beta_bar`
//! (which the emulator holds at the accumulator pre-charge); where a check valve is open at
//! rest the standstill is refused in one line, since the fit there reads β about 30 % low.

use pumpcyl::bulk::{effective_beta, gas_fraction};
use pumpcyl::circuit::parts::BETA_OIL_BAR;
use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_pumpcyl");

/// Runs pumpcyl in `dir`; its stdout, or its stderr as the error.
fn pumpcyl(dir: &Path, args: &[String]) -> Result<String, String> {
    let out = Command::new(BIN)
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    match out.status.success() {
        true => Ok(text(&out.stdout)),
        false => Err(text(&out.stderr)),
    }
}

/// Emulates the article's step at Kp 25 and 20 and a standstill with `sets`, every effect on
/// and the PLC's noise, and writes the identification experiment over them.
fn records(dir: &Path, sets: &[String]) {
    let set: Vec<String> = sets
        .iter()
        .flat_map(|s| ["--set".into(), s.clone()])
        .collect();
    for (out, experiment, kp) in [
        ("id.csv", "step", 25),
        ("val.csv", "step", 20),
        ("still.csv", "standstill", 25),
    ] {
        let mut args: Vec<String> = ["emulate", "--experiment", experiment, "--out", out]
            .map(String::from)
            .into();
        args.extend(set.iter().cloned());
        args.extend(["--set".into(), format!("kp={kp}")]);
        pumpcyl(dir, &args).unwrap();
    }
    let keys: String = sets
        .iter()
        .map(|s| {
            let (k, v) = s.split_once('=').unwrap();
            match k {
                "circuit" => format!("{k} = \"{v}\"\n"),
                _ => format!("{k} = {v}\n"),
            }
        })
        .collect();
    let experiment = format!(
        "grids = \"article\"\n[set]\n{keys}\n[standstill]\nrecord = \"still.csv\"\n\n\
         [[dataset]]\nfile = \"id.csv\"\nkp = 25.0\nmass_kg = 10593.0\nfit_end_s = 2.7\n\n\
         [[dataset]]\nfile = \"val.csv\"\nkp = 20.0\nmass_kg = 10593.0\nfit_end_s = 2.4\n"
    );
    std::fs::write(dir.join("exp.toml"), experiment).unwrap();
}

/// The mean of (p1 + p2)/2 (bar) over a record's first `end_s` seconds, the fit window.
fn mean_pressure_bar(path: &Path, end_s: f64) -> f64 {
    let text = std::fs::read_to_string(path).unwrap();
    let rows: Vec<Vec<f64>> = (text.lines().skip(1))
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .filter(|r: &Vec<f64>| r[0] <= end_s)
        .collect();
    rows.iter().map(|r| 0.5 * (r[3] + r[4])).sum::<f64>() / rows.len() as f64
}

/// The load 1000 N above the switching force p_acc (A1 − A2) with c1 = c2 = 2e-11 holds both
/// chambers within the valves' settings (p1 11.8 bar, p2 9.3 bar against the 6.91 bar
/// accumulator). The emulator holds `beta_bar` = 190 bar at the pre-charge, so at the
/// records' mean pressure over the fit windows (10.6 bar) its β_e is 290 bar: the fit finds
/// that within 5 % (measured 276.7 bar, −4.5 %: the dead band and Coulomb friction the linear
/// model has not), and is far from the 190 bar of the rig file.
#[test]
fn with_every_valve_shut_the_fit_reads_beta_e_at_the_records_pressure() {
    let dir = tempfile::tempdir().unwrap();
    let f_n = 6.91e5 * std::f64::consts::PI / 4.0 * 0.036f64.powi(2) + 1000.0;
    let sets = [
        "circuit=dual-pump".to_string(),
        format!("external_force_n={f_n}"),
        "c1_m5_per_ns=2e-11".into(),
        "c2_m5_per_ns=2e-11".into(),
        "beta_bar=190".into(),
        "viscous_friction_ns_per_m=300".into(),
        "c12_m5_per_ns=1.2e-10".into(),
    ];
    records(dir.path(), &sets);
    let args = ["identify", "exp.toml", "--json"].map(String::from);
    let doc: serde_json::Value =
        serde_json::from_str(&pumpcyl(dir.path(), &args).unwrap()).unwrap();
    let fitted = doc["beta_bar"].as_f64().unwrap();
    let p_mean = 0.5
        * (mean_pressure_bar(&dir.path().join("id.csv"), 2.7)
            + mean_pressure_bar(&dir.path().join("val.csv"), 2.4));
    let x = gas_fraction(190.0, 6.91, BETA_OIL_BAR).unwrap();
    let beta_e = effective_beta(x, p_mean, BETA_OIL_BAR);
    assert!((p_mean - 10.6).abs() < 0.1, "{p_mean} bar");
    assert!((beta_e - 290.0).abs() < 3.0, "{beta_e} bar");
    assert!(
        (fitted / beta_e - 1.0).abs() < 0.05,
        "fit {fitted} bar, β_e {beta_e} bar"
    );
}

/// The article-valued dual-pump rig at no load rests with chamber 1 at 6.3 bar, 0.6 bar below
/// the 6.91 bar accumulator: its check valve feeds it. Fitted all the same, β read 134 bar
/// against the emulator's 188 bar at the records' 7.9 bar (113 bar against a constant 165 with
/// the effects off); `identify` refuses the standstill, naming the chamber and the valve.
#[test]
fn a_standstill_with_a_check_valve_open_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    records(dir.path(), &["circuit=dual-pump".into()]);
    let err = pumpcyl(dir.path(), &["identify", "exp.toml"].map(String::from)).unwrap_err();
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    for part in [
        "standstill",
        "chamber 1",
        "check valve",
        "6.910 bar accumulator",
    ] {
        assert!(err.contains(part), "{part}: {err}");
    }
}
