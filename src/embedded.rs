//! The embedded default: an engine and N hosts in one process, each host on its own
//! loopback port and data folder, so everything between them is real HTTP.

use std::path::PathBuf;

use anyhow::Context;
use clap::ValueEnum;
use meshflow_builtin_plugins::PLUGINS;
use meshflow_engine::EngineHandle;
use meshflow_host::{HostConfig, HostHandle};
use tokio::net::TcpListener;

/// Which built-in plugins each host offers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Layout {
    /// Each filter family on two neighbouring hosts, checks on all: workflows cross hosts,
    /// as services live on different servers in practice, and any one host may fail.
    #[default]
    Spread,
    /// Every host offers every built-in service.
    All,
}

pub struct Embedded {
    pub engine: EngineHandle,
    pub hosts: Vec<HostHandle>,
    /// Removed when the embedded system stops, unless the user gave a folder.
    _scratch: Option<tempfile::TempDir>,
}

/// Starts `hosts` hosts on 127.0.0.1 and an engine on `listen` that knows them.
pub async fn start(
    hosts: usize,
    listen: &str,
    data: Option<PathBuf>,
    layout: Layout,
) -> anyhow::Result<Embedded> {
    anyhow::ensure!(hosts > 0, "at least one host is needed");
    let (scratch, data) = match data {
        Some(dir) => (None, dir),
        None => {
            let dir = tempfile::Builder::new().prefix("meshflow-up-").tempdir()?;
            let path = dir.path().to_owned();
            (Some(dir), path)
        }
    };
    let mut handles = Vec::with_capacity(hosts);
    for index in 0..hosts {
        let config = HostConfig {
            builtins: builtins_for(index, hosts, layout),
            artefact_cache: crate::plugins::cache_dir(),
            ..HostConfig::new(data.join(format!("host-{index}")))
        };
        let listener = TcpListener::bind("127.0.0.1:0").await?;
        let handle = meshflow_host::start(config, listener)
            .await
            .with_context(|| format!("starting host {index}"))?;
        handles.push(handle);
    }
    let urls: Vec<String> = handles.iter().map(|h| h.url.clone()).collect();
    let listener =
        TcpListener::bind(listen).await.with_context(|| format!("listening on {listen}"))?;
    let engine = meshflow_engine::start(data.join("engine"), None, &urls, listener).await?;
    Ok(Embedded { engine, hosts: handles, _scratch: scratch })
}

/// The built-in components host `index` of `hosts` offers under `layout`.
fn builtins_for(index: usize, hosts: usize, layout: Layout) -> Vec<&'static [u8]> {
    let families = PLUGINS.iter().filter(|p| p.name != "checks");
    let spread = families
        .enumerate()
        .filter(|(k, _)| hosts < 3 || k % hosts == index || (k + 1) % hosts == index);
    let checks = PLUGINS.iter().filter(|p| p.name == "checks");
    match layout {
        Layout::All => PLUGINS.iter().map(|p| p.wasm).collect(),
        Layout::Spread => spread.map(|(_, p)| p).chain(checks).map(|p| p.wasm).collect(),
    }
}
