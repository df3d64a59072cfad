//! A network with affine maps on both sides: inputs mapped from a box `[lower, upper]` to
//! `[−5, 5]` (the value network's normalisation of the paper, spec §12) and the output
//! mapped back from standardised units, `y = offset + scale · net(z)`.

use crate::graph::Real;
use crate::nn::{Mlp, NnError};
use serde::{Deserialize, Serialize};

/// Half-width of the normalised input range.
pub const INPUT_HALF_RANGE: f64 = 5.0;

/// An [`Mlp`] between an input box and an affine output map. See the [module
/// documentation](self).
///
/// ```
/// use ghm::nn::{Activation, Dense, Mlp, ScaledMlp};
/// // net(z) = z₀: the output is offset + scale · z₀ with z₀ = 10 (v₀ − 0)/(2 − 0) − 5.
/// let layer = Dense { inputs: 1, outputs: 1, weight: vec![1.0], bias: vec![0.0] };
/// let net = Mlp::new(vec![layer], Activation::Tanh, Activation::Identity).unwrap();
/// let v = ScaledMlp::new(net, vec![0.0], vec![2.0], 3.0, 0.5).unwrap();
/// assert!((v.evaluate(&[1.0f64]) - 3.0).abs() < 1e-15); // the middle of the box → z = 0
/// assert!((v.evaluate(&[2.0f64]) - 5.5).abs() < 1e-15); // the top → z = 5
/// ```
///
/// Reading one from JSON checks it as [`ScaledMlp::new`] does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ScaledMlpData")]
pub struct ScaledMlp {
    /// The network, in normalised units on both sides.
    pub net: Mlp,
    /// Raw input values mapped to `−5`, one per input.
    pub input_lower: Vec<f64>,
    /// Raw input values mapped to `+5`, one per input; each above its lower value.
    pub input_upper: Vec<f64>,
    /// Added to the scaled network output: `y = offset + scale · net(z)`.
    pub output_offset: f64,
    /// Multiplies the network output: `y = offset + scale · net(z)`.
    pub output_scale: f64,
}

/// The serialised form of a [`ScaledMlp`], checked on the way in.
#[derive(Deserialize)]
struct ScaledMlpData {
    net: Mlp,
    input_lower: Vec<f64>,
    input_upper: Vec<f64>,
    output_offset: f64,
    output_scale: f64,
}

impl TryFrom<ScaledMlpData> for ScaledMlp {
    type Error = NnError;
    fn try_from(d: ScaledMlpData) -> Result<ScaledMlp, NnError> {
        ScaledMlp::new(
            d.net,
            d.input_lower,
            d.input_upper,
            d.output_offset,
            d.output_scale,
        )
    }
}

impl ScaledMlp {
    /// Checks that the box fits the network and is not empty.
    pub fn new(
        net: Mlp,
        input_lower: Vec<f64>,
        input_upper: Vec<f64>,
        output_offset: f64,
        output_scale: f64,
    ) -> Result<ScaledMlp, NnError> {
        let s = ScaledMlp {
            net,
            input_lower,
            input_upper,
            output_offset,
            output_scale,
        };
        s.validate()?;
        Ok(s)
    }

    /// The checks of [`ScaledMlp::new`], for values read from a file.
    pub fn validate(&self) -> Result<(), NnError> {
        check_box(&self.input_lower, &self.input_upper, self.net.inputs())?;
        for (field, value) in [
            ("output_offset", self.output_offset),
            ("output_scale", self.output_scale),
        ] {
            if !value.is_finite() {
                return Err(NnError::Scaling {
                    field,
                    reason: format!("{value} is not finite"),
                });
            }
        }
        Ok(())
    }

    /// `z = 10 (v − lower)/(upper − lower) − 5` for one raw input.
    pub fn normalise<T: Real>(&self, raw: &[T]) -> Vec<T> {
        normalise_into_box(raw, &self.input_lower, &self.input_upper)
    }

