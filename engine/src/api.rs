//! The engine HTTP API (DESIGN §6): hosts, catalogue, inputs, runs with their status,
//! progress events and result, and the web UI. Errors are `{"error": {"code", "message"}}`.

use std::convert::Infallible;
use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::extract::rejection::BytesRejection;
use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use futures_util::{Stream, StreamExt, stream};
use serde::Deserialize;
use serde_json::{Value as Json_, json};
use tokio_stream::wrappers::BroadcastStream;

use crate::downloads::{DownloadError, Which};
use crate::inputs::InputError;
use crate::limits::{MAX_PLUGIN_FORWARD_BYTES, MAX_REGISTER_BYTES, MAX_SUBMIT_BYTES, RETRY_AFTER};
use crate::record::Status;
use crate::registry::RegisterError;
use crate::{Engine, SubmitError};
use meshflow_api::engine::{
    BatchStatus, Comparison, HostInfo, InputUploaded, RegisterHost, RerunRequest, RunSubmitted,
    RunSummary, ServiceOffer, SubmitBatch,
};
use meshflow_api::host::MeshFileFormat;

pub fn router(engine: Arc<Engine>) -> Router {
    Router::new()
        .route("/", get(crate::ui::index))
        .route("/assets/{file}", get(crate::ui::asset))
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
        .route("/runs/{id}/rerun", post(rerun_run))
        .route("/batches", post(submit_batch).layer(DefaultBodyLimit::max(MAX_SUBMIT_BYTES)))
        .route("/batches/{id}", get(batch_status))
        .route("/runs/{id}/comparison", get(run_comparison))
        .route("/runs/{id}/events", get(run_events))
        .route("/runs/{id}/workflow", get(run_workflow))
        .route("/runs/{id}/result", get(run_result))
        .route("/runs/{id}/input", get(run_input))
        .route("/runs/{id}/steps/{index}/output", get(step_output))
        .route(
            "/workflows/validate",
            post(validate_workflow).layer(DefaultBodyLimit::max(MAX_SUBMIT_BYTES)),
        )
        .route(
            "/plugins",
            post(forward_plugin).layer(DefaultBodyLimit::max(MAX_PLUGIN_FORWARD_BYTES)),
        )
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

/// `POST /runs` (and `POST /workflows/validate`) take `{"workflow": W, "input"?: URL}` or a
/// bare workflow `W`.
fn read_submission(body: &[u8]) -> ApiResult<(Json_, Option<String>)> {
    let request: Json_ = serde_json::from_slice(body).map_err(|e| {
        ApiError(StatusCode::BAD_REQUEST, "bad-json", format!("the request is not JSON: {e}"))
    })?;
    let Some(workflow) = request.get("workflow") else {
        return Ok((request, None));
    };
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
    Ok((workflow.clone(), input))
}

fn invalid(error: crate::workflow::WorkflowError) -> ApiError {
    ApiError(StatusCode::BAD_REQUEST, "invalid-workflow", error.to_string())
}

async fn submit(
    State(engine): State<Arc<Engine>>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<RunSubmitted>)> {
    let (workflow, input) = read_submission(&body.map_err(body_refused)?)?;
    let run = engine.submit(workflow, input, &client_of(&headers)).await.map_err(refusal)?;
    Ok((StatusCode::ACCEPTED, Json(RunSubmitted { id: run.id.clone(), status: run.status() })))
}

/// Why a run was not started, as the API says it.
fn refusal(e: SubmitError) -> ApiError {
    match e {
        SubmitError::Invalid(error) => invalid(error),
        SubmitError::NoInput => ApiError(StatusCode::BAD_REQUEST, "no-input", e.to_string()),
        SubmitError::Busy(_) => {
            ApiError(StatusCode::TOO_MANY_REQUESTS, "too-many-runs", e.to_string())
        }
        SubmitError::InputRefused(_) => {
            ApiError(StatusCode::BAD_REQUEST, "input-not-allowed", e.to_string())
        }
        SubmitError::Store(error) => internal(error),
        SubmitError::NotRerunnable(_) => {
            ApiError(StatusCode::CONFLICT, "not-rerunnable", e.to_string())
        }
    }
}

/// `POST /batches`: `{"workflow", "inputs": [URL, …]}` → 202 with the batch as it starts.
async fn submit_batch(
    State(engine): State<Arc<Engine>>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<BatchStatus>)> {
    let body = body.map_err(body_refused)?;
    let request: SubmitBatch = serde_json::from_slice(&body)
        .map_err(|e| ApiError(StatusCode::BAD_REQUEST, "bad-json", e.to_string()))?;
    let batch = engine.submit_batch(request, &client_of(&headers)).await.map_err(refusal)?;
    Ok((StatusCode::ACCEPTED, Json(batch)))
}

/// `GET /batches/{id}`: each input's run and the summary rows so far.
async fn batch_status(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
) -> ApiResult<Json<BatchStatus>> {
    let batch = engine.batch(&id).await.map_err(refusal)?;
    Ok(Json(batch.ok_or_else(|| not_found("batch", &id))?))
}

/// `POST /runs/{id}/rerun`: the run's workflow again, every task pinned to its recorded
/// plugin digest and resolved parameters (`{"unpinned": true}`: today's plugins), on the
/// recorded input or `{"input": URL}`. `GET /runs/{new}/comparison` says how it compares.
async fn rerun_run(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<RunSubmitted>)> {
    let body = body.map_err(body_refused)?;
    let request: RerunRequest = if body.is_empty() {
        RerunRequest::default()
    } else {
        serde_json::from_slice(&body)
            .map_err(|e| ApiError(StatusCode::BAD_REQUEST, "bad-json", e.to_string()))?
    };
    let original = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    let run = engine.rerun(&original, request, &client_of(&headers)).await.map_err(refusal)?;
    Ok((StatusCode::ACCEPTED, Json(RunSubmitted { id: run.id.clone(), status: run.status() })))
}

/// `GET /runs/{id}/comparison`: a finished re-run against the run it re-ran: identical, or
/// the first step where they differ.
async fn run_comparison(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
) -> ApiResult<Json<Comparison>> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    let record = run.record();
    let Some(original_id) = record.rerun_of.clone() else {
        let message = format!("run {id} is not a re-run");
        return Err(ApiError(StatusCode::NOT_FOUND, "not-a-rerun", message));
    };
    if !record.status.is_final() {
        let message = format!("run {id} has not finished");
        return Err(ApiError(StatusCode::CONFLICT, "not-finished", message));
    }
    let original = engine.run(&original_id).ok_or_else(|| not_found("run", &original_id))?;
    Ok(Json(crate::rerun::compare(&original.record(), &record)))
}

