//! From a spec's names to the things that run: the model loaded and checked, the horizon
//! in steps, the NLP back-end, MPC, the guide (a policy shipped or trained, or the expert),
//! the value network, fixed inputs.

use crate::agent::PolicyFile;
use crate::control::{
    ConstantInput, Controller, Expert, InputTable, Mpc, Policy, Rules, ValueFile,
};
use crate::job::spec::{ControllerSpec, CostForm, GuideChoice, MpcSpec, RlmpcSpec, RunSpec};
use crate::job::weather::WeatherSpec;
use crate::job::JobError;
use crate::model::Plant;
use crate::nlp::Bands;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// MPC of `plant` over `horizon` steps with `spec`'s back-end and restart, planning with
/// `bands`.
pub fn make_mpc(
    plant: &Arc<Plant>,
    horizon: usize,
    spec: &MpcSpec,
    bands: Bands,
) -> Result<Mpc, JobError> {
    let fail = |e: crate::nlp::OcpError| JobError::Spec(e.to_string());
    let mut mpc = Mpc::new(plant.clone(), horizon, spec.solver_spec().build()?)
        .map_err(fail)?
        .with_bands(bands)
        .map_err(fail)?;
    if let Some(choice) = spec.warm_start {
        mpc.warm_start = choice;
    }
    Ok(mpc)
}

/// The bands' name in `summary.json`.
pub fn bands_name(bands: Bands) -> &'static str {
    match bands {
        Bands::Planning => "planning",
        Bands::Scoring => "scoring",
    }
}

/// Steps of a horizon given as `3h`, `90min`, `5400s` or a plain number of steps; `field`
/// is the spec's field that holds it (`horizon`, `init_horizon`).
pub fn parse_horizon(
    field: &'static str,
    text: &str,
    sample_period_s: f64,
) -> Result<usize, JobError> {
    let t = text.trim();
    let seconds = if let Some(h) = t.strip_suffix('h') {
        h.trim().parse::<f64>().ok().map(|v| v * 3600.0)
    } else if let Some(m) = t.strip_suffix("min") {
        m.trim().parse::<f64>().ok().map(|v| v * 60.0)
    } else if let Some(s) = t.strip_suffix('s') {
        s.trim().parse::<f64>().ok()
    } else {
        t.parse::<usize>().ok().map(|n| n as f64 * sample_period_s)
    };
    let bad = || {
        JobError::field(
            field,
            text,
            format!(
                "expected a duration such as 3h or 90min, or a number of steps, of at least \
                 one sample period ({sample_period_s} s)"
            ),
        )
    };
    let seconds = seconds
        .filter(|s| s.is_finite() && *s > 0.0)
        .ok_or_else(bad)?;
    let steps = (seconds / sample_period_s).round();
    if steps < 1.0 || (steps * sample_period_s - seconds).abs() > 1e-6 * seconds {
        return Err(bad());
    }
    if steps > MAX_HORIZON_STEPS as f64 {
        return Err(JobError::field(
            field,
            text,
            format!(
                "{steps:.3e} steps of {sample_period_s} s; a horizon has at most \
                 {MAX_HORIZON_STEPS} steps"
            ),
        ));
    }
    Ok(steps as usize)
}

/// The longest prediction horizon, in steps: each step of it is a stage of the NLP, with
/// its own variables, constraints and derivative buffers, so a larger one is refused before
/// anything is allocated.
pub const MAX_HORIZON_STEPS: usize = 100_000;

/// The agents shipped for `model_file`: `models/agents/<stem>/` beside it, trained on the
/// Venlo 2014 season; on ghm's built-in weather, its `builtin/` subfolder where one is
/// shipped. An agent trained on one season has learned that season's weather, and the
/// built-in season is not Venlo's.
pub fn shipped_dir(model_file: &Path, weather: &WeatherSpec) -> PathBuf {
    let stem = model_file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let dir = model_file
        .parent()
        .unwrap_or(Path::new("."))
        .join("agents")
        .join(stem);
    let builtin = dir.join("builtin");
    if weather.is_builtin() && builtin.join("policy.json").is_file() {
        builtin
    } else {
        dir
    }
}

