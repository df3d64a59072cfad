//! Fitting a value network to (features → return) data: the regression of RL-guided
//! MPC's terminal cost (spec §12, reference numbers §4), its gradient steps written out
//! ([`regression`](crate::rl::regression)).
//!
//! A tanh perceptron with Xavier-uniform weights and zero biases, trained with Adam on the
//! mean squared error, the learning rate decaying linearly to zero, mini-batches drawn by
//! shuffling the training part each epoch, and a fixed validation part (a seeded random
//! split). Targets are standardised for training (mean 0, variance 1) and the network is
//! returned with the map back to return units, so the losses reported are in squared
//! return units, comparable with the paper's.

use crate::nn::scaled::{check_box, normalise_into_box};
use crate::nn::{Activation, ScaledMlp};
use crate::rl::regression::{zero_gradients, OutputMap, Regression};
use crate::rl::sac::adam::Adam;
use crate::rl::sac::net::Net;
use crate::rl::{AgentError, RlError};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Regression settings. The defaults reach a lower validation error than the paper's
/// (Adam at 1e-3, batches of 1024, 200 epochs) on the shipped agents' value data in
/// half the passes (`docs/benchmarks.md`, "Value networks").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValueFitConfig {
    /// Hidden layer widths of the tanh network.
    pub hidden: Vec<usize>,
    /// Initial Adam learning rate, decaying linearly towards zero over all batches.
    pub learning_rate: f64,
    /// Points per gradient step.
    pub batch_size: usize,
    /// Passes over the training points.
    pub epochs: usize,
    /// Fraction of the points held out for validation.
    pub validation: f64,
    /// Seed of the initialisation, the validation split and the shuffles.
    pub seed: u64,
}

impl Default for ValueFitConfig {
    fn default() -> ValueFitConfig {
        ValueFitConfig {
            hidden: vec![128, 128],
            learning_rate: 3e-3,
            batch_size: 256,
            epochs: 100,
            validation: 0.2,
            seed: 4,
        }
    }
}

/// One epoch of the learning curve, losses in squared return units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EpochLoss {
    /// The epoch, 1-based.
    pub epoch: usize,
    /// Mean squared error over the epoch's training batches, as the network moved.
    pub train: f64,
    /// Mean squared error on the held-out points after the epoch (NaN when none are
    /// held out).
    pub validation: f64,
}

