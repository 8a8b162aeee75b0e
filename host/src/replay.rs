//! Replay corrections on a host (DESIGN §4): naming a step after running it, and re-running
//! a step another host named.
//!
//! A replay runs the named component by digest: one this host offers, one it fetched for a
//! replay before (`DATA/replay-plugins/<digest>.wasm`, loaded through the runtime's compiled
//! artefact cache), or else one fetched now from the host that produced the step
//! (`GET /plugins/{digest}/wasm`, cluster token), its SHA-256 checked before it is loaded.
//! Fetched plugins only replay; they are not offered as services.
//!
//! A run's engine may name the plugins this host will replay before it needs them
//! (`POST /replay-plugins`, [`ReplayPlugins::prefetch`]): they are fetched and compiled
//! the same way while the input is still broadcasting, so the replay finds them ready.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use meshflow_api::fetch_rules::{FetchScope, origin};
use meshflow_api::host::{PluginPrefetch, PrefetchOutcome, WantedPlugin, millis};
use meshflow_codec::quantize::{self, Grid};
use meshflow_codec::replay::{self, Replay};
use meshflow_mesh::{ContentHash, MeshData};
use meshflow_meshio as io;
use meshflow_params::{ParamError, ServiceInfo, from_json as params_from_json, value_json};
use meshflow_runtime::{Invocation, Plugin, Runtime, digest as sha256_hex};

use crate::config::DOWNLOAD_TIMEOUT;
use crate::meshes::CurrentMesh;
use crate::plugins::{MAX_PLUGIN_BYTES, PluginSet};

/// What a host started with `--no-foreign-plugins` says when a plugin it lacks is asked for.
pub const NO_FOREIGN_PLUGINS: &str =
    "this host runs only the plugins it loaded itself (--no-foreign-plugins)";

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

/// Why a step could not be named.
#[derive(Debug, thiserror::Error)]
pub enum NameError {
    #[error(transparent)]
    Params(#[from] ParamError),
    #[error("the plugin digest is not SHA-256 hex")]
    Digest,
}

/// Where a plugin a replay needs may come from: the origin that served the replay
/// correction (`producer`), fetched within `scope`.
#[derive(Clone, Copy)]
pub(crate) struct PluginSource<'a> {
    pub scope: &'a FetchScope,
    pub producer: Option<&'a str>,
}

/// The plugins fetched for replays, on disk and, once used, loaded; and what replays run
/// with: the runtime, and the plugins the host offers.
pub(crate) struct ReplayPlugins {
    dir: PathBuf,
    runtime: Arc<Runtime>,
    /// The host's download client: plugins come from the cluster's hosts.
    http: reqwest::Client,
    loaded: Mutex<HashMap<String, Plugin>>,
    /// One fetch and compilation per digest at a time: updates that need the same plugin
    /// at once wait for the first one's instead of each compiling it.
    pending: Mutex<HashMap<String, Arc<tokio::sync::OnceCell<Plugin>>>>,
    /// Prefetches compiling at once; a replay that needs a plugin never waits for this.
    prefetching: tokio::sync::Semaphore,
    /// Whether plugins this host did not load itself may run here (`--no-foreign-plugins`).
    foreign: bool,
}

/// What a replay's update did: the mesh, and how long it waited for its plugin when the
/// plugin was not ready here (fetched and compiled now, or a prefetch still under way).
pub struct Replayed {
    pub mesh: CurrentMesh,
    pub plugin_wait: Option<Duration>,
}

