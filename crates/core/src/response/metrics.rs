//! Step and tracking metrics (docs/simulation.md#step-metrics, #tracking-metrics) of sampled responses; times between samples are found by
//! linear interpolation.

use serde::Serialize;

/// Step-response metrics, for a step of size r from a steady state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StepMetrics {
    /// Step size (mm).
    pub step_mm: f64,
    /// 10–90 % rise time (s); `None` if the response never reaches 90 %.
    pub rise_time_s: Option<f64>,
    /// Overshoot beyond the step (mm, ≥ 0).
    pub overshoot_mm: f64,
    /// Overshoot (% of the step).
    pub overshoot_pct: f64,
    /// Time of the largest excursion in the step direction (s).
    pub peak_time_s: f64,
    /// 2 % settling time (s); `None` if still outside the band at the end.
    pub settling_time_s: Option<f64>,
    /// Steady-state error x_ref − x from the DC solution of the model (mm), the rest offset
    /// included.
    pub steady_state_error_mm: f64,
    /// Error x_ref − x at the end of the simulated record (mm), the rest offset included.
    pub final_error_mm: f64,
    /// The standing error of the loop at rest (mm; docs/simulation.md#the-rest-under-load):
    /// the part of the errors above that the P law needs to hold the load and feed the
    /// leakage. Absent from JSON for metrics of sampled data alone ([`step_metrics`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rest_offset_mm: Option<f64>,
    /// The damping warning when the loop's gain margin is under
    /// [`RINGING_GM_DB`](super::RINGING_GM_DB) ([`ringing`](super::ringing)); absent from
    /// JSON otherwise. The metrics of sampled data alone ([`step_metrics`]) leave it `None`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ringing: Option<super::Ringing>,
}

/// Metrics of the deviation response `y` (mm, starting at 0) to a step `r` (mm) at `t[0]`;
/// `dc_mm` is the model's steady-state deviation.
pub fn step_metrics(t: &[f64], y: &[f64], r: f64, dc_mm: f64) -> StepMetrics {
    let n = y.len();
    let norm: Vec<f64> = y.iter().map(|v| v / r).collect();
    let cross = |level: f64| {
        (1..n)
            .find(|&k| norm[k] >= level)
            .map(|k| interpolate_time(t, &norm, k, level))
    };
    let rise = cross(0.1).zip(cross(0.9)).map(|(a, b)| b - a);
    let (peak_k, peak) = norm
        .iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |best, (k, &v)| {
            if v > best.1 {
                (k, v)
            } else {
                best
            }
        });
    let overshoot = (peak - 1.0).max(0.0);
    StepMetrics {
        step_mm: r,
        rise_time_s: rise,
        overshoot_mm: overshoot * r.abs(),
        overshoot_pct: 100.0 * overshoot,
        peak_time_s: t[peak_k] - t[0],
        settling_time_s: settling_time(t, &norm, 0.02),
        steady_state_error_mm: r - dc_mm,
        final_error_mm: r - y[n - 1],
        rest_offset_mm: None,
        ringing: None,
    }
}

/// Time at which `v` crosses `level` between samples k−1 and k.
fn interpolate_time(t: &[f64], v: &[f64], k: usize, level: f64) -> f64 {
    if k == 0 || v[k] == v[k - 1] {
        return t[k] - t[0];
    }
    let f = (level - v[k - 1]) / (v[k] - v[k - 1]);
    t[k - 1] + f * (t[k] - t[k - 1]) - t[0]
}

/// Last time the normalised response `v` is outside 1 ± band, interpolated to the band edge;
/// `None` if it is outside at the end.
fn settling_time(t: &[f64], v: &[f64], band: f64) -> Option<f64> {
    let outside = |x: f64| (x - 1.0).abs() > band;
    if outside(*v.last()?) {
        return None;
    }
    match (0..v.len()).rev().find(|&k| outside(v[k])) {
        None => Some(0.0),
        Some(k) => {
            let edge = if v[k] > 1.0 { 1.0 + band } else { 1.0 - band };
            Some(interpolate_time(t, v, k + 1, edge))
        }
    }
}

/// Sinusoidal tracking metrics (docs/simulation.md#tracking-metrics) over the [`TrackWindow`]
/// they name.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackMetrics {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Amplitude (mm).
    pub amp_mm: f64,
    /// Maximum |e| (mm).
    pub max_error_mm: f64,
    /// RMS error (mm).
    pub rms_error_mm: f64,
    /// Wave reduction 1 − max|e|/amplitude.
    pub wave_reduction: f64,
    /// What the metrics are measured over.
    pub window: TrackWindow,
    /// The loop's standing error at rest (mm; docs/simulation.md#the-rest-under-load), part of
    /// every error above: set for the model's responses ([`track`](super::track)), absent from
    /// JSON for the metrics of sampled data alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rest_offset_mm: Option<f64>,
}

