//! Step 14, "What each circuit costs": the energy of the article's application on every
//! circuit of the report. The article calls the pump-controlled cylinder "a highly
//! energy-efficient solution due to the absence of fluid throttling" (its introduction) but
//! measures no energy; here the article's three tracking sines (its Figures 16–18: 0.10 Hz
//! ±50 mm, 0.20 Hz ±35 mm, 0.25 Hz ±20 mm, two periods each, then 2 s at rest) run on the
//! emulated rig of each Figure 1 circuit of step 11 (at the article's K_p 25) and of step 13's
//! valve (at the largest K_p meeting the article's margins), every effect on and the sensors
//! noise-free, with the power account of docs/energy.md.
//!
//! Every number is what `pumpcyl cycle --no-noise --set …` prints for the assignments listed in
//! summary.json (`set`; tests/reproduce/energy.rs runs them), and it rests on pumpcyl's loss
//! defaults (ideal drives without a return path, no pump friction, a pressure-compensated valve
//! supply), named in `defaults_assumed` and in the report.

use super::valve_or_pump::{ValveOrPump, SUPPLY_BAR};
use super::{figure1_circuits, Run, Source};
use crate::figures::{Chart, Plot};
use crate::format::fmt_short;
use crate::plot::{LineStyle, Panel, Trace};
use crate::request::cycle::{CycleKind, CycleOutcome, CycleRequest};
use crate::request::{Document, Hooks, Request, RigInput};
use anyhow::{Context, Result};
use pumpcyl::emulator::cycle::{CycleEnergy, DriveDuty};
use pumpcyl::rig::Rig;
use pumpcyl::source_files::Disk;
use rayon::prelude::*;
use serde::Serialize;
use serde_json::Value;
use std::collections::BTreeMap;

/// A published energy saving of a pump-controlled cylinder against its valve-controlled
/// original, for the plausibility comparison.
#[derive(Debug, Clone, Serialize)]
pub struct Published {
    /// Where it is published.
    pub source: &'static str,
    /// The saving, a share of the valve circuit's energy.
    pub saving_fraction: f64,
}

/// The savings the literature reports.
pub const PUBLISHED: [Published; 1] = [Published {
    source: "Padovani et al., Actuators 2019, 8(4), 78 (a self-contained electro-hydraulic cylinder against its valve-controlled original)",
    saving_fraction: 0.62,
}];

/// One circuit's duty cycle.
#[derive(Debug, Clone, Serialize)]
pub struct CircuitCycle {
    /// The circuit in words.
    pub label: String,
    /// Its circuit key.
    pub circuit: String,
    /// The `--set` assignments that make its rig from the default rig (the article's Table 1).
    pub set: Vec<String>,
    /// The cycle's energy in figures (what `pumpcyl cycle --json` prints as `summary`).
    pub summary: CycleEnergy,
    /// Each kind of loss over the cycle (J).
    pub losses_j: BTreeMap<&'static str, f64>,
    /// The largest tracking error over the cycle, |x_ref − x| of the record (mm): what the
    /// energy bought.
    pub max_error_mm: f64,
    /// Each motor's duty against its ratings; none for the valve.
    pub drives: Vec<DriveDuty>,
    /// The loss keys the energies rest on at pumpcyl's defaults (docs/energy.md#the-drives).
    pub defaults_assumed: Value,
    /// The run's warnings (cavitation, ratings).
    pub warnings: Vec<String>,
}

/// Step 14's numbers (summary.json `energy`).
#[derive(Debug, Clone, Serialize)]
pub struct EnergyStudy {
    /// The duty cycle (`pumpcyl cycle`'s `article-sines`).
    pub cycle: String,
    /// Whether the sensors were noisy (no: `--no-noise`).
    pub noise: bool,
    /// Each circuit's cycle: the Figure 1 circuits of step 11, then step 13's valve.
    pub circuits: Vec<CircuitCycle>,
    /// What the article's DPM saves against the valve over the cycle, a share of the valve's
    /// net energy.
    pub dpm_saves_vs_valve_fraction: f64,
    /// The savings the literature reports, for comparison.
    pub published: Vec<Published>,
}

/// Step 14: the article's application on every circuit, by energy.
pub(super) fn energy_study(run: &mut Run, valve: &ValveOrPump) -> Result<EnergyStudy> {
    run.step("What each circuit costs: the energy of the article's three sines on every circuit (pumpcyl's own study, answering the article's introduction; docs/energy.md)");
    let sides = sides(valve)?;
    let circuits = (sides.par_iter())
        .map(|(label, set)| circuit_cycle(label, set))
        .collect::<Result<Vec<_>>>()?;
    let net = |c: &CircuitCycle| c.summary.net_j;
    let valve_net = circuits.last().map_or(f64::NAN, net);
    let study = EnergyStudy {
        cycle: CycleKind::ArticleSines.name(),
        noise: false,
        dpm_saves_vs_valve_fraction: 1.0 - net(&circuits[0]) / valve_net,
        circuits,
        published: PUBLISHED.to_vec(),
    };
    report(run, &study)?;
    Ok(study)
}

