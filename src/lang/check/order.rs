//! Parameters and constants in dependency order: a value may name a constant declared
//! further down (GreenLight's constants are written so), and a cycle is refused with the
//! place of each of its members.
//!
//! The order is found on the syntax tree, before anything is lowered: the names a value
//! uses, through the bodies of the functions it calls, are its dependencies.

use super::Checker;
use crate::lang::ast::*;
use crate::lang::diagnostic::Diagnostic;
use std::collections::{HashMap, HashSet};

/// Where the depth-first search is with a declaration.
#[derive(Clone, Copy, PartialEq)]
enum Mark {
    New,
    Open,
    Done,
}

impl<'d> Checker<'d> {
    /// The names `e` uses, with those used by the bodies of the functions it calls (each
    /// function once; a function's own parameters are not names of the model).
    pub(super) fn names_used(&self, e: &'d Expr) -> Vec<&'d Name> {
        let mut names = Vec::new();
        let mut seen_fns: HashSet<&str> = HashSet::new();
        // (expression, the parameters of the function whose body it is in)
        let mut stack: Vec<(&'d Expr, &'d [Name])> = vec![(e, &[])];
        while let Some((e, params)) = stack.pop() {
            match e {
                Expr::Number(..) => {}
                Expr::Name(n) | Expr::Next(n, _) => {
                    if !params.iter().any(|p| p.text == n.text) {
                        names.push(n);
                    }
                }
                Expr::Neg(a, _) | Expr::Not(a, _) => stack.push((a, params)),
                Expr::Binary(_, a, b, _) => {
                    stack.push((b, params));
                    stack.push((a, params));
                }
                Expr::Call(f, args, _) => {
                    stack.extend(args.iter().rev().map(|a| (a, params)));
                    if let Some(def) = self.functions.get(f.text.as_str()) {
                        if seen_fns.insert(f.text.as_str()) {
                            stack.push((def.body, def.params));
                        }
                    }
                }
            }
        }
        names
    }

    /// The order to evaluate `params` (the `param` and `const` statements, in declaration
    /// order) in: each after every one its value names. Members of a cycle are reported
    /// (E026) and returned apart, to be given no value.
    pub(super) fn evaluation_order(
        &mut self,
        params: &[(&'d Name, &'d Expr)],
    ) -> (Vec<usize>, Vec<usize>) {
        // A name stands for its first declaration; a repeated one is reported when declared.
        let mut first: HashMap<&str, usize> = HashMap::new();
        for (i, (name, _)) in params.iter().enumerate() {
            first.entry(name.text.as_str()).or_insert(i);
        }
        let deps: Vec<Vec<usize>> = params
            .iter()
            .map(|(_, value)| {
                let mut d: Vec<usize> = self
                    .names_used(value)
                    .iter()
                    .filter_map(|n| first.get(n.text.as_str()).copied())
                    .collect();
                d.dedup();
                d
            })
            .collect();
        let mut mark = vec![Mark::New; params.len()];
        let mut order = Vec::with_capacity(params.len());
        let mut cyclic = Vec::new();
        for root in 0..params.len() {
            if mark[root] != Mark::New {
                continue;
            }
            // (declaration, how many of its dependencies were visited)
            let mut path: Vec<(usize, usize)> = vec![(root, 0)];
            mark[root] = Mark::Open;
            while let Some(&mut (node, ref mut next)) = path.last_mut() {
                let Some(&dep) = deps[node].get(*next) else {
                    mark[node] = Mark::Done;
                    if !cyclic.contains(&node) {
                        order.push(node);
                    }
                    path.pop();
                    continue;
                };
                *next += 1;
                match mark[dep] {
                    Mark::New => {
                        mark[dep] = Mark::Open;
                        path.push((dep, 0));
                    }
                    Mark::Open => {
                        let start = path.iter().position(|&(n, _)| n == dep).unwrap_or(0);
                        let members: Vec<usize> = path[start..].iter().map(|&(n, _)| n).collect();
                        if members.iter().all(|m| !cyclic.contains(m)) {
                            self.report_cycle(params, &members);
                        }
                        cyclic.extend(members);
                    }
                    Mark::Done => {}
                }
            }
        }
        (order, cyclic)
    }

    fn report_cycle(&mut self, params: &[(&'d Name, &'d Expr)], members: &[usize]) {
        let name = |i: usize| params[i].0;
        let head = name(members[0]);
        let chain: Vec<String> = members
            .iter()
            .chain(std::iter::once(&members[0]))
            .map(|&i| format!("`{}`", name(i).text))
            .collect();
        let mut d = Diagnostic::error(
            "E026",
            head.span,
            format!("`{}` depends on itself: {}", head.text, chain.join(" → ")),
        )
        .label("its value needs itself");
        for &m in &members[1..] {
            d = d.related(
                name(m).span,
                format!("`{}` is declared here, in the cycle", name(m).text),
            );
        }
        if members.len() == 1 {
            d = d.help("a value cannot name itself; write the number");
        } else {
            d = d.help("give one of them a value that does not name the others");
        }
        self.diags.push(d);
    }
}
