//! Effective bulk modulus against pressure (docs/bulk-modulus.md): the constant gas-fraction model
//! 1/β_e(p) = X/p + (1 − X)/β_oil, with X the undissolved gas volume fraction and p the mean
//! chamber pressure in bar as the article uses it (its 4.4 bar mean gives β_e = 37.8 bar at
//! 1 bar and 370 bar at 10 bar from 165 bar), and the rig's margins at each pressure.
//!
//! ```
//! use pumpcyl::{bulk, rig::Rig};
//!
//! // the gas fraction that gives the identified 165 bar at the records' 4.4 bar mean pressure
//! let x = bulk::gas_fraction(165.0, 4.4, bulk::BETA_OIL_BAR)?;
//! assert!((x - 0.02641).abs() < 1e-5);
//! // the article's 37.8 bar at 1 bar and 370 bar at 10 bar
//! assert!((bulk::effective_beta(x, 1.0, bulk::BETA_OIL_BAR) - 37.8).abs() < 0.05);
//! assert!((bulk::effective_beta(x, 10.0, bulk::BETA_OIL_BAR) - 370.5).abs() < 0.1);
//!
//! // the article's rig at 1, 4.4 and 10 bar: unstable at 1 bar, the margins grow with pressure
//! let rows = bulk::table(&Rig::default(), x, bulk::BETA_OIL_BAR, &[1.0, 4.4, 10.0])?;
//! let stable: Vec<bool> = rows.iter().map(|r| r.closed_loop_stable).collect();
//! assert_eq!(stable, [false, true, true]);
//! assert!(rows[2].gain_margin_db > rows[1].gain_margin_db);
//! # Ok::<(), bulk::BulkError>(())
//! ```

use crate::lti::{margins, LtiError};
use crate::model::Plant;
use crate::rig::Rig;
use serde::Serialize;

pub use crate::circuit::parts::BETA_OIL_BAR;

pub mod levels;
pub mod models;
pub use models::{BulkModel, Form, ATMOSPHERE_BAR, FAMILY};

/// Errors of the bulk-modulus model.
#[derive(Debug, thiserror::Error)]
pub enum BulkError {
    /// Values outside the model's range.
    #[error("{0}")]
    Input(String),
    /// A margin computation failed.
    #[error(transparent)]
    Lti(#[from] LtiError),
    /// A rig override failed.
    #[error(transparent)]
    Rig(#[from] crate::rig::RigError),
    /// A model of the family refused its values.
    #[error(transparent)]
    Model(#[from] models::ModelError),
}

/// The gas fraction X that gives `beta_bar` at mean pressure `p_bar` (docs/bulk-modulus.md#fitting-the-gas-fraction):
/// X = (1/β − 1/β_oil) / (1/p − 1/β_oil). Needs 0 < β < β_oil and 0 < p < β_oil.
pub fn gas_fraction(beta_bar: f64, p_bar: f64, beta_oil_bar: f64) -> Result<f64, BulkError> {
    models::gas_fraction_of(beta_bar, p_bar, beta_oil_bar).map_err(BulkError::Input)
}

/// A bulk modulus and the mean chamber pressure it holds at: what a gas fraction is read off
/// (docs/bulk-modulus.md#fitting-the-gas-fraction).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BetaReading {
    /// The effective bulk modulus (bar).
    pub beta_bar: f64,
    /// The mean chamber pressure it holds at (bar gauge).
    pub p_mean_bar: f64,
}

/// The article's identification: β 165 bar at its records' mean chamber pressure 4.4 bar
/// (p1 4.1 bar, p2 4.7 bar; docs/bulk-modulus.md#fitting-the-gas-fraction).
pub const ARTICLE_READING: BetaReading = BetaReading {
    beta_bar: 165.0,
    p_mean_bar: 4.4,
};

impl BetaReading {
    /// The gas fraction this reading gives ([`gas_fraction`]).
    pub fn gas_fraction(&self, beta_oil_bar: f64) -> Result<f64, BulkError> {
        gas_fraction(self.beta_bar, self.p_mean_bar, beta_oil_bar)
    }

    /// The gas fraction this reading gives under `model` ([`BulkModel::fit`]).
    pub fn gas_fraction_under(
        &self,
        model: BulkModel,
        beta_oil_bar: f64,
    ) -> Result<f64, BulkError> {
        Ok(model.fit(self.beta_bar, self.p_mean_bar, beta_oil_bar)?)
    }
}

/// A model of the family fitted to a reading: β_e at any pressure
/// (docs/bulk-modulus.md#a-family-of-models).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BetaCurve {
    /// The model.
    pub model: BulkModel,
    /// Its gas fraction, fitted to the reading.
    pub gas_fraction: f64,
    /// The pure oil's bulk modulus (bar).
    pub beta_oil_bar: f64,
}

impl BetaCurve {
    /// `model` through `reading`, with the oil's `beta_oil_bar`.
    pub fn through(
        model: BulkModel,
        reading: BetaReading,
        beta_oil_bar: f64,
    ) -> Result<BetaCurve, BulkError> {
        Ok(BetaCurve {
            model,
            gas_fraction: model.fit(reading.beta_bar, reading.p_mean_bar, beta_oil_bar)?,
            beta_oil_bar,
        })
    }

