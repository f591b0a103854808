//! The candidates' circuits (docs/select.md#circuits): the DPM at a low or a pressurised mean
//! chamber pressure, and the one-motor circuits of the article's Figure 1 (dual pump, single
//! pump) at an accumulator pre-charge; which of them a rig's components allow; and what only
//! the one-motor circuits need: their standstill cost and, for the single-pump circuit, its
//! modes (docs/circuits.md#its-two-modes) and the check whether it keeps switching between them.

use super::{Requirement, StandingLoss, WaveRequirement, RISE_STEP_MM, RISE_WINDOW_S};
use crate::circuit::single_pump::modes::{switching, Mode, StepCheck};
use crate::circuit::single_pump::SinglePump;
use crate::circuit::CircuitKind;
use crate::design::{Targets, GM_TOLERANCE_DB, PM_TOLERANCE_DEG};
use crate::emulator::chatter::{self, ModeRun};
use crate::emulator::Effects;
use crate::lti::{FreqEvaluator, LtiError, Simulator};
use crate::rig::Rig;
use crate::units::PA_PER_BAR;
use serde::ser::SerializeMap;
use serde::{Serialize, Serializer};
use std::f64::consts::PI;

pub use crate::circuit::{PressureLevel, Variant};

/// A candidate's circuit: which circuit and how its pressure level is set, one of the
/// circuit's variants ([`crate::circuit::Description::variants`]). In JSON its keys `circuit`
/// (the variant's key: `low_pressure`, `pressurised`, `dual_pump`, `single_pump`),
/// `circuit_kind` (the rig key's name: `dpm`, `dual-pump`, `single-pump`) and
/// `pressure_level`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Circuit {
    /// The circuit.
    pub kind: CircuitKind,
    /// How its pressure level is set.
    pub level: PressureLevel,
}

impl Circuit {
    /// The article's low-pressure DPM: an accumulator's pre-charge sets the mean pressure.
    pub const LOW_PRESSURE: Circuit = Circuit {
        kind: crate::circuit::ARTICLE,
        level: PressureLevel::LowPressure,
    };

    /// Every candidate circuit, in the order a selection lists them: each circuit's variants
    /// in the order of the list of circuits.
    pub fn all() -> Vec<Circuit> {
        (CircuitKind::ALL.into_iter())
            .flat_map(|kind| {
                (kind.description().variants.iter()).map(move |v| Circuit {
                    kind,
                    level: v.level,
                })
            })
            .collect()
    }

    /// The candidate circuit of the variant named `name` (`low-pressure`, `single-pump`, …).
    pub fn named(name: &str) -> Option<Circuit> {
        Circuit::all().into_iter().find(|c| c.name() == name)
    }

    /// The circuit's variant of this pressure level.
    fn variant(self) -> &'static Variant {
        (self.kind.description().variants.iter())
            .find(|v| v.level == self.level)
            .expect("a candidate circuit is one of its circuit's variants")
    }

    /// The circuit in words: `low-pressure`, `pressurised`, `dual-pump`, `single-pump`.
    pub fn name(self) -> &'static str {
        self.variant().name
    }

    /// The JSON `circuit`: `low_pressure`, `pressurised`, `dual_pump`, `single_pump`.
    pub fn key(self) -> &'static str {
        self.variant().key
    }

    /// The application key that lists its levels.
    pub fn levels_key(self) -> &'static str {
        self.level.levels_key()
    }

    /// The rig of this circuit at the pressure level `p_bar` with the bulk modulus `beta_bar`:
    /// the DPM's sum-pressure set-point 2p, a one-motor circuit's pre-charge p, or a
    /// valve-controlled cylinder's supply p (its circuit's [`crate::circuit::Level::key`]).
    pub fn rig_at(self, rig: &Rig, p_bar: f64, beta_bar: f64) -> Rig {
        match self.level {
            PressureLevel::Precharge => self.kind.built_on(&Rig {
                beta_bar,
                accumulator_precharge_bar: p_bar,
                ..rig.clone()
            }),
            PressureLevel::Supply => {
                let mut r = Rig {
                    beta_bar,
                    ..rig.clone()
                };
                let key = self.kind.description().level.key;
                (r.circuit_keys.0).insert(key.to_string(), toml::Value::Float(p_bar));
                self.kind.built_on(&r)
            }
            _ => Rig {
                beta_bar,
                p_sum_ref_bar: 2.0 * p_bar,
                ..rig.clone()
            },
        }
    }

    /// The mean chamber pressure (bar gauge) its β_e is read at, at the level `p_bar`: the
    /// level itself, but for a supply the mean chamber pressure its valve holds at rest from
    /// it ([`crate::circuit::Module::pressure_level_bar`]), or the supply itself where the
    /// valve cannot rest there (the candidate then fails for that reason).
    pub fn beta_pressure_bar(self, rig: &Rig, p_bar: f64) -> f64 {
        let at = match self.level {
            PressureLevel::Supply => {
                (self.kind).pressure_level_bar(&self.rig_at(rig, p_bar, rig.beta_bar))
            }
            _ => p_bar,
        };
        if at.is_finite() {
            at
        } else {
            p_bar
        }
    }
}

