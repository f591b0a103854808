//! The gas-fraction model's results as every front end shows them (docs/bulk-modulus.md): the
//! gas fraction and the table of β_e and the margins against mean chamber pressure, as JSON,
//! text and CSV. Pressures and bulk moduli are in bar, gain margins in dB, phase margins in deg;
//! an infinite margin is `null` in JSON, `inf` in text and an empty cell in CSV.

use crate::format::{fmt_opt, fmt_short};
use crate::records::{csv_number, csv_text};
use pumpcyl::bulk::{BetaReading, BulkModel, Row};
use serde_json::{json, Value};
use std::fmt::Write as _;

/// The bulk-modulus document (`bulk-modulus --json`): `gas_fraction` (the volume fraction of
/// gas at atmospheric pressure), `beta_oil_bar`, `gas_fraction_from` (the `beta_bar` and
/// `p_mean_bar` it was read off, and `source`, where they came from in words) and `table`, the
/// core's [`Row`]s.
pub fn bulk_json(
    x: f64,
    beta_oil_bar: f64,
    (reading, from): (BetaReading, &str),
    rows: &[Row],
) -> Value {
    json!({
        "gas_fraction": x,
        "beta_oil_bar": beta_oil_bar,
        "gas_fraction_from": {
            "beta_bar": reading.beta_bar,
            "p_mean_bar": reading.p_mean_bar,
            "source": from,
        },
        "table": rows,
    })
}

/// The gas fraction `x` and the table as text; `fit` is (β bar, at mean pressure bar, β_oil
/// bar) the gas fraction came from, `from` where β and the pressure came from in words.
pub fn bulk_text(fit: (f64, f64, f64), from: &str, x: f64, rows: &[Row]) -> String {
    let (beta_bar, p_mean_bar, beta_oil_bar) = fit;
    let mut s = format!(
        "gas fraction X = {x:.5} (beta_e = {} bar at {} bar mean pressure, from {from}; beta_oil = {beta_oil_bar} bar)\n",
        fmt_short(beta_bar, 1),
        fmt_short(p_mean_bar, 2),
    );
    let _ = writeln!(
        s,
        "{:>8} {:>10} {:>9} {:>9}  closed loop",
        "p_bar", "beta_bar", "GM_dB", "PM_deg"
    );
    for r in rows {
        let verdict = if r.closed_loop_stable {
            "stable"
        } else {
            "UNSTABLE"
        };
        let _ = writeln!(
            s,
            "{:>8.2} {:>10.1} {:>9} {:>9}  {verdict}",
            r.p_bar,
            r.beta_bar,
            fmt_opt(r.gain_margin_db, 2),
            fmt_opt(r.phase_margin_deg, 1)
        );
    }
    s
}

/// The family of β(p) models (docs/bulk-modulus.md#a-family-of-models), each fitted to the same
/// reading: the model, its gas fraction and β_e at each pressure of `pressures_bar` (bar); an
/// error in place of a model that cannot hold the reading.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Family {
    /// The pressures (bar gauge).
    pub p_bar: Vec<f64>,
    /// Each model fitted.
    pub models: Vec<Fitted>,
}

/// One model of the family fitted to the reading.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Fitted {
    /// The model and its parameters.
    #[serde(flatten)]
    pub model: BulkModel,
    /// Its gas fraction X (at atmospheric pressure for the entrained air), or `None`.
    pub gas_fraction: Option<f64>,
    /// β_e at each pressure (bar), empty where the fit failed.
    pub beta_bar: Vec<f64>,
    /// Why the model cannot hold the reading, where it cannot.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

impl Family {
    /// Every model of [`pumpcyl::bulk::FAMILY`] fitted to `reading` with the oil's
    /// `beta_oil_bar`, at `pressures_bar`.
    pub fn fit(reading: BetaReading, beta_oil_bar: f64, pressures_bar: &[f64]) -> Family {
        let models = (pumpcyl::bulk::FAMILY.into_iter())
            .map(
                |model| match model.fit(reading.beta_bar, reading.p_mean_bar, beta_oil_bar) {
                    Ok(x) => Fitted {
                        model,
                        gas_fraction: Some(x),
                        beta_bar: (pressures_bar.iter())
                            .map(|&p| model.beta_bar(x, p, beta_oil_bar))
                            .collect(),
                        error: None,
                    },
                    Err(e) => Fitted {
                        model,
                        gas_fraction: None,
                        beta_bar: vec![],
                        error: Some(e.to_string()),
                    },
                },
            )
            .collect();
        Family {
            p_bar: pressures_bar.to_vec(),
            models,
        }
    }

