//! Grey-box fit of β, b and c12 to measured frequency responses, alone or with step records
//! (docs/identification.md#grey-box-fit-to-a-frequency-response).
//!
//! Each sweep record gives its closed-loop response T̂ = x/x_ref with a relative random error ε
//! at each frequency ([`crate::frf::estimate`]). An H1 estimate's error is as large across its
//! direction as along it (ε·|T̂| on the magnitude, ε rad on the phase), so the complex residual
//! T(jω; θ) − T̂ has the variance ε²|T̂|² in each of its two components, and the weighted cost
//!
//! J(θ) = Σ_k |T(jω_k; θ) − T̂_k|² / (ε_k |T̂_k|)²
//!
//! over the usable frequencies of every sweep (coherence at least the estimate's usable level)
//! is −2 log-likelihood up to a constant, χ² with 2K − 3 degrees of freedom at the optimum
//! when ε is right (Pintelon & Schoukens, *System Identification: A Frequency Domain
//! Approach*, 2nd ed., Wiley 2012, §7–9). T is the circuit's linear loop
//! ([`crate::model::Plant`]) with its controller sampled at the record's rate, as a PLC runs
//! it ([`crate::frf::sampled_loop_response`]: the controller's hold delays the loop by half a
//! sample, which at a 100 Hz PLC takes about a fifth off the article rig's fitted b if left
//! out), c1 and c2 from the standstill point as in the step fit.
//! J is scaled by s² = J_min/(2K − 3) so that model error widens the intervals as the step
//! identification's σ² does. With step records too, their SSE is divided by their own noise
//! variance σ² (at their own optimum, inflated for correlated residuals) and added: each kind
//! of record counts as the information it carries, not as its number of samples. The step
//! records are simulated with the controller sampled too ([`Problem::with_sampled_controller`]).
//!
//! The search: the experiment's first grid on the sweeps' cost, then Nelder–Mead on
//! (ln β, ln b, ln c12) from its best point (on the sum, with step records), then profile
//! likelihoods as for the steps ([`super::uncertainty`]).

use super::grid::{Candidate, Grid};
use super::leakage::{Leakage, Standstill};
use super::problem::{Prepared, Problem};
use super::refine::candidate_of;
use super::uncertainty::{
    bounded, check_confidence, chi2_1_quantile, polish_with, step_noise, Profile, Scan,
};
use super::IdentError;
use crate::frf::{self, Complex64, Estimate, FrfError};
use crate::lti::{eigenvalues, is_stable};
use crate::model::Plant;
use crate::record::Record;
use crate::rig::Rig;
use rayon::prelude::*;
use serde::Serialize;

/// Unknowns fitted (β, b, c12).
const FITTED: usize = 3;
/// The sweeps' scale s² = J_min/(2K − 3) above which the model does not explain the estimates
/// and the fit warns. With the model right, s² is χ²_ν/ν (ν = 2K − 3), whose 99.99 % point is
/// 5.1 at ν = 5 and lower for more frequencies (at the fewest a fit takes, K = 2, s² exceeds 10
/// with probability 0.0016); measured 0.42–1.83 on 17 emulated multisines of two rigs at three
/// bands (seeds 1–6, every effect off, K 4–23), against 280–1100 with the emulator's
/// friction and dead band on and 7.6e4–3.3e6 for a record at one Kp declared at another
/// (docs/identification.md#the-intervals).
pub const MODEL_ERROR_SCALE: f64 = 10.0;

/// A dataset read: a step record ready for the time-domain fit or a sweep's estimate.
#[derive(Debug, Clone)]
pub enum Loaded {
    /// A step record.
    Step(Box<Prepared>),
    /// A sweep record's frequency response.
    Sweep(Box<SweepSet>),
}

