//! `HostClient`: the host HTTP API from Rust (async, reqwest), for the engine and the CLI.

use futures_util::StreamExt;
use reqwest::{Method, RequestBuilder, Response, StatusCode};
use serde::de::DeserializeOwned;

use crate::host::{
    CreateSession, ErrorBody, Health, InputRef, PluginEntry, RunRequest, RunResult, ServiceEntry,
    SessionCreated, SessionStatus, Update, Updated, UploadedPlugin,
};

/// What went wrong with a request: the host's answer (status, code, message) or the
/// transport.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error("{url}: HTTP {status} {code}: {message}")]
    Api { url: String, status: u16, code: String, message: String },
    #[error("{url}: {message}")]
    Transport { url: String, message: String },
    #[error("{url}: the download is larger than the limit of {limit} bytes")]
    TooLarge { url: String, limit: u64 },
}

impl ClientError {
    /// The HTTP status the host answered with, if it answered.
    pub fn status(&self) -> Option<u16> {
        match self {
            ClientError::Api { status, .. } => Some(*status),
            _ => None,
        }
    }

    /// The host's error code (`plugin-failed`, `session-busy`, ...), if it answered.
    pub fn code(&self) -> Option<&str> {
        match self {
            ClientError::Api { code, .. } => Some(code),
            _ => None,
        }
    }

    fn transport(url: &str, error: reqwest::Error) -> Self {
        // reqwest's own message hides the cause ("error sending request"): add the chain.
        let mut message = error.to_string();
        let mut source = std::error::Error::source(&error);
        while let Some(cause) = source {
            message = format!("{message}: {cause}");
            source = cause.source();
        }
        ClientError::Transport { url: url.to_owned(), message }
    }
}

/// A client of one host, e.g. `HostClient::new("http://127.0.0.1:7000")`.
#[derive(Clone, Debug)]
pub struct HostClient {
    base: String,
    http: reqwest::Client,
}

impl HostClient {
    pub fn new(base_url: &str) -> Self {
        Self::with_client(base_url, reqwest::Client::new())
    }

    /// Shares a connection pool (and its timeouts) with other clients.
    pub fn with_client(base_url: &str, http: reqwest::Client) -> Self {
        Self { base: base_url.trim_end_matches('/').to_owned(), http }
    }

    pub fn base_url(&self) -> &str {
        &self.base
    }

    pub async fn health(&self) -> Result<Health, ClientError> {
        self.json(Method::GET, "/health", |r| r).await
    }

    pub async fn services(&self) -> Result<Vec<ServiceEntry>, ClientError> {
        self.json(Method::GET, "/services", |r| r).await
    }

    pub async fn plugins(&self) -> Result<Vec<PluginEntry>, ClientError> {
        self.json(Method::GET, "/plugins", |r| r).await
    }

    /// Uploads a component; `token` is the host's `--token`.
    pub async fn upload_plugin(
        &self,
        wasm: Vec<u8>,
        token: Option<&str>,
    ) -> Result<UploadedPlugin, ClientError> {
        self.json(Method::POST, "/plugins", |r| authorized(r, token).body(wasm)).await
    }

    pub async fn delete_plugin(
        &self,
        digest: &str,
        token: Option<&str>,
    ) -> Result<(), ClientError> {
        let path = format!("/plugins/{digest}");
        self.empty(Method::DELETE, &path, |r| authorized(r, token)).await
    }

    /// Starts a session from a mesh at `url`; it loads in the background.
    pub async fn create_session(
        &self,
        url: &str,
        expected_hash: Option<&str>,
    ) -> Result<SessionCreated, ClientError> {
        let body = CreateSession {
            input: InputRef { url: url.to_owned(), hash: expected_hash.map(str::to_owned) },
        };
        self.json(Method::POST, "/sessions", |r| r.json(&body)).await
    }

    pub async fn session(&self, id: &str) -> Result<SessionStatus, ClientError> {
        self.json(Method::GET, &format!("/sessions/{id}"), |r| r).await
    }

