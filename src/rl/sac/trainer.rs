//! The training loop: episodes of an [`Env`], a random warm-up, one SAC gradient step per
//! environment step after it, periodic deterministic evaluation, and checkpoints from
//! which a training continues exactly.
//!
//! It follows Stable-Baselines3's `SAC.learn` with `VecNormalize` as the paper's code
//! configures it (`../shared/spec/reference-numbers.md` §3):
//!
//! * the first `warmup_episodes` episodes act uniformly at random in `[−1, 1]^nu`;
//! * every later environment step is followed by one gradient step on a batch drawn
//!   uniformly from the replay buffer;
//! * the learning rate decays linearly from its initial value to zero over the planned
//!   `episodes × steps` environment steps;
//! * the observation statistics are updated with every observation the training episodes
//!   see (reset observations included) and frozen for evaluation;
//! * the season's last step is terminal (`done`: no bootstrap beyond the season);
//! * an episode whose state stops being finite ends there (its last transition is
//!   dropped) and is counted in the learning curve.
//!
//! Reproducibility: one ChaCha8 generator, seeded from the configuration, draws the
//! initial weights, the warm-up actions, the exploration noise, the batches and the
//! reparameterisation noise. A stochastic environment is reseeded at each episode from
//! the seed and the episode number. A checkpoint stores the generator's position with the
//! agent, buffer and statistics, so a resumed training is bit-for-bit the uninterrupted one.

use crate::nn::Activation;
use crate::rl::buffer::{Batch, ReplayBuffer};
use crate::rl::policy::PolicyFile;
use crate::rl::sac::agent::{Sac, UpdateStats};
use crate::rl::sac::checkpoint::{self, Checkpoint};
use crate::rl::sac::types::{BestPolicy, EpisodeRecord, SacConfig, StepProgress};
use crate::rl::{Env, Normalizer, RlError};
use crate::sim::season::derived_seed;
use burn::tensor::Device;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::time::Instant;

/// A SAC training over an environment. See the [module documentation](self).
///
/// # Examples
///
/// A few ten-minute episodes on a tank with tiny networks (a real training uses the
/// defaults, a whole season and hours): a warm-up episode, then learning with an
/// evaluation after each episode; a training resumed from a checkpoint is bit-for-bit the
/// uninterrupted one; the result is a [`PolicyFile`] that drives the plant.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::Policy;
/// use ghm::model::Plant;
/// use ghm::rl::sac::{SacConfig, StepProgress, Trainer};
/// use ghm::rl::Env;
/// use ghm::sim::season::{run_season, SeasonConfig, StepLog};
/// use ghm::sim::weather::Weather;
/// use std::sync::Arc;
///
/// # let text = "\
/// # model tank
/// # sample 60 [s] integrator euler
/// # state level [m] = 1
/// # input inflow [m s^-1] in [0, 0.01] rate 0.002 start 0
/// # param k [s^-1] = 0.001
/// # der level = inflow - k * level
/// # output h [m] = level
/// # reward stored [EUR] = 2 * next(level)
/// # cost pumping [EUR] = 50 * inflow
/// # soft h in [0.5, 1.2] weight 10
/// # ";
/// let plant = Arc::new(Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?));
/// let steps = 10;
/// let weather = Weather::constant(vec![], &[], steps, plant.model.sample_period);
/// let env = Env::new(plant.clone(), weather.clone(), steps, None)?;
/// let config = SacConfig {
///     hidden: vec![8],
///     batch_size: 8,
///     buffer_size: 100,
///     warmup_episodes: 1,
///     episodes: 3,
///     eval_every: 1,
///     ..SacConfig::default()
/// };
/// let mut quiet = |_: &StepProgress| {};
///
/// let mut trainer = Trainer::new(env.clone(), config.clone())?;
/// while !trainer.is_finished() {
///     trainer.run_episode(&mut quiet)?;
/// }
/// let curve = trainer.curve();
/// assert_eq!(curve.len(), 3);
/// assert!(curve[0].warmup && !curve[1].warmup);
/// assert_eq!(curve[2].total_steps, 30);
/// assert!(curve.iter().all(|r| r.eval_reward.is_some()));
///
/// // Stop after two episodes, save, resume: the third episode is the same.
/// let dir = std::env::temp_dir().join(format!("ghm-doc-sac-{}", std::process::id()));
/// let mut first = Trainer::new(env.clone(), config)?;
/// first.run_episode(&mut quiet)?;
/// first.run_episode(&mut quiet)?;
/// first.save_checkpoint(&dir)?;
/// let mut resumed = Trainer::resume(env, &dir)?;
/// let third = resumed.run_episode(&mut quiet)?;
/// assert_eq!((third.reward, third.critic_loss), (curve[2].reward, curve[2].critic_loss));
/// std::fs::remove_dir_all(&dir)?;
///
/// // The policy to ship: the best evaluated one, as plain weights.
/// let file = trainer.policy(&plant.model.name)?;
/// assert_eq!(file.observation_names.len(), 3); // level, previous inflow, step
/// let mut policy = Policy::new(&plant, file)?;
/// let season = SeasonConfig { steps, enforce_limits: false, uncertainty: None };
/// let result = run_season(&plant, &weather, &mut policy, &season, &mut |_: &StepLog| {})?;
/// assert!(result.metrics.cumulative_reward.is_finite());
/// # Ok(())
/// # }
/// ```
pub struct Trainer {
    config: SacConfig,
    env: Env,
    eval_env: Env,
    agent: Sac,
    buffer: ReplayBuffer,
    normalizer: Normalizer,
    rng: ChaCha8Rng,
    total_steps: u64,
    curve: Vec<EpisodeRecord>,
    best: Option<BestPolicy>,
    device: Device,
    batch: Batch,
}

