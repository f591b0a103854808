//! `pumpcyl cycle` (docs/energy.md#duty-cycles): a duty cycle's energy closes and its figures
//! are the account's; a constant-velocity stroke's losses are the loss models by hand; the
//! drives' duty names a motor too small; bad cycles are refused in one line.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;
use serde_json::Value;
use std::path::Path;

/// The user rig (tests/user-rig.toml) with the drives' electrical losses of a real servo and
/// its pumps' torque losses.
fn electric_rig(dir: &Path) -> String {
    let user = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/user-rig.toml"))
        .unwrap();
    let text = format!(
        "{user}\nmotor_winding_resistance_ohm = 1.8\nmotor_torque_constant_nm_per_a = 1.4\n\
         drive_efficiency = 0.94\ndrive_regeneration_fraction = 0.5\n\
         pump_friction_torque_fraction = 0.02\npump_viscous_torque_nms_per_rad = 1e-4\n"
    );
    let path = dir.join("electric.toml");
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// A record's power columns by name (docs/formats.md#power-columns), and its signals.
fn columns(csv: &str) -> Vec<(String, Vec<f64>)> {
    let mut lines = csv.lines();
    let names: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (names.iter().enumerate())
        .map(|(c, n)| (n.to_string(), rows.iter().map(|r| r[c]).collect()))
        .collect()
}

fn column<'a>(cols: &'a [(String, Vec<f64>)], name: &str) -> &'a [f64] {
    &cols.iter().find(|(n, _)| n == name).unwrap().1
}

#[test]
fn a_step_cycle_closes_and_its_figures_are_the_accounts() {
    let dir = tempfile::tempdir().unwrap();
    let rig = electric_rig(dir.path());
    let args = [
        "cycle", "--rig", &rig, "--cycle", "steps", "--hold-s", "1", "--json",
    ];
    let doc = run::json(dir.path(), &[&args[..], &["--out", "c.csv"]].concat());
    let (s, e) = (&doc["summary"], &doc["energy"]);
    let get = |v: &Value, k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k}: {v}"));
    assert_eq!(doc["cycle"]["duration_s"], 5.0);
    assert_eq!(get(s, "duration_s"), 5.0);
    // net = drawn − returned = the sources; the account closes over the cycle
    let net = get(s, "net_j");
    assert!((net - run::sum(&e["sources_j"])).abs() <= 1e-12 * net);
    assert!((get(s, "drawn_j") - get(s, "regenerated_j") - net).abs() <= 1e-9 * net);
    assert_eq!(get(s, "drawn_j"), get(&e["sources_j"], "electrical"));
    let closing = net - get(s, "work_out_j") - get(s, "losses_j") - get(s, "stored_change_j");
    assert!(closing.abs() <= 1e-6 * get(s, "drawn_j"), "{closing} J");
    assert!((get(s, "mean_power_w") - net / 5.0).abs() <= 1e-12 * net);
    // every drive-train loss is there, set: the copper, the electronics, the bus's brake share,
    // the pumps' friction
    for kind in [
        "copper",
        "drive_electronics",
        "brake_resistor",
        "pump_friction",
    ] {
        assert!(get(&e["losses_j"], kind) > 0.0, "{kind}: {e}");
    }
    assert!(get(s, "regenerated_j") > 0.0, "{s}");
    assert!(
        (get(&e["losses_j"], "brake_resistor") - get(s, "regenerated_j")).abs()
            <= 1e-9 * get(s, "drawn_j"),
        "half the bus's braking returned, half burnt: {e}"
    );
    assert_eq!(doc["defaults_assumed"], serde_json::json!({}));
    // the record's power columns give the figures: peak and the load's positive work
    let csv = std::fs::read_to_string(dir.path().join("c.csv")).unwrap();
    let cols = columns(&csv);
    let drawn: Vec<f64> = (0..column(&cols, "time_s").len())
        .map(|k| column(&cols, "source_electrical_w")[k] + column(&cols, "source_regenerated_w")[k])
        .collect();
    let peak = drawn.iter().cloned().fold(f64::MIN, f64::max);
    assert_eq!(peak, get(s, "peak_power_w"));
    let load: f64 = (column(&cols, "work_out_w").iter())
        .zip(column(&cols, "stored_load_motion_w"))
        .map(|(w, m)| (w + m).max(0.0) * 0.01)
        .sum();
    assert!((load - get(s, "load_work_j")).abs() <= 1e-9 * load);
    assert!((get(s, "efficiency") - load / get(s, "drawn_j")).abs() <= 1e-12);
    // both motors listed, within their ratings on this light rig
    let drives = doc["drives"].as_array().unwrap();
    assert_eq!(drives.len(), 2);
    for d in drives {
        assert_eq!(d["exceeds"], serde_json::json!([]), "{d}");
        assert!(get(d, "rms_torque_nm") <= get(d, "peak_torque_nm"));
        assert!(get(d, "rms_speed_rpm") <= get(d, "peak_speed_rpm"));
    }
}

