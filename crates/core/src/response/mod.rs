//! Time-domain responses of the closed loop (the article §2.3.3; docs/simulation.md#exact-zero-order-hold): position step, sinusoidal tracking and
//! any recorded reference, simulated exactly by zero-order hold on deviations from the operating
//! point and reported as absolute values in user units (mm, bar gauge, rpm).

mod damping;
mod metrics;
mod ratings;
mod stroke;

pub use damping::{ringing, Ringing, RINGING_GM_DB};
pub use metrics::{
    position_mse_until, step_metrics, track_metrics, StepMetrics, TrackMetrics, TrackWindow,
};
pub use ratings::{load_torques_nm, over_ratings, signals_over_ratings, OverRating};
pub use stroke::{stroke_excursion, StrokeExcursion};

use crate::circuit::Role;
use crate::lti::{LtiError, Simulator, StateSpace, Zoh};
use crate::model::Plant;
use crate::rig::Rig;
use crate::units::{PA_PER_BAR, RAD_S_PER_RPM};
use nalgebra::linalg::balancing::balance_parlett_reinsch;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Simulated (or measured) signals in user units, one value per sample.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Signals {
    /// Time (s).
    pub time_s: Vec<f64>,
    /// Position reference (mm).
    pub x_ref_mm: Vec<f64>,
    /// Position (mm).
    pub x_mm: Vec<f64>,
    /// Control error x_ref − x (mm).
    pub e_mm: Vec<f64>,
    /// Chamber 1 pressure (bar gauge).
    pub p1_bar: Vec<f64>,
    /// Chamber 2 pressure (bar gauge).
    pub p2_bar: Vec<f64>,
    /// Motor 1 speed (rpm).
    pub w1_rpm: Vec<f64>,
    /// Motor 2 speed (rpm); empty for a circuit with one motor.
    pub w2_rpm: Vec<f64>,
    /// The single-pump circuit's mode (1: chamber 2 on the accumulator, 2: chamber 1;
    /// docs/emulator.md#the-mode-signal), in its emulated records only; empty otherwise.
    pub mode: Vec<f64>,
    /// The power account's mean over the interval from each sample to the next (W; 0 at the
    /// last sample), one column per entry of [`crate::circuit::energy::Energy::named`] with
    /// `_w` appended, where an emulated run accounts its energy (docs/energy.md#over-a-run,
    /// docs/formats.md#power-columns); empty otherwise.
    pub power_w: Vec<(String, Vec<f64>)>,
}

