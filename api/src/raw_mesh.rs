//! The `raw` mesh format: a 12-byte header ([`MAGIC`], then the vertex and triangle counts as
//! u32 LE), the positions (f32 LE, three per vertex) and the triangles' corners (u32 LE),
//! then, for a mesh with attributes, their canonical bytes (see [`Section`]). No text to
//! parse, so a million vertices reach the browser's GPU in one copy; and the one format
//! whose content hash is checked without a mesh library: it is the BLAKE3 of [`HASH_TAG`]
//! followed by everything after the magic, exactly what `meshflow-mesh` hashes.

/// The first four bytes of a `raw` mesh.
pub const MAGIC: &[u8; 4] = b"MFR1";

/// Magic and the two counts; the arrays after it are 4-byte aligned.
pub const HEADER_BYTES: usize = 12;

/// What a mesh's content hash starts with, before the counts and arrays (the host's tests
/// check that this is `meshflow-mesh`'s tag).
pub const HASH_TAG: &[u8] = b"meshflow-mesh-v1";

/// Why bytes are not a `raw` mesh.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum RawMeshError {
    #[error("not a raw mesh: it does not start with {MAGIC:?}")]
    NotRaw,
    #[error(
        "a raw mesh of {vertices} vertices and {triangles} triangles has {expected} bytes, not {actual}"
    )]
    Length { vertices: u32, triangles: u32, expected: u64, actual: u64 },
    #[error("the raw mesh's attributes are malformed: {0}")]
    Attributes(String),
}

/// What the canonical attribute bytes start with (`meshflow-mesh`'s tag).
pub const ATTRIBUTES_TAG: &[u8] = b"attributes-v1";
/// Limits of the attribute section, as `meshflow-mesh` holds them.
const MAX_ATTRIBUTES: u32 = 32;
const MAX_NAME_BYTES: u32 = 64;
const MAX_MATERIALS: u32 = 1024;
const MAX_MATERIAL_NAME_BYTES: u32 = 256;

/// Where an attribute lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Domain {
    Vertex,
    Face,
    Corner,
}

/// One attribute of a raw mesh: its shape, and where its numbers lie in the bytes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawAttribute {
    pub domain: Domain,
    /// `u8`, `i32`, `u32`, `f32` or `f64`.
    pub number_type: &'static str,
    pub components: u8,
    pub name: String,
    /// Byte offset of the first number from the start of the raw mesh.
    pub offset: u64,
    /// How many numbers (elements × components).
    pub numbers: u64,
}

impl RawAttribute {
    pub fn number_bytes(&self) -> u64 {
        if self.number_type == "u8" {
            1
        } else if self.number_type == "f64" {
            8
        } else {
            4
        }
    }
}

/// The attribute section of a raw mesh, read without its numbers.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Section {
    pub attributes: Vec<RawAttribute>,
    pub materials: Vec<String>,
    pub libraries: Vec<String>,
    pub textures: Vec<String>,
}

/// Bytes of a raw mesh's header and arrays, before any attribute section.
pub fn arrays_end(vertices: u32, triangles: u32) -> u64 {
    HEADER_BYTES as u64 + 12 * u64::from(vertices) + 12 * u64::from(triangles)
}

