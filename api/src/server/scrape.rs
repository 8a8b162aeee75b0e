//! Who may read a server's `/metrics` (DESIGN §11): its own machine, or a scraper with the
//! metrics token.

use std::net::SocketAddr;

use axum::http::{HeaderMap, StatusCode, header};

use super::{ApiError, bearer, require};

/// Who may read `/metrics`: a client on the loopback (a scraper or an operator on the
/// machine) as it is; anyone else with the metrics token as a bearer token, and nobody
/// else when there is no metrics token. A loopback request that says it was forwarded
/// (`Forwarded`, `X-Forwarded-For`) came through a proxy from elsewhere: it needs the token.
pub fn may_scrape(
    peer: Option<SocketAddr>,
    headers: &HeaderMap,
    token: Option<&str>,
) -> Result<(), ApiError> {
    let forwarded =
        headers.contains_key(header::FORWARDED) || headers.contains_key("x-forwarded-for");
    if peer.is_some_and(|peer| peer.ip().is_loopback()) && !forwarded {
        return Ok(());
    }
    let Some(token) = token else {
        return Err(ApiError::new(
            StatusCode::FORBIDDEN,
            "metrics-loopback-only",
            "metrics are served to loopback clients only: start the server with a metrics token \
             (--metrics-token-file) to serve them elsewhere",
        ));
    };
    require(bearer(headers), &[token], "the metrics token").map_err(|refused| {
        ApiError::new(StatusCode::UNAUTHORIZED, "unauthorized", refused.to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOKEN: &str = "metrics-token-0123456789";

    fn with_bearer(token: &str) -> HeaderMap {
        let mut headers = HeaderMap::new();
        headers.insert(header::AUTHORIZATION, format!("Bearer {token}").parse().unwrap());
        headers
    }

    #[test]
    fn loopback_scrapes_freely_and_others_need_the_metrics_token() {
        let none = HeaderMap::new();
        for loopback in ["127.0.0.1:50000", "[::1]:50000"] {
            let peer = Some(loopback.parse().unwrap());
            assert!(may_scrape(peer, &none, None).is_ok());
            assert!(may_scrape(peer, &none, Some(TOKEN)).is_ok());
        }
        let remote: Option<SocketAddr> = Some("192.0.2.7:50000".parse().unwrap());
        let status = |r: Result<(), ApiError>| r.map_err(|e| e.status.as_u16());
        assert_eq!(status(may_scrape(remote, &none, None)), Err(403));
        assert_eq!(status(may_scrape(remote, &with_bearer(TOKEN), None)), Err(403));
        assert_eq!(status(may_scrape(remote, &none, Some(TOKEN))), Err(401));
        assert_eq!(
            status(may_scrape(remote, &with_bearer("not-the-token"), Some(TOKEN))),
            Err(401)
        );
        assert_eq!(status(may_scrape(remote, &with_bearer(TOKEN), Some(TOKEN))), Ok(()));
        // No peer address known: not loopback.
        assert_eq!(status(may_scrape(None, &none, Some(TOKEN))), Err(401));
        // Through a proxy on the machine: the client is elsewhere.
        let loopback = Some("127.0.0.1:50000".parse().unwrap());
        let mut proxied = HeaderMap::new();
        proxied.insert("x-forwarded-for", "192.0.2.7".parse().unwrap());
        assert_eq!(status(may_scrape(loopback, &proxied, Some(TOKEN))), Err(401));
        proxied.insert(header::AUTHORIZATION, format!("Bearer {TOKEN}").parse().unwrap());
        assert_eq!(status(may_scrape(loopback, &proxied, Some(TOKEN))), Ok(()));
    }
}
