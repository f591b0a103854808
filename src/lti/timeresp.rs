//! Exact time responses of an LTI model under a zero-order-hold input (SPEC §5).
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
        let scale = balance_parlett_reinsch(&mut block);
        let e = block.exp();
        // unbalance: exp(D⁻¹ M D) = D⁻¹ exp(M) D
        let e = DMatrix::from_fn(n + m, n + m, |i, j| e[(i, j)] * scale[i] / scale[j]);
        Ok(Zoh {
            h,
            phi: e.view((0, 0), (n, n)).into_owned(),
            gamma: e.view((0, n), (n, m)).into_owned(),
        })
    }
}

/// A simulated response: states and outputs at every sample time.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    /// Sample times (s).
    pub t: Vec<f64>,
    /// States, row-major: `states[k * n + i]` is state i at sample k.
    pub states: Vec<f64>,
    /// Outputs, row-major: `outputs[k * p + i]` is output i at sample k.
    pub outputs: Vec<f64>,
    /// Number of states.
    pub n: usize,
    /// Number of outputs.
    pub p: usize,
}

impl Response {
    /// Output `i` over time.
    pub fn output(&self, i: usize) -> Vec<f64> {
        self.outputs
            .iter()
            .skip(i)
            .step_by(self.p)
            .copied()
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
}

/// Row-major Φ and Γ of one step for a tight inner loop.
#[derive(Debug, Clone)]
struct Stepper {
    h: f64,
    phi: Vec<f64>,
    gamma: Vec<f64>,
}

impl<'a> Simulator<'a> {
    /// A simulator for `sys`.
    pub fn new(sys: &'a StateSpace) -> Self {
        Simulator {
            sys,
            cache: Vec::new(),
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
        let z = Zoh::new(&self.sys.a, &self.sys.b, h)?;
        let row_major = |m: &DMatrix<f64>| -> Vec<f64> { m.transpose().iter().copied().collect() };
        self.cache.push(Stepper {
            h,
            phi: row_major(&z.phi),
            gamma: row_major(&z.gamma),
        });
        Ok(self.cache.len() - 1)
    }

    /// Simulate from state `x0` with input samples `u` (row-major, m per sample) held from
    /// each sample time to the next. `t` must be strictly increasing.
    pub fn run(&mut self, t: &[f64], u: &[f64], x0: &[f64]) -> Result<Response, LtiError> {
        let (n, m, p) = (self.sys.order(), self.sys.b.ncols(), self.sys.c.nrows());
        if u.len() != t.len() * m || x0.len() != n {
            return Err(LtiError::Dimension(format!(
                "simulation needs {} input values and {n} initial states, got {} and {}",
                t.len() * m,
                u.len(),
                x0.len()
            )));
        }
        let mut states = Vec::with_capacity(t.len() * n);
        states.extend_from_slice(x0);
        let mut x = x0.to_vec();
        for k in 1..t.len() {
            let s = self.stepper(t[k] - t[k - 1])?;
            let step = &self.cache[s];
            let uk = &u[(k - 1) * m..k * m];
            for i in 0..n {
                let free: f64 = step.phi[i * n..(i + 1) * n]
                    .iter()
                    .zip(&x)
                    .map(|(a, b)| a * b)
                    .sum();
                let forced: f64 = step.gamma[i * m..(i + 1) * m]
                    .iter()
                    .zip(uk)
                    .map(|(a, b)| a * b)
                    .sum();
                states.push(free + forced);
            }
            x.copy_from_slice(&states[k * n..]);
        }
        let outputs = self.outputs(&states, u, t.len());
        Ok(Response {
            t: t.to_vec(),
            states,
            outputs,
            n,
            p,
        })
    }

    /// y = C x + D u at every sample.
    fn outputs(&self, states: &[f64], u: &[f64], len: usize) -> Vec<f64> {
        let (n, m, p) = (self.sys.order(), self.sys.b.ncols(), self.sys.c.nrows());
        let mut out = Vec::with_capacity(len * p);
        for k in 0..len {
            let x = &states[k * n..(k + 1) * n];
            let uk = &u[k * m..(k + 1) * m];
            for i in 0..p {
                let cx: f64 = (0..n).map(|j| self.sys.c[(i, j)] * x[j]).sum();
                let du: f64 = (0..m).map(|j| self.sys.d[(i, j)] * uk[j]).sum();
                out.push(cx + du);
            }
        }
        out
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
                rel(r.outputs[k], want) < 1e-12,
                "t={tk}: {} vs {want}",
                r.outputs[k]
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
            assert!((r.outputs[k] - tk).abs() < 1e-14);
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
    fn bad_step_is_an_error() {
        let a = DMatrix::from_row_slice(1, 1, &[-1.0]);
        let b = DMatrix::from_row_slice(1, 1, &[1.0]);
        assert!(Zoh::new(&a, &b, 0.0).is_err());
        assert!(Zoh::new(&a, &b, f64::NAN).is_err());
    }
}
