//! `meshflow check`: one check on one mesh file, locally.

use crate::output::out;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::bail;
use clap::Args;
use meshflow_runtime::{ServiceKind, value_text};

use super::{millis, parse_params, value_json};
use crate::PluginArgs;

#[derive(Args)]
pub struct CheckArgs {
    /// The check to run.
    service: String,
    /// Input mesh (OBJ, PLY, OFF, STL).
    input: PathBuf,
    /// A parameter, NAME=VALUE; repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    #[command(flatten)]
    plugins: PluginArgs,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &CheckArgs) -> anyhow::Result<()> {
    let params = parse_params(&args.params)?;
    let (runtime, catalog) = crate::plugins::load(&args.plugins)?;
    let (plugin, info) = catalog.find(&args.service)?;
    if info.kind != ServiceKind::Check {
        bail!("`{}` is a filter, not a check: use `meshflow apply`", args.service);
    }
    let started = Instant::now();
    let mesh = super::pack::load_mesh(&args.input)?;
    let load_time = started.elapsed();
    let output = runtime.run(plugin, &args.service, mesh, &params)?;
    crate::plugins::show_output(&args.plugins, &output);
    let value = output.value.expect("the runtime checks that a check returns a value");
    if args.json {
        let summary = serde_json::json!({
            "service": args.service,
            "value": value_json(&value),
            "timings_ms": { "load": millis(load_time), "run": millis(output.duration) },
        });
        out!("{summary}");
    } else {
        out!("{}", value_text(&value));
    }
    Ok(())
}