/// `POST /workflows/validate`: the checks of `POST /runs` without the run, so the workbench
/// validates as the user types with the engine's own rules. 200 `{"valid": true}` or the
/// same 400 `invalid-workflow` (with the step path) that submitting would give.
async fn validate_workflow(
    State(engine): State<Arc<Engine>>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<Json<Json_>> {
    let (workflow, _) = read_submission(&body.map_err(body_refused)?)?;
    engine.check_workflow(&workflow).map_err(invalid)?;
    Ok(Json(json!({"valid": true})))
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

/// `GET /runs/{id}/workflow`: what was submitted, as `POST /runs` takes it (to run again).
async fn run_workflow(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
) -> ApiResult<Json<Json_>> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    Ok(Json(json!({"workflow": run.workflow, "input": run.input})))
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

#[derive(Deserialize)]
struct FormatQuery {
    format: Option<String>,
}

/// `GET /runs/{id}/result[?format=]`: the final mesh, fetched from its host with the cluster
/// token (a user holds none, so a redirect would not do), served only if it is the mesh the
/// record names (its content hash checked), in the asked format (`.mfm` by default).
async fn run_result(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Query(query): Query<FormatQuery>,
) -> ApiResult<Response> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    let record = run.record();
    // `.mfm` unless asked otherwise: the CLI decodes it (and checks it once more).
    mesh_download(&engine, &record, Which::Result, query.format).await
}

/// `GET /runs/{id}/input?format=`: the run's input, if it was uploaded to this engine.
async fn run_input(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Query(query): Query<FormatQuery>,
) -> ApiResult<Response> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    mesh_download(&engine, &run.record(), Which::Input, query.format).await
}

/// `GET /runs/{id}/steps/{index}/output?format=`: a filter step's output, while its host
/// still holds it.
async fn step_output(
    State(engine): State<Arc<Engine>>,
    Path((id, index)): Path<(String, usize)>,
    Query(query): Query<FormatQuery>,
) -> ApiResult<Response> {
    let run = engine.run(&id).ok_or_else(|| not_found("run", &id))?;
    mesh_download(&engine, &run.record(), Which::Step(index), query.format).await
}

