//! A study file (TOML) and the jobs it plans: one season per (model, controller, horizon,
//! scenario), the season optimum per model where asked, and, with `[agents]`, the
//! trainings and value fits the policies and RL-guided MPC of the study read (instead of
//! the agents shipped with the model), each with its own run folder under the study's
//! output folder. A job names the folders of the jobs it reads ([`Job::needs`]); they are
//! always of an earlier phase ([`Work::phase`]): trainings, then value fits, then seasons.
//!
//! ```toml
//! models = ["../models/lettuce.ghm"]     # paths are relative to the study file, or
//!                                         # start with $GHM_DATA/ (the data folder)
//! horizons = ["1h", "3h", "6h"]          # for the controllers that have one
//! optimum = true                          # the season optimum of each model
//!
//! [weather]                               # as the commands' weather options
//! days = 2
//!
//! [scenarios]
//! nominal = true                          # the deterministic season
//! stochastic = 3                          # seasons on a perturbed plant, seeds seed..
//! uncertainty = 0.1
//! seed = 1
//!
//! [[controllers]]
//! name = "MPC"
//! kind = "mpc"                            # inputs, expert, rules, policy, mpc, rlmpc
//!
//! [agents]                                # train the agents and value networks (optional)
//! episodes = 100
//! stochastic = true                       # the stochastic scenarios' on the perturbed plant
//! ```

use crate::job::train::TrainSpec;
use crate::job::value::ValueSpec;
use crate::job::{
    Choice, ControllerKind, ControllerSpec, CostForm, GuideChoice, PlantSpec, RunSpec, WeatherSpec,
};
use crate::study::StudyError;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The study file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StudyFile {
    models: Vec<PathBuf>,
    #[serde(default)]
    horizons: Vec<String>,
    #[serde(default)]
    optimum: bool,
    #[serde(default)]
    weather: WeatherSpec,
    #[serde(default)]
    scenarios: Scenarios,
    #[serde(default)]
    controllers: Vec<toml::Spanned<toml::Table>>,
    #[serde(default)]
    agents: Option<Agents>,
}

/// `[agents]`: the trainings and value fits of the study's own agents (`ghm train` and
/// `ghm value` options, by their names).
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct Agents {
    episodes: usize,
    warmup: usize,
    seed: u64,
    checkpoint_every: usize,
    gamma: f64,
    batch_size: usize,
    /// The stochastic scenarios' agents (and value networks) are trained on the perturbed
    /// plant (the scenarios' δ); otherwise every scenario uses the nominal plant's.
    stochastic: bool,
    trajectories: usize,
    spread: f64,
    epochs: usize,
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
            stochastic: true,
            trajectories: value.trajectories,
            spread: value.spread,
            epochs: value.epochs,
        }
    }
}

/// Which plants each controller's seasons run on.
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct Scenarios {
    nominal: bool,
    stochastic: usize,
    uncertainty: f64,
    seed: u64,
}

impl Default for Scenarios {
    fn default() -> Self {
        Scenarios {
            nominal: true,
            stochastic: 0,
            uncertainty: 0.1,
            seed: 1,
        }
    }
}

/// The largest number of stochastic scenarios a study may ask for.
const MAX_SCENARIOS: usize = 10_000;

/// What a job runs.
#[derive(Debug, Clone, PartialEq)]
pub enum Work {
    /// A season (or the season optimum).
    Season(RunSpec),
    /// A training of a SAC agent.
    Train(TrainSpec),
    /// A value network fitted to a guide's returns.
    Value(ValueSpec),
}

/// The phases' names, in the order they run ([`Work::phase`] indexes them).
const PHASE_NAMES: [&str; 3] = ["trainings", "value fits", "seasons"];

