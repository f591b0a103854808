//! Coverage of the uncertainty intervals (docs/identification.md, "Uncertainty") measured on
//! records of the nonlinear emulator (docs/emulator.md) with known truths: for each record set
//! a truth (β, b, c12) around the article's rig (its §2.3.4), the article's 5 mm step at
//! Kp = 25 and Kp = 20 and a standstill record, emulated with every effect on (Coulomb
//! friction, the pumps' dead band, β_e(p), …: model error the LTI model lacks) and the
//! article's PLC noise from a fresh seed; identified, profiled, and each 95 % interval checked
//! for its truth.
//!
//! The always-run test takes 20 record sets; the full measurement (`cargo test --release
//! --test coverage -- --ignored --nocapture`, docs/identification.md, "Uncertainty") takes
//! `PUMPCYL_COVERAGE_SETS` sets (default 120) and prints the coverage.

use pumpcyl::emulator::{article, Effects, Experiment as Emulation};
use pumpcyl::ident::{
    analyze, search, spaced, Candidate, DatasetSpec, Grid, Prepared, Problem, SearchOptions,
    Standstill, UncertaintyOptions, PARAMETERS,
};
use pumpcyl::record::Record;
use pumpcyl::rig::Rig;
use rayon::prelude::*;

#[path = "common/coverage.rs"]
mod coverage;
use coverage::Outcome;

/// The datasets: (Kp, end of the fit window on the record's time axis, s): the article's
/// windows (2.2 s and 1.9 s after the step, docs/identification.md#the-fit-windows).
const DATASETS: [(f64, f64); 2] = [(25.0, 2.7), (20.0, 2.4)];
/// When the step starts (s) and how long each step record is (s): past both fit windows.
const STEP_AT_S: f64 = 0.5;
const STEP_RECORD_S: f64 = 3.0;
/// Length of the standstill record (s).
const STANDSTILL_S: f64 = 4.0;

/// The truth of record set `k`: β 140–200 bar, b 100–400 N·s/m, c12 0.8–1.5·10⁻¹⁰, spread
/// over their ranges by three incommensurate sequences (the golden-ratio lattice).
fn truth(k: u64) -> Candidate {
    let frac = |a: f64| (k as f64 * a).fract();
    Candidate {
        beta_bar: 140.0 + 60.0 * frac(0.618_033_988_7),
        viscous_friction_ns_per_m: 100.0 + 300.0 * frac(0.754_877_666_2),
        c12_m5_per_ns: 0.8e-10 + 0.7e-10 * frac(0.569_840_290_9),
    }
}

/// The article's rig with the truth's β, b and c12.
fn rig_of(t: &Candidate, kp: f64) -> Rig {
    Rig {
        beta_bar: t.beta_bar,
        viscous_friction_ns_per_m: t.viscous_friction_ns_per_m,
        c12_m5_per_ns: t.c12_m5_per_ns,
        kp,
        ..Rig::default()
    }
}

/// An emulated record as a record read from a file.
fn record(name: &str, run: &Emulation, rig: &Rig, effects: Effects, seed: u64) -> Record {
    let s = run
        .run(rig, effects, &article::plc(seed))
        .expect("the emulator runs the rig");
    Record::parse(pumpcyl_present::records::record_csv(&s).as_bytes(), name)
        .expect("the emulator's record reads")
}

/// The identification problem of record set `k` with truth `t`.
fn problem(k: u64, t: &Candidate) -> Problem {
    let truth_rig = rig_of(t, 25.0);
    let effects = Effects::for_rig(&truth_rig).expect("the emulator takes the rig");
    let still = Emulation::standstill(&truth_rig, Some(STANDSTILL_S));
    let still = record("standstill.csv", &still, &truth_rig, effects, 3 * k + 2);
    let datasets = DATASETS
        .iter()
        .enumerate()
        .map(|(i, &(kp, fit_end_s))| {
            let rig = rig_of(t, kp);
            let step = Emulation::step(&rig, None, None, STEP_AT_S, Some(STEP_RECORD_S));
            let name = format!("kp{kp}.csv");
            let rec = record(&name, &step, &rig, effects, 3 * k + i as u64);
            let spec = DatasetSpec {
                file: name,
                kp,
                mass_kg: rig.mass_kg,
                fit_end_s,
            };
            Prepared::new(&spec, rec, &Rig::default()).expect("the record fits the rig")
        })
        .collect();
    Problem {
        datasets,
        standstill: Standstill::of_record(&still).expect("standstill record"),
    }
}

/// A coarse grid around the article's values: the analysis starts from its best point.
fn coarse() -> Grid {
    Grid {
        beta_bar: spaced(100.0, 260.0, 5, true),
        viscous_friction_ns_per_m: spaced(50.0, 800.0, 4, true),
        c12_m5_per_ns: spaced(0.5e-10, 2.5e-10, 5, true),
    }
}

fn identify(k: u64) -> Outcome {
    let t = truth(k);
    let p = problem(k, &t);
    let opts = SearchOptions {
        top_n: 1,
        threshold_mm2: 1e-9,
        shard: None,
    };
    let start = search(&p, &coarse(), 1, opts, &|_| true).top[0].candidate;
    let u = analyze(&p, &start, &UncertaintyOptions::default()).expect("the analysis runs");
    let intervals = PARAMETERS.map(|name| {
        let pr = u.profile(name).expect("every parameter profiled");
        (pr.identifiable, pr.interval)
    });
    Outcome::of(
        intervals,
        [t.beta_bar, t.viscous_friction_ns_per_m, t.c12_m5_per_ns],
    )
}

/// Every parameter's coverage at least 90 % over record sets 1..=`sets`; b counted only where
/// its interval is closed.
fn check(sets: u64) {
    let outcomes: Vec<Outcome> = (1..=sets).into_par_iter().map(identify).collect();
    let c = coverage::coverage(&outcomes, |o, i| i != 1 || o.bounded[1]);
    coverage::check("emulated step record sets", sets, &c);
}

/// 20 record sets, at least 18 covered per parameter (the intervals without the model-error
/// variance missed c12 in 5 of these 20).
#[test]
fn the_intervals_hold_the_emulators_truth_on_20_record_sets() {
    check(20);
}

#[test]
#[ignore = "about 20 s in release: cargo test --release --test coverage -- --ignored --nocapture"]
fn the_95_percent_intervals_hold_the_emulators_truth_nine_times_in_ten() {
    check(coverage::sets(120));
}
