//! The replay buffer of off-policy learning: a ring of transitions
//! `(s, a, r, s', done)` with uniform sampling.
//!
//! Observations are stored raw (model units, `f32`) and standardised when a batch is drawn,
//! with the normaliser's statistics of that moment, as Stable-Baselines3 does with
//! `VecNormalize`. The buffer writes itself to a compact little-endian binary file so that
//! a training checkpoint holds it exactly.

use crate::rl::{AgentError, Normalizer, RlError};
use rand::Rng;
use std::io::{Read, Write};
use std::path::Path;

const MAGIC: &[u8; 8] = b"GHMRB001";

/// A ring buffer of transitions. See the [module documentation](self).
///
/// ```
/// use ghm::rl::buffer::{Batch, ReplayBuffer};
/// use ghm::rl::Normalizer;
/// use rand::SeedableRng;
///
/// let mut buffer = ReplayBuffer::new(2, 1, 1000);
/// buffer.push(&[1.0, 2.0], &[0.5], 0.1, &[1.5, 2.0], false).unwrap();
/// let mut batch = Batch::default();
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
/// buffer.sample(4, &mut rng, &Normalizer::new(2), &mut batch).unwrap();
/// assert_eq!(batch.observations.len(), 4 * 2);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayBuffer {
    observation_width: usize,
    action_width: usize,
    capacity: usize,
    len: usize,
    next: usize,
    observations: Vec<f32>,
    actions: Vec<f32>,
    rewards: Vec<f32>,
    next_observations: Vec<f32>,
    dones: Vec<f32>,
}

/// A drawn batch, row-major, observations already standardised.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Batch {
    /// Transitions drawn (rows).
    pub size: usize,
    /// Standardised observations, one row per transition.
    pub observations: Vec<f32>,
    /// Actions as stored (in `[−1, 1]` when the agent chose them), one row per transition.
    pub actions: Vec<f32>,
    /// One reward per transition.
    pub rewards: Vec<f32>,
    /// Standardised observations after the transition, one row per transition.
    pub next_observations: Vec<f32>,
    /// 1 where the transition was pushed with `done`, else 0.
    pub dones: Vec<f32>,
}

impl ReplayBuffer {
    /// An empty buffer for `capacity` transitions.
    pub fn new(observation_width: usize, action_width: usize, capacity: usize) -> ReplayBuffer {
        let capacity = capacity.max(1);
        ReplayBuffer {
            observation_width,
            action_width,
            capacity,
            len: 0,
            next: 0,
            observations: vec![0.0; capacity * observation_width],
            actions: vec![0.0; capacity * action_width],
            rewards: vec![0.0; capacity],
            next_observations: vec![0.0; capacity * observation_width],
            dones: vec![0.0; capacity],
        }
    }

    /// Transitions held, at most the capacity.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it holds no transition yet.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Transitions it holds before overwriting the oldest (at least 1).
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Stores a transition, overwriting the oldest once full.
    pub fn push(
        &mut self,
        observation: &[f64],
        action: &[f64],
        reward: f64,
        next_observation: &[f64],
        done: bool,
    ) -> Result<(), RlError> {
        let (ow, aw) = (self.observation_width, self.action_width);
        for width in [observation.len(), next_observation.len()] {
            if width != ow {
                return Err(AgentError::ObservationWidth {
                    given: width,
                    expected: ow,
                }
                .into());
            }
        }
        if action.len() != aw {
            return Err(RlError::ActionWidth {
                given: action.len(),
                expected: aw,
            });
        }
        let i = self.next;
        copy_into(&mut self.observations[i * ow..(i + 1) * ow], observation);
        copy_into(&mut self.actions[i * aw..(i + 1) * aw], action);
        copy_into(
            &mut self.next_observations[i * ow..(i + 1) * ow],
            next_observation,
        );
        self.rewards[i] = reward as f32;
        self.dones[i] = if done { 1.0 } else { 0.0 };
        self.next = (i + 1) % self.capacity;
        self.len = (self.len + 1).min(self.capacity);
        Ok(())
    }