    /// The family as text: β_e at each pressure under each model, one column a model.
    pub fn text(&self) -> String {
        let mut s = String::from(
            "the same reading under other models of beta against pressure (docs/bulk-modulus.md#a-family-of-models):\n",
        );
        let _ = write!(s, "{:>8}", "p_bar");
        for m in &self.models {
            let _ = write!(s, " {:>31}", m.model.name());
        }
        s.push('\n');
        for (k, p) in self.p_bar.iter().enumerate() {
            let _ = write!(s, "{p:>8.2}");
            for m in &self.models {
                let cell = m.beta_bar.get(k).map_or("-".into(), |b| format!("{b:.1}"));
                let _ = write!(s, " {cell:>31}");
            }
            s.push('\n');
        }
        s
    }
}

/// The table as CSV: `p_bar,beta_bar,gain_margin_db,phase_margin_deg,closed_loop_stable`, one
/// row per pressure, values in the records' number format ([`csv_number`]; a margin that does
/// not exist is an empty cell).
pub fn bulk_csv(rows: &[Row]) -> String {
    let header = [
        "p_bar",
        "beta_bar",
        "gain_margin_db",
        "phase_margin_deg",
        "closed_loop_stable",
    ]
    .map(String::from);
    let opt = |v: Option<f64>| v.map_or(String::new(), csv_number);
    let cells = |r: &Row| {
        [
            csv_number(r.p_bar),
            csv_number(r.beta_bar),
            opt(r.gain_margin_db),
            opt(r.phase_margin_deg),
            r.closed_loop_stable.to_string(),
        ]
    };
    csv_text(&header, rows.iter().map(cells))
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::bulk::{gas_fraction, table, BETA_OIL_BAR};
    use pumpcyl::rig::Rig;

    #[test]
    fn the_table_has_a_row_per_pressure_in_every_form() {
        let x = gas_fraction(165.0, 4.4, BETA_OIL_BAR).unwrap();
        let rows = table(&Rig::default(), x, BETA_OIL_BAR, &[1.0, 4.4, 10.0]).unwrap();
        let csv = bulk_csv(&rows);
        assert_eq!(csv.lines().count(), 1 + 3);
        assert!(csv.lines().all(|l| l.split(',').count() == 5), "{csv}");
        // β_e grows with pressure
        let beta: Vec<f64> = rows.iter().map(|r| r.beta_bar).collect();
        assert!(beta[0] < beta[1] && beta[1] < beta[2], "{beta:?}");
        let reading = pumpcyl::bulk::ARTICLE_READING;
        let v = bulk_json(x, BETA_OIL_BAR, (reading, "the article"), &rows);
        assert_eq!(v["gas_fraction_from"]["p_mean_bar"], 4.4);
        assert_eq!(v["table"].as_array().unwrap().len(), 3);
        assert!((v["table"][1]["beta_bar"].as_f64().unwrap() - 165.0).abs() < 1e-6);
        // the gas fraction line, the column names, one line per pressure
        assert_eq!(
            bulk_text((165.0, 4.4, BETA_OIL_BAR), "the article", x, &rows)
                .lines()
                .count(),
            5
        );
    }
}

/// β_e identified at several pressure levels and the family fitted to them
/// (docs/bulk-modulus.md#several-pressure-levels), with the margins of the rig at the advised
/// next level under the two models it separates.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Levels {
    /// Each level's experiment file and what it read.
    pub identified: Vec<IdentifiedLevel>,
    /// The family fitted to them.
    #[serde(flatten)]
    pub fit: pumpcyl::bulk::levels::LevelsFit,
    /// The rig's margins at the next level under each of the two models it separates.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub next_level_margins: Vec<Row>,
    /// The emulator run against the records of the levels that join it, the gas fraction of
    /// the best model fitted directly (docs/identification.md#nonlinear-refinement); `null`
    /// where no level joins.
    pub nonlinear: Option<pumpcyl::ident::NonlinearFit>,
}

/// One level's identification.
#[derive(Debug, Clone, serde::Serialize)]
pub struct IdentifiedLevel {
    /// The experiment file.
    pub experiment: String,
    /// The mean chamber pressure (bar gauge).
    pub p_mean_bar: f64,
    /// Where it came from: `records` or `anchor`.
    pub p_mean_from: &'static str,
    /// The identified β_e (bar).
    pub beta_bar: f64,
    /// Its profile-likelihood interval (bar).
    pub interval_bar: [f64; 2],
    /// Whether the records bound β on both sides.
    pub identifiable: bool,
}

