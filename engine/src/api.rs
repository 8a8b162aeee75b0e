//! The engine HTTP API (DESIGN §6): hosts, catalogue, inputs, runs with their status,
//! progress events and result, and the web UI. Errors are `{"error": {"code", "message"}}`.

use std::convert::Infallible;
use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::extract::rejection::BytesRejection;
use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use futures_util::{Stream, StreamExt, stream};
use serde::Deserialize;
use serde_json::{Value as Json_, json};
use tokio_stream::wrappers::BroadcastStream;

use crate::inputs::InputError;
use crate::limits::{MAX_REGISTER_BYTES, MAX_SUBMIT_BYTES, RETRY_AFTER};
use crate::record::Status;
use crate::registry::RegisterError;
use crate::{Engine, SubmitError};
use meshflow_api::engine::{
    HostInfo, InputUploaded, RegisterHost, RunSubmitted, RunSummary, ServiceOffer,
};
use meshflow_api::fetch_rules::quoted;

pub fn router(engine: Arc<Engine>) -> Router {
    Router::new()
        .route("/", get(|| async { Html(crate::ui::PAGE) }))
        .route("/health", get(|| async { Json(json!({"status": "ok"})) }))
        .route(
            "/hosts",
            get(list_hosts).post(register_host).layer(DefaultBodyLimit::max(MAX_REGISTER_BYTES)),
        )
        .route("/services", get(services))
        // Streamed to disk: the limit is applied while writing.
        .route("/inputs", post(upload_input).layer(DefaultBodyLimit::disable()))
        .route("/inputs/{file}", get(download_input))
        .route("/runs", get(list_runs).post(submit).layer(DefaultBodyLimit::max(MAX_SUBMIT_BYTES)))
        .route("/runs/{id}", get(run_status))
        .route("/runs/{id}/cancel", post(cancel_run))
        .route("/runs/{id}/events", get(run_events))
        .route("/runs/{id}/result", get(run_result))
        .layer(axum::middleware::from_fn_with_state(engine.clone(), crate::auth::check))
        .with_state(engine)
}

struct ApiError(StatusCode, &'static str, String);

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = json!({"error": {"code": self.1, "message": self.2}});
        let mut response = (self.0, Json(body)).into_response();
        if self.0 == StatusCode::TOO_MANY_REQUESTS {
            response.headers_mut().insert(header::RETRY_AFTER, RETRY_AFTER.as_secs().into());
        }
        response
    }
}

/// A body over its route's limit, or one that broke off, as a JSON error.
fn body_refused(rejection: BytesRejection) -> ApiError {
    let status = rejection.status();
    let code = if status == StatusCode::PAYLOAD_TOO_LARGE { "too-large" } else { "bad-body" };
    ApiError(status, code, rejection.body_text())
}

fn internal(error: impl std::fmt::Display) -> ApiError {
    tracing::error!("{error}");
    ApiError(StatusCode::INTERNAL_SERVER_ERROR, "internal", error.to_string())
}

/// Who sends a request, for per-client limits: a digest of its bearer token, or
/// `anonymous` (the token itself is never stored).
fn client_of(headers: &HeaderMap) -> String {
    let token = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    match token {
        Some(token) => format!("token:{}", &blake3::hash(token.as_bytes()).to_hex()[..16]),
        None => "anonymous".to_owned(),
    }
}

type ApiResult<T> = Result<T, ApiError>;

fn not_found(what: &str, id: &str) -> ApiError {
    ApiError(StatusCode::NOT_FOUND, "not-found", format!("no {what} \"{id}\""))
}

async fn register_host(
    State(engine): State<Arc<Engine>>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<HostInfo>)> {
    let body = body.map_err(body_refused)?;
    let registration: RegisterHost = serde_json::from_slice(&body).map_err(|e| {
        ApiError(StatusCode::BAD_REQUEST, "bad-request", format!("expected {{\"url\": ...}}: {e}"))
    })?;
    let host = engine.registry.register(&registration.url).await.map_err(|e| match e {
        RegisterError::BadUrl(_) => ApiError(StatusCode::BAD_REQUEST, "bad-url", e.to_string()),
        RegisterError::Full => ApiError(StatusCode::CONFLICT, "too-many-hosts", e.to_string()),
        RegisterError::Store(error) => internal(error),
    })?;
    Ok((StatusCode::CREATED, Json(host_info(&host))))
}

