//! A small parser of the Python-like expressions GreenLight writes in its model files
//! (`definition` and `init` strings) into an own syntax tree, [`Expr`].
//!
//! Accepted: numbers (`12`, `1.5`, `.5`, `1.2e3`), names, calls by bare name with
//! positional arguments, `+ - * / **`, unary `-` and `+`, one comparison per level
//! (`< <= > >= == !=`) and parentheses, with Python's precedence: `**` is right-associative
//! and binds tighter than a unary minus on its left (`-2**2` is −4) but its exponent may
//! carry its own sign (`2**-1`); comparisons bind loosest. Everything else Python would
//! accept (attributes, strings, `%`, `//`, chained comparisons, `and`/`or`/`not`,
//! `a if c else b`, subscripts, keyword arguments) is refused with a message naming the
//! construct; the caller adds the variable's name and file.

use std::fmt;

/// A binary arithmetic operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `**`
    Pow,
}

/// A comparison, whose value is 1 (true) or 0 (false).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CmpOp {
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `==`
    Eq,
    /// `!=`
    Ne,
}

impl CmpOp {
    /// The operator as written (the same in Python and in `.ghm`).
    pub fn symbol(self) -> &'static str {
        match self {
            CmpOp::Lt => "<",
            CmpOp::Le => "<=",
            CmpOp::Gt => ">",
            CmpOp::Ge => ">=",
            CmpOp::Eq => "==",
            CmpOp::Ne => "!=",
        }
    }
}

/// An expression of a GreenLight definition.
#[derive(Debug, Clone)]
pub enum Expr {
    /// A number: its value and its text as written (kept for the emitted file).
    Num(f64, String),
    /// A variable or function parameter.
    Name(String),
    /// `-a`
    Neg(Box<Expr>),
    /// `a op b`
    Bin(BinOp, Box<Expr>, Box<Expr>),
    /// `a cmp b`
    Cmp(CmpOp, Box<Expr>, Box<Expr>),
    /// `f(a, b, …)`
    Call(String, Vec<Expr>),
}

/// Structural equality; numbers compare by value (`1.0` equals `1`).
impl PartialEq for Expr {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Expr::Num(a, _), Expr::Num(b, _)) => a == b,
            (Expr::Name(a), Expr::Name(b)) => a == b,
            (Expr::Neg(a), Expr::Neg(b)) => a == b,
            (Expr::Bin(o, a, b), Expr::Bin(p, c, d)) => o == p && a == c && b == d,
            (Expr::Cmp(o, a, b), Expr::Cmp(p, c, d)) => o == p && a == c && b == d,
            (Expr::Call(f, a), Expr::Call(g, b)) => f == g && a == b,
            _ => false,
        }
    }
}

impl Expr {
    /// Every name the expression reads (not the called functions), in order of first use.
    pub fn names(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        let mut stack = vec![self];
        while let Some(e) = stack.pop() {
            match e {
                Expr::Num(..) => {}
                Expr::Name(n) => {
                    if !out.contains(&n.as_str()) {
                        out.push(n);
                    }
                }
                Expr::Neg(a) => stack.push(a),
                Expr::Bin(_, a, b) | Expr::Cmp(_, a, b) => {
                    stack.push(b);
                    stack.push(a);
                }
                Expr::Call(_, args) => stack.extend(args.iter().rev()),
            }
        }
        out
    }

    /// Every function called, with its number of arguments.
    pub fn calls(&self) -> Vec<(&str, usize)> {
        let mut out = Vec::new();
        let mut stack = vec![self];
        while let Some(e) = stack.pop() {
            match e {
                Expr::Num(..) | Expr::Name(_) => {}
                Expr::Neg(a) => stack.push(a),
                Expr::Bin(_, a, b) | Expr::Cmp(_, a, b) => {
                    stack.push(b);
                    stack.push(a);
                }
                Expr::Call(f, args) => {
                    out.push((f.as_str(), args.len()));
                    stack.extend(args.iter().rev());
                }
            }
        }
        out
    }

