//! The sweeps `pumpcyl emulate` records and `pumpcyl frf` reads back
//! (docs/identification.md#frequency-response-from-a-sweep): their options, their defaults from
//! the sweep designer, and the excitation they describe.

use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
use pumpcyl::frf::{self, Design, DesignGoal, Excitation};
use pumpcyl::rig::Rig;

/// The sweeps pumpcyl can emulate and describe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SweepKind {
    /// Logarithmic chirp, faded in and out, played --periods times.
    Chirp,
    /// Multisine with Schroeder phases on the grid of its period (1/--from-hz).
    Multisine,
    /// One sine after another, log-spaced, settling then --periods whole periods each.
    SteppedSine,
}

/// How a sweep is shaped (`emulate --experiment chirp|multisine|stepped-sine`, `frf --sweep`).
/// Absent band limits come from the sweep designer (`pumpcyl frf --design`).
#[derive(Debug, Clone, Args)]
pub struct SweepArgs {
    /// Sweep: lowest frequency (Hz). Default: the designer's (a tenth of the loop's crossover).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    from_hz: Option<f64>,
    /// Sweep: highest frequency (Hz). Default: the designer's (past the hydraulic resonance).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    to_hz: Option<f64>,
    /// Chirp: the length of one sweep (s). Default: 10 periods of --from-hz.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    sweep_s: Option<f64>,
    /// Sweeps of a chirp, periods of a multisine (the first settles) or periods fitted per
    /// frequency of a stepped sine. Default: 3, 24 (for ε = 5 % at coherence 0.9), 4.
    #[arg(long)]
    periods: Option<usize>,
    /// Multisine: its lines.
    #[arg(long, default_value_t = 30)]
    lines: usize,
    /// Stepped sine: its frequencies.
    #[arg(long, default_value_t = 12)]
    levels: usize,
    /// Stepped sine: periods discarded at each frequency (at least the loop's transient decay
    /// is discarded in any case).
    #[arg(long, default_value_t = 2)]
    settle_periods: usize,
}

/// The sweep asked for on `rig`, starting at `at_s`, for a record at `rate_hz`, checked.
pub(crate) fn excitation(
    kind: SweepKind,
    amplitude_mm: Option<f64>,
    at_s: f64,
    args: &SweepArgs,
    (rig, rate_hz): (&Rig, f64),
) -> Result<Excitation> {
    let (band, amplitude_mm) = match (args.from_hz, args.to_hz, amplitude_mm) {
        (Some(lo), Some(hi), Some(a)) => ((lo, hi), a),
        _ => {
            let d = design_for(rig, rate_hz)?;
            (
                (
                    args.from_hz.unwrap_or(d.from_hz),
                    args.to_hz.unwrap_or(d.to_hz),
                ),
                amplitude_mm.unwrap_or(d.amplitude_mm),
            )
        }
    };
    let e = match kind {
        SweepKind::Chirp => Excitation::chirp(
            rig,
            amplitude_mm,
            band,
            (
                args.sweep_s.unwrap_or(10.0 / band.0),
                args.periods.unwrap_or(3),
            ),
            rate_hz,
        ),
        SweepKind::Multisine => Excitation::multisine(
            rig,
            amplitude_mm,
            band,
            (
                args.lines,
                args.periods
                    .unwrap_or(frf::design::averages_for(0.9, 0.05) + 1),
            ),
            rate_hz,
        ),
        SweepKind::SteppedSine => {
            let decay_s = pumpcyl::response::transient_decay_s(rig).unwrap_or(0.0);
            Excitation::stepped_sine(
                rig,
                amplitude_mm,
                band,
                (args.levels, args.periods.unwrap_or(4)),
                (args.settle_periods, decay_s),
            )
        }
    }
    .starting_at(at_s);
    e.check(rate_hz, rig)
        .map_err(|err| crate::emit::as_option(err, option_of))?;
    Ok(e)
}

/// The option that sets a sweep's field.
pub(crate) fn option_of(field: &str) -> &str {
    match field {
        "from_hz" => "from-hz",
        "to_hz" => "to-hz",
        "amplitude_mm" => "amplitude-mm",
        "duration_s" => "sweep-s",
        "sweeps" | "periods" => "periods",
        "settle_periods" => "settle-periods",
        "start_s" => "at-s",
        "rate_hz" => "rate-hz",
        other => other,
    }
}

/// The designer's sweep for `rig` at `rate_hz`.
pub(crate) fn design_for(rig: &Rig, rate_hz: f64) -> Result<Design> {
    let goal = DesignGoal {
        rate_hz,
        ..DesignGoal::default()
    };
    frf::design(rig, &goal).map_err(|e| anyhow!("designing the sweep: {e}"))
}