impl Work {
    /// The job's kind in `study.json`.
    pub fn kind(&self) -> &'static str {
        match self {
            Work::Season(_) => "season",
            Work::Train(_) => "train",
            Work::Value(_) => "value",
        }
    }

    /// The phase's name, as the study's log and `timings.csv` say it.
    pub fn phase_name(&self) -> &'static str {
        PHASE_NAMES[self.phase()]
    }

    /// The phase it runs in: a job reads only jobs of earlier phases.
    pub fn phase(&self) -> usize {
        match self {
            Work::Train(_) => 0,
            Work::Value(_) => 1,
            Work::Season(_) => 2,
        }
    }

    /// The spec as `run.json` records it.
    pub fn spec_json(&self) -> serde_json::Value {
        let value = match self {
            Work::Season(s) => serde_json::to_value(s),
            Work::Train(s) => serde_json::to_value(s),
            Work::Value(s) => serde_json::to_value(s),
        };
        value.unwrap_or_default()
    }

    /// The season's spec, for seasons.
    pub fn season(&self) -> Option<&RunSpec> {
        match self {
            Work::Season(s) => Some(s),
            _ => None,
        }
    }
}

/// One planned job.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    /// What to run.
    pub work: Work,
    /// The folders (relative to the study's output folder) of the jobs it reads.
    pub needs: Vec<PathBuf>,
    /// Its run folder, relative to the study's output folder.
    pub folder: PathBuf,
    /// The model's file stem (a table's first column).
    pub model: String,
    /// The controller's name as the study file gives it.
    pub controller: String,
    /// The horizon as written, empty for controllers without one.
    pub horizon: String,
    /// `nominal` or `stochastic-NN` (for a training or value fit: the plant it is for).
    pub scenario: String,
}

/// Reads the study file at `path` and plans its jobs, in a fixed order (the shards rely
/// on it): per model, the trainings and value fits, the optimum, then per controller,
/// horizon and scenario. `out` is the study's output folder (the seasons read their
/// agents from the trainings' folders in it).
pub fn plan(path: &Path, out: &Path) -> Result<Vec<Job>, StudyError> {
    let text = std::fs::read_to_string(path).map_err(|e| StudyError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let file: StudyFile = toml::from_str(&text).map_err(|e| StudyError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    let data = std::env::var_os(DATA_VARIABLE).map(PathBuf::from);
    let place = Place {
        base,
        data: data.as_deref(),
    };
    plan_file(file, &place, out, &text).map_err(|message| StudyError::File {
        path: path.to_path_buf(),
        message,
    })
}

/// The environment variable naming the data folder, which a study file's paths may start
/// with (`$GHM_DATA/venlo2014_30min_model_units.csv`, `docs/data.md`).
pub const DATA_VARIABLE: &str = "GHM_DATA";

/// Where a study file's paths lead: relative ones to the file's folder (the file's
/// canonical path where it exists, so that a job's spec names the same file however the
/// study reaches it; as joined otherwise, and the job then says that it is missing), those
/// that start with `$GHM_DATA/` to the data folder.
struct Place<'a> {
    base: &'a Path,
    data: Option<&'a Path>,
}

impl Place<'_> {
    fn locate(&self, path: &Path) -> Result<PathBuf, String> {
        let text = path.to_string_lossy();
        let prefix = format!("${DATA_VARIABLE}/");
        let Some(rest) = text.strip_prefix(&prefix) else {
            let joined = self.base.join(path);
            return Ok(std::fs::canonicalize(&joined).unwrap_or(joined));
        };
        match self.data {
            Some(dir) => Ok(dir.join(rest)),
            None => Err(format!(
                "`{text}` names the data folder, but {DATA_VARIABLE} is not set: set it to the \
                 folder that holds {rest} (`ghm import venlo` makes the Venlo weather; \
                 docs/data.md)"
            )),
        }
    }
}

