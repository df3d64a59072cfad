//! `ghm rlmpc`: a season of RL-guided MPC (the learned terminal cost, the terminal region
//! around the guide's roll-out, and warm starts from the guide), with the outputs of
//! `ghm mpc` and, per step, the terminal region's state. Without `--agent`/`--value` it
//! uses the agent and value network shipped for the model under `models/agents/`.
//! `--compare` also runs plain MPC at the same horizon and prints both.

use crate::cli::args::{choice, FolderArgs, PlantArgs, WeatherArgs};
use crate::cli::mpc::NlpArgs;
use crate::cli::CliError;
use crate::job::output::figure;
use crate::job::{ControllerSpec, CostForm, GuideChoice, MpcSpec, RlmpcSpec, RunSpec, Variant};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct RlmpcArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// Prediction horizon: `1h`, `90min`, `1800s` or a number of steps.
    #[arg(long, value_name = "H", default_value_t = RlmpcSpec::default().mpc.horizon)]
    pub horizon: String,
    #[command(flatten)]
    pub guidance: GuideArgs,
    #[command(flatten)]
    pub nlp: NlpArgs,
    #[command(flatten)]
    pub weather: WeatherArgs,
    #[command(flatten)]
    pub plant: PlantArgs,
    /// Also run plain MPC at the same horizon (into OUT/mpc) and print both.
    #[arg(long)]
    pub compare: bool,
    /// Run folder.
    #[arg(long, value_name = "DIR", default_value = "runs/rlmpc")]
    pub out: PathBuf,
    #[command(flatten)]
    pub folder: FolderArgs,
}

/// The guide, its value network, the terminal region and the terminal cost of RL-guided
/// MPC (`ghm rlmpc`, `ghm serve`).
#[derive(Debug, Clone, Args)]
pub struct GuideArgs {
    /// The guide.
    #[arg(long, value_parser = choice::<GuideChoice>(), default_value_t = RlmpcSpec::default().guide)]
    pub guide: GuideChoice,
    /// The guide's policy (a `ghm train` or `ghm distill` folder, or a policy file);
    /// default: the SAC agent shipped for the model.
    #[arg(long, value_name = "DIR")]
    pub agent: Option<PathBuf>,
    /// The value network (a `ghm value` folder or value.json); default: the shipped one
    /// for the guide.
    #[arg(long, value_name = "DIR")]
    pub value: Option<PathBuf>,
    /// With or without the terminal region.
    #[arg(long, value_parser = choice::<Variant>(), default_value_t = RlmpcSpec::default().variant)]
    pub variant: Variant,
    /// Relative half-width ε of the terminal region.
    #[arg(long, value_name = "EPS", default_value_t = RlmpcSpec::default().epsilon)]
    pub epsilon: f64,
    /// The terminal cost's form.
    #[arg(long, value_parser = choice::<CostForm>(), default_value_t = RlmpcSpec::default().terminal_cost)]
    pub terminal_cost: CostForm,
}

impl GuideArgs {
    /// RL-guided MPC of `mpc` with these settings.
    pub fn rlmpc(&self, mpc: MpcSpec) -> RlmpcSpec {
        RlmpcSpec {
            mpc,
            guide: self.guide,
            agent: self.agent.clone(),
            value: self.value.clone(),
            variant: self.variant,
            epsilon: self.epsilon,
            terminal_cost: self.terminal_cost,
        }
    }
}

pub fn run(args: &RlmpcArgs) -> Result<(), CliError> {
    let rlmpc = args.guidance.rlmpc(args.nlp.mpc(&args.horizon));
    let spec = |controller| RunSpec {
        model: args.file.clone(),
        weather: args.weather.spec(),
        plant: args.plant.spec(),
        controller,
    };
    let label = rlmpc.label();
    let plain = ControllerSpec::Mpc(rlmpc.mpc.clone());
    let guided = args
        .folder
        .run_season(&spec(ControllerSpec::Rlmpc(rlmpc)), &args.out)?;
    if args.compare {
        println!();
        let plain = args
            .folder
            .run_season(&spec(plain), &args.out.join("mpc"))?;
        let unit = &guided.unit;
        println!();
        println!("at a {} horizon:", args.horizon);
        for (name, m) in [(label.as_str(), &guided.metrics), ("MPC", &plain.metrics)] {
            println!(
                "  {:<22} EPI {} {unit}, cumulative reward {} {unit}, median solve {:.2} ms",
                name,
                figure(m.epi, true),
                figure(m.cumulative_reward, true),
                m.solve.median_ms
            );
        }
    }
    Ok(())
}
