//! The checker: resolves the names of the collected declarations, lowers every expression
//! into one [`Graph`] and checks the model for meaning errors, giving the [`Model`].
//!
//! It keeps going after an error, so that one run reports every problem of a file, and it
//! never panics on user input. Lowering expressions is in `lower.rs`, the checks of
//! constant settings (bounds, rates, bands, `sample`, `uncertainty`) in `settings.rs`.

mod lower;
mod order;
mod settings;

use lower::Derivable;

use crate::graph::{Graph, NodeId, Op};
use crate::lang::ast::*;
use crate::lang::collect::{collect, Decls};
use crate::lang::diagnostic::CheckFailure;
use crate::lang::diagnostic::Diagnostic;
use crate::lang::model::*;
use crate::lang::source::{SourceMap, Span};
use std::collections::{HashMap, HashSet};

/// Where a name points.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Symbol {
    State(usize),
    Input(usize),
    Disturbance(usize),
    Param(usize),
    Const(f64),
    Let(usize),
    Output(usize),
    Term,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Context {
    /// Only parameters and constants, evaluated at their nominal values.
    Constant,
    /// States, inputs, disturbances, parameters, lets, outputs.
    Dynamics,
    /// As dynamics, plus `next(x)`.
    Stage,
}

/// Where a let or output is in its lowering (lets and outputs are lowered on first use).
#[derive(Debug, Clone, Copy)]
enum Derived<'d> {
    /// Not lowered yet: its expression.
    Pending(&'d Expr),
    /// Being lowered: met again, it depends on itself.
    InProgress,
    /// Lowered to this node.
    Done(NodeId),
}

/// A `fn` declaration, inlined wherever it is called.
struct FunctionDef<'d> {
    name: &'d Name,
    params: &'d [Name],
    body: &'d Expr,
}

/// The names visible while lowering: a function's parameters bound to the nodes of its
/// arguments, or no extra names (a let or output lowered inside a call sees only the
/// model's names).
struct Scope {
    /// The function whose body is being lowered (`None` for a let or output).
    function: Option<String>,
    /// Its parameters' names and nodes.
    bindings: Vec<(String, NodeId)>,
}

/// The checker's state; `'d` is the life of the collected declarations, whose lets and
/// outputs it lowers on first use.
struct Checker<'d> {
    diags: Vec<Diagnostic>,
    graph: Graph,
    symbols: HashMap<String, (Symbol, Span)>,
    lets: Vec<(String, Derived<'d>)>,
    outputs_derived: Vec<Derived<'d>>,
    used: HashSet<String>,
    layout: Layout,
    param_values: Vec<f64>,
    functions: HashMap<&'d str, FunctionDef<'d>>,
    scopes: Vec<Scope>,
    /// Where each node was first written (the model's `origins`).
    origins: HashMap<NodeId, Span>,
}

/// Checks the statements of a loaded model; `diags` are those of loading and parsing.
pub(crate) fn check(
    sources: SourceMap,
    mut diags: Vec<Diagnostic>,
    statements: Vec<Statement>,
) -> Result<Model, CheckFailure> {
    let decls = collect(statements, &mut diags);
    let mut c = Checker {
        diags,
        graph: Graph::new(),
        symbols: HashMap::new(),
        lets: Vec::new(),
        outputs_derived: Vec::new(),
        used: HashSet::new(),
        layout: Layout {
            nx: 0,
            nu: 0,
            nd: 0,
            np: 0,
        },
        param_values: Vec::new(),
        functions: HashMap::new(),
        scopes: Vec::new(),
        origins: HashMap::new(),
    };
    let model = c.run(&decls);
    let errors = c.diags.iter().any(Diagnostic::is_error);
    match model {
        Some(mut m) if !errors => {
            m.sources = sources;
            m.warnings = c.diags;
            Ok(m)
        }
        _ => Err(CheckFailure {
            sources,
            diagnostics: c.diags,
        }),
    }
}

fn info(name: &Name, doc: &Doc) -> Info {
    Info {
        name: name.text.clone(),
        unit: doc.unit.clone().unwrap_or_default(),
        description: doc.description.clone().unwrap_or_default(),
        source: doc.source.clone().unwrap_or_default(),
        span: Some(name.span),
    }
}

impl<'d> Checker<'d> {
    fn declare(&mut self, name: &Name, symbol: Symbol) {
        if name.text == "t" || Op::from_function(&name.text).is_some() {
            self.diags.push(
                Diagnostic::error(
                    "E004",
                    name.span,
                    format!("`{}` is a built-in name", name.text),
                )
                .label("reserved")
                .help("choose another name"),
            );
        }
        if let Some((_, first)) = self.symbols.get(&name.text) {
            let first = *first;
            self.diags.push(
                Diagnostic::error("E004", name.span, format!("`{}` is declared twice", name.text))
                    .label("declared again here")
                    .related(first, "first declared here")
                    .help("names are shared by parameters, states, inputs, disturbances, lets, outputs and objective terms: rename one"),
            );
            return;
        }
        self.symbols.insert(name.text.clone(), (symbol, name.span));
    }

