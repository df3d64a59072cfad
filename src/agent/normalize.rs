//! A running observation normaliser in the style of Stable-Baselines3's `VecNormalize`
//! (`norm_obs = True`, observations only).
//!
//! Per component it keeps a running mean `μ`, a running (population) variance `σ²` and a
//! common sample count `n`, and standardises `s' = clip((s − μ)/√(σ² + ε), −c, c)` with
//! `ε = 1e-8` and `c = 10` by default. Updates merge a batch's mean, variance and size into
//! the running moments with the parallel algorithm of Chan, Golub and LeVeque, exactly as
//! SB3's `RunningMeanStd.update_from_moments`; as there, the count starts at `1e-4` with
//! `μ = 0`, `σ² = 1` (a tiny prior that keeps the first standardisation finite).
//! A frozen normaliser (evaluation, or a trained agent) ignores updates.
//!
//! The normaliser is `serde`-serialisable so that it can be saved beside an agent; a
//! deserialised one is checked like [`Normalizer::from_stats`].

use crate::agent::AgentError;
use serde::{Deserialize, Serialize};

/// SB3's `RunningMeanStd` initial count.
pub const DEFAULT_COUNT: f64 = 1e-4;
/// SB3's `VecNormalize` epsilon under the square root.
pub const DEFAULT_EPSILON: f64 = 1e-8;
/// SB3's `VecNormalize` default `clip_obs`.
pub const DEFAULT_CLIP: f64 = 10.0;

/// Running mean/variance observation normaliser. See the [module documentation](self).
///
/// # Examples
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::agent::Normalizer;
///
/// // From a zero prior count, the statistics are those of the data: μ = (2, 10),
/// // σ² = (1, 0) over the batch (1, 10), (3, 10).
/// let mut n = Normalizer::from_stats(vec![0.0; 2], vec![1.0; 2], 0.0)?;
/// n.update_batch(&[1.0, 10.0, 3.0, 10.0])?;
/// assert_eq!((n.mean(), n.var(), n.count()), (&[2.0, 10.0][..], &[1.0, 0.0][..], 2.0));
///
/// // s' = clip((s − μ)/√(σ² + ε), −10, 10): a constant column blows up, and is clipped.
/// let mut out = [0.0; 2];
/// n.normalize(&[4.0, 10.01], &mut out)?;
/// assert!((out[0] - 2.0).abs() < 1e-7);
/// assert_eq!(out[1], 10.0);
///
/// // Frozen (a trained agent), it ignores updates; a wrong width is an error.
/// n.freeze();
/// n.update(&[100.0, 100.0])?;
/// assert_eq!(n.mean(), [2.0, 10.0]);
/// assert!(n.update(&[1.0]).is_err());
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "NormalizerData", into = "NormalizerData")]
pub struct Normalizer {
    mean: Vec<f64>,
    var: Vec<f64>,
    count: f64,
    clip: f64,
    epsilon: f64,
    frozen: bool,
}

/// The serialised form, checked on the way in.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct NormalizerData {
    mean: Vec<f64>,
    var: Vec<f64>,
    count: f64,
    clip: f64,
    epsilon: f64,
    frozen: bool,
}

impl TryFrom<NormalizerData> for Normalizer {
    type Error = AgentError;
    fn try_from(d: NormalizerData) -> Result<Normalizer, AgentError> {
        let mut n = Normalizer::from_stats(d.mean, d.var, d.count)?
            .with_clip(d.clip)?
            .with_epsilon(d.epsilon)?;
        n.frozen = d.frozen;
        Ok(n)
    }
}

impl From<Normalizer> for NormalizerData {
    fn from(n: Normalizer) -> NormalizerData {
        NormalizerData {
            mean: n.mean,
            var: n.var,
            count: n.count,
            clip: n.clip,
            epsilon: n.epsilon,
            frozen: n.frozen,
        }
    }
}

fn bad(name: &'static str, value: f64, why: &'static str) -> AgentError {
    AgentError::BadSetting { name, value, why }
}

impl Normalizer {
    /// A fresh normaliser for observations of `width` entries with SB3's defaults:
    /// `μ = 0`, `σ² = 1`, count `1e-4`, `ε = 1e-8`, clip `10`, not frozen.
    pub fn new(width: usize) -> Normalizer {
        Normalizer {
            mean: vec![0.0; width],
            var: vec![1.0; width],
            count: DEFAULT_COUNT,
            clip: DEFAULT_CLIP,
            epsilon: DEFAULT_EPSILON,
            frozen: false,
        }
    }

