//! The packed mesh format: exact round trips of any mesh, compactness, and damage handling.

mod correction_common;

use correction_common::{Rng, attributed, grid};
use meshflow_codec::pack::{self, PackError};
use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::Domain;
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
fn a_mesh_packed_by_the_previous_format_still_unpacks() {
    // Format 5 (the geometry in one stream), written by the release before format 6.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bunny-v5.mfm");
    let v5 = std::fs::read(path).unwrap();
    assert_eq!(u16::from_le_bytes([v5[4], v5[5]]), 5);
    let mesh = bunny();
    assert_exact(&pack::decode(&v5).unwrap(), &mesh);
    let (arriving, hash) = pack::decode_from(Trickle { bytes: &v5, chunk: 1460 }).unwrap();
    assert_exact(&arriving, &mesh);
    assert_eq!(hash, pack::stated_hash(&v5).unwrap());
    assert_eq!(pack::encode(&mesh).unwrap()[4], 6, "new files are format 6");
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

/// A download: at most `chunk` bytes a read.
struct Trickle<'a> {
    bytes: &'a [u8],
    chunk: usize,
}

impl std::io::Read for Trickle<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.chunk.min(buf.len()).min(self.bytes.len());
        buf[..n].copy_from_slice(&self.bytes[..n]);
        self.bytes = &self.bytes[n..];
        Ok(n)
    }
}

/// What decoding gives, as text: the mesh's hash or the error.
fn outcome(decoded: Result<MeshData, PackError>) -> String {
    decoded.map_or_else(|e| format!("error: {e}"), |m| m.content_hash().to_hex())
}

#[test]
fn a_mesh_arriving_in_pieces_decodes_as_the_whole_does() {
    let cloud = MeshData::new(grid(40, 40, 0, &mut Rng(3)).positions, vec![]);
    for mesh in [bunny(), attributed_grid(), cloud, MeshData::default()] {
        let bytes = pack::encode(&mesh).unwrap();
        for chunk in [1, 7, 1460, 1 << 20] {
            let (decoded, hash) = pack::decode_from(Trickle { bytes: &bytes, chunk }).unwrap();
            assert_eq!(hash, mesh.content_hash());
            assert_exact(&decoded, &mesh);
            assert_eq!(decoded, mesh);
        }
    }
}

#[test]
fn a_cut_or_damaged_arrival_fails_as_the_whole_does() {
    let mesh = grid(5, 4, 1, &mut Rng(7));
    let bytes = pack::encode(&mesh).unwrap();
    let both = |bytes: &[u8]| {
        let arriving = outcome(pack::decode_from(Trickle { bytes, chunk: 5 }).map(|(m, _)| m));
        (outcome(pack::decode(bytes)), arriving)
    };
    for len in 0..bytes.len() {
        let (whole, arriving) = both(&bytes[..len]);
        assert!(whole.starts_with("error"), "prefix {len}");
        assert_eq!(whole, arriving, "prefix {len}");
    }
    for bit in 0..8 * bytes.len() {
        let mut damaged = bytes.clone();
        damaged[bit / 8] ^= 1 << (bit % 8);
        let (whole, arriving) = both(&damaged);
        assert_eq!(whole, arriving, "bit {bit}");
    }
    // Resealed damage: the connectivity, decoded before the rest arrives, fails as it would
    // once everything is in.
    for at in 54..bytes.len() {
        for value in [0, 0x55, 0xff] {
            let mut damaged = bytes.clone();
            damaged[at] = value;
            reseal(&mut damaged);
            let (whole, arriving) = both(&damaged);
            assert_eq!(whole, arriving, "byte {at} = {value}");
        }
    }
}

