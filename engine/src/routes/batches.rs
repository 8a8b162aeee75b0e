//! `POST /batches` (one workflow over many inputs), `GET /batches/{id}` and
//! `POST /batches/{id}/cancel`.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::{Extension, Json};
use meshflow_api::engine::{BatchStatus, SubmitBatch};

use super::error::{ApiError, ApiResult, not_found, rejected};
use crate::engine::Engine;
use crate::users::User;

/// `POST /batches`: `{"workflow", "inputs": [URL, …]}` → 202 with the batch as it starts.
pub async fn submit(
    State(engine): State<Arc<Engine>>,
    Extension(user): Extension<User>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<BatchStatus>)> {
    let body = body.map_err(rejected)?;
    let request: SubmitBatch = serde_json::from_slice(&body)
        .map_err(|e| ApiError::bad_request("bad-json", e.to_string()))?;
    let batch = engine.submit_batch(request, &user.name).await?;
    Ok((StatusCode::ACCEPTED, Json(batch)))
}

/// `GET /batches/{id}`: each input's run and the summary rows so far (the user's batches
/// only; an admin's: any).
pub async fn status(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Extension(user): Extension<User>,
) -> ApiResult<Json<BatchStatus>> {
    let batch = engine.batch(&id, &user).await?;
    Ok(Json(batch.ok_or_else(|| not_found("batch", &id))?))
}

/// `POST /batches/{id}/cancel`: starts no more of its runs and cancels those going; the
/// batch as it then stands (its inputs not started say `cancelled`).
pub async fn cancel(
    State(engine): State<Arc<Engine>>,
    Path(id): Path<String>,
    Extension(user): Extension<User>,
) -> ApiResult<Json<BatchStatus>> {
    let batch = engine.cancel_batch(&id, &user).await?;
    Ok(Json(batch.ok_or_else(|| not_found("batch", &id))?))
}
