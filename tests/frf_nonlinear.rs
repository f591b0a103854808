//! A sweep that leaves the linear model's reach is designed against and reported
//! (docs/identification.md#designing-the-sweep, #non-linear-distortion): the designer bounds
//! the amplitude by the chambers' pressure band, `frf` detects non-linear distortion at a
//! multisine's non-excited lines and pressures at the cavitation floor, the designed multisine
//! resolves the resonance, a record made with the designer's defaults reads back with them, and
//! the model drawn beside a one-motor record says which rest it is the model of.

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

#[path = "common/cavitating.rs"]
mod cavitating;

use pumpcyl::frf::{Excitation, SweepKind, SweepSpec};
use pumpcyl::lti::{eigenvalues, resonance};
use pumpcyl::model::Plant;
use pumpcyl::rig::Rig;
use std::path::{Path, PathBuf};

fn user_rig_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/user-rig.toml")
}

/// A column of a record's CSV.
fn column(path: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header.iter().position(|h| *h == name).unwrap();
    lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect()
}

/// `pumpcyl emulate --experiment multisine --out NAME ARGS --json` in `dir`: its warnings.
fn emulate(dir: &Path, name: &str, args: &[&str]) -> Vec<String> {
    let mut all = vec![
        "emulate",
        "--experiment",
        "multisine",
        "--out",
        name,
        "--json",
    ];
    all.extend_from_slice(args);
    let v = run::json(dir, &all);
    (v["warnings"].as_array().unwrap().iter())
        .map(|w| w.as_str().unwrap().to_string())
        .collect()
}

fn floor_warned(warnings: &[String]) -> bool {
    warnings.iter().any(|w| w.contains("cavitation floor"))
}

#[test]
fn the_designed_multisine_keeps_the_chambers_above_the_cavitation_floor() {
    // the article's rig at beta 250 bar, where the design bound by the motors' speed alone
    // (15.0 mm) drove chamber 1 to -1 bar, and the user rig (80/45 mm) at beta 800 bar and a
    // 7 bar sum pressure, where it (60.7 mm) did too; every emulator effect on, no noise
    let dir = tempfile::tempdir().unwrap();
    let user = user_rig_path();
    let user = user.to_str().unwrap();
    let stiff_user = [
        "--rig",
        user,
        "--set",
        "beta_bar=800",
        "--set",
        "p_sum_ref_bar=7",
    ];
    for (label, rig) in [
        ("beta 250", &["--set", "beta_bar=250"][..]),
        ("user rig", &stiff_user[..]),
    ] {
        let d = run::json(dir.path(), &[&["frf", "--design", "--json"], rig].concat());
        let bound = d["amplitude_bound"].as_str().unwrap();
        let warnings = emulate(dir.path(), "ms.csv", &[rig, &["--no-noise"]].concat());
        assert!(!floor_warned(&warnings), "{label}: {warnings:?}");
        // the design lets chamber 1 take two thirds of the room from its rest to the floor:
        // the record's lowest p1 lies that far below its rest, as its first sample shows it
        let p1 = column(&dir.path().join("ms.csv"), "p1_bar");
        let lowest = p1.iter().cloned().fold(f64::INFINITY, f64::min);
        let aimed = p1[0] - 2.0 / 3.0 * (p1[0] + 1.0);
        eprintln!(
            "{label}: {bound}; rest {:.3}, lowest {lowest:.3}, aimed at {aimed:.3} bar",
            p1[0]
        );
        assert!(bound.starts_with("p1"), "{label}: {bound}");
        assert!(
            (lowest - aimed).abs() < 0.3,
            "{label}: {lowest} against {aimed}"
        );
    }
}

/// `pumpcyl frf REC --json ARGS` in `dir`.
fn frf_json(dir: &Path, rec: &str, args: &[&str]) -> serde_json::Value {
    run::json(dir, &[&["frf", rec, "--json"], args].concat())
}