impl Serialize for Circuit {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(3))?;
        m.serialize_entry("circuit", self.key())?;
        m.serialize_entry("circuit_kind", &self.kind)?;
        m.serialize_entry("pressure_level", &self.level)?;
        m.end()
    }
}

/// The circuits a rig's components allow (docs/select.md#circuits): those that need no more
/// drives and pumps than the rig's circuit has ([`crate::circuit::Description`]). A DPM rig
/// has two drives and two pumps, so it can be built as any of the three (the one-motor
/// circuits use drive 1 and pump 1, the dual-pump circuit pump 2 as well); a dual-pump rig has
/// one drive (its file may not name a second), so the dual- and single-pump circuits; a
/// single-pump rig has one pump, so only itself.
pub fn allowed_circuits(rig: &Rig) -> Vec<CircuitKind> {
    let has = rig.circuit.description();
    (CircuitKind::ALL.into_iter())
        .filter(|k| {
            let needs = k.description();
            needs.drives <= has.drives
                && needs.pumps <= has.pumps
                && needs.servo_valves <= has.servo_valves
        })
        .collect()
}

/// Why `kind` cannot be built from the components of `rig`, if it cannot. A circuit without
/// drives (the servo valve) can be put on any cylinder beside its own circuit, as its module
/// builds it there ([`CircuitKind::built_on`], docs/select.md#the-valve-beside-the-pumps);
/// it is tried only when named.
pub fn not_allowed(rig: &Rig, kind: CircuitKind) -> Option<String> {
    if allowed_circuits(rig).contains(&kind) || kind.description().drives == 0 {
        return None;
    }
    let has = rig.circuit.description();
    let count = |n: usize, what: &str| {
        let words = ["no", "one", "two", "three"];
        let plural = if n == 1 { "" } else { "s" };
        format!(
            "{} {what}{plural}",
            words.get(n).copied().unwrap_or("several")
        )
    };
    let mut parts = vec![count(has.drives, "drive"), count(has.pumps, "pump")];
    if has.servo_valves + kind.description().servo_valves > 0 {
        parts.push(count(has.servo_valves, "servo valve"));
    }
    let last = parts.pop().expect("two parts at least");
    let missing = format!("{} and {last}", parts.join(", "));
    Some(format!(
        "\"{}\": the rig is a {} circuit, with {missing}: it allows {} (docs/select.md#circuits)",
        kind.name(),
        rig.circuit.name(),
        (allowed_circuits(rig).iter())
            .map(|k| format!("\"{}\"", k.name()))
            .collect::<Vec<_>>()
            .join(", ")
    ))
}

/// What a single-pump candidate's mode check found (docs/select.md#the-single-pump-circuit).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeVerdict {
    /// Mode switches over every run of the check.
    pub switches: usize,
    /// Mode switches after the step settled, and a wave's in its watched periods beyond those
    /// its reference explains.
    pub switches_after_settling: usize,
    /// Half the peak-to-peak control error after the step settled (m): the amplitude of any
    /// sustained oscillation.
    pub oscillation_amplitude_m: f64,
    /// Why the candidate keeps switching modes under its load, in words; `None` when it does
    /// not.
    pub keeps_switching: Option<String>,
}

