//! The emulator's time integration (docs/emulator.md#the-integration): the rig's stiff
//! dynamics (the drives' current loops at 1257 1/s and feedforward filters beside the hydraulic
//! resonance of a few Hz, the article §3.3) integrated over one PLC interval with the speed
//! references held.
//!
//! The stiff part of the equations is linear: the drives' loops. So the integrator splits
//! ẏ = f(y) into J₀ y + N(y), J₀ the exact Jacobian at the dynamics' operating point, and takes
//! the linear part exactly through the matrix functions e^{hJ₀}, φ₁, φ₂, φ₃ (computed once per
//! dynamics and step length), the non-stiff rest N by Cox and Matthews' fourth-order
//! exponential Runge–Kutta method ETDRK4 (J. Comput. Phys. 176, 2002; Hochbruck and Ostermann,
//! "Exponential integrators", Acta Numerica 2010, §2). Each step is checked by step doubling
//! and halved where it misses the tolerance; an interval the steps cannot finish (the drives
//! at their torque limit with the piston in a stop) falls back to diffsol's BDF. The result is
//! a function of the dynamics, the state, the commands and the interval alone, whatever ran
//! before on the thread.

use super::phi::{phi_levels, propagator, Phis, Propagator};
use super::steps::{self, Interval};
use super::{Dynamics, EmulatorError};
use crate::circuit::energy::Energy;
use crate::circuit::{Circuit, Role};
use diffsol::{
    NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod, OdeSolverStopReason, VectorCommon,
};
use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::rc::Rc;

/// Typical magnitude of each state (SI), for finite-difference steps and tolerances, by its
/// role ([`crate::circuit::Role::typical_size`]).
pub(super) fn typical(d: &Dynamics) -> Vec<f64> {
    (d.circuit().states().iter())
        .map(|s| s.role.typical_size())
        .collect()
}

/// Integrate the rig over one PLC interval with the speed references `u` held.
pub(super) fn hold(
    d: &Dynamics,
    x: &[f64],
    u: [f64; 2],
    t0: f64,
    t1: f64,
) -> Result<Vec<f64>, EmulatorError> {
    if let Some(rtol) = BDF_RTOL.with(Cell::get) {
        return bdf(
            &|x: &[f64], y: &mut [f64]| d.rhs(x, &u, y),
            &typical(d),
            x,
            (t0, t1),
            rtol,
        );
    }
    exponential(d, x, u, t0, t1).or_else(|_| {
        // where the exponential steps give up (the drives held at their torque limit while the
        // piston sits in a stop: the linear part no longer matches), the BDF takes the interval
        let f = |x: &[f64], y: &mut [f64]| d.rhs(x, &u, y);
        let scale = typical(d);
        bdf(&f, &scale, x, (t0, t1), FALLBACK_RTOL).or_else(|_| bdf(&f, &scale, x, (t0, t1), 1e-7))
    })
}

/// [`hold`] with the rig's power integrated beside its states (docs/energy.md#over-a-run):
/// the states exactly as [`hold`] gives them, and the energies of the interval from a BDF run
/// of the states with the power's terms as its integrated outputs, whose error control resolves
/// the drives' fast transients that a quadrature at the exponential steps' nodes would not.
pub(super) fn hold_accounting(
    d: &Dynamics,
    x: &[f64],
    u: [f64; 2],
    (t0, t1): (f64, f64),
) -> Result<(Vec<f64>, Energy), EmulatorError> {
    let out = hold(d, x, u, t0, t1)?;
    Ok((out, energy_by_bdf(d, x, u, (t0, t1))?))
}