#[test]
fn a_multisine_that_cavitates_is_reported_as_distorted_and_at_the_floor() {
    // the speed-bound design on the article rig at beta 250 bar: 15 mm, 0.195 … 2.456 Hz,
    // period 1/0.195 s (13 lines), 24 periods; the sensors' noise on
    let dir = tempfile::tempdir().unwrap();
    let sweep = [&cavitating::MULTISINE[..], &["--set", "beta_bar=250"]].concat();
    assert!(floor_warned(&emulate(dir.path(), "cav.csv", &sweep)));
    let at_floor = |p: &[f64]| p.iter().filter(|&&v| v <= -1.0 + 1e-3).count();
    let p1 = column(&dir.path().join("cav.csv"), "p1_bar");
    assert!(at_floor(&p1) > 100, "{}", at_floor(&p1));
    let v = frf_json(
        dir.path(),
        "cav.csv",
        &[&["--sweep", "multisine"], &sweep[..]].concat(),
    );
    let d = &v["distortion"];
    let above = d["non_excited_db_above_noise"].as_f64().unwrap();
    let threshold = d["threshold_db"].as_f64().unwrap();
    eprintln!("cavitating: {d}");
    assert!(
        d["warned"].as_bool().unwrap() && above > threshold + 10.0,
        "{d}"
    );
    let warnings: Vec<&str> = (v["warnings"].as_array().unwrap().iter())
        .map(|w| w.as_str().unwrap())
        .collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.starts_with("non-linear distortion")),
        "{warnings:?}"
    );
    let floor = warnings
        .iter()
        .find(|w| w.contains("cavitation floor"))
        .unwrap();
    assert!(floor.contains("chamber 1 in "), "{floor}");
}

#[test]
fn a_small_multisine_of_the_linear_loop_shows_no_distortion() {
    // every effect off, 2 mm on the user rig, the sensors' noise on: the detection lines hold
    // noise only, their level within the threshold of a 0.001 false alarm
    let dir = tempfile::tempdir().unwrap();
    let user = user_rig_path();
    let sweep = [
        "--rig",
        user.to_str().unwrap(),
        "--amplitude-mm",
        "2",
        "--from-hz",
        "0.1",
        "--to-hz",
        "3",
        "--periods",
        "12",
    ];
    emulate(
        dir.path(),
        "lin.csv",
        &[&sweep[..], &["--no-effects"]].concat(),
    );
    let v = frf_json(
        dir.path(),
        "lin.csv",
        &[&["--sweep", "multisine"], &sweep[..]].concat(),
    );
    let d = &v["distortion"];
    eprintln!("{d}");
    assert!(!d["warned"].as_bool().unwrap(), "{d}");
    let above = d["non_excited_db_above_noise"].as_f64().unwrap();
    assert!(above.abs() < d["threshold_db"].as_f64().unwrap(), "{d}");
    assert!(d["lines"].as_u64().unwrap() > 20, "{d}");
    assert!(!format!("{}", v["warnings"]).contains("distortion"));
}

