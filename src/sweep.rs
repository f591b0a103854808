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
    /// Multisine: its period (s), a whole multiple of 1/--from-hz. Default: the designer's
    /// (lines dense about the resonance) where --from-hz is the designer's too, else 1/--from-hz.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    period_s: Option<f64>,
    /// Multisine: its lines. Default: the designer's (at least 30, as many as put two within
    /// the resonance's half-power band) where --from-hz is the designer's too, else 30.
    #[arg(long)]
    lines: Option<usize>,
    /// Stepped sine: its frequencies.
    #[arg(long, default_value_t = 12)]
    levels: usize,
    /// Stepped sine: periods discarded at each frequency (at least the loop's transient decay
    /// is discarded in any case).
    #[arg(long, default_value_t = 2)]
    settle_periods: usize,
}

impl SweepArgs {
    /// The band or the period is left to the designer.
    pub(crate) fn band_defaulted(&self) -> bool {
        self.from_hz.is_none() || self.to_hz.is_none() || self.period_s.is_none()
    }
}

impl From<SweepKind> for frf::SweepKind {
    fn from(k: SweepKind) -> frf::SweepKind {
        match k {
            SweepKind::Chirp => frf::SweepKind::Chirp,
            SweepKind::Multisine => frf::SweepKind::Multisine,
            SweepKind::SteppedSine => frf::SweepKind::SteppedSine,
        }
    }
}

/// The sweep asked for on `rig`, starting at `at_s`, for a record at `rate_hz`, checked: the
/// options as the keys of a sweep in a file ([`frf::SweepSpec`]), so both read the same.
pub(crate) fn excitation(
    kind: SweepKind,
    amplitude_mm: Option<f64>,
    at_s: f64,
    args: &SweepArgs,
    (rig, rate_hz): (&Rig, f64),
) -> Result<Excitation> {
    let spec = frf::SweepSpec {
        amplitude_mm,
        from_hz: args.from_hz,
        to_hz: args.to_hz,
        at_s: Some(at_s),
        sweep_s: args.sweep_s,
        periods: args.periods,
        period_s: args.period_s,
        lines: args.lines,
        levels: Some(args.levels),
        settle_periods: Some(args.settle_periods),
        ..frf::SweepSpec::of_kind(kind.into())
    };
    let spec = spec
        .resolved(rig, rate_hz)
        .map_err(|e| anyhow!("{}", e.message))?;
    spec.excitation(rig, rate_hz)
        .map_err(|err| crate::emit::as_option(err, option_of))
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
        "period_s" => "period-s",
        "start_s" => "at-s",
        "rate_hz" => "rate-hz",
        other => other,
    }
}

/// The designer's sweep for `rig` at `rate_hz`.
pub(crate) fn design_for(rig: &Rig, rate_hz: f64) -> Result<Design> {
    frf::design(rig, &goal_at(rate_hz)).map_err(|e| anyhow!("designing the sweep: {e}"))
}

/// The designer's default goal for a record at `rate_hz`.
pub(crate) fn goal_at(rate_hz: f64) -> DesignGoal {
    DesignGoal {
        rate_hz,
        ..DesignGoal::default()
    }
}
