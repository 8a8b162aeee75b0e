//! Browser safety that does not depend on tokens (DESIGN §11): a page on another site must
//! not be able to use a server that trusts its network (tokenless loopback mode), neither
//! by a cross-site request nor by DNS rebinding.
//!
//! - The `Host` header must be a name the server answers to: an IP literal (rebinding needs
//!   a name the attacker controls), `localhost`, or a name the operator gave (`--public-url`).
//! - A request from a browser (it carries `Origin` or `Sec-Fetch-Site`) that changes state
//!   must come from the server's own origin or one the operator allowed (`--allow-origin`),
//!   and must send JSON where the route takes JSON (a cross-site form or `text/plain`
//!   `fetch` needs no CORS preflight).

use std::net::IpAddr;
use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{HeaderMap, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::ApiError;

/// What a server answers to, and which routes take bytes rather than JSON.
#[derive(Clone, Debug)]
pub struct BrowserGuard {
    names: Vec<String>,
    origins: Vec<String>,
    raw_body_paths: &'static [&'static str],
}

impl BrowserGuard {
    /// `public_urls`: the URLs the server is reached at (their host names are accepted in
    /// `Host`); `allowed_origins`: other origins (`scheme://host[:port]`) whose pages may
    /// change state; `raw_body_paths`: path prefixes whose bodies are not JSON (uploads).
    pub fn new(
        public_urls: &[&str],
        allowed_origins: &[String],
        raw_body_paths: &'static [&'static str],
    ) -> Self {
        let names = public_urls
            .iter()
            .filter_map(|url| url::Url::parse(url).ok()?.host_str().map(str::to_ascii_lowercase))
            .collect();
        let origins =
            allowed_origins.iter().map(|o| o.trim_end_matches('/').to_ascii_lowercase()).collect();
        Self { names, origins, raw_body_paths }
    }

    /// Why a request is refused, if it is.
    pub fn check(&self, method: &Method, path: &str, headers: &HeaderMap) -> Result<(), ApiError> {
        let refuse =
            |code, message: String| Err(ApiError::new(StatusCode::FORBIDDEN, code, message));
        let host = headers.get(header::HOST).and_then(|h| h.to_str().ok()).unwrap_or("");
        if !self.answers_to(host) {
            return refuse(
                "bad-host",
                format!("this server does not answer to the name {host:?} (see --public-url)"),
            );
        }
        let from_browser =
            headers.contains_key(header::ORIGIN) || headers.contains_key("sec-fetch-site");
        let changes_state = !matches!(*method, Method::GET | Method::HEAD | Method::OPTIONS);
        if !(from_browser && changes_state) {
            return Ok(());
        }
        let origin = headers.get(header::ORIGIN).and_then(|o| o.to_str().ok());
        let same_site = headers.get("sec-fetch-site").and_then(|s| s.to_str().ok());
        let allowed = match origin {
            Some(origin) => self.origin_allowed(origin, host),
            // No Origin but fetch metadata: only the page's own requests pass.
            None => matches!(same_site, Some("same-origin" | "none")),
        };
        if !allowed {
            let origin = origin.unwrap_or("another site");
            return refuse(
                "bad-origin",
                format!(
                    "a page from {origin} may not change this server's state (see --allow-origin)"
                ),
            );
        }
        let raw = self.raw_body_paths.iter().any(|prefix| path.starts_with(prefix));
        if !raw && has_body(headers) && !is_json(headers) {
            return refuse("not-json", "this route takes application/json".to_owned());
        }
        Ok(())
    }

    fn answers_to(&self, host: &str) -> bool {
        let name = host_name(host).to_ascii_lowercase();
        !name.is_empty()
            && (name.parse::<IpAddr>().is_ok() || name == "localhost" || self.names.contains(&name))
    }

    fn origin_allowed(&self, origin: &str, host: &str) -> bool {
        let origin = origin.to_ascii_lowercase();
        let authority = origin.split_once("://").map_or("", |(_, rest)| rest);
        authority == host.to_ascii_lowercase() || self.origins.contains(&origin)
    }
}

/// The name in a `Host` value: `name`, `name:port`, `[v6]:port`.
fn host_name(host: &str) -> &str {
    if let Some(rest) = host.strip_prefix('[') {
        return rest.split(']').next().unwrap_or("");
    }
    host.rsplit_once(':').map_or(host, |(name, _)| name)
}

