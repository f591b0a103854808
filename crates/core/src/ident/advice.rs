//! Experiment advice: which further record would shrink the uncertainty of (β, b, c12) most
//! (docs/identification.md, "Experiment advice").
//!
//! The method is the linearised (Fisher) counterpart of the profile-likelihood intervals of
//! the uncertainty analysis. With θ = (ln β, ln b, ln c12) and position noise of variance σ²
//! (inflated by the AR(1) factor of correlated residuals, as the uncertainty analysis does),
//! the information of a record is JᵀJ/σ², J the sensitivities ∂x/∂θ (mm) of its simulated
//! position, each record's initial position fitted (the sensitivities' mean over the fit
//! window removed, which is the offset's Schur complement). The sensitivities are central
//! differences of the exact ZOH simulation of the LTI model (docs/model.md) with a step of
//! [`LOG_STEP`] in ln θ. The information of the existing records plus a candidate's, inverted,
//! is the expected covariance of θ after adding that record; the interval of parameter i is
//! θ̂ᵢ·exp(±z·sdᵢ), z the normal quantile of the confidence. The same formula without a
//! candidate gives the current widths, so each candidate's gain reads as a ratio.
//!
//! A direction the records do not inform (b from the article's steps) makes the information
//! singular or nearly so: the inverse is a pseudo-inverse on the information scaled to unit
//! diagonal (eigenvalues below [`RCOND`] times the largest are dropped), and a parameter whose
//! linearised interval reaches a search bound ([`BOUNDS`]) or that lies in the dropped
//! directions is reported as unbounded, not as a meaningless huge number.
//!
//! A sweep candidate (a multisine, a stepped sine) is fitted in the frequency domain, so its
//! information is that cost's, over its lines ([`sweep_information`]). A candidate costs its
//! length: with a budget ([`AdviceOptions::budget_s`]) each is counted as often as it fits in
//! that recording time, otherwise once.

use super::grid::{candidate_values, Candidate};
use super::problem::{DatasetSpec, Prepared, Problem};
use super::refine::{candidate_of, log_point};
use super::uncertainty::{
    analyze, check_confidence, chi2_1_quantile, search_bound_at, UncertaintyOptions, BOUNDS,
    PARAMETERS,
};
use super::{Experiment, IdentError};
use crate::frf::spec::{DEFAULT_LEVELS, DEFAULT_LINES};
use crate::frf::{Excitation, SweepKind, SweepSpec};
use crate::lti::{eigenvalues, is_stable, PoleInfo};
use crate::model::Plant;
use crate::record::Record;
use crate::rig::Rig;
use crate::source_files::{self, FieldError, Key::Index, Key::Name};
use nalgebra::{Matrix3, SymmetricEigen};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::Path;

/// Step of the central differences in ln θ (0.1 %): the truncation error, about h²/6 of the
/// third derivative, is ~10⁻⁷ relative, while the simulation's rounding (~10⁻¹³ relative for
/// the balanced exact ZOH) divided by h stays ~10⁻¹⁰.
pub const LOG_STEP: f64 = 1e-3;
/// Relative eigenvalue below which a direction of the (unit-diagonal) information counts as
/// not informed at all.
pub const RCOND: f64 = 1e-12;
/// Most candidate experiments compared in one call.
pub const MAX_CANDIDATES: usize = 200;
/// Longest candidate record (s) after its rest.
pub const MAX_DURATION_S: f64 = 600.0;
/// Time at rest before the excitation starts (s), as in the article's records.
pub const REST_S: f64 = 0.5;
/// Default duration of a candidate record after its rest (s): the same recording time for
/// every candidate, one period of the slowest default sinusoid.
pub const DEFAULT_DURATION_S: f64 = 10.0;
/// Default step sizes (mm).
pub const DEFAULT_STEPS_MM: [f64; 4] = [2.0, 5.0, 10.0, 20.0];
/// Default sinusoid frequencies (Hz): across the closed loop's lightly damped pair and the hydraulic
/// resonance of the article's rig (0.6 and 1 Hz), far below the records' Nyquist frequency.
pub const DEFAULT_FREQS_HZ: [f64; 6] = [0.1, 0.2, 0.5, 0.8, 1.0, 1.5];
/// Default position gains tried besides the experiment's own, as factors on its largest: a
/// softer and a stiffer loop of the rig's own (the article's records at Kp 25 get 15 and 35).
pub const DEFAULT_KP_FACTORS: [f64; 2] = [0.6, 1.4];
/// Largest default sinusoid amplitude (mm).
pub const DEFAULT_MAX_AMP_MM: f64 = 20.0;
/// Share of the speed at which pump 1 alone, at its maximum speed, moves the piston that a
/// default sinusoid's peak velocity may use (so the pumps stay far from saturation, where the
/// linear model holds).
pub const VELOCITY_SHARE: f64 = 0.5;
/// Fewest samples per period of a sinusoid.
pub const MIN_SAMPLES_PER_PERIOD: f64 = 10.0;
/// Least closed-loop damping ratio at the identified point of a candidate's gain: below it
/// the loop rings for dozens of periods, too close to instability to run on a rig whose
/// parameters are uncertain (the article's design targets of §2.2 keep it far higher).
pub const MIN_DAMPING: f64 = 0.05;
/// Iteration limit of the 3×3 symmetric eigen-decomposition.
const EIGEN_ITERS: usize = 1000;

/// A candidate further experiment: a record of the closed loop at gain `kp` driven by a step
/// or a sinusoid after [`REST_S`] at rest, lasting `duration_s` after it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Design {
    /// A reference step of `step_mm` (mm; negative retracts).
    Step {
        /// Step size (mm).
        step_mm: f64,
        /// Position gain (normalised command per metre).
        kp: f64,
        /// Record length after the rest (s).
        duration_s: f64,
    },
    /// A reference sinusoid x0 + A·sin(2πf(t − rest)).
    Sine {
        /// Frequency (Hz).
        freq_hz: f64,
        /// Amplitude (mm).
        amp_mm: f64,
        /// Position gain (normalised command per metre).
        kp: f64,
        /// Record length after the rest (s).
        duration_s: f64,
    },
    /// A sweep about x0 (a multisine, a chirp or a stepped sine, the keys of
    /// docs/formats.md#sweep-records-and-their-description) starting after the rest, fitted in the frequency
    /// domain (docs/identification.md#grey-box-fit-to-a-frequency-response). Built by
    /// [`Design::sweep`], which fills in its band and amplitude.
    Sweep {
        /// The sweep, its band and amplitude resolved.
        sweep: SweepSpec,
        /// Position gain (normalised command per metre).
        kp: f64,
        /// Record length after the rest (s), from the sweep's keys.
        duration_s: f64,
    },
}

