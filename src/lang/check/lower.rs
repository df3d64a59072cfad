//! Lowering: expressions to nodes of the model's [`Graph`](crate::graph::Graph), names
//! resolved, lets and outputs lowered on first use, constant expressions evaluated.
//!
//! Lowering keeps its own stack of tasks instead of recursing, so that neither a long chain
//! of lets (each lowered where it is first used) nor a deep expression can overflow the
//! call stack, whatever the model.

use super::{Checker, Context, Derived, Scope, Symbol};
use crate::graph::{NodeId, Op};
use crate::lang::ast::*;
use crate::lang::diagnostic::{did_you_mean, Diagnostic};
use crate::lang::source::Span;

/// A let or an output: the quantities lowered once, on first use.
#[derive(Debug, Clone, Copy)]
pub(super) enum Derivable {
    /// The let with this index.
    Let(usize),
    /// The output with this index.
    Output(usize),
}

/// One step of the lowering machine.
enum Task<'e> {
    /// Lower an expression: push its value (after lowering its parts).
    Visit(&'e Expr, Context),
    /// Combine the values of an expression's parts, on top of the value stack.
    Build(&'e Expr),
    /// Push the value of a let or output used at a place (lowering it first if needed).
    Use(Derivable, Span),
    /// The value on top of the stack is now lowered: remember it for the let or output.
    Finish(Derivable),
    /// A call of a `fn`, its arguments on top of the stack: lower its body with its
    /// parameters bound to them.
    Inline(&'e Expr, Context),
    /// The body of a function (or a let or output) is lowered: leave its scope.
    EndScope,
}

impl<'d> Checker<'d> {
    pub(super) fn unknown(&mut self, name: &Name) {
        let mut candidates: Vec<&str> = self.symbols.keys().map(String::as_str).collect();
        candidates.sort_unstable();
        let mut d = Diagnostic::error("E003", name.span, format!("unknown name `{}`", name.text))
            .label("not declared");
        d = match did_you_mean(&name.text, candidates.into_iter()) {
            Some(s) => d.help(format!("did you mean `{s}`?")),
            None => {
                d.help("declare it with `param`, `const`, `state`, `input`, `disturbance` or `let`")
            }
        };
        self.diags.push(d);
    }

    /// Evaluates a constant expression (parameters at their nominal values).
    pub(super) fn constant(&mut self, e: &Expr, what: &str) -> Option<f64> {
        let errors_before = self.diags.iter().filter(|d| d.is_error()).count();
        let n = self.lower(e, Context::Constant);
        let new_errors = self.diags.iter().filter(|d| d.is_error()).count() > errors_before;
        // A value left out of a reported cycle (E026) is NaN; its uses need no second error.
        let left_out = |v: f64| v.is_nan() && self.diags.iter().any(|d| d.code == "E026");
        match self.graph.as_constant(n) {
            Some(v) if !v.is_finite() && !new_errors && !left_out(v) => {
                self.diags.push(
                    Diagnostic::error("E022", e.span(), format!("{what} evaluates to {v}"))
                        .label("not a finite number")
                        .help("check for a division by zero, the log of a negative number or an overflow"),
                );
                None
            }
            Some(v) => Some(v),
            None => {
                self.diags.push(
                    Diagnostic::error(
                        "E015",
                        e.span(),
                        format!("{what} must be a constant expression"),
                    )
                    .label("depends on a state, input or disturbance")
                    .help("use numbers, constants and parameters declared above this line"),
                );
                None
            }
        }
    }

    /// Lowers an expression in a context.
    pub(super) fn lower(&mut self, e: &Expr, ctx: Context) -> NodeId {
        self.run_tasks(Task::Visit(e, ctx))
    }

    /// The node of a let or output used at `at`, lowered now if it was not yet.
    pub(super) fn derived(&mut self, which: Derivable, at: Span) -> NodeId {
        self.run_tasks(Task::Use(which, at))
    }

    /// Runs the machine from one task until its value is known. The tasks run in the order
    /// the recursive descent would take, so diagnostics and graph nodes come out in the
    /// same order.
    fn run_tasks(&mut self, first: Task<'_>) -> NodeId {
        // The tasks borrow both the expression given and the lets' and outputs' own.
        let mut tasks: Vec<Task<'_>> = vec![first];
        let mut values: Vec<NodeId> = Vec::new();
        while let Some(task) = tasks.pop() {
            match task {
                Task::Visit(e, ctx) => self.visit(e, ctx, &mut tasks, &mut values),
                Task::Build(e) => {
                    let node = self.build(e, &mut values);
                    values.push(node);
                }
                Task::Use(which, at) => self.use_derived(which, at, &mut tasks, &mut values),
                Task::Finish(which) => {
                    let node = self.pop(&mut values);
                    *self.slot(which) = Derived::Done(node);
                    values.push(node);
                }
                Task::Inline(e, ctx) => self.inline(e, ctx, &mut tasks, &mut values),
                Task::EndScope => {
                    self.scopes.pop();
                }
            }
        }
        debug_assert_eq!(values.len(), 1, "lowering left {} values", values.len());
        self.pop(&mut values)
    }

    /// The top value (a NaN constant if the stack is empty, which would be a bug).
    fn pop(&mut self, values: &mut Vec<NodeId>) -> NodeId {
        values
            .pop()
            .unwrap_or_else(|| self.graph.constant(f64::NAN))
    }

    fn slot(&mut self, which: Derivable) -> &mut Derived<'d> {
        match which {
            Derivable::Let(i) => &mut self.lets[i].1,
            Derivable::Output(i) => &mut self.outputs_derived[i],
        }
    }

    /// Pushes the value of a let or output, or the tasks that lower it first.
    fn use_derived<'e>(
        &mut self,
        which: Derivable,
        at: Span,
        tasks: &mut Vec<Task<'e>>,
        values: &mut Vec<NodeId>,
    ) where
        'd: 'e,
    {
        match std::mem::replace(self.slot(which), Derived::InProgress) {
            Derived::Done(n) => {
                *self.slot(which) = Derived::Done(n);
                values.push(n);
            }
            Derived::InProgress => {
                let d = match which {
                    Derivable::Let(i) => Diagnostic::error(
                        "E010",
                        at,
                        format!("`{}` depends on itself", self.lets[i].0),
                    )
                    .help("a `let` may not refer back to itself through other lets or outputs; break the cycle"),
                    Derivable::Output(_) => {
                        Diagnostic::error("E010", at, "this output depends on itself")
                            .help("break the cycle between outputs and lets")
                    }
                };
                self.diags.push(d.label("cycle through this use"));
                let nan = self.graph.constant(f64::NAN);
                // Marked done so that the cycle is reported once.
                *self.slot(which) = Derived::Done(nan);
                values.push(nan);
            }
            Derived::Pending(expr) => {
                // A let sees the model's names only, wherever it is first used.
                self.scopes.push(Scope {
                    function: None,
                    bindings: Vec::new(),
                });
                tasks.push(Task::Finish(which));
                tasks.push(Task::EndScope);
                tasks.push(Task::Visit(expr, Context::Dynamics));
            }
        }
    }

    /// Pushes the value of a leaf, or the tasks that lower the parts and then combine them.
    fn visit<'e>(
        &mut self,
        e: &'e Expr,
        ctx: Context,
        tasks: &mut Vec<Task<'e>>,
        values: &mut Vec<NodeId>,
    ) where
        'd: 'e,
    {
        let leaf = match e {
            Expr::Number(v, _) => self.graph.constant(*v),
            Expr::Name(n) => match self.name(n, ctx) {
                Ok(node) => node,
                Err(which) => return tasks.push(Task::Use(which, n.span)),
            },
            Expr::Next(n, span) => self.next(n, *span, ctx),
            Expr::Neg(a, _) | Expr::Not(a, _) => {
                tasks.push(Task::Build(e));
                return tasks.push(Task::Visit(a, ctx));
            }
            Expr::Call(f, args, span) if self.functions.contains_key(f.text.as_str()) => {
                if self.user_call(f, args.len(), *span) {
                    tasks.push(Task::Inline(e, ctx));
                    tasks.extend(args.iter().rev().map(|a| Task::Visit(a, ctx)));
                    return;
                }
                self.graph.constant(f64::NAN)
            }
            Expr::Binary(_, a, b, _) => {
                tasks.push(Task::Build(e));
                tasks.push(Task::Visit(b, ctx));
                return tasks.push(Task::Visit(a, ctx));
            }
            Expr::Call(f, args, span) => match self.function(f, args.len(), *span) {
                Some(_) => {
                    tasks.push(Task::Build(e));
                    tasks.extend(args.iter().rev().map(|a| Task::Visit(a, ctx)));
                    return;
                }
                None => self.graph.constant(f64::NAN),
            },
        };
        values.push(leaf);
    }

    /// Applies an expression's operation to the values of its parts (on top of the stack),
    /// and records where the resulting node was written if it is new.
    fn build(&mut self, e: &Expr, values: &mut Vec<NodeId>) -> NodeId {
        let node = self.build_node(e, values);
        self.origins.entry(node).or_insert(e.span());
        node
    }

    fn build_node(&mut self, e: &Expr, values: &mut Vec<NodeId>) -> NodeId {
        match e {
            Expr::Neg(..) => {
                let a = self.pop(values);
                self.graph.neg(a)
            }
            Expr::Not(..) => {
                let a = self.pop(values);
                self.graph.apply(Op::Not, &[a])
            }
            Expr::Binary(op, ..) => {
                let y = self.pop(values);
                let x = self.pop(values);
                let op = match op {
                    BinaryOp::Add => Op::Add,
                    BinaryOp::Sub => Op::Sub,
                    BinaryOp::Mul => Op::Mul,
                    BinaryOp::Div => Op::Div,
                    BinaryOp::Pow => Op::Pow,
                    BinaryOp::Lt => Op::Lt,
                    BinaryOp::Le => Op::Le,
                    BinaryOp::Gt => Op::Gt,
                    BinaryOp::Ge => Op::Ge,
                    BinaryOp::Eq => Op::Eq,
                    BinaryOp::Ne => Op::Ne,
                    BinaryOp::And => Op::And,
                    BinaryOp::Or => Op::Or,
                };
                self.graph.apply(op, &[x, y])
            }
            Expr::Call(f, args, _) => match Op::from_function(&f.text) {
                Some(op) if values.len() >= args.len() => {
                    let nodes = values.split_off(values.len() - args.len());
                    self.graph.apply(op, &nodes)
                }
                _ => self.graph.constant(f64::NAN),
            },
            Expr::Number(..) | Expr::Name(_) | Expr::Next(..) => self.graph.constant(f64::NAN),
        }
    }

    /// Whether a call of the `fn` named `f` with `arity` arguments can be inlined: the
    /// right number of arguments, and not a call of a function from its own body.
    fn user_call(&mut self, f: &Name, arity: usize, span: Span) -> bool {
        self.used.insert(format!("fn {}", f.text));
        let Some(def) = self.functions.get(f.text.as_str()) else {
            return false;
        };
        let (expected, declared) = (def.params.len(), def.name.span);
        if self
            .scopes
            .iter()
            .any(|s| s.function.as_deref() == Some(f.text.as_str()))
        {
            self.diags.push(
                Diagnostic::error("E025", f.span, format!("`{}` calls itself", f.text))
                    .label("called again inside its own body")
                    .related(declared, "declared here")
                    .help("functions are inlined where they are called, so they cannot recurse; write the repetition out"),
            );
            return false;
        }
        if arity != expected {
            let params: Vec<&str> = def.params.iter().map(|p| p.text.as_str()).collect();
            self.diags.push(
                Diagnostic::error(
                    "E011",
                    span,
                    format!(
                        "`{}` takes {expected} argument{}, not {arity}",
                        f.text,
                        if expected == 1 { "" } else { "s" },
                    ),
                )
                .label("wrong number of arguments")
                .related(declared, "declared here")
                .help(format!("write `{}({})`", f.text, params.join(", "))),
            );
            return false;
        }
        true
    }

    /// Starts lowering the body of a called `fn` with its parameters bound to the
    /// arguments' nodes (on top of the stack).
    fn inline<'e>(
        &mut self,
        e: &'e Expr,
        ctx: Context,
        tasks: &mut Vec<Task<'e>>,
        values: &mut Vec<NodeId>,
    ) where
        'd: 'e,
    {
        let Expr::Call(f, args, _) = e else { return };
        let Some(def) = self.functions.get(f.text.as_str()) else {
            return values.push(self.graph.constant(f64::NAN));
        };
        let (params, body) = (def.params, def.body);
        let nodes = values.split_off(values.len().saturating_sub(args.len()));
        self.scopes.push(Scope {
            function: Some(f.text.clone()),
            bindings: params.iter().map(|p| p.text.clone()).zip(nodes).collect(),
        });
        tasks.push(Task::EndScope);
        tasks.push(Task::Visit(body, ctx));
    }

    /// `next(n)`: the state after the step, in stage terms only.
    fn next(&mut self, n: &Name, span: Span, ctx: Context) -> NodeId {
        if ctx != Context::Stage {
            self.diags.push(
                Diagnostic::error("E013", span, "`next(...)` is only allowed in `reward` and `cost` terms")
                    .label("not allowed here")
                    .help("`next(x)` is the state after the step; dynamics and outputs use the current state"),
            );
            return self.graph.constant(f64::NAN);
        }
        match self.symbols.get(&n.text) {
            Some((Symbol::State(i), _)) => {
                let i = *i;
                self.used.insert(n.text.clone());
                self.graph.var(self.layout.x_next(i))
            }
            Some(_) => {
                self.diags.push(
                    Diagnostic::error(
                        "E013",
                        n.span,
                        format!("`next({})`: `{}` is not a state", n.text, n.text),
                    )
                    .label("not a state")
                    .help("`next` takes a state name"),
                );
                self.graph.constant(f64::NAN)
            }
            None => {
                self.unknown(n);
                self.graph.constant(f64::NAN)
            }
        }
    }

    /// The operation of a call with `arity` arguments, or `None` (reported) for an unknown
    /// function or a wrong number of arguments.
    fn function(&mut self, f: &Name, arity: usize, span: Span) -> Option<Op> {
        let Some(op) = Op::from_function(&f.text) else {
            let mut d = Diagnostic::error("E011", f.span, format!("unknown function `{}`", f.text))
                .label("not a function");
            d = match did_you_mean(&f.text, Op::FUNCTIONS.iter().copied()) {
                Some(s) => d.help(format!(
                    "did you mean `{s}`? functions: {}",
                    Op::FUNCTIONS.join(", ")
                )),
                None => d.help(format!("functions: {}", Op::FUNCTIONS.join(", "))),
            };
            self.diags.push(d);
            return None;
        };
        if arity != op.arity() {
            self.diags.push(
                Diagnostic::error(
                    "E011",
                    span,
                    format!(
                        "`{}` takes {} argument{}, not {}",
                        f.text,
                        op.arity(),
                        if op.arity() == 1 { "" } else { "s" },
                        arity
                    ),
                )
                .label("wrong number of arguments")
                .help(format!(
                    "write `{}({})`",
                    f.text,
                    ["a", "b", "c"][..op.arity()].join(", ")
                )),
            );
            return None;
        }
        Some(op)
    }

    /// The node a name stands for, or the let or output that must be lowered for it.
    fn name(&mut self, n: &Name, ctx: Context) -> Result<NodeId, Derivable> {
        if let Some(scope) = self.scopes.last() {
            if let Some((_, node)) = scope.bindings.iter().find(|(p, _)| *p == n.text) {
                return Ok(*node);
            }
        }
        let Some((symbol, _)) = self.symbols.get(&n.text).copied() else {
            self.unknown(n);
            return Ok(self.graph.constant(f64::NAN));
        };
        self.used.insert(n.text.clone());
        Ok(match (symbol, ctx) {
            (Symbol::Const(v), _) => self.graph.constant(v),
            (Symbol::Param(i), Context::Constant) => {
                let v = self.param_values.get(i).copied().unwrap_or(f64::NAN);
                self.graph.constant(v)
            }
            (Symbol::Param(i), _) => self.graph.var(self.layout.p(i)),
            (_, Context::Constant) => {
                // Only parameters and constants declared above are constant; report by caller.
                self.graph.var(0)
            }
            (Symbol::State(i), _) => self.graph.var(self.layout.x(i)),
            (Symbol::Input(i), _) => self.graph.var(self.layout.u(i)),
            (Symbol::Disturbance(i), _) => self.graph.var(self.layout.d(i)),
            (Symbol::Let(i), _) => return Err(Derivable::Let(i)),
            (Symbol::Output(i), _) => return Err(Derivable::Output(i)),
            (Symbol::Term, _) => {
                self.diags.push(
                    Diagnostic::error(
                        "E003",
                        n.span,
                        format!(
                            "`{}` is an objective term and cannot be used in an expression",
                            n.text
                        ),
                    )
                    .label("objective term")
                    .help("put the shared expression in a `let` and use that in both places"),
                );
                self.graph.constant(f64::NAN)
            }
        })
    }
}
