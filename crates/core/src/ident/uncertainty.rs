//! How sure is the identification? Noise level from the residuals at the optimum and a
//! confidence interval for each of β, b and c12 by profiling the likelihood
//! (docs/identification.md, "Uncertainty").
//!
//! With independent Gaussian position noise of one level σ on every sample, minus twice the
//! log-likelihood is SSE/σ² up to a constant, SSE being the sum of squared position errors
//! (mm²) over every dataset's fit window (not the cost, which is a mean of per-dataset means).
//! Each record's initial position is fitted with the parameters (a constant per dataset, in
//! closed form): the identification takes it from the mean of the samples at rest, whose noise
//! would otherwise shift every later sample alike and make the intervals too narrow.
//! σ² is estimated as SSE_min/(N − p), N the samples inside the fit windows, p = 3 plus one
//! offset per dataset. The profile of a
//! parameter θ is, for each value of θ, the least SSE over the other two; the likelihood-ratio
//! interval at confidence P is where ΔSSE(θ)/σ² ≤ χ²₁(P) (3.841 for 95 %). Where the profile
//! stays below that level up to a search bound, the data do not bound the parameter: it is
//! reported as not identifiable.
//!
//! Residuals that are not white (model error rather than sensor noise, as on records of a
//! nonlinear rig) carry less information than their number of samples suggests: σ² in the
//! statistic is multiplied by the integrated autocorrelation time of the residuals, the ratio
//! of N to the effective number of independent samples (1 within sampling error for white
//! residuals, (1 + ρ)/(1 − ρ) for AR(1) ones). Model error also biases the estimate, alike on
//! every record of the rig, by more than that variance allows; the records' disagreement
//! measures it: each parameter's variance is further inflated by the sample variance over the
//! datasets of each one's own estimate ([`model_error_inflation`], docs/identification.md,
//! "Uncertainty").

use super::grid::Candidate;
use super::problem::Problem;
use super::refine::{candidate_of, log_point, minimize};
use super::IdentError;
use rayon::prelude::*;
use serde::Serialize;

/// Names of the parameters, in the order (β, b, c12) of the point.
pub const PARAMETERS: [&str; 3] = ["beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"];
/// Units of the parameters, in the order of [`PARAMETERS`].
pub const UNITS: [&str; 3] = ["bar", "N·s/m", "m⁵/(N·s)"];
/// Search bounds of β (bar), b (N·s/m) and c12 (m⁵/(N·s)): a profile that reaches one without
/// crossing the threshold means the data do not bound that side.
pub const BOUNDS: [[f64; 2]; 3] = [[1.0, 1.0e5], [1.0, 1.0e5], [1.0e-15, 1.0e-8]];
/// How near a search bound (in ln, 0.1 %) an estimate sits at it: the searches are +∞ outside
/// [`BOUNDS`], so one the records do not stop presses on the bound (b within 1e-8 of 1 N·s/m
/// on a sweep of a rig without viscous friction).
pub const AT_BOUND: f64 = 1e-3;
/// Unknowns fitted besides the datasets' offsets (β, b, c12).
const FITTED: usize = 3;

/// The search bound (of [`BOUNDS`]) that parameter `i`'s estimate `value` sits at, within
/// [`AT_BOUND`], if any: such a value is the search's limit, not an estimate.
pub fn search_bound_at(i: usize, value: f64) -> Option<f64> {
    BOUNDS[i]
        .into_iter()
        .find(|b| (value / b).ln().abs() <= AT_BOUND)
}

/// Why parameter `i` whose estimate sits at the search bound `bound` is not identifiable.
pub fn at_bound_reason(i: usize, bound: f64) -> String {
    format!(
        "its estimate sits at the search bound {} {}: the records do not bound it, and that \
         value is the search's limit, not an estimate",
        super::grid::short(bound),
        UNITS[i]
    )
}
/// First profile offset from the optimum, in ln(parameter) (0.2 %).
const FIRST_STEP: f64 = 0.002;
/// Each further offset is this much larger than the previous one.
const GROWTH: f64 = 1.5;
/// Profile points per side at most, before the crossing is refined.
const MAX_STEPS: usize = 40;
/// Secant steps refining where a profile crosses the threshold.
const CROSSING_ITERS: usize = 3;
/// Initial simplex of the inner (warm-started) searches, in ln(parameter).
const INNER_STEP: f64 = 0.05;
/// Iteration limit of every simplex search.
const MAX_ITERS: u64 = 400;
/// Largest variance inflation applied for correlated residuals.
const MAX_INFLATION: f64 = 1.0e4;

