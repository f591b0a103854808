//! Chamber leakages from a standstill record (the article §2.3.2, §2.4; docs/identification.md#leakage-from-standstill).

use super::IdentError;

/// The largest standstill speed accepted (rpm): far above any pump.
const MAX_SPEED_RPM: f64 = 1e6;
/// The largest standstill pressure accepted (bar): far above any hydraulic system.
const MAX_PRESSURE_BAR: f64 = 1e4;
use crate::rig::Rig;

pub use crate::circuit::dpm::{Leakage, Standstill};

impl Standstill {
    /// The mean speeds and chamber 1 pressure of a standstill record (the article §2.3.2, §2.4; docs/identification.md#leakage-from-standstill).
    /// A record without `w2_rpm` (a one-motor circuit's) gives `w2_rpm` NaN, which the DPM's
    /// [`Standstill::leakage`] refuses.
    pub fn of_record(rec: &crate::record::Record) -> Result<Standstill, IdentError> {
        let mean = |v: &Option<Vec<f64>>, col: &str| {
            v.as_ref()
                .map(|v| v.iter().sum::<f64>() / v.len() as f64)
                .ok_or_else(|| {
                    IdentError::Input(format!(
                        "{}: line 1 (header): a standstill record needs the column `{col}`",
                        rec.file
                    ))
                })
        };
        Ok(Standstill {
            w1_rpm: mean(&rec.w1_rpm, "w1_rpm")?,
            w2_rpm: match rec.w2_rpm {
                Some(_) => mean(&rec.w2_rpm, "w2_rpm")?,
                None => f64::NAN,
            },
            p1_bar: mean(&rec.p1_bar, "p1_bar")?,
        })
    }

    /// Check the values are usable (finite, positive pressure, magnitudes a pump-driven
    /// cylinder can have).
    pub fn validate(&self) -> Result<(), IdentError> {
        let bad = |key: &str, v: f64, rule: &str| {
            Err(IdentError::Input(format!(
                "standstill `{key}` = {v}: {rule}"
            )))
        };
        // w2_rpm NaN: no second motor (a one-motor circuit's record), checked by the DPM's
        // leakage
        let second = (!self.w2_rpm.is_nan()).then_some(("w2_rpm", self.w2_rpm));
        for (key, v) in [("w1_rpm", self.w1_rpm), ("p1_bar", self.p1_bar)]
            .into_iter()
            .chain(second)
        {
            if !v.is_finite() {
                return bad(key, v, "must be a finite number");
            }
        }
        for (key, v) in [("w1_rpm", self.w1_rpm), ("w2_rpm", self.w2_rpm)] {
            if v.abs() > MAX_SPEED_RPM {
                let rule = format!("outside the physical range ±{MAX_SPEED_RPM:e} rpm");
                return bad(key, v, &rule);
            }
        }
        if self.p1_bar > MAX_PRESSURE_BAR {
            let rule = format!("above the physical limit {MAX_PRESSURE_BAR:e} bar");
            return bad("p1_bar", self.p1_bar, &rule);
        }
        if self.p1_bar <= 0.0 {
            return bad(
                "p1_bar",
                self.p1_bar,
                "must be > 0 (gauge pressure at standstill)",
            );
        }
        Ok(())
    }

    /// [`Standstill::validate`], and on a dual-pump rig that the standstill has every valve
    /// shut: with a check valve open the pump speed feeds the valve and c1, c2 would be its
    /// flow, not leakage (docs/circuits.md#identification-where-a-valve-is-open). Checked once,
    /// before any fit, so that the reason is said rather than every candidate failing.
    pub fn validate_for(&self, rig: &Rig) -> Result<(), IdentError> {
        self.validate()?;
        if rig.circuit.validate_rest(rig).is_err() {
            return Ok(()); // the rig's own checks name an undetermined rest
        }
        let p_bar = [self.p1_bar, rig.p2_at_rest_bar(self.p1_bar)];
        (crate::circuit::AnyCircuit::linear(rig))
            .standstill_valves_shut(p_bar.map(|p| p * crate::units::PA_PER_BAR))
            .map_err(|e| IdentError::Input(format!("standstill p1_bar = {}: {e}", self.p1_bar)))
    }

