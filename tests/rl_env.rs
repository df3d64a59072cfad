//! The reinforcement-learning environment: rewards equal the season loop's, the action map
//! is exact, the observation layout, uncertainty draws, and the normaliser against the
//! nominal agent's saved statistics.

use ghm::control::InputTable;
use ghm::lang::model::Redraw;
use ghm::model::Plant;
use ghm::rl::{AgentError, Env, Normalizer, RlError};
use ghm::sim::season::{run_season, SeasonConfig, StepLog, UncertaintyDraw};
use ghm::sim::weather::{builtin_season, Weather};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::sync::Arc;

const STEPS: usize = 1920;

fn plant(file: &str) -> Arc<Plant> {
    let model = ghm::lang::load(Path::new(file)).unwrap_or_else(|e| panic!("{}", e.render()));
    Arc::new(Plant::new(model))
}

fn plant_from(text: &str) -> Arc<Plant> {
    let model = ghm::lang::load_str("test.ghm", text).unwrap_or_else(|e| panic!("{}", e.render()));
    Arc::new(Plant::new(model))
}

fn weather(plant: &Plant, steps: usize) -> Weather {
    builtin_season(steps, 1800.0, 7)
        .select(&plant.model.weather_columns(), 0, steps)
        .expect("built-in season has every column")
}

/// A fixed action sequence: mostly uniform in [−1.3, 1.3] (so some entries need clipping),
/// with runs of zeros and of ±1.
fn actions(nu: usize, steps: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..steps)
        .map(|k| match k % 50 {
            0..=4 => vec![0.0; nu],
            5..=7 => vec![1.0; nu],
            8..=9 => vec![-1.0; nu],
            _ => (0..nu).map(|_| rng.random_range(-1.3..1.3)).collect(),
        })
        .collect()
}

/// One episode: (observations before each step, rewards, inputs, final observation).
type Episode = (Vec<Vec<f64>>, Vec<f64>, Vec<Vec<f64>>, Vec<f64>);

fn episode(env: &mut Env, actions: &[Vec<f64>]) -> Episode {
    let mut obs = vec![env.reset().to_vec()];
    let (mut rewards, mut inputs) = (Vec::new(), Vec::new());
    for (k, a) in actions.iter().enumerate() {
        let t = env.step(a).expect("step");
        assert_eq!(t.done, k + 1 == actions.len());
        rewards.push(t.reward);
        inputs.push(t.input.to_vec());
        obs.push(t.observation.to_vec());
    }
    let last = obs.pop().expect("final observation");
    (obs, rewards, inputs, last)
}

fn season_logs(
    plant: &Plant,
    w: &Weather,
    inputs: &[Vec<f64>],
    u: Option<UncertaintyDraw>,
) -> Vec<StepLog> {
    let config = SeasonConfig {
        steps: inputs.len(),
        enforce_limits: true,
        uncertainty: u,
    };
    let mut logs = Vec::new();
    run_season(
        plant,
        w,
        &mut InputTable(inputs.to_vec()),
        &config,
        &mut |l: &StepLog| logs.push(l.clone()),
    )
    .expect("season runs");
    logs
}

/// The env's rewards, inputs and output observations equal `run_season`'s logs for the
/// same inputs, step by step.
fn assert_matches_season(file: &str, uncertainty: Option<UncertaintyDraw>) {
    let p = plant(file);
    let w = weather(&p, STEPS);
    let mut env = Env::new(p.clone(), w.clone(), STEPS, uncertainty).expect("env");
    let acts = actions(p.layout.nu, STEPS, 5);
    let (obs, rewards, inputs, _) = episode(&mut env, &acts);
    let logs = season_logs(&p, &w, &inputs, uncertainty);
    assert_eq!(logs.len(), STEPS);
    let ny = p.model.outputs.len();
    let mut total = 0.0;
    for (k, log) in logs.iter().enumerate() {
        assert_eq!(log.input, inputs[k], "{file}: input at step {k}");
        assert!(
            (log.reward - rewards[k]).abs() <= 1e-12,
            "{file}: reward at step {k}: season {} env {}",
            log.reward,
            rewards[k]
        );
        assert_eq!(
            &obs[k][..ny],
            &log.outputs[..],
            "{file}: outputs at step {k}"
        );
        total += rewards[k];
    }
    // Not a trivial season: the rewards vary and the penalties bite somewhere.
    assert!(logs.iter().any(|l| l.penalties.iter().sum::<f64>() > 0.0));
    assert!((total - logs[STEPS - 1].cumulative_reward).abs() <= 1e-9);
}

