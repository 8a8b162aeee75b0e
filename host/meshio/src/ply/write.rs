//! Writing PLY: `float x y z` vertices and `list uchar int vertex_indices` faces, with every
//! attribute PLY can hold: vertex `uchar red green blue alpha`, `float nx ny nz`,
//! `float quality`, `float texture_u texture_v` (or the other names readers know for them,
//! when another attribute has those names); face `uchar red green blue alpha`,
//! `int texnumber` (the material), `list uchar float texcoord` (corner texture coordinates,
//! as MeshLab writes them); every other vertex and face attribute by its name and type (a
//! list of its components when it has more than one); `comment TextureFile` lines, and
//! `comment meshflow material|library` lines for what PLY has no place for.

use std::io::{self, Write};

use super::super::PlyEncoding;
use super::super::text;
use super::plan::{CORNER_TEXCOORD, Group, MESHFLOW_COMMENT, TEXNUMBER, groups, reserved};
use meshflow_mesh::attributes::{self as model, Attribute, Domain, NumberType, Values};
use meshflow_mesh::{MeshData, as_le_bytes_f32};

/// One property group of a record: `per` numbers of `values` per element, after a count
/// byte when `list`.
struct Field<'a> {
    values: &'a Values,
    per: usize,
    list: bool,
}

/// Encodes a mesh as PLY in the given encoding.
pub(crate) fn write(out: &mut dyn Write, mesh: &MeshData, encoding: PlyEncoding) -> io::Result<()> {
    let format = match encoding {
        PlyEncoding::Ascii => "ascii",
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
        PlyEncoding::BinaryBigEndian => "binary_big_endian",
    };
    let (vertex_fields, vertex_header) = fields(mesh, Domain::Vertex);
    let (face_fields, face_header) = fields(mesh, Domain::Face);
    // `int` is what every reader expects; only ids beyond i32 need `uint`.
    let index_type = if mesh.vertex_count() > i32::MAX as usize { "uint" } else { "int" };
    write!(out, "ply\nformat {format} 1.0\ncomment written by meshflow\n")?;
    let materials = &mesh.attributes.materials;
    for texture in &materials.textures {
        writeln!(out, "comment TextureFile {texture}")?;
    }
    if !names_follow_textures(mesh) {
        for name in &materials.names {
            writeln!(out, "comment {MESHFLOW_COMMENT} material {name}")?;
        }
    }
    for library in &materials.libraries {
        writeln!(out, "comment {MESHFLOW_COMMENT} library {library}")?;
    }
    write!(
        out,
        "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         {vertex_header}element face {}\nproperty list uchar {index_type} vertex_indices\n\
         {face_header}end_header\n",
        mesh.vertex_count(),
        mesh.triangle_count()
    )?;
    if vertex_fields.is_empty() && face_fields.is_empty() {
        return match encoding {
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
        };
    }
    write_records(out, encoding, mesh.vertex_count(), &vertex_fields, |buffer, v| {
        put_f32s(buffer, &mesh.positions[3 * v..3 * v + 3], encoding)
    })?;
    write_records(out, encoding, mesh.triangle_count(), &face_fields, |buffer, t| {
        put_corners(buffer, &mesh.triangles[3 * t..3 * t + 3], encoding)
    })
}

/// Whether the material names are the textures' and a reader takes them from there (a
/// `texnumber` of a material attribute), so no `comment meshflow material` is needed.
fn names_follow_textures(mesh: &MeshData) -> bool {
    let m = &mesh.attributes.materials;
    m.names == m.textures && mesh.attributes.get(Domain::Face, model::MATERIAL).is_some()
}

