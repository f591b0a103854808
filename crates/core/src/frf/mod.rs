//! Frequency response from a sweep record (docs/identification.md#frequency-response-from-a-sweep).
//!
//! From a record's reference r = x_ref and position x this estimates the closed-loop response
//! T = x/x_ref with its coherence γ² and a 95 % band at each frequency, and, given the rig, the
//! plant's response P = x/ω_e from the position law's speed command ω_e = K_scale·Kp·e
//! (docs/model.md#the-dpm-control-law; drive 2 gets α times it). Where the law has no other
//! term (the sum-pressure loop open, or a one-motor circuit) ω_e is drive 1's whole command and
//! P = x/ω_ref1; with the sum-pressure loop closed P is the plant with that loop closed inside
//! it, L/(K_scale·Kp) with L the open loop x/e that `margins --sum-pressure-closed` analyses
//! (docs/identification.md#what-is-estimated). The command is not in a record: it is rebuilt
//! from the error e = x_ref − x, and P is read as the ratio of the two cross-spectra with the
//! reference, S_rx/S_ru (the indirect closed-loop method), which noise on x does not bias as it
//! would bias S_ux/S_uu, since u carries that noise back through the loop.
//!
//! - broadband records (a single chirp, or any sweep not described): Welch's averaged spectra,
//!   Hann window, half-overlapping segments, H1 = S_rx/S_rr, γ² = |S_rx|²/(S_rr S_xx);
//! - a periodic sweep (a multisine, a chirp played three times or more): its periods in
//!   periodic steady state as segments (the leading ones whose response still differs from the
//!   last period's by more than its noise left out, at least the first), no window, at its harmonics, the same H1 and γ²;
//! - a stepped sine: a least-squares sine fit of r and x over the whole periods after settling.
//!
//! The band is the random error of an H1 estimate (Bendat & Piersol, *Random Data*, 4th ed.,
//! Wiley 2010, §9.2.4, Table 9.6): ε = √(1 − γ²)/(|γ|·√(2 n_d)), n_d the independent averages;
//! |H| lies within ±1.96 ε (relative) and the phase within ±asin(1.96 ε) at 95 %.

pub mod design;
pub mod distortion;
pub mod excitation;
mod model;
pub mod spec;
pub mod spectra;

pub use design::{design, design_from_pilot, Design, DesignGoal, Pilot};
pub use distortion::Distortion;
pub use excitation::{Excitation, Level};
pub use model::{model_response, sampled_loop_response};
/// The complex numbers of the estimates (num-complex's).
pub use num_complex::Complex64;
pub use spec::{SweepKind, SweepSpec};

use crate::record::Record;
use crate::rig::Rig;
use serde::Serialize;
use spectra::Spectra;

/// The longest Welch segment or period (samples): 2¹⁸, 2621 s at 100 Hz, 262 s at 1 kHz.
pub const MAX_SEGMENT: usize = 1 << 18;
/// The most frequencies an estimate reports; denser bins are thinned log-uniformly.
pub const MAX_FREQUENCIES: usize = 400;
/// Welch segments a record is cut into when the lowest frequency allows it.
pub const SEGMENTS: usize = 8;
/// Periods of the lowest frequency a Welch segment must hold.
pub const PERIODS_PER_SEGMENT: f64 = 4.0;
/// The lowest Welch bin an estimate keeps: its segment holds 3 periods there. The Hann
/// window's main lobe spans ±2 bins, so a bin within two of zero shares it with the segment's
/// mean and drift: on a noise-free single chirp (0.05–3 Hz, 150 s) of the 80/45 mm rig the
/// phase at bin 2 is 2.9° off the model's, at bin 3 0.2°
/// (docs/identification.md#the-estimators).
pub const RESOLVED_BIN: usize = 3;
/// Coherence below which a frequency is never usable: the noise carries as much power as the
/// response (ε > 0.5/√n_d). With few averages the bar is higher: [`usable_coherence`].
pub const USABLE_COHERENCE: f64 = 0.5;
/// The normal quantile of the 95 % band.
pub const Z95: f64 = 1.959_963_984_540_054;
/// Reference power (relative to its peak bin) below which a bin is not excited: −40 dB.
pub const EXCITED: f64 = 1e-4;
/// Crossings of its mean below which a reference is not a sweep (a step crosses it once).
pub const MIN_CROSSINGS: usize = 8;
/// Sample spacing tolerance, relative to the mean step.
const UNIFORM: f64 = 1e-3;

