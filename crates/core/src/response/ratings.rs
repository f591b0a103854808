//! Whether a response stays within the drives' ratings (docs/simulation.md#drive-ratings): the
//! motors' rated speed and torque and the pumps' maximum speed. The linear model knows no
//! limit, so a response that asks more of a drive than its rating is one the rig cannot run:
//! its drives would saturate. The one check `step`, `track`, `simulate`, `emulate` and
//! `select` make.

use super::Signals;
use crate::rig::Rig;
use crate::units::PA_PER_BAR;
use serde::Serialize;
use std::fmt;

/// One quantity of one drive beyond its rating: the peak, the rating it exceeds and when.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "quantity", rename_all = "snake_case")]
pub enum OverRating {
    /// A motor turns faster than `motor_rated_speed_rpm`.
    MotorSpeed {
        /// Motor 1 or 2.
        motor: usize,
        /// The largest |ω| (rpm).
        peak_rpm: f64,
        /// The rating (rpm).
        rated_rpm: f64,
        /// When the peak occurs (s, on the signals' time axis); `None` at standstill.
        at_s: Option<f64>,
    },
    /// A motor carries more load torque than `motor_rated_torque_nm`.
    MotorTorque {
        /// Motor 1 or 2.
        motor: usize,
        /// The largest |load torque| (N·m).
        peak_nm: f64,
        /// The rating (N·m).
        rated_nm: f64,
        /// When the peak occurs (s); `None` at standstill.
        at_s: Option<f64>,
    },
    /// A pump turns faster than `pump_max_speed_rpm`.
    PumpSpeed {
        /// Pump 1 or 2.
        pump: usize,
        /// The largest |ω| (rpm).
        peak_rpm: f64,
        /// The limit (rpm).
        max_rpm: f64,
        /// When the peak occurs (s); `None` at standstill.
        at_s: Option<f64>,
    },
}

impl fmt::Display for OverRating {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let when = |at: &Option<f64>| at.map_or(String::new(), |t| format!(" at t = {t:.2} s"));
        match self {
            OverRating::MotorSpeed {
                motor,
                peak_rpm,
                rated_rpm,
                at_s,
            } => write!(
                f,
                "motor {motor} reaches {peak_rpm:.0} rpm{}, above its rated {rated_rpm} rpm (motor_rated_speed_rpm)",
                when(at_s)
            ),
            OverRating::MotorTorque {
                motor,
                peak_nm,
                rated_nm,
                at_s,
            } => write!(
                f,
                "motor {motor} needs {peak_nm:.1} N·m{}, above its rated {rated_nm} N·m (motor_rated_torque_nm)",
                when(at_s)
            ),
            OverRating::PumpSpeed {
                pump,
                peak_rpm,
                max_rpm,
                at_s,
            } => write!(
                f,
                "pump {pump} reaches {peak_rpm:.0} rpm{}, above its maximum {max_rpm} rpm (pump_max_speed_rpm)",
                when(at_s)
            ),
        }
    }
}

/// A peak magnitude and when it occurs (s; `None` at standstill).
type Peak = (f64, Option<f64>);

/// The load torques of the pumps on motors 1 and 2 (N·m) at chamber pressures `p1_bar`,
/// `p2_bar` (bar gauge): pump 1 moves oil from chamber 2 to chamber 1, D1 (p1 − p2); pump 2
/// from the reservoir to chamber 1, D2 p1 (docs/model.md). The torque that accelerates the
/// drive's own inertia is not in it.
pub fn load_torques_nm(rig: &Rig, p1_bar: f64, p2_bar: f64) -> [f64; 2] {
    crate::circuit::AnyCircuit::linear(rig)
        .load_torques_nm([p1_bar, p2_bar].map(|p| p * PA_PER_BAR))
}

/// Every rating of `rig` the drive speeds `speed_rpm` and load torques `torque_nm` of motors 1
/// and 2 exceed, motor 1 first, torque before speed; empty when all are within their ratings.
/// For a standstill (select's steady states); [`signals_over_ratings`] for a response.
pub fn over_ratings(rig: &Rig, speed_rpm: [f64; 2], torque_nm: [f64; 2]) -> Vec<OverRating> {
    let at = |v: [f64; 2]| v.map(|v| (v.abs(), None));
    check(rig, at(speed_rpm), at(torque_nm))
}

/// Every rating of `rig` the response `s` exceeds at its peaks ([`over_ratings`]): the largest
/// |w1_rpm|, |w2_rpm| and load torques ([`load_torques_nm`] of p1_bar, p2_bar), each with its
/// time. Signals a record lacks (empty) are not checked.
pub fn signals_over_ratings(rig: &Rig, s: &Signals) -> Vec<OverRating> {
    let (n, circuit) = (s.time_s.len(), crate::circuit::AnyCircuit::linear(rig));
    let speed = [&s.w1_rpm, &s.w2_rpm].map(|w| peak(w.iter().copied(), &s.time_s));
    let pressures = s.p1_bar.len() == n && s.p2_bar.len() == n;
    let torque = [0, 1].map(|k| {
        let t = s
            .p1_bar
            .iter()
            .zip(&s.p2_bar)
            .filter(|_| pressures)
            .map(|(a, b)| circuit.load_torques_nm([*a, *b].map(|p| p * PA_PER_BAR))[k]);
        peak(t, &s.time_s)
    });
    check(rig, speed, torque)
}

