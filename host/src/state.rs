//! What every request handler shares: one host's runtime, plugins, sessions and blobs.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::blobs::BlobStore;
use super::config::{
    DOWNLOAD_CONNECT_TIMEOUT, DOWNLOAD_READ_TIMEOUT, DOWNLOAD_TIMEOUT, HostConfig,
    MAX_CONCURRENT_CONVERSIONS,
};
use super::edit_logs::EditLogs;
use super::plugins::PluginSet;
use super::replay::ReplayPlugins;
use super::sessions::Sessions;
use meshflow_api::ClientError;
use meshflow_api::fetch_rules::{FetchScope, Origins, guarded_client, origin, parse_origin};
use meshflow_runtime::Runtime;

pub struct Host {
    pub config: HostConfig,
    /// Where other hosts and the engine reach this one; blob URLs start with it.
    pub public_url: String,
    pub runtime: Arc<Runtime>,
    pub plugins: PluginSet,
    pub sessions: Sessions,
    pub blobs: BlobStore,
    /// Edit logs being encoded after their steps were answered.
    pub edit_logs: EditLogs,
    /// Plugins fetched from other hosts to replay their steps.
    pub replay_plugins: ReplayPlugins,
    /// Slots for meshes being written in a file format ([`MAX_CONCURRENT_CONVERSIONS`]).
    pub conversions: tokio::sync::Semaphore,
    /// For downloads: inputs, corrections and full meshes of other hosts.
    pub http: reqwest::Client,
    /// What every download may reach before a request names its peers (see [`Host::scope`]).
    fetch: FetchScope,
    running: AtomicUsize,
}

/// The folders under `--data`.
pub struct DataDirs {
    pub blobs: PathBuf,
    pub plugins: PathBuf,
    pub replay_plugins: PathBuf,
    pub sessions: PathBuf,
    pub cache: PathBuf,
}

impl DataDirs {
    pub fn create(config: &HostConfig) -> std::io::Result<Self> {
        let data = &config.data_dir;
        let dirs = Self {
            blobs: data.join("blobs"),
            plugins: data.join("plugins"),
            replay_plugins: data.join("replay-plugins"),
            sessions: data.join("sessions"),
            cache: config.artefact_cache.clone().unwrap_or_else(|| data.join("cache")),
        };
        for dir in [&dirs.blobs, &dirs.plugins, &dirs.replay_plugins, &dirs.sessions, &dirs.cache] {
            std::fs::create_dir_all(dir)?;
        }
        Ok(dirs)
    }
}

impl Host {
    pub fn new(
        config: HostConfig,
        public_url: String,
        runtime: Arc<Runtime>,
        plugins: PluginSet,
        dirs: &DataDirs,
    ) -> anyhow::Result<Self> {
        let http = guarded_client()
            .connect_timeout(DOWNLOAD_CONNECT_TIMEOUT)
            .read_timeout(DOWNLOAD_READ_TIMEOUT)
            .build()?;
        let fetch = base_scope(&config, &public_url)?;
        Ok(Self {
            sessions: Sessions::new(dirs.sessions.clone()),
            blobs: BlobStore::new(
                dirs.blobs.clone(),
                config.blob_budget_bytes,
                config.recent_outputs,
            ),
            edit_logs: EditLogs::default(),
            replay_plugins: ReplayPlugins::new(dirs.replay_plugins.clone()),
            conversions: tokio::sync::Semaphore::new(MAX_CONCURRENT_CONVERSIONS),
            config,
            public_url,
            runtime,
            plugins,
            http,
            fetch,
            running: AtomicUsize::new(0),
        })
    }

    pub fn blob_url(&self, name: &str) -> String {
        format!("{}/blobs/{name}", self.public_url)
    }

    pub fn running(&self) -> usize {
        self.running.load(Ordering::Relaxed)
    }

    /// Counts a run in progress until the returned guard drops.
    pub fn start_run(&self) -> RunningGuard<'_> {
        self.running.fetch_add(1, Ordering::Relaxed);
        RunningGuard(&self.running)
    }

    /// What a request naming `peers` (the cluster's origins, as the engine sent them) may
    /// fetch: this host's own origins plus the peers, which also get the cluster token.
    pub fn scope(&self, peers: &[String]) -> Result<FetchScope, String> {
        let mut scope = self.fetch.clone();
        for peer in peers {
            let peer = parse_origin(peer).map_err(|e| format!("peers: {e}"))?;
            scope.allowed.add(peer.clone());
            scope.cluster.insert(peer);
        }
        Ok(scope)
    }

    /// Downloads `url` within `scope`, held to the size cap and the download deadlines.
    pub async fn download(&self, url: &str, scope: &FetchScope) -> Result<Vec<u8>, ClientError> {
        let limit = self.config.max_download_bytes;
        meshflow_api::fetch(&self.http, url, scope, limit, DOWNLOAD_TIMEOUT).await
    }
}

pub struct RunningGuard<'a>(&'a AtomicUsize);

impl Drop for RunningGuard<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

/// The origins a host fetches from whatever the request: its engine's and its own (which
/// also get the cluster token) and its `--allow-input-from`. A host with neither a cluster
/// token nor an allow-list (loopback only, see `start`) fetches from any origin.
fn base_scope(config: &HostConfig, public_url: &str) -> anyhow::Result<FetchScope> {
    let mut cluster = std::collections::BTreeSet::new();
    for url in Some(public_url).into_iter().chain(config.engine.as_deref()) {
        cluster.insert(origin(&reqwest::Url::parse(url)?));
    }
    let mut listed = Vec::new();
    for text in &config.allow_input_from {
        listed.push(parse_origin(text).map_err(anyhow::Error::msg)?);
    }
    let allowed = match config.cluster_token.is_none() && listed.is_empty() {
        true => Origins::any(),
        false => Origins::of(listed.into_iter().chain(cluster.iter().cloned())),
    };
    Ok(FetchScope { allowed, cluster, token: config.cluster_token.clone() })
}
