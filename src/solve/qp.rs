//! The quadratic sub-problem of one SQP iteration, solved by clarabel.
//!
//! ```text
//! minimise ½ dᵀ H d + ∇fᵀ d   subject to   g_l ≤ g + J d ≤ g_u,   x_l ≤ x + d ≤ x_u
//! ```
//!
//! The sparsity pattern is fixed for a given problem (dense upper triangles of the
//! Hessian blocks, the constraint Jacobian, one row per finite bound), so the clarabel
//! solver is built once and only its values are updated between iterations and between
//! MPC steps; the symbolic factorisation is not repeated. It is rebuilt only when the set
//! of finite bounds changes (a terminal box switched on, say).

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, SupportedConeT,
    ZeroConeT,
};
use nalgebra::DMatrix;
use std::ops::Range;

/// What a row of the QP's `A` stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Row {
    /// `J_i d = g_l − g_i`.
    Equality(usize),
    /// `J_i d ≤ g_u − g_i`.
    ConUpper(usize),
    /// `−J_i d ≤ g_i − g_l`.
    ConLower(usize),
    /// `d_i ≤ x_u − x_i`.
    VarUpper(usize),
    /// `−d_i ≤ x_i − x_l`.
    VarLower(usize),
}

/// Everything the QP needs from the NLP at the current iterate.
pub(crate) struct QpData<'a> {
    /// Convexified Hessian blocks, aligned with the block ranges given at construction.
    pub blocks: &'a [DMatrix<f64>],
    /// Added to the diagonal of variables outside every block.
    pub diagonal: f64,
    pub gradient: &'a [f64],
    pub jacobian: &'a [f64],
    pub g: &'a [f64],
    pub x: &'a [f64],
    pub x_lower: &'a [f64],
    pub x_upper: &'a [f64],
    pub g_lower: &'a [f64],
    pub g_upper: &'a [f64],
}

/// The QP's answer, in NLP terms.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum QpOutcome {
    Solved,
    Infeasible,
    Failed,
}

pub(crate) struct QpSolver {
    n: usize,
    rows: Vec<Row>,
    n_eq: usize,
    blocks: Vec<Range<usize>>,
    /// For each block, the CSC positions of its upper triangle, column by column.
    block_positions: Vec<Vec<usize>>,
    /// CSC positions of the diagonals of variables outside every block.
    free_diagonals: Vec<(usize, usize)>,
    p: CscMatrix<f64>,
    /// `(csc position, Jacobian entry or bound, sign)` of every entry of `A`.
    a_sources: Vec<(usize, Option<usize>, f64)>,
    a: CscMatrix<f64>,
    q: Vec<f64>,
    b: Vec<f64>,
    solver: Option<DefaultSolver<f64>>,
    /// Primal step.
    pub step: Vec<f64>,
    /// Constraint and bound multipliers (signed).
    pub multipliers: Vec<f64>,
    pub bound_multipliers: Vec<f64>,
    pub iterations: u32,
}

fn settings() -> DefaultSettings<f64> {
    DefaultSettings {
        verbose: false,
        presolve_enable: false,
        input_sparse_dropzeros: false,
        max_iter: 100,
        tol_gap_abs: 1e-11,
        tol_gap_rel: 1e-11,
        tol_feas: 1e-11,
        tol_ktratio: 1e-8,
        ..DefaultSettings::default()
    }
}

/// The QP rows for the given bounds: equalities first (zero cone), then inequalities.
fn rows_for(
    x_lower: &[f64],
    x_upper: &[f64],
    g_lower: &[f64],
    g_upper: &[f64],
) -> (Vec<Row>, usize) {
    let mut rows = Vec::new();
    for (i, (&lo, &hi)) in g_lower.iter().zip(g_upper).enumerate() {
        if lo == hi {
            rows.push(Row::Equality(i));
        }
    }
    let n_eq = rows.len();
    for (i, (&lo, &hi)) in g_lower.iter().zip(g_upper).enumerate() {
        if lo != hi {
            if hi.is_finite() {
                rows.push(Row::ConUpper(i));
            }
            if lo.is_finite() {
                rows.push(Row::ConLower(i));
            }
        }
    }
    for (i, (&lo, &hi)) in x_lower.iter().zip(x_upper).enumerate() {
        if hi.is_finite() {
            rows.push(Row::VarUpper(i));
        }
        if lo.is_finite() {
            rows.push(Row::VarLower(i));
        }
    }
    (rows, n_eq)
}