impl Levels {
    /// The levels as text: the readings, each model's fit, the verdict, the band and the next level.
    pub fn text(&self) -> String {
        let f = &self.fit;
        let pct = f.confidence * 100.0;
        let n = self.identified.len();
        let levels = if n == 1 { "level" } else { "levels" };
        let mut s = format!("beta identified at {n} pressure {levels} ({pct}% intervals):\n");
        for l in &self.identified {
            let _ = writeln!(
                s,
                "  {:>7.2} bar ({})  beta {:>7.1} bar  [{:.1}, {:.1}]{}  {}",
                l.p_mean_bar,
                l.p_mean_from,
                l.beta_bar,
                l.interval_bar[0],
                l.interval_bar[1],
                if l.identifiable { "" } else { " (not bounded)" },
                l.experiment
            );
        }
        let _ = writeln!(
            s,
            "{:>40} {:>9} {:>21} {:>8} {:>7} {:>7} {:>8}  verdict",
            "model", "X", "X interval", "chi2", "dAIC", "weight", "p"
        );
        for m in &f.fits {
            let [lo, hi] = m.gas_fraction_interval;
            let p = m.p_value.map_or("-".into(), |p| format!("{p:.3}"));
            let verdict = if m.plausible { "plausible" } else { "rejected" };
            let _ =
                writeln!(
                s,
                "{:>40} {:>9.5} [{lo:>9.5}, {hi:>9.5}] {:>8.2} {:>7.2} {:>7.3} {p:>8}  {verdict}",
                m.model.described(), m.gas_fraction, m.chi2, m.delta_aic, m.akaike_weight
            );
        }
        let _ = writeln!(s, "beta against pressure, the band holding the plausible models' parameter and model-form uncertainty:");
        let _ = writeln!(
            s,
            "{:>8} {:>10} {:>23} {:>23}",
            "p_bar", "beta_bar", "band (all plausible)", "band (best model)"
        );
        for b in &f.band {
            let _ = writeln!(
                s,
                "{:>8.2} {:>10.1} [{:>9.1}, {:>9.1}] [{:>9.1}, {:>9.1}]",
                b.p_bar,
                b.beta_bar,
                b.band_bar[0],
                b.band_bar[1],
                b.best_model_band_bar[0],
                b.best_model_band_bar[1]
            );
        }
        s + &self.nonlinear_text() + &self.next_text()
    }

    /// The nonlinear refinement: each model's refit, the verdict, the best model's X and β at
    /// each level; nothing where it did not run.
    fn nonlinear_text(&self) -> String {
        let Some(n) = &self.nonlinear else {
            return String::new();
        };
        let mut s = format!(
            "nonlinear refinement, the emulator run against the records ({} emulations, docs/identification.md#nonlinear-refinement):\n",
            n.emulations
        );
        let _ = writeln!(
            s,
            "{:>40} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7} {:>7}  verdict",
            "model", "X", "b N s/m", "Fc N", "band rpm", "SSE mm2", "dAIC", "weight"
        );
        for m in &n.fits {
            let r = &m.refined;
            let verdict = if m.plausible { "plausible" } else { "rejected" };
            let _ = writeln!(
                s,
                "{:>40} {:>9.5} {:>9.0} {:>9.1} {:>9.2} {:>9.4} {:>7.2} {:>7.3}  {verdict}",
                m.model.described(),
                r.gas_fraction,
                r.viscous_friction_ns_per_m,
                r.coulomb_friction_n,
                r.pump_dead_band_rpm,
                m.sse_mm2,
                m.delta_aic,
                m.akaike_weight
            );
        }
        let best = n.best();
        let [lo, hi] = n.gas_fraction_interval;
        let bounded = if n.identifiable { "" } else { " (not bounded)" };
        let told = match n.model {
            Some(m) => format!("the records tell the model: {}", m.described()),
            None if n.fits.len() == 1 => format!("one model refined: {}", best.model.described()),
            None => "the records cannot tell every other model from the best".to_string(),
        };
        let _ = writeln!(
            s,
            "{told}; its X {:.5} [{lo:.5}, {hi:.5}]{bounded}, noise {:.4} mm; beta at each level:",
            best.refined.gas_fraction, n.noise_std_mm
        );
        for l in &n.levels {
            let _ = writeln!(
                s,
                "  {:>7.2} bar  beta {:>7.1} bar  [{:.1}, {:.1}]",
                l.p_mean_bar, l.beta_bar, l.interval_bar[0], l.interval_bar[1]
            );
        }
        s
    }