    fn run(&mut self, d: &'d Decls) -> Option<Model> {
        let (mut states, mut inputs, mut dists) = (vec![], vec![], vec![]);
        // Pass 1: declare names, in groups so the variable layout is fixed.
        for s in &d.items {
            match &s.stmt {
                Stmt::State { name, .. } => {
                    self.declare(name, Symbol::State(states.len()));
                    states.push(s);
                }
                Stmt::Input { name, .. } => {
                    self.declare(name, Symbol::Input(inputs.len()));
                    inputs.push(s);
                }
                Stmt::Disturbance { name, .. } => {
                    self.declare(name, Symbol::Disturbance(dists.len()));
                    dists.push(s);
                }
                _ => {}
            }
        }
        self.declare_functions(d);
        let param_decls = self.params(d);
        let consts: Vec<(String, f64, Span)> = param_decls
            .iter()
            .filter(|(p, _)| p.kind == ParamKind::Constant)
            .map(|(p, s)| (p.info.name.clone(), p.value, *s))
            .collect();
        let param_decls: Vec<ParamDecl> = param_decls
            .into_iter()
            .filter(|(p, _)| p.kind != ParamKind::Constant)
            .map(|(p, _)| p)
            .collect();
        self.layout = Layout {
            nx: states.len(),
            nu: inputs.len(),
            nd: dists.len(),
            np: param_decls.len(),
        };
        for s in &d.items {
            match &s.stmt {
                Stmt::Let { name, expr, .. } => {
                    self.declare(name, Symbol::Let(self.lets.len()));
                    self.lets.push((name.text.clone(), Derived::Pending(expr)));
                }
                Stmt::Output { name, expr, .. } => {
                    self.declare(name, Symbol::Output(self.outputs_derived.len()));
                    self.outputs_derived.push(Derived::Pending(expr));
                }
                Stmt::Term { name, .. } => self.declare(name, Symbol::Term),
                _ => {}
            }
        }

        // States, inputs, disturbances.
        let states: Vec<StateDecl> = states
            .iter()
            .filter_map(|s| match &s.stmt {
                Stmt::State { name, initial, doc } => Some(StateDecl {
                    info: info(name, doc),
                    initial: self
                        .constant(initial, "an initial value")
                        .unwrap_or(f64::NAN),
                }),
                _ => None,
            })
            .collect();
        let mut inputs: Vec<InputDecl> = inputs.iter().filter_map(|s| self.input(s)).collect();
        let dists: Vec<DisturbanceDecl> = dists
            .iter()
            .filter_map(|s| match &s.stmt {
                Stmt::Disturbance {
                    name,
                    column,
                    value,
                    clock,
                    doc,
                } => Some(DisturbanceDecl {
                    info: info(name, doc),
                    column: column
                        .clone()
                        .or_else(|| clock.then(|| CLOCK_COLUMN.to_string())),
                    value: value
                        .as_ref()
                        .and_then(|v| self.constant(v, "a disturbance value")),
                    clock: *clock,
                }),
                _ => None,
            })
            .collect();

        // Dynamics.
        let mut derivative: Vec<Option<NodeId>> = vec![None; states.len()];
        let mut soft_stmts = Vec::new();
        let mut terms = Vec::new();
        for s in &d.items {
            match &s.stmt {
                Stmt::Der { state, expr } => match self.symbols.get(&state.text) {
                    Some((Symbol::State(i), _)) => {
                        let i = *i;
                        self.used.insert(state.text.clone());
                        derivative[i] = Some(self.lower(expr, Context::Dynamics));
                    }
                    Some(_) => self.diags.push(
                        Diagnostic::error("E006", state.span, format!("`der {}`: `{}` is not a state", state.text, state.text))
                            .label("not a state")
                            .help("only states have derivatives; declare it with `state` or use `let` for an algebraic quantity"),
                    ),
                    None => self.unknown(state),
                },
                Stmt::Term { kind, name, expr, doc } => {
                    let ctx = if *kind == TermKind::Terminal {
                        Context::Dynamics
                    } else {
                        Context::Stage
                    };
                    let n = self.lower(expr, ctx);
                    if *kind == TermKind::Terminal {
                        self.terminal_reads_only_the_state(name, expr, n, &inputs, &dists);
                    }
                    let node = if *kind == TermKind::Cost { self.graph.neg(n) } else { n };
                    terms.push(TermDecl {
                        info: info(name, doc),
                        kind: *kind,
                        node,
                    });
                }
                Stmt::Soft { .. } => soft_stmts.push(s),
                _ => {}
            }
        }
        for (i, s) in states.iter().enumerate() {
            if derivative[i].is_none() {
                let span = self
                    .symbols
                    .get(&s.info.name)
                    .map(|x| x.1)
                    .unwrap_or_default();
                self.diags.push(
                    Diagnostic::error(
                        "E005",
                        span,
                        format!("state `{}` has no `der` equation", s.info.name),
                    )
                    .label("declared here")
                    .help(format!(
                        "add `der {} = <expression>` giving its rate of change",
                        s.info.name
                    )),
                );
            }
        }
        // Outputs (lowered in order; lets are lowered on first use).
        let mut outputs = Vec::new();
        for s in &d.items {
            if let Stmt::Output { name, doc, .. } = &s.stmt {
                if let Some((Symbol::Output(i), _)) = self.symbols.get(&name.text).copied() {
                    let node = self.derived(Derivable::Output(i), name.span);
                    outputs.push(OutputDecl {
                        info: info(name, doc),
                        node,
                    });
                }
            }
        }
        let soft: Vec<SoftBand> = soft_stmts.iter().filter_map(|s| self.soft(s)).collect();
        self.rules(d, &mut inputs);
        // Lets never used still get lowered, so their errors are reported.
        for i in 0..self.lets.len() {
            if let Derived::Pending(_) = self.lets[i].1 {
                let name = self.lets[i].0.clone();
                let span = self.symbols.get(&name).map(|x| x.1).unwrap_or_default();
                self.derived(Derivable::Let(i), span);
            }
        }
        self.check_unused_functions();
        self.check_clocks(&dists);
        let sample = self.sample(d.sample.as_ref());
        let uncertainty = self.uncertainty(d.uncertainty.as_ref());
        let solver = self.solver_hints(&d.solver);
        self.warn_unused(&param_decls, &consts, &dists, &inputs);

        let (name, description) = match &d.model {
            Some((n, desc)) => (n.text.clone(), desc.clone().unwrap_or_default()),
            None => ("model".to_string(), String::new()),
        };
        let missing = self.graph.constant(f64::NAN);
        Some(Model {
            name,
            description,
            sources: SourceMap::default(),
            graph: std::mem::take(&mut self.graph),
            states,
            inputs,
            disturbances: dists,
            params: param_decls,
            derivatives: derivative
                .into_iter()
                .map(|d| d.unwrap_or(missing))
                .collect(),
            outputs,
            sample_period: sample.period,
            integrator: sample.integrator,
            substeps: sample.substeps,
            plan_substeps: sample.plan_substeps,
            terms,
            soft,
            uncertainty,
            solver,
            warnings: Vec::new(),
            origins: std::mem::take(&mut self.origins),
        })
    }

