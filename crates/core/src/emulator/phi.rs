//! The matrix functions of the integrator's linear parts (docs/emulator.md#the-integration):
//! e^z, φ₁(z), φ₂(z), φ₃(z) of z = hJ₀/2ˡ for the halvings ℓ of a PLC interval, and the ETDRK4
//! propagators built from them.
//!
//! J₀ is balanced by a diagonal similarity of powers of two (Parlett and Reinsch, Numerische
//! Mathematik 13, 1969), the Taylor series of φ₃(z/2ˢ) summed by Horner's rule, then
//! φ_k = z φ_{k+1} + 1/k! for the others, then s doublings φ_k(2z) = 2⁻ᵏ (e^z φ_k(z) + Σ_{j=1..k} φ_j(z)/(k−j)!)
//! (Skaflestad and Wright, Applied Numerical Mathematics 59, 2009). The four functions of a
//! level sit side by side, row by row, so each doubling is one product e^z [φ₀ φ₁ φ₂ φ₃]; the
//! products skip the exact zeros of their left factor (J₀ is sparse, and so are the rows of
//! e^z that only the feedforward filters feed) and are compiled for the circuits' orders, with
//! AVX2 where the processor has it. Every entry is the same sum, term by term in the same
//! order, as the plain product's: a skipped term is an exact zero, so the results are the same
//! bit for bit.

use super::EmulatorError;

/// Taylor terms of φ₃ at ‖z‖₁ ≤ 1/2 (φ₂, φ₁, e^z then have one, two, three more): the first
/// left out is below 10⁻¹⁶ of them.
const TAYLOR_TERMS: usize = 14;

/// 1/k! for k = 0 ..= [`TAYLOR_TERMS`] + 3 (the factorials are exact integers below 2⁵³).
const INVERSE_FACTORIALS: [f64; TAYLOR_TERMS + 4] = {
    let mut out = [0.0; TAYLOR_TERMS + 4];
    let (mut k, mut factorial) = (0, 1.0);
    while k < out.len() {
        if k > 0 {
            factorial *= k as f64;
        }
        out[k] = 1.0 / factorial;
        k += 1;
    }
    out
};

/// Sweeps of [`balance`] at most.
const BALANCE_SWEEPS: usize = 16;

/// e^z, φ₁(z), φ₂(z), φ₃(z) of z = hJ₀/2ˡ for the levels ℓ of a block, of the balanced
/// D⁻¹J₀D: entry (r, c) of J₀'s is d_r/d_c times it. Level by level, finest first, each an
/// n × 4n row-major matrix [φ₀ φ₁ φ₂ φ₃].
pub(super) struct Phis {
    n: usize,
    /// d_r/d_c, row-major: what takes a balanced entry back to J₀'s.
    back: Vec<f64>,
    m: Vec<f64>,
}

impl Phis {
    /// Level `l`: the n × 4n row-major [φ₀ φ₁ φ₂ φ₃], balanced.
    fn level(&self, l: usize) -> &[f64] {
        let size = 4 * self.n * self.n;
        let levels = self.m.len() / size;
        &self.m[(levels - 1 - l) * size..(levels - l) * size]
    }

    /// Entry (r, c) of φ_k of level `l`, balanced.
    #[cfg(test)]
    fn at(&self, l: usize, k: usize, r: usize, c: usize) -> f64 {
        self.level(l)[r * 4 * self.n + k * self.n + c]
    }

    /// φ_k of level `l`, row-major: of J₀ itself.
    #[cfg(test)]
    pub(super) fn of_j(&self, l: usize, k: usize) -> Vec<f64> {
        let n = self.n;
        (0..n * n)
            .map(|i| self.at(l, k, i / n, i % n) * self.back[i])
            .collect()
    }

    /// How many levels it holds.
    #[cfg(test)]
    pub(super) fn levels(&self) -> usize {
        self.m.len() / (4 * self.n * self.n)
    }
}

