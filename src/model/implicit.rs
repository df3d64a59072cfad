//! Implicit Runge–Kutta steps for stiff models: the stage equations solved by Newton, the
//! step's first and second derivatives from the implicit function theorem.
//!
//! Over one sub-step of length `h` from `x₀`, the stage values `Xᵢ` solve
//!
//! ```text
//! Gᵢ(z, X) = Xᵢ − x₀ − h Σⱼ aᵢⱼ f(Xⱼ, u, d(t₀ + cⱼ h), p) = 0,    i = 1…s,
//! ```
//!
//! and every method here is *stiffly accurate* (`c_s = 1`, the last row of `A` is the
//! weights `b`), so the state after the sub-step is the last stage value `X_s`. The stage
//! values of all sub-steps, `W`, are extra variables of the graph: the step's outputs
//! `P(z, W)` (`x⁺`, the stage terms, `y(x⁺)`) and the residuals `G(z, W)` are graph nodes
//! compiled into one tape, so their derivatives are exact.
//!
//! * **Values**: simplified Newton per sub-step with the matrix `I − h A ⊗ J`, split by the
//!   eigenvalues of `A⁻¹` into `n × n` systems for RADAU3 and RADAU5
//!   ([`super::eigen_split`]). The last sub-step's factored matrix is tried first (across
//!   steps too, in a simulation's workspace: RADAU5's rule), from the last sub-step's
//!   collocation polynomial continued; where it contracts slowly, `J` is taken afresh at
//!   the start, and at every stage where that barely contracts (in a simulation) or slows
//!   (for derivatives), anew each time (a simulation's three-stage exact matrix factored
//!   by blocks, [`super::block_newton`]; derivatives' whole); in a simulation, an exact
//!   iteration whose corrections grow twice in a row gives up, and a sub-step that fails
//!   is solved in two pieces, four from a piece that fails, … up to 64, and the rest of
//!   the step in as many (an optimiser's values stay NaN there, as its derivatives
//!   would). A sub-step that converged at a rate of contraction above 0.2
//!   has the next one take `J` afresh at its start, from its extrapolated stages. In a
//!   simulation, converged when the error left, estimated from the rate of contraction
//!   (`η ‖Δ‖`, Hairer & Wanner IV.8), is below 1e-5 scaled; for derivatives, at a scaled
//!   correction of 1e-10 ([`Purpose`]); both below the integration error, so that the
//!   derivatives below are those of the step actually taken. (Measured on the GreenLight
//!   season, `docs/benchmarks.md`, "Fewer Newton iterations, and triangular solves row by
//!   row": 5.2 iterations a sub-step before, 2.7 now.) A workspace for derivatives
//!   keeps nothing from one step to the next, so that its numbers do not depend on which
//!   steps were solved before. A sub-step's first iteration evaluates `f` at every stage
//!   in one pass of the tape ([`Tape::eval_points`]); the later ones only the part of it
//!   that reads the state ([`Tape::dependents_of_first`]).
//! * **Jacobian**: `W_z = −G_W⁻¹ G_z` and `dP/dz = P_z + P_W W_z`.
//! * **Hessian of `λᵀP`**: with the adjoint `μ` of `G_Wᵀ μ = −P_Wᵀ λ`, the Lagrangian
//!   `L = λᵀP + μᵀG` is stationary in `W`, and `∇²(λᵀP) = Tᵀ ∇²L T` with `T = [I; W_z]`.
//!   The Newton iterations themselves are never differentiated.

use nalgebra::{DMatrix, DVector, Dyn, LU};

use super::block_newton::BlockNewton;
use super::dense_lu::DenseLu;
use super::eigen_split::{EigenSplit, SplitMatrix};
use super::sparse_lu::SparseOrder;
use super::Layout;
use crate::graph::{Derivatives, Evaluation, Graph, NodeId, PointsWorkspace, Tape, Workspace};
use crate::lang::model::{Integrator, Model};
use std::sync::Arc;

/// Newton iterations allowed per sub-step before the step is declared failed.
const MAX_NEWTON_ITERATIONS: usize = 60;
/// What a workspace solves steps for, which sets how far Newton goes and what it keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Purpose {
    /// A simulation: converged when the error left in the stage values, estimated from the
    /// rate of contraction, is below 1e-5 (scaled), below the integration error (the
    /// GreenLight open loop's worst share of its tolerances is vpAir's 0.681 against 0.697
    /// at 1e-7; the methods' orders in `tests/implicit.rs` hold); the factored matrix carries
    /// over from step to step. An optimiser's values are solved as derivatives are
    /// ([`super::Plant::optimisation_workspace`]).
    Simulation,
    /// Derivatives by the implicit function theorem: converged to a correction of 1e-10,
    /// so that `G = 0` holds to what the derivatives need; nothing carries over from one
    /// step to the next, so that the numbers do not depend on which steps were solved
    /// before.
    Derivatives,
}

/// The error a simulation's Newton iteration may leave in the stage values, relative to
/// `1 + |x|`, as estimated by `η ‖Δ‖` (Hairer & Wanner, *Solving ODEs II*, IV.8).
const SIMULATION_TOLERANCE: f64 = 1e-5;
/// The largest correction, relative to `1 + |x|`, of a converged iteration for derivatives.
const DERIVATIVES_TOLERANCE: f64 = 1e-10;

impl Purpose {
    /// Whether an iteration whose last correction had the scaled size `size` has converged,
    /// `eta = θ / (1 − θ)` bounding the error left by the correction's size (`θ` the rate
    /// of contraction): what is left after a correction `Δ` is at most `η ‖Δ‖`.
    fn converged(self, size: f64, eta: f64) -> bool {
        match self {
            Purpose::Simulation => eta * size <= SIMULATION_TOLERANCE,
            Purpose::Derivatives => size <= DERIVATIVES_TOLERANCE,
        }
    }

    /// Whether an iteration with a matrix fresh for this sub-step, contracting at `theta`
    /// after a correction of the scaled size `size`, `left` iterations still allowed,
    /// should take the exact Newton matrix (`J` at every stage's latest value, `sn × sn`),
    /// anew each time. A simulation goes on with the matrix it has while the iteration
    /// contracts fast enough to converge within the iterations left: after a large jump
    /// of the controls it often contracts slowly at first and fast later
    /// (`docs/benchmarks.md`, "Fewer exact Newton matrices": GreenLight under jumping
    /// controls about twice as fast as turning at 0.5, the same values to the tolerance).
    /// Derivatives, converged to a correction of 1e-10, turn at 0.5.
    fn turn_to_exact(self, theta: f64, size: f64, left: usize) -> bool {
        match self {
            Purpose::Simulation => {
                let exponent = i32::try_from(left).unwrap_or(i32::MAX);
                theta > SIMULATION_SLOW_CONTRACTION
                    || (theta > SLOW_CONTRACTION
                        && !self.converged(theta.powi(exponent) * size, contraction_eta(theta)))
            }
            Purpose::Derivatives => theta > SLOW_CONTRACTION,
        }
    }

