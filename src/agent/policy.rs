//! A trained policy as a file: the deterministic actor `a = tanh(μ(ŝ))` as plain weights
//! ([`Mlp`]), the frozen observation statistics that standardise `ŝ`, and what it was
//! trained on. It is what `ghm train` ships and what `ghm policy`, the value data and
//! RL-guided MPC load; it needs no training framework to run, and it evaluates over dual
//! numbers, so an optimiser can differentiate through it.

use crate::agent::observation::ObservationLayout;
use crate::agent::{AgentError, Normalizer};
use crate::graph::Real;
use crate::lang::Model;
use crate::nn::Mlp;
use crate::report::atomic;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A deterministic policy and its observation statistics. See the [module
/// documentation](self).
///
/// Reading one from JSON checks that its parts fit each other: the actor's inputs, the
/// statistics and the observation names have one width, the action names (where recorded)
/// match the actor's outputs, and the evaluation reward is finite.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "PolicyData")]
pub struct PolicyFile {
    /// The model it was trained on (the model file's `model` name).
    pub model: String,
    /// Which observation the policy sees: version 1 (the current weather) or 2 (with
    /// forecast rows); left out of the file for version 1.
    #[serde(default, skip_serializing_if = "ObservationLayout::is_current_weather")]
    pub observation: ObservationLayout,
    /// The observation's entries, in order (outputs, previous inputs, step, weather, the
    /// forecast rows of version 2).
    pub observation_names: Vec<String>,
    /// The model's inputs the actions set, in order (empty in files written before ghm
    /// recorded them).
    #[serde(default)]
    pub action_names: Vec<String>,
    /// Frozen statistics for the observation.
    pub normalizer: Normalizer,
    /// Observation (standardised) → action in `[−1, 1]^nu` (tanh output).
    pub actor: Mlp,
    /// The training episode after which this policy was kept.
    pub episode: usize,
    /// Its evaluation reward then, if it was evaluated.
    pub eval_reward: Option<f64>,
}

/// The serialised form of a [`PolicyFile`], checked on the way in.
#[derive(Deserialize)]
struct PolicyData {
    model: String,
    #[serde(default)]
    observation: ObservationLayout,
    observation_names: Vec<String>,
    #[serde(default)]
    action_names: Vec<String>,
    normalizer: Normalizer,
    actor: Mlp,
    episode: usize,
    eval_reward: Option<f64>,
}

impl TryFrom<PolicyData> for PolicyFile {
    type Error = String;
    fn try_from(d: PolicyData) -> Result<PolicyFile, String> {
        let width = d.normalizer.width();
        if d.actor.inputs() != width || d.observation_names.len() != width {
            return Err(format!(
                "\"actor\" takes {} inputs, \"normalizer\" covers {width} and \"observation_names\" has {}; all three must agree",
                d.actor.inputs(),
                d.observation_names.len()
            ));
        }
        if !d.action_names.is_empty() && d.action_names.len() != d.actor.outputs() {
            return Err(format!(
                "\"actor\" sets {} inputs but \"action_names\" has {}",
                d.actor.outputs(),
                d.action_names.len()
            ));
        }
        if let Some(r) = d.eval_reward.filter(|r| !r.is_finite()) {
            return Err(format!("\"eval_reward\" is {r}, not a finite number"));
        }
        Ok(PolicyFile {
            model: d.model,
            observation: d.observation,
            observation_names: d.observation_names,
            action_names: d.action_names,
            normalizer: d.normalizer,
            actor: d.actor,
            episode: d.episode,
            eval_reward: d.eval_reward,
        })
    }
}

impl PolicyFile {
    /// The action for a raw observation, over any dual number type: the observation is
    /// standardised and clipped as in training (the clip's derivative is zero outside).
    ///
    /// ```
    /// use ghm::agent::PolicyFile;
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
    pub fn action<T: Real>(&self, observation: &[T]) -> Result<Vec<T>, AgentError> {
        let width = self.normalizer.width();
        if observation.len() != width {
            return Err(AgentError::ObservationWidth {
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
            .map_err(|e| AgentError::Network(e.to_string()))
    }

    /// Writes the policy as JSON, atomically (see [`atomic`]).
    pub fn save(&self, path: &Path) -> Result<(), AgentError> {
        let fail = |reason: String| AgentError::PolicyFile {
            path: path.to_path_buf(),
            reason,
        };
        let text = serde_json::to_string(self).map_err(|e| fail(e.to_string()))?;
        atomic::write(path, text).map_err(|e| fail(format!("cannot write: {e}")))
    }

    /// Reads a policy written by [`PolicyFile::save`] and checks that its parts fit; an
    /// error names the file and the field.
    pub fn load(path: &Path) -> Result<PolicyFile, AgentError> {
        let fail = |reason: String| AgentError::PolicyFile {
            path: path.to_path_buf(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| fail(format!("cannot read: {e}")))?;
        serde_json::from_str(&text).map_err(|e| fail(format!("not a valid policy file: {e}")))
    }

    /// Checks that the policy was made for `model`'s observation and inputs (by name and
    /// order; the action names only where the file records them). A policy trained on a
    /// model of another name but with the same observation and inputs passes: the caller
    /// may warn about the name.
    pub fn check_fits(&self, model: &Model, path: &Path) -> Result<(), AgentError> {
        let fail = |reason: String| AgentError::PolicyFile {
            path: path.to_path_buf(),
            reason,
        };
        let observation = self.observation.names(model);
        if self.observation_names != observation {
            return Err(fail(format!(
                "\"observation_names\" are [{}]; model `{}` observes [{}] in observation \
                 version {}",
                self.observation_names.join(", "),
                model.name,
                observation.join(", "),
                self.observation.version()
            )));
        }
        let inputs: Vec<&str> = model.inputs.iter().map(|u| u.info.name.as_str()).collect();
        let recorded = !self.action_names.is_empty();
        if self.actor.outputs() != inputs.len() || (recorded && self.action_names != inputs) {
            return Err(fail(format!(
                "the policy sets {} inputs [{}]; model `{}` has [{}]",
                self.actor.outputs(),
                self.action_names.join(", "),
                model.name,
                inputs.join(", ")
            )));
        }
        Ok(())
    }
}
