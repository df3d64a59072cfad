//! `ghm check`: parse, check, summarise, and optionally verify derivatives.

use crate::cli::CliError;
use crate::graph::{Op, Sparsity};
use crate::job::load_model;
use crate::lang::diagnostic::{render, Diagnostic};
use crate::model::singular::singularities;
use crate::model::verify::{verify_step_derivatives, Entry, NonFiniteEntry};
use crate::model::Plant;
use crate::sim::weather::builtin_season;
use clap::Args;
use rand::{Rng, SeedableRng};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct CheckArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// Compare the exact Jacobian and Hessian of the discrete step and stage terms with
    /// central finite differences at the initial point and at random points; fail above 1e-6.
    #[arg(long)]
    pub verify_derivatives: bool,
    /// Number of random points for --verify-derivatives (at most 10 000).
    #[arg(long, default_value_t = 8)]
    pub points: usize,
}

/// The most random points `--verify-derivatives` checks.
const MAX_POINTS: usize = 10_000;

fn list<T>(items: &[T], f: impl Fn(&T) -> String) -> String {
    items.iter().map(f).collect::<Vec<_>>().join(", ")
}

pub fn run(args: &CheckArgs) -> Result<(), CliError> {
    let model = load_model(&args.file)?;
    let plant = Plant::new(model);
    let m = &plant.model;
    let l = plant.layout;
    println!("model {} — {}", m.name, m.description);
    println!(
        "  states       ({}): {}",
        l.nx,
        list(&m.states, |s| format!("{} [{}]", s.info.name, s.info.unit))
    );
    println!(
        "  inputs       ({}): {}",
        l.nu,
        list(&m.inputs, |u| format!(
            "{} [{}] in [{}, {}]{}",
            u.info.name,
            u.info.unit,
            u.lower,
            u.upper,
            u.rate.map_or(String::new(), |r| format!(" rate {r}"))
        ))
    );
    println!(
        "  disturbances ({}): {}",
        l.nd,
        list(&m.disturbances, |d| d.info.name.clone())
    );
    let uncertain = m
        .params
        .iter()
        .filter(|p| p.kind == crate::lang::ast::ParamKind::Uncertain)
        .count();
    println!("  parameters   ({}): {} marked uncertain", l.np, uncertain);
    println!(
        "  outputs      ({}): {}",
        m.outputs.len(),
        list(&m.outputs, |o| format!("{} [{}]", o.info.name, o.info.unit))
    );
    println!(
        "  objective: {} term(s): {}",
        m.terms.len(),
        list(&m.terms, |t| format!(
            "{} {}",
            t.kind.keyword(),
            t.info.name
        ))
    );
    println!(
        "  soft bands: {}",
        list(&m.soft, |b| format!(
            "{} in [{}, {}]",
            m.outputs[b.output].info.name, b.lower, b.upper
        ))
    );
    let planning = if m.plans_with_other_substeps() {
        format!(", controllers predict with {}", m.plan_substeps)
    } else {
        String::new()
    };
    println!(
        "  sample period {} s, {} with {} sub-step(s){planning}",
        m.sample_period,
        m.integrator.name(),
        m.substeps
    );
    let roots: Vec<_> = plant
        .next_state
        .iter()
        .chain(&plant.stage_terms)
        .chain(&plant.next_outputs)
        .copied()
        .collect();
    let tree = plant.graph.tree_size(&roots);
    let dag = plant.graph.reachable(&roots).len();
    println!(
        "  discrete step graph: {tree:.3e} nodes as trees, {dag} after sharing ({:.1e}× smaller)",
        tree / dag as f64
    );
    let tape = plant.step_tape();
    let wrt: Vec<usize> = (0..l.nx + l.nu).collect();
    if plant.is_implicit() {
        println!(
            "  implicit step: stage equations and outputs on one tape of {} instructions, \
             solved by Newton; exact derivatives by the implicit function theorem",
            tape.n_instructions()
        );
    } else {
        let sp = Sparsity::of(tape, &wrt);
        println!(
        "  step tape: {} instructions; Jacobian wrt (x, u): {} of {} entries non-zero; Hessian: {} of {} lower-triangle entries",
        tape.n_instructions(),
        sp.jacobian_nnz(),
        tape.n_outputs() * wrt.len(),
        sp.hessian.len(),
        wrt.len() * (wrt.len() + 1) / 2
    );
    }
    warn_singularities(&plant);
    if args.verify_derivatives {
        if args.points > MAX_POINTS {
            return Err(CliError::Argument(format!(
                "--points {}: at most {MAX_POINTS} random points",
                args.points
            )));
        }
        let points = sample_points(&plant, args.points);
        let r = verify_step_derivatives(&plant, &points);
        if let Some(bad) = r.non_finite {
            return Err(CliError::DerivativeNotFinite(describe_non_finite(
                &plant, &bad,
            )));
        }
        println!(
            "  derivative check at {} points: Jacobian max rel. error {:.2e}, Hessian max rel. error {:.2e}",
            r.points, r.jacobian_max_rel_error, r.hessian_max_rel_error
        );
        // NaN (a finite difference that was not finite) fails too.
        if r.max().is_nan() || r.max() > 1e-6 {
            return Err(CliError::DerivativeCheck(r.max()));
        }
        println!("  derivatives OK (≤ 1e-6)");
    }
    Ok(())
}