impl Design {
    /// The position gain.
    pub fn kp(&self) -> f64 {
        match *self {
            Design::Step { kp, .. } | Design::Sine { kp, .. } | Design::Sweep { kp, .. } => kp,
        }
    }

    /// Record length after the rest (s).
    pub fn duration_s(&self) -> f64 {
        match *self {
            Design::Step { duration_s, .. }
            | Design::Sine { duration_s, .. }
            | Design::Sweep { duration_s, .. } => duration_s,
        }
    }

    /// The sweep `spec` at gain `kp` on `rig` (the experiment's, its gain set to `kp`) for
    /// records at `rate_hz`: its absent band and amplitude from the designer, its start after
    /// the rest, checked ([`SweepSpec::excitation`]).
    pub fn sweep(spec: &SweepSpec, kp: f64, rig: &Rig, rate_hz: f64) -> Result<Design, FieldError> {
        let at = Rig { kp, ..rig.clone() };
        let sweep = SweepSpec {
            at_s: Some(REST_S),
            ..spec.resolved(&at, rate_hz)?
        };
        let e = sweep.excitation(&at, rate_hz)?;
        Ok(Design::Sweep {
            sweep,
            kp,
            duration_s: e.duration_s() - REST_S,
        })
    }

    /// The excitation of a sweep on `rig` (its x0; a stepped sine's settling from its loop)
    /// at `rate_hz`, starting after the rest; `None` for the other designs or a sweep `rig`
    /// cannot run.
    pub fn excitation(&self, rig: &Rig, rate_hz: f64) -> Option<Excitation> {
        let Design::Sweep { sweep, kp, .. } = self else {
            return None;
        };
        let at = Rig {
            kp: *kp,
            ..rig.clone()
        };
        sweep.excitation(&at, rate_hz).ok()
    }

    /// A short label: `step 5 mm, Kp 25, 10 s` or `sine 0.5 Hz 18.4 mm, Kp 25, 10 s`.
    pub fn label(&self) -> String {
        let tail = format!("Kp {}, {} s", self.kp(), self.duration_s());
        match *self {
            Design::Step { step_mm, .. } => format!("step {step_mm} mm, {tail}"),
            Design::Sine {
                freq_hz, amp_mm, ..
            } => format!("sine {freq_hz} Hz {amp_mm:.1} mm, {tail}"),
            Design::Sweep { sweep, kp, .. } => {
                let (lo, hi, a) = (
                    sweep.from_hz.unwrap_or_default(),
                    sweep.to_hz.unwrap_or_default(),
                    sweep.amplitude_mm.unwrap_or_default(),
                );
                let count = match sweep.kind {
                    SweepKind::Multisine => {
                        format!(" {} lines", sweep.lines.unwrap_or(DEFAULT_LINES))
                    }
                    SweepKind::SteppedSine => {
                        format!(" {} levels", sweep.levels.unwrap_or(DEFAULT_LEVELS))
                    }
                    SweepKind::Chirp => String::new(),
                };
                format!(
                    "{} {lo:.3}-{hi:.2} Hz{count} {a:.1} mm, Kp {kp}, {:.0} s",
                    sweep.kind.name(),
                    self.duration_s()
                )
            }
        }
    }

    /// The reference deviation (mm) at time `t` (s) from the start of the record.
    fn deviation_mm(&self, t: f64) -> f64 {
        let s = t - REST_S;
        if s < 0.0 {
            return 0.0;
        }
        match *self {
            Design::Step { step_mm, .. } => step_mm,
            Design::Sine {
                freq_hz, amp_mm, ..
            } => amp_mm * (2.0 * PI * freq_hz * s).sin(),
            Design::Sweep { .. } => 0.0,
        }
    }

    /// Check the design against the limits, the sample rate `rate_hz` and the stroke of `rig`
    /// (its reference, about x0, must stay inside it: [`Rig::check_reference`]); the error names
    /// the offending field.
    pub fn check(&self, rate_hz: f64, rig: &Rig) -> Result<(), FieldError> {
        let positive = |field: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(FieldError::new(
                    field,
                    format!("{field} = {v}: must be > 0"),
                ))
            }
        };
        positive("kp", self.kp())?;
        let d = self.duration_s();
        positive("duration_s", d)?;
        if d > MAX_DURATION_S {
            return Err(FieldError::new(
                "duration_s",
                format!("duration_s = {d}: longer than the limit of {MAX_DURATION_S} s"),
            ));
        }
        let samples = (REST_S + d) * rate_hz;
        crate::limits::check_samples(REST_S + d, rate_hz).map_err(|_| {
            FieldError::new(
                "duration_s",
                format!(
                    "duration_s = {d}: {samples:.0} samples at {rate_hz} Hz, more than the limit \
                     of {:e}",
                    crate::limits::MAX_SAMPLES
                ),
            )
        })?;
        let reach = match *self {
            Design::Step { step_mm, .. } => {
                if !(step_mm.is_finite() && step_mm != 0.0) {
                    return Err(FieldError::new(
                        "step_mm",
                        format!("step_mm = {step_mm}: must be a non-zero number"),
                    ));
                }
                ("step_mm", step_mm.min(0.0), step_mm.max(0.0))
            }
            Design::Sine {
                freq_hz, amp_mm, ..
            } => {
                positive("freq_hz", freq_hz)?;
                positive("amp_mm", amp_mm)?;
                if freq_hz * MIN_SAMPLES_PER_PERIOD > rate_hz {
                    return Err(FieldError::new(
                        "freq_hz",
                        format!(
                            "freq_hz = {freq_hz}: fewer than {MIN_SAMPLES_PER_PERIOD} samples \
                             per period at the records' {rate_hz} Hz"
                        ),
                    ));
                }
                ("amp_mm", -amp_mm, amp_mm)
            }
            Design::Sweep { sweep, kp, .. } => {
                let at = Rig { kp, ..rig.clone() };
                let e = sweep.excitation(&at, rate_hz)?;
                ("amplitude_mm", -e.amplitude_mm(), e.amplitude_mm())
            }
        };
        let (field, lo, hi) = reach;
        rig.check_reference(rig.x0_mm + lo, rig.x0_mm + hi)
            .map_err(|e| FieldError::new(field, format!("{field}: {e}")))
    }

    /// The design's record at `rate_hz` on `rig` (from its position x0): time, and the
    /// reference as both reference and position columns (only the reference matters to the
    /// sensitivities; the measured position cancels in them).
    pub fn record(&self, rate_hz: f64, rig: &Rig) -> Result<Record, IdentError> {
        let t = crate::response::sample_times(REST_S + self.duration_s(), rate_hz)?;
        let x0_mm = rig.x0_mm;
        let r: Vec<f64> = match self.excitation(rig, rate_hz) {
            Some(e) => t.iter().map(|&t| e.reference_mm(t)).collect(),
            None => t.iter().map(|&t| x0_mm + self.deviation_mm(t)).collect(),
        };
        Ok(Record::from_arrays(&self.label(), &t, &r, &r)?)
    }

    /// The design as a dataset of the identification problem, on the rig and mass of
    /// `like` (an existing dataset) at this design's gain, its fit window the whole record.
    pub fn prepared(&self, like: &Prepared, rate_hz: f64) -> Result<Prepared, IdentError> {
        let record = self.record(rate_hz, &like.rig)?;
        let spec = DatasetSpec {
            file: self.label(),
            kp: self.kp(),
            mass_kg: like.rig.mass_kg,
            fit_end_s: record.time_s[record.len() - 1],
        };
        Prepared::new(&spec, record, &like.rig)
    }
}

