//! What every request handler shares: one host's runtime, plugins, sessions, blobs and
//! downloads, and the work in flight over them.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::blobs::BlobStore;
use super::config::HostConfig;
use super::conversions::Conversions;
use super::downloads::Downloads;
use super::edit_logs::EditLogs;
use super::metrics::Metrics;
use super::plugins::PluginSet;
use super::replay::ReplayPlugins;
use super::sessions::Sessions;
use meshflow_runtime::Runtime;

pub struct Host {
    pub config: HostConfig,
    /// Where other hosts and the engine reach this one; blob URLs start with it.
    pub public_url: String,
    pub runtime: Arc<Runtime>,
    pub plugins: PluginSet,
    pub sessions: Sessions,
    /// Shared with the edit logs being encoded in the background.
    pub blobs: Arc<BlobStore>,
    /// Edit logs being encoded after their steps were answered.
    pub edit_logs: EditLogs,
    /// Plugins fetched from other hosts to replay their steps.
    pub replay_plugins: ReplayPlugins,
    /// Meshes being written in a file format.
    pub conversions: Conversions,
    /// Inputs, corrections and full meshes of other hosts, within the fetch rules.
    pub downloads: Downloads,
    /// What `GET /metrics` reports.
    pub metrics: Metrics,
    /// This process among the host's lives: `GET /health` says it, so the engine learns of
    /// a restart (and forgets the plugins it had fetched, held in memory only).
    pub instance: String,
    running: AtomicUsize,
}

/// The folders under `--data`.
pub struct DataDirs {
    pub blobs: PathBuf,
    pub plugins: PathBuf,
    pub replay_plugins: PathBuf,
    pub sessions: PathBuf,
    pub cache: PathBuf,
    /// The edit logs' bytes per edit, kept across restarts (a file).
    pub edit_log_rates: PathBuf,
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
            edit_log_rates: data.join("edit-log-rates.json"),
        };
        for dir in [&dirs.blobs, &dirs.plugins, &dirs.replay_plugins, &dirs.sessions, &dirs.cache] {
            std::fs::create_dir_all(dir)?;
        }
        // Sessions' inputs and uploaded plugins are the users': no one else on the machine
        // reads them (an existing folder is tightened too).
        std::fs::set_permissions(data, std::os::unix::fs::PermissionsExt::from_mode(0o700))?;
        Ok(dirs)
    }
}

/// Names one run of this process: its id and start time, hashed (not a secret, just
/// different each start).
fn instance_id() -> String {
    let started = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default()
        .as_nanos();
    let mut hasher = blake3::Hasher::new();
    hasher.update(&std::process::id().to_le_bytes()).update(&started.to_le_bytes());
    hasher.finalize().to_hex()[..16].to_owned()
}

impl Host {
    pub fn new(
        config: HostConfig,
        public_url: String,
        runtime: Arc<Runtime>,
        plugins: PluginSet,
        dirs: &DataDirs,
    ) -> anyhow::Result<Self> {
        let downloads = Downloads::new(&config, &public_url)?;
        let replay_plugins = ReplayPlugins::new(
            dirs.replay_plugins.clone(),
            runtime.clone(),
            downloads.client().clone(),
            config.foreign_plugins,
        );
        let recent = (config.recent_outputs, config.recent_output_bytes);
        let blobs = BlobStore::new(dirs.blobs.clone(), config.blob_budget_bytes, recent);
        Ok(Self {
            sessions: Sessions::new(dirs.sessions.clone()),
            blobs: Arc::new(blobs),
            edit_logs: EditLogs::kept_in(dirs.edit_log_rates.clone()),
            replay_plugins,
            conversions: Conversions::default(),
            metrics: Metrics::new(downloads.downloaded()),
            downloads,
            config,
            public_url,
            runtime,
            plugins,
            instance: instance_id(),
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
}

pub struct RunningGuard<'a>(&'a AtomicUsize);

impl Drop for RunningGuard<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}