/// Why a record gives no frequency response; each message is one line naming the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FrfError {
    /// The record cannot show the frequencies asked for.
    #[error("{file}: {message}")]
    TooShort {
        /// The record.
        file: String,
        /// What is missing.
        message: String,
    },
    /// The reference is not a sweep (or not the sweep described).
    #[error("{file}: {message}")]
    NotSweep {
        /// The record.
        file: String,
        /// What the reference is.
        message: String,
    },
    /// The samples are not uniformly spaced.
    #[error("{file}: {message}")]
    NotUniform {
        /// The record.
        file: String,
        /// Where.
        message: String,
    },
    /// No frequency has a usable coherence.
    #[error("{file}: {message}")]
    NoCoherence {
        /// The record.
        file: String,
        /// The best coherence found.
        message: String,
    },
    /// The sweep ends below the crossover of the rig's loop.
    #[error("{file}: {message}")]
    NoCrossover {
        /// The record.
        file: String,
        /// Where the sweep ends and the crossover lies.
        message: String,
    },
}

/// How the spectra were estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Welch, Hann window, half-overlapping segments.
    WelchHann,
    /// Whole periods of a periodic sweep, no window.
    Periods,
    /// Least-squares sine fit per stepped-sine level.
    SineFit,
}

/// The estimate at one frequency.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Point {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Real part of H.
    pub re: f64,
    /// Imaginary part of H.
    pub im: f64,
    /// |H| (dB).
    pub magnitude_db: f64,
    /// arg H (deg), unwrapped along the frequencies.
    pub phase_deg: f64,
    /// Coherence γ² (0 … 1).
    pub coherence: f64,
    /// Relative random error ε of |H| (one standard deviation; also the phase's in rad).
    pub relative_error: f64,
    /// Half-width of the 95 % band of |H| above it (dB): 20 log10(1 + 1.96 ε).
    pub band_db: f64,
    /// Half-width of the 95 % band of the phase (deg): asin(min(1.96 ε, 1)).
    pub band_deg: f64,
}

impl Point {
    fn new(freq_hz: f64, h: Complex64, coherence: f64, relative_error: f64) -> Point {
        let z = Z95 * relative_error;
        Point {
            freq_hz,
            re: h.re,
            im: h.im,
            magnitude_db: 20.0 * h.norm().log10(),
            phase_deg: h.arg().to_degrees(),
            coherence,
            relative_error,
            band_db: 20.0 * (1.0 + z).log10(),
            band_deg: z.min(1.0).asin().to_degrees(),
        }
    }

    /// H as a complex number.
    pub fn h(&self) -> Complex64 {
        Complex64::new(self.re, self.im)
    }
}

/// The coherence a frequency needs to be usable: [`USABLE_COHERENCE`], and above what
/// unrelated signals reach by chance at 95 % over `frequencies` frequencies when averaged
/// `averages` times. Uncorrelated signals give an estimated γ² above c with probability
/// (1 − c)^(n_d − 1) (Carter, Knapp & Nuttall, IEEE Trans. Audio Electroacoust. 21, 1973,
/// 388–389), so c = 1 − (0.05/m)^(1/(n_d − 1)) over m frequencies (Bonferroni).
pub fn usable_coherence(averages: f64, frequencies: usize) -> f64 {
    if averages <= 1.5 {
        return USABLE_COHERENCE;
    }
    let chance = 1.0 - (0.05 / frequencies.max(1) as f64).powf(1.0 / (averages - 1.0));
    chance.max(USABLE_COHERENCE)
}

/// [`usable_coherence`] of a periodic estimate whose noise variance pools `half` lines on each
/// side of each of `frequencies` lines (its `periodic_ratios`) over `periods` periods. With no
/// response, M|X̄|²/σ̂² is F-distributed with 2 and 2d degrees of freedom (d = (M − 1)·(2·half
/// \+ 1) complex ones in σ̂²), exceeding y with probability (1 + y/d)^(−d); at 95 % over m
/// lines (Bonferroni) y = d((m/0.05)^(1/d) − 1), and γ² = y/(M + y).
pub fn usable_pooled_coherence(periods: usize, half: usize, frequencies: usize) -> f64 {
    let m = periods.max(2) as f64;
    let d = (m - 1.0) * (2 * half + 1) as f64;
    let y = d * ((frequencies.max(1) as f64 / 0.05).powf(1.0 / d) - 1.0);
    (y / (m + y)).max(USABLE_COHERENCE)
}

/// One estimated frequency response.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Response {
    /// What it is, in symbols: `x/x_ref`, `x/w_ref1` (the position law is drive 1's whole
    /// command) or `x/w_e` (the position law's part of it, the sum-pressure loop closed).
    pub name: &'static str,
    /// Its unit: `mm/mm` or `mm/rpm`.
    pub unit: &'static str,
    /// The frequencies, increasing.
    pub points: Vec<Point>,
}

