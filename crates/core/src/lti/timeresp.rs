//! Exact time responses of an LTI model under a zero-order-hold input (the article §2.3.3; docs/simulation.md#exact-zero-order-hold).
//!
//! For a step h the input is held constant, so x(t+h) = Φ x(t) + Γ u(t) exactly, with
//! Φ = e^{Ah} and Γ = ∫₀ʰ e^{As} ds B, both read off one exponential of the block matrix
//! [[A, B], [0, 0]]·h — never Γ = A⁻¹(Φ − I)B, since A is singular (the position integrator).
//! The block matrix is balanced before `exp` (DEPENDENCIES.md: 8e-10 → 4e-14 relative error on
//! the rig). Discretisations are cached per distinct step, so non-uniform sample times work.

use super::{LtiError, StateSpace};
use nalgebra::linalg::balancing::balance_parlett_reinsch;
use nalgebra::DMatrix;

/// Steps within this relative distance share one discretisation (sample clocks written as
/// decimal text differ in the last bits).
const SAME_STEP_RELATIVE: f64 = 1e-9;

/// The zero-order-hold discretisation of ẋ = A x + B u over a step `h` (s).
#[derive(Debug, Clone, PartialEq)]
pub struct Zoh {
    /// Step (s).
    pub h: f64,
    /// Φ = e^{Ah}, n × n.
    pub phi: DMatrix<f64>,
    /// Γ = ∫₀ʰ e^{As} ds B, n × m.
    pub gamma: DMatrix<f64>,
}

impl Zoh {
    /// Discretise (A, B) over the step `h` > 0.
    pub fn new(a: &DMatrix<f64>, b: &DMatrix<f64>, h: f64) -> Result<Zoh, LtiError> {
        Self::with_scale(a, b, h, None)
    }

    /// Discretise with a given balancing scale of the block matrix (length n + m), as returned
    /// by [`Zoh::balancing_scale`] for a similar model, instead of balancing again: any diagonal
    /// scaling is exact, balancing only guards accuracy, and a grid search over similar models
    /// can balance once. `None` balances this model.
    pub fn with_scale(
        a: &DMatrix<f64>,
        b: &DMatrix<f64>,
        h: f64,
        scale: Option<&[f64]>,
    ) -> Result<Zoh, LtiError> {
        let (n, m) = (a.nrows(), b.ncols());
        let block = block_matrix(a, b, h)?;
        if scale.is_some_and(|d| d.len() != n + m || d.iter().any(|v| !(v.is_finite() && *v > 0.0)))
        {
            return Err(LtiError::Dimension(format!(
                "balancing scale must hold {} positive values",
                n + m
            )));
        }
        // stack matrices are about twice as fast for the rig's sizes (6, 8, 10 states + 1 input)
        macro_rules! fixed {
            ($k:literal) => {
                balanced_exp(
                    nalgebra::SMatrix::<f64, $k, $k>::from_fn(|i, j| block[(i, j)]),
                    scale,
                )
            };
        }
        let e = match n + m {
            7 => fixed!(7),
            9 => fixed!(9),
            11 => fixed!(11),
            _ => balanced_exp(block, scale),
        };
        Ok(Zoh {
            h,
            phi: e.view((0, 0), (n, n)).into_owned(),
            gamma: e.view((0, n), (n, m)).into_owned(),
        })
    }

    /// The Parlett–Reinsch balancing scale of the block matrix [[A, B], [0, 0]]·h.
    pub fn balancing_scale(
        a: &DMatrix<f64>,
        b: &DMatrix<f64>,
        h: f64,
    ) -> Result<Vec<f64>, LtiError> {
        let mut block = block_matrix(a, b, h)?;
        Ok(balance_parlett_reinsch(&mut block)
            .iter()
            .copied()
            .collect())
    }
}

/// [[A, B], [0, 0]]·h, checked: h > 0 and every entry finite (`exp` panics otherwise).
fn block_matrix(a: &DMatrix<f64>, b: &DMatrix<f64>, h: f64) -> Result<DMatrix<f64>, LtiError> {
    if !(h.is_finite() && h > 0.0) {
        return Err(LtiError::Dimension(format!(
            "time step must be finite and > 0, got {h}"
        )));
    }
    let (n, m) = (a.nrows(), b.ncols());
    let mut block = DMatrix::zeros(n + m, n + m);
    block.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    block.view_mut((0, n), (n, m)).copy_from(&(b * h));
    if let Some(k) = block.iter().position(|v| !v.is_finite()) {
        return Err(LtiError::NonFinite {
            matrix: "A or B",
            row: k % (n + m) + 1,
            col: k / (n + m) + 1,
        });
    }
    Ok(block)
}

