//! Exact derivatives of a tape with respect to a chosen subset of its inputs.
//!
//! * Jacobian: forward mode with vector duals of [`LANES`] lanes, one pass per chunk of
//!   `LANES` chosen inputs (one pass for a plant with up to eight states and inputs).
//!   A sparse Jacobian may instead seed groups of columns that share no row
//!   ([`Derivatives::grouped`], [`super::ColumnGroups`]): one lane per group.
//! * Hessian of a weighted sum of outputs `Σ wᵢ outᵢ`: forward-over-reverse. The forward
//!   pass runs on vector duals, then one reverse (adjoint) sweep runs on the same duals;
//!   the adjoint of input `i` carries the gradient in its real part and row `i` of the
//!   Hessian in its lanes. The cost is a small multiple of one evaluation and no dense
//!   `n × n` second-order dual is ever formed.
//!
//! Both sweeps ([`super::sweep`]) skip what the inputs not chosen cannot change
//! ([`super::activity`]): the forward sweep the zero lanes of passive values, the reverse
//! sweep the adjoints of passive slots and the zero lanes of a passive factor's partial.
//! Both run on the widest vector unit the processor has ([`super::wide`]).
//!
//! * The same along chosen directions `V` ([`Derivatives::hessian_along`]): `∇²(Σ wᵢ outᵢ) V`
//!   in one forward-over-reverse pass per [`LANES`] directions, for a step whose
//!   derivatives are wanted along a few directions of many inputs.
//!
//! All scratch space lives in [`Derivatives`], sized once: evaluation does not allocate.

use super::activity::{active_args, ActiveArgs};
use super::lanes::{Lanes, LANES};
use super::sweep::reverse_sweep;
use super::{wide, ColumnGroups, Sparsity, Tape, Workspace};

type Lane = Lanes<f64>;

/// Results of one derivative evaluation, in buffers owned by [`Derivatives`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Evaluation {
    /// Output values.
    pub values: Vec<f64>,
    /// `n_outputs × n_wrt`, row-major.
    pub jacobian: Vec<f64>,
    /// Gradient of the weighted output sum (after [`Derivatives::hessian`]).
    pub gradient: Vec<f64>,
    /// `n_wrt × n_wrt`, row-major, symmetric (after [`Derivatives::hessian`]).
    pub hessian: Vec<f64>,
}

/// Reusable derivative evaluator for one tape and one choice of inputs.
#[derive(Debug, Clone)]
pub struct Derivatives {
    wrt: Vec<usize>,
    active: Vec<ActiveArgs>,
    result: Evaluation,
    inputs: Vec<Lane>,
    ws: Workspace<Lane>,
    adjoint: Vec<Lane>,
    live: Vec<bool>,
    /// For [`Derivatives::grouped`]: the Jacobian's pattern and its column groups.
    grouped: Option<(Sparsity, ColumnGroups)>,
}

fn lane(d: &Lane, l: usize) -> f64 {
    d.eps.0[l]
}

impl Derivatives {
    /// Derivatives of `tape` with respect to inputs `wrt` (indices into the tape's inputs).
    pub fn new(tape: &Tape, wrt: &[usize]) -> Derivatives {
        let (m, n) = (tape.outputs.len(), wrt.len());
        Derivatives {
            wrt: wrt.to_vec(),
            active: active_args(tape, wrt),
            result: Evaluation {
                values: vec![0.0; m],
                jacobian: vec![0.0; m * n],
                gradient: vec![0.0; n],
                hessian: vec![0.0; n * n],
            },
            inputs: vec![Lane::from(0.0); tape.n_inputs],
            ws: tape.workspace::<Lane>(),
            adjoint: vec![Lane::from(0.0); tape.n_slots()],
            live: vec![false; tape.n_slots()],
            grouped: None,
        }
    }