/// The estimate from one record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// The record.
    pub file: String,
    /// How the spectra were estimated.
    pub method: Method,
    /// The record's sample rate (Hz).
    pub rate_hz: f64,
    /// Samples per segment (per period, per level's fit for a stepped sine: its longest).
    pub segment_samples: usize,
    /// Segments (periods, levels) averaged.
    pub segments: usize,
    /// Leading periods of a periodic sweep left out as not yet in periodic steady state
    /// (docs/identification.md#frequency-response-from-a-sweep); 0 for the other methods.
    pub periods_discarded: usize,
    /// Neighbouring lines pooled on each side for each line's noise variance (a periodic
    /// sweep of few periods, [`pooled_lines`]); 0: each line's own scatter (the other methods).
    pub pooled_lines: usize,
    /// Independent averages n_d in the band's formula.
    pub averages: f64,
    /// The coherence a frequency needs to be usable ([`usable_coherence`]).
    pub usable_coherence: f64,
    /// The lowest frequency estimated (Hz).
    pub lowest_frequency_hz: f64,
    /// Why the estimate starts there: the sweep's own lowest frequency, or the lowest the
    /// record's Welch segments resolve where the sweep reaches below it.
    pub lowest_frequency_reason: String,
    /// The closed loop x/x_ref.
    pub closed_loop: Response,
    /// The plant x/ω_e (needs the rig's gains), where estimated.
    pub plant: Option<Response>,
    /// The non-linear distortion at a periodic sweep's non-excited harmonics
    /// ([`distortion::detect`]); `None` for the other methods or a sweep that leaves none.
    pub distortion: Option<Distortion>,
    /// What the reader should know: unusable frequencies, missing levels.
    pub warnings: Vec<String>,
}

/// What the estimate knows beyond the record.
#[derive(Debug, Clone, Copy, Default)]
pub struct Options<'a> {
    /// The sweep that made the record (checked against its reference), if known.
    pub excitation: Option<Excitation>,
    /// The rig: its loop's crossover is checked, its gains give the plant's response.
    pub rig: Option<&'a Rig>,
    /// Welch segment length (s) instead of the default.
    pub segment_s: Option<f64>,
}

/// Per-frequency ratios before they become points: frequency, T, γ², ε, and the plant's H.
struct Raw {
    freq_hz: f64,
    t: Complex64,
    coherence: f64,
    error: f64,
    plant: Option<Complex64>,
}

/// The frequency response of `rec` (see the module's description).
pub fn estimate(rec: &Record, opts: &Options) -> Result<Estimate, FrfError> {
    let rate_hz = uniform_rate(rec)?;
    check_sweep(rec)?;
    if let Some(e) = &opts.excitation {
        check_matches(rec, e)?;
    }
    let mut warnings = Vec::new();
    let command = opts.rig.map(|rig| speed_command(rec, rig));
    let (command, plant_name) = command.unzip();
    let (raw, mut est) = match opts.excitation {
        Some(e @ Excitation::SteppedSine { .. }) => {
            sine_fits(rec, &e, command.as_deref(), &mut warnings)?
        }
        Some(e) if e.period_s().is_some_and(|p| whole(p * rate_hz)) => {
            periodic(rec, &e, rate_hz, command.as_deref())?
        }
        None if opts.segment_s.is_none() => match find_period(rec) {
            Some((first, len)) => found_periodic(rec, (first, len), rate_hz, command.as_deref())?,
            None => welch_estimate(rec, opts, rate_hz, command.as_deref(), &mut warnings)?,
        },
        _ => welch_estimate(rec, opts, rate_hz, command.as_deref(), &mut warnings)?,
    };
    let raw = thin(raw);
    finish(&mut est, raw, plant_name, &mut warnings)?;
    if let Some(rig) = opts.rig {
        check_crossover(&est, rig)?;
    }
    if est.method != Method::Periods {
        warnings.extend(distortion::floor_warning(rec, (0, rec.len())));
    }
    // the periodic estimate's own (distortion, cavitation floor in its periods) first
    est.warnings.extend(warnings);
    Ok(est)
}

fn whole(v: f64) -> bool {
    v >= 2.0 && (v - v.round()).abs() < 1e-6 * v
}

/// The sample rate of a uniformly sampled record (Hz).
fn uniform_rate(rec: &Record) -> Result<f64, FrfError> {
    let n = rec.len();
    let err = |message: String| FrfError::NotUniform {
        file: rec.file.clone(),
        message,
    };
    if n < 4 {
        return Err(FrfError::TooShort {
            file: rec.file.clone(),
            message: format!("{n} samples: a frequency response needs a sweep of many periods"),
        });
    }
    let step = (rec.time_s[n - 1] - rec.time_s[0]) / (n - 1) as f64;
    if let Some(k) =
        (1..n).find(|&k| ((rec.time_s[k] - rec.time_s[k - 1]) - step).abs() > UNIFORM * step + 2e-6)
    {
        return Err(err(format!(
            "samples {} and {k} are {} s apart, the record's mean step is {step} s: the \
             frequency response needs uniform sampling (resample the record)",
            k - 1,
            rec.time_s[k] - rec.time_s[k - 1]
        )));
    }
    Ok(1.0 / step)
}