/// exp(M) through a diagonal similarity: exp(D⁻¹ M D) = D⁻¹ exp(M) D, with D the given scale or
/// M's Parlett–Reinsch balancing.
fn balanced_exp<D>(mut m: nalgebra::OMatrix<f64, D, D>, scale: Option<&[f64]>) -> DMatrix<f64>
where
    D: nalgebra::DimMin<D, Output = D>,
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D, D>
        + nalgebra::allocator::Allocator<D>
        + nalgebra::allocator::Allocator<nalgebra::DimMinimum<D, D>>,
{
    let k = m.nrows();
    let d: Vec<f64> = match scale {
        Some(d) => {
            for j in 0..k {
                for i in 0..k {
                    m[(i, j)] *= d[j] / d[i];
                }
            }
            d.to_vec()
        }
        None => balance_parlett_reinsch(&mut m).iter().copied().collect(),
    };
    let e = m.exp();
    DMatrix::from_fn(k, k, |i, j| e[(i, j)] * d[i] / d[j])
}

/// A simulated response: the states at every sample time; outputs y = C x + D u are formed on
/// demand.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    /// Sample times (s).
    pub t: Vec<f64>,
    /// States, row-major: `states[k * n + i]` is state i at sample k.
    pub states: Vec<f64>,
    /// Number of states.
    pub n: usize,
    /// The inputs, row-major (m per sample).
    inputs: Vec<f64>,
    /// Non-zero entries of each row of C.
    c_rows: Vec<Vec<(usize, f64)>>,
    /// Non-zero entries of each row of D.
    d_rows: Vec<Vec<(usize, f64)>>,
}

impl Response {
    /// Number of outputs.
    pub fn outputs(&self) -> usize {
        self.c_rows.len()
    }

    /// Output `i` over time: C_i x + D_i u.
    pub fn output(&self, i: usize) -> Vec<f64> {
        let m = self.inputs.len() / self.t.len().max(1);
        self.states
            .chunks_exact(self.n)
            .zip(self.inputs.chunks_exact(m.max(1)))
            .map(|(x, u)| {
                let cx: f64 = self.c_rows[i].iter().map(|&(j, v)| v * x[j]).sum();
                let du: f64 = self.d_rows[i].iter().map(|&(j, v)| v * u[j]).sum();
                cx + du
            })
            .collect()
    }

    /// State `i` over time.
    pub fn state(&self, i: usize) -> Vec<f64> {
        self.states
            .iter()
            .skip(i)
            .step_by(self.n)
            .copied()
            .collect()
    }
}

/// A stepper for one model: caches the discretisation per distinct step.
#[derive(Debug, Clone)]
pub struct Simulator<'a> {
    sys: &'a StateSpace,
    cache: Vec<Stepper>,
    scale: Option<&'a [f64]>,
}

/// Column-major Φ and Γ of one step for a tight inner loop.
#[derive(Debug, Clone)]
struct Stepper {
    h: f64,
    phi: Vec<f64>,
    gamma: Vec<f64>,
}

/// One step next = Φ x + Γ u with column-major Φ (n × n) and Γ (n × m).
type StepFn = fn(phi: &[f64], gamma: &[f64], x: &[f64], u: &[f64], next: &mut [f64]);

/// The step for order `n`: monomorphised for the rig's orders (6, 8, 10) so the accumulators
/// stay in registers, and compiled for AVX2 + FMA when the processor has them (checked at run
/// time); generic otherwise.
fn step_fn(n: usize) -> StepFn {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        match n {
            6 => return avx::step::<6>,
            8 => return avx::step::<8>,
            10 => return avx::step::<10>,
            _ => {}
        }
    }
    match n {
        6 => step_fixed::<6>,
        8 => step_fixed::<8>,
        10 => step_fixed::<10>,
        _ => step_any,
    }
}

/// The fixed-order step compiled with AVX2 and FMA enabled.
#[cfg(target_arch = "x86_64")]
mod avx {
    /// Safe entry point; only handed out by `step_fn` after run-time detection.
    pub fn step<const N: usize>(
        phi: &[f64],
        gamma: &[f64],
        x: &[f64],
        u: &[f64],
        next: &mut [f64],
    ) {
        // SAFETY: `step_fn` returns this function only when the running processor reports
        // AVX2 and FMA, the features `step_avx` is compiled for.
        unsafe { step_avx::<N>(phi, gamma, x, u, next) }
    }

    #[target_feature(enable = "avx2,fma")]
    unsafe fn step_avx<const N: usize>(
        phi: &[f64],
        gamma: &[f64],
        x: &[f64],
        u: &[f64],
        next: &mut [f64],
    ) {
        super::step_fixed::<N>(phi, gamma, x, u, next)
    }
}

