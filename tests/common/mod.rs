//! A real meshflow system on 127.0.0.1 for end-to-end tests: an engine and hosts, each on
//! its own port and data folder, talked to over HTTP as a user would.

#![allow(dead_code)] // each test crate includes this module and uses its own subset

pub mod local;
pub mod process;
pub mod proxy;

use std::path::{Path, PathBuf};
use std::time::Duration;

use meshflow_builtin_plugins::PLUGINS;
use meshflow_engine::EngineHandle;
use meshflow_host::{HostConfig, HostHandle};
use meshflow_mesh::MeshData;
use meshflow_meshio::{self as io, Format};
use meshflow_runtime::Limits;
use serde_json::Value as Json;
use tokio::net::TcpListener;

/// The upload token of every in-process host.
pub const TOKEN: &str = "sesame-upload-token";
/// The API token of every test engine, which the cluster's client sends.
pub const API_TOKEN: &str = "api-token-for-tests";
/// The cluster token of every test engine and its hosts.
pub const CLUSTER_TOKEN: &str = "cluster-token-for-tests";

/// Longest a test waits for a run to finish.
const RUN_TIMEOUT: Duration = Duration::from_secs(120);

/// Compiled components shared by every host and local runtime of the tests.
pub fn components_cache() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("workflow-components")
}

/// An input mesh: the bytes a user uploads and the mesh a host decodes from them.
pub struct Input {
    pub name: &'static str,
    pub bytes: Vec<u8>,
    pub mesh: MeshData,
}

impl Input {
    pub fn bunny() -> Self {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj");
        let bytes = std::fs::read(path).unwrap();
        let mesh = io::load_bytes(&bytes, Format::Obj, "bunny.obj").unwrap();
        Self { name: "bunny.obj", bytes, mesh }
    }

    /// A generated scan with holes, debris and non-manifold spots, uploaded as PLY.
    pub fn scan(vertices: usize, seed: u64) -> Self {
        use meshflow_generate::{ScanSpec, scan};
        let spec = ScanSpec { vertices, components: 12, holes: 15, noise: 0.2, seed };
        let mut bytes = Vec::new();
        io::write_to(&mut bytes, &scan(&spec), Format::Ply).unwrap();
        let mesh = io::load_bytes(&bytes, Format::Ply, "scan.ply").unwrap();
        Self { name: "scan.ply", bytes, mesh }
    }
}

/// An engine and the hosts it knows; its API through [`EngineApi`] (deref).
pub struct Cluster {
    pub engine: EngineHandle,
    /// In-process hosts, in registration order (empty when the hosts run elsewhere).
    pub hosts: Vec<HostHandle>,
    api: EngineApi,
    _data: tempfile::TempDir,
}

impl std::ops::Deref for Cluster {
    type Target = EngineApi;

    fn deref(&self) -> &EngineApi {
        &self.api
    }
}

/// An engine's HTTP API as the tests use it, wherever the engine runs.
pub struct EngineApi {
    pub base: String,
    pub http: reqwest::Client,
}

impl Cluster {
    /// One in-process host per entry, offering the named built-in plugin families
    /// (`smoothing`, `cleanup`, `holes`, `checks`); uploads allowed with [`TOKEN`]. The
    /// engine and hosts use [`API_TOKEN`] and [`CLUSTER_TOKEN`]; `http` sends the API token.
    pub async fn start(families: &[&[&str]]) -> Self {
        Self::start_with(families, &[]).await
    }

    /// In-process hosts as [`Cluster::start`] makes them, then hosts running elsewhere.
    pub async fn start_with(families: &[&[&str]], other_hosts: &[String]) -> Self {
        Self::start_allowing(families, other_hosts, &[]).await
    }

    /// As [`Cluster::start_with`], with inputs also allowed from `origins` (engine and
    /// in-process hosts).
    pub async fn start_allowing(
        families: &[&[&str]],
        other_hosts: &[String],
        origins: &[String],
    ) -> Self {
        Self::start_configured(families, other_hosts, origins, |_| Limits::default()).await
    }

    /// As [`Cluster::start`], in-process host `i` with the sandbox limits `limits(i)`.
    pub async fn start_with_limits(families: &[&[&str]], limits: impl Fn(usize) -> Limits) -> Self {
        Self::start_configured(families, &[], &[], limits).await
    }

