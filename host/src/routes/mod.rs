//! The HTTP edge of the host: the router, one file per resource, and the mapping of domain
//! errors to statuses (`error.rs`).

mod auth;
mod blobs;
mod error;
mod meshes;
mod ops;
mod plugins;
mod sessions;
mod steps;

use std::sync::Arc;

use axum::Router;
use axum::extract::{DefaultBodyLimit, State};
use axum::routing::{delete, get, post};

use crate::plugins::MAX_PLUGIN_BYTES;
use crate::state::Host;
use error::ApiError;
use meshflow_api::host::Health;
use meshflow_api::server::{BrowserGuard, browser_guard as guard};

pub fn router(host: Arc<Host>) -> Router {
    Router::new()
        .route("/health", get(health))
        .route("/ready", get(ops::ready))
        .route("/metrics", get(ops::metrics))
        .route("/services", get(plugins::services))
        .route(
            "/plugins",
            get(plugins::list).post(plugins::upload).layer(DefaultBodyLimit::max(MAX_PLUGIN_BYTES)),
        )
        .route("/plugins/{digest}", delete(plugins::delete))
        .route("/plugins/{digest}/wasm", get(plugins::component))
        .route("/replay-plugins", post(plugins::prefetch))
        .route("/sessions", post(sessions::create))
        .route("/sessions/{id}", get(sessions::status).delete(sessions::delete))
        .route("/sessions/{id}/update", post(steps::update))
        .route("/sessions/{id}/run", post(steps::run))
        .route("/blobs/{name}", get(blobs::serve).head(blobs::serve))
        .route("/meshes/convert", post(meshes::convert))
        .fallback(|| async {
            ApiError::new(axum::http::StatusCode::NOT_FOUND, "not-found", "no such endpoint")
        })
        .layer(axum::middleware::from_fn_with_state(host.clone(), auth::check))
        // Outermost: a page on another site is refused before any token is looked at.
        .layer(axum::middleware::from_fn_with_state(browser_guard(&host), guard))
        // axum's own rejections (a body over its limit: 413) in the JSON envelope too.
        .layer(axum::middleware::from_fn(meshflow_api::server::json_errors))
        .with_state(host)
}

/// Hosts answer to their public name; only plugin uploads send bytes rather than JSON.
fn browser_guard(host: &Host) -> Arc<BrowserGuard> {
    Arc::new(BrowserGuard::new(&[host.public_url.as_str()], &[], &["/plugins"]))
}

/// A URL a request names for this host to fetch, normalised, or why it is refused: too
/// long or not a URL (`bad-url`), or outside what the host fetches from with these `peers`
/// (`url-not-allowed`).
fn allowed_url(host: &Host, text: &str, peers: &[String]) -> Result<String, ApiError> {
    Ok(host.downloads.allowed_url(text, peers)?)
}

async fn health(State(host): State<Arc<Host>>) -> axum::Json<Health> {
    axum::Json(Health {
        status: "ok".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        running: host.running(),
        sessions: host.sessions.count(),
        foreign_plugins: host.replay_plugins.runs_foreign(),
        instance: Some(host.instance.clone()),
    })
}