/// The default candidates for an experiment whose datasets use the gains `kps`: steps of
/// [`DEFAULT_STEPS_MM`] and sinusoids of [`DEFAULT_FREQS_HZ`] at each of `kps` and at
/// [`DEFAULT_KP_FACTORS`] times the largest of them (to 0.1), [`DEFAULT_DURATION_S`] each; a sinusoid's amplitude is the least of
/// [`DEFAULT_MAX_AMP_MM`], the amplitude whose peak velocity is `v_max_m_per_s`, and the room
/// in the stroke; frequencies with fewer than [`MIN_SAMPLES_PER_PERIOD`] samples per period
/// at `rate_hz` are left out.
pub fn default_designs(kps: &[f64], v_max_m_per_s: f64, room_mm: f64, rate_hz: f64) -> Vec<Design> {
    let largest = kps.iter().copied().fold(0.0, f64::max);
    let around = DEFAULT_KP_FACTORS.map(|f| (f * largest * 10.0).round() / 10.0);
    let mut gains: Vec<f64> = (kps.iter().chain(&around).copied())
        .filter(|k| *k > 0.0)
        .collect();
    gains.sort_by(f64::total_cmp);
    gains.dedup();
    let duration_s = DEFAULT_DURATION_S;
    let mut out = Vec::new();
    for &kp in &gains {
        for step_mm in DEFAULT_STEPS_MM.into_iter().filter(|s| *s <= room_mm) {
            out.push(Design::Step {
                step_mm,
                kp,
                duration_s,
            });
        }
        for freq_hz in DEFAULT_FREQS_HZ {
            if freq_hz * MIN_SAMPLES_PER_PERIOD > rate_hz {
                continue;
            }
            let amp_mm = DEFAULT_MAX_AMP_MM
                .min(v_max_m_per_s * 1e3 / (2.0 * PI * freq_hz))
                .min(room_mm);
            // one decimal: the amplitude a user would type
            let amp_mm = (amp_mm * 10.0).floor() / 10.0;
            out.push(Design::Sine {
                freq_hz,
                amp_mm,
                kp,
                duration_s,
            });
        }
    }
    out
}

/// A candidate file as written (docs/identification.md, "Experiment advice").
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct CandidateFile {
    #[serde(default)]
    step: Vec<StepSpec>,
    #[serde(default)]
    sine: Vec<SineSpec>,
    #[serde(default)]
    sweep: Vec<toml::Table>,
}

/// The `i`-th `[[sweep]]` entry of `text`, `table`: `kp` beside a sweep's keys, those of an
/// experiment file's `[dataset.sweep]` ([`SweepSpec`], docs/formats.md#sweep-records-and-their-description),
/// read apart so that a key neither knows is refused. The error names the key's line.
fn sweep_entry(
    text: &str,
    i: usize,
    mut table: toml::Table,
) -> Result<(f64, SweepSpec), (String, String)> {
    let line = |key: Option<&'static str>| {
        let mut path = vec![Name("sweep"), Index(i)];
        path.extend(key.map(Name));
        source_files::toml_line(text, &path).map_or(String::new(), |l| format!("line {l}, "))
    };
    let kp = match table.remove("kp") {
        Some(v) => v.as_float().or(v.as_integer().map(|k| k as f64)),
        None => None,
    };
    let kp = kp.ok_or_else(|| {
        (
            line(Some("kp")),
            "kp: needs the position gain, a number".into(),
        )
    })?;
    let spec = SweepSpec::deserialize(toml::Value::Table(table))
        .map_err(|e| (line(None), e.message().to_string()))?;
    Ok((kp, spec))
}

/// A `[[step]]` entry.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct StepSpec {
    step_mm: f64,
    kp: f64,
    duration_s: Option<f64>,
}

/// A `[[sine]]` entry.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SineSpec {
    freq_hz: f64,
    amp_mm: f64,
    kp: f64,
    duration_s: Option<f64>,
}

