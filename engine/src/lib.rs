//! The meshflow engine: reads workflows, picks hosts, runs the concurrent transfer protocol
//! between them, and serves the engine HTTP API (DESIGN §5–6). Its state lives in SQLite
//! under the data folder, so a restart loses no run (DESIGN §10).
//!
//! This crate must not depend on wasmtime or the host server: it speaks to hosts only
//! through `meshflow-api`, and handles no mesh bytes: hosts write downloads in the user's
//! format (`downloads.rs`). `tests/layers.rs` holds it to that.
//!
//! Inside, dependencies point one way: `routes` (the HTTP API) and `batches` over `engine`
//! (the state: runs, hosts, inputs), over `executor`, `plan`, `registry`, `store` and
//! `run`, over `workflow`, `record` and `limits`. This file only starts the server.

mod admission;
pub mod auth;
mod batch_drivers;
mod batches;
pub mod downloads;
mod engine;
mod executor;
mod files;
mod inputs;
pub mod limits;
pub mod measured;
mod metrics;
pub mod plan;
pub mod record;
pub mod registry;
pub mod rerun;
mod routes;
pub mod run;
mod store;
pub mod summary;
pub mod trust;
pub mod users;
pub mod validate;
mod verified;
pub mod workflow;

use std::path::PathBuf;
use std::sync::Arc;

pub use auth::Access;
pub use engine::{Engine, EngineConfig, SubmitError};
pub use routes::router;

/// A running engine server.
pub struct EngineHandle {
    pub url: String,
    /// Where it listens (its public URL may name another address).
    pub address: std::net::SocketAddr,
    pub engine: Arc<Engine>,
    server: tokio::task::JoinHandle<std::io::Result<()>>,
}

impl EngineHandle {
    /// Serves until the process ends.
    pub async fn wait(self) -> anyhow::Result<()> {
        Ok(self.server.await??)
    }
}

/// Starts an engine on `listener` with its state under `data_dir`: registers `hosts` and
/// the hosts it knew before, resumes the runs it was executing, and serves in the
/// background, over https when `access.tls` names a certificate. Without both tokens it
/// listens only on loopback, unless `access.insecure_no_auth`.
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
    let tls = access.tls.as_ref().map(|files| files.server_config()).transpose()?;
    let scheme = if tls.is_some() { "https" } else { "http" };
    let url = public_url.unwrap_or_else(|| match address.ip().is_unspecified() {
        true => format!("{scheme}://127.0.0.1:{}", address.port()),
        false => format!("{scheme}://{address}"),
    });
    let (engine, unfinished, known) =
        Engine::open(EngineConfig { data_dir, public_url: url.clone(), access })?;
    // Hosts named at start are checked first (a bad URL stops the start); those known from
    // before are polled again together.
    for host in hosts {
        engine.registry.register(host).await?.keep_always();
    }
    let again = known.iter().map(|host| engine.registry.register(host));
    for (host, registered) in known.iter().zip(futures_util::future::join_all(again).await) {
        if let Err(error) = registered {
            tracing::warn!("forgetting host {host}: {error}");
        }
    }
    for entry in engine.registry.hosts() {
        if let Some(error) = entry.state().last_error {
            tracing::warn!("host {} does not answer yet: {error}", entry.url);
        }
    }
    engine.settle_completed();
    for stored in unfinished {
        tracing::info!("resuming run {}", stored.id);
        engine.resume(stored);
    }
    engine.resume_batches().await;
    let app = router(engine.clone());
    let serving = meshflow_api::server::serve_with(listener, app, tls, std::future::pending());
    let server = tokio::spawn(serving);
    tracing::info!("engine listening on {address}, reached at {url}");
    Ok(EngineHandle { url, address, engine, server })
}

/// Copies the engine's database under `data_dir` to `to` (SQLite's online backup: safe while
/// the engine runs); the copy is readable by this user only.
pub fn backup(data_dir: &std::path::Path, to: &std::path::Path) -> anyhow::Result<()> {
    let from = data_dir.join(engine::DATABASE);
    anyhow::ensure!(from.is_file(), "no engine database at {}", from.display());
    store::backup(&from, to)?;
    Ok(())
}