#[test]
fn rewards_equal_the_season_loop_on_the_deterministic_plant() {
    assert_matches_season("models/lettuce.ghm", None);
    assert_matches_season("models/lettuce-thesis.ghm", None);
}

#[test]
fn first_stochastic_episode_equals_the_season_loop_with_the_same_draw() {
    let u = Some(UncertaintyDraw {
        delta: 0.2,
        seed: 42,
    });
    // Redraw once per season, and every step.
    assert_matches_season("models/lettuce.ghm", u);
    assert_matches_season("models/lettuce-thesis.ghm", u);
}

#[test]
fn action_map_holds_bounds_and_rate_limits_by_construction() {
    let p = plant("models/lettuce.ghm");
    let mut env = Env::new(p.clone(), weather(&p, STEPS), STEPS, None).expect("env");
    let delta = env.action_scale().to_vec();
    assert_eq!(delta, vec![0.12, 0.75, 15.0]);
    let (lo, hi) = ([0.0, 0.0, 0.0], [1.2, 7.5, 150.0]);
    env.reset();
    assert_eq!(env.previous_input(), &[0.0, 0.0, 50.0]);
    // a = 0 holds the input; a = ±1 moves by exactly δu unless a bound stops it.
    let t = env.step(&[0.0, 0.0, 0.0]).unwrap();
    assert_eq!(t.input, &[0.0, 0.0, 50.0]);
    let t = env.step(&[1.0, 1.0, 1.0]).unwrap();
    assert_eq!(t.input, &[0.12, 0.75, 65.0]);
    let t = env.step(&[-1.0, 1.0, -1.0]).unwrap();
    assert_eq!(t.input, &[0.12 - 0.12, 0.75 + 0.75, 50.0]);
    // u1 is at its lower bound: −1 stays there; beyond ±1 acts as ±1.
    let t = env.step(&[-1.0, 7.0, -3.0]).unwrap();
    assert_eq!(t.input, &[0.0, 1.5 + 0.75, 35.0]);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut moved = [false; 2];
    for k in 4..STEPS {
        let prev = env.previous_input().to_vec();
        let a: Vec<f64> = match k % 3 {
            0 => (0..3).map(|_| rng.random_range(-2.0..2.0)).collect(),
            1 => vec![1.0; 3],
            _ => vec![-1.0; 3],
        };
        let t = env.step(&a).unwrap();
        for i in 0..3 {
            let u = t.input[i];
            assert!(u >= lo[i] && u <= hi[i], "bound of input {i} at step {k}");
            assert!(
                u <= prev[i] + delta[i] && u >= prev[i] - delta[i],
                "rate of input {i} at step {k}"
            );
            let ac = a[i].clamp(-1.0, 1.0);
            let free = prev[i] + ac * delta[i];
            if free >= lo[i] && free <= hi[i] {
                assert_eq!(u, free, "unclipped move of input {i} at step {k}");
                if ac.abs() == 1.0 {
                    moved[usize::from(ac > 0.0)] = true;
                }
            } else {
                assert_eq!(u, if free < lo[i] { lo[i] } else { hi[i] });
            }
        }
    }
    assert!(moved[0] && moved[1], "both full moves were exercised");
}

