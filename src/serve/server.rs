//! The HTTP side of the service (axum on tokio): the routes, the token, the body limit,
//! parsing and checking requests, the live page and its history, and starting and
//! stopping the whole service. Deciding is
//! the controller thread's ([`actor`](super::actor)); this side only talks to it.

use super::actor::{spawn, ControllerThread, Job};
use super::api::{ApiError, DecideRequest, ErrorBody, ModelInfo};
use super::history::{steps_in_days, History, MAX_HISTORY_DAYS};
use super::metrics::Metrics;
use super::token::TokenCheck;
use super::validate::check;
use super::{ServeError, ServeOptions};
use axum::body::{to_bytes, Bytes};
use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use std::io::Write;
use std::sync::Arc;
use std::time::Instant;
use tokio::sync::{mpsc, oneshot};

/// What the handlers share.
struct App {
    jobs: mpsc::Sender<Job>,
    info: Arc<ModelInfo>,
    history: History,
    info_json: Bytes,
    token: Option<TokenCheck>,
    metrics: Arc<Metrics>,
    max_body: usize,
}

/// Runs the service until Ctrl-C, SIGTERM, or a journal failure it cannot recover from.
pub fn run(options: ServeOptions) -> Result<(), ServeError> {
    if !options.listen.ip().is_loopback() && options.token.is_none() {
        return Err(ServeError::Token(format!(
            "listening on {}, beyond loopback, needs an API token: --token-file FILE, or the \
             environment variable {}",
            options.listen,
            super::token::TOKEN_ENV
        )));
    }
    let metrics = Arc::new(Metrics::default());
    let clock = Instant::now();
    let controller = spawn(
        options.spec.clone(),
        options.journal.clone(),
        options.max_sessions,
        metrics.clone(),
    )?;
    let info = controller.info.clone();
    if controller.restored > 0 {
        eprintln!(
            "restored {} journaled decisions from {} in {:.2} s",
            controller.restored,
            options.journal.display(),
            clock.elapsed().as_secs_f64()
        );
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|e| ServeError::Runtime(format!("cannot start the async runtime: {e}")))?;
    let info_json = serde_json::to_vec(info.as_ref())
        .map_err(|e| ServeError::Runtime(e.to_string()))?
        .into();
    let ControllerThread {
        jobs,
        stopped,
        thread,
        history,
        ..
    } = controller;
    runtime.block_on(async move {
        let listen = |e: std::io::Error| ServeError::Listen {
            addr: options.listen.to_string(),
            message: e.to_string(),
        };
        let listener = tokio::net::TcpListener::bind(options.listen)
            .await
            .map_err(listen)?;
        let address = listener.local_addr().map_err(listen)?;
        let app = Arc::new(App {
            jobs,
            info: info.clone(),
            history,
            info_json,
            token: options.token.as_deref().map(TokenCheck::new),
            metrics,
            max_body: options.max_body,
        });
        let router = Router::new()
            .route("/decide", post(decide))
            .route("/health", get(health))
            .route("/model", get(model))
            .route("/metrics", get(metrics_text))
            .route("/", get(page))
            .route("/history", get(history_json))
            .fallback(not_found)
            .with_state(app);
        println!(
            "serving {} ({}) on http://{address}{}",
            info.controller,
            info.model,
            if options.token.is_some() {
                ", token required"
            } else {
                ""
            }
        );
        let _ = std::io::stdout().flush();
        let served = axum::serve(listener, router)
            .with_graceful_shutdown(shutdown(stopped))
            .await
            .map_err(|e| ServeError::Runtime(format!("the HTTP server stopped: {e}")));
        // Every sender is gone with the router: the controller thread ends its last batch.
        let decided = thread
            .join()
            .map_err(|_| ServeError::Runtime("the controller thread panicked".into()))?;
        served.and(decided)
    })
}

/// Resolves on Ctrl-C, SIGTERM, or when the controller thread has stopped.
async fn shutdown(controller_stopped: oneshot::Receiver<()>) {
    let terminate = async {
        #[cfg(unix)]
        if let Ok(mut s) = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        {
            s.recv().await;
            return;
        }
        std::future::pending::<()>().await
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => eprintln!("stopping (Ctrl-C)"),
        _ = terminate => eprintln!("stopping (SIGTERM)"),
        _ = controller_stopped => eprintln!("stopping: the controller thread has stopped"),
    }
}