/// Whether PLY holds this attribute of the mesh, and how it is written: its header lines.
pub(crate) fn properties(mesh: &MeshData, a: &Attribute) -> Option<String> {
    let ty = ply_type(a.values.number_type());
    let shape = (a.domain, a.name.as_str(), a.components, a.values.number_type());
    Some(match shape {
        (Domain::Vertex | Domain::Face, model::COLOR, 4, NumberType::U8) => {
            let names = written_names(mesh, a.domain, model::COLOR)?;
            names.iter().map(|n| format!("property uchar {n}\n")).collect()
        }
        (Domain::Vertex, model::NORMAL | model::TEXCOORD, ..) => {
            let names = written_names(mesh, a.domain, &a.name)?;
            names.iter().map(|n| format!("property float {n}\n")).collect()
        }
        (Domain::Vertex, model::QUALITY, ..) => "property float quality\n".into(),
        (Domain::Corner, model::TEXCOORD, ..) => {
            format!("property list uchar float {CORNER_TEXCOORD}\n")
        }
        (Domain::Corner, ..) => return None,
        (Domain::Face, model::MATERIAL, ..) => {
            let names = mesh.attributes.materials.names.len();
            let Values::U32(indices) = &a.values else { return None };
            if indices.iter().any(|&i| i as usize >= names) {
                return None;
            }
            let ty = if indices.iter().any(|&i| i > i32::MAX as u32) { "uint" } else { "int" };
            format!("property {ty} {TEXNUMBER}\n")
        }
        (domain, name, ..) => {
            let texnumber = domain == Domain::Face && name == TEXNUMBER && a.components == 1;
            let clash = match texnumber {
                true => !texnumber_stays(mesh, a),
                false => reserved(domain, name) || taken_together(mesh, domain, name),
            };
            if clash {
                return None;
            }
            match a.components {
                1 => format!("property {ty} {name}\n"),
                _ => format!("property list uchar {ty} {name}\n"),
            }
        }
    })
}

/// The set of PLY names an attribute made of a group (colour, normal, texture coordinate)
/// is written as: the first set, in the reader's order, that no other attribute of the
/// domain is named like, and before which no set is complete among the other attributes
/// (the reader would take that one). `None` when there is none.
fn written_names(
    mesh: &MeshData,
    domain: Domain,
    attribute: &str,
) -> Option<&'static [&'static str]> {
    let all = groups(domain);
    let sets = all.iter().filter(|g| g.attribute == attribute);
    for (k, group) in sets.clone().enumerate() {
        let free = group.names.iter().all(|n| mesh.attributes.get(domain, n).is_none());
        let earlier_complete = sets.clone().take(k).any(|g| complete(mesh, domain, g));
        if free && !earlier_complete {
            return Some(group.names);
        }
    }
    None
}

/// Whether the mesh has every name a group needs as a one-number attribute of a type the
/// reader takes together: written as is, they would read back as the group's attribute.
fn complete(mesh: &MeshData, domain: Domain, group: &Group) -> bool {
    group.names[..group.needed].iter().all(|n| {
        mesh.attributes
            .get(domain, n)
            .is_some_and(|a| a.components == 1 && (group.takes)(a.values.number_type()))
    })
}

/// Whether a reader would take a property of this name into another attribute: it belongs
/// to a set a reader would take as one (when the mesh has no such attribute yet).
fn taken_together(mesh: &MeshData, domain: Domain, name: &str) -> bool {
    groups(domain).iter().any(|group| {
        group.names.contains(&name)
            && mesh.attributes.get(domain, group.attribute).is_none()
            && complete(mesh, domain, group)
    })
}

/// Whether a plain `texnumber` reads back as itself: not when a reader would take it for
/// the material index of the names or textures written with it.
fn texnumber_stays(mesh: &MeshData, a: &Attribute) -> bool {
    let m = &mesh.attributes.materials;
    if mesh.attributes.get(Domain::Face, model::MATERIAL).is_some() {
        return false;
    }
    let count = if m.names.is_empty() { m.textures.len() } else { m.names.len() };
    let integer = !matches!(a.values.number_type(), NumberType::F32 | NumberType::F64);
    let indexes = (0..a.values.len()).all(|i| (0.0..count as f64).contains(&a.values.get(i)));
    !(integer && count > 0 && indexes)
}

/// What PLY cannot hold of the mesh, one line each.
pub(crate) fn unsupported(mesh: &MeshData) -> Vec<String> {
    let mut lines = Vec::new();
    for a in mesh.attributes.iter() {
        if properties(mesh, a).is_none() {
            lines.push(crate::holds::describe(a));
        }
    }
    let m = &mesh.attributes.materials;
    let padded = |s: &String| s.trim_ascii() != s;
    if [&m.names, &m.textures, &m.libraries].into_iter().flatten().any(padded) {
        lines.push("names with spaces at their ends".into());
    }
    lines
}

fn ply_type(ty: NumberType) -> &'static str {
    match ty {
        NumberType::U8 => "uchar",
        NumberType::I32 => "int",
        NumberType::U32 => "uint",
        NumberType::F32 => "float",
        NumberType::F64 => "double",
    }
}

