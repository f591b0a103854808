//! `pumpcyl advise`: which further record would narrow the intervals of β, b and c12 most,
//! from the linearised model (docs/identification.md, "Experiment advice"); formatting only.

use anyhow::Result;
use clap::Args;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use pumpcyl::ident::{advise_experiment, Advice, Experiment, Width};

#[derive(Debug, Args)]
pub struct AdviseArgs {
    /// Experiment description (TOML), as for `pumpcyl identify`: its records are identified
    /// first, then the candidates compared at the answer.
    experiment: PathBuf,
    /// Confidence level of the expected intervals, in (0, 1).
    #[arg(long, default_value_t = 0.95)]
    confidence: f64,
    /// Print JSON (point, noise_std_mm, current, candidates ranked, best_for, skipped).
    #[arg(long)]
    json: bool,
    /// Candidate experiments (TOML: [[step]] step_mm, kp, duration_s; [[sine]] freq_hz,
    /// amp_mm, kp, duration_s). Default: steps of 2, 5, 10, 20 mm and sinusoids of 0.1 to
    /// 1.5 Hz at the experiment's gains and at Kp 15, 25, 35.
    #[arg(long, value_name = "FILE.toml")]
    candidates: Option<PathBuf>,
}

/// Run the identification of the experiment, then the advice.
pub fn run(args: &AdviseArgs) -> Result<String> {
    crate::emit::check_confidence(args.confidence)?;
    let exp = Experiment::load_in(crate::inputs::files(), &args.experiment)?;
    let start = Instant::now();
    let advice = advise_experiment(
        &exp,
        crate::inputs::files(),
        args.candidates.as_deref(),
        args.confidence,
    )?;
    let seconds = start.elapsed().as_secs_f64();
    if args.json {
        let mut v = serde_json::to_value(&advice)?;
        v["experiment"] = serde_json::json!(args.experiment.display().to_string());
        v["seconds"] = serde_json::json!(seconds);
        return Ok(serde_json::to_string_pretty(&v)? + "\n");
    }
    Ok(text(
        &args.experiment.display().to_string(),
        &advice,
        seconds,
    ))
}

/// A relative width as the table shows it: `12.3 %` or `unbounded`.
fn shown(w: &Width) -> String {
    w.relative_width
        .map_or("unbounded".into(), |r| format!("{:.1} %", 100.0 * r))
}

/// The advice as text: the point, the current widths, the table, the best per parameter.
fn text(name: &str, a: &Advice, seconds: f64) -> String {
    let mut s = String::new();
    let p = &a.point;
    let _ = writeln!(
        s,
        "experiment advice for {name} (linearised at beta {:.1} bar, b {:.1} N·s/m, c12 {:.4e} \
         m⁵/(N·s); noise sigma {:.4} mm, variance inflated {:.1}-fold; {:.0} % intervals, \
         widths relative to the estimate), in {seconds:.1} s",
        p.beta_bar,
        p.viscous_friction_ns_per_m,
        p.c12_m5_per_ns,
        a.noise_std_mm,
        a.variance_inflation,
        a.confidence * 100.0
    );
    let _ = writeln!(
        s,
        "{:>4}  {:<36} {:>10} {:>10} {:>10}   {:>7} {:>7} {:>7}",
        "rank", "record added", "beta", "b", "c12", "x beta", "x b", "x c12"
    );
    let _ = writeln!(
        s,
        "{:>4}  {:<36} {:>10} {:>10} {:>10}",
        "-",
        "none (the current records)",
        shown(&a.current[0]),
        shown(&a.current[1]),
        shown(&a.current[2])
    );
    for (k, c) in a.candidates.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:>4}  {:<36} {:>10} {:>10} {:>10}   {:>7.2} {:>7.2} {:>7.2}",
            k + 1,
            c.label,
            shown(&c.widths[0]),
            shown(&c.widths[1]),
            shown(&c.widths[2]),
            c.improvement[0],
            c.improvement[1],
            c.improvement[2]
        );
    }
    for line in &a.skipped {
        let _ = writeln!(s, "skipped: {line}");
    }
    if let Some(b) = a.candidates.iter().find(|c| c.label == a.best_for[1]) {
        let _ = writeln!(
            s,
            "helps b most: {} (b {} -> {}, {:.1} times narrower in log terms)",
            b.label,
            shown(&a.current[1]),
            shown(&b.widths[1]),
            b.improvement[1]
        );
    }
    let _ = writeln!(
        s,
        "best for beta: {}; best for c12: {}",
        a.best_for[0], a.best_for[2]
    );
    s
}
