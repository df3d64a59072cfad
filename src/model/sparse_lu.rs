//! LU factors of a small sparse matrix whose pattern is known before its values: the
//! simplified Newton matrices of an implicit step, `σ I − J`, where `J` has the model's
//! fixed Jacobian pattern (GreenLight's: 138 of 784 entries).
//!
//! The order of elimination is chosen once from the pattern (greedy minimum degree on its
//! symmetric closure) and the fill it makes is found once; each matrix is then factored
//! and solved over those entries alone, without row exchanges. A pivot smaller than a
//! tenth of the largest entry below it (threshold pivoting's test) refuses the
//! factorisation, and the caller falls back to [`DenseLu`](super::dense_lu::DenseLu) with
//! partial pivoting ([`NewtonLu`]).

use super::dense_lu::{DenseLu, Scalar};
use std::ops::Range;
use std::sync::Arc;

/// How much smaller than the largest entry below it, in its column, a pivot may be.
const PIVOT_THRESHOLD: f64 = 0.1;

/// The order of elimination of one pattern, and where its factors may be non-zero.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SparseOrder {
    n: usize,
    /// Position `k` of the elimination is row and column `order[k]` of the matrix.
    order: Vec<usize>,
    /// The entries of the matrix (row-major) that may be non-zero; others must be zero.
    pattern: Vec<bool>,
    /// `later_rows[later_start[k]..later_start[k + 1]]`: the positions `i > k` where `L`'s
    /// column `k` (and, the structure being symmetric, `U`'s row `k`) may be non-zero.
    later_start: Vec<usize>,
    later_rows: Vec<usize>,
    /// The same for `U`'s column `j`: the positions `k < j` where it may be non-zero.
    earlier_start: Vec<usize>,
    earlier_rows: Vec<usize>,
}

impl SparseOrder {
    /// The order of the `n × n` pattern whose row `r` may be non-zero in the columns
    /// `rows[r]` (the diagonal is always taken as non-zero).
    pub fn of(n: usize, rows: &[Vec<usize>]) -> SparseOrder {
        assert!(
            rows.len() <= n && rows.iter().flatten().all(|&c| c < n),
            "a pattern of {} rows with a column past {n}",
            rows.len()
        );
        let mut pattern = vec![false; n * n];
        for (r, columns) in rows.iter().enumerate() {
            for &c in columns {
                pattern[r * n + c] = true;
            }
        }
        for k in 0..n {
            pattern[k * n + k] = true;
        }
        let (order, neighbours_at_elimination): (Vec<usize>, Vec<Vec<usize>>) =
            minimum_degree(n, &pattern).into_iter().unzip();
        let mut position = vec![0; n];
        for (k, &v) in order.iter().enumerate() {
            position[v] = k;
        }
        let later: Vec<Vec<usize>> = neighbours_at_elimination
            .iter()
            .map(|neighbours| {
                let mut positions: Vec<usize> = neighbours.iter().map(|&v| position[v]).collect();
                positions.sort_unstable();
                positions
            })
            .collect();
        let mut earlier = vec![Vec::new(); n];
        for (k, rows) in later.iter().enumerate() {
            for &j in rows {
                earlier[j].push(k);
            }
        }
        let (later_start, later_rows) = flatten(&later);
        let (earlier_start, earlier_rows) = flatten(&earlier);
        SparseOrder {
            n,
            order,
            pattern,
            later_start,
            later_rows,
            earlier_start,
            earlier_rows,
        }
    }

    /// Entries of `L` and of `U` off the diagonal, each: what a solve runs over.
    pub fn off_diagonal_entries(&self) -> usize {
        self.later_rows.len()
    }

    /// Where `L`'s column `k` lies in `later_rows` (and in a factor's `lower`).
    fn later_range(&self, k: usize) -> Range<usize> {
        self.later_start[k]..self.later_start[k + 1]
    }

