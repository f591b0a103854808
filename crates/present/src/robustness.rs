//! The margins beyond gain and phase, as every front end shows them: the disk margin and the
//! sensitivity peaks (docs/analysis.md#disk-margins), and the loop as its PLC samples it
//! (docs/analysis.md#sampled-data-margins).

use crate::figures::{trace, Chart, Plot};
use crate::format::fmt_opt;
use crate::plot::{LineStyle, Panel, Trace};
type Complex64 = nalgebra::Complex<f64>;
use pumpcyl::loops::Loop;
use pumpcyl::lti::{
    disk_margins, log_grid, sampled_disk_margins, sampled_margins, unwrap_from, DiskMargins,
    FreqEvaluator, LtiError, Margins, Peak, SampledLoop,
};
use serde::Serialize;
use serde_json::{json, Value};
use std::f64::consts::{PI, TAU};
use std::fmt::Write as _;

/// A loop's disk margins ([`disk_margins`]), computed once for every part of a document that
/// shows them (the disk margin, the gang of four's peaks).
pub type Disk = Result<DiskMargins, LtiError>;

/// The loop's disk margin and its sensitivity peaks: `disk`, `sensitivity_peak`
/// (M_s, the disk margin of skew 1 being 1/M_s) and `complementary_sensitivity_peak` (M_t, skew
/// −1: 1/M_t); each `null` where the loop's frequency response cannot be evaluated (the
/// classical margins still stand).
pub fn disk_json(disk: &Disk) -> Value {
    match disk {
        Ok(d) => json!(d),
        Err(_) => json!({
            "disk": null,
            "sensitivity_peak": null,
            "complementary_sensitivity_peak": null,
        }),
    }
}

/// The loop's disk margin and sensitivity peaks in one line of text (a line saying why where
/// they cannot be computed).
pub fn disk_text(disk: &Disk) -> String {
    match disk {
        Ok(d) => format!("{} (docs/analysis.md#disk-margins)\n", disk_line(d)),
        Err(e) => format!("disk margin: not computed ({e})\n"),
    }
}

/// "disk margin (skew σ): alpha …, gain ±…, phase ±… at …; M_s … at …, M_t … at …".
fn disk_line(d: &DiskMargins) -> String {
    let num =
        |v: Option<f64>, unit: &str| v.map_or("inf".to_string(), |v| format!("{v:.2} {unit}"));
    let hz = |v: Option<f64>| v.map_or("infinite frequency".to_string(), |v| format!("{v:.3} Hz"));
    let (ms, mt) = (&d.sensitivity_peak, &d.complementary_sensitivity_peak);
    let kind = match d.disk.skew {
        0.0 => "balanced, skew 0".to_string(),
        s => format!("skew {s}"),
    };
    format!(
        "disk margin ({kind}): alpha {:.4}, gain +/-{}, phase +/-{} at {}; M_s {:.3} at {}, M_t {:.3} at {}",
        d.disk.disk_margin,
        num(d.disk.gain_margin_db, "dB"),
        num(d.disk.phase_margin_deg, "deg"),
        hz(d.disk.frequency_hz),
        ms.value,
        hz(ms.frequency_hz),
        mt.value,
        hz(mt.frequency_hz),
    )
}

/// The loop as its PLC closes it: sampled with a zero-order hold at the rig's `plc_rate_hz`,
/// its command applied `plc_delay_samples` later (docs/analysis.md#sampled-data-margins).
#[derive(Debug, Clone, Serialize)]
pub struct Sampled {
    /// The PLC's sample rate (Hz).
    pub plc_rate_hz: f64,
    /// Its computation delay (samples).
    pub plc_delay_samples: usize,
    /// The sampled loop's margins, every crossing and the sampled closed loop's stability.
    #[serde(flatten)]
    pub margins: Margins,
    /// The smallest delay margin in samples of the PLC (the sampled `delay_margin_s` × rate).
    pub delay_margin_samples: Option<f64>,
    /// The phase margin the sampling and the delay cost: the continuous loop's less the
    /// sampled one's (deg); `None` where either is infinite.
    pub phase_margin_cost_deg: Option<f64>,
    /// The gain margin they cost (dB), as `phase_margin_cost_deg`.
    pub gain_margin_cost_db: Option<f64>,
    /// The sampled loop's disk margin and sensitivity peaks.
    #[serde(flatten)]
    pub disk: DiskMargins,
}