    /// The verdict and the next level to record, with the rig's margins there.
    pub fn next_text(&self) -> String {
        let f = &self.fit;
        let mut s = format!("{}\n", self.verdict());
        if let Some(n) = &f.next_level {
            let _ = writeln!(
                s,
                "next level: record at {:.1} bar mean chamber pressure, where {} and {} differ most (beta {:.1} and {:.1} bar; a record there, as sure as the levels' trend against beta says, adds chi2 {:.1} between them)",
                n.p_mean_bar, n.models[0].described(), n.models[1].described(), n.beta_bar[0], n.beta_bar[1], n.expected_chi2
            );
            for (m, r) in n.models.iter().zip(&self.next_level_margins) {
                let stable = if r.closed_loop_stable {
                    "stable"
                } else {
                    "UNSTABLE: lower Kp for that record"
                };
                let _ = writeln!(
                    s,
                    "  the rig there under {}: GM {} dB, PM {} deg, {stable}",
                    m.described(),
                    fmt_opt(r.gain_margin_db, 2),
                    fmt_opt(r.phase_margin_deg, 1)
                );
            }
        }
        s
    }

    /// The verdict in one line.
    fn verdict(&self) -> String {
        let f = &self.fit;
        let standing: Vec<String> = (f.fits.iter())
            .filter(|m| m.plausible)
            .map(|m| m.model.described())
            .collect();
        match (f.model, f.levels.len()) {
            (_, 1) => "one level: every model passes through it; record at a second pressure level to tell them apart".into(),
            (Some(m), _) => format!("the records tell the model: {} (every other model's misfit is significant at {}%)", m.described(), f.confidence * 100.0),
            (None, _) if standing.is_empty() => "no model of the family fits the levels: the band spans them all".into(),
            (None, _) => format!("the records cannot tell apart: {}", standing.join(", ")),
        }
    }
}

/// Whether [`identify_levels`] refines the levels through the emulator
/// (docs/identification.md#nonlinear-refinement).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refine {
    /// No refinement.
    Off,
    /// The levels whose experiments join it, beyond the work limit only if allowed.
    On {
        /// Run beyond [`pumpcyl::limits::MAX_REFINED_SAMPLES`].
        allow_long_run: bool,
    },
}

/// Most levels a request identifies.
const MAX_LEVEL_FILES: usize = pumpcyl::bulk::levels::MAX_LEVELS;

/// β identified at each experiment's pressure level and the family of models (with `own`, a
/// rig's model) fitted to them with the oil's β and the confidence `(beta_oil_bar,
/// confidence)`, the band at `band_at_bar`, the next level among 0.5 bar steps up to twice the
/// highest level (at least 20 bar) with the first experiment's rig's margins there
/// (docs/bulk-modulus.md#several-pressure-levels).
///
/// With `refine` on, the levels whose experiments join it are refined through the emulator
/// (docs/identification.md#nonlinear-refinement).
///
/// # Errors
/// No experiment or more than the limit, a confidence outside (0, 1), an identification that
/// fails (named by its file), levels the fit refuses, a refinement that cannot run.
pub fn identify_levels(
    exps: &[pumpcyl::ident::Experiment],
    own: BulkModel,
    (beta_oil_bar, confidence): (f64, f64),
    band_at_bar: &[f64],
    refine: Refine,
) -> anyhow::Result<Levels> {
    use pumpcyl::bulk::levels::{candidates, fit_levels, NextSearch};
    let most = MAX_LEVEL_FILES;
    if exps.is_empty() || exps.len() > most {
        anyhow::bail!(
            "{} pressure levels: give 1 to {most} experiments",
            exps.len()
        );
    }
    let confidence = pumpcyl::ident::check_confidence(confidence)?;
    let mut identified = Vec::new();
    let (mut read, mut linear) = (Vec::new(), Vec::new());
    for exp in exps {
        let r = pumpcyl::ident::identify_level(exp, confidence)
            .map_err(|e| anyhow::anyhow!("{}: {e}", exp.path.display()))?;
        identified.push(IdentifiedLevel {
            experiment: exp.path.display().to_string(),
            p_mean_bar: r.level.p_mean_bar,
            p_mean_from: if r.pressure_from_records {
                "records"
            } else {
                "anchor"
            },
            beta_bar: r.level.beta_bar,
            interval_bar: r.level.interval_bar,
            identifiable: r.identifiable,
        });
        linear.push((r.best, r.level.p_mean_bar));
        read.push(r.level);
    }
    let highest = read.iter().map(|l| l.p_mean_bar).fold(0.0, f64::max);
    let next_from: Vec<f64> = (1..=400)
        .map(|i| 0.5 * f64::from(i))
        .take_while(|p| *p <= (2.0 * highest).max(20.0))
        .collect();
    let models = candidates(own);
    let rig = &exps[0].rig;
    // a level is only advised where the first experiment's loop is stable with every
    // standing model's β there (records at an unstable gain cannot be taken)
    let stable = |beta: f64| level_margins(rig, 0.0, beta).is_ok_and(|r| r.closed_loop_stable);
    let next = NextSearch {
        from_bar: &next_from,
        usable: &stable,
    };
    let fit = fit_levels(&read, &models, beta_oil_bar, confidence, band_at_bar, &next)?;
    let next_level_margins = match &fit.next_level {
        Some(n) => (n.beta_bar.iter())
            .map(|&b| level_margins(rig, n.p_mean_bar, b))
            .collect::<anyhow::Result<Vec<Row>>>()?,
        None => Vec::new(),
    };
    let nonlinear = match refine {
        Refine::On { allow_long_run } => {
            refine_levels(exps, &linear, &fit.fits, (confidence, allow_long_run))?
        }
        Refine::Off => None,
    };
    Ok(Levels {
        identified,
        fit,
        next_level_margins,
        nonlinear,
    })
}

