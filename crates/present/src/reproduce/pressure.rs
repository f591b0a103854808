//! The bulk modulus against pressure (the article §3.1, Figures 12 and 13; docs/bulk-modulus.md):
//! the gas fraction, β_e over 1–10 bar and the margins there, on two rigs named wherever a
//! number stands: the article's Table 1 rig (β 165 bar at 4.4 bar, the basis of every number
//! compared with the article's) and the rig identified from the emulated records.

use super::summary::{self, AtPressure};
use super::{
    agrees, bode_series, margins_of, margins_row, printed, Run, Source, IDENTIFIED_RIG,
    MARGIN_HEADER, TABLE1_RIG,
};
use crate::figures::{bode_markers, Chart};
use crate::format::fmt_opt;
use anyhow::Result;
use pumpcyl::bulk::{self, gas_fraction, BETA_OIL_BAR};
use pumpcyl::design::Targets;
use pumpcyl::emulator::article;
use pumpcyl::ident::Experiment;
use pumpcyl::lti;
use pumpcyl::rig::Rig;

/// The pressure study's result: the margins, and the gas fraction and mean pressure they rest
/// on.
pub(super) struct Pressure {
    pub study: summary::MarginsStudy,
    pub gas_fraction: f64,
    pub gas_fraction_article_basis: f64,
    pub intro: summary::IntroExample,
    pub p_mean_bar: f64,
}

/// The low and high mean chamber pressures of the article's study (bar).
const LOW_BAR: f64 = 1.0;
const HIGH_BAR: f64 = 10.0;

/// `rig` with β_e of gas fraction `x` at each of `pressures`: the margins there, and the rig.
fn at_pressures(rig: &Rig, x: f64, pressures: [f64; 3]) -> Result<[(AtPressure, Rig); 3]> {
    let rows = bulk::table(rig, x, BETA_OIL_BAR, &pressures)?;
    let at = |row: &bulk::Row| -> Result<(AtPressure, Rig)> {
        let r = Rig {
            beta_bar: row.beta_bar,
            ..rig.clone()
        };
        let margins = margins_of(&r)?;
        let at = AtPressure {
            p_bar: row.p_bar,
            beta_bar: row.beta_bar,
            margins,
        };
        Ok((at, r))
    };
    Ok([at(&rows[0])?, at(&rows[1])?, at(&rows[2])?])
}

/// A row label: the rig, the pressure and β_e there.
fn label(rig: &str, at: &AtPressure) -> String {
    format!("{rig} at {:.2} bar, β_e {:.1} bar", at.p_bar, at.beta_bar)
}

