//! Object File Format: an optional `OFF` keyword (or a variant such as `COFF`, `NOFF`,
//! `STOFF`, `4OFF`, `nOFF`), the counts `vertices faces [edges]`, one vertex per line, then one
//! face per line as `n i0 … i(n-1)` with optional colour values after the indices.
//!
//! Read line by line. The prefixes say what follows a vertex's coordinates, in this order:
//! `N` a normal, `C` a colour (`r g b [a]`: integers from 0 to 255, or floats from 0 to 1
//! when any has a decimal point), `ST` a texture coordinate; all are kept. Values after a
//! face's indices are its colour (kept as a face `color`). `#` starts a comment anywhere.

use std::io::{self, Write};

use super::build::{
    capacity, check_arity, check_corner, check_finite, check_vertex_count, push_fan,
};
use super::error::{Invalid, Position, ReadResult};
use super::text::{self, parse_f32, parse_i64, shown};
use crate::dropped::{Dropped, Loaded};
use crate::holds::{describe, materials};
use crate::keep::{Kept, expand_polygons, int_to_u8, unit_to_u8};
use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{self as model, Attribute, Domain, NumberType, Values};

/// Decodes an OFF file.
pub(crate) fn read(bytes: &[u8]) -> ReadResult<Loaded> {
    let mut lines = Lines::new(bytes);
    let mut counts = Vec::new();
    let mut dropped = Dropped::default();
    let at = lines.next_or_eof(&mut counts, || "the OFF header".into())?;
    let mut dimension = 3;
    let mut extras = Extras::default();
    if counts[0].ends_with(b"OFF") {
        let keyword = counts.remove(0);
        (dimension, extras) = keyword_dimension(keyword, at)?;
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
    let mut vertex_values = VertexValues::new(extras);
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
        vertex_values.read(vertex, &values[dimension..], at);
    }

    let mut triangles = Vec::with_capacity(capacity(face_count, lines.remaining(), 8) * 3);
    let mut corners = Vec::new();
    let mut face_colours = Colours::default();
    let mut fans = Vec::new();
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
        face_colours.read(face, &values[arity as usize + 1..]);
        fans.push(arity as u32 - 2);
        push_fan(&mut triangles, &corners);
    }
    // Anything after the faces (edges, trailing data) is not part of the mesh.
    let mut mesh = MeshData::new(positions, triangles);
    let mut kept = Kept::new(mesh.vertex_count(), mesh.triangle_count());
    vertex_values.keep(&mut kept, &mut dropped);
    let fans = fans.iter().any(|&n| n != 1).then_some(&fans[..]);
    face_colours.keep(Domain::Face, fans, &mut kept, &mut dropped);
    mesh.attributes = kept.attributes;
    Ok(Loaded { mesh, dropped })
}

/// What the keyword's prefix says follows each vertex's coordinates.
#[derive(Clone, Copy, Default)]
struct Extras {
    texcoord: bool,
    colour: bool,
    normal: bool,
}

/// Colours of vertices or faces as read: `r g b a` as written, or `None` for an element
/// without one.
#[derive(Default)]
struct Colours {
    rgba: Vec<[f32; 4]>,
    given: usize,
    /// Any value had a decimal point or exponent: the colours are floats from 0 to 1.
    floats: bool,
    /// Why the colours cannot be kept (a colour map index, a value not a number).
    refused: Option<String>,
}

impl Colours {
    /// Reads the colour values of `element` (none, `r g b` or `r g b a`).
    fn read(&mut self, element: usize, tokens: &[&[u8]]) {
        let mut rgba = [f32::INFINITY, f32::INFINITY, f32::INFINITY, f32::INFINITY];
        match tokens.len() {
            0 => {}
            3 | 4 => {
                for (value, token) in rgba.iter_mut().zip(tokens) {
                    self.floats |= token.iter().any(|b| b".eE".contains(b));
                    match parse_f32(token) {
                        Ok(x) => *value = x,
                        Err(e) => {
                            self.refused.get_or_insert(format!("element {element}: {e}"));
                        }
                    }
                }
                if tokens.len() == 3 {
                    rgba[3] = f32::INFINITY;
                }
                self.given += 1;
            }
            1 => {
                self.refused.get_or_insert("colour map indices".into());
            }
            n => {
                self.refused.get_or_insert(format!("element {element} has {n} colour values"));
            }
        }
        self.rgba.push(rgba);
    }