    /// The expression with every name replaced by `rename(name)`.
    pub fn map_names(&self, rename: &dyn Fn(&str) -> String) -> Expr {
        match self {
            Expr::Num(v, t) => Expr::Num(*v, t.clone()),
            Expr::Name(n) => Expr::Name(rename(n)),
            Expr::Neg(a) => Expr::Neg(Box::new(a.map_names(rename))),
            Expr::Bin(o, a, b) => Expr::Bin(
                *o,
                Box::new(a.map_names(rename)),
                Box::new(b.map_names(rename)),
            ),
            Expr::Cmp(o, a, b) => Expr::Cmp(
                *o,
                Box::new(a.map_names(rename)),
                Box::new(b.map_names(rename)),
            ),
            Expr::Call(f, args) => Expr::Call(
                f.clone(),
                args.iter().map(|a| a.map_names(rename)).collect(),
            ),
        }
    }
}

/// Why an expression was refused: the construct and the byte offset where it starts.
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError {
    /// What was found and why it is refused.
    pub message: String,
    /// Byte offset into the expression text.
    pub at: usize,
}

impl fmt::Display for ExprError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (at character {})", self.message, self.at + 1)
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64, String),
    Name(String),
    Op(&'static str),
    LParen,
    RParen,
    Comma,
    End,
}

/// Python keywords that may not be names; each marks a construct the importer refuses.
const PYTHON_KEYWORDS: &[&str] = &[
    "and", "or", "not", "if", "else", "lambda", "in", "is", "for", "None", "True", "False",
    "await", "yield",
];

fn tokenize(text: &str) -> Result<Vec<(Tok, usize)>, ExprError> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    let err = |message: String, at: usize| Err(ExprError { message, at });
    while i < bytes.len() {
        let c = bytes[i];
        let start = i;
        if c == b' ' || c == b'\t' || c == b'\n' || c == b'\r' {
            i += 1;
            continue;
        }
        if c.is_ascii_digit() || (c == b'.' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
            }
            if i < bytes.len() && bytes[i] == b'.' {
                i += 1;
                while i < bytes.len() && bytes[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
                let mut j = i + 1;
                if j < bytes.len() && (bytes[j] == b'+' || bytes[j] == b'-') {
                    j += 1;
                }
                if j < bytes.len() && bytes[j].is_ascii_digit() {
                    while j < bytes.len() && bytes[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                }
            }
            if i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                return err(
                    format!(
                        "number `{}` in a form the importer does not read (write e.g. 12, 1.5, 1.2e3)",
                        &text[start..=i]
                    ),
                    start,
                );
            }
            let t = &text[start..i];
            let v: f64 = match t.parse() {
                Ok(v) => v,
                Err(_) => return err(format!("number `{t}` cannot be read"), start),
            };
            out.push((Tok::Num(v, t.to_string()), start));
            continue;
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            let name = &text[start..i];
            if PYTHON_KEYWORDS.contains(&name) {
                return err(
                    format!("the Python keyword `{name}` is not supported (write logical_and(a, b), logical_or(a, b), ifElse(c, a, b))"),
                    start,
                );
            }
            out.push((Tok::Name(name.to_string()), start));
            continue;
        }
        let two = text.get(i..i + 2).unwrap_or("");
        let op: &'static str = match two {
            "**" => "**",
            "<=" => "<=",
            ">=" => ">=",
            "==" => "==",
            "!=" => "!=",
            "//" => return err("floor division `//` is not supported".into(), start),
            _ => match c {
                b'+' => "+",
                b'-' => "-",
                b'*' => "*",
                b'/' => "/",
                b'<' => "<",
                b'>' => ">",
                b'(' => "(",
                b')' => ")",
                b',' => ",",
                b'%' => {
                    return err(
                        "the operator `%` is not supported (write mod(a, b))".into(),
                        start,
                    )
                }
                b'.' => return err(
                    "attribute access (`.`) is not supported: call functions by their bare name"
                        .into(),
                    start,
                ),
                b'"' | b'\'' => return err("strings are not supported".into(), start),
                b'[' | b']' => {
                    return err(
                        "subscripts and lists (`[ ]`) are not supported".into(),
                        start,
                    )
                }
                b'=' => {
                    return err(
                        "assignment or keyword arguments (`=`) are not supported".into(),
                        start,
                    )
                }
                _ => {
                    let ch = text[i..].chars().next().unwrap_or('?');
                    return err(format!("unexpected character `{ch}`"), start);
                }
            },
        };
        i += op.len();
        let tok = match op {
            "(" => Tok::LParen,
            ")" => Tok::RParen,
            "," => Tok::Comma,
            _ => Tok::Op(op),
        };
        out.push((tok, start));
    }
    out.push((Tok::End, text.len()));
    Ok(out)
}

