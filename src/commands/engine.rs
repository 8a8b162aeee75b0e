//! `meshflow engine`: serve the engine HTTP API and web UI over the given hosts.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use meshflow_engine::Access;

use super::tokens::{ApiTokenArgs, ClusterArgs};

#[derive(Args)]
pub struct EngineArgs {
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:7000", value_name = "ADDR")]
    listen: String,
    /// A host to use (more can register themselves with `meshflow host --engine`).
    #[arg(long = "host", value_name = "URL")]
    hosts: Vec<String>,
    /// Folder for uploaded inputs.
    #[arg(long, value_name = "DIR", default_value = "meshflow-engine-data")]
    data: PathBuf,
    /// URL hosts reach this engine at (default: http:// + the listening address).
    #[arg(long, value_name = "URL")]
    public_url: Option<String>,
    #[command(flatten)]
    api_token: ApiTokenArgs,
    #[command(flatten)]
    cluster: ClusterArgs,
    /// Listen on a non-loopback address without tokens (anyone reaching it can use it).
    #[arg(long)]
    insecure_no_auth: bool,
}

pub fn run(args: EngineArgs) -> anyhow::Result<()> {
    super::host::init_logging();
    let access = Access {
        api_token: args.api_token.get()?,
        cluster_token: args.cluster.token.get()?,
        allow_input_from: args.cluster.allow_input_from,
        insecure_no_auth: args.insecure_no_auth,
    };
    tokio::runtime::Runtime::new()?.block_on(async {
        let listener = tokio::net::TcpListener::bind(&args.listen)
            .await
            .with_context(|| format!("listening on {}", args.listen))?;
        let handle =
            meshflow_engine::start(args.data, args.public_url, &args.hosts, access, listener)
                .await?;
        eprintln!("engine: {} (web UI at {0}/)", handle.url);
        tokio::select! {
            served = handle.wait() => served,
            _ = tokio::signal::ctrl_c() => Ok(()),
        }
    })
}
