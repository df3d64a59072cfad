//! Reading GreenLight's model files and resolving them into one list of variables, as
//! GreenLight 2.0.5 does (`docs/import.md` has the rules):
//!
//! * A file with a top-level `processing_order` is read through that list only: a string
//!   ending in `.json` is another file, relative to the folder of the file holding the
//!   list (`/` or `\` as separator), read the same way; a string ending in `.csv` is a
//!   weather file (recorded); a dict is a component applied directly; a string without
//!   an extension is ignored.
//! * Inside a component, any dict with a key `type` or `definition` is a variable named
//!   by its key (still searched for nested variables); other dicts group variables, and
//!   their path names the section the variable is written in. A dict named `options`
//!   holds options (ignored here). A name declared twice in one component is an error, as
//!   is a duplicate JSON key.
//! * A variable declared again in a later component is changed field by field:
//!   `definition`, `unit` and `init` when given, `description` when not empty,
//!   `reference` always (a missing one clears it), `type` added to the types it had (the
//!   last one given is the one the importer uses).

use crate::import::ImportError;
use serde::de::{Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// A JSON value with object keys in file order (duplicates refused while reading).
#[derive(Debug, Clone, PartialEq)]
pub enum Node {
    /// `null`
    Null,
    /// `true`/`false`
    Bool(bool),
    /// A number, as text.
    Number(String),
    /// A string.
    Str(String),
    /// An array.
    List(Vec<Node>),
    /// An object, keys in order.
    Map(Vec<(String, Node)>),
}

impl Node {
    /// The value of `key` in an object.
    pub fn get(&self, key: &str) -> Option<&Node> {
        match self {
            Node::Map(entries) => entries.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    /// A string or a number as text (GreenLight's fields are strings; numbers are taken
    /// as written).
    fn text(&self) -> Option<String> {
        match self {
            Node::Str(s) => Some(s.clone()),
            Node::Number(n) => Some(n.clone()),
            _ => None,
        }
    }
}

impl<'de> Deserialize<'de> for Node {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NodeVisitor)
    }
}

struct NodeVisitor;

impl<'de> Visitor<'de> for NodeVisitor {
    type Value = Node;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_unit<E>(self) -> Result<Node, E> {
        Ok(Node::Null)
    }
    fn visit_bool<E>(self, v: bool) -> Result<Node, E> {
        Ok(Node::Bool(v))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Node, E> {
        Ok(Node::Number(v.to_string()))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Node, E> {
        Ok(Node::Number(v.to_string()))
    }
    fn visit_f64<E>(self, v: f64) -> Result<Node, E> {
        Ok(Node::Number(v.to_string()))
    }
    fn visit_str<E>(self, v: &str) -> Result<Node, E> {
        Ok(Node::Str(v.to_string()))
    }
    fn visit_string<E>(self, v: String) -> Result<Node, E> {
        Ok(Node::Str(v))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Node, A::Error> {
        let mut out = Vec::new();
        while let Some(v) = seq.next_element()? {
            out.push(v);
        }
        Ok(Node::List(out))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Node, A::Error> {
        let mut out: Vec<(String, Node)> = Vec::new();
        while let Some((k, v)) = map.next_entry::<String, Node>()? {
            if out.iter().any(|(seen, _)| *seen == k) {
                return Err(serde::de::Error::custom(format!("duplicate key `{k}`")));
            }
            out.push((k, v));
        }
        Ok(Node::Map(out))
    }
}

/// GreenLight's kinds of variable (`type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `state`: `definition` is the derivative per second, `init` the initial value.
    State,
    /// `const`: a constant expression (it may read other constants).
    Const,
    /// `aux`: an algebraic expression.
    Aux,
    /// `input`: an exogenous input with a default `definition`.
    Input,
    /// `function`: the key is the signature, the definition the body.
    Function,
    /// `time`: the name of the time axis.
    Time,
}

impl Kind {
    fn parse(s: &str) -> Option<Kind> {
        Some(match s {
            "state" => Kind::State,
            "const" => Kind::Const,
            "aux" => Kind::Aux,
            "input" => Kind::Input,
            "function" => Kind::Function,
            "time" => Kind::Time,
            _ => return None,
        })
    }

    /// The word GreenLight writes.
    pub fn word(self) -> &'static str {
        match self {
            Kind::State => "state",
            Kind::Const => "const",
            Kind::Aux => "aux",
            Kind::Input => "input",
            Kind::Function => "function",
            Kind::Time => "time",
        }
    }
}

/// One resolved variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Its name (for a function, the name before the parentheses).
    pub name: String,
    /// The last type given.
    pub kind: Kind,
    /// Every type ever given, in order (GreenLight keeps the name in each type's set).
    pub kinds: Vec<Kind>,
    /// The definition (the derivative of a state, a function's body); a variable declared
    /// without one has its own name.
    pub definition: String,
    /// The initial value of a state.
    pub init: Option<String>,
    /// The unit, if one was given.
    pub unit: Option<String>,
    /// The description (`""` if none).
    pub description: String,
    /// The reference of the last declaration (`""` if none).
    pub reference: String,
    /// A function's parameters.
    pub params: Vec<String>,
    /// The file (relative to the main file's folder) and group path of its first
    /// declaration: the section it is written in.
    pub group: String,
    /// Files (relative) that changed it after its first declaration.
    pub changed_by: Vec<String>,
    /// The file (relative to the main file's folder) its definition comes from, for
    /// messages.
    pub definition_from: String,
}

/// A resolved GreenLight model.
#[derive(Debug, Clone, Default)]
pub struct Resolved {
    /// The variables in order of first declaration.
    pub vars: Vec<Variable>,
    /// The model files read, in order (the main file first).
    pub files: Vec<PathBuf>,
    /// Weather (`.csv`) files named in a `processing_order`.
    pub csv_files: Vec<PathBuf>,
    /// Entries of a `processing_order` that were ignored (strings without a `.json` or
    /// `.csv` extension).
    pub ignored: Vec<String>,
    /// The main file's `About`/`about` text, if any.
    pub about: Option<String>,
}

impl Resolved {
    /// The variable called `name`.
    pub fn get(&self, name: &str) -> Option<&Variable> {
        self.vars.iter().find(|v| v.name == name)
    }
}

/// Files may include each other at most this deep (a file including itself is refused
/// by the stack check, this is a backstop).
const MAX_FILE_DEPTH: usize = 32;

/// A group path and the entries of its dict still to visit.
type Frame = (Vec<String>, std::vec::IntoIter<(String, Node)>);

struct Resolver {
    out: Resolved,
    index: HashMap<String, usize>,
    root_dir: PathBuf,
    stack: Vec<PathBuf>,
}

/// Reads `main` (a GreenLight model `.json`) and everything its `processing_order` names.
pub fn resolve(main: &Path) -> Result<Resolved, ImportError> {
    let root_dir = main.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut r = Resolver {
        out: Resolved::default(),
        index: HashMap::new(),
        root_dir,
        stack: Vec::new(),
    };
    let node = read_json(main)?;
    r.out.about = about(&node);
    r.file(main, node)?;
    Ok(r.out)
}

fn about(node: &Node) -> Option<String> {
    let Node::Map(entries) = node else {
        return None;
    };
    for (k, v) in entries {
        if k.eq_ignore_ascii_case("about") {
            return v.text();
        }
        if k.eq_ignore_ascii_case("info") {
            if let Some(a) = about(v) {
                return Some(a);
            }
        }
    }
    None
}

/// Reads one JSON file with keys in order; a duplicate key is an error.
pub fn read_json(path: &Path) -> Result<Node, ImportError> {
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut de = serde_json::Deserializer::from_slice(&bytes);
    let node = Node::deserialize(&mut de).and_then(|n| de.end().map(|()| n));
    node.map_err(|e| ImportError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// A `processing_order` path with `/` or `\` separators, relative to `dir` unless absolute.
fn entry_path(dir: &Path, entry: &str) -> PathBuf {
    let mut p = if entry.starts_with('/') || entry.starts_with('\\') {
        PathBuf::from("/")
    } else {
        dir.to_path_buf()
    };
    for part in entry.split(['/', '\\']) {
        match part {
            "" | "." => {}
            // `a/../b` as `b`, so that messages show plain paths.
            ".." if p.file_name().is_some() => {
                p.pop();
            }
            _ => p.push(part),
        }
    }
    p
}

impl Resolver {
    fn relative(&self, path: &Path) -> String {
        let shown = path.strip_prefix(&self.root_dir).unwrap_or(path);
        shown.display().to_string()
    }

    fn file(&mut self, path: &Path, node: Node) -> Result<(), ImportError> {
        if self.stack.iter().any(|p| p == path) || self.stack.len() >= MAX_FILE_DEPTH {
            return Err(ImportError::Json {
                path: path.to_path_buf(),
                message: "the file is included in its own processing_order (a cycle)".into(),
            });
        }
        self.stack.push(path.to_path_buf());
        self.out.files.push(path.to_path_buf());
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let name = self.relative(path);
        match node.get("processing_order") {
            Some(order) => {
                let mut entries = Vec::new();
                flatten(order, &mut entries);
                for entry in entries {
                    match entry {
                        Node::Str(s) => {
                            let lower = s.to_ascii_lowercase();
                            if lower.ends_with(".json") {
                                let p = entry_path(&dir, &s);
                                let child = read_json(&p).map_err(|e| match e {
                                    ImportError::Io { source, .. } => ImportError::Missing {
                                        path: p.clone(),
                                        from: path.to_path_buf(),
                                        source,
                                    },
                                    other => other,
                                })?;
                                self.file(&p, child)?;
                            } else if lower.ends_with(".csv") {
                                self.out.csv_files.push(entry_path(&dir, &s));
                            } else {
                                self.out.ignored.push(s);
                            }
                        }
                        Node::Map(_) => {
                            let label = format!("{name} (processing_order entry)");
                            self.component(path, &label, entry)?;
                        }
                        other => {
                            return Err(ImportError::Json {
                                path: path.to_path_buf(),
                                message: format!(
                                    "a processing_order entry must be a file name or a dict, not {other:?}"
                                ),
                            })
                        }
                    }
                }
            }
            None => self.component(path, &name, node)?,
        }
        self.stack.pop();
        Ok(())
    }

    /// Applies one component (a file without processing_order, or a dict entry).
    fn component(&mut self, path: &Path, label: &str, node: Node) -> Result<(), ImportError> {
        let mut seen: HashMap<String, ()> = HashMap::new();
        let Node::Map(top) = node else {
            return Ok(());
        };
        // Depth-first in file order: a frame is a group path and the entries still to visit.
        let mut stack: Vec<Frame> = vec![(Vec::new(), top.into_iter())];
        while let Some((group, entries)) = stack.last_mut() {
            let Some((key, value)) = entries.next() else {
                stack.pop();
                continue;
            };
            let Node::Map(inner) = &value else { continue };
            if key.eq_ignore_ascii_case("options") {
                continue;
            }
            let group = group.clone();
            if value.get("type").is_none() && value.get("definition").is_none() {
                if let Some(init) = value.get("init") {
                    // GreenLight reads `init` from any dict: `{"x": {"init": "5"}}` sets it.
                    self.init_only(path, &key, init)?;
                }
            } else {
                let name = self.variable(path, label, &group, &key, &value)?;
                if seen.insert(name.clone(), ()).is_some() {
                    return Err(ImportError::Variable {
                        path: path.to_path_buf(),
                        name,
                        message: "declared twice in the same component".into(),
                    });
                }
            }
            let mut g = group;
            g.push(key);
            stack.push((g, inner.clone().into_iter()));
        }
        Ok(())
    }

    /// A node with an `init` and neither `type` nor `definition`: the initial value of a
    /// variable declared before.
    fn init_only(&mut self, path: &Path, key: &str, init: &Node) -> Result<(), ImportError> {
        let bad = |message: &str| ImportError::Variable {
            path: path.to_path_buf(),
            name: key.to_string(),
            message: message.to_string(),
        };
        let text = init
            .text()
            .ok_or_else(|| bad("field `init` must be a string"))?;
        let &i = self
            .index
            .get(key)
            .ok_or_else(|| bad("an `init` for a variable not declared before"))?;
        self.out.vars[i].init = Some(text);
        Ok(())
    }

    /// Declares or changes the variable of node `key`; returns its name.
    fn variable(
        &mut self,
        path: &Path,
        label: &str,
        group: &[String],
        key: &str,
        node: &Node,
    ) -> Result<String, ImportError> {
        let bad = |message: String| ImportError::Variable {
            path: path.to_path_buf(),
            name: key.to_string(),
            message,
        };
        let field = |f: &str| -> Result<Option<String>, ImportError> {
            match node.get(f) {
                None => Ok(None),
                Some(v) => v
                    .text()
                    .map(Some)
                    .ok_or_else(|| bad(format!("field `{f}` must be a string"))),
            }
        };
        let kind = match field("type")? {
            None => None,
            Some(t) => Some(Kind::parse(t.trim()).ok_or_else(|| {
                bad(format!(
                    "unknown type `{t}` (state, const, aux, input, function or time)"
                ))
            })?),
        };
        let (name, params) = match key.find('(') {
            Some(open) => {
                let inner = key[open + 1..]
                    .strip_suffix(')')
                    .ok_or_else(|| bad("a function's key must be `name(a, b, ...)`".into()))?;
                let params: Vec<String> = inner
                    .split(',')
                    .map(|p| p.trim().to_string())
                    .filter(|p| !p.is_empty())
                    .collect();
                (key[..open].trim().to_string(), params)
            }
            None => (key.to_string(), Vec::new()),
        };
        if kind == Some(Kind::Function) && !key.contains('(') {
            return Err(bad(
                "a function's key must be its signature `name(a, b, ...)`".into(),
            ));
        }
        let definition = field("definition")?;
        let unit = field("unit")?;
        let description = field("description")?.unwrap_or_default();
        let reference = field("reference")?.unwrap_or_default();
        let init = field("init")?;
        let group_label = std::iter::once(label.to_string())
            .chain(group.iter().cloned())
            .collect::<Vec<_>>()
            .join(" > ");
        match self.index.get(&name) {
            Some(&i) => {
                let v = &mut self.out.vars[i];
                if let Some(d) = definition {
                    v.definition = d;
                    v.definition_from = label.to_string();
                }
                if let Some(u) = unit {
                    v.unit = Some(u);
                }
                if !description.is_empty() {
                    v.description = description;
                }
                v.reference = reference;
                if init.is_some() {
                    v.init = init;
                }
                if let Some(k) = kind {
                    v.kind = k;
                    if !v.kinds.contains(&k) {
                        v.kinds.push(k);
                    }
                }
                if !params.is_empty() || key.contains('(') {
                    v.params = params;
                }
                if !v.changed_by.contains(&label.to_string()) {
                    v.changed_by.push(label.to_string());
                }
            }
            None => {
                let kind = kind.ok_or_else(|| {
                    bad("a new variable needs a `type` (state, const, aux, input, function or time)".into())
                })?;
                self.index.insert(name.clone(), self.out.vars.len());
                self.out.vars.push(Variable {
                    name: name.clone(),
                    kind,
                    kinds: vec![kind],
                    definition: definition.unwrap_or_else(|| name.clone()),
                    init,
                    unit,
                    description,
                    reference,
                    params,
                    group: group_label,
                    changed_by: Vec::new(),
                    definition_from: label.to_string(),
                });
            }
        }
        Ok(name)
    }
}

fn flatten(node: &Node, out: &mut Vec<Node>) {
    match node {
        Node::List(items) => items.iter().for_each(|i| flatten(i, out)),
        other => out.push(other.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder under the system's temporary folder.
    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("ghm-import-json-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("sub")).unwrap();
        d
    }

    #[test]
    fn processing_order_and_field_by_field_overrides() {
        let d = dir("order");
        std::fs::write(
            d.join("main.json"),
            r#"{"About": "a test", "ignored": {"z": {"type": "const", "definition": "9"}},
               "processing_order": ["sub/base.json", "sub\\ext.json", "no extension", "data/w.csv",
                 {"y": {"init": "5"}, "options": {"t_end": "1"}}]}"#,
        )
        .unwrap();
        std::fs::write(
            d.join("sub/base.json"),
            r#"{"Group": {"reference": "ignored text",
                 "Inner": {"x": {"type": "const", "definition": "1", "unit": "m", "description": "first", "reference": "R1"},
                           "y": {"type": "state", "definition": "-x", "init": "2", "unit": "K", "description": "a state", "reference": "R2"}}},
               "f(a, b)": {"type": "function", "definition": "a*b"},
               "u": {"type": "aux", "definition": "0", "reference": "keep?"}}"#,
        )
        .unwrap();
        std::fs::write(
            d.join("sub/ext.json"),
            r#"{"x": {"definition": "x0 + 1", "description": ""},
               "y": {"type": "state", "unit": "°C", "description": "changed"},
               "u": {"type": "const", "definition": "0"},
               "x0": {"type": "const", "definition": "3"}}"#,
        )
        .unwrap();
        let r = resolve(&d.join("main.json")).unwrap();
        let names: Vec<&str> = r.vars.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["x", "y", "f", "u", "x0"]);
        assert_eq!(r.files.len(), 3);
        assert_eq!(r.csv_files, [d.join("data/w.csv")]);
        assert_eq!(r.ignored, ["no extension"]);
        assert_eq!(r.about.as_deref(), Some("a test"));
        let x = r.get("x").unwrap();
        // Definition replaced; unit kept; empty description keeps; missing reference wipes.
        assert_eq!(x.definition, "x0 + 1");
        assert_eq!(x.unit.as_deref(), Some("m"));
        assert_eq!(x.description, "first");
        assert_eq!(x.reference, "");
        assert_eq!(x.kind, Kind::Const);
        assert_eq!(
            x.group,
            format!("sub{}base.json > Group > Inner", std::path::MAIN_SEPARATOR)
        );
        assert_eq!(
            x.definition_from,
            format!("sub{}ext.json", std::path::MAIN_SEPARATOR)
        );
        // A node without definition keeps it; unit and description replaced; the dict entry
        // of the processing_order sets the init.
        let y = r.get("y").unwrap();
        assert_eq!(
            (y.definition.as_str(), y.unit.as_deref()),
            ("-x", Some("°C"))
        );
        assert_eq!(
            (y.description.as_str(), y.init.as_deref()),
            ("changed", Some("5"))
        );
        assert_eq!(y.kind, Kind::State);
        // A type is added, the last one used.
        let u = r.get("u").unwrap();
        assert_eq!(
            (u.kind, u.kinds.clone()),
            (Kind::Const, vec![Kind::Aux, Kind::Const])
        );
        let f = r.get("f").unwrap();
        assert_eq!(
            (f.kind, f.params.clone()),
            (Kind::Function, vec!["a".to_string(), "b".to_string()])
        );
        assert!(
            r.get("z").is_none(),
            "keys beside processing_order are not read"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn errors_name_the_file_and_the_variable() {
        let d = dir("errors");
        let main = d.join("main.json");
        std::fs::write(
            &main,
            r#"{"a": {"type": "const", "definition": "1"}, "a": {}}"#,
        )
        .unwrap();
        let e = resolve(&main).unwrap_err().to_string();
        assert!(
            e.contains("main.json") && e.contains("duplicate key `a`"),
            "{e}"
        );

        std::fs::write(
            &main,
            r#"{"g1": {"a": {"type": "const"}}, "g2": {"a": {"type": "aux"}}}"#,
        )
        .unwrap();
        let e = resolve(&main).unwrap_err().to_string();
        assert!(e.contains("variable `a`: declared twice"), "{e}");

        std::fs::write(&main, r#"{"processing_order": ["sub/missing.json"]}"#).unwrap();
        let e = resolve(&main).unwrap_err().to_string();
        assert!(
            e.contains("missing.json") && e.contains("named in the processing_order of"),
            "{e}"
        );

        std::fs::write(&main, r#"{"processing_order": ["main.json"]}"#).unwrap();
        let e = resolve(&main).unwrap_err().to_string();
        assert!(e.contains("cycle"), "{e}");

        std::fs::write(&main, r#"{"a": {"type": "variable", "definition": "1"}}"#).unwrap();
        let e = resolve(&main).unwrap_err().to_string();
        assert!(e.contains("variable `a`: unknown type `variable`"), "{e}");

        std::fs::write(&main, r#"{"a": {"definition": "1"}}"#).unwrap();
        let e = resolve(&main).unwrap_err().to_string();
        assert!(e.contains("needs a `type`"), "{e}");

        std::fs::write(&main, r#"{"a": {"init": "1"}}"#).unwrap();
        let e = resolve(&main).unwrap_err().to_string();
        assert!(
            e.contains("variable `a`: an `init` for a variable not declared before"),
            "{e}"
        );

        std::fs::write(&main, "{not json").unwrap();
        assert!(matches!(
            resolve(&main).unwrap_err(),
            ImportError::Json { .. }
        ));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
