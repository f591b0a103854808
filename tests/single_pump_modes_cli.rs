//! `pumpcyl margins` and `pumpcyl poles` on a single-pump rig
//! (docs/circuits.md#modes-in-margins-and-poles): both modes, each with the margins (poles) of
//! its own linear model, the mode at rest marked, beside the switching force p_acc (A1 − A2)
//! computed here by hand; on the article's values and on the user rig.

use pumpcyl::circuit::single_pump::modes::Mode;
use pumpcyl::lti;
use pumpcyl::rig::Rig;
use serde_json::Value;
use std::f64::consts::PI;
use std::path::Path;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// The rig file args and the same rig in Rust: the article's values or the user rig (its
/// file less its second pump, which the single-pump circuit has not), as a single-pump circuit
/// at `force_n`; the folder holding the file.
fn rigs(user: bool, force_n: f64) -> (tempfile::TempDir, Vec<String>, Rig) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("rig.toml");
    let text = if user {
        let own = std::fs::read_to_string("tests/user-rig.toml").unwrap();
        let kept: Vec<&str> = (own.lines())
            .filter(|l| !l.starts_with("displacement_2_cm3_per_rev"))
            .collect();
        kept.join("\n")
    } else {
        String::new()
    };
    std::fs::write(&file, format!("circuit = \"single-pump\"\n{text}\n")).unwrap();
    let set = format!("external_force_n={force_n}");
    let args = vec![
        "--rig".to_string(),
        file.display().to_string(),
        "--set".to_string(),
        set.clone(),
    ];
    let rig = Rig::from_file(&file)
        .unwrap()
        .with_overrides(&[set])
        .unwrap();
    (dir, args, rig)
}

fn cli(command: &str, args: &[String]) -> Value {
    let mut all = vec![command, "--json"];
    all.extend(args.iter().map(String::as_str));
    run::json(Path::new("."), &all)
}

fn close(a: &Value, b: Option<f64>) {
    match (a.as_f64(), b) {
        (Some(a), Some(b)) => assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} vs {b}"),
        (None, None) => {}
        (a, b) => panic!("{a:?} vs {b:?}"),
    }
}

/// The switching force by hand: the rod's annulus π/4 d² times the pre-charge.
fn switching_force_n(rig: &Rig) -> f64 {
    rig.accumulator_precharge_bar * 1e5 * PI / 4.0 * (rig.rod_diameter_mm * 1e-3).powi(2)
}

/// Each mode's margins in `margins --json` are `lti::margins` of that mode's own loop; the
/// mode at rest is the one the force puts it in, and the headline margins are its.
#[test]
fn the_modes_margins_are_each_modes_own() {
    for (user, force) in [(false, 0.0), (true, 0.0), (false, 7000.0)] {
        let (_dir, args, rig) = rigs(user, force);
        let doc = cli("margins", &args);
        let f_s = switching_force_n(&rig);
        close(&doc["switching_force_n"], Some(f_s));
        close(&doc["force_from_switching_n"], Some(force - f_s));
        close(
            &doc["acceleration_to_switch_m_per_s2"],
            Some((f_s - force) / rig.mass_kg),
        );
        let at_rest = if force > f_s { 1 } else { 2 };
        assert_eq!(doc["mode_at_rest"], at_rest);
        let modes = doc["modes"].as_array().unwrap();
        assert_eq!(modes.len(), 2);
        for (m, chamber) in modes.iter().zip([2, 1]) {
            assert_eq!(m["accumulator_chamber"], chamber);
            let mode = Mode::new(&rig, chamber);
            assert_eq!(m["mode"], mode.number());
            assert_eq!(m["at_rest"], mode.number() == at_rest);
            let want = lti::margins(&mode.open_loop().unwrap()).unwrap();
            close(&m["gain_margin_db"], want.gain_margin_db);
            close(&m["phase_margin_deg"], want.phase_margin_deg);
            close(&m["gain_crossover_hz"], want.gain_crossover_hz);
            close(&m["delay_margin_s"], want.delay_margin_s);
            assert_eq!(m["closed_loop_stable"], want.closed_loop_stable);
            assert_eq!(
                m["crossings"].as_array().unwrap().len(),
                want.crossings.len()
            );
            if mode.number() == at_rest {
                assert_eq!(m["gain_margin_db"], doc["gain_margin_db"]);
            }
        }
    }
}

