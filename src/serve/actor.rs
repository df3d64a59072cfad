//! The controller thread: the one owner of every session's controller and of the journal.
//! HTTP handlers send it checked requests over a channel and await its answer, so decisions
//! are made one at a time, in arrival order. It takes what has queued up as one batch,
//! decides each, appends them all to the journal in one transaction, and only then answers.
//!
//! A session's controller is rebuilt from the journal by deciding every journaled request
//! again, in order, with a fresh controller: the controllers are deterministic, so this
//! rebuilds the same warm start, and each input decided again must equal the journaled one
//! bit for bit. That happens for every session when the service starts, and for the
//! sessions of a batch the journal could not take.

use super::api::{ApiError, DecideRequest, DecideResponse, ModelInfo, PlanJson, Quantity};
use super::history::{History, HistoryPoint, PlanAhead};
use super::journal::{Entry, Journal, Outcome};
use super::metrics::Metrics;
use super::validate::{check, Checked};
use super::ServeError;
use crate::control::{Fallback, LimitPolicy, StepRequest, SteppedController, Stepper};
use crate::job::output::model_hash;
use crate::job::{build_controller, RunSpec, StandaloneController};
use crate::solve::SolveStatus;
use axum::http::StatusCode;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;
use tokio::sync::{mpsc, oneshot};

/// Requests queued for the controller thread before handlers wait to queue more.
const QUEUE: usize = 1024;

/// The controller thread, started and ready.
pub struct ControllerThread {
    /// What it serves.
    pub info: Arc<ModelInfo>,
    /// Journaled decisions it re-decided to start.
    pub restored: u64,
    /// The recent decisions of every session, which it keeps up to date.
    pub history: History,
    /// Where requests go.
    pub jobs: mpsc::Sender<Job>,
    /// Resolves when it has stopped.
    pub stopped: oneshot::Receiver<()>,
    /// The thread; its result says why it stopped.
    pub thread: std::thread::JoinHandle<Result<(), ServeError>>,
}

/// Starts the controller thread: it builds the controller of `spec` (controllers are not
/// `Send`: they are built where they run), opens the journal, restores every session in
/// it, and then serves the jobs sent to it. Returns once it is ready, or with why it could
/// not start.
pub fn spawn(
    spec: RunSpec,
    journal: PathBuf,
    max_sessions: usize,
    metrics: Arc<Metrics>,
) -> Result<ControllerThread, ServeError> {
    let (ready, on_ready) = std::sync::mpsc::channel();
    let (jobs, queue) = mpsc::channel(QUEUE);
    let (stop, stopped) = oneshot::channel();
    let thread = std::thread::Builder::new()
        .name("ghm-controller".into())
        .spawn(move || {
            let start = || -> Result<_, ServeError> {
                let built = build_controller(&spec)?;
                let info = Arc::new(model_info(&spec, &built));
                let journal = Journal::open(&journal, &spec, &info.model_sha256)?;
                let history = History::new(info.sample_period_s);
                let parts = Parts {
                    spec,
                    info: info.clone(),
                    journal,
                    history: history.clone(),
                    max_sessions,
                    metrics,
                };
                let (actor, restored) = Actor::start(parts, built)?;
                Ok((actor, info, restored, history))
            };
            let result = match start() {
                Ok((actor, info, restored, history)) => {
                    let _ = ready.send(Ok((info, restored, history)));
                    actor.run(queue)
                }
                Err(e) => {
                    let _ = ready.send(Err(e));
                    Ok(())
                }
            };
            let _ = stop.send(());
            result
        })
        .map_err(|e| ServeError::Runtime(format!("cannot start the controller thread: {e}")))?;
    let (info, restored, history) = on_ready.recv().map_err(|_| {
        ServeError::Runtime("the controller thread stopped while starting".into())
    })??;
    Ok(ControllerThread {
        info,
        restored,
        history,
        jobs,
        stopped,
        thread,
    })
}

/// `GET /model` of a controller built from `spec`.
fn model_info(spec: &RunSpec, built: &StandaloneController) -> ModelInfo {
    let model = &built.plant.model;
    let quantity = |info: &crate::lang::model::Info| Quantity {
        name: info.name.clone(),
        unit: info.unit.clone(),
        lower: None,
        upper: None,
    };
    let finite = |v: f64| Some(v).filter(|v| v.is_finite());
    ModelInfo {
        model: model.name.clone(),
        model_sha256: model_hash(&built.plant),
        controller: built.controller.name(),
        spec: spec.clone(),
        sample_period_s: model.sample_period,
        forecast_rows: built.forecast_rows.max(1),
        states: model.states.iter().map(|s| quantity(&s.info)).collect(),
        inputs: model
            .inputs
            .iter()
            .map(|u| Quantity {
                lower: Some(u.lower),
                upper: Some(u.upper),
                ..quantity(&u.info)
            })
            .collect(),
        disturbances: model
            .disturbances
            .iter()
            .map(|d| quantity(&d.info))
            .collect(),
        outputs: model
            .outputs
            .iter()
            .enumerate()
            .map(|(i, y)| match model.soft.iter().find(|b| b.output == i) {
                Some(band) => Quantity {
                    lower: finite(band.lower),
                    upper: finite(band.upper),
                    ..quantity(&y.info)
                },
                None => quantity(&y.info),
            })
            .collect(),
    }
}

