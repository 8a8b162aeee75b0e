//! PLY reading: every encoding and type, extra properties and elements, polygons, raw-scan
//! features, and rejection of malformed files with positions in the message.

use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Domain, Values};
use meshflow_meshio::{self as io, Format, LoadError, Position};

/// One value of a hand-written PLY body.
#[derive(Clone, Copy)]
enum V {
    I8(i8),
    U8(u8),
    I16(i16),
    U16(u16),
    I32(i32),
    U32(u32),
    F32(f32),
    F64(f64),
}

#[derive(Clone, Copy, PartialEq)]
enum Enc {
    Ascii,
    Little,
    Big,
}

impl Enc {
    const ALL: [Enc; 3] = [Enc::Ascii, Enc::Little, Enc::Big];

    fn name(self) -> &'static str {
        match self {
            Enc::Ascii => "ascii",
            Enc::Little => "binary_little_endian",
            Enc::Big => "binary_big_endian",
        }
    }
}

/// Builds a PLY file from the declarations after the `format` line and one value list per
/// record (one line in ascii).
fn ply(enc: Enc, declarations: &str, records: &[Vec<V>]) -> Vec<u8> {
    let mut out =
        format!("ply\nformat {} 1.0\n{declarations}end_header\n", enc.name()).into_bytes();
    for record in records {
        if enc == Enc::Ascii {
            let words: Vec<String> = record
                .iter()
                .map(|v| match *v {
                    V::I8(x) => x.to_string(),
                    V::U8(x) => x.to_string(),
                    V::I16(x) => x.to_string(),
                    V::U16(x) => x.to_string(),
                    V::I32(x) => x.to_string(),
                    V::U32(x) => x.to_string(),
                    V::F32(x) => x.to_string(),
                    V::F64(x) => x.to_string(),
                })
                .collect();
            out.extend_from_slice(words.join(" ").as_bytes());
            out.push(b'\n');
            continue;
        }
        for v in record {
            macro_rules! put {
                ($x:expr) => {
                    if enc == Enc::Big {
                        out.extend_from_slice(&$x.to_be_bytes())
                    } else {
                        out.extend_from_slice(&$x.to_le_bytes())
                    }
                };
            }
            match *v {
                V::I8(x) => put!(x),
                V::U8(x) => put!(x),
                V::I16(x) => put!(x),
                V::U16(x) => put!(x),
                V::I32(x) => put!(x),
                V::U32(x) => put!(x),
                V::F32(x) => put!(x),
                V::F64(x) => put!(x),
            }
        }
    }
    out
}

/// Replaces text in the header only, leaving a binary body untouched.
fn edit_header(bytes: &[u8], from: &str, to: &str) -> Vec<u8> {
    let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    assert!(header.contains(from));
    let mut out = header.replacen(from, to, 1).into_bytes();
    out.extend_from_slice(&bytes[end..]);
    out
}

fn load(bytes: &[u8]) -> Result<MeshData, LoadError> {
    io::load_bytes(bytes, Format::Ply, "scan.ply")
}

fn error(bytes: &[u8]) -> (String, Option<Position>) {
    match load(bytes).unwrap_err() {
        LoadError::Invalid { name, at, reason } => {
            assert_eq!(name, "scan.ply");
            let message = LoadError::Invalid { name, at, reason }.to_string();
            (message, at)
        }
        other => panic!("expected an Invalid error, got {other}"),
    }
}

const SQUARE_AND_APEX: [[f32; 3]; 5] =
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 1.0]];

fn expected_scan() -> MeshData {
    MeshData::new(
        SQUARE_AND_APEX.iter().flatten().copied().collect(),
        // quad fan, triangle, pentagon fan, degenerate triangle
        vec![0, 1, 2, 0, 2, 3, 4, 1, 0, 0, 1, 2, 0, 2, 3, 0, 3, 4, 1, 1, 2],
    )
}

/// Faces of `expected_scan` with an extra colour and an extra list per face.
fn face_records() -> Vec<Vec<V>> {
    let faces: [&[i32]; 4] = [&[0, 1, 2, 3], &[4, 1, 0], &[0, 1, 2, 3, 4], &[1, 1, 2]];
    faces
        .iter()
        .map(|f| {
            let mut r = vec![V::U8(200)];
            r.push(V::U8(f.len() as u8));
            r.extend(f.iter().map(|&i| V::I32(i)));
            r.extend([V::U16(2), V::F32(0.25), V::F32(0.75)]);
            r
        })
        .collect()
}