    /// Whether an exact Newton iteration whose last `growing` corrections each grew should
    /// give up: a simulation solves the sub-step in pieces instead; derivatives, which
    /// cannot split, go on to the iteration limit (so that MPC's numbers stay as they were).
    fn gives_up(self, growing: usize) -> bool {
        self == Purpose::Simulation && growing >= DIVERGING_CORRECTIONS
    }
}
/// Corrections in a row, each larger than the last, after which a simulation's exact Newton
/// iteration gives up on its sub-step, which is then solved in pieces
/// ([`ImplicitStep::solve_pieces`]): on GreenLight such an iteration went on growing for
/// its 60 iterations, each with the exact matrix afresh (`docs/benchmarks.md`, "Giving
/// up on a diverging sub-step").
const DIVERGING_CORRECTIONS: usize = 2;
/// A correction this small that no longer shrinks is round-off: converged as well.
const ROUND_OFF_FLOOR: f64 = 1e-9;
/// The contraction above which a reused matrix gives up, and, for derivatives, a fresh one
/// turns to exact Newton ([`Purpose::turn_to_exact`]).
const SLOW_CONTRACTION: f64 = 0.5;
/// The contraction above which a simulation's fresh matrix turns to exact Newton
/// whatever the iterations left ([`Purpose::turn_to_exact`]).
const SIMULATION_SLOW_CONTRACTION: f64 = 0.95;
/// The contraction of a converged sub-step above which the next one, in a simulation,
/// takes `J` afresh at its start (its stages still extrapolated from this one's).
const REFRESH_CONTRACTION: f64 = 0.2;
/// The stages whose `f` one evaluation of the tape gives (every stage of RADAU5 and SDIRK3).
const STAGE_POINTS: usize = 3;
/// The most pieces a failed sub-step is split into (by halving) before the step is
/// declared failed.
const MAX_SPLIT: usize = 64;

/// The Butcher tableau of a stiffly accurate implicit method.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Tableau {
    /// Number of stages `s`.
    pub stages: usize,
    /// `A`, row-major `s × s`.
    pub a: Vec<f64>,
    /// The stage times `c` as fractions of the step.
    pub c: Vec<f64>,
}

impl Tableau {
    /// The tableau of an implicit integrator (`None` for the explicit ones).
    pub fn of(integrator: Integrator) -> Option<Tableau> {
        let s6 = 6f64.sqrt();
        let (a, c) = match integrator {
            Integrator::Rk4 | Integrator::Euler => return None,
            Integrator::BackwardEuler => (vec![1.0], vec![1.0]),
            Integrator::Radau3 => (
                vec![5.0 / 12.0, -1.0 / 12.0, 3.0 / 4.0, 1.0 / 4.0],
                vec![1.0 / 3.0, 1.0],
            ),
            Integrator::Radau5 => (
                vec![
                    (88.0 - 7.0 * s6) / 360.0,
                    (296.0 - 169.0 * s6) / 1800.0,
                    (-2.0 + 3.0 * s6) / 225.0,
                    (296.0 + 169.0 * s6) / 1800.0,
                    (88.0 + 7.0 * s6) / 360.0,
                    (-2.0 - 3.0 * s6) / 225.0,
                    (16.0 - s6) / 36.0,
                    (16.0 + s6) / 36.0,
                    1.0 / 9.0,
                ],
                vec![(4.0 - s6) / 10.0, (4.0 + s6) / 10.0, 1.0],
            ),
            Integrator::Sdirk3 => {
                // Alexander (1977): γ is the root of x³ − 3x² + 3x/2 − 1/6 in (1/6, 1/2).
                let g = 0.435_866_521_508_459;
                let tau = (1.0 + g) / 2.0;
                let b1 = -(6.0 * g * g - 16.0 * g + 1.0) / 4.0;
                let b2 = (6.0 * g * g - 20.0 * g + 5.0) / 4.0;
                (
                    vec![g, 0.0, 0.0, tau - g, g, 0.0, b1, b2, g],
                    vec![g, tau, 1.0],
                )
            }
        };
        Some(Tableau {
            stages: c.len(),
            a,
            c,
        })
    }

    fn a(&self, i: usize, j: usize) -> f64 {
        self.a[i * self.stages + j]
    }
}

/// `L_j(1 + c_i)` for the Lagrange basis on the nodes `0, c₁ … c_s`, stage `i` row by row,
/// `j` over the nodes `c₁ … c_s`.
fn extrapolation(tableau: &Tableau) -> Vec<f64> {
    let s = tableau.stages;
    let nodes: Vec<f64> = std::iter::once(0.0)
        .chain(tableau.c.iter().copied())
        .collect();
    let mut e = vec![0.0; s * s];
    for i in 0..s {
        let tau = 1.0 + tableau.c[i];
        for j in 0..s {
            let node = nodes[j + 1];
            e[i * s + j] = nodes
                .iter()
                .filter(|&&m| m != node)
                .map(|&m| (tau - m) / (node - m))
                .product();
        }
    }
    e
}

/// Graph nodes of an implicit step: the state after it and the stage residuals, over the
/// base variables `(x, u, d, p)` and the stage values `W` (variables from `w_offset` on).
pub(crate) struct ImplicitNodes {
    /// `x⁺`: the last stage of the last sub-step (variables of `W`).
    pub next_state: Vec<NodeId>,
    /// `G(z, W)`, sub-step by sub-step, stage by stage, state by state.
    pub residuals: Vec<NodeId>,
}

/// The `η` that judges a sub-step's first iteration, from the last converged one's:
/// `η^0.8` (a little more cautious than the last rate), no smaller than round-off.
fn first_eta(last: f64) -> f64 {
    last.max(f64::EPSILON).powf(0.8)
}

/// The order in which to factor the Newton matrices of `f = rhs` sparse, where their
/// factors have at most half the entries of dense ones (GreenLight: `J` may be non-zero in
/// 138 of its 784 entries; its factors in this order in 184, where partial pivoting's fill
/// about 410).
fn sparse_order(jacobian: &Derivatives, nx: usize) -> Option<Arc<SparseOrder>> {
    let order = SparseOrder::of(nx, &jacobian.pattern()?.jacobian);
    (2 * order.off_diagonal_entries() + nx <= nx * nx / 2).then(|| Arc::new(order))
}

