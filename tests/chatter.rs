//! `pumpcyl chatter` (docs/circuits.md#a-scan-of-the-load) on a single-pump rig that is not the
//! article's: a 50/28 mm cylinder carrying 600 kg, a 2.5 cm³/rev pump, a 2 bar pre-charge.
//! Its switching force is p_acc (A1 − A2) computed here by hand; at each force the command's
//! runs are those of the library's emulator called directly (`chatter::scan_forces` for the
//! step, `chatter::sine` for the wave); forces far from the switching force are quiet while
//! the wave at the switching force switches more often than its reference explains; the JSON
//! keys, the CSV and the refusals of bad input.

use pumpcyl::emulator::chatter;
use pumpcyl::emulator::Effects;
use pumpcyl::rig::Rig;
use serde_json::Value;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// The rig: 50/28 mm, 300 mm stroke, 600 kg without a mass table, one 2.5 cm³/rev pump, a
/// 2 bar pre-charge, β 120 bar, its own friction and leakages; the check valves' defaults
/// (0.5 bar cracking, pilot ratio 3).
const RIG: &str = "\
circuit = \"single-pump\"
piston_diameter_mm = 50.0
rod_diameter_mm = 28.0
stroke_mm = 300.0
x0_mm = 150.0
mass_kg = 600.0
mass_by_position = []
displacement_1_cm3_per_rev = 2.5
accumulator_precharge_bar = 2.0
beta_bar = 120.0
kp = 25.0
viscous_friction_ns_per_m = 300.0
c12_m5_per_ns = 5.0e-11
c1_m5_per_ns = 2.0e-11
c2_m5_per_ns = 2.0e-11
line_volume_1_dm3 = 0.05
line_volume_2_dm3 = 0.05
";

/// The rig file in a fresh folder.
fn rig_file() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("rig.toml");
    std::fs::write(&file, RIG).unwrap();
    (dir, file)
}

/// Piston and annulus areas (m²) and the switching force p_acc (A1 − A2) (N), by hand.
fn by_hand() -> (f64, f64, f64) {
    let a1 = PI / 4.0 * 0.05f64.powi(2);
    let a2 = a1 - PI / 4.0 * 0.028f64.powi(2);
    (a1, a2, 2.0e5 * (a1 - a2))
}

/// `pumpcyl chatter --json` on the rig file with `args`.
fn chatter_json(file: &Path, args: &[&str]) -> Value {
    let mut all = vec!["chatter", "--json", "--rig", file.to_str().unwrap()];
    all.extend(args);
    run::json(Path::new("."), &all)
}

/// The keys of a JSON object, sorted.
fn keys_of(v: &Value) -> Vec<&str> {
    v.as_object().unwrap().keys().map(String::as_str).collect()
}

fn close(got: &Value, want: f64, what: &str) {
    let got = got.as_f64().unwrap_or_else(|| panic!("{what}: {got}"));
    assert!(
        (got - want).abs() <= 1e-9 * want.abs().max(1.0),
        "{what}: {got} vs {want}"
    );
}