/// Plans `file` (whose text is `text`, for the lines of its errors).
fn plan_file(file: StudyFile, place: &Place, out: &Path, text: &str) -> Result<Vec<Job>, String> {
    if file.models.is_empty() {
        return Err("`models` names no model file".into());
    }
    if file.controllers.is_empty() && !file.optimum {
        return Err("the study runs nothing: add [[controllers]] or `optimum = true`".into());
    }
    let s = &file.scenarios;
    if s.stochastic > MAX_SCENARIOS {
        return Err(format!(
            "[scenarios] stochastic = {}: at most {MAX_SCENARIOS}",
            s.stochastic
        ));
    }
    if s.stochastic > 0 && !(s.uncertainty > 0.0 && s.uncertainty < 1.0) {
        return Err(format!(
            "[scenarios] uncertainty = {}: stochastic scenarios need a δ in (0, 1)",
            s.uncertainty
        ));
    }
    let mut weather = file.weather.clone();
    weather.weather = weather.weather.map(|p| place.locate(&p)).transpose()?;
    weather.knmi = weather.knmi.map(|p| place.locate(&p)).transpose()?;
    let mut scenarios: Vec<(String, PlantSpec)> = Vec::new();
    if s.nominal {
        scenarios.push(("nominal".into(), PlantSpec::NOMINAL));
    }
    for i in 0..s.stochastic {
        let plant = PlantSpec {
            uncertainty: s.uncertainty,
            seed: s.seed + i as u64,
        };
        scenarios.push((format!("stochastic-{i:02}"), plant));
    }
    let controllers = file
        .controllers
        .iter()
        .enumerate()
        .map(|(i, table)| {
            controller_entry(i, table.get_ref(), table.span())
                .map_err(|m| at_line(text, table.span(), m))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut names: Vec<&str> = controllers.iter().map(|c| c.name.as_str()).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| slug(w[0]) == slug(w[1])) {
        return Err(format!(
            "two controllers named `{}` and `{}` would share a folder; give them distinct names",
            w[0], w[1]
        ));
    }

    let mut jobs = Vec::new();
    for model in &file.models {
        let model_path = place.locate(model)?;
        let stem = model
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "model".into());
        let mut own = OwnAgents {
            agents: file.agents.as_ref(),
            stem: &stem,
            out,
            used: std::collections::BTreeSet::new(),
        };
        let mut seasons = Vec::new();
        if file.optimum {
            seasons.push(Job {
                work: Work::Season(RunSpec {
                    model: model_path.clone(),
                    weather: weather.clone(),
                    plant: PlantSpec::NOMINAL,
                    controller: ControllerSpec::Optimum(crate::job::OptimumSpec::default()),
                }),
                needs: Vec::new(),
                folder: Path::new(&stem).join("optimum"),
                model: stem.clone(),
                controller: "optimum".into(),
                horizon: String::new(),
                scenario: "nominal".into(),
            });
        }
        for c in &controllers {
            let horizons: Vec<String> = match (&c.horizon, c.kind.has_horizon()) {
                (Some(h), _) => vec![h.clone()],
                (None, true) if file.horizons.is_empty() => {
                    return Err(at_line(text, c.span.clone(), format!(
                        "controller `{}` ({}) needs a horizon: give it `horizon = \"3h\"` or the study `horizons = [...]`",
                        c.name, c.kind
                    )))
                }
                (None, true) => file.horizons.clone(),
                (None, false) => vec![String::new()],
            };
            for horizon in &horizons {
                let spec = c
                    .spec(horizon, place)
                    .map_err(|m| at_line(text, c.span.clone(), m))?;
                for (scenario, plant) in &scenarios {
                    let mut folder = Path::new(&stem).join(slug(&c.name));
                    if !horizon.is_empty() {
                        folder.push(slug(horizon));
                    }
                    folder.push(scenario);
                    let (controller, needs) = own.attach(spec.clone(), plant);
                    seasons.push(Job {
                        work: Work::Season(RunSpec {
                            model: model_path.clone(),
                            weather: weather.clone(),
                            plant: plant.clone(),
                            controller,
                        }),
                        needs,
                        folder,
                        model: stem.clone(),
                        controller: c.name.clone(),
                        horizon: horizon.clone(),
                        scenario: scenario.clone(),
                    });
                }
            }
        }
        jobs.extend(own.jobs(&model_path, &weather, s));
        jobs.extend(seasons);
    }
    Ok(jobs)
}

/// A study's own agents for one model: which trainings and value fits its seasons read.
struct OwnAgents<'a> {
    agents: Option<&'a Agents>,
    stem: &'a str,
    out: &'a Path,
    /// (plant kind, guide's value or the agent itself) pairs the seasons read.
    used: std::collections::BTreeSet<(&'static str, Own)>,
}

/// What a season reads of the study's own agents.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Own {
    /// The trained agent.
    Agent,
    /// The value network of a guide.
    Value(GuideChoice),
}