/// The gas fraction from the identified β, β_e over 1–10 bar and the margins there, on the
/// article's Table 1 rig and on the identified rig `nominal` (the article §3.1).
pub(super) fn pressure_study(
    run: &mut Run,
    nominal: &Rig,
    exp: &Experiment,
    truth: &article::Truth,
) -> Result<Pressure> {
    run.step("Bulk modulus against pressure: gas fraction and margins (the article §3.1, Figures 12 and 13; docs/bulk-modulus.md)");
    let table1 = Rig::default();
    let p_mean = exp.mean_chamber_pressure_bar().unwrap_or(f64::NAN);
    let x = gas_fraction(nominal.beta_bar, p_mean, BETA_OIL_BAR)?;
    let x_article = gas_fraction(table1.beta_bar, article::P_FIT_BAR, BETA_OIL_BAR)?;
    let basis = format!(
        "{TABLE1_RIG}: β_e from the gas fraction X = {x_article:.5} of its β {} bar at {} bar",
        table1.beta_bar,
        article::P_FIT_BAR
    );
    let fine = bulk::table(
        &table1,
        x_article,
        BETA_OIL_BAR,
        &pumpcyl::ident::spaced(LOW_BAR, HIGH_BAR, 91, false),
    )?;
    run.figure(
        "bulk_modulus",
        Source::Article(12),
        &format!(
            "Effective bulk modulus and the margins against the mean chamber pressure on {basis}, under the article's constant-gas-fraction model"
        ),
        &Chart::bulk_modulus(
            (table1.beta_bar, article::P_FIT_BAR, BETA_OIL_BAR),
            (bulk::BulkModel::ConstantGasFraction, x_article),
            &fine,
        ),
    )?;
    let article_at = at_pressures(&table1, x_article, [LOW_BAR, article::P_FIT_BAR, HIGH_BAR])?;
    let identified_at = at_pressures(nominal, x, [LOW_BAR, p_mean, HIGH_BAR])?;
    let table1_m = margins_of(&table1)?;
    let nominal_m = margins_of(nominal)?;
    let mut rows: Vec<Vec<String>> = article_at
        .iter()
        .map(|(at, r)| margins_row(&label(TABLE1_RIG, at), r, &at.margins))
        .collect();
    rows.extend(
        identified_at
            .iter()
            .map(|(at, r)| margins_row(&label(IDENTIFIED_RIG, at), r, &at.margins)),
    );
    run.table(
        "Margins of the position loop (the article §2.3.3) against the mean chamber pressure, each row naming its rig",
        &MARGIN_HEADER,
        rows,
    );
    run.text(&format!(
        "The first three rows are {basis}: the article's basis, and that of every 1 and 10 bar number \
         compared with the article's. The last three are {IDENTIFIED_RIG}: β_e follows its own gas \
         fraction X = {x:.5}, fitted to the identified β = {:.1} bar at the records' mean pressure \
         {p_mean:.2} bar; they differ from the first three by that rig's other parameters and by \
         the two gas fractions.",
        nominal.beta_bar
    ));
    let freqs = lti::log_grid(0.01, 100.0, 401);
    let mut series = Vec::new();
    let mut markers = Vec::new();
    for (at, r) in &article_at {
        let name = format!("{:.1} bar, β_e {:.1} bar", at.p_bar, at.beta_bar);
        series.push(bode_series(r, &name, &freqs)?);
        markers.push(Some(bode_markers(&at.margins)));
    }
    let title = "Bode diagram for β_e at 1 bar, 4.4 bar and 10 bar (the article's Table 1 rig)";
    run.figure(
        "bode_pressure",
        Source::Article(13),
        &format!("Bode diagram of the position loop for β_e at {LOW_BAR} bar, at {} bar (β {} bar) and at {HIGH_BAR} bar, on {basis}, under the article's constant-gas-fraction model (the other models: the table below)", article::P_FIT_BAR, table1.beta_bar),
        &Chart::bode(title, series, markers),
    )?;
    run.compare(
        "GM, the article's Table 1 rig (dB)",
        fmt_opt(table1_m.gain_margin_db, 2),
        &format!("{}", printed::GM_DB),
        "-",
    );
    run.compare(
        "PM, the article's Table 1 rig (deg)",
        fmt_opt(table1_m.phase_margin_deg, 1),
        &format!("{}", printed::PM_DEG),
        "-",
    );
    run.compare(
        "GM / PM, the rig identified from the records",
        format!(
            "{} dB / {} deg",
            fmt_opt(nominal_m.gain_margin_db, 2),
            fmt_opt(nominal_m.phase_margin_deg, 1)
        ),
        "-",
        "-",
    );
    let [(low, low_rig), _, (high, high_rig)] = &article_at;
    let article_basis = [
        article_row(run, &table1, &table1_m, low, low_rig)?,
        article_row(run, &table1, &table1_m, high, high_rig)?,
    ];
    let truth_x = truth.effects.gas_fraction.unwrap_or(f64::NAN);
    run.compare(
        "gas fraction X",
        format!("{x_article:.5} ({TABLE1_RIG}: β 165 bar at 4.4 bar); {x:.5} (identified β at {p_mean:.2} bar)"),
        &format!("{} %", 100.0 * printed::GAS_FRACTION),
        &format!("{truth_x:.5}"),
    );
    let intro = intro_example();
    run.compare(
        "introduction: β_e at 100 bar / at 1 bar for X = 1 % (bar), and their ratio",
        format!(
            "{:.0} / {:.1} ({:.1}×)",
            intro.beta_100bar, intro.beta_1bar, intro.ratio
        ),
        &format!(
            "about {} / about {} ({}×)",
            printed::INTRO_BETA_100BAR,
            printed::INTRO_BETA_1BAR,
            printed::INTRO_RATIO
        ),
        "-",
    );
    forty_fold(run, &intro, table1.beta_bar, nominal.beta_bar);
    let models = other_models(run, &table1, &article_at)?;
    let [(p1bar, _), (p_fit, _), (p10bar, _)] = article_at;
    let [(id_low, _), (id_mean, _), (id_high, _)] = identified_at;
    Ok(Pressure {
        study: summary::MarginsStudy {
            rig: basis,
            default_rig: table1_m,
            p1bar: summary::ArticleAtPressure {
                at: p1bar,
                article: article_basis[0].clone(),
            },
            p_fit,
            p10bar: summary::ArticleAtPressure {
                at: p10bar,
                article: article_basis[1].clone(),
            },
            identified_rig: summary::IdentifiedPressures {
                rig: IDENTIFIED_RIG.to_string(),
                gas_fraction: x,
                nominal: nominal_m,
                p1bar: id_low,
                p_mean: id_mean,
                p10bar: id_high,
            },
            models,
        },
        gas_fraction: x,
        gas_fraction_article_basis: x_article,
        intro,
        p_mean_bar: p_mean,
    })
}