fn has_body(headers: &HeaderMap) -> bool {
    let length = headers.get(header::CONTENT_LENGTH).and_then(|l| l.to_str().ok());
    headers.contains_key(header::TRANSFER_ENCODING) || length.is_some_and(|l| l.trim() != "0")
}

fn is_json(headers: &HeaderMap) -> bool {
    let kind = headers.get(header::CONTENT_TYPE).and_then(|t| t.to_str().ok()).unwrap_or("");
    let essence = kind.split(';').next().unwrap_or("").trim().to_ascii_lowercase();
    essence == "application/json"
}

/// The guard as an axum middleware (`axum::middleware::from_fn_with_state`).
pub async fn guard(
    State(guard): State<Arc<BrowserGuard>>,
    request: Request,
    next: Next,
) -> Response {
    match guard.check(request.method(), request.uri().path(), request.headers()) {
        Ok(()) => next.run(request).await,
        Err(refusal) => refusal.into_response(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
        let mut map = HeaderMap::new();
        for (name, value) in pairs {
            map.insert(*name, value.parse().unwrap());
        }
        map
    }

    fn guard() -> BrowserGuard {
        BrowserGuard::new(
            &["https://engine.lab.example"],
            &["https://portal.lab.example".into()],
            &["/inputs"],
        )
    }

    fn code(method: Method, path: &str, pairs: &[(&'static str, &str)]) -> Option<&'static str> {
        guard().check(&method, path, &headers(pairs)).err().map(|e| e.code)
    }

    #[test]
    fn host_names_must_be_ours() {
        assert_eq!(code(Method::GET, "/runs", &[("host", "127.0.0.1:7000")]), None);
        assert_eq!(code(Method::GET, "/runs", &[("host", "[::1]:7000")]), None);
        assert_eq!(code(Method::GET, "/runs", &[("host", "localhost:7000")]), None);
        assert_eq!(code(Method::GET, "/runs", &[("host", "engine.lab.example")]), None);
        assert_eq!(
            code(Method::GET, "/runs", &[("host", "rebind.evil.example")]),
            Some("bad-host")
        );
        assert_eq!(code(Method::GET, "/runs", &[]), Some("bad-host"));
    }

    #[test]
    fn cross_site_writes_are_refused() {
        let evil = [
            ("host", "127.0.0.1:7000"),
            ("origin", "http://evil.example"),
            ("content-type", "text/plain"),
            ("content-length", "20"),
        ];
        assert_eq!(code(Method::POST, "/runs", &evil), Some("bad-origin"));
        let same = [
            ("host", "127.0.0.1:7000"),
            ("origin", "http://127.0.0.1:7000"),
            ("content-type", "application/json"),
            ("content-length", "20"),
        ];
        assert_eq!(code(Method::POST, "/runs", &same), None);
        let plain = [
            ("host", "127.0.0.1:7000"),
            ("origin", "http://127.0.0.1:7000"),
            ("content-type", "text/plain;charset=UTF-8"),
            ("content-length", "20"),
        ];
        assert_eq!(code(Method::POST, "/runs", &plain), Some("not-json"));
        assert_eq!(code(Method::POST, "/inputs?name=a.ply", &plain), None);
        let portal = [
            ("host", "engine.lab.example"),
            ("origin", "https://portal.lab.example"),
            ("content-type", "application/json"),
            ("content-length", "2"),
        ];
        assert_eq!(code(Method::POST, "/runs", &portal), None);
        let cross = [("host", "127.0.0.1:7000"), ("sec-fetch-site", "cross-site")];
        assert_eq!(code(Method::POST, "/runs/x/cancel", &cross), Some("bad-origin"));
        // A page may read (CORS keeps the answer from another site's script), and a client
        // that is not a browser sends neither header.
        assert_eq!(
            code(
                Method::GET,
                "/runs",
                &[("host", "127.0.0.1:7000"), ("origin", "http://evil.example")]
            ),
            None
        );
        assert_eq!(
            code(
                Method::POST,
                "/runs",
                &[
                    ("host", "127.0.0.1:7000"),
                    ("content-type", "text/plain"),
                    ("content-length", "3")
                ]
            ),
            None
        );
    }
}