    /// Draws `size` transitions uniformly (with replacement) into `batch`, standardising
    /// the observations with `normalizer`.
    pub fn sample<R: Rng>(
        &self,
        size: usize,
        rng: &mut R,
        normalizer: &Normalizer,
        batch: &mut Batch,
    ) -> Result<(), RlError> {
        if self.len == 0 {
            return Err(RlError::EmptyBuffer);
        }
        let (ow, aw) = (self.observation_width, self.action_width);
        batch.size = size;
        for v in [
            &mut batch.observations,
            &mut batch.actions,
            &mut batch.rewards,
            &mut batch.next_observations,
            &mut batch.dones,
        ] {
            v.clear();
        }
        let mut raw = vec![0.0; ow];
        let mut standard = vec![0.0; ow];
        for _ in 0..size {
            let i = rng.random_range(0..self.len);
            for (source, target) in [
                (&self.observations, &mut batch.observations),
                (&self.next_observations, &mut batch.next_observations),
            ] {
                for (r, s) in raw.iter_mut().zip(&source[i * ow..(i + 1) * ow]) {
                    *r = f64::from(*s);
                }
                normalizer.normalize(&raw, &mut standard)?;
                target.extend(standard.iter().map(|v| *v as f32));
            }
            batch
                .actions
                .extend_from_slice(&self.actions[i * aw..(i + 1) * aw]);
            batch.rewards.push(self.rewards[i]);
            batch.dones.push(self.dones[i]);
        }
        Ok(())
    }

    /// Writes the buffer to `path`.
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
        out.write_all(MAGIC)?;
        for n in [
            self.observation_width,
            self.action_width,
            self.capacity,
            self.len,
            self.next,
        ] {
            out.write_all(&(n as u64).to_le_bytes())?;
        }
        for values in [
            &self.observations,
            &self.actions,
            &self.rewards,
            &self.next_observations,
            &self.dones,
        ] {
            for v in values.iter() {
                out.write_all(&v.to_le_bytes())?;
            }
        }
        out.flush()
    }

    /// Reads a buffer written by [`ReplayBuffer::save`].
    pub fn load(path: &Path) -> std::io::Result<ReplayBuffer> {
        let invalid =
            |why: &str| std::io::Error::new(std::io::ErrorKind::InvalidData, why.to_string());
        let mut input = std::io::BufReader::new(std::fs::File::open(path)?);
        let mut magic = [0u8; 8];
        input.read_exact(&mut magic)?;
        if &magic != MAGIC {
            return Err(invalid("not a ghm replay buffer"));
        }
        let mut header = [0usize; 5];
        for h in &mut header {
            let mut b = [0u8; 8];
            input.read_exact(&mut b)?;
            *h = usize::try_from(u64::from_le_bytes(b)).map_err(|_| invalid("size overflows"))?;
        }
        let [ow, aw, capacity, len, next] = header;
        if capacity == 0 || len > capacity || next >= capacity || ow > 1 << 16 || aw > 1 << 16 {
            return Err(invalid("inconsistent replay buffer header"));
        }
        let mut buffer = ReplayBuffer::new(ow, aw, capacity);
        buffer.len = len;
        buffer.next = next;
        for values in [
            &mut buffer.observations,
            &mut buffer.actions,
            &mut buffer.rewards,
            &mut buffer.next_observations,
            &mut buffer.dones,
        ] {
            let mut bytes = vec![0u8; values.len() * 4];
            input.read_exact(&mut bytes)?;
            for (v, b) in values.iter_mut().zip(bytes.chunks_exact(4)) {
                *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
        Ok(buffer)
    }
}

fn copy_into(target: &mut [f32], source: &[f64]) {
    for (t, s) in target.iter_mut().zip(source) {
        *t = *s as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn ring_overwrites_oldest_and_round_trips() {
        let mut b = ReplayBuffer::new(2, 1, 3);
        for i in 0..5 {
            let x = i as f64;
            b.push(&[x, -x], &[0.5], x, &[x + 1.0, 0.0], i == 4)
                .unwrap();
        }
        assert_eq!(b.len(), 3);
        // Slots hold transitions 3, 4, 2.
        assert_eq!(b.rewards, vec![3.0, 4.0, 2.0]);
        assert_eq!(b.dones, vec![0.0, 1.0, 0.0]);
        let dir = std::env::temp_dir().join(format!("ghm-rb-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("buffer.bin");
        b.save(&path).unwrap();
        assert_eq!(ReplayBuffer::load(&path).unwrap(), b);
        std::fs::write(&path, b"nonsense").unwrap();
        assert!(ReplayBuffer::load(&path).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn samples_are_standardised_with_the_given_statistics() {
        let mut b = ReplayBuffer::new(1, 1, 10);
        b.push(&[3.0], &[0.1], 1.0, &[5.0], false).unwrap();
        let norm = Normalizer::from_stats(vec![1.0], vec![4.0], 10.0).unwrap();
        let mut batch = Batch::default();
        b.sample(4, &mut ChaCha8Rng::seed_from_u64(1), &norm, &mut batch)
            .unwrap();
        assert_eq!(batch.observations.len(), 4);
        assert!((batch.observations[0] - 1.0).abs() < 1e-6);
        assert!((batch.next_observations[0] - 2.0).abs() < 1e-6);
        assert!(b.push(&[1.0, 2.0], &[0.0], 0.0, &[1.0], false).is_err());
    }
}