/// Read candidate designs from TOML text (`[[step]]` with `step_mm`, `kp`, optional
/// `duration_s`; `[[sine]]` with `freq_hz`, `amp_mm`, `kp`, optional `duration_s`; `[[sweep]]`
/// with `kp` and a sweep's keys, [`SweepSpec`], its absent band and amplitude from the
/// designer for `rig` at that `kp`), checked
/// against `rate_hz` and the stroke of `rig` as [`Design::check`] does. Errors are one line
/// naming `name`, the line and the key.
pub fn designs_from_toml(
    text: &str,
    name: &str,
    rate_hz: f64,
    rig: &Rig,
) -> Result<Vec<Design>, IdentError> {
    let file: CandidateFile = toml::from_str(text).map_err(|e| {
        IdentError::Input(format!("{name}: {}", source_files::toml_error(&e, text)))
    })?;
    let duration = |d: Option<f64>| d.unwrap_or(DEFAULT_DURATION_S);
    let steps = file.step.iter().map(|s| {
        (
            "step",
            Design::Step {
                step_mm: s.step_mm,
                kp: s.kp,
                duration_s: duration(s.duration_s),
            },
        )
    });
    let sines = file.sine.iter().map(|s| {
        (
            "sine",
            Design::Sine {
                freq_hz: s.freq_hz,
                amp_mm: s.amp_mm,
                kp: s.kp,
                duration_s: duration(s.duration_s),
            },
        )
    });
    let mut sweeps = Vec::with_capacity(file.sweep.len());
    for (i, table) in file.sweep.into_iter().enumerate() {
        let (kp, spec) = sweep_entry(text, i, table).map_err(|(line, m)| {
            IdentError::Input(format!("{name}: {line}[[sweep]] {}: {m}", i + 1))
        })?;
        sweeps.push(("sweep", Design::sweep(&spec, kp, rig, rate_hz)));
    }
    let all: Vec<(&str, Result<Design, FieldError>)> = (steps.map(|(t, d)| (t, Ok(d))))
        .chain(sines.map(|(t, d)| (t, Ok(d))))
        .chain(sweeps)
        .collect();
    if all.is_empty() {
        return Err(IdentError::Input(format!(
            "{name}: no candidate: give at least one [[step]], [[sine]] or [[sweep]]"
        )));
    }
    if all.len() > MAX_CANDIDATES {
        return Err(IdentError::Input(format!(
            "{name}: {} candidates, more than the limit of {MAX_CANDIDATES}",
            all.len()
        )));
    }
    let mut out = Vec::with_capacity(all.len());
    let mut index = [0usize; 3];
    for (table, d) in all {
        let k = ["step", "sine", "sweep"]
            .iter()
            .position(|t| *t == table)
            .unwrap_or(0);
        let checked = d.and_then(|d| d.check(rate_hz, rig).map(|()| d));
        match checked {
            Ok(d) => out.push(d),
            Err(m) => {
                let path = [Name(table), Index(index[k]), Name(m.field)];
                let line = source_files::toml_line(text, &path)
                    .map_or(String::new(), |l| format!("line {l}, "));
                return Err(IdentError::Input(format!(
                    "{name}: {line}[[{table}]] {}: {m}",
                    index[k] + 1
                )));
            }
        }
        index[k] += 1;
    }
    Ok(out)
}

/// [`designs_from_toml`] for the records of `problem`: its first dataset's sample rate,
/// rig position and stroke.
pub fn designs_for(problem: &Problem, text: &str, name: &str) -> Result<Vec<Design>, IdentError> {
    let first = first_step_record(problem)?;
    designs_from_toml(text, name, rate_hz(first), &first.rig)
}

/// The first step record of `problem`, whose sample rate, rig and position the candidates
/// take; refused in one line when the experiment has none (its records all sweeps, fitted in
/// the frequency domain): the advice weighs each candidate against the information of the step
/// records' time-domain fit (docs/identification.md, "Experiment advice").
fn first_step_record(problem: &Problem) -> Result<&Prepared, IdentError> {
    problem.datasets.first().ok_or_else(|| {
        IdentError::Input(
            "no step record: the advice weighs candidate experiments against the information \
             of the experiment's step records, and its records are all sweeps (fitted in the \
             frequency domain); add a step record to the experiment"
                .into(),
        )
    })
}

/// Options of the advice.
#[derive(Debug, Clone, PartialEq)]
pub struct AdviceOptions {
    /// Confidence level of the intervals, in (0, 1).
    pub confidence: f64,
    /// The candidates; `None` = [`default_designs`] for the experiment.
    pub designs: Option<Vec<Design>>,
    /// With the default candidates, add the multisine `pumpcyl frf --design` designs at each
    /// of the records' gains (fitted in the frequency domain).
    pub sweeps: bool,
    /// Recording time (s) every candidate is weighed at: its information times
    /// `budget_s`/its duration (the record played that many times, each an independent
    /// record), candidates longer than it skipped. `None`: each candidate is one record,
    /// whatever its length.
    pub budget_s: Option<f64>,
}

impl Default for AdviceOptions {
    fn default() -> Self {
        AdviceOptions {
            confidence: 0.95,
            designs: None,
            sweeps: true,
            budget_s: None,
        }
    }
}

/// The expected interval of one parameter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Width {
    /// The parameter (one of [`PARAMETERS`]).
    pub parameter: &'static str,
    /// Standard deviation of its logarithm (∞ when not informed at all); the intervals are
    /// θ̂·exp(±z·sd).
    pub log_std: f64,
    /// The expected interval in the parameter's unit (bar, N·s/m, m⁵/(N·s)); `None` when it
    /// is unbounded (it reaches a search bound).
    pub interval: Option<[f64; 2]>,
    /// Its width hi − lo (the parameter's unit); `None` when unbounded.
    pub width: Option<f64>,
    /// The width relative to the estimate; `None` when unbounded.
    pub relative_width: Option<f64>,
}

impl Width {
    /// This width shown as unbounded (no interval), its `log_std` kept for the ranking: the
    /// current width of a parameter whose records put its estimate at a search bound.
    fn unbounded(&self) -> Width {
        Width {
            interval: None,
            width: None,
            relative_width: None,
            ..*self
        }
    }
}

/// One candidate and what it is expected to give.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Assessment {
    /// The experiment.
    pub design: Design,
    /// A short label of it.
    pub label: String,
    /// Its record length after the rest (s): what it costs.
    pub duration_s: f64,
    /// Times its record is counted: the budget over its length, 1 without a budget.
    pub repeats: f64,
    /// Expected intervals of (β, b, c12) after adding its record to the existing ones.
    pub widths: [Width; 3],
    /// Improvement factor per parameter: current log-std over the expected one (≥ 1).
    pub improvement: [f64; 3],
    /// The ranking score: Σ ln(expected/current log-std), the log of the product of the
    /// width ratios (more negative is better).
    pub score: f64,
}

/// The advice: the current widths, the candidates ranked best first, the best per parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Advice {
    /// The point the model is linearised at: the identification's answer polished on the SSE,
    /// with the rig file's value for each parameter whose estimate sits at its search bound
    /// (`point_from_rig`).
    pub point: Candidate,
    /// The parameters (of [`PARAMETERS`](super::PARAMETERS)) whose estimate sat at its search
    /// bound, where the records do not bound them: the model is linearised at the rig's value
    /// instead (a bound such as b = 1 N·s/m linearises a model without friction, in which no
    /// record could show b), and their current widths are unbounded.
    pub point_from_rig: Vec<&'static str>,
    /// The identification's answer the point was polished from (`identify`'s refined best,
    /// which minimises the cost: each record's initial position from its samples at rest).
    pub identified: Candidate,
    /// Noise level σ (mm) estimated from the residuals there.
    pub noise_std_mm: f64,
    /// Factor on σ² for correlated residuals (the uncertainty analysis's AR(1) inflation),
    /// applied to the existing records and to every candidate's.
    pub variance_inflation: f64,
    /// Factor on each parameter's variance, (β, b, c12), for the model error the records'
    /// disagreement shows (the uncertainty analysis's, docs/identification.md, "Uncertainty"),
    /// applied to the current widths and to every candidate's: a new record is expected to
    /// disagree with the model as much as the existing ones do.
    #[serde(serialize_with = "by_parameter")]
    pub model_error_factor: [f64; 3],
    /// Confidence level.
    pub confidence: f64,
    /// The recording time every candidate is weighed at (s), if one was given.
    pub budget_s: Option<f64>,
    /// The normal quantile z of the intervals θ̂·exp(±z·sd).
    pub z: f64,
    /// The current widths (the existing records only), by the same formula.
    pub current: [Width; 3],
    /// The candidates, best (lowest score) first.
    pub candidates: Vec<Assessment>,
    /// Candidates left out, each with the reason (an unstable closed loop at the point).
    pub skipped: Vec<String>,
    /// Label of the candidate that narrows each of (β, b, c12) most; serialised keyed by the
    /// parameter's name (`best_for.viscous_friction_ns_per_m`), never by position.
    #[serde(serialize_with = "by_parameter")]
    pub best_for: [String; 3],
}