impl Signals {
    /// Every signal with its column name (the record's names, and `e_mm`), in record order.
    pub fn named(&self) -> [(&'static str, &Vec<f64>); 8] {
        [
            ("time_s", &self.time_s),
            ("x_ref_mm", &self.x_ref_mm),
            ("x_mm", &self.x_mm),
            ("e_mm", &self.e_mm),
            ("p1_bar", &self.p1_bar),
            ("p2_bar", &self.p2_bar),
            ("w1_rpm", &self.w1_rpm),
            ("w2_rpm", &self.w2_rpm),
        ]
    }

    /// The columns of the signals as a record, in its order: `time_s, x_ref_mm, x_mm` and
    /// those of `p1_bar, p2_bar, w1_rpm, w2_rpm, mode` that hold one value per sample (a
    /// one-motor circuit's record has no `w2_rpm`, only the single-pump circuit's a `mode`),
    /// then the power columns, if any.
    pub fn record_columns(&self) -> Vec<(&str, &Vec<f64>)> {
        let n = self.time_s.len();
        (self.named().into_iter())
            .chain([("mode", &self.mode)])
            .chain(self.power_w.iter().map(|(name, v)| (name.as_str(), v)))
            .filter(|(name, v)| *name != "e_mm" && v.len() == n)
            .collect()
    }

    /// Add the mean power of the energies `interval` over `seconds` as sample `k` of the power
    /// columns, a column that appears first here holding 0 at the earlier samples.
    pub fn push_power(
        &mut self,
        k: usize,
        interval: &crate::circuit::energy::Energy,
        seconds: f64,
    ) {
        for (name, j) in interval.named() {
            let name = format!("{name}_w");
            let at = match self.power_w.iter().position(|(n, _)| *n == name) {
                Some(at) => at,
                None => {
                    self.power_w.push((name, vec![0.0; k]));
                    self.power_w.len() - 1
                }
            };
            self.power_w[at].1.push(j / seconds);
        }
        for (_, column) in &mut self.power_w {
            column.resize(k + 1, 0.0);
        }
    }

    /// The samples of the whole periods of `window`, both its ends included, as a figure
    /// draws them (every signal that holds one value per sample; absent ones stay empty).
    pub fn over(&self, window: &TrackWindow) -> Signals {
        let span = window.from_s - metrics::WINDOW_SLACK_S..=window.to_s + metrics::WINDOW_SLACK_S;
        let keep: Vec<usize> = (0..self.time_s.len())
            .filter(|&k| span.contains(&self.time_s[k]))
            .collect();
        self.samples(&keep)
    }

    /// The samples `keep` (indices, in order) of every signal that holds one value per
    /// sample; absent ones stay empty.
    pub fn samples(&self, keep: &[usize]) -> Signals {
        let n = self.time_s.len();
        let pick = |v: &Vec<f64>| -> Vec<f64> {
            if v.len() == n {
                keep.iter().map(|&k| v[k]).collect()
            } else {
                Vec::new()
            }
        };
        Signals {
            time_s: pick(&self.time_s),
            x_ref_mm: pick(&self.x_ref_mm),
            x_mm: pick(&self.x_mm),
            e_mm: pick(&self.e_mm),
            p1_bar: pick(&self.p1_bar),
            p2_bar: pick(&self.p2_bar),
            w1_rpm: pick(&self.w1_rpm),
            w2_rpm: pick(&self.w2_rpm),
            mode: pick(&self.mode),
            power_w: (self.power_w.iter())
                .map(|(name, v)| (name.clone(), pick(v)))
                .collect(),
        }
    }

    /// The measured signals of a record (absent ones empty), with the control error
    /// e = x_ref − x.
    pub fn of_record(rec: &crate::record::Record) -> Signals {
        let opt = |v: &Option<Vec<f64>>| v.clone().unwrap_or_default();
        Signals {
            time_s: rec.time_s.clone(),
            x_ref_mm: rec.x_ref_mm.clone(),
            x_mm: rec.x_mm.clone(),
            e_mm: rec
                .x_ref_mm
                .iter()
                .zip(&rec.x_mm)
                .map(|(r, x)| r - x)
                .collect(),
            p1_bar: opt(&rec.p1_bar),
            p2_bar: opt(&rec.p2_bar),
            w1_rpm: opt(&rec.w1_rpm),
            w2_rpm: opt(&rec.w2_rpm),
            mode: Vec::new(),
            power_w: Vec::new(),
        }
    }
}

/// The steady state the deviations are taken from, in user units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Baseline {
    /// Reference (mm).
    pub x_ref_mm: f64,
    /// Position (mm).
    pub x_mm: f64,
    /// Chamber pressures (bar gauge).
    pub p_bar: [f64; 2],
    /// Motor speeds (rpm).
    pub w_rpm: [f64; 2],
}

impl Baseline {
    /// The rig's loop at rest with the piston at x0 ([`Plant::rest`], sum-pressure loop as the
    /// rig says): the reference stands off x0 by the rest offset, the pressures and speeds are
    /// those of that rest. Where the loop has no rest (a singular closed loop, whose responses
    /// are refused) the operating point itself, without an offset.
    pub fn of_rig(rig: &Rig) -> Baseline {
        let plant = Plant::new(rig);
        let (x, offset_m) = match plant.rest(rig.sum_pressure) {
            Some(rest) => (rest.state, rest.offset_m),
            None => (plant.operating_point().state, 0.0),
        };
        // a circuit with fewer than two pressures or speeds reads 0 for the missing ones (its
        // responses are refused before they use them: `stable_loop`)
        let at = |role: Role, k: usize| plant.states_of(role).get(k).map_or(0.0, |&i| x[i]);
        let x_mm = x[plant.position()] * 1e3;
        Baseline {
            x_ref_mm: x_mm + offset_m * 1e3,
            x_mm,
            p_bar: [0, 1].map(|k| at(Role::Pressure, k) / PA_PER_BAR),
            w_rpm: [0, 1].map(|k| at(Role::MotorSpeed, k) / RAD_S_PER_RPM),
        }
    }

