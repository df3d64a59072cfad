//! Soft actor-critic: it learns a small control task, checkpoints resume exactly, and the
//! exported policy (plain weights, any dual number type) matches the burn actor and drives
//! a season exactly as the training's own evaluation does.

use burn::tensor::{Device, Tensor, TensorData};
use ghm::control::Policy;
use ghm::model::{ModelBuilder, Plant};
use ghm::rl::sac::{SacConfig, Trainer};
use ghm::rl::{Env, PolicyFile};
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::Weather;
use num_dual::{first_derivative, DualNum};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

const STEPS: usize = 40;

/// Drive a position from 0 to 1: `dx/dt = 0.25 u`, `u ∈ [−1, 1]`, reward `−(x − 1)²`.
fn reach_plant() -> Arc<Plant> {
    let b = ModelBuilder::new("reach");
    let pos = b.state("pos", 0.0);
    let push = b.input("push").bounds(-1.0, 1.0);
    b.der(pos, 0.25 * push);
    b.output("pos", pos);
    let gap = pos - 1.0;
    b.cost("distance", gap * gap);
    b.sample(1.0, 1);
    Arc::new(Plant::new(b.build().expect("the reach model builds")))
}

fn reach_env() -> Env {
    let plant = reach_plant();
    let weather = Weather::constant(vec![], &[], STEPS, 1.0);
    Env::new(plant, weather, STEPS, None).expect("env")
}

fn small_config(episodes: usize) -> SacConfig {
    SacConfig {
        hidden: vec![64, 64],
        gamma: 0.9,
        learning_rate: 3e-3,
        batch_size: 128,
        buffer_size: 20_000,
        warmup_episodes: 3,
        episodes,
        eval_every: 5,
        seed: 11,
        ..SacConfig::default()
    }
}

/// Cumulative reward of uniformly random actions, averaged over a few episodes.
fn random_reward(env: &mut Env) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut total = 0.0;
    for _ in 0..5 {
        env.reset();
        loop {
            let a = [rng.random_range(-1.0..=1.0)];
            let t = env.step(&a).unwrap();
            total += t.reward;
            if t.done {
                break;
            }
        }
    }
    total / 5.0
}

#[test]
fn sac_learns_to_reach_the_target() {
    let mut env = reach_env();
    let random = random_reward(&mut env);
    let mut trainer = Trainer::new(env, small_config(40)).unwrap();
    while !trainer.is_finished() {
        trainer.run_episode(&mut |_| {}).unwrap();
    }
    let learned = trainer.evaluate().unwrap();
    // The best possible return is about −1.9 (four steps at full push, then hold).
    assert!(
        learned > -4.0 && learned > random + 10.0,
        "deterministic return {learned:.3} after training; random actions {random:.3}"
    );
}

