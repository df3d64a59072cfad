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

pub use super::jobs::{Job, Work};
use super::own_agents::{Agents, Distilled, Learning, OwnAgents, LEARNED_FOLDERS};
use crate::job::{
    Choice, ControllerKind, ControllerSpec, GuideChoice, PlantSpec, RunSpec, WeatherSpec,
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
    #[serde(default)]
    distilled: Option<Distilled>,
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

/// The folder of a model's season optimum.
const OPTIMUM_FOLDER: &str = "optimum";

/// The largest number of stochastic scenarios a study may ask for.
const MAX_SCENARIOS: usize = 10_000;

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

    if let Some(agents) = &file.agents {
        agents.check()?;
    }
    let template = file
        .distilled
        .as_ref()
        .map(|d| {
            let teacher = d
                .teacher
                .clone()
                .map(|table| controller_spec(table, "", place))
                .transpose()
                .map_err(|m| format!("[distilled] teacher: {m}"))?;
            d.template(teacher)
        })
        .transpose()?;
    let learning = Learning {
        agents: file.agents.as_ref(),
        distilled: file.distilled.as_ref().zip(template.as_ref()),
    };
    let reserved = LEARNED_FOLDERS.iter().chain(&[OPTIMUM_FOLDER]);
    if let Some((c, folder)) = controllers.iter().find_map(|c| {
        reserved
            .clone()
            .find(|f| slug(&c.name) == **f)
            .map(|f| (c, f))
    }) {
        return Err(at_line(
            text,
            c.span.clone(),
            format!(
                "controller `{}` would write into the folder `{folder}`, which the study keeps for \
                 its own runs; give it another name",
                c.name
            ),
        ));
    }
    let mut jobs = Vec::new();
    for model in &file.models {
        let model_path = place.locate(model)?;
        let stem = model
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "model".into());
        let mut own = OwnAgents::new(learning, &stem, out);
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
                folder: Path::new(&stem).join(OPTIMUM_FOLDER),
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
                    let (controller, needs) =
                        own.attach(spec.clone(), c.guide, plant).map_err(|m| {
                            at_line(
                                text,
                                c.span.clone(),
                                format!("controller `{}`: {m}", c.name),
                            )
                        })?;
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
        jobs.extend(own.jobs(&model_path, &weather, s.uncertainty));
        jobs.extend(seasons);
    }
    Ok(jobs)
}

/// A `[[controllers]]` entry: its name, kind and the rest of its fields.
struct ControllerEntry {
    name: String,
    kind: ControllerKind,
    horizon: Option<String>,
    /// The learned guide a policy controller follows (`guide`, SAC's by default), for the
    /// study's own agents.
    guide: GuideChoice,
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
    // A policy's `guide` says which of the study's learned guides it follows.
    let guide = match (kind, fields.get("guide")) {
        (ControllerKind::Policy, Some(toml::Value::String(g))) => match GuideChoice::from_name(g) {
            Some(g @ (GuideChoice::Sac | GuideChoice::Distilled)) => {
                fields.remove("guide");
                g
            }
            _ => {
                return Err(format!(
                    "controller `{name}`: a policy follows `guide` = \"sac\" or \"distilled\", not \"{g}\""
                ))
            }
        },
        _ => GuideChoice::Sac,
    };
    Ok(ControllerEntry {
        name,
        kind,
        horizon,
        guide,
        fields,
        span,
    })
}

impl ControllerEntry {
    /// The controller at `horizon` (empty: none), its file paths located by `place`.
    fn spec(&self, horizon: &str, place: &Place) -> Result<ControllerSpec, String> {
        controller_spec(self.fields.clone(), horizon, place)
            .map_err(|m| format!("controller `{}`: {m}", self.name))
    }
}

