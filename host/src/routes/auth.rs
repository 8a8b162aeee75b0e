//! Who may call which route, checked from the headers before any body is read: `/health`
//! and `/ready` are open, `/metrics` checks its own rule (`ops.rs`); uploading and deleting
//! plugins takes the upload token (refused outright when the host has none), and listing
//! them and the services takes it or the cluster token (a publisher has only the first);
//! everything else takes the cluster token when the host has one.

use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{Method, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use crate::state::Host;
use meshflow_api::server::{ApiError, bearer, require};

pub async fn check(State(host): State<Arc<Host>>, request: Request, next: Next) -> Response {
    let path = request.uri().path();
    let given = bearer(request.headers());
    // `/metrics` applies its own rule (`ops.rs`).
    let allowed = if matches!(path, "/health" | "/ready" | "/metrics") {
        Ok(())
    } else if path.starts_with("/plugins")
        && matches!(*request.method(), Method::POST | Method::DELETE)
    {
        match &host.config.token {
            Some(token) => {
                require(given, &[token], "the host's upload token").map_err(|e| e.into_response())
            }
            None => Err(ApiError::new(
                StatusCode::FORBIDDEN,
                "uploads-disabled",
                "uploads disabled: start the host with an upload token (--token)",
            )
            .into_response()),
        }
    } else if matches!(path, "/plugins" | "/services") && *request.method() == Method::GET {
        let tokens = [&host.config.cluster_token, &host.config.token];
        let accepted: Vec<&str> = tokens.iter().filter_map(|t| t.as_deref()).collect();
        // A host with an upload token but no cluster token is open to the cluster anyway.
        let open = host.config.cluster_token.is_none();
        let accepted = if open { Vec::new() } else { accepted };
        require(given, &accepted, "the cluster or upload token").map_err(|e| e.into_response())
    } else {
        let cluster: Vec<&str> = host.config.cluster_token.as_deref().into_iter().collect();
        require(given, &cluster, "the cluster token").map_err(|e| e.into_response())
    };
    match allowed {
        Ok(()) => next.run(request).await,
        Err(refusal) => refusal,
    }
}