/// The check whether a single-pump candidate keeps switching modes under its load
/// (docs/select.md#the-single-pump-circuit): the application's step (and its waves) from rest
/// on a single-pump rig and the switches it makes. A trait so that either integration of the
/// circuit (the emulator's, the circuit's own equations) can answer.
pub trait ModeCheck: Sync {
    /// The verdict on the single-pump rig `rig` (at the candidate's gain, pressure, bulk
    /// modulus, load and external force) under the application's waves `waves`.
    ///
    /// # Errors
    /// The check cannot be run, in one line.
    fn run(&self, rig: &Rig, waves: &[WaveRequirement]) -> Result<ModeVerdict, String>;

    /// What the check integrates, in words (the reasons name it).
    fn describe(&self) -> String;

    /// The check's name in a selection's result (`emulator`, `equations`).
    fn name(&self) -> &'static str;

    /// The work one run of the check takes at least, in right-hand-side evaluations of the
    /// rig's equations, under the application's waves `waves`: what a selection counts
    /// against its limit (docs/select.md#work). At least: without the step's settling time,
    /// which follows the gain the selection designs.
    fn work(&self, waves: &[WaveRequirement]) -> f64;
}

/// The check on the circuit's own nonlinear equations under the continuous P law
/// ([`StepCheck::run`] on [`SinglePump::new`]): the step alone, and any switch during it keeps
/// the candidate switching — the stricter verdict, as on these equations every switching step
/// tried settled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EquationsCheck(pub StepCheck);

impl EquationsCheck {
    /// The article's 5 mm step ([`StepCheck::ARTICLE`]).
    pub const ARTICLE: EquationsCheck = EquationsCheck(StepCheck::ARTICLE);
}

impl ModeCheck for EquationsCheck {
    fn run(&self, rig: &Rig, _: &[WaveRequirement]) -> Result<ModeVerdict, String> {
        let v = self
            .0
            .run(&SinglePump::new(rig))
            .map_err(|e| e.to_string())?;
        Ok(ModeVerdict {
            switches: v.switches,
            switches_after_settling: v.switches_after_settling,
            oscillation_amplitude_m: v.amplitude_after_settling_m,
            keeps_switching: (v.switches > 0).then(|| {
                format!(
                    "{} switches during the step, {} after it settled (±{:.3} mm)",
                    v.switches,
                    v.switches_after_settling,
                    v.amplitude_after_settling_m * 1e3
                )
            }),
        })
    }

    fn describe(&self) -> String {
        format!(
            "the circuit's equations under the continuous P law, a {} mm step",
            self.0.step_m * 1e3
        )
    }

    fn name(&self) -> &'static str {
        "equations"
    }

    /// The step held and watched (without its settling time) in RK4 steps of four
    /// evaluations each.
    fn work(&self, _: &[WaveRequirement]) -> f64 {
        let c = &self.0;
        4.0 * (c.hold_s + c.tail_s) / c.step_s
    }
}

/// The check on the emulator (docs/circuits.md#will-it-chatter): the 5 mm step
/// ([`chatter::step`]) and each of the application's waves ([`chatter::sine`]) emulated with
/// every effect on for the rig ([`Effects::for_rig`]) and a noise-free PLC at its 100 Hz, so
/// the verdict is deterministic and a switch is the circuit's, not the sensors'. It keeps
/// switching when the step switches after it has settled, or a wave switches in its watched
/// periods more often than its reference's own needed force crosses the switching force;
/// switches during the step's transient that die out do not count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EmulatedCheck;

impl ModeCheck for EmulatedCheck {
    fn run(&self, rig: &Rig, waves: &[WaveRequirement]) -> Result<ModeVerdict, String> {
        let text = |e: crate::emulator::EmulatorError| e.to_string();
        let effects = Effects::for_rig(rig).map_err(text)?;
        let step = chatter::step(rig, effects).map_err(text)?;
        let sines = (waves.iter())
            .map(|w| chatter::sine(rig, effects, w.freq_hz, w.amp_mm))
            .collect::<Result<Vec<_>, _>>()
            .map_err(text)?;
        let beyond = |r: &ModeRun| {
            r.switches_after_settling
                .saturating_sub(r.switches_explained)
        };
        let step_keeps = step.switches_after_settling > 0;
        let keeps_switching = if step_keeps {
            Some(format!(
                "the {} switches {} times after it settled at {:.1} s (±{:.3} mm)",
                step.experiment,
                step.switches_after_settling,
                step.settled_at_s,
                step.error_amplitude_m * 1e3
            ))
        } else {
            sines.iter().find(|r| beyond(r) > 0).map(|r| {
                format!(
                    "the {} switches {} times in its last {} periods, {} of them explained by the reference's own force crossing the switching force",
                    r.experiment,
                    r.switches_after_settling,
                    chatter::WATCHED_PERIODS,
                    r.switches_explained
                )
            })
        };
        Ok(ModeVerdict {
            switches: step.switches + sines.iter().map(|r| r.switches).sum::<usize>(),
            switches_after_settling: step.switches_after_settling
                + sines.iter().map(beyond).sum::<usize>(),
            oscillation_amplitude_m: step.error_amplitude_m,
            keeps_switching,
        })
    }