/// The policy of `--agent`, or the shipped one (see [`shipped_dir`]), checked against
/// `plant`: its observation and inputs must be the model's; another model name is only
/// warned about.
pub fn resolve_policy(
    model_file: &Path,
    weather: &WeatherSpec,
    agent: Option<&Path>,
    plant: &Plant,
    announce: bool,
) -> Result<PolicyFile, JobError> {
    let path = match agent {
        Some(a) => policy_path(a)?,
        None => {
            let dir = shipped_dir(model_file, weather);
            let path = dir.join("policy.json");
            if !path.is_file() {
                return Err(JobError::unset(
                    "agent",
                    format!(
                        "no agent shipped for {} (looked in {}); train one with `ghm train` and \
                         name its folder",
                        model_file.display(),
                        dir.display()
                    ),
                ));
            }
            if announce {
                eprintln!("using the agent shipped in {}", dir.display());
            }
            path
        }
    };
    let fail = |e: crate::agent::AgentError| JobError::Spec(e.to_string());
    let policy = PolicyFile::load(&path).map_err(fail)?;
    policy.check_fits(&plant.model, &path).map_err(fail)?;
    if policy.model != plant.model.name {
        eprintln!(
            "warning: the policy was trained on model `{}`, this is `{}`",
            policy.model, plant.model.name
        );
    }
    Ok(policy)
}

/// A factory of guide controllers (one per thread or per use).
pub type GuideFactory = Box<dyn Fn() -> Box<dyn Controller + Send> + Sync>;

/// The policy a guide of `choice` follows: `--agent`'s or the shipped one for the SAC
/// guide (see [`resolve_policy`]), `--agent`'s for a distilled guide (none is shipped),
/// none for the expert and the rules.
pub fn resolve_guide_policy(
    choice: GuideChoice,
    model_file: &Path,
    weather: &WeatherSpec,
    agent: Option<&Path>,
    plant: &Plant,
    announce: bool,
) -> Result<Option<PolicyFile>, JobError> {
    match choice {
        GuideChoice::Sac => resolve_policy(model_file, weather, agent, plant, announce).map(Some),
        GuideChoice::Distilled => {
            let agent = agent.ok_or_else(|| {
                JobError::unset(
                    "agent",
                    "the distilled guide needs a policy: name the folder of a `ghm distill` run",
                )
            })?;
            resolve_policy(model_file, weather, Some(agent), plant, announce).map(Some)
        }
        GuideChoice::Expert | GuideChoice::Rules => Ok(None),
    }
}

/// Builds the guide factory for `choice`; the SAC and distilled guides follow `policy` (see
/// [`resolve_guide_policy`]).
pub fn guide_factory(
    plant: &Arc<Plant>,
    choice: GuideChoice,
    policy: Option<PolicyFile>,
) -> Result<GuideFactory, JobError> {
    let fail = |e: crate::control::ControlError| JobError::Spec(e.to_string());
    match choice {
        GuideChoice::Sac | GuideChoice::Distilled => {
            let file = policy.ok_or_else(|| {
                JobError::unset(
                    "agent",
                    format!("the {} guide needs a policy", choice.name()),
                )
            })?;
            Ok(clones_of(Policy::new(plant, file).map_err(fail)?))
        }
        GuideChoice::Expert => Ok(clones_of(Expert::new(plant.clone()).map_err(fail)?)),
        GuideChoice::Rules => Ok(clones_of(Rules::new(plant.clone()).map_err(fail)?)),
    }
}

/// A factory of fresh copies of `guide`, which is built once.
fn clones_of<G: Controller + Clone + Send + Sync + 'static>(guide: G) -> GuideFactory {
    Box::new(move || Box::new(guide.clone()) as Box<dyn Controller + Send>)
}

/// The files a spec's controller reads, loaded and checked against the plant: the policy
/// of a policy controller or of RL-guided MPC's SAC guide, and RL-guided MPC's value
/// network. The job layer reads them from disk ([`ControllerFiles::load`]); a compiled
/// controller carries them inside (`embed`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ControllerFiles {
    /// The policy, where the controller follows one.
    pub policy: Option<PolicyFile>,
    /// The value network, where the controller has a terminal cost.
    pub value: Option<ValueFile>,
}

