//! The simplified Newton matrix of an implicit Runge–Kutta method split by the eigenvalues
//! of `A⁻¹` (Hairer & Wanner, *Solving ODEs II*, IV.8), written here from the algebra.
//!
//! The Newton system of one sub-step, `(I − h A ⊗ J) Δ = r` over the `s × n` stage
//! increments, multiplied by `A⁻¹ / h`, is `(A⁻¹/h ⊗ I − I ⊗ J) Δ = (A⁻¹ ⊗ I) r / h`.
//! Where `A⁻¹ = T Λ T⁻¹` with `Λ` block-diagonal (a real eigenvalue `γ` as a 1 × 1 block, a
//! pair `α ± iβ` as the block `[[α, β], [−β, α]]`), the change of variables
//! `w = (T⁻¹ ⊗ I) Δ`, `ρ = (T⁻¹ ⊗ I) r` leaves one independent `n × n` system per block:
//!
//! ```text
//! real γ:        (γ/h · I − J) w = γ/h · ρ
//! pair α ± iβ:   ((α − iβ)/h · I − J) (w₁ + i w₂) = ((α ρ₁ + β ρ₂) + i (α ρ₂ − β ρ₁)) / h
//! ```
//!
//! For RADAU5 (`s = 3`: one real eigenvalue and one pair) that is one real and one complex
//! `n × n` factorisation instead of one real `3n × 3n`: about a fifth of the work, and
//! solves of about half. The iterates are those of the unsplit matrix, up to round-off.
//! Methods whose `A⁻¹` is not diagonalisable (SDIRK: one eigenvalue, thrice) have no split.

use super::sparse_lu::{NewtonLu, SparseOrder};
use nalgebra::{Complex, DMatrix, DVector};
use std::sync::Arc;

/// One diagonal block of `Λ`: its first row in `w` and its eigenvalue(s).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Block {
    /// A real eigenvalue `γ`, row `row`.
    Real { row: usize, gamma: f64 },
    /// The pair `α ± iβ`, rows `row` and `row + 1`.
    Pair { row: usize, alpha: f64, beta: f64 },
}

/// `A⁻¹ = T Λ T⁻¹` of a tableau, `Λ` as its blocks.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct EigenSplit {
    t: DMatrix<f64>,
    t_inv: DMatrix<f64>,
    blocks: Vec<Block>,
}

/// How far `T Λ T⁻¹` may be from `A⁻¹` (entry by entry, relative to the largest) for the
/// split to be used.
const RECONSTRUCTION_TOLERANCE: f64 = 1e-10;

impl EigenSplit {
    /// The split of the `s × s` matrix `a` (row-major); `None` where `a` is singular or
    /// `A⁻¹` has a repeated eigenvalue.
    pub fn of(a: &[f64], stages: usize) -> Option<EigenSplit> {
        let a_inv = DMatrix::from_row_slice(stages, stages, a).try_inverse()?;
        let mut eigenvalues: Vec<Complex<f64>> = a_inv
            .clone()
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect();
        // Real ones first, then one of each pair (the one with β > 0).
        eigenvalues.sort_by(|x, y| {
            x.im.abs()
                .total_cmp(&y.im.abs())
                .then(y.im.total_cmp(&x.im))
        });
        let scale = a_inv.amax();
        if !distinct(&eigenvalues, scale) {
            return None;
        }
        let mut columns: Vec<DVector<f64>> = Vec::with_capacity(stages);
        let mut blocks = Vec::new();
        for lambda in eigenvalues {
            let row = columns.len();
            if lambda.im.abs() <= 1e-12 * scale {
                let v = eigenvector(&a_inv, Complex::new(lambda.re, 0.0))?;
                columns.push(v.map(|z| z.re));
                blocks.push(Block::Real {
                    row,
                    gamma: lambda.re,
                });
            } else if lambda.im > 0.0 {
                let v = eigenvector(&a_inv, lambda)?;
                columns.push(v.map(|z| z.re));
                columns.push(v.map(|z| z.im));
                blocks.push(Block::Pair {
                    row,
                    alpha: lambda.re,
                    beta: lambda.im,
                });
            }
        }
        if columns.len() != stages {
            return None;
        }
        let t = DMatrix::from_columns(&columns);
        let t_inv = t.clone().try_inverse()?;
        let split = EigenSplit { t, t_inv, blocks };
        let error = (&split.t * split.lambda() * &split.t_inv - &a_inv).amax();
        (error <= RECONSTRUCTION_TOLERANCE * scale).then_some(split)
    }

    /// `Λ`, block-diagonal.
    fn lambda(&self) -> DMatrix<f64> {
        let s = self.t.nrows();
        let mut m = DMatrix::zeros(s, s);
        for block in &self.blocks {
            match *block {
                Block::Real { row, gamma } => m[(row, row)] = gamma,
                Block::Pair { row, alpha, beta } => {
                    m[(row, row)] = alpha;
                    m[(row, row + 1)] = beta;
                    m[(row + 1, row)] = -beta;
                    m[(row + 1, row + 1)] = alpha;
                }
            }
        }
        m
    }

