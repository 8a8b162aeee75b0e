//! A load names what the file held beyond positions and triangles (issue 35): the cases
//! users met — a scan with flags and quality, colours and double coordinates, a textured
//! OBJ, normals — and the plain files that hold nothing more, which report nothing.

use meshflow_meshio::{Dropped, Format, load_bytes_reporting};

fn dropped(bytes: &[u8], format: Format) -> Dropped {
    load_bytes_reporting(bytes, format, "test").unwrap().dropped
}

fn binary_ply(header: &str, body: &[u8]) -> Vec<u8> {
    let mut bytes = header.as_bytes().to_vec();
    bytes.extend_from_slice(body);
    bytes
}

#[test]
fn a_scan_with_flags_and_quality_names_both() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nproperty uchar flags\nproperty float quality\nelement face 1\n\
               property list uchar int vertex_indices\nend_header\n\
               0 0 0 0 0.5\n1 0 0 1 0.25\n0 1 0 0 1\n3 0 1 2\n";
    let d = dropped(ply.as_bytes(), Format::Ply);
    assert_eq!(d.attributes, ["vertex property 'flags'", "vertex property 'quality'"]);
    assert_eq!(d.rounding, None);
}

#[test]
fn colours_and_double_coordinates_are_named_with_the_largest_rounding() {
    // Binary doubles, one of which (0.1) has no exact f32.
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\n\
                  property double y\nproperty double z\nproperty uchar red\nproperty uchar green\n\
                  property uchar blue\nproperty uchar alpha\nproperty float quality\n\
                  element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let mut body = Vec::new();
    for p in [[0.1f64, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        p.iter().for_each(|c| body.extend_from_slice(&c.to_le_bytes()));
        body.extend_from_slice(&[255, 0, 0, 255]);
        body.extend_from_slice(&0.5f32.to_le_bytes());
    }
    body.push(3);
    [0i32, 1, 2].iter().for_each(|i| body.extend_from_slice(&i.to_le_bytes()));
    let loaded = load_bytes_reporting(&binary_ply(header, &body), Format::Ply, "t").unwrap();
    assert_eq!(loaded.mesh.positions[0], 0.1f32);
    let d = loaded.dropped;
    assert_eq!(
        d.attributes,
        ["vertex colour (red, green, blue, alpha)", "vertex property 'quality'"]
    );
    assert_eq!(d.rounding, Some((0.1f64 - f64::from(0.1f32)).abs()));
    assert!(d.lines().last().unwrap().starts_with("double coordinates, rounded to float"));

    // The same in ascii: the value is what it always was, and the rounding is reported.
    let ascii = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
                 property double z\nelement face 1\nproperty list uchar int vertex_indices\n\
                 end_header\n0.1 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let loaded = load_bytes_reporting(ascii.as_bytes(), Format::Ply, "t").unwrap();
    assert_eq!(loaded.mesh.positions[0], 0.1f32);
    assert_eq!(loaded.dropped.rounding, Some((0.1f64 - f64::from(0.1f32)).abs()));
}

#[test]
fn ply_normals_texture_coordinates_and_other_elements_are_grouped() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
               property float u\nproperty float v\nelement face 1\n\
               property list uchar int vertex_indices\nproperty list uchar float texcoord\n\
               element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
               0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n0 1 0 0 0 1 0 1\n3 0 1 2 6 0 0 1 0 0 1\n0 1\n";
    let d = dropped(ply.as_bytes(), Format::Ply);
    assert_eq!(
        d.attributes,
        [
            "vertex normal (nx, ny, nz)",
            "vertex texture coordinate (u, v)",
            "corner texture coordinates ('texcoord')",
            "element 'edge' (1 records)"
        ]
    );
}

#[test]
fn a_textured_obj_names_its_coordinates_normals_and_material() {
    let obj = "mtllib scan.mtl\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nvt 0 0\nvt 1 0\n\
               vt 0 1\nvn 0 0 1\nusemtl skin\nf 1/1/1 2/2/1 3/3/1\n";
    let d = dropped(obj.as_bytes(), Format::Obj);
    assert_eq!(
        d.attributes,
        [
            "vertex colour (r g b after x y z on 'v' lines)",
            "corner texture coordinates (3 'vt')",
            "normals (1 'vn')",
            "materials and textures (mtllib scan.mtl; usemtl skin)"
        ]
    );
}

#[test]
fn coloured_off_files_name_their_colours() {
    let off = "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n\
               3 0 1 2 10 20 30\n";
    let d = dropped(off.as_bytes(), Format::Off);
    assert_eq!(d.attributes, ["vertex colour (C)", "face colour (values after a face's indices)"]);
}

#[test]
fn stl_colour_words_are_named_and_plain_files_report_nothing() {
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&1u32.to_le_bytes());
    let mut record = vec![0u8; 12];
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        p.iter().for_each(|c| record.extend_from_slice(&c.to_le_bytes()));
    }
    let plain = [stl.clone(), record.clone(), vec![0, 0]].concat();
    assert!(dropped(&plain, Format::Stl).is_empty());
    let coloured = [stl, record, 0x801fu16.to_le_bytes().to_vec()].concat();
    assert_eq!(
        dropped(&coloured, Format::Stl).attributes,
        ["triangle colour (STL attribute words)"]
    );

    let bunny = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/bunny.obj"),
    )
    .unwrap();
    assert!(dropped(&bunny, Format::Obj).is_empty(), "the bunny holds only v and f");
}
