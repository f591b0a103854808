//! `pumpcyl select` across circuits (docs/select.md#circuits): every circuit the rig's
//! components allow at every level, on the article's application and on the user rig; the DPM
//! candidates unchanged by the others; the single-pump candidate failing where its step
//! switches modes, and not under a load well above its switching force.

use pumpcyl::bulk::effective_beta;
use pumpcyl::circuit::single_pump::modes::{switching, StepCheck};
use pumpcyl::circuit::single_pump::SinglePump;
use pumpcyl::rig::Rig;
use pumpcyl::select::{
    Application, Circuit, EquationsCheck, ModeCheck, ModeVerdict, WaveRequirement,
};
use serde_json::Value;
use std::path::Path;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// The single-pump candidate circuit (docs/select.md#circuits).
fn single_pump() -> Circuit {
    Circuit::named("single-pump").expect("select offers the single-pump circuit")
}

fn select(args: &[&str]) -> Value {
    run::json(Path::new("."), &[&["select", "--json"], args].concat())
}

/// The (circuit, pressure level) of every option.
fn rows(s: &Value) -> Vec<(String, f64)> {
    (s["options"].as_array().unwrap().iter())
        .map(|o| {
            let name = o["circuit"].as_str().unwrap().to_string();
            (name, o["mean_pressure_bar"].as_f64().unwrap())
        })
        .collect()
}

/// The rows the application's levels give for `circuits`, in the selection's order.
fn expected(circuits: &[(&str, &[f64])]) -> Vec<(String, f64)> {
    (circuits.iter())
        .flat_map(|(c, ps)| ps.iter().map(|p| (c.to_string(), *p)))
        .collect()
}

const LOW: [f64; 10] = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];

/// On the article's application every circuit gets a row at each of its levels, named by
/// circuit, kind and pressure level; the DPM rows are those of a DPM-only selection, number
/// for number; the answer names its circuit.
#[test]
fn the_article_application_gives_every_circuit_at_every_level() {
    let all = select(&[]);
    let want = expected(&[
        ("low_pressure", &LOW),
        ("pressurised", &[20.0, 30.0, 50.0]),
        ("dual_pump", &LOW),
        ("single_pump", &LOW),
    ]);
    assert_eq!(rows(&all), want);
    for o in all["options"].as_array().unwrap() {
        let (kind, level) = match o["circuit"].as_str().unwrap() {
            "low_pressure" => ("dpm", "low_pressure"),
            "pressurised" => ("dpm", "pressurised"),
            "dual_pump" => ("dual-pump", "precharge"),
            _ => ("single-pump", "precharge"),
        };
        assert_eq!(
            (o["circuit_kind"].as_str(), o["pressure_level"].as_str()),
            (Some(kind), Some(level)),
            "{o}"
        );
        assert!(o["reason"].as_str().is_some_and(|r| !r.is_empty()), "{o}");
    }
    let dpm = select(&["--circuits", "dpm"]);
    let options = all["options"].as_array().unwrap();
    assert_eq!(
        &options[..13],
        dpm["options"].as_array().unwrap().as_slice()
    );
    let answer = &all["at_min_mean_pressure"];
    assert_eq!(all["chosen_circuit"], answer["circuit_kind"]);
    let chosen = all["chosen"].as_u64().unwrap() as usize;
    assert_eq!(options[chosen]["circuit_kind"], answer["circuit_kind"]);
    // the refined answer is no higher than any circuit's lowest meeting level
    let p = all["min_mean_pressure_bar"].as_f64().unwrap();
    for o in options.iter().filter(|o| o["meets"] == true) {
        assert!(p <= o["mean_pressure_bar"].as_f64().unwrap(), "{p}: {o}");
    }
}

