//! Which circuit, at which pressure level? The article's closing advice (its §4) as a
//! computation (docs/select.md): with a reference gas fraction and its range, predict before
//! the system is built whether a pump-controlled cylinder meets an application's requirement
//! at each candidate circuit and pressure level, and what holding that pressure costs.
//!
//! Each candidate is the same 10-state LTI model (docs/model.md) at the candidate's mean
//! chamber pressure p: β_e follows the gas-fraction model at p (docs/bulk-modulus.md) over the
//! gas-fraction range, the sum-pressure set-point is 2p. Its largest gain is the design
//! method's worst case over the stroke and the loads (docs/design.md) at the range's ends and
//! reference, its tracking is predicted at that gain, and its cost is the standstill leakage
//! balance at that pressure (the article §2.4; [`standing_loss`]).

use crate::bulk::{effective_beta, BetaReading, ARTICLE_READING};
use crate::cavitation::check_chambers;
use crate::design::{self, DesignError, Targets};
use crate::rig::{Rig, RigError};
use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::PI;

/// The two circuits pumpcyl models (docs/select.md#circuits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Circuit {
    /// The article's low-pressure circuit: an accumulator's pre-charge sets the pressure level
    /// (the article's 1 to 10 bar).
    LowPressure,
    /// The pressurised dual-prime-mover circuit the article cites (its references 5 and 10):
    /// the sum-pressure set-point raised so both chambers sit at tens of bar.
    Pressurised,
}

impl Circuit {
    /// The circuit in words: `low-pressure`, `pressurised`.
    pub fn name(self) -> &'static str {
        match self {
            Circuit::LowPressure => "low-pressure",
            Circuit::Pressurised => "pressurised",
        }
    }
}

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
}