/// The energies of the interval from a BDF run of the states with the power's terms integrated
/// as its outputs: each term by the BDF's own formula and under its error control, outside the
/// Newton iteration (the terms feed nothing back), so the linear systems stay the states' size.
fn energy_by_bdf(
    d: &Dynamics,
    x: &[f64],
    u: [f64; 2],
    (t0, t1): (f64, f64),
) -> Result<Energy, EmulatorError> {
    let template = d.power(x, &u);
    let terms = template.flat().len();
    let drives = drive_states(d);
    let power = |z: &[f64], w: &mut [f64]| {
        add_work(1);
        w[..terms].copy_from_slice(&d.power(z, &u).flat_as(&template));
        for (k, [speed, torque]) in drives.iter().enumerate() {
            w[terms + 2 * k] = z[*speed] * z[*speed];
            w[terms + 2 * k + 1] = z[*torque] * z[*torque];
        }
    };
    let outputs = terms + 2 * drives.len();
    let rhs = |x: &[f64], y: &mut [f64]| {
        add_work(1);
        d.rhs(x, &u, y)
    };
    let seconds = (t1 - t0).max(1e-6);
    let joules = template.scale_w().max(1e-3) * seconds;
    let scale = typical(d);
    // the squares ride on the account's steps, outside the error control
    let out_atol: Vec<f64> = (std::iter::repeat_n(joules * ENERGY_RTOL, terms))
        .chain(std::iter::repeat_n(UNCONTROLLED, 2 * drives.len()))
        .collect();
    let err = |e: diffsol::error::DiffsolError| EmulatorError(format!("ODE solver: {e}"));
    let x0 = x.to_vec();
    let problem = OdeBuilder::<NalgebraMat<f64>>::new()
        .t0(t0)
        .rtol(ENERGY_RTOL)
        .atol(scale.iter().map(|s| s * ENERGY_RTOL).collect::<Vec<f64>>())
        .rhs_implicit(
            move |x: &[f64], _p: &[f64], _t: f64, y: &mut [f64]| rhs(x, y),
            differenced(rhs, &scale),
        )
        .out_implicit(
            move |x: &[f64], _p: &[f64], _t: f64, w: &mut [f64]| power(x, w),
            differenced(power, &scale),
            outputs,
        )
        .integrate_out(true)
        .out_rtol(ENERGY_RTOL)
        .out_atol(out_atol)
        .init(
            move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&x0),
            x.len(),
        )
        .build()
        .map_err(err)?;
    let mut solver = problem.bdf::<NalgebraLU<f64>>().map_err(err)?;
    solver.set_stop_time(t1).map_err(err)?;
    // each drive's largest |speed| and |torque| at the solver's steps and the interval's ends
    let peak = |y: &[f64], peaks: &mut [[f64; 2]]| {
        for (p, [w, tau]) in peaks.iter_mut().zip(&drives) {
            *p = [p[0].max(y[*w].abs()), p[1].max(y[*tau].abs())];
        }
    };
    let mut peaks = vec![[0.0; 2]; drives.len()];
    peak(x, &mut peaks);
    let mut reached = false;
    for _ in 0..MAX_BDF_STEPS {
        reached = matches!(
            solver.step().map_err(err)?,
            OdeSolverStopReason::TstopReached
        );
        peak(solver.state().y.inner().as_slice(), &mut peaks);
        if reached {
            break;
        }
    }
    if !reached {
        return Err(EmulatorError(format!(
            "ODE solver: more than {MAX_BDF_STEPS} steps from t = {t0} to {t1} s"
        )));
    }
    let g = solver.state().g.inner().as_slice().to_vec();
    finite(&g, t1)?;
    let mut energy = Energy {
        drive_squares: g[terms..].chunks(2).map(|c| [c[0], c[1]]).collect(),
        drive_peaks: peaks,
        ..Energy::default()
    };
    energy.add(&template.with_flat(&g[..terms]), 1.0);
    Ok(energy)
}

/// Each drive's (speed, electromagnetic torque) states, in order; none for a circuit without
/// drives or with the first-order motor model (no torque states).
pub(super) fn drive_states(d: &Dynamics) -> Vec<[usize; 2]> {
    let states = d.circuit().states();
    let at = |role: Role| -> Vec<usize> {
        (states.iter().enumerate())
            .filter(|(_, s)| s.role == role)
            .map(|(i, _)| i)
            .collect()
    };
    (at(Role::MotorSpeed).into_iter())
        .zip(at(Role::Torque))
        .map(|(w, tau)| [w, tau])
        .collect()
}

/// Relative tolerance of the BDF run that integrates the account beside the states (states and
/// energies alike): the energies to about 10⁻⁶ of those at 10⁻⁹ on the article's duty cycle
/// (633.2991 against 633.2990 J drawn), in a third of 10⁻⁹'s time; the account closes to
/// 10⁻¹², every term integrated by the same formula.
const ENERGY_RTOL: f64 = 1e-7;

/// The absolute tolerance that keeps an output out of the error control: the drives' squares
/// (drive sizing's RMS) are integrated on the steps the account's control chooses, which
/// resolve the current loop's transients (measured on the article's duty cycle: the same RMS
/// torques to 10⁻⁹ as under a control of 10⁻⁴ of their size).
const UNCONTROLLED: f64 = 1e100;

/// The most steps the BDF may take over one PLC interval while it integrates the account.
const MAX_BDF_STEPS: usize = 1_000_000;

/// Relative tolerance of the BDF where the exponential integrator gives up.
const FALLBACK_RTOL: f64 = 1e-9;

thread_local! {
    /// The BDF's relative tolerance where [`with_bdf_integrator`] asks for it.
    static BDF_RTOL: Cell<Option<f64>> = const { Cell::new(None) };
    /// The integrator's work on this thread so far ([`work`]).
    static WORK: Cell<u64> = const { Cell::new(0) };
}

