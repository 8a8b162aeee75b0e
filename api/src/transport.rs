//! What both clients share: one base URL over a connection pool, the sending of a request
//! and the typing of its failure ([`ClientError`]), and size-capped downloads.

use std::time::Duration;

use futures_util::StreamExt;
use reqwest::header::{ACCEPT_ENCODING, CONTENT_ENCODING, HeaderMap};
use reqwest::{Method, RequestBuilder, Response, StatusCode};
use serde::de::DeserializeOwned;

use crate::fetch_rules::{FetchScope, Refusal, quoted};
use crate::host::ErrorBody;

/// What went wrong with a request, typed by what a caller does about it: a host that is
/// [`Unreachable`](Self::Unreachable), too slow ([`Timeout`](Self::Timeout)) or broken
/// ([`Server`](Self::Server), [`Protocol`](Self::Protocol)) may be replaced by another; a
/// [`Refused`](Self::Refused) request would fail the same way anywhere.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error("{url}: cannot connect: {message}")]
    Unreachable { url: String, message: String },
    #[error("{url}: timed out: {message}")]
    Timeout { url: String, message: String },
    /// The host refused the request itself (bad parameters, a failing plugin, an input it
    /// could not fetch): HTTP 4xx, or 502 for a download the request pointed it to.
    #[error("{url}: HTTP {status} {code}: {message}")]
    Refused { url: String, status: u16, code: String, message: String },
    /// The host failed (HTTP 5xx).
    #[error("{url}: HTTP {status} {code}: {message}")]
    Server { url: String, status: u16, code: String, message: String },
    /// The answer was cut off or not what the API promises.
    #[error("{url}: {message}")]
    Protocol { url: String, message: String },
    #[error("{url}: the download is larger than the limit of {limit} bytes")]
    TooLarge { url: String, limit: u64 },
    /// The server is busy (HTTP 429): ask again after `retry_after`, or elsewhere.
    #[error("{url}: busy: {message}")]
    Busy { url: String, retry_after: Option<Duration>, message: String },
    /// A token would have crossed plain http beyond loopback (see [`crate::tls`]).
    #[error("{url}: {message}")]
    PlainHttp { url: String, message: String },
    /// The URL (or a redirect's target) is not one the fetch rules allow.
    #[error(transparent)]
    NotAllowed(#[from] Refusal),
}

/// How long a client tries to connect before the server counts as unreachable.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// The whole of a quick query (health, services, plugins, a session's status): a server
/// that accepts but does not answer in this time counts as timed out, so one hung host
/// cannot stall whoever polls it.
pub const QUERY_TIMEOUT: Duration = Duration::from_secs(5);

/// The whole of a call that makes a host work: a step (its run deadline and its wait for a
/// run slot), an update (a download and a replay), a wait for a session to load, a blob
/// or plugin transfer. Generous, so no legitimate call hits it; bounded, so a host that
/// accepts and never answers cannot hold a run for ever.
pub const WORK_TIMEOUT: Duration = Duration::from_secs(15 * 60);

/// One long poll of a loading session: the host answers within its own limit (60 s).
pub const LONG_POLL_TIMEOUT: Duration = Duration::from_secs(90);

/// A connection pool with [`CONNECT_TIMEOUT`]. Steps and transfers get no overall deadline
/// here: a host bounds their work by its own run deadline and download limits.
pub(crate) fn default_client() -> reqwest::Client {
    crate::tls::client_builder()
        .connect_timeout(CONNECT_TIMEOUT)
        .build()
        .expect("a client with only a connect timeout builds")
}

/// The pause before an idempotent request whose connection was dropped is sent once more.
pub const DROPPED_RETRY_PAUSE: Duration = Duration::from_millis(100);

/// Error bodies are read up to this size; the rest is not kept.
pub const MAX_ERROR_BODY_BYTES: usize = 16 << 10;

/// Redirects [`fetch_compressible`] follows, each checked against the fetch rules.
pub const MAX_REDIRECTS: usize = 5;
/// The largest JSON answer a client reads (a host's services or run result, an engine's run
/// record): far above any real one, and what a lying server can make it hold.
pub const MAX_JSON_ANSWER_BYTES: u64 = 64 << 20;

