//! Experiment advice with a sweep among the candidates (docs/identification.md, "Experiment
//! advice"): on the article's rig and its emulated step records, a multisine is predicted to
//! bound b where no step can, and the frequency-domain information of a multisine or a stepped
//! sine agrees with the time-domain information of the same record (Parseval: both see the same
//! signal); sweeps given in a candidates file are weighed as the designed one; a recording-time
//! budget counts each candidate as often as it fits.

use pumpcyl::emulator::article;
use pumpcyl::frf::{SweepKind, SweepSpec};
use pumpcyl::ident::{
    advise, designs_for, gram, sweep_information, AdviceOptions, Candidate, Design, Experiment,
    LOG_STEP,
};
use std::path::Path;

/// The article's embedded identification experiment (its emulated step records).
fn experiment() -> Experiment {
    let path = Path::new(article::FOLDER).join("identify.toml");
    Experiment::load_in(&article::Embedded, &path).unwrap()
}

/// The truth the records were emulated with (β at their mean pressure).
const TRUTH: Candidate = Candidate {
    beta_bar: 165.0,
    viscous_friction_ns_per_m: 100.0,
    c12_m5_per_ns: 1.2e-10,
};

#[test]
fn a_sweep_is_predicted_to_bound_b_where_no_step_can() {
    let exp = experiment();
    let a = advise(&exp.problem, &TRUTH, &AdviceOptions::default()).unwrap();
    // the steps alone leave b unbounded (the uncertainty analysis's verdict, step 9)
    assert!(a.current[1].interval.is_none(), "{:?}", a.current[1]);
    let sweeps: Vec<_> = a
        .candidates
        .iter()
        .filter(|c| matches!(c.design, Design::Sweep { .. }))
        .collect();
    assert!(!sweeps.is_empty(), "the defaults hold a sweep");
    for s in &sweeps {
        let w = &s.widths[1];
        eprintln!("{}: b {:?}, rank score {}", s.label, w.interval, s.score);
        // bounded about the point the advice linearises at (the steps' least-SSE point)
        let [lo, hi] = w.interval.expect("a sweep bounds b");
        let b = a.point.viscous_friction_ns_per_m;
        assert!(lo < b && b < hi, "{lo} {b} {hi}");
    }
    // a sweep narrows b more than any further step (a large step may bound it, loosely)
    let narrowest_sweep = sweeps
        .iter()
        .filter_map(|s| s.widths[1].width)
        .fold(f64::INFINITY, f64::min);
    for c in &a.candidates {
        if let (Design::Step { .. }, Some(w)) = (c.design, c.widths[1].width) {
            assert!(w > narrowest_sweep, "{}: b width {w}", c.label);
        }
    }
    assert!(a.best_for[1].starts_with("multisine"), "{}", a.best_for[1]);
}

#[test]
fn a_multisines_frequency_information_matches_its_time_domain_information() {
    let exp = experiment();
    let first = &exp.problem.datasets[0];
    let rate = 100.0;
    let sweep = |periods: usize| {
        let spec = SweepSpec {
            from_hz: Some(0.4),
            to_hz: Some(1.5),
            lines: Some(30),
            amplitude_mm: Some(8.0),
            periods: Some(periods),
            ..SweepSpec::of_kind(SweepKind::Multisine)
        };
        Design::sweep(&spec, 25.0, &first.rig, rate).unwrap()
    };
    let p = [
        TRUTH.beta_bar.ln(),
        TRUTH.viscous_friction_ns_per_m.ln(),
        TRUTH.c12_m5_per_ns.ln(),
    ];
    // one more period adds one steady period's information in either domain (the first
    // period's start-up transient cancels in the difference): Parseval says they are equal;
    // the time domain simulates the continuous loop, the frequency domain the loop sampled
    // at 100 Hz, which differ by the hold's half-sample delay (4 to 7 % here)
    let info = |periods: usize| {
        let d = sweep(periods);
        let ds = d.prepared(first, rate).unwrap();
        let freq = sweep_information(&exp.problem, &ds, &d, (&p, LOG_STEP), 1.0, rate).unwrap();
        (freq, gram(&exp.problem, &ds, &p, LOG_STEP).unwrap())
    };
    let ((f6, t6), (f7, t7)) = (info(6), info(7));
    let (freq, time) = (f7 - f6, t7 - t6);
    let r: Vec<f64> = (0..3).map(|i| freq[(i, i)] / time[(i, i)]).collect();
    eprintln!("one period: frequency {freq} time {time} ratio {r:?}");
    for (i, r) in r.iter().enumerate() {
        assert!((r - 1.0).abs() < 0.1, "{i}: {r}");
    }
}