    /// The initial steady state of a record (docs/simulation.md#deviations-and-the-baseline), with the rig's operating point for the
    /// signals the record lacks.
    pub fn of_record(rec: &crate::record::Record, rig: &Rig) -> Baseline {
        let op = Self::of_rig(rig);
        let mean = |s: &Option<Vec<f64>>, fallback: f64| {
            s.as_ref().map_or(fallback, |v| rec.initial_mean(v))
        };
        Baseline {
            x_ref_mm: rec.initial_mean(&rec.x_ref_mm),
            x_mm: rec.initial_mean(&rec.x_mm),
            p_bar: [
                mean(&rec.p1_bar, op.p_bar[0]),
                mean(&rec.p2_bar, op.p_bar[1]),
            ],
            w_rpm: [
                mean(&rec.w1_rpm, op.w_rpm[0]),
                mean(&rec.w2_rpm, op.w_rpm[1]),
            ],
        }
    }
}

/// Simulate the closed loop of `rig` (sum-pressure loop as the rig says) driven by the
/// reference `x_ref_mm` sampled at `time_s` and held between samples, starting at rest in
/// `base`. An unstable closed loop is an error ([`LtiError::Unstable`]), not a response.
pub fn simulate(
    rig: &Rig,
    time_s: &[f64],
    x_ref_mm: &[f64],
    base: &Baseline,
) -> Result<Signals, LtiError> {
    let (sys, rows) = stable_loop(rig)?;
    let rest = vec![0.0; sys.order()];
    run_from(&sys, &rows, time_s, x_ref_mm, base, &rest)
}

/// Where the recorded signals are among the simulated closed loop's outputs
/// ([`Plant::outputs`]).
struct Rows {
    position: usize,
    pressures: Vec<usize>,
    speeds: Vec<usize>,
    error: usize,
}

impl Rows {
    fn of(plant: &Plant) -> Rows {
        let outputs = plant.outputs();
        let with = |role: Option<Role>| -> Vec<usize> {
            (outputs.iter().enumerate())
                .filter(|(_, o)| o.role == role)
                .map(|(i, _)| i)
                .collect()
        };
        Rows {
            position: with(Some(Role::Position))[0],
            pressures: with(Some(Role::Pressure)),
            speeds: with(Some(Role::MotorSpeed)),
            error: with(None)[0],
        }
    }
}

/// The closed loop of `rig` as simulated (sum-pressure loop as the rig says, outputs
/// [`Plant::outputs`]), refused when unstable: its response would grow without bound.
fn stable_loop(rig: &Rig) -> Result<(StateSpace, Rows), LtiError> {
    // a circuit with modes has no one linear response (docs/circuits.md#its-two-modes)
    crate::circuit::require(rig, "a simulated response", |k| !k.has_modes())
        .map_err(LtiError::Circuit)?;
    let plant = Plant::new(rig);
    let sys = plant.closed_loop_outputs(rig.sum_pressure);
    crate::lti::require_stable(&sys.a)?;
    Ok((sys, Rows::of(&plant)))
}

/// Run the closed loop `sys` from the deviation state `x0` under the held reference
/// `x_ref_mm` and report the signals in user units about `base`.
fn run_from(
    sys: &StateSpace,
    rows: &Rows,
    time_s: &[f64],
    x_ref_mm: &[f64],
    base: &Baseline,
    x0: &[f64],
) -> Result<Signals, LtiError> {
    let u: Vec<f64> = x_ref_mm
        .iter()
        .map(|r| (r - base.x_ref_mm) * 1e-3)
        .collect();
    let r = Simulator::new(sys).run(time_s, &u, x0)?;
    let shifted = |i: usize, scale: f64, offset: f64| -> Vec<f64> {
        r.output(i).iter().map(|v| v * scale + offset).collect()
    };
    // a signal the circuit does not have (a second motor) stays empty, as a record's absent one
    let maybe = |rows: &[usize], k: usize, scale: f64, offset: f64| -> Vec<f64> {
        rows.get(k)
            .map_or_else(Vec::new, |&i| shifted(i, scale, offset))
    };
    Ok(Signals {
        time_s: time_s.to_vec(),
        x_ref_mm: x_ref_mm.to_vec(),
        x_mm: shifted(rows.position, 1e3, base.x_mm),
        p1_bar: maybe(&rows.pressures, 0, 1.0 / PA_PER_BAR, base.p_bar[0]),
        p2_bar: maybe(&rows.pressures, 1, 1.0 / PA_PER_BAR, base.p_bar[1]),
        w1_rpm: maybe(&rows.speeds, 0, 1.0 / RAD_S_PER_RPM, base.w_rpm[0]),
        w2_rpm: maybe(&rows.speeds, 1, 1.0 / RAD_S_PER_RPM, base.w_rpm[1]),
        e_mm: shifted(rows.error, 1e3, base.x_ref_mm - base.x_mm),
        mode: Vec::new(),
        power_w: Vec::new(),
    })
}

