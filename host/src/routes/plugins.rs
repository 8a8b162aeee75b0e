//! `/plugins` and `/services`: upload, list and delete plugins (`auth.rs` checks the upload
//! token before a body is read).

use std::sync::Arc;

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, Query, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;

use super::error::{ApiError, ApiJson};
use crate::plugins::Upload;
use crate::state::Host;
use meshflow_api::host::{
    MAX_PREFETCH_PLUGINS, PluginEntry, PrefetchPlugins, PrefetchedPlugins, ServiceEntry,
    UploadedPlugin, Vouched,
};

/// `POST /plugins?replace=true`.
#[derive(Deserialize)]
pub struct UploadQuery {
    #[serde(default)]
    replace: bool,
}

/// `POST /plugins`: body = component bytes.
pub async fn upload(
    State(host): State<Arc<Host>>,
    Query(query): Query<UploadQuery>,
    body: Bytes,
) -> Result<(StatusCode, Json<UploadedPlugin>), ApiError> {
    let upload = host.plugins.upload(&host.runtime, body, query.replace).await?;
    let Upload { digest, services, present, outcome } = upload;
    if present {
        let present = services.iter().map(|s| s.name.clone()).collect();
        let answer = UploadedPlugin { digest, services, present, ..UploadedPlugin::default() };
        return Ok((StatusCode::OK, Json(answer)));
    }
    let (new, replaced) = (outcome.new, outcome.replaced);
    let answer = UploadedPlugin { digest, services, new, replaced, present: Vec::new() };
    Ok((StatusCode::CREATED, Json(answer)))
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
/// that replays a step of this one; zstd-compressed (a third of the bytes) to a client
/// that accepts it.
pub async fn component(
    State(host): State<Arc<Host>>,
    Path(digest): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let missing =
        || ApiError::new(StatusCode::NOT_FOUND, "no-plugin", format!("no plugin {digest} here"));
    let wasm = (header::CONTENT_TYPE, "application/wasm");
    // The answer depends on the header: a cache must not give one form for the other.
    let vary = (header::VARY, "accept-encoding");
    if meshflow_api::accepts_zstd(&headers) {
        let sent = host.plugins.sent(&digest).ok_or_else(missing)?;
        let zstd = (header::CONTENT_ENCODING, "zstd");
        return Ok(([wasm, zstd, vary], Vec::clone(&sent)).into_response());
    }
    let bytes = host.plugins.bytes(&digest).ok_or_else(missing)?;
    Ok(([wasm, vary], bytes).into_response())
}

/// `POST /replay-plugins` (cluster token): makes ready the plugins a run may replay
/// here, each fetched from the cluster host named beside it. The work is a task of its
/// own, so a caller that hangs up does not cancel a compile half done; the answer comes
/// when every plugin is ready or has failed (a failure is an outcome, not an error).
pub async fn prefetch(
    State(host): State<Arc<Host>>,
    ApiJson(Vouched { body, peers }): ApiJson<Vouched<PrefetchPlugins>>,
) -> Result<Json<PrefetchedPlugins>, ApiError> {
    let PrefetchPlugins { plugins: wanted } = body;
    if wanted.len() > MAX_PREFETCH_PLUGINS {
        let message = format!("at most {MAX_PREFETCH_PLUGINS} plugins per request");
        return Err(ApiError::bad_request("too-many-plugins", message));
    }
    let scope = host.downloads.scope(&peers)?;
    let work = tokio::spawn(async move {
        host.replay_plugins.prefetch_all(&host.plugins, &scope, &wanted).await
    });
    let plugins = work.await.map_err(|e| ApiError::internal(format!("prefetch failed: {e}")))?;
    Ok(Json(PrefetchedPlugins { plugins }))
}

/// `DELETE /plugins/{digest}`.
pub async fn delete(
    State(host): State<Arc<Host>>,
    Path(digest): Path<String>,
) -> Result<StatusCode, ApiError> {
    host.plugins.remove(&digest)?;
    Ok(StatusCode::NO_CONTENT)
}