/// The information (frequency domain, time domain) of a stepped sine of 3 levels, 0.1 to
/// 0.3 Hz, `periods` fitted per level, at 100 Hz (unit noise variance).
fn stepped_sine_information(
    exp: &Experiment,
    periods: usize,
) -> (nalgebra::Matrix3<f64>, nalgebra::Matrix3<f64>) {
    let first = &exp.problem.datasets[0];
    let spec = SweepSpec {
        from_hz: Some(0.1),
        to_hz: Some(0.3),
        levels: Some(3),
        amplitude_mm: Some(5.0),
        periods: Some(periods),
        ..SweepSpec::of_kind(SweepKind::SteppedSine)
    };
    let d = Design::sweep(&spec, 25.0, &first.rig, 100.0).unwrap();
    let ds = d.prepared(first, 100.0).unwrap();
    let p = [
        TRUTH.beta_bar.ln(),
        TRUTH.viscous_friction_ns_per_m.ln(),
        TRUTH.c12_m5_per_ns.ln(),
    ];
    let freq = sweep_information(&exp.problem, &ds, &d, (&p, LOG_STEP), 1.0, 100.0).unwrap();
    (freq, gram(&exp.problem, &ds, &p, LOG_STEP).unwrap())
}

#[test]
fn a_stepped_sines_frequency_information_matches_its_time_domain_information() {
    // one more fitted period per level adds one steady period of each level's sine in either
    // domain (the settling before it shifts, unchanged); the levels lie below the loop's
    // lightly damped pair (0.6 Hz), where the sampled loop's sensitivities and the continuous
    // loop's differ by 2 % (at it, by 31 %: the hold's half-sample delay lowers its damping)
    let exp = experiment();
    let ((f4, t4), (f5, t5)) = (
        stepped_sine_information(&exp, 4),
        stepped_sine_information(&exp, 5),
    );
    let (freq, time) = (f5 - f4, t5 - t4);
    let r: Vec<f64> = (0..3).map(|i| freq[(i, i)] / time[(i, i)]).collect();
    eprintln!("one period per level: frequency {freq} time {time} ratio {r:?}");
    for (i, r) in r.iter().enumerate() {
        assert!((r - 1.0).abs() < 0.1, "{i}: {r}");
    }
}

/// The candidates file `text` read for the article's experiment.
fn candidates(exp: &Experiment, text: &str) -> Result<Vec<Design>, String> {
    designs_for(&exp.problem, text, "c.toml").map_err(|e| e.to_string())
}

