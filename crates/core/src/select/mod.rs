//! Which circuit, at which pressure level? The article's closing advice (its §4) as a
//! computation (docs/select.md): with a reference gas fraction and its range, predict before
//! the system is built whether a pump-controlled cylinder meets an application's requirement
//! at each candidate circuit and pressure level, and what holding that pressure costs.
//!
//! A candidate is a circuit at a pressure level ([`Circuit`]): the DPM at a mean chamber
//! pressure p (low or pressurised; its sum-pressure set-point 2p), or a one-motor circuit of
//! the article's Figure 1 (dual pump, single pump) at an accumulator pre-charge p. Each is its
//! circuit's own linear model (docs/circuits.md) with β_e from the gas-fraction model at p
//! (docs/bulk-modulus.md) over the gas-fraction range. Its largest gain is the design method's
//! worst case over the stroke and the loads (docs/design.md) at the range's ends and
//! reference, its tracking is predicted at that gain, and its cost is the standstill leakage
//! balance at that pressure (the article §2.4; [`standing_loss`]). The single-pump candidate
//! fails where it switches modes under its load ([`circuits::switches`]).

mod application;
pub mod circuits;
pub mod energy;

pub use application::*;
pub use circuits::{
    Circuit, EmulatedCheck, EquationsCheck, ModeCheck, ModeCheckKind, ModeVerdict, PressureLevel,
};

use crate::bulk::{BetaReading, ARTICLE_READING};
use crate::cavitation::check_chambers;
use crate::circuit::CircuitKind;
use crate::design::{self, DesignError, Targets};
use crate::rig::{Rig, RigError};
use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::PI;

/// A wave to track and the largest control error allowed (the article's §3 waves).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaveRequirement {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Amplitude (mm).
    pub amp_mm: f64,
    /// Largest control error allowed after the first period (mm).
    pub max_error_mm: f64,
}

/// What the application needs and what is uncertain about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Requirement {
    /// The reference gas fraction X (dimensionless).
    pub gas_fraction: f64,
    /// The lowest gas fraction considered.
    pub gas_fraction_min: f64,
    /// The highest gas fraction considered (the worst case for β_e).
    pub gas_fraction_max: f64,
    /// The pure-oil bulk modulus of the gas-fraction model (bar).
    pub beta_oil_bar: f64,
    /// Margin targets and the stroke and loads they hold over (`p_mean_bar` and `waves` unused).
    pub targets: Targets,
    /// Waves to track within an error.
    pub waves: Vec<WaveRequirement>,
    /// Largest 10–90 % rise time of a 5 mm step allowed (s), if required.
    pub max_rise_time_s: Option<f64>,
    /// External force range [lowest, highest] (N): the standstill cost is taken at both.
    pub external_force_n: [f64; 2],
    /// Where the gas-fraction range came from.
    pub gas_fraction_from: GasFractionFrom,
    /// Where the rig came from.
    pub rig_from: RigFrom,
}

/// Where a selection's gas-fraction range came from (docs/select.md#the-gas-fraction); in JSON
/// an object whose `source` names the variant, with the reading's fields beside it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "source", rename_all = "snake_case")]
pub enum GasFractionFrom {
    /// The application states `gas_fraction`.
    Application,
    /// The article's identification (β 165 bar at 4.4 bar), on the article's own rig.
    Article(BetaReading),
    /// The rig's β at its mean chamber pressure at rest at x0 ([`BetaReading::of_rig`]).
    Rig(BetaReading),
    /// An identification's interval of β (docs/select.md#from-an-identification).
    Identification(BetaEvidence),
}

impl Default for GasFractionFrom {
    fn default() -> Self {
        GasFractionFrom::Article(ARTICLE_READING)
    }
}

/// Where a selection's rig came from; in JSON an object whose `source` names the variant.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
#[serde(tag = "source", rename_all = "snake_case")]
pub enum RigFrom {
    /// The article's rig (the article §2.3.4): the application names none.
    #[default]
    Article,
    /// The application's `[rig]` table.
    Table,
    /// The rig file the application's `rig` key names (the path relative to the application
    /// file resolved).
    File {
        /// The rig file.
        path: String,
    },
    /// A rig given beside the application (`pumpcyl select --rig`, Python `rig=`).
    Given {
        /// The rig, in the caller's words (a file name).
        name: String,
        /// The application's own rig it replaces, in words, if the application had one.
        replaces: Option<String>,
    },
}

impl RigFrom {
    /// Where the rig came from, in words.
    pub fn describe(&self) -> String {
        match self {
            RigFrom::Article => "the article's rig (its §2.3.4)".to_string(),
            RigFrom::Table => "the application's [rig] table".to_string(),
            RigFrom::File { path } => format!("{path} (the application's `rig` key)"),
            RigFrom::Given { name, replaces } => match replaces {
                Some(r) => format!("{name}, replacing {r}"),
                None => name.clone(),
            },
        }
    }
}

/// The standstill leakage balance at one pressure pair (the article §2.4): the pumps turn to
/// feed the leakage, and that flow at those pressures is lost as heat.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StandingLoss {
    /// Chamber pressures p1, p2 (bar gauge).
    pub p_bar: [f64; 2],
    /// Hydraulic power lost to leakage, Σ p × Q (W).
    pub power_w: f64,
    /// Pump speeds that feed it, motors 1 and 2 (rpm).
    pub speed_rpm: [f64; 2],
    /// Motor torques that hold the pressures, motors 1 and 2 (N·m).
    pub torque_nm: [f64; 2],
    /// What the drives draw from the supply to feed it, their winding's and electronics'
    /// losses included, net of what they return (W; docs/energy.md#the-drives).
    pub electrical_power_w: f64,
}

/// The standstill balance of `rig` at the chamber pressures `p_bar` (bar gauge; the circuit's
/// [`crate::circuit::Dpm::standstill_balance`], docs/select.md#cost).
pub fn standing_loss(rig: &Rig, p_bar: [f64; 2]) -> StandingLoss {
    let circuit = crate::circuit::Dpm::linear(rig);
    let b = circuit.standstill_balance(p_bar.map(|p| p * 1e5));
    let d = circuit.si().d;
    let rpm = |q: f64, d: f64| q / d * 60.0 / (2.0 * PI);
    let shafts = [0, 1].map(|k| [b.flow_m3_s[k] / d[k], b.torque_nm[k]]);
    StandingLoss {
        p_bar,
        power_w: b.power_w,
        speed_rpm: [0, 1].map(|k| rpm(b.flow_m3_s[k], d[k])),
        torque_nm: b.torque_nm,
        electrical_power_w: crate::circuit::energy::Electrics::of(rig).supply_w(&shafts),
    }
}

/// The chamber pressures at rest (bar gauge) for the mean pressure `p_mean_bar` and the
/// external force `force_n`: p1 + p2 = 2 p_mean (the sum-pressure loop) and
/// p1 A1 − p2 A2 = F_ext (Newton at rest, docs/model.md#newton; [`Rig::p2_at_rest_bar`]).
pub fn chamber_pressures(rig: &Rig, p_mean_bar: f64, force_n: f64) -> [f64; 2] {
    let si = rig.si();
    let p1_bar = (2.0 * p_mean_bar * si.a2 + force_n / 1e5) / (si.a1 + si.a2);
    let at_force = Rig {
        external_force_n: force_n,
        ..rig.clone()
    };
    [p1_bar, at_force.p2_at_rest_bar(p1_bar)]
}

