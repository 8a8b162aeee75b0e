//! The packed mesh format: exact round trips of any mesh, compactness, and damage handling.

mod correction_common;

use correction_common::{Rng, grid};
use meshflow_codec::pack::{self, PackError};
use meshflow_mesh::MeshData;
use meshflow_meshio as io;
use proptest::prelude::*;

fn assert_exact(a: &MeshData, b: &MeshData) {
    let bits = |m: &MeshData| m.positions.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(a), bits(b));
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.content_hash(), b.content_hash());
}

fn bunny() -> MeshData {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/bunny.obj");
    io::load(&path).expect("the bunny ships with the repository")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Arbitrary soups: degenerate, duplicate and non-manifold triangles, unreferenced
    /// vertices, any finite float bits (-0.0, subnormals; non-finite ones are refused).
    #[test]
    fn any_mesh_round_trips_exactly(
        positions in prop::collection::vec(
            any::<u32>().prop_map(f32::from_bits).prop_filter("finite", |c| c.is_finite()),
            0..60,
        ),
        corners in prop::collection::vec(any::<u32>(), 0..90),
    ) {
        let n = positions.len() / 3;
        let positions = positions[..3 * n].to_vec();
        let triangles: Vec<u32> = if n == 0 {
            vec![]
        } else {
            corners[..corners.len() / 3 * 3].iter().map(|c| c % n as u32).collect()
        };
        let mesh = MeshData::new(positions, triangles);
        let bytes = pack::encode(&mesh).unwrap();
        assert_exact(&pack::decode(&bytes).unwrap(), &mesh);
    }

    #[test]
    fn grids_round_trip_exactly(seed in any::<u64>(), w in 1u32..30, h in 1u32..30, islands in 0u32..4) {
        let mesh = grid(w, h, islands, &mut Rng(seed));
        assert_exact(&pack::decode(&pack::encode(&mesh).unwrap()).unwrap(), &mesh);
    }
}

#[test]
fn the_bunny_round_trips_and_beats_binary_ply() {
    let mesh = bunny();
    let bytes = pack::encode(&mesh).unwrap();
    assert_exact(&pack::decode(&bytes).unwrap(), &mesh);
    let mut ply = Vec::new();
    io::write_to(&mut ply, &mesh, io::Format::Ply).unwrap();
    assert!(bytes.len() * 2 < ply.len(), "{} packed vs {} PLY bytes", bytes.len(), ply.len());
    // What the coding order and the edge-based connectivity buy (PLY + zstd-19: 39,326 B).
    assert!(bytes.len() < 23_000, "the bunny packs to {} bytes", bytes.len());
}

#[test]
fn invalid_meshes_are_refused() {
    let bad = MeshData::new(vec![0.0; 9], vec![0, 1, 3]);
    assert!(matches!(pack::encode(&bad), Err(PackError::InvalidMesh(_))));
    let ragged = MeshData::new(vec![0.0; 8], vec![]);
    assert!(matches!(pack::encode(&ragged), Err(PackError::InvalidMesh(_))));
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mesh = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, bad, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2]);
        assert!(matches!(pack::encode(&mesh), Err(PackError::InvalidMesh(_))), "{bad}");
    }
}

#[test]
fn every_truncation_and_bit_flip_is_an_error() {
    let mesh = grid(5, 4, 1, &mut Rng(7));
    let bytes = pack::encode(&mesh).unwrap();
    for len in 0..bytes.len() {
        assert!(pack::decode(&bytes[..len]).is_err(), "prefix {len}");
    }
    for bit in 0..8 * bytes.len() {
        let mut damaged = bytes.clone();
        damaged[bit / 8] ^= 1 << (bit % 8);
        assert!(pack::decode(&damaged).is_err(), "bit {bit}");
    }
    let mut v9 = bytes.clone();
    v9[4] = 9;
    assert!(matches!(pack::decode(&v9), Err(PackError::UnsupportedVersion { found: 9, .. })));
}

fn reseal(bytes: &mut [u8]) {
    let sum = blake3::hash(&bytes[22..]);
    bytes[6..22].copy_from_slice(&sum.as_bytes()[..16]);
}

#[test]
fn forged_counts_are_refused_before_allocating() {
    let mesh = grid(3, 3, 0, &mut Rng(8));
    let bytes = pack::encode(&mesh).unwrap();
    // Vertex count varint after the checksum and content hash: make it 2^32 - 1.
    let mut forged = bytes[..54].to_vec();
    forged.extend([0xff, 0xff, 0xff, 0xff, 0x0f]);
    forged.extend_from_slice(&bytes[55..]);
    reseal(&mut forged);
    assert!(matches!(pack::decode(&forged), Err(PackError::Malformed(_))));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn resealed_damage_never_panics(seed in 0u64..9, at in any::<usize>(), value in any::<u8>()) {
        // Row-ordered grids, and the bunny (seed 8), whose triangles come in no local order
        // (most of them then name their shared edge through the recency list).
        let mesh = if seed == 8 { bunny() } else { grid(6, 5, 2, &mut Rng(seed)) };
        let mut bytes = pack::encode(&mesh).unwrap();
        let i = 54 + at % (bytes.len() - 54);
        bytes[i] = value;
        reseal(&mut bytes);
        match pack::decode(&bytes) {
            // Damage to the final padding bits may leave the data intact.
            Ok(decoded) => prop_assert_eq!(decoded.content_hash(), mesh.content_hash()),
            Err(e) => prop_assert!(!matches!(e, PackError::ChecksumMismatch)),
        }
    }
}