/// The article's extrapolation beside the other models of β(p) fitted to the same 165 bar at
/// 4.4 bar (docs/bulk-modulus.md#a-family-of-models): β_e and the margins at 1 and 10 bar under
/// each, and the band they span.
fn other_models(
    run: &mut Run,
    table1: &Rig,
    article_at: &[(AtPressure, Rig); 3],
) -> Result<Vec<summary::ModelExtrapolation>> {
    let pressures = [LOW_BAR, HIGH_BAR];
    let reading = pumpcyl::bulk::ARTICLE_READING;
    let family = crate::bulk::Family::fit(reading, BETA_OIL_BAR, &pressures);
    let mut rows = Vec::new();
    let mut out = Vec::new();
    let mut band = [(f64::INFINITY, f64::NEG_INFINITY); 2];
    for m in &family.models {
        let x = m
            .gas_fraction
            .ok_or_else(|| anyhow::anyhow!("{}: no fit", m.model.name()))?;
        let lowest = lowest_level(table1, |p| m.model.beta_bar(x, p, BETA_OIL_BAR))?;
        out.push(summary::ModelExtrapolation {
            model: m.model,
            gas_fraction: x,
            beta_1bar: m.beta_bar[0],
            beta_10bar: m.beta_bar[1],
            lowest_level_bar: lowest,
        });
        let mut row = vec![m.model.name().to_string()];
        for (k, beta) in m.beta_bar.iter().enumerate() {
            band[k] = (band[k].0.min(*beta), band[k].1.max(*beta));
            let r = Rig {
                beta_bar: *beta,
                ..table1.clone()
            };
            let mm = margins_of(&r)?;
            row.push(format!(
                "{beta:.1} bar: GM {} dB, PM {} deg",
                fmt_opt(mm.gain_margin_db, 2),
                fmt_opt(mm.phase_margin_deg, 1)
            ));
        }
        row.push(lowest.map_or("none up to 100 bar".into(), |p| format!("{p:.2} bar")));
        rows.push(row);
    }
    let t = Targets::default();
    run.table(
        &format!("β_e at {LOW_BAR} and {HIGH_BAR} bar from the same 165 bar at 4.4 bar under each model of β against pressure, the margins of {TABLE1_RIG} there (isothermal air, all of it dissolved at 30 bar in the last), and the lowest mean pressure at which that loop has PM >= {} deg and GM >= {} dB (pumpcyl's default targets; docs/bulk-modulus.md#a-family-of-models)", t.pm_deg, t.gm_db),
        &["model", "1 bar", "10 bar", "lowest level meeting the targets"],
        rows,
    );
    let lowest: Vec<f64> = out.iter().filter_map(|m| m.lowest_level_bar).collect();
    run.compare_why(
        "lowest mean chamber pressure at which the article's loop (Kp 25) meets PM 34 deg and GM 6 dB, over the models of β(p)",
        format!(
            "{} (the article's model); {:.2}–{:.2} bar over the family",
            out[0].lowest_level_bar.map_or("none".into(), |p| format!("{p:.2} bar")),
            lowest.iter().copied().fold(f64::INFINITY, f64::min),
            lowest.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        ),
        "-",
        "-",
        "which pressure level a circuit needs moves with the model of β(p): one identification cannot settle it (docs/bulk-modulus.md#several-pressure-levels)",
    );
    run.compare_why(
        "β_e at 1 bar / 10 bar under the other models of β(p) fitted to 165 bar at 4.4 bar (bar)",
        format!(
            "{:.1} / {:.1} (the article's model); {:.1}–{:.1} / {:.1}–{:.1} over the family",
            article_at[0].0.beta_bar, article_at[2].0.beta_bar, band[0].0, band[0].1, band[1].0, band[1].1
        ),
        "as low as 38 / up to 370",
        "-",
        "one identification at one pressure cannot tell the models apart: the extrapolation holds only as far as its model (docs/bulk-modulus.md#a-family-of-models)",
    );
    Ok(out)
}

