//! The studies on the identified rig: the bulk modulus against pressure (docs/bulk-modulus.md),
//! the damping studies (the article's Figures 11 and 14), the stroke (§3.3, Figure 15), the sinusoidal
//! tracking (docs/simulation.md#tracking-metrics) and the design check (§2.2).

use super::summary::{self, AtPressure, Case, ResonanceCase};
use super::{
    agrees, bode_series, margins_of, margins_row, printed, variants, Position, Run, Source, Study,
    MARGIN_HEADER,
};
use crate::figures::{bode_markers, Chart};
use crate::format::fmt_opt;
use anyhow::Result;
use pumpcyl::bulk::{self, gas_fraction, BETA_OIL_BAR};
use pumpcyl::design::{design, Targets};
use pumpcyl::emulator::article;
use pumpcyl::ident::Experiment;
use pumpcyl::lti;
use pumpcyl::model::Plant;
use pumpcyl::response::ARTICLE_SINE_CASES;
use pumpcyl::rig::Rig;

/// Where the Figure 14 resonance is looked for (Hz): the hydraulic–mechanical mode.
const RESONANCE_BAND_HZ: (f64, f64) = (0.1, 10.0);

/// The pressure study's result: the margins, and the gas fraction and mean pressure they rest
/// on.
pub(super) struct Pressure {
    pub study: summary::MarginsStudy,
    pub gas_fraction: f64,
    pub gas_fraction_article_basis: f64,
    pub intro: summary::IntroExample,
    pub p_mean_bar: f64,
}

/// Step 5: gas fraction from the identified β, β_e over 1–10 bar and the margins there (§7).
pub(super) fn pressure_study(
    run: &mut Run,
    nominal: &Rig,
    exp: &Experiment,
    truth: &article::Truth,
) -> Result<Pressure> {
    run.step("Bulk modulus against pressure: gas fraction and margins (docs/bulk-modulus.md)");
    let p_mean = exp.mean_chamber_pressure_bar().unwrap_or(f64::NAN);
    let x = gas_fraction(nominal.beta_bar, p_mean, BETA_OIL_BAR)?;
    let pressures = [1.0, p_mean, 10.0];
    let rows = bulk::table(nominal, x, BETA_OIL_BAR, &pressures)?;
    let fine = bulk::table(
        nominal,
        x,
        BETA_OIL_BAR,
        &pumpcyl::ident::spaced(1.0, 10.0, 91, false),
    )?;
    let fit = (nominal.beta_bar, p_mean, BETA_OIL_BAR);
    run.figure(
        "bulk_modulus",
        Source::Article(12),
        "Effective bulk modulus and margins against mean chamber pressure (gas-fraction model, identified rig; \
         the comparison table's 1 and 10 bar rows use the article's basis, the default rig)",
        &Chart::bulk_modulus(fit, x, &fine),
    )?;
    let freqs = lti::log_grid(0.01, 100.0, 401);
    let mut series = Vec::new();
    let mut markers = Vec::new();
    let mut table = Vec::new();
    let nominal_m = margins_of(nominal)?;
    let default_m = margins_of(&Rig::default())?;
    table.push(margins_row("identified rig (nominal)", nominal, &nominal_m));
    table.push(margins_row(
        "default rig (the article §2.1)",
        &Rig::default(),
        &default_m,
    ));
    let mut at = Vec::new();
    for row in &rows {
        let rig = Rig {
            beta_bar: row.beta_bar,
            ..nominal.clone()
        };
        let m = margins_of(&rig)?;
        let label = format!(
            "identified rig at {:.1} bar, β_e {:.0} bar",
            row.p_bar, row.beta_bar
        );
        table.push(margins_row(&label, &rig, &m));
        series.push(bode_series(&rig, &label, &freqs)?);
        markers.push(Some(bode_markers(&m)));
        at.push(AtPressure {
            p_bar: row.p_bar,
            beta_bar: row.beta_bar,
            margins: m,
        });
    }
    let [p1bar, p_mean_at, p10bar]: [AtPressure; 3] = at
        .try_into()
        .map_err(|_| anyhow::anyhow!("three pressures"))?;
    run.table(
        "Margins of the position loop (the article §2.3.3), each row on its rig: the pressure rows on the identified rig (the comparison table's 1 and 10 bar rows are on the article's basis, the default rig)",
        &MARGIN_HEADER,
        table,
    );
    let x_article = gas_fraction(article::BETA_FIT_BAR, article::P_FIT_BAR, BETA_OIL_BAR)?;
    let basis = format!(
        "These rows are the identified rig: β_e follows the gas fraction X = {x:.5} fitted to the identified β = {:.1} bar          at the identification records' mean pressure {p_mean:.2} bar. The comparison table's 1 and 10 bar rows are on the          article's basis instead (the default rig, X = {x_article:.5} from its β 165 bar at 4.4 bar), so their margins differ          from these by the rigs' other parameters and the two gas fractions.",
        nominal.beta_bar
    );
    run.text(&basis);
    let title = "Bode diagram for β_e at 1 bar, the mean pressure and 10 bar (identified rig)";
    run.figure(
        "bode_pressure",
        Source::Article(13),
        &format!("{title}. {basis}"),
        &Chart::bode(title, series, markers),
    )?;
    run.compare(
        "GM, default rig (dB)",
        fmt_opt(default_m.gain_margin_db, 2),
        &format!("{}", printed::GM_DB),
        "-",
    );
    run.compare(
        "PM, default rig (deg)",
        fmt_opt(default_m.phase_margin_deg, 1),
        &format!("{}", printed::PM_DEG),
        "-",
    );
    run.compare(
        "GM / PM, identified rig",
        format!(
            "{} dB / {} deg",
            fmt_opt(nominal_m.gain_margin_db, 2),
            fmt_opt(nominal_m.phase_margin_deg, 1)
        ),
        "-",
        "-",
    );
    let article_basis = pressure_numbers(run)?;
    let truth_x = truth.effects.gas_fraction.unwrap_or(f64::NAN);
    run.compare_why(
        "gas fraction X",
        format!("{x_article:.5} (its basis: β 165 bar at 4.4 bar); {x:.5} (identified β at {p_mean:.2} bar)"),
        &format!("{} %", 100.0 * printed::GAS_FRACTION),
        &format!("{truth_x:.5}"),
        "",
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
    Ok(Pressure {
        study: summary::MarginsStudy {
            nominal: nominal_m,
            default_rig: default_m,
            p1bar,
            p_mean: p_mean_at,
            p10bar,
            article_basis,
        },
        gas_fraction: x,
        gas_fraction_article_basis: x_article,
        intro,
        p_mean_bar: p_mean,
    })
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
    }
}