    /// A normaliser with given running statistics (e.g. an agent's saved `VecNormalize`),
    /// default `ε` and clip, not frozen. A count of 0 makes the first update take the batch's
    /// moments as they are.
    ///
    /// Errors: [`AgentError::ObservationWidth`] if `var` and `mean` differ in length,
    /// [`AgentError::BadSetting`] for a non-finite mean, a negative or non-finite variance, or a
    /// negative or non-finite count.
    pub fn from_stats(mean: Vec<f64>, var: Vec<f64>, count: f64) -> Result<Normalizer, AgentError> {
        if var.len() != mean.len() {
            return Err(AgentError::ObservationWidth {
                given: var.len(),
                expected: mean.len(),
            });
        }
        if let Some(&m) = mean.iter().find(|m| !m.is_finite()) {
            return Err(bad("mean", m, "must be finite"));
        }
        if let Some(&v) = var.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            return Err(bad("var", v, "must be finite and ≥ 0"));
        }
        if !(count.is_finite() && count >= 0.0) {
            return Err(bad("count", count, "must be finite and ≥ 0"));
        }
        Ok(Normalizer {
            mean,
            var,
            count,
            clip: DEFAULT_CLIP,
            epsilon: DEFAULT_EPSILON,
            frozen: false,
        })
    }

    /// Sets the clip bound `c` (> 0; may be infinite for no clipping).
    pub fn with_clip(mut self, clip: f64) -> Result<Normalizer, AgentError> {
        if clip.is_nan() || clip <= 0.0 {
            return Err(bad("clip", clip, "must be > 0"));
        }
        self.clip = clip;
        Ok(self)
    }

    /// Sets `ε` under the square root (finite, ≥ 0).
    pub fn with_epsilon(mut self, epsilon: f64) -> Result<Normalizer, AgentError> {
        if !(epsilon.is_finite() && epsilon >= 0.0) {
            return Err(bad("epsilon", epsilon, "must be finite and ≥ 0"));
        }
        self.epsilon = epsilon;
        Ok(self)
    }

    /// Number of observation entries.
    pub fn width(&self) -> usize {
        self.mean.len()
    }

    /// Running mean `μ`.
    pub fn mean(&self) -> &[f64] {
        &self.mean
    }

    /// Running population variance `σ²`.
    pub fn var(&self) -> &[f64] {
        &self.var
    }

    /// Running sample count (including the initial prior count).
    pub fn count(&self) -> f64 {
        self.count
    }

    /// The clip bound `c`.
    pub fn clip(&self) -> f64 {
        self.clip
    }

    /// `ε` under the square root.
    pub fn epsilon(&self) -> f64 {
        self.epsilon
    }

    /// Stops updates (evaluation, or a trained agent).
    pub fn freeze(&mut self) {
        self.frozen = true;
    }

    /// Resumes updates.
    pub fn unfreeze(&mut self) {
        self.frozen = false;
    }

    /// Whether updates are ignored.
    pub fn is_frozen(&self) -> bool {
        self.frozen
    }

    fn check_width(&self, given: usize) -> Result<(), AgentError> {
        if given != self.width() {
            return Err(AgentError::ObservationWidth {
                given,
                expected: self.width(),
            });
        }
        Ok(())
    }

    /// Merges one observation (a batch of one: its mean, zero variance, count 1), as SB3's
    /// `VecNormalize` does with a single environment. No effect when frozen.
    ///
    /// Errors: [`AgentError::ObservationWidth`].
    pub fn update(&mut self, obs: &[f64]) -> Result<(), AgentError> {
        self.check_width(obs.len())?;
        if self.frozen {
            return Ok(());
        }
        for (i, &s) in obs.iter().enumerate() {
            merge(&mut self.mean[i], &mut self.var[i], self.count, s, 0.0, 1.0);
        }
        self.count += 1.0;
        Ok(())
    }

    /// Merges a batch of observations, row-major (`rows.len()` a multiple of the width): the
    /// batch's mean and population variance (two passes) are merged into the running moments.
    /// An empty batch, or a frozen normaliser, changes nothing.
    ///
    /// Errors: [`AgentError::BatchShape`].
    pub fn update_batch(&mut self, rows: &[f64]) -> Result<(), AgentError> {
        let w = self.width();
        if w == 0 || !rows.len().is_multiple_of(w) {
            if rows.is_empty() {
                return Ok(());
            }
            return Err(AgentError::BatchShape {
                len: rows.len(),
                width: w,
            });
        }
        let n = rows.len() / w;
        if self.frozen || n == 0 {
            return Ok(());
        }
        let nf = n as f64;
        for j in 0..w {
            let column = || rows.iter().skip(j).step_by(w);
            let bm = column().sum::<f64>() / nf;
            let bv = column().map(|s| (s - bm) * (s - bm)).sum::<f64>() / nf;
            merge(&mut self.mean[j], &mut self.var[j], self.count, bm, bv, nf);
        }
        self.count += nf;
        Ok(())
    }

    /// Writes `clip((s − μ)/√(σ² + ε), −c, c)` into `out`.
    ///
    /// Errors: [`AgentError::ObservationWidth`] if `obs` or `out` has the wrong length.
    pub fn normalize(&self, obs: &[f64], out: &mut [f64]) -> Result<(), AgentError> {
        self.check_width(obs.len())?;
        self.check_width(out.len())?;
        for (i, (o, &s)) in out.iter_mut().zip(obs).enumerate() {
            *o = self.one(i, s);
        }
        Ok(())
    }

    /// [`Normalizer::normalize`] into `f32` (the precision of the networks), with `scratch`
    /// as the `f64` buffer.
    ///
    /// Errors: [`AgentError::ObservationWidth`].
    pub fn normalize_f32(
        &self,
        obs: &[f64],
        scratch: &mut [f64],
        out: &mut [f32],
    ) -> Result<(), AgentError> {
        self.normalize(obs, scratch)?;
        for (o, s) in out.iter_mut().zip(scratch.iter()) {
            *o = *s as f32;
        }
        Ok(())
    }

    /// [`Normalizer::normalize`] in place.
    ///
    /// Errors: [`AgentError::ObservationWidth`].
    pub fn normalize_in_place(&self, obs: &mut [f64]) -> Result<(), AgentError> {
        self.check_width(obs.len())?;
        for (i, s) in obs.iter_mut().enumerate() {
            *s = self.one(i, *s);
        }
        Ok(())
    }

    fn one(&self, i: usize, s: f64) -> f64 {
        ((s - self.mean[i]) / (self.var[i] + self.epsilon).sqrt()).clamp(-self.clip, self.clip)
    }
}