#[test]
fn extra_properties_are_kept_and_other_elements_skipped_in_every_encoding() {
    // Fixed-size vertex records with doubles, a lone normal component, two colour channels
    // and confidence; a material element before the faces, extra face properties, and an
    // edge element after them.
    let declarations = "comment from a scanner\nobj_info scanner v2\n\
        element vertex 5\nproperty float confidence\nproperty double z\nproperty double x\n\
        property float nx\nproperty double y\nproperty uchar red\nproperty uchar green\n\
        element material 2\nproperty uchar ambient_red\nproperty float shininess\n\
        element face 4\nproperty uchar intensity\nproperty list uchar int vertex_indices\n\
        property list ushort float texcoord\n\
        element edge 2\nproperty int vertex1\nproperty int vertex2\nproperty list uint char flags\n";
    let mut records: Vec<Vec<V>> = SQUARE_AND_APEX
        .iter()
        .map(|p| {
            let [x, y, z] = p.map(f64::from);
            vec![V::F32(0.9), V::F64(z), V::F64(x), V::F32(-1.0), V::F64(y), V::U8(255), V::U8(0)]
        })
        .collect();
    records.push(vec![V::U8(10), V::F32(0.5)]);
    records.push(vec![V::U8(20), V::F32(1e-3)]);
    records.extend(face_records());
    records.push(vec![V::I32(0), V::I32(1), V::U32(3), V::I8(-1), V::I8(2), V::I8(3)]);
    records.push(vec![V::I32(1), V::I32(2), V::U32(0)]);
    for enc in Enc::ALL {
        let loaded =
            io::load_bytes_reporting(&ply(enc, declarations, &records), Format::Ply, "s").unwrap();
        let mesh = loaded.mesh;
        assert_eq!(mesh.positions, expected_scan().positions, "{}", enc.name());
        assert_eq!(mesh.triangles, expected_scan().triangles, "{}", enc.name());
        // Properties that make no well-known attribute are kept by name and type; face
        // values spread over their polygon's triangles.
        assert_eq!(
            mesh.attributes.describe(),
            [
                "vertex confidence (1 × f32)",
                "vertex green (1 × u8)",
                "vertex nx (1 × f32)",
                "vertex red (1 × u8)",
                "face intensity (1 × u8)"
            ],
            "{}",
            enc.name()
        );
        let intensity = mesh.attributes.get(Domain::Face, "intensity").unwrap();
        assert_eq!(intensity.values, Values::U8(vec![200; 7]));
        assert_eq!(
            loaded.dropped.attributes,
            [
                "element 'material' (2 records)",
                "element 'edge' (2 records)",
                "corner texture coordinates (face list 'texcoord'): a face's list does not hold u v per corner"
            ],
            "{}",
            enc.name()
        );
    }
}

