//! Averaged auto- and cross-spectra of the reference r and a response y: Welch's method with a
//! Hann window (broadband records), whole periods without a window (a periodic multisine), and
//! the least-squares sine fit of one frequency (a stepped sine's level).

use num_complex::Complex64;
use realfft::RealFftPlanner;
use std::f64::consts::PI;

/// Summed spectra at each bin (one-sided, unscaled: only their ratios are used).
#[derive(Debug, Clone, PartialEq)]
pub struct Spectra {
    /// Σ|R|² per bin.
    pub rr: Vec<f64>,
    /// Σ conj(R)·Y per bin.
    pub ry: Vec<Complex64>,
    /// Σ|Y|² per bin.
    pub yy: Vec<f64>,
    /// Σ Y per bin (the mean response of a periodic sweep at every bin, excited or not).
    pub y: Vec<Complex64>,
    /// Segments averaged.
    pub segments: usize,
    /// Samples per segment.
    pub segment_len: usize,
    /// Independent averages the segments are worth (Welch 1967): n/(1 + 2ρ²) for overlapping
    /// windowed segments, ρ the correlation of two windows at their overlap; n without overlap.
    pub averages: f64,
}

/// The periodic Hann window of `n` samples, the one `scipy.signal.csd` and `welch` use
/// (`get_window('hann', n)`).
pub fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 0.5 - 0.5 * (2.0 * PI * k as f64 / n as f64).cos())
        .collect()
}

/// The segment starts of `len`-sample segments stepping by `step` through `n` samples.
fn starts(n: usize, len: usize, step: usize) -> impl Iterator<Item = usize> {
    (0..)
        .map(move |j| j * step)
        .take_while(move |s| s + len <= n)
}

/// Welch's averaged spectra of `r` and `y` (`len` samples per segment, Hann window, `overlap`
/// samples shared by neighbours, each segment's mean removed), as `scipy.signal.csd` with
/// `window='hann', detrend='constant'` computes them up to a common scale.
pub fn welch(r: &[f64], y: &[f64], len: usize, overlap: usize) -> Spectra {
    let window = hann(len);
    let step = len - overlap;
    let mut sum = Accumulator::new(len);
    for s in starts(r.len().min(y.len()), len, step) {
        sum.add(&r[s..s + len], &y[s..s + len], Some(&window));
    }
    let segments = sum.segments;
    let rho = overlap_correlation(&window, step);
    let averages = if segments > 1 {
        segments as f64 / (1.0 + 2.0 * rho * rho)
    } else {
        1.0
    };
    sum.finish(averages)
}

/// Spectra of whole periods of `len` samples from `first` on, no window (each period of a
/// periodic excitation in steady state holds whole periods of every line: no leakage).
pub fn periods(r: &[f64], y: &[f64], first: usize, len: usize) -> Spectra {
    let mut sum = Accumulator::new(len);
    for s in starts(r.len().min(y.len()).saturating_sub(first), len, len) {
        let s = first + s;
        sum.add(&r[s..s + len], &y[s..s + len], None);
    }
    let n = sum.segments as f64;
    sum.finish(n)
}

/// The ratio of a period's mean-square difference from the last period to the last two
/// periods' own one above which the period is not yet in periodic steady state.
pub const TRANSIENT_RATIO: f64 = 2.0;