/// How long a start-up transient of the closed loop of `rig` as simulated (sum-pressure loop
/// as the rig says) takes to decay below 1 % (s): ln(100)/|Re λ| of its slowest pole λ
/// (docs/simulation.md#tracking-metrics). An unstable loop is an error, as in [`simulate`].
pub fn transient_decay_s(rig: &Rig) -> Result<f64, LtiError> {
    let (sys, _) = stable_loop(rig)?;
    let slowest = crate::lti::eigenvalues(&sys.a)?
        .iter()
        .map(|p| p.re)
        .fold(f64::NEG_INFINITY, f64::max);
    Ok(100f64.ln() / -slowest)
}

/// Refuse a sinusoid of `freq_hz` sampled at `rate_hz` at or above the Nyquist frequency: the
/// samples would not show it (the one check for every sine pumpcyl simulates or emulates).
pub fn check_nyquist(freq_hz: f64, rate_hz: f64) -> Result<(), LtiError> {
    let nyquist_hz = rate_hz / 2.0;
    if freq_hz < nyquist_hz {
        return Ok(());
    }
    Err(LtiError::AboveNyquist {
        freq_hz,
        rate_hz,
        nyquist_hz,
    })
}

/// Uniform sample times 0, 1/rate, … up to and including `duration_s`; refused beyond
/// [`MAX_SAMPLES`](crate::limits::MAX_SAMPLES) samples ([`check_samples`](crate::limits::check_samples)).
pub fn sample_times(duration_s: f64, rate_hz: f64) -> Result<Vec<f64>, crate::limits::LimitError> {
    let n = crate::limits::check_samples(duration_s, rate_hz)?;
    Ok((0..n).map(|k| k as f64 / rate_hz).collect())
}

/// Step response: the reference jumps by `step_mm` at t = 0 from the rig's operating point.
///
/// A 5 mm step of the article's rig with the sum-pressure loop open, sampled at 1 kHz, and its
/// metrics (docs/simulation.md#step-metrics): the overshoot is the article's 40 %.
///
/// ```
/// use pumpcyl::{lti::dc_output, model::Plant, response, rig::Rig};
///
/// let rig = Rig::default().with_overrides(&["sum_pressure=false".to_string()])?;
/// let s = response::step(&rig, 5.0, 3.0, 1000.0)?;
/// assert_eq!(s.time_s.len(), 3001);
/// assert!((s.x_mm[0] - rig.x0_mm).abs() < 1e-9); // starts at the operating point
///
/// // the steady state of the closed loop (its DC solution), then the metrics
/// let sys = Plant::new(&rig).closed_loop_outputs(false);
/// let dc_mm = dc_output(&sys, &[5e-3]).unwrap()[0] * 1e3;
/// assert!((dc_mm - 5.0).abs() < 1e-9); // the integrating loop has no steady-state error
/// let y: Vec<f64> = s.x_mm.iter().map(|x| x - s.x_mm[0]).collect();
/// let m = response::step_metrics(&s.time_s, &y, 5.0, dc_mm);
/// assert!((39.0..40.5).contains(&m.overshoot_pct), "overshoot {} %", m.overshoot_pct);
/// assert!((0.3..0.45).contains(&m.rise_time_s.unwrap()));
/// assert!(m.settling_time_s.unwrap() < 3.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn step(rig: &Rig, step_mm: f64, duration_s: f64, rate_hz: f64) -> Result<Signals, LtiError> {
    let base = Baseline::of_rig(rig);
    let t = sample_times(duration_s, rate_hz)?;
    let r = vec![base.x_ref_mm + step_mm; t.len()];
    simulate(rig, &t, &r, &base)
}

