//! `meshflow check`: one check, or every check (`--all`), on one mesh file, locally.

use crate::output::out;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Args;
use meshflow_meshio as io;
use meshflow_runtime::{Catalog, CheckRun, Plugin, ServiceKind, value_text};

use super::{millis, parse_params, value_json};
use crate::PluginArgs;

#[derive(Args)]
pub struct CheckArgs {
    /// The check to run, then the input mesh (OBJ, PLY, OFF, STL); with --all, the mesh only.
    #[arg(value_names = ["SERVICE", "MESH"], num_args = 1..=2, required = true)]
    targets: Vec<String>,
    /// Run every check on offer on one load of the mesh (each plugin's checks in one
    /// instance, sharing the mesh's connectivity), with their default parameters.
    #[arg(long, conflicts_with = "params")]
    all: bool,
    /// A parameter, NAME=VALUE; repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    #[command(flatten)]
    plugins: PluginArgs,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// The command line named the wrong number of things.
#[derive(Debug, thiserror::Error)]
pub enum CheckUsage {
    #[error("`check --all` takes the mesh only, got {0} arguments (`check --all MESH`)")]
    AllTakesTheMesh(usize),
    #[error("`check` takes a check and a mesh (`check SERVICE MESH`), or `--all MESH`")]
    ServiceAndMesh,
    #[error("`{0}` is a filter, not a check: use `meshflow apply`")]
    Filter(String),
}

pub fn run(args: &CheckArgs) -> anyhow::Result<()> {
    if args.all {
        return match args.targets.as_slice() {
            [mesh] => run_all(args, PathBuf::from(mesh)),
            more => Err(CheckUsage::AllTakesTheMesh(more.len()).into()),
        };
    }
    let [service, input] = args.targets.as_slice() else {
        return Err(CheckUsage::ServiceAndMesh.into());
    };
    let params = parse_params(&args.params)?;
    let (runtime, catalog) = crate::plugins::load(&args.plugins)?;
    let (plugin, info) = catalog.find(service)?;
    if info.kind != ServiceKind::Check {
        return Err(CheckUsage::Filter(service.clone()).into());
    }
    let started = Instant::now();
    let mesh = io::load(std::path::Path::new(input))?;
    let load_time = started.elapsed();
    let output = runtime.run(plugin, service, mesh, &params)?;
    crate::plugins::show_output(&args.plugins, &output);
    let value = output.value.expect("the runtime checks that a check returns a value");
    if args.json {
        let summary = serde_json::json!({
            "service": service,
            "value": value_json(&value),
            "timings_ms": { "load": millis(load_time), "run": millis(output.duration) },
        });
        out!("{summary}");
    } else {
        out!("{}", value_text(&value));
    }
    Ok(())
}

/// Every check on offer, on one load: a check that refuses the mesh (`volume` on an open
/// one) is reported with its reason, and the others still run.
fn run_all(args: &CheckArgs, input: PathBuf) -> anyhow::Result<()> {
    let (runtime, catalog) = crate::plugins::load(&args.plugins)?;
    let started = Instant::now();
    let mesh = std::sync::Arc::new(io::load(&input)?);
    let load_time = started.elapsed();
    let started = Instant::now();
    let mut runs = Vec::new();
    for (plugin, services) in checks_by_plugin(&catalog) {
        runs.extend(runtime.run_checks(plugin, &services, std::sync::Arc::clone(&mesh))?);
    }
    let run_time = started.elapsed();
    if args.json {
        out!("{}", all_json(&runs, load_time, run_time));
    } else {
        for run in &runs {
            match &run.value {
                Ok(value) => out!("{}\t{}", run.service, value_text(value)),
                Err(error) => out!("{}\trefused: {error}", run.service),
            }
        }
    }
    Ok(())
}

/// The checks an unpinned run would get, grouped by the plugin that serves them, in the
/// catalogue's order.
fn checks_by_plugin(catalog: &Catalog) -> Vec<(&Plugin, Vec<&str>)> {
    let mut groups: Vec<(&Plugin, Vec<&str>)> = Vec::new();
    for (info, plugin) in catalog.services() {
        if info.kind != ServiceKind::Check {
            continue;
        }
        match groups.iter_mut().find(|(p, _)| p.digest == plugin.digest) {
            Some((_, services)) => services.push(&info.name),
            None => groups.push((plugin, vec![&info.name])),
        }
    }
    groups
}

fn all_json(runs: &[CheckRun], load: Duration, run: Duration) -> serde_json::Value {
    let checks: Vec<serde_json::Value> = runs
        .iter()
        .map(|r| {
            let mut check = serde_json::json!({
                "service": r.service,
                "value": r.value.as_ref().map_or(serde_json::Value::Null, value_json),
                "timings_ms": { "run": millis(r.duration) },
            });
            if let Err(error) = &r.value {
                check["error"] = error.to_string().into();
            }
            check
        })
        .collect();
    serde_json::json!({ "checks": checks, "timings_ms": { "load": millis(load), "run": millis(run) } })
}
