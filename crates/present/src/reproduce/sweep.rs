//! Step 12, "A sweep beside the steps" (pumpcyl's own study, not in the article): the
//! article identifies β, b and c12 from steps (§2.4.4), which cannot bound b (step 9). An
//! emulated multisine of the same rig, designed as `pumpcyl frf --design` designs it, is
//! identified in the frequency domain (docs/identification.md#grey-box-fit-to-a-frequency-response)
//! beside the steps: the 95 % intervals from the steps, from the sweep, and from both.

use super::summary::{IntervalSet, PerParameter, SweepBeside};
use super::{Run, Source};
use crate::figures::{parameter_value, trace, Chart, PARAMETER_AXES};
use crate::plot::{LineStyle, Panel};
use anyhow::{anyhow, Result};
use pumpcyl::emulator::article::{self, Truth};
use pumpcyl::emulator::Experiment as Emulation;
use pumpcyl::frf::{self, DesignGoal, Excitation};
use pumpcyl::ident::{
    candidate_values, Candidate, Experiment, FrequencyProblem, Profile, SweepSet, Uncertainty,
};
use pumpcyl::record::Record;

/// Seed of the sweep's sensor noise (the embedded records use 1 to 5).
const SEED: u64 = 6;
/// How far above the truth an interval is drawn (a factor): an unbounded one is cut there.
const DRAWN: f64 = 30.0;

/// Step 12: the multisine emulated on the identification record's `truth`, fitted alone and
/// with the step records of `exp`; `steps` the steps' intervals (step 9) at `confidence`.
pub(super) fn sweep_beside_steps(
    run: &mut Run,
    exp: &Experiment,
    steps: &Uncertainty,
    truth: (&Truth, &Candidate),
    confidence: f64,
) -> Result<SweepBeside> {
    run.step("A sweep beside the steps (pumpcyl's own study, not in the article): β, b and c12 from an emulated multisine, from the steps, and from both");
    let (excitation, record) = emulate(truth.0)?;
    let base = &exp
        .problem
        .datasets
        .first()
        .ok_or_else(|| anyhow!("the identification has no step record"))?
        .rig;
    let sweep = SweepSet::new("sweep.csv", &record, base.clone())?;
    let alone = FrequencyProblem {
        sweeps: vec![sweep],
        steps: None,
        standstill: exp.problem.standstill,
    };
    let both = FrequencyProblem {
        steps: Some(exp.problem.clone().with_sampled_controller()),
        ..alone.clone()
    };
    let fitted = |p: &FrequencyProblem| -> Result<IntervalSet> {
        let fit = p.fit(&exp.first_grid)?;
        let u = p.uncertainty(&fit, confidence)?;
        Ok(interval_set(&fit.best, &u.profiles, truth.1))
    };
    let v = SweepBeside {
        note: "pumpcyl's own study on EMULATED records: the multisine is emulated on the \
               identification record's truth, not measured"
            .into(),
        sweep: describe(&excitation),
        confidence,
        steps: interval_set(&steps.best, &steps.profiles, truth.1),
        sweep_alone: fitted(&alone)?,
        both: fitted(&both)?,
    };
    report(run, &v, truth.1)?;
    Ok(v)
}

/// The multisine designed for the truth's rig and its record as the PLC samples it.
fn emulate(truth: &Truth) -> Result<(Excitation, Record)> {
    let goal = DesignGoal {
        rate_hz: truth.plc.rate_hz,
        ..DesignGoal::default()
    };
    let d = frf::design(&truth.rig, &goal)?;
    let e = Excitation::multisine(
        &truth.rig,
        d.amplitude_mm,
        (d.from_hz, d.to_hz),
        (d.lines, d.periods),
        truth.plc.rate_hz,
    )
    .with_period(d.period_s, truth.plc.rate_hz);
    let plc = pumpcyl::emulator::Plc {
        seed: SEED,
        ..article::plc(SEED)
    };
    let signals = Emulation::Sweep(e).run(&truth.rig, truth.effects, &plc)?;
    let record = Record::parse(crate::records::record_csv(&signals).as_bytes(), "sweep.csv")?;
    Ok((e, record))
}

/// The sweep in one line.
fn describe(e: &Excitation) -> String {
    let (lo, hi) = e.band_hz();
    format!(
        "multisine of {} lines {lo:.3} .. {hi:.2} Hz, ±{:.1} mm, {:.0} s",
        e.frequencies_hz().len(),
        e.amplitude_mm(),
        e.duration_s()
    )
}

/// One record set's answer and intervals beside the truth.
fn interval_set(best: &Candidate, profiles: &[Profile], truth: &Candidate) -> IntervalSet {
    let profile = |n: &str| profiles.iter().find(|p| p.parameter == n);
    IntervalSet {
        best: PerParameter::from_fn(|i, _| value_of(best, i)),
        intervals: PerParameter::from_fn(|_, n| profile(n).map(|p| p.interval)),
        identifiable: PerParameter::from_fn(|_, n| profile(n).is_some_and(|p| p.identifiable)),
        truth_inside: PerParameter::from_fn(|i, n| {
            let t = value_of(truth, i);
            profile(n).is_some_and(|p| p.interval[0] <= t && t <= p.interval[1])
        }),
    }
}

/// The value of parameter `i` (of `pumpcyl::ident::PARAMETERS`) at `c`.
fn value_of(c: &Candidate, i: usize) -> f64 {
    candidate_values(c)[i]
}