async fn mesh_download(
    engine: &Engine,
    record: &crate::record::RunRecord,
    which: Which,
    format: Option<String>,
) -> ApiResult<Response> {
    let name = format.unwrap_or_else(|| "mfm".into());
    let format = MeshFileFormat::parse(&name)
        .ok_or_else(|| download_error(DownloadError::BadFormat(name.chars().take(16).collect())))?;
    let download = engine.download(record, which, format).await.map_err(download_error)?;
    let headers = [
        (header::CONTENT_TYPE, "application/octet-stream".to_owned()),
        (header::CONTENT_DISPOSITION, format!("attachment; filename=\"{}\"", download.file_name)),
    ];
    Ok((headers, download.bytes).into_response())
}

fn download_error(error: DownloadError) -> ApiError {
    use DownloadError as E;
    let (status, code) = match &error {
        E::BadFormat(_) => (StatusCode::BAD_REQUEST, "bad-format"),
        E::NotFinished(_) => (StatusCode::CONFLICT, "not-finished"),
        E::NoResult { .. } => (StatusCode::CONFLICT, "run-failed"),
        E::NoStep { .. } | E::NotAFilter { .. } | E::NoInput(_) => {
            (StatusCode::NOT_FOUND, "not-found")
        }
        E::Gone { .. } => (StatusCode::GONE, "gone"),
        E::Fetch { .. } | E::UnknownHost(_) | E::Corrupt { .. } => {
            (StatusCode::BAD_GATEWAY, "download-failed")
        }
        E::NoHost => (StatusCode::SERVICE_UNAVAILABLE, "no-host"),
        E::HashMismatch { .. } => (StatusCode::BAD_GATEWAY, "hash-mismatch"),
    };
    ApiError(status, code, error.to_string())
}

#[derive(Deserialize)]
struct PluginQuery {
    host: Option<String>,
    /// Passed on to the host: serve the plugin's services in place of another plugin's.
    #[serde(default)]
    replace: bool,
}

/// The header carrying a host's upload token through `POST /plugins` (the `Authorization`
/// header is the engine's own API token).
const UPLOAD_TOKEN_HEADER: &str = "x-upload-token";

/// `POST /plugins?host=<registered host>`: forwards a `.wasm` to that host with the upload
/// token from [`UPLOAD_TOKEN_HEADER`] (never logged), for the browser, which cannot call
/// hosts of other origins. Answers what the host answered.
async fn forward_plugin(
    State(engine): State<Arc<Engine>>,
    Query(query): Query<PluginQuery>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<Json_>)> {
    let wasm = body.map_err(body_refused)?;
    let host = query.host.unwrap_or_default();
    // Only registered hosts: the engine must not post to any address a client names.
    if !engine.registry.hosts().iter().any(|h| h.url == host) {
        return Err(ApiError(
            StatusCode::BAD_REQUEST,
            "unknown-host",
            format!("\"{}\" is not a registered host", host.chars().take(200).collect::<String>()),
        ));
    }
    let token = headers.get(UPLOAD_TOKEN_HEADER).and_then(|v| v.to_str().ok());
    let uploaded = engine
        .registry
        .client(&host)
        .upload_plugin(wasm.to_vec(), token, query.replace)
        .await
        .map_err(|e| {
            match e {
                // The host's 401 is 403 here: a 401 from the engine means its own API token.
                meshflow_api::ClientError::Refused { status: 401, code, message, .. } => ApiError(
                    StatusCode::FORBIDDEN,
                    "host-unauthorized",
                    format!("{host} refused the upload token ({code}: {message})"),
                ),
                meshflow_api::ClientError::Refused { status, code, message, .. } => {
                    let status = StatusCode::from_u16(status).unwrap_or(StatusCode::BAD_GATEWAY);
                    ApiError(status, "host-refused", format!("{host} answered {code}: {message}"))
                }
                other => ApiError(StatusCode::BAD_GATEWAY, "host-failed", other.to_string()),
            }
        })?;
    // The catalogue learns the new services now rather than at the next poll.
    if let Some(entry) = engine.registry.hosts().iter().find(|h| h.url == host) {
        entry.refresh().await;
    }
    Ok((StatusCode::CREATED, Json(json!(uploaded))))
}