/// The step of an unstable closed loop of `rig` (sum-pressure loop as the rig says), as
/// [`step`] but without refusing it, cut at the first sample where the position has left its
/// operating point by more than `bound_mm` (or at `duration_s`): enough to show how it
/// diverges, never a response growing without bound. For a stable loop it is [`step`] over
/// that window.
pub fn diverging_step(
    rig: &Rig,
    step_mm: f64,
    bound_mm: f64,
    duration_s: f64,
    rate_hz: f64,
) -> Result<Signals, LtiError> {
    let base = Baseline::of_rig(rig);
    let t = sample_times(duration_s, rate_hz)?;
    let r = vec![base.x_ref_mm + step_mm; t.len()];
    let plant = Plant::new(rig);
    let sys = plant.closed_loop_outputs(rig.sum_pressure);
    let s = run_from(
        &sys,
        &Rows::of(&plant),
        &t,
        &r,
        &base,
        &vec![0.0; sys.order()],
    )?;
    let end = s
        .x_mm
        .iter()
        .position(|x| (x - base.x_mm).abs() > bound_mm || x.is_nan())
        .map_or(t.len(), |k| k + 1);
    Ok(s.samples(&(0..end).collect::<Vec<_>>()))
}

/// Metrics of a step response `s` of `rig` (from [`step`]) to a step of `step_mm`, the
/// steady-state error taken from the DC solution of the closed loop (NaN when it has none),
/// the errors with the loop's rest offset ([`Baseline::of_rig`]) in them.
pub fn step_metrics_of(rig: &Rig, s: &Signals, step_mm: f64) -> StepMetrics {
    let sys = Plant::new(rig).closed_loop_outputs(rig.sum_pressure);
    let dc_mm = crate::lti::dc_output(&sys, &[step_mm * 1e-3]).map_or(f64::NAN, |y| y[0] * 1e3);
    let x0 = s.x_mm[0];
    let y: Vec<f64> = s.x_mm.iter().map(|x| x - x0).collect();
    let m = step_metrics(&s.time_s, &y, step_mm, dc_mm);
    let base = Baseline::of_rig(rig);
    let offset_mm = base.x_ref_mm - base.x_mm;
    StepMetrics {
        steady_state_error_mm: m.steady_state_error_mm + offset_mm,
        final_error_mm: m.final_error_mm + offset_mm,
        rest_offset_mm: Some(offset_mm),
        ..m
    }
}

/// [`step_metrics_of`] with the damping warning of the rig's loop ([`ringing`]): the metrics
/// `step` reports, on the command line and in Python.
///
/// # Errors
/// The loop's margins cannot be computed.
pub fn step_report(rig: &Rig, s: &Signals, step_mm: f64) -> Result<StepMetrics, LtiError> {
    Ok(StepMetrics {
        ringing: ringing(rig)?,
        ..step_metrics_of(rig, s, step_mm)
    })
}

