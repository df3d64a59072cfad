//! The IPOPT back-end on small hand-written programs: Hock–Schittkowski 71 (optimum,
//! KKT residuals, multiplier signs, warm start), an infeasible program and one whose
//! objective is not finite.
#![cfg(feature = "ipopt")]

use ghm::nlp::{Nlp, Pattern};
use ghm::solve::{Ipopt, IpoptOptions, SolveStatus, Solver, Start};

/// HS071: min x1 x4 (x1 + x2 + x3) + x3 s.t. x1 x2 x3 x4 ≥ 25, Σ xi² = 40, 1 ≤ xi ≤ 5.
struct Hs071 {
    jacobian: Pattern,
    hessian: Pattern,
    /// The objective scale it asks the solvers for.
    objective_scale: f64,
}

impl Hs071 {
    fn new() -> Hs071 {
        let mut jacobian = Pattern::default();
        for row in 0..2 {
            for col in 0..4 {
                jacobian.push(row, col);
            }
        }
        let mut hessian = Pattern::default();
        for row in 0..4 {
            for col in 0..=row {
                hessian.push(row, col);
            }
        }
        Hs071 {
            jacobian,
            hessian,
            objective_scale: 1.0,
        }
    }
}

impl Nlp for Hs071 {
    fn objective_scaling(&self) -> f64 {
        self.objective_scale
    }
    fn n_vars(&self) -> usize {
        4
    }
    fn n_cons(&self) -> usize {
        2
    }
    fn var_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        lower.fill(1.0);
        upper.fill(5.0);
    }
    fn con_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        lower.copy_from_slice(&[25.0, 40.0]);
        upper.copy_from_slice(&[f64::INFINITY, 40.0]);
    }
    fn initial_point(&mut self, x: &mut [f64]) {
        x.copy_from_slice(&[1.0, 5.0, 5.0, 1.0]);
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2]
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = x[3] * (2.0 * x[0] + x[1] + x[2]);
        g[1] = x[0] * x[3];
        g[2] = x[0] * x[3] + 1.0;
        g[3] = x[0] * (x[0] + x[1] + x[2]);
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = x.iter().product();
        g[1] = x.iter().map(|v| v * v).sum();
    }
    fn jacobian_pattern(&self) -> &Pattern {
        &self.jacobian
    }
    fn jacobian_values(&mut self, x: &[f64], v: &mut [f64]) {
        for i in 0..4 {
            v[i] = (0..4).filter(|&j| j != i).map(|j| x[j]).product();
            v[4 + i] = 2.0 * x[i];
        }
    }
    fn hessian_pattern(&self) -> &Pattern {
        &self.hessian
    }
    fn hessian_values(&mut self, x: &[f64], sigma: f64, l: &[f64], v: &mut [f64]) {
        // Lower triangle, row by row: (0,0) (1,0) (1,1) (2,0) (2,1) (2,2) (3,0) .. (3,3).
        let mut k = 0;
        for r in 0..4 {
            for c in 0..=r {
                let objective = match (r, c) {
                    (0, 0) => 2.0 * x[3],
                    (1, 0) | (2, 0) => x[3],
                    (3, 0) => 2.0 * x[0] + x[1] + x[2],
                    (3, 1) | (3, 2) => x[0],
                    _ => 0.0,
                };
                let product = if r == c {
                    0.0
                } else {
                    (0..4).filter(|&j| j != r && j != c).map(|j| x[j]).product()
                };
                let squares = if r == c { 2.0 } else { 0.0 };
                v[k] = sigma * objective + l[0] * product + l[1] * squares;
                k += 1;
            }
        }
    }
}

const F_STAR: f64 = 17.014_017_3;