/// Chan et al.'s parallel merge of `(mean, var, count)` with a batch `(bm, bv, bc)`, written
/// as SB3's `RunningMeanStd.update_from_moments`; the caller adds `bc` to the count.
fn merge(mean: &mut f64, var: &mut f64, count: f64, bm: f64, bv: f64, bc: f64) {
    let delta = bm - *mean;
    let total = count + bc;
    let new_mean = *mean + delta * bc / total;
    let m_a = *var * count;
    let m_b = bv * bc;
    let m2 = m_a + m_b + delta * delta * count * bc / total;
    *mean = new_mean;
    *var = m2 / total;
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const W: usize = 5;

    /// 1000 rows of 5 columns with different scales and offsets.
    fn data() -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let scale = [1e-3, 1.0, 40.0, 1e3, 7.0];
        let offset = [0.1, -3.0, 500.0, 1e4, 0.0];
        (0..1000 * W)
            .map(|i| offset[i % W] + scale[i % W] * rng.random_range(-1.0..1.0))
            .collect()
    }

    /// Two-pass mean and population variance of each column.
    fn two_pass(rows: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = (rows.len() / W) as f64;
        let mean: Vec<f64> = (0..W)
            .map(|j| rows.iter().skip(j).step_by(W).sum::<f64>() / n)
            .collect();
        let var = (0..W)
            .map(|j| {
                rows.iter()
                    .skip(j)
                    .step_by(W)
                    .map(|s| (s - mean[j]).powi(2))
                    .sum::<f64>()
                    / n
            })
            .collect();
        (mean, var)
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs().max(1e-300)
    }

    #[test]
    fn running_moments_equal_two_pass_moments() {
        let rows = data();
        let (mean, var) = two_pass(&rows);
        // Count 0: the running moments are the data's own.
        let mut n = Normalizer::from_stats(vec![0.0; W], vec![1.0; W], 0.0).unwrap();
        for row in rows.chunks_exact(W) {
            n.update(row).unwrap();
        }
        for j in 0..W {
            assert!(close(n.mean()[j], mean[j], 1e-12), "mean {j}");
            assert!(close(n.var()[j], var[j], 1e-12), "var {j}");
        }
        assert_eq!(n.count(), 1000.0);
        // SB3's prior (count 1e-4, μ = 0, σ² = 1) pooled with the data, computed directly.
        let mut sb3 = Normalizer::new(W);
        for row in rows.chunks_exact(W) {
            sb3.update(row).unwrap();
        }
        let (c, nd) = (DEFAULT_COUNT, 1000.0);
        for j in 0..W {
            let m = nd * mean[j] / (nd + c);
            let m2 = c * 1.0 + c * m * m + nd * var[j] + nd * (mean[j] - m).powi(2);
            assert!(close(sb3.mean()[j], m, 1e-12), "SB3 mean {j}");
            assert!(close(sb3.var()[j], m2 / (nd + c), 1e-12), "SB3 var {j}");
        }
        assert!(close(sb3.count(), nd + c, 1e-15));
    }

    #[test]
    fn batch_updates_equal_one_by_one_updates() {
        let rows = data();
        let mut single = Normalizer::new(W);
        for row in rows.chunks_exact(W) {
            single.update(row).unwrap();
        }
        let mut batched = Normalizer::new(W);
        // Uneven batches: 1, 7, 100, 392, 500 rows.
        let mut at = 0;
        for size in [1, 7, 100, 392, 500] {
            batched
                .update_batch(&rows[at * W..(at + size) * W])
                .unwrap();
            at += size;
        }
        assert_eq!(at, 1000);
        let mut whole = Normalizer::new(W);
        whole.update_batch(&rows).unwrap();
        for j in 0..W {
            for other in [&batched, &whole] {
                assert!(close(other.mean()[j], single.mean()[j], 1e-12), "mean {j}");
                assert!(close(other.var()[j], single.var()[j], 1e-12), "var {j}");
            }
        }
        assert!(close(batched.count(), single.count(), 1e-15));
        assert!(close(whole.count(), single.count(), 1e-15));
    }

    #[test]
    fn standardises_and_clips_at_ten() {
        let n = Normalizer::from_stats(vec![1.0, -2.0, 0.0], vec![4.0, 0.25, 1e-6], 5.0).unwrap();
        let mut out = [0.0; 3];
        n.normalize(&[5.0, -2.0, 1.0], &mut out).unwrap();
        assert!(close(out[0], 4.0 / (4.0f64 + 1e-8).sqrt(), 1e-15));
        assert_eq!(out[1], 0.0);
        // 1/√(1e-6 + 1e-8) ≈ 995: clipped.
        assert_eq!(out[2], 10.0);
        n.normalize(&[-1e9, 1e9, -1.0], &mut out).unwrap();
        assert_eq!(out, [-10.0, 10.0, -10.0]);
        let mut inplace = [5.0, -2.0, 1.0];
        n.normalize_in_place(&mut inplace).unwrap();
        n.normalize(&[5.0, -2.0, 1.0], &mut out).unwrap();
        assert_eq!(inplace, out);
        let wide = n.clone().with_clip(f64::INFINITY).unwrap();
        wide.normalize(&[-1e9, 1e9, -1.0], &mut out).unwrap();
        assert!(out[0] < -1e8 && out[1] > 1e9);
    }

    #[test]
    fn frozen_normaliser_does_not_change() {
        let rows = data();
        let mut n = Normalizer::new(W);
        n.update_batch(&rows[..50 * W]).unwrap();
        n.freeze();
        let before = n.clone();
        n.update(&rows[..W]).unwrap();
        n.update_batch(&rows).unwrap();
        assert_eq!(n, before);
        n.unfreeze();
        n.update(&rows[..W]).unwrap();
        assert_ne!(n, before);
    }

    #[test]
    fn wrong_sizes_are_errors() {
        let mut n = Normalizer::new(3);
        assert_eq!(
            n.update(&[1.0, 2.0]),
            Err(AgentError::ObservationWidth {
                given: 2,
                expected: 3
            })
        );
        assert_eq!(
            n.update_batch(&[1.0; 7]),
            Err(AgentError::BatchShape { len: 7, width: 3 })
        );
        let mut out = [0.0; 2];
        assert!(n.normalize(&[1.0; 3], &mut out).is_err());
        assert!(n.normalize(&[1.0; 2], &mut [0.0; 3]).is_err());
        assert!(Normalizer::from_stats(vec![0.0; 2], vec![1.0; 3], 1.0).is_err());
        assert!(Normalizer::from_stats(vec![0.0; 2], vec![-1.0, 1.0], 1.0).is_err());
        assert!(Normalizer::from_stats(vec![0.0; 2], vec![1.0; 2], f64::NAN).is_err());
        assert!(Normalizer::new(2).with_clip(0.0).is_err());
        assert!(Normalizer::new(2).with_epsilon(-1.0).is_err());
        // An empty batch is no update.
        let before = n.clone();
        n.update_batch(&[]).unwrap();
        assert_eq!(n, before);
    }

    #[test]
    fn serde_round_trip_and_checked_input() {
        let mut n = Normalizer::new(W);
        n.update_batch(&data()).unwrap();
        n.freeze();
        let text = serde_json::to_string(&n).unwrap();
        let back: Normalizer = serde_json::from_str(&text).unwrap();
        assert_eq!(back, n);
        assert!(back.is_frozen());
        let broken = r#"{"mean":[0.0,1.0],"var":[1.0],"count":1.0,"clip":10.0,"epsilon":1e-8,"frozen":false}"#;
        assert!(serde_json::from_str::<Normalizer>(broken).is_err());
    }
}
