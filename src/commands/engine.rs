//! `meshflow engine`: serve the engine HTTP API and web UI over the given hosts;
//! `meshflow engine backup`: copy its database while it runs.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use meshflow_engine::Access;

use super::options::ServerOpsArgs;
use super::tokens::{ApiTokenArgs, ClusterArgs};

#[derive(Args)]
pub struct EngineArgs {
    #[command(subcommand)]
    command: Option<EngineCommand>,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:7000", value_name = "ADDR")]
    listen: String,
    /// A host to use (more can register themselves with `meshflow host --engine`).
    #[arg(long = "host", value_name = "URL")]
    hosts: Vec<String>,
    /// Folder for uploaded inputs.
    #[arg(long, value_name = "DIR", default_value = "meshflow-engine-data")]
    data: PathBuf,
    /// URL hosts and browsers reach this engine at (default: http:// + the listening
    /// address, https:// with --tls-cert); its host name is one the engine answers to.
    #[arg(long, value_name = "URL")]
    public_url: Option<String>,
    #[command(flatten)]
    api_token: ApiTokenArgs,
    /// Named users, one a line: `NAME ROLE TOKEN` (role `user` or `admin`, the token as
    /// itself or `sha256:<hex>`); read again when it changes.
    #[arg(long, value_name = "FILE")]
    users: Option<PathBuf>,
    /// An origin (scheme://host[:port]) whose pages may use this engine besides its own;
    /// repeat for more.
    #[arg(long, value_name = "ORIGIN")]
    allow_origin: Vec<String>,
    #[command(flatten)]
    ops: ServerOpsArgs,
    #[command(flatten)]
    cluster: ClusterArgs,
    /// Listen on a non-loopback address without tokens (anyone reaching it can use it).
    #[arg(long)]
    insecure_no_auth: bool,
    /// How far a host is trusted: `trusted` (default), `spot-check` (a share of its steps
    /// replayed elsewhere) or `untrusted` (every result replayed before anyone builds on
    /// it); kept in the database. Repeatable.
    #[arg(long = "host-trust", value_name = "URL=LEVEL", value_parser = meshflow_engine::trust::parse_assignment)]
    host_trust: Vec<(String, meshflow_engine::trust::Trust)>,
    /// The share of a `spot-check` host's steps replayed on another host (0 to 1).
    #[arg(long = "spot-check", value_name = "SHARE", default_value_t = meshflow_engine::trust::DEFAULT_SPOT_CHECK)]
    spot_check: f64,
}

#[derive(Subcommand)]
enum EngineCommand {
    /// Copy the engine's database to a file, safely while the engine runs (SQLite's online
    /// backup); restore by putting the copy in place as DIR/engine.sqlite3.
    Backup(BackupArgs),
}

#[derive(Args)]
struct BackupArgs {
    /// The engine's data folder.
    #[arg(long, value_name = "DIR", default_value = "meshflow-engine-data")]
    data: PathBuf,
    /// Where to write the copy.
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
}

pub fn run(args: EngineArgs) -> anyhow::Result<()> {
    if let Some(EngineCommand::Backup(backup)) = args.command {
        meshflow_engine::backup(&backup.data, &backup.output)?;
        eprintln!("engine database backed up to {}", backup.output.display());
        return Ok(());
    }
    super::host::init_logging(args.ops.logs.log_format);
    let access = Access {
        api_token: args.api_token.get()?,
        users_file: args.users,
        cluster_token: args.cluster.token.get()?,
        allow_input_from: args.cluster.allow_input_from,
        insecure_no_auth: args.insecure_no_auth,
        allow_origins: args.allow_origin,
        tls: args.ops.tls.files(),
        metrics_token: args.ops.metrics_token.get()?,
    };
    tokio::runtime::Runtime::new()?.block_on(async {
        let listener = tokio::net::TcpListener::bind(&args.listen)
            .await
            .with_context(|| format!("listening on {}", args.listen))?;
        let handle =
            meshflow_engine::start(args.data, args.public_url, &args.hosts, access, listener)
                .await?;
        let registry = &handle.engine.registry;
        registry.set_spot_check_share(args.spot_check);
        for (url, level) in &args.host_trust {
            registry.set_trust(url, *level).await?;
        }
        eprintln!("engine: {} (web UI at {0}/)", handle.url);
        tokio::select! {
            served = handle.wait() => served,
            _ = tokio::signal::ctrl_c() => Ok(()),
        }
    })
}
