//! The emulator on every circuit (docs/emulator.md#every-circuit): each circuit started at its
//! rest stays there; a matched dual-pump circuit moving at constant speed keeps its chamber
//! pressures; the single-pump circuit far above its switching force follows mode 1's linear
//! step, and at rest sits in the mode the docs state on either side of the switching force; and
//! the emulator's chatter prediction on the article's application (docs/circuits.md#will-it-chatter).

use pumpcyl::circuit::dual_pump::DualPump;
use pumpcyl::circuit::single_pump::modes::{closed_loop, switching, Mode};
use pumpcyl::circuit::{Circuit, CircuitKind};
use pumpcyl::emulator::{chatter, emulate, equilibrium, hold_speeds, Dynamics, Effects, Plc};
use pumpcyl::rig::Rig;

/// The article's rig as a circuit of `kind`, with `sets` applied.
fn article(kind: CircuitKind, sets: &[String]) -> Rig {
    let mut all = vec![format!("circuit={}", kind.name())];
    all.extend_from_slice(sets);
    Rig::default().with_overrides(&all).unwrap()
}

/// tests/user-rig.toml as a circuit of `kind` (the single-pump circuit has no second pump: its
/// displacement line left out).
fn user(kind: CircuitKind) -> Rig {
    let text = std::fs::read_to_string("tests/user-rig.toml").unwrap();
    let text: String = (text.lines())
        .filter(|l| kind != CircuitKind::SinglePump || !l.starts_with("displacement_2"))
        .map(|l| format!("{l}\n"))
        .collect();
    let rig = Rig::from_toml_str(&text, "user-rig.toml").unwrap();
    rig.with_overrides(&[format!("circuit={}", kind.name())])
        .unwrap()
}

/// `rig` at a gain its loop is stable at: its own `kp`, or the design method's largest gain
/// meeting the default targets where that is lower (a valve's gains are far below the pump
/// circuits', docs/circuits.md#valve).
fn stable(rig: Rig) -> Rig {
    let kp = pumpcyl::design::kp_max(&rig, &pumpcyl::design::Targets::default()).unwrap();
    Rig {
        kp: rig.kp.min(kp),
        ..rig
    }
}

/// Every circuit, on the article's rig and the user rig, every effect on and off, started at
/// the rest of its loop with the reference held: the piston moves less than 1e-9 m in 10 s.
#[test]
fn every_circuit_at_rest_stays_there() {
    for kind in CircuitKind::ALL {
        for rig in [article(kind, &[]), user(kind)].map(stable) {
            for effects in [Effects::none(), Effects::for_rig(&rig).unwrap()] {
                let d = Dynamics::new(&rig, effects).unwrap();
                let s = emulate(&rig, &d, &Plc::ideal(100.0), 0.0, 10.0, |_| rig.x0_mm)
                    .unwrap()
                    .signals;
                let drift_m = (s.x_mm.iter())
                    .map(|x| (x - s.x_mm[0]).abs() * 1e-3)
                    .fold(0.0, f64::max);
                assert!(drift_m < 1e-9, "{kind:?} {effects:?}: {drift_m} m");
                // the record has one speed column per motor, and a mode for the single pump
                let drives = kind.description().drives;
                let n = s.time_s.len();
                let column = |k: usize| if drives >= k { n } else { 0 };
                assert_eq!((s.w1_rpm.len(), s.w2_rpm.len()), (column(1), column(2)));
                let modes = kind == CircuitKind::SinglePump;
                assert_eq!(s.mode.len(), if modes { s.time_s.len() } else { 0 });
                // the record reads back: no speed column for a motor it lacks, the mode column
                // passed over as a record's extra columns are (docs/formats.md#record-csv)
                let csv = pumpcyl_present::records::record_csv(&s);
                assert_eq!(csv.lines().next().unwrap().ends_with(",mode"), modes);
                let rec = pumpcyl::record::Record::parse(csv.as_bytes(), "r.csv").unwrap();
                let absent = (rec.w1_rpm.is_none(), rec.w2_rpm.is_none());
                assert_eq!((absent, rec.len()), ((drives < 1, drives < 2), n));
            }
        }
    }
}

