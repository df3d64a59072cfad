//! A study file (TOML) and the jobs it plans: one season per (model, controller, horizon,
//! scenario), and the season optimum per model where asked, each with its own run folder
//! under the study's output folder.
//!
//! ```toml
//! models = ["../models/lettuce.ghm"]     # paths are relative to the study file
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
//! kind = "mpc"                            # inputs, expert, policy, mpc, rlmpc
//! ```

use crate::job::{ControllerSpec, PlantSpec, RunSpec, WeatherSpec};
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
    controllers: Vec<toml::Table>,
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

/// One planned season.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    /// What to run.
    pub spec: RunSpec,
    /// Its run folder, relative to the study's output folder.
    pub folder: PathBuf,
    /// The model's file stem (a table's first column).
    pub model: String,
    /// The controller's name as the study file gives it.
    pub controller: String,
    /// The horizon as written, empty for controllers without one.
    pub horizon: String,
    /// `nominal` or `stochastic-NN`.
    pub scenario: String,
}

/// Reads the study file at `path` and plans its jobs, in a fixed order (the shards rely
/// on it): per model, the optimum first, then per controller, horizon and scenario.
pub fn plan(path: &Path) -> Result<Vec<Job>, StudyError> {
    let text = std::fs::read_to_string(path).map_err(|e| StudyError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let file: StudyFile = toml::from_str(&text).map_err(|e| StudyError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    plan_file(file, base).map_err(|message| StudyError::File {
        path: path.to_path_buf(),
        message,
    })
}

fn plan_file(file: StudyFile, base: &Path) -> Result<Vec<Job>, String> {
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
    weather.weather = weather.weather.map(|p| locate(base, &p));
    weather.knmi = weather.knmi.map(|p| locate(base, &p));
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
        .map(|(i, table)| controller_entry(i, table))
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
        let model_path = locate(base, model);
        let stem = model
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "model".into());
        if file.optimum {
            jobs.push(Job {
                spec: RunSpec {
                    model: model_path.clone(),
                    weather: weather.clone(),
                    plant: PlantSpec::NOMINAL,
                    controller: ControllerSpec::Optimum(crate::job::OptimumSpec {
                        init_horizon: "1h".into(),
                        solver: None,
                        max_iterations: 500,
                    }),
                },
                folder: Path::new(&stem).join("optimum"),
                model: stem.clone(),
                controller: "optimum".into(),
                horizon: String::new(),
                scenario: "nominal".into(),
            });
        }
        for c in &controllers {
            let horizons: Vec<String> = match (&c.horizon, c.needs_horizon) {
                (Some(h), _) => vec![h.clone()],
                (None, true) if file.horizons.is_empty() => {
                    return Err(format!(
                        "controller `{}` ({}) needs a horizon: give it `horizon = \"3h\"` or the study `horizons = [...]`",
                        c.name, c.kind
                    ))
                }
                (None, true) => file.horizons.clone(),
                (None, false) => vec![String::new()],
            };
            for horizon in &horizons {
                let spec = c.spec(horizon, base)?;
                for (scenario, plant) in &scenarios {
                    let mut folder = Path::new(&stem).join(slug(&c.name));
                    if !horizon.is_empty() {
                        folder.push(slug(horizon));
                    }
                    folder.push(scenario);
                    jobs.push(Job {
                        spec: RunSpec {
                            model: model_path.clone(),
                            weather: weather.clone(),
                            plant: plant.clone(),
                            controller: spec.clone(),
                        },
                        folder,
                        model: stem.clone(),
                        controller: c.name.clone(),
                        horizon: horizon.clone(),
                        scenario: scenario.clone(),
                    });
                }
            }
        }
    }
    Ok(jobs)
}

/// A `[[controllers]]` entry: its name, kind and the rest of its fields.
struct ControllerEntry {
    name: String,
    kind: String,
    horizon: Option<String>,
    needs_horizon: bool,
    fields: toml::Table,
}

fn controller_entry(index: usize, table: &toml::Table) -> Result<ControllerEntry, String> {
    let mut fields = table.clone();
    let kind = match fields.get("kind") {
        Some(toml::Value::String(k)) => k.clone(),
        _ => {
            return Err(format!(
                "controller {} has no `kind` (one of inputs, expert, policy, mpc, rlmpc)",
                index + 1
            ))
        }
    };
    let name = match fields.remove("name") {
        Some(toml::Value::String(n)) if !n.trim().is_empty() => n,
        None => kind.clone(),
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
    if kind == "optimum" {
        return Err(format!(
            "controller `{name}`: the optimum is asked for with `optimum = true` at the top of the study"
        ));
    }
    Ok(ControllerEntry {
        needs_horizon: kind == "mpc" || kind == "rlmpc",
        name,
        kind,
        horizon,
        fields,
    })
}

impl ControllerEntry {
    /// The controller at `horizon` (empty: none), its file paths relative to `base`.
    fn spec(&self, horizon: &str, base: &Path) -> Result<ControllerSpec, String> {
        let mut fields = self.fields.clone();
        if !horizon.is_empty() {
            fields.insert("horizon".into(), toml::Value::String(horizon.into()));
        }
        for key in ["agent", "value", "inputs"] {
            if let Some(toml::Value::String(p)) = fields.get(key) {
                if !p.starts_with("const:") {
                    let located = locate(base, Path::new(p)).to_string_lossy().into_owned();
                    fields.insert(key.into(), toml::Value::String(located));
                }
            }
        }
        toml::Value::Table(fields)
            .try_into::<ControllerSpec>()
            .map_err(|e| format!("controller `{}`: {}", self.name, e.message()))
    }
}

/// A path of the study file, relative to its folder: the file's canonical path where it
/// exists (so that a job's spec names the same file however the study reaches it), as
/// joined otherwise (the job then says that it is missing).
fn locate(base: &Path, path: &Path) -> PathBuf {
    let joined = base.join(path);
    std::fs::canonicalize(&joined).unwrap_or(joined)
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
        plan_file(file, Path::new("studies"))
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
        assert_eq!(jobs[3].spec.plant.seed, 2);
        assert_eq!(jobs[9].folder, Path::new("lettuce/expert/stochastic-01"));
        assert_eq!(
            jobs[1].spec.model,
            Path::new("studies/../models/lettuce.ghm")
        );
        assert_eq!(jobs[1].spec.weather.days, Some(2.0));
        let ControllerSpec::Rlmpc(r) = &jobs[4].spec.controller else {
            panic!("{:?}", jobs[4].spec.controller);
        };
        assert_eq!(r.horizon, "6h");
    }

    #[test]
    fn mistakes_in_a_study_are_named() {
        let cases = [
            ("models = []\n[[controllers]]\nkind = \"expert\"", "names no model"),
            ("models = [\"m.ghm\"]", "runs nothing"),
            ("models = [\"m.ghm\"]\n[[controllers]]\nkind = \"mpc\"", "needs a horizon"),
            (
                "models = [\"m.ghm\"]\nhorizons = [\"1h\"]\n[[controllers]]\nkind = \"mpc\"\nsolvr = \"sqp\"",
                "solvr",
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
    fn slugs_are_folder_names() {
        assert_eq!(slug("RL-MPC (sac)"), "rl-mpc-sac");
        assert_eq!(slug("MPC"), "mpc");
        assert_eq!(slug("1.5h"), "1.5h");
        assert_eq!(slug("***"), "controller");
    }
}
