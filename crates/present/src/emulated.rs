//! An emulated record as every front end asks for it and shows it (`pumpcyl emulate`, Python's
//! `emulate`; docs/emulator.md): the request, its run and its document; and what the emulator
//! used on a rig, in words: `emulate`, the emulator FMU and `reproduce` each say it where they
//! run the emulator (docs/emulator.md#what-a-user-rig-gets).

use crate::plot::sig;
use pumpcyl::cavitation::FloorHit;
use pumpcyl::circuit::CircuitKind;
use pumpcyl::emulator::article::{self, Emulated, Kind, Truth};
use pumpcyl::emulator::{
    beta_anchor_bar, DriveStep, Effects, EmulatorError, EndStopHit, Experiment, Plc, RunError,
    DRIVE_RATE_HZ, DRIVE_RECORD_S, PLC_RATE_HZ,
};
use pumpcyl::limits::Work;
use pumpcyl::response::Signals;
use pumpcyl::rig::{Rig, PUMP_DEAD_BAND_RPM};
use pumpcyl::source_files::FieldError;
use pumpcyl::units::{readable, RAD_S_PER_RPM};
use serde_json::{json, Value};

/// Which experiment to emulate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExperimentKind {
    /// A position step of the closed loop.
    Step,
    /// A sinusoidal reference of the closed loop.
    Sine,
    /// A speed step of one drive, decoupled from its pump.
    DriveStep,
    /// The closed loop holding still.
    Standstill,
    /// A logarithmic chirp of the closed loop about x0.
    Chirp,
    /// A periodic multisine of the closed loop about x0.
    Multisine,
    /// A stepped sine of the closed loop about x0.
    SteppedSine,
}

impl ExperimentKind {
    /// Every experiment, in the order the command line lists them.
    pub const ALL: [ExperimentKind; 7] = [
        Self::Step,
        Self::Sine,
        Self::DriveStep,
        Self::Standstill,
        Self::Chirp,
        Self::Multisine,
        Self::SteppedSine,
    ];

    /// The experiment's name, as the command line's `--experiment` and Python's `experiment`
    /// take it.
    pub fn name(self) -> &'static str {
        match self {
            ExperimentKind::Step => "step",
            ExperimentKind::Sine => "sine",
            ExperimentKind::DriveStep => "drive-step",
            ExperimentKind::Standstill => "standstill",
            ExperimentKind::Chirp => "chirp",
            ExperimentKind::Multisine => "multisine",
            ExperimentKind::SteppedSine => "stepped-sine",
        }
    }

    /// What the experiment does, in one line: the command line's help of its `--experiment`
    /// value.
    pub fn help(self) -> &'static str {
        match self {
            ExperimentKind::Step => "Position step of the closed loop",
            ExperimentKind::Sine => "Sinusoidal position reference",
            ExperimentKind::DriveStep => {
                "One drive alone, decoupled from its pump, feedforward off: a speed step"
            }
            ExperimentKind::Standstill => "The reference held: the pumps only feed the leakage",
            ExperimentKind::Chirp => {
                "Logarithmic chirp about x0 (docs/identification.md#frequency-response-from-a-sweep)"
            }
            ExperimentKind::Multisine => "Periodic multisine about x0, Schroeder phases",
            ExperimentKind::SteppedSine => "Stepped sine about x0",
        }
    }

    /// The experiment named `name`, if there is one.
    pub fn named(name: &str) -> Option<ExperimentKind> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// An emulated record asked for: the experiment and its settings (mm, s, Hz, rpm), the PLC's
