//! The IPOPT back-end (cargo feature `ipopt`): the system's IPOPT, through the C shim of
//! the `ipopt-sys` crate, with the exact Hessian of the [`Nlp`].
//!
//! Every solve creates and frees its own IPOPT problem. The [`Nlp`] reaches the callbacks
//! through IPOPT's user-data pointer; each callback catches panics and reports
//! non-finite values as a failed evaluation, so that IPOPT decides what to do and a solve
//! ends with a [`SolveStatus`] rather than a crash. IPOPT prints nothing at the default
//! `print_level` 0 (its banner is suppressed too). Solves are serialised process-wide:
//! IPOPT with the sequential MUMPS is not thread-safe.
//!
//! Multipliers: IPOPT's stationarity is `∇f + Jᵀλ − z_L + z_U = 0`; this module returns
//! `λ` as is and `ν = z_U − z_L`, and splits a warm start's `ν` back into `z_L, z_U`.

use super::scaled_objective::solve_scaled;
use super::solution_builder::{Ending, SolutionBuilder};
use super::{kkt_residuals, Solution, SolveStatus, Solver, Start};
use crate::nlp::{Nlp, Pattern};
use ipopt_sys as sys;
use std::ffi::{c_void, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Mutex, PoisonError};

/// Options of the IPOPT back-end. Values out of IPOPT's ranges fail a solve (with
/// [`SolveStatus::NumericalError`]) before IPOPT sees them, as IPOPT would print about them.
#[derive(Debug, Clone, PartialEq)]
pub struct IpoptOptions {
    /// IPOPT's `tol`: relative KKT tolerance of an optimal solve.
    pub tol: f64,
    /// IPOPT's `acceptable_tol`.
    pub acceptable_tol: f64,
    pub max_iter: usize,
    /// IPOPT's `print_level` (0 to 12); 0 prints nothing.
    pub print_level: i32,
    /// Start from the start's multipliers when it has some (IPOPT's
    /// `warm_start_init_point`).
    pub warm_start: bool,
    /// Initial barrier parameter of a warm start (a cold start uses IPOPT's default).
    pub warm_start_mu_init: f64,
    /// How far a warm start's point and multipliers are pushed off their bounds.
    pub warm_start_push: f64,
    /// IPOPT's `linear_solver`: `mumps` (Debian's IPOPT has no other), `ma27`, `ma57`,
    /// `ma77`, `ma86`, `ma97`, `pardiso`, `wsmp`, `spral` or `custom`. A solve fails on
    /// another name, and on one the installed IPOPT lacks.
    pub linear_solver: String,
}

impl Default for IpoptOptions {
    fn default() -> Self {
        IpoptOptions {
            tol: 1e-8,
            acceptable_tol: 1e-6,
            max_iter: 500,
            print_level: 0,
            warm_start: true,
            warm_start_mu_init: 1e-4,
            warm_start_push: 1e-9,
            linear_solver: "mumps".to_string(),
        }
    }
}

/// The settings of IPOPT's `linear_solver` (3.11 to 3.14).
const LINEAR_SOLVERS: [&str; 10] = [
    "ma27", "ma57", "ma77", "ma86", "ma97", "pardiso", "wsmp", "mumps", "spral", "custom",
];

/// Serialises solves: IPOPT with the sequential MUMPS (Debian's) is not thread-safe, and
/// two solves at once in one process crash it (`PB allocation in DMUMPS_LOAD_INIT`).
static IPOPT_LOCK: Mutex<()> = Mutex::new(());

