//! The position references of a closed-loop sweep about the operating point
//! (docs/identification.md#frequency-response-from-a-sweep): a logarithmic chirp, a periodic
//! multisine with Schroeder phases, and a stepped sine. Each is a small `Copy` value: its
//! frequencies are computed from its parameters, so an emulated experiment can hold it.

use crate::rig::Rig;
use crate::source_files::FieldError;
use std::f64::consts::PI;

/// The most lines of a multisine or levels of a stepped sine (every loop over them is bounded).
pub const MAX_LINES: usize = 200;
/// Lines of a multisine when `lines` is absent and the band is not the designer's.
pub const DEFAULT_LINES: usize = 30;
/// The fewest samples per period of the highest frequency an excitation may ask for: four
/// samples show a sine's amplitude and phase; fewer alias the sweep into the estimate.
pub const MIN_SAMPLES_PER_PERIOD: f64 = 4.0;
/// The most harmonics of a periodic chirp an estimate looks at.
pub const MAX_HARMONICS: usize = 100_000;
/// The points over one period on which a multisine's peak is found (for its scale).
const PEAK_GRID: usize = 4096;

/// A sweep of the position reference about `centre_mm`, starting at `start_s` (the reference
/// holds the centre before that).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Excitation {
    /// Logarithmic chirp from `from_hz` to `to_hz` over `sweep_s`, amplitude `amplitude_mm`,
    /// faded in and out by raised cosines of `fade_s` each, played `sweeps` times in a row: from
    /// three sweeps on, the record is periodic after the first and its sweeps are averaged
    /// like a multisine's periods.
    Chirp {
        /// Centre of the sweep and the reference outside it (mm).
        centre_mm: f64,
        /// Amplitude (mm).
        amplitude_mm: f64,
        /// Start frequency (Hz).
        from_hz: f64,
        /// End frequency (Hz).
        to_hz: f64,
        /// Start of the sweep (s).
        start_s: f64,
        /// Length of the sweep (s).
        sweep_s: f64,
        /// Length of the fade in and of the fade out (s).
        fade_s: f64,
        /// Sweeps played one after the other.
        sweeps: usize,
    },
    /// Sum of `lines` sines on the grid k/`period_s` (log-spaced k from `from_hz`·period to
    /// `to_hz`·period, repeats dropped), Schroeder phases, scaled to the peak `amplitude_mm`;
    /// `periods` periods, the first of which lets the loop settle.
    Multisine {
        /// Centre (mm).
        centre_mm: f64,
        /// Peak deviation from the centre (mm).
        amplitude_mm: f64,
        /// Lowest frequency asked for (Hz).
        from_hz: f64,
        /// Highest frequency asked for (Hz).
        to_hz: f64,
        /// Number of lines asked for (fewer if the grid holds fewer).
        lines: usize,
        /// Period (s).
        period_s: f64,
        /// Periods played, the first one for settling.
        periods: usize,
        /// Start (s).
        start_s: f64,
        /// Amplitude of each line (mm), set by [`Excitation::multisine`] from the peak.
        line_mm: f64,
    },
    /// `levels` sines log-spaced from `from_hz` to `to_hz`, each played for `settle_periods`
    /// but at least `settle_s` (discarded, rounded up to whole periods) then `periods` (fitted)
    /// whole periods, starting and ending at the centre.
    SteppedSine {
        /// Centre (mm).
        centre_mm: f64,
        /// Amplitude (mm).
        amplitude_mm: f64,
        /// Lowest frequency (Hz).
        from_hz: f64,
        /// Highest frequency (Hz).
        to_hz: f64,
        /// Number of frequencies.
        levels: usize,
        /// Periods fitted at each frequency.
        periods: usize,
        /// Periods discarded at each frequency while the loop settles.
        settle_periods: usize,
        /// The least settling time at each frequency (s): the loop's transient decay.
        settle_s: f64,
        /// Start (s).
        start_s: f64,
    },
}