/// `A⁻¹` of a three-stage tableau, row-major; `None` for other tableaus.
fn three_stage_inverse(tableau: &Tableau) -> Option<[f64; 9]> {
    if tableau.stages != 3 {
        return None;
    }
    let inverse = DMatrix::from_row_slice(3, 3, &tableau.a).try_inverse()?;
    Some(std::array::from_fn(|k| inverse[(k / 3, k % 3)]))
}

/// `η = θ / (1 − θ)` of a rate of contraction `θ < 1`.
fn contraction_eta(theta: f64) -> f64 {
    theta / (1.0 - theta)
}

/// Variable number of stage `stage` of sub-step `sub`, state `k`.
fn w_var(w_offset: usize, nx: usize, stages: usize, sub: usize, stage: usize, k: usize) -> usize {
    w_offset + (sub * stages + stage) * nx + k
}

/// Adds the stage residuals of `model`'s implicit integrator to `graph`.
pub(crate) fn build_nodes(
    graph: &mut Graph,
    model: &Model,
    tableau: &Tableau,
    w_offset: usize,
) -> ImplicitNodes {
    let nx = model.layout().nx;
    let s = tableau.stages;
    let h = model.sample_period / model.substeps as f64;
    let mut start: Vec<NodeId> = (0..nx).map(|k| graph.var(k)).collect();
    let mut residuals = Vec::with_capacity(model.substeps * s * nx);
    for sub in 0..model.substeps {
        let t0 = sub as f64 * h;
        let stages: Vec<Vec<NodeId>> = (0..s)
            .map(|i| {
                (0..nx)
                    .map(|k| graph.var(w_var(w_offset, nx, s, sub, i, k)))
                    .collect()
            })
            .collect();
        let slopes: Vec<Vec<NodeId>> = (0..s)
            .map(|j| super::rhs_at(graph, model, &stages[j], t0 + tableau.c[j] * h))
            .collect();
        for (i, stage) in stages.iter().enumerate() {
            for k in 0..nx {
                let terms: Vec<NodeId> = (0..s)
                    .filter(|&j| tableau.a(i, j) != 0.0)
                    .map(|j| graph.scale(h * tableau.a(i, j), slopes[j][k]))
                    .collect();
                let sum = graph.sum(&terms);
                let moved = graph.sub(stage[k], start[k]);
                residuals.push(graph.sub(moved, sum));
            }
        }
        start = stages[s - 1].clone();
    }
    ImplicitNodes {
        next_state: start,
        residuals,
    }
}

/// A factored simplified Newton matrix.
#[derive(Debug, Clone)]
enum NewtonMatrix {
    /// `I − h (A ⊗ I) diag(J₁ … J_s)`, factored whole.
    Dense(LU<f64, Dyn, Dyn>),
    /// `I − h A ⊗ J`, one `J` for every stage, split by the eigenvalues of `A⁻¹`.
    Split(SplitMatrix),
    /// `I − h (A ⊗ I) diag(J₁, J₂, J₃)` of a three-stage method, factored by blocks (a
    /// simulation's exact Newton matrix).
    Blocks(Box<BlockNewton>),
}

/// An implicit step, compiled: what [`super::Plant`] holds for an implicit integrator.
#[derive(Debug, Clone)]
pub(crate) struct ImplicitStep {
    tableau: Tableau,
    /// `A⁻¹ = T Λ T⁻¹`, where the tableau has such a split (RADAU3, RADAU5).
    split: Option<EigenSplit>,
    /// `A⁻¹`, row-major, of a three-stage tableau (RADAU5, SDIRK3): a simulation's exact
    /// Newton matrix is factored by blocks ([`BlockNewton`]).
    three_stage_inverse: Option<[f64; 9]>,
    /// `L_j(1 + c_i)`, `s × s`: the Lagrange basis on the nodes `0, c₁ … c_s` (the node 0
    /// carries the value 0 and drops out) at the next sub-step's stage times.
    extrapolation: Vec<f64>,
    substeps: usize,
    h: f64,
    layout: Layout,
    clock: Option<usize>,
    w_offset: usize,
    n_w: usize,
    /// `f(x, u, d, p)` over the base variables.
    rhs: Tape,
    /// The instructions of `rhs` that read the state: all a Newton iteration after the
    /// sub-step's first needs to evaluate, as only the stage values move.
    rhs_state_part: Tape,
    /// The order in which the simplified Newton matrices `σ I − J` are factored sparse,
    /// from `J`'s pattern; `None` where the pattern is too dense to gain by it.
    sparse_order: Option<Arc<SparseOrder>>,
    /// `∂f/∂x` of `rhs`, its columns grouped by the pattern (made once, cloned into each
    /// workspace).
    rhs_jacobian: Derivatives,
    /// `P(z, W)` over `(x, u, d, p, x⁺ slots, W)`.
    post: Tape,
    /// `[P; G](z, W)`, for derivatives.
    combined: Tape,
}

/// Scratch of one implicit step: the Newton iteration's buffers and the stage values.
#[derive(Debug, Clone)]
pub(crate) struct ImplicitWorkspace {
    /// `f` at up to [`STAGE_POINTS`] stages at once: the tape's scratch, inputs and outputs.
    stage_ws: PointsWorkspace<STAGE_POINTS>,
    stage_inputs: Vec<[f64; STAGE_POINTS]>,
    stage_slopes: Vec<[f64; STAGE_POINTS]>,
    /// Whether `stage_ws` holds a whole evaluation of `f` at this sub-step's stage inputs
    /// other than the state, so that [`ImplicitStep::stage_slopes`] need run only the part
    /// that reads the state.
    stage_base_evaluated: bool,
    rhs_jacobian: Derivatives,
    rhs_inputs: Vec<f64>,
    slopes: Vec<f64>,
    increments: Vec<f64>,
    residual: Vec<f64>,
    start: Vec<f64>,
    /// The converged stage values `W` (valid after a successful solve).
    w: Vec<f64>,
    /// `(z, x⁺ slots, W)`, the inputs of the post and combined tapes.
    full_inputs: Vec<f64>,
    post_ws: Workspace<f64>,
    /// The factored Newton matrix of the last sub-step solved, and its sub-step length.
    newton: Option<(NewtonMatrix, f64)>,
    /// The stage increments of the last sub-step solved: the start of the next sub-step's
    /// iteration, extrapolated.
    previous: Vec<f64>,
    /// The length of that sub-step; `None` before the first.
    previous_h: Option<f64>,
    /// What the steps are solved for.
    purpose: Purpose,
    /// `η = θ / (1 − θ)` of the last iteration that converged (`θ` its rate of
    /// contraction): the first iteration of the next sub-step, with no rate of its own yet,
    /// is judged by it.
    eta: f64,
    /// The last sub-step contracted slower than [`REFRESH_CONTRACTION`]: the next one takes
    /// `J` afresh at its start, from its extrapolated stages.
    stale: bool,
}