/// One circuit at one pressure level, over the gas-fraction range.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// The circuit and how its pressure level is set (in JSON the keys `circuit`,
    /// `circuit_kind`, `pressure_level`).
    #[serde(flatten)]
    pub circuit: Circuit,
    /// The pressure level (bar gauge): the DPM's mean chamber pressure, a one-motor circuit's
    /// accumulator pre-charge (`pressure_level` says which).
    pub mean_pressure_bar: f64,
    /// β_e there at the highest and the lowest gas fraction (bar).
    pub beta_e_bar: [f64; 2],
    /// The largest Kp meeting the margin targets over the stroke, the loads and the whole
    /// gas-fraction range (1/m); 0 when none does (`null` in JSON: no gain is not a gain of 0;
    /// `reason` says why). With a fixed gain, that gain.
    #[serde(serialize_with = "no_gain_as_null")]
    pub kp_max: f64,
    /// The largest Kp meeting the margin targets over the stroke, the loads and the whole
    /// gas-fraction range (1/m), also when the gain is fixed; 0 when none does (`null` in JSON).
    #[serde(serialize_with = "no_gain_as_null")]
    pub kp_max_range: f64,
    /// The largest Kp at the reference gas fraction (1/m); 0 when none does (`null` in JSON).
    #[serde(serialize_with = "no_gain_as_null")]
    pub kp_max_reference: f64,
    /// The velocity-loop gain K_v at `kp_max` on the rig at the reference gas fraction (1/s;
    /// [`crate::lti::Margins::velocity_gain_per_s`]): the gains compared across circuits,
    /// whatever unit their K_p has. `None` without a gain.
    pub kv_max_per_s: Option<f64>,
    /// Each wave's largest control error at `kp_max` over the gas-fraction range and the
    /// loads, [least, most] (mm); empty when `kp_max` is 0.
    pub tracking_max_error_mm: Vec<[f64; 2]>,
    /// The 10–90 % rise time of a 5 mm step at `kp_max` over the gas-fraction range and the
    /// loads, [least, most] (s; `null` in JSON where a step never reaches 90 %); `None` when
    /// `kp_max` is 0.
    pub rise_time_s: Option<[f64; 2]>,
    /// The loop's standing error at rest at `kp_max` over the gas-fraction range, the loads
    /// and the force range, [least, most] (mm; docs/simulation.md#the-rest-under-load): the
    /// part of `tracking_max_error_mm` the P law needs to hold the load and feed the leakage.
    /// `None` when `kp_max` is 0.
    pub rest_offset_mm: Option<[f64; 2]>,
    /// The standstill cost at the lowest and the highest external force; `None` (`null` in
    /// JSON) where a chamber would cavitate there (docs/model.md#cavitation): no state to cost.
    pub standing: Option<[StandingLoss; 2]>,
    /// The larger of the two standing losses (W); `None` as `standing`.
    pub standing_loss_w: Option<f64>,
    /// A single-pump candidate's mode switches over its mode check's runs (the worst load and
    /// external force; docs/select.md#the-single-pump-circuit); `None` (`null` in JSON) where
    /// the check did not run: another circuit, no gain, or a mode's margins breaking the
    /// targets.
    pub mode_switches: Option<usize>,
    /// Its mode switches after the step settled, and a wave's in its watched periods beyond
    /// those its reference explains (the worst load and force); `None` as `mode_switches`.
    pub switches_after_settling: Option<usize>,
    /// Half the peak-to-peak control error after the step settled (mm), the amplitude of any
    /// sustained oscillation (the worst load and force); `None` as `mode_switches`.
    pub oscillation_amplitude_mm: Option<f64>,
    /// Whether the requirement holds over the whole uncertainty.
    pub meets: bool,
    /// Whether the requirement holds in the best case: at the lowest gas fraction (the stiffest
    /// oil), at the largest gain meeting the margin targets there (or the fixed gain). A
    /// candidate that fails even then cannot be made certain by learning more about the air.
    pub meets_best_case: bool,
    /// Whether the margin targets (not the tracking) hold at `kp_max` at the reference gas
    /// fraction alone: `kp_max` is positive and at most `kp_max_reference`.
    pub margins_hold_at_reference_gas_fraction: bool,
    /// Why it does or does not.
    pub reason: String,
}

/// A largest gain of 0 (no gain meets the margin targets) as `null`, any other as itself.
fn no_gain_as_null<S: serde::Serializer>(kp: &f64, s: S) -> Result<S::Ok, S::Error> {
    (*kp > 0.0).then_some(*kp).serialize(s)
}

/// The tool's answer in the article's terms (its §4): where the prediction is uncertain,
/// choose a circuit with a higher effective bulk modulus; where it fails even in the best
/// case, it is not uncertain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// The low-pressure circuit meets the requirement over the whole uncertainty.
    LowPressureSuitable,
    /// Only a pressurised level meets it over the whole uncertainty; a low-pressure level meets
    /// it in the best case (the least air): the low-pressure circuit is uncertain.
    UsePressurisedCircuit,
    /// Only a pressurised level meets it over the whole uncertainty; no low-pressure level
    /// meets it even in the best case (or none was tried).
    LowPressureInsufficient,
    /// The valve-controlled cylinder meets it over the whole uncertainty from a supply
    /// pressure (`min_mean_pressure_bar` holds the supply).
    ValveSuitable,
    /// No level meets it over the whole uncertainty, but one does in the best case.
    Uncertain,
    /// No level meets it, even in the best case.
    NotAchievable,
}

/// The selection: every candidate and the answer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Selection {
    /// Every candidate, circuit by circuit, pressure rising.
    pub options: Vec<Candidate>,
    /// The lowest mean pressure at which the requirement holds over the whole uncertainty
    /// (bar), found between the levels: bisected to [`REFINE_TOLERANCE_BAR`] between the
    /// highest level below `min_level_bar` (which fails) and it; `min_level_bar` itself when
    /// no level lies below it; `None` if no level meets.
    pub min_mean_pressure_bar: Option<f64>,
    /// The lowest of the levels evaluated (`options`) that meets the requirement, in the circuit
    /// of the answer (bar).
    pub min_level_bar: Option<f64>,
    /// The bisection's last bracket [fails, meets] (bar); `None` without a bisection.
    pub min_mean_pressure_bracket_bar: Option<[f64; 2]>,
    /// The candidate at `min_mean_pressure_bar`, in the circuit of the level `min_level_bar`.
    pub at_min_mean_pressure: Option<Candidate>,
    /// The lowest level that meets the requirement in the circuit of the answer (index into
    /// `options`): each circuit's lowest meeting level is bisected, the lowest result answers.
    pub chosen: Option<usize>,
    /// The circuit of the answer: that of the lowest level meeting the requirement.
    pub chosen_circuit: Option<CircuitKind>,
    /// The verdict.
    pub verdict: Verdict,
    /// Why, in words.
    pub reasons: Vec<String>,
    /// The gas-fraction range evaluated: [lowest, reference, highest].
    pub gas_fraction: [f64; 3],
    /// Where the gas-fraction range came from.
    pub gas_fraction_from: GasFractionFrom,
    /// Where the rig came from.
    pub rig: RigFrom,
    /// The single-pump candidates' mode check (`emulator`, `equations`;
    /// docs/select.md#the-single-pump-circuit).
    pub mode_check: &'static str,
}

/// How closely the lowest mean pressure is found between the levels (bar).
pub const REFINE_TOLERANCE_BAR: f64 = 0.01;
/// Most bisection steps (a bracket of 1000 bar needs 17).
const MAX_BISECTIONS: usize = 40;