impl Sampled {
    /// The loop `lp` (a rig's; `None` for a state-space model, which names no PLC) as its PLC
    /// samples it, against its continuous margins `continuous`.
    ///
    /// # Errors
    /// The sampled margins cannot be computed.
    pub fn of_loop(
        lp: &Loop,
        continuous: &Margins,
        skew: f64,
    ) -> Result<Option<Sampled>, LtiError> {
        let Some(rig) = &lp.rig else {
            return Ok(None);
        };
        let (h, delay) = rig.plc_sampling();
        let margins = sampled_margins(&lp.open_loop, h, delay)?;
        let cost = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| a - b);
        Ok(Some(Sampled {
            plc_rate_hz: rig.plc_rate_hz,
            plc_delay_samples: delay,
            delay_margin_samples: margins.delay_margin_s.map(|d| d / h),
            phase_margin_cost_deg: cost(continuous.phase_margin_deg, margins.phase_margin_deg),
            gain_margin_cost_db: cost(continuous.gain_margin_db, margins.gain_margin_db),
            disk: sampled_disk_margins(&lp.open_loop, h, delay, skew)?,
            margins,
        }))
    }

    /// The sampled margins as text: one block under the continuous ones.
    pub fn text(&self) -> String {
        let m = &self.margins;
        let at = |f: Option<f64>| f.map_or(String::new(), |f| format!(" at {f:.4} Hz"));
        let cost = |c: Option<f64>, unit: &str| c.map_or("-".into(), |c| format!("{c:.2} {unit}"));
        let mut s = format!(
            "as the PLC closes it ({} Hz, zero-order hold, {} sample(s) of computation delay; docs/analysis.md#sampled-data-margins):\n",
            self.plc_rate_hz, self.plc_delay_samples
        );
        let _ = writeln!(
            s,
            "  gain margin   {:>9} dB{}  (the PLC costs {})",
            fmt_opt(m.gain_margin_db, 2),
            at(m.phase_crossover_hz),
            cost(self.gain_margin_cost_db, "dB")
        );
        let _ = writeln!(
            s,
            "  phase margin  {:>9} deg{}  (the PLC costs {})",
            fmt_opt(m.phase_margin_deg, 2),
            at(m.gain_crossover_hz),
            cost(self.phase_margin_cost_deg, "deg")
        );
        let _ = writeln!(
            s,
            "  delay margin  {:>9} s ({} samples)",
            fmt_opt(m.delay_margin_s, 4),
            fmt_opt(self.delay_margin_samples, 2)
        );
        let stable = if m.closed_loop_stable {
            "stable"
        } else {
            "NOT STABLE"
        };
        let _ = writeln!(s, "  closed loop   {stable} (the sampled closed loop's eigenvalues against the unit circle)");
        let _ = writeln!(s, "  {}", disk_line(&self.disk));
        s
    }
}

/// `sampled`: the loop as its PLC samples it ([`Sampled`]), `null` for a state-space model
/// (which names no PLC) or where it cannot be computed (`sampled_error` says why).
pub fn sampled_json(lp: &Loop, continuous: &Margins, skew: f64) -> Value {
    match Sampled::of_loop(lp, continuous, skew) {
        Ok(s) => json!({ "sampled": s }),
        Err(e) => json!({ "sampled": null, "sampled_error": e.to_string() }),
    }
}

/// The sampled margins as text ([`Sampled::text`]), nothing for a state-space model.
pub fn sampled_text(lp: &Loop, continuous: &Margins, skew: f64) -> String {
    match Sampled::of_loop(lp, continuous, skew) {
        Ok(Some(s)) => s.text(),
        Ok(None) => String::new(),
        Err(e) => format!("sampled margins: not computed ({e})\n"),
    }
}

