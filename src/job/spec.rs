//! What a season job runs, as plain data: the model, the weather slice, the plant and the
//! controller. The command-line flags map onto these types one for one (the choice enums
//! are the flags' values), and a study file spells them in TOML.

use crate::job::weather::WeatherSpec;
use clap::ValueEnum;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// One season: which model, on which weather and plant, under which controller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// The model file (.ghm).
    pub model: PathBuf,
    /// The weather source and the season's slice of it.
    #[serde(default)]
    pub weather: WeatherSpec,
    /// The plant's parametric uncertainty (the controllers predict with the nominal model).
    #[serde(default)]
    pub plant: PlantSpec,
    /// What decides the inputs.
    pub controller: ControllerSpec,
}

/// The plant's parametric uncertainty. Controllers keep predicting with the nominal model.
#[derive(Debug, Clone, PartialEq, clap::Args, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlantSpec {
    /// Parametric uncertainty δ of the plant (relative half-width; the model file says which
    /// parameters and how often they are redrawn). 0 = the nominal, deterministic plant;
    /// controllers predict with the nominal model either way.
    #[arg(long, value_name = "DELTA", default_value_t = 0.0)]
    pub uncertainty: f64,
    /// Seed of the parameter draws.
    #[arg(long, value_name = "S", default_value_t = 4)]
    pub seed: u64,
}

impl Default for PlantSpec {
    fn default() -> Self {
        PlantSpec {
            uncertainty: 0.0,
            seed: 4,
        }
    }
}

impl PlantSpec {
    /// The nominal, deterministic plant.
    pub const NOMINAL: PlantSpec = PlantSpec {
        uncertainty: 0.0,
        seed: 0,
    };

    /// The parameter draws, `None` for the nominal plant.
    pub fn draw(&self) -> Result<Option<crate::sim::season::UncertaintyDraw>, super::JobError> {
        if !(self.uncertainty >= 0.0 && self.uncertainty < 1.0) {
            return Err(super::JobError::Spec(
                "--uncertainty must be in [0, 1)".into(),
            ));
        }
        Ok(
            (self.uncertainty > 0.0).then_some(crate::sim::season::UncertaintyDraw {
                delta: self.uncertainty,
                seed: self.seed,
            }),
        )
    }
}

/// What decides a season's inputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ControllerSpec {
    /// Fixed inputs: `const:u1,u2,...`, a CSV file with one row per step, or (none) the
    /// model's start input.
    Inputs {
        /// `const:...` or a CSV path; `None` is the start input.
        #[serde(default)]
        inputs: Option<String>,
        /// Clip the inputs to their bounds and rate limits (`--no-rate-limit` turns it off).
        #[serde(default = "yes")]
        enforce_limits: bool,
    },
    /// The rule-based expert.
    Expert,
    /// A trained deterministic policy: a `ghm train` folder or a policy file, or (none) the
    /// agent shipped for the model.
    Policy {
        /// The agent folder or file.
        #[serde(default)]
        agent: Option<PathBuf>,
    },
    /// Economic MPC.
    Mpc(MpcSpec),
    /// RL-guided MPC.
    Rlmpc(RlmpcSpec),
    /// The season as one NLP with perfect foresight, scored like any controller (always on
    /// the nominal plant).
    Optimum(OptimumSpec),
}

fn yes() -> bool {
    true
}

/// Economic MPC: the horizon, the NLP back-end and the bands it plans with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MpcSpec {
    /// `3h`, `90min`, `5400s` or a number of steps.
    pub horizon: String,
    /// The NLP back-end.
    #[serde(default)]
    pub solver: SolverChoice,
    /// How each step restarts from the last one's solution; `None`: the back-end's choice.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warm_start: Option<WarmStartChoice>,
    /// The soft-band bounds to plan with.
    #[serde(default)]
    pub bands: BandsChoice,
}