/// IPOPT as a [`Solver`]. Solves from several threads are safe but run one at a time.
///
/// # Examples
///
/// (Built and run only with `--features ipopt`.) One and the same optimal-control problem,
/// the CSTR over four steps, solved by IPOPT and by the default [`Sqp`](crate::solve::Sqp):
/// the back-ends agree.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::nlp::{Nlp, Ocp};
/// use ghm::solve::{Ipopt, IpoptOptions, Solver, Sqp, Start};
/// use std::sync::Arc;
///
/// let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/cstr.ghm");
/// let plant = Arc::new(ghm::model::Plant::new(ghm::lang::load(&file).map_err(|e| e.render())?));
/// let mut ocp = Ocp::new(plant.clone(), 4)?;
/// let (x0, u0) = (plant.model.initial_state(), plant.model.start_input());
/// ocp.set_problem(0, &x0, &u0, &[])?; // no disturbances
/// let mut start = vec![0.0; ocp.n_vars()];
/// ocp.initial_point(&mut start);
///
/// let by_ipopt = Ipopt::new(IpoptOptions::default()).solve(&mut ocp, Start::cold(&start));
/// let by_sqp = Sqp::default().solve(&mut ocp, Start::cold(&start));
/// assert!(by_ipopt.status.is_success() && by_sqp.status.is_success());
/// let (a, b) = (by_ipopt.stats.objective, by_sqp.stats.objective);
/// assert!((a - b).abs() <= 1e-6 * (1.0 + b.abs()), "{a} against {b}");
/// // The first input, the one MPC applies, within its rate limit of 3 K.
/// let u = ocp.input(&by_ipopt.x, 0)[0];
/// assert!((u - ocp.input(&by_sqp.x, 0)[0]).abs() < 1e-4);
/// assert!((u - 300.0).abs() <= 3.0 + 1e-7);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, Default)]
pub struct Ipopt {
    pub options: IpoptOptions,
    /// A temporary cap on the iterations, below `options.max_iter`.
    iteration_limit: Option<usize>,
}

impl Ipopt {
    pub fn new(options: IpoptOptions) -> Ipopt {
        Ipopt {
            options,
            iteration_limit: None,
        }
    }
}

/// What the callbacks see through the user-data pointer.
struct Context<'a> {
    nlp: &'a mut dyn Nlp,
    start: Start<'a>,
    jacobian: Pattern,
    hessian: Pattern,
    n: usize,
    m: usize,
    iterations: usize,
}

/// A solve that never reached IPOPT (bad input, or IPOPT refused the problem).
fn failed(nlp: &mut dyn Nlp, x: Vec<f64>, builder: SolutionBuilder) -> Solution {
    builder.refused(SolveStatus::NumericalError, x, nlp.n_cons())
}

impl Solver for Ipopt {
    fn name(&self) -> &'static str {
        "ipopt"
    }

    fn set_iteration_limit(&mut self, limit: Option<usize>) {
        self.iteration_limit = limit;
    }

    /// 40 (the interior point's is 80): from `mu_init = 1e-4` IPOPT's monotone barrier often
    /// needs more iterations to its tolerance than SQP's 15. With that budget the warm solve
    /// ran out on most of the paper season's steps at 6 h, each then re-solved cold (some
    /// solves failed, and the steps took much longer); with 40, a handful of cold
    /// re-solves and no failure (measured: `docs/benchmarks.md`, "The same problems, two
    /// back-ends: where the reward differences come from").
    fn warm_iteration_budget(&self) -> usize {
        40
    }

    fn solve(&mut self, nlp: &mut dyn Nlp, start: Start<'_>) -> Solution {
        solve_scaled(nlp, start, |nlp, start, scale| {
            self.solve_in_scale(nlp, start, scale)
        })
    }
}

