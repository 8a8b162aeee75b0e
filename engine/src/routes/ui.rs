//! The workbench's files (`engine/web/`, bundled by `build.rs`), served from the binary:
//! `GET /` is its page, `GET /assets/…` its scripts and styles, whose names carry a content
//! hash and so may be cached for good.

use axum::extract::Path;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};

/// Every file of the bundle by its path under the bundle's root.
const ASSETS: &[(&str, &[u8])] = include!(concat!(env!("OUT_DIR"), "/web_assets.rs"));

pub async fn index() -> Response {
    serve("index.html", "no-cache")
}

pub async fn asset(Path(file): Path<String>) -> Response {
    serve(&format!("assets/{file}"), "public, max-age=31536000, immutable")
}

fn serve(name: &str, cache: &'static str) -> Response {
    match ASSETS.iter().find(|(asset, _)| *asset == name) {
        Some((_, bytes)) => {
            let headers =
                [(header::CONTENT_TYPE, content_type(name)), (header::CACHE_CONTROL, cache)];
            (headers, *bytes).into_response()
        }
        None => (StatusCode::NOT_FOUND, "no such file").into_response(),
    }
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
