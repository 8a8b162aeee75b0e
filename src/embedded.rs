//! The embedded default: an engine and N hosts in one process, each host on its own
//! loopback port and data folder, so everything between them is real HTTP.

use std::path::PathBuf;

use anyhow::Context;
use clap::ValueEnum;
use meshflow_api::tls::ClientPolicy;
use meshflow_builtin_plugins::PLUGINS;
use meshflow_engine::{Access, EngineHandle};
use meshflow_host::{HostConfig, HostHandle};
use tokio::net::TcpListener;

use crate::commands::tokens;
use crate::throwaway_tls;

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
    /// The tokens the engine and hosts were started with.
    pub tokens: Tokens,
    /// With TLS, the throwaway CA's certificate (what clients give as `--ca-file`).
    pub ca: Option<PathBuf>,
    /// Removed when the embedded system stops, unless the user gave a folder.
    _scratch: Option<tempfile::TempDir>,
}

/// The embedded system's secrets: given, or fresh for each start.
#[derive(Clone, Debug)]
pub struct Tokens {
    pub api: String,
    pub cluster: String,
}

impl Tokens {
    /// The given tokens, and fresh random ones for those not given.
    pub fn given_or_fresh(api: Option<String>, cluster: Option<String>) -> anyhow::Result<Self> {
        let fresh = |given: Option<String>| given.map_or_else(tokens::fresh, Ok);
        Ok(Self { api: fresh(api)?, cluster: fresh(cluster)? })
    }
}

/// Starts `hosts` hosts on 127.0.0.1 and an engine on `listen` that knows them, all with
/// `tokens`; the engine with `access` (its users file, allowed origins, …), whose tokens
/// and `insecure_no_auth` are the embedded system's. With `tls`, everything speaks https
/// with a throwaway CA made under the data folder, which this process's clients trust.
#[allow(clippy::too_many_arguments)]
pub async fn start(
    hosts: usize,
    listen: &str,
    data: Option<PathBuf>,
    layout: Layout,
    tokens: Tokens,
    access: Access,
    sandbox: crate::SandboxArgs,
    tls: bool,
) -> anyhow::Result<Embedded> {
    let allow_input_from = access.allow_input_from.clone();
    anyhow::ensure!(hosts > 0, "at least one host is needed");
    let (scratch, data) = match data {
        Some(dir) => (None, dir),
        None => {
            let dir = tempfile::Builder::new().prefix("meshflow-up-").tempdir()?;
            let path = dir.path().to_owned();
            (Some(dir), path)
        }
    };
    let tls = match tls {
        true => Some(throwaway_tls::make(&data.join("tls"))?),
        false => None,
    };
    if let Some(tls) = &tls {
        ClientPolicy::installed().with_ca_file(&tls.ca)?.install();
    }
    let server_tls = tls.as_ref().map(|tls| tls.server.clone());
    let mut handles = Vec::with_capacity(hosts);
    for index in 0..hosts {
        let config = HostConfig {
            builtins: builtins_for(index, hosts, layout),
            artefact_cache: crate::plugins::cache_dir(),
            cluster_token: Some(tokens.cluster.clone()),
            allow_input_from: allow_input_from.clone(),
            limits: sandbox.limits(),
            tls: server_tls.clone(),
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
    let access = Access {
        api_token: Some(tokens.api.clone()),
        cluster_token: Some(tokens.cluster.clone()),
        allow_input_from,
        insecure_no_auth: false,
        tls: server_tls,
        ..access
    };
    let engine = meshflow_engine::start(data.join("engine"), None, &urls, access, listener).await?;
    let ca = tls.map(|tls| tls.ca);
    Ok(Embedded { engine, hosts: handles, tokens, ca, _scratch: scratch })
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