/// A matched dual-pump circuit (D2/D1 = A1/A2 − 1) driven at a constant shaft speed from its
/// steady motion keeps its chamber pressures while the piston moves 40 mm: the emulated
/// equations' pressures stay at the closed-form balance's (docs/circuits.md#steady-motion),
/// which for a matched circuit differ from the rest only by the friction b v the pressures
/// carry (hand calculation below).
#[test]
fn a_matched_dual_pump_at_constant_speed_keeps_its_pressures() {
    let base = article(CircuitKind::DualPump, &[]);
    let si = base.si();
    let d2 = base.displacement_1_cm3_per_rev * (si.a1 / si.a2 - 1.0);
    // leakage to the accumulator line on both sides and the load at the switching force keep
    // both chambers near p_acc, every valve shut
    let f_s = base.accumulator_precharge_bar * 1e5 * (si.a1 - si.a2);
    let rig = article(
        CircuitKind::DualPump,
        &[
            format!("displacement_2_cm3_per_rev={d2}"),
            "c1_m5_per_ns=2e-11".into(),
            "c2_m5_per_ns=2e-11".into(),
            format!("external_force_n={f_s}"),
        ],
    );
    let c = DualPump::new(&rig).unwrap();
    assert!(c.mismatch_m2().abs() < 1e-15 * si.a1);
    let v = 0.02;
    let moving = c.steady_motion(v);
    let bulk = c.steady_bulk(v).unwrap();
    assert_eq!(bulk.valve_flow_m3_per_s, [0.0, 0.0]);
    // hand calculation: with M = 0 the flow balances fix q1/q2 = kb/ka, the force balance their
    // size; only b v is new against the rest
    let rest = c.rest();
    let [c1, c2, c12] = [2e-11, 2e-11, si.c12];
    let r = d2 / base.displacement_1_cm3_per_rev;
    let (ka, kb) = (r * c12 - c1, r * c12 + (1.0 + r) * c2);
    let det = kb * si.a1 - ka * si.a2;
    let dp1 = kb * si.b * v / det;
    assert!(((moving.p1_pa - rest.p1_pa) / dp1 - 1.0).abs() < 1e-9);
    // the emulator, every effect off, the drive commanded at the speed that holds the motion
    let d = Dynamics::new(&rig, Effects::none()).unwrap();
    let load = c.load_torque_nm([moving.p1_pa, moving.p2_pa]);
    let km = si.km[0];
    let w_ref = moving.omega_rad_per_s + load / km;
    let mut x = vec![
        0.3,
        v,
        moving.p1_pa,
        moving.p2_pa,
        moving.omega_rad_per_s,
        load,
        w_ref,
    ];
    assert_eq!(x.len(), d.order());
    for k in 0..20 {
        let t = k as f64 * 0.1;
        x = hold_speeds(&d, &x, [w_ref, 0.0], t, t + 0.1).unwrap();
        for (i, want) in [(2, moving.p1_pa), (3, moving.p2_pa)] {
            assert!(
                (x[i] - want).abs() < 1e-6 * want,
                "t {t}: p{} {}",
                i - 1,
                x[i]
            );
        }
    }
    assert!(
        (x[0] - 0.34).abs() < 1e-9 && (x[1] - v).abs() < 1e-12,
        "{x:?}"
    );
}

/// At 10 × the switching force p_acc (A1 − A2) the emulated 5 mm step (every effect off, an
/// ideal PLC at 1 kHz) never leaves mode 1 and follows mode 1's linear step (its equations in
/// closed loop under the continuous P law) within 2 % of the step. The tolerance is the valve's:
/// mode 1 pins chamber 2 at p_acc, the emulator passes chamber 2's flow through the open
/// check valve, whose incremental resistance at the leakage it carries at rest (c1 (p1 − p_acc)
/// ≈ 110 cm³/s, 0.04 bar below p_acc) is about 4e7 Pa·s/m³; over 15 s of mode 1's lightly
/// damped pair (damping ratio 0.045) that moves the response by 1.0 % of the step
/// (docs/circuits.md#its-two-modes, measured with the continuous law), and the 1 kHz sampling
/// adds its 1 ms delay (the DPM's 2 % bound of the same comparison, docs/emulator.md).
#[test]
fn far_above_the_switching_force_the_emulated_step_follows_mode_1() {
    let f = 10.0 * switching(&article(CircuitKind::SinglePump, &[])).switching_force_n;
    let rig = article(CircuitKind::SinglePump, &[format!("external_force_n={f}")]);
    let d = Dynamics::new(&rig, Effects::none()).unwrap();
    let x0 = rig.x0_mm;
    let step = |t: f64| if t < 0.5 { x0 } else { x0 + 5.0 };
    let s = emulate(&rig, &d, &Plc::ideal(1000.0), 0.0, 15.5, step)
        .unwrap()
        .signals;
    assert!(s.mode.iter().all(|&m| m == 1.0), "left mode 1");
    let mode = Mode::new(&rig, 2);
    let op = mode.operating_point();
    let mut linear = vec![0.0];
    let x_lin0 = op.state[0];
    closed_loop(
        &mode,
        &op,
        &op.state,
        |t| step(t) * 1e-3,
        15.5,
        1e-4,
        |t, st| {
            // the emulator's samples, every tenth RK4 step of 0.1 ms
            if ((t * 1e4).round() as usize).is_multiple_of(10) {
                linear.push((st[0] - x_lin0) * 1e3);
            }
        },
    );
    let worst = (s.x_mm.iter().zip(&linear))
        .map(|(e, l)| (e - s.x_mm[0] - l).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.02 * 5.0,
        "emulated and mode 1 differ by {worst} mm"
    );
    let peak = s.x_mm.iter().fold(0.0f64, |m, x| m.max(x - s.x_mm[0]));
    assert!(peak > 5.0 && peak < 10.0, "peak {peak} mm");
}