    /// Like [`Derivatives::new`], but [`Derivatives::jacobian`] seeds groups of columns
    /// that share no row, one lane per group: as many forward passes as the pattern needs
    /// groups (divided by [`LANES`]) instead of columns. The same Jacobian; worth it where
    /// many columns each reach few outputs (the stage values of an implicit step).
    ///
    /// ```
    /// use ghm::graph::{Derivatives, Graph, Op};
    ///
    /// // Ten independent outputs exp(x_i): one group, one pass.
    /// let mut g = Graph::new();
    /// let outs: Vec<_> = (0..10).map(|i| { let x = g.var(i); g.apply(Op::Exp, &[x]) }).collect();
    /// let tape = g.compile(&outs, 10);
    /// let wrt: Vec<usize> = (0..10).collect();
    /// let x: Vec<f64> = (0..10).map(|i| 0.1 * i as f64).collect();
    /// let dense = Derivatives::new(&tape, &wrt).jacobian(&tape, &x).clone();
    /// let grouped = Derivatives::grouped(&tape, &wrt).jacobian(&tape, &x).clone();
    /// assert_eq!(dense, grouped);
    /// ```
    pub fn grouped(tape: &Tape, wrt: &[usize]) -> Derivatives {
        let pattern = Sparsity::of_jacobian(tape, wrt);
        let groups = ColumnGroups::of(&pattern);
        Derivatives {
            grouped: Some((pattern, groups)),
            ..Derivatives::new(tape, wrt)
        }
    }

    /// The Jacobian's pattern, for derivatives made by [`Derivatives::grouped`].
    pub fn pattern(&self) -> Option<&Sparsity> {
        self.grouped.as_ref().map(|(pattern, _)| pattern)
    }

    /// The tape inputs differentiated against, in column order.
    pub fn wrt(&self) -> &[usize] {
        &self.wrt
    }

    fn seed(&mut self, x: &[f64], chunk: usize) -> std::ops::Range<usize> {
        for (d, &v) in self.inputs.iter_mut().zip(x) {
            *d = Lane::from(v);
        }
        let lo = chunk * LANES;
        let hi = (lo + LANES).min(self.wrt.len());
        for (l, k) in (lo..hi).enumerate() {
            let i = self.wrt[k];
            self.inputs[i] = Lane::from(x[i]).derivative(l);
        }
        lo..hi
    }

    fn chunks(&self) -> usize {
        self.wrt.len().div_ceil(LANES).max(1)
    }

    /// Forward pass of one chunk; stores values and that chunk's Jacobian columns.
    fn forward(&mut self, tape: &Tape, x: &[f64], chunk: usize) -> std::ops::Range<usize> {
        let n = self.wrt.len();
        let cols = self.seed(x, chunk);
        self.ws.slots[..tape.n_inputs].copy_from_slice(&self.inputs);
        wide::forward(tape, &self.active, &mut self.ws);
        for (row, &s) in tape.outputs.iter().enumerate() {
            let d = &self.ws.slots[s as usize];
            self.result.values[row] = d.re;
            for (l, col) in cols.clone().enumerate() {
                self.result.jacobian[row * n + col] = lane(d, l);
            }
        }
        cols
    }

    /// The adjoints of `Σ weights[i] · output[i]` over the lanes the last forward run left.
    fn reverse(&mut self, tape: &Tape, weights: &[f64]) {
        wide::reverse(
            tape,
            &self.active,
            &self.ws,
            weights,
            &mut self.adjoint,
            &mut self.live,
        );
    }

    /// Values and Jacobian at `x`.
    pub fn jacobian(&mut self, tape: &Tape, x: &[f64]) -> &Evaluation {
        if self.grouped.is_some() {
            return self.jacobian_by_groups(tape, x);
        }
        for chunk in 0..self.chunks() {
            self.forward(tape, x, chunk);
        }
        &self.result
    }

