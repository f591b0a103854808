//! Unit conversions between the user-facing units (bar, rpm, mm, dm³, cm³/rev, kg·mm²) and SI,
//! and numbers written as a user would write them.

use std::f64::consts::PI;

/// Pascal per bar.
pub const PA_PER_BAR: f64 = 1e5;
/// Radians per second per rpm.
pub const RAD_S_PER_RPM: f64 = 2.0 * PI / 60.0;

/// A number as a user would write it: plain when moderate, in exponent form when huge or tiny.
pub fn readable(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e7).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}
