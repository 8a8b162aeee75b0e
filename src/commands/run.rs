//! `meshflow run`: a workflow on a local mesh through an embedded engine and hosts.

use std::path::PathBuf;

use clap::Args;
use meshflow_api::EngineClient;

use super::remote::{Submission, TransferMode};
use super::tokens::{ApiTokenArgs, ClusterTokenArgs};
use crate::embedded::{self, Layout, Tokens};

#[derive(Args)]
pub struct RunArgs {
    /// Workflow JSON file.
    workflow: PathBuf,
    /// Input mesh (OBJ, PLY, OFF, STL or .mfm).
    input: PathBuf,
    /// Where to write the result (format by extension).
    #[arg(short, long)]
    output: PathBuf,
    /// How many hosts to start.
    #[arg(long, default_value_t = 3)]
    hosts: usize,
    /// Which built-in services each host offers.
    #[arg(long, value_enum, default_value_t = Layout::Spread)]
    layout: Layout,
    /// Overrides the workflow's "transfer".
    #[arg(long, value_enum)]
    transfer: Option<TransferMode>,
    /// Write the run's record (every step, transfer and timing) as JSON.
    #[arg(long, value_name = "R.json")]
    report: Option<PathBuf>,
    /// Print the run's record on stdout instead of progress.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    api_token: ApiTokenArgs,
    #[command(flatten)]
    cluster_token: ClusterTokenArgs,
}

pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let tokens = Tokens::given_or_fresh(args.api_token.get()?, args.cluster_token.get()?)?;
    tokio::runtime::Runtime::new()?.block_on(async {
        let system =
            embedded::start(args.hosts, "127.0.0.1:0", None, args.layout, tokens, Vec::new())
                .await?;
        let submission = Submission {
            engine: EngineClient::new(&system.engine.url).with_token(&system.tokens.api),
            workflow: args.workflow,
            input: Some(args.input.display().to_string()),
            transfer: args.transfer,
            output: Some(args.output),
            report: args.report,
            json: args.json,
        };
        submission.execute(true).await
    })
}