/// One sweep record ready to fit: its estimate and the usable frequencies with their weights.
#[derive(Debug, Clone)]
pub struct SweepSet {
    /// Label (the file name as given).
    pub name: String,
    /// The rig with this record's Kp and mass.
    pub rig: Rig,
    /// The frequency response estimated from the record.
    pub estimate: Estimate,
    /// Usable frequencies (Hz).
    freq_hz: Vec<f64>,
    /// T̂ there.
    measured: Vec<Complex64>,
    /// 1/(ε|T̂|)² there.
    weight: Vec<f64>,
}

impl SweepSet {
    /// Estimate the frequency response of `record` (taken on `rig`, its Kp and mass set) and
    /// keep the frequencies whose coherence is usable. Refused as [`frf::estimate`] refuses a
    /// record (not a sweep, too short, no usable coherence, ending below the crossover).
    pub fn new(name: &str, record: &Record, rig: Rig) -> Result<SweepSet, FrfError> {
        SweepSet::described(name, record, rig, None)
    }

    /// [`SweepSet::new`] for a record of the sweep `excitation` where it is described (an
    /// experiment file's `[dataset.sweep]`): its reference is checked against the description
    /// and estimated as that sweep (a stepped sine level by level).
    pub fn described(
        name: &str,
        record: &Record,
        rig: Rig,
        excitation: Option<frf::Excitation>,
    ) -> Result<SweepSet, FrfError> {
        let opts = frf::Options {
            excitation,
            rig: Some(&rig),
            segment_s: None,
        };
        let estimate = frf::estimate(record, &opts)?;
        let usable = estimate.usable_coherence;
        let (mut freq_hz, mut measured, mut weight) = (Vec::new(), Vec::new(), Vec::new());
        for p in &estimate.closed_loop.points {
            let sd = p.relative_error * p.h().norm();
            if p.coherence >= usable && sd.is_finite() && sd > 0.0 {
                freq_hz.push(p.freq_hz);
                measured.push(p.h());
                weight.push(1.0 / (sd * sd));
            }
        }
        Ok(SweepSet {
            name: name.to_string(),
            rig,
            estimate,
            freq_hz,
            measured,
            weight,
        })
    }

    /// The frequencies the fit uses (Hz).
    pub fn frequencies_hz(&self) -> &[f64] {
        &self.freq_hz
    }

    /// The lowest frequency the fit uses (Hz).
    fn lowest_fitted_hz(&self) -> f64 {
        self.freq_hz.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Why the fit starts at [`SweepSet::lowest_fitted_hz`]: the estimate's reason where it is
    /// the estimate's lowest frequency, else the coherence below the usable level beneath it.
    fn lowest_fitted_reason(&self) -> String {
        let est = &self.estimate;
        if self.lowest_fitted_hz() <= est.lowest_frequency_hz {
            return est.lowest_frequency_reason.clone();
        }
        format!(
            "the coherence is below the usable {:.3} from the estimate's lowest frequency, \
             {:.4} Hz ({}), up to it",
            est.usable_coherence, est.lowest_frequency_hz, est.lowest_frequency_reason
        )
    }

    /// The closed loop of `rig` at `freq_hz`, its controller sampled at the record's rate
    /// ([`frf::sampled_loop_response`]); `None` when the continuous loop is unstable or the
    /// response cannot be computed.
    pub fn model_at(&self, rig: &Rig, freq_hz: &[f64]) -> Option<Vec<Complex64>> {
        let plant = Plant::new(rig);
        let sys = plant.closed_loop(rig.sum_pressure);
        if !eigenvalues(&sys.a).is_ok_and(|p| is_stable(&p)) {
            return None;
        }
        frf::sampled_loop_response(&plant, rig.sum_pressure, freq_hz, self.estimate.rate_hz).ok()
    }

    /// J of this record for the rig `rig` (+∞ when its loop is unstable).
    fn cost(&self, rig: &Rig) -> f64 {
        let Some(model) = self.model_at(rig, &self.freq_hz) else {
            return f64::INFINITY;
        };
        let j: f64 = model
            .iter()
            .zip(&self.measured)
            .zip(&self.weight)
            .map(|((m, h), w)| w * (m - h).norm_sqr())
            .sum();
        if j.is_finite() {
            j
        } else {
            f64::INFINITY
        }
    }
}

/// The warning of a fit whose scale `s2` exceeds [`MODEL_ERROR_SCALE`].
fn model_error_warning(s2: f64) -> String {
    format!(
        "the fit's scale s² = {s2:.3e} (the sweeps' least cost per degree of freedom, near 1 \
         when the model explains the estimates within their bands) exceeds \
         {MODEL_ERROR_SCALE}: the model does not explain the records (a Kp, mass or sample \
         rate declared other than the record's, or effects the linear loop leaves out), and \
         the intervals do not hold: widened by s² as if that misfit were noise, they can \
         exclude the truth"
    )
}

/// The records of a frequency-domain (or combined) fit.
#[derive(Debug, Clone)]
pub struct FrequencyProblem {
    /// The sweep records, at least one.
    pub sweeps: Vec<SweepSet>,
    /// Step records fitted with them (the step identification's problem), if any.
    pub steps: Option<Problem>,
    /// The standstill point that gives c1, c2 for each c12.
    pub standstill: Standstill,
}

/// How the two kinds of record are weighted in the sum.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scales {
    /// s² the sweeps' J is divided by: J_min/(2K − 3) of the sweeps alone.
    pub sweep_scale: f64,
    /// σ² (mm²) the step records' SSE is divided by, when there are step records.
    pub step_noise_var_mm2: Option<f64>,
}

