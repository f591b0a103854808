//! Robust design (docs/design.md#robust-design): the margins over the uncertainty of the
//! identified parameters, the stroke and the pressure range, and the largest position gain
//! whose worst-case margins meet the targets; the article's "if unstable, lower the leakage
//! estimate and repeat" (§2.2, last step of the method) done automatically.
//!
//! The parameter set is a [`Region`]: the confidence box of (β, b, c12) with the ridge of the
//! profile-likelihood points inside it (docs/identification.md, "Uncertainty"), or a stated
//! default box for a rig without records. Each parameter point is combined with every stroke
//! position, mass and mean pressure (β_e(p) from the gas fraction that gives the point's β at
//! the identification pressure, docs/bulk-modulus.md).

use super::{kp_max, kp_max_below, margins_at, meets, DesignError, Targets, Verdict};
use super::{GM_TOLERANCE_DB, KP_CEILING, KP_FLOOR, PM_TOLERANCE_DEG};
use crate::ident::{
    analyze, check_confidence, spaced, Candidate, Experiment, FrequencyProblem, Grid, Profile,
    Standstill, Uncertainty, UncertaintyOptions,
};
use crate::lti::Margins;
use crate::rig::Rig;
use rayon::prelude::*;
use serde::Serialize;

/// Stated default uncertainty for a rig without records, as factors on the rig's values
/// (docs/design.md#the-stated-default-uncertainty): β ±15 %.
pub const DEFAULT_BETA_FACTORS: [f64; 2] = [0.85, 1.15];
/// Viscous friction b × [0.5, 2]: a step barely informs it.
pub const DEFAULT_FRICTION_FACTORS: [f64; 2] = [0.5, 2.0];
/// Cross-port leakage c12 × [0.7, 1.3].
pub const DEFAULT_C12_FACTORS: [f64; 2] = [0.7, 1.3];
/// Most values per parameter axis of the interior grid.
pub const MAX_GRID: usize = 9;
/// Most stroke positions.
pub const MAX_POSITIONS: usize = 41;
/// Most steps of the leakage loop.
pub const MAX_STEPS: usize = 50;
/// Most ridge (profile) points used; more are thinned evenly.
pub const MAX_RIDGE: usize = 60;
/// Most evaluation points (parameter points × positions × masses × pressures).
pub const MAX_EVALUATIONS: usize = 50_000;

/// Where the parameter set comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RegionSource {
    /// The profile-likelihood confidence region of identification records.
    Records,
    /// The stated default uncertainty around the rig's own values.
    StatedDefault,
    /// One parameter point given by the caller (zero width).
    Point,
}

/// The set of parameters the design must hold over.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Region {
    /// Where it comes from.
    pub source: RegionSource,
    /// Confidence level of the region (records only).
    pub confidence: Option<f64>,
    /// The point estimate.
    pub nominal: Candidate,
    /// β interval (bar).
    pub beta_bar: [f64; 2],
    /// b interval (N·s/m); for a b the records do not bound, the search bounds reached.
    pub viscous_friction_ns_per_m: [f64; 2],
    /// c12 interval (m⁵/(N·s)).
    pub c12_m5_per_ns: [f64; 2],
    /// Whether the records bound (β, b, c12); all true for the stated default.
    pub identifiable: [bool; 3],
    /// Profile points inside the region: the least-cost point for each profiled value, the
    /// ridge along which the region stretches.
    pub ridge: Vec<Candidate>,
    /// The standstill point giving c1, c2 for each c12 (docs/identification.md#leakage-from-standstill);
    /// `None`: c1 and c2 scale with c12 in proportion to the rig's values.
    pub standstill: Option<Standstill>,
}

impl Region {
    /// The stated default uncertainty around `rig`'s β, b and c12 (the factors
    /// [`DEFAULT_BETA_FACTORS`], [`DEFAULT_FRICTION_FACTORS`], [`DEFAULT_C12_FACTORS`]).
    pub fn stated_default(rig: &Rig) -> Region {
        let scaled = |v: f64, f: [f64; 2]| [v * f[0], v * f[1]];
        Region {
            source: RegionSource::StatedDefault,
            confidence: None,
            nominal: Candidate {
                beta_bar: rig.beta_bar,
                viscous_friction_ns_per_m: rig.viscous_friction_ns_per_m,
                c12_m5_per_ns: rig.c12_m5_per_ns,
            },
            beta_bar: scaled(rig.beta_bar, DEFAULT_BETA_FACTORS),
            viscous_friction_ns_per_m: scaled(
                rig.viscous_friction_ns_per_m,
                DEFAULT_FRICTION_FACTORS,
            ),
            c12_m5_per_ns: scaled(rig.c12_m5_per_ns, DEFAULT_C12_FACTORS),
            identifiable: [true; 3],
            ridge: Vec::new(),
            standstill: None,
        }
    }

    /// The confidence region of an uncertainty analysis: the profiles' intervals (the search
    /// bounds for a side a profile did not cross) and the profile points whose statistic is
    /// within the threshold; c1, c2 from `standstill`.
    pub fn from_uncertainty(u: &Uncertainty, standstill: Standstill) -> Region {
        Region::from_profiles(u.best, (u.confidence, u.threshold), &u.profiles, standstill)
    }

