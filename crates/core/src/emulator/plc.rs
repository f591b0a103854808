//! The PLC around the emulated rig: 100 Hz sampling, sensor noise and quantisation, the
//! circuit's control law in absolute terms (the DPM's of docs/model.md#the-dpm-control-law, where
//! the 10 bar sum-pressure set-point matters; the single-motor circuits' P law on one motor),
//! commands held between samples, and the plant integrated between samples by the exponential
//! integrator of `integrate` (the current loop at 1257 1/s makes the dynamics stiff;
//! docs/emulator.md#the-integration).

use super::integrate::{hold, hold_accounting, typical, work};
use super::{Dynamics, EndStopHit};
use super::{EmulatorError, RunError};
use crate::cavitation::FloorHit;
use crate::circuit::energy::Energy;
use crate::limits::{EmulatorWork, Work};
use crate::response::Signals;
use crate::rig::Rig;
use crate::units::{PA_PER_BAR, RAD_S_PER_RPM};

/// Sampling, sensors and randomness of the PLC.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plc {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Position sensor noise, standard deviation (mm).
    pub noise_x_mm: f64,
    /// Position quantisation step (mm); 0 = none.
    pub quant_x_mm: f64,
    /// Pressure sensor noise (bar).
    pub noise_p_bar: f64,
    /// Speed measurement noise (rpm).
    pub noise_w_rpm: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// Whether a record's run integrates the rig's power account beside its states
    /// (docs/energy.md#over-a-run); the record is the same either way.
    pub energy: bool,
}

impl Plc {
    /// Noise-free, unquantised sampling at `rate_hz`.
    pub fn ideal(rate_hz: f64) -> Plc {
        Plc {
            rate_hz,
            noise_x_mm: 0.0,
            quant_x_mm: 0.0,
            noise_p_bar: 0.0,
            noise_w_rpm: 0.0,
            seed: 1,
            energy: false,
        }
    }
}

/// Seeded Gaussian noise (xorshift64 and Box–Muller): deterministic for a seed.
#[derive(Clone)]
pub(super) struct Noise(u64);

