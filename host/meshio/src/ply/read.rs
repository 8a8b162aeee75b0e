//! Reading a PLY body into a mesh: the `vertex` element's x/y/z, the `face` element's index
//! lists, and the attributes [`plan`](super::plan) found in both; other elements are
//! skipped, and named in the [`Dropped`] report.

use super::super::build::{
    capacity, check_arity, check_corner, check_finite, check_vertex_count, push_fan,
};
use super::super::error::{Invalid, Position, ReadResult};
use super::header::{self, Element, Encoding, Header, Kind, Scalar};
use super::plan::{self, Column, Plan, Role};
use super::source::{Ascii, BigEndian, Binary, LittleEndian, Source, truncated};
use crate::dropped::{Dropped, Loaded};
use meshflow_mesh::MeshData;

/// Decodes a PLY file of any encoding.
pub(crate) fn read(bytes: &[u8]) -> ReadResult<Loaded> {
    let header = header::parse(bytes)?;
    let body = &bytes[header.body_offset..];
    check_sizes(&header, body.len())?;
    let layout = Layout::new(&header)?;
    let mut dropped = Dropped::default();
    let axes = header.elements.iter().any(|e| e.name == "vertex").then_some(layout.axes);
    let mut plan = plan::plan(&header, axes, layout.corners, &mut dropped);
    let mut mesh = Body::default();
    match header.encoding {
        Encoding::Ascii => read_body(
            &header,
            &layout,
            &mut plan,
            Ascii::new(body, header.body_line),
            &mut mesh,
            &mut dropped,
        ),
        Encoding::BinaryLittleEndian => read_body(
            &header,
            &layout,
            &mut plan,
            Binary::<LittleEndian>::new(body, header.body_offset),
            &mut mesh,
            &mut dropped,
        ),
        Encoding::BinaryBigEndian => read_body(
            &header,
            &layout,
            &mut plan,
            Binary::<BigEndian>::new(body, header.body_offset),
            &mut mesh,
            &mut dropped,
        ),
    }?;
    let mut data = MeshData::new(mesh.positions, mesh.triangles);
    let (vertices, triangles) = (data.vertex_count(), data.triangle_count());
    data.attributes = plan.assemble(vertices, triangles, &mesh.corners, &mut dropped);
    Ok(Loaded { mesh: data, dropped })
}

/// What the body reader fills.
#[derive(Default)]
struct Body {
    positions: Vec<f32>,
    triangles: Vec<u32>,
    /// Each face's corner count, when face values are kept (they are per polygon).
    corners: Vec<u32>,
}

/// Rejects headers whose counts the body cannot hold, before anything is allocated from
/// them: a 20-byte file claiming 4 billion vertices fails here, at once.
fn check_sizes(header: &Header, available: usize) -> ReadResult<()> {
    // Ascii: the last value of the file may lack its separator.
    let slack = u128::from(header.encoding == Encoding::Ascii);
    let mut needed: u128 = 0;
    for element in &header.elements {
        needed += u128::from(element.count) * element.min_size(header.encoding) as u128;
        if needed > available as u128 + slack {
            let reason = format!(
                "the header declares {} '{}' elements, but the {available} bytes after the header \
                 cannot hold them (truncated or corrupt file)",
                element.count, element.name
            );
            return Err(Invalid::line(element.line, reason));
        }
    }
    Ok(())
}

/// Which elements and properties carry the mesh.
struct Layout {
    vertex_count: u64,
    /// Property indices of x, y, z in the vertex element.
    axes: [usize; 3],
    /// Property index of the corner list in the face element.
    corners: Option<usize>,
}

