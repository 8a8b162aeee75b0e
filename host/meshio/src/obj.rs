//! Wavefront OBJ: `v` (with `r g b` colours), `vt`, `vn`, `f` (`v`, `v/t`, `v//n`,
//! `v/t/n`), `mtllib` and `usemtl`; groups, objects, lines and points carry no
//! triangle-mesh data and are skipped.
//!
//! Texture coordinates are per corner (`texcoord` on corners), unless the file gives every
//! vertex its own, one `vt` per `v` in the same order (then per vertex). Normals are per
//! vertex: a vertex whose corners name different normals gets their mean, and the load says
//! so. `usemtl` gives each face a `material`; faces before any `usemtl` use one named
//! `default`. The textures a library names are not part of the mesh (a mesh is what the file
//! holds, wherever it lies): they are read from the libraries when those are copied beside
//! a saved mesh (see [`library_textures`]).
//!
//! Parsed here rather than with `tobj`: tobj renumbers vertices per object in the order faces
//! first use them and drops unreferenced ones, which would change raw scans and break
//! bit-identical round trips; it also reports errors without line numbers.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::io::{self, Write};
use std::path::Path;

use super::build::{check_arity, check_finite, out_of_range, push_fan};
use super::error::{Invalid, Position, ReadResult};
use super::text::{self, parse_f32, parse_i64};
use crate::dropped::{Dropped, Loaded};
use crate::holds::{describe, materials};
use crate::keep::{Kept, MaterialList, MaterialNames, acceptable, int_to_u8, unit_to_u8};
use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{self as model, Attribute, Domain, Values};

/// A corner without a texture coordinate or normal index, or a face without a material.
const NONE: u32 = u32::MAX;
/// A face whose `usemtl` name was refused.
const REFUSED: u32 = u32::MAX - 1;
/// What faces before any `usemtl` use.
const DEFAULT_MATERIAL: &str = "default";
/// Marks a vertex without a colour on its `v` line: it becomes opaque white.
const WHITE: f32 = f32::INFINITY;

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

/// Per-corner indices of one kind (`vt` or `vn`), kept from the first corner that has one.
#[derive(Default)]
struct CornerIndices {
    /// 0-based indices per triangle corner, [`NONE`] where a corner has none; empty until
    /// the first corner with one.
    corners: Vec<u32>,
    /// A corner named an index that does not exist (checked at the end for forward
    /// references): `(line, index)`.
    bad: Option<(usize, i64)>,
}

impl CornerIndices {
    /// Appends the fan triangles' indices for a polygon whose corners have `indices`.
    fn push(&mut self, indices: &[u32], triangles_before: usize) {
        if self.corners.is_empty() {
            if indices.iter().all(|&i| i == NONE) {
                return;
            }
            self.corners.resize(triangles_before * 3, NONE);
        }
        push_fan(&mut self.corners, indices);
    }
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
    /// `r g b` per vertex ([`WHITE`] for a vertex without); empty until the first colour.
    colours: Vec<f32>,
    texcoords: Vec<f32>,
    normals: Vec<f32>,
    /// A `vt` or `vn` line that is not numbers: `(what, line)`; those are then dropped.
    bad_texcoord: Option<usize>,
    bad_normal: Option<usize>,
    corner_texcoords: CornerIndices,
    corner_normals: CornerIndices,
    texcoord_scratch: Vec<u32>,
    normal_scratch: Vec<u32>,
    /// Material per triangle ([`NONE`] before any `usemtl`), from the first `usemtl` on.
    face_materials: Option<Vec<u32>>,
    material: u32,
    names: MaterialNames,
    dropped: Dropped,
}

impl Reader {
    fn statement(&mut self, number: usize, line: &[u8]) -> ReadResult<()> {
        let mut tokens = text::tokens(line);
        match tokens.next() {
            Some(b"v") => self.vertex(Position::Line(number), tokens),
            Some(b"f") | Some(b"fo") => self.face(number, tokens),
            Some(b"vt") => {
                if !numbers(tokens, 1, &mut self.texcoords, 2) {
                    self.bad_texcoord.get_or_insert(number);
                }
                Ok(())
            }
            Some(b"vn") => {
                if !numbers(tokens, 3, &mut self.normals, 3) {
                    self.bad_normal.get_or_insert(number);
                }
                Ok(())
            }
            Some(b"mtllib") => {
                for name in tokens {
                    let name = String::from_utf8_lossy(name);
                    self.names.add(MaterialList::Libraries, &name, &mut self.dropped);
                }
                Ok(())
            }
            Some(keyword @ b"usemtl") => {
                let start = line.windows(keyword.len()).position(|w| w == keyword).unwrap_or(0);
                let name = String::from_utf8_lossy(line[start + keyword.len()..].trim_ascii());
                self.use_material(&name);
                Ok(())
            }
            _ => Ok(()),
        }
    }

