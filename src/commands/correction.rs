//! `meshflow correction apply|inspect`: replay a step's correction, or describe one.

use crate::output::out;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use clap::Subcommand;
use meshflow_codec::correction::{self, SECTIONS};
use meshflow_mesh::store::OpKind;

use super::millis;
use super::pack::{load_mesh, save_mesh};

#[derive(Subcommand)]
pub enum CorrectionCommand {
    /// Apply a correction (.mfc) to the mesh it was made for; the hashes are verified.
    Apply {
        /// The base mesh (OBJ, PLY, OFF, STL or packed .mfm).
        base: PathBuf,
        /// The correction.
        correction: PathBuf,
        /// The result mesh (by extension; .mfm packs it); written atomically.
        #[arg(short, long)]
        output: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Describe a correction: hashes, operations by kind, bytes by section.
    Inspect {
        correction: PathBuf,
        #[arg(long)]
        json: bool,
    },
}

pub fn run(command: &CorrectionCommand) -> anyhow::Result<()> {
    match command {
        CorrectionCommand::Apply { base, correction, output, json } => {
            apply(base, correction, output, *json)
        }
        CorrectionCommand::Inspect { correction, json } => inspect(correction, *json),
    }
}

fn read(path: &Path) -> anyhow::Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("reading {}", path.display()))
}

fn apply(base: &Path, correction: &Path, output: &Path, json: bool) -> anyhow::Result<()> {
    let mesh = Arc::new(load_mesh(base)?);
    let bytes = read(correction)?;
    let started = Instant::now();
    let result = correction::apply(Arc::clone(&mesh), &bytes)
        .with_context(|| format!("applying {}", correction.display()))?;
    let apply_time = started.elapsed();
    save_mesh(output, &result)?;
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

fn inspect(path: &Path, json: bool) -> anyhow::Result<()> {
    let bytes = read(path)?;
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
    out!("correction v{}, {} bytes", c.version, c.total_bytes());
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