impl Layout {
    fn new(header: &Header) -> ReadResult<Layout> {
        let mut layout = Layout { vertex_count: 0, axes: [0; 3], corners: None };
        if let Some(vertex) = header.elements.iter().find(|e| e.name == "vertex") {
            let at = Position::Line(vertex.line);
            check_vertex_count(vertex.count, at)?;
            layout.vertex_count = vertex.count;
            for (axis, name) in layout.axes.iter_mut().zip(["x", "y", "z"]) {
                *axis = vertex
                    .property(name)
                    .filter(|&p| matches!(vertex.properties[p].kind, Kind::Scalar(_)))
                    .ok_or_else(|| {
                        Invalid::at(
                            at,
                            format!("the vertex element has no scalar '{name}' property"),
                        )
                    })?;
            }
        }
        if let Some(face) = header.elements.iter().find(|e| e.name == "face") {
            let list = face.property("vertex_indices").or_else(|| face.property("vertex_index"));
            layout.corners = match list.map(|p| face.properties[p].kind) {
                Some(Kind::List { item, .. }) if item.is_integer() => list,
                // A face element without corners only matters if it has faces.
                None if face.count == 0 => None,
                _ => {
                    let reason =
                        "the face element has no integer list 'vertex_indices' or 'vertex_index'";
                    return Err(Invalid::line(face.line, reason));
                }
            };
        }
        Ok(layout)
    }
}

fn read_body<S: Source>(
    header: &Header,
    layout: &Layout,
    plan: &mut Plan,
    mut source: S,
    body: &mut Body,
    dropped: &mut Dropped,
) -> ReadResult<()> {
    let record_corners = plan.face_columns();
    for element in &header.elements {
        match (element.name.as_str(), layout.corners) {
            ("vertex", _) => read_vertices(
                &mut source,
                element,
                &plan.vertex_roles,
                &mut plan.columns,
                &mut body.positions,
                dropped,
            )?,
            ("face", Some(_)) => {
                let corners = record_corners.then_some(&mut body.corners);
                let faces = Faces { roles: &plan.face_roles, vertices: layout.vertex_count };
                faces.read(&mut source, element, &mut plan.columns, &mut body.triangles, corners)?
            }
            _ => skip_element(&mut source, element)?,
        }
    }
    // Bytes after the last element are ignored, as other readers do.
    Ok(())
}

/// Reads one property value into its column: a scalar, or a list (its length noted).
fn read_column<S: Source>(source: &mut S, kind: Kind, column: &mut Column) -> ReadResult<()> {
    match kind {
        Kind::Scalar(ty) => {
            column.values.push(source.value(ty)?);
            Ok(())
        }
        Kind::List { count, item } => {
            let n = source.integer(count)?;
            let n = usize::try_from(n)
                .map_err(|_| Invalid::at(source.last_at(), format!("negative list length {n}")))?;
            if column.record(n) {
                (0..n).try_for_each(|_| source.value(item).map(|x| column.values.push(x)))
            } else {
                source.skip_items(item, n)
            }
        }
    }
}

fn read_vertices<S: Source>(
    source: &mut S,
    element: &Element,
    roles: &[Role],
    columns: &mut [Column],
    positions: &mut Vec<f32>,
    dropped: &mut Dropped,
) -> ReadResult<()> {
    // `check_sizes` bounded the count by the file size, so these reservations are safe.
    positions.reserve(element.count as usize * 3);
    for role in roles {
        if let Role::Column(c) = *role {
            columns[c].values.reserve(element.count as usize);
        }
    }
    let mut axes = [0; 3];
    for (p, role) in roles.iter().enumerate() {
        if let Role::Axis(k) = *role {
            axes[k] = p;
        }
    }
    if let Some(size) = element.fixed_size()
        && let Some((data, offset)) = source.unread()
    {
        let block = fixed_block(data, offset, element.count, size)?;
        decode_fixed_vertices::<S>(element, axes, size, block, offset, positions, dropped)?;
        decode_fixed_columns::<S>(element, roles, columns, size, block);
        source.consume(block.len());
        return Ok(());
    }
    for vertex in 0..element.count as usize {
        let mut p = [0.0f32; 3];
        for (property, role) in element.properties.iter().zip(roles) {
            let value = match (*role, property.kind) {
                (Role::Axis(axis), Kind::Scalar(Scalar::F64)) => {
                    source.double_coordinate().map(|(exact, rounded)| {
                        dropped.rounded(exact, rounded);
                        p[axis] = rounded;
                    })
                }
                (Role::Axis(axis), Kind::Scalar(ty)) => source.coordinate(ty).map(|c| p[axis] = c),
                (Role::Column(c), kind) => read_column(source, kind, &mut columns[c]),
                _ => source.skip(property.kind),
            };
            value.map_err(|e| e.context(format_args!("vertex {vertex}")))?;
        }
        check_finite(vertex, p, source.last_at())?;
        positions.extend_from_slice(&p);
    }
    Ok(())
}