    fn use_material(&mut self, name: &str) {
        let faces = self.triangles.len() / 3;
        self.face_materials.get_or_insert_with(|| vec![NONE; faces]);
        self.material = match self.names.add(MaterialList::Names, name, &mut self.dropped) {
            Some(i) => i as u32,
            None => REFUSED,
        };
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
        self.positions.extend_from_slice(&p);
        // Further values: one is the homogeneous w; three or more are `r g b` colours.
        let rest: Vec<&[u8]> = tokens.take(3).collect();
        if rest.len() == 3 {
            let rgb: Option<Vec<f32>> = rest.iter().map(|t| parse_f32(t).ok()).collect();
            match rgb {
                Some(rgb) => {
                    if self.colours.is_empty() {
                        self.colours.resize(vertex * 3, WHITE);
                    }
                    self.colours.extend_from_slice(&rgb);
                }
                None => {
                    self.dropped.add(format!("vertex colour on {at}: values that are not numbers"))
                }
            }
        }
        if !self.colours.is_empty() && self.colours.len() < self.positions.len() {
            self.colours.resize(self.positions.len(), WHITE);
        }
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
        self.texcoord_scratch.clear();
        self.normal_scratch.clear();
        for token in tokens {
            // `v`, `v/vt`, `v//vn` or `v/vt/vn`.
            let mut parts = token.split(|&b| b == b'/');
            let index_token = parts.next().unwrap_or(token);
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
            let defined = self.texcoords.len() / 2;
            let t = corner_index(parts.next(), defined, number, &mut self.corner_texcoords);
            self.texcoord_scratch.push(t);
            let defined = self.normals.len() / 3;
            let n = corner_index(parts.next(), defined, number, &mut self.corner_normals);
            self.normal_scratch.push(n);
        }
        check_arity(face, self.corners.len() as i64, at)?;
        let before = self.triangles.len() / 3;
        push_fan(&mut self.triangles, &self.corners);
        self.corner_texcoords.push(&self.texcoord_scratch, before);
        self.corner_normals.push(&self.normal_scratch, before);
        if let Some(materials) = &mut self.face_materials {
            let fan = self.corners.len() - 2;
            materials.extend(std::iter::repeat_n(self.material, fan));
        }
        self.faces += 1;
        Ok(())
    }

    fn finish(mut self) -> ReadResult<Loaded> {
        let vertices = (self.positions.len() / 3) as u64;
        if let Some(&(line, face, index)) =
            self.forward.iter().find(|&&(_, _, index)| index as u64 > vertices)
        {
            return Err(Invalid::line(line, out_of_range(face, index, vertices)));
        }
        let (v, t) = (self.positions.len() / 3, self.triangles.len() / 3);
        let mut kept = Kept::new(v, t);
        let mut dropped = std::mem::take(&mut self.dropped);
        self.colours(&mut kept, &mut dropped);
        self.texture_coordinates(&mut kept, &mut dropped);
        self.vertex_normals(&mut kept, &mut dropped);
        self.materials(&mut kept, &mut dropped);
        let mut mesh = MeshData::new(self.positions, self.triangles);
        mesh.attributes = kept.attributes;
        mesh.attributes.materials = self.names.materials;
        Ok(Loaded { mesh, dropped })
    }

    fn colours(&mut self, kept: &mut Kept, dropped: &mut Dropped) {
        if self.colours.is_empty() {
            return;
        }
        // Floats from 0 to 1 (the common extension), or bytes when any value exceeds 1.
        let unit = self.colours.iter().all(|&c| c <= 1.0 || c == WHITE);
        let missing = self.colours.chunks_exact(3).filter(|c| c[0] == WHITE).count();
        if missing > 0 {
            dropped.add(format!("vertex colour: {missing} 'v' lines have none; they are white"));
        }
        let mut rgba = Vec::with_capacity(self.colours.len() / 3 * 4);
        for c in self.colours.chunks_exact(3) {
            for &x in c {
                let x = f64::from(x);
                rgba.push(if unit { unit_to_u8(x) } else { int_to_u8(x) });
            }
            rgba.push(255);
        }
        kept.keep(
            Attribute::color(rgba),
            "vertex colour (r g b after x y z on 'v' lines)",
            dropped,
        );
    }