    /// [`Derivatives::jacobian`] with a lane per group of columns.
    fn jacobian_by_groups(&mut self, tape: &Tape, x: &[f64]) -> &Evaluation {
        let Some((pattern, groups)) = &self.grouped else {
            unreachable!("called for grouped derivatives only");
        };
        let n = self.wrt.len();
        self.result.jacobian.fill(0.0);
        for chunk in 0..groups.n_groups().div_ceil(LANES).max(1) {
            let lanes = chunk * LANES..(chunk + 1) * LANES;
            for (d, &v) in self.inputs.iter_mut().zip(x) {
                *d = Lane::from(v);
            }
            for (col, &i) in self.wrt.iter().enumerate() {
                let g = groups.group_of(col);
                if lanes.contains(&g) {
                    self.inputs[i].eps.0[g - lanes.start] = 1.0;
                }
            }
            self.ws.slots[..tape.n_inputs].copy_from_slice(&self.inputs);
            wide::forward(tape, &self.active, &mut self.ws);
            for (row, &s) in tape.outputs.iter().enumerate() {
                let d = &self.ws.slots[s as usize];
                self.result.values[row] = d.re;
                for &col in &pattern.jacobian[row] {
                    let g = groups.group_of(col);
                    if lanes.contains(&g) {
                        self.result.jacobian[row * n + col] = lane(d, g - lanes.start);
                    }
                }
            }
        }
        &self.result
    }

    /// Values, and the gradient and Hessian-times-`V` of `Σ weights[i] · output[i]` at `x`
    /// along `k` directions: `directions` holds `V`, `n_wrt × k` column by column, and
    /// `product` receives `∇²(Σ wᵢ outᵢ) V` in the same layout, `gradient` the gradient.
    /// One forward-over-reverse pass per [`LANES`] directions, whatever the number of
    /// inputs; the Jacobian in the result is not filled.
    ///
    /// ```
    /// use ghm::graph::{Derivatives, Graph};
    ///
    /// // f = x² y: ∇²f = [[2y, 2x], [2x, 0]]; along v = (1, 1) at (1, 3): (8, 2).
    /// let mut g = Graph::new();
    /// let (x, y) = (g.var(0), g.var(1));
    /// let x2 = g.power(x, 2.0);
    /// let f = g.mul(x2, y);
    /// let tape = g.compile(&[f], 2);
    /// let mut d = Derivatives::new(&tape, &[0, 1]);
    /// let (mut gradient, mut product) = ([0.0; 2], [0.0; 2]);
    /// d.hessian_along(&tape, &[1.0, 3.0], &[1.0], &[1.0, 1.0], &mut gradient, &mut product);
    /// assert_eq!(gradient, [6.0, 1.0]);
    /// assert_eq!(product, [8.0, 2.0]);
    /// ```
    pub fn hessian_along(
        &mut self,
        tape: &Tape,
        x: &[f64],
        weights: &[f64],
        directions: &[f64],
        gradient: &mut [f64],
        product: &mut [f64],
    ) -> &Evaluation {
        let n = self.wrt.len();
        let k = directions.len() / n.max(1);
        debug_assert_eq!(directions.len(), n * k);
        debug_assert_eq!(product.len(), n * k);
        for chunk in 0..k.div_ceil(LANES).max(1) {
            let cols = chunk * LANES..((chunk + 1) * LANES).min(k);
            for (d, &v) in self.inputs.iter_mut().zip(x) {
                *d = Lane::from(v);
            }
            for (r, &i) in self.wrt.iter().enumerate() {
                for (l, col) in cols.clone().enumerate() {
                    self.inputs[i].eps.0[l] = directions[col * n + r];
                }
            }
            self.ws.slots[..tape.n_inputs].copy_from_slice(&self.inputs);
            wide::forward(tape, &self.active, &mut self.ws);
            for (row, &s) in tape.outputs.iter().enumerate() {
                self.result.values[row] = self.ws.slots[s as usize].re;
            }
            self.reverse(tape, weights);
            for (r, &i) in self.wrt.iter().enumerate() {
                let a = &self.adjoint[i];
                gradient[r] = a.re;
                for (l, col) in cols.clone().enumerate() {
                    product[col * n + r] = lane(a, l);
                }
            }
        }
        &self.result
    }

    /// Values, Jacobian, gradient and Hessian of `Σ weights[i] · output[i]` at `x`, in one
    /// forward-over-reverse pass per chunk.
    pub fn hessian(&mut self, tape: &Tape, x: &[f64], weights: &[f64]) -> &Evaluation {
        let n = self.wrt.len();
        for chunk in 0..self.chunks() {
            let cols = self.forward(tape, x, chunk);
            self.reverse(tape, weights);
            for (k, &i) in self.wrt.iter().enumerate() {
                let a = &self.adjoint[i];
                self.result.gradient[k] = a.re;
                for (l, col) in cols.clone().enumerate() {
                    self.result.hessian[k * n + col] = lane(a, l);
                }
            }
        }
        &self.result
    }
}

