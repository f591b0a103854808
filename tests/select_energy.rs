//! `select --energy` (docs/select.md#energy): each circuit of a selection through the
//! application's duty cycle on the emulated rig — the figures of each closing as an account, the
//! cheapest that meets named, what the chosen circuit costs against it and saves against the
//! valve — on an application of the user rig where the DPM, the dual-pump circuit and a valve
//! all meet; and without `--energy` the selection's document has no `energy`.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;
use serde_json::Value;

fn app(dir: &std::path::Path) {
    let user = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/user-rig.toml");
    let text = format!(
        "rig = \"{user}\"\nsupply_bar = [70.0, 140.0]\n[[wave]]\nfreq_hz = 0.1\namp_mm = 20.0\n\
         max_error_mm = 30.0\n"
    );
    std::fs::write(dir.join("app.toml"), text).unwrap();
}

fn f(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key}: {v}"))
}

#[test]
fn select_prices_each_circuit_over_the_duty_cycle() {
    let dir = tempfile::tempdir().unwrap();
    app(dir.path());
    let args = ["select", "app.toml", "--circuits", "dpm,dual-pump,valve"];
    let doc = run::json(dir.path(), &[&args[..], &["--energy", "--json"]].concat());
    let e = &doc["energy"];
    let circuits = e["circuits"].as_array().unwrap();
    let kinds: Vec<&str> = circuits
        .iter()
        .map(|c| c["circuit_kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["dpm", "dual-pump", "valve"], "{e}");
    let net = |kind: &str| {
        f(
            &circuits[kinds.iter().position(|k| *k == kind).unwrap()]["energy"],
            "net_j",
        )
    };
    for c in circuits {
        assert_eq!(c["meets"], true, "{c}");
        let s = &c["energy"];
        let closing =
            f(s, "net_j") - f(s, "work_out_j") - f(s, "losses_j") - f(s, "stored_change_j");
        assert!(closing.abs() <= 1e-6 * f(s, "drawn_j"), "{c}");
        assert!(
            (f(s, "drawn_j") - f(s, "regenerated_j") - f(s, "net_j")).abs()
                <= 1e-9 * f(s, "drawn_j")
        );
        let by_kind: f64 = c["losses_j"]
            .as_object()
            .unwrap()
            .values()
            .map(|j| j.as_f64().unwrap())
            .sum();
        assert!(
            (by_kind - f(s, "losses_j")).abs() <= 1e-9 * f(s, "drawn_j"),
            "{c}"
        );
    }
    // the valve pays for throttling, the pumps do not throttle
    let valve = &circuits[2];
    assert!(
        f(&valve["losses_j"], "valve_throttling") > 0.9 * f(&valve["energy"], "losses_j"),
        "{valve}"
    );
    assert!(circuits[0]["losses_j"].get("valve_throttling").is_none());
    assert_eq!(valve["drives"], serde_json::json!([]));
    // the chosen circuit against the cheapest that meets and against the valve
    assert_eq!(e["chosen"], doc["chosen_circuit"]);
    let chosen = doc["chosen_circuit"].as_str().unwrap();
    let cheapest = ["dpm", "dual-pump", "valve"]
        .into_iter()
        .min_by(|a, b| net(a).total_cmp(&net(b)))
        .unwrap();
    assert_eq!(e["cheapest"], cheapest);
    assert_eq!(f(e, "chosen_over_cheapest_j"), net(chosen) - net(cheapest));
    assert_eq!(f(e, "chosen_saves_vs_valve_j"), net("valve") - net(chosen));
    assert_eq!(
        f(e, "chosen_saves_vs_valve_fraction"),
        (net("valve") - net(chosen)) / net("valve")
    );
    assert!(f(e, "chosen_saves_vs_valve_fraction") > 0.5, "{e}");
    // the chosen circuit's cycle runs at the answer's level and gain
    let at = &doc["at_min_mean_pressure"];
    assert_eq!(circuits[0]["mean_pressure_bar"], at["mean_pressure_bar"]);
    assert_eq!(circuits[0]["kp"], at["kp_max"]);
    // without --energy: the selection alone
    let plain = run::json(dir.path(), &[&args[..], &["--json"]].concat());
    assert!(plain.get("energy").is_none());
    let mut with = doc.clone();
    with.as_object_mut().unwrap().remove("energy");
    assert_eq!(with, plain);
}