    fn texture_coordinates(&mut self, kept: &mut Kept, dropped: &mut Dropped) {
        let count = self.texcoords.len() / 2;
        let corners = std::mem::take(&mut self.corner_texcoords);
        let what = format!("texture coordinates ({count} 'vt')");
        let Some(indices) = used(self.bad_texcoord, corners, count, &what, dropped) else {
            return;
        };
        if let Some(uv) =
            per_vertex(&indices, &self.triangles, &self.texcoords, 2, self.positions.len() / 3)
        {
            kept.keep(Attribute::texcoord(Domain::Vertex, uv), &what, dropped);
            return;
        }
        let without = indices.iter().filter(|&&i| i == NONE).count();
        if without > 0 {
            dropped.add(format!("{what}: {without} face corners have none; they get 0 0"));
        }
        let mut uv = Vec::with_capacity(indices.len() * 2);
        for &i in &indices {
            match i {
                NONE => uv.extend_from_slice(&[0.0, 0.0]),
                i => uv.extend_from_slice(&self.texcoords[2 * i as usize..2 * i as usize + 2]),
            }
        }
        kept.keep(Attribute::texcoord(Domain::Corner, uv), &what, dropped);
    }

    fn vertex_normals(&mut self, kept: &mut Kept, dropped: &mut Dropped) {
        let count = self.normals.len() / 3;
        let corners = std::mem::take(&mut self.corner_normals);
        let what = format!("normals ({count} 'vn')");
        let Some(indices) = used(self.bad_normal, corners, count, &what, dropped) else {
            return;
        };
        if let Some(xyz) =
            per_vertex(&indices, &self.triangles, &self.normals, 3, self.positions.len() / 3)
        {
            kept.keep(Attribute::normal(xyz), &what, dropped);
            return;
        }
        // One normal per vertex: the one its corners name, or the mean of several.
        let vertices = self.positions.len() / 3;
        let mut first = vec![NONE; vertices];
        let mut sum = vec![[0.0f64; 3]; vertices];
        let mut differing = vec![false; vertices];
        for (&v, &n) in self.triangles.iter().zip(&indices) {
            if n == NONE {
                continue;
            }
            let (v, normal) = (v as usize, &self.normals[3 * n as usize..3 * n as usize + 3]);
            match first[v] {
                NONE => first[v] = n,
                f if self.normals[3 * f as usize..3 * f as usize + 3] != *normal => {
                    differing[v] = true
                }
                _ => {}
            }
            for k in 0..3 {
                sum[v][k] += f64::from(normal[k]);
            }
        }
        let mut xyz = Vec::with_capacity(vertices * 3);
        for v in 0..vertices {
            if first[v] == NONE {
                xyz.extend_from_slice(&[0.0; 3]);
            } else if !differing[v] {
                let f = first[v] as usize;
                xyz.extend_from_slice(&self.normals[3 * f..3 * f + 3]);
            } else {
                let s = sum[v];
                let length = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
                let scale = if length > 0.0 { 1.0 / length } else { 0.0 };
                xyz.extend(s.iter().map(|c| (c * scale) as f32));
            }
        }
        let averaged = differing.iter().filter(|&&d| d).count();
        if averaged > 0 {
            dropped.add(format!(
                "{what}: {averaged} vertices have different normals on different faces; \
                 each keeps their normalised mean"
            ));
        }
        let without = indices.iter().filter(|&&i| i == NONE).count();
        if without > 0 {
            dropped.add(format!("{what}: {without} face corners have none"));
        }
        kept.keep(Attribute::normal(xyz), &what, dropped);
    }

    fn materials(&mut self, kept: &mut Kept, dropped: &mut Dropped) {
        let Some(mut faces) = self.face_materials.take() else { return };
        if faces.contains(&REFUSED) {
            dropped.add("face materials: a 'usemtl' name was refused".into());
            return;
        }
        if faces.contains(&NONE) {
            let Some(default) = self.names.add(MaterialList::Names, DEFAULT_MATERIAL, dropped)
            else {
                return;
            };
            for m in faces.iter_mut().filter(|m| **m == NONE) {
                *m = default as u32;
            }
        }
        kept.keep(Attribute::material(faces), "face materials ('usemtl')", dropped);
    }
}