/// RL-guided MPC: MPC plus a guide, its value network, the terminal region and the form of
/// the terminal cost.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RlmpcSpec {
    /// `1h`, `90min`, `1800s` or a number of steps.
    pub horizon: String,
    /// The NLP back-end.
    #[serde(default)]
    pub solver: SolverChoice,
    /// How each step restarts from the last one's solution; `None`: the back-end's choice.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warm_start: Option<WarmStartChoice>,
    /// The soft-band bounds to plan with.
    #[serde(default)]
    pub bands: BandsChoice,
    /// The guide.
    #[serde(default)]
    pub guide: GuideChoice,
    /// The SAC agent (folder or policy file); `None`: the shipped one.
    #[serde(default)]
    pub agent: Option<PathBuf>,
    /// The value network (folder or value.json); `None`: the shipped one for the guide.
    #[serde(default)]
    pub value: Option<PathBuf>,
    /// With or without the terminal region.
    #[serde(default)]
    pub variant: Variant,
    /// Relative half-width ε of the terminal region.
    #[serde(default = "default_epsilon")]
    pub epsilon: f64,
    /// The terminal cost's form.
    #[serde(default)]
    pub terminal_cost: CostForm,
}

fn default_epsilon() -> f64 {
    0.05
}

impl RlmpcSpec {
    /// The MPC under the guidance.
    pub fn mpc(&self) -> MpcSpec {
        MpcSpec {
            horizon: self.horizon.clone(),
            solver: self.solver,
            warm_start: self.warm_start,
            bands: self.bands,
        }
    }

    /// The controller's name in tables: `RL-MPC (sac)`, `RL-MPC-VFO (expert)`.
    pub fn label(&self) -> String {
        let variant = match self.variant {
            Variant::Rlmpc => "RL-MPC",
            Variant::Vfo => "RL-MPC-VFO",
        };
        format!("{variant} ({})", self.guide.name())
    }
}

/// The season optimum: initialised from a closed loop of MPC, solved as one NLP.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptimumSpec {
    /// The horizon of the initialising MPC.
    #[serde(default = "default_init_horizon")]
    pub init_horizon: String,
    /// The NLP back-end; `None`: IPOPT where built with it, otherwise `ipm`.
    #[serde(default)]
    pub solver: Option<SolverChoice>,
    /// The season NLP's iteration limit.
    #[serde(default = "default_optimum_iterations")]
    pub max_iterations: usize,
}

fn default_init_horizon() -> String {
    "1h".into()
}

fn default_optimum_iterations() -> usize {
    500
}

/// The NLP back-ends.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SolverChoice {
    /// Pure-Rust interior point, stage by stage (Riccati recursion), exact Hessian.
    #[default]
    Ipm,
    /// Pure-Rust SQP with clarabel sub-problems.
    Sqp,
    /// The system's IPOPT (needs a build with `--features ipopt`).
    Ipopt,
}

/// How each MPC step restarts the back-end from the last step's solution, shifted by one
/// step ([`crate::solve::WarmStart`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WarmStartChoice {
    /// The shifted primal point (under guidance with the constraint multipliers); bound
    /// multipliers and barrier afresh (the interior point's default: six to twelve
    /// iterations every step, none much longer).
    Primal,
    /// The shifted primal point and multipliers (SQP's and IPOPT's default; the interior
    /// point's fewest iterations in the median, 20–40 where the active set changes).
    PrimalDual,
    /// The shifted primal point with its constraint multipliers for plain MPC too, again
    /// without them where the Hessian keeps needing corrections (the interior point: a
    /// quarter fewer iterations than `primal`).
    PrimalMultipliers,
}

impl WarmStartChoice {
    /// The solver layer's restart.
    pub fn restart(self) -> crate::solve::WarmStart {
        match self {
            WarmStartChoice::Primal => crate::solve::WarmStart::Primal,
            WarmStartChoice::PrimalDual => crate::solve::WarmStart::PrimalDual,
            WarmStartChoice::PrimalMultipliers => crate::solve::WarmStart::PrimalMultipliers,
        }
    }
}

