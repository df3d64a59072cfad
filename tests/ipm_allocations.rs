//! The interior point's workspace is sized once per problem pattern: a solve of a pattern
//! it has seen allocates nothing in its iterations. A counting global allocator (this test
//! binary's own) counts the allocations of a solve on a hand-written staged problem whose
//! callbacks allocate nothing; what remains are the three vectors of the returned
//! `Solution` (`x`, `λ`, `ν`), however many iterations the solve takes.

use ghm::nlp::{Nlp, Pattern, Stages};
use ghm::solve::{Ipm, IpmOptions, MuStrategy, Solution, SolveStatus, Solver, Start};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, counting the allocations of the thread that asked for it.
struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn record() {
    // `try_with`: the thread's locals may be gone while it ends.
    let counting = COUNTING.try_with(Cell::get).unwrap_or(false);
    if counting {
        let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        record();
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        record();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        record();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// `f()` and the allocations it made on this thread.
fn allocations_of<T>(f: impl FnOnce() -> T) -> (T, usize) {
    ALLOCATIONS.with(|n| n.set(0));
    COUNTING.with(|c| c.set(true));
    let value = f();
    COUNTING.with(|c| c.set(false));
    (value, ALLOCATIONS.with(Cell::get))
}

/// The vectors of a returned [`Solution`]: `x`, `λ` and `ν`.
const SOLUTION_VECTORS: usize = 3;

/// A tank filled by a bounded inflow: `x_{k+1} = x_k + u_k` from `x_0 = 0`, the level
/// tracking `goal` at a quadratic-plus-quartic cost of the inflow, with the rows
/// `x_k + u_k ≥ floor` (`k = 1 … N − 1`). Variables `[u_0] [x_1 u_1] … [x_N]`; rows: the
/// dynamics, then the floors. Convex, so no inertia correction; nothing allocates in its
/// callbacks but [`Nlp::stages`], which a solver asks once per pattern.
struct Tank {
    n: usize,
    goal: f64,
    floor: f64,
    jacobian: Pattern,
    hessian: Pattern,
}

impl Tank {
    const RHO: f64 = 0.1;
    const QUARTIC: f64 = 0.01;

    fn new(n: usize, goal: f64, floor: f64) -> Tank {
        let mut tank = Tank {
            n,
            goal,
            floor,
            jacobian: Pattern::default(),
            hessian: Pattern::default(),
        };
        for k in 0..n {
            tank.jacobian.push(k, tank.x(k + 1));
            if k > 0 {
                tank.jacobian.push(k, tank.x(k));
            }
            tank.jacobian.push(k, tank.u(k));
        }
        for k in 1..n {
            tank.jacobian.push(n + k - 1, tank.x(k));
            tank.jacobian.push(n + k - 1, tank.u(k));
        }
        for v in 0..2 * n {
            tank.hessian.push(v, v);
        }
        tank
    }

    fn x(&self, k: usize) -> usize {
        2 * k - 1
    }

    fn u(&self, k: usize) -> usize {
        2 * k
    }
}

impl Nlp for Tank {
    fn n_vars(&self) -> usize {
        2 * self.n
    }
    fn n_cons(&self) -> usize {
        2 * self.n - 1
    }
    fn var_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        lower.fill(-10.0);
        upper.fill(10.0);
        for k in 0..self.n {
            lower[self.u(k)] = -1.0;
            upper[self.u(k)] = 1.0;
        }
    }
    fn con_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        lower[..self.n].fill(0.0);
        upper[..self.n].fill(0.0);
        lower[self.n..].fill(self.floor);
        upper[self.n..].fill(f64::INFINITY);
    }
    fn initial_point(&mut self, x: &mut [f64]) {
        x.fill(0.0);
    }
    fn objective(&mut self, w: &[f64]) -> f64 {
        (0..self.n)
            .map(|k| {
                let u = w[self.u(k)];
                (w[self.x(k + 1)] - self.goal).powi(2)
                    + Self::RHO * u * u
                    + Self::QUARTIC * u.powi(4)
            })
            .sum()
    }
    fn gradient(&mut self, w: &[f64], g: &mut [f64]) {
        for k in 0..self.n {
            let u = w[self.u(k)];
            g[self.x(k + 1)] = 2.0 * (w[self.x(k + 1)] - self.goal);
            g[self.u(k)] = 2.0 * Self::RHO * u + 4.0 * Self::QUARTIC * u.powi(3);
        }
    }
    fn constraints(&mut self, w: &[f64], g: &mut [f64]) {
        for k in 0..self.n {
            let previous = if k > 0 { w[self.x(k)] } else { 0.0 };
            g[k] = w[self.x(k + 1)] - previous - w[self.u(k)];
        }
        for k in 1..self.n {
            g[self.n + k - 1] = w[self.x(k)] + w[self.u(k)];
        }
    }
    fn jacobian_pattern(&self) -> &Pattern {
        &self.jacobian
    }
    fn jacobian_values(&mut self, _: &[f64], values: &mut [f64]) {
        let mut e = 0;
        for k in 0..self.n {
            values[e] = 1.0;
            e += 1;
            if k > 0 {
                values[e] = -1.0;
                e += 1;
            }
            values[e] = -1.0;
            e += 1;
        }
        values[e..].fill(1.0);
    }
    fn hessian_pattern(&self) -> &Pattern {
        &self.hessian
    }
    fn hessian_values(&mut self, w: &[f64], sigma: f64, _: &[f64], values: &mut [f64]) {
        // The diagonal: variable `v` is a level where odd, an inflow where even.
        for (v, value) in values.iter_mut().enumerate() {
            *value = sigma
                * if v % 2 == 1 {
                    2.0
                } else {
                    2.0 * Self::RHO + 12.0 * Self::QUARTIC * w[v].powi(2)
                };
        }
    }
    fn stages(&self) -> Option<Stages> {
        Some(Stages {
            states: std::iter::once(0..0)
                .chain((1..=self.n).map(|k| self.x(k)..self.x(k) + 1))
                .collect(),
            controls: (0..self.n).map(|k| self.u(k)..self.u(k) + 1).collect(),
            dynamics: (0..self.n).map(|k| k..k + 1).collect(),
        })
    }
}

