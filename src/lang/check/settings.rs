//! Checks of constant settings: input bounds, rate limits and start values, soft and
//! planning bands, the `sample` statement and the `uncertainty` settings.

use super::{info, Checker, Symbol};
use crate::lang::ast::*;
use crate::lang::diagnostic::Diagnostic;
use crate::lang::model::*;
use crate::lang::source::Span;

/// What a `sample` statement sets.
pub(super) struct Sample {
    /// The control period in seconds.
    pub period: f64,
    /// `integrator NAME` (`rk4` without one).
    pub integrator: Integrator,
    /// `substeps N` (1 without).
    pub substeps: usize,
    /// `plan substeps M` (`substeps` without).
    pub plan_substeps: usize,
}

/// Shortest sample period accepted, in seconds.
const MIN_PERIOD_S: f64 = 0.1;
/// Longest sample period accepted, in seconds: one day.
const MAX_PERIOD_S: f64 = 86_400.0;

/// A number as a person writes it: `1e-300`, not three hundred zeros.
fn readable(v: f64) -> String {
    if v == 0.0 || (1e-3..1e7).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

impl Checker<'_> {
    pub(super) fn input(&mut self, s: &Statement) -> Option<InputDecl> {
        let Stmt::Input {
            name,
            bounds,
            rate,
            start,
            doc,
            ..
        } = &s.stmt
        else {
            return None;
        };
        let (lower, upper) = match bounds {
            Some((lo, hi)) => {
                let l = self.constant(lo, "a bound").unwrap_or(f64::NAN);
                let h = self.constant(hi, "a bound").unwrap_or(f64::NAN);
                if l > h {
                    self.diags.push(
                        Diagnostic::error(
                            "E008",
                            lo.span().to(hi.span()),
                            format!(
                                "input `{}` has bounds with lower {l} > upper {h}",
                                name.text
                            ),
                        )
                        .label("empty interval")
                        .help("write the bounds as `in [lower, upper]`"),
                    );
                }
                (l, h)
            }
            None => (f64::NEG_INFINITY, f64::INFINITY),
        };
        let rate_v = match rate {
            Some(r) => {
                let v = self.constant(r, "a rate limit").unwrap_or(f64::NAN);
                if v < 0.0 {
                    self.diags.push(
                        Diagnostic::error("E007", r.span(), format!("rate limit of `{}` is negative ({v})", name.text))
                            .label("must be ≥ 0")
                            .help("the rate limit is the largest |u(k) − u(k−1)|; give a non-negative number"),
                    );
                }
                Some(v)
            }
            None => None,
        };
        let start_v = match start {
            Some(e) => {
                let v = self.constant(e, "a start value").unwrap_or(f64::NAN);
                if v < lower || v > upper {
                    self.diags.push(
                        Diagnostic::error("E021", e.span(), format!("start value {v} of `{}` lies outside its bounds [{lower}, {upper}]", name.text))
                            .label("outside the bounds")
                            .help("the start value is the input applied before the first step; put it within the bounds"),
                    );
                }
                v
            }
            None => lower.max(0.0).min(upper),
        };
        Some(InputDecl {
            info: info(name, doc),
            lower,
            upper,
            rate: rate_v,
            start: if start_v.is_finite() { start_v } else { 0.0 },
            // Lowered with the dynamics ([`Checker::rules`]).
            rule: None,
        })
    }

    /// The first graph variable in `slots` that `node` reads (through lets and outputs).
    fn first_variable_read(
        &self,
        node: crate::graph::NodeId,
        slots: std::ops::Range<usize>,
    ) -> Option<usize> {
        self.graph
            .reachable(&[node])
            .into_iter()
            .find_map(|n| match self.graph.node(n) {
                crate::graph::Node::Var(v) => Some(v as usize).filter(|v| slots.contains(v)),
                _ => None,
            })
    }

    /// Refuses a `terminal` term that reads an input or a disturbance (directly or through
    /// a let or an output), naming it: a terminal value is worth the state a horizon ends
    /// in, and is evaluated where no step's input or weather is given.
    pub(super) fn terminal_reads_only_the_state(
        &mut self,
        name: &Name,
        expr: &Expr,
        node: crate::graph::NodeId,
        inputs: &[InputDecl],
        dists: &[DisturbanceDecl],
    ) {
        let (nx, nu, nd) = (self.layout.nx, self.layout.nu, self.layout.nd);
        let read = match self.first_variable_read(node, nx..nx + nu + nd) {
            Some(v) if v < nx + nu => {
                Some(("input", inputs.get(v - nx).map(|d| d.info.name.clone())))
            }
            Some(v) => Some((
                "disturbance",
                dists.get(v - nx - nu).map(|d| d.info.name.clone()),
            )),
            None => None,
        };
        if let Some((kind, read_name)) = read {
            let a_kind = if kind == "input" {
                "an input"
            } else {
                "a disturbance"
            };
            let read_name = read_name.unwrap_or_else(|| a_kind.to_string());
            self.diags.push(
                Diagnostic::error(
                    "E029",
                    expr.span(),
                    format!("`terminal {}` reads the {kind} `{read_name}`", name.text),
                )
                .label(format!("reads {a_kind}"))
                .help("a terminal value is worth the state a horizon ends in: write it, and the lets and outputs it uses, from states and parameters only"),
            );
        }
    }

    /// Lowers each input's `rule` into the graph, once the lets it reads can be; a rule
    /// that reads an input (directly or through a let) is refused, naming the input: a
    /// rule decides the inputs, so it cannot read them.
    pub(super) fn rules(&mut self, d: &crate::lang::collect::Decls, inputs: &mut [InputDecl]) {
        let mut index = 0;
        for s in &d.items {
            let Stmt::Input { name, rule, .. } = &s.stmt else {
                continue;
            };
            let i = index;
            index += 1;
            let Some(expr) = rule.as_ref() else {
                continue;
            };
            let node = self.lower(expr, super::Context::Dynamics);
            let (nx, nu) = (self.layout.nx, self.layout.nu);
            let read = self.first_variable_read(node, nx..nx + nu).map(|v| v - nx);
            if let Some(u) = read {
                let read_name = inputs.get(u).map_or("an input", |d| d.info.name.as_str());
                self.diags.push(
                    Diagnostic::error(
                        "E028",
                        expr.span(),
                        format!(
                            "the rule of input `{}` reads the input `{read_name}`",
                            name.text
                        ),
                    )
                    .label("reads an input")
                    .help("a rule decides the inputs from the state, the weather and the parameters; write it, and the lets it uses, without inputs"),
                );
                continue;
            }
            if let Some(input) = inputs.get_mut(i) {
                input.rule = Some(node);
            }
        }
    }

    pub(super) fn soft(&mut self, s: &Statement) -> Option<SoftBand> {
        let Stmt::Soft {
            output,
            band,
            weight_lo,
            weight_hi,
            plan,
            description,
        } = &s.stmt
        else {
            return None;
        };
        let index = match self.symbols.get(&output.text) {
            Some((Symbol::Output(i), _)) => *i,
            Some(_) => {
                self.diags.push(
                    Diagnostic::error(
                        "E018",
                        output.span,
                        format!(
                            "soft bands apply to outputs; `{}` is not an output",
                            output.text
                        ),
                    )
                    .label("not an output")
                    .help(format!(
                        "declare `output {0} = ...` (an output may simply equal a state)",
                        output.text
                    )),
                );
                return None;
            }
            None => {
                self.unknown(output);
                return None;
            }
        };
        self.used.insert(output.text.clone());
        let (lo, hi) = self.band(band);
        if lo > hi {
            self.diags.push(
                Diagnostic::error(
                    "E008",
                    band.span,
                    format!("soft band on `{}` has lower {lo} > upper {hi}", output.text),
                )
                .label("empty band")
                .help("write the band as `in [lower, upper]`"),
            );
        }
        let wl = self.constant(weight_lo, "a weight").unwrap_or(f64::NAN);
        let wh = match weight_hi {
            Some(w) => self.constant(w, "a weight").unwrap_or(f64::NAN),
            None => wl,
        };
        // One weight for both sides is checked once.
        let weights = match weight_hi {
            Some(w_hi) => vec![(wl, weight_lo), (wh, w_hi)],
            None => vec![(wl, weight_lo)],
        };
        for (w, e) in weights {
            if w < 0.0 {
                self.diags.push(
                    Diagnostic::error("E007", e.span(), format!("penalty weight {w} is negative"))
                        .label("must be ≥ 0")
                        .help(
                            "a soft band penalises leaving it; its weights are non-negative prices",
                        ),
                );
            }
        }
        let (plo, phi) = match plan {
            Some(p) => {
                let (a, b) = self.band(p);
                let (plo, phi) = (a.max(lo), b.min(hi));
                if plo > phi {
                    self.diags.push(
                        Diagnostic::error(
                            "E008",
                            p.lo.as_ref().or(p.hi.as_ref()).map_or(p.span, |e| e.span()),
                            format!(
                                "planning band on `{}` is empty inside [{lo}, {hi}]",
                                output.text
                            ),
                        )
                        .label("empty planning band")
                        .help("a planning band is a tighter band inside the soft band"),
                    );
                }
                (plo, phi)
            }
            None => (lo, hi),
        };
        Some(SoftBand {
            output: index,
            lower: lo,
            upper: hi,
            weight_below: wl,
            weight_above: wh,
            plan_lower: plo,
            plan_upper: phi,
            description: description.clone().unwrap_or_default(),
        })
    }

    fn band(&mut self, b: &Band) -> (f64, f64) {
        let lo = b.lo.as_ref().map_or(f64::NEG_INFINITY, |e| {
            self.constant(e, "a band limit").unwrap_or(f64::NAN)
        });
        let hi = b.hi.as_ref().map_or(f64::INFINITY, |e| {
            self.constant(e, "a band limit").unwrap_or(f64::NAN)
        });
        (lo, hi)
    }

    pub(super) fn sample(&mut self, s: Option<&Statement>) -> Sample {
        let Some(Statement {
            stmt:
                Stmt::Sample {
                    period,
                    unit,
                    integrator,
                    substeps,
                    plan_substeps,
                    span,
                },
            ..
        }) = s
        else {
            self.diags.push(
                Diagnostic::error("E012", Span::default(), "the model has no `sample` statement")
                    .label("")
                    .help("add e.g. `sample 1800 [s] integrator rk4 substeps 4` to set the control period"),
            );
            return Sample {
                period: f64::NAN,
                integrator: Integrator::Rk4,
                substeps: 1,
                plan_substeps: 1,
            };
        };
        let mut p = self
            .constant(period, "the sample period")
            .unwrap_or(f64::NAN);
        let factor = match unit.as_deref().map(str::trim) {
            None | Some("s") => 1.0,
            Some("min") => 60.0,
            Some("h") => 3600.0,
            Some(other) => {
                self.diags.push(
                    Diagnostic::error("E017", *span, format!("unknown time unit `[{other}]`"))
                        .label("here")
                        .help("use [s], [min] or [h]"),
                );
                1.0
            }
        };
        p *= factor;
        if p.is_nan() || p <= 0.0 {
            self.diags.push(
                Diagnostic::error("E017", period.span(), "the sample period must be positive")
                    .label("here")
                    .help("give the control period in seconds, e.g. `sample 1800 [s]`"),
            );
        } else if !(MIN_PERIOD_S..=MAX_PERIOD_S).contains(&p) {
            // A season is sized in steps of this period: outside the range it would have
            // billions of steps or none.
            self.diags.push(
                Diagnostic::error(
                    "E017",
                    period.span(),
                    format!(
                        "the sample period is {} s; it must be from {MIN_PERIOD_S} s to \
                         {MAX_PERIOD_S} s (one day)",
                        readable(p)
                    ),
                )
                .label("out of range")
                .help(
                    "give the control period in seconds, minutes or hours, e.g. `sample 30 [min]`",
                ),
            );
        }
        let integ = match integrator.as_ref().map(|n| (n.text.as_str(), n.span)) {
            None => Integrator::Rk4,
            Some((name, sp)) => Integrator::from_name(name).unwrap_or_else(|| {
                let known: Vec<String> = Integrator::ALL
                    .iter()
                    .map(|i| format!("`{}`", i.name()))
                    .collect();
                self.diags.push(
                    Diagnostic::error("E017", sp, format!("unknown integrator `{name}`"))
                        .label("unknown")
                        .help(format!("use one of {}", known.join(", "))),
                );
                Integrator::Rk4
            }),
        };
        let n = substeps
            .as_ref()
            .map_or(1, |e| self.substeps(e, "substeps 4"));
        Sample {
            period: p,
            integrator: integ,
            substeps: n,
            plan_substeps: plan_substeps
                .as_ref()
                .map_or(n, |e| self.substeps(e, "plan substeps 1")),
        }
    }

    /// A number of sub-steps (`substeps N`, `plan substeps M`): a whole number from 1 to
    /// 1000; 1 where it is not (with E017, `example` in its help).
    fn substeps(&mut self, e: &Expr, example: &str) -> usize {
        let v = self
            .constant(e, "the number of sub-steps")
            .unwrap_or(f64::NAN);
        if v >= 1.0 && v.fract() == 0.0 && v <= 1000.0 {
            return v as usize;
        }
        self.diags.push(
            Diagnostic::error(
                "E017",
                e.span(),
                format!("sub-steps must be a whole number from 1 to 1000, not {v}"),
            )
            .label("here")
            .help(format!("e.g. `{example}`")),
        );
        1
    }

    pub(super) fn uncertainty(&mut self, s: Option<&Statement>) -> Uncertainty {
        let mut u = Uncertainty::default();
        let Some(Statement {
            stmt: Stmt::Uncertainty { settings, .. },
            ..
        }) = s
        else {
            return u;
        };
        for (k, v) in settings {
            let ok = match (k.text.as_str(), v.text.as_str()) {
                ("redraw", "season") => {
                    u.redraw = Redraw::Season;
                    true
                }
                ("redraw", "step") => {
                    u.redraw = Redraw::Step;
                    true
                }
                ("params", "all") => {
                    u.all_params = true;
                    true
                }
                ("params", "marked") => {
                    u.all_params = false;
                    true
                }
                ("spread", num) => match num.parse::<f64>() {
                    Ok(x) if x > 0.0 && x.is_finite() => {
                        u.spread = x;
                        true
                    }
                    _ => false,
                },
                _ => false,
            };
            if !ok {
                self.diags.push(
                    Diagnostic::error("E016", k.span.to(v.span), format!("unknown uncertainty setting `{} = {}`", k.text, v.text))
                        .label("not understood")
                        .help("settings are `redraw = season|step`, `spread = <positive number>`, `params = marked|all`"),
                );
            }
        }
        u
    }

    /// The settings of every `solver` statement, a later one replacing an earlier.
    pub(super) fn solver_hints(&mut self, statements: &[Statement]) -> SolverHints {
        let mut hints = SolverHints::default();
        let settings = statements.iter().filter_map(|s| match &s.stmt {
            Stmt::Solver { settings, .. } => Some(settings),
            _ => None,
        });
        for (key, value) in settings.flatten() {
            match (key.text.as_str(), value.text.parse::<f64>()) {
                ("objective_scale", Ok(scale)) if scale > 0.0 && scale.is_finite() => {
                    hints.objective_scale = scale
                }
                ("objective_scale", _) => self.diags.push(
                    Diagnostic::error(
                        "E030",
                        value.span,
                        format!(
                            "the objective's scale must be a positive number, not `{}`",
                            value.text
                        ),
                    )
                    .label("not a positive number")
                    .help("e.g. `solver objective_scale = 1000` for stage costs around 1e-4"),
                ),
                ("rollout_push", Ok(push)) if push > 0.0 && push < 0.5 => {
                    hints.rollout_push = Some(push)
                }
                ("rollout_push", _) => self.diags.push(
                    Diagnostic::error(
                        "E030",
                        value.span,
                        format!(
                            "the roll-out's push must be a number between 0 and 0.5, not `{}`",
                            value.text
                        ),
                    )
                    .label("not in (0, 0.5)")
                    .help("e.g. `solver rollout_push = 1e-4` for a stiff plant"),
                ),
                _ => self.diags.push(
                    Diagnostic::error(
                        "E030",
                        key.span.to(value.span),
                        format!("unknown solver setting `{} = {}`", key.text, value.text),
                    )
                    .label("not understood")
                    .help("the settings are `objective_scale = <positive number>` and `rollout_push = <number in (0, 0.5)>`"),
                ),
            }
        }
        hints
    }
}