    /// Records the `fn` declarations (lowered where they are called).
    fn declare_functions(&mut self, d: &'d Decls) {
        for s in &d.items {
            let Stmt::Function {
                name, params, body, ..
            } = &s.stmt
            else {
                continue;
            };
            if Op::from_function(&name.text).is_some() || name.text == "next" {
                self.diags.push(
                    Diagnostic::error(
                        "E004",
                        name.span,
                        format!("`{}` is a built-in function", name.text),
                    )
                    .label("reserved")
                    .help("choose another name for the function"),
                );
                continue;
            }
            for (i, p) in params.iter().enumerate() {
                if let Some(first) = params[..i].iter().find(|q| q.text == p.text) {
                    self.diags.push(
                        Diagnostic::error(
                            "E025",
                            p.span,
                            format!("parameter `{}` of `{}` is named twice", p.text, name.text),
                        )
                        .label("named again here")
                        .related(first.span, "first named here")
                        .help("give each parameter of a function its own name"),
                    );
                }
            }
            self.functions
                .insert(name.text.as_str(), FunctionDef { name, params, body });
        }
    }

    /// Parameters and constants, evaluated in dependency order and declared; the
    /// parameters keep their declaration order in the layout. Returns every `param` and
    /// `const` declaration in declaration order, with the statement's span.
    fn params(&mut self, d: &'d Decls) -> Vec<(ParamDecl, Span)> {
        let stmts: Vec<&'d Statement> = d
            .items
            .iter()
            .filter(|s| matches!(s.stmt, Stmt::Param { .. }))
            .collect();
        let named: Vec<(&'d Name, &'d Expr)> = stmts
            .iter()
            .filter_map(|s| match &s.stmt {
                Stmt::Param { name, value, .. } => Some((name, value)),
                _ => None,
            })
            .collect();
        // The layout index of each `param`, in declaration order.
        let mut index = Vec::with_capacity(stmts.len());
        for s in &stmts {
            let plain = matches!(&s.stmt, Stmt::Param { kind, .. } if *kind != ParamKind::Constant);
            index.push(plain.then(|| {
                self.param_values.push(f64::NAN);
                self.param_values.len() - 1
            }));
        }
        let (order, cyclic) = self.evaluation_order(&named);
        let mut values = vec![f64::NAN; stmts.len()];
        // Members of a cycle are declared without a value, so that their uses do not
        // report them as unknown too.
        let mut in_cycle = vec![false; stmts.len()];
        for &k in &cyclic {
            in_cycle[k] = true;
        }
        let cyclic = (0..stmts.len()).filter(|&k| in_cycle[k]);
        for k in cyclic.chain(order) {
            let Stmt::Param { name, value, .. } = &stmts[k].stmt else {
                continue;
            };
            if in_cycle[k] {
                // Named in the cycle's error: not reported again as unused.
                self.used.insert(name.text.clone());
            }
            let v = if !in_cycle[k] {
                self.constant(value, "a parameter value")
                    .unwrap_or(f64::NAN)
            } else {
                f64::NAN
            };
            values[k] = v;
            match index[k] {
                Some(i) => {
                    self.param_values[i] = v;
                    self.declare(name, Symbol::Param(i));
                }
                None => self.declare(name, Symbol::Const(v)),
            }
        }
        stmts
            .iter()
            .zip(values)
            .filter_map(|(s, value)| match &s.stmt {
                Stmt::Param {
                    name, kind, doc, ..
                } => Some((
                    ParamDecl {
                        info: info(name, doc),
                        value,
                        kind: *kind,
                    },
                    s.span,
                )),
                _ => None,
            })
            .collect()
    }

