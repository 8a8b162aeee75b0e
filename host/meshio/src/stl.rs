//! STL, ascii and binary. STL stores three positions per triangle and no vertex ids, so the
//! reader welds corners whose positions are bit-identical into one vertex, numbered in the
//! order they first appear; the result is deterministic and topology-preserving for files
//! written from indexed meshes.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::io::{self, Write};

use super::build::{capacity, check_arity, push_fan};
use super::error::{Invalid, Position, ReadResult};
use super::text::{self, parse_f32, shown};
use crate::dropped::{Dropped, Loaded};
use meshflow_mesh::MeshData;

const HEADER: usize = 80;
const BODY: usize = HEADER + 4;
const RECORD: usize = 50;

/// Decodes an STL file. Binary when the size is exactly what the triangle count in the
/// binary header needs (binary files may also start with `solid`), ascii when the file starts
/// with `solid`.
pub(crate) fn read(bytes: &[u8]) -> ReadResult<Loaded> {
    let declared = binary_count(bytes);
    if let Some(count) =
        declared.filter(|&n| BODY as u64 + RECORD as u64 * u64::from(n) == bytes.len() as u64)
    {
        return read_binary(bytes, count as usize);
    }
    if bytes.trim_ascii_start().starts_with(b"solid") {
        let mesh = read_ascii(bytes)?;
        return Ok(Loaded { mesh, dropped: Dropped::default() });
    }
    Err(Invalid::whole(match declared {
        Some(n) => format!(
            "not an STL file: not ascii (no 'solid' at the start), and as binary STL its {n} \
             triangles need {} bytes but the file has {} (truncated?)",
            BODY as u64 + RECORD as u64 * u64::from(n),
            bytes.len()
        ),
        None => format!(
            "not an STL file: {} bytes is too short for binary STL and there is no 'solid' at the start",
            bytes.len()
        ),
    }))
}

/// The triangle count of a binary header, if the file is long enough to have one.
fn binary_count(bytes: &[u8]) -> Option<u32> {
    let field = bytes.get(HEADER..BODY)?;
    Some(u32::from_le_bytes(field.try_into().ok()?))
}

fn read_binary(bytes: &[u8], count: usize) -> ReadResult<Loaded> {
    // A closed mesh has about half as many vertices as triangles.
    let mut welder = Welder::with_capacity(count / 2 + 1);
    let mut triangles = Vec::with_capacity(count * 3);
    let mut dropped = Dropped::default();
    for (triangle, record) in bytes[BODY..].chunks_exact(RECORD).enumerate() {
        // The stored normal (first 12 bytes) is derived data. The attribute word is zero
        // unless a writer put a colour there (VisCAM, Materialise), which is not kept.
        if record[RECORD - 2..] != [0, 0] {
            dropped.add("triangle colour (STL attribute words)".into());
        }
        for corner in 0..3 {
            let offset = 12 + 12 * corner;
            let value = |k: usize| {
                let at = offset + 4 * k;
                f32::from_le_bytes(record[at..at + 4].try_into().expect("4 bytes"))
            };
            let at = Position::Byte((BODY + RECORD * triangle + offset) as u64);
            triangles.push(welder.id([value(0), value(1), value(2)], triangle, corner, at)?);
        }
    }
    Ok(Loaded { mesh: welder.finish(triangles), dropped })
}