/// The work the integrations on this thread have done so far, in right-hand-side evaluations of
/// the rig's equations: each evaluation of an exponential step's nonlinear part or of the BDF's
/// right-hand side counts 1, a new linear part what its Jacobian ([`JACOBIAN_WORK`]) and a pass
/// of its φ functions ([`PHI_WORK`]) cost in evaluations of the same time. A caller takes the
/// difference over its own integrations (docs/emulator.md#the-work-limit).
pub(crate) fn work() -> u64 {
    WORK.with(Cell::get)
}

/// Add `n` units to this thread's integrator work.
fn add_work(n: u64) {
    WORK.with(|w| w.set(w.get() + n));
}

/// A Jacobian at a lattice point by dual numbers, in right-hand-side evaluations: its n + 2
/// evaluations in dual numbers, about 18 (the one-motor circuits' 7 states) to 28 (the DPM's
/// 10) evaluations' time (docs/emulator.md#the-work-limit).
const JACOBIAN_WORK: u64 = 30;

/// One pass of the matrix functions' scaling and squaring for a block of halvings, in
/// right-hand-side evaluations: a new linear part (this and a Jacobian) costs the time of
/// 100 to 350 evaluations in the emulator's runs, measured against their evaluations' time
/// on the three circuits (docs/emulator.md#the-work-limit).
const PHI_WORK: u64 = 200;

/// Run `f` with the emulator integrating by diffsol's BDF at the relative tolerance `rtol`
/// (absolute `rtol` times each state's typical size) on this thread: the reference the
/// exponential integrator is tested against at 10⁻¹¹ (tests/emulator_integration.rs), and at
/// 10⁻⁷ the integration the emulator had before it. Slow.
#[doc(hidden)]
pub fn with_bdf_integrator<R>(rtol: f64, f: impl FnOnce() -> R) -> R {
    let before = BDF_RTOL.with(|r| r.replace(Some(rtol)));
    let out = f();
    BDF_RTOL.with(|r| r.set(before));
    out
}

/// Integrate ẋ = f(x) over [t0, t1] from `x` by BDF at relative tolerance 10⁻⁷; `scale` holds
/// each state's typical size (absolute tolerances and finite-difference steps).
pub(super) fn integrate<F: Fn(&[f64], &mut [f64])>(
    f: &F,
    scale: &[f64],
    x: &[f64],
    t0: f64,
    t1: f64,
) -> Result<Vec<f64>, EmulatorError> {
    bdf(f, scale, x, (t0, t1), 1e-7)
}

/// Integrate ẋ = f(x) over [t0, t1] by diffsol's BDF at relative tolerance `rtol`, absolute
/// `rtol` times each state's `scale`.
fn bdf<F: Fn(&[f64], &mut [f64])>(
    f: &F,
    scale: &[f64],
    x: &[f64],
    (t0, t1): (f64, f64),
    rtol: f64,
) -> Result<Vec<f64>, EmulatorError> {
    let n = x.len();
    let x0 = x.to_vec();
    let f = &|x: &[f64], y: &mut [f64]| {
        add_work(1);
        f(x, y)
    };
    let err = |e: diffsol::error::DiffsolError| EmulatorError(format!("ODE solver: {e}"));
    let problem = OdeBuilder::<NalgebraMat<f64>>::new()
        .t0(t0)
        .rtol(rtol)
        .atol(scale.iter().map(|s| s * rtol).collect::<Vec<f64>>())
        .rhs_implicit(
            move |x: &[f64], _p: &[f64], _t: f64, y: &mut [f64]| f(x, y),
            differenced(f, scale),
        )
        .init(
            move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&x0),
            n,
        )
        .build()
        .map_err(err)?;
    let mut solver = problem.bdf::<NalgebraLU<f64>>().map_err(err)?;
    solver.solve(t1).map_err(err)?;
    let y = solver.state().y.inner().as_slice().to_vec();
    finite(&y, t1)?;
    Ok(y)
}

fn finite(y: &[f64], t: f64) -> Result<(), EmulatorError> {
    if y.iter().any(|v| !v.is_finite()) {
        return Err(EmulatorError(format!(
            "ODE solver: the state is not finite at t = {t} s"
        )));
    }
    Ok(())
}

/// The Jacobian-vector product of `f` by forward differences ([`jac_vec`]), as diffsol takes
/// it: f at the point the Jacobian is taken evaluated once for all its columns.
fn differenced<'a, F: Fn(&[f64], &mut [f64]) + 'a>(
    f: F,
    scale: &'a [f64],
) -> impl Fn(&[f64], &[f64], f64, &[f64], &mut [f64]) + 'a {
    let at: RefCell<(Vec<f64>, Vec<f64>)> = RefCell::new((Vec::new(), Vec::new()));
    move |x: &[f64], _p: &[f64], _t: f64, v: &[f64], y: &mut [f64]| {
        let mut at = at.borrow_mut();
        if at.0 != x {
            at.0 = x.to_vec();
            at.1 = vec![0.0; y.len()];
            f(x, &mut at.1);
        }
        jac_vec(&f, (x, &at.1), v, scale, y)
    }
}