/// Fits a value network to `features` (row-major, `width` per point, inside the box
/// `[lower, upper]`) and `targets`. `on_epoch` sees each epoch's losses.
///
/// # Examples
///
/// A small network fitted to a return-to-go that falls linearly with the step and rises
/// with the state, `V = 10 x + (100 − k)/10`, in a fraction of a second:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::rl::value_fit::{fit_value, ValueFitConfig};
///
/// let (mut features, mut targets) = (Vec::new(), Vec::new());
/// for i in 0..200 {
///     let (x, k) = (0.1 * (i % 10) as f64, (i / 2) as f64);
///     features.extend([x, k]);
///     targets.push(10.0 * x + (100.0 - k) / 10.0);
/// }
/// let config = ValueFitConfig {
///     hidden: vec![16],
///     learning_rate: 1e-2,
///     batch_size: 32,
///     epochs: 100,
///     ..Default::default()
/// };
/// let mut epochs = 0;
/// let (value, curve) = fit_value(
///     &features, 2, &targets, &[0.0, 0.0], &[1.0, 100.0], &config, &mut |_| epochs += 1,
/// )?;
/// assert_eq!((curve.len(), epochs), (100, 100));
/// let mean = targets.iter().sum::<f64>() / 200.0;
/// let variance = targets.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / 200.0;
/// // Losses are in squared return units: far below the targets' own spread.
/// assert!(curve[99].validation < curve[0].validation);
/// assert!(curve[99].validation < 0.01 * variance, "{:?} against {variance}", curve[99]);
/// // The network maps raw (x, k) to return units.
/// let v: f64 = value.evaluate(&[0.5, 50.0]);
/// assert!((v - 10.0).abs() < 1.0, "{v}");
/// # Ok(())
/// # }
/// ```
pub fn fit_value(
    features: &[f64],
    width: usize,
    targets: &[f64],
    lower: &[f64],
    upper: &[f64],
    config: &ValueFitConfig,
    on_epoch: &mut dyn FnMut(&EpochLoss),
) -> Result<(ScaledMlp, Vec<EpochLoss>), RlError> {
    let n = targets.len();
    if width == 0 || features.len() != n * width {
        return Err(AgentError::BatchShape {
            len: features.len(),
            width,
        }
        .into());
    }
    if n < 10 || config.batch_size == 0 || config.epochs == 0 {
        return Err(RlError::BadConfig {
            name: "value data",
            why: format!(
                "{n} points, batch {}, {} epochs: need at least 10 points, a batch and an epoch",
                config.batch_size, config.epochs
            ),
        });
    }
    let mean = targets.iter().sum::<f64>() / n as f64;
    let var = targets.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / n as f64;
    let std = var.sqrt().max(1e-12);
    check_box(lower, upper, width).map_err(|e| RlError::BadConfig {
        name: "value input box",
        why: e.to_string(),
    })?;
    // Inputs through the same box map the network will use.
    let mut widths = vec![width];
    widths.extend_from_slice(&config.hidden);
    widths.push(1);
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let mut net = Net::init_xavier(&widths, Activation::Tanh, &mut rng);
    let z: Vec<f32> = features
        .chunks(width)
        .flat_map(|row| normalise_into_box(row, lower, upper))
        .map(|v| v as f32)
        .collect();
    let y: Vec<f32> = targets.iter().map(|t| ((t - mean) / std) as f32).collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.shuffle(&mut rng);
    let n_val = ((n as f64 * config.validation).round() as usize).min(n - 1);
    let (validation, train) = order.split_at(n_val);
    let mut train = train.to_vec();
    let mut gradients = zero_gradients(&net);
    let lengths: Vec<usize> = gradients.iter().map(Vec::len).collect();
    let mut adam = Adam::new(&lengths);
    let batches_per_epoch = train.len().div_ceil(config.batch_size);
    let total_steps = (batches_per_epoch * config.epochs) as f64;
    let mut step = 0usize;
    let mut curve = Vec::with_capacity(config.epochs);
    let mut regression = Regression::new();
    let (mut zb, mut yb) = (Vec::new(), Vec::new());
    let gather = |rows: &[usize], zb: &mut Vec<f32>, yb: &mut Vec<f32>| {
        zb.clear();
        yb.clear();
        for &r in rows {
            zb.extend_from_slice(&z[r * width..(r + 1) * width]);
            yb.push(y[r]);
        }
    };
    for epoch in 1..=config.epochs {
        train.shuffle(&mut rng);
        let mut train_sum = 0.0;
        for rows in train.chunks(config.batch_size) {
            let lr = (config.learning_rate * (1.0 - step as f64 / total_steps)) as f32;
            step += 1;
            gather(rows, &mut zb, &mut yb);
            let loss = regression.step(&net, OutputMap::Linear, &zb, &yb, &mut gradients);
            train_sum += f64::from(loss) * rows.len() as f64;
            adam.step(lr, net.parameters_mut(), &gradients);
        }
        let train_loss = train_sum / train.len() as f64 * var;
        let validation_loss = if validation.is_empty() {
            f64::NAN
        } else {
            let mut sum = 0.0;
            for rows in validation.chunks(8192) {
                gather(rows, &mut zb, &mut yb);
                let predicted = regression.predict(&net, OutputMap::Linear, &zb);
                sum += predicted
                    .iter()
                    .zip(&yb)
                    .map(|(p, t)| f64::from(p - t).powi(2))
                    .sum::<f64>();
            }
            sum / validation.len() as f64 * var
        };
        if !train_loss.is_finite() {
            return Err(RlError::Backend(format!(
                "the value fit diverged at epoch {epoch}"
            )));
        }
        let record = EpochLoss {
            epoch,
            train: train_loss,
            validation: validation_loss,
        };
        on_epoch(&record);
        curve.push(record);
    }
    let mlp = net
        .to_mlp(Activation::Identity)
        .map_err(|e| RlError::Backend(e.to_string()))?;
    let fitted = ScaledMlp::new(mlp, lower.to_vec(), upper.to_vec(), mean, std)
        .map_err(|e| RlError::Backend(e.to_string()))?;
    Ok((fitted, curve))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_a_smooth_function_and_maps_back_to_raw_units() {
        // v(x, k) = 3 + 2 sin(x) − k/10 on x ∈ [0, 3], k ∈ [0, 10].
        let mut features = Vec::new();
        let mut targets = Vec::new();
        for i in 0..40 {
            for k in 0..11 {
                let x = 3.0 * i as f64 / 39.0;
                features.extend([x, k as f64]);
                targets.push(3.0 + 2.0 * x.sin() - k as f64 / 10.0);
            }
        }
        let config = ValueFitConfig {
            hidden: vec![32, 32],
            learning_rate: 1e-2,
            batch_size: 64,
            epochs: 150,
            ..ValueFitConfig::default()
        };
        let (net, curve) = fit_value(
            &features,
            2,
            &targets,
            &[0.0, 0.0],
            &[3.0, 10.0],
            &config,
            &mut |_| {},
        )
        .unwrap();
        let last = curve.last().unwrap();
        assert!(last.train < 2e-3 && last.validation < 5e-3, "{last:?}");
        let v = net.evaluate(&[1.0f64, 4.0]);
        assert!((v - (3.0 + 2.0 * 1.0f64.sin() - 0.4)).abs() < 0.1, "{v}");
    }
}
