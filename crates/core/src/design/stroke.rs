//! The worst case over the stroke, searched rather than sampled (docs/design.md#the-worst-case-searched).
//!
//! The article checks three stroke positions, x0 and x0 ± 50 mm (§3.3); the smallest margin may
//! lie between them, where the chamber volumes, the mass that follows the stroke (its
//! `mass_by_position` table, linear between the points) and the loop's resonance meet. For one
//! load, pressure and linear model the phase and gain margins at the designed gain are functions
//! of the position x alone, continuous but kinked at the table's points. The search samples
//! them at [`SCAN_POINTS`] evenly spaced positions and at every table point inside the range,
//! brackets the smallest sample between its neighbours, and closes the bracket by golden
//! section to [`X_TOLERANCE_MM`] — a bounded number of margin analyses,
//! [`SEARCH_ANALYSES`] at most.

use super::{margins_in, DesignError, Targets};
use crate::lti::Margins;
use crate::rig::Rig;
use serde::Serialize;

/// Evenly spaced positions of the first pass (the range's ends included).
pub const SCAN_POINTS: usize = 41;
/// Width (mm) to which golden section closes a bracket.
pub const X_TOLERANCE_MM: f64 = 0.001;
/// Golden-section steps at most: a bracket of two scan intervals (at most 2/40 of a range of at
/// most 10⁴ mm, 500 mm) shrinks by 0.618 per step, below 0.001 mm in 28.
const GOLDEN_STEPS: usize = 40;
/// Margin analyses one search takes at most, besides one for each point of the mass table
/// inside the range: the scan and two golden-section refinements.
pub const SEARCH_ANALYSES: f64 = (SCAN_POINTS + 2 * (GOLDEN_STEPS + 2)) as f64;

/// Which margin a searched position is the worst of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Searched {
    /// The position of the smallest phase margin.
    PhaseMargin,
    /// The position of the smallest gain margin.
    GainMargin,
}

/// The rig at one position of the search, and the mode and gain its margins are read with.
pub struct Line<'a> {
    /// The rig at a position (mm): the operating point moved there, the mass following it.
    pub at: &'a dyn Fn(f64) -> Result<Rig, DesignError>,
    /// The linear model ([`crate::circuit::AnyCircuit::linear_modes`]).
    pub mode: usize,
    /// The gain (1/m).
    pub kp: f64,
    /// The targets (their `sampled` choice of loop).
    pub targets: &'a Targets,
}

impl Line<'_> {
    /// The margins at position `x_mm`.
    fn margins(&self, x_mm: f64) -> Result<Margins, DesignError> {
        margins_in(&(self.at)(x_mm)?, self.kp, self.mode, self.targets.sampled)
    }

    /// The positions in [`lo_mm`, `hi_mm`] of the smallest phase margin and of the smallest
    /// gain margin (an unstable closed loop counting as the smallest, an infinite margin as the
    /// largest), with `breaks` (the mass table's points) sampled as well.
    ///
    /// # Errors
    /// A margin analysis fails.
    pub fn worst(
        &self,
        lo_mm: f64,
        hi_mm: f64,
        breaks: &[f64],
    ) -> Result<Vec<(Searched, f64)>, DesignError> {
        let mut xs: Vec<f64> = (0..SCAN_POINTS)
            .map(|i| lo_mm + (hi_mm - lo_mm) * i as f64 / (SCAN_POINTS - 1) as f64)
            .chain(
                breaks
                    .iter()
                    .copied()
                    .filter(|x| (lo_mm..=hi_mm).contains(x)),
            )
            .collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        let ms = xs
            .iter()
            .map(|&x| self.margins(x))
            .collect::<Result<Vec<_>, _>>()?;
        let mut out = Vec::new();
        for (which, key) in [
            (Searched::PhaseMargin, pm_key as fn(&Margins) -> f64),
            (Searched::GainMargin, gm_key),
        ] {
            let k = (0..xs.len()).min_by(|&a, &b| key(&ms[a]).total_cmp(&key(&ms[b])));
            let k = k.expect("the scan has points");
            if !key(&ms[k]).is_finite() && key(&ms[k]) > 0.0 {
                continue; // infinite everywhere: no worst position
            }
            let (a, b) = (xs[k.saturating_sub(1)], xs[(k + 1).min(xs.len() - 1)]);
            let f = |x: f64| self.margins(x).map(|m| key(&m));
            out.push((which, golden_min(f, a, b, xs[k], key(&ms[k]))?));
        }
        Ok(out)
    }
}

/// The phase margin as the search orders it: −∞ for an unstable closed loop, +∞ infinite.
fn pm_key(m: &Margins) -> f64 {
    match m.closed_loop_stable {
        false => f64::NEG_INFINITY,
        true => m.phase_margin_deg.unwrap_or(f64::INFINITY),
    }
}

/// The gain margin as the search orders it, as [`pm_key`].
fn gm_key(m: &Margins) -> f64 {
    match m.closed_loop_stable {
        false => f64::NEG_INFINITY,
        true => m.gain_margin_db.unwrap_or(f64::INFINITY),
    }
}

/// The minimiser of `f` on [a, b] by golden section to [`X_TOLERANCE_MM`], or `best` (whose
/// value is `f_best`) where no point evaluated is lower.
fn golden_min(
    f: impl Fn(f64) -> Result<f64, DesignError>,
    mut a: f64,
    mut b: f64,
    best: f64,
    f_best: f64,
) -> Result<f64, DesignError> {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (f(c)?, f(d)?);
    for _ in 0..GOLDEN_STEPS {
        if b - a <= X_TOLERANCE_MM {
            break;
        }
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - r * (b - a);
            fc = f(c)?;
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + r * (b - a);
            fd = f(d)?;
        }
    }
    let (x, fx) = if fc < fd { (c, fc) } else { (d, fd) };
    Ok(if fx < f_best { x } else { best })
}
