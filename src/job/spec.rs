//! What a season job runs, as plain data: the model, the weather slice, the plant and the
//! controller. A study file spells them in TOML, Python in JSON, and the commands map
//! their flags onto them (`cli`); the types know no command line. Each default is stated
//! once, in a `Default` impl, and every door reads it from there.

use crate::control::WarmStart;
use crate::job::weather::WeatherSpec;
use crate::job::JobError;
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlantSpec {
    /// Parametric uncertainty δ of the plant (relative half-width; the model file says which
    /// parameters and how often they are redrawn). 0 = the nominal, deterministic plant;
    /// controllers predict with the nominal model either way.
    pub uncertainty: f64,
    /// Seed of the parameter draws.
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
    pub fn draw(&self) -> Result<Option<crate::sim::season::UncertaintyDraw>, JobError> {
        if !(self.uncertainty >= 0.0 && self.uncertainty < 1.0) {
            return Err(JobError::field(
                "uncertainty",
                self.uncertainty,
                "must be in [0, 1)",
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
    /// Fixed inputs.
    Inputs(InputsSpec),
    /// The rule-based expert.
    Expert,
    /// The model's own rules: each input set by its declaration's `rule`.
    Rules,
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

crate::choice! {
    /// The kinds of controller, as a spec's `kind` names them.
    pub enum ControllerKind {
        /// Fixed inputs: a constant, a CSV file or the model's start input.
        Inputs = "inputs",
        /// The rule-based expert.
        Expert = "expert",
        /// The model's own rules (each input's `rule`), as GreenLight's climate control.
        Rules = "rules",
        /// A trained policy.
        Policy = "policy",
        /// Economic MPC.
        Mpc = "mpc",
        /// RL-guided MPC.
        Rlmpc = "rlmpc",
        /// The season optimum.
        Optimum = "optimum",
    }
}

impl ControllerKind {
    /// Whether it decides each step from the state it is given (and so can be served,
    /// compiled or driven from Python), rather than replaying a table of inputs fixed
    /// before the season.
    pub fn is_feedback(self) -> bool {
        match self {
            ControllerKind::Expert
            | ControllerKind::Rules
            | ControllerKind::Policy
            | ControllerKind::Mpc
            | ControllerKind::Rlmpc => true,
            ControllerKind::Inputs | ControllerKind::Optimum => false,
        }
    }

    /// Whether it plans over a prediction horizon (and so takes a `horizon`).
    pub fn has_horizon(self) -> bool {
        match self {
            ControllerKind::Mpc | ControllerKind::Rlmpc => true,
            ControllerKind::Inputs
            | ControllerKind::Expert
            | ControllerKind::Rules
            | ControllerKind::Policy
            | ControllerKind::Optimum => false,
        }
    }
}

impl ControllerSpec {
    /// The controller of `kind` with every setting at its default.
    pub fn default_of(kind: ControllerKind) -> ControllerSpec {
        match kind {
            ControllerKind::Inputs => ControllerSpec::Inputs(InputsSpec::default()),
            ControllerKind::Expert => ControllerSpec::Expert,
            ControllerKind::Rules => ControllerSpec::Rules,
            ControllerKind::Policy => ControllerSpec::Policy { agent: None },
            ControllerKind::Mpc => ControllerSpec::Mpc(MpcSpec::default()),
            ControllerKind::Rlmpc => ControllerSpec::Rlmpc(RlmpcSpec::default()),
            ControllerKind::Optimum => ControllerSpec::Optimum(OptimumSpec::default()),
        }
    }

    /// Its kind.
    pub fn kind(&self) -> ControllerKind {
        match self {
            ControllerSpec::Inputs(_) => ControllerKind::Inputs,
            ControllerSpec::Expert => ControllerKind::Expert,
            ControllerSpec::Rules => ControllerKind::Rules,
            ControllerSpec::Policy { .. } => ControllerKind::Policy,
            ControllerSpec::Mpc(_) => ControllerKind::Mpc,
            ControllerSpec::Rlmpc(_) => ControllerKind::Rlmpc,
            ControllerSpec::Optimum(_) => ControllerKind::Optimum,
        }
    }

    /// The prediction horizon as written, for the controllers that have one.
    pub fn horizon(&self) -> Option<&str> {
        match self {
            ControllerSpec::Mpc(mpc) => Some(&mpc.horizon),
            ControllerSpec::Rlmpc(rlmpc) => Some(&rlmpc.mpc.horizon),
            ControllerSpec::Inputs(_)
            | ControllerSpec::Expert
            | ControllerSpec::Rules
            | ControllerSpec::Policy { .. }
            | ControllerSpec::Optimum(_) => None,
        }
    }
}

/// Fixed inputs: `const:u1,u2,...`, a CSV file with one row per step, or (none) the
/// model's start input.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InputsSpec {
    /// `const:...` or a CSV path; `None` is the start input.
    pub inputs: Option<String>,
    /// Clip the inputs to their bounds and rate limits.
    pub enforce_limits: bool,
}

impl Default for InputsSpec {
    fn default() -> Self {
        InputsSpec {
            inputs: None,
            enforce_limits: true,
        }
    }
}

/// Economic MPC: the horizon, the NLP back-end, its restart and the bands it plans with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MpcSpec {
    /// `3h`, `90min`, `5400s` or a number of steps (a study's `horizons` fills it in).
    pub horizon: String,
    /// The NLP back-end.
    #[serde(default)]
    pub solver: SolverChoice,
    /// How each step restarts from the last one's solution; `None`: the back-end's choice.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warm_start: Option<WarmStart>,
    /// The soft-band bounds to plan with.
    #[serde(default)]
    pub bands: BandsChoice,
}

impl Default for MpcSpec {
    /// `ghm mpc`'s defaults: a 3-hour horizon, the interior point, its own restart.
    fn default() -> Self {
        MpcSpec {
            horizon: "3h".into(),
            solver: SolverChoice::default(),
            warm_start: None,
            bands: BandsChoice::default(),
        }
    }
}

impl MpcSpec {
    /// The back-end it solves with.
    pub fn solver_spec(&self) -> SolverSpec {
        SolverSpec::new(self.solver)
    }
}

/// RL-guided MPC: MPC plus a guide, its value network, the terminal region and the form of
/// the terminal cost. A spec file writes the MPC's fields beside the guide's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RlmpcSpec {
    /// The MPC under the guidance.
    #[serde(flatten)]
    pub mpc: MpcSpec,
    /// The guide.
    #[serde(default)]
    pub guide: GuideChoice,
    /// The guide's policy (a `ghm train` or `ghm distill` folder, or a policy file);
    /// `None`: the SAC agent shipped for the model.
    #[serde(default)]
    pub agent: Option<PathBuf>,
    /// The value network (folder or value.json); `None`: the shipped one for the guide.
    #[serde(default)]
    pub value: Option<PathBuf>,
    /// With or without the terminal region.
    #[serde(default)]
    pub variant: Variant,
    /// Relative half-width ε of the terminal region.
    #[serde(default = "RlmpcSpec::default_epsilon")]
    pub epsilon: f64,
    /// The terminal cost's form.
    #[serde(default)]
    pub terminal_cost: CostForm,
}

impl Default for RlmpcSpec {
    /// `ghm rlmpc`'s defaults: MPC's over a 1-hour horizon, guided by the SAC agent shipped
    /// for the model, with the terminal region (ε = 0.05) and the exact terminal cost.
    fn default() -> Self {
        RlmpcSpec {
            mpc: MpcSpec {
                horizon: "1h".into(),
                ..MpcSpec::default()
            },
            guide: GuideChoice::default(),
            agent: None,
            value: None,
            variant: Variant::default(),
            epsilon: RlmpcSpec::default_epsilon(),
            terminal_cost: CostForm::default(),
        }
    }
}

impl RlmpcSpec {
    fn default_epsilon() -> f64 {
        0.05
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
#[serde(default, deny_unknown_fields)]
pub struct OptimumSpec {
    /// The horizon of the initialising MPC.
    pub init_horizon: String,
    /// Inputs to start from instead of a closed loop of MPC: a CSV with a row per step, its
    /// columns named as the model's inputs or as a season's `trajectory.csv` names them
    /// (`u_<input>`), e.g. the study's MPC season of the same weather.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub init_inputs: Option<PathBuf>,
    /// The NLP back-end; `None`: IPOPT where built with it, otherwise `ipm`.
    pub solver: Option<SolverChoice>,
    /// The season NLP's iteration limit.
    pub max_iterations: usize,
}

impl Default for OptimumSpec {
    fn default() -> Self {
        OptimumSpec {
            init_horizon: "1h".into(),
            init_inputs: None,
            solver: None,
            max_iterations: 500,
        }
    }
}

impl OptimumSpec {
    /// The back-end that solves the season NLP (`trace`: print its iterations).
    pub fn solver_spec(&self, trace: bool) -> SolverSpec {
        let kind = self.solver.unwrap_or(if cfg!(feature = "ipopt") {
            SolverChoice::Ipopt
        } else {
            SolverChoice::Ipm
        });
        SolverSpec {
            kind,
            max_iterations: Some(self.max_iterations),
            trace,
        }
    }
}

/// An NLP back-end and its options: every command and the season optimum build their
/// solver from one ([`SolverSpec::build`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SolverSpec {
    /// Which back-end.
    pub kind: SolverChoice,
    /// Its iteration limit; `None`: the back-end's own.
    pub max_iterations: Option<usize>,
    /// Print each iteration (a long solve's progress).
    pub trace: bool,
}

impl SolverSpec {
    /// `kind` with its own options.
    pub fn new(kind: SolverChoice) -> Self {
        SolverSpec {
            kind,
            max_iterations: None,
            trace: false,
        }
    }

    /// The back-end, or a message saying how to get it.
    pub fn build(&self) -> Result<Box<dyn crate::solve::Solver>, JobError> {
        use crate::solve::{Ipm, IpmOptions, Sqp, SqpOptions};
        match self.kind {
            SolverChoice::Ipm => {
                let mut options = IpmOptions {
                    trace: self.trace,
                    ..IpmOptions::default()
                };
                if let Some(limit) = self.max_iterations {
                    options.max_iterations = limit;
                }
                Ok(Box::new(Ipm::new(options)))
            }
            SolverChoice::Sqp => {
                let mut options = SqpOptions {
                    trace: self.trace,
                    ..SqpOptions::default()
                };
                if let Some(limit) = self.max_iterations {
                    options.max_iterations = limit;
                }
                Ok(Box::new(Sqp::new(options)))
            }
            #[cfg(feature = "ipopt")]
            SolverChoice::Ipopt => {
                let mut options = crate::solve::IpoptOptions::default();
                if let Some(limit) = self.max_iterations {
                    options.max_iter = limit;
                }
                Ok(Box::new(crate::solve::Ipopt::new(options)))
            }
            #[cfg(not(feature = "ipopt"))]
            SolverChoice::Ipopt => Err(JobError::field(
                "solver",
                "ipopt",
                "needs a build with the IPOPT back-end: install IPOPT (Debian: \
                 coinor-libipopt-dev) and build with `cargo build --release --features ipopt`",
            )),
        }
    }
}

crate::choice! {
    /// The NLP back-ends.
    pub enum SolverChoice {
        /// Pure-Rust interior point, stage by stage (Riccati recursion), exact Hessian.
        Ipm = "ipm",
        /// Pure-Rust SQP with clarabel sub-problems.
        Sqp = "sqp",
        /// The system's IPOPT (needs a build with `--features ipopt`).
        Ipopt = "ipopt",
    }
    default Ipm
}

crate::choice! {
    /// Which bounds of the soft bands MPC plans with.
    pub enum BandsChoice {
        /// The model file's `plan` bounds when the plant differs from the model MPC
        /// predicts with (`uncertainty` > 0, or the model's `plan substeps` differ from its
        /// `substeps`), the scoring bounds when it is that model (default).
        Auto = "auto",
        /// Always the `plan` bounds (a back-off even on the nominal plant).
        Planning = "planning",
        /// Always the bounds the season is scored with.
        Scoring = "scoring",
    }
    default Auto
}

impl BandsChoice {
    /// The bands for a season of `model` on a plant with this uncertainty.
    pub fn resolve(self, plant: &PlantSpec, model: &crate::lang::Model) -> crate::nlp::Bands {
        use crate::nlp::Bands;
        let predicted_exactly = plant.uncertainty == 0.0 && !model.plans_with_other_substeps();
        match self {
            BandsChoice::Planning => Bands::Planning,
            BandsChoice::Scoring => Bands::Scoring,
            BandsChoice::Auto if predicted_exactly => Bands::Scoring,
            BandsChoice::Auto => Bands::Planning,
        }
    }
}

crate::choice! {
    /// Which policy guides RL-guided MPC.
    pub enum GuideChoice {
        /// The trained SAC policy (`agent`, or the one shipped for the model).
        Sac = "sac",
        /// The rule-based expert: no training needed.
        Expert = "expert",
        /// The model's own rules (each input's `rule`, e.g. GreenLight's climate control):
        /// no training needed.
        Rules = "rules",
        /// A policy distilled from MPC by `ghm distill` (`agent`: its folder or policy
        /// file; none is shipped).
        Distilled = "distilled",
    }
    default Sac
}

impl GuideChoice {
    /// Whether the guide follows a policy file (SAC's or a distilled one), which the
    /// controller names with `agent`; the expert and the rules need none.
    pub fn follows_policy(self) -> bool {
        matches!(self, GuideChoice::Sac | GuideChoice::Distilled)
    }
}

crate::choice! {
    /// With or without the terminal region.
    pub enum Variant {
        /// Terminal cost, terminal region and guide warm start (the paper's RL-MPC).
        Rlmpc = "rlmpc",
        /// Value function only: no terminal region (the paper's RL-MPC-VFO).
        Vfo = "vfo",
    }
    default Rlmpc
}

crate::choice! {
    /// The terminal cost's form.
    pub enum CostForm {
        /// −V with its exact gradient and Hessian.
        Exact = "exact",
        /// −V's first-order expansion around the guess's terminal state (the paper's code).
        Taylor = "taylor",
        /// No terminal cost (guide warm start and region only).
        None = "none",
    }
    default Exact
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::Choice;

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
        assert_eq!(r.mpc.solver, SolverChoice::Ipm);
        assert_eq!(r.mpc.horizon, "6h");
        assert_eq!(spec.weather.days, Some(2.0));
        assert_eq!(spec.weather.weather_seed, 2014);
        assert_eq!(spec.plant.seed, 4);
        let again: RunSpec = serde_json::from_value(serde_json::to_value(&spec).unwrap()).unwrap();
        assert_eq!(again, spec);
    }

    #[test]
    fn a_misspelt_field_is_refused() {
        for kind in ["mpc", "rlmpc"] {
            let text = format!(
                r#"{{"model": "m.ghm", "controller": {{"kind": "{kind}", "horizon": "1h", "solvr": "sqp"}}}}"#
            );
            let e = serde_json::from_str::<RunSpec>(&text).unwrap_err();
            assert!(e.to_string().contains("solvr"), "{kind}: {e}");
        }
        let text =
            r#"{"model": "m.ghm", "controller": {"kind": "mpc", "horizon": "1h", "guide": "sac"}}"#;
        let e = serde_json::from_str::<RunSpec>(text).unwrap_err();
        assert!(e.to_string().contains("guide"), "{e}");
    }

    #[test]
    fn rl_guided_mpc_writes_its_mpc_fields_beside_its_own_and_reads_them_back() {
        let spec = ControllerSpec::Rlmpc(RlmpcSpec {
            mpc: MpcSpec {
                horizon: "2h".into(),
                solver: SolverChoice::Sqp,
                warm_start: Some(WarmStart::PrimalDual),
                bands: BandsChoice::Planning,
            },
            epsilon: 0.1,
            ..RlmpcSpec::default()
        });
        let json = serde_json::to_value(&spec).unwrap();
        assert_eq!(json["horizon"], "2h");
        assert_eq!(json["warm_start"], "primal-dual");
        assert_eq!(json["guide"], "sac");
        let back: ControllerSpec = serde_json::from_value(json).unwrap();
        assert_eq!(back, spec);
    }

    #[test]
    fn every_kind_has_defaults_that_read_back_and_answer_for_their_kind() {
        for &kind in ControllerKind::ALL {
            let spec = ControllerSpec::default_of(kind);
            assert_eq!(spec.kind(), kind);
            assert_eq!(spec.horizon().is_some(), kind.has_horizon(), "{kind}");
            let json = serde_json::to_value(&spec).unwrap();
            assert_eq!(json["kind"], kind.name());
            let back: ControllerSpec = serde_json::from_value(json).unwrap();
            assert_eq!(back, spec);
        }
        assert_eq!(
            ControllerSpec::default_of(ControllerKind::Mpc).horizon(),
            Some("3h")
        );
        assert_eq!(
            ControllerSpec::default_of(ControllerKind::Rlmpc).horizon(),
            Some("1h")
        );
    }

    #[test]
    fn a_field_error_names_the_field_as_a_spec_writes_it() {
        let e = PlantSpec {
            uncertainty: 2.0,
            seed: 0,
        }
        .draw()
        .unwrap_err();
        assert_eq!(e.to_string(), "`uncertainty` = 2: must be in [0, 1)");
    }
}
