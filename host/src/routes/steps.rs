//! `POST /sessions/{id}/update` and `POST /sessions/{id}/run`: adapters over `steps.rs`.

use std::sync::Arc;

use axum::Json;
use axum::extract::{Path, State};

use super::error::{ApiError, ApiJson};
use crate::state::Host;
use crate::steps;
use meshflow_api::host::{RunRequest, RunResult, Update, Updated, Vouched};

/// `POST /sessions/{id}/update`: re-run the step (`replay`) or replay its edit log
/// (`correction`), as asked, falling back to the edit log and then to the full mesh.
pub async fn update(
    State(host): State<Arc<Host>>,
    Path(id): Path<String>,
    ApiJson(Vouched { body: update, peers }): ApiJson<Vouched<Update>>,
) -> Result<Json<Updated>, ApiError> {
    Ok(Json(steps::update(&host, &id, update, &peers).await?))
}

/// `POST /sessions/{id}/run`: a filter replaces the session's mesh and yields a
/// correction and a full-mesh URL; a check yields its value.
pub async fn run(
    State(host): State<Arc<Host>>,
    Path(id): Path<String>,
    ApiJson(request): ApiJson<RunRequest>,
) -> Result<Json<RunResult>, ApiError> {
    Ok(Json(steps::run(&host, &id, request).await?))
}