impl From<crate::solve::WarmStart> for WarmStartChoice {
    /// The choice that names a restart (in `summary.json`, by the same names as the spec).
    fn from(restart: crate::solve::WarmStart) -> Self {
        match restart {
            crate::solve::WarmStart::Primal => WarmStartChoice::Primal,
            crate::solve::WarmStart::PrimalDual => WarmStartChoice::PrimalDual,
            crate::solve::WarmStart::PrimalMultipliers => WarmStartChoice::PrimalMultipliers,
        }
    }
}

/// Which bounds of the soft bands MPC plans with.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BandsChoice {
    /// The model file's `plan` bounds when the plant is uncertain (`--uncertainty` > 0),
    /// the scoring bounds when it is the model (default).
    #[default]
    Auto,
    /// Always the `plan` bounds (a back-off even on the nominal plant).
    Planning,
    /// Always the bounds the season is scored with.
    Scoring,
}

impl BandsChoice {
    /// The bands for a season on a plant with this uncertainty.
    pub fn resolve(self, plant: &PlantSpec) -> crate::nlp::Bands {
        use crate::nlp::Bands;
        match self {
            BandsChoice::Planning => Bands::Planning,
            BandsChoice::Scoring => Bands::Scoring,
            BandsChoice::Auto if plant.uncertainty > 0.0 => Bands::Planning,
            BandsChoice::Auto => Bands::Scoring,
        }
    }
}

/// Which policy guides RL-guided MPC.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, ValueEnum, Serialize, Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum GuideChoice {
    /// The trained SAC policy (`--agent`, or the one shipped for the model).
    #[default]
    Sac,
    /// The rule-based expert: no training needed.
    Expert,
}

impl GuideChoice {
    /// The guide's name in files and tables.
    pub fn name(self) -> &'static str {
        match self {
            GuideChoice::Sac => "sac",
            GuideChoice::Expert => "expert",
        }
    }
}

/// With or without the terminal region.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Variant {
    /// Terminal cost, terminal region and guide warm start (the paper's RL-MPC).
    #[default]
    Rlmpc,
    /// Value function only: no terminal region (the paper's RL-MPC-VFO).
    Vfo,
}

/// The terminal cost's form.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CostForm {
    /// −V with its exact gradient and Hessian.
    #[default]
    Exact,
    /// −V's first-order expansion around the guess's terminal state (the paper's code).
    Taylor,
    /// No terminal cost (guide warm start and region only).
    None,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spec_reads_back_as_written_and_defaults_what_it_omits() {
        let text = r#"{
            "model": "models/lettuce.ghm",
            "weather": { "days": 2.0 },
            "controller": { "kind": "rlmpc", "horizon": "6h", "guide": "expert" }
        }"#;
        let spec: RunSpec = serde_json::from_str(text).unwrap();
        let ControllerSpec::Rlmpc(r) = &spec.controller else {
            panic!("not rlmpc: {:?}", spec.controller);
        };
        assert_eq!(r.guide, GuideChoice::Expert);
        assert_eq!(r.epsilon, 0.05);
        assert_eq!(r.solver, SolverChoice::Ipm);
        assert_eq!(spec.weather.days, Some(2.0));
        assert_eq!(spec.weather.weather_seed, 2014);
        assert_eq!(spec.plant.seed, 4);
        let again: RunSpec = serde_json::from_value(serde_json::to_value(&spec).unwrap()).unwrap();
        assert_eq!(again, spec);
    }

    #[test]
    fn a_misspelt_field_is_refused() {
        let text =
            r#"{"model": "m.ghm", "controller": {"kind": "mpc", "horizon": "1h", "solvr": "sqp"}}"#;
        let e = serde_json::from_str::<RunSpec>(text).unwrap_err();
        assert!(e.to_string().contains("solvr"), "{e}");
    }
}