/// A request for the controller thread, with where to send its answer.
pub struct Job {
    /// The request as received (journaled as it is).
    pub request: DecideRequest,
    /// The request checked against the model.
    pub checked: Checked,
    /// Where the answer goes.
    pub reply: oneshot::Sender<Result<DecideResponse, ApiError>>,
}

/// The most requests decided in one batch (one journal transaction).
const MAX_BATCH: usize = 256;

/// One greenhouse's controller and where its steps stand.
struct Session {
    /// The controller with its plant, step workspace and the service's stepper (the input
    /// clipped to its limits, the horizon's forecast rows required, the plan kept).
    controller: SteppedController,
    /// The last step decided (journaled, or in the batch being decided).
    last_step: Option<u64>,
}

/// What the controller thread is started with, besides its first controller.
struct Parts {
    spec: RunSpec,
    info: Arc<ModelInfo>,
    journal: Journal,
    history: History,
    max_sessions: usize,
    metrics: Arc<Metrics>,
}

/// The controller thread's state.
struct Actor {
    spec: RunSpec,
    info: Arc<ModelInfo>,
    journal: Journal,
    history: History,
    sessions: HashMap<String, Session>,
    /// A controller built and not yet given to a session.
    spare: Option<StandaloneController>,
    max_sessions: usize,
    metrics: Arc<Metrics>,
}

/// An answer waiting for the batch's journal transaction.
struct Pending {
    reply: oneshot::Sender<Result<DecideResponse, ApiError>>,
    result: Result<DecideResponse, ApiError>,
    /// Whether it is a decision of this batch (dropped if the journal fails).
    decided: Option<String>,
}

impl Actor {
    /// The controller thread over `journal`, with every session journaled restored;
    /// `built` is a controller of `spec` already built (it becomes the first session's).
    fn start(parts: Parts, built: StandaloneController) -> Result<(Actor, u64), ServeError> {
        let mut actor = Actor {
            spec: parts.spec,
            info: parts.info,
            journal: parts.journal,
            history: parts.history,
            sessions: HashMap::new(),
            spare: Some(built),
            max_sessions: parts.max_sessions,
            metrics: parts.metrics,
        };
        let mut restored = 0;
        for name in actor.journal.sessions()? {
            restored += actor.restore(&name)?;
        }
        actor.metrics.restored(restored);
        actor.metrics.sessions(actor.sessions.len());
        Ok((actor, restored))
    }

    /// Serves jobs until every sender is gone; an error means the journal failed and a
    /// session could not be restored from it, and the service must stop.
    fn run(mut self, mut jobs: mpsc::Receiver<Job>) -> Result<(), ServeError> {
        while let Some(first) = jobs.blocking_recv() {
            let mut batch = vec![first];
            while batch.len() < MAX_BATCH {
                match jobs.try_recv() {
                    Ok(job) => batch.push(job),
                    Err(_) => break,
                }
            }
            self.batch(batch)?;
        }
        Ok(())
    }

    /// Decides a batch, journals it, answers it.
    fn batch(&mut self, jobs: Vec<Job>) -> Result<(), ServeError> {
        let mut entries: Vec<Entry> = Vec::new();
        let mut pending = Vec::with_capacity(jobs.len());
        for job in jobs {
            let (result, decided) = self.handle(&job, &entries);
            if let Some(outcome) = &decided {
                entries.push(Entry {
                    request: job.request.clone(),
                    outcome: outcome.clone(),
                });
            }
            pending.push(Pending {
                reply: job.reply,
                result,
                decided: decided.map(|_| job.request.session),
            });
        }
        let journaled = if entries.is_empty() {
            Ok(())
        } else {
            self.journal.append(&entries)
        };
        if let Err(e) = &journaled {
            eprintln!("error: {e}; the batch's decisions are not answered");
        }
        let mut broken: Vec<String> = Vec::new();
        for p in pending {
            let result = match (&journaled, &p.decided) {
                (Err(e), Some(session)) => {
                    if !broken.contains(session) {
                        broken.push(session.clone());
                    }
                    Err(ApiError::new(
                        StatusCode::SERVICE_UNAVAILABLE,
                        format!(
                            "the decision could not be journaled ({e}); nothing was decided: retry"
                        ),
                    ))
                }
                _ => p.result,
            };
            self.count(&result, p.decided.is_some());
            // A client that has gone away no longer needs its answer.
            let _ = p.reply.send(result);
        }
        for session in broken {
            self.sessions.remove(&session);
            self.restore(&session)?;
        }
        self.metrics.sessions(self.sessions.len());
        Ok(())
    }

