//! Save → load round trips are bit-identical for every format and encoding, through memory
//! and through files; format detection.

use std::path::Path;

use meshflow_mesh::MeshData;
use meshflow_meshio::{self as io, Format, PlyEncoding};

/// Finite f32 values that are hard to print and parse back exactly, plus pseudo-random bit
/// patterns over the whole finite range.
fn tricky_values() -> Vec<f32> {
    let mut values = vec![
        0.0,
        -0.0,
        0.1,
        -0.1,
        1.0 / 3.0,
        std::f32::consts::PI,
        1e-30,
        1e-5,
        9.999_999e-6,
        1e16,
        9.999_999e15,
        123_456.79,
        16_777_216.0,
        f32::MIN_POSITIVE,
        f32::from_bits(1), // smallest subnormal
        f32::MAX,
        f32::MIN,
        f32::EPSILON,
    ];
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    while values.len() < 3 * 700 {
        state =
            state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        let value = f32::from_bits((state >> 32) as u32);
        if value.is_finite() {
            values.push(value);
        }
    }
    values
}

/// A raw-scan-like mesh: tricky coordinates, a degenerate triangle, a non-manifold edge,
/// unreferenced vertices and duplicate positions.
fn raw_mesh() -> MeshData {
    let mut positions = tricky_values();
    positions.extend_from_slice(&[1.0, 2.0, 3.0, 1.0, 2.0, 3.0]); // two identical vertices
    let n = (positions.len() / 3) as u32;
    let mut triangles = vec![0, 1, 2, 0, 2, 1, 1, 2, 3, 1, 2, 4, 1, 2, 5]; // edge 1-2 used 5 times
    triangles.extend_from_slice(&[6, 6, 7]); // degenerate
    triangles.extend_from_slice(&[n - 1, n - 2, 8]);
    triangles.extend((10..n - 20).step_by(3).flat_map(|i| [i + 2, i, i + 1]));
    // Vertices n-20 .. n-2 (except those used above) stay unreferenced.
    MeshData::new(positions, triangles)
}

fn encode(mesh: &MeshData, format: Format, encoding: PlyEncoding) -> Vec<u8> {
    let mut bytes = Vec::new();
    io::write_as(&mut bytes, mesh, format, encoding).unwrap();
    bytes
}

fn assert_identical(loaded: &MeshData, original: &MeshData, what: &str) {
    assert_eq!(loaded.vertex_count(), original.vertex_count(), "{what}: vertex count");
    assert_eq!(loaded.triangles, original.triangles, "{what}: triangles");
    let bits = |m: &MeshData| m.positions.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(loaded), bits(original), "{what}: position bits");
    assert_eq!(loaded.content_hash(), original.content_hash(), "{what}: content hash");
}

#[test]
fn every_indexed_format_round_trips_bit_identically_in_memory() {
    let mesh = raw_mesh();
    let cases = [
        (Format::Obj, PlyEncoding::default()),
        (Format::Off, PlyEncoding::default()),
        (Format::Ply, PlyEncoding::BinaryLittleEndian),
        (Format::Ply, PlyEncoding::BinaryBigEndian),
        (Format::Ply, PlyEncoding::Ascii),
    ];
    for (format, encoding) in cases {
        let bytes = encode(&mesh, format, encoding);
        let loaded = io::load_bytes(&bytes, format, "mem").unwrap();
        assert_identical(&loaded, &mesh, &format!("{format} {encoding:?}"));
    }
}

#[test]
fn ascii_and_binary_ply_of_the_same_mesh_load_identically() {
    let mesh = raw_mesh();
    let ascii = encode(&mesh, Format::Ply, PlyEncoding::Ascii);
    let little = encode(&mesh, Format::Ply, PlyEncoding::BinaryLittleEndian);
    let big = encode(&mesh, Format::Ply, PlyEncoding::BinaryBigEndian);
    assert_ne!(ascii, little);
    assert_ne!(little, big);
    let from_ascii = io::load_bytes(&ascii, Format::Ply, "a.ply").unwrap();
    let from_little = io::load_bytes(&little, Format::Ply, "l.ply").unwrap();
    let from_big = io::load_bytes(&big, Format::Ply, "b.ply").unwrap();
    assert_eq!(from_ascii, from_little);
    assert_eq!(from_little, from_big);
    assert_eq!(from_ascii.content_hash(), from_big.content_hash());
}

#[test]
fn binary_little_endian_ply_has_the_documented_layout() {
    let mesh = MeshData::new(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], vec![0, 1, 2]);
    let bytes = encode(&mesh, Format::Ply, PlyEncoding::BinaryLittleEndian);
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.starts_with("ply\nformat binary_little_endian 1.0\n"));
    assert!(
        text.contains("element vertex 3\nproperty float x\nproperty float y\nproperty float z\n")
    );
    assert!(text.contains("element face 1\nproperty list uchar int vertex_indices\nend_header\n"));
    let body = &bytes[bytes.len() - (36 + 13)..];
    assert_eq!(&body[..4], &1.0f32.to_le_bytes());
    assert_eq!(&body[36..], &[3, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]);
}

#[test]
fn files_round_trip_through_save_and_load_by_extension() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = raw_mesh();
    for name in ["m.obj", "m.off", "m.ply", "M.PLY", "m.Obj"] {
        let path = dir.path().join(name);
        io::save(&path, &mesh).unwrap();
        let loaded = io::load(&path).unwrap();
        assert_identical(&loaded, &mesh, name);
    }
    let path = dir.path().join("big.ply");
    io::save_as(&path, &mesh, Format::Ply, PlyEncoding::BinaryBigEndian).unwrap();
    assert!(std::fs::read(&path).unwrap().starts_with(b"ply\nformat binary_big_endian"));
    assert_identical(&io::load(&path).unwrap(), &mesh, "big.ply");
}

