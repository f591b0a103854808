//! The identification steps: the drive gain (the article §2.4.1), the leakages and the
//! two-stage grid identification (§2.4), and the robustness record.

use super::{printed, summary, Run, Source, IDENTIFIED_RIG, TABLE1_RIG};
use crate::figures::Chart;
use crate::identification as outputs;
use anyhow::Result;
use pumpcyl::emulator::article;
use pumpcyl::ident::{
    identify_drive, DatasetSpec, DriveRecord, Experiment, Grid, Options, Prepared, Problem, Request,
};
use pumpcyl::record::Record;
use pumpcyl::response::Signals;
use pumpcyl::rig::Rig;
use std::path::Path;
use std::time::Instant;

/// Step 1: Km from the drive step (the article §2.4.1).
pub(super) fn drive_step(run: &mut Run) -> Result<(summary::Drive, f64)> {
    run.step("Drive gain from the drive step (the article §2.4.1)");
    let rec = DriveRecord::read_in(&article::Embedded, &run.record("drive_step.csv"))?;
    let si = Rig::default().si();
    let fit = identify_drive(&rec, si.jm[0], si.omega_i)?;
    run.figure(
        "drive_step",
        Source::Article(5),
        "Drive 1 alone, feedforward off: emulated speed step and the identified model",
        &Chart::drive_step(&rec, &fit).relabel("measured", "emulated"),
    )?;
    run.compare(
        "drive gain Km (N·m·s/rad)",
        format!("{:.4}", fit.km_nms_per_rad),
        &format!("{}", printed::KM),
        "0.026",
    );
    Ok((
        summary::Drive {
            km_nms_per_rad: fit.km_nms_per_rad,
            mse_rpm2: fit.mse_rpm2,
            article_km_nms_per_rad: printed::KM,
        },
        fit.km_nms_per_rad,
    ))
}

