//! The valve-controlled cylinder on the command line. `pumpcyl select` on it
//! (docs/select.md#cost-of-the-valve-controlled-cylinder):
//! its supply pressures as the levels, each candidate's β_e read at the mean chamber pressure
//! its valve holds at rest from that supply, its standing loss the power the supply delivers at
//! rest, and the gain and tracking of each candidate those `pumpcyl design` gives on the same
//! rig. Every reference here is computed from the valve's equations by hand (the closed-form
//! rest and the lands' law, docs/circuits.md#valve-rest), not by pumpcyl. And what it refuses:
//! an identification, whose c12 it has none of, in one line.

use serde_json::Value;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

const RIG: &str = r#"circuit = "valve"
piston_diameter_mm = 80.0
rod_diameter_mm = 45.0
stroke_mm = 400.0
x0_mm = 150.0
mass_kg = 2500.0
beta_bar = 8000.0
supply_pressure_bar = 180.0
valve_rated_flow_lpm = 40.0
valve_null_leakage_lpm = 4.0
external_force_n = 15000.0
line_volume_1_dm3 = 0.3
line_volume_2_dm3 = 0.3
kp = 2.0
mass_by_position = []
"#;

const APP: &str = r#"rig = "valve.toml"
supply_bar = [20.0, 35.0, 70.0, 140.0]
external_force_n = [5000.0, 15000.0]
[[wave]]
freq_hz = 0.1
amp_mm = 20.0
max_error_mm = 12.0
"#;

/// The valve's rest from the closed form (no cylinder leakage): spool opening, p1, p2 (Pa).
fn rest(ps: f64, force_n: f64, u0: f64) -> [f64; 3] {
    let a1 = std::f64::consts::PI / 4.0 * 0.08f64.powi(2);
    let a2 = a1 - std::f64::consts::PI / 4.0 * 0.045f64.powi(2);
    let k = (force_n + a2 * ps) / (a1 * ps - force_n);
    let r = k.sqrt();
    [
        u0 * (r - 1.0) / (r + 1.0),
        k * ps / (k + 1.0),
        ps / (k + 1.0),
    ]
}

#[test]
fn a_valve_rig_is_selected_over_its_supply_pressures() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("valve.toml"), RIG).unwrap();
    std::fs::write(dir.path().join("app.toml"), APP).unwrap();
    let s: Value = run::json(dir.path(), &["select", "app.toml", "--json"]);
    let options = s["options"].as_array().unwrap();
    let levels: Vec<f64> = options
        .iter()
        .map(|o| o["mean_pressure_bar"].as_f64().unwrap())
        .collect();
    assert_eq!(levels, [20.0, 35.0, 70.0, 140.0]);
    // 20 bar cannot hold 15 kN on the 80 mm piston: that candidate fails, named, the others run
    let first = &options[0];
    assert_eq!(first["kp_max"].as_f64().unwrap_or(0.0), 0.0);
    assert_eq!(first["meets"], false);
    assert!(
        first["reason"]
            .as_str()
            .unwrap()
            .contains("cannot hold the external force"),
        "{first}"
    );
    // the gas fraction from the rig's 8000 bar at its own rest (180 bar supply, 15 kN)
    let x_of = |beta: f64, p: f64| (1.0 / beta - 1.0 / 17000.0) / (1.0 / p - 1.0 / 17000.0);
    let [_, p1, p2] = rest(180e5, 15000.0, 1.0);
    let x = x_of(8000.0, 0.5 * (p1 + p2) / 1e5);
    let [lo, _, hi] = [0, 1, 2].map(|k| s["gas_fraction"][k].as_f64().unwrap());
    assert!(
        (lo - x / 2.0).abs() < 1e-9 * x && (hi - 2.0 * x).abs() < 1e-9 * x,
        "{lo} {hi} {x}"
    );
    // lands: K_v from 40 L/min at 35 bar, the underlap from 4 L/min of null leakage
    let lpm = 1e-3 / 60.0;
    let kv = 40.0 * lpm / 35e5f64.sqrt();
    for o in &options[1..] {
        let ps = o["mean_pressure_bar"].as_f64().unwrap() * 1e5;
        let u0 = 4.0 * lpm / (2.0 * kv * (ps / 2.0).sqrt());
        // β_e at the mean chamber pressure at rest under the rig's own force
        let [_, p1, p2] = rest(ps, 15000.0, u0);
        let p_mean = 0.5 * (p1 + p2) / 1e5;
        let beta = |x: f64| 1.0 / (x / p_mean + (1.0 - x) / 17000.0);
        let b = &o["beta_e_bar"];
        assert!(
            (b[0].as_f64().unwrap() - beta(hi)).abs() < 1e-6 * beta(hi),
            "{o}"
        );
        assert!(
            (b[1].as_f64().unwrap() - beta(lo)).abs() < 1e-6 * beta(lo),
            "{o}"
        );
        // the supply's power at rest, (p_s − p_t) Q through the lands P→A and P→B, at both ends
        // of the force range
        for (k, f) in [5000.0, 15000.0].into_iter().enumerate() {
            let [s0, p1, p2] = rest(ps, f, u0);
            let q = kv * ((u0 + s0) * (ps - p1).sqrt() + (u0 - s0) * (ps - p2).sqrt());
            let got = o["standing"][k]["power_w"].as_f64().unwrap();
            assert!(
                (got - ps * q).abs() < 1e-6 * ps * q,
                "{f} N: {got} vs {}",
                ps * q
            );
            let p = &o["standing"][k]["p_bar"];
            assert!((p[0].as_f64().unwrap() - p1 / 1e5).abs() < 1e-6);
        }
        assert!(o["standing_loss_w"].as_f64().unwrap() > 0.0);
    }
    // each candidate's gain holds over the gas-fraction range and the stroke: at most what
    // `design` allows on the rig at that supply with the softest β_e
    for o in &options[1..] {
        let ps = o["mean_pressure_bar"].as_f64().unwrap();
        let d: Value = run::json(
            dir.path(),
            &[
                "design",
                "--rig",
                "valve.toml",
                "--set",
                &format!("supply_pressure_bar={ps}"),
                "--set",
                &format!("beta_bar={}", o["beta_e_bar"][0].as_f64().unwrap()),
                "--json",
            ],
        );
        let soft = d["kp_max_worst_case"].as_f64().unwrap();
        let kp = o["kp_max"].as_f64().unwrap();
        assert!(
            kp <= soft * (1.0 + 1e-9),
            "{ps} bar: {kp} above the softest's {soft}"
        );
    }
    // the answer: a supply between the levels, the valve named in the verdict
    assert_eq!(s["chosen_circuit"], "valve");
    assert_eq!(s["verdict"], "valve_suitable");
    let [fails, meets] = [0, 1].map(|k| s["min_mean_pressure_bracket_bar"][k].as_f64().unwrap());
    assert!(
        meets - fails <= 0.01 + 1e-12 && meets <= 35.0 && fails >= 20.0,
        "{fails} {meets}"
    );
    assert_eq!(s["min_level_bar"], 35.0);
    let out = run::pumpcyl(dir.path(), &["select", "app.toml"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("VALVE-CONTROLLED CYLINDER SUITABLE"),
        "{text}"
    );
    assert!(!text.contains("single-pump mode check"), "{text}");
}

