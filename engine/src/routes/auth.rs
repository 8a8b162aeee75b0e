//! Who may call which engine route (DESIGN §10), checked from the headers before any body
//! is read: `GET /` (the UI page) and `GET /health` are open; `POST /hosts` takes the
//! cluster token (the API token when there is no cluster token); `GET /inputs/{file}` takes
//! either (hosts fetch inputs with the cluster token, users with theirs); every other route
//! takes the API token, which `GET /runs/{id}/events` also accepts as `?token=` (a browser's
//! `EventSource` cannot set headers). A route whose tokens are all unset is open.

use std::sync::Arc;

use axum::extract::{Query, Request, State};
use axum::http::Method;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use meshflow_api::server::{bearer, require};
use serde::Deserialize;

use crate::engine::Engine;

#[derive(Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

/// The middleware: refuses a request without the token its route takes.
pub async fn check(State(engine): State<Arc<Engine>>, request: Request, next: Next) -> Response {
    let access = &engine.access;
    let (api, cluster) = (access.api_token.as_deref(), access.cluster_token.as_deref());
    let path = request.uri().path();
    let get = request.method() == Method::GET;
    let mut given = bearer(request.headers()).map(str::to_owned);
    // The page and its bundled files are public; what they show needs the API token.
    let page = path == "/" || path == "/health" || path.starts_with("/assets/");
    let allowed = if get && page {
        Ok(())
    } else if path == "/hosts" && request.method() == Method::POST {
        let tokens: Vec<&str> = cluster.or(api).into_iter().collect();
        require(given.as_deref(), &tokens, "the cluster token")
    } else if get && path.starts_with("/inputs/") {
        let tokens: Vec<&str> = [api, cluster].into_iter().flatten().collect();
        require(given.as_deref(), &tokens, "the API or the cluster token")
    } else {
        if get && path.starts_with("/runs/") && path.ends_with("/events") && given.is_none() {
            given = Query::<TokenQuery>::try_from_uri(request.uri()).ok().and_then(|q| q.0.token);
        }
        let tokens: Vec<&str> = api.into_iter().collect();
        require(given.as_deref(), &tokens, "the API token")
    };
    match allowed {
        Ok(()) => next.run(request).await,
        Err(refusal) => refusal.into_response(),
    }
}
