//! Uncertainty of the identification (docs/identification.md, "Uncertainty"): on records
//! simulated by the LTI model with known β, b, c12 and Gaussian noise, the noise estimate
//! matches the noise put in, the 95 % intervals contain the truth, and they shrink with less
//! noise and with more data.

#[path = "../crates/core/tests/common/synthetic.rs"]
mod synthetic;

use pumpcyl::ident::{analyze, Candidate, Uncertainty, UncertaintyOptions};
use synthetic::{problem, TRUTH};

/// A start 10 % off the truth, as a grid search would leave it.
const START: Candidate = Candidate {
    beta_bar: 180.0,
    viscous_friction_ns_per_m: 150.0,
    c12_m5_per_ns: 1.1e-10,
};

fn run(noise_mm: f64, seed: u64, datasets: usize, profile: [bool; 3]) -> Uncertainty {
    let p = problem(&TRUTH, noise_mm, seed, datasets);
    let opts = UncertaintyOptions {
        confidence: 0.95,
        profile,
    };
    analyze(&p, &START, &opts).unwrap()
}

fn width(u: &Uncertainty, name: &str) -> f64 {
    let [lo, hi] = u.profile(name).unwrap().interval;
    hi / lo
}

#[test]
fn intervals_contain_the_truth_and_the_noise_is_recovered() {
    let u = run(0.02, 7, 2, [true; 3]);
    // 2 × (0.5 s at rest + 2.2 s / 1.9 s) at 100 Hz, samples at t ≤ fit end
    assert_eq!(u.samples, 271 + 241);
    assert!((u.threshold - 3.841_458_8).abs() < 1e-6);
    // white noise: the residuals' lag-1 autocorrelation is within about 2/√N of 0
    assert!(
        u.residual_autocorrelation.abs() < 0.1,
        "{}",
        u.residual_autocorrelation
    );
    // σ̂² = SSE/(N − 5) is χ²-distributed: ±10 % holds with ~98 % probability for N = 512
    assert!(
        (u.noise_std_mm / 0.02 - 1.0).abs() < 0.1,
        "{}",
        u.noise_std_mm
    );
    let truth = [
        ("beta_bar", TRUTH.beta_bar),
        ("viscous_friction_ns_per_m", TRUTH.viscous_friction_ns_per_m),
        ("c12_m5_per_ns", TRUTH.c12_m5_per_ns),
    ];
    for (name, t) in truth {
        let p = u.profile(name).unwrap();
        let [lo, hi] = p.interval;
        assert!(lo <= t && t <= hi, "{name}: {t} outside [{lo}, {hi}]");
        // every profile point is a least SSE: none is below the optimum's (beyond the inner
        // searches' tolerance)
        for q in &p.points {
            assert!(q.statistic > -0.05, "{name}: {q:?}");
        }
        // the points are ordered and the optimum lies inside the interval
        assert!(p.points.windows(2).all(|w| w[0].value <= w[1].value));
    }
    for name in ["beta_bar", "c12_m5_per_ns"] {
        let p = u.profile(name).unwrap();
        assert!(p.identifiable, "{name}: {p:?}");
        // at σ = 0.02 mm the article's step pins β and c12 to a few per cent
        assert!(width(&u, name) < 1.3, "{name}: {:?}", p.interval);
        // the interval's ends are where the profile crosses χ²₁(0.95): the points just
        // outside lie above it, the optimum's neighbours below
        let above = p
            .points
            .iter()
            .filter(|q| q.statistic > u.threshold)
            .count();
        assert!(above >= 2, "{name}");
    }
}

#[test]
fn intervals_shrink_with_less_noise_and_more_data() {
    let two = [true, false, true];
    let noisy = run(0.04, 3, 2, two);
    let quiet = run(0.01, 3, 2, two);
    let one = run(0.04, 3, 1, two);
    for name in ["beta_bar", "c12_m5_per_ns"] {
        let (wn, wq, w1) = (
            width(&noisy, name).ln(),
            width(&quiet, name).ln(),
            width(&one, name).ln(),
        );
        // the interval's log-width scales with σ near the optimum: a quarter of the noise,
        // about a quarter of the width
        assert!(wq < 0.4 * wn, "{name}: {wq} vs {wn}");
        assert!(wq > 0.15 * wn, "{name}: {wq} vs {wn}");
        // the second dataset adds information
        assert!(wn < w1, "{name}: two datasets {wn}, one {w1}");
    }
    // b was not profiled
    assert!(noisy.profile("viscous_friction_ns_per_m").is_none());
}

#[test]
fn a_start_without_leakage_or_friction_is_moved_into_the_bounds() {
    // a grid may hold b = 0 and c12 = 0, outside the logarithmic search bounds
    let p = problem(&TRUTH, 0.02, 5, 1);
    let start = Candidate {
        beta_bar: 150.0,
        viscous_friction_ns_per_m: 0.0,
        c12_m5_per_ns: 0.0,
    };
    let opts = UncertaintyOptions {
        confidence: 0.95,
        profile: [false; 3],
    };
    // the analysis is local (it polishes the identification's answer), so from this far off it
    // need not find the truth; it must start inside the bounds and stay there
    let u = analyze(&p, &start, &opts).unwrap();
    let c = u.best;
    let values = [c.beta_bar, c.viscous_friction_ns_per_m, c.c12_m5_per_ns];
    for (v, [lo, hi]) in values.into_iter().zip(pumpcyl::ident::BOUNDS) {
        assert!(lo <= v && v <= hi, "{c:?}");
    }
    assert!(u.sse_mm2.is_finite() && u.noise_std_mm > 0.0);
}