    /// c1 and c2 from the standstill continuity equations (the article §2.3.2, §2.4; docs/identification.md#leakage-from-standstill) for a given c12:
    /// c1 = (D1 ω1 + D2 ω2 − c12 (p1 − p2))/p1, c2 = (−D1 ω1 + c12 (p1 − p2))/p2, with p2 from
    /// Newton's force balance at rest, p1 A1 − p2 A2 = F_ext (the sign convention of docs/model.md#newton).
    pub fn leakage(&self, rig: &Rig, c12: f64) -> Result<Leakage, IdentError> {
        self.validate()?;
        (rig.circuit.validate_rest(rig))
            .map_err(|(key, value, rule)| IdentError::Input(format!("{key} = {value}: {rule}")))?;
        (crate::circuit::AnyCircuit::linear(rig))
            .standstill_leakage(rig, self, c12)
            .unwrap_or_else(|| {
                Err(format!(
                    "circuit = \"{}\": leakage from standstill models the circuits whose \
                     standstill fixes c1 and c2 only (dpm and dual-pump) so far; margins, \
                     poles, bode and model analyse every circuit \
                     (docs/circuits.md#what-works-on-which-circuit)",
                    rig.circuit.name()
                ))
            })
            .map_err(IdentError::Input)
    }
}

/// Largest spread of the position (max − min, mm) a standstill record may show: more than
/// sensor noise and a P loop's creep means the piston moved, and the pumps' mean speeds then
/// feed motion as well as leakage.
pub const STANDSTILL_SPREAD_MM: f64 = 0.5;

/// Why a record may not be a standstill (the article's Section 2.4 needs the piston at
/// rest under feedback): the reference changes, or the position spreads more than
/// [`STANDSTILL_SPREAD_MM`].
pub fn standstill_warnings(rec: &crate::record::Record) -> Vec<String> {
    let mut out = Vec::new();
    if rec.first_change() < rec.len() {
        out.push(format!(
            "{}: the reference changes at t = {} s: a standstill record holds it constant",
            rec.file,
            rec.time_s[rec.first_change()]
        ));
    }
    let (lo, hi) = rec
        .x_mm
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
            (l.min(x), h.max(x))
        });
    if hi - lo > STANDSTILL_SPREAD_MM {
        out.push(format!(
            "{}: the position spans {:.3} mm (more than {STANDSTILL_SPREAD_MM} mm): the piston is not at standstill, \
             so the mean pump speeds feed motion as well as leakage",
            rec.file,
            hi - lo
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_the_article_leakages() {
        let s = Standstill {
            w1_rpm: -160.0,
            w2_rpm: 245.0,
            p1_bar: 3.95,
        };
        let l = s.leakage(&Rig::default(), 1.2e-10).unwrap();
        assert!((l.p2_bar - 5.86).abs() < 0.01, "{l:?}");
        assert!((l.c1_m5_per_ns / 5.49e-11 - 1.0).abs() < 0.01, "{l:?}");
        assert!((l.c2_m5_per_ns / -1.19e-11 - 1.0).abs() < 0.02, "{l:?}");
        // the leakages close the continuity equations at standstill exactly
        let si = Rig::default().si();
        let rpm = crate::units::RAD_S_PER_RPM;
        let (p1, p2) = (3.95e5, l.p2_bar * 1e5);
        let q1 = si.d[0] * -160.0 * rpm + si.d[1] * 245.0 * rpm
            - l.c1_m5_per_ns * p1
            - 1.2e-10 * (p1 - p2);
        let q2 = -si.d[0] * -160.0 * rpm + 1.2e-10 * (p1 - p2) - l.c2_m5_per_ns * p2;
        assert!(q1.abs() < 1e-18 && q2.abs() < 1e-18);
    }

    #[test]
    fn a_standstill_that_cavitates_chamber_2_is_refused() {
        // an external force pushing the piston in (+x) with chamber 1 at 0.1 bar: the force
        // balance asks for p2 = (p1 A1 − F)/A2 far below the vapour pressure, a state the
        // circuit cannot hold
        let rig = Rig {
            external_force_n: 20_000.0,
            ..Rig::default()
        };
        let s = Standstill {
            w1_rpm: -160.0,
            w2_rpm: 245.0,
            p1_bar: 0.1,
        };
        assert!(rig.p2_at_rest_bar(0.1) < -1.0);
        let e = s.leakage(&rig, 1e-10).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("chamber 2") && e.contains("cavitation"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }

    #[test]
    fn bad_standstill_is_an_error() {
        let s = Standstill {
            w1_rpm: -160.0,
            w2_rpm: 245.0,
            p1_bar: 0.0,
        };
        assert!(s
            .leakage(&Rig::default(), 1e-10)
            .unwrap_err()
            .to_string()
            .contains("p1_bar"));
    }
}
