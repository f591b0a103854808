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

use super::{Dynamics, EmulatorError};
use crate::circuit::{Circuit, Role};
use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod, VectorCommon};
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
            move |x: &[f64], _p: &[f64], _t: f64, v: &[f64], y: &mut [f64]| {
                jac_vec(f, x, v, scale, y)
            },
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

/// J(x)·v by a forward difference along v, the step scaled so no state moves by more than
/// 1e-7 of its typical size.
fn jac_vec<F: Fn(&[f64], &mut [f64])>(f: &F, x: &[f64], v: &[f64], scale: &[f64], y: &mut [f64]) {
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
    let mut f0 = vec![0.0; x.len()];
    f(x, &mut f0);
    f(&xp, y);
    for (yi, f) in y.iter_mut().zip(&f0) {
        *yi = (*yi - f) / eps;
    }
}

/// The most states the integrator takes (the circuits have 7 to 10).
const N_MAX: usize = 16;
/// Local error allowed per step, in each state's typical size, as step doubling estimates it
/// (the estimate runs low on this problem: 10⁻⁹ keeps the emulated records within 10⁻¹⁰ m of
/// the tight reference, tests/emulator_integration.rs).
const TOLERANCE: f64 = 1e-9;
/// A step's error, in typical sizes, beyond which even the shortest step is refused: a
/// discontinuity of the equations (a stop's contact, cavitation) is crossed by a step of
/// [`MAX_HALVINGS`] halvings whatever its estimate below this.
const BLOW_UP: f64 = 1e-3;
/// Halvings of the PLC interval allowed before the integration gives up.
const MAX_HALVINGS: u32 = 30;
/// Steps (each checked by doubling) allowed per PLC interval before the BDF takes over.
const MAX_STEPS: usize = 5_000;

/// A state in typical sizes: y = x / s.
type Vector = [f64; N_MAX];

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
    }
}

/// The cell of the speed commands, in typical sizes: the Jacobian follows them only where a
/// drive's torque or a pump's speed limit is reached.
const COMMAND_CELL: f64 = 0.25;

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
    j: Vec<f64>,
    j_columns: Vec<f64>,
    propagators: RefCell<Vec<(Halving, Rc<Propagator>)>>,
}

/// A halving of an interval: the bits of the interval (s) and the number of halvings.
type Halving = (u64, u32);

/// A linear part's key: the serial of what is known of the dynamics, the lattice cell of the
/// state and of the commands.
type LinearKey = (u64, Vec<i64>);

/// Linear parts kept per thread in each of two generations (each with its propagators, about
/// 25 kB): a noisy record at rest visits a few thousand cells over ten minutes, most of them
/// again and again, a noisy one in motion 17 000, met again periods later
/// (docs/emulator.md#the-integration). The results do not depend on what the cache holds.
const CACHE: usize = 2048;

/// The linear parts of the thread: those used since the current generation began, and those of
/// the one before, moved back into the current one when used again. When the current one is
/// full it becomes the old one and the old one is dropped: what is still in use survives.
#[derive(Default)]
struct Generations {
    current: HashMap<LinearKey, Rc<Linear>>,
    old: HashMap<LinearKey, Rc<Linear>>,
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
            self.old = std::mem::take(&mut self.current);
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
    let probe = probe(d);
    if let Some(k) = KNOWN.with(|k| k.borrow().iter().find(|k| k.probe == probe).cloned()) {
        return k;
    }
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
        command_cell: Role::SpeedCommand.typical_size() * COMMAND_CELL,
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
    let at: Vec<f64> = (x.iter().zip(&k.cells))
        .map(|(&v, &c)| centre(v, c))
        .collect();
    let uq = u.map(|v| centre(v, k.command_cell));
    let point: Vec<i64> = if k.by_regime {
        let regime = d.circuit().drive_regime(&at, &uq).unwrap_or(u64::MAX);
        (x.iter().zip(&k.cells).zip(&k.roles))
            .filter(|(_, role)| !regime_only(**role))
            .map(|((&v, &c), _)| cell_of(v, c))
            .chain([regime as i64])
            .collect()
    } else {
        (x.iter().zip(&k.cells))
            .map(|(&v, &c)| cell_of(v, c))
            .chain(u.map(|v| cell_of(v, k.command_cell)))
            .collect()
    };
    let key = (k.serial, point);
    if let Some(l) = LINEAR.with(|c| c.borrow_mut().get(&key)) {
        return l;
    }
    add_work(JACOBIAN_WORK);
    let mut j = d.jacobian(&at, &uq);
    for r in 0..n {
        for c in 0..n {
            j[r * n + c] *= k.scale[c] / k.scale[r];
        }
    }
    let l = Rc::new(Linear {
        j_columns: columns(&j, n),
        j,
        propagators: RefCell::new(Vec::new()),
    });
    LINEAR.with(|c| c.borrow_mut().insert(key, l.clone()));
    l
}

