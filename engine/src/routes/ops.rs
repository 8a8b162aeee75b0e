//! Operations (DESIGN §11): `GET /metrics` in the Prometheus text format, for loopback
//! clients and holders of the metrics token ([`crate::metrics::may_scrape`]), and
//! `GET /ready`: the store answers and at least one host is up. `routes/auth.rs` lets these
//! (and `/health`) through without the API token.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::{ConnectInfo, Request, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use meshflow_api::server::ApiError;
use serde_json::json;

use crate::engine::Engine;
use crate::metrics::CONTENT_TYPE;
use meshflow_api::server::may_scrape;

/// How long `/ready` waits for the store before saying it does not answer.
const STORE_ANSWER: Duration = Duration::from_secs(2);

/// `GET /metrics`.
pub async fn metrics(State(engine): State<Arc<Engine>>, request: Request) -> Response {
    let peer = request.extensions().get::<ConnectInfo<SocketAddr>>().map(|info| info.0);
    let token = engine.access.metrics_token.as_deref();
    if let Err(refused) = may_scrape(peer, request.headers(), token) {
        return refused.into_response();
    }
    let runs: Vec<_> = engine.runs().iter().map(|run| run.status()).collect();
    let text = engine.registry.metrics.render(runs, &engine.registry.hosts());
    ([(header::CONTENT_TYPE, CONTENT_TYPE)], text).into_response()
}

/// `GET /ready`: 200 once the store answers and a host is up; else 503 `not-ready`, saying
/// what is missing.
pub async fn ready(State(engine): State<Arc<Engine>>) -> Response {
    let mut missing = Vec::new();
    let query = engine.store.call(|c| Ok(c.query_row("SELECT 1", [], |_| Ok(()))?));
    match tokio::time::timeout(STORE_ANSWER, query).await {
        Ok(Ok(())) => {}
        Ok(Err(error)) => missing.push(format!("the store does not answer: {error}")),
        Err(_) => {
            missing.push(format!("the store did not answer within {} s", STORE_ANSWER.as_secs()))
        }
    }
    let hosts = engine.registry.hosts();
    let up = hosts.iter().filter(|host| host.is_up() && !host.is_suspect()).count();
    if hosts.is_empty() {
        missing.push("no host is registered".to_owned());
    } else if up == 0 {
        missing.push(format!("none of the {} registered hosts is up", hosts.len()));
    }
    if missing.is_empty() {
        return axum::Json(json!({"status": "ready", "hosts_up": up})).into_response();
    }
    ApiError::new(StatusCode::SERVICE_UNAVAILABLE, "not-ready", missing.join("; ")).into_response()
}