/// Refuse a reference that crosses its mean fewer than [`MIN_CROSSINGS`] times: a step or a
/// hold, not a sweep.
pub fn check_sweep(rec: &Record) -> Result<(), FrfError> {
    let mean = rec.x_ref_mm.iter().sum::<f64>() / rec.len() as f64;
    let mut last = 0.0;
    let mut crossings = 0;
    for &r in &rec.x_ref_mm {
        let s = (r - mean).signum() * f64::from(u8::from(r != mean));
        if s != 0.0 {
            crossings += usize::from(last != 0.0 && s != last);
            last = s;
        }
    }
    if crossings >= MIN_CROSSINGS {
        return Ok(());
    }
    Err(FrfError::NotSweep {
        file: rec.file.clone(),
        message: format!(
            "the reference x_ref_mm crosses its mean {crossings} times: it is not a sweep (a step \
             or a hold?); a frequency response needs a chirp, multisine or stepped sine \
             (pumpcyl emulate --experiment chirp)"
        ),
    })
}

/// Refuse a record whose reference is not the sweep `e` described.
pub fn check_matches(rec: &Record, e: &Excitation) -> Result<(), FrfError> {
    let tol = crate::record::POSITION_RESOLUTION_MM;
    let worst = rec
        .time_s
        .iter()
        .zip(&rec.x_ref_mm)
        .map(|(&t, &r)| (t, (r - e.reference_mm(t)).abs()))
        .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    if worst.1 <= tol {
        return Ok(());
    }
    Err(FrfError::NotSweep {
        file: rec.file.clone(),
        message: format!(
            "the reference x_ref_mm is not the {} described: it differs from it by {:.4} mm at \
             {} s (are the amplitude, band, counts and rig x0 those it was emulated with?)",
            e.name(),
            worst.1,
            worst.0
        ),
    })
}

/// The position law's speed command ω_e = K_scale·Kp·e of drive 1 (rpm) and the name of the
/// plant's response x/ω_e: `x/w_ref1` where the law has no other term, so that ω_e is the
/// whole command; `x/w_e` where the sum-pressure loop adds its pressure term (closed inside
/// the plant, docs/identification.md#what-is-estimated).
fn speed_command(rec: &Record, rig: &Rig) -> (Vec<f64>, &'static str) {
    let plant = crate::model::Plant::new(rig);
    let (kx, kr) = plant.controller(rig.sum_pressure);
    let x = plant.position();
    let whole = (0..kx.ncols()).all(|j| j == x || kx[(0, j)] == 0.0);
    let gain_rpm_per_mm = kr[(0, 0)] * 1e-3 / crate::units::RAD_S_PER_RPM;
    let command = rec
        .x_ref_mm
        .iter()
        .zip(&rec.x_mm)
        .map(|(r, x)| gain_rpm_per_mm * (r - x))
        .collect();
    (command, if whole { "x/w_ref1" } else { "x/w_e" })
}

/// ε of an H1 estimate from γ² and n_d averages (Bendat & Piersol 2010, Table 9.6).
pub fn h1_relative_error(coherence: f64, averages: f64) -> f64 {
    let g2 = coherence.clamp(0.0, 1.0);
    if g2 <= 0.0 {
        return f64::INFINITY;
    }
    (1.0 - g2).sqrt() / (g2.sqrt() * (2.0 * averages).sqrt())
}

/// The ratios at bin `k` of the spectra of (r, x) and, if given, (r, u).
fn ratio_at(freq_hz: f64, k: usize, sx: &Spectra, su: Option<&Spectra>) -> Raw {
    let t = sx.ry[k] / sx.rr[k];
    let coherence = (sx.ry[k].norm_sqr() / (sx.rr[k] * sx.yy[k])).clamp(0.0, 1.0);
    Raw {
        freq_hz,
        t,
        coherence,
        error: h1_relative_error(coherence, sx.averages),
        plant: su.map(|su| sx.ry[k] / su.ry[k]),
    }
}