/// Warns (W002) at each expression whose value or exact derivative is not finite at the
/// initial state and start input (weather from the built-in season's first row).
fn warn_singularities(plant: &Plant) {
    let Some(mut point) = sample_points(plant, 0).into_iter().next() else {
        return;
    };
    point.extend(plant.model.states.iter().map(|s| s.initial));
    let found = singularities(&plant.model, &point);
    let warnings: Vec<Diagnostic> = found
        .iter()
        .filter_map(|s| {
            let what = match s.partial {
                Some(p) => format!("its derivative is {p} at the initial state (value {})", s.value),
                None => format!("its value is {} at the initial state", s.value),
            };
            let op = match s.op {
                Op::Powf(bits) => format!("the power ^{}", f64::from_bits(bits)),
                Op::Powi(n) => format!("the power ^{n}"),
                op => format!("`{}`", format!("{op:?}").to_lowercase()),
            };
            Some(
                Diagnostic::warning("W002", s.span?, format!("{op} here is singular: {what}"))
                    .label("not differentiable here")
                    .help("an optimiser needs finite derivatives: smooth it (e.g. `0.5 + 0.5 * tanh(z / 2)` for a logistic switch, `sqrt(x^2 + eps^2)` for `abs(x)`), or keep the state away from this point"),
            )
        })
        .collect();
    if !warnings.is_empty() {
        eprint!("{}", render(&plant.model.sources, &warnings));
    }
    let unplaced = found.len() - warnings.len();
    if unplaced > 0 {
        eprintln!(
            "warning: {unplaced} operation(s) of the model are singular at the initial state"
        );
    }
}

/// "at the initial point, ∂(state `x` after the step)/∂(input `u`) is NaN; ...".
fn describe_non_finite(plant: &Plant, bad: &NonFiniteEntry) -> String {
    let out = |row| plant.describe(plant.step_quantity(row));
    let what = match bad.entry {
        Entry::Value { row } => format!("the value of {}", out(row)),
        Entry::Jacobian { row, col } => {
            format!("∂({}) / ∂({})", out(row), plant.describe_variable(col))
        }
        Entry::Hessian { row, col } => format!(
            "a second derivative ∂² / ∂({}) ∂({}) of the step",
            plant.describe_variable(row),
            plant.describe_variable(col)
        ),
    };
    let point = if bad.point == 0 {
        "the initial state and start input".to_string()
    } else {
        format!("random point {} around the initial state", bad.point)
    };
    format!(
        "at {point}, {what} is {}; the model is not defined or not differentiable there \
         (a division by zero, log or sqrt of zero or a negative number, an overflow)",
        bad.value
    )
}

/// The initial point and random points around it, with weather from the built-in season
/// (or the disturbances' constant values).
fn sample_points(plant: &Plant, n: usize) -> Vec<Vec<f64>> {
    let m = &plant.model;
    let l = plant.layout;
    let frame = builtin_season(48 * 40, m.sample_period.max(1.0), 7);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let p = m.nominal_params();
    (0..=n)
        .map(|k| {
            let jitter = |rng: &mut rand_chacha::ChaCha8Rng, v: f64| {
                if k == 0 {
                    v
                } else {
                    v * (1.0 + rng.random_range(-0.2..0.2))
                }
            };
            let mut z = Vec::with_capacity(l.n_base());
            for s in &m.states {
                z.push(jitter(&mut rng, s.initial));
            }
            for u in &m.inputs {
                let mid = if u.lower.is_finite() && u.upper.is_finite() {
                    0.5 * (u.lower + u.upper)
                } else {
                    u.start
                };
                z.push(if k == 0 {
                    u.start
                } else {
                    jitter(&mut rng, mid)
                });
            }
            let row = (k * 97) % frame.rows().max(1);
            for d in &m.disturbances {
                let from_frame = d
                    .column
                    .as_deref()
                    .and_then(|c| frame.column(c))
                    .and_then(|col| col.get(row).copied());
                z.push(d.value.or(from_frame).unwrap_or(0.0));
            }
            z.extend_from_slice(&p);
            z
        })
        .collect()
}
