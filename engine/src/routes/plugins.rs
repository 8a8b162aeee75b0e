//! `POST /plugins?host=`: a `.wasm` forwarded to a registered host, for the browser, which
//! cannot call hosts of other origins.

use std::sync::Arc;

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Query, State};
use axum::http::{HeaderMap, StatusCode};
use serde::Deserialize;
use serde_json::{Value, json};

use super::error::{ApiError, ApiResult, host_refused, rejected};
use crate::engine::Engine;

#[derive(Deserialize)]
pub struct PluginQuery {
    host: Option<String>,
    /// Passed on to the host: serve the plugin's services in place of another plugin's.
    #[serde(default)]
    replace: bool,
}

/// The header carrying a host's upload token through `POST /plugins` (the `Authorization`
/// header is the engine's own API token).
const UPLOAD_TOKEN_HEADER: &str = "x-upload-token";

/// Forwards the body to the registered host `host` with the upload token from
/// [`UPLOAD_TOKEN_HEADER`] (never logged). Answers what the host answered.
pub async fn forward(
    State(engine): State<Arc<Engine>>,
    Query(query): Query<PluginQuery>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> ApiResult<(StatusCode, Json<Value>)> {
    let wasm = body.map_err(rejected)?;
    let host = query.host.unwrap_or_default();
    // Only registered hosts: the engine must not post to any address a client names.
    if !engine.registry.hosts().iter().any(|h| h.url == host) {
        let shown: String = host.chars().take(200).collect();
        let message = format!("\"{shown}\" is not a registered host");
        return Err(ApiError::bad_request("unknown-host", message));
    }
    let token = headers.get(UPLOAD_TOKEN_HEADER).and_then(|v| v.to_str().ok());
    let uploaded = engine
        .registry
        .client(&host)
        .upload_plugin(wasm.to_vec(), token, query.replace)
        .await
        .map_err(|error| host_refused(&host, error))?;
    // The catalogue learns the new services now rather than at the next poll.
    if let Some(entry) = engine.registry.hosts().iter().find(|h| h.url == host) {
        engine.registry.refresh(entry).await;
    }
    Ok((StatusCode::CREATED, Json(json!(uploaded))))
}
