//! `meshflow run`: a workflow on local meshes through an embedded engine and hosts: one
//! mesh to `-o`, or many (`--out-dir`) as a batch.

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use meshflow_api::EngineClient;

use super::batch::BatchArgs;
use super::remote::{Submission, TransferMode};
use super::tokens::{ApiTokenArgs, ClusterTokenArgs};
use crate::embedded::{self, Layout, Tokens};

#[derive(Args)]
pub struct RunArgs {
    /// Workflow JSON file.
    workflow: PathBuf,
    /// Input meshes (OBJ, PLY, OFF, STL or .mfm files, or URLs); more than one needs
    /// --out-dir.
    inputs: Vec<String>,
    /// Where to write the result of a single input (format by extension).
    #[arg(short, long)]
    output: Option<PathBuf>,
    #[command(flatten)]
    batch: BatchArgs,
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
    /// Print the run's record (a batch: its summary rows) on stdout instead of progress.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    api_token: ApiTokenArgs,
    #[command(flatten)]
    cluster_token: ClusterTokenArgs,
    #[command(flatten)]
    sandbox: crate::SandboxArgs,
}

pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let inputs = args.batch.inputs(&args.inputs)?;
    check_shape(&inputs, args.output.is_some(), args.report.is_some(), &args.batch)?;
    let tokens = Tokens::given_or_fresh(args.api_token.get()?, args.cluster_token.get()?)?;
    tokio::runtime::Runtime::new()?.block_on(async {
        let system = embedded::start(
            args.hosts,
            "127.0.0.1:0",
            None,
            args.layout,
            tokens,
            Vec::new(),
            args.sandbox,
        )
        .await?;
        let submission = Submission {
            engine: EngineClient::new(&system.engine.url).with_token(&system.tokens.api),
            workflow: args.workflow,
            input: inputs.first().cloned(),
            transfer: args.transfer,
            output: args.output,
            report: args.report,
            json: args.json,
        };
        match &args.batch.out_dir {
            None => submission.execute(true).await,
            Some(dir) => {
                let workflow = submission.read_workflow()?;
                args.batch.run(submission.engine, workflow, inputs, dir.clone(), args.json).await
            }
        }
    })
}

/// One input with `-o`, or a batch into `--out-dir` (which writes its own records).
pub fn check_shape(
    inputs: &[String],
    output: bool,
    report: bool,
    batch: &BatchArgs,
) -> anyhow::Result<()> {
    match &batch.out_dir {
        Some(_) if output || report => {
            bail!(
                "a batch (--out-dir) writes its results and records under DIR; drop -o and --report"
            )
        }
        Some(_) if inputs.is_empty() => bail!("no inputs given"),
        Some(_) => Ok(()),
        None if inputs.len() > 1 => bail!("several inputs make a batch: give --out-dir DIR"),
        None => Ok(()),
    }
}