/// The fields of a domain's records and their header lines (faces: with the corners').
fn fields(mesh: &MeshData, domain: Domain) -> (Vec<Field<'_>>, String) {
    let mut fields = Vec::new();
    let mut header = String::new();
    for a in mesh.attributes.iter().filter(|a| a.domain == domain) {
        if let Some(lines) = properties(mesh, a) {
            let list = lines.starts_with("property list");
            header.push_str(&lines);
            fields.push(Field { values: &a.values, per: usize::from(a.components), list });
        }
    }
    if domain == Domain::Face
        && let Some(a) = mesh.attributes.get(Domain::Corner, model::TEXCOORD)
    {
        header.push_str(&format!("property list uchar float {CORNER_TEXCOORD}\n"));
        fields.push(Field { values: &a.values, per: 6, list: true });
    }
    (fields, header)
}

/// Writes `count` records: `first` (coordinates or corners), then each field.
fn write_records(
    out: &mut dyn Write,
    encoding: PlyEncoding,
    count: usize,
    fields: &[Field<'_>],
    first: impl Fn(&mut Vec<u8>, usize),
) -> io::Result<()> {
    const BATCH: usize = 4096;
    let mut buffer = Vec::with_capacity(BATCH * 64);
    for start in (0..count).step_by(BATCH) {
        buffer.clear();
        for e in start..(start + BATCH).min(count) {
            first(&mut buffer, e);
            for field in fields {
                if field.list {
                    put_count(&mut buffer, field.per, encoding);
                }
                for k in 0..field.per {
                    put_value(&mut buffer, field.values, e * field.per + k, encoding);
                }
            }
            if encoding == PlyEncoding::Ascii {
                buffer.pop();
                buffer.push(b'\n');
            }
        }
        out.write_all(&buffer)?;
    }
    Ok(())
}

fn put_count(buffer: &mut Vec<u8>, n: usize, encoding: PlyEncoding) {
    match encoding {
        PlyEncoding::Ascii => {
            let _ = write!(buffer, "{n} ");
        }
        _ => buffer.push(n as u8),
    }
}

fn put_f32s(buffer: &mut Vec<u8>, values: &[f32], encoding: PlyEncoding) {
    for &v in values {
        match encoding {
            PlyEncoding::Ascii => {
                let _ = text::write_f32(buffer, v);
                buffer.push(b' ');
            }
            PlyEncoding::BinaryLittleEndian => buffer.extend_from_slice(&v.to_le_bytes()),
            PlyEncoding::BinaryBigEndian => buffer.extend_from_slice(&v.to_be_bytes()),
        }
    }
}

fn put_corners(buffer: &mut Vec<u8>, corners: &[u32], encoding: PlyEncoding) {
    put_count(buffer, 3, encoding);
    for &c in corners {
        match encoding {
            PlyEncoding::Ascii => {
                let _ = write!(buffer, "{c} ");
            }
            PlyEncoding::BinaryLittleEndian => buffer.extend_from_slice(&c.to_le_bytes()),
            PlyEncoding::BinaryBigEndian => buffer.extend_from_slice(&c.to_be_bytes()),
        }
    }
}

/// Number `i` of `values` in its own type; in ascii followed by a space.
fn put_value(buffer: &mut Vec<u8>, values: &Values, i: usize, encoding: PlyEncoding) {
    macro_rules! bytes {
        ($x:expr) => {
            match encoding {
                PlyEncoding::BinaryBigEndian => buffer.extend_from_slice(&$x.to_be_bytes()),
                _ => buffer.extend_from_slice(&$x.to_le_bytes()),
            }
        };
    }
    if encoding == PlyEncoding::Ascii {
        let _ = match values {
            Values::U8(v) => write!(buffer, "{}", v[i]),
            Values::I32(v) => write!(buffer, "{}", v[i]),
            Values::U32(v) => write!(buffer, "{}", v[i]),
            Values::F32(v) => text::write_f32(buffer, v[i]),
            Values::F64(v) => text::write_f64(buffer, v[i]),
        };
        buffer.push(b' ');
        return;
    }
    match values {
        Values::U8(v) => buffer.push(v[i]),
        Values::I32(v) => bytes!(v[i]),
        Values::U32(v) => bytes!(v[i]),
        Values::F32(v) => bytes!(v[i]),
        Values::F64(v) => bytes!(v[i]),
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