/// Options of the analysis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UncertaintyOptions {
    /// Confidence level of the intervals, in (0, 1).
    pub confidence: f64,
    /// Which of (β, b, c12) to profile; the others get no interval (the full range).
    pub profile: [bool; 3],
}

impl Default for UncertaintyOptions {
    fn default() -> Self {
        UncertaintyOptions {
            confidence: 0.95,
            profile: [true; 3],
        }
    }
}

/// One point of a profile.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProfilePoint {
    /// The profiled parameter's value (its unit: bar, N·s/m or m⁵/(N·s)).
    pub value: f64,
    /// Least SSE (mm²) over the other two parameters; for a frequency-domain fit its least
    /// weighted cost (no unit, docs/identification.md#grey-box-fit-to-a-frequency-response).
    pub sse_mm2: f64,
    /// ΔSSE/σ², to compare with χ²₁(confidence).
    pub statistic: f64,
    /// Where the least SSE is.
    pub candidate: Candidate,
}

/// The profile of one parameter and the interval read off it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Profile {
    /// The parameter's name (one of [`PARAMETERS`]).
    pub parameter: &'static str,
    /// The points, by increasing value (the optimum among them).
    pub points: Vec<ProfilePoint>,
    /// The confidence interval [lo, hi]; an end the profile did not cross is the search bound.
    pub interval: [f64; 2],
    /// Whether the profile crossed the threshold below and above the optimum.
    pub crossed: [bool; 2],
    /// Whether the data bound the parameter: the profile crossed on both sides.
    pub identifiable: bool,
}

/// The result of the analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Uncertainty {
    /// The least-SSE point (the identification's answer, polished on the SSE).
    pub best: Candidate,
    /// SSE (mm²) there.
    pub sse_mm2: f64,
    /// Samples inside the fit windows, over all datasets.
    pub samples: usize,
    /// Estimated noise level σ (mm).
    pub noise_std_mm: f64,
    /// Confidence level.
    pub confidence: f64,
    /// χ²₁(confidence): the largest ΔSSE/σ² inside an interval.
    pub threshold: f64,
    /// Lag-1 autocorrelation of the residuals at the optimum, pooled over the datasets: near
    /// 0 (within about 2/√N) for white noise; well above, the residuals are mostly model error
    /// and the intervals, which assume white noise, are too narrow.
    pub residual_autocorrelation: f64,
    /// Factor on σ² in the statistic for correlated residuals: (1 + ρ)/(1 − ρ) with ρ the
    /// lag-1 autocorrelation when it is positive, else 1.
    pub variance_inflation: f64,
    /// Factor on σ² in each profile's statistic, (β, b, c12): `variance_inflation` times one
    /// plus the model-error variance the datasets' disagreement shows, over the parameter's
    /// variance from correlated noise alone (docs/identification.md, "Uncertainty").
    pub inflation_by_parameter: [f64; 3],
    /// One profile per profiled parameter, in the order (β, b, c12).
    pub profiles: Vec<Profile>,
}

impl Uncertainty {
    /// The profile of parameter `name` (one of [`PARAMETERS`]), if it was profiled.
    pub fn profile(&self, name: &str) -> Option<&Profile> {
        self.profiles.iter().find(|p| p.parameter == name)
    }
}

/// Quantile of the χ² distribution with one degree of freedom: the square of the standard
/// normal quantile at (1 + p)/2. `p` must lie in (0, 1).
pub fn chi2_1_quantile(p: f64) -> f64 {
    normal_quantile(0.5 + 0.5 * p).powi(2)
}

/// Standard normal quantile (Acklam's rational approximation, relative error below 1.2·10⁻⁹).
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    const LOW: f64 = 0.02425;
    if p < LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// `f` at a point in (ln β, ln b, ln c12); +∞ outside [`BOUNDS`].