/// Bisection steps of [`lowest_level`]: 100 bar to 0.01 bar in fewer than 14; 40 leaves room.
const LEVEL_STEPS: usize = 40;

/// The lowest mean chamber pressure (bar, to 0.01 bar, between 0.01 and 100 bar) at which
/// `rig` with β_e `beta_at(p)` meets pumpcyl's default targets; `None` where 100 bar does not
/// (β_e rises with pressure under every model, and the margins with β_e on this rig).
fn lowest_level(rig: &Rig, beta_at: impl Fn(f64) -> f64) -> Result<Option<f64>> {
    let t = Targets::default();
    let meets = |p: f64| -> Result<bool> {
        let m = margins_of(&Rig {
            beta_bar: beta_at(p),
            ..rig.clone()
        })?;
        let pm = m.phase_margin_deg.unwrap_or(f64::INFINITY);
        let gm = m.gain_margin_db.unwrap_or(f64::INFINITY);
        Ok(m.closed_loop_stable && pm >= t.pm_deg && gm >= t.gm_db)
    };
    let (mut lo, mut hi) = (0.01, 100.0);
    if !meets(hi)? {
        return Ok(None);
    }
    for _ in 0..LEVEL_STEPS {
        if hi - lo < 0.005 {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if meets(mid)? {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok(Some(hi))
}

/// The article's introduction: a gas fraction of 1 % and β_e at 100 bar against 1 bar.
fn intro_example() -> summary::IntroExample {
    let at = |p: f64| bulk::effective_beta(printed::INTRO_GAS_FRACTION, p, BETA_OIL_BAR);
    let (beta_100bar, beta_1bar) = (at(100.0), at(1.0));
    summary::IntroExample {
        gas_fraction: printed::INTRO_GAS_FRACTION,
        beta_100bar,
        beta_1bar,
        ratio: beta_100bar / beta_1bar,
        article_beta_100bar: printed::INTRO_BETA_100BAR,
        article_beta_1bar: printed::INTRO_BETA_1BAR,
        article_ratio: printed::INTRO_RATIO,
        forty_fold: beta_100bar / printed::BETA_BAR,
        article_forty_fold: printed::FORTY_FOLD,
    }
}

/// The article's §4: the identified β against β_e of a 100 bar system with 1 % of air,
/// "approximately forty-fold" lower, computed.
fn forty_fold(run: &mut Run, intro: &summary::IntroExample, table1_beta: f64, identified: f64) {
    run.compare_why(
        "§4: β_e at 100 bar for X = 1 % over the identified β",
        format!(
            "{:.0} / {table1_beta:.0} = {:.1}× ({TABLE1_RIG}); {:.1}× (identified β {identified:.1} bar)",
            intro.beta_100bar,
            intro.beta_100bar / table1_beta,
            intro.beta_100bar / identified
        ),
        &format!(
            "approximately forty-fold ({} / {} = {:.1})",
            printed::INTRO_BETA_100BAR,
            printed::BETA_BAR,
            printed::INTRO_BETA_100BAR / printed::BETA_BAR
        ),
        "-",
        "the article's own numbers give 38, which it rounds to forty",
    );
}

/// The Kp (on `rig`) that meets the phase margin `pm_deg` alone.
fn kp_for_pm(rig: &Rig, pm_deg: f64) -> Result<f64> {
    let same_pm = Targets {
        pm_deg,
        gm_db: 0.0,
        stroke_mm: 0.0,
        ..Targets::default()
    };
    Ok(pumpcyl::design::kp_max(rig, &same_pm)?)
}

/// The article's margins at one pressure and the Kp that keeps a margin there, on its basis:
/// `table1` (margins `m0` at 4.4 bar), `at` on `rig` (its β_e at that pressure). At 1 bar the
/// article's claim keeps the gain margin ("below 25 % of Kp"); at 10 bar it keeps the phase
/// margin, computed both on its printed 34° and on pumpcyl's 33.5°.
fn article_row(
    run: &mut Run,
    table1: &Rig,
    m0: &lti::Margins,
    at: &AtPressure,
    rig: &Rig,
) -> Result<summary::ArticleBasis> {
    let p = at.p_bar;
    let (gm_a, pm_a) = if p < article::P_FIT_BAR {
        (printed::GM_1BAR_DB, printed::PM_1BAR_DEG)
    } else {
        (printed::GM_10BAR_DB, printed::PM_10BAR_DEG)
    };
    let pm0 = m0.phase_margin_deg.unwrap_or(f64::NAN);
    let gm0 = m0.gain_margin_db.unwrap_or(f64::NAN);
    let m = &at.margins;
    let (gm, pm) = (
        m.gain_margin_db.unwrap_or(f64::NAN),
        m.phase_margin_deg.unwrap_or(f64::NAN),
    );
    let why = if agrees(gm, gm_a, 0.1) && agrees(pm, pm_a, if p < 5.0 { 1.0 } else { 0.1 }) {
        ""
    } else {
        "the margins are computed exactly from the 10-state model; the article reads them off MATLAB's margin"
    };
    run.compare_why(
        &format!(
            "GM / PM at {p} bar, β_e {:.1} bar, {TABLE1_RIG}",
            at.beta_bar
        ),
        format!("{gm:.2} dB / {pm:.1} deg"),
        &format!("{gm_a} dB / {pm_a} deg"),
        "-",
        why,
    );
    // the loop gain scales with Kp, so the GM moves by 20 log10 of the Kp ratio
    let same_gm = 10f64.powf((gm - gm0) / 20.0);
    let kp_same_pm = kp_for_pm(rig, pm0)?;
    let kp_article_pm = kp_for_pm(rig, printed::PM_DEG)?;
    let gm_at_article_pm = gm - 20.0 * (kp_article_pm / table1.kp).log10();
    if p < 5.0 {
        let ok = same_gm < printed::KP_RATIO_1BAR_BELOW;
        run.compare_why(
            &format!("Kp keeping the 4.4 bar GM ({gm0:.2} dB) at {p} bar, {TABLE1_RIG}"),
            format!(
                "{:.1} % of Kp ({:.2})",
                100.0 * same_gm,
                same_gm * table1.kp
            ),
            &format!("below {:.0} % of Kp", 100.0 * printed::KP_RATIO_1BAR_BELOW),
            "-",
            &format!(
                "{}keeping the PM ({pm0:.1} deg) instead needs {:.1} % of Kp",
                if ok { "" } else { "NOT REPRODUCED; " },
                100.0 * kp_same_pm / table1.kp
            ),
        );
    } else {
        let change = kp_article_pm / table1.kp - 1.0;
        let ok = (change - printed::KP_CHANGE_10BAR).abs() <= 0.05;
        run.compare_why(
            &format!(
                "Kp keeping the article's PM ({} deg) at {p} bar, {TABLE1_RIG}",
                printed::PM_DEG
            ),
            format!(
                "{:.2} ({:+.1} %), GM there {gm_at_article_pm:.1} dB",
                kp_article_pm,
                100.0 * change
            ),
            &format!("about +{:.0} %", 100.0 * printed::KP_CHANGE_10BAR),
            "-",
            &format!(
                "{}on pumpcyl's own PM ({pm0:.1} deg): {:.2} ({:+.1} %)",
                if ok { "" } else { "NOT REPRODUCED; " },
                kp_same_pm,
                100.0 * (kp_same_pm / table1.kp - 1.0)
            ),
        );
    }
    Ok(summary::ArticleBasis {
        kp_same_pm,
        kp_change: kp_same_pm / table1.kp - 1.0,
        kp_same_gm_ratio: same_gm,
        kp_article_pm,
        kp_article_pm_change: kp_article_pm / table1.kp - 1.0,
        gain_margin_at_kp_article_pm_db: gm_at_article_pm,
        article: summary::GmPm {
            gain_margin_db: gm_a,
            phase_margin_deg: pm_a,
        },
    })
}