impl ImplicitWorkspace {
    /// Keeps the stage increments of the sub-step just solved, of length `h`.
    fn remember_substep(&mut self, h: f64) {
        self.previous.copy_from_slice(&self.increments);
        self.previous_h = Some(h);
    }
}

/// The Newton iteration of a sub-step did not converge (or met a number that is not finite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct NewtonFailure;

impl ImplicitStep {
    /// Compiles the tapes of an implicit step whose graph nodes `graph` holds.
    pub fn new(
        graph: &Graph,
        model: &Model,
        tableau: Tableau,
        step_outputs: &[NodeId],
        residuals: &[NodeId],
    ) -> ImplicitStep {
        let layout = model.layout();
        let w_offset = layout.n_all();
        let n_w = residuals.len();
        let n_in = w_offset + n_w;
        let mut all = step_outputs.to_vec();
        all.extend_from_slice(residuals);
        let rhs = graph.compile(&model.derivatives, layout.n_base());
        let rhs_jacobian = Derivatives::grouped(&rhs, &(0..layout.nx).collect::<Vec<_>>());
        ImplicitStep {
            substeps: model.substeps,
            h: model.sample_period / model.substeps as f64,
            clock: model.clock().map(|i| layout.d(i)),
            rhs_state_part: rhs.dependents_of_first(layout.nx),
            sparse_order: sparse_order(&rhs_jacobian, layout.nx),
            rhs_jacobian,
            rhs,
            post: graph.compile(step_outputs, n_in),
            combined: graph.compile(&all, n_in),
            extrapolation: extrapolation(&tableau),
            split: EigenSplit::of(&tableau.a, tableau.stages),
            three_stage_inverse: three_stage_inverse(&tableau),
            tableau,
            layout,
            w_offset,
            n_w,
        }
    }

    /// Values the step returns: `(x⁺, stage terms, y(x⁺))`.
    pub fn n_outputs(&self) -> usize {
        self.post.n_outputs()
    }

    /// The tape of `[P; G]` over `(x, u, d, p, x⁺ slots, W)`.
    pub fn combined_tape(&self) -> &Tape {
        &self.combined
    }

    /// Scratch for steps solved for `purpose`.
    pub fn workspace_for(&self, purpose: Purpose) -> ImplicitWorkspace {
        ImplicitWorkspace {
            purpose,
            ..self.workspace()
        }
    }

    /// Scratch for a simulation's steps.
    pub fn workspace(&self) -> ImplicitWorkspace {
        let nx = self.layout.nx;
        let sn = self.tableau.stages * nx;
        ImplicitWorkspace {
            stage_ws: self.rhs.points_workspace(),
            stage_inputs: vec![[0.0; STAGE_POINTS]; self.layout.n_base()],
            stage_slopes: vec![[0.0; STAGE_POINTS]; nx],
            stage_base_evaluated: false,
            rhs_jacobian: self.rhs_jacobian.clone(),
            rhs_inputs: vec![0.0; self.layout.n_base()],
            slopes: vec![0.0; sn],
            increments: vec![0.0; sn],
            residual: vec![0.0; sn],
            start: vec![0.0; nx],
            w: vec![0.0; self.n_w],
            full_inputs: vec![0.0; self.w_offset + self.n_w],
            post_ws: self.post.workspace(),
            newton: None,
            previous: vec![0.0; sn],
            previous_h: None,
            purpose: Purpose::Simulation,
            eta: 1.0,
            stale: false,
        }
    }

    /// The Newton matrix `I − h (A ⊗ I) diag(J₁ … J_s)`, `J_j = ∂f/∂x` at stage `j`'s
    /// state and time in `points`, factored; one point stands for every stage (simplified
    /// Newton), and is split by the eigenvalues of `A⁻¹` where the tableau allows.
    fn newton_matrix(
        &self,
        ws: &mut ImplicitWorkspace,
        base: &[f64],
        points: &[(Vec<f64>, f64)],
        h: f64,
    ) -> NewtonMatrix {
        let nx = self.layout.nx;
        let mut jacobians = Vec::with_capacity(points.len());
        for (x, t) in points {
            self.set_rhs_inputs(ws, base, x, *t);
            let jac = ws.rhs_jacobian.jacobian(&self.rhs, &ws.rhs_inputs);
            jacobians.push(jac.jacobian.clone());
        }
        let blocks = match (&self.split, jacobians.as_slice(), self.three_stage_inverse) {
            (Some(split), [jacobian], _) => {
                return NewtonMatrix::Split(split.factor(
                    jacobian,
                    nx,
                    h,
                    self.sparse_order.as_ref(),
                ));
            }
            // Derivatives keep the whole matrix, so that MPC's numbers stay as they were.
            (_, [j1, j2, j3], Some(alpha)) if ws.purpose == Purpose::Simulation => {
                BlockNewton::factor(alpha, [j1, j2, j3], nx, h)
            }
            _ => None,
        };
        match blocks {
            Some(blocks) => NewtonMatrix::Blocks(Box::new(blocks)),
            // Other methods, derivatives, and a singular block: the whole matrix.
            None => NewtonMatrix::Dense(self.dense_newton_matrix(&jacobians, h).lu()),
        }
    }

    /// `I − h (A ⊗ I) diag(J₁ … J_s)` whole; fewer Jacobians than stages stand for the
    /// stages from the last on.
    fn dense_newton_matrix(&self, jacobians: &[Vec<f64>], h: f64) -> DMatrix<f64> {
        let nx = self.layout.nx;
        let s = self.tableau.stages;
        // The matrix only steers the iteration (the residuals decide convergence): an entry
        // of J that is not finite (a term like |x|^0.33 at x = 0) is left out.
        DMatrix::from_fn(s * nx, s * nx, |r, c| {
            let (i, k) = (r / nx, r % nx);
            let (j, l) = (c / nx, c % nx);
            let identity = if r == c { 1.0 } else { 0.0 };
            let d = jacobians[j.min(jacobians.len() - 1)][k * nx + l];
            identity - h * self.tableau.a(i, j) * if d.is_finite() { d } else { 0.0 }
        })
    }

