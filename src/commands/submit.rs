//! `meshflow submit`: a workflow to a running engine, optionally waiting for the result.

use crate::output::out;
use std::path::PathBuf;

use clap::Args;
use meshflow_api::EngineClient;

use super::batch::BatchArgs;
use super::options::RunOutputArgs;
use super::remote::{Submission, TransferMode};

/// Which engine to talk to, and with what API token.
#[derive(Args)]
pub struct EngineTarget {
    /// The engine's URL.
    #[arg(long, value_name = "URL")]
    engine: String,
    /// The engine's API token.
    #[arg(long, env = "MESHFLOW_API_TOKEN", hide_env_values = true, value_name = "TOKEN")]
    token: Option<String>,
    /// Read the API token from this file.
    #[arg(long, value_name = "PATH")]
    token_file: Option<PathBuf>,
}

impl EngineTarget {
    pub fn client(&self) -> anyhow::Result<EngineClient> {
        let client = EngineClient::new(self.engine.trim_end_matches('/'));
        super::tokens::warn_if_in_argv("--token", "--token-file", "MESHFLOW_API_TOKEN");
        Ok(match super::tokens::read(self.token.as_deref(), self.token_file.as_deref())? {
            Some(token) => client.with_token(&token),
            None => client,
        })
    }
}

#[derive(Args)]
pub struct SubmitArgs {
    #[command(flatten)]
    engine: EngineTarget,
    /// Workflow JSON file.
    workflow: PathBuf,
    /// The input: a URL hosts can fetch, or a local mesh file to upload to the engine;
    /// repeated (with --out-dir) for a batch.
    #[arg(long, value_name = "URL|FILE")]
    input: Vec<String>,
    #[command(flatten)]
    batch: BatchArgs,
    /// -o and --report imply --wait.
    #[command(flatten)]
    out: RunOutputArgs,
    /// Follow the run's progress until it ends.
    #[arg(long)]
    wait: bool,
    /// Overrides the workflow's "transfer".
    #[arg(long, value_enum)]
    transfer: Option<TransferMode>,
}

pub fn run(args: SubmitArgs) -> anyhow::Result<()> {
    let wait = args.wait || args.out.output.is_some() || args.out.report.is_some();
    let inputs = args.batch.inputs(&args.input)?;
    super::run::check_shape(&inputs, &args.out, &args.batch)?;
    let submission = Submission {
        engine: args.engine.client()?,
        workflow: args.workflow,
        input: inputs.first().cloned(),
        transfer: args.transfer,
        out: args.out,
    };
    let runtime = tokio::runtime::Runtime::new()?;
    match &args.batch.out_dir {
        None => runtime.block_on(submission.execute(wait)),
        Some(dir) => {
            let workflow = submission.read_workflow()?;
            let json = submission.out.json;
            let batch = args.batch.run(submission.engine, workflow, inputs, dir.clone(), json);
            runtime.block_on(batch)
        }
    }
}

#[derive(Args)]
pub struct CancelArgs {
    #[command(flatten)]
    engine: EngineTarget,
    /// The run to stop, or a batch (its id starts with `b-`).
    run: String,
}

/// `meshflow cancel`: stops a run (it ends `cancelled` and its host sessions are freed), or
/// a batch (no more of its runs start, those going are cancelled).
pub fn cancel(args: CancelArgs) -> anyhow::Result<()> {
    let engine = args.engine.client()?;
    let runtime = tokio::runtime::Runtime::new()?;
    if args.run.starts_with("b-") {
        let batch = runtime.block_on(engine.cancel_batch(&args.run))?;
        let cancelled = batch.rows.iter().filter(|row| row.status == "cancelled").count();
        out!(
            "batch {}: {}; {cancelled} of {} input(s) cancelled",
            batch.id,
            batch.status,
            batch.rows.len()
        );
        return Ok(());
    }
    let cancelled = runtime.block_on(engine.cancel(&args.run))?;
    let status = format!("{:?}", cancelled.status).to_lowercase();
    out!("run {}: {status} after {} step(s)", cancelled.id, cancelled.steps);
    Ok(())
}
