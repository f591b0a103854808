//! Candidate grids of the two-stage search (docs/identification.md#the-two-grids).

use crate::source_files::FieldError;
use serde::{Deserialize, Serialize};

/// A candidate parameter set of the grid search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Effective bulk modulus (bar).
    pub beta_bar: f64,
    /// Viscous friction (N·s/m).
    pub viscous_friction_ns_per_m: f64,
    /// Cross-port leakage (m⁵/(N·s)); c1, c2 follow from the standstill record.
    pub c12_m5_per_ns: f64,
}

/// The rig keys of the three axes, in the order (β, b, c12).
const AXES: [&str; 3] = ["beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"];

/// A first grid's values per axis and how far it reaches each side of its centre (a factor):
/// β 16 values over ÷8 … ×8, b 12 over ÷8 … ×8, c12 17 over ÷100 … ×100, all log-spaced. The
/// counts are the article's first grid's (§2.4); the spans cover what a rig file's values
/// may be off by: an effective β an order of magnitude below the oil's (docs/bulk-modulus.md),
/// friction and cross-port leakage known to a decade or two.
pub const FIRST_AXES: [(usize, f64); 3] = [(16, 8.0), (12, 8.0), (17, 100.0)];

/// The values per axis of a stage centred on the previous stage's best: the article's refined
/// grid's counts (19 β, 11 b, 17 c12; §2.4), odd so the best is the middle value.
pub const SECOND_COUNTS: [usize; 3] = [19, 11, 17];

/// A grid value in four significant digits, as messages show it: `37.5`, `2400`, `1.2e-10`.
pub fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    if (1e-3..1e6).contains(&v.abs()) {
        let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.3e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = if m.contains('.') {
            m.trim_end_matches('0').trim_end_matches('.')
        } else {
            m
        };
        format!("{m}e{e}")
    }
}

/// The values of a candidate in the order (β, b, c12).
pub fn candidate_values(c: &Candidate) -> [f64; 3] {
    [c.beta_bar, c.viscous_friction_ns_per_m, c.c12_m5_per_ns]
}

/// A full-factorial grid β × b × c12.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// Bulk modulus values (bar).
    pub beta_bar: Vec<f64>,
    /// Friction values (N·s/m).
    pub viscous_friction_ns_per_m: Vec<f64>,
    /// Cross-port leakage values (m⁵/(N·s)).
    pub c12_m5_per_ns: Vec<f64>,
}

/// The grid of the second stage of a search.
#[derive(Debug, Clone, PartialEq)]
pub enum SecondGrid {
    /// A grid given in advance (the experiment's `refined_grid`, or the article's).
    Given(Grid),
    /// Centred on the first stage's best ([`Grid::around`]): known only once the first stage
    /// has run.
    Centred,
}

impl SecondGrid {
    /// The candidates of a grid derived after the first stage ([`Grid::around`],
    /// [`Grid::refined_from`]).
    pub fn centred_len() -> usize {
        SECOND_COUNTS.iter().product()
    }
}

impl From<Grid> for SecondGrid {
    fn from(g: Grid) -> Self {
        SecondGrid::Given(g)
    }
}

/// `count` values from `from` to `to`, evenly spaced (in log space when `log`).
pub fn spaced(from: f64, to: f64, count: usize, log: bool) -> Vec<f64> {
    if count == 1 {
        return vec![from];
    }
    let (a, b) = if log {
        (from.ln(), to.ln())
    } else {
        (from, to)
    };
    (0..count)
        .map(|i| {
            let v = a + (b - a) * i as f64 / (count - 1) as f64;
            if log {
                v.exp()
            } else {
                v
            }
        })
        .collect()
}

/// `from`, `from + step`, … up to `to` inclusive (rounded to the step's grid).
pub fn stepped(from: f64, to: f64, step: f64) -> Vec<f64> {
    let n = ((to - from) / step + 1e-9).floor() as usize;
    (0..=n).map(|i| from + step * i as f64).collect()
}

impl Grid {
    /// The article's first grid: 16 β × 12 b × 17 c12 = 3264 candidates (docs/identification.md#the-two-grids).
    pub fn article_first() -> Grid {
        let mut beta = stepped(25.0, 250.0, 25.0);
        beta.push(300.0);
        beta.extend(stepped(400.0, 600.0, 100.0));
        beta.extend([800.0, 1000.0]);
        let mut b = stepped(50.0, 250.0, 25.0);
        b.extend([300.0, 400.0, 500.0]);
        Grid {
            beta_bar: beta,
            viscous_friction_ns_per_m: b,
            c12_m5_per_ns: spaced(1e-13, 1e-9, 17, true),
        }
    }

    /// The article's refined grid: 19 β × 11 b × 17 c12 = 3553 candidates (docs/identification.md#the-two-grids).
    pub fn article_refined() -> Grid {
        Grid {
            beta_bar: stepped(130.0, 220.0, 5.0),
            viscous_friction_ns_per_m: stepped(100.0, 600.0, 50.0),
            c12_m5_per_ns: spaced(0.8e-10, 2.4e-10, 17, false),
        }
    }

