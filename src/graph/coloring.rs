//! Columns of a sparse Jacobian gathered into groups that share no row (Curtis, Powell &
//! Reid 1974): one forward pass seeds a whole group in one lane, and each structural
//! non-zero is read back from the lane of its column's group. A Jacobian with `n`
//! columns costs as many passes as it has groups, not columns.

use super::Sparsity;

/// A partition of a Jacobian's columns into groups whose columns share no row.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnGroups {
    group_of: Vec<usize>,
    n_groups: usize,
}

impl ColumnGroups {
    /// Greedy, columns in order: each joins the first group in which no column shares a
    /// row with it.
    ///
    /// ```
    /// use ghm::graph::{ColumnGroups, Graph, Sparsity};
    ///
    /// // (x + y, y + z): x and z share no output, so they share a group.
    /// let mut g = Graph::new();
    /// let (x, y, z) = (g.var(0), g.var(1), g.var(2));
    /// let (a, b) = (g.add(x, y), g.add(y, z));
    /// let tape = g.compile(&[a, b], 3);
    /// let groups = ColumnGroups::of(&Sparsity::of_jacobian(&tape, &[0, 1, 2]));
    /// assert_eq!(groups.n_groups(), 2);
    /// assert_eq!(groups.group_of(0), groups.group_of(2));
    /// ```
    pub fn of(pattern: &Sparsity) -> ColumnGroups {
        let mut rows_of = vec![Vec::new(); pattern.n];
        for (row, cols) in pattern.jacobian.iter().enumerate() {
            for &c in cols {
                rows_of[c].push(row);
            }
        }
        const UNSET: usize = usize::MAX;
        let mut group_of = vec![UNSET; pattern.n];
        let mut n_groups = 0;
        // `taken[g] == c + 1`: group g holds a column that shares a row with column c.
        let mut taken: Vec<usize> = Vec::new();
        for c in 0..pattern.n {
            for &row in &rows_of[c] {
                for &other in &pattern.jacobian[row] {
                    if group_of[other] != UNSET {
                        taken[group_of[other]] = c + 1;
                    }
                }
            }
            let g = (0..n_groups)
                .find(|&g| taken[g] != c + 1)
                .unwrap_or_else(|| {
                    n_groups += 1;
                    taken.push(0);
                    n_groups - 1
                });
            group_of[c] = g;
        }
        ColumnGroups { group_of, n_groups }
    }

    /// How many groups: the forward directions one Jacobian takes.
    pub fn n_groups(&self) -> usize {
        self.n_groups
    }

    /// The group of column `col`.
    pub fn group_of(&self, col: usize) -> usize {
        self.group_of[col]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No two columns of a group share a row, on a banded pattern.
    #[test]
    fn grouped_columns_share_no_row() {
        let n = 10;
        let jacobian: Vec<Vec<usize>> = (0..n)
            .map(|r: usize| (r.saturating_sub(1)..(r + 2).min(n)).collect())
            .collect();
        let pattern = Sparsity {
            n,
            jacobian,
            hessian: Vec::new(),
        };
        let groups = ColumnGroups::of(&pattern);
        assert_eq!(groups.n_groups(), 3, "a tridiagonal pattern takes three");
        for cols in &pattern.jacobian {
            for (i, &a) in cols.iter().enumerate() {
                for &b in &cols[i + 1..] {
                    assert_ne!(groups.group_of(a), groups.group_of(b), "{a} and {b}");
                }
            }
        }
    }
}