/// The attribute columns of fixed-size binary records, one column at a time.
fn decode_fixed_columns<S: Source>(
    element: &Element,
    roles: &[Role],
    columns: &mut [Column],
    size: usize,
    block: &[u8],
) {
    let mut start = 0;
    for (property, role) in element.properties.iter().zip(roles) {
        let Kind::Scalar(ty) = property.kind else { unreachable!("fixed records hold scalars") };
        if let Role::Column(c) = *role {
            let values = &mut columns[c].values;
            for record in block.chunks_exact(size) {
                values.push(S::decode_value(ty, &record[start..]));
            }
        }
        start += ty.size();
    }
}

/// The first `count` records of `size` bytes of a binary body, or the truncation error.
fn fixed_block(data: &[u8], offset: usize, count: u64, size: usize) -> ReadResult<&[u8]> {
    let len = usize::try_from(count).unwrap_or(usize::MAX).saturating_mul(size);
    data.get(..len).ok_or_else(|| truncated(offset, len, data.len()))
}

/// The fast path for binary vertex records of one fixed layout: no per-value calls.
fn decode_fixed_vertices<S: Source>(
    element: &Element,
    axes: [usize; 3],
    size: usize,
    block: &[u8],
    offset: usize,
    positions: &mut Vec<f32>,
    dropped: &mut Dropped,
) -> ReadResult<()> {
    let field = |axis: usize| {
        let start = element.properties[..axis].iter().map(|p| scalar_size(p.kind)).sum::<usize>();
        match element.properties[axis].kind {
            Kind::Scalar(ty) => (start, ty),
            Kind::List { .. } => unreachable!("Layout keeps only scalar axes"),
        }
    };
    let [(ox, tx), (oy, ty), (oz, tz)] = axes.map(field);
    let first = positions.len();
    for (vertex, record) in block.chunks_exact(size).enumerate() {
        let p = [
            S::decode_f32(tx, &record[ox..]),
            S::decode_f32(ty, &record[oy..]),
            S::decode_f32(tz, &record[oz..]),
        ];
        check_finite(vertex, p, Position::Byte((offset + vertex * size) as u64))?;
        positions.extend_from_slice(&p);
    }
    // Doubles: a second pass for the largest rounding, so the common float files pay nothing.
    for (k, (ty, start)) in [(tx, ox), (ty, oy), (tz, oz)].into_iter().enumerate() {
        if ty != Scalar::F64 {
            continue;
        }
        let rounded = positions[first..].iter().skip(k).step_by(3);
        for (record, &rounded) in block.chunks_exact(size).zip(rounded) {
            dropped.rounded(S::decode_f64(&record[start..]), rounded);
        }
    }
    Ok(())
}

fn scalar_size(kind: Kind) -> usize {
    match kind {
        Kind::Scalar(ty) => ty.size(),
        Kind::List { .. } => 0,
    }
}

/// How face records are read: each property's role, and the vertex count corners are
/// checked against.
struct Faces<'a> {
    roles: &'a [Role],
    vertices: u64,
}

