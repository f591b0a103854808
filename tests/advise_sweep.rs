//! Experiment advice with a sweep among the candidates (docs/identification.md, "Experiment
//! advice"): on the article's rig and its emulated step records, a multisine is predicted to
//! bound b where no step can, and the frequency-domain information of a multisine agrees with
//! the time-domain information of the same record (Parseval: both see the same signal).

use pumpcyl::emulator::article;
use pumpcyl::ident::{
    advise, gram, sweep_information, AdviceOptions, Candidate, Design, Experiment, LOG_STEP,
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
    let sweep = |periods: usize| Design::Sweep {
        from_hz: 0.4,
        to_hz: 1.5,
        lines: 30,
        amp_mm: 8.0,
        periods,
        kp: 25.0,
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