impl QpSolver {
    /// A QP workspace for `n` variables, the Hessian `blocks` and the Jacobian pattern.
    pub fn new(
        n: usize,
        blocks: Vec<Range<usize>>,
        jacobian_rows: &[usize],
        jacobian_cols: &[usize],
        bounds: (&[f64], &[f64], &[f64], &[f64]),
    ) -> QpSolver {
        let (rows, n_eq) = rows_for(bounds.0, bounds.1, bounds.2, bounds.3);
        // P: dense upper triangle of each block, diagonal elsewhere.
        let mut in_block = vec![None; n];
        for (b, r) in blocks.iter().enumerate() {
            for v in r.clone() {
                in_block[v] = Some(b);
            }
        }
        let mut colptr = vec![0];
        let mut rowval = Vec::new();
        let mut block_positions = vec![Vec::new(); blocks.len()];
        let mut free_diagonals = Vec::new();
        for (col, owner) in in_block.iter().enumerate() {
            match owner {
                Some(b) => {
                    for row in blocks[*b].start..=col {
                        block_positions[*b].push(rowval.len());
                        rowval.push(row);
                    }
                }
                None => {
                    free_diagonals.push((rowval.len(), col));
                    rowval.push(col);
                }
            }
            colptr.push(rowval.len());
        }
        let nnz = rowval.len();
        let p = CscMatrix::new(n, n, colptr, rowval, vec![0.0; nnz]);
        // A: entries (qp row, col, source, sign), sorted by column then row.
        let mut rows_of_con: Vec<Vec<(usize, f64)>> = vec![Vec::new(); bounds.2.len()];
        for (r, row) in rows.iter().enumerate() {
            match *row {
                Row::Equality(i) | Row::ConUpper(i) => rows_of_con[i].push((r, 1.0)),
                Row::ConLower(i) => rows_of_con[i].push((r, -1.0)),
                _ => {}
            }
        }
        let mut entries: Vec<(usize, usize, Option<usize>, f64)> = Vec::new();
        for (k, (&i, &c)) in jacobian_rows.iter().zip(jacobian_cols).enumerate() {
            for &(r, sign) in &rows_of_con[i] {
                entries.push((c, r, Some(k), sign));
            }
        }
        for (r, row) in rows.iter().enumerate() {
            match *row {
                Row::VarUpper(i) => entries.push((i, r, None, 1.0)),
                Row::VarLower(i) => entries.push((i, r, None, -1.0)),
                _ => {}
            }
        }
        entries.sort_by_key(|e| (e.0, e.1));
        let mut a_colptr = vec![0; n + 1];
        let mut a_rowval = Vec::with_capacity(entries.len());
        let mut a_sources = Vec::with_capacity(entries.len());
        let mut last = None;
        for &(c, r, source, sign) in &entries {
            // Repeated (row, col) pairs share one position.
            if last != Some((c, r)) {
                a_rowval.push(r);
                a_colptr[c + 1] += 1;
                last = Some((c, r));
            }
            a_sources.push((a_rowval.len() - 1, source, sign));
        }
        for c in 0..n {
            a_colptr[c + 1] += a_colptr[c];
        }
        let a_nnz = a_rowval.len();
        let a = CscMatrix::new(rows.len(), n, a_colptr, a_rowval, vec![0.0; a_nnz]);
        QpSolver {
            n,
            q: vec![0.0; n],
            b: vec![0.0; rows.len()],
            rows,
            n_eq,
            blocks,
            block_positions,
            free_diagonals,
            p,
            a_sources,
            a,
            solver: None,
            step: vec![0.0; n],
            multipliers: vec![0.0; bounds.2.len()],
            bound_multipliers: vec![0.0; n],
            iterations: 0,
        }
    }

    /// Whether this workspace still fits problems with these bounds.
    pub fn fits(&self, bounds: (&[f64], &[f64], &[f64], &[f64])) -> bool {
        let (rows, n_eq) = rows_for(bounds.0, bounds.1, bounds.2, bounds.3);
        rows == self.rows && n_eq == self.n_eq && bounds.0.len() == self.n
    }

    pub fn solve(&mut self, data: &QpData) -> QpOutcome {
        self.fill(data);
        let updated = match self.solver.as_mut() {
            Some(s) => s
                .update_data(&self.p.nzval, &self.q, &self.a.nzval, &self.b)
                .is_ok(),
            None => false,
        };
        if !updated {
            let cones: Vec<SupportedConeT<f64>> = vec![
                ZeroConeT(self.n_eq),
                NonnegativeConeT(self.rows.len() - self.n_eq),
            ];
            match DefaultSolver::new(&self.p, &self.q, &self.a, &self.b, &cones, settings()) {
                Ok(s) => self.solver = Some(s),
                Err(_) => return QpOutcome::Failed,
            }
        }
        let Some(solver) = self.solver.as_mut() else {
            return QpOutcome::Failed;
        };
        solver.solve();
        let sol = &solver.solution;
        self.iterations = sol.iterations;
        match sol.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {}
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                return QpOutcome::Infeasible
            }
            _ => return QpOutcome::Failed,
        }
        if sol.x.iter().chain(&sol.z).any(|v| !v.is_finite()) {
            return QpOutcome::Failed;
        }
        self.step.copy_from_slice(&sol.x);
        self.multipliers.fill(0.0);
        self.bound_multipliers.fill(0.0);
        for (row, &z) in self.rows.iter().zip(&sol.z) {
            match *row {
                Row::Equality(i) | Row::ConUpper(i) => self.multipliers[i] += z,
                Row::ConLower(i) => self.multipliers[i] -= z,
                Row::VarUpper(i) => self.bound_multipliers[i] += z,
                Row::VarLower(i) => self.bound_multipliers[i] -= z,
            }
        }
        QpOutcome::Solved
    }

    fn fill(&mut self, data: &QpData) {
        for (b, range) in self.blocks.iter().enumerate() {
            let m = &data.blocks[b];
            let mut k = 0;
            for col in 0..range.len() {
                for row in 0..=col {
                    self.p.nzval[self.block_positions[b][k]] = m[(row, col)];
                    k += 1;
                }
            }
        }
        for &(pos, _) in &self.free_diagonals {
            self.p.nzval[pos] = data.diagonal;
        }
        self.q.copy_from_slice(data.gradient);
        self.a.nzval.fill(0.0);
        for &(pos, source, sign) in &self.a_sources {
            self.a.nzval[pos] += sign * source.map_or(1.0, |k| data.jacobian[k]);
        }
        for (r, row) in self.rows.iter().enumerate() {
            self.b[r] = match *row {
                Row::Equality(i) => data.g_lower[i] - data.g[i],
                Row::ConUpper(i) => data.g_upper[i] - data.g[i],
                Row::ConLower(i) => data.g[i] - data.g_lower[i],
                Row::VarUpper(i) => data.x_upper[i] - data.x[i],
                Row::VarLower(i) => data.x[i] - data.x_lower[i],
            };
        }
    }
}
