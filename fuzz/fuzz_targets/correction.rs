//! Any bytes as a correction, applied to a small fixed mesh. Half of the inputs are
//! resealed (correct magic, version and checksum, base hash of the fixed mesh) so the
//! fuzzer reaches the entropy-coded sections instead of stopping at the checksum.
#![no_main]

use libfuzzer_sys::fuzz_target;
use meshflow_codec::correction;
use meshflow_mesh::MeshData;

fn base() -> MeshData {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for y in 0..4u32 {
        for x in 0..4u32 {
            positions.extend([x as f32, y as f32, ((x * y) % 3) as f32 * 0.1]);
            if x < 3 && y < 3 {
                let v = y * 4 + x;
                triangles.extend([v, v + 1, v + 5, v, v + 5, v + 4]);
            }
        }
    }
    MeshData::new(positions, triangles)
}

fuzz_target!(|data: &[u8]| {
    let base = base();
    let _ = correction::decode(data);
    let _ = correction::apply(base.clone(), data);
    if let Some((&reseal, rest)) = data.split_first() {
        if reseal & 1 == 1 {
            // magic, version, checksum (filled below), base hash, then the fuzzed rest.
            let mut bytes = b"MFC\x1a".to_vec();
            bytes.extend(correction::VERSION.to_le_bytes());
            bytes.extend([0; 16]);
            bytes.extend(base.content_hash().0);
            bytes.extend(rest);
            let sum = blake3::hash(&bytes[22..]);
            bytes[6..22].copy_from_slice(&sum.as_bytes()[..16]);
            let _ = correction::apply(base, &bytes);
        }
    }
});