    /// The confidence region at (confidence, threshold) of the profiles around `best`, of a
    /// time-domain ([`Uncertainty`]) or a frequency-domain fit
    /// ([`crate::ident::FrequencyUncertainty`]).
    fn from_profiles(
        best: Candidate,
        (confidence, threshold): (f64, f64),
        profiles: &[Profile],
        standstill: Standstill,
    ) -> Region {
        let profile = |name: &str| profiles.iter().find(|p| p.parameter == name);
        let interval = |name: &str, v: f64| profile(name).map_or([v, v], |p| p.interval);
        let identifiable =
            crate::ident::PARAMETERS.map(|name| profile(name).is_some_and(|p| p.identifiable));
        let [beta, b, c12] = crate::ident::PARAMETERS;
        let boxed = [beta, b, c12].map(|n| profile(n).map(|p| p.interval));
        // each profile has its own variance inflation (docs/identification.md, "Uncertainty"):
        // a point under one profile's threshold may lie outside another's interval
        let inside = |c: &Candidate| {
            let v = [c.beta_bar, c.viscous_friction_ns_per_m, c.c12_m5_per_ns];
            (0..3).all(|i| boxed[i].is_none_or(|[lo, hi]| lo <= v[i] && v[i] <= hi))
        };
        let ridge: Vec<Candidate> = profiles
            .iter()
            .flat_map(|p| &p.points)
            .filter(|q| q.statistic <= threshold)
            .map(|q| q.candidate)
            .filter(inside)
            .collect();
        Region {
            source: RegionSource::Records,
            confidence: Some(confidence),
            nominal: best,
            beta_bar: interval(beta, best.beta_bar),
            viscous_friction_ns_per_m: interval(b, best.viscous_friction_ns_per_m),
            c12_m5_per_ns: interval(c12, best.c12_m5_per_ns),
            identifiable,
            ridge: thin(ridge, MAX_RIDGE),
            standstill: Some(standstill),
        }
    }

    /// The confidence region of `u` with the identification's answer `best` as its point
    /// estimate, the one `identify` reports and every other step uses (the profiles' polished
    /// optimum lies in the same region, but wanders along a flat b).
    ///
    /// A parameter the records cannot bound (b from steps) has a profile that ends at its
    /// search range while the polished answer wanders on along the flat direction, below the
    /// range's lowest value: its interval is widened to hold the answer, so that the region is
    /// still the whole range the records allow.
    pub fn around(best: Candidate, u: &Uncertainty, standstill: Standstill) -> Region {
        Region::from_uncertainty(u, standstill).holding(best)
    }

    /// This region with `best` as its point estimate, each interval widened to hold it.
    fn holding(self, best: Candidate) -> Region {
        let r = self;
        let hold = |[lo, hi]: [f64; 2], v: f64| [lo.min(v), hi.max(v)];
        Region {
            nominal: best,
            beta_bar: hold(r.beta_bar, best.beta_bar),
            viscous_friction_ns_per_m: hold(
                r.viscous_friction_ns_per_m,
                best.viscous_friction_ns_per_m,
            ),
            c12_m5_per_ns: hold(r.c12_m5_per_ns, best.c12_m5_per_ns),
            ..r
        }
    }

    /// Identify the experiment's records with the file's options and read the confidence
    /// region at `confidence` off the profiles (docs/identification.md, "Uncertainty");
    /// returns the experiment's rig carrying the identification's answer (β, b, c12 and c1, c2 from the
    /// standstill) and the region.
    pub fn of_records(exp: &Experiment, confidence: f64) -> Result<(Rig, Region), DesignError> {
        let confidence = check_confidence(confidence)?;
        let (best, region) = match exp.frequency_problem() {
            Some(problem) => Region::of_frequency_fit(exp, &problem, confidence)?,
            None => {
                let id = exp.identify(&exp.options())?;
                let opts = UncertaintyOptions {
                    confidence,
                    ..UncertaintyOptions::default()
                };
                let best = id.best().candidate;
                let u = analyze(&exp.problem, &best, &opts)?;
                (best, Region::around(best, &u, exp.problem.standstill))
            }
        };
        let (c1, c2) = region.leakages(&exp.rig, best.c12_m5_per_ns)?;
        let rig = Rig {
            beta_bar: best.beta_bar,
            viscous_friction_ns_per_m: best.viscous_friction_ns_per_m,
            c12_m5_per_ns: best.c12_m5_per_ns,
            c1_m5_per_ns: c1,
            c2_m5_per_ns: c2,
            ..exp.rig.clone()
        };
        Ok((rig, region))
    }

    /// The frequency-domain fit of an experiment's sweeps, with its step records beside them
    /// where it has any (docs/identification.md#grey-box-fit-to-a-frequency-response), and
    /// its confidence region at `confidence` around the fit's answer, as `identify
    /// --uncertainty` gives them: the records the robust design holds over are all of them.
    fn of_frequency_fit(
        exp: &Experiment,
        problem: &FrequencyProblem,
        confidence: f64,
    ) -> Result<(Candidate, Region), DesignError> {
        let fit = problem.fit(&exp.first_grid)?;
        let u = problem.uncertainty(&fit, confidence)?;
        let region = Region::from_profiles(
            fit.best,
            (u.confidence, u.threshold),
            &u.profiles,
            exp.problem.standstill,
        );
        Ok((fit.best, region.holding(fit.best)))
    }

    /// A region of one point (zero width): `c` with c1, c2 from `standstill` or the rig.
    pub fn point(c: Candidate, standstill: Option<Standstill>) -> Region {
        Region {
            source: RegionSource::Point,
            confidence: None,
            nominal: c,
            beta_bar: [c.beta_bar; 2],
            viscous_friction_ns_per_m: [c.viscous_friction_ns_per_m; 2],
            c12_m5_per_ns: [c.c12_m5_per_ns; 2],
            identifiable: [true; 3],
            ridge: Vec::new(),
            standstill,
        }
    }

    /// Check the intervals: finite, positive, ordered, holding the point estimate.
    fn validate(&self) -> Result<(), DesignError> {
        let c = &self.nominal;
        for (name, [lo, hi], v) in [
            ("beta_bar", self.beta_bar, c.beta_bar),
            (
                "viscous_friction_ns_per_m",
                self.viscous_friction_ns_per_m,
                c.viscous_friction_ns_per_m,
            ),
            ("c12_m5_per_ns", self.c12_m5_per_ns, c.c12_m5_per_ns),
        ] {
            let ok = lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= v && v <= hi;
            if !ok {
                return Err(DesignError::Input(format!(
                    "region {name} [{lo}, {hi}] must be finite, > 0 and hold the estimate {v}"
                )));
            }
        }
        Ok(())
    }