/// Gradient of `Σ wᵢ outᵢ` with respect to all inputs, by one reverse sweep on floats
/// (allocates; for tests and one-off use).
///
/// ```
/// use ghm::graph::{gradient_f64, Graph};
///
/// // ∇(2·x²y − y) at (3, 4) = (2·2xy, 2·x² − 1) = (48, 17).
/// let mut g = Graph::new();
/// let (x, y) = (g.var(0), g.var(1));
/// let x2 = g.power(x, 2.0);
/// let x2y = g.mul(x2, y);
/// let tape = g.compile(&[x2y, y], 2);
/// assert_eq!(gradient_f64(&tape, &[3.0, 4.0], &[2.0, -1.0]), [48.0, 17.0]);
/// ```
pub fn gradient_f64(tape: &Tape, x: &[f64], weights: &[f64]) -> Vec<f64> {
    let mut ws = tape.workspace::<f64>();
    ws.slots[..tape.n_inputs].copy_from_slice(x);
    tape.run(&mut ws);
    let mut adjoint = vec![0.0; tape.n_slots()];
    let mut live = vec![false; tape.n_slots()];
    let everything: Vec<usize> = (0..tape.n_inputs).collect();
    let active = active_args(tape, &everything);
    reverse_sweep(tape, &active, &ws, weights, &mut adjoint, &mut live);
    adjoint.truncate(tape.n_inputs);
    adjoint
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::{Graph, Op};

    /// f(x, y, z) = exp(x y) + x² z / y + sin(z), with derivatives by hand.
    type Exact = ([f64; 3], [[f64; 3]; 3]);

    fn hand_checkable() -> (Tape, impl Fn(f64, f64, f64) -> Exact) {
        let mut g = Graph::new();
        let (x, y, z) = (g.var(0), g.var(1), g.var(2));
        let xy = g.mul(x, y);
        let e = g.apply(Op::Exp, &[xy]);
        let x2 = g.power(x, 2.0);
        let x2z = g.mul(x2, z);
        let q = g.div(x2z, y);
        let s = g.apply(Op::Sin, &[z]);
        let f0 = g.add(e, q);
        let f = g.add(f0, s);
        let tape = g.compile(&[f], 3);
        let exact = |x: f64, y: f64, z: f64| {
            let e = (x * y).exp();
            let grad = [
                y * e + 2.0 * x * z / y,
                x * e - x * x * z / (y * y),
                x * x / y + z.cos(),
            ];
            let hxx = y * y * e + 2.0 * z / y;
            let hxy = e + x * y * e - 2.0 * x * z / (y * y);
            let hxz = 2.0 * x / y;
            let hyy = x * x * e + 2.0 * x * x * z / (y * y * y);
            let hyz = -x * x / (y * y);
            let hzz = -z.sin();
            (grad, [[hxx, hxy, hxz], [hxy, hyy, hyz], [hxz, hyz, hzz]])
        };
        (tape, exact)
    }

    #[test]
    fn gradient_and_hessian_match_hand_derivatives() {
        let (tape, exact) = hand_checkable();
        let x = [0.7, 1.3, -0.4];
        let (g_ref, h_ref) = exact(x[0], x[1], x[2]);
        let mut d = Derivatives::new(&tape, &[0, 1, 2]);
        let r = d.hessian(&tape, &x, &[1.0]);
        let (j, g, h) = (&r.jacobian, &r.gradient, &r.hessian);
        for i in 0..3 {
            assert!((g[i] - g_ref[i]).abs() < 1e-13);
            assert!((j[i] - g_ref[i]).abs() < 1e-13, "Jacobian row = gradient");
            for k in 0..3 {
                assert!((h[i * 3 + k] - h_ref[i][k]).abs() < 1e-12, "H[{i}][{k}]");
            }
        }
        let g2 = gradient_f64(&tape, &x, &[1.0]);
        assert!((g2[1] - g_ref[1]).abs() < 1e-13);
    }

    /// Every sum, difference, product and quotient with one passive argument, in both
    /// orders, and the choosing ops with a passive branch: the sweeps that skip the passive
    /// halves give what hyper-dual numbers give, entry by entry.
    #[test]
    fn passive_inputs_leave_the_derivatives_as_hyper_duals_give_them() {
        use num_dual::HyperDual64;
        // Inputs (x, y, p, q); differentiate against x and y only.
        let mut g = Graph::new();
        let (x, y, p, q) = (g.var(0), g.var(1), g.var(2), g.var(3));
        let pq = g.mul(p, q);
        let terms = [
            g.mul(x, pq),
            g.mul(pq, y),
            g.div(x, p),
            g.div(q, y),
            g.add(x, q),
            g.sub(p, y),
            g.sub(y, q),
            g.apply(Op::Exp, &[pq]),
            g.apply(Op::Max, &[x, p]),
            g.apply(Op::Min, &[q, y]),
        ];
        let mut products = Vec::new();
        for (k, &t) in terms.iter().enumerate() {
            let partner = terms[(k + 3) % terms.len()];
            products.push(g.mul(t, partner));
            products.push(g.div(t, partner));
        }
        let curved = g.apply(Op::Exp, &[products[4]]);
        let total = g.sum(&products);
        let tape = g.compile(&[total, curved], 4);
        let weights = [0.7, -1.3];
        let wrt = [0, 1];
        // At the first point both choices take their active argument; at the second the
        // max takes its passive one.
        for point in [[0.9, 1.4, 0.6, 2.1], [0.3, -0.8, 1.2, 0.5]] {
            let mut d = Derivatives::new(&tape, &wrt);
            let e = d.hessian(&tape, &point, &weights).clone();
            for (i, &wi) in wrt.iter().enumerate() {
                for (j, &wj) in wrt.iter().enumerate() {
                    let seeded: Vec<HyperDual64> = point
                        .iter()
                        .enumerate()
                        .map(|(k, &v)| {
                            let e1 = if k == wi { 1.0 } else { 0.0 };
                            let e2 = if k == wj { 1.0 } else { 0.0 };
                            HyperDual64::new(v, e1, e2, 0.0)
                        })
                        .collect();
                    let mut ws = tape.workspace::<HyperDual64>();
                    let mut out = [HyperDual64::from(0.0); 2];
                    tape.eval(&mut ws, &seeded, &mut out);
                    let sum = out[0] * weights[0] + out[1] * weights[1];
                    let close = |a: f64, b: f64| (a - b).abs() <= 1e-13 * (1.0 + b.abs());
                    assert!(
                        close(e.hessian[i * 2 + j], sum.eps1eps2),
                        "H[{i}][{j}] at {point:?}"
                    );
                    assert!(close(e.gradient[i], sum.eps1), "g[{i}] at {point:?}");
                    for (row, o) in out.iter().enumerate() {
                        assert!(close(e.jacobian[row * 2 + i], o.eps1), "J[{row}][{i}]");
                    }
                }
            }
        }
    }

    #[test]
    fn chunks_cover_more_inputs_than_lanes() {
        // f = (Σ i·x_i)² over 11 inputs: H = 2 a aᵀ with a_i = i + 1.
        let n = 11;
        let mut g = Graph::new();
        let terms: Vec<_> = (0..n)
            .map(|i| {
                let v = g.var(i);
                g.scale((i + 1) as f64, v)
            })
            .collect();
        let s = g.sum(&terms);
        let f = g.power(s, 2.0);
        let tape = g.compile(&[f], n);
        let wrt: Vec<usize> = (0..n).collect();
        let mut d = Derivatives::new(&tape, &wrt);
        let x: Vec<f64> = (0..n).map(|i| 0.1 * i as f64).collect();
        let h = &d.hessian(&tape, &x, &[1.0]).hessian;
        for a in 0..n {
            for b in 0..n {
                assert_eq!(h[a * n + b], 2.0 * ((a + 1) * (b + 1)) as f64);
            }
        }
    }
}