    /// The colours as an attribute of `domain`, polygons spread over their `fans`.
    fn keep(self, domain: Domain, fans: Option<&[u32]>, kept: &mut Kept, dropped: &mut Dropped) {
        let what = match domain {
            Domain::Face => "face colour (values after a face's indices)",
            _ => "vertex colour (C)",
        };
        if let Some(reason) = self.refused {
            dropped.add(format!("{what}: {reason}"));
            return;
        }
        if self.given == 0 {
            return;
        }
        let missing = self.rgba.len() - self.given;
        if missing > 0 {
            dropped.add(format!("{what}: {missing} have none; they are white"));
        }
        let convert = if self.floats { unit_to_u8 } else { int_to_u8 };
        let bytes: Vec<u8> = self
            .rgba
            .iter()
            .flatten()
            .map(|&x| if x == f32::INFINITY { 255 } else { convert(f64::from(x)) })
            .collect();
        let values = expand_polygons(Values::U8(bytes), 4, fans);
        let colour = Attribute { domain, name: model::COLOR.into(), components: 4, values };
        kept.keep(colour, what, dropped);
    }
}

/// The normals, colours and texture coordinates of vertex lines.
struct VertexValues {
    extras: Extras,
    normals: Vec<f32>,
    colours: Colours,
    texcoords: Vec<f32>,
    /// Why normals or texture coordinates cannot be kept.
    refused: Option<String>,
}

impl VertexValues {
    fn new(extras: Extras) -> Self {
        Self {
            extras,
            normals: Vec::new(),
            colours: Colours::default(),
            texcoords: Vec::new(),
            refused: None,
        }
    }

    /// Reads the values after a vertex's coordinates: `[nx ny nz] [r g b [a]] [s t]`.
    fn read(&mut self, vertex: usize, mut rest: &[&[u8]], at: Position) {
        let Extras { texcoord, colour, normal } = self.extras;
        let floats = |tokens: &[&[u8]], out: &mut Vec<f32>, refused: &mut Option<String>| {
            for token in tokens {
                match parse_f32(token) {
                    Ok(x) => out.push(x),
                    Err(e) => {
                        refused.get_or_insert(format!("{at}: {e}"));
                        out.push(0.0);
                    }
                }
            }
        };
        let needed = 3 * usize::from(normal) + 2 * usize::from(texcoord);
        if rest.len() < needed + if colour { 3 } else { 0 } {
            self.refused.get_or_insert(format!("vertex {vertex} has too few values"));
            return;
        }
        if normal {
            floats(&rest[..3], &mut self.normals, &mut self.refused);
            rest = &rest[3..];
        }
        if texcoord {
            let (head, st) = rest.split_at(rest.len() - 2);
            floats(st, &mut self.texcoords, &mut self.refused);
            rest = head;
        }
        if colour {
            self.colours.read(vertex, rest);
        }
    }

    fn keep(self, kept: &mut Kept, dropped: &mut Dropped) {
        let Extras { texcoord, colour, normal } = self.extras;
        if let Some(reason) = &self.refused {
            for (on, what) in [
                (normal, "vertex normal (N)"),
                (colour, "vertex colour (C)"),
                (texcoord, "vertex texture coordinate (ST)"),
            ] {
                if on {
                    dropped.add(format!("{what}: {reason}"));
                }
            }
            return;
        }
        if normal {
            kept.keep(Attribute::normal(self.normals), "vertex normal (N)", dropped);
        }
        if colour {
            self.colours.keep(Domain::Vertex, None, kept, dropped);
        }
        if texcoord {
            let uv = Attribute::texcoord(Domain::Vertex, self.texcoords);
            kept.keep(uv, "vertex texture coordinate (ST)", dropped);
        }
    }
}

