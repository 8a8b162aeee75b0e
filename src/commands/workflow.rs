//! `meshflow workflow from-mlx | to-mlx`: MeshLab filter scripts to workflows and back.

use std::path::{Path, PathBuf};

use crate::mlx;
use anyhow::Context;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum WorkflowCommand {
    /// Convert a MeshLab filter script (.mlx) to a workflow; refuses, listing each, the
    /// filters no service does.
    FromMlx {
        script: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Convert a workflow without IF or WHILE to a MeshLab filter script.
    ToMlx {
        workflow: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// The mesh the script is meant for: MeshLab takes lengths (isotropic remeshing's
        /// target) as absolute values, the services as percentages of its bounding-box
        /// diagonal.
        #[arg(long, value_name = "FILE")]
        mesh: Option<PathBuf>,
    },
}

pub fn run(command: WorkflowCommand) -> anyhow::Result<()> {
    match command {
        WorkflowCommand::FromMlx { script, output } => {
            let text = read(&script)?;
            let converted =
                mlx::from_mlx(&text).with_context(|| format!("converting {}", script.display()))?;
            for note in &converted.notes {
                eprintln!("note: {note}");
            }
            let offered = offered_services()?;
            for step in converted.workflow["steps"].as_array().into_iter().flatten() {
                let service = step["run"].as_str().unwrap_or_default();
                if !offered.iter().any(|s| s == service) {
                    eprintln!(
                        "warning: no built-in plugin offers \"{service}\" yet; the workflow needs a host that does"
                    );
                }
            }
            let json = serde_json::to_string_pretty(&converted.workflow)?;
            super::pack::write_atomically(&output, format!("{json}\n").as_bytes())
        }
        WorkflowCommand::ToMlx { workflow, output, mesh } => {
            let text = read(&workflow)?;
            let json: serde_json::Value = serde_json::from_str(&text)
                .with_context(|| format!("{} is not valid JSON", workflow.display()))?;
            let diagonal = match mesh {
                Some(path) => Some(bounding_box_diagonal(&path)?),
                None => None,
            };
            let script = mlx::to_mlx(&json, diagonal)
                .with_context(|| format!("converting {}", workflow.display()))?;
            super::pack::write_atomically(&output, script.as_bytes())
        }
    }
}

fn read(path: &Path) -> anyhow::Result<String> {
    let size =
        std::fs::metadata(path).with_context(|| format!("reading {}", path.display()))?.len();
    anyhow::ensure!(
        size <= mlx::MAX_SCRIPT_BYTES as u64,
        "{} is {size} bytes; at most {} are read",
        path.display(),
        mlx::MAX_SCRIPT_BYTES
    );
    std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))
}

/// The names of the services the built-in plugins offer.
fn offered_services() -> anyhow::Result<Vec<String>> {
    let (_, catalog) = crate::plugins::load(&crate::PluginArgs::default())?;
    Ok(catalog.services().iter().map(|(info, _)| info.name.clone()).collect())
}

fn bounding_box_diagonal(path: &Path) -> anyhow::Result<f64> {
    let mesh =
        meshflow_meshio::load(path).with_context(|| format!("loading {}", path.display()))?;
    let (min, max) = mesh.bounding_box().context("the mesh has no vertices")?;
    Ok((0..3).map(|k| f64::from(max[k] - min[k]).powi(2)).sum::<f64>().sqrt())
}