#[test]
fn damage_in_a_later_geometry_block_fails_as_the_whole_does() {
    // 67,600 vertices: two geometry blocks.
    let mesh = grid(260, 260, 0, &mut Rng(5));
    let bytes = pack::encode(&mesh).unwrap();
    let whole_and_arriving = |bytes: &[u8]| {
        let arriving = pack::decode_from(Trickle { bytes, chunk: 4096 }).map(|(m, _)| m);
        (outcome(pack::decode(bytes)), outcome(arriving))
    };
    let mut failures = 0;
    for at in (54..bytes.len()).step_by(bytes.len() / 60) {
        let mut damaged = bytes.clone();
        damaged[at] ^= 0x5a;
        reseal(&mut damaged);
        let (whole, arriving) = whole_and_arriving(&damaged);
        assert_eq!(whole, arriving, "byte {at}");
        failures += usize::from(whole.starts_with("error"));
    }
    assert!(failures > 50, "only {failures} of the damaged copies failed");
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
    let arriving = pack::decode_from(Trickle { bytes: &forged, chunk: 3 });
    assert!(matches!(arriving, Err(PackError::Malformed(_))));
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

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Every domain and number type, any finite bits: the same mesh back, hash included.
    #[test]
    fn attributes_round_trip_exactly(seed in any::<u64>(), w in 1u32..20, h in 1u32..20, islands in 0u32..4) {
        let mut rng = Rng(seed);
        let mesh = attributed(grid(w, h, islands, &mut rng), &mut rng);
        let decoded = pack::decode(&pack::encode(&mesh).unwrap()).unwrap();
        assert_exact(&decoded, &mesh);
        prop_assert_eq!(decoded, mesh);
    }

    /// Attribute values of any finite bit pattern (`-0.0`, subnormals, extremes) on a soup.
    #[test]
    fn any_attribute_bits_round_trip(
        floats in prop::collection::vec(
            any::<u32>().prop_map(f32::from_bits).prop_filter("finite", |c| c.is_finite()),
            12,
        ),
        doubles in prop::collection::vec(
            any::<u64>().prop_map(f64::from_bits).prop_filter("finite", |c| c.is_finite()),
            4,
        ),
        ints in prop::collection::vec(any::<i32>(), 6),
        bytes in prop::collection::vec(any::<u8>(), 24),
    ) {
        use meshflow_mesh::attributes::{Attribute, Domain, Values};
        let mut mesh = MeshData::new(vec![0.0; 12], vec![0, 1, 2, 2, 1, 3]);
        let a = &mut mesh.attributes;
        a.insert(Attribute::normal(floats), 4, 2).unwrap();
        a.insert(Attribute::color(bytes[..16].to_vec()), 4, 2).unwrap();
        a.insert(Attribute { domain: Domain::Vertex, name: "w".into(), components: 1, values: Values::F64(doubles) }, 4, 2).unwrap();
        a.insert(Attribute { domain: Domain::Corner, name: "i".into(), components: 1, values: Values::I32(ints) }, 4, 2).unwrap();
        a.insert(Attribute { domain: Domain::Face, name: "u".into(), components: 4, values: Values::U8(bytes[16..].to_vec()) }, 4, 2).unwrap();
        let decoded = pack::decode(&pack::encode(&mesh).unwrap()).unwrap();
        prop_assert_eq!(decoded.content_hash(), mesh.content_hash());
        prop_assert_eq!(decoded, mesh);
    }
}

/// A 300 × 300 grid with colours, quality, normals and the rest.
fn attributed_grid() -> MeshData {
    let mut rng = Rng(21);
    attributed(grid(300, 300, 3, &mut rng), &mut rng)
}

