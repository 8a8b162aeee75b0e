//! `HostClient`: the host HTTP API from Rust (async, reqwest), for the engine and the CLI.

use std::sync::{Arc, RwLock};

use reqwest::Method;

use crate::host::{
    ConvertMesh, CreateSession, Health, InputRef, PluginEntry, PrefetchPlugins, PrefetchedPlugins,
    RunRequest, RunResult, ServiceEntry, SessionCreated, SessionStatus, Update, Updated,
    UploadedPlugin, Vouched, WantedPlugin,
};
use crate::transport::{
    ClientError, Endpoint, LONG_POLL_TIMEOUT, QUERY_TIMEOUT, WORK_TIMEOUT, read_capped, send,
};

/// A client of one host, e.g. `HostClient::new("http://127.0.0.1:7000")`.
#[derive(Clone, Debug)]
pub struct HostClient {
    endpoint: Endpoint,
    access: ClusterAccess,
}

/// What a cluster member sends with its requests to hosts: the cluster token, and the
/// origins of the cluster (the engine and its hosts), which a host may fetch from and send
/// the token to. The engine's registry updates the origins as hosts register; every client
/// made from one `ClusterAccess` sees the change.
#[derive(Clone, Debug, Default)]
pub struct ClusterAccess {
    token: Option<String>,
    peers: Arc<RwLock<Vec<String>>>,
}

impl ClusterAccess {
    pub fn new(token: Option<String>) -> Self {
        Self { token, peers: Arc::default() }
    }

    pub fn token(&self) -> Option<&str> {
        self.token.as_deref()
    }

    /// Replaces the cluster's origins (`scheme://host[:port]`).
    pub fn set_peers(&self, origins: Vec<String>) {
        *self.peers.write().expect("peers lock") = origins;
    }

    fn peers(&self) -> Vec<String> {
        self.peers.read().expect("peers lock").clone()
    }
}

impl HostClient {
    /// A client with its own pool, which gives up connecting after
    /// [`CONNECT_TIMEOUT`](crate::CONNECT_TIMEOUT).
    pub fn new(base_url: &str) -> Self {
        Self::with_client(base_url, crate::transport::default_client())
    }

    /// Shares a connection pool (and its timeouts) with other clients.
    pub fn with_client(base_url: &str, http: reqwest::Client) -> Self {
        Self { endpoint: Endpoint::new(base_url, http), access: ClusterAccess::default() }
    }

    /// Sends the cluster token (`Authorization: Bearer`) with every request.
    pub fn with_token(self, token: &str) -> Self {
        self.with_access(ClusterAccess::new(Some(token.to_owned())))
    }

    /// Sends the cluster token with every request, and the cluster's origins with the
    /// requests that name URLs (sessions, updates).
    pub fn with_access(mut self, access: ClusterAccess) -> Self {
        self.endpoint.token = access.token.clone();
        self.access = access;
        self
    }

    pub fn base_url(&self) -> &str {
        &self.endpoint.base
    }

    pub async fn health(&self) -> Result<Health, ClientError> {
        self.endpoint.json(Method::GET, "/health", |r| r.timeout(QUERY_TIMEOUT)).await
    }

    pub async fn services(&self) -> Result<Vec<ServiceEntry>, ClientError> {
        self.endpoint.json(Method::GET, "/services", |r| r.timeout(QUERY_TIMEOUT)).await
    }

    pub async fn plugins(&self) -> Result<Vec<PluginEntry>, ClientError> {
        self.endpoint.json(Method::GET, "/plugins", |r| r.timeout(QUERY_TIMEOUT)).await
    }

    /// Uploads a component; `token` is the host's upload token (its `--token`), sent
    /// instead of the cluster token. With `replace`, services another plugin offers are
    /// served by this one from now on (else such an upload is refused, 409).
    pub async fn upload_plugin(
        &self,
        wasm: Vec<u8>,
        token: Option<&str>,
        replace: bool,
    ) -> Result<UploadedPlugin, ClientError> {
        let uploads = self.upload_endpoint(token);
        let path = if replace { "/plugins?replace=true" } else { "/plugins" };
        let sent = uploads.json(Method::POST, path, |r| r.timeout(WORK_TIMEOUT).body(wasm)).await;
        match sent {
            // A host that refuses the token answers before reading a large body and closes
            // the connection, so the sender sees a broken pipe, not the refusal: ask again
            // without the body (the upload token may list plugins) to learn the real reason.
            Err(ClientError::Unreachable { .. } | ClientError::Protocol { .. }) => {
                let listed = uploads.json::<Vec<PluginEntry>>(Method::GET, "/plugins", |r| {
                    r.timeout(QUERY_TIMEOUT)
                });
                match listed.await {
                    Err(refused @ ClientError::Refused { .. }) => Err(refused),
                    _ => sent,
                }
            }
            sent => sent,
        }
    }

    pub async fn delete_plugin(
        &self,
        digest: &str,
        token: Option<&str>,
    ) -> Result<(), ClientError> {
        let path = format!("/plugins/{digest}");
        self.upload_endpoint(token).empty(Method::DELETE, &path, |r| r.timeout(QUERY_TIMEOUT)).await
    }

    fn upload_endpoint(&self, token: Option<&str>) -> Endpoint {
        Endpoint { token: token.map(str::to_owned), ..self.endpoint.clone() }
    }

    /// Starts a session from a mesh at `url`; it loads in the background.
    pub async fn create_session(
        &self,
        url: &str,
        expected_hash: Option<&str>,
    ) -> Result<SessionCreated, ClientError> {
        let input = InputRef { url: url.to_owned(), hash: expected_hash.map(str::to_owned) };
        self.create_session_with(CreateSession { input, grid: None }).await
    }