impl ClientError {
    /// Whether another host might succeed where this one failed: it could not be reached,
    /// timed out, broke, or answered nonsense.
    pub fn is_host_failure(&self) -> bool {
        matches!(
            self,
            Self::Unreachable { .. }
                | Self::Timeout { .. }
                | Self::Server { .. }
                | Self::Protocol { .. }
        )
    }

    fn transport(url: &str, error: reqwest::Error) -> Self {
        // reqwest's own message hides the cause ("error sending request"): add the chain.
        // The URL is said once, by the caller, quoted.
        let error = error.without_url();
        let mut message = error.to_string();
        let mut source = std::error::Error::source(&error);
        while let Some(cause) = source {
            message = format!("{message}: {cause}");
            source = cause.source();
        }
        let url = url.to_owned();
        if error.is_timeout() {
            ClientError::Timeout { url, message }
        } else if error.is_connect() {
            ClientError::Unreachable { url, message }
        } else {
            ClientError::Protocol { url, message }
        }
    }
}

/// A server's base URL, the pool its requests go through and the bearer token they carry.
#[derive(Clone, Debug)]
pub(crate) struct Endpoint {
    pub base: String,
    pub http: reqwest::Client,
    pub token: Option<String>,
}

impl Endpoint {
    pub fn new(base_url: &str, http: reqwest::Client) -> Self {
        Self { base: base_url.trim_end_matches('/').to_owned(), http, token: None }
    }

    /// A request to `url` with this endpoint's token.
    pub fn request(&self, method: Method, url: &str) -> RequestBuilder {
        authorized(self.http.request(method, url), self.token.as_deref())
    }

    pub async fn json<T: DeserializeOwned>(
        &self,
        method: Method,
        path: &str,
        build: impl FnOnce(RequestBuilder) -> RequestBuilder,
    ) -> Result<T, ClientError> {
        let url = format!("{}{path}", self.base);
        let response = send(build(self.request(method, &url)), &url).await?;
        // A server answering more than any answer can hold is broken or lying: a failure of
        // that server (the engine tries another host), not of the request.
        let body =
            read_capped(response, &url, MAX_JSON_ANSWER_BYTES).await.map_err(|e| match e {
                ClientError::TooLarge { url, limit } => {
                    ClientError::Protocol { url, message: format!("an answer over {limit} bytes") }
                }
                other => other,
            })?;
        serde_json::from_slice(&body).map_err(|e| ClientError::Protocol {
            url: url.clone(),
            message: format!("the answer is not the JSON expected: {e}"),
        })
    }

    pub async fn empty(
        &self,
        method: Method,
        path: &str,
        build: impl FnOnce(RequestBuilder) -> RequestBuilder,
    ) -> Result<(), ClientError> {
        let url = format!("{}{path}", self.base);
        send(build(self.request(method, &url)), &url).await.map(drop)
    }
}

pub(crate) fn authorized(request: RequestBuilder, token: Option<&str>) -> RequestBuilder {
    match token {
        Some(token) => request.bearer_auth(token),
        None => request,
    }
}

/// Sends a request; an error status becomes [`ClientError::Busy`] (429),
/// [`ClientError::Refused`] or [`ClientError::Server`] with the host's code and message (or the start of the body's
/// text when it is not a host error).
pub(crate) async fn send(request: RequestBuilder, url: &str) -> Result<Response, ClientError> {
    let (client, request) = request.build_split();
    let request = request.map_err(|e| ClientError::transport(url, e))?;
    if request.headers().contains_key(reqwest::header::AUTHORIZATION)
        && let Some(message) = crate::tls::plain_http_refusal(request.url())
    {
        return Err(ClientError::PlainHttp { url: url.to_owned(), message });
    }
    let idempotent = matches!(*request.method(), Method::GET | Method::HEAD | Method::DELETE);
    let again = if idempotent { request.try_clone() } else { None };
    let response = match (client.execute(request).await, again) {
        // The connection was dropped under the request (reset, closed before an answer):
        // servers do that under load or as they restart, and asking an idempotent request
        // once more is what a browser does. Not after a timeout or a refused connection.
        (Err(e), Some(again)) if e.is_request() && !e.is_connect() && !e.is_timeout() => {
            tokio::time::sleep(DROPPED_RETRY_PAUSE).await;
            client.execute(again).await
        }
        (first, _) => first,
    };
    let response = response.map_err(|e| ClientError::transport(url, e))?;
    let status = response.status();
    if status.is_success() {
        return Ok(response);
    }
    let retry_after = retry_after(&response);
    let text = error_text(response).await;
    let (code, message) = match serde_json::from_str::<ErrorBody>(&text) {
        Ok(body) => (body.error.code, body.error.message),
        Err(_) => (code_of(status), text),
    };
    if status == StatusCode::TOO_MANY_REQUESTS {
        return Err(ClientError::Busy { url: url.to_owned(), retry_after, message });
    }
    Err(status_error(url, status, code, message))
}

