//! The expression graph: a DAG of primitive operations over numbered variables, built with
//! hash-consing (a sub-expression written twice is stored once) and constant folding, then
//! compiled to a flat [`Tape`] that evaluates over any dual number type.
//!
//! Architecture invariant: `graph` knows nothing of models, solvers or plants. Its
//! variables are plain indices; what they mean is the business of the rooms above.
//!
//! # Examples
//!
//! Two functions of `(x, y)`, `f = x² y + sin x` and `q = x / y`: build them, compile them
//! into one tape, evaluate it, and take the exact Jacobian and the Hessian of a weighted
//! sum of the two, against the derivatives by hand.
//!
//! ```
//! use ghm::graph::{Derivatives, Graph, Op};
//!
//! let mut g = Graph::new();
//! let (x, y) = (g.var(0), g.var(1));
//! let x2 = g.power(x, 2.0);
//! let x2y = g.mul(x2, y);
//! let sin_x = g.apply(Op::Sin, &[x]);
//! let f = g.add(x2y, sin_x);
//! let q = g.div(x, y);
//! let tape = g.compile(&[f, q], 2);
//!
//! let (a, b) = (0.5_f64, 2.0_f64);
//! let values = tape.eval_f64(&[a, b]);
//! assert_eq!(values, [a * a * b + a.sin(), 0.25]);
//!
//! // Jacobian with respect to (x, y), one row per output.
//! let mut d = Derivatives::new(&tape, &[0, 1]);
//! let jacobian = &d.jacobian(&tape, &[a, b]).jacobian;
//! let by_hand = [2.0 * a * b + a.cos(), a * a, 1.0 / b, -a / (b * b)];
//! for (exact, hand) in jacobian.iter().zip(by_hand) {
//!     assert!((exact - hand).abs() < 1e-15);
//! }
//!
//! // Hessian of 1·f + 3·q: f_xx = 2y − sin x, f_xy = 2x, f_yy = 0;
//! // q_xx = 0, q_xy = −1/y², q_yy = 2x/y³.
//! let e = d.hessian(&tape, &[a, b], &[1.0, 3.0]);
//! let hxy = 2.0 * a - 3.0 / (b * b);
//! let by_hand = [2.0 * b - a.sin(), hxy, hxy, 3.0 * 2.0 * a / (b * b * b)];
//! for (exact, hand) in e.hessian.iter().zip(by_hand) {
//!     assert!((exact - hand).abs() < 1e-15);
//! }
//! // ... and the gradient of the same sum comes with it.
//! assert!((e.gradient[1] - (a * a - 3.0 * a / (b * b))).abs() < 1e-15);
//! ```

mod activity;
mod coloring;
mod derivative;
mod lanes;
mod op;
mod sparsity;
mod sweep;
mod tape;
mod wide;

pub use coloring::ColumnGroups;
pub use derivative::{gradient_f64, Derivatives, Evaluation};
pub use lanes::{LaneVector, Lanes, LANES};
pub use op::{Op, Real};
pub use sparsity::Sparsity;
pub use tape::{PointsWorkspace, Tape, Workspace};

use std::collections::HashMap;

/// A node of a [`Graph`]. Ids are dense and every node's arguments have smaller ids.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(u32);

impl NodeId {
    const NONE: NodeId = NodeId(u32::MAX);

    /// Its position in the graph's node list.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// What a node computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Node {
    /// A literal, stored as its bit pattern so that nodes can be hashed.
    Const(u64),
    /// Variable number `i` of the graph's inputs.
    Var(u32),
    /// An operation on up to three earlier nodes (unused slots hold `NodeId::NONE`).
    Apply(Op, [NodeId; 3]),
}

