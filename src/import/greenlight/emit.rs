//! Writing a resolved GreenLight model as `.ghm` text.
//!
//! How each GreenLight kind becomes a statement:
//!
//! | GreenLight | `.ghm` |
//! |---|---|
//! | `state` | `state x [unit] = init "description"` and `der x = definition` |
//! | `const` | `const` with its expression and `source "reference"`, or `let` when it reads (also through other constants) an input, a weather column or anything else that is not constant (Katzin 2021: `pressure`, `rhoAirCap` read `hElevation`) |
//! | `aux` | `let` (the description as a comment) |
//! | `input` | `disturbance x [unit] column "x" value default` (a default that is not constant, as van Henten's control rules: `let`) |
//! | a variable whose name is a weather column (Katzin 2021: the const `hElevation`) | `disturbance` |
//! | a control named in `inputs` | `input x [unit] in [0, 1] start 0.5 "description"` (unbounded, start 0, unless its unit is `-`) with `rule definition`, GreenLight's rule, on the next line |
//! | `function` | `fn`, except GreenLight's `ifElse`, `min` and `max` (recognised by their bodies) |
//! | `time` | nothing (a comment): GreenLight's time axis, no variable |
//! | the readings a grower looks at (`READINGS`: air temperature, humidity, CO₂, heating and lamp power, fruit dry matter, harvest), where the model has their variables | `output air_temperature [°C] = tAir …` (added, so that a season's plot shows the climate and the crop) |
//!
//! Expressions: `**` becomes `^` (both right-associative, binding tighter than a unary
//! minus on their left), comparisons stay (both give 1 or 0), `logical_and`/`logical_or`
//! become `and`/`or`, `mod` stays (`mod` is numpy's floor-mod in GreenLight and in the
//! language). GreenLight's `ifElse(c, a, b)` is `c*a + (1-c)*b`: where `c` is a
//! comparison or a logical combination of them (0 or 1), that is the language's
//! `if(c, a, b)` (which takes `a` where `c > 0.5`); every `ifElse` of Katzin 2021 has a
//! comparison as its condition (`tFlr > tAir`, `wind < 0.25`, `etaRoof >= etaRoofThr`,
//! `lampTimeOn <= lampTimeOff`, `lampTimeOn < lampTimeOff`, `dayLampStart <= dayLampStop`).
//! Any other condition is written out as `c * a + (1 - c) * b`, GreenLight's own formula.
//! Likewise `logical_and(a, b)` reads numpy's truth (non-zero): an argument that is not a
//! comparison is written `(a != 0)`. `min`/`max` are GreenLight functions
//! `(a<b)*a + (b<=a)*b`, equal to the language's built-ins.
//!
//! Names keep GreenLight's spelling; a name the language reserves (a keyword, a built-in
//! function, `t`) gets `_gl` appended, and the file says so in a comment.

use crate::import::greenlight::expr::{parse, BinOp, CmpOp, Expr};
use crate::import::greenlight::json::{Kind, Resolved, Variable};
use crate::import::ImportError;
use crate::lang::parse::is_reserved;
use std::collections::{BTreeSet, HashMap, HashSet};
use std::fmt::Write as _;
use std::path::PathBuf;

/// What to write.
#[derive(Debug, Clone)]
pub struct EmitOptions {
    /// The `model` name.
    pub model_name: String,
    /// Controls written as `input … in [0, 1] start 0.5` with their rule.
    pub inputs: Vec<String>,
    /// The weather file's columns (other than `Time`): variables of these names become
    /// disturbances.
    pub weather_columns: Vec<String>,
    /// `sample … integrator NAME`.
    pub integrator: String,
    /// The sample period, seconds.
    pub step_s: f64,
    /// `substeps N`.
    pub substeps: usize,
    /// Comment lines for the header (without `# `).
    pub header: Vec<String>,
    /// Variables (GreenLight names) the model does not use, left out and only listed in
    /// a comment at the end of the file.
    pub unused: Vec<String>,
}

