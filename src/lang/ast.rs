//! The syntax tree of a `.ghm` file: what the parser builds and the checker reads.
//!
//! Every node carries the [`Span`] of the text it came from, so that any later error can
//! point at the exact place in the user's file.

use crate::lang::source::Span;

/// An identifier together with where it was written.
#[derive(Debug, Clone, PartialEq)]
pub struct Name {
    /// The identifier as written (letters, digits and `_`; for an `uncertainty` setting's
    /// value, also a number such as `0.5`).
    pub text: String,
    /// Where the identifier is in the source.
    pub span: Span,
}

/// Binary operators of the expression language.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryOp {
    /// `a + b`.
    Add,
    /// `a - b`.
    Sub,
    /// `a * b`.
    Mul,
    /// `a / b`.
    Div,
    /// `a ^ b` (right-associative; also what `pow(a, b)` means).
    Pow,
    /// `a < b`: 1 if true, else 0.
    Lt,
    /// `a <= b`: 1 if true, else 0.
    Le,
    /// `a > b`: 1 if true, else 0.
    Gt,
    /// `a >= b`: 1 if true, else 0.
    Ge,
    /// `a == b`: 1 if true, else 0.
    Eq,
    /// `a != b`: 1 if true, else 0.
    Ne,
    /// `a and b`: 1 if both are true (above 0.5), else 0.
    And,
    /// `a or b`: 1 if either is true (above 0.5), else 0.
    Or,
}

/// An expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A numeric literal such as `1.5` or `2e-3` (never negative: `-1` is [`Expr::Neg`]).
    Number(f64, Span),
    /// A reference to a declared name.
    Name(Name),
    /// `next(x)`: the value of state `x` after the step (stage terms only).
    Next(Name, Span),
    /// Unary minus, `-a`.
    Neg(Box<Expr>, Span),
    /// `not a`: 1 where `a` is false (at most 0.5), else 0.
    Not(Box<Expr>, Span),
    /// `lhs op rhs`.
    Binary(BinaryOp, Box<Expr>, Box<Expr>, Span),
    /// A function call `f(a, ...)`: the function's name and its arguments in order.
    Call(Name, Vec<Expr>, Span),
}

impl Expr {
    /// Where the whole expression is in the source.
    pub fn span(&self) -> Span {
        match self {
            Expr::Number(_, s) | Expr::Next(_, s) | Expr::Neg(_, s) | Expr::Not(_, s) => *s,
            Expr::Name(n) => n.span,
            Expr::Binary(_, _, _, s) | Expr::Call(_, _, s) => *s,
        }
    }
}

/// What a declaration says about itself for humans: unit, description and source.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Doc {
    /// The text inside `[...]` after the name, trimmed (`kg m^-2`); not checked.
    pub unit: Option<String>,
    /// The quoted string after the declaration, without the quotes.
    pub description: Option<String>,
    /// The string of `source "..."` (parameters and constants only).
    pub source: Option<String>,
}

/// One side of a soft band, or a planning band: `in [lo, hi]`, `<= hi` or `>= lo`.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// The lower limit (`in [lo, hi]`, `>= lo`), a constant expression; `None` for `<= hi`.
    pub lo: Option<Expr>,
    /// The upper limit (`in [lo, hi]`, `<= hi`), a constant expression; `None` for `>= lo`.
    pub hi: Option<Expr>,
    /// Where the band is in the source.
    pub span: Span,
}

/// Whether a parameter may be perturbed by parametric uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamKind {
    /// `param name = v uncertain`: drawn in every uncertainty setting.
    Uncertain,
    /// `param name = v`: drawn only when the uncertainty setting says `params = all`.
    Plain,
    /// `const name = v`: never perturbed.
    Constant,
}

/// How a stage term enters the objective.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TermKind {
    /// Added to the reward.
    Reward,
    /// Subtracted from the reward.
    Cost,
    /// Added to the reward once, at the end of the horizon / season (a function of the state).
    Terminal,
}

impl TermKind {
    /// The statement keyword that declares it: `reward`, `cost` or `terminal`.
    pub fn keyword(self) -> &'static str {
        match self {
            TermKind::Reward => "reward",
            TermKind::Cost => "cost",
            TermKind::Terminal => "terminal",
        }
    }
}

