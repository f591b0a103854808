//! The report's section "The article's Figure 1 circuits on its own application" against the
//! commands a user runs on the same rigs: `pumpcyl margins --json` for the margins (per mode
//! for the single pump), `pumpcyl rig` and `pumpcyl emulate --no-noise` for the emulated step
//! and the article's three sinusoids, whose numbers this file measures from the records itself.
//! Part of tests/reproduce.rs, so it shares that file's one reproduce run.

use super::{reproduced, summary};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// `pumpcyl ARGS`, its standard output as text.
fn pumpcyl(args: &[String]) -> String {
    String::from_utf8(super::pumpcyl_stdout(args)).unwrap()
}

/// `--set` options of a circuit's assignments.
fn sets(circuit: &Value) -> Vec<String> {
    (circuit["set"].as_array().unwrap().iter())
        .flat_map(|s| ["--set".to_string(), s.as_str().unwrap().to_string()])
        .collect()
}

/// A record's columns by name.
fn read_csv(path: &Path) -> std::collections::HashMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let names: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let mut cols = vec![Vec::new(); names.len()];
    for line in lines {
        for (c, v) in cols.iter_mut().zip(line.split(',')) {
            c.push(v.parse::<f64>().unwrap());
        }
    }
    names.into_iter().zip(cols).collect()
}

fn close(what: &str, got: f64, want: f64, tol: f64) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: the section says {want}, the command gives {got}"
    );
}

