//! The syntax tree of a `.ghm` file: what the parser builds and the checker reads.
//!
//! Every node carries the [`Span`] of the text it came from, so that any later error can
//! point at the exact place in the user's file.

use crate::lang::source::Span;

/// An identifier together with where it was written.
#[derive(Debug, Clone, PartialEq)]
pub struct Name {
    pub text: String,
    pub span: Span,
}

/// Binary operators of the expression language.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Lt,
    Le,
    Gt,
    Ge,
}

/// An expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    Number(f64, Span),
    Name(Name),
    /// `next(x)`: the value of state `x` after the step (stage terms only).
    Next(Name, Span),
    Neg(Box<Expr>, Span),
    Binary(BinaryOp, Box<Expr>, Box<Expr>, Span),
    Call(Name, Vec<Expr>, Span),
}

impl Expr {
    /// Where the whole expression is in the source.
    pub fn span(&self) -> Span {
        match self {
            Expr::Number(_, s) | Expr::Next(_, s) | Expr::Neg(_, s) => *s,
            Expr::Name(n) => n.span,
            Expr::Binary(_, _, _, s) | Expr::Call(_, _, s) => *s,
        }
    }
}

/// What a declaration says about itself for humans: unit, description and source.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Doc {
    pub unit: Option<String>,
    pub description: Option<String>,
    pub source: Option<String>,
}

/// One side of a soft band, or a planning band: `in [lo, hi]`, `<= hi` or `>= lo`.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    pub lo: Option<Expr>,
    pub hi: Option<Expr>,
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
    Model {
        name: Name,
        description: Option<String>,
    },
    Import {
        path: String,
        span: Span,
    },
    Param {
        name: Name,
        kind: ParamKind,
        value: Expr,
        doc: Doc,
    },
    State {
        name: Name,
        initial: Expr,
        doc: Doc,
    },
    Input {
        name: Name,
        bounds: Option<(Expr, Expr)>,
        rate: Option<Expr>,
        start: Option<Expr>,
        doc: Doc,
    },
    Disturbance {
        name: Name,
        column: Option<String>,
        value: Option<Expr>,
        doc: Doc,
    },
    Let {
        name: Name,
        expr: Expr,
        doc: Doc,
    },
    Der {
        state: Name,
        expr: Expr,
    },
    Output {
        name: Name,
        expr: Expr,
        doc: Doc,
    },
    Sample {
        period: Expr,
        unit: Option<String>,
        integrator: Option<Name>,
        substeps: Option<Expr>,
        span: Span,
    },
    Term {
        kind: TermKind,
        name: Name,
        expr: Expr,
        doc: Doc,
    },
    Soft {
        output: Name,
        band: Band,
        weight_lo: Expr,
        weight_hi: Option<Expr>,
        plan: Option<Band>,
        description: Option<String>,
    },
    Drop {
        kind: String,
        name: Name,
    },
    Uncertainty {
        settings: Vec<(Name, Name)>,
        span: Span,
    },
}

/// A statement with its span, and whether it was written as `override`.
#[derive(Debug, Clone, PartialEq)]
pub struct Statement {
    pub stmt: Stmt,
    pub overrides: bool,
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