pub(super) fn bounded(p: &[f64], f: impl Fn(&Candidate) -> f64) -> f64 {
    let inside = p
        .iter()
        .zip(BOUNDS)
        .all(|(v, [lo, hi])| (lo.ln()..=hi.ln()).contains(v));
    if inside {
        f(&candidate_of(p))
    } else {
        f64::INFINITY
    }
}

/// The SSE of a point in (ln β, ln b, ln c12); +∞ outside [`BOUNDS`].
fn sse_at(problem: &Problem, p: &[f64]) -> f64 {
    bounded(p, |c| problem.sse_offset_free(c))
}

/// A cost over (ln β, ln b, ln c12) whose profiles are read: the step records' SSE here, the
/// frequency-domain fit's weighted cost in [`super::frequency`].
pub(super) type Objective<'a> = &'a (dyn Fn(&[f64]) -> f64 + Sync);

/// Refuse a confidence level outside (0, 1); the message names the parameter `confidence`.
pub fn check_confidence(confidence: f64) -> Result<f64, IdentError> {
    if confidence > 0.0 && confidence < 1.0 {
        return Ok(confidence);
    }
    Err(IdentError::Input(format!(
        "confidence {confidence}: must lie strictly between 0 and 1"
    )))
}

/// The likelihood at the optimum: the polished point, its SSE, σ², the χ²₁ threshold and the
/// residuals' lag-1 autocorrelation with its variance inflation.
struct Optimum {
    best: Vec<f64>,
    sse: f64,
    var: f64,
    threshold: f64,
    rho: f64,
    inflation: f64,
    /// Per parameter (β, b, c12): `inflation` with the model-error variance added.
    inflations: [f64; 3],
}

impl Optimum {
    /// Polish `start` on the SSE and estimate the noise there.
    fn find(problem: &Problem, start: &Candidate, confidence: f64) -> Result<Optimum, IdentError> {
        check_confidence(confidence)?;
        let samples = problem.samples();
        let fitted = FITTED + problem.datasets.len();
        if samples <= fitted {
            return Err(IdentError::Input(format!(
                "{samples} samples inside the fit windows: too few to estimate the noise"
            )));
        }
        let (best, sse) = polish(problem, start);
        if !(sse.is_finite() && sse > 0.0) {
            return Err(IdentError::Input(format!(
                "the SSE at the optimum is {sse} mm²: no noise level can be estimated"
            )));
        }
        let rho = autocorrelations(problem, &candidate_of(&best));
        let var = sse / (samples - fitted) as f64;
        let inflation = variance_inflation(&rho);
        let rho1 = rho.get(1).copied().unwrap_or(f64::NAN);
        let model = model_error_inflation(problem, &best, var * inflation).unwrap_or([1.0; 3]);
        Ok(Optimum {
            var,
            threshold: chi2_1_quantile(confidence),
            inflation,
            inflations: model.map(|c| {
                // the records' spread holds their noise too, which white residuals (τ = 1)
                // show is all of it: only the residuals' correlated share 1 − 1/τ counts
                let share = 1.0 - 1.0 / inflation;
                ((1.0 + share * (c - 1.0)) * inflation).min(MAX_INFLATION)
            }),
            rho: rho1,
            best,
            sse,
        })
    }

    /// The profile scan of `f` (the SSE) at this optimum.
    fn scan<'a>(&'a self, f: Objective<'a>) -> Scan<'a> {
        Scan {
            f,
            best: &self.best,
            sse: self.sse,
            var: self.inflations.map(|c| self.var * c),
            threshold: self.threshold,
        }
    }
}

/// The step records' least SSE near `start` (mm²) and the noise variance (mm²) a combined
/// fit divides it by: σ² = SSE/(N − p) times the residuals' integrated autocorrelation time
/// (docs/identification.md, "Sweeps and steps together").
pub(super) fn step_noise(problem: &Problem, start: &Candidate) -> Result<(f64, f64), IdentError> {
    let o = Optimum::find(problem, start, 0.95)?;
    Ok((o.sse, o.var * o.inflation))
}