    /// Where `U`'s column `j` lies in `earlier_rows` (and in a factor's `upper`).
    fn earlier_range(&self, j: usize) -> Range<usize> {
        self.earlier_start[j]..self.earlier_start[j + 1]
    }

    fn later(&self, k: usize) -> &[usize] {
        &self.later_rows[self.later_range(k)]
    }

    fn earlier(&self, j: usize) -> &[usize] {
        &self.earlier_rows[self.earlier_range(j)]
    }
}

/// Greedy minimum degree on the symmetric closure of the `n × n` `pattern` (row-major):
/// each vertex in the order of elimination (the lowest index among the least connected),
/// with the vertices still live beside it then, which become a clique (the fill).
fn minimum_degree(n: usize, pattern: &[bool]) -> Vec<(usize, Vec<usize>)> {
    let mut adjacent: Vec<Vec<bool>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| i != j && (pattern[i * n + j] || pattern[j * n + i]))
                .collect()
        })
        .collect();
    let mut eliminated = vec![false; n];
    let mut eliminations = Vec::with_capacity(n);
    for _ in 0..n {
        let live_neighbours = |v: usize| -> Vec<usize> {
            (0..n)
                .filter(|&j| adjacent[v][j] && !eliminated[j])
                .collect()
        };
        let Some((v, neighbours)) = (0..n)
            .filter(|&v| !eliminated[v])
            .map(|v| (v, live_neighbours(v)))
            .min_by_key(|(_, neighbours)| neighbours.len())
        else {
            break;
        };
        for &a in &neighbours {
            for &b in &neighbours {
                if a != b {
                    adjacent[a][b] = true;
                }
            }
        }
        eliminated[v] = true;
        eliminations.push((v, neighbours));
    }
    eliminations
}

fn flatten(lists: &[Vec<usize>]) -> (Vec<usize>, Vec<usize>) {
    let mut start = Vec::with_capacity(lists.len() + 1);
    start.push(0);
    let mut flat = Vec::new();
    for list in lists {
        flat.extend_from_slice(list);
        start.push(flat.len());
    }
    (start, flat)
}

/// `M = Pᵀ L U P` of one matrix of a [`SparseOrder`]'s pattern (`P` its order).
#[derive(Debug, Clone)]
pub(crate) struct SparseLu<T> {
    order: Arc<SparseOrder>,
    /// `L`'s entries below the diagonal, column by column, as `order.later_rows`.
    lower: Vec<T>,
    /// `U`'s entries above the diagonal, column by column, as `order.earlier_rows`.
    upper: Vec<T>,
    inverse_diagonal: Vec<T>,
}

impl<T: Scalar> SparseLu<T> {
    /// Factors the row-major `n × n` matrix `m` in `order`; `None` where an entry outside
    /// the pattern is not zero or a pivot fails the threshold (or is zero or not finite).
    pub fn factor(order: &Arc<SparseOrder>, m: &[T]) -> Option<SparseLu<T>> {
        let n = order.n;
        debug_assert_eq!(m.len(), n * n);
        let outside = m
            .iter()
            .zip(&order.pattern)
            .any(|(v, &inside)| !inside && v.magnitude() != 0.0);
        if outside {
            return None;
        }
        let mut a: Vec<T> = (0..n * n)
            .map(|idx| m[order.order[idx / n] * n + order.order[idx % n]])
            .collect();
        let mut inverse_diagonal = Vec::with_capacity(n);
        for k in 0..n {
            let later = order.later(k);
            let pivot = a[k * n + k];
            let size = pivot.magnitude();
            // NaN, where elimination made one, refuses the factors (`max` would skip it).
            let largest = later
                .iter()
                .map(|&i| a[i * n + k].magnitude())
                .fold(0.0, |m: f64, x| {
                    if x.is_nan() || m.is_nan() {
                        f64::NAN
                    } else {
                        m.max(x)
                    }
                });
            if !(size.is_finite() && size > 0.0 && size >= PIVOT_THRESHOLD * largest) {
                return None;
            }
            let inverse = T::ONE / pivot;
            inverse_diagonal.push(inverse);
            for &i in later {
                let factor = a[i * n + k] * inverse;
                a[i * n + k] = factor;
                for &j in later {
                    a[i * n + j] = a[i * n + j] - factor * a[k * n + j];
                }
            }
        }
        let lower = (0..n)
            .flat_map(|k| order.later(k).iter().map(move |&i| (i, k)))
            .map(|(i, k)| a[i * n + k])
            .collect();
        let upper = (0..n)
            .flat_map(|j| order.earlier(j).iter().map(move |&k| (k, j)))
            .map(|(k, j)| a[k * n + j])
            .collect();
        Some(SparseLu {
            order: Arc::clone(order),
            lower,
            upper,
            inverse_diagonal,
        })
    }