/// Reads the attribute section that starts at byte `start` of a raw mesh of `vertices` and
/// `triangles` from `input` (positioned there), skipping the numbers; it must end exactly
/// at `end`. Every count is checked against what the mesh can have before it is believed.
pub fn read_section<R: std::io::Read>(
    input: &mut R,
    start: u64,
    end: u64,
    vertices: u32,
    triangles: u32,
) -> Result<Section, RawMeshError> {
    let mut r = SectionReader { input, at: start, end };
    if r.bytes(ATTRIBUTES_TAG.len() as u64)? != ATTRIBUTES_TAG {
        return Err(bad("it does not start with the attributes tag"));
    }
    let count = r.u32()?;
    if count > MAX_ATTRIBUTES {
        return Err(bad(format!("{count} attributes; at most {MAX_ATTRIBUTES}")));
    }
    let mut section = Section::default();
    for _ in 0..count {
        let shape = r.bytes(3)?;
        let domain = match shape[0] {
            0 => Domain::Vertex,
            1 => Domain::Face,
            2 => Domain::Corner,
            d => return Err(bad(format!("domain {d}"))),
        };
        let number_type = match shape[1] {
            0 => "u8",
            1 => "i32",
            2 => "u32",
            3 => "f32",
            4 => "f64",
            t => return Err(bad(format!("number type {t}"))),
        };
        let components = shape[2];
        if !(1..=4).contains(&components) {
            return Err(bad(format!("{components} components")));
        }
        let name = r.string(MAX_NAME_BYTES)?;
        if name.is_empty() {
            return Err(bad("an attribute without a name"));
        }
        let numbers = u64::from_le_bytes(r.bytes(8)?.try_into().expect("eight bytes"));
        let elements = match domain {
            Domain::Vertex => u64::from(vertices),
            Domain::Face => u64::from(triangles),
            Domain::Corner => 3 * u64::from(triangles),
        };
        if numbers != elements * u64::from(components) {
            return Err(bad(format!("{name} has {numbers} numbers for {elements} elements")));
        }
        let attribute =
            RawAttribute { domain, number_type, components, name, offset: r.at, numbers };
        r.skip(numbers * attribute.number_bytes())?;
        section.attributes.push(attribute);
    }
    for list in [&mut section.materials, &mut section.libraries, &mut section.textures] {
        let count = r.u32()?;
        if count > MAX_MATERIALS {
            return Err(bad(format!("{count} material names; at most {MAX_MATERIALS}")));
        }
        for _ in 0..count {
            list.push(r.string(MAX_MATERIAL_NAME_BYTES)?);
        }
    }
    if r.at != r.end {
        return Err(bad(format!("{} bytes after the section", r.end - r.at)));
    }
    Ok(section)
}

fn bad(what: impl Into<String>) -> RawMeshError {
    RawMeshError::Attributes(what.into())
}

/// Reads a section, never past its end.
struct SectionReader<'a, R> {
    input: &'a mut R,
    at: u64,
    end: u64,
}

impl<R: std::io::Read> SectionReader<'_, R> {
    fn room(&mut self, n: u64) -> Result<(), RawMeshError> {
        if self.at + n > self.end {
            return Err(bad("it is cut short"));
        }
        self.at += n;
        Ok(())
    }

    fn bytes(&mut self, n: u64) -> Result<Vec<u8>, RawMeshError> {
        self.room(n)?;
        let mut bytes = vec![0; n as usize];
        self.input.read_exact(&mut bytes).map_err(|e| bad(e.to_string()))?;
        Ok(bytes)
    }

    fn u32(&mut self) -> Result<u32, RawMeshError> {
        Ok(u32::from_le_bytes(self.bytes(4)?.try_into().expect("four bytes")))
    }

    fn string(&mut self, limit: u32) -> Result<String, RawMeshError> {
        let length = self.u32()?;
        if length > limit {
            return Err(bad(format!("a name of {length} bytes; at most {limit}")));
        }
        String::from_utf8(self.bytes(u64::from(length))?).map_err(|_| bad("a name is not UTF-8"))
    }

    fn skip(&mut self, n: u64) -> Result<(), RawMeshError> {
        self.room(n)?;
        let mut limited = <&mut R as std::io::Read>::take(&mut *self.input, n);
        let skipped =
            std::io::copy(&mut limited, &mut std::io::sink()).map_err(|e| bad(e.to_string()))?;
        if skipped != n {
            return Err(bad("it is cut short"));
        }
        Ok(())
    }
}

/// The counts a `raw` mesh's header gives, checked against its length and, when it has
/// attributes, against their section.
pub fn counts(raw: &[u8]) -> Result<(u32, u32), RawMeshError> {
    let (vertices, triangles) = header_counts(raw)?;
    // In u64: no count in a header can overflow it.
    let expected = arrays_end(vertices, triangles);
    let actual = raw.len() as u64;
    if actual < expected
        || (actual > expected && !raw[expected as usize..].starts_with(ATTRIBUTES_TAG))
    {
        return Err(RawMeshError::Length { vertices, triangles, expected, actual });
    }
    if actual > expected {
        read_section(&mut &raw[expected as usize..], expected, actual, vertices, triangles)?;
    }
    Ok((vertices, triangles))
}

