//! Source files and byte spans, and the mapping from a byte offset to `line:column`.

use crate::lang::text::normalize;
use std::path::{Path, PathBuf};

/// A half-open byte range `[start, end)` in one source file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Span {
    /// Index of the file in the [`SourceMap`].
    pub file: usize,
    /// Byte offset of the first byte.
    pub start: usize,
    /// Byte offset one past the last byte.
    pub end: usize,
}

impl Span {
    /// The bytes `start..end` of file `file` (its index in the [`SourceMap`]).
    pub fn new(file: usize, start: usize, end: usize) -> Span {
        Span { file, start, end }
    }

    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span::new(
            self.file,
            self.start.min(other.start),
            self.end.max(other.end),
        )
    }
}

/// One loaded `.ghm` file.
#[derive(Debug, Clone)]
pub struct SourceFile {
    /// The path as the loader was given it (for an import, the importing file's folder
    /// joined with the import path).
    pub path: PathBuf,
    /// The path as the user should see it in messages.
    pub display: String,
    /// The whole file as read, without a byte-order mark and with `\n` line endings
    /// (see [`normalize`]).
    pub text: String,
    line_starts: Vec<usize>,
}

impl SourceFile {
    /// A file read from `path` with contents `text` (normalised: no byte-order mark,
    /// `\n` line endings), its lines indexed.
    pub fn new(path: &Path, text: String) -> SourceFile {
        let text = if text.starts_with('\u{FEFF}') || text.contains('\r') {
            normalize(&text)
        } else {
            text
        };
        let line_starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        SourceFile {
            display: path.display().to_string(),
            path: path.to_path_buf(),
            text,
            line_starts,
        }
    }

    /// 1-based line and column (in characters) of a byte offset.
    ///
    /// ```
    /// use ghm::lang::source::SourceFile;
    ///
    /// let file = SourceFile::new("m.ghm".as_ref(), "state t [°C] = 1\nder t = -t\n".into());
    /// assert_eq!(file.line_col(0), (1, 1));
    /// assert_eq!(file.line_col(file.text.find('=').unwrap()), (1, 14)); // `°` is one column
    /// assert_eq!(file.line_col(file.text.find("der").unwrap()), (2, 1));
    /// ```
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let line = match self.line_starts.binary_search(&offset) {
            Ok(i) => i,
            Err(i) => i - 1,
        };
        let start = self.line_starts[line];
        let end = offset.min(self.text.len());
        let col = self
            .text
            .get(start..end)
            .map_or(1, |s| s.chars().count() + 1);
        (line + 1, col)
    }
}

/// All files of one model (the main file and what it imports), indexed by [`Span::file`].
#[derive(Debug, Clone, Default)]
pub struct SourceMap {
    /// The files in load order: the main file first, then each import as it is reached.
    pub files: Vec<SourceFile>,
}

impl SourceMap {
    /// Adds a file and returns its index, for [`Span::file`].
    pub fn add(&mut self, file: SourceFile) -> usize {
        self.files.push(file);
        self.files.len() - 1
    }

    /// `file:line:col` of the start of a span.
    ///
    /// ```
    /// use ghm::lang::source::{SourceFile, SourceMap, Span};
    ///
    /// let mut sources = SourceMap::default();
    /// let id = sources.add(SourceFile::new("m.ghm".as_ref(), "sample 60\nstate x = 1\n".into()));
    /// assert_eq!(sources.location(Span::new(id, 16, 17)), "m.ghm:2:7");
    /// assert_eq!(sources.location(Span::new(id + 1, 0, 1)), "<unknown>");
    /// ```
    pub fn location(&self, span: Span) -> String {
        match self.files.get(span.file) {
            Some(f) => {
                let (l, c) = f.line_col(span.start);
                format!("{}:{}:{}", f.display, l, c)
            }
            None => "<unknown>".to_string(),
        }
    }
}