impl Trainer {
    /// A new training over `env` (deterministic or stochastic).
    pub fn new(env: Env, config: SacConfig) -> Result<Trainer, RlError> {
        config.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
        let (ow, aw) = (env.observation_len(), env.action_len());
        let agent = Sac::new(ow, aw, &config.hidden, &mut rng);
        Ok(Trainer {
            buffer: ReplayBuffer::new(ow, aw, config.buffer_size),
            normalizer: Normalizer::new(ow),
            eval_env: env.clone(),
            env,
            agent,
            rng,
            total_steps: 0,
            curve: Vec::new(),
            best: None,
            device: super::training_device(),
            batch: Batch::default(),
            config,
        })
    }

    /// Continues the training whose checkpoint is in `dir` (written by
    /// [`Trainer::save_checkpoint`]) over `env`, which must be the same environment.
    pub fn resume(env: Env, dir: &Path) -> Result<Trainer, RlError> {
        let Checkpoint {
            config,
            agent,
            buffer,
            normalizer,
            rng,
            total_steps,
            curve,
            best,
        } = checkpoint::read(dir)?;
        if agent.observation_width != env.observation_len()
            || agent.action_width != env.action_len()
        {
            return Err(RlError::Checkpoint {
                path: dir.display().to_string(),
                why: format!(
                    "the agent observes {} values and sets {} inputs; this model has {} and {}",
                    agent.observation_width,
                    agent.action_width,
                    env.observation_len(),
                    env.action_len()
                ),
            });
        }
        config.validate()?;
        Ok(Trainer {
            config,
            eval_env: env.clone(),
            env,
            agent,
            buffer,
            normalizer,
            rng,
            total_steps,
            curve,
            best,
            device: super::training_device(),
            batch: Batch::default(),
        })
    }

    /// Writes a checkpoint into `dir` (atomically: a crash leaves the previous one).
    pub fn save_checkpoint(&self, dir: &Path) -> Result<(), RlError> {
        let snapshot = checkpoint::Snapshot {
            config: &self.config,
            agent: &self.agent,
            buffer: &self.buffer,
            normalizer: &self.normalizer,
            rng: &self.rng,
            total_steps: self.total_steps,
            curve: &self.curve,
            best: self.best.as_ref(),
        };
        checkpoint::write(&snapshot, dir)
    }