    fn describe(&self) -> String {
        "the emulator, a noise-free PLC at 100 Hz: the 5 mm step and the application's waves"
            .to_string()
    }

    fn name(&self) -> &'static str {
        "emulator"
    }

    /// The step's hold and watched tail ([`chatter::HOLD_S`], [`chatter::TAIL_S`]) and each
    /// wave's run ([`chatter::sine_seconds`]) at the PLC's rate, each controller step counted
    /// as a calm loop's at most ([`crate::limits::CALM_STEP_WORK`]; docs/emulator.md#the-work-limit).
    fn work(&self, waves: &[WaveRequirement]) -> f64 {
        let waves_s: f64 = waves.iter().map(|w| chatter::sine_seconds(w.freq_hz)).sum();
        let seconds = chatter::HOLD_S + chatter::TAIL_S + waves_s;
        seconds * crate::emulator::PLC_RATE_HZ * crate::limits::CALM_STEP_WORK
    }
}

/// The mode checks a selection offers, by name (docs/select.md#the-single-pump-circuit):
/// `emulator` (the default) and `equations`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModeCheckKind {
    /// [`EmulatedCheck`].
    #[default]
    Emulator,
    /// [`EquationsCheck::ARTICLE`].
    Equations,
}

impl ModeCheckKind {
    /// Every mode check's name, the default first.
    pub const NAMES: [&'static str; 2] = ["emulator", "equations"];

    /// The mode check called `name`.
    ///
    /// # Errors
    /// No such check, in one line naming the ones there are.
    pub fn from_name(name: &str) -> Result<ModeCheckKind, String> {
        match name {
            "emulator" => Ok(ModeCheckKind::Emulator),
            "equations" => Ok(ModeCheckKind::Equations),
            other => Err(format!(
                "mode check \"{other}\": no such check ({})",
                Self::NAMES.join(", ")
            )),
        }
    }

    /// The check itself.
    pub fn check(self) -> &'static dyn ModeCheck {
        match self {
            ModeCheckKind::Emulator => &EmulatedCheck,
            ModeCheckKind::Equations => &EquationsCheck::ARTICLE,
        }
    }
}

/// The reason every failing single-pump candidate starts with.
pub const SWITCHES: &str = "switches modes under this load";

/// What the single-pump candidate's mode checks found: why it switches modes, if it does, and
/// the check's worst numbers over the runs made (`None` where no check ran).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Switches {
    /// Why it switches modes under its load, starting with [`SWITCHES`].
    pub why: Option<String>,
    /// The checks' verdicts, worst of each number (most switches, largest amplitude).
    pub worst: Option<ModeVerdict>,
}

