//! The numbers of a step, named as the model names them, so that a NaN or an infinity can
//! be reported where it is made: "output `y` (m.ghm:5:8) is NaN", not "entry 3".
//!
//! It names and finds; deciding to stop a season is the season loop's job.

use crate::model::Plant;

/// One number of a step, by its place in the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// State `i` after the step.
    State(usize),
    /// Input `i` as the controller asked for it.
    Input(usize),
    /// Stage term `i`, an index into [`Plant::stage_term_index`].
    Term(usize),
    /// Output `i` observed before the step (at `x(k)`).
    Output(usize),
    /// Output `i` after the step (at `x(k+1)`).
    NextOutput(usize),
    /// The penalty of soft band `i`.
    Penalty(usize),
    /// The step's reward (economic terms minus penalties).
    Reward,
    /// The season's reward so far.
    CumulativeReward,
}

impl Plant {
    /// The quantity as a person finds it in the model file.
    ///
    /// ```
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use ghm::model::{finite::Quantity, Plant};
    ///
    /// let text = "sample 60 [s]\nstate level = 1\nder level = -level\noutput h = sqrt(level - 2)\n";
    /// let plant = Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?);
    /// assert_eq!(plant.describe(Quantity::Output(0)), "output `h` (tank.ghm:4:8)");
    /// assert_eq!(plant.describe(Quantity::State(0)), "state `level` (tank.ghm:2:7) after the step");
    /// # Ok(())
    /// # }
    /// ```
    pub fn describe(&self, q: Quantity) -> String {
        let m = &self.model;
        let named = |kind: &str, info: &crate::lang::model::Info| match m.location(info) {
            Some(at) => format!("{kind} `{}` ({at})", info.name),
            None => format!("{kind} `{}`", info.name),
        };
        match q {
            Quantity::State(i) => format!("{} after the step", named("state", &m.states[i].info)),
            Quantity::Input(i) => named("input", &m.inputs[i].info),
            Quantity::Term(i) => {
                let t = &m.terms[self.stage_term_index[i]];
                named(t.kind.keyword(), &t.info)
            }
            Quantity::Output(i) => named("output", &m.outputs[i].info),
            Quantity::NextOutput(i) => {
                format!("{} after the step", named("output", &m.outputs[i].info))
            }
            Quantity::Penalty(b) => format!(
                "the penalty of the soft band on {}",
                named("output", &m.outputs[m.soft[b].output].info)
            ),
            Quantity::Reward => "the step's reward".to_string(),
            Quantity::CumulativeReward => "the cumulative reward".to_string(),
        }
    }
}

impl Plant {
    /// The quantity of row `row` of the step tape's outputs `(x⁺, stage terms, y(x⁺))`.
    pub fn step_quantity(&self, row: usize) -> Quantity {
        let (nx, nt) = (self.layout.nx, self.stage_terms.len());
        if row < nx {
            Quantity::State(row)
        } else if row < nx + nt {
            Quantity::Term(row - nx)
        } else {
            Quantity::NextOutput(row - nx - nt)
        }
    }

    /// Variable `i` of `(x, u)`, the variables a step is differentiated against, by name.
    pub fn describe_variable(&self, i: usize) -> String {
        let nx = self.layout.nx;
        if i < nx {
            format!("state `{}`", self.model.states[i].info.name)
        } else {
            format!("input `{}`", self.model.inputs[i - nx].info.name)
        }
    }
}

/// The first entry of `values` that is NaN or infinite, as `(quantity(i), value)`.
///
/// ```
/// use ghm::model::finite::{first_non_finite, Quantity};
///
/// assert_eq!(first_non_finite(&[1.0, 2.0], Quantity::State), None);
/// let found = first_non_finite(&[1.0, f64::INFINITY, f64::NAN], Quantity::Input);
/// assert_eq!(found, Some((Quantity::Input(1), f64::INFINITY)));
/// ```
pub fn first_non_finite(
    values: &[f64],
    quantity: impl Fn(usize) -> Quantity,
) -> Option<(Quantity, f64)> {
    values
        .iter()
        .position(|v| !v.is_finite())
        .map(|i| (quantity(i), values[i]))
}