/// J(x)·v by a forward difference along v from `f0` = f(x), the step scaled so no state moves
/// by more than 1e-7 of its typical size.
fn jac_vec<F: Fn(&[f64], &mut [f64])>(
    f: &F,
    (x, f0): (&[f64], &[f64]),
    v: &[f64],
    scale: &[f64],
    y: &mut [f64],
) {
    let vmax = v
        .iter()
        .zip(scale)
        .map(|(v, s)| (v / s).abs())
        .fold(0.0, f64::max);
    if vmax == 0.0 {
        y.fill(0.0);
        return;
    }
    let eps = 1e-7 / vmax;
    let xp: Vec<f64> = x.iter().zip(v).map(|(x, v)| x + eps * v).collect();
    f(&xp, y);
    for (yi, f) in y.iter_mut().zip(f0) {
        *yi = (*yi - f) / eps;
    }
}

/// The cell of the lattice the linear part is taken on, in typical sizes, by a state's role:
/// fine where the Jacobian follows the state (the pressures through β(p), the position through
/// the volumes and the mass along the stroke), about a quarter of the smoothing width where a
/// smoothed nonlinearity sits (the Coulomb friction's 1 mm/s, the pumps' dead band), coarser
/// where the equations are linear in it (torques, feedforward states, commands). Finer cells
/// cost more Jacobians, coarser ones more and shorter steps: these were measured best on the
/// article's noisy records (docs/emulator.md#the-integration).
fn cell(role: Role) -> f64 {
    match role {
        Role::Position | Role::Pressure => 1.0 / 64.0,
        Role::Velocity => 1.0 / 16.0,
        Role::MotorSpeed | Role::Torque | Role::Feedforward | Role::SpeedCommand => 1.0 / 4.0,
        Role::SpoolOpening | Role::SpoolVelocity | Role::SpoolCommand => 1.0 / 16.0,
    }
}

/// The cell of the speed commands, in typical sizes: the Jacobian follows them only where a
/// drive's torque or a pump's speed limit is reached.
const COMMAND_CELL: f64 = 0.25;

/// The role of the dynamics' commands (a drive's speed, a spool's opening), whose typical
/// size sets their cell.
fn command_role(d: &Dynamics) -> Role {
    (d.circuit().inputs().first()).map_or(Role::SpeedCommand, |s| s.role)
}

/// What the integrator knows of one dynamics: its identity, the typical sizes of its states
/// and the lattice cells (SI) its linear parts are taken on.
struct Known {
    /// The dynamics' rates at two points, bit for bit: its identity.
    probe: Vec<u64>,
    /// A number no other `Known` of the thread has: the key of its linear parts.
    serial: u64,
    scale: Vec<f64>,
    cells: Vec<f64>,
    /// The cell of the speed commands (rad/s).
    command_cell: f64,
    /// Whether the circuit says which side of their limits its drives are on
    /// ([`Circuit::drive_regime`]): then the states of [`regime_only`] roles and the commands
    /// key a linear part by that regime alone.
    by_regime: bool,
    /// The role of each state.
    roles: Vec<Role>,
}

/// Whether a state of `role` enters the equations only through the drives, linearly on each
/// side of their limits ([`Circuit::drive_regime`]): the torques and feedforward filters.
fn regime_only(role: Role) -> bool {
    matches!(role, Role::Torque | Role::Feedforward)
}

/// A linear part: the scaled Jacobian J₀ at a lattice point (row-major, and column-major for
/// products) and the ETDRK4 propagators of the halvings of the intervals it was used over (by
/// the bits of the interval and the halving).
struct Linear {
    n: usize,
    j: Vec<f64>,
    j_columns: Vec<f64>,
    propagators: RefCell<Vec<(Halving, Rc<Propagator>)>>,
}

/// A halving of an interval: the bits of the interval (s) and the number of halvings.
type Halving = (u64, u32);

/// A linear part's key: the serial of what is known of the dynamics, the lattice cell of the
/// state and of the commands (or of the states that are not [`regime_only`] and the drives'
/// regime), the rest 0.
type LinearKey = (u64, [i64; KEY]);

/// The most numbers a linear part's lattice cell takes: a cell of each state and of each
/// of the two commands.
const KEY: usize = N_MAX + 2;

/// The most states the integrator takes (the circuits have 6 to 10).
const N_MAX: usize = 16;

