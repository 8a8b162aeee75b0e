//! Option blocks that several subcommands share, each defined once.

use std::path::PathBuf;

use clap::Args;

use super::tokens::{ApiTokenArgs, ClusterArgs};
use crate::embedded::{self, Embedded, Layout, Tokens};

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
    pub sandbox: crate::SandboxArgs,
}

impl EmbeddedArgs {
    /// Starts the engine on `listen` and the hosts, with the given tokens or fresh ones.
    pub async fn start(
        &self,
        listen: &str,
        data: Option<PathBuf>,
        layout: Layout,
    ) -> anyhow::Result<Embedded> {
        let tokens = Tokens::given_or_fresh(self.api_token.get()?, self.cluster.token.get()?)?;
        let allowed = self.cluster.allow_input_from.clone();
        embedded::start(self.hosts, listen, data, layout, tokens, allowed, self.sandbox).await
    }
}