/// Step 2: leakage from standstill, the two-stage grid and Nelder–Mead (the article §2.4; docs/identification.md).
pub(super) fn identification(
    run: &mut Run,
    truth: &article::Truth,
) -> Result<(Experiment, Rig, summary::Identified, f64)> {
    run.step("Leakage from standstill and the two-stage grid identification (the article §2.4)");
    // result.json names the experiment as it lies in the result folder, records/identify.toml
    let exp = Experiment::load_in(&article::Embedded, &run.record("identify.toml"))?;
    let request = exp.request(exp.options());
    let total = request.candidates();
    let on_candidates = run.opts.on_candidates;
    let t0 = Instant::now();
    let id = request.run(&|n| on_candidates.is_none_or(|f| f(n, total)))?;
    let v = outputs::identification_json(&exp, &id, t0.elapsed().as_secs_f64())?;
    for (name, bytes) in outputs::files(&exp, &id, &v)? {
        if name == "landscape.svg" || name.starts_with("fit-") && name.ends_with(".svg") {
            let svg = String::from_utf8(bytes.clone())?;
            let (source, caption) = match name.strip_prefix("fit-") {
                None => (
                    Source::Own,
                    format!(
                        "Identification cost over β and c12 on the emulated records: the slice at b = {} N·s/m, \
                         the refined grid's best b (after pumpcyl's local refinement the answer has b = {:.0} N·s/m)",
                        id.grid_best.candidate.viscous_friction_ns_per_m,
                        id.best().candidate.viscous_friction_ns_per_m
                    ),
                ),
                Some(rest) => {
                    let i: usize = rest.trim_end_matches(".svg").parse()?;
                    let ds = &exp.problem.datasets[i - 1];
                    let source = match i {
                        1 => Source::ArticleWithPanels(6, &[(7, "pressure"), (8, "motor-velocity")]),
                        _ => Source::Article(9),
                    };
                    (source, format!(
                        "The model of {IDENTIFIED_RIG} against the emulated {} (Kp = {}): position, error, pressures, motor speeds; the dashed grey line ends the fit window",
                        ds.name,
                        ds.rig.kp
                    ))
                }
            };
            let stem = Path::new("identification").join(name.trim_end_matches(".svg"));
            run.inline(&svg, &stem.to_string_lossy(), source, &caption);
        }
        run.files
            .push((Path::new("identification").join(name), bytes));
    }
    let best = id.best();
    let l = id.leakage;
    let s = exp.problem.standstill;
    let nominal = Rig {
        beta_bar: best.candidate.beta_bar,
        viscous_friction_ns_per_m: best.candidate.viscous_friction_ns_per_m,
        c12_m5_per_ns: best.candidate.c12_m5_per_ns,
        c1_m5_per_ns: l.c1_m5_per_ns,
        c2_m5_per_ns: l.c2_m5_per_ns,
        ..exp.rig.clone()
    };
    let truth_rig = &truth.rig;
    let truth_beta = truth_rig.beta_bar;
    run.text(&format!(
        "Standstill record means: ω1 {:.1} rpm, ω2 {:.1} rpm, p1 {:.3} bar (p2 {:.3} bar from the force balance). \
         {} candidates in {:.2} s; the emulator's truth is beta_e = {truth_beta:.0} bar at the mean pressure, \
         c12 = {:.1e} m⁵/(N·s). The friction b absorbs the emulator's {} N Coulomb friction, \
         which the LTI model lacks.",
        s.w1_rpm, s.w2_rpm, s.p1_bar, l.p2_bar, id.evaluated(), t0.elapsed().as_secs_f64(),
        truth_rig.c12_m5_per_ns, truth.effects.coulomb_n
    ));
    let rows = [
        (
            "bulk modulus β (bar)",
            format!("{:.1}", nominal.beta_bar),
            "165",
            format!("{truth_beta:.1}"),
            "",
        ),
        (
            "viscous friction b (N·s/m)",
            format!("{:.0}", nominal.viscous_friction_ns_per_m),
            "100",
            format!("{:.0}", truth_rig.viscous_friction_ns_per_m),
            "b absorbs the emulator's 15 N Coulomb friction, which the LTI model lacks",
        ),
        (
            "cross-port leakage c12 (m⁵/(N·s))",
            format!("{:.3e}", nominal.c12_m5_per_ns),
            "1.2e-10",
            format!("{:.1e}", truth_rig.c12_m5_per_ns),
            "",
        ),
    ];
    let standstill =
        "from the identified c12 by the standstill balance, on the emulated standstill record";
    let leakages = [
        (
            "c1 (m⁵/(N·s))",
            l.c1_m5_per_ns,
            "5.49e-11",
            truth_rig.c1_m5_per_ns,
        ),
        (
            "c2 (m⁵/(N·s))",
            l.c2_m5_per_ns,
            "-1.19e-11",
            truth_rig.c2_m5_per_ns,
        ),
    ]
    .map(|(quantity, value, printed, truth)| {
        (
            quantity,
            format!("{value:.3e}"),
            printed,
            format!("{truth:.2e}"),
            standstill,
        )
    });
    let first = &id.stages[0].summary;
    let first_best = first.top.first().map_or(f64::NAN, |c| c.cost_mm2);
    for (quantity, ours, article, truth, why) in rows.into_iter().chain(leakages) {
        run.compare_why(quantity, ours, article, &truth, why);
    }
    run.compare_why(
        "identification cost (mm²)",
        format!("{:.4}", best.cost_mm2),
        &format!("{}", printed::COST_MM2),
        "-",
        "the residual on emulated records (5 um noise), not on the article's measurements",
    );
    run.compare_why(
        "first grid: best cost (mm²) / candidates below 0.25 mm²",
        format!("{first_best:.4} / {}", first.threshold_count),
        &format!(
            "{} / {}",
            printed::FIRST_GRID_BEST_MM2,
            printed::FIRST_GRID_BELOW
        ),
        "-",
        "records emulated, not the article's: costs and counts are not comparable (docs/choices.md#the-article-against-itself on the 48)",
    );
    run.compare_why(
        "first grid: bounds of the threshold set (β bar, b N·s/m, c12 m⁵/(N·s))",
        first.threshold_bounds.map_or("-".into(), |b| bounds_text(&b)),
        &bounds_text(&printed::FIRST_GRID_BOUNDS),
        "-",
        "they set the refined grid; pumpcyl's refined grid is the article's (docs/identification.md)",
    );
    let grid = &id.grid_best;
    let edges = id.grid_best_edges();
    let edge_text: Vec<String> = pumpcyl::ident::PARAMETERS
        .iter()
        .zip(edges)
        .filter_map(|(name, e)| {
            e.map(|(lo, hi)| format!("{name} on the grid's edge ({lo} … {hi})"))
        })
        .collect();
    let truth_point = pumpcyl::ident::Candidate {
        beta_bar: truth_beta,
        viscous_friction_ns_per_m: truth_rig.viscous_friction_ns_per_m,
        c12_m5_per_ns: truth_rig.c12_m5_per_ns,
    };
    let (bias, bias_why) = super::bias::bias(
        run,
        &exp.problem,
        (grid.candidate, grid.cost_mm2),
        &truth_point,
    )?;
    run.compare_why(
        "the refined grid alone, the article's method: β (bar) / b (N·s/m) / c12",
        format!(
            "{:.0} / {:.0} / {:.2e}",
            grid.candidate.beta_bar,
            grid.candidate.viscous_friction_ns_per_m,
            grid.candidate.c12_m5_per_ns
        ),
        &format!("{} / {} / {:.1e}", printed::BETA_BAR, printed::B_NS_PER_M, printed::C12),
        &format!(
            "{truth_beta:.0} / {:.0} / {:.1e}",
            truth_point.viscous_friction_ns_per_m, truth_point.c12_m5_per_ns
        ),
        &format!(
            "{bias_why} (the table in step 2); the rows above add pumpcyl's Nelder–Mead refinement after the grid, a step the article does not take{}",
            if edge_text.is_empty() {
                String::new()
            } else {
                format!("; {}: the optimum may lie outside it", edge_text.join(", "))
            }
        ),
    );
    let identified = summary::Identified {
        beta_bar: nominal.beta_bar,
        viscous_friction_ns_per_m: nominal.viscous_friction_ns_per_m,
        c12_m5_per_ns: nominal.c12_m5_per_ns,
        cost_mm2: best.cost_mm2,
        first_grid: summary::FirstGrid {
            best_cost_mm2: first_best,
            below_threshold: first.threshold_count,
            bounds: first.threshold_bounds,
            article_best_cost_mm2: printed::FIRST_GRID_BEST_MM2,
            article_below_threshold: printed::FIRST_GRID_BELOW,
            article_bounds: printed::FIRST_GRID_BOUNDS,
        },
        grid_only: summary::GridOnly {
            beta_bar: grid.candidate.beta_bar,
            viscous_friction_ns_per_m: grid.candidate.viscous_friction_ns_per_m,
            c12_m5_per_ns: grid.candidate.c12_m5_per_ns,
            cost_mm2: grid.cost_mm2,
            on_edge: summary::PerParameter::from_fn(|k, _| edges[k].is_some()),
            bias,
        },
        candidates_evaluated: id.evaluated(),
        emulator_truth: summary::BetaC12 {
            beta_bar: truth_beta,
            c12_m5_per_ns: truth_rig.c12_m5_per_ns,
        },
        article: summary::ArticleIdentified {
            beta_bar: printed::BETA_BAR,
            viscous_friction_ns_per_m: printed::B_NS_PER_M,
            c12_m5_per_ns: printed::C12,
            cost_mm2: printed::COST_MM2,
        },
        leakage: summary::Leakage {
            w1_rpm: s.w1_rpm,
            w2_rpm: s.w2_rpm,
            p1_bar: s.p1_bar,
            p2_bar: l.p2_bar,
            c1_m5_per_ns: l.c1_m5_per_ns,
            c2_m5_per_ns: l.c2_m5_per_ns,
            article: summary::ChamberLeakages {
                c1_m5_per_ns: printed::C1,
                c2_m5_per_ns: printed::C2,
            },
        },
    };
    Ok((exp, nominal, identified, best.cost_mm2))
}

