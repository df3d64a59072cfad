//! A trained policy as a file: the deterministic actor `a = tanh(μ(ŝ))` as plain weights
//! ([`Mlp`]), the frozen observation statistics that standardise `ŝ`, and what it was
//! trained on. It is what `ghm train` ships and what `ghm policy`, the value data and
//! RL-guided MPC load; it needs no training framework to run, and it evaluates over dual
//! numbers, so an optimiser can differentiate through it.

use crate::graph::Real;
use crate::nn::Mlp;
use crate::rl::{Normalizer, RlError};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A deterministic policy and its observation statistics. See the [module
/// documentation](self).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolicyFile {
    /// The model it was trained on (the model file's `model` name).
    pub model: String,
    /// The observation's entries, in order (outputs, previous inputs, step, weather).
    pub observation_names: Vec<String>,
    /// Frozen statistics for the observation.
    pub normalizer: Normalizer,
    /// Observation (standardised) → action in `[−1, 1]^nu` (tanh output).
    pub actor: Mlp,
    /// The training episode after which this policy was kept.
    pub episode: usize,
    /// Its evaluation reward then, if it was evaluated.
    pub eval_reward: Option<f64>,
}

impl PolicyFile {
    /// The action for a raw observation, over any dual number type: the observation is
    /// standardised and clipped as in training (the clip's derivative is zero outside).
    ///
    /// ```
    /// use ghm::rl::PolicyFile;
    /// use num_dual::{first_derivative, DualNum};
    ///
    /// let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/agents/lettuce");
    /// let policy = PolicyFile::load(&dir.join("policy.json")).unwrap();
    /// // The season's first observation: outputs, previous input, step, weather.
    /// let s: [f64; 12] = [0.0035, 537.26, 15.0, 62.644, 0.0, 0.0, 50.0, 0.0, 0.0, 8.6333e-4, 5.6, 5.4981e-3];
    /// let a = policy.action(&s).unwrap();
    /// assert_eq!(a.len(), 3);
    /// assert!(a.iter().all(|v| v.abs() <= 1.0));
    /// // ∂a₃/∂T (heating action against indoor temperature), exactly, through the network.
    /// let (_, slope): (f64, f64) = first_derivative(
    ///     |t| {
    ///         let mut o: Vec<_> = s.iter().map(|v| DualNum::from_re(*v)).collect();
    ///         o[2] = t;
    ///         policy.action(&o).unwrap()[2]
    ///     },
    ///     15.0f64,
    /// );
    /// assert!(slope.is_finite());
    /// ```
    pub fn action<T: Real>(&self, observation: &[T]) -> Result<Vec<T>, RlError> {
        let width = self.normalizer.width();
        if observation.len() != width {
            return Err(RlError::ObservationWidth {
                given: observation.len(),
                expected: width,
            });
        }
        let clip = self.normalizer.clip();
        let eps = self.normalizer.epsilon();
        let standard: Vec<T> = observation
            .iter()
            .zip(self.normalizer.mean().iter().zip(self.normalizer.var()))
            .map(|(s, (m, v))| {
                let z = (*s - *m) / (v + eps).sqrt();
                if z.re() > clip {
                    T::from(clip)
                } else if z.re() < -clip {
                    T::from(-clip)
                } else {
                    z
                }
            })
            .collect();
        self.actor
            .try_forward(&standard)
            .map_err(|e| RlError::Backend(e.to_string()))
    }

    /// Writes the policy as JSON.
    pub fn save(&self, path: &Path) -> Result<(), RlError> {
        let fail = |why: String| RlError::Checkpoint {
            path: path.display().to_string(),
            why,
        };
        let text = serde_json::to_string(self).map_err(|e| fail(e.to_string()))?;
        std::fs::write(path, text).map_err(|e| fail(e.to_string()))
    }

    /// Reads a policy written by [`PolicyFile::save`] and checks that its parts fit.
    pub fn load(path: &Path) -> Result<PolicyFile, RlError> {
        let fail = |why: String| RlError::Checkpoint {
            path: path.display().to_string(),
            why,
        };
        let text = std::fs::read_to_string(path).map_err(|e| fail(e.to_string()))?;
        let policy: PolicyFile =
            serde_json::from_str(&text).map_err(|e| fail(format!("not a policy file: {e}")))?;
        if policy.actor.inputs() != policy.normalizer.width()
            || policy.observation_names.len() != policy.normalizer.width()
        {
            return Err(fail(format!(
                "the actor takes {} inputs, the statistics cover {} and {} observation names are given",
                policy.actor.inputs(),
                policy.normalizer.width(),
                policy.observation_names.len()
            )));
        }
        Ok(policy)
    }
}
