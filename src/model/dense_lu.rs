//! LU factors of a small dense matrix, real or complex, kept column by column for the
//! triangular solves that an implicit step's Newton iteration repeats: each solved unknown,
//! times its column, is subtracted from the rest in one loop over contiguous memory, with
//! no dependence from one entry to the next and no allocation. (nalgebra's generic LU solves took a fifth of a
//! GreenLight season's time; a dot product per row, a chain of additions, 4 % more than
//! these columns: `docs/benchmarks.md`.)

use nalgebra::Complex;
use std::ops::{Add, Div, Mul, Sub};

/// The numbers a [`DenseLu`] works in.
pub(crate) trait Scalar:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    /// A size for choosing pivots (`|re| + |im|` for a complex number).
    fn magnitude(self) -> f64;
}

impl Scalar for f64 {
    const ZERO: f64 = 0.0;
    const ONE: f64 = 1.0;
    fn magnitude(self) -> f64 {
        self.abs()
    }
}

impl Scalar for Complex<f64> {
    const ZERO: Complex<f64> = Complex::new(0.0, 0.0);
    const ONE: Complex<f64> = Complex::new(1.0, 0.0);
    fn magnitude(self) -> f64 {
        self.re.abs() + self.im.abs()
    }
}

/// `P M = L U` of an `n × n` matrix by Gaussian elimination with partial pivoting: `L`
/// (unit diagonal) below the diagonal of `columns`, `U` on and above it, column by column,
/// and the reciprocals of `U`'s diagonal apart.
#[derive(Debug, Clone)]
pub(crate) struct DenseLu<T> {
    n: usize,
    columns: Vec<T>,
    inverse_diagonal: Vec<T>,
    /// Row `i` of `P M` is row `rows[i]` of `M`.
    rows: Vec<usize>,
}

impl<T: Scalar> DenseLu<T> {
    /// Factors the row-major `n × n` matrix `m`; `None` where a pivot is zero or not finite.
    pub fn factor(mut m: Vec<T>, n: usize) -> Option<DenseLu<T>> {
        debug_assert_eq!(m.len(), n * n);
        let mut rows: Vec<usize> = (0..n).collect();
        let mut inverse_diagonal = vec![T::ZERO; n];
        for k in 0..n {
            let (pivot, size) = (k..n)
                .map(|r| (r, m[r * n + k].magnitude()))
                .fold((k, -1.0), |best, c| if c.1 > best.1 { c } else { best });
            if !(size > 0.0 && size.is_finite()) {
                return None;
            }
            if pivot != k {
                for c in 0..n {
                    m.swap(k * n + c, pivot * n + c);
                }
                rows.swap(k, pivot);
            }
            let inverse = T::ONE / m[k * n + k];
            inverse_diagonal[k] = inverse;
            let (upper, lower) = m.split_at_mut((k + 1) * n);
            let pivot_row = &upper[k * n + k + 1..k * n + n];
            for row in lower.chunks_exact_mut(n) {
                let factor = row[k] * inverse;
                row[k] = factor;
                for (x, &p) in row[k + 1..].iter_mut().zip(pivot_row) {
                    *x = *x - factor * p;
                }
            }
        }
        let columns = (0..n * n).map(|k| m[(k % n) * n + k / n]).collect();
        Some(DenseLu {
            n,
            columns,
            inverse_diagonal,
            rows,
        })
    }

    /// Solves `M x = b`: `b` in `rhs` on entry, `x` on return; `scratch` holds `n` values.
    pub fn solve(&self, rhs: &mut [T], scratch: &mut [T]) {
        let n = self.n;
        for (s, &r) in scratch.iter_mut().zip(&self.rows) {
            *s = rhs[r];
        }
        for k in 0..n {
            let x = scratch[k];
            let column = &self.columns[k * n + k + 1..k * n + n];
            for (s, &l) in scratch[k + 1..n].iter_mut().zip(column) {
                *s = *s - l * x;
            }
        }
        for k in (0..n).rev() {
            let x = scratch[k] * self.inverse_diagonal[k];
            scratch[k] = x;
            let column = &self.columns[k * n..k * n + k];
            for (s, &u) in scratch[..k].iter_mut().zip(column) {
                *s = *s - u * x;
            }
        }
        rhs.copy_from_slice(&scratch[..n]);
    }