/// An expression DAG with hash-consing and constant folding.
///
/// # Examples
///
/// ```
/// use ghm::graph::{Graph, Op};
///
/// let mut g = Graph::new();
/// let (x, y) = (g.var(0), g.var(1));
/// // Hash-consing: the same expression is the same node, operands of `+` in any order.
/// let xy = g.mul(x, y);
/// assert_eq!(g.mul(y, x), xy);
/// let n = g.len();
/// let s = g.add(xy, x);
/// assert_eq!(g.add(x, xy), s);
/// assert_eq!(g.len(), n + 1);
/// // Constant folding and identities: no node for `2 + 3`, `x · 1` or `x − x`.
/// let (two, three, one) = (g.constant(2.0), g.constant(3.0), g.constant(1.0));
/// let five = g.add(two, three);
/// assert_eq!(g.as_constant(five), Some(5.0));
/// assert_eq!(g.mul(x, one), x);
/// let zero = g.sub(x, x);
/// assert_eq!(g.as_constant(zero), Some(0.0));
/// // Evaluate without compiling (the hot path compiles to a `Tape`).
/// let e = g.apply(Op::Exp, &[s]);
/// assert_eq!(g.eval_f64(&[e], &[0.0, 7.0]), [1.0]);
/// ```
#[derive(Debug, Clone, Default)]
pub struct Graph {
    nodes: Vec<Node>,
    index: HashMap<Node, NodeId>,
}

impl Graph {
    /// An empty graph.
    pub fn new() -> Graph {
        Graph::default()
    }

    /// Nodes in the graph (each distinct expression once).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether it has no nodes.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// What node `id` computes.
    pub fn node(&self, id: NodeId) -> Node {
        self.nodes[id.index()]
    }

