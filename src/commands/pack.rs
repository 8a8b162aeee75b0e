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

/// Unpacks `input` into a mesh file; `strict` refuses a format that cannot hold an
/// attribute of the mesh instead of warning.
pub fn unpack(input: &Path, output: &Path, strict: bool, json: bool) -> anyhow::Result<()> {
    let bytes = std::fs::read(input).with_context(|| format!("reading {}", input.display()))?;
    let started = Instant::now();
    let mesh = pack::decode(&bytes).with_context(|| format!("unpacking {}", input.display()))?;
    let decode_time = started.elapsed();
    save_mesh_from(output, &mesh, strict, Some(input))?;
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

/// Saves a mesh atomically, packed (`.mfm`) or in the format its extension names, with a
/// warning on stderr for each attribute that format cannot hold.
pub fn save_mesh(path: &Path, mesh: &MeshData) -> anyhow::Result<()> {
    save_mesh_from(path, mesh, false, None)
}

/// [`save_mesh`] for a mesh loaded from `source`: the material libraries and textures it
/// names are copied from beside `source` to beside `path`. With `strict`, a format that
/// cannot hold an attribute of the mesh is refused (nothing is written) instead of
/// warned about.
pub fn save_mesh_from(
    path: &Path,
    mesh: &MeshData,
    strict: bool,
    source: Option<&Path>,
) -> anyhow::Result<()> {
    if is_packed(path) {
        return write_atomically(path, &pack::encode(mesh)?);
    }
    let format = io::Format::from_path(path)
        .ok_or_else(|| io::SaveError::UnknownFormat { path: path.into() })?;
    let left_out = io::unsupported(mesh, format);
    let name = format.display_name();
    if strict && !left_out.is_empty() {
        anyhow::bail!(
            "{}: {name} cannot hold {}; nothing was written (--strict): choose a format that \
             does (PLY holds every attribute)",
            path.display(),
            left_out.join(", ")
        );
    }
    for what in &left_out {
        eprintln!("warning: {}: {name} cannot hold {what}; saved without it", path.display());
    }
    io::save(path, mesh).with_context(|| format!("writing {}", path.display()))?;
    if let Some(source) = source {
        let materials = &mesh.attributes.materials;
        let copied = io::copy_companion_files(source, path, materials)?;
        for skipped in &copied.skipped {
            eprintln!("warning: {}: not copied: {skipped}", path.display());
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` atomically (temporary file, sync, rename).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    Ok(io::write_file(path, |out| out.write_all(bytes))?)
}