/// One integration: the dynamics, the commands held, what is known of them and the linear
/// part the steps take exactly.
struct Problem<'a> {
    d: &'a Dynamics,
    u: [f64; 2],
    known: &'a Known,
    linear: &'a Linear,
    n: usize,
    /// The PLC interval (s): the steps are its halvings.
    span: f64,
}

impl Problem<'_> {
    /// The nonlinear part N(y) = f(y) − J₀ y in typical sizes at the scaled state `y`.
    fn nonlinear(&self, y: &Vector, out: &mut Vector) {
        add_work(1);
        let (n, s) = (self.n, &self.known.scale);
        let mut x = [0.0; N_MAX];
        for i in 0..n {
            x[i] = y[i] * s[i];
        }
        self.d.rhs(&x[..n], &self.u, &mut out[..n]);
        for i in 0..n {
            out[i] /= s[i];
        }
        let mut jy = [0.0; N_MAX];
        mat_vec_add(&self.linear.j_columns, y, &mut jy, n);
        for i in 0..n {
            out[i] -= jy[i];
        }
    }
}

/// The matrices of one ETDRK4 step of length h with the linear part J₀ (scaled, column-major):
/// e^{hJ₀/2}, (h/2) φ₁(hJ₀/2), e^{hJ₀}, and the weights h(φ₁ − 3φ₂ + 4φ₃), 2h(φ₂ − 2φ₃),
/// h(4φ₃ − φ₂) of hJ₀.
struct Propagator {
    /// The six matrices one after the other, each column-major n × n.
    m: Vec<f64>,
    n: usize,
}

impl Propagator {
    fn matrix(&self, k: usize) -> &[f64] {
        let nn = self.n * self.n;
        &self.m[k * nn..(k + 1) * nn]
    }
    fn e_half(&self) -> &[f64] {
        self.matrix(0)
    }
    fn p_half(&self) -> &[f64] {
        self.matrix(1)
    }
    fn e(&self) -> &[f64] {
        self.matrix(2)
    }
    fn weight1(&self) -> &[f64] {
        self.matrix(3)
    }
    fn weight2(&self) -> &[f64] {
        self.matrix(4)
    }
    fn weight3(&self) -> &[f64] {
        self.matrix(5)
    }
}