    fn count(&self, result: &Result<DecideResponse, ApiError>, decided: bool) {
        match result {
            Ok(r) if r.from_journal => self.metrics.journal_answer(),
            Ok(r) => self
                .metrics
                .decided(r.solve_time_ms / 1e3, r.fallback.map(Fallback::name)),
            Err(e) if decided && e.status == StatusCode::INTERNAL_SERVER_ERROR => {
                self.metrics.controller_failed()
            }
            // The handler counts every error answer.
            Err(_) => {}
        }
    }

    /// One job: its answer, and the outcome to journal when it was decided now.
    fn handle(
        &mut self,
        job: &Job,
        batch: &[Entry],
    ) -> (Result<DecideResponse, ApiError>, Option<Outcome>) {
        let name = &job.request.session;
        if !self.sessions.contains_key(name) {
            if self.sessions.len() >= self.max_sessions {
                return (
                    Err(ApiError::unprocessable(format!(
                        "session {name:?} would be one too many: this service serves at most {} \
                         (--max-sessions)",
                        self.max_sessions
                    ))),
                    None,
                );
            }
            match self.new_session() {
                Ok(s) => {
                    self.sessions.insert(name.clone(), s);
                }
                Err(e) => {
                    return (
                        Err(ApiError::new(
                            StatusCode::INTERNAL_SERVER_ERROR,
                            format!("cannot build a controller for session {name:?}: {e}"),
                        )),
                        None,
                    )
                }
            }
        }
        let step = job.request.step;
        let last = self.sessions.get(name).and_then(|s| s.last_step);
        if let Some(last) = last.filter(|l| step <= *l) {
            return (self.retry(&job.request, last, batch), None);
        }
        let Some(session) = self.sessions.get_mut(name) else {
            return (
                Err(ApiError::new(
                    StatusCode::INTERNAL_SERVER_ERROR,
                    "the session vanished",
                )),
                None,
            );
        };
        let outcome = decide_and_record(session, &job.checked, &self.history);
        session.last_step = Some(step);
        let result = match &outcome {
            Outcome::Answer(a) => Ok(a.clone()),
            Outcome::Failed(m) => Err(ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, m.clone())),
        };
        (result, Some(outcome))
    }

    /// The answer to a step at or before the session's last: the journaled one when the
    /// request is the same, a conflict otherwise.
    fn retry(
        &self,
        request: &DecideRequest,
        last: u64,
        batch: &[Entry],
    ) -> Result<DecideResponse, ApiError> {
        let (session, step) = (&request.session, request.step);
        let found = match batch
            .iter()
            .find(|e| e.request.session == *session && e.request.step == step)
        {
            Some(e) => Some(e.clone()),
            None => self
                .journal
                .lookup(session, step)
                .map_err(|e| ApiError::new(StatusCode::SERVICE_UNAVAILABLE, e.to_string()))?,
        };
        let conflict = |why: String| Err(ApiError::new(StatusCode::CONFLICT, why));
        match found {
            Some(e) if e.request == *request => match e.outcome {
                Outcome::Answer(mut a) => {
                    a.from_journal = true;
                    Ok(a)
                }
                Outcome::Failed(m) => Err(ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, m)),
            },
            Some(_) => conflict(format!(
                "step {step} of session {session:?} was decided already, for another request; a \
                 retry must repeat the request, and new measurements go with the next step \
                 (the last decided is {last})"
            )),
            None => conflict(format!(
                "step {step} of session {session:?} comes after step {last} was decided: a \
                 session's steps go forward"
            )),
        }
    }

    /// A fresh session: the spare controller, or a new one.
    fn new_session(&mut self) -> Result<Session, ServeError> {
        let controller = match self.spare.take() {
            Some(c) => c,
            None => build_controller(&self.spec)?,
        };
        let stepper = Stepper::new(LimitPolicy::Clip)
            .with_forecast_rows(controller.forecast_rows)
            .with_plans();
        Ok(Session {
            controller: SteppedController::new(controller.plant, controller.controller, stepper),
            last_step: None,
        })
    }

    /// Rebuilds `name` from the journal; returns the decisions re-decided.
    fn restore(&mut self, name: &str) -> Result<u64, ServeError> {
        let mut session = self.new_session()?;
        let mut n = 0;
        let info = self.info.clone();
        let history = self.history.clone();
        history.forget(name);
        self.journal.for_each(name, |entry| {
            let step = entry.request.step;
            let mismatch = |what: String| ServeError::Recovery {
                session: name.to_string(),
                step,
                message: what,
            };
            let checked = check(&entry.request, &info).map_err(|e| mismatch(e.message))?;
            let again = decide_and_record(&mut session, &checked, &history);
            same_decision(&entry.outcome, &again).map_err(mismatch)?;
            session.last_step = Some(step);
            n += 1;
            Ok(())
        })?;
        self.sessions.insert(name.to_string(), session);
        Ok(n)
    }
}