/// One sweep's part of the answer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepSummary {
    /// The record.
    pub file: String,
    /// How its spectra were estimated.
    pub method: frf::Method,
    /// Frequencies estimated, and those usable (fitted).
    pub frequencies: usize,
    /// Usable frequencies, fitted.
    pub fitted_frequencies: usize,
    /// The coherence a frequency needed.
    pub usable_coherence: f64,
    /// The lowest frequency fitted (Hz).
    pub lowest_frequency_hz: f64,
    /// Why the fit starts there: the estimate's lowest frequency and its reason
    /// ([`frf::Estimate::lowest_frequency_reason`]), or where the coherence first reaches the
    /// usable level.
    pub lowest_frequency_reason: String,
    /// J of this record at the answer (no unit).
    pub weighted_cost: f64,
}

/// The answer of a frequency-domain (or combined) fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrequencyFit {
    /// Best point of the grid on the sweeps' cost.
    pub grid_best: Candidate,
    /// The answer: the least of the (combined) cost near it.
    pub best: Candidate,
    /// The scaled cost there: J/s² (+ SSE/σ² with step records).
    pub cost: f64,
    /// The sweeps' J there (no unit).
    pub sweep_cost: f64,
    /// The step records' SSE there (mm²), with step records.
    pub step_sse_mm2: Option<f64>,
    /// The weights of the sum.
    pub scales: Scales,
    /// Usable frequencies over every sweep (K).
    pub frequencies: usize,
    /// Candidates of the grid evaluated.
    pub evaluated: usize,
    /// c1, c2 of the answer from the standstill point.
    pub leakage: Leakage,
    /// Each sweep's part.
    pub sweeps: Vec<SweepSummary>,
    /// What the reader should know: the sweeps' estimate warnings, an answer on the grid's
    /// edge.
    pub warnings: Vec<String>,
}

/// The profile-likelihood intervals of a frequency-domain fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrequencyUncertainty {
    /// Confidence level.
    pub confidence: f64,
    /// χ²₁(confidence): the largest rise of the scaled cost inside an interval.
    pub threshold: f64,
    /// One profile per parameter, in the order (β, b, c12).
    pub profiles: Vec<Profile>,
}

