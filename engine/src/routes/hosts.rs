//! `GET /hosts`, `POST /hosts` (a host registers, or is registered) and `GET /services`
//! (the catalogue: every service on offer, with the hosts offering it).

use std::sync::Arc;

use axum::extract::State;
use axum::extract::rejection::BytesRejection;
use axum::http::StatusCode;
use axum::{Json, body::Bytes};
use meshflow_api::engine::{HostInfo, RegisterHost, ServiceOffer};

use super::error::{ApiError, ApiResult, rejected};
use crate::engine::Engine;
use crate::registry::HostEntry;

pub async fn register(
    State(engine): State<Arc<Engine>>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<HostInfo>)> {
    let body = body.map_err(rejected)?;
    let registration: RegisterHost = serde_json::from_slice(&body).map_err(|e| {
        ApiError::bad_request("bad-request", format!("expected {{\"url\": ...}}: {e}"))
    })?;
    let host = engine.registry.register(&registration.url).await?;
    Ok((StatusCode::CREATED, Json(host_info(&host))))
}

pub async fn list(State(engine): State<Arc<Engine>>) -> Json<Vec<HostInfo>> {
    Json(engine.registry.hosts().iter().map(|h| host_info(h)).collect())
}

pub async fn services(State(engine): State<Arc<Engine>>) -> Json<Vec<ServiceOffer>> {
    Json(engine.registry.catalogue().into_values().collect())
}

fn host_info(host: &HostEntry) -> HostInfo {
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