    /// The parameter points searched: the interior grid of `levels` log-spaced values per
    /// axis (its corners are the box's vertices), the point estimate and the ridge.
    pub fn samples(&self, levels: usize) -> Vec<Candidate> {
        let axis = |[lo, hi]: [f64; 2]| {
            if lo == hi {
                vec![lo]
            } else {
                spaced(lo, hi, levels.max(2), true)
            }
        };
        let grid = Grid {
            beta_bar: axis(self.beta_bar),
            viscous_friction_ns_per_m: axis(self.viscous_friction_ns_per_m),
            c12_m5_per_ns: axis(self.c12_m5_per_ns),
        };
        let mut out: Vec<Candidate> = (0..grid.len()).map(|i| grid.candidate(i)).collect();
        out.push(self.nominal);
        out.extend(&self.ridge);
        out
    }

    /// c1 and c2 (m⁵/(N·s)) for cross-port leakage `c12` on `rig`.
    fn leakages(&self, rig: &Rig, c12: f64) -> Result<(f64, f64), DesignError> {
        match &self.standstill {
            Some(s) => {
                let l = s.leakage(rig, c12)?;
                Ok((l.c1_m5_per_ns, l.c2_m5_per_ns))
            }
            None if rig.c12_m5_per_ns > 0.0 => {
                let f = c12 / rig.c12_m5_per_ns;
                Ok((rig.c1_m5_per_ns * f, rig.c2_m5_per_ns * f))
            }
            None => Ok((rig.c1_m5_per_ns, rig.c2_m5_per_ns)),
        }
    }
}

/// At most `n` of `v`, evenly spaced.
fn thin<T: Copy>(v: Vec<T>, n: usize) -> Vec<T> {
    if v.len() <= n {
        return v;
    }
    (0..n).map(|k| v[k * (v.len() - 1) / (n - 1)]).collect()
}

/// How finely the set is searched.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RobustOptions {
    /// Values per parameter axis of the interior grid (2 = the box's vertices only).
    pub grid: usize,
    /// Stroke positions from x0 − stroke to x0 + stroke (odd counts hold x0).
    pub positions: usize,
    /// Steps of the leakage loop, from the estimate down to the region's lowest c12.
    pub loop_steps: usize,
    /// Whether masses × pressures beyond
    /// [`MAX_MARGIN_ANALYSES`](crate::limits::MAX_MARGIN_ANALYSES) may run
    /// ([`Targets::check_work`], as the nominal design checks them).
    pub allow_long_run: bool,
}

impl Default for RobustOptions {
    /// 3 values per axis (vertices, edge midpoints, centre), 5 positions, 6 loop steps.
    fn default() -> Self {
        RobustOptions {
            grid: 3,
            positions: 5,
            loop_steps: 6,
            allow_long_run: false,
        }
    }
}

/// One point of the searched set: parameters and operating condition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Point {
    /// Bulk modulus at the identification pressure (bar).
    pub beta_bar: f64,
    /// Viscous friction (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// Cross-port leakage (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// Chamber 1 leakage following c12 (m⁵/(N·s)).
    pub c1_m5_per_ns: f64,
    /// Chamber 2 leakage following c12 (m⁵/(N·s)).
    pub c2_m5_per_ns: f64,
    /// Piston position (mm).
    pub x_mm: f64,
    /// Mass there (kg): the load case's, following the rig's `mass_by_position`.
    pub mass_kg: f64,
    /// The load case: its mass at x0 (kg).
    pub load_mass_kg: f64,
    /// Mean chamber pressure (bar), when pressure is varied.
    pub p_mean_bar: Option<f64>,
    /// Effective bulk modulus there (bar).
    pub beta_e_bar: f64,
}

impl Point {
    /// `rig` at this point.
    pub fn rig(&self, rig: &Rig) -> Rig {
        Rig {
            beta_bar: self.beta_e_bar,
            viscous_friction_ns_per_m: self.viscous_friction_ns_per_m,
            c12_m5_per_ns: self.c12_m5_per_ns,
            c1_m5_per_ns: self.c1_m5_per_ns,
            c2_m5_per_ns: self.c2_m5_per_ns,
            x0_mm: self.x_mm,
            mass_kg: self.mass_kg,
            ..rig.clone()
        }
    }

    /// The point in words.
    pub fn describe(&self) -> String {
        format!(
            "beta {:.1} bar, b {:.0} N·s/m, c12 {:.3e} m⁵/(N·s), x {:.1} mm, m {:.0} kg{}, beta_e {:.1} bar",
            self.beta_bar,
            self.viscous_friction_ns_per_m,
            self.c12_m5_per_ns,
            self.x_mm,
            self.mass_kg,
            self.p_mean_bar
                .map_or(String::new(), |p| format!(", p {p:.2} bar")),
            self.beta_e_bar
        )
    }
}

/// The worst value of one margin over the set and where it occurs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Worst {
    /// The value; `None` = infinite everywhere.
    pub value: Option<f64>,
    /// Whether the closed loop is stable there.
    pub closed_loop_stable: bool,
    /// Where.
    pub at: Point,
}

/// The worst-case margins over the set at one gain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WorstCase {
    /// The gain (1/m).
    pub kp: f64,
    /// Smallest gain margin (dB); an unstable point first.
    pub gain_margin_db: Worst,
    /// Smallest phase margin (deg); an unstable point first.
    pub phase_margin_deg: Worst,
    /// Smallest delay margin (s); an unstable point first.
    pub delay_margin_s: Worst,
    /// Whether the closed loop is stable at every point.
    pub all_stable: bool,
    /// Whether every point meets the targets (within the verdict's tolerances).
    pub meets_targets: bool,
    /// Points evaluated.
    pub points: usize,
}

/// The margin that limits the gain at a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Binding {
    /// The phase margin reaches its target.
    PhaseMargin,
    /// The gain margin reaches its target.
    GainMargin,
    /// The closed loop reaches its stability limit.
    Stability,
}

/// The condition that decides a gain: where the gain is largest that still meets the
/// targets, and which margin binds there.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Deciding {
    /// Where.
    pub at: Point,
    /// Which margin.
    pub binding: Binding,
    /// Gain margin there at the decided gain (dB), `None` = infinite.
    pub gain_margin_db: Option<f64>,
    /// Phase margin there (deg), `None` = infinite.
    pub phase_margin_deg: Option<f64>,
}