/// Parses at least `min` and at most `max` numbers of a `vt` or `vn` line into `out`
/// (missing ones are 0); false when one is not a number.
fn numbers<'a>(
    tokens: impl Iterator<Item = &'a [u8]>,
    min: usize,
    out: &mut Vec<f32>,
    max: usize,
) -> bool {
    let mut values = [0.0f32; 3];
    let mut n = 0;
    for token in tokens.take(max) {
        match parse_f32(token) {
            Ok(x) if x.is_finite() => values[n] = x,
            _ => return false,
        }
        n += 1;
    }
    out.extend_from_slice(&values[..max]);
    n >= min
}

/// The 0-based index of a corner's `vt` or `vn` part: [`NONE`] when absent; a bad one is
/// noted in `indices`.
fn corner_index(
    part: Option<&[u8]>,
    defined: usize,
    line: usize,
    indices: &mut CornerIndices,
) -> u32 {
    let Some(part) = part.filter(|p| !p.is_empty()) else { return NONE };
    let Ok(index) = parse_i64(part) else {
        indices.bad.get_or_insert((line, 0));
        return NONE;
    };
    let id = match index {
        1.. => index - 1,
        ..0 => defined as i64 + index,
        0 => -1,
    };
    match u32::try_from(id) {
        Ok(id) if id < REFUSED => id,
        _ => {
            indices.bad.get_or_insert((line, index));
            NONE
        }
    }
}

/// The corner indices when they name existing values; `None` when no corner has one, or
/// one is bad (named in `dropped`).
fn checked(
    corners: CornerIndices,
    count: usize,
    what: &str,
    dropped: &mut Dropped,
) -> Option<Vec<u32>> {
    if let Some((line, index)) = corners.bad {
        dropped.add(format!("{what}: line {line} names index {index}, which is not one"));
        return None;
    }
    if corners.corners.is_empty() {
        return None;
    }
    if let Some(&i) = corners.corners.iter().find(|&&i| i != NONE && i as usize >= count) {
        dropped.add(format!("{what}: a face names index {}, beyond the last", i + 1));
        return None;
    }
    Some(corners.corners)
}

/// The corners' indices into `count` values (`vt` or `vn`), or `None` with what was wrong
/// named in `dropped`: a line of them that was not numbers, or no face using them.
fn used(
    bad_line: Option<usize>,
    corners: CornerIndices,
    count: usize,
    what: &str,
    dropped: &mut Dropped,
) -> Option<Vec<u32>> {
    if let Some(line) = bad_line {
        dropped.add(format!("{what}: line {line} is not numbers"));
        return None;
    }
    let indices = checked(corners, count, what, dropped);
    if indices.is_none() && count > 0 {
        dropped.add(format!("{what}: no face uses them"));
    }
    indices
}

/// The values per vertex when the file gives one per vertex in vertex order and every
/// corner names its vertex's own (`f 1/1/1 2/2/2 …`): exactly what a writer of per-vertex
/// values writes, unreferenced vertices included.
fn per_vertex(
    indices: &[u32],
    triangles: &[u32],
    values: &[f32],
    per: usize,
    vertices: usize,
) -> Option<Vec<f32>> {
    let own = values.len() / per == vertices && indices.iter().zip(triangles).all(|(i, v)| i == v);
    own.then(|| values.to_vec())
}