/// Analyse the uncertainty of the identification whose answer is `start`.
pub fn analyze(
    problem: &Problem,
    start: &Candidate,
    opts: &UncertaintyOptions,
) -> Result<Uncertainty, IdentError> {
    let o = Optimum::find(problem, start, opts.confidence)?;
    let f = |p: &[f64]| sse_at(problem, p);
    let profiles = o.scan(&f).profiles(opts.profile);
    Ok(Uncertainty {
        best: candidate_of(&o.best),
        sse_mm2: o.sse,
        samples: problem.samples(),
        noise_std_mm: o.var.sqrt(),
        confidence: opts.confidence,
        threshold: o.threshold,
        residual_autocorrelation: o.rho,
        variance_inflation: o.inflation,
        inflation_by_parameter: o.inflations,
        profiles,
    })
}

/// How far from the estimate (a factor) the quick identifiability check looks: a decade.
pub const FLAT_FACTOR: f64 = 10.0;

/// Whether the records bound one parameter, and why not when they do not.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Identifiability {
    /// The parameter (one of [`PARAMETERS`]).
    pub parameter: &'static str,
    /// Whether the records bound it.
    pub identifiable: bool,
    /// Why not, in words; `None` when identifiable.
    pub reason: Option<String>,
}

impl Identifiability {
    /// The verdict of a full profile ([`analyze`]): identifiable when it crossed the threshold
    /// on both sides.
    pub fn of_profile(p: &Profile, confidence: f64) -> Identifiability {
        let i = PARAMETERS
            .iter()
            .position(|n| *n == p.parameter)
            .unwrap_or(0);
        let open: Vec<String> = [0, 1]
            .into_iter()
            .filter(|&s| !p.crossed[s])
            .map(|s| super::grid::short(BOUNDS[i][s]))
            .collect();
        Identifiability {
            parameter: p.parameter,
            identifiable: p.identifiable,
            reason: (!p.identifiable).then(|| {
                format!(
                    "its {:.0} % profile likelihood stays under the threshold out to the search \
                     bound {}",
                    confidence * 100.0,
                    open.join(" and ")
                )
            }),
        }
    }

    /// This verdict for the estimate `value`: not identifiable where it sits at a search bound
    /// ([`search_bound_at`]), whatever the profile said.
    pub fn checked_at(self, value: f64) -> Identifiability {
        let i = PARAMETERS.iter().position(|n| *n == self.parameter);
        match i.and_then(|i| Some((i, search_bound_at(i, value)?))) {
            Some((i, bound)) => Identifiability {
                identifiable: false,
                reason: Some(at_bound_reason(i, bound)),
                ..self
            },
            None => self,
        }
    }
}

/// Which of (β, b, c12) the records bound, decided cheaply (docs/identification.md, "Identifiability"):
/// at the SSE optimum near `start`, each parameter is fixed a decade ([`FLAT_FACTOR`]) below
/// and above its estimate (within [`BOUNDS`]) and the SSE minimised over the other two. A
/// parameter whose profile statistic ΔSSE/σ² stays at or under χ²₁(`confidence`) at either
/// point is not identifiable: its interval would span more than a decade on that side.
pub fn identifiability(
    problem: &Problem,
    start: &Candidate,
    confidence: f64,
) -> Result<[Identifiability; 3], IdentError> {
    let o = Optimum::find(problem, start, confidence)?;
    let f = |p: &[f64]| sse_at(problem, p);
    let scan = o.scan(&f);
    let tasks: Vec<(usize, usize)> = (0..3).flat_map(|i| [(i, 0), (i, 1)]).collect();
    let points: Vec<ProfilePoint> = tasks
        .par_iter()
        .map(|&(i, side)| {
            let step = FLAT_FACTOR.ln() * if side == 0 { -1.0 } else { 1.0 };
            let v = (o.best[i] + step).clamp(BOUNDS[i][0].ln(), BOUNDS[i][1].ln());
            scan.fixed(i, v, &o.best).1
        })
        .collect();
    Ok(std::array::from_fn(|i| {
        let pair = [&points[2 * i], &points[2 * i + 1]];
        let flat: Vec<&&ProfilePoint> =
            pair.iter().filter(|p| p.statistic <= o.threshold).collect();
        let reason = (!flat.is_empty()).then(|| {
            let at: Vec<String> = flat
                .iter()
                .map(|p| {
                    let v = super::grid::short(p.value);
                    format!("{:.2} at {v} {}", p.statistic, UNITS[i])
                })
                .collect();
            format!(
                "the fit stays within the noise a decade from the estimate {} {}: \
                 Delta SSE / sigma^2 = {}, under the {:.0} % threshold {:.2}",
                super::grid::short(o.best[i].exp()),
                UNITS[i],
                at.join(" and "),
                confidence * 100.0,
                o.threshold
            )
        });
        Identifiability {
            parameter: PARAMETERS[i],
            identifiable: reason.is_none(),
            reason,
        }
    }))
}