/// The nonlinear refinement (docs/identification.md#nonlinear-refinement) of the step records
/// of the experiments that join it — those whose `nonlinear_refinement` says so, or, where it
/// is absent, every one when two levels or more are fitted (where the refinement pays: one
/// gas fraction across pressures) — under each model of `fits` (the levels fit's), from its
/// gas fraction; `linear` holds each level's linear answer and mean pressure. `None` where no
/// experiment joins.
///
/// # Errors
/// A refinement that cannot run, named by the first experiment that joins; records × models
/// beyond [`pumpcyl::limits::MAX_REFINED_SAMPLES`] unless `allow_long_run`.
fn refine_levels(
    exps: &[pumpcyl::ident::Experiment],
    linear: &[(pumpcyl::ident::Candidate, f64)],
    fits: &[pumpcyl::bulk::levels::ModelFit],
    (confidence, allow_long_run): (f64, bool),
) -> anyhow::Result<Option<pumpcyl::ident::NonlinearFit>> {
    let pays = exps.len() >= 2;
    let joining: Vec<(&pumpcyl::ident::Experiment, pumpcyl::ident::Source<'_>)> = (exps.iter())
        .zip(linear)
        .filter(|(e, _)| e.file.nonlinear_refinement.unwrap_or(pays))
        .filter(|(e, _)| !e.problem.datasets.is_empty())
        .map(|(e, &(linear, p_mean_bar))| {
            let problem = &e.problem;
            (
                e,
                pumpcyl::ident::Source {
                    problem,
                    linear,
                    p_mean_bar,
                },
            )
        })
        .collect();
    let Some((first, _)) = joining.first() else {
        return Ok(None);
    };
    let sources: Vec<_> = joining.iter().map(|(_, s)| *s).collect();
    let samples: usize = sources.iter().map(|s| s.problem.samples()).sum();
    pumpcyl::limits::check_work(
        "the nonlinear refinement (record samples in the fit windows × models; an experiment's \
         nonlinear_refinement = false keeps its records out)",
        (samples * fits.len()) as f64,
        pumpcyl::limits::MAX_REFINED_SAMPLES,
        allow_long_run,
    )?;
    let models: Vec<(BulkModel, f64)> = fits.iter().map(|f| (f.model, f.gas_fraction)).collect();
    pumpcyl::ident::refine_nonlinear(&sources, &models, confidence)
        .map(Some)
        .map_err(|e| anyhow::anyhow!("{}: nonlinear refinement: {e}", first.path.display()))
}

/// The margins of `rig` with β `beta_bar` at the mean pressure `p_bar`.
fn level_margins(rig: &pumpcyl::rig::Rig, p_bar: f64, beta_bar: f64) -> anyhow::Result<Row> {
    let r = pumpcyl::rig::Rig {
        beta_bar,
        ..rig.clone()
    };
    r.validate("beta at the next level")?;
    let m = pumpcyl::lti::margins(&pumpcyl::model::Plant::new(&r).open_loop(false))?;
    Ok(Row {
        p_bar,
        beta_bar,
        gain_margin_db: m.gain_margin_db,
        phase_margin_deg: m.phase_margin_deg,
        closed_loop_stable: m.closed_loop_stable,
    })
}
