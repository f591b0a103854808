//! Step 10, "Which circuit": the article's closing advice (its §4) run on its own application
//! (docs/select.md#the-article-s-application). Before the rig was built, with the undissolved
//! air known only to a factor 2, would the low-pressure circuit have been a certain choice, and
//! was the article's own (its pressure level, Kp 25)? Then the same question with the gas
//! fraction read off the identification's interval of β (step 9).

use super::summary::{SelectUnder, WhichCircuit};
use super::{printed, Run, Source};
use crate::select::{gas_fraction_text, selection_chart, verdict_text};
use anyhow::Result;
use pumpcyl::design::Region;
use pumpcyl::select::{select, Application, BetaEvidence, Candidate, Circuit, Selection};

/// Step 10: the selection on the article's application with the stated gas-fraction range and
/// with the identified one (`region` at `confidence`, read at `p_mean_bar`), and the article's
/// own circuit at its pressure level and gain.
pub(super) fn which_circuit(
    run: &mut Run,
    region: &Region,
    confidence: f64,
    p_mean_bar: f64,
) -> Result<WhichCircuit> {
    run.step("Which circuit (the article §4): was the article's low-pressure circuit a certain choice? (docs/select.md)");
    // the article's question is the DPM's: low-pressure or pressurised (docs/select.md)
    let app = Application::default().with_circuits(&[pumpcyl::circuit::ARTICLE])?;
    let stated = app.select(None)?;
    let article = select(
        &app.rig,
        &app.requirement(),
        &[(Circuit::LOW_PRESSURE, p_mean_bar)],
        Some(printed::KP),
    )?
    .options
    .remove(0);
    let evidence = BetaEvidence::of_region(region, confidence, p_mean_bar);
    let identified = app.with_evidence(&evidence)?.select(None)?;
    run.text(&explanation(&app, &stated, &article, &identified));
    compare(run, &app, &stated, &article, &identified);
    run.table(
        "Which circuit: each level over the stated gas-fraction range (×/÷ 2) and over the identified one",
        &HEADER,
        stated
            .options
            .iter()
            .zip(&identified.options)
            .map(|(s, i)| row(s, i))
            .collect(),
    );
    let models = under_models(&app, &stated)?;
    models_table(run, &models);
    let chart = selection_chart(&app, &stated);
    run.figure(
        "which_circuit",
        Source::Own,
        "Which circuit (the article's §4 advice as a computation): the largest Kp and the 0.2 Hz ±35 mm tracking error against the mean pressure over the stated gas-fraction range",
        &chart,
    )?;
    Ok(WhichCircuit {
        stated,
        article_choice: article,
        identified,
        models,
    })
}

/// The selection over the stated gas-fraction range under each model of β(p) of the family
/// (docs/bulk-modulus.md#a-family-of-models): the article's reading, 165 bar at 4.4 bar, read
/// through each for its X (a factor 2 either way); `stated` is the rig's own model's. The
/// models run in parallel.
fn under_models(app: &Application, stated: &Selection) -> Result<Vec<SelectUnder>> {
    use rayon::prelude::*;
    let own = app.rig.bulk_model();
    (pumpcyl::bulk::FAMILY.par_iter())
        .map(|&m| {
            let s = match m == own {
                true => stated.clone(),
                false => {
                    let rig = app.rig.with_bulk_model(m);
                    app.with_rig(rig, app.rig_from.clone())?.select(None)?
                }
            };
            Ok(SelectUnder {
                model: m,
                gas_fraction: s.gas_fraction,
                min_mean_pressure_bar: s.min_mean_pressure_bar,
                min_level_bar: s.min_level_bar,
            })
        })
        .collect()
}

/// The table of the lowest meeting level under each model of β(p), and the comparison row.
fn models_table(run: &mut Run, models: &[SelectUnder]) {
    let level = |p: Option<f64>| p.map_or("none".to_string(), |p| format!("{p:.2}"));
    run.table(
        "Which circuit under each model of β against pressure (docs/bulk-modulus.md#a-family-of-models): the article's 165 bar at 4.4 bar read through each for its gas fraction, a factor 2 either way; the lowest mean pressure that meets pumpcyl's requirement",
        &["model", "X range", "lowest meeting mean pressure (bar)", "lowest meeting level (bar)"],
        (models.iter())
            .map(|m| {
                let [lo, _, hi] = m.gas_fraction;
                vec![
                    m.model.described(),
                    format!("{lo:.4}–{hi:.4}"),
                    level(m.min_mean_pressure_bar),
                    level(m.min_level_bar),
                ]
            })
            .collect(),
    );
    let spread: Vec<f64> = models
        .iter()
        .filter_map(|m| m.min_mean_pressure_bar)
        .collect();
    let (lo, hi) = (
        spread.iter().copied().fold(f64::INFINITY, f64::min),
        spread.iter().copied().fold(0.0, f64::max),
    );
    run.compare_why(
        "§4 advice: select's lowest certain mean pressure over the models of β(p) (stated X range)",
        match spread.len() {
            0 => "none under any model".to_string(),
            _ => format!("{lo:.2}–{hi:.2} bar ({} of {} models meet somewhere)", spread.len(), models.len()),
        },
        "one model (the constant gas fraction of its reference [21])",
        "-",
        "the choice of pressure level moves with the model of β(p); one identification at one pressure cannot tell them apart (docs/bulk-modulus.md#several-pressure-levels)",
    );
}

