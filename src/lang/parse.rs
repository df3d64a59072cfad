//! The parser: `.ghm` text to a list of [`Statement`]s plus diagnostics.
//!
//! The source is split at every line that starts with a statement keyword and each piece
//! is parsed on its own with the pest grammar (`grammar/ghm.pest`). A syntax error thus
//! loses one statement, not the rest of the file, and every bad statement is reported.
//! The parser never panics, whatever the input.

use crate::lang::ast::*;
use crate::lang::chars::unexpected;
use crate::lang::diagnostic::Diagnostic;
use crate::lang::limits::too_complex;
use crate::lang::source::Span;
use pest::iterators::Pair;
use pest::Parser;

#[derive(pest_derive::Parser)]
#[grammar = "../grammar/ghm.pest"]
struct GhmParser;

/// Keywords that start a statement: the parser splits the source at lines starting so.
pub const STATEMENT_KEYWORDS: &[&str] = &[
    "model",
    "import",
    "param",
    "const",
    "state",
    "input",
    "disturbance",
    "let",
    "der",
    "output",
    "sample",
    "reward",
    "cost",
    "soft",
    "terminal",
    "override",
    "drop",
    "uncertainty",
    "solver",
    "fn",
];

/// Whether `name` is a keyword of the grammar (and so can never be a name).
pub fn is_keyword(name: &str) -> bool {
    GhmParser::parse(Rule::keyword, name).is_ok_and(|p| p.as_str().len() == name.len())
}

/// Whether a model may not declare `name`: a keyword, a built-in function or `t` (E004).
///
/// ```
/// use ghm::lang::parse::is_reserved;
/// assert!(is_reserved("clock") && is_reserved("ln") && is_reserved("t"));
/// assert!(!is_reserved("tAir") && !is_reserved("minimum"));
/// ```
pub fn is_reserved(name: &str) -> bool {
    name == "t" || crate::graph::Op::from_function(name).is_some() || is_keyword(name)
}

/// Parses one file. `file` is the file's index in the source map (used in spans).
pub fn parse(file: usize, text: &str) -> (Vec<Statement>, Vec<Diagnostic>) {
    let mut statements = Vec::new();
    let mut diagnostics = Vec::new();
    for (start, chunk) in split_statements(text) {
        if let Some(d) = too_complex(file, start, chunk) {
            diagnostics.push(d);
            continue;
        }
        match GhmParser::parse(Rule::statement, chunk) {
            Ok(mut pairs) => {
                let Some(stmt_pair) = pairs.next().and_then(|p| p.children().next()) else {
                    continue;
                };
                let builder = Builder {
                    file,
                    offset: start,
                };
                match builder.statement(stmt_pair) {
                    Ok(s) => statements.push(s),
                    Err(d) => diagnostics.push(*d),
                }
            }
            Err(e) => diagnostics.push(syntax_error(file, start, chunk, e)),
        }
    }
    (statements, diagnostics)
}

/// Splits the text into `(byte offset, statement text)` pieces. Text before the first
/// keyword line (other than comments and blank lines) becomes a piece of its own so that
/// it is reported, not dropped.
fn split_statements(text: &str) -> Vec<(usize, &str)> {
    let mut starts = Vec::new();
    let mut offset = 0;
    let mut first_content = None;
    for line in text.split_inclusive('\n') {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        let word: String = trimmed
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if STATEMENT_KEYWORDS.contains(&word.as_str()) {
            starts.push(offset + indent);
        } else if first_content.is_none()
            && starts.is_empty()
            && !trimmed.is_empty()
            && !trimmed.starts_with('#')
        {
            first_content = Some(offset + indent);
        }
        offset += line.len();
    }
    if let Some(s) = first_content {
        starts.insert(0, s);
    }
    let mut pieces = Vec::with_capacity(starts.len());
    for (i, &s) in starts.iter().enumerate() {
        let e = starts.get(i + 1).copied().unwrap_or(text.len());
        pieces.push((s, &text[s..e]));
    }
    pieces
}

