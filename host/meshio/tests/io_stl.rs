//! STL reading: ascii and binary detection, vertex welding, errors.

use meshflow_mesh::MeshData;
use meshflow_meshio::{self as io, Format, LoadError, Position};

fn load(bytes: &[u8]) -> Result<MeshData, LoadError> {
    io::load_bytes(bytes, Format::Stl, "part.stl")
}

fn error(bytes: &[u8]) -> (String, Option<Position>) {
    let err = load(bytes).unwrap_err();
    let at = match &err {
        LoadError::Invalid { at, .. } => *at,
        other => panic!("expected an Invalid error, got {other}"),
    };
    (err.to_string(), at)
}

/// Two triangles of a unit square sharing the edge (1,0,0)-(0,1,0), plus a degenerate one.
const TRIANGLES: [[[f32; 3]; 3]; 3] = [
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
    [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
    [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.0]],
];

fn expected() -> MeshData {
    MeshData::new(
        vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0],
        vec![0, 1, 2, 1, 3, 2, 3, 3, 0],
    )
}

fn binary(header: &[u8], triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut out = vec![b' '; 80];
    out[..header.len()].copy_from_slice(header);
    out.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
    for t in triangles {
        out.extend_from_slice(&[0u8; 12]); // normal
        for c in t.iter().flatten() {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out.extend_from_slice(&[0, 0]);
    }
    out
}

fn ascii(triangles: &[[[f32; 3]; 3]]) -> String {
    let mut out = String::from("solid part\n");
    for t in triangles {
        out += "  facet normal 0 0 1\n    outer loop\n";
        for v in t {
            out += &format!("      vertex {} {} {}\n", v[0], v[1], v[2]);
        }
        out += "    endloop\n  endfacet\n";
    }
    out + "endsolid part\n"
}

#[test]
fn binary_and_ascii_weld_identical_positions_in_first_seen_order() {
    assert_eq!(load(&binary(b"exported", &TRIANGLES)).unwrap(), expected());
    assert_eq!(load(ascii(&TRIANGLES).as_bytes()).unwrap(), expected());
}

#[test]
fn binary_files_whose_header_starts_with_solid_are_read_as_binary() {
    assert_eq!(load(&binary(b"solid but actually binary", &TRIANGLES)).unwrap(), expected());
}

#[test]
fn welding_is_by_bit_pattern_so_signed_zeros_stay_apart() {
    let t = [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[-0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
    ];
    let mesh = load(&binary(b"", &t)).unwrap();
    assert_eq!(mesh.vertex_count(), 4);
    assert_eq!(mesh.triangles, vec![0, 1, 2, 3, 1, 2]);
}

#[test]
fn ascii_polygons_multiple_solids_and_crlf_load() {
    let text = "solid a\r\nfacet normal 0 0 1\r\nouter loop\r\nvertex 0 0 0\r\nvertex 1 0 0\r\nvertex 1 1 0\r\n\
                vertex 0 1 0\r\nendloop\r\nendfacet\r\nendsolid a\r\nsolid b\r\nfacet normal 0 0 1\r\nouter loop\r\n\
                vertex 0 0 0\r\nvertex 1 1 0\r\nvertex 0 0 5\r\nendloop\r\nendfacet\r\nendsolid b\r\n";
    let mesh = load(text.as_bytes()).unwrap();
    assert_eq!(mesh.vertex_count(), 5);
    assert_eq!(mesh.triangles, vec![0, 1, 2, 0, 2, 3, 0, 2, 4]);
}

#[test]
fn truncated_or_padded_binary_files_are_rejected_with_the_sizes() {
    let bytes = binary(b"exported", &TRIANGLES);
    for len in [0, 10, 83, 84, 100, bytes.len() - 1] {
        assert!(load(&bytes[..len]).is_err(), "{len} bytes loaded");
    }
    let (message, at) = error(&bytes[..bytes.len() - 1]);
    assert_eq!(at, None);
    assert!(message.contains("3 triangles need 234 bytes but the file has 233"), "{message}");
    let mut padded = bytes.clone();
    padded.push(0);
    assert!(error(&padded).0.contains("the file has 235"));
    // A hostile count: fails on the size check without allocating for 4 billion triangles.
    let mut hostile = bytes[..84].to_vec();
    hostile[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(error(&hostile).0.contains("4294967295 triangles need"));
}

#[test]
fn non_finite_coordinates_are_rejected_with_their_offset() {
    let mut t = TRIANGLES;
    t[1][2][1] = f32::NAN;
    let (message, at) = error(&binary(b"", &t));
    // Record 1 starts at 84 + 50; its third corner at 12 + 24 into the record.
    assert_eq!(at, Some(Position::Byte(84 + 50 + 36)));
    assert!(message.contains("triangle 1 corner 2 has a non-finite coordinate (NaN)"), "{message}");
    let text = ascii(&TRIANGLES).replacen("vertex 1 1 0", "vertex 1 inf 0", 1);
    let (message, at) = error(text.as_bytes());
    assert_eq!(at, Some(Position::Line(12)), "{message}");
    assert!(message.contains("triangle 1 corner 1 has a non-finite coordinate (inf)"), "{message}");
}

#[test]
fn malformed_ascii_names_the_line() {
    let good = ascii(&TRIANGLES);
    let (message, at) = error(good.replacen("vertex 1 0 0", "vertex 1 O 0", 1).as_bytes());
    assert_eq!(at, Some(Position::Line(5)));
    assert_eq!(message, "part.stl: line 5: facet 0: 'O' is not a number");
    let two_corners = good.replacen("      vertex 0 1 0\n", "", 1);
    let (message, at) = error(two_corners.as_bytes());
    assert_eq!(at, Some(Position::Line(2)), "{message}");
    assert!(message.contains("face 0 has 2 corners"), "{message}");
    let (message, _) = error(good.replacen("endloop", "endloop\nbanana", 1).as_bytes());
    assert!(message.contains("line 8: unexpected 'banana' in ascii STL"), "{message}");
    let (message, _) = error(good.rsplit_once("  endfacet").unwrap().0.as_bytes());
    assert!(message.contains("file ends inside facet 2"), "{message}");
    let (message, _) = error(b"garbage that is no mesh");
    assert!(message.contains("too short for binary STL and there is no 'solid'"), "{message}");
}
