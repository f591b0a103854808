//! One anchor per rig (docs/bulk-modulus.md#the-anchor): `design --p-mean-bar`, `bulk-modulus`,
//! `select` and the emulator read the rig's gas fraction off its `beta_bar` at the same mean
//! pressure, the pressure where its emulated loop rests, and say which.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

use std::path::Path;

/// An 80/45 mm DPM of 2000 kg with a 12 bar sum-pressure set-point (not the article's rig).
const RIG: &str = "piston_diameter_mm = 80.0
rod_diameter_mm = 45.0
stroke_mm = 800.0
x0_mm = 400.0
mass_kg = 2000.0
mass_by_position = []
displacement_1_cm3_per_rev = 8.0
displacement_2_cm3_per_rev = 5.0
beta_bar = 200.0
p_sum_ref_bar = 12.0
kp = 15.0
";

fn pumpcyl(args: &[&str], rig: &Path) -> serde_json::Value {
    let rig = rig.to_str().unwrap();
    run::json(Path::new("."), &[args, &["--rig", rig, "--json"]].concat())
}

/// The mean chamber pressure (bar) where the emulated rig rests: the last row of a noise-free
/// standstill record (its columns as docs/formats.md#record-csv).
fn emulated_rest_bar(rig: &Path, dir: &Path) -> f64 {
    let csv = dir.join("standstill.csv");
    let (rig, out) = (rig.to_str().unwrap(), csv.to_str().unwrap());
    let args = [
        "emulate",
        "--experiment",
        "standstill",
        "--duration-s",
        "20",
        "--no-noise",
    ];
    let done = run::pumpcyl(dir, &[&args[..], &["--rig", rig, "--out", out]].concat());
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let last: Vec<f64> = (lines.next_back().unwrap().split(','))
        .map(|v| v.parse().unwrap())
        .collect();
    let at = |name: &str| last[head.iter().position(|h| *h == name).unwrap()];
    0.5 * (at("p1_bar") + at("p2_bar"))
}

#[test]
fn design_bulk_modulus_and_the_emulator_anchor_beta_at_one_pressure() {
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("rig.toml");
    std::fs::write(&rig, RIG).unwrap();
    let rest = emulated_rest_bar(&rig, dir.path());
    // the P laws rest the loop below half its 12 bar set-point
    assert!(rest > 4.0 && rest < 5.99, "{rest}");

    let design = pumpcyl(&["design", "--p-mean-bar", "3"], &rig);
    let anchor = design["targets"]["p_beta_bar"].as_f64().unwrap();
    assert!(
        (anchor - rest).abs() < 1e-3,
        "design anchors at {anchor}, the rig rests at {rest}"
    );
    // the same gain as naming the anchor by hand, and not the article's 4.4 bar's
    let by_hand = pumpcyl(
        &[
            "design",
            "--p-mean-bar",
            "3",
            "--p-beta-bar",
            &format!("{anchor}"),
        ],
        &rig,
    );
    assert_eq!(design["kp_max_worst_case"], by_hand["kp_max_worst_case"]);
    let article = pumpcyl(
        &["design", "--p-mean-bar", "3", "--p-beta-bar", "4.4"],
        &rig,
    );
    // the worst case is the 3 bar condition, whose β the anchor sets
    let worst = |d: &serde_json::Value| d["kp_max_worst_case"].as_f64().unwrap();
    let (own, at_44) = (worst(&design), worst(&article));
    assert!((own / at_44 - 1.0).abs() > 0.05, "{own} vs {at_44}");

    let bulk = pumpcyl(&["bulk-modulus"], &rig);
    let p = bulk["gas_fraction_from"]["p_mean_bar"].as_f64().unwrap();
    assert!(
        (p - anchor).abs() < 1e-12,
        "bulk-modulus reads beta at {p}, design at {anchor}"
    );
}

#[test]
fn the_article_rig_keeps_the_article_anchor() {
    let dir = tempfile::tempdir().unwrap();
    let v = run::json(dir.path(), &["design", "--p-mean-bar", "2", "--json"]);
    assert_eq!(v["targets"]["p_beta_bar"], 4.4);
}
