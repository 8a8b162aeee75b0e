//! The `raw` mesh format: a 12-byte header ([`MAGIC`], then the vertex and triangle counts as
//! u32 LE), the positions (f32 LE, three per vertex) and the triangles' corners (u32 LE).
//! No text to parse, so a million vertices reach the browser's GPU in one copy; and the one
//! format whose content hash is checked without a mesh library: it is the BLAKE3 of
//! [`HASH_TAG`] followed by everything after the magic, exactly what `meshflow-mesh` hashes.

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
}

/// The counts a `raw` mesh's header gives, checked against its length.
pub fn counts(raw: &[u8]) -> Result<(u32, u32), RawMeshError> {
    if raw.len() < HEADER_BYTES || &raw[..4] != MAGIC {
        return Err(RawMeshError::NotRaw);
    }
    let word = |at: usize| u32::from_le_bytes(raw[at..at + 4].try_into().expect("four bytes"));
    let (vertices, triangles) = (word(4), word(8));
    // In u64: no count in a header can overflow it.
    let expected = HEADER_BYTES as u64 + 12 * u64::from(vertices) + 12 * u64::from(triangles);
    let actual = raw.len() as u64;
    if expected != actual {
        return Err(RawMeshError::Length { vertices, triangles, expected, actual });
    }
    Ok((vertices, triangles))
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
}
