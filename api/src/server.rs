//! What the engine and host servers share: the accept loop with its timeouts, bearer-token
//! checks, and the refusal to listen openly without tokens.
//!
//! `axum::serve` has no header timeout, so a client that sends half a request head would
//! hold a connection forever; here hyper reads headers under [`HEADER_READ_TIMEOUT`] and
//! every request body under an idle limit ([`BODY_IDLE_TIMEOUT`]).

use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::server::graceful::GracefulShutdown;
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio_util::either::Either;
use tower_http::timeout::RequestBodyTimeout;

use crate::host::{ErrorBody, ErrorDetail};

mod browser;
mod json_errors;
mod scrape;
pub mod throwaway;
mod tls;
pub use browser::{BrowserGuard, guard as browser_guard};
pub use json_errors::json_errors;
pub use scrape::may_scrape;
pub use tls::TlsFiles;

/// A connection whose request head has not fully arrived after this long is closed.
pub const HEADER_READ_TIMEOUT: Duration = Duration::from_secs(10);
/// A request body that sends nothing for this long fails (the handler sees an error).
pub const BODY_IDLE_TIMEOUT: Duration = Duration::from_secs(30);
/// After shutdown is asked for, connections still open after this long are dropped.
pub const SHUTDOWN_GRACE: Duration = Duration::from_secs(10);
/// A failed `accept` (e.g. out of file descriptors) is retried after this pause.
const ACCEPT_RETRY: Duration = Duration::from_millis(100);

/// Serves `app` on `listener` until `shutdown` completes, then lets requests in flight finish
/// (up to [`SHUTDOWN_GRACE`]).
pub async fn serve(
    listener: TcpListener,
    app: Router,
    shutdown: impl Future<Output = ()>,
) -> std::io::Result<()> {
    serve_with(listener, app, None, shutdown).await
}

/// [`serve`], over TLS when `tls` is given: the handshake must end within
/// [`HEADER_READ_TIMEOUT`], as a request head must.
pub async fn serve_with(
    listener: TcpListener,
    app: Router,
    tls: Option<Arc<rustls::ServerConfig>>,
    shutdown: impl Future<Output = ()>,
) -> std::io::Result<()> {
    let graceful = GracefulShutdown::new();
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new()).header_read_timeout(HEADER_READ_TIMEOUT);
    let acceptor = tls.map(tokio_rustls::TlsAcceptor::from);
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(accepted) => accepted,
                Err(error) => {
                    tracing::warn!("accepting a connection: {error}");
                    tokio::time::sleep(ACCEPT_RETRY).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        let service =
            TowerToHyperService::new(RequestBodyTimeout::new(app.clone(), BODY_IDLE_TIMEOUT));
        // The peer's address, for handlers that extract `ConnectInfo<SocketAddr>` (who may
        // read `/metrics` without a token).
        let service = hyper::service::service_fn(move |mut request: hyper::Request<_>| {
            request.extensions_mut().insert(axum::extract::ConnectInfo(peer));
            hyper::service::Service::call(&service, request)
        });
        let (http, watcher, acceptor) = (http.clone(), graceful.watcher(), acceptor.clone());
        tokio::spawn(async move {
            let stream = match acceptor {
                None => Either::Left(stream),
                Some(acceptor) => {
                    match tokio::time::timeout(HEADER_READ_TIMEOUT, acceptor.accept(stream)).await {
                        Ok(Ok(stream)) => Either::Right(stream),
                        // A client that cannot finish a handshake ends only its own connection.
                        _ => return,
                    }
                }
            };
            // A client that goes away or times out ends only its own connection.
            let _ = watcher.watch(http.serve_connection(TokioIo::new(stream), service)).await;
        });
    }
    drop(listener);
    if tokio::time::timeout(SHUTDOWN_GRACE, graceful.shutdown()).await.is_err() {
        tracing::warn!("connections still open after {} s were dropped", SHUTDOWN_GRACE.as_secs());
    }
    Ok(())
}

/// The bearer token of a request, if it has one.
pub fn bearer(headers: &HeaderMap) -> Option<&str> {
    headers.get(header::AUTHORIZATION)?.to_str().ok()?.strip_prefix("Bearer ")
}

/// Compares a given token with an expected one in time that does not depend on where they
/// differ (by comparing their hashes).
pub fn token_matches(given: &str, expected: &str) -> bool {
    blake3::hash(given.as_bytes()) == blake3::hash(expected.as_bytes())
}