/// sample rate and noise. `None` takes the experiment's default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Request {
    /// The experiment.
    pub experiment: ExperimentKind,
    /// Start of a step (mm); default x0.
    pub from_mm: Option<f64>,
    /// End of a step (mm); default x0 + 10 mm.
    pub to_mm: Option<f64>,
    /// Time of the step or the start of the sine (s).
    pub at_s: f64,
    /// Sine amplitude (mm); default [`SINE_AMPLITUDE_MM`].
    pub amplitude_mm: Option<f64>,
    /// Sine frequency (Hz).
    pub freq_hz: f64,
    /// The drive of a drive step (1 or 2).
    pub motor: usize,
    /// Speed a drive step goes to (rpm).
    pub to_rpm: f64,
    /// Record length (s).
    pub duration_s: Option<f64>,
    /// PLC sample rate (Hz).
    pub rate_hz: Option<f64>,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Whether the PLC's sensors add the article's noise.
    pub noise: bool,
    /// The excitation of a sweep experiment (chirp, multisine, stepped sine), built for the
    /// rig and rate (`pumpcyl frf --design` gives its defaults); `None` for the others.
    pub sweep: Option<pumpcyl::frf::Excitation>,
    /// Whether the closed loop's run integrates the rig's power account beside its states
    /// (docs/energy.md#over-a-run): the record is the same either way.
    pub energy: bool,
}

/// A sine's amplitude when none is given (mm).
pub const SINE_AMPLITUDE_MM: f64 = 20.0;

impl Request {
    /// The PLC sampling the record: the drive records' rate for a drive step, the article's
    /// PLC rate otherwise, unless `rate_hz` is given; the article's noise unless `noise` is off.
    pub fn plc(&self) -> Result<Plc, FieldError> {
        let default_rate = match self.experiment {
            ExperimentKind::DriveStep => DRIVE_RATE_HZ,
            _ => PLC_RATE_HZ,
        };
        let rate_hz = self.rate_hz.unwrap_or(default_rate);
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(FieldError::new(
                "rate_hz",
                format!("rate_hz = {rate_hz}: must be > 0"),
            ));
        }
        let base = if self.noise {
            article::plc(self.seed)
        } else {
            Plc::ideal(rate_hz)
        };
        Ok(Plc {
            rate_hz,
            seed: self.seed,
            energy: self.energy,
            ..base
        })
    }

    /// The experiment on `rig` sampled at `rate_hz`, checked; an error names the setting at
    /// fault.
    pub fn plan(&self, rig: &Rig, rate_hz: f64) -> Result<Kind, FieldError> {
        let (at, d) = (self.at_s, self.duration_s);
        let plan = match self.experiment {
            ExperimentKind::Step => {
                Kind::Loop(Experiment::step(rig, self.from_mm, self.to_mm, at, d))
            }
            ExperimentKind::Sine => Kind::Loop(Experiment::sine(
                rig,
                self.amplitude_mm.unwrap_or(SINE_AMPLITUDE_MM),
                self.freq_hz,
                at,
                d,
            )),
            ExperimentKind::Chirp | ExperimentKind::Multisine | ExperimentKind::SteppedSine => {
                let sweep = self.sweep.ok_or_else(|| {
                    FieldError::new("sweep", "a sweep experiment needs its excitation")
                })?;
                Kind::Loop(Experiment::Sweep(sweep))
            }
            ExperimentKind::Standstill => Kind::Loop(Experiment::standstill(rig, d)),
            ExperimentKind::DriveStep => Kind::Drive(DriveStep {
                motor: self.motor,
                from_rpm: 0.0,
                to_rpm: self.to_rpm,
                at_s: at,
                duration_s: d.unwrap_or(DRIVE_RECORD_S),
            }),
        };
        match &plan {
            Kind::Loop(e) => e.check(rig, rate_hz)?,
            Kind::Drive(d) => d.check(rate_hz)?,
        }
        Ok(plan)
    }
}

/// The record length (s) of a plan, for the work limit.
pub fn duration_s(plan: &Kind) -> f64 {
    match plan {
        Kind::Loop(e) => e.duration_s(),
        Kind::Drive(d) => d.duration_s,
    }
}

/// The controller steps of a closed-loop plan at `rate_hz` (what [`run`] reports as progress);
/// 0 for a drive record, which takes no noticeable time.
pub fn steps(plan: &Kind, rate_hz: f64) -> u64 {
    match plan {
        Kind::Loop(e) => e.steps(rate_hz),
        Kind::Drive(_) => 0,
    }
}