/// How many statements of each kind were written.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Counts {
    /// `state` (each with its `der`).
    pub states: usize,
    /// `const`.
    pub consts: usize,
    /// `let` from GreenLight `aux`.
    pub lets_from_aux: usize,
    /// `let` from GreenLight `const` that read something not constant.
    pub lets_from_const: usize,
    /// `let` from GreenLight `input` whose default is not constant.
    pub lets_from_input: usize,
    /// `input`.
    pub inputs: usize,
    /// `disturbance`.
    pub disturbances: usize,
    /// `fn`.
    pub functions: usize,
    /// GreenLight functions written as built-ins (`ifElse`, `min`, `max`).
    pub builtin_functions: usize,
    /// `output` (the readings a grower looks at).
    pub outputs: usize,
    /// Variables written as nothing (`time`).
    pub skipped: usize,
    /// GreenLight `const`s the model does not use, left out (listed at the end).
    pub unused_consts: usize,
    /// GreenLight `aux`es the model does not use, left out (listed at the end).
    pub unused_auxes: usize,
}

/// The `.ghm` text and what it holds.
#[derive(Debug, Clone)]
pub struct Emitted {
    /// The file.
    pub text: String,
    /// Statement counts.
    pub counts: Counts,
    /// Renamings `(GreenLight name, .ghm name)`.
    pub renamed: Vec<(String, String)>,
    /// Variables that became disturbances because a weather column has their name,
    /// though GreenLight declares them otherwise (Katzin 2021: `hElevation`).
    pub columns_taken: Vec<String>,
    /// Constants written as `let` because they read something not constant.
    pub consts_as_lets: Vec<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Skip,
    Function,
    BuiltinFunction,
    State,
    Const,
    Let,
    Input,
    Disturbance,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mapped {
    If,
    Min,
    Max,
}

/// The output tree: the language's expressions.
#[derive(Debug, Clone)]
enum G {
    Num(String),
    Name(String),
    Neg(Box<G>),
    Bin(BinOp, Box<G>, Box<G>),
    Cmp(CmpOp, Box<G>, Box<G>),
    And(Box<G>, Box<G>),
    Or(Box<G>, Box<G>),
    Call(&'static str, Vec<G>),
    UserCall(String, Vec<G>),
}

impl G {
    fn prec(&self) -> u8 {
        match self {
            G::Or(..) => 1,
            G::And(..) => 2,
            G::Cmp(..) => 4,
            G::Bin(BinOp::Add | BinOp::Sub, ..) => 5,
            G::Bin(BinOp::Mul | BinOp::Div, ..) => 6,
            G::Neg(_) => 7,
            G::Bin(BinOp::Pow, ..) => 8,
            G::Num(_) | G::Name(_) | G::Call(..) | G::UserCall(..) => 9,
        }
    }

    fn is_bool(&self) -> bool {
        matches!(self, G::Cmp(..) | G::And(..) | G::Or(..))
    }

    fn write(&self, out: &mut String, min: u8) {
        let paren = self.prec() < min;
        if paren {
            out.push('(');
        }
        match self {
            G::Num(s) | G::Name(s) => out.push_str(s),
            G::Neg(a) => {
                out.push('-');
                a.write(out, 8);
            }
            G::Bin(op, a, b) => {
                let (l, r, sym) = match op {
                    BinOp::Add => (5, 6, " + "),
                    BinOp::Sub => (5, 6, " - "),
                    BinOp::Mul => (6, 7, " * "),
                    BinOp::Div => (6, 7, " / "),
                    BinOp::Pow => (9, 7, "^"),
                };
                a.write(out, l);
                out.push_str(sym);
                b.write(out, r);
            }
            G::Cmp(op, a, b) => {
                a.write(out, 5);
                out.push(' ');
                out.push_str(op.symbol());
                out.push(' ');
                b.write(out, 5);
            }
            G::And(a, b) => {
                a.write(out, 2);
                out.push_str(" and ");
                b.write(out, 3);
            }
            G::Or(a, b) => {
                a.write(out, 1);
                out.push_str(" or ");
                b.write(out, 2);
            }
            G::Call(f, args) => call(out, f, args),
            G::UserCall(f, args) => call(out, f, args),
        }
        if paren {
            out.push(')');
        }
    }

