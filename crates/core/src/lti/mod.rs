//! Generic continuous-time linear time-invariant state-space models: `ẋ = A x + B u`,
//! `y = C x + D u`, and the analyses of docs/analysis.md#margins on them — poles, frequency response (Bode) and
//! stability margins — computed on the state-space form, never through transfer-function
//! polynomials (see DEPENDENCIES.md for the numerical pitfalls this module avoids).

mod disk;
mod freqresp;
mod io;
mod margins;
mod poles;
mod roots;
mod sampled;
mod timeresp;

pub use disk::{disk_margins, sampled_disk_margins, DiskMargin, DiskMargins, Peak};
pub use freqresp::{bode, log_grid, unwrap_from, Bode, FreqEvaluator};
pub use io::{ModelJson, StateInfo, MAX_STATES};
pub use margins::{margins, Crossing, CrossingKind, Margins, RELIABLE_DB, RELIABLE_DEG};
pub use poles::{
    check_magnitudes, eigenvalues, poles_and_stability, resonance, stability, PoleInfo, Stability,
};
pub use sampled::{sampled_margins, SampledLoop, MAX_DELAY_SAMPLES};
pub use timeresp::{dc_output, Response, Simulator, Zoh};

use nalgebra::DMatrix;

/// Errors of the LTI analyses.
#[derive(Debug, thiserror::Error)]
pub enum LtiError {
    /// Matrix sizes that do not fit together.
    #[error("model dimensions: {0}")]
    Dimension(String),
    /// A rig of a circuit this analysis does not model yet.
    #[error("{0}")]
    Circuit(String),
    /// NaN or infinity in a matrix.
    #[error("model matrix {matrix} has a non-finite entry at row {row}, column {col}")]
    NonFinite {
        /// Which matrix (A, B, C or D).
        matrix: &'static str,
        /// Row (1-based).
        row: usize,
        /// Column (1-based).
        col: usize,
    },
    /// The analysis needs one input and one output.
    #[error("model must be SISO (1 input, 1 output) for this analysis; it has {inputs} inputs and {outputs} outputs")]
    NotSiso {
        /// Number of inputs.
        inputs: usize,
        /// Number of outputs.
        outputs: usize,
    },
    /// The Schur iteration did not converge within its iteration limit.
    #[error("eigenvalue computation did not converge (Schur iteration limit reached)")]
    NoConvergence,
    /// A time response was asked of an unstable model: it would grow without bound.
    #[error(
        "the closed loop is unstable (a pole at {real_per_s:+.4} {imag_rad_per_s:+.4}j rad/s, \
         {freq_hz:.3} Hz): its response grows without bound"
    )]
    Unstable {
        /// Real part of the rightmost pole (1/s).
        real_per_s: f64,
        /// Its imaginary part (rad/s).
        imag_rad_per_s: f64,
        /// Its frequency |p|/2π (Hz).
        freq_hz: f64,
    },
    /// An entry too large or too small for the eigenvalue and frequency-response numerics (their
    /// balancing does not terminate on such scales).
    #[error("model matrix {matrix} has an entry {value:e} at row {row}, column {col}: pumpcyl analyses nonzero magnitudes from 1e-150 to 1e150")]
    Magnitude {
        /// Which matrix (A, B, C or D).
        matrix: &'static str,
        /// The entry.
        value: f64,
        /// Row (1-based).
        row: usize,
        /// Column (1-based).
        col: usize,
    },
    /// A result that is not a finite number (the model is numerically beyond evaluation there).
    #[error("{what} is not a finite number at {at}: the model cannot be evaluated there in double precision")]
    NonFiniteResult {
        /// The quantity.
        what: &'static str,
        /// Where (for example the frequency).
        at: String,
    },
    /// A record too long to simulate, or a duration or rate that is not positive.
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
    /// A sinusoid at or above the Nyquist frequency of its sampling would alias.
    #[error("{freq_hz} Hz is at or above the Nyquist frequency {nyquist_hz} Hz of sampling at {rate_hz} Hz: the samples would not show the sine; raise the sample rate above {} Hz", 2.0 * freq_hz)]
    AboveNyquist {
        /// The sine's frequency (Hz).
        freq_hz: f64,
        /// The sampling rate (Hz).
        rate_hz: f64,
        /// Half the sampling rate (Hz).
        nyquist_hz: f64,
    },
    /// The transfer function is identically zero: no input reaches the output.
    #[error("no input reaches the output: C (sI − A)⁻¹ B + D is identically zero (B, C or D and every C Aᵏ B are zero), so the frequency response is −∞ dB everywhere")]
    NoTransfer,
    /// Unity feedback with D = −1 has no solution.
    #[error("unity feedback is ill-posed: 1 + D = 0 (algebraic loop)")]
    IllPosedFeedback,
}

/// A continuous-time state-space model. SI units are the caller's business; the analyses are
/// unit-agnostic (frequencies in rad/s internally, Hz at the API where named `_hz`).
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    /// State matrix, n × n.
    pub a: DMatrix<f64>,
    /// Input matrix, n × m.
    pub b: DMatrix<f64>,
    /// Output matrix, p × n.
    pub c: DMatrix<f64>,
    /// Feedthrough matrix, p × m.
    pub d: DMatrix<f64>,
}