/// Welch's estimate: the segment length from the band or the record, the excited bins.
fn welch_estimate(
    rec: &Record,
    opts: &Options,
    rate_hz: f64,
    command: Option<&[f64]>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Raw>, Estimate), FrfError> {
    let n = rec.len();
    let band = opts.excitation.map(|e| e.band_hz());
    if let Some(e @ Excitation::Chirp { .. }) = opts.excitation {
        warnings.push(format!(
            "a {} not periodic in the record (played fewer than 3 times, or its sweep not whole \
             samples): each frequency lies in one or two Welch segments, so the coherence and the \
             band say little and the window biases the estimate near lightly damped modes; play \
             it 3 times or more (--periods 3)",
            e.name()
        ));
    }
    let too_short = |message: String| FrfError::TooShort {
        file: rec.file.clone(),
        message,
    };
    let len = segment_len(opts, band, n, rate_hz);
    if len < 8 || len > n || len > MAX_SEGMENT {
        return Err(too_short(format!(
            "a Welch segment of {len} samples ({} s) does not fit: it needs 8 … {} samples, \
             the record holds {n}",
            len as f64 / rate_hz,
            MAX_SEGMENT.min(n),
        )));
    }
    let (r, x) = (&rec.x_ref_mm, &rec.x_mm);
    let sx = spectra::welch(r, x, len, len / 2);
    let su = command.map(|u| spectra::welch(r, u, len, len / 2));
    let df = rate_hz / len as f64;
    let peak = sx.rr.iter().skip(1).cloned().fold(0.0, f64::max);
    let lowest = 1 + usize::from(band.is_none());
    let excited: Vec<usize> = (lowest..sx.rr.len() - 1)
        .filter(|&k| {
            let f = k as f64 * df;
            match band {
                Some((lo, hi)) => f >= lo && f <= hi && sx.rr[k] > 0.0,
                None => sx.rr[k] >= EXCITED * peak && sx.rr[k] > 0.0,
            }
        })
        .collect();
    let (below, bins) = excited.split_at(excited.partition_point(|&k| k < RESOLVED_BIN));
    let segment_s = len as f64 / rate_hz;
    let resolved_hz = RESOLVED_BIN as f64 * df;
    if bins.is_empty() {
        return Err(too_short(match below.last() {
            Some(&k) => format!(
                "the sweep's frequencies end at {:.4} Hz, below the {resolved_hz:.4} Hz that \
                 {segment_s:.2} s Welch segments resolve ({RESOLVED_BIN} periods each): no band \
                 is left (a longer record, or the sweep repeated in whole periods, 3 or more)",
                k as f64 * df
            ),
            None => format!(
                "no frequency of the sweep lies on the {df:.4} Hz grid of {len}-sample segments"
            ),
        }));
    }
    let raw = bins
        .iter()
        .map(|&k| ratio_at(k as f64 * df, k, &sx, su.as_ref()))
        .collect();
    let mut est = shell(rec, Method::WelchHann, rate_hz, &sx);
    est.lowest_frequency_reason = match below.first() {
        Some(&k) => format!(
            "{} {:.4} Hz, but the record's {segment_s:.2} s Welch segments resolve only from \
             {resolved_hz:.4} Hz ({RESOLVED_BIN} periods each; below, the window biases the \
             estimate): a longer record, or the sweep repeated in whole periods, reaches lower",
            band.map_or("the reference has power down to", |_| {
                "the sweep described starts at"
            }),
            band.map_or(k as f64 * df, |b| b.0)
        ),
        None if band.is_some() => "the lowest frequency of the sweep described".into(),
        None => "the lowest frequency the reference excites (within 40 dB of its strongest)".into(),
    };
    Ok((raw, est))
}

/// Samples of a Welch segment: `segment_s` where given; else the record cut into
/// [`SEGMENTS`] half-overlapping ones, longer where a described band's lowest frequency needs
/// [`PERIODS_PER_SEGMENT`] periods and the record holds them (where it does not, the estimate
/// starts at the lowest frequency the shorter segments resolve).
fn segment_len(opts: &Options, band: Option<(f64, f64)>, n: usize, rate_hz: f64) -> usize {
    if let Some(s) = opts.segment_s {
        return (s * rate_hz).round().max(0.0) as usize;
    }
    let default = 2 * n / (SEGMENTS + 1);
    let need = band
        .map_or(0.0, |(lo, _)| PERIODS_PER_SEGMENT * rate_hz / lo)
        .ceil() as usize;
    if need <= n.min(MAX_SEGMENT) {
        default.max(need)
    } else {
        default
    }
}

/// An estimate's description before its points.
fn shell(rec: &Record, method: Method, rate_hz: f64, s: &Spectra) -> Estimate {
    Estimate {
        file: rec.file.clone(),
        method,
        rate_hz,
        segment_samples: s.segment_len,
        segments: s.segments,
        periods_discarded: 0,
        pooled_lines: 0,
        averages: s.averages,
        usable_coherence: USABLE_COHERENCE,
        lowest_frequency_hz: f64::NAN,
        lowest_frequency_reason: String::new(),
        closed_loop: Response {
            name: "x/x_ref",
            unit: "mm/mm",
            points: Vec::new(),
        },
        plant: None,
        distortion: None,
        warnings: Vec::new(),
    }
}

/// A periodic sweep: its periods in periodic steady state, at the harmonics it excites.
fn periodic(
    rec: &Record,
    e: &Excitation,
    rate_hz: f64,
    command: Option<&[f64]>,
) -> Result<(Vec<Raw>, Estimate), FrfError> {
    let period_s = e.period_s().unwrap_or(f64::NAN);
    let len = (period_s * rate_hz).round() as usize;
    let start = ((e.start_s() - rec.time_s[0]) * rate_hz).round().max(0.0) as usize;
    let (sx, su, mut est) = settled_spectra(rec, (start, len), rate_hz, command)?;
    est.lowest_frequency_reason = "the lowest frequency of the sweep described".into();
    let bins: Vec<usize> = (e.excited_harmonics().iter())
        .map(|&k| k as usize)
        .filter(|&k| k < len / 2)
        .collect();
    detect_distortion(&mut est, &sx, &bins);
    Ok((periodic_ratios(&bins, period_s, &sx, su.as_ref()), est))
}