/// The matrices of one ETDRK4 step of length h with the linear part J₀ (scaled, column-major):
/// e^{hJ₀/2}, (h/2) φ₁(hJ₀/2), e^{hJ₀}, and the weights h(φ₁ − 3φ₂ + 4φ₃), 2h(φ₂ − 2φ₃),
/// h(4φ₃ − φ₂) of hJ₀.
pub(super) struct Propagator {
    /// The six matrices one after the other, each column-major n × n.
    pub(super) m: Vec<f64>,
}

#[cfg(test)]
impl Propagator {
    fn matrix(&self, k: usize) -> &[f64] {
        let nn = self.m.len() / 6;
        &self.m[k * nn..(k + 1) * nn]
    }
    pub(super) fn e(&self) -> &[f64] {
        self.matrix(2)
    }
    pub(super) fn weight1(&self) -> &[f64] {
        self.matrix(3)
    }
    pub(super) fn weight2(&self) -> &[f64] {
        self.matrix(4)
    }
    pub(super) fn weight3(&self) -> &[f64] {
        self.matrix(5)
    }
}

/// The ETDRK4 propagator of a step of `h` from the φ functions of hJ₀ (level `l` of `phis`) and
/// of hJ₀/2 (level `l + 1`), back from the balanced basis.
pub(super) fn propagator(phis: &Phis, l: usize, h: f64) -> Propagator {
    let n = phis.n;
    let nn = n * n;
    let (whole, half) = (phis.level(l), phis.level(l + 1));
    let mut m = spare(6 * nn);
    for r in 0..n {
        let (w, hf) = (&whole[r * 4 * n..], &half[r * 4 * n..]);
        for c in 0..n {
            // exact: a ratio of powers of two
            let back = phis.back[r * n + c];
            let (e, f1, f2, f3) = (w[c], w[n + c], w[2 * n + c], w[3 * n + c]);
            let (e_half, p_half) = (hf[c], hf[n + c]);
            let o = c * n + r;
            m[o] = e_half * back;
            m[nn + o] = p_half * (0.5 * h) * back;
            m[2 * nn + o] = e * back;
            m[3 * nn + o] = h * (f1 - 3.0 * f2 + 4.0 * f3) * back;
            m[4 * nn + o] = h * (2.0 * f2 - 4.0 * f3) * back;
            m[5 * nn + o] = h * (-f2 + 4.0 * f3) * back;
        }
    }
    Propagator { m }
}

/// Buffers of dropped propagators kept for new ones, at most [`SPARE`]: a noisy record in
/// motion builds and drops tens of thousands of propagators, and the allocator would
/// otherwise hand their memory back and fault it in again (the cache's two generations bound
/// how many are alive at once).
const SPARE: usize = 1 << 14;

