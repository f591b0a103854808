//! Step 9, "How sure are we": what the article's single worst-case identification leaves
//! open. The profile-likelihood intervals of β, b and c12 from the identification records
//! (docs/identification.md, "Uncertainty"), the design that holds over that whole confidence
//! region, the stroke and the pressure (docs/design.md#robust-design; it automates the
//! article's §2.2 advice to lower the leakage estimate and repeat), and which further record
//! would narrow the intervals most (docs/identification.md, "Experiment advice").

use super::summary::{AdviceSummary, HowSure, PerParameter, RobustSummary};
use super::{Run, Source};
use crate::advise::width_text;
use crate::figures::{parameter_value, Chart, PARAMETER_AXES, PARAMETER_NAMES};
use anyhow::Result;
use pumpcyl::design::robust::{Binding, RobustOptions};
use pumpcyl::design::{robust_design, Region, RobustDesign, Targets};
use pumpcyl::ident::{advise, analyze, Advice, AdviceOptions, Candidate, Experiment, Uncertainty};
use pumpcyl::ident::{UncertaintyOptions, PARAMETERS};
use pumpcyl::rig::Rig;

/// Confidence level of the intervals and of the region the design holds over.
pub(super) const CONFIDENCE: f64 = 0.95;
/// Candidate experiments listed in the report (the best first).
const LISTED: usize = 6;

/// What the step found, typed.
#[derive(Debug, Clone)]
pub struct Certainty {
    /// The intervals and profiles.
    pub uncertainty: Uncertainty,
    /// The design over the confidence region.
    pub robust: RobustDesign,
    /// The candidate further records.
    pub advice: Advice,
}

/// Step 9: intervals, robust design and experiment advice on the identification records;
/// `nominal` is the identified rig, `p_mean_bar` the mean chamber pressure (bar) its β holds
/// at, `truth` the (β, b, c12) the records were emulated with.
pub(super) fn how_sure(
    run: &mut Run,
    exp: &Experiment,
    nominal: &Rig,
    p_mean_bar: f64,
    truth: &Candidate,
) -> Result<(Certainty, HowSure)> {
    run.step("How sure are we (pumpcyl's own study, not in the article): intervals, a design that holds over them, the next experiment");
    let best = Candidate {
        beta_bar: nominal.beta_bar,
        viscous_friction_ns_per_m: nominal.viscous_friction_ns_per_m,
        c12_m5_per_ns: nominal.c12_m5_per_ns,
    };
    let opts = UncertaintyOptions {
        confidence: CONFIDENCE,
        ..UncertaintyOptions::default()
    };
    let u = analyze(&exp.problem, &best, &opts)?;
    intervals(run, &u, &best, truth)?;
    let region = Region::around(best, &u, exp.problem.standstill);
    let targets = Targets::default().over_records(exp);
    debug_assert_eq!(targets.p_beta_bar, Some(p_mean_bar));
    let d = robust_design(nominal, &region, &targets, &RobustOptions::default())?;
    robust(run, &d)?;
    // the article's kinds of record (steps, sines); step 11 sets a sweep beside them
    let steps_and_sines = AdviceOptions {
        sweeps: false,
        ..AdviceOptions::default()
    };
    let advice = advise(&exp.problem, &best, &steps_and_sines)?;
    next_experiment(run, &advice);
    let v = HowSure {
        confidence: CONFIDENCE,
        noise_std_mm: u.noise_std_mm,
        variance_inflation: u.variance_inflation,
        intervals: PerParameter::from_fn(|_, n| u.profile(n).map(|p| p.interval)),
        identifiable: PerParameter::from_fn(|_, n| u.profile(n).is_some_and(|p| p.identifiable)),
        truth_inside: PerParameter::from_fn(|i, _| inside(&u, i, truth)),
        robust_design: RobustSummary {
            kp_max: d.kp_max,
            kp_max_nominal: d.kp_max_nominal,
            deciding: d.deciding,
            worst_case: d.worst_case,
            steps: d.steps.clone(),
            verdict: d.verdict,
            reasons: d.reasons.clone(),
        },
        advice: AdviceSummary {
            current: advice.current,
            best_for: advice.best_for.clone(),
            top: advice.candidates.iter().take(LISTED).cloned().collect(),
        },
    };
    Ok((
        Certainty {
            uncertainty: u,
            robust: d,
            advice,
        },
        v,
    ))
}

/// The value of parameter `i` (of [`PARAMETERS`]) at `c`.
fn value_of(c: &Candidate, i: usize) -> f64 {
    [c.beta_bar, c.viscous_friction_ns_per_m, c.c12_m5_per_ns][i]
}

/// Whether parameter `i`'s interval holds the emulator's truth.
fn inside(u: &Uncertainty, i: usize, truth: &Candidate) -> bool {
    let t = value_of(truth, i);
    u.profile(PARAMETERS[i])
        .is_some_and(|p| p.interval[0] <= t && t <= p.interval[1])
}

