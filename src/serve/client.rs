//! `ghm replay`'s side of the service: [`RemoteController`], a [`Controller`] that asks a
//! running `ghm serve` for each decision over HTTP (ureq, blocking). It sends what the
//! season loop observes — the step, the state, the outputs, the previous input and as many
//! forecast rows as the served controller reads — and retries while the service is down
//! or restarting, so that a season outlives a restart of the service.

use super::api::{DecideRequest, DecideResponse, ErrorBody, ModelInfo};
use super::ServeError;
use crate::control::{ControlError, Controller, Decision, Observation, StepRecord};
use std::time::{Duration, Instant};

/// A controller served by `ghm serve` at a URL.
pub struct RemoteController {
    agent: ureq::Agent,
    base: String,
    authorization: Option<String>,
    session: String,
    info: ModelInfo,
    retry_for: Duration,
}

impl RemoteController {
    /// Connects to the service at `base` (`http://host:port`): reads what it serves
    /// (`GET /model`), retrying for up to `retry_for` while it does not answer.
    pub fn connect(
        base: &str,
        token: Option<&str>,
        session: &str,
        retry_for: Duration,
    ) -> Result<RemoteController, ServeError> {
        let agent: ureq::Agent = ureq::Agent::config_builder()
            // A controller next to the greenhouse is reached directly, not through a proxy.
            .proxy(None)
            .http_status_as_error(false)
            .timeout_global(Some(Duration::from_secs(600)))
            .build()
            .into();
        let base = base.trim_end_matches('/').to_string();
        let mut client = RemoteController {
            agent,
            authorization: token.map(|t| format!("Bearer {t}")),
            session: session.to_string(),
            info: placeholder_info(),
            retry_for,
            base,
        };
        let (status, body) = client
            .call("GET", "/model", None)
            .map_err(ServeError::Client)?;
        if status != 200 {
            return Err(ServeError::Client(format!(
                "{}/model answered {status}: {}",
                client.base,
                error_text(&body)
            )));
        }
        client.info = serde_json::from_str(&body).map_err(|e| {
            ServeError::Client(format!(
                "{}/model is not a ghm service's model description: {e}",
                client.base
            ))
        })?;
        Ok(client)
    }

    /// What the service serves.
    pub fn info(&self) -> &ModelInfo {
        &self.info
    }

    /// One request, retried while the service cannot be reached or answers 503; the
    /// status and body of the answer, or why there was none.
    fn call(&self, method: &str, path: &str, body: Option<&[u8]>) -> Result<(u16, String), String> {
        let url = format!("{}{path}", self.base);
        let started = Instant::now();
        let mut wait = Duration::from_millis(50);
        let mut told = false;
        loop {
            let answer = self.once(method, &url, body);
            let why = match answer {
                Ok((503, text)) => format!("503 {}", error_text(&text)),
                Ok(answer) => return Ok(answer),
                Err(ureq::Error::BadUri(e)) => return Err(format!("{url}: not a URL ({e})")),
                Err(e) => e.to_string(),
            };
            if started.elapsed() >= self.retry_for {
                return Err(format!(
                    "{url} did not answer in {:.0} s: {why}",
                    self.retry_for.as_secs_f64()
                ));
            }
            if !told {
                eprintln!(
                    "{url}: {why}; retrying for up to {:.0} s",
                    self.retry_for.as_secs_f64()
                );
                told = true;
            }
            std::thread::sleep(wait);
            wait = (wait * 2).min(Duration::from_secs(1));
        }
    }

    fn once(
        &self,
        method: &str,
        url: &str,
        body: Option<&[u8]>,
    ) -> Result<(u16, String), ureq::Error> {
        let mut response = match (method, body) {
            ("POST", Some(body)) => {
                let mut r = self
                    .agent
                    .post(url)
                    .header("Content-Type", "application/json");
                if let Some(a) = &self.authorization {
                    r = r.header("Authorization", a);
                }
                r.send(body)?
            }
            _ => self.agent.get(url).call()?,
        };
        let status = response.status().as_u16();
        let text = response.body_mut().read_to_string()?;
        Ok((status, text))
    }
}

impl Controller for RemoteController {
    fn name(&self) -> String {
        self.info.controller.clone()
    }

    fn decide(&mut self, o: &Observation) -> Result<Decision, ControlError> {
        let fail = ControlError::Other;
        let nd = self.info.disturbances.len();
        // Without disturbances every row is empty: as many as the controller reads.
        let rows = o
            .forecast
            .len()
            .checked_div(nd)
            .map_or(self.info.forecast_rows, |r| r.min(self.info.forecast_rows));
        let some = |v: &[f64]| v.iter().map(|x| Some(*x)).collect::<Vec<_>>();
        let request = DecideRequest {
            session: self.session.clone(),
            step: o.step as u64,
            state: some(o.state),
            previous_input: some(o.previous_input),
            outputs: Some(some(o.outputs)),
            forecast: (0..rows)
                .map(|r| some(&o.forecast[r * nd..(r + 1) * nd]))
                .collect(),
            units: None,
        };
        let body = serde_json::to_vec(&request).map_err(|source| ControlError::Json {
            what: format!("cannot encode the request to {}/decide", self.base),
            source,
        })?;
        let (status, text) = self.call("POST", "/decide", Some(&body)).map_err(fail)?;
        if status != 200 {
            return Err(fail(format!(
                "{}/decide answered {status}: {}",
                self.base,
                error_text(&text)
            )));
        }
        let answer: DecideResponse =
            serde_json::from_str(&text).map_err(|source| ControlError::Json {
                what: format!("{}/decide answered what is not a decision", self.base),
                source,
            })?;
        if answer.step != o.step as u64 || answer.session != self.session {
            return Err(fail(format!(
                "{}/decide answered for step {} of session {:?}; asked for step {} of {:?}",
                self.base, answer.step, answer.session, o.step, self.session
            )));
        }
        Ok(Decision {
            input: answer.input,
            record: StepRecord {
                solve_time_s: answer.solve_time_ms / 1e3,
                iterations: answer.iterations,
                inertia_corrections: answer.inertia_corrections,
                status: answer.status,
                fallback: answer.fallback,
                terminal_region: answer.terminal_region,
            },
        })
    }
}

/// The message of an error body, or the body itself.
fn error_text(body: &str) -> String {
    serde_json::from_str::<ErrorBody>(body).map_or_else(|_| body.trim().to_string(), |e| e.error)
}

/// Stands in until `GET /model` has answered.
fn placeholder_info() -> ModelInfo {
    ModelInfo {
        model: String::new(),
        model_sha256: String::new(),
        controller: String::new(),
        spec: crate::job::RunSpec {
            model: Default::default(),
            weather: Default::default(),
            plant: Default::default(),
            controller: crate::job::ControllerSpec::Expert,
        },
        sample_period_s: 0.0,
        forecast_rows: 0,
        states: Vec::new(),
        inputs: Vec::new(),
        disturbances: Vec::new(),
        outputs: Vec::new(),
    }
}