/// The textures (`map_Kd` and the other maps) the material `libraries` beside an OBJ in
/// `dir` name: only plain file names, each checked; what could not be read or was refused
/// is named in the second list.
pub(crate) fn library_textures(dir: &Path, libraries: &[String]) -> (Vec<String>, Vec<String>) {
    /// A material library larger than this is not read (they are a few KB).
    const MAX_LIBRARY_BYTES: u64 = 4 << 20;
    let mut names = MaterialNames { materials: meshflow_mesh::attributes::Materials::default() };
    let mut notes = Dropped::default();
    for library in libraries {
        let library = library.clone();
        if !acceptable(MaterialList::Libraries, &library) {
            continue;
        }
        let path = dir.join(&library);
        let size = std::fs::metadata(&path).ok().filter(|m| m.is_file()).map(|m| m.len());
        let text = match size {
            Some(size) if size <= MAX_LIBRARY_BYTES => std::fs::read(&path).ok(),
            Some(_) => {
                notes.add(format!("material library '{library}': too large to read"));
                continue;
            }
            None => None,
        };
        let Some(text) = text else {
            continue; // the copy names it as missing
        };
        for (_, line) in text::lines(&text) {
            let mut tokens = text::tokens(line);
            let Some(keyword) = tokens.next() else { continue };
            let keyword = keyword.to_ascii_lowercase();
            let is_map = keyword.starts_with(b"map_")
                || [&b"bump"[..], b"disp", b"decal", b"refl", b"norm"].contains(&&keyword[..]);
            // Options (`-s 1 1 1`, `-bm 0.5`) come first; the file name is last.
            if let (true, Some(file)) = (is_map, tokens.last()) {
                let file = String::from_utf8_lossy(file);
                names.add(MaterialList::Textures, &file, &mut notes);
            }
        }
    }
    (names.materials.textures, notes.lines())
}

/// What OBJ cannot hold of the mesh.
pub(crate) fn unsupported(mesh: &MeshData) -> Vec<String> {
    let attributes = &mesh.attributes;
    let corner_uv = attributes.get(Domain::Corner, model::TEXCOORD).is_some();
    let mut lines = Vec::new();
    for a in attributes.iter() {
        match (a.domain, a.name.as_str()) {
            (Domain::Vertex, model::COLOR) => {
                let Values::U8(rgba) = &a.values else { continue };
                if rgba.chunks_exact(4).any(|c| c[3] != 255) {
                    lines.push("vertex color's alpha (not opaque everywhere)".into());
                }
            }
            (Domain::Vertex, model::NORMAL) | (Domain::Corner, model::TEXCOORD) => {}
            (Domain::Vertex, model::TEXCOORD) if !corner_uv => {}
            (Domain::Face, model::MATERIAL) if material_indices(mesh).is_some() => {}
            _ => lines.push(describe(a)),
        }
    }
    let m = &attributes.materials;
    let material = attributes.get(Domain::Face, model::MATERIAL).is_some();
    if !m.names.is_empty() && !material && mesh.triangle_count() > 0 {
        lines.extend(materials(mesh, true, false, false));
    }
    if m.libraries.is_empty() {
        lines.extend(materials(mesh, false, false, true));
    }
    let spaced = m.libraries.iter().any(|l| l.contains(|c: char| c.is_ascii_whitespace()));
    let padded = m.names.iter().any(|n| n.trim_ascii() != n);
    if spaced || padded {
        lines.push("material or library names with spaces where OBJ cannot keep them".into());
    }
    lines
}

/// The material indices when every one names a material.
fn material_indices(mesh: &MeshData) -> Option<&[u32]> {
    let a = mesh.attributes.get(Domain::Face, model::MATERIAL)?;
    let Values::U32(indices) = &a.values else { return None };
    let names = mesh.attributes.materials.names.len();
    indices.iter().all(|&i| (i as usize) < names).then_some(indices)
}