/// The Kp (on `rig`) that meets the phase margin `pm_deg` alone.
fn kp_for_pm(rig: &Rig, pm_deg: f64) -> Result<f64> {
    let same_pm = Targets {
        pm_deg,
        gm_db: 0.0,
        stroke_mm: 0.0,
        ..Targets::article()
    };
    Ok(pumpcyl::design::kp_max(rig, &same_pm)?)
}

/// The article's margins at 1 and 10 bar and the Kp that keeps a margin there, on its own
/// basis: the default rig, β_e from 165 bar at 4.4 bar (the article's bulk-modulus study). At
/// 1 bar the article's claim keeps the gain margin ("below 25 % of Kp"); at 10 bar it keeps
/// the phase margin, computed both on its printed 34° and on pumpcyl's 33.5°.
fn pressure_numbers(run: &mut Run) -> Result<Vec<summary::ArticleBasis>> {
    let rig = Rig::default();
    let x = gas_fraction(rig.beta_bar, article::P_FIT_BAR, BETA_OIL_BAR)?;
    let m0 = margins_of(&rig)?;
    let pm0 = m0.phase_margin_deg.unwrap_or(f64::NAN);
    let gm0 = m0.gain_margin_db.unwrap_or(f64::NAN);
    let cases = [
        (1.0, printed::GM_1BAR_DB, printed::PM_1BAR_DEG),
        (10.0, printed::GM_10BAR_DB, printed::PM_10BAR_DEG),
    ];
    let mut out = Vec::new();
    for (p, gm_a, pm_a) in cases {
        let r = Rig {
            beta_bar: bulk::effective_beta(x, p, BETA_OIL_BAR),
            ..rig.clone()
        };
        let m = margins_of(&r)?;
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
            &format!("GM / PM at {p} bar, β_e {:.1} bar, default rig", r.beta_bar),
            format!("{gm:.2} dB / {pm:.1} deg"),
            &format!("{gm_a} dB / {pm_a} deg"),
            "-",
            why,
        );
        // the loop gain scales with Kp, so the GM moves by 20 log10 of the Kp ratio
        let same_gm = 10f64.powf((gm - gm0) / 20.0);
        let kp_same_pm = kp_for_pm(&r, pm0)?;
        let kp_article_pm = kp_for_pm(&r, printed::PM_DEG)?;
        let gm_at_article_pm = gm - 20.0 * (kp_article_pm / rig.kp).log10();
        if p < 5.0 {
            let ok = same_gm < printed::KP_RATIO_1BAR_BELOW;
            run.compare_why(
                &format!("Kp keeping the 4.4 bar GM ({gm0:.2} dB) at {p} bar, default rig"),
                format!("{:.1} % of Kp ({:.2})", 100.0 * same_gm, same_gm * rig.kp),
                &format!("below {:.0} % of Kp", 100.0 * printed::KP_RATIO_1BAR_BELOW),
                "-",
                &format!(
                    "{}keeping the PM ({pm0:.1} deg) instead needs {:.1} % of Kp",
                    if ok { "" } else { "NOT REPRODUCED; " },
                    100.0 * kp_same_pm / rig.kp
                ),
            );
        } else {
            let change = kp_article_pm / rig.kp - 1.0;
            let ok = (change - printed::KP_CHANGE_10BAR).abs() <= 0.05;
            run.compare_why(
                &format!(
                    "Kp keeping the article's PM ({} deg) at {p} bar, default rig",
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
                    100.0 * (kp_same_pm / rig.kp - 1.0)
                ),
            );
        }
        out.push(summary::ArticleBasis {
            p_bar: p,
            beta_bar: r.beta_bar,
            gain_margin_db: m.gain_margin_db,
            phase_margin_deg: m.phase_margin_deg,
            kp_same_pm,
            kp_change: kp_same_pm / rig.kp - 1.0,
            kp_same_gm_ratio: same_gm,
            kp_article_pm,
            kp_article_pm_change: kp_article_pm / rig.kp - 1.0,
            gain_margin_at_kp_article_pm_db: gm_at_article_pm,
            article: summary::GmPm {
                gain_margin_db: gm_a,
                phase_margin_deg: pm_a,
            },
        });
    }
    Ok(out)
}