    fn set_rhs_inputs(&self, ws: &mut ImplicitWorkspace, base: &[f64], x: &[f64], t: f64) {
        let nx = self.layout.nx;
        ws.rhs_inputs.copy_from_slice(&base[..self.layout.n_base()]);
        ws.rhs_inputs[..nx].copy_from_slice(x);
        if let Some(c) = self.clock {
            ws.rhs_inputs[c] = base[c] + t;
        }
    }

    /// The stage values `start + increments` of stage `i`, and their time.
    fn stage_point(&self, ws: &ImplicitWorkspace, i: usize, t0: f64, h: f64) -> (Vec<f64>, f64) {
        let nx = self.layout.nx;
        let x = (0..nx)
            .map(|k| ws.start[k] + ws.increments[i * nx + k])
            .collect();
        (x, t0 + self.tableau.c[i] * h)
    }

    /// Newton on the stage equations of one sub-step of length `h` from `ws.start` at
    /// `t0`. The last sub-step's factored matrix is tried first while it serves (RADAU5's
    /// rule); where it contracts slowly, the iteration starts again with `J` at the start,
    /// and turns to exact Newton (`J` at every stage) where that contracts too slowly
    /// ([`Purpose::turn_to_exact`]). The stage increments are left in `ws.increments`.
    fn solve_substep(
        &self,
        ws: &mut ImplicitWorkspace,
        base: &[f64],
        t0: f64,
        h: f64,
    ) -> Result<(), NewtonFailure> {
        if let Some((lu, made_for)) = ws.newton.take() {
            if made_for == h {
                self.extrapolate(ws, h);
                let lu = if std::mem::take(&mut ws.stale) {
                    let start_point = [(ws.start.clone(), t0)];
                    self.newton_matrix(ws, base, &start_point, h)
                } else {
                    lu
                };
                if let Ok(lu) = self.newton(ws, base, t0, h, lu, true) {
                    ws.newton = Some((lu, h));
                    ws.remember_substep(h);
                    return Ok(());
                }
            }
        }
        ws.increments.fill(0.0);
        let start_point = vec![(ws.start.clone(), t0)];
        let fresh = self.newton_matrix(ws, base, &start_point, h);
        let lu = self.newton(ws, base, t0, h, fresh, false)?;
        ws.newton = Some((lu, h));
        ws.remember_substep(h);
        Ok(())
    }

    /// The first guess of a sub-step's stage increments: the last sub-step's collocation
    /// polynomial (through its start and stages) continued past its end, where the last
    /// sub-step had the same length; zero otherwise.
    fn extrapolate(&self, ws: &mut ImplicitWorkspace, h: f64) {
        let nx = self.layout.nx;
        let s = self.tableau.stages;
        match ws.previous_h {
            Some(made_for) if made_for == h => {
                let z = &ws.previous;
                for i in 0..s {
                    for k in 0..nx {
                        // Nodes 0, c₁ … c_s with values 0, Z₁ … Z_s; less the new start Z_s.
                        let mut v = -z[(s - 1) * nx + k];
                        for j in 0..s {
                            v += self.extrapolation[i * s + j] * z[j * nx + k];
                        }
                        ws.increments[i * nx + k] = v;
                    }
                }
            }
            _ => ws.increments.fill(0.0),
        }
    }

    /// The Newton iteration from `ws.increments` with the factored matrix `lu`; a `reused`
    /// matrix gives up at the first slow contraction, a fresh one is replaced by the exact
    /// Newton matrix wherever [`Purpose::turn_to_exact`] says. Returns the matrix it ended
    /// with.
    fn newton(
        &self,
        ws: &mut ImplicitWorkspace,
        base: &[f64],
        t0: f64,
        h: f64,
        mut lu: NewtonMatrix,
        reused: bool,
    ) -> Result<NewtonMatrix, NewtonFailure> {
        let nx = self.layout.nx;
        if nx == 0 {
            // No state, no stage equations (and no rows to take them by).
            return Ok(lu);
        }
        let s = self.tableau.stages;
        let mut previous = f64::INFINITY;
        let mut theta = 0.0;
        let mut eta = first_eta(ws.eta);
        // Corrections in a row that grew since the iteration turned to exact Newton.
        let mut growing = None;
        self.set_stage_base(ws, base);
        for iteration in 0..MAX_NEWTON_ITERATIONS {
            self.stage_slopes(ws, base, t0, h);
            // `h Σⱼ aᵢⱼ f(Zⱼ) − Zᵢ`, stage by stage over contiguous rows.
            let rows = ws
                .residual
                .chunks_exact_mut(nx)
                .zip(ws.increments.chunks_exact(nx));
            for (i, (residual, increments)) in rows.enumerate() {
                // From −0.0, as `Iterator::sum` starts: the same bits as a sum over `j`.
                residual.fill(-0.0);
                for (j, slopes) in ws.slopes.chunks_exact(nx).enumerate() {
                    let a = self.tableau.a(i, j);
                    for (r, f) in residual.iter_mut().zip(slopes) {
                        *r += a * f;
                    }
                }
                for (r, z) in residual.iter_mut().zip(increments) {
                    *r = h * *r - z;
                }
            }
            if !self.solve_newton(&mut lu, &mut ws.residual) {
                return Err(NewtonFailure);
            }
            // A NaN anywhere (f undefined at a stage) is no convergence: `max` skips it.
            let (mut size, mut undefined) = (0.0f64, false);
            let stages = ws
                .increments
                .chunks_exact_mut(nx)
                .zip(ws.residual.chunks_exact(nx));
            for (increments, corrections) in stages {
                for ((z, dz), x) in increments.iter_mut().zip(corrections).zip(&ws.start) {
                    *z += dz;
                    let scaled = dz.abs() / (1.0 + x.abs());
                    undefined |= scaled.is_nan();
                    size = size.max(scaled);
                }
            }
            if undefined || !size.is_finite() {
                return Err(NewtonFailure);
            }
            if previous.is_finite() && size < previous {
                theta = size / previous;
                eta = contraction_eta(theta);
            }
            if ws.purpose.converged(size, eta)
                || (size <= ROUND_OFF_FLOOR && size >= 0.5 * previous)
            {
                ws.eta = eta;
                ws.stale = theta > REFRESH_CONTRACTION;
                return Ok(lu);
            }
            // 0 at the first iteration, where `previous` is infinite.
            let contraction = size / previous;
            if let Some(grown) = growing.as_mut() {
                *grown = if contraction > 1.0 { *grown + 1 } else { 0 };
                if ws.purpose.gives_up(*grown) {
                    return Err(NewtonFailure);
                }
            }
            let left = MAX_NEWTON_ITERATIONS - iteration - 1;
            let slow = if reused {
                contraction > SLOW_CONTRACTION
            } else {
                ws.purpose.turn_to_exact(contraction, size, left)
            };
            if slow {
                if reused {
                    return Err(NewtonFailure);
                }
                let points: Vec<(Vec<f64>, f64)> =
                    (0..s).map(|i| self.stage_point(ws, i, t0, h)).collect();
                lu = self.newton_matrix(ws, base, &points, h);
                growing.get_or_insert(0);
            }
            previous = size;
        }
        Err(NewtonFailure)
    }

