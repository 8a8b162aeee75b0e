//! Replay corrections on a host (DESIGN §4): naming a step after running it, and re-running
//! a step another host named.
//!
//! A replay runs the named component by digest: one this host offers, one it fetched for a
//! replay before (`DATA/replay-plugins/<digest>.wasm`, loaded through the runtime's compiled
//! artefact cache), or else one fetched now from the host that produced the step
//! (`GET /plugins/{digest}/wasm`, cluster token), its SHA-256 checked before it is loaded.
//! Fetched plugins only replay; they are not offered as services.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use meshflow_api::fetch_rules::FetchScope;
use meshflow_codec::quantize::{self, Grid};
use meshflow_codec::replay::{self, Replay};
use meshflow_mesh::{ContentHash, MeshData};
use meshflow_meshio as io;
use meshflow_params::{ServiceInfo, from_json as params_from_json, value_json};
use meshflow_runtime::{Plugin, Runtime, digest as sha256_hex};

use crate::config::DOWNLOAD_TIMEOUT;
use crate::plugins::MAX_PLUGIN_BYTES;
use crate::sessions::CurrentMesh;
use crate::state::Host;

/// Why a replay did not give the step's result; the host then falls back to the edit log.
#[derive(Debug, thiserror::Error)]
pub enum ReplayFailure {
    #[error("{0}")]
    Unreadable(#[from] replay::ReplayError),
    #[error("the replay is for mesh {expected}, this session holds {found}")]
    OtherBase { expected: String, found: String },
    #[error("the replay gives mesh {found}, the step announced {expected}")]
    OtherResult { expected: String, found: String },
    #[error("plugin {digest}: {message}")]
    Plugin { digest: String, message: String },
    #[error("parameters: {0}")]
    Params(String),
    #[error("re-running {service}: {message}")]
    Run { service: String, message: String },
    /// The decisive case: the same component on the same mesh gave other bits.
    #[error("re-running {service} reached mesh {found}, not {expected}")]
    Diverged { service: String, expected: String, found: String },
}

/// The plugins fetched for replays, on disk and, once used, loaded.
pub(crate) struct ReplayPlugins {
    dir: PathBuf,
    loaded: Mutex<HashMap<String, Plugin>>,
    /// One fetch and compilation per digest at a time: updates that need the same plugin
    /// at once wait for the first one's instead of each compiling it.
    pending: Mutex<HashMap<String, Arc<tokio::sync::OnceCell<Plugin>>>>,
}

impl ReplayPlugins {
    pub fn new(dir: PathBuf) -> Self {
        Self { dir, loaded: Mutex::default(), pending: Mutex::default() }
    }

    fn pending(&self, digest: &str) -> Arc<tokio::sync::OnceCell<Plugin>> {
        let mut pending = self.pending.lock().expect("replay plugins lock");
        pending.entry(digest.to_owned()).or_default().clone()
    }

    fn done(&self, digest: &str) {
        self.pending.lock().expect("replay plugins lock").remove(digest);
    }

    fn path(&self, digest: &str) -> PathBuf {
        self.dir.join(format!("{digest}.wasm"))
    }

    fn get(&self, digest: &str) -> Option<Plugin> {
        self.loaded.lock().expect("replay plugins lock").get(digest).cloned()
    }

