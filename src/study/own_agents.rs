//! A study's own learned guides: the SAC agents it trains (`[agents]`), the guides it
//! distils from a teacher (`[distilled]`) and the value networks it fits to their returns,
//! each a job of a phase before the seasons that read it, in a folder of its own under the
//! study's output folder (`MODEL/agents/KIND`, `MODEL/distilled/KIND`,
//! `MODEL/values/KIND-GUIDE`; KIND is `nominal` or `stochastic`, the plant learned on).
//! A season whose controller names no agent or value network of its own reads the study's.

use super::jobs::{Job, Work};
use crate::job::distill::{DistillSpec, StartRows, Warming};
use crate::job::train::TrainSpec;
use crate::job::value::ValueSpec;
use crate::job::{ControllerSpec, CostForm, GuideChoice, PlantSpec, WeatherSpec};
use serde::Deserialize;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The folders of a model's trainings, distillations and value fits, which no
/// controller's folder may take.
pub(super) const LEARNED_FOLDERS: [&str; 3] = [AGENTS, DISTILLATIONS, VALUES];
const AGENTS: &str = "agents";
const DISTILLATIONS: &str = "distillations";
const VALUES: &str = "values";

/// `[agents]`: the trainings and value fits of the study's own SAC agents (`ghm train` and
/// `ghm value` options, by their names); its value-fit options serve the distilled guides'
/// fits too.
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(super) struct Agents {
    episodes: usize,
    warmup: usize,
    seed: u64,
    checkpoint_every: usize,
    gamma: f64,
    batch_size: usize,
    learning_rate: f64,
    /// The stochastic scenarios' agents (and value networks) are trained on the perturbed
    /// plant (the scenarios' δ); otherwise every scenario uses the nominal plant's.
    stochastic: bool,
    trajectories: usize,
    spread: f64,
    epochs: usize,
    /// Days of each value-fit roll-out (`ghm value --days`); none: the study's season.
    value_days: Option<f64>,
    /// The state the value networks read (`ghm value --state`); none: the model's first.
    state: Option<String>,
}

impl Default for Agents {
    /// `ghm train`'s and `ghm value`'s defaults; the stochastic scenarios' agents trained
    /// on their perturbed plant.
    fn default() -> Self {
        let (train, value) = (TrainSpec::default(), ValueSpec::default());
        Agents {
            episodes: train.episodes,
            warmup: train.warmup,
            seed: train.seed,
            checkpoint_every: train.checkpoint_every,
            gamma: train.gamma,
            batch_size: train.batch_size,
            learning_rate: train.learning_rate,
            stochastic: true,
            trajectories: value.trajectories,
            spread: value.spread,
            epochs: value.epochs,
            value_days: None,
            state: None,
        }
    }
}

impl Agents {
    /// Refuses settings no job could run with, naming the key.
    pub fn check(&self) -> Result<(), String> {
        positive_days(self.value_days, "[agents] value_days")
    }
}

/// Refuses a length in days that is not a positive number.
fn positive_days(days: Option<f64>, key: &str) -> Result<(), String> {
    match days {
        Some(d) if !(d.is_finite() && d > 0.0) => {
            Err(format!("{key}: {d} is not a positive number of days"))
        }
        _ => Ok(()),
    }
}

/// `weather` over `days` days from its start where given, else `weather` itself.
fn over_days(weather: &WeatherSpec, days: Option<f64>) -> WeatherSpec {
    match days {
        Some(days) => WeatherSpec {
            days: Some(days),
            steps: None,
            ..weather.clone()
        },
        None => weather.clone(),
    }
}

/// `[distilled]`: the study's own guides distilled from a teacher with DAgger (`ghm
/// distill`'s options, by their names; the teacher as a `[[controllers]]` entry).
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(super) struct Distilled {
    /// The teacher, a table like a `[[controllers]]` entry; none: `ghm distill`'s (MPC
    /// at 6 h).
    pub teacher: Option<toml::Table>,
    iterations: usize,
    roll_outs: usize,
    noise: f64,
    /// `FIRST..LAST`: the rows of the weather the noisy roll-outs start at.
    start_rows: Option<String>,
    /// `LO..HI`: the degrees the noisy roll-outs' weather is warmed by.
    warming: Option<String>,
    /// The humidities the warming keeps at their relative humidity.
    keep_humidity: Vec<String>,
    /// Rows of forecast the guide observes after the current weather.
    forecast_rows: usize,
    /// Days of each roll-out (`ghm distill --days`); none: the study's season.
    days: Option<f64>,
    epochs: usize,
    seed: u64,
    /// The stochastic scenarios' guides are distilled on the perturbed plant (the
    /// scenarios' δ); otherwise every scenario uses the nominal plant's.
    stochastic: bool,
}