/// The residual degrees of freedom (complex) a periodic estimate's noise variance is read from
/// at each frequency: the period-to-period scatter of M periods gives M − 1 at its own line,
/// too few for a weight when M is small (with M = 2, 1/σ̂² has no finite mean and a fit weighted
/// by it is overconfident), so neighbouring lines are pooled until they reach this
/// (docs/identification.md#coherence-and-the-band).
pub const NOISE_DOF: usize = 16;

/// Neighbouring lines pooled on each side for a periodic estimate of `periods` periods
/// ([`NOISE_DOF`]): 0 from 17 periods on.
pub fn pooled_lines(periods: usize) -> usize {
    let own = periods.saturating_sub(1).max(1);
    NOISE_DOF.div_ceil(own).saturating_sub(1).div_ceil(2)
}

/// The ratios of a periodic estimate at its excited `bins`: H₁ as [`ratio_at`]; with few
/// periods ([`pooled_lines`] > 0) the noise variance of x at each line is the mean of the
/// period-to-period scatter of its neighbours' (the noise spectrum is smooth; Pintelon &
/// Schoukens 2012, §2.6), and γ², ε follow from it: γ² = |X̄|²/(|X̄|² + σ̂²),
/// ε = h1_relative_error(γ², M) = σ̂/(|X̄|√(2M)).
fn periodic_ratios(bins: &[usize], period_s: f64, sx: &Spectra, su: Option<&Spectra>) -> Vec<Raw> {
    let mut raw: Vec<Raw> = (bins.iter())
        .map(|&k| ratio_at(k as f64 / period_s, k, sx, su))
        .collect();
    let half = pooled_lines(sx.segments);
    if half == 0 || raw.is_empty() {
        return raw;
    }
    let m = sx.segments as f64;
    // per line: |X̄|² and the scatter Σ|X_m − X̄|²/(M − 1) (R the same in every period)
    let mean_sq = |k: usize| sx.ry[k].norm_sqr() / (sx.rr[k] * m);
    let scatter = |k: usize| (sx.yy[k] - sx.ry[k].norm_sqr() / sx.rr[k]).max(0.0) / (m - 1.0);
    let scatters: Vec<f64> = bins.iter().map(|&k| scatter(k)).collect();
    let width = (2 * half + 1).min(bins.len());
    for (i, r) in raw.iter_mut().enumerate() {
        let from = i.saturating_sub(half).min(bins.len() - width);
        let noise = scatters[from..from + width].iter().sum::<f64>() / width as f64;
        let signal = mean_sq(bins[i]);
        r.coherence = if signal + noise > 0.0 {
            signal / (signal + noise)
        } else {
            0.0
        };
        r.error = h1_relative_error(r.coherence, m);
    }
    raw
}

/// The spectra of the whole periods of `len` samples from `start` on that are in periodic
/// steady state ([`spectra::transient_periods`]: at least 2 remain), and the estimate's
/// shell; refused when the record has fewer than 3 periods or none shown settled.
fn settled_spectra(
    rec: &Record,
    (start, len): (usize, usize),
    rate_hz: f64,
    command: Option<&[f64]>,
) -> Result<(Spectra, Option<Spectra>, Estimate), FrfError> {
    let (r, x) = (&rec.x_ref_mm, &rec.x_mm);
    let whole = rec.len().saturating_sub(start) / len.max(1);
    let resolution = crate::record::POSITION_RESOLUTION_MM;
    let refuse = |message: String| FrfError::TooShort {
        file: rec.file.clone(),
        message,
    };
    let period_s = len as f64 / rate_hz;
    if whole < 3 || len > MAX_SEGMENT {
        return Err(refuse(format!(
            "{whole} whole periods of {period_s} s: the estimate needs at least 3 (the first \
             to settle) and periods up to {MAX_SEGMENT} samples"
        )));
    }
    let discarded = spectra::transient_periods(x, start, len, resolution).map_err(|needed| {
        refuse(format!(
            "{whole} whole periods of {period_s} s, none shown in periodic steady state (each \
             differs from the last by more than the last two differ): the record needs about \
             {needed} periods"
        ))
    })?;
    let first = start + discarded * len;
    let sx = spectra::periods(r, x, first, len);
    let su = command.map(|u| spectra::periods(r, u, first, len));
    let mut est = shell(rec, Method::Periods, rate_hz, &sx);
    est.periods_discarded = discarded;
    est.pooled_lines = pooled_lines(sx.segments);
    let analysed = (first, first + sx.segments * len);
    est.warnings
        .extend(distortion::floor_warning(rec, analysed));
    Ok((sx, su, est))
}