    /// `POST /sessions` with every option.
    pub async fn create_session_with(
        &self,
        request: CreateSession,
    ) -> Result<SessionCreated, ClientError> {
        let body = Vouched { body: request, peers: self.access.peers() };
        self.endpoint
            .json(Method::POST, "/sessions", |r| r.timeout(QUERY_TIMEOUT).json(&body))
            .await
    }

    pub async fn session(&self, id: &str) -> Result<SessionStatus, ClientError> {
        self.endpoint
            .json(Method::GET, &format!("/sessions/{id}"), |r| r.timeout(QUERY_TIMEOUT))
            .await
    }

    /// The session's status once it is no longer loading (the host waits up to ~60 s;
    /// this asks again until then, for at most [`WORK_TIMEOUT`] in all).
    pub async fn wait_ready(&self, id: &str) -> Result<SessionStatus, ClientError> {
        let path = format!("/sessions/{id}?wait=ready");
        let waiting = async {
            loop {
                let status: SessionStatus = self
                    .endpoint
                    .json(Method::GET, &path, |r| r.timeout(LONG_POLL_TIMEOUT))
                    .await?;
                if status.state != crate::host::SessionState::Loading {
                    return Ok(status);
                }
            }
        };
        tokio::time::timeout(WORK_TIMEOUT, waiting).await.unwrap_or_else(|_| {
            Err(ClientError::Timeout {
                url: format!("{}{path}", self.endpoint.base),
                message: format!("still loading after {WORK_TIMEOUT:?}"),
            })
        })
    }

    pub async fn update(&self, id: &str, update: &Update) -> Result<Updated, ClientError> {
        let body = Vouched { body: update, peers: self.access.peers() };
        let path = format!("/sessions/{id}/update");
        self.endpoint.json(Method::POST, &path, |r| r.timeout(WORK_TIMEOUT).json(&body)).await
    }

    /// `POST /replay-plugins`: the host fetches and compiles the plugins it lacks (each
    /// from the cluster host named beside it) and answers once all are ready or failed.
    pub async fn prefetch_plugins(
        &self,
        plugins: Vec<WantedPlugin>,
    ) -> Result<PrefetchedPlugins, ClientError> {
        let body = Vouched { body: PrefetchPlugins { plugins }, peers: self.access.peers() };
        let path = "/replay-plugins";
        self.endpoint.json(Method::POST, path, |r| r.timeout(WORK_TIMEOUT).json(&body)).await
    }

    pub async fn run(&self, id: &str, request: &RunRequest) -> Result<RunResult, ClientError> {
        let path = format!("/sessions/{id}/run");
        self.endpoint.json(Method::POST, &path, |r| r.timeout(WORK_TIMEOUT).json(request)).await
    }

    pub async fn delete_session(&self, id: &str) -> Result<(), ClientError> {
        let path = format!("/sessions/{id}");
        self.endpoint.empty(Method::DELETE, &path, |r| r.timeout(QUERY_TIMEOUT)).await
    }

    /// `POST /meshes/convert`: the mesh `request` names, written as it asks, at most `limit`
    /// bytes.
    pub async fn convert(&self, request: ConvertMesh, limit: u64) -> Result<Vec<u8>, ClientError> {
        let url = format!("{}/meshes/convert", self.endpoint.base);
        let body = Vouched { body: request, peers: self.access.peers() };
        let request = self.endpoint.request(Method::POST, &url).timeout(WORK_TIMEOUT).json(&body);
        read_capped(send(request, &url).await?, &url, limit).await
    }

    /// `POST /meshes/convert`, its successful answer unread: the caller streams and caps it.
    pub async fn convert_response(
        &self,
        request: ConvertMesh,
    ) -> Result<reqwest::Response, ClientError> {
        let url = format!("{}/meshes/convert", self.endpoint.base);
        let body = Vouched { body: request, peers: self.access.peers() };
        let request = self.endpoint.request(Method::POST, &url).timeout(WORK_TIMEOUT).json(&body);
        send(request, &url).await
    }

    /// The size of a blob (any URL), by `HEAD`.
    pub async fn blob_size(&self, url: &str) -> Result<u64, ClientError> {
        let request = self.endpoint.request(Method::HEAD, url).timeout(QUERY_TIMEOUT);
        let response = send(request, url).await?;
        // Not `content_length()`: for a HEAD answer that is the empty body's length.
        let length = response.headers().get(reqwest::header::CONTENT_LENGTH);
        length.and_then(|v| v.to_str().ok()?.parse().ok()).ok_or_else(|| ClientError::Protocol {
            url: url.to_owned(),
            message: "no valid Content-Length in the answer".into(),
        })
    }

    /// The size of a full-mesh blob, which the host packs and stores first if it has not
    /// yet: a `GET` whose body is not read (a `HEAD` answers without packing). So the mesh
    /// outlives the session that held it.
    pub async fn packed_size(&self, url: &str) -> Result<u64, ClientError> {
        let response =
            send(self.endpoint.request(Method::GET, url).timeout(WORK_TIMEOUT), url).await?;
        response.content_length().ok_or_else(|| ClientError::Protocol {
            url: url.to_owned(),
            message: "no valid Content-Length in the answer".into(),
        })
    }

    /// A blob of this host (or another host's, by URL), with the host's error message when
    /// it has none.
    pub async fn download(&self, url: &str) -> Result<Vec<u8>, ClientError> {
        self.download_at_most(url, u64::MAX).await
    }

    /// As [`download`](Self::download), refusing more than `limit` bytes.
    pub async fn download_at_most(&self, url: &str, limit: u64) -> Result<Vec<u8>, ClientError> {
        let request = self.endpoint.request(Method::GET, url).timeout(WORK_TIMEOUT);
        read_capped(send(request, url).await?, url, limit).await
    }
}