/// Integrate the rig over [t0, t1] with the commands `u` held by ETDRK4 steps of the whole
/// interval, halved where a step misses the tolerance (at most [`MAX_HALVINGS`] times, at most
/// [`MAX_STEPS`] steps).
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
    let p = Problem {
        d,
        u,
        known: &known,
        linear: &linear,
        n,
        span,
    };
    let mut y = [0.0; N_MAX];
    for i in 0..n {
        y[i] = x[i] / known.scale[i];
    }
    // the interval in 2^level steps, `at` of them done
    let (mut level, mut at) = (0u32, 0u64);
    let mut reuse: Option<Vector> = None;
    for _ in 0..MAX_STEPS {
        if at == 1u64 << level {
            let out: Vec<f64> = (0..n).map(|i| y[i] * known.scale[i]).collect();
            finite(&out, t1)?;
            return Ok(out);
        }
        let h = span / (1u64 << level) as f64;
        let (next, error, mid) = doubled(&p, &y, level, reuse.take())?;
        let last = level == MAX_HALVINGS;
        if error <= TOLERANCE || (last && error <= BLOW_UP) {
            y = next;
            at += 1;
            if level > 0 && at % 2 == 0 {
                level -= 1;
                at /= 2;
            }
        } else if last {
            let t = t0 + span * at as f64 / (1u64 << level) as f64;
            return Err(EmulatorError(format!(
                "ODE solver: no step of {h:.3e} s or longer meets the tolerance at t = {t} s"
            )));
        } else {
            level += 1;
            at *= 2;
            // the first half of the step just refused is the next try's whole step
            reuse = Some(mid);
        }
    }
    Err(EmulatorError(format!(
        "ODE solver: more than {MAX_STEPS} steps between t = {t0} s and t = {t1} s"
    )))
}

/// Two ETDRK4 steps of h/2 from `y`, h the interval's `level`-th halving, and their error:
/// their difference from one step of h over 15 (Richardson, the method being of order 4), the
/// largest in typical sizes.
fn doubled(
    p: &Problem,
    y: &Vector,
    level: u32,
    whole: Option<Vector>,
) -> Result<(Vector, f64, Vector), EmulatorError> {
    let mut n0 = [0.0; N_MAX];
    p.nonlinear(y, &mut n0);
    let whole = match whole {
        Some(w) => w,
        None => etdrk4(p, &*propagator_for(p, level)?, y, &n0),
    };
    let half = propagator_for(p, level + 1)?;
    let mid = etdrk4(p, &half, y, &n0);
    let mut n_mid = [0.0; N_MAX];
    p.nonlinear(&mid, &mut n_mid);
    let end = etdrk4(p, &half, &mid, &n_mid);
    let error = (0..p.n)
        .map(|i| (end[i] - whole[i]).abs() / 15.0)
        .fold(0.0, f64::max);
    if !error.is_finite() {
        return Ok((end, f64::INFINITY, mid));
    }
    Ok((end, error, mid))
}

/// One step of Cox and Matthews' ETDRK4 from `y` (nonlinear part `n0` there) with the
/// propagator `q`.
fn etdrk4(p: &Problem, q: &Propagator, y: &Vector, n0: &Vector) -> Vector {
    let n = p.n;
    let mut ey = [0.0; N_MAX];
    mat_vec_add(q.e_half(), y, &mut ey, n);
    let mut a = ey;
    mat_vec_add(q.p_half(), n0, &mut a, n);
    let mut na = [0.0; N_MAX];
    p.nonlinear(&a, &mut na);
    let mut b = ey;
    mat_vec_add(q.p_half(), &na, &mut b, n);
    let mut nb = [0.0; N_MAX];
    p.nonlinear(&b, &mut nb);
    let mut c = [0.0; N_MAX];
    mat_vec_add(q.e_half(), &a, &mut c, n);
    let mut twice = [0.0; N_MAX];
    let mut sum = [0.0; N_MAX];
    for i in 0..n {
        twice[i] = 2.0 * nb[i] - n0[i];
        sum[i] = na[i] + nb[i];
    }
    mat_vec_add(q.p_half(), &twice, &mut c, n);
    let mut nc = [0.0; N_MAX];
    p.nonlinear(&c, &mut nc);
    let mut out = [0.0; N_MAX];
    mat_vec_add(q.e(), y, &mut out, n);
    mat_vec_add(q.weight1(), n0, &mut out, n);
    mat_vec_add(q.weight2(), &sum, &mut out, n);
    mat_vec_add(q.weight3(), &nc, &mut out, n);
    out
}