fn host_info(host: &crate::registry::HostEntry) -> HostInfo {
    let state = host.state();
    HostInfo {
        url: host.url.clone(),
        up: state.up,
        running: state.running,
        assigned: state.assigned,
        last_error: state.last_error.clone(),
        services: state.services.iter().map(|s| s.info.name.clone()).collect(),
        suspect: host.suspicion(),
    }
}

async fn list_hosts(State(engine): State<Arc<Engine>>) -> Json<Vec<HostInfo>> {
    Json(engine.registry.hosts().iter().map(|h| host_info(h)).collect())
}

async fn services(State(engine): State<Arc<Engine>>) -> Json<Vec<ServiceOffer>> {
    Json(engine.registry.catalogue().into_values().collect())
}

#[derive(Deserialize)]
struct InputQuery {
    name: Option<String>,
}

async fn upload_input(
    State(engine): State<Arc<Engine>>,
    Query(query): Query<InputQuery>,
    body: Body,
) -> ApiResult<(StatusCode, Json<InputUploaded>)> {
    let name = query.name.ok_or_else(|| {
        ApiError(
            StatusCode::BAD_REQUEST,
            "bad-request",
            "give the file name, e.g. POST /inputs?name=bunny.ply".into(),
        )
    })?;
    let (url, bytes) =
        engine.put_input(&name, body.into_data_stream()).await.map_err(|e| match e {
            InputError::TooLarge(_) => {
                ApiError(StatusCode::PAYLOAD_TOO_LARGE, "too-large", e.to_string())
            }
            InputError::Io(error) => internal(error),
            _ => ApiError(StatusCode::BAD_REQUEST, "bad-input", e.to_string()),
        })?;
    Ok((StatusCode::CREATED, Json(InputUploaded { url, bytes })))
}

/// Streams a stored input (inputs may be gigabytes: never read whole).
async fn download_input(
    State(engine): State<Arc<Engine>>,
    Path(file): Path<String>,
) -> ApiResult<Response> {
    let path = engine.inputs.path(&file).ok_or_else(|| not_found("input", &file))?;
    let opened = tokio::fs::File::open(&path).await.map_err(internal)?;
    let length = opened.metadata().await.map_err(internal)?.len();
    let body = Body::from_stream(tokio_util::io::ReaderStream::new(opened));
    let headers = [
        (header::CONTENT_TYPE, "application/octet-stream".to_owned()),
        (header::CONTENT_LENGTH, length.to_string()),
    ];
    Ok((headers, body).into_response())
}

/// `POST /runs` takes `{"workflow": W, "input"?: URL}` or a bare workflow `W`.
async fn submit(
    State(engine): State<Arc<Engine>>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<RunSubmitted>)> {
    let body = body.map_err(body_refused)?;
    let request: Json_ = serde_json::from_slice(&body).map_err(|e| {
        ApiError(StatusCode::BAD_REQUEST, "bad-json", format!("the request is not JSON: {e}"))
    })?;
    let (workflow, input) = match request.get("workflow") {
        Some(workflow) => {
            let input = match request.get("input") {
                None | Some(Json_::Null) => None,
                Some(Json_::String(url)) => Some(url.clone()),
                Some(_) => {
                    return Err(ApiError(
                        StatusCode::BAD_REQUEST,
                        "invalid-workflow",
                        "input: must be a URL string".into(),
                    ));
                }
            };
            (workflow, input)
        }
        None => (&request, None),
    };
    let run =
        engine.submit(workflow.clone(), input, &client_of(&headers)).await.map_err(
            |e| match e {
                SubmitError::Invalid(_) => {
                    ApiError(StatusCode::BAD_REQUEST, "invalid-workflow", e.to_string())
                }
                SubmitError::NoInput => {
                    ApiError(StatusCode::BAD_REQUEST, "no-input", e.to_string())
                }
                SubmitError::Busy(_) => {
                    ApiError(StatusCode::TOO_MANY_REQUESTS, "too-many-runs", e.to_string())
                }
                SubmitError::InputRefused(_) => {
                    ApiError(StatusCode::BAD_REQUEST, "input-not-allowed", e.to_string())
                }
                SubmitError::Store(error) => internal(error),
            },
        )?;
    Ok((StatusCode::ACCEPTED, Json(RunSubmitted { id: run.id.clone(), status: run.status() })))
}