#[test]
fn attributes_cost_a_fraction_of_their_raw_bytes() {
    let mesh = attributed_grid();
    let bare = MeshData::new(mesh.positions.clone(), mesh.triangles.clone());
    let packed = pack::encode(&mesh).unwrap();
    assert_eq!(pack::decode(&packed).unwrap(), mesh);
    let raw: usize = mesh.attributes.iter().map(|a| a.values.to_le_bytes().len()).sum();
    let cost = packed.len() - pack::encode(&bare).unwrap().len();
    assert!(cost * 2 < raw, "attributes: {cost} packed bytes of {raw} raw");
    // Colours smooth over the surface with the same noise of ±4 on each channel: about 3.6
    // bits for the first channel's noise against its neighbours' mean, a bit and a half for
    // each other channel, whose prediction follows the first one's residual (7.6 measured;
    // 32 raw).
    let colours_only = {
        let mut m = bare.clone();
        let colour = mesh.attributes.get(Domain::Vertex, "color").unwrap().clone();
        m.attributes.insert(colour, m.vertex_count(), m.triangle_count()).unwrap();
        m
    };
    let colour_bytes =
        pack::encode(&colours_only).unwrap().len() - pack::encode(&bare).unwrap().len();
    let per_vertex = 8.0 * colour_bytes as f64 / mesh.vertex_count() as f64;
    assert!(per_vertex < 8.5, "{per_vertex:.1} bits per colour");
}

#[test]
fn normals_the_store_computed_cost_almost_nothing() {
    use meshflow_mesh::attributes::Attribute;
    use meshflow_mesh::store::{MeshStore, Op};
    let mut rng = Rng(5);
    let base = grid(200, 200, 0, &mut rng);
    let (v, t) = (base.vertex_count(), base.triangle_count());
    let mut with_normals = base.clone();
    with_normals.attributes.insert(Attribute::normal(vec![0.0; 3 * v]), v, t).unwrap();
    // Moving every vertex has the store recompute every normal.
    let mut store = MeshStore::new(with_normals);
    let xyz = base.positions.iter().map(|c| c * 1.5).collect();
    store.apply(Op::SetPositions { xyz }).unwrap();
    let (result, _) = store.finish();
    let bare = MeshData::new(result.positions.clone(), result.triangles.clone());
    let cost = pack::encode(&result).unwrap().len() - pack::encode(&bare).unwrap().len();
    assert!(cost < v / 50, "{cost} bytes for {v} recomputed normals");
    assert_eq!(pack::decode(&pack::encode(&result).unwrap()).unwrap(), result);
}

#[test]
fn damaged_attributes_are_errors_and_never_panic() {
    let mut rng = Rng(9);
    let mesh = attributed(grid(6, 5, 1, &mut rng), &mut rng);
    let bytes = pack::encode(&mesh).unwrap();
    for len in 0..bytes.len() {
        assert!(pack::decode(&bytes[..len]).is_err(), "prefix {len}");
    }
    for i in 54..bytes.len() {
        for value in [0u8, 1, 0x7f, 0x80, 0xff, bytes[i] ^ 0x10] {
            let mut damaged = bytes.clone();
            damaged[i] = value;
            reseal(&mut damaged);
            match pack::decode(&damaged) {
                Ok(decoded) => assert_eq!(decoded.content_hash(), mesh.content_hash()),
                Err(e) => assert!(!matches!(e, PackError::ChecksumMismatch)),
            }
        }
    }
}

/// A packed file's header varints (counts, grid flag, section lengths; no grid) and its
/// sections, after the 54 bytes of magic, version, checksum and hash.
fn split(bytes: &[u8]) -> (Vec<u64>, [Vec<u8>; 3]) {
    let mut at = 54;
    let mut varints = Vec::new();
    while varints.len() < 6 {
        let (mut value, mut shift) = (0u64, 0);
        loop {
            let b = bytes[at];
            at += 1;
            value |= u64::from(b & 0x7f) << shift;
            shift += 7;
            if b & 0x80 == 0 {
                break;
            }
        }
        varints.push(value);
    }
    assert_eq!(varints[2], 0, "no grid");
    let mut sections: [Vec<u8>; 3] = Default::default();
    for (k, section) in sections.iter_mut().enumerate() {
        let length = varints[3 + k] as usize;
        *section = bytes[at..at + length].to_vec();
        at += length;
    }
    (varints, sections)
}