    async fn start_configured(
        families: &[&[&str]],
        other_hosts: &[String],
        origins: &[String],
        limits: impl Fn(usize) -> Limits,
    ) -> Self {
        let data = tempfile::tempdir().unwrap();
        let hosts = start_hosts_with(families, data.path(), origins, limits).await;
        Self::around_allowing(hosts, data, other_hosts, origins).await
    }

    /// An engine over hosts started already, whose data lives in `data`.
    pub async fn around(hosts: Vec<HostHandle>, data: tempfile::TempDir) -> Self {
        Self::around_allowing(hosts, data, &[], &[]).await
    }

    async fn around_allowing(
        hosts: Vec<HostHandle>,
        data: tempfile::TempDir,
        other_hosts: &[String],
        origins: &[String],
    ) -> Self {
        let urls: Vec<String> =
            hosts.iter().map(|h| h.url.clone()).chain(other_hosts.iter().cloned()).collect();
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let access = meshflow_engine::Access {
            api_token: Some(API_TOKEN.into()),
            cluster_token: Some(CLUSTER_TOKEN.into()),
            allow_input_from: origins.to_vec(),
            ..Default::default()
        };
        let engine =
            meshflow_engine::start(data.path().join("engine"), None, &urls, access, listener)
                .await
                .unwrap();
        let api = EngineApi::new(&engine.url);
        Self { engine, hosts, api, _data: data }
    }
}