/// Step 6: the damping studies. The article's Figure 14 is cumulative: the original; c12, c1
/// and c2 all divided by 10; then also the motor coupling removed. Its Figure 11 removes the
/// drive velocity feedforward; the first-order motor is pumpcyl's own study.
pub(super) fn damping_study(run: &mut Run, nominal: &Rig) -> Result<summary::Damping> {
    run.step("Damping studies: leakage and motor coupling (Figure 14), the drive feedforward (Figure 11), a first-order motor (pumpcyl's own)");
    let tenth = Rig {
        c12_m5_per_ns: nominal.c12_m5_per_ns / 10.0,
        c1_m5_per_ns: nominal.c1_m5_per_ns / 10.0,
        c2_m5_per_ns: nominal.c2_m5_per_ns / 10.0,
        ..nominal.clone()
    };
    let uncoupled = Rig {
        motor_coupling: false,
        ..tenth.clone()
    };
    let fig14 = vec![
        ("identified rig".to_string(), nominal.clone()),
        ("c12, c1, c2 / 10".to_string(), tenth),
        (
            "c12, c1, c2 / 10, motor coupling removed".to_string(),
            uncoupled,
        ),
    ];
    let study = Study {
        stem: "fig14_damping",
        what: "Figure 14, cumulative damping study",
        position: Position::Absolute,
        bode: Source::Article(14),
        step: Source::Own,
    };
    let cases = variants(run, &study, &fig14)?;
    let mut rows = Vec::new();
    let mut figure14 = Vec::new();
    for ((label, rig), case) in fig14.iter().zip(cases) {
        let poles = lti::eigenvalues(&Plant::new(rig).open_loop(false).a)?;
        let r = lti::resonance(&poles, RESONANCE_BAND_HZ.0, RESONANCE_BAND_HZ.1);
        let (f, z) = r.map_or((None, None), |r| (Some(r.natural_freq_hz), r.damping));
        rows.push(vec![label.clone(), fmt_opt(f, 3), fmt_opt(z, 3)]);
        figure14.push(ResonanceCase {
            case,
            resonance_hz: f,
            damping_ratio: z,
        });
    }
    run.table(
        "Figure 14: least-damped open-loop pole pair between 0.1 and 10 Hz (the resonance)",
        &["case", "resonance (Hz)", "damping ratio"],
        rows,
    );
    let third = &figure14[2];
    run.compare(
        "Figure 14, third curve: resonance (Hz) / damping ratio",
        format!(
            "{} / {}",
            fmt_opt(third.resonance_hz, 3),
            fmt_opt(third.damping_ratio, 3)
        ),
        "about 0.8 / lightly damped",
        "-",
    );
    let with = |f: &dyn Fn(&mut Rig), label: &str| {
        let mut r = nominal.clone();
        f(&mut r);
        vec![
            ("identified rig".to_string(), nominal.clone()),
            (label.to_string(), r),
        ]
    };
    let motor = with(
        &|r| r.motor_model = pumpcyl::rig::MotorModel::FirstOrder,
        "first-order motor",
    );
    let study = Study {
        stem: "motor_first_order",
        what: "first-order motor model (pumpcyl's own study)",
        position: Position::Absolute,
        bode: Source::Own,
        step: Source::Own,
    };
    let motor = variants(run, &study, &motor)?;
    let ff = with(&|r| r.feedforward = false, "feedforward off");
    let study = Study {
        stem: "fig11_feedforward",
        what: "Figure 11, drive velocity feedforward removed",
        position: Position::Absolute,
        bode: Source::Article(11),
        step: Source::Article(11),
    };
    let ff = variants(run, &study, &ff)?;
    feedforward_rows(run, &ff);
    Ok(summary::Damping {
        figure14,
        first_order_motor: motor,
        feedforward_off: ff,
    })
}

