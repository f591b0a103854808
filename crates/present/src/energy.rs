//! Energies as text (docs/energy.md): a run's account, and a duty cycle's figures and its
//! drives' duty.

use crate::format::fmt_short;
use pumpcyl::circuit::energy::Energy;
use pumpcyl::circuit::CircuitKind;
use pumpcyl::emulator::cycle::{CycleEnergy, CycleRun};
use pumpcyl::select::energy::SelectionEnergy;
use serde_json::Value;
use std::fmt::Write;

/// A run's energies as lines of text: what the sources delivered, the work against the load,
/// each loss and each stored energy's change (J; docs/energy.md#over-a-run).
pub fn energy_text(e: &Energy) -> String {
    let line = |(kind, j): &(&'static str, f64)| format!("    {kind:<26} {j:>14.4} J\n");
    let list = |l: &[(&'static str, f64)]| l.iter().map(line).collect::<String>();
    format!(
        "energy over the record (docs/energy.md#over-a-run):\n  delivered\n{}  work against the load {:.4} J\n  losses\n{}  stored (change)\n{}  imbalance {:.3e} J\n",
        list(&e.sources_j),
        e.work_out_j,
        list(&e.losses_j),
        list(&e.stored_j),
        e.imbalance_j()
    )
}

/// A duty cycle `(cycle, rig)` in words: its energy figures, the account by kind, each motor's
/// duty against its ratings, and the electrical keys it assumed at pumpcyl's defaults.
///
/// # Errors
/// Never: the text is built in memory.
pub fn cycle_text(
    (cycle, rig): (&str, &str),
    c: &CycleEnergy,
    (run, assumed): (&CycleRun, &Value),
) -> anyhow::Result<String> {
    let mut s = format!(
        "duty cycle {cycle} on {rig}, {:.2} s (emulated data, not a measurement)\n\
         drawn {:.2} J, returned {:.2} J, net {:.2} J (mean {:.2} W, peak {:.1} W)\n\
         load's work {:.2} J, efficiency {:.1} %, work against the external force {:.2} J\n",
        c.duration_s,
        c.drawn_j,
        c.regenerated_j,
        c.net_j,
        c.mean_power_w,
        c.peak_power_w,
        c.load_work_j,
        100.0 * c.efficiency,
        c.work_out_j,
    );
    if let Some(e) = &run.emulation.energy {
        s += &energy_text(e);
    }
    for d in &run.drives {
        let verdict = match d.exceeds.is_empty() {
            true => "fits".to_string(),
            false => format!("TOO SMALL ({})", d.exceeds.join(", ")),
        };
        writeln!(
            s,
            "motor {}: torque RMS {:.2} / rated {} N m, peak {:.2} / {} N m; speed RMS {:.0}, peak {:.0} / rated {} rpm: {verdict}",
            d.motor,
            d.rms_torque_nm,
            fmt_short(d.rated_torque_nm, 4),
            d.peak_torque_nm,
            fmt_short(d.peak_torque_limit_nm, 4),
            d.rms_speed_rpm,
            d.peak_speed_rpm,
            fmt_short(d.rated_speed_rpm, 2)
        )?;
    }
    if let Some(keys) = assumed.as_object().filter(|k| !k.is_empty()) {
        let named: Vec<String> = keys.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        writeln!(
            s,
            "assumed (pumpcyl's defaults, docs/energy.md#the-drives): {}",
            named.join(", ")
        )?;
    }
    Ok(s)
}

/// A selection's circuits by their duty cycle's energy (docs/select.md#energy), in lines.
pub fn selection_energy_text(e: &SelectionEnergy) -> String {
    let mut s = format!("energy over the duty cycle ({}; emulated):\n", e.cycle);
    for c in &e.circuits {
        let losses: Vec<String> = (c.losses_j.iter())
            .filter(|(_, j)| j.abs() >= 0.005 * c.energy.drawn_j)
            .map(|(k, j)| format!("{k} {j:.0} J"))
            .collect();
        let meets = if c.meets { "" } else { " (does not meet)" };
        s += &format!(
            "  {}{meets} at {} bar, Kp {}: net {:.1} J (drawn {:.1}, returned {:.1}), peak {:.0} W; {}\n",
            c.circuit.name(),
            fmt_short(c.mean_pressure_bar, 2),
            fmt_short(c.kp, 2),
            c.energy.net_j,
            c.energy.drawn_j,
            c.energy.regenerated_j,
            c.energy.peak_power_w,
            losses.join(", ")
        );
    }
    let name = |k: Option<CircuitKind>| k.map_or("none".to_string(), |k| k.name().to_string());
    match e.chosen_over_cheapest_j {
        Some(_) if e.chosen == e.cheapest => {
            s += &format!(
                "  the chosen {} is the cheapest that meets\n",
                name(e.chosen)
            )
        }
        Some(over) => {
            s += &format!(
            "  the chosen {} costs {over:.1} J per cycle more than the cheapest that meets, {}\n",
            name(e.chosen),
            name(e.cheapest)
        )
        }
        None => {}
    }
    let valve_note = match e.valve_meets {
        Some(false) => ", which does not meet the requirement",
        _ => "",
    };
    match (e.chosen_saves_vs_valve_j, e.chosen_saves_vs_valve_fraction) {
        (Some(j), Some(f)) if j >= 0.0 => {
            s += &format!(
                "  against the valve-controlled cylinder{valve_note} it saves {j:.1} J per cycle ({:.0} %)\n",
                100.0 * f
            )
        }
        (Some(j), Some(f)) => {
            s += &format!(
                "  it costs {:.1} J per cycle ({:.0} %) more than the valve-controlled cylinder{valve_note}\n",
                -j,
                -100.0 * f
            )
        }
        _ => s += "  no valve-controlled cylinder to compare with (--circuits …,valve)\n",
    }
    s
}