/// The whole periods of a sinusoidal response its tracking metrics are measured over
/// (docs/simulation.md#tracking-metrics).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackWindow {
    /// Whether the response is the model's periodic steady state (started from its own
    /// periodic solution, so every period is alike), not one started from rest or a record.
    pub steady_state: bool,
    /// The first and last period measured, counted from 1 at the wave's start.
    pub periods: [u32; 2],
    /// Start of the window on the signals' time axis (s): the start of period `periods[0]`.
    pub from_s: f64,
    /// End of the window (s), excluded: the end of period `periods[1]`.
    pub to_s: f64,
}

/// Slack (s) on a window's ends, for sample times written as decimal text.
pub(super) const WINDOW_SLACK_S: f64 = 1e-9;

impl TrackWindow {
    /// Periods `first..=last` (from 1) of a wave of `freq_hz` that starts at `start_s`.
    pub fn periods(start_s: f64, freq_hz: f64, first: u32, last: u32, steady_state: bool) -> Self {
        TrackWindow {
            steady_state,
            periods: [first, last],
            from_s: start_s + f64::from(first - 1) / freq_hz,
            to_s: start_s + f64::from(last) / freq_hz,
        }
    }

    /// Every whole period of a wave of `freq_hz` that starts at `start_s` and is recorded up to
    /// `end_s` which begins once a start-up transient of `decay_s` (s, ≥ 0) has died out;
    /// `None` when no whole period is left after it. Not the steady state: a record or a
    /// response started from rest.
    pub fn after_decay(start_s: f64, freq_hz: f64, decay_s: f64, end_s: f64) -> Option<Self> {
        if !(decay_s >= 0.0 && freq_hz > 0.0) {
            return None;
        }
        let count = |span_s: f64| span_s * freq_hz;
        let first = count(decay_s).ceil() + 1.0;
        let last = (count(end_s - start_s) + WINDOW_SLACK_S * freq_hz).floor();
        let fits = first.is_finite() && last.is_finite() && last >= first;
        (fits && last <= f64::from(u32::MAX))
            .then(|| Self::periods(start_s, freq_hz, first as u32, last as u32, false))
    }

    /// Whether sample time `t` (s) lies in the window.
    fn holds(&self, t: f64) -> bool {
        t >= self.from_s - WINDOW_SLACK_S && t < self.to_s - WINDOW_SLACK_S
    }
}

/// Metrics of the error `e` (mm) sampled at `t` (s) for a sine of `freq_hz` and `amp_mm`,
/// over the samples in `window` (from its start, up to but not including its end, so each
/// whole period counts its samples once).
pub fn track_metrics(
    t: &[f64],
    e: &[f64],
    freq_hz: f64,
    amp_mm: f64,
    window: TrackWindow,
) -> TrackMetrics {
    let inside: Vec<f64> = t
        .iter()
        .zip(e)
        .filter(|(t, _)| window.holds(**t))
        .map(|(_, e)| *e)
        .collect();
    let max = inside.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    let rms = (inside.iter().map(|e| e * e).sum::<f64>() / inside.len().max(1) as f64).sqrt();
    TrackMetrics {
        freq_hz,
        amp_mm,
        max_error_mm: max,
        rms_error_mm: rms,
        wave_reduction: 1.0 - max / amp_mm,
        window,
        rest_offset_mm: None,
    }
}