/// The counts in a raw mesh's header (its first [`HEADER_BYTES`]), unchecked.
pub fn header_counts(header: &[u8]) -> Result<(u32, u32), RawMeshError> {
    if header.len() < HEADER_BYTES || &header[..4] != MAGIC {
        return Err(RawMeshError::NotRaw);
    }
    let word = |at: usize| u32::from_le_bytes(header[at..at + 4].try_into().expect("four bytes"));
    Ok((word(4), word(8)))
}

/// The content hash (hex) of the mesh a `raw` mesh holds.
pub fn content_hash(raw: &[u8]) -> Result<String, RawMeshError> {
    counts(raw)?;
    let mut hasher = blake3::Hasher::new();
    hasher.update(HASH_TAG).update(&raw[MAGIC.len()..]);
    Ok(hasher.finalize().to_hex().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_triangle() -> Vec<u8> {
        let mut raw = MAGIC.to_vec();
        raw.extend(3u32.to_le_bytes());
        raw.extend(1u32.to_le_bytes());
        raw.extend([0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()));
        raw.extend([0u32, 1, 2].iter().flat_map(|v| v.to_le_bytes()));
        raw
    }

    #[test]
    fn a_raw_mesh_hashes_its_tag_counts_and_arrays() {
        let raw = one_triangle();
        assert_eq!(counts(&raw), Ok((3, 1)));
        let mut expected = blake3::Hasher::new();
        expected.update(HASH_TAG).update(&raw[4..]);
        assert_eq!(content_hash(&raw).unwrap(), expected.finalize().to_hex().to_string());
    }

    #[test]
    fn cut_padded_or_foreign_bytes_are_refused() {
        let raw = one_triangle();
        assert_eq!(
            content_hash(&raw[..raw.len() - 1]).unwrap_err(),
            RawMeshError::Length { vertices: 3, triangles: 1, expected: 60, actual: 59 }
        );
        let mut padded = raw.clone();
        padded.push(0);
        assert!(matches!(counts(&padded), Err(RawMeshError::Length { .. })));
        assert_eq!(counts(b"ply\nformat binary"), Err(RawMeshError::NotRaw));
        assert_eq!(counts(b"MFR"), Err(RawMeshError::NotRaw));
        let mut huge = raw;
        huge[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(counts(&huge), Err(RawMeshError::Length { .. })));
    }

    /// One triangle with a per-vertex quality: the section as `meshflow-mesh` writes it.
    fn with_quality() -> Vec<u8> {
        let mut raw = one_triangle();
        raw.extend(ATTRIBUTES_TAG);
        raw.extend(1u32.to_le_bytes());
        raw.extend([0, 3, 1]);
        raw.extend(7u32.to_le_bytes());
        raw.extend(b"quality");
        raw.extend(3u64.to_le_bytes());
        raw.extend([0.5f32, 1.0, 2.0].iter().flat_map(|v| v.to_le_bytes()));
        for _ in 0..3 {
            raw.extend(0u32.to_le_bytes());
        }
        raw
    }

    #[test]
    fn an_attribute_section_is_read_and_checked_against_the_mesh() {
        let raw = with_quality();
        assert_eq!(counts(&raw), Ok((3, 1)));
        let section = read_section(&mut &raw[60..], 60, raw.len() as u64, 3, 1).unwrap();
        assert_eq!(section.attributes.len(), 1);
        let quality = &section.attributes[0];
        assert_eq!(
            (quality.name.as_str(), quality.number_type, quality.numbers),
            ("quality", "f32", 3)
        );
        assert_eq!(
            &raw[quality.offset as usize..quality.offset as usize + 4],
            0.5f32.to_le_bytes()
        );

        // A section that claims a value per vertex of a mesh it does not fit, or runs on.
        assert!(matches!(counts(&raw[..raw.len() - 1]), Err(RawMeshError::Attributes(_))));
        let mut longer = raw.clone();
        longer.push(0);
        assert!(matches!(counts(&longer), Err(RawMeshError::Attributes(_))));
        let mut lying = raw;
        lying[60 + 13 + 4 + 3 + 4 + 7] = 4;
        assert!(matches!(counts(&lying), Err(RawMeshError::Attributes(_))));
    }
}
