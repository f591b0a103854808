//! Experiment advice (docs/identification.md, "Experiment advice"): the linearised (Fisher)
//! intervals against the profile-likelihood ones of the uncertainty analysis, against the
//! spread of identified β over fresh noise (Monte Carlo), and the properties that must hold
//! (more data never widens; twice the record, √2 narrower; half the noise, half the width);
//! the CLI's JSON and its one-line errors.

#[path = "../crates/core/tests/common/synthetic.rs"]
mod synthetic;

use nalgebra::Matrix3;
use pumpcyl::ident::{
    advise, analyze, gram, widths, Advice, AdviceOptions, Candidate, DatasetSpec, Design, Prepared,
    Problem, UncertaintyOptions, LOG_STEP,
};
use pumpcyl::record::Record;
use pumpcyl::response::{simulate, Baseline};
use pumpcyl::rig::Rig;
use rayon::prelude::*;
use synthetic::{problem, truth_rig, Noise, TRUTH};

/// A start 10 % off the truth, as a grid search would leave it.
const START: Candidate = Candidate {
    beta_bar: 180.0,
    viscous_friction_ns_per_m: 150.0,
    c12_m5_per_ns: 1.1e-10,
};

/// The candidate of the Monte Carlo check: a 0.5 Hz, 10 mm sinusoid at Kp 25 for 5 s.
const SINE: Design = Design::Sine {
    freq_hz: 0.5,
    amp_mm: 10.0,
    kp: 25.0,
    duration_s: 5.0,
};

fn log_truth() -> [f64; 3] {
    [
        TRUTH.beta_bar.ln(),
        TRUTH.viscous_friction_ns_per_m.ln(),
        TRUTH.c12_m5_per_ns.ln(),
    ]
}

fn advice(p: &Problem, designs: Vec<Design>) -> Advice {
    let opts = AdviceOptions {
        confidence: 0.95,
        designs: Some(designs),
        ..AdviceOptions::default()
    };
    advise(p, &START, &opts).unwrap()
}

/// The design's record simulated with the truth at 100 Hz from x0, with noise σ = `noise_mm`,
/// as a dataset fitted over the whole record.
fn noisy_dataset(design: &Design, noise_mm: f64, noise: &mut Noise) -> Prepared {
    let rig = truth_rig(&TRUTH, design.kp());
    let clean = design.record(100.0, &rig).unwrap();
    let s = simulate(
        &rig,
        &clean.time_s,
        &clean.x_ref_mm,
        // at rest on the record's first reference, as identification takes its baseline
        // (docs/simulation.md#deviations-and-the-baseline)
        &Baseline {
            x_ref_mm: clean.x_ref_mm[0],
            x_mm: clean.x_ref_mm[0],
            ..Baseline::of_rig(&rig)
        },
    )
    .unwrap();
    let x_mm: Vec<f64> = s
        .x_mm
        .iter()
        .map(|x| x + noise_mm * noise.gauss())
        .collect();
    let record = Record::from_arrays("sine.csv", &clean.time_s, &clean.x_ref_mm, &x_mm).unwrap();
    let spec = DatasetSpec {
        file: "sine.csv".into(),
        kp: design.kp(),
        mass_kg: 10593.0,
        fit_end_s: clean.time_s[clean.len() - 1],
    };
    Prepared::new(&spec, record, &Rig::default()).unwrap()
}

#[test]
fn fisher_widths_agree_with_the_profile_likelihood_intervals() {
    let p = problem(&TRUTH, 0.02, 7, 2);
    let u = analyze(
        &p,
        &START,
        &UncertaintyOptions {
            confidence: 0.95,
            profile: [true, false, true],
        },
    )
    .unwrap();
    let a = advice(&p, vec![SINE]);
    assert!((a.noise_std_mm - u.noise_std_mm).abs() < 1e-12);
    for (i, name) in [(0, "beta_bar"), (2, "c12_m5_per_ns")] {
        let [lo, hi] = u.profile(name).unwrap().interval;
        let [flo, fhi] = a.current[i].interval.unwrap();
        // the profile's statistic carries the records' disagreement too (the model-error
        // variance, docs/identification.md, "Uncertainty"), the Fisher widths the noise alone
        let model_error = (u.inflation_by_parameter[i] / u.variance_inflation).sqrt();
        let ratio = model_error * (fhi / flo).ln() / (hi / lo).ln();
        eprintln!("{name}: profile {lo:.4e} .. {hi:.4e}, Fisher {flo:.4e} .. {fhi:.4e}, log-width ratio {ratio:.3}");
        // on LTI records the cost is nearly quadratic in ln θ over a few per cent, so the two
        // agree far better than the factor 2 a nonlinear rig may need
        assert!((0.8..1.25).contains(&ratio), "{name}: {ratio}");
    }
}

