//! Property tests of the `.ghm` front end: whatever the text, `ghm::lang::load_str` returns
//! `Ok` or `Err` (never panics), a failure has at least one error, and every diagnostic
//! renders and points inside the text it talks about.
//!
//! Inputs: random strings, random byte-level mutations of `models/lettuce.ghm`, every
//! prefix of that file, and token soups built from the language's own vocabulary. Sizes are
//! kept modest (no deeply nested expressions), so the file runs in seconds in the dev
//! profile; set `PROPTEST_CASES` for a longer hunt.

use ghm::lang::diagnostic::{render, Diagnostic};
use ghm::lang::parse::STATEMENT_KEYWORDS;
use ghm::lang::source::SourceMap;
use ghm::lang::{load_str, CheckFailure, Model};
use proptest::prelude::*;
use proptest::sample::{select, Index};

const LETTUCE: &str = include_str!("../models/lettuce.ghm");

/// Every diagnostic points at a real place: a known file, a range inside its text, on
/// character boundaries. Rendering must not panic either.
fn assert_well_placed(sources: &SourceMap, diagnostics: &[Diagnostic]) {
    for d in diagnostics {
        let file = sources.files.get(d.span.file).unwrap_or_else(|| {
            panic!(
                "{} points into file {} of {}",
                d.code,
                d.span.file,
                sources.files.len()
            )
        });
        let text = &file.text;
        assert!(
            d.span.start <= d.span.end && d.span.end <= text.len(),
            "{} span {:?} outside a text of {} bytes",
            d.code,
            d.span,
            text.len()
        );
        assert!(
            text.is_char_boundary(d.span.start) && text.is_char_boundary(d.span.end),
            "{} span {:?} splits a character",
            d.code,
            d.span
        );
    }
    let _ = render(sources, diagnostics);
}

/// Loads `text` and checks what came back. Returns whether it loaded.
fn load_checked(text: &str) -> bool {
    let result: Result<Model, CheckFailure> = load_str("prop.ghm", text);
    match result {
        Ok(model) => {
            assert!(model.warnings.iter().all(|w| !w.is_error()));
            assert_well_placed(&model.sources, &model.warnings);
            true
        }
        Err(failure) => {
            assert!(
                failure.error_count() >= 1,
                "a failure without errors: {:?}",
                failure.diagnostics
            );
            assert_well_placed(&failure.sources, &failure.diagnostics);
            let _ = failure.render();
            false
        }
    }
}

#[test]
fn lettuce_loads() {
    assert!(load_checked(LETTUCE));
}

#[test]
fn every_prefix_of_lettuce() {
    let mut loaded = 0;
    for (i, _) in LETTUCE.char_indices() {
        if load_checked(&LETTUCE[..i]) {
            loaded += 1;
        }
    }
    // Everything after the last `der` is optional, so some prefixes load; most do not.
    assert!(loaded > 0, "no prefix loaded");
}

#[test]
fn every_line_dropped_from_lettuce() {
    let lines: Vec<&str> = LETTUCE.split_inclusive('\n').collect();
    for skip in 0..lines.len() {
        let text: String = lines
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != skip)
            .map(|(_, l)| *l)
            .collect();
        load_checked(&text);
    }
}

// ---- mutations -------------------------------------------------------------------------

/// One edit of the lettuce file's bytes.
#[derive(Debug, Clone)]
enum Mutation {
    Delete(Index, usize),
    Insert(Index, Vec<u8>),
    Replace(Index, u8),
    Truncate(Index),
    SwapLines(Index, Index),
    DuplicateLine(Index),
}

/// Bytes that mean something to the language, and any byte at all.
fn interesting_byte() -> impl Strategy<Value = u8> {
    prop_oneof![
        3 => select(b"()[]=,+-*/^<>#\"\n\t .0123456789eE_xyz".to_vec()),
        1 => any::<u8>(),
    ]
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<Index>(), 1..40usize).prop_map(|(i, n)| Mutation::Delete(i, n)),
        (
            any::<Index>(),
            prop::collection::vec(interesting_byte(), 1..6)
        )
            .prop_map(|(i, b)| Mutation::Insert(i, b)),
        (any::<Index>(), interesting_byte()).prop_map(|(i, b)| Mutation::Replace(i, b)),
        any::<Index>().prop_map(Mutation::Truncate),
        (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        any::<Index>().prop_map(Mutation::DuplicateLine),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let len = bytes.len();
    match m {
        Mutation::Delete(i, n) if len > 0 => {
            let at = i.index(len);
            let end = (at + n).min(len);
            bytes.drain(at..end);
        }
        Mutation::Insert(i, b) => {
            let at = i.index(len + 1);
            bytes.splice(at..at, b.iter().copied());
        }
        Mutation::Replace(i, b) if len > 0 => bytes[i.index(len)] = *b,
        Mutation::Truncate(i) => bytes.truncate(i.index(len + 1)),
        Mutation::SwapLines(a, b) => {
            let mut lines: Vec<Vec<u8>> =
                bytes.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect();
            let n = lines.len();
            lines.swap(a.index(n), b.index(n));
            *bytes = lines.join(&b'\n');
        }
        Mutation::DuplicateLine(a) => {
            let mut lines: Vec<Vec<u8>> =
                bytes.split(|&c| c == b'\n').map(<[u8]>::to_vec).collect();
            let k = a.index(lines.len());
            let line = lines[k].clone();
            lines.insert(k, line);
            *bytes = lines.join(&b'\n');
        }
        _ => {}
    }
}