/// Why the single-pump candidate (the rigs `ends` at its gain: the reference gas fraction
/// first, then the range's ends) switches modes under its load, if it does: a mode whose
/// margins break the targets at the candidate's gain at an end and a load (either mode: a load
/// that accelerates crosses the switching force; the check does not run then), or the check
/// `check` on the reference at each force of [`mode_check_forces`] and each load finding that it
/// keeps switching ([`ModeVerdict::keeps_switching`]).
///
/// # Errors
/// A mode's model cannot be analysed, or the check cannot be run.
pub fn switches(
    ends: &[&Rig],
    req: &Requirement,
    loads: &[f64],
    check: &dyn ModeCheck,
) -> Result<Switches, String> {
    let reference = ends[0];
    let reached = modes_reached(reference, req, loads);
    for end in ends {
        for &mass_kg in loads {
            let r = Rig {
                mass_kg,
                ..(*end).clone()
            };
            let broken = mode_margins_break(&r, &req.targets, &reached.chambers)
                .map_err(|e| e.to_string())?;
            if let Some(why) = broken {
                let why = if reached.switching {
                    format!("{SWITCHES}: {why}")
                } else {
                    format!("the mode it rests in over the whole force range breaks the margin targets: {why}")
                };
                return Ok(Switches {
                    why: Some(why),
                    worst: None,
                });
            }
        }
    }
    let mut out = Switches::default();
    for f in mode_check_forces(reference, req, loads) {
        for &mass_kg in loads {
            let r = Rig {
                mass_kg,
                external_force_n: f,
                ..reference.clone()
            };
            let v = check.run(&r, &req.waves)?;
            let why = v.keeps_switching.clone();
            out.worst = Some(match out.worst.take() {
                None => v,
                Some(w) => ModeVerdict {
                    switches: w.switches.max(v.switches),
                    switches_after_settling: w
                        .switches_after_settling
                        .max(v.switches_after_settling),
                    oscillation_amplitude_m: w
                        .oscillation_amplitude_m
                        .max(v.oscillation_amplitude_m),
                    keeps_switching: w.keeps_switching.or(v.keeps_switching),
                },
            });
            if let Some(why) = why {
                out.why = Some(format!(
                    "{SWITCHES}: {why} at {f} N, {mass_kg} kg, Kp {:.2} ({})",
                    reference.kp,
                    check.describe()
                ));
                return Ok(out);
            }
        }
    }
    Ok(out)
}

/// How many forces inside the requirement's range the mode check adds where the loads' forces
/// can reach the switching force (docs/select.md#the-single-pump-circuit).
pub const MODE_CHECK_INNER_FORCES: usize = 5;

/// The external forces (N) the single-pump mode check runs at, the most telling first: the
/// switching force and forces about it where the requirement's range reaches it, then the
/// range's ends. The circuit switches where the force its piston must give — the external
/// force plus m ẍ + b ẋ of a wave, amplitude A ω √(m² ω² + b²) — crosses the switching force
/// p_acc (A1 − A2) beyond its check valves' band, so a range whose ends both lie clear of it
/// can hold forces in between where every wave switches
/// (docs/circuits.md#the-switching-force). The window about the switching force is the band
/// widened by the largest wave force of the loads; [`MODE_CHECK_INNER_FORCES`] evenly spaced
/// forces of the range inside it (the switching force among them where it lies inside) are
/// checked.
pub fn mode_check_forces(reference: &Rig, req: &Requirement, loads: &[f64]) -> Vec<f64> {
    let [lo, hi] = req.external_force_n;
    let mut forces = Vec::new();
    if let Some([from, to]) = switching_window(reference, req, loads) {
        let f_s = switching(reference).switching_force_n;
        if (lo..=hi).contains(&f_s) {
            forces.push(f_s);
        }
        let n = MODE_CHECK_INNER_FORCES;
        forces.extend((0..n).map(|k| from + (to - from) * k as f64 / (n - 1) as f64));
    }
    forces.extend([lo, hi]);
    let mut seen: Vec<f64> = Vec::new();
    forces.retain(|f| {
        let new = !seen.contains(f);
        seen.push(*f);
        new
    });
    forces
}

/// The external forces of `req`'s range (N, [from, to]) at which the force the piston must
/// give can reach the switching force's valve band: the band widened by the largest wave force
/// A ω √(m² ω² + b²) of the loads, within the range; `None` where the range lies clear of it
/// (docs/circuits.md#the-switching-force).
fn switching_window(reference: &Rig, req: &Requirement, loads: &[f64]) -> Option<[f64; 2]> {
    let [lo, hi] = req.external_force_n;
    let band = switching(reference).valve_band_n;
    let b = reference.viscous_friction_ns_per_m;
    let wave_n = (req.waves.iter())
        .flat_map(|w| loads.iter().map(move |&m| (w, m)))
        .map(|(w, m)| {
            let omega = 2.0 * PI * w.freq_hz;
            w.amp_mm * 1e-3 * omega * (m * m * omega * omega + b * b).sqrt()
        })
        .fold(0.0, f64::max);
    let (from, to) = ((band[0] - wave_n).max(lo), (band[1] + wave_n).min(hi));
    (from <= to).then_some([from, to])
}

