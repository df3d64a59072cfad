//! Where a model's exact derivatives are not finite at a point, named by the expression
//! the user wrote: `abs(x)^0.33` at `x = 0` (an infinite partial), `exp(z)` that overflows.
//!
//! Every operation reached by the model's equations (`der`, outputs, objective terms) is
//! evaluated at the point; an operation whose arguments are finite but whose value, or
//! whose partial derivative with respect to an argument that depends on the states or
//! inputs, is not finite is reported. Branches that `if`, `min` and `max` do not take are
//! never differentiated (see [`Op::passed_on`]), so they are not reported.

use crate::graph::{Node, NodeId, Op};
use crate::lang::model::Model;
use crate::lang::source::Span;

/// One operation whose value or derivative is not finite at the point.
#[derive(Debug, Clone, PartialEq)]
pub struct Singularity {
    /// The operation's node in the model's graph.
    pub node: NodeId,
    /// Where the expression was written (`None` for a model built in Rust).
    pub span: Option<Span>,
    /// The operation.
    pub op: Op,
    /// Its value at the point.
    pub value: f64,
    /// The partial derivative that is not finite (`None` when the value itself is not).
    pub partial: Option<f64>,
}

/// The operations of `model`'s equations that are singular at `point`, the values of the
/// graph's variables `(x, u, d, p, x⁺)`, each expression once, in graph order. Variables
/// `x`, `u` and `x⁺` are the ones derivatives are taken with respect to.
pub fn singularities(model: &Model, point: &[f64]) -> Vec<Singularity> {
    let graph = &model.graph;
    let layout = model.layout();
    let mut roots: Vec<NodeId> = model.derivatives.clone();
    roots.extend(model.outputs.iter().map(|o| o.node));
    roots.extend(model.terms.iter().map(|t| t.node));
    let order = graph.reachable(&roots);
    let mut value = vec![f64::NAN; graph.len()];
    let mut varies = vec![false; graph.len()];
    for &id in &order {
        let i = id.index();
        match graph.node(id) {
            Node::Const(bits) => value[i] = f64::from_bits(bits),
            Node::Var(v) => {
                let v = v as usize;
                value[i] = point.get(v).copied().unwrap_or(f64::NAN);
                varies[i] = v < layout.nx + layout.nu || v >= layout.n_base();
            }
            Node::Apply(op, args) => {
                let arg = |k: usize| args[k].index();
                let at = |k: usize| if k < op.arity() { value[arg(k)] } else { 0.0 };
                value[i] = op.apply_f64(at(0), at(1), at(2));
                varies[i] = (0..op.arity()).any(|k| varies[arg(k)]);
            }
        }
    }
    // The operations whose derivatives reach the roots: the branch taken only.
    let mut live = vec![false; graph.len()];
    for &r in &roots {
        live[r.index()] = true;
    }
    let mut found = Vec::new();
    let mut spans_seen = Vec::new();
    for &id in order.iter().rev() {
        let i = id.index();
        let Node::Apply(op, args) = graph.node(id) else {
            continue;
        };
        if !live[i] {
            continue;
        }
        let at = |k: usize| {
            if k < op.arity() {
                value[args[k].index()]
            } else {
                0.0
            }
        };
        let taken = op.passed_on(at(0), at(1), at(2));
        let passes = |k: usize| taken.is_none_or(|t| t == k);
        for (k, a) in args.iter().enumerate().take(op.arity()) {
            if passes(k) {
                live[a.index()] = true;
            }
        }
        let arguments_finite = (0..op.arity()).all(|k| at(k).is_finite());
        if !arguments_finite || !varies[i] || op.is_piecewise_constant() {
            continue;
        }
        let partial = if value[i].is_finite() {
            let partials = op.partials(at(0), at(1), at(2), value[i]);
            (0..op.arity())
                .filter(|&k| passes(k) && varies[args[k].index()])
                .map(|k| partials[k])
                .find(|p| !p.is_finite())
        } else {
            Some(f64::NAN)
        };
        let Some(partial) = partial else { continue };
        let span = model.origins.get(&id).copied();
        if span.is_some_and(|s| spans_seen.contains(&s)) {
            continue;
        }
        spans_seen.extend(span);
        found.push(Singularity {
            node: id,
            span,
            op,
            value: value[i],
            partial: value[i].is_finite().then_some(partial),
        });
    }
    found.reverse();
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::load_str;

    fn at_start(text: &str) -> Vec<Singularity> {
        let m = load_str("s.ghm", text).unwrap_or_else(|e| panic!("{}", e.render()));
        let mut point: Vec<f64> = m.states.iter().map(|s| s.initial).collect();
        point.extend(m.start_input());
        point.extend(m.disturbances.iter().map(|d| d.value.unwrap_or(0.0)));
        point.extend(m.nominal_params());
        point.extend(m.states.iter().map(|s| s.initial));
        singularities(&m, &point)
    }

    #[test]
    fn an_infinite_partial_is_named_by_its_expression() {
        let found = at_start(
            "sample 60 [s]
state a = 16.5
state b = 16.5
der a = abs(b - a)^0.33 * (b - a)
der b = 0
",
        );
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(matches!(found[0].op, Op::Powf(_)));
        assert!(found[0].partial.is_some_and(|p| !p.is_finite()));
        let span = found[0].span.expect("span");
        // The power's span, up to the space before `*`.
        assert!((15..=16).contains(&(span.end - span.start)), "{span:?}");
    }

    #[test]
    fn an_overflow_is_reported_and_untaken_branches_are_not() {
        let found = at_start(
            "sample 60 [s]
state x = 0
der x = if(x > 1, sqrt(x), 0) + 1 / (1 + exp(1000 * (x + 1)))
",
        );
        // sqrt(x) at 0 is in the branch `if` does not take.
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].op, Op::Exp);
        assert_eq!(found[0].partial, None);
    }

    #[test]
    fn a_smooth_model_has_none() {
        let found = at_start(
            "sample 60 [s]
state x = 0
input u in [0, 1] start 0.5
der x = 0.5 + 0.5 * tanh(1000 * (x + 1)) + sqrt(u + x^2 + 1)
",
        );
        assert!(found.is_empty(), "{found:?}");
    }
}