/// Largest |L| drawn in the Nyquist diagram: the curve is drawn from where it last enters the
/// circle of this radius (a type-1 loop comes from −j∞), so the region around −1 fills it.
const NYQUIST_RADIUS: f64 = 3.0;
/// Points of the Nyquist curves (log-spaced in frequency).
const NYQUIST_POINTS: usize = 4000;

/// The Nyquist diagram of the loop `lp` (docs/analysis.md#the-nyquist-diagram): L(jω) for
/// ω > 0 and, for a rig's loop, the loop as its PLC samples it up to its Nyquist frequency;
/// the unit circle, the critical point −1 and the disk of critical points the disk margin of
/// skew `skew` keeps the curve away from.
///
/// # Errors
/// The frequency response or the disk margin cannot be computed.
pub fn nyquist_chart(lp: &Loop, skew: f64) -> Result<Chart, LtiError> {
    let ev = FreqEvaluator::new(&lp.open_loop)?;
    let hi_hz = (ev.poles().iter().map(|p| p.norm())).fold(1.0, f64::max) * 10.0 / TAU;
    let omega: Vec<f64> = log_grid(1e-4, hi_hz, NYQUIST_POINTS)
        .iter()
        .map(|f| f * TAU)
        .collect();
    let mut traces = vec![curve(
        "L(jω), continuous",
        &ev.at_many(&omega),
        LineStyle::Solid,
        0,
    )];
    if let Some(rig) = &lp.rig {
        let (h, d) = rig.plc_sampling();
        let sampled = SampledLoop::new(&lp.open_loop, h, d)?;
        let within: Vec<f64> = omega.iter().copied().filter(|w| *w <= PI / h).collect();
        let values: Vec<Complex64> = within
            .iter()
            .map(|&w| sampled.frequency_response(w))
            .collect();
        let label = format!(
            "L(e^jωh), sampled at {} Hz, {d} sample(s) of delay",
            rig.plc_rate_hz
        );
        traces.push(curve(&label, &values, LineStyle::Dashed, 1));
    }
    let disk = disk_margins(&lp.open_loop, skew)?.disk;
    traces.push(circle("unit circle", 0.0, 1.0, LineStyle::Dotted, 7));
    let (centre, radius) = critical_disk(disk.gains());
    let label = format!(
        "disk margin's disk (alpha {:.3}, skew {skew})",
        disk.disk_margin
    );
    traces.push(circle(&label, centre, radius, LineStyle::DashDot, 3));
    traces.push(trace(
        "critical point -1",
        &[-1.0],
        &[0.0],
        LineStyle::Markers,
        Some(3),
    ));
    Ok(Chart {
        title: format!("Nyquist: {}", lp.description),
        subtitle: Some(format!(
            "the curve must leave the disk outside: the loop holds for any gain and phase change within ±{} dB and ±{} deg at once",
            disk.gain_margin_db.map_or("inf".into(), |g| format!("{g:.2}")),
            disk.phase_margin_deg.map_or("inf".into(), |p| format!("{p:.1}"))
        )),
        plot: Plot::Xy {
            x_label: "Re L".into(),
            panels: vec![Panel {
                y_label: "Im L".into(),
                traces,
                categories: vec![],
            }],
        },
    })
}

/// The curve of `values` from where it last enters the circle of radius [`NYQUIST_RADIUS`].
fn curve(label: &str, values: &[Complex64], style: LineStyle, color: usize) -> Trace {
    let start = values
        .iter()
        .rposition(|l| l.norm() > NYQUIST_RADIUS || l.norm().is_nan())
        .map_or(0, |k| k + 1);
    let (re, im): (Vec<f64>, Vec<f64>) = values[start..].iter().map(|l| (l.re, l.im)).unzip();
    trace(label, &re, &im, style, Some(color))
}

