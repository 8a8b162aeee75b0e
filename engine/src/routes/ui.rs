//! The workbench's files (`engine/web/`, bundled by `build.rs`), served from the binary:
//! `GET /` is its page, `GET /assets/…` its scripts and styles, whose names carry a content
//! hash and so may be cached for good. Every answer carries a strict Content-Security-Policy
//! (scripts, styles and connections from this origin only, no inline script or style, no
//! framing) and the headers that keep browsers from sniffing types, sending referrers or
//! framing the page (DESIGN §11).

use axum::extract::Path;
use axum::http::{HeaderName, StatusCode, header};
use axum::response::{IntoResponse, Response};

/// What the page may load and do: its own scripts, styles and API; images also from
/// `data:`/`blob:` (three.js textures, downloads); nothing inline, no plugins, no frames.
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'self'; script-src 'self'; \
     style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; object-src 'none'; \
     base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

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