    /// The first grid centred on `centre` (a rig's β, b, c12, or the middle of the
    /// experiment's ranges): per axis [`FIRST_AXES`] log-spaced values from centre/factor to
    /// centre·factor (docs/identification.md#the-two-grids). The error names the axis whose
    /// centre is not a positive number.
    pub fn centred(centre: &Candidate) -> Result<Grid, FieldError> {
        let values = candidate_values(centre);
        let mut ranges = [[0.0; 2]; 3];
        for (k, (_, factor)) in FIRST_AXES.into_iter().enumerate() {
            let c = values[k];
            if !(c.is_finite() && c > 0.0) {
                return Err(FieldError::new(
                    AXES[k],
                    format!(
                        "{} = {c}: a grid is centred on the rig's value, which must be > 0; \
                         give [ranges] {} = [lo, hi] or a [grid]",
                        AXES[k], AXES[k]
                    ),
                ));
            }
            ranges[k] = [c / factor, c * factor];
        }
        Ok(Grid::over(&ranges))
    }

    /// The first grid over ranges [lo, hi] per axis (the experiment's `[ranges]`): the counts
    /// of [`FIRST_AXES`], log-spaced.
    pub fn over(ranges: &[[f64; 2]; 3]) -> Grid {
        let axes = ranges
            .iter()
            .zip(FIRST_AXES)
            .map(|(&[lo, hi], (count, _))| {
                // the ends exactly as given (exp(ln x) may differ in the last bit)
                let mut axis = spaced(lo, hi, count, true);
                if let [first, .., last] = axis.as_mut_slice() {
                    (*first, *last) = (lo, hi);
                }
                axis
            })
            .collect();
        Grid::of_axes(axes)
    }

    /// The next stage's grid centred on `best`, a point of the stage grid `parent`: per axis
    /// the counts of [`SECOND_COUNTS`], log-spaced from best/r to best·r so that `best` is its
    /// middle value, r the larger ratio of `best` to its neighbours on the parent's axis (one
    /// neighbour when `best` lies on the axis's edge: the grid then reaches beyond the parent
    /// by that step). An axis of one value stays that value.
    pub fn around(parent: &Grid, best: &Candidate) -> Grid {
        let values = candidate_values(best);
        let axes = parent
            .axes()
            .into_iter()
            .zip(values)
            .zip(SECOND_COUNTS)
            .map(|(((_, axis), b), count)| {
                let below = axis
                    .iter()
                    .copied()
                    .filter(|v| *v < b)
                    .max_by(f64::total_cmp);
                let above = axis
                    .iter()
                    .copied()
                    .filter(|v| *v > b)
                    .min_by(f64::total_cmp);
                let ratio = [below.map(|v| b / v), above.map(|v| v / b)]
                    .into_iter()
                    .flatten()
                    .filter(|r| r.is_finite())
                    .fold(1.0, f64::max);
                if ratio <= 1.0 || b <= 0.0 {
                    vec![b]
                } else {
                    spaced(b / ratio, b * ratio, count, true)
                }
            })
            .collect();
        Grid::of_axes(axes)
    }

    /// Whether axis `axis` (0 β, 1 b, 2 c12) has values both below and above `value`.
    pub fn straddles(&self, axis: usize, value: f64) -> bool {
        let v = self.axes()[axis].1;
        v.iter().any(|x| *x < value) && v.iter().any(|x| *x > value)
    }

    /// A grid of three axes (β, b, c12).
    fn of_axes(mut axes: Vec<Vec<f64>>) -> Grid {
        let c12_m5_per_ns = axes.pop().unwrap_or_default();
        let viscous_friction_ns_per_m = axes.pop().unwrap_or_default();
        Grid {
            beta_bar: axes.pop().unwrap_or_default(),
            viscous_friction_ns_per_m,
            c12_m5_per_ns,
        }
    }