/// The variance inflation for residuals with autocorrelations `rho` (`rho[k]` at lag k,
/// `rho[0]` = 1): the integrated autocorrelation time τ = 1 + 2 Σ ρ_k, the ratio of the
/// samples to the effective number of independent ones (Bayley & Hammersley 1946), the sum
/// truncated by Geyer's initial positive sequence (1992): over the pairs ρ_{2m} + ρ_{2m+1}
/// while they stay positive. For AR(1) residuals it tends to (1 + ρ₁)/(1 − ρ₁). At least 1
/// (white residuals keep the plain likelihood), at most [`MAX_INFLATION`]; 1 when not finite.
pub fn variance_inflation(rho: &[f64]) -> f64 {
    let mut tau = -1.0;
    for pair in rho.chunks(2) {
        let g: f64 = pair.iter().sum();
        if g.is_nan() || g <= 0.0 {
            break;
        }
        tau += 2.0 * g;
    }
    if tau.is_finite() {
        tau.clamp(1.0, MAX_INFLATION)
    } else {
        1.0
    }
}

/// Autocorrelations of the offset-free residuals of a candidate at lags 0, 1, …, pooled over
/// the datasets ([`pooled_autocorrelations`]); empty when the residuals are not finite.
fn autocorrelations(problem: &Problem, c: &Candidate) -> Vec<f64> {
    let residuals: Option<Vec<Vec<f64>>> = (problem.datasets.iter())
        .map(|ds| problem.residuals_offset_free(c, ds))
        .collect();
    residuals.map_or_else(Vec::new, |r| pooled_autocorrelations(&r))
}

/// Autocorrelations of residuals at lags 0, 1, …, pooled over the datasets (each lag's
/// products summed within each dataset, over the pooled power), up to the shortest dataset's
/// length less one.
pub(super) fn pooled_autocorrelations(residuals: &[Vec<f64>]) -> Vec<f64> {
    let lags = residuals.iter().map(Vec::len).min().unwrap_or(0);
    let lagged = |k: usize| -> f64 {
        residuals
            .iter()
            .map(|r| r.iter().zip(&r[k..]).map(|(a, b)| a * b).sum::<f64>())
            .sum()
    };
    let power = lagged(0);
    (0..lags).map(|k| lagged(k) / power).collect()
}

/// Relative step (in ln parameter) of the residuals' finite-difference sensitivities.
const SENSITIVITY_STEP: f64 = 1e-4;