// ---- token soups -----------------------------------------------------------------------

/// The other keywords.
const KEYWORDS: &[&str] = &[
    "uncertain",
    "integrator",
    "rate",
    "start",
    "column",
    "value",
    "source",
    "weight",
    "plan",
    "substeps",
    "next",
    "in",
];

const PUNCTUATION: &[&str] = &[
    "+", "-", "*", "/", "^", "<", "<=", ">", ">=", "=", "(", ")", "[", "]", ",", "\"", "#",
];

const NUMBERS: &[&str] = &[
    "0", "1", "2", "-1", "0.5", ".5", "1.", "1e3", "1e-3", "2.5E+2", "1e999", "1e-999", "0.0035",
    "1800", "1000", "1001",
];

const NAMES: &[&str] = &[
    "x",
    "y",
    "u",
    "d",
    "p",
    "t",
    "temp",
    "temp_air",
    "dry_weight",
    "heating",
    "crop",
    "co2_ppm",
    "rh_pct",
    "price_crop",
    "step_s",
    "exp",
    "log",
    "ln",
    "sqrt",
    "abs",
    "tanh",
    "sin",
    "cos",
    "min",
    "max",
    "pow",
    "if",
    "rk4",
    "euler",
    "season",
    "step",
    "all",
    "marked",
    "redraw",
    "spread",
    "params",
    "reward",
    "soft",
    "_",
    "é",
];

const PIECES: &[&str] = &[
    "\n",
    "\n",
    "\n",
    "\"a description\"",
    "[s]",
    "[min]",
    "[h]",
    "[kg m^-2]",
    "[°C]",
    "# comment\n",
    "\"lettuce.ghm\"",
    "\"\"",
    "[]",
];

fn token() -> impl Strategy<Value = &'static str> {
    prop_oneof![
        2 => select(STATEMENT_KEYWORDS),
        2 => select(KEYWORDS),
        4 => select(PUNCTUATION),
        2 => select(NUMBERS),
        4 => select(NAMES),
        2 => select(PIECES),
    ]
}

fn separator() -> impl Strategy<Value = &'static str> {
    prop_oneof![6 => Just(" "), 1 => Just(""), 1 => Just("\n"), 1 => Just("\t")]
}

fn soup(tokens: usize) -> impl Strategy<Value = String> {
    prop::collection::vec((token(), separator()), 0..tokens).prop_map(|parts| {
        parts
            .into_iter()
            .flat_map(|(t, s)| [t, s])
            .collect::<String>()
    })
}

/// Lines that each start with a statement keyword, so that more of them get past the
/// parser and reach the checker.
fn statements() -> impl Strategy<Value = String> {
    let keyword = select(STATEMENT_KEYWORDS);
    let line = (prop::option::of(Just("override ")), keyword, soup(12))
        .prop_map(|(o, k, rest)| format!("{}{k} {rest}\n", o.unwrap_or("")));
    prop::collection::vec(line, 0..16).prop_map(|lines| lines.concat())
}

// ---- well-formed statements -----------------------------------------------------------

/// A small pool of names, so that declarations collide, refer to each other and form
/// cycles.
const POOL: &[&str] = &["x", "y", "u", "d", "p", "a", "b", "t", "exp", "temp"];

const FUNCTIONS: &[&str] = &[
    "exp", "log", "ln", "sqrt", "abs", "tanh", "sin", "cos", "min", "max", "pow", "if", "exq",
];

const OPERATORS: &[&str] = &["+", "-", "*", "/", "^", "<", "<=", ">", ">="];

const UNITS: &[&str] = &["[s]", "[min]", "[h]", "[kg m^-2]", "[°C]", "[]"];

fn name() -> impl Strategy<Value = &'static str> + Clone {
    select(POOL)
}

/// A random expression over the pool, at most a few levels deep.
fn expr() -> impl Strategy<Value = String> + Clone {
    let leaf = prop_oneof![
        name().prop_map(str::to_string),
        select(NUMBERS).prop_map(str::to_string),
    ];
    leaf.prop_recursive(4, 24, 3, |inner| {
        prop_oneof![
            inner.clone().prop_map(|e| format!("-{e}")),
            inner.clone().prop_map(|e| format!("({e})")),
            (inner.clone(), select(OPERATORS), inner.clone())
                .prop_map(|(a, op, b)| format!("{a} {op} {b}")),
            (
                select(FUNCTIONS),
                prop::collection::vec(inner.clone(), 0..4)
            )
                .prop_map(|(f, args)| format!("{f}({})", args.join(", "))),
            name().prop_map(|n| format!("next({n})")),
        ]
    })
}

