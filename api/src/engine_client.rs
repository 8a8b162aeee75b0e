//! `EngineClient`: the engine HTTP API from Rust (async, reqwest), for the CLI and scripts.

use reqwest::Method;

use crate::engine::{
    BatchStatus, Comparison, HostInfo, InputUploaded, RegisterHost, RerunRequest, RunRecord,
    RunSubmitted, RunSummary, ServiceOffer, SubmitBatch, SubmitRun,
};
use crate::host::UploadedPlugin;
use crate::transport::{ClientError, Endpoint, WORK_TIMEOUT, read_capped, send};

/// A client of one engine, e.g. `EngineClient::new("http://127.0.0.1:7000")`.
#[derive(Clone, Debug)]
pub struct EngineClient {
    endpoint: Endpoint,
}

impl EngineClient {
    pub fn new(base_url: &str) -> Self {
        Self { endpoint: Endpoint::new(base_url, crate::transport::default_client()) }
    }

    /// Sends an API token (`Authorization: Bearer`) with every request.
    pub fn with_token(mut self, token: &str) -> Self {
        self.endpoint.token = Some(token.to_owned());
        self
    }

    pub fn base_url(&self) -> &str {
        &self.endpoint.base
    }

    pub async fn hosts(&self) -> Result<Vec<HostInfo>, ClientError> {
        self.endpoint.json(Method::GET, "/hosts", |r| r).await
    }

    pub async fn register_host(&self, url: &str) -> Result<HostInfo, ClientError> {
        let body = RegisterHost { url: url.to_owned() };
        self.endpoint.json(Method::POST, "/hosts", |r| r.json(&body)).await
    }

    pub async fn services(&self) -> Result<Vec<ServiceOffer>, ClientError> {
        self.endpoint.json(Method::GET, "/services", |r| r).await
    }

    /// Uploads a mesh file as a run input; `name` (its file name) tells its format.
    pub async fn upload_input(
        &self,
        name: &str,
        bytes: Vec<u8>,
    ) -> Result<InputUploaded, ClientError> {
        self.endpoint
            .json(Method::POST, "/inputs", |r| r.query(&[("name", name)]).body(bytes))
            .await
    }

    /// Uploads a plugin component to the registered host `host` through the engine, which
    /// learns its services at once; `upload_token` is that host's.
    pub async fn upload_plugin(
        &self,
        host: &str,
        wasm: Vec<u8>,
        upload_token: &str,
        replace: bool,
    ) -> Result<UploadedPlugin, ClientError> {
        let replace = if replace { "true" } else { "false" };
        self.endpoint
            .json(Method::POST, "/plugins", |r| {
                r.query(&[("host", host), ("replace", replace)])
                    .header("x-upload-token", upload_token)
                    .timeout(WORK_TIMEOUT)
                    .body(wasm)
            })
            .await
    }

    pub async fn submit(&self, run: &SubmitRun) -> Result<RunSubmitted, ClientError> {
        self.endpoint.json(Method::POST, "/runs", |r| r.json(run)).await
    }

    /// Starts one workflow over many inputs.
    pub async fn submit_batch(&self, batch: &SubmitBatch) -> Result<BatchStatus, ClientError> {
        self.endpoint.json(Method::POST, "/batches", |r| r.json(batch)).await
    }

    pub async fn batch(&self, id: &str) -> Result<BatchStatus, ClientError> {
        self.endpoint.json(Method::GET, &format!("/batches/{id}"), |r| r).await
    }

    /// Stops a batch: no more of its runs start, those going are cancelled.
    pub async fn cancel_batch(&self, id: &str) -> Result<BatchStatus, ClientError> {
        self.endpoint.json(Method::POST, &format!("/batches/{id}/cancel"), |r| r).await
    }

    /// Runs a kept run again, pinned to its recorded plugins and parameters.
    pub async fn rerun(
        &self,
        id: &str,
        request: &RerunRequest,
    ) -> Result<RunSubmitted, ClientError> {
        self.endpoint.json(Method::POST, &format!("/runs/{id}/rerun"), |r| r.json(request)).await
    }

    /// A finished re-run compared with the run it re-ran.
    pub async fn comparison(&self, id: &str) -> Result<Comparison, ClientError> {
        self.endpoint.json(Method::GET, &format!("/runs/{id}/comparison"), |r| r).await
    }

    pub async fn runs(&self) -> Result<Vec<RunSummary>, ClientError> {
        self.endpoint.json(Method::GET, "/runs", |r| r).await
    }

    pub async fn run(&self, id: &str) -> Result<RunRecord, ClientError> {
        self.endpoint.json(Method::GET, &format!("/runs/{id}"), |r| r).await
    }

    /// Asks the engine to stop a run; its state then is `cancelled`.
    pub async fn cancel(&self, id: &str) -> Result<RunSummary, ClientError> {
        self.endpoint.json(Method::POST, &format!("/runs/{id}/cancel"), |r| r).await
    }

    /// The open event stream of a run (server-sent events: `record`, then each change).
    pub async fn events(&self, id: &str) -> Result<reqwest::Response, ClientError> {
        let url = format!("{}/runs/{id}/events", self.endpoint.base);
        send(self.endpoint.request(Method::GET, &url), &url).await
    }

    /// The final mesh of a finished run, packed (`.mfm`); the engine's error message when
    /// there is none.
    pub async fn result(&self, id: &str) -> Result<Vec<u8>, ClientError> {
        let url = format!("{}/runs/{id}/result", self.endpoint.base);
        let response = send(self.endpoint.request(Method::GET, &url), &url).await?;
        read_capped(response, &url, u64::MAX).await
    }
}
