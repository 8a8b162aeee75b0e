//! Browser safety that does not depend on tokens (DESIGN §11), for the engine: the `Host`
//! header must be a name the engine answers to (an IP address, `localhost`, or its public
//! URL's name), and a page may change the engine's state only from the engine's own origin
//! or one given with `--allow-origin`, sending JSON except to the upload routes (`/inputs`,
//! `/plugins`). See `meshflow_api::server::BrowserGuard`.
//!
//! Probes (`GET /health`, `/ready`, `/metrics`) pass whatever name they use: monitoring
//! reaches the engine by names of its own, and they show no user's data.

use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::Method;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use meshflow_api::server::BrowserGuard;

use crate::engine::Engine;

/// Routes whose bodies are bytes, not JSON.
const RAW_BODY_PATHS: &[&str] = &["/inputs", "/plugins"];
/// Read-only routes for monitoring, which any `Host` may ask.
const PROBES: &[&str] = &["/health", "/ready", "/metrics"];

/// The guard for this engine: its public URL and the origins an operator allowed.
pub fn guard_of(engine: &Engine) -> Arc<BrowserGuard> {
    let urls = [engine.public_url.as_str()];
    Arc::new(BrowserGuard::new(&urls, &engine.access.allow_origins, RAW_BODY_PATHS))
}

/// The middleware: refuses what a page of another site, or a rebound name, asks.
pub async fn check(
    State(guard): State<Arc<BrowserGuard>>,
    request: Request,
    next: Next,
) -> Response {
    let probe = matches!(*request.method(), Method::GET | Method::HEAD)
        && PROBES.contains(&request.uri().path());
    match guard.check(request.method(), request.uri().path(), request.headers()) {
        Err(refusal) if !probe => refusal.into_response(),
        _ => next.run(request).await,
    }
}
