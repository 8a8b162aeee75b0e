//! The engine HTTP API (DESIGN §6): hosts, catalogue, inputs, runs with their status,
//! progress events and result, and the web UI. Errors are `{"error": {"code", "message"}}`.

use std::convert::Infallible;
use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{StatusCode, header};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use futures_util::{Stream, StreamExt, stream};
use serde::Deserialize;
use serde_json::{Value as Json_, json};
use tokio_stream::wrappers::BroadcastStream;

use crate::record::Status;
use crate::workflow::Workflow;
use crate::{Engine, SubmitError};
use meshflow_api::engine::{
    HostInfo, InputUploaded, RegisterHost, RunSubmitted, RunSummary, ServiceOffer,
};
use meshflow_api::fetch_rules::quoted;

/// The largest mesh accepted by `POST /inputs`.
pub const MAX_INPUT_BYTES: usize = 4 << 30;

pub fn router(engine: Arc<Engine>) -> Router {
    Router::new()
        .route("/", get(|| async { Html(crate::ui::PAGE) }))
        .route("/health", get(|| async { Json(json!({"status": "ok"})) }))
        .route("/hosts", get(list_hosts).post(register_host))
        .route("/services", get(services))
        .route("/inputs", post(upload_input).layer(DefaultBodyLimit::max(MAX_INPUT_BYTES)))
        .route("/inputs/{file}", get(download_input))
        .route("/runs", get(list_runs).post(submit))
        .route("/runs/{id}", get(run_status))
        .route("/runs/{id}/events", get(run_events))
        .route("/runs/{id}/result", get(run_result))
        .layer(axum::middleware::from_fn_with_state(engine.clone(), crate::auth::check))
        .with_state(engine)
}

struct ApiError(StatusCode, &'static str, String);

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = json!({"error": {"code": self.1, "message": self.2}});
        (self.0, Json(body)).into_response()
    }
}

type ApiResult<T> = Result<T, ApiError>;

fn not_found(what: &str, id: &str) -> ApiError {
    ApiError(StatusCode::NOT_FOUND, "not-found", format!("no {what} \"{id}\""))
}

async fn register_host(
    State(engine): State<Arc<Engine>>,
    body: Bytes,
) -> ApiResult<(StatusCode, Json<HostInfo>)> {
    let registration: RegisterHost = serde_json::from_slice(&body).map_err(|e| {
        ApiError(StatusCode::BAD_REQUEST, "bad-request", format!("expected {{\"url\": ...}}: {e}"))
    })?;
    let host = engine
        .registry
        .register(&registration.url)
        .await
        .map_err(|e| ApiError(StatusCode::BAD_REQUEST, "bad-url", e.to_string()))?;
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
    body: Bytes,
) -> ApiResult<(StatusCode, Json<InputUploaded>)> {
    let name = query.name.ok_or_else(|| {
        ApiError(
            StatusCode::BAD_REQUEST,
            "bad-request",
            "give the file name, e.g. POST /inputs?name=bunny.ply".into(),
        )
    })?;
    let url = engine
        .put_input(&name, &body)
        .await
        .map_err(|message| ApiError(StatusCode::BAD_REQUEST, "bad-input", message))?;
    Ok((StatusCode::CREATED, Json(InputUploaded { url, bytes: body.len() as u64 })))
}

async fn download_input(
    State(engine): State<Arc<Engine>>,
    Path(file): Path<String>,
) -> ApiResult<Response> {
    let path = engine.inputs.path(&file).ok_or_else(|| not_found("input", &file))?;
    let bytes = tokio::fs::read(&path)
        .await
        .map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, "io", e.to_string()))?;
    Ok(([(header::CONTENT_TYPE, "application/octet-stream")], Body::from(bytes)).into_response())
}

/// `POST /runs` takes `{"workflow": W, "input"?: URL}` or a bare workflow `W`.
async fn submit(
    State(engine): State<Arc<Engine>>,
    body: Bytes,
) -> ApiResult<(StatusCode, Json<RunSubmitted>)> {
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
    let invalid = |message: String| ApiError(StatusCode::BAD_REQUEST, "invalid-workflow", message);
    let workflow = Workflow::from_json(workflow).map_err(|e| invalid(e.to_string()))?;
    let run = engine.submit(workflow, input).map_err(|e| match e {
        SubmitError::Invalid(error) => invalid(error.to_string()),
        SubmitError::NoInput => ApiError(StatusCode::BAD_REQUEST, "no-input", e.to_string()),
        SubmitError::InputRefused(_) => {
            ApiError(StatusCode::BAD_REQUEST, "input-not-allowed", e.to_string())
        }
    })?;
    Ok((
        StatusCode::ACCEPTED,
        Json(RunSubmitted { id: run.id.clone(), status: run.record().status }),
    ))
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
    let finished = matches!(snapshot.status, Status::Completed | Status::Failed);
    let first = stream::once(async move {
        Ok(SseEvent::default().event("record").json_data(&snapshot).expect("a record is JSON"))
    });
    let changes = live
        .take_while(move |_| std::future::ready(!finished))
        .filter_map(|event| std::future::ready(event.ok()))
        .scan(false, |ended, event| {
            // Stop after the event that finishes the run.
            if *ended {
                return std::future::ready(None);
            }
            *ended = event.kind == "status"
                && matches!(event.data["status"].as_str(), Some("completed" | "failed"));
            let sse = SseEvent::default().event(event.kind).json_data(&event.data);
            std::future::ready(Some(sse.map_err(|_| ()).ok()))
        })
        .filter_map(|event| std::future::ready(event.map(Ok)));
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
            let unavailable =
                |message: String| ApiError(StatusCode::BAD_GATEWAY, "result-unavailable", message);
            let client = engine.registry.blob_client(&result.url).ok_or_else(|| {
                unavailable(format!("{}: not on a registered host", quoted(&result.url)))
            })?;
            let bytes =
                client.download(&result.url).await.map_err(|e| unavailable(e.to_string()))?;
            let headers = [(header::CONTENT_TYPE, "application/octet-stream")];
            Ok((headers, Body::from(bytes)).into_response())
        }
        (Status::Failed, _) => Err(ApiError(
            StatusCode::CONFLICT,
            "run-failed",
            record.error.unwrap_or_else(|| "the run failed".into()),
        )),
        _ => {
            Err(ApiError(StatusCode::CONFLICT, "not-finished", format!("run {id} is still going")))
        }
    }
}
