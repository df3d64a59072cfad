//! The compiled form of a graph: a flat list of instructions over numbered slots,
//! evaluated generically over any [`Real`] (f64 or a dual number).
//!
//! Slot layout: `[0, n_inputs)` are the inputs, then the constants, then one slot per
//! instruction (static single assignment, so the reverse sweep can read every value).
//! A [`Workspace`] holds the slots; it is sized once and reused, so evaluation does not
//! allocate.

use super::{Graph, Node, NodeId, Op, Real};
use std::collections::HashMap;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Instr {
    pub op: Op,
    pub args: [u32; 3],
    pub out: u32,
}

/// A compiled function from `n_inputs` values to `outputs.len()` values.
///
/// # Examples
///
/// Evaluation without allocation, reusing a [`Workspace`], on floats and on dual numbers:
///
/// ```
/// use ghm::graph::{Graph, Op};
/// use num_dual::{Dual64, DualNum};
///
/// // (x, y) ↦ (x·y, exp(x))
/// let mut g = Graph::new();
/// let (x, y) = (g.var(0), g.var(1));
/// let xy = g.mul(x, y);
/// let ex = g.apply(Op::Exp, &[x]);
/// let tape = g.compile(&[xy, ex], 2);
/// assert_eq!((tape.n_inputs(), tape.n_outputs()), (2, 2));
///
/// let mut ws = tape.workspace::<f64>();
/// let mut out = [0.0; 2];
/// for (a, b) in [(1.0, 2.0), (0.0, 3.0)] {
///     tape.eval(&mut ws, &[a, b], &mut out);
///     assert_eq!(out, [a * b, f64::exp(a)]);
/// }
///
/// // The same tape over a dual number: ∂/∂x at (1, 2).
/// let mut ws = tape.workspace::<Dual64>();
/// let mut out = [Dual64::from_re(0.0); 2];
/// tape.eval(&mut ws, &[Dual64::new(1.0, 1.0), Dual64::from_re(2.0)], &mut out);
/// assert_eq!(out[0].eps, 2.0); // ∂(x y)/∂x = y
/// assert_eq!(out[1].eps, f64::exp(1.0)); // ∂exp(x)/∂x = exp(x)
/// ```
#[derive(Debug, Clone)]
pub struct Tape {
    pub(crate) n_inputs: usize,
    /// This and `instrs` are private so that every tape is made by [`Tape::checked`] and
    /// stays as it checked: the interpreters below read slots without bounds checks on the
    /// strength of that check.
    n_slots: usize,
    pub(crate) constants: Vec<(u32, f64)>,
    instrs: Vec<Instr>,
    pub(crate) outputs: Vec<u32>,
}

/// Reusable storage for evaluating one tape over one number type.
#[derive(Debug, Clone)]
pub struct Workspace<T> {
    pub(crate) slots: Vec<T>,
}

/// Reusable storage for evaluating one tape at `N` points at once
/// ([`Tape::eval_points`]).
#[derive(Debug, Clone)]
pub struct PointsWorkspace<const N: usize> {
    slots: Vec<[f64; N]>,
}

impl Tape {
    pub(crate) fn compile(graph: &Graph, outputs: &[NodeId], n_inputs: usize) -> Tape {
        let order = graph.reachable(outputs);
        let mut slot: HashMap<NodeId, u32> = HashMap::with_capacity(order.len());
        let mut constants = Vec::new();
        let mut instrs = Vec::new();
        let mut next = n_inputs as u32;
        // Constants first so that instruction slots are contiguous.
        for &n in &order {
            match graph.node(n) {
                Node::Var(i) => {
                    slot.insert(n, i);
                }
                Node::Const(bits) => {
                    slot.insert(n, next);
                    constants.push((next, f64::from_bits(bits)));
                    next += 1;
                }
                Node::Apply(..) => {}
            }
        }
        for &n in &order {
            if let Node::Apply(op, a) = graph.node(n) {
                let mut args = [0u32; 3];
                for k in 0..op.arity() {
                    args[k] = slot[&a[k]];
                }
                instrs.push(Instr {
                    op,
                    args,
                    out: next,
                });
                slot.insert(n, next);
                next += 1;
            }
        }
        Tape::checked(Tape {
            n_inputs,
            n_slots: next as usize,
            constants,
            instrs,
            outputs: outputs.iter().map(|o| slot[o]).collect(),
        })
    }

    /// `tape`, once every slot its instructions read or write is known to lie below
    /// `n_slots` (and inside any workspace of at least that many slots).
    fn checked(tape: Tape) -> Tape {
        let n = tape.n_slots;
        let inside = |slot: u32| (slot as usize) < n;
        assert!(
            tape.n_inputs <= n
                && tape
                    .instrs
                    .iter()
                    .all(|i| i.args.iter().all(|&a| inside(a)) && inside(i.out))
                && tape.outputs.iter().all(|&o| inside(o))
                && tape.constants.iter().all(|&(c, _)| inside(c)),
            "a tape reads or writes a slot past its {n}"
        );
        tape
    }

