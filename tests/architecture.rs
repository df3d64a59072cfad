//! The code map of `docs/architecture.md` against the code: each top-level module's row
//! lists, in its "may use" column, exactly the top-level modules its sources name as
//! `crate::<module>` (in code, not in comments or strings: a doc link is no dependency), and
//! the top-level modules form no cycle, nor do the files. The `ghm-python` row lists
//! exactly the modules `python/src` names as `ghm::<module>`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module → the modules it uses (or may use).
type Edges = BTreeMap<String, BTreeSet<String>>;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The top-level modules: the folders and files under `src/` but the crate roots.
fn top_level_modules(src: &Path) -> BTreeSet<String> {
    let mut modules = BTreeSet::new();
    for entry in std::fs::read_dir(src).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        if path.is_dir() {
            modules.insert(name);
        } else if let Some(stem) = name.strip_suffix(".rs") {
            if stem != "lib" && stem != "main" {
                modules.insert(stem.to_string());
            }
        }
    }
    modules
}

/// The Rust files of a top-level module.
fn module_files(src: &Path, module: &str) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut stack = vec![src.join(module)];
    let single = src.join(format!("{module}.rs"));
    if single.is_file() {
        files.push(single);
    }
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// The source with comments, string and character literals blanked out (newlines kept,
/// so line numbers hold).
fn code_only(source: &str) -> String {
    let chars: Vec<char> = source.chars().collect();
    let mut out = String::with_capacity(source.len());
    let blank = |c: char| if c == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(chars[i]));
                    i += 1;
                }
            }
        } else if c == 'r'
            && (next == Some('"') || next == Some('#'))
            && !chars[..i]
                .last()
                .is_some_and(|p| p.is_alphanumeric() || *p == '_')
        {
            // A raw string r"…" or r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while chars.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if chars.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                if j >= chars.len() {
                    break;
                }
                if chars[j] == '"' && (0..hashes).all(|h| chars.get(j + 1 + h) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.extend(chars[i..j.min(chars.len())].iter().map(|c| blank(*c)));
            i = j;
        } else if c == '"' {
            out.push(' ');
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if i < chars.len() {
                    out.push(blank(chars[i]));
                    i += 1;
                }
            }
            out.push(' ');
            i += 1;
        } else if c == '\'' && (next == Some('\\') || chars.get(i + 2) == Some(&'\'')) {
            // A character literal ('x', '\n', '\u{..}'), not a lifetime.
            let mut j = i + 1;
            if chars.get(j) == Some(&'\\') {
                j += 2;
            } else {
                j += 1;
            }
            while j < chars.len() && chars[j] != '\'' {
                j += 1;
            }
            for _ in i..=j.min(chars.len() - 1) {
                out.push(' ');
            }
            i = j + 1;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// The top-level modules a piece of code names as `crate::<module>` (also inside
/// `crate::{a, b::c}`), with the line of each first use.
fn crate_paths(code: &str, modules: &BTreeSet<String>) -> BTreeMap<String, usize> {
    paths_under("crate", code, modules)
}

/// The top-level modules a piece of code names as `<root>::<module>`, with the line of
/// each first use.
fn paths_under(root: &str, code: &str, modules: &BTreeSet<String>) -> BTreeMap<String, usize> {
    let prefix = format!("{root}::");
    let mut used = BTreeMap::new();
    for (n, line) in code.lines().enumerate() {
        let mut rest = line;
        while let Some(at) = rest.find(&prefix) {
            let before = rest[..at].chars().last();
            let after = &rest[at + prefix.len()..];
            rest = after;
            if before.is_some_and(|b| b.is_alphanumeric() || b == '_') {
                continue; // `foo_crate::`, not `crate::`
            }
            let names: Vec<&str> = if let Some(group) = after.strip_prefix('{') {
                // One level of `crate::{a, b::c}`; a group over lines is not used in ghm.
                let end = group.find('}').unwrap_or(group.len());
                group[..end]
                    .split(',')
                    .map(|p| p.trim().split("::").next().unwrap_or("").trim())
                    .collect()
            } else {
                let end = after
                    .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .unwrap_or(after.len());
                vec![&after[..end]]
            };
            for name in names {
                if modules.contains(name) {
                    used.entry(name.to_string()).or_insert(n + 1);
                }
            }
        }
    }
    used
}

/// The code's edges between top-level modules, each with where it is first seen.
fn code_edges(
    src: &Path,
    modules: &BTreeSet<String>,
) -> BTreeMap<String, BTreeMap<String, String>> {
    let mut edges = BTreeMap::new();
    for module in modules {
        let mut uses: BTreeMap<String, String> = BTreeMap::new();
        for file in module_files(src, module) {
            let text = std::fs::read_to_string(&file).unwrap();
            for (used, line) in crate_paths(&code_only(&text), modules) {
                if &used != module {
                    let at = file.strip_prefix(root()).unwrap_or(&file).display();
                    uses.entry(used).or_insert_with(|| format!("{at}:{line}"));
                }
            }
        }
        edges.insert(module.clone(), uses);
    }
    edges
}

/// The "may use" column of the code map, per module that has a row; the names in
/// backticks before any `::` are the modules (`report::atomic` is `report`), other words
/// (external crates, comments) are ignored.
fn documented_edges(doc: &str, modules: &BTreeSet<String>) -> Result<Edges, String> {
    documented_rows(doc, modules, |module| modules.contains(module))
}

/// The "may use" column of the rows whose module `wanted` accepts.
fn documented_rows(
    doc: &str,
    modules: &BTreeSet<String>,
    wanted: impl Fn(&str) -> bool,
) -> Result<Edges, String> {
    let mut edges = Edges::new();
    for line in doc.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // "| `module` | owns | may use | must not |" splits into 6 cells, the outer two empty.
        if cells.len() < 6 || !cells[1].starts_with('`') {
            continue;
        }
        let module = backticked(cells[1]).into_iter().next().unwrap_or_default();
        if !wanted(&module) {
            continue;
        }
        let may_use: BTreeSet<String> = backticked(cells[3])
            .into_iter()
            .map(|t| t.split("::").next().unwrap_or("").to_string())
            .filter(|t| modules.contains(t))
            .collect();
        if edges.insert(module.clone(), may_use).is_some() {
            return Err(format!("module `{module}` has two rows in the code map"));
        }
    }
    Ok(edges)
}