    /// Solves `M x = b`: `b` in `rhs` on entry, `x` on return; `scratch` holds `n` values.
    pub fn solve(&self, rhs: &mut [T], scratch: &mut [T]) {
        let order = &*self.order;
        let n = order.n;
        for (s, &r) in scratch.iter_mut().zip(&order.order) {
            *s = rhs[r];
        }
        for k in 0..n {
            let x = scratch[k];
            let entries = &self.lower[order.later_range(k)];
            for (&i, &l) in order.later(k).iter().zip(entries) {
                scratch[i] = scratch[i] - l * x;
            }
        }
        for j in (0..n).rev() {
            let x = scratch[j] * self.inverse_diagonal[j];
            scratch[j] = x;
            let entries = &self.upper[order.earlier_range(j)];
            for (&k, &u) in order.earlier(j).iter().zip(entries) {
                scratch[k] = scratch[k] - u * x;
            }
        }
        for (&s, &r) in scratch.iter().zip(&order.order) {
            rhs[r] = s;
        }
    }
}

/// The factors of one simplified Newton matrix: sparse in the model's order where its
/// pivots allow, dense with partial pivoting otherwise.
#[derive(Debug, Clone)]
pub(crate) enum NewtonLu<T> {
    Sparse(SparseLu<T>),
    Dense(DenseLu<T>),
}

impl<T: Scalar> NewtonLu<T> {
    /// Factors the row-major `n × n` matrix `m`, sparse in `order` where there is one and
    /// its pivots allow; `None` where even partial pivoting finds a zero pivot.
    pub fn factor(order: Option<&Arc<SparseOrder>>, m: Vec<T>, n: usize) -> Option<NewtonLu<T>> {
        if let Some(sparse) = order.and_then(|order| SparseLu::factor(order, &m)) {
            return Some(NewtonLu::Sparse(sparse));
        }
        DenseLu::factor(m, n).map(NewtonLu::Dense)
    }