    /// The inputs of `f` that are the same at every stage, `(u, d, p)` of `base`, into
    /// every point of `ws.stage_inputs` (the clock's time, too, which
    /// [`stage_slopes`](Self::stage_slopes) moves on per stage).
    fn set_stage_base(&self, ws: &mut ImplicitWorkspace, base: &[f64]) {
        let nx = self.layout.nx;
        for (input, &b) in ws.stage_inputs[nx..].iter_mut().zip(&base[nx..]) {
            *input = [b; STAGE_POINTS];
        }
        ws.stage_base_evaluated = false;
    }

    /// `f` at every stage's value `start + increments` and time into `ws.slopes`, up to
    /// [`STAGE_POINTS`] stages per evaluation of the tape; the points past the last stage
    /// repeat it. `ws.stage_inputs` holds the stages' common inputs
    /// ([`set_stage_base`](Self::set_stage_base)).
    fn stage_slopes(&self, ws: &mut ImplicitWorkspace, base: &[f64], t0: f64, h: f64) {
        let nx = self.layout.nx;
        let s = self.tableau.stages;
        for first in (0..s).step_by(STAGE_POINTS) {
            let count = STAGE_POINTS.min(s - first);
            let stage_of = |point: usize| first + point.min(count - 1);
            for (k, input) in ws.stage_inputs[..nx].iter_mut().enumerate() {
                *input = std::array::from_fn(|point| {
                    ws.start[k] + ws.increments[stage_of(point) * nx + k]
                });
            }
            if let Some(c) = self.clock {
                let clock = base[c];
                ws.stage_inputs[c] =
                    std::array::from_fn(|point| clock + t0 + self.tableau.c[stage_of(point)] * h);
            }
            // With more stages than points (no tableau here has), the passes would differ
            // in their clock's time: each would evaluate `f` whole.
            let tape = if ws.stage_base_evaluated {
                &self.rhs_state_part
            } else {
                &self.rhs
            };
            tape.eval_points(&mut ws.stage_ws, &ws.stage_inputs, &mut ws.stage_slopes);
            ws.stage_base_evaluated = s <= STAGE_POINTS;
            for point in 0..count {
                for (k, slope) in ws.stage_slopes.iter().enumerate() {
                    ws.slopes[(first + point) * nx + k] = slope[point];
                }
            }
        }
    }

    /// Solves `matrix · Δ = r` in place (`r`, then the correction `Δ`); false where the
    /// matrix is singular.
    fn solve_newton(&self, matrix: &mut NewtonMatrix, r: &mut [f64]) -> bool {
        match (matrix, &self.split) {
            (NewtonMatrix::Split(m), Some(split)) => m.solve_mut(split, r),
            (NewtonMatrix::Dense(lu), _) => {
                let mut v = DVector::from_column_slice(r);
                let solved = lu.solve_mut(&mut v);
                r.copy_from_slice(v.as_slice());
                solved
            }
            (NewtonMatrix::Blocks(m), _) => {
                m.solve_mut(r);
                true
            }
            (NewtonMatrix::Split(_), None) => false,
        }
    }

    /// Solves the stage equations of every sub-step from the base point `(x, u, d, p)`;
    /// the stage values are left in the workspace. In a simulation, a sub-step whose
    /// Newton iteration fails is solved in pieces ([`Self::solve_pieces`]), and so is the
    /// rest of the step; the stages in `W` of a sub-step solved in pieces all hold the
    /// state it ends in (the step's outputs read only the last stage of `W`, `x⁺`, and the
    /// next sub-step starts from it).
    ///
    /// Only a simulation splits: an optimiser's values are those its derivatives (which
    /// need the model's own sub-steps) can follow, so a point they cannot solve has no value
    /// either and the line search steps back from it. (With the fallback, such a point had
    /// a value and NaN derivatives: the interior point stopped with `invalid_number` at the
    /// GreenLight season's first steps.)
    pub fn solve(&self, ws: &mut ImplicitWorkspace, base: &[f64]) -> Result<(), NewtonFailure> {
        let nx = self.layout.nx;
        let sn = self.tableau.stages * nx;
        ws.start.copy_from_slice(&base[..nx]);
        ws.previous_h = None;
        if ws.purpose == Purpose::Derivatives {
            ws.newton = None;
        }
        let mut pieces = 1;
        for sub in 0..self.substeps {
            let t0 = sub as f64 * self.h;
            let stages = sub * sn..(sub + 1) * sn;
            if pieces == 1 {
                match self.solve_substep(ws, base, t0, self.h) {
                    Ok(()) => {
                        for (r, w) in ws.w[stages.clone()].iter_mut().enumerate() {
                            *w = ws.start[r % nx] + ws.increments[r];
                        }
                        ws.start.copy_from_slice(&ws.w[stages.end - nx..stages.end]);
                        continue;
                    }
                    Err(failure) if ws.purpose == Purpose::Derivatives => return Err(failure),
                    Err(_) => pieces = 2,
                }
            }
            pieces = self.solve_pieces(ws, base, t0, pieces)?;
            for (r, w) in ws.w[stages].iter_mut().enumerate() {
                *w = ws.start[r % nx];
            }
        }
        Ok(())
    }

    /// The sub-step from `ws.start` at `t0` in `pieces` equal pieces, twice as many from
    /// any piece whose Newton iteration fails on, up to [`MAX_SPLIT`]; `ws.start` is left
    /// at the state the sub-step ends in. Returns the pieces it ended with, which the rest
    /// of the step keeps: on GreenLight, where one sub-step of a step fails, its others
    /// mostly fail as well (`docs/benchmarks.md`, "Giving up on a diverging sub-step").
    fn solve_pieces(
        &self,
        ws: &mut ImplicitWorkspace,
        base: &[f64],
        t0: f64,
        mut pieces: usize,
    ) -> Result<usize, NewtonFailure> {
        let last = (self.tableau.stages - 1) * self.layout.nx;
        let mut piece = 0;
        while piece < pieces {
            let h = self.h / pieces as f64;
            if self
                .solve_substep(ws, base, t0 + piece as f64 * h, h)
                .is_ok()
            {
                for (x, dx) in ws.start.iter_mut().zip(&ws.increments[last..]) {
                    *x += dx;
                }
                piece += 1;
            } else if pieces < MAX_SPLIT {
                pieces *= 2;
                piece *= 2;
            } else {
                return Err(NewtonFailure);
            }
        }
        Ok(pieces)
    }