fn syntax_error(file: usize, start: usize, chunk: &str, e: pest::error::Error<Rule>) -> Diagnostic {
    let pos = match e.location {
        pest::error::InputLocation::Pos(p) => p,
        pest::error::InputLocation::Span((p, _)) => p,
    };
    let at = start + pos;
    let end = at + chunk[pos..].chars().next().map_or(0, char::len_utf8);
    let found = chunk[pos..]
        .split(|c: char| c.is_whitespace())
        .next()
        .unwrap_or("");
    let expected = match &e.variant {
        pest::error::ErrorVariant::ParsingError { positives, .. } => describe_expected(positives),
        pest::error::ErrorVariant::CustomError { message } => message.clone(),
    };
    let span = Span::new(file, at, end);
    if let Some(odd) = chunk[pos..].chars().next().and_then(unexpected) {
        return Diagnostic::error(
            "E001",
            span,
            format!("syntax error: unexpected {}", odd.what),
        )
        .label(format!("expected {expected}"))
        .help(odd.help);
    }
    let found_text = if found.is_empty() {
        "the end of the statement".to_string()
    } else {
        format!("`{found}`")
    };
    Diagnostic::error(
        "E001",
        span,
        format!("syntax error: unexpected {found_text}"),
    )
    .label(format!("expected {expected}"))
    .help("see docs/language.md for the form of each statement")
}

fn describe_expected(rules: &[Rule]) -> String {
    let mut names: Vec<&str> = rules
        .iter()
        .map(|r| match r {
            Rule::expr
            | Rule::disjunction
            | Rule::conjunction
            | Rule::negation
            | Rule::comparison
            | Rule::sum
            | Rule::product
            | Rule::unary
            | Rule::power
            | Rule::atom => "an expression",
            Rule::ident => "a name",
            Rule::number => "a number",
            Rule::string | Rule::description => "a quoted string",
            Rule::unit => "a unit like [kg m^-2]",
            Rule::band | Rule::band_in | Rule::band_le | Rule::band_ge => {
                "a band (`in [lo, hi]`, `<= hi` or `>= lo`)"
            }
            Rule::weights => "`weight`",
            Rule::bounds => "`in [lo, hi]`",
            Rule::input_rule => "`rule EXPRESSION`",
            Rule::EOI => "the end of the statement",
            Rule::cmp_op | Rule::add_op | Rule::mul_op | Rule::kw_and | Rule::kw_or => {
                "an operator"
            }
            Rule::fn_params => "parameters `(a, b)`",
            Rule::setting => "a setting `name = value`",
            Rule::drop_kind => "`reward`, `cost`, `soft` or `terminal`",
            _ => "more input",
        })
        .collect();
    names.sort_unstable();
    names.dedup();
    match names.len() {
        0 => "something else".to_string(),
        1 => names[0].to_string(),
        _ => {
            let last = names.pop().unwrap_or_default();
            format!("{} or {}", names.join(", "), last)
        }
    }
}

/// Children of a pair without the keyword tokens (`kw_*` rules), which carry no data.
trait Children<'i> {
    fn children(self) -> std::vec::IntoIter<Pair<'i, Rule>>;
}

impl<'i> Children<'i> for Pair<'i, Rule> {
    fn children(self) -> std::vec::IntoIter<Pair<'i, Rule>> {
        self.into_inner()
            .filter(|q| !format!("{:?}", q.as_rule()).starts_with("kw_"))
            .collect::<Vec<_>>()
            .into_iter()
    }
}

/// Turns pest pairs into AST nodes, shifting positions by the piece's offset.
struct Builder {
    file: usize,
    offset: usize,
}

type Built<T> = Result<T, Box<Diagnostic>>;

impl Builder {
    fn span(&self, p: &Pair<Rule>) -> Span {
        let s = p.as_span();
        Span::new(self.file, self.offset + s.start(), self.offset + s.end())
    }

