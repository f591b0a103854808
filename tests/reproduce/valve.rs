//! The report's section "Valve or pump" against the commands a user runs on the same rigs:
//! `pumpcyl design --json` for K_p max and K_v, `pumpcyl track --json` at that gain for the
//! 0.2 Hz ±35 mm error, `pumpcyl poles --json` for the resonance, `pumpcyl model --json` for an
//! independent K_v (lim s·L(s) by a solve at small s), and Merritt's ω_h and the valve's sizing
//! from the rig's own numbers. Part of tests/reproduce.rs, so it shares that file's one
//! reproduce run.

use super::json::matrix;
use super::{reproduced, summary};
use nalgebra::{DMatrix, DVector};
use serde_json::Value;
use std::f64::consts::PI;
use std::process::Command;

/// `pumpcyl ARGS --json` on the side's rig, parsed.
fn json(args: &[&str], side: &Value) -> Value {
    let mut all: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    for s in side["set"].as_array().unwrap() {
        all.extend(["--set".to_string(), s.as_str().unwrap().to_string()]);
    }
    all.push("--json".to_string());
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(&all)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "pumpcyl {all:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn close(what: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs(),
        "{what}: {got} against {want}"
    );
}

/// lim s·L(s) of the open loop `pumpcyl model --json` prints, at s = 10⁻⁷ rad/s by a dense
/// solve (the loop's other poles are above 10⁻² rad/s).
fn velocity_gain(model: &Value) -> f64 {
    let a = matrix(&model["A"]);
    let n = a.len();
    let s = 1e-7;
    let m = DMatrix::from_fn(n, n, |i, j| if i == j { s } else { 0.0 } - a[i][j]);
    let b = DVector::from_iterator(n, matrix(&model["B"]).into_iter().map(|r| r[0]));
    let c = &matrix(&model["C"])[0];
    let x = m.lu().solve(&b).unwrap();
    s * (0..n).map(|i| c[i] * x[i]).sum::<f64>()
}

#[test]
fn the_valve_or_pump_section_holds_the_commands_numbers() {
    let s = summary();
    let v = &s["valve_or_pump"];
    let sides = v["sides"].as_array().unwrap();
    let kinds: Vec<&str> = sides
        .iter()
        .map(|c| c["circuit"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["dpm", "valve", "valve"]);
    // the DPM's top speed from Table 1: 6 cm³/rev at 3600 rpm into the 63/36 mm annulus
    let a1 = PI / 4.0 * 0.063f64.powi(2);
    let a2 = a1 - PI / 4.0 * 0.036f64.powi(2);
    let top = 6e-6 * 60.0 / a2;
    close(
        "top speed",
        v["top_speed_m_per_s"].as_f64().unwrap(),
        top,
        1e-12,
    );
    for side in sides {
        let what = side["label"].as_str().unwrap();
        let num = |k: &str| side[k].as_f64().unwrap();
        let design = json(
            &["design", "--target-pm-deg", "34", "--target-gm-db", "6.5"],
            side,
        );
        close(
            what,
            num("kp_max"),
            design["kp_max"].as_f64().unwrap(),
            1e-12,
        );
        close(
            what,
            num("kv_max_per_s"),
            design["kv_max_per_s"].as_f64().unwrap(),
            1e-12,
        );
        let kp = format!("kp={}", num("kp_max"));
        let model = json(&["model", "--set", &kp], side);
        close(
            &format!("{what}: K_v"),
            num("kv_max_per_s"),
            velocity_gain(&model),
            1e-4,
        );
        let track = json(
            &["track", "--freq-hz", "0.2", "--amp-mm", "35", "--set", &kp],
            side,
        );
        let error = track["cases"][0]["metrics"]["max_error_mm"]
            .as_f64()
            .unwrap_or_else(|| panic!("{track}"));
        close(
            &format!("{what}: tracking"),
            num("max_error_mm"),
            error,
            1e-9,
        );
        // the resonance: the least-damped open-loop pole pair in 0.1-30 Hz
        let poles = json(&["poles"], side);
        let least = (poles["open_loop"].as_array().unwrap().iter())
            .filter(|p| p["im"].as_f64().unwrap() > 0.0)
            .filter(|p| (0.1..30.0).contains(&p["natural_freq_hz"].as_f64().unwrap()))
            .min_by(|a, b| {
                a["damping"]
                    .as_f64()
                    .unwrap()
                    .total_cmp(&b["damping"].as_f64().unwrap())
            })
            .unwrap();
        close(
            &format!("{what}: resonance"),
            num("resonance_hz"),
            least["natural_freq_hz"].as_f64().unwrap(),
            1e-9,
        );
        if side["circuit"] == "valve" {
            // the valve's resonance is Merritt's hydraulic natural frequency, and far less
            // damped than the DPM's
            close(
                &format!("{what}: Merritt"),
                num("resonance_hz"),
                num("merritt_hz"),
                0.01,
            );
            assert!(num("damping_ratio") < 0.1 * sides[0]["damping_ratio"].as_f64().unwrap());
            assert!(num("kv_max_per_s") < 0.1 * sides[0]["kv_max_per_s"].as_f64().unwrap());
        }
    }
    // each side's figures are at its K_p max: one of the article's margins binds there
    for case in v["at_kp_max"].as_array().unwrap() {
        let gm = case["gain_margin_db"].as_f64().unwrap();
        let pm = case["phase_margin_deg"].as_f64().unwrap();
        assert!(
            (gm - 6.5).abs() < 1e-6 || (pm - 34.0).abs() < 1e-6,
            "{gm} dB {pm} deg"
        );
        assert!(gm >= 6.5 - 1e-6 && pm >= 34.0 - 1e-6, "{gm} dB {pm} deg");
    }
    // β_e of the rig's oil at the valve's rest: 1/β = X/p + (1 − X)/β_oil
    let (x, p) = (
        v["gas_fraction"].as_f64().unwrap(),
        sides[1]["p_mean_bar"].as_f64().unwrap(),
    );
    close(
        "valve β_e",
        sides[1]["beta_e_bar"].as_f64().unwrap(),
        1.0 / (x / p + (1.0 - x) / 17000.0),
        1e-9,
    );
    // the section is in the report, as a table with its comparison rows
    let html = std::fs::read_to_string(reproduced().0.join("report.html")).unwrap();
    assert!(html.contains("Valve or pump"));
    assert!(html.contains("would certainly not have been achievable"));
}