    /// The first output at the raw input `raw`, over any dual number type.
    pub fn evaluate<T: Real>(&self, raw: &[T]) -> T {
        let z = self.normalise(raw);
        self.net.forward(&z)[0] * self.output_scale + self.output_offset
    }

    /// The first output at `raw` with its first and second derivatives with respect to
    /// raw input `i`, by [`Mlp::forward_second_along`].
    pub fn evaluate_second(&self, raw: &[f64], i: usize) -> (f64, f64, f64) {
        let z = self.normalise(raw);
        let mut tangent = vec![0.0; z.len()];
        tangent[i] = box_gain(self.input_lower[i], self.input_upper[i]);
        let (v, d, d2) = self.net.forward_second_along(&z, &tangent);
        (
            v * self.output_scale + self.output_offset,
            d * self.output_scale,
            d2 * self.output_scale,
        )
    }
}

/// `z = 10 (v − lower)/(upper − lower) − 5`, component-wise: the input map of
/// [`ScaledMlp`], for callers that have the box but no network yet (a fit).
pub fn normalise_into_box<T: Real>(raw: &[T], lower: &[f64], upper: &[f64]) -> Vec<T> {
    raw.iter()
        .zip(lower.iter().zip(upper))
        .map(|(v, (l, u))| (*v - *l) * box_gain(*l, *u) - T::from(INPUT_HALF_RANGE))
        .collect()
}

/// `∂z/∂v` of the input map: `10 / (upper − lower)`.
fn box_gain(lower: f64, upper: f64) -> f64 {
    2.0 * INPUT_HALF_RANGE / (upper - lower)
}

/// Checks an input box for `width` inputs: the right length, finite, `upper > lower`.
pub fn check_box(lower: &[f64], upper: &[f64], width: usize) -> Result<(), NnError> {
    for (field, bound) in [("input_lower", lower), ("input_upper", upper)] {
        if bound.len() != width {
            return Err(NnError::Scaling {
                field,
                reason: format!("{} values for a network of {width} inputs", bound.len()),
            });
        }
    }
    match lower
        .iter()
        .zip(upper)
        .position(|(l, u)| !(l.is_finite() && u.is_finite() && u > l))
    {
        Some(i) => Err(NnError::Scaling {
            field: "input_upper",
            reason: format!(
                "input {i}: the box [{}, {}] is not finite or is empty (each upper value must be above its input_lower)",
                lower[i], upper[i]
            ),
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nn::{Activation, Dense};
    use num_dual::{second_derivative, DualNum};

    #[test]
    fn the_second_order_pass_takes_the_input_map_into_account() {
        let layer = Dense {
            inputs: 2,
            outputs: 2,
            weight: vec![0.7, -0.4, 0.2, 0.9],
            bias: vec![0.1, -0.3],
        };
        let out = Dense {
            inputs: 2,
            outputs: 1,
            weight: vec![1.5, -0.8],
            bias: vec![0.05],
        };
        let net = Mlp::new(vec![layer, out], Activation::Tanh, Activation::Identity).unwrap();
        let v = ScaledMlp::new(net, vec![0.0, 0.0], vec![0.5, 1920.0], 1.9, 1.3).unwrap();
        for (raw, i) in [([0.1, 300.0], 0), ([0.45, 1700.0], 1)] {
            let (f, d, d2) = v.evaluate_second(&raw, i);
            let (rf, rd, rd2) = second_derivative(
                |s| {
                    let mut input = [DualNum::from_re(raw[0]), DualNum::from_re(raw[1])];
                    input[i] = s;
                    v.evaluate(&input)
                },
                raw[i],
            );
            for (a, b) in [(f, rf), (d, rd), (d2, rd2)] {
                assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "{a} vs {b}");
            }
            assert!(d != 0.0 && d2 != 0.0);
        }
    }
}
