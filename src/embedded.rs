//! The embedded default: an engine and N hosts in one process, each host on its own
//! loopback port and data folder, so everything between them is real HTTP.

use std::path::PathBuf;

use anyhow::Context;
use clap::ValueEnum;
use meshflow_api::server::throwaway;
use meshflow_api::tls::ClientPolicy;
use meshflow_builtin_plugins::PLUGINS;
use meshflow_engine::{Access, EngineHandle};
use meshflow_host::{HostConfig, HostHandle};
use tokio::net::TcpListener;

use crate::commands::tokens;

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
    /// The hosts' upload token: what a plugin author gives `meshflow plugin upload`.
    pub upload: String,
}

impl Tokens {
    /// The given tokens, and fresh random ones for those not given.
    pub fn given_or_fresh(
        api: Option<String>,
        cluster: Option<String>,
        upload: Option<String>,
    ) -> anyhow::Result<Self> {
        let fresh = |given: Option<String>| given.map_or_else(tokens::fresh, Ok);
        Ok(Self { api: fresh(api)?, cluster: fresh(cluster)?, upload: fresh(upload)? })
    }
}

/// What to start: `hosts` hosts on 127.0.0.1 (on ports from `first_host_port` on, else
/// any) and an engine on `listen` that knows them, all with `tokens`; the engine with
/// `access` (its users file, allowed origins, …), whose tokens and `insecure_no_auth` are
/// the embedded system's.
pub struct Spec {
    pub hosts: usize,
    pub listen: String,
    /// Kept across starts when given; else a temporary folder, removed at the end.
    pub data: Option<PathBuf>,
    pub layout: Layout,
    pub tokens: Tokens,
    pub access: Access,
    pub sandbox: crate::SandboxArgs,
    /// Every connection over https, with a throwaway CA made under the data folder, which
    /// this process's clients trust.
    pub tls: bool,
    pub first_host_port: Option<u16>,
    /// Plugin components every host offers besides the built-ins (installed in each
    /// host's plugin folder, as an upload would be, so they serve their names first).
    pub plugins: Vec<Vec<u8>>,
}

/// Starts the engine and hosts `spec` describes.
pub async fn start(spec: Spec) -> anyhow::Result<Embedded> {
    let Spec { hosts, listen, data, layout, tokens, access, sandbox, tls, .. } = spec;
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
        true => Some(throwaway::make(&data.join("tls"), "meshflow")?),
        false => None,
    };
    if let Some(tls) = &tls {
        ClientPolicy::installed().with_ca_file(&tls.ca)?.install();
    }
    let server_tls = tls.as_ref().map(|tls| tls.server.clone());
    let mut handles = Vec::with_capacity(hosts);
    for index in 0..hosts {
        let dir = data.join(format!("host-{index}"));
        install_plugins(&dir.join("plugins"), &spec.plugins)?;
        let config = HostConfig {
            builtins: builtins_for(index, hosts, layout),
            artefact_cache: crate::plugins::cache_dir(),
            token: Some(tokens.upload.clone()),
            cluster_token: Some(tokens.cluster.clone()),
            allow_input_from: allow_input_from.clone(),
            limits: sandbox.limits(),
            tls: server_tls.clone(),
            ..HostConfig::new(dir)
        };
        let port = spec.first_host_port.map_or(0, |first| first.saturating_add(index as u16));
        let listener = TcpListener::bind(("127.0.0.1", port))
            .await
            .with_context(|| format!("listening on 127.0.0.1:{port} for host {index}"))?;
        let handle = meshflow_host::start(config, listener)
            .await
            .with_context(|| format!("starting host {index}"))?;
        handles.push(handle);
    }
    warn_shadowed(&handles);
    let urls: Vec<String> = handles.iter().map(|h| h.url.clone()).collect();
    let listener =
        TcpListener::bind(&listen).await.with_context(|| format!("listening on {listen}"))?;
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

/// Writes each component into a host's plugin folder under its digest, as an upload
/// keeps it; the host validates it when it loads the folder.
fn install_plugins(dir: &std::path::Path, plugins: &[Vec<u8>]) -> anyhow::Result<()> {
    if plugins.is_empty() {
        return Ok(());
    }
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for bytes in plugins {
        let path = dir.join(format!("{}.wasm", meshflow_runtime::digest(bytes)));
        meshflow_meshio::write_private_file(&path, |out| out.write_all(bytes))?;
    }
    Ok(())
}

/// One line on stderr per built-in service a `--plugin` component hides on some host: the
/// plugin's service of that name runs instead, there and in every workflow naming it.
fn warn_shadowed(hosts: &[HostHandle]) {
    let mut names: Vec<String> = hosts.iter().flat_map(HostHandle::shadowed_builtins).collect();
    names.sort();
    names.dedup();
    for name in names {
        eprintln!(
            "warning: a --plugin component's `{name}` shadows the built-in service of that name"
        );
    }
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
