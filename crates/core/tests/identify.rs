//! Identification recovers known parameters from records simulated by the model with seeded
//! noise (the article §2.4; docs/identification.md).

use pumpcyl::ident::{finish, run_stages, Candidate, Experiment, Grid, Options};
use std::path::Path;

#[path = "common/synthetic.rs"]
mod synthetic;

/// Write a 5 mm step record (0.5 s rest, step 340 → 345 mm, 4 s) simulated with `truth`.
fn write_record(dir: &Path, name: &str, truth: &Candidate, kp: f64, noise_mm: f64, seed: u64) {
    let mut noise = synthetic::Noise::new(seed);
    let rec = synthetic::record(truth, kp, noise_mm, &mut noise, 401);
    std::fs::write(dir.join(name), synthetic::csv(&rec)).unwrap();
}

fn experiment(dir: &Path, extra: &str) -> Experiment {
    let text = format!(
        "{extra}\n[standstill]\nw1_rpm = -160.0\nw2_rpm = 245.0\np1_bar = 3.95\n\
         [[dataset]]\nfile = \"ident.csv\"\nkp = 25.0\nmass_kg = 10593.0\nfit_end_s = 3.7\n\
         [[dataset]]\nfile = \"valid.csv\"\nkp = 20.0\nmass_kg = 10593.0\nfit_end_s = 3.7\n"
    );
    std::fs::write(dir.join("exp.toml"), text).unwrap();
    Experiment::load(&dir.join("exp.toml")).unwrap()
}

fn opts(local_refinement: bool) -> Options {
    Options {
        auto_refine: false,
        local_refinement,
        threshold_mm2: 0.25,
        top_n: 20,
    }
}

#[test]
fn grid_search_recovers_the_truth_within_one_grid_step() {
    let dir = tempfile::tempdir().unwrap();
    let truth = Candidate {
        beta_bar: 165.0,
        viscous_friction_ns_per_m: 100.0,
        c12_m5_per_ns: 1.2e-10,
    };
    write_record(dir.path(), "ident.csv", &truth, 25.0, 0.01, 11);
    write_record(dir.path(), "valid.csv", &truth, 20.0, 0.01, 12);
    // the article's grids: their steps (5 bar, 50 N·s/m, 1e-11) hold the truth exactly
    let exp = experiment(dir.path(), "grids = \"article\"");
    let stages = run_stages(&exp.problem, exp.grids(), &opts(false), None, &|_| {}).unwrap();
    assert_eq!(stages[0].summary.evaluated, 3264);
    assert_eq!(stages[1].summary.evaluated, 3553);
    let id = finish(&exp.problem, stages, &opts(false)).unwrap();
    let best = id.best().candidate;
    assert!((best.beta_bar - 165.0).abs() <= 5.0, "{best:?}");
    assert!(
        (best.c12_m5_per_ns - 1.2e-10).abs() <= 1.0e-11 + 1e-22,
        "{best:?}"
    );
    // the noise floor: cost ≈ σ² = 1e-4 mm² at the truth
    assert!(id.best().cost_mm2 < 2e-4, "{}", id.best().cost_mm2);
    // the article's leakages follow for c12 = 1.2e-10
    assert!((id.leakage.c1_m5_per_ns / 5.49e-11 - 1.0).abs() < 0.05);
}