#[test]
fn vertices_with_list_properties_and_integer_coordinates_load() {
    // A list in the vertex element forces the per-value path; coordinates of integer types.
    let declarations = "element vertex 5\nproperty short x\nproperty list uchar uchar tags\n\
        property int y\nproperty char z\nproperty ushort w\n\
        element face 4\nproperty uchar intensity\nproperty list uchar int vertex_indices\n\
        property list ushort float texcoord\n";
    let mut records: Vec<Vec<V>> = [[0i16, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [1, 1, 2]]
        .iter()
        .map(|&[x, y, z]| {
            vec![
                V::I16(x),
                V::U8(2),
                V::U8(7),
                V::U8(8),
                V::I32(y.into()),
                V::I8(z as i8),
                V::U16(9),
            ]
        })
        .collect();
    records.extend(face_records());
    let expected_positions: Vec<f32> = SQUARE_AND_APEX.iter().flatten().map(|c| c * 2.0).collect();
    for enc in Enc::ALL {
        let mesh = load(&ply(enc, declarations, &records)).unwrap();
        assert_eq!(mesh.positions, expected_positions, "{}", enc.name());
        assert_eq!(mesh.triangles, expected_scan().triangles, "{}", enc.name());
    }
}

#[test]
fn vertex_index_lists_of_any_integer_type_and_faces_before_vertices_load() {
    let declarations = "element face 2\nproperty list ushort uint vertex_index\n\
        element vertex 4\nproperty float x\nproperty float y\nproperty float z\n";
    let records = vec![
        vec![V::U16(4), V::U32(0), V::U32(1), V::U32(2), V::U32(3)],
        vec![V::U16(3), V::U32(3), V::U32(2), V::U32(1)],
        vec![V::F32(0.0), V::F32(0.0), V::F32(0.0)],
        vec![V::F32(1.0), V::F32(0.0), V::F32(0.0)],
        vec![V::F32(1.0), V::F32(1.0), V::F32(0.0)],
        vec![V::F32(0.0), V::F32(1.0), V::F32(0.0)],
    ];
    for enc in Enc::ALL {
        let mesh = load(&ply(enc, declarations, &records)).unwrap();
        assert_eq!(mesh.triangles, vec![0, 1, 2, 0, 2, 3, 3, 2, 1], "{}", enc.name());
        assert_eq!(mesh.vertex_count(), 4);
    }
}

#[test]
fn big_endian_bodies_are_decoded_in_big_endian() {
    let declarations = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list uchar int vertex_indices\n";
    let records = vec![
        vec![V::F32(1.5), V::F32(-2.0), V::F32(3.25)],
        vec![V::F32(4.0), V::F32(5.0), V::F32(6.0)],
        vec![V::F32(7.0), V::F32(8.0), V::F32(9.0)],
        vec![V::U8(3), V::I32(2), V::I32(0), V::I32(1)],
    ];
    let big = ply(Enc::Big, declarations, &records);
    let mesh = load(&big).unwrap();
    assert_eq!(mesh.positions, vec![1.5, -2.0, 3.25, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    assert_eq!(mesh.triangles, vec![2, 0, 1]);
    // The same bytes declared little endian are different numbers (or invalid).
    let relabelled = edit_header(&big, "binary_big_endian", "binary_little_endian");
    let little_reading = load(&relabelled);
    assert!(little_reading.map(|m| m != mesh).unwrap_or(true));
}

#[test]
fn raw_scan_features_load_unchanged() {
    // Vertex 4 is unreferenced, face 1 is degenerate, edge 0-1 has three triangles.
    let text = "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\n\
        property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0\n1 0 0\n0 1 0\n0 -1 0\n9 9 9\n0 0 1\n3 0 1 2\n3 2 2 2\n3 1 0 3\n3 0 1 5\n";
    let mesh = load(text.as_bytes()).unwrap();
    assert_eq!(mesh.vertex_count(), 6);
    assert_eq!(mesh.triangles, vec![0, 1, 2, 2, 2, 2, 1, 0, 3, 0, 1, 5]);
}

#[test]
fn crlf_headers_and_bodies_load() {
    let text = "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\nproperty float y\r\n\
        property float z\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n\
        0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n";
    assert_eq!(load(text.as_bytes()).unwrap().triangles, vec![0, 1, 2]);
}

fn triangle_file(enc: Enc) -> Vec<u8> {
    let declarations = "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        element face 2\nproperty list uchar int vertex_indices\n";
    let mut records: Vec<Vec<V>> =
        (0..4).map(|i| vec![V::F32(i as f32), V::F32(0.5), V::F32(-1.0)]).collect();
    records.push(vec![V::U8(3), V::I32(0), V::I32(1), V::I32(2)]);
    records.push(vec![V::U8(3), V::I32(1), V::I32(3), V::I32(2)]);
    ply(enc, declarations, &records)
}

#[test]
fn every_truncation_of_a_binary_file_with_per_value_layouts_is_an_error() {
    // Face records with an extra property and a vertex list property take the per-value path.
    let declarations = "element vertex 3\nproperty float x\nproperty list uchar uchar tags\n\
        property float y\nproperty float z\nelement face 2\nproperty list uchar uint vertex_indices\n\
        property uchar flags\n";
    let mut records: Vec<Vec<V>> = (0..3)
        .map(|i| vec![V::F32(i as f32), V::U8(1), V::U8(9), V::F32(1.0), V::F32(2.0)])
        .collect();
    records.push(vec![V::U8(3), V::U32(0), V::U32(1), V::U32(2), V::U8(0)]);
    records.push(vec![V::U8(3), V::U32(2), V::U32(1), V::U32(0), V::U8(0)]);
    for enc in [Enc::Little, Enc::Big] {
        let bytes = ply(enc, declarations, &records);
        assert_eq!(load(&bytes).unwrap().triangles, vec![0, 1, 2, 2, 1, 0]);
        for len in 0..bytes.len() {
            assert!(load(&bytes[..len]).is_err(), "a file cut to {len} bytes loaded");
        }
        let (message, at) = error(&bytes[..bytes.len() - 3]);
        // Face 1's last corner starts 5 bytes before the end (4 bytes, then the flags byte).
        assert_eq!(at, Some(Position::Byte(bytes.len() as u64 - 5)), "{message}");
        assert!(
            message.contains("face 1: the file is truncated: 4 more bytes needed, 2 left"),
            "{message}"
        );
    }
}

#[test]
fn every_truncation_of_a_binary_file_is_an_error_with_a_byte_offset() {
    let bytes = triangle_file(Enc::Little);
    let header = bytes.len() - (4 * 12 + 2 * 13);
    assert!(load(&bytes).is_ok());
    for len in 0..bytes.len() {
        let result = load(&bytes[..len]);
        assert!(result.is_err(), "a file cut to {len} bytes loaded");
        if len > header {
            let (message, at) = error(&bytes[..len]);
            assert!(message.contains("truncated") || message.contains("cannot hold"), "{message}");
            assert!(at.is_some(), "{message}");
        }
    }
    // Cut inside the faces: the message names the face and the byte where its corner list
    // starts, which the file cannot hold.
    let (message, at) = error(&bytes[..header + 48 + 13 + 5]);
    assert_eq!(at, Some(Position::Byte((header + 62) as u64)), "{message}");
    let expected = format!(
        "scan.ply: byte {}: face 1: the file is truncated: 12 more bytes needed, 4 left",
        header + 62
    );
    assert_eq!(message, expected);
}

#[test]
fn header_counts_the_file_cannot_hold_fail_before_allocating() {
    // 20 bytes of body claiming 4 billion vertices: rejected from the header alone.
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n\
        property float x\nproperty float y\nproperty float z\nend_header\n"
        .to_vec();
    bytes.extend_from_slice(&[0u8; 20]);
    let (message, at) = error(&bytes);
    assert_eq!(at, Some(Position::Line(3)));
    assert!(message.contains("declares 4000000000 'vertex' elements"), "{message}");
    assert!(message.contains("cannot hold"), "{message}");

    // The same for faces after valid vertices, and for skipped elements, in ascii too.
    let bytes =
        edit_header(&triangle_file(Enc::Little), "element face 2", "element face 3000000000");
    assert!(error(&bytes).0.contains("3000000000 'face' elements"));
    let ascii = String::from_utf8(triangle_file(Enc::Ascii)).unwrap();
    let hostile = ascii.replacen(
        "element face 2",
        "element junk 99999999999\nproperty int a\nelement face 2",
        1,
    );
    let (message, at) = error(hostile.as_bytes());
    assert_eq!(at, Some(Position::Line(7)), "{message}");
    // More than 2^32 vertices cannot be numbered by u32 ids at all.
    let huge = ascii.replacen("element vertex 4", "element vertex 5000000000", 1);
    assert!(load(huge.as_bytes()).is_err());
}

#[test]
fn an_index_out_of_range_names_the_face_the_vertex_and_the_byte() {
    let mut bytes = triangle_file(Enc::Little);
    let header = bytes.len() - (4 * 12 + 2 * 13);
    // Face 1, second corner (after its count byte and first index).
    let at = header + 48 + 13 + 1 + 4;
    bytes[at..at + 4].copy_from_slice(&7i32.to_le_bytes());
    let (message, position) = error(&bytes);
    assert_eq!(position, Some(Position::Byte(at as u64)));
    assert_eq!(
        message,
        format!("scan.ply: byte {at}: face 1 uses vertex 7, but there are only 4 vertices")
    );

    bytes[at..at + 4].copy_from_slice(&(-1i32).to_le_bytes());
    assert!(error(&bytes).0.contains("face 1 uses vertex -1"));

    let ascii = String::from_utf8(triangle_file(Enc::Ascii)).unwrap().replace("3 1 3 2", "3 1 4 2");
    let (message, at) = error(ascii.as_bytes());
    assert_eq!(at, Some(Position::Line(15)), "{message}");
    assert!(message.contains("face 1 uses vertex 4, but there are only 4 vertices"), "{message}");
}

#[test]
fn non_finite_coordinates_are_rejected() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut bytes = triangle_file(Enc::Big);
        let header = bytes.len() - (4 * 12 + 2 * 13);
        let at = header + 2 * 12 + 4; // vertex 2, y
        bytes[at..at + 4].copy_from_slice(&bad.to_be_bytes());
        let (message, position) = error(&bytes);
        assert_eq!(position, Some(Position::Byte((header + 24) as u64)), "{message}");
        assert!(message.contains("vertex 2 has a non-finite coordinate"), "{message}");
    }
    // A double too large for f32 is not finite either.
    let declarations =
        "element vertex 1\nproperty double x\nproperty double y\nproperty double z\n";
    let bytes = ply(Enc::Little, declarations, &[vec![V::F64(0.0), V::F64(1e300), V::F64(0.0)]]);
    assert!(error(&bytes).0.contains("non-finite"));
    let ascii =
        String::from_utf8(triangle_file(Enc::Ascii)).unwrap().replace("1 0.5 -1", "nan 0.5 -1");
    let (message, at) = error(ascii.as_bytes());
    assert_eq!(at, Some(Position::Line(11)), "{message}");
    assert!(message.contains("vertex 1 has a non-finite coordinate (NaN)"), "{message}");
}

#[test]
fn bad_ascii_values_and_short_faces_name_the_line() {
    let ascii = String::from_utf8(triangle_file(Enc::Ascii)).unwrap();
    let bad_number = ascii.replace("2 0.5 -1", "2 0.5 -1x");
    let (message, at) = error(bad_number.as_bytes());
    assert_eq!(at, Some(Position::Line(12)), "{message}");
    assert!(message.contains("'-1x' is not a number"), "{message}");

    let short_face = ascii.replace("3 1 3 2", "2 1 3\n3 0 0 0");
    let (message, at) = error(short_face.as_bytes());
    assert_eq!(at, Some(Position::Line(15)), "{message}");
    assert!(message.contains("face 1 has 2 corners"), "{message}");

    let truncated = &ascii[..ascii.len() - 6];
    let (message, _) = error(truncated.as_bytes());
    assert!(message.contains("truncated"), "{message}");
}

#[test]
fn garbage_and_broken_headers_are_rejected() {
    let cases: [(&[u8], &str); 7] = [
        (b"", "does not start with 'ply'"),
        (b"\x00\x01\x02garbage\xff", "does not start with 'ply'"),
        (b"ply\nformat ascii 1.0\nelement vertex 0\n", "no 'end_header'"),
        (
            b"ply\nformat ascii 1.0\nproperty float x\nend_header\n",
            "line 3: property before any element",
        ),
        (b"ply\nformat klingon 1.0\nend_header\n", "line 2: unknown PLY format 'klingon'"),
        (
            b"ply\nelement vertex 1\nproperty quad x\nend_header\n",
            "line 3: unknown property type 'quad'",
        ),
        (b"ply\nelement vertex 1\nproperty float x\nend_header\n0\n", "no 'format' line"),
    ];
    for (bytes, expected) in cases {
        let (message, _) = error(bytes);
        assert!(message.contains(expected), "{message:?} lacks {expected:?}");
    }
    let missing_z = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n";
    assert!(error(missing_z).0.contains("line 3: the vertex element has no scalar 'z' property"));
    let float_list = b"ply\nformat ascii 1.0\nelement face 1\nproperty list float int vertex_indices\nend_header\n";
    assert!(error(float_list).0.contains("list count must have an integer type"));
    let duplicate = b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float x\nend_header\n";
    assert!(error(duplicate).0.contains("line 5: property 'x' is declared twice"));
}

#[test]
fn a_header_of_many_properties_is_read_and_still_checked() {
    // 200k extra properties: a header a hostile client might send (a quadratic check of
    // names took 21 s on it); each vertex then carries them all.
    let mut header = String::from("ply\nformat binary_little_endian 1.0\nelement vertex 3\n");
    header.push_str("property float x\nproperty float y\nproperty float z\n");
    for i in 0..200_000 {
        header.push_str(&format!("property uchar extra{i}\n"));
    }
    let mut with_face = header.clone();
    with_face.push_str("element face 1\nproperty list uchar int vertex_indices\nend_header\n");
    let mut bytes = with_face.into_bytes();
    for v in 0..3u8 {
        for c in [v as f32, (v * 2) as f32, 0.5] {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        bytes.extend(std::iter::repeat_n(7u8, 200_000));
    }
    bytes.push(3);
    for i in 0..3i32 {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    let mesh = io::load_bytes(&bytes, Format::Ply, "wide.ply").unwrap();
    assert_eq!(mesh.triangles, vec![0, 1, 2]);
    assert_eq!(mesh.positions[3..6], [1.0, 2.0, 0.5]);

    header.push_str("property uchar extra199999\nend_header\n");
    let error = io::load_bytes(header.as_bytes(), Format::Ply, "wide.ply").unwrap_err();
    assert!(error.to_string().contains("property 'extra199999' is declared twice"), "{error}");
}