/// out += m · v (m column-major n × n): a sum of columns, which vectorises where a sum of
/// row products would not; unrolled for the circuits' orders.
fn mat_vec_add(m: &[f64], v: &Vector, out: &mut Vector, n: usize) {
    match n {
        7 => mat_vec_add_n::<7>(m, v, out),
        8 => mat_vec_add_n::<8>(m, v, out),
        9 => mat_vec_add_n::<9>(m, v, out),
        10 => mat_vec_add_n::<10>(m, v, out),
        _ => {
            for (column, &vk) in m.chunks_exact(n).zip(&v[..n]) {
                for (o, c) in out[..n].iter_mut().zip(column) {
                    *o += c * vk;
                }
            }
        }
    }
}

fn mat_vec_add_n<const N: usize>(m: &[f64], v: &Vector, out: &mut Vector) {
    let (m, _) = m.as_chunks::<N>();
    let mut acc = [0.0; N];
    acc.copy_from_slice(&out[..N]);
    for (column, &vk) in m[..N].iter().zip(&v[..N]) {
        for r in 0..N {
            acc[r] += column[r] * vk;
        }
    }
    out[..N].copy_from_slice(&acc);
}

/// The column-major copy of a row-major n × n matrix.
fn columns(m: &[f64], n: usize) -> Vec<f64> {
    (0..n * n).map(|i| m[(i % n) * n + i / n]).collect()
}

/// Halvings of the interval whose φ functions one pass of the scaling and squaring gives (the
/// doublings pass them all on the way): a block of halvings 0 ..= CHAIN, then CHAIN + 1 ..= 2 CHAIN + 1,
/// and so on. Most intervals take steps of the first four halvings, whose propagators the
/// first pass builds ([`EAGER`]), so a linear part needs one pass.
const CHAIN: u32 = 6;

/// Halvings of a block, after its first, whose propagators are built with the first's: most
/// intervals' steps are of the first four halvings.
const EAGER: u32 = 3;

/// The propagator of the problem's linear part for steps of the interval's `level`-th halving,
/// kept with it or built from the φ functions of its block of halvings, with those of the
/// block's first [`EAGER`] + 1 halvings. The φ functions are not kept (a linear part with them
/// took three times the memory, and the cache that many fewer linear parts): a longer halving
/// of the block asked for later computes them again. Which block a halving belongs to is
/// fixed, so the propagator is a function of the linear part, the interval and the level
/// alone.
fn propagator_for(p: &Problem, level: u32) -> Result<Rc<Propagator>, EmulatorError> {
    let key = (p.span.to_bits(), level);
    let kept = p.linear.propagators.borrow();
    if let Some((_, q)) = kept.iter().find(|(k, _)| *k == key) {
        return Ok(q.clone());
    }
    drop(kept);
    let first = level / (CHAIN + 1) * (CHAIN + 1);
    let h = p.span * 0.5f64.powi(first as i32);
    add_work(PHI_WORK);
    let phi = phi_levels(p.n, &p.linear.j, h, CHAIN as usize)?;
    let of_level = |l: u32| {
        let hl = p.span * 0.5f64.powi(l as i32);
        Rc::new(propagator(&phi, (l - first) as usize, hl))
    };
    let q = of_level(level);
    let mut kept = p.linear.propagators.borrow_mut();
    kept.push((key, q.clone()));
    // the block's first halvings too, which most intervals' steps are of, while its φ
    // functions are at hand: they are let go, a linear part keeps its propagators alone
    for l in first..=first + EAGER {
        if !kept.iter().any(|(k, _)| *k == (p.span.to_bits(), l)) {
            kept.push(((p.span.to_bits(), l), of_level(l)));
        }
    }
    Ok(q)
}

/// Taylor terms of φ₃ at ‖z‖₁ ≤ 1/2 (φ₂, φ₁, e^z then have one, two, three more): the first
/// left out is below 10⁻¹⁶ of them.
const TAYLOR_TERMS: usize = 14;

thread_local! {
    /// [`phi_levels`]' working matrices, kept between calls: a new linear part would otherwise
    /// allocate and zero them afresh.
    static PHI_SCRATCH: Cell<Vec<f64>> = const { Cell::new(Vec::new()) };
}