/// One step of the leakage loop.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LoopStep {
    /// Leakage estimate of this step (m⁵/(N·s)).
    pub c12_m5_per_ns: f64,
    /// c1 following it (m⁵/(N·s)).
    pub c1_m5_per_ns: f64,
    /// c2 following it (m⁵/(N·s)).
    pub c2_m5_per_ns: f64,
    /// Largest Kp meeting the targets with this leakage (β and b at the estimate) over the
    /// stroke, masses and pressures (1/m).
    pub kp_max: f64,
    /// The condition deciding that gain.
    pub deciding: Deciding,
    /// The worst-case margins over the whole set at that gain.
    pub worst_case: WorstCase,
}

/// PM, GM and delay margin over the stroke at one parameter point, pressure and mass.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StrokeCurve {
    /// Mean pressure (bar), when pressure is varied.
    pub p_mean_bar: Option<f64>,
    /// The load case: its mass at x0 (kg); along the curve the mass follows the rig's
    /// `mass_by_position`.
    pub mass_kg: f64,
    /// Positions (mm).
    pub x_mm: Vec<f64>,
    /// Phase margin (deg) at each position; `None` = infinite.
    pub phase_margin_deg: Vec<Option<f64>>,
    /// Gain margin (dB) at each position; `None` = infinite.
    pub gain_margin_db: Vec<Option<f64>>,
}

/// The robust design result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobustDesign {
    /// The targets.
    pub targets: Targets,
    /// The parameter set.
    pub region: Region,
    /// How finely it was searched.
    pub options: RobustOptions,
    /// Largest Kp whose worst-case margins over the whole set meet the targets (1/m); never
    /// above `kp_max_nominal`.
    pub kp_max: f64,
    /// Largest Kp meeting the targets at the point estimate and the rig's operating point
    /// (the nominal design, 1/m).
    pub kp_max_nominal: f64,
    /// The condition deciding `kp_max`.
    pub deciding: Deciding,
    /// Worst-case margins over the set at `kp_max`.
    pub worst_case: WorstCase,
    /// Worst-case margins over the set at `kp_max_nominal`.
    pub worst_case_nominal: WorstCase,
    /// The leakage loop, from the estimate down to the region's lowest c12.
    pub steps: Vec<LoopStep>,
    /// The first step whose gain meets the targets over the whole set, if any.
    pub loop_answer: Option<usize>,
    /// Margins over the stroke at the deciding parameter point, at `kp_max`.
    pub stroke_curves: Vec<StrokeCurve>,
    /// The verdict.
    pub verdict: Verdict,
    /// Why, in words.
    pub reasons: Vec<String>,
}

/// The evaluation points: every parameter sample × position × mass × pressure.
fn points(
    rig: &Rig,
    region: &Region,
    params: &[Candidate],
    t: &Targets,
    positions: &[f64],
) -> Result<Vec<Point>, DesignError> {
    let masses = if t.mass_kg.is_empty() {
        vec![rig.mass_kg]
    } else {
        t.mass_kg.clone()
    };
    let pressures: Vec<Option<f64>> = if t.p_mean_bar.is_empty() {
        vec![None]
    } else {
        t.p_mean_bar.iter().map(|p| Some(*p)).collect()
    };
    let total = params.len() * positions.len() * masses.len() * pressures.len();
    if total > MAX_EVALUATIONS {
        return Err(DesignError::Input(format!(
            "{total} evaluation points (parameter points x positions x masses x pressures): \
             more than the limit of {MAX_EVALUATIONS}"
        )));
    }
    let mut out = Vec::with_capacity(total);
    for c in params {
        let (c1, c2) = region.leakages(rig, c.c12_m5_per_ns)?;
        let curve = match pressures[0] {
            Some(_) => Some(super::rig_curve(rig, c.beta_bar, t.beta_anchor_bar(rig))?),
            None => None,
        };
        for &x_mm in positions {
            for &load_mass_kg in &masses {
                for &p in &pressures {
                    out.push(Point {
                        beta_bar: c.beta_bar,
                        viscous_friction_ns_per_m: c.viscous_friction_ns_per_m,
                        c12_m5_per_ns: c.c12_m5_per_ns,
                        c1_m5_per_ns: c1,
                        c2_m5_per_ns: c2,
                        x_mm,
                        // the mass follows the stroke where the geometry ties them
                        mass_kg: rig.mass_at(load_mass_kg, x_mm)?,
                        load_mass_kg,
                        p_mean_bar: p,
                        beta_e_bar: match (curve, p) {
                            (Some(curve), Some(p)) => curve.beta_bar(p),
                            _ => c.beta_bar,
                        },
                    });
                }
            }
        }
    }
    for p in &out {
        p.rig(rig).validate("robust design point")?;
    }
    Ok(out)
}

/// `xs` with the positions of the least phase and gain margins over the stroke of the nominal
/// point `nominal` at gain `kp`, searched (docs/design.md#the-worst-case-searched): the region's
/// corners then meet the position where the nominal loop is weakest, not only the samples.
fn with_searched(
    mut xs: Vec<f64>,
    nominal: &Rig,
    t: &Targets,
    kp: f64,
) -> Result<Vec<f64>, DesignError> {
    let (lo, hi) = (xs[0], xs[xs.len() - 1]);
    if hi > lo {
        let at = |x_mm: f64| -> Result<Rig, DesignError> {
            Ok(Rig {
                x0_mm: x_mm,
                mass_kg: nominal.mass_at(nominal.mass_kg, x_mm)?,
                ..nominal.clone()
            })
        };
        let breaks: Vec<f64> = nominal.mass_by_position.iter().map(|p| p.x_mm).collect();
        let line = super::stroke::Line {
            at: &at,
            mode: 0,
            kp,
            targets: t,
        };
        xs.extend(line.worst(lo, hi, &breaks)?.into_iter().map(|(_, x)| x));
        xs.sort_by(f64::total_cmp);
        xs.dedup();
    }
    Ok(xs)
}

/// `n` positions from x0 − stroke to x0 + stroke (x0 alone for a zero stroke or n = 1).
fn positions(rig: &Rig, stroke_mm: f64, n: usize) -> Vec<f64> {
    if stroke_mm == 0.0 || n <= 1 {
        return vec![rig.x0_mm];
    }
    spaced(rig.x0_mm - stroke_mm, rig.x0_mm + stroke_mm, n, false)
}