/// Decides one checked request with the session's controller, and adds a decision to the
/// session's history.
fn decide_and_record(session: &mut Session, c: &Checked, history: &History) -> Outcome {
    let (outcome, outputs) = decide(session, c);
    if let Outcome::Answer(a) = &outcome {
        let plan = a.plan.as_ref().map(|p| {
            let predicted = planned_outputs(session, p, &c.forecast);
            PlanAhead::new(a.step, p, predicted)
        });
        let point = HistoryPoint {
            step: a.step,
            state: c.state.clone(),
            input: a.input.clone(),
            outputs,
        };
        history.record(&c.session, point, plan);
    }
    outcome
}

/// The outputs of a plan's predicted states `x_{i+1}`, with its inputs `u_i` and the
/// forecast row of step `i+1` (the last row past the forecast's end).
fn planned_outputs(session: &Session, plan: &PlanJson, forecast: &[f64]) -> Vec<Vec<f64>> {
    let plant = session.controller.plant();
    let nd = plant.layout.nd;
    let rows = forecast.len().checked_div(nd).unwrap_or(0);
    plan.states
        .iter()
        .zip(&plan.inputs)
        .enumerate()
        .map(|(i, (x, u))| {
            let row = (i + 1).min(rows.saturating_sub(1));
            forecast
                .get(row * nd..(row + 1) * nd)
                .map(|d| plant.outputs(x, u, d, session.controller.params()))
                .unwrap_or_default()
        })
        .collect()
}

/// Decides one checked request with the session's controller, through the one
/// [`Stepper`] every door shares (the input clipped to its bounds and rate limits); returns
/// the outputs the controller observed with the outcome (none where it failed).
fn decide(session: &mut Session, c: &Checked) -> (Outcome, Vec<f64>) {
    let request = StepRequest {
        step: c.step,
        state: &c.state,
        measured_outputs: c.outputs.as_deref(),
        previous_input: &c.previous_input,
        forecast: &c.forecast,
    };
    match session.controller.decide(&request) {
        Ok(d) => {
            let r = d.record;
            let answer = Outcome::Answer(DecideResponse {
                session: c.session.clone(),
                step: c.step as u64,
                input: d.input,
                status: r.status,
                iterations: r.iterations,
                inertia_corrections: r.inertia_corrections,
                solve_time_ms: r.solve_time_s * 1e3,
                fallback: r.fallback,
                terminal_region: r.terminal_region,
                plan: d.plan.map(|p| PlanJson {
                    inputs: p.inputs,
                    states: p.states,
                }),
                from_journal: false,
            });
            (answer, d.outputs)
        }
        Err(e) => (
            Outcome::Failed(format!(
                "the controller failed at step {} of session {:?}: {e}",
                c.step, c.session
            )),
            Vec::new(),
        ),
    }
}

/// Whether a decision made again is the journaled one: the same input to the last bit,
/// reached the same way; `Err` says how they differ.
fn same_decision(journaled: &Outcome, again: &Outcome) -> Result<(), String> {
    let bits = |u: &[f64]| u.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    match (journaled, again) {
        (Outcome::Answer(a), Outcome::Answer(b))
            if bits(&a.input) == bits(&b.input)
                && a.status == b.status
                && a.iterations == b.iterations
                && a.fallback == b.fallback =>
        {
            Ok(())
        }
        (Outcome::Failed(_), Outcome::Failed(_)) => Ok(()),
        (a, b) => Err(format!(
            "the journal says {}, deciding again gives {}: the model, the controller or a file \
             it reads (agent, value network) is not the one the journal was written with; \
             start with those, or begin another --journal",
            describe(a),
            describe(b)
        )),
    }
}

fn describe(o: &Outcome) -> String {
    match o {
        Outcome::Answer(a) => format!(
            "input {:?} ({} iterations, status `{}`, fallback {:?})",
            a.input,
            a.iterations,
            a.status.map_or("", SolveStatus::name),
            a.fallback.map(Fallback::name)
        ),
        Outcome::Failed(m) => format!("a failure ({m})"),
    }
}
