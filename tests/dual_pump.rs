//! The single-motor dual-pump circuit (the article's Figure 1b; docs/circuits.md#dual-pump):
//! its linear model against finite differences of its own equations, its margins against
//! python-control on a model built independently, its steady pressures in motion against the
//! flow balance by hand and against a simulation, its rest held by the equations, and the rig
//! keys a dual-pump rig refuses.

#[path = "common/jacobian.rs"]
mod jacobian;
#[path = "common/skip.rs"]
mod skip;

use nalgebra::{DMatrix, Matrix3, Vector3};
use proptest::prelude::*;
use pumpcyl::circuit::dual_pump::DualPump;
use pumpcyl::circuit::{linearise, Circuit, Effects, Role};
use pumpcyl::lti::{margins, StateSpace};
use pumpcyl::rig::Rig;
use std::f64::consts::PI;
use std::path::Path;
use std::process::Command;

/// The article's rig as a dual-pump rig, with `sets` applied.
fn dual_rig(sets: &[String]) -> Rig {
    let mut all = vec!["circuit=dual-pump".to_string()];
    all.extend_from_slice(sets);
    Rig::default().with_overrides(&all).unwrap()
}

fn dual(sets: &[&str]) -> DualPump {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    DualPump::new(&dual_rig(&sets)).unwrap()
}

/// D2 (cm³/rev) that matches the chambers of the article's cylinder: D2/D1 = A1/A2 − 1.
fn matched_d2() -> f64 {
    let (d1, d2) = (63.0f64, 36.0f64);
    6.0 * (d1 * d1 / (d1 * d1 - d2 * d2) - 1.0)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    /// The dual-number linear model equals a central finite-difference Jacobian of the same
    /// equations to 1e-6 relative, element by element (an element below a thousandth of its
    /// row's largest, e.g. one that is zero, to 1e-9 of that largest), over random rigs and
    /// every model variant.
    #[test]
    fn the_linear_model_is_the_jacobian_of_the_equations(
        mass in 500.0..20000.0f64,
        beta in 20.0..2000.0f64,
        d2 in 1.0..9.0f64,
        c1 in 1e-12..2e-10f64,
        c2 in 1e-12..2e-10f64,
        c12 in 0.0..5e-10f64,
        force in 0.0..20000.0f64,
        p_acc in 1.0..30.0f64,
        x0 in 50.0..450.0f64,
        variant in 0usize..4,
    ) {
        let mut sets: Vec<String> = vec![
            format!("mass_kg={mass}"), format!("beta_bar={beta}"),
            format!("displacement_2_cm3_per_rev={d2}"), format!("c1_m5_per_ns={c1:e}"),
            format!("c2_m5_per_ns={c2:e}"), format!("c12_m5_per_ns={c12:e}"),
            format!("external_force_n={force}"), format!("accumulator_precharge_bar={p_acc}"),
            format!("x0_mm={x0}"), "mass_by_position=[]".into(),
        ];
        sets.extend(match variant {
            0 => vec![],
            1 => vec!["feedforward=false".to_string()],
            2 => vec!["motor_model=first_order".to_string()],
            _ => vec!["motor_coupling=false".to_string()],
        });
        let all: Vec<String> = ["circuit=dual-pump".to_string()].into_iter().chain(sets).collect();
        let rig = Rig::default().with_overrides(&all);
        prop_assume!(rig.is_ok()); // a rest that cavitates is refused by the rig itself
        let c = DualPump::new(&rig.unwrap()).unwrap();
        let op = c.operating_point();
        let (a, b) = linearise(&c, &op.state, &op.inputs);
        let (fa, fb) = jacobian::fd_jacobian(&c, &op.state, &op.inputs);
        for i in 0..a.nrows() {
            let row = a.row(i).amax().max(b.row(i).amax());
            for (ad, fd) in a.row(i).iter().chain(b.row(i).iter()).zip(fa.row(i).iter().chain(fb.row(i).iter())) {
                let tol = 1e-6 * ad.abs().max(1e-3 * row);
                prop_assert!((ad - fd).abs() <= tol, "row {i}: dual {ad} vs fd {fd}");
            }
        }
    }
}