/// The article's Figure 11 in numbers: the step's overshoot and peak time and the gain margin,
/// with and without the drive velocity feedforward.
fn feedforward_rows(run: &mut Run, cases: &[Case]) {
    let cell = |c: &Case| {
        c.step.map_or("unstable".to_string(), |s| {
            format!("{:.1} % at {:.2} s", s.overshoot_pct, s.peak_time_s)
        })
    };
    let [with, without] = cases else { return };
    run.compare_why(
        "Figure 11: 5 mm step overshoot and peak time, with / without feedforward",
        format!("{} / {}", cell(with), cell(without)),
        "its Figure 11: the response changes drastically without it",
        "-",
        "read the article's two curves against these numbers",
    );
    run.compare(
        "Figure 11: GM with / without feedforward, identified rig (dB)",
        format!(
            "{} / {}",
            fmt_opt(with.margins.gain_margin_db, 2),
            fmt_opt(without.margins.gain_margin_db, 2)
        ),
        &format!("{} (default rig) / -", printed::GM_DB),
        "-",
    );
}

/// Step 7: margins over the stroke, mass and volumes following it (the article §3.3; docs/model.md#variants).
pub(super) fn stroke_study(run: &mut Run, nominal: &Rig) -> Result<summary::Stroke> {
    run.step("Stroke: margins at -50, 0 and +50 mm (the article §3.3)");
    let at = |dx: f64| -> Result<(String, Rig)> {
        let mass = nominal.mass_at(nominal.mass_kg, nominal.x0_mm + dx)?;
        let label = if dx == 0.0 {
            format!("x0 = {} mm, {mass:.0} kg", nominal.x0_mm)
        } else {
            format!("{dx:+} mm, {mass:.0} kg")
        };
        let rig = Rig {
            x0_mm: nominal.x0_mm + dx,
            mass_kg: mass,
            ..nominal.clone()
        };
        Ok((label, rig))
    };
    let rigs = vec![at(-STROKE_MM)?, at(0.0)?, at(STROKE_MM)?];
    let study = Study {
        stem: "stroke",
        what: "stroke positions",
        position: Position::AboutX0,
        bode: Source::Article(15),
        step: Source::Article(15),
    };
    let cases: Vec<Case> = variants(run, &study, &rigs)?;
    let (article_basis, article_reproduced) = stroke_numbers(run)?;
    Ok(summary::Stroke {
        cases,
        article_basis,
        article_reproduced,
    })
}