/// A value per parameter, in the order of [`PARAMETERS`](super::PARAMETERS), serialised as a map
/// keyed by the parameter's name.
fn by_parameter<T: Serialize, S: serde::Serializer>(v: &[T; 3], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut map = s.serialize_map(Some(v.len()))?;
    for (name, x) in super::PARAMETERS.iter().zip(v) {
        map.serialize_entry(name, x)?;
    }
    map.end()
}

/// The sensitivities' Gram matrix JᵀJ (mm²) of dataset `ds` at the point `p` in
/// (ln β, ln b, ln c12), each record's initial position fitted (residual means removed), by
/// central differences with step `h` in ln θ. The dataset need not belong to `problem`
/// (which gives the standstill point for c1, c2).
pub fn gram(
    problem: &Problem,
    ds: &Prepared,
    p: &[f64; 3],
    h: f64,
) -> Result<Matrix3<f64>, IdentError> {
    let columns = (0..3)
        .map(|i| {
            let at = |sign: f64| {
                let mut q = p.to_vec();
                q[i] += sign * h;
                problem
                    .residuals_offset_free(&candidate_of(&q), ds)
                    .ok_or_else(|| {
                        IdentError::Input(format!(
                            "dataset `{}`: the model cannot be simulated near the point",
                            ds.name
                        ))
                    })
            };
            let (plus, minus) = (at(1.0)?, at(-1.0)?);
            Ok(plus
                .iter()
                .zip(&minus)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect::<Vec<f64>>())
        })
        .collect::<Result<Vec<_>, IdentError>>()?;
    Ok(Matrix3::from_fn(|i, j| {
        columns[i].iter().zip(&columns[j]).map(|(a, b)| a * b).sum()
    }))
}

/// The expected intervals from the information `info` (JᵀJ/σ², in ln θ) at the point
/// `point`, with normal quantile `z`: pseudo-inverse on the unit-diagonal scaling, dropped
/// directions and intervals reaching [`BOUNDS`] reported as unbounded.
pub fn widths(info: &Matrix3<f64>, point: &Candidate, z: f64) -> Result<[Width; 3], IdentError> {
    let d: Vec<f64> = (0..3).map(|i| info[(i, i)]).collect();
    let informed: Vec<bool> = d.iter().map(|&v| v.is_finite() && v > 0.0).collect();
    let scale: Vec<f64> = (0..3)
        .map(|i| if informed[i] { 1.0 / d[i].sqrt() } else { 0.0 })
        .collect();
    let scaled = Matrix3::from_fn(|i, j| info[(i, j)] * scale[i] * scale[j]);
    let eig = SymmetricEigen::try_new(scaled, f64::EPSILON, EIGEN_ITERS).ok_or_else(|| {
        IdentError::Input("the information matrix has no eigen-decomposition".into())
    })?;
    let top = eig.eigenvalues.max().max(0.0);
    let mut var = [0.0; 3];
    let mut dropped = [0.0; 3];
    for k in 0..3 {
        let mu = eig.eigenvalues[k];
        let v = eig.eigenvectors.column(k);
        for i in 0..3 {
            if top > 0.0 && mu > RCOND * top {
                var[i] += v[i] * v[i] / mu * scale[i] * scale[i];
            } else {
                dropped[i] += v[i] * v[i];
            }
        }
    }
    let p = log_point(point);
    Ok(std::array::from_fn(|i| {
        let sd = if informed[i] && dropped[i] < 1e-6 {
            var[i].sqrt()
        } else {
            f64::INFINITY
        };
        let (lo, hi) = ((p[i] - z * sd).exp(), (p[i] + z * sd).exp());
        let [blo, bhi] = BOUNDS[i];
        let bounded = sd.is_finite() && lo > blo && hi < bhi;
        let estimate = p[i].exp();
        Width {
            parameter: PARAMETERS[i],
            log_std: sd,
            interval: bounded.then_some([lo, hi]),
            width: bounded.then_some(hi - lo),
            relative_width: bounded.then_some((hi - lo) / estimate),
        }
    }))
}

/// The Fisher information (in ln θ) of the sweep `d` recorded as the dataset `ds` at `rate_hz`,
/// at the point `p`, position noise of variance `var` (mm²): the frequency-domain cost's
/// Iᵢⱼ = Σ_k Re(∂T_k/∂θᵢ · conj ∂T_k/∂θⱼ)/σ_k², T the loop sampled at `rate_hz`
/// ([`crate::frf::sampled_loop_response`]) and σ_k² = 2·var/(M_k·r_k²) the variance of each
/// component of T̂ at line k from M_k samples of a sine of amplitude r_k (mm)
/// (`sweep_lines`). Derivatives by central differences with step `h` in ln θ, as
/// [`gram`]'s. A chirp, and any design not a sweep, gets the time-domain information of its
/// record, [`gram`]/`var`, which equals it by Parseval in the steady state.
pub fn sweep_information(
    problem: &Problem,
    ds: &Prepared,
    d: &Design,
    (p, h): (&[f64; 3], f64),
    var: f64,
    rate_hz: f64,
) -> Result<Matrix3<f64>, IdentError> {
    let lines = d
        .excitation(&ds.rig, rate_hz)
        .map(|e| sweep_lines(&e, rate_hz))
        .unwrap_or_default();
    if lines.is_empty() {
        return gram(problem, ds, p, h).map(|g| g / var);
    }
    let freqs: Vec<f64> = lines.iter().map(|l| l.0).collect();
    let response = |q: &[f64]| {
        let rig = problem.rig_for(&candidate_of(q), ds)?;
        crate::frf::sampled_loop_response(&Plant::new(&rig), rig.sum_pressure, &freqs, rate_hz)
            .map_err(|e| IdentError::Input(format!("{}: {e}", d.label())))
    };
    let columns = (0..3)
        .map(|i| {
            let at = |sign: f64| {
                let mut q = p.to_vec();
                q[i] += sign * h;
                response(&q)
            };
            let (plus, minus) = (at(1.0)?, at(-1.0)?);
            Ok(plus
                .iter()
                .zip(&minus)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect::<Vec<_>>())
        })
        .collect::<Result<Vec<_>, IdentError>>()?;
    let weight: Vec<f64> = lines
        .iter()
        .map(|&(_, amp_mm, samples)| samples * amp_mm * amp_mm / (2.0 * var))
        .collect();
    Ok(Matrix3::from_fn(|i, j| {
        (columns[i].iter().zip(&columns[j]).zip(&weight))
            .map(|((a, b), w)| w * (a * b.conj()).re)
            .sum::<f64>()
    }))
}

