//! The HTTP side of the service (axum on tokio): the routes, the token, the body limit,
//! parsing and checking requests, and starting and stopping the whole service. Deciding is
//! the controller thread's ([`actor`](super::actor)); this side only talks to it.

use super::actor::{spawn, ControllerThread, Job};
use super::api::{ApiError, DecideRequest, ErrorBody, ModelInfo};
use super::metrics::Metrics;
use super::token::TokenCheck;
use super::validate::check;
use super::{ServeError, ServeOptions};
use axum::body::{to_bytes, Bytes};
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
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

async fn decide_answer(app: &App, request: Request) -> Result<Vec<u8>, ApiError> {
    if let Some(token) = &app.token {
        let given = request.headers().get(header::AUTHORIZATION);
        if !token.accepts(given.map(|v| v.as_bytes())) {
            return Err(ApiError::new(
                StatusCode::UNAUTHORIZED,
                "a valid API token is required: send the header `Authorization: Bearer <token>`",
            ));
        }
    }
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

async fn not_found(request: Request) -> Response {
    error(ApiError::new(
        StatusCode::NOT_FOUND,
        format!(
            "no {} {}: the service answers POST /decide, GET /model, GET /health and GET /metrics",
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