/// What a run of a plan gives: the record and, for the closed loop, the first end stop it met
/// and the first chamber at the cavitation floor.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The record.
    pub data: Emulated,
    /// The first end stop the piston met (docs/emulator.md#end-stops).
    pub end_stop: Option<EndStopHit>,
    /// The first chamber at the cavitation floor (docs/emulator.md#cavitation).
    pub cavitation: Option<FloorHit>,
    /// The energies of a closed-loop run that asked for them (docs/energy.md#over-a-run).
    pub energy: Option<pumpcyl::circuit::energy::Energy>,
}

/// Run a plan on the truth ([`Outcome`]); `work.progress(n)` as `n` more of its [`steps`] are
/// done, the closed loop stopped when its integrator's work goes beyond the limit unless `work`
/// allows a long run (docs/emulator.md#the-work-limit).
pub fn run(plan: &Kind, truth: &Truth, work: &Work) -> Result<Outcome, RunError> {
    Ok(match plan {
        Kind::Loop(e) => {
            let em = e.run_reporting(&truth.rig, truth.effects, &truth.plc, work)?;
            Outcome {
                data: Emulated::Loop(em.signals),
                end_stop: em.end_stop,
                cavitation: em.cavitation,
                energy: em.energy,
            }
        }
        Kind::Drive(_) => Outcome {
            data: plan.run(truth)?,
            end_stop: None,
            cavitation: None,
            energy: None,
        },
    })
}

/// An emulated run with what every front end says of it: its outcome, its warnings
/// ([`warnings`]) and the emulator's basis in words ([`basis`]).
#[derive(Debug, Clone)]
pub struct Emulation {
    /// The run's record, end stop and cavitation.
    pub outcome: Outcome,
    /// Its warnings, one line each.
    pub warnings: Vec<String>,
    /// The emulator's basis, one sentence.
    pub basis: String,
}

/// Run a plan on the truth ([`run`]) with its warnings and basis, as `pumpcyl emulate` and
/// Python's `emulate` do.
///
/// # Errors
/// As [`run`]; a rig whose loop cannot rest at x0 (its basis names β_e there).
pub fn emulate(plan: &Kind, truth: &Truth, work: &Work) -> Result<Emulation, RunError> {
    let outcome = run(plan, truth, work)?;
    let basis = basis(&truth.rig, &truth.effects).map_err(RunError::Emulator)?;
    Ok(Emulation {
        warnings: warnings(&truth.rig, &outcome),
        outcome,
        basis,
    })
}

impl Emulation {
    /// Its document ([`emulated_json`]) as an `experiment` on the rig `origin` (in words) of
    /// the circuit `circuit`.
    pub fn document(
        &self,
        experiment: ExperimentKind,
        origin: &str,
        circuit: CircuitKind,
    ) -> Value {
        let mut doc = emulated_json(
            experiment,
            (origin, circuit),
            &self.outcome.data,
            &self.basis,
            &self.warnings,
            self.outcome.end_stop.as_ref(),
        );
        if let Some(e) = &self.outcome.energy {
            doc["energy"] = energy_json(e);
        }
        doc
    }
}

