//! Nonlinear refinement (docs/identification.md#nonlinear-refinement): the emulator's equations
//! (docs/emulator.md) run against the records themselves, so the gas fraction X of the rig's
//! β(p) model is fitted directly, with the piston's Coulomb friction and the pumps' dead band
//! that the linear model folds into its viscous friction b. Records at several pressure levels
//! then constrain one X, each chamber's β following its own pressure along the record, instead
//! of one β per level read off a linear model.
//!
//! The fit is a damped Gauss–Newton (Levenberg–Marquardt) search over the logarithms of
//! (X, b, F_c, dead band) with finite-difference sensitivities, each residual the offset-free
//! position error of one sample (the linear fit's, docs/identification.md#the-cost); X's
//! interval is read off its profile likelihood, the other three re-fitted at each point, the
//! noise variance inflated for correlated residuals as in the linear analysis
//! (docs/identification.md, "Uncertainty").

use super::grid::Candidate;
use super::problem::{Prepared, Problem};
use super::refine::minimize;
use super::uncertainty::{chi2_1_quantile, pooled_autocorrelations, variance_inflation};
use super::IdentError;
use crate::bulk::models::BulkModel;
use crate::emulator::{emulate_reporting, Dynamics, Effects, Plc};
use crate::limits::Work;
use crate::rig::Rig;
use nalgebra::DVector;
use rayon::prelude::*;
use serde::Serialize;

/// The fitted parameters, in the order of [`PARAMETERS`].
pub const PARAMETERS: [&str; 5] = [
    "gas_fraction",
    "viscous_friction_ns_per_m",
    "coulomb_friction_n",
    "pump_dead_band_rpm",
    "c12_m5_per_ns",
];
/// The least value of each parameter: they are fitted in logarithms, so a rig's 0 starts here,
/// and a parameter the records do not see (a viscous friction far below the other forces)
/// stops here instead of drifting towards 0.
const FLOORS: [f64; 5] = [1e-6, 1.0, 0.1, 0.1, 1e-16];
/// The search's simplex: first steps in the logarithms, iterations at most, and the spread of
/// its SSE, relative to the start's, at which it stops.
const SEARCH: (f64, u64, f64) = (0.1, 300, 1e-6);
/// The first steps of the other models' searches, which start near their optimum.
const LATER_STEP: f64 = 0.05;
/// Each profile point's re-fit of the other parameters: its first steps and iterations.
const PROFILE_SEARCH: (f64, u64) = (0.03, 80);
/// Iterations of each dataset's own search of X.
const DATASET_ITERS: u64 = 60;
/// Times the profile starts again from a point of lower SSE than the optimum it began at.
const RESTARTS: usize = 2;
/// First profile offset from the optimum in ln X, and the growth of each further one.
const PROFILE_FIRST: f64 = 0.01;
const PROFILE_GROWTH: f64 = 1.8;
/// Profile points per side at most.
const PROFILE_STEPS: usize = 9;

/// One pressure level's records and what the linear identification found there.
#[derive(Debug, Clone, Copy)]
pub struct Source<'a> {
    /// The level's datasets and standstill point.
    pub problem: &'a Problem,
    /// The linear fit's answer there: its c12 is kept, its b starts the search.
    pub linear: Candidate,
    /// The records' mean chamber pressure (bar gauge).
    pub p_mean_bar: f64,
}

/// The refined parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Refined {
    /// Gas fraction X of the model.
    pub gas_fraction: f64,
    /// Viscous friction b (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// Coulomb friction on the piston (N).
    pub coulomb_friction_n: f64,
    /// The pumps' dead band (rpm).
    pub pump_dead_band_rpm: f64,
    /// Cross-port leakage c12 (m⁵/(N·s)); c1 and c2 follow from each level's standstill point.
    pub c12_m5_per_ns: f64,
}