/// A circle of `radius` about (`centre`, 0).
fn circle(label: &str, centre: f64, radius: f64, style: LineStyle, color: usize) -> Trace {
    let (re, im): (Vec<f64>, Vec<f64>) = (0..=360)
        .map(|k| f64::from(k).to_radians())
        .map(|t| (centre + radius * t.cos(), radius * t.sin()))
        .unzip();
    trace(label, &re, &im, style, Some(color))
}

/// The centre (on the real axis) and radius of the disk of critical points −1/f, f in the disk
/// margin's disk of gains with real-axis intercepts γ_min and γ_max (docs/analysis.md#disk-margins):
/// its intercepts are −1/γ_min and −1/γ_max (a half-plane, drawn as a large disk, where γ_max
/// is unbounded).
fn critical_disk((g_min, g_max): (f64, f64)) -> (f64, f64) {
    let far = if g_max > 0.0 { -1.0 / g_max } else { 0.0 };
    let near = -1.0 / g_min.max(1e-9);
    ((near + far) / 2.0, (far - near).abs() / 2.0)
}

/// The gang of four of a rig's loop L = C·P, C the PLC's position gain K_p (1/m) and P the
/// plant from the normalised command to the position (docs/analysis.md#the-gang-of-four): the
/// sensitivity S = 1/(1 + L), the complementary sensitivity T = L/(1 + L), the load sensitivity
/// PS = T/K_p (position per unit of a disturbance added to the command) and the noise
/// sensitivity CS = K_p·S (command per metre of position noise) (Åström & Murray, *Feedback
/// Systems*, 2nd ed., 2021, §12.1). Their peaks; the curves are [`gang_of_four_chart`]'s.
#[derive(Debug, Clone, Serialize)]
pub struct GangOfFour {
    /// The controller's gain K_p (1/m).
    pub controller_gain_per_m: f64,
    /// max |S| = M_s.
    pub sensitivity_peak: Peak,
    /// max |T| = M_t.
    pub complementary_sensitivity_peak: Peak,
    /// max |PS| = M_t/K_p (m per unit of command).
    pub load_sensitivity_peak_m: Peak,
    /// max |CS| = K_p·M_s (unit of command per m).
    pub noise_sensitivity_peak_per_m: Peak,
}

impl GangOfFour {
    /// The gang of four of `lp`'s loop from its disk margins `d` of any skew (whose M_s and M_t,
    /// the same whatever the skew, it scales); `None` for a state-space model, which names no
    /// controller.
    pub fn of_loop(lp: &Loop, d: &DiskMargins) -> Option<GangOfFour> {
        let kp = lp.rig.as_ref()?.kp;
        let scaled = |p: &Peak, k: f64| Peak {
            value: p.value * k,
            frequency_hz: p.frequency_hz,
        };
        Some(GangOfFour {
            controller_gain_per_m: kp,
            load_sensitivity_peak_m: scaled(&d.complementary_sensitivity_peak, 1.0 / kp),
            noise_sensitivity_peak_per_m: scaled(&d.sensitivity_peak, kp),
            sensitivity_peak: d.sensitivity_peak.clone(),
            complementary_sensitivity_peak: d.complementary_sensitivity_peak.clone(),
        })
    }
}

/// The gang of four's peaks in one line of text, nothing for a state-space model.
pub fn gang_of_four_text(lp: &Loop, disk: &Disk) -> String {
    let Some(g) = disk.as_ref().ok().and_then(|d| GangOfFour::of_loop(lp, d)) else {
        return String::new();
    };
    let at = |p: &Peak| {
        p.frequency_hz
            .map_or("infinite frequency".into(), |f| format!("{f:.3} Hz"))
    };
    format!(
        "gang of four (Kp {} 1/m): max |PS| {:.4} m per unit of command at {}, max |CS| {:.2} per m at {} (docs/analysis.md#the-gang-of-four)\n",
        g.controller_gain_per_m,
        g.load_sensitivity_peak_m.value,
        at(&g.load_sensitivity_peak_m),
        g.noise_sensitivity_peak_per_m.value,
        at(&g.noise_sensitivity_peak_per_m),
    )
}