#[test]
fn sweeps_in_a_candidates_file_are_weighed_as_the_designed_one() {
    let exp = experiment();
    let a = advise(&exp.problem, &TRUTH, &AdviceOptions::default()).unwrap();
    let designed = a
        .candidates
        .iter()
        .find(|c| matches!(c.design, Design::Sweep { .. }))
        .expect("the defaults hold a sweep");
    let Design::Sweep { sweep, kp, .. } = designed.design else {
        unreachable!()
    };
    // the designed multisine's keys written out, with a chirp and a stepped sine beside it
    let text = format!(
        "[[sweep]]\nkind = \"multisine\"\nkp = {kp}\namplitude_mm = {}\nfrom_hz = {}\n\
         to_hz = {}\nperiod_s = {}\nlines = {}\nperiods = {}\n\n\
         [[sweep]]\nkind = \"stepped-sine\"\nkp = 20.0\namplitude_mm = 5.0\nfrom_hz = 0.3\n\
         to_hz = 1.2\nlevels = 4\n\n\
         [[sweep]]\nkind = \"chirp\"\nkp = 20.0\namplitude_mm = 5.0\nfrom_hz = 0.3\n\
         to_hz = 1.2\n",
        sweep.amplitude_mm.unwrap(),
        sweep.from_hz.unwrap(),
        sweep.to_hz.unwrap(),
        sweep.period_s.unwrap(),
        sweep.lines.unwrap(),
        sweep.periods.unwrap()
    );
    let designs = candidates(&exp, &text).unwrap();
    let opts = AdviceOptions {
        designs: Some(designs),
        ..AdviceOptions::default()
    };
    let b = advise(&exp.problem, &TRUTH, &opts).unwrap();
    assert_eq!(b.candidates.len() + b.skipped.len(), 3, "{:?}", b.skipped);
    let same = b
        .candidates
        .iter()
        .find(|c| c.label == designed.label)
        .expect("the file's multisine is the designed one");
    for i in 0..3 {
        let (x, y) = (same.widths[i].log_std, designed.widths[i].log_std);
        assert!((x / y - 1.0).abs() < 1e-9, "{i}: {x} vs {y}");
    }
    for c in &b.candidates {
        eprintln!("{}: b {:?}", c.label, c.widths[1].interval);
        assert!(
            c.improvement.iter().all(|&r| r >= 1.0 - 1e-9),
            "{}",
            c.label
        );
    }
    assert!(b
        .candidates
        .iter()
        .any(|c| c.label.starts_with("stepped-sine")));
}

#[test]
fn a_sweep_entry_with_a_bad_key_is_refused_in_one_line_naming_it() {
    let exp = experiment();
    let e = candidates(
        &exp,
        "[[sweep]]\nkind = \"multisine\"\nkp = 25.0\nfrom_hz = -1.0\n",
    )
    .unwrap_err();
    assert!(
        !e.contains('\n') && e.starts_with("c.toml: line 4, [[sweep]] 1: from_hz"),
        "{e}"
    );
    let e = candidates(
        &exp,
        "[[sweep]]\nkind = \"multisine\"\nkp = 25.0\nduration = 3\n",
    )
    .unwrap_err();
    assert!(!e.contains('\n') && e.contains("duration"), "{e}");
    let e = candidates(&exp, "[[sweep]]\nkind = \"square\"\nkp = 25.0\n").unwrap_err();
    assert!(!e.contains('\n') && e.contains("square"), "{e}");
    eprintln!("{e}");
}

