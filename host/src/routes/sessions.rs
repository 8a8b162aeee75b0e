//! `/sessions`: create one on an input URL (it loads in the background), its status
//! (optionally waiting until it is loaded), delete.

use std::sync::Arc;

use axum::extract::{Path, Query, State};
use axum::http::StatusCode;
use serde::Deserialize;

use super::error::{self, ApiError, ApiJson};
use crate::config::LONG_POLL;
use crate::rebuild;
use crate::sessions::{self, SessionRecord};
use crate::state::Host;
use meshflow_api::host::{CreateSession, SessionCreated, SessionState, SessionStatus, Vouched};

/// `POST /sessions`: the input downloads in the background.
pub async fn create(
    State(host): State<Arc<Host>>,
    ApiJson(Vouched { body: request, peers }): ApiJson<Vouched<CreateSession>>,
) -> Result<(StatusCode, axum::Json<SessionCreated>), ApiError> {
    let input_url = super::allowed_url(&host, &request.input.url, &peers)?;
    let id = sessions::new_id();
    let record = SessionRecord {
        input_url,
        input_hash: request.input.hash,
        input: None,
        steps: Vec::new(),
        peers,
        grid: request.grid,
        offered: Vec::new(),
    };
    rebuild::start(&host, id.clone(), record)?;
    let created = SessionCreated { id, state: SessionState::Loading };
    Ok((StatusCode::ACCEPTED, axum::Json(created)))
}

#[derive(Deserialize)]
pub struct StatusQuery {
    wait: Option<String>,
}

/// `GET /sessions/{id}[?wait=ready]`.
pub async fn status(
    State(host): State<Arc<Host>>,
    Path(id): Path<String>,
    Query(query): Query<StatusQuery>,
) -> Result<axum::Json<SessionStatus>, ApiError> {
    let status = match query.wait.as_deref() {
        None => host.sessions.status(&id),
        Some("ready") => host.sessions.wait_loaded(&id, LONG_POLL).await,
        Some(other) => {
            return Err(ApiError::bad_request(
                "bad-query",
                format!("wait={other}: only wait=ready is known"),
            ));
        }
    };
    status.map(axum::Json).ok_or_else(|| error::not_found("session", &id))
}

/// `DELETE /sessions/{id}`.
pub async fn delete(
    State(host): State<Arc<Host>>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    if host.sessions.remove(&id) {
        Ok(StatusCode::NO_CONTENT)
    } else {
        Err(error::not_found("session", &id))
    }
}
