//! The workbench's files (`engine/web/`, bundled by `build.rs`), served from the binary:
//! `GET /` is its page, `GET /assets/…` its scripts and styles, whose names carry a content
//! hash and so may be cached for good. Every answer carries a strict Content-Security-Policy
//! (scripts, styles and connections from this origin only, no inline script or style, no
//! framing) and the headers that keep browsers from sniffing types, sending referrers or
//! framing the page (DESIGN §11).

use std::collections::HashMap;
use std::sync::Arc;

use axum::extract::{Path, State};
use axum::http::{HeaderName, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::{Extension, Json};
use serde::Serialize;

use crate::engine::Engine;
use crate::record::Status;
use crate::store;
use crate::users::User;

/// What the page may load and do: its own scripts, styles and API; images also from
/// `data:`/`blob:` (three.js textures, downloads); nothing inline, no plugins, no frames.
/// The viewer decodes meshes in a module worker of this origin (`worker-src 'self'`).
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'self'; script-src 'self'; \
     worker-src 'self'; style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; \
     object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

/// The headers of every answer of the UI's routes.
const SECURITY_HEADERS: [(HeaderName, &str); 4] = [
    (header::CONTENT_SECURITY_POLICY, CONTENT_SECURITY_POLICY),
    (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
    (header::REFERRER_POLICY, "no-referrer"),
    (header::X_FRAME_OPTIONS, "DENY"),
];

/// Every file of the bundle by its path under the bundle's root.
const ASSETS: &[(&str, &[u8])] = include!(concat!(env!("OUT_DIR"), "/web_assets.rs"));

pub async fn index() -> Response {
    serve("index.html", "no-cache")
}

pub async fn asset(Path(file): Path<String>) -> Response {
    serve(&format!("assets/{file}"), "public, max-age=31536000, immutable")
}

/// `GET /favicon.ico` and `/favicon.svg`: the bundle's icon (public, like the page), so a
/// browser's own request for it is not answered 401.
pub async fn favicon() -> Response {
    serve("favicon.svg", "public, max-age=86400")
}

/// One run as the workbench's history lists it.
#[derive(Serialize)]
pub struct HistoryRow {
    id: String,
    status: Status,
    steps: usize,
    user: String,
    /// When it was submitted (seconds since 1970), if the store knows.
    created_unix: Option<i64>,
    total_ms: Option<f64>,
    input: String,
    /// The name the input was uploaded under, if it was uploaded.
    input_name: Option<String>,
    workflow: serde_json::Value,
}

/// `GET /history`: the runs the user may see with when, who, what input under which name,
/// which workflow and how long (what `GET /runs` leaves out), in submission order.
pub async fn history(
    State(engine): State<Arc<Engine>>,
    Extension(user): Extension<User>,
) -> Json<Vec<HistoryRow>> {
    let runs: Vec<_> = engine.runs().into_iter().filter(|run| user.may_see(&run.user)).collect();
    let files: Vec<String> = runs
        .iter()
        .map(|run| run.input.rsplit('/').next().unwrap_or_default().to_owned())
        .collect();
    let looked_up = engine
        .store
        .call(move |c| {
            let names = store::input_names(c, &files)?;
            let mut statement = c.prepare("SELECT id, created_unix FROM runs")?;
            let created = statement
                .query_map([], |row| Ok((row.get::<_, String>(0)?, row.get::<_, i64>(1)?)))?
                .collect::<Result<HashMap<_, _>, _>>()?;
            Ok((names, created))
        })
        .await;
    let (names, created) = looked_up.unwrap_or_else(|error| {
        tracing::warn!("reading the history's names and times: {error}");
        Default::default()
    });
    let rows = runs.into_iter().map(|run| {
        let record = run.record();
        let file = run.input.rsplit('/').next().unwrap_or_default();
        HistoryRow {
            created_unix: created.get(&run.id).copied(),
            input_name: names.get(file).cloned(),
            id: record.id,
            status: record.status,
            steps: record.steps.len(),
            user: run.user.clone(),
            total_ms: record.total_ms,
            input: run.input.clone(),
            workflow: record.workflow,
        }
    });
    Json(rows.collect())
}

fn serve(name: &str, cache: &'static str) -> Response {
    let answer = match ASSETS.iter().find(|(asset, _)| *asset == name) {
        Some((_, bytes)) => {
            let headers =
                [(header::CONTENT_TYPE, content_type(name)), (header::CACHE_CONTROL, cache)];
            (headers, *bytes).into_response()
        }
        None => (StatusCode::NOT_FOUND, "no such file").into_response(),
    };
    (SECURITY_HEADERS, answer).into_response()
}

fn content_type(name: &str) -> &'static str {
    match name.rsplit_once('.').map(|(_, ext)| ext) {
        Some("html") => "text/html; charset=utf-8",
        Some("js") => "text/javascript; charset=utf-8",
        Some("css") => "text/css; charset=utf-8",
        Some("json") => "application/json",
        Some("svg") => "image/svg+xml",
        _ => "application/octet-stream",
    }
}