/// Step 3: the robustness record (m = 4898 kg, Kp = 40): a β × c12 grid at the identified b.
pub(super) fn robustness(
    run: &mut Run,
    exp: &Experiment,
    nominal: &Rig,
) -> Result<summary::Robustness> {
    run.step("Robustness record: m = 4898 kg, Kp = 40 (the article §2.4)");
    let rig = Rig {
        k_pres_per_bar: article::k_pres_for_mass(4898.0),
        ..nominal.clone()
    };
    let spec = DatasetSpec {
        file: "robustness.csv".into(),
        kp: 40.0,
        mass_kg: 4898.0,
        fit_end_s: article::STEP_AT_S + article::fit_window_s(40.0),
    };
    let record = Record::read_in(&article::Embedded, &run.record("robustness.csv"))?;
    let problem = Problem {
        datasets: vec![Prepared::new(&spec, record.clone(), &rig)?],
        standstill: exp.problem.standstill,
    };
    let grid = Grid {
        beta_bar: pumpcyl::ident::stepped(100.0, 400.0, 5.0),
        viscous_friction_ns_per_m: vec![nominal.viscous_friction_ns_per_m],
        c12_m5_per_ns: pumpcyl::ident::spaced(0.5e-10, 2.5e-10, 21, false),
    };
    let opts = Options {
        auto_refine: false,
        local_refinement: false,
        threshold_mm2: 0.25,
        top_n: 1,
    };
    let id = Request::new(&problem, (grid, None), opts).run(&|_| true)?;
    let best = id.best().candidate;
    let ds = &problem.datasets[0];
    let article_candidate = pumpcyl::ident::Candidate {
        beta_bar: printed::ROBUST_BETA_BAR,
        viscous_friction_ns_per_m: nominal.viscous_friction_ns_per_m,
        c12_m5_per_ns: printed::ROBUST_C12,
    };
    let sim_best = problem.simulate(&best, ds)?;
    let sim_article = problem.simulate(&article_candidate, ds)?;
    let cost_article = problem.dataset_mse(&article_candidate, ds);
    let measured = Signals::of_record(&record);
    let series = [
        (
            format!(
                "model, best fit: β {:.0} bar, c12 {:.2e}",
                best.beta_bar, best.c12_m5_per_ns
            ),
            &sim_best,
        ),
        (
            "model, article: β 220 bar, c12 1.0e-10".to_string(),
            &sim_article,
        ),
    ];
    let subtitle = format!(
        "cost {:.4} mm² (best fit), {cost_article:.4} mm² (article's values); c12 in m⁵/(N·s)",
        id.best().cost_mm2
    );
    run.figure(
        "robustness",
        Source::Article(10),
        &format!("The emulated robustness record (another day's gas fraction: β_e 220 bar at its operating pressure) against the model of {IDENTIFIED_RIG} at 4898 kg and Kp 40, with β and c12 fitted to this record and with the article's values"),
        &Chart::signals_of("Robustness record: m = 4898 kg, Kp = 40 (emulated)", Some(&subtitle), &series, Some(("emulated", &measured)), Some(spec.fit_end_s)),
    )?;
    run.compare(
        "robustness β (bar)",
        format!("{:.0}", best.beta_bar),
        "220",
        "220",
    );
    run.compare_why(
        "robustness c12 (m⁵/(N·s))",
        format!("{:.2e}", best.c12_m5_per_ns),
        "1.0e-10",
        "1.2e-10",
        "the emulated record keeps the emulator's c12; only its gas fraction differs from the others",
    );
    Ok(summary::Robustness {
        beta_bar: best.beta_bar,
        c12_m5_per_ns: best.c12_m5_per_ns,
        cost_mm2: id.best().cost_mm2,
        cost_at_article_values_mm2: cost_article,
        emulator_truth_beta_bar: article::BETA_ROBUSTNESS_BAR,
        article: summary::BetaC12 {
            beta_bar: printed::ROBUST_BETA_BAR,
            c12_m5_per_ns: printed::ROBUST_C12,
        },
    })
}