    fn text(&self) -> String {
        let mut s = String::new();
        self.write(&mut s, 0);
        s
    }
}

fn call(out: &mut String, f: &str, args: &[G]) {
    out.push_str(f);
    out.push('(');
    for (i, a) in args.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        a.write(out, 0);
    }
    out.push(')');
}

fn num(s: &str) -> G {
    G::Num(s.to_string())
}

fn bin(op: BinOp, a: G, b: G) -> G {
    G::Bin(op, Box::new(a), Box::new(b))
}

/// GreenLight's built-ins the language has under the same name, with their arity.
const SAME_BUILTINS: &[(&str, &str, usize)] = &[
    ("exp", "exp", 1),
    ("log", "log", 1),
    ("sqrt", "sqrt", 1),
    ("abs", "abs", 1),
    ("sin", "sin", 1),
    ("cos", "cos", 1),
    ("tanh", "tanh", 1),
    ("floor", "floor", 1),
    ("mod", "mod", 2),
];

/// GreenLight's built-ins the language lacks: refused with this message.
const MISSING_BUILTINS: &[&str] = &[
    "sinh", "cosh", "arcsin", "arccos", "arctan", "arctan2", "arcsinh", "arccosh", "arctanh",
    "conj", "real", "imag", "complex", "contains", "inf", "radians", "where",
];

/// The canonical bodies GreenLight gives its `ifElse`, `min` and `max` (parameters as
/// `p0`, `p1`, …).
fn mapped_function(v: &Variable, body: &Expr) -> Option<Mapped> {
    let (want, canonical) = match v.name.as_str() {
        "ifElse" => (Mapped::If, "p0*p1 + (1-p0)*p2"),
        "min" => (Mapped::Min, "(p0<p1)*p0 + (p1<=p0)*p1"),
        "max" => (Mapped::Max, "(p0>p1)*p0 + (p1>=p0)*p1"),
        _ => return None,
    };
    let positional = body.map_names(&|n| match v.params.iter().position(|p| p == n) {
        Some(i) => format!("p{i}"),
        None => format!("global {n}"),
    });
    let canonical = parse(canonical).ok()?;
    (positional == canonical).then_some(want)
}

fn ghm_name(name: &str, taken: &HashSet<String>) -> String {
    if !is_reserved(name) {
        return name.to_string();
    }
    let mut candidate = format!("{name}_gl");
    let mut k = 2;
    while taken.contains(&candidate) || is_reserved(&candidate) {
        candidate = format!("{name}_gl{k}");
        k += 1;
    }
    candidate
}

fn valid_ident(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A string the language accepts inside quotes: no `"`, no line break.
pub fn quote(s: &str) -> String {
    let cleaned: String = s
        .chars()
        .map(|c| match c {
            '"' => '\'',
            '\n' | '\r' | '\t' => ' ',
            c => c,
        })
        .collect();
    let words: Vec<&str> = cleaned.split_whitespace().collect();
    format!("\"{}\"", words.join(" "))
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The unit as the language writes it (`**` as `^`), or `None` with no unit; a unit the
/// brackets cannot hold comes back as `Err(text)` for the description.
fn unit(v: &Variable) -> Result<Option<String>, String> {
    let Some(u) = v.unit.as_deref().map(str::trim) else {
        return Ok(None);
    };
    if u.is_empty() || u == "no_unit_defined" {
        return Ok(None);
    }
    if u.contains([']', '\n', '\r']) {
        return Err(one_line(u));
    }
    Ok(Some(one_line(&u.replace("**", "^"))))
}

struct Ctx<'a> {
    names: &'a HashMap<String, String>,
    roles: &'a HashMap<String, Role>,
    users: &'a HashMap<String, (String, usize)>,
    mapped: &'a HashMap<String, Mapped>,
}

impl Ctx<'_> {
    /// Translates `e`; `params` are the names a function body binds (GreenLight name →
    /// `.ghm` name).
    fn tr(&self, e: &Expr, params: &HashMap<String, String>) -> Result<G, String> {
        Ok(match e {
            Expr::Num(_, t) => num(t),
            Expr::Name(n) => {
                if let Some(p) = params.get(n) {
                    G::Name(p.clone())
                } else {
                    match self.roles.get(n) {
                        None => return Err(format!("`{n}` is not declared in the model")),
                        Some(Role::Skip) => {
                            return Err(format!(
                                "`{n}` is GreenLight's time axis, which the import does not provide as a variable"
                            ))
                        }
                        Some(Role::Function | Role::BuiltinFunction) => {
                            return Err(format!("`{n}` is a function, used as a value"))
                        }
                        Some(_) => G::Name(self.names[n].clone()),
                    }
                }
            }
            Expr::Neg(a) => G::Neg(Box::new(self.tr(a, params)?)),
            Expr::Bin(op, a, b) => bin(*op, self.tr(a, params)?, self.tr(b, params)?),
            Expr::Cmp(op, a, b) => G::Cmp(
                *op,
                Box::new(self.tr(a, params)?),
                Box::new(self.tr(b, params)?),
            ),
            Expr::Call(f, args) => {
                let a: Vec<G> = args
                    .iter()
                    .map(|x| self.tr(x, params))
                    .collect::<Result<_, _>>()?;
                self.call(f, a)?
            }
        })
    }

    fn call(&self, f: &str, mut a: Vec<G>) -> Result<G, String> {
        let arity = |n: usize| {
            if a.len() == n {
                Ok(())
            } else {
                Err(format!("`{f}` takes {n} argument(s), given {}", a.len()))
            }
        };
        if let Some((name, n)) = self.users.get(f) {
            arity(*n)?;
            return Ok(G::UserCall(name.clone(), a));
        }
        let mapped = self.mapped.get(f).copied().or(match f {
            // Not declared by the model: numpy's meaning.
            "min" | "max" if !self.roles.contains_key(f) => {
                Some(if f == "min" { Mapped::Min } else { Mapped::Max })
            }
            _ => None,
        });
        if let Some(m) = mapped {
            return Ok(match m {
                Mapped::Min | Mapped::Max => {
                    arity(2)?;
                    G::Call(if m == Mapped::Min { "min" } else { "max" }, a)
                }
                Mapped::If => {
                    arity(3)?;
                    let (c, x, y) = (a.remove(0), a.remove(0), a.remove(0));
                    if c.is_bool() {
                        G::Call("if", vec![c, x, y])
                    } else {
                        // GreenLight's formula, for a condition that need not be 0 or 1.
                        bin(
                            BinOp::Add,
                            bin(BinOp::Mul, c.clone(), x),
                            bin(BinOp::Mul, bin(BinOp::Sub, num("1"), c), y),
                        )
                    }
                }
            });
        }
        if let Some((_, g, n)) = SAME_BUILTINS.iter().find(|(gl, _, _)| *gl == f) {
            arity(*n)?;
            return Ok(G::Call(g, a));
        }
        let truth = |g: G| {
            if g.is_bool() {
                g
            } else {
                G::Cmp(CmpOp::Ne, Box::new(g), Box::new(num("0")))
            }
        };
        Ok(match f {
            "logical_and" | "logical_or" => {
                arity(2)?;
                let (x, y) = (truth(a.remove(0)), truth(a.remove(0)));
                if f == "logical_and" {
                    G::And(Box::new(x), Box::new(y))
                } else {
                    G::Or(Box::new(x), Box::new(y))
                }
            }
            "log10" => {
                arity(1)?;
                bin(
                    BinOp::Div,
                    G::Call("log", a),
                    G::Call("log", vec![num("10")]),
                )
            }
            "log1p" => {
                arity(1)?;
                G::Call("log", vec![bin(BinOp::Add, num("1"), a.remove(0))])
            }
            "expm1" => {
                arity(1)?;
                bin(BinOp::Sub, G::Call("exp", a), num("1"))
            }
            "ceil" => {
                arity(1)?;
                G::Neg(Box::new(G::Call(
                    "floor",
                    vec![G::Neg(Box::new(a.remove(0)))],
                )))
            }
            "tan" => {
                arity(1)?;
                bin(BinOp::Div, G::Call("sin", a.clone()), G::Call("cos", a))
            }
            _ if MISSING_BUILTINS.contains(&f) => {
                return Err(format!(
                    "the function `{f}` has no equivalent in the .ghm language"
                ))
            }
            _ => return Err(format!("unknown function `{f}`")),
        })
    }
}

/// Writes `model` as `.ghm` text.
pub fn emit(model: &Resolved, opts: &EmitOptions) -> Result<Emitted, ImportError> {
    let file_of = |v: &Variable| -> PathBuf { PathBuf::from(v.definition_from.clone()) };
    let fail = |v: &Variable, message: String| ImportError::Variable {
        path: file_of(v),
        name: v.name.clone(),
        message,
    };

    // Parse every definition and init.
    let mut defs: HashMap<&str, Expr> = HashMap::new();
    let mut inits: HashMap<&str, Expr> = HashMap::new();
    for v in &model.vars {
        if !valid_ident(&v.name) {
            return Err(fail(
                v,
                "the name is not an ASCII identifier (letters, digits, `_`)".into(),
            ));
        }
        if v.kind == Kind::Time {
            continue;
        }
        let parsed = parse(&v.definition).map_err(|e| ImportError::Expr {
            path: file_of(v),
            name: v.name.clone(),
            field: "definition",
            text: v.definition.clone(),
            message: e.to_string(),
        })?;
        defs.insert(&v.name, parsed);
        if v.kind == Kind::State {
            let init = v
                .init
                .as_deref()
                .ok_or_else(|| fail(v, "a state needs an `init` value".into()))?;
            let parsed = parse(init).map_err(|e| ImportError::Expr {
                path: file_of(v),
                name: v.name.clone(),
                field: "init",
                text: init.to_string(),
                message: e.to_string(),
            })?;
            inits.insert(&v.name, parsed);
        }
    }

    // Roles.
    let columns: HashSet<&str> = opts.weather_columns.iter().map(String::as_str).collect();
    let controls: HashSet<&str> = opts.inputs.iter().map(String::as_str).collect();
    for name in &opts.inputs {
        let Some(v) = model.get(name) else {
            return Err(ImportError::Inputs(format!(
                "`{name}` is not a variable of the model (give --inputs the names of aux variables, e.g. uBoil,uRoof)"
            )));
        };
        if matches!(v.kind, Kind::State | Kind::Function | Kind::Time) {
            return Err(ImportError::Inputs(format!(
                "`{name}` is a {} and cannot become a control input",
                v.kind.word()
            )));
        }
        if columns.contains(name.as_str()) {
            return Err(ImportError::Inputs(format!(
                "`{name}` is a column of the weather file and cannot also be a control input"
            )));
        }
    }
    let mut roles: HashMap<String, Role> = HashMap::new();
    let mut mapped: HashMap<String, Mapped> = HashMap::new();
    let mut columns_taken = Vec::new();
    for v in &model.vars {
        let role = match v.kind {
            Kind::Time => Role::Skip,
            Kind::Function => match mapped_function(v, &defs[v.name.as_str()]) {
                Some(m) => {
                    mapped.insert(v.name.clone(), m);
                    Role::BuiltinFunction
                }
                None => Role::Function,
            },
            _ if columns.contains(v.name.as_str()) => {
                if v.kind == Kind::State {
                    return Err(fail(
                        v,
                        "a state cannot be replaced by a weather column".into(),
                    ));
                }
                if v.kind != Kind::Input {
                    columns_taken.push(v.name.clone());
                }
                Role::Disturbance
            }
            _ if controls.contains(v.name.as_str()) => Role::Input,
            Kind::State => Role::State,
            Kind::Const => Role::Const,
            Kind::Aux => Role::Let,
            Kind::Input => Role::Disturbance,
        };
        roles.insert(v.name.clone(), role);
    }
    // A const is constant when every name it reads is a constant const.
    let mut constant: HashSet<&str> = model
        .vars
        .iter()
        .filter(|v| roles[&v.name] == Role::Const)
        .map(|v| v.name.as_str())
        .collect();
    loop {
        let demote: Vec<&str> = constant
            .iter()
            .copied()
            .filter(|n| defs[n].names().iter().any(|r| !constant.contains(r)))
            .collect();
        if demote.is_empty() {
            break;
        }
        for n in demote {
            constant.remove(n);
        }
    }
    let is_constant = |e: &Expr| e.names().iter().all(|n| constant.contains(n));
    let mut consts_as_lets = Vec::new();
    for v in &model.vars {
        let role = roles[&v.name];
        if role == Role::Const && !constant.contains(v.name.as_str()) {
            consts_as_lets.push(v.name.clone());
            roles.insert(v.name.clone(), Role::Let);
        }
        // An input whose default is not constant (a rule) is an aux to GreenLight.
        if v.kind == Kind::Input
            && role == Role::Disturbance
            && !columns.contains(v.name.as_str())
            && !is_constant(&defs[v.name.as_str()])
        {
            roles.insert(v.name.clone(), Role::Let);
        }
    }

    // Names.
    let mut taken: HashSet<String> = model.vars.iter().map(|v| v.name.clone()).collect();
    let mut names: HashMap<String, String> = HashMap::new();
    let mut renamed = Vec::new();
    for v in &model.vars {
        if roles[&v.name] == Role::BuiltinFunction {
            continue;
        }
        let n = ghm_name(&v.name, &taken);
        if n != v.name {
            renamed.push((v.name.clone(), n.clone()));
            taken.insert(n.clone());
        }
        names.insert(v.name.clone(), n);
    }
    let mut users: HashMap<String, (String, usize)> = HashMap::new();
    for v in &model.vars {
        if roles[&v.name] == Role::Function {
            users.insert(v.name.clone(), (names[&v.name].clone(), v.params.len()));
        }
    }
    let ctx = Ctx {
        names: &names,
        roles: &roles,
        users: &users,
        mapped: &mapped,
    };
    let none = HashMap::new();
    let tr = |v: &Variable, e: &Expr, params: &HashMap<String, String>, field: &'static str| {
        ctx.tr(e, params)
            .map(|g| g.text())
            .map_err(|message| ImportError::Expr {
                path: file_of(v),
                name: v.name.clone(),
                field,
                text: if field == "init" {
                    v.init.clone().unwrap_or_default()
                } else {
                    v.definition.clone()
                },
                message,
            })
    };