#[test]
fn resuming_from_a_checkpoint_repeats_the_uninterrupted_run() {
    let dir = std::env::temp_dir().join(format!("ghm-sac-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let config = SacConfig {
        eval_every: 2,
        ..small_config(6)
    };
    let mut straight = Trainer::new(reach_env(), config.clone()).unwrap();
    while !straight.is_finished() {
        straight.run_episode(&mut |_| {}).unwrap();
    }
    let mut first = Trainer::new(reach_env(), config).unwrap();
    for _ in 0..4 {
        first.run_episode(&mut |_| {}).unwrap();
    }
    first.save_checkpoint(&dir).unwrap();
    drop(first);
    let mut resumed = Trainer::resume(reach_env(), &dir).unwrap();
    assert_eq!(resumed.episodes_done(), 4);
    while !resumed.is_finished() {
        resumed.run_episode(&mut |_| {}).unwrap();
    }
    assert_eq!(
        resumed.agent(),
        straight.agent(),
        "weights and optimiser state differ"
    );
    assert_eq!(resumed.normalizer(), straight.normalizer());
    let rewards = |t: &Trainer| -> Vec<(f64, Option<f64>)> {
        t.curve()
            .iter()
            .map(|r| (r.reward, r.eval_reward))
            .collect()
    };
    assert_eq!(rewards(&resumed), rewards(&straight));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Five episodes, each one evaluated, so that the best evaluation is a choice among five.
fn trained_policy() -> (Trainer, PolicyFile) {
    let config = SacConfig {
        eval_every: 1,
        ..small_config(5)
    };
    let mut trainer = Trainer::new(reach_env(), config).unwrap();
    while !trainer.is_finished() {
        trainer.run_episode(&mut |_| {}).unwrap();
    }
    let policy = trainer.policy("reach").unwrap();
    (trainer, policy)
}

#[test]
fn exported_actor_matches_the_burn_actor() {
    let (trainer, policy) = trained_policy();
    // The best policy's actor is the one exported.
    let actor = &trainer.best().expect("evaluated").actor;
    let width = policy.normalizer.width();
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let n = 1000;
    let standard: Vec<f32> = (0..n * width)
        .map(|_| rng.random_range(-3.0..3.0))
        .collect();
    let device = Device::flex().autodiff();
    let input = Tensor::<2>::from_data(TensorData::new(standard.clone(), [n, width]), &device);
    let burn_out = actor
        .tensors(&device, false)
        .forward(input)
        .narrow(1, 0, 1)
        .tanh()
        .into_data()
        .try_to_vec::<f32>()
        .unwrap();
    let mut worst = 0.0f64;
    for (row, expected) in standard.chunks(width).zip(&burn_out) {
        let x: Vec<f64> = row.iter().map(|v| f64::from(*v)).collect();
        let ours = policy.actor.forward(&x)[0];
        worst = worst.max((ours - f64::from(*expected)).abs());
    }
    assert!(worst < 1e-5, "largest difference {worst:e}");
}

#[test]
fn exported_policy_differentiates_and_drives_a_season_like_the_evaluation() {
    let (mut trainer, policy) = trained_policy();
    // The shipped policy is the best of the evaluations after each episode, and says which.
    let evals: Vec<f64> = trainer
        .curve()
        .iter()
        .filter_map(|r| r.eval_reward)
        .collect();
    assert_eq!(evals.len(), 5);
    let (at, best) = (evals.iter().copied().enumerate())
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    assert_eq!(policy.eval_reward, Some(best), "evaluations {evals:?}");
    assert_eq!(policy.episode, at + 1, "evaluations {evals:?}");
    // Evaluation is deterministic: the current policy evaluates as after the last episode.
    assert_eq!(trainer.evaluate().unwrap(), evals[4]);
    let plant = reach_plant();
    let weather = Weather::constant(vec![], &[], STEPS, 1.0);
    let mut controller = Policy::new(&plant, policy.clone()).unwrap();
    let config = SeasonConfig {
        steps: STEPS,
        enforce_limits: true,
        uncertainty: None,
    };
    let result = run_season(
        &plant,
        &weather,
        &mut controller,
        &config,
        &mut |_: &StepLog| {},
    )
    .unwrap();
    assert!(
        (result.metrics.cumulative_reward - best).abs() < 1e-4,
        "season {} vs evaluation {best}",
        result.metrics.cumulative_reward
    );
    // The policy's action is differentiable in the observation (here in the position).
    let obs = [0.3f64, 0.0, 5.0];
    let (a, da) = first_derivative(
        |x| {
            let o = [x, DualNum::from_re(0.0), DualNum::from_re(5.0)];
            policy.action(&o).unwrap()[0]
        },
        obs[0],
    );
    let h = 1e-6f64;
    let plus = policy.action(&[obs[0] + h, 0.0, 5.0]).unwrap()[0];
    let minus = policy.action(&[obs[0] - h, 0.0, 5.0]).unwrap()[0];
    assert!((a - policy.action(&obs).unwrap()[0]).abs() < 1e-15);
    assert!((da - (plus - minus) / (2.0 * h)).abs() < 1e-5, "{da} vs FD");
}

#[test]
fn bad_settings_and_checkpoints_are_errors() {
    let bad = SacConfig {
        gamma: 1.5,
        ..SacConfig::default()
    };
    assert!(Trainer::new(reach_env(), bad).is_err());
    let dir = std::env::temp_dir().join(format!("ghm-sac-none-{}", std::process::id()));
    assert!(Trainer::resume(reach_env(), &dir).is_err());
}
