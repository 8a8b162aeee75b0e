//! `meshflow run`: a workflow on local meshes through an embedded engine and hosts: one
//! mesh to `-o`, or many (`--out-dir`) as a batch.

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use meshflow_api::EngineClient;
use meshflow_engine::Access;

use super::batch::BatchArgs;
use super::options::{EmbeddedArgs, RunOutputArgs};
use super::remote::{Submission, TransferMode};
use crate::embedded::Layout;

#[derive(Args)]
pub struct RunArgs {
    /// Workflow JSON file.
    workflow: PathBuf,
    /// Input meshes (OBJ, PLY, OFF, STL or .mfm files, or URLs); more than one needs
    /// --out-dir.
    inputs: Vec<String>,
    #[command(flatten)]
    out: RunOutputArgs,
    #[command(flatten)]
    batch: BatchArgs,
    #[command(flatten)]
    embedded: EmbeddedArgs,
    /// Which built-in services each host offers.
    #[arg(long, value_enum, default_value_t = Layout::Spread)]
    layout: Layout,
    /// Overrides the workflow's "transfer".
    #[arg(long, value_enum)]
    transfer: Option<TransferMode>,
}

pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let inputs = args.batch.inputs(&args.inputs)?;
    check_shape(&inputs, &args.out, &args.batch)?;
    tokio::runtime::Runtime::new()?.block_on(async {
        let system =
            args.embedded.start("127.0.0.1:0", None, args.layout, Access::default()).await?;
        let submission = Submission {
            engine: EngineClient::new(&system.engine.url).with_token(&system.tokens.api),
            workflow: args.workflow,
            input: inputs.first().cloned(),
            transfer: args.transfer,
            out: args.out,
        };
        match &args.batch.out_dir {
            None => submission.execute(true).await,
            Some(dir) => {
                let workflow = submission.read_workflow()?;
                let json = submission.out.json;
                args.batch.run(submission.engine, workflow, inputs, dir.clone(), json).await
            }
        }
    })
}

/// One input with `-o`, or a batch into `--out-dir` (which writes its own records).
pub fn check_shape(
    inputs: &[String],
    out: &RunOutputArgs,
    batch: &BatchArgs,
) -> anyhow::Result<()> {
    match &batch.out_dir {
        Some(_) if out.output.is_some() || out.report.is_some() => {
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
