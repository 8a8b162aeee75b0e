//! A compact indexed triangle set: the form a mesh has between steps, on disk and on the wire.

/// A compact mesh: every vertex and triangle id in range is live.
///
/// `positions` holds `x y z` per vertex, `triangles` holds `a b c` per triangle. Input meshes
/// may be raw scans, so triangles may be degenerate (repeated vertices), non-manifold, and
/// vertices may be unreferenced; only indices out of range are impossible. `attributes`
/// holds what else the mesh carries (colours, normals, …), one value per element.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<f32>,
    pub triangles: Vec<u32>,
    pub attributes: Attributes,
}

use crate::attributes::{AttributeError, Attributes};

/// The BLAKE3 hash of a mesh's canonical bytes: names one mesh state on every host.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ContentHash(pub [u8; 32]);

impl ContentHash {
    pub fn to_hex(&self) -> String {
        hex::encode(self.0)
    }

    /// The hash `to_hex` wrote (either case), `None` for anything else.
    pub fn from_hex(text: &str) -> Option<Self> {
        let mut bytes = [0u8; 32];
        hex::decode_to_slice(text, &mut bytes).ok().map(|()| Self(bytes))
    }
}

impl std::fmt::Display for ContentHash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.to_hex())
    }
}

impl std::fmt::Debug for ContentHash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ContentHash({})", self.to_hex())
    }
}

/// Domain separation for the canonical encoding; bump it if the encoding ever changes.
const CANONICAL_TAG: &[u8] = b"meshflow-mesh-v1";

impl MeshData {
    pub fn new(positions: Vec<f32>, triangles: Vec<u32>) -> Self {
        Self { positions, triangles, attributes: Attributes::default() }
    }

    /// The bytes its arrays take: positions, corners and attribute values.
    pub fn array_bytes(&self) -> usize {
        let attributes: usize =
            self.attributes.iter().map(|a| a.values.len() * a.values.number_type().size()).sum();
        (self.positions.len() + self.triangles.len()) * 4 + attributes
    }

    /// The mesh with `attributes`, which must fit it (see [`Attributes::check`]).
    pub fn with_attributes(mut self, attributes: Attributes) -> Result<Self, AttributeError> {
        attributes.check(self.vertex_count(), self.triangle_count())?;
        self.attributes = attributes;
        Ok(self)
    }

    pub fn vertex_count(&self) -> usize {
        self.positions.len() / 3
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len() / 3
    }

    /// The canonical content hash: BLAKE3 over the tag, both counts (u32 LE), the position
    /// bit patterns (f32 LE) and the corner indices (u32 LE), then, for a mesh that has
    /// attributes, each in canonical order (domain, type, components, name, values LE) and
    /// the materials. Bit patterns, not values, so `-0.0` and `0.0` are different states, as
    /// they are different bytes. A mesh without attributes hashes as before they existed.
    pub fn content_hash(&self) -> ContentHash {
        let mut hasher = blake3::Hasher::new();
        hasher.update(CANONICAL_TAG);
        hasher.update(&(self.vertex_count() as u32).to_le_bytes());
        hasher.update(&(self.triangle_count() as u32).to_le_bytes());
        hasher.update(as_le_bytes_f32(&self.positions).as_ref());
        hasher.update(as_le_bytes_u32(&self.triangles).as_ref());
        if !self.attributes.is_empty() {
            crate::attributes::write_canonical(&self.attributes, &mut |bytes| {
                hasher.update(bytes);
            });
        }
        ContentHash(*hasher.finalize().as_bytes())
    }

    /// Axis-aligned bounding box of all vertices, `None` for a mesh without vertices.
    pub fn bounding_box(&self) -> Option<([f32; 3], [f32; 3])> {
        let mut chunks = self.positions.chunks_exact(3);
        let first = chunks.next()?;
        let (mut lo, mut hi) = ([first[0], first[1], first[2]], [first[0], first[1], first[2]]);
        for p in chunks {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        Some((lo, hi))
    }
}

/// Little-endian bytes of an f32 slice, borrowed on little-endian machines.
pub fn as_le_bytes_f32(values: &[f32]) -> std::borrow::Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        // SAFETY: f32 has no padding and any byte is a valid u8.
        std::borrow::Cow::Borrowed(unsafe {
            std::slice::from_raw_parts(values.as_ptr().cast::<u8>(), values.len() * 4)
        })
    } else {
        std::borrow::Cow::Owned(values.iter().flat_map(|v| v.to_le_bytes()).collect())
    }
}

/// Little-endian bytes of a u32 slice, borrowed on little-endian machines.
pub fn as_le_bytes_u32(values: &[u32]) -> std::borrow::Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        // SAFETY: u32 has no padding and any byte is a valid u8.
        std::borrow::Cow::Borrowed(unsafe {
            std::slice::from_raw_parts(values.as_ptr().cast::<u8>(), values.len() * 4)
        })
    } else {
        std::borrow::Cow::Owned(values.iter().flat_map(|v| v.to_le_bytes()).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attributes::Attribute;

    #[test]
    fn hash_depends_on_every_byte_and_on_the_split_between_arrays() {
        let a = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2]);
        let mut b = a.clone();
        assert_eq!(a.content_hash(), b.content_hash());
        b.positions[4] = -0.0;
        assert_ne!(a.content_hash(), b.content_hash());
        let mut c = a.clone();
        c.triangles = vec![0, 2, 1];
        assert_ne!(a.content_hash(), c.content_hash());
    }

    #[test]
    fn hash_covers_attributes_and_an_attribute_free_mesh_hashes_as_before() {
        let a = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2]);
        // The v1 hash of this triangle, from before attributes existed.
        let mut v1 = blake3::Hasher::new();
        v1.update(CANONICAL_TAG);
        v1.update(&3u32.to_le_bytes());
        v1.update(&1u32.to_le_bytes());
        v1.update(&as_le_bytes_f32(&a.positions));
        v1.update(&as_le_bytes_u32(&a.triangles));
        assert_eq!(a.content_hash().0, *v1.finalize().as_bytes());

        let mut red = a.clone();
        red.attributes.insert(Attribute::color([255, 0, 0, 255].repeat(3)), 3, 1).unwrap();
        let mut redder = red.clone();
        redder
            .attributes
            .insert(
                Attribute::color([[254, 0, 0, 255].to_vec(), [255, 0, 0, 255].repeat(2)].concat()),
                3,
                1,
            )
            .unwrap();
        assert_ne!(a.content_hash(), red.content_hash());
        assert_ne!(red.content_hash(), redder.content_hash());
        let mut named = red.clone();
        named.attributes.materials.textures.push("skin.png".into());
        assert_ne!(red.content_hash(), named.content_hash());
    }

    #[test]
    fn bounding_box_spans_all_vertices() {
        let m = MeshData::new(vec![1.0, -2.0, 3.0, -1.0, 5.0, 0.5], vec![]);
        assert_eq!(m.bounding_box(), Some(([-1.0, -2.0, 0.5], [1.0, 5.0, 3.0])));
        assert_eq!(MeshData::default().bounding_box(), None);
    }
}
