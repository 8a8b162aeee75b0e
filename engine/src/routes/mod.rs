//! The engine HTTP API (DESIGN §6): hosts, catalogue, inputs, runs with their status,
//! progress events and result, batches, workflow checks, plugin uploads and the web UI.
//! One file per resource; errors are `{"error": {"code", "message"}}` ([`error`]); who may
//! call what is [`auth`]; every request first passes the browser guard ([`browser`]).

mod auth;
mod batches;
mod browser;
mod downloads;
mod error;
mod events;
mod hosts;
mod inputs;
mod ops;
mod plugins;
mod runs;
pub(crate) use runs::ended;
mod ui;
mod workflows;

use std::sync::Arc;

use axum::extract::DefaultBodyLimit;
use axum::routing::{get, post};
use axum::{Extension, Json, Router};
use serde_json::json;

use crate::engine::Engine;
use crate::limits::{MAX_PLUGIN_FORWARD_BYTES, MAX_REGISTER_BYTES, MAX_SUBMIT_BYTES};
use crate::users::User;

pub fn router(engine: Arc<Engine>) -> Router {
    Router::new()
        .route("/", get(ui::index))
        .route("/assets/{file}", get(ui::asset))
        .route("/favicon.ico", get(ui::favicon))
        .route("/favicon.svg", get(ui::favicon))
        .route("/history", get(ui::history))
        .route("/health", get(|| async { Json(json!({"status": "ok"})) }))
        .route("/ready", get(ops::ready))
        .route("/metrics", get(ops::metrics))
        .route(
            "/hosts",
            get(hosts::list)
                .post(hosts::register)
                .patch(hosts::set_trust)
                .layer(DefaultBodyLimit::max(MAX_REGISTER_BYTES)),
        )
        .route("/services", get(hosts::services))
        .route("/me", get(|Extension(user): Extension<User>| async move { Json(user) }))
        // Streamed to disk: the limit is applied while writing.
        .route("/inputs", post(inputs::upload).layer(DefaultBodyLimit::disable()))
        .route("/inputs/{file}", get(inputs::download))
        .route(
            "/runs",
            get(runs::list).post(runs::submit).layer(DefaultBodyLimit::max(MAX_SUBMIT_BYTES)),
        )
        .route("/runs/{id}", get(runs::status))
        .route("/runs/{id}/cancel", post(runs::cancel))
        .route("/runs/{id}/rerun", post(runs::rerun))
        .route("/batches", post(batches::submit).layer(DefaultBodyLimit::max(MAX_SUBMIT_BYTES)))
        .route("/batches/{id}", get(batches::status))
        .route("/batches/{id}/cancel", post(batches::cancel))
        .route("/runs/{id}/comparison", get(runs::comparison))
        .route("/runs/{id}/events", get(events::stream))
        .route("/runs/{id}/workflow", get(runs::workflow))
        .route("/runs/{id}/result", get(downloads::result))
        .route("/runs/{id}/input", get(downloads::input))
        .route("/runs/{id}/steps/{index}/output", get(downloads::step_output))
        .route(
            "/workflows/validate",
            post(workflows::validate).layer(DefaultBodyLimit::max(MAX_SUBMIT_BYTES)),
        )
        .route(
            "/plugins",
            post(plugins::forward).layer(DefaultBodyLimit::max(MAX_PLUGIN_FORWARD_BYTES)),
        )
        .layer(axum::middleware::from_fn_with_state(engine.clone(), auth::check))
        .layer(axum::middleware::from_fn_with_state(browser::guard_of(&engine), browser::check))
        // axum's own rejections (a path that does not parse: 400) in the JSON envelope too.
        .layer(axum::middleware::from_fn(meshflow_api::server::json_errors))
        .with_state(engine)
}