#[test]
fn local_refinement_lands_within_two_percent_between_grid_points() {
    let dir = tempfile::tempdir().unwrap();
    let truth = Candidate {
        beta_bar: 172.5,
        viscous_friction_ns_per_m: 130.0,
        c12_m5_per_ns: 1.25e-10,
    };
    write_record(dir.path(), "ident.csv", &truth, 25.0, 0.005, 21);
    write_record(dir.path(), "valid.csv", &truth, 20.0, 0.005, 22);
    // a small first grid around the article's refined one keeps the test quick
    let exp = experiment(
        dir.path(),
        "[grid]\nbeta_bar = [130.0, 150.0, 170.0, 190.0, 210.0]\n\
         viscous_friction_ns_per_m = [50.0, 100.0, 200.0, 400.0]\n\
         c12_m5_per_ns = [0.8e-10, 1.0e-10, 1.2e-10, 1.4e-10, 1.6e-10]\n\
         [refined_grid]\nbeta_bar = [160.0, 170.0, 180.0]\nviscous_friction_ns_per_m = [100.0, 150.0]\n\
         c12_m5_per_ns = [1.1e-10, 1.3e-10]\n",
    );
    let o = opts(true);
    let stages = run_stages(&exp.problem, exp.grids(), &o, None, &|_| {}).unwrap();
    let id = finish(&exp.problem, stages, &o).unwrap();
    let r = id.refined.expect("refinement improves on the grid");
    assert!(r.cost_mm2 < id.grid_best.cost_mm2);
    let c = r.candidate;
    assert!((c.beta_bar / 172.5 - 1.0).abs() < 0.02, "{c:?}");
    assert!((c.c12_m5_per_ns / 1.25e-10 - 1.0).abs() < 0.02, "{c:?}");
}

#[test]
fn sharded_search_merges_to_the_same_answer() {
    let dir = tempfile::tempdir().unwrap();
    let truth = Candidate {
        beta_bar: 165.0,
        viscous_friction_ns_per_m: 100.0,
        c12_m5_per_ns: 1.2e-10,
    };
    write_record(dir.path(), "ident.csv", &truth, 25.0, 0.01, 31);
    write_record(dir.path(), "valid.csv", &truth, 20.0, 0.01, 32);
    let exp = experiment(dir.path(), "");
    let small = (
        Grid {
            beta_bar: vec![100.0, 165.0, 250.0],
            viscous_friction_ns_per_m: vec![100.0, 200.0],
            c12_m5_per_ns: pumpcyl::ident::spaced(1e-11, 1e-9, 7, true),
        },
        None,
    );
    let o = opts(false);
    let whole = run_stages(&exp.problem, small.clone(), &o, None, &|_| {}).unwrap();
    let mut merged = run_stages(&exp.problem, small.clone(), &o, Some((1, 3)), &|_| {}).unwrap();
    for i in 2..=3 {
        let part = run_stages(&exp.problem, small.clone(), &o, Some((i, 3)), &|_| {}).unwrap();
        let s = merged
            .remove(0)
            .summary
            .merge(part[0].summary.clone(), o.top_n);
        merged.insert(
            0,
            pumpcyl::ident::Stage {
                grid: small.0.clone(),
                summary: s,
            },
        );
    }
    assert_eq!(merged[0].summary.evaluated, 42);
    assert_eq!(merged[0].summary.top, whole[0].summary.top);
    assert_eq!(
        merged[0].summary.threshold_count,
        whole[0].summary.threshold_count
    );
}

#[test]
fn a_search_stops_when_progress_says_so() {
    use std::sync::atomic::{AtomicU64, Ordering};
    let dir = tempfile::tempdir().unwrap();
    let truth = Candidate {
        beta_bar: 165.0,
        viscous_friction_ns_per_m: 100.0,
        c12_m5_per_ns: 1.2e-10,
    };
    write_record(dir.path(), "ident.csv", &truth, 25.0, 0.01, 41);
    write_record(dir.path(), "valid.csv", &truth, 20.0, 0.01, 42);
    let exp = experiment(dir.path(), "");
    let seen = AtomicU64::new(0);
    let r = pumpcyl::ident::run_stages_while(&exp.problem, exp.grids(), &opts(false), None, &|n| {
        seen.fetch_add(n, Ordering::Relaxed);
        false
    });
    assert!(
        matches!(r, Err(pumpcyl::ident::IdentError::Interrupted)),
        "{r:?}"
    );
    // only the chunks already running finish: far fewer than the first grid's 3264
    let seen = seen.load(Ordering::Relaxed);
    assert!(seen > 0 && seen < 1000, "{seen} candidates evaluated");
    // a progress that never stops gives the whole search
    let all =
        pumpcyl::ident::run_stages_while(&exp.problem, exp.grids(), &opts(false), None, &|_| true)
            .unwrap();
    assert_eq!(all[0].summary.evaluated + all[1].summary.evaluated, 6817);
}
