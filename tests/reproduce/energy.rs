//! The report's section "What each circuit costs" against the commands a user runs on the same
//! rigs: `pumpcyl rig --set …` writes each circuit's rig, `pumpcyl cycle --no-noise --rig …
//! --json` runs the article's three sines on it; the section's figures are that document's, the
//! account closes, and the DPM's saving against the valve is recomputed from the two nets. Part
//! of tests/reproduce.rs, so it shares that file's one reproduce run.

use super::{pumpcyl_stdout as pumpcyl, summary};
use serde_json::Value;
use std::path::Path;

/// `pumpcyl cycle --no-noise --json` on the rig `pumpcyl rig` writes for `circuit`'s `set`.
fn cycle(dir: &Path, k: usize, circuit: &Value) -> Value {
    let mut rig_args = vec!["rig".to_string()];
    for s in circuit["set"].as_array().unwrap() {
        rig_args.extend(["--set".to_string(), s.as_str().unwrap().to_string()]);
    }
    let rig = dir.join(format!("energy-{k}.toml"));
    std::fs::write(&rig, pumpcyl(&rig_args)).unwrap();
    let args = [
        "cycle",
        "--no-noise",
        "--json",
        "--rig",
        rig.to_str().unwrap(),
    ];
    let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    serde_json::from_slice(&pumpcyl(&args)).unwrap()
}

fn close(what: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs().max(1e-9),
        "{what}: the section says {want}, the command gives {got}"
    );
}

#[test]
fn the_energy_section_holds_the_cycle_commands_numbers() {
    let s = summary();
    let e = &s["energy"];
    let circuits = e["circuits"].as_array().unwrap();
    let kinds: Vec<&str> = circuits
        .iter()
        .map(|c| c["circuit"].as_str().unwrap())
        .collect();
    assert_eq!(
        kinds,
        ["dpm", "dual-pump", "dual-pump", "single-pump", "valve"],
        "the Figure 1 circuits and the valve"
    );
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("reproduce-energy");
    std::fs::create_dir_all(&dir).unwrap();
    for (k, c) in circuits.iter().enumerate() {
        let label = c["label"].as_str().unwrap();
        let doc = cycle(&dir, k, c);
        for key in [
            "drawn_j",
            "net_j",
            "load_work_j",
            "peak_power_w",
            "losses_j",
        ] {
            let (got, want) = (doc["summary"][key].as_f64(), c["summary"][key].as_f64());
            close(&format!("{label} {key}"), got.unwrap(), want.unwrap(), 1e-9);
        }
        let losses = doc["energy"]["losses_j"].as_object().unwrap();
        for (kind, want) in c["losses_j"].as_object().unwrap() {
            let got = losses[kind].as_f64().unwrap();
            close(
                &format!("{label} {kind}"),
                got,
                want.as_f64().unwrap(),
                1e-9,
            );
        }
        // the account closes: drawn less returned = work + losses + stored change
        let sm = &c["summary"];
        let f = |k: &str| sm[k].as_f64().unwrap();
        let imbalance = f("net_j") - f("work_out_j") - f("losses_j") - f("stored_change_j");
        assert!(
            imbalance.abs() <= 1e-6 * f("drawn_j"),
            "{label}: {imbalance} J"
        );
        assert_eq!(doc["defaults_assumed"], c["defaults_assumed"], "{label}");
        // the largest error, recomputed from the command's own record (written to 1e-6 mm)
        let csv = dir.join(format!("energy-{k}.csv"));
        let rig = dir.join(format!("energy-{k}.toml"));
        let args = [
            "cycle",
            "--no-noise",
            "--rig",
            rig.to_str().unwrap(),
            "--out",
            csv.to_str().unwrap(),
        ];
        pumpcyl(&args.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        let text = std::fs::read_to_string(&csv).unwrap();
        let mut lines = text.lines();
        let names: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |n: &str| names.iter().position(|c| *c == n).unwrap();
        let (r, x) = (col("x_ref_mm"), col("x_mm"));
        let max_error = lines
            .map(|l| {
                l.split(',')
                    .map(|v| v.parse::<f64>().unwrap())
                    .collect::<Vec<_>>()
            })
            .map(|v| (v[r] - v[x]).abs())
            .fold(0.0, f64::max);
        close(
            &format!("{label} max |e|"),
            max_error,
            c["max_error_mm"].as_f64().unwrap(),
            1e-6,
        );
    }
    // the valve's own loss is its throttling, the pumps' their leakage and braking
    let valve = &circuits[4]["losses_j"];
    assert!(
        valve["valve_throttling"].as_f64().unwrap()
            > 0.9 * circuits[4]["summary"]["losses_j"].as_f64().unwrap()
    );
    let net = |c: &Value| c["summary"]["net_j"].as_f64().unwrap();
    let saving = 1.0 - net(&circuits[0]) / net(&circuits[4]);
    close(
        "saving",
        e["dpm_saves_vs_valve_fraction"].as_f64().unwrap(),
        saving,
        1e-12,
    );
    // the report names the saving and the published one beside it
    let (folder, _) = super::reproduced();
    let html = std::fs::read_to_string(folder.join("report.html")).unwrap();
    assert!(
        html.contains(&format!("{:.0} % less", 100.0 * saving)),
        "saving in the report"
    );
    assert!(
        html.contains("Padovani et al. "),
        "the published saving beside it"
    );
}
