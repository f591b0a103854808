//! `pumpcyl select`'s single-pump candidate under the emulated mode check
//! (docs/select.md#the-single-pump-circuit): each candidate's switches, switches after settling
//! and oscillation amplitude are those of `pumpcyl emulate` records of the same candidate rig
//! (the mode column counted with the valve rule, `SwitchCounter`); a candidate keeps switching
//! where a wave switches more often than its reference's needed force crosses the switching
//! force, and passes at a large external force, on the article's rig and on the user rig; a
//! step that switches during its transient and settles passes the emulated check and fails the
//! equations' check.

use pumpcyl::bulk::{effective_beta, BETA_OIL_BAR};
use pumpcyl::circuit::single_pump::modes::{switching, Mode, SwitchCounter, MAX_SETTLING_S};
use pumpcyl::rig::Rig;
use pumpcyl::select::Application;
use serde_json::Value;
use std::f64::consts::PI;
use std::path::Path;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// The time the step is held at x0 (s), the emulated check's (chatter::HOLD_S).
const HOLD_S: f64 = 1.0;

/// A single-pump rig file in `dir`: the article's rig (its seesaw's mass table too), or the
/// user rig less its second pump.
fn rig_file(dir: &Path, user: bool) -> std::path::PathBuf {
    let text = if user {
        let own = std::fs::read_to_string("tests/user-rig.toml").unwrap();
        let kept: Vec<&str> = (own.lines())
            .filter(|l| !l.starts_with("displacement_2_cm3_per_rev"))
            .collect();
        format!("circuit = \"single-pump\"\n{}\n", kept.join("\n"))
    } else {
        let article = Rig {
            circuit: pumpcyl::circuit::CircuitKind::SinglePump,
            ..Rig::default()
        };
        article.to_toml()
    };
    let file = dir.join("rig.toml");
    std::fs::write(&file, text).unwrap();
    file
}

/// The one candidate a selection on the rig file `rig` makes at the pre-charge `p_bar`, one
/// load `mass_kg`, the gas fraction fixed at `x`, the external force `force_n` and the gain
/// `kp`, under the mode check `check`: margin targets that only ask for stability and the
/// 0.2 Hz ±35 mm wave within a loose 100 mm, so that the mode check decides.
fn candidate(
    rig: &Path,
    (p_bar, mass_kg, x): (f64, f64, f64),
    force_n: f64,
    kp: f64,
    check: &str,
) -> Value {
    let sets = [
        "circuits=[\"single-pump\"]".to_string(),
        format!("precharge_bar=[{p_bar}]"),
        format!("mass_kg=[{mass_kg}]"),
        format!("gas_fraction={x}"),
        format!("gas_fraction_min={x}"),
        format!("gas_fraction_max={x}"),
        "target_pm_deg=0".into(),
        "target_gm_db=0".into(),
        "stroke_mm=0".into(),
        format!("external_force_n=[{force_n}, {force_n}]"),
        format!("rig.external_force_n={force_n}"),
        "wave=[{ freq_hz = 0.2, amp_mm = 35.0, max_error_mm = 100.0 }]".into(),
    ];
    let mut args: Vec<String> = ["select", "--json", "--rig"].map(String::from).to_vec();
    args.push(rig.display().to_string());
    args.extend(["--kp".to_string(), kp.to_string()]);
    args.extend(["--mode-check".to_string(), check.to_string()]);
    for s in sets {
        args.extend(["--set".to_string(), s]);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let s = run::json(Path::new("."), &args);
    assert_eq!(s["mode_check"], check);
    s["options"][0].clone()
}

/// What `pumpcyl emulate` records of one run: its mode switches (the valve rule on its
/// pressures, counted with `SwitchCounter`), those after `watched_from_s`, and half the
/// peak-to-peak control error `x_ref_mm − x_mm` after it (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Counted {
    switches: usize,
    after: usize,
    amplitude_mm: f64,
}

/// The mode at the recorded pressures `p1`, `p2` (bar) of `rig` by the valve rule
/// (docs/circuits.md#will-it-chatter): each check valve's opening signal, the accumulator
/// pressure less its chamber's plus the pilot ratio times the other chamber's above the
/// accumulator; the valve into chamber 2 open further is mode 1, into chamber 1 mode 2, none
/// while both signals are at most the cracking pressure (both shut). The record's `mode`
/// column names the valve nearer to opening there too (docs/emulator.md#the-mode-signal), so
/// it is read from the pressures.
fn valve_mode(rig: &Rig, p1: f64, p2: f64) -> Option<usize> {
    let (acc, k) = (
        rig.accumulator_precharge_bar,
        rig.circuit_key("pilot_ratio"),
    );
    let (s1, s2) = ((acc - p1) + k * (p2 - acc), (acc - p2) + k * (p1 - acc));
    if s1.max(s2) <= rig.circuit_key("check_valve_crack_bar") {
        None
    } else if s2 >= s1 {
        Some(1)
    } else {
        Some(2)
    }
}