impl FrequencyProblem {
    /// The records of a frequency-domain fit from datasets loaded for it
    /// ([`super::DatasetEntry::load`] with the frequency method): the sweeps, with the step
    /// records beside them, their controller sampled as the sweeps'
    /// ([`Problem::with_sampled_controller`]). Refused without a sweep.
    pub fn of_loaded(
        loaded: Vec<Loaded>,
        standstill: Standstill,
    ) -> Result<FrequencyProblem, IdentError> {
        let (mut steps, mut sweeps) = (Vec::new(), Vec::new());
        for l in loaded {
            match l {
                Loaded::Step(p) => steps.push(*p),
                Loaded::Sweep(s) => sweeps.push(*s),
            }
        }
        if sweeps.is_empty() {
            return Err(IdentError::Input(
                "the frequency method needs at least one sweep record (a chirp, multisine or \
                 stepped sine); every dataset's reference is a step or a hold"
                    .into(),
            ));
        }
        let steps = (!steps.is_empty()).then(|| {
            let p = Problem {
                datasets: steps,
                standstill,
            };
            p.with_sampled_controller()
        });
        Ok(FrequencyProblem {
            sweeps,
            steps,
            standstill,
        })
    }

    /// The names of the step records fitted beside the sweeps.
    pub fn step_names(&self) -> Vec<String> {
        (self.steps.iter())
            .flat_map(|p| p.datasets.iter().map(|d| d.name.clone()))
            .collect()
    }

    /// The rig of sweep `set` with a candidate's β, b, c12 and the c1, c2 that hold the
    /// standstill point with that c12.
    pub fn rig_for(&self, c: &Candidate, set: &SweepSet) -> Result<Rig, IdentError> {
        let l = self.standstill.leakage(&set.rig, c.c12_m5_per_ns)?;
        Ok(Rig {
            beta_bar: c.beta_bar,
            viscous_friction_ns_per_m: c.viscous_friction_ns_per_m,
            c12_m5_per_ns: c.c12_m5_per_ns,
            c1_m5_per_ns: l.c1_m5_per_ns,
            c2_m5_per_ns: l.c2_m5_per_ns,
            ..set.rig.clone()
        })
    }

    /// The sweeps' J for a candidate (+∞ when a loop is unstable or a rig cannot be built).
    pub fn sweep_cost(&self, c: &Candidate) -> f64 {
        self.sweeps
            .iter()
            .map(|s| self.rig_for(c, s).map_or(f64::INFINITY, |rig| s.cost(&rig)))
            .sum()
    }

    /// The scaled cost of a candidate: J/s², plus SSE/σ² of the step records.
    pub fn scaled_cost(&self, c: &Candidate, scales: &Scales) -> f64 {
        let j = self.sweep_cost(c) / scales.sweep_scale;
        match (&self.steps, scales.step_noise_var_mm2) {
            (Some(p), Some(var)) if j.is_finite() => j + p.sse_offset_free(c) / var,
            _ => j,
        }
    }

    /// Usable frequencies over every sweep.
    pub fn frequencies(&self) -> usize {
        self.sweeps.iter().map(|s| s.freq_hz.len()).sum()
    }