impl Faces<'_> {
    fn read<S: Source>(
        &self,
        source: &mut S,
        element: &Element,
        columns: &mut [Column],
        triangles: &mut Vec<u32>,
        mut corner_counts: Option<&mut Vec<u32>>,
    ) -> ReadResult<()> {
        let list = self.roles.iter().position(|r| *r == Role::Corners).expect("a corner list");
        let vertices = self.vertices;
        let Kind::List { count: count_type, item } = element.properties[list].kind else {
            unreachable!("Layout keeps only list corners")
        };
        // Most faces are triangles; the cap keeps a lying count from reserving beyond the file.
        let triangle_bytes = element.min_size(Encoding::BinaryLittleEndian) + 3 * item.size();
        let faces = capacity(element.count, source.remaining(), triangle_bytes);
        triangles.reserve(faces * 3);
        if element.properties.len() == 1
            && let Some((data, offset)) = source.unread()
        {
            let len = decode_face_lists::<S>(
                data,
                offset,
                element.count,
                [count_type, item],
                vertices,
                triangles,
            )?;
            source.consume(len);
            return Ok(());
        }
        if let Some(counts) = corner_counts.as_deref_mut() {
            counts.reserve(faces);
        }
        let mut corners = Vec::new();
        for face in 0..element.count as usize {
            let in_face = |e: Invalid| e.context(format_args!("face {face}"));
            for (property, role) in element.properties.iter().zip(self.roles) {
                match *role {
                    Role::Corners => {
                        let n = source.integer(count_type).map_err(in_face)?;
                        check_arity(face, n, source.last_at())?;
                        corners.clear();
                        for _ in 0..n {
                            let corner = source.integer(item).map_err(in_face)?;
                            corners.push(check_corner(face, corner, vertices, source.last_at())?);
                        }
                        push_fan(triangles, &corners);
                    }
                    Role::Column(c) => {
                        read_column(source, property.kind, &mut columns[c]).map_err(in_face)?
                    }
                    _ => source.skip(property.kind).map_err(in_face)?,
                }
            }
            if let Some(counts) = corner_counts.as_deref_mut() {
                counts.push(u32::try_from(corners.len()).unwrap_or(u32::MAX));
            }
        }
        Ok(())
    }
}

/// The fast path for binary faces that hold nothing but their corner list (what nearly every
/// writer produces): decodes straight from the bytes. Returns the bytes used.
fn decode_face_lists<S: Source>(
    data: &[u8],
    offset: usize,
    count: u64,
    [count_type, item]: [Scalar; 2],
    vertices: u64,
    triangles: &mut Vec<u32>,
) -> ReadResult<usize> {
    let (count_size, item_size) = (count_type.size(), item.size());
    let at = |pos: usize| Position::Byte((offset + pos) as u64);
    let mut corners = Vec::new();
    let mut pos = 0;
    for face in 0..count as usize {
        let in_face = |e: Invalid| e.context(format_args!("face {face}"));
        let head = fixed_block(&data[pos..], offset + pos, 1, count_size).map_err(in_face)?;
        let n = S::decode_int(count_type, head);
        check_arity(face, n, at(pos))?;
        let start = pos + count_size;
        let list =
            fixed_block(&data[start..], offset + start, n as u64, item_size).map_err(in_face)?;
        corners.clear();
        for (k, raw) in list.chunks_exact(item_size).enumerate() {
            let corner = S::decode_int(item, raw);
            corners.push(check_corner(face, corner, vertices, at(start + k * item_size))?);
        }
        push_fan(triangles, &corners);
        pos = start + list.len();
    }
    Ok(pos)
}

fn skip_element<S: Source>(source: &mut S, element: &Element) -> ReadResult<()> {
    if element.properties.is_empty() {
        return Ok(());
    }
    if let Some(size) = element.fixed_size()
        && let Some((data, offset)) = source.unread()
    {
        let len = fixed_block(data, offset, element.count, size)?.len();
        source.consume(len);
        return Ok(());
    }
    for record in 0..element.count {
        for property in &element.properties {
            source
                .skip(property.kind)
                .map_err(|e| e.context(format_args!("{} {record}", element.name)))?;
        }
    }
    Ok(())
}