/// Relative tolerance on the end of a sweep ([`Excitation::reference_mm`]): far below a sample
/// and far above the rounding of a time in a record.
const END_TOLERANCE: f64 = 1e-9;

/// Time of the first sweep when none is given (s): a second at the operating point.
pub const START_S: f64 = 1.0;

impl Excitation {
    /// `sweeps` chirps about the rig's x0 from [`START_S`], each `sweep_s` rounded to whole
    /// samples at `rate_hz` (so repeated sweeps are periodic in the record) and faded over a
    /// tenth of the sweep or one period of `from_hz`, whichever is shorter.
    pub fn chirp(
        rig: &Rig,
        amplitude_mm: f64,
        (from_hz, to_hz): (f64, f64),
        (sweep_s, sweeps): (f64, usize),
        rate_hz: f64,
    ) -> Self {
        let sweep_s = whole_samples(sweep_s, rate_hz);
        let fade_s = (0.1 * sweep_s).min(1.0 / from_hz.max(f64::MIN_POSITIVE));
        Excitation::Chirp {
            centre_mm: rig.x0_mm,
            amplitude_mm,
            from_hz,
            to_hz,
            start_s: START_S,
            sweep_s,
            fade_s,
            sweeps,
        }
    }

    /// A multisine about the rig's x0 whose period holds whole periods of every line and whole
    /// samples at `rate_hz`: the period is 1/`from_hz` rounded to whole samples, so the lowest
    /// line is the first harmonic and every line lies on the record's frequency grid.
    pub fn multisine(
        rig: &Rig,
        amplitude_mm: f64,
        (from_hz, to_hz): (f64, f64),
        (lines, periods): (usize, usize),
        rate_hz: f64,
    ) -> Self {
        Excitation::Multisine {
            centre_mm: rig.x0_mm,
            amplitude_mm,
            from_hz,
            to_hz,
            lines,
            period_s: 0.0,
            periods,
            start_s: START_S,
            line_mm: 0.0,
        }
        .with_period(1.0 / from_hz, rate_hz)
    }

    /// The same multisine with the period `period_s` rounded to whole samples at `rate_hz`
    /// (its lines the harmonics of that period in its band), its lines rescaled to the same
    /// peak; a period shorter than 1/`from_hz` holds no line there ([`Excitation::check`]
    /// refuses it). Another sweep is returned unchanged.
    pub fn with_period(mut self, period_s: f64, rate_hz: f64) -> Self {
        if let Excitation::Multisine { period_s: p, .. } = &mut self {
            *p = whole_samples(period_s, rate_hz);
        }
        let peak = self.unit_peak();
        if let Excitation::Multisine {
            line_mm,
            amplitude_mm,
            ..
        } = &mut self
        {
            *line_mm = if peak > 0.0 {
                *amplitude_mm / peak
            } else {
                0.0
            };
        }
        self
    }

    /// A stepped sine about the rig's x0, settling at each level for `settle_periods` and at
    /// least `settle_s`.
    pub fn stepped_sine(
        rig: &Rig,
        amplitude_mm: f64,
        (from_hz, to_hz): (f64, f64),
        (levels, periods): (usize, usize),
        (settle_periods, settle_s): (usize, f64),
    ) -> Self {
        Excitation::SteppedSine {
            centre_mm: rig.x0_mm,
            amplitude_mm,
            from_hz,
            to_hz,
            levels,
            periods,
            settle_periods,
            settle_s,
            start_s: START_S,
        }
    }

    /// The same sweep starting at `start_s` (s).
    pub fn starting_at(mut self, start_s: f64) -> Self {
        match &mut self {
            Excitation::Chirp { start_s: s, .. }
            | Excitation::Multisine { start_s: s, .. }
            | Excitation::SteppedSine { start_s: s, .. } => *s = start_s,
        }
        self
    }

