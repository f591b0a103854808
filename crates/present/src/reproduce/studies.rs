//! The studies on the rig identified from the records, each compared with the article's numbers
//! on its Table 1 rig: the damping studies (the article §3.2, Figures 11 and 14), the stroke
//! (§3.3, Figure 15) and the design check (§2.2).

use super::summary::{self, Case, ResonanceCase};
use super::{
    agrees, margins_of, printed, resonance, variants, Position, Run, Source, Study, IDENTIFIED_RIG,
    TABLE1_RIG,
};
use crate::format::fmt_opt;
use anyhow::Result;
use pumpcyl::design::{design, Targets};
use pumpcyl::response::ARTICLE_SINE_CASES;
use pumpcyl::rig::Rig;

/// Where the Figure 14 resonance is looked for (Hz): the hydraulic–mechanical mode.
const RESONANCE_BAND_HZ: (f64, f64) = (0.1, 10.0);

/// Step 5: the damping studies. The article's Figure 14 is cumulative: the original; c12, c1
/// and c2 all divided by 10; then also the motor coupling removed. Its Figure 11 removes the
/// drive velocity feedforward; the first-order motor is pumpcyl's own study.
pub(super) fn damping_study(run: &mut Run, nominal: &Rig) -> Result<summary::Damping> {
    run.step("Damping studies: leakage and motor coupling (the article §3.2, Figure 14), the drive feedforward (Figure 11), a first-order motor (pumpcyl's own)");
    let fig14 = figure14_rigs(nominal, "identified rig");
    let study = Study {
        stem: "fig14_damping",
        what: "Figure 14, cumulative damping study",
        rig: IDENTIFIED_RIG,
        position: Position::Absolute,
        bode: Source::Article(14),
        step: Source::Extends(14),
    };
    let cases = variants(run, &study, &fig14)?;
    let mut rows = Vec::new();
    let mut figure14 = Vec::new();
    for ((label, rig), case) in fig14.iter().zip(cases) {
        let (f, z) = resonance(rig, RESONANCE_BAND_HZ)?;
        rows.push(vec![label.clone(), fmt_opt(f, 3), fmt_opt(z, 3)]);
        figure14.push(ResonanceCase {
            case,
            resonance_hz: f,
            damping_ratio: z,
        });
    }
    let table1 = Rig::default();
    let (f, z) = resonance(&figure14_rigs(&table1, "")[2].1, RESONANCE_BAND_HZ)?;
    rows.push(vec![
        format!("c12, c1, c2 / 10, motor coupling removed, on {TABLE1_RIG}"),
        fmt_opt(f, 3),
        fmt_opt(z, 3),
    ]);
    run.table(
        &format!("Figure 14: least-damped open-loop pole pair between 0.1 and 10 Hz (the resonance), on {IDENTIFIED_RIG} and, last row, on {TABLE1_RIG}"),
        &["case", "resonance (Hz)", "damping ratio"],
        rows,
    );
    run.compare(
        &format!("Figure 14, third curve: resonance (Hz) / damping ratio, {TABLE1_RIG}"),
        format!("{} / {}", fmt_opt(f, 3), fmt_opt(z, 3)),
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
        rig: IDENTIFIED_RIG,
        position: Position::Absolute,
        bode: Source::Own,
        step: Source::Own,
    };
    let motor = variants(run, &study, &motor)?;
    let ff = with(&|r| r.feedforward = false, "feedforward off");
    let study = Study {
        stem: "fig11_feedforward",
        what: "Figure 11, drive velocity feedforward removed",
        rig: IDENTIFIED_RIG,
        position: Position::Absolute,
        bode: Source::Extends(11),
        step: Source::Article(11),
    };
    let ff = variants(run, &study, &ff)?;
    let table1_rig = feedforward_rows(run, &ff, &table1, (f, z))?;
    Ok(summary::Damping {
        figure14,
        first_order_motor: motor,
        feedforward_off: ff,
        table1_rig,
    })
}

/// The article's Figure 14 cases, cumulative, on `rig` (its own case labelled `as_is`): the
/// rig; c12, c1 and c2 all divided by 10; then also the motor coupling removed.
fn figure14_rigs(rig: &Rig, as_is: &str) -> Vec<(String, Rig)> {
    let tenth = Rig {
        c12_m5_per_ns: rig.c12_m5_per_ns / 10.0,
        c1_m5_per_ns: rig.c1_m5_per_ns / 10.0,
        c2_m5_per_ns: rig.c2_m5_per_ns / 10.0,
        ..rig.clone()
    };
    let uncoupled = Rig {
        motor_coupling: false,
        ..tenth.clone()
    };
    vec![
        (as_is.to_string(), rig.clone()),
        ("c12, c1, c2 / 10".to_string(), tenth),
        (
            "c12, c1, c2 / 10, motor coupling removed".to_string(),
            uncoupled,
        ),
    ]
}