impl Refined {
    /// The parameters of a point in their logarithms (the order of [`PARAMETERS`]).
    fn of(theta: &[f64]) -> Refined {
        Refined {
            gas_fraction: theta[0].exp(),
            viscous_friction_ns_per_m: theta[1].exp(),
            coulomb_friction_n: theta[2].exp(),
            pump_dead_band_rpm: theta[3].exp(),
            c12_m5_per_ns: theta[4].exp(),
        }
    }

    /// The point of the parameters in their logarithms, each at least its floor.
    fn theta(&self) -> Vec<f64> {
        let v = [
            self.gas_fraction,
            self.viscous_friction_ns_per_m,
            self.coulomb_friction_n,
            self.pump_dead_band_rpm,
            self.c12_m5_per_ns,
        ];
        v.iter().zip(FLOORS).map(|(v, f)| v.max(f).ln()).collect()
    }
}

/// β_e at one level under the refined gas fraction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LevelBeta {
    /// The records' mean chamber pressure (bar gauge).
    pub p_mean_bar: f64,
    /// β_e there (bar).
    pub beta_bar: f64,
    /// Over the gas fraction's interval (bar).
    pub interval_bar: [f64; 2],
}

/// One model's refinement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelRefit {
    /// The model whose gas fraction is fitted.
    pub model: BulkModel,
    /// Where the search started.
    pub start: Refined,
    /// The SSE there (mm²).
    pub start_sse_mm2: f64,
    /// The least-SSE parameters.
    pub refined: Refined,
    /// The SSE there (mm², each record's initial position fitted).
    pub sse_mm2: f64,
    /// AIC minus the least AIC of the models: with the same parameters in each, ΔSSE/σ².
    pub delta_aic: f64,
    /// The Akaike weight exp(−ΔAIC/2) normalised over the models.
    pub akaike_weight: f64,
    /// Whether the records leave the model standing: ΔAIC below χ²₁(P).
    pub plausible: bool,
}

/// The nonlinear refinement's answer: each model refined, the best one's gas fraction profiled.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NonlinearFit {
    /// Each model refined, least SSE first.
    pub fits: Vec<ModelRefit>,
    /// The model the records tell, where more than one was refined and only it stands.
    pub model: Option<BulkModel>,
    /// Samples inside the fit windows.
    pub samples: usize,
    /// Estimated noise σ (mm) at the best model's optimum, its variance inflated for
    /// correlated residuals.
    pub noise_std_mm: f64,
    /// The factor on σ² for correlated residuals.
    pub variance_inflation: f64,
    /// The best model's X: its interval at the confidence asked, the wider of
    /// `profile_interval` and `datasets_interval` on each side.
    pub gas_fraction_interval: [f64; 2],
    /// X's profile-likelihood interval.
    pub profile_interval: [f64; 2],
    /// Whether the profile crossed the threshold on both sides.
    pub identifiable: bool,
    /// Each dataset's own X: ln X re-fitted to that record alone, the other parameters held.
    pub dataset_gas_fractions: Vec<f64>,
    /// The interval the datasets' spread gives: the best ln X ± Student's t over n − 1 degrees
    /// of freedom times their standard deviation over √n (the best X where fewer than two).
    pub datasets_interval: [f64; 2],
    /// The profile: (X, ΔSSE/σ²) by increasing X.
    pub profile: Vec<[f64; 2]>,
    /// β_e at each level's mean pressure under the best model's X.
    pub levels: Vec<LevelBeta>,
    /// Emulations run.
    pub emulations: u64,
}

impl NonlinearFit {
    /// The best model's refinement.
    pub fn best(&self) -> &ModelRefit {
        &self.fits[0]
    }
}

/// One dataset ready for emulation: its rig (without the fitted parameters), its PLC rate and
/// the record's window.
struct Run<'a> {
    ds: &'a Prepared,
    problem: &'a Problem,
    rig: Rig,
    rate_hz: f64,
    duration_s: f64,
}