    /// The name used on the command line and in files: `chirp`, `multisine`, `stepped-sine`.
    pub fn name(&self) -> &'static str {
        match self {
            Excitation::Chirp { .. } => "chirp",
            Excitation::Multisine { .. } => "multisine",
            Excitation::SteppedSine { .. } => "stepped-sine",
        }
    }

    /// The centre of the sweep (mm).
    pub fn centre_mm(&self) -> f64 {
        match *self {
            Excitation::Chirp { centre_mm, .. }
            | Excitation::Multisine { centre_mm, .. }
            | Excitation::SteppedSine { centre_mm, .. } => centre_mm,
        }
    }

    /// When the sweep starts (s).
    pub fn start_s(&self) -> f64 {
        match *self {
            Excitation::Chirp { start_s, .. }
            | Excitation::Multisine { start_s, .. }
            | Excitation::SteppedSine { start_s, .. } => start_s,
        }
    }

    /// The frequency band asked for (Hz).
    pub fn band_hz(&self) -> (f64, f64) {
        match *self {
            Excitation::Chirp { from_hz, to_hz, .. }
            | Excitation::Multisine { from_hz, to_hz, .. }
            | Excitation::SteppedSine { from_hz, to_hz, .. } => (from_hz, to_hz),
        }
    }

    /// Record length: the lead-in at the centre and the whole sweep (s).
    pub fn duration_s(&self) -> f64 {
        let sweep = match *self {
            Excitation::Chirp {
                sweep_s, sweeps, ..
            } => sweep_s * sweeps as f64,
            Excitation::Multisine {
                period_s, periods, ..
            } => period_s * periods as f64,
            Excitation::SteppedSine { .. } => self.levels().iter().map(|l| l.end_s).sum(),
        };
        self.start_s() + sweep
    }

    /// The multisine's lines as harmonics k of 1/period (empty for the other sweeps): `lines`
    /// log-spaced harmonics from `from_hz`·period to `to_hz`·period, rounded, repeats dropped.
    pub fn harmonics(&self) -> Vec<u32> {
        let Excitation::Multisine {
            from_hz,
            to_hz,
            lines,
            period_s,
            ..
        } = *self
        else {
            return Vec::new();
        };
        let (k0, k1) = ((from_hz * period_s).round(), (to_hz * period_s).round());
        if !(k0 >= 1.0 && k1 >= k0 && k1 < 1e7) {
            return Vec::new();
        }
        let n = lines.clamp(1, MAX_LINES);
        let mut ks: Vec<u32> = crate::lti::log_grid(k0, k1.max(k0), n.max(2))
            .iter()
            .take(n)
            .map(|k| k.round() as u32)
            .collect();
        ks.dedup();
        ks
    }

    /// The period of a periodic sweep (s): a multisine's, or a chirp's sweep when it is played
    /// at least three times; `None` otherwise.
    pub fn period_s(&self) -> Option<f64> {
        match *self {
            Excitation::Multisine { period_s, .. } => Some(period_s),
            Excitation::Chirp {
                sweep_s, sweeps, ..
            } if sweeps >= 3 => Some(sweep_s),
            _ => None,
        }
    }

    /// The harmonics of 1/period a periodic sweep excites: a multisine's lines, every harmonic
    /// of a periodic chirp's band (at most [`MAX_HARMONICS`]).
    pub fn excited_harmonics(&self) -> Vec<u32> {
        match (*self, self.period_s()) {
            (Excitation::Chirp { from_hz, to_hz, .. }, Some(p)) => {
                let k0 = (from_hz * p).ceil().max(1.0);
                let k1 = (to_hz * p).floor().min(k0 + MAX_HARMONICS as f64 - 1.0);
                (k0 as u32..=k1.max(k0 - 1.0) as u32).collect()
            }
            _ => self.harmonics(),
        }
    }

    /// The frequencies the sweep holds (Hz): the multisine's lines, the stepped sine's levels,
    /// empty for a chirp (it holds a continuum).
    pub fn frequencies_hz(&self) -> Vec<f64> {
        match *self {
            Excitation::Multisine { period_s, .. } => self
                .harmonics()
                .iter()
                .map(|&k| f64::from(k) / period_s)
                .collect(),
            Excitation::SteppedSine { .. } => self.levels().iter().map(|l| l.freq_hz).collect(),
            Excitation::Chirp { .. } => Vec::new(),
        }
    }

    /// The stepped sine's levels: frequency, start after the previous level, settling end
    /// and end, in seconds from the sweep's start (empty for the other sweeps).
    pub fn levels(&self) -> Vec<Level> {
        let Excitation::SteppedSine {
            from_hz,
            to_hz,
            levels,
            periods,
            settle_periods,
            settle_s: least_s,
            ..
        } = *self
        else {
            return Vec::new();
        };
        let n = levels.clamp(1, MAX_LINES);
        let freqs = if n == 1 {
            vec![from_hz]
        } else {
            crate::lti::log_grid(from_hz, to_hz, n)
        };
        let mut t = 0.0;
        freqs
            .into_iter()
            .map(|f| {
                let settle_s = (settle_periods as f64).max((least_s * f).ceil()) / f;
                let end_s = settle_s + periods as f64 / f;
                let level = Level {
                    freq_hz: f,
                    start_s: t,
                    settle_s,
                    end_s,
                };
                t += end_s;
                level
            })
            .collect()
    }

    /// The position reference (mm) at time `t` (s).
    pub fn reference_mm(&self, t: f64) -> f64 {
        let tau = t - self.start_s();
        // the last sample of a sweep of whole samples lies at its end: within rounding of it,
        // whether its time was computed or read from a file, it is the sweep's
        let span = self.duration_s() - self.start_s();
        if tau < 0.0 || tau > span + END_TOLERANCE * span.max(1.0) {
            return self.centre_mm();
        }
        self.centre_mm() + self.deviation_mm(tau)
    }

    /// The deviation from the centre `tau` seconds into the sweep (mm).
    fn deviation_mm(&self, tau: f64) -> f64 {
        match *self {
            Excitation::Chirp {
                amplitude_mm,
                from_hz,
                to_hz,
                sweep_s,
                fade_s,
                ..
            } => {
                let tau = tau % sweep_s;
                amplitude_mm
                    * fade(tau, sweep_s, fade_s)
                    * chirp_phase(tau, from_hz, to_hz, sweep_s).sin()
            }
            Excitation::Multisine {
                period_s, line_mm, ..
            } => line_mm * self.unit_multisine(tau / period_s),
            Excitation::SteppedSine { amplitude_mm, .. } => self
                .levels()
                .iter()
                .find(|l| tau < l.start_s + l.end_s)
                .map_or(0.0, |l| {
                    amplitude_mm * (2.0 * PI * l.freq_hz * (tau - l.start_s)).sin()
                }),
        }
    }

    /// The multisine's sum of unit lines at `phase` periods, Schroeder phases
    /// φ_i = −π i(i − 1)/N (Schroeder, IEEE Trans. Inf. Theory 16, 1970, 85–89).
    fn unit_multisine(&self, phase: f64) -> f64 {
        let ks = self.harmonics();
        let n = ks.len() as f64;
        ks.iter()
            .enumerate()
            .map(|(i, &k)| {
                let i = i as f64 + 1.0;
                (2.0 * PI * f64::from(k) * phase - PI * i * (i - 1.0) / n).cos()
            })
            .sum()
    }

    /// The peak of the unit multisine over one period.
    fn unit_peak(&self) -> f64 {
        (0..PEAK_GRID)
            .map(|j| self.unit_multisine(j as f64 / PEAK_GRID as f64).abs())
            .fold(0.0, f64::max)
    }

    /// The lowest and highest value over one period (on 4096 points) of a linear
    /// system's periodic response to the multisine, `h` its response at each line
    /// ([`Excitation::frequencies_hz`]) per mm of reference, at the multisine's own amplitude:
    /// the excursion of that output about its rest. (0, 0) for the other sweeps.
    pub fn response_range(&self, h: &[num_complex::Complex64]) -> (f64, f64) {
        let Excitation::Multisine { line_mm, .. } = *self else {
            return (0.0, 0.0);
        };
        let ks = self.harmonics();
        let n = ks.len() as f64;
        let at = |phase: f64| {
            (ks.iter().zip(h).enumerate())
                .map(|(i, (&k, h))| {
                    let i = i as f64 + 1.0;
                    let arg = 2.0 * PI * f64::from(k) * phase - PI * i * (i - 1.0) / n;
                    line_mm * (h * num_complex::Complex64::from_polar(1.0, arg)).re
                })
                .sum::<f64>()
        };
        (0..PEAK_GRID)
            .map(|j| at(j as f64 / PEAK_GRID as f64))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    }

    /// Refuse what cannot work at `rate_hz` on `rig`: a band that is not 0 < from ≤ to, a
    /// highest frequency with fewer than [`MIN_SAMPLES_PER_PERIOD`] samples per period
    /// (which includes the Nyquist frequency), a reference leaving the stroke, a sweep too
    /// short to hold a period of its lowest frequency, counts of zero or beyond [`MAX_LINES`].
    /// The error names the field.
    pub fn check(&self, rate_hz: f64, rig: &Rig) -> Result<(), FieldError> {
        let (from_hz, to_hz) = self.band_hz();
        let field = |f: &'static str, m: String| Err(FieldError::new(f, format!("{f} = {m}")));
        if !(from_hz.is_finite() && from_hz > 0.0) {
            return field("from_hz", format!("{from_hz}: must be > 0"));
        }
        if !(to_hz.is_finite() && to_hz >= from_hz) {
            return field("to_hz", format!("{to_hz}: must be >= from_hz ({from_hz})"));
        }
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return field("rate_hz", format!("{rate_hz}: must be > 0"));
        }
        if to_hz * MIN_SAMPLES_PER_PERIOD > rate_hz {
            return field(
                "to_hz",
                format!(
                    "{to_hz}: {:.3} samples per period at {rate_hz} Hz, at least \
                     {MIN_SAMPLES_PER_PERIOD} are needed (below {} Hz)",
                    rate_hz / to_hz,
                    rate_hz / MIN_SAMPLES_PER_PERIOD
                ),
            );
        }
        if !(self.start_s().is_finite() && self.start_s() >= 0.0) {
            return field("start_s", format!("{}: must be >= 0", self.start_s()));
        }
        self.check_shape(from_hz)?;
        let (a, c) = (self.amplitude_mm(), self.centre_mm());
        if !(a.is_finite() && a > 0.0) {
            return field("amplitude_mm", format!("{a}: must be > 0"));
        }
        rig.check_reference(c - a, c + a)
            .map_err(|e| FieldError::new("amplitude_mm", format!("amplitude_mm = {a}: {e}")))
    }

    /// Counts and lengths of each kind of sweep.
    fn check_shape(&self, from_hz: f64) -> Result<(), FieldError> {
        let count = |f: &'static str, n: usize, lo: usize| {
            if (lo..=MAX_LINES).contains(&n) {
                return Ok(());
            }
            Err(FieldError::new(
                f,
                format!("{f} = {n}: must be {lo} … {MAX_LINES}"),
            ))
        };
        match *self {
            Excitation::Chirp {
                sweep_s,
                fade_s,
                sweeps,
                ..
            } => {
                count("sweeps", sweeps, 1)?;
                if !(sweep_s.is_finite() && sweep_s * from_hz >= 1.0) {
                    return Err(FieldError::new(
                        "duration_s",
                        format!(
                            "duration_s = {sweep_s}: a chirp from {from_hz} Hz needs at least one \
                             period of it ({} s)",
                            1.0 / from_hz
                        ),
                    ));
                }
                if !(fade_s.is_finite() && fade_s >= 0.0 && 2.0 * fade_s <= sweep_s) {
                    return Err(FieldError::new(
                        "fade_s",
                        format!("fade_s = {fade_s}: must be 0 … half the sweep ({sweep_s} s)"),
                    ));
                }
                Ok(())
            }
            Excitation::Multisine {
                lines,
                periods,
                period_s,
                ..
            } => {
                count("lines", lines, 1)?;
                count("periods", periods, 2)?;
                if !(period_s.is_finite() && period_s * from_hz >= 0.5) {
                    return Err(FieldError::new(
                        "period_s",
                        format!(
                            "period_s = {period_s}: a multisine from {from_hz} Hz needs a period \
                             of at least 1/from_hz ({} s)",
                            1.0 / from_hz
                        ),
                    ));
                }
                if self.harmonics().is_empty() {
                    return Err(FieldError::new(
                        "from_hz",
                        format!(
                            "from_hz = {from_hz}: no line on the grid of 1/{period_s} Hz in the band"
                        ),
                    ));
                }
                Ok(())
            }
            Excitation::SteppedSine {
                levels,
                periods,
                settle_periods,
                ..
            } => {
                count("levels", levels, 1)?;
                count("periods", periods, 1)?;
                count("settle_periods", settle_periods.max(1), 1)?;
                let Excitation::SteppedSine { settle_s, .. } = *self else {
                    return Ok(());
                };
                if !(settle_s.is_finite() && (0.0..1e5).contains(&settle_s)) {
                    return Err(FieldError::new(
                        "settle_s",
                        format!("settle_s = {settle_s}: must be 0 … 1e5 s"),
                    ));
                }
                Ok(())
            }
        }
    }

    /// The amplitude asked for (mm): the peak deviation from the centre.
    pub fn amplitude_mm(&self) -> f64 {
        match *self {
            Excitation::Chirp { amplitude_mm, .. }
            | Excitation::Multisine { amplitude_mm, .. }
            | Excitation::SteppedSine { amplitude_mm, .. } => amplitude_mm,
        }
    }
}