    // Sections in order of first declaration.
    let mut sections: Vec<(&str, Vec<&Variable>)> = Vec::new();
    for v in &model.vars {
        match sections.iter_mut().find(|(g, _)| *g == v.group) {
            Some((_, list)) => list.push(v),
            None => sections.push((&v.group, vec![v])),
        }
    }

    let mut out = String::new();
    let mut counts = Counts::default();
    for line in &opts.header {
        let line = one_line(line);
        if line.is_empty() {
            out.push_str("#\n");
        } else {
            let _ = writeln!(out, "# {line}");
        }
    }
    if !renamed.is_empty() {
        out.push_str("#\n# Renamed (the .ghm language reserves these words):");
        for (from, to) in &renamed {
            let _ = write!(out, " {from} → {to};");
        }
        out.push('\n');
    }
    out.push('\n');
    let _ = writeln!(
        out,
        "model {}{}",
        opts.model_name,
        model
            .about
            .as_deref()
            .map(|a| format!(" {}", quote(a)))
            .unwrap_or_default()
    );
    let _ = writeln!(
        out,
        "sample {} [s] integrator {} substeps {}",
        fmt_num(opts.step_s),
        opts.integrator,
        opts.substeps
    );
    if !opts.inputs.is_empty() {
        let _ = writeln!(
            out,
            "\n# Control inputs (open loop: set from outside): {}.\n# GreenLight's rule for each is its `rule` (`ghm simulate --rules` applies them).",
            opts.inputs.join(", ")
        );
    }