impl Default for Distilled {
    /// `ghm distill`'s defaults; the stochastic scenarios' guides distilled on their
    /// perturbed plant.
    fn default() -> Self {
        let spec = DistillSpec::default();
        Distilled {
            teacher: None,
            iterations: spec.iterations,
            roll_outs: spec.roll_outs,
            noise: spec.noise,
            start_rows: None,
            warming: None,
            keep_humidity: Vec::new(),
            forecast_rows: spec.forecast_rows,
            days: None,
            epochs: spec.fit.epochs,
            seed: spec.seed,
            stochastic: true,
        }
    }
}

impl Distilled {
    /// The distillation these options describe, for any model, weather and plant (those
    /// are set per job); `teacher` is the located teacher table's controller, where given.
    pub fn template(&self, teacher: Option<ControllerSpec>) -> Result<DistillSpec, String> {
        positive_days(self.days, "[distilled] days")?;
        let default = DistillSpec::default();
        let start_rows = self
            .start_rows
            .as_deref()
            .map(str::parse::<StartRows>)
            .transpose()
            .map_err(|e| format!("[distilled] start_rows: {e}"))?;
        let warming = match (&self.warming, self.keep_humidity.is_empty()) {
            (Some(range), _) => Some(
                range
                    .parse::<Warming>()
                    .map_err(|e| format!("[distilled] warming: {e}"))?
                    .keeping_humidity(self.keep_humidity.iter().cloned()),
            ),
            (None, true) => None,
            (None, false) => return Err("[distilled] keep_humidity needs a warming".into()),
        };
        let mut spec = DistillSpec {
            teacher: teacher.unwrap_or(default.teacher),
            iterations: self.iterations,
            roll_outs: self.roll_outs,
            noise: self.noise,
            start_rows,
            warming,
            forecast_rows: self.forecast_rows,
            seed: self.seed,
            ..default
        };
        spec.fit.epochs = self.epochs;
        Ok(spec)
    }
}

/// The study's learning settings: `[agents]`, and `[distilled]` as a distillation
/// template (its teacher located).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Learning<'a> {
    pub agents: Option<&'a Agents>,
    pub distilled: Option<(&'a Distilled, &'a DistillSpec)>,
}

/// A study's own learned guides for one model: which trainings, distillations and value
/// fits its seasons read.
pub(super) struct OwnAgents<'a> {
    learning: Learning<'a>,
    stem: &'a str,
    out: &'a Path,
    /// (plant kind, what) pairs the seasons read.
    used: BTreeSet<(&'static str, Own)>,
}

/// What a season reads of the study's own learned guides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Own {
    /// The policy of a learned guide (SAC's or a distilled one).
    Agent(GuideChoice),
    /// The value network of a guide.
    Value(GuideChoice),
}

impl<'a> OwnAgents<'a> {
    /// Nothing read yet of the guides `learning` makes for the model `stem`.
    pub fn new(learning: Learning<'a>, stem: &'a str, out: &'a Path) -> Self {
        OwnAgents {
            learning,
            stem,
            out,
            used: BTreeSet::new(),
        }
    }

    /// Whether the study learns `guide` itself: SAC with `[agents]`, a distilled guide
    /// with `[distilled]`, the expert's and the rules' value networks with `[agents]`.
    fn learns(&self, guide: GuideChoice) -> bool {
        match guide {
            GuideChoice::Distilled => self.learning.distilled.is_some(),
            GuideChoice::Sac | GuideChoice::Expert | GuideChoice::Rules => {
                self.learning.agents.is_some()
            }
        }
    }