/// The article's Figure 11 in numbers: the step's overshoot and peak time on the identified
/// rig (`cases`), and the gain margin with and without the drive velocity feedforward on the
/// article's Table 1 rig `table1`, whose Figure 14 resonance `fig14` goes with them into the
/// summary.
fn feedforward_rows(
    run: &mut Run,
    cases: &[Case],
    table1: &Rig,
    fig14: (Option<f64>, Option<f64>),
) -> Result<summary::Table1Damping> {
    let cell = |c: &Case| {
        c.step.map_or("unstable".to_string(), |s| {
            format!("{:.1} % at {:.2} s", s.overshoot_pct, s.peak_time_s)
        })
    };
    if let [with, without] = cases {
        run.compare_why(
            &format!("Figure 11: 5 mm step overshoot and peak time, with / without feedforward, {IDENTIFIED_RIG}"),
            format!("{} / {}", cell(with), cell(without)),
            "its Figure 11: the response changes drastically without it",
            "-",
            "read the article's two curves against these numbers",
        );
    }
    let with = margins_of(table1)?;
    let without = margins_of(&Rig {
        feedforward: false,
        ..table1.clone()
    })?;
    run.compare(
        &format!("Figure 11: GM with / without feedforward, {TABLE1_RIG} (dB)"),
        format!(
            "{} / {}",
            fmt_opt(with.gain_margin_db, 2),
            fmt_opt(without.gain_margin_db, 2)
        ),
        &format!("{} / -", printed::GM_DB),
        "-",
    );
    Ok(summary::Table1Damping {
        figure14_third_resonance_hz: fig14.0,
        figure14_third_damping_ratio: fig14.1,
        gain_margin_with_feedforward_db: with.gain_margin_db,
        gain_margin_without_feedforward_db: without.gain_margin_db,
    })
}

/// Step 6: margins over the stroke, mass and volumes following it (the article §3.3; docs/model.md#variants).
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
        rig: IDENTIFIED_RIG,
        position: Position::AboutX0,
        bode: Source::Article(15),
        step: Source::Extends(15),
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
        let pm_fits = |c: &summary::MarginChange| agrees(c.pm_change_deg, pm_article, pm_digit);
        let fits = |c: &summary::MarginChange| pm_fits(c) && gm_fits(c);
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
            pm_reproduced: pm_fits(&readings.mass_and_volumes),
            gm_reproduced: gm_fits(&readings.mass_and_volumes),
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
    // each statement marked on its own; the readings tried go with the first one missed
    let mut readings_told = reproduced;
    let mut mark = |ok: bool| {
        if ok {
            String::new()
        } else if !readings_told {
            readings_told = true;
            format!(
                "NOT REPRODUCED: no single reading of the article's Figure 15 gives all four of its statements (PM, GM): {tried}"
            )
        } else {
            "NOT REPRODUCED (the readings tried are in the first Figure 15 row not reproduced)"
                .to_string()
        }
    };
    for b in &out {
        let (pm_why, gm_why) = (mark(b.pm_reproduced), mark(b.gm_reproduced));
        run.compare_why(
            &format!(
                "Figure 15: PM change at {:+} mm of stroke, {TABLE1_RIG} (deg)",
                b.dx_mm
            ),
            format!("{:+.1}", b.pm_change_deg),
            &format!("{:+}", b.article_pm_change_deg),
            "-",
            &pm_why,
        );
        run.compare_why(
            &format!(
                "Figure 15: GM change at {:+} mm of stroke, {TABLE1_RIG} (dB)",
                b.dx_mm
            ),
            format!("{:+.2}", b.gm_change_db),
            &b.article_gm_change,
            "-",
            &gm_why,
        );
    }
    Ok((out, reproduced))
}