    for (group, vars) in &sections {
        let _ = writeln!(out, "\n# ---- {} ----", one_line(group));
        for v in vars {
            if opts.unused.contains(&v.name) {
                match v.kind {
                    Kind::Const => counts.unused_consts += 1,
                    _ => counts.unused_auxes += 1,
                }
                continue;
            }
            let role = roles[&v.name];
            let name = names
                .get(&v.name)
                .cloned()
                .unwrap_or_else(|| v.name.clone());
            let (unit_text, unit_note) = match unit(v) {
                Ok(Some(u)) => (format!(" [{u}]"), None),
                Ok(None) => (String::new(), None),
                Err(raw) => (String::new(), Some(raw)),
            };
            let mut description = one_line(&v.description);
            if let Some(raw) = &unit_note {
                description = format!("{description} (unit: {raw})").trim().to_string();
            }
            let desc = if description.is_empty() {
                String::new()
            } else {
                format!(" {}", quote(&description))
            };
            let reference = one_line(&v.reference);
            let mut notes = Vec::new();
            if !reference.is_empty() && role != Role::Const {
                notes.push(format!("# {reference}"));
            }
            if !v.changed_by.is_empty() {
                notes.push(format!("# changed by {}", v.changed_by.join(", ")));
            }
            if v.kinds.len() > 1 {
                let words: Vec<&str> = v.kinds.iter().map(|k| k.word()).collect();
                notes.push(format!(
                    "# declared as {} in turn; the last type ({}) is used",
                    words.join(", then "),
                    v.kind.word()
                ));
            }
            let def = &defs.get(v.name.as_str());
            match role {
                Role::Skip => {
                    counts.skipped += 1;
                    let _ = writeln!(
                        out,
                        "# {}: GreenLight's time axis ({}), not a variable of the model",
                        v.name,
                        v.unit.as_deref().unwrap_or("s")
                    );
                    continue;
                }
                Role::BuiltinFunction => {
                    counts.builtin_functions += 1;
                    let how = match mapped[&v.name] {
                        Mapped::If => {
                            "written as the language's if(c, a, b) where c is a comparison"
                        }
                        Mapped::Min => "the language's min(a, b)",
                        Mapped::Max => "the language's max(a, b)",
                    };
                    let _ = writeln!(
                        out,
                        "# {}({}) = {}: {how}",
                        v.name,
                        v.params.join(", "),
                        one_line(&v.definition)
                    );
                    continue;
                }
                _ => {}
            }
            for n in &notes {
                out.push_str(n);
                out.push('\n');
            }
            let def = def.ok_or_else(|| fail(v, "no definition".into()))?;
            match role {
                Role::State => {
                    counts.states += 1;
                    let init = tr(v, &inits[v.name.as_str()], &none, "init")?;
                    let _ = writeln!(out, "state {name}{unit_text} = {init}{desc}");
                    let _ = writeln!(out, "der {name} = {}", tr(v, def, &none, "definition")?);
                }
                Role::Const => {
                    counts.consts += 1;
                    let source = if reference.is_empty() {
                        String::new()
                    } else {
                        format!(" source {}", quote(&reference))
                    };
                    let _ = writeln!(
                        out,
                        "const {name}{unit_text} = {}{source}{desc}",
                        tr(v, def, &none, "definition")?
                    );
                }
                Role::Let => {
                    match v.kind {
                        Kind::Const => counts.lets_from_const += 1,
                        Kind::Input => counts.lets_from_input += 1,
                        _ => counts.lets_from_aux += 1,
                    }
                    let comment = if v.kind == Kind::Const {
                        let why = if description.is_empty() {
                            String::new()
                        } else {
                            format!("{description}; ")
                        };
                        format!("  # {why}a GreenLight const that reads a variable")
                    } else if description.is_empty() {
                        String::new()
                    } else {
                        format!("  # {description}")
                    };
                    let _ = writeln!(
                        out,
                        "let {name}{unit_text} = {}{comment}",
                        tr(v, def, &none, "definition")?
                    );
                }
                Role::Input => {
                    counts.inputs += 1;
                    // A GreenLight control with unit `-` is a fraction 0–1 (all of Katzin
                    // 2021's); for any other unit GreenLight states no range.
                    // It starts from the middle of that range: GreenLight's controls are
                    // rules with no value before the first step, and an optimiser's first
                    // plan holds the start input (on the economic tomato problem a plan
                    // from the range's bounds took 114–134 interior-point iterations, from
                    // its middle 26).
                    if unit(v) == Ok(Some("-".to_string())) {
                        let _ = writeln!(out, "input {name}{unit_text} in [0, 1] start 0.5{desc}");
                    } else {
                        out.push_str(
                            "# no bounds: GreenLight gives none for a control with a unit\n",
                        );
                        let _ = writeln!(out, "input {name}{unit_text}{desc}");
                    }
                    let _ = writeln!(out, "    rule {}", tr(v, def, &none, "definition")?);
                }
                Role::Disturbance => {
                    counts.disturbances += 1;
                    let value = if is_constant(def) {
                        format!(" value {}", tr(v, def, &none, "definition")?)
                    } else {
                        String::new()
                    };
                    let _ = writeln!(
                        out,
                        "disturbance {name}{unit_text} column {}{value}{desc}",
                        quote(&v.name)
                    );
                }
                Role::Function => {
                    counts.functions += 1;
                    let mut params = HashMap::new();
                    let mut shown = Vec::new();
                    let mut local: HashSet<String> = HashSet::new();
                    for p in &v.params {
                        if !valid_ident(p) {
                            return Err(fail(
                                v,
                                format!("parameter `{p}` is not an ASCII identifier"),
                            ));
                        }
                        let g = ghm_name(p, &local);
                        local.insert(g.clone());
                        params.insert(p.clone(), g.clone());
                        shown.push(g);
                    }
                    let _ = writeln!(
                        out,
                        "fn {name}({}){unit_text} = {}{desc}",
                        shown.join(", "),
                        tr(v, def, &params, "definition")?
                    );
                }
                Role::Skip | Role::BuiltinFunction => {}
            }
        }
    }
    let used: BTreeSet<&str> = model.vars.iter().map(|v| v.name.as_str()).collect();
    debug_assert!(opts.inputs.iter().all(|i| used.contains(i.as_str())));
    let readings: Vec<&Reading> = READINGS
        .iter()
        .filter(|r| {
            r.sum_of.iter().all(|n| {
                names.contains_key(*n) && roles.get(*n).is_some_and(|role| *role != Role::Skip)
            }) && !taken.contains(r.name)
        })
        .collect();
    if !readings.is_empty() {
        out.push_str(
            "\n# ---- What a grower reads (added by the importer, so that a season's plot and \
             trajectory show the climate and the crop) ----\n",
        );
    }
    for r in readings {
        counts.outputs += 1;
        let sum: Vec<&str> = r.sum_of.iter().map(|n| names[*n].as_str()).collect();
        let _ = writeln!(
            out,
            "output {} [{}] = {} {}",
            r.name,
            r.unit,
            sum.join(" + "),
            quote(r.description)
        );
    }
    if !opts.unused.is_empty() {
        out.push_str(
            "\n# Left out: GreenLight defines these, and this model uses none of them:\n#",
        );
        let mut width = 1;
        for name in &opts.unused {
            if width + name.len() + 1 > 88 {
                out.push_str("\n#");
                width = 1;
            }
            let _ = write!(out, " {name}");
            width += name.len() + 1;
        }
        out.push('\n');
    }
    Ok(Emitted {
        text: out,
        counts,
        renamed,
        columns_taken,
        consts_as_lets,
    })
}

