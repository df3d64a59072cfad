//! The recent decisions of every session, kept in memory for the live page (`GET /` and
//! `GET /history`): the measured state, the applied input and the outputs of each step,
//! and the plan of the last decision. The controller thread writes it as it decides (and
//! as it restores a session from the journal); the HTTP side reads it without waiting for
//! a decision. Each session keeps at most [`MAX_HISTORY_DAYS`] days of steps.

use super::api::PlanJson;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex, MutexGuard};

/// The most days of steps a session keeps, and `GET /history` returns.
pub const MAX_HISTORY_DAYS: f64 = 7.0;

/// The most steps a session keeps, whatever the sample period.
pub const MAX_HISTORY_STEPS: usize = 20_000;

/// One decided step, as the live page draws it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryPoint {
    /// The step `k`.
    pub step: u64,
    /// The measured state `x(k)`.
    pub state: Vec<f64>,
    /// The input decided for `k … k+1`.
    pub input: Vec<f64>,
    /// The outputs at `k` the controller saw (measured, or evaluated by the service).
    pub outputs: Vec<f64>,
}

/// The plan of the last decision, placed in time: its inputs apply at steps
/// `step, step+1, …` and its states (and outputs) are predicted at `step+1, step+2, …`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanAhead {
    /// The step the plan was made at.
    pub step: u64,
    /// One row per step of the horizon, one value per input.
    pub inputs: Vec<Vec<f64>>,
    /// One row per step of the horizon, one value per state.
    pub states: Vec<Vec<f64>>,
    /// The outputs of the predicted states, one row per step of the horizon.
    pub outputs: Vec<Vec<f64>>,
}

impl PlanAhead {
    /// `plan`, made at `step`, with the outputs of its predicted states.
    pub fn new(step: u64, plan: &PlanJson, outputs: Vec<Vec<f64>>) -> PlanAhead {
        PlanAhead {
            step,
            inputs: plan.inputs.clone(),
            states: plan.states.clone(),
            outputs,
        }
    }
}

/// `GET /history`: a session's last steps and its current plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryJson {
    /// The session shown.
    pub session: String,
    /// Every session with decisions, sorted.
    pub sessions: Vec<String>,
    /// The decided steps, oldest first.
    pub steps: Vec<HistoryPoint>,
    /// The plan of the last decision; `null` for controllers without one, after a
    /// fallback, and before the first decision.
    pub plan: Option<PlanAhead>,
}

/// One session's recent steps.
#[derive(Debug, Default)]
struct Track {
    points: VecDeque<HistoryPoint>,
    plan: Option<PlanAhead>,
}

/// The recent decisions of every session, shared by the controller thread and the
/// handlers.
#[derive(Debug, Clone)]
pub struct History {
    tracks: Arc<Mutex<HashMap<String, Track>>>,
    capacity: usize,
}

impl History {
    /// An empty history keeping [`MAX_HISTORY_DAYS`] days of steps of `sample_period_s`.
    pub fn new(sample_period_s: f64) -> History {
        History {
            tracks: Arc::default(),
            capacity: steps_in_days(MAX_HISTORY_DAYS, sample_period_s),
        }
    }

    /// The most steps a session keeps.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    fn lock(&self) -> MutexGuard<'_, HashMap<String, Track>> {
        // A writer that panicked left whole entries behind: the map is still usable.
        self.tracks.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Adds a decided step of `session`, and its plan (replacing the last).
    pub fn record(&self, session: &str, point: HistoryPoint, plan: Option<PlanAhead>) {
        let mut tracks = self.lock();
        let track = tracks.entry(session.to_string()).or_default();
        if track.points.len() >= self.capacity {
            track.points.pop_front();
        }
        track.points.push_back(point);
        track.plan = plan;
    }

    /// Forgets `session` (before it is restored from the journal again).
    pub fn forget(&self, session: &str) {
        self.lock().remove(session);
    }

    /// The last `steps` steps of `session` (by default the `default` session, or else the
    /// first by name) and its plan.
    pub fn snapshot(&self, session: Option<&str>, steps: usize) -> HistoryJson {
        let tracks = self.lock();
        let mut sessions: Vec<String> = tracks.keys().cloned().collect();
        sessions.sort();
        let name = match session {
            Some(s) => s.to_string(),
            None if tracks.contains_key(super::api::DEFAULT_SESSION) => {
                super::api::DEFAULT_SESSION.to_string()
            }
            None => sessions.first().cloned().unwrap_or_default(),
        };
        let (points, plan) = match tracks.get(&name) {
            Some(t) => {
                let skip = t.points.len().saturating_sub(steps);
                (
                    t.points.iter().skip(skip).cloned().collect(),
                    t.plan.clone(),
                )
            }
            None => (Vec::new(), None),
        };
        HistoryJson {
            session: name,
            sessions,
            steps: points,
            plan,
        }
    }
}

/// The steps of `sample_period_s` in `days` days, at least 1 and at most
/// [`MAX_HISTORY_STEPS`].
pub fn steps_in_days(days: f64, sample_period_s: f64) -> usize {
    let steps = (days * 86_400.0 / sample_period_s).ceil();
    if steps.is_finite() && steps >= 1.0 {
        (steps as usize).min(MAX_HISTORY_STEPS)
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(step: u64) -> HistoryPoint {
        HistoryPoint {
            step,
            state: vec![step as f64],
            input: vec![0.0],
            outputs: vec![],
        }
    }

    #[test]
    fn a_session_keeps_its_last_days_and_the_last_plan() {
        // One day of 6-hour steps: 4 steps a day, 28 kept.
        let history = History::new(6.0 * 3600.0);
        assert_eq!(history.capacity(), 28);
        for k in 0..30 {
            history.record("a", point(k), None);
        }
        let plan = PlanAhead {
            step: 30,
            inputs: vec![vec![1.0]],
            states: vec![vec![2.0]],
            outputs: vec![vec![]],
        };
        history.record("a", point(30), Some(plan.clone()));
        let all = history.snapshot(Some("a"), usize::MAX);
        assert_eq!(all.steps.len(), 28);
        assert_eq!(all.steps[0].step, 3);
        assert_eq!(all.plan, Some(plan));
        let last = history.snapshot(None, 2);
        assert_eq!(last.session, "a");
        assert_eq!(
            last.steps.iter().map(|p| p.step).collect::<Vec<_>>(),
            [29, 30]
        );
        history.forget("a");
        let none = history.snapshot(Some("a"), 2);
        assert!(none.steps.is_empty() && none.plan.is_none() && none.sessions.is_empty());
    }

    #[test]
    fn steps_in_days_is_bounded() {
        assert_eq!(steps_in_days(2.0, 1800.0), 96);
        assert_eq!(steps_in_days(7.0, 1.0), MAX_HISTORY_STEPS);
        assert_eq!(steps_in_days(0.0, 1800.0), 1);
        assert_eq!(steps_in_days(1.0, 0.0), 1);
    }
}