#[test]
fn inputs_without_a_rate_limit_move_over_their_range() {
    let text = "
model tank
state level = 1
input valve in [0, 4] start 1
input pump in [-2, 2] rate 0.5 start 0
param k = 0.01
der level = -k * valve * level + pump * 0.001
output y = level
reward keep = level
soft y in [0.5, 2] weight 1
sample 60 [s] integrator euler substeps 1
";
    let p = plant_from(text);
    let w = Weather::constant(vec![], &[], 10, 60.0);
    let mut env = Env::new(p, w, 10, None).expect("env");
    assert_eq!(env.action_scale(), &[4.0, 0.5]);
    assert_eq!(env.observation_len(), 1 + 2 + 1);
    assert_eq!(
        env.observation_names(),
        vec!["y", "prev_valve", "prev_pump", "step"]
    );
    env.reset();
    let t = env.step(&[0.5, 1.0]).unwrap();
    assert_eq!(t.input, &[3.0, 0.5]);
    let t = env.step(&[1.0, -1.0]).unwrap();
    assert_eq!(t.input, &[4.0, 0.0]);
    let t = env.step(&[-1.0, -1.0]).unwrap();
    assert_eq!(t.input, &[0.0, -0.5]);
    // No disturbances: the observation ends with the step index.
    assert_eq!(t.observation[1..], [0.0, -0.5, 3.0]);

    let unbounded = text.replace("input valve in [0, 4] start 1", "input valve start 1");
    let p = plant_from(&unbounded);
    let w = Weather::constant(vec![], &[], 10, 60.0);
    assert!(matches!(
        Env::new(p, w, 10, None),
        Err(RlError::Agent(AgentError::UnboundedInput { ref input, .. })) if input == "valve"
    ));
}

#[test]
fn observation_layout_at_step_zero() {
    let p = plant("models/lettuce.ghm");
    let w = weather(&p, STEPS);
    let mut env = Env::new(p.clone(), w.clone(), STEPS, None).expect("env");
    let s0 = env.reset().to_vec();
    assert_eq!(env.observation_len(), 12);
    assert_eq!(s0.len(), 12);
    let x0 = p.model.initial_state();
    let u_start = p.model.start_input();
    let y0 = p.outputs(&x0, &u_start, w.at(0), &p.model.nominal_params());
    assert_eq!(&s0[..4], &y0[..]);
    assert_eq!(&s0[4..7], &[0.0, 0.0, 50.0]);
    assert_eq!(s0[7], 0.0);
    assert_eq!(&s0[8..], w.at(0));
    // Spec §7: y(0) = (0.0035, 537.26 ppm, 15 °C, 62.64 %).
    for (got, want) in s0[..4].iter().zip([0.0035, 537.26, 15.0, 62.644]) {
        assert!((got - want).abs() <= 1e-4 * want, "y(0): {got} vs {want}");
    }
    let names = env.observation_names();
    assert_eq!(names.len(), 12);
    assert_eq!(names[4], "prev_co2_supply");
    assert_eq!(names[7], "step");
    assert_eq!(names[8], "radiation");
    // After one step: k = 1, d(1), u(0).
    let t = env.step(&[1.0, 0.0, -1.0]).unwrap();
    assert_eq!(t.observation[7], 1.0);
    assert_eq!(&t.observation[4..7], &[0.12, 0.0, 35.0]);
    assert_eq!(&t.observation[8..], w.at(1));
    assert_eq!(env.step_index(), 1);
}

