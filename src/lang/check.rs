//! The checker: loads a `.ghm` file and its imports, applies overrides, resolves names,
//! lowers every expression into one [`Graph`] and checks the model for meaning errors.
//!
//! It keeps going after an error, so that one run reports every problem of a file, and it
//! never panics on user input.

use crate::graph::{Graph, NodeId, Op};
use crate::lang::ast::*;
use crate::lang::diagnostic::{did_you_mean, Diagnostic};
use crate::lang::model::*;
use crate::lang::parse::parse;
use crate::lang::source::{SourceFile, SourceMap, Span};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Why a model could not be loaded: the diagnostics (errors and warnings) and the sources
/// they point into.
///
/// # Examples
///
/// A misspelt name is an error with a code, a `file:line:column`, the source line with a
/// caret under the name, and a hint:
///
/// ```
/// use ghm::lang::diagnostic::Severity;
///
/// let text = "\
/// sample 30 [min]
/// state temp_air [°C] = 15
/// input heating [W m^-2] in [0, 150]
/// der temp_air = (heatng - 6.1 * temp_air) / 3e4
/// ";
/// let failure = ghm::lang::load_str("bad.ghm", text).unwrap_err();
/// assert_eq!(failure.error_count(), 1);
/// let error = &failure.diagnostics[0];
/// assert_eq!((error.severity, error.code), (Severity::Error, "E003"));
/// assert_eq!(failure.sources.location(error.span), "bad.ghm:4:17");
///
/// let message = failure.render();
/// assert!(message.starts_with("error[E003]: unknown name `heatng`"));
/// assert!(message.contains("┌─ bad.ghm:4:17"));
/// assert!(message.contains("help: did you mean `heating`?"));
/// // The unused input is reported too, as a warning.
/// assert!(message.contains("warning[W001]: input `heating` is never used"));
/// // As an error (`?` into `Box<dyn Error>`), it shows the same text, Debug included.
/// assert_eq!(failure.to_string(), message.trim_end());
/// assert_eq!(format!("{failure:?}"), failure.to_string());
/// ```
#[derive(Clone)]
pub struct CheckFailure {
    /// The files read (the main file and its imports), which the spans point into.
    pub sources: SourceMap,
    /// Every error and warning found: those of parsing and imports first, then those of
    /// checking.
    pub diagnostics: Vec<Diagnostic>,
}

/// Displays as [`CheckFailure::render`], so that `?` carries the full message into any
/// `Box<dyn Error>`.
impl std::fmt::Display for CheckFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.render().trim_end())
    }
}

/// Debug shows the rendered diagnostics too: `main` returning `Result<(), Box<dyn Error>>`
/// prints an error with `{:?}`, and a user should see `file:line:column`, not the fields.
impl std::fmt::Debug for CheckFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

impl std::error::Error for CheckFailure {}

impl CheckFailure {
    /// The diagnostics rendered as text with `file:line:col`, source lines and carets.
    pub fn render(&self) -> String {
        crate::lang::diagnostic::render(&self.sources, &self.diagnostics)
    }

    /// The number of errors (warnings are not counted).
    pub fn error_count(&self) -> usize {
        self.diagnostics.iter().filter(|d| d.is_error()).count()
    }
}

/// Loads and checks the model in `path` (with its imports).
///
/// A model with errors gives a [`CheckFailure`]; [`CheckFailure::render`] turns it into the
/// message a user should see. A file that cannot be read is a failure with code `E009`.
///
/// # Examples
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
/// let model = ghm::lang::load(&dir.join("cstr.ghm")).map_err(|e| e.render())?;
/// assert_eq!(model.name, "cstr");
/// let states: Vec<&str> = model.states.iter().map(|s| s.info.name.as_str()).collect();
/// assert_eq!(states, ["ca", "temp"]);
/// assert_eq!(model.sample_period, 6.0); // `sample step_s [s]` with `step_s = 6`
/// assert_eq!(model.substeps, 20);
/// assert_eq!(model.inputs[0].rate, Some(3.0));
///
/// let missing = ghm::lang::load(&dir.join("no-such-model.ghm")).unwrap_err();
/// assert_eq!(missing.diagnostics[0].code, "E009");
/// assert!(missing.render().contains("cannot read model file"));
/// # Ok(())
/// # }
/// ```
pub fn load(path: &Path) -> Result<Model, CheckFailure> {
    let mut loader = Loader::default();
    let statements = match std::fs::read_to_string(path) {
        Ok(text) => loader.file(path, text, None),
        Err(e) => {
            return Err(CheckFailure {
                sources: SourceMap::default(),
                diagnostics: vec![Diagnostic::error(
                    "E009",
                    Span::default(),
                    format!("cannot read model file `{}`: {e}", path.display()),
                )
                .help("check the path; model files end in .ghm")],
            })
        }
    };
    check(loader, statements)
}

