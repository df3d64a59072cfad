//! The exact Newton matrix of a three-stage implicit step, `I − h (A ⊗ I) diag(J₁, J₂, J₃)`,
//! factored by blocks rather than whole.
//!
//! Multiplied on the left by `A⁻¹ ⊗ I` it is `K = (α ⊗ I) − h diag(J₁, J₂, J₃)` with
//! `α = A⁻¹`: its blocks off the diagonal are multiples of the identity. Eliminating the
//! first block row needs only `X = K₁₁⁻¹` (every later block is a multiple of `X` plus a
//! multiple of `I`); eliminating the second, `Y = K'₂₂⁻¹ K'₂₃`; then the `n × n` Schur
//! complement `S` is factored. That is about `8 n³` operations where the whole `3n × 3n`
//! matrix takes `18 n³`, with no `3n × 3n` matrix built.
//!
//! The blocks are eliminated in order without pivoting between them: where a diagonal
//! block is singular, [`BlockNewton::factor`] returns `None` and the caller factors the
//! whole matrix.

use super::dense_lu::DenseLu;

/// The factors of `K = (α ⊗ I) − h diag(J₁, J₂, J₃)`, and `α`.
#[derive(Debug, Clone)]
pub(crate) struct BlockNewton {
    n: usize,
    /// `α = A⁻¹`, row-major `3 × 3`.
    alpha: [f64; 9],
    k11: DenseLu<f64>,
    /// `X = K₁₁⁻¹`, row-major.
    x: Vec<f64>,
    k22: DenseLu<f64>,
    /// `Y = K'₂₂⁻¹ K'₂₃`, row-major.
    y: Vec<f64>,
    /// `K'₃₂ = α₃₂ I − α₃₁ α₁₂ X`, row-major.
    k32: Vec<f64>,
    /// `S = K'₃₃ − K'₃₂ Y`.
    s: DenseLu<f64>,
    scratch: Vec<f64>,
    /// `(α ⊗ I) r`, then the solution.
    b: Vec<f64>,
}

impl BlockNewton {
    /// Factors `K` for `alpha = A⁻¹` (row-major `3 × 3`), the stages' Jacobians `jacobians`
    /// (row-major `n × n` each; an entry that is not finite counts as 0, as the matrix only
    /// steers the iteration) and the sub-step `h`; `None` where a block is singular.
    pub fn factor(alpha: [f64; 9], jacobians: [&[f64]; 3], n: usize, h: f64) -> Option<Self> {
        let a = |i: usize, j: usize| alpha[i * 3 + j];
        // α_ii I − h J_i, row-major.
        let diagonal = |i: usize| -> Vec<f64> {
            let mut m: Vec<f64> = jacobians[i]
                .iter()
                .map(|&d| if d.is_finite() { -h * d } else { 0.0 })
                .collect();
            for k in 0..n {
                m[k * n + k] += a(i, i);
            }
            m
        };
        let k11 = DenseLu::factor(diagonal(0), n)?;
        let x = inverse(&k11, n);
        // K'_ij = K_ij − α_i1 α_1j X for i, j in {2, 3}.
        let eliminated = |i: usize, j: usize, mut m: Vec<f64>| -> Vec<f64> {
            let c = a(i, 0) * a(0, j);
            for (m, &x) in m.iter_mut().zip(&x) {
                *m -= c * x;
            }
            m
        };
        let scaled_identity = |c: f64| -> Vec<f64> {
            let mut m = vec![0.0; n * n];
            for k in 0..n {
                m[k * n + k] = c;
            }
            m
        };
        let k22 = DenseLu::factor(eliminated(1, 1, diagonal(1)), n)?;
        let k23 = eliminated(1, 2, scaled_identity(a(1, 2)));
        let k32 = eliminated(2, 1, scaled_identity(a(2, 1)));
        let mut s = eliminated(2, 2, diagonal(2));
        // Y = K'₂₂⁻¹ K'₂₃.
        let mut y = k23;
        k22.solve_rows(&mut y, n);
        // S = K'₃₃ − K'₃₂ Y.
        for r in 0..n {
            let row = &k32[r * n..(r + 1) * n];
            for (k, &v) in row.iter().enumerate() {
                if v != 0.0 {
                    for (s, &y) in s[r * n..(r + 1) * n].iter_mut().zip(&y[k * n..(k + 1) * n]) {
                        *s -= v * y;
                    }
                }
            }
        }
        let s = DenseLu::factor(s, n)?;
        Some(BlockNewton {
            n,
            alpha,
            k11,
            x,
            k22,
            y,
            k32,
            s,
            scratch: vec![0.0; n],
            b: vec![0.0; 3 * n],
        })
    }