    /// The factored blocks for the Jacobian `jacobian` (`n × n`, row-major) and the
    /// sub-step length `h`.
    pub fn factor(
        &self,
        jacobian: &[f64],
        n: usize,
        h: f64,
        order: Option<&Arc<SparseOrder>>,
    ) -> SplitMatrix {
        let factors = self
            .blocks
            .iter()
            .map(|block| match *block {
                Block::Real { gamma, .. } => BlockFactor::Real(NewtonLu::factor(
                    order,
                    shifted(jacobian, n, gamma / h, |v| v),
                    n,
                )),
                Block::Pair { alpha, beta, .. } => BlockFactor::Pair(NewtonLu::factor(
                    order,
                    shifted(jacobian, n, Complex::new(alpha / h, -beta / h), |v| {
                        Complex::new(v, 0.0)
                    }),
                    n,
                )),
            })
            .collect();
        SplitMatrix {
            factors,
            scratch: Scratch {
                n,
                h,
                work: vec![0.0; self.t.nrows() * n],
                real: vec![0.0; 2 * n],
                complex: vec![Complex::new(0.0, 0.0); 2 * n],
            },
        }
    }

    /// `out = (M ⊗ I) v` for an `s × s` matrix `m` and `v` stage by stage (`s × n`).
    fn apply(m: &DMatrix<f64>, v: &[f64], out: &mut [f64], n: usize) {
        let s = m.nrows();
        for i in 0..s {
            let row = &mut out[i * n..(i + 1) * n];
            row.fill(0.0);
            for j in 0..s {
                let factor = m[(i, j)];
                for (o, x) in row.iter_mut().zip(&v[j * n..(j + 1) * n]) {
                    *o += factor * x;
                }
            }
        }
    }
}

/// Whether no two eigenvalues are closer than a millionth of `scale`.
fn distinct(eigenvalues: &[Complex<f64>], scale: f64) -> bool {
    eigenvalues.iter().enumerate().all(|(i, x)| {
        eigenvalues[i + 1..]
            .iter()
            .all(|y| (x - y).norm() > 1e-6 * scale)
    })
}

/// A null vector of `m − λ I` with its last entry 1: the other entries solve the first
/// `s − 1` equations. `None` where they are singular (a repeated eigenvalue).
fn eigenvector(m: &DMatrix<f64>, lambda: Complex<f64>) -> Option<DVector<Complex<f64>>> {
    let s = m.nrows();
    let shifted = DMatrix::from_fn(s, s, |r, c| {
        Complex::new(m[(r, c)], 0.0)
            - if r == c {
                lambda
            } else {
                Complex::new(0.0, 0.0)
            }
    });
    let k = s - 1;
    let lead = shifted.view((0, 0), (k, k)).into_owned();
    let rhs = -shifted.view((0, k), (k, 1)).into_owned();
    let head = if k == 0 {
        DMatrix::zeros(0, 1)
    } else {
        lead.lu().solve(&rhs)?
    };
    Some(DVector::from_fn(s, |r, _| {
        if r < k {
            head[(r, 0)]
        } else {
            Complex::new(1.0, 0.0)
        }
    }))
}

/// `shift · I − J` over the scalar `T`, row-major; an entry of `J` that is not finite (a
/// term like `|x|^0.33` at `x = 0`) is left out: the matrix only steers the iteration.
fn shifted<T: nalgebra::ComplexField + Copy>(
    jacobian: &[f64],
    n: usize,
    shift: T,
    from: impl Fn(f64) -> T,
) -> Vec<T> {
    jacobian
        .iter()
        .enumerate()
        .map(|(k, &d)| {
            let d = from(if d.is_finite() { d } else { 0.0 });
            if k / n == k % n {
                shift - d
            } else {
                -d
            }
        })
        .collect()
}

/// The LU factors of one block of the split Newton matrix (`None`: the block is singular).
#[derive(Debug, Clone)]
enum BlockFactor {
    Real(Option<NewtonLu<f64>>),
    Pair(Option<NewtonLu<Complex<f64>>>),
}

/// The split Newton matrix of one Jacobian and sub-step length, factored, with its scratch.
#[derive(Debug, Clone)]
pub(crate) struct SplitMatrix {
    factors: Vec<BlockFactor>,
    scratch: Scratch,
}

/// What a solve with a [`SplitMatrix`] works in: the transformed vector `w` (`s × n`) and
/// one block's right-hand side.
#[derive(Debug, Clone)]
struct Scratch {
    n: usize,
    h: f64,
    work: Vec<f64>,
    /// A real block's right-hand side and its solve's scratch, `n` each.
    real: Vec<f64>,
    /// A pair's complex right-hand side and its solve's scratch, `n` each.
    complex: Vec<Complex<f64>>,
}