    fn name(&self, p: Pair<Rule>) -> Name {
        Name {
            text: p.as_str().to_string(),
            span: self.span(&p),
        }
    }

    fn string(p: Pair<Rule>) -> String {
        // string = "\"" ~ string_body ~ "\""; description wraps a string.
        let mut p = p;
        while p.as_rule() != Rule::string_body {
            match p.children().next() {
                Some(inner) => p = inner,
                None => return String::new(),
            }
        }
        p.as_str().to_string()
    }

    fn unit(p: Pair<Rule>) -> String {
        p.children()
            .next()
            .map(|b| b.as_str().trim().to_string())
            .unwrap_or_default()
    }

    fn statement(&self, p: Pair<Rule>) -> Built<Statement> {
        let span = self.span(&p);
        if p.as_rule() == Rule::override_stmt {
            let inner = p.children().next().ok_or_else(|| self.internal(span))?;
            let mut s = self.statement(inner)?;
            s.overrides = true;
            s.span = span;
            return Ok(s);
        }
        let rule = p.as_rule();
        let mut it = p.children();
        let stmt = match rule {
            Rule::model_stmt => {
                let name = self.name(self.next(&mut it, span)?);
                let description = it.next().map(Self::string);
                Stmt::Model { name, description }
            }
            Rule::import_stmt => {
                let s = self.next(&mut it, span)?;
                Stmt::Import {
                    path: Self::string(s),
                    span,
                }
            }
            Rule::param_stmt | Rule::const_stmt => {
                let name = self.name(self.next(&mut it, span)?);
                let mut doc = Doc::default();
                let mut kind = if rule == Rule::const_stmt {
                    ParamKind::Constant
                } else {
                    ParamKind::Plain
                };
                let mut value = None;
                for q in it {
                    match q.as_rule() {
                        Rule::unit => doc.unit = Some(Self::unit(q)),
                        Rule::expr => value = Some(self.expr(q)?),
                        Rule::uncertain => kind = ParamKind::Uncertain,
                        Rule::source_ref => doc.source = q.children().next().map(Self::string),
                        Rule::description => doc.description = Some(Self::string(q)),
                        _ => {}
                    }
                }
                Stmt::Param {
                    name,
                    kind,
                    value: value.ok_or_else(|| self.internal(span))?,
                    doc,
                }
            }
            Rule::state_stmt
            | Rule::let_stmt
            | Rule::output_stmt
            | Rule::reward_stmt
            | Rule::cost_stmt
            | Rule::terminal_stmt => {
                let name = self.name(self.next(&mut it, span)?);
                let mut doc = Doc::default();
                let mut expr = None;
                for q in it {
                    match q.as_rule() {
                        Rule::unit => doc.unit = Some(Self::unit(q)),
                        Rule::expr => expr = Some(self.expr(q)?),
                        Rule::description => doc.description = Some(Self::string(q)),
                        _ => {}
                    }
                }
                let expr = expr.ok_or_else(|| self.internal(span))?;
                match rule {
                    Rule::state_stmt => Stmt::State {
                        name,
                        initial: expr,
                        doc,
                    },
                    Rule::let_stmt => Stmt::Let { name, expr, doc },
                    Rule::output_stmt => Stmt::Output { name, expr, doc },
                    _ => Stmt::Term {
                        kind: match rule {
                            Rule::reward_stmt => TermKind::Reward,
                            Rule::cost_stmt => TermKind::Cost,
                            _ => TermKind::Terminal,
                        },
                        name,
                        expr,
                        doc,
                    },
                }
            }
            Rule::input_stmt => {
                let name = self.name(self.next(&mut it, span)?);
                let (mut doc, mut bounds, mut rate, mut start) = (Doc::default(), None, None, None);
                let mut rule = None;
                for q in it {
                    match q.as_rule() {
                        Rule::unit => doc.unit = Some(Self::unit(q)),
                        Rule::bounds => {
                            let mut b = q.children();
                            let lo = self.expr(self.next(&mut b, span)?)?;
                            let hi = self.expr(self.next(&mut b, span)?)?;
                            bounds = Some((lo, hi));
                        }
                        Rule::rate => rate = Some(self.expr(self.next(&mut q.children(), span)?)?),
                        Rule::start => {
                            start = Some(self.expr(self.next(&mut q.children(), span)?)?)
                        }
                        Rule::input_rule => {
                            rule = Some(self.expr(self.next(&mut q.children(), span)?)?)
                        }
                        Rule::description => doc.description = Some(Self::string(q)),
                        _ => {}
                    }
                }
                Stmt::Input {
                    name,
                    bounds,
                    rate,
                    start,
                    rule,
                    doc,
                }
            }
            Rule::disturbance_stmt => {
                let name = self.name(self.next(&mut it, span)?);
                let (mut doc, mut column, mut value) = (Doc::default(), None, None);
                let mut clock = false;
                for q in it {
                    match q.as_rule() {
                        Rule::unit => doc.unit = Some(Self::unit(q)),
                        Rule::clock => clock = true,
                        Rule::column => column = q.children().next().map(Self::string),
                        Rule::value => {
                            value = Some(self.expr(self.next(&mut q.children(), span)?)?)
                        }
                        Rule::description => doc.description = Some(Self::string(q)),
                        _ => {}
                    }
                }
                Stmt::Disturbance {
                    name,
                    column,
                    value,
                    clock,
                    doc,
                }
            }
            Rule::der_stmt => {
                let state = self.name(self.next(&mut it, span)?);
                let expr = self.expr(self.next(&mut it, span)?)?;
                Stmt::Der { state, expr }
            }
            Rule::sample_stmt => {
                let period = self.expr(self.next(&mut it, span)?)?;
                let (mut unit, mut integrator, mut substeps) = (None, None, None);
                let mut plan_substeps = None;
                for q in it {
                    match q.as_rule() {
                        Rule::unit => unit = Some(Self::unit(q)),
                        Rule::integrator => integrator = q.children().next().map(|n| self.name(n)),
                        Rule::substeps => {
                            substeps = Some(self.expr(self.next(&mut q.children(), span)?)?)
                        }
                        Rule::plan_substeps => {
                            plan_substeps = Some(self.expr(self.next(&mut q.children(), span)?)?)
                        }
                        _ => {}
                    }
                }
                Stmt::Sample {
                    period,
                    unit,
                    integrator,
                    substeps,
                    plan_substeps,
                    span,
                }
            }
            Rule::soft_stmt => {
                let output = self.name(self.next(&mut it, span)?);
                let band = self.band(self.next(&mut it, span)?)?;
                let mut w = self.next(&mut it, span)?.children();
                let weight_lo = self.expr(self.next(&mut w, span)?)?;
                let weight_hi = match w.next() {
                    Some(e) => Some(self.expr(e)?),
                    None => None,
                };
                let (mut plan, mut description) = (None, None);
                for q in it {
                    match q.as_rule() {
                        Rule::plan => plan = Some(self.band(self.next(&mut q.children(), span)?)?),
                        Rule::description => description = Some(Self::string(q)),
                        _ => {}
                    }
                }
                Stmt::Soft {
                    output,
                    band,
                    weight_lo,
                    weight_hi,
                    plan,
                    description,
                }
            }
            Rule::fn_stmt => {
                let name = self.name(self.next(&mut it, span)?);
                let params = self
                    .next(&mut it, span)?
                    .children()
                    .map(|q| self.name(q))
                    .collect();
                let (mut doc, mut body) = (Doc::default(), None);
                for q in it {
                    match q.as_rule() {
                        Rule::unit => doc.unit = Some(Self::unit(q)),
                        Rule::expr => body = Some(self.expr(q)?),
                        Rule::description => doc.description = Some(Self::string(q)),
                        _ => {}
                    }
                }
                Stmt::Function {
                    name,
                    params,
                    body: body.ok_or_else(|| self.internal(span))?,
                    doc,
                }
            }
            Rule::drop_stmt => {
                let kind = self.next(&mut it, span)?.as_str().to_string();
                let name = self.name(self.next(&mut it, span)?);
                Stmt::Drop { kind, name }
            }
            Rule::uncertainty_stmt => Stmt::Uncertainty {
                settings: self.settings(it, span)?,
                span,
            },
            Rule::solver_stmt => Stmt::Solver {
                settings: self.settings(it, span)?,
                span,
            },
            _ => return Err(self.internal(span)),
        };
        Ok(Statement {
            stmt,
            overrides: false,
            span,
        })
    }