/// The leading periods of `y` (whole periods of `len` samples from `start`) not yet in
/// periodic steady state, at least 1 (Pintelon & Schoukens, *System Identification: A
/// Frequency Domain Approach*, 2nd ed., Wiley 2012, §2.6): the noise is the mean-square
/// difference of the last two periods (2σ², at least that of a `resolution` quantization,
/// 2·resolution²/12), and a period whose mean-square difference from the last one exceeds
/// [`TRANSIENT_RATIO`] times it is transient: the leading periods up to the first that is not
/// are left out (the first always). With 3 periods
/// only the first is left out (none can be checked). `Err` holds the periods a record needs
/// when every period checked is transient (the last two may then be too): the periods the
/// last difference takes to decay to the noise floor at the rate of the last two, plus 3.
pub fn transient_periods(
    y: &[f64],
    start: usize,
    len: usize,
    resolution: f64,
) -> Result<usize, usize> {
    let whole = y.len().saturating_sub(start) / len.max(1);
    if whole < 4 {
        return Ok(1);
    }
    let period = |j: usize| &y[start + j * len..start + (j + 1) * len];
    let msd = |j: usize, k: usize| {
        let (a, b) = (period(j), period(k));
        a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>() / len as f64
    };
    let floor = resolution * resolution / 6.0;
    let noise = msd(whole - 1, whole - 2).max(floor);
    // a decaying transient's difference from the last period shrinks period by period: the
    // first period within the noise ends it (a later outlier of a noisy record does not count)
    if let Some(settled) = (1..whole - 2).find(|&j| msd(j, whole - 1) <= TRANSIENT_RATIO * noise) {
        return Ok(settled);
    }
    // the decay per period of the mean-square difference, from the last three periods
    let decay = noise / msd(whole - 2, whole - 3).max(floor);
    let more = (noise / floor).ln() / (1.0 / decay).ln();
    let more = if more.is_finite() && more > 0.0 {
        more.ceil()
    } else {
        whole as f64
    };
    Err(whole + (more as usize).min(MAX_MORE_PERIODS) + 1)
}

/// The most periods [`transient_periods`] asks a record to add.
const MAX_MORE_PERIODS: usize = 1000;

/// The correlation of two windows `step` samples apart: Σ w[k] w[k+step] / Σ w².
fn overlap_correlation(window: &[f64], step: usize) -> f64 {
    let energy: f64 = window.iter().map(|w| w * w).sum();
    let shared: f64 = window
        .iter()
        .zip(window.iter().skip(step))
        .map(|(a, b)| a * b)
        .sum();
    if energy > 0.0 {
        shared / energy
    } else {
        0.0
    }
}

/// Running sums of the segment spectra.
struct Accumulator {
    fft: std::sync::Arc<dyn realfft::RealToComplex<f64>>,
    input: Vec<f64>,
    scratch: Vec<Complex64>,
    fr: Vec<Complex64>,
    fy: Vec<Complex64>,
    rr: Vec<f64>,
    ry: Vec<Complex64>,
    yy: Vec<f64>,
    y: Vec<Complex64>,
    segments: usize,
    len: usize,
}

impl Accumulator {
    fn new(len: usize) -> Self {
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(len);
        let bins = len / 2 + 1;
        Accumulator {
            input: fft.make_input_vec(),
            scratch: fft.make_scratch_vec(),
            fr: fft.make_output_vec(),
            fy: fft.make_output_vec(),
            fft,
            rr: vec![0.0; bins],
            ry: vec![Complex64::new(0.0, 0.0); bins],
            yy: vec![0.0; bins],
            y: vec![Complex64::new(0.0, 0.0); bins],
            segments: 0,
            len,
        }
    }

    /// Add one segment: mean removed, windowed if a window is given.
    fn add(&mut self, r: &[f64], y: &[f64], window: Option<&[f64]>) {
        transform(self, r, window, true);
        transform(self, y, window, false);
        for k in 0..self.rr.len() {
            let (a, b) = (self.fr[k], self.fy[k]);
            self.rr[k] += a.norm_sqr();
            self.yy[k] += b.norm_sqr();
            self.ry[k] += a.conj() * b;
            self.y[k] += b;
        }
        self.segments += 1;
    }

    fn finish(self, averages: f64) -> Spectra {
        Spectra {
            rr: self.rr,
            ry: self.ry,
            yy: self.yy,
            y: self.y,
            segments: self.segments,
            segment_len: self.len,
            averages,
        }
    }
}

/// The FFT of one segment into the accumulator's `fr` (reference) or `fy` (response).
fn transform(acc: &mut Accumulator, x: &[f64], window: Option<&[f64]>, reference: bool) {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    for (k, v) in acc.input.iter_mut().enumerate() {
        *v = (x[k] - mean) * window.map_or(1.0, |w| w[k]);
    }
    let out = if reference { &mut acc.fr } else { &mut acc.fy };
    // the lengths come from the plan itself, so the transform cannot fail
    let _ = acc
        .fft
        .process_with_scratch(&mut acc.input, out, &mut acc.scratch);
}