/// The inflation of each parameter's (β, b, c12) variance for the model error the datasets
/// disagree by: 1 + s²ⱼ / (σ²·τ·[(JᵀJ)⁻¹]ⱼⱼ), where s²ⱼ is the sample variance over the
/// datasets of each one's own least-SSE estimate (ln parameter), σ²·τ the inflated noise
/// variance (`var`) and [(JᵀJ)⁻¹]ⱼⱼ the parameter's least-squares variance per unit noise
/// variance, J the offset-free residuals' sensitivities at `best` (docs/identification.md,
/// "Uncertainty"). `None` with one dataset, or when J is not finite or JᵀJ singular.
fn model_error_inflation(problem: &Problem, best: &[f64], var: f64) -> Option<[f64; 3]> {
    let k = problem.datasets.len();
    if k < 2 {
        return None;
    }
    let lsq = least_squares_variance(problem, best)?;
    let own: Vec<Vec<f64>> = (0..k)
        .into_par_iter()
        .map(|d| {
            let one = Problem {
                datasets: vec![problem.datasets[d].clone()],
                standstill: problem.standstill,
            };
            polish(&one, &candidate_of(best)).0
        })
        .collect();
    Some(std::array::from_fn(|j| {
        let mean = own.iter().map(|p| p[j]).sum::<f64>() / k as f64;
        let spread = own.iter().map(|p| (p[j] - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
        1.0 + spread / (var * lsq[j])
    }))
}

/// [(JᵀJ)⁻¹]ⱼⱼ for (ln β, ln b, ln c12), J the sensitivities of the offset-free residuals
/// (mm) of every dataset at `best` by central differences; `None` when they are not finite
/// or JᵀJ is singular.
fn least_squares_variance(problem: &Problem, best: &[f64]) -> Option<[f64; 3]> {
    use nalgebra::{Matrix3, Vector3};
    let residuals = |j: usize, h: f64| -> Option<Vec<Vec<f64>>> {
        let mut p = best.to_vec();
        p[j] += h;
        let c = candidate_of(&p);
        let ds = &problem.datasets;
        ds.iter()
            .map(|d| problem.residuals_offset_free(&c, d))
            .collect()
    };
    let mut sens = Vec::new();
    for j in 0..3 {
        sens.push((
            residuals(j, SENSITIVITY_STEP)?,
            residuals(j, -SENSITIVITY_STEP)?,
        ));
    }
    let mut h = Matrix3::<f64>::zeros();
    for d in 0..problem.datasets.len() {
        for i in 0..sens[0].0[d].len() {
            let v = Vector3::from_fn(|j, _| {
                (sens[j].0[d][i] - sens[j].1[d][i]) / (2.0 * SENSITIVITY_STEP)
            });
            h += v * v.transpose();
        }
    }
    let hi = h.try_inverse()?;
    let v: [f64; 3] = std::array::from_fn(|j| hi[(j, j)]);
    v.iter().all(|x| x.is_finite() && *x > 0.0).then_some(v)
}

/// The least-SSE point near `start` (two simplex searches, the second restarted smaller), in
/// (ln β, ln b, ln c12), and its SSE; `start` (moved into [`BOUNDS`]) when the search finds
/// nothing better.
fn polish(problem: &Problem, start: &Candidate) -> (Vec<f64>, f64) {
    polish_with(&|p: &[f64]| sse_at(problem, p), start)
}

/// The least-`f` point near `start`, as [`polish`] finds the least SSE.
pub(super) fn polish_with(f: Objective, start: &Candidate) -> (Vec<f64>, f64) {
    let mut best: Vec<f64> = log_point(start)
        .iter()
        .zip(BOUNDS)
        .map(|(v, [lo, hi])| v.clamp(lo.ln(), hi.ln()))
        .collect();
    let mut cost = f(&best);
    for step in [0.1, 0.02] {
        let tol = 1e-9 * cost.max(1e-300);
        if let Some((p, c)) = minimize(f, &best, step, tol, MAX_ITERS) {
            if c < cost {
                (best, cost) = (p, c);
            }
        }
    }
    (best, cost)
}

/// One side of one profile: its points (from the optimum outwards) and where it crossed the
/// threshold, if it did.
struct Side {
    points: Vec<ProfilePoint>,
    crossing: Option<f64>,
}

/// What every profile point needs.
pub(super) struct Scan<'a> {
    /// The cost profiled (+∞ outside [`BOUNDS`]).
    pub f: Objective<'a>,
    /// Optimum in (ln β, ln b, ln c12).
    pub best: &'a [f64],
    /// Cost there (the SSE, mm², of the step records).
    pub sse: f64,
    /// What each parameter's (β, b, c12) cost difference is divided by: the noise variance σ²
    /// (mm²) times the parameter's inflation for the step records.
    pub var: [f64; 3],
    /// χ²₁(confidence).
    pub threshold: f64,
}

impl Scan<'_> {
    /// The profiles of the parameters `profile` marks, both sides of each walked in parallel.
    pub fn profiles(&self, profile: [bool; 3]) -> Vec<Profile> {
        let tasks: Vec<(usize, f64)> = (0..3)
            .filter(|&i| profile[i])
            .flat_map(|i| [(i, -1.0), (i, 1.0)])
            .collect();
        let sides: Vec<Side> = tasks
            .par_iter()
            .map(|&(i, dir)| self.side(i, dir))
            .collect();
        sides
            .chunks(2)
            .zip(tasks.chunks(2))
            .map(|(s, t)| {
                let i = t[0].0;
                profile_of(i, self.point(i, self.best, self.sse), &s[0], &s[1])
            })
            .collect()
    }

    /// The profile point of parameter `i` at a full point `p` in log space with SSE `sse`.
    fn point(&self, i: usize, p: &[f64], sse: f64) -> ProfilePoint {
        let candidate = candidate_of(p);
        ProfilePoint {
            value: candidate_value(&candidate, i),
            sse_mm2: sse,
            statistic: (sse - self.sse) / self.var[i],
            candidate,
        }
    }

    /// The least SSE with parameter `i` fixed at `v` (ln), over the other two, warm-started
    /// from `warm` (a full point); returns the full point and the profile point.
    fn fixed(&self, i: usize, v: f64, warm: &[f64]) -> (Vec<f64>, ProfilePoint) {
        let others: Vec<usize> = (0..3).filter(|&j| j != i).collect();
        let full = |q: &[f64]| {
            let mut p = warm.to_vec();
            p[i] = v;
            for (k, &j) in others.iter().enumerate() {
                p[j] = q[k];
            }
            p
        };
        let f = |q: &[f64]| (self.f)(&full(q));
        let q0: Vec<f64> = others.iter().map(|&j| warm[j]).collect();
        let tol = 1e-4 * self.var[i];
        let (q, sse) = minimize(&f, &q0, INNER_STEP, tol, MAX_ITERS)
            .filter(|(_, c)| c.is_finite())
            .unwrap_or_else(|| (q0.clone(), f(&q0)));
        let p = full(&q);
        let point = self.point(i, &p, sse);
        (p, point)
    }

    /// Walk from the optimum in direction `dir` (±1) along parameter `i` with widening steps
    /// until the statistic exceeds the threshold or the search bound is reached; refine the
    /// crossing by secant steps on the signed root of the statistic.
    fn side(&self, i: usize, dir: f64) -> Side {
        let bound = if dir < 0.0 {
            BOUNDS[i][0].ln()
        } else {
            BOUNDS[i][1].ln()
        };
        let mut points = Vec::new();
        let (mut inner, mut inner_stat) = (self.best.to_vec(), 0.0);
        let mut offset = FIRST_STEP;
        for _ in 0..MAX_STEPS {
            let raw = self.best[i] + dir * offset;
            let at_bound = (raw - bound) * dir >= 0.0;
            let v = if at_bound { bound } else { raw };
            let (p, point) = self.fixed(i, v, &inner);
            points.push(point);
            if point.statistic > self.threshold {
                let (c, extra) = self.crossing(i, (inner, inner_stat), (p, point.statistic));
                points.extend(extra);
                return Side {
                    points,
                    crossing: Some(c),
                };
            }
            if at_bound {
                break;
            }
            (inner, inner_stat) = (p, point.statistic);
            offset *= GROWTH;
        }
        Side {
            points,
            crossing: None,
        }
    }

    /// Where the profile of parameter `i` crosses the threshold between a point below it
    /// and one above (full points in log space with their statistics): secant steps on
    /// √statistic, which is close to linear in the parameter near the optimum. Returns the
    /// crossing (ln) and the profile points computed on the way.
    fn crossing(
        &self,
        i: usize,
        below: (Vec<f64>, f64),
        above: (Vec<f64>, f64),
    ) -> (f64, Vec<ProfilePoint>) {
        let root = |s: f64| s.max(0.0).sqrt();
        let target = self.threshold.sqrt();
        let (mut lo, mut hi) = (below, above);
        let interpolate = |lo: &(Vec<f64>, f64), hi: &(Vec<f64>, f64)| {
            let (ra, rb) = (root(lo.1), root(hi.1));
            let w = ((target - ra) / (rb - ra)).clamp(0.0, 1.0);
            lo.0[i] + w * (hi.0[i] - lo.0[i])
        };
        let mut extra = Vec::new();
        for _ in 0..CROSSING_ITERS {
            let v = interpolate(&lo, &hi);
            let (p, point) = self.fixed(i, v, &lo.0);
            extra.push(point);
            if point.statistic > self.threshold {
                hi = (p, point.statistic);
            } else {
                lo = (p, point.statistic);
            }
        }
        (interpolate(&lo, &hi), extra)
    }
}