/// A statement of a `.ghm` file.
#[derive(Debug, Clone, PartialEq)]
pub enum Stmt {
    /// `model NAME "description"`: names the model (the last one wins).
    Model {
        /// The model's name.
        name: Name,
        /// The optional quoted description.
        description: Option<String>,
    },
    /// `import "path.ghm"`: replaced by the imported file's statements while loading.
    Import {
        /// The path as written, relative to the importing file.
        path: String,
        /// Where the statement is.
        span: Span,
    },
    /// `param` or `const` (told apart by `kind`).
    Param {
        /// The parameter's name.
        name: Name,
        /// `const`, `param` or `param ... uncertain`.
        kind: ParamKind,
        /// The nominal value: a constant expression over parameters declared above.
        value: Expr,
        /// Unit, description and `source "..."`.
        doc: Doc,
    },
    /// `state NAME [unit] = EXPR "description"`.
    State {
        /// The state's name.
        name: Name,
        /// The initial value, a constant expression.
        initial: Expr,
        /// Unit and description (no source).
        doc: Doc,
    },
    /// `input NAME [unit] in [LO, HI] rate R start S "description"` (all options optional).
    Input {
        /// The input's name.
        name: Name,
        /// `in [LO, HI]`, as constant expressions; `None`: unbounded.
        bounds: Option<(Expr, Expr)>,
        /// `rate R`: the largest |u(k) − u(k−1)|; `None`: no limit.
        rate: Option<Expr>,
        /// `start S`: the input before the first step; `None`: 0 clipped into the bounds.
        start: Option<Expr>,
        /// `rule EXPR`: the rule a rule-based controller sets the input by, from the state,
        /// the weather and the parameters; `None`: no rule.
        rule: Option<Expr>,
        /// Unit and description.
        doc: Doc,
    },
    /// `disturbance NAME [unit] column "name" value V "description"`.
    Disturbance {
        /// The disturbance's name.
        name: Name,
        /// `column "name"`: its weather-file column; `None`: the disturbance's own name.
        column: Option<String>,
        /// `value V`: a constant, used when no weather file is given and every disturbance
        /// has one.
        value: Option<Expr>,
        /// `clock`: the time in seconds, read from the weather (column `time_s` unless
        /// `column` names another) and advanced by the integrator within a step.
        clock: bool,
        /// Unit and description.
        doc: Doc,
    },
    /// `let NAME [unit] = EXPR`: a named intermediate expression.
    Let {
        /// The let's name.
        name: Name,
        /// Its expression, over states, inputs, disturbances, parameters, lets and outputs.
        expr: Expr,
        /// The unit only (a `let` has no description).
        doc: Doc,
    },
    /// `der STATE = EXPR`: the state's time derivative, per second.
    Der {
        /// The state it differentiates.
        state: Name,
        /// dx/dt = f(x, u, d, p).
        expr: Expr,
    },
    /// `output NAME [unit] = EXPR "description"`.
    Output {
        /// The output's name.
        name: Name,
        /// y = g(x, u, d, p).
        expr: Expr,
        /// Unit and description.
        doc: Doc,
    },
    /// `sample EXPR [unit] integrator NAME substeps N plan substeps M`: the control period.
    Sample {
        /// The period in `unit`, a constant expression.
        period: Expr,
        /// `s`, `min` or `h` (anything else is error E017); `None`: seconds.
        unit: Option<String>,
        /// `integrator rk4|euler`; `None`: `rk4`.
        integrator: Option<Name>,
        /// `substeps N`: integration steps per period (1–1000); `None`: 1.
        substeps: Option<Expr>,
        /// `plan substeps M`: integration steps per period in the controllers' predictions
        /// (1–1000); `None`: `substeps`.
        plan_substeps: Option<Expr>,
        /// Where the statement is.
        span: Span,
    },
    /// `reward`, `cost` or `terminal NAME [unit] = EXPR "description"`.
    Term {
        /// Which of the three keywords declared it.
        kind: TermKind,
        /// The term's name.
        name: Name,
        /// The term's value as written (a cost is not negated here).
        expr: Expr,
        /// Unit and description.
        doc: Doc,
    },
    /// `soft OUTPUT BAND weight W, W_ABOVE plan BAND "description"`.
    Soft {
        /// The output the band applies to.
        output: Name,
        /// The band outside which the output is penalised.
        band: Band,
        /// The first weight: the penalty per unit below the band, and above it too when
        /// there is no second weight.
        weight_lo: Expr,
        /// The second weight, `weight w_below, w_above`: the penalty per unit above the band.
        weight_hi: Option<Expr>,
        /// `plan BAND`: the tighter band a controller may plan with.
        plan: Option<Band>,
        /// The optional quoted description.
        description: Option<String>,
    },
    /// `fn NAME(A, B) [unit] = EXPR "description"`: a function, inlined into the graph
    /// wherever it is called.
    Function {
        /// The function's name.
        name: Name,
        /// Its parameters, in order.
        params: Vec<Name>,
        /// Its body, over its parameters and any name of the model.
        body: Expr,
        /// Unit (of the result) and description.
        doc: Doc,
    },
    /// `drop KIND NAME`: removes an objective term or a soft band declared before.
    Drop {
        /// `reward`, `cost`, `soft` or `terminal`, as written.
        kind: String,
        /// The term's name, or for `soft` the output's.
        name: Name,
    },
    /// `solver SETTING = VALUE, ...`: how every solver is to see the problem.
    Solver {
        /// `(setting, value)` pairs in order, e.g. `(objective_scale, 1000)`.
        settings: Vec<(Name, Name)>,
        /// Where the statement is.
        span: Span,
    },
    /// `uncertainty SETTING = VALUE, ...`: the parametric uncertainty rule.
    Uncertainty {
        /// `(setting, value)` pairs in order, e.g. `(redraw, step)`, `(spread, 0.5)`.
        settings: Vec<(Name, Name)>,
        /// Where the statement is.
        span: Span,
    },
}

/// A statement with its span, and whether it was written as `override`.
#[derive(Debug, Clone, PartialEq)]
pub struct Statement {
    /// What the statement says.
    pub stmt: Stmt,
    /// Whether it was written `override ...`, replacing an earlier declaration.
    pub overrides: bool,
    /// The whole statement, `override` included.
    pub span: Span,
}

impl Stmt {
    /// The name a statement declares, if it declares one, with the kind word used in messages.
    pub fn declared(&self) -> Option<(&'static str, &Name)> {
        match self {
            Stmt::Param { name, kind, .. } => Some((
                if *kind == ParamKind::Constant {
                    "const"
                } else {
                    "param"
                },
                name,
            )),
            Stmt::State { name, .. } => Some(("state", name)),
            Stmt::Input { name, .. } => Some(("input", name)),
            Stmt::Disturbance { name, .. } => Some(("disturbance", name)),
            Stmt::Let { name, .. } => Some(("let", name)),
            Stmt::Output { name, .. } => Some(("output", name)),
            Stmt::Term { kind, name, .. } => Some((kind.keyword(), name)),
            _ => None,
        }
    }
}
