//! β_e identified at several pressure levels, and the family of models fitted to them
//! (docs/bulk-modulus.md#several-pressure-levels).
//!
//! One identification reads β_e at one mean chamber pressure; every model of the family passes
//! through it ([`super::BulkModel::fit`]). Two or more levels test the models: each is fitted
//! to all of them by weighted least squares in ln β (its one parameter, the gas fraction X),
//! its misfit χ² = Σ ((ln β_i − ln β(p_i; X)) / σ_i)² read against the χ² distribution with
//! L − 1 degrees of freedom (L levels), and compared by Akaike's information criterion (with
//! one parameter each, AIC = χ² + 2; Burnham & Anderson, *Model Selection and Multimodel
//! Inference*, 2nd ed., 2002, §2.2 and §2.9). Each level's term is its own profile likelihood
//! of β at the model's β (the identification's ΔSSE/σ² statistic, its signed root interpolated
//! linearly in ln β and extended along its end slopes: the root is nearly linear in the
//! parameter), so a level whose β is bounded on one side only weighs as little as it should;
//! without a profile, the interval read as a normal one in ln β on each side of the estimate. The records *tell the model* when every other model's misfit is significant at
//! the confidence level; otherwise they cannot tell the remaining ones apart. The β(p) band
//! holds both uncertainties: each plausible model's X interval (Δχ² ≤ χ²₁(P)), and the models
//! themselves (the band is the union over the plausible models).

use super::{BulkError, BulkModel, FAMILY};
use serde::Serialize;

/// Most levels a fit takes (each one identification).
pub const MAX_LEVELS: usize = 20;

/// Points of the scan of ln X that brackets each model's best gas fraction.
const SCAN_POINTS: usize = 241;

/// Golden-section steps refining a bracket (its width shrinks 0.618× a step).
const GOLDEN_STEPS: usize = 80;

/// Bisection steps of an interval end.
const BISECTION_STEPS: usize = 80;

/// The smallest and largest gas fraction considered.
const X_RANGE: [f64; 2] = [1e-9, 0.999];

/// β_e identified at one pressure level.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Level {
    /// The records' mean chamber pressure (bar gauge).
    pub p_mean_bar: f64,
    /// The identified β_e (bar).
    pub beta_bar: f64,
    /// Its interval at the confidence level (bar).
    pub interval_bar: [f64; 2],
    /// Its profile likelihood where the identification gives one: (β bar, ΔSSE/σ² statistic)
    /// by increasing β; empty: the interval read as a normal one in ln β.
    #[serde(skip)]
    pub profile: Vec<[f64; 2]>,
}

/// One model fitted to the levels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModelFit {
    /// The model.
    pub model: BulkModel,
    /// The best gas fraction.
    pub gas_fraction: f64,
    /// Its interval: Δχ² ≤ χ²₁(P).
    pub gas_fraction_interval: [f64; 2],
    /// The misfit χ² at the best gas fraction.
    pub chi2: f64,
    /// Akaike's criterion, χ² + 2 (one parameter; the constant of the likelihood dropped).
    pub aic: f64,
    /// AIC minus the least AIC of the family.
    pub delta_aic: f64,
    /// The Akaike weight exp(−ΔAIC/2) normalised over the family.
    pub akaike_weight: f64,
    /// The probability of a misfit at least this large were the model true: χ² against the
    /// χ² distribution with L − 1 degrees of freedom; `None` with one level.
    pub p_value: Option<f64>,
    /// Whether the records leave the model standing: `p_value` at least 1 − P.
    pub plausible: bool,
}

/// The band of β_e at one pressure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BandPoint {
    /// Mean chamber pressure (bar gauge).
    pub p_bar: f64,
    /// β_e of the best model (least AIC) at its best gas fraction (bar).
    pub beta_bar: f64,
    /// The lowest and highest β_e of the plausible models over their gas-fraction intervals (bar).
    pub band_bar: [f64; 2],
    /// The band of the best model alone, its parameter uncertainty (bar).
    pub best_model_band_bar: [f64; 2],
}

