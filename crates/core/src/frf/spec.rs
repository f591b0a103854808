//! A sweep as written in a file (docs/formats.md#sweep-records-and-their-description): the keys of an experiment
//! file's `[dataset.sweep]` and of `advise`'s `[[sweep]]` candidates, the same names as
//! `pumpcyl emulate --experiment chirp|multisine|stepped-sine`'s options, and the excitation
//! they describe, the absent band and amplitude taken from the sweep designer
//! ([`super::design()`]) as `emulate` takes them.

use super::design::{averages_for, design, DesignGoal};
use super::Excitation;
use crate::rig::Rig;
use crate::source_files::FieldError;
use serde::{Deserialize, Serialize};

/// The sweeps pumpcyl can emulate, describe and advise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SweepKind {
    /// Logarithmic chirp, faded in and out, played `periods` times.
    Chirp,
    /// Multisine with Schroeder phases on the grid of its period (1/`from_hz`).
    Multisine,
    /// One sine after another, log-spaced, settling then `periods` whole periods each.
    SteppedSine,
}

impl SweepKind {
    /// The name in files and on the command line: `chirp`, `multisine`, `stepped-sine`.
    pub fn name(&self) -> &'static str {
        match self {
            SweepKind::Chirp => "chirp",
            SweepKind::Multisine => "multisine",
            SweepKind::SteppedSine => "stepped-sine",
        }
    }
}

pub use super::excitation::DEFAULT_LINES;
/// Levels of a stepped sine when `levels` is absent.
pub const DEFAULT_LEVELS: usize = 12;
/// Periods discarded per level of a stepped sine when `settle_periods` is absent.
pub const DEFAULT_SETTLE_PERIODS: usize = 2;
/// Where a sweep starts (s) when `at_s` is absent.
pub const DEFAULT_AT_S: f64 = 0.5;

/// A sweep's keys; every one but `kind` may be left out (the defaults of
/// docs/formats.md#sweep-records-and-their-description).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// `chirp`, `multisine` or `stepped-sine`.
    pub kind: SweepKind,
    /// Peak deviation from x0 (mm). Default: the designer's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude_mm: Option<f64>,
    /// Lowest frequency (Hz). Default: the designer's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from_hz: Option<f64>,
    /// Highest frequency (Hz). Default: the designer's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to_hz: Option<f64>,
    /// The sweep's start (s); x0 before it. Default: [`DEFAULT_AT_S`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_s: Option<f64>,
    /// Chirp: one sweep's length (s). Default: 10 periods of `from_hz`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep_s: Option<f64>,
    /// Chirp: sweeps played; multisine: periods (the first settles); stepped sine: periods
    /// fitted per level. Default: 3; 24 (ε = 5 % at coherence 0.9); 4.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub periods: Option<usize>,
    /// Multisine: its period (s), a whole multiple of 1/`from_hz` for its lowest line to lie
    /// there. Default: the designer's where `from_hz` is the designer's too, else 1/`from_hz`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period_s: Option<f64>,
    /// Multisine: lines. Default: the designer's where `from_hz` is the designer's too (as
    /// many as the resonance needs, at least [`DEFAULT_LINES`]), else [`DEFAULT_LINES`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lines: Option<usize>,
    /// Stepped sine: levels. Default: [`DEFAULT_LEVELS`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<usize>,
    /// Stepped sine: periods discarded per level (at least the loop's transient decay is).
    /// Default: [`DEFAULT_SETTLE_PERIODS`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settle_periods: Option<usize>,
}

impl SweepSpec {
    /// A sweep of `kind` with every other key at its default.
    pub fn of_kind(kind: SweepKind) -> SweepSpec {
        SweepSpec {
            kind,
            amplitude_mm: None,
            from_hz: None,
            to_hz: None,
            at_s: None,
            sweep_s: None,
            periods: None,
            period_s: None,
            lines: None,
            levels: None,
            settle_periods: None,
        }
    }

    /// The same sweep with its band and amplitude filled in from the designer for `rig` at
    /// `rate_hz` where absent, so that it no longer depends on the rig's parameters.
    pub fn resolved(&self, rig: &Rig, rate_hz: f64) -> Result<SweepSpec, FieldError> {
        if let (Some(_), Some(_), Some(_)) = (self.from_hz, self.to_hz, self.amplitude_mm) {
            return Ok(*self);
        }
        let goal = DesignGoal {
            rate_hz,
            ..DesignGoal::default()
        };
        let d = design(rig, &goal)
            .map_err(|e| FieldError::new("from_hz", format!("designing the sweep: {e}")))?;
        let designed_period = self.from_hz.is_none() && self.kind == SweepKind::Multisine;
        Ok(SweepSpec {
            period_s: self.period_s.or(designed_period.then_some(d.period_s)),
            lines: self.lines.or(designed_period.then_some(d.lines)),
            from_hz: self.from_hz.or(Some(d.from_hz)),
            to_hz: self.to_hz.or(Some(d.to_hz)),
            amplitude_mm: self.amplitude_mm.or(Some(d.amplitude_mm)),
            ..*self
        })
    }

    /// The excitation this describes about `rig`'s x0 for a record at `rate_hz`, checked
    /// ([`Excitation::check`]); absent band and amplitude from the designer.
    pub fn excitation(&self, rig: &Rig, rate_hz: f64) -> Result<Excitation, FieldError> {
        let s = self.resolved(rig, rate_hz)?;
        let band = (s.from_hz.unwrap_or_default(), s.to_hz.unwrap_or_default());
        let amplitude_mm = s.amplitude_mm.unwrap_or_default();
        let e = match s.kind {
            SweepKind::Chirp => Excitation::chirp(
                rig,
                amplitude_mm,
                band,
                (s.sweep_s.unwrap_or(10.0 / band.0), s.periods.unwrap_or(3)),
                rate_hz,
            ),
            SweepKind::Multisine => Excitation::multisine(
                rig,
                amplitude_mm,
                band,
                (
                    s.lines.unwrap_or(DEFAULT_LINES),
                    s.periods.unwrap_or(averages_for(0.9, 0.05) + 1),
                ),
                rate_hz,
            )
            .with_period(s.period_s.unwrap_or(1.0 / band.0), rate_hz),
            SweepKind::SteppedSine => {
                let decay_s = crate::response::transient_decay_s(rig).unwrap_or(0.0);
                Excitation::stepped_sine(
                    rig,
                    amplitude_mm,
                    band,
                    (s.levels.unwrap_or(DEFAULT_LEVELS), s.periods.unwrap_or(4)),
                    (s.settle_periods.unwrap_or(DEFAULT_SETTLE_PERIODS), decay_s),
                )
            }
        }
        .starting_at(s.at_s.unwrap_or(DEFAULT_AT_S));
        e.check(rate_hz, rig)?;
        Ok(e)
    }
}