/// A hasher for lattice cells (the multiply-rotate hash of Firefox and rustc): the cache looks
/// a linear part up in every PLC interval, and its keys come from the program, not from
/// outside.
#[derive(Default, Clone, Copy)]
struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

/// The cache's maps of linear parts.
type Cells = HashMap<LinearKey, Rc<Linear>, std::hash::BuildHasherDefault<CellHasher>>;

/// Linear parts kept per thread in each of two generations (each with its propagators, about
/// 25 kB): a noisy record at rest visits a few thousand cells over ten minutes, most of them
/// again and again, a noisy one in motion 17 000, met again periods later
/// (docs/emulator.md#the-integration). The results do not depend on what the cache holds.
const CACHE: usize = 2048;

/// The linear parts of the thread: those used since the current generation began, and those of
/// the one before, moved back into the current one when used again. When the current one is
/// full it becomes the old one and the old one is dropped: what is still in use survives.
struct Generations {
    current: Cells,
    old: Cells,
}

impl Default for Generations {
    fn default() -> Self {
        Generations {
            current: Cells::with_capacity_and_hasher(CACHE, Default::default()),
            old: Cells::default(),
        }
    }
}

impl Generations {
    fn get(&mut self, key: &LinearKey) -> Option<Rc<Linear>> {
        if let Some(l) = self.current.get(key) {
            return Some(l.clone());
        }
        let (key, l) = self.old.remove_entry(key)?;
        self.insert(key, l.clone());
        Some(l)
    }

    fn insert(&mut self, key: LinearKey, l: Rc<Linear>) {
        if self.current.len() >= CACHE {
            let fresh = Cells::with_capacity_and_hasher(CACHE, Default::default());
            self.old = std::mem::replace(&mut self.current, fresh);
        }
        self.current.insert(key, l);
    }
}

thread_local! {
    static KNOWN: RefCell<Vec<Rc<Known>>> = const { RefCell::new(Vec::new()) };
    static SERIAL: Cell<u64> = const { Cell::new(0) };
    static LINEAR: RefCell<Generations> = RefCell::new(Generations::default());
}

/// The rates of `d` at its operating point and far from it (every state moved, the commands
/// beyond the drives' limits), bit for bit.
fn probe(d: &Dynamics) -> Vec<u64> {
    let (x, u) = d.operating_point();
    let n = x.len();
    let mut out = vec![0.0; 2 * n];
    d.rhs(&x, &u, &mut out[..n]);
    let far: Vec<f64> = x.iter().map(|v| v * 1.1 + 0.37).collect();
    d.rhs(&far, &[u[0] + 1e3, u[1] - 1e3], &mut out[n..]);
    out.iter().map(|v| v.to_bits()).collect()
}

/// What is known of `d`, found by its probe or learnt.
fn known(d: &Dynamics) -> Rc<Known> {
    let probe = d.probe(probe);
    if let Some(k) = KNOWN.with(|k| k.borrow().iter().find(|k| k.probe == probe).cloned()) {
        return k;
    }
    let probe = probe.to_vec();
    let scale = typical(d);
    let states = d.circuit().states();
    let cells = (states.iter().zip(&scale))
        .map(|(s, size)| size * cell(s.role))
        .collect();
    let (x, u) = d.operating_point();
    let by_regime = d.circuit().drive_regime(&x, &u).is_some();
    let roles = states.iter().map(|s| s.role).collect();
    let serial = SERIAL.with(|s| {
        s.set(s.get() + 1);
        s.get()
    });
    let k = Rc::new(Known {
        probe,
        serial,
        scale,
        cells,
        command_cell: command_role(d).typical_size() * COMMAND_CELL,
        by_regime,
        roles,
    });
    KNOWN.with(|all| {
        let mut all = all.borrow_mut();
        all.insert(0, k.clone());
        all.truncate(8);
    });
    k
}