struct Parser {
    toks: Vec<(Tok, usize)>,
    pos: usize,
    depth: usize,
}

/// Nesting deeper than this is refused (it keeps the recursive parser off the stack's end).
const MAX_DEPTH: usize = 200;

impl Parser {
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].0
    }
    fn at(&self) -> usize {
        self.toks[self.pos].1
    }
    fn next(&mut self) -> Tok {
        let t = self.toks[self.pos].0.clone();
        if self.pos + 1 < self.toks.len() {
            self.pos += 1;
        }
        t
    }
    fn err<T>(&self, message: String) -> Result<T, ExprError> {
        Err(ExprError {
            message,
            at: self.at(),
        })
    }
    fn describe(t: &Tok) -> String {
        match t {
            Tok::Num(_, s) => format!("number `{s}`"),
            Tok::Name(n) => format!("name `{n}`"),
            Tok::Op(o) => format!("`{o}`"),
            Tok::LParen => "`(`".into(),
            Tok::RParen => "`)`".into(),
            Tok::Comma => "`,`".into(),
            Tok::End => "the end of the expression".into(),
        }
    }

    fn comparison(&mut self) -> Result<Expr, ExprError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return self.err(format!(
                "expression nested more than {MAX_DEPTH} levels deep"
            ));
        }
        let left = self.sum()?;
        let op = match self.peek() {
            Tok::Op("<") => CmpOp::Lt,
            Tok::Op("<=") => CmpOp::Le,
            Tok::Op(">") => CmpOp::Gt,
            Tok::Op(">=") => CmpOp::Ge,
            Tok::Op("==") => CmpOp::Eq,
            Tok::Op("!=") => CmpOp::Ne,
            _ => {
                self.depth -= 1;
                return Ok(left);
            }
        };
        self.next();
        let right = self.sum()?;
        if let Tok::Op("<" | "<=" | ">" | ">=" | "==" | "!=") = self.peek() {
            return self.err("chained comparisons (`a < b < c`) are not supported: write logical_and(a < b, b < c)".into());
        }
        self.depth -= 1;
        Ok(Expr::Cmp(op, Box::new(left), Box::new(right)))
    }

    fn sum(&mut self) -> Result<Expr, ExprError> {
        let mut left = self.product()?;
        loop {
            let op = match self.peek() {
                Tok::Op("+") => BinOp::Add,
                Tok::Op("-") => BinOp::Sub,
                _ => return Ok(left),
            };
            self.next();
            let right = self.product()?;
            left = Expr::Bin(op, Box::new(left), Box::new(right));
        }
    }

    fn product(&mut self) -> Result<Expr, ExprError> {
        let mut left = self.unary()?;
        loop {
            let op = match self.peek() {
                Tok::Op("*") => BinOp::Mul,
                Tok::Op("/") => BinOp::Div,
                _ => return Ok(left),
            };
            self.next();
            let right = self.unary()?;
            left = Expr::Bin(op, Box::new(left), Box::new(right));
        }
    }

    fn unary(&mut self) -> Result<Expr, ExprError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return self.err(format!(
                "expression nested more than {MAX_DEPTH} levels deep"
            ));
        }
        let e = match self.peek() {
            Tok::Op("-") => {
                self.next();
                Expr::Neg(Box::new(self.unary()?))
            }
            Tok::Op("+") => {
                self.next();
                self.unary()?
            }
            _ => self.power()?,
        };
        self.depth -= 1;
        Ok(e)
    }

    fn power(&mut self) -> Result<Expr, ExprError> {
        let base = self.atom()?;
        if let Tok::Op("**") = self.peek() {
            self.next();
            let exponent = self.unary()?;
            return Ok(Expr::Bin(BinOp::Pow, Box::new(base), Box::new(exponent)));
        }
        Ok(base)
    }

    fn atom(&mut self) -> Result<Expr, ExprError> {
        match self.next() {
            Tok::Num(v, t) => Ok(Expr::Num(v, t)),
            Tok::Name(n) => {
                if *self.peek() != Tok::LParen {
                    return Ok(Expr::Name(n));
                }
                self.next();
                let mut args = Vec::new();
                if *self.peek() == Tok::RParen {
                    self.next();
                    return Ok(Expr::Call(n, args));
                }
                loop {
                    args.push(self.comparison()?);
                    match self.next() {
                        Tok::Comma => {}
                        Tok::RParen => return Ok(Expr::Call(n, args)),
                        t => {
                            self.pos -= 1;
                            return self.err(format!(
                                "expected `,` or `)` in the call of `{n}`, found {}",
                                Self::describe(&t)
                            ));
                        }
                    }
                }
            }
            Tok::LParen => {
                let e = self.comparison()?;
                match self.next() {
                    Tok::RParen => Ok(e),
                    Tok::Comma => {
                        self.pos -= 1;
                        self.err("tuples (`(a, b)`) are not supported".into())
                    }
                    t => {
                        self.pos -= 1;
                        self.err(format!("expected `)`, found {}", Self::describe(&t)))
                    }
                }
            }
            t => {
                self.pos = self.pos.saturating_sub(usize::from(t != Tok::End));
                self.err(format!(
                    "expected a number, a name or `(`, found {}",
                    Self::describe(&t)
                ))
            }
        }
    }
}