fn band() -> impl Strategy<Value = String> + Clone {
    prop_oneof![
        (expr(), expr()).prop_map(|(a, b)| format!("in [{a}, {b}]")),
        expr().prop_map(|e| format!("<= {e}")),
        expr().prop_map(|e| format!(">= {e}")),
    ]
}

fn opt(s: impl Strategy<Value = String> + Clone) -> impl Strategy<Value = String> + Clone {
    prop::option::of(s).prop_map(Option::unwrap_or_default)
}

/// One statement that usually parses, so that the checker sees it.
fn statement() -> impl Strategy<Value = String> {
    let unit = opt(select(UNITS).prop_map(|u| format!(" {u}")));
    let declaration = prop_oneof![
        (
            select(&["param", "const", "state", "let", "output", "reward", "cost", "terminal"][..]),
            name(),
            unit.clone(),
            expr(),
            opt(Just(" uncertain".to_string()))
        )
            .prop_map(|(k, n, u, e, x)| {
                let extra = if k == "param" { x } else { String::new() };
                format!("{k} {n}{u} = {e}{extra}")
            }),
        (
            name(),
            opt((expr(), expr()).prop_map(|(a, b)| format!(" in [{a}, {b}]"))),
            opt(expr().prop_map(|e| format!(" rate {e}"))),
            opt(expr().prop_map(|e| format!(" start {e}")))
        )
            .prop_map(|(n, b, r, s)| format!("input {n}{b}{r}{s}")),
        (
            name(),
            opt(Just(" column \"c\"".to_string())),
            opt(expr().prop_map(|e| format!(" value {e}")))
        )
            .prop_map(|(n, c, v)| format!("disturbance {n}{c}{v}")),
        (name(), expr()).prop_map(|(n, e)| format!("der {n} = {e}")),
        (
            expr(),
            opt(select(&["[s]", "[min]", "[h]", "[d]"][..]).prop_map(|u| format!(" {u}"))),
            opt(select(&["rk4", "euler", "heun"][..]).prop_map(|i| format!(" integrator {i}"))),
            opt(expr().prop_map(|e| format!(" substeps {e}"))),
            opt(expr().prop_map(|e| format!(" plan substeps {e}")))
        )
            .prop_map(|(e, u, i, n, p)| format!("sample {e}{u}{i}{n}{p}")),
        (
            name(),
            band(),
            expr(),
            opt(expr().prop_map(|e| format!(", {e}"))),
            opt(band().prop_map(|b| format!(" plan {b}")))
        )
            .prop_map(|(n, b, w, w2, p)| format!("soft {n} {b} weight {w}{w2}{p}")),
    ];
    prop_oneof![
        8 => declaration.clone(),
        2 => declaration.prop_map(|d| format!("override {d}")),
        1 => (select(&["reward", "cost", "soft", "terminal"][..]), name()).prop_map(|(k, n)| format!("drop {k} {n}")),
        1 => (select(&["season", "step", "daily"][..]), select(&["0", "0.5", "1", "2"][..]), select(&["marked", "all", "some"][..]))
            .prop_map(|(r, s, p)| format!("uncertainty redraw = {r}, spread = {s}, params = {p}")),
        1 => select(&["import \"models/lettuce.ghm\"", "import \"missing.ghm\"", "model m \"d\""][..]).prop_map(str::to_string),
    ]
}

/// A model of well-formed statements, mostly wrong in meaning.
fn model() -> impl Strategy<Value = String> {
    prop::collection::vec(statement(), 0..14)
        .prop_map(|lines| lines.into_iter().map(|l| l + "\n").collect())
}

/// 256 cases per property, or `PROPTEST_CASES` for a longer hunt.
fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(256)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

    #[test]
    fn random_unicode_strings(text in any::<String>()) {
        load_checked(&text);
    }

    #[test]
    fn random_printable_text(text in "[ -~\t\n°é×]{0,300}") {
        load_checked(&text);
    }

    #[test]
    fn mutated_lettuce(edits in prop::collection::vec(mutation(), 1..8)) {
        let mut bytes = LETTUCE.as_bytes().to_vec();
        for m in &edits {
            apply(&mut bytes, m);
        }
        load_checked(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn lettuce_with_a_token_soup_inserted(at in any::<Index>(), inserted in soup(20)) {
        let mut cut = at.index(LETTUCE.len() + 1);
        while !LETTUCE.is_char_boundary(cut) {
            cut -= 1;
        }
        let text = format!("{}{inserted}{}", &LETTUCE[..cut], &LETTUCE[cut..]);
        load_checked(&text);
    }

    #[test]
    fn token_soup(text in soup(80)) {
        load_checked(&text);
    }

    #[test]
    fn statement_soup(text in statements()) {
        load_checked(&text);
    }

    #[test]
    fn well_formed_statements(text in model()) {
        load_checked(&text);
    }
}