/// One frequency of a stepped sine, times from the start of the sweep (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Level {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Start of this level from the start of the sweep (s).
    pub start_s: f64,
    /// Settling time from the level's start, discarded by the estimate (s).
    pub settle_s: f64,
    /// Length of the level (s).
    pub end_s: f64,
}

/// `seconds` rounded to whole samples at `rate_hz` (at least one), unchanged if either is not a
/// positive number ([`Excitation::check`] refuses those).
fn whole_samples(seconds: f64, rate_hz: f64) -> f64 {
    let n = (seconds * rate_hz).round();
    if n.is_finite() && n >= 1.0 && rate_hz > 0.0 {
        n / rate_hz
    } else {
        seconds
    }
}

/// Phase of the logarithmic chirp at `tau` (rad): 2π f0 T/ln(f1/f0)·((f1/f0)^{τ/T} − 1), so
/// the instantaneous frequency rises from f0 to f1 exponentially; linear when f0 = f1.
fn chirp_phase(tau: f64, f0: f64, f1: f64, sweep_s: f64) -> f64 {
    let ratio = f1 / f0;
    if (ratio - 1.0).abs() < 1e-9 {
        return 2.0 * PI * f0 * tau;
    }
    2.0 * PI * f0 * sweep_s / ratio.ln() * (ratio.powf(tau / sweep_s) - 1.0)
}

/// Raised-cosine fade in over the first `fade_s` and out over the last `fade_s` of `sweep_s`.
fn fade(tau: f64, sweep_s: f64, fade_s: f64) -> f64 {
    if fade_s <= 0.0 {
        return 1.0;
    }
    let edge = tau.min(sweep_s - tau).max(0.0);
    if edge >= fade_s {
        return 1.0;
    }
    0.5 * (1.0 - (PI * edge / fade_s).cos())
}