/// The switching force is p_acc (A1 − A2) and the valve band [F_s − A1 Δp_crack,
/// F_s + A2 Δp_crack]; at 300 N below and 480 N above it (beyond the band and the 0.2 Hz
/// ±35 mm wave's needed-force swing, A ω √(m² ω² + b²) = 35.7 N) neither the step nor the wave
/// switches; at the switching force the wave's needed force crosses it twice a period (4 in the
/// two watched periods) and the loop switches more often than that: it chatters. Every run is
/// the library's emulator run at that force, number for number.
#[test]
fn only_the_switching_force_chatters_and_every_run_is_the_librarys() {
    let (_dir, file) = rig_file();
    let (a1, a2, f_s) = by_hand();
    assert!((f_s - 123.15).abs() < 0.01, "{f_s}");
    let forces = [f_s - 300.0, f_s, f_s + 480.0];
    let texts: Vec<String> = forces.iter().map(|f| f.to_string()).collect();
    let mut args = vec!["--wave", "0.2:35"];
    for t in &texts {
        args.extend(["--force-n", t.as_str()]);
    }
    let doc = chatter_json(&file, &args);
    close(&doc["switching_force_n"], f_s, "switching force");
    close(&doc["valve_band_n"][0], f_s - a1 * 0.5e5, "band, low edge");
    close(&doc["valve_band_n"][1], f_s + a2 * 0.5e5, "band, high edge");
    assert_eq!(doc["circuit"], "single-pump");
    assert_eq!(
        doc["mode_at_rest"], 2,
        "no load rests below F_s: chamber 1 on the accumulator"
    );

    let rig = Rig::from_file(&file).unwrap();
    let steps = chatter::scan_forces(&rig, &forces).unwrap();
    let scanned = doc["forces"].as_array().unwrap();
    assert_eq!(scanned.len(), 3);
    for ((got, f), step) in scanned.iter().zip(forces).zip(&steps) {
        assert_eq!(got["external_force_n"], f);
        assert_eq!(got["step"], serde_json::to_value(step).unwrap(), "{f} N");
        let loaded = Rig {
            external_force_n: f,
            ..rig.clone()
        };
        let wave = chatter::sine(&loaded, Effects::for_rig(&loaded).unwrap(), 0.2, 35.0).unwrap();
        assert_eq!(
            got["waves"][0],
            serde_json::to_value(&wave).unwrap(),
            "{f} N"
        );
        let sum = step.switches + wave.switches;
        assert_eq!(got["switches"], sum, "{f} N");
        let extra = step.switches_after_settling
            + wave
                .switches_after_settling
                .saturating_sub(wave.switches_explained);
        assert_eq!(got["extra_switches"], extra, "{f} N");
    }
    // far from the switching force: nothing switches, in the mode its side says
    for (got, mode) in [(&scanned[0], 2), (&scanned[2], 1)] {
        assert_eq!(got["verdict"], "quiet", "{got}");
        assert_eq!(got["switches"], 0, "{got}");
        assert_eq!(got["mode_at_start"], mode, "{got}");
        assert_eq!(got["switches_explained"], 0, "{got}");
    }
    // at it: the reference explains two switches a period, the loop makes more
    let at = &scanned[1];
    let wave = &at["waves"][0];
    assert_eq!(wave["switches_explained"], 4, "{at}");
    let watched = wave["switches_after_settling"].as_u64().unwrap();
    assert!(watched > 4, "{at}");
    assert_eq!(at["extra_switches"], watched - 4);
    assert_eq!(
        (at["verdict"].as_str(), wave["chatters"].as_bool()),
        (Some("chatters"), Some(true))
    );
    assert_eq!(doc["verdict"], "chatters");
    let fmt = |a: f64| serde_json::json!([a, a]);
    assert_eq!(doc["chattering_ranges_n"], serde_json::json!([fmt(f_s)]));
    assert_eq!(
        doc["quiet_ranges_n"],
        serde_json::json!([fmt(forces[0]), fmt(forces[2])])
    );
    assert!(
        doc["answer"]
            .as_str()
            .unwrap()
            .starts_with(&format!("chatters at {f_s:.1} N: ")),
        "{}",
        doc["answer"]
    );
}

/// Without forces the scan runs 13 about the switching force: the switching force itself, the
/// valve band's edges, and each side six forces half the band's reach on that side apart, out
/// to three times that reach; its steps are the library's scan of the same forces, and the
/// document has exactly its keys.
#[test]
fn the_default_scan_spans_the_valve_band_and_the_document_has_its_keys() {
    let (_dir, file) = rig_file();
    let (a1, a2, f_s) = by_hand();
    let doc = chatter_json(&file, &[]);
    // the keys of the document (and the rig file's defaulted keys the command line adds to
    // every document with a `rig`); serde_json reads them sorted
    let mut want = [
        "rig",
        "circuit",
        "verdict",
        "answer",
        "switching_force_n",
        "valve_band_n",
        "external_force_n",
        "mode_at_rest",
        "step_mm",
        "waves",
        "forces",
        "quiet_ranges_n",
        "chattering_ranges_n",
        "basis",
        "rig_defaulted_keys",
    ];
    want.sort_unstable();
    assert_eq!(keys_of(&doc), want);
    let scanned = doc["forces"].as_array().unwrap();
    assert_eq!(scanned.len(), chatter::DEFAULT_POINTS);
    let (below, above) = (a1 * 0.5e5, a2 * 0.5e5);
    for (k, f) in scanned.iter().enumerate() {
        let want = if k <= 6 {
            f_s - below * 0.5 * (6 - k) as f64
        } else {
            f_s + above * 0.5 * (k - 6) as f64
        };
        close(&f["external_force_n"], want, &format!("force {k}"));
        let mut want = [
            "external_force_n",
            "mode_at_start",
            "verdict",
            "switches",
            "switches_after_settling",
            "switches_explained",
            "extra_switches",
            "step",
            "waves",
        ];
        want.sort_unstable();
        assert_eq!(keys_of(f), want);
    }
    assert_eq!(scanned[6]["external_force_n"], doc["switching_force_n"]);
    let forces: Vec<f64> = scanned
        .iter()
        .map(|f| f["external_force_n"].as_f64().unwrap())
        .collect();
    let rig = Rig::from_file(&file).unwrap();
    for (got, step) in scanned
        .iter()
        .zip(chatter::scan_forces(&rig, &forces).unwrap())
    {
        assert_eq!(got["step"], serde_json::to_value(&step).unwrap());
    }
    // the 600 kg step's transient never reaches the band's edges: nothing switches
    assert_eq!(doc["verdict"], "quiet", "{}", doc["answer"]);
    assert_eq!(
        doc["quiet_ranges_n"],
        serde_json::json!([[forces[0], forces[12]]])
    );
}