#[test]
fn identifying_a_valve_rig_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let exp = "[set]\ncircuit = \"valve\"\n[standstill]\nw1_rpm = -160.0\nw2_rpm = 245.0\n\
               p1_bar = 3.95\n[[dataset]]\nfile = \"r.csv\"\nkp = 0.5\nmass_kg = 10593.0\n\
               fit_end_s = 4.0\n";
    std::fs::write(dir.path().join("exp.toml"), exp).unwrap();
    run::refused(
        dir.path(),
        &["identify", "exp.toml"],
        &[
            "exp.toml",
            "circuit = \"valve\"",
            "c12",
            "circuits with drives",
        ],
    );
}

/// A servo valve can be tried beside a pump rig's circuits when named
/// (docs/select.md#the-valve-beside-the-pumps): on the user rig (not the article's) the
/// selection holds the DPM's levels and a valve candidate at each supply pressure, its rated
/// flow sized for the pumps' top speed; unnamed, the pump rig's default has no valve.
#[test]
fn select_tries_a_valve_beside_a_pump_rigs_circuits_when_named() {
    let user = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/user-rig.toml");
    let doc: Value = run::json(
        std::path::Path::new("."),
        &[
            "select",
            "--rig",
            user,
            "--circuits",
            "dpm,valve",
            "--set",
            "supply_bar=[70.0, 140.0]",
            "--json",
        ],
    );
    let options = doc["options"].as_array().unwrap();
    let valves: Vec<&Value> = options
        .iter()
        .filter(|o| o["circuit_kind"] == "valve")
        .collect();
    let levels: Vec<f64> = valves
        .iter()
        .map(|o| o["mean_pressure_bar"].as_f64().unwrap())
        .collect();
    assert_eq!(levels, [70.0, 140.0], "{doc}");
    assert!(options.iter().any(|o| o["circuit_kind"] == "dpm"));
    for v in &valves {
        let kv = v["kv_max_per_s"].as_f64().unwrap();
        assert!(kv > 0.0 && v["kp_max"].as_f64().unwrap() > 0.0, "{v}");
        assert!(v["standing_loss_w"].as_f64().unwrap() > 0.0, "{v}");
    }
    let default: Value = run::json(
        std::path::Path::new("."),
        &["select", "--rig", user, "--json"],
    );
    let kinds: Vec<&str> = (default["options"].as_array().unwrap().iter())
        .map(|o| o["circuit_kind"].as_str().unwrap())
        .collect();
    assert!(!kinds.contains(&"valve"), "{kinds:?}");
}