/// Errors of the selection.
#[derive(Debug, thiserror::Error)]
pub enum SelectError {
    /// A value that cannot be used, named.
    #[error("{0}")]
    Input(String),
    /// A `KEY=VALUE` override of the application that does not fit.
    #[error("{source_name} {assignment}: {message}")]
    Set {
        /// Where the overrides come from, in the caller's words (`--set`).
        source_name: String,
        /// The assignment as given (all of them, space-separated, when the fault is in none
        /// alone).
        assignment: String,
        /// What is wrong.
        message: String,
    },
    /// An application value outside its range once the overrides are applied.
    #[error("{source_name}: key `{key}`: {message}")]
    Invalid {
        /// Where the overrides come from, in the caller's words (`--set`).
        source_name: String,
        /// The key, as written in the application file (`rig.` keys prefixed).
        key: String,
        /// What is wrong.
        message: String,
    },
    /// The rig at a candidate.
    #[error(transparent)]
    Rig(#[from] RigError),
    /// The design at a candidate.
    #[error(transparent)]
    Design(#[from] DesignError),
    /// Work beyond its limit, not allowed.
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
}

/// Evaluate `levels` (circuit, mean pressure in bar) for `rig` against `req`; `kp` fixes the
/// gain instead of designing it (docs/select.md).
pub fn select(
    rig: &Rig,
    req: &Requirement,
    levels: &[(Circuit, f64)],
    kp: Option<f64>,
) -> Result<Selection, SelectError> {
    select_with(rig, req, levels, kp, &crate::limits::Work::QUIET)
}

/// [`select`], beyond [`MAX_SELECT_CASES`](crate::limits::MAX_SELECT_CASES) load × level cases
/// ([`cases`]) only when `work` allows a long run, its progress given to `work` in cases.
pub fn select_with(
    rig: &Rig,
    req: &Requirement,
    levels: &[(Circuit, f64)],
    kp: Option<f64>,
    work: &crate::limits::Work,
) -> Result<Selection, SelectError> {
    select_checked(rig, req, levels, kp, work, ModeCheckKind::default().check())
}

/// [`select_with`] with the single-pump candidates' mode check `mode_check`
/// ([`ModeCheck`]: the circuit's equations, or the emulator).
pub fn select_checked(
    rig: &Rig,
    req: &Requirement,
    levels: &[(Circuit, f64)],
    kp: Option<f64>,
    work: &crate::limits::Work,
    mode_check: &dyn ModeCheck,
) -> Result<Selection, SelectError> {
    check(rig, req, levels, kp).map_err(|(key, m)| SelectError::Input(format!("`{key}` = {m}")))?;
    crate::limits::check_work(
        &format!(
            "mass_kg loads × pressure levels (cases{})",
            if req.waves.len() > 1 {
                format!(
                    "; each [[wave]] beyond the first adds 1/{WAVES_PER_CASE} of a case, {} \
                     waves",
                    req.waves.len()
                )
            } else {
                String::new()
            }
        ),
        case_work(req, levels),
        crate::limits::MAX_SELECT_CASES,
        work.allow_long_run,
    )?;
    crate::limits::check_work(
        &format!(
            "the single-pump mode checks (right-hand-side evaluations of the {} check's runs at \
             each load, external force and pre-charge, the bisection's included)",
            mode_check.name()
        ),
        mode_check_work(req, levels, mode_check),
        crate::limits::MAX_EMULATOR_WORK,
        work.allow_long_run,
    )?;
    let loads = req.targets.mass_kg.len().max(1) as u64;
    // the candidates are independent: one per thread
    let options = levels
        .par_iter()
        .map(|&(circuit, p)| {
            let c = candidate(rig, req, circuit, p, kp, mode_check);
            work.advance(loads)?;
            c
        })
        .collect::<Result<Vec<_>, _>>()?;
    answer(rig, req, options, kp, mode_check)
}

/// The cases a selection evaluates: each load (the rig's mass when none is given) at each
/// pressure level.
pub fn cases(req: &Requirement, levels: &[(Circuit, f64)]) -> f64 {
    req.targets.mass_kg.len().max(1) as f64 * levels.len() as f64
}

/// Waves whose tracking simulations cost about one case (docs/select.md#work): a case's gain
/// design and simulations of the first wave take about 5 ms in the debug-optimised CLI, each
/// further wave's simulations at the gas fraction's ends about 0.16 ms of it (40 waves on the
/// user rig's 13 DPM levels and two loads) **\[choice\]**: 30, rounding towards counting more.
pub const WAVES_PER_CASE: f64 = 30.0;

/// A selection's work in cases against [`MAX_SELECT_CASES`](crate::limits::MAX_SELECT_CASES)
/// (docs/select.md#work): its [`cases`], each wave beyond the first (a case includes one
/// wave's tracking) adding [`1/WAVES_PER_CASE`](WAVES_PER_CASE) of a case.
pub fn case_work(req: &Requirement, levels: &[(Circuit, f64)]) -> f64 {
    let extra = req.waves.len().saturating_sub(1) as f64;
    cases(req, levels) * (1.0 + extra / WAVES_PER_CASE)
}

/// The work of the single-pump candidates' mode checks (right-hand-side evaluations, against
/// [`MAX_EMULATOR_WORK`](crate::limits::MAX_EMULATOR_WORK); docs/select.md#work): one run of
/// `check` ([`ModeCheck::work`], its step and each wave) at each load and each force the check
/// runs at (the range's ends, the switching force and the forces about it), for each single-pump level and each halving of the bisection between
/// them (`refine`: at most as many as bring the widest gap between two levels down to
/// [`REFINE_TOLERANCE_BAR`]). An estimate before the gains are designed: without the step's
/// settling time, and a loop far from calm costs more (docs/emulator.md#the-work-limit);
/// a candidate whose margins fail is not checked at all.
pub fn mode_check_work(req: &Requirement, levels: &[(Circuit, f64)], check: &dyn ModeCheck) -> f64 {
    let mut p: Vec<f64> = (levels.iter())
        .filter(|(c, _)| c.kind.has_modes())
        .map(|&(_, p)| p)
        .collect();
    if p.is_empty() {
        return 0.0;
    }
    p.sort_by(f64::total_cmp);
    let gap = p.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
    let halvings = if gap > REFINE_TOLERANCE_BAR {
        ((gap / REFINE_TOLERANCE_BAR).log2().ceil() as usize).min(MAX_BISECTIONS)
    } else {
        0
    };
    // the range's ends, and where it reaches the switching force's window the switching force
    // and the forces inside it (circuits::mode_check_forces): counted as if it always did
    let [lo, hi] = req.external_force_n;
    let forces = if lo == hi {
        1
    } else {
        3 + circuits::MODE_CHECK_INNER_FORCES
    };
    let runs = (p.len() + halvings) * req.targets.mass_kg.len().max(1) * forces;
    runs as f64 * check.work(&req.waves)
}

/// What cannot be used in a selection, as (the key, why): the gas fractions, the waves (each
/// value positive, inside the stroke, resolved by the tracking: [`design::check_wave`]), the
/// pressure levels and the fixed gain.
fn check(
    rig: &Rig,
    req: &Requirement,
    levels: &[(Circuit, f64)],
    kp: Option<f64>,
) -> Result<(), (String, String)> {
    let bad = |key: &str, m: String| Err((key.to_string(), m));
    let fractions = [
        ("gas_fraction", req.gas_fraction),
        ("gas_fraction_min", req.gas_fraction_min),
        ("gas_fraction_max", req.gas_fraction_max),
    ];
    for (key, x) in fractions {
        if !(x.is_finite() && x > 0.0 && x < 1.0) {
            return bad(key, format!("{x}: must lie strictly between 0 and 1"));
        }
    }
    check_oil(req.beta_oil_bar)?;
    if !(req.gas_fraction_min <= req.gas_fraction && req.gas_fraction <= req.gas_fraction_max) {
        return bad(
            "gas_fraction",
            format!(
                "{}: must lie within gas_fraction_min … gas_fraction_max",
                req.gas_fraction
            ),
        );
    }
    for w in &req.waves {
        let what = format!(
            "{} Hz ±{} mm within {} mm",
            w.freq_hz, w.amp_mm, w.max_error_mm
        );
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !(positive(w.freq_hz) && positive(w.amp_mm) && positive(w.max_error_mm)) {
            return bad("wave", format!("{what}: every value must be > 0"));
        }
        design::check_wave(rig, w.freq_hz, w.amp_mm)
            .or_else(|e| bad("wave", format!("{what}: {e}")))?;
    }
    let [lowest, highest] = req.external_force_n;
    if lowest > highest {
        return bad(
            "external_force_n",
            format!("[{lowest}, {highest}]: the range is [lowest, highest], the lowest first"),
        );
    }
    for &(circuit, p) in levels {
        if !(p.is_finite() && p > 0.0 && p <= 1000.0) {
            let key = circuit.levels_key();
            return bad(key, format!("{p}: every level must lie in (0, 1000] bar"));
        }
        if let Some(why) = circuits::not_allowed(rig, circuit.kind) {
            return bad("circuits", why);
        }
    }
    if let Some(t) = req.max_rise_time_s {
        if !(t.is_finite() && t > 0.0 && t <= RISE_WINDOW_S) {
            return bad(
                "max_rise_time_s",
                format!("{t}: must lie in (0, {RISE_WINDOW_S}] s"),
            );
        }
    }
    match kp {
        Some(kp) if !(kp.is_finite() && kp > 0.0 && kp <= 1e4) => {
            bad("kp", format!("{kp}: must lie in (0, 1e4] 1/m"))
        }
        _ => Ok(()),
    }
}

/// The pure-oil bulk modulus checked, as (the key, why).
fn check_oil(beta_oil_bar: f64) -> Result<(), (String, String)> {
    if beta_oil_bar.is_finite() && beta_oil_bar > 0.0 && beta_oil_bar <= 1e6 {
        Ok(())
    } else {
        let why = format!("{beta_oil_bar}: must lie in (0, 1e6] bar");
        Err(("beta_oil_bar".to_string(), why))
    }
}

/// One candidate over the gas-fraction range.
fn candidate(
    rig: &Rig,
    req: &Requirement,
    circuit: Circuit,
    p_bar: f64,
    fixed_kp: Option<f64>,
    mode_check: &dyn ModeCheck,
) -> Result<Candidate, SelectError> {
    let p_beta = circuit.beta_pressure_bar(rig, p_bar);
    let model = rig.bulk_model();
    let at = |x: f64| circuit.rig_at(rig, p_bar, model.beta_bar(x, p_beta, req.beta_oil_bar));
    let (soft, stiff, reference) = (
        at(req.gas_fraction_max),
        at(req.gas_fraction_min),
        at(req.gas_fraction),
    );
    let mut out = Candidate {
        circuit,
        mean_pressure_bar: p_bar,
        beta_e_bar: [soft.beta_bar, stiff.beta_bar],
        kp_max: 0.0,
        kp_max_range: 0.0,
        kp_max_reference: 0.0,
        kv_max_per_s: None,
        tracking_max_error_mm: Vec::new(),
        rest_offset_mm: None,
        rise_time_s: None,
        standing: None,
        standing_loss_w: None,
        mode_switches: None,
        switches_after_settling: None,
        oscillation_amplitude_mm: None,
        meets: false,
        meets_best_case: false,
        margins_hold_at_reference_gas_fraction: false,
        reason: String::new(),
    };
    // a one-motor or valve circuit at a level it cannot rest at fails there, not the whole
    // selection
    let own_rest = matches!(
        circuit.level,
        PressureLevel::Precharge | PressureLevel::Supply
    );
    let gains = (!own_rest || reference.validate("candidate").is_ok())
        .then(|| gains(req, [&soft, &stiff, &reference]))
        .transpose();
    let [kp_range, kp_stiff, kp_reference] = match gains {
        Ok(Some(kp)) => kp,
        Err(e) if !own_rest => return Err(e.into()),
        Err(e) => return Ok(failed(out, e.to_string())),
        Ok(None) => {
            let e = reference.validate("candidate").err().map(|e| e.to_string());
            return Ok(failed(out, e.unwrap_or_default()));
        }
    };
    let kp_max = fixed_kp.unwrap_or(kp_range);
    (out.kp_max, out.kp_max_range, out.kp_max_reference) = (kp_max, kp_range, kp_reference);
    out.kv_max_per_s = velocity_gain(&reference, kp_max);
    let standing = match circuit.level {
        PressureLevel::Precharge => one_motor_standstill(&reference, req),
        PressureLevel::Supply => supply_standstill(&reference, req),
        _ => standstill(rig, req, p_bar),
    };
    let standing = match standing {
        Ok(standing) => standing,
        Err(why) => return Ok(failed(out, why)),
    };
    out.standing = Some(standing);
    out.standing_loss_w = Some(standing[0].power_w.max(standing[1].power_w));
    if let Some(why) = over_rating(rig, &standing) {
        return Ok(failed(out, why));
    }
    out.margins_hold_at_reference_gas_fraction = kp_max > 0.0 && kp_max <= kp_reference;
    let (band, failing) = assess(req, &[&stiff, &soft], kp_max, kp_range)?;
    if let Some(band) = band {
        out.tracking_max_error_mm = band.tracking_mm;
        out.rise_time_s = Some(band.rise_time_s);
        out.rest_offset_mm = Some(band.rest_offset_mm);
    }
    if circuit.kind.has_modes() && kp_max > 0.0 {
        let with_kp = [&reference, &stiff, &soft].map(|r| Rig {
            kp: kp_max,
            ..r.clone()
        });
        let ends: Vec<&Rig> = with_kp.iter().collect();
        let loads = loads_of(req, &reference);
        match circuits::switches(&ends, req, &loads, mode_check) {
            Ok(found) => {
                if let Some(v) = found.worst {
                    out.mode_switches = Some(v.switches);
                    out.switches_after_settling = Some(v.switches_after_settling);
                    out.oscillation_amplitude_mm = Some(v.oscillation_amplitude_m * 1e3);
                }
                if let Some(why) = found.why {
                    let rest = failing.join("; ");
                    let why = if rest.is_empty() {
                        why
                    } else {
                        format!("{why}; {rest}")
                    };
                    return Ok(failed(out, why));
                }
            }
            Err(why) => return Ok(failed(out, why)),
        }
    }
    if failing.is_empty() {
        out.meets = true;
        out.meets_best_case = true;
        out.reason = format!(
            "meets every requirement at Kp = {kp_max:.2} over the gas-fraction range and the loads"
        );
        return Ok(out);
    }
    out.reason = failing.join("; ");
    if req.gas_fraction_min < req.gas_fraction_max {
        let kp_best = fixed_kp.unwrap_or(kp_stiff);
        out.meets_best_case = assess(req, &[&stiff], kp_best, kp_stiff)?.1.is_empty();
        if out.meets_best_case {
            out.reason += &format!(
                "; met in the best case, the least air (gas fraction {:.4}), at Kp = {kp_best:.2}",
                req.gas_fraction_min
            );
        }
    }
    Ok(out)
}

/// The velocity-loop gain (1/s) of `rig`'s loop at the gain `kp`, `None` without a gain or
/// where the loop has none.
fn velocity_gain(rig: &Rig, kp: f64) -> Option<f64> {
    if kp <= 0.0 {
        return None;
    }
    let at = Rig { kp, ..rig.clone() };
    let open = crate::model::Plant::new(&at).open_loop(false);
    crate::lti::margins(&open).ok()?.velocity_gain_per_s
}

/// `c` failing for `why`: it meets nothing.
fn failed(mut c: Candidate, why: String) -> Candidate {
    c.reason = why;
    c
}

/// The largest gains meeting the margin targets over the stroke and the loads
/// ([`design::kp_max_worst_case`]) of the rigs at the gas-fraction range's ends and its
/// reference `[soft, stiff, reference]`: [over the range, at the stiff end, at the reference].
/// The margins are monotone in β_e, so the range's ends bound it (docs/select.md).
fn gains(req: &Requirement, [soft, stiff, reference]: [&Rig; 3]) -> Result<[f64; 3], DesignError> {
    let kp_reference = design::kp_max_worst_case(reference, &req.targets)?;
    let kp_at = |r: &Rig, x: f64| -> Result<f64, DesignError> {
        // a zero-width range (or an end at the reference) is one design, not three
        if x == req.gas_fraction {
            Ok(kp_reference)
        } else {
            design::kp_max_worst_case(r, &req.targets)
        }
    };
    let kp_stiff = kp_at(stiff, req.gas_fraction_min)?;
    let kp_range = kp_at(soft, req.gas_fraction_max)?
        .min(kp_stiff)
        .min(kp_reference);
    Ok([kp_range, kp_stiff, kp_reference])
}

/// The loads of `req` (each its mass at x0), the rig's mass when none is given.
fn loads_of(req: &Requirement, rig: &Rig) -> Vec<f64> {
    match req.targets.mass_kg.as_slice() {
        [] => vec![rig.mass_kg],
        loads => loads.to_vec(),
    }
}

/// The standstill cost of the one-motor rig `r` at the lowest and the highest external force,
/// or why it cannot rest there (an undetermined rest, a chamber below the vapour pressure).
fn one_motor_standstill(r: &Rig, req: &Requirement) -> Result<[StandingLoss; 2], String> {
    own_rest_at_forces(r, req, circuits::one_motor_standing)
}

/// A supplied circuit's rest at the lowest and the highest external force: the chamber
/// pressures and the power its supply delivers there (no motors: speeds and torques 0), or
/// why it cannot rest under that force.
fn supply_standstill(r: &Rig, req: &Requirement) -> Result<[StandingLoss; 2], String> {
    own_rest_at_forces(r, req, |loaded| {
        let rest = loaded.circuit.supply_rest(loaded)?;
        Ok(StandingLoss {
            p_bar: rest.p_pa.map(|p| p / crate::units::PA_PER_BAR),
            power_w: rest.power_w,
            speed_rpm: [0.0; 2],
            torque_nm: [0.0; 2],
            // the supply's own losses are not modelled: what it delivers
            electrical_power_w: rest.power_w,
        })
    })
}

/// `standing` of the rig `r` under the lowest and the highest external force of `req`, each
/// loaded rig checked first and its chambers after (above the vapour pressure), or why it
/// cannot rest under that force.
fn own_rest_at_forces(
    r: &Rig,
    req: &Requirement,
    standing: impl Fn(&Rig) -> Result<StandingLoss, String>,
) -> Result<[StandingLoss; 2], String> {
    let at = |f: f64| -> Result<StandingLoss, String> {
        let loaded = Rig {
            external_force_n: f,
            ..r.clone()
        };
        let why = |e: String| format!("at an external force of {f} N: {e}");
        loaded
            .validate("candidate")
            .map_err(|e| why(e.to_string()))?;
        let s = standing(&loaded).map_err(why)?;
        check_chambers(&s.p_bar).map_err(|e| why(e.to_string()))?;
        Ok(s)
    };
    let [lo, hi] = req.external_force_n;
    Ok([at(lo)?, at(hi)?])
}

/// The standstill balance at the lowest and the highest external force, or why the circuit
/// cannot hold it: a chamber below the oil's vapour pressure (docs/model.md#cavitation).
fn standstill(rig: &Rig, req: &Requirement, p_bar: f64) -> Result<[StandingLoss; 2], String> {
    let pressures = req
        .external_force_n
        .map(|f| chamber_pressures(rig, p_bar, f));
    for (f, p) in req.external_force_n.iter().zip(&pressures) {
        check_chambers(p).map_err(|e| format!("at an external force of {f} N: {e}"))?;
    }
    Ok(pressures.map(|p| standing_loss(rig, p)))
}

/// Whether `req` holds at gain `kp` over the rigs `ends` and the loads, `kp_allowed` being the
/// largest gain that meets the margin targets over them: the responses (none where the gain
/// does not hold the targets or the closed loop is unstable) and what falls short (empty when
/// it holds).
fn assess(
    req: &Requirement,
    ends: &[&Rig],
    kp: f64,
    kp_allowed: f64,
) -> Result<(Option<Band>, Vec<String>), SelectError> {
    if kp <= 0.0 {
        let why = "no gain meets the margin targets over the gas-fraction range";
        return Ok((None, vec![why.into()]));
    }
    if kp > kp_allowed {
        let why = format!(
            "Kp = {kp} breaks the margin targets in the gas-fraction range (largest that holds: {kp_allowed:.2})"
        );
        return Ok((None, vec![why]));
    }
    match response_band(req, ends, kp) {
        Err(DesignError::Lti(e @ crate::lti::LtiError::Unstable { .. })) => Ok((
            None,
            vec![format!(
                "at Kp = {kp:.2} with {}: {e}",
                ends.first().map_or("the controller's loops closed", |r| r
                    .circuit
                    .closed_loops())
            )],
        )),
        Err(e) => Err(e.into()),
        Ok(band) => {
            let failing = shortfalls(req, &band);
            Ok((Some(band), failing))
        }
    }
}

/// What `band` falls short of in `req`: each wave whose worst error exceeds its bound, and the
/// rise time; empty when it meets the requirement.
fn shortfalls(req: &Requirement, band: &Band) -> Vec<String> {
    let mut out: Vec<String> = req
        .waves
        .iter()
        .zip(&band.tracking_mm)
        .filter(|(w, [_, worst])| *worst > w.max_error_mm)
        .map(|(w, [_, worst])| {
            format!(
                "{} Hz ±{} mm: error up to {worst:.2} mm > {} mm",
                w.freq_hz, w.amp_mm, w.max_error_mm
            )
        })
        .collect();
    if let Some(max) = req.max_rise_time_s {
        let worst = band.rise_time_s[1];
        if worst > max {
            let worst = if worst.is_finite() {
                format!("up to {worst:.3} s")
            } else {
                format!("not reached within {RISE_WINDOW_S} s")
            };
            out.push(format!("rise time {worst} > {max} s"));
        }
    }
    out
}

/// The step whose rise time a requirement bounds (mm): the article's identification step (§2.4).
pub const RISE_STEP_MM: f64 = 5.0;
/// How long the rise-time step is simulated (s) and at what rate (Hz).
const RISE_WINDOW_S: f64 = 10.0;
const RISE_RATE_HZ: f64 = 200.0;

/// The responses at one gain over the uncertainty: each wave's largest control error, the
/// rise time and the rest offset, as [least, most].
struct Band {
    tracking_mm: Vec<[f64; 2]>,
    rise_time_s: [f64; 2],
    rest_offset_mm: [f64; 2],
}

/// The external forces of `req` the responses are taken at: the range's two ends, one where
/// they are equal. The rest offset that holds the load grows with it
/// (docs/simulation.md#the-rest-under-load), so the ends bound the errors.
fn forces_of(req: &Requirement) -> Vec<f64> {
    let [lo, hi] = req.external_force_n;
    if lo == hi {
        vec![lo]
    } else {
        vec![lo, hi]
    }
}

/// Each wave's largest control error, the step's rise time and the rest offset at gain `kp`
/// over `ends` (the rigs at the ends of the gas-fraction range), the loads of `req` (each its
/// mass at x0) and the ends of its force range, as [least, most]; a step that never reaches
/// 90 % counts as an infinite rise time.
fn response_band(req: &Requirement, ends: &[&Rig], kp: f64) -> Result<Band, DesignError> {
    let waves: Vec<(f64, f64)> = req.waves.iter().map(|w| (w.freq_hz, w.amp_mm)).collect();
    let widen = |b: &mut [f64; 2], v: f64| *b = [b[0].min(v), b[1].max(v)];
    let mut band = Band {
        tracking_mm: vec![[f64::INFINITY, f64::NEG_INFINITY]; waves.len()],
        rise_time_s: [f64::INFINITY, f64::NEG_INFINITY],
        rest_offset_mm: [f64::INFINITY, f64::NEG_INFINITY],
    };
    for end in ends {
        for mass_kg in loads_of(req, end) {
            for external_force_n in forces_of(req) {
                let r = Rig {
                    kp,
                    mass_kg,
                    external_force_n,
                    ..(*end).clone()
                };
                let (errors, rise) = responses(&r, &waves)?;
                for (b, e) in band.tracking_mm.iter_mut().zip(errors) {
                    widen(b, e);
                }
                widen(&mut band.rise_time_s, rise);
                let base = crate::response::Baseline::of_rig(&r);
                widen(&mut band.rest_offset_mm, base.x_ref_mm - base.x_mm);
            }
        }
    }
    Ok(band)
}

/// Each wave's largest control error (mm) and the rise time (s; infinite where the step never
/// reaches 90 %) of `r`: simulated (docs/simulation.md), or for the single-pump circuit from
/// its mode at rest's linear model ([`circuits::mode_at_rest_responses`]).
fn responses(r: &Rig, waves: &[(f64, f64)]) -> Result<(Vec<f64>, f64), DesignError> {
    if r.circuit.has_modes() {
        return Ok(circuits::mode_at_rest_responses(r, waves)?);
    }
    let at = design::predicted_tracking(r, waves)?;
    let s = crate::response::step(r, RISE_STEP_MM, RISE_WINDOW_S, RISE_RATE_HZ)?;
    let rise = crate::response::step_metrics_of(r, &s, RISE_STEP_MM).rise_time_s;
    Ok((
        at.iter().map(|m| m.max_error_mm).collect(),
        rise.unwrap_or(f64::INFINITY),
    ))
}

/// Why holding the pressure exceeds a drive's rating, if it does (the one rating check,
/// [`crate::response::over_ratings`]).
fn over_rating(rig: &Rig, standing: &[StandingLoss; 2]) -> Option<String> {
    standing.iter().find_map(|s| {
        let o = crate::response::over_ratings(rig, s.speed_rpm, s.torque_nm);
        Some(format!(
            "{}, to hold p1 {:.1} / p2 {:.1} bar at standstill",
            o.first()?,
            s.p_bar[0],
            s.p_bar[1]
        ))
    })
}

/// The lowest level of `options` of the circuit `kind` that meets the requirement (index).
fn lowest_meeting(options: &[Candidate], kind: CircuitKind) -> Option<usize> {
    lowest_where(options, kind, |c| c.meets)
}

/// The lowest level of `options` of the circuit `kind` that `keep` accepts (index).
fn lowest_where(
    options: &[Candidate],
    kind: CircuitKind,
    keep: impl Fn(&Candidate) -> bool,
) -> Option<usize> {
    options
        .iter()
        .enumerate()
        .filter(|(_, c)| c.circuit.kind == kind && keep(c))
        .min_by(|a, b| a.1.mean_pressure_bar.total_cmp(&b.1.mean_pressure_bar))
        .map(|(k, _)| k)
}

/// The lowest mean pressure between the levels: the candidate `options[k]` (the lowest level
/// that meets) bisected, in its circuit, against the highest level of the same circuit below
/// it (which fails, as every level below the lowest meeting one does; the DPM's low and
/// pressurised levels are one circuit) to [`REFINE_TOLERANCE_BAR`], at most
/// [`MAX_BISECTIONS`] steps. The meeting candidate found and the last bracket [fails, meets]
/// (none when no level lies below).
fn refine(
    rig: &Rig,
    req: &Requirement,
    options: &[Candidate],
    k: usize,
    kp: Option<f64>,
    mode_check: &dyn ModeCheck,
) -> Result<(Candidate, Option<[f64; 2]>), SelectError> {
    let meeting = &options[k];
    let below = options
        .iter()
        .filter(|c| c.circuit.kind == meeting.circuit.kind)
        .map(|c| c.mean_pressure_bar)
        .filter(|&p| p < meeting.mean_pressure_bar)
        .fold(f64::NEG_INFINITY, f64::max);
    if !below.is_finite() {
        return Ok((meeting.clone(), None));
    }
    let (mut lo, mut hi, mut at) = (below, meeting.mean_pressure_bar, meeting.clone());
    for _ in 0..MAX_BISECTIONS {
        if hi - lo <= REFINE_TOLERANCE_BAR {
            break;
        }
        let mid = 0.5 * (lo + hi);
        let c = candidate(rig, req, meeting.circuit, mid, kp, mode_check)?;
        if c.meets {
            (hi, at) = (mid, c);
        } else {
            lo = mid;
        }
    }
    Ok((at, Some([lo, hi])))
}

/// The verdict and why: the circuit of the lowest meeting candidate `at` (refined), else
/// whether any level meets in the best case. The low-pressure circuits are the DPM at its low
/// levels and the one-motor circuits at their accumulator pre-charge.
fn verdict(options: &[Candidate], at: Option<&Candidate>) -> (Verdict, Vec<String>) {
    let is_low = |c: &Candidate| {
        matches!(
            c.circuit.level,
            PressureLevel::LowPressure | PressureLevel::Precharge
        )
    };
    let low: Vec<&Candidate> = options.iter().filter(|c| is_low(c)).collect();
    let low_best = low.iter().find(|c| c.meets_best_case);
    match at {
        Some(c) if c.circuit.level == PressureLevel::Supply => (
            Verdict::ValveSuitable,
            vec![format!(
                "the {} circuit meets the requirement over the whole gas-fraction range from a supply of {:.2} bar: {}",
                c.circuit.name(),
                c.mean_pressure_bar,
                c.reason
            )],
        ),
        Some(c) if c.circuit.level == PressureLevel::Precharge => (
            Verdict::LowPressureSuitable,
            vec![format!(
                "the {} circuit meets the requirement over the whole gas-fraction range from an accumulator pre-charge of {:.2} bar: {}",
                c.circuit.name(),
                c.mean_pressure_bar,
                c.reason
            )],
        ),
        Some(c) if is_low(c) => (
            Verdict::LowPressureSuitable,
            vec![format!(
                "the low-pressure circuit meets the requirement over the whole gas-fraction range from {:.2} bar: {}",
                c.mean_pressure_bar, c.reason
            )],
        ),
        Some(c) => {
            let pressurised = format!(
                "use the pressurised circuit at ≥ {:.2} bar ({})",
                c.mean_pressure_bar, c.reason
            );
            match (low_best, low.is_empty()) {
                (Some(b), _) => (
                    Verdict::UsePressurisedCircuit,
                    vec![format!(
                        "uncertain with the low-pressure circuit: at {} bar{} it meets the requirement only in the best case, not over the whole gas-fraction range; {pressurised}",
                        b.mean_pressure_bar,
                        match b.circuit.level {
                            PressureLevel::Precharge => format!(" ({})", b.circuit.name()),
                            _ => String::new(),
                        }
                    )],
                ),
                (None, true) => (
                    Verdict::LowPressureInsufficient,
                    vec![format!("no low-pressure level was tried; {pressurised}")],
                ),
                (None, false) => (
                    Verdict::LowPressureInsufficient,
                    vec![format!(
                        "the low-pressure circuit fails at every level even in the best case (the least air); {pressurised}"
                    )],
                ),
            }
        }
        None => {
            let best = options.iter().find(|c| c.meets_best_case);
            let highest = options
                .iter()
                .max_by(|a, b| a.mean_pressure_bar.total_cmp(&b.mean_pressure_bar));
            let why = |c: &Candidate| {
                format!(
                    "at the highest level ({}, {} bar): {}",
                    c.circuit.name(),
                    c.mean_pressure_bar,
                    c.reason
                )
            };
            match best {
                Some(b) => (
                    Verdict::Uncertain,
                    vec![format!(
                        "uncertain: no level meets the requirement over the whole gas-fraction range; from {} bar ({}) it is met in the best case, the least air",
                        b.mean_pressure_bar,
                        b.circuit.name()
                    )],
                ),
                None => (
                    Verdict::NotAchievable,
                    highest
                        .map(|c| {
                            format!(
                                "not achievable with these circuits, even in the best case (the least air); {}",
                                why(c)
                            )
                        })
                        .into_iter()
                        .collect(),
                ),
            }
        }
    }
}

/// The selection of `options`: the lowest level that meets `req` over the whole uncertainty,
/// refined between the levels ([`refine`]), and the verdict.
fn answer(
    rig: &Rig,
    req: &Requirement,
    options: Vec<Candidate>,
    kp: Option<f64>,
    mode_check: &dyn ModeCheck,
) -> Result<Selection, SelectError> {
    // each circuit's lowest meeting level refined, the lowest of them the answer (the first
    // circuit listed on a tie)
    let mut chosen: Option<usize> = None;
    let (mut at, mut bracket) = (None, None);
    for kind in CircuitKind::ALL {
        let Some(k) = lowest_meeting(&options, kind) else {
            continue;
        };
        let (found, b) = refine(rig, req, &options, k, kp, mode_check)?;
        let lower = |c: &Candidate| found.mean_pressure_bar < c.mean_pressure_bar;
        if at.as_ref().is_none_or(lower) {
            (chosen, at, bracket) = (Some(k), Some(found), b);
        }
    }
    let (verdict, reasons) = verdict(&options, at.as_ref());
    Ok(Selection {
        min_mean_pressure_bar: at.as_ref().map(|c| c.mean_pressure_bar),
        min_level_bar: chosen.map(|k| options[k].mean_pressure_bar),
        min_mean_pressure_bracket_bar: bracket,
        chosen_circuit: at.as_ref().map(|c| c.circuit.kind),
        at_min_mean_pressure: at,
        chosen,
        options,
        verdict,
        reasons,
        gas_fraction: [req.gas_fraction_min, req.gas_fraction, req.gas_fraction_max],
        gas_fraction_from: req.gas_fraction_from,
        rig: req.rig_from.clone(),
        mode_check: mode_check.name(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bulk::{effective_beta, gas_fraction, BETA_OIL_BAR};

    fn requirement(x: [f64; 3], waves: Vec<WaveRequirement>) -> Requirement {
        Requirement {
            gas_fraction_min: x[0],
            gas_fraction: x[1],
            gas_fraction_max: x[2],
            beta_oil_bar: BETA_OIL_BAR,
            targets: Targets {
                pm_deg: 30.0,
                gm_db: 6.0,
                stroke_mm: 0.0,
                ..Targets::default()
            },
            waves,
            max_rise_time_s: None,
            external_force_n: [0.0, 0.0],
            gas_fraction_from: GasFractionFrom::Application,
            rig_from: RigFrom::Article,
        }
    }

    /// The standing loss is Σ pressure × leakage flow, and equals the pumps' hydraulic power
    /// (a hand calculation at the article's standstill point: p1 3.95 bar, p2 5.865 bar).
    #[test]
    fn the_standing_loss_is_the_leakage_flow_times_pressure() {
        let rig = Rig::default();
        let [p1, p2] = chamber_pressures(&rig, 0.5 * (3.95 + 3.95 * 3117.2453 / 2099.4), 0.0);
        assert!((p1 - 3.95).abs() < 1e-3, "{p1}");
        let s = standing_loss(&rig, [p1, p2]);
        let (pa1, pa2) = (p1 * 1e5, p2 * 1e5);
        // by hand: c1 p1² + c2 p2² + c12 (p1 − p2)²
        let by_hand = 5.49e-11 * pa1 * pa1 + -1.19e-11 * pa2 * pa2 + 1.2e-10 * (pa1 - pa2).powi(2);
        assert!(
            (s.power_w - by_hand).abs() < 1e-12,
            "{} vs {by_hand}",
            s.power_w
        );
        // the pumps' hydraulic power is the same
        let si = rig.si();
        let w = |rpm: f64| rpm * 2.0 * PI / 60.0;
        let pumps = (pa1 - pa2) * si.d[0] * w(s.speed_rpm[0]) + pa1 * si.d[1] * w(s.speed_rpm[1]);
        assert!((pumps - s.power_w).abs() < 1e-9 * s.power_w.abs().max(1.0));
        // the article's standstill speeds: pump 1 backwards, pump 2 forwards (−160 / 245 rpm)
        assert!(
            s.speed_rpm[0] < 0.0 && s.speed_rpm[1] > 0.0,
            "{:?}",
            s.speed_rpm
        );
    }

    /// At rest the sum-pressure loop holds p1 + p2 = 2 p and Newton holds p1 A1 − p2 A2 = F_ext
    /// (docs/model.md#newton), the leakage identification's convention.
    #[test]
    fn the_chamber_pressures_hold_the_sum_and_the_load() {
        let rig = Rig::default();
        let si = rig.si();
        for force in [-20_000.0, 0.0, 15_000.0] {
            let [p1, p2] = chamber_pressures(&rig, 10.0, force);
            assert!((p1 + p2 - 20.0).abs() < 1e-12, "{p1} {p2}");
            assert!(
                (p1 * 1e5 * si.a1 - p2 * 1e5 * si.a2 - force).abs() < 1e-6,
                "{force}"
            );
        }
    }

    /// At Kp 25 with the gas fraction fixed, a level meets GM 6 dB and PM 30° exactly when the
    /// LTI margins at β_e(p) do; widening the range never lowers the answer.
    #[test]
    fn the_lowest_pressure_follows_the_margins_and_widening_the_range_never_lowers_it() {
        let rig = Rig::default();
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        let levels: Vec<(Circuit, f64)> = (1..=10)
            .map(|p| (Circuit::LOW_PRESSURE, p as f64))
            .collect();
        let fixed = select(&rig, &requirement([x, x, x], vec![]), &levels, Some(25.0)).unwrap();
        for c in &fixed.options {
            let r = Rig {
                beta_bar: effective_beta(x, c.mean_pressure_bar, BETA_OIL_BAR),
                ..rig.clone()
            };
            let m = crate::lti::margins(&crate::model::Plant::new(&r).open_loop(false)).unwrap();
            let holds = m.closed_loop_stable
                && m.gain_margin_db.is_none_or(|g| g >= 6.0 - 0.05)
                && m.phase_margin_deg.is_none_or(|p| p >= 30.0 - 0.05);
            assert_eq!(
                c.meets, holds,
                "{} bar: {m:?} {}",
                c.mean_pressure_bar, c.reason
            );
        }
        let wide = select(
            &rig,
            &requirement([x / 2.0, x, 2.0 * x], vec![]),
            &levels,
            Some(25.0),
        )
        .unwrap();
        let (a, b) = (fixed.min_mean_pressure_bar, wide.min_mean_pressure_bar);
        assert!(a.is_some(), "{:?}", fixed.reasons);
        assert!(b.is_none() || b >= a, "{a:?} -> {b:?}");
    }

    /// An identified β interval maps to the gas-fraction range end for end (the soft end of
    /// β is the most air) and round-trips through the gas-fraction model; an interval that
    /// does not hold its estimate is refused.
    #[test]
    fn an_identified_beta_interval_sets_the_gas_fraction_range() {
        let e = BetaEvidence {
            beta_bar: [150.0, 180.0],
            beta_nominal_bar: 165.0,
            p_mean_bar: 4.4,
            confidence: 0.95,
        };
        let app = Application::default().with_evidence(&e).unwrap();
        let beta = |x: f64| effective_beta(x, 4.4, app.beta_oil_bar);
        assert!((beta(app.gas_fraction_max) - 150.0).abs() < 1e-9);
        assert!((beta(app.gas_fraction_min) - 180.0).abs() < 1e-9);
        assert!((beta(app.gas_fraction) - 165.0).abs() < 1e-9);
        assert_eq!(
            app.requirement().gas_fraction_from,
            GasFractionFrom::Identification(e)
        );
        let outside = BetaEvidence {
            beta_nominal_bar: 190.0,
            ..e
        };
        let err = Application::default()
            .with_evidence(&outside)
            .unwrap_err()
            .to_string();
        assert!(err.contains("does not hold its estimate 190"), "{err}");
    }

    /// A requirement no candidate meets gives no pressure and says why.
    #[test]
    fn an_impossible_requirement_says_why() {
        let rig = Rig::default();
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        let wave = WaveRequirement {
            freq_hz: 0.2,
            amp_mm: 35.0,
            max_error_mm: 0.01,
        };
        let s = select(
            &rig,
            &requirement([x, x, x], vec![wave]),
            &[(Circuit::LOW_PRESSURE, 4.4)],
            None,
        )
        .unwrap();
        assert_eq!(s.min_mean_pressure_bar, None);
        assert_eq!(s.verdict, Verdict::NotAchievable);
        assert!(s.reasons[0].contains("0.2 Hz ±35 mm"), "{:?}", s.reasons);
    }

    /// A gain-margin target of 400 dB is met by no gain: every option's largest gain is `null`
    /// in JSON with the reason, never a gain of 0.
    #[test]
    fn no_gain_meeting_the_targets_is_null_not_zero() {
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        let mut req = requirement([x, x, x], Vec::new());
        req.targets.gm_db = 400.0;
        let s = select(&Rig::default(), &req, &[(Circuit::LOW_PRESSURE, 4.4)], None).unwrap();
        let json = serde_json::to_value(&s).unwrap();
        let options = json["options"].as_array().unwrap();
        assert!(!options.is_empty());
        for o in options {
            for key in ["kp_max", "kp_max_range", "kp_max_reference"] {
                assert!(o[key].is_null(), "{key}: {o}");
            }
            assert!(o["reason"].as_str().unwrap().contains("no gain"), "{o}");
        }
    }

    /// The bisection's bracket straddles the margins' own threshold: at Kp 25 with the gas
    /// fraction fixed, the LTI margins at β_e(p) meet GM 6 dB and PM 30° at the bracket's upper
    /// end and not at its lower end, within 0.01 bar.
    #[test]
    fn the_lowest_pressure_is_bisected_to_the_margins_threshold() {
        let rig = Rig::default();
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        let levels = [(Circuit::LOW_PRESSURE, 3.0), (Circuit::LOW_PRESSURE, 6.0)];
        let s = select(&rig, &requirement([x, x, x], vec![]), &levels, Some(25.0)).unwrap();
        assert_eq!(s.min_level_bar, Some(6.0));
        let [lo, hi] = s.min_mean_pressure_bracket_bar.unwrap();
        assert!(hi - lo <= REFINE_TOLERANCE_BAR && lo < hi, "{lo} {hi}");
        assert_eq!(s.min_mean_pressure_bar, Some(hi));
        let holds = |p: f64| {
            let r = Rig {
                beta_bar: effective_beta(x, p, BETA_OIL_BAR),
                ..rig.clone()
            };
            let m = crate::lti::margins(&crate::model::Plant::new(&r).open_loop(false)).unwrap();
            m.closed_loop_stable
                && m.gain_margin_db.is_none_or(|g| g >= 6.0)
                && m.phase_margin_deg.is_none_or(|p| p >= 30.0)
        };
        assert!(holds(hi) && !holds(lo), "{lo} {hi}");
    }

    /// On a rig given beside the application the gas fraction is the rig's β at half its
    /// sum-pressure set-point and the loads its mass; a stated gas fraction stays, its range a
    /// factor 2 either way.
    #[test]
    fn the_keys_left_out_follow_the_rig() {
        let mine = Rig {
            beta_bar: 300.0,
            p_sum_ref_bar: 12.0,
            mass_kg: 2500.0,
            mass_by_position: Vec::new(),
            ..Rig::default()
        };
        let given = RigFrom::Given {
            name: "mine".into(),
            replaces: None,
        };
        let app = Application::default()
            .with_rig(mine.clone(), given.clone())
            .unwrap();
        // β read at the rig's anchor, where its loop rests, below half its 12 bar set-point
        let anchor = crate::anchor::anchor_bar(&mine);
        assert!(anchor > 4.0 && anchor < 6.0, "{anchor}");
        let x = gas_fraction(300.0, anchor, BETA_OIL_BAR).unwrap();
        assert_eq!(
            [app.gas_fraction_min, app.gas_fraction, app.gas_fraction_max],
            [x / 2.0, x, 2.0 * x]
        );
        assert!(app.mass_kg.is_empty());
        let reading = BetaReading {
            beta_bar: 300.0,
            p_mean_bar: anchor,
        };
        assert_eq!(app.gas_fraction_from, GasFractionFrom::Rig(reading));
        let stated = Application::default()
            .with_overrides("--set", &["gas_fraction=0.02".to_string()])
            .unwrap()
            .with_rig(mine, given)
            .unwrap();
        assert_eq!(stated.gas_fraction, 0.02);
        assert_eq!(stated.gas_fraction_max, 0.04);
        assert_eq!(stated.gas_fraction_from, GasFractionFrom::Application);
        // the article's application on the article's rig is unchanged
        let article = Application::default();
        assert_eq!(article.mass_kg, ARTICLE_LOADS_KG);
        assert_eq!(
            article.gas_fraction,
            gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap()
        );
    }

    /// A standstill that needs a chamber below the vapour pressure fails its candidate with
    /// the cavitation as the reason and no standing loss; a force range given highest first
    /// is refused.
    #[test]
    fn cavitation_fails_a_candidate_and_a_reversed_range_is_refused() {
        let rig = Rig::default();
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        let mut req = requirement([x, x, x], vec![]);
        req.external_force_n = [0.0, 5000.0];
        let s = select(&rig, &req, &[(Circuit::LOW_PRESSURE, 1.0)], Some(25.0)).unwrap();
        let c = &s.options[0];
        let [_, p2] = chamber_pressures(&rig, 1.0, 5000.0);
        assert!(p2 < crate::cavitation::VAPOUR_PRESSURE_BAR_GAUGE, "{p2}");
        assert!(!c.meets && !c.meets_best_case && c.standing_loss_w.is_none());
        assert!(c.reason.contains("cavitation"), "{}", c.reason);
        req.external_force_n = [3000.0, -1000.0];
        let err = select(&rig, &req, &[(Circuit::LOW_PRESSURE, 1.0)], Some(25.0)).unwrap_err();
        assert!(err.to_string().contains("external_force_n"), "{err}");
    }
}