    fn intern(&mut self, node: Node) -> NodeId {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = NodeId(self.nodes.len() as u32);
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    /// The literal `value` (`−0.0` and `0.0` are one node).
    pub fn constant(&mut self, value: f64) -> NodeId {
        // One zero: -0.0 and 0.0 share a node.
        let value = if value == 0.0 { 0.0 } else { value };
        self.intern(Node::Const(value.to_bits()))
    }

    /// Input variable number `index` (its position in the input vector of an evaluation).
    pub fn var(&mut self, index: usize) -> NodeId {
        self.intern(Node::Var(index as u32))
    }

    /// The literal value of a node, if it is a constant.
    pub fn as_constant(&self, id: NodeId) -> Option<f64> {
        match self.nodes[id.index()] {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    /// Applies `op` to its arguments (pass as many as the op takes), folding constants and
    /// the algebraic identities that keep the graph small.
    pub fn apply(&mut self, op: Op, args: &[NodeId]) -> NodeId {
        let mut a = [NodeId::NONE; 3];
        a[..args.len()].copy_from_slice(args);
        let c: Vec<Option<f64>> = args.iter().map(|&x| self.as_constant(x)).collect();
        if c.iter().all(Option::is_some) && !args.is_empty() {
            let v: Vec<f64> = c.iter().map(|x| x.unwrap_or(0.0)).collect();
            let get = |i: usize| v.get(i).copied().unwrap_or(0.0);
            let value = match op {
                // Exact for integer exponents and negative bases, unlike exp(b ln a).
                Op::Pow => get(0).powf(get(1)),
                _ => op.apply_f64(get(0), get(1), get(2)),
            };
            return self.constant(value);
        }
        let is = |i: usize, value: f64| c.get(i).copied().flatten() == Some(value);
        match op {
            Op::Add if is(0, 0.0) => return a[1],
            Op::Add | Op::Sub if is(1, 0.0) => return a[0],
            Op::Sub if is(0, 0.0) => return self.apply(Op::Neg, &[a[1]]),
            Op::Sub if a[0] == a[1] => return self.constant(0.0),
            Op::Mul if is(0, 0.0) || is(1, 0.0) => return self.constant(0.0),
            Op::Mul if is(0, 1.0) => return a[1],
            Op::Mul | Op::Div if is(1, 1.0) => return a[0],
            Op::Mul if is(0, -1.0) => return self.apply(Op::Neg, &[a[1]]),
            Op::Mul if is(1, -1.0) => return self.apply(Op::Neg, &[a[0]]),
            Op::Div if is(0, 0.0) => return self.constant(0.0),
            Op::Neg => {
                if let Node::Apply(Op::Neg, inner) = self.nodes[a[0].index()] {
                    return inner[0];
                }
            }
            Op::Pow => {
                if let Some(e) = c.get(1).copied().flatten() {
                    return self.power(a[0], e);
                }
                if let Some(base) = c[0] {
                    // base^b = exp(ln(base) b), with ln(base) folded.
                    let ln = self.constant(base.ln());
                    let prod = self.mul(ln, a[1]);
                    return self.apply(Op::Exp, &[prod]);
                }
            }
            Op::Powi(1) => return a[0],
            Op::Select => {
                if let Some(cond) = c[0] {
                    return if cond > 0.5 { a[1] } else { a[2] };
                }
                if a[1] == a[2] {
                    return a[1];
                }
            }
            _ => {}
        }
        if op.is_commutative() && a[1] < a[0] {
            a.swap(0, 1);
        }
        self.intern(Node::Apply(op, a))
    }

    /// `base ^ exponent` for a constant exponent.
    pub fn power(&mut self, base: NodeId, exponent: f64) -> NodeId {
        if exponent == 1.0 {
            base
        } else if exponent == 0.0 {
            self.constant(1.0)
        } else if exponent.fract() == 0.0 && exponent.abs() <= 64.0 {
            self.apply(Op::Powi(exponent as i32), &[base])
        } else if exponent == 0.5 {
            self.apply(Op::Sqrt, &[base])
        } else {
            self.apply(Op::Powf(exponent.to_bits()), &[base])
        }
    }

    /// `a + b`.
    pub fn add(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.apply(Op::Add, &[a, b])
    }
    /// `a − b`.
    pub fn sub(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.apply(Op::Sub, &[a, b])
    }
    /// `a · b`.
    pub fn mul(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.apply(Op::Mul, &[a, b])
    }
    /// `a / b`.
    pub fn div(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.apply(Op::Div, &[a, b])
    }
    /// `−a`.
    pub fn neg(&mut self, a: NodeId) -> NodeId {
        self.apply(Op::Neg, &[a])
    }
    /// `factor · a`, with `factor` a constant.
    pub fn scale(&mut self, factor: f64, a: NodeId) -> NodeId {
        let f = self.constant(factor);
        self.mul(f, a)
    }

    /// Sum of several nodes (zero for none).
    pub fn sum(&mut self, terms: &[NodeId]) -> NodeId {
        let mut acc = self.constant(0.0);
        for &t in terms {
            acc = self.add(acc, t);
        }
        acc
    }

    /// The arguments of a node, without the unused slots.
    pub fn args(&self, id: NodeId) -> &[NodeId] {
        match &self.nodes[id.index()] {
            Node::Apply(op, a) => &a[..op.arity()],
            _ => &[],
        }
    }

    /// All nodes `roots` depend on (themselves included), in increasing id order, which is
    /// a topological order.
    pub fn reachable(&self, roots: &[NodeId]) -> Vec<NodeId> {
        let mut seen = vec![false; self.nodes.len()];
        let mut stack: Vec<NodeId> = roots.to_vec();
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n.index()], true) {
                continue;
            }
            stack.extend(self.args(n).iter().copied());
        }
        (0..self.nodes.len())
            .filter(|&i| seen[i])
            .map(|i| NodeId(i as u32))
            .collect()
    }

    /// Rebuilds `roots` with variable `i` replaced by `replacement[i]` (variables beyond the
    /// slice are kept). Shared sub-expressions stay shared.
    ///
    /// ```
    /// use ghm::graph::Graph;
    ///
    /// // f(x, y) = x · y, then f(x + 1, y): the `x` of f becomes `x + 1`.
    /// let mut g = Graph::new();
    /// let (x, y) = (g.var(0), g.var(1));
    /// let f = g.mul(x, y);
    /// let one = g.constant(1.0);
    /// let x1 = g.add(x, one);
    /// let shifted = g.substitute(&[f], &[x1]);
    /// assert_eq!(g.eval_f64(&shifted, &[2.0, 5.0]), [15.0]);
    /// ```
    pub fn substitute(&mut self, roots: &[NodeId], replacement: &[NodeId]) -> Vec<NodeId> {
        let mut map: HashMap<NodeId, NodeId> = HashMap::new();
        for n in self.reachable(roots) {
            let new = match self.nodes[n.index()] {
                Node::Const(_) => n,
                Node::Var(i) => replacement.get(i as usize).copied().unwrap_or(n),
                Node::Apply(op, a) => {
                    let args: Vec<NodeId> = a[..op.arity()].iter().map(|x| map[x]).collect();
                    self.apply(op, &args)
                }
            };
            map.insert(n, new);
        }
        roots.iter().map(|r| map[r]).collect()
    }