/// The next level to record, to tell the plausible models apart.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NextLevel {
    /// Mean chamber pressure (bar gauge).
    pub p_mean_bar: f64,
    /// The two plausible models that differ least there, the pair it separates.
    pub models: [BulkModel; 2],
    /// Their β_e there (bar).
    pub beta_bar: [f64; 2],
    /// The χ² by which a record there would separate them, its σ of ln β extrapolated from
    /// the levels' own against their β.
    pub expected_chi2: f64,
}

/// The family fitted to the levels.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LevelsFit {
    /// The levels, pressure rising.
    pub levels: Vec<Level>,
    /// The confidence level of the intervals and tests.
    pub confidence: f64,
    /// Each model of the candidates, least AIC first.
    pub fits: Vec<ModelFit>,
    /// The model the records tell, where every other is implausible.
    pub model: Option<BulkModel>,
    /// The band of β_e at the pressures asked.
    pub band: Vec<BandPoint>,
    /// Where to record next, while more than one model stands.
    pub next_level: Option<NextLevel>,
}

/// Where the next level is looked for: the mean pressures (bar) to try, and whether a β is
/// usable for a record (the rig's loop stable with it, at the records' gain).
pub struct NextSearch<'a> {
    /// The mean chamber pressures tried (bar gauge).
    pub from_bar: &'a [f64],
    /// Whether records can be taken with this β (bar).
    pub usable: &'a dyn Fn(f64) -> bool,
}