    /// For each axis, its range (lo, hi) when `c` lies on its lowest or highest value and
    /// the axis has more than one value (the optimum may lie beyond it), else `None`.
    pub fn edges_at(&self, c: &Candidate) -> [Option<(f64, f64)>; 3] {
        let values = candidate_values(c);
        let axes = self.axes();
        std::array::from_fn(|k| {
            let axis = axes[k].1;
            let (lo, hi) = axis
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                    (l.min(x), h.max(x))
                });
            (axis.len() > 1 && (values[k] == lo || values[k] == hi)).then_some((lo, hi))
        })
    }

    /// Number of candidates.
    pub fn len(&self) -> usize {
        self.beta_bar
            .len()
            .saturating_mul(self.viscous_friction_ns_per_m.len())
            .saturating_mul(self.c12_m5_per_ns.len())
    }

    /// Whether the grid has no candidate.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The candidate at a flat index (c12 fastest, then b, then β).
    pub fn candidate(&self, index: usize) -> Candidate {
        let (nb, nc) = (
            self.viscous_friction_ns_per_m.len(),
            self.c12_m5_per_ns.len(),
        );
        Candidate {
            beta_bar: self.beta_bar[index / (nb * nc)],
            viscous_friction_ns_per_m: self.viscous_friction_ns_per_m[index / nc % nb],
            c12_m5_per_ns: self.c12_m5_per_ns[index % nc],
        }
    }

    /// Check every axis is non-empty with finite positive values.
    /// The error names the axis (`beta_bar`, ...) and says what is wrong with it.
    pub fn validate(&self, name: &str) -> Result<(), FieldError> {
        for (axis, v) in self.axes() {
            if v.is_empty() {
                return Err(FieldError::new(
                    axis,
                    format!("{name}.{axis}: needs at least one value"),
                ));
            }
            if let Some(x) = v.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                return Err(FieldError::new(
                    axis,
                    format!("{name}.{axis}: {x} is not a finite value >= 0"),
                ));
            }
        }
        if self.beta_bar.contains(&0.0) {
            return Err(FieldError::new(
                "beta_bar",
                format!("{name}.beta_bar: the bulk modulus must be > 0"),
            ));
        }
        for (axis, v) in self.axes() {
            for &x in v {
                if let Some(rule) = crate::rig::Rig::check_key(axis, x) {
                    let x = crate::units::readable(x);
                    return Err(FieldError::new(axis, format!("{name}.{axis}: {x}: {rule}")));
                }
            }
        }
        Ok(())
    }

    /// The three axes with their rig key names.
    fn axes(&self) -> [(&'static str, &Vec<f64>); 3] {
        [
            (AXES[0], &self.beta_bar),
            (AXES[1], &self.viscous_friction_ns_per_m),
            (AXES[2], &self.c12_m5_per_ns),
        ]
    }

    /// The refined grid derived from the bounds [lo, hi] of β, b and c12 over a set of good
    /// candidates (`--auto-refine`): each axis spans the set's range widened to the neighbouring
    /// values of `parent`, with the article's refined counts (19, 11, 17); an axis stays
    /// logarithmic if the parent's is.
    pub fn refined_from(parent: &Grid, bounds: &[[f64; 2]; 3]) -> Grid {
        let axis = |values: &[f64], [lo, hi]: [f64; 2], count: usize| -> Vec<f64> {
            let below = values
                .iter()
                .copied()
                .filter(|v| *v < lo)
                .max_by(f64::total_cmp)
                .unwrap_or(lo);
            let above = values
                .iter()
                .copied()
                .filter(|v| *v > hi)
                .min_by(f64::total_cmp)
                .unwrap_or(hi);
            let log = values.len() > 2 && is_log_spaced(values);
            spaced(below, above, count, log)
        };
        Grid {
            beta_bar: axis(&parent.beta_bar, bounds[0], SECOND_COUNTS[0]),
            viscous_friction_ns_per_m: axis(
                &parent.viscous_friction_ns_per_m,
                bounds[1],
                SECOND_COUNTS[1],
            ),
            c12_m5_per_ns: axis(&parent.c12_m5_per_ns, bounds[2], SECOND_COUNTS[2]),
        }
    }
}

/// Whether positive values have a constant ratio (log spacing) rather than a constant step.
fn is_log_spaced(v: &[f64]) -> bool {
    v.iter().all(|x| *x > 0.0) && {
        let r0 = v[1] / v[0];
        let d0 = v[1] - v[0];
        let ratio_err = v
            .windows(2)
            .map(|w| (w[1] / w[0] / r0 - 1.0).abs())
            .fold(0.0, f64::max);
        let step_err = v
            .windows(2)
            .map(|w| ((w[1] - w[0]) / d0 - 1.0).abs())
            .fold(0.0, f64::max);
        ratio_err < step_err
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn article_grid_sizes() {
        let first = Grid::article_first();
        assert_eq!(first.beta_bar.len(), 16);
        assert_eq!(first.viscous_friction_ns_per_m.len(), 12);
        assert_eq!(first.len(), 3264);
        assert_eq!(Grid::article_refined().len(), 3553);
        assert_eq!(*first.beta_bar.last().unwrap(), 1000.0);
        assert!((first.c12_m5_per_ns[8] / 1e-11 - 1.0).abs() < 1e-12);
        let r = Grid::article_refined();
        assert!((r.c12_m5_per_ns[4] - 1.2e-10).abs() < 1e-22);
    }

    #[test]
    fn flat_index_enumerates_every_candidate_once() {
        let g = Grid::article_first();
        let mut seen = std::collections::HashSet::new();
        for i in 0..g.len() {
            let c = g.candidate(i);
            seen.insert((
                c.beta_bar.to_bits(),
                c.viscous_friction_ns_per_m.to_bits(),
                c.c12_m5_per_ns.to_bits(),
            ));
        }
        assert_eq!(seen.len(), g.len());
    }
}
