//! `meshflow up`: the embedded default — an engine and N hosts on loopback, until Ctrl-C.

use std::path::PathBuf;

use clap::Args;

use crate::embedded::{self, Layout};

#[derive(Args)]
pub struct UpArgs {
    /// How many hosts to start.
    #[arg(long, default_value_t = 3)]
    hosts: usize,
    /// Where the engine listens.
    #[arg(long, default_value = "127.0.0.1:7000", value_name = "ADDR")]
    listen: String,
    /// Keep the hosts' and engine's data in this folder (default: a temporary one).
    #[arg(long, value_name = "DIR")]
    data: Option<PathBuf>,
    /// Which built-in services each host offers.
    #[arg(long, value_enum, default_value_t = Layout::Spread)]
    layout: Layout,
}

pub fn run(args: UpArgs) -> anyhow::Result<()> {
    super::host::init_logging();
    tokio::runtime::Runtime::new()?.block_on(async {
        let system = embedded::start(args.hosts, &args.listen, args.data, args.layout).await?;
        println!("engine: {} (web UI at {0}/)", system.engine.url);
        for host in &system.hosts {
            println!("host:   {}", host.url);
        }
        tokio::signal::ctrl_c().await?;
        Ok(())
    })
}