impl EngineApi {
    /// The API of the engine at `base`, called with [`API_TOKEN`].
    pub fn new(base: &str) -> Self {
        Self { base: base.to_owned(), http: bearer_client(API_TOKEN) }
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    /// `POST /inputs`: the URL hosts fetch the input from.
    pub async fn upload(&self, input: &Input) -> String {
        let url = self.url(&format!("/inputs?name={}", input.name));
        let answer = self.http.post(url).body(input.bytes.clone()).send().await.unwrap();
        assert_eq!(answer.status(), 201);
        answer.json::<Json>().await.unwrap()["url"].as_str().unwrap().to_owned()
    }

    /// `POST /hosts {"url"}` as a host registers itself, with the cluster token.
    pub async fn register(&self, url: &str) -> reqwest::Response {
        let request = reqwest::Client::new().post(self.url("/hosts")).bearer_auth(CLUSTER_TOKEN);
        request.json(&serde_json::json!({ "url": url })).send().await.unwrap()
    }

    /// `POST /runs` with a raw body: the status and the JSON answer.
    pub async fn post_run(&self, body: impl Into<reqwest::Body>) -> (u16, Json) {
        let answer = self.http.post(self.url("/runs")).body(body).send().await.unwrap();
        let status = answer.status().as_u16();
        (status, answer.json().await.unwrap())
    }

    /// Submits `workflow` on `input`; the run id.
    pub async fn submit(&self, workflow: &Json, input: &str) -> String {
        let body = serde_json::json!({"workflow": workflow, "input": input});
        let (status, answer) = self.post_run(body.to_string()).await;
        assert_eq!(status, 202, "the engine refused the run: {answer}");
        answer["id"].as_str().unwrap().to_owned()
    }

    /// `GET /runs/{id}`.
    pub async fn record(&self, id: &str) -> Json {
        let answer = self.http.get(self.url(&format!("/runs/{id}"))).send().await.unwrap();
        assert_eq!(answer.status(), 200);
        answer.json().await.unwrap()
    }

    /// Polls the run until it ends and its record settles (a completed run's result
    /// packed on its holders); its record.
    pub async fn finished(&self, id: &str) -> Json {
        let deadline = tokio::time::Instant::now() + RUN_TIMEOUT;
        loop {
            let record = self.record(id).await;
            if has_settled(&record) {
                return record;
            }
            assert!(tokio::time::Instant::now() < deadline, "run {id} still going: {record:#}");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// Polls the run until `reached` holds for its record, which it returns; the run must be
    /// queued (waiting for a worker on a loaded machine) or running until then.
    pub async fn under_way_until(&self, id: &str, reached: impl Fn(&Json) -> bool) -> Json {
        let deadline = tokio::time::Instant::now() + RUN_TIMEOUT;
        loop {
            let record = self.record(id).await;
            if reached(&record) {
                return record;
            }
            let status = record["status"].as_str().unwrap_or_default();
            assert!(status == "queued" || status == "running", "{record:#}");
            assert!(tokio::time::Instant::now() < deadline, "run {id} never got there: {record:#}");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    /// Submits and waits for the end.
    pub async fn run(&self, workflow: &Json, input: &str) -> Json {
        let id = self.submit(workflow, input).await;
        self.finished(&id).await
    }

    /// The final mesh through `GET /runs/{id}/result` (a redirect to the host holding it).
    pub async fn result(&self, id: &str) -> MeshData {
        let answer = self.http.get(self.url(&format!("/runs/{id}/result"))).send().await.unwrap();
        assert_eq!(answer.status(), 200);
        meshflow_codec::pack::decode(&answer.bytes().await.unwrap()).unwrap()
    }

    /// `GET /services`: the catalogue by service name, with the hosts offering each.
    pub async fn services(&self) -> Json {
        self.http.get(self.url("/services")).send().await.unwrap().json().await.unwrap()
    }
}

/// In-process hosts under `data`, one per entry of `families` (the built-in plugin
/// families it offers), with [`CLUSTER_TOKEN`], inputs also allowed from `origins`;
/// uploads allowed with [`TOKEN`].
pub async fn start_hosts(families: &[&[&str]], data: &Path, origins: &[String]) -> Vec<HostHandle> {
    start_hosts_with(families, data, origins, |_| Limits::default()).await
}

/// [`start_hosts`], host `i` with the sandbox limits `limits(i)`.
pub async fn start_hosts_with(
    families: &[&[&str]],
    data: &Path,
    origins: &[String],
    limits: impl Fn(usize) -> Limits,
) -> Vec<HostHandle> {
    start_hosts_configured_allowing(families, data, origins, |i, config| config.limits = limits(i))
        .await
}

/// [`start_hosts`], host `i`'s configuration changed by `configure(i, config)` first.
pub async fn start_hosts_configured(
    families: &[&[&str]],
    data: &Path,
    configure: impl Fn(usize, &mut HostConfig),
) -> Vec<HostHandle> {
    start_hosts_configured_allowing(families, data, &[], configure).await
}

async fn start_hosts_configured_allowing(
    families: &[&[&str]],
    data: &Path,
    origins: &[String],
    configure: impl Fn(usize, &mut HostConfig),
) -> Vec<HostHandle> {
    let mut hosts = Vec::new();
    for (index, names) in families.iter().enumerate() {
        let config = HostConfig {
            builtins: builtins(names),
            artefact_cache: Some(components_cache()),
            token: Some(TOKEN.into()),
            cluster_token: Some(CLUSTER_TOKEN.into()),
            allow_input_from: origins.to_vec(),
            ..HostConfig::new(data.join(format!("host-{index}")))
        };
        let mut config = config;
        configure(index, &mut config);
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        hosts.push(meshflow_host::start(config, listener).await.unwrap());
    }
    hosts
}

/// Whether a run record's status is final.
pub fn has_ended(record: &Json) -> bool {
    matches!(record["status"].as_str(), Some("completed" | "failed" | "cancelled" | "interrupted"))
}

/// Whether nothing about the run changes any more: ended, and a completed run settled.
pub fn has_settled(record: &Json) -> bool {
    has_ended(record) && (record["status"] != "completed" || record["settled_ms"].is_number())
}

/// An HTTP client that sends `token` as a bearer token with every request.
pub fn bearer_client(token: &str) -> reqwest::Client {
    let value = format!("Bearer {token}").parse().unwrap();
    let headers = [(reqwest::header::AUTHORIZATION, value)].into_iter().collect();
    reqwest::Client::builder().default_headers(headers).build().unwrap()
}

/// The component bytes of the named built-in plugin families.
pub fn builtins(names: &[&str]) -> Vec<&'static [u8]> {
    names.iter().map(|name| builtin(name)).collect()
}

pub fn builtin(name: &str) -> &'static [u8] {
    PLUGINS.iter().find(|p| p.name == name).map(|p| p.wasm).expect("a built-in plugin family")
}

/// Every step of a record as (path, outcome): a filter's output hash, a check's value.
pub fn executed(record: &Json) -> Vec<(String, Json)> {
    steps(record)
        .iter()
        .map(|step| {
            let outcome = match step["kind"].as_str() {
                Some("filter") => step["output_hash"].clone(),
                _ => step["value"].clone(),
            };
            (step["path"].as_str().unwrap().to_owned(), outcome)
        })
        .collect()
}

pub fn steps(record: &Json) -> &[Json] {
    record["steps"].as_array().expect("a record lists its steps")
}

pub fn text(json: &Json) -> &str {
    json.as_str().unwrap_or_else(|| panic!("expected a string, got {json}"))
}