    /// Fit β, b, c12: `grid` on the sweeps' cost, then the (combined) cost polished from its
    /// best point.
    pub fn fit(&self, grid: &Grid) -> Result<FrequencyFit, IdentError> {
        let k = self.frequencies();
        if 2 * k <= FITTED {
            return Err(IdentError::Input(format!(
                "{k} usable frequencies over the sweeps: too few to fit beta, b and c12 \
                 (a sweep over more lines, or a longer record)"
            )));
        }
        let costs: Vec<f64> = (0..grid.len())
            .into_par_iter()
            .map(|i| self.sweep_cost(&grid.candidate(i)))
            .collect();
        let (index, grid_cost) = costs
            .iter()
            .copied()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|(_, c)| c.is_finite())
            .ok_or_else(|| {
                IdentError::Input(
                    "no candidate of the grid has a stable loop with a finite cost: check \
                     the records, gains and grid"
                        .into(),
                )
            })?;
        let grid_best = grid.candidate(index);
        let sweeps_only = |p: &[f64]| bounded(p, |c| self.sweep_cost(c));
        let (p, j_min) = polish_with(&sweeps_only, &grid_best);
        let j_min = j_min.min(grid_cost);
        let mut scales = Scales {
            sweep_scale: (j_min / (2 * k - FITTED) as f64).max(f64::MIN_POSITIVE),
            step_noise_var_mm2: None,
        };
        let mut best = candidate_of(&p);
        if let Some(steps) = &self.steps {
            let (_, var) = step_noise(steps, &best)?;
            scales.step_noise_var_mm2 = Some(var);
            let both = |q: &[f64]| bounded(q, |c| self.scaled_cost(c, &scales));
            best = candidate_of(&polish_with(&both, &best).0);
        }
        self.answer(grid, grid_best, best, scales)
    }

    /// The fit's description at `best`.
    fn answer(
        &self,
        grid: &Grid,
        grid_best: Candidate,
        best: Candidate,
        scales: Scales,
    ) -> Result<FrequencyFit, IdentError> {
        let mut warnings: Vec<String> = self
            .sweeps
            .iter()
            .flat_map(|s| {
                s.estimate
                    .warnings
                    .iter()
                    .map(|w| format!("{}: {w}", s.name))
            })
            .collect();
        if scales.sweep_scale > MODEL_ERROR_SCALE {
            warnings.push(model_error_warning(scales.sweep_scale));
        }
        let values = super::grid::candidate_values(&grid_best);
        for (i, range) in grid.edges_at(&grid_best).into_iter().enumerate() {
            if let Some((lo, hi)) = range {
                warnings.push(format!(
                    "the best grid point has {} = {} on the edge of the grid ({} … {}): the \
                     optimum may lie outside it; widen that axis ([ranges] or [grid])",
                    super::uncertainty::PARAMETERS[i],
                    super::grid::short(values[i]),
                    super::grid::short(lo),
                    super::grid::short(hi)
                ));
            }
        }
        let sweeps = self
            .sweeps
            .iter()
            .map(|s| {
                let cost = self.rig_for(&best, s).map_or(f64::INFINITY, |r| s.cost(&r));
                SweepSummary {
                    file: s.name.clone(),
                    method: s.estimate.method,
                    frequencies: s.estimate.closed_loop.points.len(),
                    fitted_frequencies: s.freq_hz.len(),
                    usable_coherence: s.estimate.usable_coherence,
                    lowest_frequency_hz: s.lowest_fitted_hz(),
                    lowest_frequency_reason: s.lowest_fitted_reason(),
                    weighted_cost: cost,
                }
            })
            .collect();
        Ok(FrequencyFit {
            grid_best,
            cost: self.scaled_cost(&best, &scales),
            sweep_cost: self.sweep_cost(&best),
            step_sse_mm2: self.steps.as_ref().map(|p| p.sse_offset_free(&best)),
            scales,
            frequencies: self.frequencies(),
            evaluated: grid.len(),
            leakage: self
                .standstill
                .leakage(&self.sweeps[0].rig, best.c12_m5_per_ns)?,
            sweeps,
            warnings,
            best,
        })
    }

    /// Profile-likelihood intervals of β, b and c12 at the fit's answer: the scaled cost's
    /// rise over its least value, the other two re-optimised, against χ²₁(`confidence`).
    pub fn uncertainty(
        &self,
        fit: &FrequencyFit,
        confidence: f64,
    ) -> Result<FrequencyUncertainty, IdentError> {
        check_confidence(confidence)?;
        let f = |p: &[f64]| bounded(p, |c| self.scaled_cost(c, &fit.scales));
        let (best, cost) = polish_with(&f, &fit.best);
        let threshold = chi2_1_quantile(confidence);
        let scan = Scan {
            f: &f,
            best: &best,
            sse: cost,
            var: [1.0; 3],
            threshold,
        };
        Ok(FrequencyUncertainty {
            confidence,
            threshold,
            profiles: scan.profiles([true; 3]),
        })
    }
}