    /// The instructions, in the order they run.
    pub(crate) fn instructions(&self) -> &[Instr] {
        &self.instrs
    }

    /// Slots of a workspace: inputs, constants and one per instruction.
    pub(crate) fn n_slots(&self) -> usize {
        self.n_slots
    }

    /// Length of the input vector an evaluation takes.
    pub fn n_inputs(&self) -> usize {
        self.n_inputs
    }

    /// Values an evaluation returns, in the order of the outputs it was compiled with.
    pub fn n_outputs(&self) -> usize {
        self.outputs.len()
    }

    /// Number of operations evaluated per call.
    pub fn n_instructions(&self) -> usize {
        self.instrs.len()
    }

    /// A workspace for evaluating this tape over `T`, with the constants in place.
    pub fn workspace<T: Real>(&self) -> Workspace<T> {
        let mut slots = vec![T::zero(); self.n_slots];
        for &(s, v) in &self.constants {
            slots[s as usize] = T::from(v);
        }
        Workspace { slots }
    }

    /// Runs the instructions with the inputs already in place in `ws`.
    #[inline]
    pub(crate) fn run<T: Real>(&self, ws: &mut Workspace<T>) {
        let s = &mut ws.slots;
        assert!(
            s.len() >= self.n_slots,
            "a workspace too small for its tape"
        );
        for ins in &self.instrs {
            let [a, b, c] = ins.args.map(|slot| slot as usize);
            // SAFETY: every slot an instruction reads or writes is below `n_slots`
            // (`Tape::checked`), which is at most `s.len()` (asserted above).
            unsafe {
                let v = ins.op.apply(
                    *s.get_unchecked(a),
                    *s.get_unchecked(b),
                    *s.get_unchecked(c),
                );
                *s.get_unchecked_mut(ins.out as usize) = v;
            }
        }
    }

    /// Evaluates the tape: `outputs[i]` receives output `i`.
    pub fn eval<T: Real>(&self, ws: &mut Workspace<T>, inputs: &[T], outputs: &mut [T]) {
        debug_assert_eq!(inputs.len(), self.n_inputs);
        debug_assert_eq!(outputs.len(), self.outputs.len());
        ws.slots[..self.n_inputs].copy_from_slice(inputs);
        self.run(ws);
        for (o, &s) in outputs.iter_mut().zip(&self.outputs) {
            *o = ws.slots[s as usize];
        }
    }

    /// A workspace for evaluating this tape at `N` points at once, constants in place.
    pub fn points_workspace<const N: usize>(&self) -> PointsWorkspace<N> {
        let mut slots = vec![[0.0; N]; self.n_slots];
        for &(s, v) in &self.constants {
            slots[s as usize] = [v; N];
        }
        PointsWorkspace { slots }
    }

    /// Evaluates the tape at `N` points at once: `inputs[i][l]` is input `i` of point `l`,
    /// and `outputs[i][l]` receives output `i` there; the same values as [`Tape::eval`] at
    /// each point, for about the dispatch cost of one.
    ///
    /// ```
    /// use ghm::graph::{Graph, Op};
    ///
    /// let mut g = Graph::new();
    /// let (x, y) = (g.var(0), g.var(1));
    /// let xy = g.mul(x, y);
    /// let e = g.apply(Op::Exp, &[xy]);
    /// let tape = g.compile(&[e], 2);
    /// let mut ws = tape.points_workspace::<2>();
    /// let mut out = [[0.0; 2]];
    /// tape.eval_points(&mut ws, &[[1.0, 0.5], [2.0, 3.0]], &mut out);
    /// assert_eq!(out, [[f64::exp(2.0), f64::exp(1.5)]]);
    /// ```
    // Out of line: inlined into the implicit step's Newton loop, its code placement moved
    // with every change around it (a GreenLight season 2–4 % either way). Its loop is
    // `run`'s written again rather than shared through a closure, which cost `run` the
    // inlining of `Op::apply` (`docs/benchmarks.md`, "The 111-day season in under 2 s").
    #[inline(never)]
    pub fn eval_points<const N: usize>(
        &self,
        ws: &mut PointsWorkspace<N>,
        inputs: &[[f64; N]],
        outputs: &mut [[f64; N]],
    ) {
        debug_assert_eq!(inputs.len(), self.n_inputs);
        debug_assert_eq!(outputs.len(), self.outputs.len());
        let s = &mut ws.slots;
        s[..self.n_inputs].copy_from_slice(inputs);
        assert!(
            s.len() >= self.n_slots,
            "a workspace too small for its tape"
        );
        for ins in &self.instrs {
            let [a, b, c] = ins.args.map(|slot| slot as usize);
            // SAFETY: every slot an instruction reads or writes is below `n_slots`
            // (`Tape::checked`), which is at most `s.len()` (asserted above).
            unsafe {
                *s.get_unchecked_mut(ins.out as usize) = ins.op.apply_points(
                    *s.get_unchecked(a),
                    *s.get_unchecked(b),
                    *s.get_unchecked(c),
                );
            }
        }
        for (o, &slot) in outputs.iter_mut().zip(&self.outputs) {
            *o = s[slot as usize];
        }
    }