/// Checks a model given as text (`name` is used in messages; imports are resolved relative
/// to the current directory).
///
/// # Examples
///
/// A heated tank (the first model of `docs/language.md`, without weather):
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let text = r#"
/// model tank "a heated tank, 10-minute control"
/// sample 10 [min] integrator rk4 substeps 2
/// state temp [°C] = 15 "water temperature"
/// input heat [kW] in [0, 5] rate 0.5 start 0 "heater power"
/// param loss [kW °C^-1] = 0.1 uncertain "heat loss coefficient"
/// const cap [kJ °C^-1] = 4186
/// der temp = (heat - loss * (temp - 10)) / cap
/// output t_water [°C] = temp
/// cost heating [EUR] = 0.13 * heat * 600 / 3600
/// "#;
/// let model = ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?;
/// assert_eq!(model.name, "tank");
/// assert_eq!(model.sample_period, 600.0); // seconds
/// let heat = &model.inputs[0];
/// assert_eq!((heat.lower, heat.upper, heat.rate, heat.start), (0.0, 5.0, Some(0.5), 0.0));
/// assert_eq!(model.nominal_params(), [0.1]); // `const cap` is folded in, not a parameter
/// assert_eq!(model.output_index("t_water"), Some(0));
/// assert!(model.warnings.is_empty());
/// # Ok(())
/// # }
/// ```
pub fn load_str(name: &str, text: &str) -> Result<Model, CheckFailure> {
    let mut loader = Loader::default();
    let statements = loader.file(Path::new(name), text.to_string(), None);
    check(loader, statements)
}

#[derive(Default)]
struct Loader {
    sources: SourceMap,
    diagnostics: Vec<Diagnostic>,
    stack: Vec<PathBuf>,
}

impl Loader {
    /// Parses one file and, in place of each `import`, the statements of the imported file.
    fn file(&mut self, path: &Path, text: String, _from: Option<Span>) -> Vec<Statement> {
        let id = self.sources.add(SourceFile::new(path, text));
        let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        self.stack.push(canonical);
        let (parsed, diags) = parse(id, &self.sources.files[id].text);
        self.diagnostics.extend(diags);
        let mut out = Vec::new();
        for s in parsed {
            if let Stmt::Import { path: rel, span } = &s.stmt {
                let target = path.parent().unwrap_or(Path::new("")).join(rel);
                let canonical = target.canonicalize().unwrap_or_else(|_| target.clone());
                if self.stack.contains(&canonical) {
                    self.diagnostics.push(
                        Diagnostic::error("E020", *span, format!("import cycle: `{rel}` imports itself, directly or through other files"))
                            .label("imported again here")
                            .help("remove one of the imports in the cycle"),
                    );
                    continue;
                }
                match std::fs::read_to_string(&target) {
                    Ok(text) => out.extend(self.file(&target, text, Some(*span))),
                    Err(e) => self.diagnostics.push(
                        Diagnostic::error("E009", *span, format!("cannot import `{rel}`: {e}"))
                            .label(format!("looked for {}", target.display()))
                            .help("import paths are relative to the file that imports them"),
                    ),
                }
            } else {
                out.push(s);
            }
        }
        self.stack.pop();
        out
    }
}

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

#[derive(Debug, Clone)]
enum Derived {
    Pending(Expr),
    InProgress,
    Done(NodeId),
}

struct Checker {
    diags: Vec<Diagnostic>,
    graph: Graph,
    symbols: HashMap<String, (Symbol, Span)>,
    lets: Vec<(String, Derived)>,
    outputs_derived: Vec<Derived>,
    used: HashSet<String>,
    layout: Layout,
    param_values: Vec<f64>,
}

