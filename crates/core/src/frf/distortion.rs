//! Non-linear distortion in a periodic sweep and the cavitation floor in its record
//! (docs/identification.md#non-linear-distortion).
//!
//! A periodic excitation that excites only some harmonics of its period (a multisine's lines)
//! leaves the others as detection lines: a linear loop's response has nothing there but noise,
//! while a non-linear one puts its harmonics and intermodulation products there too, periodic
//! like the excitation (Pintelon & Schoukens, *System Identification: A Frequency Domain
//! Approach*, 2nd ed., Wiley 2012, Ch. 4; Schoukens, Vaes & Pintelon, IEEE Control Syst. Mag.
//! 36(3), 2016, 38–69). Over M periods the mean X̄_k of a detection line carries the periodic
//! part, the period-to-period scatter s_k² = (Σ|X_m,k|² − M|X̄_k|²)/(M − 1) the noise alone:
//! without distortion E(M|X̄_k|²) = E(s_k²) = σ_k². The ratio R = Σ M|X̄_k|² / Σ s_k² over
//! the K detection lines is the distortion's level above the noise, 1 (0 dB) for a linear loop.
//! Without distortion R is F-distributed with 2K_e and 2K_e(M − 1) degrees of freedom, K_e =
//! (Σ s_k²)²/Σ s_k⁴ the lines' effective number where the noise level varies with frequency
//! (Satterthwaite), and ln R is near normal with variance 1/K_e + 1/(K_e(M − 1)); distortion is
//! detected where ln R exceeds its (1 − [`FALSE_ALARM`]) quantile.

use super::spectra::Spectra;
use crate::cavitation::{AT_FLOOR_BAR, VAPOUR_PRESSURE_BAR_GAUGE};
use crate::record::Record;
use serde::Serialize;

/// The probability that a linear loop's noise alone is reported as distortion.
pub const FALSE_ALARM: f64 = 1e-3;
/// Reference power (relative to its strongest bin) at or below which a harmonic is a detection
/// line: −80 dB, below any sweep's skirt and above the rounding of a record's reference.
pub const DETECTION_LINE: f64 = 1e-8;

/// The distortion found at a periodic sweep's detection lines.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Distortion {
    /// The mean power of the averaged response at the detection lines over the noise level of
    /// its period-to-period scatter there (dB): about 0 for a linear loop.
    pub non_excited_db_above_noise: f64,
    /// The mean power of the averaged response at the detection lines below its mean power at
    /// the excited lines (dB): how large the distortion is beside the response.
    pub non_excited_db_below_response: f64,
    /// The detection lines: the harmonics of the period up to twice the highest excited one
    /// that the sweep does not excite.
    pub lines: usize,
    /// The level a linear loop's noise exceeds with probability [`FALSE_ALARM`] (dB).
    pub threshold_db: f64,
    /// [`FALSE_ALARM`].
    pub false_alarm: f64,
    /// The level exceeds the threshold: the estimate warns.
    pub warned: bool,
}

impl Distortion {
    /// The warning, where distortion is detected.
    pub fn warning(&self) -> Option<String> {
        self.warned.then(|| {
            format!(
                "non-linear distortion: the response at the {} non-excited lines carries {:.1} dB \
                 above the noise of its period-to-period scatter (a linear loop exceeds {:.1} dB \
                 with probability {}), {:.1} dB below the response at the excited lines: the loop is not linear at this amplitude, and the band, \
                 which holds the noise only, understates the error at the excited lines (a dead \
                 band and friction weigh more at a smaller amplitude, cavitation and valves at a \
                 larger; docs/identification.md#non-linear-distortion)",
                self.lines,
                self.non_excited_db_above_noise,
                self.threshold_db,
                self.false_alarm,
                self.non_excited_db_below_response
            )
        })
    }
}

/// The distortion at the detection lines of the spectra `sx` of whole periods, `excited` the
/// excited harmonics; the scatter of each line at least `floor` (the position's quantization).
/// `None` with fewer than 2 periods or no detection line.
pub fn detect(sx: &Spectra, excited: &[usize], floor: f64) -> Option<Distortion> {
    let m = sx.segments as f64;
    let top = *excited.iter().max()?;
    let peak = sx.rr.iter().skip(1).cloned().fold(0.0, f64::max);
    let last = (2 * top).min(sx.segment_len.saturating_sub(1) / 2);
    let lines: Vec<usize> = (1..=last)
        .filter(|k| !excited.contains(k) && sx.rr[*k] <= DETECTION_LINE * peak)
        .collect();
    if sx.segments < 2 || lines.is_empty() || sx.y.len() < sx.rr.len() {
        return None;
    }
    let mean_sq = |k: usize| sx.y[k].norm_sqr() / m;
    let scatter = |k: usize| ((sx.yy[k] - mean_sq(k)) / (m - 1.0)).max(floor);
    let signal: f64 = lines.iter().map(|&k| mean_sq(k)).sum();
    let noise: f64 = lines.iter().map(|&k| scatter(k)).sum();
    let noise_sq: f64 = lines.iter().map(|&k| scatter(k).powi(2)).sum();
    let effective = noise * noise / noise_sq;
    let sd = (1.0 / effective + 1.0 / (effective * (m - 1.0))).sqrt();
    let z = crate::ident::normal_quantile(1.0 - FALSE_ALARM);
    let ratio = signal / noise;
    let response = excited.iter().map(|&k| mean_sq(k)).sum::<f64>() / excited.len() as f64;
    let below = 10.0 * (response * lines.len() as f64 / signal).log10();
    let threshold = z * sd;
    Some(Distortion {
        non_excited_db_above_noise: 10.0 * ratio.log10(),
        non_excited_db_below_response: below,
        lines: lines.len(),
        threshold_db: 10.0 * threshold / std::f64::consts::LN_10,
        false_alarm: FALSE_ALARM,
        warned: ratio.ln() > threshold,
    })
}

