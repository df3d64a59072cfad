//! `ghm rlmpc`: a season of RL-guided MPC (the learned terminal cost, the terminal region
//! around the guide's roll-out, and warm starts from the guide), with the outputs of
//! `ghm mpc` and, per step, the terminal region's state. Without `--agent`/`--value` it
//! uses the agent and value network shipped for the model under `models/agents/`.
//! `--compare` also runs plain MPC at the same horizon and prints both.

use crate::cli::guide::{guide_factory, shipped_dir, GuideChoice};
use crate::cli::mpc::{bands_name, make_mpc, parse_horizon, BandsChoice, SolverChoice};
use crate::cli::output::figure;
use crate::cli::simulate::{run_season_and_report, SeasonArgs};
use crate::cli::weather_args::{UncertaintyArgs, WeatherArgs};
use crate::cli::{load_model, CliError};
use crate::control::{RlGuidance, RlMpcOptions, TerminalCostForm, ValueFile};
use crate::model::Plant;
use clap::{Args, ValueEnum};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// With or without the terminal region.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Variant {
    /// Terminal cost, terminal region and guide warm start (the paper's RL-MPC).
    Rlmpc,
    /// Value function only: no terminal region (the paper's RL-MPC-VFO).
    Vfo,
}

/// The terminal cost's form.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CostForm {
    /// −V with its exact gradient and Hessian.
    Exact,
    /// −V's first-order expansion around the guess's terminal state (the paper's code).
    Taylor,
    /// No terminal cost (guide warm start and region only).
    None,
}

#[derive(Debug, Args)]
pub struct RlmpcArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// Prediction horizon: `1h`, `90min`, `1800s` or a number of steps.
    #[arg(long, value_name = "H", default_value = "1h")]
    pub horizon: String,
    /// The guide.
    #[arg(long, value_enum, default_value_t = GuideChoice::Sac)]
    pub guide: GuideChoice,
    /// The SAC agent (a `ghm train` folder or policy file); default: the shipped one.
    #[arg(long, value_name = "DIR")]
    pub agent: Option<PathBuf>,
    /// The value network (a `ghm value` folder or value.json); default: the shipped one
    /// for the guide.
    #[arg(long, value_name = "DIR")]
    pub value: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t = Variant::Rlmpc)]
    pub variant: Variant,
    /// Relative half-width ε of the terminal region.
    #[arg(long, value_name = "EPS", default_value_t = 0.05)]
    pub epsilon: f64,
    #[arg(long, value_enum, default_value_t = CostForm::Exact)]
    pub terminal_cost: CostForm,
    /// The NLP back-end.
    #[arg(long, value_enum, default_value_t = SolverChoice::Ipm)]
    pub solver: SolverChoice,
    /// Soft-band bounds to plan with (as `ghm mpc --bands`).
    #[arg(long, value_enum, default_value_t = BandsChoice::Auto)]
    pub bands: BandsChoice,
    #[command(flatten)]
    pub weather: WeatherArgs,
    #[command(flatten)]
    pub plant: UncertaintyArgs,
    /// Also run plain MPC at the same horizon (into OUT/mpc) and print both.
    #[arg(long)]
    pub compare: bool,
    /// Run folder.
    #[arg(long, value_name = "DIR", default_value = "runs/rlmpc")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

/// The value file of `--value`, or the shipped one for the guide.
fn resolve_value(args: &RlmpcArgs, plant: &Plant) -> Result<ValueFile, CliError> {
    let path = match &args.value {
        Some(p) if p.is_dir() => p.join("value.json"),
        Some(p) => p.clone(),
        None => {
            shipped_dir(&args.file, &args.weather).join(format!("value-{}.json", args.guide.name()))
        }
    };
    if !path.is_file() {
        return Err(CliError::Argument(format!(
            "no value network at {}: fit one with `ghm value{}` and pass --value DIR",
            path.display(),
            if args.guide == GuideChoice::Expert {
                " --guide expert"
            } else {
                ""
            }
        )));
    }
    let value = ValueFile::load(&path).map_err(|e| CliError::Argument(e.to_string()))?;
    check_value_fits(&value, &path, &plant.model)?;
    Ok(value)
}