/// A request without a token its route takes; answered 401 `unauthorized`.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Unauthorized(String);

impl IntoResponse for Unauthorized {
    fn into_response(self) -> Response {
        let mut response =
            ApiError::new(StatusCode::UNAUTHORIZED, "unauthorized", self.0).into_response();
        // The request's body was never read: the connection cannot carry another request,
        // so tell the client not to put it back in its pool.
        response
            .headers_mut()
            .insert(axum::http::header::CONNECTION, axum::http::HeaderValue::from_static("close"));
        response
    }
}

/// Checks `given` against the tokens a route takes (`what` names them). No tokens: the
/// route is open.
pub fn require(given: Option<&str>, accepted: &[&str], what: &str) -> Result<(), Unauthorized> {
    if accepted.is_empty() || given.is_some_and(|g| accepted.iter().any(|t| token_matches(g, t))) {
        return Ok(());
    }
    Err(Unauthorized(match given {
        None => format!("this route needs {what} as a bearer token"),
        Some(_) => format!("the bearer token is not {what}"),
    }))
}

/// An error answer of either server: a status, a kebab-case code and a human message, sent
/// as `{"error": {"code", "message"}}`; a 429 says when to come back (`Retry-After`).
#[derive(Debug)]
pub struct ApiError {
    pub status: StatusCode,
    pub code: &'static str,
    pub message: String,
    /// Sent as `Retry-After` (whole seconds) with a 429.
    pub retry_after: Option<Duration>,
}

impl ApiError {
    pub fn new(status: StatusCode, code: &'static str, message: impl Into<String>) -> Self {
        Self { status, code, message: message.into(), retry_after: None }
    }

    pub fn bad_request(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, code, message)
    }

    pub fn conflict(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::CONFLICT, code, message)
    }

    pub fn internal(message: impl std::fmt::Display) -> Self {
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", message.to_string())
    }

    /// A 429 that says when to come back.
    pub fn busy(code: &'static str, message: impl Into<String>, retry_after: Duration) -> Self {
        Self {
            retry_after: Some(retry_after),
            ..Self::new(StatusCode::TOO_MANY_REQUESTS, code, message)
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body =
            ErrorBody { error: ErrorDetail { code: self.code.to_owned(), message: self.message } };
        let mut response = (self.status, axum::Json(body)).into_response();
        if let Some(after) =
            self.retry_after.filter(|_| self.status == StatusCode::TOO_MANY_REQUESTS)
        {
            response.headers_mut().insert(header::RETRY_AFTER, after.as_secs().into());
        }
        response
    }
}

/// Why a server will not start.
#[derive(Debug, thiserror::Error)]
#[error(
    "refusing to listen on {address} without {missing}: anyone who can reach it could use it. \
     Give the token(s), listen on a loopback address, or pass --insecure-no-auth"
)]
pub struct Exposed {
    pub address: SocketAddr,
    pub missing: String,
}

/// A server without some of its tokens listens only on loopback, unless `insecure`.
pub fn check_exposure(
    address: SocketAddr,
    missing: &[&str],
    insecure: bool,
) -> Result<(), Exposed> {
    if missing.is_empty() || insecure || address.ip().is_loopback() {
        return Ok(());
    }
    Err(Exposed { address, missing: missing.join(" and ") })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_are_required_only_where_set() {
        assert!(require(None, &[], "the API token").is_ok());
        assert!(require(Some("a"), &["a", "b"], "x").is_ok());
        assert!(require(Some("b"), &["a", "b"], "x").is_ok());
        let refused = require(Some("c"), &["a"], "x").unwrap_err();
        assert_eq!(refused.into_response().status(), 401);
        assert!(require(None, &["a"], "x").is_err());
    }

    #[test]
    fn open_servers_stay_on_loopback() {
        let public: SocketAddr = "0.0.0.0:7000".parse().unwrap();
        let loopback: SocketAddr = "127.0.0.1:7000".parse().unwrap();
        assert!(check_exposure(public, &["the cluster token"], false).is_err());
        assert!(check_exposure(public, &["the cluster token"], true).is_ok());
        assert!(check_exposure(loopback, &["the cluster token"], false).is_ok());
        assert!(check_exposure(public, &[], false).is_ok());
    }
}