/// The article's loop (its Table 1 rig at Kp 25) as it designs it, continuous, and as its
/// 100 Hz PLC closes it, with the disk margin, and its Nyquist diagram
/// (docs/analysis.md#sampled-data-margins, docs/analysis.md#disk-margins).
fn loop_margins(run: &mut Run) -> Result<summary::LoopMargins> {
    let lp = pumpcyl::loops::Loop::of_rig(Rig::default(), TABLE1_RIG, false);
    let m = pumpcyl::lti::margins(&lp.open_loop)?;
    let s = crate::robustness::Sampled::of_loop(&lp, &m, 0.0)?.expect("a rig's loop names its PLC");
    let disk = pumpcyl::lti::disk_margins(&lp.open_loop, 0.0)?;
    let row = |what: &str, c: Option<f64>, d: Option<f64>, digits: usize| {
        vec![what.to_string(), fmt_opt(c, digits), fmt_opt(d, digits)]
    };
    let disk_row = |d: &pumpcyl::lti::DiskMargins| {
        format!(
            "{:.3} (±{} dB, ±{} deg)",
            d.disk.disk_margin,
            fmt_opt(d.disk.gain_margin_db, 2),
            fmt_opt(d.disk.phase_margin_deg, 1)
        )
    };
    let rate = format!(
        "as its PLC closes it ({} Hz, {} sample of delay)",
        s.plc_rate_hz, s.plc_delay_samples
    );
    run.table(
        &format!("The loop's margins on {TABLE1_RIG} at Kp 25: continuous, as the article designs it, and sampled, as its PLC runs it"),
        &["margin", "continuous", &rate],
        vec![
            row("gain margin (dB)", m.gain_margin_db, s.margins.gain_margin_db, 2),
            row("phase margin (deg)", m.phase_margin_deg, s.margins.phase_margin_deg, 2),
            row("delay margin (s)", m.delay_margin_s, s.margins.delay_margin_s, 4),
            vec!["disk margin alpha (balanced)".into(), disk_row(&disk), disk_row(&s.disk)],
            vec![
                "sensitivity peaks M_s, M_t".into(),
                format!("{:.2}, {:.2}", disk.sensitivity_peak.value, disk.complementary_sensitivity_peak.value),
                format!("{:.2}, {:.2}", s.disk.sensitivity_peak.value, s.disk.complementary_sensitivity_peak.value),
            ],
        ],
    );
    run.compare_why(
        &format!("phase margin the PLC's sampling and delay cost, {TABLE1_RIG}"),
        format!("{} deg", fmt_opt(s.phase_margin_cost_deg, 2)),
        "-",
        "-",
        "the article designs on the continuous loop (§2.2, §3.3); its loop runs at 100 Hz (§2.3.4): a hold and one sample of delay lag 1.5 samples, about 2.8 deg at 0.51 Hz",
    );
    let chart = crate::robustness::nyquist_chart(&lp, 0.0)?;
    run.figure(
        "nyquist",
        Source::Own,
        "Nyquist diagram of the article's loop, continuous and as its PLC samples it, with the unit circle, the critical point and the disk the balanced disk margin keeps the curve from",
        &chart,
    )?;
    let grid = pumpcyl::lti::log_grid(0.01, 100.0, 801);
    let chart = crate::robustness::gang_of_four_chart(&lp, &grid)?;
    run.figure(
        "gang_of_four",
        Source::Own,
        "The gang of four of the article's loop: S and T, the load sensitivity PS (position per unit of command disturbance) and the noise sensitivity CS (command per metre of noise), the PLC's Kp 25 as the controller",
        &chart,
    )?;
    Ok(summary::LoopMargins {
        gain_margin_db: m.gain_margin_db,
        phase_margin_deg: m.phase_margin_deg,
        disk_margin: disk.disk.disk_margin,
        plc_rate_hz: s.plc_rate_hz,
        plc_delay_samples: s.plc_delay_samples,
        sampled_gain_margin_db: s.margins.gain_margin_db,
        sampled_phase_margin_deg: s.margins.phase_margin_deg,
        sampled_disk_margin: s.disk.disk.disk_margin,
        phase_margin_cost_deg: s.phase_margin_cost_deg,
    })
}

/// Step 8: the design check of the article §2.2 on the identified rig.
pub(super) fn design_check(run: &mut Run, nominal: &Rig) -> Result<(summary::DesignCheck, f64)> {
    run.step(&format!(
        "Design check: the article §2.2 at the identified operating point, on {IDENTIFIED_RIG}"
    ));
    let targets = Targets {
        mass_kg: vec![4898.0, nominal.mass_kg],
        waves: ARTICLE_SINE_CASES.to_vec(),
        sampled: false,
        bulk_model: None,
        ..Targets::default()
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
    run.text(&format!(
        "The targets: {}; the article's two loads, {} kg at x0, the mass following the stroke as the rig's geometry ties them.",
        crate::origin::targets(targets.pm_deg, targets.gm_db, targets.stroke_mm),
        targets
            .mass_kg
            .iter()
            .map(|m| format!("{m:.0}"))
            .collect::<Vec<_>>()
            .join(" and ")
    ));
    run.table(
        &format!("Design on {IDENTIFIED_RIG}, the targets above"),
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
        &format!("design: largest Kp at every stroke point and load, the mass following the stroke, {IDENTIFIED_RIG}"),
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
        &format!("design: largest Kp for PM 34 deg and GM 6 dB, {IDENTIFIED_RIG}"),
        format!("{:.2}", d.kp_max),
        &format!("{} (kept)", printed::KP),
        "-",
    );
    let loop_margins = loop_margins(run)?;
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
            loop_margins,
        },
        kp_max,
    ))
}