/// e^z, φ₁(z), φ₂(z), φ₃(z) of z = hJ/2ˡ for ℓ = 0 ..= `levels` + 1 (φ₀ = e^z,
/// φ_{k+1}(z) = (φ_k(z) − 1/k!)/z): J balanced by a diagonal similarity of powers of two
/// ([`balance`]), the Taylor series of φ₃(z/2ˢ) by Horner's rule and φ_k = z φ_{k+1} + 1/k!,
/// then s doublings φ_k(2z) = 2⁻ᵏ (e^z φ_k(z) + Σ_{j=1..k} φ_j(z)/(k−j)!) (Skaflestad and
/// Wright, Applied Numerical Mathematics 59, 2009), each doubling one level of step length.
fn phi_levels(n: usize, j: &[f64], h: f64, levels: usize) -> Result<Phis, EmulatorError> {
    if !j.iter().all(|v| v.is_finite()) {
        return Err(EmulatorError(
            "ODE solver: the Jacobian is not finite".to_string(),
        ));
    }
    // φ_k(D⁻¹ZD) = D⁻¹ φ_k(Z) D: balanced by powers of two, exactly, the norm that sets the
    // doublings drops from the typical sizes' scaling to near the spectral radius
    let nn = n * n;
    // one allocation: a, two Taylor terms, four products, φ₀..φ₃
    let mut work = PHI_SCRATCH.with(Cell::take);
    work.clear();
    work.resize(11 * nn, 0.0);
    let (a, rest) = work.split_at_mut(nn);
    let (mut t0, rest) = rest.split_at_mut(nn);
    let (mut t1, rest) = rest.split_at_mut(nn);
    let (products, phi) = rest.split_at_mut(4 * nn);
    a.copy_from_slice(j);
    let d = balance(a, n);
    let norm = (0..n)
        .map(|c| (0..n).map(|r| (h * a[r * n + c]).abs()).sum::<f64>())
        .fold(0.0, f64::max);
    // ‖hJ/2ˢ‖ ≤ 1/2, and s > `levels` so every level asked for is passed on the way
    let s = ((norm / 0.5).log2().ceil().max(0.0) as usize).max(levels + 1);
    let scale = h / 2f64.powi(s as i32);
    a.iter_mut().for_each(|v| *v *= scale);
    // φ₃(a) = Σ aᵐ/(m + 3)! by Horner, then φ_k = a φ_{k+1} + I/k!
    let add_diagonal = |m: &mut [f64], v: f64| (0..n).for_each(|i| m[i * n + i] += v);
    let factorial = |k: usize| (1..=k).map(|i| i as f64).product::<f64>();
    add_diagonal(t0, 1.0 / factorial(TAYLOR_TERMS + 3));
    for m in (0..TAYLOR_TERMS).rev() {
        mat_mul_into(a, t0, t1, n);
        add_diagonal(t1, 1.0 / factorial(m + 3));
        std::mem::swap(&mut t0, &mut t1);
    }
    phi[3 * nn..].copy_from_slice(t0);
    for k in (0..3).rev() {
        let (low, high) = phi.split_at_mut((k + 1) * nn);
        mat_mul_into(a, &high[..nn], &mut low[k * nn..], n);
        add_diagonal(&mut low[k * nn..], 1.0 / factorial(k));
    }
    let mut out = Vec::with_capacity((levels + 2) * 4 * nn);
    for step in 0..=s {
        if step + levels + 1 >= s {
            out.extend_from_slice(phi);
        }
        if step == s {
            break;
        }
        for k in 0..4 {
            // e·e, e·φ₁, e·φ₂, e·φ₃
            let (e, f) = (&phi[..nn], &phi[k * nn..(k + 1) * nn]);
            mat_mul_into(e, f, &mut products[k * nn..(k + 1) * nn], n);
        }
        let (e, f) = phi.split_at_mut(nn);
        let (f1, f) = f.split_at_mut(nn);
        let (f2, f3) = f.split_at_mut(nn);
        for i in 0..nn {
            let (g1, g2, g3) = (f1[i], f2[i], f3[i]);
            f1[i] = 0.5 * (products[nn + i] + g1);
            f2[i] = 0.25 * (products[2 * nn + i] + g1 + g2);
            f3[i] = 0.125 * (products[3 * nn + i] + 0.5 * g1 + g2 + g3);
        }
        e.copy_from_slice(&products[..nn]);
    }
    PHI_SCRATCH.with(|s| s.set(work));
    Ok(Phis { n, d, m: out })
}

