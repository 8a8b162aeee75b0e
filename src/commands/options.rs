//! Option blocks that several subcommands share, each defined once.

use std::path::PathBuf;

use clap::Args;
use meshflow_api::server::TlsFiles;
use meshflow_api::tls::ClientPolicy;

use super::host::LogArgs;
use super::tokens::{ApiTokenArgs, ClusterArgs, MetricsTokenArgs, UploadTokenArgs};
use crate::embedded::{self, Embedded, Layout, Spec, Tokens};
use meshflow_engine::Access;
use meshflow_runtime::{
    DEFAULT_DEADLINE, DEFAULT_MEMORY_BYTES, Limits, MAX_DEADLINE, MIB, MemoryCapError,
    memory_cap_bytes,
};

/// The sandbox's limits an operator may change (every command that builds a runtime:
/// `apply`, `check`, `run`, `rerun`, `batch`, `host`, `up`, …).
#[derive(Args, Clone, Copy, Debug)]
pub struct SandboxArgs {
    /// Seconds one plugin run may take before the sandbox stops it. Slow filters on large
    /// meshes need more (isotropic remeshing of 1M vertices, 10 rounds: about 50 s).
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_DEADLINE.as_secs(),
          value_parser = clap::value_parser!(u64).range(1..=MAX_DEADLINE.as_secs()))]
    pub run_deadline: u64,
    /// MiB of linear memory one plugin run may grow to, 1-4096 (a 32-bit guest addresses
    /// 4 GiB). The built-ins need 30-60 bytes per triangle, decimation and remeshing up
    /// to 320 (docs/benchmarks.md); each of the host's concurrent runs may take this much.
    #[arg(long, value_name = "MIB", default_value_t = (DEFAULT_MEMORY_BYTES / MIB) as u64,
          value_parser = parse_memory_cap)]
    pub memory_cap: u64,
    /// Run services that declare themselves local (Laplacian and Taubin smoothing) on
    /// partitions of at most this many core triangles, each grown by the service's reach,
    /// on meshes with more: the same result as on the whole mesh, within the memory cap.
    /// Default: the memory cap over 128 bytes (16M triangles under 2 GiB).
    #[arg(long, value_name = "TRIANGLES", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_partition_triangles: Option<u64>,
}

/// `--memory-cap`, refused with the sandbox's own reason when it cannot be given.
fn parse_memory_cap(text: &str) -> Result<u64, MemoryCapParseError> {
    let mib: u64 = text.trim().parse().map_err(|_| MemoryCapParseError::NotANumber)?;
    memory_cap_bytes(mib)?;
    Ok(mib)
}

