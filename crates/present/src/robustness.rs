//! The margins beyond gain and phase, as every front end shows them: the disk margin and the
//! sensitivity peaks (docs/analysis.md#disk-margins), and the loop as its PLC samples it
//! (docs/analysis.md#sampled-data-margins).

use crate::format::fmt_opt;
use pumpcyl::loops::Loop;
use pumpcyl::lti::{
    disk_margins, sampled_disk_margins, sampled_margins, DiskMargins, LtiError, Margins,
};
use serde::Serialize;
use serde_json::{json, Value};
use std::fmt::Write as _;

/// The loop's disk margin of skew `skew` and its sensitivity peaks: `disk`, `sensitivity_peak`
/// (M_s, the disk margin of skew 1 being 1/M_s) and `complementary_sensitivity_peak` (M_t, skew
/// −1: 1/M_t); each `null` where the loop's frequency response cannot be evaluated (the
/// classical margins still stand).
pub fn disk_json(lp: &Loop, skew: f64) -> Value {
    match disk_margins(&lp.open_loop, skew) {
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
pub fn disk_text(lp: &Loop, skew: f64) -> String {
    match disk_margins(&lp.open_loop, skew) {
        Ok(d) => format!("{} (docs/analysis.md#disk-margins)\n", disk_line(&d)),
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