impl Ipopt {
    /// A solve of `nlp`, whose objective is the problem's times `objective_scale` (which
    /// a warm start's barrier follows).
    fn solve_in_scale(
        &mut self,
        nlp: &mut dyn Nlp,
        start: Start<'_>,
        objective_scale: f64,
    ) -> Solution {
        let builder = SolutionBuilder::start("ipopt", false);
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        let (jacobian, hessian) = (
            nlp.jacobian_pattern().clone(),
            nlp.hessian_pattern().clone(),
        );
        let o = &self.options;
        let positive = |v: f64| v > 0.0 && v.is_finite();
        let input_ok = LINEAR_SOLVERS.contains(&o.linear_solver.as_str())
            && [o.tol, o.acceptable_tol, o.warm_start_mu_init]
                .into_iter()
                .all(positive)
            && positive(o.warm_start_push)
            && o.warm_start_push <= 0.5
            && (0..=12).contains(&o.print_level)
            && start.x.len() == n
            && start.multipliers.is_none_or(|l| l.len() == m)
            && start.bound_multipliers.is_none_or(|v| v.len() == n)
            && [n, m, jacobian.len(), hessian.len()]
                .iter()
                .all(|&k| k <= i32::MAX as usize)
            && pattern_ok(&jacobian, m, n)
            && pattern_ok(&hessian, n, n);
        if !input_ok {
            let mut x = vec![0.0; n];
            nlp.initial_point(&mut x);
            return failed(nlp, x, builder);
        }
        let limit = self
            .iteration_limit
            .map_or(o.max_iter, |cap| cap.min(o.max_iter));
        let max_iter = i32::try_from(limit).unwrap_or(i32::MAX);
        let mut options = vec![
            ("print_level", Value::Int(o.print_level)),
            ("sb", Value::Str("yes")),
            // Not a stray `ipopt.opt` of the working directory.
            ("option_file_name", Value::Str("")),
            ("tol", Value::Num(o.tol)),
            ("acceptable_tol", Value::Num(o.acceptable_tol)),
            ("max_iter", Value::Int(max_iter)),
            ("hessian_approximation", Value::Str("exact")),
            ("linear_solver", Value::Str(&o.linear_solver)),
        ];
        // A primal-dual point only: IPOPT's warm start needs the bound multipliers too.
        if o.warm_start && start.multipliers.is_some() && start.bound_multipliers.is_some() {
            options.extend([
                ("warm_start_init_point", Value::Str("yes")),
                (
                    "mu_init",
                    Value::Num(start.barrier.unwrap_or(o.warm_start_mu_init) * objective_scale),
                ),
                ("warm_start_bound_push", Value::Num(o.warm_start_push)),
                ("warm_start_bound_frac", Value::Num(o.warm_start_push)),
                ("warm_start_slack_bound_push", Value::Num(o.warm_start_push)),
                ("warm_start_slack_bound_frac", Value::Num(o.warm_start_push)),
                ("warm_start_mult_bound_push", Value::Num(o.warm_start_push)),
            ]);
        }
        let mut ctx = Context {
            nlp,
            start,
            jacobian,
            hessian,
            n,
            m,
            iterations: 0,
        };
        let user_data = &mut ctx as *mut Context<'_> as *mut c_void;
        let _lock = IPOPT_LOCK.lock().unwrap_or_else(PoisonError::into_inner);
        let mut problem: sys::CNLP_ProblemPtr = std::ptr::null_mut();
        // SAFETY: the callbacks match the shim's signatures; `problem` is freed below.
        let created = unsafe {
            sys::cnlp_create_problem(
                &mut problem,
                0,
                Some(sizes),
                Some(init),
                Some(bounds),
                Some(eval_f),
                Some(eval_g),
                Some(eval_grad_f),
                Some(eval_jac_g),
                Some(eval_h),
                None,
            )
        };
        if created != sys::CNLP_CreateProblemStatus_CNLP_SUCCESS || problem.is_null() {
            return failed(ctx.nlp, start.x.to_vec(), builder);
        }
        let options_ok = options
            .into_iter()
            .all(|(key, value)| set(problem, key, value));
        // SAFETY: `problem` is live, `user_data` points at `ctx`, which outlives the calls
        // and is reached only through that pointer until they return.
        let (status, (x, lambda, z_l, z_u)) = unsafe {
            sys::cnlp_set_intermediate_callback(problem, Some(intermediate));
            // Sizes the solution buffers to n and m and fills them with the start.
            let sized = sys::cnlp_init_solution(problem, user_data) != 0;
            let status = (sized && options_ok).then(|| sys::cnlp_solve(problem, user_data).status);
            let data = sys::cnlp_get_solver_data(problem);
            let out = if sized {
                let copy = |p: *const f64, len| slice(p, len).to_vec();
                (
                    copy(data.x, n),
                    copy(data.mult_g, m),
                    copy(data.mult_x_L, n),
                    copy(data.mult_x_U, n),
                )
            } else {
                (start.x.to_vec(), vec![0.0; m], vec![0.0; n], vec![0.0; n])
            };
            sys::cnlp_free_problem(problem);
            (status, out)
        };
        let status = status.map_or(SolveStatus::NumericalError, map_status);
        let nu: Vec<f64> = z_u.iter().zip(&z_l).map(|(u, l)| u - l).collect();
        let nlp = ctx.nlp;
        let objective = nlp.objective(&x);
        let kkt = kkt_residuals(nlp, &x, &lambda, &nu);
        let ending = Ending {
            status,
            iterations: ctx.iterations,
            objective,
            kkt,
            inertia_corrections: 0,
        };
        builder.build(ending, x, lambda, nu)
    }
}

