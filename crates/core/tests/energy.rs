//! The power account closes (docs/energy.md): at any state of any circuit's emulated
//! equations, what the sources deliver equals the work against the external force, the losses
//! and the rates of the stored energies, to rounding; and each term is what a hand calculation
//! from its part's law gives where one is easy to write.

use pumpcyl::circuit::energy::Power;
use pumpcyl::emulator::{Dynamics, Effects};
use pumpcyl::rig::Rig;

/// The rigs: the article's, and a rig of our own in each circuit (every effect on; the drives'
/// electrical losses and the pumps' torque losses too).
fn rigs() -> Vec<(String, Rig)> {
    let own = "piston_diameter_mm = 80.0\nrod_diameter_mm = 45.0\nstroke_mm = 800.0\n\
               x0_mm = 400.0\nmass_kg = 2500.0\nmass_by_position = []\nbeta_bar = 300.0\n\
               kp = 15.0\nviscous_friction_ns_per_m = 250.0\nc12_m5_per_ns = 2.0e-10\n\
               external_force_n = 3000.0\nmotor_winding_resistance_ohm = 0.6\n\
               motor_torque_constant_nm_per_a = 1.2\ndrive_efficiency = 0.93\n\
               drive_regeneration_fraction = 0.5\npump_friction_torque_fraction = 0.03\n\
               pump_viscous_torque_nms_per_rad = 2e-4\n";
    let valve = "circuit = \"valve\"\npiston_diameter_mm = 80.0\nrod_diameter_mm = 45.0\n\
                 stroke_mm = 400.0\nx0_mm = 150.0\nmass_kg = 2500.0\nbeta_bar = 8000.0\n\
                 supply_pressure_bar = 180.0\nvalve_rated_flow_lpm = 40.0\n\
                 valve_null_leakage_lpm = 4.0\nexternal_force_n = 15000.0\n\
                 tank_pressure_bar = 2.0\ncylinder_leakage_m5_per_ns = 1e-12\nkp = 2.0\n\
                 mass_by_position = []\nsupply_flow_lpm = 25.0\n";
    let mut out = vec![("article".to_string(), Rig::default())];
    for circuit in ["dpm", "dual-pump", "single-pump"] {
        let text = format!("{own}circuit = \"{circuit}\"\n");
        out.push((
            circuit.into(),
            Rig::from_toml_str(&text, "own.toml").unwrap(),
        ));
    }
    out.push((
        "valve".into(),
        Rig::from_toml_str(valve, "valve.toml").unwrap(),
    ));
    out
}