fn backticked(cell: &str) -> Vec<String> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .map(|s| s.trim().to_string())
        .collect()
}

/// A cycle of `edges`, as the modules along it, if there is one.
fn find_cycle(edges: &Edges) -> Option<Vec<String>> {
    // 0: unvisited, 1: on the current path, 2: done.
    fn visit(
        m: &str,
        edges: &Edges,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(m.to_string(), 1);
        path.push(m.to_string());
        for next in edges.get(m).into_iter().flatten() {
            match state.get(next.as_str()).copied().unwrap_or(0) {
                1 => {
                    let start = path.iter().position(|p| p == next).unwrap();
                    let mut cycle = path[start..].to_vec();
                    cycle.push(next.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(next, edges, state, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        state.insert(m.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for m in edges.keys() {
        if state.get(m.as_str()).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(m, edges, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

#[test]
fn the_code_map_lists_exactly_the_modules_each_module_uses() {
    let src = root().join("src");
    let modules = top_level_modules(&src);
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let documented = documented_edges(&doc, &modules).unwrap();
    let code = code_edges(&src, &modules);
    let mut problems = Vec::new();
    for (module, uses) in &code {
        let Some(listed) = documented.get(module) else {
            problems.push(format!(
                "`{module}` has no row in the code map of docs/architecture.md"
            ));
            continue;
        };
        for (used, at) in uses {
            if !listed.contains(used) {
                problems.push(format!(
                    "`{module}` uses `{used}` ({at}), which its row's \"may use\" does not list"
                ));
            }
        }
        for used in listed {
            if !uses.contains_key(used) {
                problems.push(format!(
                    "`{module}`'s row lists `{used}` under \"may use\", but no code of \
                     src/{module} uses it"
                ));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "docs/architecture.md and the code disagree:\n  {}",
        problems.join("\n  ")
    );
}

#[test]
fn the_python_row_lists_exactly_the_modules_the_python_crate_uses() {
    let modules = top_level_modules(&root().join("src"));
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let rows = documented_rows(&doc, &modules, |m| m == "ghm-python").unwrap();
    let listed = rows
        .get("ghm-python")
        .expect("a `ghm-python` row in the code map");
    let mut used = BTreeSet::new();
    let dir = root().join("python/src");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&path).unwrap();
            used.extend(paths_under("ghm", &code_only(&text), &modules).into_keys());
        }
    }
    assert_eq!(
        listed, &used,
        "the `ghm-python` row of docs/architecture.md lists {listed:?}; python/src uses {used:?}"
    );
}

#[test]
fn top_level_modules_form_no_cycle() {
    let src = root().join("src");
    let modules = top_level_modules(&src);
    let edges: Edges = code_edges(&src, &modules)
        .into_iter()
        .map(|(m, uses)| (m, uses.into_keys().collect()))
        .collect();
    if let Some(cycle) = find_cycle(&edges) {
        panic!(
            "the top-level modules use each other in a cycle: {}",
            cycle.join(" → ")
        );
    }
}

/// The module path of a file under `src/` (`lang/check/mod.rs` → `lang::check`).
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap();
    let mut segments: Vec<String> = rel
        .iter()
        .map(|s| s.to_str().unwrap().to_string())
        .collect();
    let last = segments.pop().unwrap();
    if last != "mod.rs" {
        segments.push(last.trim_end_matches(".rs").to_string());
    }
    segments
}

/// Every path a piece of code names from the crate's root or relative to `module`
/// (`crate::a::B`, `super::c::D`, one level of `{…}` groups), as module segments.
fn named_paths(code: &str, module: &[String]) -> Vec<Vec<String>> {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut paths = Vec::new();
    for line in code.lines() {
        for (at, _) in line.match_indices("::") {
            // The start of the path this `::` belongs to.
            let start = line[..at]
                .rfind(|c: char| !(ident(c) || c == ':'))
                .map_or(0, |i| i + 1);
            if line[start..at].contains("::") {
                continue; // not the path's first `::`
            }
            let mut base: Vec<String> = match &line[start..at] {
                "crate" => Vec::new(),
                "super" => module.to_vec(),
                _ => continue,
            };
            let mut rest = &line[at + 2..];
            if line[start..at] == *"super" {
                base.pop();
                while let Some(r) = rest.strip_prefix("super::") {
                    base.pop();
                    rest = r;
                }
            }
            // `a::b::{c, d::e}`: the segments before a group, then each of its items.
            let head_end = rest
                .find(|c: char| !(ident(c) || c == ':'))
                .unwrap_or(rest.len());
            let (head, after) = rest.split_at(head_end);
            let tails: Vec<&str> = match after.strip_prefix('{') {
                Some(group) if head.is_empty() || head.ends_with("::") => {
                    let end = group.find('}').unwrap_or(group.len());
                    group[..end].split(',').collect()
                }
                _ => vec![""],
            };
            for tail in tails {
                let tail = tail.trim();
                let end = tail
                    .find(|c: char| !(ident(c) || c == ':'))
                    .unwrap_or(tail.len());
                let mut path = base.clone();
                path.extend(
                    head.split("::")
                        .chain(tail[..end].split("::"))
                        .filter(|s| !s.is_empty())
                        .map(str::to_string),
                );
                paths.push(path);
            }
        }
    }
    paths
}

/// The file a module path leads into: the longest prefix that is `src/<p>.rs` or
/// `src/<p>/mod.rs`.
fn file_of(src: &Path, path: &[String]) -> Option<PathBuf> {
    (1..=path.len()).rev().find_map(|n| {
        let p = path[..n].join("/");
        [src.join(format!("{p}.rs")), src.join(&p).join("mod.rs")]
            .into_iter()
            .find(|f| f.is_file())
    })
}

/// Which files of `src/` each file imports, by the paths its code names; a `mod.rs` naming
/// files under its own folder is the module's face, not an import.
fn file_edges(src: &Path) -> Edges {
    let mut edges = Edges::new();
    for module in top_level_modules(src) {
        for file in module_files(src, &module) {
            let here = module_path(src, &file);
            let code = code_only(&std::fs::read_to_string(&file).unwrap());
            // A file's own tests (`#[cfg(test)] mod tests`, at its end) are not its imports.
            let code = code
                .find("#[cfg(test)]\nmod ")
                .map_or(&code[..], |i| &code[..i]);
            let folder = file.parent().unwrap().to_path_buf();
            let is_face = file.ends_with("mod.rs");
            let name = |f: &Path| f.strip_prefix(src).unwrap().display().to_string();
            let uses = edges.entry(name(&file)).or_default();
            for path in named_paths(code, &here) {
                if let Some(target) = file_of(src, &path) {
                    if target != file && !(is_face && target.starts_with(&folder)) {
                        uses.insert(name(&target));
                    }
                }
            }
        }
    }
    edges
}

#[test]
fn files_form_no_cycle() {
    let src = root().join("src");
    let edges = file_edges(&src);
    assert!(
        edges["lang/load.rs"].contains("lang/check/mod.rs"),
        "the scan sees `use crate::lang::check::check`: {:?}",
        edges["lang/load.rs"]
    );
    assert!(
        edges["study/report.rs"].contains("study/markdown.rs"),
        "the scan sees `use crate::study::markdown::model_section`"
    );
    if let Some(cycle) = find_cycle(&edges) {
        panic!(
            "these files import each other in a cycle: {}",
            cycle.join(" → ")
        );
    }
}

#[test]
fn the_checks_themselves_can_fail() {
    let modules: BTreeSet<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
    // Only code counts: comments, doc links and strings do not.
    let code = code_only(
        "use crate::b::X; // crate::c\n/// [`c`](crate::c)\nlet s = \"crate::c\"; let q = '\"'; let r = r#\"crate::c\"#;\nuse crate::{a, c::Y};\n",
    );
    let used = crate_paths(&code, &modules);
    assert_eq!(used.keys().collect::<Vec<_>>(), ["a", "b", "c"]);
    assert_eq!(used["b"], 1);
    assert_eq!(used["c"], 4);
    let doc = "| module | owns | may use | must not |\n|---|---|---|---|\n\
               | `a` | x | `b`, `c::z` (why), serde | y |\n| `b` | x | — | y |\n";
    let documented = documented_edges(doc, &modules).unwrap();
    assert_eq!(documented["a"].iter().collect::<Vec<_>>(), ["b", "c"]);
    assert!(documented["b"].is_empty());
    let edge = |pairs: &[(&str, &str)]| {
        let mut e = Edges::new();
        for (from, to) in pairs {
            e.entry(from.to_string())
                .or_default()
                .insert(to.to_string());
        }
        e
    };
    assert_eq!(
        find_cycle(&edge(&[("a", "b"), ("b", "c"), ("a", "c")])),
        None
    );
    assert_eq!(
        find_cycle(&edge(&[("a", "b"), ("b", "c"), ("c", "a")])).unwrap(),
        ["a", "b", "c", "a"]
    );
    let here: Vec<String> = ["study", "report"].iter().map(|s| s.to_string()).collect();
    let named = named_paths(
        "use super::table::{spread, TableLine};\nlet x = crate::lang::load(p);\nfoo::bar();\n",
        &here,
    );
    assert_eq!(
        named,
        [
            vec!["study", "table", "spread"],
            vec!["study", "table", "TableLine"],
            vec!["lang", "load"],
        ]
    );
}

#[test]
fn the_spec_types_know_no_command_line() {
    // The job layer's specs are read from study files, Python and bundles as well as
    // from flags; only `cli` maps flags onto them.
    let src = root().join("src");
    let mut found = Vec::new();
    for module in ["job", "study", "embed", "serve"] {
        for path in module_files(&src, module) {
            let code = code_only(&std::fs::read_to_string(&path).unwrap());
            if code.contains("clap::") || code.contains("use clap") {
                found.push(path.display().to_string());
            }
        }
    }
    assert!(
        found.is_empty(),
        "these files use clap; flags belong to src/cli: {found:?}"
    );
}

#[test]
fn only_control_knows_warm_starts() {
    // How MPC restarts from its last solution is MPC's policy: declared once, in
    // `control`, and read by its names everywhere else; a back-end only says whether it
    // restarts from multipliers (`Solver::restarts_from_multipliers`).
    let src = root().join("src");
    let mut declared = Vec::new();
    let mut named_by_solvers = Vec::new();
    for module in top_level_modules(&src) {
        for path in module_files(&src, &module) {
            let code = code_only(&std::fs::read_to_string(&path).unwrap());
            let file = path.strip_prefix(root()).unwrap().display().to_string();
            if code.contains("enum WarmStart") {
                declared.push(file.clone());
            }
            if module == "solve" && code.contains("WarmStart") {
                named_by_solvers.push(file);
            }
        }
    }
    assert_eq!(declared, ["src/control/warm_start.rs"]);
    assert!(
        named_by_solvers.is_empty(),
        "the back-ends name MPC's warm start: {named_by_solvers:?}"
    );
}