/// Encodes `mtllib`, `v x y z [r g b]`, `vt`, `vn`, `usemtl` and 1-based `f a/t/n` lines.
pub(crate) fn write(out: &mut dyn Write, mesh: &MeshData) -> io::Result<()> {
    writeln!(
        out,
        "# meshflow: {} vertices, {} triangles",
        mesh.vertex_count(),
        mesh.triangle_count()
    )?;
    let attributes = &mesh.attributes;
    let m = &attributes.materials;
    if !m.libraries.is_empty() {
        writeln!(out, "mtllib {}", m.libraries.join(" "))?;
    }
    let colours = match attributes.get(Domain::Vertex, model::COLOR).map(|a| &a.values) {
        Some(Values::U8(rgba)) => Some(rgba),
        _ => None,
    };
    for (v, p) in mesh.positions.chunks_exact(3).enumerate() {
        out.write_all(b"v ")?;
        text::write_xyz(out, p)?;
        if let Some(rgba) = colours {
            for &c in &rgba[4 * v..4 * v + 3] {
                out.write_all(b" ")?;
                text::write_f32(out, f32::from(c) / 255.0)?;
            }
        }
        out.write_all(b"\n")?;
    }
    let texcoords = texcoord_indices(mesh);
    if let Some((values, _)) = &texcoords {
        for uv in values.chunks_exact(2) {
            out.write_all(b"vt ")?;
            text::write_f32(out, uv[0])?;
            out.write_all(b" ")?;
            text::write_f32(out, uv[1])?;
            out.write_all(b"\n")?;
        }
    }
    let normals = match attributes.get(Domain::Vertex, model::NORMAL).map(|a| &a.values) {
        Some(Values::F32(xyz)) => Some(xyz),
        _ => None,
    };
    if let Some(xyz) = normals {
        for n in xyz.chunks_exact(3) {
            out.write_all(b"vn ")?;
            text::write_xyz(out, n)?;
            out.write_all(b"\n")?;
        }
    }
    let materials = material_indices(mesh);
    if let Some(indices) = materials {
        // Names are numbered in the order `usemtl` first names them: when faces first use
        // them in another order, or some not at all, name them all first.
        let mut seen = vec![false; m.names.len()];
        let mut order = Vec::new();
        for &i in indices {
            if !std::mem::replace(&mut seen[i as usize], true) {
                order.push(i);
            }
        }
        if order.iter().enumerate().any(|(k, &i)| k as u32 != i) || order.len() < m.names.len() {
            for name in &m.names {
                writeln!(out, "usemtl {name}")?;
            }
        }
    } else if !m.names.is_empty() && mesh.triangle_count() == 0 {
        for name in &m.names {
            writeln!(out, "usemtl {name}")?;
        }
    }
    let mut current = NONE;
    for (t, corners) in mesh.triangles.chunks_exact(3).enumerate() {
        if let Some(indices) = materials
            && indices[t] != current
        {
            current = indices[t];
            writeln!(out, "usemtl {}", m.names[current as usize])?;
        }
        out.write_all(b"f")?;
        for (k, &v) in corners.iter().enumerate() {
            let v = u64::from(v) + 1;
            let t = texcoords.as_ref().map(|(_, at)| u64::from(at(3 * t + k, v as u32 - 1)) + 1);
            match (t, normals.is_some()) {
                (None, false) => write!(out, " {v}")?,
                (Some(t), false) => write!(out, " {v}/{t}")?,
                (None, true) => write!(out, " {v}//{v}")?,
                (Some(t), true) => write!(out, " {v}/{t}/{v}")?,
            }
        }
        out.write_all(b"\n")?;
    }
    Ok(())
}

/// A corner's `vt` index from its corner number and vertex.
type TexcoordAt = Box<dyn Fn(usize, u32) -> u32>;

/// The `vt` values to write and each corner's index into them: per vertex (one `vt` a
/// vertex), or per corner (equal values written once).
fn texcoord_indices(mesh: &MeshData) -> Option<(Vec<f32>, TexcoordAt)> {
    let attributes = &mesh.attributes;
    if let Some(a) = attributes.get(Domain::Corner, model::TEXCOORD) {
        let Values::F32(uv) = &a.values else { return None };
        let mut values = Vec::new();
        let mut indices = Vec::with_capacity(uv.len() / 2);
        let mut seen: HashMap<[u32; 2], u32> = HashMap::new();
        for pair in uv.chunks_exact(2) {
            let key = [pair[0].to_bits(), pair[1].to_bits()];
            let next = (values.len() / 2) as u32;
            let index = match seen.entry(key) {
                Entry::Occupied(e) => *e.get(),
                Entry::Vacant(e) => {
                    values.extend_from_slice(pair);
                    *e.insert(next)
                }
            };
            indices.push(index);
        }
        // One `vt` per vertex in vertex order, each corner naming its vertex's, would read
        // back as per-vertex coordinates: one unused `vt` more keeps them per corner.
        let looks_per_vertex = values.len() / 2 == mesh.vertex_count()
            && indices.iter().zip(&mesh.triangles).all(|(i, v)| i == v);
        if looks_per_vertex {
            values.extend_from_slice(&[0.0, 0.0]);
        }
        return Some((values, Box::new(move |corner, _| indices[corner])));
    }
    let a = attributes.get(Domain::Vertex, model::TEXCOORD)?;
    let Values::F32(uv) = &a.values else { return None };
    Some((uv.clone(), Box::new(|_, vertex| vertex)))
}
