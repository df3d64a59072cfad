//! Size limits of one statement, counted on its tokens: brackets nested at most
//! [`MAX_NESTING`] deep and at most [`MAX_OPERATORS`] operators.
//!
//! The parser recurses on nesting (pest and the syntax tree builder), and a long chain of
//! operators is a deep syntax tree, so the limits keep any statement far from the end of
//! the stack. Comments, strings, units and the signs of exponents (`1e-3`) are not
//! operators or brackets: only tokens of expressions count.

use crate::lang::diagnostic::Diagnostic;
use crate::lang::source::Span;

/// Deepest bracket nesting one statement may have: far beyond any model.
pub const MAX_NESTING: usize = 64;
/// Most operators (and commas) one statement may have: far beyond any model.
pub const MAX_OPERATORS: usize = 1000;

/// What [`scan`] found in a statement.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Counts {
    /// The deepest bracket nesting.
    deepest: usize,
    /// Byte offset of the bracket that first reached it.
    deepest_at: usize,
    /// Operators and commas.
    operators: usize,
}

/// Rejects a statement (at byte `start` of file `file`) too deeply nested or too long to
/// parse and check safely.
pub fn too_complex(file: usize, start: usize, chunk: &str) -> Option<Diagnostic> {
    let counts = scan(chunk);
    let span = |at: usize| Span::new(file, start + at, start + at + 1);
    if counts.deepest > MAX_NESTING {
        return Some(
            Diagnostic::error(
                "E023",
                span(counts.deepest_at),
                format!(
                    "brackets nested {} deep (at most {MAX_NESTING})",
                    counts.deepest
                ),
            )
            .label("too deep")
            .help("split the expression into named parts with `let`"),
        );
    }
    if counts.operators > MAX_OPERATORS {
        return Some(
            Diagnostic::error(
                "E023",
                span(0),
                format!(
                    "statement has {} operators (at most {MAX_OPERATORS})",
                    counts.operators
                ),
            )
            .label("statement too long")
            .help("split the expression into named parts with `let`"),
        );
    }
    None
}

/// Counts the brackets and operators among the tokens of a statement.
fn scan(chunk: &str) -> Counts {
    let bytes = chunk.as_bytes();
    let at = |i: usize| bytes.get(i).copied().unwrap_or(0);
    let is_word = |b: u8| b.is_ascii_alphanumeric() || b == b'_' || b >= 0x80;
    let mut counts = Counts::default();
    let mut depth = 0usize;
    // Whether the last token was the keyword `in`: then `[` opens bounds, else a unit.
    let mut after_in = false;
    let mut i = 0;
    while i < bytes.len() {
        let b = bytes[i];
        let mut word_in = false;
        match b {
            b'#' => i = skip_to(bytes, i + 1, None),
            b'"' => i = skip_to(bytes, i + 1, Some(b'"')),
            b'[' if !after_in => i = skip_to(bytes, i + 1, Some(b']')),
            b'(' | b'[' => {
                depth += 1;
                if depth > counts.deepest {
                    counts.deepest = depth;
                    counts.deepest_at = i;
                }
                i += 1;
            }
            b')' | b']' => {
                depth = depth.saturating_sub(1);
                i += 1;
            }
            b'0'..=b'9' | b'.' => i = skip_number(bytes, i),
            b'<' | b'>' => {
                counts.operators += 1;
                i += if at(i + 1) == b'=' { 2 } else { 1 };
            }
            b'+' | b'-' | b'*' | b'/' | b'^' | b',' => {
                counts.operators += 1;
                i += 1;
            }
            _ if is_word(b) => {
                let start = i;
                while i < bytes.len() && is_word(bytes[i]) {
                    i += 1;
                }
                word_in = &bytes[start..i] == b"in";
            }
            _ => i += 1,
        }
        if !b.is_ascii_whitespace() && b != b'#' {
            after_in = word_in;
        }
    }
    counts
}

/// The offset after a comment (`close` = `None`: up to the line's end), a string or a
/// unit (past `close`, or up to the line's end if it is missing).
fn skip_to(bytes: &[u8], mut i: usize, close: Option<u8>) -> usize {
    while i < bytes.len() && bytes[i] != b'\n' && bytes[i] != b'\r' {
        if Some(bytes[i]) == close {
            return i + 1;
        }
        i += 1;
    }
    i
}

/// The offset after a number starting at `i`: digits, a fraction and an exponent, whose
/// sign is part of the number.
fn skip_number(bytes: &[u8], mut i: usize) -> usize {
    let at = |i: usize| bytes.get(i).copied().unwrap_or(0);
    while at(i).is_ascii_digit() || at(i) == b'.' {
        i += 1;
    }
    if matches!(at(i), b'e' | b'E') {
        let sign = usize::from(matches!(at(i + 1), b'+' | b'-'));
        if at(i + 1 + sign).is_ascii_digit() {
            i += 1 + sign;
            while at(i).is_ascii_digit() {
                i += 1;
            }
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_tokens_only() {
        let c = scan("der x = (a + 1e-3) * [b] # (((--- \"\n + f(x, y) \"((--\" [kg m^-2]");
        // `in`-less `[b]` and `[kg m^-2]` are units; the comment and string are skipped.
        assert_eq!((c.deepest, c.operators), (1, 4));
        let c = scan("input u [W m^-2] in [0, (1)] rate 1e+2");
        assert_eq!((c.deepest, c.deepest_at, c.operators), (2, 24, 1));
        let c = scan("soft y <= 2 weight 1 plan in\n  [0, 1]");
        assert_eq!((c.deepest, c.operators), (1, 2));
    }
}
