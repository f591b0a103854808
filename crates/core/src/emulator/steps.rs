//! The exponential integrator's steps over one PLC interval (docs/emulator.md#the-integration):
//! Cox and Matthews' ETDRK4 (J. Comput. Phys. 176, 2002) on ẏ = J₀ y + N(y) in typical sizes,
//! each step checked by step doubling and halved where it misses the tolerance.
//!
//! The steps are compiled for each order of state (the circuits have 6 to 10), so the states
//! and the products with the propagators' matrices stay in registers, and with AVX2 where the
//! processor has it. Every product is the same sum, term by term in the same order, as a plain
//! loop's: no fused multiply-add, so the results are the same bit for bit on any processor.

use super::phi::Propagator;
use super::{Dynamics, EmulatorError};
use std::rc::Rc;

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

/// One PLC interval to integrate: the dynamics and the commands held, the states' typical
/// sizes, the linear part J₀ (scaled, column-major), the propagators of its halvings, and the
/// interval.
pub(super) struct Interval<'a> {
    pub(super) d: &'a Dynamics,
    pub(super) u: [f64; 2],
    pub(super) scale: &'a [f64],
    pub(super) j_columns: &'a [f64],
    /// The ETDRK4 propagator of a step of the interval's `level`-th halving.
    pub(super) propagator: &'a dyn Fn(u32) -> Result<Rc<Propagator>, EmulatorError>,
    /// Counts the work of `n` evaluations of the rig's equations
    /// (docs/emulator.md#the-work-limit).
    pub(super) work: fn(u64),
    pub(super) t0: f64,
    pub(super) t1: f64,
}

/// Integrate `p` from the state `x` (SI) by ETDRK4 steps of the whole interval, halved where a
/// step misses the tolerance (at most [`MAX_HALVINGS`] times, at most [`MAX_STEPS`] steps).
pub(super) fn integrate(p: &Interval, x: &[f64]) -> Result<Vec<f64>, EmulatorError> {
    if x.len() != p.scale.len() {
        return Err(EmulatorError(format!(
            "{} states for a rig of {}",
            x.len(),
            p.scale.len()
        )));
    }
    macro_rules! orders {
        (fast: $($f:literal),*; plain: $($n:literal),*) => {
            match x.len() {
                $($f => dispatch::<$f>(p, x),)*
                $($n => run::<$n>(p, x),)*
                n => Err(EmulatorError(format!("no steps for {n} states"))),
            }
        };
    }
    orders!(fast: 6, 7, 8, 9, 10; plain: 1, 2, 3, 4, 5, 11, 12, 13, 14, 15, 16)
}

/// [`run`] with AVX2 where the running processor has it.
fn dispatch<const N: usize>(p: &Interval, x: &[f64]) -> Result<Vec<f64>, EmulatorError> {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor reports AVX2, the feature `run_avx2` is compiled for.
        return unsafe { run_avx2::<N>(p, x) };
    }
    run::<N>(p, x)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn run_avx2<const N: usize>(p: &Interval, x: &[f64]) -> Result<Vec<f64>, EmulatorError> {
    run::<N>(p, x)
}

/// The steps for a compile-time order N.
#[inline(always)]
fn run<const N: usize>(p: &Interval, x: &[f64]) -> Result<Vec<f64>, EmulatorError> {
    let mut y = [0.0; N];
    for i in 0..N {
        y[i] = x[i] / p.scale[i];
    }
    // the interval in 2^level steps, `at` of them done
    let (mut level, mut at) = (0u32, 0u64);
    // after a refusal: the first half of the refused step and the nonlinear part at its start
    let mut reuse: Option<([f64; N], [f64; N])> = None;
    for _ in 0..MAX_STEPS {
        if at == 1u64 << level {
            return Ok((0..N).map(|i| y[i] * p.scale[i]).collect());
        }
        let span = p.t1 - p.t0;
        let h = span / (1u64 << level) as f64;
        let (next, error, mid, n0) = doubled(p, &y, level, reuse.take())?;
        let last = level == MAX_HALVINGS;
        if error <= TOLERANCE || (last && error <= BLOW_UP) {
            y = next;
            at += 1;
            if level > 0 && at % 2 == 0 {
                level -= 1;
                at /= 2;
            }
        } else if last {
            let t = p.t0 + span * at as f64 / (1u64 << level) as f64;
            return Err(EmulatorError(format!(
                "ODE solver: no step of {h:.3e} s or longer meets the tolerance at t = {t} s"
            )));
        } else {
            level += 1;
            at *= 2;
            // the first half of the step just refused is the next try's whole step, from
            // the same state
            reuse = Some((mid, n0));
        }
    }
    Err(EmulatorError(format!(
        "ODE solver: more than {MAX_STEPS} steps between t = {} s and t = {} s",
        p.t0, p.t1
    )))
}

