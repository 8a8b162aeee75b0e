//! `meshflow submit`: a workflow to a running engine, optionally waiting for the result.

use std::path::PathBuf;

use clap::Args;

use super::remote::{Submission, TransferMode};

#[derive(Args)]
pub struct SubmitArgs {
    /// The engine's URL.
    #[arg(long, value_name = "URL")]
    engine: String,
    /// The engine's API token.
    #[arg(long, env = "MESHFLOW_API_TOKEN", hide_env_values = true, value_name = "TOKEN")]
    token: Option<String>,
    /// Read the API token from this file.
    #[arg(long, value_name = "PATH")]
    token_file: Option<PathBuf>,
    /// Workflow JSON file.
    workflow: PathBuf,
    /// The input: a URL hosts can fetch, or a local mesh file to upload to the engine.
    #[arg(long, value_name = "URL|FILE")]
    input: Option<String>,
    /// Where to write the result (format by extension); implies --wait.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Follow the run's progress until it ends.
    #[arg(long)]
    wait: bool,
    /// Overrides the workflow's "transfer".
    #[arg(long, value_enum)]
    transfer: Option<TransferMode>,
    /// Write the run's record as JSON (implies --wait).
    #[arg(long, value_name = "R.json")]
    report: Option<PathBuf>,
    /// Print JSON (the run id, or the record when waiting) instead of progress.
    #[arg(long)]
    json: bool,
}

pub fn run(args: SubmitArgs) -> anyhow::Result<()> {
    let wait = args.wait || args.output.is_some() || args.report.is_some();
    let submission = Submission {
        engine: args.engine.trim_end_matches('/').to_owned(),
        token: super::tokens::read(args.token.as_deref(), args.token_file.as_deref())?,
        workflow: args.workflow,
        input: args.input,
        transfer: args.transfer,
        output: args.output,
        report: args.report,
        json: args.json,
    };
    tokio::runtime::Runtime::new()?.block_on(submission.execute(wait))
}