    /// Solves `(I − h (A ⊗ I) diag(J₁, J₂, J₃)) Δ = r` in place (`r`, then `Δ`), as
    /// `K Δ = (α ⊗ I) r` by block substitution.
    pub fn solve_mut(&mut self, r: &mut [f64]) {
        let n = self.n;
        let a = |i: usize, j: usize| self.alpha[i * 3 + j];
        // b = (α ⊗ I) r.
        let b = &mut self.b;
        b.fill(0.0);
        for i in 0..3 {
            for j in 0..3 {
                let c = a(i, j);
                for (b, &r) in b[i * n..(i + 1) * n].iter_mut().zip(&r[j * n..(j + 1) * n]) {
                    *b += c * r;
                }
            }
        }
        let (b1, rest) = b.split_at_mut(n);
        let (b2, b3) = rest.split_at_mut(n);
        // c₁ = K₁₁⁻¹ b₁; b₂ −= α₂₁ c₁; b₃ −= α₃₁ c₁.
        self.k11.solve(b1, &mut self.scratch);
        for k in 0..n {
            b2[k] -= a(1, 0) * b1[k];
            b3[k] -= a(2, 0) * b1[k];
        }
        // c₂ = K'₂₂⁻¹ b₂; b₃ −= K'₃₂ c₂; Δ₃ = S⁻¹ b₃.
        self.k22.solve(b2, &mut self.scratch);
        for (row, b3) in b3.iter_mut().enumerate() {
            let k32 = &self.k32[row * n..(row + 1) * n];
            *b3 -= k32.iter().zip(b2.iter()).map(|(k, c)| k * c).sum::<f64>();
        }
        self.s.solve(b3, &mut self.scratch);
        // Δ₂ = c₂ − Y Δ₃; Δ₁ = c₁ − X (α₁₂ Δ₂ + α₁₃ Δ₃).
        for (row, b2) in b2.iter_mut().enumerate() {
            let y = &self.y[row * n..(row + 1) * n];
            *b2 -= y.iter().zip(b3.iter()).map(|(y, d)| y * d).sum::<f64>();
        }
        let w = &mut self.scratch;
        for ((w, d2), d3) in w.iter_mut().zip(b2.iter()).zip(b3.iter()) {
            *w = a(0, 1) * d2 + a(0, 2) * d3;
        }
        for (row, b1) in b1.iter_mut().enumerate() {
            let x = &self.x[row * n..(row + 1) * n];
            *b1 -= x.iter().zip(w.iter()).map(|(x, w)| x * w).sum::<f64>();
        }
        r.copy_from_slice(b);
    }
}

/// `M⁻¹` of a factored `n × n` matrix, row-major.
fn inverse(lu: &DenseLu<f64>, n: usize) -> Vec<f64> {
    let mut inverse = vec![0.0; n * n];
    for k in 0..n {
        inverse[k * n + k] = 1.0;
    }
    lu.solve_rows(&mut inverse, n);
    inverse
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::model::Integrator;
    use crate::model::implicit::Tableau;
    use nalgebra::DMatrix;

    #[test]
    fn block_solves_match_the_whole_matrix() {
        // RADAU5's A, stiff and non-stiff Jacobians of a few sizes.
        let a = Tableau::of(Integrator::Radau5).unwrap().a;
        let alpha_matrix = DMatrix::from_row_slice(3, 3, &a).try_inverse().unwrap();
        let mut alpha = [0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                alpha[i * 3 + j] = alpha_matrix[(i, j)];
            }
        }
        let mut seed = 7u64;
        let mut random = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for (n, h, stiffness) in [(1, 0.5, 1.0), (5, 75.0, 0.7), (28, 300.0, 0.3)] {
            let jacobians: Vec<Vec<f64>> = (0..3)
                .map(|_| {
                    (0..n * n)
                        .map(|k| random() * 0.02 - if k % (n + 1) == 0 { stiffness } else { 0.0 })
                        .collect()
                })
                .collect();
            let whole = DMatrix::from_fn(3 * n, 3 * n, |r, c| {
                let (i, k) = (r / n, r % n);
                let (j, l) = (c / n, c % n);
                let identity = if r == c { 1.0 } else { 0.0 };
                identity - h * a[i * 3 + j] * jacobians[j][k * n + l]
            });
            let rhs: Vec<f64> = (0..3 * n).map(|_| random()).collect();
            let want = whole
                .clone()
                .lu()
                .solve(&nalgebra::DVector::from_vec(rhs.clone()))
                .unwrap();
            let mut blocks =
                BlockNewton::factor(alpha, [&jacobians[0], &jacobians[1], &jacobians[2]], n, h)
                    .unwrap();
            let mut got = rhs.clone();
            blocks.solve_mut(&mut got);
            let scale = want.amax().max(1.0);
            for (g, w) in got.iter().zip(want.iter()) {
                assert!((g - w).abs() < 1e-10 * scale, "n = {n}: {g} against {w}");
            }
        }
    }
}