/// Parameter `i` of a candidate.
fn candidate_value(c: &Candidate, i: usize) -> f64 {
    [c.beta_bar, c.viscous_friction_ns_per_m, c.c12_m5_per_ns][i]
}

/// Assemble the profile of parameter `i` from the optimum and its two sides.
fn profile_of(i: usize, optimum: ProfilePoint, below: &Side, above: &Side) -> Profile {
    let mut points: Vec<ProfilePoint> = below
        .points
        .iter()
        .chain(&above.points)
        .copied()
        .chain([optimum])
        .collect();
    points.sort_by(|a, b| a.value.total_cmp(&b.value));
    let end = |side: &Side, bound: f64| side.crossing.map_or(bound, f64::exp);
    let crossed = [below.crossing.is_some(), above.crossing.is_some()];
    Profile {
        parameter: PARAMETERS[i],
        points,
        interval: [end(below, BOUNDS[i][0]), end(above, BOUNDS[i][1])],
        crossed,
        identifiable: crossed[0] && crossed[1],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inflation_is_the_integrated_autocorrelation_time() {
        // AR(1): 1 + 2 Σ ρ^k = (1 + ρ)/(1 − ρ), the sum cut where the pairs turn negative
        let rho: Vec<f64> = (0..2000).map(|k| 0.9_f64.powi(k)).collect();
        assert!((variance_inflation(&rho) - 19.0).abs() < 1e-6);
        // alternating AR(1) (ρ = −0.5): 1 + 2ρ/(1 − ρ) < 1 → the white-noise 1
        let alt: Vec<f64> = (0..50).map(|k| (-0.5_f64).powi(k)).collect();
        assert_eq!(variance_inflation(&alt), 1.0);
        // a positive bump then negative lags: only the initial positive pairs count
        let cut = [1.0, 0.5, 0.3, 0.1, -0.2, -0.3, 0.9, 0.9];
        assert!((variance_inflation(&cut) - (-1.0 + 2.0 * (1.5 + 0.4))).abs() < 1e-12);
        assert_eq!(variance_inflation(&[]), 1.0);
        assert_eq!(variance_inflation(&[f64::NAN, 1.0]), 1.0);
    }

    #[test]
    fn an_estimate_at_a_search_bound_is_not_identifiable_whatever_its_profile() {
        // within 0.1 % (in ln) of a bound of BOUNDS: [1, 1e5] N·s/m for b
        assert_eq!(search_bound_at(1, 1.000_000_007), Some(1.0));
        assert_eq!(search_bound_at(1, 0.9995), Some(1.0));
        assert_eq!(search_bound_at(1, 1.002), None);
        assert_eq!(search_bound_at(0, 99_950.0), Some(1.0e5));
        assert_eq!(search_bound_at(2, 1.2e-10), None);
        let bounded = Identifiability {
            parameter: PARAMETERS[1],
            identifiable: true,
            reason: None,
        };
        let d = bounded.clone().checked_at(1.0);
        assert!(!d.identifiable);
        assert!(d.reason.unwrap().contains("search bound 1 N·s/m"));
        assert_eq!(bounded.clone().checked_at(2500.0), bounded);
    }

    #[test]
    fn chi2_quantiles_match_tables() {
        // χ²₁ table values (Abramowitz & Stegun, Table 26.8)
        for (p, q) in [
            (0.95, 3.841_458_820_694_124),
            (0.99, 6.634_896_601_021_213),
            (0.90, 2.705_543_454_095_404),
            (0.5, 0.454_936_423_119_572_7),
            (0.999, 10.827_566_170_662_733),
        ] {
            let got = chi2_1_quantile(p);
            assert!((got / q - 1.0).abs() < 1e-8, "p = {p}: {got} vs {q}");
        }
        // one standard deviation: P(|Z| ≤ 1) = erf(1/√2)
        assert!((chi2_1_quantile(0.682_689_492_137_085_9) - 1.0).abs() < 1e-8);
    }
}