/// The lines a sweep's estimate averages: (frequency (Hz), amplitude (mm), samples averaged).
/// A multisine's lines over its periods after the first, which settles; a stepped sine's
/// levels over their fitted periods after settling; none for a chirp.
fn sweep_lines(e: &Excitation, rate_hz: f64) -> Vec<(f64, f64, f64)> {
    match *e {
        Excitation::Multisine {
            period_s,
            periods,
            line_mm,
            ..
        } => {
            let averaged = periods.saturating_sub(1).max(1) as f64 * period_s * rate_hz;
            (e.frequencies_hz().into_iter())
                .map(|f| (f, line_mm, averaged))
                .collect()
        }
        Excitation::SteppedSine { amplitude_mm, .. } => (e.levels().into_iter())
            .map(|l| (l.freq_hz, amplitude_mm, (l.end_s - l.settle_s) * rate_hz))
            .collect(),
        Excitation::Chirp { .. } => Vec::new(),
    }
}

/// The default sweeps at each gain of `kps`: the multisine `pumpcyl frf --design` designs for
/// the rig of `like` at that gain ([`crate::frf::design`]), its lines and period, its periods
/// cut to [`MAX_DURATION_S`]; none at a gain where fewer than 3 periods fit or the design
/// fails [`Design::check`].
fn default_sweeps(like: &Rig, kps: &[f64], rate_hz: f64) -> Vec<Design> {
    let goal = crate::frf::DesignGoal {
        rate_hz,
        ..crate::frf::DesignGoal::default()
    };
    kps.iter()
        .filter_map(|&kp| {
            let rig = Rig { kp, ..like.clone() };
            let d = crate::frf::design(&rig, &goal).ok()?;
            let fit = (MAX_DURATION_S / d.period_s).floor() as usize;
            let spec = SweepSpec {
                from_hz: Some(d.from_hz),
                to_hz: Some(d.to_hz),
                period_s: Some(d.period_s),
                lines: Some(d.lines),
                amplitude_mm: Some((d.amplitude_mm * 10.0).floor() / 10.0),
                periods: Some(d.periods.min(fit)),
                ..SweepSpec::of_kind(SweepKind::Multisine)
            };
            let sweep = Design::sweep(&spec, kp, &rig, rate_hz).ok()?;
            (d.periods.min(fit) >= 3 && sweep.check(rate_hz, &rig).is_ok()).then_some(sweep)
        })
        .collect()
}

/// The sample rate (Hz) of a dataset's record: samples per second over its length.
fn rate_hz(ds: &Prepared) -> f64 {
    let t = &ds.record.time_s;
    (t.len() - 1) as f64 / (t[t.len() - 1] - t[0])
}

/// The piston speed (m/s) of pump 1 alone at its maximum speed, times [`VELOCITY_SHARE`].
fn velocity_limit(rig: &crate::rig::Rig) -> f64 {
    let flow_m3_s = rig.pump_max_speed_rpm / 60.0 * rig.displacement_1_cm3_per_rev * 1e-6;
    VELOCITY_SHARE * flow_m3_s / rig.si().a1
}

/// Why a candidate experiment is left out of the ranking (it cannot be run at the identified
/// point), in words.
struct Skip(String);

/// Whether the record `ds` can be run on the rig whose parameters are `c`: its closed loop
/// stable with a least damping ratio of at least [`MIN_DAMPING`], and the motor speeds of its
/// predicted response within the motors' rated speed (beyond it the drives saturate and the
/// linear model no longer holds). The reason when not.
fn runnable(problem: &Problem, c: &Candidate, ds: &Prepared) -> Result<(), Skip> {
    let rig = problem.rig_for(c, ds).map_err(|e| Skip(e.to_string()))?;
    let sys = Plant::new(&rig).closed_loop(rig.sum_pressure);
    let poles = eigenvalues(&sys.a).map_err(|e| Skip(e.to_string()))?;
    if !is_stable(&poles) {
        return Err(Skip(
            "the closed loop is unstable at the identified point".into(),
        ));
    }
    let least = poles
        .into_iter()
        .filter_map(|p| PoleInfo::from(p).damping)
        .fold(1.0, f64::min);
    if least < MIN_DAMPING {
        return Err(Skip(format!(
            "closed-loop damping ratio {least:.3} at the identified point, below {MIN_DAMPING}: \
             too close to instability to run"
        )));
    }
    let s = problem.simulate(c, ds).map_err(|e| Skip(e.to_string()))?;
    for (k, w) in [&s.w1_rpm, &s.w2_rpm].into_iter().enumerate() {
        let peak = w.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
        if peak > rig.motor_rated_speed_rpm {
            return Err(Skip(format!(
                "motor {} would reach {peak:.0} rpm, above its rated {} rpm: the drives would \
                 saturate",
                k + 1,
                rig.motor_rated_speed_rpm
            )));
        }
    }
    Ok(())
}

