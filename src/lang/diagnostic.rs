//! Diagnostics: errors and warnings about a `.ghm` file, each with a code, a span, a
//! message and a hint on what to do, rendered as `file:line:col` with the source line and
//! a caret (by `codespan-reporting`); and [`CheckFailure`], the diagnostics of a model
//! that did not load with the sources they point into.

use crate::lang::source::{SourceMap, Span};
use codespan_reporting::diagnostic::{Diagnostic as CsDiagnostic, Label};
use codespan_reporting::files::SimpleFiles;
use codespan_reporting::term;

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
        render(&self.sources, &self.diagnostics)
    }

    /// The number of errors (warnings are not counted).
    pub fn error_count(&self) -> usize {
        self.diagnostics.iter().filter(|d| d.is_error()).count()
    }
}

/// How bad a diagnostic is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    /// Reported, but the model still loads (codes `W…`).
    Warning,
    /// Stops the model from loading (codes `E…`).
    Error,
}

/// One message about the model source.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// A stable code, e.g. `E003`, documented in `docs/language.md`.
    pub code: &'static str,
    /// The headline, e.g. ``unknown name `heatng` ``.
    pub message: String,
    /// The place the caret points at.
    pub span: Span,
    /// Short text under the caret.
    pub label: String,
    /// Secondary places, e.g. the first declaration of a duplicate.
    pub related: Vec<(Span, String)>,
    /// What to do about it.
    pub help: Option<String>,
}

impl Diagnostic {
    /// An error at `span`, with no label, help or related places yet.
    pub fn error(code: &'static str, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            code,
            message: message.into(),
            span,
            label: String::new(),
            related: Vec::new(),
            help: None,
        }
    }

    /// A warning at `span`, with no label, help or related places yet.
    pub fn warning(code: &'static str, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Warning,
            ..Diagnostic::error(code, span, message)
        }
    }

    /// Sets the short text under the caret.
    pub fn label(mut self, label: impl Into<String>) -> Diagnostic {
        self.label = label.into();
        self
    }

    /// Sets what to do about it.
    pub fn help(mut self, help: impl Into<String>) -> Diagnostic {
        self.help = Some(help.into());
        self
    }

    /// Adds a secondary place with its text.
    pub fn related(mut self, span: Span, text: impl Into<String>) -> Diagnostic {
        self.related.push((span, text.into()));
        self
    }

    /// Whether it is an error (one error stops the model from loading).
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

/// Renders diagnostics as plain text (no colour): `error[E001]: ...` followed by
/// `┌─ file:line:col`, the source line and a caret.
///
/// ```
/// use ghm::lang::diagnostic::{render, Diagnostic};
/// use ghm::lang::source::{SourceFile, SourceMap, Span};
///
/// let mut sources = SourceMap::default();
/// let text = "sample 60 [s]\nstate x = 1\nder x = -y\n";
/// let file = sources.add(SourceFile::new("m.ghm".as_ref(), text.into()));
/// let at = text.find('y').unwrap();
/// let d = Diagnostic::error("E003", Span::new(file, at, at + 1), "unknown name `y`")
///     .label("not declared")
///     .help("declare it, or fix the spelling");
/// let message = render(&sources, &[d]);
/// assert!(message.starts_with("error[E003]: unknown name `y`"));
/// assert!(message.contains("┌─ m.ghm:3:10"));
/// assert!(message.contains("3 │ der x = -y"));
/// assert!(message.contains("^ not declared"));
/// assert!(message.contains("= help: declare it, or fix the spelling"));
/// ```
pub fn render(sources: &SourceMap, diagnostics: &[Diagnostic]) -> String {
    let mut files = SimpleFiles::new();
    for f in &sources.files {
        files.add(f.display.clone(), f.text.clone());
    }
    let config = term::Config::default();
    let mut out = String::new();
    for d in diagnostics {
        let mut labels = vec![
            Label::primary(d.span.file, d.span.start..d.span.end).with_message(d.label.clone())
        ];
        for (span, text) in &d.related {
            labels.push(Label::secondary(span.file, span.start..span.end).with_message(text));
        }
        let base = match d.severity {
            Severity::Error => CsDiagnostic::error(),
            Severity::Warning => CsDiagnostic::warning(),
        };
        let mut cs = base
            .with_code(d.code)
            .with_message(&d.message)
            .with_labels(labels);
        if let Some(help) = &d.help {
            cs = cs.with_notes(vec![format!("help: {help}")]);
        }
        if term::emit_to_string(&mut out, &config, &files, &cs).is_err() {
            // A span outside its file: fall back to the bare location.
            out.push_str(&format!("{}: {}\n", sources.location(d.span), d.message));
        }
    }
    out
}

/// Levenshtein distance, for "did you mean" hints.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The closest of `candidates` to `name`, if it is close enough to be a likely typo.
///
/// ```
/// use ghm::lang::diagnostic::did_you_mean;
///
/// let names = ["heating", "ventilation", "co2_supply"];
/// assert_eq!(did_you_mean("heatng", names.into_iter()).as_deref(), Some("heating"));
/// assert_eq!(did_you_mean("pump", names.into_iter()), None);
/// ```
pub fn did_you_mean<'a>(name: &str, candidates: impl Iterator<Item = &'a str>) -> Option<String> {
    let limit = (name.chars().count() / 3).max(1) + 1;
    candidates
        .map(|c| (edit_distance(name, c), c))
        .filter(|(d, _)| *d <= limit)
        .min()
        .map(|(_, c)| c.to_string())
}
