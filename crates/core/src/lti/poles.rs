//! Poles (eigenvalues of A) with natural frequency and damping ratio (docs/analysis.md#poles-and-damping).

use super::LtiError;
use nalgebra::linalg::balancing::balance_parlett_reinsch;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Schur iteration limit: the QR iteration can cycle on some inputs (nalgebra #611, #764).
const SCHUR_MAX_ITER: usize = 10_000;

/// Eigenvalues of `a`, balanced first (the rig's A spans ~1e-5 … 3e10), sorted by modulus.
/// Non-finite input or a Schur iteration that does not converge is an error, never a hang.
///
/// Poles and damping of the article's rig (docs/analysis.md#poles-and-damping):
///
/// ```
/// use pumpcyl::{lti::{eigenvalues, PoleInfo}, model::Plant, rig::Rig};
///
/// let rig = Rig::default();
/// let open = Plant::new(&rig).open_loop(false);
/// let poles: Vec<PoleInfo> = eigenvalues(&open.a)?.into_iter().map(PoleInfo::from).collect();
/// assert_eq!(poles.len(), 10);
/// // one pole at the origin (the piston position integrates its velocity), damping undefined
/// assert_eq!(poles.iter().filter(|p| p.damping.is_none()).count(), 1);
/// // the two feedforward filters contribute their poles at −1/τff
/// let ff = poles.iter().filter(|p| (p.re + 1.0 / rig.tau_ff_s).abs() < 1e-6).count();
/// assert_eq!(ff, 2);
///
/// // closed under unity position feedback, every pole is in the left half-plane
/// let closed: Vec<PoleInfo> = open.closed_loop_poles()?.into_iter().map(PoleInfo::from).collect();
/// assert!(closed.iter().all(|p| p.re < 0.0));
/// let least = closed.iter().filter_map(|p| p.damping).fold(f64::INFINITY, f64::min);
/// assert!((0.2..0.3).contains(&least), "least damping {least}");
/// # Ok::<(), pumpcyl::lti::LtiError>(())
/// ```
pub fn eigenvalues(a: &DMatrix<f64>) -> Result<Vec<Complex64>, LtiError> {
    Ok(BalancedSchur::new(a)?.eigenvalues)
}

/// Refuse entries of matrix `matrix` outside 1e-150 … 1e150 in magnitude (zero allowed): beyond
/// them the balancing of the eigenvalue and frequency-response numerics need not terminate, and
/// the products of unity feedback overflow.
pub fn check_magnitudes(matrix: &'static str, a: &DMatrix<f64>) -> Result<(), LtiError> {
    match a
        .iter()
        .position(|v| *v != 0.0 && !(1e-150..=1e150).contains(&v.abs()))
    {
        Some(k) => Err(LtiError::Magnitude {
            matrix,
            value: a[k],
            row: k % a.nrows() + 1,
            col: k / a.nrows() + 1,
        }),
        None => Ok(()),
    }
}

/// Real Schur form of the permuted and balanced matrix: `D⁻¹ Pᵀ A P D = Q T Qᵀ`, T
/// quasi-upper-triangular with exactly zero sub-diagonal entries between its 1×1 and 2×2
/// blocks. The permutation P first isolates the eigenvalues that the sparsity of A already
/// shows (a row or column with no off-diagonal entry in the active block, as LAPACK's `gebal`
/// does): they are diagonal entries, exact, so integrators built in series stay at exactly 0
/// instead of splitting into a rounding-noise cluster, and a nilpotent chain never reaches the
/// QR iteration.
pub(crate) struct BalancedSchur {
    /// The permutation: row/column i of the permuted matrix is row/column `perm[i]` of A.
    pub perm: Vec<usize>,
    /// Balancing scale D (diagonal).
    pub scale: DVector<f64>,
    /// Orthogonal Schur vectors.
    pub q: DMatrix<f64>,
    /// Quasi-triangular factor.
    pub t: DMatrix<f64>,
    /// Eigenvalues sorted by modulus.
    pub eigenvalues: Vec<Complex64>,
    /// The 1-norm of the permuted, balanced A: the scale of its rounding errors.
    pub norm: f64,
}

impl BalancedSchur {
    /// Permute, balance, then Schur with an iteration limit.
    pub fn new(a: &DMatrix<f64>) -> Result<Self, LtiError> {
        if let Some(k) = a.iter().position(|v| !v.is_finite()) {
            return Err(LtiError::NonFinite {
                matrix: "A",
                row: k % a.nrows() + 1,
                col: k / a.nrows() + 1,
            });
        }
        check_magnitudes("A", a)?;
        let perm = isolating_permutation(a);
        let n = a.nrows();
        let mut balanced = DMatrix::from_fn(n, n, |i, j| a[(perm[i], perm[j])]);
        let scale = balance_parlett_reinsch(&mut balanced);
        let norm = balanced
            .column_iter()
            .map(|c| c.lp_norm(1))
            .fold(0.0, f64::max);
        let schur = balanced
            .try_schur(f64::EPSILON, SCHUR_MAX_ITER)
            .ok_or(LtiError::NoConvergence)?;
        let mut eigenvalues: Vec<Complex64> = schur.complex_eigenvalues().iter().copied().collect();
        eigenvalues.sort_by(|p, q| p.norm().total_cmp(&q.norm()).then(p.im.total_cmp(&q.im)));
        let (q, t) = schur.unpack();
        Ok(BalancedSchur {
            perm,
            scale,
            q,
            t,
            eigenvalues,
            norm,
        })
    }

    /// The rounding radius of a simple eigenvalue (1/s): n·ε·‖A‖₁ of the permuted, balanced
    /// A (first-order perturbation of a well-conditioned eigenvalue; 0 for A = 0).
    pub fn rounding(&self) -> f64 {
        self.t.nrows() as f64 * f64::EPSILON * self.norm
    }

    /// The number of poles at the origin ([`count_integrators`]).
    pub fn integrators(&self) -> usize {
        count_integrators(&self.eigenvalues, self.rounding(), self.norm)
    }

    /// An input vector b of A's basis in the Schur basis: Qᵀ D⁻¹ Pᵀ b.
    pub fn input(&self, b: &DVector<f64>) -> Vec<f64> {
        let pb = DVector::from_fn(b.len(), |i, _| b[self.perm[i]] / self.scale[i]);
        self.q.tr_mul(&pb).iter().copied().collect()
    }

    /// An output row c of A's basis in the Schur basis (as a column): Qᵀ D Pᵀ cᵀ.
    pub fn output(&self, c: &DVector<f64>) -> Vec<f64> {
        let pc = DVector::from_fn(c.len(), |i, _| c[self.perm[i]] * self.scale[i]);
        self.q.tr_mul(&pc).iter().copied().collect()
    }
}

/// The symmetric permutation that isolates eigenvalues (LAPACK `gebal`, job 'P'): rows with no
/// off-diagonal entry inside the active block go to its bottom, columns with none to its top,
/// until neither is left; at most n passes of O(n²).
fn isolating_permutation(a: &DMatrix<f64>) -> Vec<usize> {
    let n = a.nrows();
    let mut perm: Vec<usize> = (0..n).collect();
    let (mut lo, mut hi) = (0, n);
    let at = |perm: &[usize], i: usize, j: usize| a[(perm[i], perm[j])];
    while let Some(i) = (lo..hi)
        .rev()
        .find(|&i| (lo..hi).all(|j| j == i || at(&perm, i, j) == 0.0))
    {
        perm.swap(i, hi - 1);
        hi -= 1;
    }
    while let Some(j) = (lo..hi).find(|&j| (lo..hi).all(|i| i == j || at(&perm, i, j) == 0.0)) {
        perm.swap(j, lo);
        lo += 1;
    }
    perm
}

/// A pole with its natural frequency and damping ratio.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PoleInfo {
    /// Real part (1/s).
    pub re: f64,
    /// Imaginary part (rad/s).
    pub im: f64,
    /// Natural frequency |λ|/(2π) (Hz).
    pub natural_freq_hz: f64,
    /// Damping ratio −Re λ/|λ|; `None` for a pole at the origin (undefined).
    pub damping: Option<f64>,
}