/// The circuits costed: the Figure 1 circuits of step 11 and the valve of step 13 with β_e of
/// the rig's oil at its rest, at its largest K_p meeting the article's margins.
fn sides(valve: &ValveOrPump) -> Result<Vec<(String, Vec<String>)>> {
    let mut sides = figure1_circuits::circuits(&Rig::default());
    let own = valve.sides.get(1).context("step 13 has no valve side")?;
    let mut set = own.set.clone();
    set.push(format!("kp={}", own.kp_max));
    sides.push((
        format!("valve, {SUPPLY_BAR} bar supply (K_p {:.3})", own.kp_max),
        set,
    ));
    Ok(sides)
}

/// One circuit's cycle, as `pumpcyl cycle --no-noise --set …` runs it.
fn circuit_cycle(label: &str, set: &[String]) -> Result<CircuitCycle> {
    let rig = Rig::default()
        .with_overrides(set)
        .with_context(|| format!("the energy study's rig {set:?}"))?;
    let request = CycleRequest {
        rig: RigInput {
            rig,
            name: format!("default rig, {}", set.join(", ")),
            defaulted: None,
        },
        cycle: CycleKind::ArticleSines,
        effects: true,
        noise: false,
        seed: 0,
        allow_long_run: false,
        files: &Disk,
    };
    let outcome: CycleOutcome = request.run(Hooks::none())?;
    let signals = &outcome.run().emulation.signals;
    let account =
        (outcome.run().emulation.energy.as_ref()).context("the cycle ran without its account")?;
    Ok(CircuitCycle {
        label: label.to_string(),
        circuit: request.rig.rig.circuit.name().to_string(),
        set: set.to_vec(),
        summary: outcome.energy().clone(),
        losses_j: account.losses_j.iter().copied().collect(),
        max_error_mm: (signals.x_ref_mm.iter().zip(&signals.x_mm))
            .map(|(r, x)| (r - x).abs())
            .fold(0.0, f64::max),
        drives: outcome.run().drives.clone(),
        defaults_assumed: outcome.assumed(),
        warnings: outcome.warnings().to_vec(),
    })
}

/// The section's text, table, figure and comparison row.
fn report(run: &mut Run, s: &EnergyStudy) -> Result<()> {
    run.text(&explanation(s));
    run.table(
        "The article's three sines (two periods each, then 2 s at rest; 40 s) on each circuit, every effect on, noise-free sensors (emulated): energy drawn from the supply, the load's work, the largest losses and the motors' duty",
        &HEADER,
        s.circuits.iter().map(row).collect(),
    );
    run.figure(
        "energy_per_circuit",
        Source::Own,
        "What each circuit costs over the article's three sines (answering its introduction's \"absence of fluid throttling\"): the losses by kind, stacked, for every circuit (top) and for the pump circuits alone (bottom)",
        &chart(s),
    )?;
    let dpm = &s.circuits[0];
    let valve = s.circuits.last().context("no valve")?;
    run.compare_why(
        "Introduction: energy of the application, DPM against the valve-controlled cylinder (net J over the three sines; saving)",
        format!(
            "{:.0} J against {:.0} J: {:.0} % less",
            dpm.summary.net_j,
            valve.summary.net_j,
            100.0 * s.dpm_saves_vs_valve_fraction
        ),
        "\"a highly energy-efficient solution due to the absence of fluid throttling\" (no number); the literature: about 62 % less (Padovani et al. 2019)",
        "-",
        &format!("plausibility, not a test: the application lifts nothing (zero external force), so the valve's {SUPPLY_BAR} bar supply is throttled almost whole, where the published savings are of loaded machines; the valve, at the article's margins, tracks the sines far worse (the table's max |e|), so it moves less for its energy; and every loss model is at pumpcyl's defaults (ideal drives and pumps, no return path), docs/energy.md"),
    );
    Ok(())
}

const HEADER: [&str; 9] = [
    "circuit",
    "max |e| (mm)",
    "drawn (J)",
    "net (J)",
    "peak (W)",
    "load's work (J)",
    "largest losses (J)",
    "motors: RMS / rated torque (N m)",
    "warnings",
];