/// Two ETDRK4 steps of h/2 from `y`, h the interval's `level`-th halving, and their error:
/// their difference from one step of h over 15 (Richardson, the method being of order 4), the
/// largest in typical sizes; with the first half step and the nonlinear part at `y`. `whole`:
/// the step of h and the nonlinear part at `y`, where known.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn doubled<const N: usize>(
    p: &Interval,
    y: &[f64; N],
    level: u32,
    whole: Option<([f64; N], [f64; N])>,
) -> Result<([f64; N], f64, [f64; N], [f64; N]), EmulatorError> {
    let (whole, n0) = match whole {
        Some(known) => known,
        None => {
            let n0 = nonlinear(p, y);
            (etdrk4(p, &*(p.propagator)(level)?, y, &n0), n0)
        }
    };
    let half = (p.propagator)(level + 1)?;
    let mid = etdrk4(p, &half, y, &n0);
    let n_mid = nonlinear(p, &mid);
    let end = etdrk4(p, &half, &mid, &n_mid);
    let error = (0..N)
        .map(|i| (end[i] - whole[i]).abs() / 15.0)
        .fold(0.0, f64::max);
    if !error.is_finite() {
        return Ok((end, f64::INFINITY, mid, n0));
    }
    Ok((end, error, mid, n0))
}

/// The nonlinear part N(y) = f(y) − J₀ y in typical sizes at the scaled state `y`.
#[inline(always)]
fn nonlinear<const N: usize>(p: &Interval, y: &[f64; N]) -> [f64; N] {
    (p.work)(1);
    let mut x = [0.0; N];
    for ((x, y), s) in x.iter_mut().zip(y).zip(p.scale) {
        *x = y * s;
    }
    let mut out = [0.0; N];
    p.d.rhs(&x, &p.u, &mut out);
    let mut jy = [0.0; N];
    mat_vec_add(p.j_columns, &[y], &mut jy);
    for ((out, s), jy) in out.iter_mut().zip(p.scale).zip(jy) {
        *out = *out / s - jy;
    }
    out
}

/// One step of Cox and Matthews' ETDRK4 from `y` (nonlinear part `n0` there) with the
/// propagator `q`.
#[inline(always)]
fn etdrk4<const N: usize>(p: &Interval, q: &Propagator, y: &[f64; N], n0: &[f64; N]) -> [f64; N] {
    let nn = N * N;
    let (e_half, p_half) = (&q.m[..nn], &q.m[nn..2 * nn]);
    let mut ey = [0.0; N];
    mat_vec_add(e_half, &[y], &mut ey);
    let mut a = ey;
    mat_vec_add(p_half, &[n0], &mut a);
    let na = nonlinear(p, &a);
    let mut b = ey;
    mat_vec_add(p_half, &[&na], &mut b);
    let nb = nonlinear(p, &b);
    let (mut twice, mut sum) = ([0.0; N], [0.0; N]);
    for i in 0..N {
        twice[i] = 2.0 * nb[i] - n0[i];
        sum[i] = na[i] + nb[i];
    }
    // e^{hJ₀/2} a + (h/2) φ₁(hJ₀/2) (2 N(b) − N(y)): the two matrices side by side
    let mut c = [0.0; N];
    mat_vec_add(&q.m[..2 * nn], &[&a, &twice], &mut c);
    let nc = nonlinear(p, &c);
    // e^{hJ₀} y and the three weights, side by side
    let mut out = [0.0; N];
    mat_vec_add(&q.m[2 * nn..6 * nn], &[y, n0, &sum, &nc], &mut out);
    out
}

/// out += [m₁ m₂ …] [v₁; v₂; …], the m_k column-major N × N one after the other in `m`: a sum
/// of columns in order, which vectorises where a sum of row products would not.
#[inline(always)]
fn mat_vec_add<const N: usize>(m: &[f64], v: &[&[f64; N]], out: &mut [f64; N]) {
    let mut acc = *out;
    for (block, v) in m.chunks_exact(N * N).zip(v) {
        for (column, &vk) in block.chunks_exact(N).zip(v.iter()) {
            for r in 0..N {
                acc[r] += column[r] * vk;
            }
        }
    }
    *out = acc;
}
