//! Runs: `POST /runs` (submit), `GET /runs`, `GET /runs/{id}` (the record),
//! `POST /runs/{id}/cancel`, `POST /runs/{id}/rerun`, `GET /runs/{id}/comparison` and
//! `GET /runs/{id}/workflow`. Their events and meshes are `events` and `downloads`.

use std::sync::Arc;

use axum::Extension;
use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use meshflow_api::engine::{Comparison, RerunRequest, RunSubmitted, RunSummary};
use serde_json::{Value, json};

use super::error::{ApiError, ApiResult, not_found, rejected};
use crate::engine::Engine;
use crate::limits::CANCEL_WAIT;
use crate::record::RunRecord;
use crate::run::Run;
use crate::users::User;

/// `POST /runs` (and `POST /workflows/validate`) take `{"workflow": W, "input"?: URL}` or a
/// bare workflow `W`.
pub fn read_submission(body: &[u8]) -> ApiResult<(Value, Option<String>)> {
    let request: Value = serde_json::from_slice(body)
        .map_err(|e| ApiError::bad_request("bad-json", format!("the request is not JSON: {e}")))?;
    let Some(workflow) = request.get("workflow") else {
        return Ok((request, None));
    };
    let input = match request.get("input") {
        None | Some(Value::Null) => None,
        Some(Value::String(url)) => Some(url.clone()),
        Some(_) => {
            return Err(ApiError::bad_request("invalid-workflow", "input: must be a URL string"));
        }
    };
    Ok((workflow.clone(), input))
}

/// The run `id` if `user` may see it (theirs, or any for an admin), or 404 as if it did not
/// exist.
pub fn find(engine: &Engine, id: &str, user: &User) -> ApiResult<Arc<Run>> {
    engine.run(id).filter(|run| user.may_see(&run.user)).ok_or_else(|| not_found("run", id))
}

pub async fn submit(
    State(engine): State<Arc<Engine>>,
    Extension(user): Extension<User>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<RunSubmitted>)> {
    let (workflow, input) = read_submission(&body.map_err(rejected)?)?;
    let run = engine.submit(workflow, input, &user.name).await?;
    Ok((StatusCode::ACCEPTED, Json(RunSubmitted { id: run.id.clone(), status: run.status() })))
}

/// `POST /runs/{id}/rerun`: the run's workflow again, every task pinned to its recorded
/// plugin digest and resolved parameters (`{"unpinned": true}`: today's plugins), on the
/// recorded input or `{"input": URL}`. `GET /runs/{new}/comparison` says how it compares.
pub async fn rerun(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Extension(user): Extension<User>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<RunSubmitted>)> {
    let body = body.map_err(rejected)?;
    let request: RerunRequest = if body.is_empty() {
        RerunRequest::default()
    } else {
        serde_json::from_slice(&body)
            .map_err(|e| ApiError::bad_request("bad-json", e.to_string()))?
    };
    let original = find(&engine, &id, &user)?;
    let run = engine.rerun(&original, request, &user.name).await?;
    Ok((StatusCode::ACCEPTED, Json(RunSubmitted { id: run.id.clone(), status: run.status() })))
}

/// `GET /runs/{id}/comparison`: a finished re-run against the run it re-ran: identical, or
/// the first step where they differ.
pub async fn comparison(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Extension(user): Extension<User>,
) -> ApiResult<Json<Comparison>> {
    let record = find(&engine, &id, &user)?.record();
    let Some(original_id) = record.rerun_of.clone() else {
        let message = format!("run {id} is not a re-run");
        return Err(ApiError::new(StatusCode::NOT_FOUND, "not-a-rerun", message));
    };
    if !record.status.is_final() {
        return Err(ApiError::conflict("not-finished", format!("run {id} has not finished")));
    }
    let original = find(&engine, &original_id, &user)?;
    Ok(Json(crate::rerun::compare(&original.record(), &record)))
}

/// `POST /runs/{id}/cancel`: the run stops at once (a step running on a host is abandoned)
/// and its host sessions are deleted; the answer has its final status.
pub async fn cancel(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Extension(user): Extension<User>,
) -> ApiResult<(StatusCode, Json<RunSummary>)> {
    let run = find(&engine, &id, &user)?;
    if run.is_finished() {
        let message = format!("run {id} has ended already ({:?})", run.status());
        return Err(ApiError::conflict("finished", message));
    }
    run.cancel();
    ended(&run).await;
    Ok((StatusCode::ACCEPTED, Json(summary(run.record()))))
}

/// Waits (at most [`CANCEL_WAIT`]) for a cancelled run's driver to end it, so the answer
/// carries the final status (`cancelled`, or whatever it reached first), not `running`.
pub(crate) async fn ended(run: &Run) {
    let deadline = tokio::time::Instant::now() + CANCEL_WAIT;
    while !run.is_finished() && tokio::time::Instant::now() < deadline {
        tokio::time::sleep(std::time::Duration::from_millis(5)).await;
    }
}

/// `GET /runs`: the user's runs (an admin's: everyone's), oldest first.
pub async fn list(
    State(engine): State<Arc<Engine>>,
    Extension(user): Extension<User>,
) -> Json<Vec<RunSummary>> {
    let runs = engine.runs().into_iter().filter(|run| user.may_see(&run.user));
    Json(runs.map(|run| summary(run.record())).collect())
}

fn summary(record: RunRecord) -> RunSummary {
    RunSummary { id: record.id, status: record.status, steps: record.steps.len() }
}

pub async fn status(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Extension(user): Extension<User>,
) -> ApiResult<Json<Value>> {
    Ok(Json(json!(find(&engine, &id, &user)?.record())))
}

/// `GET /runs/{id}/workflow`: what was submitted, as `POST /runs` takes it (to run again).
pub async fn workflow(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Extension(user): Extension<User>,
) -> ApiResult<Json<Value>> {
    let run = find(&engine, &id, &user)?;
    Ok(Json(json!({"workflow": run.workflow(), "input": run.input})))
}