/// Φ x + Γ u for a compile-time order N, column by column (independent rows, no serial sum).
#[inline(always)]
fn step_fixed<const N: usize>(phi: &[f64], gamma: &[f64], x: &[f64], u: &[f64], next: &mut [f64]) {
    let mut acc = [0.0; N];
    for (col, &xj) in phi.chunks_exact(N).zip(x) {
        for i in 0..N {
            acc[i] += col[i] * xj;
        }
    }
    for (col, &uj) in gamma.chunks_exact(N).zip(u) {
        for i in 0..N {
            acc[i] += col[i] * uj;
        }
    }
    next.copy_from_slice(&acc);
}

/// Φ x + Γ u for any order.
fn step_any(phi: &[f64], gamma: &[f64], x: &[f64], u: &[f64], next: &mut [f64]) {
    let n = x.len();
    next.fill(0.0);
    for (col, &xj) in phi
        .chunks_exact(n)
        .zip(x)
        .chain(gamma.chunks_exact(n).zip(u))
    {
        for (acc, &a) in next.iter_mut().zip(col) {
            *acc += a * xj;
        }
    }
}

/// The non-zero entries of each row of a matrix, for outputs that mostly pick states.
fn sparse_rows(m: &DMatrix<f64>) -> Vec<Vec<(usize, f64)>> {
    m.row_iter()
        .map(|r| {
            r.iter()
                .enumerate()
                .filter(|(_, v)| **v != 0.0)
                .map(|(j, v)| (j, *v))
                .collect()
        })
        .collect()
}

impl<'a> Simulator<'a> {
    /// A simulator for `sys`.
    pub fn new(sys: &'a StateSpace) -> Self {
        Simulator {
            sys,
            cache: Vec::new(),
            scale: None,
        }
    }

    /// A simulator that discretises with a fixed balancing scale (see [`Zoh::with_scale`]).
    pub fn with_scale(sys: &'a StateSpace, scale: &'a [f64]) -> Self {
        Simulator {
            sys,
            cache: Vec::new(),
            scale: Some(scale),
        }
    }

    /// The cached stepper for step `h`, discretising on first use.
    fn stepper(&mut self, h: f64) -> Result<usize, LtiError> {
        if let Some(i) = self
            .cache
            .iter()
            .position(|s| (s.h - h).abs() <= SAME_STEP_RELATIVE * s.h)
        {
            return Ok(i);
        }
        let z = Zoh::with_scale(&self.sys.a, &self.sys.b, h, self.scale)?;
        self.cache.push(Stepper {
            h,
            phi: z.phi.as_slice().to_vec(),
            gamma: z.gamma.as_slice().to_vec(),
        });
        Ok(self.cache.len() - 1)
    }

    /// Simulate from state `x0` with input samples `u` (row-major, m per sample) held from each
    /// sample time to the next, handing each state x(t_k) to `visit(k, x)` without storing
    /// anything: the zero-allocation path of a grid search. Stops early when `visit` returns
    /// `false`.
    pub fn run_with(
        &mut self,
        t: &[f64],
        u: &[f64],
        x0: &[f64],
        mut visit: impl FnMut(usize, &[f64]) -> bool,
    ) -> Result<(), LtiError> {
        let (n, m) = (self.sys.order(), self.sys.b.ncols());
        if u.len() != t.len() * m || x0.len() != n {
            return Err(LtiError::Dimension(format!(
                "simulation needs {} input values and {n} initial states, got {} and {}",
                t.len() * m,
                u.len(),
                x0.len()
            )));
        }
        let (mut x, mut next) = (x0.to_vec(), vec![0.0; n]);
        if t.is_empty() || !visit(0, &x) {
            return Ok(());
        }
        let step = step_fn(n);
        let mut current: Option<usize> = None;
        for k in 1..t.len() {
            let h = t[k] - t[k - 1];
            let s = match current {
                Some(i) if (self.cache[i].h - h).abs() <= SAME_STEP_RELATIVE * self.cache[i].h => i,
                _ => self.stepper(h)?,
            };
            current = Some(s);
            let st = &self.cache[s];
            step(&st.phi, &st.gamma, &x, &u[(k - 1) * m..k * m], &mut next);
            std::mem::swap(&mut x, &mut next);
            if !visit(k, &x) {
                break;
            }
        }
        Ok(())
    }