    /// Solves `M X = B` for `k` right-hand sides at once: `B` row-major `n × k` in `rhs` on
    /// entry, `X` on return. Each elimination step is a multiple of one row of `B` taken
    /// from another, over contiguous memory (where `n` single solves would read `B` by
    /// columns).
    pub fn solve_rows(&self, rhs: &mut [T], k: usize) {
        let n = self.n;
        debug_assert_eq!(rhs.len(), n * k);
        let mut permuted = vec![T::ZERO; n * k];
        for (row, &r) in permuted.chunks_exact_mut(k).zip(&self.rows) {
            row.copy_from_slice(&rhs[r * k..(r + 1) * k]);
        }
        for j in 0..n {
            let (done, rest) = permuted.split_at_mut((j + 1) * k);
            let pivot = &done[j * k..];
            for (i, row) in rest.chunks_exact_mut(k).enumerate() {
                let l = self.columns[j * n + j + 1 + i];
                for (x, &p) in row.iter_mut().zip(pivot) {
                    *x = *x - l * p;
                }
            }
        }
        for j in (0..n).rev() {
            let (before, from) = permuted.split_at_mut(j * k);
            let pivot = &mut from[..k];
            let inverse = self.inverse_diagonal[j];
            for p in pivot.iter_mut() {
                *p = *p * inverse;
            }
            for (i, row) in before.chunks_exact_mut(k).enumerate() {
                let u = self.columns[j * n + i];
                for (x, &p) in row.iter_mut().zip(pivot.iter()) {
                    *x = *x - u * p;
                }
            }
        }
        rhs.copy_from_slice(&permuted);
    }

