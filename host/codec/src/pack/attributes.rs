//! The attributes section of a packed mesh: every attribute in canonical order, then the
//! materials.
//!
//! ```text
//! varint attribute count
//! per attribute: domain u8 (vertex, face, corner), number type u8 (u8 i32 u32 f32 f64),
//!                components u8, name length u8 and bytes, predictor u8, decorrelation
//!                mask u8, varint stream length, the values' coded stream (`values.rs`)
//! material names, libraries, textures: each a varint count of (varint length, bytes)
//! ```
//!
//! A mesh without attributes has an empty section. Decoding bounds every allocation by the
//! bytes that carry it: an attribute's numbers by its stream's length, a string by what is
//! left; the decoded attributes are checked ([`Attributes::check`]) before the mesh's hash.

use meshflow_mesh::attributes::{
    Attribute, Attributes, Domain, MAX_ATTRIBUTES, MAX_MATERIALS, MAX_NAME_BYTES, Materials,
    NumberType, Values,
};

use super::values::{self, Geometry, Predictor};
use super::{ELEMENT_SLACK, ELEMENTS_PER_BYTE, PackError};
use crate::correction::coding::bytes::{ByteReader, put_varint};
use crate::correction::coding::numbers::{MAX_COMPONENTS, Number};
use crate::correction::coding::stream::{SymbolReader, SymbolWriter};

const DOMAINS: [Domain; 3] = [Domain::Vertex, Domain::Face, Domain::Corner];

/// The section for `attributes` of the mesh `geometry` describes (empty without any).
pub(super) fn write(attributes: &Attributes, geometry: &Geometry) -> Vec<u8> {
    let mut out = Vec::new();
    if attributes.is_empty() {
        return out;
    }
    put_varint(&mut out, attributes.len() as u64);
    for a in attributes.iter() {
        let ty = a.values.number_type();
        let domain = DOMAINS.iter().position(|&d| d == a.domain).expect("every domain");
        let ty_index = NumberType::ALL.iter().position(|&t| t == ty).expect("every type");
        out.extend([domain as u8, ty_index as u8, a.components, a.name.len() as u8]);
        out.extend_from_slice(a.name.as_bytes());
        let (choice, stream) = code(a, geometry);
        out.extend([choice.0 as u8, choice.1]);
        put_varint(&mut out, stream.len() as u64);
        out.extend_from_slice(&stream);
    }
    let m = &attributes.materials;
    for list in [&m.names, &m.libraries, &m.textures] {
        put_varint(&mut out, list.len() as u64);
        for s in list {
            put_varint(&mut out, s.len() as u64);
            out.extend_from_slice(s.as_bytes());
        }
    }
    out
}

/// The predictor chosen for `a` and its values' coded stream.
fn code(a: &Attribute, geometry: &Geometry) -> ((Predictor, u8), Vec<u8>) {
    fn with<T: Number>(
        geometry: &Geometry,
        a: &Attribute,
        float: bool,
        values: &[T],
    ) -> ((Predictor, u8), Vec<u8>) {
        let n = usize::from(a.components);
        let choice = values::choose(geometry, a.domain, n, float, values);
        let mut w = SymbolWriter::new();
        values::write(&mut w, geometry, a.domain, n, choice, values);
        (choice, w.finish())
    }
    match &a.values {
        Values::U8(v) => with(geometry, a, false, v),
        Values::I32(v) => with(geometry, a, false, v),
        Values::U32(v) => with(geometry, a, false, v),
        Values::F32(v) => with(geometry, a, true, v),
        Values::F64(v) => with(geometry, a, true, v),
    }
}

