//! The studies on the identified rig: the bulk modulus against pressure (docs/bulk-modulus.md),
//! the damping studies (the article's Figures 11 and 14), the stroke (§2.1), the sinusoidal
//! tracking (docs/simulation.md#tracking-metrics) and the design check (§2.2).

use super::summary::{self, AtPressure, Case, ResonanceCase};
use super::{
    agrees, bode_series, margins_of, margins_row, printed, variants, Position, Run, MARGIN_HEADER,
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
use pumpcyl::record::Record;
use pumpcyl::response::{simulate, track_metrics, Baseline, Signals, ARTICLE_SINE_CASES};
use pumpcyl::rig::Rig;

/// Where the Figure 14 resonance is looked for (Hz): the hydraulic–mechanical mode.
const RESONANCE_BAND_HZ: (f64, f64) = (0.1, 10.0);

/// The pressure study's result: the margins, and the gas fraction and mean pressure they rest
/// on.
pub(super) struct Pressure {
    pub study: summary::MarginsStudy,
    pub gas_fraction: f64,
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
    let rec = &exp.problem.datasets[0].record;
    let p_mean = rec
        .mean_chamber_pressure_bar()
        .map_or(f64::NAN, |p| p.iter().sum::<f64>() / p.len() as f64);
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
        "Effective bulk modulus and margins against mean chamber pressure (gas-fraction model)",
        &Chart::bulk_modulus(fit, x, &fine),
    )?;
    let freqs = lti::log_grid(0.01, 100.0, 401);
    let mut series = Vec::new();
    let mut markers = Vec::new();
    let mut table = Vec::new();
    let nominal_m = margins_of(nominal)?;
    let default_m = margins_of(&Rig::default())?;
    table.push(margins_row("identified rig (nominal)", &nominal_m));
    table.push(margins_row("default rig (the article §2.1)", &default_m));
    let mut at = Vec::new();
    for row in &rows {
        let rig = Rig {
            beta_bar: row.beta_bar,
            ..nominal.clone()
        };
        let m = margins_of(&rig)?;
        let label = format!("{:.1} bar, β_e {:.0} bar", row.p_bar, row.beta_bar);
        table.push(margins_row(&label, &m));
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
        "Margins of the position loop (the article §2.3.3)",
        &MARGIN_HEADER,
        table,
    );
    run.text(&format!(
        "Gas fraction X = {x:.5} from β = {:.1} bar at the identification records' mean pressure {p_mean:.2} bar.",
        nominal.beta_bar
    ));
    let title = "Bode diagram for β_e at 1 bar, the mean pressure and 10 bar";
    run.figure("bode_pressure", title, &Chart::bode(title, series, markers))?;
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
    run.compare(
        "gas fraction X",
        format!("{x:.5}"),
        "-",
        &format!("{:.5}", truth_x),
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
        p_mean_bar: p_mean,
    })
}

/// The article's margins at 1 and 10 bar and the Kp for the nominal PM there, on its own basis:
/// the default rig, β_e from 165 bar at 4.4 bar (the article's bulk-modulus study).
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
            &format!("GM / PM at {p} bar, β_e {:.1} bar", r.beta_bar),
            format!("{gm:.2} dB / {pm:.1} deg"),
            &format!("{gm_a} dB / {pm_a} deg"),
            "-",
            why,
        );
        let same_pm = Targets {
            pm_deg: pm0,
            gm_db: 0.0,
            stroke_mm: 0.0,
            p_mean_bar: vec![],
            p_beta_bar: article::P_FIT_BAR,
            mass_kg: vec![],
            waves: vec![],
        };
        let kp = pumpcyl::design::kp_max(&r, &same_pm)?;
        let change = kp / rig.kp - 1.0;
        let (article_text, ok) = if p < 5.0 {
            (
                format!("below {:.0} % of Kp", 100.0 * printed::KP_RATIO_1BAR_BELOW),
                kp / rig.kp < printed::KP_RATIO_1BAR_BELOW,
            )
        } else {
            (
                format!("about +{:.0} %", 100.0 * printed::KP_CHANGE_10BAR),
                (change - printed::KP_CHANGE_10BAR).abs() <= 0.05,
            )
        };
        run.compare_why(
            &format!("Kp for the same PM ({pm0:.1} deg) at {p} bar"),
            format!("{kp:.2} ({:+.0} %)", 100.0 * change),
            &article_text,
            "-",
            &if ok {
                String::new()
            } else {
                // the loop gain scales with Kp, so the GM moves by 20 log10 of the Kp ratio
                let same_gm = 10f64.powf((gm - gm0) / 20.0);
                format!(
                    "keeping the GM of 4.4 bar needs {:.0} % of Kp (the article's 'below 25 %'); keeping the PM needs {:.0} %",
                    100.0 * same_gm,
                    100.0 * kp / rig.kp
                )
            },
        );
        out.push(summary::ArticleBasis {
            p_bar: p,
            beta_bar: r.beta_bar,
            gain_margin_db: m.gain_margin_db,
            phase_margin_deg: m.phase_margin_deg,
            kp_same_pm: kp,
            kp_change: change,
            article: summary::GmPm {
                gain_margin_db: gm_a,
                phase_margin_deg: pm_a,
            },
        });
    }
    Ok(out)
}