    /// The part of this tape that depends on its first `n` inputs: the same slots,
    /// constants and outputs, only the instructions that read those inputs directly or
    /// through others. Where a workspace holds a whole evaluation of this tape, evaluating
    /// the part on it after only those `n` inputs changed gives the whole tape's values
    /// (the other slots still hold theirs). An implicit step's Newton iteration moves only
    /// the state, so the weather's and the controls' share of `f` is evaluated once per
    /// sub-step instead of once per iteration.
    ///
    /// ```
    /// use ghm::graph::{Graph, Op};
    ///
    /// // (x, w) ↦ x · exp(w): exp(w) does not depend on x.
    /// let mut g = Graph::new();
    /// let (x, w) = (g.var(0), g.var(1));
    /// let e = g.apply(Op::Exp, &[w]);
    /// let f = g.mul(x, e);
    /// let tape = g.compile(&[f], 2);
    /// let part = tape.dependents_of_first(1);
    /// assert_eq!((tape.n_instructions(), part.n_instructions()), (2, 1));
    ///
    /// let mut ws = tape.points_workspace::<1>();
    /// let mut out = [[0.0]];
    /// tape.eval_points(&mut ws, &[[2.0], [0.5]], &mut out);
    /// part.eval_points(&mut ws, &[[3.0], [0.5]], &mut out);
    /// assert_eq!(out, [[3.0 * f64::exp(0.5)]]);
    /// ```
    pub fn dependents_of_first(&self, n: usize) -> Tape {
        let mut depends = vec![false; self.n_slots];
        depends[..n.min(self.n_inputs)].fill(true);
        let mut instrs = Vec::new();
        for ins in &self.instrs {
            let reads = ins.args[..ins.op.arity()]
                .iter()
                .any(|&a| depends[a as usize]);
            if reads {
                depends[ins.out as usize] = true;
                instrs.push(*ins);
            }
        }
        Tape::checked(Tape {
            n_inputs: self.n_inputs,
            n_slots: self.n_slots,
            constants: self.constants.clone(),
            instrs,
            outputs: self.outputs.clone(),
        })
    }

    /// Convenience: evaluate on floats with a fresh workspace (allocates; not for hot loops).
    pub fn eval_f64(&self, inputs: &[f64]) -> Vec<f64> {
        let mut ws = self.workspace::<f64>();
        let mut out = vec![0.0; self.outputs.len()];
        self.eval(&mut ws, inputs, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use crate::graph::{Graph, Op};
    use num_dual::Dual64;

    /// The interpreters read slots unchecked: a workspace made for a smaller tape is
    /// refused before any is read.
    #[test]
    #[should_panic(expected = "a workspace too small for its tape")]
    fn a_workspace_of_a_smaller_tape_is_refused() {
        let mut g = Graph::new();
        let x = g.var(0);
        let small = g.compile(&[x], 1);
        let e = g.apply(Op::Exp, &[x]);
        let f = g.apply(Op::Exp, &[e]);
        let large = g.compile(&[f], 1);
        let mut ws = small.points_workspace::<2>();
        let mut out = [[0.0; 2]];
        large.eval_points(&mut ws, &[[1.0, 2.0]], &mut out);
    }

    #[test]
    fn tape_matches_graph_and_carries_duals() {
        let mut g = Graph::new();
        let x = g.var(0);
        let y = g.var(1);
        let xy = g.mul(x, y);
        let e = g.apply(Op::Exp, &[xy]);
        let f = g.add(e, x);
        let tape = g.compile(&[f, y], 2);
        let v = tape.eval_f64(&[0.5, 2.0]);
        assert_eq!(v, g.eval_f64(&[f, y], &[0.5, 2.0]));
        let mut ws = tape.workspace::<Dual64>();
        let mut out = [Dual64::from(0.0); 2];
        tape.eval(
            &mut ws,
            &[Dual64::new(0.5, 1.0), Dual64::from(2.0)],
            &mut out,
        );
        // d/dx (exp(xy) + x) = y exp(xy) + 1
        assert!((out[0].eps - (2.0 * 1f64.exp() + 1.0)).abs() < 1e-14);
    }
}
