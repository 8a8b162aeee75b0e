//! `/plugins` and `/services`: upload (bearer token), list and delete plugins.

use std::sync::Arc;

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, StatusCode, header};

use super::error::ApiError;
use crate::state::Host;
use meshflow_api::host::{PluginEntry, ServiceEntry, UploadedPlugin};
use meshflow_runtime::digest;

/// Uploads and deletes need the host's token; a host without one takes none.
fn authorize(host: &Host, headers: &HeaderMap) -> Result<(), ApiError> {
    let Some(token) = &host.config.token else {
        return Err(ApiError::new(
            StatusCode::FORBIDDEN,
            "uploads-disabled",
            "uploads disabled: start the host with --token",
        ));
    };
    let given = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    // Comparing hashes takes the same time wherever the strings differ.
    match given {
        Some(given) if blake3::hash(given.as_bytes()) == blake3::hash(token.as_bytes()) => Ok(()),
        _ => Err(ApiError::new(
            StatusCode::UNAUTHORIZED,
            "unauthorized",
            "a valid bearer token is required",
        )),
    }
}

/// `POST /plugins`: body = component bytes.
pub async fn upload(
    State(host): State<Arc<Host>>,
    headers: HeaderMap,
    body: Bytes,
) -> Result<(StatusCode, Json<UploadedPlugin>), ApiError> {
    authorize(&host, &headers)?;
    let digest = digest(&body);
    if let Some(services) = host.plugins.known(&digest) {
        return Ok((StatusCode::OK, Json(UploadedPlugin { digest, services })));
    }
    let runtime = host.runtime.clone();
    let bytes = body.clone();
    let plugin = tokio::task::spawn_blocking(move || runtime.load(&bytes))
        .await?
        .map_err(|e| ApiError::unprocessable("invalid-plugin", e.to_string()))?;
    let services = plugin.services.clone();
    host.plugins.add(plugin, &body)?;
    tracing::info!("plugin {digest} uploaded");
    Ok((StatusCode::CREATED, Json(UploadedPlugin { digest, services })))
}

/// `GET /plugins`.
pub async fn list(State(host): State<Arc<Host>>) -> Json<Vec<PluginEntry>> {
    Json(host.plugins.entries())
}

/// `GET /services`.
pub async fn services(State(host): State<Arc<Host>>) -> Json<Vec<ServiceEntry>> {
    Json(host.plugins.services())
}

/// `DELETE /plugins/{digest}`.
pub async fn delete(
    State(host): State<Arc<Host>>,
    Path(digest): Path<String>,
    headers: HeaderMap,
) -> Result<StatusCode, ApiError> {
    authorize(&host, &headers)?;
    host.plugins.remove(&digest)?;
    Ok(StatusCode::NO_CONTENT)
}
