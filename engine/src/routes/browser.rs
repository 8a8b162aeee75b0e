//! Browser safety that does not depend on tokens (DESIGN §11), for the engine: the `Host`
//! header must be a name the engine answers to (an IP address, `localhost`, or its public
//! URL's name), and a page may change the engine's state only from the engine's own origin
//! or one given with `--allow-origin`, sending JSON except to the upload routes (`/inputs`,
//! `/plugins`). See `meshflow_api::server::BrowserGuard`.
//!
//! The guard holds on every route, probes included (`/health`, `/ready`, `/metrics`): a
//! monitor reaches the engine by an IP address, `localhost` or its public name.

use std::sync::Arc;

use axum::extract::{Request, State};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use meshflow_api::server::BrowserGuard;

use crate::engine::Engine;

/// Routes whose bodies are bytes, not JSON.
const RAW_BODY_PATHS: &[&str] = &["/inputs", "/plugins"];

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
    match guard.check(request.method(), request.uri().path(), request.headers()) {
        Err(refusal) => refusal.into_response(),
        Ok(()) => next.run(request).await,
    }
}