/// The comparison rows: the lowest certain level before and after the identification, beside
/// the article's advice (it gives no number).
fn compare(
    run: &mut Run,
    app: &Application,
    stated: &Selection,
    article: &Candidate,
    identified: &Selection,
) {
    let level = |s: &Selection| {
        s.at_min_mean_pressure
            .as_ref()
            .map_or("none".to_string(), |c| {
                format!("{:.2} bar (Kp {:.2})", c.mean_pressure_bar, c.kp_max)
            })
    };
    run.compare_why(
        "§4 advice: lowest mean pressure where the low-pressure circuit is certain, stated X ×/÷ 2 / identified X",
        format!("{} / {}", level(stated), level(identified)),
        "predict it before building (no number given)",
        "-",
        &format!(
            "pumpcyl's requirement, not the article's (docs/select.md): {}, over the article's two loads; {}; {}",
            crate::origin::targets(app.target_pm_deg, app.target_gm_db, app.stroke_mm),
            app.wave.iter().map(crate::origin::wave).collect::<Vec<_>>().join("; "),
            crate::origin::gas_fraction_range(app)
        ),
    );
    run.compare_why(
        "§4 advice: the article's own circuit (low-pressure, records' mean pressure, Kp 25) certain before building?",
        format!(
            "{}: largest Kp over the stated X range {:.2}",
            if article.meets { "yes" } else { "no" },
            article.kp_max_range
        ),
        "the rig worked (its Figures 16-18)",
        "-",
        choice(article),
    );
}

/// Whether the article's circuit was a certain choice, and why not.
fn choice(article: &Candidate) -> &'static str {
    match (article.meets, article.margins_hold_at_reference_gas_fraction) {
        (true, _) => "a certain choice",
        (false, true) => {
            "not a certain choice before the rig was built: it holds at the reference gas fraction, not over the stated range"
        }
        (false, false) => {
            "not a certain choice before the rig was built by pumpcyl's requirement: at Kp 25 its margin targets are missed over the stroke and the loads even at the reference gas fraction. The article checks ±50 mm with 9958 kg and 12,373 kg too (§3.3, Figure 15) and keeps Kp 25 with the margins it finds there; it sets no such requirement, so the verdict rests on pumpcyl's requirement, not on the article's"
        }
    }
}

const HEADER: [&str; 9] = [
    "circuit",
    "p (bar)",
    "stated X: β_e (bar)",
    "Kp max",
    "max |e| (mm)",
    "identified X: β_e (bar)",
    "Kp max",
    "max |e| (mm)",
    "standing loss (W)",
];

/// One level's row: the stated range beside the identified one.
fn row(stated: &Candidate, identified: &Candidate) -> Vec<String> {
    let beta = |c: &Candidate| format!("{:.0}–{:.0}", c.beta_e_bar[0], c.beta_e_bar[1]);
    let error = |c: &Candidate| {
        let e: Vec<String> = c
            .tracking_max_error_mm
            .iter()
            .map(|[_, worst]| format!("{worst:.1}"))
            .collect();
        let e = if e.is_empty() {
            "-".into()
        } else {
            e.join(", ")
        };
        format!("{e} {}", if c.meets { "✓" } else { "✗" })
    };
    vec![
        stated.circuit.name().into(),
        format!("{}", stated.mean_pressure_bar),
        beta(stated),
        format!("{:.2}", stated.kp_max),
        error(stated),
        beta(identified),
        format!("{:.2}", identified.kp_max),
        error(identified),
        stated
            .standing_loss_w
            .map_or("-".to_string(), |w| format!("{w:.1}")),
    ]
}

/// The answer in words: the stated range's verdict, the article's own circuit, the identified
/// range's verdict.
fn explanation(
    app: &Application,
    stated: &Selection,
    article: &Candidate,
    identified: &Selection,
) -> String {
    let level = |s: &Selection| {
        s.min_mean_pressure_bar
            .map_or("no level".to_string(), |p| format!("{p:.2} bar"))
    };
    format!(
        "The article ends (its §4) by advising to predict with LTI models, before the system is built, \
         whether a low-pressure circuit will work, and to choose a circuit with a higher effective bulk \
         modulus where the prediction is uncertain. It gives no number to predict against; pumpcyl's \
         select (docs/select.md) does the prediction on the article's application, its rig and its two \
         loads, against a requirement of pumpcyl's: {}; {}; over {}. Before the rig was built, with the {}: {} from {} ({}). \
         The article's own circuit, the low-pressure circuit at the records' mean pressure {:.2} bar with \
         Kp {}: {}over the whole gas-fraction range ({}); at the reference gas fraction the margin \
         targets {}. So the article's circuit was {}. With the {} (step 9), the answer is {} from {} \
         ({}): the identification removes most of the uncertainty that made the low-pressure choice \
         uncertain. The standing loss is the leakage's Σ p × Q at rest (docs/select.md#cost).",
        crate::origin::targets(app.target_pm_deg, app.target_gm_db, app.stroke_mm),
        app.wave.iter().map(crate::origin::wave).collect::<Vec<_>>().join("; "),
        crate::origin::gas_fraction_range(app),
        gas_fraction_text(stated),
        verdict_text(stated.verdict).to_lowercase(),
        level(stated),
        stated.reasons.join("; "),
        article.mean_pressure_bar,
        printed::KP,
        if article.meets { "meets the requirement " } else { "does not meet the requirement " },
        article.reason,
        if article.margins_hold_at_reference_gas_fraction { "hold" } else { "do not hold over the stroke and the loads" },
        choice(article),
        gas_fraction_text(identified),
        verdict_text(identified.verdict).to_lowercase(),
        level(identified),
        identified.reasons.join("; "),
    )
}