/// The distortion at the non-excited harmonics of a periodic estimate's spectra `sx`, its
/// lines `bins` excited, into `est` with its warning.
fn detect_distortion(est: &mut Estimate, sx: &Spectra, bins: &[usize]) {
    let floor =
        distortion::quantization_floor(sx.segment_len, crate::record::POSITION_RESOLUTION_MM);
    est.distortion = distortion::detect(sx, bins, floor);
    est.warnings
        .extend(est.distortion.and_then(|d| d.warning()));
}

/// Samples compared before a lag is checked over the whole record.
const PROBE: usize = 64;

/// A reference that repeats, found without its description: (the first sample of its second
/// period, the period in samples) when, from where it first leaves its initial value, it
/// repeats within [`crate::record::POSITION_RESOLUTION_MM`] for at least three whole periods
/// (a multisine, a chirp played three times or more).
pub fn find_period(rec: &Record) -> Option<(usize, usize)> {
    let r = &rec.x_ref_mm;
    let n = r.len();
    let tol = crate::record::POSITION_RESOLUTION_MM;
    let s = r.iter().position(|&v| (v - r[0]).abs() > tol)?;
    let same = |l: usize, m: usize| (s..s + m).all(|k| (r[k + l] - r[k]).abs() <= tol);
    let len = (PROBE..=(n - s) / 3)
        .filter(|&l| l <= MAX_SEGMENT)
        .find(|&l| same(l, PROBE) && same(l, ((n - s) / l - 1) * l))?;
    Some((s + len, len))
}

/// A periodic sweep found by [`find_period`]: its periods in periodic steady state, at the
/// harmonics its reference excites (power above [`EXCITED`] of the strongest).
fn found_periodic(
    rec: &Record,
    (first, len): (usize, usize),
    rate_hz: f64,
    command: Option<&[f64]>,
) -> Result<(Vec<Raw>, Estimate), FrfError> {
    let (sx, su, mut est) = settled_spectra(rec, (first - len, len), rate_hz, command)?;
    est.lowest_frequency_reason =
        "the lowest frequency the periodic reference excites (within 40 dB of its strongest)"
            .into();
    let peak = sx.rr.iter().skip(1).cloned().fold(0.0, f64::max);
    let period_s = len as f64 / rate_hz;
    let bins: Vec<usize> = (1..len.div_ceil(2))
        .filter(|&k| sx.rr[k] > 0.0 && sx.rr[k] >= EXCITED * peak)
        .collect();
    detect_distortion(&mut est, &sx, &bins);
    Ok((periodic_ratios(&bins, period_s, &sx, su.as_ref()), est))
}

/// A stepped sine: the sine fit of r, x (and u) over each level's whole periods after settling.
fn sine_fits(
    rec: &Record,
    e: &Excitation,
    command: Option<&[f64]>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Raw>, Estimate), FrfError> {
    let t = &rec.time_s;
    let step = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    let mut raw = Vec::new();
    let mut longest = 0;
    let levels = e.levels();
    for l in &levels {
        let from = e.start_s() + l.start_s + l.settle_s;
        let to = e.start_s() + l.start_s + l.end_s;
        let (i0, i1) = (
            t.partition_point(|&v| v < from - 1e-9),
            t.partition_point(|&v| v < to - 1e-9),
        );
        if to > t[t.len() - 1] + step || i1 < i0 + 8 {
            continue;
        }
        let span = &t[i0..i1];
        let fit = |y: &[f64]| spectra::sine_fit(span, &y[i0..i1], l.freq_hz);
        let (Some((ar, _)), Some((ax, var))) = (fit(&rec.x_ref_mm), fit(&rec.x_mm)) else {
            continue;
        };
        let m = (i1 - i0) as f64;
        let power = 0.5 * ax.norm_sqr();
        let coherence = if power + var > 0.0 {
            power / (power + var)
        } else {
            0.0
        };
        let error = if ax.norm() > 0.0 {
            (2.0 * var / m).sqrt() / ax.norm()
        } else {
            f64::INFINITY
        };
        let plant = command.and_then(fit).map(|(au, _)| ax / au);
        raw.push(Raw {
            freq_hz: l.freq_hz,
            t: ax / ar,
            coherence,
            error,
            plant,
        });
        longest = longest.max(i1 - i0);
    }
    let missing = levels.len() - raw.len();
    if raw.is_empty() {
        return Err(FrfError::TooShort {
            file: rec.file.clone(),
            message: format!(
                "the record ends at {} s, before the first level's settled periods end (the \
                 sweep needs {} s)",
                t[t.len() - 1],
                e.duration_s()
            ),
        });
    }
    if missing > 0 {
        warnings.push(format!(
            "{missing} of {} levels are missing: the record ends at {} s, the sweep at {} s",
            levels.len(),
            t[t.len() - 1],
            e.duration_s()
        ));
    }
    let mut est = shell(
        rec,
        Method::SineFit,
        1.0 / (t[1] - t[0]),
        &Spectra {
            rr: Vec::new(),
            ry: Vec::new(),
            yy: Vec::new(),
            y: Vec::new(),
            segments: raw.len(),
            segment_len: longest,
            averages: 1.0,
        },
    );
    est.rate_hz = (t.len() - 1) as f64 / (t[t.len() - 1] - t[0]);
    est.lowest_frequency_reason = "the lowest level of the sweep described".into();
    Ok((raw, est))
}