    /// The plant a learned guide for `plant` learns on: `nominal` or `stochastic`. The
    /// expert's and the rules' value networks are fitted on the nominal plant.
    fn kind(&self, plant: &PlantSpec, guide: GuideChoice) -> &'static str {
        let per_plant = match guide {
            GuideChoice::Sac => self.learning.agents.is_some_and(|a| a.stochastic),
            GuideChoice::Distilled => self.learning.distilled.is_some_and(|(d, _)| d.stochastic),
            GuideChoice::Expert | GuideChoice::Rules => false,
        };
        if per_plant && plant.uncertainty > 0.0 {
            "stochastic"
        } else {
            "nominal"
        }
    }

    /// The folder of a training, distillation or value fit, relative to the output folder.
    fn folder(&self, kind: &str, what: Own) -> PathBuf {
        let model = Path::new(self.stem);
        match what {
            Own::Agent(GuideChoice::Distilled) => model.join(DISTILLATIONS).join(kind),
            Own::Agent(_) => model.join(AGENTS).join(kind),
            // The expert's and the rules' value fits do not depend on any training.
            Own::Value(guide @ (GuideChoice::Expert | GuideChoice::Rules)) => {
                model.join(VALUES).join(guide.name())
            }
            Own::Value(guide) => model.join(VALUES).join(format!("{kind}-{}", guide.name())),
        }
    }

    /// The controller with the study's own policy and value network where it names none
    /// (`policy_guide`: which learned guide a policy controller follows), and the folders
    /// it then reads. A distilled guide without `[distilled]` and without an `agent` is
    /// refused.
    pub fn attach(
        &mut self,
        mut controller: ControllerSpec,
        policy_guide: GuideChoice,
        plant: &PlantSpec,
    ) -> Result<(ControllerSpec, Vec<PathBuf>), String> {
        let mut needs = Vec::new();
        let mut use_own = |what: Own| -> Result<Option<PathBuf>, String> {
            let (Own::Agent(guide) | Own::Value(guide)) = what;
            if !self.learns(guide) {
                return if guide == GuideChoice::Distilled {
                    Err(
                        "a distilled guide needs its `agent`, or a [distilled] table for the \
                         study to distil its own"
                            .into(),
                    )
                } else {
                    Ok(None)
                };
            }
            let kind = self.kind(plant, guide);
            self.used.insert((kind, what));
            let folder = self.folder(kind, what);
            needs.push(folder.clone());
            Ok(Some(self.out.join(folder)))
        };
        match &mut controller {
            ControllerSpec::Policy { agent } if agent.is_none() => {
                *agent = use_own(Own::Agent(policy_guide))?;
            }
            ControllerSpec::Rlmpc(r) => {
                if r.guide.follows_policy() && r.agent.is_none() {
                    r.agent = use_own(Own::Agent(r.guide))?;
                }
                if r.terminal_cost != CostForm::None && r.value.is_none() {
                    r.value = use_own(Own::Value(r.guide))?;
                }
            }
            ControllerSpec::Policy { .. }
            | ControllerSpec::Inputs(_)
            | ControllerSpec::Expert
            | ControllerSpec::Rules
            | ControllerSpec::Mpc(_)
            | ControllerSpec::Optimum(_) => {}
        }
        Ok((controller, needs))
    }

    /// The trainings, distillations and value fits the seasons read, in that order.
    pub fn jobs(&self, model: &Path, weather: &WeatherSpec, uncertainty: f64) -> Vec<Job> {
        let job = |work: Work, needs: Vec<PathBuf>, folder: PathBuf, name: &str, kind: &str| Job {
            work,
            needs,
            folder,
            model: self.stem.to_string(),
            controller: name.to_string(),
            horizon: String::new(),
            scenario: kind.to_string(),
        };
        // The kinds of plant each learned guide is needed for, nominal first.
        let kinds_of = |guide: GuideChoice| -> Vec<&'static str> {
            let mut kinds: Vec<&'static str> = self
                .used
                .iter()
                .filter(|(_, what)| matches!(what, Own::Agent(g) | Own::Value(g) if *g == guide))
                .map(|(kind, _)| *kind)
                .collect();
            kinds.sort_unstable();
            kinds.dedup();
            kinds
        };
        let plant_for = |kind: &str| {
            let stochastic = kind == "stochastic";
            (stochastic, if stochastic { uncertainty } else { 0.0 })
        };
        let mut jobs = Vec::new();
        if let Some(agents) = self.learning.agents {
            for kind in kinds_of(GuideChoice::Sac) {
                let (stochastic, uncertainty) = plant_for(kind);
                let spec = TrainSpec {
                    model: model.to_path_buf(),
                    weather: weather.clone(),
                    stochastic,
                    uncertainty,
                    seed: agents.seed,
                    episodes: agents.episodes,
                    warmup: agents.warmup,
                    checkpoint_every: agents.checkpoint_every,
                    gamma: agents.gamma,
                    batch_size: agents.batch_size,
                    learning_rate: agents.learning_rate,
                };
                let folder = self.folder(kind, Own::Agent(GuideChoice::Sac));
                jobs.push(job(Work::Train(spec), Vec::new(), folder, "training", kind));
            }
        }
        if let Some((distilled, template)) = self.learning.distilled {
            for kind in kinds_of(GuideChoice::Distilled) {
                let (stochastic, uncertainty) = plant_for(kind);
                let spec = DistillSpec {
                    model: model.to_path_buf(),
                    weather: over_days(weather, distilled.days),
                    stochastic,
                    uncertainty,
                    ..template.clone()
                };
                let folder = self.folder(kind, Own::Agent(GuideChoice::Distilled));
                jobs.push(job(
                    Work::Distill(spec),
                    Vec::new(),
                    folder,
                    "distillation",
                    kind,
                ));
            }
        }
        let value_options = self.learning.agents.cloned().unwrap_or_default();
        for (kind, what) in &self.used {
            let Own::Value(guide) = *what else {
                continue;
            };
            let agent = guide
                .follows_policy()
                .then(|| self.folder(kind, Own::Agent(guide)));
            let spec = ValueSpec {
                model: model.to_path_buf(),
                weather: over_days(weather, value_options.value_days),
                guide,
                agent: agent.as_ref().map(|a| self.out.join(a)),
                trajectories: value_options.trajectories,
                spread: value_options.spread,
                state: value_options.state.clone(),
                epochs: value_options.epochs,
                seed: value_options.seed,
                ..ValueSpec::default()
            };
            let name = format!("value fit ({})", guide.name());
            jobs.push(job(
                Work::Value(spec),
                agent.into_iter().collect(),
                self.folder(kind, *what),
                &name,
                kind,
            ));
        }
        jobs
    }
}