/// A `Retry-After` in whole seconds (the HTTP-date form is not used by our servers).
fn retry_after(response: &Response) -> Option<Duration> {
    let value = response.headers().get(reqwest::header::RETRY_AFTER)?;
    value.to_str().ok()?.trim().parse().ok().map(Duration::from_secs)
}

/// An error status as a [`ClientError`]: refused (4xx, and 502 for a download the request
/// pointed the server to) or a server failure (other 5xx).
fn status_error(url: &str, status: StatusCode, code: String, message: String) -> ClientError {
    let (url, status) = (url.to_owned(), status.as_u16());
    if status == StatusCode::BAD_GATEWAY.as_u16() || status < 500 {
        ClientError::Refused { url, status, code, message }
    } else {
        ClientError::Server { url, status, code, message }
    }
}

/// The start of an error body, at most [`MAX_ERROR_BODY_BYTES`], as text.
async fn error_text(response: Response) -> String {
    let mut kept = Vec::new();
    let mut body = response.bytes_stream();
    while let Some(Ok(chunk)) = body.next().await {
        kept.extend_from_slice(&chunk[..chunk.len().min(MAX_ERROR_BODY_BYTES - kept.len())]);
        if kept.len() == MAX_ERROR_BODY_BYTES {
            break;
        }
    }
    String::from_utf8_lossy(&kept).into_owned()
}

fn code_of(status: StatusCode) -> String {
    status.canonical_reason().unwrap_or("error").to_lowercase().replace(' ', "-")
}

/// Downloads `url` into memory within `deadline`, refusing more than `limit` bytes (see
/// [`read_capped`]). The URL and every redirect's target must pass `scope`, and only
/// cluster origins get the cluster token. The URL may be anyone's: an error answer's body is
/// neither read nor repeated, only its status, and the URL is quoted ([`quoted`]).
///
/// The body is asked for zstd-compressed (`Accept-Encoding: zstd`): a host sends a plugin
/// so, a third of its bytes. It is decompressed here, held to `limit` bytes compressed and
/// again decompressed; a server that ignores the header is read as it answers, and any
/// other content coding is refused.
pub async fn fetch_compressible(
    http: &reqwest::Client,
    url: &str,
    scope: &FetchScope,
    limit: u64,
    deadline: Duration,
) -> Result<Vec<u8>, ClientError> {
    let fetched = async {
        let (response, shown) = fetch_response_with(http, url, scope, Some("zstd")).await?;
        let coding = response.headers().get(CONTENT_ENCODING).cloned();
        let body = read_capped(response, &shown, limit).await?;
        let protocol = |message: String| ClientError::Protocol { url: shown.clone(), message };
        match coding.as_ref().map(|c| c.to_str().map(str::trim)) {
            None => Ok(body),
            Some(Ok(c)) if c.eq_ignore_ascii_case("identity") => Ok(body),
            Some(Ok(c)) if c.eq_ignore_ascii_case("zstd") => {
                tokio::task::spawn_blocking(move || unzstd_capped(&body, limit))
                    .await
                    .map_err(|e| protocol(e.to_string()))?
                    .ok_or_else(|| ClientError::TooLarge { url: shown.clone(), limit })?
                    .map_err(|e| protocol(format!("the zstd body does not decode: {e}")))
            }
            Some(_) => Err(protocol(format!("a content coding other than zstd: {coding:?}"))),
        }
    };
    tokio::time::timeout(deadline, fetched).await.unwrap_or_else(|_| {
        Err(ClientError::Timeout {
            url: quoted(url),
            message: format!("the download took longer than {} s", deadline.as_secs()),
        })
    })
}