/// Compare candidate experiments for the identification `problem` whose answer is `start`:
/// the current expected widths and each candidate's after adding its record, ranked.
pub fn advise(
    problem: &Problem,
    start: &Candidate,
    opts: &AdviceOptions,
) -> Result<Advice, IdentError> {
    let first = first_step_record(problem)?;
    let u = analyze(
        problem,
        start,
        &UncertaintyOptions {
            confidence: opts.confidence,
            profile: [false; 3],
        },
    )?;
    check_budget(opts.budget_s)?;
    let (point, from_rig) = linearisation_point(&u.best, &first.rig);
    let rate = rate_hz(first);
    let designs = match &opts.designs {
        Some(d) => d.clone(),
        None => {
            let mut kps: Vec<f64> = problem.datasets.iter().map(|d| d.rig.kp).collect();
            let rig = &first.rig;
            let room = rig.x0_mm.min(rig.stroke_mm - rig.x0_mm);
            let mut d = default_designs(&kps, velocity_limit(rig), room, rate);
            kps.sort_by(f64::total_cmp);
            kps.dedup();
            if opts.sweeps {
                let at_point = problem.rig_for(&point, first)?;
                d.extend(default_sweeps(&at_point, &kps, rate));
            }
            d
        }
    };
    if designs.is_empty() || designs.len() > MAX_CANDIDATES {
        return Err(IdentError::Input(format!(
            "{} candidate experiments: give 1 to {MAX_CANDIDATES}",
            designs.len()
        )));
    }
    let p: [f64; 3] = log_point(&point).try_into().expect("three parameters");
    let var = u.noise_std_mm.powi(2) * u.variance_inflation;
    let z = chi2_1_quantile(opts.confidence).sqrt();
    let mut existing = Matrix3::zeros();
    for ds in &problem.datasets {
        existing += gram(problem, ds, &p, LOG_STEP)? / var;
    }
    // the model error the records' disagreement shows stays with every candidate
    let model_error = model_error_factor(&u);
    let existing = with_model_error(&existing, &model_error);
    let mut current = widths(&existing, &point, z)?;
    for &i in &from_rig {
        current[i] = current[i].unbounded();
    }
    let assessed: Vec<Result<Result<Assessment, Skip>, IdentError>> = designs
        .par_iter()
        .map(|d| {
            d.check(rate, &first.rig)
                .map_err(|m| IdentError::Input(format!("candidate `{}`: {m}", d.label())))?;
            let ds = d.prepared(first, rate)?;
            let repeats = match opts.budget_s {
                Some(b) if d.duration_s() > b => {
                    let why = format!("{} s, longer than the budget of {b} s", d.duration_s());
                    return Ok(Err(Skip(format!("{}: {why}", d.label()))));
                }
                Some(b) => b / d.duration_s(),
                None => 1.0,
            };
            if let Err(Skip(why)) = runnable(problem, &point, &ds) {
                return Ok(Err(Skip(format!("{}: {why}", d.label()))));
            }
            let info = sweep_information(problem, &ds, d, (&p, LOG_STEP), var, rate)? * repeats;
            let added = with_model_error(&info, &model_error);
            let info = existing + added;
            let w = widths(&info, &point, z)?;
            let improvement: [f64; 3] =
                std::array::from_fn(|i| ratio(current[i].log_std, w[i].log_std));
            Ok(Ok(Assessment {
                design: *d,
                label: d.label(),
                duration_s: d.duration_s(),
                repeats,
                widths: w,
                improvement,
                score: -improvement.iter().map(|r| r.ln()).sum::<f64>(),
            }))
        })
        .collect();
    let mut candidates = Vec::new();
    let mut skipped = Vec::new();
    for a in assessed {
        match a? {
            Ok(a) => candidates.push(a),
            Err(Skip(why)) => skipped.push(why),
        }
    }
    if candidates.is_empty() {
        return Err(IdentError::Input(format!(
            "no candidate experiment can be run at the identified point: {}",
            skipped.join("; ")
        )));
    }
    candidates.sort_by(|a, b| a.score.total_cmp(&b.score));
    let best_for = std::array::from_fn(|i| {
        candidates
            .iter()
            .min_by(|a, b| a.widths[i].log_std.total_cmp(&b.widths[i].log_std))
            .map(|a| a.label.clone())
            .unwrap_or_default()
    });
    Ok(Advice {
        point,
        point_from_rig: from_rig.iter().map(|&i| PARAMETERS[i]).collect(),
        identified: *start,
        noise_std_mm: u.noise_std_mm,
        variance_inflation: u.variance_inflation,
        model_error_factor: model_error,
        confidence: opts.confidence,
        budget_s: opts.budget_s,
        z,
        current,
        candidates,
        skipped,
        best_for,
    })
}

/// The point to linearise at: `best`, with the value of `rig` (the rig file's, where it lies
/// inside the search bounds) for each parameter whose estimate sits at its search bound
/// ([`search_bound_at`]); and those parameters' indices.
fn linearisation_point(best: &Candidate, rig: &Rig) -> (Candidate, Vec<usize>) {
    let mut values = candidate_values(best);
    let own = [
        rig.beta_bar,
        rig.viscous_friction_ns_per_m,
        rig.c12_m5_per_ns,
    ];
    let mut replaced = Vec::new();
    for i in 0..3 {
        let inside = own[i] > BOUNDS[i][0] && own[i] < BOUNDS[i][1];
        if search_bound_at(i, values[i]).is_some() && inside && search_bound_at(i, own[i]).is_none()
        {
            values[i] = own[i];
            replaced.push(i);
        }
    }
    let [beta_bar, viscous_friction_ns_per_m, c12_m5_per_ns] = values;
    let point = Candidate {
        beta_bar,
        viscous_friction_ns_per_m,
        c12_m5_per_ns,
    };
    (point, replaced)
}

/// Each parameter's factor on its variance from the model error the datasets' disagreement
/// shows, as the uncertainty analysis finds it (its per-parameter inflation over the noise's
/// own); 1 where the records agree or there is one record.
fn model_error_factor(u: &super::uncertainty::Uncertainty) -> [f64; 3] {
    u.inflation_by_parameter
        .map(|f| (f / u.variance_inflation).max(1.0))
}

/// The information with each parameter's variance multiplied by its factor `f`:
/// I'ᵢⱼ = Iᵢⱼ / √(fᵢ fⱼ), so the covariance's (pseudo-)inverse scales as √(fᵢ fⱼ) and each
/// width by √fᵢ.
fn with_model_error(info: &Matrix3<f64>, f: &[f64; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| info[(i, j)] / (f[i] * f[j]).sqrt())
}

/// The whole advice for a loaded experiment: its identification on its own grids and options
/// (refused when it would take hours, as `identify` does without `--allow-long-run`), then
/// [`advise`] on the candidates of the TOML file `candidates` (read from `files`) or on the
/// defaults, each weighed at the recording time `budget_s` where given
/// ([`AdviceOptions::budget_s`]).
pub fn advise_experiment(
    exp: &Experiment,
    files: &dyn source_files::Files,
    candidates: Option<&Path>,
    (confidence, budget_s): (f64, Option<f64>),
) -> Result<Advice, IdentError> {
    let confidence = check_confidence(confidence)?;
    check_budget(budget_s)?;
    // before the candidates are read and the records identified: the same refusal with or
    // without a candidates file
    first_step_record(&exp.problem)?;
    let designs = match candidates {
        Some(path) => {
            let name = path.display().to_string();
            let text = source_files::read_text(files, path)
                .map_err(|m| IdentError::Input(format!("{name}: {m}")))?;
            Some(designs_for(&exp.problem, &text, &name)?)
        }
        None => None,
    };
    let id = exp.identify(&exp.options())?;
    let opts = AdviceOptions {
        confidence,
        designs,
        sweeps: true,
        budget_s,
    };
    advise(&exp.problem, &id.best().candidate, &opts)
}