/// A tank of 24 stages with its solver after one solve, which sized the workspace.
fn solved_once(options: IpmOptions) -> (Tank, Ipm, Solution) {
    let mut tank = Tank::new(24, 3.0, 0.2);
    let mut ipm = Ipm::new(options);
    let start = vec![0.0; tank.n_vars()];
    let first = ipm.solve(&mut tank, Start::cold(&start));
    assert_eq!(first.status, SolveStatus::Optimal, "{:?}", first.stats);
    (tank, ipm, first)
}

/// The earlier solution shifted by one stage (the last stage's values kept), as MPC
/// restarts.
fn shifted(values: &[f64], width: usize) -> Vec<f64> {
    let mut out = values[width..].to_vec();
    out.extend_from_slice(&values[values.len() - width..]);
    out
}

#[test]
fn a_cold_solve_with_the_adaptive_barrier_allocates_only_its_solution() {
    let (mut tank, mut ipm, first) = solved_once(IpmOptions::default());
    let start = shifted(&first.x, 2);
    let (solution, allocations) = allocations_of(|| ipm.solve(&mut tank, Start::shifted(&start)));
    assert!(solution.status.is_success(), "{:?}", solution.stats);
    assert!(solution.stats.iterations >= 3, "{:?}", solution.stats);
    assert_eq!(solution.stats.inertia_corrections, 0);
    assert_eq!(allocations, SOLUTION_VECTORS, "{:?}", solution.stats);
}

#[test]
fn a_warm_solve_with_the_monotone_barrier_allocates_only_its_solution() {
    let options = IpmOptions {
        mu_strategy: MuStrategy::Monotone,
        ..IpmOptions::default()
    };
    let (mut tank, mut ipm, first) = solved_once(options);
    let x = shifted(&first.x, 2);
    // The dynamics rows come first, one per stage; the floors after them.
    let mut lambda = shifted(&first.multipliers[..tank.n], 1);
    lambda.extend(shifted(&first.multipliers[tank.n..], 1));
    let nu = shifted(&first.bound_multipliers, 2);
    let (solution, allocations) =
        allocations_of(|| ipm.solve(&mut tank, Start::warm(&x, &lambda, &nu)));
    assert!(solution.status.is_success(), "{:?}", solution.stats);
    assert!(solution.stats.iterations >= 1, "{:?}", solution.stats);
    assert_eq!(allocations, SOLUTION_VECTORS, "{:?}", solution.stats);
}

#[test]
fn the_allocations_of_a_solve_do_not_grow_with_its_iterations() {
    let (mut tank, mut ipm, _) = solved_once(IpmOptions::default());
    let start = vec![0.5; tank.n_vars()];
    let mut counts = Vec::new();
    for limit in [1, 2, 4, 8] {
        ipm.set_iteration_limit(Some(limit));
        let (solution, allocations) = allocations_of(|| ipm.solve(&mut tank, Start::cold(&start)));
        assert_eq!(solution.stats.iterations, limit, "{:?}", solution.stats);
        counts.push(allocations);
    }
    assert_eq!(counts, [SOLUTION_VECTORS; 4]);
}