/// Parses one GreenLight expression.
///
/// ```
/// use ghm::import::greenlight::expr::{parse, Expr};
/// let e = parse("-2**2").unwrap();
/// assert!(matches!(e, Expr::Neg(_)));
/// assert!(parse("a % b").unwrap_err().message.contains("`%`"));
/// ```
pub fn parse(text: &str) -> Result<Expr, ExprError> {
    let toks = tokenize(text)?;
    let mut p = Parser {
        toks,
        pos: 0,
        depth: 0,
    };
    if *p.peek() == Tok::End {
        return p.err("empty expression".into());
    }
    let e = p.comparison()?;
    if *p.peek() != Tok::End {
        let t = p.peek().clone();
        return p.err(format!(
            "unexpected {} after a complete expression",
            Parser::describe(&t)
        ));
    }
    Ok(e)
}

/// Evaluates an expression with Python's meaning (comparisons give 1 or 0), for tests and
/// for checking that a value is a plain number; `name` gives the value of a name, `call`
/// of a function call (`None`: unknown, and the result is `None`).
pub fn eval(
    e: &Expr,
    name: &dyn Fn(&str) -> Option<f64>,
    call: &dyn Fn(&str, &[f64]) -> Option<f64>,
) -> Option<f64> {
    Some(match e {
        Expr::Num(v, _) => *v,
        Expr::Name(n) => name(n)?,
        Expr::Neg(a) => -eval(a, name, call)?,
        Expr::Bin(op, a, b) => {
            let (a, b) = (eval(a, name, call)?, eval(b, name, call)?);
            match op {
                BinOp::Add => a + b,
                BinOp::Sub => a - b,
                BinOp::Mul => a * b,
                BinOp::Div => a / b,
                BinOp::Pow => a.powf(b),
            }
        }
        Expr::Cmp(op, a, b) => {
            let (a, b) = (eval(a, name, call)?, eval(b, name, call)?);
            let r = match op {
                CmpOp::Lt => a < b,
                CmpOp::Le => a <= b,
                CmpOp::Gt => a > b,
                CmpOp::Ge => a >= b,
                CmpOp::Eq => a == b,
                CmpOp::Ne => a != b,
            };
            f64::from(u8::from(r))
        }
        Expr::Call(f, args) => {
            let vals: Option<Vec<f64>> = args.iter().map(|a| eval(a, name, call)).collect();
            call(f, &vals?)?
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn num(e: &str) -> f64 {
        eval(&parse(e).unwrap(), &|_| None, &|_, _| None).unwrap()
    }

    #[test]
    fn precedence_follows_python() {
        assert_eq!(num("-2**2"), -4.0);
        assert_eq!(num("2**3**2"), 512.0);
        assert_eq!(num("2**-1"), 0.5);
        assert_eq!(num("(-2)**2"), 4.0);
        assert_eq!(num("8 / 2 / 2"), 2.0);
        assert_eq!(num("1 - 2 - 3"), -4.0);
        assert_eq!(num("2 * 3 + 4 * 5"), 26.0);
        assert_eq!(num("-3 * 2"), -6.0);
        assert_eq!(num("2 * -3"), -6.0);
        assert_eq!(num("1 + 2 < 4"), 1.0);
        assert_eq!(num("(1 < 2) * 5"), 5.0);
        assert_eq!(num("1.2e3 + 20e3 + .5 + 2.5577e-5"), 21200.5 + 2.5577e-5);
        assert_eq!(num("+4 - - 1"), 5.0);
        assert_eq!(num("3 != 3"), 0.0);
    }

    #[test]
    fn trees_have_the_expected_shape() {
        let e = parse("a * b ** c").unwrap();
        let Expr::Bin(BinOp::Mul, _, right) = &e else {
            panic!("{e:?}")
        };
        assert!(matches!(**right, Expr::Bin(BinOp::Pow, ..)));
        let e = parse("f(x, -0.5, g(y))").unwrap();
        assert_eq!(e.calls(), [("f", 3), ("g", 1)]);
        assert_eq!(e.names(), ["x", "y"]);
        assert_eq!(parse("f()").unwrap(), Expr::Call("f".into(), vec![]));
        assert_eq!(parse("1.0").unwrap(), parse("1").unwrap());
    }

    #[test]
    fn refusals_name_the_construct() {
        let cases = [
            ("np.exp(x)", "attribute"),
            ("a % b", "`%`"),
            ("a // b", "`//`"),
            ("'x'", "strings"),
            ("a < b < c", "chained"),
            ("a and b", "`and`"),
            ("a if c else b", "`if`"),
            ("x[1]", "subscripts"),
            ("f(a=1)", "keyword arguments"),
            ("1_000", "form"),
            ("0x10", "form"),
            ("(a, b)", "tuples"),
            ("a +", "expected a number"),
            ("a b", "unexpected name `b`"),
            ("(a", "expected `)`"),
            ("", "empty"),
            ("a @ b", "unexpected character `@`"),
        ];
        for (text, needle) in cases {
            let e = parse(text).unwrap_err();
            assert!(e.message.contains(needle), "{text}: {}", e.message);
        }
        let deep = format!("{}1{}", "(".repeat(500), ")".repeat(500));
        assert!(parse(&deep).unwrap_err().message.contains("nested"));
    }
}