fn map_status(status: sys::CNLP_ApplicationReturnStatus) -> SolveStatus {
    match status {
        sys::CNLP_ApplicationReturnStatus_CNLP_SOLVE_SUCCEEDED => SolveStatus::Optimal,
        sys::CNLP_ApplicationReturnStatus_CNLP_SOLVED_TO_ACCEPTABLE_LEVEL => {
            SolveStatus::Acceptable
        }
        sys::CNLP_ApplicationReturnStatus_CNLP_MAXIMUM_ITERATIONS_EXCEEDED => {
            SolveStatus::MaxIterations
        }
        sys::CNLP_ApplicationReturnStatus_CNLP_INFEASIBLE_PROBLEM_DETECTED => {
            SolveStatus::Infeasible
        }
        sys::CNLP_ApplicationReturnStatus_CNLP_INVALID_NUMBER_DETECTED => {
            SolveStatus::InvalidNumber
        }
        _ => SolveStatus::NumericalError,
    }
}

/// A value of an IPOPT option.
enum Value<'a> {
    Str(&'a str),
    Num(f64),
    Int(i32),
}

/// Sets an option of a live problem; false when IPOPT refuses it.
fn set(problem: sys::CNLP_ProblemPtr, key: &str, value: Value<'_>) -> bool {
    let Ok(key) = CString::new(key) else {
        return false;
    };
    // SAFETY: a live problem and NUL-terminated strings that outlive the call.
    unsafe {
        match value {
            Value::Str(v) => CString::new(v)
                .is_ok_and(|v| sys::cnlp_add_str_option(problem, key.as_ptr(), v.as_ptr()) != 0),
            Value::Num(v) => sys::cnlp_add_num_option(problem, key.as_ptr(), v) != 0,
            Value::Int(v) => sys::cnlp_add_int_option(problem, key.as_ptr(), v) != 0,
        }
    }
}

/// Whether every entry of a pattern lies in a `rows × cols` matrix.
fn pattern_ok(pattern: &Pattern, rows: usize, cols: usize) -> bool {
    pattern.rows.len() == pattern.cols.len()
        && (pattern.rows.iter().zip(&pattern.cols)).all(|(&r, &c)| r < rows && c < cols)
}

/// The slice behind a buffer of IPOPT's, of at least `len` elements unless null.
unsafe fn slice<'a, T>(p: *const T, len: usize) -> &'a [T] {
    if p.is_null() || len == 0 {
        &[]
    } else {
        std::slice::from_raw_parts(p, len)
    }
}

/// The mutable slice behind a buffer of IPOPT's, as [`slice`].
unsafe fn slice_mut<'a, T>(p: *mut T, len: usize) -> &'a mut [T] {
    if p.is_null() || len == 0 {
        &mut []
    } else {
        std::slice::from_raw_parts_mut(p, len)
    }
}