/// Vertex dimension of an OFF keyword: 3, 4 for `4OFF`, 0 for `nOFF` (given in the file),
/// and the values the prefix letters `ST`, `C`, `N` announce after the coordinates.
fn keyword_dimension(keyword: &[u8], at: Position) -> ReadResult<(usize, Extras)> {
    let prefix = &keyword[..keyword.len() - 3];
    let mut dimension = 3;
    let mut extras = Extras::default();
    let mut rest = prefix;
    for (letters, flag) in
        [(&b"ST"[..], &mut extras.texcoord), (b"C", &mut extras.colour), (b"N", &mut extras.normal)]
    {
        if let Some(r) = rest.strip_prefix(letters) {
            *flag = true;
            rest = r;
        }
    }
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
    Ok((dimension, extras))
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

/// The attributes OFF holds: vertex colours (`C`), normals (`N`) and texture coordinates
/// (`ST`), and face colours.
fn held(a: &Attribute) -> bool {
    let u8x4 = a.components == 4 && a.values.number_type() == NumberType::U8;
    matches!((a.domain, a.name.as_str()), (Domain::Vertex, model::NORMAL | model::TEXCOORD))
        || (matches!(a.domain, Domain::Vertex | Domain::Face) && a.name == model::COLOR && u8x4)
}

/// What OFF cannot hold of the mesh.
pub(crate) fn unsupported(mesh: &MeshData) -> Vec<String> {
    let mut lines: Vec<String> =
        mesh.attributes.iter().filter(|a| !held(a)).map(describe).collect();
    lines.extend(materials(mesh, true, true, true));
    lines
}

/// Encodes `[ST][C][N]OFF`, the counts, `x y z [nx ny nz] [r g b a] [s t]` lines and
/// `3 a b c [r g b a]` lines; colours as integers from 0 to 255.
pub(crate) fn write(out: &mut dyn Write, mesh: &MeshData) -> io::Result<()> {
    let get =
        |domain, name| mesh.attributes.get(domain, name).filter(|a| held(a)).map(|a| &a.values);
    let normals = match get(Domain::Vertex, model::NORMAL) {
        Some(Values::F32(v)) => Some(v),
        _ => None,
    };
    let colours = match get(Domain::Vertex, model::COLOR) {
        Some(Values::U8(v)) => Some(v),
        _ => None,
    };
    let texcoords = match get(Domain::Vertex, model::TEXCOORD) {
        Some(Values::F32(v)) => Some(v),
        _ => None,
    };
    let face_colours = match get(Domain::Face, model::COLOR) {
        Some(Values::U8(v)) => Some(v),
        _ => None,
    };
    let st = if texcoords.is_some() { "ST" } else { "" };
    let c = if colours.is_some() { "C" } else { "" };
    let n = if normals.is_some() { "N" } else { "" };
    writeln!(out, "{st}{c}{n}OFF")?;
    writeln!(out, "{} {} 0", mesh.vertex_count(), mesh.triangle_count())?;
    for (v, p) in mesh.positions.chunks_exact(3).enumerate() {
        text::write_xyz(out, p)?;
        if let Some(normals) = normals {
            out.write_all(b" ")?;
            text::write_xyz(out, &normals[3 * v..3 * v + 3])?;
        }
        if let Some(colours) = colours {
            let c = &colours[4 * v..4 * v + 4];
            write!(out, " {} {} {} {}", c[0], c[1], c[2], c[3])?;
        }
        if let Some(texcoords) = texcoords {
            out.write_all(b" ")?;
            text::write_f32(out, texcoords[2 * v])?;
            out.write_all(b" ")?;
            text::write_f32(out, texcoords[2 * v + 1])?;
        }
        out.write_all(b"\n")?;
    }
    for (f, t) in mesh.triangles.chunks_exact(3).enumerate() {
        write!(out, "3 {} {} {}", t[0], t[1], t[2])?;
        if let Some(colours) = face_colours {
            let c = &colours[4 * f..4 * f + 4];
            write!(out, " {} {} {} {}", c[0], c[1], c[2], c[3])?;
        }
        out.write_all(b"\n")?;
    }
    Ok(())
}