/// The least-squares fit of c + a cos(ωt) + b sin(ωt) to `y` at times `t`: the complex
/// amplitude a − i b (so y ≈ c + Re((a − i b) e^{iωt})) and the residual variance.
pub fn sine_fit(t: &[f64], y: &[f64], freq_hz: f64) -> Option<(Complex64, f64)> {
    let w = 2.0 * PI * freq_hz;
    let t0 = *t.first()?;
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    let mut v = nalgebra::Vector3::<f64>::zeros();
    for (&tk, &yk) in t.iter().zip(y) {
        let phase = w * (tk - t0);
        let basis = nalgebra::Vector3::new(1.0, phase.cos(), phase.sin());
        m += basis * basis.transpose();
        v += basis * yk;
    }
    let p = m.lu().solve(&v)?;
    let ss: f64 = t
        .iter()
        .zip(y)
        .map(|(&tk, &yk)| {
            let phase = w * (tk - t0);
            let e = yk - p[0] - p[1] * phase.cos() - p[2] * phase.sin();
            e * e
        })
        .sum();
    let dof = t.len().saturating_sub(3).max(1) as f64;
    // the amplitude refers to the phase at t0: shift it to t = 0 for a common time origin
    let amplitude = Complex64::new(p[1], -p[2]) * Complex64::from_polar(1.0, -w * t0);
    Some((amplitude, ss / dof))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hann_windows_half_apart_correlate_by_one_sixth() {
        // Σ sin²(πk/N) cos²(πk/N) over the overlap (N/16) over Σ sin⁴(πk/N) (3N/8)
        assert!((overlap_correlation(&hann(1024), 512) - 1.0 / 6.0).abs() < 1e-12);
    }

    /// A sine of 50-sample periods plus a transient 10^(-t/period) of amplitude 1, sampled
    /// at `periods` periods.
    fn decaying(periods: usize) -> Vec<f64> {
        (0..periods * 50)
            .map(|k| (2.0 * PI * k as f64 / 50.0).sin() + 10f64.powf(-(k as f64) / 50.0))
            .collect()
    }

    #[test]
    fn periods_whose_transient_exceeds_the_resolution_are_left_out() {
        // the transient's mean square over period j: 10^(-2j) Σ 10^(-i/25)/50 = 0.227·10^(-2j),
        // against twice the floor 2·(1e-3)²/6 = 3.3e-7: above at j = 2, below at j = 3
        assert_eq!(transient_periods(&decaying(20), 0, 50, 1e-3), Ok(3));
        // a resolution 10 times coarser: 3.3e-5, above at j = 1, below at j = 2
        assert_eq!(transient_periods(&decaying(20), 0, 50, 1e-2), Ok(2));
        // no transient: only the first period goes; with 3 periods none can be checked
        let steady: Vec<f64> = (0..1000).map(|k| (k as f64 * 0.3).sin()).collect();
        assert_eq!(transient_periods(&steady[..500], 0, 50, 1e-3), Ok(1));
        assert_eq!(transient_periods(&decaying(3), 0, 50, 1e-3), Ok(1));
        // 4 periods still decaying: refused, with more periods asked for
        assert!(transient_periods(&decaying(4), 0, 50, 1e-3).is_err_and(|n| n > 4));
    }

    #[test]
    fn the_sine_fit_recovers_amplitude_phase_and_offset() {
        let t: Vec<f64> = (0..400).map(|k| 3.0 + k as f64 * 0.01).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|t| 2.0 + 1.5 * (2.0 * PI * 0.5 * t + 0.3).cos())
            .collect();
        let (a, var) = sine_fit(&t, &y, 0.5).unwrap();
        // y = Re(1.5 e^{i 0.3} e^{iωt}): the amplitude referred to t = 0
        assert!((a - Complex64::from_polar(1.5, 0.3)).norm() < 1e-10, "{a}");
        assert!(var < 1e-20);
    }
}