/// Bounds of β (bar), b (N·s/m) and c12 (m⁵/(N·s)), as "lo–hi" or "= v" where they meet.
fn bounds_text(b: &[[f64; 2]; 3]) -> String {
    let one = |[lo, hi]: [f64; 2], digits: usize, sci: bool| {
        let f = |v: f64| {
            if sci {
                format!("{v:.1e}")
            } else {
                format!("{v:.digits$}")
            }
        };
        if lo == hi {
            format!("= {}", f(lo))
        } else {
            format!("{}–{}", f(lo), f(hi))
        }
    };
    format!(
        "β {}, b {}, c12 {}",
        one(b[0], 0, false),
        one(b[1], 0, false),
        one(b[2], 0, true)
    )
}

/// The emulated records' operating conditions beside the article's: the sum-pressure
/// set-point, the standstill point and the identification step's mean chamber pressures.
pub(super) fn conditions(
    run: &mut Run,
    exp: &Experiment,
    truth: &article::Truth,
) -> Result<summary::Conditions> {
    let s = exp.problem.standstill;
    let rec = &exp.problem.datasets[0].record;
    let mean = |p: &Option<Vec<f64>>| {
        p.as_ref()
            .map_or(f64::NAN, |p| p.iter().sum::<f64>() / p.len() as f64)
    };
    let step_mean_p_bar = [mean(&rec.p1_bar), mean(&rec.p2_bar)];
    // the article's standstill p1 and its force balance give p2 (the article §2.4)
    let article_p2_bar = Rig::default().p2_at_rest_bar(printed::STANDSTILL_P1_BAR);
    let out = summary::Conditions {
        p_sum_ref_bar: truth.rig.p_sum_ref_bar,
        article_p_sum_ref_bar: printed::P_SUM_REF_BAR,
        standstill_w_rpm: [s.w1_rpm, s.w2_rpm],
        standstill_p1_bar: s.p1_bar,
        article_standstill_w_rpm: [printed::STANDSTILL_W1_RPM, printed::STANDSTILL_W2_RPM],
        article_standstill_p1_bar: printed::STANDSTILL_P1_BAR,
        article_standstill_p2_bar: article_p2_bar,
        step_mean_p_bar,
        article_step_mean_p_bar: printed::STEP_MEAN_P_BAR,
    };
    run.compare_why(
        "emulated records: sum-pressure set-point (bar)",
        format!("{:.3}", out.p_sum_ref_bar),
        &format!("{}", printed::P_SUM_REF_BAR),
        &format!("{:.3}", out.p_sum_ref_bar),
        &format!(
            "chosen so that the emulated mean chamber pressure at x0 is {} bar, where the article states β 165 bar; \
             the proportional sum-pressure loop holds p1 + p2 below its set-point (docs/emulator.md)",
            article::P_FIT_BAR
        ),
    );
    run.compare_why(
        "standstill: ω1 / ω2 (rpm), p1 (bar)",
        format!("{:.0} / {:.0}, {:.2}", s.w1_rpm, s.w2_rpm, s.p1_bar),
        &format!(
            "{} / {}, {}",
            printed::STANDSTILL_W1_RPM,
            printed::STANDSTILL_W2_RPM,
            printed::STANDSTILL_P1_BAR
        ),
        "-",
        "the emulated chambers sit at the set-point above, not at the article's pressures; the leakages they feed scale with them",
    );
    run.compare_why(
        "identification step: mean p1 / p2 (bar)",
        format!("{:.2} / {:.2}", step_mean_p_bar[0], step_mean_p_bar[1]),
        &format!(
            "{} / {}",
            printed::STEP_MEAN_P_BAR[0],
            printed::STEP_MEAN_P_BAR[1]
        ),
        "-",
        &format!(
            "the emulated pair obeys the force balance at rest p1 A1 − p2 A2 = F_ext; the article's does not: \
             at its own standstill p1 = {} bar the balance gives p2 = {article_p2_bar:.2} bar (docs/choices.md#the-article-against-itself)",
            printed::STANDSTILL_P1_BAR
        ),
    );
    Ok(out)
}