/// `pumpcyl emulate` noise-free at the PLC's 100 Hz on the rig file `rig` with `sets` (the rig
/// `r`), the experiment `experiment`, counted from `watched_from_s` on.
fn emulated(
    (rig, r): (&Path, &Rig),
    sets: &[String],
    experiment: &[String],
    watched_from_s: f64,
) -> Counted {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("record.csv");
    let mut args: Vec<String> = ["emulate", "--no-noise", "--rate-hz", "100", "--rig"]
        .map(String::from)
        .to_vec();
    args.push(rig.display().to_string());
    for s in sets {
        args.extend(["--set".to_string(), s.clone()]);
    }
    args.extend(experiment.iter().cloned());
    args.extend(["--out".to_string(), out.display().to_string()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let run = run::pumpcyl(Path::new("."), &args);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t, r_mm, x_mm) = (col("time_s"), col("x_ref_mm"), col("x_mm"));
    let (p1, p2) = (col("p1_bar"), col("p2_bar"));
    let rows: Vec<Vec<f64>> =
        (lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())).collect();
    let mode = |row: &[f64]| valve_mode(r, row[p1], row[p2]);
    let mut counter = SwitchCounter::starting_in(mode(&rows[0]));
    let (mut before, mut lo, mut hi) = (None, f64::INFINITY, f64::NEG_INFINITY);
    for row in &rows[1..] {
        counter.observe(mode(row));
        if row[t] >= watched_from_s - 1e-9 {
            before.get_or_insert(counter.switches);
            let e = row[r_mm] - row[x_mm];
            (lo, hi) = (lo.min(e), hi.max(e));
        }
    }
    Counted {
        switches: counter.switches,
        after: counter.switches - before.unwrap(),
        amplitude_mm: 0.5 * (hi - lo),
    }
}

/// The candidate rig's step and 0.2 Hz ±35 mm wave emulated as the check runs them: the step
/// of 5 mm after 1 s, watched from the 2 % settling time 4/|Re s| of the mode at rest's
/// slowest closed-loop pole (docs/circuits.md#will-it-chatter), 10 s more; the wave after 1 s
/// at rest, 20 s of transient, then its last two periods watched.
fn emulated_runs(file: &Path, rig: &Rig, sets: &[String]) -> (Counted, Counted) {
    let at_rest = switching(rig).mode_at_rest;
    let settle = (Mode::new(rig, 3 - at_rest).settling_time_s().unwrap()).min(MAX_SETTLING_S);
    let settled_at = HOLD_S + settle;
    let step = [
        "--experiment".to_string(),
        "step".into(),
        "--from-mm".into(),
        rig.x0_mm.to_string(),
        "--to-mm".into(),
        (rig.x0_mm + 5.0).to_string(),
        "--at-s".into(),
        HOLD_S.to_string(),
        "--duration-s".into(),
        (settled_at + 10.0).to_string(),
    ];
    let step = emulated((file, rig), sets, &step, settled_at);
    let sine = [
        "--experiment",
        "sine",
        "--freq-hz",
        "0.2",
        "--amplitude-mm",
        "35",
        "--at-s",
        "1",
        "--duration-s",
        "31",
    ]
    .map(String::from);
    // 1 s at rest, 4 periods (20 s) of transient, two periods watched
    let sine = emulated((file, rig), sets, &sine, 21.0);
    (step, sine)
}

/// The candidate rig of the selection on the file `file`: the pre-charge, the bulk modulus at
/// the gas fraction `x` there, the gain, the load and the external force, as `--set`s and as a
/// rig.
fn candidate_rig(
    file: &Path,
    p_bar: f64,
    x: f64,
    kp: f64,
    mass_kg: f64,
    force_n: f64,
) -> (Vec<String>, Rig) {
    let beta = effective_beta(x, p_bar, BETA_OIL_BAR);
    let sets = vec![
        format!("accumulator_precharge_bar={p_bar}"),
        format!("beta_bar={beta}"),
        format!("kp={kp}"),
        format!("mass_kg={mass_kg}"),
        format!("external_force_n={force_n}"),
    ];
    let rig = Rig::from_file(file).unwrap().with_overrides(&sets).unwrap();
    (sets, rig)
}

/// The times the reference's needed force F_ext + m ẍ + b ẋ of the 0.2 Hz ±35 mm wave crosses
/// the switching force in two periods, by hand: a sinusoid about F_ext of amplitude
/// A ω √(m² ω² + b²) crosses a level twice a period when it reaches it.
fn explained_by_hand(rig: &Rig) -> usize {
    let (w, a) = (2.0 * PI * 0.2, 0.035);
    let swing =
        a * w * (rig.mass_kg.powi(2) * w * w + rig.viscous_friction_ns_per_m.powi(2)).sqrt();
    let f_s = switching(rig).switching_force_n;
    if (rig.external_force_n - f_s).abs() < swing {
        4
    } else {
        0
    }
}