#[test]
fn a_budget_counts_each_candidate_as_often_as_it_fits() {
    let exp = experiment();
    let sine = |duration_s: f64| Design::Sine {
        freq_hz: 0.5,
        amp_mm: 10.0,
        kp: 25.0,
        duration_s,
    };
    let at = |budget_s: Option<f64>, designs: Vec<Design>| {
        let opts = AdviceOptions {
            designs: Some(designs),
            budget_s,
            ..AdviceOptions::default()
        };
        advise(&exp.problem, &TRUTH, &opts).unwrap()
    };
    // without a budget each candidate is one record: the longer sine narrows every interval
    // more, and ranks first
    let one = at(None, vec![sine(20.0), sine(160.0)]);
    assert_eq!(one.candidates[0].duration_s, 160.0);
    // at 160 s of recording the 20 s sine is counted 8 times: 8 start-up transients, each of
    // which informs the direction a single sine's steady state leaves open (its steady state
    // gives two numbers, |T| and arg T, for three parameters), against one; it now ranks first
    let budget = at(Some(160.0), vec![sine(20.0), sine(160.0)]);
    let by = |a: &pumpcyl::ident::Advice, d: f64| {
        a.candidates
            .iter()
            .find(|c| c.duration_s == d)
            .unwrap()
            .clone()
    };
    let (short, long) = (by(&budget, 20.0), by(&budget, 160.0));
    assert_eq!((short.repeats, long.repeats), (8.0, 1.0));
    assert_eq!(budget.candidates[0].duration_s, 20.0);
    for i in 0..3 {
        let (s, l) = (short.widths[i].log_std, long.widths[i].log_std);
        eprintln!("parameter {i}: 20 s x 8 {s:.3e}, 160 s x 1 {l:.3e}");
        assert!(s < l, "{i}: {s} vs {l}");
    }
    // the 160 s sine at a budget of its own length is the record without a budget
    let (l, m) = (by(&one, 160.0), long);
    for i in 0..3 {
        assert_eq!(l.widths[i].log_std, m.widths[i].log_std, "{i}");
    }
    // a candidate longer than the budget is skipped, saying so
    let c = at(Some(100.0), vec![sine(20.0), sine(160.0)]);
    assert_eq!(c.candidates.len(), 1);
    assert!(
        c.skipped[0].contains("longer than the budget of 100 s"),
        "{:?}",
        c.skipped
    );
    // a budget that is not a positive time is refused
    let opts = AdviceOptions {
        budget_s: Some(-1.0),
        ..AdviceOptions::default()
    };
    let e = advise(&exp.problem, &TRUTH, &opts).unwrap_err().to_string();
    assert!(e.contains("budget_s = -1"), "{e}");
}

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

/// A sweep-only experiment on the tests' user rig (80/45 mm, 2500 kg, β 300 bar, Kp 15; no
/// value of the article's): an emulated multisine and standstill, fitted in the frequency
/// domain. The advice weighs candidates against step records, so it is refused in one line,
/// with or without a candidates file (an empty one, one with a step), never a panic.
#[test]
fn a_sweep_only_experiment_is_refused_in_one_line_with_or_without_candidates() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rig = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/user-rig.toml");
    let rig = rig.to_str().unwrap();
    for args in [
        &["--experiment", "multisine", "--out", "sweep.csv"][..],
        &[
            "--experiment",
            "standstill",
            "--duration-s",
            "2",
            "--out",
            "standstill.csv",
        ],
    ] {
        let mut all = vec!["emulate", "--rig", rig, "--no-effects"];
        all.extend(args);
        let out = run::pumpcyl(d, &all);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    std::fs::write(
        d.join("exp.toml"),
        format!(
            "rig = \"{rig}\"\nmethod = \"frequency\"\n[standstill]\nrecord = \"standstill.csv\"\n\n\
             [[dataset]]\nfile = \"sweep.csv\"\nkp = 15.0\nmass_kg = 2500.0\n"
        ),
    )
    .unwrap();
    std::fs::write(d.join("empty.toml"), "").unwrap();
    std::fs::write(d.join("step.toml"), "[[step]]\nstep_mm = 5.0\nkp = 15.0\n").unwrap();
    let words = ["no step record", "all sweeps"];
    run::refused(
        d,
        &["advise", "exp.toml", "--candidates", "empty.toml"],
        &words,
    );
    run::refused(
        d,
        &["advise", "exp.toml", "--candidates", "step.toml", "--json"],
        &words,
    );
    run::refused(d, &["advise", "exp.toml"], &words);
    // the library's entry points refuse it too, in the same words
    let exp = Experiment::load(&d.join("exp.toml")).unwrap();
    assert!(exp.problem.datasets.is_empty() && !exp.sweeps.is_empty());
    let e = designs_for(
        &exp.problem,
        "[[step]]\nstep_mm = 5.0\nkp = 15.0\n",
        "c.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("no step record"), "{e}");
    let e = advise(&exp.problem, &TRUTH, &AdviceOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("no step record"), "{e}");
}
