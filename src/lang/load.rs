//! Loading a model: reading the main file and, in place of each `import`, the files it
//! imports; the entry points [`load`] and [`load_str`], which give a [`CheckFailure`] for
//! a model with errors.

use crate::lang::ast::*;
use crate::lang::check::check;
use crate::lang::diagnostic::{CheckFailure, Diagnostic};
use crate::lang::model::Model;
use crate::lang::parse::parse;
use crate::lang::source::{SourceFile, SourceMap, Span};
use crate::lang::text::{decode, Decoded};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    let statements = match std::fs::read(path) {
        Ok(bytes) => loader.file(path, decode(bytes)),
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
    check(loader.sources, loader.diagnostics, statements)
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
    let text = Decoded {
        text: text.to_string(),
        invalid: None,
    };
    let statements = loader.file(Path::new(name), text);
    check(loader.sources, loader.diagnostics, statements)
}

/// Checks a model whose files are given in memory, by path: `root` is the main file, and
/// each import is looked up as [`load`] would find it on disk (the importing file's folder
/// joined with the import path). How a compiled controller loads the model it carries.
///
/// ```
/// use std::collections::BTreeMap;
/// use std::path::{Path, PathBuf};
///
/// let mut files = BTreeMap::new();
/// files.insert(PathBuf::from("plant.ghm"), "import \"common.ghm\"\nder x = -x / tau\n".to_string());
/// files.insert(PathBuf::from("common.ghm"), "sample 1 [s]\nstate x [m] = 1\nparam tau [s] = 10\n".to_string());
/// let model = ghm::lang::load_files(Path::new("plant.ghm"), &files).map_err(|e| e.render()).unwrap();
/// assert_eq!(model.states[0].info.name, "x");
/// assert_eq!(model.sources.files.len(), 2);
/// ```
pub fn load_files(root: &Path, files: &BTreeMap<PathBuf, String>) -> Result<Model, CheckFailure> {
    let mut loader = Loader {
        memory: Some(files),
        ..Loader::default()
    };
    let statements = match files.get(root) {
        Some(text) => loader.file(root, decode(text.clone().into_bytes())),
        None => {
            return Err(CheckFailure {
                sources: SourceMap::default(),
                diagnostics: vec![Diagnostic::error(
                    "E009",
                    Span::default(),
                    format!("no model file `{}` among the files given", root.display()),
                )],
            })
        }
    };
    check(loader.sources, loader.diagnostics, statements)
}

#[derive(Default)]
struct Loader<'a> {
    sources: SourceMap,
    diagnostics: Vec<Diagnostic>,
    stack: Vec<PathBuf>,
    /// The files by path, where they are given in memory ([`load_files`]); `None`: the
    /// file system.
    memory: Option<&'a BTreeMap<PathBuf, String>>,
}

impl Loader<'_> {
    /// A path as the import-cycle check compares it: canonical on disk, as given in memory.
    fn identity(&self, path: &Path) -> PathBuf {
        match self.memory {
            Some(_) => path.to_path_buf(),
            None => path.canonicalize().unwrap_or_else(|_| path.to_path_buf()),
        }
    }

    /// The bytes of an imported file.
    fn read(&self, path: &Path) -> std::io::Result<Vec<u8>> {
        match self.memory {
            Some(files) => files
                .get(path)
                .map(|text| text.clone().into_bytes())
                .ok_or_else(|| std::io::Error::from(std::io::ErrorKind::NotFound)),
            None => std::fs::read(path),
        }
    }

    /// Parses one file and, in place of each `import`, the statements of the imported file.
    /// A file that is not UTF-8 is an error at its first bad byte, and the rest of it (the
    /// bad bytes replaced) is still parsed, so that its other errors are reported too.
    fn file(&mut self, path: &Path, text: Decoded) -> Vec<Statement> {
        let id = self.sources.add(SourceFile::new(path, text.text));
        if let Some(bad) = text.invalid {
            let at = bad.normalized_offset;
            let display = &self.sources.files[id].display;
            self.diagnostics.push(
                Diagnostic::error(
                    "E024",
                    Span::new(id, at, at + '\u{FFFD}'.len_utf8()),
                    format!(
                        "`{display}` is not UTF-8 text: byte {} (0x{:02X}) is not UTF-8",
                        bad.offset, bad.byte
                    ),
                )
                .label("not UTF-8")
                .help("save the file as UTF-8 (editors offer it as an encoding when saving)"),
            );
        }
        let canonical = self.identity(path);
        self.stack.push(canonical);
        let (parsed, diags) = parse(id, &self.sources.files[id].text);
        self.diagnostics.extend(diags);
        let mut out = Vec::new();
        for s in parsed {
            if let Stmt::Import { path: rel, span } = &s.stmt {
                let target = path.parent().unwrap_or(Path::new("")).join(rel);
                let canonical = self.identity(&target);
                if self.stack.contains(&canonical) {
                    self.diagnostics.push(
                        Diagnostic::error("E020", *span, format!("import cycle: `{rel}` imports itself, directly or through other files"))
                            .label("imported again here")
                            .help("remove one of the imports in the cycle"),
                    );
                    continue;
                }
                match self.read(&target) {
                    Ok(bytes) => out.extend(self.file(&target, decode(bytes))),
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