/// The emulated record of `extra` on the rig made of `circuit`'s assignments, written by
/// `pumpcyl rig` to a file that `pumpcyl emulate --rig` reads, as a user would.
fn emulate(dir: &Path, name: &str, circuit: &Value, extra: &[&str]) -> PathBuf {
    let rig = dir.join(format!("{name}.toml"));
    std::fs::write(
        &rig,
        pumpcyl(&[vec!["rig".to_string()], sets(circuit)].concat()),
    )
    .unwrap();
    let out = dir.join(format!("{name}.csv"));
    let mut args: Vec<String> = ["emulate", "--no-noise", "--rig"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    args.push(rig.display().to_string());
    args.extend(extra.iter().map(|s| s.to_string()));
    args.extend(["--out".to_string(), out.display().to_string()]);
    pumpcyl(&args);
    out
}

/// Changes of the `mode` column from sample `from` on.
fn mode_changes(mode: &[f64], from: usize) -> usize {
    mode[from..].windows(2).filter(|w| w[0] != w[1]).count()
}

/// The 10–90 % rise time (s) and the overshoot (% of the step) of the position about its
/// value before the step at `at_s`, computed here from the record.
fn rise_and_overshoot(t: &[f64], x: &[f64], at_s: f64, step_mm: f64) -> (f64, f64) {
    let k0 = t.iter().position(|&v| v >= at_s - 1e-9).unwrap();
    let y: Vec<f64> = x[k0..].iter().map(|v| (v - x[k0 - 1]) / step_mm).collect();
    let ts = &t[k0..];
    let cross = |level: f64| {
        let k = (1..y.len()).find(|&k| y[k] >= level).unwrap();
        ts[k - 1] + (level - y[k - 1]) / (y[k] - y[k - 1]) * (ts[k] - ts[k - 1])
    };
    let peak = y.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    (cross(0.9) - cross(0.1), 100.0 * (peak - 1.0).max(0.0))
}

/// One circuit's margins against `pumpcyl margins --json`, its modes' for the single pump.
fn check_margins(c: &Value, single: &Value) {
    let label = c["label"].as_str().unwrap();
    let doc: Value = serde_json::from_str(&pumpcyl(
        &[vec!["margins".to_string(), "--json".to_string()], sets(c)].concat(),
    ))
    .unwrap();
    for key in ["gain_margin_db", "phase_margin_deg"] {
        let want = c["margins"][key].as_f64().unwrap();
        close(
            &format!("{label} {key}"),
            doc[key].as_f64().unwrap(),
            want,
            1e-9 * want.abs(),
        );
    }
    if c["circuit"] == "single-pump" {
        let modes = doc["modes"].as_array().unwrap();
        assert_eq!(modes.len(), 2);
        for (m, ours) in modes.iter().zip(c["modes"].as_array().unwrap()) {
            assert_eq!(m["mode"], ours["mode"]);
            assert_eq!(m["at_rest"], ours["at_rest"]);
            let (g, w) = (
                m["gain_margin_db"].as_f64(),
                ours["margins"]["gain_margin_db"].as_f64(),
            );
            close("mode GM", g.unwrap(), w.unwrap(), 1e-9);
        }
        let f_s = single["switching_force_n"].as_f64().unwrap();
        close(
            "switching force",
            doc["switching_force_n"].as_f64().unwrap(),
            f_s,
            1e-6,
        );
    } else {
        assert!(c["modes"].as_array().unwrap().is_empty());
    }
}

/// One circuit's emulated step and sinusoids against `pumpcyl emulate`'s records.
fn check_records(dir: &Path, k: usize, c: &Value) {
    let label = c["label"].as_str().unwrap();
    let step = read_csv(&emulate(
        dir,
        &format!("step{k}"),
        c,
        &["--experiment", "step", "--duration-s", "15.5"],
    ));
    let rest = [step["p1_bar"][0], step["p2_bar"][0]];
    for (i, p) in rest.iter().enumerate() {
        let want = c["rest_pressures_bar"][i].as_f64().unwrap();
        close(&format!("{label} rest pressure {}", i + 1), *p, want, 1e-5);
    }
    let rest_error = step["x_ref_mm"][0] - step["x_mm"][0];
    let want = c["rest_error_mm"].as_f64().unwrap();
    close(&format!("{label} rest error"), rest_error, want, 2e-6);
    let (rise, overshoot) = rise_and_overshoot(&step["time_s"], &step["x_mm"], 0.5, 5.0);
    close(
        &format!("{label} rise"),
        rise,
        c["step"]["rise_time_s"].as_f64().unwrap(),
        1e-3,
    );
    let pct = c["step"]["overshoot_pct"].as_f64().unwrap();
    close(&format!("{label} overshoot"), overshoot, pct, 0.01);
    if let Some(mode) = step.get("mode") {
        assert_eq!(
            Some(mode_changes(mode, 0) as u64),
            c["step_mode_changes"].as_u64()
        );
    }
    for (j, w) in c["tracking"].as_array().unwrap().iter().enumerate() {
        let (f, a, len) = (
            w["freq_hz"].as_f64().unwrap(),
            w["amplitude_mm"].as_f64().unwrap(),
            w["record_s"].as_f64().unwrap(),
        );
        let extra = [
            "--experiment".to_string(),
            "sine".into(),
            "--at-s".into(),
            "1".into(),
            "--freq-hz".into(),
            f.to_string(),
            "--amplitude-mm".into(),
            a.to_string(),
            "--duration-s".into(),
            len.to_string(),
        ];
        let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
        let r = read_csv(&emulate(dir, &format!("sine{k}-{j}"), c, &extra));
        // the last two whole periods
        let from = r["time_s"]
            .iter()
            .position(|&t| t >= len - 2.0 / f - 1e-9)
            .unwrap();
        let max_e = (from..r["time_s"].len())
            .map(|i| (r["x_ref_mm"][i] - r["x_mm"][i]).abs())
            .fold(0.0, f64::max);
        let want = w["max_error_mm"].as_f64().unwrap();
        close(&format!("{label} {f} Hz max error"), max_e, want, 2e-6);
        if let Some(mode) = r.get("mode") {
            assert_eq!(
                Some(mode_changes(mode, 0) as u64),
                w["mode_changes"].as_u64()
            );
            let last = w["mode_changes_last_two_periods"].as_u64();
            assert_eq!(Some(mode_changes(mode, from) as u64), last);
        }
    }
}

/// The value of `key` in a rig file written by `pumpcyl rig`.
fn rig_value(rig_toml: &str, key: &str) -> f64 {
    let line = (rig_toml.lines())
        .find(|l| l.starts_with(&format!("{key} = ")))
        .unwrap_or_else(|| panic!("no {key}"));
    line.split('=')
        .nth(1)
        .unwrap()
        .split('#')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

/// Mode switches in a single-pump record, counted from its chamber pressures as
/// docs/circuits.md#will-it-chatter defines them: each check valve's opening signal
/// (p_acc − p_i) + k (p_other − p_acc); the mode is the chamber whose valve is open (signal above
/// the cracking pressure), the larger if both, none while both are shut; a switch is the mode
/// moving from one chamber to the other. Returns (all switches, those at or after `from_s`).
fn switches(
    r: &std::collections::HashMap<String, Vec<f64>>,
    rig_toml: &str,
    from_s: f64,
) -> (usize, usize) {
    let p_acc = rig_value(rig_toml, "accumulator_precharge_bar");
    let k = rig_value(rig_toml, "pilot_ratio");
    let crack = rig_value(rig_toml, "check_valve_crack_bar");
    let (mut last, mut all, mut after) = (None, 0, 0);
    let samples = r["time_s"].iter().zip(&r["p1_bar"]).zip(&r["p2_bar"]);
    for ((&t, &p1), &p2) in samples {
        let s1 = (p_acc - p1) + k * (p2 - p_acc);
        let s2 = (p_acc - p2) + k * (p1 - p_acc);
        let mode = if s1.max(s2) <= crack {
            continue;
        } else if s2 >= s1 {
            1
        } else {
            2
        };
        if last.is_some_and(|l| l != mode) {
            all += 1;
            after += usize::from(t >= from_s - 1e-9);
        }
        last = Some(mode);
    }
    (all, after)
}

/// The chatter prediction against records of `pumpcyl emulate`: the step at zero external
/// force run as the prediction runs it (at rest at x0 for 1 s, then 5 mm up) and the three
/// sines switch as often, in all and after settling; at the last quiet force of each quiet
/// range the step never switches, at the scanned force beyond it, it does.
fn check_chatter(dir: &Path, single: &Value, chatter: &Value) {
    let rig_toml = pumpcyl(&[vec!["rig".to_string()], sets(single)].concat());
    let step = |name: &str, force: f64, seconds: f64| {
        let mut c = single.clone();
        c["set"]
            .as_array_mut()
            .unwrap()
            .push(Value::from(format!("external_force_n={force}")));
        let (from, to, len) = ("345".to_string(), "350".to_string(), seconds.to_string());
        read_csv(&emulate(
            dir,
            name,
            &c,
            &[
                "--experiment",
                "step",
                "--from-mm",
                &from,
                "--to-mm",
                &to,
                "--at-s",
                "1",
                "--duration-s",
                &len,
            ],
        ))
    };
    let zero = &chatter["step"];
    let settled = zero["settled_at_s"].as_f64().unwrap();
    let r = step(
        "chatter-step",
        0.0,
        settled + zero["watched_s"].as_f64().unwrap(),
    );
    let counted = switches(&r, &rig_toml, settled);
    assert_eq!(counted.0 as u64, zero["switches"].as_u64().unwrap());
    assert_eq!(
        counted.1 as u64,
        zero["switches_after_settling"].as_u64().unwrap()
    );
    let waves = single["tracking"].as_array().unwrap().iter();
    for (k, (w, ours)) in waves.zip(chatter["sines"].as_array().unwrap()).enumerate() {
        // the single pump's sine records of check_records, the fourth circuit's
        let f = w["freq_hz"].as_f64().unwrap();
        let r = read_csv(&dir.join(format!("sine3-{k}.csv")));
        let counted = switches(&r, &rig_toml, ours["settled_at_s"].as_f64().unwrap());
        assert_eq!(
            counted.0 as u64,
            ours["switches"].as_u64().unwrap(),
            "{f} Hz"
        );
        assert_eq!(
            counted.1 as u64,
            ours["switches_after_settling"].as_u64().unwrap(),
            "{f} Hz"
        );
    }
    let ranges = chatter["quiet_ranges_n"].as_array().unwrap();
    assert!(!ranges.is_empty(), "no quiet range: {chatter}");
    let scan: Vec<f64> = (chatter["scan"].as_array().unwrap().iter())
        .map(|r| r["external_force_n"].as_f64().unwrap())
        .collect();
    let run = |name: &str, force: f64| switches(&step(name, force, 22.0), &rig_toml, 0.0).0;
    let lo_quiet = ranges[0][1].as_f64().unwrap();
    let beyond = scan.iter().find(|&&f| f > lo_quiet).copied().unwrap();
    assert_eq!(run("quiet-lo", lo_quiet), 0, "{lo_quiet} N is quiet");
    assert!(run("switching-lo", beyond) > 0, "{beyond} N switches");
    let hi_quiet = ranges.last().unwrap()[0].as_f64().unwrap();
    let before = scan.iter().rev().find(|&&f| f < hi_quiet).copied().unwrap();
    assert_eq!(run("quiet-hi", hi_quiet), 0, "{hi_quiet} N is quiet");
    assert!(run("switching-hi", before) > 0, "{before} N switches");
}

#[test]
fn the_figure1_section_holds_the_commands_numbers() {
    let s = summary();
    let section = &s["figure1_circuits"];
    let circuits = section["circuits"].as_array().unwrap();
    let kinds: Vec<&str> = circuits
        .iter()
        .map(|c| c["circuit"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["dpm", "dual-pump", "dual-pump", "single-pump"]);
    let chatter = &section["single_pump_chatter"];
    let single = &circuits[3];
    // the one-motor circuits' linear models rest at the DPM's rest pressures: the single pump's
    // pre-charge is the DPM's p1 with no load, 10 bar × A2/(A1 + A2)
    let (a1, a2) = (63.0f64.powi(2), 63.0f64.powi(2) - 36.0f64.powi(2));
    let p_acc = single["accumulator_precharge_bar"].as_f64().unwrap();
    close("pre-charge", p_acc, 10.0 * a2 / (a1 + a2), 1e-12);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("reproduce-figure1");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::thread::scope(|scope| {
        for (k, c) in circuits.iter().enumerate() {
            let dir = &dir;
            scope.spawn(move || {
                check_margins(c, chatter);
                check_records(dir, k, c);
            });
        }
    });
    // after the single pump's sine records are written
    check_chatter(&dir, single, chatter);
    // the verdict follows from its runs: a step switching after settling or a sine more than
    // twice a period would be chatter
    let runs = std::iter::once(&chatter["step"]).chain(chatter["sines"].as_array().unwrap());
    let any = runs.clone().any(|r| r["chatters"] == true);
    assert_eq!(chatter["chatters"], any);
    for r in runs {
        assert!(r["switches_after_settling"].as_u64() <= r["switches"].as_u64());
    }
    // the section is in the report, marked as pumpcyl's own study answering §2.1 and §4
    let html = std::fs::read_to_string(reproduced().0.join("report.html")).unwrap();
    assert!(
        html.contains("The article&#39;s Figure 1 circuits on its own application")
            || html.contains("The article's Figure 1 circuits on its own application")
    );
    assert!(html.contains("pumpcyl's own study") || html.contains("pumpcyl&#39;s own study"));
}