/// The linear part of `d` for the state `x` and commands `u`: the exact Jacobian at the centre
/// of the lattice cell that holds them (docs/emulator.md#the-integration; the cells' edges
/// include 0, so a cell never straddles the retracted end stop), from the cache or computed.
/// Where the circuit says which side of their limits its drives are on, the torque and
/// feedforward states and the commands key it by that regime at the centre instead of by their
/// cells: the Jacobian there is the same, bit for bit, whichever of their cells the centre is
/// in. A function of its arguments alone: whether it was cached changes nothing.
fn linear_at(d: &Dynamics, k: &Known, x: &[f64], u: [f64; 2]) -> Rc<Linear> {
    let n = x.len();
    let cell_of = |v: f64, c: f64| (v / c).floor() as i64;
    let centre = |v: f64, c: f64| (cell_of(v, c) as f64 + 0.5) * c;
    let mut at = [0.0; N_MAX];
    for ((a, &v), &c) in at.iter_mut().zip(x).zip(&k.cells) {
        *a = centre(v, c);
    }
    let at = &at[..n];
    let uq = u.map(|v| centre(v, k.command_cell));
    let mut point = [0; KEY];
    if k.by_regime {
        let regime = d.circuit().drive_regime(at, &uq).unwrap_or(u64::MAX);
        let cells = (x.iter().zip(&k.cells).zip(&k.roles))
            .filter(|(_, role)| !regime_only(**role))
            .map(|((&v, &c), _)| cell_of(v, c))
            .chain([regime as i64]);
        point.iter_mut().zip(cells).for_each(|(p, c)| *p = c);
    } else {
        let cells = (x.iter().zip(&k.cells))
            .map(|(&v, &c)| cell_of(v, c))
            .chain(u.map(|v| cell_of(v, k.command_cell)));
        point.iter_mut().zip(cells).for_each(|(p, c)| *p = c);
    }
    let key = (k.serial, point);
    if let Some(l) = LINEAR.with(|c| c.borrow_mut().get(&key)) {
        return l;
    }
    add_work(JACOBIAN_WORK);
    let mut j = vec![0.0; n * n];
    d.jacobian_into(at, &uq, &mut j);
    for r in 0..n {
        for c in 0..n {
            j[r * n + c] *= k.scale[c] / k.scale[r];
        }
    }
    let l = Rc::new(Linear {
        n,
        j_columns: columns(&j, n),
        j,
        propagators: RefCell::new(Vec::with_capacity(EAGER as usize + 2)),
    });
    LINEAR.with(|c| c.borrow_mut().insert(key, l.clone()));
    l
}

/// Integrate the rig over [t0, t1] with the commands `u` held by ETDRK4 steps of the whole
/// interval, halved where a step misses the tolerance ([`steps::integrate`]).
fn exponential(
    d: &Dynamics,
    x: &[f64],
    u: [f64; 2],
    t0: f64,
    t1: f64,
) -> Result<Vec<f64>, EmulatorError> {
    let n = d.order();
    if n > N_MAX {
        return Err(EmulatorError(format!(
            "the emulator integrates at most {N_MAX} states, not {n}"
        )));
    }
    let span = t1 - t0;
    if !(span >= 0.0 && span.is_finite()) {
        return Err(EmulatorError(format!(
            "cannot integrate from t = {t0} s to t = {t1} s"
        )));
    }
    if span == 0.0 {
        return Ok(x.to_vec());
    }
    let known = known(d);
    let linear = linear_at(d, &known, x, u);
    let held = RefCell::new(None);
    let propagator = |level| propagator_for(&linear, span, level, &held);
    let interval = Interval {
        d,
        u,
        scale: &known.scale,
        j_columns: &linear.j_columns,
        propagator: &propagator,
        work: add_work,
        t0,
        t1,
    };
    let out = steps::integrate(&interval, x);
    keep_eager(&linear, span, held.into_inner());
    let out = out?;
    finite(&out, t1)?;
    Ok(out)
}

/// The column-major copy of a row-major n × n matrix.
fn columns(m: &[f64], n: usize) -> Vec<f64> {
    (0..n * n).map(|i| m[(i % n) * n + i / n]).collect()
}

/// Halvings of the interval whose φ functions one pass of the scaling and squaring gives (the
/// doublings pass them all on the way): a block of halvings 0 ..= CHAIN, then CHAIN + 1 ..= 2 CHAIN + 1,
/// and so on.
const CHAIN: u32 = 6;

/// Halvings of a block, after its first, whose propagators a linear part keeps once the φ
/// functions of the block were computed for it, whether its interval asked for them or not:
/// most intervals' steps are of the first four halvings, and a linear part met again then
/// needs no new pass.
const EAGER: u32 = 3;

/// The φ functions of the block of halvings last computed in an interval, with the block's
/// first halving: the interval's other halvings of that block take their propagators from them.
type Held = RefCell<Option<(u32, Phis)>>;

/// The propagator of `linear` for steps of the interval `span`'s `level`-th halving, kept
/// with it or built from the φ functions of its block of halvings, those `held` by the
/// interval or computed (and then held). The φ functions are not kept past the interval (a
/// linear part with them took three times the memory, and the cache that many fewer linear
/// parts): a halving asked for later computes them again. Which block a halving belongs to is
/// fixed, so the propagator is a function of the linear part, the interval and the level
/// alone.
fn propagator_for(
    linear: &Linear,
    span: f64,
    level: u32,
    held: &Held,
) -> Result<Rc<Propagator>, EmulatorError> {
    let key = (span.to_bits(), level);
    if let Some((_, q)) = linear.propagators.borrow().iter().find(|(k, _)| *k == key) {
        return Ok(q.clone());
    }
    let first = level / (CHAIN + 1) * (CHAIN + 1);
    let mut held = held.borrow_mut();
    if !matches!(&*held, Some((f, _)) if *f == first) {
        let h = span * 0.5f64.powi(first as i32);
        add_work(PHI_WORK);
        *held = Some((first, phi_levels(linear.n, &linear.j, h, CHAIN as usize)?));
    }
    let phis = &held.as_ref().expect("held just above").1;
    Ok(keep(linear, span, level, first, phis))
}