impl From<Complex64> for PoleInfo {
    fn from(p: Complex64) -> Self {
        let wn = p.norm();
        PoleInfo {
            re: p.re,
            im: p.im,
            natural_freq_hz: wn / (2.0 * PI),
            damping: (wn > 0.0).then(|| -p.re / wn),
        }
    }
}

/// The resonance of a set of poles: the least-damped complex pair whose natural frequency lies
/// in `[from_hz, to_hz]` (the article's Figure 14 reads it off the Bode peak), `None` if there
/// is no complex pole there.
pub fn resonance(poles: &[Complex64], from_hz: f64, to_hz: f64) -> Option<PoleInfo> {
    poles
        .iter()
        .filter(|p| p.im > 0.0)
        .map(|p| PoleInfo::from(*p))
        .filter(|i| (from_hz..=to_hz).contains(&i.natural_freq_hz))
        .min_by(|a, b| {
            let z = |i: &PoleInfo| i.damping.unwrap_or(f64::INFINITY);
            z(a).total_cmp(&z(b))
        })
}

/// The number of poles at the origin, from eigenvalues sorted by modulus, the rounding radius
/// `rounding` = n·ε·‖A‖ (1/s; [`BalancedSchur::rounding`]) and ‖A‖ (`norm`).
///
/// A single computed eigenvalue is at the origin when it lies within 100 rounding radii of it
/// (room for an eigenvalue condition number up to 100, a similarity of condition 10 or so). An
/// m-fold pole at the origin (m ≥ 2, a Jordan block) is computed as a cluster of m eigenvalues
/// of radius about (`rounding`/‖A‖)^(1/m)·‖A‖ around it whose mean stays within `rounding` of
/// 0, since rounding perturbs the cluster's trace only to first order: m is the largest count
/// whose m smallest eigenvalues lie inside that radius with their mean inside `rounding`. So a
/// slow pole beside a fast one (−0.5 beside −1e9, or −3e-6 beside an integrator in a stiff rig)
/// is not an integrator, and a double integrator that rounding split into ±1e-7 is two
/// (docs/analysis.md#phase-unwrapping-from-the-integrators).
pub(crate) fn count_integrators(poles: &[Complex64], rounding: f64, norm: f64) -> usize {
    if norm == 0.0 {
        return poles.len();
    }
    let cluster = (2..=poles.len()).rev().find(|&m| {
        let radius = (rounding / norm).powf(1.0 / m as f64) * norm;
        let mean = poles[..m].iter().sum::<Complex64>() / m as f64;
        poles[m - 1].norm() <= radius && mean.norm() <= rounding
    });
    cluster.unwrap_or(usize::from(
        poles.first().is_some_and(|p| p.norm() <= 100.0 * rounding),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn resonance_is_the_least_damped_pair_in_the_band() {
        // two second-order modes, 1 Hz ζ 0.5 and 5 Hz ζ 0.05, and a real pole
        let mode = |f: f64, z: f64| {
            let w = 2.0 * PI * f;
            let d = w * (1.0 - z * z).sqrt();
            [Complex64::new(-z * w, d), Complex64::new(-z * w, -d)]
        };
        let mut p = vec![Complex64::new(-3.0, 0.0)];
        p.extend(mode(1.0, 0.5));
        p.extend(mode(5.0, 0.05));
        let r = resonance(&p, 0.1, 10.0).unwrap();
        assert_relative_eq!(r.natural_freq_hz, 5.0, max_relative = 1e-12);
        assert_relative_eq!(r.damping.unwrap(), 0.05, max_relative = 1e-12);
        let r = resonance(&p, 0.1, 2.0).unwrap();
        assert_relative_eq!(r.damping.unwrap(), 0.5, max_relative = 1e-12);
        assert!(resonance(&p, 10.0, 100.0).is_none());
    }

    #[test]
    fn second_order_poles_give_wn_and_zeta() {
        // s² + 2ζω s + ω², ω = 10, ζ = 0.1, companion form
        let (w, z) = (10.0, 0.1);
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w * w, -2.0 * z * w]);
        let p = eigenvalues(&a).unwrap();
        for pole in p {
            let info = PoleInfo::from(pole);
            assert_relative_eq!(info.natural_freq_hz, w / (2.0 * PI), max_relative = 1e-12);
            assert_relative_eq!(info.damping.unwrap(), z, max_relative = 1e-12);
        }
    }

    #[test]
    fn badly_scaled_matrix_needs_balancing() {
        // diag similarity of a stable matrix with entries spanning 1e-6 … 1e10
        let base =
            DMatrix::from_row_slice(3, 3, &[-1.0, 2.0, 0.0, -3.0, -1.0, 1.0, 0.0, -1.0, -5.0]);
        let s = nalgebra::DVector::from_vec(vec![1e-6, 1.0, 1e4]);
        let scaled = DMatrix::from_fn(3, 3, |i, j| base[(i, j)] * s[i] / s[j]);
        let mut p1 = eigenvalues(&base).unwrap();
        let mut p2 = eigenvalues(&scaled).unwrap();
        p1.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        p2.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        for (a, b) in p1.iter().zip(&p2) {
            assert!((a - b).norm() < 1e-9 * a.norm().max(1.0), "{a} vs {b}");
        }
    }

    #[test]
    fn non_finite_is_an_error() {
        let a = DMatrix::from_row_slice(1, 1, &[f64::NAN]);
        assert!(eigenvalues(&a).is_err());
    }
}