/// The mode at rest changes at the switching force the docs state: the emulated standstill
/// (every effect on, the PLC's noise-free loop for 10 s) sits in mode 1 just above the valve
/// band [F_s − A1 Δp_crack, F_s + A2 Δp_crack] around F_s = p_acc (A1 − A2) and in mode 2 just
/// below it (docs/circuits.md#the-switching-force).
#[test]
fn the_emulated_standstill_sits_in_the_mode_of_its_side_of_the_switching_force() {
    let s = switching(&article(CircuitKind::SinglePump, &[]));
    for (force, mode) in [
        (s.valve_band_n[1] + 30.0, 1.0),
        (s.valve_band_n[0] - 30.0, 2.0),
    ] {
        let rig = article(
            CircuitKind::SinglePump,
            &[format!("external_force_n={force}")],
        );
        let d = Dynamics::new(&rig, Effects::for_rig(&rig).unwrap()).unwrap();
        let rest = equilibrium(&rig, &d, rig.x0_mm).unwrap();
        assert_eq!(d.mode(&rest), Some(mode as usize), "{force} N");
        let rec = emulate(&rig, &d, &Plc::ideal(100.0), 0.0, 10.0, |_| rig.x0_mm)
            .unwrap()
            .signals;
        assert!(rec.mode.iter().all(|&m| m == mode), "{force} N");
        // the accumulator chamber within the valve's cracking pressure of p_acc
        let p_acc = rig.accumulator_precharge_bar;
        let on = if mode == 1.0 {
            &rec.p2_bar
        } else {
            &rec.p1_bar
        };
        assert!(on
            .iter()
            .all(|p| (p - p_acc).abs() < rig.circuit_key("check_valve_crack_bar")));
    }
}

/// The emulator's chatter prediction on the article's application (single-pump circuit, Kp 25,
/// zero external force; docs/circuits.md#will-it-chatter): the 5 mm step and the three sines
/// settle without a mode switch after settling, and the step's force scan settles without any
/// switch up to 400 N and from 1000 N, switching (during the transient only) in between, the
/// band around the switching force (703 N) that the continuous-law check finds too (400 N
/// quiet, 450 N switching; tests/single_pump.rs).
#[test]
fn the_article_application_does_not_chatter_and_switches_only_near_the_switching_force() {
    let rig = article(CircuitKind::SinglePump, &[]);
    let p = chatter::predict(&rig, Effects::for_rig(&rig).unwrap()).unwrap();
    assert!(!p.chatters(), "{p:?}");
    assert_eq!((p.step.mode_at_start, p.step.switches), (Some(2), 0));
    assert!(p.step.error_amplitude_m < 1e-6, "{:?}", p.step);
    for s in &p.sines {
        assert_eq!(s.switches_after_settling, 0, "{s:?}");
    }
    let forces = [350.0, 400.0, 450.0, 700.0, 950.0, 1000.0, 1050.0];
    let runs = chatter::scan_forces(&rig, &forces).unwrap();
    let switched: Vec<bool> = runs.iter().map(|r| r.switches > 0).collect();
    assert_eq!(
        switched,
        [false, false, true, true, true, false, false],
        "{runs:?}"
    );
    assert!(runs
        .iter()
        .all(|r| r.switches_after_settling == 0 && !r.chatters));
    assert_eq!(
        chatter::quiet_ranges_n(&runs),
        [(350.0, 400.0), (1000.0, 1050.0)]
    );
    // a DPM rig is refused in one line
    let dpm = chatter::step(&Rig::default(), Effects::none())
        .unwrap_err()
        .0;
    assert!(dpm.contains("circuit = \"dpm\""), "{dpm}");
}