#[test]
fn stl_round_trips_meshes_whose_vertices_are_distinct_and_in_first_use_order() {
    let positions = tricky_values();
    let n = (positions.len() / 3) as u32;
    // Triangles use vertices 0, 1, 2, ... in order, then reuse some (shared vertices).
    let mut triangles: Vec<u32> = (0..n - n % 3).collect();
    triangles.extend_from_slice(&[0, 4, 8, 5, 5, 1]);
    let mesh = MeshData::new(positions[..(n - n % 3) as usize * 3].to_vec(), triangles);
    let bytes = encode(&mesh, Format::Stl, PlyEncoding::default());
    assert_eq!(bytes.len(), 84 + 50 * mesh.triangle_count());
    let loaded = io::load_bytes(&bytes, Format::Stl, "m.stl").unwrap();
    assert_identical(&loaded, &mesh, "stl");

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.stl");
    io::save(&path, &mesh).unwrap();
    assert_identical(&io::load(&path).unwrap(), &mesh, "stl file");
}

#[test]
fn empty_meshes_round_trip() {
    let empty = MeshData::default();
    for format in Format::ALL {
        let bytes = encode(&empty, format, PlyEncoding::default());
        assert_eq!(io::load_bytes(&bytes, format, "empty").unwrap(), empty, "{format}");
    }
    // A point cloud: vertices without faces.
    let cloud = MeshData::new(vec![1.0, 2.0, 3.0, -4.0, 5.5, 6.25], vec![]);
    for format in [Format::Obj, Format::Off, Format::Ply] {
        let bytes = encode(&cloud, format, PlyEncoding::default());
        assert_eq!(io::load_bytes(&bytes, format, "cloud").unwrap(), cloud, "{format}");
    }
}

#[test]
fn text_output_is_compact_for_ordinary_values() {
    let mesh = MeshData::new(vec![0.5, -1.0, 1e-30, 3.0, 0.0, -0.0, 1.0, 2.0, 3.0], vec![0, 1, 2]);
    let obj = String::from_utf8(encode(&mesh, Format::Obj, PlyEncoding::default())).unwrap();
    assert!(obj.contains("\nv 0.5 -1 1e-30\nv 3 0 -0\nv 1 2 3\nf 1 2 3\n"), "{obj}");
    let off = String::from_utf8(encode(&mesh, Format::Off, PlyEncoding::default())).unwrap();
    assert_eq!(off, "OFF\n3 1 0\n0.5 -1 1e-30\n3 0 -0\n1 2 3\n3 0 1 2\n");
}

#[test]
fn formats_are_detected_from_extensions_and_names() {
    assert_eq!(Format::from_path(Path::new("a/b/bunny.PLY")), Some(Format::Ply));
    assert_eq!(Format::from_path(Path::new("x.obj")), Some(Format::Obj));
    assert_eq!(Format::from_path(Path::new("x.Off")), Some(Format::Off));
    assert_eq!(Format::from_path(Path::new("x.stl")), Some(Format::Stl));
    assert_eq!(Format::from_path(Path::new("x.ply.gz")), None);
    assert_eq!(Format::from_path(Path::new("ply")), None);
    assert_eq!(Format::from_name("ply"), Some(Format::Ply));
    assert_eq!(Format::from_name(".STL"), Some(Format::Stl));
    assert_eq!(Format::from_name("obj"), Some(Format::Obj));
    assert_eq!(Format::from_name("gltf"), None);
    for format in Format::ALL {
        assert_eq!(Format::from_name(&format.to_string()), Some(format));
    }
}

#[test]
fn loading_an_unknown_extension_or_a_missing_file_names_the_file() {
    let err = io::load(Path::new("mesh.xyz")).unwrap_err();
    assert!(matches!(err, io::LoadError::UnknownFormat { .. }));
    assert!(err.to_string().starts_with("mesh.xyz: unknown mesh format"), "{err}");
    let err = io::load(Path::new("/nonexistent/dir/mesh.ply")).unwrap_err();
    assert!(matches!(err, io::LoadError::Io { .. }));
    assert!(err.to_string().starts_with("/nonexistent/dir/mesh.ply: cannot read"), "{err}");
}

#[test]
fn the_example_bunny_loads_and_converts_through_every_format() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/bunny.obj");
    let bunny = io::load(&path).unwrap();
    assert_eq!((bunny.vertex_count(), bunny.triangle_count()), (1839, 3674));
    for (format, encoding) in [
        (Format::Ply, PlyEncoding::BinaryLittleEndian),
        (Format::Ply, PlyEncoding::Ascii),
        (Format::Off, PlyEncoding::default()),
        (Format::Obj, PlyEncoding::default()),
    ] {
        let bytes = encode(&bunny, format, encoding);
        let loaded = io::load_bytes(&bytes, format, "bunny").unwrap();
        assert_identical(&loaded, &bunny, &format!("bunny as {format} {encoding:?}"));
    }
    // STL drops the vertex numbering but keeps the shape: same triangles by position.
    let stl = io::load_bytes(
        &encode(&bunny, Format::Stl, PlyEncoding::default()),
        Format::Stl,
        "bunny.stl",
    )
    .unwrap();
    assert_eq!(stl.triangle_count(), bunny.triangle_count());
    let corner = |m: &MeshData, t: usize| {
        let v = m.triangles[t] as usize * 3;
        [m.positions[v], m.positions[v + 1], m.positions[v + 2]]
    };
    assert!((0..bunny.triangles.len()).all(|t| corner(&stl, t) == corner(&bunny, t)));
}