    /// The session's status once it is no longer loading (the host waits up to ~60 s;
    /// this asks again until then).
    pub async fn wait_ready(&self, id: &str) -> Result<SessionStatus, ClientError> {
        loop {
            let status: SessionStatus =
                self.json(Method::GET, &format!("/sessions/{id}?wait=ready"), |r| r).await?;
            if status.state != crate::host::SessionState::Loading {
                return Ok(status);
            }
        }
    }

    pub async fn update(&self, id: &str, update: &Update) -> Result<Updated, ClientError> {
        self.json(Method::POST, &format!("/sessions/{id}/update"), |r| r.json(update)).await
    }

    pub async fn run(&self, id: &str, request: &RunRequest) -> Result<RunResult, ClientError> {
        self.json(Method::POST, &format!("/sessions/{id}/run"), |r| r.json(request)).await
    }

    pub async fn delete_session(&self, id: &str) -> Result<(), ClientError> {
        self.empty(Method::DELETE, &format!("/sessions/{id}"), |r| r).await
    }

    /// The size of a blob (any URL), by `HEAD`.
    pub async fn blob_size(&self, url: &str) -> Result<u64, ClientError> {
        let response = send(self.http.head(url), url).await?;
        // Not `content_length()`: for a HEAD answer that is the empty body's length.
        let length = response.headers().get(reqwest::header::CONTENT_LENGTH);
        length.and_then(|v| v.to_str().ok()?.parse().ok()).ok_or_else(|| ClientError::Transport {
            url: url.to_owned(),
            message: "no valid Content-Length in the answer".into(),
        })
    }

    /// The bytes at any URL (a blob of some host, an input).
    pub async fn download(&self, url: &str) -> Result<Vec<u8>, ClientError> {
        fetch(&self.http, url, u64::MAX).await
    }

    async fn json<T: DeserializeOwned>(
        &self,
        method: Method,
        path: &str,
        build: impl FnOnce(RequestBuilder) -> RequestBuilder,
    ) -> Result<T, ClientError> {
        let url = format!("{}{path}", self.base);
        let response = send(build(self.http.request(method, &url)), &url).await?;
        response.json().await.map_err(|e| ClientError::transport(&url, e))
    }

    async fn empty(
        &self,
        method: Method,
        path: &str,
        build: impl FnOnce(RequestBuilder) -> RequestBuilder,
    ) -> Result<(), ClientError> {
        let url = format!("{}{path}", self.base);
        send(build(self.http.request(method, &url)), &url).await.map(drop)
    }
}

fn authorized(request: RequestBuilder, token: Option<&str>) -> RequestBuilder {
    match token {
        Some(token) => request.bearer_auth(token),
        None => request,
    }
}

/// Sends a request; an error status becomes [`ClientError::Api`] with the host's code and
/// message (or the body's text when it is not a host error).
async fn send(request: RequestBuilder, url: &str) -> Result<Response, ClientError> {
    let response = request.send().await.map_err(|e| ClientError::transport(url, e))?;
    let status = response.status();
    if status.is_success() {
        return Ok(response);
    }
    let text = response.text().await.unwrap_or_default();
    let (code, message) = match serde_json::from_str::<ErrorBody>(&text) {
        Ok(body) => (body.error.code, body.error.message),
        Err(_) => (code_of(status), text),
    };
    Err(ClientError::Api { url: url.to_owned(), status: status.as_u16(), code, message })
}

fn code_of(status: StatusCode) -> String {
    status.canonical_reason().unwrap_or("error").to_lowercase().replace(' ', "-")
}

/// Downloads `url` into memory, refusing more than `limit` bytes (checked against the
/// announced length first, then while reading).
pub async fn fetch(http: &reqwest::Client, url: &str, limit: u64) -> Result<Vec<u8>, ClientError> {
    let response = send(http.get(url), url).await?;
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