    /// Solves `M x = b`: `b` in `rhs` on entry, `x` on return; `scratch` holds `n` values.
    pub fn solve(&self, rhs: &mut [T], scratch: &mut [T]) {
        match self {
            NewtonLu::Sparse(lu) => lu.solve(rhs, scratch),
            NewtonLu::Dense(lu) => lu.solve(rhs, scratch),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Complex;

    /// A matrix of the pattern `rows`, diagonally heavy by `shift`.
    fn matrix(n: usize, rows: &[Vec<usize>], shift: f64) -> Vec<f64> {
        let mut m = vec![0.0; n * n];
        for (r, columns) in rows.iter().enumerate() {
            for &c in columns {
                m[r * n + c] = ((r * 7 + c * 3) % 11) as f64 * 0.1 - 0.5;
            }
        }
        for k in 0..n {
            m[k * n + k] += shift;
        }
        m
    }

    fn arrow_and_chain(n: usize) -> Vec<Vec<usize>> {
        // Row 0 reads everything, every row reads 0, and a chain links neighbours.
        (0..n)
            .map(|r| {
                let mut c = vec![0, r];
                if r + 1 < n {
                    c.push(r + 1);
                }
                if r == 0 {
                    c.extend(1..n);
                }
                c.sort_unstable();
                c.dedup();
                c
            })
            .collect()
    }

    fn residual(m: &[f64], n: usize, x: &[f64], b: &[f64]) -> f64 {
        (0..n)
            .map(|r| ((0..n).map(|c| m[r * n + c] * x[c]).sum::<f64>() - b[r]).abs())
            .fold(0.0, f64::max)
    }

    /// The elimination order keeps an arrow's dense row and column last, so its factors
    /// fill no more than the pattern, and the solve is as exact as a dense one.
    #[test]
    fn an_arrow_is_factored_without_fill_and_solved() {
        let n = 12;
        let rows = arrow_and_chain(n);
        let order = Arc::new(SparseOrder::of(n, &rows));
        let pattern_off_diagonal = rows.iter().map(Vec::len).sum::<usize>() - n;
        assert!(2 * order.off_diagonal_entries() <= pattern_off_diagonal + 2 * n);
        let m = matrix(n, &rows, 4.0);
        let b: Vec<f64> = (0..n).map(|k| (k as f64).sin()).collect();
        let lu = SparseLu::factor(&order, &m).expect("a diagonally heavy matrix factors");
        let (mut x, mut scratch) = (b.clone(), vec![0.0; n]);
        lu.solve(&mut x, &mut scratch);
        assert!(residual(&m, n, &x, &b) < 1e-12);
    }

    /// Complex matrices (RADAU5's pair) are solved the same way.
    #[test]
    fn complex_matrices_are_solved() {
        let n = 9;
        let rows = arrow_and_chain(n);
        let order = Arc::new(SparseOrder::of(n, &rows));
        let m: Vec<Complex<f64>> = matrix(n, &rows, 2.0)
            .iter()
            .enumerate()
            .map(|(k, &v)| Complex::new(v, if k % (n + 1) == 0 { -1.5 } else { 0.0 }))
            .collect();
        let b: Vec<Complex<f64>> = (0..n).map(|k| Complex::new(1.0, k as f64)).collect();
        let lu = SparseLu::factor(&order, &m).expect("factors");
        let (mut x, mut scratch) = (b.clone(), vec![Complex::new(0.0, 0.0); n]);
        lu.solve(&mut x, &mut scratch);
        for r in 0..n {
            let row: Complex<f64> = (0..n).map(|c| m[r * n + c] * x[c]).sum();
            assert!((row - b[r]).norm() < 1e-12, "row {r}");
        }
    }

    /// A small pivot, or an entry outside the pattern, is refused by the sparse factors
    /// and left to partial pivoting, which solves it.
    #[test]
    fn small_pivots_and_entries_outside_the_pattern_fall_back_to_pivoting() {
        let n = 3;
        let rows = vec![vec![0, 1], vec![0, 1], vec![2]];
        let order = Arc::new(SparseOrder::of(n, &rows));
        // [[1e-9, 1], [1, 1], [0, 0, 1]]: the first pivot is tiny whichever comes first.
        let m = vec![1e-9, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        assert!(SparseLu::factor(&order, &m).is_none());
        let mut outside = matrix(n, &rows, 3.0);
        outside[2 * n] = 0.5;
        assert!(SparseLu::factor(&order, &outside).is_none());
        let mut undefined = matrix(n, &rows, 3.0);
        undefined[n] = f64::NAN;
        assert!(SparseLu::factor(&order, &undefined).is_none());
        for m in [m, outside] {
            let lu = NewtonLu::factor(Some(&order), m.clone(), n).expect("pivoting solves it");
            assert!(matches!(lu, NewtonLu::Dense(_)));
            let b = [1.0, 2.0, 3.0];
            let (mut x, mut scratch) = (b.to_vec(), vec![0.0; n]);
            lu.solve(&mut x, &mut scratch);
            assert!(residual(&m, n, &x, &b) < 1e-9);
        }
    }
}