/// The largest magnitude of `v` sampled at `time_s` and when it occurs (NaN wins: a response
/// that is not a number is not within any rating); (0, `None`) when `v` is empty.
fn peak(v: impl Iterator<Item = f64>, time_s: &[f64]) -> Peak {
    v.zip(time_s)
        .fold((0.0, None), |(m, at), (v, t)| match v.abs() {
            a if a > m || (a.is_nan() && !m.is_nan()) => (a, Some(*t)),
            _ => (m, at),
        })
}

/// The ratings the peaks exceed.
fn check(rig: &Rig, speed_rpm: [Peak; 2], torque_nm: [Peak; 2]) -> Vec<OverRating> {
    let mut out = Vec::new();
    for k in 0..2 {
        let ((w, w_at), (tq, tq_at)) = (speed_rpm[k], torque_nm[k]);
        let beyond = |v: f64, limit: f64| v > limit || v.is_nan();
        if beyond(tq, rig.motor_rated_torque_nm) {
            out.push(OverRating::MotorTorque {
                motor: k + 1,
                peak_nm: tq,
                rated_nm: rig.motor_rated_torque_nm,
                at_s: tq_at,
            });
        }
        if beyond(w, rig.motor_rated_speed_rpm) {
            out.push(OverRating::MotorSpeed {
                motor: k + 1,
                peak_rpm: w,
                rated_rpm: rig.motor_rated_speed_rpm,
                at_s: w_at,
            });
        }
        if beyond(w, rig.pump_max_speed_rpm) {
            out.push(OverRating::PumpSpeed {
                pump: k + 1,
                peak_rpm: w,
                max_rpm: rig.pump_max_speed_rpm,
                at_s: w_at,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-made response: motor 1 at 3500 rpm at t = 1 s (beyond the rated 3000 and below
    /// the pump's 3600), motor 2 at −3700 rpm at t = 2 s (beyond both), and p1 40 / p2 0 bar at
    /// t = 2 s: the load torques D1·40 bar and D2·40 bar.
    #[test]
    fn the_peaks_beyond_the_ratings_are_named_with_their_times() {
        let rig = Rig::default();
        let s = Signals {
            time_s: vec![0.0, 1.0, 2.0],
            w1_rpm: vec![100.0, 3500.0, -200.0],
            w2_rpm: vec![0.0, 10.0, -3700.0],
            p1_bar: vec![5.0, 5.0, 40.0],
            p2_bar: vec![4.0, 4.0, 0.0],
            ..Signals::default()
        };
        let d = rig.si().d;
        let torque = [d[0] * 40e5, d[1] * 40e5];
        let got = signals_over_ratings(&rig, &s);
        let mut want = Vec::new();
        for (k, tq) in torque.iter().enumerate() {
            if *tq > 12.5 {
                want.push(OverRating::MotorTorque {
                    motor: k + 1,
                    peak_nm: *tq,
                    rated_nm: 12.5,
                    at_s: Some(2.0),
                });
            }
            let (w, at) = [(3500.0, 1.0), (3700.0, 2.0)][k];
            want.push(OverRating::MotorSpeed {
                motor: k + 1,
                peak_rpm: w,
                rated_rpm: 3000.0,
                at_s: Some(at),
            });
        }
        want.push(OverRating::PumpSpeed {
            pump: 2,
            peak_rpm: 3700.0,
            max_rpm: 3600.0,
            at_s: Some(2.0),
        });
        assert_eq!(got, want);
        assert_eq!(
            got.last().unwrap().to_string(),
            "pump 2 reaches 3700 rpm at t = 2.00 s, above its maximum 3600 rpm (pump_max_speed_rpm)"
        );
        // within the ratings, or without the speed and pressure columns: nothing
        let calm = Signals {
            time_s: vec![0.0, 1.0],
            w1_rpm: vec![2999.0, -2999.0],
            ..Signals::default()
        };
        assert!(signals_over_ratings(&rig, &calm).is_empty());
    }

    #[test]
    fn a_standstill_is_checked_without_times() {
        let rig = Rig::default();
        let got = over_ratings(&rig, [-3100.0, 0.0], [0.0, -13.0]);
        assert_eq!(got.len(), 2);
        assert_eq!(
            got[0].to_string(),
            "motor 1 reaches 3100 rpm, above its rated 3000 rpm (motor_rated_speed_rpm)"
        );
        assert_eq!(
            got[1].to_string(),
            "motor 2 needs 13.0 N·m, above its rated 12.5 N·m (motor_rated_torque_nm)"
        );
    }

    #[test]
    fn the_load_torques_are_the_pumps_pressure_differences() {
        let rig = Rig::default();
        let d = rig.si().d;
        let [t1, t2] = load_torques_nm(&rig, 10.0, 3.0);
        assert!((t1 - d[0] * 7e5).abs() < 1e-12 && (t2 - d[1] * 10e5).abs() < 1e-12);
    }
}