impl Noise {
    pub(super) fn new(seed: u64) -> Noise {
        Noise(seed.max(1).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    pub(super) fn gauss(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// An emulated record and the first time its piston met an end of the stroke, if it did
/// (docs/emulator.md#end-stops).
#[derive(Debug, Clone, PartialEq)]
pub struct Emulation {
    /// The PLC's record (measured signals, user units).
    pub signals: Signals,
    /// The first end stop the piston met, at a PLC sample.
    pub end_stop: Option<EndStopHit>,
    /// The first chamber at the cavitation floor, at a PLC sample of the record.
    pub cavitation: Option<FloorHit>,
    /// The energies of the record's run, where its PLC asked for them ([`Plc::energy`]).
    pub energy: Option<Energy>,
}

/// Emulate the closed loop for the reference `x_ref_mm(t)` from `t = 0` to `duration_s`.
/// The run starts at the steady state of the loop for the reference held at its t = 0 value
/// (see [`equilibrium`]), then runs `settle_s` more with noise (not recorded) so the record
/// opens with the PLC's own jitter. Returns the PLC's record and whether it met an end stop.
pub fn emulate(
    rig: &Rig,
    dynamics: &Dynamics,
    plc: &Plc,
    settle_s: f64,
    duration_s: f64,
    x_ref_mm: impl Fn(f64) -> f64,
) -> Result<Emulation, EmulatorError> {
    let unlimited = Work {
        allow_long_run: true,
        ..Work::QUIET
    };
    emulate_reporting(
        rig,
        dynamics,
        plc,
        (settle_s, duration_s),
        x_ref_mm,
        &unlimited,
    )
    .map_err(RunError::into_emulator)
}

/// Controller steps between two calls of an emulation's progress callback.
pub const PROGRESS_STEPS: u64 = 1 << 12;

/// [`emulate`] over `(settle_s, duration_s)`, calling `work.progress(n)` as each `n` more
/// controller steps of the record are done ([`PROGRESS_STEPS`] at a time, the rest at the end):
/// `duration_s × rate_hz` in all. Unless `work` allows a long run, the integrator's work is
/// watched as it runs ([`EmulatorWork`]) and the run stopped with [`RunError::Limit`] beyond
/// [`crate::limits::MAX_EMULATOR_WORK`] (docs/emulator.md#the-work-limit).
pub fn emulate_reporting(
    rig: &Rig,
    dynamics: &Dynamics,
    plc: &Plc,
    times: (f64, f64),
    x_ref_mm: impl Fn(f64) -> f64,
    work: &Work,
) -> Result<Emulation, RunError> {
    emulate_profile(
        rig,
        dynamics,
        plc,
        times,
        (&x_ref_mm, Profile::default()),
        work,
    )
}

/// A look at the rig at each sample of a record: its time (s) and the state.
pub type Observer<'a> = &'a mut dyn FnMut(f64, &[f64]);

/// What a record's run follows besides its position reference (a duty cycle's,
/// docs/energy.md#duty-cycles): the external force on the piston over time, where it changes,
/// and a look at the rig's state at each sample (its time and the state, before the PLC
/// measures it).
#[derive(Default)]
pub struct Profile<'a> {
    /// The external force (N) at a time (s), from the settling on; `None`: the rig's own.
    pub force_n: Option<&'a dyn Fn(f64) -> f64>,
    /// Called at each sample of the record with its time (s) and the rig's state.
    pub observe: Option<Observer<'a>>,
}

/// [`emulate_reporting`] with the reference `x_ref_mm` and the rest of `profile`: the loop
/// settles under the force at t = 0.
pub fn emulate_profile(
    rig: &Rig,
    dynamics: &Dynamics,
    plc: &Plc,
    (settle_s, duration_s): (f64, f64),
    (x_ref_mm, mut profile): (&dyn Fn(f64) -> f64, Profile<'_>),
    work: &Work,
) -> Result<Emulation, RunError> {
    let (mut rig, mut dynamics) = (rig.clone(), dynamics.clone());
    if let Some(force_n) = profile.force_n {
        rig.external_force_n = force_n(0.0);
        dynamics.set_external_force_n(rig.external_force_n);
    }
    let mut run = PlcLoop::settled(&rig, &dynamics, plc, x_ref_mm(0.0), settle_s)?;
    if plc.energy {
        run.account_energy();
    }
    let signals = record(&mut run, duration_s, (x_ref_mm, &mut profile), work)?;
    Ok(Emulation {
        signals,
        end_stop: run.end_stop,
        cavitation: run.cavitation,
        energy: run.energy,
    })
}

/// The PLC around the emulated rig, advanced one sample at a time: at each sample the PLC
/// measures and computes the speed references, which are held while the
/// rig is integrated to the next sample ([`PlcLoop::hold`]). [`emulate`] and the FMU
/// (docs/fmu.md) run the same sequence, so they give the same records.
#[derive(Clone)]
pub struct PlcLoop {
    rig: Rig,
    dynamics: Dynamics,
    plc: Plc,
    noise: Noise,
    x: Vec<f64>,
    end_stop: Option<EndStopHit>,
    /// The first chamber at the cavitation floor after t = 0 ([`PlcLoop::hold`]).
    cavitation: Option<FloorHit>,
    /// The integrator's work in this loop's [`PlcLoop::hold`]s (right-hand-side evaluations,
    /// docs/emulator.md#the-work-limit).
    work: u64,
    /// The energies of its [`PlcLoop::hold`]s since [`PlcLoop::account_energy`], if asked.
    energy: Option<Energy>,
    /// The energies of the last [`PlcLoop::hold`], where they are accounted.
    last_hold: Option<Energy>,
}

impl PlcLoop {
    /// The loop at rest with the reference held at `r0_mm` ([`equilibrium`]), then run for
    /// `settle_s` more at that reference with the PLC's noise, so a record opens with its jitter.
    pub fn settled(
        rig: &Rig,
        dynamics: &Dynamics,
        plc: &Plc,
        r0_mm: f64,
        settle_s: f64,
    ) -> Result<PlcLoop, EmulatorError> {
        let mut run = PlcLoop {
            rig: rig.clone(),
            dynamics: dynamics.clone(),
            plc: *plc,
            noise: Noise::new(plc.seed),
            x: equilibrium(rig, dynamics, r0_mm)?,
            end_stop: None,
            energy: None,
            last_hold: None,
            cavitation: None,
            work: 0,
        };
        let ts = 1.0 / plc.rate_hz;
        let settle_steps = (settle_s * plc.rate_hz).round() as usize;
        for k in 0..settle_steps {
            let t = -settle_s + k as f64 * ts;
            let (_, u) = run.sample(r0_mm);
            run.hold(u, t, t + ts)?;
        }
        Ok(run)
    }

    /// The speed commands (rad/s) the PLC sends at a sample with the reference `r_mm`.
    pub fn commands(&mut self, r_mm: f64) -> [f64; 2] {
        self.sample(r_mm).1
    }

    /// One PLC sample with the reference `r_mm`: what the PLC measures and the motor speed
    /// references (rad/s) it sends.
    pub(crate) fn sample(&mut self, r_mm: f64) -> (Measured, [f64; 2]) {
        let m = measure(&self.x, &self.dynamics, &self.plc, &mut self.noise);
        let u = self
            .dynamics
            .circuit()
            .plc_commands(&self.rig, r_mm, m.x_mm, &m.p_bar);
        (m, u)
    }

    /// Integrate the rig from `t0` to `t1` (s) with the speed references `u` (rad/s) held.
    /// The first end stop met is kept ([`PlcLoop::end_stop`]), and from t = 0 on the first
    /// chamber at the cavitation floor.
    pub fn hold(&mut self, u: [f64; 2], t0: f64, t1: f64) -> Result<(), EmulatorError> {
        let before = work();
        self.x = match &mut self.energy {
            Some(energy) => {
                let (x, interval) = hold_accounting(&self.dynamics, &self.x, u, (t0, t1))?;
                energy.merge(&interval);
                self.last_hold = Some(interval);
                x
            }
            None => hold(&self.dynamics, &self.x, u, t0, t1)?,
        };
        self.work += work() - before;
        if self.end_stop.is_none() {
            self.end_stop = self.dynamics.end_stop(&self.x, t1);
        }
        if self.cavitation.is_none() && t0 >= 0.0 {
            self.cavitation = self.dynamics.floor_hit(&self.x, t1);
        }
        Ok(())
    }

    /// From now on, integrate the rig's power beside its states (docs/energy.md#over-a-run):
    /// the states stay exactly as without.
    pub fn account_energy(&mut self) {
        self.energy = Some(Energy::default());
    }

    /// The energies since [`PlcLoop::account_energy`], if asked.
    pub fn energy(&self) -> Option<&Energy> {
        self.energy.as_ref()
    }

    /// The first end of the stroke the piston met at the end of a [`PlcLoop::hold`], if any
    /// (docs/emulator.md#end-stops).
    pub fn end_stop(&self) -> Option<EndStopHit> {
        self.end_stop
    }

    /// The rig's state (SI, absolute position, gauge pressures; the circuit's states,
    /// [`crate::circuit::Circuit::states`]).
    pub fn state(&self) -> &[f64] {
        &self.x
    }

    /// The rig's dynamics.
    pub fn dynamics(&self) -> &Dynamics {
        &self.dynamics
    }

    /// Change the external force on the piston (N) from now on.
    pub fn set_external_force_n(&mut self, f_n: f64) {
        self.dynamics.set_external_force_n(f_n);
    }

    /// The integrator's work in this loop's holds so far, in right-hand-side evaluations of
    /// the rig's equations (docs/emulator.md#the-work-limit).
    pub fn integrator_work(&self) -> u64 {
        self.work
    }

    /// The PLC's sample period (s).
    pub fn period_s(&self) -> f64 {
        1.0 / self.plc.rate_hz
    }
}

/// Integrate the rig from state `x` over [`t0`, `t1`] (s) with the speed references `u`
/// (rad/s) held, its power integrated beside the states into `energy`
/// (docs/energy.md#over-a-run): the states exactly as [`hold_speeds`] gives them.
///
/// # Errors
/// As [`hold_speeds`].
pub fn hold_speeds_accounting(
    d: &Dynamics,
    x: &[f64],
    u: [f64; 2],
    (t0, t1): (f64, f64),
    energy: &mut Energy,
) -> Result<Vec<f64>, EmulatorError> {
    let (out, interval) = hold_accounting(d, x, u, (t0, t1))?;
    energy.merge(&interval);
    Ok(out)
}

/// Integrate the rig from state `x` over [`t0`, `t1`] (s) with the speed references `u`
/// (rad/s) held: the emulator without its PLC, driven by a controller outside.
pub fn hold_speeds(
    d: &Dynamics,
    x: &[f64],
    u: [f64; 2],
    t0: f64,
    t1: f64,
) -> Result<Vec<f64>, EmulatorError> {
    hold(d, x, u, t0, t1)
}

/// The steady state of the emulated loop with the reference held at `r_mm` (noise-free
/// sensors): Newton's method on f(x, control(x)) = 0 from the LTI operating point. The P
/// position and sum-pressure loops need small steady errors to turn the pumps that feed the
/// leakage, which the LTI deviation model never sees; this finds them.
pub fn equilibrium(rig: &Rig, d: &Dynamics, r_mm: f64) -> Result<Vec<f64>, EmulatorError> {
    // the torque and speed limits are idle at rest, but a Newton step may cross them and find
    // a flat (singular) Jacobian there: solve without them, then check with them
    // the end stops likewise: a rest outside the stroke is refused, not searched for in a stop
    let free = d.without_limits();
    let (mut start, _) = d.operating_point();
    start[d.at.position] = r_mm * 1e-3;
    let x = match steady_state(rig, &free, r_mm, start.clone()) {
        Ok(x) => x,
        // a single-motor circuit whose valves are open at the linear model's rest: Newton
        // starts again from where the loop itself runs to
        Err(e) if d.circuit().commands() == 1 => {
            let near = run_towards_rest(rig, d, r_mm, start).map_err(|_| e)?;
            steady_state(rig, &free, r_mm, near)?
        }
        Err(e) => return Err(e),
    };
    if let Some(stops) = d.circuit().stops() {
        stops
            .check_rest(x[d.at.position], r_mm)
            .map_err(EmulatorError)?;
    }
    d.check_rest_speeds(&x, r_mm)?;
    let mut f = vec![0.0; x.len()];
    let m = measure(&x, d, &Plc::ideal(1.0), &mut Noise::new(1));
    d.rhs(
        &x,
        &d.circuit().plc_commands(rig, r_mm, m.x_mm, &m.p_bar),
        &mut f,
    );
    if f.iter().zip(typical(d)).any(|(v, s)| (v / s).abs() > 1e-6) {
        return Err(EmulatorError(format!(
            "the emulated loop cannot rest at x_ref = {r_mm} mm within its torque and speed limits"
        )));
    }
    let p_bar: Vec<f64> = d.at.pressures.iter().map(|&i| x[i] / PA_PER_BAR).collect();
    crate::cavitation::check_chambers(&p_bar).map_err(|e| {
        EmulatorError(format!(
            "the emulated loop at rest at x_ref = {r_mm} mm: {e}"
        ))
    })?;
    Ok(x)
}

/// How long the loop runs towards its rest before Newton starts again (s)
/// ([`run_towards_rest`]): several times the slowest settling of the article's and the test
/// rigs' single-motor loops **\[choice\]**.
const RUN_TO_REST_S: f64 = 30.0;

/// The state the noise-free PLC loop with the reference held at `r_mm` reaches from `start` in
/// [`RUN_TO_REST_S`] at 100 Hz: a start for Newton's method where the linear model's rest is
/// far from the emulated one (a single-motor circuit whose check valves are open there,
/// docs/emulator.md#every-circuit).
fn run_towards_rest(
    rig: &Rig,
    d: &Dynamics,
    r_mm: f64,
    start: Vec<f64>,
) -> Result<Vec<f64>, EmulatorError> {
    let exact = Plc::ideal(100.0);
    let ts = 1.0 / exact.rate_hz;
    let mut x = start;
    for k in 0..(RUN_TO_REST_S * exact.rate_hz) as usize {
        let m = measure(&x, d, &exact, &mut Noise::new(1));
        let u = d.circuit().plc_commands(rig, r_mm, m.x_mm, &m.p_bar);
        let t = k as f64 * ts;
        x = hold(d, &x, u, t, t + ts)?;
    }
    Ok(x)
}

fn steady_state(
    rig: &Rig,
    d: &Dynamics,
    r_mm: f64,
    start: Vec<f64>,
) -> Result<Vec<f64>, EmulatorError> {
    let exact = Plc::ideal(1.0);
    let quiet = Noise::new(1);
    let scale = typical(d);
    let n = d.order();
    let g = |x: &[f64], out: &mut [f64]| {
        let m = measure(x, d, &exact, &mut quiet.clone());
        d.rhs(
            x,
            &d.circuit().plc_commands(rig, r_mm, m.x_mm, &m.p_bar),
            out,
        );
    };
    let mut x = start;
    let mut f = vec![0.0; n];
    let size = |f: &[f64]| {
        f.iter()
            .zip(&scale)
            .map(|(v, s)| (v / s).abs())
            .fold(0.0, f64::max)
    };
    for _ in 0..50 {
        g(&x, &mut f);
        let now = size(&f);
        if now < 1e-7 {
            return Ok(x);
        }
        let mut jac = nalgebra::DMatrix::zeros(n, n);
        let mut fp = vec![0.0; n];
        for j in 0..n {
            let mut xp = x.clone();
            let h = 1e-6 * scale[j];
            xp[j] += h;
            g(&xp, &mut fp);
            for i in 0..n {
                jac[(i, j)] = (fp[i] - f[i]) / h;
            }
        }
        let rhs = nalgebra::DVector::from_iterator(n, f.iter().map(|v| -v));
        let dx = jac
            .lu()
            .solve(&rhs)
            .ok_or("the emulated loop has no unique steady state (singular Jacobian)")?;
        // damped Newton: halve the step (at most 20 times) until the residual shrinks
        let mut t = 1.0;
        let mut trial = x.clone();
        let mut shrunk = false;
        for _ in 0..20 {
            for ((xt, xi), di) in trial.iter_mut().zip(&x).zip(dx.iter()) {
                *xt = xi + t * di;
            }
            g(&trial, &mut fp);
            if size(&fp) < now {
                shrunk = true;
                break;
            }
            t *= 0.5;
        }
        // at the rounding floor of a stiff loop (a large sum-pressure gain amplifies it) no
        // step shrinks the residual: accept within the tolerance `equilibrium` checks
        if !shrunk && now < 1e-6 {
            return Ok(x);
        }
        x = trial;
    }
    Err(EmulatorError(format!(
        "the emulated loop found no steady state at x_ref = {r_mm} mm in 50 Newton steps"
    )))
}

/// What the PLC reads: position (mm), pressures (bar), the motor speeds (rpm, one per motor
/// of the circuit), with noise and quantisation.
pub(crate) struct Measured {
    pub(crate) x_mm: f64,
    pub(crate) p_bar: [f64; 2],
    pub(crate) w_rpm: Vec<f64>,
}

fn measure(x: &[f64], d: &Dynamics, plc: &Plc, noise: &mut Noise) -> Measured {
    let at = &d.at;
    let quant = |v: f64, q: f64| if q > 0.0 { (v / q).round() * q } else { v };
    Measured {
        x_mm: quant(
            x[at.position] * 1e3 + plc.noise_x_mm * noise.gauss(),
            plc.quant_x_mm,
        ),
        p_bar: [0, 1].map(|i| x[at.pressures[i]] / PA_PER_BAR + plc.noise_p_bar * noise.gauss()),
        w_rpm: (at.speeds.iter())
            .map(|&i| x[i] / RAD_S_PER_RPM + plc.noise_w_rpm * noise.gauss())
            .collect(),
    }
}

/// The recorded run from t = 0, its integrator work watched unless `work` allows a long run.
fn record(
    run: &mut PlcLoop,
    duration_s: f64,
    (x_ref_mm, profile): (&dyn Fn(f64) -> f64, &mut Profile<'_>),
    work: &Work,
) -> Result<Signals, RunError> {
    let ts = run.period_s();
    let steps = (duration_s * run.plc.rate_hz).round() as usize;
    let mut watch = EmulatorWork::new(steps as u64, ts, work.allow_long_run);
    let before = run.work;
    let mut out = Signals::default();
    for k in 0..=steps {
        let t = k as f64 * ts;
        let r = x_ref_mm(t);
        if let Some(force_n) = profile.force_n {
            run.set_external_force_n(force_n(t));
        }
        if let Some(observe) = &mut profile.observe {
            observe(t, &run.x);
        }
        let (m, u) = run.sample(r);
        out.time_s.push(t);
        out.x_ref_mm.push(r);
        out.x_mm.push(m.x_mm);
        out.e_mm.push(r - m.x_mm);
        out.p1_bar.push(m.p_bar[0]);
        out.p2_bar.push(m.p_bar[1]);
        for (column, w) in [&mut out.w1_rpm, &mut out.w2_rpm].into_iter().zip(&m.w_rpm) {
            column.push(*w);
        }
        if let Some(mode) = run.dynamics.mode(&run.x) {
            out.mode.push(mode as f64);
        }
        if k < steps {
            run.hold(u, t, t + ts)?;
            watch.check(k as u64 + 1, run.work - before)?;
        }
        if run.energy.is_some() {
            // the interval from this sample to the next; none after the last
            out.push_power(k, &run.last_hold.take().unwrap_or_default(), ts);
        }
        if (k as u64 + 1).is_multiple_of(PROGRESS_STEPS) {
            work.advance(PROGRESS_STEPS)?;
        }
    }
    work.advance((steps as u64 + 1) % PROGRESS_STEPS)?;
    Ok(out)
}