/// At most [`MAX_FREQUENCIES`] of `raw`, the nearest to log-uniform targets.
fn thin(raw: Vec<Raw>) -> Vec<Raw> {
    if raw.len() <= MAX_FREQUENCIES {
        return raw;
    }
    let (lo, hi) = (raw[0].freq_hz, raw[raw.len() - 1].freq_hz);
    let mut keep = vec![false; raw.len()];
    for f in crate::lti::log_grid(lo, hi, MAX_FREQUENCIES) {
        let k = raw.partition_point(|r| r.freq_hz < f).min(raw.len() - 1);
        let k = if k > 0 && (raw[k - 1].freq_hz - f).abs() < (raw[k].freq_hz - f).abs() {
            k - 1
        } else {
            k
        };
        keep[k] = true;
    }
    raw.into_iter()
        .zip(keep)
        .filter_map(|(r, k)| k.then_some(r))
        .collect()
}

/// The points of both responses, phases unwrapped; refused if no frequency is usable.
fn finish(
    est: &mut Estimate,
    raw: Vec<Raw>,
    plant_name: Option<&'static str>,
    warnings: &mut Vec<String>,
) -> Result<(), FrfError> {
    let bar = match est.pooled_lines {
        0 => usable_coherence(est.averages, raw.len()),
        half => usable_pooled_coherence(est.segments, half, raw.len()),
    };
    est.usable_coherence = bar;
    let best = raw.iter().map(|r| r.coherence).fold(0.0, f64::max);
    if best < bar {
        return Err(FrfError::NoCoherence {
            file: est.file.clone(),
            message: format!(
                "the coherence is below the usable {bar:.3} at every frequency (at most \
                 {best:.3}, with {:.1} averages): the noise outweighs the response to the sweep; \
                 a larger amplitude or a longer record is needed",
                est.averages
            ),
        });
    }
    let unusable = raw.iter().filter(|r| r.coherence < bar).count();
    if unusable > 0 {
        warnings.push(format!(
            "{unusable} of {} frequencies have a coherence below the usable {bar:.3}: their \
             estimate is unreliable, read them with care",
            raw.len()
        ));
    }
    est.lowest_frequency_hz = raw.iter().map(|r| r.freq_hz).fold(f64::INFINITY, f64::min);
    est.closed_loop.points = unwrap(
        raw.iter()
            .map(|r| Point::new(r.freq_hz, r.t, r.coherence, r.error))
            .collect(),
    );
    if let Some(name) = plant_name.filter(|_| raw.iter().all(|r| r.plant.is_some())) {
        let points = raw
            .iter()
            .map(|r| {
                // P = T/(K(1 − T)) to first order: δP/P = δT/(T(1 − T)), so ε_P = ε_T/|1 − T|
                let error = r.error / (Complex64::new(1.0, 0.0) - r.t).norm();
                Point::new(r.freq_hz, r.plant.unwrap_or_default(), r.coherence, error)
            })
            .collect();
        est.plant = Some(Response {
            name,
            unit: "mm/rpm",
            points: unwrap(points),
        });
    }
    Ok(())
}

/// Unwrap the phases along the frequencies, the first one in (−180, 180].
fn unwrap(mut points: Vec<Point>) -> Vec<Point> {
    for k in 1..points.len() {
        let prev = points[k - 1].phase_deg;
        let jump = ((points[k].phase_deg - prev) / 360.0).round() * 360.0;
        points[k].phase_deg -= jump;
    }
    points
}

/// Refuse an estimate whose usable frequencies end below the gain crossover of the rig's
/// position loop (docs/analysis.md#margins): it says nothing about the margins.
fn check_crossover(est: &Estimate, rig: &Rig) -> Result<(), FrfError> {
    let plant = crate::model::Plant::new(rig);
    let Ok(m) = crate::lti::margins(&plant.open_loop(false)) else {
        return Ok(());
    };
    let Some(fc) = m.gain_crossover_hz else {
        return Ok(());
    };
    let top = est
        .closed_loop
        .points
        .iter()
        .filter(|p| p.coherence >= est.usable_coherence)
        .map(|p| p.freq_hz)
        .fold(0.0, f64::max);
    if top >= fc {
        return Ok(());
    }
    Err(FrfError::NoCrossover {
        file: est.file.clone(),
        message: format!(
            "the sweep's usable frequencies end at {top:.3} Hz, below the {fc:.3} Hz gain \
             crossover of the rig's position loop: it cannot show the loop's margins (sweep to \
             at least {:.3} Hz)",
            2.0 * fc
        ),
    })
}