/// Sinusoidal tracking in the periodic steady state (docs/simulation.md#tracking-metrics):
/// x_ref = x0 + A sin(2π f t) over `periods` whole periods sampled at `rate_hz` and held
/// between samples, the closed loop started from its own periodic solution
/// ([`steady_sine`]), so every period is the steady one. The metrics are over all the
/// simulated periods; a response started from rest would carry the start-up transient
/// ([`transient_decay_s`]) into them.
///
/// The article's 0.2 Hz ±35 mm wave: one period or four, the same steady state.
///
/// ```
/// use pumpcyl::{response, rig::Rig};
///
/// let rig = Rig::default();
/// let (s, m) = response::track(&rig, 0.2, 35.0, 1, 100.0)?;
/// assert_eq!(s.time_s.len(), 501); // 5 s at 100 Hz, both ends
/// assert!(m.window.steady_state && m.window.periods == [1, 1]);
/// // a P position loop lags the wave by millimetres, but reduces it
/// assert!(m.rms_error_mm < m.max_error_mm && m.max_error_mm < 35.0);
/// assert!((m.wave_reduction - (1.0 - m.max_error_mm / 35.0)).abs() < 1e-12);
/// let (_, four) = response::track(&rig, 0.2, 35.0, 4, 100.0)?;
/// assert!((four.max_error_mm - m.max_error_mm).abs() < 1e-9);
/// assert!((four.rms_error_mm - m.rms_error_mm).abs() < 1e-9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn track(
    rig: &Rig,
    freq_hz: f64,
    amp_mm: f64,
    periods: u32,
    rate_hz: f64,
) -> Result<(Signals, TrackMetrics), LtiError> {
    if periods == 0 {
        return Err(LtiError::Dimension(
            "tracking needs at least one period".into(),
        ));
    }
    check_nyquist(freq_hz, rate_hz)?;
    let t = sample_times(f64::from(periods) / freq_hz, rate_hz)?;
    let base = Baseline::of_rig(rig);
    let s = steady_sine(rig, freq_hz, amp_mm, 0.0, &t, &base)?;
    let window = TrackWindow::periods(0.0, freq_hz, 1, periods, true);
    let m = TrackMetrics {
        rest_offset_mm: Some(base.x_ref_mm - base.x_mm),
        ..track_metrics(&s.time_s, &s.e_mm, freq_hz, amp_mm, window)
    };
    Ok((s, m))
}

/// The periodic steady state of the closed loop of `rig` (sum-pressure loop as the rig says)
/// under x_ref = `base.x_ref_mm` + `amp_mm` sin(2π f (t − `start_s`)), sampled at the uniform
/// times `time_s` and held between samples (docs/simulation.md#tracking-metrics).
///
/// The sampled loop x_{k+1} = Φ x_k + Γ u_k under u_k = Im(U e^{jωkh}) has the periodic
/// solution x_k = Im((e^{jωh} I − Φ)⁻¹ Γ U e^{jωkh}), exactly; the simulation starts from it
/// at `time_s[0]`. An unstable loop is an error, as in [`simulate`]; so are sample times that
/// are not uniform and a sine at or above their Nyquist frequency.
pub fn steady_sine(
    rig: &Rig,
    freq_hz: f64,
    amp_mm: f64,
    start_s: f64,
    time_s: &[f64],
    base: &Baseline,
) -> Result<Signals, LtiError> {
    let h = uniform_step(time_s)?;
    check_nyquist(freq_hz, 1.0 / h)?;
    let (sys, rows) = stable_loop(rig)?;
    let omega = 2.0 * PI * freq_hz;
    let x_ref: Vec<f64> = time_s
        .iter()
        .map(|t| base.x_ref_mm + amp_mm * (omega * (t - start_s)).sin())
        .collect();
    let z = periodic_solution(&sys, omega, h)?;
    let u = Complex64::from_polar(amp_mm * 1e-3, omega * (time_s[0] - start_s));
    let x0: Vec<f64> = z.iter().map(|zi| (zi * u).im).collect();
    run_from(&sys, &rows, time_s, &x_ref, base, &x0)
}

/// The step (s) of uniform sample times: every step within the simulator's 1e-9 relative of
/// the first (sample clocks written as decimal text differ in their last bits).
fn uniform_step(time_s: &[f64]) -> Result<f64, LtiError> {
    let h = match time_s {
        [a, b, ..] => b - a,
        _ => {
            return Err(LtiError::Dimension(
                "a steady state needs at least two sample times".into(),
            ))
        }
    };
    let same = |w: &[f64]| ((w[1] - w[0]) - h).abs() <= 1e-9 * h;
    if h > 0.0 && h.is_finite() && time_s.windows(2).all(same) {
        return Ok(h);
    }
    Err(LtiError::Dimension(
        "a steady state needs uniform, increasing sample times".into(),
    ))
}

