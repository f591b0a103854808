//! The report's models of β(p) through the article's reading (docs/bulk-modulus.md#a-family-of-models):
//! summary.json's `margins.models` holds each model's β_e at 1 and 10 bar as `pumpcyl
//! bulk-modulus --json` tables them, and its lowest level is where the Table 1 loop starts to
//! meet PM 34° and GM 6 dB: `pumpcyl margins` with that model's β a hundredth of a bar above
//! it meets them, two hundredths below it does not.

use super::{pumpcyl_stdout as pumpcyl, summary};
use serde_json::Value;

/// `pumpcyl margins --json` with β `beta_bar`.
fn margins_at(beta_bar: f64) -> Value {
    let set = format!("beta_bar={beta_bar:?}");
    let args = ["margins".into(), "--json".into(), "--set".into(), set];
    serde_json::from_slice(&pumpcyl(&args)).unwrap()
}

/// Whether the margins meet PM 34° and GM 6 dB with a stable loop.
fn meets(m: &Value) -> bool {
    let pm = m["phase_margin_deg"].as_f64().unwrap_or(f64::INFINITY);
    let gm = m["gain_margin_db"].as_f64().unwrap_or(f64::INFINITY);
    m["closed_loop_stable"].as_bool().unwrap() && pm >= 34.0 && gm >= 6.0
}

#[test]
fn the_report_tables_each_model_and_the_lowest_level_it_allows() {
    let s = summary();
    let models = s["margins"]["models"].as_array().unwrap();
    let args: Vec<String> = [
        "bulk-modulus",
        "--json",
        "--from-bar",
        "1",
        "--to-bar",
        "10",
    ]
    .iter()
    .map(|a| a.to_string())
    .collect();
    let bulk: Value = serde_json::from_slice(&pumpcyl(&args)).unwrap();
    let family = bulk["models"]["models"].as_array().unwrap();
    assert_eq!(models.len(), family.len());
    for (m, f) in models.iter().zip(family) {
        assert_eq!(m["model"], f["model"]);
        let table = f["beta_bar"].as_array().unwrap();
        let (first, last) = (
            table[0].as_f64().unwrap(),
            table.last().unwrap().as_f64().unwrap(),
        );
        assert!((m["beta_1bar"].as_f64().unwrap() / first - 1.0).abs() < 1e-12);
        assert!((m["beta_10bar"].as_f64().unwrap() / last - 1.0).abs() < 1e-12);
        let x = m["gas_fraction"].as_f64().unwrap();
        assert_eq!(x, f["gas_fraction"].as_f64().unwrap());
        let p = m["lowest_level_bar"].as_f64().unwrap();
        // the model's β just above and below the level, by the bulk-modulus table there
        let beta_at = |p_bar: f64| {
            let a = ["bulk-modulus", "--json", "--points", "2", "--from-bar"];
            let mut args: Vec<String> = a.iter().map(|a| a.to_string()).collect();
            args.extend([
                format!("{p_bar}"),
                "--to-bar".into(),
                format!("{}", p_bar + 1.0),
            ]);
            let doc: Value = serde_json::from_slice(&pumpcyl(&args)).unwrap();
            let row = doc["models"]["models"].as_array().unwrap().iter();
            let same = row.clone().find(|r| r["model"] == m["model"]).unwrap();
            same["beta_bar"][0].as_f64().unwrap()
        };
        assert!(meets(&margins_at(beta_at(p + 0.01))), "{m}");
        assert!(!meets(&margins_at(beta_at(p - 0.02))), "{m}");
    }
}

/// The report's `which_circuit.models`: under each model of β(p), the DPM's lowest meeting
/// level over the stated gas-fraction range is `pumpcyl select --circuits dpm` with the
/// article rig under that model (`--set rig.bulk_modulus_model=…` and its parameters), and
/// the models do not all agree (the choice of level moves with the model).
#[test]
fn the_report_selects_under_each_model_as_select_does() {
    let s = summary();
    let models = s["which_circuit"]["models"].as_array().unwrap();
    assert_eq!(models.len(), 4);
    let mut lowest = Vec::new();
    for m in models {
        let mut args: Vec<String> = ["select", "--json", "--circuits", "dpm"]
            .iter()
            .map(|a| a.to_string())
            .collect();
        for (k, v) in m["model"].as_object().unwrap() {
            let key = if k == "model" {
                "bulk_modulus_model"
            } else {
                k
            };
            let v = v.as_str().map_or(v.to_string(), str::to_string);
            args.extend(["--set".into(), format!("rig.{key}={v}")]);
        }
        let doc: Value = serde_json::from_slice(&pumpcyl(&args)).unwrap();
        for key in ["min_mean_pressure_bar", "min_level_bar", "gas_fraction"] {
            assert_eq!(m[key], doc[key], "{key} under {}", m["model"]);
        }
        lowest.push(m["min_mean_pressure_bar"].as_f64().unwrap());
    }
    let spread = lowest.iter().fold(0.0f64, |a, b| a.max(*b))
        - lowest.iter().fold(f64::INFINITY, |a, b| a.min(*b));
    assert!(spread > 1.0, "{lowest:?}");
}