/// Runs a callback body on the context: false (IPOPT's failed evaluation) on a panic.
///
/// # Safety
/// `user_data` is the `Context` that `Ipopt::solve` passed to IPOPT, live and not
/// otherwise borrowed during the solve.
unsafe fn with(user_data: *mut c_void, body: impl FnOnce(&mut Context<'_>) -> bool) -> i32 {
    let ctx = &mut *(user_data as *mut Context<'_>);
    catch_unwind(AssertUnwindSafe(|| body(ctx))).unwrap_or(false) as i32
}

fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

/// Writes a pattern's coordinates as IPOPT's (C-style) indices.
unsafe fn write_pattern(pattern: &Pattern, rows: *mut i32, cols: *mut i32) -> bool {
    let rows = slice_mut(rows, pattern.len()).iter_mut();
    let cols = slice_mut(cols, pattern.len()).iter_mut();
    for ((row, col), (&r, &c)) in rows.zip(cols).zip(pattern.rows.iter().zip(&pattern.cols)) {
        // Checked against i32 in `Ipopt::solve`.
        (*row, *col) = (r as i32, c as i32);
    }
    true
}

unsafe extern "C" fn sizes(
    n: *mut i32,
    m: *mut i32,
    nj: *mut i32,
    nh: *mut i32,
    u: *mut c_void,
) -> i32 {
    with(u, |c| {
        (*n, *m) = (c.n as i32, c.m as i32);
        (*nj, *nh) = (c.jacobian.len() as i32, c.hessian.len() as i32);
        true
    })
}

#[allow(clippy::too_many_arguments)]
unsafe extern "C" fn init(
    _: i32,
    init_x: i32,
    x: *mut f64,
    init_z: i32,
    z_l: *mut f64,
    z_u: *mut f64,
    _: i32,
    init_lambda: i32,
    lambda: *mut f64,
    u: *mut c_void,
) -> i32 {
    with(u, |c| {
        if init_x != 0 {
            slice_mut(x, c.n).copy_from_slice(c.start.x);
        }
        if init_z != 0 {
            let (z_l, z_u) = (slice_mut(z_l, c.n), slice_mut(z_u, c.n));
            let nu = c.start.bound_multipliers.unwrap_or(&[]);
            for i in 0..c.n {
                let v = nu.get(i).copied().unwrap_or(0.0);
                (z_l[i], z_u[i]) = ((-v).max(0.0), v.max(0.0));
            }
        }
        if init_lambda != 0 {
            let lambda = slice_mut(lambda, c.m);
            match c.start.multipliers {
                Some(l) => lambda.copy_from_slice(l),
                None => lambda.fill(0.0),
            }
        }
        true
    })
}

unsafe extern "C" fn bounds(
    _: i32,
    x_l: *mut f64,
    x_u: *mut f64,
    _: i32,
    g_l: *mut f64,
    g_u: *mut f64,
    u: *mut c_void,
) -> i32 {
    with(u, |c| {
        c.nlp.var_bounds(slice_mut(x_l, c.n), slice_mut(x_u, c.n));
        c.nlp.con_bounds(slice_mut(g_l, c.m), slice_mut(g_u, c.m));
        true
    })
}

unsafe extern "C" fn eval_f(_: i32, x: *const f64, _: i32, f: *mut f64, u: *mut c_void) -> i32 {
    with(u, |c| {
        *f = c.nlp.objective(slice(x, c.n));
        f.read().is_finite()
    })
}

unsafe extern "C" fn eval_grad_f(
    _: i32,
    x: *const f64,
    _: i32,
    g: *mut f64,
    u: *mut c_void,
) -> i32 {
    with(u, |c| {
        let g = slice_mut(g, c.n);
        c.nlp.gradient(slice(x, c.n), g);
        finite(g)
    })
}

unsafe extern "C" fn eval_g(
    _: i32,
    x: *const f64,
    _: i32,
    _: i32,
    g: *mut f64,
    u: *mut c_void,
) -> i32 {
    with(u, |c| {
        let g = slice_mut(g, c.m);
        c.nlp.constraints(slice(x, c.n), g);
        finite(g)
    })
}

#[allow(clippy::too_many_arguments)]
unsafe extern "C" fn eval_jac_g(
    _: i32,
    x: *const f64,
    _: i32,
    _: i32,
    _: i32,
    rows: *mut i32,
    cols: *mut i32,
    values: *mut f64,
    u: *mut c_void,
) -> i32 {
    with(u, |c| {
        if values.is_null() {
            return write_pattern(&c.jacobian, rows, cols);
        }
        let values = slice_mut(values, c.jacobian.len());
        c.nlp.jacobian_values(slice(x, c.n), values);
        finite(values)
    })
}

#[allow(clippy::too_many_arguments)]
unsafe extern "C" fn eval_h(
    _: i32,
    x: *const f64,
    _: i32,
    sigma: f64,
    _: i32,
    lambda: *const f64,
    _: i32,
    _: i32,
    rows: *mut i32,
    cols: *mut i32,
    values: *mut f64,
    u: *mut c_void,
) -> i32 {
    with(u, |c| {
        if values.is_null() {
            return write_pattern(&c.hessian, rows, cols);
        }
        let values = slice_mut(values, c.hessian.len());
        c.nlp
            .hessian_values(slice(x, c.n), sigma, slice(lambda, c.m), values);
        finite(values)
    })
}

#[allow(clippy::too_many_arguments)]
unsafe extern "C" fn intermediate(
    _: sys::CNLP_AlgorithmMode,
    iteration: i32,
    _: f64,
    _: f64,
    _: f64,
    _: f64,
    _: f64,
    _: f64,
    _: f64,
    _: f64,
    _: i32,
    u: *mut c_void,
) -> i32 {
    with(u, |c| {
        c.iterations = c.iterations.max(usize::try_from(iteration).unwrap_or(0));
        true
    })
}