    /// The training's settings.
    pub fn config(&self) -> &SacConfig {
        &self.config
    }

    /// The agent as it stands.
    pub fn agent(&self) -> &Sac {
        &self.agent
    }

    /// The learning curve: one record per completed episode.
    pub fn curve(&self) -> &[EpisodeRecord] {
        &self.curve
    }

    /// The best evaluated policy so far (`None` before an evaluation, or when every
    /// evaluated policy diverged).
    pub fn best(&self) -> Option<&BestPolicy> {
        self.best.as_ref()
    }

    /// The running observation statistics (not frozen).
    pub fn normalizer(&self) -> &Normalizer {
        &self.normalizer
    }

    /// Episodes completed.
    pub fn episodes_done(&self) -> usize {
        self.curve.len()
    }

    /// Whether `config.episodes` episodes are done.
    pub fn is_finished(&self) -> bool {
        self.curve.len() >= self.config.episodes
    }

    fn planned_steps(&self) -> u64 {
        (self.config.episodes * self.env.episode_len()) as u64
    }

    fn target_entropy(&self) -> f64 {
        self.config
            .target_entropy
            .unwrap_or(-(self.agent.action_width as f64))
    }

    /// Runs the next episode (and an evaluation when one is due) and returns its record.
    pub fn run_episode(
        &mut self,
        on_step: &mut dyn FnMut(&StepProgress),
    ) -> Result<EpisodeRecord, RlError> {
        let started = Instant::now();
        let episode = self.curve.len() + 1;
        let warmup = episode <= self.config.warmup_episodes;
        self.env.reseed(episode_seed(self.config.seed, episode));
        let mut observation = self.env.reset().to_vec();
        self.normalizer.update(&observation)?;
        let (mut reward, mut steps, mut diverged) = (0.0, 0, false);
        let mut sums = [0.0f64; 4];
        let mut updates = 0usize;
        let mut standard = vec![0.0; observation.len()];
        let mut standard_f32 = vec![0.0f32; observation.len()];
        loop {
            let action: Vec<f64> = if warmup {
                (0..self.agent.action_width)
                    .map(|_| self.rng.random_range(-1.0..=1.0))
                    .collect()
            } else {
                self.normalizer
                    .normalize_f32(&observation, &mut standard, &mut standard_f32)?;
                self.agent.act(&standard_f32, false, &mut self.rng)
            };
            let (next, step_reward, done) = match self.env.step(&action) {
                Ok(t) => (t.observation.to_vec(), t.reward, t.done),
                Err(RlError::Diverged { .. }) => {
                    diverged = true;
                    break;
                }
                Err(e) => return Err(e),
            };
            self.normalizer.update(&next)?;
            self.buffer
                .push(&observation, &action, step_reward, &next, done)?;
            self.total_steps += 1;
            reward += step_reward;
            steps += 1;
            if !warmup {
                let stats = self.gradient_step()?;
                for (s, v) in sums.iter_mut().zip([
                    stats.critic_loss,
                    stats.actor_loss,
                    stats.alpha,
                    stats.entropy,
                ]) {
                    *s += f64::from(v);
                }
                updates += 1;
            }
            observation = next;
            if steps % 64 == 0 || done {
                on_step(&StepProgress {
                    episode,
                    step: steps,
                    total_steps: self.total_steps,
                    reward,
                });
            }
            if done {
                break;
            }
        }
        let mean = |s: f64| if updates > 0 { s / updates as f64 } else { 0.0 };
        let eval_reward =
            if self.config.eval_every > 0 && episode.is_multiple_of(self.config.eval_every) {
                Some(self.evaluate()?)
            } else {
                None
            };
        let record = EpisodeRecord {
            episode,
            total_steps: self.total_steps,
            steps,
            reward,
            warmup,
            diverged,
            eval_reward,
            critic_loss: mean(sums[0]),
            actor_loss: mean(sums[1]),
            alpha: mean(sums[2]),
            entropy: mean(sums[3]),
            wall_s: started.elapsed().as_secs_f64(),
        };
        self.curve.push(record.clone());
        Ok(record)
    }