impl StateSpace {
    /// Build a model, checking that the sizes fit and every entry is finite.
    pub fn new(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
    ) -> Result<Self, LtiError> {
        let n = a.nrows();
        let dim = |what: String| Err(LtiError::Dimension(what));
        if n == 0 {
            return dim("A is empty: the model has no states".into());
        }
        if a.ncols() != n {
            return dim(format!("A must be square, it is {}×{}", n, a.ncols()));
        }
        if b.nrows() != n {
            return dim(format!("B has {} rows, A has {n}", b.nrows()));
        }
        if c.ncols() != n {
            return dim(format!("C has {} columns, A has {n}", c.ncols()));
        }
        if d.nrows() != c.nrows() || d.ncols() != b.ncols() {
            return dim(format!(
                "D is {}×{}, expected {}×{} (outputs × inputs)",
                d.nrows(),
                d.ncols(),
                c.nrows(),
                b.ncols()
            ));
        }
        for (name, m) in [("A", &a), ("B", &b), ("C", &c), ("D", &d)] {
            check_finite(name, m)?;
        }
        Ok(StateSpace { a, b, c, d })
    }

    /// Number of states.
    pub fn order(&self) -> usize {
        self.a.nrows()
    }

    /// Fail unless the model has one input and one output.
    pub fn require_siso(&self) -> Result<(), LtiError> {
        if self.b.ncols() == 1 && self.c.nrows() == 1 {
            Ok(())
        } else {
            Err(LtiError::NotSiso {
                inputs: self.b.ncols(),
                outputs: self.c.nrows(),
            })
        }
    }

    /// Fail with [`LtiError::NoTransfer`] when the transfer function C (sI − A)⁻¹ B + D is
    /// identically zero: D and every Markov parameter C Aᵏ B (k < n, Cayley–Hamilton) are
    /// exactly zero, as with B = 0 or C = 0 or a structurally disconnected input and output.
    pub fn require_transfer(&self) -> Result<(), LtiError> {
        let mut v = self.b.clone();
        for _ in 0..self.order() {
            if (&self.c * &v).iter().any(|x| *x != 0.0) {
                return Ok(());
            }
            v = &self.a * v;
            // only exact zeros matter: rescale so that the powers never overflow
            let top = v.amax();
            if top == 0.0 {
                break;
            }
            v /= top;
        }
        if self.d.iter().any(|x| *x != 0.0) {
            return Ok(());
        }
        Err(LtiError::NoTransfer)
    }

    /// The closed loop r → y of a SISO loop transfer L under unity negative feedback,
    /// u = r − y: A − B C/(1+D), B/(1+D), C/(1+D), D/(1+D).
    pub fn unity_feedback(&self) -> Result<StateSpace, LtiError> {
        self.require_siso()?;
        let den = 1.0 + self.d[(0, 0)];
        if den.abs() < f64::EPSILON {
            return Err(LtiError::IllPosedFeedback);
        }
        let a = &self.a - &self.b * &self.c / den;
        StateSpace::new(a, &self.b / den, &self.c / den, &self.d / den)
    }

    /// Stability of the closed loop under unity negative feedback (SISO), decided against
    /// rounding ([`stability`]).
    pub fn closed_loop_stability(&self) -> Result<Stability, LtiError> {
        stability(&self.unity_feedback()?.a)
    }

    /// Closed-loop poles under unity negative feedback (SISO).
    pub fn closed_loop_poles(&self) -> Result<Vec<num_complex::Complex64>, LtiError> {
        eigenvalues(&self.unity_feedback()?.a)
    }
}

/// Fail with [`LtiError::Unstable`] unless `a` is provably asymptotically stable: every
/// eigenvalue left of the imaginary axis by more than rounding ([`stability`]).
pub fn require_stable(a: &DMatrix<f64>) -> Result<(), LtiError> {
    let (poles, stability) = poles_and_stability(a)?;
    if stability == Stability::Stable {
        return Ok(());
    }
    let p = poles
        .iter()
        .copied()
        .max_by(|a, b| a.re.total_cmp(&b.re))
        .unwrap_or_default();
    Err(LtiError::Unstable {
        real_per_s: p.re,
        imag_rad_per_s: p.im.abs(),
        freq_hz: p.norm() / (2.0 * std::f64::consts::PI),
    })
}

/// NaN/inf check naming the first bad entry (1-based).
fn check_finite(matrix: &'static str, m: &DMatrix<f64>) -> Result<(), LtiError> {
    for r in 0..m.nrows() {
        for c in 0..m.ncols() {
            if !m[(r, c)].is_finite() {
                return Err(LtiError::NonFinite {
                    matrix,
                    row: r + 1,
                    col: c + 1,
                });
            }
        }
    }
    Ok(())
}

/// A closed loop is (asymptotically) stable when every pole lies strictly in the left
/// half-plane; a pole within 1e-10·max(1, |λ|) of the imaginary axis counts as not stable.
pub fn is_stable(poles: &[num_complex::Complex64]) -> bool {
    poles.iter().all(|p| p.re < -1e-10 * p.norm().max(1.0))
}

/// A single-input single-output model from row-major slices, for the tests of this module's
/// analyses.
#[cfg(test)]
pub(crate) fn siso(a: &[f64], b: &[f64], c: &[f64], d: f64) -> StateSpace {
    use nalgebra::DMatrix;
    let n = b.len();
    StateSpace::new(
        DMatrix::from_row_slice(n, n, a),
        DMatrix::from_row_slice(n, 1, b),
        DMatrix::from_row_slice(1, n, c),
        DMatrix::from_element(1, 1, d),
    )
    .unwrap()
}