/// Ordering key of a margin: an unstable point first, an infinite margin last.
fn key(m: &Margins, v: Option<f64>) -> f64 {
    if !m.closed_loop_stable {
        return f64::NEG_INFINITY;
    }
    v.unwrap_or(f64::INFINITY)
}

/// Whether margins meet the targets within the verdict's tolerances.
fn meets_within(m: &Margins, t: &Targets) -> bool {
    m.closed_loop_stable
        && m.phase_margin_deg
            .is_none_or(|pm| pm >= t.pm_deg - PM_TOLERANCE_DEG)
        && m.gain_margin_db
            .is_none_or(|gm| gm >= t.gm_db - GM_TOLERANCE_DB)
}

/// The margins at every point with gain `kp`, in parallel.
fn margins_over(
    rig: &Rig,
    pts: &[Point],
    kp: f64,
    sampled: bool,
) -> Result<Vec<Margins>, DesignError> {
    pts.par_iter()
        .map(|p| margins_at(&p.rig(rig), kp, sampled))
        .collect()
}

/// The worst-case margins over `pts` at gain `kp`.
pub fn worst_case(
    rig: &Rig,
    pts: &[Point],
    t: &Targets,
    kp: f64,
) -> Result<WorstCase, DesignError> {
    let ms = margins_over(rig, pts, kp, t.sampled)?;
    let worst = |f: fn(&Margins) -> Option<f64>| {
        let (i, m) = ms
            .iter()
            .enumerate()
            .min_by(|a, b| key(a.1, f(a.1)).total_cmp(&key(b.1, f(b.1))))
            .expect("at least one point");
        Worst {
            value: f(m),
            closed_loop_stable: m.closed_loop_stable,
            at: pts[i],
        }
    };
    Ok(WorstCase {
        kp,
        gain_margin_db: worst(|m| m.gain_margin_db),
        phase_margin_deg: worst(|m| m.phase_margin_deg),
        delay_margin_s: worst(|m| m.delay_margin_s),
        all_stable: ms.iter().all(|m| m.closed_loop_stable),
        meets_targets: ms.iter().all(|m| meets_within(m, t)),
        points: pts.len(),
    })
}

/// The largest Kp in (0, `ceiling`] meeting the targets at every point, and the index of the
/// point deciding it (`None` when every point meets them at `ceiling`).
///
/// Equal to the least of the points' own largest gains (the margins fall as the gain rises),
/// found without searching at every point: at the current gain, the failing points furthest
/// below the targets (an unstable one, the least phase margin, the least gain margin) are
/// searched below it ([`kp_max_below`]) and the gain drops to the least of their answers; repeated until no
/// point fails (at most one round per point, each dropping the gain).
pub fn robust_kp(
    rig: &Rig,
    pts: &[Point],
    t: &Targets,
    ceiling: f64,
) -> Result<(f64, Option<usize>), DesignError> {
    let (mut kp, mut deciding) = (ceiling, None);
    for _ in 0..=pts.len() {
        let ms = margins_over(rig, pts, kp, t.sampled)?;
        let failing: Vec<usize> = (0..pts.len()).filter(|&i| !meets(&ms[i], t)).collect();
        let furthest = |f: fn(&Margins) -> Option<f64>| {
            failing
                .iter()
                .copied()
                .min_by(|&a, &b| key(&ms[a], f(&ms[a])).total_cmp(&key(&ms[b], f(&ms[b]))))
        };
        let mut worst: Vec<usize> = [
            furthest(|m| m.phase_margin_deg),
            furthest(|m| m.gain_margin_db),
        ]
        .into_iter()
        .flatten()
        .collect();
        worst.dedup();
        if worst.is_empty() {
            break;
        }
        let gains: Vec<f64> = worst
            .par_iter()
            .map(|&i| kp_max_below(&pts[i].rig(rig), t, kp))
            .collect::<Result<_, _>>()?;
        let (k, i) = gains
            .iter()
            .zip(&worst)
            .min_by(|a, b| a.0.total_cmp(b.0))
            .expect("at least one failing point");
        (kp, deciding) = (*k, Some(*i));
        if kp == 0.0 {
            break;
        }
    }
    Ok((kp, deciding))
}

/// Which margin binds at `point` with gain `kp` (the largest meeting the targets there).
fn deciding(rig: &Rig, point: Point, t: &Targets, kp: f64) -> Result<Deciding, DesignError> {
    let m = margins_at(&point.rig(rig), kp.max(KP_FLOOR), t.sampled)?;
    let slack =
        |v: Option<f64>, target: f64, tol: f64| v.map_or(f64::INFINITY, |v| (v - target) / tol);
    let (pm, gm) = (
        slack(m.phase_margin_deg, t.pm_deg, PM_TOLERANCE_DEG),
        slack(m.gain_margin_db, t.gm_db, GM_TOLERANCE_DB),
    );
    let binding = if !m.closed_loop_stable || pm.min(gm) > 1.0 {
        Binding::Stability
    } else if pm <= gm {
        Binding::PhaseMargin
    } else {
        Binding::GainMargin
    };
    Ok(Deciding {
        at: point,
        binding,
        gain_margin_db: m.gain_margin_db,
        phase_margin_deg: m.phase_margin_deg,
    })
}

/// Check the inputs as [`super::design`] does, and the search's sizes.
fn check(rig: &Rig, t: &Targets, opts: &RobustOptions) -> Result<(), DesignError> {
    // the robust design searches the mode the rig rests in
    t.check_work(1, opts.allow_long_run)?;
    super::check_inputs(rig, t)?;
    for (name, v, max) in [
        ("grid", opts.grid, MAX_GRID),
        ("positions", opts.positions, MAX_POSITIONS),
        ("loop_steps", opts.loop_steps, MAX_STEPS),
    ] {
        if v == 0 || v > max {
            return Err(DesignError::Input(format!(
                "robust design {name} = {v}: must lie in 1 ..= {max}"
            )));
        }
    }
    Ok(())
}