    /// Simulate from state `x0` with input samples `u` (row-major, m per sample) held from
    /// each sample time to the next. `t` must be strictly increasing.
    pub fn run(&mut self, t: &[f64], u: &[f64], x0: &[f64]) -> Result<Response, LtiError> {
        let n = self.sys.order();
        let mut states = Vec::with_capacity(t.len() * n);
        self.run_with(t, u, x0, |_, x| {
            states.extend_from_slice(x);
            true
        })?;
        Ok(Response {
            t: t.to_vec(),
            states,
            n,
            inputs: u.to_vec(),
            c_rows: sparse_rows(&self.sys.c),
            d_rows: sparse_rows(&self.sys.d),
        })
    }
}

/// Steady-state output for a constant input `u` (the DC solution A x = −B u), or `None` when A is
/// singular (an uncontrolled integrator).
pub fn dc_output(sys: &StateSpace, u: &[f64]) -> Option<Vec<f64>> {
    let u = nalgebra::DVector::from_column_slice(u);
    let x = sys.a.clone().lu().solve(&(-(&sys.b * &u)))?;
    let y = &sys.c * x + &sys.d * u;
    Some(y.iter().copied().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn siso(a: &[f64], b: &[f64], c: &[f64]) -> StateSpace {
        let n = b.len();
        StateSpace::new(
            DMatrix::from_row_slice(n, n, a),
            DMatrix::from_row_slice(n, 1, b),
            DMatrix::from_row_slice(1, n, c),
            DMatrix::zeros(1, 1),
        )
        .unwrap()
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    #[test]
    fn first_order_step_and_ramp_of_zoh_input() {
        // ẋ = −x/τ + u/τ, y = x: step response 1 − e^{−t/τ}, exact at the samples
        let tau = 0.37;
        let sys = siso(&[-1.0 / tau], &[1.0 / tau], &[1.0]);
        let t: Vec<f64> = (0..200).map(|k| k as f64 * 0.01).collect();
        let r = Simulator::new(&sys)
            .run(&t, &vec![1.0; t.len()], &[0.0])
            .unwrap();
        for (k, &tk) in t.iter().enumerate().skip(1) {
            let want = 1.0 - (-tk / tau).exp();
            assert!(
                rel(r.output(0)[k], want) < 1e-12,
                "t={tk}: {} vs {want}",
                r.output(0)[k]
            );
        }
    }

    #[test]
    fn integrator_uses_the_block_exponential() {
        // ẋ = u (A singular): x(t) = t for a unit step
        let sys = siso(&[0.0], &[1.0], &[1.0]);
        let t = [0.0, 0.1, 0.35, 0.36, 1.0];
        let r = Simulator::new(&sys).run(&t, &[1.0; 5], &[0.0]).unwrap();
        for (k, &tk) in t.iter().enumerate() {
            assert!((r.output(0)[k] - tk).abs() < 1e-14);
        }
    }

    #[test]
    fn steps_compose() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -25.0, -0.4]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let z1 = Zoh::new(&a, &b, 0.013).unwrap();
        let z2 = Zoh::new(&a, &b, 0.029).unwrap();
        let z12 = Zoh::new(&a, &b, 0.042).unwrap();
        let phi = &z2.phi * &z1.phi;
        let gamma = &z2.phi * &z1.gamma + &z2.gamma;
        assert!((phi - z12.phi).norm() < 1e-14);
        assert!((gamma - z12.gamma).norm() < 1e-15);
    }

    #[test]
    fn every_step_kernel_agrees() {
        for n in [6usize, 8, 10] {
            let phi: Vec<f64> = (0..n * n)
                .map(|k| ((k * 37 % 101) as f64 - 50.0) / 7.0)
                .collect();
            let gamma: Vec<f64> = (0..n).map(|k| k as f64 * 0.3 - 1.0).collect();
            let x: Vec<f64> = (0..n).map(|k| (k as f64).sin()).collect();
            let mut want = vec![0.0; n];
            step_any(&phi, &gamma, &x, &[2.5], &mut want);
            let mut got = vec![0.0; n];
            step_fn(n)(&phi, &gamma, &x, &[2.5], &mut got);
            for i in 0..n {
                let direct: f64 =
                    (0..n).map(|j| phi[j * n + i] * x[j]).sum::<f64>() + gamma[i] * 2.5;
                assert!((want[i] - direct).abs() < 1e-12 * direct.abs().max(1.0));
                assert!((got[i] - direct).abs() < 1e-12 * direct.abs().max(1.0));
            }
        }
    }

    #[test]
    fn bad_step_is_an_error() {
        let a = DMatrix::from_row_slice(1, 1, &[-1.0]);
        let b = DMatrix::from_row_slice(1, 1, &[1.0]);
        assert!(Zoh::new(&a, &b, 0.0).is_err());
        assert!(Zoh::new(&a, &b, f64::NAN).is_err());
    }
}