/// Declarations after overrides and drops, in declaration order.
#[derive(Default)]
struct Decls {
    model: Option<(Name, Option<String>)>,
    items: Vec<Statement>,
    sample: Option<Statement>,
    uncertainty: Option<Statement>,
}

fn key(stmt: &Stmt) -> Option<(String, String)> {
    match stmt {
        Stmt::Der { state, .. } => Some(("der".into(), state.text.clone())),
        Stmt::Soft { output, .. } => Some(("soft".into(), output.text.clone())),
        Stmt::Term { name, .. } => Some(("term".into(), name.text.clone())),
        other => other
            .declared()
            .map(|(_, n)| ("name".into(), n.text.clone())),
    }
}

fn key_span(stmt: &Statement) -> Span {
    match &stmt.stmt {
        Stmt::Der { state, .. } => state.span,
        Stmt::Soft { output, .. } => output.span,
        other => other.declared().map_or(stmt.span, |(_, n)| n.span),
    }
}

fn collect(statements: Vec<Statement>, diags: &mut Vec<Diagnostic>) -> Decls {
    let mut d = Decls::default();
    let mut index: HashMap<(String, String), usize> = HashMap::new();
    for s in statements {
        match &s.stmt {
            Stmt::Model { name, description } => {
                d.model = Some((name.clone(), description.clone()))
            }
            Stmt::Sample { .. } => {
                if d.sample.is_some() && !s.overrides {
                    diags.push(
                        Diagnostic::error("E004", s.span, "the sample period is declared twice")
                            .label("second `sample`")
                            .help("write `override sample ...` to replace an imported one"),
                    );
                }
                d.sample = Some(s);
            }
            Stmt::Uncertainty { .. } => d.uncertainty = Some(s),
            Stmt::Drop { kind, name } => {
                let k = if kind == "soft" { "soft" } else { "term" };
                let key = (k.to_string(), name.text.clone());
                // `drop cost c` must not remove a `reward c`: the terms share one key.
                let declared_kind = index.get(&key).and_then(|&i| match &d.items[i].stmt {
                    Stmt::Term { kind, .. } => Some(kind.keyword()),
                    _ => None,
                });
                if let Some(declared) = declared_kind.filter(|declared| declared != kind) {
                    diags.push(
                        Diagnostic::error(
                            "E014",
                            name.span,
                            format!(
                                "there is no {kind} `{}` to drop; it is a {declared}",
                                name.text
                            ),
                        )
                        .label("declared with another kind")
                        .help(format!("write `drop {declared} {}`", name.text)),
                    );
                    continue;
                }
                match index.remove(&key) {
                    Some(i) => {
                        d.items[i].stmt = Stmt::Drop {
                            kind: kind.clone(),
                            name: name.clone(),
                        }
                    }
                    None => diags.push(
                        Diagnostic::error(
                            "E014",
                            name.span,
                            format!("there is no {kind} `{}` to drop", name.text),
                        )
                        .label("not declared before this line")
                        .help("`drop` removes a declaration made earlier or in an imported file"),
                    ),
                }
            }
            _ => {
                let Some(k) = key(&s.stmt) else { continue };
                match (index.get(&k), s.overrides) {
                    (Some(&i), true) => d.items[i] = s,
                    (Some(&i), false) => {
                        let what = if k.0 == "der" { "the derivative of" } else { "" };
                        diags.push(
                            Diagnostic::error("E004", key_span(&s), format!("{what} `{}` is declared twice", k.1).trim().to_string())
                                .label("declared again here")
                                .related(key_span(&d.items[i]), "first declared here")
                                .help("rename one of them, or write `override` to replace the first on purpose"),
                        );
                    }
                    (None, true) => diags.push(
                        Diagnostic::error("E014", key_span(&s), format!("`override` of `{}`, which is not declared before", k.1))
                            .label("nothing to override")
                            .help("drop `override` to declare it, or check the name against the imported file"),
                    ),
                    (None, false) => {
                        index.insert(k, d.items.len());
                        d.items.push(s);
                    }
                }
            }
        }
    }
    d
}