    /// Copies `(z, 0, W)` into the post/combined tapes' inputs.
    fn fill_full_inputs(&self, ws: &mut ImplicitWorkspace, base: &[f64]) {
        let nb = self.layout.n_base();
        ws.full_inputs[..nb].copy_from_slice(&base[..nb]);
        ws.full_inputs[nb..self.w_offset].fill(0.0);
        ws.full_inputs[self.w_offset..].copy_from_slice(&ws.w);
    }

    /// One step: `(x⁺, stage terms, y(x⁺))` into `outputs`, all NaN if Newton failed.
    pub fn eval(&self, ws: &mut ImplicitWorkspace, base: &[f64], outputs: &mut [f64]) {
        if self.solve(ws, base).is_err() {
            outputs.fill(f64::NAN);
            return;
        }
        self.fill_full_inputs(ws, base);
        self.post.eval(&mut ws.post_ws, &ws.full_inputs, outputs);
    }
}

/// Exact derivatives of an implicit step with respect to chosen base inputs.
///
/// `G_W` is block lower triangular, a block per sub-step (a sub-step's stage equations
/// read its own stage values and the state the last one ended in), so `W_z` comes by
/// block forward substitution over `s·n × s·n` blocks and the adjoint `μ` by backward
/// substitution; the combined tape's Jacobian seeds groups of columns that share no row
/// ([`Derivatives::grouped`]); and the Hessian of the Lagrangian is taken along the
/// columns of `T = [I; W_z]` only ([`Derivatives::hessian_along`]), never over all of `W`.
#[derive(Debug, Clone)]
pub(crate) struct ImplicitDerivatives {
    n_wrt: usize,
    combined: Derivatives,
    ws: ImplicitWorkspace,
    weights: Vec<f64>,
    /// Rows (and columns) of `G_W` per diagonal block: a sub-step's, or all of `W` where
    /// the pattern is not block lower triangular.
    block: usize,
    /// `coupled[k][l]`: block `(k, l)` of `G_W` holds a structural non-zero (`l < k`).
    coupled: Vec<Vec<bool>>,
    /// `G_W`, `n_w × n_w`.
    g_w: DMatrix<f64>,
    /// `P_W`, `m × n_w`.
    p_w: DMatrix<f64>,
    /// `W_z`, `n_w × n_wrt`.
    w_z: DMatrix<f64>,
    /// The factors of `G_W`'s diagonal blocks, from the last [`Self::first_order`]: the
    /// same factors solve for `W_z` and, transposed, for the adjoint.
    block_factors: Vec<DenseLu<f64>>,
    /// `block` values of scratch for the solves.
    scratch: Vec<f64>,
    /// `T = [I; W_z]`, column by column, and `∇²L T` in the same layout.
    directions: Vec<f64>,
    product: Vec<f64>,
    gradient: Vec<f64>,
    result: Evaluation,
}

impl ImplicitDerivatives {
    pub fn new(step: &ImplicitStep, wrt: &[usize]) -> ImplicitDerivatives {
        let full: Vec<usize> = wrt
            .iter()
            .copied()
            .chain(step.w_offset..step.w_offset + step.n_w)
            .collect();
        let (m, n, nw) = (step.n_outputs(), wrt.len(), step.n_w);
        let combined = Derivatives::grouped(&step.combined, &full);
        let pattern = combined
            .pattern()
            .expect("grouped derivatives keep their pattern");
        let (block, coupled) = block_structure(
            &pattern.jacobian[m..],
            n,
            nw,
            step.tableau.stages * step.layout.nx,
        );
        ImplicitDerivatives {
            n_wrt: n,
            combined,
            ws: step.workspace_for(Purpose::Derivatives),
            weights: vec![0.0; m + nw],
            block,
            coupled,
            g_w: DMatrix::zeros(nw, nw),
            p_w: DMatrix::zeros(m, nw),
            w_z: DMatrix::zeros(nw, n),
            block_factors: Vec::with_capacity(nw / block.max(1)),
            scratch: vec![0.0; block],
            directions: vec![0.0; (n + nw) * n],
            product: vec![0.0; (n + nw) * n],
            gradient: vec![0.0; n + nw],
            result: Evaluation {
                values: vec![0.0; m],
                jacobian: vec![0.0; m * n],
                gradient: vec![0.0; n],
                hessian: vec![0.0; n * n],
            },
        }
    }

    fn fail(&mut self) -> &Evaluation {
        self.result.values.fill(f64::NAN);
        self.result.jacobian.fill(f64::NAN);
        self.result.gradient.fill(f64::NAN);
        self.result.hessian.fill(f64::NAN);
        &self.result
    }

    /// Solves the step and forms `G_W`, `P_W`, `W_z` and `dP/dz`; `None` where the step or
    /// a block of `G_W` failed.
    fn first_order(&mut self, step: &ImplicitStep, base: &[f64]) -> Option<()> {
        if step.solve(&mut self.ws, base).is_err() {
            return None;
        }
        step.fill_full_inputs(&mut self.ws, base);
        let (m, n, nw) = (step.n_outputs(), self.n_wrt, step.n_w);
        let nf = n + nw;
        let e = self.combined.jacobian(&step.combined, &self.ws.full_inputs);
        let at = |r: usize, c: usize| e.jacobian[r * nf + c];
        self.g_w = DMatrix::from_fn(nw, nw, |r, c| at(m + r, n + c));
        self.p_w = DMatrix::from_fn(m, nw, |r, c| at(r, n + c));
        let p_z = DMatrix::from_fn(m, n, at);
        // G_W W_z = −G_z, block by block from the first sub-step.
        let b = self.block;
        let mut w_z = DMatrix::from_fn(nw, n, |r, c| -at(m + r, c));
        self.block_factors.clear();
        for k in 0..nw / b {
            let mut rhs = w_z.rows(k * b, b).clone_owned();
            for l in (0..k).filter(|&l| self.coupled[k][l]) {
                rhs -= self.g_w.view((k * b, l * b), (b, b)) * w_z.rows(l * b, b);
            }
            let diagonal = (0..b * b).map(|i| self.g_w[(k * b + i / b, k * b + i % b)]);
            let lu = DenseLu::factor(diagonal.collect(), b)?;
            for column in rhs.as_mut_slice().chunks_exact_mut(b) {
                lu.solve(column, &mut self.scratch);
            }
            w_z.rows_mut(k * b, b).copy_from(&rhs);
            self.block_factors.push(lu);
        }
        self.result.values.copy_from_slice(&e.values[..m]);
        let dp = p_z + &self.p_w * &w_z;
        for r in 0..m {
            for c in 0..n {
                self.result.jacobian[r * n + c] = dp[(r, c)];
            }
        }
        self.w_z = w_z;
        Some(())
    }