/// Refuse a budget that is not a positive number of seconds.
fn check_budget(budget_s: Option<f64>) -> Result<(), IdentError> {
    match budget_s {
        Some(b) if !(b.is_finite() && b > 0.0) => Err(IdentError::Input(format!(
            "budget_s = {b}: the recording time must be a positive number of seconds"
        ))),
        _ => Ok(()),
    }
}

/// `before / after` for log-stds, 1 when both are infinite (no information either way).
fn ratio(before: f64, after: f64) -> f64 {
    if before.is_infinite() && after.is_infinite() {
        1.0
    } else {
        before / after
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_model_error_factor_widens_each_parameter_by_its_root() {
        // a coupled, well-conditioned information: each log-std grows by exactly √fᵢ
        let info = Matrix3::new(4e4, 1e3, -2e3, 1e3, 9e2, 3e2, -2e3, 3e2, 2.5e4);
        let point = Candidate {
            beta_bar: 165.0,
            viscous_friction_ns_per_m: 100.0,
            c12_m5_per_ns: 1.2e-10,
        };
        let f = [2.85, 42.4, 4.35];
        let before = widths(&info, &point, 1.96).unwrap();
        let after = widths(&with_model_error(&info, &f), &point, 1.96).unwrap();
        for i in 0..3 {
            let r = after[i].log_std / before[i].log_std;
            assert!((r - f[i].sqrt()).abs() < 1e-9 * r, "{i}: {r}");
        }
    }

    #[test]
    fn a_singular_information_gives_unbounded_not_huge() {
        // β and c12 informed, b not at all, and a near-duplicate direction
        let point = Candidate {
            beta_bar: 165.0,
            viscous_friction_ns_per_m: 100.0,
            c12_m5_per_ns: 1.2e-10,
        };
        let info = Matrix3::new(4e4, 0.0, 1e3, 0.0, 0.0, 0.0, 1e3, 0.0, 1e4);
        let w = widths(&info, &point, 1.96).unwrap();
        assert!(w[1].interval.is_none() && w[1].log_std.is_infinite());
        // the 2×2 block inverted by hand: var(ln β) = 1e4 / (4e8 − 1e6)
        let var0: f64 = 1e4 / (4e8 - 1e6);
        assert!((w[0].log_std / var0.sqrt() - 1.0).abs() < 1e-9);
        let [lo, hi] = w[0].interval.unwrap();
        assert!(((hi / lo).ln() - 2.0 * 1.96 * var0.sqrt()).abs() < 1e-12);
        // a tiny but non-zero b information whose interval reaches the bounds: unbounded too
        let weak = Matrix3::new(4e4, 0.0, 0.0, 0.0, 1e-3, 0.0, 0.0, 0.0, 1e4);
        let w = widths(&weak, &point, 1.96).unwrap();
        assert!(w[1].log_std.is_finite() && w[1].interval.is_none());
        assert!(w[0].interval.is_some() && w[2].interval.is_some());
    }

    #[test]
    fn candidate_file_errors_name_the_line_and_key() {
        let ok = "[[step]]\nstep_mm = 5.0\nkp = 25.0\n[[sine]]\nfreq_hz = 0.5\namp_mm = 10.0\nkp = 20.0\nduration_s = 4.0\n";
        let d = designs_from_toml(ok, "c.toml", 100.0, &Rig::default()).unwrap();
        assert_eq!(d.len(), 2);
        assert_eq!(d[1].duration_s(), 4.0);
        let bad = [
            (
                "[[sine]]\nfreq_hz = 0.5\namp_mm = -3.0\nkp = 25.0\n",
                "line 3",
                "amp_mm",
            ),
            (
                "[[step]]\nstep_mm = 5.0\nkp = 25.0\nsize = 2\n",
                "line 4",
                "size",
            ),
            ("[[step]]\nstep_mm = 400.0\nkp = 25.0\n", "line 2", "stroke"),
            (
                "[[sine]]\nfreq_hz = 20.0\namp_mm = 3.0\nkp = 25.0\n",
                "line 2",
                "samples per",
            ),
            (
                "[[step]]\nstep_mm = 5.0\nkp = 25.0\nduration_s = 1e6\n",
                "line 4",
                "limit",
            ),
            ("", "c.toml", "no candidate"),
        ];
        for (text, line, needle) in bad {
            let e = designs_from_toml(text, "c.toml", 100.0, &Rig::default())
                .unwrap_err()
                .to_string();
            assert!(e.contains(line) && e.contains(needle), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn default_gains_come_from_the_experiments_own() {
        // a rig recorded at Kp 15 and 10: 0.6 and 1.4 times 15 beside them, not the article's
        // 25 and 35
        let gains = |kps: &[f64]| {
            let mut g: Vec<f64> = (default_designs(kps, 0.058, 155.0, 100.0).iter())
                .map(Design::kp)
                .collect();
            g.dedup();
            g
        };
        assert_eq!(gains(&[15.0, 10.0]), [9.0, 10.0, 15.0, 21.0]);
        assert_eq!(gains(&[25.0, 20.0]), [15.0, 20.0, 25.0, 35.0]);
        assert_eq!(gains(&[2.5]), [1.5, 2.5, 3.5]);
    }

    #[test]
    fn default_sines_stay_inside_the_velocity_and_the_stroke() {
        let d = default_designs(&[25.0, 20.0], 0.058, 155.0, 100.0);
        // gains 15, 20, 25, 35: 4 steps + 6 sines each
        assert_eq!(d.len(), 4 * 10);
        for x in &d {
            if let Design::Sine {
                freq_hz, amp_mm, ..
            } = *x
            {
                assert!(2.0 * PI * freq_hz * amp_mm * 1e-3 <= 0.058 + 1e-12);
                assert!(amp_mm <= DEFAULT_MAX_AMP_MM);
            }
        }
        // at 10 Hz sampling, the 1.5 Hz sinusoid is left out (1.0 Hz has its 10 samples)
        assert_eq!(
            default_designs(&[25.0], 0.058, 155.0, 10.0).len(),
            3 * (4 + 5)
        );
    }
}