thread_local! {
    static SPARES: std::cell::RefCell<Vec<Vec<f64>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A buffer of `len` numbers, a spare one where there is one: what it holds is to be written
/// over.
fn spare(len: usize) -> Vec<f64> {
    let mut m = SPARES.with(|s| s.borrow_mut().pop()).unwrap_or_default();
    // a spare of the right length is written over entry by entry: no need to clear it first
    if m.len() != len {
        m.clear();
        m.resize(len, 0.0);
    }
    m
}

impl Drop for Propagator {
    fn drop(&mut self) {
        let m = std::mem::take(&mut self.m);
        // during a thread's exit the spares may be gone already: the buffer is then freed
        let _ = SPARES.try_with(|s| {
            let mut s = s.borrow_mut();
            if s.len() < SPARE {
                s.push(m);
            }
        });
    }
}

/// e^z, φ₁(z), φ₂(z), φ₃(z) of z = hJ/2ˡ for ℓ = 0 ..= `levels` + 1 (φ₀ = e^z,
/// φ_{k+1}(z) = (φ_k(z) − 1/k!)/z), J row-major n × n (the module's doc says how).
pub(super) fn phi_levels(
    n: usize,
    j: &[f64],
    h: f64,
    levels: usize,
) -> Result<Phis, EmulatorError> {
    if !j.iter().all(|v| v.is_finite()) {
        return Err(EmulatorError(
            "ODE solver: the Jacobian is not finite".to_string(),
        ));
    }
    // φ_k(D⁻¹ZD) = D⁻¹ φ_k(Z) D: balanced by powers of two, exactly, the norm that sets the
    // doublings drops from the typical sizes' scaling to near the spectral radius
    let mut a = j.to_vec();
    let d = balance(&mut a, n);
    let norm = (0..n)
        .map(|c| (0..n).map(|r| (h * a[r * n + c]).abs()).sum::<f64>())
        .fold(0.0, f64::max);
    // ‖hJ/2ˢ‖ ≤ 1/2, and s > `levels` so every level asked for is passed on the way
    let s = ((norm / 0.5).log2().ceil().max(0.0) as usize).max(levels + 1);
    let scale = h / 2f64.powi(s as i32);
    a.iter_mut().for_each(|v| *v *= scale);
    let mut m = PHI_SPARE.with(std::cell::Cell::take);
    m.clear();
    m.reserve_exact((levels + 2) * 4 * n * n);
    // the last levels + 2 of the s + 1 passed: s − levels − 1 doublings before the first kept
    let pass = Pass {
        n,
        a: &a,
        doublings: s,
        skip: s - levels - 1,
    };
    run_pass(&pass, &mut m);
    let back = (0..n * n).map(|i| d[i / n] / d[i % n]).collect();
    Ok(Phis { n, back, m })
}

thread_local! {
    /// The buffer of the last φ functions dropped, for the next: most intervals compute at
    /// most one block.
    static PHI_SPARE: std::cell::Cell<Vec<f64>> = const { std::cell::Cell::new(Vec::new()) };
}

impl Drop for Phis {
    fn drop(&mut self) {
        let m = std::mem::take(&mut self.m);
        let _ = PHI_SPARE.try_with(|s| s.set(m));
    }
}

/// One pass of the scaling and squaring: the scaled, balanced z = a (row-major n × n), the
/// number of doublings, and how many of the levels passed are not kept (the coarsest
/// `levels + 2` are: the output holds `doublings + 1 − skip` levels).
struct Pass<'a> {
    n: usize,
    a: &'a [f64],
    doublings: usize,
    skip: usize,
}

/// Run `pass` into `out`, compiled for the order where the circuits have it.
fn run_pass(pass: &Pass, out: &mut Vec<f64>) {
    macro_rules! orders {
        ($($n:literal => $w:literal),*) => {
            match pass.n {
                $($n => return dispatch::<$n, $w>(pass, out),)*
                _ => pass_any(pass, out),
            }
        };
    }
    orders!(6 => 24, 7 => 28, 8 => 32, 9 => 36, 10 => 40)
}