impl<'a> NextSearch<'a> {
    /// Every pressure of `from_bar`, every β usable.
    pub fn any(from_bar: &'a [f64]) -> NextSearch<'a> {
        NextSearch {
            from_bar,
            usable: &|_| true,
        }
    }
}

/// The models fitted to several levels: [`FAMILY`], the adiabatic entrained air (n = 1.4) and
/// `own` (a rig's model) where it is none of them.
pub fn candidates(own: BulkModel) -> Vec<BulkModel> {
    let mut out = FAMILY.to_vec();
    out.push(BulkModel::EntrainedAir {
        polytropic_index: 1.4,
    });
    if !out.contains(&own) {
        out.push(own);
    }
    out
}

/// One level's σ of ln β below and above its estimate: its interval read as a normal one at
/// `confidence` on each side.
fn sigma_ln(level: &Level, confidence: f64) -> [f64; 2] {
    let z = normal_quantile(0.5 + 0.5 * confidence);
    let [lo, hi] = level.interval_bar;
    let b = level.beta_bar;
    [((b / lo).ln() / z).max(1e-6), ((hi / b).ln() / z).max(1e-6)]
}

/// The level's statistic (χ²-like) at β `beta`: its profile's where it has one, else its
/// two-sided normal reading.
fn level_chi2(level: &Level, sigma: [f64; 2], beta: f64) -> f64 {
    let u = beta.ln();
    if level.profile.len() < 2 {
        let d = u - level.beta_bar.ln();
        return (d / if d < 0.0 { sigma[0] } else { sigma[1] }).powi(2);
    }
    // the signed root against ln β, linear between points and along the end segments
    let centre = level.beta_bar.ln();
    let root = |[b, stat]: [f64; 2]| (b.ln(), stat.max(0.0).sqrt() * (b.ln() - centre).signum());
    let pts: Vec<(f64, f64)> = level.profile.iter().map(|p| root(*p)).collect();
    let k = pts.partition_point(|p| p.0 < u).clamp(1, pts.len() - 1);
    let ((u0, r0), (u1, r1)) = (pts[k - 1], pts[k]);
    let r = if u1 > u0 {
        r0 + (r1 - r0) * (u - u0) / (u1 - u0)
    } else {
        r0
    };
    r * r
}

/// Check the levels: finite, positive, each interval holding its estimate, at most
/// [`MAX_LEVELS`], pressures distinct.
fn check(levels: &[Level], confidence: f64) -> Result<(), BulkError> {
    let bad = |m: String| Err(BulkError::Input(m));
    if levels.is_empty() || levels.len() > MAX_LEVELS {
        return bad(format!(
            "{} pressure levels: give 1 to {MAX_LEVELS}",
            levels.len()
        ));
    }
    if !(confidence > 0.0 && confidence < 1.0) {
        return bad(format!("confidence {confidence}: must lie in (0, 1)"));
    }
    for l in levels {
        let [lo, hi] = l.interval_bar;
        let finite = [l.p_mean_bar, l.beta_bar, lo, hi]
            .iter()
            .all(|v| v.is_finite());
        if !(finite && l.p_mean_bar > 0.0 && 0.0 < lo && lo <= l.beta_bar && l.beta_bar <= hi) {
            return bad(format!(
                "the level at {} bar: beta {} bar with interval [{lo}, {hi}] bar must be positive, finite and hold its estimate",
                l.p_mean_bar, l.beta_bar
            ));
        }
    }
    let mut p: Vec<f64> = levels.iter().map(|l| l.p_mean_bar).collect();
    p.sort_by(f64::total_cmp);
    if p.windows(2).any(|w| w[1] - w[0] < 1e-6 * w[1]) {
        return bad("two levels at the same mean chamber pressure: merge their records".into());
    }
    Ok(())
}

/// χ² of `model` with gas fraction `x` on the levels.
fn chi2(model: BulkModel, x: f64, levels: &[Level], sigma: &[[f64; 2]], oil: f64) -> f64 {
    levels
        .iter()
        .zip(sigma)
        .map(|(l, s)| level_chi2(l, *s, model.beta_bar(x, l.p_mean_bar, oil)))
        .sum()
}

/// The gas fraction of least χ²: a scan of ln X over [`X_RANGE`], then golden section between
/// the best point's neighbours.
fn best_x(f: &dyn Fn(f64) -> f64) -> f64 {
    let [lo, hi] = X_RANGE.map(f64::ln);
    let at = |i: usize| lo + (hi - lo) * i as f64 / (SCAN_POINTS - 1) as f64;
    let g = |u: f64| {
        let v = f(u.exp());
        if v.is_finite() {
            v
        } else {
            f64::INFINITY
        }
    };
    let i = (0..SCAN_POINTS)
        .min_by(|&a, &b| g(at(a)).total_cmp(&g(at(b))))
        .unwrap_or(0);
    let (mut a, mut b) = (at(i.saturating_sub(1)), at((i + 1).min(SCAN_POINTS - 1)));
    let r = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..GOLDEN_STEPS {
        let (c, d) = (b - r * (b - a), a + r * (b - a));
        if g(c) < g(d) {
            b = d;
        } else {
            a = c;
        }
    }
    (0.5 * (a + b)).exp()
}

/// Where χ² rises `threshold` above its least value at `x`, towards `end`: bisection in ln X;
/// `end` itself where it never does.
fn interval_end(f: &dyn Fn(f64) -> f64, x: f64, end: f64, threshold: f64) -> f64 {
    let least = f(x);
    let above = |u: f64| {
        let v = f(u.exp());
        !v.is_finite() || v - least > threshold
    };
    let (mut inside, mut outside) = (x.ln(), end.ln());
    if !above(outside) {
        return end;
    }
    for _ in 0..BISECTION_STEPS {
        let mid = 0.5 * (inside + outside);
        if above(mid) {
            outside = mid;
        } else {
            inside = mid;
        }
    }
    (0.5 * (inside + outside)).exp()
}

/// The standard normal quantile at `p` in (0, 1).
fn normal_quantile(p: f64) -> f64 {
    std::f64::consts::SQRT_2 * statrs::function::erf::erf_inv(2.0 * p - 1.0)
}

/// The probability that a χ² variable with `dof` degrees of freedom exceeds `chi2`.
fn chi2_survival(chi2: f64, dof: usize) -> f64 {
    statrs::function::gamma::gamma_ur(0.5 * dof as f64, 0.5 * chi2.max(1e-300))
}

/// Fit `model` to the levels.
fn fit_one(
    model: BulkModel,
    levels: &[Level],
    sigma: &[[f64; 2]],
    oil: f64,
    confidence: f64,
) -> ModelFit {
    let f = |x: f64| chi2(model, x, levels, sigma, oil);
    let x = best_x(&f);
    let threshold = normal_quantile(0.5 + 0.5 * confidence).powi(2);
    let interval = [
        interval_end(&f, x, X_RANGE[0], threshold),
        interval_end(&f, x, X_RANGE[1], threshold),
    ];
    let c = f(x);
    let p_value = (levels.len() > 1).then(|| chi2_survival(c, levels.len() - 1));
    ModelFit {
        model,
        gas_fraction: x,
        gas_fraction_interval: interval,
        chi2: c,
        aic: c + 2.0,
        delta_aic: 0.0,
        akaike_weight: 0.0,
        p_value,
        plausible: p_value.is_none_or(|p| p >= 1.0 - confidence),
    }
}

/// The lowest and highest β_e of `fit` over its gas-fraction interval at `p_bar` (β falls as X
/// rises).
fn model_band(fit: &ModelFit, p_bar: f64, oil: f64) -> [f64; 2] {
    let [x_lo, x_hi] = fit.gas_fraction_interval;
    let b = |x: f64| fit.model.beta_bar(x, p_bar, oil);
    let (a, c) = (b(x_hi), b(x_lo));
    [a.min(c), a.max(c)]
}

/// Fit every model of `models` to `levels` (intervals at `confidence`), with the oil's
/// `beta_oil_bar`; the band at `band_at_bar`; the next level as `next` searches it.
///
/// # Errors
/// Levels that are not positive and finite, an interval that does not hold its estimate, two
/// levels at one pressure, none or more than [`MAX_LEVELS`].
pub fn fit_levels(
    levels: &[Level],
    models: &[BulkModel],
    beta_oil_bar: f64,
    confidence: f64,
    band_at_bar: &[f64],
    next: &NextSearch<'_>,
) -> Result<LevelsFit, BulkError> {
    check(levels, confidence)?;
    let mut levels = levels.to_vec();
    levels.sort_by(|a, b| a.p_mean_bar.total_cmp(&b.p_mean_bar));
    let sigma: Vec<[f64; 2]> = levels.iter().map(|l| sigma_ln(l, confidence)).collect();
    let mut fits = Vec::with_capacity(models.len());
    for m in models {
        m.check()?;
        fits.push(fit_one(*m, &levels, &sigma, beta_oil_bar, confidence));
    }
    weigh(&mut fits);
    let plausible: Vec<&ModelFit> = fits.iter().filter(|f| f.plausible).collect();
    let model = match plausible.as_slice() {
        [only] if levels.len() > 1 => Some(only.model),
        _ => None,
    };
    // the band spans the plausible models; where none stands, every model
    let spanned: Vec<&ModelFit> = match plausible.is_empty() {
        true => fits.iter().collect(),
        false => plausible.clone(),
    };
    let band = (band_at_bar.iter())
        .map(|&p| band_point(p, &fits[0], &spanned, beta_oil_bar))
        .collect();
    let trend = SigmaTrend::of(&levels, &sigma);
    let next_level = match model.is_none() && plausible.len() > 1 {
        true => next_level(&plausible, next, trend, beta_oil_bar),
        false => None,
    };
    Ok(LevelsFit {
        levels,
        confidence,
        fits,
        model,
        band,
        next_level,
    })
}

/// ΔAIC and the Akaike weights; the fits ordered least AIC first.
fn weigh(fits: &mut [ModelFit]) {
    fits.sort_by(|a, b| a.aic.total_cmp(&b.aic));
    let least = fits.first().map_or(0.0, |f| f.aic);
    let delta: Vec<f64> = fits.iter().map(|f| f.aic - least).collect();
    for ((f, d), w) in fits.iter_mut().zip(&delta).zip(akaike_weights(&delta)) {
        f.delta_aic = *d;
        f.akaike_weight = w;
    }
}

/// The Akaike weights exp(−ΔAIC/2) normalised over the models (Burnham & Anderson 2002, §2.9),
/// of each model's ΔAIC.
pub fn akaike_weights(delta_aic: &[f64]) -> Vec<f64> {
    let total: f64 = delta_aic.iter().map(|d| (-0.5 * d).exp()).sum();
    delta_aic.iter().map(|d| (-0.5 * d).exp() / total).collect()
}

/// The band at `p`: the best model's β and band, the union of `spanned`'s bands.
fn band_point(p: f64, best: &ModelFit, spanned: &[&ModelFit], oil: f64) -> BandPoint {
    let bands: Vec<[f64; 2]> = spanned.iter().map(|f| model_band(f, p, oil)).collect();
    BandPoint {
        p_bar: p,
        beta_bar: best.model.beta_bar(best.gas_fraction, p, oil),
        band_bar: [
            bands.iter().map(|b| b[0]).fold(f64::INFINITY, f64::min),
            bands.iter().map(|b| b[1]).fold(f64::NEG_INFINITY, f64::max),
        ],
        best_model_band_bar: model_band(best, p, oil),
    }
}

/// How sure a level is against its β: σ of ln β = e^a β^k, least squares in ln σ against
/// ln β over the levels (a stiffer loop at a higher β says less about it: k > 0 on records),
/// k within [0, 3], and never below the surest level's σ (no record is trusted to be surer
/// than any taken); one level, or levels at one β, a constant σ.
#[derive(Debug, Clone, Copy)]
struct SigmaTrend {
    a: f64,
    k: f64,
    floor: f64,
}

impl SigmaTrend {
    fn of(levels: &[Level], sigma: &[[f64; 2]]) -> SigmaTrend {
        let pts: Vec<(f64, f64)> = (levels.iter().zip(sigma))
            .map(|(l, s)| (l.beta_bar.ln(), (0.5 * (s[0] + s[1])).ln()))
            .collect();
        let n = pts.len() as f64;
        let (mx, my) = pts
            .iter()
            .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let k = if sxx > 1e-12 {
            (sxy / sxx).clamp(0.0, 3.0)
        } else {
            0.0
        };
        let floor = pts.iter().map(|p| p.1.exp()).fold(f64::INFINITY, f64::min);
        SigmaTrend {
            a: my - k * mx,
            k,
            floor,
        }
    }