/// `POST /runs/{id}/cancel`: the run stops at once (a step running on a host is abandoned)
/// and its host sessions are deleted.
async fn cancel_run(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
) -> ApiResult<(StatusCode, Json<RunSummary>)> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    if run.is_finished() {
        return Err(ApiError(
            StatusCode::CONFLICT,
            "finished",
            format!("run {id} has ended already ({:?})", run.status()),
        ));
    }
    run.cancel();
    let record = run.record();
    let summary = RunSummary { id: record.id, status: record.status, steps: record.steps.len() };
    Ok((StatusCode::ACCEPTED, Json(summary)))
}

async fn list_runs(State(engine): State<Arc<Engine>>) -> Json<Vec<RunSummary>> {
    let summary = |record: crate::record::RunRecord| RunSummary {
        id: record.id,
        status: record.status,
        steps: record.steps.len(),
    };
    Json(engine.runs().iter().map(|run| summary(run.record())).collect())
}

async fn run_status(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
) -> ApiResult<Json<Json_>> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    Ok(Json(json!(run.record())))
}

/// Progress as server-sent events: first the whole record (`record`), then each change
/// (`status`, `broadcast`, `step`, `transfer`, ...); the stream ends with the run.
async fn run_events(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
) -> ApiResult<Sse<impl Stream<Item = Result<SseEvent, Infallible>>>> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    // Subscribe before taking the snapshot, so no change falls between the two.
    let live = BroadcastStream::new(run.subscribe());
    let snapshot = run.record();
    let finished = snapshot.status.is_final();
    let first = stream::once(async move {
        Ok(SseEvent::default().event("record").json_data(&snapshot).expect("a record is JSON"))
    });
    // Each change as it happens, ending after the one that finishes the run (at once for
    // a run that had finished). A subscriber that fell behind gets the whole record again.
    let changes = stream::unfold((live, finished), move |(mut live, ended)| {
        let run = run.clone();
        async move {
            if ended {
                return None;
            }
            let (kind, data) = match live.next().await? {
                Ok(event) => (event.kind, event.data),
                Err(_lagged) => ("record", json!(run.record())),
            };
            let last = match kind {
                "status" => serde_json::from_value::<Status>(data["status"].clone())
                    .is_ok_and(Status::is_final),
                "record" => run.is_finished(),
                _ => false,
            };
            let event = SseEvent::default().event(kind).json_data(&data).expect("events are JSON");
            Some((Ok(event), (live, last)))
        }
    });
    Ok(Sse::new(first.chain(changes)).keep_alive(KeepAlive::default()))
}

/// The final mesh (`.mfm`), fetched from the host holding it with the cluster token (a
/// user holds no cluster token, so a redirect to the host would not do).
async fn run_result(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
) -> ApiResult<Response> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    let record = run.record();
    match (record.status, record.result) {
        (Status::Completed, Some(result)) => {
            // Only from where a host of ours serves the recorded mesh: the record's URL
            // passed the executor's checks, and is checked again here.
            let unavailable =
                |message: String| ApiError(StatusCode::BAD_GATEWAY, "result-unavailable", message);
            let hosts = engine.registry.hosts();
            let served = crate::executor::is_content_hash(&result.hash)
                && hosts
                    .iter()
                    .any(|h| result.url == crate::executor::full_mesh_url(&h.url, &result.hash));
            if !served {
                return Err(ApiError(
                    StatusCode::BAD_GATEWAY,
                    "unverified-result",
                    format!("run {id}: no known host serves its result mesh {}", result.hash),
                ));
            }
            let client = engine.registry.blob_client(&result.url).ok_or_else(|| {
                unavailable(format!("{}: not on a registered host", quoted(&result.url)))
            })?;
            let bytes =
                client.download(&result.url).await.map_err(|e| unavailable(e.to_string()))?;
            let headers = [(header::CONTENT_TYPE, "application/octet-stream")];
            Ok((headers, Body::from(bytes)).into_response())
        }
        (status, _) if status.is_final() => Err(ApiError(
            StatusCode::CONFLICT,
            "run-failed",
            record.error.unwrap_or_else(|| format!("the run ended {status:?} without a result")),
        )),
        _ => {
            Err(ApiError(StatusCode::CONFLICT, "not-finished", format!("run {id} is still going")))
        }
    }
}
