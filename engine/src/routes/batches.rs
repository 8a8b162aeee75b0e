//! `POST /batches` (one workflow over many inputs) and `GET /batches/{id}`.

use std::sync::Arc;

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, StatusCode};
use meshflow_api::engine::{BatchStatus, SubmitBatch};

use super::client_of;
use super::error::{ApiError, ApiResult, not_found, rejected};
use crate::engine::Engine;

/// `POST /batches`: `{"workflow", "inputs": [URL, …]}` → 202 with the batch as it starts.
pub async fn submit(
    State(engine): State<Arc<Engine>>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<BatchStatus>)> {
    let body = body.map_err(rejected)?;
    let request: SubmitBatch = serde_json::from_slice(&body)
        .map_err(|e| ApiError::bad_request("bad-json", e.to_string()))?;
    let batch = engine.submit_batch(request, &client_of(&headers)).await?;
    Ok((StatusCode::ACCEPTED, Json(batch)))
}

/// `GET /batches/{id}`: each input's run and the summary rows so far.
pub async fn status(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
) -> ApiResult<Json<BatchStatus>> {
    let batch = engine.batch(&id).await?;
    Ok(Json(batch.ok_or_else(|| not_found("batch", &id))?))
}
