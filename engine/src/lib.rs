//! The meshflow engine: reads workflows, picks hosts, runs the concurrent transfer protocol
//! between them, and serves the engine HTTP API (DESIGN §5–6).
//!
//! This crate must not depend on wasmtime, the mesh store, the codecs or the host server:
//! it speaks to hosts only through `meshflow-api` (`cargo tree -p meshflow-engine -e normal`
//! shows no wasmtime, cranelift or constriction).

mod api;
pub mod auth;
mod executor;
mod inputs;
pub mod plan;
pub mod record;
pub mod registry;
pub mod run;
mod ui;
pub mod validate;
pub mod workflow;

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

pub use api::router;
pub use auth::Access;
use registry::Registry;
use run::Run;
use workflow::{Workflow, WorkflowError};

/// Finished runs kept for status queries; older ones are forgotten first.
pub const KEPT_RUNS: usize = 1000;

pub struct EngineConfig {
    /// Where uploaded inputs are kept.
    pub data_dir: PathBuf,
    /// The URL hosts use to reach this engine (for uploaded inputs).
    pub public_url: String,
    pub access: Access,
}

pub struct Engine {
    pub registry: Arc<Registry>,
    runs: Mutex<HashMap<String, Arc<Run>>>,
    /// Run ids in the order they were submitted.
    order: Mutex<Vec<String>>,
    inputs: inputs::Inputs,
    public_url: String,
    access: Access,
}

/// Why a run was not accepted.
#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    #[error(transparent)]
    Invalid(#[from] WorkflowError),
    #[error("the workflow has no input: give \"input\" in the workflow or with the request")]
    NoInput,
    #[error("input: {0}")]
    InputRefused(#[from] meshflow_api::fetch_rules::Refusal),
}

impl Engine {
    pub fn new(config: EngineConfig) -> anyhow::Result<Arc<Self>> {
        let public_url = config.public_url.trim_end_matches('/').to_owned();
        let cluster = config.access.cluster_token.clone();
        let engine = Arc::new(Self {
            registry: Arc::new(Registry::new(&public_url, cluster)?),
            runs: Mutex::default(),
            order: Mutex::default(),
            inputs: inputs::Inputs::new(config.data_dir.join("inputs"))?,
            public_url,
            access: config.access,
        });
        engine.registry.spawn_poller();
        Ok(engine)
    }

    /// Validates the workflow against the catalogue and starts it; returns at once.
    pub fn submit(
        &self,
        workflow: Workflow,
        input: Option<String>,
    ) -> Result<Arc<Run>, SubmitError> {
        let input = input.or_else(|| workflow.input.clone()).ok_or(SubmitError::NoInput)?;
        let hosts = self.registry.hosts().into_iter().map(|host| host.url.clone());
        self.access.check_input(&input, &self.public_url, hosts)?;
        validate::validate(&workflow, &|name| self.registry.service(name))?;
        let id = self.new_run_id();
        let run = Arc::new(Run::new(id.clone(), workflow.transfer));
        self.keep(run.clone());
        tokio::spawn(executor::execute(run.clone(), workflow, input, self.registry.clone()));
        Ok(run)
    }

    pub fn run(&self, id: &str) -> Option<Arc<Run>> {
        self.runs.lock().unwrap().get(id).cloned()
    }

    pub fn runs(&self) -> Vec<Arc<Run>> {
        let runs = self.runs.lock().unwrap();
        self.order.lock().unwrap().iter().filter_map(|id| runs.get(id).cloned()).collect()
    }

    fn keep(&self, run: Arc<Run>) {
        let mut runs = self.runs.lock().unwrap();
        let mut order = self.order.lock().unwrap();
        while order.len() >= KEPT_RUNS {
            let Some(position) = order.iter().position(|id| runs[id].is_finished()) else { break };
            runs.remove(&order.remove(position));
        }
        order.push(run.id.clone());
        runs.insert(run.id.clone(), run);
    }

    fn new_run_id(&self) -> String {
        let seed =
            format!("{:?}{}", std::time::SystemTime::now(), self.order.lock().unwrap().len());
        blake3::hash(seed.as_bytes()).to_hex()[..16].to_owned()
    }

    /// Stores an uploaded input and returns the URL hosts fetch it from.
    pub async fn put_input(&self, name: &str, bytes: &[u8]) -> Result<String, String> {
        let file = self.inputs.put(name, bytes).await?;
        Ok(format!("{}/inputs/{file}", self.public_url))
    }
}

/// A running engine server.
pub struct EngineHandle {
    pub url: String,
    pub engine: Arc<Engine>,
    server: tokio::task::JoinHandle<std::io::Result<()>>,
}

impl EngineHandle {
    /// Serves until the process ends.
    pub async fn wait(self) -> anyhow::Result<()> {
        Ok(self.server.await??)
    }
}

/// Starts an engine on `listener`, registers `hosts`, and serves in the background. Without
/// both tokens it listens only on loopback, unless `access.insecure_no_auth`.
pub async fn start(
    data_dir: PathBuf,
    public_url: Option<String>,
    hosts: &[String],
    access: Access,
    listener: tokio::net::TcpListener,
) -> anyhow::Result<EngineHandle> {
    let address = listener.local_addr()?;
    let access = access.validated()?;
    meshflow_api::server::check_exposure(address, &access.missing(), access.insecure_no_auth)?;
    let url = public_url.unwrap_or_else(|| match address.ip().is_unspecified() {
        true => format!("http://127.0.0.1:{}", address.port()),
        false => format!("http://{address}"),
    });
    let engine = Engine::new(EngineConfig { data_dir, public_url: url.clone(), access })?;
    for host in hosts {
        let entry = engine.registry.register(host).await?;
        if let Some(error) = entry.state().last_error {
            tracing::warn!("host {host} does not answer yet: {error}");
        }
    }
    let app = router(engine.clone());
    let server = tokio::spawn(meshflow_api::server::serve(listener, app, std::future::pending()));
    tracing::info!("engine listening on {address}, reached at {url}");
    Ok(EngineHandle { url, engine, server })
}