#[test]
fn the_designed_multisine_puts_two_lines_within_the_resonances_half_power_band() {
    // the plant's least-damped pair above the crossover, the hydraulic resonance the design
    // reports: lines within f_n (1 ± ζ), its half-power band. The user rig with little friction
    // and cross-port leakage rings at 2.49 Hz with ζ 0.04, a band of 0.2 Hz, where a period of
    // 1/from_hz (0.337 Hz) put its lines 0.337 Hz apart and none in it; the article's rig,
    // damped (ζ 0.77), holds its 4 lines within it
    let light = [
        "viscous_friction_ns_per_m=10".into(),
        "c12_m5_per_ns=1e-12".into(),
    ];
    let user = Rig::from_file(&user_rig_path()).unwrap();
    let light = user.with_overrides(&light).unwrap();
    for (label, rig) in [("light user rig", light), ("article rig", Rig::default())] {
        let spec = SweepSpec::of_kind(SweepKind::Multisine);
        let e: Excitation = spec.excitation(&rig, 100.0).unwrap();
        let lines = e.frequencies_hz();
        let d = pumpcyl::frf::design(&rig, &pumpcyl::frf::DesignGoal::default()).unwrap();
        let plant = Plant::new(&rig);
        let r = resonance(&eigenvalues(&plant.a).unwrap(), d.crossover_hz, 100.0).unwrap();
        let z = r.damping.unwrap();
        let (lo, hi) = (r.natural_freq_hz * (1.0 - z), r.natural_freq_hz * (1.0 + z));
        let within = lines.iter().filter(|&&f| f >= lo && f <= hi).count();
        eprintln!(
            "{label}: {} lines on {:.3} s, {within} in {lo:.3} … {hi:.3} Hz",
            lines.len(),
            d.period_s
        );
        assert_eq!(lines.len(), d.lines_held, "{label}");
        assert!(within >= 2, "{label}: {lines:?}");
    }
}

#[test]
fn a_record_of_the_designers_defaults_reads_back_with_them() {
    // emulated with --set and read back with the same --set and no sweep option: the
    // description is the record's (its last sample, at the sweep's end, included)
    let dir = tempfile::tempdir().unwrap();
    let set = ["--set", "beta_bar=250"];
    emulate(dir.path(), "d.csv", &set);
    let v = frf_json(
        dir.path(),
        "d.csv",
        &[&["--sweep", "multisine"], &set[..]].concat(),
    );
    assert_eq!(v["method"], "periods");
    // another rig's design: refused in one line that names the options to give
    run::refused(
        dir.path(),
        &["frf", "d.csv", "--sweep", "multisine"],
        &[
            "d.csv",
            "--from-hz",
            "--amplitude-mm",
            "--period-s",
            "repeats every",
        ],
    );
}

#[test]
fn frf_design_of_a_record_takes_its_coherence_and_settling() {
    // a pilot record of the designed multisine on the user rig, the sensors' noise on: its
    // median usable coherence, at the design's own amplitude, gives the averages for ε = 5 %
    // by n_d = (1 − γ²)/(2 γ² ε²) (at least 2), its discarded periods the settling; the
    // designed record then reaches ε = 5 % at the median line
    let dir = tempfile::tempdir().unwrap();
    let user = user_rig_path();
    let rig = ["--rig", user.to_str().unwrap()];
    emulate(dir.path(), "pilot.csv", &rig);
    let pilot = frf_json(dir.path(), "pilot.csv", &rig);
    let bar = pilot["usable_coherence"].as_f64().unwrap();
    let mut usable: Vec<f64> = (pilot["closed_loop"]["points"].as_array().unwrap().iter())
        .map(|p| p["coherence"].as_f64().unwrap())
        .filter(|&c| c >= bar)
        .collect();
    usable.sort_by(f64::total_cmp);
    let g2 = usable[usable.len() / 2];
    let n_d = ((1.0 - g2) / (2.0 * g2 * 0.05 * 0.05)).ceil().max(2.0) as u64;
    let d = run::json(
        dir.path(),
        &[&["frf", "--design", "pilot.csv", "--json"], &rig[..]].concat(),
    );
    let (averages, periods) = (
        d["averages"].as_u64().unwrap(),
        d["periods"].as_u64().unwrap(),
    );
    let settled = pilot["periods_discarded"].as_u64().unwrap();
    eprintln!("pilot: coherence {g2:.6}, {settled} periods settling; design {averages} averages, {periods} periods");
    assert_eq!(averages, n_d);
    // the pilot's period is the design's: its settling periods, then at least 3 and one more
    assert_eq!(periods, settled + averages.max(3) + 1);
    let count = periods.to_string();
    emulate(
        dir.path(),
        "short.csv",
        &[&rig[..], &["--periods", &count]].concat(),
    );
    let v = frf_json(
        dir.path(),
        "short.csv",
        &[&["--sweep", "multisine", "--periods", &count], &rig[..]].concat(),
    );
    let mut eps: Vec<f64> = (v["closed_loop"]["points"].as_array().unwrap().iter())
        .map(|p| p["relative_error"].as_f64().unwrap())
        .collect();
    eps.sort_by(f64::total_cmp);
    assert!(eps[eps.len() / 2] <= 0.05, "{eps:?}");
    // a file that is no record: one line naming it
    std::fs::write(dir.path().join("r.csv"), "time_s,x_ref_mm,x_mm\n").unwrap();
    run::refused(dir.path(), &["frf", "--design", "r.csv"], &["r.csv"]);
}