    fn keep(&self, plugin: Plugin, bytes: &[u8]) -> Result<Plugin, String> {
        let path = self.path(&plugin.digest);
        io::write_file(&path, |out| out.write_all(bytes))
            .map_err(|e| format!("storing the fetched plugin: {e}"))?;
        let mut loaded = self.loaded.lock().expect("replay plugins lock");
        loaded.insert(plugin.digest.clone(), plugin.clone());
        Ok(plugin)
    }
}

/// Names a filter step that ran `plugin`'s service `info` with `params` on mesh `base` and
/// gave `result`: the replay correction (DESIGN §4), every parameter resolved.
pub fn name(
    plugin: &Plugin,
    info: &ServiceInfo,
    params: &[(String, meshflow_params::Value)],
    base: ContentHash,
    result: &MeshData,
    result_hash: ContentHash,
) -> Result<Replay, String> {
    let resolved = meshflow_params::resolve(info, params).map_err(|e| e.to_string())?;
    let params: serde_json::Map<_, _> =
        resolved.into_iter().map(|(name, value)| (name, value_json(&value))).collect();
    Ok(Replay {
        plugin: parse_digest(&plugin.digest).ok_or("the plugin digest is not SHA-256 hex")?,
        service: info.name.clone(),
        params: serde_json::Value::Object(params).to_string(),
        base,
        result: result_hash,
        result_counts: [result.vertex_count() as u64, result.triangle_count() as u64],
    })
}

/// Re-runs `step` with `plugin` on `mesh` in the sandbox (blocking), snaps the result onto
/// `grid` as the producer did (a quantised run), and checks that it reaches the step's
/// result hash.
pub fn rerun(
    runtime: &Runtime,
    plugin: &Plugin,
    step: &Replay,
    mesh: Arc<MeshData>,
    grid: Option<Grid>,
) -> Result<MeshData, ReplayFailure> {
    let service = step.service.clone();
    let failed = |message: String| ReplayFailure::Run { service: service.clone(), message };
    let info = plugin
        .service(&step.service)
        .ok_or_else(|| failed(format!("plugin {} has no such service", plugin.digest)))?;
    let given: serde_json::Map<String, serde_json::Value> =
        serde_json::from_str(&step.params).map_err(|e| ReplayFailure::Params(e.to_string()))?;
    let params =
        params_from_json(info, &given).map_err(|e| ReplayFailure::Params(e.to_string()))?;
    let output = runtime
        .run(plugin, &step.service, Arc::clone(&mesh), &params)
        .map_err(|e| failed(e.to_string()))?;
    let result = output.mesh.ok_or_else(|| failed("the service is a check".into()))?;
    let mesh = match grid {
        Some(grid) => {
            quantize::snap_step(&grid, &mesh, result, output.log)
                .map_err(|e| failed(format!("snapping to the grid: {e}")))?
                .0
        }
        None => result,
    };
    let found = mesh.content_hash();
    if found != step.result {
        let (expected, found) = (step.result.to_hex(), found.to_hex());
        return Err(ReplayFailure::Diverged { service, expected, found });
    }
    Ok(mesh)
}

/// Re-runs the step `bytes` names on `base` (whose hash is known) and checks it reaches
/// `expected`. `producer` is the origin that served the replay correction: where a missing
/// plugin is fetched from.
pub(crate) async fn apply(
    host: &Host,
    scope: &FetchScope,
    producer: Option<&str>,
    base: &CurrentMesh,
    grid: Option<Grid>,
    bytes: &[u8],
    expected: &str,
) -> Result<CurrentMesh, ReplayFailure> {
    let step = replay::decode(bytes)?;
    if !step.base.to_hex().eq_ignore_ascii_case(&base.hash) {
        let (expected, found) = (step.base.to_hex(), base.hash.clone());
        return Err(ReplayFailure::OtherBase { expected, found });
    }
    if !step.result.to_hex().eq_ignore_ascii_case(expected) {
        let (expected, found) = (expected.to_owned(), step.result.to_hex());
        return Err(ReplayFailure::OtherResult { expected, found });
    }
    let plugin = plugin_for(host, scope, producer, &step.plugin_hex()).await?;
    let hash = step.result.to_hex();
    let mesh =
        rerun_off_thread(host.runtime.clone(), plugin, step, base.mesh.clone(), grid).await?;
    Ok(CurrentMesh { mesh: Arc::new(mesh), hash })
}

/// [`rerun`] on a blocking thread.
pub(crate) async fn rerun_off_thread(
    runtime: Arc<Runtime>,
    plugin: Plugin,
    step: Replay,
    mesh: Arc<MeshData>,
    grid: Option<Grid>,
) -> Result<MeshData, ReplayFailure> {
    let service = step.service.clone();
    tokio::task::spawn_blocking(move || rerun(&runtime, &plugin, &step, mesh, grid))
        .await
        .map_err(|e| ReplayFailure::Run { service, message: e.to_string() })?
}

/// The plugin with `digest`: offered here, fetched before, or fetched now from `producer`.
pub(crate) async fn plugin_for(
    host: &Host,
    scope: &FetchScope,
    producer: Option<&str>,
    digest: &str,
) -> Result<Plugin, ReplayFailure> {
    if let Some(plugin) = host.plugins.by_digest(digest).or_else(|| host.replay_plugins.get(digest))
    {
        return Ok(plugin);
    }
    let pending = host.replay_plugins.pending(digest);
    let plugin = pending.get_or_try_init(|| obtain(host, scope, producer, digest)).await.cloned();
    host.replay_plugins.done(digest);
    plugin
}

/// Reads the plugin kept from an earlier replay, or fetches it from `producer`; checks its
/// digest, loads (compiles) and keeps it.
async fn obtain(
    host: &Host,
    scope: &FetchScope,
    producer: Option<&str>,
    digest: &str,
) -> Result<Plugin, ReplayFailure> {
    let fail = |message: String| ReplayFailure::Plugin { digest: digest.to_owned(), message };
    let stored = host.replay_plugins.path(digest);
    let bytes = match tokio::fs::read(&stored).await {
        Ok(bytes) => bytes,
        Err(_) => {
            let producer =
                producer.ok_or_else(|| fail("not here, and no host to fetch it from".into()))?;
            let url = format!("{producer}/plugins/{digest}/wasm");
            meshflow_api::fetch(
                &host.http,
                &url,
                scope,
                MAX_PLUGIN_BYTES as u64,
                PLUGIN_FETCH_TIMEOUT,
            )
            .await
            .map_err(|e| fail(format!("fetching it: {e}")))?
        }
    };
    let found = sha256_hex(&bytes);
    if found != digest {
        return Err(fail(format!("the bytes fetched have digest {found}")));
    }
    let runtime = host.runtime.clone();
    let loaded = bytes.clone();
    let plugin = tokio::task::spawn_blocking(move || runtime.load(&loaded))
        .await
        .map_err(|e| fail(e.to_string()))?
        .map_err(|e| fail(e.to_string()))?;
    host.replay_plugins.keep(plugin, &bytes).map_err(fail)
}

/// A plugin is at most [`MAX_PLUGIN_BYTES`]; fetching it is held to the download deadline.
const PLUGIN_FETCH_TIMEOUT: Duration = DOWNLOAD_TIMEOUT;

fn parse_digest(hex: &str) -> Option<[u8; 32]> {
    let bytes = hex::decode(hex).ok()?;
    bytes.try_into().ok()
}