/// A quantity of GreenLight's greenhouse models that growers read, written as an output
/// where the model has every variable it sums.
struct Reading {
    name: &'static str,
    unit: &'static str,
    sum_of: &'static [&'static str],
    description: &'static str,
}

/// The readings: the climate (Katzin 2021's `tAir`, `rhIn`, `co2InPpm`), the energy
/// (`hBoilPipe + hBoilGroPipe`, `qLampIn + qIntLampIn`) and the crop (`cFruit`,
/// `mcFruitHar`).
const READINGS: [Reading; 7] = [
    Reading {
        name: "air_temperature",
        unit: "°C",
        sum_of: &["tAir"],
        description: "air temperature (tAir)",
    },
    Reading {
        name: "relative_humidity",
        unit: "%",
        sum_of: &["rhIn"],
        description: "relative humidity of the air (rhIn)",
    },
    Reading {
        name: "co2_concentration",
        unit: "ppm",
        sum_of: &["co2InPpm"],
        description: "CO2 concentration of the air (co2InPpm)",
    },
    Reading {
        name: "heating_power",
        unit: "W m^-2",
        sum_of: &["hBoilPipe", "hBoilGroPipe"],
        description: "boiler heat to the pipe rails and the grow pipes",
    },
    Reading {
        name: "lamp_power",
        unit: "W m^-2",
        sum_of: &["qLampIn", "qIntLampIn"],
        description: "electric input of the top lamps and the interlights",
    },
    Reading {
        name: "fruit_dry_matter",
        unit: "mg{CH2O} m^-2",
        sum_of: &["cFruit"],
        description: "carbohydrates in the fruit (cFruit)",
    },
    Reading {
        name: "harvest_rate",
        unit: "mg{CH2O} m^-2 s^-1",
        sum_of: &["mcFruitHar"],
        description: "fruit harvest (mcFruitHar)",
    },
];

/// A number as the shortest text that reads back the same.
pub fn fmt_num(x: f64) -> String {
    format!("{x}")
}