    /// The number of nodes the expressions of `roots` would have as trees, without any
    /// sharing (as a float: it grows exponentially with nesting).
    pub fn tree_size(&self, roots: &[NodeId]) -> f64 {
        let order = self.reachable(roots);
        let mut size: HashMap<NodeId, f64> = HashMap::with_capacity(order.len());
        for n in order {
            let s = 1.0 + self.args(n).iter().map(|a| size[a]).sum::<f64>();
            size.insert(n, s);
        }
        roots.iter().map(|r| size[r]).sum()
    }

    /// Evaluates nodes on plain floats (for constant expressions and tests; the hot path is
    /// [`Tape`]).
    pub fn eval_f64(&self, roots: &[NodeId], vars: &[f64]) -> Vec<f64> {
        let mut value: HashMap<NodeId, f64> = HashMap::new();
        for n in self.reachable(roots) {
            let v = match self.nodes[n.index()] {
                Node::Const(bits) => f64::from_bits(bits),
                Node::Var(i) => vars.get(i as usize).copied().unwrap_or(f64::NAN),
                Node::Apply(op, a) => {
                    let g = |k: usize| if k < op.arity() { value[&a[k]] } else { 0.0 };
                    op.apply_f64(g(0), g(1), g(2))
                }
            };
            value.insert(n, v);
        }
        roots.iter().map(|r| value[r]).collect()
    }

    /// The largest variable index used by `roots`, plus one.
    pub fn var_count(&self, roots: &[NodeId]) -> usize {
        self.reachable(roots)
            .iter()
            .filter_map(|&n| match self.nodes[n.index()] {
                Node::Var(i) => Some(i as usize + 1),
                _ => None,
            })
            .max()
            .unwrap_or(0)
    }

    /// Compiles `outputs` into a tape over `n_inputs` variables.
    pub fn compile(&self, outputs: &[NodeId], n_inputs: usize) -> Tape {
        Tape::compile(self, outputs, n_inputs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn common_subexpressions_are_shared() {
        let mut g = Graph::new();
        let x = g.var(0);
        let y = g.var(1);
        let a = g.mul(x, y);
        let b = g.mul(y, x);
        assert_eq!(a, b, "commutative operands are ordered");
        let e1 = g.apply(Op::Exp, &[a]);
        let e2 = g.apply(Op::Exp, &[b]);
        assert_eq!(e1, e2);
    }

    #[test]
    fn constants_fold_and_identities_vanish() {
        let mut g = Graph::new();
        let x = g.var(0);
        let two = g.constant(2.0);
        let three = g.constant(3.0);
        let six = g.mul(two, three);
        assert_eq!(g.as_constant(six), Some(6.0));
        let zero = g.constant(0.0);
        let one = g.constant(1.0);
        assert_eq!(g.add(x, zero), x);
        assert_eq!(g.mul(one, x), x);
        let nx = g.neg(x);
        assert_eq!(g.neg(nx), x);
        assert_eq!(g.apply(Op::Pow, &[x, one]), x);
    }

    #[test]
    fn substitution_keeps_sharing_and_values() {
        let mut g = Graph::new();
        let x = g.var(0);
        let sq = g.mul(x, x);
        let f = g.add(sq, x); // x^2 + x
        let y = g.var(1);
        let two = g.constant(2.0);
        let y2 = g.mul(two, y);
        let out = g.substitute(&[f], &[y2]); // (2y)^2 + 2y
        assert_eq!(g.eval_f64(&out, &[0.0, 3.0]), vec![42.0]);
    }

    #[test]
    fn tree_size_counts_without_sharing() {
        let mut g = Graph::new();
        let x = g.var(0);
        let mut e = x;
        for _ in 0..10 {
            e = g.mul(e, e);
        }
        assert_eq!(g.tree_size(&[e]), 2f64.powi(11) - 1.0);
        assert_eq!(g.reachable(&[e]).len(), 11);
    }
}
