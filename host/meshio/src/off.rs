//! Object File Format: an optional `OFF` keyword (or a variant such as `COFF`, `NOFF`,
//! `STOFF`, `4OFF`, `nOFF`), the counts `vertices faces [edges]`, one vertex per line, then one
//! face per line as `n i0 … i(n-1)` with optional colour values after the indices.
//!
//! Read line by line, taking the values a line needs and ignoring the rest, so per-vertex
//! colours, normals or texture coordinates of every variant load without knowing their
//! exact layout. `#` starts a comment anywhere.

use std::io::{self, Write};

use super::build::{
    capacity, check_arity, check_corner, check_finite, check_vertex_count, push_fan,
};
use super::error::{Invalid, Position, ReadResult};
use super::text::{self, parse_f32, parse_i64, shown};
use crate::dropped::{Dropped, Loaded};
use meshflow_mesh::MeshData;

/// Decodes an OFF file.
pub(crate) fn read(bytes: &[u8]) -> ReadResult<Loaded> {
    let mut lines = Lines::new(bytes);
    let mut counts = Vec::new();
    let mut dropped = Dropped::default();
    let at = lines.next_or_eof(&mut counts, || "the OFF header".into())?;
    let mut dimension = 3;
    if counts[0].ends_with(b"OFF") {
        let keyword = counts.remove(0);
        dimension = keyword_dimension(keyword, at)?;
        vertex_extras(keyword, &mut dropped);
        if counts.first() == Some(&&b"BINARY"[..]) {
            return Err(Invalid::at(at, "binary OFF is not supported"));
        }
        if counts.is_empty() {
            lines.next_or_eof(&mut counts, || "the vertex and face counts".into())?;
        }
        if dimension == 0 {
            // nOFF: the dimension comes first, then the counts, possibly on the next line.
            let token = counts.remove(0);
            dimension = parse_count(token, "dimension", at)? as usize;
            if counts.is_empty() {
                lines.next_or_eof(&mut counts, || "the vertex and face counts".into())?;
            }
        }
        if dimension < 3 {
            return Err(Invalid::at(at, format!("{dimension}-dimensional OFF is not supported")));
        }
    }
    let at = lines.at;
    if counts.len() < 2 {
        return Err(Invalid::at(at, "expected the vertex and face counts"));
    }
    let vertex_count = parse_count(counts[0], "vertex count", at)?;
    let face_count = parse_count(counts[1], "face count", at)?;
    check_vertex_count(vertex_count, at)?;

    // The shortest vertex line is "0 0 0\n", the shortest face line "3 0 0 0\n".
    let remaining = lines.remaining();
    let mut positions = Vec::with_capacity(capacity(vertex_count, remaining, 6) * 3);
    let mut values = Vec::new();
    for vertex in 0..vertex_count as usize {
        let at = lines.next_or_eof(&mut values, || format!("vertex {vertex} of {vertex_count}"))?;
        if values.len() < dimension {
            let reason =
                format!("vertex {vertex} has {} values, expected {dimension}", values.len());
            return Err(Invalid::at(at, reason));
        }
        let mut p = [0.0f32; 3];
        for (value, token) in p.iter_mut().zip(&values) {
            *value =
                parse_f32(token).map_err(|r| Invalid::at(at, format!("vertex {vertex}: {r}")))?;
        }
        check_finite(vertex, p, at)?;
        positions.extend_from_slice(&p);
    }

    let mut triangles = Vec::with_capacity(capacity(face_count, lines.remaining(), 8) * 3);
    let mut corners = Vec::new();
    for face in 0..face_count as usize {
        let at = lines.next_or_eof(&mut values, || format!("face {face} of {face_count}"))?;
        let arity =
            parse_i64(values[0]).map_err(|r| Invalid::at(at, format!("face {face}: {r}")))?;
        check_arity(face, arity, at)?;
        let Some(indices) = values.get(1..=arity as usize) else {
            let reason = format!(
                "face {face} has {arity} corners but only {} values follow",
                values.len() - 1
            );
            return Err(Invalid::at(at, reason));
        };
        corners.clear();
        for token in indices {
            let index =
                parse_i64(token).map_err(|r| Invalid::at(at, format!("face {face}: {r}")))?;
            corners.push(check_corner(face, index, vertex_count, at)?);
        }
        // Values after the indices are a face colour.
        if values.len() > arity as usize + 1 {
            dropped.add("face colour (values after a face's indices)".into());
        }
        push_fan(&mut triangles, &corners);
    }
    // Anything after the faces (edges, trailing data) is not part of the mesh.
    Ok(Loaded { mesh: MeshData::new(positions, triangles), dropped })
}