#[test]
fn hs071_cold_start_is_optimal_with_signed_multipliers() {
    let mut nlp = Hs071::new();
    let mut solver = Ipopt::default();
    assert_eq!(solver.name(), "ipopt");
    let sol = solver.solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    eprintln!(
        "cold: {:?} after {} iterations, {:?}",
        sol.status, sol.stats.iterations, sol.stats.kkt
    );
    assert_eq!(sol.status, SolveStatus::Optimal);
    assert!(
        (sol.stats.objective - F_STAR).abs() < 1e-6,
        "{}",
        sol.stats.objective
    );
    assert!(sol.stats.kkt.max() <= 1e-6, "{:?}", sol.stats.kkt);
    assert!(sol.stats.iterations > 0 && sol.stats.time_s > 0.0);
    // Optimum (1, 4.743, 3.821, 1.379): x1 at its lower bound, the product constraint at
    // its lower bound; both multipliers negative in the ∇f + Jᵀλ + ν = 0 convention.
    assert!((sol.x[0] - 1.0).abs() < 1e-7);
    assert!(
        sol.bound_multipliers[0] < -0.1,
        "{:?}",
        sol.bound_multipliers
    );
    assert!(sol.bound_multipliers[1..].iter().all(|v| v.abs() < 1e-6));
    assert!(sol.multipliers[0] < -0.1, "{:?}", sol.multipliers);
    // The multipliers IPOPT's own HS071 example prints (λ = (−0.552294, 0.161469),
    // z_L[0] = 1.087871), in ghm's convention ν = −z_L + z_U: an independent figure, where
    // this test used to compare the KKT residuals with themselves.
    for (got, want) in sol.multipliers.iter().zip([-0.552_294, 0.161_469]) {
        assert!((got - want).abs() < 1e-5, "{:?}", sol.multipliers);
    }
    assert!(
        (sol.bound_multipliers[0] + 1.087_871).abs() < 1e-5,
        "{:?}",
        sol.bound_multipliers
    );
}

#[test]
fn hs071_with_its_objective_scaled_gives_the_same_answer_in_its_own_units() {
    let mut nlp = Hs071 {
        objective_scale: 1000.0,
        ..Hs071::new()
    };
    let mut solver = Ipopt::default();
    let sol = solver.solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    assert_eq!(sol.status, SolveStatus::Optimal);
    assert!((sol.stats.objective - F_STAR).abs() < 1e-6);
    for (got, want) in sol.multipliers.iter().zip([-0.552_294, 0.161_469]) {
        assert!((got - want).abs() < 1e-5, "{:?}", sol.multipliers);
    }
    assert!((sol.bound_multipliers[0] + 1.087_871).abs() < 1e-5);
    let start = Start::warm(&sol.x, &sol.multipliers, &sol.bound_multipliers);
    let warm = solver.solve(&mut nlp, start);
    assert_eq!(warm.status, SolveStatus::Optimal);
    assert!(warm.stats.iterations <= 5, "{:?}", warm.stats);
}

#[test]
fn hs071_warm_start_from_the_solution_takes_few_iterations() {
    let mut nlp = Hs071::new();
    let mut solver = Ipopt::default();
    let cold = solver.solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    assert_eq!(cold.status, SolveStatus::Optimal);
    let start = Start::warm(&cold.x, &cold.multipliers, &cold.bound_multipliers);
    let warm = solver.solve(&mut nlp, start);
    eprintln!(
        "warm: {:?} after {} iterations (cold {}), {:?}",
        warm.status, warm.stats.iterations, cold.stats.iterations, warm.stats.kkt
    );
    assert_eq!(warm.status, SolveStatus::Optimal);
    assert!((warm.stats.objective - F_STAR).abs() < 1e-6);
    assert!(warm.stats.kkt.max() <= 1e-6, "{:?}", warm.stats.kkt);
    assert!(warm.stats.iterations <= 5 && warm.stats.iterations < cold.stats.iterations);
    // A warm start that is switched off solves as from cold.
    let mut off = Ipopt::new(IpoptOptions {
        warm_start: false,
        ..IpoptOptions::default()
    });
    let start = Start::warm(
        &[1.0, 5.0, 5.0, 1.0],
        &cold.multipliers,
        &cold.bound_multipliers,
    );
    assert_eq!(
        off.solve(&mut nlp, start).stats.iterations,
        cold.stats.iterations
    );
}