/// `compressed` decoded, or `None` once it would exceed `limit` bytes (a small body may
/// decode to gigabytes).
fn unzstd_capped(compressed: &[u8], limit: u64) -> Option<std::io::Result<Vec<u8>>> {
    use std::io::Read;
    let decoder = match zstd::stream::read::Decoder::new(compressed) {
        Ok(decoder) => decoder,
        Err(e) => return Some(Err(e)),
    };
    let mut out = Vec::new();
    if let Err(e) = decoder.take(limit + 1).read_to_end(&mut out) {
        return Some(Err(e));
    }
    (out.len() as u64 <= limit).then_some(Ok(out))
}

/// Whether a request's `Accept-Encoding` takes zstd (a `q` of zero declines it).
pub fn accepts_zstd(headers: &HeaderMap) -> bool {
    let declined = |param: &str| {
        param.strip_prefix("q=").is_some_and(|q| q.trim().parse::<f32>().is_ok_and(|q| q <= 0.0))
    };
    headers
        .get_all(ACCEPT_ENCODING)
        .iter()
        .filter_map(|value| value.to_str().ok())
        .flat_map(|value| value.split(','))
        .any(|item| {
            let mut parts = item.split(';').map(str::trim);
            let coding = parts.next().unwrap_or_default();
            coding.eq_ignore_ascii_case("zstd") && !parts.any(declined)
        })
}

/// The successful answer to a GET of `url` within `scope`, redirects followed and each
/// checked (see [`fetch_compressible`]), with the URL it came from as errors quote it; its body is
/// the caller's to read (and to cap: the announced length is not checked here). No
/// overall deadline: the caller sets one.
pub async fn fetch_response(
    http: &reqwest::Client,
    url: &str,
    scope: &FetchScope,
) -> Result<(Response, String), ClientError> {
    fetch_response_with(http, url, scope, None).await
}

/// [`fetch_response`], asking for a content coding when one is given.
async fn fetch_response_with(
    http: &reqwest::Client,
    url: &str,
    scope: &FetchScope,
    accept_encoding: Option<&'static str>,
) -> Result<(Response, String), ClientError> {
    let mut next = reqwest::Url::parse(url).map_err(|_| Refusal::NotAUrl(quoted(url)))?;
    for _ in 0..=MAX_REDIRECTS {
        scope.allowed.check(&next)?;
        let shown = quoted(next.as_str());
        let token = scope.token_for(&next);
        if let Some(message) = token.and_then(|_| crate::tls::plain_http_refusal(&next)) {
            return Err(ClientError::PlainHttp { url: shown, message });
        }
        let mut request = authorized(http.get(next.clone()), token);
        if let Some(coding) = accept_encoding {
            request = request.header(ACCEPT_ENCODING, coding);
        }
        let response = request.send().await.map_err(|e| ClientError::transport(&shown, e))?;
        let status = response.status();
        if status.is_redirection() {
            let location = response.headers().get(reqwest::header::LOCATION);
            let target = location.and_then(|l| l.to_str().ok()).and_then(|l| next.join(l).ok());
            next = target.ok_or_else(|| ClientError::Protocol {
                url: shown,
                message: format!("the server answered {status} without a usable Location"),
            })?;
            continue;
        }
        if !status.is_success() {
            let message = format!("the server answered {status}");
            return Err(status_error(&shown, status, code_of(status), message));
        }
        return Ok((response, shown));
    }
    Err(ClientError::Protocol {
        url: quoted(url),
        message: format!("more than {MAX_REDIRECTS} redirects"),
    })
}