    /// σ of ln β for a record whose β is `beta_bar`.
    fn at(&self, beta_bar: f64) -> f64 {
        (self.a + self.k * beta_bar.ln()).exp().max(self.floor)
    }
}

/// The pressure among `next`'s at which the closest pair of the plausible models is best
/// told apart: their difference in ln β over the σ a record there is expected to have
/// ([`SigmaTrend`]), the record that best separates what the records leave standing; only
/// where every plausible model's β there is usable.
fn next_level(
    plausible: &[&ModelFit],
    next: &NextSearch<'_>,
    trend: SigmaTrend,
    oil: f64,
) -> Option<NextLevel> {
    let ln_beta = |f: &ModelFit, p: f64| f.model.beta_bar(f.gas_fraction, p, oil).ln();
    let closest = |p: f64| {
        let mut best: Option<(f64, usize, usize)> = None;
        for i in 0..plausible.len() {
            for j in i + 1..plausible.len() {
                let (a, b) = (ln_beta(plausible[i], p), ln_beta(plausible[j], p));
                let z = (a - b).abs() / trend.at((0.5 * (a + b)).exp());
                if z.is_finite() && best.is_none_or(|c| z < c.0) {
                    best = Some((z, i, j));
                }
            }
        }
        best
    };
    let usable = |p: f64| {
        (plausible.iter()).all(|f| (next.usable)(f.model.beta_bar(f.gas_fraction, p, oil)))
    };
    let (p, (z, i, j)) = (next.from_bar.iter())
        .filter(|&&p| usable(p))
        .filter_map(|&p| closest(p).map(|c| (p, c)))
        .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))?;
    let beta = |f: &ModelFit| f.model.beta_bar(f.gas_fraction, p, oil);
    Some(NextLevel {
        p_mean_bar: p,
        models: [plausible[i].model, plausible[j].model],
        beta_bar: [beta(plausible[i]), beta(plausible[j])],
        expected_chi2: z * z,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bulk::BETA_OIL_BAR;

    /// Levels read exactly off a model, ±5 % intervals.
    fn levels_of(model: BulkModel, x: f64, pressures: &[f64], spread: f64) -> Vec<Level> {
        pressures
            .iter()
            .map(|&p| {
                let b = model.beta_bar(x, p, BETA_OIL_BAR);
                Level {
                    p_mean_bar: p,
                    beta_bar: b,
                    interval_bar: [b / (1.0 + spread), b * (1.0 + spread)],
                    profile: vec![],
                }
            })
            .collect()
    }

    /// Exact levels of the entrained air at 2, 5 and 10 bar: the fit finds it, its gas
    /// fraction to 1e-6 with an interval holding it, a misfit of nearly 0, every other model
    /// implausible; one level tells nothing.
    #[test]
    fn exact_levels_tell_their_model() {
        let truth = BulkModel::EntrainedAir {
            polytropic_index: 1.4,
        };
        let x = 0.12;
        let levels = levels_of(truth, x, &[2.0, 5.0, 10.0], 0.05);
        let fit = fit_levels(
            &levels,
            &candidates(truth),
            BETA_OIL_BAR,
            0.95,
            &[1.0],
            &NextSearch::any(&[1.0, 20.0]),
        )
        .unwrap();
        assert_eq!(fit.model, Some(truth), "{:#?}", fit.fits);
        let best = &fit.fits[0];
        assert!(
            (best.gas_fraction / x - 1.0).abs() < 1e-6,
            "{}",
            best.gas_fraction
        );
        let [lo, hi] = best.gas_fraction_interval;
        assert!(lo < x && x < hi);
        assert!(best.chi2 < 1e-9 && best.akaike_weight > 0.9);
        let truth_1bar = truth.beta_bar(x, 1.0, BETA_OIL_BAR);
        let [b_lo, b_hi] = fit.band[0].band_bar;
        assert!(b_lo < truth_1bar && truth_1bar < b_hi);
        let one = fit_levels(
            &levels[1..2],
            &candidates(truth),
            BETA_OIL_BAR,
            0.95,
            &[1.0],
            &NextSearch::any(&[]),
        )
        .unwrap();
        assert_eq!(one.model, None);
        assert!(one.fits.iter().all(|f| f.plausible && f.chi2 < 1e-12));
    }

    /// Wide intervals leave several models standing; the next level is where the closest pair
    /// parts most, and it parts them more than at the levels themselves.
    #[test]
    fn unsure_levels_say_so_and_advise_the_next() {
        let truth = BulkModel::ConstantGasFraction;
        let levels = levels_of(truth, 0.0264, &[4.0, 5.0], 0.5);
        let from: Vec<f64> = (1..=40).map(|i| 0.5 * i as f64).collect();
        let fit = fit_levels(
            &levels,
            &candidates(truth),
            BETA_OIL_BAR,
            0.95,
            &[1.0, 10.0],
            &NextSearch::any(&from),
        )
        .unwrap();
        assert_eq!(fit.model, None);
        assert!(fit.fits.iter().filter(|f| f.plausible).count() > 1);
        let next = fit.next_level.unwrap();
        assert!(next.p_mean_bar < 4.0 || next.p_mean_bar > 5.0, "{next:?}");
        // the band at 1 bar spans the models: wider than the best model's own
        let b = fit.band[0];
        assert!(
            b.band_bar[0] <= b.best_model_band_bar[0] && b.band_bar[1] >= b.best_model_band_bar[1]
        );
    }

    /// The χ² survival function against tables (Abramowitz & Stegun, Table 26.8).
    #[test]
    fn chi2_survival_matches_tables() {
        for (x, dof, p) in [
            (3.841_458_820_694_124, 1, 0.05),
            (5.991_464_547_107_979, 2, 0.05),
            (7.814_727_903_251_178, 3, 0.05),
        ] {
            assert!((chi2_survival(x, dof) - p).abs() < 1e-9, "{x} {dof}");
        }
    }

    #[test]
    fn bad_levels_are_refused() {
        let l = Level {
            p_mean_bar: 4.4,
            beta_bar: 165.0,
            interval_bar: [170.0, 180.0],
            profile: vec![],
        };
        assert!(fit_levels(
            std::slice::from_ref(&l),
            &FAMILY,
            BETA_OIL_BAR,
            0.95,
            &[],
            &NextSearch::any(&[])
        )
        .is_err());
        let ok = Level {
            interval_bar: [150.0, 180.0],
            ..l.clone()
        };
        assert!(fit_levels(
            &[ok.clone(), ok],
            &FAMILY,
            BETA_OIL_BAR,
            0.95,
            &[],
            &NextSearch::any(&[])
        )
        .is_err());
        assert!(fit_levels(&[], &FAMILY, BETA_OIL_BAR, 0.95, &[], &NextSearch::any(&[])).is_err());
    }
}