/// The residuals of a parameter vector over every level's datasets.
struct Residuals<'a> {
    runs: Vec<Run<'a>>,
    model: BulkModel,
    count: std::sync::atomic::AtomicU64,
}

impl<'a> Run<'a> {
    /// Dataset `ds` of level `s`, its rig that of the level's linear answer with the pumps'
    /// slip held at the rig's (absent, it would follow the fit's c12); refused when its fit
    /// window holds fewer than three samples or its samples are not at one rate.
    fn new(s: &Source<'a>, ds: &'a Prepared) -> Result<Run<'a>, IdentError> {
        let rig = Rig {
            pump_slip_m5_per_ns: Some(ds.rig.pump_slip()),
            ..s.problem.rig_for(&s.linear, ds)?
        };
        let refuse = |why: &str| IdentError::Input(format!("dataset `{}`: {why}", ds.name));
        let t = &ds.record.time_s[..ds.window_len()];
        let n = t.len();
        if n < 3 {
            return Err(refuse("too few samples in its fit window"));
        }
        let h = (t[n - 1] - t[0]) / (n - 1) as f64;
        let uniform = t.windows(2).all(|w| ((w[1] - w[0]) - h).abs() <= 1e-6 * h);
        if !(h > 0.0 && uniform) {
            return Err(refuse(
                "its samples are not at one rate, the rate the emulated PLC runs at",
            ));
        }
        Ok(Run {
            ds,
            problem: s.problem,
            rig,
            rate_hz: 1.0 / h,
            duration_s: t[n - 1] - t[0],
        })
    }
}

impl<'a> Residuals<'a> {
    /// Every dataset of `sources` under `model`.
    fn new(sources: &[Source<'a>], model: BulkModel) -> Result<Residuals<'a>, IdentError> {
        let runs = (sources.iter())
            .flat_map(|s| s.problem.datasets.iter().map(move |ds| Run::new(s, ds)))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Residuals {
            runs,
            model,
            count: 0.into(),
        })
    }

    /// The offset-free position errors (mm) of one dataset, `None` where the emulator fails.
    fn of_run(&self, run: &Run<'_>, p: &Refined) -> Option<Vec<f64>> {
        self.count
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let l = (run.problem.standstill)
            .leakage(&run.rig, p.c12_m5_per_ns)
            .ok()?;
        let rig = Rig {
            c12_m5_per_ns: p.c12_m5_per_ns,
            c1_m5_per_ns: l.c1_m5_per_ns,
            c2_m5_per_ns: l.c2_m5_per_ns,
            viscous_friction_ns_per_m: p.viscous_friction_ns_per_m,
            coulomb_friction_n: Some(p.coulomb_friction_n),
            pump_dead_band_rpm: p.pump_dead_band_rpm,
            ..run.rig.clone()
        };
        let effects = Effects {
            bulk_model: self.model,
            ..Effects::all(p.gas_fraction).with_rig(&rig)
        };
        let d = Dynamics::new(&rig, effects).ok()?;
        let rec = &run.ds.record;
        let h = 1.0 / run.rate_hz;
        let last = rec.len() - 1;
        let reference = |t: f64| rec.x_ref_mm[(((t / h) + 1e-6).floor() as usize).min(last)];
        let plc = Plc::ideal(run.rate_hz);
        let e = emulate_reporting(
            &rig,
            &d,
            &plc,
            (0.0, run.duration_s),
            reference,
            &Work::QUIET,
        )
        .ok()?;
        let n = run.ds.window_len();
        let (sim, meas) = (&e.signals.x_mm, &rec.x_mm);
        if sim.len() < n {
            return None;
        }
        let mut r: Vec<f64> = (0..n).map(|k| sim[k] - meas[k]).collect();
        let mean = r.iter().sum::<f64>() / n as f64;
        r.iter_mut().for_each(|v| *v -= mean);
        r.iter().all(|v| v.is_finite()).then_some(r)
    }

    /// Every dataset's residuals, in order.
    fn each(&self, theta: &[f64]) -> Option<Vec<Vec<f64>>> {
        let p = Refined::of(theta);
        (self.runs.par_iter())
            .map(|run| self.of_run(run, &p))
            .collect()
    }

    /// Every residual in one vector.
    fn all(&self, theta: &[f64]) -> Option<DVector<f64>> {
        let r = self.each(theta)?;
        Some(DVector::from_iterator(
            r.iter().map(Vec::len).sum(),
            r.into_iter().flatten(),
        ))
    }

    /// The SSE (mm²) of every residual, +∞ where the emulator fails.
    fn sse(&self, theta: &[f64]) -> f64 {
        self.all(theta).map_or(f64::INFINITY, |r| r.norm_squared())
    }

    /// Samples inside the fit windows, over every dataset.
    fn samples(&self) -> usize {
        self.runs.iter().map(|r| r.ds.window_len()).sum()
    }
}

/// A least-SSE point of the search.
#[derive(Clone)]
struct Point {
    theta: Vec<f64>,
    sse: f64,
}

/// The least SSE over the coordinates `free` of `theta` (the others held), by Nelder–Mead
/// from `theta` (argmin; [`super::refine::minimize`]), each coordinate kept at or above its
/// floor, the simplex's first steps `step`, at most `iters` iterations, stopping when the
/// simplex's SSE spread falls below `tol` (mm²).
fn least_sse(
    res: &Residuals<'_>,
    theta: &[f64],
    free: &[usize],
    (step, tol, iters): (f64, f64, u64),
) -> Option<Point> {
    let at = |q: &[f64]| {
        let mut t = theta.to_vec();
        for (&i, v) in free.iter().zip(q) {
            t[i] = v.max(FLOORS[i].ln());
        }
        t
    };
    let sse = |q: &[f64]| res.sse(&at(q));
    let q0: Vec<f64> = free.iter().map(|&i| theta[i]).collect();
    let (q, sse) = minimize(&sse, &q0, step, tol, iters)?;
    sse.is_finite().then(|| Point { theta: at(&q), sse })
}

/// One model's search: its residuals, start and least-SSE point.
struct Searched<'a> {
    res: Residuals<'a>,
    start: Refined,
    start_sse: f64,
    best: Point,
}

