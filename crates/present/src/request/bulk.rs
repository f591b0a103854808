//! The bulk-modulus request: the gas fraction from an identified β_e at its mean pressure, β_e
//! against pressure and the margins there (docs/bulk-modulus.md).

use super::{check_field, Document, FieldError, Given, Hooks, Request, RigInput};
use crate::bulk::{bulk_csv, bulk_json, bulk_text, identify_levels, Family, Levels, Refine};
use crate::figures::Chart;
use pumpcyl::bulk::{table_under, BetaReading, BulkModel, Row};
use pumpcyl::ident::Experiment;
use serde_json::Value;

/// Rows of the fine table an output file holds.
const FINE_ROWS: usize = 91;

/// `bulk-modulus`: the gas fraction the reading gives, and a table of β_e and the margins over
/// a range of mean pressures.
#[derive(Debug, Clone)]
pub struct BulkModulus {
    /// The rig whose margins are tabled.
    pub rig: RigInput,
    /// The identified β_e (bar) and the mean pressure it was read at (bar).
    pub reading: BetaReading,
    /// Where the reading came from, in the front end's words.
    pub from: String,
    /// Pure-oil bulk modulus (bar).
    pub beta_oil_bar: f64,
    /// Lowest mean pressure of the table (bar).
    pub from_bar: f64,
    /// Highest mean pressure of the table (bar).
    pub to_bar: f64,
    /// Table rows, evenly spaced.
    pub points: usize,
    /// Whether a table beyond the margin analyses' limit, or a nonlinear refinement of the
    /// levels beyond its limit, may run.
    pub allow_long_run: bool,
    /// The model of β against pressure the table follows (docs/bulk-modulus.md#a-family-of-models).
    pub model: BulkModel,
    /// Experiments at several pressure levels, each identifying β there
    /// (docs/bulk-modulus.md#several-pressure-levels); empty: none.
    pub levels: Vec<Experiment>,
    /// The confidence level of the levels' intervals and tests.
    pub confidence: f64,
}

/// The gas fraction and the table.
pub struct BulkOutcome {
    request: BulkModulus,
    gas_fraction: f64,
    rows: Vec<Row>,
    levels: Option<Levels>,
}

impl BulkModulus {
    fn check(&self) -> anyhow::Result<()> {
        let (from, to) = (self.from_bar, self.to_bar);
        if !(from > 0.0 && to > from && to.is_finite()) {
            let e = FieldError::new(
                "from_bar",
                Given::Number(from),
                "must satisfy 0 < from < to",
            );
            return Err(e.and("to_bar", Given::Number(to)).into());
        }
        let n = self.points as f64;
        check_field("points", n, self.points >= 2, "must be at least 2")?;
        let limited = |e: pumpcyl::limits::LimitError| {
            let long = matches!(e, pumpcyl::limits::LimitError::LongRun { .. });
            let error = FieldError::new("points", Given::Number(n), e.to_string());
            if long {
                error.unless("allow_long_run")
            } else {
                error
            }
        };
        pumpcyl::limits::check_size("the table", n).map_err(limited)?;
        let most = pumpcyl::limits::MAX_MARGIN_ANALYSES;
        pumpcyl::limits::check_work("the table", n, most, self.allow_long_run).map_err(limited)?;
        Ok(())
    }

    /// β_e and the margins at `points` mean pressures over the request's range.
    fn rows(&self, x: f64, points: usize) -> anyhow::Result<Vec<Row>> {
        let pressures = pumpcyl::ident::spaced(self.from_bar, self.to_bar, points, false);
        let rig = &self.rig.rig;
        Ok(table_under(
            self.model,
            rig,
            x,
            self.beta_oil_bar,
            &pressures,
        )?)
    }
}

impl Request for BulkModulus {
    type Outcome = BulkOutcome;

    fn run(&self, _: Hooks<'_>) -> anyhow::Result<BulkOutcome> {
        self.check()?;
        let r = &self.reading;
        let x = self
            .model
            .fit(r.beta_bar, r.p_mean_bar, self.beta_oil_bar)?;
        let rows = self.rows(x, self.points)?;
        let p: Vec<f64> = rows.iter().map(|r| r.p_bar).collect();
        Ok(BulkOutcome {
            levels: self.levels(&p)?,
            rows,
            request: self.clone(),
            gas_fraction: x,
        })
    }
}

impl BulkModulus {
    /// β identified at each level's experiment and the family fitted to them, the band at
    /// `band_at_bar`; `None` without levels.
    fn levels(&self, band_at_bar: &[f64]) -> anyhow::Result<Option<Levels>> {
        if self.levels.is_empty() {
            return Ok(None);
        }
        let own = self.rig.rig.bulk_model();
        let fit = (self.beta_oil_bar, self.confidence);
        identify_levels(
            &self.levels,
            own,
            fit,
            band_at_bar,
            Refine::On {
                allow_long_run: self.allow_long_run,
            },
        )
        .map(Some)
    }
}

impl BulkOutcome {
    /// The family of β(p) models fitted to the same reading, at the table's pressures.
    fn family(&self) -> Family {
        let r = &self.request;
        let p: Vec<f64> = self.rows.iter().map(|row| row.p_bar).collect();
        Family::fit(r.reading, r.beta_oil_bar, &p)
    }

    /// What the gas fraction was read off: (β bar, at mean pressure bar, β_oil bar).
    fn fit(&self) -> (f64, f64, f64) {
        let r = &self.request;
        (r.reading.beta_bar, r.reading.p_mean_bar, r.beta_oil_bar)
    }

    /// A fine table over the same range as CSV.
    ///
    /// # Errors
    /// A margin that cannot be computed.
    pub fn csv(&self) -> anyhow::Result<String> {
        Ok(bulk_csv(&self.request.rows(self.gas_fraction, FINE_ROWS)?))
    }

    /// β_e, GM and PM against pressure over a fine table.
    ///
    /// # Errors
    /// A margin that cannot be computed.
    pub fn chart(&self) -> anyhow::Result<Chart> {
        let rows = self.request.rows(self.gas_fraction, FINE_ROWS)?;
        let model = (self.request.model, self.gas_fraction);
        Ok(Chart::bulk_modulus(self.fit(), model, &rows))
    }
}

impl Document for BulkOutcome {
    fn json(&self) -> anyhow::Result<Value> {
        let r = &self.request;
        let reading = (r.reading, r.from.as_str());
        let mut doc = bulk_json(self.gas_fraction, r.beta_oil_bar, reading, &self.rows);
        doc["models"] = serde_json::to_value(self.family())?;
        doc["model"] = serde_json::to_value(r.model)?;
        if let Some(levels) = &self.levels {
            doc["levels"] = serde_json::to_value(levels)?;
        }
        Ok(doc)
    }

    fn text(&self) -> anyhow::Result<String> {
        let from = &self.request.from;
        let text = format!(
            "{}beta against pressure under the {} model (docs/bulk-modulus.md#a-family-of-models)\n",
            bulk_text(self.fit(), from, self.gas_fraction, &self.rows),
            self.request.model.described(),
        );
        let levels = self.levels.as_ref().map_or(String::new(), Levels::text);
        Ok(text + &self.family().text() + &levels)
    }
}
