//! OBJ reading: polygons, index forms, objects, raw-scan features, errors with line numbers.

use meshflow_mesh::MeshData;
use meshflow_meshio::{self as io, Format, LoadError, Position};

fn load(text: &str) -> Result<MeshData, LoadError> {
    io::load_bytes(text.as_bytes(), Format::Obj, "mesh.obj")
}

fn error(text: &str) -> (String, Option<Position>) {
    let err = load(text).unwrap_err();
    let at = match &err {
        LoadError::Invalid { at, .. } => *at,
        other => panic!("expected an Invalid error, got {other}"),
    };
    (err.to_string(), at)
}

const SQUARE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

#[test]
fn polygons_are_fan_triangulated_and_index_forms_are_read() {
    let text = format!(
        "# exported\nmtllib scan.mtl\n{SQUARE}v 0.5 0.5 1\nvt 0 0\nvt 1 0\nvn 0 0 1\n\
         usemtl skin\ns off\nf 1/1/1 2/2/1 3//1 4\nf 1 2 3 4 5\nf 5/1 1/2 2\n"
    );
    let mesh = load(&text).unwrap();
    assert_eq!(mesh.vertex_count(), 5);
    assert_eq!(mesh.positions[12..], [0.5, 0.5, 1.0]);
    assert_eq!(mesh.triangles, vec![0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3, 0, 3, 4, 4, 0, 1]);
}

#[test]
fn objects_and_groups_merge_into_one_mesh_with_the_file_numbering() {
    // Vertex 2 is shared by both objects and must stay one vertex; vertex 3 is unused.
    let text = "o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 7 7 7\nf 1 2 3\n\
                o second\ng part\nv 1 1 0\nf 2 5 3\nf -3 -1 -4\n";
    let mesh = load(text).unwrap();
    assert_eq!(mesh.vertex_count(), 5);
    assert_eq!(mesh.triangles, vec![0, 1, 2, 1, 4, 2, 2, 4, 1]);
}

#[test]
fn raw_scan_features_load_unchanged() {
    // Unreferenced vertices (first and last), a degenerate face, three faces on one edge,
    // and a face that names a vertex defined later in the file.
    let text = "v 9 9 9\nv 0 0 0\nv 1 0 0\nf 2 2 3\nf 2 3 4\nv 0 1 0\nf 3 2 4\nv 0 0 1\nf 2 3 5\nv 5 5 5\n";
    let mesh = load(text).unwrap();
    assert_eq!(mesh.vertex_count(), 6);
    assert_eq!(mesh.triangles, vec![1, 1, 2, 1, 2, 3, 2, 1, 3, 1, 2, 4]);
    assert_eq!(mesh.positions[..3], [9.0, 9.0, 9.0]);
}

#[test]
fn extra_vertex_values_crlf_continuations_and_odd_statements_are_tolerated() {
    let text = "v 0 0 0 1.0\r\nv 1 0 0 0.5 0.5 0.5\r\nv 0 1 0\r\nf 1 \\\r\n  2 3\r\nl 1 2\r\np 3\r\ncstype bezier\r\n";
    let mesh = load(text).unwrap();
    assert_eq!(mesh.positions, vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    assert_eq!(mesh.triangles, vec![0, 1, 2]);
}

#[test]
fn a_bad_number_names_its_line() {
    let (message, at) = error(&format!("{SQUARE}v 1 2 x3\nf 1 2 3\n"));
    assert_eq!(at, Some(Position::Line(5)));
    assert_eq!(message, "mesh.obj: line 5: vertex 4: 'x3' is not a number");
    let (message, _) = error(&format!("{SQUARE}v 1 2\n"));
    assert_eq!(message, "mesh.obj: line 5: vertex 4 has no z coordinate");
    let (message, _) = error(&format!("{SQUARE}\n\nf 1 2 three\n"));
    assert_eq!(message, "mesh.obj: line 7: face 0: 'three' is not an integer");
}

#[test]
fn indices_out_of_range_name_the_line_and_the_vertex() {
    let (message, at) = error(&format!("{SQUARE}f 1 2 3\nf 1 5 3\n"));
    assert_eq!(at, Some(Position::Line(6)));
    assert_eq!(message, "mesh.obj: line 6: face 1 uses vertex 5, but there are only 4 vertices");
    let (message, _) = error(&format!("{SQUARE}f 1 -5 3\n"));
    assert!(message.starts_with("mesh.obj: line 5: face 0 uses relative vertex -5"), "{message}");
    let (message, _) = error(&format!("{SQUARE}f 0 1 2\n"));
    assert!(
        message.contains("line 5: face 0 uses vertex 0, but OBJ indices start at 1"),
        "{message}"
    );
    let (message, _) = error(&format!("{SQUARE}f 1 2 99999999999\n"));
    assert!(message.contains("line 5: face 0 uses vertex 99999999999"), "{message}");
}

#[test]
fn faces_of_fewer_than_three_corners_and_non_finite_coordinates_are_rejected() {
    let (message, _) = error(&format!("{SQUARE}f 1 2\n"));
    assert_eq!(message, "mesh.obj: line 5: face 0 has 2 corners, a face needs at least 3");
    for bad in ["nan", "inf", "-infinity", "1e39"] {
        let (message, at) = error(&format!("v 0 0 0\nv 1 {bad} 0\n"));
        assert_eq!(at, Some(Position::Line(2)), "{message}");
        assert!(message.contains("vertex 1 has a non-finite coordinate"), "{message}");
    }
}

#[test]
fn garbage_is_not_a_mesh_but_an_empty_file_is_an_empty_one() {
    assert_eq!(load("").unwrap(), MeshData::default());
    assert_eq!(load("# nothing\n\n").unwrap(), MeshData::default());
    let err = io::load_bytes(b"v \xff\xfe\x00 1 2\n", Format::Obj, "mesh.obj").unwrap_err();
    assert!(err.to_string().starts_with("mesh.obj: line 1: vertex 0: "), "{err}");
}