/// The standstill balance of `rig` at the chamber pressures `p_bar` (bar gauge; the circuit's
/// [`crate::circuit::Dpm::standstill_balance`], docs/select.md#cost).
pub fn standing_loss(rig: &Rig, p_bar: [f64; 2]) -> StandingLoss {
    let circuit = crate::circuit::Dpm::linear(rig);
    let b = circuit.standstill_balance(p_bar.map(|p| p * 1e5));
    let d = circuit.si().d;
    let rpm = |q: f64, d: f64| q / d * 60.0 / (2.0 * PI);
    StandingLoss {
        p_bar,
        power_w: b.power_w,
        speed_rpm: [0, 1].map(|k| rpm(b.flow_m3_s[k], d[k])),
        torque_nm: b.torque_nm,
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
    /// The circuit.
    pub circuit: Circuit,
    /// Mean chamber pressure (bar gauge).
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
    /// Each wave's largest control error at `kp_max` over the gas-fraction range and the
    /// loads, [least, most] (mm); empty when `kp_max` is 0.
    pub tracking_max_error_mm: Vec<[f64; 2]>,
    /// The 10–90 % rise time of a 5 mm step at `kp_max` over the gas-fraction range and the
    /// loads, [least, most] (s; `null` in JSON where a step never reaches 90 %); `None` when
    /// `kp_max` is 0.
    pub rise_time_s: Option<[f64; 2]>,
    /// The standstill cost at the lowest and the highest external force; `None` (`null` in
    /// JSON) where a chamber would cavitate there (docs/model.md#cavitation): no state to cost.
    pub standing: Option<[StandingLoss; 2]>,
    /// The larger of the two standing losses (W); `None` as `standing`.
    pub standing_loss_w: Option<f64>,
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
    /// The lowest of the levels evaluated (`options`) that meets the requirement (bar).
    pub min_level_bar: Option<f64>,
    /// The bisection's last bracket [fails, meets] (bar); `None` without a bisection.
    pub min_mean_pressure_bracket_bar: Option<[f64; 2]>,
    /// The candidate at `min_mean_pressure_bar`, in the circuit of the level `min_level_bar`.
    pub at_min_mean_pressure: Option<Candidate>,
    /// The lowest level that meets the requirement (index into `options`).
    pub chosen: Option<usize>,
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
    check(rig, req, levels, kp).map_err(|(key, m)| SelectError::Input(format!("`{key}` = {m}")))?;
    crate::circuit::require_dpm(rig, "select").map_err(SelectError::Input)?;
    crate::limits::check_work(
        "mass_kg loads × pressure levels (cases)",
        cases(req, levels),
        crate::limits::MAX_SELECT_CASES,
        work.allow_long_run,
    )?;
    let loads = req.targets.mass_kg.len().max(1) as u64;
    // the candidates are independent: one per thread
    let options = levels
        .par_iter()
        .map(|&(circuit, p)| {
            let c = candidate(rig, req, circuit, p, kp);
            (work.progress)(loads);
            c
        })
        .collect::<Result<Vec<_>, _>>()?;
    answer(rig, req, options, kp)
}

/// The cases a selection evaluates: each load (the rig's mass when none is given) at each
/// pressure level.
pub fn cases(req: &Requirement, levels: &[(Circuit, f64)]) -> f64 {
    req.targets.mass_kg.len().max(1) as f64 * levels.len() as f64
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
            let key = match circuit {
                Circuit::LowPressure => "low_pressure_bar",
                Circuit::Pressurised => "pressurised_bar",
            };
            return bad(key, format!("{p}: every level must lie in (0, 1000] bar"));
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
) -> Result<Candidate, SelectError> {
    let at = |x: f64| Rig {
        beta_bar: effective_beta(x, p_bar, req.beta_oil_bar),
        p_sum_ref_bar: 2.0 * p_bar,
        ..rig.clone()
    };
    let (soft, stiff, reference) = (
        at(req.gas_fraction_max),
        at(req.gas_fraction_min),
        at(req.gas_fraction),
    );
    // the margins are monotone in β_e, so the range's ends bound it (docs/select.md)
    let kp_reference = design::kp_max_worst_case(&reference, &req.targets)?;
    let kp_at = |r: &Rig, x: f64| -> Result<f64, DesignError> {
        // a zero-width range (or an end at the reference) is one design, not three
        if x == req.gas_fraction {
            Ok(kp_reference)
        } else {
            design::kp_max_worst_case(r, &req.targets)
        }
    };
    let kp_stiff = kp_at(&stiff, req.gas_fraction_min)?;
    let kp_range = kp_at(&soft, req.gas_fraction_max)?
        .min(kp_stiff)
        .min(kp_reference);
    let kp_max = fixed_kp.unwrap_or(kp_range);
    let mut out = Candidate {
        circuit,
        mean_pressure_bar: p_bar,
        beta_e_bar: [soft.beta_bar, stiff.beta_bar],
        kp_max,
        kp_max_range: kp_range,
        kp_max_reference: kp_reference,
        tracking_max_error_mm: Vec::new(),
        rise_time_s: None,
        standing: None,
        standing_loss_w: None,
        meets: false,
        meets_best_case: false,
        margins_hold_at_reference_gas_fraction: false,
        reason: String::new(),
    };
    let standing = match standstill(rig, req, p_bar) {
        Ok(standing) => standing,
        Err(why) => {
            out.reason = why;
            return Ok(out);
        }
    };
    out.standing = Some(standing);
    out.standing_loss_w = Some(standing[0].power_w.max(standing[1].power_w));
    if let Some(why) = over_rating(rig, &standing) {
        out.reason = why;
        return Ok(out);
    }
    out.margins_hold_at_reference_gas_fraction = kp_max > 0.0 && kp_max <= kp_reference;
    let (band, failing) = assess(req, &[&stiff, &soft], kp_max, kp_range)?;
    if let Some(band) = band {
        out.tracking_max_error_mm = band.tracking_mm;
        out.rise_time_s = Some(band.rise_time_s);
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
                "at Kp = {kp:.2} with the sum-pressure loop closed: {e}"
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

/// The responses at one gain over the uncertainty: each wave's largest control error and the
/// rise time, as [least, most].
struct Band {
    tracking_mm: Vec<[f64; 2]>,
    rise_time_s: [f64; 2],
}

/// Each wave's largest control error and the step's rise time at gain `kp` over `ends` (the
/// rigs at the ends of the gas-fraction range) and the loads of `req` (each its mass at x0),
/// as [least, most]; a step that never reaches 90 % counts as an infinite rise time.
fn response_band(req: &Requirement, ends: &[&Rig], kp: f64) -> Result<Band, DesignError> {
    let waves: Vec<(f64, f64)> = req.waves.iter().map(|w| (w.freq_hz, w.amp_mm)).collect();
    let widen = |b: &mut [f64; 2], v: f64| *b = [b[0].min(v), b[1].max(v)];
    let mut band = Band {
        tracking_mm: vec![[f64::INFINITY, f64::NEG_INFINITY]; waves.len()],
        rise_time_s: [f64::INFINITY, f64::NEG_INFINITY],
    };
    for end in ends {
        let loads = match req.targets.mass_kg.as_slice() {
            [] => vec![end.mass_kg],
            loads => loads.to_vec(),
        };
        for mass_kg in loads {
            let r = Rig {
                kp,
                mass_kg,
                ..(*end).clone()
            };
            let at = design::predicted_tracking(&r, &waves)?;
            for (b, m) in band.tracking_mm.iter_mut().zip(&at) {
                widen(b, m.max_error_mm);
            }
            let s = crate::response::step(&r, RISE_STEP_MM, RISE_WINDOW_S, RISE_RATE_HZ)?;
            let rise = crate::response::step_metrics_of(&r, &s, RISE_STEP_MM).rise_time_s;
            widen(&mut band.rise_time_s, rise.unwrap_or(f64::INFINITY));
        }
    }
    Ok(band)
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

/// The lowest level of `options` that meets the requirement (index).
fn lowest_meeting(options: &[Candidate]) -> Option<usize> {
    options
        .iter()
        .enumerate()
        .filter(|(_, c)| c.meets)
        .min_by(|a, b| a.1.mean_pressure_bar.total_cmp(&b.1.mean_pressure_bar))
        .map(|(k, _)| k)
}

/// The lowest mean pressure between the levels: the candidate `options[k]` (the lowest level
/// that meets) bisected, in its circuit, against the highest level below it (which fails, as
/// every level below the lowest meeting one does) to [`REFINE_TOLERANCE_BAR`], at most
/// [`MAX_BISECTIONS`] steps. The meeting candidate found and the last bracket [fails, meets]
/// (none when no level lies below).
fn refine(
    rig: &Rig,
    req: &Requirement,
    options: &[Candidate],
    k: usize,
    kp: Option<f64>,
) -> Result<(Candidate, Option<[f64; 2]>), SelectError> {
    let meeting = &options[k];
    let below = options
        .iter()
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
        let c = candidate(rig, req, meeting.circuit, mid, kp)?;
        if c.meets {
            (hi, at) = (mid, c);
        } else {
            lo = mid;
        }
    }
    Ok((at, Some([lo, hi])))
}

/// The verdict and why: the circuit of the lowest meeting candidate `at` (refined), else
/// whether any level meets in the best case.
fn verdict(options: &[Candidate], at: Option<&Candidate>) -> (Verdict, Vec<String>) {
    let low: Vec<&Candidate> = options
        .iter()
        .filter(|c| c.circuit == Circuit::LowPressure)
        .collect();
    let low_best = low.iter().find(|c| c.meets_best_case);
    match at {
        Some(c) if c.circuit == Circuit::LowPressure => (
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
                        "uncertain with the low-pressure circuit: at {} bar it meets the requirement only in the best case, not over the whole gas-fraction range; {pressurised}",
                        b.mean_pressure_bar
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
) -> Result<Selection, SelectError> {
    let chosen = lowest_meeting(&options);
    let (at, bracket) = match chosen {
        Some(k) => {
            let (at, bracket) = refine(rig, req, &options, k, kp)?;
            (Some(at), bracket)
        }
        None => (None, None),
    };
    let (verdict, reasons) = verdict(&options, at.as_ref());
    Ok(Selection {
        min_mean_pressure_bar: at.as_ref().map(|c| c.mean_pressure_bar),
        min_level_bar: chosen.map(|k| options[k].mean_pressure_bar),
        min_mean_pressure_bracket_bar: bracket,
        at_min_mean_pressure: at,
        chosen,
        options,
        verdict,
        reasons,
        gas_fraction: [req.gas_fraction_min, req.gas_fraction, req.gas_fraction_max],
        gas_fraction_from: req.gas_fraction_from,
        rig: req.rig_from.clone(),
    })
}

/// An application to choose a circuit for (docs/formats.md#application-toml): the rig, the
/// uncertainty of the undissolved air, the targets, the loads, the waves and the pressure
/// levels to try. Field names are the TOML keys; units are in the names.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Application {
    /// The reference gas fraction X (dimensionless).
    pub gas_fraction: f64,
    /// The lowest gas fraction considered.
    pub gas_fraction_min: f64,
    /// The highest gas fraction considered.
    pub gas_fraction_max: f64,
    /// Pure-oil bulk modulus of the gas-fraction model (bar).
    pub beta_oil_bar: f64,
    /// Phase margin target (deg).
    pub target_pm_deg: f64,
    /// Gain margin target (dB).
    pub target_gm_db: f64,
    /// Stroke excursion on each side of x0 (mm).
    pub stroke_mm: f64,
    /// Loads, each its mass at x0 (kg); empty = the rig's `mass_kg`.
    pub mass_kg: Vec<f64>,
    /// External force range [lowest, highest] (N).
    pub external_force_n: [f64; 2],
    /// Mean chamber pressures of the low-pressure circuit to try (bar).
    pub low_pressure_bar: Vec<f64>,
    /// Mean chamber pressures of the pressurised circuit to try (bar).
    pub pressurised_bar: Vec<f64>,
    /// The waves to track within an error.
    pub wave: Vec<WaveRequirement>,
    /// Largest 10–90 % rise time of a 5 mm step allowed (s); absent: not required.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rise_time_s: Option<f64>,
    /// The rig: a `[rig]` table (any rig key; absent keys take the article's rig) or the name
    /// of a rig file, relative to the application file (docs/formats.md#application-toml).
    #[serde(deserialize_with = "rig_table_or_file")]
    pub rig: Rig,
    /// Where the rig came from (not a key).
    #[serde(skip)]
    pub rig_from: RigFrom,
    /// Where the gas-fraction range came from (not a key).
    #[serde(skip)]
    pub gas_fraction_from: GasFractionFrom,
    /// The keys the application leaves to the rig (not a key): each follows it as
    /// [`Application::with_rig`] says.
    #[serde(skip)]
    pub follows_rig: FollowsRig,
}

/// The application keys that, absent, follow the rig (docs/select.md#the-gas-fraction): the
/// gas fraction is read off the rig's β at its mean chamber pressure (the article's
/// identification on the article's rig), its range is a factor 2 either way of it, and the
/// loads are the rig's `mass_kg` (the article's two loads on the article's rig).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FollowsRig {
    /// `gas_fraction` follows the rig.
    pub gas_fraction: bool,
    /// `gas_fraction_min` is half the reference.
    pub gas_fraction_min: bool,
    /// `gas_fraction_max` is twice the reference.
    pub gas_fraction_max: bool,
    /// `mass_kg` follows the rig.
    pub mass_kg: bool,
}

impl FollowsRig {
    /// Every such key follows the rig.
    pub const ALL: FollowsRig = FollowsRig {
        gas_fraction: true,
        gas_fraction_min: true,
        gas_fraction_max: true,
        mass_kg: true,
    };

    /// Those of `self` whose key is not `key` (a key stated).
    fn stated(mut self, key: &str) -> FollowsRig {
        match key {
            "gas_fraction" => self.gas_fraction = false,
            "gas_fraction_min" => self.gas_fraction_min = false,
            "gas_fraction_max" => self.gas_fraction_max = false,
            "mass_kg" => self.mass_kg = false,
            _ => {}
        }
        self
    }
}

impl Default for FollowsRig {
    fn default() -> Self {
        FollowsRig::ALL
    }
}

/// The article's two loads (kg at x0), the loads of the article's application on its rig.
pub const ARTICLE_LOADS_KG: [f64; 2] = [4898.0, 10593.0];

/// The `rig` key: a table of rig keys, or a file name (the placeholder rig it gives here is
/// replaced by the file's as the application is read: [`Application::from_file_in`]).
fn rig_table_or_file<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Rig, D::Error> {
    struct TableOrFile;
    impl<'de> serde::de::Visitor<'de> for TableOrFile {
        type Value = Rig;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a [rig] table or the name of a rig file")
        }
        fn visit_str<E: serde::de::Error>(self, _: &str) -> Result<Rig, E> {
            Ok(Rig::default())
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Rig, A::Error> {
            serde::Deserialize::deserialize(serde::de::value::MapAccessDeserializer::new(map))
        }
    }
    d.deserialize_any(TableOrFile)
}

/// An identification's word on the gas fraction: the interval of β its records leave, at the
/// pressure they were taken (docs/select.md#from-an-identification).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BetaEvidence {
    /// The β interval (bar).
    pub beta_bar: [f64; 2],
    /// The point estimate (bar).
    pub beta_nominal_bar: f64,
    /// The records' mean chamber pressure (bar gauge).
    pub p_mean_bar: f64,
    /// The interval's confidence level.
    pub confidence: f64,
}

impl BetaEvidence {
    /// Identify `exp`'s records and read the β interval at `confidence` off the profiles
    /// (docs/identification.md, "Uncertainty"), at the first record's mean chamber pressure.
    ///
    /// # Errors
    /// The identification or the profiles fail, or the first record has no chamber pressures.
    pub fn of_records(
        exp: &crate::ident::Experiment,
        confidence: f64,
    ) -> Result<BetaEvidence, SelectError> {
        let p_mean_bar = exp.mean_chamber_pressure_bar().ok_or_else(|| {
            SelectError::Input(format!(
                "{}: the first dataset's record has no chamber pressures (p1_bar, p2_bar) to read the gas fraction at",
                exp.path.display()
            ))
        })?;
        let (_, region) = crate::design::Region::of_records(exp, confidence)?;
        Ok(BetaEvidence::of_region(&region, confidence, p_mean_bar))
    }

    /// The β interval of a confidence `region` already computed (at `confidence`), read at the
    /// records' mean chamber pressure `p_mean_bar` (bar).
    pub fn of_region(region: &crate::design::Region, confidence: f64, p_mean_bar: f64) -> Self {
        BetaEvidence {
            beta_bar: region.beta_bar,
            beta_nominal_bar: region.nominal.beta_bar,
            p_mean_bar,
            confidence,
        }
    }
}

impl Default for Application {
    /// The article's application with pumpcyl's requirement (docs/select.md#the-article-s-application):
    /// the article's rig, its gas fraction 2.64 % (β 165 bar at 4.4 bar) and its two loads; a
    /// factor 2 either way on the gas fraction, the default targets ([`Targets::default`]: PM 34°,
    /// GM 6 dB over x0 ± 50 mm) and the 0.2 Hz ±35 mm wave within 14 mm are pumpcyl's choices,
    /// since the article sets no range, no gain-margin target and no tracking requirement.
    ///
    /// [`Targets::default`]: crate::design::Targets
    fn default() -> Self {
        let x = ARTICLE_READING
            .gas_fraction(crate::bulk::BETA_OIL_BAR)
            .unwrap_or(0.0264);
        Application {
            gas_fraction: x,
            gas_fraction_min: x / 2.0,
            gas_fraction_max: 2.0 * x,
            beta_oil_bar: crate::bulk::BETA_OIL_BAR,
            target_pm_deg: 34.0,
            target_gm_db: 6.0,
            stroke_mm: 50.0,
            mass_kg: ARTICLE_LOADS_KG.to_vec(),
            external_force_n: [0.0, 0.0],
            low_pressure_bar: (1..=10).map(f64::from).collect(),
            pressurised_bar: vec![20.0, 30.0, 50.0],
            wave: vec![WaveRequirement {
                freq_hz: 0.2,
                amp_mm: 35.0,
                max_error_mm: 14.0,
            }],
            max_rise_time_s: None,
            rig: Rig::default(),
            rig_from: RigFrom::Article,
            gas_fraction_from: GasFractionFrom::Article(ARTICLE_READING),
            follows_rig: FollowsRig::ALL,
        }
    }
}

impl Application {
    /// Parse an application from TOML text; `name` stands for the file in messages, which name
    /// the line and the key. A `rig` file name is read from `files`, relative to `dir`.
    pub fn from_toml_in(
        files: &dyn crate::input::Files,
        text: &str,
        name: &str,
        dir: &std::path::Path,
    ) -> Result<Application, SelectError> {
        let located = |key: &str, message: String| {
            let path: Vec<crate::input::Key> =
                key.split('.').map(crate::input::Key::Name).collect();
            let line = crate::input::toml_line(text, &path)
                .map_or(String::new(), |l| format!("line {l}, "));
            SelectError::Input(format!("{name}: {line}key `{key}`: {message}"))
        };
        let syntax = |e: toml::de::Error| {
            SelectError::Input(format!("{name}: {}", crate::input::toml_error(&e, text)))
        };
        let mut app: Application = toml::from_str(text).map_err(syntax)?;
        let raw: toml::Table = toml::from_str(text).map_err(syntax)?;
        app.rig_from = match raw.get("rig") {
            Some(toml::Value::String(file)) => {
                let path = dir.join(file);
                app.rig =
                    Rig::from_file_in(files, &path).map_err(|e| located("rig", e.to_string()))?;
                RigFrom::File {
                    path: path.display().to_string(),
                }
            }
            Some(_) => RigFrom::Table,
            None => RigFrom::Article,
        };
        app.follows_rig = raw.keys().fold(FollowsRig::ALL, |f, key| f.stated(key));
        app.resolve()
            .and_then(|()| app.validate())
            .map_err(|(key, message)| located(&key, message))?;
        Ok(app)
    }

    /// [`Application::from_toml_in`] with a `rig` file name read from disk, relative to the
    /// working directory.
    pub fn from_toml_str(text: &str, name: &str) -> Result<Application, SelectError> {
        Self::from_toml_in(&crate::input::Disk, text, name, std::path::Path::new("."))
    }

    /// Read and check an application file; a `rig` file name is relative to it.
    pub fn from_file_in(
        files: &dyn crate::input::Files,
        path: &std::path::Path,
    ) -> Result<Application, SelectError> {
        let name = path.display().to_string();
        let text = crate::input::read_text(files, path)
            .map_err(|e| SelectError::Input(format!("{name}: {e}")))?;
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        Self::from_toml_in(files, &text, &name, dir)
    }

    /// The application on `rig` (from `from`): the keys it leaves to the rig follow it
    /// ([`FollowsRig`]), then every value is checked.
    ///
    /// # Errors
    /// The rig's β at its mean pressure gives no gas fraction, or a value does not fit the
    /// rig (a wave beyond its stroke, a load out of range), the key named.
    pub fn with_rig(&self, rig: Rig, from: RigFrom) -> Result<Application, SelectError> {
        let mut app = Application {
            rig,
            rig_from: from,
            ..self.clone()
        };
        app.resolve()
            .and_then(|()| app.validate())
            .map_err(|(key, m)| SelectError::Input(format!("key `{key}`: {m}")))?;
        Ok(app)
    }

    /// Set the keys that follow the rig ([`FollowsRig`]) from it: the gas fraction from the
    /// rig's β at its mean chamber pressure ([`BetaReading::for_rig`]), a factor 2 either way,
    /// and the loads; the error names the key.
    fn resolve(&mut self) -> Result<(), (String, String)> {
        // what the keys follow, checked first so that a fault is named where it lies
        self.check_rig()?;
        check_oil(self.beta_oil_bar)?;
        let article_rig = self.rig_from == RigFrom::Article;
        let follows = self.follows_rig;
        if follows.mass_kg {
            self.mass_kg = if article_rig && self.rig.mass_kg == Rig::default().mass_kg {
                ARTICLE_LOADS_KG.to_vec()
            } else {
                Vec::new()
            };
        }
        if follows.gas_fraction {
            let reading = BetaReading::for_rig(&self.rig, article_rig);
            self.gas_fraction = reading.gas_fraction(self.beta_oil_bar).map_err(|e| {
                let m = format!(
                    "absent, so read off the rig's beta {} bar at its mean chamber pressure {} bar, which gives none: {e}; state gas_fraction",
                    reading.beta_bar, reading.p_mean_bar
                );
                ("gas_fraction".to_string(), m)
            })?;
            self.gas_fraction_from = if reading == ARTICLE_READING {
                GasFractionFrom::Article(reading)
            } else {
                GasFractionFrom::Rig(reading)
            };
        } else if matches!(
            self.gas_fraction_from,
            GasFractionFrom::Article(_) | GasFractionFrom::Rig(_)
        ) {
            self.gas_fraction_from = GasFractionFrom::Application;
        }
        if follows.gas_fraction_min {
            self.gas_fraction_min = 0.5 * self.gas_fraction;
        }
        if follows.gas_fraction_max {
            self.gas_fraction_max = 2.0 * self.gas_fraction;
        }
        Ok(())
    }

    /// Apply `KEY=VALUE` overrides (`rig.KEY=VALUE` for a rig key; values in TOML), then check;
    /// errors name `source_name` and the key.
    pub fn with_overrides(
        &self,
        source_name: &str,
        assignments: &[String],
    ) -> Result<Application, SelectError> {
        if assignments.is_empty() {
            return Ok(self.clone());
        }
        let err = |a: &str, message: String| SelectError::Set {
            source_name: source_name.to_string(),
            assignment: a.to_string(),
            message,
        };
        let mut table = toml::Table::try_from(self).map_err(|e| err("", e.to_string()))?;
        for a in assignments {
            let (key, raw) = a
                .split_once('=')
                .ok_or_else(|| err(a, "expected KEY=VALUE".into()))?;
            let (key, raw) = (key.trim(), raw.trim());
            let value = crate::input::parse_value(raw);
            let (place, leaf) = match key.strip_prefix("rig.") {
                Some(rig_key) => (
                    table.get_mut("rig").and_then(toml::Value::as_table_mut),
                    rig_key,
                ),
                None => (Some(&mut table), key),
            };
            let place = place.ok_or_else(|| err(a, "no rig table".into()))?;
            let value = match place.get(leaf) {
                Some(current) => crate::input::typed_like(current, value).map_err(|got| {
                    err(
                        a,
                        format!("key `{key}` takes a {}, got {got}", current.type_str()),
                    )
                })?,
                // an optional key left out: its type is checked as the application is read
                None if OPTIONAL_KEYS.contains(&key) => value,
                None => return Err(err(a, format!("unknown key `{key}`"))),
            };
            place.insert(leaf.to_string(), value);
        }
        let app: Application = table.try_into().map_err(|e: toml::de::Error| {
            err(
                &assignments.join(" "),
                crate::input::serde_message(e.message()),
            )
        })?;
        let mut app = Application {
            rig_from: self.rig_from.clone(),
            gas_fraction_from: self.gas_fraction_from,
            follows_rig: assignments
                .iter()
                .filter_map(|a| a.split_once('=').map(|(k, _)| k.trim()))
                .fold(self.follows_rig, FollowsRig::stated),
            ..app
        };
        app.resolve()
            .and_then(|()| app.validate())
            .map_err(|(key, message)| SelectError::Invalid {
                source_name: source_name.to_string(),
                key: key.to_string(),
                message,
            })?;
        Ok(app)
    }

    /// The application with its gas-fraction range read off an identified interval of β
    /// (docs/select.md#from-an-identification): the soft end of β gives the highest X, the
    /// stiff end the lowest, the estimate the reference.
    ///
    /// # Errors
    /// An interval that is not ordered around the estimate, or a β the gas-fraction model
    /// cannot reach (at or above the oil's modulus).
    pub fn with_evidence(&self, e: &BetaEvidence) -> Result<Application, SelectError> {
        let [lo, hi] = e.beta_bar;
        if !(lo <= e.beta_nominal_bar && e.beta_nominal_bar <= hi) {
            return Err(SelectError::Input(format!(
                "the beta interval [{lo}, {hi}] bar does not hold its estimate {} bar",
                e.beta_nominal_bar
            )));
        }
        let x = |b: f64| {
            crate::bulk::gas_fraction(b, e.p_mean_bar, self.beta_oil_bar)
                .map_err(|err| SelectError::Input(format!("gas fraction from beta {b} bar: {err}")))
        };
        let out = Application {
            gas_fraction_min: x(hi)?,
            gas_fraction: x(e.beta_nominal_bar)?,
            gas_fraction_max: x(lo)?,
            gas_fraction_from: GasFractionFrom::Identification(*e),
            follows_rig: FollowsRig {
                gas_fraction: false,
                gas_fraction_min: false,
                gas_fraction_max: false,
                ..self.follows_rig
            },
            ..self.clone()
        };
        out.validate()
            .map_err(|(key, m)| SelectError::Input(format!("key `{key}`: {m}")))?;
        Ok(out)
    }

    /// The application as TOML with a comment per key, ready to edit (what `pumpcyl select
    /// --print-default` prints).
    pub fn to_commented_toml(&self) -> String {
        let mut table = toml::Table::try_from(self).expect("an application always serialises");
        table.remove("rig");
        let mut out = String::from(
            "# pumpcyl application (docs/formats.md#application-toml; docs/select.md). Units are part of every key.\n\
             # Absent keys take the article's application; the gas fraction and the loads follow the rig.\n\
             # [rig] takes any rig key (`pumpcyl rig`); or name a rig file: rig = \"my-rig.toml\" (relative to this file).\n",
        );
        for (key, doc) in APPLICATION_KEY_DOCS.iter().filter(|(k, _)| *k != "wave") {
            match table.get(*key) {
                Some(value) => out.push_str(&format!("{key} = {value}  # {doc}\n")),
                None => out.push_str(&format!("# {key} = 0.5  # {doc}\n")),
            }
        }
        for w in &self.wave {
            out.push_str(&format!(
                "\n[[wave]]  # a wave to track and the largest control error allowed\nfreq_hz = {:?}\namp_mm = {:?}\nmax_error_mm = {:?}\n",
                w.freq_hz, w.amp_mm, w.max_error_mm
            ));
        }
        out.push_str(&format!(
            "\n[rig]  # {}: the keys that differ from the article's rig (`pumpcyl rig` lists them all)\n",
            self.rig_from.describe()
        ));
        let ours = toml::Table::try_from(&self.rig).expect("a rig always serialises");
        let article = toml::Table::try_from(Rig::file_default()).expect("a rig always serialises");
        for (key, value) in ours.iter().filter(|(k, v)| article.get(*k) != Some(*v)) {
            out.push_str(&format!("{key} = {value}\n"));
        }
        out
    }

    /// Every value checked, the error naming its key: the rig's rules, the loads in the range
    /// of the rig's `mass_kg`, forces finite, at least one wave and one pressure level, the
    /// targets, and what every selection checks (gas fractions, waves, levels).
    pub fn validate(&self) -> Result<(), (String, String)> {
        self.check_rig()?;
        let fail = |key: &str, message: String| Err((key.to_string(), message));
        for &m in &self.mass_kg {
            if let Some(rule) = Rig::check_key("mass_kg", m) {
                return fail("mass_kg", format!("{m}: every load {rule}"));
            }
        }
        for f in self.external_force_n {
            if !(f.is_finite() && f.abs() <= 1e8) {
                return fail(
                    "external_force_n",
                    format!("{f}: must be finite, at most 1e8 N"),
                );
            }
        }
        if self.wave.is_empty() && self.max_rise_time_s.is_none() {
            return fail(
                "wave",
                "no requirement: give at least one [[wave]] or max_rise_time_s".into(),
            );
        }
        if self.low_pressure_bar.len() + self.pressurised_bar.len() == 0 {
            return fail("low_pressure_bar", "no pressure level to try".into());
        }
        if self.low_pressure_bar.len() + self.pressurised_bar.len() > MAX_LEVELS {
            return fail(
                "low_pressure_bar",
                format!("more than {MAX_LEVELS} pressure levels"),
            );
        }
        let targets = [
            ("target_pm_deg", self.target_pm_deg),
            ("target_gm_db", self.target_gm_db),
            ("stroke_mm", self.stroke_mm),
        ];
        for (key, v) in targets {
            if !(v.is_finite() && v >= 0.0) {
                return fail(key, format!("{v}: must be a finite number >= 0"));
            }
        }
        check(&self.rig, &self.requirement(), &self.levels(), None)
    }

    /// The rig's rules, the error naming its key as `rig.KEY`.
    fn check_rig(&self) -> Result<(), (String, String)> {
        self.rig.validate("rig").map_err(|e| match e {
            RigError::Invalid {
                key, value, rule, ..
            } => (format!("rig.{key}"), format!("{value}: {rule}")),
            other => ("rig".to_string(), other.to_string()),
        })
    }

    /// The requirement this application states.
    pub fn requirement(&self) -> Requirement {
        Requirement {
            gas_fraction: self.gas_fraction,
            gas_fraction_min: self.gas_fraction_min,
            gas_fraction_max: self.gas_fraction_max,
            beta_oil_bar: self.beta_oil_bar,
            targets: Targets {
                pm_deg: self.target_pm_deg,
                gm_db: self.target_gm_db,
                stroke_mm: self.stroke_mm,
                mass_kg: self.mass_kg.clone(),
                // no pressure list or waves: each candidate sets β_e and tracks itself
                ..Targets::default()
            },
            waves: self.wave.clone(),
            max_rise_time_s: self.max_rise_time_s,
            external_force_n: self.external_force_n,
            gas_fraction_from: self.gas_fraction_from,
            rig_from: self.rig_from.clone(),
        }
    }

    /// The circuits and pressure levels to try, low-pressure first, pressure rising.
    pub fn levels(&self) -> Vec<(Circuit, f64)> {
        let mut out: Vec<(Circuit, f64)> = Vec::new();
        for (circuit, ps) in [
            (Circuit::LowPressure, &self.low_pressure_bar),
            (Circuit::Pressurised, &self.pressurised_bar),
        ] {
            let mut ps = ps.clone();
            ps.sort_by(f64::total_cmp);
            out.extend(ps.into_iter().map(|p| (circuit, p)));
        }
        out
    }

    /// Run the selection ([`select`]); `kp` fixes the gain.
    pub fn select(&self, kp: Option<f64>) -> Result<Selection, SelectError> {
        self.select_with(kp, &crate::limits::Work::QUIET)
    }

    /// Run the selection ([`select_with`]) as `work` allows and follows it.
    pub fn select_with(
        &self,
        kp: Option<f64>,
        work: &crate::limits::Work,
    ) -> Result<Selection, SelectError> {
        select_with(&self.rig, &self.requirement(), &self.levels(), kp, work)
    }

    /// The load × level cases its selection evaluates ([`cases`]).
    pub fn cases(&self) -> f64 {
        cases(&self.requirement(), &self.levels())
    }
}

/// Each application key with its unit and meaning, in the order `to_commented_toml` writes them.
pub const APPLICATION_KEY_DOCS: &[(&str, &str)] = &[
    (
        "gas_fraction",
        "reference undissolved-gas fraction X (absent: the rig's beta at its mean chamber pressure, half p_sum_ref_bar; on the article's rig its 165 bar at 4.4 bar)",
    ),
    (
        "gas_fraction_min",
        "lowest X considered (absent: a factor 2 below; undissolved air varies between applications)",
    ),
    (
        "gas_fraction_max",
        "highest X considered (absent: a factor 2 above; the worst case for beta_e)",
    ),
    (
        "beta_oil_bar",
        "bar, pure-oil bulk modulus of the gas-fraction model",
    ),
    ("target_pm_deg", "deg, phase margin target"),
    ("target_gm_db", "dB, gain margin target"),
    (
        "stroke_mm",
        "mm, stroke excursion checked on each side of x0",
    ),
    (
        "mass_kg",
        "kg, loads (each its mass at x0; along the stroke it follows rig.mass_by_position; empty: rig.mass_kg; absent: the rig's, the article's two loads on its rig)",
    ),
    (
        "external_force_n",
        "N, external force range [lowest, highest] (the standing cost is taken at both)",
    ),
    (
        "low_pressure_bar",
        "bar, mean chamber pressures of the low-pressure circuit (accumulator pre-charge)",
    ),
    (
        "pressurised_bar",
        "bar, mean chamber pressures of the pressurised dual-prime-mover circuit",
    ),
    (
        "max_rise_time_s",
        "s, largest 10-90 % rise time of a 5 mm step (absent: not required)",
    ),
    (
        "wave",
        "waves to track: [[wave]] freq_hz, amp_mm, max_error_mm",
    ),
];

/// The application keys that may be absent (no value to take a type from).
const OPTIONAL_KEYS: &[&str] = &["max_rise_time_s"];

/// Most pressure levels an application may list.
pub const MAX_LEVELS: usize = 200;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bulk::{gas_fraction, BETA_OIL_BAR};

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
        let levels: Vec<(Circuit, f64)> =
            (1..=10).map(|p| (Circuit::LowPressure, p as f64)).collect();
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
            &[(Circuit::LowPressure, 4.4)],
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
        let s = select(&Rig::default(), &req, &[(Circuit::LowPressure, 4.4)], None).unwrap();
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
        let levels = [(Circuit::LowPressure, 3.0), (Circuit::LowPressure, 6.0)];
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
        let x = gas_fraction(300.0, 6.0, BETA_OIL_BAR).unwrap();
        assert_eq!(
            [app.gas_fraction_min, app.gas_fraction, app.gas_fraction_max],
            [x / 2.0, x, 2.0 * x]
        );
        assert!(app.mass_kg.is_empty());
        let reading = BetaReading {
            beta_bar: 300.0,
            p_mean_bar: 6.0,
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
        let s = select(&rig, &req, &[(Circuit::LowPressure, 1.0)], Some(25.0)).unwrap();
        let c = &s.options[0];
        let [_, p2] = chamber_pressures(&rig, 1.0, 5000.0);
        assert!(p2 < crate::cavitation::VAPOUR_PRESSURE_BAR_GAUGE, "{p2}");
        assert!(!c.meets && !c.meets_best_case && c.standing_loss_w.is_none());
        assert!(c.reason.contains("cavitation"), "{}", c.reason);
        req.external_force_n = [3000.0, -1000.0];
        let err = select(&rig, &req, &[(Circuit::LowPressure, 1.0)], Some(25.0)).unwrap_err();
        assert!(err.to_string().contains("external_force_n"), "{err}");
    }
}
