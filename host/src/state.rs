//! What every request handler shares: one host's runtime, plugins, sessions and blobs.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::blobs::BlobStore;
use super::config::HostConfig;
use super::plugins::PluginSet;
use super::sessions::Sessions;
use meshflow_runtime::Runtime;

pub struct Host {
    pub config: HostConfig,
    /// Where other hosts and the engine reach this one; blob URLs start with it.
    pub public_url: String,
    pub runtime: Arc<Runtime>,
    pub plugins: PluginSet,
    pub sessions: Sessions,
    pub blobs: BlobStore,
    /// For downloads: inputs, corrections and full meshes of other hosts.
    pub http: reqwest::Client,
    running: AtomicUsize,
}

/// The folders under `--data`.
pub struct DataDirs {
    pub blobs: PathBuf,
    pub plugins: PathBuf,
    pub sessions: PathBuf,
    pub cache: PathBuf,
}

impl DataDirs {
    pub fn create(config: &HostConfig) -> std::io::Result<Self> {
        let data = &config.data_dir;
        let dirs = Self {
            blobs: data.join("blobs"),
            plugins: data.join("plugins"),
            sessions: data.join("sessions"),
            cache: config.artefact_cache.clone().unwrap_or_else(|| data.join("cache")),
        };
        for dir in [&dirs.blobs, &dirs.plugins, &dirs.sessions, &dirs.cache] {
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
        let http = reqwest::Client::builder()
            .connect_timeout(super::config::DOWNLOAD_CONNECT_TIMEOUT)
            .read_timeout(super::config::DOWNLOAD_READ_TIMEOUT)
            .build()?;
        Ok(Self {
            sessions: Sessions::new(dirs.sessions.clone()),
            blobs: BlobStore::new(
                dirs.blobs.clone(),
                config.blob_budget_bytes,
                config.recent_outputs,
            ),
            config,
            public_url,
            runtime,
            plugins,
            http,
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

    /// Downloads `url`, held to the size cap.
    pub async fn download(&self, url: &str) -> Result<Vec<u8>, String> {
        meshflow_api::fetch(&self.http, url, self.config.max_download_bytes)
            .await
            .map_err(|e| e.to_string())
    }
}

pub struct RunningGuard<'a>(&'a AtomicUsize);

impl Drop for RunningGuard<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}