/// A run's energies as the `energy` object of `emulate --json` (docs/energy.md#over-a-run):
/// `energy_in_j` (what the sources delivered: the drives' shaft power τ·ω, or a valve's
/// supply), `sources_j`, `work_out_j`, `losses_j` and `stored_j` by kind, `stored_change_j`
/// and `imbalance_j` (sources − work − losses − stored, zero but for rounding).
pub fn energy_json(e: &pumpcyl::circuit::energy::Energy) -> Value {
    let by_kind = |list: &[(&'static str, f64)]| -> Value {
        list.iter()
            .map(|(k, j)| (k.to_string(), json!(j)))
            .collect::<serde_json::Map<_, _>>()
            .into()
    };
    let sum = |list: &[(&'static str, f64)]| list.iter().map(|(_, j)| j).sum::<f64>();
    json!({
        "energy_in_j": sum(&e.sources_j),
        "sources_j": by_kind(&e.sources_j),
        "work_out_j": e.work_out_j,
        "losses_j": by_kind(&e.losses_j),
        "stored_j": by_kind(&e.stored_j),
        "stored_change_j": sum(&e.stored_j),
        "imbalance_j": e.imbalance_j(),
    })
}

/// The warnings of an emulated run on `rig`: the drive ratings a closed-loop record exceeds
/// (docs/simulation.md#drive-ratings), one line each, and the first chamber at the cavitation
/// floor; none for a drive record.
pub fn warnings(rig: &Rig, run: &Outcome) -> Vec<String> {
    let signals = match &run.data {
        Emulated::Loop(s) => Some(s),
        Emulated::Drive(_) => None,
    };
    run_warnings(rig, signals, run.cavitation)
}

/// [`warnings`] of a run on `rig` with the closed-loop `signals` (none for a drive record) and
/// the first chamber at the cavitation floor, if any.
pub fn run_warnings(
    rig: &Rig,
    signals: Option<&Signals>,
    cavitation: Option<FloorHit>,
) -> Vec<String> {
    let mut lines = signals.map_or_else(Vec::new, |s| {
        crate::documents::rating_warning_lines(
            "emulated",
            &pumpcyl::response::signals_over_ratings(rig, s),
        )
    });
    lines.extend(cavitation.map(|hit| format!("emulated: {hit}")));
    lines.extend(pumpcyl::circuit::valves::relief_warning(rig));
    lines
}

/// An emulated record's columns by name, those its CSV holds, in its order
/// (docs/formats.md#record-csv, #drive-record-csv).
pub fn columns(data: &Emulated) -> Vec<(&str, &[f64])> {
    match data {
        Emulated::Loop(s) => loop_columns(s),
        Emulated::Drive(d) => vec![
            ("time_s", &d.time_s[..]),
            ("w_ref_rpm", &d.w_ref_rpm[..]),
            ("w_rpm", &d.w_rpm[..]),
        ],
    }
}

/// The document of an emulated record (`pumpcyl emulate --json`, Python's `emulate`): the
/// experiment, the rig in words, its circuit (`dpm`, `dual-pump`, `single-pump`), the number
/// of samples, the emulator's basis in words
/// ([`basis`]), the drive-rating warnings, the end stop met (or `null`) and the record's columns
/// ([`columns`]: those of its CSV).
pub fn emulated_json(
    experiment: ExperimentKind,
    (rig, circuit): (&str, CircuitKind),
    data: &Emulated,
    basis: &str,
    warnings: &[String],
    end_stop: Option<&EndStopHit>,
) -> Value {
    json!({
        "experiment": experiment.name(),
        "rig": rig,
        "circuit": circuit.name(),
        "samples": data.len(),
        "basis": basis,
        "warnings": warnings,
        "end_stop": end_stop.map(|hit| hit.to_string()),
        "columns": columns_json(&columns(data)),
    })
}

/// A closed-loop record's columns by name ([`Signals::record_columns`]).
pub fn loop_columns(s: &Signals) -> Vec<(&str, &[f64])> {
    (s.record_columns().into_iter())
        .map(|(n, v)| (n, &v[..]))
        .collect()
}

/// A record's columns ([`columns`], [`loop_columns`]) as a JSON object, each a list of numbers.
pub fn columns_json(columns: &[(&str, &[f64])]) -> Value {
    (columns.iter())
        .map(|(n, v)| (n.to_string(), json!(v)))
        .collect::<serde_json::Map<String, Value>>()
        .into()
}

/// One sentence naming the emulator's bulk modulus (β_e and the pressure where it holds, the gas
/// fraction), its mass law and its limits and defaults on `rig` with `effects`.
///
/// # Errors
/// A rig whose loop cannot rest at x0 (the pressure where β_e holds is its rest's).
pub fn basis(rig: &Rig, effects: &Effects) -> Result<String, EmulatorError> {
    let Some(x) = effects.gas_fraction else {
        return Ok(format!(
            "emulator effects off: beta_e {} bar constant (the rig's beta_bar), mass {} kg \
             constant, no limits, friction only viscous",
            readable(rig.beta_bar),
            readable(rig.mass_kg)
        ));
    };
    let p_mean = beta_anchor_bar(rig)?;
    // the DPM's sentence as it always was; a single-motor circuit's names its own level and
    // valves (docs/emulator.md#every-circuit)
    let d = rig.circuit.description();
    let valves = (d.valves)
        .map(|v| format!("; circuit {}: {v} (docs/circuits.md#valves)", d.name))
        .unwrap_or_default();
    let anchor = d.level.words;
    Ok(format!(
        "emulator: beta_e {:.1} bar at {}, {:.2} bar \
         (gas fraction X = {:.5}, beta_oil {} bar), beta_e(p) of both chambers' mean pressure{}; \
         {}; chamber volumes following the piston; {}{} N Coulomb friction ({}){valves} \
         (docs/emulator.md#what-a-user-rig-gets)",
        effects.bulk_model.beta_bar(x, p_mean, effects.beta_oil_bar),
        anchor,
        p_mean,
        x,
        readable(effects.beta_oil_bar),
        effects.bulk_model.unless_the_articles(),
        mass_law(rig, effects),
        if d.drives > 0 {
            drives_and_pumps(rig, effects)
        } else {
            String::new()
        },
        sig(effects.coulomb_n, 4),
        source(
            "coulomb_friction_n",
            rig.coulomb_friction_n.is_some(),
            "the article rig's 15 N x (d1 + d2) / 99 mm"
        ),
    ))
}

/// Where an emulator effect's value comes from: its key when the rig sets it, its default's
/// rule when it does not.
fn source(key: &str, set: bool, default: &str) -> String {
    if set {
        key.to_string()
    } else {
        format!("default: {default}")
    }
}

/// The emulator's drive and pump limits, pump dead band and slip on `rig` in words, each with
/// its key or its default's rule (docs/emulator.md#what-a-user-rig-gets), up to the Coulomb
/// friction that follows: a circuit without drives has none of them.
fn drives_and_pumps(rig: &Rig, effects: &Effects) -> String {
    let band_rpm = effects.dead_band_rad_s / RAD_S_PER_RPM;
    format!(
        "torque limited to {} x the rated {} N m, pump speed to {} rpm; {} rpm pump dead band ({}) \
         with slip {} m^5/(N s) ({}) and ",
        effects
            .peak_torque_factor
            .map_or("no limit".into(), readable),
        readable(rig.motor_rated_torque_nm),
        readable(rig.pump_max_speed_rpm),
        sig(band_rpm, 4),
        source(
            "pump_dead_band_rpm",
            rig.pump_dead_band_rpm != PUMP_DEAD_BAND_RPM,
            "the article rig's"
        ),
        sig(effects.slip_m5_per_ns, 4),
        source(
            "pump_slip_m5_per_ns",
            rig.pump_slip_m5_per_ns.is_some(),
            "the article rig's 4e-11 x c12 / 1.2e-10"
        ),
    )
}

/// The emulator's mass law on `rig`, in words.
fn mass_law(rig: &Rig, effects: &Effects) -> String {
    let t = &rig.mass_by_position;
    if !effects.stroke_mass || t.len() < 2 {
        return format!("mass {} kg constant over the stroke", readable(rig.mass_kg));
    }
    format!(
        "mass {} kg at x0 following the rig's mass_by_position ({} points, {} to {} mm)",
        readable(rig.mass_kg),
        t.len(),
        readable(t[0].x_mm),
        readable(t[t.len() - 1].x_mm)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The basis names the drives' and pumps' limits of a circuit with drives, and of the
    /// valve-controlled cylinder only what it has: nothing of the article's motors leaks in.
    #[test]
    fn the_basis_names_only_what_the_circuit_has() {
        for (circuit, drives) in [("dpm", true), ("single-pump", true), ("valve", false)] {
            let rig = Rig::default()
                .with_overrides(&[format!("circuit={circuit}")])
                .unwrap();
            let text = basis(&rig, &Effects::for_rig(&rig).unwrap()).unwrap();
            for words in ["torque limited", "pump speed", "pump dead band", "slip"] {
                assert_eq!(text.contains(words), drives, "{circuit}: {words} in {text}");
            }
            assert!(text.contains("N Coulomb friction (default: "), "{text}");
        }
    }
}