/// A candidate's numbers against the emulated records of its rig: its switches those of the
/// step and the wave together, its switches after settling the step's after it settled and the
/// wave's in its watched periods beyond those its reference explains, its amplitude the step's
/// error swing after settling.
fn assert_matches_records(o: &Value, step: Counted, sine: Counted, explained: usize) {
    assert_eq!(o["mode_switches"], step.switches + sine.switches, "{o}");
    let after = step.after + sine.after.saturating_sub(explained);
    assert_eq!(o["switches_after_settling"], after, "{o} {step:?} {sine:?}");
    let amplitude = o["oscillation_amplitude_mm"].as_f64().unwrap();
    assert!(
        (amplitude - step.amplitude_mm).abs() < 2e-6,
        "{amplitude} vs {step:?}"
    );
}

/// On the article's application (its rig, gas-fraction range and two loads) at a 4 bar
/// pre-charge the single-pump candidate's mode-check numbers are those of `pumpcyl emulate`
/// on the candidate rig at the reference gas fraction and its gain, the worst of the two loads;
/// the check runs (its margins hold) and its switches die out after the step has settled.
#[test]
fn the_article_application_single_pump_numbers_are_the_emulated_records() {
    let s = run::json(
        Path::new("."),
        &[
            "select",
            "--json",
            "--circuits",
            "single-pump",
            "--set",
            "precharge_bar=[4.0]",
        ],
    );
    assert_eq!(s["mode_check"], "emulator");
    let o = &s["options"][0];
    let kp = o["kp_max"].as_f64().unwrap();
    let app = Application::default();
    let dir = tempfile::tempdir().unwrap();
    let file = rig_file(dir.path(), false);
    let mut worst = (0, 0, 0.0f64);
    for m in &app.mass_kg {
        let (sets, rig) = candidate_rig(&file, 4.0, app.gas_fraction, kp, *m, 0.0);
        let (step, sine) = emulated_runs(&file, &rig, &sets);
        let explained = explained_by_hand(&rig);
        worst = (
            worst.0.max(step.switches + sine.switches),
            worst
                .1
                .max(step.after + sine.after.saturating_sub(explained)),
            worst.2.max(step.amplitude_mm),
        );
    }
    assert_eq!(o["mode_switches"], worst.0, "{o}");
    assert!(worst.0 > 0, "the candidate switches during its runs: {o}");
    assert_eq!(o["switches_after_settling"], worst.1, "{o}");
    assert_eq!(worst.1, 0);
    let amplitude = o["oscillation_amplitude_mm"].as_f64().unwrap();
    assert!(
        (amplitude - worst.2).abs() < 2e-6,
        "{amplitude} vs {worst:?}"
    );
    assert!(
        !o["reason"].as_str().unwrap().contains("switches modes"),
        "{o}"
    );
}

/// On the article's rig at a 6.91 bar pre-charge (switching force 703 N), 10 593 kg, Kp 25:
/// at 500 N the 0.2 Hz wave's needed force crosses the switching force, twice a period, and
/// the emulated loop switches more often than that in the watched periods — the candidate
/// keeps switching; at 3000 N (4.3 times the switching force) it never switches and passes. At
/// 700 N the step switches during its transient only and the waves no more than their
/// reference explains: the emulated check passes it, the equations' check (any switch fails)
/// does not.
#[test]
fn the_article_rig_keeps_switching_near_its_switching_force_and_not_far_above_it() {
    let dir = tempfile::tempdir().unwrap();
    let file = rig_file(dir.path(), false);
    let x = Application::default().gas_fraction;
    let load = (6.91, 10593.0, x);
    let near = candidate(&file, load, 500.0, 25.0, "emulator");
    let (sets, rig) = candidate_rig(&file, 6.91, x, 25.0, 10593.0, 500.0);
    assert_eq!(explained_by_hand(&rig), 4);
    let (step, sine) = emulated_runs(&file, &rig, &sets);
    assert_matches_records(&near, step, sine, 4);
    assert!(sine.after > 4, "{sine:?}");
    let reason = near["reason"].as_str().unwrap();
    assert!(
        reason.starts_with("switches modes under this load: the sine 0.20 Hz, 35 mm switches")
            && reason.contains(&format!(
                "switches {} times in its last 2 periods, 4 of them explained",
                sine.after
            )),
        "{reason}"
    );
    assert_eq!(
        (near["meets"].as_bool(), near["meets_best_case"].as_bool()),
        (Some(false), Some(false))
    );

    let far = candidate(&file, load, 3000.0, 25.0, "emulator");
    let (sets, rig) = candidate_rig(&file, 6.91, x, 25.0, 10593.0, 3000.0);
    assert!(3000.0 > 4.0 * switching(&rig).switching_force_n);
    let (step, sine) = emulated_runs(&file, &rig, &sets);
    assert_eq!(step.switches + sine.switches, 0);
    assert_matches_records(&far, step, sine, 0);
    assert_eq!(far["meets"], true, "{far}");

    let settles = candidate(&file, load, 700.0, 25.0, "emulator");
    let (sets, rig) = candidate_rig(&file, 6.91, x, 25.0, 10593.0, 700.0);
    let (step, sine) = emulated_runs(&file, &rig, &sets);
    assert!(step.switches > 0 && step.after == 0, "{step:?}");
    assert_matches_records(&settles, step, sine, explained_by_hand(&rig));
    assert_eq!(settles["meets"], true, "{settles}");
    let strict = candidate(&file, load, 700.0, 25.0, "equations");
    let reason = strict["reason"].as_str().unwrap();
    assert!(
        reason.starts_with("switches modes under this load: ")
            && reason.contains("switches during the step"),
        "{reason}"
    );
}