/// On the user rig (a DPM rig: two drives, two pumps) every circuit is tried at every level
/// the command gives it; `--circuits` picks some, and a circuit its components do not allow is
/// refused naming the key.
#[test]
fn the_user_rig_gives_every_circuit_at_every_level() {
    let levels = [
        "--set",
        "low_pressure_bar=[5.0, 10.0]",
        "--set",
        "pressurised_bar=[30.0]",
        "--set",
        "precharge_bar=[3.0, 8.0]",
    ];
    let rig = ["--rig", "tests/user-rig.toml"];
    let all = select(&[&rig[..], &levels].concat());
    let want = expected(&[
        ("low_pressure", &[5.0, 10.0]),
        ("pressurised", &[30.0]),
        ("dual_pump", &[3.0, 8.0]),
        ("single_pump", &[3.0, 8.0]),
    ]);
    assert_eq!(rows(&all), want);
    let two = select(&[&rig[..], &levels, &["--circuits", "single-pump,dpm"]].concat());
    let want = expected(&[
        ("low_pressure", &[5.0, 10.0]),
        ("pressurised", &[30.0]),
        ("single_pump", &[3.0, 8.0]),
    ]);
    assert_eq!(rows(&two), want);
    // a single-pump rig has one drive and one pump: no DPM
    let out = run::pumpcyl(
        Path::new("."),
        &[
            "select",
            "--set",
            "rig.circuit=\"single-pump\"",
            "--circuits",
            "dpm",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("circuits") && err.contains("single-pump"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// A single-pump application: its pre-charge `p_bar`, one load `mass_kg`, the gas fraction
/// fixed at `x`, the rig's and the application's external force `force_n`; margin targets
/// that only ask for stability and a loose wave, so that the mode check decides.
fn single_pump_app(p_bar: f64, mass_kg: f64, x: f64, force_n: f64) -> Application {
    let set = |k: &str, v: String| format!("{k}={v}");
    Application::default()
        .with_overrides(
            "--set",
            &[
                set("circuits", "[\"single-pump\"]".into()),
                set("precharge_bar", format!("[{p_bar}]")),
                set("mass_kg", format!("[{mass_kg}]")),
                set("gas_fraction", format!("{x}")),
                set("gas_fraction_min", format!("{x}")),
                set("gas_fraction_max", format!("{x}")),
                set("target_pm_deg", "0".into()),
                set("target_gm_db", "0".into()),
                set("stroke_mm", "0".into()),
                set("external_force_n", format!("[{force_n}, {force_n}]")),
                set("rig.external_force_n", format!("{force_n}")),
                set(
                    "wave",
                    "[{ freq_hz = 0.2, amp_mm = 35.0, max_error_mm = 100.0 }]".into(),
                ),
            ],
        )
        .unwrap()
}

/// The check's own verdict on the candidate `app` makes at gain `kp`.
fn check_of(app: &Application, kp: f64) -> pumpcyl::circuit::single_pump::modes::StepVerdict {
    let p = app.precharge_bar[0];
    let beta = effective_beta(app.gas_fraction, p, app.beta_oil_bar);
    let rig = Rig {
        kp,
        mass_kg: app.mass_kg[0],
        ..single_pump().rig_at(&app.rig, p, beta)
    };
    StepCheck::ARTICLE.run(&SinglePump::new(&rig)).unwrap()
}

/// At zero external force and a 0.5 bar pre-charge (switching force ≈ 51 N) the article's step
/// at Kp 25 on 4898 kg needs more force than that to accelerate the load: the circuit's
/// equations switch modes, and the candidate fails with the reason under the equations' check
/// (which fails any switch). At ten times the switching
/// force the step stays in mode 1, and the candidate does not fail for switching.
#[test]
fn the_single_pump_candidate_fails_where_its_step_switches_modes() {
    let x = 1e-3;
    let calm = single_pump_app(0.5, 4898.0, x, 0.0);
    let verdict = check_of(&calm, 25.0);
    assert!(verdict.switches > 0, "{verdict:?}");
    let equations = |app: &Application| {
        let work = pumpcyl::limits::Work::QUIET;
        app.select_checked(Some(25.0), &work, &EquationsCheck::ARTICLE)
            .unwrap()
    };
    let s = equations(&calm);
    assert_eq!(s.mode_check, "equations");
    let c = &s.options[0];
    assert_eq!(c.circuit, single_pump());
    assert!(!c.meets && !c.meets_best_case, "{c:?}");
    assert!(
        c.reason.starts_with("switches modes under this load: ")
            && c.reason
                .contains(&format!("{} switches during the step", verdict.switches)),
        "{}",
        c.reason
    );
    let f_s = switching(
        &calm
            .rig
            .with_overrides(&[
                "circuit=single-pump".into(),
                "accumulator_precharge_bar=0.5".into(),
            ])
            .unwrap(),
    )
    .switching_force_n;
    assert!((f_s - 0.5e5 * std::f64::consts::PI / 4.0 * 0.036f64.powi(2)).abs() < 1e-9);
    let loaded = single_pump_app(0.5, 4898.0, x, 10.0 * f_s);
    let verdict = check_of(&loaded, 25.0);
    assert_eq!(verdict.switches, 0, "{verdict:?}");
    let c = &equations(&loaded).options[0];
    assert!(!c.reason.contains("switches"), "{}", c.reason);
    assert!(c.meets, "{}", c.reason);
}

/// The mode check is a trait: a stand-in that always finds switches fails every single-pump
/// candidate with its count, and leaves the other circuits alone.
#[test]
fn another_mode_check_can_stand_in() {
    struct Always;
    impl ModeCheck for Always {
        fn run(&self, rig: &Rig, waves: &[WaveRequirement]) -> Result<ModeVerdict, String> {
            let mut v = EquationsCheck::ARTICLE.run(rig, waves)?;
            v.switches = 7;
            v.keeps_switching = Some("7 switches during the step".into());
            Ok(v)
        }
        fn describe(&self) -> String {
            "a stand-in".into()
        }
        fn name(&self) -> &'static str {
            "stand-in"
        }
        fn work(&self, waves: &[WaveRequirement]) -> f64 {
            EquationsCheck::ARTICLE.work(waves)
        }
    }
    let app = Application::default()
        .with_overrides(
            "--set",
            &[
                "precharge_bar=[8.0]".into(),
                "low_pressure_bar=[8.0]".into(),
                "pressurised_bar=[]".into(),
            ],
        )
        .unwrap();
    let work = pumpcyl::limits::Work::QUIET;
    let s = app.select_checked(None, &work, &Always).unwrap();
    let reasons: Vec<(&str, &str)> = (s.options.iter())
        .map(|c| (c.circuit.name(), c.reason.as_str()))
        .collect();
    assert_eq!(reasons.len(), 3);
    for (circuit, reason) in reasons {
        let stood_in =
            reason.contains("7 switches during the step") && reason.contains("a stand-in");
        assert_eq!(stood_in, circuit == "single-pump", "{circuit}: {reason}");
    }
    assert_eq!(s.mode_check, "stand-in");
    let _ = EquationsCheck::ARTICLE.describe();
}
