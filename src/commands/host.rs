//! `meshflow host`: serve the host HTTP API (sessions, services, plugin upload, blobs).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use clap::Args;

use super::options::ServerOpsArgs;
use super::tokens::{self, ClusterArgs};
use meshflow_host::{
    DEFAULT_BLOB_BUDGET_BYTES, DEFAULT_MAX_DOWNLOAD_BYTES, DEFAULT_SESSION_TTL, HostConfig, serve,
};

#[derive(Args)]
pub struct HostArgs {
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:7070", value_name = "ADDR")]
    listen: String,
    /// Folder for blobs, uploaded plugins, compiled components and sessions; kept across
    /// restarts.
    #[arg(long, value_name = "DIR")]
    data: PathBuf,
    /// Upload token: bearer token for plugin upload and delete; without it uploads are
    /// refused.
    #[arg(long, env = "MESHFLOW_UPLOAD_TOKEN", hide_env_values = true, value_name = "TOKEN")]
    token: Option<String>,
    /// Read the upload token from this file.
    #[arg(long, value_name = "PATH")]
    token_file: Option<PathBuf>,
    #[command(flatten)]
    cluster: ClusterArgs,
    /// Listen on a non-loopback address without a cluster token (anyone reaching it can
    /// use it).
    #[arg(long)]
    insecure_no_auth: bool,
    /// Run only the plugins this host loaded itself (built in or uploaded here): no replays
    /// of other hosts' plugins (they reach it as edit logs or full meshes instead), and no
    /// steps the engine would move here because the mesh is here.
    #[arg(long)]
    no_foreign_plugins: bool,
    /// Engine to register with at start.
    #[arg(long, value_name = "URL")]
    engine: Option<String>,
    /// URL others reach this host at (default: http:// + the listening address).
    #[arg(long, value_name = "URL")]
    public_url: Option<String>,
    /// Total size of stored blobs before the oldest unneeded ones are deleted.
    #[arg(long, value_name = "MIB", default_value_t = DEFAULT_BLOB_BUDGET_BYTES >> 20)]
    blob_budget_mib: u64,
    /// Sessions idle this long are deleted.
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_SESSION_TTL.as_secs())]
    session_ttl: u64,
    /// Largest download (input, correction, full mesh) accepted.
    #[arg(long, value_name = "MIB", default_value_t = DEFAULT_MAX_DOWNLOAD_BYTES >> 20)]
    max_download_mib: u64,
    /// Built-in plugin families to load (comma list of smoothing, checks, holes, cleanup);
    /// default all. Hosts offering different services make a workflow cross hosts.
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    builtin: Option<Vec<String>>,
    #[command(flatten)]
    ops: ServerOpsArgs,
    #[command(flatten)]
    sandbox: crate::SandboxArgs,
}

pub fn run(args: HostArgs) -> anyhow::Result<()> {
    init_logging(args.ops.logs.log_format);
    tokens::warn_if_in_argv("--token", "--token-file", "MESHFLOW_UPLOAD_TOKEN");
    let config = HostConfig {
        token: tokens::read(args.token.as_deref(), args.token_file.as_deref())?,
        cluster_token: args.cluster.token.get()?,
        allow_input_from: args.cluster.allow_input_from,
        insecure_no_auth: args.insecure_no_auth,
        foreign_plugins: !args.no_foreign_plugins,
        engine: args.engine,
        public_url: args.public_url,
        tls: args.ops.tls.files(),
        metrics_token: args.ops.metrics_token.get()?,
        builtins: builtin_components(args.builtin.as_deref())?,
        blob_budget_bytes: args.blob_budget_mib << 20,
        session_ttl: Duration::from_secs(args.session_ttl),
        max_download_bytes: args.max_download_mib << 20,
        limits: args.sandbox.limits(),
        ..HostConfig::new(args.data)
    };
    tokio::runtime::Runtime::new()?.block_on(async {
        let listener = tokio::net::TcpListener::bind(&args.listen)
            .await
            .with_context(|| format!("listening on {}", args.listen))?;
        serve(config, listener).await
    })
}

/// The components of the named built-in families, or of all of them.
fn builtin_components(names: Option<&[String]>) -> anyhow::Result<Vec<&'static [u8]>> {
    let Some(names) = names else { return Ok(crate::plugins::builtin_components()) };
    let known = meshflow_builtin_plugins::PLUGINS;
    names
        .iter()
        .map(|name| {
            let builtin = known.iter().find(|builtin| builtin.name == name.as_str());
            builtin.map(|builtin| builtin.wasm).with_context(|| {
                let names: Vec<&str> = known.iter().map(|builtin| builtin.name).collect();
                format!("no built-in plugin family {name:?}; known: {}", names.join(", "))
            })
        })
        .collect()
}

/// How servers write their log lines on stderr.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LogFormat {
    /// One readable line per event.
    #[default]
    Text,
    /// One JSON object per line: `timestamp`, `level`, `message` and the event's fields.
    Json,
}

/// `--log-format`, for the commands that serve.
#[derive(Args, Clone, Copy, Debug, Default)]
pub struct LogArgs {
    /// Log lines as text, or as JSON objects (one a line) for a log collector.
    #[arg(long, value_enum, default_value_t = LogFormat::Text, value_name = "FORMAT")]
    pub log_format: LogFormat,
}

/// Log lines on stderr in `format`; a second call (several servers in one process) is
/// harmless.
pub fn init_logging(format: LogFormat) {
    let logs = tracing_subscriber::fmt().with_target(false).with_writer(std::io::stderr);
    let _ = match format {
        LogFormat::Text => logs.try_init(),
        LogFormat::Json => logs.json().flatten_event(true).try_init(),
    };
}