/// Search the least SSE of `model` from the gas fraction `x_start` and `common`'s other
/// parameters, the simplex's first steps `step` (in the logarithms).
fn search<'a>(
    sources: &[Source<'a>],
    (model, x_start): (BulkModel, f64),
    common: Refined,
    step: f64,
) -> Result<Searched<'a>, IdentError> {
    let res = Residuals::new(sources, model)?;
    let start = Refined {
        gas_fraction: x_start,
        ..common
    };
    let theta0 = start.theta();
    let start_sse = res.sse(&theta0);
    let best = (start_sse.is_finite())
        .then(|| least_sse(&res, &theta0, &ALL, (step, SEARCH.2 * start_sse, SEARCH.1)))
        .flatten()
        .ok_or_else(|| {
            IdentError::Input(format!(
                "the emulator cannot run the records under {} from X = {x_start}",
                model.described()
            ))
        })?;
    Ok(Searched {
        res,
        start,
        start_sse,
        best,
    })
}

/// Every parameter free.
const ALL: [usize; 5] = [0, 1, 2, 3, 4];

/// Refine the linear identifications of `sources` (one per pressure level) through the
/// emulator under each of `models` (each with the gas fraction it starts from), the other
/// parameters starting from the linear fits' b (their geometric mean) and the rig's Coulomb
/// friction and dead band; compare the models by their least SSE and profile the best one's
/// X at `confidence`.
///
/// # Errors
/// No records or models, records not at one rate, too few samples to estimate the noise, or
/// an emulator that cannot run a start.
pub fn refine_nonlinear(
    sources: &[Source<'_>],
    models: &[(BulkModel, f64)],
    confidence: f64,
) -> Result<NonlinearFit, IdentError> {
    let confidence = super::check_confidence(confidence)?;
    let (Some(first), false) = (sources.first(), models.is_empty()) else {
        return Err(IdentError::Input("no records or no model to refine".into()));
    };
    let rig = &first.problem.datasets[0].rig;
    let mean = |f: fn(&Candidate) -> f64, floor: f64| {
        let ln = sources.iter().map(|s| f(&s.linear).max(floor).ln());
        (ln.sum::<f64>() / sources.len() as f64).exp()
    };
    let common = Refined {
        gas_fraction: 0.0,
        viscous_friction_ns_per_m: mean(|c| c.viscous_friction_ns_per_m, FLOORS[1]),
        c12_m5_per_ns: mean(|c| c.c12_m5_per_ns, FLOORS[4]),
        coulomb_friction_n: rig.coulomb_friction(),
        pump_dead_band_rpm: rig.pump_dead_band_rpm,
    };
    let mut searched = vec![search(sources, models[0], common, SEARCH.0)?];
    // the other models start where the first ended, their X through its β at the middle level
    let first = Refined::of(&searched[0].best.theta);
    let mut p: Vec<f64> = sources.iter().map(|s| s.p_mean_bar).collect();
    p.sort_by(f64::total_cmp);
    let p_mid = p[p.len() / 2];
    let oil = crate::bulk::BETA_OIL_BAR;
    let beta_mid = models[0].0.beta_bar(first.gas_fraction, p_mid, oil);
    for &(m, x) in &models[1..] {
        let x = m.fit(beta_mid, p_mid, oil).unwrap_or(x);
        searched.push(search(sources, (m, x), first, LATER_STEP)?);
    }
    let samples = searched[0].res.samples();
    let fitted = PARAMETERS.len() + searched[0].res.runs.len();
    if samples <= fitted {
        return Err(IdentError::Input(format!(
            "{samples} samples inside the fit windows: too few to estimate the noise"
        )));
    }
    searched.sort_by(|a, b| a.best.sse.total_cmp(&b.best.sse));
    let threshold = chi2_1_quantile(confidence);
    let (scan, var, inflation) = profile_best(&mut searched[0], samples - fitted, threshold)?;
    let (profile, profile_interval, crossed) = scan;
    let dataset_gas_fractions = dataset_estimates(&searched[0]);
    let datasets_interval = spread_interval(
        searched[0].best.theta[0],
        &dataset_gas_fractions,
        confidence,
    );
    let interval = [
        profile_interval[0].min(datasets_interval[0]),
        profile_interval[1].max(datasets_interval[1]),
    ];
    let fits = compare(&searched, var, threshold);
    let best = &fits[0];
    let levels = (sources.iter())
        .map(|s| {
            let beta = |x: f64| {
                best.model
                    .beta_bar(x, s.p_mean_bar, crate::bulk::BETA_OIL_BAR)
            };
            LevelBeta {
                p_mean_bar: s.p_mean_bar,
                beta_bar: beta(best.refined.gas_fraction),
                interval_bar: [beta(interval[1]), beta(interval[0])],
            }
        })
        .collect();
    let standing: Vec<&ModelRefit> = fits.iter().filter(|f| f.plausible).collect();
    let model = match standing.as_slice() {
        [only] if fits.len() > 1 => Some(only.model),
        _ => None,
    };
    let emulations = (searched.iter())
        .map(|s| s.res.count.load(std::sync::atomic::Ordering::Relaxed))
        .sum();
    Ok(NonlinearFit {
        model,
        samples,
        noise_std_mm: var.sqrt(),
        variance_inflation: inflation,
        gas_fraction_interval: interval,
        profile_interval,
        dataset_gas_fractions,
        datasets_interval,
        identifiable: crossed.iter().all(|&c| c),
        profile,
        levels,
        emulations,
        fits,
    })
}

/// Profile the best model's X, starting again (at most [`RESTARTS`] times) from a lower SSE
/// the profile meets; σ² the SSE over `dof` degrees of freedom, inflated for the residuals'
/// correlation. Returns the profile, σ² and the inflation.
fn profile_best(
    s: &mut Searched<'_>,
    dof: usize,
    threshold: f64,
) -> Result<(Scan, f64, f64), IdentError> {
    let tol = SEARCH.2 * s.start_sse;
    let search = (SEARCH.0, tol, SEARCH.1);
    for restart in 0..=RESTARTS {
        let residuals = (s.res.each(&s.best.theta))
            .ok_or_else(|| IdentError::Input("the emulator cannot run the best fit".into()))?;
        let inflation = variance_inflation(&pooled_autocorrelations(&residuals));
        let var = s.best.sse / dof as f64 * inflation;
        let (scan, lower) = profile_x(&s.res, &s.best, var, threshold, tol);
        match lower {
            // the profile met a lower SSE: the optimum lies there, and the profile starts again
            Some(lower) if restart < RESTARTS => {
                s.best = least_sse(&s.res, &lower.theta, &ALL, search)
                    .filter(|p| p.sse < lower.sse)
                    .unwrap_or(lower);
            }
            _ => return Ok((scan, var, inflation)),
        }
    }
    unreachable!("the last restart returns")
}

/// Each dataset's own X: ln X re-fitted by Nelder–Mead to that record alone, the other
/// parameters held at `s`'s optimum; a dataset whose search fails is left out.
fn dataset_estimates(s: &Searched<'_>) -> Vec<f64> {
    let best = &s.best.theta;
    let tol = SEARCH.2 * s.best.sse;
    (s.res.runs.par_iter())
        .filter_map(|run| {
            let sse = |q: &[f64]| {
                let mut t = best.clone();
                t[0] = q[0];
                let r = s.res.of_run(run, &Refined::of(&t));
                r.map_or(f64::INFINITY, |r| r.iter().map(|v| v * v).sum())
            };
            let (q, _) = minimize(&sse, &best[..1], PROFILE_FIRST, tol, DATASET_ITERS)?;
            Some(q[0].exp())
        })
        .collect()
}

/// The interval of ln X about `ln_best` that the datasets' own estimates `xs` give:
/// ± t_{n−1}((1 + P)/2) · s/√n, s their standard deviation in ln X; `[x, x]` where fewer than two.
fn spread_interval(ln_best: f64, xs: &[f64], confidence: f64) -> [f64; 2] {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let n = xs.len();
    let t = (n >= 2)
        .then(|| StudentsT::new(0.0, 1.0, (n - 1) as f64).ok())
        .flatten();
    let Some(t) = t else {
        return [ln_best.exp(); 2];
    };
    let ln: Vec<f64> = xs.iter().map(|x| x.ln()).collect();
    let mean = ln.iter().sum::<f64>() / n as f64;
    let var = ln.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let half = t.inverse_cdf(0.5 * (1.0 + confidence)) * (var / n as f64).sqrt();
    [(ln_best - half).exp(), (ln_best + half).exp()]
}

/// Each model's refinement against the best one's: ΔAIC = ΔSSE/σ² (the models have the same
/// parameters), the Akaike weights, and whether ΔAIC stays below `threshold`.
fn compare(searched: &[Searched<'_>], var: f64, threshold: f64) -> Vec<ModelRefit> {
    let least = searched[0].best.sse;
    let delta: Vec<f64> = (searched.iter())
        .map(|s| (s.best.sse - least) / var)
        .collect();
    let weights = crate::bulk::levels::akaike_weights(&delta);
    (searched.iter().zip(&delta).zip(weights))
        .map(|((s, &d), w)| ModelRefit {
            model: s.res.model,
            start: s.start,
            start_sse_mm2: s.start_sse,
            refined: Refined::of(&s.best.theta),
            sse_mm2: s.best.sse,
            delta_aic: d,
            akaike_weight: w,
            plausible: d < threshold,
        })
        .collect()
}

/// A profile: its points (X, ΔSSE/σ²), X's interval and whether each side crossed.
type Scan = (Vec<[f64; 2]>, [f64; 2], [bool; 2]);

/// The profile of ln X about `best`: outward steps, the other parameters re-fitted from the
/// previous point, until ΔSSE/σ² passes `threshold`; the interval's ends interpolated in ln X
/// between the points that straddle it (the outermost point where it never does). Beside it,
/// the point of least SSE the profile met, where that is lower than `best`'s by more than `tol`.
fn profile_x(
    res: &Residuals<'_>,
    best: &Point,
    var: f64,
    threshold: f64,
    tol: f64,
) -> (Scan, Option<Point>) {
    let mut points = vec![[best.theta[0].exp(), 0.0]];
    let mut ends = [best.theta[0]; 2];
    let mut crossed = [false; 2];
    let mut lower: Option<Point> = None;
    let (step, iters) = PROFILE_SEARCH;
    for (side, sign) in [-1.0f64, 1.0].into_iter().enumerate() {
        let (mut theta, mut offset, mut last) = (best.theta.clone(), PROFILE_FIRST, (0.0, 0.0));
        for _ in 0..PROFILE_STEPS {
            theta[0] = best.theta[0] + sign * offset;
            let Some(p) = least_sse(res, &theta, &ALL[1..], (step, tol, iters)) else {
                break;
            };
            if p.sse < lower.as_ref().map_or(best.sse - tol, |l| l.sse) {
                lower = Some(p.clone());
            }
            let stat = ((p.sse - best.sse) / var).max(0.0);
            points.push([theta[0].exp(), stat]);
            ends[side] = theta[0];
            if stat >= threshold {
                let (o0, s0) = last;
                let cross = o0 + (offset - o0) * (threshold - s0) / (stat - s0);
                ends[side] = best.theta[0] + sign * cross;
                crossed[side] = true;
                break;
            }
            last = (offset, stat);
            theta = p.theta;
            offset *= PROFILE_GROWTH;
        }
    }
    points.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let scan = (points, [ends[0].exp(), ends[1].exp()], crossed);
    (scan, lower)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_datasets_interval_is_students_t_over_root_n_in_ln_x() {
        // six estimates, ln X spread known: t₅(0.975) = 2.570 581 8 (any table of Student's t)
        let ln = [-2.10, -2.12, -2.08, -2.15, -2.11, -2.09];
        let xs: Vec<f64> = ln.iter().map(|v: &f64| v.exp()).collect();
        let mean = ln.iter().sum::<f64>() / 6.0;
        let s = (ln.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 5.0).sqrt();
        let half = 2.570_581_8 * s / 6f64.sqrt();
        let [lo, hi] = spread_interval(-2.1, &xs, 0.95);
        assert!((lo.ln() - (-2.1 - half)).abs() < 1e-7, "{lo}");
        assert!((hi.ln() - (-2.1 + half)).abs() < 1e-7, "{hi}");
        // one estimate gives no spread: the interval is the point
        assert_eq!(spread_interval(-2.1, &xs[..1], 0.95), [(-2.1f64).exp(); 2]);
    }

    #[test]
    fn parameters_round_trip_through_their_logarithms_above_their_floors() {
        let p = Refined {
            gas_fraction: 0.12,
            viscous_friction_ns_per_m: 0.0,
            coulomb_friction_n: 15.0,
            pump_dead_band_rpm: 60.0,
            c12_m5_per_ns: 1.2e-10,
        };
        let back = Refined::of(&p.theta());
        assert!((back.gas_fraction / 0.12 - 1.0).abs() < 1e-12);
        assert!((back.c12_m5_per_ns / 1.2e-10 - 1.0).abs() < 1e-12);
        // a 0 the rig gives starts at the floor
        assert!((back.viscous_friction_ns_per_m - FLOORS[1]).abs() < 1e-12);
    }
}
