//! The host HTTP server: services, plugin upload, sessions that load a
//! mesh from a URL and then run services or take other hosts' steps, and blobs.
//!
//! The engine must not link this crate: it runs plugins (wasmtime). Domain modules know
//! no HTTP and return typed errors, and depend one way, each only on those listed after it:
//! - orchestration over the whole host: `steps` (a session runs a service or takes another
//!   host's step), `rebuild` (loading and replaying a session), `eviction`;
//! - `state` (the `Host` every handler shares: it holds what follows);
//! - its parts: `edit_logs` (encoded after the answer, into the blobs), `replay` (naming a
//!   step, re-running a named one with the offered or fetched plugins), `conversions`
//!   (meshes written as files, from the blobs and sessions);
//! - `plugins` (the plugin set), `sessions` (table and records), `blobs` (storage),
//!   `downloads` (the client and fetch scopes);
//! - `meshes` (formats, decoding, blob names), `config` (settings and limits).
//!
//! Only `routes/` speaks HTTP: one file per resource, each a thin adapter over the above,
//! and `routes/error.rs` maps every domain error to a status and code.

mod blobs;
mod config;
mod conversions;
mod downloads;
mod edit_logs;
mod eviction;
mod meshes;
mod metrics;
mod plugins;
mod rebuild;
pub mod replay;
mod routes;
mod sessions;
mod spool;
mod state;
mod steps;

pub use config::*;
pub use plugins::MAX_PLUGIN_BYTES;

use std::sync::Arc;

use anyhow::Context;
use tokio::net::TcpListener;

use meshflow_api::server::{TlsFiles, check_exposure, serve_with};
use meshflow_api::tls::plain_http_refusal;
use meshflow_runtime::Runtime;
use state::{DataDirs, Host};

/// A running host server.
pub struct HostHandle {
    /// Where it is reached (its public URL).
    pub url: String,
    shutdown: tokio::sync::oneshot::Sender<()>,
    server: tokio::task::JoinHandle<std::io::Result<()>>,
    background: Vec<tokio::task::AbortHandle>,
    host: Arc<Host>,
}

impl HostHandle {
    /// Stops accepting requests, lets those in flight finish and the edit logs of answered
    /// steps be written, and returns.
    pub async fn shutdown(self) -> anyhow::Result<()> {
        let _ = self.shutdown.send(());
        self.background.iter().for_each(|task| task.abort());
        self.server.await.context("the host server task failed")??;
        self.host.edit_logs.finish_all().await;
        Ok(())
    }

    /// The built-in services an uploaded plugin serves in their place, by name (sorted):
    /// what a user who installed plugins should hear about.
    pub fn shadowed_builtins(&self) -> Vec<String> {
        let mut names: Vec<String> = (self.host.plugins.services().into_iter())
            .filter(|entry| entry.builtin && entry.pinned_only)
            .map(|entry| entry.info.name)
            .collect();
        names.sort();
        names.dedup();
        names
    }
}

/// Starts a host on `listener`: loads the plugins (built-in and stored), rebuilds stored
/// sessions in the background, serves, and registers with the engine if one is given.
/// Without a cluster token it listens only on loopback, unless `insecure_no_auth`.
pub async fn start(config: HostConfig, listener: TcpListener) -> anyhow::Result<HostHandle> {
    let address = listener.local_addr()?;
    let missing: &[&str] = match config.cluster_token {
        Some(_) => &[],
        None => &["a cluster token"],
    };
    check_exposure(address, missing, config.insecure_no_auth)?;
    let dirs = DataDirs::create(&config).with_context(|| {
        format!("creating the data folders under {}", config.data_dir.display())
    })?;
    let tls = config.tls.as_ref().map(TlsFiles::server_config).transpose()?;
    let scheme = if tls.is_some() { "https" } else { "http" };
    let public_url = match &config.public_url {
        Some(url) => url.trim_end_matches('/').to_owned(),
        None if address.ip().is_unspecified() => format!("{scheme}://127.0.0.1:{}", address.port()),
        None => format!("{scheme}://{address}"),
    };
    let (runtime, plugins) = {
        let (limits, cache) = (config.limits.clone(), dirs.cache.clone());
        let (plugin_dir, builtins) = (dirs.plugins.clone(), config.builtins.clone());
        tokio::task::spawn_blocking(move || {
            let runtime = Runtime::new(limits, Some(&cache))?;
            let plugins = plugins::PluginSet::load(&runtime, plugin_dir, &builtins)?;
            Ok::<_, anyhow::Error>((Arc::new(runtime), plugins))
        })
        .await??
    };
    let host = Arc::new(Host::new(config, public_url.clone(), runtime, plugins, &dirs)?);
    for (id, record) in host.sessions.saved_records() {
        rebuild::start(&host, id, record)?;
    }

    let (shutdown, stop) = tokio::sync::oneshot::channel::<()>();
    let app = routes::router(host.clone());
    let server = tokio::spawn(serve_with(listener, app, tls, async {
        let _ = stop.await;
    }));
    let mut background =
        vec![tokio::spawn(eviction::run_periodically(host.clone())).abort_handle()];
    if let Some(engine) = host.config.engine.clone() {
        let registration = register(host.clone(), engine, public_url.clone());
        background.push(tokio::spawn(registration).abort_handle());
    }
    tracing::info!("host listening on {address}, reached at {public_url}");
    Ok(HostHandle { url: public_url, shutdown, server, background, host })
}

/// Serves until Ctrl-C.
pub async fn serve(config: HostConfig, listener: TcpListener) -> anyhow::Result<()> {
    let handle = start(config, listener).await?;
    tokio::signal::ctrl_c().await?;
    tracing::info!("shutting down");
    handle.shutdown().await
}

/// `POST {engine}/hosts {"url"}` with the cluster token, a few times; a failure is logged,
/// not fatal.
async fn register(host: Arc<Host>, engine: String, url: String) {
    let endpoint = format!("{}/hosts", engine.trim_end_matches('/'));
    let plain = reqwest::Url::parse(&endpoint).ok().and_then(|url| plain_http_refusal(&url));
    if let Some(refusal) = plain.filter(|_| host.config.cluster_token.is_some()) {
        tracing::error!("not registering with the engine: {refusal}");
        return;
    }
    for attempt in 1..=REGISTER_ATTEMPTS {
        let mut request = host.downloads.client().post(&endpoint).timeout(REGISTER_TIMEOUT);
        if let Some(token) = &host.config.cluster_token {
            request = request.bearer_auth(token);
        }
        let sent = request.json(&serde_json::json!({ "url": url })).send().await;
        match sent.and_then(|r| r.error_for_status()) {
            Ok(_) => {
                tracing::info!("registered with the engine at {engine}");
                return;
            }
            Err(e) => tracing::warn!("registering with {endpoint} (attempt {attempt}): {e}"),
        }
        tokio::time::sleep(REGISTER_RETRY).await;
    }
    tracing::warn!("gave up registering with the engine at {engine}");
}