impl ControllerFiles {
    /// Reads the files `spec`'s controller needs (`announce`: say on stderr which shipped
    /// agent is used).
    pub fn load(spec: &RunSpec, plant: &Plant, announce: bool) -> Result<Self, JobError> {
        let mut files = ControllerFiles::default();
        match &spec.controller {
            ControllerSpec::Policy { agent } => {
                files.policy = Some(resolve_policy(
                    &spec.model,
                    &spec.weather,
                    agent.as_deref(),
                    plant,
                    announce,
                )?);
            }
            ControllerSpec::Rlmpc(rlmpc) => {
                files.policy = resolve_guide_policy(
                    rlmpc.guide,
                    &spec.model,
                    &spec.weather,
                    rlmpc.agent.as_deref(),
                    plant,
                    announce,
                )?;
                if rlmpc.terminal_cost != CostForm::None {
                    files.value = Some(resolve_value(&spec.model, &spec.weather, rlmpc, plant)?);
                }
            }
            ControllerSpec::Inputs(_)
            | ControllerSpec::Expert
            | ControllerSpec::Rules
            | ControllerSpec::Mpc(_)
            | ControllerSpec::Optimum(_) => {}
        }
        Ok(files)
    }
}

/// The policy file of an agent folder or file, which must exist.
pub fn policy_path(agent: &Path) -> Result<PathBuf, JobError> {
    let path = if agent.is_dir() {
        agent.join("policy.json")
    } else {
        agent.to_path_buf()
    };
    if !path.is_file() {
        return Err(JobError::Spec(format!(
            "no policy at {}: pass a folder written by `ghm train` or its policy.json",
            path.display()
        )));
    }
    Ok(path)
}

/// The value file of `--value`, or the shipped one for the guide.
pub fn resolve_value(
    model_file: &Path,
    weather: &WeatherSpec,
    spec: &RlmpcSpec,
    plant: &Plant,
) -> Result<ValueFile, JobError> {
    let path = match &spec.value {
        Some(p) if p.is_dir() => p.join("value.json"),
        Some(p) => p.clone(),
        None => shipped_dir(model_file, weather).join(format!("value-{}.json", spec.guide.name())),
    };
    if !path.is_file() {
        return Err(JobError::field(
            "value",
            path.display(),
            format!(
                "no value network there: fit one with `ghm value{}` and name its folder",
                if spec.guide == GuideChoice::default() {
                    String::new()
                } else {
                    format!(" --guide {}", spec.guide.name())
                }
            ),
        ));
    }
    let value = ValueFile::load(&path).map_err(|e| JobError::Spec(e.to_string()))?;
    check_value_fits(&value, &path, &plant.model)?;
    Ok(value)
}

/// Refuses a value network that reads another state than the one its file names in this
/// model; warns when it was fitted on a model of another name.
fn check_value_fits(
    value: &ValueFile,
    path: &Path,
    model: &crate::lang::Model,
) -> Result<(), JobError> {
    let state = model.states.get(value.state_index).map(|s| &s.info.name);
    if state != Some(&value.state_name) {
        return Err(JobError::Spec(format!(
            "value file {}: \"state_index\" {} is {} in model `{}`, but the network was fitted on state `{}` (\"state_name\"); fit one for this model with `ghm value`",
            path.display(),
            value.state_index,
            state.map_or("no state".to_string(), |s| format!("`{s}`")),
            model.name,
            value.state_name
        )));
    }
    if value.model != model.name {
        eprintln!(
            "warning: the value network was fitted on model `{}`, this is `{}`",
            value.model, model.name
        );
    }
    Ok(())
}