/// A successful answer's body, refusing more than `limit` bytes (checked against the
/// announced length first, then while reading).
pub(crate) async fn read_capped(
    response: Response,
    url: &str,
    limit: u64,
) -> Result<Vec<u8>, ClientError> {
    let too_large = || ClientError::TooLarge { url: url.to_owned(), limit };
    if response.content_length().is_some_and(|n| n > limit) {
        return Err(too_large());
    }
    let mut bytes = Vec::with_capacity(response.content_length().unwrap_or(0).min(limit) as usize);
    let mut body = response.bytes_stream();
    while let Some(chunk) = body.next().await {
        let chunk = chunk.map_err(|e| ClientError::transport(url, e))?;
        if (bytes.len() + chunk.len()) as u64 > limit {
            return Err(too_large());
        }
        bytes.extend_from_slice(&chunk);
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zstd_is_taken_when_accepted_and_not_declined() {
        let with = |values: &[&str]| {
            let mut headers = HeaderMap::new();
            for v in values {
                headers.append(ACCEPT_ENCODING, v.parse().unwrap());
            }
            accepts_zstd(&headers)
        };
        assert!(with(&["zstd"]) && with(&["gzip, ZSTD;q=0.5"]) && with(&["gzip", "zstd"]));
        assert!(!with(&[]) && !with(&["gzip, br"]) && !with(&["zstd;q=0"]) && !with(&["zstdx"]));
    }

    #[test]
    fn a_zstd_body_decodes_only_within_the_limit() {
        let component: Vec<u8> = (0..300_000u32).map(|i| (i % 251) as u8).collect();
        let packed = zstd::bulk::compress(&component, 9).unwrap();
        assert_eq!(unzstd_capped(&packed, 300_000).unwrap().unwrap(), component);
        // 64 MB of zeros in a few kilobytes: refused at the limit, not decoded whole.
        let bomb = zstd::bulk::compress(&vec![0u8; 64 << 20], 9).unwrap();
        assert!(bomb.len() < 64 << 10, "{} B", bomb.len());
        assert!(unzstd_capped(&bomb, 1 << 20).is_none());
        assert!(unzstd_capped(b"not zstd at all", 1 << 20).unwrap().is_err());
    }
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// A server that resets its first `drops` connections after reading their request, then
    /// answers `200 ok`; the number of connections it saw.
    async fn dropping_server(
        drops: usize,
    ) -> (String, std::sync::Arc<std::sync::atomic::AtomicUsize>) {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}/x", listener.local_addr().unwrap());
        let seen = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let count = seen.clone();
        tokio::spawn(async move {
            loop {
                let (mut socket, _) = listener.accept().await.unwrap();
                let n = count.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                let mut head = [0u8; 4096];
                let _ = socket.read(&mut head).await;
                if n < drops {
                    // Deprecated for blocking on drop; a zero linger resets at once instead.
                    #[allow(deprecated)]
                    socket.set_linger(Some(Duration::ZERO)).unwrap();
                    drop(socket);
                } else {
                    let answer =
                        "HTTP/1.1 200 OK\r\ncontent-length: 2\r\nconnection: close\r\n\r\nok";
                    socket.write_all(answer.as_bytes()).await.unwrap();
                }
            }
        });
        (url, seen)
    }

    #[tokio::test]
    async fn a_json_answer_larger_than_the_cap_is_refused_unread() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let base = format!("http://{}", listener.local_addr().unwrap());
        tokio::spawn(async move {
            let (mut socket, _) = listener.accept().await.unwrap();
            let mut head = [0u8; 4096];
            let _ = socket.read(&mut head).await;
            // Announces a body one byte over the cap and sends a start of it.
            let answer = format!(
                "HTTP/1.1 200 OK\r\ncontent-type: application/json\r\ncontent-length: {}\r\n\r\n{{\"status\": \"",
                MAX_JSON_ANSWER_BYTES + 1
            );
            socket.write_all(answer.as_bytes()).await.unwrap();
            tokio::time::sleep(Duration::from_secs(5)).await;
        });
        let endpoint = Endpoint::new(&base, default_client());
        let answer = endpoint.json::<serde_json::Value>(Method::GET, "/health", |r| r).await;
        let error = answer.unwrap_err();
        assert!(error.is_host_failure(), "{error}");
        assert!(error.to_string().contains("an answer over 67108864 bytes"), "{error}");
    }

    #[tokio::test]
    async fn an_idempotent_request_whose_connection_is_reset_is_sent_once_more() {
        use std::sync::atomic::Ordering::SeqCst;
        let http = default_client();
        let (url, seen) = dropping_server(1).await;
        let answer = send(http.get(&url), &url).await.unwrap();
        assert_eq!(answer.text().await.unwrap(), "ok");
        assert_eq!(seen.load(SeqCst), 2);

        // Not a request that may have had an effect, and only once.
        let (url, seen) = dropping_server(1).await;
        assert!(send(http.post(&url).body("x"), &url).await.is_err());
        assert_eq!(seen.load(SeqCst), 1);
        let (url, seen) = dropping_server(2).await;
        assert!(send(http.get(&url), &url).await.is_err());
        assert_eq!(seen.load(SeqCst), 2);
    }
}