/// The open loop e → x of the circuit: its A with the control law's inner feedback (none but
/// the position's here), B times the reference gain, output the position.
fn open_loop(c: &DualPump) -> StateSpace {
    let op = c.operating_point();
    let (a, b) = linearise(c, &op.state, &op.inputs);
    let law = c.control_law();
    let mut kx = law.kx.clone();
    let x = c.state_of(Role::Position).unwrap();
    kx.column_mut(x).fill(0.0);
    let n = a.nrows();
    let mut cx = DMatrix::zeros(1, n);
    cx[(0, x)] = 1.0;
    StateSpace::new(&a + &b * kx, &b * &law.kr, cx, DMatrix::zeros(1, 1)).unwrap()
}

/// The margins of the article's rig with D2 matched agree with python-control's on the model
/// tests/reference/dual_pump_margins.py builds from the equations itself (not from pumpcyl).
#[test]
fn margins_agree_with_python_control_on_an_independent_model() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = root.join("target/py-venv/bin/python");
    let have = python.exists()
        && Command::new(&python)
            .args(["-c", "import control"])
            .output()
            .is_ok_and(|o| o.status.success());
    if !have {
        let test = "dual_pump::margins_agree_with_python_control_on_an_independent_model";
        skip::skip(
            test,
            "python-control in target/py-venv",
            "./test.sh creates the venv",
        );
        return;
    }
    let rig = dual_rig(&[format!("displacement_2_cm3_per_rev={}", matched_d2())]);
    let ours = margins(&open_loop(&DualPump::new(&rig).unwrap())).unwrap();
    let json = serde_json::to_string(&rig).unwrap();
    let out = Command::new(&python)
        .arg(root.join("tests/reference/dual_pump_margins.py"))
        .arg(json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let theirs: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let pairs = [
        ("gain_margin_db", ours.gain_margin_db),
        ("phase_margin_deg", ours.phase_margin_deg),
        ("phase_crossover_hz", ours.phase_crossover_hz),
        ("gain_crossover_hz", ours.gain_crossover_hz),
    ];
    for (key, ours) in pairs {
        let (ours, theirs) = (ours.unwrap(), theirs[key].as_f64().unwrap());
        assert!(
            (ours / theirs - 1.0).abs() < 1e-6,
            "{key}: pumpcyl {ours}, python-control {theirs}"
        );
    }
    assert!(ours.closed_loop_stable);
}

/// The flow and force balance at constant piston speed, solved by hand as a 3 × 3 linear
/// system in (p1, p2, ω) from the equations of docs/circuits.md#steady-motion.
fn balance_by_hand(rig: &Rig, v: f64) -> [f64; 3] {
    let d1 = rig.piston_diameter_mm * 1e-3;
    let a1 = PI * d1 * d1 / 4.0;
    let a2 = a1 - PI * (rig.rod_diameter_mm * 1e-3).powi(2) / 4.0;
    let per_rad = 1e-6 / (2.0 * PI);
    let (pd1, pd2) = (
        rig.displacement_1_cm3_per_rev * per_rad,
        rig.displacement_2_cm3_per_rev * per_rad,
    );
    let (c1, c2, c12) = (rig.c1_m5_per_ns, rig.c2_m5_per_ns, rig.c12_m5_per_ns);
    let pa = rig.accumulator_precharge_bar * 1e5;
    // rows: force, chamber 1, chamber 2; unknowns p1, p2, ω
    let m = Matrix3::new(
        a1,
        -a2,
        0.0,
        -(c1 + c12),
        c12,
        pd1 + pd2,
        c12,
        -(c2 + c12),
        -pd1,
    );
    let rhs = Vector3::new(
        rig.external_force_n + rig.viscous_friction_ns_per_m * v,
        a1 * v - c1 * pa,
        -a2 * v - c2 * pa,
    );
    let s = m.lu().solve(&rhs).unwrap();
    [s[0], s[1], s[2]]
}

