//! Operations (DESIGN §11): `GET /metrics` in the Prometheus text format, for loopback
//! clients and holders of the metrics token ([`crate::metrics::may_scrape`]), and
//! `GET /ready`: the data folder takes a file and a plugin is loaded. `auth.rs` lets these
//! (and `/health`) through without the cluster token.

use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::{ConnectInfo, Request, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde_json::json;

use super::ApiError;
use crate::metrics::CONTENT_TYPE;
use crate::state::Host;
use meshflow_api::server::may_scrape;

/// `GET /metrics`.
pub async fn metrics(State(host): State<Arc<Host>>, request: Request) -> Response {
    let peer = request.extensions().get::<ConnectInfo<SocketAddr>>().map(|info| info.0);
    if let Err(refused) = may_scrape(peer, request.headers(), host.config.metrics_token.as_deref())
    {
        return refused.into_response();
    }
    let blobs = host.config.data_dir.join("blobs");
    let text = host.metrics.render(host.sessions.count(), host.running(), &blobs).await;
    ([(header::CONTENT_TYPE, CONTENT_TYPE)], text).into_response()
}

/// `GET /ready`: 200 when the data folder takes a new file and at least one plugin offers a
/// service; else 503 `not-ready`, saying what is missing.
pub async fn ready(State(host): State<Arc<Host>>) -> Response {
    let mut missing = Vec::new();
    let data = host.config.data_dir.clone();
    let writable = tokio::task::spawn_blocking(move || {
        use std::io::Write;
        tempfile::NamedTempFile::new_in(&data)?.write_all(b"ready?")
    })
    .await;
    match writable {
        Ok(Ok(())) => {}
        Ok(Err(error)) => missing.push(format!(
            "the data folder {} takes no file: {error}",
            host.config.data_dir.display()
        )),
        Err(error) => missing.push(format!("checking the data folder: {error}")),
    }
    let services = host.plugins.services().len();
    if services == 0 {
        missing.push("no plugin is loaded: the host offers no service".to_owned());
    }
    if missing.is_empty() {
        return axum::Json(json!({"status": "ready", "services": services})).into_response();
    }
    ApiError::new(StatusCode::SERVICE_UNAVAILABLE, "not-ready", missing.join("; ")).into_response()
}