/// `gang_of_four`: [`GangOfFour`] of the loop, `null` for a state-space model or where the
/// frequency response cannot be evaluated.
pub fn gang_of_four_json(lp: &Loop, disk: &Disk) -> Value {
    let gang = disk.as_ref().ok().and_then(|d| GangOfFour::of_loop(lp, d));
    json!({ "gang_of_four": gang })
}

/// The gang of four of a rig's loop `lp` as Bode magnitudes (and phases) over `freq_hz`:
/// S, T (dB), PS (dB re 1 m per unit of command) and CS (dB re 1 per m).
///
/// # Errors
/// A state-space model (no controller gain), or a frequency response that cannot be evaluated.
pub fn gang_of_four_chart(lp: &Loop, freq_hz: &[f64]) -> anyhow::Result<Chart> {
    let Some(rig) = &lp.rig else {
        anyhow::bail!(
            "the gang of four needs a rig's loop: a state-space model names no controller gain"
        );
    };
    let ev = FreqEvaluator::new(&lp.open_loop)?;
    let omega: Vec<f64> = freq_hz.iter().map(|f| f * TAU).collect();
    let l = ev.at_many(&omega);
    let s: Vec<Complex64> = l.iter().map(|l| 1.0 / (1.0 + l)).collect();
    let t: Vec<Complex64> = l.iter().map(|l| l / (1.0 + l)).collect();
    let kp = rig.kp;
    let series = |label: &str, v: &[Complex64], k: f64| {
        // unwrapped from the first value's principal phase
        let phase = unwrap_from(v, v.first().map_or(0.0, |z| z.arg().to_degrees()));
        crate::plot::BodeSeries {
            label: label.into(),
            freq_hz: freq_hz.to_vec(),
            mag_db: v.iter().map(|v| 20.0 * (v.norm() * k).log10()).collect(),
            phase_deg: phase,
        }
    };
    let all = vec![
        series("S = 1/(1+L)", &s, 1.0),
        series("T = L/(1+L)", &t, 1.0),
        series("PS = T/Kp (dB re 1 m per unit command)", &t, 1.0 / kp),
        series("CS = Kp S (dB re 1 per m)", &s, kp),
    ];
    let markers = vec![None; all.len()];
    Ok(Chart::bode(
        &format!("Gang of four (Kp {kp} 1/m): {}", lp.description),
        all,
        markers,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::rig::Rig;

    /// The balanced disk margin's disk of critical points, drawn about −1, is the largest the
    /// Nyquist curve stays out of: the continuous curve of the article's loop keeps
    /// |L − c| ≥ r at every frequency and touches it (to 10⁻⁴ of r) near the disk margin's
    /// frequency.
    #[test]
    fn the_nyquist_curve_touches_the_disk_margins_disk() {
        let lp = Loop::of_rig(Rig::default(), "article", false);
        let dm = disk_margins(&lp.open_loop, 0.0).unwrap().disk;
        let (c, r) = critical_disk(dm.gains());
        // for skew 0 the intercepts are −γ_max and −1/γ_max about −1
        let g_max = 10f64.powf(dm.gain_margin_db.unwrap() / 20.0);
        assert!((c - r + g_max).abs() < 1e-9 && (c + r + 1.0 / g_max).abs() < 1e-9);
        let ev = FreqEvaluator::new(&lp.open_loop).unwrap();
        let omega: Vec<f64> = log_grid(1e-2, 1e3, 200_000);
        let (gap, at) = (omega.iter())
            .map(|&w| ((ev.at(w) - Complex64::new(c, 0.0)).norm() - r, w))
            .fold((f64::INFINITY, 0.0), |a, b| if b.0 < a.0 { b } else { a });
        assert!(gap > -1e-6 * r && gap < 1e-4 * r, "gap {gap}, r {r}");
        let hz = dm.frequency_hz.unwrap();
        assert!(
            (at / TAU / hz - 1.0).abs() < 0.01,
            "{} Hz vs {hz}",
            at / TAU
        );
    }
}
