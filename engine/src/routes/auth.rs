//! Who may call which engine route (DESIGN §10), checked from the headers before any body
//! is read: `GET /` (the UI page, its assets and icon), `GET /health` and `GET /ready` are open, `GET /metrics`
//! checks its own rule; `POST /hosts` takes the
//! cluster token (the API token when there is no cluster token); `GET /inputs/{file}` takes
//! the cluster token (hosts fetch inputs with it) or a user's token (their own uploads);
//! every other route takes a user's token (`--users`, or the API token: the user
//! `default`), which `GET /runs/{id}/events` also accepts as `?token=` (a browser's
//! `EventSource` cannot set headers). The user is put in the request's extensions for the
//! handlers. Without any API token every caller is the user `default`.

use std::sync::Arc;

use axum::extract::{Query, Request, State};
use axum::http::{HeaderValue, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use meshflow_api::server::{ApiError, bearer, require, token_matches};
use serde::Deserialize;

use crate::engine::Engine;

#[derive(Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

/// The middleware: refuses a request without the token its route takes.
pub async fn check(
    State(engine): State<Arc<Engine>>,
    mut request: Request,
    next: Next,
) -> Response {
    let access = &engine.access;
    let (api, cluster) = (access.api_token.as_deref(), access.cluster_token.as_deref());
    let path = request.uri().path();
    let get = request.method() == Method::GET;
    let mut given = bearer(request.headers()).map(str::to_owned);
    // The page and its bundled files are public; what they show needs the API token.
    // `/metrics` applies its own rule (`routes/ops.rs`).
    let operations = matches!(path, "/health" | "/ready" | "/metrics");
    let icon = matches!(path, "/favicon.ico" | "/favicon.svg");
    let page = path == "/" || icon || operations || path.starts_with("/assets/");
    if get && page {
        return next.run(request).await;
    }
    if path == "/hosts" && request.method() == Method::POST {
        let tokens: Vec<&str> = cluster.or(api).into_iter().collect();
        return match require(given.as_deref(), &tokens, "the cluster token") {
            Ok(()) => next.run(request).await,
            Err(refusal) => refusal.into_response(),
        };
    }
    let what = if get && path.starts_with("/inputs/") {
        let by_cluster =
            cluster.is_some_and(|c| given.as_deref().is_some_and(|g| token_matches(g, c)));
        // Hosts fetch any input; a cluster-only engine takes no other token here.
        if by_cluster {
            return next.run(request).await;
        }
        if cluster.is_some() && !engine.users.required() {
            return unauthorized(given.as_deref(), "the API or the cluster token");
        }
        "the API or the cluster token"
    } else {
        if get && path.starts_with("/runs/") && path.ends_with("/events") && given.is_none() {
            given = Query::<TokenQuery>::try_from_uri(request.uri()).ok().and_then(|q| q.0.token);
        }
        "the API token"
    };
    match engine.users.authenticate(given.as_deref()) {
        Some(user) => {
            request.extensions_mut().insert(user);
            next.run(request).await
        }
        None => unauthorized(given.as_deref(), what),
    }
}

/// 401 `unauthorized`, as `meshflow_api::server::require` words it; the body was never
/// read, so the connection closes.
fn unauthorized(given: Option<&str>, what: &str) -> Response {
    let message = match given {
        None => format!("this route needs {what} as a bearer token"),
        Some(_) => format!("the bearer token is not {what}"),
    };
    let mut response =
        ApiError::new(StatusCode::UNAUTHORIZED, "unauthorized", message).into_response();
    response.headers_mut().insert(header::CONNECTION, HeaderValue::from_static("close"));
    response
}
