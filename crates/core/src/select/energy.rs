//! What the circuits of a selection cost over the application's duty cycle
//! (docs/select.md#energy): each circuit's lowest level that meets the requirement (or, where
//! none does, its lowest with a gain, for comparison), at its largest gain, run through the
//! application's waves on the emulated rig with its power account; the cheapest that meets,
//! and what the chosen circuit costs against it and saves against the valve-controlled
//! cylinder.

use super::{lowest_meeting, lowest_where, Candidate, Circuit, Requirement, Selection};
use crate::circuit::CircuitKind;
use crate::emulator::cycle::{self, Cycle, CycleEnergy, DriveDuty, SINE_PERIODS};
use crate::emulator::{Dynamics, Effects, Plc, RunError, PLC_RATE_HZ, SETTLE_S};
use crate::limits::Work;
use crate::rig::Rig;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// One circuit's duty cycle: its lowest meeting level and gain, the cycle's energy and losses by
/// kind, and its motors' duty.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CircuitEnergy {
    /// The circuit (in JSON `circuit`, `circuit_kind`, `pressure_level`).
    #[serde(flatten)]
    pub circuit: Circuit,
    /// Its level (bar): the lowest that meets, refined for the chosen circuit.
    pub mean_pressure_bar: f64,
    /// The gain the cycle runs at (1/m): the candidate's largest.
    pub kp: f64,
    /// Whether this level meets the requirement; a circuit with no level that does is costed
    /// at its lowest level with a gain, for comparison.
    pub meets: bool,
    /// The cycle's energy in figures.
    pub energy: CycleEnergy,
    /// Each kind of loss over the cycle (J).
    pub losses_j: BTreeMap<&'static str, f64>,
    /// Each motor's duty; none for the valve.
    pub drives: Vec<DriveDuty>,
}

/// The selection's circuits by their cycle's energy.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SelectionEnergy {
    /// The duty cycle, in words.
    pub cycle: String,
    /// Each circuit of the selection, in its order of circuits: at its lowest meeting level,
    /// or, where none meets, at its lowest level with a gain (`meets` false).
    pub circuits: Vec<CircuitEnergy>,
    /// The circuit of the answer.
    pub chosen: Option<CircuitKind>,
    /// The circuit that meets whose cycle costs least (net energy).
    pub cheapest: Option<CircuitKind>,
    /// What the chosen circuit's cycle costs beyond the cheapest's (J; 0 when it is the
    /// cheapest).
    pub chosen_over_cheapest_j: Option<f64>,
    /// What the chosen circuit saves against the valve-controlled cylinder over the cycle (J),
    /// where the selection tried a valve (whether or not it meets: `circuits` says).
    pub chosen_saves_vs_valve_j: Option<f64>,
    /// The same as a share of the valve's net energy.
    pub chosen_saves_vs_valve_fraction: Option<f64>,
    /// Whether the valve compared with meets the requirement; `None` without a valve.
    pub valve_meets: Option<bool>,
}

/// The application's duty cycle: its waves about the rig's x0, [`SINE_PERIODS`] periods each.
fn duty_cycle(rig: &Rig, req: &Requirement) -> Cycle {
    Cycle::Sines {
        centre_mm: rig.x0_mm,
        sines: req.waves.iter().map(|w| (w.freq_hz, w.amp_mm)).collect(),
        periods: SINE_PERIODS,
    }
}

/// Each circuit's candidate to cost: the chosen circuit's refined level, every other circuit's
/// lowest meeting level, and a circuit with none its lowest level with a gain.
fn costed(selection: &Selection) -> Vec<&Candidate> {
    let options = &selection.options;
    (CircuitKind::ALL.into_iter())
        .filter_map(|kind| {
            let at = selection.at_min_mean_pressure.as_ref();
            let lowest = lowest_meeting(options, kind)
                .or_else(|| lowest_where(options, kind, |c| c.kp_max > 0.0));
            (at.filter(|c| c.circuit.kind == kind)).or(lowest.map(|k| &options[k]))
        })
        .collect()
}

/// One candidate's cycle on its rig at the reference gas fraction, its gain the largest.
fn cost(
    rig: &Rig,
    req: &Requirement,
    c: &Candidate,
    work: &Work,
) -> Result<CircuitEnergy, RunError> {
    let p = c.mean_pressure_bar;
    let beta = rig.bulk_model().beta_bar(
        req.gas_fraction,
        c.circuit.beta_pressure_bar(rig, p),
        req.beta_oil_bar,
    );
    let at = Rig {
        kp: c.kp_max,
        ..c.circuit.rig_at(rig, p, beta)
    };
    let effects = Effects::for_rig(&at)?;
    let dynamics = Dynamics::new(&at, effects)?;
    let cycle = duty_cycle(&at, req);
    let run = cycle::run(
        &at,
        &dynamics,
        &Plc::ideal(PLC_RATE_HZ),
        (SETTLE_S, &cycle),
        work,
    )?;
    let account = run.emulation.energy.clone().unwrap_or_default();
    Ok(CircuitEnergy {
        circuit: c.circuit,
        mean_pressure_bar: p,
        kp: c.kp_max,
        meets: c.meets,
        energy: run
            .energy()
            .ok_or_else(|| RunError::Emulator("no energy account".into()))?,
        losses_j: account.losses_j.into_iter().collect(),
        drives: run.drives,
    })
}

/// Each circuit of `selection` at its lowest meeting level (or, where none meets, its lowest
/// with a gain), run through the application's duty cycle (its waves about x0, two periods
/// each; noise off, every effect on), and what the chosen circuit costs against the cheapest
/// that meets and saves against the valve (docs/select.md#energy).
///
/// # Errors
/// A candidate's emulation fails, or goes beyond `work`'s limit.
pub fn of_selection(
    rig: &Rig,
    req: &Requirement,
    selection: &Selection,
    work: &Work,
) -> Result<SelectionEnergy, RunError> {
    // the circuits are independent: one per thread
    let circuits = (costed(selection).par_iter())
        .map(|c| cost(rig, req, c, work))
        .collect::<Result<Vec<_>, _>>()?;
    let net = |kind: CircuitKind| {
        (circuits.iter())
            .find(|c| c.circuit.kind == kind)
            .map(|c| c.energy.net_j)
    };
    let cheapest = (circuits.iter().filter(|c| c.meets))
        .min_by(|a, b| a.energy.net_j.total_cmp(&b.energy.net_j))
        .map(|c| c.circuit.kind);
    let chosen = selection.chosen_circuit;
    let chosen_net = chosen.and_then(net);
    // the valve-controlled cylinder, compared with a chosen pump circuit
    let valve = (circuits.iter())
        .find(|c| c.circuit.kind.description().drives == 0)
        .filter(|_| chosen.is_some_and(|k| k.description().drives > 0));
    let valve_net = valve.map(|c| c.energy.net_j);
    let saves = chosen_net.zip(valve_net).map(|(c, v)| v - c);
    Ok(SelectionEnergy {
        cycle: format!(
            "the application's waves about x0, {SINE_PERIODS} periods each, then {} s at rest; \
             the reference gas fraction, each circuit's largest gain, noise off",
            cycle::SINES_REST_S
        ),
        chosen_over_cheapest_j: chosen_net.zip(cheapest.and_then(net)).map(|(c, m)| c - m),
        chosen_saves_vs_valve_fraction: saves.zip(valve_net).map(|(s, v)| s / v),
        chosen_saves_vs_valve_j: saves,
        valve_meets: valve.map(|c| c.meets),
        circuits,
        chosen,
        cheapest,
    })
}