fn read_ascii(bytes: &[u8]) -> ReadResult<MeshData> {
    let mut welder = Welder::with_capacity(capacity(bytes.len() as u64, bytes.len(), 400));
    let mut triangles = Vec::new();
    let mut polygon = Vec::new();
    let mut facet = 0;
    let mut open_facet: Option<Position> = None;
    let mut last = Position::Line(1);
    for (number, line) in text::lines(bytes) {
        let at = Position::Line(number);
        let mut tokens = text::tokens(line);
        let Some(keyword) = tokens.next() else {
            continue;
        };
        last = at;
        match keyword {
            // Solid names, facet normals and loop markers carry no geometry.
            b"solid" | b"endsolid" | b"outer" | b"endloop" => {}
            b"facet" => {
                if open_facet.is_some() {
                    return Err(Invalid::at(
                        at,
                        format!("facet {facet} is not closed by 'endfacet'"),
                    ));
                }
                open_facet = Some(at);
                polygon.clear();
            }
            b"vertex" => {
                if open_facet.is_none() {
                    return Err(Invalid::at(at, "'vertex' outside a facet"));
                }
                let mut p = [0.0f32; 3];
                for (value, axis) in p.iter_mut().zip(["x", "y", "z"]) {
                    let token = tokens.next().ok_or_else(|| {
                        Invalid::at(at, format!("facet {facet}: vertex has no {axis} coordinate"))
                    })?;
                    *value = parse_f32(token)
                        .map_err(|r| Invalid::at(at, format!("facet {facet}: {r}")))?;
                }
                let corner = polygon.len();
                polygon.push(welder.id(p, facet, corner, at)?);
            }
            b"endfacet" => {
                let start = open_facet
                    .take()
                    .ok_or_else(|| Invalid::at(at, "'endfacet' without 'facet'"))?;
                check_arity(facet, polygon.len() as i64, start)?;
                push_fan(&mut triangles, &polygon);
                facet += 1;
            }
            other => {
                return Err(Invalid::at(at, format!("unexpected '{}' in ascii STL", shown(other))));
            }
        }
    }
    if open_facet.is_some() {
        return Err(Invalid::at(last, format!("file ends inside facet {facet}")));
    }
    Ok(welder.finish(triangles))
}

/// Assigns one id per distinct position bit pattern, in first-seen order.
struct Welder {
    positions: Vec<f32>,
    ids: HashMap<[u32; 3], u32>,
}

impl Welder {
    fn with_capacity(vertices: usize) -> Self {
        Self { positions: Vec::with_capacity(vertices * 3), ids: HashMap::with_capacity(vertices) }
    }

    fn id(&mut self, p: [f32; 3], triangle: usize, corner: usize, at: Position) -> ReadResult<u32> {
        if let Some(bad) = p.iter().find(|c| !c.is_finite()) {
            let reason =
                format!("triangle {triangle} corner {corner} has a non-finite coordinate ({bad})");
            return Err(Invalid::at(at, reason));
        }
        // Bit patterns, not values: -0.0 and 0.0 stay apart, as the content hash sees them.
        match self.ids.entry(p.map(f32::to_bits)) {
            Entry::Occupied(entry) => Ok(*entry.get()),
            Entry::Vacant(entry) => {
                let id = u32::try_from(self.positions.len() / 3).map_err(|_| {
                    Invalid::at(at, "more distinct vertices than 32-bit ids can number")
                })?;
                self.positions.extend_from_slice(&p);
                Ok(*entry.insert(id))
            }
        }
    }

    fn finish(self, triangles: Vec<u32>) -> MeshData {
        MeshData::new(self.positions, triangles)
    }
}

/// Encodes binary STL. Lossy like the format: unreferenced vertices are dropped and loading
/// numbers vertices in the order triangles use them.
pub(crate) fn write(out: &mut dyn Write, mesh: &MeshData) -> io::Result<()> {
    let count = u32::try_from(mesh.triangle_count()).map_err(|_| {
        io::Error::new(io::ErrorKind::InvalidInput, "too many triangles for binary STL")
    })?;
    // The header must not start with "solid", or some readers take the file for ascii.
    let mut header = [b' '; HEADER];
    let title = b"binary STL written by meshflow";
    header[..title.len()].copy_from_slice(title);
    out.write_all(&header)?;
    out.write_all(&count.to_le_bytes())?;
    let vertex = |v: u32| -> [f32; 3] {
        let i = v as usize * 3;
        [mesh.positions[i], mesh.positions[i + 1], mesh.positions[i + 2]]
    };
    let mut record = [0u8; RECORD];
    for t in mesh.triangles.chunks_exact(3) {
        let corners = [vertex(t[0]), vertex(t[1]), vertex(t[2])];
        let values = std::iter::once(unit_normal(corners)).chain(corners).flatten();
        for (slot, value) in record.chunks_exact_mut(4).zip(values) {
            slot.copy_from_slice(&value.to_le_bytes());
        }
        out.write_all(&record)?;
    }
    Ok(())
}

/// The facet normal STL wants; zero for degenerate triangles.
fn unit_normal([a, b, c]: [[f32; 3]; 3]) -> [f32; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if length > 0.0 && length.is_finite() { n.map(|x| x / length) } else { [0.0; 3] }
}
