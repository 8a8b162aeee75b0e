//! Wavefront OBJ: `v` and `f` statements; everything else (normals, texture coordinates,
//! groups, materials, lines, points) carries no triangle-mesh geometry and is skipped —
//! normals, texture coordinates, materials and vertex colours named in the [`Dropped`] report.
//!
//! Parsed here rather than with `tobj`: tobj renumbers vertices per object in the order faces
//! first use them and drops unreferenced ones, which would change raw scans and break
//! bit-identical round trips; it also reports errors without line numbers.

use std::io::{self, Write};

use super::build::{check_arity, check_finite, out_of_range, push_fan};
use super::error::{Invalid, Position, ReadResult};
use super::text::{self, parse_f32, parse_i64, shown};
use crate::dropped::{Dropped, Loaded};
use meshflow_mesh::MeshData;

/// Decodes an OBJ file. All objects and groups share the file's one vertex list, so they
/// merge into one mesh with the file's own numbering.
pub(crate) fn read(bytes: &[u8]) -> ReadResult<Loaded> {
    let mut reader = Reader::default();
    // A statement ending in a backslash continues on the next line (OBJ spec); errors name
    // the line the statement starts on.
    let mut joined = Vec::new();
    let mut first_line = 0;
    for (number, line) in text::lines(bytes) {
        if let Some(head) = line.trim_ascii_end().strip_suffix(b"\\") {
            if joined.is_empty() {
                first_line = number;
            }
            joined.extend_from_slice(head);
            joined.push(b' ');
        } else if joined.is_empty() {
            reader.statement(number, line)?;
        } else {
            joined.extend_from_slice(line);
            reader.statement(first_line, &joined)?;
            joined.clear();
        }
    }
    if !joined.is_empty() {
        reader.statement(first_line, &joined)?;
    }
    reader.finish()
}

#[derive(Default)]
struct Reader {
    positions: Vec<f32>,
    triangles: Vec<u32>,
    faces: usize,
    corners: Vec<u32>,
    /// Corners naming a vertex defined later in the file: `(line, face, 1-based index)`.
    /// Checked at the end, when the vertex count is known.
    forward: Vec<(usize, usize, i64)>,
    /// What the mesh does not keep: `vt` and `vn` counts, material statements, and
    /// whether `v` lines carry colours.
    texture_coordinates: usize,
    normals: usize,
    materials: Vec<String>,
    coloured: bool,
}

impl Reader {
    fn statement(&mut self, number: usize, line: &[u8]) -> ReadResult<()> {
        let mut tokens = text::tokens(line);
        match tokens.next() {
            Some(b"v") => self.vertex(Position::Line(number), tokens),
            Some(b"f") | Some(b"fo") => self.face(number, tokens),
            Some(b"vt") => {
                self.texture_coordinates += 1;
                Ok(())
            }
            Some(b"vn") => {
                self.normals += 1;
                Ok(())
            }
            Some(keyword @ (b"mtllib" | b"usemtl")) => {
                let names: Vec<String> = tokens.map(shown).collect();
                let statement = format!("{} {}", shown(keyword), names.join(" "));
                if !self.materials.contains(&statement) {
                    self.materials.push(statement);
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    fn vertex<'a>(
        &mut self,
        at: Position,
        mut tokens: impl Iterator<Item = &'a [u8]>,
    ) -> ReadResult<()> {
        let vertex = self.positions.len() / 3;
        let mut p = [0.0f32; 3];
        for (value, axis) in p.iter_mut().zip(["x", "y", "z"]) {
            let token = tokens.next().ok_or_else(|| {
                Invalid::at(at, format!("vertex {vertex} has no {axis} coordinate"))
            })?;
            *value = parse_f32(token)
                .map_err(|reason| Invalid::at(at, format!("vertex {vertex}: {reason}")))?;
        }
        check_finite(vertex, p, at)?;
        // Further values (w, or r g b vertex colours) are not geometry; three or more
        // are colours (one is the homogeneous w).
        self.coloured |= tokens.count() >= 3;
        self.positions.extend_from_slice(&p);
        Ok(())
    }

    fn face<'a>(
        &mut self,
        number: usize,
        tokens: impl Iterator<Item = &'a [u8]>,
    ) -> ReadResult<()> {
        let at = Position::Line(number);
        let face = self.faces;
        let vertices = (self.positions.len() / 3) as i64;
        self.corners.clear();
        for token in tokens {
            // `v`, `v/vt`, `v//vn` or `v/vt/vn`: only the position index matters.
            let index_token = token.split(|&b| b == b'/').next().unwrap_or(token);
            let index = parse_i64(index_token)
                .map_err(|reason| Invalid::at(at, format!("face {face}: {reason}")))?;
            let id = match index {
                1.. => index - 1,
                // Relative: -1 is the latest vertex defined before this line.
                ..0 => vertices + index,
                0 => {
                    return Err(Invalid::at(
                        at,
                        format!("face {face} uses vertex 0, but OBJ indices start at 1"),
                    ));
                }
            };
            if id < 0 {
                return Err(Invalid::at(
                    at,
                    format!(
                        "face {face} uses relative vertex {index}, but only {vertices} vertices precede it"
                    ),
                ));
            }
            if id >= vertices {
                if id > i64::from(u32::MAX) {
                    return Err(Invalid::at(at, out_of_range(face, index, vertices as u64)));
                }
                self.forward.push((number, face, index));
            }
            self.corners.push(id as u32);
        }
        check_arity(face, self.corners.len() as i64, at)?;
        push_fan(&mut self.triangles, &self.corners);
        self.faces += 1;
        Ok(())
    }

    fn finish(self) -> ReadResult<Loaded> {
        let vertices = (self.positions.len() / 3) as u64;
        if let Some(&(line, face, index)) =
            self.forward.iter().find(|&&(_, _, index)| index as u64 > vertices)
        {
            return Err(Invalid::line(line, out_of_range(face, index, vertices)));
        }
        let mut dropped = Dropped::default();
        if self.coloured {
            dropped.add("vertex colour (r g b after x y z on 'v' lines)".into());
        }
        if self.texture_coordinates > 0 {
            let count = self.texture_coordinates;
            dropped.add(format!("corner texture coordinates ({count} 'vt')"));
        }
        if self.normals > 0 {
            dropped.add(format!("normals ({} 'vn')", self.normals));
        }
        if !self.materials.is_empty() {
            const SHOWN: usize = 3;
            let mut named = self.materials[..self.materials.len().min(SHOWN)].join("; ");
            if self.materials.len() > SHOWN {
                named += &format!("; and {} more", self.materials.len() - SHOWN);
            }
            dropped.add(format!("materials and textures ({named})"));
        }
        Ok(Loaded { mesh: MeshData::new(self.positions, self.triangles), dropped })
    }
}

/// Encodes `v x y z` lines and 1-based `f a b c` lines.
pub(crate) fn write(out: &mut dyn Write, mesh: &MeshData) -> io::Result<()> {
    writeln!(
        out,
        "# meshflow: {} vertices, {} triangles",
        mesh.vertex_count(),
        mesh.triangle_count()
    )?;
    for p in mesh.positions.chunks_exact(3) {
        out.write_all(b"v ")?;
        text::write_xyz(out, p)?;
        out.write_all(b"\n")?;
    }
    for t in mesh.triangles.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|v| u64::from(v) + 1);
        writeln!(out, "f {a} {b} {c}")?;
    }
    Ok(())
}
