//! Training checkpoints: everything a [`Trainer`](super::Trainer) needs to continue exactly where it
//! stopped, in a folder `DIR/checkpoint/`:
//!
//! * `state.json`: the configuration, the agent (networks and Adam moments, `f32` values
//!   written in their shortest exact decimal form), the observation statistics, the
//!   generator's seed, stream and position, the learning curve and the best policy;
//! * `buffer.bin`: the replay buffer ([`ReplayBuffer::save`]).
//!
//! A checkpoint is written to `checkpoint.partial/` and then swapped in by renames, so an
//! interruption while writing leaves the previous checkpoint (as `checkpoint/` or, between
//! the two renames, `checkpoint.previous/`, which [`read`] falls back to).

use crate::rl::buffer::ReplayBuffer;
use crate::rl::sac::agent::Sac;
use crate::rl::sac::types::{BestPolicy, EpisodeRecord, SacConfig};
use crate::rl::{Normalizer, RlError};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The contents of a checkpoint.
pub struct Checkpoint {
    /// The training's settings.
    pub config: SacConfig,
    /// The agent: networks and optimiser states.
    pub agent: Sac,
    /// The replay buffer, every stored transition.
    pub buffer: ReplayBuffer,
    /// The observation statistics, as they stood.
    pub normalizer: Normalizer,
    /// The trainer's generator, at its exact position.
    pub rng: ChaCha8Rng,
    /// Environment steps taken so far.
    pub total_steps: u64,
    /// The learning curve so far, one record per completed episode.
    pub curve: Vec<EpisodeRecord>,
    /// The best evaluated policy so far, if any.
    pub best: Option<BestPolicy>,
}

#[derive(Serialize, Deserialize)]
struct State {
    format: u32,
    config: SacConfig,
    agent: Sac,
    normalizer: Normalizer,
    rng_seed: [u8; 32],
    rng_stream: u64,
    /// `u128` as a decimal string (JSON numbers stop at 64 bits).
    rng_word_pos: String,
    total_steps: u64,
    curve: Vec<EpisodeRecord>,
    best: Option<BestPolicy>,
}

const FORMAT: u32 = 1;

fn fail(path: &Path, why: impl std::fmt::Display) -> RlError {
    RlError::Checkpoint {
        path: path.display().to_string(),
        why: why.to_string(),
    }
}

/// What [`write()`] stores, borrowed from a running training
/// ([`Trainer::save_checkpoint`](super::Trainer::save_checkpoint) lends its own).
pub struct Snapshot<'a> {
    /// The training's settings.
    pub config: &'a SacConfig,
    /// The agent: networks and optimiser states.
    pub agent: &'a Sac,
    /// The replay buffer.
    pub buffer: &'a ReplayBuffer,
    /// The observation statistics.
    pub normalizer: &'a Normalizer,
    /// The trainer's generator, at its exact position.
    pub rng: &'a ChaCha8Rng,
    /// Environment steps taken so far.
    pub total_steps: u64,
    /// The learning curve so far.
    pub curve: &'a [EpisodeRecord],
    /// The best evaluated policy so far, if any.
    pub best: Option<&'a BestPolicy>,
}

/// Writes a training's checkpoint into `dir/checkpoint/`.
pub fn write(snapshot: &Snapshot<'_>, dir: &Path) -> Result<(), RlError> {
    let partial = dir.join("checkpoint.partial");
    let current = dir.join("checkpoint");
    let previous = dir.join("checkpoint.previous");
    if partial.exists() {
        std::fs::remove_dir_all(&partial).map_err(|e| fail(&partial, e))?;
    }
    std::fs::create_dir_all(&partial).map_err(|e| fail(&partial, e))?;
    let state = State {
        format: FORMAT,
        config: snapshot.config.clone(),
        agent: snapshot.agent.clone(),
        normalizer: snapshot.normalizer.clone(),
        rng_seed: snapshot.rng.get_seed(),
        rng_stream: snapshot.rng.get_stream(),
        rng_word_pos: snapshot.rng.get_word_pos().to_string(),
        total_steps: snapshot.total_steps,
        curve: snapshot.curve.to_vec(),
        best: snapshot.best.cloned(),
    };
    let state_path = partial.join("state.json");
    let text = serde_json::to_string(&state).map_err(|e| fail(&state_path, e))?;
    std::fs::write(&state_path, text).map_err(|e| fail(&state_path, e))?;
    let buffer_path = partial.join("buffer.bin");
    snapshot
        .buffer
        .save(&buffer_path)
        .map_err(|e| fail(&buffer_path, e))?;
    if previous.exists() {
        std::fs::remove_dir_all(&previous).map_err(|e| fail(&previous, e))?;
    }
    if current.exists() {
        std::fs::rename(&current, &previous).map_err(|e| fail(&current, e))?;
    }
    std::fs::rename(&partial, &current).map_err(|e| fail(&partial, e))?;
    if previous.exists() {
        std::fs::remove_dir_all(&previous).map_err(|e| fail(&previous, e))?;
    }
    Ok(())
}

/// Whether `dir` holds a checkpoint.
pub fn exists(dir: &Path) -> bool {
    checkpoint_folder(dir).is_some()
}

fn checkpoint_folder(dir: &Path) -> Option<PathBuf> {
    ["checkpoint", "checkpoint.previous"]
        .iter()
        .map(|name| dir.join(name))
        .find(|p| p.join("state.json").is_file() && p.join("buffer.bin").is_file())
}

/// Reads the checkpoint in `dir`.
pub fn read(dir: &Path) -> Result<Checkpoint, RlError> {
    let folder = checkpoint_folder(dir)
        .ok_or_else(|| fail(dir, "no checkpoint here (expected checkpoint/state.json)"))?;
    let state_path = folder.join("state.json");
    let text = std::fs::read_to_string(&state_path).map_err(|e| fail(&state_path, e))?;
    let state: State = serde_json::from_str(&text).map_err(|e| fail(&state_path, e))?;
    if state.format != FORMAT {
        return Err(fail(
            &state_path,
            format!("format {} (this ghm reads {FORMAT})", state.format),
        ));
    }
    let buffer_path = folder.join("buffer.bin");
    let buffer = ReplayBuffer::load(&buffer_path).map_err(|e| fail(&buffer_path, e))?;
    let word_pos: u128 = state
        .rng_word_pos
        .parse()
        .map_err(|e| fail(&state_path, format!("generator position: {e}")))?;
    let mut rng = ChaCha8Rng::from_seed(state.rng_seed);
    rng.set_stream(state.rng_stream);
    rng.set_word_pos(word_pos);
    Ok(Checkpoint {
        config: state.config,
        agent: state.agent,
        buffer,
        normalizer: state.normalizer,
        rng,
        total_steps: state.total_steps,
        curve: state.curve,
        best: state.best,
    })
}
