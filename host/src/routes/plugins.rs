//! `/plugins` and `/services`: upload, list and delete plugins (`auth.rs` checks the upload
//! token before a body is read).

use std::sync::Arc;

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::StatusCode;

use super::error::ApiError;
use crate::state::Host;
use meshflow_api::host::{PluginEntry, ServiceEntry, UploadedPlugin};
use meshflow_runtime::digest;

/// `POST /plugins`: body = component bytes.
pub async fn upload(
    State(host): State<Arc<Host>>,
    body: Bytes,
) -> Result<(StatusCode, Json<UploadedPlugin>), ApiError> {
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

/// `GET /plugins/{digest}/wasm` (cluster token): a loaded plugin's component, for a host
/// that replays a step of this one.
pub async fn component(
    State(host): State<Arc<Host>>,
    Path(digest): Path<String>,
) -> Result<impl axum::response::IntoResponse, ApiError> {
    let bytes = host.plugins.bytes(&digest).ok_or_else(|| {
        ApiError::new(StatusCode::NOT_FOUND, "no-plugin", format!("no plugin {digest} here"))
    })?;
    Ok(([(axum::http::header::CONTENT_TYPE, "application/wasm")], bytes))
}

/// `DELETE /plugins/{digest}`.
pub async fn delete(
    State(host): State<Arc<Host>>,
    Path(digest): Path<String>,
) -> Result<StatusCode, ApiError> {
    host.plugins.remove(&digest)?;
    Ok(StatusCode::NO_CONTENT)
}