#[test]
fn max_iter_bad_starts_and_bad_options_end_without_success() {
    let mut nlp = Hs071::new();
    let mut solver = Ipopt::new(IpoptOptions {
        max_iter: 2,
        ..IpoptOptions::default()
    });
    let sol = solver.solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    assert_eq!(sol.status, SolveStatus::MaxIterations);
    assert_eq!(sol.stats.iterations, 2);
    let sol = Ipopt::default().solve(&mut nlp, Start::cold(&[1.0, 5.0]));
    assert!(!sol.status.is_success());
    assert_eq!((sol.x.len(), sol.multipliers.len()), (4, 2));
    let sol = Ipopt::new(IpoptOptions {
        linear_solver: "no-such-solver".into(),
        ..IpoptOptions::default()
    })
    .solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    assert!(!sol.status.is_success());
    let sol = Ipopt::new(IpoptOptions {
        tol: -1.0,
        ..IpoptOptions::default()
    })
    .solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    assert_eq!(sol.status, SolveStatus::NumericalError);
    // Debian's IPOPT has no MA27: IPOPT fails the solve, silently.
    let sol = Ipopt::new(IpoptOptions {
        linear_solver: "ma27".into(),
        ..IpoptOptions::default()
    })
    .solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    assert_eq!(sol.status, SolveStatus::NumericalError);
}

#[test]
fn solves_from_several_threads_at_once_do_not_interfere() {
    // The sequential MUMPS behind IPOPT is not thread-safe: the back-end serialises.
    let threads: Vec<_> = (0..4)
        .map(|_| {
            std::thread::spawn(|| {
                (0..5)
                    .map(|_| {
                        Ipopt::default()
                            .solve(&mut Hs071::new(), Start::cold(&[1.0, 5.0, 5.0, 1.0]))
                    })
                    .all(|sol| sol.status == SolveStatus::Optimal)
            })
        })
        .collect();
    for thread in threads {
        assert_eq!(thread.join().ok(), Some(true));
    }
}

/// min x² + y² s.t. x + y ≥ 3 (linear), x, y ∈ [0, 1]: infeasible, or with `nan`, an
/// objective that is never finite.
struct Small {
    nan: bool,
    jacobian: Pattern,
    hessian: Pattern,
}

impl Small {
    fn new(nan: bool) -> Small {
        Small {
            nan,
            jacobian: Pattern {
                rows: vec![0, 0],
                cols: vec![0, 1],
            },
            hessian: Pattern {
                rows: vec![0, 1],
                cols: vec![0, 1],
            },
        }
    }
}

impl Nlp for Small {
    fn n_vars(&self) -> usize {
        2
    }
    fn n_cons(&self) -> usize {
        1
    }
    fn var_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        lower.fill(0.0);
        upper.fill(1.0);
    }
    fn con_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        lower[0] = if self.nan { 0.0 } else { 3.0 };
        upper[0] = f64::INFINITY;
    }
    fn initial_point(&mut self, x: &mut [f64]) {
        x.fill(0.5);
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        if self.nan {
            f64::NAN
        } else {
            x[0] * x[0] + x[1] * x[1]
        }
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = 2.0 * x[0];
        g[1] = 2.0 * x[1];
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = x[0] + x[1];
    }
    fn jacobian_pattern(&self) -> &Pattern {
        &self.jacobian
    }
    fn jacobian_values(&mut self, _: &[f64], v: &mut [f64]) {
        v.fill(1.0);
    }
    fn hessian_pattern(&self) -> &Pattern {
        &self.hessian
    }
    fn hessian_values(&mut self, _: &[f64], sigma: f64, _: &[f64], v: &mut [f64]) {
        v.fill(2.0 * sigma);
    }
}

#[test]
fn infeasible_and_non_finite_programs_fail_without_panic() {
    let sol = Ipopt::default().solve(&mut Small::new(false), Start::cold(&[0.5, 0.5]));
    eprintln!(
        "infeasible: {:?} after {} iterations",
        sol.status, sol.stats.iterations
    );
    assert!(!sol.status.is_success());
    assert!(sol.stats.kkt.primal > 0.5);
    let sol = Ipopt::default().solve(&mut Small::new(true), Start::cold(&[0.5, 0.5]));
    eprintln!("nan: {:?}", sol.status);
    assert!(!sol.status.is_success());
}

#[test]
fn iteration_limit_caps_ipopt_until_lifted() {
    let mut nlp = Hs071::new();
    let mut solver = Ipopt::default();
    solver.set_iteration_limit(Some(2));
    let capped = solver.solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    assert_eq!(capped.status, SolveStatus::MaxIterations);
    assert!(capped.stats.iterations <= 2);
    solver.set_iteration_limit(None);
    let full = solver.solve(&mut nlp, Start::cold(&[1.0, 5.0, 5.0, 1.0]));
    assert_eq!(full.status, SolveStatus::Optimal);
}