/// The controller a table of `kind` and its fields describes, at `horizon` (empty: as
/// written), its file paths located by `place`.
fn controller_spec(
    mut fields: toml::Table,
    horizon: &str,
    place: &Place,
) -> Result<ControllerSpec, String> {
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
        .map_err(|e| e.message().to_string())
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

    /// Phases: every job reads only jobs planned before it, of an earlier phase.
    fn needs_come_first(jobs: &[Job]) {
        for (k, job) in jobs.iter().enumerate() {
            for need in &job.needs {
                let i = jobs.iter().position(|j| &j.folder == need).unwrap();
                assert!(i < k && jobs[i].work.phase() < job.work.phase(), "{need:?}");
            }
        }
    }

    /// The jobs' folders, in order.
    fn folders(jobs: &[Job]) -> Vec<String> {
        jobs.iter()
            .map(|j| j.folder.display().to_string())
            .collect()
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
            learning_rate = 1e-3
            value_days = 10
            state = "temp_air"
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
        let folders = folders(&jobs);
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
        let config = train.config();
        assert_eq!(
            (config.gamma, config.batch_size, config.learning_rate),
            (0.99, 64, 1e-3)
        );
        let Work::Value(value) = &jobs[4].work else {
            panic!("{:?}", jobs[4].work);
        };
        assert_eq!(
            value.agent.as_deref(),
            Some(Path::new("/out/lettuce/agents/stochastic"))
        );
        assert_eq!(jobs[4].needs, [Path::new("lettuce/agents/stochastic")]);
        // The value fits roll out over their own days, reading the state named; the
        // trainings over the study's season.
        assert_eq!(
            (value.weather.days, value.state.as_deref()),
            (Some(10.0), Some("temp_air"))
        );
        assert_eq!(train.weather.days, None);
        needs_come_first(&jobs);
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
    fn distilled_guides_are_distilled_and_fitted_before_the_seasons_that_read_them() {
        let jobs = plan_text(
            r#"
            models = ["../models/lettuce.ghm"]
            horizons = ["1h"]
            [scenarios]
            stochastic = 1
            uncertainty = 0.05
            [distilled]
            iterations = 3
            start_rows = "0..5000"
            warming = "0..8"
            keep_humidity = ["hum_out"]
            forecast_rows = 12
            days = 4
            [distilled.teacher]
            kind = "mpc"
            horizon = "2h"
            [[controllers]]
            name = "Distilled"
            kind = "policy"
            guide = "distilled"
            [[controllers]]
            name = "RL-MPC (distilled)"
            kind = "rlmpc"
            guide = "distilled"
            [[controllers]]
            name = "RL-MPC"
            kind = "rlmpc"
            "#,
        )
        .unwrap();
        let folders = folders(&jobs);
        // Without [agents], the SAC guide is the shipped one: nothing trained for it.
        assert_eq!(
            folders[..4],
            [
                "lettuce/distillations/nominal",
                "lettuce/distillations/stochastic",
                "lettuce/values/nominal-distilled",
                "lettuce/values/stochastic-distilled",
            ]
        );
        let Work::Distill(distill) = &jobs[1].work else {
            panic!("{:?}", jobs[1].work);
        };
        assert!(distill.stochastic && distill.uncertainty == 0.05 && distill.iterations == 3);
        assert_eq!(distill.forecast_rows, 12);
        assert_eq!(
            (distill.weather.days, distill.weather.steps),
            (Some(4.0), None)
        );
        let warming = distill.warming.as_ref().unwrap();
        assert_eq!(
            (warming.degrees, &warming.keep_humidity[..]),
            ([0.0, 8.0], &["hum_out".to_string()][..])
        );
        assert_eq!(distill.teacher.horizon(), Some("2h"));
        assert_eq!(
            distill.start_rows,
            Some(crate::job::distill::StartRows {
                first: 0,
                last: 5000
            })
        );
        let Work::Value(value) = &jobs[3].work else {
            panic!("{:?}", jobs[3].work);
        };
        assert_eq!(value.guide, GuideChoice::Distilled);
        needs_come_first(&jobs);
        assert_eq!(
            jobs[3].needs,
            [Path::new("lettuce/distillations/stochastic")]
        );
        let by_folder = |f: &str| jobs.iter().find(|j| j.folder == Path::new(f)).unwrap();
        let policy = by_folder("lettuce/distilled/stochastic-00");
        assert_eq!(
            policy.needs,
            [Path::new("lettuce/distillations/stochastic")]
        );
        let rlmpc = by_folder("lettuce/rl-mpc-distilled/1h/nominal");
        assert_eq!(
            rlmpc.needs,
            [
                Path::new("lettuce/distillations/nominal"),
                Path::new("lettuce/values/nominal-distilled")
            ]
        );
        assert!(by_folder("lettuce/rl-mpc/1h/nominal").needs.is_empty());
        // A distilled guide needs [distilled] or its own agent; a policy follows a
        // learned guide only.
        for (entry, expected) in [
            (
                "kind = \"policy\"\nguide = \"distilled\"",
                "line 3: controller `policy`: a distilled guide needs its `agent`",
            ),
            (
                "kind = \"policy\"\nguide = \"expert\"",
                "a policy follows `guide` = \"sac\" or \"distilled\"",
            ),
        ] {
            let text = format!("models = [\"m.ghm\"]\n\n[[controllers]]\n{entry}");
            let e = plan_text(&text).unwrap_err();
            assert!(e.contains(expected), "{text}\n→ {e}");
        }
        let e = plan_text("models = [\"m.ghm\"]\n[distilled]\nstart_rows = \"9\"\n[[controllers]]\nkind = \"expert\"")
            .unwrap_err();
        assert!(
            e.contains("[distilled] start_rows: `9` is not FIRST..LAST"),
            "{e}"
        );
        for (distilled, expected) in [
            ("warming = \"8\"", "[distilled] warming: `8` is not LO..HI"),
            (
                "keep_humidity = [\"hum_out\"]",
                "[distilled] keep_humidity needs a warming",
            ),
        ] {
            let text = format!("models = [\"m.ghm\"]\n[distilled]\n{distilled}\n[[controllers]]\nkind = \"expert\"");
            let e = plan_text(&text).unwrap_err();
            assert!(e.contains(expected), "{text}\n→ {e}");
        }
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
            (
                "models = [\"m.ghm\"]\n[[controllers]]\nname = \"Values\"\nkind = \"expert\"",
                "line 2: controller `Values` would write into the folder `values`",
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

    /// A roll-out length that is not a positive number of days is refused when the study
    /// is planned, naming its key.
    #[test]
    fn learned_guides_roll_out_over_a_positive_number_of_days() {
        for (table, key) in [
            ("[distilled]\ndays = 0", "[distilled] days"),
            ("[agents]\nvalue_days = -2", "[agents] value_days"),
        ] {
            let text = format!(
                "models = [\"../models/lettuce.ghm\"]\n{table}\n[[controllers]]\nname = \"MPC\"\nkind = \"mpc\"\n"
            );
            let error = plan_text(&text).unwrap_err();
            assert!(error.contains(key), "{error}");
        }
    }
}