/// Mean squared position error (mm²) between a simulated `sim` and a measured `meas` position
/// (mm) over the samples with time `t` ≤ `end_s` (s): how well a replayed record fits up to the
/// end of its fit window (docs/simulation.md). 0 when no sample lies in the window.
pub fn position_mse_until(t: &[f64], sim: &[f64], meas: &[f64], end_s: f64) -> f64 {
    let (sum, n) = t
        .iter()
        .zip(sim.iter().zip(meas))
        .filter(|(t, _)| **t <= end_s)
        .fold((0.0, 0usize), |(s, n), (_, (a, b))| {
            (s + (a - b).powi(2), n + 1)
        });
    sum / n.max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn position_mse_counts_only_the_fit_window() {
        // errors 1, 2, 3, 4 mm at t = 0..3 s: up to 1.5 s the mean of 1 and 4 mm²
        let t = [0.0, 1.0, 2.0, 3.0];
        let meas = [0.0; 4];
        let sim = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(position_mse_until(&t, &sim, &meas, 1.5), 2.5);
        assert_eq!(position_mse_until(&t, &sim, &meas, 3.0), 7.5);
        assert_eq!(position_mse_until(&t, &sim, &meas, -1.0), 0.0);
    }

    #[test]
    fn second_order_step_metrics_match_closed_form() {
        // y = 1 − e^{−ζωt}(cos ωd t + ζ/√(1−ζ²) sin ωd t): overshoot e^{−πζ/√(1−ζ²)},
        // peak at π/ωd
        let (wn, z) = (4.0f64, 0.3f64);
        let wd = wn * (1.0 - z * z).sqrt();
        let t: Vec<f64> = (0..=200_000).map(|k| k as f64 * 1e-4).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&t| {
                1.0 - (-z * wn * t).exp()
                    * ((wd * t).cos() + z / (1.0 - z * z).sqrt() * (wd * t).sin())
            })
            .collect();
        let m = step_metrics(&t, &y, 1.0, 1.0);
        let os = (-PI * z / (1.0 - z * z).sqrt()).exp();
        assert!((m.overshoot_pct - 100.0 * os).abs() < 1e-3, "{m:?}");
        assert!((m.peak_time_s - PI / wd).abs() < 2e-4);
        assert!(m.steady_state_error_mm.abs() < 1e-12);
        // settling: the envelope bound 4/(ζωn) is an upper estimate; the true value is below it
        let ts = m.settling_time_s.unwrap();
        assert!(ts > 2.0 && ts < 4.0 / (z * wn), "{ts}");
        // at the settling time the response is at the band edge
        let k = t.iter().position(|&x| x >= ts).unwrap();
        assert!(((y[k] - 1.0).abs() - 0.02).abs() < 1e-3);
    }

    #[test]
    fn first_order_rise_time_is_tau_ln9() {
        let tau = 0.5;
        let t: Vec<f64> = (0..=100_000).map(|k| k as f64 * 1e-4).collect();
        let y: Vec<f64> = t.iter().map(|t| 5.0 * (1.0 - (-t / tau).exp())).collect();
        let m = step_metrics(&t, &y, 5.0, 5.0);
        assert!(
            (m.rise_time_s.unwrap() - tau * 9f64.ln()).abs() < 1e-6,
            "{m:?}"
        );
        assert!((m.settling_time_s.unwrap() - tau * 50f64.ln()).abs() < 1e-6);
        assert_eq!(m.overshoot_mm, 0.0);
    }

    #[test]
    fn tracking_metrics_count_only_the_window() {
        let f = 0.5;
        let t: Vec<f64> = (0..=600).map(|k| k as f64 * 0.01).collect();
        // a large error in the first period and at the very end, a 2 mm sine between
        let e: Vec<f64> = t
            .iter()
            .map(|&t| {
                if !(2.0..5.999).contains(&t) {
                    50.0
                } else {
                    2.0 * (2.0 * PI * f * t).sin()
                }
            })
            .collect();
        let w = TrackWindow::periods(0.0, f, 2, 3, false);
        assert_eq!((w.from_s, w.to_s), (2.0, 6.0));
        let m = track_metrics(&t, &e, f, 20.0, w);
        assert!((m.max_error_mm - 2.0).abs() < 1e-3, "{m:?}");
        // two whole periods of 200 samples each: the RMS of a sine, exactly
        assert!((m.rms_error_mm - 2.0 / 2f64.sqrt()).abs() < 1e-12);
        assert!((m.wave_reduction - 0.9).abs() < 1e-4);
        assert_eq!(m.window, w);
    }

    #[test]
    fn the_periods_after_a_decay_are_whole_and_start_after_it() {
        // the wave starts at 1 s; 0.1 Hz: periods start at 1, 11, 21, 31, 41 s
        let w = TrackWindow::after_decay(1.0, 0.1, 11.2, 41.0).unwrap();
        assert_eq!(w.periods, [3, 4]);
        assert!((w.from_s - 21.0).abs() < 1e-12 && (w.to_s - 41.0).abs() < 1e-12);
        assert!(!w.steady_state);
        // a record ending a hair before a period's end (decimal clock) still holds it
        let w = TrackWindow::after_decay(1.0, 0.1, 11.2, 41.0 - 1e-12).unwrap();
        assert_eq!(w.periods, [3, 4]);
        // a decay ending exactly at a period's start: that period is measured
        let w = TrackWindow::after_decay(0.0, 0.25, 8.0, 17.0).unwrap();
        assert_eq!(w.periods, [3, 4]);
        // nothing whole left after the decay
        assert_eq!(TrackWindow::after_decay(1.0, 0.1, 11.2, 30.0), None);
        assert_eq!(TrackWindow::after_decay(1.0, 0.1, f64::NAN, 41.0), None);
        assert_eq!(TrackWindow::after_decay(1.0, 0.1, -1.0, 41.0), None);
        assert_eq!(TrackWindow::after_decay(1.0, 0.0, 11.2, 41.0), None);
    }

    use std::f64::consts::PI;
}