/// The propagator of `linear` for the `level`-th halving of `span` from the φ functions `phis`
/// of the block from `first`, kept with the linear part.
fn keep(linear: &Linear, span: f64, level: u32, first: u32, phis: &Phis) -> Rc<Propagator> {
    let h = span * 0.5f64.powi(level as i32);
    let q = Rc::new(propagator(phis, (level - first) as usize, h));
    let key = (span.to_bits(), level);
    linear.propagators.borrow_mut().push((key, q.clone()));
    q
}

/// At the end of an interval: the propagators of the first [`EAGER`] + 1 halvings of the
/// block whose φ functions it `held`, kept with the linear part where it has them not yet.
fn keep_eager(linear: &Linear, span: f64, held: Option<(u32, Phis)>) {
    let Some((first, phis)) = held else { return };
    for level in first..=first + EAGER {
        let key = (span.to_bits(), level);
        if !linear.propagators.borrow().iter().any(|(k, _)| *k == key) {
            keep(linear, span, level, first, &phis);
        }
    }
}

/// The ETDRK4 propagators of steps of h/2ˡ, ℓ = 0 ..= `levels`, with the scaled linear part `j`.
#[cfg(test)]
fn propagators(
    n: usize,
    j: &[f64],
    h: f64,
    levels: usize,
) -> Result<Vec<Propagator>, EmulatorError> {
    let phis = phi_levels(n, j, h, levels)?;
    Ok((0..=levels)
        .map(|l| propagator(&phis, l, h * 0.5f64.powi(l as i32)))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::circuit::CircuitKind;
    use crate::emulator::Effects;
    use crate::rig::Rig;

    #[test]
    fn the_jacobian_depends_on_the_torques_feedforward_states_and_commands_through_the_drive_regime_alone(
    ) {
        // what keys a linear part by the regime instead of their cells rests on: at any state,
        // moving the torques, feedforward filters and commands within one regime leaves the
        // Jacobian the same bit for bit, on every circuit, below, at and beyond the limits
        for kind in CircuitKind::ALL {
            let rig = Rig::default()
                .with_overrides(&[format!("circuit={}", kind.name())])
                .unwrap();
            let d = Dynamics::new(&rig, Effects::for_rig(&rig).unwrap()).unwrap();
            let (x0, u0) = d.operating_point();
            if d.circuit().drive_regime(&x0, &u0).is_none() {
                // a circuit without drives keys its linear parts by every state's cell
                continue;
            }
            let roles: Vec<Role> = d.circuit().states().iter().map(|s| s.role).collect();
            let mut seed = 0x2545_f491_4f6c_dd1d_u64;
            let mut random = move || {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            };
            let (mut compared, mut limited) = (0, 0);
            for sample in 0..400 {
                // the speeds near and beyond the pumps' limit too (about 377 rad/s)
                let reach = [1.0, 10.0, 100.0, 1000.0][sample % 4];
                let x: Vec<f64> = (x0.iter().zip(&roles))
                    .map(|(&v, role)| match role {
                        Role::MotorSpeed => v + 2.0 * reach * random(),
                        _ => v + role.typical_size() * 20.0 * random(),
                    })
                    .collect();
                let u = [0, 1].map(|i| u0[i] + reach * random());
                let regime = d.circuit().drive_regime(&x, &u).unwrap();
                let j = d.jacobian(&x, &u);
                for _ in 0..8 {
                    let mut y = x.clone();
                    for (v, role) in y.iter_mut().zip(&roles) {
                        if regime_only(*role) {
                            *v += [1.0, reach, 30.0][sample % 3] * random();
                        }
                    }
                    let w = [0, 1].map(|i| u[i] + reach * random());
                    if d.circuit().drive_regime(&y, &w) != Some(regime) {
                        continue;
                    }
                    let jy = d.jacobian(&y, &w);
                    assert!(
                        (j.iter().zip(&jy)).all(|(a, b)| a.to_bits() == b.to_bits()),
                        "{kind:?} regime {regime}: {x:?} {u:?} vs {y:?} {w:?}"
                    );
                    compared += 1;
                    limited += usize::from(regime != 0);
                }
            }
            assert!(
                compared > 1000 && limited > 100,
                "{kind:?}: {compared}, {limited}"
            );
        }
    }

    #[test]
    fn the_integrators_jacobian_is_the_circuits_linearisation_bit_for_bit() {
        // the linear parts take ∂f/∂x alone (Dynamics::jacobian_into): the same numbers as the
        // full linearisation's, on every circuit, within and beyond the drives' limits
        for kind in CircuitKind::ALL {
            let rig = Rig::default()
                .with_overrides(&[format!("circuit={}", kind.name())])
                .unwrap();
            let d = Dynamics::new(&rig, Effects::for_rig(&rig).unwrap()).unwrap();
            let (x0, u0) = d.operating_point();
            let n = x0.len();
            for sample in 0..50 {
                let reach = [0.1, 1.0, 10.0, 100.0][sample % 4];
                let x: Vec<f64> = (x0.iter().zip(d.circuit().states()))
                    .map(|(&v, s)| {
                        v + s.role.typical_size() * reach * ((sample * 7 % 11) as f64 - 5.0) / 5.0
                    })
                    .collect();
                let u = u0.map(|v| v + 30.0 * reach * ((sample % 5) as f64 - 2.0));
                let mut j = vec![f64::NAN; n * n];
                d.jacobian_into(&x, &u, &mut j);
                let want = d.jacobian(&x, &u);
                assert!(
                    (j.iter().zip(&want)).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{kind:?}: {x:?} {u:?}"
                );
            }
        }
    }

    #[test]
    fn the_phi_functions_of_a_diagonal_matrix_are_the_scalar_ones() {
        // φ₀ = eᶻ, φ₁ = (eᶻ − 1)/z, φ₂ = (eᶻ − 1 − z)/z², φ₃ = (eᶻ − 1 − z − z²/2)/z³
        let z = [-1257.0 * 0.01, -3.0, -0.2, 0.7];
        let n = z.len();
        let mut j = vec![0.0; n * n];
        for i in 0..n {
            j[i * n + i] = z[i];
        }
        let phis = phi_levels(n, &j, 1.0, 2).unwrap();
        assert_eq!(phis.levels(), 4);
        for l in 0..4 {
            let zs = z.map(|v| v * 0.5f64.powi(l as i32));
            for (i, &z) in zs.iter().enumerate() {
                let e = z.exp();
                // the closed forms cancel for small z: there the series Σ zᵐ/(m + k)!
                let series = |k: i32| {
                    let (mut sum, mut term) = (0.0, 1.0 / (1..=k).map(f64::from).product::<f64>());
                    for m in 0..40 {
                        sum += term;
                        term *= z / f64::from(m + k + 1);
                    }
                    sum
                };
                let want = if z.abs() < 1.0 {
                    [0, 1, 2, 3].map(series)
                } else {
                    [
                        e,
                        (e - 1.0) / z,
                        (e - 1.0 - z) / (z * z),
                        (e - 1.0 - z - z * z / 2.0) / (z * z * z),
                    ]
                };
                for (k, want) in want.iter().enumerate() {
                    let got = phis.of_j(l, k)[i * n + i];
                    assert!(
                        (got - want).abs() < 1e-12 * want.abs().max(1e-3),
                        "phi{k}({z}) = {got}, want {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_linear_system_with_a_constant_input_is_integrated_exactly() {
        // ETDRK4 with N constant is exact: y(h) = e^{hJ} y0 + h φ₁(hJ) N
        let n = 2;
        let j = [-1257.0, 0.0, 5.0, -2.0];
        let h = 0.01;
        let q = &propagators(n, &j, h, 0).unwrap()[0];
        let full = phi_levels(n, &j, h, 0).unwrap();
        let (e, phi1) = (full.of_j(0, 0), full.of_j(0, 1));
        let y = [1.0, -2.0];
        let c = [3.0, 0.5];
        // out += m v, m column-major n × n
        let mat_vec_add = |m: &[f64], v: &[f64; 2], out: &mut [f64; 2]| {
            for (column, vk) in m.chunks_exact(n).zip(v) {
                for (o, m) in out.iter_mut().zip(column) {
                    *o += m * vk;
                }
            }
        };
        // four stages of a constant N (the second weight takes two of them): the weights must
        // add up to h φ₁
        let mut via = [0.0; 2];
        mat_vec_add(q.e(), &y, &mut via);
        for w in [q.weight1(), q.weight2(), q.weight2(), q.weight3()] {
            mat_vec_add(w, &c, &mut via);
        }
        let mut want = [0.0; 2];
        mat_vec_add(&columns(&e, n), &y, &mut want);
        let p1: Vec<f64> = phi1.iter().map(|v| v * h).collect();
        mat_vec_add(&columns(&p1, n), &c, &mut want);
        for i in 0..n {
            assert!(
                (via[i] - want[i]).abs() < 1e-14,
                "{i}: {} vs {}",
                via[i],
                want[i]
            );
        }
    }
}
