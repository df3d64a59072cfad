//! RL-guided MPC from the library: the trained agent and value network shipped with the
//! lettuce model for ghm's built-in weather guide a 1-hour MPC; four days on that weather,
//! beside the agent alone and plain MPC at the same horizon. (`models/agents/lettuce/`
//! holds the agent trained on the Venlo 2014 season; its `builtin/` subfolder the one
//! trained on the built-in season.)
//!
//! Run: `cargo run --release --example rl_guided_mpc`

use ghm::control::{Controller, Mpc, Policy, RlGuidance, RlMpcOptions, ValueFile};
use ghm::model::Plant;
use ghm::rl::PolicyFile;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::builtin_season;
use ghm::solve::Ipm;
use std::path::Path;
use std::sync::Arc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = ghm::lang::load(&root.join("models/lettuce.ghm"))?;
    let plant = Arc::new(Plant::new(model));
    let agent = root.join("models/agents/lettuce/builtin");
    let policy = PolicyFile::load(&agent.join("policy.json"))?;
    let value = ValueFile::load(&agent.join("value-sac.json"))?;

    let (steps, horizon) = (192, 2); // four days of 30-minute steps, 1 h ahead
    let columns = plant.model.weather_columns();
    let weather = builtin_season(steps + horizon, plant.model.sample_period, 2014).select(
        &columns,
        0,
        steps + horizon,
    )?;

    // The guide is any controller; here the trained policy (the rule-based
    // `ghm::control::Expert` works the same way, without training).
    let guide = Policy::new(&plant, policy.clone())?;
    let guidance = RlGuidance::new(
        plant.clone(),
        Box::new(guide),
        "sac",
        Some(value),
        RlMpcOptions::default(), // ε = 5 % terminal region, exact terminal cost
    )?;
    let rl_mpc = Mpc::new(plant.clone(), horizon, Box::new(Ipm::default()))?
        .with_guidance(Box::new(guidance));
    let mpc = Mpc::new(plant.clone(), horizon, Box::new(Ipm::default()))?;
    let agent_alone = Policy::new(&plant, policy)?;

    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let controllers: Vec<(&str, Box<dyn Controller>)> = vec![
        ("agent alone", Box::new(agent_alone)),
        ("MPC", Box::new(mpc)),
        ("RL-guided MPC", Box::new(rl_mpc)),
    ];
    for (name, mut controller) in controllers {
        let result = run_season(
            &plant,
            &weather,
            controller.as_mut(),
            &config,
            &mut |_: &StepLog| {},
        )?;
        let m = &result.metrics;
        println!(
            "{name:<14} EPI {:+.4}  cumulative reward {:+.4}  ({} failed solves)",
            m.epi, m.cumulative_reward, m.solve.failed_solves
        );
    }
    Ok(())
}