#[test]
fn a_dual_pump_rig_resting_with_a_valve_open_is_drawn_about_that_rest() {
    // the user rig as a dual-pump circuit at no load: the valves-shut rest puts chamber 1 far
    // below the accumulator, where its check valve opens; the emulated record rests with
    // chamber 1 held near the accumulator instead. A 0.5 mm multisine, every effect off and
    // no noise: the estimate is the loop about that rest, and the model drawn is its
    let dir = tempfile::tempdir().unwrap();
    let user = user_rig_path();
    let rig = [
        "--rig",
        user.to_str().unwrap(),
        "--set",
        "circuit=dual-pump",
    ];
    let small = ["--amplitude-mm", "0.5"];
    let quiet = ["--no-effects", "--no-noise"];
    emulate(dir.path(), "dp.csv", &[&rig[..], &small, &quiet].concat());
    let p1 = column(&dir.path().join("dp.csv"), "p1_bar");
    let r = Rig::from_file(&user)
        .unwrap()
        .with_overrides(&["circuit=dual-pump".into()])
        .unwrap();
    let p_acc = r.accumulator_precharge_bar;
    assert!(p1[0] < p_acc && p1[0] > p_acc - 1.5, "{} bar", p1[0]);
    let read = [&["--sweep", "multisine"][..], &small, &rig].concat();
    let v = frf_json(dir.path(), "dp.csv", &read);
    let label = v["model"]["label"].as_str().unwrap();
    assert!(
        label.contains("dual-pump, linearised at its rest with a check valve open"),
        "{label}"
    );
    let w = format!("{}", v["warnings"]);
    let shut_rest = pumpcyl::circuit::dual_pump::DualPump::new(&r)
        .unwrap()
        .rest()
        .p1_pa
        / 1e5;
    assert!(shut_rest < p_acc - 0.5, "{shut_rest}");
    assert!(
        w.contains(&format!("chamber 1 at {shut_rest:.2} bar")),
        "{w}"
    );
    // the estimate against the curve drawn and against the valves-shut model
    let points = v["closed_loop"]["points"].as_array().unwrap();
    let freqs: Vec<f64> = points
        .iter()
        .map(|p| p["freq_hz"].as_f64().unwrap())
        .collect();
    let db = |p: &serde_json::Value| p["magnitude_db"].as_f64().unwrap();
    let drawn = v["model"]["magnitude_db"].as_array().unwrap();
    let worst_drawn = (points.iter().zip(drawn))
        .map(|(p, m)| (db(p) - m.as_f64().unwrap()).abs())
        .fold(0.0, f64::max);
    let rate_hz = v["rate_hz"].as_f64().unwrap();
    let shut =
        pumpcyl::frf::sampled_loop_response(&Plant::new(&r), r.sum_pressure, &freqs, rate_hz)
            .unwrap();
    let worst_shut = (points.iter().zip(&shut))
        .map(|(p, h)| (db(p) - 20.0 * h.norm().log10()).abs())
        .fold(0.0, f64::max);
    eprintln!("dual pump: {worst_drawn:.3} dB from the curve drawn, {worst_shut:.3} dB from the valves-shut model");
    assert!(
        worst_drawn < 0.1 && worst_shut > 3.0,
        "{worst_drawn} {worst_shut}"
    );
}