impl SplitMatrix {
    /// Solves `(I − h A ⊗ J) Δ = r` in place (`r`, then `Δ`, stage by stage); false where a
    /// block is singular.
    pub fn solve_mut(&mut self, split: &EigenSplit, r: &mut [f64]) -> bool {
        let scratch = &mut self.scratch;
        let n = scratch.n;
        EigenSplit::apply(&split.t_inv, r, &mut scratch.work, n);
        for (block, factor) in split.blocks.iter().zip(&self.factors) {
            let solved = match (*block, factor) {
                (Block::Real { row, gamma }, BlockFactor::Real(Some(lu))) => {
                    scratch.solve_real(lu, row, gamma);
                    true
                }
                (Block::Pair { row, alpha, beta }, BlockFactor::Pair(Some(lu))) => {
                    scratch.solve_pair(lu, row, alpha, beta);
                    true
                }
                _ => false,
            };
            if !solved {
                return false;
            }
        }
        EigenSplit::apply(&split.t, &scratch.work, r, n);
        true
    }
}

impl Scratch {
    /// `(γ/h · I − J) w = γ/h · ρ` for rows `row` of `self.work`, in place.
    fn solve_real(&mut self, lu: &NewtonLu<f64>, row: usize, gamma: f64) {
        let n = self.n;
        let g = gamma / self.h;
        let rho = &mut self.work[row * n..(row + 1) * n];
        let (rhs, scratch) = self.real.split_at_mut(n);
        for (v, x) in rho.iter_mut().zip(rhs.iter_mut()) {
            *x = g * *v;
        }
        lu.solve(rhs, scratch);
        rho.copy_from_slice(rhs);
    }

    /// `((α − iβ)/h · I − J)(w₁ + i w₂) = ((α ρ₁ + β ρ₂) + i (α ρ₂ − β ρ₁)) / h` for rows
    /// `row` and `row + 1` of `self.work`, in place.
    fn solve_pair(&mut self, lu: &NewtonLu<Complex<f64>>, row: usize, alpha: f64, beta: f64) {
        let n = self.n;
        let (a, b) = (alpha / self.h, beta / self.h);
        let (first, second) = self.work[row * n..(row + 2) * n].split_at_mut(n);
        let (rhs, scratch) = self.complex.split_at_mut(n);
        for ((v, r1), r2) in rhs.iter_mut().zip(first.iter()).zip(second.iter()) {
            *v = Complex::new(a * r1 + b * r2, a * r2 - b * r1);
        }
        lu.solve(rhs, scratch);
        for ((v, w1), w2) in rhs.iter().zip(first.iter_mut()).zip(second.iter_mut()) {
            *w1 = v.re;
            *w2 = v.im;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::model::Integrator;
    use crate::model::implicit::Tableau;

    /// The split solve agrees with the dense `3n × 3n` one, for RADAU5 and RADAU3.
    #[test]
    fn split_solve_matches_the_dense_newton_matrix() {
        for integrator in [
            Integrator::Radau3,
            Integrator::Radau5,
            Integrator::BackwardEuler,
        ] {
            let tableau = Tableau::of(integrator).unwrap();
            let s = tableau.stages;
            let split = EigenSplit::of(&tableau.a, s).expect("a split");
            let n = 4;
            let h = 0.7;
            let jacobian: Vec<f64> = (0..n * n)
                .map(|k| ((k * 37 % 11) as f64 - 5.0) * 0.9)
                .collect();
            let dense = DMatrix::from_fn(s * n, s * n, |r, c| {
                let (i, k, j, l) = (r / n, r % n, c / n, c % n);
                let identity = if r == c { 1.0 } else { 0.0 };
                identity - h * tableau.a[i * s + j] * jacobian[k * n + l]
            });
            let rhs: Vec<f64> = (0..s * n).map(|k| (k as f64 * 0.37).sin()).collect();
            let expected = dense.lu().solve(&DVector::from_column_slice(&rhs)).unwrap();
            let rows: Vec<Vec<usize>> = (0..n)
                .map(|r| (0..n).filter(|&c| jacobian[r * n + c] != 0.0).collect())
                .collect();
            let order = Arc::new(SparseOrder::of(n, &rows));
            for order in [None, Some(&order)] {
                let mut got = rhs.clone();
                assert!(split
                    .factor(&jacobian, n, h, order)
                    .solve_mut(&split, &mut got));
                for (g, e) in got.iter().zip(expected.iter()) {
                    assert!(
                        (g - e).abs() < 1e-10 * (1.0 + e.abs()),
                        "{integrator:?}: {g} vs {e}"
                    );
                }
            }
        }
    }

    /// SDIRK's `A⁻¹` has one eigenvalue three times: no split.
    #[test]
    fn sdirk_has_no_split() {
        let tableau = Tableau::of(Integrator::Sdirk3).unwrap();
        assert!(EigenSplit::of(&tableau.a, tableau.stages).is_none());
    }
}
