//! `meshflow rerun RECORD.json`: a recorded run again, every task pinned to the plugin
//! digest and resolved parameters it ran with, and whether the result is bit-identical.

use crate::output::out;

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use meshflow_api::EngineClient;
use meshflow_api::engine::{Comparison, RunRecord, Status};
use meshflow_engine::Access;
use meshflow_engine::rerun::{compare, rerun_workflow};

use super::options::{EmbeddedArgs, RunOutputArgs};
use super::remote::Submission;
use crate::embedded::Layout;

#[derive(Args)]
pub struct RerunArgs {
    /// A run record: `meshflow run --report`, `submit --json`, `GET /runs/{id}`.
    record: PathBuf,
    /// Run on this mesh (a file or a URL) instead of the recorded input URL. A file whose
    /// content hash is the recorded input's counts as the recorded input.
    #[arg(long, value_name = "FILE|URL")]
    input: Option<String>,
    #[command(flatten)]
    out: RunOutputArgs,
    /// Run today's plugin for each service (with the recorded parameters) instead of the
    /// recorded digests: shows whether an updated plugin changes the results.
    #[arg(long)]
    unpinned: bool,
    /// Re-run on this engine (its API token from --api-token or MESHFLOW_API_TOKEN)
    /// instead of an embedded engine and hosts.
    #[arg(long, value_name = "URL")]
    engine: Option<String>,
    /// Without --engine: the embedded engine and hosts (with --engine: its API token).
    #[command(flatten)]
    embedded: EmbeddedArgs,
}

/// Exits 0 when the re-run is bit-identical to the record, else says where it diverged
/// and fails.
pub fn run(args: RerunArgs) -> anyhow::Result<()> {
    let name = args.record.display();
    let text = std::fs::read_to_string(&args.record).with_context(|| format!("reading {name}"))?;
    let recorded: RunRecord =
        serde_json::from_str(&text).with_context(|| format!("{name} is not a run record"))?;
    let workflow = rerun_workflow(&recorded, !args.unpinned)
        .with_context(|| format!("{name} cannot be re-run"))?;
    let input = match (&args.input, &recorded.input) {
        (Some(input), _) => input.clone(),
        (None, Some(input)) => input.url.clone(),
        (None, None) => bail!("{name} names no input; give --input FILE|URL"),
    };
    tokio::runtime::Runtime::new()?.block_on(async {
        // Kept alive until the re-run has ended and its result is saved.
        let mut embedded = None;
        let engine = match &args.engine {
            Some(url) => {
                let client = EngineClient::new(url.trim_end_matches('/'));
                match args.embedded.api_token.get()? {
                    Some(token) => client.with_token(&token),
                    None => client,
                }
            }
            None => {
                let system = args
                    .embedded
                    .start("127.0.0.1:0", None, Layout::Spread, Access::default())
                    .await?;
                let client = EngineClient::new(&system.engine.url).with_token(&system.tokens.api);
                embedded = Some(system);
                client
            }
        };
        // The workflow is built from the record (run_to_end takes it), not read from a file.
        let submission = Submission {
            engine,
            workflow: args.record.clone(),
            input: Some(input),
            transfer: None,
            out: args.out.clone(),
        };
        let rerun = submission.run_to_end(workflow).await?;
        let comparison = compare(&recorded, &rerun);
        if rerun.status == Status::Completed {
            submission.save_result(&rerun).await?;
        }
        drop(embedded);
        report(&comparison, &recorded, args.out.json)
    })
}

fn report(comparison: &Comparison, recorded: &RunRecord, json: bool) -> anyhow::Result<()> {
    if json {
        out!("{}", serde_json::to_string_pretty(comparison)?);
    }
    let Some(divergence) = &comparison.divergence else {
        if !json {
            let hash = recorded.result.as_ref().map_or("", |r| r.hash.as_str());
            out!("bit-identical to run {}: result {hash}", recorded.id);
        }
        return Ok(());
    };
    let step = match (divergence.index, &divergence.service) {
        (Some(index), Some(service)) => format!("step {index}, {} ({service})", divergence.path),
        _ => divergence.path.clone(),
    };
    bail!("the re-run diverged from run {} at {step}: {}", recorded.id, divergence.message)
}