/// [`pass_n`] with AVX2 where the running processor has it.
fn dispatch<const N: usize, const W: usize>(pass: &Pass, out: &mut Vec<f64>) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor reports AVX2, the feature `pass_avx2` is compiled for.
        unsafe { pass_avx2::<N, W>(pass, out) };
        return;
    }
    pass_n::<N, W>(pass, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn pass_avx2<const N: usize, const W: usize>(pass: &Pass, out: &mut Vec<f64>) {
    pass_n::<N, W>(pass, out)
}

/// The nonzero entries of an N × N matrix by row, each row in column order.
struct Sparse<const N: usize> {
    /// Where each row's entries start and end in `entries`.
    rows: [(usize, usize); N],
    /// (column, value) of each nonzero entry, the first of them in use.
    entries: [(usize, f64); SPARSE_MAX],
}

/// The most entries a [`Sparse`] holds: the compiled orders' N × N.
const SPARSE_MAX: usize = 100;

impl<const N: usize> Sparse<N> {
    fn new() -> Self {
        const { assert!(N * N <= SPARSE_MAX) };
        Sparse {
            rows: [(0, 0); N],
            entries: [(0, 0.0); SPARSE_MAX],
        }
    }

    /// The nonzero entries of the first N columns of `a`'s rows.
    #[inline(always)]
    fn of<const W: usize>(&mut self, a: &[[f64; W]; N]) -> &Self {
        let mut len = 0;
        for (r, row) in a.iter().enumerate() {
            let start = len;
            for (c, &v) in row[..N].iter().enumerate() {
                if v != 0.0 {
                    self.entries[len] = (c, v);
                    len += 1;
                }
            }
            self.rows[r] = (start, len);
        }
        self
    }
}

/// out = a · b over the nonzero entries of `a` (each sum term by term in column order, as a
/// plain product's: a skipped term is an exact zero), b and out N × W.
#[inline(always)]
fn sparse_mul<const N: usize, const W: usize>(
    a: &Sparse<N>,
    b: &[[f64; W]; N],
    out: &mut [[f64; W]; N],
) {
    for (&(start, end), out_row) in a.rows.iter().zip(out.iter_mut()) {
        let mut acc = [0.0; W];
        for &(k, v) in &a.entries[start..end] {
            let b_row = &b[k];
            for c in 0..W {
                acc[c] += v * b_row[c];
            }
        }
        *out_row = acc;
    }
}

/// The pass for a compile-time order N (W = 4N): the Taylor series by Horner's rule, the other
/// φ functions from φ₃, then the doublings, keeping the levels asked for.
#[inline(always)]
fn pass_n<const N: usize, const W: usize>(pass: &Pass, out: &mut Vec<f64>) {
    let mut a = [[0.0; N]; N];
    for (r, row) in a.iter_mut().enumerate() {
        row.copy_from_slice(&pass.a[r * N..(r + 1) * N]);
    }
    let mut sparse_a = Sparse::new();
    let a = sparse_a.of(&a);
    // φ₃(a) = Σ aᵐ/(m + 3)! by Horner, then φ_k = a φ_{k+1} + I/k!
    let (mut t0, mut t1) = ([[0.0; N]; N], [[0.0; N]; N]);
    let (mut t, mut next) = (&mut t0, &mut t1);
    (0..N).for_each(|i| t[i][i] += INVERSE_FACTORIALS[TAYLOR_TERMS + 3]);
    for m in (0..TAYLOR_TERMS).rev() {
        sparse_mul(a, t, next);
        (0..N).for_each(|i| next[i][i] += INVERSE_FACTORIALS[m + 3]);
        std::mem::swap(&mut t, &mut next);
    }
    // [φ₀ φ₁ φ₂ φ₃] side by side
    let mut phi = [[0.0; W]; N];
    for k in (0..4).rev() {
        if k < 3 {
            sparse_mul(a, t, next);
            (0..N).for_each(|i| next[i][i] += INVERSE_FACTORIALS[k]);
            std::mem::swap(&mut t, &mut next);
        }
        for (row, t) in phi.iter_mut().zip(t.iter()) {
            row[k * N..(k + 1) * N].copy_from_slice(t);
        }
    }
    let (mut products, mut e) = ([[0.0; W]; N], Sparse::new());
    for step in 0..=pass.doublings {
        if step >= pass.skip {
            phi.iter().for_each(|row| out.extend_from_slice(row));
        }
        if step == pass.doublings {
            break;
        }
        // e·e, e·φ₁, e·φ₂, e·φ₃ at once
        sparse_mul(e.of(&phi), &phi, &mut products);
        for (row, p) in phi.iter_mut().zip(&products) {
            double_row::<N>(row, p);
        }
    }
}

/// One doubling of a row [φ₀ φ₁ φ₂ φ₃] from the row of e^z [φ₀ φ₁ φ₂ φ₃] (`p`).
#[inline(always)]
fn double_row<const N: usize>(row: &mut [f64], p: &[f64]) {
    for c in 0..N {
        let (g1, g2, g3) = (row[N + c], row[2 * N + c], row[3 * N + c]);
        row[c] = p[c];
        row[N + c] = 0.5 * (p[N + c] + g1);
        row[2 * N + c] = 0.25 * (p[2 * N + c] + g1 + g2);
        row[3 * N + c] = 0.125 * (p[3 * N + c] + 0.5 * g1 + g2 + g3);
    }
}

/// The pass for any order, plainly: the same sums as [`pass_n`]'s.
fn pass_any(pass: &Pass, out: &mut Vec<f64>) {
    let n = pass.n;
    let (nn, w) = (n * n, 4 * n);
    let factorial = |k: usize| (1..=k).map(|i| i as f64).product::<f64>();
    let mul = |a: &[f64], b: &[f64], out: &mut [f64], width: usize| {
        out.fill(0.0);
        for r in 0..n {
            for k in 0..n {
                for c in 0..width {
                    out[r * width + c] += a[r * n + k] * b[k * width + c];
                }
            }
        }
    };
    let (mut t0, mut t1) = (vec![0.0; nn], vec![0.0; nn]);
    (0..n).for_each(|i| t0[i * n + i] += 1.0 / factorial(TAYLOR_TERMS + 3));
    for m in (0..TAYLOR_TERMS).rev() {
        mul(pass.a, &t0, &mut t1, n);
        (0..n).for_each(|i| t1[i * n + i] += 1.0 / factorial(m + 3));
        std::mem::swap(&mut t0, &mut t1);
    }
    let mut phi = vec![0.0; n * w];
    for k in (0..4).rev() {
        if k < 3 {
            mul(pass.a, &t0, &mut t1, n);
            (0..n).for_each(|i| t1[i * n + i] += 1.0 / factorial(k));
            std::mem::swap(&mut t0, &mut t1);
        }
        for r in 0..n {
            phi[r * w + k * n..r * w + (k + 1) * n].copy_from_slice(&t0[r * n..(r + 1) * n]);
        }
    }
    let mut products = vec![0.0; n * w];
    for step in 0..=pass.doublings {
        if step >= pass.skip {
            out.extend_from_slice(&phi);
        }
        if step == pass.doublings {
            break;
        }
        let e: Vec<f64> = (0..nn).map(|i| phi[(i / n) * w + i % n]).collect();
        mul(&e, &phi, &mut products, w);
        for r in 0..n {
            let (row, p) = (&mut phi[r * w..(r + 1) * w], &products[r * w..(r + 1) * w]);
            for c in 0..n {
                let (g1, g2, g3) = (row[n + c], row[2 * n + c], row[3 * n + c]);
                row[c] = p[c];
                row[n + c] = 0.5 * (p[n + c] + g1);
                row[2 * n + c] = 0.25 * (p[2 * n + c] + g1 + g2);
                row[3 * n + c] = 0.125 * (p[3 * n + c] + 0.5 * g1 + g2 + g3);
            }
        }
    }
}

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
            // at most 64 factors of two each way: beyond, the scaling would not help. Times a
            // power of two is its division by the inverse power, rounded alike: the same bits
            // as dividing, without a division's latency
            for _ in 0..64 {
                if c >= r * 0.5 {
                    break;
                }
                c *= 2.0;
                r *= 0.5;
                f *= 2.0;
            }
            for _ in 0..64 {
                if c < r * 2.0 {
                    break;
                }
                c *= 0.5;
                r *= 2.0;
                f *= 0.5;
            }
            if c + r < 0.95 * total {
                changed = true;
                d[i] *= f;
                let inverse = 1.0 / f;
                for k in 0..n {
                    a[i * n + k] *= inverse;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_compiled_sparse_pass_is_the_plain_pass_bit_for_bit() {
        // what the integrator's records rest on: skipping exact zeros and compiling for an
        // order (with AVX2 where the processor has it) leaves every entry's sum as it was
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut random = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for n in 1..=12 {
            for sample in 0..20 {
                // about a third of the entries exactly zero, as in the circuits' Jacobians
                let a: Vec<f64> = (0..n * n)
                    .map(|i| {
                        let keep = i % (n + 1) == 0 || random() > -0.2 + 0.1 * (sample % 3) as f64;
                        if keep {
                            random() * [0.01, 0.1, 0.5][sample % 3]
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let pass = Pass {
                    n,
                    a: &a,
                    doublings: 7 + sample % 3,
                    skip: sample % 3,
                };
                let (mut fast, mut plain) = (Vec::new(), Vec::new());
                run_pass(&pass, &mut fast);
                pass_any(&pass, &mut plain);
                assert_eq!(fast.len(), 8 * 4 * n * n);
                assert!(
                    (fast.iter().zip(&plain)).all(|(f, p)| f.to_bits() == p.to_bits()),
                    "order {n}, sample {sample}"
                );
            }
        }
    }
}