/// The scatter floor of one period's DFT at a bin (the unnormalised transform of `len`
/// samples): the quantization of positions at `resolution`, `len`·resolution²/12.
pub fn quantization_floor(len: usize, resolution: f64) -> f64 {
    len as f64 * resolution * resolution / 12.0
}

/// A warning when a chamber pressure of `rec` (its `p1_bar`, `p2_bar` columns, where present)
/// reaches the cavitation floor within samples `from .. to`: how many samples and from when.
pub fn floor_warning(rec: &Record, (from, to): (usize, usize)) -> Option<String> {
    let at_floor = |p: &[f64]| {
        let span = &p[from.min(p.len())..to.min(p.len())];
        let hits = span
            .iter()
            .filter(|&&v| v <= VAPOUR_PRESSURE_BAR_GAUGE + AT_FLOOR_BAR)
            .count();
        let first = span
            .iter()
            .position(|&v| v <= VAPOUR_PRESSURE_BAR_GAUGE + AT_FLOOR_BAR);
        first.map(|i| (hits, rec.time_s[from + i]))
    };
    let found: Vec<String> = [&rec.p1_bar, &rec.p2_bar]
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let (hits, at) = at_floor(p.as_deref()?)?;
            Some(format!(
                "chamber {} in {hits} samples from t = {at:.2} s",
                i + 1
            ))
        })
        .collect();
    if found.is_empty() {
        return None;
    }
    Some(format!(
        "the record's pressures reach the cavitation floor ({} bar gauge) within the analysed \
         samples ({}): the oil cavitates there, so the record is not what the linear model \
         describes and the estimate mixes the loop with the floor (a smaller amplitude; \
         docs/emulator.md#cavitation)",
        crate::units::readable(VAPOUR_PRESSURE_BAR_GAUGE),
        found.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::spectra;
    use std::f64::consts::PI;

    /// Standard normal deviates from a fixed-seed xorshift and Box–Muller.
    fn normals(seed: u64, n: usize) -> Vec<f64> {
        let mut s = seed.max(1);
        let mut uniform = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (a, b) = (uniform().max(1e-300), uniform());
                (-2.0 * a.ln()).sqrt() * (2.0 * PI * b).cos()
            })
            .collect()
    }

    /// 8 periods of 128 samples of a multisine on harmonics 3, 5, 7, 9 and the response
    /// `y(r)` with unit-variance noise scaled by `noise`; the distortion found.
    fn found(y: impl Fn(f64) -> f64, noise: f64, seed: u64) -> Distortion {
        let (len, m, lines) = (128, 8, [3usize, 5, 7, 9]);
        let r: Vec<f64> = (0..len * m)
            .map(|t| {
                (lines.iter())
                    .map(|&k| (2.0 * PI * (k * t) as f64 / len as f64 + k as f64).cos())
                    .sum()
            })
            .collect();
        let e = normals(seed, r.len());
        let x: Vec<f64> = r.iter().zip(&e).map(|(r, e)| y(*r) + noise * e).collect();
        let sx = spectra::periods(&r, &x, 0, len);
        detect(&sx, &lines, 0.0).unwrap()
    }

    #[test]
    fn a_linear_response_warns_at_about_the_false_alarm_rate() {
        // 2000 noise realisations of a linear response: the detection's false alarms number
        // about 2000 · 0.001 = 2 (at most 8 holds with probability 0.9997, Poisson; 0 measured:
        // the normal approximation of ln R is conservative at 14 lines and 8 periods)
        let alarms = (1..=2000)
            .filter(|&seed| found(|r| 0.5 * r, 0.1, seed).warned)
            .count();
        assert!(alarms <= 8, "{alarms} of 2000");
        let d = found(|r| 0.5 * r, 0.1, 7);
        // 2 · 9 = 18 harmonics, 4 excited, the even ones and 1 left: 14 detection lines
        assert_eq!(d.lines, 14);
    }

    #[test]
    fn a_squared_term_puts_its_products_on_the_detection_lines() {
        // r² puts its products on the even harmonics 2 … 18 (sums and differences of the odd
        // lines): at 0.02 r² a product of amplitude 0.02 gives a 128-sample period's DFT
        // |X|² = (64 · 0.02)² = 1.64 against the noise's 128 · 0.1² = 1.28, so M|X̄|²/s² ≈ 10 at
        // such a line over 8 periods: some 10 dB over the 14 lines, 13.5 measured
        let d = found(|r| 0.5 * r + 0.02 * r * r, 0.1, 3);
        assert!(
            d.warned && d.non_excited_db_above_noise > d.threshold_db + 6.0,
            "{d:?}"
        );
        // without it the same noise stays within the threshold
        let quiet = found(|r| 0.5 * r, 0.1, 3);
        assert!(!quiet.warned && quiet.non_excited_db_above_noise.abs() < quiet.threshold_db);
    }
}