#[test]
fn the_predicted_spread_of_beta_matches_monte_carlo() {
    const NOISE_MM: f64 = 0.05;
    // `PUMPCYL_MC_RUNS` sets the number of runs (default 32, a test's budget)
    let runs: u64 = std::env::var("PUMPCYL_MC_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(32);
    let base = problem(&TRUTH, NOISE_MM, 1, 2);
    let mut noise = Noise::new(1);
    let cand = noisy_dataset(&SINE, NOISE_MM, &mut noise);
    let mut info = Matrix3::zeros();
    for ds in base.datasets.iter().chain([&cand]) {
        info += gram(&base, ds, &log_truth(), LOG_STEP).unwrap() / (NOISE_MM * NOISE_MM);
    }
    let predicted = widths(&info, &TRUTH, 1.0).unwrap()[0].log_std;
    let estimates: Vec<f64> = (1..=runs)
        .into_par_iter()
        .map(|seed| {
            let mut p = problem(&TRUTH, NOISE_MM, 1000 + seed, 2);
            let mut noise = Noise::new(5000 + seed);
            p.datasets.push(noisy_dataset(&SINE, NOISE_MM, &mut noise));
            let opts = UncertaintyOptions {
                confidence: 0.95,
                profile: [false; 3],
            };
            analyze(&p, &TRUTH, &opts).unwrap().best.beta_bar.ln()
        })
        .collect();
    let n = estimates.len() as f64;
    let mean = estimates.iter().sum::<f64>() / n;
    let sd = (estimates.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    eprintln!(
        "Monte Carlo over {runs} runs: sd(ln beta) {sd:.3e}, predicted {predicted:.3e}, ratio {:.3}; \
         mean beta {:.2} bar (truth {})",
        sd / predicted,
        mean.exp(),
        TRUTH.beta_bar
    );
    // the sample sd of n draws has a relative standard error of 1/√(2(n − 1)), 12.7 % for
    // 32: ±40 % is more than three standard errors
    let se = 1.0 / (2.0 * (n - 1.0)).sqrt();
    assert!(
        ((sd / predicted) - 1.0).abs() < (3.2 * se).max(0.05),
        "{sd} vs {predicted}"
    );
    // unbiased within three standard errors of the mean
    assert!((mean - TRUTH.beta_bar.ln()).abs() < 3.0 * predicted / n.sqrt() + 1e-4);
}

#[test]
fn more_data_never_widens_and_halving_the_noise_halves_the_widths() {
    let noisy = problem(&TRUTH, 0.02, 3, 2);
    let quiet = problem(&TRUTH, 0.01, 3, 2);
    // every fifth default design (steps and sinusoids at every gain), to keep the test short
    let designs: Vec<Design> = pumpcyl::ident::default_designs(&[25.0, 20.0], 0.058, 155.0, 100.0)
        .into_iter()
        .step_by(5)
        .collect();
    let a = advice(&noisy, designs.clone());
    assert_eq!(a.candidates.len() + a.skipped.len(), designs.len());
    // at Kp 35 the truth's closed loop has a damping ratio of 0.011 (`pumpcyl poles --set
    // kp=35`): those candidates are skipped for it, the others kept
    let at35 = designs.iter().filter(|d| d.kp() == 35.0).count();
    assert!(at35 >= 1);
    let damped: Vec<&String> = a
        .skipped
        .iter()
        .filter(|s| s.contains("damping ratio 0.01"))
        .collect();
    assert_eq!(damped.len(), at35, "{:?}", a.skipped);
    assert!(a.candidates.iter().all(|c| c.design.kp() < 35.0));
    for c in &a.candidates {
        for i in 0..3 {
            assert!(
                c.widths[i].log_std <= a.current[i].log_std * (1.0 + 1e-9),
                "{}: {:?} vs {:?}",
                c.label,
                c.widths[i],
                a.current[i]
            );
            assert!(c.improvement[i] >= 1.0 - 1e-9);
        }
    }
    // ranked by the score, best first
    assert!(a.candidates.windows(2).all(|w| w[0].score <= w[1].score));
    let b = advice(&quiet, vec![SINE]);
    let a1 = advice(&noisy, vec![SINE]);
    for i in [0, 2] {
        let r = a1.current[i].log_std / b.current[i].log_std;
        assert!((r - 2.0).abs() < 0.1, "{i}: current {r}");
        let r = a1.candidates[0].widths[i].log_std / b.candidates[0].widths[i].log_std;
        assert!((r - 2.0).abs() < 0.1, "{i}: with the sine {r}");
    }
}

#[test]
fn twice_the_record_narrows_by_root_two() {
    let like = problem(&TRUTH, 0.02, 3, 1);
    let info = |duration_s: f64| {
        let mut m = Matrix3::zeros();
        for freq_hz in [0.5, 1.0] {
            let d = Design::Sine {
                freq_hz,
                amp_mm: 5.0,
                kp: 25.0,
                duration_s,
            };
            let ds = d.prepared(&like.datasets[0], 100.0).unwrap();
            m += gram(&like, &ds, &log_truth(), LOG_STEP).unwrap();
        }
        m
    };
    // the start-up transient carries information of its own (about 5 s of the periodic
    // steady state on the diagonal; measured, the Gram matrix grows as a + b·D), a share that
    // fades as 1/D: the ratio approaches √2 from below as the records grow
    let ratios = |d: f64| {
        let (ws, wl) = (
            widths(&info(d), &TRUTH, 1.96).unwrap(),
            widths(&info(2.0 * d), &TRUTH, 1.96).unwrap(),
        );
        std::array::from_fn::<f64, 3, _>(|i| ws[i].log_std / wl[i].log_std)
    };
    let (short, long) = (ratios(20.0), ratios(80.0));
    for i in 0..3 {
        eprintln!(
            "parameter {i}: log-std ratio 20 s / 40 s {:.3}, 80 s / 160 s {:.3}",
            short[i], long[i]
        );
        assert!(long[i] <= 2f64.sqrt() * 1.01, "{i}: {}", long[i]);
        assert!(
            (long[i] / 2f64.sqrt() - 1.0).abs() < 0.06,
            "{i}: {}",
            long[i]
        );
        assert!(
            (long[i] - 2f64.sqrt()).abs() < (short[i] - 2f64.sqrt()).abs(),
            "{i}: {short:?} {long:?}"
        );
    }
}

#[test]
fn sensitivities_do_not_depend_on_the_difference_step() {
    let p = problem(&TRUTH, 0.02, 3, 2);
    let ds = &p.datasets[0];
    let (g1, g2) = (
        gram(&p, ds, &log_truth(), LOG_STEP).unwrap(),
        gram(&p, ds, &log_truth(), LOG_STEP / 10.0).unwrap(),
    );
    for i in 0..3 {
        let rel = (g1[(i, i)] / g2[(i, i)] - 1.0).abs();
        assert!(rel < 1e-5, "{i}: {rel}");
    }
}

#[test]
fn advise_cli_json_and_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let exp = synthetic::experiment_file(dir.path(), 0.02);
    let cands = dir.path().join("c.toml");
    std::fs::write(
        &cands,
        "[[step]]\nstep_mm = 10.0\nkp = 25.0\nduration_s = 4.0\n\
         [[sine]]\nfreq_hz = 0.5\namp_mm = 10.0\nkp = 25.0\nduration_s = 4.0\n",
    )
    .unwrap();
    let c = cands.to_str().unwrap();
    let o = pumpcyl(&["advise", &exp, "--json", "--candidates", c]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["confidence"], 0.95);
    assert!((v["z"].as_f64().unwrap() - 1.959_964).abs() < 1e-5);
    assert!(v["noise_std_mm"].as_f64().unwrap() > 0.0);
    // records of one LTI model with white noise hardly disagree: factors just above 1
    for f in v["model_error_factor"].as_object().unwrap().values() {
        assert!((1.0..1.1).contains(&f.as_f64().unwrap()), "{f}");
    }
    let names = ["beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"];
    for (i, name) in names.iter().enumerate() {
        assert_eq!(v["current"][i]["parameter"], *name);
        assert!(v["current"][i]["log_std"].as_f64().is_some());
    }
    let cands_json = v["candidates"].as_array().unwrap();
    assert_eq!(cands_json.len(), 2);
    for c in cands_json {
        assert!(c["label"].is_string() && c["score"].is_number());
        assert!(["step", "sine"].contains(&c["design"]["kind"].as_str().unwrap()));
        assert_eq!(c["improvement"].as_array().unwrap().len(), 3);
    }
    // the best candidate per parameter is keyed by the parameter's name, never by position,
    // and is the first of that parameter's ranking
    let labels: Vec<&str> = cands_json
        .iter()
        .map(|c| c["label"].as_str().unwrap())
        .collect();
    let best_for = v["best_for"].as_object().unwrap();
    assert_eq!(best_for.len(), 3);
    for name in names {
        let best = best_for[name].as_str().unwrap();
        assert!(labels.contains(&best), "{best} not among {labels:?}");
        let ranking = v["ranking_by_parameter"][name].as_array().unwrap();
        assert_eq!(ranking.len(), 2);
        assert_eq!(ranking[0]["label"], best);
        let log_std = |k: usize| ranking[k]["log_std"].as_f64().unwrap();
        assert!(log_std(0) <= log_std(1));
    }

    let o = pumpcyl(&["advise", &exp, "--candidates", c]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("helps b most: "), "{text}");

    for (content, needles) in [
        (
            "[[step]]\nstep_mm = 5.0\nkp = 25.0\nsize_mm = 3\n",
            vec!["line 4", "size_mm"],
        ),
        (
            "[[sine]]\nfreq_hz = 0.5\namp_mm = -2.0\nkp = 25.0\n",
            vec!["line 3", "amp_mm", "must be > 0"],
        ),
    ] {
        std::fs::write(&cands, content).unwrap();
        let o = pumpcyl(&["advise", &exp, "--candidates", c]);
        assert!(!o.status.success());
        let e = String::from_utf8_lossy(&o.stderr);
        for n in needles {
            assert!(e.contains(n) && e.contains("c.toml"), "{n}: {e}");
        }
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
        assert!(!e.contains("panicked"), "{e}");
    }
    let o = pumpcyl(&["advise", &exp, "--confidence", "1.5"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("confidence"));
}

/// Run the pumpcyl binary with `args`.
fn pumpcyl(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .output()
        .unwrap()
}