    /// Lowers the functions never called, so that their errors are reported, and warns.
    fn check_unused_functions(&mut self) {
        let mut unused: Vec<(&'d Name, &'d [Name], &'d Expr)> = self
            .functions
            .values()
            .filter(|f| !self.used.contains(&format!("fn {}", f.name.text)))
            .map(|f| (f.name, f.params, f.body))
            .collect();
        unused.sort_by_key(|(n, ..)| n.span.start);
        for (name, params, body) in unused {
            let nan = self.graph.constant(f64::NAN);
            self.scopes.push(Scope {
                function: Some(name.text.clone()),
                bindings: params.iter().map(|p| (p.text.clone(), nan)).collect(),
            });
            self.lower(body, Context::Stage);
            self.scopes.pop();
            self.diags.push(
                Diagnostic::warning(
                    "W001",
                    name.span,
                    format!("function `{}` is never called", name.text),
                )
                .label("unused")
                .help("remove it, or call it in an equation"),
            );
        }
    }

    /// At most one `clock`.
    fn check_clocks(&mut self, dists: &[DisturbanceDecl]) {
        let clocks: Vec<&DisturbanceDecl> = dists.iter().filter(|d| d.clock).collect();
        if let [first, second, ..] = clocks[..] {
            if let (Some(at), Some(before)) = (second.info.span, first.info.span) {
                self.diags.push(
                    Diagnostic::error(
                        "E027",
                        at,
                        format!("`{}` is a second clock", second.info.name),
                    )
                    .label("second `clock`")
                    .related(
                        before,
                        format!("`{}` is the model's clock", first.info.name),
                    )
                    .help("a model has one clock; derive other times from it with `let`"),
                );
            }
        }
    }
    fn warn_unused(
        &mut self,
        params: &[ParamDecl],
        consts: &[(String, f64, Span)],
        dists: &[DisturbanceDecl],
        inputs: &[InputDecl],
    ) {
        let mut names: Vec<(&str, &str)> = Vec::new();
        names.extend(params.iter().map(|p| ("parameter", p.info.name.as_str())));
        names.extend(consts.iter().map(|c| ("constant", c.0.as_str())));
        names.extend(dists.iter().map(|d| ("disturbance", d.info.name.as_str())));
        names.extend(inputs.iter().map(|d| ("input", d.info.name.as_str())));
        let lets: Vec<String> = self.lets.iter().map(|l| l.0.clone()).collect();
        names.extend(lets.iter().map(|l| ("let", l.as_str())));
        let mut warnings = Vec::new();
        for (kind, n) in names {
            if !self.used.contains(n) {
                if let Some((_, span)) = self.symbols.get(n) {
                    warnings.push(
                        Diagnostic::warning("W001", *span, format!("{kind} `{n}` is never used"))
                            .label("unused")
                            .help("remove it, or use it in an equation"),
                    );
                }
            }
        }
        self.diags.extend(warnings);
    }
}
