//! Collecting declarations: the statements of all files in order, with `override`
//! replacing and `drop` removing an earlier declaration, duplicates reported.

use crate::lang::ast::*;
use crate::lang::diagnostic::Diagnostic;
use crate::lang::source::Span;
use std::collections::HashMap;

/// Declarations after overrides and drops, in declaration order.
#[derive(Default)]
pub(crate) struct Decls {
    pub(crate) model: Option<(Name, Option<String>)>,
    pub(crate) items: Vec<Statement>,
    pub(crate) sample: Option<Statement>,
    pub(crate) uncertainty: Option<Statement>,
    /// Every `solver` statement, in order (a later setting replaces an earlier one).
    pub(crate) solver: Vec<Statement>,
}

fn key(stmt: &Stmt) -> Option<(String, String)> {
    match stmt {
        Stmt::Der { state, .. } => Some(("der".into(), state.text.clone())),
        Stmt::Soft { output, .. } => Some(("soft".into(), output.text.clone())),
        Stmt::Term { name, .. } => Some(("term".into(), name.text.clone())),
        Stmt::Function { name, .. } => Some(("fn".into(), name.text.clone())),
        other => other
            .declared()
            .map(|(_, n)| ("name".into(), n.text.clone())),
    }
}

fn key_span(stmt: &Statement) -> Span {
    match &stmt.stmt {
        Stmt::Der { state, .. } => state.span,
        Stmt::Soft { output, .. } => output.span,
        Stmt::Function { name, .. } => name.span,
        other => other.declared().map_or(stmt.span, |(_, n)| n.span),
    }
}

pub(crate) fn collect(statements: Vec<Statement>, diags: &mut Vec<Diagnostic>) -> Decls {
    let mut d = Decls::default();
    let mut index: HashMap<(String, String), usize> = HashMap::new();
    for s in statements {
        match &s.stmt {
            Stmt::Model { name, description } => {
                d.model = Some((name.clone(), description.clone()))
            }
            Stmt::Sample { .. } => {
                if d.sample.is_some() && !s.overrides {
                    diags.push(
                        Diagnostic::error("E004", s.span, "the sample period is declared twice")
                            .label("second `sample`")
                            .help("write `override sample ...` to replace an imported one"),
                    );
                }
                d.sample = Some(s);
            }
            Stmt::Uncertainty { .. } => d.uncertainty = Some(s),
            Stmt::Solver { .. } => d.solver.push(s),
            Stmt::Drop { kind, name } => {
                let k = if kind == "soft" { "soft" } else { "term" };
                let key = (k.to_string(), name.text.clone());
                // `drop cost c` must not remove a `reward c`: the terms share one key.
                let declared_kind = index.get(&key).and_then(|&i| match &d.items[i].stmt {
                    Stmt::Term { kind, .. } => Some(kind.keyword()),
                    _ => None,
                });
                if let Some(declared) = declared_kind.filter(|declared| declared != kind) {
                    diags.push(
                        Diagnostic::error(
                            "E014",
                            name.span,
                            format!(
                                "there is no {kind} `{}` to drop; it is a {declared}",
                                name.text
                            ),
                        )
                        .label("declared with another kind")
                        .help(format!("write `drop {declared} {}`", name.text)),
                    );
                    continue;
                }
                match index.remove(&key) {
                    Some(i) => {
                        d.items[i].stmt = Stmt::Drop {
                            kind: kind.clone(),
                            name: name.clone(),
                        }
                    }
                    None => diags.push(
                        Diagnostic::error(
                            "E014",
                            name.span,
                            format!("there is no {kind} `{}` to drop", name.text),
                        )
                        .label("not declared before this line")
                        .help("`drop` removes a declaration made earlier or in an imported file"),
                    ),
                }
            }
            _ => {
                let Some(k) = key(&s.stmt) else { continue };
                match (index.get(&k), s.overrides) {
                    (Some(&i), true) => d.items[i] = s,
                    (Some(&i), false) => {
                        let what = if k.0 == "der" { "the derivative of" } else { "" };
                        diags.push(
                            Diagnostic::error("E004", key_span(&s), format!("{what} `{}` is declared twice", k.1).trim().to_string())
                                .label("declared again here")
                                .related(key_span(&d.items[i]), "first declared here")
                                .help("rename one of them, or write `override` to replace the first on purpose"),
                        );
                    }
                    (None, true) => diags.push(
                        Diagnostic::error("E014", key_span(&s), format!("`override` of `{}`, which is not declared before", k.1))
                            .label("nothing to override")
                            .help("drop `override` to declare it, or check the name against the imported file"),
                    ),
                    (None, false) => {
                        index.insert(k, d.items.len());
                        d.items.push(s);
                    }
                }
            }
        }
    }
    d
}