/// Each mode's closed-loop poles in `poles --json` are the eigenvalues of unity feedback around
/// its own loop; the text outputs show both modes.
#[test]
fn the_modes_poles_and_the_text_show_both_modes() {
    let (_dir, args, rig) = rigs(true, 0.0);
    let doc = cli("poles", &args);
    close(&doc["switching_force_n"], Some(switching_force_n(&rig)));
    for (m, chamber) in doc["modes"].as_array().unwrap().iter().zip([2, 1]) {
        let cl = Mode::new(&rig, chamber)
            .open_loop()
            .unwrap()
            .unity_feedback()
            .unwrap();
        let (poles, _) = lti::poles_and_stability(&cl.a).unwrap();
        let mut want: Vec<f64> = poles.iter().map(|p| p.re).collect();
        let mut got: Vec<f64> = (m["closed_loop"].as_array().unwrap().iter())
            .map(|p| p["re"].as_f64().unwrap())
            .collect();
        want.sort_by(f64::total_cmp);
        got.sort_by(f64::total_cmp);
        assert_eq!(got, want);
        assert_eq!(got.len(), 6);
        // independently: the poles' sum is the trace of the mode's closed loop
        let trace = cl.a.trace();
        let sum: f64 = got.iter().sum();
        assert!(
            (sum - trace).abs() <= 1e-9 * trace.abs(),
            "{sum} vs {trace}"
        );
    }
    for command in ["margins", "poles"] {
        let mut all = vec![command];
        all.extend(args.iter().map(String::as_str));
        let out = run::pumpcyl(Path::new("."), &all);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success());
        assert!(text.contains("switching force p_acc (A1 - A2)"), "{text}");
        assert!(
            text.contains("\nmode 1 (chamber 2 at the accumulator pressure)\n"),
            "{text}"
        );
        assert!(
            text.contains("\nmode 2 (chamber 1 at the accumulator pressure), the mode at rest\n"),
            "{text}"
        );
    }
    // the DPM's documents have no modes
    let dpm = run::json(Path::new("."), &["margins", "--json"]);
    assert!(dpm.get("modes").is_none() && dpm.get("switching_force_n").is_none());
}

/// `design` on a single-pump rig names the circuit and the mode whose linear model the gains
/// are designed on, in the text and the JSON (`analysed_loop`), as `margins` does.
#[test]
fn design_names_the_circuit_and_the_mode_at_rest() {
    let dir = tempfile::tempdir().unwrap();
    let v = run::json(
        dir.path(),
        &["design", "--set", "circuit=single-pump", "--json"],
    );
    let named = v["analysed_loop"].as_str().unwrap();
    assert!(
        named.contains("circuit single-pump") && named.contains("the mode at rest"),
        "{named}"
    );
    let margins = run::pumpcyl(dir.path(), &["margins", "--set", "circuit=single-pump"]);
    assert!(String::from_utf8_lossy(&margins.stdout).contains(named));
}

/// `design` on a single-pump rig checks its gain in both modes at every condition: each
/// condition's margins equal those `margins` gives for that mode at that position, mass and
/// gain, and the gain over all conditions is the least Kp max of both modes. On the user rig
/// under 2 kN (above its switching force: mode 1 at rest) the other mode binds, below what
/// mode 1 alone would allow.
#[test]
fn design_checks_both_modes_at_every_condition() {
    let (dir, args, _) = rigs(true, 2000.0);
    let mut design = vec!["design", "--json"];
    design.extend(args.iter().map(String::as_str));
    let d = run::json(dir.path(), &design);
    let conditions = d["conditions"].as_array().unwrap();
    let checked = conditions
        .iter()
        .filter(|c| c["searched"].is_null())
        .count();
    assert_eq!(checked, 6, "3 positions × 2 modes");
    assert_eq!(
        conditions.len(),
        10,
        "and the least PM and GM searched in each mode"
    );
    let kp = d["kp_max"].as_f64().unwrap();
    for c in conditions {
        let mode = c["mode"].as_u64().unwrap();
        let (x, m) = (c["x_mm"].as_f64().unwrap(), c["mass_kg"].as_f64().unwrap());
        let sets = [
            format!("kp={kp}"),
            format!("x0_mm={x}"),
            format!("mass_kg={m}"),
        ];
        let mut margins = vec!["margins", "--json"];
        margins.extend(args.iter().map(String::as_str));
        for s in &sets {
            margins.extend(["--set", s.as_str()]);
        }
        let v = run::json(dir.path(), &margins);
        let same = (v["modes"].as_array().unwrap().iter())
            .find(|e| e["mode"].as_u64() == Some(mode))
            .unwrap_or_else(|| panic!("mode {mode} in {v}"));
        for key in ["gain_margin_db", "phase_margin_deg"] {
            let (a, b) = (c[key].as_f64().unwrap(), same[key].as_f64().unwrap());
            assert!(
                (a - b).abs() < 1e-9 * b.abs().max(1.0),
                "{key} mode {mode}: {a} {b}"
            );
        }
    }
    let least = (conditions.iter())
        .map(|c| c["kp_max"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    let worst_case = d["kp_max_worst_case"].as_f64().unwrap();
    assert_eq!(worst_case, least);
    assert!(d["analysed_loop"].as_str().unwrap().contains("mode 1"));
    assert_eq!(d["worst_case"]["mode"], 2);
    let at_rest = (conditions.iter())
        .filter(|c| c["mode"] == 1)
        .map(|c| c["kp_max"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert!(worst_case < 0.9 * at_rest, "{worst_case} {at_rest}");
}