/// The modes the single-pump rig `reference` works in over `req`: both where its force range
/// reaches the switching force ([`switching_window`]), the one at rest otherwise (the same at
/// both ends of a range that does not reach it), as the chambers at the accumulator.
struct Reached {
    chambers: Vec<usize>,
    switching: bool,
}

fn modes_reached(reference: &Rig, req: &Requirement, loads: &[f64]) -> Reached {
    if switching_window(reference, req, loads).is_some() {
        return Reached {
            chambers: vec![2, 1],
            switching: true,
        };
    }
    let at_rest = switching(&Rig {
        external_force_n: req.external_force_n[0],
        ..reference.clone()
    })
    .mode_at_rest;
    Reached {
        chambers: vec![3 - at_rest],
        switching: false,
    }
}

/// Which of the modes `chambers` (the chamber at the accumulator) of the single-pump rig `r`
/// breaks the margin targets at its gain, if one does (the tolerances of the design's
/// verdict: [`PM_TOLERANCE_DEG`], [`GM_TOLERANCE_DB`]).
fn mode_margins_break(
    r: &Rig,
    t: &Targets,
    chambers: &[usize],
) -> Result<Option<String>, LtiError> {
    for &chamber in chambers {
        let mode = Mode::new(r, chamber);
        let m = crate::lti::margins(&mode.open_loop()?)?;
        let pm_low = m
            .phase_margin_deg
            .is_some_and(|pm| pm < t.pm_deg - PM_TOLERANCE_DEG);
        let gm_low = m
            .gain_margin_db
            .is_some_and(|gm| gm < t.gm_db - GM_TOLERANCE_DB);
        if !m.closed_loop_stable || pm_low || gm_low {
            let show = |v: Option<f64>| v.map_or("inf".to_string(), |v| format!("{v:.1}"));
            return Ok(Some(format!(
                "mode {} (chamber {chamber} at the accumulator) at Kp {:.2}, {} kg: PM {} deg, GM {} dB{}",
                mode.number(),
                r.kp,
                r.mass_kg,
                show(m.phase_margin_deg),
                show(m.gain_margin_db),
                if m.closed_loop_stable { "" } else { ", unstable" }
            )));
        }
    }
    Ok(None)
}

/// The standstill cost of the one-motor rig `r` at its external force (docs/select.md#cost):
/// the drive turns to feed the leakage, the shaft power τ ω at rest lost as heat, with τ the
/// pumps' load torque at the rest's chamber pressures.
///
/// # Errors
/// The dual-pump circuit's rest is undetermined.
pub fn one_motor_standing(r: &Rig) -> Result<StandingLoss, String> {
    let rest = r.circuit.one_motor_rest(r)?;
    let (torque, w) = (rest.torque_nm, rest.w_rad_per_s);
    Ok(StandingLoss {
        p_bar: rest.p_pa.map(|p| p / PA_PER_BAR),
        power_w: torque * w,
        speed_rpm: [w * 60.0 / (2.0 * PI), 0.0],
        torque_nm: [torque, 0.0],
        electrical_power_w: crate::circuit::energy::Electrics::of(r).supply_w(&[[w, torque]]),
    })
}