/// RK4 of the circuit's equations under its control law with reference `x_ref(t)`, for
/// `seconds` in steps of 0.1 ms, from its operating point.
fn simulate(c: &DualPump, x_ref: impl Fn(f64) -> f64, seconds: f64) -> Vec<f64> {
    let op = c.operating_point();
    let law = c.control_law();
    let x0 = op.state.clone();
    let f = |t: f64, s: &[f64]| {
        let dx_state: Vec<f64> = s.iter().zip(&x0).map(|(a, b)| a - b).collect();
        let u = op.inputs[0]
            + (0..s.len())
                .map(|j| law.kx[(0, j)] * dx_state[j])
                .sum::<f64>()
            + law.kr[(0, 0)] * (x_ref(t) - x0[0]);
        let mut dx = vec![0.0; s.len()];
        c.rhs(s, &[u], &mut dx);
        dx
    };
    let h = 1e-4;
    let steps = (seconds / h).round() as usize;
    let mut s = op.state.clone();
    let add = |s: &[f64], k: &[f64], w: f64| -> Vec<f64> {
        s.iter().zip(k).map(|(a, b)| a + w * b).collect()
    };
    for k in 0..steps {
        let t = k as f64 * h;
        let k1 = f(t, &s);
        let k2 = f(t + h / 2.0, &add(&s, &k1, h / 2.0));
        let k3 = f(t + h / 2.0, &add(&s, &k2, h / 2.0));
        let k4 = f(t + h, &add(&s, &k3, h));
        for i in 0..s.len() {
            s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
    s
}

/// A matched rig moving at constant speed keeps its chamber pressures (to the friction
/// force's share); a mismatched one (the article's D2 = 3.6 cm³/rev) shifts them by what the
/// steady flow balance predicts, and a simulated ramp settles there.
#[test]
fn constant_speed_keeps_matched_pressures_and_shifts_mismatched_ones() {
    // 100 mm in 20 s: nine times the slowest closed-loop time constant, 2.2 s (the leakage's)
    let v = 0.005;
    // matched, no friction: the rest pressures exactly
    let matched = dual(&[
        &format!("displacement_2_cm3_per_rev={}", matched_d2()),
        "viscous_friction_ns_per_m=0",
    ]);
    assert!(matched.mismatch_m2().abs() < 1e-18);
    let (rest, moving) = (matched.rest(), matched.steady_motion(v));
    assert!((moving.p1_pa - rest.p1_pa).abs() < 1e-9 * rest.p1_pa);
    assert!((moving.p2_pa - rest.p2_pa).abs() < 1e-9 * rest.p2_pa);
    // mismatched: against the balance by hand, then against a simulated ramp
    let rig = dual_rig(&[]);
    let c = DualPump::new(&rig).unwrap();
    let [p1, p2, w] = balance_by_hand(&rig, v);
    let s = c.steady_motion(v);
    for (ours, hand) in [(s.p1_pa, p1), (s.p2_pa, p2), (s.omega_rad_per_s, w)] {
        assert!((ours / hand - 1.0).abs() < 1e-9, "{ours} vs {hand}");
    }
    let rest = c.rest();
    let shift = [s.p1_pa - rest.p1_pa, s.p2_pa - rest.p2_pa];
    // pump 2 over-supplies chamber 1 as the piston extends: both pressures rise
    assert!(shift[0] > 0.15e5 && shift[1] > 0.25e5, "{shift:?}");
    let x0 = c.operating_point().state[0];
    let end = simulate(&c, |t| x0 + v * t, 20.0);
    let got = [end[2] - rest.p1_pa, end[3] - rest.p2_pa];
    for i in 0..2 {
        assert!(
            (got[i] / shift[i] - 1.0).abs() < 1e-3,
            "chamber {}: simulated shift {} Pa, balance {} Pa",
            i + 1,
            got[i],
            shift[i]
        );
    }
    let matched_end = simulate(&matched, |t| x0 + v * t, 20.0);
    let rest = matched.rest();
    assert!((matched_end[2] - rest.p1_pa).abs() < 1e-3 * rest.p1_pa);
    assert!((matched_end[3] - rest.p2_pa).abs() < 1e-3 * rest.p2_pa);
}

/// Integrating the equations from the operating point with no reference change stays there:
/// drift below 1e-9 m over 10 s, for every motor model; and the emulator's equations (every
/// effect, the end stops, the valves) where the rest keeps the valves shut (a load that holds
/// both chambers at the accumulator).
#[test]
fn the_operating_point_holds_for_ten_seconds() {
    for sets in [
        &[][..],
        &["feedforward=false"],
        &["motor_model=first_order"],
    ] {
        let c = dual(sets);
        let x0 = c.operating_point().state[0];
        let end = simulate(&c, |_| x0, 10.0);
        assert!(
            (end[0] - x0).abs() < 1e-9,
            "{sets:?}: drift {} m",
            end[0] - x0
        );
    }
    let rig = dual_rig(&[]);
    let si = rig.si();
    let balanced = format!(
        "external_force_n={}",
        rig.accumulator_precharge_bar * 1e5 * (si.a1 - si.a2)
    );
    let rig = dual_rig(&[balanced]);
    let c = DualPump::emulated(&rig, Effects::all(0.02)).unwrap();
    let bulk = c.steady_bulk(0.0).unwrap();
    assert_eq!(bulk.valve_flow_m3_per_s, [0.0, 0.0]);
    let x0 = c.operating_point().state[0];
    let end = simulate(&c, |_| x0, 10.0);
    assert!(
        (end[0] - x0).abs() < 1e-9,
        "with valves: drift {} m",
        end[0] - x0
    );
}

/// On the article's values with no load the leakage balance holds both chambers below the
/// accumulator by more than the check valves' cracking pressure: the emulator's valves would
/// open there, which docs/circuits.md#valves states. β_e in motion follows the mean pressure.
#[test]
fn the_unloaded_rest_opens_the_check_valve_and_beta_follows_the_mean_pressure() {
    let c = dual(&[]);
    let rest = c.steady_bulk(0.0).unwrap();
    assert!(
        rest.valve_flow_m3_per_s.iter().all(|q| *q > 0.0),
        "{rest:?}"
    );
    assert!((rest.beta_e_bar / 165.0 - 1.0).abs() < 1e-12);
    let moving = c.steady_bulk(0.01).unwrap();
    // the gas fraction of 165 bar at the rest's mean, read at the moving mean (docs/bulk-modulus.md)
    let (p0, p) = (rest.p_mean_bar, moving.p_mean_bar);
    let x = (1.0 / 165.0 - 1.0 / 17000.0) / (1.0 / p0 - 1.0 / 17000.0);
    let want = 1.0 / (x / p + (1.0 - x) / 17000.0);
    assert!((moving.beta_e_bar / want - 1.0).abs() < 1e-12);
    assert!(moving.beta_e_bar > rest.beta_e_bar);
}

#[test]
fn a_key_of_the_other_circuit_is_refused_with_its_line() {
    let text = "circuit = \"dual-pump\"\nkm2_nms_per_rad = 0.03\n";
    let e = Rig::from_toml_str(text, "r.toml").unwrap_err().to_string();
    assert_eq!(
        e,
        "r.toml: line 2, key `km2_nms_per_rad`: the dual-pump circuit has no such key \
         (it belongs to the dpm circuit; docs/circuits.md)"
    );
    let e = Rig::from_toml_str("accumulator_precharge_bar = 5.0\n", "d.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("d.toml: line 1, key `accumulator_precharge_bar`: the dpm circuit"),
        "{e}"
    );
    let set = |s: &[&str]| {
        let s: Vec<String> = s.iter().map(|x| x.to_string()).collect();
        Rig::default().with_overrides_from("--set", &s)
    };
    let e = set(&["circuit=dual-pump", "k_pres_per_bar=0.3"])
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("--set: key `k_pres_per_bar`: the dual-pump circuit has no such key"),
        "{e}"
    );
    assert!(set(&["circuit=dual-pump", "accumulator_precharge_bar=8"]).is_ok());
    let e = Rig::from_toml_str("circuit = \"triple\"\n", "t.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("t.toml") && e.contains("`dpm`") && e.contains("`dual-pump`"),
        "{e}"
    );
    let e = set(&["circuit=triple"]).unwrap_err().to_string();
    assert!(e.contains("`dpm`") && e.contains("`dual-pump`"), "{e}");
}

/// A dual-pump rig's printed form reads back to it, and the keys it leaves out are only its own.
#[test]
fn a_dual_pump_rig_round_trips_and_names_only_its_own_defaults() {
    let rig = dual_rig(&["accumulator_precharge_bar=8.5".into()]);
    let text = rig.to_commented_toml();
    assert!(text.contains("# km2_nms_per_rad = 0.026"), "{text}");
    assert_eq!(Rig::from_toml_str(&text, "p.toml").unwrap(), rig);
    assert_eq!(Rig::from_toml_str(&rig.to_toml(), "p.toml").unwrap(), rig);
    let file = Rig::from_toml_str_with_defaults("circuit = \"dual-pump\"\n", "q.toml").unwrap();
    assert!(file.defaulted.contains(&"accumulator_precharge_bar"));
    assert!(!file.defaulted.contains(&"p_sum_ref_bar"));
    // the rest of a pre-charge that cavitates is refused, naming the pre-charge
    let e = Rig::from_toml_str(
        "circuit = \"dual-pump\"\naccumulator_precharge_bar = 1.0\nexternal_force_n = -5000.0\n",
        "c.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("c.toml: line 2, key `accumulator_precharge_bar`") && e.contains("vapour"),
        "{e}"
    );
}

/// Where the no-load rest of the leakage balance opens the check valves, the emulated circuit
/// (every effect, the valves) started there settles where check valve 1 just feeds chamber 1:
/// p1 between the accumulator less the valve's cracking pressure and less its full opening,
/// p2 from the force balance (within the 15 N Coulomb friction), the piston near x0.
#[test]
fn the_emulated_unloaded_circuit_settles_on_its_check_valve() {
    let rig = dual_rig(&[]);
    let c = DualPump::emulated(&rig, Effects::all(0.02)).unwrap();
    let x0 = c.operating_point().state[0];
    let end = simulate(&c, |_| x0, 10.0);
    let p_acc = rig.accumulator_precharge_bar * 1e5;
    let valve = pumpcyl::circuit::valves::Valve::ANTI_CAVITATION;
    let (p1, p2) = (end[2], end[3]);
    assert!(
        p1 < p_acc - valve.crack_pa && p1 > p_acc - valve.crack_pa - valve.open_range_pa,
        "p1 {p1} Pa"
    );
    let si = rig.si();
    assert!((p1 * si.a1 - p2 * si.a2).abs() < 20.0, "{p1} {p2}");
    assert!((end[0] - x0).abs() < 5e-3, "x {} m off x0", end[0] - x0);
    // and it is not the linear model's rest: chamber 1 is 2 bar above it
    assert!(p1 - c.rest().p1_pa > 2e5);
}

/// The step response pumpcyl simulates for a dual-pump rig (its exact ZOH of the linear model)
/// follows the circuit's own equations integrated by RK4 from the operating point: a 0.1 mm
/// step, compared at 0.5 s and 3 s; one motor, so the record has w1 and no w2.
#[test]
fn the_simulated_step_of_a_dual_pump_rig_follows_its_equations() {
    let rig = dual_rig(&[format!("displacement_2_cm3_per_rev={}", matched_d2())]);
    let c = DualPump::new(&rig).unwrap();
    let x0 = c.operating_point().state[0];
    let s = pumpcyl::response::step(&rig, 0.1, 3.0, 1000.0).unwrap();
    assert!(s.w2_rpm.is_empty() && s.w1_rpm.len() == s.time_s.len());
    assert!(s.p1_bar.len() == s.time_s.len() && s.p2_bar.len() == s.time_s.len());
    for t in [0.5, 3.0] {
        let k = (t * 1000.0) as usize;
        let linear_mm = s.x_mm[k] - s.x_mm[0];
        let rk4_mm = (simulate(&c, |_| x0 + 1e-4, t)[0] - x0) * 1e3;
        assert!(
            (linear_mm - rk4_mm).abs() < 1e-6 * 0.1 + 1e-9,
            "t {t}: linear {linear_mm} mm, equations {rk4_mm} mm"
        );
    }
    // the rest of a step and the drive's torque rating checked on the one motor
    assert!((s.x_mm.last().unwrap() - s.x_mm[0] - 0.1).abs() < 5e-3);
    let over = pumpcyl::response::signals_over_ratings(&rig, &s);
    assert!(over.is_empty(), "{over:?}");
}

#[test]
fn responses_of_a_single_pump_rig_are_refused_not_answered_with_another_circuit() {
    let rig = Rig::default()
        .with_overrides(&["circuit=single-pump".into()])
        .unwrap();
    let e = pumpcyl::response::step(&rig, 5.0, 3.0, 100.0)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("circuit = \"single-pump\"") && e.contains("only so far"),
        "{e}"
    );
}