    fn gradient_step(&mut self) -> Result<UpdateStats, RlError> {
        let progress_remaining = 1.0 - self.total_steps as f64 / self.planned_steps() as f64;
        let lr = (self.config.learning_rate * progress_remaining.max(0.0)) as f32;
        self.buffer.sample(
            self.config.batch_size,
            &mut self.rng,
            &self.normalizer,
            &mut self.batch,
        )?;
        self.agent.update(
            &self.batch,
            lr,
            self.config.gamma as f32,
            self.config.tau as f32,
            self.target_entropy() as f32,
            &mut self.rng,
            &self.device,
        )
    }

    /// Mean cumulative reward of the deterministic policy with frozen statistics; keeps
    /// the best policy so far (a policy whose state diverged in an evaluation episode
    /// scores its reward up to there and is never kept).
    pub fn evaluate(&mut self) -> Result<f64, RlError> {
        let mut normalizer = self.normalizer.clone();
        normalizer.freeze();
        let (mut total, mut any_diverged) = (0.0, false);
        for e in 0..self.config.eval_episodes {
            self.eval_env
                .reseed(episode_seed(self.config.seed ^ 0x5eed, e + 1));
            let (reward, diverged) =
                run_deterministic(&mut self.eval_env, &self.agent, &normalizer)?;
            total += reward;
            any_diverged |= diverged;
        }
        let mean = total / self.config.eval_episodes as f64;
        if !any_diverged && self.best.as_ref().is_none_or(|b| mean > b.eval_reward) {
            self.best = Some(BestPolicy {
                eval_reward: mean,
                episode: self.curve.len() + 1,
                actor: self.agent.actor.clone(),
                normalizer,
            });
        }
        Ok(mean)
    }

    /// The policy to ship: the best evaluated one, or the current one if none was
    /// evaluated.
    pub fn policy(&self, model_name: &str) -> Result<PolicyFile, RlError> {
        let (actor, normalizer, eval_reward, episode) = match &self.best {
            Some(b) => (
                &b.actor,
                b.normalizer.clone(),
                Some(b.eval_reward),
                b.episode,
            ),
            None => {
                let mut n = self.normalizer.clone();
                n.freeze();
                (&self.agent.actor, n, None, self.curve.len())
            }
        };
        let mean_head = actor
            .to_mlp(Activation::Identity)
            .and_then(|m| m.with_output_rows(0..self.agent.action_width))
            .map_err(|e| RlError::Backend(e.to_string()))?
            .with_output_activation(Activation::Tanh);
        Ok(PolicyFile {
            model: model_name.to_string(),
            observation: self.env.observation_layout(),
            observation_names: self.env.observation_names(),
            action_names: self.env.action_names(),
            normalizer,
            actor: mean_head,
            episode,
            eval_reward,
        })
    }
}

/// Cumulative reward of one deterministic episode, and whether its state diverged (the
/// reward then runs up to the divergence).
fn run_deterministic(
    env: &mut Env,
    agent: &Sac,
    normalizer: &Normalizer,
) -> Result<(f64, bool), RlError> {
    let mut observation = env.reset().to_vec();
    let mut standard = vec![0.0; observation.len()];
    let mut input = vec![0.0f32; observation.len()];
    let mut total = 0.0;
    loop {
        normalizer.normalize_f32(&observation, &mut standard, &mut input)?;
        let action = agent.act_deterministic(&input);
        match env.step(&action) {
            Ok(t) => {
                total += t.reward;
                if t.done {
                    return Ok((total, false));
                }
                observation.copy_from_slice(t.observation);
            }
            Err(RlError::Diverged { .. }) => return Ok((total, true)),
            Err(e) => return Err(e),
        }
    }
}

/// The environment seed of an episode: derived from the training seed and the episode number.
fn episode_seed(seed: u64, episode: usize) -> u64 {
    derived_seed(seed, episode as u64)
}