/// Reads the section [`write`] wrote for the mesh `geometry` describes.
pub(super) fn read(bytes: &[u8], geometry: &Geometry) -> Result<Attributes, PackError> {
    let mut attributes = Attributes::default();
    if bytes.is_empty() {
        return Ok(attributes);
    }
    let malformed = |what: String| PackError::Malformed(format!("attributes: {what}"));
    let mut r = ByteReader::new(bytes);
    let count = r.varint()?;
    if count > MAX_ATTRIBUTES as u64 {
        return Err(malformed(format!("{count} attributes")));
    }
    let vertices = geometry.count(Domain::Vertex);
    let triangles = geometry.count(Domain::Face);
    let mut last: Option<(Domain, String)> = None;
    for _ in 0..count {
        let [domain, ty, components, name_len] = r.array()?;
        let domain = *DOMAINS
            .get(usize::from(domain))
            .ok_or_else(|| malformed(format!("domain {domain}")))?;
        let ty = *NumberType::ALL
            .get(usize::from(ty))
            .ok_or_else(|| malformed(format!("number type {ty}")))?;
        if !(1..=MAX_COMPONENTS as u8).contains(&components)
            || usize::from(name_len) > MAX_NAME_BYTES
        {
            return Err(malformed(format!("{components} components, a {name_len}-byte name")));
        }
        let name = String::from_utf8(r.take(usize::from(name_len))?.to_vec())
            .map_err(|_| malformed("a name that is not UTF-8".into()))?;
        if last.as_ref().is_some_and(|l| (l.0, &l.1) >= (domain, &name)) {
            return Err(malformed("out of canonical order or repeated".into()));
        }
        let [predictor, decorrelate] = r.array()?;
        let n = usize::from(components);
        let float = matches!(ty, NumberType::F32 | NumberType::F64);
        let predictor = Predictor::from_byte(predictor)
            .filter(|p| p.fits(domain, n, float))
            .ok_or_else(|| malformed(format!("predictor {predictor} for {name}")))?;
        let length = usize::try_from(r.varint()?).map_err(|_| PackError::Truncated)?;
        let stream = r.take(length)?;
        let numbers = (geometry.count(domain) * n) as u64;
        if numbers > ELEMENTS_PER_BYTE * length as u64 + ELEMENT_SLACK {
            return Err(malformed(format!("{numbers} numbers of {name} in {length} bytes")));
        }
        let mut input = SymbolReader::new(stream).map_err(|_| PackError::Corrupt("attribute"))?;
        let args = (geometry, domain, n, (predictor, decorrelate));
        let values = match ty {
            NumberType::U8 => typed(&mut input, args, Values::U8),
            NumberType::I32 => typed(&mut input, args, Values::I32),
            NumberType::U32 => typed(&mut input, args, Values::U32),
            NumberType::F32 => typed(&mut input, args, Values::F32),
            NumberType::F64 => typed(&mut input, args, Values::F64),
        }?;
        let attribute = Attribute { domain, name: name.clone(), components, values };
        attributes.insert(attribute, vertices, triangles).map_err(|e| malformed(e.to_string()))?;
        last = Some((domain, name));
    }
    let mut lists: [Vec<String>; 3] = Default::default();
    for list in &mut lists {
        let count = r.varint()?;
        if count > MAX_MATERIALS as u64 {
            return Err(malformed(format!("{count} material names")));
        }
        for _ in 0..count {
            let length = usize::try_from(r.varint()?).map_err(|_| PackError::Truncated)?;
            let text = String::from_utf8(r.take(length)?.to_vec())
                .map_err(|_| malformed("a material name that is not UTF-8".into()))?;
            list.push(text);
        }
    }
    let [names, libraries, textures] = lists;
    attributes.materials = Materials { names, libraries, textures };
    if r.remaining() != 0 {
        return Err(malformed(format!("{} bytes after the materials", r.remaining())));
    }
    attributes.check(vertices, triangles).map_err(|e| malformed(e.to_string()))?;
    Ok(attributes)
}

/// One attribute's values of type `T`, wrapped as [`Values`].
fn typed<T: Number>(
    input: &mut SymbolReader,
    (geometry, domain, components, choice): (&Geometry, Domain, usize, (Predictor, u8)),
    wrap: fn(Vec<T>) -> Values,
) -> Result<Values, PackError> {
    values::read(input, geometry, domain, components, choice)
        .map(wrap)
        .map_err(|_| PackError::Corrupt("attribute"))
}