    /// The adjoint `μ` of `G_Wᵀ μ = −P_Wᵀ λ`, block by block from the last sub-step, with
    /// the blocks' factors of [`Self::first_order`].
    fn adjoint(&mut self, lambda: &[f64]) -> DVector<f64> {
        let b = self.block;
        let blocks = self.g_w.nrows() / b;
        let lambda = DVector::from_column_slice(lambda);
        let mut mu = -(self.p_w.transpose() * lambda);
        for k in (0..blocks).rev() {
            let mut rhs = mu.rows(k * b, b).clone_owned();
            for l in (k + 1..blocks).filter(|&l| self.coupled[l][k]) {
                rhs -= self.g_w.view((l * b, k * b), (b, b)).transpose() * mu.rows(l * b, b);
            }
            self.block_factors[k].solve_transpose(rhs.as_mut_slice(), &mut self.scratch);
            mu.rows_mut(k * b, b).copy_from(&rhs);
        }
        mu
    }

    /// Values and Jacobian of the step at the base point.
    pub fn jacobian(&mut self, step: &ImplicitStep, base: &[f64]) -> &Evaluation {
        if self.first_order(step, base).is_none() {
            return self.fail();
        }
        &self.result
    }

    /// Values, Jacobian, and the gradient and Hessian of `Σ weights[i] · output[i]`.
    pub fn hessian(&mut self, step: &ImplicitStep, base: &[f64], weights: &[f64]) -> &Evaluation {
        if self.first_order(step, base).is_none() {
            return self.fail();
        }
        let (m, n, nw) = (step.n_outputs(), self.n_wrt, step.n_w);
        let nf = n + nw;
        let mu = self.adjoint(&weights[..m]);
        self.weights[..m].copy_from_slice(&weights[..m]);
        self.weights[m..].copy_from_slice(mu.as_slice());
        // T = [I; W_z], column by column.
        self.directions.fill(0.0);
        for c in 0..n {
            let column = &mut self.directions[c * nf..(c + 1) * nf];
            column[c] = 1.0;
            column[n..].copy_from_slice(self.w_z.column(c).as_slice());
        }
        self.combined.hessian_along(
            &step.combined,
            &self.ws.full_inputs,
            &self.weights,
            &self.directions,
            &mut self.gradient,
            &mut self.product,
        );
        // Tᵀ (∇²L T) and Tᵀ ∇L.
        let lt = DMatrix::from_column_slice(nf, n, &self.product);
        let h = lt.rows(0, n) + self.w_z.transpose() * lt.rows(n, nw);
        let g = DVector::from_column_slice(&self.gradient[..n])
            + self.w_z.transpose() * DVector::from_column_slice(&self.gradient[n..]);
        for r in 0..n {
            self.result.gradient[r] = g[r];
            for c in 0..n {
                // Symmetric up to round-off: keep it exactly symmetric.
                self.result.hessian[r * n + c] = 0.5 * (h[(r, c)] + h[(c, r)]);
            }
        }
        &self.result
    }
}

/// The block size of `G_W` and which blocks below the diagonal hold non-zeros, from the
/// Jacobian pattern of the residual rows (`g_rows`, columns `n_wrt` on being `W`): blocks
/// of `sub_block` (a sub-step's stage values) where nothing lies above the diagonal
/// blocks, as the stage equations are built; one block of all `W` otherwise.
fn block_structure(
    g_rows: &[Vec<usize>],
    n_wrt: usize,
    n_w: usize,
    sub_block: usize,
) -> (usize, Vec<Vec<bool>>) {
    let blocks = n_w / sub_block.max(1);
    let mut coupled = vec![vec![false; blocks]; blocks];
    let mut lower = sub_block > 0 && n_w.is_multiple_of(sub_block);
    if lower {
        for (row, cols) in g_rows.iter().enumerate() {
            for &c in cols.iter().filter(|&&c| c >= n_wrt) {
                let (k, l) = (row / sub_block, (c - n_wrt) / sub_block);
                lower &= l <= k;
                if l < k {
                    coupled[k][l] = true;
                }
            }
        }
    }
    if lower {
        (sub_block, coupled)
    } else {
        (n_w, vec![vec![false]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each tableau is stiffly accurate and its rows sum to the stage times.
    #[test]
    fn tableaus_are_consistent_and_stiffly_accurate() {
        for integrator in Integrator::ALL {
            let Some(t) = Tableau::of(integrator) else {
                assert!(!integrator.is_implicit());
                continue;
            };
            assert!(integrator.is_implicit());
            let s = t.stages;
            assert_eq!(t.c[s - 1], 1.0, "{integrator:?}");
            let b_sum: f64 = (0..s).map(|j| t.a(s - 1, j)).sum();
            assert!((b_sum - 1.0).abs() < 1e-14, "{integrator:?}: Σb = {b_sum}");
            for i in 0..s {
                let row: f64 = (0..s).map(|j| t.a(i, j)).sum();
                assert!((row - t.c[i]).abs() < 1e-14, "{integrator:?} row {i}");
            }
        }
    }

    /// Order conditions up to each method's order: Σ bᵢ cᵢ^(q−1) = 1/q.
    #[test]
    fn tableaus_reach_their_order() {
        for (integrator, order) in [
            (Integrator::BackwardEuler, 1),
            (Integrator::Radau3, 3),
            (Integrator::Radau5, 5),
            (Integrator::Sdirk3, 3),
        ] {
            let t = Tableau::of(integrator).unwrap();
            let s = t.stages;
            for q in 1..=order {
                let sum: f64 = (0..s).map(|i| t.a(s - 1, i) * t.c[i].powi(q - 1)).sum();
                assert!(
                    (sum - 1.0 / q as f64).abs() < 1e-13,
                    "{integrator:?}: quadrature of order {q}: {sum}"
                );
            }
        }
        // Alexander's γ solves its cubic.
        let g: f64 = 0.435_866_521_508_459;
        assert!((g.powi(3) - 3.0 * g * g + 1.5 * g - 1.0 / 6.0).abs() < 1e-15);
    }
}