/// The intervals table and the three profile figures; `identified` is the identification's
/// answer (step 2).
fn intervals(
    run: &mut Run,
    u: &Uncertainty,
    identified: &Candidate,
    truth: &Candidate,
) -> Result<()> {
    run.text(&format!(
        "The article identifies β and the leakage at one worst-case point and gives no error \
         bars. Profiling the identification cost (for each value of one parameter, the least \
         cost over the other two) and reading the {:.0} % region off it with the χ²₁ threshold \
         gives the intervals below. The noise level σ = {:.4} mm comes from the residuals; \
         they are correlated (lag-1 autocorrelation {:.2}), so σ² is inflated {:.1}-fold \
         (docs/identification.md, \"Uncertainty\"). The identification's answer (step 2) \
         minimises the mean position MSE of the records; the profiles minimise the summed squared \
         error with each record's initial offset fitted, so their least point differs: little where the \
         records bound a parameter, much along one they do not.",
        CONFIDENCE * 100.0,
        u.noise_std_mm,
        u.residual_autocorrelation,
        u.variance_inflation
    ));
    let rows = u
        .profiles
        .iter()
        .map(|p| {
            let i = crate::figures::parameter_index(p.parameter);
            vec![
                PARAMETER_AXES[i].to_string(),
                parameter_value(i, value_of(identified, i)),
                parameter_value(i, value_of(&u.best, i)),
                format!(
                    "{} .. {}",
                    parameter_value(i, p.interval[0]),
                    parameter_value(i, p.interval[1])
                ),
                if p.identifiable {
                    "yes".into()
                } else {
                    "no: the profile stays below the threshold up to a search bound".into()
                },
                format!(
                    "{} ({})",
                    parameter_value(i, value_of(truth, i)),
                    if inside(u, i, truth) {
                        "inside"
                    } else {
                        "OUTSIDE"
                    }
                ),
            ]
        })
        .collect();
    run.table(
        &format!(
            "{:.0} % profile-likelihood intervals from the emulated identification records",
            CONFIDENCE * 100.0
        ),
        &[
            "parameter",
            "identified (step 2)",
            "least-SSE point of the profiles",
            "interval",
            "identifiable",
            "emulator truth",
        ],
        rows,
    );
    for p in &u.profiles {
        run.figure(
            &format!("profile-{}", p.parameter),
            Source::Own,
            &format!(
                "Likelihood profile of {}: where it stays below the dashed threshold is the {:.0} % interval",
                PARAMETER_NAMES[crate::figures::parameter_index(p.parameter)],
                CONFIDENCE * 100.0
            ),
            &Chart::profile(u, p),
        )?;
    }
    Ok(())
}

/// The robust design: gains, deciding condition, the leakage loop and the stroke figure.
fn robust(run: &mut Run, d: &RobustDesign) -> Result<()> {
    let binding = match d.deciding.binding {
        Binding::PhaseMargin => "the phase margin",
        Binding::GainMargin => "the gain margin",
        Binding::Stability => "stability",
    };
    run.text(&format!(
        "With the targets {}, at the mean chamber pressures {} bar the records span (β_e \
         following the gas-fraction model), the largest Kp at the point estimate is {:.2}; over \
         the whole {:.0} % region, the stroke and those pressures it is {:.2}. It is decided by \
         {binding} at {} (docs/design.md#robust-design). The verdict:",
        crate::origin::targets(d.targets.pm_deg, d.targets.gm_db, d.targets.stroke_mm),
        d.targets
            .p_mean_bar
            .iter()
            .map(|p| format!("{p:.2}"))
            .collect::<Vec<_>>()
            .join(", "),
        d.kp_max_nominal,
        CONFIDENCE * 100.0,
        d.kp_max,
        d.deciding.at.describe(),
    ));
    run.blocks.push(crate::html::Block::List(d.reasons.clone()));
    run.compare_why(
        "largest Kp for PM 34 deg (the article's design result) and GM 6 dB (pumpcyl's choice) over the 95 % region, stroke and pressures",
        format!("{:.2}", d.kp_max),
        "- (no uncertainty given)",
        "-",
        &format!(
            "the article designs at the point estimate (pumpcyl there: {:.2}); over the region {binding} decides",
            d.kp_max_nominal
        ),
    );
    run.blocks
        .push(crate::design::leakage_loop_table(d).block());
    run.figure(
        "robust-margins",
        Source::Own,
        "Margins over the stroke at the robust Kp, at the parameters that decide it",
        &Chart::robust_margins(d),
    )
}

/// The candidate records ranked by the expected interval widths, and the one that helps b most.
fn next_experiment(run: &mut Run, a: &Advice) {
    let mut rows = vec![{
        let mut r = vec!["none (the records as they are)".to_string()];
        r.extend(a.current.iter().map(width_text));
        r
    }];
    rows.extend(a.candidates.iter().take(LISTED).map(|c| {
        let mut r = vec![c.label.clone()];
        r.extend(c.widths.iter().map(width_text));
        r
    }));
    run.table(
        "Expected width of each 95 % interval, relative to the estimate, after adding one more \
         record (linearised model, docs/identification.md, \"Experiment advice\")",
        &["record added", "β", "b", "c12"],
        rows,
    );
    run.text(&format!(
        "The record that narrows b most: {}. For β: {}; for c12: {}. {} candidate(s) were \
         left out (an unstable or barely damped loop, or motors beyond their speed).",
        a.best_for[1],
        a.best_for[0],
        a.best_for[2],
        a.skipped.len()
    ));
}
