//! `meshflow pack` and `meshflow unpack`: meshes to and from the packed `.mfm` format, and
//! the file helpers other commands share for packed meshes and corrections.

use crate::output::out;
use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use meshflow_codec::{pack, quantize};
use meshflow_mesh::MeshData;
use meshflow_meshio as io;

use super::millis;

/// The extension of packed meshes.
const PACKED: &str = "mfm";

/// Packs `input`; with `quantize`, first snaps it to a grid of at most `2^bits` cells per
/// axis over its bounding box (the packed mesh then codes grid steps).
pub fn pack(input: &Path, output: &Path, quantize: Option<u32>, json: bool) -> anyhow::Result<()> {
    let mut mesh = load_mesh(input)?;
    if let Some(bits) = quantize {
        quantize::quantize(&mut mesh, bits)?;
    }
    let started = Instant::now();
    let bytes = pack::encode(&mesh)?;
    let encode_time = started.elapsed();
    write_atomically(output, &bytes)?;
    report(json, "packed", &mesh, bytes.len(), encode_time, output);
    Ok(())
}

pub fn unpack(input: &Path, output: &Path, json: bool) -> anyhow::Result<()> {
    let bytes = std::fs::read(input).with_context(|| format!("reading {}", input.display()))?;
    let started = Instant::now();
    let mesh = pack::decode(&bytes).with_context(|| format!("unpacking {}", input.display()))?;
    let decode_time = started.elapsed();
    save_mesh(output, &mesh)?;
    report(json, "unpacked", &mesh, bytes.len(), decode_time, output);
    Ok(())
}

fn report(
    json: bool,
    what: &str,
    mesh: &MeshData,
    packed: usize,
    time: std::time::Duration,
    output: &Path,
) {
    if json {
        let summary = serde_json::json!({
            "vertices": mesh.vertex_count(),
            "triangles": mesh.triangle_count(),
            "packed_bytes": packed,
            "hash": mesh.content_hash().to_hex(),
            "time_ms": millis(time),
        });
        out!("{summary}");
    } else {
        out!(
            "{what} {} vertices, {} triangles ({packed} packed bytes) -> {}",
            mesh.vertex_count(),
            mesh.triangle_count(),
            output.display()
        );
    }
}

pub fn is_packed(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case(PACKED))
}

/// Loads a mesh file, packed (`.mfm`) or any format `io::load` reads, and says on stderr
/// what the file held that the mesh does not keep (colours, normals, …).
pub fn load_mesh(path: &Path) -> anyhow::Result<MeshData> {
    if is_packed(path) {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        return pack::decode(&bytes).with_context(|| format!("unpacking {}", path.display()));
    }
    let loaded = io::load_reporting(path)?;
    for line in loaded.dropped.lines() {
        eprintln!("warning: {}: not kept: {line}", path.display());
    }
    Ok(loaded.mesh)
}

/// Saves a mesh atomically, packed (`.mfm`) or in the format its extension names.
pub fn save_mesh(path: &Path, mesh: &MeshData) -> anyhow::Result<()> {
    if is_packed(path) {
        return write_atomically(path, &pack::encode(mesh)?);
    }
    io::save(path, mesh).with_context(|| format!("writing {}", path.display()))
}

/// Writes `bytes` to `path` atomically (temporary file, sync, rename).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    Ok(io::write_file(path, |out| out.write_all(bytes))?)
}