/// Step 6: the damping studies. The article's Figure 14 is cumulative: the original; c12, c1
/// and c2 all divided by 10; then also the motor coupling removed. The first-order motor
/// (its Figure 11) and the feedforward off (its text) are separate studies.
pub(super) fn damping_study(run: &mut Run, nominal: &Rig) -> Result<summary::Damping> {
    run.step("Damping studies: leakage and motor coupling (Figure 14), motor model (Figure 11), feedforward");
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
    let cases = variants(
        run,
        "fig14_damping",
        "Figure 14, cumulative damping study",
        &fig14,
        Position::Absolute,
    )?;
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
    let motor = variants(
        run,
        "fig11_motor",
        "Figure 11, first-order motor model",
        &motor,
        Position::Absolute,
    )?;
    let ff = with(&|r| r.feedforward = false, "feedforward off");
    let ff = variants(
        run,
        "feedforward",
        "drive feedforward removed",
        &ff,
        Position::Absolute,
    )?;
    Ok(summary::Damping {
        figure14,
        first_order_motor: motor,
        feedforward_off: ff,
    })
}

/// Step 7: margins over the stroke, mass and volumes following it (the article §2.1; docs/model.md#variants).
pub(super) fn stroke_study(run: &mut Run, nominal: &Rig) -> Result<summary::Stroke> {
    run.step("Stroke: margins at -50, 0 and +50 mm (the article §2.1)");
    let at = |dx: f64, mass: f64| Rig {
        x0_mm: nominal.x0_mm + dx,
        mass_kg: mass,
        ..nominal.clone()
    };
    let rigs = vec![
        ("-50 mm, 9958 kg".to_string(), at(-50.0, 9958.0)),
        ("x0 = 345 mm, 10 593 kg".to_string(), nominal.clone()),
        ("+50 mm, 12 373 kg".to_string(), at(50.0, 12373.0)),
    ];
    let cases: Vec<Case> = variants(run, "stroke", "stroke positions", &rigs, Position::AboutX0)?;
    Ok(summary::Stroke {
        cases,
        article_basis: stroke_numbers(run)?,
    })
}

/// The PM changes at ±50 mm the article prints, on the default rig: mass and volumes moved
/// together (what pumpcyl's stroke study does), and the mass alone.
fn stroke_numbers(run: &mut Run) -> Result<Vec<summary::StrokeBasis>> {
    let rig = Rig::default();
    let pm = |r: &Rig| -> Result<f64> { Ok(margins_of(r)?.phase_margin_deg.unwrap_or(f64::NAN)) };
    let pm0 = pm(&rig)?;
    let mut out = Vec::new();
    let cases = [
        (-50.0, 9958.0, printed::PM_CHANGE_MINUS50_DEG),
        (50.0, 12373.0, printed::PM_CHANGE_PLUS50_DEG),
    ];
    for (dx, mass, article_change) in cases {
        let both = pm(&Rig {
            x0_mm: rig.x0_mm + dx,
            mass_kg: mass,
            ..rig.clone()
        })? - pm0;
        let mass_alone = pm(&Rig {
            mass_kg: mass,
            ..rig.clone()
        })? - pm0;
        let why = if agrees(both, article_change, if dx < 0.0 { 0.1 } else { 1.0 }) {
            String::new()
        } else {
            format!(
                "pumpcyl moves mass and volumes together; moving the mass alone gives {mass_alone:+.1} deg"
            )
        };
        run.compare_why(
            &format!("PM change at {dx:+} mm of stroke (deg)"),
            format!("{both:+.1}"),
            &format!("{article_change:+}"),
            "-",
            &why,
        );
        out.push(summary::StrokeBasis {
            dx_mm: dx,
            mass_kg: mass,
            pm_change_deg: both,
            pm_change_mass_alone_deg: mass_alone,
            article_pm_change_deg: article_change,
        });
    }
    Ok(out)
}

