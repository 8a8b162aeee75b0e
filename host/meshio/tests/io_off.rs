//! OFF reading: header variants, comments, extra per-vertex and per-face values, polygons,
//! errors with line numbers.

use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Domain, Values};
use meshflow_meshio::{self as io, Format, LoadError, Position};

fn load(text: &str) -> Result<MeshData, LoadError> {
    io::load_bytes(text.as_bytes(), Format::Off, "mesh.off")
}

fn error(text: &str) -> (String, Option<Position>) {
    let err = load(text).unwrap_err();
    let at = match &err {
        LoadError::Invalid { at, .. } => *at,
        other => panic!("expected an Invalid error, got {other}"),
    };
    (err.to_string(), at)
}

fn square_with_apex() -> MeshData {
    MeshData::new(
        vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.5, 1.0],
        vec![0, 1, 2, 0, 2, 3, 4, 1, 0, 1, 1, 2],
    )
}

#[test]
fn plain_off_with_comments_polygons_and_face_colours() {
    let text = "OFF\n# a comment line\n5 3 0 # counts\n\n0 0 0\n1 0 0\n1 1 0\n0 1 0 # corner\n0.5 0.5 1\n\
                4 0 1 2 3 255 0 0\n3 4 1 0\n3 1 1 2 0.5 0.5 0.5 1\n";
    let mesh = load(text).unwrap();
    assert_eq!(
        (&mesh.positions, &mesh.triangles),
        (&square_with_apex().positions, &square_with_apex().triangles)
    );
    // Integer colours are bytes, float ones from 0 to 1; a face without one is white, and
    // the quad's colour goes to both its triangles.
    let colour = mesh.attributes.get(Domain::Face, "color").unwrap();
    assert_eq!(
        colour.values,
        Values::U8(vec![255, 0, 0, 255, 255, 0, 0, 255, 255, 255, 255, 255, 128, 128, 128, 255])
    );
}

#[test]
fn header_variants_and_a_missing_header_load_the_same_mesh() {
    let faces = "4 0 1 2 3\n3 4 1 0\n3 1 1 2\n";
    let plain = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n";
    let coloured =
        "0 0 0 1 0 0 1\n1 0 0 0 1 0 1\n1 1 0 0 0 1 1\n0 1 0 1 1 1 1\n0.5 0.5 1 0 0 0 1\n";
    let normals = "0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n0.5 0.5 1 0 0 1\n";
    let homogeneous = "0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n0.5 0.5 1 1\n";
    let cases = [
        format!("OFF\n5 3 0\n{plain}{faces}"),
        format!("OFF 5 3 0\n{plain}{faces}"),
        format!("5 3 0\n{plain}{faces}"),
        format!("5 3\n{plain}{faces}"),
        format!("COFF\n5 3 0\n{coloured}{faces}"),
        format!("NOFF\n5 3 0\n{normals}{faces}"),
        format!(
            "CNOFF\n5 3 0\n0 0 0 1 0 0 1 0 0 1\n1 0 0 1 0 0 1 0 0 1\n1 1 0 1 0 0 1 0 0 1\n0 1 0 1 0 0 1 0 0 1\n0.5 0.5 1 1 0 0 1 0 0 1\n{faces}"
        ),
        format!(
            "STOFF\n5 3 0\n0 0 0 0.1 0.2\n1 0 0 0.1 0.2\n1 1 0 0.1 0.2\n0 1 0 0.1 0.2\n0.5 0.5 1 0.1 0.2\n{faces}"
        ),
        format!("4OFF\n5 3 0\n{homogeneous}{faces}"),
        format!("nOFF\n3\n5 3 0\n{plain}{faces}"),
        format!("nOFF 3 5 3 0\n{plain}{faces}"),
        format!("OFF\r\n5 3 0\r\n{}{}", plain.replace('\n', "\r\n"), faces.replace('\n', "\r\n")),
    ];
    for text in cases {
        let mesh = load(&text).unwrap();
        assert_eq!(mesh.positions, square_with_apex().positions, "{text}");
        assert_eq!(mesh.triangles, square_with_apex().triangles, "{text}");
    }
}

#[test]
fn unreferenced_vertices_and_trailing_data_are_fine() {
    let text = "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n9 9 9\n3 0 1 2\n2 0 1\n";
    let mesh = load(text).unwrap();
    assert_eq!(mesh.vertex_count(), 4);
    assert_eq!(mesh.triangles, vec![0, 1, 2]);
}

#[test]
fn a_bad_number_names_its_line() {
    let (message, at) = error("OFF\n3 1 0\n0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n");
    assert_eq!(at, Some(Position::Line(4)));
    assert_eq!(message, "mesh.off: line 4: vertex 1: 'zero' is not a number");
    let (message, _) = error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 one 2\n");
    assert_eq!(message, "mesh.off: line 6: face 0: 'one' is not an integer");
    let (message, _) = error("OFF\nthree 1 0\n");
    assert_eq!(message, "mesh.off: line 2: vertex count: 'three' is not an integer");
    let (message, _) = error("OFF\n3 1 0\n0 0\n");
    assert_eq!(message, "mesh.off: line 3: vertex 0 has 2 values, expected 3");
}

#[test]
fn bad_faces_and_coordinates_are_rejected_with_their_line() {
    let head = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";
    let (message, at) = error(&format!("{head}3 0 1 3\n"));
    assert_eq!(at, Some(Position::Line(6)));
    assert_eq!(message, "mesh.off: line 6: face 0 uses vertex 3, but there are only 3 vertices");
    let (message, _) = error(&format!("{head}3 0 -1 2\n"));
    assert!(message.contains("face 0 uses vertex -1"), "{message}");
    let (message, _) = error(&format!("{head}2 0 1\n"));
    assert_eq!(message, "mesh.off: line 6: face 0 has 2 corners, a face needs at least 3");
    let (message, _) = error(&format!("{head}4 0 1 2\n"));
    assert_eq!(message, "mesh.off: line 6: face 0 has 4 corners but only 3 values follow");
    let (message, at) = error("OFF\n3 1 0\n0 0 0\n1 NaN 0\n0 1 0\n3 0 1 2\n");
    assert_eq!(at, Some(Position::Line(4)));
    assert!(message.contains("vertex 1 has a non-finite coordinate (NaN)"), "{message}");
}

#[test]
fn counts_the_file_cannot_hold_fail_at_its_end() {
    let (message, at) = error("OFF\n4000000000 4000000000 0\n0 0 0\n");
    assert_eq!(at, Some(Position::Line(3)));
    assert_eq!(message, "mesh.off: line 3: file ends before vertex 1 of 4000000000");
    let (message, _) = error("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    assert!(message.contains("file ends before face 1 of 2"), "{message}");
    let (message, _) = error("OFF\n99999999999 0 0\n");
    assert!(message.contains("do not fit 32-bit vertex ids"), "{message}");
}

#[test]
fn garbage_and_unsupported_variants_are_rejected() {
    assert!(error("").0.contains("file ends before the OFF header"));
    assert!(error("\u{1}\u{2}garbage\n").0.contains("expected the vertex and face counts"));
    assert!(error("OFF BINARY\n").0.contains("binary OFF is not supported"));
    assert!(error("XYZOFF\n3 1 0\n").0.contains("unknown OFF keyword 'XYZOFF'"));
    assert!(error("nOFF\n2\n3 1 0\n").0.contains("2-dimensional OFF is not supported"));
}