/// A circuit's row.
fn row(c: &CircuitCycle) -> Vec<String> {
    let s = &c.summary;
    let mut losses: Vec<(&&str, &f64)> = c.losses_j.iter().collect();
    losses.sort_by(|a, b| b.1.total_cmp(a.1));
    let largest = (losses.iter().take(3))
        .map(|(k, j)| format!("{k} {j:.1}"))
        .collect::<Vec<_>>()
        .join(", ");
    let motors = (c.drives.iter())
        .map(|d| {
            format!(
                "{:.2} / {}",
                d.rms_torque_nm,
                fmt_short(d.rated_torque_nm, 4)
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    vec![
        c.label.clone(),
        format!("{:.1}", c.max_error_mm),
        format!("{:.1}", s.drawn_j),
        format!("{:.1}", s.net_j),
        format!("{:.1}", s.peak_power_w),
        format!("{:.1}", s.load_work_j),
        largest,
        if motors.is_empty() {
            "-".into()
        } else {
            motors
        },
        c.warnings.len().to_string(),
    ]
}

/// What the section shows, with the defaults the numbers rest on.
fn explanation(s: &EnergyStudy) -> String {
    let assumed: Vec<String> = (s.circuits.iter())
        .filter_map(|c| c.defaults_assumed.as_object())
        .flat_map(|o| o.iter().map(|(k, v)| format!("{k} = {v}")))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    format!(
        "The article's three tracking sines run on the emulated rig of every circuit of this report (emulated data, not measurements): the Figure 1 circuits of step 11 at K_p 25 and the valve of step 13 at the largest K_p meeting the article's margins, every effect on, noise-free sensors, each integrated with its power account (docs/energy.md#over-a-run; `pumpcyl cycle --no-noise --set …` with the assignments in summary.json gives each row). The article's DPM draws {:.0} J where the valve draws {:.0} J, and the valve buys less with it: at the article's margins its velocity-loop gain is a fraction of the DPM's (step 13), so it follows the sines with errors up to {:.0} mm against the DPM's {:.0} mm. The numbers rest on pumpcyl's loss defaults, which the article does not give: {} for the drives (ideal, no return path: what a drive brakes is burnt in its brake resistor), and a pressure-compensated valve supply (it delivers the flow the valve passes at {SUPPLY_BAR} bar; docs/energy.md#the-valve-s-supply). The article's Kp-25 controller and its sum-pressure set-point keep the DPM's leakage flowing all cycle; see docs/energy.md for each loss's law.",
        s.circuits[0].summary.net_j,
        s.circuits.last().map_or(f64::NAN, |c| c.summary.net_j),
        s.circuits.last().map_or(f64::NAN, |c| c.max_error_mm),
        s.circuits[0].max_error_mm,
        assumed.join(", "),
    )
}

/// Stacked bars of each circuit's losses by kind: every circuit, then the pump circuits alone.
fn chart(s: &EnergyStudy) -> Chart {
    let kinds = kinds(s);
    let all: Vec<&CircuitCycle> = s.circuits.iter().collect();
    let pumps: Vec<&CircuitCycle> = all
        .iter()
        .copied()
        .filter(|c| !c.drives.is_empty())
        .collect();
    Chart {
        title: "Losses over the article's three sines, by circuit (emulated)".into(),
        subtitle: Some("pumpcyl's loss defaults; noise-free sensors; 40 s".into()),
        plot: Plot::Categories {
            x_label: "circuit".into(),
            categories: all.iter().map(|c| short(&c.label)).collect(),
            panels: vec![
                panel("every circuit (J)", &all, s, &kinds),
                panel("the pump circuits (J)", &pumps, s, &kinds),
            ],
        },
    }
}

/// The kinds of loss drawn, largest overall first; kinds below 1 % of every circuit's losses
/// join `other`.
fn kinds(s: &EnergyStudy) -> Vec<Vec<&'static str>> {
    let share = |k: &str| {
        (s.circuits.iter())
            .map(|c| c.losses_j.get(k).copied().unwrap_or(0.0) / c.summary.losses_j.max(1e-12))
            .fold(0.0, f64::max)
    };
    let mut named: Vec<&'static str> = (s.circuits.iter())
        .flat_map(|c| c.losses_j.keys().copied())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    named.sort_by(|a, b| share(b).total_cmp(&share(a)));
    let (big, small): (Vec<_>, Vec<_>) = named.into_iter().partition(|k| share(k) >= 0.01);
    let mut kinds: Vec<Vec<&'static str>> = big.into_iter().map(|k| vec![k]).collect();
    if !small.is_empty() {
        kinds.push(small);
    }
    kinds
}

/// One panel: for each kind (tallest total first), the bars of the running totals up to it.
fn panel(y_label: &str, circuits: &[&CircuitCycle], s: &EnergyStudy, kinds: &[Vec<&str>]) -> Panel {
    let position = |c: &CircuitCycle| {
        (s.circuits.iter())
            .position(|d| d.label == c.label)
            .unwrap_or(0) as f64
            + 1.0
    };
    let total = |c: &CircuitCycle, upto: usize| -> f64 {
        (kinds[..=upto].iter().flatten())
            .map(|k| c.losses_j.get(k).copied().unwrap_or(0.0))
            .sum()
    };
    let traces = (0..kinds.len())
        .rev()
        .map(|k| Trace {
            label: match kinds[k].len() {
                1 => kinds[k][0].to_string(),
                _ => "other".to_string(),
            },
            t_s: circuits.iter().map(|c| position(c)).collect(),
            y: circuits.iter().map(|c| total(c, k)).collect(),
            style: LineStyle::Bars,
            color: Some(k),
        })
        .collect();
    Panel {
        y_label: y_label.into(),
        traces,
        ..Default::default()
    }
}

/// A circuit's label up to its parenthesis, for the axis.
fn short(label: &str) -> String {
    label.split(" (").next().unwrap_or(label).to_string()
}