/// Refuses a value network that reads another state than the one its file names in this
/// model; warns when it was fitted on a model of another name.
fn check_value_fits(
    value: &ValueFile,
    path: &Path,
    model: &crate::lang::Model,
) -> Result<(), CliError> {
    let state = model.states.get(value.state_index).map(|s| &s.info.name);
    if state != Some(&value.state_name) {
        return Err(CliError::Argument(format!(
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

pub fn run(args: &RlmpcArgs) -> Result<(), CliError> {
    let model = load_model(&args.file)?;
    let plant = Arc::new(Plant::new(model));
    let horizon = parse_horizon(&args.horizon, plant.model.sample_period)?;
    let make_guide = guide_factory(
        &plant,
        args.guide,
        &args.file,
        &args.weather,
        args.agent.as_deref(),
    )?;
    let value = match args.terminal_cost {
        CostForm::None => None,
        _ => Some(resolve_value(args, &plant)?),
    };
    if let Some(v) = &value {
        if v.guide != args.guide.name() {
            eprintln!(
                "warning: the value network learned the {} guide's returns; the guide is {}",
                v.guide,
                args.guide.name()
            );
        }
    }
    let options = RlMpcOptions {
        epsilon: (args.variant == Variant::Rlmpc).then_some(args.epsilon),
        terminal_cost: match args.terminal_cost {
            CostForm::Taylor => TerminalCostForm::Taylor,
            _ => TerminalCostForm::Exact,
        },
    };
    let guidance = RlGuidance::new(
        plant.clone(),
        make_guide(),
        args.guide.name(),
        value,
        options,
    )
    .map_err(|e| CliError::Argument(e.to_string()))?;
    let bands = args.bands.resolve(&args.plant);
    let mut controller =
        make_mpc(&plant, horizon, args.solver, bands)?.with_guidance(Box::new(guidance));
    let extra = json!({
        "horizon_steps": horizon,
        "horizon_h": horizon as f64 * plant.model.sample_period / 3600.0,
        "guide": args.guide.name(),
        "variant": format!("{:?}", args.variant).to_lowercase(),
        "epsilon": args.epsilon,
        "terminal_cost": format!("{:?}", args.terminal_cost).to_lowercase(),
        "bands": bands_name(bands),
    });
    fn season<'a>(args: &'a RlmpcArgs, out: &'a Path, horizon: usize) -> SeasonArgs<'a> {
        SeasonArgs {
            file: &args.file,
            weather: &args.weather,
            uncertainty: &args.plant,
            out,
            overwrite: args.overwrite,
            enforce_limits: true,
            forecast: horizon,
        }
    }
    let guided = run_season_and_report(
        &season(args, &args.out, horizon),
        &plant,
        &mut controller,
        extra,
    )?;
    if args.compare {
        let mpc_dir = args.out.join("mpc");
        let mut mpc = make_mpc(&plant, horizon, args.solver, bands)?;
        println!();
        let plain = run_season_and_report(
            &season(args, &mpc_dir, horizon),
            &plant,
            &mut mpc,
            json!({ "horizon_steps": horizon, "bands": bands_name(bands) }),
        )?;
        let unit = plant.model.objective_unit();
        println!();
        println!("at a {} horizon:", args.horizon);
        println!(
            "  {:<22} EPI {} {unit}, cumulative reward {} {unit}, median solve {:.2} ms",
            controller_label(args),
            figure(guided.epi, true),
            figure(guided.cumulative_reward, true),
            guided.solve.median_ms
        );
        println!(
            "  {:<22} EPI {} {unit}, cumulative reward {} {unit}, median solve {:.2} ms",
            "MPC",
            figure(plain.epi, true),
            figure(plain.cumulative_reward, true),
            plain.solve.median_ms
        );
    }
    Ok(())
}

fn controller_label(args: &RlmpcArgs) -> String {
    let variant = match args.variant {
        Variant::Rlmpc => "RL-MPC",
        Variant::Vfo => "RL-MPC-VFO",
    };
    format!("{variant} ({})", args.guide.name())
}
