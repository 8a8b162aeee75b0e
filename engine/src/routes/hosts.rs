//! `GET /hosts`, `POST /hosts` (a host registers, or is registered) and `GET /services`
//! (the catalogue: every service on offer, with the hosts offering it).

use std::sync::Arc;

use axum::extract::State;
use axum::extract::rejection::BytesRejection;
use axum::http::StatusCode;
use axum::{Json, body::Bytes};
use meshflow_api::engine::{HostInfo, RegisterHost, ServiceOffer, SetTrust};

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

/// `PATCH /hosts {"url", "trust"}`: an admin sets how far a registered host is trusted.
pub async fn set_trust(
    State(engine): State<Arc<Engine>>,
    axum::Extension(user): axum::Extension<crate::users::User>,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<Json<HostInfo>> {
    if !user.is_admin() {
        let message = "setting a host's trust needs the admin role";
        return Err(ApiError::new(StatusCode::FORBIDDEN, "forbidden", message));
    }
    let body = body.map_err(rejected)?;
    let request: SetTrust = serde_json::from_slice(&body).map_err(|e| {
        ApiError::bad_request("bad-request", format!("expected {{\"url\", \"trust\"}}: {e}"))
    })?;
    let trust = crate::trust::Trust::parse(&request.trust).ok_or_else(|| {
        ApiError::bad_request(
            "bad-request",
            "trust is one of trusted, spot-check, untrusted".to_owned(),
        )
    })?;
    let host = engine.registry.host(&request.url).ok_or_else(|| {
        ApiError::new(StatusCode::NOT_FOUND, "not-found", "no host is registered at that URL")
    })?;
    host.set_trust(trust);
    tracing::info!(host = %host.url, user = %user.name, "trust set to {}", trust.name());
    Ok(Json(host_info(&host)))
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
        trust: host.trust().name().to_owned(),
    }
}