/// `POST /decide`.
async fn decide(State(app): State<Arc<App>>, request: Request) -> Response {
    match decide_answer(&app, request).await {
        Ok(body) => json(StatusCode::OK, body),
        Err(e) => {
            app.metrics.failed(e.status.as_u16());
            eprintln!("POST /decide: {} {}", e.status.as_u16(), e.message);
            error(e)
        }
    }
}

/// 401 unless the request carries the API token, where the service has one.
fn authorize(app: &App, headers: &HeaderMap) -> Result<(), ApiError> {
    let Some(token) = &app.token else {
        return Ok(());
    };
    let given = headers.get(header::AUTHORIZATION);
    if token.accepts(given.map(|v| v.as_bytes())) {
        Ok(())
    } else {
        Err(ApiError::new(
            StatusCode::UNAUTHORIZED,
            "a valid API token is required: send the header `Authorization: Bearer <token>`",
        ))
    }
}

async fn decide_answer(app: &App, request: Request) -> Result<Vec<u8>, ApiError> {
    authorize(app, request.headers())?;
    let body = to_bytes(request.into_body(), app.max_body)
        .await
        .map_err(|e| body_error(e, app.max_body))?;
    let parsed: DecideRequest = serde_json::from_slice(&body).map_err(|e| {
        let text = String::from_utf8_lossy(&body);
        let hint = if ["NaN", "Infinity"].iter().any(|t| text.contains(t)) {
            "; JSON has no NaN or Infinity: send null for a missing measurement (it is refused \
             by name)"
        } else {
            ""
        };
        ApiError::new(
            StatusCode::BAD_REQUEST,
            format!("the body is not a decision request: {e}{hint}"),
        )
    })?;
    let checked = check(&parsed, &app.info)?;
    let (reply, answer) = oneshot::channel();
    let stopped = || {
        ApiError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "the controller thread has stopped; the service is shutting down",
        )
    };
    app.jobs
        .send(Job {
            request: parsed,
            checked,
            reply,
        })
        .await
        .map_err(|_| stopped())?;
    let response = answer.await.map_err(|_| stopped())??;
    serde_json::to_vec(&response)
        .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))
}

/// 413 for a body over the limit, 400 for one that could not be read.
fn body_error(e: axum::Error, limit: usize) -> ApiError {
    let inner = e.into_inner();
    let mut source: Option<&(dyn std::error::Error + 'static)> = Some(inner.as_ref());
    while let Some(s) = source {
        if s.is::<http_body_util::LengthLimitError>() {
            return ApiError::new(
                StatusCode::PAYLOAD_TOO_LARGE,
                format!("the body is larger than {limit} bytes (--max-body)"),
            );
        }
        source = s.source();
    }
    ApiError::new(
        StatusCode::BAD_REQUEST,
        format!("the body could not be read: {inner}"),
    )
}

/// `GET /health`: 200 while the controller thread runs.
async fn health(State(app): State<Arc<App>>) -> Response {
    if app.jobs.is_closed() {
        return json(
            StatusCode::SERVICE_UNAVAILABLE,
            br#"{"status":"stopped"}"#.to_vec(),
        );
    }
    json(StatusCode::OK, br#"{"status":"ok"}"#.to_vec())
}

/// `GET /model`: what is served and what a request must hold.
async fn model(State(app): State<Arc<App>>) -> Response {
    json(StatusCode::OK, app.info_json.to_vec())
}

/// `GET /metrics`: the Prometheus text format.
async fn metrics_text(State(app): State<Arc<App>>) -> Response {
    (
        StatusCode::OK,
        [(header::CONTENT_TYPE, "text/plain; version=0.0.4")],
        app.metrics.render(),
    )
        .into_response()
}

/// The live page: static HTML that draws `GET /history` (it holds no data itself).
const PAGE: &str = include_str!("page.html");

/// `GET /`: the live page.
async fn page() -> Response {
    (
        StatusCode::OK,
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        PAGE,
    )
        .into_response()
}

/// Days of history `GET /history` returns when the query names none.
const DEFAULT_HISTORY_DAYS: f64 = 2.0;

/// `GET /history?session=NAME&days=D`: the session's last `D` days of decisions (at most
/// [`MAX_HISTORY_DAYS`]) and its current plan; the token is required as for `/decide`.
async fn history_json(State(app): State<Arc<App>>, request: Request) -> Response {
    match history_answer(&app, &request) {
        Ok(body) => json(StatusCode::OK, body),
        Err(e) => error(e),
    }
}

fn history_answer(app: &App, request: &Request) -> Result<Vec<u8>, ApiError> {
    authorize(app, request.headers())?;
    let query = HistoryQuery::parse(request.uri().query().unwrap_or(""))?;
    let steps = steps_in_days(query.days, app.info.sample_period_s);
    let snapshot = app.history.snapshot(query.session.as_deref(), steps);
    serde_json::to_vec(&snapshot)
        .map_err(|e| ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))
}

/// The query of `GET /history`.
#[derive(Debug, PartialEq)]
struct HistoryQuery {
    session: Option<String>,
    days: f64,
}

impl HistoryQuery {
    /// `session=NAME&days=D`, both optional; 400 for anything else.
    fn parse(query: &str) -> Result<HistoryQuery, ApiError> {
        let bad = |m: String| ApiError::new(StatusCode::BAD_REQUEST, m);
        let mut parsed = HistoryQuery {
            session: None,
            days: DEFAULT_HISTORY_DAYS,
        };
        for pair in query.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
            let value = percent_decode(value)
                .ok_or_else(|| bad(format!("{key}: {value:?} is not percent-encoded UTF-8")))?;
            match key {
                "session" => parsed.session = Some(value),
                "days" => {
                    parsed.days = value
                        .parse::<f64>()
                        .ok()
                        .filter(|d| *d > 0.0 && d.is_finite())
                        .ok_or_else(|| {
                            bad(format!("days={value:?}: give a positive number of days"))
                        })?
                        .min(MAX_HISTORY_DAYS)
                }
                _ => {
                    return Err(bad(format!(
                        "GET /history takes session=NAME and days=D, not {key:?}"
                    )))
                }
            }
        }
        Ok(parsed)
    }
}