/// The robust design of `rig` over `region` (docs/design.md#robust-design): the largest Kp
/// whose worst-case margins over the region's samples × stroke × masses × pressures meet the
/// targets, never above the nominal design's; the leakage loop; the margins over the stroke
/// at the deciding parameter point; a verdict.
pub fn robust_design(
    rig: &Rig,
    region: &Region,
    t: &Targets,
    opts: &RobustOptions,
) -> Result<RobustDesign, DesignError> {
    check(rig, t, opts)?;
    region.validate()?;
    let t = &t.anchored(rig);
    let (c1, c2) = region.leakages(rig, region.nominal.c12_m5_per_ns)?;
    let nominal_point = Point {
        beta_bar: region.nominal.beta_bar,
        viscous_friction_ns_per_m: region.nominal.viscous_friction_ns_per_m,
        c12_m5_per_ns: region.nominal.c12_m5_per_ns,
        c1_m5_per_ns: c1,
        c2_m5_per_ns: c2,
        x_mm: rig.x0_mm,
        mass_kg: rig.mass_kg,
        load_mass_kg: rig.mass_kg,
        p_mean_bar: None,
        beta_e_bar: region.nominal.beta_bar,
    };
    let kp_nominal = kp_max(&nominal_point.rig(rig), t)?;
    if kp_nominal == 0.0 {
        return Err(DesignError::Input(
            "no position gain meets the margin targets at the point estimate: lower the targets"
                .into(),
        ));
    }
    let xs = with_searched(
        positions(rig, t.stroke_mm, opts.positions),
        &nominal_point.rig(rig),
        t,
        kp_nominal,
    )?;
    let pts = points(rig, region, &region.samples(opts.grid), t, &xs)?;
    let (kp, at) = robust_kp(rig, &pts, t, kp_nominal)?;
    let deciding = deciding(rig, at.map_or(nominal_point, |i| pts[i]), t, kp)?;
    let worst = worst_case(rig, &pts, t, kp.max(KP_FLOOR))?;
    let worst_nominal = worst_case(rig, &pts, t, kp_nominal)?;
    let steps = leakage_loop(rig, region, t, &xs, &pts, opts.loop_steps)?;
    let loop_answer = steps.iter().position(|s| s.worst_case.meets_targets);
    let stroke_curves = stroke_curves(rig, &deciding.at, t, kp.max(KP_FLOOR))?;
    let (verdict, reasons) = judge(region, t, kp, kp_nominal, &deciding, &steps, loop_answer);
    Ok(RobustDesign {
        targets: t.clone(),
        region: region.clone(),
        options: *opts,
        kp_max: kp,
        kp_max_nominal: kp_nominal,
        deciding,
        worst_case: worst,
        worst_case_nominal: worst_nominal,
        steps,
        loop_answer,
        stroke_curves,
        verdict,
        reasons,
    })
}

/// The article's loop (§2.2): design at the estimate, then lower the leakage estimate and
/// design again, `n` steps from the estimate's c12 down to the region's lowest (log-spaced);
/// each step's gain is the largest meeting the targets over the stroke, masses and pressures
/// with that leakage, and is checked over the whole set `pts`.
fn leakage_loop(
    rig: &Rig,
    region: &Region,
    t: &Targets,
    xs: &[f64],
    pts: &[Point],
    n: usize,
) -> Result<Vec<LoopStep>, DesignError> {
    let (c12, lowest) = (region.nominal.c12_m5_per_ns, region.c12_m5_per_ns[0]);
    let mut values = if lowest < c12 {
        spaced(c12, lowest, n, true)
    } else {
        vec![c12]
    };
    values[0] = c12; // the estimate itself, not its round trip through the logarithm
    values
        .iter()
        .map(|&c| {
            let at = Candidate {
                c12_m5_per_ns: c,
                ..region.nominal
            };
            let conditions = points(rig, region, &[at], t, xs)?;
            let (kp, i) = robust_kp(rig, &conditions, t, KP_CEILING)?;
            let point = i.map_or(conditions[0], |i| conditions[i]);
            Ok(LoopStep {
                c12_m5_per_ns: c,
                c1_m5_per_ns: point.c1_m5_per_ns,
                c2_m5_per_ns: point.c2_m5_per_ns,
                kp_max: kp,
                deciding: deciding(rig, point, t, kp)?,
                worst_case: worst_case(rig, pts, t, kp.max(KP_FLOOR))?,
            })
        })
        .collect()
}

/// Positions on the stroke drawn in the figure.
const CURVE_POSITIONS: usize = 21;

/// PM and GM over the stroke at the parameter point of `at`, for each mass and pressure.
fn stroke_curves(
    rig: &Rig,
    at: &Point,
    t: &Targets,
    kp: f64,
) -> Result<Vec<StrokeCurve>, DesignError> {
    let xs = positions(rig, t.stroke_mm, CURVE_POSITIONS);
    let region = Region::point(
        Candidate {
            beta_bar: at.beta_bar,
            viscous_friction_ns_per_m: at.viscous_friction_ns_per_m,
            c12_m5_per_ns: at.c12_m5_per_ns,
        },
        None,
    );
    let fixed = Rig {
        c12_m5_per_ns: at.c12_m5_per_ns,
        c1_m5_per_ns: at.c1_m5_per_ns,
        c2_m5_per_ns: at.c2_m5_per_ns,
        ..rig.clone()
    };
    let pts = points(&fixed, &region, &[region.nominal], t, &xs)?;
    let ms = margins_over(rig, &pts, kp, t.sampled)?;
    let mut curves: Vec<StrokeCurve> = Vec::new();
    for (p, m) in pts.iter().zip(&ms) {
        let same =
            |c: &&mut StrokeCurve| c.p_mean_bar == p.p_mean_bar && c.mass_kg == p.load_mass_kg;
        let curve = match curves.iter_mut().position(|c| same(&c)) {
            Some(i) => &mut curves[i],
            None => {
                curves.push(StrokeCurve {
                    p_mean_bar: p.p_mean_bar,
                    mass_kg: p.load_mass_kg,
                    x_mm: Vec::new(),
                    phase_margin_deg: Vec::new(),
                    gain_margin_db: Vec::new(),
                });
                curves.last_mut().expect("just pushed")
            }
        };
        curve.x_mm.push(p.x_mm);
        curve.phase_margin_deg.push(m.phase_margin_deg);
        curve.gain_margin_db.push(m.gain_margin_db);
    }
    Ok(curves)
}