#[test]
fn episode_ends_after_its_steps_and_reads_the_last_weather_row() {
    let p = plant("models/lettuce.ghm");
    let w = weather(&p, 5);
    let mut env = Env::new(p.clone(), w.clone(), 5, None).expect("env");
    assert_eq!(env.step(&[0.0; 3]).unwrap_err(), RlError::NotReset);
    env.reset();
    for k in 0..5 {
        let t = env.step(&[0.1, 0.1, 0.1]).unwrap();
        assert_eq!(t.done, k == 4);
        if t.done {
            assert_eq!(t.observation[7], 5.0);
            assert_eq!(&t.observation[8..], w.at(4));
        }
    }
    assert!(env.is_done());
    assert_eq!(
        env.step(&[0.0; 3]).unwrap_err(),
        RlError::EpisodeOver { steps: 5 }
    );
    // A longer weather is read at k = 5 itself.
    let long = weather(&p, 6);
    let mut env = Env::new(p.clone(), long.clone(), 5, None).expect("env");
    env.reset();
    for _ in 0..5 {
        env.step(&[0.0; 3]).unwrap();
    }
    assert_eq!(&env.observation()[8..], long.at(5));
    // A second episode starts afresh and repeats the first.
    let a = actions(3, 5, 1);
    let first = episode(&mut env, &a);
    let second = episode(&mut env, &a);
    assert_eq!(first, second);
}

#[test]
fn bad_sizes_and_settings_are_errors() {
    let p = plant("models/lettuce.ghm");
    let w = weather(&p, 10);
    assert_eq!(
        Env::new(p.clone(), w.clone(), 11, None).unwrap_err(),
        RlError::WeatherTooShort {
            available: 10,
            needed: 11
        }
    );
    assert_eq!(
        Env::new(p.clone(), w.clone(), 0, None).unwrap_err(),
        RlError::EmptyEpisode
    );
    let narrow = Weather::constant(vec!["a".into()], &[1.0], 10, 1800.0);
    assert!(matches!(
        Env::new(p.clone(), narrow, 10, None),
        Err(RlError::WeatherWidth {
            given: 1,
            expected: 4
        })
    ));
    for delta in [f64::NAN, -0.1, f64::INFINITY] {
        let u = Some(UncertaintyDraw { delta, seed: 1 });
        assert!(matches!(
            Env::new(p.clone(), w.clone(), 10, u),
            Err(RlError::BadUncertainty { .. })
        ));
    }
    let mut env = Env::new(p, w, 10, None).expect("env");
    env.reset();
    assert_eq!(
        env.step(&[0.0; 2]).unwrap_err(),
        RlError::ActionWidth {
            given: 2,
            expected: 3
        }
    );
    assert!(matches!(
        env.step(&[0.0, f64::NAN, 0.0]),
        Err(RlError::NonFiniteAction { index: 1, .. })
    ));
    // The failed calls changed nothing.
    assert_eq!(env.step_index(), 0);
    assert!(env.step(&[0.0; 3]).is_ok());
}

fn rewards_of_episodes(env: &mut Env, episodes: usize) -> Vec<Vec<f64>> {
    let a = actions(env.action_len(), env.episode_len(), 9);
    (0..episodes).map(|_| episode(env, &a).1).collect()
}

#[test]
fn stochastic_env_is_reproducible_by_seed() {
    let p = plant("models/lettuce.ghm");
    let w = weather(&p, 200);
    let draw = |seed| Some(UncertaintyDraw { delta: 0.1, seed });
    let mut a = Env::new(p.clone(), w.clone(), 200, draw(1)).expect("env");
    let mut b = Env::new(p.clone(), w.clone(), 200, draw(1)).expect("env");
    let mut c = Env::new(p.clone(), w.clone(), 200, draw(2)).expect("env");
    let ra = rewards_of_episodes(&mut a, 3);
    assert_eq!(ra, rewards_of_episodes(&mut b, 3));
    let rc = rewards_of_episodes(&mut c, 3);
    for e in 0..3 {
        assert_ne!(ra[e], rc[e], "episode {e}");
    }
    // Every episode draws afresh; reseeding replays the sequence.
    assert_ne!(ra[0], ra[1]);
    a.reseed(1);
    assert_eq!(ra, rewards_of_episodes(&mut a, 3));
    // Deterministic plant: nominal parameters, identical episodes.
    let mut d = Env::new(p.clone(), w, 200, None).expect("env");
    let rd = rewards_of_episodes(&mut d, 2);
    assert_eq!(rd[0], rd[1]);
    assert_eq!(d.params(), &p.model.nominal_params()[..]);
    assert_ne!(rd[0], ra[0]);
}