/// A URL query value decoded (`+` is a space, `%XX` a byte); `None` if it is not valid.
fn percent_decode(text: &str) -> Option<String> {
    let mut bytes = Vec::with_capacity(text.len());
    let mut rest = text.as_bytes();
    while let Some((&b, tail)) = rest.split_first() {
        rest = tail;
        match b {
            b'+' => bytes.push(b' '),
            b'%' => {
                let hex = rest.get(..2)?;
                let hex = std::str::from_utf8(hex).ok()?;
                bytes.push(u8::from_str_radix(hex, 16).ok()?);
                rest = &rest[2..];
            }
            _ => bytes.push(b),
        }
    }
    String::from_utf8(bytes).ok()
}

async fn not_found(request: Request) -> Response {
    error(ApiError::new(
        StatusCode::NOT_FOUND,
        format!(
            "no {} {}: the service answers POST /decide, GET /model, GET /health, GET /metrics, \
             GET /history and GET / (the live page)",
            request.method(),
            request.uri().path()
        ),
    ))
}

fn json(status: StatusCode, body: Vec<u8>) -> Response {
    (status, [(header::CONTENT_TYPE, "application/json")], body).into_response()
}

fn error(e: ApiError) -> Response {
    let body = serde_json::to_vec(&ErrorBody { error: e.message })
        .unwrap_or_else(|_| br#"{"error":"unprintable error"}"#.to_vec());
    let mut response = json(e.status, body);
    if e.status == StatusCode::UNAUTHORIZED {
        response.headers_mut().insert(
            header::WWW_AUTHENTICATE,
            header::HeaderValue::from_static("Bearer"),
        );
    }
    response
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_history_query_names_a_session_and_a_bounded_number_of_days() {
        let q = HistoryQuery::parse("session=house%201&days=3").unwrap();
        assert_eq!(q.session.as_deref(), Some("house 1"));
        assert_eq!(q.days, 3.0);
        let q = HistoryQuery::parse("").unwrap();
        assert_eq!((q.session, q.days), (None, DEFAULT_HISTORY_DAYS));
        assert_eq!(
            HistoryQuery::parse("days=365").unwrap().days,
            MAX_HISTORY_DAYS
        );
        for bad in ["days=-1", "days=NaN", "days=x", "step=3", "session=%zz"] {
            let e = HistoryQuery::parse(bad).unwrap_err();
            assert_eq!(e.status, StatusCode::BAD_REQUEST, "{bad}: {}", e.message);
        }
    }

    #[test]
    fn percent_decoding_refuses_what_is_not_utf8() {
        assert_eq!(percent_decode("a+b%2Fc").as_deref(), Some("a b/c"));
        assert_eq!(percent_decode("%C3%A9").as_deref(), Some("é"));
        assert_eq!(percent_decode("%ff"), None);
        assert_eq!(percent_decode("%4"), None);
    }
}