/// A profile at constant velocity under a constant force, effects and noise off: over the
/// steady part each loss column is its model by hand from the recorded pressures — the
/// leakages c·Δp², the viscous friction b·v², the windings' R·(τ/k_t)² with the pumps' load
/// torques D₁(p₁ − p₂) and D₂·p₁ — and the work out is F·v.
#[test]
fn a_constant_velocity_strokes_losses_are_the_loss_models_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let rig = electric_rig(dir.path());
    let (v, force) = (0.02, 4000.0);
    std::fs::write(
        dir.path().join("stroke.csv"),
        format!("time_s,x_ref_mm,external_force_n\n0,300,{force}\n1,300,{force}\n11,500,{force}\n"),
    )
    .unwrap();
    let args = [
        "cycle",
        "--rig",
        &rig,
        "--cycle",
        "stroke.csv",
        "--no-effects",
        "--no-noise",
    ];
    let out = run::pumpcyl(
        dir.path(),
        &[&args[..], &["--json", "--out", "s.csv"]].concat(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cols = columns(&std::fs::read_to_string(dir.path().join("s.csv")).unwrap());
    let d = [8e-6, 5e-6].map(|cm3| cm3 / (2.0 * std::f64::consts::PI));
    let (c1, c2, c12) = (5.49e-11, -1.19e-11, 2.0e-10);
    let (r_ohm, kt) = (1.8, 1.4);
    let time = column(&cols, "time_s");
    let mut checked = 0;
    for (k, t) in time.iter().enumerate() {
        // steady: well after the ramp's start, before its end
        if !(8.0..10.5).contains(t) {
            continue;
        }
        let (p1, p2) = (
            column(&cols, "p1_bar")[k] * 1e5,
            column(&cols, "p2_bar")[k] * 1e5,
        );
        let leak = c1 * p1 * p1 + c2 * p2 * p2 + c12 * (p1 - p2) * (p1 - p2);
        let close = |name: &str, want: f64, tol: f64| {
            let got = column(&cols, name)[k];
            assert!(
                (got - want).abs() <= tol * want.abs(),
                "t = {t} s: {name} {got} W, by hand {want} W"
            );
        };
        close("loss_leakage_w", leak, 1e-4);
        // the velocity converges to the ramp's slowly (the P loop's tracking error settles)
        close("loss_viscous_friction_w", 250.0 * v * v, 1e-3);
        close("work_out_w", force * v, 1e-3);
        let tau = [d[0] * (p1 - p2), d[1] * p1];
        close(
            "loss_copper_w",
            r_ohm / (kt * kt) * (tau[0] * tau[0] + tau[1] * tau[1]),
            1e-3,
        );
        checked += 1;
    }
    assert!(checked > 200, "{checked} samples");
}

#[test]
fn a_motor_too_small_is_named() {
    let dir = tempfile::tempdir().unwrap();
    // the article rig's 10.6 t on steps of 40 mm with a rated torque of 0.15 N·m, which holds
    // it at rest (0.45 N·m for a moment) but not through the steps
    let out = run::pumpcyl(
        dir.path(),
        &[
            "cycle",
            "--cycle",
            "steps",
            "--step-mm",
            "40",
            "--hold-s",
            "1",
            "--set",
            "motor_rated_torque_nm=0.15",
            "--json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("motor 1 is too small for this cycle: RMS torque"),
        "{err}"
    );
    let exceeds = &doc["drives"][0]["exceeds"];
    assert!(
        exceeds.as_array().unwrap().contains(&"rms_torque".into()),
        "{exceeds}"
    );
    assert!(doc["warnings"].to_string().contains("too small"));
    assert!(err.contains("above its rated 0.15 N m"), "{err}");
    assert_eq!(doc["defaults_assumed"]["drive_efficiency"], 1.0);
}

#[test]
fn bad_cycles_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("far.csv"),
        "time_s,x_ref_mm\n0,300\n1,300\n2,9000\n",
    )
    .unwrap();
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "far.csv"],
        &["far.csv", "line 4", "x_ref_mm", "9000", "stroke_mm"],
    );
    std::fs::write(
        dir.path().join("kn.csv"),
        "time_s,x_ref_mm,external_force_n\n0,300,1e9\n1,300,0\n",
    )
    .unwrap();
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "kn.csv"],
        &["kn.csv", "line 2", "external_force_n"],
    );
    std::fs::write(
        dir.path().join("nan.csv"),
        "time_s,x_ref_mm\n0,300\n1,NaN\n",
    )
    .unwrap();
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "nan.csv"],
        &["nan.csv", "line 3", "x_ref_mm"],
    );
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "absent.csv"],
        &["absent.csv"],
    );
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "steps", "--step-mm", "5000"],
        &["--step-mm 5000", "stroke"],
    );
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "steps", "--hold-s", "0"],
        &["--hold-s 0"],
    );
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "steps", "--step-mm", "NaN"],
        &["--step-mm NaN", "finite"],
    );
    std::fs::write(
        dir.path().join("long.csv"),
        "time_s,x_ref_mm\n0,300\n1e6,300\n",
    )
    .unwrap();
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "long.csv"],
        &["--cycle long.csv", "1000000 s", "--allow-long-run"],
    );
    std::fs::write(dir.path().join("one.csv"), "time_s,x_ref_mm\n0,300\n").unwrap();
    run::refused(
        dir.path(),
        &["cycle", "--cycle", "one.csv"],
        &["one.csv", "2 samples"],
    );
    // the output never replaces the profile it read
    std::fs::write(dir.path().join("p.csv"), "time_s,x_ref_mm\n0,300\n1,300\n").unwrap();
    let before = std::fs::read(dir.path().join("p.csv")).unwrap();
    let out = run::pumpcyl(dir.path(), &["cycle", "--cycle", "p.csv", "--out", "p.csv"]);
    assert!(!out.status.success());
    assert_eq!(std::fs::read(dir.path().join("p.csv")).unwrap(), before);
}