/// (e^{jωh} I − Φ)⁻¹ Γ of the loop `sys` sampled with zero-order hold over `h` (s): the state of
/// the periodic solution, per unit of a complex input amplitude, at a sample where the input's
/// phase is 0. Solved by a complex LU on Φ balanced (Parlett–Reinsch), as the frequency
/// response is: (μI − D⁻¹ΦD) D⁻¹z = D⁻¹Γ.
fn periodic_solution(sys: &StateSpace, omega: f64, h: f64) -> Result<Vec<Complex64>, LtiError> {
    let zoh = Zoh::new(&sys.a, &sys.b, h)?;
    let mut phi = zoh.phi;
    let d = balance_parlett_reinsch(&mut phi);
    let n = phi.nrows();
    let mu = Complex64::from_polar(1.0, omega * h);
    let lhs = DMatrix::from_fn(n, n, |i, j| {
        let diagonal = if i == j { mu } else { Complex64::new(0.0, 0.0) };
        diagonal - phi[(i, j)]
    });
    let rhs = DVector::from_fn(n, |i, _| Complex64::new(zoh.gamma[(i, 0)] / d[i], 0.0));
    let z: Option<Vec<Complex64>> = lhs
        .lu()
        .solve(&rhs)
        .map(|w| w.iter().zip(d.iter()).map(|(w, d)| w * d).collect());
    match z {
        Some(z) if z.iter().all(|v| v.re.is_finite() && v.im.is_finite()) => Ok(z),
        _ => Err(LtiError::NonFiniteResult {
            what: "the periodic steady state",
            at: format!("{} Hz", omega / (2.0 * PI)),
        }),
    }
}

/// The three sinusoidal tracking cases of the article (docs/simulation.md#tracking-metrics): (frequency Hz, amplitude mm).
pub const ARTICLE_SINE_CASES: [(f64, f64); 3] = [(0.1, 50.0), (0.2, 35.0), (0.25, 20.0)];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_diverging_step_stops_at_its_bound_and_a_stable_one_is_the_step() {
        // the first-order motor loop of the article's rig is unstable as simulated
        let rig = Rig {
            motor_model: crate::rig::MotorModel::FirstOrder,
            ..Rig::default()
        };
        assert!(step(&rig, 5.0, 6.0, 100.0).is_err());
        let x0 = Baseline::of_rig(&rig).x_mm;
        // it overshoots the 5 mm step past 6 mm within a second: cut there
        let s = diverging_step(&rig, 5.0, 6.0, 6.0, 100.0).unwrap();
        let n = s.x_mm.len();
        assert!(n > 10 && n < 101, "{n} samples");
        assert!((s.x_mm[n - 1] - x0).abs() > 6.0);
        assert!(s.x_mm[..n - 1].iter().all(|x| (x - x0).abs() <= 6.0));
        assert_eq!(s.time_s.len(), n);
        assert_eq!(s.w2_rpm.len(), n);
        // it grows slowly (a pole near +0.02 rad/s): over 6 s it stays within 15 mm, all drawn
        let s = diverging_step(&rig, 5.0, 15.0, 6.0, 100.0).unwrap();
        assert_eq!(s.x_mm.len(), 601);
        // a stable loop: the same samples as the step
        let ok = Rig::default();
        let d = diverging_step(&ok, 5.0, 15.0, 6.0, 100.0).unwrap();
        assert_eq!(d, step(&ok, 5.0, 6.0, 100.0).unwrap());
    }
    use crate::lti::dc_output;

    #[test]
    fn step_settles_at_the_dc_solution() {
        let rig = Rig::default();
        let s = step(&rig, 5.0, 100.0, 100.0).unwrap();
        let sys = Plant::new(&rig).closed_loop_outputs(true);
        let dc = dc_output(&sys, &[5e-3]).unwrap();
        let base = Baseline::of_rig(&rig);
        let last = s.time_s.len() - 1;
        assert!((s.x_mm[last] - (base.x_mm + dc[0] * 1e3)).abs() < 1e-6);
        assert!((s.p1_bar[last] - (base.p_bar[0] + dc[1] / 1e5)).abs() < 1e-6);
        assert!((s.w1_rpm[last] - (base.w_rpm[0] + dc[3] / RAD_S_PER_RPM)).abs() < 1e-4);
        assert!(
            (dc[0] - 5e-3).abs() < 1e-12,
            "type-1 loop: no steady-state error"
        );
        // the error settles at the loop's rest offset (docs/simulation.md#the-rest-under-load)
        assert!((s.e_mm[last] - (base.x_ref_mm - base.x_mm)).abs() < 1e-6);
    }
}