/// e^z, φ₁(z), φ₂(z), φ₃(z) of z = hJ₀/2ˡ for the levels ℓ of a block, finest first, each
/// row-major n × n, of the balanced D⁻¹J₀D: entry (r, c) of J₀'s is d_r/d_c times it.
struct Phis {
    n: usize,
    d: Vec<f64>,
    m: Vec<f64>,
}

impl Phis {
    /// φ_k of level `l`, balanced.
    fn balanced(&self, l: usize, k: usize) -> &[f64] {
        let nn = self.n * self.n;
        let at = (4 * (self.m.len() / (4 * nn) - 1 - l) + k) * nn;
        &self.m[at..at + nn]
    }

    /// φ_k of level `l`, row-major: of J₀ itself.
    #[cfg(test)]
    fn of_j(&self, l: usize, k: usize) -> Vec<f64> {
        let n = self.n;
        let b = self.balanced(l, k);
        (0..n * n)
            .map(|i| b[i] * self.d[i / n] / self.d[i % n])
            .collect()
    }
}

/// Sweeps of [`balance`] at most.
const BALANCE_SWEEPS: usize = 16;

/// Balance the row-major n × n matrix `a` in place by a diagonal similarity of powers of two,
/// a ← D⁻¹ a D, so that each state's row and column have about the same norm (Parlett and
/// Reinsch, Numerische Mathematik 13, 1969, as LAPACK's gebal does it); returns D. Exact in
/// floating point: only exponents change. Not nalgebra's `balance_parlett_reinsch` (which
/// `lti::poles` uses on its analyses' matrices): that one iterates until converged with no
/// bound, and wants a `DMatrix` where this runs on the integrator's row-major slice once per
/// new linear part.
fn balance(a: &mut [f64], n: usize) -> Vec<f64> {
    let mut d = vec![1.0; n];
    for _ in 0..BALANCE_SWEEPS {
        let mut changed = false;
        for i in 0..n {
            let (mut c, mut r) = (0.0, 0.0);
            for k in (0..n).filter(|&k| k != i) {
                c += a[k * n + i].abs();
                r += a[i * n + k].abs();
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let (total, mut f) = (c + r, 1.0);
            // at most 64 factors of two each way: beyond, the scaling would not help
            for _ in 0..64 {
                if c >= r / 2.0 {
                    break;
                }
                c *= 2.0;
                r /= 2.0;
                f *= 2.0;
            }
            for _ in 0..64 {
                if c < r * 2.0 {
                    break;
                }
                c /= 2.0;
                r *= 2.0;
                f /= 2.0;
            }
            if c + r < 0.95 * total {
                changed = true;
                d[i] *= f;
                for k in 0..n {
                    a[i * n + k] /= f;
                    a[k * n + i] *= f;
                }
            }
        }
        if !changed {
            break;
        }
    }
    d
}

/// The ETDRK4 propagator of a step of `h` from the φ functions of hJ₀ (level `l` of `phis`) and
/// of hJ₀/2 (level `l + 1`), back from the balanced basis.
fn propagator(phis: &Phis, l: usize, h: f64) -> Propagator {
    let n = phis.n;
    let nn = n * n;
    let (f1, f2, f3) = (
        phis.balanced(l, 1),
        phis.balanced(l, 2),
        phis.balanced(l, 3),
    );
    let (e, e_half, p_half) = (
        phis.balanced(l, 0),
        phis.balanced(l + 1, 0),
        phis.balanced(l + 1, 1),
    );
    let mut m = vec![0.0; 6 * nn];
    for r in 0..n {
        for c in 0..n {
            // exact: a ratio of powers of two
            let back = phis.d[r] / phis.d[c];
            let (i, o) = (r * n + c, c * n + r);
            m[o] = e_half[i] * back;
            m[nn + o] = p_half[i] * (0.5 * h) * back;
            m[2 * nn + o] = e[i] * back;
            m[3 * nn + o] = h * (f1[i] - 3.0 * f2[i] + 4.0 * f3[i]) * back;
            m[4 * nn + o] = h * (2.0 * f2[i] - 4.0 * f3[i]) * back;
            m[5 * nn + o] = h * (-f2[i] + 4.0 * f3[i]) * back;
        }
    }
    Propagator { m, n }
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

/// out = a · b (row-major n × n), unrolled for the circuits' orders.
fn mat_mul_into(a: &[f64], b: &[f64], out: &mut [f64], n: usize) {
    match n {
        7 => mat_mul_n::<7>(a, b, out),
        8 => mat_mul_n::<8>(a, b, out),
        9 => mat_mul_n::<9>(a, b, out),
        10 => mat_mul_n::<10>(a, b, out),
        _ => mat_mul_any(a, b, out, n),
    }
}

fn mat_mul_n<const N: usize>(a: &[f64], b: &[f64], out: &mut [f64]) {
    let (a, _) = a.as_chunks::<N>();
    let (b, _) = b.as_chunks::<N>();
    let (out, _) = out.as_chunks_mut::<N>();
    for (a_row, out_row) in a[..N].iter().zip(&mut out[..N]) {
        let mut acc = [0.0; N];
        for (&aik, b_row) in a_row.iter().zip(&b[..N]) {
            for c in 0..N {
                acc[c] += aik * b_row[c];
            }
        }
        *out_row = acc;
    }
}

fn mat_mul_any(a: &[f64], b: &[f64], out: &mut [f64], n: usize) {
    out.fill(0.0);
    for (a_row, out_row) in a.chunks_exact(n).zip(out.chunks_exact_mut(n)) {
        for (&aik, b_row) in a_row.iter().zip(b.chunks_exact(n)) {
            for (o, &b) in out_row.iter_mut().zip(b_row) {
                *o += aik * b;
            }
        }
    }
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
    fn the_phi_functions_of_a_diagonal_matrix_are_the_scalar_ones() {
        // φ₀ = eᶻ, φ₁ = (eᶻ − 1)/z, φ₂ = (eᶻ − 1 − z)/z², φ₃ = (eᶻ − 1 − z − z²/2)/z³
        let z = [-1257.0 * 0.01, -3.0, -0.2, 0.7];
        let n = z.len();
        let mut j = vec![0.0; n * n];
        for i in 0..n {
            j[i * n + i] = z[i];
        }
        let phis = phi_levels(n, &j, 1.0, 2).unwrap();
        assert_eq!(phis.m.len(), 4 * 4 * n * n);
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
        let mut y = [0.0; N_MAX];
        y[0] = 1.0;
        y[1] = -2.0;
        let mut c = [0.0; N_MAX];
        c[0] = 3.0;
        c[1] = 0.5;
        // four stages of a constant N (the second weight takes two of them): the weights must
        // add up to h φ₁
        let mut via = [0.0; N_MAX];
        mat_vec_add(q.e(), &y, &mut via, n);
        for w in [q.weight1(), q.weight2(), q.weight2(), q.weight3()] {
            mat_vec_add(w, &c, &mut via, n);
        }
        let mut want = [0.0; N_MAX];
        mat_vec_add(&columns(&e, n), &y, &mut want, n);
        let p1: Vec<f64> = phi1.iter().map(|v| v * h).collect();
        mat_vec_add(&columns(&p1, n), &c, &mut want, n);
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
