//! `pumpcyl advise`: which further record would narrow the intervals of β, b and c12 most,
//! from the linearised model (docs/identification.md, "Experiment advice"), shown as
//! [`pumpcyl_present::advise`] formats it.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

use pumpcyl_present::request::advise::Advise;

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
    /// amp_mm, kp, duration_s; [[sweep]] kp and a sweep's keys: kind, amplitude_mm, from_hz,
    /// to_hz, periods, lines, levels, sweep_s, settle_periods). Default: steps of 2, 5, 10,
    /// 20 mm and sinusoids of 0.1 to 1.5 Hz at the experiment's gains and at Kp 15, 25, 35,
    /// and the designer's multisine at the experiment's gains.
    #[arg(long, value_name = "FILE.toml")]
    candidates: Option<PathBuf>,
    /// Weigh every candidate at this recording time (s): its record counted budget/length
    /// times, candidates longer than it skipped. Default: each candidate is one record.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    budget_s: Option<f64>,
    /// An experiment at another pressure level (repeatable): with this experiment's own, the
    /// family of beta(p) models is fitted to them and the next level to record named
    /// (docs/bulk-modulus.md#several-pressure-levels).
    #[arg(long, value_name = "EXPERIMENT.toml")]
    level: Vec<PathBuf>,
}

/// Run the identification of the experiment, then the advice.
pub fn run(args: &AdviseArgs) -> Result<String> {
    pumpcyl_present::request::check_confidence(args.confidence)?;
    let request = Advise {
        experiment: crate::read_files::experiment(&args.experiment)?,
        candidates: args.candidates.clone(),
        confidence: args.confidence,
        budget_s: args.budget_s,
        files: crate::read_files::files(),
        levels: (args.level.iter())
            .map(|p| crate::read_files::experiment(p))
            .collect::<Result<Vec<_>>>()?,
    };
    crate::emit::show(&crate::emit::run(&request)?, args.json)
}