/// β, b and c12 come back from emulated step records of the dual-pump circuit (the linear
/// model it identifies with is the circuit's own, `model::Plant`; docs/identification.md): a
/// truth off the article's values, its steps at Kp 25 and 20 and a standstill emulated with
/// the valves in but every other effect off and a noise-free PLC at 1 kHz, the load 1 kN above
/// the switching force so every valve stays shut; the grid search over 3 × 3 × 3 values around
/// the truth (β ×/÷ 1.1, b ×/÷ 3, c12 ×/÷ 1.3) finds the truth, and the cost there is below
/// 1e-4 mm² (measured 9.8e-6 mm²: the 1 ms sampling). b is the weakly seen one: at ×/÷ 1.5 the
/// cost of b = 200 N·s/m is 8.5e-6 mm², below the truth's — the dual-pump loop's damping is
/// its leakage's, as the DPM's is (docs/identification.md).
#[test]
fn dual_pump_step_records_identify_beta_b_and_c12() {
    use pumpcyl::emulator::Experiment;
    use pumpcyl::ident::{search, Candidate, DatasetSpec, Grid, Prepared, Problem};
    use pumpcyl::ident::{SearchOptions, Standstill};
    use pumpcyl::record::Record;

    let base = article(CircuitKind::DualPump, &[]);
    let si = base.si();
    let f = base.accumulator_precharge_bar * 1e5 * (si.a1 - si.a2) + 1000.0;
    let truth = Candidate {
        beta_bar: 190.0,
        viscous_friction_ns_per_m: 300.0,
        c12_m5_per_ns: 1.2e-10,
    };
    let rig_at = |kp: f64| {
        article(
            CircuitKind::DualPump,
            &[
                format!("external_force_n={f}"),
                "c1_m5_per_ns=2e-11".into(),
                "c2_m5_per_ns=2e-11".into(),
                format!("beta_bar={}", truth.beta_bar),
                format!(
                    "viscous_friction_ns_per_m={}",
                    truth.viscous_friction_ns_per_m
                ),
                format!("c12_m5_per_ns={}", truth.c12_m5_per_ns),
                format!("kp={kp}"),
            ],
        )
    };
    let rig = rig_at(25.0);
    let rest = DualPump::emulated(&rig, Effects::none()).unwrap();
    assert_eq!(rest.steady_bulk(0.0).unwrap().valve_flow_m3_per_s, [0.0; 2]);
    let plc = Plc::ideal(1000.0);
    let record = |name: &str, e: Experiment, rig: &Rig| {
        let s = e.run(rig, Effects::none(), &plc).unwrap();
        assert!(s.w2_rpm.is_empty());
        Record::parse(pumpcyl_present::records::record_csv(&s).as_bytes(), name).unwrap()
    };
    let datasets = [(25.0, 2.7), (20.0, 2.4)]
        .into_iter()
        .map(|(kp, fit_end_s)| {
            let r = rig_at(kp);
            let name = format!("kp{kp}.csv");
            let rec = record(&name, Experiment::step(&r, None, None, 0.5, Some(3.0)), &r);
            let spec = DatasetSpec {
                file: name,
                kp,
                mass_kg: r.mass_kg,
                fit_end_s,
            };
            Prepared::new(&spec, rec, &r).unwrap()
        })
        .collect();
    let still = record("still.csv", Experiment::standstill(&rig, Some(4.0)), &rig);
    let p = Problem {
        datasets,
        standstill: Standstill::of_record(&still).unwrap(),
    };
    let around = |v: f64, k: f64| vec![v / k, v, v * k];
    let grid = Grid {
        beta_bar: around(truth.beta_bar, 1.1),
        viscous_friction_ns_per_m: around(truth.viscous_friction_ns_per_m, 3.0),
        c12_m5_per_ns: around(truth.c12_m5_per_ns, 1.3),
    };
    let opts = SearchOptions {
        top_n: 1,
        threshold_mm2: 1e-9,
        shard: None,
    };
    let best = search(&p, &grid, 1, opts, &|_| true).top[0];
    assert_eq!(best.candidate, truth, "{best:?}");
    let cost = p.cost(&truth);
    assert!(cost < 1e-4, "{cost} mm²");
}