    /// Solves `Mᵀ x = b` with the same factors (`Mᵀ = Uᵀ Lᵀ P`): `b` in `rhs` on entry, `x`
    /// on return; `scratch` holds `n` values. Each unknown is a dot product with a column
    /// of the factors, contiguous in memory.
    pub fn solve_transpose(&self, rhs: &mut [T], scratch: &mut [T]) {
        let n = self.n;
        // Uᵀ y = b, from the first unknown.
        for k in 0..n {
            let column = &self.columns[k * n..k * n + k];
            let sum = column
                .iter()
                .zip(&scratch[..k])
                .fold(rhs[k], |sum, (&u, &y)| sum - u * y);
            scratch[k] = sum * self.inverse_diagonal[k];
        }
        // Lᵀ z = y, from the last unknown (unit diagonal).
        for k in (0..n).rev() {
            let column = &self.columns[k * n + k + 1..k * n + n];
            let sum = column
                .iter()
                .zip(&scratch[k + 1..n])
                .fold(scratch[k], |sum, (&l, &z)| sum - l * z);
            scratch[k] = sum;
        }
        // P x = z.
        for (&r, &z) in self.rows.iter().zip(&scratch[..n]) {
            rhs[r] = z;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn matrix(n: usize, seed: usize) -> Vec<f64> {
        (0..n * n)
            .map(|k| {
                (((k + seed) * 37 % 23) as f64 - 11.0) * 0.3
                    + if k % (n + 1) == 0 { 0.1 } else { 0.0 }
            })
            .collect()
    }

    /// Real and complex solves agree with nalgebra's LU, pivoting included.
    #[test]
    fn solves_agree_with_nalgebra() {
        for n in [1, 2, 5, 28] {
            let m = matrix(n, n);
            let b: Vec<f64> = (0..n).map(|k| (k as f64 * 0.7).cos()).collect();
            let expected = DMatrix::from_row_slice(n, n, &m)
                .lu()
                .solve(&nalgebra::DVector::from_column_slice(&b))
                .unwrap();
            let lu = DenseLu::factor(m.clone(), n).unwrap();
            let (mut x, mut scratch) = (b.clone(), vec![0.0; n]);
            lu.solve(&mut x, &mut scratch);
            for (g, e) in x.iter().zip(expected.iter()) {
                assert!(
                    (g - e).abs() <= 1e-11 * (1.0 + e.abs()),
                    "n = {n}: {g} vs {e}"
                );
            }

            let shift = Complex::new(0.3, -1.7);
            let mc: Vec<Complex<f64>> = m
                .iter()
                .enumerate()
                .map(|(k, &v)| {
                    Complex::new(v, 0.0)
                        + if k % (n + 1) == 0 {
                            shift
                        } else {
                            Complex::ZERO
                        }
                })
                .collect();
            let bc: Vec<Complex<f64>> = b.iter().map(|&v| Complex::new(v, -v)).collect();
            let expected = DMatrix::from_row_slice(n, n, &mc)
                .lu()
                .solve(&nalgebra::DVector::from_column_slice(&bc))
                .unwrap();
            let lu = DenseLu::factor(mc, n).unwrap();
            let (mut x, mut scratch) = (bc, vec![Complex::ZERO; n]);
            lu.solve(&mut x, &mut scratch);
            for (g, e) in x.iter().zip(expected.iter()) {
                assert!(
                    (g - e).norm() <= 1e-11 * (1.0 + e.norm()),
                    "n = {n}: {g} vs {e}"
                );
            }
        }
    }

    /// `Mᵀ x = b` by the factors of `M` agrees with nalgebra's LU of `Mᵀ`, pivoting included.
    #[test]
    fn transposed_solves_agree_with_nalgebra() {
        for n in [1, 2, 5, 28, 84] {
            let m = matrix(n, n + 3);
            let b: Vec<f64> = (0..n).map(|k| (k as f64 * 0.3).sin() + 0.5).collect();
            let expected = DMatrix::from_row_slice(n, n, &m)
                .transpose()
                .lu()
                .solve(&nalgebra::DVector::from_column_slice(&b))
                .unwrap();
            let lu = DenseLu::factor(m, n).unwrap();
            let (mut x, mut scratch) = (b, vec![0.0; n]);
            lu.solve_transpose(&mut x, &mut scratch);
            for (g, e) in x.iter().zip(expected.iter()) {
                assert!(
                    (g - e).abs() <= 1e-10 * (1.0 + e.abs()),
                    "n = {n}: {g} vs {e}"
                );
            }
        }
    }

    /// Many right-hand sides at once give what one solve each gives, to round-off.
    #[test]
    fn row_solves_agree_with_single_solves() {
        for (n, k) in [(1, 1), (5, 3), (28, 28)] {
            let m = matrix(n, n + 1);
            let lu = DenseLu::factor(m, n).unwrap();
            let b: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.37).sin()).collect();
            let mut all = b.clone();
            lu.solve_rows(&mut all, k);
            let (mut column, mut scratch) = (vec![0.0; n], vec![0.0; n]);
            for c in 0..k {
                for r in 0..n {
                    column[r] = b[r * k + c];
                }
                lu.solve(&mut column, &mut scratch);
                for r in 0..n {
                    let g = all[r * k + c];
                    assert!(
                        (g - column[r]).abs() <= 1e-12 * (1.0 + column[r].abs()),
                        "{g} vs {}",
                        column[r]
                    );
                }
            }
        }
    }

    /// A singular matrix is refused, not factored into infinities.
    #[test]
    fn singular_matrices_are_refused() {
        assert!(DenseLu::factor(vec![1.0, 2.0, 2.0, 4.0], 2).is_none());
        assert!(DenseLu::factor(vec![f64::NAN, 0.0, 0.0, 1.0], 2).is_none());
    }
}