    /// β_e (bar) at the gauge pressure `p_bar`.
    pub fn beta_bar(&self, p_bar: f64) -> f64 {
        self.model
            .beta_bar(self.gas_fraction, p_bar, self.beta_oil_bar)
    }
}

/// β_e at pressure `p_bar` for gas fraction `x` (bar).
pub fn effective_beta(x: f64, p_bar: f64, beta_oil_bar: f64) -> f64 {
    models::effective_beta_of(x, p_bar, beta_oil_bar)
}

/// One row of the β_e(p) table with the rig's margins there.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Row {
    /// Mean chamber pressure (bar).
    pub p_bar: f64,
    /// Effective bulk modulus (bar).
    pub beta_bar: f64,
    /// Gain margin of the open loop (the article §2.3.3; docs/analysis.md#the-loop-that-is-analysed) (dB); `None` = infinite.
    pub gain_margin_db: Option<f64>,
    /// Phase margin (deg); `None` = infinite.
    pub phase_margin_deg: Option<f64>,
    /// Closed-loop stability from the eigenvalues.
    pub closed_loop_stable: bool,
}

/// β_e and the rig's margins (sum-pressure loop open, docs/bulk-modulus.md#margins-against-pressure) at each pressure.
pub fn table(
    rig: &Rig,
    x: f64,
    beta_oil_bar: f64,
    pressures_bar: &[f64],
) -> Result<Vec<Row>, BulkError> {
    table_under(
        BulkModel::ConstantGasFraction,
        rig,
        x,
        beta_oil_bar,
        pressures_bar,
    )
}

/// [`table`] with β_e from `model` (docs/bulk-modulus.md#a-family-of-models) and its gas
/// fraction `x`.
pub fn table_under(
    model: BulkModel,
    rig: &Rig,
    x: f64,
    beta_oil_bar: f64,
    pressures_bar: &[f64],
) -> Result<Vec<Row>, BulkError> {
    pressures_bar
        .iter()
        .map(|&p| {
            let beta = model.beta_bar(x, p, beta_oil_bar);
            let r = Rig {
                beta_bar: beta,
                ..rig.clone()
            };
            r.validate("β_e from the gas-fraction model")?;
            let m = margins(&Plant::new(&r).open_loop(false))?;
            Ok(Row {
                p_bar: p,
                beta_bar: beta,
                gain_margin_db: m.gain_margin_db,
                phase_margin_deg: m.phase_margin_deg,
                closed_loop_stable: m.closed_loop_stable,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_the_article_extrapolation() {
        // X from 165 bar at 4.4 bar; the article's 37.8 bar at 1 bar and 370 bar at 10 bar
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        assert!((x - 0.026415).abs() < 1e-5, "{x}");
        assert!((effective_beta(x, 1.0, BETA_OIL_BAR) - 37.8).abs() < 0.05);
        assert!((effective_beta(x, 10.0, BETA_OIL_BAR) - 370.0).abs() < 1.0);
        assert!((effective_beta(x, 4.4, BETA_OIL_BAR) - 165.0).abs() < 1e-9);
    }

    #[test]
    fn limits_hold() {
        // no gas: β_e = β_oil at any pressure; all gas: β_e = p (isothermal gas)
        assert!((effective_beta(0.0, 3.0, BETA_OIL_BAR) - BETA_OIL_BAR).abs() < 1e-9);
        assert!((effective_beta(1.0, 3.0, BETA_OIL_BAR) - 3.0).abs() < 1e-12);
        assert!(gas_fraction(2.0, 4.4, BETA_OIL_BAR).is_err());
        assert!(gas_fraction(-1.0, 4.4, BETA_OIL_BAR).is_err());
        assert!(gas_fraction(165.0, 0.0, BETA_OIL_BAR).is_err());
    }

    #[test]
    fn margins_grow_with_pressure() {
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        let rows = table(&Rig::default(), x, BETA_OIL_BAR, &[1.0, 4.4, 10.0]).unwrap();
        // at 4.4 bar the nominal margins; stiffer oil at 10 bar gives more, 1 bar is unstable
        assert!((rows[1].gain_margin_db.unwrap() - 6.45).abs() < 0.05);
        assert!(rows[2].gain_margin_db.unwrap() > rows[1].gain_margin_db.unwrap());
        assert!(!rows[0].closed_loop_stable);
    }
}