/// The fixed inputs of `spec`: `const:u1,u2,...`, a CSV file, or (`None`) the start input.
pub fn parse_inputs(spec: Option<&str>, plant: &Plant) -> Result<Box<dyn Controller>, JobError> {
    let nu = plant.layout.nu;
    let Some(spec) = spec else {
        return Ok(Box::new(ConstantInput(plant.model.start_input())));
    };
    if let Some(list) = spec.strip_prefix("const:") {
        let values: Result<Vec<f64>, _> =
            list.split(',').map(|s| s.trim().parse::<f64>()).collect();
        let values = values.map_err(|_| {
            JobError::field(
                "inputs",
                spec,
                format!("expected {nu} comma-separated numbers"),
            )
        })?;
        if values.len() != nu {
            return Err(JobError::field(
                "inputs",
                spec,
                format!(
                    "gives {} values; the model has {nu} inputs ({})",
                    values.len(),
                    plant
                        .model
                        .inputs
                        .iter()
                        .map(|u| u.info.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        if let Some((u, v)) = plant
            .model
            .inputs
            .iter()
            .zip(&values)
            .find(|(_, v)| !v.is_finite())
        {
            return Err(JobError::field(
                "inputs",
                spec,
                format!(
                    "the value of {} is {v}; every input must be a finite number",
                    u.info.name
                ),
            ));
        }
        return Ok(Box::new(ConstantInput(values)));
    }
    Ok(Box::new(input_table(Path::new(spec), plant)?))
}

/// The inputs of a CSV file, one row per step: its columns named as the model's inputs,
/// or `u_<input>` as a season's `trajectory.csv` names them (so a season's inputs can be
/// played again, or start the season optimum).
pub fn input_table(path: &Path, plant: &Plant) -> Result<InputTable, JobError> {
    let names: Vec<String> = plant
        .model
        .inputs
        .iter()
        .map(|u| u.info.name.clone())
        .collect();
    let period = plant.model.sample_period;
    let (frame, columns) = match crate::sim::weather::load_csv(path, &names, period) {
        Ok(frame) => (frame, names),
        Err(plain) => {
            let logged: Vec<String> = names.iter().map(|n| format!("u_{n}")).collect();
            match crate::sim::weather::load_csv(path, &logged, period) {
                Ok(frame) => (frame, logged),
                Err(_) => return Err(plain.into()),
            }
        }
    };
    let rows = frame.rows();
    let w = frame.select(&columns, 0, rows)?;
    Ok(InputTable((0..rows).map(|k| w.at(k).to_vec()).collect()))
}

/// Loads and checks a model, printing its warnings; errors become [`JobError::Model`].
pub fn load_model(path: &std::path::Path) -> Result<crate::lang::Model, JobError> {
    match crate::lang::load(path) {
        Ok(m) => {
            if !m.warnings.is_empty() {
                eprint!(
                    "{}",
                    crate::lang::diagnostic::render(&m.sources, &m.warnings)
                );
            }
            Ok(m)
        }
        Err(f) => {
            let n = f.error_count();
            Err(JobError::Model(format!(
                "{}error: {} has {n} error{}; nothing was run\n",
                f.render(),
                path.display(),
                if n == 1 { "" } else { "s" }
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn horizons_parse_in_hours_minutes_seconds_and_steps() {
        assert_eq!(parse_horizon("horizon", "3h", 1800.0).unwrap(), 6);
        assert_eq!(parse_horizon("horizon", "90min", 1800.0).unwrap(), 3);
        assert_eq!(parse_horizon("horizon", "1800s", 1800.0).unwrap(), 1);
        assert_eq!(parse_horizon("horizon", "4", 1800.0).unwrap(), 4);
        assert_eq!(parse_horizon("horizon", "0.5h", 1800.0).unwrap(), 1);
        for bad in ["0h", "45min", "-1h", "abc", "", "1.5"] {
            assert!(parse_horizon("horizon", bad, 1800.0).is_err(), "{bad}");
        }
    }

    fn weather(file: Option<&str>) -> WeatherSpec {
        WeatherSpec {
            weather: file.map(PathBuf::from),
            ..WeatherSpec::default()
        }
    }

    #[test]
    fn the_built_in_weather_picks_the_builtin_agent_where_one_is_shipped() {
        let root = std::env::temp_dir().join(format!("ghm-shipped-{}", std::process::id()));
        let dir = root.join("agents").join("plant");
        std::fs::create_dir_all(dir.join("builtin")).unwrap();
        let model = root.join("plant.ghm");
        // No builtin/policy.json yet: the season's agent for every weather.
        assert_eq!(shipped_dir(&model, &weather(None)), dir);
        std::fs::write(dir.join("builtin").join("policy.json"), "{}").unwrap();
        assert_eq!(shipped_dir(&model, &weather(None)), dir.join("builtin"));
        assert_eq!(shipped_dir(&model, &weather(Some("venlo.csv"))), dir);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