    fn band(&self, p: Pair<Rule>) -> Built<Band> {
        let span = self.span(&p);
        let inner = self.next(&mut p.children(), span)?;
        let rule = inner.as_rule();
        let mut it = inner.children();
        let first = self.expr(self.next(&mut it, span)?)?;
        Ok(match rule {
            Rule::band_in => {
                let hi = self.expr(self.next(&mut it, span)?)?;
                Band {
                    lo: Some(first),
                    hi: Some(hi),
                    span,
                }
            }
            Rule::band_le => Band {
                lo: None,
                hi: Some(first),
                span,
            },
            _ => Band {
                lo: Some(first),
                hi: None,
                span,
            },
        })
    }

    fn expr(&self, p: Pair<Rule>) -> Built<Expr> {
        let span = self.span(&p);
        match p.as_rule() {
            Rule::expr | Rule::atom => {
                let inner = self.next(&mut p.children(), span)?;
                self.expr(inner)
            }
            Rule::disjunction | Rule::conjunction => {
                let op = if p.as_rule() == Rule::disjunction {
                    BinaryOp::Or
                } else {
                    BinaryOp::And
                };
                let mut it = p.children();
                let mut lhs = self.expr(self.next(&mut it, span)?)?;
                for q in it {
                    let rhs = self.expr(q)?;
                    let s = lhs.span().to(rhs.span());
                    lhs = Expr::Binary(op, Box::new(lhs), Box::new(rhs), s);
                }
                Ok(lhs)
            }
            Rule::negation => self.prefixed(p, Rule::kw_not, Expr::Not),
            Rule::comparison | Rule::sum | Rule::product => {
                let mut it = p.children();
                let mut lhs = self.expr(self.next(&mut it, span)?)?;
                while let Some(op) = it.next() {
                    let rhs = self.expr(self.next(&mut it, span)?)?;
                    let op = match op.as_str() {
                        "+" => BinaryOp::Add,
                        "-" => BinaryOp::Sub,
                        "*" => BinaryOp::Mul,
                        "/" => BinaryOp::Div,
                        "<" => BinaryOp::Lt,
                        "<=" => BinaryOp::Le,
                        ">" => BinaryOp::Gt,
                        "==" => BinaryOp::Eq,
                        "!=" => BinaryOp::Ne,
                        _ => BinaryOp::Ge,
                    };
                    let s = lhs.span().to(rhs.span());
                    lhs = Expr::Binary(op, Box::new(lhs), Box::new(rhs), s);
                }
                Ok(lhs)
            }
            Rule::unary => self.prefixed(p, Rule::neg, Expr::Neg),
            Rule::power => {
                let mut it = p.children();
                let base = self.expr(self.next(&mut it, span)?)?;
                match it.next() {
                    Some(exp) => Ok(Expr::Binary(
                        BinaryOp::Pow,
                        Box::new(base),
                        Box::new(self.expr(exp)?),
                        span,
                    )),
                    None => Ok(base),
                }
            }
            Rule::number => {
                let v: f64 = p.as_str().parse().map_err(|_| {
                    Diagnostic::error(
                        "E002",
                        span,
                        format!("`{}` is not a valid number", p.as_str()),
                    )
                })?;
                Ok(Expr::Number(v, span))
            }
            Rule::ident => Ok(Expr::Name(self.name(p))),
            Rule::next_call => {
                let n = self.name(self.next(&mut p.children(), span)?);
                Ok(Expr::Next(n, span))
            }
            Rule::call => {
                let mut it = p.children();
                let f = self.name(self.next(&mut it, span)?);
                let args = it.map(|a| self.expr(a)).collect::<Built<Vec<_>>>()?;
                Ok(Expr::Call(f, args, span))
            }
            _ => Err(self.internal(span)),
        }
    }