/// The CSV holds one row a run at a force, the figure renders; a circuit without modes gets a
/// one-line answer from its own description and runs nothing.
#[test]
fn outputs_and_circuits_without_modes() {
    let (dir, file) = rig_file();
    let csv = dir.path().join("scan.csv");
    let svg = dir.path().join("scan.svg");
    for out in [&csv, &svg] {
        let o = run::pumpcyl(
            Path::new("."),
            &[
                "chatter",
                "--rig",
                file.to_str().unwrap(),
                "--force-n",
                "0",
                "--force-n",
                "400",
                "--wave",
                "0.25:20",
                "--out",
                out.to_str().unwrap(),
            ],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "external_force_n,run,mode_at_start,switches,switches_after_settling,\
         switches_explained,extra_switches,error_amplitude_mm,chatters,verdict"
    );
    assert_eq!(lines.len(), 1 + 2 * 2, "{text}");
    assert!(
        lines[1].starts_with("0.000000,5 mm step,2,0,0,0,0,"),
        "{text}"
    );
    assert!(
        lines[4].starts_with("400.000000,\"sine 0.25 Hz, 20 mm\",1,"),
        "{text}"
    );
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));

    for set in ["circuit=dpm", "circuit=dual-pump"] {
        let o = run::pumpcyl(Path::new("."), &["chatter", "--set", set]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout);
        assert_eq!(out.lines().count(), 1, "{out}");
        assert!(
            out.contains("no modes to switch between, so it cannot chatter: ")
                && out.contains("no valve moves a chamber onto the accumulator"),
            "{out}"
        );
        let doc = run::json(Path::new("."), &["chatter", "--set", set, "--json"]);
        assert_eq!(doc["verdict"], "no_modes");
        assert_eq!(doc["forces"], serde_json::json!([]));
        assert_eq!(doc["switching_force_n"], Value::Null);
    }
}

/// Bad input is one line naming the option, file, line or key, exit 1, and no output file; a
/// scan beyond the work limit is refused before it runs, naming --allow-long-run.
#[test]
fn bad_input_is_refused_in_one_line_and_writes_nothing() {
    let (dir, file) = rig_file();
    let rig = file.to_str().unwrap();
    let out = dir.path().join("scan.csv");
    let out_arg = out.to_str().unwrap();
    let cases: [(&[&str], &[&str]); 5] = [
        (
            &["--force-n", "2e9"],
            &["--force-n 2000000000", "external_force_n", "physical range"],
        ),
        (
            &["--wave", "0.2:200"],
            &["--wave 0.2:200", "outside the stroke"],
        ),
        (&["--from-n", "100", "--to-n", "0"], &["--to-n 0", "from_n"]),
        (
            &["--force-n", "0", "--points", "3"],
            &["--points", "--force-n"],
        ),
        (
            &["--from-n", "0", "--to-n", "200", "--points", "20000"],
            &["emulated controller steps", "--allow-long-run"],
        ),
    ];
    for (args, words) in cases {
        let mut all = vec!["chatter", "--rig", rig, "--out", out_arg];
        all.extend(args);
        let o = run::pumpcyl(Path::new("."), &all);
        let err = String::from_utf8_lossy(&o.stderr);
        // clap's own refusals (conflicting options) exit 2 with a usage block
        if args.contains(&"--points") && args.contains(&"--force-n") {
            assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
            assert!(
                err.contains("--points") && err.contains("--force-n"),
                "{err}"
            );
        } else {
            run::refused(Path::new("."), &all, words);
        }
        assert!(!out.exists(), "{args:?} left {}", out.display());
    }
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, RIG.replace("mass_kg = 600.0", "mass_kg = -600.0")).unwrap();
    run::refused(
        Path::new("."),
        &["chatter", "--rig", bad.to_str().unwrap()],
        &["bad.toml", "line 6", "key `mass_kg` = -600", "must be > 0"],
    );
}