#[test]
fn bad_confidence_is_an_error() {
    let p = problem(&TRUTH, 0.02, 1, 1);
    for confidence in [0.0, 1.0, -0.5, f64::NAN] {
        let opts = UncertaintyOptions {
            confidence,
            profile: [true; 3],
        };
        let e = analyze(&p, &START, &opts).unwrap_err().to_string();
        assert!(e.contains("confidence"), "{e}");
    }
}

#[test]
fn identify_uncertainty_json_text_and_figures() {
    let dir = tempfile::tempdir().unwrap();
    let exp = synthetic::experiment_file(dir.path(), 0.02);
    let out = dir.path().join("out");
    let o = pumpcyl(&[
        "identify",
        &exp,
        "--uncertainty",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["confidence"], 0.95);
    let sigma = v["noise_std_mm"].as_f64().unwrap();
    assert!((sigma / 0.02 - 1.0).abs() < 0.15, "{sigma}");
    for (name, t) in [
        ("beta_bar", TRUTH.beta_bar),
        ("c12_m5_per_ns", TRUTH.c12_m5_per_ns),
    ] {
        let iv = v["intervals"][name].as_array().unwrap();
        let (lo, hi) = (iv[0].as_f64().unwrap(), iv[1].as_f64().unwrap());
        assert!(lo <= t && t <= hi, "{name}: {t} outside [{lo}, {hi}]");
        assert_eq!(v["identifiable"][name], true);
    }
    assert!(v["identifiable"]["viscous_friction_ns_per_m"].is_boolean());
    assert!(v["intervals"]["viscous_friction_ns_per_m"][1]
        .as_f64()
        .is_some());
    // the identification's own fields are still there
    assert!(v["beta_bar"].as_f64().is_some());
    for name in ["beta_bar", "viscous_friction_ns_per_m", "c12_m5_per_ns"] {
        for ext in ["svg", "png"] {
            let f = out.join(format!("profile-{name}.{ext}"));
            assert!(std::fs::metadata(&f).unwrap().len() > 1000, "{f:?}");
        }
    }
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    assert_eq!(saved["intervals"], v["intervals"]);

    let o = pumpcyl(&["identify", &exp, "--uncertainty", "--confidence", "0.9"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("90 % profile-likelihood intervals"), "{text}");
    assert!(
        text.contains("beta_bar") && text.contains("c12_m5_per_ns"),
        "{text}"
    );

    for (args, needle) in [
        (vec!["--uncertainty", "--confidence", "1.5"], "confidence"),
        (vec!["--confidence", "0.9"], "--uncertainty"),
    ] {
        let mut all = vec!["identify", exp.as_str()];
        all.extend(args);
        let o = pumpcyl(&all);
        assert!(!o.status.success());
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains(needle), "{e}");
        assert!(!e.contains("panicked"), "{e}");
    }
}

/// The embedded article records (emulated by the nonlinear rig, truth in data/article/README.md:
/// β_e 165 bar at the records' mean pressure, c12 1.2e-10, b 100 N·s/m): their residuals are
/// model error, strongly correlated, and with the inflation for it the 95 % intervals contain
/// the emulator's β and c12; a step does not bound b.
#[test]
fn article_records_intervals_contain_the_emulator_truth() {
    use pumpcyl::ident::{Experiment, Options};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/article/identify.toml");
    let exp = Experiment::load(&path).unwrap();
    let id = exp.identify(&Options::default()).unwrap();
    let u = analyze(
        &exp.problem,
        &id.best().candidate,
        &UncertaintyOptions::default(),
    )
    .unwrap();
    assert!(
        u.residual_autocorrelation > 0.5,
        "{}",
        u.residual_autocorrelation
    );
    // the integrated autocorrelation time of nearly AR(1) residuals: near (1 + ρ)/(1 − ρ);
    // each parameter's inflation adds the records' disagreement on top
    let rho = u.residual_autocorrelation;
    let ar1 = (1.0 + rho) / (1.0 - rho);
    assert!(
        (0.5..2.0).contains(&(u.variance_inflation / ar1)),
        "{} against {ar1}",
        u.variance_inflation
    );
    assert!(u
        .inflation_by_parameter
        .iter()
        .all(|&c| c >= u.variance_inflation));
    for (name, truth) in [("beta_bar", 165.0), ("c12_m5_per_ns", 1.2e-10)] {
        let p = u.profile(name).unwrap();
        let [lo, hi] = p.interval;
        assert!(lo <= truth && truth <= hi, "{name}: {lo} .. {hi}");
        assert!(p.identifiable, "{name}");
        // and still informative: narrower than ±20 %
        assert!(hi / lo < 1.2 * 1.2, "{name}: {lo} .. {hi}");
    }
    assert!(!u.profile("viscous_friction_ns_per_m").unwrap().identifiable);
}

/// Run the pumpcyl binary with `args`.
fn pumpcyl(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .output()
        .unwrap()
}