/// The three record sets, labelled, in the report's order.
fn sets(v: &SweepBeside) -> [(&'static str, &IntervalSet); 3] {
    [
        ("steps (the article's method)", &v.steps),
        ("sweep", &v.sweep_alone),
        ("steps and sweep", &v.both),
    ]
}

/// The text, the table and the figure.
fn report(run: &mut Run, v: &SweepBeside, truth: &Candidate) -> Result<()> {
    run.text(&format!(
        "The steps cannot bound b (step 9): a step excites the loop little at its resonance. \
         A sweep through the resonance can. pumpcyl emulates one on the identification \
         record's truth ({}; the sweep designer's band and amplitude, `pumpcyl frf --design`), \
         estimates its frequency response and fits β, b and c12 to it, alone and with the step \
         records (docs/identification.md#grey-box-fit-to-a-frequency-response; the step \
         records are simulated there with the PLC's sampled controller). Every record here is \
         emulated, not measured.",
        v.sweep
    ));
    let interval = |s: &IntervalSet, i: usize| {
        s.intervals.get(i).map_or("-".into(), |[lo, hi]| {
            format!(
                "{} .. {}{}{}",
                parameter_value(i, lo),
                parameter_value(i, hi),
                if *s.identifiable.get(i) {
                    ""
                } else {
                    " (unbounded)"
                },
                if *s.truth_inside.get(i) {
                    ""
                } else {
                    ", truth OUTSIDE"
                }
            )
        })
    };
    let rows = (0..3)
        .map(|i| {
            let mut r = vec![
                PARAMETER_AXES[i].to_string(),
                parameter_value(i, value_of(truth, i)),
            ];
            r.extend(sets(v).iter().map(|(_, s)| interval(s, i)));
            r
        })
        .collect();
    run.table(
        &format!(
            "{:.0} % profile-likelihood intervals from the steps, the sweep and both",
            v.confidence * 100.0
        ),
        &[
            "parameter",
            "emulator truth",
            "steps",
            "sweep",
            "steps and sweep",
        ],
        rows,
    );
    run.text(&reading(v, truth));
    run.figure(
        "sweep_beside_steps",
        Source::Own,
        &format!(
            "The {:.0} % intervals of β, b and c12 from the steps, the sweep and both, relative to the emulator's truth",
            v.confidence * 100.0
        ),
        &chart(v, truth),
    )
}

/// What the table shows about b, in words.
fn reading(v: &SweepBeside, truth: &Candidate) -> String {
    let b = |s: &IntervalSet| {
        s.intervals
            .get(1)
            .map_or("not profiled".into(), |[lo, hi]| {
                format!(
                    "{} .. {} N·s/m",
                    parameter_value(1, lo),
                    parameter_value(1, hi)
                )
            })
    };
    let steps = if *v.steps.identifiable.get(1) {
        format!("bound b to {}", b(&v.steps))
    } else {
        "cannot bound b: its profile stays below the threshold up to a search bound".into()
    };
    let truth_b = parameter_value(1, truth.viscous_friction_ns_per_m);
    let caveat = if *v.sweep_alone.truth_inside.get(1) {
        format!("it holds the emulator's viscous friction ({truth_b} N·s/m)")
    } else {
        format!(
            "it misses the emulator's viscous friction ({truth_b} N·s/m): the sweep measures the \
             damping of the loop's resonance at its amplitude, and the emulator's effects that \
             the linear model leaves out (its Coulomb friction, the pumps' dead band) damp it \
             too, which only b can take up. Read the sweep's b as the effective damping at that \
             amplitude; with the emulator's effects off it recovers the viscous friction within \
             1 % (docs/identification.md#the-intervals)"
        )
    };
    format!(
        "The steps {steps}. The sweep bounds all three; b to {}, and {caveat}. Steps and sweep \
         together: b {}.",
        b(&v.sweep_alone),
        b(&v.both)
    )
}

/// One panel per parameter: each set's interval as a vertical bar over its category (the sets
/// named on the x axis, each in its colour), relative to the truth and cut at [`DRAWN`]; the
/// truth at 1.
fn chart(v: &SweepBeside, truth: &Candidate) -> Chart {
    let sets = sets(v);
    let panels = (0..3)
        .map(|i| {
            let t = value_of(truth, i);
            let mut traces: Vec<_> = (sets.iter().enumerate())
                .filter_map(|(k, (_, s))| {
                    let iv = (*s.intervals.get(i))?;
                    let rel = |x: f64| (x / t).min(DRAWN);
                    let x = (k + 1) as f64;
                    let (xs, ys) = ([x, x], [rel(iv[0]), rel(iv[1])]);
                    Some(trace("", &xs, &ys, LineStyle::Solid, Some(k)))
                })
                .collect();
            let ends = [0.5, sets.len() as f64 + 0.5];
            traces.push(trace("truth", &ends, &[1.0; 2], LineStyle::Dashed, Some(6)));
            Panel {
                y_label: format!("{} / truth", ["β", "b", "c12"][i]),
                traces,
                ..Default::default()
            }
        })
        .collect();
    Chart {
        title: "Intervals from the steps, the sweep and both".into(),
        subtitle: Some(format!("an interval is cut at {DRAWN:.0} × the truth")),
        plot: crate::figures::Plot::Categories {
            x_label: "record set".into(),
            categories: sets.iter().map(|(name, _)| name.to_string()).collect(),
            panels,
        },
    }
}