/// The identification step's 10–90 % rise time (the article's Figure 6): the LTI model of the
/// identified rig and the emulated record.
pub(super) fn rise_time(
    run: &mut Run,
    exp: &Experiment,
    nominal: &Rig,
) -> Result<summary::RiseTime> {
    let rec = &exp.problem.datasets[0].record;
    let k0 = rec.first_change();
    let step_mm = rec.x_ref_mm[k0] - rec.x_ref_mm[0];
    let x0 = rec.initial_mean(&rec.x_mm);
    let t: Vec<f64> = rec.time_s[k0..]
        .iter()
        .map(|t| t - rec.time_s[k0])
        .collect();
    let y: Vec<f64> = rec.x_mm[k0..].iter().map(|x| x - x0).collect();
    let emulated = pumpcyl::response::step_metrics(&t, &y, step_mm, step_mm).rise_time_s;
    let lti = |rig: &Rig| -> Result<Option<f64>> {
        let s = pumpcyl::response::step(rig, step_mm, 3.0, 1000.0)?;
        Ok(pumpcyl::response::step_metrics_of(rig, &s, step_mm).rise_time_s)
    };
    let (model, identified) = (lti(&Rig::default())?, lti(nominal)?);
    let fmt = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3}"));
    run.compare(
        "Figure 6: 10–90 % rise time of the identification step (s)",
        format!(
            "{} (LTI model, {TABLE1_RIG}); {} ({IDENTIFIED_RIG})",
            fmt(model),
            fmt(identified)
        ),
        &format!("about {}", printed::RISE_TIME_S),
        &format!("{} (emulated record)", fmt(emulated)),
    );
    Ok(summary::RiseTime {
        model_s: model,
        identified_model_s: identified,
        emulated_s: emulated,
        article_s: printed::RISE_TIME_S,
    })
}