#[test]
fn parameters_follow_the_models_redraw_rule() {
    let draw = Some(UncertaintyDraw {
        delta: 0.1,
        seed: 4,
    });
    // lettuce-thesis.ghm: every parameter redrawn every step.
    let p = plant("models/lettuce-thesis.ghm");
    assert_eq!(p.model.uncertainty.redraw, Redraw::Step);
    let mut env = Env::new(p.clone(), weather(&p, 50), 50, draw).expect("env");
    env.reset();
    let nominal = p.model.nominal_params();
    let mut prev = env.params().to_vec();
    for k in 0..49 {
        env.step(&[0.2, -0.1, 0.3]).unwrap();
        let now = env.params();
        for i in 0..now.len() {
            assert_ne!(now[i], prev[i], "parameter {i} unchanged at step {k}");
            let rel = (now[i] / nominal[i] - 1.0).abs();
            assert!(rel <= 0.5 * 0.1 + 1e-12, "parameter {i} outside ±δ/2");
        }
        prev = now.to_vec();
    }
    // lettuce.ghm: marked parameters drawn once per episode, the others nominal.
    let p = plant("models/lettuce.ghm");
    assert_eq!(p.model.uncertainty.redraw, Redraw::Season);
    let mut env = Env::new(p.clone(), weather(&p, 50), 50, draw).expect("env");
    env.reset();
    let first = env.params().to_vec();
    assert_ne!(first, p.model.nominal_params());
    for _ in 0..50 {
        env.step(&[0.2, -0.1, 0.3]).unwrap();
        assert_eq!(env.params(), &first[..]);
    }
    env.reset();
    assert_ne!(env.params(), &first[..]);
}

/// The nominal agent's saved `VecNormalize` statistics (reference-numbers.md §3) applied to
/// the reset observation give the normalised vector printed by the paper's code.
#[test]
fn normaliser_reproduces_the_nominal_agents_reset_observation() {
    let mean = vec![
        0.1190266,
        1033.158,
        12.42613,
        80.56909,
        0.3878139,
        1.037027,
        18.91059,
        959.3345,
        82.83675,
        8.846782e-4,
        7.700862,
        6.180940e-3,
    ];
    let var = vec![
        8.685085e-3,
        1.611238e5,
        15.65606,
        76.25552,
        0.1909001,
        4.081321,
        656.4095,
        3.073057e5,
        2.020294e4,
        3.388785e-9,
        7.233914,
        6.042068e-7,
    ];
    let mut n = Normalizer::from_stats(mean, var, 307_253.0).expect("stats");
    n.freeze();
    let s0 = [
        0.0035, 537.26, 15.0, 62.644, 0.0, 0.0, 50.0, 0.0, 0.0, 8.6333e-4, 5.6, 5.4981e-3,
    ];
    let want = [
        -1.23964, -1.23541, 0.650497, -2.05271, -0.887606, -0.513322, 1.21346, -1.73055, -0.582795,
        -0.184527, -0.781107, -0.87123,
    ];
    let mut out = [0.0; 12];
    n.normalize(&s0, &mut out).unwrap();
    for i in 0..12 {
        assert!(
            (out[i] - want[i]).abs() <= 2e-4,
            "entry {i}: {} vs {}",
            out[i],
            want[i]
        );
    }
    // And the env's own reset observation agrees with the spec's in its first 8 entries.
    let p = plant("models/lettuce-thesis.ghm");
    let mut env = Env::new(p.clone(), weather(&p, 10), 10, None).expect("env");
    let s = env.reset();
    for i in 0..8 {
        assert!(
            (s[i] - s0[i]).abs() <= 1e-4 * s0[i].abs().max(1.0),
            "entry {i}"
        );
    }
}
