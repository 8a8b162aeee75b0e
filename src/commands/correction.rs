//! `meshflow correction apply|inspect`: replay a step's correction (an edit log, `.mfc`, or
//! a named step re-run in the sandbox, `.mfr`), or describe one.

use crate::output::out;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Subcommand;
use meshflow_codec::correction::{self, SECTIONS};
use meshflow_codec::replay;
use meshflow_mesh::MeshData;
use meshflow_mesh::store::OpKind;

use super::millis;
use super::pack::{load_mesh, save_mesh_from};
use crate::PluginArgs;

#[derive(Subcommand)]
pub enum CorrectionCommand {
    /// Apply a correction to the mesh it was made for; the hashes are verified. An edit
    /// log (.mfc) is replayed; a replay (.mfr) re-runs the plugin it names, built in or
    /// given with --plugin.
    Apply {
        /// The base mesh (OBJ, PLY, OFF, STL or packed .mfm).
        base: PathBuf,
        /// The correction.
        correction: PathBuf,
        /// The result mesh (by extension; .mfm packs it); written atomically.
        #[arg(short, long)]
        output: PathBuf,
        /// Refuse (write nothing) when the output's format cannot hold an attribute of
        /// the result, instead of warning and saving without it.
        #[arg(long)]
        strict: bool,
        #[command(flatten)]
        plugins: PluginArgs,
        #[arg(long)]
        json: bool,
    },
    /// Describe a correction: its kind, hashes, and operations by kind and bytes by section
    /// (an edit log) or plugin, service and parameters (a replay).
    Inspect {
        correction: PathBuf,
        #[arg(long)]
        json: bool,
    },
}

pub fn run(command: &CorrectionCommand) -> anyhow::Result<()> {
    match command {
        CorrectionCommand::Apply { base, correction, output, strict, plugins, json } => {
            apply(base, correction, output, *strict, plugins, *json)
        }
        CorrectionCommand::Inspect { correction, json } => inspect(correction, *json),
    }
}

fn read(path: &Path) -> anyhow::Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("reading {}", path.display()))
}

fn apply(
    base: &Path,
    correction: &Path,
    output: &Path,
    strict: bool,
    plugins: &PluginArgs,
    json: bool,
) -> anyhow::Result<()> {
    let mesh = Arc::new(load_mesh(base)?);
    let bytes = read(correction)?;
    let started = Instant::now();
    let result = if replay::is_replay(&bytes) {
        rerun(&mesh, &bytes, plugins)
    } else {
        correction::apply(Arc::clone(&mesh), &bytes).map_err(anyhow::Error::from)
    }
    .with_context(|| format!("applying {}", correction.display()))?;
    let apply_time = started.elapsed();
    save_mesh_from(output, &result, strict, Some(base))?;
    if json {
        let summary = serde_json::json!({
            "base_hash": mesh.content_hash().to_hex(),
            "result_hash": result.content_hash().to_hex(),
            "vertices": result.vertex_count(),
            "triangles": result.triangle_count(),
            "correction_bytes": bytes.len(),
            "apply_ms": millis(apply_time),
        });
        out!("{summary}");
    } else {
        out!(
            "{} vertices, {} triangles ({}) -> {}",
            result.vertex_count(),
            result.triangle_count(),
            result.content_hash(),
            output.display()
        );
    }
    Ok(())
}

/// Re-runs the step a replay names on `mesh`, which must be the step's base.
fn rerun(mesh: &Arc<MeshData>, bytes: &[u8], plugins: &PluginArgs) -> anyhow::Result<MeshData> {
    let step = replay::decode(bytes)?;
    let found = mesh.content_hash();
    if found != step.base {
        bail!("the replay is for mesh {}, not this one ({found})", step.base);
    }
    let (runtime, catalog) = crate::plugins::load(plugins)?;
    let digest = step.plugin_hex();
    let Some(plugin) = catalog.plugins().iter().find(|p| p.digest == digest) else {
        bail!(
            "the replay names plugin {digest} ({}), which is not built in: give it with --plugin",
            step.service
        );
    };
    Ok(meshflow_host::replay::rerun(&runtime, plugin, &step, Arc::clone(mesh), None)?)
}

fn inspect(path: &Path, json: bool) -> anyhow::Result<()> {
    let bytes = read(path)?;
    if replay::is_replay(&bytes) {
        return inspect_replay(path, &bytes, json);
    }
    let c = correction::decode(&bytes).with_context(|| format!("reading {}", path.display()))?;
    let kinds: Vec<(OpKind, correction::KindCount)> =
        OpKind::ALL.iter().map(|&k| (k, c.count(k))).filter(|(_, n)| n.ops > 0).collect();
    if json {
        let operations: serde_json::Map<String, serde_json::Value> = kinds
            .iter()
            .map(|(k, n)| {
                (k.name().to_owned(), serde_json::json!({ "ops": n.ops, "edits": n.edits }))
            })
            .collect();
        let mut sections = serde_json::Map::new();
        sections.insert("header".into(), c.header_bytes.into());
        for (name, size) in SECTIONS.iter().zip(c.section_bytes) {
            sections.insert((*name).into(), size.into());
        }
        let summary = serde_json::json!({
            "kind": "edits",
            "version": c.version,
            "base_hash": c.base.to_hex(),
            "result_hash": c.result.to_hex(),
            "base": { "vertices": c.base_counts[0], "triangles": c.base_counts[1] },
            "result": { "vertices": c.result_counts[0], "triangles": c.result_counts[1] },
            "operations": operations,
            "bytes": sections,
            "total_bytes": c.total_bytes(),
        });
        out!("{summary}");
        return Ok(());
    }
    out!("edit log (correction v{}), {} bytes", c.version, c.total_bytes());
    out!("base:   {} ({} vertices, {} triangles)", c.base, c.base_counts[0], c.base_counts[1]);
    out!(
        "result: {} ({} vertices, {} triangles)",
        c.result,
        c.result_counts[0],
        c.result_counts[1]
    );
    for (k, n) in kinds {
        out!("  {:<20} {:>8} ops {:>10} edits", k.name(), n.ops, n.edits);
    }
    out!("  {:<20} {:>8} bytes", "header", c.header_bytes);
    for (name, size) in SECTIONS.iter().zip(c.section_bytes) {
        out!("  {name:<20} {size:>8} bytes");
    }
    Ok(())
}

fn inspect_replay(path: &Path, bytes: &[u8], json: bool) -> anyhow::Result<()> {
    let step = replay::decode(bytes).with_context(|| format!("reading {}", path.display()))?;
    let params: serde_json::Value = serde_json::from_str(&step.params)
        .unwrap_or(serde_json::Value::String(step.params.clone()));
    if json {
        let summary = serde_json::json!({
            "kind": "replay",
            "version": replay::VERSION,
            "plugin": step.plugin_hex(),
            "service": step.service,
            "params": params,
            "base_hash": step.base.to_hex(),
            "result_hash": step.result.to_hex(),
            "result": { "vertices": step.result_counts[0], "triangles": step.result_counts[1] },
            "total_bytes": bytes.len(),
        });
        out!("{summary}");
        return Ok(());
    }
    out!("replay (v{}), {} bytes: re-runs the step on the base mesh", replay::VERSION, bytes.len());
    out!("plugin: {}", step.plugin_hex());
    out!("step:   {} {params}", step.service);
    out!("base:   {}", step.base);
    out!(
        "result: {} ({} vertices, {} triangles)",
        step.result,
        step.result_counts[0],
        step.result_counts[1]
    );
    Ok(())
}