/// The single-pump rig's responses in the mode at rest, which its linear model is
/// (docs/circuits.md#its-two-modes): each wave's largest control error, the amplitude
/// |1/(1 + L(j2πf))| A of the periodic steady state under the P law on top of the loop's rest
/// offset (docs/simulation.md#the-rest-under-load), and the rise time of a
/// [`RISE_STEP_MM`] step of the closed loop (infinite where it never reaches 90 %).
///
/// # Errors
/// The mode's model cannot be analysed.
pub fn mode_at_rest_responses(r: &Rig, waves: &[(f64, f64)]) -> Result<(Vec<f64>, f64), LtiError> {
    let mode = Mode::new(r, 3 - switching(r).mode_at_rest);
    let open = mode.open_loop()?;
    let l = FreqEvaluator::new(&open)?;
    let base = crate::response::Baseline::of_rig(r);
    let offset_mm = (base.x_ref_mm - base.x_mm).abs();
    let errors = (waves.iter())
        .map(|&(f, a)| offset_mm + a / (1.0 + l.at(2.0 * PI * f)).norm())
        .collect();
    let closed = open.unity_feedback()?;
    crate::lti::require_stable(&closed.a)?;
    let rate_hz = 200.0;
    let n = (RISE_WINDOW_S * rate_hz).round() as usize + 1;
    let t: Vec<f64> = (0..n).map(|k| k as f64 / rate_hz).collect();
    let step_m = RISE_STEP_MM * 1e-3;
    let y = Simulator::new(&closed).run(&t, &vec![step_m; n], &vec![0.0; closed.order()])?;
    let y_mm: Vec<f64> = y.output(0).iter().map(|v| v * 1e3).collect();
    let metrics = crate::response::step_metrics(&t, &y_mm, RISE_STEP_MM, RISE_STEP_MM);
    Ok((errors, metrics.rise_time_s.unwrap_or(f64::INFINITY)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_circuit_names_itself_three_ways_in_json() {
        let v = serde_json::to_value(Circuit::named("single-pump").unwrap()).unwrap();
        let want = serde_json::json!({
            "circuit": "single_pump",
            "circuit_kind": "single-pump",
            "pressure_level": "precharge",
        });
        assert_eq!(v, want);
        let v = serde_json::to_value(Circuit::LOW_PRESSURE).unwrap();
        assert_eq!(v["circuit"], "low_pressure");
        assert_eq!(v["circuit_kind"], "dpm");
        let names: Vec<&str> = Circuit::all().iter().map(|c| c.name()).collect();
        assert_eq!(
            names,
            [
                "low-pressure",
                "pressurised",
                "dual-pump",
                "single-pump",
                "valve"
            ]
        );
        let v = serde_json::to_value(Circuit::named("valve").unwrap()).unwrap();
        assert_eq!(v["pressure_level"], "supply");
    }

    #[test]
    fn a_rig_allows_the_circuits_its_components_make() {
        let rig = |k: CircuitKind| Rig {
            circuit: k,
            ..Rig::default()
        };
        // a pump rig's default is its pump circuits; a valve beside them is tried when named
        assert_eq!(allowed_circuits(&rig(CircuitKind::Dpm)).len(), 3);
        assert!(not_allowed(&rig(CircuitKind::Dpm), CircuitKind::Valve).is_none());
        let valve = rig(CircuitKind::Valve);
        assert_eq!(allowed_circuits(&valve), [CircuitKind::Valve]);
        let why = not_allowed(&valve, CircuitKind::Dpm).unwrap();
        assert!(why.contains("no drives, no pumps"), "{why}");
        assert!(not_allowed(&rig(CircuitKind::Dpm), CircuitKind::SinglePump).is_none());
        let why = not_allowed(&rig(CircuitKind::DualPump), CircuitKind::Dpm).unwrap();
        assert!(why.contains("one drive"), "{why}");
        let why = not_allowed(&rig(CircuitKind::SinglePump), CircuitKind::DualPump).unwrap();
        assert!(why.contains("one drive and one pump"), "{why}");
    }

    /// At no load the single-pump circuit rests in mode 2, chamber 1 at p_acc and
    /// p2 = p_acc A1/A2: the pump feeds chamber 2's leakage to the accumulator line and across,
    /// so the drive's power τ ω is (c2 + c12)(p2 − p_acc)², by hand.
    #[test]
    fn the_single_pump_standing_power_is_its_leakage_power() {
        let rig = Rig {
            circuit: CircuitKind::SinglePump,
            ..Rig::default()
        };
        let s = one_motor_standing(&rig).unwrap();
        let si = rig.si();
        let p_acc = rig.accumulator_precharge_bar * PA_PER_BAR;
        let p2 = p_acc * si.a1 / si.a2;
        assert!((s.p_bar[0] - rig.accumulator_precharge_bar).abs() < 1e-12);
        assert!((s.p_bar[1] * PA_PER_BAR / p2 - 1.0).abs() < 1e-12);
        let by_hand = (si.c2 + si.c12) * (p2 - p_acc).powi(2);
        assert!(
            (s.power_w / by_hand - 1.0).abs() < 1e-9,
            "{} vs {by_hand}",
            s.power_w
        );
        assert_eq!((s.speed_rpm[1], s.torque_nm[1]), (0.0, 0.0));
    }
}