/// Asymptotic stability of a matrix's eigenvalues, decided against rounding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stability {
    /// Every eigenvalue lies left of the imaginary axis by more than its rounding radius.
    Stable,
    /// An eigenvalue lies right of the imaginary axis by more than its rounding radius.
    Unstable,
    /// Poles at the origin — integrators, each exactly 0 or within 100 rounding radii of it
    /// (100 n·ε·‖A‖₁, ‖A‖₁ bounding the largest pole) — and every other eigenvalue left of the
    /// imaginary axis by more than its rounding radius: a plain integrator such as the piston position integrating its
    /// velocity; not asymptotically stable (docs/analysis.md#poles-and-damping).
    Integrator,
    /// No eigenvalue is clearly unstable, but one that is not an integrator lies within
    /// rounding of the imaginary axis (an undamped pair, or a slow pole beside fast ones): not
    /// provably asymptotically stable.
    Undecided,
}

/// The stability of `a`'s eigenvalues, with tolerances relative to the matrix's scale (the
/// rounding radius n·ε·‖A‖₁ after balancing, and poles at the origin counted by their rounding
/// clusters), so a pole at −2e-12 of a model whose entries are 1e-12 is stable and one at
/// −1e-9 beside poles at 1e10 is undecided (docs/analysis.md#poles-and-damping).
pub fn stability(a: &DMatrix<f64>) -> Result<Stability, LtiError> {
    Ok(poles_and_stability(a)?.1)
}

/// The eigenvalues of `a` sorted by modulus ([`eigenvalues`]) and their [`stability`], from one
/// factorisation.
pub fn poles_and_stability(a: &DMatrix<f64>) -> Result<(Vec<Complex64>, Stability), LtiError> {
    let s = BalancedSchur::new(a)?;
    let (rounding, at_origin) = (s.rounding(), s.integrators());
    let rest = &s.eigenvalues[at_origin..];
    let stability = if rest.iter().any(|p| p.re > rounding) {
        Stability::Unstable
    } else if rest.iter().any(|p| p.re >= -rounding) {
        Stability::Undecided
    } else if at_origin > 0 {
        Stability::Integrator
    } else {
        Stability::Stable
    };
    Ok((s.eigenvalues, stability))
}
