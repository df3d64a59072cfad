//! Sparsity of a tape's derivatives, read off the graph: which chosen inputs each output
//! depends on (Jacobian pattern) and which pairs of inputs meet in a nonlinear operation
//! (Hessian pattern of any weighted sum of the outputs).

use super::{Op, Tape};

/// Structural non-zeros of the Jacobian and of the Hessian of a weighted output sum.
#[derive(Debug, Clone, PartialEq)]
pub struct Sparsity {
    /// Number of chosen inputs (columns).
    pub n: usize,
    /// `jacobian[row]` = the columns output `row` depends on, sorted.
    pub jacobian: Vec<Vec<usize>>,
    /// Lower-triangle pairs `(i, j)`, `i >= j`, sorted.
    pub hessian: Vec<(usize, usize)>,
}

type Bits = Vec<u64>;

fn union(a: &Bits, b: &Bits) -> Bits {
    a.iter().zip(b).map(|(x, y)| x | y).collect()
}

fn members(b: &Bits) -> Vec<usize> {
    let mut out = Vec::new();
    for (w, &word) in b.iter().enumerate() {
        let mut m = word;
        while m != 0 {
            let t = m.trailing_zeros() as usize;
            out.push(w * 64 + t);
            m &= m - 1;
        }
    }
    out
}

impl Sparsity {
    /// The patterns of `tape` with respect to inputs `wrt`.
    ///
    /// ```
    /// use ghm::graph::{Graph, Op, Sparsity};
    ///
    /// // (x y + z, exp z): x and y meet in a product, z only in exp.
    /// let mut g = Graph::new();
    /// let (x, y, z) = (g.var(0), g.var(1), g.var(2));
    /// let xy = g.mul(x, y);
    /// let f = g.add(xy, z);
    /// let e = g.apply(Op::Exp, &[z]);
    /// let tape = g.compile(&[f, e], 3);
    /// let s = Sparsity::of(&tape, &[0, 1, 2]);
    /// assert_eq!(s.jacobian, vec![vec![0, 1, 2], vec![2]]);
    /// assert_eq!(s.jacobian_nnz(), 4);
    /// assert_eq!(s.hessian, vec![(1, 0), (2, 2)]); // ∂²/∂y∂x and ∂²/∂z²
    /// ```
    pub fn of(tape: &Tape, wrt: &[usize]) -> Sparsity {
        let n = wrt.len();
        let mut pairs = vec![false; n * n];
        let jacobian = propagate(tape, wrt, |a, b| {
            for i in members(a) {
                for j in members(b) {
                    let (hi, lo) = if i >= j { (i, j) } else { (j, i) };
                    pairs[hi * n + lo] = true;
                }
            }
        });
        let mut hessian = Vec::new();
        for i in 0..n {
            for j in 0..=i {
                if pairs[i * n + j] {
                    hessian.push((i, j));
                }
            }
        }
        Sparsity {
            n,
            jacobian,
            hessian,
        }
    }

    /// The Jacobian pattern alone (`hessian` left empty): one pass of bit sets over the
    /// tape, cheap enough for tapes with hundreds of chosen inputs.
    ///
    /// ```
    /// use ghm::graph::{Graph, Op, Sparsity};
    ///
    /// let mut g = Graph::new();
    /// let (x, y, z) = (g.var(0), g.var(1), g.var(2));
    /// let xy = g.mul(x, y);
    /// let e = g.apply(Op::Exp, &[z]);
    /// let tape = g.compile(&[xy, e], 3);
    /// let s = Sparsity::of_jacobian(&tape, &[0, 1, 2]);
    /// assert_eq!(s.jacobian, vec![vec![0, 1], vec![2]]);
    /// assert!(s.hessian.is_empty());
    /// ```
    pub fn of_jacobian(tape: &Tape, wrt: &[usize]) -> Sparsity {
        Sparsity {
            n: wrt.len(),
            jacobian: propagate(tape, wrt, |_, _| {}),
            hessian: Vec::new(),
        }
    }

    /// Structural non-zeros of the Jacobian, all rows together.
    pub fn jacobian_nnz(&self) -> usize {
        self.jacobian.iter().map(Vec::len).sum()
    }
}

/// Which chosen inputs each slot depends on, pushed through the tape; `meet(a, b)` is told
/// of every pair of dependency sets that meet in a nonlinear operation. Returns each
/// output's columns.
fn propagate(tape: &Tape, wrt: &[usize], mut meet: impl FnMut(&Bits, &Bits)) -> Vec<Vec<usize>> {
    let words = wrt.len().div_ceil(64).max(1);
    let empty: Bits = vec![0; words];
    let mut deps: Vec<Bits> = vec![empty.clone(); tape.n_slots()];
    for (col, &i) in wrt.iter().enumerate() {
        deps[i][col / 64] |= 1 << (col % 64);
    }
    for ins in tape.instructions() {
        let [a, b, c] = ins.args.map(|s| s as usize);
        let d = match ins.op {
            op if op.is_piecewise_constant() => empty.clone(),
            Op::Select => union(&deps[b], &deps[c]),
            op if op.is_linear() || matches!(op, Op::Abs | Op::Min | Op::Max) => {
                if op.arity() == 1 {
                    deps[a].clone()
                } else {
                    union(&deps[a], &deps[b])
                }
            }
            Op::Mul => {
                meet(&deps[a], &deps[b]);
                union(&deps[a], &deps[b])
            }
            Op::Div => {
                meet(&deps[a], &deps[b]);
                meet(&deps[b], &deps[b]);
                union(&deps[a], &deps[b])
            }
            op if op.arity() == 1 => {
                meet(&deps[a], &deps[a]);
                deps[a].clone()
            }
            _ => {
                let all = union(&deps[a], &deps[b]);
                meet(&all, &all);
                all
            }
        };
        deps[ins.out as usize] = d;
    }
    tape.outputs
        .iter()
        .map(|&s| members(&deps[s as usize]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::Graph;

    #[test]
    fn linear_terms_have_no_hessian_entries() {
        let mut g = Graph::new();
        let (x, y, z) = (g.var(0), g.var(1), g.var(2));
        let xy = g.mul(x, y);
        let f = g.add(xy, z); // xy + z
        let e = g.apply(Op::Exp, &[z]);
        let tape = g.compile(&[f, e], 3);
        let s = Sparsity::of(&tape, &[0, 1, 2]);
        assert_eq!(s.jacobian, vec![vec![0, 1, 2], vec![2]]);
        assert_eq!(s.hessian, vec![(1, 0), (2, 2)]);
    }
}