/// The article's stroke study: x0 ± 50 mm, the mass following the rig's `mass_by_position`
/// (9958 and 12373 kg on the article's rig).
const STROKE_MM: f64 = 50.0;

/// Largest GM change (dB) that reads as "virtually unchanged".
const GM_UNCHANGED_DB: f64 = 0.3;

/// Largest GM change (dB) that reads as "increases slightly".
const GM_SLIGHT_DB: f64 = 2.0;

/// The margin changes at ±50 mm on the default rig under each reading of the article's
/// Figure 15 (mass and volumes moved together, as pumpcyl's stroke study does; the mass alone;
/// the volumes alone), each checked against the article's four statements.
fn stroke_numbers(run: &mut Run) -> Result<(Vec<summary::StrokeBasis>, bool)> {
    let rig = Rig::default();
    let m0 = margins_of(&rig)?;
    let change = |r: &Rig| -> Result<summary::MarginChange> {
        let m = margins_of(r)?;
        let d = |a: Option<f64>, b: Option<f64>| a.zip(b).map_or(f64::NAN, |(a, b)| a - b);
        Ok(summary::MarginChange {
            pm_change_deg: d(m.phase_margin_deg, m0.phase_margin_deg),
            gm_change_db: d(m.gain_margin_db, m0.gain_margin_db),
        })
    };
    let mut out = Vec::new();
    let printed = [
        (printed::PM_CHANGE_MINUS50_DEG, 0.1, "virtually unchanged"),
        (printed::PM_CHANGE_PLUS50_DEG, 1.0, "increases slightly"),
    ];
    for (dx, (pm_article, pm_digit, gm_article)) in [-STROKE_MM, STROKE_MM].into_iter().zip(printed)
    {
        let mass = rig.mass_at(rig.mass_kg, rig.x0_mm + dx)?;
        let moved = |x: bool, m: bool| Rig {
            x0_mm: if x { rig.x0_mm + dx } else { rig.x0_mm },
            mass_kg: if m { mass } else { rig.mass_kg },
            ..rig.clone()
        };
        let readings = summary::StrokeReadings {
            mass_and_volumes: change(&moved(true, true))?,
            mass_alone: change(&moved(false, true))?,
            volumes_alone: change(&moved(true, false))?,
        };
        let gm_fits = |c: &summary::MarginChange| {
            if dx < 0.0 {
                c.gm_change_db.abs() <= GM_UNCHANGED_DB
            } else {
                c.gm_change_db > 0.0 && c.gm_change_db <= GM_SLIGHT_DB
            }
        };
        let fits =
            |c: &summary::MarginChange| agrees(c.pm_change_deg, pm_article, pm_digit) && gm_fits(c);
        out.push(summary::StrokeBasis {
            dx_mm: dx,
            mass_kg: mass,
            pm_change_deg: readings.mass_and_volumes.pm_change_deg,
            gm_change_db: readings.mass_and_volumes.gm_change_db,
            article_pm_change_deg: pm_article,
            article_gm_change: gm_article.to_string(),
            fits: [
                fits(&readings.mass_and_volumes),
                fits(&readings.mass_alone),
                fits(&readings.volumes_alone),
            ],
            readings,
        });
    }
    let reproduced = (0..3).any(|k| out.iter().all(|b| b.fits[k]));
    let tried = out
        .iter()
        .map(|b| {
            let r = &b.readings;
            let f = |c: &summary::MarginChange| {
                format!("{:+.1} deg / {:+.2} dB", c.pm_change_deg, c.gm_change_db)
            };
            format!(
                "at {:+} mm: mass and volumes {}, mass alone {}, volumes alone {}",
                b.dx_mm,
                f(&r.mass_and_volumes),
                f(&r.mass_alone),
                f(&r.volumes_alone)
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    let why = if reproduced {
        String::new()
    } else {
        format!(
            "NOT REPRODUCED: no single reading of the article's Figure 15 gives all four of its statements (PM, GM): {tried}"
        )
    };
    let see_above = if reproduced {
        String::new()
    } else {
        "NOT REPRODUCED (the first Figure 15 row says why)".to_string()
    };
    for (k, b) in out.iter().enumerate() {
        run.compare_why(
            &format!(
                "Figure 15: PM change at {:+} mm of stroke, default rig (deg)",
                b.dx_mm
            ),
            format!("{:+.1}", b.pm_change_deg),
            &format!("{:+}", b.article_pm_change_deg),
            "-",
            if k == 0 { &why } else { &see_above },
        );
        run.compare_why(
            &format!(
                "Figure 15: GM change at {:+} mm of stroke, default rig (dB)",
                b.dx_mm
            ),
            format!("{:+.2}", b.gm_change_db),
            &b.article_gm_change,
            "-",
            &see_above,
        );
    }
    Ok((out, reproduced))
}

/// Step 9: the design check of the article §2.2 on the identified rig.
pub(super) fn design_check(run: &mut Run, nominal: &Rig) -> Result<(summary::DesignCheck, f64)> {
    run.step("Design check: the article §2.2 at the identified operating point");
    let targets = Targets {
        pm_deg: 34.0,
        gm_db: 6.0,
        stroke_mm: 50.0,
        p_mean_bar: vec![],
        p_beta_bar: 4.4,
        mass_kg: vec![4898.0, nominal.mass_kg],
        waves: ARTICLE_SINE_CASES.to_vec(),
    };
    let d = design(nominal, &targets)?;
    // the same check with one mass over the whole stroke, as before the geometry tied them
    let constant = design(
        &Rig {
            mass_by_position: vec![],
            ..nominal.clone()
        },
        &targets,
    )?;
    let verdict = |v| crate::design::verdict_text(v);
    run.table(
        "Design (targets PM 34 deg, GM 6 dB; stroke ±50 mm; loads 4898 and 10593 kg at x0, the mass following the stroke as the rig's geometry ties them)",
        &["quantity", "value"],
        vec![
            vec![
                "largest Kp at the design point".into(),
                format!("{:.2}", d.kp_max),
            ],
            vec![
                "largest Kp at every condition".into(),
                format!("{:.2}", d.kp_max_worst_case),
            ],
            vec!["verdict".into(), verdict(d.verdict).into()],
            vec!["why".into(), d.reasons.join("; ")],
            vec![
                "with one mass over the whole stroke instead: largest Kp at every condition, verdict".into(),
                format!(
                    "{:.2}, {}",
                    constant.kp_max_worst_case,
                    verdict(constant.verdict)
                ),
            ],
        ],
    );
    run.compare_why(
        "design: largest Kp at every stroke point and load, the mass following the stroke",
        format!(
            "{:.2} ({}); one mass over the stroke: {:.2} ({})",
            d.kp_max_worst_case,
            verdict(d.verdict),
            constant.kp_max_worst_case,
            verdict(constant.verdict)
        ),
        "x0 − 50 mm with 9958 kg, x0 + 50 mm with 12373 kg",
        "-",
        "the article pairs each stroke point with its mass; so does pumpcyl (the rig's mass_by_position)",
    );
    run.compare(
        "design: largest Kp for PM 34 deg",
        format!("{:.2}", d.kp_max),
        &format!("{} (kept)", printed::KP),
        "-",
    );
    let kp_max = d.kp_max;
    Ok((
        summary::DesignCheck {
            kp_max,
            kp_max_worst_case: d.kp_max_worst_case,
            verdict: d.verdict,
            reasons: d.reasons,
            targets: d.targets,
            kp_max_worst_case_constant_mass: constant.kp_max_worst_case,
            verdict_constant_mass: constant.verdict,
            article_kp: printed::KP,
        },
        kp_max,
    ))
}