fn check(loader: Loader, statements: Vec<Statement>) -> Result<Model, CheckFailure> {
    let Loader {
        sources,
        diagnostics: mut diags,
        ..
    } = loader;
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
    }
}

impl Checker {
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

    fn run(&mut self, d: &Decls) -> Option<Model> {
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
        let mut param_decls = Vec::new();
        // Parameters: values are constant expressions over earlier parameters.
        for s in &d.items {
            if let Stmt::Param {
                name,
                kind,
                value,
                doc,
            } = &s.stmt
            {
                let v = self
                    .constant(value, "a parameter value")
                    .unwrap_or(f64::NAN);
                if *kind == ParamKind::Constant {
                    self.declare(name, Symbol::Const(v));
                } else {
                    self.declare(name, Symbol::Param(self.param_values.len()));
                    self.param_values.push(v);
                }
                param_decls.push((
                    ParamDecl {
                        info: info(name, doc),
                        value: v,
                        kind: *kind,
                    },
                    s.span,
                ));
            }
        }
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
                    self.lets
                        .push((name.text.clone(), Derived::Pending(expr.clone())));
                }
                Stmt::Output { name, expr, .. } => {
                    self.declare(name, Symbol::Output(self.outputs_derived.len()));
                    self.outputs_derived.push(Derived::Pending(expr.clone()));
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
        let inputs: Vec<InputDecl> = inputs.iter().filter_map(|s| self.input(s)).collect();
        let dists: Vec<DisturbanceDecl> = dists
            .iter()
            .filter_map(|s| match &s.stmt {
                Stmt::Disturbance {
                    name,
                    column,
                    value,
                    doc,
                } => Some(DisturbanceDecl {
                    info: info(name, doc),
                    column: column.clone(),
                    value: value
                        .as_ref()
                        .and_then(|v| self.constant(v, "a disturbance value")),
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
                    let node = self.derived_output(i, name.span);
                    outputs.push(OutputDecl {
                        info: info(name, doc),
                        node,
                    });
                }
            }
        }
        let soft: Vec<SoftBand> = soft_stmts.iter().filter_map(|s| self.soft(s)).collect();
        // Lets never used still get lowered, so their errors are reported.
        for i in 0..self.lets.len() {
            if let Derived::Pending(_) = self.lets[i].1 {
                let name = self.lets[i].0.clone();
                let span = self.symbols.get(&name).map(|x| x.1).unwrap_or_default();
                self.derived_let(i, span);
            }
        }
        let (sample_period, integrator, substeps) = self.sample(d.sample.as_ref());
        let uncertainty = self.uncertainty(d.uncertainty.as_ref());
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
            sample_period,
            integrator,
            substeps,
            terms,
            soft,
            uncertainty,
            warnings: Vec::new(),
        })
    }

    fn input(&mut self, s: &Statement) -> Option<InputDecl> {
        let Stmt::Input {
            name,
            bounds,
            rate,
            start,
            doc,
        } = &s.stmt
        else {
            return None;
        };
        let (lower, upper) = match bounds {
            Some((lo, hi)) => {
                let l = self.constant(lo, "a bound").unwrap_or(f64::NAN);
                let h = self.constant(hi, "a bound").unwrap_or(f64::NAN);
                if l > h {
                    self.diags.push(
                        Diagnostic::error(
                            "E008",
                            lo.span().to(hi.span()),
                            format!(
                                "input `{}` has bounds with lower {l} > upper {h}",
                                name.text
                            ),
                        )
                        .label("empty interval")
                        .help("write the bounds as `in [lower, upper]`"),
                    );
                }
                (l, h)
            }
            None => (f64::NEG_INFINITY, f64::INFINITY),
        };
        let rate_v = match rate {
            Some(r) => {
                let v = self.constant(r, "a rate limit").unwrap_or(f64::NAN);
                if v < 0.0 {
                    self.diags.push(
                        Diagnostic::error("E007", r.span(), format!("rate limit of `{}` is negative ({v})", name.text))
                            .label("must be ≥ 0")
                            .help("the rate limit is the largest |u(k) − u(k−1)|; give a non-negative number"),
                    );
                }
                Some(v)
            }
            None => None,
        };
        let start_v = match start {
            Some(e) => {
                let v = self.constant(e, "a start value").unwrap_or(f64::NAN);
                if v < lower || v > upper {
                    self.diags.push(
                        Diagnostic::error("E021", e.span(), format!("start value {v} of `{}` lies outside its bounds [{lower}, {upper}]", name.text))
                            .label("outside the bounds")
                            .help("the start value is the input applied before the first step; put it within the bounds"),
                    );
                }
                v
            }
            None => lower.max(0.0).min(upper),
        };
        Some(InputDecl {
            info: info(name, doc),
            lower,
            upper,
            rate: rate_v,
            start: if start_v.is_finite() { start_v } else { 0.0 },
        })
    }

    fn soft(&mut self, s: &Statement) -> Option<SoftBand> {
        let Stmt::Soft {
            output,
            band,
            weight_lo,
            weight_hi,
            plan,
            description,
        } = &s.stmt
        else {
            return None;
        };
        let index = match self.symbols.get(&output.text) {
            Some((Symbol::Output(i), _)) => *i,
            Some(_) => {
                self.diags.push(
                    Diagnostic::error(
                        "E018",
                        output.span,
                        format!(
                            "soft bands apply to outputs; `{}` is not an output",
                            output.text
                        ),
                    )
                    .label("not an output")
                    .help(format!(
                        "declare `output {0} = ...` (an output may simply equal a state)",
                        output.text
                    )),
                );
                return None;
            }
            None => {
                self.unknown(output);
                return None;
            }
        };
        self.used.insert(output.text.clone());
        let (lo, hi) = self.band(band);
        if lo > hi {
            self.diags.push(
                Diagnostic::error(
                    "E008",
                    band.span,
                    format!("soft band on `{}` has lower {lo} > upper {hi}", output.text),
                )
                .label("empty band")
                .help("write the band as `in [lower, upper]`"),
            );
        }
        let wl = self.constant(weight_lo, "a weight").unwrap_or(f64::NAN);
        let wh = match weight_hi {
            Some(w) => self.constant(w, "a weight").unwrap_or(f64::NAN),
            None => wl,
        };
        // One weight for both sides is checked once.
        let weights = match weight_hi {
            Some(w_hi) => vec![(wl, weight_lo), (wh, w_hi)],
            None => vec![(wl, weight_lo)],
        };
        for (w, e) in weights {
            if w < 0.0 {
                self.diags.push(
                    Diagnostic::error("E007", e.span(), format!("penalty weight {w} is negative"))
                        .label("must be ≥ 0")
                        .help(
                            "a soft band penalises leaving it; its weights are non-negative prices",
                        ),
                );
            }
        }
        let (plo, phi) = match plan {
            Some(p) => {
                let (a, b) = self.band(p);
                let (plo, phi) = (a.max(lo), b.min(hi));
                if plo > phi {
                    self.diags.push(
                        Diagnostic::error(
                            "E008",
                            p.lo.as_ref().or(p.hi.as_ref()).map_or(p.span, |e| e.span()),
                            format!(
                                "planning band on `{}` is empty inside [{lo}, {hi}]",
                                output.text
                            ),
                        )
                        .label("empty planning band")
                        .help("a planning band is a tighter band inside the soft band"),
                    );
                }
                (plo, phi)
            }
            None => (lo, hi),
        };
        Some(SoftBand {
            output: index,
            lower: lo,
            upper: hi,
            weight_below: wl,
            weight_above: wh,
            plan_lower: plo,
            plan_upper: phi,
            description: description.clone().unwrap_or_default(),
        })
    }

    fn band(&mut self, b: &Band) -> (f64, f64) {
        let lo = b.lo.as_ref().map_or(f64::NEG_INFINITY, |e| {
            self.constant(e, "a band limit").unwrap_or(f64::NAN)
        });
        let hi = b.hi.as_ref().map_or(f64::INFINITY, |e| {
            self.constant(e, "a band limit").unwrap_or(f64::NAN)
        });
        (lo, hi)
    }

    fn sample(&mut self, s: Option<&Statement>) -> (f64, Integrator, usize) {
        let Some(Statement {
            stmt:
                Stmt::Sample {
                    period,
                    unit,
                    integrator,
                    substeps,
                    span,
                },
            ..
        }) = s
        else {
            self.diags.push(
                Diagnostic::error("E012", Span::default(), "the model has no `sample` statement")
                    .label("")
                    .help("add e.g. `sample 1800 [s] integrator rk4 substeps 4` to set the control period"),
            );
            return (f64::NAN, Integrator::Rk4, 1);
        };
        let mut p = self
            .constant(period, "the sample period")
            .unwrap_or(f64::NAN);
        let factor = match unit.as_deref().map(str::trim) {
            None | Some("s") => 1.0,
            Some("min") => 60.0,
            Some("h") => 3600.0,
            Some(other) => {
                self.diags.push(
                    Diagnostic::error("E017", *span, format!("unknown time unit `[{other}]`"))
                        .label("here")
                        .help("use [s], [min] or [h]"),
                );
                1.0
            }
        };
        p *= factor;
        if p.is_nan() || p <= 0.0 {
            self.diags.push(
                Diagnostic::error("E017", period.span(), "the sample period must be positive")
                    .label("here")
                    .help("give the control period in seconds, e.g. `sample 1800 [s]`"),
            );
        }
        let integ = match integrator.as_ref().map(|n| (n.text.as_str(), n.span)) {
            None | Some(("rk4", _)) => Integrator::Rk4,
            Some(("euler", _)) => Integrator::Euler,
            Some((other, sp)) => {
                self.diags.push(
                    Diagnostic::error("E017", sp, format!("unknown integrator `{other}`"))
                        .label("unknown")
                        .help("use `rk4` or `euler`"),
                );
                Integrator::Rk4
            }
        };
        let n = match substeps {
            Some(e) => {
                let v = self
                    .constant(e, "the number of sub-steps")
                    .unwrap_or(f64::NAN);
                if !(v >= 1.0 && v.fract() == 0.0 && v <= 1000.0) {
                    self.diags.push(
                        Diagnostic::error(
                            "E017",
                            e.span(),
                            format!("sub-steps must be a whole number from 1 to 1000, not {v}"),
                        )
                        .label("here")
                        .help("e.g. `substeps 4`"),
                    );
                    1
                } else {
                    v as usize
                }
            }
            None => 1,
        };
        (p, integ, n)
    }

    fn uncertainty(&mut self, s: Option<&Statement>) -> Uncertainty {
        let mut u = Uncertainty::default();
        let Some(Statement {
            stmt: Stmt::Uncertainty { settings, .. },
            ..
        }) = s
        else {
            return u;
        };
        for (k, v) in settings {
            let ok = match (k.text.as_str(), v.text.as_str()) {
                ("redraw", "season") => {
                    u.redraw = Redraw::Season;
                    true
                }
                ("redraw", "step") => {
                    u.redraw = Redraw::Step;
                    true
                }
                ("params", "all") => {
                    u.all_params = true;
                    true
                }
                ("params", "marked") => {
                    u.all_params = false;
                    true
                }
                ("spread", num) => match num.parse::<f64>() {
                    Ok(x) if x > 0.0 && x.is_finite() => {
                        u.spread = x;
                        true
                    }
                    _ => false,
                },
                _ => false,
            };
            if !ok {
                self.diags.push(
                    Diagnostic::error("E016", k.span.to(v.span), format!("unknown uncertainty setting `{} = {}`", k.text, v.text))
                        .label("not understood")
                        .help("settings are `redraw = season|step`, `spread = <positive number>`, `params = marked|all`"),
                );
            }
        }
        u
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

    fn unknown(&mut self, name: &Name) {
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
    fn constant(&mut self, e: &Expr, what: &str) -> Option<f64> {
        let errors_before = self.diags.iter().filter(|d| d.is_error()).count();
        let n = self.lower(e, Context::Constant);
        let new_errors = self.diags.iter().filter(|d| d.is_error()).count() > errors_before;
        match self.graph.as_constant(n) {
            Some(v) if !v.is_finite() && !new_errors => {
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

    fn derived_let(&mut self, i: usize, at: Span) -> NodeId {
        match std::mem::replace(&mut self.lets[i].1, Derived::InProgress) {
            Derived::Done(n) => {
                self.lets[i].1 = Derived::Done(n);
                n
            }
            Derived::InProgress => {
                let name = self.lets[i].0.clone();
                self.diags.push(
                    Diagnostic::error("E010", at, format!("`{name}` depends on itself"))
                        .label("cycle through this use")
                        .help("a `let` may not refer back to itself through other lets or outputs; break the cycle"),
                );
                let nan = self.graph.constant(f64::NAN);
                // Leave it marked so the cycle is reported once.
                self.lets[i].1 = Derived::Done(nan);
                nan
            }
            Derived::Pending(expr) => {
                let n = self.lower(&expr, Context::Dynamics);
                self.lets[i].1 = Derived::Done(n);
                n
            }
        }
    }

    fn derived_output(&mut self, i: usize, at: Span) -> NodeId {
        match std::mem::replace(&mut self.outputs_derived[i], Derived::InProgress) {
            Derived::Done(n) => {
                self.outputs_derived[i] = Derived::Done(n);
                n
            }
            Derived::InProgress => {
                self.diags.push(
                    Diagnostic::error("E010", at, "this output depends on itself")
                        .label("cycle through this use")
                        .help("break the cycle between outputs and lets"),
                );
                let nan = self.graph.constant(f64::NAN);
                self.outputs_derived[i] = Derived::Done(nan);
                nan
            }
            Derived::Pending(expr) => {
                let n = self.lower(&expr, Context::Dynamics);
                self.outputs_derived[i] = Derived::Done(n);
                n
            }
        }
    }

    fn lower(&mut self, e: &Expr, ctx: Context) -> NodeId {
        match e {
            Expr::Number(v, _) => self.graph.constant(*v),
            Expr::Name(n) => self.name(n, ctx),
            Expr::Next(n, span) => {
                if ctx != Context::Stage {
                    self.diags.push(
                        Diagnostic::error("E013", *span, "`next(...)` is only allowed in `reward` and `cost` terms")
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
            Expr::Neg(a, _) => {
                let a = self.lower(a, ctx);
                self.graph.neg(a)
            }
            Expr::Binary(op, a, b, _) => {
                let x = self.lower(a, ctx);
                let y = self.lower(b, ctx);
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
                };
                self.graph.apply(op, &[x, y])
            }
            Expr::Call(f, args, span) => {
                let Some(op) = Op::from_function(&f.text) else {
                    let mut d =
                        Diagnostic::error("E011", f.span, format!("unknown function `{}`", f.text))
                            .label("not a function");
                    d = match did_you_mean(&f.text, Op::FUNCTIONS.iter().copied()) {
                        Some(s) => d.help(format!(
                            "did you mean `{s}`? functions: {}",
                            Op::FUNCTIONS.join(", ")
                        )),
                        None => d.help(format!("functions: {}", Op::FUNCTIONS.join(", "))),
                    };
                    self.diags.push(d);
                    return self.graph.constant(f64::NAN);
                };
                if args.len() != op.arity() {
                    self.diags.push(
                        Diagnostic::error(
                            "E011",
                            *span,
                            format!(
                                "`{}` takes {} argument{}, not {}",
                                f.text,
                                op.arity(),
                                if op.arity() == 1 { "" } else { "s" },
                                args.len()
                            ),
                        )
                        .label("wrong number of arguments")
                        .help(format!(
                            "write `{}({})`",
                            f.text,
                            ["a", "b", "c"][..op.arity()].join(", ")
                        )),
                    );
                    return self.graph.constant(f64::NAN);
                }
                let nodes: Vec<NodeId> = args.iter().map(|a| self.lower(a, ctx)).collect();
                self.graph.apply(op, &nodes)
            }
        }
    }

    fn name(&mut self, n: &Name, ctx: Context) -> NodeId {
        let Some((symbol, _)) = self.symbols.get(&n.text).copied() else {
            self.unknown(n);
            return self.graph.constant(f64::NAN);
        };
        self.used.insert(n.text.clone());
        match (symbol, ctx) {
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
            (Symbol::Let(i), _) => self.derived_let(i, n.span),
            (Symbol::Output(i), _) => self.derived_output(i, n.span),
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
        }
    }
}