impl OwnAgents<'_> {
    /// The plant an agent for `plant` is trained on: `nominal` or `stochastic`.
    fn kind(&self, plant: &PlantSpec, agents: &Agents) -> &'static str {
        if agents.stochastic && plant.uncertainty > 0.0 {
            "stochastic"
        } else {
            "nominal"
        }
    }

    /// The folder of a training or value fit, relative to the output folder.
    fn folder(&self, kind: &str, what: Own) -> PathBuf {
        match what {
            Own::Agent => Path::new(self.stem).join("agents").join(kind),
            // The expert's and the rules' value fits do not depend on any training.
            Own::Value(guide @ (GuideChoice::Expert | GuideChoice::Rules)) => {
                Path::new(self.stem).join("values").join(guide.name())
            }
            Own::Value(GuideChoice::Sac) => Path::new(self.stem)
                .join("values")
                .join(format!("{kind}-sac")),
        }
    }

    /// The controller with the study's own agent and value network where it names none,
    /// and the folders it then reads.
    fn attach(
        &mut self,
        mut controller: ControllerSpec,
        plant: &PlantSpec,
    ) -> (ControllerSpec, Vec<PathBuf>) {
        let mut needs = Vec::new();
        let Some(agents) = self.agents else {
            return (controller, needs);
        };
        let kind = self.kind(plant, agents);
        let mut use_own = |what: Own, needs: &mut Vec<PathBuf>| {
            let kind = match what {
                Own::Value(GuideChoice::Expert | GuideChoice::Rules) => "nominal",
                _ => kind,
            };
            self.used.insert((kind, what));
            let folder = self.folder(kind, what);
            needs.push(folder.clone());
            self.out.join(folder)
        };
        match &mut controller {
            ControllerSpec::Policy { agent } if agent.is_none() => {
                *agent = Some(use_own(Own::Agent, &mut needs));
            }
            ControllerSpec::Rlmpc(r) => {
                if r.guide == GuideChoice::Sac && r.agent.is_none() {
                    r.agent = Some(use_own(Own::Agent, &mut needs));
                }
                if r.terminal_cost != CostForm::None && r.value.is_none() {
                    r.value = Some(use_own(Own::Value(r.guide), &mut needs));
                }
            }
            ControllerSpec::Policy { .. }
            | ControllerSpec::Inputs(_)
            | ControllerSpec::Expert
            | ControllerSpec::Rules
            | ControllerSpec::Mpc(_)
            | ControllerSpec::Optimum(_) => {}
        }
        (controller, needs)
    }

    /// The trainings and value fits the seasons read, trainings first.
    fn jobs(&self, model: &Path, weather: &WeatherSpec, scenarios: &Scenarios) -> Vec<Job> {
        let Some(agents) = self.agents else {
            return Vec::new();
        };
        let mut trainings: Vec<&'static str> = Vec::new();
        for (kind, what) in &self.used {
            let needs_agent = *what == Own::Agent || *what == Own::Value(GuideChoice::Sac);
            if needs_agent && !trainings.contains(kind) {
                trainings.push(kind);
            }
        }
        trainings.sort_unstable();
        let job = |work: Work, needs: Vec<PathBuf>, folder: PathBuf, name: &str, kind: &str| Job {
            work,
            needs,
            folder,
            model: self.stem.to_string(),
            controller: name.to_string(),
            horizon: String::new(),
            scenario: kind.to_string(),
        };
        let mut jobs = Vec::new();
        for kind in &trainings {
            let stochastic = *kind == "stochastic";
            let spec = TrainSpec {
                model: model.to_path_buf(),
                weather: weather.clone(),
                stochastic,
                uncertainty: if stochastic {
                    scenarios.uncertainty
                } else {
                    0.0
                },
                seed: agents.seed,
                episodes: agents.episodes,
                warmup: agents.warmup,
                checkpoint_every: agents.checkpoint_every,
                gamma: agents.gamma,
                batch_size: agents.batch_size,
            };
            jobs.push(job(
                Work::Train(spec),
                Vec::new(),
                self.folder(kind, Own::Agent),
                "training",
                kind,
            ));
        }
        for (kind, what) in &self.used {
            let Own::Value(guide) = *what else {
                continue;
            };
            let agent = (guide == GuideChoice::Sac).then(|| self.folder(kind, Own::Agent));
            let spec = ValueSpec {
                model: model.to_path_buf(),
                weather: weather.clone(),
                guide,
                agent: agent.as_ref().map(|a| self.out.join(a)),
                trajectories: agents.trajectories,
                spread: agents.spread,
                state: None,
                epochs: agents.epochs,
                seed: agents.seed,
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

/// A `[[controllers]]` entry: its name, kind and the rest of its fields.
struct ControllerEntry {
    name: String,
    kind: ControllerKind,
    horizon: Option<String>,
    fields: toml::Table,
    /// Where its table is in the study file.
    span: std::ops::Range<usize>,
}

/// `message` about the table at `span` of `text`, led by the line of the key it names
/// (`unknown field \`solvr\``), else of the table.
fn at_line(text: &str, span: std::ops::Range<usize>, message: String) -> String {
    // The table's keys: from its header to the next header (the span may be the header's).
    let table = text.get(span.start..).unwrap_or_default();
    let named: Vec<&str> = message.split('`').skip(1).step_by(2).collect();
    let key_offset = table
        .lines()
        .scan(0, |offset, line| {
            let start = *offset;
            *offset += line.len() + 1;
            Some((start, line))
        })
        .take_while(|(start, line)| *start == 0 || !line.trim_start().starts_with('['))
        .find(|(_, line)| {
            let key = line.split('=').next().unwrap_or_default().trim();
            line.contains('=') && named.contains(&key)
        })
        .map_or(0, |(start, _)| start);
    let at = (span.start + key_offset).min(text.len());
    let line = text[..at].matches('\n').count() + 1;
    format!("line {line}: {message}")
}

fn controller_entry(
    index: usize,
    table: &toml::Table,
    span: std::ops::Range<usize>,
) -> Result<ControllerEntry, String> {
    let mut fields = table.clone();
    let kinds = || {
        ControllerKind::ALL
            .iter()
            .filter(|k| **k != ControllerKind::Optimum)
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let kind = match fields.get("kind") {
        Some(toml::Value::String(k)) => ControllerKind::from_name(k).ok_or_else(|| {
            format!(
                "controller {}: unknown `kind` = \"{k}\" (one of {})",
                index + 1,
                kinds()
            )
        })?,
        _ => {
            return Err(format!(
                "controller {} has no `kind` (one of {})",
                index + 1,
                kinds()
            ))
        }
    };
    let name = match fields.remove("name") {
        Some(toml::Value::String(n)) if !n.trim().is_empty() => n,
        None => kind.name().to_string(),
        Some(other) => {
            return Err(format!(
                "controller {}: `name` = {other} is not a name",
                index + 1
            ))
        }
    };
    let horizon = match fields.remove("horizon") {
        Some(toml::Value::String(h)) => Some(h),
        None => None,
        Some(other) => {
            return Err(format!(
                "controller `{name}`: `horizon` = {other}; write it as a string such as \"3h\""
            ))
        }
    };
    if kind == ControllerKind::Optimum {
        return Err(format!(
            "controller `{name}`: the optimum is asked for with `optimum = true` at the top of the study"
        ));
    }
    Ok(ControllerEntry {
        name,
        kind,
        horizon,
        fields,
        span,
    })
}

impl ControllerEntry {
    /// The controller at `horizon` (empty: none), its file paths located by `place`.
    fn spec(&self, horizon: &str, place: &Place) -> Result<ControllerSpec, String> {
        let mut fields = self.fields.clone();
        if !horizon.is_empty() {
            fields.insert("horizon".into(), toml::Value::String(horizon.into()));
        }
        for key in ["agent", "value", "inputs"] {
            if let Some(toml::Value::String(p)) = fields.get(key) {
                if !p.starts_with("const:") {
                    let located = place.locate(Path::new(p))?.to_string_lossy().into_owned();
                    fields.insert(key.into(), toml::Value::String(located));
                }
            }
        }
        toml::Value::Table(fields)
            .try_into::<ControllerSpec>()
            .map_err(|e| format!("controller `{}`: {}", self.name, e.message()))
    }
}

/// A name as a folder name: lower case, runs of other characters as one `-`.
pub fn slug(name: &str) -> String {
    let mut out = String::new();
    for c in name.chars() {
        if c.is_ascii_alphanumeric() || c == '.' {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    let trimmed = out.trim_matches('-');
    if trimmed.is_empty() {
        "controller".into()
    } else {
        trimmed.into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan_text(text: &str) -> Result<Vec<Job>, String> {
        let file: StudyFile = toml::from_str(text).map_err(|e| e.to_string())?;
        let place = Place {
            base: Path::new("studies"),
            data: Some(Path::new("/data")),
        };
        plan_file(file, &place, Path::new("/out"), text)
    }

    #[test]
    fn every_controller_horizon_and_scenario_is_one_job_in_a_fixed_order() {
        let jobs = plan_text(
            r#"
            models = ["../models/lettuce.ghm"]
            horizons = ["1h", "6h"]
            optimum = true
            [weather]
            days = 2
            [scenarios]
            stochastic = 2
            [[controllers]]
            name = "RL-MPC (expert)"
            kind = "rlmpc"
            guide = "expert"
            [[controllers]]
            kind = "expert"
            "#,
        )
        .unwrap();
        // optimum + rlmpc × 2 horizons × 3 scenarios + expert × 3 scenarios
        assert_eq!(jobs.len(), 1 + 6 + 3);
        assert_eq!(jobs[0].folder, Path::new("lettuce/optimum"));
        assert_eq!(
            jobs[1].folder,
            Path::new("lettuce/rl-mpc-expert/1h/nominal")
        );
        assert_eq!(
            jobs[3].folder,
            Path::new("lettuce/rl-mpc-expert/1h/stochastic-01")
        );
        let season = |k: usize| jobs[k].work.season().unwrap();
        assert_eq!(season(3).plant.seed, 2);
        assert_eq!(jobs[9].folder, Path::new("lettuce/expert/stochastic-01"));
        assert_eq!(season(1).model, Path::new("studies/../models/lettuce.ghm"));
        assert_eq!(season(1).weather.days, Some(2.0));
        let ControllerSpec::Rlmpc(r) = &season(4).controller else {
            panic!("{:?}", season(4).controller);
        };
        assert_eq!(r.mpc.horizon, "6h");
        assert!(jobs.iter().all(|j| j.needs.is_empty()));
    }

    #[test]
    fn own_agents_are_trained_and_fitted_before_the_seasons_that_read_them() {
        let jobs = plan_text(
            r#"
            models = ["../models/lettuce.ghm"]
            horizons = ["1h"]
            [scenarios]
            stochastic = 1
            uncertainty = 0.05
            [agents]
            episodes = 3
            warmup = 1
            gamma = 0.99
            batch_size = 64
            [[controllers]]
            name = "SAC"
            kind = "policy"
            [[controllers]]
            name = "RL-MPC"
            kind = "rlmpc"
            [[controllers]]
            name = "RL-MPC (expert)"
            kind = "rlmpc"
            guide = "expert"
            [[controllers]]
            name = "given"
            kind = "policy"
            agent = "agents/mine"
            "#,
        )
        .unwrap();
        let folders: Vec<String> = jobs
            .iter()
            .map(|j| j.folder.display().to_string())
            .collect();
        assert_eq!(
            folders[..5],
            [
                "lettuce/agents/nominal",
                "lettuce/agents/stochastic",
                "lettuce/values/nominal-sac",
                "lettuce/values/expert",
                "lettuce/values/stochastic-sac",
            ]
        );
        let Work::Train(train) = &jobs[1].work else {
            panic!("{:?}", jobs[1].work);
        };
        assert!(train.stochastic && train.uncertainty == 0.05 && train.episodes == 3);
        assert_eq!((train.gamma, train.batch_size), (0.99, 64));
        assert_eq!(
            (train.config().gamma, train.config().batch_size),
            (0.99, 64)
        );
        let Work::Value(value) = &jobs[4].work else {
            panic!("{:?}", jobs[4].work);
        };
        assert_eq!(
            value.agent.as_deref(),
            Some(Path::new("/out/lettuce/agents/stochastic"))
        );
        assert_eq!(jobs[4].needs, [Path::new("lettuce/agents/stochastic")]);
        // Phases: every job reads only jobs planned before it, of an earlier phase.
        for (k, job) in jobs.iter().enumerate() {
            for need in &job.needs {
                let i = jobs.iter().position(|j| &j.folder == need).unwrap();
                assert!(i < k && jobs[i].work.phase() < job.work.phase(), "{need:?}");
            }
        }
        let by_folder = |f: &str| jobs.iter().find(|j| j.folder == Path::new(f)).unwrap();
        let rlmpc = by_folder("lettuce/rl-mpc/1h/stochastic-00");
        let Some(ControllerSpec::Rlmpc(r)) = rlmpc.work.season().map(|s| &s.controller) else {
            panic!();
        };
        assert_eq!(
            r.agent.as_deref(),
            Some(Path::new("/out/lettuce/agents/stochastic"))
        );
        assert_eq!(
            r.value.as_deref(),
            Some(Path::new("/out/lettuce/values/stochastic-sac"))
        );
        let expert = by_folder("lettuce/rl-mpc-expert/1h/nominal");
        assert_eq!(expert.needs, [Path::new("lettuce/values/expert")]);
        // A controller that names its agent reads it, not the study's.
        let given = by_folder("lettuce/given/nominal");
        assert!(given.needs.is_empty());
    }

    #[test]
    fn mistakes_in_a_study_are_named() {
        let cases = [
            ("models = []\n[[controllers]]\nkind = \"expert\"", "names no model"),
            ("models = [\"m.ghm\"]", "runs nothing"),
            (
                "models = [\"m.ghm\"]\n[[controllers]]\nkind = \"mpc\"",
                "line 2: controller `mpc` (mpc) needs a horizon",
            ),
            (
                "models = [\"m.ghm\"]\nhorizons = [\"1h\"]\n[[controllers]]\nkind = \"mpc\"\nsolvr = \"sqp\"",
                "line 5: controller `mpc`: unknown field `solvr`",
            ),
            ("models = [\"m.ghm\"]\n[[controllers]]\nname = \"x\"", "no `kind`"),
            (
                "models = [\"m.ghm\"]\n[[controllers]]\nkind = \"expert\"\n[[controllers]]\nkind = \"expert\"",
                "share a folder",
            ),
            (
                "models = [\"m.ghm\"]\n[scenarios]\nstochastic = 3\nuncertainty = 0\n[[controllers]]\nkind = \"expert\"",
                "need a δ",
            ),
        ];
        for (text, expected) in cases {
            let e = plan_text(text).unwrap_err();
            assert!(e.contains(expected), "{text}\n→ {e}");
        }
    }

    #[test]
    fn a_path_in_the_data_folder_is_found_there_or_refused_naming_the_variable() {
        let text = "models = [\"m.ghm\"]\n[weather]\nweather = \"$GHM_DATA/venlo.csv\"\n\
                    [[controllers]]\nkind = \"expert\"";
        let jobs = plan_text(text).expect("plans");
        let Work::Season(run) = &jobs[0].work else {
            panic!("a season")
        };
        assert_eq!(
            run.weather.weather.as_deref(),
            Some(Path::new("/data/venlo.csv"))
        );
        let file: StudyFile = toml::from_str(text).expect("parses");
        let place = Place {
            base: Path::new("studies"),
            data: None,
        };
        let e = plan_file(file, &place, Path::new("/out"), text).expect_err("no data folder");
        assert!(
            e.contains("GHM_DATA is not set") && e.contains("ghm import venlo"),
            "{e}"
        );
    }

    #[test]
    fn every_shipped_study_file_plans() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/studies");
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        assert!(files.len() >= 7, "{files:?}");
        for file in files {
            let text = std::fs::read_to_string(&file).expect("reads");
            let parsed: StudyFile = toml::from_str(&text).expect("parses");
            let place = Place {
                base: file.parent().expect("a folder"),
                data: Some(Path::new("/data")),
            };
            let jobs = plan_file(parsed, &place, Path::new("/tmp/ghm-plan-only"), &text)
                .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            assert!(!jobs.is_empty(), "{}", file.display());
        }
    }

    #[test]
    fn slugs_are_folder_names() {
        assert_eq!(slug("RL-MPC (sac)"), "rl-mpc-sac");
        assert_eq!(slug("MPC"), "mpc");
        assert_eq!(slug("1.5h"), "1.5h");
        assert_eq!(slug("***"), "controller");
    }
}