#[derive(Debug, thiserror::Error)]
enum MemoryCapParseError {
    #[error("expected a whole number of MiB")]
    NotANumber,
    #[error(transparent)]
    Cap(#[from] MemoryCapError),
}

impl Default for SandboxArgs {
    fn default() -> Self {
        Self {
            run_deadline: DEFAULT_DEADLINE.as_secs(),
            memory_cap: (DEFAULT_MEMORY_BYTES / MIB) as u64,
            max_partition_triangles: None,
        }
    }
}

impl SandboxArgs {
    pub fn limits(&self) -> Limits {
        Limits {
            deadline: std::time::Duration::from_secs(self.run_deadline),
            // Checked when parsed, and again by `Runtime::new`.
            memory_bytes: self.memory_cap as usize * MIB,
            max_partition_triangles: self.max_partition_triangles.map(|n| n as usize),
            ..Limits::default()
        }
    }
}

/// Where a run's result and record go (`run`, `rerun`, `submit`).
#[derive(Args, Clone, Debug, Default)]
pub struct RunOutputArgs {
    /// Where to write the result (format by extension; a `.mfm` is written as received).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write the run's record (every step, transfer and timing) as JSON.
    #[arg(long, value_name = "R.json")]
    pub report: Option<PathBuf>,
    /// Print JSON instead of progress: the run's record (a batch: its summary rows; a
    /// re-run: the comparison; `submit` without waiting: the run's id).
    #[arg(long)]
    pub json: bool,
}

/// An engine and hosts started in this process on loopback (`run`, `rerun`, `up`).
#[derive(Args)]
pub struct EmbeddedArgs {
    /// How many hosts to start.
    #[arg(long, default_value_t = 3)]
    pub hosts: usize,
    #[command(flatten)]
    pub api_token: ApiTokenArgs,
    #[command(flatten)]
    pub cluster: ClusterArgs,
    #[command(flatten)]
    pub sandbox: SandboxArgs,
    #[command(flatten)]
    pub upload_token: UploadTokenArgs,
    /// Plugin components (.wasm) every host offers besides the built-ins; their services
    /// serve their names first.
    #[arg(long = "plugin", value_name = "FILE.wasm")]
    pub plugins: Vec<PathBuf>,
    /// Every connection over https, with a certificate authority made for this start
    /// (its certificate is printed, for `--ca-file`).
    #[arg(long)]
    pub tls: bool,
    /// The hosts listen on this port and the next ones (default: any free ports).
    #[arg(long, value_name = "FIRST")]
    pub host_ports: Option<u16>,
}

impl EmbeddedArgs {
    /// Starts the engine on `listen` with `access` and the hosts, with the given tokens or
    /// fresh ones.
    pub async fn start(
        &self,
        listen: &str,
        data: Option<PathBuf>,
        layout: Layout,
        access: Access,
    ) -> anyhow::Result<Embedded> {
        let tokens = Tokens::given_or_fresh(
            self.api_token.get()?,
            self.cluster.token.get()?,
            self.upload_token.get()?,
        )?;
        let plugins = self.plugins.iter().map(|path| crate::plugins::read_plugin_file(path));
        embedded::start(Spec {
            hosts: self.hosts,
            listen: listen.to_owned(),
            data,
            layout,
            tokens,
            access: Access { allow_input_from: self.cluster.allow_input_from.clone(), ..access },
            sandbox: self.sandbox,
            tls: self.tls,
            first_host_port: self.host_ports,
            plugins: plugins.collect::<anyhow::Result<_>>()?,
        })
        .await
    }
}

/// Whom this process's HTTPS clients trust, and whether tokens may cross plain http
/// (every subcommand).
#[derive(Args, Clone, Debug, Default)]
pub struct ClientTlsArgs {
    /// Also trust the certificates in this PEM file (a lab's private CA), besides the
    /// system's roots.
    #[arg(long, global = true, env = "MESHFLOW_CA_FILE", value_name = "PEM")]
    pub ca_file: Option<PathBuf>,
    /// Send tokens over plain http to addresses beyond loopback (only on a network you
    /// trust end to end).
    #[arg(long, global = true)]
    pub insecure_plain_http: bool,
}

impl ClientTlsArgs {
    /// Makes this the policy of every client the process builds.
    pub fn install(&self) -> anyhow::Result<()> {
        let mut policy = ClientPolicy::default().allow_plain_http(self.insecure_plain_http);
        if let Some(path) = &self.ca_file {
            policy = policy.with_ca_file(path)?;
        }
        policy.install();
        Ok(())
    }
}

/// What both servers take for running on a network (`engine`, `host`): TLS, who may read
/// `/metrics`, and the log format.
#[derive(Args, Clone, Debug)]
pub struct ServerOpsArgs {
    #[command(flatten)]
    pub tls: ServerTlsArgs,
    #[command(flatten)]
    pub metrics_token: MetricsTokenArgs,
    #[command(flatten)]
    pub logs: LogArgs,
}

/// A server's certificate and key (`engine`, `host`).
#[derive(Args, Clone, Debug, Default)]
pub struct ServerTlsArgs {
    /// Serve https with this certificate chain (PEM); re-read when the file changes.
    #[arg(long, value_name = "PEM", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// The certificate's private key (PEM).
    #[arg(long, value_name = "PEM", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
}

impl ServerTlsArgs {
    pub fn files(&self) -> Option<TlsFiles> {
        Some(TlsFiles { cert: self.tls_cert.clone()?, key: self.tls_key.clone()? })
    }
}