/// Why a plugin named for a prefetch is not ready: refused before anything is fetched (a
/// digest or source that does not qualify), or the fetch or compile failed or took too long.
#[derive(Debug, thiserror::Error)]
pub enum PrefetchError {
    #[error("the digest is not 64 lowercase hex digits")]
    Digest,
    #[error("{0:?} is not the origin of a host of the cluster")]
    NotACluster(String),
    #[error("not ready after {0:?}")]
    TimedOut(Duration),
    #[error("the host is stopping")]
    Stopping,
    #[error("{NO_FOREIGN_PLUGINS}")]
    NoForeignPlugins,
    #[error(transparent)]
    Plugin(#[from] ReplayFailure),
}

impl ReplayPlugins {
    pub fn new(dir: PathBuf, runtime: Arc<Runtime>, http: reqwest::Client, foreign: bool) -> Self {
        Self {
            foreign,
            dir,
            runtime,
            http,
            loaded: Mutex::default(),
            pending: Mutex::default(),
            prefetching: tokio::sync::Semaphore::new(MAX_CONCURRENT_PREFETCHES),
        }
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

    fn keep(&self, plugin: Plugin, bytes: &[u8]) -> Result<Plugin, ReplayFailure> {
        let path = self.path(&plugin.digest);
        io::write_private_file(&path, |out| out.write_all(bytes)).map_err(|e| {
            ReplayFailure::Plugin {
                digest: plugin.digest.clone(),
                message: format!("storing the fetched plugin: {e}"),
            }
        })?;
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
) -> Result<Replay, NameError> {
    let resolved = meshflow_params::resolve(info, params)?;
    let params = serde_json::Value::Object(params_json(&resolved)).to_string();
    name_resolved(&plugin.digest, &info.name, params, base, result, result_hash)
}

/// Resolved parameters as the JSON object a replay and an answer carry.
pub fn params_json(
    resolved: &[(String, meshflow_params::Value)],
) -> serde_json::Map<String, serde_json::Value> {
    resolved.iter().map(|(name, value)| (name.clone(), value_json(value))).collect()
}

/// [`name`] of a step whose parameters are already resolved, as JSON text (`params`).
pub(crate) fn name_resolved(
    digest: &str,
    service: &str,
    params: String,
    base: ContentHash,
    result: &MeshData,
    result_hash: ContentHash,
) -> Result<Replay, NameError> {
    Ok(Replay {
        plugin: parse_digest(digest).ok_or(NameError::Digest)?,
        service: service.to_owned(),
        params,
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
    // Looked up and resolved once: the run does neither again.
    let invocation = Invocation::resolve(plugin.clone(), info.clone(), &params)
        .map_err(|e| failed(e.to_string()))?;
    let output =
        runtime.invoke(&invocation, Arc::clone(&mesh)).map_err(|e| failed(e.to_string()))?;
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

impl ReplayPlugins {
    /// Re-runs the step `bytes` names on `base` (whose hash is known) and checks it reaches
    /// `expected`. A plugin neither `offered` nor kept is fetched from `source`.
    pub async fn apply(
        &self,
        offered: &PluginSet,
        source: PluginSource<'_>,
        base: &CurrentMesh,
        grid: Option<Grid>,
        bytes: &[u8],
        expected: &str,
    ) -> Result<Replayed, ReplayFailure> {
        let step = replay::decode(bytes)?;
        if !step.base.to_hex().eq_ignore_ascii_case(&base.hash) {
            let (expected, found) = (step.base.to_hex(), base.hash.clone());
            return Err(ReplayFailure::OtherBase { expected, found });
        }
        if !step.result.to_hex().eq_ignore_ascii_case(expected) {
            let (expected, found) = (expected.to_owned(), step.result.to_hex());
            return Err(ReplayFailure::OtherResult { expected, found });
        }
        let (plugin, plugin_wait) = self.plugin_waited(offered, source, &step.plugin_hex()).await?;
        let hash = step.result.to_hex();
        let mesh = self.rerun_off_thread(plugin, step, base.mesh.clone(), grid).await?;
        Ok(Replayed { mesh: CurrentMesh { mesh: Arc::new(mesh), hash }, plugin_wait })
    }

    /// [`rerun`] on a blocking thread.
    pub async fn rerun_off_thread(
        &self,
        plugin: Plugin,
        step: Replay,
        mesh: Arc<MeshData>,
        grid: Option<Grid>,
    ) -> Result<MeshData, ReplayFailure> {
        let service = step.service.clone();
        let runtime = self.runtime.clone();
        tokio::task::spawn_blocking(move || rerun(&runtime, &plugin, &step, mesh, grid))
            .await
            .map_err(|e| ReplayFailure::Run { service, message: e.to_string() })?
    }

    /// The plugin with `digest`: `offered` here, fetched before, or fetched now from
    /// `source`.
    pub async fn plugin_for(
        &self,
        offered: &PluginSet,
        source: PluginSource<'_>,
        digest: &str,
    ) -> Result<Plugin, ReplayFailure> {
        Ok(self.plugin_waited(offered, source, digest).await?.0)
    }

    /// [`plugin_for`](Self::plugin_for), and how long it waited when the plugin was not
    /// ready at once.
    async fn plugin_waited(
        &self,
        offered: &PluginSet,
        source: PluginSource<'_>,
        digest: &str,
    ) -> Result<(Plugin, Option<Duration>), ReplayFailure> {
        if let Some(plugin) = self.ready(offered, digest) {
            return Ok((plugin, None));
        }
        if !self.foreign {
            let message = NO_FOREIGN_PLUGINS.to_owned();
            return Err(ReplayFailure::Plugin { digest: digest.to_owned(), message });
        }
        let started = Instant::now();
        let pending = self.pending(digest);
        let plugin = pending.get_or_try_init(|| self.obtain(source, digest)).await.cloned();
        self.done(digest);
        Ok((plugin?, Some(started.elapsed())))
    }

    /// The plugin with `digest` if it is compiled here: offered, or loaded for a replay
    /// (when foreign plugins may run here).
    fn ready(&self, offered: &PluginSet, digest: &str) -> Option<Plugin> {
        offered.by_digest(digest).or_else(|| self.fetched(digest))
    }

    /// A plugin this host did not load itself but fetched for a replay or a prefetch, ready
    /// to run. `None` with `--no-foreign-plugins`.
    fn fetched(&self, digest: &str) -> Option<Plugin> {
        self.foreign.then(|| self.get(digest)).flatten()
    }

    /// What a step the engine moved here runs with: a plugin fetched for a replay or a
    /// prefetch, in memory or, after a restart, compiled again from the copy kept on disk;
    /// never fetched now. `None` with `--no-foreign-plugins`, for a name that is no digest,
    /// or when no copy is kept.
    pub async fn kept(&self, offered: &PluginSet, digest: &str) -> Option<Plugin> {
        if !self.foreign || !is_digest(digest) {
            return None;
        }
        let nowhere = PluginSource { scope: &FetchScope::default(), producer: None };
        self.plugin_for(offered, nowhere, digest).await.ok()
    }

    /// Whether plugins fetched from other hosts may run here.
    pub fn runs_foreign(&self) -> bool {
        self.foreign
    }

    /// Makes the plugin `wanted` names ready for a replay to come: nothing if it is
    /// compiled here, else loaded from an earlier replay's copy or fetched from
    /// `wanted.from` (which must be a cluster origin of `scope`, the engine's peers) and
    /// compiled, sharing the fetch with any replay that needs it meanwhile. At most
    /// [`MAX_CONCURRENT_PREFETCHES`] compile at once, each within [`PREFETCH_TIMEOUT`]. A
    /// failure is only reported: a replay fetches the plugin itself when it needs it.
    pub async fn prefetch(
        &self,
        offered: &PluginSet,
        scope: &FetchScope,
        wanted: &WantedPlugin,
    ) -> PluginPrefetch {
        let started = Instant::now();
        let digest = wanted.digest.as_str();
        let outcome = self.prefetched(offered, scope, wanted).await;
        let ms = millis(started.elapsed());
        let bytes = offered.size(digest).or_else(|| self.kept_size(digest));
        let answer = |outcome, error| PluginPrefetch {
            digest: digest.to_owned(),
            outcome,
            ms,
            bytes,
            error,
        };
        match outcome {
            Ok(outcome) => answer(outcome, None),
            Err(error) => {
                let from: String = wanted.from.chars().take(200).collect();
                tracing::warn!(%from, "prefetching plugin {digest:.64}: {error}");
                answer(PrefetchOutcome::Failed, Some(error.to_string()))
            }
        }
    }

    /// [`prefetch`](Self::prefetch) of every plugin in `wanted`, at once (bounded by the
    /// prefetch slots); the outcomes in order.
    pub async fn prefetch_all(
        &self,
        offered: &PluginSet,
        scope: &FetchScope,
        wanted: &[WantedPlugin],
    ) -> Vec<PluginPrefetch> {
        let each = wanted.iter().map(|w| self.prefetch(offered, scope, w));
        futures_util::future::join_all(each).await
    }

    async fn prefetched(
        &self,
        offered: &PluginSet,
        scope: &FetchScope,
        wanted: &WantedPlugin,
    ) -> Result<PrefetchOutcome, PrefetchError> {
        let digest = wanted.digest.as_str();
        if !is_digest(digest) {
            return Err(PrefetchError::Digest);
        }
        if self.ready(offered, digest).is_some() {
            return Ok(PrefetchOutcome::Present);
        }
        if !self.foreign {
            return Err(PrefetchError::NoForeignPlugins);
        }
        let from = cluster_origin(scope, &wanted.from)?;
        let work = async {
            let _slot = self.prefetching.acquire().await.map_err(|_| PrefetchError::Stopping)?;
            // Another prefetch or a replay may have made it ready while this one waited.
            if self.ready(offered, digest).is_some() {
                return Ok(PrefetchOutcome::Present);
            }
            let kept = tokio::fs::try_exists(self.path(digest)).await.unwrap_or(false);
            let source = PluginSource { scope, producer: Some(&from) };
            self.plugin_for(offered, source, digest).await?;
            Ok(match kept {
                true => PrefetchOutcome::Loaded,
                false => PrefetchOutcome::Fetched,
            })
        };
        tokio::time::timeout(PREFETCH_TIMEOUT, work)
            .await
            .unwrap_or(Err(PrefetchError::TimedOut(PREFETCH_TIMEOUT)))
    }

    /// The size of the copy kept from an earlier replay or prefetch.
    fn kept_size(&self, digest: &str) -> Option<u64> {
        is_digest(digest).then(|| std::fs::metadata(self.path(digest)).ok().map(|m| m.len()))?
    }

    /// Reads the plugin kept from an earlier replay, or fetches it from `source`; checks
    /// its digest, loads (compiles) and keeps it.
    async fn obtain(
        &self,
        source: PluginSource<'_>,
        digest: &str,
    ) -> Result<Plugin, ReplayFailure> {
        let fail = |message: String| ReplayFailure::Plugin { digest: digest.to_owned(), message };
        let stored = self.path(digest);
        let bytes = match tokio::fs::read(&stored).await {
            Ok(bytes) => bytes,
            Err(_) => {
                let producer = source
                    .producer
                    .ok_or_else(|| fail("not here, and no host to fetch it from".into()))?;
                let url = format!("{producer}/plugins/{digest}/wasm");
                let (limit, deadline) = (MAX_PLUGIN_BYTES as u64, PLUGIN_FETCH_TIMEOUT);
                meshflow_api::fetch_compressible(&self.http, &url, source.scope, limit, deadline)
                    .await
                    .map_err(|e| fail(format!("fetching it: {e}")))?
            }
        };
        let found = sha256_hex(&bytes);
        if found != digest {
            return Err(fail(format!("the bytes fetched have digest {found}")));
        }
        let runtime = self.runtime.clone();
        let bytes = Arc::new(bytes);
        let loaded = bytes.clone();
        let plugin = tokio::task::spawn_blocking(move || runtime.load(&loaded))
            .await
            .map_err(|e| fail(e.to_string()))?
            .map_err(|e| fail(e.to_string()))?;
        self.keep(plugin, &bytes)
    }
}

/// A plugin is at most [`MAX_PLUGIN_BYTES`]; fetching it is held to the download deadline.
const PLUGIN_FETCH_TIMEOUT: Duration = DOWNLOAD_TIMEOUT;

/// Prefetches fetching or compiling at once on a host: each compile takes a core for up
/// to tens of seconds (an 18 MB Python component), and the host has runs to serve.
pub const MAX_CONCURRENT_PREFETCHES: usize = 2;

/// A prefetch's whole time: waiting for a slot, the download, and the compile (a large
/// component compiles in under a minute uncached here).
pub const PREFETCH_TIMEOUT: Duration = Duration::from_secs(15 * 60);

/// A plugin digest as this host names files after it: 64 lowercase hex digits.
fn is_digest(digest: &str) -> bool {
    digest.len() == 64 && digest.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

/// The origin of `from` if it is one of the cluster's (the engine vouched for it), else
/// why not: a prefetch fetches only from hosts of the cluster.
fn cluster_origin(scope: &FetchScope, from: &str) -> Result<String, PrefetchError> {
    let not_cluster = || PrefetchError::NotACluster(from.chars().take(200).collect());
    let url = reqwest::Url::parse(from).map_err(|_| not_cluster())?;
    let found = origin(&url);
    match scope.cluster.contains(&found) {
        true => Ok(found),
        false => Err(not_cluster()),
    }
}

fn parse_digest(hex: &str) -> Option<[u8; 32]> {
    let bytes = hex::decode(hex).ok()?;
    bytes.try_into().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prefetch_names_only_digests_and_fetches_only_from_the_cluster() {
        assert!(is_digest(&"0a".repeat(32)));
        for bad in
            ["0A".repeat(32), "0a".repeat(31), format!("../{}", "a".repeat(61)), String::new()]
        {
            assert!(!is_digest(&bad), "{bad}");
        }
        let mut scope = FetchScope {
            allowed: meshflow_api::fetch_rules::Origins::any(),
            cluster: Default::default(),
            token: None,
        };
        scope.cluster.insert("http://127.0.0.1:7001".to_owned());
        let found = cluster_origin(&scope, "http://127.0.0.1:7001/anything?x=1").unwrap();
        assert_eq!(found, "http://127.0.0.1:7001");
        // Allowed to fetch inputs from is not enough: the source must be a cluster host.
        for stranger in ["http://127.0.0.1:7002", "http://example.org", "not a url", "file:///etc"]
        {
            let refused = cluster_origin(&scope, stranger).unwrap_err();
            assert!(matches!(refused, PrefetchError::NotACluster(_)), "{stranger}: {refused}");
        }
    }
}