/// The user rig as a single-pump rig (80/45 mm, 2500 kg, β 300 bar) at a 5 bar pre-charge
/// (switching force 795 N), Kp 15: at 650 N the wave's needed force (650 ± 138 N) stays below
/// the switching force, so its reference explains no switch, yet the emulated loop switches in
/// the watched periods: it keeps switching; at 3000 N it never switches and passes; the numbers
/// are the records'.
#[test]
fn the_user_rig_keeps_switching_near_its_switching_force_and_not_far_above_it() {
    let dir = tempfile::tempdir().unwrap();
    let file = rig_file(dir.path(), true);
    let x = 0.02;
    let load = (5.0, 2500.0, x);
    let near = candidate(&file, load, 650.0, 15.0, "emulator");
    let (sets, rig) = candidate_rig(&file, 5.0, x, 15.0, 2500.0, 650.0);
    assert_eq!(explained_by_hand(&rig), 0);
    let (step, sine) = emulated_runs(&file, &rig, &sets);
    assert!(sine.after > 0, "{sine:?}");
    assert_matches_records(&near, step, sine, 0);
    let reason = near["reason"].as_str().unwrap();
    assert!(
        reason.starts_with("switches modes under this load: the sine 0.20 Hz, 35 mm switches")
            && reason.contains("0 of them explained"),
        "{reason}"
    );
    let far = candidate(&file, load, 3000.0, 15.0, "emulator");
    let (sets, rig) = candidate_rig(&file, 5.0, x, 15.0, 2500.0, 3000.0);
    let (step, sine) = emulated_runs(&file, &rig, &sets);
    assert_eq!(step.switches + sine.switches, 0);
    assert_matches_records(&far, step, sine, 0);
    assert_eq!(far["meets"], true, "{far}");
}

/// A mode check that does not exist is refused in one line naming the option and the checks;
/// the other circuits' rows carry no mode-check numbers.
#[test]
fn an_unknown_mode_check_is_refused_and_other_circuits_have_no_numbers() {
    run::refused(
        Path::new("."),
        &["select", "--mode-check", "emulated"],
        &["--mode-check", "emulator", "equations"],
    );
    let s = run::json(
        Path::new("."),
        &[
            "select",
            "--json",
            "--circuits",
            "dpm",
            "--set",
            "low_pressure_bar=[4.0]",
            "--set",
            "pressurised_bar=[]",
        ],
    );
    for key in [
        "mode_switches",
        "switches_after_settling",
        "oscillation_amplitude_mm",
    ] {
        assert!(s["options"][0][key].is_null(), "{key}: {s}");
    }
}

/// No level to try names the key that lists the levels of the circuits asked for: a one-motor
/// circuit's `precharge_bar`, not the DPM's `low_pressure_bar`.
#[test]
fn no_level_names_the_circuits_own_key() {
    let dir = tempfile::tempdir().unwrap();
    let one_motor = [
        "select",
        "--set",
        "circuits=[\"single-pump\"]",
        "--set",
        "precharge_bar=[]",
    ];
    run::refused(
        dir.path(),
        &one_motor,
        &["precharge_bar", "no pressure level to try"],
    );
    let out = run::pumpcyl(dir.path(), &one_motor);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("low_pressure_bar"));
    let dpm = [
        "select",
        "--set",
        "circuits=[\"dpm\"]",
        "--set",
        "low_pressure_bar=[]",
        "--set",
        "pressurised_bar=[]",
    ];
    run::refused(dir.path(), &dpm, &["low_pressure_bar", "pressurised_bar"]);
}