/// A deterministic stream of numbers in [0, 1).
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    fn within(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// A state near `rest` of the circuit's kind of signals, each moved by a random amount on its
/// own scale: positions across and beyond the stroke (the end stops), speeds both ways,
/// pressures from the cavitation floor to hundreds of bar.
fn state_near(d: &Dynamics, rest: &[f64], rig: &Rig, r: &mut Stream) -> Vec<f64> {
    use pumpcyl::circuit::{Circuit, Role};
    let stroke = rig.stroke_mm * 1e-3;
    (d.circuit().states().iter().zip(rest))
        .map(|(s, &x0)| match s.role {
            Role::Position => r.within(-0.01, stroke + 0.01),
            Role::Velocity => r.within(-0.3, 0.3),
            Role::Pressure => r.within(-1.0e5, 2.0e7),
            Role::MotorSpeed => r.within(-400.0, 400.0),
            Role::Torque => r.within(-40.0, 40.0),
            _ => x0 * r.within(0.5, 1.5) + r.within(-1.0, 1.0),
        })
        .collect()
}

fn sum(list: &[(&'static str, f64)]) -> f64 {
    list.iter().map(|(_, w)| w).sum()
}

#[test]
fn the_account_closes_at_random_states_of_every_circuit() {
    let mut r = Stream(7);
    for (name, rig) in rigs() {
        let d = Dynamics::new(&rig, Effects::for_rig(&rig).unwrap()).unwrap();
        let (rest, u0) = d.operating_point();
        for k in 0..2000 {
            let x = state_near(&d, &rest, &rig, &mut r);
            let u = [
                u0[0] + r.within(-300.0, 300.0),
                u0[1] + r.within(-300.0, 300.0),
            ];
            let p = d.power(&x, &u);
            let (imbalance, scale) = (p.imbalance_w(), p.scale_w());
            assert!(
                imbalance.abs() <= 1e-9 * scale,
                "{name} state {k}: imbalance {imbalance:e} W of {scale:e} W\n{p:#?}"
            );
            assert!(
                sum(&p.sources_w).is_finite() && scale > 0.0,
                "{name}: {p:?}"
            );
            for (kind, w) in &p.losses_w {
                // a loss never gives energy back, but for the speed limit's rounding
                assert!(*w >= -1e-9 * scale, "{name} state {k}: loss {kind} = {w} W");
            }
        }
    }
}

/// At a DPM rig's rest nothing moves: the drives deliver what the leakages lose, which is
/// `select`'s standing loss at the rest's pressures (docs/select.md), and nothing is stored at
/// a rate.
#[test]
fn at_rest_the_drives_feed_the_standing_loss_select_prices() {
    for (name, rig) in rigs()
        .into_iter()
        .filter(|(n, _)| n == "article" || n == "dpm")
    {
        let d = Dynamics::new(&rig, Effects::none()).unwrap();
        let (x, u) = d.operating_point();
        let p = d.power(&x, &u);
        let loss = pumpcyl::select::standing_loss(&rig, [x[2] / 1e5, x[3] / 1e5]);
        let standing = loss.electrical_power_w;
        assert!(standing > 1.0, "{name}: {standing} W");
        // the hydraulic loss is what the leakages take; the drives' own losses come on top
        let leakage = p.losses_w.iter().find(|(k, _)| *k == "leakage").unwrap().1;
        assert!(
            (leakage - loss.power_w).abs() <= 1e-6 * loss.power_w,
            "{name}"
        );
        assert_eq!(standing > loss.power_w * 1.01, name == "dpm", "{name}");
        let drives = sum(&p.sources_w);
        assert!(
            (drives - standing).abs() <= 1e-6 * standing,
            "{name}: {drives} W, {standing} W"
        );
        for (kind, w) in &p.stored_w {
            assert!(w.abs() <= 1e-6 * standing, "{name}: stored {kind} = {w} W");
        }
        assert_eq!(p.work_out_w, 0.0, "{name}");
    }
}

/// The DPM circuit at constant velocity with every effect off, its drives at the speeds that
/// feed the chambers: each loss is its law by hand (c·Δp², b·v², D·ω·Δp − q·Δp) and the work
/// out is F_ext·v.
#[test]
fn the_losses_are_their_laws_by_hand() {
    let rig = Rig {
        external_force_n: 2000.0,
        ..Rig::default()
    };
    let d = Dynamics::new(&rig, Effects::none()).unwrap();
    let (mut x, u) = d.operating_point();
    let si = rig.si();
    let (v, p1, p2) = (0.05, 30.0e5, 12.0e5);
    x[1] = v;
    x[2] = p1;
    x[3] = p2;
    let p: Power = d.power(&x, &u);
    let get = |list: &[(&'static str, f64)], kind: &str| {
        list.iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, w)| *w)
            .unwrap()
    };
    let leaks = si.c1 * p1 * p1 + si.c2 * p2 * p2 + si.c12 * (p1 - p2) * (p1 - p2);
    assert!((get(&p.losses_w, "leakage") - leaks).abs() <= 1e-12 * leaks);
    let viscous = rig.viscous_friction_ns_per_m * v * v;
    assert!((get(&p.losses_w, "viscous_friction") - viscous).abs() <= 1e-12 * viscous);
    assert_eq!(p.work_out_w, 2000.0 * v);
    // ideal pumps (no dead band, no slip): nothing lost in them
    assert_eq!(get(&p.losses_w, "pump_slip_and_dead_band"), 0.0);
    // the default electrical side is lossless and burns what the bus returns
    let (w1, w2, tau1, tau2) = (x[4], x[5], x[6], x[7]);
    let shafts = tau1 * w1 + tau2 * w2;
    let net = get(&p.sources_w, "electrical") - get(&p.losses_w, "brake_resistor");
    assert!((net - shafts).abs() <= 1e-12 * shafts.abs().max(1.0));
    assert_eq!(get(&p.losses_w, "copper"), 0.0);
    assert_eq!(get(&p.losses_w, "drive_electronics"), 0.0);
}

/// The drives' electrical side by hand (docs/energy.md#the-drives), on the DPM with one drive
/// motoring and the other braking: the copper loss R·(τ/k_t)², the electronics' (1/η − 1) of
/// what a motoring drive's terminals take and (1 − η) of what a braking one's give, the two
/// drives' DC powers netted on their common bus, and of the bus's net braking the regenerated
/// share returned and the rest burnt.
#[test]
fn the_electrical_losses_are_their_laws_by_hand() {
    let text = "motor_winding_resistance_ohm = 0.4\nmotor_torque_constant_nm_per_a = 1.5\n\
                drive_efficiency = 0.9\ndrive_regeneration_fraction = 0.25\n";
    let rig = Rig::from_toml_str(text, "electric.toml").unwrap();
    let d = Dynamics::new(&rig, Effects::none()).unwrap();
    let (mut x, u) = d.operating_point();
    let get = |list: &[(&'static str, f64)], kind: &str| {
        list.iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, w)| *w)
            .unwrap()
    };
    // drive 2 braking a little (the bus draws) or hard (the bus returns)
    for w2 in [150.0, 300.0] {
        let [w1, tau1, tau2] = [100.0, 10.0, -8.0];
        (x[4], x[5], x[6], x[7]) = (w1, w2, tau1, tau2);
        let p: Power = d.power(&x, &u);
        let copper = |tau: f64| 0.4 * (tau / 1.5) * (tau / 1.5);
        let dc1 = (tau1 * w1 + copper(tau1)) / 0.9;
        let dc2 = (tau2 * w2 + copper(tau2)) * 0.9;
        let bus = dc1 + dc2;
        let close = |got: f64, want: f64| (got - want).abs() <= 1e-12 * want.abs().max(1.0);
        assert!(close(
            get(&p.losses_w, "copper"),
            copper(tau1) + copper(tau2)
        ));
        let electronics = (dc1 - tau1 * w1 - copper(tau1)) + (dc2 - tau2 * w2 - copper(tau2));
        assert!(close(get(&p.losses_w, "drive_electronics"), electronics));
        assert!(close(get(&p.sources_w, "electrical"), bus.max(0.0)));
        assert!(close(get(&p.sources_w, "regenerated"), 0.25 * bus.min(0.0)));
        assert!(close(
            get(&p.losses_w, "brake_resistor"),
            -0.75 * bus.min(0.0)
        ));
        assert!(p.imbalance_w().abs() <= 1e-9 * p.scale_w(), "{w2}: {p:?}");
        assert_eq!(bus < 0.0, w2 == 300.0, "{bus}");
    }
}

/// Over a run the energies are integrated with the states (docs/energy.md#over-a-run): the
/// states exactly as without the account, the account closing to rounding, and the stored
/// energies equal to their state functions' changes — ½·m·v² of the load (a constant mass)
/// and ½·J·ω² of each drive — to 1e-6 of the energy the sources delivered: the quadrature is
/// the integrator's own fourth order.
#[test]
fn over_a_run_the_energies_close_and_the_stored_ones_are_their_state_functions() {
    use pumpcyl::circuit::energy::Energy;
    use pumpcyl::circuit::{Circuit, Role};
    use pumpcyl::emulator::{hold_speeds, hold_speeds_accounting};
    for (name, rig) in rigs().into_iter().filter(|(n, _)| n != "article") {
        let d = Dynamics::new(&rig, Effects::none()).unwrap();
        let (rest, u0) = d.operating_point();
        let states = d.circuit().states();
        let at = |role: Role| {
            (states.iter().enumerate())
                .filter(move |(_, s)| s.role == role)
                .map(|(i, _)| i)
        };
        let v = at(Role::Velocity).next().unwrap();
        let speeds: Vec<usize> = at(Role::MotorSpeed).collect();
        // a command step, held for 0.4 s in PLC intervals of 10 ms
        let u = match name.as_str() {
            "valve" => [u0[0] + 0.2, 0.0],
            _ => [u0[0] + 40.0, u0[1] - 25.0],
        };
        let (mut plain, mut counted) = (rest.clone(), rest.clone());
        let mut energy = Energy::default();
        for k in 0..40 {
            let (t0, t1) = (k as f64 * 0.01, (k + 1) as f64 * 0.01);
            plain = hold_speeds(&d, &plain, u, t0, t1).unwrap();
            counted = hold_speeds_accounting(&d, &counted, u, (t0, t1), &mut energy).unwrap();
            assert_eq!(
                plain, counted,
                "{name}: the states change with the account at {t1} s"
            );
        }
        let delivered: f64 = energy.sources_j.iter().map(|(_, j)| j.abs()).sum();
        assert!(delivered > 1.0, "{name}: {energy:?}");
        assert!(
            energy.imbalance_j().abs() <= 1e-9 * delivered,
            "{name}: {energy:?}"
        );
        let kinetic = |x: &[f64]| 0.5 * rig.mass_kg * x[v] * x[v];
        let load = kinetic(&counted) - kinetic(&rest);
        let got = energy.of("load_motion");
        assert!(
            (got - load).abs() <= 1e-6 * delivered,
            "{name}: load motion {got} J, ½mv² {load} J"
        );
        if name == "dpm" {
            // each drive's motor-plus-pump inertia (RigSi::j)
            let j = rig.si().j;
            let spin = |x: &[f64]| {
                (speeds.iter().zip(j))
                    .map(|(&i, j)| 0.5 * j * x[i] * x[i])
                    .sum::<f64>()
            };
            let drives = spin(&counted) - spin(&rest);
            let got = energy.of("drive_motion");
            assert!(drives.abs() > 1e-3 * delivered, "{name}: {drives} J");
            assert!(
                (got - drives).abs() <= 1e-6 * delivered,
                "{name}: drive motion {got} J, ½Jω² {drives} J; {energy:?}"
            );
        }
    }
}

/// A standstill duty cycle (docs/energy.md#duty-cycles), the reference held, effects and noise
/// off: its mean power is what `select` prices as the standing loss at the rest's pressures,
/// the drives' electrical losses included, on the article's rig and on a DPM rig of our own
/// whose drives lose in their windings and electronics.
#[test]
fn a_standstill_cycle_costs_selects_standing_loss() {
    use pumpcyl::emulator::cycle::{self, Cycle};
    use pumpcyl::emulator::Plc;
    use pumpcyl::limits::Work;
    for (name, rig) in rigs()
        .into_iter()
        .filter(|(n, _)| n == "article" || n == "dpm")
    {
        let d = Dynamics::new(&rig, Effects::none()).unwrap();
        let held = Cycle::Table {
            time_s: vec![0.0, 3.0],
            x_ref_mm: vec![rig.x0_mm; 2],
            force_n: None,
        };
        let plc = Plc::ideal(100.0);
        let run = cycle::run(&rig, &d, &plc, (1.0, &held), &Work::QUIET).unwrap();
        let e = run.energy().unwrap();
        // the loop's own rest (the PLC's), as its record measures it without noise
        let s = &run.emulation.signals;
        let loss = pumpcyl::select::standing_loss(&rig, [s.p1_bar[0], s.p2_bar[0]]);
        let want = loss.electrical_power_w;
        assert!(
            (e.mean_power_w - want).abs() <= 1e-6 * want,
            "{name}: {} W over the cycle, {want} W standing",
            e.mean_power_w
        );
        assert!((e.peak_power_w - want).abs() <= 1e-6 * want, "{name}");
        assert!(e.load_work_j.abs() <= 1e-12 * e.drawn_j, "{name}");
    }
}

/// The pumps' torque losses by hand (docs/energy.md#the-pumps), on the DPM with the rig's own
/// effects: each pump's friction torque C_f·D·|Δp|·tanh(ω/0.6 rad/s) + b_p·ω times its speed,
/// and the drives carry it: at a state where each drive's torque equals its pumps' load, the
/// speed's rate is zero only with the friction in the load.
#[test]
fn the_pumps_torque_losses_are_their_law_by_hand() {
    let text = "pump_friction_torque_fraction = 0.04\npump_viscous_torque_nms_per_rad = 3e-4\n";
    let rig = Rig::from_toml_str(text, "pumps.toml").unwrap();
    let d = Dynamics::new(&rig, Effects::for_rig(&rig).unwrap()).unwrap();
    let (mut x, u) = d.operating_point();
    let si = rig.si();
    let (p1, p2, w) = (25.0e5, 9.0e5, [-40.0, 90.0]);
    (x[2], x[3], x[4], x[5]) = (p1, p2, w[0], w[1]);
    let dp = [p1 - p2, p1];
    let friction = |i: usize| 0.04 * si.d[i] * dp[i].abs() * (w[i] / 0.6).tanh() + 3e-4 * w[i];
    // the drives' torques at their loads: no acceleration
    (x[6], x[7]) = (dp[0] * si.d[0] + friction(0), dp[1] * si.d[1] + friction(1));
    let p: Power = d.power(&x, &u);
    let get = |kind: &str| p.losses_w.iter().find(|(k, _)| *k == kind).unwrap().1;
    let want = friction(0) * w[0] + friction(1) * w[1];
    assert!(
        (get("pump_friction") - want).abs() <= 1e-12 * want.abs(),
        "{p:?}"
    );
    let mut dx = vec![0.0; x.len()];
    d.rhs(&x, &u, &mut dx);
    for i in [4, 5] {
        assert!(dx[i].abs() <= 1e-9, "drive {}: {} rad/s²", i - 3, dx[i]);
    }
    assert!(p.imbalance_w().abs() <= 1e-9 * p.scale_w());
}

/// A valve's fixed-displacement supply by hand (docs/energy.md#the-valve): at rest it delivers
/// its flow at the supply pressure, the lands draw the underlap's, and the relief valve spills
/// the rest, (p_s − p_t)·(Q_pump − Q_lands) of heat; `select`'s standing cost is the whole
/// pump's (p_s − p_t)·Q_pump.
#[test]
fn a_fixed_supply_spills_its_excess_through_the_relief_valve() {
    let (_, rig) = rigs().into_iter().find(|(n, _)| n == "valve").unwrap();
    let d = Dynamics::new(&rig, Effects::none()).unwrap();
    let (x, u) = d.operating_point();
    let p = d.power(&x, &u);
    let get =
        |list: &[(&'static str, f64)], kind: &str| list.iter().find(|(k, _)| *k == kind).unwrap().1;
    let (ps, pt, pump) = (180.0e5, 2.0e5, 25.0e-3 / 60.0);
    let supply = get(&p.sources_w, "supply");
    assert!((supply - ps * pump).abs() <= 1e-9 * supply, "{p:?}");
    let rest = rig.circuit.supply_rest(&rig).unwrap();
    let spilled = (ps - pt) * (pump - rest.flow_m3_s);
    assert!(rest.flow_m3_s > 0.0 && spilled > 0.0, "{rest:?}");
    assert!(
        (get(&p.losses_w, "supply_relief") - spilled).abs() <= 1e-6 * spilled,
        "{p:?}"
    );
    // select's standing cost of the valve (docs/select.md#cost-of-the-valve-controlled-cylinder)
    assert!((rest.power_w - (ps - pt) * pump).abs() <= 1e-9 * rest.power_w);
}

/// Drive sizing's RMS torque is the torque's square integrated with the account
/// (docs/energy.md#drive-sizing), not sampled at the PLC's instants: over a cycle of steps with
/// the PLC's noisy commands (the drives' current loops answer each new command within a
/// millisecond) the motors' RMS torques give back the copper loss R·∫(τ/k_t)² dt that the
/// account integrates under its error control, on the DPM and dual-pump rigs of our own; and no
/// RMS exceeds its peak.
#[test]
fn the_rms_torque_gives_back_the_copper_loss() {
    use pumpcyl::emulator::article;
    use pumpcyl::emulator::cycle::{self, Cycle};
    use pumpcyl::limits::Work;
    for (name, rig) in rigs()
        .into_iter()
        .filter(|(n, _)| n == "dpm" || n == "dual-pump")
    {
        let d = Dynamics::new(&rig, Effects::for_rig(&rig).unwrap()).unwrap();
        let steps = Cycle::Steps {
            centre_mm: rig.x0_mm,
            amplitude_mm: 20.0,
            hold_s: 1.5,
        };
        let run = cycle::run(&rig, &d, &article::plc(7), (1.0, &steps), &Work::QUIET).unwrap();
        let t = &run.emulation.signals.time_s;
        let seconds = t[t.len() - 1] - t[0];
        let copper = run.emulation.energy.as_ref().unwrap().of("copper");
        let r_per_kt2 = rig.circuit_key("motor_winding_resistance_ohm")
            / rig.circuit_key("motor_torque_constant_nm_per_a").powi(2);
        let from_rms: f64 = (run.drives.iter())
            .map(|m| r_per_kt2 * m.rms_torque_nm.powi(2) * seconds)
            .sum();
        assert!(copper > 0.1, "{name}: {copper} J of copper loss");
        assert!(
            (from_rms - copper).abs() <= 1e-5 * copper,
            "{name}: the RMS torques give {from_rms} J, the account {copper} J"
        );
        for m in &run.drives {
            assert!(m.rms_torque_nm <= m.peak_torque_nm, "{name}: {m:?}");
            assert!(m.rms_speed_rpm <= m.peak_speed_rpm, "{name}: {m:?}");
        }
    }
}