    /// `not not a`, `--a`: the operand wrapped once per `prefix` token before it, each
    /// wrapper spanning the whole prefixed expression.
    fn prefixed(
        &self,
        p: Pair<Rule>,
        prefix: Rule,
        wrap: fn(Box<Expr>, Span) -> Expr,
    ) -> Built<Expr> {
        let span = self.span(&p);
        let (mut count, mut operand) = (0, None);
        // Not `children`: it leaves out keyword tokens, and here they are the data.
        for q in p.into_inner() {
            if q.as_rule() == prefix {
                count += 1;
            } else {
                operand = Some(q);
            }
        }
        let mut e = self.expr(operand.ok_or_else(|| self.internal(span))?)?;
        for _ in 0..count {
            e = wrap(Box::new(e), span);
        }
        Ok(e)
    }

    /// The `SETTING = VALUE` pairs of an `uncertainty` or `solver` statement.
    fn settings<'i>(
        &self,
        pairs: impl Iterator<Item = Pair<'i, Rule>>,
        span: Span,
    ) -> Built<Vec<(Name, Name)>> {
        pairs
            .map(|setting| {
                let mut kv = setting.children();
                let key = self.name(self.next(&mut kv, span)?);
                let value = self.name(self.next(&mut kv, span)?);
                Ok((key, value))
            })
            .collect()
    }

    fn next<'i>(
        &self,
        it: &mut impl Iterator<Item = Pair<'i, Rule>>,
        span: Span,
    ) -> Built<Pair<'i, Rule>> {
        it.next().ok_or_else(|| self.internal(span))
    }

    fn internal(&self, span: Span) -> Box<Diagnostic> {
        Box::new(
            Diagnostic::error("E000", span, "internal parser error: unexpected tree shape")
                .help("please report this with the file that caused it"),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_each_statement_kind() {
        let src = "model m \"d\"\nparam a [s] = 2 uncertain \"x\" source \"y\"\nconst c = 1/3\nstate x [m] = 1\ninput u [W] in [0, 1] rate 0.1 start 0\ndisturbance d column \"c\" value 3\nlet l = a * x\nder x = -l + u + d\noutput y = x ^ 2\nsample 10 [s] integrator rk4 substeps 2\nreward r = next(x) - x\ncost k = u\nsoft y in [0, 1] weight 1, 2 plan <= 0.9\nuncertainty redraw = step, spread = 0.5\n";
        let (stmts, diags) = parse(0, src);
        assert!(diags.is_empty(), "{diags:?}");
        assert_eq!(stmts.len(), 14);
        assert!(matches!(
            &stmts[1].stmt,
            Stmt::Param {
                kind: ParamKind::Uncertain,
                ..
            }
        ));
    }

    #[test]
    fn reports_every_bad_statement() {
        let (stmts, diags) = parse(0, "param a = \nparam b = 2\nstate x = )\n");
        assert_eq!(stmts.len(), 1);
        assert_eq!(diags.len(), 2);
    }

    #[test]
    fn precedence_and_power_are_right_associative() {
        let (stmts, _) = parse(0, "let z = -2 ^ 2 ^ 3 * 4 + 1\n");
        let Stmt::Let { expr, .. } = &stmts[0].stmt else {
            panic!()
        };
        // ((-(2^(2^3))) * 4) + 1
        let Expr::Binary(BinaryOp::Add, lhs, _, _) = expr else {
            panic!("{expr:?}")
        };
        let Expr::Binary(BinaryOp::Mul, neg, _, _) = lhs.as_ref() else {
            panic!()
        };
        assert!(matches!(neg.as_ref(), Expr::Neg(..)));
    }
}
