//! Writing PLY: `float x y z` vertices and `list uchar int vertex_indices` faces.

use std::io::{self, Write};

use super::super::PlyEncoding;
use super::super::text;
use meshflow_mesh::{MeshData, as_le_bytes_f32};

/// Encodes a mesh as PLY in the given encoding.
pub(crate) fn write(out: &mut dyn Write, mesh: &MeshData, encoding: PlyEncoding) -> io::Result<()> {
    let format = match encoding {
        PlyEncoding::Ascii => "ascii",
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
        PlyEncoding::BinaryBigEndian => "binary_big_endian",
    };
    // `int` is what every reader expects; only ids beyond i32 need `uint`.
    let index_type = if mesh.vertex_count() > i32::MAX as usize { "uint" } else { "int" };
    write!(
        out,
        "ply\nformat {format} 1.0\ncomment written by meshflow\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\nelement face {}\n\
         property list uchar {index_type} vertex_indices\nend_header\n",
        mesh.vertex_count(),
        mesh.triangle_count()
    )?;
    match encoding {
        PlyEncoding::Ascii => write_ascii(out, mesh),
        PlyEncoding::BinaryLittleEndian => {
            out.write_all(&as_le_bytes_f32(&mesh.positions))?;
            write_faces(out, mesh, u32::to_le_bytes)
        }
        PlyEncoding::BinaryBigEndian => {
            for batch in mesh.positions.chunks(4096) {
                let bytes: Vec<u8> = batch.iter().flat_map(|v| v.to_be_bytes()).collect();
                out.write_all(&bytes)?;
            }
            write_faces(out, mesh, u32::to_be_bytes)
        }
    }
}

fn write_ascii(out: &mut dyn Write, mesh: &MeshData) -> io::Result<()> {
    for p in mesh.positions.chunks_exact(3) {
        text::write_xyz(out, p)?;
        out.write_all(b"\n")?;
    }
    for t in mesh.triangles.chunks_exact(3) {
        writeln!(out, "3 {} {} {}", t[0], t[1], t[2])?;
    }
    Ok(())
}

/// Binary face records, 13 bytes each, batched so the writer sees few large writes.
fn write_faces(out: &mut dyn Write, mesh: &MeshData, bytes: fn(u32) -> [u8; 4]) -> io::Result<()> {
    const BATCH: usize = 4096;
    let mut buffer = Vec::with_capacity(BATCH * 13);
    for batch in mesh.triangles.chunks(BATCH * 3) {
        buffer.clear();
        for t in batch.chunks_exact(3) {
            buffer.push(3u8);
            for &v in t {
                buffer.extend_from_slice(&bytes(v));
            }
        }
        out.write_all(&buffer)?;
    }
    Ok(())
}