/// The verdict and its reasons.
fn judge(
    region: &Region,
    t: &Targets,
    kp: f64,
    kp_nominal: f64,
    d: &Deciding,
    steps: &[LoopStep],
    loop_answer: Option<usize>,
) -> (Verdict, Vec<String>) {
    let binding = match d.binding {
        Binding::PhaseMargin => format!("the phase margin reaches {} deg", t.pm_deg),
        Binding::GainMargin => format!("the gain margin reaches {} dB", t.gm_db),
        Binding::Stability => "the closed loop reaches its stability limit".into(),
    };
    let source = match region.source {
        RegionSource::Records => format!(
            "the {:.0} % confidence region of the records",
            region.confidence.unwrap_or(0.0) * 100.0
        ),
        RegionSource::StatedDefault => "the stated default uncertainty (beta ±15 %, b x[0.5, 2], c12 x[0.7, 1.3]; docs/design.md)".into(),
        RegionSource::Point => "the given parameter point".into(),
    };
    let mut reasons = vec![format!(
        "robust Kp = {kp:.2} (nominal {kp_nominal:.2}) meets PM >= {} deg and GM >= {} dB over {source}, the stroke, masses and pressures",
        t.pm_deg, t.gm_db
    )];
    reasons.push(format!(
        "deciding condition: {}, where {binding}",
        d.at.describe()
    ));
    if !region.identifiable[1] {
        reasons.push(format!(
            "b is not identifiable from the records: its whole reported interval {:.0} .. {:.0} N·s/m is searched",
            region.viscous_friction_ns_per_m[0], region.viscous_friction_ns_per_m[1]
        ));
    }
    match loop_answer {
        Some(i) => reasons.push(format!(
            "the article's loop (lower the leakage estimate and repeat) stops at step {}: c12 = {:.3e} gives Kp = {:.2}, which meets the targets over the whole set",
            i + 1,
            steps[i].c12_m5_per_ns,
            steps[i].kp_max
        )),
        None => reasons.push(
            "the article's loop (lower the leakage estimate and repeat) reaches the region's lowest c12 without a gain that meets the targets over the whole set: the leakage alone does not decide it".into(),
        ),
    }
    if kp == 0.0 {
        reasons.push("no gain meets the targets over the whole set: use a circuit with higher pressure (stiffer beta_e) or narrow the uncertainty".into());
        return (Verdict::UseHigherPressure, reasons);
    }
    (Verdict::Adequate, reasons)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bulk::{effective_beta, gas_fraction, BETA_OIL_BAR};

    fn targets() -> Targets {
        Targets::default()
    }

    /// The robust gain on the default rig over the stated default uncertainty is below the
    /// nominal design's and is decided where the margins are least: the region's lowest β, b
    /// and c12 (least stiffness and damping), at a stroke end, by a margin at its target.
    #[test]
    fn default_rig_robust_gain_is_below_nominal_and_named() {
        let rig = Rig::default();
        let t = targets();
        let d = robust_design(
            &rig,
            &Region::stated_default(&rig),
            &t,
            &RobustOptions::default(),
        )
        .unwrap();
        // the nominal design is the article's Kp 25 within 1 (docs/design.md)
        assert!(
            (d.kp_max_nominal - 25.0).abs() < 1.0,
            "{}",
            d.kp_max_nominal
        );
        assert!(
            d.kp_max > 1.0 && d.kp_max < d.kp_max_nominal,
            "{}",
            d.kp_max
        );
        assert_eq!(d.kp_max_nominal, kp_max(&rig, &t).unwrap());
        let at = d.deciding.at;
        assert!((at.beta_bar / (0.85 * 165.0) - 1.0).abs() < 1e-9, "{at:?}");
        assert!(
            (at.viscous_friction_ns_per_m / 50.0 - 1.0).abs() < 1e-9,
            "{at:?}"
        );
        assert!((at.c12_m5_per_ns / 0.84e-10 - 1.0).abs() < 1e-9, "{at:?}");
        assert!((at.x_mm - rig.x0_mm).abs() == 50.0, "{at:?}");
        // the binding margin sits on its target there; the other one is above its own
        match d.deciding.binding {
            Binding::GainMargin => {
                assert!((d.deciding.gain_margin_db.unwrap() - 6.0).abs() < GM_TOLERANCE_DB);
                assert!(d.deciding.phase_margin_deg.unwrap() > 34.0);
            }
            Binding::PhaseMargin => {
                assert!((d.deciding.phase_margin_deg.unwrap() - 34.0).abs() < PM_TOLERANCE_DEG);
                assert!(d.deciding.gain_margin_db.unwrap() > 6.0);
            }
            Binding::Stability => panic!("{:?}", d.deciding),
        }
        assert!(
            d.reasons[1]
                .starts_with("deciding condition: beta 140.3 bar, b 50 N·s/m, c12 8.400e-11"),
            "{:?}",
            d.reasons
        );
        // the whole set meets the targets at the robust gain, not at the nominal one
        assert!(d.worst_case.meets_targets && d.worst_case.all_stable);
        assert!(!d.worst_case_nominal.meets_targets);
        assert_eq!(d.worst_case.points, (27 + 1) * 5);
        assert_eq!(d.verdict, Verdict::Adequate);
        // the leakage loop: from the estimate down to the lowest c12, each step at most the
        // gain of the step before (less leakage, less damping)
        assert_eq!(d.steps.len(), 6);
        assert_eq!(d.steps[0].c12_m5_per_ns, 1.2e-10);
        assert!((d.steps[5].c12_m5_per_ns / 0.84e-10 - 1.0).abs() < 1e-12);
        for w in d.steps.windows(2) {
            assert!(
                w[1].kp_max <= w[0].kp_max,
                "{} then {}",
                w[0].kp_max,
                w[1].kp_max
            );
        }
        // each step's gain is never above the nominal one, and lowering c12 alone does not
        // reach the robust gain: b and β decide as well
        assert!(d.steps[0].kp_max <= d.kp_max_nominal);
        assert!(d.steps.iter().all(|s| s.kp_max > d.kp_max));
        assert_eq!(d.loop_answer, None);
        // the figure's curves: the deciding parameter point over the stroke, one per
        // pressure and mass, the least GM on it the worst case's
        assert_eq!(d.stroke_curves.len(), 1);
        let least = d.stroke_curves[0]
            .gain_margin_db
            .iter()
            .map(|g| g.unwrap())
            .fold(f64::INFINITY, f64::min);
        assert!((least - d.worst_case.gain_margin_db.value.unwrap()).abs() < 1e-9);
    }

    /// A region of one point with one position and the rig's own pressure is the nominal
    /// design: the same gain as the search of `kp_max`, with the phase or gain margin on
    /// its target.
    #[test]
    fn zero_width_region_gives_the_nominal_gain() {
        let rig = Rig::default();
        let mut t = targets();
        t.stroke_mm = 0.0;
        let region = Region::point(Region::stated_default(&rig).nominal, None);
        let opts = RobustOptions {
            grid: 2,
            positions: 1,
            loop_steps: 1,
            ..RobustOptions::default()
        };
        let d = robust_design(&rig, &region, &t, &opts).unwrap();
        assert_eq!(d.worst_case.points, 2); // the corner and the estimate, the same point
        let reference = kp_max(&rig, &t).unwrap();
        assert!(
            (d.kp_max / reference - 1.0).abs() < 1e-12,
            "{} {reference}",
            d.kp_max
        );
        let m = margins_at(
            &Rig {
                kp: d.kp_max,
                ..rig
            },
            d.kp_max,
            false,
        )
        .unwrap();
        let on_pm = (m.phase_margin_deg.unwrap() - 34.0).abs() < 0.01;
        let on_gm = (m.gain_margin_db.unwrap() - 6.0).abs() < 0.001;
        assert!(on_pm || on_gm, "{m:?}");
        assert_eq!(d.steps.len(), 1);
        assert!((d.steps[0].kp_max / reference - 1.0).abs() < 1e-9);
    }

    /// The worst case found on the box's vertices and 3 stroke positions equals the worst
    /// case of a fine grid (5 values per axis, 9 positions) at the same gain: the margins are
    /// monotone in β, b and c12 over the box and least at a stroke end or x0
    /// (docs/design.md#why-the-search-covers-the-worst-case). With one mass over the stroke
    /// the delay margin agrees too; with the mass following the stroke (the article's seesaw)
    /// it can be least between the sampled positions, by well under 1 %.
    #[test]
    fn sampled_worst_case_equals_a_fine_grid() {
        let paired = Rig::default();
        let constant = Rig {
            mass_by_position: vec![],
            ..Rig::default()
        };
        for (rig, delay_tolerance) in [(&paired, 0.01), (&constant, 1e-9)] {
            let t = targets();
            let region = Region::stated_default(rig);
            let at = |n: usize, positions: usize| {
                points(
                    rig,
                    &region,
                    &region.samples(n),
                    &t,
                    &self::positions(rig, 50.0, positions),
                )
                .unwrap()
            };
            let (coarse, fine) = (at(2, 3), at(5, 9));
            let (kp, _) = robust_kp(rig, &coarse, &t, KP_CEILING).unwrap();
            assert_eq!(fine.len(), (125 + 1) * 9);
            let (wc, wf) = (
                worst_case(rig, &coarse, &t, kp).unwrap(),
                worst_case(rig, &fine, &t, kp).unwrap(),
            );
            let v = |w: &Worst| w.value.unwrap();
            assert!((v(&wc.gain_margin_db) - v(&wf.gain_margin_db)).abs() < 1e-9);
            assert!((v(&wc.phase_margin_deg) - v(&wf.phase_margin_deg)).abs() < 1e-6);
            let dm = (v(&wc.delay_margin_s), v(&wf.delay_margin_s));
            assert!(
                dm.1 <= dm.0 && dm.0 - dm.1 <= delay_tolerance * dm.0,
                "{dm:?}"
            );
            assert!(wf.meets_targets);
        }
    }

    /// Lower mean pressure softens β_e (docs/bulk-modulus.md): over 2, 4.4 and 10 bar the
    /// deciding condition is at 2 bar, with β_e from the gas fraction of the estimate.
    #[test]
    fn the_lowest_pressure_decides() {
        let rig = Rig::default();
        let mut t = targets();
        t.p_mean_bar = vec![2.0, 4.4, 10.0];
        let region = Region::point(Region::stated_default(&rig).nominal, None);
        let opts = RobustOptions {
            grid: 2,
            positions: 3,
            loop_steps: 2,
            ..RobustOptions::default()
        };
        let d = robust_design(&rig, &region, &t, &opts).unwrap();
        assert_eq!(d.deciding.at.p_mean_bar, Some(2.0));
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        let beta_e = effective_beta(x, 2.0, BETA_OIL_BAR);
        assert!((d.deciding.at.beta_e_bar - beta_e).abs() < 1e-9);
        assert!(beta_e < 100.0, "{beta_e}");
        assert!(
            d.kp_max < 0.6 * d.kp_max_nominal,
            "{} {}",
            d.kp_max,
            d.kp_max_nominal
        );
        assert_eq!(d.stroke_curves.len(), 3);
    }

    #[test]
    fn bad_regions_and_sizes_are_named() {
        let rig = Rig::default();
        let mut region = Region::stated_default(&rig);
        region.beta_bar = [170.0, 200.0];
        let e = robust_design(&rig, &region, &targets(), &RobustOptions::default()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "region beta_bar [170, 200] must be finite, > 0 and hold the estimate 165"
        );
        let opts = RobustOptions {
            grid: 10,
            ..RobustOptions::default()
        };
        let e = robust_design(&rig, &Region::stated_default(&rig), &targets(), &opts).unwrap_err();
        assert_eq!(
            e.to_string(),
            "robust design grid = 10: must lie in 1 ..= 9"
        );
    }
}