/// The file `split` read, with `attributes` as its attributes section, resealed.
fn with_attributes_section(bytes: &[u8], attributes: &[u8]) -> Vec<u8> {
    let (mut varints, [connectivity, geometry, _]) = split(bytes);
    varints[5] = attributes.len() as u64;
    let mut out = bytes[..54].to_vec();
    for mut value in varints {
        while value >= 0x80 {
            out.push(value as u8 | 0x80);
            value >>= 7;
        }
        out.push(value as u8);
    }
    out.extend(connectivity.iter().chain(&geometry).chain(attributes));
    reseal(&mut out);
    out
}

#[test]
fn a_forged_attribute_stream_is_refused_before_allocating() {
    use meshflow_mesh::attributes::Attribute;
    let mut mesh = grid(300, 300, 0, &mut Rng(3));
    let (v, t) = (mesh.vertex_count(), mesh.triangle_count());
    // Constant colours pack to a few hundred bytes and still decode.
    mesh.attributes.insert(Attribute::color(vec![200; 4 * v]), v, t).unwrap();
    let bytes = pack::encode(&mesh).unwrap();
    assert_eq!(pack::decode(&bytes).unwrap(), mesh);
    let (_, [_, _, section]) = split(&bytes);
    assert!(section.len() < 1000, "{} bytes of constant colours", section.len());
    assert_eq!(pack::decode(&with_attributes_section(&bytes, &section)).unwrap(), mesh);
    // The same attribute header with a 1-byte stream: 360,000 numbers cannot come from it.
    let header = 1 + 4 + "color".len() + 2;
    let mut forged = section[..header].to_vec();
    forged.extend([1, 0, 0, 0, 0]); // stream length 1, the byte, no materials
    match pack::decode(&with_attributes_section(&bytes, &forged)) {
        Err(PackError::Malformed(m)) => assert!(m.contains("numbers"), "{m}"),
        other => panic!("{other:?}"),
    }
    // Attributes out of canonical order, repeated, or with a forged count are malformed.
    let mut twice = vec![2];
    twice.extend(&section[1..section.len() - 3]);
    twice.extend(&section[1..]);
    assert!(matches!(
        pack::decode(&with_attributes_section(&bytes, &twice)),
        Err(PackError::Malformed(_))
    ));
    let mut many = section.clone();
    many[0] = 33;
    assert!(matches!(
        pack::decode(&with_attributes_section(&bytes, &many)),
        Err(PackError::Malformed(_))
    ));
}

/// A vertex with 100,000 triangles around it (a fan, as a hostile file may hold): its
/// attributes pack and unpack in linear time, not one scan of the fan per triangle.
#[test]
fn a_fan_of_100000_triangles_with_attributes_packs_quickly() {
    use meshflow_mesh::attributes::{Attribute, Values};
    let n = 100_000u32;
    let mut positions = vec![0.0f32; 3];
    for i in 0..=n {
        let a = i as f32 * 0.0001;
        positions.extend([a.cos(), a.sin(), 0.0]);
    }
    let triangles: Vec<u32> = (1..=n).flat_map(|i| [0, i, i + 1]).collect();
    let mut mesh = MeshData::new(positions, triangles);
    let (v, t) = (mesh.vertex_count(), mesh.triangle_count());
    let a = &mut mesh.attributes;
    a.insert(Attribute::quality((0..v).map(|i| i as f32).collect()), v, t).unwrap();
    let label = Attribute {
        domain: Domain::Face,
        name: "label".into(),
        components: 1,
        values: Values::I32((0..t as i32).map(|i| i / 100).collect()),
    };
    a.insert(label, v, t).unwrap();
    let started = std::time::Instant::now();
    let bytes = pack::encode(&mesh).unwrap();
    assert_eq!(pack::decode(&bytes).unwrap(), mesh);
    let elapsed = started.elapsed();
    assert!(elapsed.as_secs_f64() < 5.0, "{elapsed:?}");
}