/// Step 8: the three sinusoids of the article (docs/simulation.md#tracking-metrics), emulated records against the model.
pub(super) fn tracking(run: &mut Run, nominal: &Rig) -> Result<Vec<summary::Tracking>> {
    run.step("Sinusoidal tracking (docs/simulation.md#tracking-metrics)");
    let files = [
        "sine_0.10hz_50mm.csv",
        "sine_0.20hz_35mm.csv",
        "sine_0.25hz_20mm.csv",
    ];
    let mut out = Vec::new();
    let mut rows = Vec::new();
    for (((f, a), file), article_e) in ARTICLE_SINE_CASES
        .iter()
        .zip(files)
        .zip(printed::TRACK_MAX_ERROR_MM)
    {
        let rec = Record::read_in(&article::Embedded, &run.record(file))?;
        let measured = Signals::of_record(&rec);
        let sim = simulate(
            nominal,
            &rec.time_s,
            &rec.x_ref_mm,
            &Baseline::of_record(&rec, nominal),
        )?;
        // skip the rest before the wave starts (1 s) and its first period
        let start = rec.first_change();
        let tm = |s: &Signals| track_metrics(&s.time_s[start..], &s.e_mm[start..], *f, *a);
        let (m, s) = (tm(&measured), tm(&sim));
        rows.push(vec![
            format!("{f} Hz, ±{a} mm"),
            format!("{article_e}"),
            format!("{:.2}", m.max_error_mm),
            format!("{:.2}", s.max_error_mm),
            format!("{:.1} %", 100.0 * m.wave_reduction),
            format!("{:.1} %", 100.0 * s.wave_reduction),
        ]);
        out.push(summary::Tracking {
            freq_hz: *f,
            amp_mm: *a,
            emulated: m,
            model: s,
            article_measured_max_error_mm: article_e,
        });
        let why = if agrees(s.max_error_mm, article_e, 0.01) {
            String::new()
        } else {
            format!(
                "the article's is measured on the real rig; LTI model {:.2} mm, emulated rig {:.2} mm",
                s.max_error_mm, m.max_error_mm
            )
        };
        run.compare_why(
            &format!("max control error {f} Hz, ±{a} mm (mm)"),
            format!("{:.2} (LTI model)", s.max_error_mm),
            &format!("{article_e} (real rig)"),
            &format!("{:.2} (emulated rig)", m.max_error_mm),
            &why,
        );
        let title = format!("Sinusoid {f} Hz, ±{a} mm: emulated record against the model");
        let subtitle = format!(
            "max |e|: {:.2} mm emulated, {:.2} mm model; wave reduction {:.1} % / {:.1} %",
            m.max_error_mm,
            s.max_error_mm,
            100.0 * m.wave_reduction,
            100.0 * s.wave_reduction
        );
        let series = [("model".to_string(), &sim)];
        let stem = format!("sine_{}hz", format!("{f:.2}").replace('.', "p"));
        let chart = Chart::signals(&title, Some(&subtitle), &series, Some(&measured), None);
        run.figure(&stem, &title, &chart)?;
    }
    run.table(
        "Tracking (after the first period)",
        &[
            "case",
            "max |e| article, real rig (mm)",
            "max |e| emulated (mm)",
            "max |e| model (mm)",
            "wave reduction emulated",
            "wave reduction model",
        ],
        rows,
    );
    Ok(out)
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
    run.table(
        "Design (targets PM 34 deg, GM 6 dB; stroke ±50 mm; masses 4898 and 10 593 kg)",
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
            vec![
                "verdict".into(),
                crate::design::verdict_text(d.verdict).into(),
            ],
            vec!["why".into(), d.reasons.join("; ")],
        ],
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
            article_kp: printed::KP,
        },
        kp_max,
    ))
}
