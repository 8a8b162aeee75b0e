//! `meshflow up`: the embedded default — an engine and N hosts on loopback, until Ctrl-C.

use crate::output::out;
use std::path::PathBuf;

use clap::Args;

use meshflow_engine::Access;

use super::options::EmbeddedArgs;
use crate::embedded::Layout;

#[derive(Args)]
pub struct UpArgs {
    #[command(flatten)]
    embedded: EmbeddedArgs,
    /// Where the engine listens.
    #[arg(long, default_value = "127.0.0.1:7000", value_name = "ADDR")]
    listen: String,
    /// Keep the hosts' and engine's data in this folder (default: a temporary one).
    #[arg(long, value_name = "DIR")]
    data: Option<PathBuf>,
    /// Which built-in services each host offers.
    #[arg(long, value_enum, default_value_t = Layout::Spread)]
    layout: Layout,
    /// Named users of the engine, one a line: `NAME ROLE TOKEN` (see `meshflow engine`);
    /// the printed API token stays the admin `default`.
    #[arg(long, value_name = "FILE")]
    users: Option<PathBuf>,
    #[command(flatten)]
    logs: super::host::LogArgs,
}

pub fn run(args: UpArgs) -> anyhow::Result<()> {
    super::host::init_logging(args.logs.log_format);
    tokio::runtime::Runtime::new()?.block_on(async {
        let access = Access { users_file: args.users, ..Access::default() };
        let system = args.embedded.start(&args.listen, args.data, args.layout, access).await?;
        let (url, tokens) = (&system.engine.url, &system.tokens);
        out!("engine: {url}");
        out!("web UI: {url}/#token={}", tokens.api);
        for host in &system.hosts {
            out!("host:   {}", host.url);
        }
        if let Some(ca) = &system.ca {
            out!("the CA: {} (export MESHFLOW_CA_FILE={0})", ca.display());
        }
        out!("for meshflow submit:    export MESHFLOW_API_TOKEN={}", tokens.api);
        out!("for more hosts:         export MESHFLOW_CLUSTER_TOKEN={}", tokens.cluster);
        out!("for meshflow plugin upload: export MESHFLOW_UPLOAD_TOKEN={}", tokens.upload);
        // Ctrl-C or a service manager's SIGTERM: either way the temporary folder goes.
        let mut terminate =
            tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
        tokio::select! {
            stopped = tokio::signal::ctrl_c() => stopped?,
            _ = terminate.recv() => {}
        }
        drop(system);
        Ok(())
    })
}