/// The per-vertex values an OFF keyword announces (`STCNOFF`: texture coordinates,
/// colours, normals), which the mesh does not keep.
fn vertex_extras(keyword: &[u8], dropped: &mut Dropped) {
    let prefix = &keyword[..keyword.len() - 3];
    for (letters, what) in [
        (&b"ST"[..], "vertex texture coordinate (ST)"),
        (b"C", "vertex colour (C)"),
        (b"N", "vertex normal (N)"),
    ] {
        if prefix.windows(letters.len()).any(|w| w == letters) {
            dropped.add(what.into());
        }
    }
}

/// Vertex dimension of an OFF keyword: 3, 4 for `4OFF`, 0 for `nOFF` (given in the file).
/// The prefix letters `ST`, `C`, `N` announce extra per-vertex values, which are ignored.
fn keyword_dimension(keyword: &[u8], at: Position) -> ReadResult<usize> {
    let prefix = &keyword[..keyword.len() - 3];
    let mut dimension = 3;
    let mut rest = prefix.strip_prefix(b"ST").unwrap_or(prefix);
    rest = rest.strip_prefix(b"C").unwrap_or(rest);
    rest = rest.strip_prefix(b"N").unwrap_or(rest);
    if let Some(r) = rest.strip_prefix(b"4") {
        dimension = 4;
        rest = r;
    }
    if let Some(r) = rest.strip_prefix(b"n") {
        dimension = 0;
        rest = r;
    }
    if !rest.is_empty() {
        return Err(Invalid::at(at, format!("unknown OFF keyword '{}'", shown(keyword))));
    }
    Ok(dimension)
}

fn parse_count(token: &[u8], what: &str, at: Position) -> ReadResult<u64> {
    let count = parse_i64(token).map_err(|r| Invalid::at(at, format!("{what}: {r}")))?;
    u64::try_from(count).map_err(|_| Invalid::at(at, format!("{what} {count} is negative")))
}

/// The lines of the file that have tokens once comments are removed.
struct Lines<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Number of the last line read; errors at the end of the file point there.
    number: usize,
    at: Position,
}

impl<'a> Lines<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, pos: 0, number: 0, at: Position::Line(1) }
    }

    /// Puts the tokens of the next line that has any into `tokens` and returns its position,
    /// or an error naming what was `expected` (built only then: this runs once per line).
    fn next_or_eof(
        &mut self,
        tokens: &mut Vec<&'a [u8]>,
        expected: impl FnOnce() -> String,
    ) -> ReadResult<Position> {
        while self.pos < self.bytes.len() {
            let rest = &self.bytes[self.pos..];
            let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            self.pos += end + 1;
            self.number += 1;
            self.at = Position::Line(self.number);
            let line = &rest[..end];
            let content = match line.iter().position(|&b| b == b'#') {
                Some(hash) => &line[..hash],
                None => line,
            };
            tokens.clear();
            tokens.extend(text::tokens(content));
            if !tokens.is_empty() {
                return Ok(self.at);
            }
        }
        Err(Invalid::at(self.at, format!("file ends before {}", expected())))
    }

    fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }
}

/// Encodes `OFF`, the counts, `x y z` lines and `3 a b c` lines.
pub(crate) fn write(out: &mut dyn Write, mesh: &MeshData) -> io::Result<()> {
    writeln!(out, "OFF")?;
    writeln!(out, "{} {} 0", mesh.vertex_count(), mesh.triangle_count())?;
    for p in mesh.positions.chunks_exact(3) {
        text::write_xyz(out, p)?;
        out.write_all(b"\n")?;
    }
    for t in mesh.triangles.chunks_exact(3) {
        writeln!(out, "3 {} {} {}", t[0], t[1], t[2])?;
    }
    Ok(())
}
